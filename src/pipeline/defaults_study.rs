//! `reports/defaults/`: which estimator the toolkit uses when a scenario does not choose one.
//!
//! Every candidate — a differentiator, a marker-centre method and a rotation-centre method — is
//! judged by its total error against the resolvable truth (noise everywhere, plus the bias where
//! α2 jumps at entry and exit) over a spread of camera set-ups of the seed rig: frame rates,
//! resolutions and marker sizes in pixels. Each set-up is rendered and detected once and every
//! candidate is run on the same detections, so the ranking compares estimators, not noise draws.
//! The ranking is scale-free: at each set-up a candidate's RMS error is divided by the best
//! candidate's there, and the score is the geometric mean of those ratios over set-ups and over
//! θ2, ω2 and α2 (1 = best everywhere).

use super::frames::{detect_frames, FrameDetection, FrameLoopOptions, FramesError};
use super::rig::{Rig, RigError};
use super::run::run_truths;
use crate::budget::judge::signal_errors;
use crate::budget::stats::ErrorStats;
use crate::estimate::{
    estimate, Differentiator, EstimateError, EstimatorConfig, MarkerCentreMethod,
    RotationCentreMethod, Signal,
};
use crate::io::csv_out::{num, CsvError, CsvWriter};
use crate::io::tracks_csv::Corners;
use crate::scenario::{load_any, with_overrides, Scenario, ScenarioError};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use toml::Value;

/// The built-in scenario whose rig the spread films (dynamics, frame timing and image effects
/// as the seed's; only the camera changes).
pub const BASE_SCENARIO: &str = "seed-internal-4k";

/// The printed marker's edge, mm, and its distance from the axis in marker sizes on the seed rig
/// (744 px / 164.8 px): the spread keeps the seed's layout where the frame allows it.
const SEED_ORBIT_IN_MARKERS: f64 = 744.0 / 164.8;

#[derive(Debug, thiserror::Error)]
pub enum DefaultsError {
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error("{point}")]
    Rig { point: String, source: RigError },
    #[error("{point}")]
    Frames { point: String, source: FramesError },
    #[error(transparent)]
    Csv(#[from] CsvError),
    #[error("{file}: cannot write")]
    Write {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("no candidate estimator gave an answer at every camera set-up")]
    NoCandidate,
}

/// An image size of the spread.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolution {
    pub label: &'static str,
    pub width_px: u32,
    pub height_px: u32,
}

/// The camera set-ups the candidates are judged over.
#[derive(Debug, Clone, PartialEq)]
pub struct Spread {
    pub fps: Vec<f64>,
    pub resolutions: Vec<Resolution>,
    /// Edge of the marker's black square in the image, px.
    pub marker_px: Vec<f64>,
    /// The rig's clearance dynamics (pin–slot impacts) off, on, or both.
    pub dynamics: Vec<bool>,
    /// Length of each run, s (long enough for an entry and an exit after the resolvable truth's
    /// first undefined frames).
    pub duration_s: f64,
    /// Scenario seed of every run.
    pub seed: u64,
}

const R1080: Resolution = Resolution {
    label: "1080p",
    width_px: 1920,
    height_px: 1080,
};
const R4K: Resolution = Resolution {
    label: "4k",
    width_px: 3840,
    height_px: 2160,
};

impl Spread {
    /// The spread of `reports/defaults/`: exact kinematics and with impacts × 24–120 fps ×
    /// 1080p, 4K × 40–250 px markers.
    pub fn full() -> Self {
        Self {
            fps: vec![24.0, 30.0, 60.0, 120.0],
            resolutions: vec![R1080, R4K],
            marker_px: vec![40.0, 100.0, 250.0],
            dynamics: vec![false, true],
            duration_s: 5.0,
            seed: 1,
        }
    }

    /// A tiny spread for tests: two set-ups at 1080p and 30 fps, exact kinematics.
    pub fn tiny() -> Self {
        Self {
            fps: vec![30.0],
            resolutions: vec![R1080],
            marker_px: vec![60.0, 120.0],
            dynamics: vec![false],
            duration_s: 5.0,
            seed: 1,
        }
    }

    /// Every set-up: dynamics outermost, then frame rate, resolution and marker size.
    pub fn points(&self) -> Vec<CameraPoint> {
        let mut points = Vec::new();
        for &dynamics in &self.dynamics {
            for &fps in &self.fps {
                for &resolution in &self.resolutions {
                    for &marker_px in &self.marker_px {
                        points.push(CameraPoint {
                            fps,
                            resolution,
                            marker_px,
                            dynamics,
                        });
                    }
                }
            }
        }
        points
    }
}

/// One camera set-up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraPoint {
    pub fps: f64,
    pub resolution: Resolution,
    pub marker_px: f64,
    /// Clearance dynamics on (impacts at entry) or exact kinematics.
    pub dynamics: bool,
}

impl CameraPoint {
    pub fn label(&self) -> String {
        format!(
            "{}, {} fps, {}, {} px marker",
            self.mechanism(),
            self.fps,
            self.resolution.label,
            self.marker_px
        )
    }

    /// `impacts` (clearance dynamics) or `kinematics` (exact).
    pub fn mechanism(&self) -> &'static str {
        mechanism_name(self.dynamics)
    }

    /// Distance of the marker centre from the wheel axis in the image, px: the seed's layout,
    /// moved inwards when the marker's paper would otherwise leave the frame on some turn.
    pub fn orbit_px(&self) -> f64 {
        // The paper is 1.5 marker edges wide (8 mm margins on a 32 mm marker): half its diagonal
        // is 1.06 edges; keep 5 % of the height clear.
        let room = 0.45 * self.resolution.height_px as f64 - 1.07 * self.marker_px;
        (SEED_ORBIT_IN_MARKERS * self.marker_px).min(room)
    }

    /// The base scenario filmed with this camera.
    pub fn scenario(
        &self,
        base: &Scenario,
        duration_s: f64,
        seed: u64,
    ) -> Result<Scenario, ScenarioError> {
        let mm_per_px = base.scene.marker.size_mm / self.marker_px;
        let overrides = [
            ("name", Value::String(format!("defaults {}", self.label()))),
            ("seed", Value::Integer(seed as i64)),
            ("duration_s", Value::Float(duration_s)),
            ("dynamics.enabled", Value::Boolean(self.dynamics)),
            ("frame_timing.fps", Value::Float(self.fps)),
            (
                "camera.width_px",
                Value::Integer(self.resolution.width_px as i64),
            ),
            (
                "camera.height_px",
                Value::Integer(self.resolution.height_px as i64),
            ),
            ("camera.focal.mm_per_px", Value::Float(mm_per_px)),
            (
                "scene.marker.radius_mm",
                Value::Float(self.orbit_px() * mm_per_px),
            ),
        ]
        .map(|(k, v)| (k.to_string(), v));
        with_overrides(base, &overrides, Path::new("defaults"))
    }
}

/// Why the toolkit's default estimator is what it is, in one line (printed by `geneva analyze`
/// when it uses the defaults).
pub fn defaults_reason() -> String {
    let s = Spread::full();
    let span = |v: &[f64]| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        format!("{lo}–{hi}")
    };
    let resolutions: Vec<&str> = s.resolutions.iter().map(|r| r.label).collect();
    format!(
        "the lowest total error (noise plus the bias at the entry/exit α2 jumps, against the \
         resolvable truth) of {} candidates over {} set-ups: {}, {} fps, {}, {} px markers \
         (reports/defaults/)",
        candidates().len(),
        s.points().len(),
        mechanisms(&s).join(" and "),
        span(&s.fps),
        resolutions.join(" and "),
        span(&s.marker_px)
    )
}

fn mechanism_name(dynamics: bool) -> &'static str {
    if dynamics {
        "impacts"
    } else {
        "kinematics"
    }
}

fn mechanisms(s: &Spread) -> Vec<&'static str> {
    s.dynamics.iter().map(|&d| mechanism_name(d)).collect()
}

/// A candidate estimator.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// Unique, comma-free name ([`EstimatorConfig::choice_name`]).
    pub name: String,
    pub estimator: EstimatorConfig,
}

/// Every combination of the differentiators, marker centres and rotation-centre methods the
/// toolkit has (Savitzky–Golay at two fixed windows and one window in time; Kalman with its
/// automatic λ); everything else as the estimator's defaults.
pub fn candidates() -> Vec<Candidate> {
    let differentiators = [
        Differentiator::Seed,
        Differentiator::Central3,
        Differentiator::SavitzkyGolay {
            window_frames: 5,
            window_s: None,
            order: 2,
        },
        Differentiator::SavitzkyGolay {
            window_frames: 9,
            window_s: None,
            order: 2,
        },
        Differentiator::SavitzkyGolay {
            window_frames: 9,
            window_s: Some(0.2),
            order: 2,
        },
        Differentiator::KalmanRts {
            lambda_per_s6: None,
        },
    ];
    let centres = [
        MarkerCentreMethod::CornerMean,
        MarkerCentreMethod::DiagonalIntersection,
    ];
    let rotation = [
        RotationCentreMethod::Seed,
        RotationCentreMethod::Kasa,
        RotationCentreMethod::Taubin,
        RotationCentreMethod::Geometric,
    ];
    let mut out = Vec::new();
    for d in &differentiators {
        for &m in &centres {
            for &r in &rotation {
                let estimator = EstimatorConfig {
                    differentiator: d.clone(),
                    marker_centre: m,
                    rotation_centre: r,
                    ..EstimatorConfig::default()
                };
                out.push(Candidate {
                    name: estimator.choice_name(),
                    estimator,
                });
            }
        }
    }
    out
}

/// One candidate's errors at one set-up: fused signal against the resolvable truth, RMS.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CandidateErrors {
    pub theta_rad: f64,
    pub omega_rad_s: f64,
    pub alpha_rad_s2: f64,
    /// α2 in the drive phase, where the motion is smooth: mostly the noise.
    pub alpha_drive_rad_s2: f64,
    /// α2 in the entry and exit phases, where it jumps: noise plus the smoothing bias.
    pub alpha_jumps_rad_s2: f64,
    /// Frames with a resolvable truth and a measurement.
    pub frames: usize,
}

/// Errors of every candidate at one set-up (`Err`: the candidate refused the track, and why).
#[derive(Debug, Clone)]
pub struct PointResult {
    pub point: CameraPoint,
    pub frames_total: usize,
    pub frames_detected: usize,
    pub errors: Vec<Result<CandidateErrors, EstimateError>>,
}

/// Runs one set-up: render and detect once, then every candidate on the same detections.
pub fn evaluate_point(
    point: CameraPoint,
    scenario: &Scenario,
    candidates: &[Candidate],
) -> Result<PointResult, DefaultsError> {
    let label = point.label();
    let label = label.as_str();
    let rig = Rig::new(scenario).map_err(|source| DefaultsError::Rig {
        point: label.into(),
        source,
    })?;
    let n = rig.frame_times.len();
    let mut detections: Vec<FrameDetection> = Vec::with_capacity(n);
    detect_frames(
        &rig,
        0..n,
        FrameLoopOptions::default(),
        |chunk| {
            detections.extend_from_slice(chunk);
            Ok(())
        },
        &|_| {},
    )
    .map_err(|source| DefaultsError::Frames {
        point: label.into(),
        source,
    })?;
    let t: Vec<f64> = detections.iter().map(|d| d.t_s).collect();
    let corners: Vec<Option<Corners>> = detections.iter().map(|d| d.corners_px).collect();
    let truths = run_truths(&rig, &t);
    let phases = &truths.truth.phase;
    let errors = candidates
        .par_iter()
        .map(|c| {
            let est = estimate(&c.estimator, &t, &corners, None)?;
            let signals = signal_errors(&est, &truths.geometry, &truths.truth, &truths.resolvable);
            let fused = &signals[Signal::Fused.index()];
            let only = |v: &[f64], keep: &dyn Fn(&str) -> bool| -> Vec<f64> {
                v.iter()
                    .zip(phases)
                    .filter(|(_, p)| keep(p))
                    .map(|(x, _)| *x)
                    .collect()
            };
            let alpha = &fused.alpha_err_rad_s2;
            let theta = ErrorStats::of(&fused.theta_err_rad);
            Ok(CandidateErrors {
                theta_rad: theta.rms,
                omega_rad_s: ErrorStats::of(&fused.omega_err_rad_s).rms,
                alpha_rad_s2: ErrorStats::of(alpha).rms,
                alpha_drive_rad_s2: ErrorStats::of(&only(alpha, &|p| p == "drive")).rms,
                alpha_jumps_rad_s2: ErrorStats::of(&only(alpha, &|p| p == "entry" || p == "exit"))
                    .rms,
                frames: theta.n,
            })
        })
        .collect();
    Ok(PointResult {
        point,
        frames_total: n,
        frames_detected: corners.iter().filter(|c| c.is_some()).count(),
        errors,
    })
}

/// One candidate's place in the ranking: geometric means over the set-ups of its RMS error
/// divided by the best candidate's RMS at that set-up (1 = the best everywhere).
#[derive(Debug, Clone, PartialEq)]
pub struct Ranked {
    /// Index into the candidate list.
    pub candidate: usize,
    pub name: String,
    /// Geometric mean of the θ2, ω2 and α2 ratios over every set-up: the ranking key.
    pub score: f64,
    pub theta: f64,
    pub omega: f64,
    pub alpha: f64,
    /// α2 in the drive (smooth motion: mostly noise) and at the entry/exit jumps (noise + bias).
    pub alpha_drive: f64,
    pub alpha_jumps: f64,
    /// The largest α2 ratio over the set-ups.
    pub alpha_worst: f64,
    /// Set-ups where the candidate refused the track.
    pub failures: usize,
}

fn geometric_mean(values: &[f64]) -> f64 {
    let finite: Vec<f64> = values
        .iter()
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if finite.is_empty() {
        return f64::NAN;
    }
    (finite.iter().map(|v| v.ln()).sum::<f64>() / finite.len() as f64).exp()
}

/// Ranks the candidates (pure): fewest failures first, then the lowest score; ties keep the
/// candidate order.
pub fn rank(results: &[PointResult], names: &[String]) -> Vec<Ranked> {
    type Pick = fn(&CandidateErrors) -> f64;
    let picks: [Pick; 5] = [
        |e| e.theta_rad,
        |e| e.omega_rad_s,
        |e| e.alpha_rad_s2,
        |e| e.alpha_drive_rad_s2,
        |e| e.alpha_jumps_rad_s2,
    ];
    // ratios[q][c] = the candidate's ratios to the best at each set-up, for quantity q.
    let mut ratios = vec![vec![Vec::new(); names.len()]; picks.len()];
    for r in results {
        for (q, pick) in picks.iter().enumerate() {
            let best = r
                .errors
                .iter()
                .filter_map(|e| e.as_ref().ok().map(pick))
                .filter(|v| v.is_finite() && *v > 0.0)
                .fold(f64::INFINITY, f64::min);
            for (c, e) in r.errors.iter().enumerate() {
                if let Ok(e) = e {
                    ratios[q][c].push(pick(e) / best);
                }
            }
        }
    }
    let mut ranked: Vec<Ranked> = names
        .iter()
        .enumerate()
        .map(|(c, name)| {
            let total: Vec<f64> = (0..3).flat_map(|q| ratios[q][c].clone()).collect();
            Ranked {
                candidate: c,
                name: name.clone(),
                score: geometric_mean(&total),
                theta: geometric_mean(&ratios[0][c]),
                omega: geometric_mean(&ratios[1][c]),
                alpha: geometric_mean(&ratios[2][c]),
                alpha_drive: geometric_mean(&ratios[3][c]),
                alpha_jumps: geometric_mean(&ratios[4][c]),
                alpha_worst: ratios[2][c]
                    .iter()
                    .copied()
                    .filter(|v| v.is_finite())
                    .fold(f64::NAN, f64::max),
                failures: results
                    .iter()
                    .filter(|r| r.errors.get(c).is_some_and(|e| e.is_err()))
                    .count(),
            }
        })
        .collect();
    ranked.sort_by(|a, b| {
        a.failures
            .cmp(&b.failures)
            .then(a.score.total_cmp(&b.score))
    });
    ranked
}

/// What the study computed.
#[derive(Debug, Clone)]
pub struct DefaultsStudy {
    pub spread: Spread,
    pub candidates: Vec<Candidate>,
    pub results: Vec<PointResult>,
    pub ranking: Vec<Ranked>,
    pub files: Vec<PathBuf>,
}

impl DefaultsStudy {
    /// The best candidate (first in the ranking); an error when every candidate failed somewhere.
    pub fn best(&self) -> Result<&Candidate, DefaultsError> {
        self.ranking
            .first()
            .filter(|r| r.failures == 0 && r.score.is_finite())
            .map(|r| &self.candidates[r.candidate])
            .ok_or(DefaultsError::NoCandidate)
    }
}

/// Runs the study over `spread` on the built-in [`BASE_SCENARIO`].
pub fn run_study(
    spread: &Spread,
    progress: &dyn Fn(usize, usize),
) -> Result<DefaultsStudy, DefaultsError> {
    let base = load_any(BASE_SCENARIO)?;
    let candidates = candidates();
    let points = spread.points();
    let mut results = Vec::with_capacity(points.len());
    for (i, point) in points.iter().enumerate() {
        let scenario = point.scenario(&base, spread.duration_s, spread.seed)?;
        results.push(evaluate_point(*point, &scenario, &candidates)?);
        progress(i + 1, points.len());
    }
    let names: Vec<String> = candidates.iter().map(|c| c.name.clone()).collect();
    let ranking = rank(&results, &names);
    Ok(DefaultsStudy {
        spread: spread.clone(),
        candidates,
        results,
        ranking,
        files: Vec::new(),
    })
}

fn write_text(path: &Path, text: &str) -> Result<PathBuf, DefaultsError> {
    std::fs::write(path, text).map_err(|source| DefaultsError::Write {
        file: path.to_path_buf(),
        source,
    })?;
    Ok(path.to_path_buf())
}

/// Header of `ranking.csv`.
pub const RANKING_HEADER: [&str; 12] = [
    "rank",
    "candidate",
    "differentiator",
    "marker_centre",
    "rotation_centre",
    "score",
    "theta_ratio",
    "omega_ratio",
    "alpha_ratio",
    "alpha_drive_ratio",
    "alpha_jumps_ratio",
    "failures",
];

/// Runs the study and writes `ranking.csv`, `per_setup.csv` and `README.md` into `out_dir`.
pub fn defaults_report(out_dir: &Path, spread: &Spread) -> Result<DefaultsStudy, DefaultsError> {
    let mut study = run_study(spread, &|_, _| {})?;
    let best = study.best()?.clone();
    let ranking_path = out_dir.join("ranking.csv");
    let mut w = CsvWriter::create(&ranking_path, &RANKING_HEADER)?;
    for (i, r) in study.ranking.iter().enumerate() {
        let e = &study.candidates[r.candidate].estimator;
        w.row(&[
            (i + 1).to_string(),
            r.name.clone(),
            e.differentiator.label(),
            e.marker_centre.name().into(),
            e.rotation_centre.name().into(),
            num(r.score),
            num(r.theta),
            num(r.omega),
            num(r.alpha),
            num(r.alpha_drive),
            num(r.alpha_jumps),
            r.failures.to_string(),
        ])?;
    }
    w.finish()?;
    let setup_path = out_dir.join("per_setup.csv");
    let mut w = CsvWriter::create(
        &setup_path,
        &[
            "mechanism",
            "fps",
            "resolution",
            "marker_px",
            "orbit_px",
            "frames_total",
            "frames_detected",
            "candidate",
            "frames_judged",
            "theta_rms_rad",
            "omega_rms_rad_s",
            "alpha_rms_rad_s2",
            "alpha_drive_rms_rad_s2",
            "alpha_jumps_rms_rad_s2",
            "error",
        ],
    )?;
    for r in &study.results {
        for (c, e) in study.candidates.iter().zip(&r.errors) {
            let mut cells = vec![
                r.point.mechanism().to_string(),
                num(r.point.fps),
                r.point.resolution.label.to_string(),
                num(r.point.marker_px),
                format!("{:.1}", r.point.orbit_px()),
                r.frames_total.to_string(),
                r.frames_detected.to_string(),
                c.name.clone(),
            ];
            match e {
                Ok(e) => cells.extend([
                    e.frames.to_string(),
                    num(e.theta_rad),
                    num(e.omega_rad_s),
                    num(e.alpha_rad_s2),
                    num(e.alpha_drive_rad_s2),
                    num(e.alpha_jumps_rad_s2),
                    String::new(),
                ]),
                Err(error) => {
                    cells.extend((0..6).map(|_| String::new()));
                    cells.push(crate::errors::full(error).replace([',', '\n'], ";"));
                }
            }
            w.row(&cells)?;
        }
    }
    w.finish()?;
    let md = readme(&study, &best);
    study.files = vec![
        ranking_path,
        setup_path,
        write_text(&out_dir.join("README.md"), &md)?,
    ];
    Ok(study)
}

fn readme(study: &DefaultsStudy, best: &Candidate) -> String {
    let s = &study.spread;
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let resolutions: Vec<&str> = s.resolutions.iter().map(|r| r.label).collect();
    let default = EstimatorConfig::default();
    let default_name = default.choice_name();
    let mut md = format!(
        "# Default estimator\n\nWhich differentiator, marker centre and rotation-centre method \
         `geneva` uses when a scenario (or `geneva analyze` without `--scenario`) does not choose. \
         Each of the {} candidates is judged by its total error — the noise everywhere plus the \
         bias where α2 jumps at entry and exit — against the resolvable truth (the motion \
         averaged over each frame's exposure and band-limited to the footage's Nyquist rate, \
         ARCHITECTURE.md), fused signal, over {} set-ups of the `{BASE_SCENARIO}` rig (its \
         phone frame timing and image effects): {} × {} fps × {} × a {} px marker, {} s each, \
         seed {} (`kinematics`: exact Geneva motion, whose α2 jumps at entry and exit; \
         `impacts`: the rig's pin–slot clearance dynamics, with impacts at entry). The marker stays at the seed's {:.2} marker sizes from the \
         axis unless the frame is too small for it (`orbit_px` in `per_setup.csv`). Every \
         set-up is rendered and detected once and all candidates run on the same detections.\n\n\
         **Score**: at each set-up a candidate's RMS error is divided by the best candidate's \
         there; the score is the geometric mean of these ratios over the set-ups and over θ2, ω2 \
         and α2 (1 = the best at every set-up). Beside the α2 ratio: the drive phase alone (smooth \
         motion: mostly the noise) and the entry and exit phases alone (the jumps: noise plus \
         the smoothing bias); \"worst α2\" is the largest α2 ratio at any set-up. One run (one \
         seed) a set-up: the ranking of candidates whose scores differ by less than the \
         run-to-run scatter, not measured here, is not settled by this table.\n\n",
        study.candidates.len(),
        study.results.len(),
        mechanisms(s).join(", "),
        list(&s.fps),
        resolutions.join(", "),
        list(&s.marker_px),
        s.duration_s,
        s.seed,
        SEED_ORBIT_IN_MARKERS,
    );
    md.push_str(&format!(
        "**Best: `{}`**. The toolkit's default estimator is `{}`{}.\n\n",
        best.name,
        default_name,
        if default_name == best.name {
            " — the best of this table"
        } else {
            " — **not** the best of this table"
        }
    ));
    md.push_str(
        "| rank | differentiator / marker centre / rotation centre | score | θ2 | ω2 | α2 | α2 drive | α2 entry+exit | worst α2 | failures |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (i, r) in study.ranking.iter().enumerate() {
        md.push_str(&format!(
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {} |\n",
            i + 1,
            r.name,
            r.score,
            r.theta,
            r.omega,
            r.alpha,
            r.alpha_drive,
            r.alpha_jumps,
            r.alpha_worst,
            r.failures
        ));
    }
    md.push_str("\n## Absolute errors of the best candidate and of the seed's estimator\n\n");
    let seed_name = (EstimatorConfig {
        differentiator: Differentiator::Seed,
        marker_centre: MarkerCentreMethod::CornerMean,
        rotation_centre: RotationCentreMethod::Seed,
        ..EstimatorConfig::default()
    })
    .choice_name();
    let index = |name: &str| study.candidates.iter().position(|c| c.name == name);
    md.push_str(
        "Fused signal, RMS against the resolvable truth (rad, rad/s, rad/s²); `best` is the \
         first row above, `seed` the seed study's estimator.\n\n\
         | set-up | frames detected | θ2 best | θ2 seed | ω2 best | ω2 seed | α2 best | α2 seed | α2 entry+exit best | α2 entry+exit seed |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let cell = |r: &PointResult, c: Option<usize>, f: fn(&CandidateErrors) -> f64| {
        c.and_then(|c| r.errors.get(c))
            .and_then(|e| e.as_ref().ok())
            .map_or("failed".to_string(), |e| format!("{:.2e}", f(e)))
    };
    let (b, sd) = (index(&best.name), index(&seed_name));
    for r in &study.results {
        md.push_str(&format!(
            "| {} | {}/{} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.point.label(),
            r.frames_detected,
            r.frames_total,
            cell(r, b, |e| e.theta_rad),
            cell(r, sd, |e| e.theta_rad),
            cell(r, b, |e| e.omega_rad_s),
            cell(r, sd, |e| e.omega_rad_s),
            cell(r, b, |e| e.alpha_rad_s2),
            cell(r, sd, |e| e.alpha_rad_s2),
            cell(r, b, |e| e.alpha_jumps_rad_s2),
            cell(r, sd, |e| e.alpha_jumps_rad_s2),
        ));
    }
    md.push_str(
        "\nEvery candidate at every set-up: `per_setup.csv`; the ranking as data: \
         `ranking.csv`. Regenerate with `cargo xtask reports`.\n",
    );
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn errors(scale: f64) -> CandidateErrors {
        CandidateErrors {
            theta_rad: 1e-3 * scale,
            omega_rad_s: 1e-2 * scale,
            alpha_rad_s2: scale,
            alpha_drive_rad_s2: 0.5 * scale,
            alpha_jumps_rad_s2: 2.0 * scale,
            frames: 100,
        }
    }

    fn point(errors: Vec<Result<CandidateErrors, EstimateError>>) -> PointResult {
        PointResult {
            point: Spread::tiny().points()[0],
            frames_total: 100,
            frames_detected: 100,
            errors,
        }
    }

    #[test]
    fn ranking_is_scale_free_and_puts_failures_last() {
        let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        // b is best at both set-ups although the set-ups' error levels differ 1000-fold; c is
        // better than b at the second set-up but refused the first track.
        let results = vec![
            point(vec![
                Ok(errors(2.0)),
                Ok(errors(1.0)),
                Err(EstimateError::ArcTooShort {
                    span_deg: 3.0,
                    min_deg: 10.0,
                }),
            ]),
            point(vec![
                Ok(errors(2000.0)),
                Ok(errors(1000.0)),
                Ok(errors(500.0)),
            ]),
        ];
        let r = rank(&results, &names);
        let order: Vec<&str> = r.iter().map(|x| x.name.as_str()).collect();
        assert_eq!(order, ["b", "a", "c"]);
        // b: ratio 1 at the first set-up, 2 at the second → geometric mean √2.
        assert!((r[0].score - 2f64.sqrt()).abs() < 1e-12, "{r:?}");
        assert!((r[1].score - 8f64.sqrt()).abs() < 1e-12, "{r:?}");
        assert_eq!((r[2].failures, r[2].score), (1, 1.0));
        assert!((r[1].alpha_worst - 4.0).abs() < 1e-12);
    }

    #[test]
    fn every_candidate_has_a_unique_name_and_the_default_is_a_candidate() {
        let c = candidates();
        let mut names: Vec<&str> = c.iter().map(|c| c.name.as_str()).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), c.len());
        assert!(names.iter().all(|n| !n.contains(',')));
        let default = EstimatorConfig::default().choice_name();
        assert!(c.iter().any(|c| c.name == default), "{default}");
    }

    #[test]
    fn the_spread_keeps_every_marker_inside_its_frame() {
        for p in Spread::full().points() {
            let half = p.resolution.height_px as f64 / 2.0;
            assert!(p.orbit_px() + 1.07 * p.marker_px < half, "{p:?}");
            assert!(p.orbit_px() > 0.5 * p.marker_px, "{p:?}");
        }
    }
}
