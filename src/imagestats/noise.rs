//! Pixel noise of one frame that texture cannot pass for: the weak-texture patch selection of
//! Liu, Tanaka & Okutomi (2013) with the noise variance read from the selected patches'
//! covariance eigenvalues as Chen, Zhu & Heng (2015) do.
//!
//! A region's plain spatial σ (`RegionStats::noise_sigma_dn`) is everything that varies there:
//! sensor noise, but also print mottle, paper fibre, tape, stains and whatever the phone's
//! denoiser and codec left. Here the region is cut into all d×d patches that lie inside it:
//!
//! - **Weak-texture selection** (Liu, Tanaka & Okutomi, "Single-image noise level estimation for
//!   blind denoising", IEEE TIP 22(12):5226–5237, 2013): a patch's texture strength ξ is the sum
//!   of its squared central differences ([−½, 0, ½] across and down, the valid part of the
//!   patch). On a flat patch with white noise of variance σ², ξ = nᵀ(DhᵀDh + DvᵀDv)n follows
//!   approximately a Gamma law of shape r/2 and scale 2σ²·tr/r, with tr = tr(DhᵀDh + DvᵀDv) =
//!   d(d − 2) and r = its rank, d² − 4 (the four parity classes of a patch are invisible to a
//!   central difference). Patches with ξ above its 1 − 10⁻⁶ quantile (their paper's confidence)
//!   hold texture and are left out; the selection and σ are iterated to a fixed point.
//! - **Noise variance from the eigenvalues** (Chen, Zhu & Heng, "An efficient statistical method
//!   for image noise level estimation", ICCV 2015): the patch covariance of white noise is σ²·I;
//!   structure adds a few large eigenvalues. σ² is the mean of the smallest eigenvalues, taken
//!   from the largest set whose mean does not exceed its median (the noise eigenvalues spread
//!   symmetrically about σ², structure only above). Liu et al. take the smallest eigenvalue
//!   alone, which a finite sample biases low by about (1 − √(d²/M))² for M patches
//!   (Marchenko–Pastur): 40 % low on the few hundred patches of a small marker's ink.
//!
//! What a frame can and cannot say ([`WeakTextureNoise::not_identifiable`]): on a flat region
//! under white sensor noise the selected patches' mean texture strength is tr·σ² (the law
//! above) and almost every eigenvalue is a noise eigenvalue. When the flattest patches vary
//! between neighbours more (or less) than white noise of their σ would, or few eigenvalues are
//! noise eigenvalues, the variation is not white: texture at the patch's scale, or noise that
//! demosaicing, denoising or a codec correlated between neighbours, whose smallest eigenvalues
//! see only its high frequencies. Then one frame cannot tell the sensor's noise from the scene,
//! and the estimate says so rather than give a number.

use super::{check_view, pixel, StatsError};
use crate::detect::GrayView;
use nalgebra::{DMatrix, SymmetricEigen};
use statrs::distribution::{ContinuousCDF, Gamma};

/// Options of the weak-texture estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct WeakTextureOptions {
    /// Patch sides tried, largest first; the largest with at least `patches_per_dim` patches per
    /// patch dimension (d²) is used. Default [7, 5, 3].
    pub patch_sides_px: Vec<usize>,
    /// Patches needed per patch dimension: with fewer the eigenvalues spread too wide for the
    /// tail's mean to stay within a few per cent. Default 30 (bias below 2 % on white noise).
    pub patches_per_dim: usize,
    /// Probability that a flat patch under white noise passes the texture test. Default 1 − 10⁻⁶
    /// (Liu et al.'s): the selection itself then biases σ by less than 0.1 %.
    pub confidence: f64,
    /// Iterations of selection and estimate at most. Default 10.
    pub max_iterations: usize,
}

impl Default for WeakTextureOptions {
    fn default() -> Self {
        Self {
            patch_sides_px: vec![7, 5, 3],
            patches_per_dim: 30,
            confidence: 1.0 - 1e-6,
            max_iterations: 10,
        }
    }
}

/// The noise of a region from its weak-texture patches.
#[derive(Debug, Clone, PartialEq)]
pub struct WeakTextureNoise {
    /// σ of the white noise the weak-texture patches hold, DN (with the 8-bit quantisation).
    pub sigma_dn: f64,
    /// Approximate standard error of `sigma_dn`, DN: σ/√(2·n), n the pixels the selected patches
    /// cover times the share of noise eigenvalues.
    pub sigma_stderr_dn: f64,
    /// Patch side d, px.
    pub patch_px: usize,
    /// Patches inside the region, and those that passed the texture test.
    pub patches: usize,
    pub selected: usize,
    /// Eigenvalues counted as noise, of d².
    pub noise_dims: usize,
    /// Distinct pixels the selected patches cover.
    pub pixels: usize,
    /// Iterations until the selection stopped changing.
    pub iterations: usize,
    /// See [`WeakTextureNoise::consistency`].
    consistency: f64,
}

/// The weak-texture patches' mean texture strength over the strength white noise of the
/// estimated σ gives (tr·σ²) must lie in this range. It is 1 on white noise (0.997–1.03
/// measured over flat and ramped regions, σ 0.8–5 DN); texture at the patch's scale raises it,
/// and so does noise that demosaicing, denoising or a codec correlated between neighbours (a
/// 0.5 px blur of white noise: 1.4; JPEG at quality 95 of 0.8 DN: 2.3), because the smallest
/// eigenvalues then see only the noise's high frequencies.
pub const WHITE_CONSISTENCY: (f64, f64) = (0.8, 1.25);

/// Below this share of noise eigenvalues (of d²) the variation is not white: on white noise
/// over a flat region almost all of them are noise eigenvalues (19–25 of 25 measured, with
/// weak texture); noise correlated by a 0.5–0.7 px blur keeps 13–16.
pub const MIN_NOISE_DIMS_SHARE: f64 = 0.6;

/// Fewer weak-texture patches than this many per patch dimension leave σ to a handful of flat
/// spots.
pub const MIN_SELECTED_PER_DIM: usize = 10;

impl WeakTextureNoise {
    /// The weak-texture patches' mean texture strength over tr·σ² (1 on white noise; NaN when
    /// σ is 0).
    pub fn consistency(&self) -> f64 {
        self.consistency
    }

    /// Why this estimate is not the sensor's white noise, when it is not: too few weak-texture
    /// patches, or variation that is not white ([`WHITE_CONSISTENCY`],
    /// [`MIN_NOISE_DIMS_SHARE`]).
    pub fn not_identifiable(&self) -> Option<String> {
        if self.sigma_dn.is_nan() || self.sigma_dn <= 0.0 {
            return Some(
                "its flattest patches hold no variation at all: noise below the 8-bit \
                 quantisation (σ under ½ DN) or flattened by the camera's processing (denoising, \
                 compression), and what varies elsewhere is texture"
                    .into(),
            );
        }
        let dims = self.patch_px * self.patch_px;
        let mut why = Vec::new();
        if self.selected < MIN_SELECTED_PER_DIM * dims {
            why.push(format!(
                "only {} of its {} patches of {}×{} px pass the texture test (needed: {}): the \
                 region is textured",
                self.selected,
                self.patches,
                self.patch_px,
                self.patch_px,
                MIN_SELECTED_PER_DIM * dims
            ));
        }
        let c = self.consistency;
        if !(c >= WHITE_CONSISTENCY.0 && c <= WHITE_CONSISTENCY.1) {
            why.push(format!(
                "its flattest patches vary {:.2} × as much between neighbours as white noise of \
                 their σ {:.2} DN would (white noise: {}–{}): texture, or noise that \
                 demosaicing, denoising or a codec correlated between neighbours",
                c, self.sigma_dn, WHITE_CONSISTENCY.0, WHITE_CONSISTENCY.1
            ));
        }
        if (self.noise_dims as f64) < MIN_NOISE_DIMS_SHARE * dims as f64 {
            why.push(format!(
                "{} of the {} eigenvalues of its weak-texture patches' covariance are noise \
                 eigenvalues (white noise: nearly all): the variation is not white",
                self.noise_dims, dims
            ));
        }
        (!why.is_empty()).then(|| why.join("; "))
    }
}

/// The texture test's threshold over σ²: the `confidence` quantile of ξ/σ² for a flat d×d patch
/// under white noise, Gamma(shape r/2, scale 2·tr/r) with tr = d(d − 2), r = d² − 4.
pub fn texture_threshold(patch_px: usize, confidence: f64) -> f64 {
    let d = patch_px as f64;
    let tr = d * (d - 2.0);
    let r = d * d - 4.0;
    // Shape and rate are positive for d ≥ 3 (checked by the caller), so the law exists.
    Gamma::new(r / 2.0, r / (2.0 * tr)).map_or(f64::INFINITY, |g| g.inverse_cdf(confidence))
}

/// σ² as the mean of the largest tail of `eigenvalues` whose mean does not exceed its median
/// (Chen, Zhu & Heng 2015), and the size of that tail.
fn tail_noise_variance(eigenvalues: &[f64]) -> (f64, usize) {
    let mut ev: Vec<f64> = eigenvalues.iter().map(|v| v.max(0.0)).collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    for i in 0..ev.len() {
        let tail = &ev[i..];
        let mean = tail.iter().sum::<f64>() / tail.len() as f64;
        let k = tail.len();
        let median = if k % 2 == 1 {
            tail[k / 2]
        } else {
            0.5 * (tail[k / 2 - 1] + tail[k / 2])
        };
        if mean <= median {
            return (mean, k);
        }
    }
    (ev.last().copied().unwrap_or(0.0), 1)
}

/// The weak-texture noise of `pixels` (absolute coordinates, any order) of `view`.
pub fn weak_texture_noise(
    view: &GrayView<'_>,
    pixels: &[(i64, i64)],
    options: &WeakTextureOptions,
) -> Result<WeakTextureNoise, StatsError> {
    check_view(view)?;
    if pixels.is_empty() {
        return Err(StatsError::TooFew {
            what: "weak-texture noise: pixels".into(),
            got: 0,
            need: 1,
        });
    }
    let x0 = pixels.iter().map(|p| p.0).min().unwrap_or(0);
    let y0 = pixels.iter().map(|p| p.1).min().unwrap_or(0);
    let w = (pixels.iter().map(|p| p.0).max().unwrap_or(0) - x0 + 1) as usize;
    let h = (pixels.iter().map(|p| p.1).max().unwrap_or(0) - y0 + 1) as usize;
    // The region as a grid of values (NaN outside it or outside the view).
    let mut grid = vec![f64::NAN; w * h];
    for &(x, y) in pixels {
        if let Some(v) = pixel(view, x, y) {
            grid[(y - y0) as usize * w + (x - x0) as usize] = v as f64;
        }
    }
    // Runs of valid pixels to the right and down give "patch fully inside" in O(1).
    let inside = |d: usize| -> Vec<(usize, usize)> {
        let mut right = vec![0usize; w * h];
        let mut ok = Vec::new();
        for y in 0..h {
            for x in (0..w).rev() {
                if !grid[y * w + x].is_nan() {
                    right[y * w + x] = 1 + if x + 1 < w { right[y * w + x + 1] } else { 0 };
                }
            }
        }
        for y in 0..h.saturating_sub(d - 1) {
            for x in 0..w.saturating_sub(d - 1) {
                if (0..d).all(|j| right[(y + j) * w + x] >= d) {
                    ok.push((x, y));
                }
            }
        }
        ok
    };
    let sides: Vec<usize> = options
        .patch_sides_px
        .iter()
        .copied()
        .filter(|&d| d >= 3)
        .collect();
    let mut chosen = None;
    let mut most = (0, 0);
    for &d in &sides {
        let at = inside(d);
        if at.len() >= options.patches_per_dim * d * d {
            chosen = Some((d, at));
            break;
        }
        if at.len() > most.0 {
            most = (at.len(), options.patches_per_dim * d * d);
        }
    }
    let Some((d, at)) = chosen else {
        return Err(StatsError::TooFew {
            what: "weak-texture noise: patches inside the region".into(),
            got: most.0,
            need: most.1.max(options.patches_per_dim * 9),
        });
    };
    let n = d * d;
    let patch = |&(px, py): &(usize, usize)| -> Vec<f64> {
        let mut v = Vec::with_capacity(n);
        for j in 0..d {
            v.extend_from_slice(&grid[(py + j) * w + px..(py + j) * w + px + d]);
        }
        v
    };
    let patches: Vec<Vec<f64>> = at.iter().map(patch).collect();
    let strength: Vec<f64> = patches
        .iter()
        .map(|p| {
            let mut s = 0.0;
            for j in 0..d {
                for i in 1..d - 1 {
                    let gx = 0.5 * (p[j * d + i + 1] - p[j * d + i - 1]);
                    let gy = 0.5 * (p[(i + 1) * d + j] - p[(i - 1) * d + j]);
                    s += gx * gx + gy * gy;
                }
            }
            s
        })
        .collect();
    let tau0 = texture_threshold(d, options.confidence);
    let eigen = |sel: &[bool]| -> Option<(f64, usize)> {
        let m = sel.iter().filter(|s| **s).count();
        if m < n + 1 {
            return None;
        }
        let mut mean = vec![0.0; n];
        for (p, _) in patches.iter().zip(sel).filter(|(_, s)| **s) {
            for (a, v) in mean.iter_mut().zip(p) {
                *a += v;
            }
        }
        mean.iter_mut().for_each(|a| *a /= m as f64);
        let mut cov = DMatrix::<f64>::zeros(n, n);
        let mut c = vec![0.0; n];
        for (p, _) in patches.iter().zip(sel).filter(|(_, s)| **s) {
            for k in 0..n {
                c[k] = p[k] - mean[k];
            }
            for r in 0..n {
                for q in r..n {
                    cov[(r, q)] += c[r] * c[q];
                }
            }
        }
        for r in 0..n {
            for q in r..n {
                let v = cov[(r, q)] / (m - 1) as f64;
                cov[(r, q)] = v;
                cov[(q, r)] = v;
            }
        }
        let ev = SymmetricEigen::new(cov).eigenvalues;
        Some(tail_noise_variance(ev.as_slice()))
    };
    let mut sel = vec![true; patches.len()];
    let (mut var, mut dims) = eigen(&sel).ok_or_else(|| StatsError::TooFew {
        what: "weak-texture noise: patches".into(),
        got: patches.len(),
        need: n + 1,
    })?;
    let mut iterations = 0;
    for _ in 0..options.max_iterations {
        iterations += 1;
        let next: Vec<bool> = strength.iter().map(|&s| s < var * tau0).collect();
        if next == sel {
            break;
        }
        match eigen(&next) {
            Some((v, k)) => {
                sel = next;
                var = v;
                dims = k;
            }
            // Too few patches pass: the region is all texture; keep the last estimate.
            None => {
                sel = next;
                break;
            }
        }
    }
    let selected = sel.iter().filter(|s| **s).count();
    let mut covered = vec![false; w * h];
    for (&(px, py), _) in at.iter().zip(&sel).filter(|(_, s)| **s) {
        for j in 0..d {
            covered[(py + j) * w + px..(py + j) * w + px + d].fill(true);
        }
    }
    let pixels_covered = covered.iter().filter(|c| **c).count();
    let sigma = var.max(0.0).sqrt();
    let mean_strength = strength
        .iter()
        .zip(&sel)
        .filter(|(_, s)| **s)
        .map(|(x, _)| x)
        .sum::<f64>()
        / selected.max(1) as f64;
    let tr = (d * (d - 2)) as f64;
    let consistency = if var > 0.0 {
        mean_strength / (tr * var)
    } else {
        f64::NAN
    };
    let dof = (pixels_covered as f64 * dims as f64 / n as f64).max(1.0);
    Ok(WeakTextureNoise {
        sigma_dn: sigma,
        sigma_stderr_dn: sigma / (2.0 * dof).sqrt(),
        patch_px: d,
        patches: patches.len(),
        selected,
        noise_dims: dims,
        pixels: pixels_covered,
        iterations,
        consistency,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::effects::pixel_noise::normal_at;

    /// A `size`² region of `f(x, y)` rounded to 8 bits, and its pixels.
    fn region(size: usize, f: impl Fn(f64, f64) -> f64) -> (Vec<u8>, Vec<(i64, i64)>) {
        let mut data = Vec::with_capacity(size * size);
        for y in 0..size {
            for x in 0..size {
                let v = f(x as f64, y as f64);
                data.push(v.round().clamp(0.0, 255.0) as u8);
            }
        }
        let pixels = (0..size as i64)
            .flat_map(|y| (0..size as i64).map(move |x| (x, y)))
            .collect();
        (data, pixels)
    }

    /// `f` plus white noise of `sigma` from the counter-based normals of `key`.
    fn noisy(
        size: usize,
        key: u64,
        sigma: f64,
        f: impl Fn(f64, f64) -> f64,
    ) -> (Vec<u8>, Vec<(i64, i64)>) {
        region(size, |x, y| {
            f(x, y) + sigma * normal_at(key, x as i64, y as i64) as f64
        })
    }

    fn estimate(size: usize, data: &[u8], pixels: &[(i64, i64)]) -> WeakTextureNoise {
        let view = GrayView::full(data, size, size);
        weak_texture_noise(&view, pixels, &WeakTextureOptions::default()).unwrap()
    }

    /// σ of white noise after rounding to whole DN.
    fn quantised(sigma: f64) -> f64 {
        (sigma * sigma + 1.0 / 12.0).sqrt()
    }

    #[test]
    fn white_noise_over_flat_and_ramped_regions_is_measured_within_3_percent() {
        for (k, sigma) in [0.8, 2.0, 5.0].into_iter().enumerate() {
            for ramp in [0.0, 0.3] {
                let (data, px) = noisy(120, 11 + k as u64, sigma, |x, y| {
                    100.0 + ramp * x + ramp / 3.0 * y
                });
                let e = estimate(120, &data, &px);
                let truth = quantised(sigma);
                assert!(
                    (e.sigma_dn - truth).abs() <= 0.03 * truth,
                    "σ {sigma}, ramp {ramp}: {e:?}"
                );
                assert_eq!(e.not_identifiable(), None, "σ {sigma}, ramp {ramp}: {e:?}");
                assert_eq!(e.patch_px, 7);
            }
        }
    }

    #[test]
    fn print_lines_over_part_of_a_region_are_left_out_and_the_noise_still_measured() {
        // Stripes of 30 DN over the left half (a 3D printer's lines): the plain σ of the region
        // is mostly theirs.
        let (data, px) = noisy(120, 5, 2.0, |x, _| {
            100.0 + if x < 60.0 { 30.0 * x.sin() } else { 0.0 }
        });
        let e = estimate(120, &data, &px);
        assert!(
            (e.sigma_dn - quantised(2.0)).abs() <= 0.03 * quantised(2.0),
            "{e:?}"
        );
        assert!(e.selected < e.patches * 6 / 10, "{e:?}");
        assert_eq!(e.not_identifiable(), None, "{e:?}");
        let view = GrayView::full(&data, 120, 120);
        let plain = super::super::region_stats(&view, &px, "stripes", 30).unwrap();
        assert!(plain.noise_sigma_dn > 5.0 * e.sigma_dn, "{plain:?}");
    }

    #[test]
    fn correlated_noise_fine_texture_and_flattened_regions_are_not_identifiable() {
        // Noise correlated between neighbours ([1 2 1]/4 both ways, as demosaicing and
        // denoising do), scaled back to σ 2 DN per pixel.
        let raw = |x: f64, y: f64| normal_at(21, x as i64, y as i64) as f64;
        let smooth = |x: f64, y: f64| {
            let w = [0.25, 0.5, 0.25];
            let mut s = 0.0;
            for (j, wy) in w.iter().enumerate() {
                for (i, wx) in w.iter().enumerate() {
                    s += wx * wy * raw(x + i as f64 - 1.0, y + j as f64 - 1.0);
                }
            }
            // Σw² = (3/8)² for the separable kernel: unit variance again.
            s / 0.375
        };
        let (data, px) = region(120, |x, y| 100.0 + 2.0 * smooth(x, y));
        let e = estimate(120, &data, &px);
        assert!(e.not_identifiable().is_some(), "correlated: {e:?}");
        // Fine texture of 3 DN (paper fibre) over white noise of 0.8 DN.
        let (data, px) = noisy(120, 8, 0.8, |x, y| 100.0 + 3.0 * (x / 1.5 + y / 3.0).sin());
        let e = estimate(120, &data, &px);
        assert!(e.not_identifiable().is_some(), "fine texture: {e:?}");
        // A region the phone's processing flattened: nothing varies.
        let (data, px) = region(120, |_, _| 100.0);
        let e = estimate(120, &data, &px);
        assert_eq!(e.sigma_dn, 0.0);
        let why = e.not_identifiable().expect("flat");
        assert!(why.contains("no variation"), "{why}");
    }

    #[test]
    fn the_standard_error_describes_the_spread_over_noise_draws() {
        let truth = quantised(2.0);
        let est: Vec<WeakTextureNoise> = (0..24)
            .map(|k| {
                let (data, px) = noisy(48, 100 + k, 2.0, |_, _| 90.0);
                estimate(48, &data, &px)
            })
            .collect();
        let errs: Vec<f64> = est.iter().map(|e| e.sigma_dn - truth).collect();
        let mean = errs.iter().sum::<f64>() / errs.len() as f64;
        let sd =
            (errs.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (errs.len() - 1) as f64).sqrt();
        let se = est.iter().map(|e| e.sigma_stderr_dn).sum::<f64>() / est.len() as f64;
        assert!(mean.abs() < 0.02 * truth, "bias {mean}");
        assert!(
            sd > 0.5 * se && sd < 2.0 * se,
            "spread {sd} against stated {se}"
        );
    }

    #[test]
    fn small_regions_use_smaller_patches_and_tiny_ones_are_errors() {
        let (data, px) = noisy(40, 3, 2.0, |_, _| 100.0);
        let e = estimate(40, &data, &px);
        assert_eq!(e.patch_px, 5, "{e:?}");
        assert!(
            (e.sigma_dn - quantised(2.0)).abs() < 0.06 * quantised(2.0),
            "{e:?}"
        );
        let (data, px) = noisy(12, 3, 2.0, |_, _| 100.0);
        let view = GrayView::full(&data, 12, 12);
        assert!(matches!(
            weak_texture_noise(&view, &px, &WeakTextureOptions::default()),
            Err(StatsError::TooFew { .. })
        ));
    }

    #[test]
    fn the_texture_threshold_holds_the_stated_share_of_noise_patches() {
        // The derivative operators' trace d(d − 2) and rank d² − 4, computed.
        for d in [3usize, 5, 7] {
            let n = d * d;
            let mut rows = Vec::new();
            for a in 0..d {
                for b in 1..d - 1 {
                    let mut h = vec![0.0; n];
                    h[a * d + b - 1] = -0.5;
                    h[a * d + b + 1] = 0.5;
                    let mut v = vec![0.0; n];
                    v[(b - 1) * d + a] = -0.5;
                    v[(b + 1) * d + a] = 0.5;
                    rows.push(h);
                    rows.push(v);
                }
            }
            let m = DMatrix::from_fn(rows.len(), n, |r, c| rows[r][c]);
            let dd = m.transpose() * m;
            assert!((dd.trace() - (d * (d - 2)) as f64).abs() < 1e-9);
            assert_eq!(dd.rank(1e-9), n - 4, "d = {d}");
        }
        // Flat patches of white noise that the test takes for texture: Liu et al.'s Gamma law
        // matches ξ's mean but not its spread (ξ is a χ² mix whose weights are the operator's
        // eigenvalues, not all equal), so at 99 % it leaves out 1–3 % rather than 1 %; at the
        // default confidence almost none, as the estimate's σ needs.
        let d = 5;
        let count_above = |tau: f64| {
            let (mut above, mut total) = (0usize, 0usize);
            for py in 0..190i64 {
                for px in (0..190i64).step_by(3) {
                    let z = |x: i64, y: i64| normal_at(9, x, y) as f64;
                    let mut s = 0.0;
                    for a in 0..d as i64 {
                        for b in 1..d as i64 - 1 {
                            let gx = 0.5 * (z(px + b + 1, py + a) - z(px + b - 1, py + a));
                            let gy = 0.5 * (z(px + a, py + b + 1) - z(px + a, py + b - 1));
                            s += gx * gx + gy * gy;
                        }
                    }
                    total += 1;
                    above += usize::from(s > tau);
                }
            }
            above as f64 / total as f64
        };
        let at99 = count_above(texture_threshold(d, 0.99));
        assert!((0.01..0.03).contains(&at99), "{at99}");
        let share = count_above(texture_threshold(
            d,
            WeakTextureOptions::default().confidence,
        ));
        assert!(share < 1e-3, "{share}");
    }
}
