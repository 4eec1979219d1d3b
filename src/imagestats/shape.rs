//! The marker's shape from its four corners: how far it is from a square (similarity fit) and
//! the affine part of the departure (aspect ratio, shear), which perspective tilt and a rolling
//! shutter produce.

use super::StatsError;

/// Fit of the four corners (OpenCV order) to a square.
#[derive(Debug, Clone, PartialEq)]
pub struct SquareFit {
    /// Centre of the fitted square (mean of the corners), px.
    pub centre_px: [f64; 2],
    /// Side of the best similarity-fitted square, px.
    pub side_px: f64,
    /// Direction of the printed top side (corner 0 → corner 1) in the image, rad, atan2(dy, dx).
    pub angle_rad: f64,
    /// RMS distance of the corners from the fitted square, px (4 degrees of freedom left).
    pub rms_residual_px: f64,
    /// The best affine image of the unit square: corner ≈ centre + A·u with u = (±½, ±½).
    pub affine: [[f64; 2]; 2],
    /// RMS distance of the corners from the affine fit, px (the projective remainder; 2
    /// degrees of freedom left).
    pub affine_rms_residual_px: f64,
    /// √(λmin/λmax) of A·Aᵀ: 1 for a square, cos(tilt) for a small tilt.
    pub aspect: f64,
    /// Image direction of the compressed axis (eigenvector of λmin), rad in (−π/2, π/2].
    pub minor_axis_angle_rad: f64,
    /// Horizontal shear per row of the image-space metric, M₀₁/M₁₁ with M = A·Aᵀ (a rolling
    /// shutter shifts later rows sideways: x' = x + κ·y gives κ for a square).
    pub shear: f64,
    /// Corners used (always 4).
    pub samples: usize,
}

/// Unit-square corners in OpenCV order (x right, y down as printed).
const U: [[f64; 2]; 4] = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]];

/// Fits the four corners to a square and to an affine square.
pub fn square_fit(corners_px: &[[f64; 2]; 4]) -> Result<SquareFit, StatsError> {
    if corners_px.iter().flatten().any(|v| !v.is_finite()) {
        return Err(StatsError::Degenerate {
            corners_px: *corners_px,
            reason: "not finite".into(),
        });
    }
    let c = [
        corners_px.iter().map(|p| p[0]).sum::<f64>() / 4.0,
        corners_px.iter().map(|p| p[1]).sum::<f64>() / 4.0,
    ];
    let q: Vec<[f64; 2]> = corners_px
        .iter()
        .map(|p| [p[0] - c[0], p[1] - c[1]])
        .collect();
    // Similarity: q ≈ [a −b; b a]·u; Σ|u|² = 2.
    let (mut a, mut b) = (0.0, 0.0);
    for (u, q) in U.iter().zip(&q) {
        a += u[0] * q[0] + u[1] * q[1];
        b += u[0] * q[1] - u[1] * q[0];
    }
    a /= 2.0;
    b /= 2.0;
    let side_px = a.hypot(b);
    if side_px < 1e-6 {
        return Err(StatsError::Degenerate {
            corners_px: *corners_px,
            reason: "zero size".into(),
        });
    }
    let sim_ss: f64 = U
        .iter()
        .zip(&q)
        .map(|(u, q)| {
            let p = [a * u[0] - b * u[1], b * u[0] + a * u[1]];
            (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)
        })
        .sum();
    // Affine: Σ u uᵀ = I, so A = Σ q uᵀ.
    let mut m = [[0.0; 2]; 2];
    for (u, q) in U.iter().zip(&q) {
        for i in 0..2 {
            for j in 0..2 {
                m[i][j] += q[i] * u[j];
            }
        }
    }
    let aff_ss: f64 = U
        .iter()
        .zip(&q)
        .map(|(u, q)| {
            let p = [
                m[0][0] * u[0] + m[0][1] * u[1],
                m[1][0] * u[0] + m[1][1] * u[1],
            ];
            (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)
        })
        .sum();
    // Image-space metric M = A·Aᵀ and its eigenvalues.
    let m00 = m[0][0] * m[0][0] + m[0][1] * m[0][1];
    let m01 = m[0][0] * m[1][0] + m[0][1] * m[1][1];
    let m11 = m[1][0] * m[1][0] + m[1][1] * m[1][1];
    let tr = m00 + m11;
    let disc = ((m00 - m11).powi(2) + 4.0 * m01 * m01).sqrt();
    let (l_max, l_min) = (0.5 * (tr + disc), 0.5 * (tr - disc));
    let major = 0.5 * (2.0 * m01).atan2(m00 - m11);
    let mut minor = major + std::f64::consts::FRAC_PI_2;
    if minor > std::f64::consts::FRAC_PI_2 {
        minor -= std::f64::consts::PI;
    }
    Ok(SquareFit {
        centre_px: c,
        side_px,
        angle_rad: b.atan2(a),
        rms_residual_px: (sim_ss / 4.0).sqrt(),
        affine: m,
        affine_rms_residual_px: (aff_ss / 4.0).sqrt(),
        aspect: if l_max > 0.0 {
            (l_min.max(0.0) / l_max).sqrt()
        } else {
            0.0
        },
        minor_axis_angle_rad: minor,
        shear: if m11 > 0.0 { m01 / m11 } else { 0.0 },
        samples: 4,
    })
}
