//! The re-render check's pose alignment (pure): footage − calibrated render over the marker
//! window, with the render first moved by the sub-pixel pose correction (shift, rotation and
//! scale about the marker's centre) that fits best, linearised on the render's gradients.
//!
//! Why: at sub-DN noise an edge shifted by a few hundredths of a pixel, well within the fitted
//! pose's uncertainty, is most of footage − render (round trip case 34: 1.05 DN against 0.78 DN
//! of noise, 0.83 DN after a (−0.03, 0.05) px shift). The check is there to show that the image
//! formation (levels, blur, noise, codec) reproduces the footage; the pose has its own checks.
//! A correction that moves a corner by more than [`MAX_ALIGNMENT_PX`] is no nuisance: then the
//! residual stays unaligned.

use crate::numeric::linalg::solve_rows;

/// Largest movement of a marker corner the alignment may make, px. Four times the largest
/// correction the calibration round trip needed (0.05 px): the aligned residual also feeds
/// calibrate's misfit guard, and a wider allowance would let a pose error of a good part of a
/// pixel pass it.
pub const MAX_ALIGNMENT_PX: f64 = 0.2;

/// One pixel of the comparison: footage − render, DN, and the render's change per unit of each
/// pose correction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelResidual {
    pub difference_dn: f64,
    pub jacobian: [f64; 4],
}

impl PixelResidual {
    /// The pixel at offset (`rx_px`, `ry_px`) from the marker's centre, where the render's
    /// gradient is (`gx`, `gy`) DN/px. A correction p = (shift x, shift y, rotation in rad,
    /// relative scale) moves the render's content by δ = (p₀ − p₂·ry + p₃·rx, p₁ + p₂·rx + p₃·ry),
    /// and render(x − δ) ≈ render − ∇render·δ.
    pub fn new(difference_dn: f64, gx: f64, gy: f64, rx_px: f64, ry_px: f64) -> PixelResidual {
        PixelResidual {
            difference_dn,
            jacobian: [
                -gx,
                -gy,
                -(-gx * ry_px + gy * rx_px),
                -(gx * rx_px + gy * ry_px),
            ],
        }
    }
}

/// The alignment's outcome.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    /// Σ difference² before and after the correction (after = before when rejected), DN².
    pub unaligned_ss: f64,
    pub aligned_ss: f64,
    /// Shift x, y (px), rotation (rad), relative scale; `None` when singular or too large.
    pub correction: Option<[f64; 4]>,
}

/// Least-squares pose correction of `pixels`; a marker whose corners lie `half_diagonal_px`
/// from its centre.
pub fn align(pixels: &[PixelResidual], half_diagonal_px: f64) -> Alignment {
    let unaligned_ss: f64 = pixels.iter().map(|p| p.difference_dn.powi(2)).sum();
    let mut normal = vec![vec![0.0; 4]; 4];
    let mut rhs = vec![0.0; 4];
    for p in pixels {
        for (r, row) in normal.iter_mut().enumerate() {
            rhs[r] += p.jacobian[r] * p.difference_dn;
            for (c, v) in row.iter_mut().enumerate() {
                *v += p.jacobian[r] * p.jacobian[c];
            }
        }
    }
    let correction = solve_rows(&normal, &rhs)
        .filter(|c| c.iter().all(|v| v.is_finite()))
        .filter(|c| {
            c[0].hypot(c[1]) + half_diagonal_px * (c[2].abs() + c[3].abs()) <= MAX_ALIGNMENT_PX
        })
        .map(|c| [c[0], c[1], c[2], c[3]]);
    let aligned_ss = match &correction {
        Some(c) => pixels
            .iter()
            .map(|p| {
                let fit: f64 = (0..4).map(|k| p.jacobian[k] * c[k]).sum();
                (p.difference_dn - fit).powi(2)
            })
            .sum(),
        None => unaligned_ss,
    };
    Alignment {
        unaligned_ss,
        aligned_ss,
        correction,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A blurred bright square of half-side 20 px on a dark ground, centred at (cx, cy), rotated
    /// by `rot` rad and scaled by 1 + `scale`: an analytic image with gradients everywhere on
    /// its edges.
    fn square(x: f64, y: f64, (cx, cy): (f64, f64), rot: f64, scale: f64) -> f64 {
        let (dx, dy) = (x - cx, y - cy);
        let (c, s) = (rot.cos(), rot.sin());
        let (u, v) = (c * dx + s * dy, -s * dx + c * dy);
        let h = 20.0 * (1.0 + scale);
        let edge =
            |t: f64| 0.5 * (1.0 + crate::numeric::dist::erf((h - t.abs()) / (1.2 * 2f64.sqrt())));
        40.0 + 150.0 * edge(u) * edge(v)
    }

    fn pixels(truth: ([f64; 2], f64, f64)) -> Vec<PixelResidual> {
        let centre = (50.0, 50.0);
        let moved = (centre.0 + truth.0[0], centre.1 + truth.0[1]);
        let mut out = Vec::new();
        for y in 20..80 {
            for x in 20..80 {
                let (xf, yf) = (x as f64, y as f64);
                let render = |x: f64, y: f64| square(x, y, centre, 0.0, 0.0);
                let footage = square(xf, yf, moved, truth.1, truth.2);
                let gx = 0.5 * (render(xf + 1.0, yf) - render(xf - 1.0, yf));
                let gy = 0.5 * (render(xf, yf + 1.0) - render(xf, yf - 1.0));
                out.push(PixelResidual::new(
                    footage - render(xf, yf),
                    gx,
                    gy,
                    xf - centre.0,
                    yf - centre.1,
                ));
            }
        }
        out
    }

    #[test]
    fn a_small_pose_error_is_recovered_and_removed() {
        let truth = ([0.04, -0.03], 0.0004, 0.0008);
        let a = align(&pixels(truth), 20.0 * 2f64.sqrt());
        let c = a.correction.expect("accepted");
        // The rotation sign: the footage's square is turned by −rot in image coordinates.
        assert!((c[0] - truth.0[0]).abs() < 0.005, "{c:?}");
        assert!((c[1] - truth.0[1]).abs() < 0.005, "{c:?}");
        assert!((c[2].abs() - truth.1).abs() < 0.0001, "{c:?}");
        assert!((c[3] - truth.2).abs() < 0.0002, "{c:?}");
        assert!(a.aligned_ss < 0.01 * a.unaligned_ss, "{a:?}");
    }

    #[test]
    fn a_large_pose_error_is_not_aligned_away() {
        let a = align(&pixels(([0.9, 0.0], 0.0, 0.0)), 20.0 * 2f64.sqrt());
        assert_eq!(a.correction, None);
        assert_eq!(a.aligned_ss, a.unaligned_ss);
        let flat = vec![PixelResidual::new(1.0, 0.0, 0.0, 1.0, 1.0); 10];
        assert_eq!(align(&flat, 10.0).correction, None);
    }
}
