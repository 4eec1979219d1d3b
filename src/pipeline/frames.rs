//! Render → detect for every frame of a synthetic rig, streamed in chunks and parallel over
//! frames. Each frame renders only the window detection needs (exact: a window of a frame is
//! bit-identical to the same pixels of the full frame, and ROI detection returns the corners
//! full-frame detection would), falling back to the full frame when the window is not enough.
//!
//! Architecture invariant: results depend only on the frame index (per-frame noise streams,
//! exact ROI), so they are identical for any thread count and chunk size.

use super::rig::Rig;
use crate::detect::{
    corners_bbox_px, roi_exactness, roi_window, ArucoDetector, DetectError, DetectionPath,
    GrayView, RoiExactness,
};
use crate::io::tracks_csv::Corners;
use crate::render::{render_frame_with, FrameBuffers, FrameRequest, PixelRect};
use rayon::prelude::*;
use std::sync::Mutex;

/// How one frame was rendered and detected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FramePath {
    /// Only the detection window was rendered and detection ran in it.
    Roi,
    /// The whole frame was rendered and searched.
    FullFrame,
    /// The window was tried, then the whole frame (marker not found in the window).
    RoiThenFullFrame,
    /// No image: the scene's exact corners ([`crate::pipeline::run::CornerSource::Exact`]).
    Exact,
}

/// Detection result of one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameDetection {
    pub frame: usize,
    pub t_s: f64,
    pub corners_px: Option<Corners>,
    pub reference_px: Option<Corners>,
    pub path: FramePath,
}

#[derive(Debug, thiserror::Error)]
#[error("frame {frame} (t = {t_s:.4} s): detection failed")]
pub struct FrameError {
    pub frame: usize,
    pub t_s: f64,
    pub source: DetectError,
}

/// Why the frame loop stopped.
#[derive(Debug, thiserror::Error)]
pub enum FramesError {
    #[error("detector: {0}")]
    Detector(DetectError),
    #[error(transparent)]
    Frame(#[from] FrameError),
    /// The sink could not store a chunk (e.g. `tracks.csv` could not be written).
    #[error(transparent)]
    Output(#[from] crate::io::csv_out::CsvError),
    /// The scenario's video codec could not encode or decode the clip.
    #[error(transparent)]
    Codec(#[from] crate::io::video_codec::CodecError),
}

/// Options of the frame loop.
#[derive(Debug, Clone, Copy)]
pub struct FrameLoopOptions {
    /// Use the region of interest when the detector configuration allows it exactly.
    pub roi: bool,
    /// Frames per chunk handed to the thread pool (bounds memory).
    pub chunk_frames: usize,
}

impl Default for FrameLoopOptions {
    fn default() -> Self {
        Self {
            roi: true,
            chunk_frames: 32,
        }
    }
}

struct Worker {
    detector: ArucoDetector,
    buffers: FrameBuffers,
    /// A full-size frame into which windows are pasted; only pasted pixels are ever read.
    canvas: Vec<u8>,
    pasted: Vec<PixelRect>,
}

impl Worker {
    fn paste(&mut self, width: usize, window: &PixelRect, data: &[u8]) {
        for (k, src) in data.chunks_exact(window.width.max(1)).enumerate() {
            let start = (window.y0 as usize + k) * width + window.x0 as usize;
            self.canvas[start..start + window.width].copy_from_slice(src);
        }
        self.pasted.push(*window);
    }

    /// Blanks what earlier frames pasted, so no stale pixel can ever be read.
    fn clear(&mut self, width: usize) {
        for w in std::mem::take(&mut self.pasted) {
            for k in 0..w.height {
                let start = (w.y0 as usize + k) * width + w.x0 as usize;
                self.canvas[start..start + w.width].fill(0);
            }
        }
    }
}

/// Workers kept from one rayon split to the next, so a full-size canvas and the render buffers
/// are allocated about once per thread rather than once per split. A worker's state never
/// affects a result (the canvas is blanked before use, buffers are overwritten).
#[derive(Default)]
struct WorkerPool {
    idle: Mutex<Vec<Worker>>,
}

/// A worker taken from the pool (created on first use), returned on drop.
struct PooledWorker<'a> {
    pool: &'a WorkerPool,
    worker: Option<Worker>,
}

impl WorkerPool {
    fn borrow(&self) -> PooledWorker<'_> {
        let worker = self.idle.lock().ok().and_then(|mut idle| idle.pop());
        PooledWorker { pool: self, worker }
    }
}

impl PooledWorker<'_> {
    fn get(&mut self, create: impl FnOnce() -> Worker) -> &mut Worker {
        self.worker.get_or_insert_with(create)
    }
}

impl Drop for PooledWorker<'_> {
    fn drop(&mut self) {
        // A worker abandoned by a panic may hold half-pasted state: drop it instead.
        if std::thread::panicking() {
            return;
        }
        if let (Some(w), Ok(mut idle)) = (self.worker.take(), self.pool.idle.lock()) {
            idle.push(w);
        }
    }
}

/// The pixels ROI detection of `bbox` reads: its window plus the sub-pixel refinement window.
fn render_rect_for(rig: &Rig, bbox: (f64, f64, f64, f64)) -> Option<PixelRect> {
    let cfg = &rig.scenario.detector;
    let w = roi_window(cfg, bbox, rig.settings.width_px, rig.settings.height_px)?;
    let pad = (cfg.corner_refinement_win_size_px.max(0) as usize) + 2;
    let rect = PixelRect::new(
        w.x0_px as i64,
        w.y0_px as i64,
        w.width_px as usize,
        w.height_px as usize,
    );
    Some(rect.expand(pad).intersect(&rig.frame_rect()))
}

/// Looks at a frame after detection: the frame (a full-size view; only the pixels rendered for
/// the detection window are valid on the ROI path) and its detection.
pub type Inspector<'a, T> = dyn Fn(GrayView<'_>, &FrameDetection) -> T + Sync + 'a;

fn process_frame<T>(
    rig: &Rig,
    scene: &dyn crate::render::shapes::SceneAt,
    worker: &mut Worker,
    frame: usize,
    roi: bool,
    inspect: &Inspector<'_, T>,
) -> Result<(FrameDetection, T), FrameError> {
    let t_s = rig.frame_times.as_slice()[frame];
    let (w, h) = (rig.settings.width_px, rig.settings.height_px);
    let cfg = &rig.scenario.detector;
    let err = |source| FrameError { frame, t_s, source };
    let reference_bbox =
        if rig.scenario.scene.reference_marker.enabled && cfg.reference_marker_id.is_some() {
            rig.scene
                .reference_marker_corners_px()
                .map(|c| corners_bbox_px(&c))
        } else {
            None
        };
    let marker_bbox = rig.marker_bbox_px(t_s);
    let request = |window| FrameRequest {
        index: frame as u64,
        t_s: rig.render_time_s(t_s),
        window,
    };

    if roi && cfg.roi.enabled && roi_exactness(cfg) == RoiExactness::Exact {
        worker.clear(w);
        let rects: Vec<PixelRect> = [Some(marker_bbox), reference_bbox]
            .into_iter()
            .flatten()
            .filter_map(|b| render_rect_for(rig, b))
            .collect();
        for rect in &rects {
            let img = render_frame_with(scene, &rig.settings, &request(*rect), &mut worker.buffers);
            worker.paste(w, &img.window, &img.data);
        }
        let view = GrayView::full(&worker.canvas, w, h);
        let obs = worker
            .detector
            .detect_marker(view, cfg.marker_id, Some(marker_bbox))
            .map_err(err)?;
        let reference = match (cfg.reference_marker_id, reference_bbox) {
            (Some(id), Some(b)) => {
                let r = worker
                    .detector
                    .detect_marker(view, id, Some(b))
                    .map_err(err)?;
                matches!(r.path, DetectionPath::Roi)
                    .then_some(r.detection)
                    .flatten()
                    .map(|d| d.corners_px)
            }
            _ => None,
        };
        if matches!(obs.path, DetectionPath::Roi)
            && (reference_bbox.is_none() || reference.is_some())
        {
            let detection = FrameDetection {
                frame,
                t_s,
                corners_px: obs.detection.map(|d| d.corners_px),
                reference_px: reference,
                path: FramePath::Roi,
            };
            let seen = inspect(view, &detection);
            return Ok((detection, seen));
        }
        let (mut full, seen) = full_frame(rig, scene, worker, frame, inspect)?;
        full.path = FramePath::RoiThenFullFrame;
        return Ok((full, seen));
    }
    full_frame(rig, scene, worker, frame, inspect)
}

fn full_frame<T>(
    rig: &Rig,
    scene: &dyn crate::render::shapes::SceneAt,
    worker: &mut Worker,
    frame: usize,
    inspect: &Inspector<'_, T>,
) -> Result<(FrameDetection, T), FrameError> {
    let t_s = rig.frame_times.as_slice()[frame];
    let (w, h) = (rig.settings.width_px, rig.settings.height_px);
    let cfg = &rig.scenario.detector;
    let err = |source| FrameError { frame, t_s, source };
    let img = render_frame_with(
        scene,
        &rig.settings,
        &FrameRequest {
            index: frame as u64,
            t_s: rig.render_time_s(t_s),
            window: rig.frame_rect(),
        },
        &mut worker.buffers,
    );
    let view = GrayView::full(&img.data, w, h);
    let found = worker.detector.detect(view).map_err(err)?;
    let pick = |id: i32| found.iter().find(|d| d.id == id).map(|d| d.corners_px);
    let detection = FrameDetection {
        frame,
        t_s,
        corners_px: pick(cfg.marker_id),
        reference_px: cfg
            .reference_marker_id
            .filter(|_| rig.scenario.scene.reference_marker.enabled)
            .and_then(pick),
        path: FramePath::FullFrame,
    };
    let seen = inspect(view, &detection);
    Ok((detection, seen))
}

/// Runs render → detect over `frames`, calling `sink` with each chunk's results in frame order
/// (so the caller can stream them to disk) and `progress` with the number of frames done.
pub fn detect_frames(
    rig: &Rig,
    frames: std::ops::Range<usize>,
    options: FrameLoopOptions,
    mut sink: impl FnMut(&[FrameDetection]) -> Result<(), crate::io::csv_out::CsvError>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<(), FramesError> {
    detect_and_inspect_frames(
        rig,
        frames,
        options,
        &|_, _| (),
        |chunk| {
            let detections: Vec<FrameDetection> = chunk.iter().map(|(d, _)| d.clone()).collect();
            sink(&detections)
        },
        progress,
    )
}

/// [`detect_frames`] with an inspector that looks at every rendered frame after detection (in
/// parallel); `sink` receives each frame's detection with what the inspector returned.
pub fn detect_and_inspect_frames<T: Send>(
    rig: &Rig,
    frames: std::ops::Range<usize>,
    options: FrameLoopOptions,
    inspect: &Inspector<'_, T>,
    mut sink: impl FnMut(&[(FrameDetection, T)]) -> Result<(), crate::io::csv_out::CsvError>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<(), FramesError> {
    let detector = ArucoDetector::new(&rig.scenario.detector).map_err(FramesError::Detector)?;
    if rig.scenario.effects.video_codec.enabled {
        return detect_coded_frames(rig, &detector, frames, options, inspect, sink, progress);
    }
    let scene = rig.animated();
    let canvas_len = rig.settings.width_px * rig.settings.height_px;
    let chunk = options.chunk_frames.max(1);
    let pool = WorkerPool::default();
    let mut start = frames.start;
    let mut done = 0;
    while start < frames.end {
        let end = (start + chunk).min(frames.end);
        let results: Vec<Result<(FrameDetection, T), FrameError>> = (start..end)
            .into_par_iter()
            .map_init(
                || pool.borrow(),
                |worker, i| {
                    let worker = worker.get(|| Worker {
                        detector: detector.clone(),
                        buffers: FrameBuffers::default(),
                        canvas: vec![0; canvas_len],
                        pasted: Vec::new(),
                    });
                    process_frame(rig, &scene, worker, i, options.roi, inspect)
                },
            )
            .collect();
        let results: Vec<(FrameDetection, T)> = results.into_iter().collect::<Result<_, _>>()?;
        sink(&results)?;
        done += results.len();
        progress(done);
        start = end;
    }
    Ok(())
}

/// [`detect_and_inspect_frames`] for a scenario with a video codec: whole frames through the
/// codec ([`super::coded_frames`]), then detection on each decoded frame, in the window when the
/// options allow it (the detector falls back to the whole frame itself).
fn detect_coded_frames<T: Send>(
    rig: &Rig,
    detector: &ArucoDetector,
    frames: std::ops::Range<usize>,
    options: FrameLoopOptions,
    inspect: &Inspector<'_, T>,
    mut sink: impl FnMut(&[(FrameDetection, T)]) -> Result<(), crate::io::csv_out::CsvError>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<(), FramesError> {
    let scene = rig.animated();
    let chunk = options.chunk_frames.max(1);
    let render = |i: usize, buffers: &mut FrameBuffers| -> Result<Vec<u8>, FramesError> {
        let request = FrameRequest {
            index: i as u64,
            t_s: rig.render_time_s(rig.frame_times.as_slice()[i]),
            window: rig.frame_rect(),
        };
        Ok(render_frame_with(&scene, &rig.settings, &request, buffers).data)
    };
    let mut pending: Vec<(usize, Vec<u8>)> = Vec::with_capacity(chunk);
    let mut done = 0;
    let mut flush = |pending: &mut Vec<(usize, Vec<u8>)>| -> Result<(), FramesError> {
        let results: Vec<Result<(FrameDetection, T), FrameError>> = pending
            .par_iter()
            .map(|(i, data)| detect_decoded(rig, detector, *i, data, options.roi, inspect))
            .collect();
        let results: Vec<(FrameDetection, T)> = results.into_iter().collect::<Result<_, _>>()?;
        sink(&results)?;
        done += results.len();
        progress(done);
        pending.clear();
        Ok(())
    };
    super::coded_frames::through_codec(rig, &render, frames, chunk, &mut |i, data| {
        pending.push((i, data));
        if pending.len() == chunk {
            flush(&mut pending)?;
        }
        Ok(())
    })?;
    flush(&mut pending)
}

/// Detection in one decoded frame (valid everywhere: every pixel was decoded).
fn detect_decoded<T>(
    rig: &Rig,
    detector: &ArucoDetector,
    frame: usize,
    data: &[u8],
    roi: bool,
    inspect: &Inspector<'_, T>,
) -> Result<(FrameDetection, T), FrameError> {
    let t_s = rig.frame_times.as_slice()[frame];
    let cfg = &rig.scenario.detector;
    let err = |source| FrameError { frame, t_s, source };
    let view = GrayView::full(data, rig.settings.width_px, rig.settings.height_px);
    let hint = |bbox| (roi && cfg.roi.enabled).then_some(bbox);
    let obs = detector
        .detect_marker(view, cfg.marker_id, hint(rig.marker_bbox_px(t_s)))
        .map_err(err)?;
    let reference = match cfg.reference_marker_id {
        Some(id) if rig.scenario.scene.reference_marker.enabled => {
            let bbox = rig
                .scene
                .reference_marker_corners_px()
                .map(|c| corners_bbox_px(&c));
            detector
                .detect_marker(view, id, bbox.and_then(hint))
                .map_err(err)?
                .detection
                .map(|d| d.corners_px)
        }
        _ => None,
    };
    let detection = FrameDetection {
        frame,
        t_s,
        corners_px: obs.detection.map(|d| d.corners_px),
        reference_px: reference,
        path: match obs.path {
            DetectionPath::Roi => FramePath::Roi,
            DetectionPath::FullFrame => FramePath::FullFrame,
            DetectionPath::RoiFallback(_) => FramePath::RoiThenFullFrame,
        },
    };
    let seen = inspect(view, &detection);
    Ok((detection, seen))
}
