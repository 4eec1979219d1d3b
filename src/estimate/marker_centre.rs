//! Marker centre from the four detected corners (OpenCV order: TL, TR, BR, BL as printed).

use super::config::MarkerCentreMethod;

/// Marker centre in pixels (OpenCV pixel convention) by `method`.
/// `DiagonalIntersection` falls back to the corner mean when the diagonals are parallel
/// (only possible for a degenerate, self-intersecting quadrilateral).
pub fn marker_centre_px(corners_px: &[[f64; 2]; 4], method: MarkerCentreMethod) -> [f64; 2] {
    match method {
        MarkerCentreMethod::CornerMean => corner_mean(corners_px),
        MarkerCentreMethod::DiagonalIntersection => {
            diagonal_intersection(corners_px).unwrap_or_else(|| corner_mean(corners_px))
        }
    }
}

/// Mean of the four corners (the seed's centre).
pub fn corner_mean(c: &[[f64; 2]; 4]) -> [f64; 2] {
    [
        (c[0][0] + c[1][0] + c[2][0] + c[3][0]) / 4.0,
        (c[0][1] + c[1][1] + c[2][1] + c[3][1]) / 4.0,
    ]
}

/// Intersection of the diagonals 0–2 and 1–3; perspective maps the printed centre exactly there.
/// `None` if the diagonals are parallel.
pub fn diagonal_intersection(c: &[[f64; 2]; 4]) -> Option<[f64; 2]> {
    let d1 = [c[2][0] - c[0][0], c[2][1] - c[0][1]];
    let d2 = [c[3][0] - c[1][0], c[3][1] - c[1][1]];
    let denom = d1[0] * d2[1] - d1[1] * d2[0];
    let scale = (d1[0].hypot(d1[1]) * d2[0].hypot(d2[1])).max(f64::MIN_POSITIVE);
    if denom.abs() <= 1e-12 * scale {
        return None;
    }
    let w = [c[1][0] - c[0][0], c[1][1] - c[0][1]];
    let s = (w[0] * d2[1] - w[1] * d2[0]) / denom;
    Some([c[0][0] + s * d1[0], c[0][1] + s * d1[1]])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_centres_agree() {
        let c = [[10.0, 10.0], [30.0, 10.0], [30.0, 30.0], [10.0, 30.0]];
        assert_eq!(corner_mean(&c), [20.0, 20.0]);
        let d = diagonal_intersection(&c).unwrap();
        assert!((d[0] - 20.0).abs() < 1e-12 && (d[1] - 20.0).abs() < 1e-12);
    }

    #[test]
    fn perspective_quad_diagonals_find_projected_centre() {
        // Homography of the unit square [-1,1]²: the centre (0,0) maps to H·(0,0,1).
        let h = [
            [100.0, 10.0, 500.0],
            [5.0, 90.0, 400.0],
            [0.0004, 0.0003, 1.0],
        ];
        let map = |x: f64, y: f64| {
            let w = h[2][0] * x + h[2][1] * y + h[2][2];
            [
                (h[0][0] * x + h[0][1] * y + h[0][2]) / w,
                (h[1][0] * x + h[1][1] * y + h[1][2]) / w,
            ]
        };
        let c = [
            map(-1.0, -1.0),
            map(1.0, -1.0),
            map(1.0, 1.0),
            map(-1.0, 1.0),
        ];
        let truth = map(0.0, 0.0);
        let d = diagonal_intersection(&c).unwrap();
        assert!((d[0] - truth[0]).abs() < 1e-9 && (d[1] - truth[1]).abs() < 1e-9);
        let m = corner_mean(&c);
        // The corner mean is biased under perspective (this is why the diagonal method exists).
        assert!((m[0] - truth[0]).hypot(m[1] - truth[1]) > 0.01);
    }
}
