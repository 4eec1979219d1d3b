//! Cross-field checks: values each valid on their own that together make a run impossible or
//! unbounded — a detector looking for another marker than the one drawn, an integration step
//! too long for the contact stiffness and wheel inertia, a disc that images larger than any
//! tessellation can follow. Run by [`super::Scenario::validate`], so `geneva scenario check`
//! reports them before any work.

use super::Scenario;
use crate::detect::parse_dictionary;
use crate::marker::Dictionary;
use crate::timing::TimingModel;
use crate::validation::{short, Problems};

/// Largest image radius of the disc, px: its outline is tessellated to a thousandth of a pixel,
/// so the vertex count grows as the square root of this (about 70,000 vertices at the limit).
pub const MAX_DISC_RADIUS_PX: f64 = 1e6;

/// Whether the detector's dictionary decodes markers drawn from `drawn` (the smaller ArUco
/// dictionaries are prefixes of the larger ones of the same bit size).
fn decodes(detector_dictionary: &str, drawn: Dictionary) -> bool {
    let Some(info) = parse_dictionary(detector_dictionary) else {
        return true; // an unknown name is reported by the detector's own validation
    };
    let family = |code: i32| (0..16).contains(&code).then_some(code / 4);
    let code = drawn.opencv_id();
    info.opencv_code == code || family(info.opencv_code).is_some_and(|f| Some(f) == family(code))
}

pub fn check(s: &Scenario, problems: &mut Problems) {
    let d = &s.detector;
    let m = &s.scene.marker;
    if usize::try_from(d.marker_id).ok() != Some(m.id) {
        problems.push(
            "detector.marker_id",
            format!(
                "the detector looks for marker {} but the scene draws scene.marker.id = {}; \
                 set both to the same id",
                d.marker_id, m.id
            ),
        );
    }
    if !decodes(&d.dictionary, m.dictionary) {
        problems.push(
            "detector.dictionary",
            format!(
                "`{}` cannot decode the drawn scene.marker.dictionary ({})",
                d.dictionary,
                m.dictionary.opencv_name()
            ),
        );
    }
    if usize::try_from(d.marker_border_bits).ok() != Some(m.border_bits) {
        problems.push(
            "detector.marker_border_bits",
            format!(
                "the detector expects a {}-cell border but scene.marker.border_bits = {}",
                d.marker_border_bits, m.border_bits
            ),
        );
    }
    let r = &s.scene.reference_marker;
    if let (true, Some(id)) = (r.enabled, d.reference_marker_id) {
        if usize::try_from(id).ok() != Some(r.id) {
            problems.push(
                "detector.reference_marker_id",
                format!(
                    "the detector looks for reference marker {id} but the scene draws \
                     scene.reference_marker.id = {}",
                    r.id
                ),
            );
        }
        if !decodes(&d.dictionary, r.dictionary) {
            problems.push(
                "scene.reference_marker.dictionary",
                format!(
                    "{} cannot be decoded by detector.dictionary `{}`",
                    r.dictionary.opencv_name(),
                    d.dictionary
                ),
            );
        }
    }
    if s.dynamics.enabled {
        let h_max = crate::mechanism::stable_step_limit_s(&s.mechanism, &s.dynamics);
        if s.dynamics.step_s > h_max {
            let d = &s.dynamics;
            let mut on = vec![format!(
                "dynamics.contact_stiffness_n_m = {}",
                short(d.contact_stiffness_n_m)
            )];
            if d.contact_model == crate::mechanism::ContactModel::Penalty {
                on.push(format!(
                    "dynamics.contact_damping_n_s_m = {}",
                    short(d.contact_damping_n_s_m)
                ));
            }
            if d.crank.model == crate::mechanism::CrankModel::Servo {
                on.push("the crank's inertia and servo (dynamics.crank)".into());
            }
            problems.push(
                "dynamics.step_s",
                format!(
                    "must be <= {} s for {} and the wheel's inertia (from \
                     dynamics.wheel_mass_kg = {} or dynamics.wheel_inertia_kg_m2), got {}",
                    short(h_max),
                    on.join(", "),
                    short(d.wheel_mass_kg),
                    short(d.step_s)
                ),
            );
        }
    }
    times_inside_one_frame(s, problems);
    let c = &s.effects.video_codec;
    if c.enabled && (s.camera.width_px % 2 == 1 || s.camera.height_px % 2 == 1) {
        problems.push(
            "effects.video_codec.enabled",
            format!(
                "a {}×{} px frame cannot be encoded in 4:2:0 (a phone's H.264 or HEVC): \
                 camera.width_px and camera.height_px must be even",
                s.camera.width_px, s.camera.height_px
            ),
        );
    }
    if let Ok(camera) = crate::camera::Camera::new(&s.camera) {
        let r_px = s.scene.disc_radius_mm / camera.image_scale_mm_per_px();
        if r_px.is_nan() || r_px > MAX_DISC_RADIUS_PX {
            problems.push(
                "scene.disc_radius_mm",
                format!(
                    "images at a radius of {} px at this camera's scale ({} mm/px); at most {} px",
                    short(r_px),
                    short(camera.image_scale_mm_per_px()),
                    short(MAX_DISC_RADIUS_PX)
                ),
            );
        }
    }
}

/// The frame interval the camera's clock runs at, s: the variable-rate model's actual rate, the
/// nominal otherwise (a timing log is read after validation; `geneva calibrate` writes its rate).
pub fn frame_interval_s(s: &Scenario) -> f64 {
    log_interval_s(s).unwrap_or_else(|| {
        let fps = match &s.frame_timing.model {
            TimingModel::Vfr(v) => v.actual_fps(s.frame_timing.fps),
            TimingModel::Constant | TimingModel::Log(_) => s.frame_timing.fps,
        };
        1.0 / fps
    })
}

/// The median interval of a timing log once it is read (`Scenario::timing_log`): the camera's
/// real rate, which a stale `frame_timing.fps` need not state.
fn log_interval_s(s: &Scenario) -> Option<f64> {
    match (&s.frame_timing.model, &s.timing_log) {
        (TimingModel::Log(_), Some(log)) => Some(crate::timing::median_interval_s(log.as_slice()))
            .filter(|d| d.is_finite() && *d > 0.0),
        _ => None,
    }
}

/// A time a camera spends inside one frame interval, as a scenario states it.
pub struct TimeInsideOneFrame {
    /// Whether its effect is switched on.
    pub on: bool,
    pub value_s: f64,
    /// The scenario field.
    pub field: &'static str,
    /// What the camera does for that long, for messages ("exposes a frame").
    pub what: &'static str,
}

/// The exposure and the rolling-shutter readout of `s`: the times no camera spends longer than
/// one frame interval on (checked here, capped by `geneva calibrate`).
pub fn times_inside_one_frame_of(s: &Scenario) -> [TimeInsideOneFrame; 2] {
    let fx = &s.effects;
    [
        TimeInsideOneFrame {
            on: fx.motion_blur.enabled,
            value_s: fx.motion_blur.exposure_s,
            field: "effects.motion_blur.exposure_s",
            what: "exposes a frame",
        },
        TimeInsideOneFrame {
            on: fx.rolling_shutter.enabled,
            value_s: fx.rolling_shutter.readout_s,
            field: "effects.rolling_shutter.readout_s",
            what: "reads a frame out",
        },
    ]
}

/// An exposure and a rolling-shutter readout each happen inside one frame interval: a camera
/// cannot expose a frame for longer than the time between two frames, nor take longer to read
/// it out, and a render that did would draw a frame no camera gives.
fn times_inside_one_frame(s: &Scenario, problems: &mut Problems) {
    // A timing log not read yet: its rate is judged once it is (`scenario::finish` validates
    // again), not on a `frame_timing.fps` that may be stale.
    if matches!(s.frame_timing.model, TimingModel::Log(_)) && s.timing_log.is_none() {
        return;
    }
    let interval_s = frame_interval_s(s);
    for TimeInsideOneFrame {
        on,
        value_s,
        field,
        what,
    } in times_inside_one_frame_of(s)
    {
        if on && value_s > interval_s * (1.0 + 1e-9) {
            let rate = match &s.frame_timing.model {
                TimingModel::Log(log) if log_interval_s(s).is_some() => {
                    format!("the median interval of the timing log {}", log.file)
                }
                _ => format!("at frame_timing.fps = {}", short(s.frame_timing.fps)),
            };
            problems.push(
                field,
                format!(
                    "{} s is longer than one frame interval ({:.3} ms, {rate}): no camera {what} \
                     for longer than the time between two frames; shorten it or lower the frame \
                     rate",
                    short(value_s),
                    1e3 * interval_s,
                ),
            );
        }
    }
}
