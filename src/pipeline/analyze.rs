//! `geneva analyze`: the same measurement pipeline on real data — a video, a folder of frames
//! with timestamps, or an existing corner track. Detection runs on whole frames until the marker
//! is found, then in a window around its last position (exact: same corners as full-frame
//! detection, with fallback), sequentially since each frame predicts the next.
//!
//! Input integrity: frames keep the numbers the input gives them; a frame that cannot be used
//! (unreadable file, another size or pixel format than the sequence, a video frame ffmpeg would
//! rescale) is recorded as missing and listed with its reason, never searched; frame numbers
//! absent from a track and a video cut short are counted and reported (`InputReport`).

use super::error_bars::ErrorBars;
use super::measure::estimate_track;
use crate::budget::error_bars::feature_flags;
use crate::detect::{corners_bbox_px, ArucoDetector, DetectError, DetectorConfig, GrayView};
use crate::estimate::measured::relative_to_first_frame;
use crate::estimate::{Estimate, EstimatorConfig, MeasuredSignal};
use crate::io::csv_out::CsvWriter;
use crate::io::images::{read_gray, read_header, ImageError, ImageHeader};
use crate::io::kinematics_csv::write_kinematics_csv;
use crate::io::kinematics_csv::BarColumns;
use crate::io::timing_log::{read_frame_timestamps, TimingLogError};
use crate::io::tracks_csv::{
    frame_gaps, read_tracks, Corners, TrackRow, TracksReadError, TracksWriter,
};
use crate::io::video::{Truncation, VideoError};
use crate::plot::{stacked_png, Panel, Series, MEASURED, SECOND, THIRD, TRUTH};
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

impl AnalyzeOptions {
    /// The detector and estimator `scenario` states, with `angle_sign` (see the field).
    pub fn from_scenario(scenario: &crate::scenario::Scenario, angle_sign: f64) -> Self {
        Self {
            detector: scenario.detector.clone(),
            estimator: scenario.estimator.clone(),
            angle_sign,
        }
    }
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
    #[error("{dir}: cannot create output directory")]
    OutDir {
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error(transparent)]
    Image(#[from] ImageError),
    #[error(transparent)]
    Timestamps(#[from] TimingLogError),
    #[error(transparent)]
    Tracks(#[from] TracksReadError),
    #[error(transparent)]
    Video(#[from] VideoError),
    #[error("{dir}: no PNG or JPEG files")]
    NoFrames { dir: PathBuf },
    #[error("{dir} holds {files} image files but {timestamps} has {times} timestamps")]
    FrameCount {
        dir: PathBuf,
        files: usize,
        timestamps: PathBuf,
        times: usize,
    },
    #[error("detector: {0}")]
    Detector(DetectError),
    #[error("{file}: frame {frame}: detection failed")]
    Detect {
        file: PathBuf,
        frame: usize,
        source: DetectError,
    },
    #[error("stopped after {frames} frames (the frames read so far are in {tracks})")]
    Interrupted {
        source: VideoError,
        frames: usize,
        tracks: PathBuf,
    },
    #[error("{file}: {absent} frame numbers are absent between its {rows} rows (largest gap {gap_start}–{gap_end}); at most {limit} may be")]
    TooManyAbsent {
        file: PathBuf,
        absent: usize,
        rows: usize,
        gap_start: usize,
        gap_end: usize,
        limit: usize,
    },
    // No path in the text: the command may have written the tracks into a staging folder that
    // is renamed (or removed) afterwards; it names their final place itself.
    #[error("estimation failed ({frames} frames read)")]
    Estimate {
        source: crate::estimate::EstimateError,
        frames: usize,
        tracks: PathBuf,
    },
    #[error(transparent)]
    Csv(#[from] crate::io::csv_out::CsvError),
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    #[error(transparent)]
    File(#[from] crate::errors::FileError),
}

/// A frame that exists in the input but was not searched: it is recorded as missing (empty
/// corners in `tracks.csv`) and listed in `unreadable_frames.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct UnreadableFrame {
    pub frame: usize,
    /// The file (image, or the video) it comes from.
    pub file: PathBuf,
    pub reason: String,
}

/// What the input held besides the frames that were analysed: frames present but unusable,
/// frame numbers absent from a track, a video cut short.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InputReport {
    /// Frame numbers of the first and last frame of the input.
    pub first_frame: usize,
    pub last_frame: usize,
    /// Frames the input holds (track rows, image files, decoded video frames).
    pub frames_present: usize,
    pub unreadable: Vec<UnreadableFrame>,
    /// Runs of frame numbers absent from a track.
    pub gaps: Vec<std::ops::RangeInclusive<usize>>,
    /// Set when a video's container promises more than decodes.
    pub truncation: Option<Truncation>,
    /// Set when a track's frame numbers and times tell different stories (the times are the
    /// time base; the numbers only label the rows).
    pub numbering: Option<NumberingMismatch>,
    /// Width and height of the frames, px (unknown for a track).
    pub frame_size_px: Option<[usize; 2]>,
}

/// Where a track's frame numbers disagree with its times: numbers that skip frames the times
/// have no room for (`frame 2, 4, 6 …` at one frame interval apart), or numbers that never step
/// by one, so that no frame interval can be read off them. The analysis and the diagnosis use
/// the times; this is said so that a track whose numbers were rewritten is noticed.
#[derive(Debug, Clone, PartialEq)]
pub struct NumberingMismatch {
    /// Steps between rows whose number skips frames the time step has no room for.
    pub steps: usize,
    /// The first such step: (frame number, next frame number, seconds between them).
    pub first: (usize, usize, f64),
    /// The median time step of rows whose numbers are consecutive, s (`None`: no such rows).
    pub frame_interval_s: Option<f64>,
    /// The median step of the frame numbers.
    pub median_number_step: usize,
}

impl std::fmt::Display for NumberingMismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (a, b, dt) = self.first;
        match self.frame_interval_s {
            Some(h) => write!(
                f,
                "the frame numbers and times disagree at {} step(s), first frame {a} → {b}: the \
                 numbers skip {} frame(s) but the times are {:.2} ms apart, {:.2} frame intervals \
                 of {:.2} ms; the times are the time base, the numbers only label the rows",
                self.steps,
                b - a - 1,
                dt * 1e3,
                dt / h,
                h * 1e3
            ),
            None => write!(
                f,
                "no two rows have consecutive frame numbers (they step by {} at the median, \
                 first frame {a} → {b}, {:.2} ms apart): no frame interval can be read off the \
                 numbers; the times are the time base, the numbers only label the rows",
                self.median_number_step,
                dt * 1e3
            ),
        }
    }
}

/// Whether the rows' frame numbers and times disagree (see [`NumberingMismatch`]). A time step
/// longer than its numbers say (a variable frame rate, a dropped frame the numbering did not
/// count) is no disagreement: phones do that.
pub fn numbering_mismatch(rows: &[TrackRow]) -> Option<NumberingMismatch> {
    let steps: Vec<(usize, usize, f64)> = rows
        .windows(2)
        .filter(|w| w[1].frame > w[0].frame)
        .map(|w| (w[0].frame, w[1].frame, w[1].t_s - w[0].t_s))
        .collect();
    if steps.len() < 2 {
        return None;
    }
    let number_steps: Vec<f64> = steps.iter().map(|(a, b, _)| (b - a) as f64).collect();
    let median_number_step = crate::numeric::robust::median(&number_steps) as usize;
    let consecutive: Vec<f64> = steps
        .iter()
        .filter(|(a, b, _)| b - a == 1)
        .map(|s| s.2)
        .collect();
    if consecutive.is_empty() {
        return Some(NumberingMismatch {
            steps: steps.len(),
            first: steps[0],
            frame_interval_s: None,
            median_number_step,
        });
    }
    let h = crate::numeric::robust::median(&consecutive);
    let bad: Vec<&(usize, usize, f64)> = steps
        .iter()
        .filter(|(a, b, dt)| b - a > 1 && *dt < ((b - a) as f64 - 0.5) * h)
        .collect();
    let first = **bad.first()?;
    Some(NumberingMismatch {
        steps: bad.len(),
        first,
        frame_interval_s: Some(h),
        median_number_step,
    })
}

impl InputReport {
    /// Frame numbers absent from a track, summed over its gaps.
    pub fn absent(&self) -> usize {
        self.gaps.iter().map(|g| g.end() - g.start() + 1).sum()
    }

    /// Frames a truncated video's container lists beyond the decodable ones (when it states a
    /// count).
    pub fn lost_to_truncation(&self) -> Option<usize> {
        let t = self.truncation.as_ref()?;
        t.container_frames.map(|n| n.saturating_sub(t.decoded))
    }
}

#[derive(Debug, Clone)]
pub struct AnalyzeOutput {
    /// Per frame of the input's numbering: the rows of `tracks` and a placeholder (no corners)
    /// for each frame number absent from a track ([`AnalyzeOutput::estimate_at_rows`] has
    /// them taken out).
    pub estimate: Estimate,
    pub signals: Vec<MeasuredSignal>,
    pub tracks: Vec<TrackRow>,
    pub input: InputReport,
    pub files: Vec<PathBuf>,
}

impl AnalyzeOutput {
    /// The estimate at the rows of `tracks` only, in their order: its k-th value belongs to the
    /// k-th row and that row's time. (`estimate` also holds the placeholders of frame numbers
    /// absent from a track; pairing it with the rows by position put every value of a track
    /// with every other row missing at another row's time.) The values are those of
    /// `estimate`: a placeholder has no corners, so it changed no derivative.
    pub fn estimate_at_rows(&self) -> Estimate {
        let keep: Vec<bool> = with_placeholders(&self.tracks)
            .into_iter()
            .map(|(_, real)| real)
            .collect();
        select_frames(&self.estimate, &keep)
    }

    /// The rows [`AnalyzeOutput::signals`] are sampled at: time (s), frame number, and whether
    /// the frame is in the input (false for a placeholder of an absent frame number, whose time
    /// is interpolated and whose values are NaN).
    pub fn sample_rows(&self) -> Vec<(f64, usize, bool)> {
        with_placeholders(&self.tracks)
            .into_iter()
            .map(|(row, real)| (row.t_s, row.frame, real))
            .collect()
    }
}

/// `e` at the frames whose `keep` is true (every per-frame series, the counts recomputed).
fn select_frames(e: &Estimate, keep: &[bool]) -> Estimate {
    if keep.len() != e.frames || keep.iter().all(|k| *k) {
        return e.clone();
    }
    fn pick<T: Clone>(v: &[T], keep: &[bool]) -> Vec<T> {
        v.iter()
            .zip(keep)
            .filter(|(_, k)| **k)
            .map(|(x, _)| x.clone())
            .collect()
    }
    let marker_centre_px = pick(&e.marker_centre_px, keep);
    let frames = marker_centre_px.len();
    let detected = marker_centre_px.iter().filter(|c| c.is_some()).count();
    Estimate {
        rotation_centre: e.rotation_centre.clone(),
        signals: e
            .signals
            .iter()
            .map(|s| crate::estimate::SignalSeries {
                signal: s.signal,
                theta_rad: pick(&s.theta_rad, keep),
                omega_rad_s: pick(&s.omega_rad_s, keep),
                alpha_rad_s2: pick(&s.alpha_rad_s2, keep),
                differentiator: s.differentiator.clone(),
            })
            .collect(),
        primary: e.primary,
        marker_centre_px,
        t_used_s: pick(&e.t_used_s, keep),
        frames,
        detected,
        missing: frames - detected,
        missing_reference: e.missing_reference,
    }
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
    ) -> Result<(Option<Corners>, Option<Corners>), DetectError> {
        let view = GrayView::full(data, w, h);
        let m = self.detector.detect_marker(
            view,
            self.marker_id,
            self.last.as_ref().map(corners_bbox_px),
        )?;
        let corners = m.detection.map(|d| d.corners_px);
        let reference = match self.reference_id {
            Some(id) => self
                .detector
                .detect_marker(view, id, self.last_reference.as_ref().map(corners_bbox_px))?
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

/// A track may miss at most this many frame numbers per row it holds, plus a constant: the
/// analysis fills absent frames with placeholders, so the bound keeps memory proportional to
/// the file.
const ABSENT_PER_ROW: usize = 10;
const ABSENT_EXTRA: usize = 10_000;

/// The header most frames share (most frequent; ties go to the earliest frame).
fn sequence_header(headers: &[Result<ImageHeader, ImageError>]) -> Option<ImageHeader> {
    let mut counts: Vec<(ImageHeader, usize)> = Vec::new();
    for h in headers.iter().flatten() {
        match counts.iter_mut().find(|(x, _)| x == h) {
            Some((_, n)) => *n += 1,
            None => counts.push((*h, 1)),
        }
    }
    // `max_by_key` keeps the last maximum; reversed, that is the earliest header seen.
    counts
        .into_iter()
        .rev()
        .max_by_key(|(_, n)| *n)
        .map(|(h, _)| h)
}

/// Why `header` cannot be used in a sequence of `expected` frames, if it cannot.
fn header_mismatch(header: &ImageHeader, expected: &ImageHeader) -> Option<String> {
    if (header.width, header.height) != (expected.width, expected.height) {
        Some(format!(
            "{}x{} px, the sequence's frames are {}x{} px",
            header.width, header.height, expected.width, expected.height
        ))
    } else if header.format != expected.format {
        Some(format!(
            "{}, the sequence's frames are {}",
            header.format, expected.format
        ))
    } else {
        None
    }
}

/// Detects the marker in every frame of `source` (or reads the track) and writes tracks.csv.
fn track(
    source: &Source,
    options: &AnalyzeOptions,
    out_dir: &Path,
    progress: &dyn Fn(usize, usize),
) -> Result<(Vec<TrackRow>, InputReport), AnalyzeError> {
    if let Source::Tracks(path) = source {
        let rows = read_tracks(path, Some(options.detector.marker_id))?;
        let gaps = frame_gaps(&rows);
        let report = InputReport {
            first_frame: rows.first().map_or(0, |r| r.frame),
            last_frame: rows.last().map_or(0, |r| r.frame),
            frames_present: rows.len(),
            gaps,
            numbering: numbering_mismatch(&rows),
            ..InputReport::default()
        };
        let limit = ABSENT_PER_ROW * rows.len() + ABSENT_EXTRA;
        if report.absent() > limit {
            let widest = report
                .gaps
                .iter()
                .max_by_key(|g| g.end() - g.start())
                .cloned()
                .unwrap_or(0..=0);
            return Err(AnalyzeError::TooManyAbsent {
                file: path.clone(),
                absent: report.absent(),
                rows: rows.len(),
                gap_start: *widest.start(),
                gap_end: *widest.end(),
                limit,
            });
        }
        return Ok((rows, report));
    }
    let detector = ArucoDetector::new(&options.detector).map_err(AnalyzeError::Detector)?;
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
    let mut report = InputReport::default();
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
            let files = crate::io::images::list_image_files(dir)?;
            if files.is_empty() {
                return Err(AnalyzeError::NoFrames { dir: dir.clone() });
            }
            let (first_frame, times) = read_frame_timestamps(timestamps, None)?;
            if files.len() != times.len() {
                return Err(AnalyzeError::FrameCount {
                    dir: dir.clone(),
                    files: files.len(),
                    timestamps: timestamps.clone(),
                    times: times.len(),
                });
            }
            // Headers first (cheap): the sequence's size and pixel format are those most frames
            // share, so one foreign frame anywhere is recognised as such.
            let headers: Vec<Result<ImageHeader, ImageError>> =
                files.iter().map(|f| read_header(f)).collect();
            let expected = sequence_header(&headers);
            report.frame_size_px = expected.as_ref().map(|h| [h.width, h.height]);
            for (i, ((file, t), header)) in
                files.iter().zip(times.as_slice()).zip(&headers).enumerate()
            {
                let frame = first_frame + i;
                let image = match (header, &expected) {
                    (Err(e), _) => Err(e.reason()),
                    (Ok(h), Some(x)) => match header_mismatch(h, x) {
                        Some(why) => Err(why),
                        None => read_gray(file).map_err(|e| e.reason()),
                    },
                    (Ok(_), None) => read_gray(file).map_err(|e| e.reason()),
                };
                match image {
                    Ok(img) => {
                        let (c, r) = tracker.observe(&img.data, img.width, img.height).map_err(
                            |source| AnalyzeError::Detect {
                                file: file.clone(),
                                frame,
                                source,
                            },
                        )?;
                        push(&mut rows, frame, *t, c, r)?;
                    }
                    Err(reason) => {
                        report.unreadable.push(UnreadableFrame {
                            frame,
                            file: file.clone(),
                            reason,
                        });
                        push(&mut rows, frame, *t, None, None)?;
                    }
                }
                progress(i + 1, files.len());
            }
        }
        Source::Video(path) => {
            let mut frames = crate::io::video::VideoFrames::open(path)?;
            let (w, h, total) = (
                frames.info().width_px,
                frames.info().height_px,
                frames.info().frame_count(),
            );
            report.truncation = frames.info().truncation();
            report.frame_size_px = Some([w, h]);
            let odd = frames.info().odd_frames.clone();
            loop {
                match frames.next_frame() {
                    Ok(Some(f)) => {
                        match odd.iter().find(|(k, _)| *k == f.index) {
                            Some((_, why)) => {
                                report.unreadable.push(UnreadableFrame {
                                    frame: f.index,
                                    file: path.clone(),
                                    reason: why.clone(),
                                });
                                push(&mut rows, f.index, f.t_s, None, None)?;
                            }
                            None => {
                                let (c, r) = tracker.observe(&f.data, w, h).map_err(|source| {
                                    AnalyzeError::Detect {
                                        file: path.clone(),
                                        frame: f.index,
                                        source,
                                    }
                                })?;
                                push(&mut rows, f.index, f.t_s, c, r)?;
                            }
                        }
                        progress(f.index + 1, total);
                    }
                    Ok(None) => break,
                    // Keep what was read: write the tracks so far, then report the error.
                    Err(source) => {
                        writer.finish()?;
                        return Err(AnalyzeError::Interrupted {
                            source,
                            frames: rows.len(),
                            tracks: tracks_path,
                        });
                    }
                }
            }
        }
        // Infallible: a tracks file returned from this function before the frame loop.
        Source::Tracks(_) => unreachable!("handled above"),
    }
    writer.finish()?;
    report.first_frame = rows.first().map_or(0, |r| r.frame);
    report.last_frame = rows.last().map_or(0, |r| r.frame);
    report.frames_present = rows.len();
    Ok((rows, report))
}

/// The rows with placeholders (no corners, time interpolated between its neighbours) for the
/// frame numbers absent from a track, so that the estimator counts them as missing and a
/// constant-rate timebase numbers frames as the input does. The flag is true for real rows.
pub(crate) fn with_placeholders(rows: &[TrackRow]) -> Vec<(TrackRow, bool)> {
    let mut out = Vec::with_capacity(rows.len());
    for (k, row) in rows.iter().enumerate() {
        if let Some(prev) = k.checked_sub(1).map(|j| &rows[j]) {
            let span = (row.frame - prev.frame) as f64;
            for frame in prev.frame + 1..row.frame {
                let u = (frame - prev.frame) as f64 / span;
                let placeholder = TrackRow {
                    frame,
                    t_s: prev.t_s + u * (row.t_s - prev.t_s),
                    marker_id: row.marker_id,
                    corners_px: None,
                    reference_px: None,
                };
                out.push((placeholder, false));
            }
        }
        out.push((row.clone(), true));
    }
    out
}

pub fn analyze(
    source: &Source,
    options: &AnalyzeOptions,
    out_dir: &Path,
    progress: &dyn Fn(usize, usize),
) -> Result<AnalyzeOutput, AnalyzeError> {
    std::fs::create_dir_all(out_dir).map_err(|source| AnalyzeError::OutDir {
        dir: out_dir.into(),
        source,
    })?;
    let (tracks, input) = track(source, options, out_dir, progress)?;
    let tracks_file = match source {
        Source::Tracks(path) => path.clone(),
        _ => out_dir.join("tracks.csv"),
    };
    let filled = with_placeholders(&tracks);
    let t: Vec<f64> = filled.iter().map(|(r, _)| r.t_s).collect();
    let corners: Vec<Option<Corners>> = filled.iter().map(|(r, _)| r.corners_px).collect();
    let reference: Vec<Option<Corners>> = filled.iter().map(|(r, _)| r.reference_px).collect();
    let use_reference = reference.iter().any(Option::is_some)
        && options.estimator.reference_compensation
            != crate::estimate::config::ReferenceCompensation::Off;
    let estimate = estimate_track(
        &options.estimator,
        &t,
        &corners,
        use_reference.then_some(reference.as_slice()),
    )
    .map_err(|source| AnalyzeError::Estimate {
        source,
        frames: tracks.len(),
        tracks: tracks_file,
    })?;
    let signals = relative_to_first_frame(&estimate, options.angle_sign);
    let [kin, plot] = write_measured(out_dir, &tracks, &signals, None)?;
    let mut files = vec![kin, plot];
    if !matches!(source, Source::Tracks(_)) {
        files.insert(0, out_dir.join("tracks.csv"));
    }
    if !input.unreadable.is_empty() {
        let path = out_dir.join("unreadable_frames.csv");
        write_unreadable(&path, &input.unreadable)?;
        files.push(path);
    }
    // A video cut short is recorded beside the results, not only said on the terminal.
    if let Some(t) = &input.truncation {
        let path = out_dir.join("truncated_video.txt");
        let lost = input
            .lost_to_truncation()
            .map(|n| format!("{n} frames lost; "))
            .unwrap_or_default();
        let text = format!(
            "truncated video: {t}\n{lost}the analysis covers the {} frames that decode\n",
            t.decoded
        );
        std::fs::write(&path, text).map_err(crate::errors::FileError::io(&path))?;
        files.push(path);
    }
    Ok(AnalyzeOutput {
        estimate,
        signals,
        tracks,
        input,
        files,
    })
}

/// `kinematics.csv` and `measured.png` of an analysis (over `tracks` with placeholders for the
/// absent frame numbers, as [`AnalyzeOutput::signals`]), with the error bars when there are
/// some: σ columns and flags in the table, σ bands and the flagged frames in the plot.
pub fn write_measured(
    out_dir: &Path,
    tracks: &[TrackRow],
    signals: &[MeasuredSignal],
    bars: Option<&ErrorBars>,
) -> Result<[PathBuf; 2], AnalyzeError> {
    let filled = with_placeholders(tracks);
    let t: Vec<f64> = filled.iter().map(|(r, _)| r.t_s).collect();
    let numbers: Vec<Option<usize>> = filled
        .iter()
        .map(|(r, real)| real.then_some(r.frame))
        .collect();
    let columns: Option<Vec<BarColumns>> = bars.map(|b| {
        signals
            .iter()
            .filter_map(|s| {
                let bars = b.signal(&s.signal)?;
                let flags = feature_flags(bars, &s.omega2_rad_s, &s.alpha2_rad_s2, b.k_sigma);
                Some(BarColumns { bars, flags })
            })
            .collect()
    });
    let kin = out_dir.join("kinematics.csv");
    write_kinematics_csv(&kin, &t, signals, None, Some(&numbers), columns.as_deref())?;
    let plot = out_dir.join("measured.png");
    let pts = |v: &[f64]| t.iter().copied().zip(v.iter().copied()).collect::<Vec<_>>();
    let mut panels = [(1, "omega2", "rad/s"), (2, "alpha2", "rad/s^2")].map(|(q, name, unit)| {
        let mut series = Vec::new();
        for (signal, color) in [("centre", SECOND), ("fused", MEASURED)] {
            if let Some(s) = signals.iter().find(|s| s.signal == signal) {
                let v = if q == 1 {
                    &s.omega2_rad_s
                } else {
                    &s.alpha2_rad_s2
                };
                series.push(Series::points(signal, pts(v), color));
            }
        }
        Panel {
            title: format!("{name} (measured)"),
            x_label: "t (s)".into(),
            y_label: format!("{name} ({unit})"),
            series,
        }
    });
    if let (Some(b), Some(cols)) = (bars, &columns) {
        let fused = signals.iter().find(|s| s.signal == "fused");
        let col = cols.iter().find(|c| c.bars.signal == "fused");
        if let (Some(s), Some(c)) = (fused, col) {
            for (panel, q) in panels.iter_mut().zip([1, 2]) {
                let v = if q == 1 {
                    &s.omega2_rad_s
                } else {
                    &s.alpha2_rad_s2
                };
                let band = |k: f64| -> Vec<f64> {
                    v.iter()
                        .zip(&c.bars.sigma[q])
                        .map(|(m, s)| m + k * s)
                        .collect()
                };
                panel.title = format!(
                    "{} (measured, fused ± 1 σ over {} simulated seeds; {}: beyond {} σ of the modelled motion)",
                    if q == 1 { "omega2" } else { "alpha2" },
                    b.seeds.len(),
                    if q == 1 { "jumps" } else { "values" },
                    b.k_sigma
                );
                panel
                    .series
                    .push(Series::line("fused + σ", pts(&band(1.0)), THIRD));
                panel
                    .series
                    .push(Series::line("fused − σ", pts(&band(-1.0)), THIRD));
                let flags = &c.flags[if q == 1 { 1 } else { 0 }];
                let flagged: Vec<f64> = v
                    .iter()
                    .zip(flags)
                    .map(|(m, f)| if *f == Some(true) { *m } else { f64::NAN })
                    .collect();
                panel
                    .series
                    .push(Series::points("beyond k σ", pts(&flagged), TRUTH));
            }
        }
    }
    stacked_png(&plot, &panels, 1200, 450)?;
    Ok([kin, plot])
}

/// `unreadable_frames.csv`: frame, file, reason (quoted: reasons hold commas).
fn write_unreadable(path: &Path, frames: &[UnreadableFrame]) -> Result<(), AnalyzeError> {
    let quote = |s: &str| format!("\"{}\"", s.replace('"', "\"\""));
    let mut w = CsvWriter::create(path, &["frame", "file", "reason"])?;
    for f in frames {
        w.row(&[
            f.frame.to_string(),
            quote(&f.file.display().to_string()),
            quote(&f.reason),
        ])?;
    }
    w.finish()?;
    Ok(())
}
