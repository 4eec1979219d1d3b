//! Fitting and judging candidate effects: for one effect (or a pair), build the trial (the
//! aligned nominal with the effect switched on at given parameters), fit the parameters by
//! simulated method of moments (minimise Σ z² over the effect's signature cells with the
//! [`Simulator`](super::simulator::Simulator) in the loop, on the fit seeds), then re-simulate
//! on fresh seeds (the evaluation seeds, shared with the nominal) and measure how far the gap
//! shrinks.

use crate::diagnose::align::{align_motion, apply_motion};
use crate::diagnose::camera_warp;
use crate::diagnose::cells::{CellKey, Cells, SlowShape};
use crate::diagnose::gap::{
    compare, compare_for_fit, excess, fmt_sum_z2, shared_tolerance_chi2, GapMap, GapOptions,
};
use crate::diagnose::nominal::{AlignError, Aligned};
use crate::diagnose::plan::{self, in_signature};
use crate::diagnose::pose_tilt::PoseTilt;
use crate::diagnose::runout::RunoutForm;
use crate::diagnose::simulator::SimulateError;
use crate::diagnose::trials::{simulated_footage, trial_cells, SimContext, TimingSource, Trial};
use crate::diagnose::verdict::Outcome;
use crate::scenario::effects::{Effect, ParamSpec};
use crate::scenario::Scenario;
use crate::timing::{FrameTimingConfig, TimingModel, VfrModel};
use std::cell::{OnceCell, RefCell};

mod direct;
mod lens;
mod moment_match;
mod noise;
mod runout;
mod search;
mod sinusoid;
mod tilt;
use crate::diagnose::memo::{MemoKey, ObjectiveMemo};
use crate::diagnose::objectives::{objective_at, shared_std_along, Objectives};
pub use lens::{lens_bend_informs, LENS_ANGLE_BEND_MIN_SHARE};
use moment_match::MomentFit;
pub use runout::FittedRunoutForm;
use runout::RunoutPhase;
use sinusoid::vibration_start_hz;
pub use sinusoid::{gain_placement_seeds, GAIN_PLACEMENTS};
pub use tilt::{pose_reported, POSE_DELTA_CHI2};

/// Why a fit, or the fitter it runs in, gave no answer.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    #[error(transparent)]
    Align(#[from] AlignError),
    #[error(transparent)]
    View(#[from] camera_warp::ViewError),
    #[error(transparent)]
    Simulate(#[from] SimulateError),
    #[error("fitting the frame timing of the footage")]
    TimingFit(#[source] crate::timing::TimingError),
    /// A broken invariant of the code, never a property of the input.
    #[error("internal error: {0}")]
    Internal(&'static str),
}

/// A fit read off or matched directly: values, standard uncertainties, the method in words.
type Found = (Vec<f64>, Vec<f64>, String);

/// The effects of `fitted` at their values, as [`Fitter::trial_with`] applies them.
pub fn applied(fitted: &[Fitted]) -> Vec<(Effect, Vec<f64>)> {
    fitted
        .iter()
        .map(|f| (f.effect, f.values.clone()))
        .collect()
}

/// One effect with fitted parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Fitted {
    pub effect: Effect,
    /// In [`Effect::params`] order.
    pub values: Vec<f64>,
    /// 1-σ uncertainties (infinite when the data do not determine a parameter).
    pub stds: Vec<f64>,
    /// How the values were obtained.
    pub method: String,
    /// Simulations run for the fit.
    pub simulations: usize,
    /// An axis runout's form, when it took the footage's ([`FittedRunoutForm`]).
    pub runout_form: Option<FittedRunoutForm>,
    /// How the values were obtained, as the code decides on it (`method` says it in words).
    pub kind: FitKind,
}

/// How a fit obtained its values: what the backfit's guard ([`Fitter::backfit_first`]) asks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitKind {
    /// A search of the fit objective (Σ z² over the signature cells on the fit seeds).
    SumZ2Search,
    /// One statistic of the simulation set matched to the footage's (secant steps): an edge
    /// width, a blockiness, a readout implied by stretch, the noise at two grey levels.
    MomentMatch,
    /// Read off the footage with at most one simulated correction: the timing fit, the
    /// timestamps' rate, the tone inverted from the ink, paper and disc levels.
    Measured,
}

/// How the method of a fit by a Σ z² search begins.
const SEARCH_METHOD: &str = "simulated method of moments: Σ z² over the";

/// How the method of a moment match begins ([`moment_method`]).
const MOMENT_METHOD: &str = "moment matching:";

impl FitKind {
    pub const ALL: [FitKind; 3] = [Self::SumZ2Search, Self::MomentMatch, Self::Measured];

    /// The name a shard record stores.
    pub fn name(self) -> &'static str {
        match self {
            Self::SumZ2Search => "sum_z2_search",
            Self::MomentMatch => "moment_match",
            Self::Measured => "measured",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }
}

/// The method of a Σ z² search of `e` on `fit_seeds` seeds (what a tilt, a lens or a runout
/// did besides is appended).
pub(crate) fn search_method(e: Effect, fit_seeds: usize) -> String {
    format!(
        "{SEARCH_METHOD} {} signature cells, {fit_seeds} fit seeds",
        e.name()
    )
}

/// The method of a moment match of `what` that took `n` simulations of `fit_seeds` seeds.
pub(crate) fn moment_method(what: &str, n: usize, fit_seeds: usize) -> String {
    format!(
        "{MOMENT_METHOD} {what} of the simulation set equal to the footage's ({n} simulations \
         of {fit_seeds} fit seeds, secant steps)"
    )
}

impl Fitted {
    /// Whether the values come from a search of the fit objective (Σ z² over the signature
    /// cells), not from a moment match or a measurement.
    pub fn searched_on_sum_z2(&self) -> bool {
        self.kind == FitKind::SumZ2Search
    }
}

/// A fitted candidate (one effect or a pair) judged on the evaluation seeds.
#[derive(Debug, Clone)]
pub struct Evaluated {
    pub effects: Vec<Fitted>,
    pub gap: GapMap,
    pub outcome: Outcome,
}

/// What the real measurement gives every comparison and fit.
#[derive(Clone, Copy)]
pub struct RealSide<'a> {
    pub cells: &'a Cells,
    /// Frame times of all frames, s.
    pub t_s: &'a [f64],
    /// Times and primary angle of the detected frames.
    pub theta_det: (&'a [f64], &'a [f64]),
    /// The angle residual after the aligned nominal motion at every frame of `t_s` (NaN where
    /// the marker was not found): the series of the `theta` cells.
    pub theta_residual: &'a [f64],
    /// Frequency of the highest spectral peak of the real angle residual above the slow band
    /// (the start of a vibration's frequency fit), Hz.
    pub theta_peak_hz: Option<f64>,
    /// The axis-runout form the marker-centre track shows ([`crate::diagnose::runout`]).
    pub runout_form: Option<RunoutForm>,
    /// The camera tilt the real corners show ([`crate::diagnose::pose_tilt`]).
    pub pose_tilt: Option<PoseTilt>,
}

/// Everything the fits need, and the nominal gap every candidate is judged against.
pub struct Fitter<'a> {
    pub ctx: SimContext<'a>,
    /// The user's nominal (before alignment).
    pub nominal: &'a Scenario,
    /// The real footage's side of every comparison and what its candidates start from.
    pub real: RealSide<'a>,
    /// The runout form's phase refined by simulation ([`Fitter::refine_runout_phase`]), which
    /// the candidate then takes instead of the track's.
    runout_phase: Option<RunoutPhase>,
    /// The aligned nominal (`base`) on the evaluation seeds against the real data.
    pub nominal_gap: GapMap,
    /// The aligned nominal's cells on each evaluation seed (what `nominal_gap` compares), kept
    /// for [`Fitter::add_eval_seeds`]; empty in a fork, which never adds seeds.
    nominal_sims: Vec<Cells>,
    pub base: Trial,
    pub fit_seeds: Vec<u64>,
    pub eval_seeds: Vec<u64>,
    pub gap_options: GapOptions,
    /// Simulations run so far, the nominal's included (for the report).
    pub simulations: RefCell<usize>,
    /// The rotation centre the estimator measures on `base`'s exact corners, px: what every
    /// trial that refits its nuisance matches (computed at the first such trial, shared with
    /// forks made after it).
    base_centre_px: OnceCell<[f64; 2]>,
    /// Fit objectives already simulated ([`crate::diagnose::memo`]); empty in a new fork.
    objective_memo: ObjectiveMemo,
    /// The same footage against the nominal without its clearance, when the nominal states one
    /// ([`Self::with_clearance_free`]): the backlash is fitted there, as a withheld clearance is.
    clearance_free: Option<Box<Fitter<'a>>>,
}

/// Relative standard uncertainty of a parameter matched on edges that a renderer other than the
/// simulation's drew: how differently two honest renderers draw the same blur or the same
/// sheared marker. The independent renderer's strong blurs, matched on the project's
/// renderer's edges, came out 1.5–1.8 % (optical, 1.5 px) and 1.2–3.2 % (motion, 20 ms) off
/// over three seeds, at 14–28 times the footage's sampling error alone; the project's own
/// footage 0.2 % and 0.3 %. Its rolling-shutter readouts, matched on the marker's sub-pixel
/// shape, came out 0.9–1.8 % off on the `fast` rig, and 1.0 % at 5.6 times the sampling error
/// on a second rig filmed closer at 60 fps.
pub const EDGE_RENDER_DISCREPANCY_REL: f64 = 0.02;

/// A moment-matched parameter's uncertainty `sd` (the footage's sampling error) at `value`,
/// with [`EDGE_RENDER_DISCREPANCY_REL`] of the value in quadrature for the effects matched on
/// edges: edge widths (optical and motion blur) and the marker's sub-pixel shape (the rolling
/// shutter's readout).
pub fn with_edge_discrepancy(e: Effect, value: f64, sd: f64) -> f64 {
    match e {
        Effect::OpticalBlur | Effect::MotionBlur | Effect::RollingShutter => {
            sd.hypot(EDGE_RENDER_DISCREPANCY_REL * value)
        }
        _ => sd,
    }
}

/// Which of the lens's signature cells a fit objective counts: all of them, or its shape cells
/// alone (the first stage of a lens fit, [`LENS_ANGLE_BEND_MIN_SHARE`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum LensCells {
    All,
    ShapeOnly,
}

/// Whether cell `key` enters the fit objective of `e`: its signature, less the angle cells of a
/// lens fitted on its shape cells.
fn in_fit_objective(e: Effect, key: &CellKey, lens: LensCells) -> bool {
    in_signature(e, key)
        && !(e == Effect::LensDistortion
            && lens == LensCells::ShapeOnly
            && plan::is_angle_channel(key.channel))
}

/// The footage's median frame interval ([`crate::timing::median_interval_s`]), or 1/30 s when
/// there is no interval: the one rate the footing's Nyquist band and the fit's frame-rate
/// parameters both read, so the two can never disagree.
pub(crate) fn median_interval_s(t_s: &[f64]) -> f64 {
    let h = crate::timing::median_interval_s(t_s);
    if h.is_finite() {
        h
    } else {
        1.0 / 30.0
    }
}

fn aligned_of<'a>(f: &'a Fitter<'a>) -> &'a Aligned {
    f.ctx.aligned
}

/// Simulated cells of `trial` on `seeds`, counted in `simulations`.
fn simulated_cells(
    ctx: &SimContext<'_>,
    trial: &Trial,
    seeds: &[u64],
    images: bool,
    simulations: &RefCell<usize>,
) -> Result<Vec<Cells>, FitError> {
    *simulations.borrow_mut() += seeds.len();
    Ok(trial_cells(ctx, trial, seeds, images)?)
}

impl<'a> Fitter<'a> {
    /// Simulates the base trial (the aligned nominal) on `eval_seeds` and compares it with the
    /// real cells: the fitter starts with the nominal gap that its fits and judgements refer to.
    pub fn new(
        ctx: SimContext<'a>,
        nominal: &'a Scenario,
        real: RealSide<'a>,
        base: Trial,
        fit_seeds: Vec<u64>,
        eval_seeds: Vec<u64>,
        gap_options: GapOptions,
    ) -> Result<Self, FitError> {
        let simulations = RefCell::new(0);
        let nominal_sims = simulated_cells(&ctx, &base, &eval_seeds, true, &simulations)?;
        let nominal_gap = compare(
            real.cells,
            &nominal_sims,
            gap_options,
            SlowShape::of(&base.scenario),
        );
        Ok(Self {
            ctx,
            nominal,
            real,
            runout_phase: None,
            nominal_gap,
            nominal_sims,
            base,
            fit_seeds,
            eval_seeds,
            gap_options,
            simulations,
            base_centre_px: OnceCell::new(),
            objective_memo: ObjectiveMemo::default(),
            clearance_free: None,
        })
    }

    /// Adds evaluation seeds: the nominal is simulated on the new ones only and the nominal gap
    /// recomputed on all of them. Call before any candidate is judged (they all share the
    /// evaluation seeds).
    pub fn add_eval_seeds(&mut self, more: &[u64]) -> Result<(), FitError> {
        debug_assert_eq!(
            self.nominal_sims.len(),
            self.eval_seeds.len(),
            "seeds are added on the main fitter, never on a fork"
        );
        let sims = self.cells(&self.base, more, true)?;
        self.nominal_sims.extend(sims);
        self.eval_seeds.extend_from_slice(more);
        self.nominal_gap = compare(
            self.real.cells,
            &self.nominal_sims,
            self.gap_options,
            SlowShape::of(&self.base.scenario),
        );
        Ok(())
    }

    /// The same fitter with its own simulation counter at zero: a candidate fitted on a fork
    /// costs exactly the fork's count, whichever machine or thread ran it.
    pub fn fork(&self) -> Fitter<'a> {
        Fitter {
            ctx: self.ctx,
            nominal: self.nominal,
            real: self.real,
            runout_phase: self.runout_phase,
            nominal_gap: self.nominal_gap.clone(),
            nominal_sims: Vec::new(),
            base: self.base.clone(),
            fit_seeds: self.fit_seeds.clone(),
            eval_seeds: self.eval_seeds.clone(),
            gap_options: self.gap_options,
            simulations: RefCell::new(0),
            base_centre_px: self.base_centre_px.clone(),
            objective_memo: ObjectiveMemo::default(),
            clearance_free: self
                .clearance_free
                .as_ref()
                .map(|f| Box::new(f.fork_keeping_sims())),
        }
    }

    /// [`Self::fork`] with the nominal simulations kept: the clearance-free fitter's, which a
    /// bootstrap footage fitted there is compared with ([`Self::fit_on_simulated_footage`]).
    fn fork_keeping_sims(&self) -> Fitter<'a> {
        let mut fork = self.fork();
        fork.nominal_sims = self.nominal_sims.clone();
        fork
    }

    /// This fitter with `free` to fit the backlash on: a fitter of the same footage whose
    /// nominal is this one's without the dynamics (`dynamics.enabled = false`), built from its
    /// own alignment ([`crate::diagnose::footing::Footing`]). When the nominal states a clearance, the
    /// residual cells are read after the nominal's own motion, which bounces with it, and a
    /// band's RMS cannot tell a clearance above the stated one from one below: stated 0.3 mm
    /// of a true 0.5 mm came out 0.129 ± 0.032 (`docs/diagnosis-findings.md`, "Clearance"). Against the
    /// clearance-free motion the clearance is what the footage's own bounce says, as when it
    /// is withheld. The values are the same parameters whichever nominal they were fitted
    /// against, so the candidate is judged here, on this fitter's gap, as every other one.
    pub fn with_clearance_free(mut self, free: Fitter<'a>) -> Self {
        self.clearance_free = Some(Box::new(free));
        self
    }

    /// The clearance-free fitter `e` is fitted on, with this fitter's fit seeds (a refit's
    /// fresh ones included): the backlash when the nominal states a clearance.
    fn delegate(&self, e: Effect) -> Option<Fitter<'a>> {
        let free = self
            .clearance_free
            .as_ref()
            .filter(|_| e == Effect::Backlash)?;
        let mut fork = free.fork_keeping_sims();
        fork.fit_seeds = self.fit_seeds.clone();
        Some(fork)
    }

    /// `job` on each of `items`, each on its own fork (handed to the job, which owns it), all
    /// at once (rayon); results in the items' order (a job that counts simulations reads its
    /// fork's). A fork shares nothing mutable, so a result is the same whatever ran beside it
    /// and whatever the thread count. Concurrent fits fill the core one fit's serial work (the
    /// optimiser's among it) leaves idle between its frame-parallel simulations.
    pub fn on_forks<I: Sync, T: Send>(
        &self,
        items: &[I],
        job: impl Fn(Fitter<'a>, &I) -> T + Sync,
    ) -> Vec<T> {
        use rayon::prelude::*;
        let forks: Vec<Fitter<'a>> = items.iter().map(|_| self.fork()).collect();
        forks
            .into_par_iter()
            .zip(items.par_iter())
            .map(|(fork, item)| job(fork, item))
            .collect()
    }

    /// The simulations this fitter has run so far (a fork starts at zero).
    pub fn simulations(&self) -> usize {
        *self.simulations.borrow()
    }

    /// A candidate fitted again as the diagnosis fitted it, on `seeds` instead of the fit seeds:
    /// what the fitted values owe to the fit seeds' realisation
    /// ([`crate::diagnose::fit_noise`]). Consumes the fitter, so that its changed fit seeds
    /// cannot leak into later fits: call it on a fork ([`Self::on_forks`]). The first effect is
    /// fitted alone and each next one beside the ones before it, at their refitted values, as
    /// the pair stage does. The runout form's refined phase is the first fit's. Returns the
    /// fits, and the simulations run, a failed fit's included.
    pub fn refit_on_seeds(
        mut self,
        effects: &[Effect],
        seeds: &[u64],
    ) -> (Result<Vec<Fitted>, FitError>, usize) {
        let before = self.simulations();
        self.fit_seeds = seeds.to_vec();
        let mut prior: Vec<(Effect, Vec<f64>)> = Vec::with_capacity(effects.len());
        let mut refitted = Vec::with_capacity(effects.len());
        for &e in effects {
            match self.fit(e, &prior) {
                Ok(f) => {
                    prior.push((e, f.values.clone()));
                    refitted.push(f);
                }
                Err(err) => return (Err(err), self.simulations() - before),
            }
        }
        let refitted = self.backfit_first(refitted);
        (refitted, self.simulations() - before)
    }

    /// One backfitting round of a greedy fit: `fits[0]` fitted again on top of the others
    /// (which were fitted on top of it), when there are others. Fitted alone, a pair's first
    /// effect takes up what the second does to the cells they share: a JPEG quality matched on
    /// the blockiness of footage whose 1.4 px optical blur the nominal put at 0.7 px came out
    /// 42 (truth 35), and the pair kept it, fitting only the blur on top. Every pair's fit
    /// goes through here (the pair stage, its refits on fresh seeds and its bootstrap
    /// footages), so the values a pair states are fitted alike.
    ///
    /// A first effect fitted by a Σ z² search keeps its values when the refit leaves that
    /// objective higher than they do ([`plan::backfit_keeps_refit`]): the refit searches from a
    /// generic start and can end above them. A first effect matched on its moments (a JPEG
    /// quality on the blockiness, a blur on the edge width) is not fitted on Σ z², and its
    /// refit is the correction the backfit is for: it is always taken.
    pub fn backfit_first(&self, mut fits: Vec<Fitted>) -> Result<Vec<Fitted>, FitError> {
        if fits.len() < 2 {
            return Ok(fits);
        }
        let others = applied(&fits[1..]);
        let refit = self.fit(fits[0].effect, &others)?;
        fits[0] = if fits[0].searched_on_sum_z2() && refit.searched_on_sum_z2() {
            self.better_of_backfit(&others, fits[0].clone(), refit)
        } else {
            refit
        };
        Ok(fits)
    }

    /// `refit` or `kept` (the same effect's values before the refit), whichever leaves the fit
    /// objective beside `others` lower ([`plan::backfit_keeps_refit`]); `kept` says so in its
    /// method.
    fn better_of_backfit(
        &self,
        others: &[(Effect, Vec<f64>)],
        kept: Fitted,
        refit: Fitted,
    ) -> Fitted {
        let at = |values: &[f64]| {
            self.objectives_beside(others, kept.effect, values, compare_for_fit, LensCells::All)
                .sum_z2
        };
        let (kept_sum_z2, refit_sum_z2) = (at(&kept.values), at(&refit.values));
        if plan::backfit_keeps_refit(kept_sum_z2, refit_sum_z2) {
            return refit;
        }
        let beside: Vec<&str> = others.iter().map(|(e, _)| e.name()).collect();
        let specs = self.specs(kept.effect);
        let values: Vec<String> = refit
            .values
            .iter()
            .zip(&specs)
            .map(|(v, spec)| format!("{} = {v:.4e} {}", spec.name, spec.unit))
            .collect();
        Fitted {
            method: format!(
                "{}; refitted beside {}, it ended at {} with Σ z² over both effects' signature \
                 cells {}, above the {} of these values, which are kept",
                kept.method,
                beside.join(", "),
                values.join(", "),
                fmt_sum_z2(refit_sum_z2),
                fmt_sum_z2(kept_sum_z2)
            ),
            simulations: kept.simulations + refit.simulations,
            ..kept
        }
    }

    /// The fit objective (Σ z² over the signature cells of `prior`'s effects and `e`, on the
    /// fit seeds) with `e` at `values` on top of `prior`, and over the same cells with `prior`
    /// alone (`e` as the nominal has it): whether a pair's second effect does anything
    /// ([`crate::diagnose::plan::second_lowers_fit`]). Infinite where a trial fails.
    pub fn objective_beside(
        &self,
        prior: &[(Effect, Vec<f64>)],
        e: Effect,
        values: &[f64],
    ) -> (f64, f64) {
        let fitted = self
            .objectives_beside(prior, e, values, compare_for_fit, LensCells::All)
            .sum_z2;
        let effects: Vec<Effect> = prior.iter().map(|a| a.0).chain([e]).collect();
        let nominal = self
            .objectives_of(
                &effects,
                self.trial_with(prior),
                compare_for_fit,
                LensCells::All,
            )
            .sum_z2;
        (fitted, nominal)
    }

    /// The aligned nominal's cells on each evaluation seed (empty in a fork).
    pub fn nominal_sims(&self) -> &[Cells] {
        &self.nominal_sims
    }

    /// A candidate fitted, as the diagnosis fitted it on the real footage, on a footage
    /// simulated at `truth` on the data seed `footage_seed` and measured as real footage: the
    /// parametric bootstrap of the footage's own noise ([`crate::diagnose::fit_noise`]). The
    /// footage's nominal gap (where the fits take their starts) is against `nominal_sims`, the
    /// main fitter's ([`Self::nominal_sims`]); the fit seeds, the runout form and phase and
    /// the camera tilt's start are this fitter's (read off the real footage). Consumes the
    /// fitter, as [`Self::refit_on_seeds`]. Returns the fits and the simulations run, the
    /// footage's included.
    pub fn fit_on_simulated_footage(
        self,
        nominal_sims: &[Cells],
        truth: &[(Effect, Vec<f64>)],
        footage_seed: u64,
    ) -> (Result<Vec<Fitted>, FitError>, usize) {
        if nominal_sims.is_empty() {
            return (
                Err(FitError::Internal(
                    "a footage fit needs the main fitter's nominal simulations",
                )),
                0,
            );
        }
        // A clearance fitted against the clearance-free motion is bootstrapped there too: its
        // footages are drawn and measured as that fitter sees the real one.
        let delegated = truth.iter().any(|(e, _)| *e == Effect::Backlash);
        if let Some(free) = delegated.then(|| self.delegate(Effect::Backlash)).flatten() {
            let sims = free.nominal_sims.clone();
            let (fits, simulations) = free.fit_on_simulated_footage(&sims, truth, footage_seed);
            let fits = fits.map(|mut fits| {
                for f in fits.iter_mut().filter(|f| f.effect == Effect::Backlash) {
                    f.method.push_str(&clearance_free_note(self.nominal));
                }
                fits
            });
            return (fits, self.simulations() + simulations);
        }
        let footage = match self.trial_with(truth).and_then(|trial| {
            *self.simulations.borrow_mut() += 1;
            Ok(simulated_footage(&self.ctx, &trial, footage_seed)?)
        }) {
            Ok(f) => f,
            Err(e) => return (Err(e), self.simulations()),
        };
        let on_footage = Fitter {
            real: RealSide {
                cells: &footage.cells,
                t_s: &footage.t_s,
                theta_det: (&footage.t_det_s, &footage.theta_det_rad),
                theta_residual: &footage.theta_residual,
                theta_peak_hz: footage.theta_peak_hz,
                ..self.real
            },
            nominal_gap: compare(
                &footage.cells,
                nominal_sims,
                self.gap_options,
                SlowShape::of(&self.base.scenario),
            ),
            ..self.fork()
        };
        let effects: Vec<Effect> = truth.iter().map(|(e, _)| *e).collect();
        let seeds = self.fit_seeds.clone();
        let (fits, simulations) = on_footage.refit_on_seeds(&effects, &seeds);
        (fits, self.simulations() + simulations)
    }

    /// One candidate alone: fitted, then judged on the evaluation seeds, with the simulations
    /// this call ran. The diagnosis calls it on forks ([`Self::on_forks`]), several at once.
    pub fn fit_single(&self, e: Effect) -> Result<(Evaluated, usize), FitError> {
        let before = self.simulations();
        let fitted = self.fit(e, &[])?;
        let evaluated = self.evaluate(vec![fitted])?;
        Ok((evaluated, self.simulations() - before))
    }

    /// The base trial: the aligned nominal at the real frame times, timestamps from the
    /// nominal's frame-timing model.
    pub fn base_trial(aligned: &Aligned, nominal: &Scenario, real_t_s: &[f64]) -> Trial {
        let duration = real_t_s.last().copied().unwrap_or(0.0)
            - real_t_s.first().copied().unwrap_or(0.0)
            + 1e-3;
        Trial {
            scenario: aligned.scenario.clone(),
            stamped_fps: None,
            timing: TimingSource::Model {
                config: nominal.frame_timing.clone(),
                log: nominal.timing_log.clone(),
                duration_s: duration,
            },
        }
    }

    fn real_duration_s(&self) -> f64 {
        self.real.t_s.last().copied().unwrap_or(0.0) - self.real.t_s.first().copied().unwrap_or(0.0)
    }

    fn median_interval_s(&self) -> f64 {
        median_interval_s(self.real.t_s)
    }

    /// The values at which `e` would leave the aligned nominal as it is on this footage
    /// ([`Effect::nominal_values`]).
    pub fn nominal_values(&self, e: Effect) -> Vec<Option<f64>> {
        e.nominal_values(&self.base.scenario, self.footage_fps_hz())
    }

    /// The footage's own frame rate, from its median frame interval, fps.
    pub fn footage_fps_hz(&self) -> f64 {
        1.0 / self.median_interval_s()
    }

    /// The parameters of `e` as this footage's fit searches them: a time inside one frame (an
    /// exposure, a readout) up to the footage's median frame interval ([`Effect::params_on`]).
    pub(crate) fn specs(&self, e: Effect) -> Vec<ParamSpec> {
        e.params_on(self.footage_fps_hz())
    }

    /// The trial with `applied` effects switched on at their values.
    pub fn trial_with(&self, applied: &[(Effect, Vec<f64>)]) -> Result<Trial, FitError> {
        self.trial_with_form(applied, self.fitted_runout_form())
    }

    /// [`Fitter::trial_with`], a runout taking the form `runout_form` (its own when `None`).
    fn trial_with_form(
        &self,
        applied: &[(Effect, Vec<f64>)],
        runout_form: Option<RunoutForm>,
    ) -> Result<Trial, FitError> {
        let mut t = self.base.clone();
        for (e, v) in applied {
            match e {
                Effect::FrameTiming => {
                    let mut cfg = FrameTimingConfig {
                        fps: self.nominal.frame_timing.fps,
                        ..self.nominal.frame_timing.clone()
                    };
                    let mut tmp = self.nominal.clone();
                    tmp.frame_timing = cfg.clone();
                    Effect::FrameTiming.apply(&mut tmp, v);
                    cfg.model = tmp.frame_timing.model;
                    t.timing = TimingSource::Model {
                        config: cfg,
                        log: None,
                        duration_s: self.real_duration_s() + 1e-3,
                    };
                }
                Effect::Timebase => {
                    let fps = v.first().copied().unwrap_or(30.0);
                    let s = &mut t.scenario;
                    let model = match &self.nominal.frame_timing.model {
                        TimingModel::Vfr(m) => m.clone(),
                        _ => VfrModel {
                            rate_error_ppm: 0.0,
                            ..VfrModel::default()
                        },
                    };
                    // The schedule must stay valid at any rate the search tries (footage
                    // stamped at 2.8 fps made the default 55 ms first interval shorter than
                    // half a frame interval, and the whole diagnosis failed on this candidate).
                    let model = model.valid_at(fps);
                    s.frame_timing = FrameTimingConfig {
                        fps,
                        model: TimingModel::Vfr(model),
                        ..self.nominal.frame_timing.clone()
                    };
                    s.timing_log = None;
                    s.duration_s = self.real_duration_s() + 0.5 / fps;
                    t.stamped_fps = Some(fps);
                    t.timing = TimingSource::ConstantRate {
                        fps_hz: fps,
                        frames: self.real.t_s.len(),
                    };
                }
                Effect::DriveSpeed => {
                    e.apply(&mut t.scenario, v);
                    // The crank phase and mean speed are nuisance: refit them for this profile.
                    let (td, th) = self.real.theta_det;
                    let a = align_motion(&t.scenario, td, th, aligned_of(self).screen_sign)
                        .map_err(camera_warp::ViewError::AlignMotion)?;
                    t.scenario = apply_motion(&t.scenario, &a);
                }
                Effect::AxisRunout => {
                    e.apply(&mut t.scenario, v);
                    if let Some(f) = runout_form {
                        let r = &mut t.scenario.dynamics.axis_runout;
                        r.cycles_per_wheel_rev = f.cycles_per_wheel_rev;
                        r.phase_rad = f.phase_rad;
                        r.frequency_hz = 0.0;
                    }
                }
                _ => {
                    e.apply(&mut t.scenario, v);
                }
            }
        }
        if applied.iter().any(|(e, _)| e.trial_refits_motion()) {
            // The crank phase and speed, the marker's angle and the measured rotation centre
            // are nuisance: refit them through this camera or this wobbling axis (see
            // `camera_warp`). A lens too: the angle cells are residuals after the aligned
            // nominal's motion, which absorbed part of the real lens's bend, so a trial that kept
            // that motion matched its whole bend to the part left over and k1 came out biased,
            // by how much depending on the alignment's loss (−0.377 and −0.534 for −0.3 on the
            // independent renderer's footage, trimmed and Huber loss); refitted, the trial's
            // motion absorbs the same part of its own bend, and the same footage gave −0.256.
            // A clearance or coasting wheel too: the nominal's alignment took the wheel's late
            // start for crank phase (55 mrad at 0.5 mm), and a trial that kept it added its own
            // delay. (Refitted, the 0.5 mm clearance still came out 11–16 % low on three seeds
            // of the self-check: its shared fit seeds, not this refit; commit `8b8b8cf`.)
            // A crank speed profile too (`Effect::trial_refits_motion`): the nominal's
            // constant-speed alignment took the profile's slow engagements for a slower crank.
            let (td, th) = self.real.theta_det;
            let sign = aligned_of(self).screen_sign;
            let want_px = match self.base_centre_px.get() {
                Some(c) => *c,
                None => {
                    let c = camera_warp::measured_centre_px(&self.base.scenario, td, sign)?;
                    *self.base_centre_px.get_or_init(|| c)
                }
            };
            t.scenario = camera_warp::refit_nuisance(&t.scenario, want_px, td, th, sign)?;
        }
        Ok(t)
    }

    /// Cells of a trial on `seeds`.
    fn cells(&self, trial: &Trial, seeds: &[u64], images: bool) -> Result<Vec<Cells>, FitError> {
        simulated_cells(&self.ctx, trial, seeds, images, &self.simulations)
    }

    /// The comparison of the real data with a trial on `seeds`.
    pub fn gap(&self, trial: &Trial, seeds: &[u64]) -> Result<GapMap, FitError> {
        Ok(compare(
            self.real.cells,
            &self.cells(trial, seeds, true)?,
            self.gap_options,
            SlowShape::of(&trial.scenario),
        ))
    }

    /// [`Objectives`] over the signature cells of `effects` (the lens's as `lens` says), Σ z²
    /// with the cells compared by `comparison`.
    fn objectives_by(
        &self,
        effects: &[Effect],
        applied: &[(Effect, Vec<f64>)],
        comparison: fn(&Cells, &[Cells], GapOptions) -> GapMap,
        lens: LensCells,
    ) -> Objectives {
        self.objectives_of(effects, self.trial_with(applied), comparison, lens)
    }

    /// [`Objectives`] of `trial` (infinite when it could not be built or simulated) over the
    /// signature cells of `effects`, as [`Fitter::objectives_by`].
    fn objectives_of(
        &self,
        effects: &[Effect],
        trial: Result<Trial, FitError>,
        comparison: fn(&Cells, &[Cells], GapOptions) -> GapMap,
        lens: LensCells,
    ) -> Objectives {
        let failed = Objectives {
            sum_z2: f64::INFINITY,
            shared_chi2: f64::INFINITY,
        };
        let Ok(trial) = trial else {
            return failed;
        };
        let key = MemoKey::new(
            &format!("{trial:?}"),
            &self.fit_seeds,
            effects,
            &format!("{lens:?}, comparison at {:#x}", comparison as usize),
        );
        if let Some(known) = self.objective_memo.get(&key) {
            return known;
        }
        // Image statistics cost most of a simulated measurement; skip them when no signature
        // channel uses them (the objective compares signature cells only).
        let images = effects.iter().any(|e| {
            plan::signature(*e).iter().any(|c| {
                crate::diagnose::cells::channel(c)
                    .is_some_and(|s| s.source == crate::diagnose::cells::Source::Image)
            })
        });
        let Ok(sims) = self.cells(&trial, &self.fit_seeds, images) else {
            return failed;
        };
        let counted = |key: &CellKey| effects.iter().any(|e| in_fit_objective(*e, key, lens));
        let sum_z2 = comparison(self.real.cells, &sims, self.gap_options)
            .cells
            .iter()
            .filter(|c| counted(&c.key))
            .map(|c| c.z * c.z)
            .sum();
        let objectives = Objectives {
            sum_z2,
            shared_chi2: shared_tolerance_chi2(self.real.cells, &sims, self.gap_options, counted),
        };
        self.objective_memo.insert(key, objectives);
        objectives
    }

    /// [`Objectives`] with `e` at `values` on top of `prior`, over the signature cells of all
    /// of them (the lens's as `lens` says), compared by `comparison`: the fit objective (Σ z²,
    /// every cell's tolerance symmetric) with [`compare_for_fit`], and, from the same
    /// simulations, the χ² whose curvature is the fitted parameter's uncertainty.
    fn objectives_beside(
        &self,
        prior: &[(Effect, Vec<f64>)],
        e: Effect,
        values: &[f64],
        comparison: fn(&Cells, &[Cells], GapOptions) -> GapMap,
        lens: LensCells,
    ) -> Objectives {
        let mut applied: Vec<(Effect, Vec<f64>)> = prior.to_vec();
        applied.push((e, values.to_vec()));
        let effects: Vec<Effect> = applied.iter().map(|a| a.0).collect();
        self.objectives_by(&effects, &applied, comparison, lens)
    }

    /// Mean over phases of a channel's real value and the nominal simulations' mean.
    fn channel_pair(&self, channel: &str, phases: &[&str]) -> Option<(f64, f64)> {
        let cells: Vec<_> = self
            .nominal_gap
            .cells
            .iter()
            .filter(|c| c.key.channel == channel && c.key.band.is_none())
            .filter(|c| phases.is_empty() || phases.contains(&c.key.phase))
            .collect();
        if cells.is_empty() {
            return None;
        }
        let n = cells.len() as f64;
        Some((
            cells.iter().map(|c| c.real).sum::<f64>() / n,
            cells.iter().map(|c| c.sim_mean).sum::<f64>() / n,
        ))
    }

    /// RMS over the banded cells of a channel (all phases, the given bands) of real and nominal.
    fn banded_pair(&self, channel: &str, bands: &[u8]) -> Option<(f64, f64)> {
        let cells: Vec<_> = self
            .nominal_gap
            .cells
            .iter()
            .filter(|c| c.key.channel == channel && c.key.band.is_some_and(|b| bands.contains(&b)))
            .collect();
        if cells.is_empty() {
            return None;
        }
        let n = cells.len() as f64;
        let r = (cells.iter().map(|c| c.real * c.real).sum::<f64>() / n).sqrt();
        let s = (cells.iter().map(|c| c.sim_mean * c.sim_mean).sum::<f64>() / n).sqrt();
        Some((r, s))
    }

    /// Image speed of the marker during the drive, px/s (median over frames).
    fn drive_speed_px_s(&self) -> f64 {
        let g = &aligned_of(self).geometry;
        let w = crate::scenario::effects::mean_crank_speed_rad_s(
            &aligned_of(self).scenario.drive_speed,
        );
        // ω2 peaks at a few tenths of ω1 for the internal drive and above ω1 for the external.
        let geneva = aligned_of(self).scenario.mechanism.geneva();
        let peak = geneva.omega2_rad_s(0.0, w).abs();
        0.6 * peak * g.marker_radius_px
    }

    /// First guesses of the parameters of `e` from the real measurement.
    fn start_values(&self, e: Effect) -> Vec<f64> {
        let s = &aligned_of(self).scenario;
        let mut v = e.values(s);
        let fx = &s.effects;
        match e {
            Effect::DriveSpeed => v[0] = if v[0] == 0.0 { -0.1 } else { v[0] },
            Effect::Backlash => v[0] = if e.is_on(s) { v[0] } else { 0.3 },
            Effect::Overrotation => v[0] = (s.dynamics.mu_kinetic / 3.0).max(0.005),
            Effect::DiscVibration => {
                let (r, n) = self.banded_pair("theta", &[0, 1, 2]).unwrap_or((1e-3, 0.0));
                v[0] = (2.0f64.sqrt() * (r * r - n * n).max(1e-10).sqrt()).clamp(1e-5, 1e-2);
                // The trend's peak, the fallback, needs the gap; `fit` reads it when this holds
                // none.
                if let Some(f) =
                    vibration_start_hz(self.real.theta_peak_hz, e.params()[1].search, || None)
                {
                    v[1] = f;
                }
            }
            Effect::AxisRunout => {
                // The wobble shows radially (what the circle fit leaves) and tangentially, as an
                // angle error of wobble / marker radius (the angle is measured about the fitted
                // centre); over a fraction of a wheel turn the circle fit absorbs most of the
                // radial part, so the slow angle residual often carries the wobble alone. Start
                // from the larger of the two readings: a start far below the truth leaves the
                // search on the flat floor where a wobble is invisible.
                let g = &aligned_of(self).geometry;
                let rms_excess = |(r, n): (f64, f64)| (r * r - n * n).max(0.0).sqrt();
                let radial_px = self.banded_pair("radius", &[0]).map_or(1.0, rms_excess);
                let tangential_px = self
                    .banded_pair("theta", &[0])
                    .map_or(0.0, |p| rms_excess(p) * g.marker_radius_px);
                let amplitude_px = 2.0f64.sqrt() * radial_px.max(tangential_px).max(1e-3);
                v[0] = (amplitude_px * g.mm_per_px * 1e-3).clamp(1e-6, 3e-3);
                // The track's own least-squares amplitude when its form is taken: it reads both
                // halves of the wobble at once.
                if let Some(f) = self.fitted_runout_form() {
                    v[0] = f.amplitude_m.clamp(1e-6, 3e-3);
                }
            }
            Effect::CameraVibration => {
                let (r, n) = self.banded_pair("radius", &[1, 2]).unwrap_or((0.3, 0.0));
                v[0] = ((r * r - n * n).max(1e-4).sqrt()).clamp(0.01, 10.0);
            }
            Effect::PixelNoise => {
                let span = fx.lighting.span_dn();
                if let (Some((ni, _)), Some((np, _))) = (
                    self.channel_pair("noise_ink", &[]),
                    self.channel_pair("noise_paper", &[]),
                ) {
                    if let Some((fw, rn)) = plan::guess_noise(
                        ni,
                        np,
                        s.scene.ink_radiance,
                        s.scene.paper_radiance,
                        span,
                    ) {
                        v = vec![fw.clamp(50.0, 1e6), rn.clamp(0.0, 5000.0)];
                    }
                }
            }
            Effect::OpticalBlur => {
                let nominal = if e.is_on(s) {
                    fx.optical_blur.sigma_px
                } else {
                    0.0
                };
                if let Some((r, sim)) =
                    self.channel_pair("edge_along", &["dwell", "entry", "drive", "exit"])
                {
                    v[0] = plan::guess_optical_sigma(r, sim, nominal).clamp(0.05, 6.0);
                }
            }
            Effect::MotionBlur => {
                let nominal = if e.is_on(s) {
                    fx.motion_blur.exposure_s
                } else {
                    0.0
                };
                if let (Some((ra, sa)), Some((rl, sl))) = (
                    self.channel_pair("edge_across", &["drive"]),
                    self.channel_pair("edge_along", &["drive"]),
                ) {
                    let extra = (ra * ra - rl * rl) - (sa * sa - sl * sl);
                    let (lo, hi) = self.specs(e)[0].search;
                    v[0] = plan::guess_exposure_s(extra, self.drive_speed_px_s(), nominal)
                        .clamp(lo, hi);
                } else {
                    v[0] = 0.01;
                }
            }
            Effect::RollingShutter => {
                let nominal = if e.is_on(s) {
                    fx.rolling_shutter.readout_s
                } else {
                    0.0
                };
                if let Some((r, sim)) = self
                    .channel_pair("rs_fine", &["all"])
                    .or_else(|| self.channel_pair("rs_readout", &["all"]))
                {
                    let (lo, hi) = self.specs(e)[0].search;
                    v[0] = (nominal + r - sim).clamp(lo, hi);
                } else {
                    v[0] = 0.01;
                }
            }
            Effect::LensDistortion => v[0] = if e.is_on(s) { v[0] } else { 0.0 },
            Effect::PerspectiveTilt => {
                if let Some(p) = self.real.pose_tilt {
                    v = vec![p.tilt_x_deg, p.tilt_y_deg];
                } else if !e.is_on(s) {
                    v = vec![0.0, 0.0];
                }
            }
            Effect::Compression => v[0] = if e.is_on(s) { v[0] } else { 50.0 },
            _ => {}
        }
        v
    }

    /// Fits `e` on top of `prior` (already fitted effects, kept fixed): on the clearance-free
    /// fitter for a delegated clearance, else by the effect's strategy — a moment match
    /// (`moments`), a direct reading of the footage (`direct`), a disc vibration's sinusoid
    /// (`sinusoid`), or a search of Σ z² (`search`, with the tilt's, lens's, runout's and
    /// noise's own steps).
    pub fn fit(&self, e: Effect, prior: &[(Effect, Vec<f64>)]) -> Result<Fitted, FitError> {
        if let Some(free) = self.delegate(e) {
            let mut fitted = free.fit(e, prior)?;
            *self.simulations.borrow_mut() += free.simulations();
            fitted.method.push_str(&clearance_free_note(self.nominal));
            return Ok(fitted);
        }
        let before = *self.simulations.borrow();
        let specs = self.specs(e);
        let mut values = self.start_values(e);
        let mut stds = vec![f64::INFINITY; specs.len()];
        let fitted = |(values, stds, method): Found, kind: FitKind| Fitted {
            effect: e,
            values,
            stds,
            method,
            simulations: *self.simulations.borrow() - before,
            runout_form: None,
            kind,
        };
        let why_searched = match self.fit_by_moments(e, prior, &values)? {
            MomentFit::Fitted(direct) => return Ok(fitted(direct, FitKind::MomentMatch)),
            MomentFit::Search(why) => why,
        };
        let direct = match e {
            Effect::FrameTiming => Some(self.frame_timing_direct()?),
            Effect::Timebase => Some(self.timebase_direct()),
            Effect::Lighting => Some(self.lighting_inverted(prior, values.clone())?),
            _ => None,
        };
        if let Some(direct) = direct {
            return Ok(fitted(direct, FitKind::Measured));
        }
        if e == Effect::DiscVibration {
            self.start_vibration_frequency(specs[1].search, &mut values, &mut stds);
            // The residual's sinusoid at the vibration's frequency matched to the footage's.
            if let Some(direct) = self.disc_vibration_by_sinusoid(prior, &values)? {
                return Ok(fitted(direct, FitKind::MomentMatch));
            }
        }
        let (values, stds, method, runout_form) =
            self.fit_by_search(e, prior, values, stds, why_searched.as_deref())?;
        Ok(Fitted {
            effect: e,
            values,
            stds,
            method,
            simulations: *self.simulations.borrow() - before,
            runout_form,
            kind: FitKind::SumZ2Search,
        })
    }

    /// The gap map with `e` at `v` on top of `prior`, on the fit seeds.
    fn gap_with(
        &self,
        prior: &[(Effect, Vec<f64>)],
        e: Effect,
        v: &[f64],
    ) -> Result<GapMap, FitError> {
        let mut applied: Vec<(Effect, Vec<f64>)> = prior.to_vec();
        applied.push((e, v.to_vec()));
        let trial = self.trial_with(&applied)?;
        self.gap(&trial, &self.fit_seeds)
    }

    /// Judges `fitted` (applied together) on the evaluation seeds.
    pub fn evaluate(&self, fitted: Vec<Fitted>) -> Result<Evaluated, FitError> {
        let trial = self.trial_with(&applied(&fitted))?;
        let gap = self.gap(&trial, &self.eval_seeds)?;
        let params: usize = fitted.iter().map(|f| f.values.len()).sum();
        let outcome = Outcome {
            remaining: gap.total,
            params,
            significant_left: gap.n_significant(),
        };
        Ok(Evaluated {
            effects: fitted,
            gap,
            outcome,
        })
    }
}

/// Per-cell shrink of `after` against `before`: 1 − excess_after / excess_before for cells with
/// a gap before.
pub fn cell_shrink(before: &GapMap, after: &GapMap) -> Vec<(crate::diagnose::cells::CellKey, f64)> {
    let z0 = before.options.dead_zone_z;
    before
        .cells
        .iter()
        .filter(|c| excess(c.z, z0) > 0.0)
        .map(|c| {
            let e0 = excess(c.z, z0);
            let e1 = after.cell(&c.key).map_or(e0, |a| excess(a.z, z0));
            (c.key, 1.0 - e1 / e0)
        })
        .collect()
}

/// What a backlash fitted against the clearance-free motion adds to its method
/// ([`Fitter::with_clearance_free`]).
pub fn clearance_free_note(nominal: &Scenario) -> String {
    let stated_mm = Effect::Backlash
        .values(nominal)
        .first()
        .copied()
        .unwrap_or(0.0);
    format!(
        "; fitted against the nominal's motion without a clearance (`dynamics.enabled = false`, \
         aligned to the footage on its own), as a withheld clearance is: the nominal states \
         {stated_mm:.3} mm, and the cells read after its own bouncing motion cannot tell a \
         clearance above that from one below (docs/diagnosis-findings.md of geneva-vision, \"Clearance\")"
    )
}

/// The caution an overrotation fit carries when the nominal states a clearance (`None`
/// otherwise, and for every other effect).
///
/// The residual cells are read after the nominal's own motion ([`super::nominal`]'s reference
/// table holds its dynamics), which bounces with the stated clearance, and a band's RMS cannot
/// tell a larger clearance from a smaller one. The backlash is therefore fitted against the
/// clearance-free motion ([`Fitter::with_clearance_free`]); the friction is fitted with the
/// clearance held at the stated value, and a mis-stated one enters it unseen. Before the
/// backlash moved (commit `488b346`, one footage, true clearance 0.5 mm):
/// stated 0.1, 0.2, 0.3, 0.4, 0.6 and 0.7 mm were refitted at 0.13–0.43 mm, all six below the
/// truth, four of them with a ± that did not hold 0.5 (3.9–12 σ). A backlash fit without a
/// clearance-free fitter (a fitter built by hand) carries the caution too.
pub fn stated_clearance_caveat(e: Effect, nominal: &Scenario) -> Option<String> {
    if !matches!(e, Effect::Backlash | Effect::Overrotation) || !Effect::Backlash.is_on(nominal) {
        return None;
    }
    let stated_mm = Effect::Backlash
        .values(nominal)
        .first()
        .copied()
        .unwrap_or(0.0);
    let what = match e {
        Effect::Backlash => "the clearance refitted from it",
        _ => "the friction fitted against it (the clearance held at the stated value)",
    };
    Some(format!(
        "; caution: the nominal states a pin–slot clearance of {stated_mm:.3} mm, and the \
         residual cells are read after the nominal's own motion, which bounces with it, so \
         {what} can land off the truth by more than its ± (docs/diagnosis-findings.md of \
         geneva-vision, \"Clearance\": a true 0.5 mm refitted at 0.13–0.43 mm from six stated clearances of \
         0.1–0.7 mm, four of six 3.9–12 σ off); a clearance is measured against the \
         clearance-free motion (the backlash candidate, or a nominal with \
         `dynamics.enabled = false`)"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::objectives::shared_std;
    use crate::diagnose::search::{minimise, SearchOptions};

    #[test]
    fn a_clearance_refitted_from_a_stated_one_carries_a_caution() -> Result<(), String> {
        let mut s = crate::scenario::load_builtin("fast").map_err(|e| e.to_string())?;
        s.dynamics.enabled = true;
        s.mechanism.pin_diameter_mm = s.mechanism.slot_width_mm - 0.3;
        for e in [Effect::Backlash, Effect::Overrotation] {
            let caveat = stated_clearance_caveat(e, &s).ok_or(format!("{e:?}: no caution"))?;
            if !caveat.contains("0.300 mm") || !caveat.contains("dynamics.enabled = false") {
                return Err(format!("{e:?}: {caveat}"));
            }
        }
        if stated_clearance_caveat(Effect::DiscVibration, &s).is_some() {
            return Err("a caution on an effect that does not fit a clearance".into());
        }
        // No clearance stated (dynamics off, or no room between pin and slot): nothing to caution.
        for (enabled, clearance_mm) in [(false, 0.3), (true, 0.0)] {
            s.dynamics.enabled = enabled;
            s.mechanism.pin_diameter_mm = s.mechanism.slot_width_mm - clearance_mm;
            if let Some(c) = stated_clearance_caveat(Effect::Backlash, &s) {
                return Err(format!("enabled {enabled}, clearance {clearance_mm}: {c}"));
            }
        }
        Ok(())
    }

    #[test]
    fn a_fit_kinds_name_round_trips_and_no_other_name_is_a_kind() {
        for kind in FitKind::ALL {
            assert_eq!(FitKind::from_name(kind.name()), Some(kind));
        }
        assert_eq!(FitKind::from_name("searched"), None);
        assert_eq!(
            FitKind::from_name(&search_method(Effect::AxisRunout, 2)),
            None
        );
    }

    #[test]
    fn the_reported_uncertainty_is_the_shared_chi2s_and_never_below_the_searchs() {
        // Σ z² of four phase cells that share one offset, and its shared χ² (a quarter):
        // the uncertainty doubles, about the minimum Σ z² found.
        let sum_z2 = |x: f64| ((x - 2.0) / 0.1).powi(2) + 5.0;
        let o = SearchOptions::new(0.0, 5.0, false);
        let evaluated: RefCell<Vec<(Vec<f64>, Objectives)>> = Default::default();
        let record = |shared: fn(f64) -> f64| {
            evaluated.borrow_mut().clear();
            let r = minimise(
                |x| {
                    let f = Objectives {
                        sum_z2: sum_z2(x),
                        shared_chi2: shared(x),
                    };
                    evaluated.borrow_mut().push((vec![1.0, x], f));
                    f.sum_z2
                },
                1.0,
                &o,
            );
            let s = shared_std(&evaluated.borrow(), &[1.0, 0.0], 1, &r, &o);
            (r, s)
        };
        let (r, s) = record(|x| (((x - 2.0) / 0.1).powi(2) + 5.0) / 4.0);
        assert!((r.value - 2.0).abs() < 0.05, "{r:?}");
        let with_bracket = |curvature: f64| curvature.hypot(r.bracket_std());
        assert!(
            (s / with_bracket(2.0 * r.std) - 1.0).abs() < 1e-9,
            "{s} vs {}",
            r.std
        );
        // Nine evaluations leave a bracket of 0.06 about a σ of 0.1: it adds little.
        assert!(r.bracket_std() < 0.25 * r.std, "{r:?}");
        // A shared χ² steeper than Σ z² (it cannot be, but rounding) or flat: the search's own.
        let (r, s) = record(|x| ((x - 2.0) / 0.01).powi(2));
        assert_eq!(s, with_bracket(r.std));
        let (r, s) = record(|_| 1.0);
        assert_eq!(s, with_bracket(r.std));
    }

    #[test]
    fn the_median_interval_ignores_dropped_frames_and_has_a_default() {
        // Two dropped frames: intervals 40, 80, 80, 40, 40 ms. The median is 40 ms; the middle
        // of the unsorted intervals would be 80 ms.
        let t_s = [0.0, 0.04, 0.12, 0.2, 0.24, 0.28];
        assert!((median_interval_s(&t_s) - 0.04).abs() < 1e-12);
        // Intervals 30 and 10 ms: the mean of the two middle ones of an even count.
        assert!((median_interval_s(&[0.0, 0.03, 0.04]) - 0.02).abs() < 1e-12);
        assert_eq!(median_interval_s(&[1.0]), 1.0 / 30.0);
        assert_eq!(median_interval_s(&[]), 1.0 / 30.0);
    }

    /// The discrepancy's form: the edge-matched effects' ± gains the renderers' difference in
    /// quadrature, the others keep their sampling ±. Its size, [`EDGE_RENDER_DISCREPANCY_REL`],
    /// was set on the measurements its doc names (the independent renderer's seed 0) and is
    /// checked where it did not set it — the parameter errors on that renderer's other seeds,
    /// `reports/diagnosis-independent-seeds-1-2/` — not here.
    #[test]
    fn edge_matched_effects_add_the_renderers_difference_in_quadrature() {
        for e in [
            Effect::OpticalBlur,
            Effect::MotionBlur,
            Effect::RollingShutter,
        ] {
            let (value, sd) = (2.0, 0.01);
            let with = with_edge_discrepancy(e, value, sd);
            let expected = (sd * sd + (EDGE_RENDER_DISCREPANCY_REL * value).powi(2)).sqrt();
            assert!((with - expected).abs() < 1e-15, "{e:?}");
            // Scales with the value: relative, not absolute.
            let doubled = with_edge_discrepancy(e, 2.0 * value, 0.0);
            assert!((doubled - 2.0 * with_edge_discrepancy(e, value, 0.0)).abs() < 1e-15);
        }
        assert_eq!(with_edge_discrepancy(Effect::Compression, 30.0, 3.0), 3.0);
        assert_eq!(with_edge_discrepancy(Effect::AxisRunout, 2e-3, 1e-4), 1e-4);
    }
}
