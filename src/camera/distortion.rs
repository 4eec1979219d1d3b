//! Brown–Conrady distortion in OpenCV's formula, on normalised image coordinates (x/z, y/z).

use glam::DVec2;

use super::LensDistortionConfig;

/// OpenCV's distortion: r² = x² + y², radial = 1 + k1 r² + k2 r⁴ + k3 r⁶,
/// x' = x·radial + 2 p1 x y + p2 (r² + 2x²), y' = y·radial + p1 (r² + 2y²) + 2 p2 x y.
pub fn distort_normalised(d: &LensDistortionConfig, p: DVec2) -> DVec2 {
    let (x, y) = (p.x, p.y);
    let r2 = x * x + y * y;
    let radial = 1.0 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3));
    DVec2::new(
        x * radial + 2.0 * d.p1 * x * y + d.p2 * (r2 + 2.0 * x * x),
        y * radial + d.p1 * (r2 + 2.0 * y * y) + 2.0 * d.p2 * x * y,
    )
}

/// Inverse of [`distort_normalised`] by Newton iteration with a numerical Jacobian; `None` if it
/// does not converge to 1e-14 (distortion not invertible there).
pub fn undistort_normalised(d: &LensDistortionConfig, target: DVec2) -> Option<DVec2> {
    let mut p = target;
    let h = 1e-7;
    for _ in 0..100 {
        let r = distort_normalised(d, p) - target;
        if r.length() < 1e-14 {
            return Some(p);
        }
        let jx = (distort_normalised(d, p + DVec2::X * h)
            - distort_normalised(d, p - DVec2::X * h))
            / (2.0 * h);
        let jy = (distort_normalised(d, p + DVec2::Y * h)
            - distort_normalised(d, p - DVec2::Y * h))
            / (2.0 * h);
        let det = jx.x * jy.y - jy.x * jx.y;
        if !det.is_finite() || det.abs() < 1e-12 {
            return None;
        }
        let step = DVec2::new(jy.y * r.x - jy.x * r.y, -jx.y * r.x + jx.x * r.y) / det;
        p -= step;
        if !p.is_finite() {
            return None;
        }
    }
    (distort_normalised(d, p) - target)
        .length()
        .lt(&1e-12)
        .then_some(p)
}
