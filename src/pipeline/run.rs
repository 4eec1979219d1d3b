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
    // No path to the tracks: a failed run's staging folder, where they were, is removed.
    #[error("estimation: {0}")]
    Estimate(crate::estimate::EstimateError),
    #[error(transparent)]
    Csv(#[from] crate::io::csv_out::CsvError),
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    #[error(transparent)]
    File(#[from] crate::errors::FileError),
    #[error(
        "the scenario's {frames} frame(s) cover {arc_deg:.3}° of the wheel's rotation: the \
         rotation-centre fit needs at least 3 frames and {min_arc_deg}° \
         (estimator.min_arc_deg); a longer duration_s, a higher frame rate or a faster drive"
    )]
    NotMeasurable {
        frames: usize,
        arc_deg: f64,
        min_arc_deg: f64,
    },
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
    /// Where the corners come from: detection on the rendered frames (what `geneva run` does),
    /// or the scene's exact corners with no image at all (the decomposition's estimator-only
    /// configuration).
    pub corners: CornerSource,
}

/// Where a run's corners come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CornerSource {
    /// The detector on the rendered frames.
    Detected,
    /// The exact projection of the marker's outer corners at each frame's render time, with
    /// nothing rendered: what the estimator makes of perfect corners. Only meaningful with every
    /// image effect off (a blurred, shuttered or noisy picture has no single exact corner); the
    /// decomposition uses it on its `none` configuration.
    Exact,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            roi: true,
            plots: true,
            write_files: true,
            chunk_frames: 32,
            corners: CornerSource::Detected,
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
    /// The headline (fused) signal's differentiator as it ran: a Kalman smoother's automatic λ
    /// resolved on the measured series.
    pub differentiator: crate::estimate::Differentiator,
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
    measurable(&rig)?;
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
    let mut take = |chunk: &[FrameDetection]| -> Result<(), crate::io::csv_out::CsvError> {
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
    };
    match options.corners {
        CornerSource::Detected => {
            detect_frames(&rig, 0..n, loop_options, take, &|done| progress(done, n))?
        }
        CornerSource::Exact => {
            let exact = exact_detections(&rig, with_reference);
            take(&exact)?;
            progress(n, n);
        }
    }
    if let Some(w) = writer {
        w.finish()?;
    }
    let mut output = judge(&rig, detections, out_dir, options, &tracks_path)?;
    output.elapsed_s = started.elapsed().as_secs_f64();
    Ok(output)
}

/// Refuses a rig whose frames the estimator cannot measure whatever the images: fewer than 3
/// frames, or an arc of the wheel's actual motion over the frames shorter than the rotation-centre
/// fit accepts. `geneva scenario check` runs it too, so such a scenario fails there and not after
/// its frames are rendered.
pub fn measurable(rig: &Rig) -> Result<(), RunError> {
    let times = rig.frame_times.as_slice();
    let (lo, hi) = times
        .iter()
        .map(|&t| rig.mechanism.actual(t).theta2_rad)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), th| {
            (lo.min(th), hi.max(th))
        });
    let arc_deg = if times.is_empty() {
        0.0
    } else {
        (hi - lo).to_degrees()
    };
    let min_arc_deg = rig.scenario.estimator.min_arc_deg;
    if times.len() < 3 || arc_deg < min_arc_deg {
        return Err(RunError::NotMeasurable {
            frames: times.len(),
            arc_deg,
            min_arc_deg,
        });
    }
    Ok(())
}

/// Cells of the marker's narrowest projection below this many pixels across cannot be read.
const MIN_CELL_PX: f64 = 1.0;

/// What makes a valid rig's marker undetectable in its frames, one sentence each naming the
/// fields (`geneva scenario check` prints them; the runs of such a rig detect nothing): paper and
/// ink closer in DN than the detector's adaptive threshold, a marker so foreshortened that its
/// cells are under a pixel across, a camera shake whose 3 σ moves the marker out of the image.
pub fn detection_warnings(rig: &Rig) -> Vec<String> {
    let s = &rig.scenario;
    let mut out = Vec::new();
    let tone = crate::scenario::clipping::Tone::of(&s.effects.lighting);
    let (ink_dn, paper_dn) = (
        tone.dn(s.scene.ink_radiance),
        tone.dn(s.scene.paper_radiance),
    );
    let threshold = s.detector.adaptive_thresh_constant_dn;
    if paper_dn - ink_dn < threshold {
        out.push(format!(
            "scene.paper_radiance, scene.ink_radiance: the paper ({paper_dn:.1} DN) and the ink \
             ({ink_dn:.1} DN) differ by {:.1} DN, less than the detector's adaptive threshold \
             (detector.adaptive_thresh_constant_dn = {threshold}): no frame's marker can be found",
            paper_dn - ink_dn
        ));
    }
    let m = &s.scene.marker;
    let cells = (m.dictionary.marker_size_bits() + 2 * m.border_bits) as f64;
    let scene = rig.animated();
    let times = rig.frame_times.as_slice();
    let stride = (times.len() / 200).max(1);
    let narrowest_px = times
        .iter()
        .step_by(stride)
        .map(|&t| narrowest_width_px(&scene.marker_corners_px(rig.render_time_s(t))))
        .fold(f64::INFINITY, f64::min);
    if narrowest_px / cells < MIN_CELL_PX {
        out.push(format!(
            "camera.perspective_tilt, scene.marker.size_mm: at its narrowest the marker spans \
             {narrowest_px:.1} px, {:.2} px per cell of its {cells} cells across: the detector \
             cannot read it (at least {MIN_CELL_PX} px a cell)",
            narrowest_px / cells
        ));
    }
    let v = &s.effects.camera_vibration;
    if v.enabled {
        let amplitude = |list: &[crate::render::effects::camera_vibration::Sinusoid]| {
            list.iter().map(|c| c.amplitude.abs()).sum::<f64>()
        };
        let reach = |rms: f64, list| 3.0 * rms + amplitude(list);
        let (rx, ry) = (
            reach(v.random.x_rms_px, &v.x_px),
            reach(v.random.y_rms_px, &v.y_px),
        );
        let (w, h) = (s.camera.width_px as f64, s.camera.height_px as f64);
        if rx > 0.5 * w || ry > 0.5 * h {
            out.push(format!(
                "effects.camera_vibration: the shake reaches {rx:.0} px in x and {ry:.0} px in y \
                 (3 σ of its random part plus its sinusoids) in a {w}×{h} image: the marker \
                 leaves the image in many frames"
            ));
        }
    }
    out
}

/// The smaller of a quadrilateral's two widths: the distance across it between each pair of
/// opposite sides (its area over their mean length).
fn narrowest_width_px(c: &[[f64; 2]; 4]) -> f64 {
    let len = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
    let area = 0.5
        * (0..4)
            .map(|i| {
                let (a, b) = (c[i], c[(i + 1) % 4]);
                a[0] * b[1] - b[0] * a[1]
            })
            .sum::<f64>()
            .abs();
    let across = |i: usize| area / (0.5 * (len(c[i], c[i + 1]) + len(c[i + 2], c[(i + 3) % 4])));
    across(0).min(across(1))
}

/// The scene's exact corners at every frame's render time (the instant the picture shows), as
/// detections: no rendering, no pixel grid, no detector.
pub fn exact_detections(rig: &Rig, with_reference: bool) -> Vec<FrameDetection> {
    let scene = rig.animated();
    let reference = if with_reference {
        scene.reference_marker_corners_px()
    } else {
        None
    };
    rig.frame_times
        .as_slice()
        .iter()
        .enumerate()
        .map(|(frame, &t_s)| FrameDetection {
            frame,
            t_s,
            corners_px: Some(scene.marker_corners_px(rig.render_time_s(t_s))),
            reference_px: reference,
            path: FramePath::Exact,
        })
        .collect()
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
    .map_err(RunError::Estimate)?;
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
            None,
        )?;
        let json_path = out_dir.join("budget.json");
        let text = serde_json::to_string_pretty(&budget)
            .map_err(crate::errors::FileError::json(&json_path))?;
        std::fs::write(&json_path, text + "\n")
            .map_err(crate::errors::FileError::io(&json_path))?;
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
    let full_frames = detections
        .iter()
        .filter(|d| matches!(d.path, FramePath::FullFrame | FramePath::RoiThenFullFrame))
        .count();
    let differentiator = est
        .signals
        .iter()
        .find(|s| s.signal == crate::estimate::Signal::Fused)
        .map_or_else(
            || scenario.estimator.differentiator.clone(),
            |s| s.differentiator.clone(),
        );
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
        differentiator,
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
