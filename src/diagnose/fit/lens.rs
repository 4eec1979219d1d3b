//! The lens's two stages: k1 searched on the marker's shape cells first, then with the angle
//! cells once the lens bends the measured angle beyond the residual's noise
//! ([`LENS_ANGLE_BEND_MIN_SHARE`]).

use super::{aligned_of, Fitter, LensCells};
use crate::diagnose::camera_warp;
use crate::diagnose::gap::compare_for_fit;
use crate::diagnose::objectives::shared_std;
use crate::diagnose::objectives::Objectives;
use crate::diagnose::search::minimise;
use crate::diagnose::search::SearchOptions;
use crate::scenario::effects::Effect;
use std::cell::RefCell;

/// Share of the aligned angle residual's RMS that a lens's bend of the measured angle (exact
/// corners) must reach before the angle cells (θ, ω̂, α̂, the angle's peak) enter its fit.
///
/// A radial lens keeps a circle about its centre a circle: a wheel whose axis is imaged near
/// the lens centre keeps its measured angle, and only the marker's shape shows the lens. The
/// angle cells then hold detection noise, and on 2 fit seeds that noise moved Σ z² by ±15 between
/// neighbouring k1: on the project's own renderer, the axis 0.02 px from the centre, a k1 = −0.09
/// lens was fitted at −0.174 ± 0.003 (the search stopped in a dip of the noise), and at −0.109
/// on the shape cells alone. A lens fit therefore starts on its shape cells; the angle cells join
/// in a second search when the lens, at the fitted k1 plus two standard deviations, bends the
/// angle by this share of the residual. The angle residual's slowest band (0–1.5 Hz of 15) holds
/// about 0.3 of its RMS, and a bend moves such a cell (30 % relative tolerance) by one z only
/// beyond about 0.8 of the band's own RMS: 0.3 × 0.8 ≈ 0.25. Off the centre (the bend grows by
/// 3·10⁻⁴ rad per pixel of offset at k1 = 0.6 on the self-check's rig) the angle cells join and
/// carry most of what identifies k1.
pub const LENS_ANGLE_BEND_MIN_SHARE: f64 = 0.25;

/// Whether a lens that bends the measured angle by `bend_rad` RMS moves the angle cells of
/// footage whose aligned angle residual is `residual_rad` RMS (see
/// [`LENS_ANGLE_BEND_MIN_SHARE`]); true when either is unknown (`None` or not finite), as
/// [`lens_bend_phrase`] says.
pub fn lens_bend_informs(bend_rad: Option<f64>, residual_rad: f64) -> bool {
    match bend_rad.filter(|b| b.is_finite()) {
        Some(b) if residual_rad.is_finite() && residual_rad > 0.0 => {
            b >= LENS_ANGLE_BEND_MIN_SHARE * residual_rad
        }
        _ => true,
    }
}

/// How a lens at k1 = `probe` bends the measured angle, in the lens fit's method string: the
/// bend beside the aligned angle residual, or why that comparison cannot be made (the bend not
/// computable on this rig, or no residual to compare with), in which case the angle cells join.
fn lens_bend_phrase(probe: f64, bend_rad: Option<f64>, residual_rad: f64) -> String {
    let residual_known = residual_rad.is_finite() && residual_rad > 0.0;
    match bend_rad.filter(|b| b.is_finite()) {
        None => format!(
            "the bend of the measured angle by a lens at k1 = {probe:.3} could not be computed \
             on this rig"
        ),
        Some(b) if residual_known => format!(
            "a lens at k1 = {probe:.3} bends the measured angle by {b:.2e} rad RMS on this rig \
             ({:.1} % of the aligned angle residual, {residual_rad:.2e} rad)",
            100.0 * b / residual_rad
        ),
        Some(b) => format!(
            "a lens at k1 = {probe:.3} bends the measured angle by {b:.2e} rad RMS on this rig, \
             and the aligned angle residual is zero or unknown"
        ),
    }
}

impl Fitter<'_> {
    /// The second stage of a lens fit, after its first on the shape cells alone: the angle cells
    /// join and k1 is searched again from the first stage's value when the lens, at that k1
    /// plus two standard deviations (the search's far end when the first stage set no
    /// uncertainty), bends the measured angle by [`LENS_ANGLE_BEND_MIN_SHARE`] of the aligned
    /// angle residual. Updates `values` and `stds`; returns the method's words for it.
    pub(super) fn lens_second_stage(
        &self,
        prior: &[(Effect, Vec<f64>)],
        values: &mut [f64],
        stds: &mut [f64],
        reported: &mut [Option<f64>],
    ) -> String {
        let e = Effect::LensDistortion;
        let spec = &e.params()[0];
        let (k1, sd) = (values[0], stds[0]);
        // The first stage's ± as the report states it (not the Σ z² curvature its search
        // decides on), so that the method's words compare with the reported ±.
        let first_reported_sd = reported[0].unwrap_or(sd);
        let reach = if sd.is_finite() {
            k1.abs() + 2.0 * sd
        } else {
            spec.search.0.abs().max(spec.search.1.abs())
        };
        let probe = if k1 > 0.0 {
            reach.min(spec.search.1)
        } else {
            -reach.min(-spec.search.0)
        };
        let (td, _) = self.real.theta_det;
        let bend_rad = camera_warp::angle_bend_rms(
            &self.base.scenario,
            e,
            &[probe],
            td,
            aligned_of(self).screen_sign,
        )
        .ok();
        let residual_rad = aligned_of(self).motion.rms_residual_rad;
        let bend = lens_bend_phrase(probe, bend_rad, residual_rad);
        if !lens_bend_informs(bend_rad, residual_rad) {
            return format!(
                "; on the shape cells: the angle cells left out, as {bend}, below {:.0} %",
                100.0 * LENS_ANGLE_BEND_MIN_SHARE
            );
        }
        // The search's own first step (a sixth of its range), not one scaled by the first
        // stage's uncertainty: the shape cells' k1 can be off by a quarter with another
        // renderer's edges, and a step of 4σ (0.01) left a k1 = −0.3 lens at the first stage's
        // −0.212 on the project's renderer, where the full step reached −0.242.
        let mut o = SearchOptions::new(spec.search.0, spec.search.1, spec.log_scale);
        o.max_evaluations = 9;
        let evaluated: RefCell<Vec<(Vec<f64>, Objectives)>> = Default::default();
        let r = minimise(
            |x| {
                let f = self.objectives_beside(prior, e, &[x], compare_for_fit, LensCells::All);
                evaluated.borrow_mut().push((vec![x], f));
                f.sum_z2
            },
            k1,
            &o,
        );
        values[0] = r.value;
        stds[0] = r.std;
        reported[0] = Some(shared_std(&evaluated.borrow(), &[k1], 0, &r, &o));
        format!(
            "; first on the shape cells (k1 = {k1:.4} ± {first_reported_sd:.4}), then with the \
             angle cells, as {bend}"
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::plan;

    #[test]
    fn the_angle_cells_join_a_lens_fit_when_the_lens_bends_the_angle_beyond_noise() {
        // The self-check's rig, axis 0.02 px from the lens centre: a k1 of 0.6 bends the angle
        // by 7 µrad against 484 µrad of residual.
        assert!(!lens_bend_informs(Some(6.8e-6), 4.84e-4));
        assert!(!lens_bend_informs(Some(0.2 * 4.84e-4), 4.84e-4));
        assert!(lens_bend_informs(Some(0.25 * 4.84e-4), 4.84e-4));
        assert!(lens_bend_informs(Some(1e-2), 4.84e-4));
        // Unknown: kept.
        assert!(lens_bend_informs(None, 4.84e-4));
        assert!(lens_bend_informs(Some(f64::INFINITY), 4.84e-4));
        assert!(lens_bend_informs(Some(f64::NAN), 4.84e-4));
        assert!(lens_bend_informs(Some(1e-9), 0.0));
        assert!(lens_bend_informs(Some(1e-9), f64::NAN));
        assert!(plan::is_angle_channel("theta_peak") && !plan::is_angle_channel("side"));
    }

    #[test]
    fn the_lens_bend_phrase_never_prints_an_infinite_share() {
        let known = lens_bend_phrase(-0.3, Some(1.2e-4), 4.8e-4);
        assert!(known.contains("25.0 %"), "{known}");
        for phrase in [
            lens_bend_phrase(-0.3, None, 4.8e-4),
            lens_bend_phrase(-0.3, Some(f64::INFINITY), 4.8e-4),
            lens_bend_phrase(-0.3, Some(1.2e-4), 0.0),
            lens_bend_phrase(-0.3, Some(1.2e-4), f64::NAN),
        ] {
            assert!(
                !phrase.contains("inf") && !phrase.contains("NaN"),
                "{phrase}"
            );
        }
        assert!(lens_bend_phrase(-0.3, None, 4.8e-4).contains("could not be computed"));
        assert!(lens_bend_phrase(-0.3, Some(1e-4), 0.0).contains("zero or unknown"));
    }
}
