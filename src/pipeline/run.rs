//! `geneva run`: render → detect → estimate → budget for a synthetic scenario, in one streaming
//! pass. Writes `tracks.csv`, `kinematics.csv`, `budget.json` and plots into the output folder.
//! The truths (actual, ideal, resolvable) are made here from the rig; `budget` compares.

use super::frames::{detect_frames, FrameDetection, FrameLoopOptions, FramePath};
use super::measure::estimate_track;
use super::plots::plot_measured_vs_truth;
use super::rig::{Rig, RigError};
use crate::budget::compare::{SignalErrors, TruthSeries};
use crate::budget::judge::{build_budget, signal_errors, TrueGeometry, Truths};
use crate::budget::report::{Budget, FrameCounts};
use crate::budget::resolvable::{Resolvable, ResolvableFilter};
use crate::io::kinematics_csv::write_kinematics_csv;
use crate::io::tracks_csv::{Corners, TrackRow, TracksWriter};
use crate::mechanism::MotionSample;
use crate::scenario::Scenario;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Rig(#[from] RigError),
    #[error("{dir}: cannot create output directory")]
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
    /// What the frames can resolve of the truth (NaN where undefined).
    pub resolvable: TruthSeries,
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
    let RunTruths {
        truth,
        ideal,
        resolvable,
        band_limited,
        resolved,
        filter,
        geometry,
    } = run_truths(rig, &t);
    let signals = signal_errors(&est, &geometry, &truth, &resolvable);
    let frames = FrameCounts {
        total: detections.len(),
        detected: detections.iter().filter(|d| d.corners_px.is_some()).count(),
    };
    let budget = build_budget(
        &scenario.name,
        &est,
        &signals,
        &Truths {
            raw: &truth,
            ideal: &ideal,
            resolvable: &resolvable,
            band_limited: &band_limited,
            frame_theta2_rad: &resolved.frame_theta2_rad,
            info: &resolved.info,
        },
        &geometry,
        frames,
    );
    let mut files = Vec::new();
    if options.write_files {
        let kin = out_dir.join("kinematics.csv");
        write_kinematics_csv(
            &kin,
            &t,
            &signals,
            Some((&truth, &ideal, &resolvable)),
            None,
        )?;
        let json_path = out_dir.join("budget.json");
        let text = serde_json::to_string_pretty(&budget).map_err(|e| RunError::Json {
            file: json_path.clone(),
            message: crate::errors::full(&e),
        })?;
        std::fs::write(&json_path, text + "\n").map_err(|e| RunError::Json {
            file: json_path.clone(),
            message: crate::errors::full(&e),
        })?;
        files.extend([tracks_path.to_path_buf(), kin, json_path]);
        if options.plots {
            files.extend(plot_measured_vs_truth(
                out_dir,
                rig,
                &signals,
                &truth,
                &resolved.info,
                filter.as_ref(),
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
        resolvable,
        detections,
        roi_frames,
        full_frames,
        elapsed_s: 0.0,
        files,
    })
}

/// The truths a run's measurement is judged against, at the frame timestamps `t`: made once from
/// the rig, shared by every estimate of the same detections.
pub struct RunTruths {
    /// The actual motion at the timestamps.
    pub truth: TruthSeries,
    /// The ideal kinematics at the timestamps.
    pub ideal: TruthSeries,
    /// What the frames can resolve of the actual motion (NaN where undefined).
    pub resolvable: TruthSeries,
    /// The actual motion band-limited at the timestamps (truth − this = the aliasing part).
    pub band_limited: TruthSeries,
    pub resolved: Resolvable,
    pub filter: Option<ResolvableFilter>,
    pub geometry: TrueGeometry,
}

/// The truths of the frames at timestamps `t` (see [`RunTruths`]).
pub fn run_truths(rig: &Rig, t: &[f64]) -> RunTruths {
    let actual_samples: Vec<MotionSample> = t.iter().map(|&x| rig.mechanism.actual(x)).collect();
    let ideal_samples: Vec<MotionSample> = t.iter().map(|&x| rig.mechanism.ideal(x)).collect();
    let truth = truth_series(&actual_samples);
    let ideal = truth_series(&ideal_samples);
    let (resolved, filter) = rig.resolvable_truth(t);
    let with_phases = |theta: &[f64], omega: &[f64], alpha: &[f64]| TruthSeries {
        t_s: t.to_vec(),
        theta2_rad: theta.to_vec(),
        omega2_rad_s: omega.to_vec(),
        alpha2_rad_s2: alpha.to_vec(),
        phase: truth.phase.clone(),
    };
    let resolvable = with_phases(
        &resolved.theta2_rad,
        &resolved.omega2_rad_s,
        &resolved.alpha2_rad_s2,
    );
    let band_limited = with_phases(
        &resolved.band_limited_theta2_rad,
        &resolved.band_limited_omega2_rad_s,
        &resolved.band_limited_alpha2_rad_s2,
    );
    let geometry = true_geometry(rig, t.first().copied().unwrap_or(0.0));
    RunTruths {
        truth,
        ideal,
        resolvable,
        band_limited,
        resolved,
        filter,
        geometry,
    }
}

/// The true image geometry at `t_s` (the first frame), for the per-signal angle offsets and the
/// bounds' radii: truth only, never fitted to the measurement.
fn true_geometry(rig: &Rig, t_s: f64) -> TrueGeometry {
    let pose = rig.pose(t_s);
    let centre = rig.scene.rotation_centre_px_at(&pose);
    let corners = rig.scene.marker_corners_px_at(&pose);
    let mc = rig.scene.marker_centre_px_at(&pose);
    let mut points_px: Vec<[f64; 2]> = corners.to_vec();
    points_px.push([mc.x, mc.y]); // centre
    points_px.push([mc.x, mc.y]); // fused is aligned to the centre signal
    TrueGeometry {
        centre_px: [centre.x, centre.y],
        points_px,
        screen_sign: rig.screen_sign,
    }
}
