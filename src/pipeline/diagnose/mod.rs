//! `geneva diagnose`: where the real measurement and the nominal simulation disagree, which
//! effect of the vocabulary explains it, and how far the gap shrinks once it is added.
//!
//! 1. The real data are measured with the nominal's detector and estimator (the code of
//!    `geneva analyze`), plus image statistics on every frame ([`real`]).
//! 2. Nuisance alignment ([`nominal`]): crank phase and speed, marker angle, orientation,
//!    radius, image scale, rotation-centre and reference-marker positions are fitted, so that
//!    what is left is a gap, not a misplacement.
//! 3. The aligned nominal is simulated at the real frame times on N seeds ([`simulate`]); both
//!    sides give the same cells ([`crate::diagnose::cells`]); the gap map compares them.
//! 4. Candidates are screened by their signatures, fitted by simulated method of moments and
//!    re-simulated on the evaluation seeds ([`fit`]); a greedy pair is tried when one effect is
//!    not enough; the ranking and the verdict are pure ([`crate::diagnose::verdict`]).
//! 5. Outputs ([`report`]): `diagnosis.json`, `diagnosis.md`, gap-map heatmaps, a ranking
//!    chart, before/after residual overlays; the real measurement's `tracks.csv` under `real/`.
//! 6. Beyond one machine ([`shards`]): the single-candidate fits of step 4 as shards, merged
//!    through the same candidate loop ([`diagnose_with`]).
//!
//! No truth of the real data is used anywhere (there is none).

pub mod camera_warp;
pub mod fit;
pub mod image;
pub mod nominal;
pub mod pose_tilt;
pub mod real;
pub mod report;
pub mod selfcheck;
pub mod shards;
pub mod simulate;

use crate::diagnose::cells::{image_cells, timing_cells, track_cells, Cells};
use crate::diagnose::gap::{seed_limited, CellGap, GapMap, GapOptions};
use crate::diagnose::plan;
use crate::diagnose::verdict::{self, Outcome, Verdict};
use crate::io::output_dir::OutputDir;
use crate::pipeline::analyze::Source;
use crate::scenario::effects::Effect;
use crate::scenario::Scenario;
use fit::{Evaluated, Fitter, RealSide};
use nominal::Aligned;
use shards::{CandidateStudy, Mode};
use simulate::SimContext;
use std::cell::RefCell;
use std::path::{Path, PathBuf};
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
        "the marker is found in only {detected} of {frames} frames; a diagnosis needs at least \
         {needed}"
    )]
    TooFewDetections {
        detected: usize,
        frames: usize,
        needed: usize,
    },
    #[error("measuring the real data")]
    Measure(#[source] Box<crate::pipeline::analyze::AnalyzeError>),
    #[error("the real frame times")]
    FrameTimes(#[source] crate::timing::TimingError),
    #[error("fitting the frame timing of the footage")]
    TimingFit(#[source] crate::timing::TimingError),
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
    #[error("the nominal scenario's camera")]
    NominalCamera(#[source] crate::camera::CameraError),
    #[error("the nominal scenario's scene")]
    NominalScene(#[source] crate::scene::SceneError),
    #[error("the nominal scenario's mechanism")]
    NominalMechanism(#[source] crate::mechanism::MechanismError),
    #[error("aligning the nominal's motion to the measured angle")]
    AlignMotion(#[source] crate::diagnose::align::AlignError),
    #[error(
        "the marker centre does not move along a measurable arc; a diagnosis needs footage where \
         the wheel turns"
    )]
    NoArc(#[source] crate::estimate::EstimateError),
    #[error(
        "the aligned nominal is not a valid scenario: {}",
        crate::validation::bullet_list(problems)
    )]
    AlignedInvalid {
        problems: Vec<crate::validation::Problem>,
    },
    #[error("the estimator on the camera's view of the exact motion")]
    ExactView(#[source] crate::estimate::EstimateError),
    #[error("simulating the nominal: its rig")]
    SimulateRig(#[source] Box<crate::pipeline::rig::RigError>),
    #[error("simulating the nominal: rendering and detecting its frames")]
    SimulateFrames(#[source] Box<crate::pipeline::frames::FramesError>),
    #[error("estimating the simulated measurement")]
    SimulateEstimate(#[source] crate::estimate::EstimateError),
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
    /// Fit the best candidate again on fresh seeds and widen its ± by the difference
    /// ([`crate::diagnose::fit_noise`]); off, its ± do not hold the fit seeds' noise.
    pub refit_best: bool,
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
            refit_best: true,
        }
    }
}

/// Default of [`DiagnoseOptions::escalate_seeds`]. On the independent renderer's footage of a
/// strong axis runout, 4 seeds left the angle's low band at z = 4.3–4.8 short of significance on
/// 2 of 3 seeds (`reports/diagnosis-seeds-independent/`); 12 seeds found all three, and the 4
/// null cases stayed without a gap (`reports/diagnosis-runout-12seeds-independent/`).
pub const ESCALATE_SEEDS: usize = 12;

/// The evaluation seeds were raised because the first comparison was short of seeds.
#[derive(Debug, Clone)]
pub struct SeedEscalation {
    pub from_seeds: usize,
    pub to_seeds: usize,
    /// The cells that were significant only in the limit of unlimited seeds, on `from_seeds`.
    pub cells: Vec<CellGap>,
}

/// One ranked candidate.
#[derive(Debug, Clone)]
pub struct Ranked {
    pub evaluated: Evaluated,
    /// 1 − D_k / D₀.
    pub shrink: f64,
    /// Penalised shrink (the ranking score).
    pub score: f64,
    /// Other candidates the data cannot tell apart from this one (filled for the best).
    pub group: Vec<String>,
    /// Per-cell shrink for the cells with a gap.
    pub cell_shrink: Vec<(crate::diagnose::cells::CellKey, f64)>,
    /// The second fit on fresh seeds that measured the fit's own noise (the best candidate
    /// only, single or pair; its stated ± include it).
    pub refit: Option<Refit>,
}

/// A candidate fitted again on fit seeds disjoint from the first fit's
/// ([`crate::diagnose::fit_noise`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Refit {
    /// The values the second fit found, on `seeds`, and the first fit's ± before they were
    /// widened: one list per effect of the candidate, in [`Effect::params`] order.
    Done {
        seeds: Vec<u64>,
        values: Vec<Vec<f64>>,
        stds_before: Vec<Vec<f64>>,
    },
    /// Not run: the time cap (`--max-minutes`) was reached first.
    TimeCap,
    /// Not run: switched off (`--no-refit`).
    Off,
    /// The second fit failed; the first fit's ± stand without it.
    Failed(String),
}

/// Everything a diagnosis found.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    pub verdict: Verdict,
    pub aligned: Aligned,
    pub nominal_gap: GapMap,
    pub real_cells: Cells,
    /// Best first; singles, and the best pair when one was tried.
    pub ranking: Vec<Ranked>,
    /// Index into `ranking` of the candidate the verdict rests on.
    pub best: Option<usize>,
    /// Candidates screened out (no significant cell in their signature), with their share of
    /// the gap.
    pub screened_out: Vec<(Effect, f64)>,
    /// Candidates not fitted because their share of the gap (an upper bound on their shrink) is
    /// below the best fitted score by more than the group margin, with that share.
    pub bounded_out: Vec<(Effect, f64)>,
    /// Candidates not tried because of `--max-minutes`.
    pub not_tried: Vec<Effect>,
    /// Candidates that cannot be judged from the input (image effects from a corner track).
    pub not_judged: Vec<Effect>,
    pub pair_tried: bool,
    /// Set when the evaluation seeds were raised before judging.
    pub escalation: Option<SeedEscalation>,
    pub seeds: Vec<u64>,
    pub fit_seeds: Vec<u64>,
    pub simulations: usize,
    pub frames: usize,
    pub detected: usize,
    pub has_images: bool,
    pub nyquist_hz: f64,
    /// Time shift between the real frames' timestamps and the aligned motion, s.
    pub real_time_shift_s: f64,
    pub elapsed_s: f64,
}

impl Diagnosis {
    /// Cells of the nominal gap still short of significance only for lack of seeds (on the
    /// final seeds): with no gap found, the report names them and how many seeds might settle
    /// them.
    pub fn seed_limited(&self) -> Vec<CellGap> {
        seed_limited(&self.nominal_gap)
    }
}

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
    if mode != Mode::Whole && options.max_minutes.is_some() {
        return Err(DiagnoseError::MaxMinutesWithShards);
    }
    if options.seeds < 2 {
        return Err(DiagnoseError::TooFewSeeds {
            seeds: options.seeds,
        });
    }
    let layout = image::marker_layout(nominal).map_err(DiagnoseError::NominalLayout)?;
    real::check_source(nominal, source)?;
    // A shard keeps no report: its real measurement goes to a scratch folder, never committed.
    let staging_dir = match mode {
        Mode::Shard { shard, .. } => out_dir
            .join(crate::shard::SHARDS)
            .join(format!(".{}.prefix", shard.index)),
        _ => out_dir.to_path_buf(),
    };
    let staging = match mode {
        Mode::Merge => OutputDir::create_carrying(&staging_dir, &[crate::shard::SHARDS]),
        _ => OutputDir::create(&staging_dir),
    }?;

    progress("measuring the real footage", 0, 1);
    let real = real::measure_real(
        nominal,
        source,
        &layout,
        &staging.path().join("real"),
        &|d, t| progress("measuring the real footage", d, t),
    )?;
    progress("aligning the nominal", 0, 1);
    let aligned = nominal::align(nominal, &real.record, &real.estimate, &layout)?;
    let t_all = real.record.t_s();
    let median_dt = {
        let mut d: Vec<f64> = t_all.windows(2).map(|w| w[1] - w[0]).collect();
        d.sort_by(f64::total_cmp);
        d.get(d.len() / 2).copied().unwrap_or(1.0 / 30.0)
    };
    let nyquist_hz = 0.5 / median_dt;
    let ctx = SimContext {
        aligned: &aligned,
        layout: &layout,
        with_images: real.record.has_images,
        nyquist_hz,
        height_px: nominal.camera.height_px as f64,
    };
    let (reference, real_time_shift_s) =
        nominal::motion_reference(&aligned.reference, &real.record, &real.estimate);
    let mut real_cells = track_cells(
        &real.record,
        &real.estimate,
        &reference,
        nyquist_hz,
        ctx.height_px,
    );
    real_cells.extend(image_cells(
        &real.record,
        aligned.geometry.rotation_centre_px,
        &reference.phase,
        nyquist_hz,
        ctx.height_px,
    ));
    real_cells.extend(timing_cells(&t_all));
    let real_theta_residual = crate::diagnose::cells::residual(
        &real.estimate.primary_series().theta_rad,
        &reference.theta_rad,
    );
    let theta_peak_hz =
        crate::diagnose::cells::residual_peak(&t_all, &real_theta_residual, nyquist_hz)
            .map(|p| p.frequency_hz);

    // What the runout and tilt candidates start from, read off the real track: only when they
    // are candidates (each costs a fit over every detected frame).
    let is_candidate = |e: Effect| options.effects.as_ref().is_none_or(|c| c.contains(&e));
    let runout_form = if is_candidate(Effect::AxisRunout) {
        crate::diagnose::runout::fit_runout_form(
            &nominal::runout_samples(&aligned, &real.record, real_time_shift_s)?,
            &crate::diagnose::runout::CYCLES_TRIED,
        )
    } else {
        None
    };
    let pose_tilt = is_candidate(Effect::PerspectiveTilt)
        .then(|| pose_tilt::pose_tilt(&aligned.scenario, &real.record))
        .flatten();
    let primary = &real.estimate.primary_series().theta_rad;
    let (t_det, th_det): (Vec<f64>, Vec<f64>) = t_all
        .iter()
        .zip(primary)
        .filter(|(_, th)| th.is_finite())
        .map(|(t, th)| (*t, *th))
        .unzip();
    let eval_seed = |k: usize| nominal.seed.wrapping_add(1000 + k as u64);
    let mut seeds: Vec<u64> = (0..options.seeds).map(eval_seed).collect();
    let fit_seeds: Vec<u64> = (0..options.fit_seeds.max(2) as u64)
        .map(|k| nominal.seed.wrapping_add(2000 + k))
        .collect();
    let base = Fitter::base_trial(&aligned, nominal, &t_all);
    progress("simulating the nominal", 0, seeds.len());
    let mut fitter = Fitter::new(
        ctx,
        nominal,
        RealSide {
            cells: &real_cells,
            t_s: &t_all,
            theta_det: (&t_det, &th_det),
            theta_residual: &real_theta_residual,
            theta_peak_hz,
            runout_form,
            pose_tilt,
        },
        base,
        fit_seeds.clone(),
        seeds.clone(),
        options.gap,
    )?;
    // A verdict of no gap that more seeds could overturn is not taken on too few: the nominal
    // is simulated on more (the first ones are kept, so only the new ones cost) and every
    // candidate is then judged on all of them.
    let limited = seed_limited(&fitter.nominal_gap);
    let escalation = if !limited.is_empty() && options.escalate_seeds > options.seeds {
        progress(
            &format!(
                "simulating the nominal on {} more seeds ({} cell(s) short of significance \
                 only for lack of seeds)",
                options.escalate_seeds - options.seeds,
                limited.len()
            ),
            0,
            1,
        );
        let more: Vec<u64> = (options.seeds..options.escalate_seeds)
            .map(eval_seed)
            .collect();
        fitter.add_eval_seeds(&more)?;
        seeds.extend(more);
        Some(SeedEscalation {
            from_seeds: options.seeds,
            to_seeds: options.escalate_seeds,
            cells: limited,
        })
    } else {
        None
    };
    let nominal_gap = fitter.nominal_gap.clone();
    let nominal_gap = &nominal_gap;
    let d0 = nominal_gap.total;

    let candidates: Vec<Effect> = options
        .effects
        .clone()
        .unwrap_or_else(|| Effect::ALL.to_vec());
    let (candidates, not_judged): (Vec<Effect>, Vec<Effect>) = candidates
        .into_iter()
        .partition(|e| real.record.has_images || !e.needs_frames());
    // Screening: only effects with a significant cell in their signature are fitted, largest
    // possible share of the gap first. The fitted ones are the work units of a shard.
    let mut screened: Vec<(Effect, f64)> = candidates
        .iter()
        .map(|&e| (e, plan::screening_share(e, nominal_gap)))
        .collect();
    screened.sort_by(|a, b| b.1.total_cmp(&a.1));
    let units: Vec<Effect> = screened
        .iter()
        .map(|(e, _)| *e)
        .filter(|&e| nominal_gap.n_significant() > 0 && plan::signature_significant(e, nominal_gap))
        .collect();
    // The runout form's phase is refined once, before any fit, so that every fit, pair and
    // shard takes the same form.
    if units.contains(&Effect::AxisRunout) {
        progress("refining the runout form's phase", 0, 1);
        fitter.refine_runout_phase();
    }
    let fitter = fitter;
    let stored = match mode {
        Mode::Whole => None,
        Mode::Shard { shard, restart } => {
            let manifest = shards::manifest(nominal, source, options, &fitter, &units);
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
            return Ok(Finished::Shard(report));
        }
        Mode::Merge => {
            let manifest = shards::manifest(nominal, source, options, &fitter, &units);
            Some(shards::stored(out_dir, &manifest, &units)?)
        }
    };
    // One candidate: fitted here, or looked up in the shards' records.
    let fit_candidate = |e: Effect| -> Result<(Evaluated, usize), DiagnoseError> {
        match &stored {
            None => fitter.fit_single(e),
            Some(stored) => stored
                .iter()
                .find(|(x, _)| *x == e)
                .map(|(_, r)| r.clone())
                .ok_or(DiagnoseError::MissingCandidate { effect: e.name() }),
        }
    };
    let mut candidate_simulations = 0usize;
    let mut screened_out = Vec::new();
    let mut bounded_out = Vec::new();
    let mut not_tried = Vec::new();
    let mut ranking: Vec<Ranked> = Vec::new();
    let mut pair_tried = false;
    if nominal_gap.n_significant() > 0 {
        let deadline = options.max_minutes.map(|m| m * 60.0);
        let total = screened.len();
        let mut best_score = f64::NEG_INFINITY;
        for (i, (e, share)) in screened.into_iter().enumerate() {
            if !plan::signature_significant(e, nominal_gap) {
                screened_out.push((e, share));
                continue;
            }
            // A candidate moves only its signature cells, so its shrink is at most its share;
            // below the best score by more than the group margin it can neither win nor join
            // the best's group.
            if share < best_score - verdict::GROUP_MARGIN {
                bounded_out.push((e, share));
                continue;
            }
            if deadline.is_some_and(|d| started.elapsed().as_secs_f64() > d) {
                not_tried.push(e);
                continue;
            }
            progress(&format!("fitting {}", e.name()), i, total);
            let (evaluated, simulations) = fit_candidate(e)?;
            candidate_simulations += simulations;
            let r = ranked(nominal_gap, evaluated);
            progress(
                &format!("{}: shrink {:.2}, score {:.2}", e.name(), r.shrink, r.score),
                i + 1,
                total,
            );
            best_score = best_score.max(r.score);
            ranking.push(r);
        }
        sort_ranking(d0, &mut ranking);
        // A second effect when the best single one does not explain the gap.
        let best_explains = ranking
            .first()
            .is_some_and(|r| verdict::explains(d0, &r.evaluated.outcome));
        if options.pairs && !best_explains && ranking.len() >= 2 {
            let deadline_hit = deadline.is_some_and(|d| started.elapsed().as_secs_f64() > d);
            if !deadline_hit {
                pair_tried = true;
                let first = ranking[0].evaluated.effects[0].clone();
                let prior = vec![(first.effect, first.values.clone())];
                let others: Vec<Effect> = ranking[1..]
                    .iter()
                    .map(|r| r.evaluated.effects[0].effect)
                    .filter(|e| !first.effect.shares_switch_with().contains(e))
                    .take(3)
                    .collect();
                for (k, e) in others.into_iter().enumerate() {
                    progress(
                        &format!("fitting {} + {}", first.effect.name(), e.name()),
                        k,
                        3,
                    );
                    let second = fitter.fit(e, &prior)?;
                    let evaluated = fitter.evaluate(vec![first.clone(), second])?;
                    ranking.push(ranked(nominal_gap, evaluated));
                }
                sort_ranking(d0, &mut ranking);
            }
        }
    }
    let outcomes: Vec<Outcome> = ranking
        .iter()
        .map(|r| r.evaluated.outcome.clone())
        .collect();
    let order = verdict::rank(d0, &outcomes);
    let group = verdict::group_of_best(d0, &outcomes, &order);
    let best = order.first().copied();
    if let Some(b) = best {
        let names: Vec<String> = group
            .iter()
            .filter(|&&i| i != b)
            .map(|&i| candidate_name(&ranking[i].evaluated))
            .collect();
        ranking[b].group = names;
        // The fit's own noise, measured on the candidate a user reads first: its parameters
        // fitted again on fresh fit seeds. The verdict and the ranking do not change (the
        // values stay the first fit's); only the ± the report states do.
        let capped = options
            .max_minutes
            .is_some_and(|m| started.elapsed().as_secs_f64() > m * 60.0);
        let (refit, simulations) = if !options.refit_best {
            (Refit::Off, 0)
        } else if capped {
            (Refit::TimeCap, 0)
        } else {
            progress(
                &format!(
                    "refitting {} on fresh seeds (the fit's own noise)",
                    candidate_name(&ranking[b].evaluated)
                ),
                0,
                1,
            );
            refit_on_fresh_seeds(&fitter, &mut ranking[b], nominal.seed, fit_seeds.len())
        };
        candidate_simulations += simulations;
        ranking[b].refit = Some(refit);
    }
    let verdict = verdict::verdict(
        nominal_gap.n_significant(),
        d0,
        best.map(|b| &ranking[b].evaluated.outcome),
    );
    // The prefix and the pairs ran on `fitter`, each single candidate on a fork of it.
    let simulations = *fitter.simulations.borrow() + candidate_simulations;
    let diagnosis = Diagnosis {
        verdict,
        aligned: aligned.clone(),
        nominal_gap: nominal_gap.clone(),
        real_cells: real_cells.clone(),
        ranking,
        best,
        screened_out,
        bounded_out,
        not_tried,
        not_judged,
        pair_tried,
        escalation,
        seeds,
        fit_seeds,
        simulations,
        frames: real.record.frames.len(),
        detected: real.record.detected(),
        has_images: real.record.has_images,
        nyquist_hz,
        real_time_shift_s,
        elapsed_s: started.elapsed().as_secs_f64(),
    };
    progress("writing the report", 0, 1);
    let files = report::write(&diagnosis, &fitter, &real, &staging)?;
    let files: Vec<PathBuf> = files.iter().map(|f| staging.final_path(f)).collect();
    staging.commit()?;
    Ok(Finished::Diagnosis(Box::new(diagnosis), files))
}

/// Seeds of the refit on fresh seeds: the nominal's seed plus this (the evaluation seeds take
/// +1000…, the fit seeds +2000…).
const REFIT_SEED_OFFSET: u64 = 3000;

/// Fits `best` again on `n` fresh fit seeds and widens each of its stated ± by the two fits'
/// difference ([`crate::diagnose::fit_noise::widened_stds`]); its values stay the first fit's.
/// Returns what the refit found and the simulations it ran. A failure is reported, not raised:
/// the first fit stands.
fn refit_on_fresh_seeds(
    fitter: &Fitter,
    best: &mut Ranked,
    nominal_seed: u64,
    n: usize,
) -> (Refit, usize) {
    let fresh: Vec<u64> = (0..n as u64)
        .map(|k| nominal_seed.wrapping_add(REFIT_SEED_OFFSET + k))
        .collect();
    let effects: Vec<Effect> = best.evaluated.effects.iter().map(|f| f.effect).collect();
    match fitter.refit_on_seeds(&effects, &fresh) {
        Ok(second) => {
            let simulations = second.iter().map(|f| f.simulations).sum();
            (
                widen_by_refit(&mut best.evaluated, fresh, second),
                simulations,
            )
        }
        Err(err) => (Refit::Failed(err.to_string()), 0),
    }
}

/// Widens each effect's stated ± of `first` by its difference from `second`, the same
/// candidate fitted on `seeds`, and returns what the refit found.
fn widen_by_refit(first: &mut Evaluated, seeds: Vec<u64>, second: Vec<fit::Fitted>) -> Refit {
    let mut values = Vec::with_capacity(second.len());
    let mut stds_before = Vec::with_capacity(second.len());
    for (first, second) in first.effects.iter_mut().zip(second) {
        debug_assert_eq!(first.effect, second.effect);
        stds_before.push(first.stds.clone());
        first.stds =
            crate::diagnose::fit_noise::widened_stds(&first.stds, &first.values, &second.values);
        values.push(second.values);
    }
    Refit::Done {
        seeds,
        values,
        stds_before,
    }
}

/// Name of a candidate: `a` or `a+b`.
pub fn candidate_name(e: &Evaluated) -> String {
    e.effects
        .iter()
        .map(|f| f.effect.name())
        .collect::<Vec<_>>()
        .join("+")
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
        evaluated,
    }
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

    /// `effect` fitted at `values` ± `stds`, as a candidate's fit reports it.
    pub(crate) fn fitted(effect: Effect, values: Vec<f64>, stds: Vec<f64>) -> fit::Fitted {
        assert_eq!(values.len(), effect.params().len());
        fit::Fitted {
            effect,
            values,
            stds,
            method: "by hand".into(),
            simulations: 0,
            runout_form: None,
        }
    }

    /// A candidate of these fits, with no gap left.
    pub(crate) fn evaluated(effects: Vec<fit::Fitted>) -> Evaluated {
        let params = effects.iter().map(|f| f.values.len()).sum();
        Evaluated {
            effects,
            gap: GapMap {
                cells: Vec::new(),
                total: 0.0,
                options: GapOptions::default(),
            },
            outcome: Outcome {
                remaining: 0.0,
                params,
                significant_left: 0,
            },
        }
    }

    #[test]
    fn a_pairs_refit_widens_each_effects_stated_sd_by_its_own_difference() {
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
        let noise_again: Vec<f64> = noise_values.iter().map(|v| v + 4.0).collect();
        let second = vec![
            fitted(Effect::Backlash, vec![0.53], vec![0.02]),
            fitted(noise, noise_again.clone(), vec![1.0; n]),
        ];
        let refit = widen_by_refit(&mut first, vec![3007, 3008], second);
        let Refit::Done {
            seeds,
            values,
            stds_before,
        } = refit
        else {
            panic!("{refit:?}")
        };
        assert_eq!(seeds, vec![3007, 3008]);
        assert_eq!(values, vec![vec![0.53], noise_again]);
        assert_eq!(stds_before, vec![vec![0.01], noise_stds]);
        // The values stay the first fit's; each ± is widened by its own effect's difference.
        assert_eq!(first.effects[0].values, vec![0.5]);
        assert_eq!(first.effects[1].values, noise_values);
        let backlash = 0.01_f64.hypot(0.03 / std::f64::consts::SQRT_2);
        assert!((first.effects[0].stds[0] / backlash - 1.0).abs() < 1e-12);
        let noise_sd = 3.0_f64.hypot(4.0 / std::f64::consts::SQRT_2);
        assert!((first.effects[1].stds[0] / noise_sd - 1.0).abs() < 1e-12);
        // A parameter the footage does not determine stays undetermined.
        assert_eq!(first.effects[1].stds[1], f64::INFINITY);
    }
}
