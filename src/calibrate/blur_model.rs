//! The renderer's blur as the edge fit sees it: maps a measured edge-profile σ to the
//! scenario's `optical_blur.sigma_px`.
//!
//! The edge fit (`imagestats::edge`) models a continuous Gaussian PSF convolved with the pixel
//! box. The renderer blurs its exact area coverage with a Gaussian kernel sampled at whole
//! pixels (`render::effects::optical_blur`). Below about 0.7 px the two differ in shape, not
//! only in variance: the sampled kernel is a centre spike with small side weights, and the
//! Gaussian that fits its edge profile best is not the one of equal variance. Mapping the
//! measured σ through the kernel's variance alone (`sigma_for_effective_px`) therefore
//! underestimated blur σ below 0.5 px by about 0.03 px (the round trip's misses at σ < 0.4 px).
//! Here the fit itself is modelled: the renderer's edge profile is computed for a given
//! `sigma_px` at the edges' orientations and fitted with the edge fit's model (levels free),
//! and that response is inverted. On JPEG footage the modelled edge also goes through the
//! codec at the footage's quality and levels (the quantised block DCT coefficients sharpen or
//! smear an edge a little, which the fit reads as blur).

use crate::imagestats::step_response;
use crate::numeric::minimize::golden_section_min;
use crate::render::effects::compression::jpeg_round_trip;
use crate::render::effects::optical_blur::{kernel, OpticalBlurConfig};

/// Half-width of the modelled band across the edge, px, and the sampling step along it.
const BAND_PX: f64 = 6.0;
const STEP_PX: f64 = 0.02;

/// Orientation bins of the edge normal, folded to [0°, 45°] (the separable kernel and the pixel
/// box are symmetric under quarter turns and reflections).
pub const ANGLE_BINS: usize = 5;

/// Bin of an edge whose unit normal is `normal`.
pub fn angle_bin(normal: [f64; 2]) -> usize {
    let (a, b) = (normal[0].abs(), normal[1].abs());
    let folded = a.min(b).atan2(a.max(b)); // [0, π/4]
    ((folded / std::f64::consts::FRAC_PI_4) * (ANGLE_BINS - 1) as f64).round() as usize
}

fn bin_angle(bin: usize) -> f64 {
    std::f64::consts::FRAC_PI_4 * bin as f64 / (ANGLE_BINS - 1) as f64
}

/// The renderer's separable kernel for `sigma_px` as (weight, offset i, offset j) taps.
fn kernel_taps(sigma_px: f64) -> Vec<(f64, f64, f64)> {
    let cfg = OpticalBlurConfig {
        enabled: true,
        sigma_px,
    };
    let r = cfg.radius_px() as i64;
    let w: Vec<f64> = if r == 0 {
        vec![1.0]
    } else {
        kernel(sigma_px, r as usize)
            .iter()
            .map(|&v| v as f64)
            .collect()
    };
    let mut taps = Vec::new();
    for i in -r..=r {
        for j in -r..=r {
            taps.push((
                w[(i + r) as usize] * w[(j + r) as usize],
                i as f64,
                j as f64,
            ));
        }
    }
    taps
}

/// Box projections (a ≥ b) of the pixel square on a normal at `angle_rad`.
fn box_of(angle_rad: f64) -> (f64, f64) {
    let (c, s) = (angle_rad.cos().abs(), angle_rad.sin().abs());
    (c.max(s), c.min(s))
}

/// The rendered 0 → 1 edge at signed distance `x` px along the normal (`angle_rad`): the exact
/// pixel coverage of a step blurred by the kernel `taps`.
fn rendered_step(x: f64, angle_rad: f64, taps: &[(f64, f64, f64)]) -> f64 {
    let (a, b) = box_of(angle_rad);
    let (c, s) = (angle_rad.cos(), angle_rad.sin());
    // An ideal step seen through the pixel box (a vanishing σ: the box alone).
    taps.iter()
        .map(|&(w, i, j)| w * step_response(x - (i * c + j * s), 1e-4, a, b))
        .sum()
}

/// The edge fit's σ on samples (distance along the normal, value): the model
/// `lo + gain·step_response(x, σ)` with the levels solved linearly, σ by golden section.
fn fit_sigma(samples: &[(f64, f64)], angle_rad: f64, upper: f64) -> f64 {
    let (a, b) = box_of(angle_rad);
    let nf = samples.len() as f64;
    let misfit = |sigma: f64| -> f64 {
        let m: Vec<f64> = samples
            .iter()
            .map(|&(x, _)| step_response(x, sigma, a, b))
            .collect();
        let (sm, sd) = (
            m.iter().sum::<f64>(),
            samples.iter().map(|p| p.1).sum::<f64>(),
        );
        let smm = m.iter().map(|v| v * v).sum::<f64>();
        let smd = m.iter().zip(samples).map(|(p, q)| p * q.1).sum::<f64>();
        let det = nf * smm - sm * sm;
        let (lo, gain) = if det.abs() > 1e-12 {
            ((smm * sd - sm * smd) / det, (nf * smd - sm * sd) / det)
        } else {
            (0.0, 1.0)
        };
        m.iter()
            .zip(samples)
            .map(|(p, q)| (lo + gain * p - q.1).powi(2))
            .sum()
    };
    golden_section_min(misfit, 1e-3, upper, 40)
}

/// σ that the edge fit returns on a noiseless edge rendered with `sigma_px` whose normal makes
/// `angle_rad` with the pixel rows.
pub fn fitted_sigma(sigma_px: f64, angle_rad: f64) -> f64 {
    let taps = kernel_taps(sigma_px);
    let n = (2.0 * BAND_PX / STEP_PX) as usize + 1;
    let samples: Vec<(f64, f64)> = (0..n)
        .map(|k| {
            let x = -BAND_PX + k as f64 * STEP_PX;
            (x, rendered_step(x, angle_rad, &taps))
        })
        .collect();
    fit_sigma(&samples, angle_rad, sigma_px.max(0.1) * 1.5 + 0.5)
}

/// JPEG footage: the levels and quality the edges were compressed with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JpegEdges {
    pub ink_dn: f64,
    pub paper_dn: f64,
    pub quality: u8,
}

/// Side of the compressed patch, px (six 8×8 blocks).
const PATCH_PX: usize = 48;

/// The same on an edge rendered between the footage's levels, rounded to 8 bits and passed
/// through a JPEG round trip at its quality, at four offsets from the 8×8 block grid: the
/// codec's quantisation of the edge's DCT coefficients changes the profile the fit sees.
pub fn fitted_sigma_jpeg(sigma_px: f64, angle_rad: f64, jpeg: &JpegEdges) -> f64 {
    let taps = kernel_taps(sigma_px);
    let (c, s) = (angle_rad.cos(), angle_rad.sin());
    let centre = 0.5 * (PATCH_PX as f64 - 1.0);
    let mut total = 0.0;
    let offsets = [0.0, 2.1, 4.3, 6.4];
    for d0 in offsets {
        let dist = |x: usize, y: usize| (x as f64 - centre) * c + (y as f64 - centre) * s - d0;
        let img: Vec<u8> = (0..PATCH_PX * PATCH_PX)
            .map(|k| {
                let v = jpeg.ink_dn
                    + (jpeg.paper_dn - jpeg.ink_dn)
                        * rendered_step(dist(k % PATCH_PX, k / PATCH_PX), angle_rad, &taps);
                (v + 0.5).clamp(0.0, 255.0) as u8
            })
            .collect();
        let Ok(out) = jpeg_round_trip(&img, PATCH_PX, PATCH_PX, jpeg.quality) else {
            return fitted_sigma(sigma_px, angle_rad);
        };
        let samples: Vec<(f64, f64)> = (0..PATCH_PX * PATCH_PX)
            .filter_map(|k| {
                let (x, y) = (k % PATCH_PX, k / PATCH_PX);
                let inside = (4..PATCH_PX - 4).contains(&x) && (4..PATCH_PX - 4).contains(&y);
                let d = dist(x, y);
                (inside && d.abs() <= BAND_PX).then_some((d, out[k] as f64))
            })
            .collect();
        total += fit_sigma(&samples, angle_rad, sigma_px.max(0.1) * 1.5 + 0.5);
    }
    total / offsets.len() as f64
}

/// The fitted σ averaged over the edges' orientations: `weights[bin]` edges in each bin.
fn mean_fitted_sigma(
    sigma_px: f64,
    weights: &[usize; ANGLE_BINS],
    jpeg: Option<&JpegEdges>,
) -> f64 {
    let one = |angle: f64| match jpeg {
        Some(j) => fitted_sigma_jpeg(sigma_px, angle, j),
        None => fitted_sigma(sigma_px, angle),
    };
    let total: usize = weights.iter().sum();
    if total == 0 {
        return one(0.0);
    }
    weights
        .iter()
        .enumerate()
        .filter(|(_, &k)| k > 0)
        .map(|(bin, &k)| k as f64 * one(bin_angle(bin)))
        .sum::<f64>()
        / total as f64
}

/// The scenario's `optical_blur.sigma_px` whose rendered edges the edge fit measures as
/// `measured_px` on edges spread over the orientation bins as `weights` (bisection; the
/// response is monotone), through a JPEG round trip when the footage is compressed. Above
/// 1.5 px the sampled kernel is a Gaussian to within 10⁻³ px and the codec leaves such soft
/// edges alone: the measured σ is returned as it is.
pub fn sigma_param_for_measured(
    measured_px: f64,
    weights: &[usize; ANGLE_BINS],
    jpeg: Option<&JpegEdges>,
) -> f64 {
    if !(measured_px.is_finite() && measured_px > 0.0) {
        return 0.0;
    }
    if measured_px > 1.5 {
        return measured_px;
    }
    let (mut lo, mut hi) = (0.0, 1.6);
    for _ in 0..24 {
        let mid = 0.5 * (lo + hi);
        if mean_fitted_sigma(mid, weights, jpeg) < measured_px {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wide_kernels_are_measured_as_they_are() {
        for s in [0.8, 1.2, 1.5] {
            for bin in 0..ANGLE_BINS {
                let f = fitted_sigma(s, bin_angle(bin));
                assert!((f - s).abs() < 0.01, "σ {s} bin {bin}: fitted {f}");
            }
        }
    }

    #[test]
    fn narrow_kernels_look_sharper_than_their_parameter() {
        // The sampled kernel at 0.3–0.5 px blurs less than a Gaussian of that σ, and the
        // response grows with σ.
        let w = [1, 0, 0, 0, 0];
        let f: Vec<f64> = [0.3, 0.4, 0.5, 0.6]
            .iter()
            .map(|&s| mean_fitted_sigma(s, &w, None))
            .collect();
        assert!(f[0] < 0.3 && f[1] < 0.4 && f[2] < 0.5, "{f:?}");
        assert!(f.windows(2).all(|p| p[1] > p[0]), "{f:?}");
    }

    #[test]
    fn the_inverse_recovers_the_parameter() {
        let w = [3, 1, 0, 2, 1];
        for s in [0.3, 0.37, 0.45, 0.6, 0.9, 1.4] {
            let m = mean_fitted_sigma(s, &w, None);
            let back = sigma_param_for_measured(m, &w, None);
            assert!((back - s).abs() < 2e-3, "σ {s}: measured {m}, back {back}");
        }
    }

    #[test]
    fn jpeg_edges_are_inverted_through_the_codec() {
        let j = JpegEdges {
            ink_dn: 40.0,
            paper_dn: 200.0,
            quality: 75,
        };
        let w = [2, 0, 1, 0, 0];
        let m = mean_fitted_sigma(0.35, &w, Some(&j));
        let back = sigma_param_for_measured(m, &w, Some(&j));
        assert!((back - 0.35).abs() < 0.01, "measured {m}, back {back}");
    }

    #[test]
    fn angle_bins_fold_the_quadrants() {
        assert_eq!(angle_bin([1.0, 0.0]), 0);
        assert_eq!(angle_bin([0.0, -1.0]), 0);
        let d = std::f64::consts::FRAC_1_SQRT_2;
        assert_eq!(angle_bin([-d, d]), ANGLE_BINS - 1);
    }
}
