//! The pixel noise's own fitting: whether the footage shows shot noise at all, the moment
//! match of the noise at the ink and paper levels, and the search along the valley of fixed
//! total noise. The footage fixes the total s/FW + RN²/FW² far better than the split of full
//! well and read noise, which only the shot part (noise rising with the grey level) sets; this
//! module keeps a split from being stated where the footage does not measure it.

use super::moment_match::MOMENT_SIMULATIONS;
use super::{
    aligned_of, moment_method, objective_at, shared_std_along, FitError, Fitter, LensCells,
    MomentFit, Objectives,
};
use crate::diagnose::moments;
use crate::diagnose::plan;
use crate::diagnose::search::{minimise, profile_half_width, SearchOptions};
use crate::diagnose::sensor_noise::{
    full_well_on_valley, mid_grey, noise_split_determined, noise_variance_cap,
    noise_variance_ratio, read_noise_on_valley, sensor_variance, NoiseCap, NOISE_SPLIT_MAX_REL_SD,
};
use crate::scenario::effects::Effect;
use std::cell::RefCell;

impl Fitter<'_> {
    /// Whether the footage's noise has the sensor model's shape, more on the paper than on the
    /// ink once the tone curve's clip is undone ([`plan::guess_noise`]): shot noise shows.
    /// Denoising, compression or another camera's noise model can invert it; then no split of
    /// full well and read noise is measured, only their total.
    pub(super) fn shot_noise_shows(&self) -> bool {
        let s = &aligned_of(self).scenario;
        let span = s.effects.lighting.span_dn();
        self.channel_pair("noise_ink", &[])
            .zip(self.channel_pair("noise_paper", &[]))
            .is_some_and(|((ni, _), (np, _))| {
                plan::guess_noise(ni, np, s.scene.ink_radiance, s.scene.paper_radiance, span)
                    .is_some()
            })
    }

    /// The cap on a pixel-noise search's noise ([`noise_variance_cap`]): the nominal's sensor at
    /// mid-grey, scaled by the larger of the footage's two noise ratios (ink, paper) to the
    /// nominal simulations'. `None` without sensor noise in the nominal.
    pub(super) fn noise_search_cap(&self) -> Option<NoiseCap> {
        let s = &aligned_of(self).scenario;
        if !Effect::PixelNoise.is_on(s) {
            return None;
        }
        let p = &s.effects.pixel_noise;
        let s_ref = mid_grey(&s.scene);
        let nominal = sensor_variance(s_ref, p.full_well_e, p.read_noise_e);
        let ratio = ["noise_ink", "noise_paper"]
            .iter()
            .filter_map(|c| self.channel_pair(c, &[]))
            .filter_map(|(real, sim)| noise_variance_ratio(real, sim))
            .reduce(f64::max)?;
        noise_variance_cap(nominal, ratio).map(|variance| NoiseCap { s_ref, variance })
    }

    /// The full well and read noise of a searched pixel-noise fit, searched once more along the
    /// valley the footage fixes. The two coordinate searches each held the other, but where read
    /// noise dominates the footage fixes only the total noise, s/FW + RN²/FW², and both move
    /// together along that curve with little change in Σ z². So the full well is searched along
    /// it ([`read_noise_on_valley`] at the mid-grey between ink and paper, through the point
    /// the coordinate searches reached), each full well with the read noise that keeps the total;
    /// the full well's ± is that search's (curvature of the shared χ² and the bracket's
    /// spread), the read noise's carries it through the valley's slope. Neither has a ± (not
    /// resolved apart) when the full well's exceeds [`NOISE_SPLIT_MAX_REL_SD`] of itself.
    /// Returns the method's words.
    ///
    /// Why: held at the search's start, the read noise kept it: the independent renderer's
    /// 2000 e⁻ / 185 e⁻ footage, searched from 60 e⁻, was fitted at 609 ± 193 e⁻ and 60 ± 30
    /// e⁻; a probe scaling both together (2× and ½×) moved off the valley (the shot part
    /// changes the total) and inflated that only to ± 229 e⁻.
    pub(super) fn noise_along_valley(
        &self,
        prior: &[(Effect, Vec<f64>)],
        values: &mut [f64],
        stds: &mut [f64],
        reported: &mut [Option<f64>],
        evaluated: &RefCell<Vec<(Vec<f64>, Objectives)>>,
    ) -> String {
        let e = Effect::PixelNoise;
        if !self.shot_noise_shows() {
            reported.fill(Some(f64::INFINITY));
            let s = &aligned_of(self).scenario;
            let span = s.effects.lighting.span_dn();
            // The sensor's σ in DN, the clip undone, beside what the footage shows.
            let sensor_dn = |channel: &str, level: f64| {
                self.channel_pair(channel, &[])
                    .map_or((f64::NAN, f64::NAN), |(dn, _)| {
                        let v = plan::sensor_variance(dn, level, span).unwrap_or(f64::NAN);
                        (v.sqrt() * span, dn)
                    })
            };
            let (ink, ink_dn) = sensor_dn("noise_ink", s.scene.ink_radiance);
            let (paper, paper_dn) = sensor_dn("noise_paper", s.scene.paper_radiance);
            return format!(
                "; full well and read noise not resolved apart: the sensor's noise is no higher \
                 on the paper than on the ink ({paper:.2} and {ink:.2} DN once the tone curve's \
                 clip is undone; {paper_dn:.2} and {ink_dn:.2} DN in the footage), so no shot \
                 noise shows and only their total is measured; the values are one pair giving it"
            );
        }
        let specs = e.params();
        let s = &aligned_of(self).scenario;
        let s_ref = mid_grey(&s.scene);
        let (fw0, rn0) = (values[0], values[1]);
        let var_ref = sensor_variance(s_ref, fw0, rn0);
        if !(s_ref > 0.0 && var_ref.is_finite() && var_ref > 0.0) {
            return String::new();
        }
        let lo = specs[0].search.0.max(s_ref / var_ref).min(fw0);
        let hi = specs[0]
            .search
            .1
            .min(full_well_on_valley(specs[1].search.1, s_ref, var_ref))
            .max(fw0);
        let start = values.to_vec();
        // The start exactly as the coordinate searches left it (its objective is looked up);
        // elsewhere the valley's read noise.
        let at = |fw: f64| -> Vec<f64> {
            // The search's log scale round-trips fw0 to within rounding.
            if (fw / fw0 - 1.0).abs() < 1e-12 {
                start.clone()
            } else {
                vec![fw, read_noise_on_valley(fw, s_ref, var_ref).unwrap_or(0.0)]
            }
        };
        let mut o = SearchOptions::new(lo, hi, true);
        o.max_evaluations = 8;
        let r = minimise(
            |fw| self.cached_sum_z2(prior, e, at(fw), LensCells::All, evaluated),
            fw0,
            &o,
        );
        let best = at(r.value);
        // Along the valley Σ z² is nearly flat and simulated on the fit seeds, so it scatters by
        // more than its curvature between neighbouring full wells: with the read noise dominating
        // (500 e⁻, 46 e⁻) Σ z² lay within 14.3–18.5 from 239 to 1610 e⁻, and the parabola through
        // the best point and its neighbours claimed a full well of about 900 e⁻ to a few percent.
        // The ± is never narrower than the valley's profile interval (shared χ² within 1 of its
        // lowest over the evaluated full wells).
        let valley_points: Vec<(f64, f64)> = r
            .evaluations
            .iter()
            .filter_map(|&(fw, _)| {
                objective_at(&evaluated.borrow(), &at(fw)).map(|f| (fw, f.shared_chi2))
            })
            .collect();
        let sd_valley = shared_std_along(&evaluated.borrow(), at, &r, &o)
            .max(profile_half_width(&valley_points, 1.0));
        // d(RN)/d(FW) along the valley: (2·var_ref·FW − s_ref) / (2·RN).
        let slope = if best[1] > 0.0 {
            (2.0 * var_ref * best[0] - s_ref) / (2.0 * best[1])
        } else {
            f64::INFINITY
        };
        // Off the valley only the total noise is measured: the read noise's ± at fixed full well
        // (the coordinate search's), carried to the new point by δRN = FW²·δvar / (2·RN).
        let sd_rn_across = reported[1].unwrap_or(stds[1])
            * if best == start {
                1.0
            } else {
                Some((best[0] / fw0).powi(2) * rn0 / best[1])
                    .filter(|k| k.is_finite())
                    .unwrap_or(f64::INFINITY)
            };
        let sd_fw = if best == start {
            reported[0].unwrap_or(stds[0]).hypot(sd_valley)
        } else {
            sd_valley
        };
        let sd_rn = sd_rn_across.hypot(slope * sd_valley);
        values.copy_from_slice(&best);
        stds.copy_from_slice(&[r.std, sd_rn_across.hypot(slope * r.std)]);
        let evaluations: Vec<String> = {
            let mut ev = r.evaluations.clone();
            ev.sort_by(|p, q| p.0.total_cmp(&q.0));
            ev.iter().map(|(x, f)| format!("{x:.0}: {f:.1}")).collect()
        };
        let words = format!(
            "; then along the valley the footage fixes (the noise at mid-grey, s/FW + RN²/FW² = \
             {var_ref:.3e}, kept: full well e⁻ → Σ z² {})",
            evaluations.join(", ")
        );
        if noise_split_determined(best[0], sd_fw) {
            reported[0] = Some(sd_fw);
            reported[1] = Some(sd_rn);
            return words;
        }
        reported.fill(Some(f64::INFINITY));
        format!(
            "{words}; full well and read noise not resolved apart (the full well's ± {sd_fw:.0} \
             e⁻ along it exceeds {NOISE_SPLIT_MAX_REL_SD} of itself): the values are one pair on \
             that valley"
        )
    }

    /// The pixel noise by moment matching. The sensor's noise variance at radiance s is a·s + b,
    /// linear in (a, b) = (1/FW, RN²/FW²); the footage shows it behind the tone curve (span² in
    /// DN²), the clip at black and white and the 8-bit quantisation, which
    /// [`plan::sensor_variance`] undoes. Newton steps with the model's Jacobian on the sensor
    /// variances at the ink and paper levels; blur, uneven light and compression bend the real
    /// map further, and the simulations in the loop absorb that. [`MomentFit::Search`] where
    /// the footage does not follow the model or the split is not determined.
    pub(super) fn noise_by_moments(
        &self,
        prior: &[(Effect, Vec<f64>)],
        start: &[f64],
    ) -> Result<MomentFit, FitError> {
        let e = Effect::PixelNoise;
        let sims_factor = self.moment_sims_factor();
        let s = &aligned_of(self).scenario;
        let span = s.effects.lighting.span_dn();
        let (si, sp) = (s.scene.ink_radiance, s.scene.paper_radiance);
        let det = si - sp;
        if det.abs() < 1e-12 || span <= 0.0 {
            return Ok(MomentFit::Search(None));
        }
        // Only where the footage follows the model's shape (more sensor noise on the paper
        // than on the ink): denoising or compression can invert that, and Newton steps on a
        // map of the wrong shape run to the bounds; the Σ z² search handles those.
        if !self.shot_noise_shows() {
            return Ok(MomentFit::Search(None));
        }
        let sensor = |sigma_dn: f64, level: f64| plan::sensor_variance(sigma_dn, level, span);
        // d(sensor variance)/d(DN variance) at a measured σ: 1/span² away from the clip.
        let slope = |sigma_dn: f64, level: f64| {
            let v = sigma_dn * sigma_dn - 1.0 / 12.0;
            match sensor(sigma_dn, level) {
                Some(u) if v > 0.0 && u > 0.0 => u / v,
                _ => 1.0 / (span * span),
            }
        };
        let (mut a, mut b) = moments::noise_to_linear(start[0], start[1]);
        for k in 0..MOMENT_SIMULATIONS {
            let Some((fw, rn)) = moments::noise_from_linear(a, b) else {
                return Ok(MomentFit::Search(None));
            };
            let g = self.gap_with(prior, e, &[fw, rn])?;
            let (Some(ink), Some(paper)) = (
                moments::channel_means(&g, "noise_ink", &[]),
                moments::channel_means(&g, "noise_paper", &[]),
            ) else {
                return Ok(MomentFit::Search(None));
            };
            let (Some(ui_real), Some(ui_sim), Some(up_real), Some(up_sim)) = (
                sensor(ink.real, si),
                sensor(ink.sim, si),
                sensor(paper.real, sp),
                sensor(paper.sim, sp),
            ) else {
                return Ok(MomentFit::Search(None));
            };
            let (dui, dup) = (ui_real - ui_sim, up_real - up_sim);
            // [si 1; sp 1]·(da, db) = (dui, dup).
            let da = (dui - dup) / det;
            let db = (si * dup - sp * dui) / det;
            let (a1, b1) = ((a + da).max(1e-9), (b + db).max(0.0));
            let converged = (da / a).abs() < 0.005 && db.abs() <= 0.005 * b.max(1e-12);
            (a, b) = (a1, b1);
            if converged || k + 1 == MOMENT_SIMULATIONS {
                let Some((fw, rn)) = moments::noise_from_linear(a, b) else {
                    return Ok(MomentFit::Search(None));
                };
                // The real variances' uncertainty through the same maps: the sampling error
                // and the channel's renderer tolerance, the relative 1-sd term the verdict's
                // z gives two honest renderers' noise at one grey level.
                let sd_sigma = |m: &moments::ChannelMeans, channel: &str| {
                    let tol =
                        crate::diagnose::cells::channel(channel).map_or(0.0, |c| c.tol_rel.ln_1p());
                    ((m.real_std * sims_factor).powi(2) + (tol * m.real).powi(2)).sqrt()
                };
                let (svi, svp) = (
                    2.0 * ink.real * sd_sigma(&ink, "noise_ink") * slope(ink.real, si),
                    2.0 * paper.real * sd_sigma(&paper, "noise_paper") * slope(paper.real, sp),
                );
                let sa = ((svi * svi + svp * svp).sqrt() / det).abs();
                let sb = ((si * svp).powi(2) + (sp * svi).powi(2)).sqrt() / det.abs();
                // FW = 1/a; RN = √b/a.
                let sd_fw = sa / (a * a);
                let sd_rn = if b > 0.0 {
                    ((sb / (2.0 * b.sqrt() * a)).powi(2) + (b.sqrt() * sa / (a * a)).powi(2)).sqrt()
                } else {
                    f64::INFINITY
                };
                let specs = e.params();
                let inside = |v: f64, r: (f64, f64)| v > r.0 && v < r.1;
                if !(inside(fw, specs[0].search) && inside(rn, specs[1].search)) {
                    // Ran to a bound: the map is not the model's; search instead.
                    return Ok(MomentFit::Search(None));
                }
                if !noise_split_determined(fw, sd_fw) {
                    // Read noise dominates at both levels: the two variances leave the shot
                    // part (1/FW) to the renderers' difference. Σ z² over all the signature
                    // cells came nearer on the one case measured (1054 e⁻ for 2000, the
                    // match 496).
                    return Ok(MomentFit::Search(Some(format!(
                        "; searched, not matched: the noise at the ink and paper levels gave \
                         a full well of {fw:.0} ± {sd_fw:.0} e⁻ (read noise {rn:.1} e⁻), \
                         beyond {NOISE_SPLIT_MAX_REL_SD} of itself: read noise dominates \
                         both levels and the shot part is not resolved"
                    ))));
                }
                let v = vec![fw, rn];
                return Ok(MomentFit::Fitted((
                    v,
                    vec![sd_fw, sd_rn],
                    moment_method(
                        "noise variance at the ink and paper levels",
                        k + 1,
                        self.fit_seeds.len(),
                    ),
                )));
            }
        }
        Ok(MomentFit::Search(None))
    }
}
