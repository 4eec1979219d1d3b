//! The effect vocabulary as one typed registry: for each effect of the design brief, its
//! scenario section, its parameters (units, valid range, a sensible search range) and how to
//! switch it on and off on a [`Scenario`].
//!
//! `decompose`, `sweep` and `diagnose` use this registry; nothing else lists effects.
//!
//! Architecture invariant: [`Effect::switch_off`] and [`Effect::apply`] change only the
//! effect's own section (see [`Effect::section`]) plus, for the clearance dynamics, the switch
//! `dynamics.enabled` and the pin diameter; a scenario that passed validation stays valid
//! after `apply` with values inside [`ParamSpec::valid`] of an effect that can act on it
//! ([`Effect::can_act_on`]) (checked by a test over every effect).
//! Effects that share a switch (`backlash` and `overrotation` are both the clearance dynamics)
//! say so in [`Effect::shares_switch_with`]: switching one off switches off the other.

use super::Scenario;
use crate::estimate::Timebase;
use crate::mechanism::DriveSpeedConfig;
use crate::render::effects::Sinusoid;
use crate::timing::{TimingModel, VfrModel};

/// One effect of the vocabulary (`../shared/design/pipeline.md`), in the brief's order, with a
/// phone's video codec beside the stills' JPEG compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Effect {
    DriveSpeed,
    Backlash,
    Overrotation,
    DiscVibration,
    AxisRunout,
    CameraVibration,
    FrameTiming,
    Timebase,
    PixelNoise,
    OpticalBlur,
    MotionBlur,
    RollingShutter,
    LensDistortion,
    PerspectiveTilt,
    Compression,
    VideoCodec,
    Lighting,
}

/// Where an effect acts: on the motion, on the times, or on the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EffectKind {
    /// Changes the wheel's motion (visible in corner tracks).
    Mechanism,
    /// Changes frame times or the analysis time base (visible in tracks and timestamps).
    Timing,
    /// Changes where the marker appears (visible in corner tracks).
    Geometry,
    /// Changes pixel values only (visible in tracks only through detection error).
    Image,
}

/// One fitted parameter of an effect.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// Short name used in reports and `diagnosis.json` (`sigma_px`, `readout_s`, ...).
    pub name: &'static str,
    /// The scenario field it sets (dotted path, as in `geneva scenario show`).
    pub path: &'static str,
    pub unit: &'static str,
    /// Values the scenario accepts for this parameter (validation range).
    pub valid: (f64, f64),
    /// Range a fit searches: values a real rig can plausibly have.
    pub search: (f64, f64),
    /// Search on a logarithmic scale (strictly positive ranges).
    pub log_scale: bool,
    /// A clearly visible value, used to probe the effect's signature.
    pub probe: f64,
    /// The value at which this parameter does nothing (the self-check's weak level is measured
    /// from it).
    pub neutral: Neutral,
    /// A time spent inside one frame (an exposure, a rolling-shutter readout): no camera takes
    /// longer than its frame interval, so the search ends there ([`ParamSpec::search_on`]) and
    /// the scenario validator refuses more (`scenario::cross`).
    pub within_frame_interval: bool,
}

/// Where a parameter does nothing. Not always the search's lower end: a full well or a JPEG
/// quality does nothing at its upper end, a signed strength at zero, a tone curve at identity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Neutral {
    /// The search's lower end (amplitudes, clearances, blur widths, times, jitter, drops).
    SearchLow,
    /// The search's upper end (an effect that grows downwards).
    SearchHigh,
    /// A fixed value (zero for signed strengths; the identity tone curve).
    Value(f64),
    /// One frame interval of the footage's own rate.
    FrameInterval,
    /// The footage's own frame rate.
    FrameRate,
    /// No value: the parameter sets a form (a frequency), not a strength.
    Form,
}

impl Neutral {
    /// The neutral value of `spec` on a rig filmed at `fps_hz`; `None` for a form, or for a
    /// frame-based neutral when the rate is not positive.
    pub fn value(self, spec: &ParamSpec, fps_hz: f64) -> Option<f64> {
        match self {
            Neutral::SearchLow => Some(spec.search.0),
            Neutral::SearchHigh => Some(spec.search.1),
            Neutral::Value(v) => Some(v),
            Neutral::FrameInterval => (fps_hz > 0.0).then(|| 1.0 / fps_hz),
            Neutral::FrameRate => (fps_hz > 0.0).then_some(fps_hz),
            Neutral::Form => None,
        }
    }
}

/// Whether `a` and `b` are one point of a search over `search` (low, high): equal to within a
/// billionth of its span, what a search's clamping and arithmetic leave of an end it stopped at.
pub fn same_search_point(a: f64, b: f64, search: (f64, f64)) -> bool {
    (a - b).abs() <= 1e-9 * (search.1 - search.0).abs().max(f64::MIN_POSITIVE)
}

const fn param(
    name: &'static str,
    path: &'static str,
    unit: &'static str,
    valid: (f64, f64),
    search: (f64, f64),
    log_scale: bool,
    probe: f64,
) -> ParamSpec {
    ParamSpec {
        name,
        path,
        unit,
        valid,
        search,
        log_scale,
        probe,
        neutral: Neutral::SearchLow,
        within_frame_interval: false,
    }
}

impl ParamSpec {
    /// The same parameter, doing nothing at `neutral` instead of the search's lower end.
    const fn neutral_at(self, neutral: Neutral) -> ParamSpec {
        ParamSpec { neutral, ..self }
    }

    /// The same parameter, a time spent inside one frame ([`ParamSpec::within_frame_interval`]).
    const fn inside_one_frame(self) -> ParamSpec {
        ParamSpec {
            within_frame_interval: true,
            ..self
        }
    }

    /// The range a fit searches on footage filmed at `fps_hz`: the registry's, its upper end cut
    /// to one frame interval for a time spent inside one frame (a 60 fps rig's exposure cannot
    /// reach the registry's 40 ms). Unchanged when the rate is not positive or the interval
    /// falls at or below the lower end.
    pub fn search_on(&self, fps_hz: f64) -> (f64, f64) {
        let (lo, hi) = self.search;
        if self.within_frame_interval && fps_hz > 0.0 {
            let interval_s = 1.0 / fps_hz;
            if interval_s > lo {
                return (lo, hi.min(interval_s));
            }
        }
        (lo, hi)
    }
}

const DRIVE_SPEED: &[ParamSpec] = &[param(
    "variation_frac",
    "drive_speed.mid_rad_s",
    "–",
    (-0.9, 2.0),
    (-0.3, 0.3),
    false,
    -0.15,
)
.neutral_at(Neutral::Value(0.0))];
const BACKLASH: &[ParamSpec] = &[param(
    "clearance_mm",
    "mechanism.pin_diameter_mm",
    "mm",
    (1e-4, 5.0),
    (0.01, 1.0),
    true,
    0.5,
)];
const OVERROTATION: &[ParamSpec] = &[param(
    "mu_kinetic",
    "dynamics.mu_kinetic",
    "–",
    (0.0, 2.0),
    (0.003, 0.3),
    true,
    0.01,
)];
const DISC_VIBRATION: &[ParamSpec] = &[
    param(
        "amplitude_rad",
        "dynamics.disc_vibration.components[0].amplitude_rad",
        "rad",
        (0.0, 0.1),
        (1e-5, 1e-2),
        true,
        2e-3,
    ),
    param(
        "frequency_hz",
        "dynamics.disc_vibration.components[0].frequency_hz",
        "Hz",
        (0.0, 10000.0),
        (0.2, 200.0),
        true,
        7.0,
    )
    .neutral_at(Neutral::Form),
];
// The probe is 2 mm: the wobble a camera sees is what the circle fit through the marker's
// path does not absorb, and over the part of a wheel turn that a few seconds of footage cover
// (the wheel moves only during engagements) a 0.5 mm wobble (1 px on the self-check's rig)
// left no trace at all (an early build's `reports/diagnosis/`: radius residual 0.048 px real vs 0.060
// simulated).
const AXIS_RUNOUT: &[ParamSpec] = &[param(
    "amplitude_m",
    "dynamics.axis_runout.amplitude_m",
    "m",
    (0.0, 0.01),
    (1e-6, 3e-3),
    true,
    2e-3,
)];
/// Wobble cycles per wheel revolution of a runout switched on from an invisible form (1 or 0
/// cycles, no time-driven part): 2, an oval bearing seat or a shaft bent in two planes, the
/// lowest order that moves the marker against a rigid wheel.
pub const VISIBLE_RUNOUT_CYCLES_PER_REV: f64 = 2.0;

const CAMERA_VIBRATION: &[ParamSpec] = &[param(
    "rms_px",
    "effects.camera_vibration.random.x_rms_px",
    "px",
    (0.0, 1e4),
    (0.01, 10.0),
    true,
    1.0,
)];
const FRAME_TIMING: &[ParamSpec] = &[
    param(
        "jitter_s",
        "frame_timing.model.jitter_s",
        "s",
        (0.0, 0.01),
        (1e-6, 1e-3),
        true,
        5e-4,
    ),
    param(
        "first_interval_s",
        "frame_timing.model.first_interval_s",
        "s",
        (0.0, 10.0),
        (0.0, 0.2),
        false,
        0.055,
    )
    .neutral_at(Neutral::FrameInterval),
    param(
        "rate_error_ppm",
        "frame_timing.model.rate_error_ppm",
        "ppm",
        (-100_000.0, 100_000.0),
        (-20_000.0, 20_000.0),
        false,
        -4500.0,
    )
    .neutral_at(Neutral::Value(0.0)),
    param(
        "drop_probability",
        "frame_timing.model.drop_probability",
        "–",
        (0.0, 0.5),
        (0.0, 0.3),
        false,
        0.05,
    ),
    param(
        "pair_alternation_s",
        "frame_timing.model.pair_alternation_s",
        "s",
        (0.0, 0.01),
        (0.0, 3e-3),
        false,
        1e-3,
    ),
];
const TIMEBASE: &[ParamSpec] = &[param(
    "fps_hz",
    "estimator.timebase.fps_hz",
    "Hz",
    (0.1, 100_000.0),
    (1.0, 1000.0),
    true,
    30.0,
)
.neutral_at(Neutral::FrameRate)];
const PIXEL_NOISE: &[ParamSpec] = &[
    param(
        "full_well_e",
        "effects.pixel_noise.full_well_e",
        "e⁻",
        (1.0, 1e7),
        (50.0, 1e6),
        true,
        2000.0,
    )
    .neutral_at(Neutral::SearchHigh),
    param(
        "read_noise_e",
        "effects.pixel_noise.read_noise_e",
        "e⁻",
        (0.0, 1e4),
        (0.0, 5000.0),
        false,
        185.0,
    ),
];
const OPTICAL_BLUR: &[ParamSpec] = &[param(
    "sigma_px",
    "effects.optical_blur.sigma_px",
    "px",
    (0.0, 20.0),
    (0.05, 6.0),
    true,
    1.5,
)];
const MOTION_BLUR: &[ParamSpec] = &[param(
    "exposure_s",
    "effects.motion_blur.exposure_s",
    "s",
    (0.0, 1.0),
    (1e-4, 0.04),
    true,
    0.02,
)
.inside_one_frame()];
const ROLLING_SHUTTER: &[ParamSpec] = &[param(
    "readout_s",
    "effects.rolling_shutter.readout_s",
    "s",
    (0.0, 1.0),
    (5e-4, 0.05),
    true,
    0.03,
)
.inside_one_frame()];
const LENS_DISTORTION: &[ParamSpec] = &[param(
    "k1",
    "camera.lens_distortion.k1",
    "–",
    (-2.0, 2.0),
    (-0.6, 0.6),
    false,
    -0.3,
)
.neutral_at(Neutral::Value(0.0))];
const PERSPECTIVE_TILT: &[ParamSpec] = &[
    param(
        "tilt_x_deg",
        "camera.perspective_tilt.tilt_x_deg",
        "deg",
        (-80.0, 80.0),
        (-40.0, 40.0),
        false,
        20.0,
    )
    .neutral_at(Neutral::Value(0.0)),
    param(
        "tilt_y_deg",
        "camera.perspective_tilt.tilt_y_deg",
        "deg",
        (-80.0, 80.0),
        (-40.0, 40.0),
        false,
        0.0,
    )
    .neutral_at(Neutral::Value(0.0)),
];
const COMPRESSION: &[ParamSpec] = &[param(
    "quality",
    "effects.compression.quality",
    "–",
    (1.0, 100.0),
    (5.0, 98.0),
    false,
    30.0,
)
.neutral_at(Neutral::SearchHigh)];
// Bit/s rather than bits per pixel: the container states it and phones are specified by it.
// The search spans below a phone's worst (30 kbit/s, a 640×360 clip at 0.004 bit/px; from
// 100 kbit/s a fit of 250 kbit/s on that clip stopped at the end) to beyond its best
// (100 Mbit/s, a 4K clip at 0.4 bit/px and 720p at 3.6): the codec's artefacts fall with the
// bitrate on a log scale. The probe, 1 Mbit/s, smooths a 720p clip's noise visibly.
const VIDEO_CODEC: &[ParamSpec] = &[param(
    "bitrate_bps",
    "effects.video_codec.bitrate_bps",
    "bit/s",
    (1e4, 1e9),
    (3e4, 1e8),
    true,
    1e6,
)
.neutral_at(Neutral::SearchHigh)];
const LIGHTING: &[ParamSpec] = &[
    param(
        "black_level_dn",
        "effects.lighting.black_level_dn",
        "DN",
        (0.0, 255.0),
        (0.0, 200.0),
        false,
        90.0,
    )
    .neutral_at(Neutral::Value(0.0)),
    param(
        "white_level_dn",
        "effects.lighting.white_level_dn",
        "DN",
        (0.0, 255.0),
        (30.0, 255.0),
        false,
        170.0,
    )
    .neutral_at(Neutral::Value(255.0)),
    param(
        "gamma",
        "effects.lighting.gamma",
        "–",
        (0.1, 10.0),
        (0.3, 3.0),
        true,
        1.0,
    )
    .neutral_at(Neutral::Value(1.0)),
];

impl Effect {
    /// Every effect, in the brief's order.
    pub const ALL: [Effect; 17] = [
        Effect::DriveSpeed,
        Effect::Backlash,
        Effect::Overrotation,
        Effect::DiscVibration,
        Effect::AxisRunout,
        Effect::CameraVibration,
        Effect::FrameTiming,
        Effect::Timebase,
        Effect::PixelNoise,
        Effect::OpticalBlur,
        Effect::MotionBlur,
        Effect::RollingShutter,
        Effect::LensDistortion,
        Effect::PerspectiveTilt,
        Effect::Compression,
        Effect::VideoCodec,
        Effect::Lighting,
    ];

    /// The vocabulary's name (`pixel_noise`, ...), as used in scenarios, CSV and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Effect::DriveSpeed => "drive_speed",
            Effect::Backlash => "backlash",
            Effect::Overrotation => "overrotation",
            Effect::DiscVibration => "disc_vibration",
            Effect::AxisRunout => "axis_runout",
            Effect::CameraVibration => "camera_vibration",
            Effect::FrameTiming => "frame_timing",
            Effect::Timebase => "timebase",
            Effect::PixelNoise => "pixel_noise",
            Effect::OpticalBlur => "optical_blur",
            Effect::MotionBlur => "motion_blur",
            Effect::RollingShutter => "rolling_shutter",
            Effect::LensDistortion => "lens_distortion",
            Effect::PerspectiveTilt => "perspective_tilt",
            Effect::Compression => "compression",
            Effect::VideoCodec => "video_codec",
            Effect::Lighting => "lighting",
        }
    }

    /// The effect called `name` (the vocabulary's spelling).
    pub fn from_name(name: &str) -> Option<Effect> {
        Effect::ALL.into_iter().find(|e| e.name() == name.trim())
    }

    /// All names, comma separated (for messages).
    pub fn names() -> String {
        Effect::ALL.map(Effect::name).join(", ")
    }

    /// The scenario section that holds the effect's switch and parameters.
    pub fn section(self) -> &'static str {
        match self {
            Effect::DriveSpeed => "drive_speed",
            Effect::Backlash | Effect::Overrotation => "dynamics",
            Effect::DiscVibration => "dynamics.disc_vibration",
            Effect::AxisRunout => "dynamics.axis_runout",
            Effect::CameraVibration => "effects.camera_vibration",
            Effect::FrameTiming => "frame_timing.model",
            Effect::Timebase => "estimator.timebase",
            Effect::PixelNoise => "effects.pixel_noise",
            Effect::OpticalBlur => "effects.optical_blur",
            Effect::MotionBlur => "effects.motion_blur",
            Effect::RollingShutter => "effects.rolling_shutter",
            Effect::LensDistortion => "camera.lens_distortion",
            Effect::PerspectiveTilt => "camera.perspective_tilt",
            Effect::Compression => "effects.compression",
            Effect::VideoCodec => "effects.video_codec",
            Effect::Lighting => "effects.lighting",
        }
    }

    /// One line for reports.
    pub fn description(self) -> &'static str {
        match self {
            Effect::DriveSpeed => "crank speed varying within each engagement (ω1 profile)",
            Effect::Backlash => "pin–slot clearance: impacts and bouncing at entry and exit",
            Effect::Overrotation => "low bearing friction: the wheel coasts past the index",
            Effect::DiscVibration => "rotational oscillation of the wheel",
            Effect::AxisRunout => "wobble of the wheel centre",
            Effect::CameraVibration => "shake of the camera (rigid image motion)",
            Effect::FrameTiming => "variable frame timing (jitter, long first interval, drops)",
            Effect::Timebase => "analysis assumes a constant frame rate",
            Effect::PixelNoise => "shot and read noise",
            Effect::OpticalBlur => "lens/sensor blur (point-spread function)",
            Effect::MotionBlur => "exposure time integrates the motion",
            Effect::RollingShutter => "rows read out one after another",
            Effect::LensDistortion => "radial lens distortion",
            Effect::PerspectiveTilt => "camera not square to the disc",
            Effect::Compression => "JPEG compression of each frame",
            Effect::VideoCodec => "H.264/HEVC video coding of the clip (bitrate, GOP, B-frames)",
            Effect::Lighting => "ink, paper and background grey levels, gamma",
        }
    }

    pub fn kind(self) -> EffectKind {
        match self {
            Effect::DriveSpeed
            | Effect::Backlash
            | Effect::Overrotation
            | Effect::DiscVibration
            | Effect::AxisRunout => EffectKind::Mechanism,
            Effect::FrameTiming | Effect::Timebase => EffectKind::Timing,
            Effect::CameraVibration
            | Effect::RollingShutter
            | Effect::LensDistortion
            | Effect::PerspectiveTilt => EffectKind::Geometry,
            Effect::PixelNoise
            | Effect::OpticalBlur
            | Effect::MotionBlur
            | Effect::Compression
            | Effect::VideoCodec
            | Effect::Lighting => EffectKind::Image,
        }
    }

    /// Whether judging the effect needs the frames themselves (its main signature is in the
    /// pixels); from a corner track alone it can only be seen through detection error.
    pub fn needs_frames(self) -> bool {
        self.kind() == EffectKind::Image
    }

    /// Whether the effect can be switched on in `s` at all: a video codec codes 4:2:0, which
    /// needs an even frame width and height (`scenario::cross` refuses others).
    pub fn can_act_on(self, s: &Scenario) -> bool {
        match self {
            Effect::VideoCodec => s.camera.width_px % 2 == 0 && s.camera.height_px % 2 == 0,
            _ => true,
        }
    }

    /// Whether the effect, fitted, predicts the signed slow angle residual frame by frame, or its
    /// seeds' scatter holds it: what the held-out check of an explanation compares
    /// ([`crate::diagnose::holdout`]). The vibrations do not: their fits state an amplitude and a
    /// frequency, not the phase a slow sinusoid's waveform needs.
    pub fn predicts_slow_angle(self) -> bool {
        !matches!(self, Effect::DiscVibration | Effect::CameraVibration)
    }

    /// Whether the effect, switched on, bends the angle the estimator measures on exact corners
    /// away from σ·θ2 + c in a way the plain motion alignment misreads as crank phase or speed:
    /// the camera's geometry (a tilt, a lens off its centre), the wheel centre's wobble, or the
    /// wheel's dynamics (a clearance's late start, coasting). A diagnosis trial of such an effect
    /// refits the motion nuisance through it (`diagnose::camera_warp`).
    ///
    /// Disc vibration bends the angle too but is not listed: its phase is one of its fitted
    /// parameters, and a nuisance refit would absorb it.
    pub fn bends_the_aligned_angle(self) -> bool {
        matches!(
            self,
            Effect::PerspectiveTilt
                | Effect::LensDistortion
                | Effect::AxisRunout
                | Effect::Backlash
                | Effect::Overrotation
        )
    }

    /// Whether a diagnosis trial of the effect refits the motion nuisance (crank phase and speed,
    /// the marker's angle, the measured rotation centre): the effects that bend the aligned angle
    /// ([`Effect::bends_the_aligned_angle`]), and the crank speed's profile, which bends nothing
    /// on exact corners but changes the motion the nuisance was fitted with: the nominal's
    /// constant-speed alignment reads a crank that slows in each engagement as a slower crank at
    /// another phase, and a profile trial that kept that motion could not match the real angle.
    pub fn trial_refits_motion(self) -> bool {
        self.bends_the_aligned_angle() || self == Effect::DriveSpeed
    }

    /// Effects switched by the same scenario fields: switching one off switches off the other.
    pub fn shares_switch_with(self) -> &'static [Effect] {
        match self {
            Effect::Backlash => &[Effect::Overrotation],
            Effect::Overrotation => &[Effect::Backlash],
            _ => &[],
        }
    }

    /// The fitted parameters as a fit on footage filmed at `fps_hz` searches them: the registry's
    /// with [`ParamSpec::search_on`]'s range.
    pub fn params_on(self, fps_hz: f64) -> Vec<ParamSpec> {
        self.params()
            .iter()
            .map(|p| ParamSpec {
                search: p.search_on(fps_hz),
                ..*p
            })
            .collect()
    }

    /// The fitted parameters.
    pub fn params(self) -> &'static [ParamSpec] {
        match self {
            Effect::DriveSpeed => DRIVE_SPEED,
            Effect::Backlash => BACKLASH,
            Effect::Overrotation => OVERROTATION,
            Effect::DiscVibration => DISC_VIBRATION,
            Effect::AxisRunout => AXIS_RUNOUT,
            Effect::CameraVibration => CAMERA_VIBRATION,
            Effect::FrameTiming => FRAME_TIMING,
            Effect::Timebase => TIMEBASE,
            Effect::PixelNoise => PIXEL_NOISE,
            Effect::OpticalBlur => OPTICAL_BLUR,
            Effect::MotionBlur => MOTION_BLUR,
            Effect::RollingShutter => ROLLING_SHUTTER,
            Effect::LensDistortion => LENS_DISTORTION,
            Effect::PerspectiveTilt => PERSPECTIVE_TILT,
            Effect::Compression => COMPRESSION,
            Effect::VideoCodec => VIDEO_CODEC,
            Effect::Lighting => LIGHTING,
        }
    }

    /// Whether `values` hold the effect where it does nothing on a rig filmed at `fps_hz`: it has
    /// a parameter whose neutral is an end of its search (a blur's, a noise's, a JPEG quality's),
    /// and every parameter with a neutral sits at it (the forms are free). A fit clamped there
    /// found the data asking for less of the effect than the search allows.
    pub fn does_nothing_at(self, values: &[f64], fps_hz: f64) -> bool {
        let params = self.params_on(fps_hz);
        let has_search_end = params
            .iter()
            .any(|p| matches!(p.neutral, Neutral::SearchLow | Neutral::SearchHigh));
        has_search_end
            && values.len() == params.len()
            && params.iter().zip(values).all(|(p, &v)| {
                p.neutral
                    .value(p, fps_hz)
                    .is_none_or(|n| same_search_point(v, n, p.search))
            })
    }

    /// The values at which this effect, fitted on `nominal` filmed at `fps_hz`, would leave
    /// the nominal as it is, one per parameter in [`Self::params`] order; `None` where no single
    /// value does. On in the nominal: its stated values (a fit that lands there restates the
    /// nominal), forms excepted, and nothing for a frame timing the nominal takes from a log or
    /// a constant rate (the fitted model replaces it whole). Off: each parameter's neutral (a
    /// blur's lower end, a JPEG quality's upper end, a signed strength's zero, a first frame
    /// interval of one interval); a form has none, nor has an effect whose switch changes the
    /// rig whatever its values: a timebase at the footage's median rate still ignores its
    /// stamps, and an overrotation switches on the wheel dynamics with the nominal's clearance.
    pub fn nominal_values(self, nominal: &Scenario, fps_hz: f64) -> Vec<Option<f64>> {
        let params = self.params_on(fps_hz);
        if self.is_on(nominal) {
            let restated = match self {
                Effect::FrameTiming => matches!(nominal.frame_timing.model, TimingModel::Vfr(_)),
                // A constant-quality codec states no bitrate: `values` gives the probe.
                Effect::VideoCodec => nominal.effects.video_codec.bitrate_bps.is_some(),
                _ => true,
            };
            let values = self.values(nominal);
            return params
                .iter()
                .zip(values.iter().map(Some).chain(std::iter::repeat(None)))
                .map(|(p, v)| match (p.neutral, v) {
                    (Neutral::Form, _) => None,
                    (_, Some(&v)) if restated => Some(v),
                    _ => None,
                })
                .collect();
        }
        params
            .iter()
            .map(|p| match (self, p.neutral) {
                (Effect::Overrotation, _) | (_, Neutral::FrameRate | Neutral::Form) => None,
                _ => p.neutral.value(p, fps_hz),
            })
            .collect()
    }

    /// Whether the effect is on in `s`.
    pub fn is_on(self, s: &Scenario) -> bool {
        let fx = &s.effects;
        match self {
            Effect::DriveSpeed => !matches!(s.drive_speed, DriveSpeedConfig::Constant { .. }),
            Effect::Backlash | Effect::Overrotation => {
                s.dynamics.enabled && s.mechanism.slot_width_mm > s.mechanism.pin_diameter_mm
            }
            Effect::DiscVibration => {
                s.dynamics.disc_vibration.enabled
                    && s.dynamics
                        .disc_vibration
                        .components
                        .iter()
                        .any(|c| c.amplitude_rad != 0.0)
            }
            Effect::AxisRunout => {
                s.dynamics.axis_runout.enabled && s.dynamics.axis_runout.amplitude_m != 0.0
            }
            Effect::CameraVibration => fx.camera_vibration.enabled,
            Effect::FrameTiming => !matches!(s.frame_timing.model, TimingModel::Constant),
            Effect::Timebase => matches!(s.estimator.timebase, Timebase::ConstantFps { .. }),
            Effect::PixelNoise => fx.pixel_noise.enabled,
            Effect::OpticalBlur => fx.optical_blur.enabled && fx.optical_blur.sigma_px > 0.0,
            Effect::MotionBlur => fx.motion_blur.enabled && fx.motion_blur.exposure_s > 0.0,
            Effect::RollingShutter => {
                fx.rolling_shutter.enabled && fx.rolling_shutter.readout_s > 0.0
            }
            Effect::LensDistortion => s.camera.lens_distortion.enabled,
            Effect::PerspectiveTilt => s.camera.perspective_tilt.enabled,
            Effect::Compression => fx.compression.enabled,
            Effect::VideoCodec => fx.video_codec.enabled,
            Effect::Lighting => fx.lighting.enabled,
        }
    }

    /// Switches the effect off in `s` (and the effects it shares a switch with).
    pub fn switch_off(self, s: &mut Scenario) {
        let fx = &mut s.effects;
        match self {
            Effect::DriveSpeed => {
                let mean = mean_crank_speed_rad_s(&s.drive_speed);
                s.drive_speed = DriveSpeedConfig::Constant { omega1_rad_s: mean };
            }
            Effect::Backlash | Effect::Overrotation => s.dynamics.enabled = false,
            Effect::DiscVibration => s.dynamics.disc_vibration.enabled = false,
            Effect::AxisRunout => s.dynamics.axis_runout.enabled = false,
            Effect::CameraVibration => fx.camera_vibration.enabled = false,
            Effect::FrameTiming => s.frame_timing.model = TimingModel::Constant,
            Effect::Timebase => s.estimator.timebase = Timebase::Timestamps,
            Effect::PixelNoise => fx.pixel_noise.enabled = false,
            Effect::OpticalBlur => fx.optical_blur.enabled = false,
            Effect::MotionBlur => fx.motion_blur.enabled = false,
            Effect::RollingShutter => fx.rolling_shutter.enabled = false,
            Effect::LensDistortion => s.camera.lens_distortion.enabled = false,
            Effect::PerspectiveTilt => s.camera.perspective_tilt.enabled = false,
            Effect::Compression => fx.compression.enabled = false,
            Effect::VideoCodec => fx.video_codec.enabled = false,
            Effect::Lighting => fx.lighting.enabled = false,
        }
    }

    /// Copies the effect's whole section (switch and every field, not only the fitted
    /// parameters) from `from` into `to`: "this effect as `from` has it".
    pub fn copy_section(self, from: &Scenario, to: &mut Scenario) {
        let (f, t) = (&from.effects, &mut to.effects);
        match self {
            Effect::DriveSpeed => to.drive_speed = from.drive_speed.clone(),
            Effect::Backlash | Effect::Overrotation => {
                let (vib, runout) = (
                    to.dynamics.disc_vibration.clone(),
                    to.dynamics.axis_runout.clone(),
                );
                to.dynamics = from.dynamics.clone();
                to.dynamics.disc_vibration = vib;
                to.dynamics.axis_runout = runout;
                to.mechanism.pin_diameter_mm = from.mechanism.pin_diameter_mm;
                to.mechanism.slot_width_mm = from.mechanism.slot_width_mm;
            }
            Effect::DiscVibration => {
                to.dynamics.disc_vibration = from.dynamics.disc_vibration.clone()
            }
            Effect::AxisRunout => to.dynamics.axis_runout = from.dynamics.axis_runout.clone(),
            Effect::CameraVibration => t.camera_vibration = f.camera_vibration.clone(),
            Effect::FrameTiming => {
                to.frame_timing.model = from.frame_timing.model.clone();
                to.timing_log = from.timing_log.clone();
            }
            Effect::Timebase => to.estimator.timebase = from.estimator.timebase,
            Effect::PixelNoise => t.pixel_noise = f.pixel_noise.clone(),
            Effect::OpticalBlur => t.optical_blur = f.optical_blur.clone(),
            Effect::MotionBlur => t.motion_blur = f.motion_blur.clone(),
            Effect::RollingShutter => t.rolling_shutter = f.rolling_shutter.clone(),
            Effect::LensDistortion => {
                to.camera.lens_distortion = from.camera.lens_distortion.clone()
            }
            Effect::PerspectiveTilt => {
                to.camera.perspective_tilt = from.camera.perspective_tilt.clone()
            }
            Effect::Compression => t.compression = f.compression.clone(),
            Effect::VideoCodec => t.video_codec = f.video_codec.clone(),
            Effect::Lighting => t.lighting = f.lighting.clone(),
        }
    }

    /// The current values of the fitted parameters in `s` (whether or not the effect is on;
    /// a variant without the field gives the registry's probe value).
    pub fn values(self, s: &Scenario) -> Vec<f64> {
        let fx = &s.effects;
        let probes = || self.params().iter().map(|p| p.probe).collect::<Vec<f64>>();
        match self {
            Effect::DriveSpeed => match &s.drive_speed {
                DriveSpeedConfig::PolynomialPerEngagement {
                    end_rad_s,
                    mid_rad_s,
                } => {
                    vec![mid_rad_s / end_rad_s - 1.0]
                }
                _ => vec![0.0],
            },
            Effect::Backlash => {
                vec![(s.mechanism.slot_width_mm - s.mechanism.pin_diameter_mm).max(0.0)]
            }
            Effect::Overrotation => vec![s.dynamics.mu_kinetic],
            Effect::DiscVibration => match s.dynamics.disc_vibration.components.first() {
                Some(c) => vec![c.amplitude_rad, c.frequency_hz],
                None => probes(),
            },
            Effect::AxisRunout => vec![s.dynamics.axis_runout.amplitude_m],
            Effect::CameraVibration => {
                let r = &fx.camera_vibration.random;
                vec![(0.5 * (r.x_rms_px * r.x_rms_px + r.y_rms_px * r.y_rms_px)).sqrt()]
            }
            Effect::FrameTiming => match &s.frame_timing.model {
                TimingModel::Vfr(m) => vec![
                    m.jitter_s,
                    m.first_interval_s,
                    m.rate_error_ppm,
                    m.drop_probability,
                    m.pair_alternation_s,
                ],
                _ => vec![0.0, 0.0, 0.0, 0.0, 0.0],
            },
            Effect::Timebase => match s.estimator.timebase {
                Timebase::ConstantFps { fps_hz } => vec![fps_hz],
                Timebase::Timestamps => vec![s.frame_timing.fps],
            },
            Effect::PixelNoise => vec![fx.pixel_noise.full_well_e, fx.pixel_noise.read_noise_e],
            Effect::OpticalBlur => vec![fx.optical_blur.sigma_px],
            Effect::MotionBlur => vec![fx.motion_blur.exposure_s],
            Effect::RollingShutter => vec![fx.rolling_shutter.readout_s],
            Effect::LensDistortion => vec![s.camera.lens_distortion.k1],
            Effect::PerspectiveTilt => vec![
                s.camera.perspective_tilt.tilt_x_deg,
                s.camera.perspective_tilt.tilt_y_deg,
            ],
            Effect::Compression => vec![fx.compression.quality as f64],
            // A constant-quality codec states no bitrate: the probe, as for a missing field.
            Effect::VideoCodec => vec![fx.video_codec.bitrate_bps.unwrap_or(VIDEO_CODEC[0].probe)],
            Effect::Lighting => vec![
                fx.lighting.black_level_dn,
                fx.lighting.white_level_dn,
                fx.lighting.gamma,
            ],
        }
    }

    /// Switches the effect on in `s` with the fitted parameters `values` (in [`Self::params`]
    /// order, each clamped into its valid range); fields that are not fitted keep their values.
    /// Returns false (and leaves `s` unchanged) when `values` has the wrong length or a value is
    /// not finite.
    pub fn apply(self, s: &mut Scenario, values: &[f64]) -> bool {
        let specs = self.params();
        if values.len() != specs.len() || values.iter().any(|v| !v.is_finite()) {
            return false;
        }
        let v: Vec<f64> = values
            .iter()
            .zip(specs)
            .map(|(x, p)| x.clamp(p.valid.0, p.valid.1))
            .collect();
        let fx = &mut s.effects;
        match self {
            Effect::DriveSpeed => {
                let mean = mean_crank_speed_rad_s(&s.drive_speed);
                // Keep the mean over a crank turn close to the nominal mean: the engagement
                // part of the turn changes, so only `end` is taken from the mean.
                s.drive_speed = DriveSpeedConfig::PolynomialPerEngagement {
                    end_rad_s: mean,
                    mid_rad_s: mean * (1.0 + v[0]),
                };
            }
            Effect::Backlash => {
                s.dynamics.enabled = true;
                s.mechanism.pin_diameter_mm = (s.mechanism.slot_width_mm - v[0]).max(1e-3);
            }
            Effect::Overrotation => {
                s.dynamics.enabled = true;
                if s.mechanism.pin_diameter_mm >= s.mechanism.slot_width_mm {
                    // Over-rotation needs room between pin and slot: the seed rig's 0.5 mm.
                    s.mechanism.pin_diameter_mm = s.mechanism.slot_width_mm - 0.5;
                }
                let ratio = if s.dynamics.mu_kinetic > 0.0 {
                    (s.dynamics.mu_static / s.dynamics.mu_kinetic).max(1.0)
                } else {
                    1.0
                };
                s.dynamics.mu_kinetic = v[0];
                s.dynamics.mu_static = (v[0] * ratio).min(2.0);
            }
            Effect::DiscVibration => {
                let vib = &mut s.dynamics.disc_vibration;
                vib.enabled = true;
                let phase = vib.components.first().map_or(0.0, |c| c.phase_rad);
                vib.components = vec![crate::mechanism::VibrationComponent {
                    amplitude_rad: v[0],
                    frequency_hz: v[1],
                    phase_rad: phase,
                }];
            }
            Effect::AxisRunout => {
                let r = &mut s.dynamics.axis_runout;
                r.enabled = true;
                r.amplitude_m = v[0];
                if !r.is_visible() {
                    // An invisible form (see `AxisRunoutConfig::is_visible`) cannot explain
                    // anything: switch on the lowest-order wobble a camera sees.
                    r.cycles_per_wheel_rev = VISIBLE_RUNOUT_CYCLES_PER_REV;
                }
            }
            Effect::CameraVibration => {
                let cv = &mut fx.camera_vibration;
                cv.enabled = true;
                cv.x_px = Vec::<Sinusoid>::new();
                cv.y_px = Vec::new();
                cv.rotation_rad = Vec::new();
                cv.random.x_rms_px = v[0];
                cv.random.y_rms_px = v[0];
            }
            Effect::FrameTiming => {
                let mut m = VfrModel {
                    jitter_s: v[0],
                    first_interval_s: v[1],
                    rate_error_ppm: v[2],
                    drop_probability: v[3],
                    pair_alternation_s: v[4],
                };
                // Keep frames in order (the model's validation rule): shrink the alternation
                // and jitter together when they would exceed half an interval.
                let half_interval_s = 0.5 / m.actual_fps(s.frame_timing.fps);
                let spread_s = m.pair_alternation_s + 8.0 * m.jitter_s;
                if spread_s > 0.999 * half_interval_s {
                    let k = 0.999 * half_interval_s / spread_s;
                    m.pair_alternation_s *= k;
                    m.jitter_s *= k;
                }
                if m.first_interval_s != 0.0 {
                    m.first_interval_s = m.first_interval_s.max(half_interval_s);
                }
                s.frame_timing.model = TimingModel::Vfr(m);
            }
            Effect::Timebase => s.estimator.timebase = Timebase::ConstantFps { fps_hz: v[0] },
            Effect::PixelNoise => {
                fx.pixel_noise.enabled = true;
                fx.pixel_noise.full_well_e = v[0];
                fx.pixel_noise.read_noise_e = v[1];
            }
            Effect::OpticalBlur => {
                fx.optical_blur.enabled = true;
                fx.optical_blur.sigma_px = v[0];
            }
            Effect::MotionBlur => {
                fx.motion_blur.enabled = true;
                fx.motion_blur.exposure_s = v[0];
            }
            Effect::RollingShutter => {
                fx.rolling_shutter.enabled = true;
                fx.rolling_shutter.readout_s = v[0];
            }
            Effect::LensDistortion => {
                s.camera.lens_distortion.enabled = true;
                s.camera.lens_distortion.k1 = v[0];
            }
            Effect::PerspectiveTilt => {
                s.camera.perspective_tilt.enabled = true;
                s.camera.perspective_tilt.tilt_x_deg = v[0];
                s.camera.perspective_tilt.tilt_y_deg = v[1];
            }
            Effect::Compression => {
                fx.compression.enabled = true;
                fx.compression.quality = v[0].round().clamp(1.0, 100.0) as u8;
            }
            Effect::VideoCodec => {
                // The codec, group of pictures, B-frames and preset stay as stated (`calibrate`
                // reads them from the container): only the bitrate is fitted.
                fx.video_codec.enabled = true;
                fx.video_codec.bitrate_bps = Some(v[0]);
            }
            Effect::Lighting => {
                fx.lighting.enabled = true;
                let black = v[0].min(254.0);
                fx.lighting.black_level_dn = black;
                fx.lighting.white_level_dn = v[1].max(black + 1.0);
                fx.lighting.gamma = v[2];
            }
        }
        true
    }
}

/// Mean crank speed of a profile, rad/s (signed): the constant speed, the per-engagement
/// polynomial's ends (the speed outside engagements), or the table's time average.
pub fn mean_crank_speed_rad_s(d: &DriveSpeedConfig) -> f64 {
    match d {
        DriveSpeedConfig::Constant { omega1_rad_s } => *omega1_rad_s,
        DriveSpeedConfig::PolynomialPerEngagement { end_rad_s, .. } => *end_rad_s,
        DriveSpeedConfig::Table {
            t_s, omega1_rad_s, ..
        } => {
            if t_s.len() < 2 {
                return omega1_rad_s.first().copied().unwrap_or(1.55);
            }
            let mut area = 0.0;
            for k in 1..t_s.len() {
                area += 0.5 * (omega1_rad_s[k] + omega1_rad_s[k - 1]) * (t_s[k] - t_s[k - 1]);
            }
            area / (t_s[t_s.len() - 1] - t_s[0])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The trials that refit the motion nuisance are those that bend the aligned angle and the
    /// crank speed's profile; no image effect and no timing effect moves the crank.
    #[test]
    fn trials_that_refit_the_motion_are_the_bending_ones_and_the_speed_profile() {
        let refitting: Vec<&str> = Effect::ALL
            .iter()
            .filter(|e| e.trial_refits_motion())
            .map(|e| e.name())
            .collect();
        assert_eq!(
            refitting,
            [
                "drive_speed",
                "backlash",
                "overrotation",
                "axis_runout",
                "lens_distortion",
                "perspective_tilt"
            ]
        );
        for e in Effect::ALL {
            assert!(!(e.kind() == EffectKind::Image && e.trial_refits_motion()));
            assert!(!e.bends_the_aligned_angle() || e.trial_refits_motion());
        }
    }

    /// A nominal's codec is restated by its bitrate; one at a constant quality states none, and
    /// the probe `values` gives in its place is no nominal value.
    #[test]
    fn a_codec_nominal_restates_its_bitrate_only_when_it_states_one() {
        let mut s = crate::scenario::load_any("fast").unwrap();
        s.effects.video_codec.enabled = true;
        assert_eq!(Effect::VideoCodec.nominal_values(&s, 30.0), [None]);
        s.effects.video_codec.bitrate_bps = Some(2e6);
        assert_eq!(Effect::VideoCodec.nominal_values(&s, 30.0), [Some(2e6)]);
        s.effects.video_codec.enabled = false;
        assert_eq!(Effect::VideoCodec.nominal_values(&s, 30.0), [Some(1e8)]);
    }

    /// A video codec acts only on frames with even sides (4:2:0); every other effect on any.
    #[test]
    fn a_video_codec_acts_only_on_even_frames() {
        let mut s = crate::scenario::load_any("fast").unwrap();
        assert!(Effect::ALL.iter().all(|e| e.can_act_on(&s)));
        s.camera.width_px += 1;
        let cannot: Vec<Effect> = Effect::ALL
            .into_iter()
            .filter(|e| !e.can_act_on(&s))
            .collect();
        assert_eq!(cannot, [Effect::VideoCodec]);
        assert!(s.validate().is_empty(), "{:?}", s.validate());
        let mut coded = s.clone();
        Effect::VideoCodec.apply(&mut coded, &[1e6]);
        assert!(!coded.validate().is_empty());
    }

    #[test]
    fn names_round_trip_and_are_the_vocabulary() {
        for e in Effect::ALL {
            assert_eq!(Effect::from_name(e.name()), Some(e));
        }
        // The brief's vocabulary, spelled exactly, with a phone's video codec beside the
        // stills' JPEG compression.
        let brief = "drive_speed, backlash, overrotation, disc_vibration, axis_runout, \
                     camera_vibration, frame_timing, timebase, pixel_noise, optical_blur, \
                     motion_blur, rolling_shutter, lens_distortion, perspective_tilt, \
                     compression, video_codec, lighting";
        assert_eq!(Effect::names(), brief);
        assert_eq!(Effect::from_name("dynamics"), None);
    }

    #[test]
    fn apply_switches_on_keeps_the_scenario_valid_and_switch_off_switches_off() {
        for base in ["fast", "seed-internal-4k", "seed-external-4k"] {
            let s0 = crate::scenario::load_any(base).unwrap();
            for e in Effect::ALL {
                // The ranges a fit on this rig's footage searches: every value it can reach
                // must give a valid scenario (an exposure past the frame interval would not).
                for pick in [0.0, 0.5, 1.0] {
                    let values: Vec<f64> = e
                        .params_on(s0.frame_timing.fps)
                        .iter()
                        .map(|p| {
                            let (lo, hi) = p.search;
                            if p.log_scale {
                                (lo.ln() + pick * (hi.ln() - lo.ln())).exp()
                            } else {
                                lo + pick * (hi - lo)
                            }
                        })
                        .collect();
                    let mut s = s0.clone();
                    assert!(e.apply(&mut s, &values), "{base}: {}", e.name());
                    assert!(e.is_on(&s), "{base}: {} on after apply", e.name());
                    let problems = s.validate();
                    assert!(
                        problems.is_empty(),
                        "{base}: {} at {values:?}: {problems:?}",
                        e.name()
                    );
                    // Fitted values read back (compression rounds to an integer quality).
                    let back = e.values(&s);
                    for ((b, v), p) in back.iter().zip(&values).zip(e.params()) {
                        let tol = if p.name == "quality" {
                            0.5
                        } else {
                            1e-9 * v.abs().max(1.0)
                        };
                        assert!((b - v).abs() <= tol, "{}: {} {b} vs {v}", e.name(), p.name);
                    }
                    e.switch_off(&mut s);
                    assert!(!e.is_on(&s), "{base}: {} off", e.name());
                    for other in e.shares_switch_with() {
                        assert!(!other.is_on(&s), "{} shares its switch", other.name());
                    }
                    assert!(s.validate().is_empty());
                }
            }
        }
    }

    #[test]
    fn apply_touches_only_the_effects_section() {
        let s0 = crate::scenario::load_any("seed-internal-4k").unwrap();
        for e in Effect::ALL {
            let probe: Vec<f64> = e.params().iter().map(|p| p.probe).collect();
            let mut s = s0.clone();
            e.apply(&mut s, &probe);
            for other in Effect::ALL {
                if other == e || e.shares_switch_with().contains(&other) {
                    continue;
                }
                // An unrelated effect keeps its switch and values.
                assert_eq!(
                    other.is_on(&s),
                    other.is_on(&s0),
                    "{} moved {}",
                    e.name(),
                    other.name()
                );
                if !(e == Effect::DriveSpeed && other == Effect::DriveSpeed) {
                    assert_eq!(
                        other.values(&s),
                        other.values(&s0),
                        "{} moved {}",
                        e.name(),
                        other.name()
                    );
                }
            }
        }
    }

    #[test]
    fn copy_section_makes_the_effect_as_the_source_has_it() {
        let base = crate::scenario::load_any("seed-internal-4k").unwrap();
        let mut none = base.clone();
        for e in Effect::ALL {
            e.switch_off(&mut none);
        }
        for e in Effect::ALL {
            let mut s = none.clone();
            e.copy_section(&base, &mut s);
            assert_eq!(e.is_on(&s), e.is_on(&base), "{}", e.name());
            assert_eq!(e.values(&s), e.values(&base), "{}", e.name());
        }
    }

    #[test]
    fn bad_values_are_refused_without_change() {
        let s0 = crate::scenario::load_any("fast").unwrap();
        let mut s = s0.clone();
        assert!(!Effect::OpticalBlur.apply(&mut s, &[f64::NAN]));
        assert!(!Effect::OpticalBlur.apply(&mut s, &[1.0, 2.0]));
        assert_eq!(s, s0);
    }

    #[test]
    fn probe_and_search_ranges_lie_in_the_valid_range() {
        for e in Effect::ALL {
            for p in e.params() {
                assert!(
                    p.valid.0 <= p.search.0 && p.search.1 <= p.valid.1,
                    "{}",
                    p.name
                );
                assert!(p.search.0 <= p.probe && p.probe <= p.search.1, "{}", p.name);
                if p.log_scale {
                    assert!(p.search.0 > 0.0, "{}", p.name);
                }
            }
        }
    }

    /// Each strength's no-effect value is one a fit can reach (the weak level lies between it and
    /// the probe); only frequencies set a form and have none.
    #[test]
    fn neutral_values_lie_in_the_search_range_and_only_frequencies_have_none() {
        let fps_hz = 30.0;
        for e in Effect::ALL {
            for p in e.params() {
                match p.neutral.value(p, fps_hz) {
                    Some(v) => assert!(
                        p.search.0 <= v && v <= p.search.1,
                        "{}.{}: neutral {v} outside {:?}",
                        e.name(),
                        p.name,
                        p.search
                    ),
                    None => assert_eq!(p.unit, "Hz", "{}.{} has no neutral", e.name(), p.name),
                }
            }
        }
        let full_well = &Effect::PixelNoise.params()[0];
        assert_eq!(
            full_well.neutral.value(full_well, fps_hz),
            Some(full_well.search.1)
        );
        let first = &Effect::FrameTiming.params()[1];
        assert_eq!(
            first.neutral.value(first, 0.0),
            None,
            "no rate, no frame interval"
        );
    }

    #[test]
    fn an_invisible_runout_is_switched_on_in_a_visible_form() {
        let mut s = crate::scenario::load_any("fast").unwrap();
        assert!(
            !s.dynamics.axis_runout.is_visible(),
            "default: an eccentric axis"
        );
        Effect::AxisRunout.apply(&mut s, &[1e-4]);
        let r = &s.dynamics.axis_runout;
        assert!(r.enabled && r.amplitude_m == 1e-4 && r.is_visible());
        assert_eq!(r.cycles_per_wheel_rev, VISIBLE_RUNOUT_CYCLES_PER_REV);
        // A form the scenario states and a camera sees is kept.
        s.dynamics.axis_runout.cycles_per_wheel_rev = 3.0;
        Effect::AxisRunout.apply(&mut s, &[2e-4]);
        assert_eq!(s.dynamics.axis_runout.cycles_per_wheel_rev, 3.0);
        s.dynamics.axis_runout.cycles_per_wheel_rev = 1.0;
        s.dynamics.axis_runout.frequency_hz = 0.5;
        Effect::AxisRunout.apply(&mut s, &[2e-4]);
        assert_eq!(s.dynamics.axis_runout.cycles_per_wheel_rev, 1.0);
    }

    #[test]
    fn an_effect_does_nothing_only_where_every_neutral_holds() {
        // A JPEG quality clamped at the search's top: no compression worth the name.
        assert!(Effect::Compression.does_nothing_at(&[98.0], 30.0));
        assert!(!Effect::Compression.does_nothing_at(&[74.1], 30.0));
        // A blur at its search's lower end; a vibration's amplitude there, whatever its form.
        let (lo, _) = Effect::MotionBlur.params()[0].search;
        assert!(Effect::MotionBlur.does_nothing_at(&[lo], 30.0));
        let (a_lo, _) = Effect::DiscVibration.params()[0].search;
        assert!(Effect::DiscVibration.does_nothing_at(&[a_lo, 7.0], 30.0));
        assert!(!Effect::DiscVibration.does_nothing_at(&[2e-3, 7.0], 30.0));
        // Neutrals that are no search end: a timebase at the footage's own rate still changes the
        // schedule, and a lens at k1 = 0 is a fitted value, not a clamp.
        assert!(!Effect::Timebase.does_nothing_at(&[30.0], 30.0));
        assert!(!Effect::LensDistortion.does_nothing_at(&[0.0], 30.0));
        // The wrong number of values is never "nothing".
        assert!(!Effect::Compression.does_nothing_at(&[], 30.0));
    }

    #[test]
    fn nominal_values_are_the_stated_ones_when_on_and_the_neutral_strengths_when_off() {
        let mut s = crate::scenario::load_any("fast").unwrap();
        Effect::LensDistortion.switch_off(&mut s);
        Effect::OpticalBlur.switch_off(&mut s);
        Effect::Timebase.switch_off(&mut s);
        Effect::FrameTiming.switch_off(&mut s);
        Effect::DiscVibration.switch_off(&mut s);
        // Off: a signed strength at zero, a blur at its search's lower end.
        assert_eq!(Effect::LensDistortion.nominal_values(&s, 60.0), [Some(0.0)]);
        let blur_lo = Effect::OpticalBlur.params()[0].search.0;
        assert_eq!(
            Effect::OpticalBlur.nominal_values(&s, 60.0),
            [Some(blur_lo)]
        );
        // Off, with no single value that does nothing: a timebase at any rate ignores the
        // stamps, an overrotation brings the wheel dynamics, a vibration's frequency is free.
        assert_eq!(Effect::Timebase.nominal_values(&s, 60.0), [None]);
        assert!(!Effect::Overrotation.is_on(&s));
        assert_eq!(Effect::Overrotation.nominal_values(&s, 60.0), [None]);
        // A frame timing's first interval does nothing at one frame interval.
        let jitter_lo = Effect::FrameTiming.params()[0].search.0;
        assert_eq!(
            Effect::FrameTiming.nominal_values(&s, 60.0),
            [
                Some(jitter_lo),
                Some(1.0 / 60.0),
                Some(0.0),
                Some(0.0),
                Some(0.0)
            ]
        );
        let amp_lo = Effect::DiscVibration.params()[0].search.0;
        assert_eq!(
            Effect::DiscVibration.nominal_values(&s, 60.0),
            [Some(amp_lo), None]
        );
        // On: the nominal's stated values (a refit landing there restates the nominal).
        Effect::OpticalBlur.apply(&mut s, &[0.7]);
        assert_eq!(Effect::OpticalBlur.nominal_values(&s, 60.0), [Some(0.7)]);
        Effect::PixelNoise.apply(&mut s, &[12_000.0, 120.0]);
        assert_eq!(
            Effect::PixelNoise.nominal_values(&s, 60.0),
            [Some(12_000.0), Some(120.0)]
        );
        Effect::DiscVibration.apply(&mut s, &[2e-3, 7.0]);
        assert_eq!(
            Effect::DiscVibration.nominal_values(&s, 60.0),
            [Some(2e-3), None]
        );
        // On from a log: the fitted model replaces it whole, so no value restates it.
        s.frame_timing.model = TimingModel::Log(crate::timing::LogModel {
            file: "frames.log".into(),
            ..Default::default()
        });
        assert!(Effect::FrameTiming.is_on(&s));
        assert_eq!(Effect::FrameTiming.nominal_values(&s, 60.0), [None; 5]);
    }

    #[test]
    fn a_time_inside_one_frame_is_searched_up_to_the_frame_interval_only() {
        let exposure = Effect::MotionBlur.params()[0];
        let readout = Effect::RollingShutter.params()[0];
        // A 60 fps rig: 16.7 ms, below the registry's 40 ms and 50 ms.
        for p in [exposure, readout] {
            let (lo, hi) = p.search_on(60.0);
            assert_eq!(lo, p.search.0);
            assert!((hi - 1.0 / 60.0).abs() < 1e-15, "{}: {hi}", p.name);
        }
        // A 24 fps rig's 41.7 ms: the exposure keeps its 40 ms, the readout is cut.
        assert_eq!(exposure.search_on(24.0), exposure.search);
        assert!((readout.search_on(24.0).1 - 1.0 / 24.0).abs() < 1e-15);
        // No rate, or an interval at the lower end: the registry's range.
        assert_eq!(exposure.search_on(0.0), exposure.search);
        assert_eq!(exposure.search_on(1e5), exposure.search);
        // Parameters that are no time inside a frame keep theirs at any rate.
        for e in Effect::ALL {
            for p in e.params_on(60.0).iter().zip(e.params()) {
                if !p.1.within_frame_interval {
                    assert_eq!(p.0.search, p.1.search, "{}", p.1.name);
                }
            }
        }
    }
}
