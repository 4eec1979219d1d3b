//! The search of Σ z² over an effect's signature cells, one coordinate at a time on the fit
//! seeds (bracket + Brent, [`crate::diagnose::search`]), with the steps some effects add to it:
//! the tilt's pose fit (`tilt`), the lens's second stage (`lens`), the noise's valley (`noise`)
//! and the runout's form (`runout`).

use super::{
    search_method, stated_clearance_caveat, FitError, FittedRunoutForm, Fitter, LensCells,
};
use crate::diagnose::gap::compare_for_fit;
use crate::diagnose::objectives::{objective_at, shared_std, Objectives};
use crate::diagnose::search::{minimise, SearchOptions, SearchResult};
use crate::diagnose::sensor_noise::{self, NOISE_SEARCH_MAX_RATIO};
use crate::scenario::effects::Effect;
use std::cell::RefCell;

/// What a search gives: values, standard uncertainties, the method in words and, for a runout,
/// the form it took from the footage.
pub(super) type Searched = (Vec<f64>, Vec<f64>, String, Option<FittedRunoutForm>);

/// What a video codec's fit says of its bitrate: it names the codec, and states no ±. On four
/// footages of the `fast` rig coded at 1 Mbit/s (H.264, 2 s, a phone's 4 DN of noise) the fits
/// gave 0.46, 0.91, 2.0 and 7.9 Mbit/s while the objective's curvature stated 2–4 %: the
/// encoder's rate control spends its bits on each clip's own noise, so the statistics a fit
/// matches move with the clip as much as with the bitrate, and a ± from one clip's fit would
/// claim what it did not measure.
const CODEC_BITRATE_NOT_MEASURED: &str = "; the bitrate is not measured, only the codec named: \
     fits of footages coded at one bitrate scatter by a factor of 2 or more (0.46–7.9 Mbit/s for 1 \
     on four footages), far beyond their curvature's ±; the container states the bitrate \
     (`geneva calibrate --video` reads it)";

impl Fitter<'_> {
    /// Fits `e` on top of `prior` by searching Σ z² from `values` (with `stds` where a start
    /// already has one); `why_searched` says why a moment match was set aside.
    pub(super) fn fit_by_search(
        &self,
        e: Effect,
        prior: &[(Effect, Vec<f64>)],
        mut values: Vec<f64>,
        mut stds: Vec<f64>,
        why_searched: Option<&str>,
    ) -> Result<Searched, FitError> {
        let specs = self.specs(e);
        // The tilt's two angles interact (either turns the marker's keystone): a second
        // round refits each at the other's fitted value.
        let searched: Vec<usize> = match e {
            Effect::PerspectiveTilt => vec![0, 1, 0, 1],
            Effect::PixelNoise => vec![0, 1],
            _ => vec![0],
        };
        let pose_start = (e == Effect::PerspectiveTilt)
            .then_some(self.real.pose_tilt)
            .flatten();
        // Every objective value by its parameters: a later search starts where an earlier
        // one ended, and the objective is deterministic (fixed seeds), so it is looked up.
        let evaluated: std::cell::RefCell<Vec<(Vec<f64>, Objectives)>> = Default::default();
        let lens_cells = if e == Effect::LensDistortion {
            LensCells::ShapeOnly
        } else {
            LensCells::All
        };
        let mut moved = vec![f64::INFINITY; specs.len()];
        // The uncertainties reported, from the shared-tolerance χ² ([`Objectives`]);
        // `stds` (Σ z²'s) steer the search's own decisions, as they always have.
        let mut reported: Vec<Option<f64>> = vec![None; specs.len()];
        let mut searches_run = 0usize;
        let mut last_search: Option<(SearchResult, SearchOptions)> = None;
        let noise_cap = (e == Effect::PixelNoise)
            .then(|| self.noise_search_cap())
            .flatten();
        for (k, &i) in searched.iter().enumerate() {
            // A second round refits a coordinate at the others' new values: pointless when
            // the one searched last did not move beyond its own uncertainty (a bound or a
            // flat objective, infinite uncertainty, counts as moved).
            if k >= specs.len() {
                let last = searched[k - 1];
                if stds[last].is_finite() && moved[last] <= stds[last] {
                    break;
                }
            }
            let spec = specs[i];
            let mut o = SearchOptions::new(spec.search.0, spec.search.1, spec.log_scale);
            o.max_evaluations = 9;
            if let Some(p) = pose_start {
                // Started at the corners' tilt: step by its uncertainty, not by a
                // sixth of the range (which could cross into the mirror minimum).
                let u95 = if i == 0 { p.u95_x_deg } else { p.u95_y_deg };
                o.step_u = u95.clamp(0.5, 4.0);
            }
            if e == Effect::PixelNoise {
                if let Some(cap) = noise_cap {
                    (o.lo, o.hi) = cap.bound(i, &values, (o.lo, o.hi));
                }
                if i == 1 {
                    let s_ref = sensor_noise::mid_grey(&self.ctx.aligned.scenario.scene);
                    o.step_u = sensor_noise::read_noise_step_e(values[0], values[1], s_ref);
                }
            }
            let base = values.clone();
            let r = minimise(
                |x| {
                    let mut v = base.clone();
                    v[i] = x;
                    self.cached_sum_z2(prior, e, v, lens_cells, &evaluated)
                },
                values[i],
                &o,
            );
            moved[i] = (r.value - values[i]).abs();
            values[i] = r.value;
            stds[i] = r.std;
            reported[i] = Some(shared_std(&evaluated.borrow(), &base, i, &r, &o));
            searches_run += 1;
            last_search = Some((r, o));
        }
        let mut method = search_method(e, self.fit_seeds.len());
        if let Some(why) = why_searched {
            method.push_str(why);
        }
        if let Some(cap) = noise_cap {
            let span_dn = self.ctx.aligned.scenario.effects.lighting.span_dn();
            method.push_str(&format!(
                "; searched where the sensor's noise at mid-grey is at most \
                 {NOISE_SEARCH_MAX_RATIO} times the footage's (σ {:.1} DN before the \
                 tone curve)",
                cap.variance.sqrt() * span_dn
            ));
        }
        if e == Effect::LensDistortion {
            method.push_str(&self.lens_second_stage(prior, &mut values, &mut stds, &mut reported));
        }
        if let Some(p) = pose_start {
            method.push_str(&self.tilt_pose_step(
                prior,
                &p,
                (&mut values, &mut stds, &mut reported),
                searches_run,
            ));
        }
        if e == Effect::PixelNoise {
            method.push_str(&self.noise_along_valley(
                prior,
                &mut values,
                &mut stds,
                &mut reported,
                &evaluated,
            ));
        }
        if e == Effect::VideoCodec {
            reported.fill(Some(f64::INFINITY));
            method.push_str(CODEC_BITRATE_NOT_MEASURED);
        }
        if let Some(caveat) = stated_clearance_caveat(e, self.nominal) {
            method.push_str(&caveat);
        }
        for (s, r) in stds.iter_mut().zip(&reported) {
            if let Some(r) = r {
                *s = *r;
            }
        }
        let mut runout_form = None;
        if let (Effect::AxisRunout, Some(f)) = (e, self.track_runout_form()) {
            let (words, form) = self.runout_form_step(
                prior,
                &f,
                values[0],
                &mut stds,
                last_search.as_ref(),
                &evaluated,
            );
            method.push_str(&words);
            runout_form = Some(form);
        }
        Ok((values, stds, method, runout_form))
    }

    /// Σ z² with `e` at `v` on top of `prior` (cells as `lens` says), looked up in `evaluated`
    /// when a search already simulated it (the objective is deterministic: fixed seeds), else
    /// simulated and recorded there.
    pub(super) fn cached_sum_z2(
        &self,
        prior: &[(Effect, Vec<f64>)],
        e: Effect,
        v: Vec<f64>,
        lens: LensCells,
        evaluated: &RefCell<Vec<(Vec<f64>, Objectives)>>,
    ) -> f64 {
        if let Some(f) = objective_at(&evaluated.borrow(), &v) {
            return f.sum_z2;
        }
        let f = self.objectives_beside(prior, e, &v, compare_for_fit, lens);
        evaluated.borrow_mut().push((v, f));
        f.sum_z2
    }
}
