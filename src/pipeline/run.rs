//! `geneva run`: render → detect → estimate → budget for a synthetic scenario, in one streaming
//! pass. Writes `tracks.csv`, `kinematics.csv`, `budget.json` and plots into the output folder.

use super::frames::{detect_frames, FrameDetection, FrameLoopOptions, FramePath};
use super::measure::estimate_track;
use super::plots::plot_measured_vs_truth;
use super::rig::{Rig, RigError};
use crate::budget::bounds::LinearWeights;
use crate::budget::compare::{to_wheel_convention, SignalErrors, TruthSeries};
use crate::budget::report::{
    bounds_report, mechanism_departure, signal_budget, BoundsInput, Budget, FrameCounts,
};
use crate::estimate::angle::screen_angle_rad;
use crate::estimate::{Estimate, Signal};
use crate::io::kinematics_csv::write_kinematics_csv;
use crate::io::tracks_csv::{Corners, TrackRow, TracksWriter};
use crate::mechanism::MotionSample;
use crate::scenario::Scenario;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{0}")]
    Rig(#[from] RigError),
    #[error("{dir}: cannot create output directory: {source}")]
    OutDir {
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error(transparent)]
    Frames(#[from] super::frames::FramesError),
    #[error("estimation: {0} (the tracks are in {1})")]
    Estimate(crate::estimate::EstimateError, PathBuf),
    #[error(transparent)]
    Csv(#[from] crate::io::csv_out::CsvError),
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    #[error("{file}: {message}")]
    Json { file: PathBuf, message: String },
}

/// Options of a run.
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub roi: bool,
    /// Write plots (the Monte Carlo and sweep callers skip them).
    pub plots: bool,
    /// Write tracks/kinematics/budget files (false: compute only).
    pub write_files: bool,
    pub chunk_frames: usize,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            roi: true,
            plots: true,
            write_files: true,
            chunk_frames: 32,
        }
    }
}

/// Everything a run computed.
#[derive(Debug, Clone)]
pub struct RunOutput {
    pub budget: Budget,
    pub signals: Vec<SignalErrors>,
    pub truth: TruthSeries,
    pub ideal: TruthSeries,
    pub detections: Vec<FrameDetection>,
    pub roi_frames: usize,
    pub full_frames: usize,
    pub elapsed_s: f64,
    pub files: Vec<PathBuf>,
}

impl RunOutput {
    pub fn frames_per_s(&self) -> f64 {
        self.detections.len() as f64 / self.elapsed_s.max(1e-9)
    }
}

pub fn truth_series(samples: &[MotionSample]) -> TruthSeries {
    TruthSeries {
        t_s: samples.iter().map(|s| s.t_s).collect(),
        theta2_rad: samples.iter().map(|s| s.theta2_rad).collect(),
        omega2_rad_s: samples.iter().map(|s| s.omega2_rad_s).collect(),
        alpha2_rad_s2: samples.iter().map(|s| s.alpha2_rad_s2).collect(),
        phase: samples.iter().map(|s| s.phase.as_str()).collect(),
    }
}

/// Runs the whole synthetic pipeline. `progress(done, total)` is called after each chunk.
pub fn run(
    scenario: &Scenario,
    out_dir: &Path,
    options: &RunOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<RunOutput, RunError> {
    let started = Instant::now();
    let rig = Rig::new(scenario)?;
    if options.write_files {
        std::fs::create_dir_all(out_dir).map_err(|source| RunError::OutDir {
            dir: out_dir.into(),
            source,
        })?;
    }
    let n = rig.frame_times.len();
    let with_reference =
        scenario.scene.reference_marker.enabled && scenario.detector.reference_marker_id.is_some();
    let tracks_path = out_dir.join("tracks.csv");
    let mut writer = if options.write_files {
        Some(TracksWriter::create(&tracks_path, with_reference)?)
    } else {
        None
    };
    let mut detections: Vec<FrameDetection> = Vec::with_capacity(n);
    let loop_options = FrameLoopOptions {
        roi: options.roi,
        chunk_frames: options.chunk_frames,
    };
    let marker_id = scenario.detector.marker_id;
    detect_frames(
        &rig,
        0..n,
        loop_options,
        |chunk| {
            if let Some(w) = writer.as_mut() {
                for d in chunk {
                    w.row(&TrackRow {
                        frame: d.frame,
                        t_s: d.t_s,
                        marker_id,
                        corners_px: d.corners_px,
                        reference_px: d.reference_px,
                    })?;
                }
            }
            detections.extend_from_slice(chunk);
            Ok(())
        },
        &|done| progress(done, n),
    )?;
    if let Some(w) = writer {
        w.finish()?;
    }
    let mut output = judge(&rig, detections, out_dir, options, &tracks_path)?;
    output.elapsed_s = started.elapsed().as_secs_f64();
    Ok(output)
}

/// Estimation and error budget of detected frames against the rig's truth.
fn judge(
    rig: &Rig,
    detections: Vec<FrameDetection>,
    out_dir: &Path,
    options: &RunOptions,
    tracks_path: &Path,
) -> Result<RunOutput, RunError> {
    let scenario = &rig.scenario;
    let t: Vec<f64> = detections.iter().map(|d| d.t_s).collect();
    let corners: Vec<Option<Corners>> = detections.iter().map(|d| d.corners_px).collect();
    let with_reference =
        scenario.scene.reference_marker.enabled && scenario.detector.reference_marker_id.is_some();
    let reference: Vec<Option<Corners>> = detections.iter().map(|d| d.reference_px).collect();
    let est = estimate_track(
        &scenario.estimator,
        &t,
        &corners,
        with_reference.then_some(reference.as_slice()),
    )
    .map_err(|e| RunError::Estimate(e, tracks_path.to_path_buf()))?;
    let actual_samples: Vec<MotionSample> = t.iter().map(|&x| rig.mechanism.actual(x)).collect();
    let ideal_samples: Vec<MotionSample> = t.iter().map(|&x| rig.mechanism.ideal(x)).collect();
    let truth = truth_series(&actual_samples);
    let ideal = truth_series(&ideal_samples);
    let signals = signal_errors(rig, &est, &truth);
    let budget = build_budget(rig, &est, &signals, &truth, &ideal, &detections);
    let mut files = Vec::new();
    if options.write_files {
        let kin = out_dir.join("kinematics.csv");
        write_kinematics_csv(&kin, &t, &signals, Some((&truth, &ideal)), None)?;
        let json_path = out_dir.join("budget.json");
        let text = serde_json::to_string_pretty(&budget).map_err(|e| RunError::Json {
            file: json_path.clone(),
            message: e.to_string(),
        })?;
        std::fs::write(&json_path, text + "\n").map_err(|e| RunError::Json {
            file: json_path.clone(),
            message: e.to_string(),
        })?;
        files.extend([tracks_path.to_path_buf(), kin, json_path]);
        if options.plots {
            files.extend(plot_measured_vs_truth(
                out_dir,
                &scenario.name,
                &signals,
                &truth,
                &actual_samples,
            )?);
        }
    }
    let roi_frames = detections
        .iter()
        .filter(|d| d.path == FramePath::Roi)
        .count();
    let full_frames = detections.len() - roi_frames;
    Ok(RunOutput {
        budget,
        signals,
        truth,
        ideal,
        detections,
        roi_frames,
        full_frames,
        elapsed_s: 0.0,
        files,
    })
}

/// The true screen position of each signal's point at the first frame, for the angle offset.
fn true_points(rig: &Rig, t_s: f64) -> ([f64; 2], Vec<[f64; 2]>) {
    let pose = rig.pose(t_s);
    let centre = rig.scene.rotation_centre_px_at(&pose);
    let corners = rig.scene.marker_corners_px_at(&pose);
    let mc = rig.scene.marker_centre_px_at(&pose);
    let mut points: Vec<[f64; 2]> = corners.to_vec();
    points.push([mc.x, mc.y]); // centre
    points.push([mc.x, mc.y]); // fused is aligned to the centre signal
    ([centre.x, centre.y], points)
}

fn signal_errors(rig: &Rig, est: &Estimate, truth: &TruthSeries) -> Vec<SignalErrors> {
    let t0 = truth.t_s.first().copied().unwrap_or(0.0);
    let (centre, points) = true_points(rig, t0);
    est.signals
        .iter()
        .map(|s| {
            let p = points[s.signal.index()];
            let offset = screen_angle_rad(p, centre);
            to_wheel_convention(
                s.signal.name(),
                &s.theta_rad,
                &s.omega_rad_s,
                &s.alpha_rad_s2,
                rig.screen_sign,
                offset,
                truth.theta2_rad.first().copied().unwrap_or(0.0),
                truth,
            )
        })
        .collect()
}

fn build_budget(
    rig: &Rig,
    est: &Estimate,
    signals: &[SignalErrors],
    truth: &TruthSeries,
    ideal: &TruthSeries,
    detections: &[FrameDetection],
) -> Budget {
    let t0 = truth.t_s.first().copied().unwrap_or(0.0);
    let (centre, points) = true_points(rig, t0);
    let intervals: Vec<f64> = est.t_used_s.windows(2).map(|w| w[1] - w[0]).collect();
    let h_min = intervals.iter().copied().fold(f64::INFINITY, f64::min);
    let h_mean = if intervals.is_empty() {
        1.0 / 30.0
    } else {
        intervals.iter().sum::<f64>() / intervals.len() as f64
    };
    let timebase_err: Vec<f64> = est
        .t_used_s
        .iter()
        .zip(&truth.t_s)
        .map(|(u, t)| u - t)
        .collect();
    let timebase_error_std_s = crate::budget::ErrorStats::of(&timebase_err).std;
    let omega_rms_true = (truth.omega2_rad_s.iter().map(|w| w * w).sum::<f64>()
        / truth.omega2_rad_s.len().max(1) as f64)
        .sqrt();
    let mut per_signal = BTreeMap::new();
    let mut bounds = BTreeMap::new();
    for (series, errors) in est.signals.iter().zip(signals) {
        per_signal.insert(errors.signal.clone(), signal_budget(errors, truth));
        let p = points[series.signal.index()];
        let radius_px = ((p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2)).sqrt();
        let differentiator = series.differentiator.clone();
        let weights = LinearWeights::probe(
            |tt, th| match differentiator.differentiate(tt, th) {
                Ok(d) => (d.omega_rad_s, d.alpha_rad_s2),
                Err(_) => (vec![f64::NAN; tt.len()], vec![f64::NAN; tt.len()]),
            },
            h_mean,
            12,
        );
        bounds.insert(
            errors.signal.clone(),
            bounds_report(&BoundsInput {
                errors,
                radius_px,
                position_error_px: 0.5,
                h_min_s: h_min,
                weights: &weights,
                omega_rms_true_rad_s: omega_rms_true,
                timebase_error_std_s,
            }),
        );
    }
    let fused = &per_signal[Signal::Fused.name()];
    Budget {
        scenario: rig.scenario.name.clone(),
        seeds: 1,
        frames: FrameCounts {
            total: detections.len(),
            detected: detections.iter().filter(|d| d.corners_px.is_some()).count(),
        },
        theta: fused.overall.theta,
        omega: fused.overall.omega,
        alpha: fused.overall.alpha,
        relative: fused.overall.relative.clone(),
        phases: fused.phases.clone(),
        mechanism: mechanism_departure(truth, ideal),
        signals: per_signal,
        bounds,
    }
}
