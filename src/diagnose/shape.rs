//! The marker's shape as four detected corners: a least-squares affine map from the printed
//! square, split into its conformal part (position, side length, rotation: what a rigid marker
//! shows) and the rest (what rolling shutter, perspective tilt, lens distortion and anisotropic
//! blur add). A rigid marker seen by an ideal camera stays a rigid square.
//!
//! With the printed corners u = (∓½, ∓½) in OpenCV order (TL, TR, BR, BL, y down) and detected
//! corners c_i, the affine fit c ≈ A·u + b has b = mean(c) and A = Σ (c_i − b)·u_iᵀ. A splits
//! uniquely into a conformal part s·R(φ) and an anticonformal part [[a, b],[b, −a]]; written in
//! the image frame (right-multiplied by R(φ)ᵀ and divided by s) the latter is the image-frame
//! stretch [[ε, η],[η, −ε]]: ε > 0 stretches x against y, η > 0 stretches along the diagonal
//! x = y. A rolling shutter reading row y at time ρ·y moves a point with image velocity
//! (v_x, v_y) by (v_x, v_y)·ρ·y, which is ε = −v_y·ρ/2, η = v_x·ρ/2 to first order.

use crate::estimate::Corners;

/// Shape of one detected marker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerShape {
    /// Mean of the four corners, px.
    pub centre_px: [f64; 2],
    /// Side length of the conformal part, px.
    pub side_px: f64,
    /// Rotation of the conformal part, rad (image frame, x towards y).
    pub rotation_rad: f64,
    /// Image-frame stretch ε (x against y), dimensionless.
    pub stretch_x: f64,
    /// Image-frame stretch η (diagonal), dimensionless.
    pub stretch_diag: f64,
    /// RMS distance of the corners from the best similarity (rigid + scale) fit, px.
    pub rigid_residual_px: f64,
}

const PRINTED: [[f64; 2]; 4] = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]];

/// Shape of `corners`; `None` for a degenerate quadrilateral (zero size).
pub fn marker_shape(corners: &Corners) -> Option<MarkerShape> {
    let mut b = [0.0; 2];
    for c in corners {
        b[0] += c[0] / 4.0;
        b[1] += c[1] / 4.0;
    }
    // A = Σ (c − b) uᵀ  (Σ u uᵀ = I for the printed corners).
    let mut a = [[0.0; 2]; 2];
    for (c, u) in corners.iter().zip(PRINTED) {
        for r in 0..2 {
            for k in 0..2 {
                a[r][k] += (c[r] - b[r]) * u[k];
            }
        }
    }
    let p = 0.5 * (a[0][0] + a[1][1]);
    let q = 0.5 * (a[1][0] - a[0][1]);
    let s = p.hypot(q);
    if !(s.is_finite() && s > 1e-9) {
        return None;
    }
    let (an, bn) = (0.5 * (a[0][0] - a[1][1]), 0.5 * (a[0][1] + a[1][0]));
    let phi = q.atan2(p);
    let (cs, sn) = (phi.cos(), phi.sin());
    // [[an, bn],[bn, −an]] · R(φ)ᵀ, R(φ)ᵀ = [[c, s],[−s, c]].
    let e11 = an * cs - bn * sn;
    let e12 = an * sn + bn * cs;
    // Residual of the similarity fit: the corners minus b + s·R(φ)·u.
    let mut ss = 0.0;
    for (c, u) in corners.iter().zip(PRINTED) {
        let x = b[0] + p * u[0] - q * u[1];
        let y = b[1] + q * u[0] + p * u[1];
        ss += (c[0] - x).powi(2) + (c[1] - y).powi(2);
    }
    Some(MarkerShape {
        centre_px: b,
        side_px: s,
        rotation_rad: phi,
        stretch_x: e11 / s,
        stretch_diag: e12 / s,
        rigid_residual_px: (ss / 4.0).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn corners_of(m: [[f64; 2]; 2], b: [f64; 2]) -> Corners {
        PRINTED.map(|u| {
            [
                b[0] + m[0][0] * u[0] + m[0][1] * u[1],
                b[1] + m[1][0] * u[0] + m[1][1] * u[1],
            ]
        })
    }

    #[test]
    fn a_rotated_square_is_rigid() {
        for phi in [0.0, 0.3, -1.2, 2.9] {
            let (c, s) = (f64::cos(phi), f64::sin(phi));
            let m = corners_of(
                [[64.0 * c, -64.0 * s], [64.0 * s, 64.0 * c]],
                [300.0, 200.0],
            );
            let sh = marker_shape(&m).unwrap();
            assert!((sh.side_px - 64.0).abs() < 1e-9);
            assert!((sh.rotation_rad - phi).abs() < 1e-9);
            assert!(sh.stretch_x.abs() < 1e-12 && sh.stretch_diag.abs() < 1e-12);
            assert!(sh.rigid_residual_px < 1e-9);
            assert!((sh.centre_px[0] - 300.0).abs() < 1e-12);
        }
    }

    #[test]
    fn an_image_frame_stretch_is_recovered_whatever_the_marker_rotation() {
        // Image-frame map E = I + [[ε, η],[η, −ε]] applied after the marker's rotation.
        let (eps, eta) = (0.02, -0.013);
        for phi in [0.0f64, 0.7, 2.0, -2.5] {
            let (c, s) = (phi.cos(), phi.sin());
            let r = [[50.0 * c, -50.0 * s], [50.0 * s, 50.0 * c]];
            let e = [[1.0 + eps, eta], [eta, 1.0 - eps]];
            let mut m = [[0.0; 2]; 2];
            for i in 0..2 {
                for j in 0..2 {
                    m[i][j] = e[i][0] * r[0][j] + e[i][1] * r[1][j];
                }
            }
            let sh = marker_shape(&corners_of(m, [0.0, 0.0])).unwrap();
            assert!((sh.stretch_x - eps).abs() < 1e-12, "{phi}: {sh:?}");
            assert!((sh.stretch_diag - eta).abs() < 1e-12, "{phi}: {sh:?}");
            assert!(sh.rigid_residual_px > 0.5);
        }
    }

    #[test]
    fn rolling_shutter_shear_has_the_documented_sign() {
        // Rows read at time ρ·y: x moves by v_x·ρ·y → ε = −v_y ρ/2, η = v_x ρ/2.
        let (vx, vy, rho) = (200.0, -80.0, 2e-5);
        let m = [[1.0, vx * rho], [0.0, 1.0 + vy * rho]].map(|row| row.map(|v| 60.0 * v));
        let sh = marker_shape(&corners_of(m, [500.0, 400.0])).unwrap();
        assert!((sh.stretch_diag - vx * rho / 2.0).abs() < 1e-4, "{sh:?}");
        assert!((sh.stretch_x + vy * rho / 2.0).abs() < 1e-4, "{sh:?}");
    }

    #[test]
    fn degenerate_corners_give_none() {
        assert!(marker_shape(&[[1.0, 1.0]; 4]).is_none());
    }
}
