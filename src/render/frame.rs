//! Frame rendering: samples the scene across each row's exposure, rasterises exactly, then
//! applies optical blur, lighting, noise, tone curve, sharpening, quantisation and compression to
//! give an 8-bit frame or any region of interest of it.
//!
//! Timing: `FrameRequest::t_s` is the centre of row 0's exposure (a frame's timestamp may mark
//! another instant: `timing::TimestampMark` converts); with rolling shutter row y is centred at
//! t_s + readout_s·y/height_px. Motion blur averages K samples at the midpoints of K
//! equal slices of the `exposure_s` window (K from the config, or automatic: the image travel
//! during the exposure — the largest vertex displacement of the scene, probed at rows 0, H/2 and
//! H−1 over four sub-intervals, plus the vibration's peak speed × exposure — divided by
//! `max_step_px`, so consecutive samples are ≤ 0.05 px apart by default). K is chosen per frame,
//! never per window.
//!
//! Region of interest: every stage is a pure function of absolute pixel position, so a window
//! is bit-identical to the same pixels of the full frame: the rasteriser is exact in integers,
//! blur and sharpening read fixed margins (kernel radii; the sharpening's margin is rendered
//! beyond the frame's edges too), noise is keyed by (seed, frame, x, y), and JPEG
//! blocks are aligned to the absolute 8-pixel grid (the window is grown to the grid, clipped to
//! the frame, compressed and cropped). Rows are processed in parallel with rayon; the result
//! does not depend on the thread count.
//!
//! Speed: each band of rows goes through rasterising, exposure averaging, blur, noise, tone
//! and quantisation while its buffers are in cache (`bands`, `tone`), and only the columns
//! some layer reaches are rasterised and blurred — the flat rest of a band is one constant.

mod bands;
mod tone;

use super::effects::camera_vibration::Vibration;
use super::effects::lighting::quantise;
use super::effects::sharpening::{self, SharpeningConfig};
use super::effects::{compression, motion_blur, optical_blur, EffectsConfig};
use super::image::{crop_buffer, GrayImage, LinearImage};
use super::raster::{ExposurePlan, PixelRect, PreparedSnapshot, RigidTransform};
use super::shapes::{SceneAt, SceneSnapshot};
use bands::{BandPipeline, BandScratch, BandValues, Samples, BAND_ROWS};
use rayon::prelude::*;
use std::sync::Mutex;
use tone::{ToneMap, ToneOut};

/// Buffers reused from frame to frame by [`render_frame_with`]: a pool of band buffers, one
/// per band being rendered at a time (about one per thread), so memory stays bounded by the
/// thread count even when a band's active columns span the whole frame.
#[derive(Debug, Default)]
pub struct FrameBuffers {
    pool: Mutex<Vec<BandScratch>>,
}

/// A band buffer borrowed from the pool, returned on drop (the contents never affect a result:
/// every stage overwrites what it reads).
struct Borrowed<'a> {
    pool: &'a Mutex<Vec<BandScratch>>,
    scratch: Option<BandScratch>,
}

impl FrameBuffers {
    fn borrow(&self) -> Borrowed<'_> {
        let scratch = self.pool.lock().ok().and_then(|mut p| p.pop());
        Borrowed {
            pool: &self.pool,
            scratch: Some(scratch.unwrap_or_default()),
        }
    }
}

impl Borrowed<'_> {
    fn get(&mut self) -> &mut BandScratch {
        self.scratch.get_or_insert_with(BandScratch::default)
    }
}

impl Drop for Borrowed<'_> {
    fn drop(&mut self) {
        // A buffer abandoned by a panic may break the rasteriser's all-zero accumulator
        // invariant: drop it instead of pooling it.
        if std::thread::panicking() {
            return;
        }
        if let (Some(s), Ok(mut pool)) = (self.scratch.take(), self.pool.lock()) {
            pool.push(s);
        }
    }
}

/// What every frame of a scenario shares.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    pub width_px: usize,
    pub height_px: usize,
    pub effects: EffectsConfig,
    /// Scenario seed (noise, random vibration).
    pub seed: u64,
}

/// One frame to render: its index (noise key), timestamp and the pixels wanted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameRequest {
    pub index: u64,
    /// Centre of row 0's exposure, seconds (not necessarily the frame's timestamp: see
    /// `timing::TimestampMark`).
    pub t_s: f64,
    /// Absolute pixel window wanted (clipped to the frame).
    pub window: PixelRect,
}

impl RenderSettings {
    pub fn frame_rect(&self) -> PixelRect {
        PixelRect::new(0, 0, self.width_px, self.height_px)
    }
}

/// Renders `frame.window ∩ frame` of the frame at `frame.t_s`. Frame sizes beyond JPEG's
/// 65535 px limit are returned uncompressed (the scenario validation rejects them).
pub fn render_frame(
    scene: &dyn SceneAt,
    settings: &RenderSettings,
    frame: &FrameRequest,
) -> GrayImage {
    render_frame_with(scene, settings, frame, &mut FrameBuffers::default())
}

/// [`render_frame`] reusing `buffers` (identical result).
pub fn render_frame_with(
    scene: &dyn SceneAt,
    settings: &RenderSettings,
    frame: &FrameRequest,
    buffers: &mut FrameBuffers,
) -> GrayImage {
    let frame_rect = settings.frame_rect();
    let window = frame.window.intersect(&frame_rect);
    let fx = &settings.effects;
    let jpeg_rect = if fx.compression.enabled {
        window.align_out(8).intersect(&frame_rect)
    } else {
        window
    };
    let mut pixels = vec![0u8; jpeg_rect.len()];
    if !jpeg_rect.is_empty() {
        let pipeline = band_pipeline(scene, settings, frame);
        let tone = ToneMap::new(
            fx,
            settings.seed,
            (frame.index, frame.t_s),
            settings.width_px,
            settings.height_px,
        );
        if fx.sharpening.active() {
            sharpened(
                &pipeline,
                &tone,
                &fx.sharpening,
                &jpeg_rect,
                buffers,
                &mut pixels,
            );
        } else {
            tone_mapped(&pipeline, &tone, &jpeg_rect, buffers, &mut pixels);
        }
    }
    if fx.compression.enabled && !jpeg_rect.is_empty() {
        if let Ok(p) = compression::jpeg_round_trip(
            &pixels,
            jpeg_rect.width,
            jpeg_rect.height,
            fx.compression.quality,
        ) {
            pixels = p;
        }
    }
    if jpeg_rect == window {
        return GrayImage {
            window,
            data: pixels,
        };
    }
    let (w, data) = crop_buffer(&pixels, &jpeg_rect, &window);
    GrayImage { window: w, data }
}

/// The tone-mapped pixels of `rect` into `out` (row-major over `rect`): 8-bit grey, or DN.
fn tone_mapped<O: ToneOut>(
    pipeline: &BandPipeline<'_>,
    tone: &ToneMap<'_>,
    rect: &PixelRect,
    buffers: &FrameBuffers,
    out: &mut [O],
) {
    render_bands(pipeline, rect, buffers, out, |v, r, y, o| {
        let (left, mid) = ((v.x0 - rect.x0) as usize, v.width);
        let (o_left, rest) = o.split_at_mut(left);
        let (o_mid, o_right) = rest.split_at_mut(mid);
        tone.constant_run(v.constant, rect.x0, y, o_left);
        tone.run(v.row(r), v.x0, y, o_mid);
        tone.constant_run(v.constant, v.x0 + mid as i64, y, o_right);
    });
}

/// The sharpened 8-bit pixels of `rect`: the tone-mapped DN of `rect` grown by the mask's
/// radius (beyond the frame's edges too, so a pixel's neighbourhood is the same in a window
/// and in the full frame), the mask's separable blur of them, then [`sharpening::sharpen`]
/// and quantisation.
fn sharpened(
    pipeline: &BandPipeline<'_>,
    tone: &ToneMap<'_>,
    mask: &SharpeningConfig,
    rect: &PixelRect,
    buffers: &FrameBuffers,
    out: &mut [u8],
) {
    let weights = mask.weights();
    let r = weights.len() / 2;
    let grown = rect.expand(r);
    let mut dn = vec![0.0f32; grown.len()];
    tone_mapped(pipeline, tone, &grown, buffers, &mut dn);
    let blurred = optical_blur::blur_separable(&dn, grown.width, grown.height, &weights);
    let amount = mask.amount as f32;
    out.par_chunks_mut(rect.width)
        .zip(blurred.par_chunks(rect.width))
        .enumerate()
        .for_each(|(y, (o, b))| {
            let row = &dn[(y + r) * grown.width + r..][..rect.width];
            for ((o, &v), &b) in o.iter_mut().zip(row).zip(b) {
                *o = quantise(sharpening::sharpen(v, b, amount));
            }
        });
}

/// Linear radiance of `rect` after motion blur, rolling shutter, vibration and optical blur.
pub fn render_linear(
    scene: &dyn SceneAt,
    settings: &RenderSettings,
    frame: &FrameRequest,
    rect: &PixelRect,
) -> LinearImage {
    let mut data = vec![0.0f32; rect.len()];
    if !rect.is_empty() {
        let pipeline = band_pipeline(scene, settings, frame);
        render_bands(
            &pipeline,
            rect,
            &FrameBuffers::default(),
            &mut data,
            |v, r, _, o| {
                let left = (v.x0 - rect.x0) as usize;
                o.fill(v.constant);
                o[left..left + v.width].copy_from_slice(v.row(r));
            },
        );
    }
    LinearImage {
        window: *rect,
        data,
    }
}

/// Renders the bands of `rect` in parallel and hands every output row to `write_row` with its
/// band's values, its row within the band and its absolute y; `out` is row-major over `rect`.
fn render_bands<T: Send>(
    pipeline: &BandPipeline<'_>,
    rect: &PixelRect,
    buffers: &FrameBuffers,
    out: &mut [T],
    write_row: impl Fn(&BandValues<'_>, usize, i64, &mut [T]) + Sync,
) {
    out.par_chunks_mut(rect.width * BAND_ROWS)
        .enumerate()
        .for_each_init(
            || buffers.borrow(),
            |scratch, (b, band_out)| {
                let band = rect.rows(rect.y0 + (b * BAND_ROWS) as i64, BAND_ROWS);
                let v = pipeline.render(&band, scratch.get());
                for (r, o) in band_out.chunks_exact_mut(rect.width).enumerate() {
                    write_row(&v, r, band.y0 + r as i64, o);
                }
            },
        );
}

/// The exposure samples (K from the scene's motion) and blur taps of one frame.
fn band_pipeline<'a>(
    scene: &'a dyn SceneAt,
    settings: &'a RenderSettings,
    frame: &FrameRequest,
) -> BandPipeline<'a> {
    let fx = &settings.effects;
    let vibration = Vibration::new(
        &fx.camera_vibration,
        settings.seed,
        settings.width_px,
        settings.height_px,
    );
    let exposure_s = fx.motion_blur.exposure_or_zero_s();
    let k = if exposure_s > 0.0 && fx.motion_blur.samples == 0 {
        fx.motion_blur.sample_count(image_travel_px(
            scene,
            settings,
            frame.t_s,
            exposure_s,
            vibration.as_ref(),
        ))
    } else {
        fx.motion_blur.sample_count(0.0)
    };
    let offsets = motion_blur::sample_offsets_s(exposure_s, k);
    let t_s = frame.t_s;
    let samples = if fx.rolling_shutter.enabled {
        Samples::Rolling(Box::new(move |y: i64, above: Option<&RowAnchor>| {
            let t_row = t_s + fx.rolling_shutter.row_delay_s(y, settings.height_px);
            let s = sample_scene(
                scene,
                vibration.as_ref(),
                offsets.iter().map(|o| t_row + o),
                false,
                above,
            );
            RowAnchor::split(s)
        }))
    } else {
        let s = sample_scene(
            scene,
            vibration.as_ref(),
            offsets.iter().map(|o| t_s + o),
            true,
            None,
        );
        let plan = ExposurePlan::new(&s.prepared, &s.scenes, &s.transforms);
        Samples::Global(s.prepared, plan)
    };
    let radius = fx.optical_blur.radius_px();
    let weights = if radius == 0 {
        Vec::new()
    } else {
        optical_blur::kernel(fx.optical_blur.sigma_px, radius)
    };
    BandPipeline { samples, weights }
}

/// The samples at `times`: their preparations, which share every layer shape that does not
/// change from the first sample (a static disc is converted once per frame, not once per
/// sample), their image transforms (camera vibration) and, when `keep_scenes`, the scene
/// snapshots themselves (only the first otherwise).
struct Sampled {
    scenes: Vec<SceneSnapshot>,
    transforms: Vec<Option<RigidTransform>>,
    prepared: Vec<PreparedSnapshot>,
}

/// The first exposure sample of a rolling-shutter row: the row below shares every layer shape
/// of it that its own samples leave unchanged (a static disc is converted once per band, not
/// once per row). Sharing reuses shapes equal to what a fresh conversion would give, so no
/// pixel changes.
pub(super) struct RowAnchor {
    scene: SceneSnapshot,
    transform: Option<RigidTransform>,
    prepared: PreparedSnapshot,
}

impl RowAnchor {
    /// A row's prepared samples, and its first sample as the anchor of the row below.
    fn split(s: Sampled) -> (Vec<PreparedSnapshot>, Option<Self>) {
        let anchor = match (
            s.scenes.into_iter().next(),
            s.transforms.first(),
            s.prepared.first(),
        ) {
            (Some(scene), Some(&transform), Some(prepared)) => Some(Self {
                scene,
                transform,
                prepared: prepared.clone(),
            }),
            _ => None,
        };
        (s.prepared, anchor)
    }
}

/// The samples at `times` (see [`Sampled`]); the first shares the unchanged shapes of
/// `above` (the previous row's first sample) when there is one under the same transform.
fn sample_scene(
    scene: &dyn SceneAt,
    vibration: Option<&Vibration>,
    times: impl Iterator<Item = f64>,
    keep_scenes: bool,
    above: Option<&RowAnchor>,
) -> Sampled {
    let mut sampled = Sampled {
        scenes: Vec::new(),
        transforms: Vec::new(),
        prepared: Vec::new(),
    };
    for t in times {
        let transform = vibration.map(|v| v.at(t));
        let snapshot = scene.snapshot(t);
        let earlier = match (
            sampled.scenes.first(),
            sampled.transforms.first(),
            sampled.prepared.first(),
        ) {
            (Some(s0), Some(tr0), Some(p0)) => Some((s0, tr0, p0)),
            _ => above.map(|a| (&a.scene, &a.transform, &a.prepared)),
        };
        let prepared = match earlier {
            Some((s0, tr0, p0)) if *tr0 == transform => {
                PreparedSnapshot::new_sharing(&snapshot, transform.as_ref(), s0, p0)
            }
            _ => PreparedSnapshot::new(&snapshot, transform.as_ref()),
        };
        if keep_scenes || sampled.scenes.is_empty() {
            sampled.scenes.push(snapshot);
        }
        sampled.transforms.push(transform);
        sampled.prepared.push(prepared);
    }
    sampled
}

/// Largest image distance (px) any scene vertex travels during the exposure of any row.
fn image_travel_px(
    scene: &dyn SceneAt,
    settings: &RenderSettings,
    t_s: f64,
    exposure_s: f64,
    vibration: Option<&Vibration>,
) -> f64 {
    let fx = &settings.effects;
    let h = settings.height_px as i64;
    let mut travel: f64 = 0.0;
    for row in [0, h / 2, (h - 1).max(0)] {
        let t0 = t_s + fx.rolling_shutter.row_delay_s(row, settings.height_px) - exposure_s / 2.0;
        let slices = 4;
        let snaps: Vec<SceneSnapshot> = (0..=slices)
            .map(|i| scene.snapshot(t0 + exposure_s * i as f64 / slices as f64))
            .collect();
        let mut path = 0.0;
        for pair in snaps.windows(2) {
            match max_vertex_shift_px(&pair[0], &pair[1]) {
                Some(d) => path += d,
                None => return f64::INFINITY, // topology changed: take the maximum K
            }
        }
        travel = travel.max(path);
    }
    travel + vibration.map_or(0.0, |v| v.max_speed_px_s() * exposure_s)
}

/// Largest displacement between corresponding vertices; `None` if the structures differ.
fn max_vertex_shift_px(a: &SceneSnapshot, b: &SceneSnapshot) -> Option<f64> {
    if a.layers.len() != b.layers.len() {
        return None;
    }
    let mut m: f64 = 0.0;
    for (la, lb) in a.layers.iter().zip(&b.layers) {
        if la.polygons.len() != lb.polygons.len() {
            return None;
        }
        for (pa, pb) in la.polygons.iter().zip(&lb.polygons) {
            if pa.vertices_px.len() != pb.vertices_px.len() {
                return None;
            }
            for (va, vb) in pa.vertices_px.iter().zip(&pb.vertices_px) {
                m = m.max(va.distance(*vb));
            }
        }
    }
    Some(m)
}

#[cfg(test)]
mod tests;
