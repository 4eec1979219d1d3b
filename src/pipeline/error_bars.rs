//! Error bars for `geneva analyze --scenario`: the rig simulated at the footage's own frame
//! times, with the crank motion fitted to the footage's measured angle (`calibrate`'s kinematic
//! motion fit), on several seeds, each simulated frame missing where the footage's is; every
//! frame's bar is the RMS of the simulated measured-minus-true error there
//! ([`crate::budget::error_bars`]).
//!
//! The simulation draws the scenario's camera, scene and effects: the bars are as right as the
//! scenario is (a calibrated one is fitted to the footage). What the model lacks is not in them.

use super::analyze::{with_placeholders, write_measured, AnalyzeError, AnalyzeOutput};
use super::decompose::place_for_seed;
use super::frames::{detect_frames, FrameDetection, FrameLoopOptions, FramesError};
use super::measure::estimate_track;
use super::rig::{Rig, RigError};
use super::run::run_truths;
use crate::budget::error_bars::{signal_bars, SeedSeries, SignalBars};
use crate::budget::judge::signal_errors;
use crate::calibrate::{fit_motion, CalibrateError, MotionFit, MotionInput};
use crate::estimate::{EstimateError, Signal};
use crate::io::tracks_csv::Corners;
use crate::mechanism::DriveSpeedConfig;
use crate::rng::Stream;
use crate::scenario::Scenario;
use crate::timing::{Timestamps, TimingError};
use std::path::Path;

/// Largest RMS difference between the footage's measured angle and the simulated rig's, rad,
/// at which the simulated frames still sample the footage's motion (2°: a few per cent of an
/// index of a four-slot wheel).
pub const MOTION_MISMATCH_LIMIT_RAD: f64 = 2.0 * std::f64::consts::PI / 180.0;

#[derive(Debug, thiserror::Error)]
pub enum ErrorBarsError {
    #[error("error bars need at least 2 seeds, got {0}")]
    Seeds(usize),
    #[error(
        "the scenario's camera is {scenario_w}x{scenario_h} px, the footage's frames are {w}x{h} \
         px: the error bars need the rig as filmed (`geneva calibrate` fits a scenario to the \
         footage)"
    )]
    FrameSize {
        scenario_w: u32,
        scenario_h: u32,
        w: usize,
        h: usize,
    },
    #[error("the footage's frame times")]
    Times(#[from] TimingError),
    #[error("the footage's crank motion could not be fitted")]
    Motion(#[source] CalibrateError),
    #[error("the rig of scenario `{scenario}` filmed at the footage's frame times")]
    Rig {
        scenario: String,
        #[source]
        source: RigError,
    },
    #[error(
        "the simulated rig does not follow the footage's motion: their angles are {rms_deg:.2}° \
         apart (RMS over {frames} frames; at most {limit_deg:.1}°), so its frames would not \
         sample the footage's; check the scenario's mechanism (kind, slots) and camera, or \
         calibrate one from this footage"
    )]
    MotionMismatch {
        rms_deg: f64,
        frames: usize,
        limit_deg: f64,
    },
    #[error(
        "the footage's marker is {footage_px:.1} px a side, the scenario's rig shows it at \
         {simulated_px:.1} px: the error bars need the rig as filmed (`geneva calibrate` fits a \
         scenario to the footage)"
    )]
    MarkerSize { footage_px: f64, simulated_px: f64 },
    #[error("seed {seed}: detection")]
    Frames {
        seed: u64,
        #[source]
        source: FramesError,
    },
    #[error("seed {seed}: the estimator")]
    Estimate {
        seed: u64,
        #[source]
        source: EstimateError,
    },
}

/// How many seeds, and the factor k of the flags.
#[derive(Debug, Clone, Copy)]
pub struct ErrorBarOptions {
    pub seeds: usize,
    pub k_sigma: f64,
}

impl Default for ErrorBarOptions {
    fn default() -> Self {
        Self {
            seeds: 16,
            k_sigma: 3.0,
        }
    }
}

/// The error bars of every signal and how they were made.
#[derive(Debug, Clone)]
pub struct ErrorBars {
    /// Per signal, in the analysis's order, at the analysis's frames.
    pub signals: Vec<SignalBars>,
    /// The scenario seeds simulated.
    pub seeds: Vec<u64>,
    pub k_sigma: f64,
    /// The crank motion fitted to the footage and simulated.
    pub motion: MotionFit,
    /// RMS difference between the footage's fused θ2 and the simulated rig's as measured, rad.
    pub motion_rms_rad: f64,
}

impl ErrorBars {
    pub fn signal(&self, name: &str) -> Option<&SignalBars> {
        self.signals.iter().find(|b| b.signal == name)
    }
}

/// Writes `bars` beside `analysis` in `out_dir`: `kinematics.csv` and `measured.png` again with
/// the σ columns, bands and flags, and `error_bars.md` with [`summary_lines`], which it returns.
pub fn write_error_bars(
    out_dir: &Path,
    analysis: &AnalyzeOutput,
    bars: &ErrorBars,
) -> Result<Vec<String>, AnalyzeError> {
    write_measured(out_dir, &analysis.tracks, &analysis.signals, Some(bars))?;
    let lines = summary_lines(bars, &analysis.signals);
    let md = out_dir.join("error_bars.md");
    std::fs::write(&md, format!("# Error bars\n\n{}\n", lines.join("\n")))
        .map_err(crate::errors::FileError::io(&md))?;
    Ok(lines)
}

/// The error bars of `analysis` (made with `angle_sign`) from `scenario` simulated at its frames.
/// `progress(done, total)` counts simulated frames.
pub fn error_bars(
    scenario: &Scenario,
    analysis: &AnalyzeOutput,
    angle_sign: f64,
    options: &ErrorBarOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<ErrorBars, ErrorBarsError> {
    if options.seeds < 2 {
        return Err(ErrorBarsError::Seeds(options.seeds));
    }
    if let Some([w, h]) = analysis.input.frame_size_px {
        let c = &scenario.camera;
        if (w, h) != (c.width_px as usize, c.height_px as usize) {
            return Err(ErrorBarsError::FrameSize {
                scenario_w: c.width_px,
                scenario_h: c.height_px,
                w,
                h,
            });
        }
    }
    let filled = with_placeholders(&analysis.tracks);
    let t0 = filled.first().map_or(0.0, |(r, _)| r.t_s);
    let times: Vec<f64> = filled.iter().map(|(r, _)| r.t_s - t0).collect();
    let seen: Vec<bool> = filled
        .iter()
        .map(|(r, real)| *real && r.corners_px.is_some())
        .collect();
    let motion = fitted_motion(scenario, analysis, &times)?;
    let rig_scenario = with_motion(scenario, &motion);
    let n = times.len();
    let seeds: Vec<u64> = (0..options.seeds as u64)
        .map(|k| scenario.seed.wrapping_add(k))
        .collect();
    let mut per_signal: Vec<(String, Vec<SeedSeries>)> = Vec::new();
    for (k, &seed) in seeds.iter().enumerate() {
        // Where the marker falls on the pixel grid sets most of a frame's detection error; the
        // footage's placement is not known to a pixel, so each seed draws its own.
        let mut s = rig_scenario.clone();
        s.seed = seed;
        place_for_seed(&mut s, Stream::ErrorBarPlacement);
        let rig = Rig::filmed_at(&s, Timestamps::new(times.clone())?).map_err(|source| {
            ErrorBarsError::Rig {
                scenario: scenario.name.clone(),
                source,
            }
        })?;
        let truths = run_truths(&rig, &times);
        let to_analysis = angle_sign * rig.screen_sign;
        let detections = simulate(&rig, seed, &|done| progress(k * n + done, seeds.len() * n))?;
        if k == 0 {
            same_marker_size(&analysis.tracks, &detections)?;
        }
        let blank = |c: Option<Corners>, i: usize| c.filter(|_| seen[i]);
        let corners: Vec<Option<Corners>> = detections
            .iter()
            .enumerate()
            .map(|(i, d)| blank(d.corners_px, i))
            .collect();
        let reference: Vec<Option<Corners>> = detections
            .iter()
            .enumerate()
            .map(|(i, d)| blank(d.reference_px, i))
            .collect();
        let with_reference = rig.scenario.scene.reference_marker.enabled
            && rig.scenario.detector.reference_marker_id.is_some();
        // Each signal is differentiated as it was on the footage: a data-driven parameter (the
        // Kalman λ) is the one resolved there, since the footage's values were made with it.
        let mut done: Vec<(String, Vec<crate::budget::compare::SignalErrors>)> = Vec::new();
        for used in &analysis.estimate.signals {
            let key = format!("{:?}", used.differentiator);
            let at = match done.iter().position(|(k, _)| *k == key) {
                Some(at) => at,
                None => {
                    let mut config = rig.scenario.estimator.clone();
                    config.differentiator = used.differentiator.clone();
                    let est = estimate_track(
                        &config,
                        &times,
                        &corners,
                        with_reference.then_some(reference.as_slice()),
                    )
                    .map_err(|source| ErrorBarsError::Estimate { seed, source })?;
                    let errors =
                        signal_errors(&est, &truths.geometry, &truths.truth, &truths.resolvable);
                    done.push((key, errors));
                    done.len() - 1
                }
            };
            let errors = &done[at].1;
            let name = used.signal.name();
            let Some(e) = errors.iter().find(|e| e.signal == name) else {
                continue;
            };
            let series = seed_series(e, to_analysis);
            match per_signal.iter_mut().find(|(n, _)| n == name) {
                Some((_, v)) => v.push(series),
                None => per_signal.push((name.to_string(), vec![series])),
            }
        }
    }
    let signals: Vec<SignalBars> = per_signal
        .iter()
        .map(|(name, series)| signal_bars(name, series))
        .collect();
    let fused = Signal::Fused.name();
    let measured = analysis.signals.iter().find(|s| s.signal == fused);
    let model = signals.iter().find(|b| b.signal == fused);
    let (motion_rms_rad, frames) = match (measured, model) {
        (Some(m), Some(b)) => rms_difference(&m.theta2_rad, &b.model[0]),
        _ => (f64::NAN, 0),
    };
    // NaN (no frame to compare) fails too.
    if motion_rms_rad.is_nan() || motion_rms_rad > MOTION_MISMATCH_LIMIT_RAD {
        return Err(ErrorBarsError::MotionMismatch {
            rms_deg: motion_rms_rad.to_degrees(),
            frames,
            limit_deg: MOTION_MISMATCH_LIMIT_RAD.to_degrees(),
        });
    }
    Ok(ErrorBars {
        signals,
        seeds,
        k_sigma: options.k_sigma,
        motion,
        motion_rms_rad,
    })
}

/// The crank motion fitted to the footage's marker-centre angle (image angle, clockwise on
/// screen positive, from the first frame's time).
fn fitted_motion(
    scenario: &Scenario,
    analysis: &AnalyzeOutput,
    times: &[f64],
) -> Result<MotionFit, ErrorBarsError> {
    let centre = &analysis.estimate.signals[Signal::Centre.index()];
    let track: Vec<(f64, f64)> = times
        .iter()
        .zip(&centre.theta_rad)
        .filter(|(_, th)| th.is_finite())
        .map(|(t, th)| (*t, -th))
        .collect();
    let input = MotionInput {
        kind: scenario.mechanism.kind,
        slots: scenario.mechanism.slots,
        dense: track.clone(),
        track,
        centre_angle_u95_rad: 0.0,
    };
    fit_motion(&input, &mut Vec::new()).map_err(ErrorBarsError::Motion)
}

/// `scenario` with the fitted crank phase and speed.
fn with_motion(scenario: &Scenario, m: &MotionFit) -> Scenario {
    let mut s = scenario.clone();
    s.mechanism.theta1_start_rad = Some(m.theta1_start_rad.value);
    s.drive_speed = match &m.polynomial {
        Some((end, mid)) => DriveSpeedConfig::PolynomialPerEngagement {
            end_rad_s: end.value,
            mid_rad_s: mid.value,
        },
        None => DriveSpeedConfig::Constant {
            omega1_rad_s: m.omega1_rad_s.value,
        },
    };
    s
}

/// One seed's detections on every frame of the rig.
fn simulate(
    rig: &Rig,
    seed: u64,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<FrameDetection>, ErrorBarsError> {
    let n = rig.frame_times.len();
    let mut detections = Vec::with_capacity(n);
    detect_frames(
        rig,
        0..n,
        FrameLoopOptions::default(),
        |chunk| {
            detections.extend_from_slice(chunk);
            Ok(())
        },
        progress,
    )
    .map_err(|source| ErrorBarsError::Frames { seed, source })?;
    Ok(detections)
}

/// A simulated signal in the analysis's convention: θ2 relative to its first measured frame,
/// the analysis's sense (`to_analysis` = ±1), errors against the actual motion.
fn seed_series(e: &crate::budget::compare::SignalErrors, to_analysis: f64) -> SeedSeries {
    let first = |v: &[f64]| v.iter().copied().find(|x| x.is_finite()).unwrap_or(0.0);
    let (m0, e0) = (first(&e.theta2_rad), first(&e.theta_raw_err_rad));
    let scaled = |v: &[f64], at: f64| v.iter().map(|x| to_analysis * (x - at)).collect();
    SeedSeries {
        measured: [
            scaled(&e.theta2_rad, m0),
            scaled(&e.omega2_rad_s, 0.0),
            scaled(&e.alpha2_rad_s2, 0.0),
        ],
        error: [
            scaled(&e.theta_raw_err_rad, e0),
            scaled(&e.omega_raw_err_rad_s, 0.0),
            scaled(&e.alpha_raw_err_rad_s2, 0.0),
        ],
    }
}

/// Largest relative difference between the footage's and the simulated rig's marker size at
/// which the simulation still stands for the footage (10 %: detection error scales with it).
const MARKER_SIZE_TOLERANCE: f64 = 0.10;

/// Refuses a rig whose marker is not the footage's size in the image (a track's camera is not
/// known from its file, so a scenario of another camera or distance shows here).
fn same_marker_size(
    footage: &[crate::io::tracks_csv::TrackRow],
    simulated: &[FrameDetection],
) -> Result<(), ErrorBarsError> {
    let side = |c: &Corners| {
        (0..4)
            .map(|i| {
                let (a, b) = (c[i], c[(i + 1) % 4]);
                (a[0] - b[0]).hypot(a[1] - b[1])
            })
            .sum::<f64>()
            / 4.0
    };
    let median = |sides: Vec<f64>| crate::numeric::robust::median_finite(sides);
    let footage_px = median(
        footage
            .iter()
            .filter_map(|r| r.corners_px.as_ref())
            .map(side)
            .collect(),
    );
    let simulated_px = median(
        simulated
            .iter()
            .filter_map(|d| d.corners_px.as_ref())
            .map(side)
            .collect(),
    );
    match (footage_px, simulated_px) {
        (Some(f), Some(s)) if (s / f - 1.0).abs() > MARKER_SIZE_TOLERANCE => {
            Err(ErrorBarsError::MarkerSize {
                footage_px: f,
                simulated_px: s,
            })
        }
        _ => Ok(()),
    }
}

/// RMS of `a − b` over the frames where both are finite, and their count.
fn rms_difference(a: &[f64], b: &[f64]) -> (f64, usize) {
    crate::numeric::robust::rms_finite(a.iter().zip(b).map(|(x, y)| x - y))
}

/// What the error bars are, in lines for the terminal and `error_bars.md`: how they were made,
/// the fused signal's median bars, the flagged frames, and what the bars do not hold.
pub fn summary_lines(
    bars: &ErrorBars,
    measured: &[crate::estimate::MeasuredSignal],
) -> Vec<String> {
    use crate::budget::error_bars::{feature_flags, sigma_relative_se};
    use crate::numeric::robust::median_finite;
    let n = bars.seeds.len();
    let m = &bars.motion;
    let drive = match &m.polynomial {
        Some((end, mid)) => format!(
            "ω1 {:.4} rad/s at the ends of an engagement, {:.4} in its middle",
            end.value, mid.value
        ),
        None => format!("ω1 {:.4} rad/s", m.omega1_rad_s.value),
    };
    let mut lines = vec![
        format!(
            "error bars: {n} simulated seeds at the footage's own frame times (each σ known to \
             ± {:.0} %, 1/√(2·{n}))",
            100.0 * sigma_relative_se(n)
        ),
        format!(
            "  crank motion fitted to the footage: θ1 at the first frame {:.4} rad, {drive}; the \
             simulated rig's angle follows the footage's to {:.3}° RMS",
            m.theta1_start_rad.value,
            bars.motion_rms_rad.to_degrees()
        ),
    ];
    let fused = crate::estimate::Signal::Fused.name();
    if let (Some(b), Some(s)) = (
        bars.signal(fused),
        measured.iter().find(|s| s.signal == fused),
    ) {
        let med = |v: &[f64]| median_finite(v.to_vec()).unwrap_or(f64::NAN);
        lines.push(format!(
            "  median σ of the fused signal: θ2 {:.4}°, ω2 {:.4} rad/s, α2 {:.3} rad/s^2",
            med(&b.sigma[0]).to_degrees(),
            med(&b.sigma[1]),
            med(&b.sigma[2])
        ));
        let [alpha, jump] = feature_flags(b, &s.omega2_rad_s, &s.alpha2_rad_s2, bars.k_sigma);
        let count = |f: &[Option<bool>]| f.iter().filter(|x| **x == Some(true)).count();
        let judged = alpha.iter().filter(|x| x.is_some()).count();
        lines.push(format!(
            "  beyond {} σ of the modelled motion (fused): α2 at {} and ω2 jumps at {} of {judged} frames \
             (kinematics.csv: alpha2_beyond_noise, omega2_jump_beyond_noise)",
            bars.k_sigma,
            count(&alpha),
            count(&jump)
        ));
    }
    lines.push(
        "  σ holds detection and timing noise and the estimator's own error of the scenario's \
         rig; not an effect the scenario lacks (geneva diagnose looks for those)"
            .into(),
    );
    lines
}
