//! `geneva diagnose`: where the real measurement and the nominal simulation disagree, which
//! effect of the vocabulary explains it, and how far the gap shrinks once it is added.
//!
//! 1. The real data are measured with the nominal's detector and estimator (the code of
//!    `geneva analyze`), plus image statistics on every frame ([`real`]).
//! 2. Nuisance alignment ([`crate::diagnose::nominal`]): crank phase and speed, marker angle, orientation,
//!    radius, image scale, rotation-centre and reference-marker positions are fitted, so that
//!    what is left is a gap, not a misplacement.
//! 3. The aligned nominal is simulated at the real frame times on N seeds
//!    ([`crate::diagnose::trials`], rendered and detected by [`simulate::RenderDetect`]); both
//!    sides give the same cells ([`crate::diagnose::cells`]); the gap map compares them.
//! 4. Candidates are screened by their signatures, fitted by simulated method of moments and
//!    re-simulated on the evaluation seeds ([`candidates`], [`fit`]); a greedy pair (its first
//!    effect refitted once beside its second) is tried when one effect is not enough, or when
//!    it is but leaves more than noise leaves in another candidate's cells (a second look,
//!    [`SecondLook`]); the ranking and the verdict are pure ([`crate::diagnose::verdict`]).
//! 5. Outputs ([`report`]): `diagnosis.json`, `diagnosis.md`, gap-map heatmaps, a ranking
//!    chart, before/after residual overlays (their curves simulated by [`overlay`]); the real
//!    measurement's `tracks.csv` under `real/`.
//! 6. Beyond one machine ([`shards`]): the single-candidate fits of step 4 as shards, merged
//!    through the same candidate loop ([`diagnose_with`]).
//!
//! No truth of the real data is used anywhere (there is none).

mod candidates;
#[cfg(test)]
mod engine_tests;
pub mod outlook;
pub mod overlay;
pub mod real;
pub mod report;
pub mod shards;
pub mod simulate;

use crate::diagnose::fit::{self, Evaluated, Fitter};
use crate::diagnose::footing::Footing;
use crate::diagnose::gap::{seed_limited, GapMap, GapOptions};
use crate::diagnose::image;
pub use crate::diagnose::outcome::{
    candidate_name, Bootstrap, Diagnosis, NotDistinct, Ranked, Refit, RefitRun, SecondLook,
    SeedEscalation, SkipReason, SkippedPair, Undetermined,
};
use crate::diagnose::outcome::{pool_refits, widen_by_footages};
use crate::diagnose::plan;
use crate::diagnose::record::RealMeasurement;
use crate::diagnose::verdict::{self, Outcome};
use crate::io::output_dir::OutputDir;
use crate::pipeline::analyze::Source;
use crate::scenario::effects::Effect;
use crate::scenario::Scenario;
use shards::{CandidateStudy, Mode};
use std::cell::RefCell;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    #[error("{}: no image files", dir.display())]
    NoFrames { dir: PathBuf },
    #[error(
        "the footage's frames are {width_px}×{height_px} px but the scenario's camera is \
         {camera_width_px}×{camera_height_px} px (camera.width_px, camera.height_px): the nominal \
         does not describe this footage"
    )]
    FrameSize {
        width_px: usize,
        height_px: usize,
        camera_width_px: usize,
        camera_height_px: usize,
    },
    #[error(
        "the marker (detector.marker_id = {marker_id}, detector.dictionary = {dictionary:?}) is \
         never found in the {frames} frames: check the nominal's marker id and dictionary"
    )]
    MarkerNeverFound {
        marker_id: i32,
        dictionary: String,
        frames: usize,
    },
    #[error(
        "the footage has {detected} frames with the marker (of {frames}); a diagnosis needs at \
         least {needed}: longer footage, or the marker in view more often"
    )]
    TooFewDetections {
        detected: usize,
        frames: usize,
        needed: usize,
    },
    #[error("measuring the real data")]
    Measure(#[source] Box<crate::pipeline::analyze::AnalyzeError>),
    #[error(
        "the marker is found in {detected} of {frames} frames, but its motion cannot be \
         estimated from them"
    )]
    RealEstimate {
        detected: usize,
        frames: usize,
        source: crate::estimate::EstimateError,
    },
    #[error(
        "frame {frame} of the footage is stamped at {t_s} s: a diagnosis simulates the rig from \
         t = 0, so the footage's times must not be negative (subtract the first frame's time \
         from every timestamp)"
    )]
    NegativeFrameTime { frame: usize, t_s: f64 },
    #[error(
        "--max-minutes stops a search by wall time, which no two machines share: a sharded \
         diagnosis fits every candidate (drop --max-minutes, or use more shards)"
    )]
    MaxMinutesWithShards,
    #[error("--seeds {seeds}: at least 2 seeds are needed for a spread")]
    TooFewSeeds { seeds: usize },
    #[error("the merged shards hold no result for candidate {effect}")]
    MissingCandidate { effect: &'static str },
    #[error("no candidate unit {unit} (the diagnosis has {units})")]
    NoUnit { unit: usize, units: usize },
    /// A broken invariant of the code, never a property of the input.
    #[error("internal error: {0}")]
    Internal(&'static str),
    #[error("the nominal scenario's marker layout")]
    NominalLayout(#[source] crate::imagestats::StatsError),
    #[error(transparent)]
    Fit(#[from] crate::diagnose::fit::FitError),
    #[error(transparent)]
    Simulate(#[from] crate::diagnose::simulator::SimulateError),
    #[error("the self-check's base scenario `{spec}`")]
    SuiteBase {
        spec: String,
        #[source]
        source: Box<crate::scenario::ScenarioError>,
    },
    #[error(
        "the self-check's footage duration {duration_s} s: expected a positive number of seconds"
    )]
    SuiteDuration { duration_s: f64 },
    #[error("phone timing log {}", path.display())]
    PhoneLog {
        path: PathBuf,
        #[source]
        source: crate::io::timing_log::TimingLogError,
    },
    #[error("self-check case {case}: rendering its footage")]
    CaseRender {
        case: String,
        #[source]
        source: Box<crate::pipeline::render_job::RenderJobError>,
    },
    #[error(
        "self-check case {case}: the novel effect {kind} cannot be placed on this rig (it needs \
         a frame, and a cable a drive phase in view)"
    )]
    CaseNovel { case: String, kind: &'static str },
    #[error("self-check case {case}: writing its footage")]
    CaseFile {
        case: String,
        #[source]
        source: crate::errors::FileError,
    },
    #[error("self-check case {case}: writing a frame")]
    CasePng {
        case: String,
        #[source]
        source: crate::io::png_out::PngError,
    },
    #[error("{file}: {message}")]
    Output { file: PathBuf, message: String },
    #[error(transparent)]
    File(#[from] crate::errors::FileError),
    #[error(transparent)]
    OutputDir(#[from] crate::io::output_dir::OutputError),
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    #[error("{place}: {what}")]
    Record {
        place: PathBuf,
        what: String,
        source: serde_json::Error,
    },
    #[error(transparent)]
    Shard(#[from] crate::shard::ShardError),
    #[error("{}: no case of the self-check's {total} has finished yet", dir.display())]
    NoCaseFinished { dir: PathBuf, total: usize },
    #[error("{}: the report so far goes into a folder apart from the run's own and its staging folder (neither inside nor around them)", dir.display())]
    SoFarInto { dir: PathBuf },
    #[error(transparent)]
    Image(#[from] crate::io::images::ImageError),
    #[error(transparent)]
    Video(#[from] crate::io::video::VideoError),
}

/// Options of a diagnosis.
#[derive(Debug, Clone)]
pub struct DiagnoseOptions {
    /// Evaluation seeds N (the nominal's spread and every candidate's judgement).
    pub seeds: usize,
    /// Seeds per objective evaluation in the fits.
    pub fit_seeds: usize,
    /// Evaluation seeds to go up to when the nominal comparison on `seeds` finds nothing
    /// significant but would with unlimited seeds ([`crate::diagnose::gap::seed_limited`]);
    /// at or below `seeds`, never.
    pub escalate_seeds: usize,
    /// Candidates (default: the whole vocabulary).
    pub effects: Option<Vec<Effect>>,
    /// Cap on the candidate search; what was not tried is reported.
    pub max_minutes: Option<f64>,
    pub gap: GapOptions,
    /// Try a second effect when the best single one leaves a significant remainder.
    pub pairs: bool,
    /// Fit the best candidate again on this many sets of fresh fit seeds and state the mean of
    /// all its fits, with the seed noise their spread shows ([`crate::diagnose::fit_noise`]);
    /// at 0 its values and ± are the first fit's, and the ± do not hold the fit seeds' noise.
    pub refits: usize,
    /// Footages simulated at the best candidate's stated values on this many fresh data
    /// seeds, each fitted as the real one was: their spread measures the footage's own noise,
    /// which widens the stated ± where the fit's curvature undercounts it
    /// ([`crate::diagnose::fit_noise::from_footage_fits`]); each costs about one fit. 0: off.
    pub bootstrap: usize,
    /// Where a progress display reads the simulations run and still planned (none: counted
    /// and dropped).
    pub meter: Option<Arc<crate::diagnose::simulator::SimMeter>>,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        Self {
            seeds: 6,
            fit_seeds: 3,
            escalate_seeds: ESCALATE_SEEDS,
            effects: None,
            max_minutes: None,
            gap: GapOptions::default(),
            pairs: true,
            refits: REFITS,
            bootstrap: 0,
            meter: None,
        }
    }
}

/// Default of [`DiagnoseOptions::refits`]: two refits give the seed noise two degrees of
/// freedom and the pooled value a third of one fit's seed variance, at two fits' cost (on the
/// benchmark footage one refit took 10–24 s, commit `c986db9`).
pub const REFITS: usize = 2;

/// Fits run at once (candidates, pairs, refits), each on its own fork: a fixed number, not the
/// thread count, so which candidates a wave fits before the best-score bound can prune them is
/// the same on every machine. On 2 cores one fit kept them 1.6 busy (its serial work between
/// frame-parallel simulations, the optimiser's among it, leaves a core idle); two at once took
/// the runout benchmark from 607 s to 547 s on one host (commit `a61c316`).
pub const CONCURRENT_FITS: usize = 2;

/// Second effects fitted beside the best single one when it does not explain the gap
/// ([`plan::second_effects`]), besides the runner-up single ([`plan::runner_up_second`]):
/// each pair costs a fit as long as a single's.
pub const MAX_SECOND_EFFECTS: usize = 3;

/// Default of [`DiagnoseOptions::escalate_seeds`]. On the independent renderer's footage of a
/// strong axis runout, 4 seeds left the angle's low band at z = 4.3–4.8 short of significance on
/// 2 of 3 seeds; 12 seeds found all three, and the 4 null cases stayed without a gap (commits
/// `cb4f031`, `a744f27`).
pub const ESCALATE_SEEDS: usize = 12;

/// The fitted values of `r` beside those at which each of its effects would leave the nominal
/// as it is (forms and values with none left out), and whether they tell it from the nominal:
/// a pair only when each of its effects does, since a second effect at its nominal values makes
/// the pair the single under another name.
/// An effect whose fit measured no value ([`verdict::undetermined_at_search_end`]) does not tell
/// its candidate from the nominal either: its switch, not a fitted value, did the closing.
fn from_nominal(fitter: &Fitter, ranked: usize, r: &Ranked) -> (NotDistinct, Option<bool>) {
    let mut judged = NotDistinct {
        ranked,
        values: Vec::new(),
        undetermined: Vec::new(),
        held_out: None,
    };
    let mut distinct = Some(true);
    for f in &r.evaluated.effects {
        let (compared, mut tells) = fitted_from_nominal(fitter, f, verdict::DISTINCT_Z);
        let specs = fitter.specs(f.effect);
        let search: Vec<(f64, f64)> = specs.iter().map(|p| p.search).collect();
        if verdict::undetermined_at_search_end(&f.values, &f.stds, &search) {
            tells = Some(false);
            judged
                .undetermined
                .extend(specs.iter().zip(&f.values).map(|(p, &value)| Undetermined {
                    effect: f.effect,
                    param: p.name,
                    value,
                    search: p.search,
                }));
        }
        distinct = match (distinct, tells) {
            (Some(false), _) | (_, Some(false)) => Some(false),
            (Some(true), Some(true)) => Some(true),
            _ => None,
        };
        judged.values.extend(compared);
    }
    (judged, distinct)
}

/// One fitted effect's values beside those at which it would leave the nominal as it is, and
/// whether they tell it from the nominal at `z` standard uncertainties
/// ([`verdict::tells_from_nominal_at`]).
fn fitted_from_nominal(
    fitter: &Fitter,
    f: &fit::Fitted,
    z: f64,
) -> (
    Vec<(Effect, &'static str, verdict::FromNominal)>,
    Option<bool>,
) {
    let compared: Vec<(Effect, &'static str, verdict::FromNominal)> = f
        .effect
        .params()
        .iter()
        .zip(fitter.nominal_values(f.effect))
        .zip(f.values.iter().zip(&f.stds))
        .filter_map(|((spec, nominal), (&value, &std))| {
            nominal.map(|nominal| {
                let v = verdict::FromNominal {
                    value,
                    std,
                    nominal,
                };
                (f.effect, spec.name, v)
            })
        })
        .collect();
    let values: Vec<verdict::FromNominal> = compared.iter().map(|c| c.2).collect();
    let tells = verdict::tells_from_nominal_at(&values, z);
    (compared, tells)
}

/// How many candidates after the best one, explaining the gap too, are fitted again and
/// judged when the best one's values do not tell it from the nominal.
const MAX_DISTINCT_TRIES: usize = 3;

/// What a progress callback hears: the stage and how far it is.
pub type Progress<'a> = dyn Fn(&str, usize, usize) + 'a;

/// Progress for logs (no terminal, benchmarks): one line per new stage with the wall time since
/// the start, so the time a stage took is the difference to the next line.
pub struct StageLog {
    started: Instant,
    last: RefCell<String>,
}

impl StageLog {
    pub fn new() -> Self {
        Self {
            started: Instant::now(),
            last: RefCell::new(String::new()),
        }
    }

    /// The line to print when `stage` differs from the previous stage, else `None`.
    pub fn line(&self, stage: &str) -> Option<String> {
        if *self.last.borrow() == stage {
            return None;
        }
        *self.last.borrow_mut() = stage.to_string();
        Some(format!(
            "[{:7.1} s] {stage}",
            self.started.elapsed().as_secs_f64()
        ))
    }
}

impl Default for StageLog {
    fn default() -> Self {
        Self::new()
    }
}

/// Runs the whole diagnosis; writes the outputs into `out_dir` (all or nothing: a staging
/// folder renamed into place at the end).
pub fn diagnose(
    nominal: &Scenario,
    source: &Source,
    out_dir: &Path,
    options: &DiagnoseOptions,
    progress: &Progress<'_>,
) -> Result<(Diagnosis, Vec<PathBuf>), DiagnoseError> {
    match diagnose_with(nominal, source, out_dir, options, Mode::Whole, progress)? {
        Finished::Diagnosis(d, files) => Ok((*d, files)),
        Finished::Shard(_) => Err(DiagnoseError::Internal(
            "a whole diagnosis ended as a shard",
        )),
    }
}

/// What [`diagnose_with`] did.
#[derive(Debug)]
pub enum Finished {
    /// The report was written (whole run or merge).
    Diagnosis(Box<Diagnosis>, Vec<PathBuf>),
    /// A shard's candidate fits were written under `DIR/shards/I/`.
    Shard(crate::shard::RunReport),
}

/// [`diagnose`] on one machine, as one shard of the candidate fits, or as the merge of the
/// shards ([`shards`]): one candidate loop for all three, so a merge is a one-machine run.
pub fn diagnose_with(
    nominal: &Scenario,
    source: &Source,
    out_dir: &Path,
    options: &DiagnoseOptions,
    mode: Mode,
    progress: &Progress<'_>,
) -> Result<Finished, DiagnoseError> {
    let started = Instant::now();
    check_options(options, mode)?;
    let layout = image::marker_layout(nominal).map_err(DiagnoseError::NominalLayout)?;
    real::check_source(nominal, source)?;
    let staging = open_staging(out_dir, mode)?;

    let meter = options.meter.clone().unwrap_or_default();
    let (real, footing) = measure_and_align(
        nominal, source, &layout, &staging, options, &meter, progress,
    )?;
    let seeds: Vec<u64> = (0..options.seeds)
        .map(|k| eval_seed(nominal.seed, k))
        .collect();
    let fit_seeds: Vec<u64> = (0..options.fit_seeds.max(2) as u64)
        .map(|k| nominal.seed.wrapping_add(2000 + k))
        .collect();
    // The nominal without its clearance and the footage aligned to it, declared here so that
    // the backlash's fitter can borrow them ([`Fitter::with_clearance_free`]); aligned only
    // when the backlash is fitted.
    let mut nominal_free = nominal.clone();
    Effect::Backlash.switch_off(&mut nominal_free);
    let footing_free: std::cell::OnceCell<Footing> = std::cell::OnceCell::new();
    meter.plan_more(seeds.len());
    progress("simulating the nominal", 0, seeds.len());
    let mut fitter = footing.fitter(nominal, &layout, fit_seeds.clone(), seeds, options.gap)?;
    let escalation = escalate_seeds(&mut fitter, options, nominal.seed, &meter, progress)?;
    // The evaluation seeds, escalated or not.
    let seeds = fitter.eval_seeds.clone();
    let nominal_gap = fitter.nominal_gap.clone();
    let nominal_gap = &nominal_gap;

    let candidates::Screening {
        screened,
        units,
        not_judged,
    } = candidates::screen(options, real.record.has_images, nominal, nominal_gap);
    let stage_outlook = outlook::Outlook::new(fit_seeds.len(), seeds.len());
    let fits = units.len();
    candidates::plan_tail(
        &stage_outlook,
        &meter,
        nominal_gap,
        options,
        seeds.len(),
        fits,
    );
    // The runout form's phase is refined once, before any fit, so that every fit, pair and
    // shard takes the same form.
    if units.contains(&Effect::AxisRunout) {
        progress("refining the runout form's phase", 0, 1);
        fitter.refine_runout_phase();
    }
    if units.contains(&Effect::Backlash) && Effect::Backlash.is_on(nominal) {
        progress(
            "aligning the nominal without its clearance (the backlash is fitted against it)",
            0,
            1,
        );
        let aligned = aligned_footing(
            &nominal_free,
            &real,
            &layout,
            Some(&[Effect::Backlash]),
            &meter,
        )?;
        let free = footing_free.get_or_init(|| aligned).fitter(
            &nominal_free,
            &layout,
            fit_seeds.clone(),
            seeds.clone(),
            options.gap,
        )?;
        fitter = fitter.with_clearance_free(free);
    }
    let fitter = fitter;
    let stored = match shard_or_merge(
        nominal,
        source,
        out_dir,
        options,
        mode,
        &fitter,
        units.clone(),
        progress,
    )? {
        ControlFlow::Break(shard) => return Ok(shard),
        ControlFlow::Continue(stored) => stored,
    };
    let fit_wave = candidates::wave_fitter(&fitter, stored.as_deref());
    let stage = candidates::Stage {
        fitter: &fitter,
        nominal_gap,
        options,
        progress,
        started,
        meter: &meter,
        outlook: RefCell::new(stage_outlook),
    };
    let mut singles = candidates::Singles::default();
    let mut pairs = candidates::Pairs::default();
    if nominal_gap.n_significant() > 0 {
        singles = candidates::fit_singles(&stage, screened, &fit_wave, stored.is_some())?;
        pairs = candidates::fit_pairs(&stage, &units, &mut singles.ranking)?;
    }
    let mut ranking = singles.ranking;
    let chosen = candidates::choose(&stage, &mut ranking, pairs.second_look.as_ref())?;
    // The prefix ran on `fitter`; each candidate, pair and refit on a fork of it.
    let simulations =
        fitter.simulations() + singles.simulations + pairs.simulations + chosen.simulations;
    let diagnosis = Diagnosis {
        verdict: chosen.verdict,
        aligned: footing.aligned.clone(),
        nominal_gap: nominal_gap.clone(),
        real_cells: footing.real_cells.clone(),
        ranking,
        best: chosen.best,
        screened_out: singles.screened_out,
        bounded_out: singles.bounded_out,
        not_tried: singles.not_tried,
        not_judged,
        pair_tried: pairs.tried,
        skipped_pairs: pairs.skipped,
        second_look: pairs.second_look,
        not_distinct: chosen.not_distinct,
        escalation,
        seeds,
        fit_seeds,
        simulations,
        frames: real.record.frames.len(),
        detected: real.record.detected(),
        has_images: real.record.has_images,
        nyquist_hz: footing.nyquist_hz,
        real_time_shift_s: footing.real_time_shift_s,
        held_out: chosen.held_out,
        elapsed_s: started.elapsed().as_secs_f64(),
    };
    progress("writing the report", 0, 1);
    let curves = overlay::overlay(&diagnosis, &fitter, &real)?;
    let files = report::write(&diagnosis, &curves, &staging)?;
    let files: Vec<PathBuf> = files.iter().map(|f| staging.final_path(f)).collect();
    staging.commit()?;
    Ok(Finished::Diagnosis(Box::new(diagnosis), files))
}

/// The real footage measured (into `real/` of the staging folder) and the nominal aligned to
/// it, its simulations counted on `meter`.
#[allow(clippy::too_many_arguments)] // the prefix's inputs, each used once
fn measure_and_align(
    nominal: &Scenario,
    source: &Source,
    layout: &crate::imagestats::MarkerLayout,
    staging: &OutputDir,
    options: &DiagnoseOptions,
    meter: &Arc<crate::diagnose::simulator::SimMeter>,
    progress: &Progress<'_>,
) -> Result<(RealMeasurement, Footing<'static>), DiagnoseError> {
    progress("measuring the real footage", 0, 1);
    let real = real::measure_real(
        nominal,
        source,
        layout,
        &staging.path().join("real"),
        &|d, t| progress("measuring the real footage", d, t),
    )?;
    progress("aligning the nominal", 0, 1);
    let footing = aligned_footing(nominal, &real, layout, options.effects.as_deref(), meter)?;
    Ok((real, footing))
}

/// `nominal` aligned to the measured footage, simulated by render → detect, its simulations
/// counted on `meter`; the runout form and tilt read only for `effects` (`None`: all).
fn aligned_footing(
    nominal: &Scenario,
    real: &RealMeasurement,
    layout: &crate::imagestats::MarkerLayout,
    effects: Option<&[Effect]>,
    meter: &Arc<crate::diagnose::simulator::SimMeter>,
) -> Result<Footing<'static>, DiagnoseError> {
    Ok(
        Footing::new(nominal, real, layout, effects, &simulate::RenderDetect)?
            .with_meter(meter.clone()),
    )
}

/// What the options allow: `--max-minutes` only on one machine, at least two seeds.
fn check_options(options: &DiagnoseOptions, mode: Mode) -> Result<(), DiagnoseError> {
    if mode != Mode::Whole && options.max_minutes.is_some() {
        return Err(DiagnoseError::MaxMinutesWithShards);
    }
    if options.seeds < 2 {
        return Err(DiagnoseError::TooFewSeeds {
            seeds: options.seeds,
        });
    }
    Ok(())
}

/// Every candidate's fit, as the shards stored it.
type StoredFits = Vec<(Effect, shards::StoredFit)>;

/// A shard fits its share of the candidate `units` here and is done (`Break`, with its
/// report); a merge continues with the shards' stored fits; a whole diagnosis with none.
#[allow(clippy::too_many_arguments)] // the prefix's state, each used once
fn shard_or_merge(
    nominal: &Scenario,
    source: &Source,
    out_dir: &Path,
    options: &DiagnoseOptions,
    mode: Mode,
    fitter: &Fitter,
    units: Vec<Effect>,
    progress: &Progress<'_>,
) -> Result<ControlFlow<Finished, Option<StoredFits>>, DiagnoseError> {
    match mode {
        Mode::Whole => Ok(ControlFlow::Continue(None)),
        Mode::Shard { shard, restart } => {
            let manifest = shards::manifest(nominal, source, options, fitter, &units);
            let study = CandidateStudy::new(fitter.fork(), units, manifest);
            let total = crate::shard::Study::manifest(&study).units;
            // The fits run in parallel and `progress` need not be thread-safe: one line here.
            progress(
                &format!("shard {shard}: fitting its share of {total} candidates"),
                0,
                1,
            );
            let control = crate::shard::Control::none();
            let report = crate::shard::run_shard(&study, out_dir, shard, restart, &control)?;
            Ok(ControlFlow::Break(Finished::Shard(report)))
        }
        Mode::Merge => {
            let manifest = shards::manifest(nominal, source, options, fitter, &units);
            Ok(ControlFlow::Continue(Some(shards::stored(
                out_dir, &manifest, &units,
            )?)))
        }
    }
}

/// The output folder a diagnosis writes into: a shard's scratch folder for its real
/// measurement (a shard keeps no report, and the folder is never committed), else `out_dir`
/// (a merge carrying the shards' records over).
fn open_staging(out_dir: &Path, mode: Mode) -> Result<OutputDir, DiagnoseError> {
    let staging_dir = match mode {
        Mode::Shard { shard, .. } => out_dir
            .join(crate::shard::SHARDS)
            .join(format!(".{}.prefix", shard.index)),
        _ => out_dir.to_path_buf(),
    };
    Ok(match mode {
        Mode::Merge => OutputDir::create_carrying(&staging_dir, &[crate::shard::SHARDS]),
        _ => OutputDir::create(&staging_dir),
    }?)
}

/// The k-th evaluation seed of a nominal seeded `nominal_seed`.
fn eval_seed(nominal_seed: u64, k: usize) -> u64 {
    nominal_seed.wrapping_add(1000 + k as u64)
}

/// A verdict of no gap that more seeds could overturn is not taken on too few: the nominal is
/// simulated on more (`--escalate-seeds`; the first ones are kept, so only the new ones cost)
/// and every candidate is then judged on all of them.
fn escalate_seeds(
    fitter: &mut Fitter,
    options: &DiagnoseOptions,
    nominal_seed: u64,
    meter: &crate::diagnose::simulator::SimMeter,
    progress: &Progress<'_>,
) -> Result<Option<SeedEscalation>, DiagnoseError> {
    let limited = seed_limited(&fitter.nominal_gap);
    if limited.is_empty() || options.escalate_seeds <= options.seeds {
        return Ok(None);
    }
    progress(
        &format!(
            "simulating the nominal on {} more seeds ({} cell(s) short of significance only \
             for lack of seeds)",
            options.escalate_seeds - options.seeds,
            limited.len()
        ),
        0,
        1,
    );
    let more: Vec<u64> = (options.seeds..options.escalate_seeds)
        .map(|k| eval_seed(nominal_seed, k))
        .collect();
    meter.plan_more(more.len());
    fitter.add_eval_seeds(&more)?;
    Ok(Some(SeedEscalation {
        from_seeds: options.seeds,
        to_seeds: options.escalate_seeds,
        cells: limited,
    }))
}

/// The progress line of a wave: "fitting a and b".
fn fitting<S: AsRef<str>>(names: impl Iterator<Item = S>) -> String {
    names
        .enumerate()
        .fold(String::from("fitting"), |line, (i, name)| {
            let joint = if i == 0 { " " } else { " and " };
            line + joint + name.as_ref()
        })
}

/// Seeds of the refits on fresh seeds: the nominal's seed plus this (the evaluation seeds take
/// +1000…, the fit seeds +2000…); refit r takes the r-th block of as many as the fit seeds.
const REFIT_SEED_OFFSET: u64 = 3000;

/// How many refits of the best candidate, on how many fresh seeds each.
struct RefitPlan {
    nominal_seed: u64,
    seeds_per_run: usize,
    runs: usize,
}

impl RefitPlan {
    fn seeds(&self, run: usize) -> Vec<u64> {
        let start = (run * self.seeds_per_run) as u64;
        (start..start + self.seeds_per_run as u64)
            .map(|k| self.nominal_seed.wrapping_add(REFIT_SEED_OFFSET + k))
            .collect()
    }
}

/// Fits `best` again on `plan.runs` sets of fresh fit seeds and pools its values and ± with
/// theirs ([`pool_refits`]). Returns what the refits found and the simulations they ran. A
/// failure is reported, not raised: the fits made before it stand (the first fit alone when
/// the first refit fails). The refits run [`CONCURRENT_FITS`] at a time; `capped` is asked
/// before every wave after the first.
fn refit_on_fresh_seeds(
    fitter: &Fitter,
    best: &mut Ranked,
    plan: &RefitPlan,
    capped: impl Fn() -> bool,
    progress: &Progress<'_>,
) -> (Refit, usize) {
    let name = candidate_name(&best.evaluated);
    let effects: Vec<Effect> = best.evaluated.effects.iter().map(|f| f.effect).collect();
    let mut runs: Vec<(Vec<u64>, Vec<fit::Fitted>)> = Vec::with_capacity(plan.runs);
    let mut simulations = 0;
    let mut short = None;
    let all: Vec<usize> = (0..plan.runs).collect();
    'waves: for wave in all.chunks(CONCURRENT_FITS) {
        let first_run = wave[0];
        if first_run > 0 && capped() {
            short = Some(format!(
                "the time cap (--max-minutes) was reached after {first_run} of {} refits",
                plan.runs
            ));
            break;
        }
        progress(
            &format!("refitting {name} on fresh seeds (the fit's own noise)"),
            first_run,
            plan.runs,
        );
        let fits = fitter.on_forks(wave, |fork, &run| {
            let seeds = plan.seeds(run);
            let (fits, sims) = fork.refit_on_seeds(&effects, &seeds);
            (seeds, fits, sims)
        });
        // Every refit of the wave ran, so all their simulations count, whichever fails.
        simulations += fits.iter().map(|(_, _, sims)| sims).sum::<usize>();
        for (&run, (seeds, fits, _)) in wave.iter().zip(fits) {
            match fits {
                Ok(fits) => runs.push((seeds, fits)),
                Err(err) if runs.is_empty() => {
                    return (Refit::Failed(err.to_string()), simulations)
                }
                Err(err) => {
                    short = Some(format!("refit {} of {} failed: {err}", run + 1, plan.runs));
                    break 'waves;
                }
            }
        }
    }
    (pool_refits(&mut best.evaluated, runs, short), simulations)
}

/// Data seeds of the bootstrap footages: nominal seed + this + k, clear of the evaluation
/// (1000 + k), fit (2000 + k) and refit (3000 + k) seeds.
const BOOTSTRAP_SEED_OFFSET: u64 = 5000;

/// The bootstrap footages of one diagnosis.
struct BootstrapPlan {
    nominal_seed: u64,
    footages: usize,
}

impl BootstrapPlan {
    fn seed(&self, k: usize) -> u64 {
        self.nominal_seed
            .wrapping_add(BOOTSTRAP_SEED_OFFSET + k as u64)
    }
}

/// Fits `best` on `plan.footages` footages simulated at its stated values
/// ([`Fitter::fit_on_simulated_footage`]) and widens its ± by the spread they show where the
/// fits' curvature undercounts it ([`crate::diagnose::fit_noise::from_footage_fits`]).
/// Returns what they found and the simulations they ran. A failure is reported, not raised;
/// with fewer than two footages fitted the ± stand. [`CONCURRENT_FITS`] at a time; `capped`
/// is asked before every wave after the first.
fn bootstrap_footage(
    fitter: &Fitter,
    best: &mut Ranked,
    plan: &BootstrapPlan,
    capped: impl Fn() -> bool,
    progress: &Progress<'_>,
) -> (Bootstrap, usize) {
    let name = candidate_name(&best.evaluated);
    let truth = fit::applied(&best.evaluated.effects);
    let nominal_sims = fitter.nominal_sims();
    let mut done: Vec<(u64, Vec<fit::Fitted>)> = Vec::with_capacity(plan.footages);
    let mut simulations = 0;
    let mut short = None;
    let all: Vec<usize> = (0..plan.footages).collect();
    'waves: for wave in all.chunks(CONCURRENT_FITS) {
        let first = wave[0];
        if first > 0 && capped() {
            short = Some(format!(
                "the time cap (--max-minutes) was reached after {first} of {} footages",
                plan.footages
            ));
            break;
        }
        progress(
            &format!(
                "fitting {name} on footages simulated at its values (the footage's own noise)"
            ),
            first,
            plan.footages,
        );
        let seeds: Vec<u64> = wave.iter().map(|&k| plan.seed(k)).collect();
        let fits = fitter.on_forks(&seeds, |fork, &seed| {
            fork.fit_on_simulated_footage(nominal_sims, &truth, seed)
        });
        simulations += fits.iter().map(|(_, sims)| sims).sum::<usize>();
        for (&seed, (fits, _)) in seeds.iter().zip(fits) {
            match fits {
                Ok(fits) => done.push((seed, fits)),
                Err(err) => {
                    short = Some(format!("the footage of data seed {seed} failed: {err}"));
                    break 'waves;
                }
            }
        }
    }
    if done.len() < 2 {
        let why = short.unwrap_or_else(|| "fewer than two footages asked".to_string());
        return (Bootstrap::Failed(why), simulations);
    }
    (
        widen_by_footages(best, done, short, fitter.footage_fps_hz()),
        simulations,
    )
}

fn ranked(nominal_gap: &GapMap, evaluated: Evaluated) -> Ranked {
    let d0 = nominal_gap.total;
    let raw = if d0 > 0.0 {
        1.0 - evaluated.outcome.remaining / d0
    } else {
        0.0
    };
    Ranked {
        shrink: raw,
        score: verdict::shrink(d0, &evaluated.outcome),
        group: Vec::new(),
        cell_shrink: fit::cell_shrink(nominal_gap, &evaluated.gap),
        refit: None,
        bootstrap: None,
        evaluated,
    }
}

/// Moves `ranking[b]` to the front, the others keeping their order, and renumbers what
/// `not_distinct` points at; returns the new index of `b`: 0 (`b` itself when it is no index
/// of `ranking`, which is left alone).
fn to_front<T>(ranking: &mut Vec<T>, not_distinct: &mut [NotDistinct], b: usize) -> usize {
    if b == 0 || b >= ranking.len() {
        return b;
    }
    let item = ranking.remove(b);
    ranking.insert(0, item);
    for n in not_distinct.iter_mut() {
        if n.ranked < b {
            n.ranked += 1;
        } else if n.ranked == b {
            n.ranked = 0;
        }
    }
    0
}

fn sort_ranking(d0: f64, ranking: &mut Vec<Ranked>) {
    let outcomes: Vec<Outcome> = ranking
        .iter()
        .map(|r| r.evaluated.outcome.clone())
        .collect();
    let order = verdict::rank(d0, &outcomes);
    let mut sorted: Vec<Ranked> = order.iter().map(|&i| ranking[i].clone()).collect();
    std::mem::swap(ranking, &mut sorted);
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    pub(crate) use crate::diagnose::outcome::tests::{evaluated, fitted};

    #[test]
    fn a_candidate_chosen_over_those_set_aside_moves_to_the_front() {
        let nd = |ranked| NotDistinct {
            ranked,
            values: Vec::new(),
            undetermined: Vec::new(),
            held_out: None,
        };
        let mut ranking = vec!["lens", "tilt", "blur", "noise"];
        let mut set_aside = vec![nd(0), nd(1)];
        assert_eq!(to_front(&mut ranking, &mut set_aside, 2), 0);
        assert_eq!(ranking, ["blur", "lens", "tilt", "noise"]);
        assert_eq!((set_aside[0].ranked, set_aside[1].ranked), (1, 2));
        // The first stays where it is; an index past the end changes nothing.
        assert_eq!(to_front(&mut ranking, &mut set_aside, 0), 0);
        assert_eq!(to_front(&mut ranking, &mut set_aside, 9), 9);
        assert_eq!(ranking, ["blur", "lens", "tilt", "noise"]);
    }

    #[test]
    fn a_pairs_refits_pool_each_effects_values_and_sds_with_its_own_fits() {
        let noise = Effect::PixelNoise;
        let n = noise.params().len();
        assert!(n >= 2);
        let noise_values: Vec<f64> = (0..n).map(|i| 100.0 + i as f64).collect();
        let mut noise_stds = vec![3.0; n];
        noise_stds[1] = f64::INFINITY;
        let mut first = evaluated(vec![
            fitted(Effect::Backlash, vec![0.5], vec![0.01]),
            fitted(noise, noise_values.clone(), noise_stds.clone()),
        ]);
        let run = |clearance: f64, shift: f64| {
            let again: Vec<f64> = noise_values.iter().map(|v| v + shift).collect();
            vec![
                fitted(Effect::Backlash, vec![clearance], vec![0.02]),
                fitted(noise, again, vec![1.0; n]),
            ]
        };
        let runs = vec![
            (vec![3007, 3008], run(0.53, 4.0)),
            (vec![3009, 3010], run(0.47, 2.0)),
        ];
        let refit = pool_refits(&mut first, runs, None);
        let Refit::Done {
            runs,
            first_values,
            stds_before,
            short,
        } = refit
        else {
            panic!("{refit:?}")
        };
        assert_eq!(runs.len(), 2);
        assert_eq!(runs[1].seeds, vec![3009, 3010]);
        assert_eq!(runs[0].values[0], vec![0.53]);
        assert_eq!(runs[1].stds[1], vec![1.0; n]);
        assert_eq!(first_values, vec![vec![0.5], noise_values.clone()]);
        assert_eq!(stds_before, vec![vec![0.01], noise_stds]);
        assert_eq!(short, None);
        // Each effect is pooled with its own fits: the mean of three, and
        // √(mean σ² + sample variance / 3).
        let close = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-12;
        let clearance = &first.effects[0];
        assert!(close(clearance.values[0], 0.5), "{clearance:?}");
        let want = ((0.01f64.powi(2) + 2.0 * 0.02f64.powi(2)) / 3.0 + 0.0009 / 3.0).sqrt();
        assert!(close(clearance.stds[0], want), "{clearance:?}");
        let pixel = &first.effects[1];
        assert!(close(pixel.values[0], 102.0), "{pixel:?}");
        let want = ((9.0 + 2.0) / 3.0 + 4.0 / 3.0f64).sqrt();
        assert!(close(pixel.stds[0], want), "{pixel:?}");
        // A parameter the footage does not determine stays the first fit's, undetermined.
        assert_eq!(pixel.values[1], noise_values[1]);
        assert_eq!(pixel.stds[1], f64::INFINITY);
    }

    #[test]
    fn a_kept_second_look_pair_tells_its_single_apart_and_nothing_else() {
        let gap = GapMap {
            cells: Vec::new(),
            total: 5.0,
            options: GapOptions::default(),
        };
        let of = |effects: &[Effect]| {
            let fits = effects
                .iter()
                .map(|&e| fitted(e, vec![1.0; e.params().len()], vec![0.1; e.params().len()]))
                .collect();
            ranked(&gap, evaluated(fits))
        };
        let ranking = vec![
            of(&[Effect::Compression, Effect::OpticalBlur]),
            of(&[Effect::MotionBlur]),
            of(&[Effect::Compression]),
            of(&[Effect::OpticalBlur, Effect::Compression]),
        ];
        let look = SecondLook {
            first: Effect::Compression,
            remainder: 11.5,
            tried: Vec::new(),
        };
        assert_eq!(look.single_behind(&ranking, 0), Some(2));
        // A single, a pair led by another effect, or no such index: nothing told apart.
        assert_eq!(look.single_behind(&ranking, 1), None);
        assert_eq!(look.single_behind(&ranking, 2), None);
        assert_eq!(look.single_behind(&ranking, 3), None);
        assert_eq!(look.single_behind(&ranking, 9), None);
        // The pair kept with its single not ranked (it cannot happen, but must not panic).
        assert_eq!(look.single_behind(&ranking[..2], 0), None);
    }

    #[test]
    fn each_refit_takes_its_own_block_of_fresh_seeds() {
        let plan = RefitPlan {
            nominal_seed: 7,
            seeds_per_run: 3,
            runs: 2,
        };
        assert_eq!(plan.seeds(0), vec![3007, 3008, 3009]);
        assert_eq!(plan.seeds(1), vec![3010, 3011, 3012]);
    }

    #[test]
    fn a_waves_progress_line_names_its_fits() {
        assert_eq!(fitting(["backlash"].iter()), "fitting backlash");
        let pairs = ["a + b".to_string(), "a + c".to_string()];
        assert_eq!(fitting(pairs.iter()), "fitting a + b and a + c");
    }
}
