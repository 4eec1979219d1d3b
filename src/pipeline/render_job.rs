//! `geneva render`: frames as PNG (or a video through ffmpeg) with `timestamps.csv` and the
//! truth at the frame times. Streams in chunks, parallel over frames; memory stays flat.

use super::rig::{Rig, RigError};
use crate::io::csv_out::{num, CsvWriter};
use crate::io::png_out::write_gray_png;
use crate::io::truth_csv::write_truth_csv;
use crate::render::independent::render_frame_independent;
use crate::render::{render_frame_with, FrameBuffers, FrameRequest, GrayImage, PixelRect};
use crate::scenario::Scenario;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum RenderJobError {
    #[error(transparent)]
    Rig(#[from] RigError),
    #[error("{dir}: cannot create output directory")]
    OutDir {
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error("frames {start}..{end}: {}", range_problem(*start, *end, *count))]
    Range {
        start: usize,
        end: usize,
        count: usize,
    },
    #[error(transparent)]
    Csv(#[from] crate::io::csv_out::CsvError),
    #[error(transparent)]
    Png(#[from] crate::io::png_out::PngError),
    #[error(transparent)]
    Video(#[from] crate::io::video_out::VideoOutError),
    #[error("frame {frame}: {source}")]
    Independent {
        frame: usize,
        source: crate::render::independent::IndependentRenderError,
    },
    #[error("--roi-margin cannot be used with the independent renderer (it draws whole frames)")]
    IndependentRoi,
    #[error(transparent)]
    Codec(#[from] crate::io::video_codec::CodecError),
    #[error(
        "--roi-margin cannot be used with effects.video_codec (the codec encodes whole frames)"
    )]
    CodecRoi,
}

/// Which renderer draws the frames.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Renderer {
    /// The project's renderer (`render::frame`): exact area coverage in linear radiance.
    #[default]
    Own,
    /// The second renderer (`render::independent`), for cross-renderer robustness checks.
    Independent,
}

/// What to render.
#[derive(Debug, Clone, Default)]
pub struct RenderJob {
    /// Frame range (default: all).
    pub frames: Option<std::ops::Range<usize>>,
    /// Render only a window around the marker (its bounding box grown by this margin, px).
    pub roi_margin_px: Option<usize>,
    /// Also (or instead of PNGs) write an MP4 with the variable timestamps.
    pub video: Option<PathBuf>,
    /// Write PNG files.
    pub png: bool,
    /// Which renderer draws the frames.
    pub renderer: Renderer,
}

#[derive(Debug, Clone)]
pub struct RenderSummary {
    pub frames: usize,
    pub files: Vec<PathBuf>,
}

fn range_problem(start: usize, end: usize, count: usize) -> String {
    if start >= end {
        format!(
            "holds no frame (the end is exclusive: {start}..{} is frame {start})",
            start + 1
        )
    } else {
        format!(
            "reaches past the last frame {} (the scenario has {count} frames, 0..{count})",
            count.saturating_sub(1)
        )
    }
}

pub fn frame_file_name(frame: usize) -> String {
    format!("frame_{frame:06}.png")
}

pub fn render_job(
    scenario: &Scenario,
    out_dir: &Path,
    job: &RenderJob,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<RenderSummary, RenderJobError> {
    let rig = Rig::new(scenario)?;
    if job.renderer == Renderer::Independent && job.roi_margin_px.is_some() {
        return Err(RenderJobError::IndependentRoi);
    }
    if scenario.effects.video_codec.enabled && job.roi_margin_px.is_some() {
        return Err(RenderJobError::CodecRoi);
    }
    std::fs::create_dir_all(out_dir).map_err(|source| RenderJobError::OutDir {
        dir: out_dir.into(),
        source,
    })?;
    let range = frame_range(&rig, job.frames.clone())?;
    let times = &rig.frame_times.as_slice()[range.clone()];
    let ts_path = out_dir.join("timestamps.csv");
    let mut ts = CsvWriter::create(&ts_path, &["frame", "t_s"])?;
    for (k, t) in times.iter().enumerate() {
        ts.row(&[(range.start + k).to_string(), num(*t)])?;
    }
    ts.finish()?;
    let truth_path = out_dir.join("truth.csv");
    write_truth_csv(
        &truth_path,
        &rig.mechanism.truth_rows(times),
        rig.mechanism.has_actual_motion(),
    )?;
    let mut files = vec![ts_path, truth_path];

    let scene = rig.animated();
    let full = rig.frame_rect();
    let window_for = |t_s: f64| -> PixelRect {
        match job.roi_margin_px {
            None => full,
            Some(m) => {
                let (x0, y0, x1, y1) = rig.marker_bbox_px(t_s);
                let (x0, y0) = (
                    (x0 - m as f64).floor() as i64,
                    (y0 - m as f64).floor() as i64,
                );
                let (x1, y1) = ((x1 + m as f64).ceil() as i64, (y1 + m as f64).ceil() as i64);
                PixelRect::new(
                    x0,
                    y0,
                    (x1 - x0 + 1).max(0) as usize,
                    (y1 - y0 + 1).max(0) as usize,
                )
                .intersect(&full)
            }
        }
    };
    let mut video = match &job.video {
        Some(path) => Some(crate::io::video_out::VideoWriter::create(
            path,
            rig.settings.width_px,
            rig.settings.height_px,
            times,
        )?),
        None => None,
    };
    let mut done = 0;
    let total = range.len();
    // Video frames are always whole frames.
    let whole = video.is_some();
    let window = |t_s: f64| if whole { full } else { window_for(t_s) };
    each_frame(
        &rig,
        &scene,
        range.clone(),
        job.renderer,
        &window,
        &mut |frame, img| {
            if job.png {
                let p = out_dir.join(frame_file_name(frame));
                write_gray_png(
                    &p,
                    img.window.width as u32,
                    img.window.height as u32,
                    &img.data,
                )?;
            }
            if let Some(v) = video.as_mut() {
                v.write_frame(&img.data)?;
            }
            done += 1;
            if done % CHUNK_FRAMES == 0 || done == total {
                progress(done, total);
            }
            Ok(())
        },
    )?;
    if let Some(v) = video.take() {
        files.push(v.finish()?);
    }
    Ok(RenderSummary {
        frames: range.end - range.start,
        files,
    })
}

/// Frames rendered at once: enough to keep every core busy, few enough that memory stays flat.
const CHUNK_FRAMES: usize = 16;

/// `frames` (default: all) checked against the rig's frame count.
fn frame_range(
    rig: &Rig,
    frames: Option<std::ops::Range<usize>>,
) -> Result<std::ops::Range<usize>, RenderJobError> {
    let count = rig.frame_times.len();
    let range = frames.unwrap_or(0..count);
    if range.start >= range.end || range.end > count {
        return Err(RenderJobError::Range {
            start: range.start,
            end: range.end,
            count,
        });
    }
    Ok(range)
}

/// Frame `i` of `rig` drawn by `renderer` in `window`; every frame's noise is keyed by its
/// index, so the images do not depend on the chunking or the thread count.
fn render_one(
    rig: &Rig,
    scene: &dyn crate::render::shapes::SceneAt,
    i: usize,
    renderer: Renderer,
    window: PixelRect,
    buffers: &mut FrameBuffers,
) -> Result<GrayImage, RenderJobError> {
    let t_s = rig.frame_times.as_slice()[i];
    let request = FrameRequest {
        index: i as u64,
        t_s: rig.render_time_s(t_s),
        window,
    };
    match renderer {
        Renderer::Own => Ok(render_frame_with(scene, &rig.settings, &request, buffers)),
        Renderer::Independent => {
            render_frame_independent(scene, &rig.settings, request.index, request.t_s)
                .map_err(|source| RenderJobError::Independent { frame: i, source })
        }
    }
}

/// Frames `range` of `rig` drawn by `renderer`, each in the window `window_for` gives at its
/// timestamp, handed to `sink` in frame order: rendered in parallel chunks, or, with a video
/// codec, whole frames through it ([`super::coded_frames`]).
fn each_frame(
    rig: &Rig,
    scene: &(dyn crate::render::shapes::SceneAt + Sync),
    range: std::ops::Range<usize>,
    renderer: Renderer,
    window_for: &(dyn Fn(f64) -> PixelRect + Sync),
    sink: &mut dyn FnMut(usize, GrayImage) -> Result<(), RenderJobError>,
) -> Result<(), RenderJobError> {
    if rig.scenario.effects.video_codec.enabled {
        let full = rig.frame_rect();
        let render = |i: usize, buffers: &mut FrameBuffers| {
            render_one(rig, scene, i, renderer, full, buffers).map(|img| img.data)
        };
        return super::coded_frames::through_codec(
            rig,
            &render,
            range,
            CHUNK_FRAMES,
            &mut |i, data| sink(i, GrayImage { window: full, data }),
        );
    }
    for start in range.clone().step_by(CHUNK_FRAMES) {
        let end = (start + CHUNK_FRAMES).min(range.end);
        let images: Vec<Result<GrayImage, RenderJobError>> = (start..end)
            .into_par_iter()
            .map_init(FrameBuffers::default, |buffers, i| {
                let window = window_for(rig.frame_times.as_slice()[i]);
                render_one(rig, scene, i, renderer, window, buffers)
            })
            .collect();
        for (k, img) in images.into_iter().enumerate() {
            sink(start + k, img?)?;
        }
    }
    Ok(())
}

/// Whole frames `frames` of `scenario`, handed to `sink` one by one in frame order: the pixels
/// `render_job` writes, for callers that want arrays rather than files (the Python module). At
/// most one chunk of frames is held here at a time. `progress(done, total)` counts frames.
pub fn render_each(
    scenario: &Scenario,
    frames: std::ops::Range<usize>,
    renderer: Renderer,
    progress: &(dyn Fn(usize, usize) + Sync),
    sink: &mut dyn FnMut(GrayImage),
) -> Result<(), RenderJobError> {
    let rig = Rig::new(scenario)?;
    let range = frame_range(&rig, Some(frames))?;
    let scene = rig.animated();
    let full = rig.frame_rect();
    let total = range.len();
    let mut done = 0;
    each_frame(&rig, &scene, range, renderer, &|_| full, &mut |_, image| {
        sink(image);
        done += 1;
        if done % CHUNK_FRAMES == 0 || done == total {
            progress(done, total);
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_errors_say_what_is_wrong() {
        let e = RenderJobError::Range {
            start: 5,
            end: 5,
            count: 60,
        }
        .to_string();
        assert!(
            e.contains("holds no frame") && !e.contains("outside"),
            "{e}"
        );
        let e = RenderJobError::Range {
            start: 50,
            end: 61,
            count: 60,
        }
        .to_string();
        assert!(e.contains("last frame 59") && e.contains("0..60"), "{e}");
    }

    #[test]
    fn the_independent_renderer_draws_whole_frames_and_refuses_a_window() {
        let mut s = crate::scenario::load_any("fast").unwrap();
        s.duration_s = 0.1;
        let dir = tempfile::tempdir().unwrap();
        let job = RenderJob {
            frames: Some(0..1),
            png: true,
            renderer: Renderer::Independent,
            ..RenderJob::default()
        };
        render_job(&s, dir.path(), &job, &|_, _| {}).unwrap();
        let img = crate::io::images::read_gray(&dir.path().join(frame_file_name(0))).unwrap();
        assert_eq!(
            (img.width as usize, img.height as usize),
            (s.camera.width_px as usize, s.camera.height_px as usize)
        );
        let roi = RenderJob {
            roi_margin_px: Some(8),
            ..job
        };
        let e = render_job(&s, dir.path(), &roi, &|_, _| {}).unwrap_err();
        assert!(matches!(e, RenderJobError::IndependentRoi), "{e}");
    }
}
