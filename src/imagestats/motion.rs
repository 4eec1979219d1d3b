//! The rigid motion of the image between two frames over the overlap of two windows: a
//! sub-pixel shift and a small turn about the overlap's centre, fitted by linearised least
//! squares on the frames' gradients (Lucas & Kanade 1981, with the rotation term of the
//! rigid-motion model; the gradient of the two frames' mean, so that neither frame is the
//! reference).
//!
//! It tells a still marker from one that moves by a tenth of a pixel whatever the camera's
//! processing does to the noise. A comparison of frame differences on edges against flat
//! regions does not: a video codec, demosaicking and sharpening make the noise several times
//! larger on edges than in flat regions (on path-traced footage through a phone model, 4–7
//! times on a wheel at rest), which such a comparison reads as motion. Here noise, wherever it
//! sits, averages out over the window's hundreds of edge pixels, and only a displacement shared
//! by all of them remains.

use super::{pixel, view_bounds, StatsError};
use crate::detect::GrayView;
use nalgebra::{Matrix3, Vector3};

/// The image's rigid motion from frame `a` to frame `b`: `b(x) ≈ a(x − d(x))` with
/// `d(x) = shift + turn × (x − centre)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMotion {
    /// The shift at the overlap's centre, px (x right, y down).
    pub shift_px: [f64; 2],
    /// The turn about the overlap's centre, rad (from +x towards +y).
    pub turn_rad: f64,
    /// The distance from the centre at which the overlap's structure sits: the RMS distance of
    /// its pixels weighted by their squared gradient, px (the turn moves the structure by
    /// `turn_rad · reach_px`).
    pub reach_px: f64,
    /// Pixels the fit used.
    pub pixels: usize,
}

impl RigidMotion {
    /// The displacement of the overlap's structure, px: the shift's length plus the turn's arc
    /// at the structure's reach (an upper bound of the displacement there).
    pub fn max_displacement_px(&self) -> f64 {
        self.shift_px[0].hypot(self.shift_px[1]) + self.turn_rad.abs() * self.reach_px
    }
}

/// Least pixels with a usable gradient for a fit.
const MIN_PIXELS: usize = 50;

/// The rigid motion between `a` and `b` over the overlap of the two views (absolute pixel
/// coordinates; the outermost row and column of the overlap only feed the gradient). An error
/// when the overlap is too small or holds no structure that pins a motion (a flat patch, a
/// single straight edge).
pub fn rigid_motion(a: &GrayView<'_>, b: &GrayView<'_>) -> Result<RigidMotion, StatsError> {
    let (ax0, ay0, ax1, ay1) = view_bounds(a);
    let (bx0, by0, bx1, by1) = view_bounds(b);
    let (x0, y0, x1, y1) = (
        ax0.max(bx0) + 1,
        ay0.max(by0) + 1,
        ax1.min(bx1) - 1,
        ay1.min(by1) - 1,
    );
    let too_few = |got| StatsError::TooFew {
        what: "rigid motion between two frames".into(),
        got,
        need: MIN_PIXELS,
    };
    if x1 < x0 || y1 < y0 {
        return Err(too_few(0));
    }
    let (cx, cy) = (0.5 * (x0 + x1) as f64, 0.5 * (y0 + y1) as f64);
    let mean = |x: i64, y: i64| -> f64 {
        // Inside both views by construction of the overlap (one pixel of margin).
        let p = |v: &GrayView<'_>| pixel(v, x, y).map_or(0.0, f64::from);
        0.5 * (p(a) + p(b))
    };
    let mut normal = Matrix3::<f64>::zeros();
    let mut rhs = Vector3::<f64>::zeros();
    let mut pixels = 0usize;
    let (mut weighted_r2, mut weight) = (0.0, 0.0);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let gx = 0.5 * (mean(x + 1, y) - mean(x - 1, y));
            let gy = 0.5 * (mean(x, y + 1) - mean(x, y - 1));
            if gx == 0.0 && gy == 0.0 {
                continue;
            }
            let (rx, ry) = (x as f64 - cx, y as f64 - cy);
            let row = Vector3::new(gx, gy, gx * -ry + gy * rx);
            let diff =
                pixel(b, x, y).map_or(0.0, f64::from) - pixel(a, x, y).map_or(0.0, f64::from);
            let g2 = gx * gx + gy * gy;
            weighted_r2 += g2 * (rx * rx + ry * ry);
            weight += g2;
            normal += row * row.transpose();
            rhs -= row * diff;
            pixels += 1;
        }
    }
    if pixels < MIN_PIXELS {
        return Err(too_few(pixels));
    }
    // A patch whose gradients span fewer than three directions of motion (flat, one straight
    // edge, a disc about the centre) does not pin the motion: its normal matrix is singular
    // against its own scale.
    let eig = normal.symmetric_eigenvalues();
    let (lo, hi) = (eig.min(), eig.max());
    if hi <= 0.0 || lo < 1e-9 * hi {
        return Err(StatsError::NoFit {
            what: "rigid motion between two frames".into(),
            reason: "the overlap's gradients do not pin a shift and a turn".into(),
        });
    }
    let solution = normal
        .cholesky()
        .map(|c| c.solve(&rhs))
        .ok_or_else(|| StatsError::NoFit {
            what: "rigid motion between two frames".into(),
            reason: "the normal equations are not positive definite".into(),
        })?;
    let reach_px = (weighted_r2 / weight).sqrt();
    Ok(RigidMotion {
        shift_px: [solution[0], solution[1]],
        turn_rad: solution[2],
        reach_px,
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64 as Rng64;

    /// A blurred dark square (side 40 px, centred at `centre`, turned by `turn_rad` about it) on
    /// a light ground, 80×80 px at origin `origin`: grey level 50 inside, 200 outside, edges
    /// blurred by a logistic of 0.7 px.
    fn square(centre: [f64; 2], turn_rad: f64, origin: (i32, i32)) -> Vec<f64> {
        let (s, c) = turn_rad.sin_cos();
        let mut out = Vec::with_capacity(80 * 80);
        for j in 0..80 {
            for i in 0..80 {
                let (x, y) = (
                    (origin.0 + i) as f64 - centre[0],
                    (origin.1 + j) as f64 - centre[1],
                );
                // Into the square's own frame.
                let (u, v) = (c * x + s * y, -s * x + c * y);
                let inside = |d: f64| 1.0 / (1.0 + (-(20.0 - d.abs()) / 0.7).exp());
                let k = inside(u) * inside(v);
                out.push(200.0 - 150.0 * k);
            }
        }
        out
    }

    fn quantise(img: &[f64], noise_dn: impl Fn(usize) -> f64, rng: &mut Rng64) -> Vec<u8> {
        img.iter()
            .enumerate()
            .map(|(k, v)| {
                let n: f64 = rng.sample::<f64, _>(rand_distr::StandardNormal) * noise_dn(k);
                (v + n).round().clamp(0.0, 255.0) as u8
            })
            .collect()
    }

    fn view(data: &[u8], origin: (i32, i32)) -> GrayView<'_> {
        GrayView {
            data,
            width: 80,
            height: 80,
            origin_px: origin,
        }
    }

    #[test]
    fn a_sub_pixel_shift_and_turn_are_recovered() {
        let mut rng = Rng64::seed_from_u64(1);
        let origin = (100, 200);
        let c0 = [140.0, 240.0];
        for (shift, turn) in [
            ([0.05, 0.0], 0.0),
            ([0.0, -0.1], 0.0),
            ([0.2, 0.15], 0.0),
            ([0.0, 0.0], 0.004),
            ([0.1, -0.05], -0.003),
        ] {
            let a = quantise(&square(c0, 0.0, origin), |_| 1.0, &mut rng);
            let moved = [c0[0] + shift[0], c0[1] + shift[1]];
            let b = quantise(&square(moved, turn, origin), |_| 1.0, &mut rng);
            let m = rigid_motion(&view(&a, origin), &view(&b, origin)).unwrap();
            // The overlap's centre is the square's centre (the window is centred on it), so
            // the fitted shift is the square's.
            for k in 0..2 {
                assert!(
                    (m.shift_px[k] - shift[k]).abs() < 0.01 + 0.1 * shift[k].abs(),
                    "shift {shift:?} turn {turn}: got {m:?}"
                );
            }
            assert!(
                (m.turn_rad - turn).abs() < 3e-4 + 0.1 * turn.abs(),
                "shift {shift:?} turn {turn}: got {m:?}"
            );
        }
    }

    /// Noise that a codec or a demosaicker leaves mostly on the edges (here five times the
    /// flat regions' σ, as on path-traced footage through a phone model at rest) does not read
    /// as motion: over 20 pairs of frames the fitted displacement stays under a tenth of a
    /// pixel (its sampling σ is about 0.02 px here), while the frame differences on the edges
    /// are several times those in flat regions.
    #[test]
    fn noise_on_the_edges_is_not_motion() {
        let mut rng = Rng64::seed_from_u64(2);
        let origin = (0, 0);
        let clean = square([40.0, 40.0], 0.0, origin);
        // The edge band: where the clean image is neither level.
        let on_edge = |k: usize| clean[k] > 55.0 && clean[k] < 195.0;
        let noise = |k: usize| if on_edge(k) { 5.0 } else { 1.0 };
        let mut worst: f64 = 0.0;
        let (mut edge_diff, mut flat_diff, mut ne, mut nf) = (0.0, 0.0, 0usize, 0usize);
        for _ in 0..20 {
            let a = quantise(&clean, noise, &mut rng);
            let b = quantise(&clean, noise, &mut rng);
            let m = rigid_motion(&view(&a, origin), &view(&b, origin)).unwrap();
            worst = worst.max(m.max_displacement_px());
            for k in 0..a.len() {
                let d = (a[k] as f64 - b[k] as f64).abs();
                if on_edge(k) {
                    edge_diff += d;
                    ne += 1;
                } else {
                    flat_diff += d;
                    nf += 1;
                }
            }
        }
        let ratio = (edge_diff / ne as f64) / (flat_diff / nf as f64);
        assert!(
            ratio > 3.0,
            "the edges' differences are {ratio:.2} × the flat's"
        );
        assert!(
            worst < 0.1,
            "noise on the edges read as a motion of {worst:.3} px"
        );
    }

    #[test]
    fn windows_with_other_origins_are_compared_where_they_overlap() {
        let mut rng = Rng64::seed_from_u64(3);
        let c0 = [140.0, 240.0];
        let a = quantise(&square(c0, 0.0, (100, 200)), |_| 0.5, &mut rng);
        let shifted = [c0[0] + 0.08, c0[1]];
        let b = quantise(&square(shifted, 0.0, (103, 198)), |_| 0.5, &mut rng);
        let m = rigid_motion(&view(&a, (100, 200)), &view(&b, (103, 198))).unwrap();
        assert!((m.shift_px[0] - 0.08).abs() < 0.015, "{m:?}");
        assert!(m.shift_px[1].abs() < 0.015, "{m:?}");
    }

    #[test]
    fn a_flat_patch_or_no_overlap_is_an_error() {
        let flat = vec![120u8; 80 * 80];
        assert!(matches!(
            rigid_motion(&view(&flat, (0, 0)), &view(&flat, (0, 0))),
            Err(StatsError::TooFew { .. })
        ));
        let mut rng = Rng64::seed_from_u64(4);
        let a = quantise(&square([40.0, 40.0], 0.0, (0, 0)), |_| 0.5, &mut rng);
        assert!(matches!(
            rigid_motion(&view(&a, (0, 0)), &view(&a, (500, 500))),
            Err(StatsError::TooFew { got: 0, .. })
        ));
        // One straight edge pins the motion across it, not along it.
        let edge: Vec<u8> = (0..80 * 80)
            .map(|k| if k % 80 < 40 { 50 } else { 200 })
            .collect();
        assert!(matches!(
            rigid_motion(&view(&edge, (0, 0)), &view(&edge, (0, 0))),
            Err(StatsError::NoFit { .. })
        ));
    }
}
