//! `geneva calibrate`: footage in, a scenario that reproduces it out. Reads the frames once
//! (video through ffmpeg, or a folder of images with a timestamps file), detects the marker
//! (whole frame until found, then in a window around its last position), measures each frame
//! with [`crate::imagestats`] (levels on every frame, edge fits on up to [`EDGE_FRAMES`] static
//! frames in parallel, temporal noise on the longest static run, JPEG traces on three frames),
//! fits the rig with [`crate::calibrate`], and writes `scenario.toml`, `timestamps.csv`,
//! `calibration.md` and `overlay.png` (footage | calibrated render at the same instant |
//! difference ×4 around mid-grey).
//!
//! [`calibrate`] (and [`measure_footage`]) are the library entry points
//! (`geneva diagnose` starts from them); nothing here is maths.

use super::calibrate_appearance::{write_marker_appearance, MosaicFrame};
use crate::calibrate::noise_levels::LevelNoise;
use crate::calibrate::output::{
    calibration_markdown, dynamics_offset_rad, overrides, scenario_toml, OutputContext, Override,
    ReRenderCheck,
};
use crate::calibrate::rerender::{align, PixelResidual};
use crate::calibrate::residual::{self, judge, Grid};
use crate::calibrate::{
    calibrate as fit_rig, noise_electrons, CalibrateError, CalibrateOptions, Calibration, Fitted,
    FootageStats, FrameObservation, SpatialNoiseSample, TemporalSample,
};
use crate::detect::{corners_bbox_px, ArucoDetector, GrayView};
use crate::errors::FileError;
use crate::imagestats::TemporalNoise;
use crate::imagestats::{
    blockiness, jpeg_quality, marker_levels, marker_regions, outer_edge_profiles, refined_corners,
    rigid_motion, temporal_noise, weak_texture_noise, EdgeOptions, EdgeProfile, LevelOptions,
    MarkerLayout, MarkerLevels, WeakTextureOptions,
};
use crate::io::output_dir::OutputDir;
use crate::render::{render_frame, FrameRequest, PixelRect};
use crate::scenario::Scenario;
use crate::timing::fit_vfr;
use crate::timing::Timestamps;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use toml::Value;

/// At most this many static poses, and as many moving frames, get their marker edges fitted.
pub const EDGE_FRAMES: usize = 96;
/// A failed re-render check whose residual is above this many times the fitted noise points at
/// the base's mechanism or marker.
const MISFIT_RATIO: f64 = 2.5;
/// Frames of the longest static run kept for the temporal noise and the overlay.
const RUN_FRAMES: usize = 12;
/// A marker whose detected centre moves less than this between frames may be static, px:
/// OpenCV's corners jitter by up to about ¾ px on a still marker under a codec's noise, and
/// beyond a pixel or so the linearised motion fit below no longer measures the motion.
const COARSE_STATIC_PX: f64 = 1.5;
/// …and is when the marker's structure (its edges, where the window's gradients are) moved
/// less than this since the static run's first frame, px ([`rigid_motion`]'s shift plus its
/// turn at the structure's radius): the regions whose noise is measured over the run keep 3 px
/// from every edge ([`LevelOptions::guard_px`]), so a fifth of a pixel leaves them as they
/// were, and a texture mosaicked from the run is registered to a fifth of a pixel. Codec and
/// demosaicking noise on a still marker reads as at most about a tenth of a pixel (path-traced
/// footage through a phone model with H.264, `tools/pbr/`).
const STILL_PX: f64 = 0.2;

/// Where the footage comes from.
#[derive(Debug, Clone)]
pub enum Footage {
    Video(PathBuf),
    Frames {
        dir: PathBuf,
        timestamps: PathBuf,
    },
    /// One still image (single-frame mode, t = 0).
    Image(PathBuf),
}

impl Footage {
    fn describe(&self) -> String {
        match self {
            Footage::Video(p) | Footage::Image(p) => p.display().to_string(),
            Footage::Frames { dir, .. } => dir.display().to_string(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum CalibrateJobError {
    #[error("--base {spec}")]
    Base {
        spec: String,
        source: crate::scenario::ScenarioError,
    },
    #[error(
        "--base {spec}: does not state the marker's side `scene.marker.size_mm` (the printed \
         black square, mm): the image scale is measured against it, so calibrate needs it from \
         you"
    )]
    BaseWithoutSide { spec: String },
    #[error("--base: the marker layout")]
    MarkerLayout(#[source] crate::imagestats::StatsError),
    #[error("--base: the detector")]
    Detector(#[source] crate::detect::DetectError),
    #[error("{dir} holds {files} image files but {timestamps} has {times} timestamps")]
    FrameCountMismatch {
        dir: PathBuf,
        files: usize,
        timestamps: PathBuf,
        times: usize,
    },
    #[error("{footage}: no frames")]
    NoFrames { footage: String },
    #[error("{footage}: timestamps")]
    Timestamps {
        footage: String,
        #[source]
        source: crate::timing::TimingError,
    },
    #[error("round trip: rendering the case")]
    RoundTripRender(#[source] super::render_job::RenderJobError),
    #[error("round trip: {file}")]
    RoundTripWrite {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("round trip: no valid case drawn in {attempts} attempts")]
    RoundTripNoCase { attempts: usize },
    #[error("{}: frame {frame}", file.display())]
    FrameRead {
        file: PathBuf,
        frame: usize,
        #[source]
        source: crate::io::images::ImageError,
    },
    #[error(
        "{}: frame {frame} is {width_px}×{height_px} px, but the first frame is \
         {first_width_px}×{first_height_px}",
        file.display()
    )]
    FrameSize {
        file: PathBuf,
        frame: usize,
        width_px: usize,
        height_px: usize,
        first_width_px: usize,
        first_height_px: usize,
    },
    #[error("{}: frame {frame}: detecting the marker", file.display())]
    FrameDetect {
        file: PathBuf,
        frame: usize,
        #[source]
        source: crate::detect::DetectError,
    },
    #[error(transparent)]
    Calibrate(#[from] CalibrateError),
    #[error(transparent)]
    Image(#[from] crate::io::images::ImageError),
    #[error(transparent)]
    Video(#[from] crate::io::video::VideoError),
    #[error(transparent)]
    TimingLog(#[from] crate::io::timing_log::TimingLogError),
    #[error(transparent)]
    OutputDir(#[from] crate::io::output_dir::OutputError),
    #[error(transparent)]
    File(#[from] crate::errors::FileError),
    #[error("{path}: the calibrated scenario")]
    Scenario {
        path: PathBuf,
        source: crate::scenario::ScenarioError,
    },
    #[error("{path}: the calibrated rig")]
    Rig {
        path: PathBuf,
        source: crate::pipeline::rig::RigError,
    },
    #[error(transparent)]
    Png(#[from] crate::io::png_out::PngError),
    #[error(transparent)]
    Texture(#[from] crate::io::texture_png::TextureError),
    #[error("{}: the overlay: {message}", file.display())]
    Overlay { file: PathBuf, message: String },
}

/// The calibration and what was written.
#[derive(Debug, Clone)]
pub struct CalibrateOutput {
    pub calibration: Calibration,
    /// The calibrated scenario as loaded back from `scenario.toml`.
    pub scenario: Scenario,
    pub check: Option<ReRenderCheck>,
    pub files: Vec<PathBuf>,
}

/// A copied window of a frame (absolute origin).
#[derive(Debug, Clone)]
pub(crate) struct Crop {
    pub(crate) rect: PixelRect,
    pub(crate) data: Vec<u8>,
}

impl Crop {
    pub(crate) fn of(data: &[u8], width: usize, height: usize, rect: PixelRect) -> Crop {
        let r = rect.intersect(&PixelRect::new(0, 0, width, height));
        let mut out = Vec::with_capacity(r.len());
        for y in r.y0..r.y1() {
            let start = y as usize * width + r.x0 as usize;
            out.extend_from_slice(&data[start..start + r.width]);
        }
        Crop { rect: r, data: out }
    }

    pub(crate) fn view(&self) -> GrayView<'_> {
        GrayView {
            data: &self.data,
            width: self.rect.width,
            height: self.rect.height,
            origin_px: (self.rect.x0 as i32, self.rect.y0 as i32),
        }
    }
}

pub(crate) type Corners = [[f64; 2]; 4];

fn centre(c: &Corners) -> [f64; 2] {
    [
        c.iter().map(|p| p[0]).sum::<f64>() / 4.0,
        c.iter().map(|p| p[1]).sum::<f64>() / 4.0,
    ]
}

/// The marker's window: its corners' box grown for the margin, the surround ring and the edge
/// band.
fn window(c: &Corners, layout: &MarkerLayout) -> PixelRect {
    let (x0, y0, x1, y1) = corners_bbox_px(c);
    let side = ((x1 - x0) + (y1 - y0)) / 2.0;
    let grow = side * (layout.margin_frac.unwrap_or(0.1) + 1.5 / layout.side_cells() as f64) + 24.0;
    let (x0, y0) = ((x0 - grow).floor() as i64, (y0 - grow).floor() as i64);
    let (x1, y1) = ((x1 + grow).ceil() as i64, (y1 + grow).ceil() as i64);
    PixelRect::new(x0, y0, (x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize)
}

/// Per-footage measurement state.
struct Measurer {
    detector: ArucoDetector,
    marker_id: i32,
    reference_id: Option<i32>,
    layout: MarkerLayout,
    ref_layout: Option<MarkerLayout>,
    level_opts: LevelOptions,
    stats: FootageStats,
    last: Option<Corners>,
    last_ref: Option<Corners>,
    edge_jobs: Vec<(usize, Crop, Corners, bool)>,
    ref_edge_jobs: Vec<(Crop, Corners)>,
    ref_crops: Vec<(Crop, Corners)>,
    run: Vec<(usize, Crop, Corners)>,
    best_run: Vec<(usize, Crop, Corners)>,
    first: Option<(usize, Crop, Corners)>,
    prev_crop: Option<(usize, Crop, Corners)>,
    stride: usize,
    prev_static: bool,
    jpeg_frames: Vec<usize>,
    single_frame: bool,
}

fn layout_of(
    dict: crate::marker::Dictionary,
    id: usize,
    bits: usize,
    size_mm: f64,
    margin_mm: f64,
) -> Result<MarkerLayout, CalibrateJobError> {
    MarkerLayout::new(dict, id, bits, Some(margin_mm / size_mm))
        .map_err(CalibrateJobError::MarkerLayout)
}

impl Measurer {
    fn new(
        base: &Scenario,
        frames_hint: usize,
        single_frame: bool,
    ) -> Result<Self, CalibrateJobError> {
        let m = &base.scene.marker;
        let layout = layout_of(
            m.dictionary,
            m.id,
            m.border_bits,
            m.size_mm,
            m.white_margin_mm,
        )?;
        let r = &base.scene.reference_marker;
        let reference_id = base.detector.reference_marker_id;
        let ref_layout = if reference_id.is_some() {
            Some(layout_of(
                r.dictionary,
                r.id,
                r.border_bits,
                r.size_mm,
                r.white_margin_mm,
            )?)
        } else {
            None
        };
        let detector = ArucoDetector::new(&base.detector).map_err(CalibrateJobError::Detector)?;
        let n = frames_hint.max(1);
        Ok(Self {
            detector,
            marker_id: base.detector.marker_id,
            reference_id,
            layout,
            ref_layout,
            level_opts: LevelOptions::default(),
            stats: FootageStats::default(),
            last: None,
            last_ref: None,
            edge_jobs: Vec::new(),
            ref_edge_jobs: Vec::new(),
            ref_crops: Vec::new(),
            run: Vec::new(),
            best_run: Vec::new(),
            first: None,
            prev_crop: None,
            stride: n.div_ceil(EDGE_FRAMES).max(1),
            prev_static: false,
            jpeg_frames: vec![0, n / 2, n.saturating_sub(1)],
            single_frame,
        })
    }

    fn observe(
        &mut self,
        index: usize,
        t_s: f64,
        data: &[u8],
        w: usize,
        h: usize,
    ) -> Result<(), crate::detect::DetectError> {
        self.stats.width_px = w;
        self.stats.height_px = h;
        let view = GrayView::full(data, w, h);
        let det = self
            .detector
            .detect_marker(
                view,
                self.marker_id,
                self.last.as_ref().map(corners_bbox_px),
            )?
            .detection
            .map(|d| d.corners_px);
        let mut obs = FrameObservation {
            frame: index,
            t_s,
            corners_px: det,
            ..Default::default()
        };
        if let Some(c) = det {
            let moved = self
                .last
                .map(|p| {
                    let (a, b) = (centre(&p), centre(&c));
                    (a[0] - b[0]).hypot(a[1] - b[1])
                })
                .unwrap_or(f64::INFINITY);
            // Static: OpenCV's (quantised) corners did not jump, and the image at the marker
            // moved by less than a fifth of a pixel since the static run's first frame (since
            // the previous frame when no run is open), so that a slow creep cannot build up
            // along a run.
            let crop_now = Crop::of(data, w, h, window(&c, &self.layout));
            let anchor = if self.prev_static {
                self.run.first()
            } else {
                self.prev_crop.as_ref()
            };
            let consecutive = self.prev_crop.as_ref().is_some_and(|p| p.0 + 1 == index);
            obs.static_pose = moved < COARSE_STATIC_PX
                && consecutive
                && anchor.is_some_and(|p| {
                    rigid_motion(&p.1.view(), &crop_now.view())
                        .is_ok_and(|m| m.max_displacement_px() < STILL_PX)
                });
            obs.levels = marker_levels(&view, &c, &self.layout, &self.level_opts).ok();
            let crop = crop_now;
            if self.first.is_none() {
                self.first = Some((index, crop.clone(), c));
            }
            // Edge fits (sub-pixel corners, blur): the first frame of every static run (one
            // per distinct pose) and every stride-th moving frame, each capped.
            let run_start = obs.static_pose && !self.prev_static;
            let (n_static, n_moving) = self.edge_jobs.iter().fold((0, 0), |a, j| {
                if j.3 {
                    (a.0 + 1, a.1)
                } else {
                    (a.0, a.1 + 1)
                }
            });
            if self.single_frame
                || (run_start && n_static < EDGE_FRAMES)
                || (!obs.static_pose && index % self.stride == 0 && n_moving < EDGE_FRAMES)
            {
                self.edge_jobs.push((
                    self.stats.frames.len(),
                    crop.clone(),
                    c,
                    obs.static_pose || self.single_frame,
                ));
            }
            if obs.static_pose {
                if self.run.is_empty() {
                    if let Some(p) = self.prev_crop.take() {
                        self.run.push(p);
                    }
                }
                if self.run.len() < RUN_FRAMES {
                    // A run's frames are cropped to its first window: the window follows
                    // OpenCV's corners, rounded outwards, and changes every frame or two on a
                    // still marker, while the noise is measured on pixels the frames share.
                    let rect = self.run.first().map_or(crop.rect, |f| f.1.rect);
                    let run_crop = if rect == crop.rect {
                        crop.clone()
                    } else {
                        Crop::of(data, w, h, rect)
                    };
                    self.run.push((index, run_crop, c));
                }
            } else {
                self.close_run();
            }
            self.prev_crop = Some((index, crop, c));
            self.last = Some(c);
            self.prev_static = obs.static_pose;
        } else {
            self.close_run();
            self.prev_crop = None;
            self.prev_static = false;
        }
        if let (Some(id), Some(layout)) = (self.reference_id, &self.ref_layout) {
            let r = self
                .detector
                .detect_marker(view, id, self.last_ref.as_ref().map(corners_bbox_px))?
                .detection
                .map(|d| d.corners_px);
            if let Some(c) = r {
                obs.reference_px = Some(c);
                if let Ok(l) = marker_levels(&view, &c, layout, &self.level_opts) {
                    self.stats.reference_levels.push(l);
                }
                if self.ref_crops.len() < RUN_FRAMES || self.ref_edge_jobs.len() < 8 {
                    let crop = Crop::of(data, w, h, window(&c, layout));
                    if self.ref_edge_jobs.len() < 8 && index % self.stride == 0 {
                        self.ref_edge_jobs.push((crop.clone(), c));
                    }
                    // The reference marker is static: the same pixels over frames (ROI windows
                    // of the first detection).
                    if self.ref_crops.len() < RUN_FRAMES {
                        let rect = self.ref_crops.first().map_or(crop.rect, |f| f.0.rect);
                        self.ref_crops.push((Crop::of(data, w, h, rect), c));
                    }
                }
                self.last_ref = Some(c);
            }
        }
        if self.jpeg_frames.contains(&index) {
            if let Ok(b) = blockiness(&view, None) {
                self.stats.blockiness.push(b);
                self.stats
                    .jpeg
                    .push(jpeg_quality(&view, None, 1024).ok().flatten());
            }
            self.jpeg_frames.retain(|&f| f != index);
        }
        self.stats.frames.push(obs);
        Ok(())
    }

    fn close_run(&mut self) {
        self.measure_run_noise();
        if self.run.len() > self.best_run.len() {
            self.best_run = std::mem::take(&mut self.run);
        }
        self.run.clear();
    }

    /// The temporal noise of the ink, paper and surround over the closing static run, at the
    /// run's levels (`FootageStats::level_noise`): each dwell shows the noise at its own levels.
    fn measure_run_noise(&mut self) {
        let Some(first) = self.run.first() else {
            return;
        };
        // Every frame of a run is cropped to its first's window (`observe`).
        let crops: Vec<&(usize, Crop, Corners)> = self.run.iter().collect();
        debug_assert!(crops.iter().all(|c| c.1.rect == first.1.rect));
        // Two frames suffice: a clip that starts as a dwell ends shows that dwell's levels on
        // two frames only, and their difference at each of a few hundred pixels pins the σ.
        if crops.len() < 2 {
            return;
        }
        let views: Vec<GrayView<'_>> = crops.iter().map(|c| c.1.view()).collect();
        let frames = (crops[0].0, crops[crops.len() - 1].0);
        for (name, noise) in regions_noise(&views, &crops[0].2, &self.layout, &self.level_opts) {
            self.stats.level_noise.push(LevelNoise {
                what: format!("{name} over frames {}–{}", frames.0, frames.1),
                level_dn: noise.level_dn,
                sigma_dn: noise.sigma_dn,
                sigma_stderr_dn: noise.sigma_stderr_dn,
            });
        }
    }

    /// Parallel edge fits, temporal noise, timing fit.
    fn finish(mut self, times: &[f64]) -> Measurements {
        self.close_run();
        let layout = &self.layout;
        let mut edge_opts = EdgeOptions {
            max_samples: 2500,
            ..Default::default()
        };
        // The footage's sharpening first: every edge fit below then models its halo.
        self.stats.sharpening =
            super::calibrate_sharpening::measure_sharpening(&self.edge_jobs, layout, &edge_opts);
        edge_opts.sharpening = self
            .stats
            .sharpening
            .filter(|m| m.significant)
            .map(|m| m.mask());
        let jobs: Vec<&(usize, Crop, Corners, bool)> = self.edge_jobs.iter().collect();
        let results: Vec<(usize, Vec<EdgeProfile>)> = jobs
            .par_iter()
            .map(|(k, crop, c, _)| {
                let fits: Vec<EdgeProfile> =
                    outer_edge_profiles(&crop.view(), c, layout, &edge_opts)
                        .into_iter()
                        .filter_map(Result::ok)
                        .collect();
                (*k, fits)
            })
            .collect();
        let n = layout.side_cells();
        for (k, fits) in results {
            let f = &mut self.stats.frames[k];
            f.refined_px = refined_corners(&fits, n);
            f.edges = fits;
        }
        if let Some(rl) = &self.ref_layout {
            self.stats.reference_edges = self
                .ref_edge_jobs
                .par_iter()
                .flat_map_iter(|(crop, c)| {
                    outer_edge_profiles(&crop.view(), c, rl, &edge_opts)
                        .into_iter()
                        .filter_map(Result::ok)
                })
                .collect();
        }
        // Temporal noise: the longest static run of the disc marker, and the reference marker.
        let mut temporal = Vec::new();
        let mut add = |what: &str, crops: &[(Crop, Corners)], layout: &MarkerLayout| {
            if crops.len() < 3 {
                return;
            }
            let views: Vec<GrayView<'_>> = crops.iter().map(|c| c.0.view()).collect();
            for (name, noise) in regions_noise(&views, &crops[0].1, layout, &self.level_opts) {
                temporal.push(TemporalSample {
                    what: format!("{what} {name}"),
                    noise,
                });
            }
        };
        let run: Vec<(Crop, Corners)> = self
            .best_run
            .iter()
            .map(|(_, c, k)| (c.clone(), *k))
            .collect();
        // Every frame of a run is cropped to its first's window (`observe`).
        add("disc", &run, &self.layout);
        if let Some(rl) = self.ref_layout.clone() {
            let crops = self.ref_crops.clone();
            add("reference", &crops, &rl);
        }
        self.stats.temporal = temporal;
        let has_disc_temporal = self
            .stats
            .temporal
            .iter()
            .any(|t| t.what.starts_with("disc"));
        if !has_disc_temporal {
            self.stats.spatial_noise =
                spatial_noise(&self.edge_jobs, &self.layout, &self.level_opts);
        }
        if times.len() >= 5 {
            if let Ok(ts) = Timestamps::new(times.to_vec()) {
                self.stats.timing = fit_vfr(&ts).ok();
            }
        }
        let overlay = if self.best_run.len() >= 2 {
            let mid = self.best_run.len() / 2;
            self.best_run.get(mid).cloned()
        } else {
            self.first.clone()
        };
        let background = self
            .edge_jobs
            .iter()
            .map(|(k, crop, _, _)| {
                (
                    self.stats.frames.get(*k).map_or(*k, |f| f.frame),
                    crop.clone(),
                )
            })
            .collect();
        let mosaic = mosaic_frames(&self.stats, self.edge_jobs, &self.best_run);
        Measurements {
            stats: self.stats,
            overlay,
            mosaic,
            background,
        }
    }
}

/// The temporal noise of the ink, paper and surround of the marker at `corners` over `views`
/// (frames of one static pose), each measured on 30 pixels or more.
fn regions_noise(
    views: &[GrayView<'_>],
    corners: &Corners,
    layout: &MarkerLayout,
    options: &LevelOptions,
) -> Vec<(&'static str, TemporalNoise)> {
    let Ok(regions) = marker_regions(&views[0], corners, layout, options) else {
        return Vec::new();
    };
    [
        ("ink", &regions.ink),
        ("paper", &regions.paper),
        ("surround", &regions.surround),
    ]
    .into_iter()
    .filter_map(|(name, px)| {
        temporal_noise(views, px)
            .ok()
            .filter(|n| n.pixels >= 30)
            .map(|n| (name, n))
    })
    .collect()
}

/// The frames the marker's texture is mosaicked from, each with the footage's frame number and
/// its corners: the static poses only (a moving marker is smeared by its motion over the
/// exposure, which no guard band of the blur's width keeps out), at their edge-fitted corners
/// (OpenCV's sit about half a pixel inside the black square); the frames of the longest static
/// run too, at the corners fitted on the run's own edge-fit frame (the pose does not change
/// within a run), so that the texture averages the noise of many frames.
fn mosaic_frames(
    stats: &FootageStats,
    edge_jobs: Vec<(usize, Crop, Corners, bool)>,
    best_run: &[(usize, Crop, Corners)],
) -> Vec<MosaicFrame> {
    let mut out: Vec<MosaicFrame> = edge_jobs
        .into_iter()
        .filter(|j| j.3)
        .filter_map(|(k, crop, detected, _)| {
            let f = stats.frames.get(k)?;
            Some((f.frame, crop, f.refined_px.unwrap_or(detected)))
        })
        .collect();
    let (Some(first), Some(last)) = (best_run.first(), best_run.last()) else {
        return out;
    };
    let run_pose = out
        .iter()
        .find(|m| (first.0..=last.0).contains(&m.0))
        .map(|m| m.2);
    if let Some(corners) = run_pose {
        for (index, crop, _) in best_run {
            if !out.iter().any(|m| m.0 == *index) {
                out.push((*index, crop.clone(), corners));
            }
        }
    }
    out
}

/// Frames whose single-frame noise is measured when the footage has no static run.
const SPATIAL_NOISE_FRAMES: usize = 8;

/// The weak-texture noise of the disc marker's ink and paper on up to
/// [`SPATIAL_NOISE_FRAMES`] of the frames kept for edge fits (static poses first), for footage
/// without a static run to measure it temporally.
fn spatial_noise(
    jobs: &[(usize, Crop, Corners, bool)],
    layout: &MarkerLayout,
    opts: &LevelOptions,
) -> Vec<SpatialNoiseSample> {
    let mut chosen: Vec<&(usize, Crop, Corners, bool)> = jobs.iter().filter(|j| j.3).collect();
    chosen.extend(jobs.iter().filter(|j| !j.3));
    chosen.truncate(SPATIAL_NOISE_FRAMES);
    let wt = WeakTextureOptions::default();
    chosen
        .par_iter()
        .filter_map(|(k, crop, c, _)| {
            let view = crop.view();
            let regions = marker_regions(&view, c, layout, opts).ok()?;
            Some(SpatialNoiseSample {
                frame: *k,
                ink: weak_texture_noise(&view, &regions.ink, &wt).ok(),
                paper: weak_texture_noise(&view, &regions.paper, &wt).ok(),
            })
        })
        .collect()
}

/// Reads the timestamps of a frame folder.
fn read_times(path: &Path) -> Result<Vec<f64>, CalibrateJobError> {
    crate::io::timing_log::read_timing_log(path, None)
        .map(|t| t.into_vec())
        .map_err(CalibrateJobError::from)
}

/// Reads the footage frame by frame into `measurer`; returns the timestamps (from the first)
/// and, for a video, how its stream was coded.
fn read_footage(
    footage: &Footage,
    measurer: &mut Measurer,
    progress: &dyn Fn(usize, usize),
) -> Result<(Vec<f64>, Option<crate::io::video::StreamCoding>), CalibrateJobError> {
    let mut coding = None;
    let mut times = Vec::new();
    match footage {
        Footage::Image(path) => {
            let img = crate::io::images::read_gray(path).map_err(CalibrateJobError::from)?;
            measurer
                .observe(0, 0.0, &img.data, img.width, img.height)
                .map_err(|source| CalibrateJobError::FrameDetect {
                    file: path.clone(),
                    frame: 0,
                    source,
                })?;
            times.push(0.0);
            progress(1, 1);
        }
        Footage::Frames { dir, timestamps } => {
            let files =
                crate::io::images::list_image_files(dir).map_err(CalibrateJobError::from)?;
            let t = read_times(timestamps)?;
            if files.len() != t.len() {
                return Err(CalibrateJobError::FrameCountMismatch {
                    dir: dir.clone(),
                    files: files.len(),
                    timestamps: timestamps.clone(),
                    times: t.len(),
                });
            }
            let t0 = t.first().copied().unwrap_or(0.0);
            // Decode a few frames in parallel, measure them in order (each predicts the next).
            for (chunk_i, chunk) in files.chunks(4).enumerate() {
                let imgs: Vec<_> = chunk
                    .par_iter()
                    .map(|f| crate::io::images::read_gray(f))
                    .collect();
                for (k, img) in imgs.into_iter().enumerate() {
                    let i = chunk_i * 4 + k;
                    let file = &files[i];
                    let img = img.map_err(|source| CalibrateJobError::FrameRead {
                        file: file.clone(),
                        frame: i,
                        source,
                    })?;
                    if i > 0
                        && (img.width, img.height)
                            != (measurer.stats.width_px, measurer.stats.height_px)
                    {
                        return Err(CalibrateJobError::FrameSize {
                            file: file.clone(),
                            frame: i,
                            width_px: img.width,
                            height_px: img.height,
                            first_width_px: measurer.stats.width_px,
                            first_height_px: measurer.stats.height_px,
                        });
                    }
                    measurer
                        .observe(i, t[i] - t0, &img.data, img.width, img.height)
                        .map_err(|source| CalibrateJobError::FrameDetect {
                            file: file.clone(),
                            frame: i,
                            source,
                        })?;
                    times.push(t[i] - t0);
                    progress(i + 1, files.len());
                }
            }
        }
        Footage::Video(path) => {
            let mut frames =
                crate::io::video::VideoFrames::open(path).map_err(CalibrateJobError::from)?;
            coding = Some(frames.info().coding.clone());
            let (w, h, total) = (
                frames.info().width_px,
                frames.info().height_px,
                frames.info().frame_count(),
            );
            let mut t0 = None;
            loop {
                match frames.next_frame() {
                    Ok(Some(f)) => {
                        let t_first = *t0.get_or_insert(f.t_s);
                        measurer
                            .observe(f.index, f.t_s - t_first, &f.data, w, h)
                            .map_err(|source| CalibrateJobError::FrameDetect {
                                file: path.clone(),
                                frame: f.index,
                                source,
                            })?;
                        times.push(f.t_s - t_first);
                        progress(f.index + 1, total);
                    }
                    Ok(None) => break,
                    Err(e) => return Err(e.into()),
                }
            }
        }
    }
    if times.is_empty() {
        return Err(CalibrateJobError::NoFrames {
            footage: footage.describe(),
        });
    }
    Ok((times, coding))
}

fn frames_hint(footage: &Footage) -> usize {
    match footage {
        Footage::Image(_) => 1,
        Footage::Frames { dir, .. } => crate::io::images::list_image_files(dir)
            .map(|f| f.len())
            .unwrap_or(1),
        Footage::Video(p) => crate::io::video::probe(p)
            .map(|i| i.frame_count())
            .unwrap_or(300),
    }
}

/// Loads the base scenario and checks that it states what the footage cannot tell.
pub fn load_base(spec: &str) -> Result<Scenario, CalibrateJobError> {
    let err = |source| CalibrateJobError::Base {
        spec: spec.to_string(),
        source,
    };
    let stated = crate::scenario::stated_fields(spec).map_err(err)?;
    let side = stated
        .get("scene")
        .and_then(|s| s.get("marker"))
        .and_then(|m| m.get("size_mm"));
    if side.is_none() {
        return Err(CalibrateJobError::BaseWithoutSide {
            spec: spec.to_string(),
        });
    }
    crate::scenario::load_any(spec).map_err(err)
}

/// Measures the footage: every frame's observation plus the footage-wide statistics.
pub fn measure_footage(
    footage: &Footage,
    base: &Scenario,
    single_frame: bool,
    progress: &dyn Fn(usize, usize),
) -> Result<FootageStats, CalibrateJobError> {
    Ok(measure(footage, base, single_frame, progress)?.0.stats)
}

/// What the measuring pass keeps: the statistics, the re-render check's frame and the frames
/// the marker's texture is mosaicked from.
struct Measurements {
    stats: FootageStats,
    overlay: Option<(usize, Crop, Corners)>,
    mosaic: Vec<MosaicFrame>,
    /// Every frame whose window was kept (the marker at rest or moving), with its footage
    /// frame number: the background is mosaicked from them.
    background: Vec<(usize, Crop)>,
}

type Measured = (Measurements, Vec<f64>);

fn measure(
    footage: &Footage,
    base: &Scenario,
    single_frame: bool,
    progress: &dyn Fn(usize, usize),
) -> Result<Measured, CalibrateJobError> {
    let mut m = Measurer::new(base, frames_hint(footage), single_frame)?;
    let (times, coding) = read_footage(footage, &mut m, progress)?;
    let mut measured = m.finish(&times);
    measured.stats.codec = coding.map(|c| {
        crate::calibrate::codec::read_codec(
            c.codec_name.as_deref(),
            c.stream_bit_rate_bps,
            c.file_bit_rate_bps,
            &c.picture_types,
        )
    });
    Ok((measured, times))
}

fn scenario_err(
    path: &Path,
) -> impl FnOnce(crate::scenario::ScenarioError) -> CalibrateJobError + '_ {
    move |source| CalibrateJobError::Scenario {
        path: path.to_path_buf(),
        source,
    }
}

/// The whole job: measure, fit, write `scenario.toml`, `timestamps.csv`, `calibration.md` and
/// `overlay.png` into `out_dir`, all at once ([`crate::io::output_dir`]: a folder that is not
/// geneva's is refused before any work, and an error leaves the previous folder as it was).
/// `options.single_frame` (implied by [`Footage::Image`]) calibrates the image formation and
/// the marker's pose from the first frame, without the motion.
pub fn calibrate(
    footage: &Footage,
    base_spec: &str,
    out_dir: &Path,
    options: &CalibrateOptions,
    progress: &dyn Fn(usize, usize),
) -> Result<CalibrateOutput, CalibrateJobError> {
    let base = load_base(base_spec)?;
    let single_frame = options.single_frame || matches!(footage, Footage::Image(_));
    let staged = OutputDir::create(out_dir)?;
    let (measured, times) = measure(footage, &base, single_frame, progress)?;
    let cal = fit_rig(&base, &measured.stats, &CalibrateOptions { single_frame })?;
    let out = write_outputs(
        footage,
        base_spec,
        &base,
        staged.path(),
        measured,
        &times,
        cal,
    )?;
    let files = staged.commit()?;
    // Loaded back from its final place: the timestamps file it names is beside it.
    let scenario_path = out_dir.join("scenario.toml");
    let scenario = crate::scenario::load(&scenario_path).map_err(scenario_err(&scenario_path))?;
    Ok(CalibrateOutput {
        scenario,
        files,
        ..out
    })
}

/// Fits what needs rendering (dynamics offset, levels and noise matched by simulation) and
/// writes the files into `out_dir` (the staging folder).
#[allow(clippy::too_many_arguments)]
fn write_outputs(
    footage: &Footage,
    base_spec: &str,
    base: &Scenario,
    out_dir: &Path,
    measured: Measurements,
    times: &[f64],
    cal: Calibration,
) -> Result<CalibrateOutput, CalibrateJobError> {
    let Measurements {
        stats,
        overlay,
        mosaic,
        background,
    } = measured;
    let single_frame = cal.motion.is_none();
    let mut files = Vec::new();
    let ts_name = "timestamps.csv";
    let ts_path = out_dir.join(ts_name);
    let with_times = !single_frame;
    if with_times {
        let ts =
            Timestamps::new(times.to_vec()).map_err(|source| CalibrateJobError::Timestamps {
                footage: footage.describe(),
                source,
            })?;
        std::fs::write(&ts_path, crate::timing::to_frames_csv(&ts))
            .map_err(FileError::io(&ts_path))?;
        files.push(ts_path.clone());
    }
    let extend = {
        let p = Path::new(base_spec);
        if p.exists() {
            p.canonicalize()
                .map(|c| c.display().to_string())
                .unwrap_or_else(|_| base_spec.to_string())
        } else {
            base_spec.to_string()
        }
    };
    let ctx = OutputContext {
        extend,
        footage: footage.describe(),
        timestamps_file: with_times.then(|| ts_name.to_string()),
        width_px: stats.width_px,
        height_px: stats.height_px,
        last_t_s: times.last().copied().unwrap_or(0.0),
        frame_interval_s: with_times
            .then(|| {
                let fps = cal.timing.as_ref().map_or(base.frame_timing.fps, |t| t.fps);
                crate::calibrate::output::footage_frame_interval_s(times, fps)
            })
            .flatten(),
    };
    let scenario_path = out_dir.join("scenario.toml");
    let mut ovs = overrides(&cal, &ctx, base);
    let mut notes = cal.notes.clone();
    if let Some(interval_s) = ctx.frame_interval_s {
        notes.extend(
            crate::calibrate::output::capped_to_frame_interval(base, interval_s)
                .iter()
                .map(crate::calibrate::output::capped_time_note),
        );
    }
    // The base's wheel dynamics displace the wheel from the ideal kinematics: shift the marker
    // angle so the rendered marker sits where the footage shows it.
    let typed = |o: &[Override]| -> Result<Scenario, CalibrateJobError> {
        // Overrides are not anchored to a file: name the timestamps and textures by their full
        // paths here.
        // A `kind` selects a variant: like `extend` in a file, it replaces the base's table.
        let mut pairs: Vec<(String, Value)> = Vec::new();
        for x in o {
            if let Some(table) = x.path.strip_suffix(".kind") {
                pairs.push((table.to_string(), Value::Table(Default::default())));
            }
            let texture = x.path.starts_with("scene.appearance.") && x.path.ends_with("_file");
            let v = if x.path == "frame_timing.model.file" {
                Value::String(ts_path.display().to_string())
            } else if let (true, Some(name)) = (texture, x.value.as_str()) {
                // The textures written beside the scenario.
                Value::String(out_dir.join(name).display().to_string())
            } else {
                x.value.clone()
            };
            pairs.push((x.path.clone(), v));
        }
        crate::scenario::with_overrides(base, &pairs, &scenario_path)
            .map_err(scenario_err(&scenario_path))
    };
    let first = typed(&ovs)?;
    // Below the printed precision it is no correction worth a note.
    let mut offset_deg = None;
    if let Some(d) = dynamics_offset_rad(&first, times).filter(|d| d.to_degrees().abs() >= 5e-5) {
        if let Some(o) = ovs
            .iter_mut()
            .find(|o| o.path == "scene.marker.angle_on_disc_deg")
        {
            if let Some(v) = o.value.as_float() {
                o.value = Value::Float(v - d.to_degrees());
                offset_deg = Some(d.to_degrees());
                o.comment.push_str(&format!(
                    "; minus {:.4}° that the base's wheel dynamics add on average",
                    d.to_degrees()
                ));
                notes.push(format!(
                    "the base's wheel dynamics turn the wheel {:.4}° from the ideal kinematics on average over the footage; the marker angle is corrected for it",
                    d.to_degrees()
                ));
            }
        }
    }
    let mut cal = cal;
    cal.notes = notes;
    // The reported marker angle is the scenario's (the same correction), not the kinematic
    // fit's, which includes the wheel's mean dynamic displacement.
    if let Some(d) = offset_deg {
        match cal.motion.as_mut() {
            Some(m) => m.angle_first_deg.value -= d,
            None => cal.geometry.angle_first_deg.value -= d,
        }
    }
    if let Some((frame, crop, corners)) = &overlay {
        let layout = layout_of(
            base.scene.marker.dictionary,
            base.scene.marker.id,
            base.scene.marker.border_bits,
            base.scene.marker.size_mm,
            base.scene.marker.white_margin_mm,
        )?;
        if cal.imaging.blur_sigma_px.is_some() {
            let mask = cal.imaging.sharpening.filter(|m| m.significant);
            let render = |o: &[Override]| typed(o).ok();
            let got = super::calibrate_sharpening::match_edges_by_render(
                mask.as_ref(),
                *frame,
                crop,
                corners,
                base,
                &mut ovs,
                &render,
            );
            if let Some(g) = &got {
                // What the scenario draws is the matched σ. Its interval: the edge fits' (their
                // spread across edges), widened by how far the edge model's reading of the same
                // σ lies from it (a systematic difference no spread shows).
                if let Some(p) = cal.imaging.blur_sigma_param_px {
                    let u95 = p.u95 + (g.blur_px - p.value).abs();
                    cal.imaging.blur_sigma_param_px = Some(Fitted::new(g.blur_px, u95));
                    set_blur_comment(&mut ovs, cal.imaging.blur_sigma_px, u95, *frame);
                }
            }
            if let Some(m) = mask {
                cal.notes.push(match got {
                    Some(g) => format!(
                        "sharpening: {}; drawn as the mask ({:.3}, σ {:.2} px) and blur (σ {:.3} px) that reproduce the edges of frame {frame} best (footage − noiseless render {:.2} → {:.2} DN RMS)",
                        m.describe(),
                        g.amount.unwrap_or(f64::NAN),
                        g.mask_sigma_px.unwrap_or(f64::NAN),
                        g.blur_px,
                        g.before_rms_dn,
                        g.after_rms_dn
                    ),
                    None => format!(
                        "sharpening: {}; drawn as the edge fits read it (rendering the calibrated scenario against frame {frame} does not improve on it)",
                        m.describe()
                    ),
                });
            }
        }
        match_by_simulation(
            &stats, *frame, crop, corners, &layout, &mut ovs, &mut cal, &typed,
        );
        let blur_sigma_px = cal
            .imaging
            .blur_sigma_px
            .map_or(base.effects.optical_blur.sigma_px, |b| b.value);
        super::calibrate_levels::make_room_for_darkest_ink(&stats, &mut ovs, &mut cal, base);
        let texture = write_marker_appearance(
            &mosaic,
            times,
            Some(*frame),
            &layout,
            blur_sigma_px,
            &mut ovs,
            &mut cal,
            base,
            &typed,
            out_dir,
        )?;
        super::calibrate_levels::write_marker_levels(
            &stats,
            &mosaic,
            texture.is_some(),
            &mut ovs,
            &mut cal,
            base,
        );
        super::calibrate_noise_levels::write_noise_levels(&stats, &mut ovs, &mut cal);
        files.extend(texture);
        files.extend(super::calibrate_surroundings::write_surroundings(
            &super::calibrate_surroundings::SurroundFrames {
                disc: &mosaic,
                background: &background,
                times_s: times,
                check_frame: Some(*frame),
            },
            blur_sigma_px,
            &mut ovs,
            &mut cal,
            &typed,
            out_dir,
        )?);
    }
    let text = scenario_toml(&ovs, &ctx, &cal);
    std::fs::write(&scenario_path, &text).map_err(FileError::io(&scenario_path))?;
    files.push(scenario_path.clone());
    let scenario = crate::scenario::load(&scenario_path).map_err(scenario_err(&scenario_path))?;
    let check = match &overlay {
        Some((frame, crop, corners)) => Some(render_check(
            &scenario,
            &cal,
            *frame,
            crop,
            corners,
            &out_dir.join("overlay.png"),
            base,
        )?),
        None => None,
    };
    if check.is_some() {
        files.push(out_dir.join("overlay.png"));
    }
    // A scenario that does not reproduce the footage is no calibration. A residual many times
    // the fitted noise most often means the base names another mechanism (kind, slot count) or
    // marker than the footage shows.
    if let Some(k) = check.as_ref().filter(|k| !k.passed()) {
        let hint = if k.ratio() > MISFIT_RATIO {
            format!(
                "; the residual is {:.1} × the fitted noise: if the render's marker sits or turns \
                 elsewhere than the footage's, check the base's mechanism (kind, slots) and marker \
                 against the footage",
                k.ratio()
            )
        } else {
            String::new()
        };
        cal.notes.push(format!(
            "warning: the re-render check failed at frame {}: the calibrated scenario does not \
             reproduce the footage down to its noise ({}){hint}; overlay.png shows what is left",
            k.frame,
            k.failures().join("; ")
        ));
    }
    let md_path = out_dir.join("calibration.md");
    std::fs::write(&md_path, calibration_markdown(&cal, &ctx, check.as_ref()))
        .map_err(FileError::io(&md_path))?;
    files.push(md_path);
    Ok(CalibrateOutput {
        calibration: cal,
        scenario,
        check,
        files,
    })
}

/// The footage's level and noise statistics, measured the way [`simulated_stats`] measures the
/// render: trimmed means (median over frames) and the noise σ (temporal on the disc marker's
/// static run when there is one, else spatial, median over frames).
fn footage_stats(stats: &FootageStats) -> Option<([f64; 3], [f64; 2], [SigmaStat; 2])> {
    let med = |mut v: Vec<f64>| -> Option<f64> {
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        Some(v[v.len() / 2])
    };
    let lv: Vec<_> = stats
        .frames
        .iter()
        .filter_map(|f| f.levels.as_ref())
        .collect();
    let ink = med(lv.iter().map(|l| l.ink.trimmed_mean_dn).collect())?;
    let paper = med(lv.iter().map(|l| l.paper.trimmed_mean_dn).collect())?;
    let disc = med(lv
        .iter()
        .filter_map(|l| l.surround.as_ref().map(|s| s.trimmed_mean_dn))
        .collect())
    .unwrap_or(f64::NAN);
    let temporal = |w: &str| {
        stats
            .temporal
            .iter()
            .find(|t| t.what == w)
            .map(|t| t.noise.sigma_dn)
    };
    if let (Some(i), Some(p)) = (temporal("disc ink"), temporal("disc paper")) {
        return Some(([ink, paper, disc], [i, p], [SigmaStat::Temporal; 2]));
    }
    // Spatially: the weak-texture σ where it measured the noise; a clipped region's plain σ
    // (its censored noise has no weak-texture law) or, where nothing was identifiable (the
    // noise is then not matched), the plain σ.
    let region = |m: usize, l: &MarkerLevels| {
        if m == 0 {
            l.ink.clone()
        } else {
            l.paper.clone()
        }
    };
    let mut sigmas = [0.0; 2];
    let mut kinds = [SigmaStat::PlaneResidual; 2];
    for m in 0..2 {
        let clipped = 2 * lv
            .iter()
            .filter(|l| region(m, l).clipping.is_some())
            .count()
            > lv.len();
        let weak: Vec<f64> = stats
            .weak_texture_noise(m)
            .filter(|e| e.not_identifiable().is_none())
            .map(|e| e.sigma_dn)
            .collect();
        if !clipped && crate::calibrate::spatial_sigma(stats, m).is_ok() {
            kinds[m] = SigmaStat::WeakTexture;
            sigmas[m] = med(weak)?;
        } else {
            sigmas[m] = med(lv.iter().map(|l| region(m, l).noise_sigma_dn).collect())?;
        }
    }
    Some(([ink, paper, disc], sigmas, kinds))
}

/// How a material's noise σ is measured on the footage, and so on the render.
#[derive(Debug, Clone, Copy, PartialEq)]
enum SigmaStat {
    /// Over frames of a static run.
    Temporal,
    /// [`weak_texture_noise`] on one frame.
    WeakTexture,
    /// The region's plain σ about a plane ([`crate::imagestats::RegionStats::noise_sigma_dn`]).
    PlaneResidual,
}

/// The same statistics on renders of `scenario` at footage frame `frame` over the crop.
fn simulated_stats(
    scenario: &Scenario,
    frame: usize,
    crop: &Crop,
    corners: &Corners,
    layout: &MarkerLayout,
    kinds: [SigmaStat; 2],
) -> Option<([f64; 3], [f64; 2])> {
    let temporal = kinds[0] == SigmaStat::Temporal;
    // The footage's levels are medians over its frames, which hold at the drift's reference
    // time: the match renders that light, steady.
    let mut steady = scenario.clone();
    let light = &mut steady.effects.lighting;
    light.gain_drift_per_s = 0.0;
    light.gain_steps.clear();
    light.flicker_frac = 0.0;
    let rig = crate::pipeline::rig::Rig::new(&steady).ok()?;
    let times = rig.frame_times.as_slice();
    let k = frame.min(times.len().checked_sub(1)?);
    let scene = rig.animated();
    let renders: Vec<_> = (0..if temporal { 6 } else { 1 })
        .into_par_iter()
        .map(|j| {
            render_frame(
                &scene,
                &rig.settings,
                &FrameRequest {
                    index: (k + 7919 * j) as u64,
                    t_s: times[k],
                    window: crop.rect,
                },
            )
        })
        .collect();
    let views: Vec<GrayView<'_>> = renders
        .iter()
        .map(|r| GrayView {
            data: &r.data,
            width: r.window.width,
            height: r.window.height,
            origin_px: (r.window.x0 as i32, r.window.y0 as i32),
        })
        .collect();
    let opts = LevelOptions::default();
    let lv = marker_levels(&views[0], corners, layout, &opts).ok()?;
    let means = [
        lv.ink.trimmed_mean_dn,
        lv.paper.trimmed_mean_dn,
        lv.surround.as_ref().map_or(f64::NAN, |s| s.trimmed_mean_dn),
    ];
    let regions = marker_regions(&views[0], corners, layout, &opts).ok()?;
    let wt = WeakTextureOptions::default();
    let mut sigmas = [0.0; 2];
    for (m, (px, plain)) in [(&regions.ink, &lv.ink), (&regions.paper, &lv.paper)]
        .into_iter()
        .enumerate()
    {
        sigmas[m] = match kinds[m] {
            SigmaStat::Temporal => temporal_noise(&views, px).ok()?.sigma_dn,
            SigmaStat::WeakTexture => weak_texture_noise(&views[0], px, &wt).ok()?.sigma_dn,
            SigmaStat::PlaneResidual => plain.noise_sigma_dn,
        };
    }
    Some((means, sigmas))
}

/// The optical blur's comment once its σ is matched by rendering (`measured`: the edge fits'
/// PSF σ).
fn set_blur_comment(ovs: &mut [Override], measured: Option<Fitted>, u95: f64, frame: usize) {
    if let Some(o) = ovs
        .iter_mut()
        .find(|o| o.path == "effects.optical_blur.sigma_px")
    {
        o.comment = format!(
            "± {u95:.3} (95 %): matched by rendering frame {frame} against the footage; the edge fits read a PSF σ of {}",
            measured.map_or("–".into(), |m| format!("{m} px"))
        );
    }
}

fn set_override(ovs: &mut [Override], path: &str, value: Value) {
    if let Some(o) = ovs.iter_mut().find(|o| o.path == path) {
        o.value = value;
    }
}

pub(crate) fn float_of(ovs: &[Override], path: &str) -> Option<f64> {
    ovs.iter()
        .find(|o| o.path == path)
        .and_then(|o| o.value.as_float())
}

/// Forward-model matching of levels and noise: renders the calibrated scenario where the
/// footage shows a static marker, measures it exactly like the footage and corrects the
/// radiances and the noise electrons until both agree (three rounds). This takes care of what
/// the direct estimates cannot: JPEG smoothing the noise, noise clipped at the white or black
/// level, blur mixing levels near edges.
#[allow(clippy::too_many_arguments)]
fn match_by_simulation(
    stats: &FootageStats,
    frame: usize,
    crop: &Crop,
    corners: &Corners,
    layout: &MarkerLayout,
    ovs: &mut [Override],
    cal: &mut Calibration,
    typed: &dyn Fn(&[Override]) -> Result<Scenario, CalibrateJobError>,
) {
    let Some((target_means, target_sigmas, kinds)) = footage_stats(stats) else {
        return;
    };
    let im = &cal.imaging;
    let (mut black, mut white) = (im.black_level_dn, im.white_level_dn);
    let (ink_clipped, paper_clipped) = (im.ink_radiance == 0.0, im.paper_radiance == 1.0);
    let span0 = white - black;
    let (Some(mut fw), Some(mut read)) = (
        float_of(ovs, "effects.pixel_noise.full_well_e"),
        float_of(ovs, "effects.pixel_noise.read_noise_e"),
    ) else {
        return;
    };
    let rad = |path: &str| float_of(ovs, path);
    let mut levels = [
        rad("scene.ink_radiance").map(|r| black + span0 * r),
        rad("scene.paper_radiance").map(|r| black + span0 * r),
        rad("scene.disc_radiance").map(|r| black + span0 * r),
    ];
    let sigma_pre = |l: f64, fw: f64, read: f64| {
        let s = ((l - black) / span0).max(0.0);
        span0 * (s * fw + read * read).sqrt() / fw
    };
    let (Some(li), Some(lp)) = (levels[0], levels[1]) else {
        return;
    };
    let mut pre = [sigma_pre(li, fw, read), sigma_pre(lp, fw, read)];
    // Shot noise is resolved when the paper's variance exceeds the ink's by more than the
    // measured σ's uncertainties allow.
    let (si, sp) = (&im.noise.ink_sigma_dn, &im.noise.paper_sigma_dn);
    let resolvable = (2.0 * sp.value * sp.u95).hypot(2.0 * si.value * si.u95);
    let mut resolved = im.noise.shot_resolved;
    // Noise the footage cannot tell is the base's σ in DN: kept as it is while the levels move.
    let match_noise = im.noise.footage_not_identifiable.is_none();
    let mut last: [Option<(f64, f64)>; 2] = [None, None];
    for _ in 0..6 {
        let Ok(s) = typed(ovs) else {
            return;
        };
        let Some((means, sigmas)) = simulated_stats(&s, frame, crop, corners, layout, kinds) else {
            return;
        };
        for m in 0..3 {
            if !(means[m].is_finite() && target_means[m].is_finite()) {
                continue;
            }
            let d = target_means[m] - means[m];
            // A clipped level is the tone curve's end: move that end with it.
            if m == 0 && ink_clipped {
                black = (black + d).clamp(0.0, white - 10.0);
                levels[0] = Some(black);
            } else if m == 1 && paper_clipped {
                white = (white + d).clamp(black + 10.0, 255.0);
                levels[1] = Some(white);
            } else if let Some(l) = levels[m].as_mut() {
                *l += d;
            }
        }
        // Secant steps on σ_pre → measured σ (JPEG and clipping make it far from the
        // identity); a ratio step first.
        for m in 0..2 {
            if !(match_noise && sigmas[m] > 1e-3 && target_sigmas[m] > 0.0) {
                continue;
            }
            let next = match last[m] {
                Some((p0, s0)) if (sigmas[m] - s0).abs() > 1e-4 && (pre[m] - p0).abs() > 1e-6 => {
                    let slope = ((sigmas[m] - s0) / (pre[m] - p0)).clamp(0.3, 2.0);
                    pre[m] + (target_sigmas[m] - sigmas[m]) / slope
                }
                _ => pre[m] * target_sigmas[m] / sigmas[m],
            };
            last[m] = Some((pre[m], sigmas[m]));
            pre[m] = next.clamp(pre[m] / 1.5, 1.5 * pre[m]).clamp(0.05, 50.0);
        }
        let (Some(li), Some(lp)) = (levels[0], levels[1]) else {
            return;
        };
        let (f, r, res) = noise_electrons(
            [li, lp],
            [pre[0] * pre[0], pre[1] * pre[1]],
            black,
            white,
            resolvable,
        );
        fw = f;
        read = r;
        resolved = res;
        let span = white - black;
        let radiance = |l: f64| ((l - black) / span).clamp(0.0, 1.0);
        set_override(
            ovs,
            "effects.lighting.black_level_dn",
            Value::Float(round6(black)),
        );
        set_override(
            ovs,
            "effects.lighting.white_level_dn",
            Value::Float(round6(white)),
        );
        set_override(
            ovs,
            "scene.ink_radiance",
            Value::Float(round6(radiance(li))),
        );
        set_override(
            ovs,
            "scene.paper_radiance",
            Value::Float(round6(radiance(lp))),
        );
        if let Some(ld) = levels[2] {
            set_override(
                ovs,
                "scene.disc_radiance",
                Value::Float(round6(radiance(ld))),
            );
        }
        set_override(
            ovs,
            "effects.pixel_noise.full_well_e",
            Value::Float(fw.round().max(1.0)),
        );
        set_override(
            ovs,
            "effects.pixel_noise.read_noise_e",
            Value::Float((read * 100.0).round() / 100.0),
        );
    }
    // How the measured σ follows the sensor's: the final scenario against one with every σ
    // 25 % larger (full well / c², read / c), rendered with the same noise streams.
    let sim = |o: &[Override]| {
        typed(o)
            .ok()
            .and_then(|s| simulated_stats(&s, frame, crop, corners, layout, kinds))
    };
    let c = 1.25;
    let mut scaled = ovs.to_vec();
    set_override(
        &mut scaled,
        "effects.pixel_noise.full_well_e",
        Value::Float((fw / (c * c)).round().max(1.0)),
    );
    set_override(
        &mut scaled,
        "effects.pixel_noise.read_noise_e",
        Value::Float((read / c * 100.0).round() / 100.0),
    );
    let mut sensitivity = [1.0, 1.0];
    let mut match_residual = [0.0, 0.0];
    let (s1, s2) = if match_noise {
        (sim(ovs), sim(&scaled))
    } else {
        (None, None)
    };
    if let (Some((_, s1)), Some((_, s2)), Some(li), Some(lp)) = (s1, s2, levels[0], levels[1]) {
        for m in 0..2 {
            let d = (s1[m] - target_sigmas[m]).abs();
            if d.is_finite() {
                match_residual[m] = d;
            }
        }
        let span = white - black;
        for (m, l) in [li, lp].into_iter().enumerate() {
            let s = ((l - black) / span).max(0.0);
            let pre_m = span * (s * fw + read * read).sqrt() / fw;
            let slope = (s2[m] - s1[m]) / ((c - 1.0) * pre_m);
            if slope.is_finite() {
                sensitivity[m] = slope.clamp(0.05, 2.0);
            }
        }
    }
    let span = white - black;
    let im = &mut cal.imaging;
    im.noise.sensitivity = sensitivity;
    im.noise.match_residual_dn = match_residual;
    im.black_level_dn = black;
    im.white_level_dn = white;
    im.noise.full_well_e = fw;
    im.noise.read_noise_e = read;
    im.noise.shot_resolved = resolved;
    im.noise.source.push_str(if match_noise {
        "; levels and electrons matched by rendering the calibrated scenario at a static frame and measuring it the same way"
    } else {
        "; levels matched by rendering the calibrated scenario at a static frame and measuring it the same way (the noise is not matched: not identifiable)"
    });
    if let (Some(li), Some(lp)) = (levels[0], levels[1]) {
        im.ink_radiance = ((li - black) / span).clamp(0.0, 1.0);
        im.paper_radiance = ((lp - black) / span).clamp(0.0, 1.0);
    }
    if let Some(ld) = levels[2] {
        im.disc_radiance = Some(((ld - black) / span).clamp(0.0, 1.0));
    }
}

pub(crate) fn round6(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}

/// Renders the calibrated scenario at the footage frame `frame` over the crop's window, writes
/// the overlay and returns the residual check.
/// The re-render comparison's window (the black square and half its white margin, inside the
/// crop and the render), the marker's centre and its corners' distance from it, px.
pub(crate) fn comparison_window(
    corners: &Corners,
    base: &Scenario,
    crop: &Crop,
    render: &crate::render::GrayImage,
) -> (PixelRect, (f64, f64), f64) {
    let m = &base.scene.marker;
    let (x0, y0, x1, y1) = corners_bbox_px(corners);
    let side = ((x1 - x0) + (y1 - y0)) / 2.0;
    let grow = 0.5 * side * m.white_margin_mm / m.size_mm;
    let win = PixelRect::new(
        (x0 - grow).floor() as i64,
        (y0 - grow).floor() as i64,
        ((x1 - x0) + 2.0 * grow).ceil() as usize + 1,
        ((y1 - y0) + 2.0 * grow).ceil() as usize + 1,
    )
    .intersect(&crop.rect)
    .intersect(&render.window);
    let centre = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    (win, centre, 0.5 * (x1 - x0).hypot(y1 - y0))
}

/// Per pixel of `win` that both hold: footage − render, and the render's change per unit of
/// each pose correction (shift x, shift y, rotation in rad and relative scale about `centre`),
/// from its central differences.
pub(crate) fn residual_rows(
    crop: &Crop,
    render: &crate::render::GrayImage,
    win: &PixelRect,
    (cx, cy): (f64, f64),
) -> Vec<PixelResidual> {
    let at = |x: i64, y: i64| render.get(x, y).map(f64::from);
    window_pixels(crop, render, win)
        .map(|(x, y, a, b)| {
            let grad = match (at(x + 1, y), at(x - 1, y), at(x, y + 1), at(x, y - 1)) {
                (Some(r), Some(l), Some(d), Some(u)) => Some((0.5 * (r - l), 0.5 * (d - u))),
                _ => None,
            };
            let (gx, gy) = grad.unwrap_or((0.0, 0.0));
            PixelResidual::new(a as f64 - b as f64, gx, gy, x as f64 - cx, y as f64 - cy)
        })
        .collect()
}

/// The pixels of `win` that both the footage `crop` and `render` hold, row by row: (x, y,
/// footage, render).
pub(crate) fn window_pixels<'a>(
    crop: &'a Crop,
    render: &'a crate::render::GrayImage,
    win: &PixelRect,
) -> impl Iterator<Item = (i64, i64, u8, u8)> + 'a {
    let view = crop.view();
    let (xs, ys) = (win.x0..win.x1(), win.y0..win.y1());
    ys.flat_map(move |y| xs.clone().map(move |x| (x, y)))
        .filter_map(move |(x, y)| {
            let a = crate::imagestats::pixel_at(&view, x, y)?;
            Some((x, y, a, render.get(x, y)?))
        })
}

fn render_check(
    scenario: &Scenario,
    cal: &Calibration,
    frame: usize,
    crop: &Crop,
    corners: &Corners,
    path: &Path,
    base: &Scenario,
) -> Result<ReRenderCheck, CalibrateJobError> {
    let rig =
        crate::pipeline::rig::Rig::new(scenario).map_err(|source| CalibrateJobError::Rig {
            path: path.to_path_buf(),
            source,
        })?;
    let times = rig.frame_times.as_slice();
    let k = frame.min(times.len().saturating_sub(1));
    let t_s = times.get(k).copied().unwrap_or(0.0);
    let scene = rig.animated();
    let req = FrameRequest {
        index: k as u64,
        t_s,
        window: crop.rect,
    };
    let full = render_frame(&scene, &rig.settings, &req);
    let mut clean_settings = rig.settings.clone();
    clean_settings.effects.pixel_noise.enabled = false;
    clean_settings.effects.compression.enabled = false;
    let clean = render_frame(&scene, &clean_settings, &req);
    // With the fitted compression, the codec's own distortion of the clean picture (block
    // edges, ringing) is part of what the model predicts for footage − clean render: it is
    // measured on the clean render coded at the fitted quality and added to the noise.
    let coded = rig.settings.effects.compression.enabled.then(|| {
        let mut coded_settings = rig.settings.clone();
        coded_settings.effects.pixel_noise.enabled = false;
        render_frame(&scene, &coded_settings, &req)
    });
    let (win, (cx, cy), half_diagonal_px) = comparison_window(corners, base, crop, &clean);
    let n = &cal.imaging.noise;
    let (li, lp) = (cal.imaging.ink_dn.value, cal.imaging.paper_dn.value);
    let (vi, vp) = (n.ink_sigma_dn.value.powi(2), n.paper_sigma_dn.value.powi(2));
    let var_at = |v: f64| {
        let f = if lp > li {
            ((v - li) / (lp - li)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        vi + f * (vp - vi)
    };
    let (mut vs, mut count) = (0.0, 0usize);
    for (x, y, _, b) in window_pixels(crop, &clean, &win) {
        vs += var_at(b as f64);
        if let Some(c) = coded.as_ref().and_then(|c| c.get(x, y)) {
            vs += (c as f64 - b as f64).powi(2);
        }
        count += 1;
    }
    let rows = residual_rows(crop, &clean, &win, (cx, cy));
    let aligned = align(&rows, half_diagonal_px);
    let count = count.max(1) as f64;
    // The structure tests: the aligned residual and the clean render over the window, against
    // a residual the fitted model draws (the render with its noise and codec − the clean one).
    let (mut residual, mut render, mut model) = (
        Grid::new(win.width, win.height),
        Grid::new(win.width, win.height),
        Grid::new(win.width, win.height),
    );
    for ((x, y, _, b), p) in window_pixels(crop, &clean, &win).zip(&rows) {
        let fit: f64 = aligned
            .correction
            .map_or(0.0, |c| (0..4).map(|k| p.jacobian[k] * c[k]).sum());
        let (gx, gy) = ((x - win.x0) as usize, (y - win.y0) as usize);
        residual.set(gx, gy, p.difference_dn - fit);
        render.set(gx, gy, b as f64);
        if let Some(f) = full.get(x, y) {
            model.set(gx, gy, f as f64 - b as f64);
        }
    }
    let structure = judge(
        residual::structure(&residual, &render),
        residual::structure(&model, &render),
    );
    let check = ReRenderCheck {
        frame,
        t_s,
        window: (win.x0, win.y0, win.width, win.height),
        residual_rms_dn: (aligned.aligned_ss / count).sqrt(),
        unaligned_rms_dn: (aligned.unaligned_ss / count).sqrt(),
        alignment: aligned
            .correction
            .map(|p| [p[0], p[1], p[2].to_degrees(), p[3]]),
        // The render is rounded to whole DN too: its rounding error (uniform, 1/12 DN², and
        // independent of the footage's noise) is part of footage − render. The fitted σ already
        // holds the footage's own rounding; the codec's distortion is in `vs` when compressed.
        expected_noise_dn: (vs / count + 1.0 / 12.0).sqrt(),
        structure,
    };
    let smooth = residual::smoothed(&residual, &render);
    super::calibrate_overlay::write_overlay(
        path,
        &super::calibrate_overlay::OverlayPanels {
            footage: crop,
            full: &full,
            clean: &clean,
            window: win,
            smoothed: &smooth,
        },
        &check,
    )?;
    Ok(check)
}
