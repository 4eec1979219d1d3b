//! Effects read off the footage directly, without a search: the frame timing (the VFR model
//! fitted to the timestamps), the timebase (their rate) and the lighting (levels and gamma
//! inverted from the measured ink, paper and disc, corrected once by simulation).

use super::{FitError, Fitter, Found};
use crate::diagnose::moments;
use crate::diagnose::nominal::AlignError;
use crate::diagnose::plan;
use crate::scenario::effects::Effect;
use crate::timing::{fit_vfr, Timestamps};

/// Standard deviation of the median frame interval of timestamps `t_s`: the median's large-sample
/// sd from the intervals' MAD (1.2533 × 1.4826 × MAD / √n), never below 1 ns, the finest stamp a
/// clock gives (a constant-rate footage's intervals differ only by rounding; a zero sd claimed
/// a rate 10⁻¹³ fps off to be exact).
fn median_interval_sd_s(t_s: &[f64]) -> f64 {
    let d: Vec<f64> = t_s.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return f64::INFINITY;
    }
    let mad = crate::numeric::robust::mad(&d);
    (1.2533 * crate::numeric::robust::MAD_TO_SD * mad / (d.len() as f64).sqrt()).max(1e-9)
}

impl Fitter<'_> {
    /// The frame timing: the VFR model fitted to the footage's timestamps.
    pub(super) fn frame_timing_direct(&self) -> Result<Found, FitError> {
        let ts = Timestamps::new(self.real.t_s.to_vec()).map_err(AlignError::FrameTimes)?;
        let f = fit_vfr(&ts).map_err(FitError::TimingFit)?;
        let rate_ppm = (f.fps / self.nominal.frame_timing.fps - 1.0) * 1e6;
        let values = vec![
            f.jitter_s,
            f.first_interval_s,
            rate_ppm,
            f.drop_probability,
            f.pair_alternation_s.abs(),
        ];
        let stds = vec![
            f.jitter_s / ((f.frames.max(4) - 3) as f64).sqrt() / std::f64::consts::SQRT_2,
            f.first_interval_stderr_s,
            f.fps_stderr / self.nominal.frame_timing.fps * 1e6,
            (f.drop_probability * (1.0 - f.drop_probability) / f.frames.max(1) as f64).sqrt(),
            f.pair_alternation_stderr_s,
        ];
        let method = "fitted directly to the footage's timestamps (geneva timing fit)".into();
        Ok((values, stds, method))
    }

    /// The timebase: the rate of the footage's timestamps.
    pub(super) fn timebase_direct(&self) -> Found {
        let fps = 1.0 / self.median_interval_s();
        let values = vec![fps];
        let stds = vec![fps * fps * median_interval_sd_s(self.real.t_s)];
        let method: String =
            "rate of the footage's timestamps; frames taken on the nominal's schedule".into();
        (values, stds, method)
    }

    /// The lighting: levels and gamma inverted from the measured ink, paper and disc around the
    /// marker, starting from `values`, then corrected once by simulation on top of `prior`.
    pub(super) fn lighting_inverted(
        &self,
        prior: &[(Effect, Vec<f64>)],
        mut values: Vec<f64>,
    ) -> Result<Found, FitError> {
        let e = Effect::Lighting;
        let s = &self.ctx.aligned.scenario;
        let all = ["dwell", "entry", "drive", "exit"];
        let (s_i, s_p, s_m) = (
            s.scene.ink_radiance,
            s.scene.paper_radiance,
            s.scene.disc_radiance,
        );
        // Levels and gamma from ink, paper and the disc around the marker (a mid-tone);
        // levels alone (gamma as the nominal's) when the mid-tone does not resolve gamma.
        let gamma0 = values[2];
        let tone = |ink: f64, paper: f64, mid: Option<f64>| {
            mid.and_then(|m| plan::guess_tone([ink, paper, m], s_i, s_p, s_m))
                .or_else(|| plan::guess_levels(ink, paper, s_i, s_p).map(|(b, w)| (b, w, gamma0)))
        };
        let real_mid = self.channel_pair("background", &all).map(|p| p.0);
        if let (Some((ink, _)), Some((paper, _))) = (
            self.channel_pair("ink", &all),
            self.channel_pair("paper", &all),
        ) {
            if let Some((b, w, g)) = tone(ink, paper, real_mid) {
                values = vec![b, w, g];
            }
        }
        // One correction with simulations (blur, noise and the surround's own model
        // error move the measured levels): the tone solved on the simulations is moved
        // onto the tone solved on the footage.
        let mut applied: Vec<(Effect, Vec<f64>)> = prior.to_vec();
        applied.push((e, values.clone()));
        let trial = self.trial_with(&applied)?;
        let g = self.gap(&trial, &self.fit_seeds)?;
        let means = |ch: &str| moments::channel_means(&g, ch, &all);
        let gamma_resolved;
        if let (Some(ink), Some(paper)) = (means("ink"), means("paper")) {
            let mid = means("background");
            let r = tone(ink.real, paper.real, mid.map(|m| m.real));
            let m = tone(ink.sim, paper.sim, mid.map(|m| m.sim));
            gamma_resolved = mid.is_some_and(|m| {
                plan::guess_tone([ink.real, paper.real, m.real], s_i, s_p, s_m).is_some()
                    && plan::guess_tone([ink.sim, paper.sim, m.sim], s_i, s_p, s_m).is_some()
            });
            if let (Some(r), Some(m)) = (r, m) {
                values[0] += r.0 - m.0;
                values[1] += r.1 - m.1;
                if gamma_resolved {
                    values[2] = (values[2] * r.2 / m.2).clamp(0.3, 3.0);
                }
            }
        } else {
            gamma_resolved = false;
        }
        let tol = crate::diagnose::cells::channel("ink").map_or(4.0, |c| c.tol_abs);
        // Gamma's uncertainty: the mid-tone moved by the level tolerance.
        let gamma_std = if gamma_resolved {
            let (ink, paper) = (means("ink"), means("paper"));
            match (ink, paper, means("background")) {
                (Some(i), Some(p), Some(m)) => {
                    let at = |d: f64| {
                        plan::guess_tone([i.real, p.real, m.real + d], s_i, s_p, s_m).map(|t| t.2)
                    };
                    match (at(tol), at(-tol)) {
                        (Some(a), Some(b)) => 0.5 * (a - b).abs(),
                        _ => f64::INFINITY,
                    }
                }
                _ => f64::INFINITY,
            }
        } else {
            f64::INFINITY
        };
        let stds = vec![tol, tol, gamma_std];
        let method = if gamma_resolved {
            "levels and gamma inverted from the measured ink, paper and disc (a mid-tone), \
             corrected once by simulation"
                .into()
        } else {
            "levels inverted from the measured ink and paper (gamma as the nominal's), \
             corrected once by simulation"
                .into()
        };
        Ok((values, stds, method))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_intervals_sd_follows_the_jitter_and_never_claims_exactness() {
        let even: Vec<f64> = (0..181).map(|i| i as f64 / 30.0).collect();
        assert_eq!(median_interval_sd_s(&even), 1e-9);
        // 180 intervals of 1/30 s − 0.5 ms, 1/30 s and 1/30 s + 0.5 ms in turn: MAD 0.5 ms.
        let jittered: Vec<f64> = std::iter::once(0.0)
            .chain((0..180).scan(0.0, |t, i| {
                *t += 1.0 / 30.0 + [-5e-4, 0.0, 5e-4][i % 3];
                Some(*t)
            }))
            .collect();
        let sd = median_interval_sd_s(&jittered);
        let expected = 1.2533 * 1.4826 * 5e-4 / 180f64.sqrt();
        assert!((sd / expected - 1.0).abs() < 1e-6, "{sd} vs {expected}");
        assert_eq!(median_interval_sd_s(&[1.0]), f64::INFINITY);
    }
}
