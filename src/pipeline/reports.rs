//! `geneva reports`: the committed reports under `reports/` — a quick Monte Carlo of `fast`
//! (the reproducibility check), the seed study redone for the internal and external rigs with
//! the phone's real frame timing, a per-source decomposition at 4K, 1080p and 720p, the seed-camera
//! sweep (the seed's design question), the dynamics report and the `geneva calibrate` round
//! trip (`calibration/`). Every number in the
//! markdown is formatted from computed results.

use super::decompose::{
    decompose_effects, markdown_table, write_outputs, DecomposeOptions, DecompositionError,
};
use super::defaults_study::{defaults_report, DefaultsError, Spread};
use super::dynamics_report::{dynamics_report, DynamicsReportError};
use super::montecarlo::{monte_carlo, MonteCarloBudget, MonteCarloError, MonteCarloOptions};
use super::rig::{Rig, RigError};
use crate::budget::decompose::{Decomposition, SeedRule, StopReason};
use crate::budget::detectability::{detectability, Detectability};
use crate::budget::report::{Budget, QuantityStats};
use crate::budget::MeanCi;
use crate::estimate::EstimatorConfig;
use crate::mechanism::Phase;
use crate::plot::bars_png;
use crate::scenario::{load_any, with_overrides, Scenario, ScenarioError};
use std::path::{Path, PathBuf};
use toml::Value;

/// The seed report's own figures (seed §5.3): the doubled half-pixel ω and α changes, which the
/// seed found to be of the same size as the scatter in its measurements.
pub const SEED_OMEGA_DOUBLED_RAD_S: f64 = 0.057;
pub const SEED_ALPHA_DOUBLED_RAD_S2: f64 = 1.73;

#[derive(Debug, thiserror::Error)]
pub enum ReportsError {
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error("{name}")]
    MonteCarlo {
        name: String,
        source: Box<MonteCarloError>,
    },
    #[error(transparent)]
    Decomposition(#[from] DecompositionError),
    #[error(transparent)]
    Rig(#[from] RigError),
    #[error(transparent)]
    Dynamics(#[from] DynamicsReportError),
    #[error(transparent)]
    Defaults(#[from] DefaultsError),
    #[error("no report named `{name}` (reports: {known})")]
    UnknownReport { name: String, known: String },
    #[error(transparent)]
    File(#[from] crate::errors::FileError),
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    #[error(transparent)]
    Output(#[from] crate::io::output_dir::OutputError),
    #[error("calibration round trip")]
    Calibration(#[source] Box<super::calibrate::CalibrateJobError>),
    #[error("error bars against the truth")]
    ErrorBars(#[source] Box<super::error_bars_check::CheckError>),
    #[error(transparent)]
    Sweep(#[from] crate::sweep::SweepError),
}

/// Round-trip cases of `reports/calibration/` (a few seconds each in release).
pub const CALIBRATION_CASES: usize = 40;

/// What to generate.
#[derive(Debug, Clone)]
pub struct ReportsOptions {
    /// Monte Carlo seeds of the main configurations.
    pub seeds: usize,
    /// Only `reports/fast/` (seconds instead of minutes).
    pub fast_only: bool,
    /// Only these report folders ([`REPORT_NAMES`]); empty: all of them.
    pub only: Vec<String>,
    /// The seed-camera sweep file (its `base` is read beside it).
    pub seed_camera_sweep: PathBuf,
}

/// The report folders `reports` writes, in the order it writes them.
pub const REPORT_NAMES: [&str; 9] = [
    "fast",
    "seed-internal-4k",
    "seed-external-4k",
    "decomposition",
    "seed-camera",
    "dynamics",
    "calibration",
    "defaults",
    "error-bars",
];

impl Default for ReportsOptions {
    fn default() -> Self {
        Self {
            seeds: 3,
            fast_only: false,
            only: Vec::new(),
            seed_camera_sweep: PathBuf::from("scenarios/sweeps/seed-camera.toml"),
        }
    }
}

fn write_text(path: &Path, text: &str) -> Result<PathBuf, ReportsError> {
    std::fs::write(path, text).map_err(crate::errors::FileError::io(path))?;
    Ok(path.to_path_buf())
}

fn mc(
    name: &str,
    scenario: &Scenario,
    out_dir: &Path,
    seeds: usize,
    plots: bool,
) -> Result<MonteCarloBudget, ReportsError> {
    let options = MonteCarloOptions {
        seeds,
        first_seed_files: plots,
        ..MonteCarloOptions::default()
    };
    monte_carlo(scenario, out_dir, &options).map_err(|source| ReportsError::MonteCarlo {
        name: name.into(),
        source: Box::new(source),
    })
}

/// `mean [low, high]` in scientific notation (CI omitted when it is not finite: one seed).
pub fn fmt_ci(m: MeanCi) -> String {
    if m.ci95_low.is_finite() && m.ci95_high.is_finite() {
        format!("{:.3e} [{:.2e}, {:.2e}]", m.mean, m.ci95_low, m.ci95_high)
    } else {
        format!("{:.3e}", m.mean)
    }
}

fn pct(x: f64) -> String {
    format!("{:.1} %", 100.0 * x)
}

/// A signal's statistics (overall, or one phase) of a per-seed budget.
fn stats<'a>(b: &'a Budget, signal: &str, phase: Option<&str>) -> Option<&'a QuantityStats> {
    let s = b.signals.get(signal)?;
    match phase {
        None => Some(&s.overall),
        Some(p) => s.phases.get(p),
    }
}

fn metric(
    m: &MonteCarloBudget,
    signal: &str,
    phase: Option<&str>,
    f: fn(&QuantityStats) -> f64,
) -> MeanCi {
    m.metric(|b| stats(b, signal, phase).map_or(f64::NAN, f))
}

fn bound(
    m: &MonteCarloBudget,
    signal: &str,
    f: fn(&crate::budget::report::BoundsReport) -> f64,
) -> MeanCi {
    m.metric(|b| b.bounds.get(signal).map_or(f64::NAN, f))
}

fn image_links(files: &[PathBuf], report_dir: &Path) -> String {
    files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "png"))
        .filter_map(|f| f.strip_prefix(report_dir).ok())
        .map(|rel| format!("![{0}]({0})\n", rel.display()))
        .collect()
}

/// The fast scenario's Monte Carlo report (what tests/reports_fast.rs regenerates).
pub fn fast_report(out_dir: &Path, seeds: usize) -> Result<MonteCarloBudget, ReportsError> {
    let scenario = load_any("fast")?;
    let m = mc("fast", &scenario, out_dir, seeds, true)?;
    let mut md = format!(
        "# fast: Monte Carlo over {} seeds\n\nScenario `fast` (1280×720, 0.5 mm/px, constant \
         30 fps, exact kinematics), seeds {:?}. Fused signal, mean over seeds with 95 % CI. \
         {TABLE_NOTE}\n\n",
        m.seeds.len(),
        m.seeds
    );
    md.push_str(&stats_table(&[("fast", &m)], "fused"));
    md.push('\n');
    md.push_str(&image_links(&m.files, out_dir));
    let mut out = m;
    out.files.push(write_text(&out_dir.join("README.md"), &md)?);
    Ok(out)
}

/// A signal's statistics against the raw truth (overall) of a per-seed budget.
fn raw_stats<'a>(b: &'a Budget, signal: &str) -> Option<&'a QuantityStats> {
    b.signals.get(signal).map(|s| &s.raw.overall)
}

fn raw_metric(m: &MonteCarloBudget, signal: &str, f: fn(&QuantityStats) -> f64) -> MeanCi {
    m.metric(|b| raw_stats(b, signal).map_or(f64::NAN, f))
}

/// Table of RMS errors for named Monte Carlo results: against the resolvable truth (overall and
/// per phase) first, then against the raw truth, and the aliasing part of the motion.
fn stats_table(rows: &[(&str, &MonteCarloBudget)], signal: &str) -> String {
    let mut s = String::from(
        "| configuration | θ2 RMS (rad) | ω2 RMS (rad/s) | α2 RMS (rad/s²) | ω2 RMS dwell | ω2 RMS drive | α2 RMS dwell | α2 RMS drive | ω2 RMS, raw truth | α2 RMS, raw truth | α2 aliasing part RMS |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (name, m) in rows {
        s.push_str(&format!(
            "| {name} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.3e} |\n",
            fmt_ci(metric(m, signal, None, |q| q.theta.rms)),
            fmt_ci(metric(m, signal, None, |q| q.omega.rms)),
            fmt_ci(metric(m, signal, None, |q| q.alpha.rms)),
            fmt_ci(metric(m, signal, Some("dwell"), |q| q.omega.rms)),
            fmt_ci(metric(m, signal, Some("drive"), |q| q.omega.rms)),
            fmt_ci(metric(m, signal, Some("dwell"), |q| q.alpha.rms)),
            fmt_ci(metric(m, signal, Some("drive"), |q| q.alpha.rms)),
            fmt_ci(raw_metric(m, signal, |q| q.omega.rms)),
            fmt_ci(raw_metric(m, signal, |q| q.alpha.rms)),
            m.metric(|b| b.aliasing.overall.alpha.rms).mean,
        ));
    }
    s
}

/// What the tables measure against, for every report that shows them.
pub const TABLE_NOTE: &str =
    "Errors are against the resolvable truth — the actual motion averaged \
     over each frame's exposure of the marker and band-limited to the footage's Nyquist rate \
     (definition in ARCHITECTURE.md) — unless marked \"raw truth\" (the actual motion at the \
     frame timestamps). The aliasing part is the actual motion above the Nyquist rate, which no \
     camera at that frame rate can follow; it is the same for every signal.";

/// Which of the seed's rigs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SeedRig {
    Internal,
    External,
}

impl SeedRig {
    pub fn scenario_name(self) -> &'static str {
        match self {
            SeedRig::Internal => "seed-internal-4k",
            SeedRig::External => "seed-external-4k",
        }
    }
    /// The phone log replayed (spans ≥ 10 s: model_test2 14.35 s, model_test5 11.04 s).
    pub fn timing_log(self) -> &'static str {
        match self {
            SeedRig::Internal => "builtin:model_test2",
            SeedRig::External => "builtin:model_test5",
        }
    }
}

fn ov(path: &str, v: Value) -> (String, Value) {
    (path.to_string(), v)
}

fn kind_table(kind: &str, extra: &[(&str, Value)]) -> Value {
    let mut t = toml::map::Map::new();
    t.insert("kind".into(), Value::String(kind.into()));
    for (k, v) in extra {
        t.insert(k.to_string(), v.clone());
    }
    Value::Table(t)
}

/// The seed rig with the phone's real frame timing, 10 s.
pub fn seed_base(rig: SeedRig) -> Result<Scenario, ScenarioError> {
    let base = load_any(rig.scenario_name())?;
    with_overrides(
        &base,
        &[
            ov(
                "frame_timing.model",
                kind_table("log", &[("file", Value::String(rig.timing_log().into()))]),
            ),
            ov("duration_s", Value::Float(10.0)),
        ],
        Path::new(rig.scenario_name()),
    )
}

/// Better settings than the seed's: cornerSubPix corner refinement and the toolkit's default
/// estimator (the best of `reports/defaults/`).
pub fn better_overrides() -> Vec<(String, Value)> {
    let e = EstimatorConfig::default();
    vec![
        ov(
            "estimator.rotation_centre",
            Value::String(e.rotation_centre.name().into()),
        ),
        ov(
            "estimator.marker_centre",
            Value::String(e.marker_centre.name().into()),
        ),
        ov(
            "detector.corner_refinement_method",
            Value::String("subpix".into()),
        ),
        // A differentiator always serialises to a table (its `kind` tag); the fallback is the
        // 3-point stencil only so that this stays free of a panic.
        ov(
            "estimator.differentiator",
            Value::try_from(&e.differentiator).unwrap_or_else(|_| kind_table("central3", &[])),
        ),
    ]
}

/// The largest impact of the actual motion in an entry phase: the biggest change of ω2 within
/// `window_s`, sampled every `step_s` (the rattle is at ~100 Hz, far above the frame rate).
pub fn largest_entry_impact(rig: &Rig, window_s: f64, step_s: f64) -> f64 {
    let n = (rig.scenario.duration_s / step_s) as usize;
    let lag = ((window_s / step_s).round() as usize).max(1);
    let samples: Vec<(f64, Phase)> = (0..=n)
        .map(|i| {
            let s = rig.mechanism.actual(i as f64 * step_s);
            (s.omega2_rad_s, s.phase)
        })
        .collect();
    samples
        .windows(lag + 1)
        .filter(|w| w[0].1 == Phase::Entry)
        .map(|w| (w[lag].0 - w[0].0).abs())
        .fold(0.0, f64::max)
}

/// What a seed reproduction report computed.
pub struct SeedReport {
    pub seed_settings: MonteCarloBudget,
    pub better: MonteCarloBudget,
    /// Dynamics off (ideal kinematics): the pure detection error (internal rig only; the
    /// external rig has no dynamics, so there it equals the main runs).
    pub seed_detection_only: Option<MonteCarloBudget>,
    pub better_detection_only: Option<MonteCarloBudget>,
    /// Seed estimator with the geometric rotation centre (isolates the centre method).
    pub seed_geometric_centre: MonteCarloBudget,
    /// Seed settings, dynamics off, analysed with an assumed constant 30 fps.
    pub seed_constant_30fps: MonteCarloBudget,
    pub impact_delta_omega_rad_s: f64,
    pub impact_seed: Option<Detectability>,
    pub impact_better: Option<Detectability>,
    pub files: Vec<PathBuf>,
}

/// The seed study redone for one rig; writes `<out_dir>/README.md` and the runs' folders.
pub fn seed_report(
    rig_kind: SeedRig,
    out_dir: &Path,
    seeds: usize,
) -> Result<SeedReport, ReportsError> {
    let name = rig_kind.scenario_name();
    let origin = Path::new(name);
    let base = seed_base(rig_kind)?;
    let better_sc = with_overrides(&base, &better_overrides(), origin)?;
    let dyn_off = [ov("dynamics.enabled", Value::Boolean(false))];
    let seed_settings = mc(
        "seed settings",
        &base,
        &out_dir.join("seed-settings"),
        seeds,
        true,
    )?;
    let better = mc(
        "better settings",
        &better_sc,
        &out_dir.join("better-settings"),
        seeds,
        true,
    )?;
    let (seed_det, better_det) = if base.dynamics.enabled {
        let s = with_overrides(&base, &dyn_off, origin)?;
        let b = with_overrides(&better_sc, &dyn_off, origin)?;
        (
            Some(mc(
                "seed, dynamics off",
                &s,
                &out_dir.join("seed-settings-no-dynamics"),
                1,
                false,
            )?),
            Some(mc(
                "better, dynamics off",
                &b,
                &out_dir.join("better-settings-no-dynamics"),
                1,
                false,
            )?),
        )
    } else {
        (None, None)
    };
    let geo = with_overrides(
        &base,
        &[
            ov(
                "estimator.rotation_centre",
                Value::String("geometric".into()),
            ),
            dyn_off[0].clone(),
        ],
        origin,
    )?;
    let seed_geo = mc(
        "seed, geometric centre",
        &geo,
        &out_dir.join("seed-geometric-centre"),
        1,
        false,
    )?;
    // Dynamics off: the rattle would hide what the time base alone costs.
    let c30 = with_overrides(
        &base,
        &[
            ov(
                "estimator.timebase",
                kind_table("constant_fps", &[("fps_hz", Value::Float(30.0))]),
            ),
            dyn_off[0].clone(),
        ],
        origin,
    )?;
    let seed_c30 = mc(
        "seed, constant 30 fps",
        &c30,
        &out_dir.join("seed-constant-30fps"),
        1,
        false,
    )?;

    let rig = Rig::new(&base)?;
    let impact = if base.dynamics.enabled {
        largest_entry_impact(&rig, 0.002, 1e-4)
    } else {
        0.0
    };
    let intervals = rig.frame_times.intervals_s();
    let h_mean = intervals.iter().sum::<f64>() / intervals.len().max(1) as f64;
    // The α detection noise while the pin drives the wheel (`budget::report::ENGAGED_PHASES`).
    let noise =
        |m: &MonteCarloBudget| bound(m, "fused", |b| b.engaged_detection_alpha_std_rad_s2).mean;
    // Detectability of the largest impact against a configuration's engaged α noise (the
    // detection-only run when there is one).
    let impact_snr = |differentiator: &crate::estimate::Differentiator, src: &MonteCarloBudget| {
        (impact > 0.0)
            .then(|| detectability(differentiator, h_mean, impact, 0.002, noise(src), 3.0).ok())
            .flatten()
    };
    let impact_seed = impact_snr(
        &base.estimator.differentiator,
        seed_det.as_ref().unwrap_or(&seed_settings),
    );
    let impact_better = impact_snr(
        &better_sc.estimator.differentiator,
        better_det.as_ref().unwrap_or(&better),
    );

    let mut report = SeedReport {
        seed_settings,
        better,
        seed_detection_only: seed_det,
        better_detection_only: better_det,
        seed_geometric_centre: seed_geo,
        seed_constant_30fps: seed_c30,
        impact_delta_omega_rad_s: impact,
        impact_seed,
        impact_better,
        files: vec![],
    };
    let mut files = Vec::new();
    for (q, f) in [("omega", 0usize), ("alpha", 1usize)] {
        let path = out_dir.join(format!("budget_{q}.png"));
        let bars = budget_bars(&report, f);
        let (symbol, unit) = if f == 0 {
            ("ω2", "rad/s")
        } else {
            ("α2", "rad/s²")
        };
        bars_png(
            &path,
            &format!("{name}: fused {symbol} error RMS against the resolvable truth (log10)"),
            &format!("log10 RMS ({unit})"),
            &bars,
        )?;
        files.push(path);
    }
    let md = seed_markdown(rig_kind, &base, &report, out_dir);
    files.push(write_text(&out_dir.join("README.md"), &md)?);
    report.files = files;
    Ok(report)
}

fn configurations(r: &SeedReport) -> Vec<(&'static str, &MonteCarloBudget)> {
    let mut v = vec![("seed settings", &r.seed_settings)];
    if let Some(m) = &r.seed_detection_only {
        v.push(("seed settings, dynamics off", m));
    }
    v.push((
        "seed + geometric centre, dynamics off",
        &r.seed_geometric_centre,
    ));
    v.push((
        "seed settings, dynamics off, constant 30 fps timebase",
        &r.seed_constant_30fps,
    ));
    v.push(("better settings", &r.better));
    if let Some(m) = &r.better_detection_only {
        v.push(("better settings, dynamics off", m));
    }
    v
}

/// log10 of the fused RMS per configuration (the rattle and the detection error differ by
/// orders of magnitude), labelled short enough to fit under the bars.
fn budget_bars(r: &SeedReport, which: usize) -> Vec<(String, f64)> {
    configurations(r)
        .into_iter()
        .map(|(n, m)| {
            let label = n
                .replace("seed settings", "seed")
                .replace("better settings", "better")
                .replace(", dynamics off", ", no dyn.")
                .replace(", constant 30 fps timebase", ", k/30 s")
                .replace("seed + geometric centre", "seed+geo");
            let v = if which == 0 {
                m.metric(|b| b.omega.rms).mean
            } else {
                m.metric(|b| b.alpha.rms).mean
            };
            (label, v.log10())
        })
        .collect()
}

fn bounds_table(r: &SeedReport, signal: &str) -> String {
    let mut s = String::from(
        "| configuration | δθ (rad) | θ frames over δθ | ω frames over 0.057-class doubled bound | α frames over 1.73-class doubled bound | ω frames over generalised bound | α frames over generalised bound |\n|---|---|---|---|---|---|---|\n",
    );
    for (name, m) in configurations(r) {
        s.push_str(&format!(
            "| {name} | {:.3e} | {} | {} | {} | {} | {} |\n",
            bound(m, signal, |b| b.half_pixel.theta_rad).mean,
            pct(bound(m, signal, |b| b.theta_exceedance.fraction).mean),
            pct(bound(m, signal, |b| b.omega_seed_doubled_exceedance.fraction).mean),
            pct(bound(m, signal, |b| b.alpha_seed_doubled_exceedance.fraction).mean),
            pct(bound(m, signal, |b| b.omega_exceedance.fraction).mean),
            pct(bound(m, signal, |b| b.alpha_exceedance.fraction).mean),
        ));
    }
    s
}

fn seed_markdown(rig: SeedRig, base: &Scenario, r: &SeedReport, out_dir: &Path) -> String {
    let name = rig.scenario_name();
    let s = &r.seed_settings;
    let det = r.seed_detection_only.as_ref().unwrap_or(s);
    let bdet = r.better_detection_only.as_ref().unwrap_or(&r.better);
    let mut md = format!(
        "# {name}: the seed's experiment redone\n\n\
         Scenario `{name}` with the phone's real frame timing (`{}`), {:.1} s, {} frames per run, \
         4K. Seed settings: OpenCV's default detection (no corner refinement), the seed's \
         estimator (mean of corners, truncated perpendicular-bisector rotation centre, \
         `numpy.gradient` twice). Better settings: cornerSubPix refinement and the toolkit's \
         default estimator (`{}`: differentiator / marker centre / rotation centre, the best of \
         `reports/defaults/`) on the real timestamps. Main configurations: {} seeds (mean \
         [95 % CI]); the others 1 seed. {TABLE_NOTE} Generated by `geneva reports`; every \
         number below is computed.\n\n",
        rig.timing_log(),
        base.duration_s,
        s.per_seed.first().map_or(0, |b| b.frames.total),
        EstimatorConfig::default().choice_name(),
        s.seeds.len(),
    );
    md.push_str("## Errors per configuration (fused signal)\n\n");
    md.push_str(&stats_table(&configurations(r), "fused"));
    md.push_str("\n## Errors per configuration (centre signal: the seed's mean of corners)\n\n");
    md.push_str(&stats_table(&configurations(r), "centre"));

    md.push_str("\n## Does the half-pixel bound hold?\n\n");
    md.push_str(&bounds_table(r, "centre"));
    let th_seed = bound(s, "centre", |b| b.theta_exceedance.fraction).mean;
    let th_geo = bound(&r.seed_geometric_centre, "centre", |b| {
        b.theta_exceedance.fraction
    })
    .mean;
    md.push_str(&format!(
        "\nWith the seed's settings the centre signal's θ2 error exceeds the half-pixel angle \
         bound δθ in {} of frames (θ2 RMS {}). The seed's rotation centre — perpendicular \
         bisectors truncated to whole pixels — is the main cause: with the same detection and \
         the geometric circle fit (dynamics off) the fraction is {} (θ2 RMS {:.3e} rad). \
         With the better settings it is {}.\n",
        pct(th_seed),
        fmt_ci(metric(s, "centre", None, |q| q.theta.rms)),
        pct(th_geo),
        metric(&r.seed_geometric_centre, "centre", None, |q| q.theta.rms).mean,
        pct(bound(&r.better, "centre", |b| b.theta_exceedance.fraction).mean),
    ));

    md.push_str("\n## Velocity and acceleration errors in dwell and drive\n\n");
    md.push_str(&format!(
        "Seed settings, fused signal: ω2 RMS {} rad/s in dwell and {} rad/s in drive; α2 RMS {} \
         rad/s² in dwell and {} rad/s² in drive. Better settings: ω2 {} / {} rad/s, α2 {} / {} \
         rad/s² (dwell / drive).\n",
        fmt_ci(metric(s, "fused", Some("dwell"), |q| q.omega.rms)),
        fmt_ci(metric(s, "fused", Some("drive"), |q| q.omega.rms)),
        fmt_ci(metric(s, "fused", Some("dwell"), |q| q.alpha.rms)),
        fmt_ci(metric(s, "fused", Some("drive"), |q| q.alpha.rms)),
        fmt_ci(metric(&r.better, "fused", Some("dwell"), |q| q.omega.rms)),
        fmt_ci(metric(&r.better, "fused", Some("drive"), |q| q.omega.rms)),
        fmt_ci(metric(&r.better, "fused", Some("dwell"), |q| q.alpha.rms)),
        fmt_ci(metric(&r.better, "fused", Some("drive"), |q| q.alpha.rms)),
    ));

    md.push_str("\n## How much of the seed's acceleration scatter is detection error?\n\n");
    let det_p95 = metric(det, "centre", None, |q| q.alpha.p95).mean;
    let det_std = metric(det, "centre", None, |q| q.alpha.std).mean;
    md.push_str(&format!(
        "The seed estimated a possible α2 change of {SEED_ALPHA_DOUBLED_RAD_S2} rad/s² \
         (ω2: {SEED_OMEGA_DOUBLED_RAD_S} rad/s) from half-pixel errors and found its measured \
         scatter of that size. The pure detection error (seed settings, ideal kinematics, no \
         rattle) of the centre signal has α2 σ = {:.3} rad/s² and 95th percentile of |error| = \
         {:.3} rad/s², i.e. {} of the {SEED_ALPHA_DOUBLED_RAD_S2} rad/s² scatter (p95 ratio); \
         ω2 σ = {:.4} rad/s. With better settings the detection-only α2 σ is {:.3} rad/s² \
         ({}).\n",
        det_std,
        det_p95,
        pct(det_p95 / SEED_ALPHA_DOUBLED_RAD_S2),
        metric(det, "centre", None, |q| q.omega.std).mean,
        metric(bdet, "fused", None, |q| q.alpha.std).mean,
        if metric(bdet, "fused", None, |q| q.alpha.std).mean
            < metric(det, "fused", None, |q| q.alpha.std).mean
        {
            "lower than the seed settings: cornerSubPix lowers the angle noise"
        } else {
            "higher than the seed settings: cornerSubPix lowers the angle noise, but the \
             better settings' differentiator amplifies what is left more than \
             `numpy.gradient` twice"
        },
    ));
    if base.dynamics.enabled {
        md.push_str(&format!(
            "\nWith dynamics on, the errors against the raw truth (the actual motion at the frame \
             timestamps) are α2 RMS {} rad/s² (seed) and {} rad/s² (better), while the aliasing \
             part of that motion — what it holds above the Nyquist rate, the pin bouncing in the \
             clearance faster than a {:.1} fps camera can follow — has α2 RMS {:.3e} rad/s². \
             Against the resolvable truth the same runs give α2 RMS {} and {} rad/s²: what remains \
             is detection and differentiation error plus the aliased rattle folded into the \
             frames' samples.\n",
            fmt_ci(raw_metric(s, "fused", |q| q.alpha.rms)),
            fmt_ci(raw_metric(&r.better, "fused", |q| q.alpha.rms)),
            s.per_seed
                .first()
                .map_or(f64::NAN, |b| 2.0 * b.resolvable.nyquist_hz),
            s.metric(|b| b.aliasing.overall.alpha.rms).mean,
            fmt_ci(s.metric(|b| b.alpha.rms)),
            fmt_ci(r.better.metric(|b| b.alpha.rms)),
        ));
    }

    md.push_str("\n## Would the backlash impacts be visible?\n\n");
    match (&r.impact_seed, &r.impact_better) {
        (Some(a), Some(b)) => {
            md.push_str(&format!(
            "Largest entry impact in the simulated actual motion: Δω2 = {:.3} rad/s within 2 ms. \
             Against the α2 detection noise of the detection-only runs while the pin drives the \
             wheel (fused signal): seed settings \
             peak |α̂| {:.3} rad/s² vs noise σ {:.3} rad/s², SNR {:.2} → {}; better settings \
             peak {:.3} rad/s² vs σ {:.3} rad/s², SNR {:.2} → {} (threshold SNR 3).\n",
            r.impact_delta_omega_rad_s,
            a.peak_alpha_rad_s2,
            a.noise_alpha_rad_s2,
            a.snr,
            if a.detectable { "detectable" } else { "not detectable" },
            b.peak_alpha_rad_s2,
            b.noise_alpha_rad_s2,
            b.snr,
            if b.detectable { "detectable" } else { "not detectable" },
        ))
        }
        _ => md.push_str(
            "This rig has no clearance dynamics in the scenario (the external drive's rotation \
             constraint), so there is no impact to detect.\n",
        ),
    }

    md.push_str("\n## What the assumed constant 30 fps costs\n\n");
    let c = &r.seed_constant_30fps;
    let t = &det.per_seed[0];
    let k = &c.per_seed[0];
    let tb = |b: &Budget| {
        b.bounds
            .get("fused")
            .map_or(f64::NAN, |x| x.timebase_error_std_s)
    };
    md.push_str(&format!(
        "Seed settings with dynamics off (so only detection and timing matter), seed {}, fused \
         signal, analysed on the real timestamps vs on k/30 s: ω2 RMS {:.4} vs {:.4} rad/s \
         (drive: {:.4} vs {:.4}), α2 RMS {:.3} vs {:.3} rad/s² (drive: {:.3} vs {:.3}); the \
         assumed time base is off the real frame times by σ {:.2e} s (the log's rate error and \
         jitter accumulate over the run).\n",
        c.seeds[0],
        t.omega.rms,
        k.omega.rms,
        t.phases.get("drive").map_or(f64::NAN, |q| q.omega.rms),
        k.phases.get("drive").map_or(f64::NAN, |q| q.omega.rms),
        t.alpha.rms,
        k.alpha.rms,
        t.phases.get("drive").map_or(f64::NAN, |q| q.alpha.rms),
        k.phases.get("drive").map_or(f64::NAN, |q| q.alpha.rms),
        tb(k),
    ));

    md.push_str("\n## Plots\n\n");
    for f in ["budget_omega.png", "budget_alpha.png"] {
        md.push_str(&format!("![{f}]({f})\n"));
    }
    md.push_str("\nSeed settings (first seed; time series against truth, error histograms):\n\n");
    md.push_str(&image_links(&s.files, out_dir));
    md.push_str("\nBetter settings:\n\n");
    md.push_str(&image_links(&r.better.files, out_dir));
    md
}

/// The decomposition cases of the report: (folder, resolution label, width, height, image
/// scale mm/px, better settings).
pub const DECOMPOSITION_CASES: [(&str, &str, i64, i64, f64, bool); 6] = [
    ("4k-seed-settings", "4K", 3840, 2160, 0.195, false),
    ("4k-better-settings", "4K", 3840, 2160, 0.195, true),
    ("1080p-seed-settings", "1080p", 1920, 1080, 0.39, false),
    ("1080p-better-settings", "1080p", 1920, 1080, 0.39, true),
    ("720p-seed-settings", "720p", 1280, 720, 0.585, false),
    ("720p-better-settings", "720p", 1280, 720, 0.585, true),
];

/// The internal seed rig of the decomposition report (4 s: one index cycle) at a resolution,
/// with seed or better settings.
pub fn decomposition_scenario(
    name: &str,
    width_px: i64,
    height_px: i64,
    mm_per_px: f64,
    better: bool,
) -> Result<Scenario, ReportsError> {
    let base = seed_base(SeedRig::Internal)?;
    let mut overrides = vec![
        ov("name", Value::String(format!("seed-internal-{name}"))),
        ov("duration_s", Value::Float(4.0)),
        ov("camera.width_px", Value::Integer(width_px)),
        ov("camera.height_px", Value::Integer(height_px)),
        ov("camera.focal.mm_per_px", Value::Float(mm_per_px)),
    ];
    if better {
        overrides.extend(better_overrides());
    }
    Ok(with_overrides(
        &base,
        &overrides,
        Path::new("decomposition"),
    )?)
}

/// The seed rule of the report's decompositions: the default target (5 percentage points) with
/// a cap of 16 seeds instead of 64, so that the six cases regenerate in minutes; a case that
/// needs more says so (stopped at the cap) and `geneva decompose` goes further.
pub const REPORT_SEED_RULE: SeedRule = SeedRule {
    initial: 4,
    cap: 16,
    target_half_width: 0.05,
};

/// Per-source decomposition of the internal seed rig at 4K, 1080p and 720p, seed and better settings,
/// seeds chosen by `rule`.
pub fn decomposition_report(out_dir: &Path, rule: SeedRule) -> Result<Vec<PathBuf>, ReportsError> {
    let mut files = Vec::new();
    let mut md = String::from(
        "# Per-source error decomposition\n\nWhich effect costs how much of the error of the \
         internal seed rig: phone timing, 4.0 s (one index cycle), at 4K (0.195 mm/px, the seed's \
         camera), 1080p (0.39 mm/px) and 720p (0.585 mm/px), the same field of view, with the seed's settings (no corner refinement, mean of \
         the corners, truncated bisector centre, `numpy.gradient`) and with better settings \
         (the seed reports' better settings: sub-pixel corners and the toolkit's default \
         estimator). Each row is a part of the fused signal's mean square error; \
         the rows add up to the whole. CIs are 95 %, from seeds paired across configurations \
         (common random numbers); a row whose share CI contains 0 is marked.\n\n",
    );
    md.push_str(
        "| case | seeds (stop) | ω2 RMS [95 % CI] rad/s | ω2 shares | α2 RMS [95 % CI] rad/s² | α2 shares |\n\
         |---|---|---|---|---|---|\n",
    );
    let mut sections = String::new();
    for (folder, label, w, h, scale, better) in DECOMPOSITION_CASES {
        let sc = decomposition_scenario(folder, w, h, scale, better)?;
        let d = decompose_effects(&sc, &DecomposeOptions { rule, roi: true }, &|_| {})?;
        files.extend(write_outputs(&d, &out_dir.join(folder))?);
        let shares = |dec: &Decomposition| {
            dec.rows
                .iter()
                .map(|r| {
                    format!(
                        "{} {:.0} % [{:.0}, {:.0}]{}",
                        r.name,
                        100.0 * r.share.mean,
                        100.0 * r.share.ci95_low,
                        100.0 * r.share.ci95_high,
                        if r.share_indistinguishable_from_zero() {
                            " (≈ 0)"
                        } else {
                            ""
                        }
                    )
                })
                .collect::<Vec<_>>()
                .join("; ")
        };
        let rms = |m: &MeanCi| {
            format!(
                "{:.4} [{:.4}, {:.4}]",
                m.mean.max(0.0).sqrt(),
                m.ci95_low.max(0.0).sqrt(),
                m.ci95_high.max(0.0).sqrt()
            )
        };
        md.push_str(&format!(
            "| [{label}, {}]({folder}/decomposition.md) | {} ({}) | {} | {} | {} | {} |\n",
            if better {
                "better settings"
            } else {
                "seed settings"
            },
            d.seeds,
            match d.stop {
                StopReason::Settled => "settled",
                StopReason::Capped => "cap",
            },
            rms(&d.omega.all),
            shares(&d.omega),
            rms(&d.alpha.all),
            shares(&d.alpha),
        ));
        sections.push_str(&format!(
            "\n## {label}, {}\n\n{}\n![omega]({folder}/decomposition_omega.png)\n\
             ![alpha]({folder}/decomposition_alpha.png)\n",
            if better {
                "better settings"
            } else {
                "seed settings"
            },
            markdown_table(&d)
        ));
    }
    md.push_str(&format!(
        "\nRMS = √V(all), the whole the rows add up to. Seed rule: {} seeds first, then more in \
         rounds until every share's 95 % CI half-width is below {:.1} percentage points, at most \
         {} seeds.\n",
        rule.initial,
        100.0 * rule.target_half_width,
        rule.cap
    ));
    md.push_str(&sections);
    files.push(write_text(&out_dir.join("README.md"), &md)?);
    Ok(files)
}

/// Writes one report folder all at once (`io::output_dir`): `make` writes into the staging
/// folder, then its README ends with the command that regenerates it; returns the final paths.
fn staged(
    dir: &Path,
    name: &str,
    make: impl FnOnce(&Path) -> Result<(), ReportsError>,
) -> Result<Vec<PathBuf>, ReportsError> {
    let out = crate::io::output_dir::OutputDir::create(dir)?;
    make(out.path())?;
    let readme = out.path().join("README.md");
    let text = std::fs::read_to_string(&readme).map_err(crate::errors::FileError::io(&readme))?;
    write_text(
        &readme,
        &format!(
            "{}\n\n## Regenerate\n\n`cargo xtask reports --only {name}` (= `geneva reports --out \
             reports --only {name}`) rewrites this folder; on the same code it comes out the \
             same, byte for byte.\n",
            text.trim_end()
        ),
    )?;
    Ok(out.commit()?)
}

/// Regenerates the reports under `out_root`: `fast/`, and unless `fast_only`,
/// `seed-internal-4k/`, `seed-external-4k/`, `decomposition/`, `seed-camera/`, `dynamics/`,
/// `calibration/`, `defaults/` and `error-bars/` — or only those named in `options.only` — each folder committed all at once.
pub fn reports(out_root: &Path, options: &ReportsOptions) -> Result<Vec<PathBuf>, ReportsError> {
    if let Some(unknown) = options
        .only
        .iter()
        .find(|n| !REPORT_NAMES.contains(&n.as_str()))
    {
        return Err(ReportsError::UnknownReport {
            name: unknown.clone(),
            known: REPORT_NAMES.join(", "),
        });
    }
    let seeds = options.seeds;
    let wanted = |name: &str| {
        if options.only.is_empty() {
            name == "fast" || !options.fast_only
        } else {
            options.only.iter().any(|n| n == name)
        }
    };
    let mut files = Vec::new();
    if wanted("fast") {
        files.extend(staged(&out_root.join("fast"), "fast", |d| {
            fast_report(d, seeds).map(|_| ())
        })?);
    }
    for (rig, name) in [
        (SeedRig::Internal, "seed-internal-4k"),
        (SeedRig::External, "seed-external-4k"),
    ] {
        if wanted(name) {
            files.extend(staged(&out_root.join(name), name, |d| {
                seed_report(rig, d, seeds).map(|_| ())
            })?);
        }
    }
    if wanted("decomposition") {
        files.extend(staged(
            &out_root.join("decomposition"),
            "decomposition",
            |d| decomposition_report(d, REPORT_SEED_RULE).map(|_| ()),
        )?);
    }
    if wanted("seed-camera") {
        files.extend(staged(&out_root.join("seed-camera"), "seed-camera", |d| {
            seed_camera_report(&options.seed_camera_sweep, d)
        })?);
    }
    if wanted("dynamics") {
        files.extend(staged(&out_root.join("dynamics"), "dynamics", |d| {
            dynamics_report(d).map(|_| ()).map_err(ReportsError::from)
        })?);
    }
    if wanted("calibration") {
        files.extend(staged(&out_root.join("calibration"), "calibration", |d| {
            super::calibrate_roundtrip::calibration_report(
                d,
                20261123,
                CALIBRATION_CASES,
                &|_, _| {},
            )
            .map(|_| ())
            .map_err(|e| ReportsError::Calibration(Box::new(e)))
        })?);
    }
    if wanted("defaults") {
        files.extend(staged(&out_root.join("defaults"), "defaults", |d| {
            defaults_report(d, &Spread::full())
                .map(|_| ())
                .map_err(ReportsError::from)
        })?);
    }
    if wanted("error-bars") {
        files.extend(staged(&out_root.join("error-bars"), "error-bars", |d| {
            super::error_bars_check::error_bars_report(d, ERROR_BAR_FOOTAGES, 16)
                .map_err(|e| ReportsError::ErrorBars(Box::new(e)))
        })?);
    }
    Ok(files)
}

/// Footages per renderer of `reports/error-bars/`.
pub const ERROR_BAR_FOOTAGES: usize = 24;

/// The seed-camera sweep (the seed's own design question), run from scratch into `out_dir`:
/// its results, summary, recommendation and heatmaps. The sweep's own bookkeeping (the manifest,
/// which names the sweep file by its absolute path) stays out, so the report does not depend on
/// where the repository is.
pub fn seed_camera_report(sweep_file: &Path, out_dir: &Path) -> Result<(), ReportsError> {
    let spec = crate::sweep::SweepSpec::load(sweep_file)?;
    let run_dir = out_dir.join("sweep-run");
    crate::sweep::run_sweep(
        &spec,
        sweep_file,
        &run_dir,
        &super::sweep_eval::PipelineEvaluator,
        &|_, _| {},
    )?;
    let entries = std::fs::read_dir(&run_dir).map_err(crate::errors::FileError::io(&run_dir))?;
    for entry in entries {
        let entry = entry.map_err(crate::errors::FileError::io(&run_dir))?;
        let name = entry.file_name();
        let keep = !matches!(
            name.to_str(),
            Some("manifest.json" | crate::io::output_dir::MARKER)
        );
        let to = out_dir.join(&name);
        let moved = if keep {
            std::fs::rename(entry.path(), &to)
        } else {
            std::fs::remove_file(entry.path())
        };
        moved.map_err(crate::errors::FileError::io(&entry.path()))?;
    }
    std::fs::remove_dir(&run_dir).map_err(crate::errors::FileError::io(&run_dir))?;
    write_text(
        &out_dir.join("README.md"),
        "# Seed-camera sweep\n\nThe seed study's own design question: at which distance, frame \
         rate and resolution does the internal 4-slot rig's measurement meet ω RMS ≤ 0.02 rad/s \
         and α RMS ≤ 1 rad/s² against the resolvable truth on their upper 95 % bounds, with the \
         impact SNR's lower bound ≥ 3? The sweep file is `scenarios/sweeps/seed-camera.toml` (seeds added in \
         rounds where a point's intervals straddle a threshold). The recommended point, the \
         runner-up and the flagged non-monotonic neighbours are in \
         [`recommendation.md`](recommendation.md); every point's figures with their intervals in \
         `summary.csv`, every run in `results.csv`.\n\n\
         ![ω RMS](heatmap_omega_rms.png)\n\n![α RMS](heatmap_alpha_rms.png)\n",
    )?;
    Ok(())
}
