//! Angles about the rotation centre, unwrapping, and fusion of the five signals.
//!
//! Sign convention: image y points down, so θ = atan2(−(y − c_y), x − c_x): counter-clockwise *as
//! seen on screen* is positive. (The seed used atan2(y − c_y, x − c_x), clockwise-positive.)

/// Wrapped angle of `p` about `c`, counter-clockwise on screen positive, in (−π, π].
pub fn screen_angle_rad(p: [f64; 2], c: [f64; 2]) -> f64 {
    (-(p[1] - c[1])).atan2(p[0] - c[0])
}

/// Fused angle from per-signal unwrapped angles `theta[s][k]` (all present in the same frames)
/// with weights `r_s²`: angular noise of a point at radius r is σ_px / r, so r² is its inverse
/// variance under equal pixel noise. Each signal's constant offset to `theta[reference]` (its
/// mean difference over all frames) is removed first, so the fused angle keeps the reference
/// signal's zero.
pub fn fuse(theta: &[Vec<f64>], radii_px: &[f64], reference: usize) -> Vec<f64> {
    let n = theta.get(reference).map_or(0, |t| t.len());
    let wsum: f64 = radii_px.iter().map(|r| r * r).sum();
    let offsets: Vec<f64> = theta
        .iter()
        .map(|t| {
            t.iter()
                .zip(&theta[reference])
                .map(|(a, b)| a - b)
                .sum::<f64>()
                / n.max(1) as f64
        })
        .collect();
    (0..n)
        .map(|k| {
            theta
                .iter()
                .zip(&offsets)
                .zip(radii_px)
                .map(|((t, o), r)| r * r * (t[k] - o))
                .sum::<f64>()
                / wsum
        })
        .collect()
}
