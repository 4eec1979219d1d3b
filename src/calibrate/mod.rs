//! Calibration of a scenario from footage (`geneva calibrate`): the fitting maths, pure (no I/O,
//! no OpenCV). The pipeline (`pipeline::calibrate`) reads the footage, detects the marker and
//! measures every frame with [`crate::imagestats`]; this module turns those per-frame
//! observations into fitted values with uncertainties ([`Calibration`]) and into a scenario that
//! extends the user's base ([`output`]).
//!
//! Every fitted value is a [`Fitted`]: the value and its expanded uncertainty U at about 95 %
//! coverage (k = 2 on the standard uncertainty from the fit, with a small floor for effects the
//! fit does not see). What is fitted, from what:
//!
//! - image scale (mm/px): marker side in px from edge-fitted corners (OpenCV's unrefined corners
//!   sit ~½ px inside) on static frames, against the known side in mm (`geometry`);
//! - rotation centre (px), marker radius (mm), marker orientation on the disc and its angle at
//!   the first frame (deg): circle fit of the four corner tracks (static poses merged), after
//!   undoing a measured perspective compression (`geometry`);
//! - sense of rotation, crank phase at the first frame and crank speed (and, when resolved, the
//!   per-engagement polynomial): least squares of the exact Geneva kinematics to the unwrapped
//!   marker angle (`motion`);
//! - grey levels, blur σ, noise (shot + read), compression: medians and fits over the per-frame
//!   image statistics (`imaging`). Noise is measured temporally on a static stretch when there
//!   is one, else on single frames by the weak-texture estimate only
//!   ([`crate::imagestats::weak_texture_noise`]); where that cannot tell noise from texture or
//!   from the camera's processing, the noise is reported not identifiable and the scenario
//!   carries the base's;
//! - the marker's appearance: its paper and ink as a texture mosaicked from the registered
//!   frames, levels near the edges (`appearance`);
//! - the marker's level by the wheel's angle (a glossy print reflecting the lamp), on the
//!   frames where it is at rest or slow (`marker_levels`);
//! - the light's drift over the footage (an auto-exposure, a lamp warming up): the marker's
//!   contrast over time, with an illumination gradient across its path fitted beside it
//!   (`exposure`);
//! - the re-render check: the calibrated scenario rendered at a footage frame, and the structure
//!   left in footage − render (`rerender`, `residual`).
//! - perspective tilt: the mean image-space metric of the marker's affine shape (aspect), with
//!   the tilt's sign from the size gradient across the image (`geometry`).
//!
//! The frame timing is the footage's own timestamps, replayed exactly by the calibrated scenario,
//! with the VFR model fitted by [`crate::timing::fit::fit_vfr`] reported beside them.

pub mod appearance;
mod blur_model;
pub mod codec;
pub mod exposure;
mod geometry;
mod imaging;
pub mod marker_levels;
mod motion;
pub mod noise_levels;
pub mod output;
pub mod rerender;
pub mod residual;
pub mod sharpening;
pub mod surroundings;

#[cfg(test)]
mod tests;

pub use geometry::{fit_geometry, GeometryFit, TiltFit};
pub use imaging::{
    fit_imaging, noise_electrons, sensor_sigma, spatial_sigma, BaseNoise, ImagingFit, NoiseFit,
};
pub use motion::{fit_motion, MotionFit, MotionInput};

use crate::imagestats::{
    Blockiness, EdgeProfile, JpegQuality, MarkerLevels, TemporalNoise, WeakTextureNoise,
};
use crate::timing::TimingFit;
use std::fmt;

/// A fitted value and its expanded uncertainty (≈ 95 % coverage).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fitted {
    pub value: f64,
    /// Half-width of the ≈ 95 % interval (k = 2).
    pub u95: f64,
}

impl Fitted {
    pub fn new(value: f64, u95: f64) -> Self {
        Self { value, u95 }
    }

    /// From a standard uncertainty σ: U = 2·√(σ² + floor²).
    pub fn from_sigma(value: f64, sigma: f64, floor: f64) -> Self {
        Self {
            value,
            u95: 2.0 * (sigma * sigma + floor * floor).sqrt(),
        }
    }

    /// True when `truth` lies within the interval.
    pub fn covers(&self, truth: f64) -> bool {
        (self.value - truth).abs() <= self.u95
    }

    /// The same interval through a monotone map (U from the mapped interval ends).
    pub fn map(&self, f: impl Fn(f64) -> f64) -> Fitted {
        let v = f(self.value);
        let a = f(self.value - self.u95);
        let b = f(self.value + self.u95);
        Fitted::new(v, (a - v).abs().max((b - v).abs()))
    }
}

impl fmt::Display for Fitted {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let digits = significant_decimals(self.u95);
        write!(f, "{:.*} ± {:.*}", digits, self.value, digits, self.u95)
    }
}

/// Decimals that show two significant digits of `u`.
pub(crate) fn significant_decimals(u: f64) -> usize {
    if !(u.is_finite() && u > 0.0) {
        return 4;
    }
    (1.0 - u.log10().floor()).clamp(0.0, 9.0) as usize
}

/// What the pipeline measured on one frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrameObservation {
    /// Frame index in the footage.
    pub frame: usize,
    /// Timestamp from the footage, s, relative to its first frame.
    pub t_s: f64,
    /// The disc marker's corners as detected (OpenCV order, px), if found.
    pub corners_px: Option<[[f64; 2]; 4]>,
    /// The static reference marker's corners, if configured and found.
    pub reference_px: Option<[[f64; 2]; 4]>,
    /// Levels and noise around the disc marker.
    pub levels: Option<MarkerLevels>,
    /// Outer-side edge fits of the disc marker (only on the frames chosen for them).
    pub edges: Vec<EdgeProfile>,
    /// Corners from the four fitted sides, when all four fitted.
    pub refined_px: Option<[[f64; 2]; 4]>,
    /// The marker moved less than the static threshold since the previous frame.
    pub static_pose: bool,
}

/// Temporal noise of one material measured on a run of static frames.
#[derive(Debug, Clone, PartialEq)]
pub struct TemporalSample {
    /// Which marker and material (`disc ink`, `reference paper`, …).
    pub what: String,
    pub noise: TemporalNoise,
}

/// One frame's weak-texture noise of the disc marker's ink and paper (`None`: the region holds
/// too few patches).
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialNoiseSample {
    pub frame: usize,
    pub ink: Option<WeakTextureNoise>,
    pub paper: Option<WeakTextureNoise>,
}

/// Everything the pipeline measured on the footage.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FootageStats {
    pub width_px: usize,
    pub height_px: usize,
    /// All frames in order (with or without a detection).
    pub frames: Vec<FrameObservation>,
    /// Levels of the reference marker on the frames where it was measured.
    pub reference_levels: Vec<MarkerLevels>,
    /// Edge fits on the reference marker.
    pub reference_edges: Vec<EdgeProfile>,
    /// Temporal noise on the longest static run.
    pub temporal: Vec<TemporalSample>,
    /// Temporal noise of ink, paper and surround on every static run of two frames or more,
    /// at each run's levels.
    pub level_noise: Vec<noise_levels::LevelNoise>,
    /// Weak-texture noise of single frames (measured when there is no static run).
    pub spatial_noise: Vec<SpatialNoiseSample>,
    /// 8-px blockiness of the frames where it was measured.
    pub blockiness: Vec<Blockiness>,
    /// JPEG quality estimates of those frames (`None`: no quantisation found).
    pub jpeg: Vec<Option<JpegQuality>>,
    /// The frame timing fit (≥ 5 frames).
    pub timing: Option<TimingFit>,
    /// The unsharp mask measured on the marker's edges (the edge fits above assume it when it
    /// is significant).
    pub sharpening: Option<sharpening::SharpeningFit>,
    /// The video codec read from the container (`None`: the footage is not a video; `Err`:
    /// why it could not be read).
    pub codec: Option<Result<codec::CodecReading, String>>,
}

impl FootageStats {
    /// The weak-texture noise estimates of material `m` (0 ink, 1 paper), frame by frame.
    pub fn weak_texture_noise(
        &self,
        m: usize,
    ) -> impl Iterator<Item = &crate::imagestats::WeakTextureNoise> {
        self.spatial_noise.iter().filter_map(move |s| {
            if m == 0 {
                s.ink.as_ref()
            } else {
                s.paper.as_ref()
            }
        })
    }
}

/// What the user asks for.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrateOptions {
    /// Calibrate image formation (and the marker's pose) from one frame, without motion.
    pub single_frame: bool,
}

/// Why the footage cannot be calibrated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrateError {
    #[error(
        "the marker (dictionary {dictionary}, id {id}) was not found in any of the {frames} frames"
    )]
    MarkerNotFound {
        dictionary: String,
        id: usize,
        frames: usize,
    },
    #[error("{0}")]
    Missing(String),
    #[error("{what}: {reason}")]
    Unresolved { what: String, reason: String },
}

/// The fitted rig.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    pub frames: usize,
    pub detected_frames: usize,
    pub geometry: GeometryFit,
    /// `None` in single-frame mode.
    pub motion: Option<MotionFit>,
    pub imaging: ImagingFit,
    pub timing: Option<TimingFit>,
    /// The marker texture measured from the footage, when one was written.
    pub appearance: Option<appearance::AppearanceRecord>,
    /// The marker's level by wheel angle, when measured (written when it shows one).
    pub marker_levels: Option<marker_levels::LevelTable>,
    /// The noise by grey level against the electron model, when measured (drawn when it shows
    /// one).
    pub noise_levels: Option<noise_levels::NoiseLevelFit>,
    /// The video codec read from the container, when the footage is a video that names one.
    pub codec: Option<codec::CodecReading>,
    /// How the disc around the marker and the background are drawn (sentences for the report;
    /// empty: both uniform).
    pub surroundings: Vec<String>,
    /// Things the user should know (assumptions, effects that were not resolved).
    pub notes: Vec<String>,
}

/// Fits the rig described by `stats`, for the marker and mechanism of `base`.
pub fn calibrate(
    base: &crate::scenario::Scenario,
    stats: &FootageStats,
    options: &CalibrateOptions,
) -> Result<Calibration, CalibrateError> {
    let detected = stats
        .frames
        .iter()
        .filter(|f| f.corners_px.is_some())
        .count();
    if detected == 0 {
        return Err(CalibrateError::MarkerNotFound {
            dictionary: base.scene.marker.dictionary.opencv_name(),
            id: base.scene.marker.id,
            frames: stats.frames.len(),
        });
    }
    if !options.single_frame && stats.frames.len() < 2 {
        return Err(CalibrateError::Missing(format!(
            "the motion (rotation centre, crank phase and speed) needs several frames, the footage \
             has {}; pass --single-frame to calibrate the image formation only",
            stats.frames.len()
        )));
    }
    let mut notes = Vec::new();
    let geometry = fit_geometry(base, stats, options.single_frame, &mut notes)?;
    let motion = if options.single_frame {
        None
    } else {
        let input = MotionInput::from_geometry(&geometry, base)?;
        Some(fit_motion(&input, &mut notes)?)
    };
    let imaging = fit_imaging(stats, &BaseNoise::of(base), &mut notes)?;
    match &stats.codec {
        Some(Ok(r)) => notes.push(format!(
            "video codec: {}; written switched off in [effects.video_codec]: the noise, blur and \
             levels above were measured on the decoded footage and already hold what the codec \
             did to them",
            r.how
        )),
        Some(Err(why)) => notes.push(format!("video codec: not read from the container: {why}")),
        None => {}
    }
    Ok(Calibration {
        frames: stats.frames.len(),
        detected_frames: detected,
        geometry,
        motion,
        imaging,
        timing: stats.timing.clone(),
        appearance: None,
        marker_levels: None,
        noise_levels: None,
        surroundings: Vec::new(),
        codec: stats.codec.clone().and_then(Result::ok),
        notes,
    })
}
