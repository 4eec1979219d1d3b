//! The light's drift over the footage: a camera's auto-exposure or a lamp warming up changes the
//! marker's contrast (paper − ink, DN) in proportion to the illumination's gain, whatever the
//! black level. The contrast of every measured frame is averaged over blocks of equal duration
//! (the frame-to-frame noise and the motion's fast structure average out; block means are close
//! to independent), and the block means are fitted by least squares with
//!
//! contrast = c₀·(1 + d·(t − t_ref))·(1 + g_x·Δx/W + g_y·Δy/H),
//!
//! where Δx, Δy are the marker centre's offsets from the frame centre: the marker travels across
//! the frame as the wheel turns, so an illumination gradient changes its contrast too, and a
//! drift is only claimed once that gradient is fitted beside it (a gradient the path cannot tell
//! from a drift shows as a wide interval, not as a drift). t_ref is the median time of the
//! measured frames, where the footage's median levels are taken, so the stated levels hold at
//! t_ref (the renderer's `effects.lighting` drift and gradient are the same product). The 95 %
//! interval of d is Student's t over the blocks' degrees of freedom on the Gauss–Newton
//! standard error, combined with [`PROPORTIONALITY_FRAC`] of d for how far the measured
//! contrast follows the light.

use super::Fitted;
use crate::numeric::dist::t975;
use crate::numeric::linalg::invert;
use crate::numeric::robust::median_in_place as median;
use nalgebra::{DMatrix, DVector};

/// Blocks the footage is cut into (at most; fewer when it has fewer than 3 frames per block).
pub const BLOCKS: usize = 16;

/// Fewer blocks than this leave too few degrees of freedom for an interval.
pub const MIN_BLOCKS: usize = 8;

/// Relative uncertainty of the contrast's proportionality to the light, added to the fit's
/// own: where the ink sits at the black level (or the paper at the white), its clipped noise
/// and the blur of the paper into it make the measured contrast follow the light only to a few
/// per cent (a 2.2 % bias seen on footage with ink at black and paper at white).
pub const PROPORTIONALITY_FRAC: f64 = 0.05;

/// A regressor whose spread over the blocks is below this (relative to the frame) is left out:
/// the marker did not travel along that axis.
const MIN_TRAVEL_FRAC: f64 = 1e-3;

/// One measured frame: its time, the marker's contrast and centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContrastSample {
    pub t_s: f64,
    /// Paper − ink, DN.
    pub contrast_dn: f64,
    /// The marker's centre, px.
    pub centre_px: [f64; 2],
}

/// The fitted drift.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftFit {
    /// Relative change of the light per second at `reference_s`.
    pub drift_per_s: Fitted,
    /// The median time of the measured frames, s: the drift's gain is 1 there.
    pub reference_s: f64,
    /// The contrast at the reference time with the marker at the frame centre, DN.
    pub contrast_dn: f64,
    /// The footage's first and last measured times, s.
    pub span_s: (f64, f64),
    pub frames: usize,
    pub blocks: usize,
    /// Which gradient terms were fitted beside the drift (x, y).
    pub gradient_fitted: [bool; 2],
    /// RMS of the block means about the fit, DN.
    pub residual_rms_dn: f64,
}

impl DriftFit {
    /// The interval excludes no drift: the footage shows one.
    pub fn significant(&self) -> bool {
        self.drift_per_s.value.abs() > self.drift_per_s.u95
    }

    /// How the illumination gradient entered the fit, for the reports.
    pub fn gradient_phrase(&self) -> &'static str {
        match self.gradient_fitted {
            [true, true] => "with an illumination gradient across the marker's path fitted beside it",
            [false, false] => "without a gradient term (the marker stays put)",
            _ => "with an illumination gradient along the one axis the marker travels fitted beside it",
        }
    }

    /// The drift's lowest and highest gain over the footage when it is significant ((1, 1)
    /// otherwise): the levels must have room for both.
    pub fn gain_range(&self) -> (f64, f64) {
        if !self.significant() {
            return (1.0, 1.0);
        }
        let g = |t: f64| 1.0 + self.drift_per_s.value * (t - self.reference_s);
        let (a, b) = (g(self.span_s.0), g(self.span_s.1));
        (a.min(b), a.max(b))
    }
}

/// The drift, or why the footage cannot show one.
#[derive(Debug, Clone, PartialEq)]
pub enum ExposureDrift {
    Fitted(DriftFit),
    NotIdentifiable(String),
}

impl ExposureDrift {
    /// The significant drift, if any.
    pub fn significant(&self) -> Option<&DriftFit> {
        match self {
            ExposureDrift::Fitted(f) if f.significant() => Some(f),
            _ => None,
        }
    }

    /// The written drift's gain at `t_s` (1 without a significant drift): what the renderer's
    /// `effects.lighting` drift gives there.
    pub fn gain_at(&self, t_s: f64) -> f64 {
        self.significant()
            .map_or(1.0, |f| 1.0 + f.drift_per_s.value * (t_s - f.reference_s))
    }

    /// The gain range the levels must hold ((1, 1) without a significant drift).
    pub fn gain_range(&self) -> (f64, f64) {
        self.significant().map_or((1.0, 1.0), DriftFit::gain_range)
    }
}

/// Fits the drift of `samples` (any order) in a `width_px` × `height_px` frame.
pub fn fit_drift(samples: &[ContrastSample], width_px: usize, height_px: usize) -> ExposureDrift {
    let mut s: Vec<ContrastSample> = samples
        .iter()
        .copied()
        .filter(|s| s.t_s.is_finite() && s.contrast_dn.is_finite() && s.contrast_dn > 0.0)
        .collect();
    s.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    let n = s.len();
    let blocks_wanted = BLOCKS.min(n / 3);
    if blocks_wanted < MIN_BLOCKS {
        return ExposureDrift::NotIdentifiable(format!(
            "frames with measured levels: {n}; a drift needs at least {} (blocks of 3)",
            3 * MIN_BLOCKS
        ));
    }
    let (t0, t1) = (s[0].t_s, s[n - 1].t_s);
    let mut times: Vec<f64> = s.iter().map(|s| s.t_s).collect();
    let reference_s = median(&mut times);
    let blocks = block_means(&s, blocks_wanted, width_px, height_px);
    if blocks.len() < MIN_BLOCKS {
        return ExposureDrift::NotIdentifiable(format!(
            "the measured frames fall into {} of {blocks_wanted} equal stretches of time: a \
             drift needs {MIN_BLOCKS}",
            blocks.len()
        ));
    }
    let spread = |k: usize| {
        let v: Vec<f64> = blocks.iter().map(|b| b[k]).collect();
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
    };
    let gradient_fitted = [spread(2) > MIN_TRAVEL_FRAC, spread(3) > MIN_TRAVEL_FRAC];
    match least_squares(&blocks, reference_s, gradient_fitted) {
        Some((c0, drift, residual_rms_dn)) if c0 > 0.0 => ExposureDrift::Fitted(DriftFit {
            drift_per_s: drift,
            reference_s,
            contrast_dn: c0,
            span_s: (t0, t1),
            frames: n,
            blocks: blocks.len(),
            gradient_fitted,
            residual_rms_dn,
        }),
        _ => ExposureDrift::NotIdentifiable(
            "the marker's path across the frame cannot be told from a change over time (the \
             least-squares system is singular)"
                .into(),
        ),
    }
}

/// Means of (t, contrast, Δx/W, Δy/H) over `k` equal stretches of the samples' time span
/// (empty stretches left out).
fn block_means(s: &[ContrastSample], k: usize, width_px: usize, height_px: usize) -> Vec<[f64; 4]> {
    let (t0, t1) = (s[0].t_s, s[s.len() - 1].t_s);
    let width = ((t1 - t0) / k as f64).max(f64::MIN_POSITIVE);
    let (w, h) = (width_px.max(1) as f64, height_px.max(1) as f64);
    let mut sums = vec![[0.0f64; 5]; k];
    for x in s {
        let b = (((x.t_s - t0) / width) as usize).min(k - 1);
        let row = [
            x.t_s,
            x.contrast_dn,
            (x.centre_px[0] - (w - 1.0) / 2.0) / w,
            (x.centre_px[1] - (h - 1.0) / 2.0) / h,
            1.0,
        ];
        for (a, v) in sums[b].iter_mut().zip(row) {
            *a += v;
        }
    }
    sums.into_iter()
        .filter(|b| b[4] > 0.0)
        .map(|b| [b[0] / b[4], b[1] / b[4], b[2] / b[4], b[3] / b[4]])
        .collect()
}

/// (c₀, d with its 95 % interval, residual RMS) of the block means, or `None` when singular:
/// Gauss–Newton on the product model from the linear model's solution.
fn least_squares(
    blocks: &[[f64; 4]],
    reference_s: f64,
    gradient: [bool; 2],
) -> Option<(f64, Fitted, f64)> {
    let cols: Vec<usize> = [2, 3]
        .into_iter()
        .zip(gradient)
        .filter_map(|(c, on)| on.then_some(c))
        .collect();
    let p = 2 + cols.len();
    let k = blocks.len();
    let y = DVector::from_iterator(k, blocks.iter().map(|b| b[1]));
    // θ = (c₀, d, g…): model c₀·(1 + d·τ)·(1 + Σ g·Δ).
    let model = |theta: &DVector<f64>, b: &[f64; 4]| {
        let a = 1.0 + theta[1] * (b[0] - reference_s);
        let g = 1.0
            + cols
                .iter()
                .enumerate()
                .map(|(j, &c)| theta[2 + j] * b[c])
                .sum::<f64>();
        (a, g)
    };
    let jacobian = |theta: &DVector<f64>| {
        DMatrix::from_fn(k, p, |r, c| {
            let b = &blocks[r];
            let (a, g) = model(theta, b);
            match c {
                0 => a * g,
                1 => theta[0] * (b[0] - reference_s) * g,
                _ => theta[0] * a * b[cols[c - 2]],
            }
        })
    };
    let mean = y.mean();
    let mut theta = DVector::from_element(p, 0.0);
    theta[0] = mean;
    for _ in 0..20 {
        let j = jacobian(&theta);
        let r = DVector::from_iterator(
            k,
            blocks.iter().map(|b| {
                let (a, g) = model(&theta, b);
                b[1] - theta[0] * a * g
            }),
        );
        let step = invert(&(j.transpose() * &j))? * j.transpose() * r;
        theta += &step;
        if step
            .iter()
            .zip(theta.iter())
            .all(|(s, t)| s.abs() <= 1e-12 * t.abs().max(1e-9))
        {
            break;
        }
    }
    let j = jacobian(&theta);
    let cov_unscaled = invert(&(j.transpose() * &j))?;
    let rss: f64 = blocks
        .iter()
        .map(|b| {
            let (a, g) = model(&theta, b);
            (b[1] - theta[0] * a * g).powi(2)
        })
        .sum();
    let dof = k - p;
    let s2 = rss / dof as f64;
    if !(theta[0] > 0.0 && theta.iter().all(|v| v.is_finite())) {
        return None;
    }
    let u_fit = t975(dof) * (s2 * cov_unscaled[(1, 1)]).max(0.0).sqrt();
    let u95 = u_fit.hypot(PROPORTIONALITY_FRAC * theta[1].abs());
    Some((
        theta[0],
        Fitted::new(theta[1], u95),
        (rss / k as f64).sqrt(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;
    use rand_distr::{Distribution, Normal};

    /// 8 s at 30 fps of a marker circling the frame centre once, under a light drifting by
    /// `drift` per s about t = 4 s and a gradient of `grad_x` across the frame, with `noise_dn`
    /// of frame-to-frame noise on the contrast.
    fn footage(drift: f64, grad_x: f64, noise_dn: f64, seed: u64) -> Vec<ContrastSample> {
        let mut rng = crate::rng::stream(seed, crate::rng::Stream::MonteCarlo, 0);
        let noise = Normal::new(0.0, noise_dn).unwrap();
        (0..240)
            .map(|i| {
                let t = i as f64 / 30.0;
                let angle = std::f64::consts::TAU * t / 8.0 + rng.gen_range(-0.01..0.01);
                let centre = [640.0 + 300.0 * angle.cos(), 480.0 + 300.0 * angle.sin()];
                let gain =
                    (1.0 + drift * (t - 4.0)) * (1.0 + grad_x * (centre[0] - 639.5) / 1280.0);
                ContrastSample {
                    t_s: t,
                    contrast_dn: 150.0 * gain + noise.sample(&mut rng),
                    centre_px: centre,
                }
            })
            .collect()
    }

    #[test]
    fn a_drift_is_recovered_within_its_interval_beside_a_gradient() {
        let mut covered = 0;
        for seed in 0..40 {
            let s = footage(0.01, -0.2, 0.8, seed);
            let ExposureDrift::Fitted(f) = fit_drift(&s, 1280, 960) else {
                panic!("not fitted");
            };
            assert!(f.significant(), "seed {seed}: {:?}", f.drift_per_s);
            assert_eq!(f.gradient_fitted, [true, true]);
            covered += f.drift_per_s.covers(0.01) as usize;
            assert!((f.reference_s - 3.983).abs() < 0.02);
        }
        // A 95 % interval: 40 footages, binomial(40, 0.95) ≥ 34 with probability 0.998.
        assert!(covered >= 34, "{covered} of 40 intervals hold the truth");
    }

    #[test]
    fn steady_light_shows_no_drift_in_most_footages_and_a_gradient_alone_none() {
        let significant = (0..40)
            .filter(|&seed| {
                matches!(fit_drift(&footage(0.0, -0.2, 0.8, seed), 1280, 960),
                    ExposureDrift::Fitted(f) if f.significant())
            })
            .count();
        // A false claim rate of 5 %: binomial(40, 0.05) ≤ 6 with probability 0.99.
        assert!(
            significant <= 6,
            "{significant} of 40 steady footages show a drift"
        );
        // Without the gradient term the gradient would read as a drift: it is fitted.
        let ExposureDrift::Fitted(f) = fit_drift(&footage(0.0, -0.3, 0.0, 1), 1280, 960) else {
            panic!("not fitted");
        };
        assert!(f.drift_per_s.value.abs() < 1e-3, "{:?}", f.drift_per_s);
        assert_eq!(f.gain_range(), (1.0, 1.0));
    }

    #[test]
    fn the_gain_range_spans_the_footage_from_the_reference_time() {
        let f = match fit_drift(&footage(0.02, 0.0, 0.3, 3), 1280, 960) {
            ExposureDrift::Fitted(f) => f,
            other => panic!("{other:?}"),
        };
        let (lo, hi) = f.gain_range();
        assert!((lo - (1.0 - 0.02 * 3.983)).abs() < 0.01, "{lo}");
        assert!((hi - (1.0 + 0.02 * 3.983)).abs() < 0.01, "{hi}");
    }

    #[test]
    fn short_or_motionless_footage_is_not_identifiable_or_fits_without_the_gradient() {
        let s = footage(0.01, 0.0, 0.5, 2);
        assert!(matches!(
            fit_drift(&s[..20], 1280, 960),
            ExposureDrift::NotIdentifiable(why) if why.contains("levels: 20;")
        ));
        let still: Vec<ContrastSample> = s
            .iter()
            .map(|x| ContrastSample {
                centre_px: [100.0, 100.0],
                ..*x
            })
            .collect();
        let ExposureDrift::Fitted(f) = fit_drift(&still, 1280, 960) else {
            panic!("not fitted");
        };
        assert_eq!(f.gradient_fitted, [false, false]);
        assert!(f.drift_per_s.covers(0.01));
    }
}
