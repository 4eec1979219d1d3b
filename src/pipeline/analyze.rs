//! `geneva analyze`: the same measurement pipeline on real data — a video, a folder of frames
//! with timestamps, or an existing corner track. Detection runs on whole frames until the marker
//! is found, then in a window around its last position (exact: same corners as full-frame
//! detection, with fallback), sequentially since each frame predicts the next.

use super::measure::estimate_track;
use crate::detect::{corners_bbox_px, ArucoDetector, DetectorConfig, GrayView};
use crate::estimate::measured::relative_to_first_frame;
use crate::estimate::{Estimate, EstimatorConfig, MeasuredSignal};
use crate::io::kinematics_csv::write_kinematics_csv;
use crate::io::tracks_csv::{read_tracks, Corners, TrackRow, TracksWriter};
use crate::plot::{stacked_png, Panel, Series, MEASURED, SECOND};
use std::path::{Path, PathBuf};

/// Where the real data comes from.
#[derive(Debug, Clone)]
pub enum Source {
    Video(PathBuf),
    Frames { dir: PathBuf, timestamps: PathBuf },
    Tracks(PathBuf),
}

#[derive(Debug, Clone)]
pub struct AnalyzeOptions {
    pub detector: DetectorConfig,
    pub estimator: EstimatorConfig,
    /// +1: angles counter-clockwise on screen positive; −1: clockwise positive (the seed's sense
    /// and the sense of θ2 in the synthetic scenes). Default −1.
    pub angle_sign: f64,
}

impl Default for AnalyzeOptions {
    fn default() -> Self {
        Self {
            detector: DetectorConfig::default(),
            estimator: EstimatorConfig::default(),
            angle_sign: -1.0,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum AnalyzeError {
    #[error("{0}")]
    Input(String),
    #[error("{file}: frame {frame}: {message}")]
    Frame {
        file: PathBuf,
        frame: usize,
        message: String,
    },
    #[error("estimation: {0} ({1} frames read, tracks written to {2})")]
    Estimate(crate::estimate::EstimateError, usize, PathBuf),
    #[error(transparent)]
    Csv(#[from] crate::io::csv_out::CsvError),
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
}

#[derive(Debug, Clone)]
pub struct AnalyzeOutput {
    pub estimate: Estimate,
    pub signals: Vec<MeasuredSignal>,
    pub tracks: Vec<TrackRow>,
    pub files: Vec<PathBuf>,
}

/// Detection state carried from frame to frame.
struct Tracker {
    detector: ArucoDetector,
    marker_id: i32,
    reference_id: Option<i32>,
    last: Option<Corners>,
    last_reference: Option<Corners>,
}

impl Tracker {
    fn observe(
        &mut self,
        data: &[u8],
        w: usize,
        h: usize,
    ) -> Result<(Option<Corners>, Option<Corners>), String> {
        let view = GrayView::full(data, w, h);
        let m = self
            .detector
            .detect_marker(
                view,
                self.marker_id,
                self.last.as_ref().map(corners_bbox_px),
            )
            .map_err(|e| e.to_string())?;
        let corners = m.detection.map(|d| d.corners_px);
        let reference = match self.reference_id {
            Some(id) => self
                .detector
                .detect_marker(view, id, self.last_reference.as_ref().map(corners_bbox_px))
                .map_err(|e| e.to_string())?
                .detection
                .map(|d| d.corners_px),
            None => None,
        };
        // Keep the last position through a missed frame, so the window follows the marker back.
        if corners.is_some() {
            self.last = corners;
        }
        if reference.is_some() {
            self.last_reference = reference;
        }
        Ok((corners, reference))
    }
}

/// Reads `frame, t_s` timestamps for a frame folder.
fn read_frame_timestamps(path: &Path) -> Result<Vec<f64>, AnalyzeError> {
    crate::io::timing_log::read_timing_log(path, None)
        .map(|t| t.into_vec())
        .map_err(|e| AnalyzeError::Input(e.to_string()))
}

/// Detects the marker in every frame of `source` (or reads the track) and writes tracks.csv.
fn track(
    source: &Source,
    options: &AnalyzeOptions,
    out_dir: &Path,
    progress: &dyn Fn(usize, usize),
) -> Result<Vec<TrackRow>, AnalyzeError> {
    if let Source::Tracks(path) = source {
        return read_tracks(path).map_err(|e| AnalyzeError::Input(e.to_string()));
    }
    let detector = ArucoDetector::new(&options.detector)
        .map_err(|e| AnalyzeError::Input(format!("detector: {e}")))?;
    let mut tracker = Tracker {
        detector,
        marker_id: options.detector.marker_id,
        reference_id: options.detector.reference_marker_id,
        last: None,
        last_reference: None,
    };
    let tracks_path = out_dir.join("tracks.csv");
    let mut writer =
        TracksWriter::create(&tracks_path, options.detector.reference_marker_id.is_some())?;
    let mut rows = Vec::new();
    let mut push = |rows: &mut Vec<TrackRow>,
                    frame: usize,
                    t_s: f64,
                    c: Option<Corners>,
                    r: Option<Corners>|
     -> Result<(), AnalyzeError> {
        let row = TrackRow {
            frame,
            t_s,
            marker_id: options.detector.marker_id,
            corners_px: c,
            reference_px: r,
        };
        writer.row(&row)?;
        rows.push(row);
        Ok(())
    };
    match source {
        Source::Frames { dir, timestamps } => {
            let files = crate::io::images::list_image_files(dir)
                .map_err(|e| AnalyzeError::Input(e.to_string()))?;
            let times = read_frame_timestamps(timestamps)?;
            if files.len() != times.len() {
                return Err(AnalyzeError::Input(format!(
                    "{} holds {} image files but {} has {} timestamps",
                    dir.display(),
                    files.len(),
                    timestamps.display(),
                    times.len()
                )));
            }
            for (i, (file, t)) in files.iter().zip(&times).enumerate() {
                let img = crate::io::images::read_gray(file).map_err(|e| AnalyzeError::Frame {
                    file: file.clone(),
                    frame: i,
                    message: e.to_string(),
                })?;
                let (c, r) = tracker
                    .observe(&img.data, img.width, img.height)
                    .map_err(|m| AnalyzeError::Frame {
                        file: file.clone(),
                        frame: i,
                        message: m,
                    })?;
                push(&mut rows, i, *t, c, r)?;
                progress(i + 1, files.len());
            }
        }
        Source::Video(path) => {
            let mut frames = crate::io::video::VideoFrames::open(path)
                .map_err(|e| AnalyzeError::Input(e.to_string()))?;
            let (w, h, total) = (
                frames.info().width_px,
                frames.info().height_px,
                frames.info().frame_count(),
            );
            loop {
                match frames.next_frame() {
                    Ok(Some(f)) => {
                        let (c, r) =
                            tracker
                                .observe(&f.data, w, h)
                                .map_err(|m| AnalyzeError::Frame {
                                    file: path.clone(),
                                    frame: f.index,
                                    message: m,
                                })?;
                        push(&mut rows, f.index, f.t_s, c, r)?;
                        progress(f.index + 1, total);
                    }
                    Ok(None) => break,
                    // Keep what was read: write the tracks so far, then report the error.
                    Err(e) => {
                        writer.finish()?;
                        return Err(AnalyzeError::Input(format!(
                            "{e} (the {} frames read so far are in {})",
                            rows.len(),
                            tracks_path.display()
                        )));
                    }
                }
            }
        }
        Source::Tracks(_) => unreachable!("handled above"),
    }
    writer.finish()?;
    Ok(rows)
}

pub fn analyze(
    source: &Source,
    options: &AnalyzeOptions,
    out_dir: &Path,
    progress: &dyn Fn(usize, usize),
) -> Result<AnalyzeOutput, AnalyzeError> {
    std::fs::create_dir_all(out_dir).map_err(|e| {
        AnalyzeError::Input(format!(
            "{}: cannot create output directory: {e}",
            out_dir.display()
        ))
    })?;
    let tracks = track(source, options, out_dir, progress)?;
    let t: Vec<f64> = tracks.iter().map(|r| r.t_s).collect();
    let corners: Vec<Option<Corners>> = tracks.iter().map(|r| r.corners_px).collect();
    let reference: Vec<Option<Corners>> = tracks.iter().map(|r| r.reference_px).collect();
    let use_reference = reference.iter().any(Option::is_some)
        && options.estimator.reference_compensation
            != crate::estimate::config::ReferenceCompensation::Off;
    let estimate = estimate_track(
        &options.estimator,
        &t,
        &corners,
        use_reference.then_some(reference.as_slice()),
    )
    .map_err(|e| AnalyzeError::Estimate(e, tracks.len(), out_dir.join("tracks.csv")))?;
    let signals = relative_to_first_frame(&estimate, options.angle_sign);
    let kin = out_dir.join("kinematics.csv");
    write_kinematics_csv(&kin, &t, &signals, None)?;
    let plot = out_dir.join("measured.png");
    let pts = |v: &[f64]| t.iter().copied().zip(v.iter().copied()).collect::<Vec<_>>();
    let mut w = Vec::new();
    let mut a = Vec::new();
    for (name, color) in [("centre", SECOND), ("fused", MEASURED)] {
        if let Some(s) = signals.iter().find(|s| s.signal == name) {
            w.push(Series::points(name, pts(&s.omega2_rad_s), color));
            a.push(Series::points(name, pts(&s.alpha2_rad_s2), color));
        }
    }
    stacked_png(
        &plot,
        &[
            Panel {
                title: "omega2 (measured)".into(),
                x_label: "t (s)".into(),
                y_label: "omega2 (rad/s)".into(),
                series: w,
            },
            Panel {
                title: "alpha2 (measured)".into(),
                x_label: "t (s)".into(),
                y_label: "alpha2 (rad/s^2)".into(),
                series: a,
            },
        ],
        1200,
        450,
    )?;
    let mut files = vec![kin, plot];
    if !matches!(source, Source::Tracks(_)) {
        files.insert(0, out_dir.join("tracks.csv"));
    }
    Ok(AnalyzeOutput {
        estimate,
        signals,
        tracks,
        files,
    })
}
