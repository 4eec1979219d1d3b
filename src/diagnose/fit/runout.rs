//! The axis runout's form: its order and phase read off the marker-centre track, the phase
//! refined by simulation, and the amplitude's and phase's uncertainties with the other free.

use super::{Fitter, LensCells};
use crate::diagnose::gap::compare_for_fit;
use crate::diagnose::objectives::held_curvature_std;
use crate::diagnose::objectives::objective_at;
use crate::diagnose::objectives::shared_curvature_std_along;
use crate::diagnose::objectives::Objectives;
use crate::diagnose::runout::RunoutForm;
use crate::diagnose::search::coupling_from_off_point;
use crate::diagnose::search::minimise;
use crate::diagnose::search::std_with_other_free;
use crate::diagnose::search::SearchOptions;
use crate::diagnose::search::SearchResult;
use crate::scenario::effects::Effect;
use std::cell::RefCell;

/// Share of the marker-centre residual a runout form must take before the runout candidate takes
/// it (order, phase, and its amplitude as the search's start). Below it the residual is mostly
/// other motion and noise, and the candidate keeps its own form: on the independent renderer's
/// footage a 3-cycle runout took 83 % of it, the angle-only effects 25 % (backlash) and 44 %
/// (drive speed), where a free form let the runout candidate come within 0.04 of backlash's
/// shrink.
const RUNOUT_FORM_MIN_SHARE: f64 = 0.6;

/// How far from the track's phase [`Fitter::refine_runout_phase`] searches, rad: beyond the
/// track's largest error seen (0.19 rad), short of a quarter turn of the form.
const RUNOUT_PHASE_REACH_RAD: f64 = 0.5;

/// The runout form's phase as the simulation refined it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct RunoutPhase {
    refined_rad: f64,
    /// The parts of [`RunoutPhase::std_rad`]: the shared χ²'s curvature alone (infinite where
    /// it has none) and the final bracket's spread.
    curvature_std_rad: f64,
    bracket_std_rad: f64,
    /// Σ z²'s curvature (the search's own, which the reported ± never falls below).
    search_std_rad: f64,
    /// The amplitude the phase was searched at (the track's), m.
    at_amplitude_m: f64,
}

impl RunoutPhase {
    /// The refined phase's uncertainty with the amplitude held at `at_amplitude_m`, as every
    /// searched parameter's ([`shared_std_along`]): the shared-tolerance χ²'s curvature and the
    /// search's final bracket. It does not hold the fit seeds' own noise: on the independent
    /// renderer's calibrated chain the phase came out 0.14 ± 0.05 rad for a true 0 on 2 fit
    /// seeds (± 0.04 from Σ z²'s curvature), 0.07 ± 0.14 on 3.
    fn std_rad(&self) -> f64 {
        held_curvature_std(self.search_std_rad, self.curvature_std_rad).hypot(self.bracket_std_rad)
    }
}

/// The runout's amplitude and phase uncertainties with the other free
/// ([`Fitter::runout_phase_freed`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct RunoutFreed {
    amplitude_std_m: f64,
    phase_std_rad: f64,
    /// The shared χ²'s normalised cross-curvature of amplitude and phase
    /// ([`coupling_from_off_point`]).
    coupling: f64,
    /// ρ² reached [`crate::diagnose::search::COUPLING_SQ_MAX`]: both ± are lower bounds.
    capped: bool,
}

/// The runout form a fitted runout took from the footage (the track's order, the phase refined
/// by simulation), reported beside its amplitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FittedRunoutForm {
    pub cycles_per_wheel_rev: f64,
    pub phase_rad: f64,
    /// The phase's 1-σ uncertainty, with the amplitude free when the fit measured how the two
    /// trade ([`Fitter::runout_phase_freed`]), else with it held at the track's.
    pub phase_std_rad: f64,
}

impl Fitter<'_> {
    /// The runout form the candidate takes from the track: only when the nominal states no
    /// runout of its own (a stated form is the user's, refitted in amplitude alone) and the form
    /// takes [`RUNOUT_FORM_MIN_SHARE`] of the centre residual.
    /// Its phase is the simulation's refinement when [`Fitter::refine_runout_phase`] ran.
    pub(super) fn fitted_runout_form(&self) -> Option<RunoutForm> {
        self.track_runout_form().map(|f| RunoutForm {
            phase_rad: self.runout_phase.map_or(f.phase_rad, |p| p.refined_rad),
            ..f
        })
    }

    /// The runout form as read off the track, when the candidate takes it
    /// ([`Fitter::fitted_runout_form`]).
    pub(super) fn track_runout_form(&self) -> Option<RunoutForm> {
        if Effect::AxisRunout.is_on(&self.base.scenario) {
            return None;
        }
        self.real
            .runout_form
            .filter(|f| f.rss_reduction_frac >= RUNOUT_FORM_MIN_SHARE)
    }

    /// Refines the phase of the runout form read off the track by simulation: a search of the
    /// phase, at the track's amplitude, on Σ z² over the runout's signature cells (the
    /// pipeline in the loop). Call before candidates are fitted; forks take the result, so every
    /// fit, pair and shard uses the same form. Nothing to do when the candidate keeps its own
    /// form (or the nominal's).
    ///
    /// Why: the track's least squares read the phase 0.05–0.19 rad off on both renderers'
    /// footage (what the nominal's alignment and circle fit take of the wobble bends the
    /// residual it reads), and at 0.11 rad off a 2 mm runout fitted 1.955 mm closed only 80 % of
    /// its own gap (a drive-speed variation closed 100 %); at the true phase it closed 100 %.
    pub fn refine_runout_phase(&mut self) {
        let Some(form) = self.track_runout_form() else {
            return;
        };
        let e = Effect::AxisRunout;
        let amplitude_m = self.start_values(e)[0];
        let mut o = SearchOptions::new(
            form.phase_rad - RUNOUT_PHASE_REACH_RAD,
            form.phase_rad + RUNOUT_PHASE_REACH_RAD,
            false,
        );
        // Three points and one parabolic step (or one step outwards): the track's phase is
        // near, and each evaluation costs the fit seeds' simulations.
        o.step_u = 0.12;
        o.tol_u = 0.02;
        o.max_evaluations = 4;
        let applied = [(e, vec![amplitude_m])];
        let evaluated: RefCell<Vec<(Vec<f64>, Objectives)>> = RefCell::new(Vec::new());
        let r = minimise(
            |phase_rad| {
                let trial = self.trial_with_form(&applied, Some(RunoutForm { phase_rad, ..form }));
                let f = self.objectives_of(&[e], trial, compare_for_fit, LensCells::All);
                evaluated.borrow_mut().push((vec![phase_rad], f));
                f.sum_z2
            },
            form.phase_rad,
            &o,
        );
        if r.objective.is_finite() {
            let evaluated = evaluated.borrow();
            self.runout_phase = Some(RunoutPhase {
                refined_rad: r.value,
                curvature_std_rad: shared_curvature_std_along(&evaluated, |x| vec![x], &r, &o),
                bracket_std_rad: r.bracket_std(),
                search_std_rad: r.std,
                at_amplitude_m: amplitude_m,
            });
        }
    }

    /// The runout amplitude's and phase's uncertainties with the other free, for a runout fitted
    /// alone whose form took the refined phase: the phase was searched at the track's amplitude
    /// and the amplitude at the refined phase, each with the other held, and the two trade. One
    /// more evaluation, 2 σ off both search lines, measures the shared χ²'s cross-curvature
    /// ([`coupling_from_off_point`]), and each ± grows by 1/√(1 − ρ²). The fit seeds' own noise
    /// is still not in them (see [`RunoutPhase::std_rad`]).
    /// `None` when a curvature is missing or the point says nothing (the ± then hold the other
    /// fixed, and the method says so).
    fn runout_phase_freed(
        &self,
        amplitude_m: f64,
        search: &(SearchResult, SearchOptions),
        evaluated: &[(Vec<f64>, Objectives)],
    ) -> Option<RunoutFreed> {
        let (p, form) = (self.runout_phase?, self.fitted_runout_form()?);
        let (r, o) = search;
        let sigma_a = shared_curvature_std_along(evaluated, |x| vec![x], r, o);
        let at_minimum = objective_at(evaluated, &[amplitude_m])?.shared_chi2;
        let sigma_p = p.curvature_std_rad;
        if !(sigma_a.is_finite() && sigma_p.is_finite() && at_minimum.is_finite()) {
            return None;
        }
        // Away from the amplitude the phase was searched at: a point back on that line says
        // nothing of the cross term.
        let from_track = (amplitude_m - p.at_amplitude_m) / sigma_a;
        let s = if from_track >= 0.0 || amplitude_m - 2.0 * sigma_a <= 0.0 {
            2.0
        } else {
            -2.0
        };
        let t = 2.0;
        let e = Effect::AxisRunout;
        let trial = self.trial_with_form(
            &[(e, vec![amplitude_m + s * sigma_a])],
            Some(RunoutForm {
                phase_rad: form.phase_rad + t * sigma_p,
                ..form
            }),
        );
        let off = self
            .objectives_of(&[e], trial, compare_for_fit, LensCells::All)
            .shared_chi2;
        let coupling = coupling_from_off_point(at_minimum, off, s, t, from_track)?;
        let (amplitude_curvature, capped) =
            std_with_other_free(held_curvature_std(r.std, sigma_a), coupling);
        let (phase_curvature, _) =
            std_with_other_free(held_curvature_std(p.search_std_rad, sigma_p), coupling);
        Some(RunoutFreed {
            amplitude_std_m: amplitude_curvature.hypot(r.bracket_std()),
            phase_std_rad: phase_curvature.hypot(p.bracket_std_rad),
            coupling,
            capped,
        })
    }

    /// The runout's form after its amplitude search: the track's order and phase `f`, the phase
    /// refined by simulation when it was, and the amplitude's ± (in `stds[0]`) with the phase
    /// free when a single-effect search at `amplitude_m` lets the two be measured together.
    /// Returns the method's words and the form.
    pub(super) fn runout_form_step(
        &self,
        prior: &[(Effect, Vec<f64>)],
        f: &RunoutForm,
        amplitude_m: f64,
        stds: &mut [f64],
        last_search: Option<&(SearchResult, SearchOptions)>,
        evaluated: &RefCell<Vec<(Vec<f64>, Objectives)>>,
    ) -> (String, FittedRunoutForm) {
        let mut method = format!(
            "; form from the marker-centre track: {} cycles per wheel revolution, \
             phase {:.2} rad ({:.0} % of the centre residual)",
            f.cycles_per_wheel_rev,
            f.phase_rad,
            100.0 * f.rss_reduction_frac
        );
        // The track's phase, without a ± of its own, unless the simulation refined it.
        let mut phase = (f.phase_rad, f64::INFINITY);
        if let Some(p) = self.runout_phase {
            // In a pair the other effect's cells join the objective, whose phase curvature the
            // refinement did not measure.
            let freed = last_search.filter(|_| prior.is_empty()).and_then(|search| {
                self.runout_phase_freed(amplitude_m, search, &evaluated.borrow())
            });
            let phase_std_rad = freed.map_or(p.std_rad(), |fr| fr.phase_std_rad);
            phase = (p.refined_rad, phase_std_rad);
            method.push_str(&format!(
                ", the phase refined by simulation to {:.2} ± {:.2} rad",
                p.refined_rad, phase_std_rad
            ));
            match freed {
                Some(fr) => {
                    stds[0] = fr.amplitude_std_m;
                    method.push_str(&format!(
                        "; amplitude and phase trade against each other (cross-curvature \
                         {:.2}, from one more evaluation off both searches) and each ± holds \
                         the other free{}",
                        fr.coupling,
                        if fr.capped {
                            " (the cross-curvature at its cap: both ± are lower bounds)"
                        } else {
                            ""
                        }
                    ));
                }
                None => method.push_str(
                    "; the amplitude's ± holds that phase fixed, and amplitude and phase trade \
                     against each other",
                ),
            }
        }
        let form = FittedRunoutForm {
            cycles_per_wheel_rev: f.cycles_per_wheel_rev,
            phase_rad: phase.0,
            phase_std_rad: phase.1,
        };
        (method, form)
    }
}
