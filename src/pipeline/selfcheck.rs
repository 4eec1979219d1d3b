//! The diagnosis self-check: footage with a known cause, rendered by the project's renderer,
//! diagnosed against a nominal that lacks the cause, and scored
//! ([`crate::diagnose::scoring`]).
//!
//! Cases (see [`cases`]):
//! - **withheld**: one effect of the vocabulary on in the data at a strong level (the registry's
//!   probe value, clearly visible) or a weak one (30 % of the way from the bottom of its search
//!   range to the probe, on the parameter's scale), the nominal the same rig with it off;
//! - **null**: nothing withheld; the data differ from the nominal only by nuisance (crank phase
//!   and speed, rotation centre, marker angle), seeds and, in half of them, by real phone frame
//!   timing (the seed's `showinfo` logs, which the nominal reads as the footage's own timestamps);
//! - **two causes at once**: two effects of a fixed list of pairs a real rig has together
//!   ([`withheld_pairs`]), both at the strong level, both off in the nominal;
//! - **out of vocabulary**: mains-light flicker (the frame's gain modulated at the beat of 100 Hz
//!   light with the frame rate: no effect of the vocabulary draws it), a withheld effect that
//!   `--effects` excludes from the candidates, and novel effects no candidate models
//!   ([`crate::render::novel`]: a marker creeping on the wheel, a mount that steps, autofocus
//!   breathing and hunting, a glare, a cable in front of the marker, duplicated frames,
//!   rolling-shutter banding).
//!
//! Every case perturbs the data's nuisance by a seeded draw ([`perturb_nuisance`]), so the
//! alignment is exercised in every case, and its rendering within what two renderers of one rig
//! differ by ([`perturb_rendering`]), so the nominal is never the data's exact twin and the
//! model tolerances of the gap map are tested for robustness, not only on this renderer.
//!
//! A case's frames are deleted once diagnosed (they are reproducible from the case); set
//! `GENEVA_KEEP_FRAMES` to keep them for inspection.

use super::diagnose::{diagnose, DiagnoseError, DiagnoseOptions, Diagnosis};
use crate::diagnose::scoring::{pct, score, CaseOutcome, Expectation, PairMember, Rate};
use crate::errors::FileError;
use crate::pipeline::analyze::Source;
use crate::pipeline::render_job::{render_job, RenderJob, Renderer};
use crate::render::novel::Novel;
use crate::scenario::effects::{Effect, ParamSpec};
use crate::scenario::Scenario;
use crate::shard::{Manifest, Study, UnitDirs};
use crate::timing::{LogModel, TimingModel};
use rand::Rng;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Strength of a withheld effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    Strong,
    Weak,
    /// The strong level's strength in a form the candidate does not parametrise
    /// ([`apply_other_form`]); only effects that have one.
    OtherForm,
}

/// A perturbation of the footage after rendering.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PostProcess {
    None,
    /// Frame gain × (1 + amplitude·sin(2π·beat·t)): mains flicker aliased by the frame rate.
    Flicker {
        amplitude_frac: f64,
        beat_hz: f64,
    },
    /// The footage's timestamps replaced by k / fps (a recorder that stamps a constant rate).
    ConstantRateStamps {
        fps_hz: f64,
    },
    /// An effect outside the vocabulary, one of [`crate::render::novel::KINDS`], at the strength
    /// [`novel_effect`] sets on the case's rig.
    Novel {
        kind: &'static str,
    },
}

/// One self-check case.
#[derive(Debug, Clone)]
pub struct Case {
    pub name: String,
    pub expectation: Expectation,
    /// The rig that makes the footage.
    pub data: Scenario,
    /// The rig as the diagnosis is told it is.
    pub nominal: Scenario,
    pub post: PostProcess,
    /// Candidate restriction (`--effects`).
    pub effects: Option<Vec<Effect>>,
    /// The withheld effects (one, or two in a pair case) and their true parameter values;
    /// empty when the case has none the candidates parametrise.
    pub truths: Vec<(Effect, Vec<f64>)>,
    /// Which renderer draws the footage (the nominal is always simulated by the project's own).
    pub renderer: Renderer,
}

/// Parameter values of a withheld effect at `level` on a rig filmed at `fps_hz`: the strong
/// probe, or, near the limit, 0.3 of the way from the value at which the parameter does nothing
/// ([`neutral_value`]) to the probe, log-spaced where the parameter is.
///
/// The timebase's parameter is the rate the footage is stamped at, the rig's own `fps_hz` at
/// every level: its strength is how far the schedule the frames were taken on strays from that
/// rate ([`timebase_schedule`]). (A weak level on the stamp rate itself, 30^0.3 ≈ 2.8 fps for
/// frames taken at 30, is no camera's clock and no detection limit; and the registry's probe,
/// 30 fps, stamped a second rig's 60 fps frames at half their rate, a time scale of 2 that the
/// case did not mean to test.)
pub fn level_values(effect: Effect, level: Level, fps_hz: f64) -> Vec<f64> {
    if effect == Effect::Timebase {
        return vec![fps_hz; effect.params().len()];
    }
    effect
        .params()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let probe = probe_on_rig(p, fps_hz);
            let from = match level {
                Level::Strong | Level::OtherForm => return probe,
                Level::Weak => match neutral_value(effect, i, fps_hz) {
                    Some(from) => from,
                    None => return probe,
                },
            };
            if p.log_scale && from > 0.0 && probe > 0.0 {
                from * (probe / from).powf(0.3)
            } else {
                from + 0.3 * (probe - from)
            }
        })
        .collect()
}

/// Share of a frame interval that a video frame's exposure or rolling-shutter readout may take
/// in a strong case: both happen within one frame interval, less the sensor's blanking.
pub const MAX_FRAME_INTERVAL_SHARE: f64 = 0.9;

/// The registry's strong probe of parameter `p` as a rig filmed at `fps_hz` can have it: a time
/// inside one frame ([`ParamSpec::within_frame_interval`], an exposure or a readout) longer than
/// [`MAX_FRAME_INTERVAL_SHARE`] of a frame interval is cut to it. The probes (20 ms, 30 ms) fit
/// the 30 fps rigs they were set on; a second rig at 60 fps took 20 ms exposures 16.7 ms apart,
/// which no video camera does (the scenario validator now refuses it), and half the frames of
/// its drive were lost.
fn probe_on_rig(p: &ParamSpec, fps_hz: f64) -> f64 {
    if p.within_frame_interval && fps_hz > 0.0 {
        p.probe.min(MAX_FRAME_INTERVAL_SHARE / fps_hz)
    } else {
        p.probe
    }
}

/// The value at which parameter `index` of `effect` does nothing, on a rig filmed at `fps_hz`
/// (the registry's [`ParamSpec::neutral`](crate::scenario::effects::ParamSpec::neutral)): the
/// weak level is measured from it. The search's lower end for strengths that grow from
/// there (amplitudes, clearances, blur widths, exposure and readout times, jitter, drops); zero
/// for signed strengths (a speed variation, a clock's rate error, a lens's k1, a tilt); a frame
/// interval for the first interval; the other end for a full well and a JPEG quality, whose
/// effect grows downwards; the identity tone curve for the lighting. `None` for a parameter
/// that sets a form, not a strength (a vibration's frequency): near the limit it keeps the
/// probe's.
///
/// Measured from the search's lower end instead, 7 of the 15 "near the limit" cases were as
/// strong as the strong ones or stronger: a full well of 151 e⁻ (the strong probe's is 2000), a
/// k1 of −0.51 (−0.3), a tilt of (−22°, −28°) (20°, 0°), a JPEG quality of 12 (30), a speed
/// variation of −0.255 (−0.15), a clock 15 350 ppm off (4 500), a white level of 72 DN and a
/// gamma of 0.43 (170 DN, 1.0); and those were the cases the near-limit figure counted as found.
pub fn neutral_value(effect: Effect, index: usize, fps_hz: f64) -> Option<f64> {
    let p = effect.params().get(index)?;
    p.neutral.value(p, fps_hz)
}

/// The schedule the frames of a withheld-timebase case are taken on: the seed's phone (the VFR
/// model's defaults: −4500 ppm, a 55 ms first interval) when strong; when weak, 0.3 of its
/// departure from a constant `fps` (−1350 ppm, the first interval 6.6 ms longer than a frame),
/// as the other weak levels sit 0.3 of the way from the value at which they do nothing to the
/// probe ([`level_values`]).
pub fn timebase_schedule(level: Level, fps: f64) -> crate::timing::VfrModel {
    let phone = crate::timing::VfrModel::default();
    match level {
        Level::Strong | Level::OtherForm => phone,
        Level::Weak => {
            let interval_s = 1.0 / fps;
            crate::timing::VfrModel {
                rate_error_ppm: 0.3 * phone.rate_error_ppm,
                first_interval_s: interval_s + 0.3 * (phone.first_interval_s - interval_s),
                ..phone
            }
        }
    }
}

/// Puts `effect` (already applied at its strong values) into a form its candidate does not
/// parametrise, as another renderer or a real rig would have it; false when the effect has no
/// such form here. The candidates fit one form each (a runout of 2 cycles per wheel revolution
/// at phase 0, a random shake, one vibration mode, a k1 lens): these cases check that a
/// diagnosis still names the effect when the data's form differs.
pub fn apply_other_form(effect: Effect, s: &mut Scenario) -> bool {
    use crate::render::effects::{Sinusoid, VideoCodec};
    match effect {
        Effect::AxisRunout => {
            let r = &mut s.dynamics.axis_runout;
            r.cycles_per_wheel_rev = 3.0;
            r.phase_rad = 1.1;
        }
        Effect::CameraVibration => {
            // A stand's two bending modes instead of a band-limited random shake.
            let cv = &mut s.effects.camera_vibration;
            cv.random.x_rms_px = 0.0;
            cv.random.y_rms_px = 0.0;
            cv.x_px = vec![Sinusoid {
                amplitude: 1.2,
                frequency_hz: 6.5,
                phase_rad: 0.3,
            }];
            cv.y_px = vec![Sinusoid {
                amplitude: 0.8,
                frequency_hz: 11.0,
                phase_rad: 1.0,
            }];
        }
        Effect::DiscVibration => {
            let v = &mut s.dynamics.disc_vibration;
            let Some(first) = v.components.first().cloned() else {
                return false;
            };
            v.components = vec![
                crate::mechanism::VibrationComponent {
                    frequency_hz: 4.0,
                    ..first.clone()
                },
                crate::mechanism::VibrationComponent {
                    amplitude_rad: 0.5 * first.amplitude_rad,
                    frequency_hz: 17.0,
                    phase_rad: 2.0,
                },
            ];
        }
        Effect::LensDistortion => {
            // Pincushion with a fourth-order term, where the candidate fits k1 alone.
            let l = &mut s.camera.lens_distortion;
            l.k1 = 0.2;
            l.k2 = 0.15;
        }
        Effect::PerspectiveTilt => {
            let t = &mut s.camera.perspective_tilt;
            t.tilt_x_deg = -8.0;
            t.tilt_y_deg = 15.0;
        }
        Effect::VideoCodec => {
            // HEVC where the candidate codes with the nominal's codec (H.264 by default).
            let c = &mut s.effects.video_codec;
            c.codec = match c.codec {
                VideoCodec::H264 => VideoCodec::Hevc,
                VideoCodec::Hevc => VideoCodec::H264,
            };
        }
        _ => return false,
    }
    true
}

/// Moves the data's nuisance by a seeded draw: crank phase ±0.2 rad, mean speed ±1.5 %, rotation
/// centre ±1.5 px, marker angle on the disc ±3°.
pub fn perturb_nuisance(s: &mut Scenario, seed: u64) {
    let mut r = crate::rng::stream(seed, crate::rng::Stream::DiagnoseNuisance, 1);
    let mut u = |a: f64| a * (2.0 * r.gen::<f64>() - 1.0);
    let start = s.mechanism.theta1_start_rad.unwrap_or(0.0);
    s.mechanism.theta1_start_rad = Some(start + u(0.2));
    s.drive_speed = crate::diagnose::align::scale_drive(&s.drive_speed, 1.0 + u(0.015));
    let centre = s.camera.rotation_centre_px.unwrap_or([
        s.camera.width_px as f64 / 2.0,
        s.camera.height_px as f64 / 2.0,
    ]);
    s.camera.rotation_centre_px = Some([centre[0] + u(1.5), centre[1] + u(1.5)]);
    s.scene.marker.angle_on_disc_deg += u(3.0);
}

/// Moves the data's rendering by a seeded draw within what two renderers of the same rig may
/// differ by with no effect at work: the edge profile (optical blur σ ±15 %, the size of
/// anti-aliasing and edge-model differences), the tone curve (black level ±3 DN, white level
/// ±4 DN, gamma ±4 %) and the sensor (full well and read noise ±10 %). Only effects already on
/// in the data are moved; a withheld effect is applied afterwards, so its own values stand.
/// The diagnosis is told none of this: it is the "nominal that differs from reality in small
/// ways that are no effect" every real comparison has.
pub fn perturb_rendering(s: &mut Scenario, seed: u64) {
    let mut r = crate::rng::stream(seed, crate::rng::Stream::DiagnoseNuisance, 2);
    let mut u = |a: f64| a * (2.0 * r.gen::<f64>() - 1.0);
    let (blur, black, white, gamma, well, read) =
        (u(0.15), u(3.0), u(4.0), u(0.04), u(0.1), u(0.1));
    let fx = &mut s.effects;
    if fx.optical_blur.enabled {
        fx.optical_blur.sigma_px *= 1.0 + blur;
    }
    if fx.lighting.enabled {
        fx.lighting.black_level_dn = (fx.lighting.black_level_dn + black).clamp(0.0, 250.0);
        fx.lighting.white_level_dn =
            (fx.lighting.white_level_dn + white).clamp(fx.lighting.black_level_dn + 5.0, 255.0);
        fx.lighting.gamma *= 1.0 + gamma;
    }
    if fx.pixel_noise.enabled {
        fx.pixel_noise.full_well_e *= 1.0 + well;
        fx.pixel_noise.read_noise_e *= 1.0 + read;
    }
}

/// The effects a withheld case is made of: every effect of the vocabulary except the one that
/// only shares another's switch (`overrotation` is `backlash`'s contact dynamics seen at exit).
pub fn withheld_effects() -> Vec<Effect> {
    Effect::ALL
        .iter()
        .copied()
        .filter(|e| *e != Effect::Overrotation)
        .collect()
}

/// A phone's frame-timing log, loaded.
#[derive(Debug, Clone)]
pub struct PhoneLog {
    pub path: PathBuf,
    pub timestamps: crate::timing::Timestamps,
}

/// The seed's phone logs (`../shared/real/phone-frame-timing/*.showinfo.log`) found next to the
/// repository, sorted and loaded; a log that does not parse is an error naming it (a null case
/// silently without real timing would test less than it says).
pub fn phone_logs(repo: &Path) -> Result<Vec<PhoneLog>, DiagnoseError> {
    let dir = repo.join("../shared/real/phone-frame-timing");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.to_string_lossy().ends_with(".showinfo.log"))
                .collect()
        })
        .unwrap_or_default();
    paths.sort();
    paths
        .into_iter()
        .map(|path| {
            let timestamps = match crate::io::timing_log::read_timing_log(&path, None) {
                Ok(t) => t,
                Err(source) => return Err(DiagnoseError::PhoneLog { path, source }),
            };
            Ok(PhoneLog { path, timestamps })
        })
        .collect()
}

/// Size of a self-check.
#[derive(Debug, Clone)]
pub struct SuitePlan {
    pub effects: Vec<Effect>,
    pub levels: Vec<Level>,
    pub seeds_per_case: usize,
    pub null_cases: usize,
    pub flicker_cases: usize,
    pub excluded_cases: usize,
    /// Two-effect cases, taking [`withheld_pairs`] in order (and round again past its end).
    pub pair_cases: usize,
    /// Novel-effect cases, taking [`crate::render::novel::KINDS`] in order (and round again).
    pub novel_cases: usize,
    /// Which renderer draws every case's footage: the project's own, or the independent one
    /// (`render::independent`), whose anti-aliasing, compositing, blur kernel and noise differ
    /// from the nominal's simulations like another renderer's would.
    pub renderer: Renderer,
}

/// The cases of a self-check built on `base` (the rig every case starts from, with the
/// effects it has on kept on in both data and nominal).
pub fn cases(base: &Scenario, plan: &SuitePlan, logs: &[PhoneLog]) -> Vec<Case> {
    let mut out = Vec::new();
    let mut case_seed = base.seed;
    let mut next_seed = || {
        case_seed = case_seed.wrapping_add(7919);
        case_seed
    };
    for &e in &plan.effects {
        for &level in &plan.levels {
            if level == Level::OtherForm && !apply_other_form(e, &mut base.clone()) {
                continue;
            }
            for k in 0..plan.seeds_per_case {
                let seed = next_seed();
                let values = level_values(e, level, base.frame_timing.fps);
                let mut nominal = base.clone();
                e.switch_off(&mut nominal);
                for other in e.shares_switch_with() {
                    other.switch_off(&mut nominal);
                }
                let mut data = nominal.clone();
                perturb_rendering(&mut data, seed);
                let mut post = PostProcess::None;
                if e == Effect::Timebase {
                    post = PostProcess::ConstantRateStamps { fps_hz: values[0] };
                    // Frames taken on a phone's variable schedule, stamped at a constant rate.
                    data.frame_timing.model =
                        TimingModel::Vfr(timebase_schedule(level, data.frame_timing.fps));
                    nominal.frame_timing.model = TimingModel::Constant;
                } else {
                    e.apply(&mut data, &values);
                    if level == Level::OtherForm {
                        apply_other_form(e, &mut data);
                    }
                }
                data.seed = seed;
                perturb_nuisance(&mut data, seed);
                let level_name = match level {
                    Level::Strong => "strong",
                    Level::Weak => "weak",
                    Level::OtherForm => "form",
                };
                out.push(Case {
                    name: format!("withheld-{}-{level_name}-{k}", e.name()),
                    expectation: Expectation::Withheld {
                        effect: e.name().into(),
                        also: switch_mate_names(e),
                        strong: level != Level::Weak,
                        form: level == Level::OtherForm,
                    },
                    data,
                    nominal,
                    post,
                    effects: None,
                    // Another form's parameters are not the candidate's: no parameter error.
                    truths: if level == Level::OtherForm {
                        Vec::new()
                    } else {
                        vec![(e, values)]
                    },
                    renderer: plan.renderer,
                });
            }
        }
    }
    for k in 0..plan.null_cases {
        let seed = next_seed();
        let mut data = base.clone();
        let mut nominal = base.clone();
        if k % 2 == 1 {
            if let Some(log) = logs.get((k / 2) % logs.len().max(1)) {
                let model = TimingModel::Log(LogModel {
                    file: log.path.to_string_lossy().into_owned(),
                    ..Default::default()
                });
                data.frame_timing.model = model.clone();
                nominal.frame_timing.model = model;
                data.timing_log = Some(log.timestamps.clone());
                nominal.timing_log = Some(log.timestamps.clone());
            }
        }
        data.seed = seed;
        perturb_nuisance(&mut data, seed);
        perturb_rendering(&mut data, seed);
        out.push(Case {
            name: format!("null-{k}"),
            expectation: Expectation::Null,
            data,
            nominal,
            post: PostProcess::None,
            effects: None,
            truths: Vec::new(),
            renderer: plan.renderer,
        });
    }
    for k in 0..plan.flicker_cases {
        let seed = next_seed();
        let mut data = base.clone();
        data.seed = seed;
        perturb_nuisance(&mut data, seed);
        perturb_rendering(&mut data, seed);
        out.push(Case {
            name: format!("oov-flicker-{k}"),
            expectation: Expectation::OutOfVocabulary,
            data,
            nominal: base.clone(),
            // 100 Hz light at 29.6–30 fps beats at a few Hz; a 6 % swing is a cheap LED lamp.
            post: PostProcess::Flicker {
                amplitude_frac: 0.06,
                beat_hz: 2.5 + 0.5 * k as f64,
            },
            effects: None,
            truths: Vec::new(),
            renderer: plan.renderer,
        });
    }
    for k in 0..plan.novel_cases {
        let seed = next_seed();
        let kind = crate::render::novel::KINDS[k % crate::render::novel::KINDS.len()];
        let mut data = base.clone();
        data.seed = seed;
        perturb_nuisance(&mut data, seed);
        perturb_rendering(&mut data, seed);
        out.push(Case {
            name: format!("novel-{kind}-{}", k / crate::render::novel::KINDS.len()),
            expectation: Expectation::OutOfVocabulary,
            data,
            nominal: base.clone(),
            post: PostProcess::Novel { kind },
            effects: None,
            truths: Vec::new(),
            renderer: plan.renderer,
        });
    }
    let excluded = excluded_effects();
    for k in 0..plan.excluded_cases {
        let seed = next_seed();
        let Some(&e) = excluded.get(k % excluded.len()) else {
            break;
        };
        let mut nominal = base.clone();
        e.switch_off(&mut nominal);
        let mut data = nominal.clone();
        perturb_rendering(&mut data, seed);
        e.apply(
            &mut data,
            &level_values(e, Level::Strong, base.frame_timing.fps),
        );
        data.seed = seed;
        perturb_nuisance(&mut data, seed);
        let candidates: Vec<Effect> = Effect::ALL
            .iter()
            .copied()
            .filter(|c| *c != e && !e.shares_switch_with().contains(c))
            .collect();
        out.push(Case {
            name: format!("oov-excluded-{}-{k}", e.name()),
            expectation: Expectation::OutOfVocabulary,
            data,
            nominal,
            post: PostProcess::None,
            effects: Some(candidates),
            truths: Vec::new(),
            renderer: plan.renderer,
        });
    }
    let pairs = withheld_pairs();
    for k in 0..plan.pair_cases {
        let Some(&(a, b)) = pairs.get(k % pairs.len().max(1)) else {
            break;
        };
        let seed = next_seed();
        let mut nominal = base.clone();
        for e in [a, b] {
            e.switch_off(&mut nominal);
            for other in e.shares_switch_with() {
                other.switch_off(&mut nominal);
            }
        }
        let mut data = nominal.clone();
        perturb_rendering(&mut data, seed);
        let truths: Vec<(Effect, Vec<f64>)> = [a, b]
            .into_iter()
            .map(|e| (e, level_values(e, Level::Strong, base.frame_timing.fps)))
            .collect();
        for (e, values) in &truths {
            e.apply(&mut data, values);
        }
        data.seed = seed;
        perturb_nuisance(&mut data, seed);
        out.push(Case {
            name: format!("pair-{}+{}-{}", a.name(), b.name(), k / pairs.len().max(1)),
            expectation: Expectation::WithheldPair {
                members: [a, b]
                    .iter()
                    .map(|e| PairMember {
                        effect: e.name().into(),
                        also: switch_mate_names(*e),
                    })
                    .collect(),
            },
            data,
            nominal,
            post: PostProcess::None,
            effects: None,
            truths,
            renderer: plan.renderer,
        });
    }
    out
}

/// The effects an out-of-vocabulary case switches on in the data and excludes from the
/// candidates, taken in this order (and round again past its end). The first three are the
/// default plan's. The rest widen a larger `--excluded` run to every other effect but four:
/// the frame timing and the timebase (the example of effects the data cannot tell
/// apart, each the other's twin) and the motion blur (the optical blur's twin at low speed),
/// whose exclusion leaves their twin to explain them, and the overrotation, which shares the
/// backlash's switch. The axis runout and the drive speed stay in although a few seconds of
/// footage often group them (with the overrotation): their cases measure how often the one
/// left in explains the other, and the reports say so beside the rate.
pub fn excluded_effects() -> Vec<Effect> {
    vec![
        Effect::RollingShutter,
        Effect::OpticalBlur,
        Effect::PixelNoise,
        Effect::Lighting,
        Effect::Compression,
        Effect::CameraVibration,
        Effect::AxisRunout,
        Effect::Backlash,
        Effect::DiscVibration,
        Effect::LensDistortion,
        Effect::PerspectiveTilt,
        Effect::DriveSpeed,
    ]
}

/// The names that count as the same answer as `e`: the effects sharing its switch.
fn switch_mate_names(e: Effect) -> Vec<String> {
    e.shares_switch_with()
        .iter()
        .map(|o| o.name().to_string())
        .collect()
}

/// The pairs of effects the two-cause cases withhold, in the order `--pairs N` takes them:
/// causes a real rig has together, each pair moving different statistics so that both are
/// findable, and each effect a one-parameter candidate or two (a pair's fit then stays small).
/// - a motion blur with a camera shake: a phone on a light stand in dim light;
/// - an optical blur with a JPEG compression: a defocused phone video, heavily encoded;
/// - a rolling shutter with a lens distortion: the two every phone camera has;
/// - a backlash with a perspective tilt: a printed drive filmed off-square;
/// - a disc vibration with an axis runout: a printed wheel on a worn shaft.
///
/// The timebase is left out: its case replaces the footage's stamps, which a pair's second
/// effect would have to share.
pub fn withheld_pairs() -> Vec<(Effect, Effect)> {
    vec![
        (Effect::MotionBlur, Effect::CameraVibration),
        (Effect::OpticalBlur, Effect::Compression),
        (Effect::RollingShutter, Effect::LensDistortion),
        (Effect::Backlash, Effect::PerspectiveTilt),
        (Effect::DiscVibration, Effect::AxisRunout),
    ]
}

/// Renders `case`'s footage into `dir` (PNG frames + `timestamps.csv`) and applies its
/// post-processing.
pub fn render_case(case: &Case, dir: &Path) -> Result<(), DiagnoseError> {
    let file = |source: crate::errors::FileError| DiagnoseError::CaseFile {
        case: case.name.clone(),
        source,
    };
    let job = RenderJob {
        frames: None,
        roi_margin_px: None,
        video: None,
        png: true,
        renderer: case.renderer,
    };
    render_job(&case.data, dir, &job, &|_, _| {}).map_err(|e| DiagnoseError::CaseRender {
        case: case.name.clone(),
        source: Box::new(e),
    })?;
    let stamps = dir.join("timestamps.csv");
    let text = std::fs::read_to_string(&stamps).map_err(|e| file(FileError::io(&stamps)(e)))?;
    let times: Vec<f64> = text
        .lines()
        .skip(1)
        .filter_map(|l| l.split(',').nth(1).and_then(|v| v.trim().parse().ok()))
        .collect();
    match case.post {
        PostProcess::None => {}
        PostProcess::Novel { kind } => draw_novel(case, kind, dir, &times)?,
        PostProcess::ConstantRateStamps { fps_hz } => {
            let mut out = String::from("frame,t_s\n");
            for k in 0..times.len() {
                out.push_str(&format!("{k},{}\n", k as f64 / fps_hz));
            }
            std::fs::write(&stamps, out).map_err(|e| file(FileError::io(&stamps)(e)))?;
        }
        PostProcess::Flicker {
            amplitude_frac,
            beat_hz,
        } => {
            for (k, t) in times.iter().enumerate() {
                let path = dir.join(crate::pipeline::render_job::frame_file_name(k));
                let mut img = crate::io::images::read_gray(&path)?;
                let gain = 1.0 + amplitude_frac * (2.0 * std::f64::consts::PI * beat_hz * t).sin();
                for v in img.data.iter_mut() {
                    *v = (*v as f64 * gain).round().clamp(0.0, 255.0) as u8;
                }
                crate::io::png_out::write_gray_png(
                    &path,
                    img.width as u32,
                    img.height as u32,
                    &img.data,
                )
                .map_err(|source| DiagnoseError::CasePng {
                    case: case.name.clone(),
                    source,
                })?;
            }
        }
    }
    Ok(())
}

/// The novel effect `kind` at its self-check strength on `rig`, placed where it meets the
/// marker: the glare on the marker's first dwell, the cable across its path halfway through the
/// first drive.
pub fn novel_effect(kind: &str, rig: &crate::pipeline::rig::Rig) -> Option<Novel> {
    let times = rig.frame_times.as_slice();
    let (t0, t_end) = (*times.first()?, *times.last()?);
    let centre = |t: f64| {
        let (x0, y0, x1, y1) = rig.marker_bbox_px(t);
        ([0.5 * (x0 + x1), 0.5 * (y0 + y1)], x1 - x0)
    };
    let (first_px, paper_px) = centre(t0);
    Some(match kind {
        "creep" => Novel::Creep { rate_deg_s: 3.0 },
        "mount_step" => Novel::MountStep {
            at_s: t0 + 0.4 * (t_end - t0),
            shift_px: [5.0, 3.0],
        },
        "zoom_breathing" => Novel::ZoomBreathing {
            amplitude_frac: 0.015,
            frequency_hz: 0.35,
        },
        "glare" => Novel::Glare {
            centre_px: first_px,
            sigma_px: 0.5 * paper_px,
            peak_dn: 220.0,
        },
        "cable" => {
            let drive: Vec<f64> = times
                .iter()
                .copied()
                .filter(|&t| rig.mechanism.actual(t).phase == crate::mechanism::Phase::Drive)
                .collect();
            let t = *drive.get(drive.len() / 2)?;
            let (at, _) = centre(t);
            let (ahead, _) = centre(t + 0.01);
            // Across the marker's path: perpendicular to its motion there.
            let along_deg = (ahead[1] - at[1]).atan2(ahead[0] - at[0]).to_degrees();
            Novel::Cable {
                through_px: at,
                angle_deg: along_deg + 90.0,
                width_px: 0.25 * paper_px,
                level_dn: 25.0,
            }
        }
        "focus_hunt" => Novel::FocusHunt {
            sigma_px: 2.5,
            period_s: 2.5,
        },
        "duplicated_frames" => Novel::DuplicatedFrames { every: 8 },
        "flicker_banding" => Novel::FlickerBanding {
            amplitude_frac: 0.08,
            wavelength_px: rig.settings.height_px as f64 / 3.0,
            drift_hz: 1.3,
        },
        _ => return None,
    })
}

/// Draws the novel effect `kind` onto the frames of `case` in `dir` (rendered, stamped `times`).
fn draw_novel(
    case: &Case,
    kind: &'static str,
    dir: &Path,
    times: &[f64],
) -> Result<(), DiagnoseError> {
    let rig =
        crate::pipeline::rig::Rig::new(&case.data).map_err(|e| DiagnoseError::CaseRender {
            case: case.name.clone(),
            source: Box::new(e.into()),
        })?;
    let Some(novel) = novel_effect(kind, &rig) else {
        return Err(DiagnoseError::CaseNovel {
            case: case.name.clone(),
            kind,
        });
    };
    let png = |path: &Path, w: usize, h: usize, data: &[u8]| {
        crate::io::png_out::write_gray_png(path, w as u32, h as u32, data).map_err(|source| {
            DiagnoseError::CasePng {
                case: case.name.clone(),
                source,
            }
        })
    };
    if let Novel::Creep { rate_deg_s } = novel {
        let slip = creep_slip(&rig, rate_deg_s.to_radians());
        let scene = rig.scene.clone().animate(|t| {
            let mut pose = rig.pose(t);
            pose.theta2_rad += slip(t);
            pose
        });
        for (k, &t) in times.iter().enumerate() {
            let request = crate::render::FrameRequest {
                index: k as u64,
                t_s: rig.render_time_s(t),
                window: rig.frame_rect(),
            };
            let img = match case.renderer {
                Renderer::Own => crate::render::render_frame(&scene, &rig.settings, &request),
                Renderer::Independent => crate::render::independent::render_frame_independent(
                    &scene,
                    &rig.settings,
                    request.index,
                    request.t_s,
                )
                .map_err(|source| DiagnoseError::CaseRender {
                    case: case.name.clone(),
                    source: Box::new(crate::pipeline::render_job::RenderJobError::Independent {
                        frame: k,
                        source,
                    }),
                })?,
            };
            let path = dir.join(crate::pipeline::render_job::frame_file_name(k));
            png(&path, img.window.width, img.window.height, &img.data)?;
        }
        return Ok(());
    }
    let mut previous: Vec<u8> = Vec::new();
    for (k, &t) in times.iter().enumerate() {
        let path = dir.join(crate::pipeline::render_job::frame_file_name(k));
        let mut img = crate::io::images::read_gray(&path)?;
        let frame = crate::render::novel::Frame {
            data: &mut img.data,
            width: img.width,
            height: img.height,
        };
        crate::render::novel::draw(&novel, frame, t, k, &previous);
        png(&path, img.width, img.height, &img.data)?;
        previous = img.data;
    }
    Ok(())
}

/// The marker's slip on the wheel at time t, rad: `rate_rad_s` × the time the wheel has dwelt
/// since the start (summed on a 1 ms grid of the actual motion, interpolated between).
fn creep_slip(rig: &crate::pipeline::rig::Rig, rate_rad_s: f64) -> impl Fn(f64) -> f64 + Sync + '_ {
    const STEP_S: f64 = 1e-3;
    let end_s = rig.frame_times.as_slice().last().copied().unwrap_or(0.0) + 1.0;
    let n = (end_s / STEP_S).ceil() as usize + 1;
    let mut slip = Vec::with_capacity(n);
    let mut acc = 0.0;
    for i in 0..n {
        slip.push(acc);
        if rig.mechanism.actual(i as f64 * STEP_S).phase == crate::mechanism::Phase::Dwell {
            acc += rate_rad_s * STEP_S;
        }
    }
    move |t: f64| {
        let x = (t / STEP_S).clamp(0.0, (n - 1) as f64);
        let i = (x.floor() as usize).min(n - 2);
        let f = x - i as f64;
        slip[i] * (1.0 - f) + slip[i + 1] * f
    }
}

/// What one case gave.
pub fn outcome(case: &Case, d: &Diagnosis) -> CaseOutcome {
    // Each candidate as the scoring reads it (every effect it names, its group's flattened) and
    // as reports write it (a pair joined by `+`, its group after ` ≈ `), in one walk.
    let (ranked, ranked_labels): (Vec<Vec<String>>, Vec<String>) = d
        .ranking
        .iter()
        .map(|r| {
            let mut names: Vec<String> = r
                .evaluated
                .effects
                .iter()
                .map(|f| f.effect.name().to_string())
                .collect();
            names.extend(
                r.group
                    .iter()
                    .flat_map(|g| g.split('+').map(str::to_string)),
            );
            let label = std::iter::once(super::diagnose::candidate_name(&r.evaluated))
                .chain(r.group.iter().cloned())
                .collect::<Vec<_>>()
                .join(" ≈ ");
            (names, label)
        })
        .unzip();
    let best = d.best.map(|b| &d.ranking[b]);
    let mut param_rel_errors = Vec::new();
    let mut param_errors_in_sd = Vec::new();
    let mut params_in_ci95 = Vec::new();
    // Each withheld effect the best candidate fitted (both of a pair, when it names both).
    let intervals = best.map(|b| b.intervals95()).unwrap_or_default();
    for (effect, truth) in &case.truths {
        let Some(best) = best else { break };
        let found = best
            .evaluated
            .effects
            .iter()
            .zip(&intervals)
            .find(|(f, _)| f.effect == *effect);
        if let Some((f, intervals)) = found {
            for (j, ((v, s), t)) in f.values.iter().zip(&f.stds).zip(truth).enumerate() {
                // Only parameters the data determine (a finite uncertainty) and that are not zero.
                if s.is_finite() && t.abs() > 0.0 {
                    param_rel_errors.push(((v - t) / t).abs());
                    // A zero uncertainty claims the exact value: any error is beyond it.
                    param_errors_in_sd.push(if *s > 0.0 {
                        (v - t).abs() / s
                    } else if v == t {
                        0.0
                    } else {
                        f64::INFINITY
                    });
                    params_in_ci95.push(
                        intervals
                            .get(j)
                            .copied()
                            .flatten()
                            .is_some_and(|i| i.low <= *t && *t <= i.high),
                    );
                }
            }
        }
    }
    CaseOutcome {
        name: case.name.clone(),
        expectation: case.expectation.clone(),
        verdict: d.verdict.as_str().to_string(),
        ranked,
        ranked_labels,
        best_shrink: best.map(|b| b.shrink),
        param_rel_errors,
        param_errors_in_sd,
        params_in_ci95,
        eval_seeds: d.seeds.len(),
    }
}

/// Renders, diagnoses and scores one case in `work_dir/<case name>/`.
pub fn run_case(
    case: &Case,
    work_dir: &Path,
    options: &DiagnoseOptions,
) -> Result<CaseOutcome, DiagnoseError> {
    let dir = work_dir.join(&case.name);
    let frames = dir.join("frames");
    if frames.exists() {
        std::fs::remove_dir_all(&frames).map_err(crate::errors::FileError::io(&frames))?;
    }
    render_case(case, &frames)?;
    let mut o = options.clone();
    o.effects = case.effects.clone();
    let started = std::time::Instant::now();
    let source = Source::Frames {
        dir: frames.clone(),
        timestamps: frames.join("timestamps.csv"),
    };
    let (d, _) = match diagnose(
        &case.nominal,
        &source,
        &dir.join("diagnosis"),
        &o,
        &|_, _, _| {},
    ) {
        Ok(d) => d,
        // A diagnosis that fails on footage this renderer made is a miss of the self-check,
        // scored as such (verdict `error`, no ranking), not the end of the suite.
        Err(e) => {
            eprintln!(
                "diagnose-selfcheck: {}: the diagnosis failed: {e}",
                case.name
            );
            if std::env::var_os("GENEVA_KEEP_FRAMES").is_none() {
                let _ = std::fs::remove_dir_all(&frames);
            }
            return Ok(CaseOutcome {
                name: case.name.clone(),
                expectation: case.expectation.clone(),
                verdict: "error".into(),
                ranked: Vec::new(),
                ranked_labels: Vec::new(),
                best_shrink: None,
                param_rel_errors: Vec::new(),
                param_errors_in_sd: Vec::new(),
                params_in_ci95: Vec::new(),
                eval_seeds: 0,
            });
        }
    };
    // Wall time goes to the terminal, not into the records: outputs stay bit-identical.
    eprintln!(
        "diagnose-selfcheck: {}: {} in {:.0} s",
        case.name,
        d.verdict.as_str(),
        started.elapsed().as_secs_f64()
    );
    // The frames are large and reproducible from the case: keep only the diagnosis.
    if std::env::var_os("GENEVA_KEEP_FRAMES").is_none() {
        let _ = std::fs::remove_dir_all(&frames);
    }
    Ok(outcome(case, &d))
}

/// The self-check as a study of case units (resumable, shardable, merged like a sweep).
pub struct SelfCheck {
    pub cases: Vec<Case>,
    pub options: DiagnoseOptions,
    pub plan_text: String,
    manifest: Manifest,
}

impl SelfCheck {
    pub fn new(cases: Vec<Case>, options: DiagnoseOptions, plan_text: String) -> Self {
        let mut inputs = BTreeMap::new();
        for c in &cases {
            inputs.insert(
                c.name.clone(),
                serde_json::json!({
                    "data": serde_json::to_value(&c.data).unwrap_or_default(),
                    "nominal": serde_json::to_value(&c.nominal).unwrap_or_default(),
                    "post": format!("{:?}", c.post),
                    "effects": c.effects.as_ref().map(|v| v.iter().map(|e| e.name()).collect::<Vec<_>>()),
                    "renderer": format!("{:?}", c.renderer),
                }),
            );
        }
        inputs.insert(
            "options".into(),
            serde_json::json!({"seeds": options.seeds, "fit_seeds": options.fit_seeds, "refits": options.refits, "bootstrap": options.bootstrap, "escalate_seeds": options.escalate_seeds, "pairs": options.pairs}),
        );
        let manifest = Manifest::new("diagnosis-selfcheck", cases.len(), inputs);
        Self {
            cases,
            options,
            plan_text,
            manifest,
        }
    }
}

/// The cases' records (JSON [`CaseOutcome`]s), read from `place`.
fn parse_outcomes<'a>(
    records: impl Iterator<Item = &'a String>,
    place: &Path,
) -> Result<Vec<CaseOutcome>, DiagnoseError> {
    records
        .map(|r| {
            serde_json::from_str(r).map_err(|source| DiagnoseError::Record {
                place: place.to_path_buf(),
                what: "a case record does not parse".into(),
                source,
            })
        })
        .collect()
}

/// What [`SelfCheck::report_so_far`] found.
#[derive(Debug)]
pub enum SoFar {
    /// The run is complete: its own report is the final one.
    Complete,
    /// The report of the cases finished so far, written.
    Written {
        finished: usize,
        total: usize,
        files: Vec<PathBuf>,
    },
}

impl SelfCheck {
    /// The report (`README.md`, `summary.json`, `cases.csv`, `confusion.csv`) of the cases that
    /// a run of this plan into `run_dir` has finished so far, written into `into` all at once.
    /// `run_dir` and its staging folder are only read, so the run may go on; the README says
    /// how many of the plan's cases it holds and names the others, since a figure over some of
    /// the cases is not the plan's figure.
    pub fn report_so_far(&self, run_dir: &Path, into: &Path) -> Result<SoFar, DiagnoseError> {
        // Written in, around or beside the run's folders, the report would replace them (the
        // run's staging, with every case finished) or stop the run from committing.
        let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
        let target = absolute(into);
        let staging = crate::io::output_dir::sibling(run_dir, "partial")?;
        if [absolute(run_dir), staging]
            .iter()
            .any(|own| target.starts_with(own) || own.starts_with(&target))
        {
            return Err(DiagnoseError::SoFarInto {
                dir: into.to_path_buf(),
            });
        }
        let records = match crate::shard::progress(self, run_dir)? {
            crate::shard::Progress::Complete => return Ok(SoFar::Complete),
            crate::shard::Progress::Running(r) => r,
        };
        let total = self.cases.len();
        if records.is_empty() {
            return Err(DiagnoseError::NoCaseFinished {
                dir: run_dir.to_path_buf(),
                total,
            });
        }
        let outcomes = parse_outcomes(records.values(), run_dir)?;
        let waiting: Vec<&str> = self
            .cases
            .iter()
            .enumerate()
            .filter(|(u, _)| !records.contains_key(u))
            .map(|(_, c)| c.name.as_str())
            .collect();
        let text = format!(
            "{}\n\n**So far: {} of the plan's {total} cases finished** (read from the run in \
             progress into `{}`); not finished yet: {}.",
            self.plan_text,
            records.len(),
            run_dir.display(),
            waiting.join(", ")
        );
        let out = crate::io::output_dir::OutputDir::create(into)?;
        write_summary(&outcomes, &text, out.path())?;
        let files = out.commit()?;
        Ok(SoFar::Written {
            finished: records.len(),
            total,
            files,
        })
    }
}

impl Study for SelfCheck {
    type Error = DiagnoseError;

    fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    fn run_unit(&self, unit: usize, work_dir: &Path) -> Result<String, DiagnoseError> {
        let case = &self.cases[unit];
        let outcome = run_case(case, &work_dir.join("cases"), &self.options)?;
        serde_json::to_string(&outcome).map_err(|source| DiagnoseError::Record {
            place: work_dir.to_path_buf(),
            what: format!("case {}: its record", case.name),
            source,
        })
    }

    fn finalize(
        &self,
        records: &[String],
        _unit_dirs: UnitDirs,
        out_dir: &Path,
    ) -> Result<(), DiagnoseError> {
        write_summary(
            &parse_outcomes(records.iter(), out_dir)?,
            &self.plan_text,
            out_dir,
        )
    }

    fn unit_name(&self, unit: usize) -> String {
        self.cases
            .get(unit)
            .map_or_else(|| format!("case {unit}"), |c| c.name.clone())
    }
}

/// Writes `README.md`, `summary.json`, `cases.csv` and `confusion.csv` of a self-check.
pub fn write_summary(
    outcomes: &[CaseOutcome],
    plan_text: &str,
    out_dir: &Path,
) -> Result<(), DiagnoseError> {
    let s = score(outcomes);
    let w = |name: &str, text: String| {
        let path = out_dir.join(name);
        std::fs::write(&path, text).map_err(|e| crate::errors::FileError::io(&path)(e).into())
    };
    let opt = |v: Option<f64>, unit: &str, k: f64| {
        v.map_or("–".into(), |v| format!("{:.2}{unit}", v * k))
    };
    let targets = [
        ("top-1, strong", pct(&s.top1_strong), "≥ 90 %"),
        ("top-3, strong", pct(&s.top3_strong), "≥ 98 %"),
        ("gap found, strong", pct(&s.detected_strong), "–"),
        ("top-1, near the limit", pct(&s.top1_weak), "–"),
        ("top-3, near the limit", pct(&s.top3_weak), "–"),
        ("gap found, near the limit", pct(&s.detected_weak), "–"),
        ("top-1, another form", pct(&s.top1_form), "–"),
        ("gap found, another form", pct(&s.detected_form), "–"),
        ("false alarms on null cases", pct(&s.false_alarms), "≤ 5 %"),
        (
            "out of vocabulary → unexplained",
            pct(&s.unexplained_recall),
            "≥ 80 %",
        ),
        (
            "median shrink of the top candidate, strong",
            opt(s.median_shrink_strong, " %", 100.0),
            "≥ 80 %",
        ),
    ];
    // Two causes at once, only when the plan had such cases.
    let pair_rows: Vec<(String, String, &str)> = if s.pair_detected.n == 0 {
        Vec::new()
    } else {
        [
            ("`explained`, the best candidate naming both", &s.pair_both),
            (
                "`explained` naming one of them only (half an account stated as whole)",
                &s.pair_one,
            ),
            ("`explained` naming neither", &s.pair_neither),
            (
                "`unexplained` (the gap found, not accounted for)",
                &s.pair_unexplained,
            ),
            ("gap found", &s.pair_detected),
        ]
        .into_iter()
        .map(|(name, rate)| (format!("two effects: {name}"), pct(rate), "–"))
        .chain([
            (
                "two effects: median relative error of both effects' identifiable parameters \
                 (cases naming both)"
                    .to_string(),
                opt(s.median_param_rel_error_pair, " %", 100.0),
                "–",
            ),
            (
                "two effects: those parameters' truth within their stated 95 % interval"
                    .to_string(),
                pct(&s.params_within_ci95_pair),
                "≈ 95 %",
            ),
        ])
        .collect()
    };
    // The fitted parameters' figures, per level: the strong level carries the target.
    let param_rows = |level: &str, median, within_2sd: &Rate, ci95: &Rate, target| {
        [
            (
                format!(
                    "median relative error of identifiable fitted parameters, {level} (top-1 cases)"
                ),
                opt(median, " %", 100.0),
                target,
            ),
            (
                format!(
                    "those parameters within 2 stated standard uncertainties of the truth, {level}"
                ),
                pct(within_2sd),
                "≈ 95 % (honest uncertainties)",
            ),
            (
                format!(
                    "those parameters' truth within their stated 95 % interval (Student's t on the \
                     ±'s degrees of freedom, `params_ci95`), {level}"
                ),
                pct(ci95),
                "≈ 95 %",
            ),
        ]
    };
    let targets = targets
        .into_iter()
        .map(|(name, v, t)| (name.to_string(), v, t))
        .chain(param_rows(
            "strong",
            s.median_param_rel_error_strong,
            &s.params_within_2sd_strong,
            &s.params_within_ci95_strong,
            "≤ 15 %",
        ))
        .chain(param_rows(
            "near the limit",
            s.median_param_rel_error_weak,
            &s.params_within_2sd_weak,
            &s.params_within_ci95_weak,
            "–",
        ))
        .chain(pair_rows);
    let mut md = String::from(
        "# Diagnosis self-check\n\nFootage with a known cause rendered by the renderer the plan names, diagnosed by \
         `geneva diagnose` against a nominal without that cause (see \
         `src/pipeline/selfcheck.rs` for the cases). Every figure is a count over the cases \
         below, with a 95 % Wilson interval; \"top-k\" counts a case only when a gap was found and the \
         withheld effect (or its group, or an effect sharing its switch) is among the k best candidates. \
         Made by `geneva diagnose-selfcheck` with the plan below; `cargo xtask diagnosis NAME` \
         regenerates each suite committed under `reports/` (`reports/README.md`).\n\n",
    );
    md.push_str(plan_text);
    md.push_str("\n\n| figure | measured | target |\n|---|---|---|\n");
    // A figure the plan has no case for (a pairs-only plan's top-1) is left out, not listed
    // as a dash.
    for (name, v, t) in targets.filter(|(_, v, _)| v != "–" && !v.starts_with("– (no case)")) {
        md.push_str(&format!("| {name} | {v} | {t} |\n"));
    }
    md.push_str(
        "\n## Confusion matrix (rows: what the footage holds; columns: the diagnosis' answer)\n\n",
    );
    let mut cols: Vec<String> = s
        .confusion
        .values()
        .flat_map(|r| r.keys().cloned())
        .collect();
    cols.sort();
    cols.dedup();
    md.push_str(&format!(
        "| case | {} |\n|---|{}\n",
        cols.join(" | "),
        "---|".repeat(cols.len())
    ));
    let mut csv = format!("case,{}\n", cols.join(","));
    for (row, counts) in &s.confusion {
        let cells: Vec<String> = cols
            .iter()
            .map(|c| counts.get(c).map_or(String::new(), |n| n.to_string()))
            .collect();
        md.push_str(&format!("| {row} | {} |\n", cells.join(" | ")));
        csv.push_str(&format!(
            "{row},{}\n",
            cols.iter()
                .map(|c| counts.get(c).copied().unwrap_or(0).to_string())
                .collect::<Vec<_>>()
                .join(",")
        ));
    }
    md.push_str(
        "\n## Cases\n\nIn the ranking, `a+b` is a pair of effects and `x ≈ y` a candidate with the \
         candidates the data cannot tell apart from it (its group).\n",
    );
    md.push_str("\n| case | verdict | ranking (best first) | shrink | parameter errors | in σ | evaluation seeds |\n|---|---|---|---|---|---|---|\n");
    let mut cases_csv =
        String::from("case,expectation,verdict,ranking,best_shrink,param_rel_errors,eval_seeds,param_errors_in_sd,params_in_ci95\n");
    for o in outcomes {
        let ranking: Vec<String> = o.ranking_labels().into_iter().take(4).collect();
        let errs: Vec<String> = o
            .param_rel_errors
            .iter()
            .map(|e| format!("{:.0} %", 100.0 * e))
            .collect();
        let in_sd: Vec<String> = o
            .param_errors_in_sd
            .iter()
            .map(|z| format!("{z:.1}"))
            .collect();
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} |\n",
            o.name,
            o.verdict,
            ranking.join(" > "),
            o.best_shrink.map_or("–".into(), |v| format!("{:.2}", v)),
            errs.join(", "),
            in_sd.join(", "),
            o.eval_seeds,
        ));
        let kind = match &o.expectation {
            Expectation::Withheld {
                effect,
                strong,
                form,
                ..
            } => format!(
                "withheld {effect} {}",
                crate::diagnose::scoring::level_name(*strong, *form)
            ),
            Expectation::WithheldPair { members } => format!(
                "withheld pair {}",
                crate::diagnose::scoring::pair_label(members)
            ),
            Expectation::Null => "null".into(),
            Expectation::OutOfVocabulary => "out_of_vocabulary".into(),
        };
        cases_csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{}\n",
            o.name,
            kind,
            o.verdict,
            ranking.join(" > "),
            o.best_shrink.map_or(String::new(), |v| format!("{v:.4}")),
            o.param_rel_errors
                .iter()
                .map(|e| format!("{e:.4}"))
                .collect::<Vec<_>>()
                .join(" "),
            o.eval_seeds,
            o.param_errors_in_sd
                .iter()
                .map(|z| format!("{z:.3}"))
                .collect::<Vec<_>>()
                .join(" "),
            o.params_in_ci95
                .iter()
                .map(|i| if *i { "1" } else { "0" })
                .collect::<Vec<_>>()
                .join(" "),
        ));
    }
    let rate_json = |r: &Rate| serde_json::json!({"k": r.k, "n": r.n, "value": r.value()});
    let summary = serde_json::json!({
        "cases": outcomes.len(),
        "top1_strong": rate_json(&s.top1_strong),
        "top3_strong": rate_json(&s.top3_strong),
        "top1_weak": rate_json(&s.top1_weak),
        "top3_weak": rate_json(&s.top3_weak),
        "detected_strong": rate_json(&s.detected_strong),
        "detected_weak": rate_json(&s.detected_weak),
        "top1_form": rate_json(&s.top1_form),
        "detected_form": rate_json(&s.detected_form),
        "false_alarms": rate_json(&s.false_alarms),
        "unexplained_recall": rate_json(&s.unexplained_recall),
        "median_shrink_strong": s.median_shrink_strong,
        "median_param_rel_error_strong": s.median_param_rel_error_strong,
        "params_within_2sd_strong": rate_json(&s.params_within_2sd_strong),
        "params_within_ci95_strong": rate_json(&s.params_within_ci95_strong),
        "median_param_rel_error_weak": s.median_param_rel_error_weak,
        "params_within_2sd_weak": rate_json(&s.params_within_2sd_weak),
        "params_within_ci95_weak": rate_json(&s.params_within_ci95_weak),
    });
    w("README.md", md)?;
    w("confusion.csv", csv)?;
    w("cases.csv", cases_csv)?;
    w(
        "summary.json",
        serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n",
    )
}

/// The rig every self-check case starts from: the built-in `fast` rig (1280×720, 30 fps,
/// 4-slot internal drive, optical blur, pixel noise and lighting on) filmed for `duration_s`.
pub fn suite_base(duration_s: f64) -> Result<Scenario, DiagnoseError> {
    let mut s = suite_base_from("fast", Some(duration_s))?;
    s.name = "selfcheck-base".into();
    Ok(s)
}

/// The rig a self-check's cases start from, as the user states it: `spec`, a scenario file
/// (often `geneva calibrate`'s) or a built-in name, filmed for `duration_s` (the scenario's own
/// length when `None`). Every case keeps the effects it has on in both data and nominal, so the
/// suite asks how the diagnosis does on that rig, not on the project's.
pub fn suite_base_from(spec: &str, duration_s: Option<f64>) -> Result<Scenario, DiagnoseError> {
    let mut s = crate::scenario::load_any(spec).map_err(|e| DiagnoseError::SuiteBase {
        spec: spec.to_string(),
        source: Box::new(e),
    })?;
    if let Some(d) = duration_s {
        if !(d.is_finite() && d > 0.0) {
            return Err(DiagnoseError::SuiteDuration { duration_s: d });
        }
        s.duration_s = d;
    }
    Ok(s)
}

impl SuitePlan {
    /// The whole self-check: every effect at two levels × `seeds` seeds, six null
    /// cases, two flicker cases and three excluded-candidate cases.
    pub fn full(seeds: usize) -> Self {
        Self {
            effects: withheld_effects(),
            levels: vec![Level::Strong, Level::Weak],
            seeds_per_case: seeds,
            null_cases: 6,
            flicker_cases: 2,
            excluded_cases: 3,
            pair_cases: 0,
            novel_cases: 0,
            renderer: Renderer::Own,
        }
    }

    /// A small case for CI: one strong withheld effect, one null case, one flicker case.
    pub fn quick(effect: Effect) -> Self {
        Self {
            effects: vec![effect],
            levels: vec![Level::Strong],
            seeds_per_case: 1,
            null_cases: 1,
            flicker_cases: 1,
            excluded_cases: 0,
            pair_cases: 0,
            novel_cases: 0,
            renderer: Renderer::Own,
        }
    }

    /// The plan in words, for the report.
    pub fn describe(&self, base: &Scenario, options: &DiagnoseOptions) -> String {
        let singles =
            if self.seeds_per_case == 0 || self.effects.is_empty() || self.levels.is_empty() {
                "no single withheld effect".to_string()
            } else {
                format!(
                    "{} withheld effect(s) ({}) × {} level(s) ({}) × {} seed(s)",
                    self.effects.len(),
                    self.effects
                        .iter()
                        .map(|e| e.name())
                        .collect::<Vec<_>>()
                        .join(", "),
                    self.levels.len(),
                    self.levels
                        .iter()
                        .map(|l| match l {
                            Level::Strong => "strong",
                            Level::Weak => "near the limit",
                            Level::OtherForm =>
                                "another form: the strong level in a form the candidate does not \
                             parametrise, only the effects that have one here",
                        })
                        .collect::<Vec<_>>()
                        .join("; "),
                    self.seeds_per_case,
                )
            };
        format!(
            "Plan: {singles}, {} null case(s), {} flicker \
             case(s), {} excluded-candidate case(s), {} two-effect case(s){}{}; footage {}×{} px, {} fps, {} s, drawn by {}; \
             diagnosis with {} evaluation seeds (raised to {} when a cell misses significance only \
             for lack of seeds) and {} fit seeds, {}{}{}.",
                        self.null_cases,
            self.flicker_cases,
            self.excluded_cases,
            self.pair_cases,
            if self.pair_cases == 0 {
                String::new()
            } else {
                format!(
                    " ({}, each effect at the strong level)",
                    withheld_pairs()
                        .iter()
                        .cycle()
                        .take(self.pair_cases)
                        .map(|(a, b)| format!("{} + {}", a.name(), b.name()))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            },
            if self.novel_cases == 0 {
                String::new()
            } else {
                format!(
                    ", {} novel-effect case(s) ({})",
                    self.novel_cases,
                    crate::render::novel::KINDS
                        .iter()
                        .cycle()
                        .take(self.novel_cases.min(crate::render::novel::KINDS.len()))
                        .copied()
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            },
            base.camera.width_px,
            base.camera.height_px,
            base.frame_timing.fps,
            base.duration_s,
            match self.renderer {
                Renderer::Own => "the project's renderer (as the nominal's simulations)",
                Renderer::Independent =>
                    "the independent renderer (`render::independent`: tiny-skia anti-aliasing in \
                     display space, pixel-integrated blur, its own noise; the nominal is simulated \
                     by the project's renderer)",
            },
            options.seeds,
            options.escalate_seeds,
            options.fit_seeds,
            match options.refits {
                0 => "the best candidate stated as its first fit (no refit)".to_string(),
                r => format!(
                    "the best candidate refitted on {r} more set(s) of them and stated as \
                     the pool of its fits"
                ),
            },
            match options.bootstrap {
                0 => String::new(),
                b => format!(
                    ", its ± widened and a significant bias taken off by its fits on {b} \
                     footage(s) simulated at its stated values"
                ),
            },
            options
                .effects
                .as_ref()
                .map_or(String::new(), |e| format!(", candidates restricted to {}", e.iter().map(|e| e.name()).collect::<Vec<_>>().join(", ")))
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each novel kind, rendered on 4.5 s of the rig at 12 fps (one drive, a dwell on each side), against
    /// the same case drawn without it: what it must change, and only that.
    #[test]
    fn every_novel_kind_draws_what_it_names() {
        let mut base = suite_base(4.5).unwrap();
        // 12 fps: enough frames for every kind's pattern, a third of the rendering.
        base.frame_timing.fps = 12.0;
        let plan = SuitePlan {
            novel_cases: crate::render::novel::KINDS.len(),
            ..SuitePlan::quick(Effect::PixelNoise)
        };
        let novel: Vec<Case> = cases(&base, &plan, &[])
            .into_iter()
            .filter(|c| c.name.starts_with("novel-"))
            .collect();
        assert_eq!(novel.len(), crate::render::novel::KINDS.len());
        let tmp = tempfile::tempdir().unwrap();
        let frame = |dir: &Path, k: usize| {
            crate::io::images::read_gray(&dir.join(crate::pipeline::render_job::frame_file_name(k)))
                .unwrap()
                .data
        };
        let differs = |a: &[u8], b: &[u8]| a.iter().zip(b).filter(|(x, y)| x != y).count();
        for case in &novel {
            assert_eq!(case.expectation, Expectation::OutOfVocabulary);
            let PostProcess::Novel { kind } = case.post else {
                panic!("{case:?}")
            };
            let (with, without) = (
                tmp.path().join(kind),
                tmp.path().join(format!("{kind}-plain")),
            );
            render_case(case, &with).unwrap();
            let plain = Case {
                post: PostProcess::None,
                ..case.clone()
            };
            render_case(&plain, &without).unwrap();
            let n = crate::pipeline::rig::Rig::new(&case.data)
                .unwrap()
                .frame_times
                .len();
            let changed: Vec<usize> = (0..n)
                .map(|k| differs(&frame(&with, k), &frame(&without, k)))
                .collect();
            let frames_changed = changed.iter().filter(|&&c| c > 0).count();
            match kind {
                // The slip grows through every dwell.
                "creep" => assert!(frames_changed > n / 3, "{kind}: {changed:?}"),
                // Untouched before the step, shifted after it.
                "mount_step" => {
                    let step = (0.4 * n as f64) as usize;
                    assert!(changed[..step - 1].iter().all(|&c| c == 0), "{changed:?}");
                    assert!(changed[step + 1..].iter().all(|&c| c > 0), "{changed:?}");
                }
                // Every eighth frame repeats its predecessor, and only those change.
                "duplicated_frames" => {
                    for (k, &c) in changed.iter().enumerate() {
                        assert_eq!(
                            c == 0,
                            k % 8 != 0 || k == 0 || frame(&without, k) == frame(&without, k - 1),
                            "frame {k}"
                        );
                        if k > 0 && k % 8 == 0 {
                            assert_eq!(frame(&with, k), frame(&with, k - 1), "frame {k}");
                        }
                    }
                }
                // A static overlay changes every frame.
                "glare" | "cable" | "flicker_banding" => {
                    assert_eq!(frames_changed, n, "{kind}: {changed:?}")
                }
                // Sinusoidal: all but the frames at its zeros.
                "zoom_breathing" | "focus_hunt" => {
                    assert!(frames_changed > n / 3, "{kind}: {changed:?}")
                }
                other => panic!("untested kind {other}"),
            }
        }
    }

    /// The written summary keeps a pair and its group apart in the case table, and states the
    /// parameters' figures near the limit beside the strong ones.
    #[test]
    fn the_summary_writes_pairs_groups_and_both_levels_parameter_figures() {
        let withheld = |strong| Expectation::Withheld {
            effect: "backlash".into(),
            also: vec!["overrotation".into()],
            strong,
            form: false,
        };
        let pair = CaseOutcome {
            name: "withheld-backlash-strong-0".into(),
            expectation: withheld(true),
            verdict: "explained".into(),
            ranked: vec![
                vec![
                    "backlash".into(),
                    "overrotation".into(),
                    "drive_speed".into(),
                    "axis_runout".into(),
                ],
                vec!["axis_runout".into()],
            ],
            ranked_labels: vec![
                "backlash+overrotation ≈ drive_speed+axis_runout".into(),
                "axis_runout".into(),
            ],
            best_shrink: Some(0.97),
            param_rel_errors: vec![0.02],
            param_errors_in_sd: vec![0.5],
            params_in_ci95: vec![true],
            eval_seeds: 4,
        };
        let weak = CaseOutcome {
            name: "withheld-backlash-weak-0".into(),
            expectation: withheld(false),
            ranked: vec![vec!["backlash".into()]],
            ranked_labels: Vec::new(),
            param_rel_errors: vec![0.3],
            param_errors_in_sd: vec![2.2],
            params_in_ci95: vec![true],
            ..pair.clone()
        };
        let dir = tempfile::tempdir().unwrap();
        write_summary(&[pair, weak], "Plan.", dir.path()).unwrap();
        let md = std::fs::read_to_string(dir.path().join("README.md")).unwrap();
        assert!(
            md.contains("| backlash+overrotation ≈ drive_speed+axis_runout > axis_runout |"),
            "{md}"
        );
        assert!(md.contains("| backlash |"), "an older record's names: {md}");
        assert!(
            md.contains("relative error of identifiable fitted parameters, near the limit (top-1 cases) | 30.00 %"),
            "{md}"
        );
        let csv = std::fs::read_to_string(dir.path().join("cases.csv")).unwrap();
        assert!(
            csv.contains(",backlash+overrotation ≈ drive_speed+axis_runout > axis_runout,"),
            "{csv}"
        );
        let summary: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join("summary.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(summary["params_within_2sd_weak"]["k"], 0);
        assert_eq!(summary["params_within_ci95_weak"]["k"], 1);
        assert_eq!(summary["params_within_ci95_strong"]["n"], 1);
    }

    /// A two-effect case switches both effects off in the nominal and on at their strong
    /// values in the data, states both truths, and leaves the other cases' footage as it was.
    #[test]
    fn pair_cases_withhold_both_effects_and_leave_the_other_cases_alone() {
        let base = suite_base(4.0).unwrap();
        let without = SuitePlan {
            seeds_per_case: 1,
            null_cases: 1,
            flicker_cases: 1,
            excluded_cases: 1,
            ..SuitePlan::quick(Effect::PixelNoise)
        };
        let with = SuitePlan {
            pair_cases: withheld_pairs().len() + 1,
            novel_cases: 0,
            ..without.clone()
        };
        let before = cases(&base, &without, &[]);
        let after = cases(&base, &with, &[]);
        assert_eq!(after.len(), before.len() + with.pair_cases);
        for (b, a) in before.iter().zip(&after) {
            assert_eq!((&b.name, &b.data), (&a.name, &a.data));
        }
        let pairs = &after[before.len()..];
        assert_eq!(pairs[0].name, "pair-motion_blur+camera_vibration-0");
        assert_eq!(
            pairs.last().unwrap().name,
            "pair-motion_blur+camera_vibration-1",
            "past the list's end it goes round with new seeds"
        );
        assert_ne!(pairs[0].data.seed, pairs.last().unwrap().data.seed);
        for (c, (a, b)) in pairs.iter().zip(withheld_pairs().into_iter().cycle()) {
            let Expectation::WithheldPair { members } = &c.expectation else {
                panic!("{}: {:?}", c.name, c.expectation);
            };
            let names: Vec<&str> = members.iter().map(|m| m.effect.as_str()).collect();
            assert_eq!(names, [a.name(), b.name()]);
            assert_eq!(c.truths.len(), 2);
            for (e, values) in &c.truths {
                assert!(!e.is_on(&c.nominal) && e.is_on(&c.data), "{}", c.name);
                assert_eq!(
                    *values,
                    level_values(*e, Level::Strong, base.frame_timing.fps)
                );
                for other in e.shares_switch_with() {
                    assert!(!other.is_on(&c.nominal), "{}", c.name);
                }
            }
            assert!(c.effects.is_none() && c.post == PostProcess::None);
        }
        let backlash = &pairs[3];
        let Expectation::WithheldPair { members } = &backlash.expectation else {
            panic!()
        };
        assert_eq!(members[0].also, ["overrotation"]);
        let text = with.describe(&base, &DiagnoseOptions::default());
        assert!(
            text.contains(
                "6 two-effect case(s) (motion_blur + camera_vibration, optical_blur + compression,"
            ),
            "{text}"
        );
        let only_pairs = SuitePlan {
            seeds_per_case: 0,
            null_cases: 0,
            flicker_cases: 0,
            ..with.clone()
        };
        assert_eq!(cases(&base, &only_pairs, &[]).len(), with.pair_cases + 1);
        let text = only_pairs.describe(&base, &DiagnoseOptions::default());
        assert!(
            text.starts_with("Plan: no single withheld effect, 0 null"),
            "{text}"
        );
        // The summary states the pair figures, and only when the plan had pair cases.
        let outcome = |c: &Case, verdict: &str, best: &[&str]| CaseOutcome {
            name: c.name.clone(),
            expectation: c.expectation.clone(),
            verdict: verdict.into(),
            ranked: vec![best.iter().map(|n| n.to_string()).collect()],
            ranked_labels: vec![best.join("+")],
            best_shrink: Some(0.9),
            param_rel_errors: vec![0.1, 0.2],
            param_errors_in_sd: vec![0.5, 1.0],
            params_in_ci95: vec![true, true],
            eval_seeds: 4,
        };
        let outcomes = [
            outcome(&pairs[0], "explained", &["motion_blur", "camera_vibration"]),
            outcome(&pairs[1], "explained", &["compression"]),
        ];
        let dir = tempfile::tempdir().unwrap();
        write_summary(&outcomes, "Plan.", dir.path()).unwrap();
        let md = std::fs::read_to_string(dir.path().join("README.md")).unwrap();
        assert!(
            md.contains("| two effects: `explained`, the best candidate naming both | 50 % (1/2;"),
            "{md}"
        );
        assert!(md.contains("| optical_blur + compression (pair) |"), "{md}");
        let csv = std::fs::read_to_string(dir.path().join("cases.csv")).unwrap();
        assert!(
            csv.contains("withheld pair motion_blur + camera_vibration,explained,"),
            "{csv}"
        );
        assert!(
            !md.contains("top-1, strong"),
            "no single case, no single figure: {md}"
        );
        write_summary(&outcomes[..0], "Plan.", dir.path()).unwrap();
        let md = std::fs::read_to_string(dir.path().join("README.md")).unwrap();
        assert!(!md.contains("two effects"), "{md}");
    }

    /// A strong exposure or readout fits in the rig's frame interval: the 30 fps probes stand,
    /// a 60 fps rig gets 15 ms, and the weak level lies below the cut probe.
    #[test]
    fn exposure_and_readout_probes_fit_the_frame_interval() {
        for e in [Effect::MotionBlur, Effect::RollingShutter] {
            let registry = e.params()[0].probe;
            assert_eq!(level_values(e, Level::Strong, 30.0), vec![registry]);
            let at_60 = level_values(e, Level::Strong, 60.0)[0];
            assert!((at_60 - 0.015).abs() < 1e-12, "{}: {at_60}", e.name());
            let weak = level_values(e, Level::Weak, 60.0)[0];
            assert!(weak < at_60 && weak > 0.0, "{}: weak {weak}", e.name());
        }
        assert_eq!(
            level_values(Effect::OpticalBlur, Level::Strong, 240.0),
            vec![Effect::OpticalBlur.params()[0].probe]
        );
    }

    /// A withheld timebase stamps the footage at the rig's own rate, whatever that rate: at 60 fps
    /// the registry's 30 fps probe stamped the frames at half their rate.
    #[test]
    fn a_withheld_timebase_stamps_at_the_rigs_own_rate() {
        for fps in [24.0, 30.0, 60.0, 240.0] {
            for level in [Level::Strong, Level::Weak, Level::OtherForm] {
                assert_eq!(level_values(Effect::Timebase, level, fps), vec![fps]);
            }
        }
    }

    /// "Near the limit" is weaker than strong: every strength parameter of every withheld effect
    /// sits between the value at which it does nothing and the strong probe, on the nothing side.
    #[test]
    fn the_weak_level_lies_between_no_effect_and_the_strong_probe() {
        let fps = 30.0;
        for e in withheld_effects() {
            let strong = level_values(e, Level::Strong, fps);
            let weak = level_values(e, Level::Weak, fps);
            for (i, p) in e.params().iter().enumerate() {
                let Some(neutral) = neutral_value(e, i, fps) else {
                    assert_eq!(
                        weak[i],
                        strong[i],
                        "{}.{}: a form keeps the probe",
                        e.name(),
                        p.name
                    );
                    continue;
                };
                if e == Effect::Timebase {
                    continue; // its strength is the schedule (`timebase_schedule`)
                }
                let (to_weak, to_strong) = (weak[i] - neutral, strong[i] - neutral);
                assert!(
                    to_weak * to_strong >= 0.0 && to_weak.abs() <= to_strong.abs(),
                    "{}.{}: weak {} is not between {} (no effect) and {} (strong)",
                    e.name(),
                    p.name,
                    weak[i],
                    neutral,
                    strong[i]
                );
                assert!(
                    p.search.0 <= weak[i] && weak[i] <= p.search.1,
                    "{}.{}: weak {} outside the search",
                    e.name(),
                    p.name,
                    weak[i]
                );
            }
        }
        // The cases the old rule (from the search's lower end) made stronger than strong.
        let fw = level_values(Effect::PixelNoise, Level::Weak, fps)[0];
        assert!(fw > 2000.0, "full well {fw}");
        let q = level_values(Effect::Compression, Level::Weak, fps)[0];
        assert!(q > 30.0, "quality {q}");
        let first = level_values(Effect::FrameTiming, Level::Weak, fps)[1];
        assert!((first - (1.0 / fps + 0.3 * (0.055 - 1.0 / fps))).abs() < 1e-12);
    }

    /// The refits and bootstrap footages of each case's best are in the plan's words and in the
    /// suite's fingerprint: a suite resumed with other ones is another suite (its stated ± and
    /// values differ).
    #[test]
    fn a_suites_refits_are_stated_and_fingerprinted() -> Result<(), DiagnoseError> {
        let base = suite_base(3.0)?;
        let plan = SuitePlan::quick(Effect::PixelNoise);
        let suite = |refits, bootstrap| {
            let options = DiagnoseOptions {
                refits,
                bootstrap,
                ..Default::default()
            };
            let text = plan.describe(&base, &options);
            let check = SelfCheck::new(cases(&base, &plan, &[]), options, text.clone());
            (text, check.manifest.fingerprint)
        };
        let (two, two_print) = suite(2, 0);
        let (none, none_print) = suite(0, 0);
        assert!(two.contains("refitted on 2 more set(s)"), "{two}");
        assert!(!two.contains("footage(s) simulated"), "{two}");
        assert!(
            none.contains("stated as its first fit (no refit)"),
            "{none}"
        );
        assert_ne!(two_print, none_print);
        assert_eq!(suite(2, 0).1, two_print);
        // So are the footages that measure the footage's own noise.
        let (boot, boot_print) = suite(0, 3);
        assert!(
            boot.contains(
                "first fit (no refit), its ± widened and a significant bias taken off \
                           by its fits on 3 footage(s)"
            ),
            "{boot}"
        );
        assert_ne!(boot_print, none_print);
        Ok(())
    }

    /// A user's rig as the base: a built-in keeps its own length unless one is given, and a
    /// scenario that cannot be loaded, or a length that is no length, is an error naming it.
    #[test]
    fn a_suite_base_is_the_users_rig_at_its_own_or_a_given_length() {
        let own = crate::scenario::load_any("seed-external-4k").unwrap();
        let base = suite_base_from("seed-external-4k", None).unwrap();
        assert_eq!(base, own);
        let short = suite_base_from("seed-external-4k", Some(3.0)).unwrap();
        assert_eq!(short.duration_s, 3.0);
        assert_eq!(short.mechanism, own.mechanism);
        let missing = suite_base_from("/nonexistent/rig.toml", None).unwrap_err();
        assert!(
            format!("{missing}").contains("/nonexistent/rig.toml"),
            "{missing}"
        );
        for bad in [0.0, -1.0, f64::NAN] {
            let e = suite_base_from("fast", Some(bad)).unwrap_err();
            assert!(format!("{e}").contains("duration"), "{e}");
        }
        assert_eq!(suite_base(4.0).unwrap().duration_s, 4.0);
    }

    /// Every other-form case holds its effect at the strong level in a form the candidate at the
    /// same values does not have, and claims no parameter truth.
    #[test]
    fn other_form_cases_differ_from_their_candidates_form() {
        let base = suite_base(4.0).unwrap();
        let plan = SuitePlan {
            effects: withheld_effects(),
            levels: vec![Level::OtherForm],
            seeds_per_case: 1,
            null_cases: 0,
            flicker_cases: 0,
            excluded_cases: 0,
            pair_cases: 0,
            novel_cases: 0,
            renderer: Renderer::Own,
        };
        let all = cases(&base, &plan, &[]);
        let names: Vec<&str> = all.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "withheld-disc_vibration-form-0",
                "withheld-axis_runout-form-0",
                "withheld-camera_vibration-form-0",
                "withheld-lens_distortion-form-0",
                "withheld-perspective_tilt-form-0",
                "withheld-video_codec-form-0",
            ]
        );
        for c in &all {
            let Expectation::Withheld {
                effect,
                strong: true,
                form: true,
                ..
            } = &c.expectation
            else {
                panic!("{}: {:?}", c.name, c.expectation);
            };
            let e = Effect::from_name(effect).unwrap();
            assert!(c.truths.is_empty(), "{}", c.name);
            assert!(!e.is_on(&c.nominal) && e.is_on(&c.data), "{}", c.name);
            let mut candidate = c.nominal.clone();
            e.apply(
                &mut candidate,
                &level_values(e, Level::Strong, base.frame_timing.fps),
            );
            let mut with_data_form = candidate.clone();
            e.copy_section(&c.data, &mut with_data_form);
            assert_ne!(
                with_data_form, candidate,
                "{}: the candidate's own form",
                c.name
            );
        }
        let runout = &all[1].data.dynamics.axis_runout;
        assert!(runout.is_visible() && runout.cycles_per_wheel_rev == 3.0);
    }

    /// A larger `--excluded` run takes every listed effect once before going round, each on in
    /// the data, off in the nominal and out of the candidates with its switch mates, while every
    /// other effect stays a candidate; the default plan's three cases keep their names.
    #[test]
    fn excluded_cases_withhold_each_listed_effect_from_the_candidates() -> Result<(), DiagnoseError>
    {
        let base = suite_base(4.0)?;
        let listed = excluded_effects();
        let plan = SuitePlan {
            seeds_per_case: 0,
            null_cases: 0,
            flicker_cases: 0,
            excluded_cases: listed.len() + 1,
            ..SuitePlan::full(0)
        };
        let all = cases(&base, &plan, &[]);
        assert_eq!(all.len(), listed.len() + 1);
        let names: Vec<&str> = all.iter().take(3).map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "oov-excluded-rolling_shutter-0",
                "oov-excluded-optical_blur-1",
                "oov-excluded-pixel_noise-2",
            ]
        );
        for (c, e) in all.iter().zip(listed.iter().cycle()) {
            assert_eq!(c.expectation, Expectation::OutOfVocabulary, "{}", c.name);
            assert!(c.name.starts_with(&format!("oov-excluded-{}-", e.name())));
            assert!(!e.is_on(&c.nominal) && e.is_on(&c.data), "{}", c.name);
            let candidates = c.effects.clone().unwrap_or_default();
            for other in Effect::ALL {
                let out = other == *e || e.shares_switch_with().contains(&other);
                assert_eq!(
                    candidates.contains(&other),
                    !out,
                    "{}: {}",
                    c.name,
                    other.name()
                );
            }
        }
        assert_ne!(all[0].data.seed, all[listed.len()].data.seed);
        for twin in [
            Effect::FrameTiming,
            Effect::Timebase,
            Effect::MotionBlur,
            Effect::Overrotation,
        ] {
            assert!(!listed.contains(&twin), "{}", twin.name());
        }
        for (i, e) in listed.iter().enumerate() {
            assert!(!listed[..i].contains(e), "{} listed twice", e.name());
        }
        Ok(())
    }

    /// The report so far of a run in progress: read from its staging folder without changing
    /// it, the figures over the finished cases only, the README saying how many of the plan's
    /// cases those are and naming the others. A run of another plan, a folder with no run, no
    /// finished case or the run's own folder as the target are refused by name.
    #[test]
    fn a_report_so_far_holds_the_finished_cases_and_names_the_others() -> Result<(), DiagnoseError>
    {
        let base = suite_base(2.0)?;
        let plan = SuitePlan::quick(Effect::PixelNoise);
        let all = cases(&base, &plan, &[]);
        let names: Vec<String> = all.iter().map(|c| c.name.clone()).collect();
        let text = plan.describe(&base, &DiagnoseOptions::default());
        let study = SelfCheck::new(all.clone(), DiagnoseOptions::default(), text.clone());
        let tmp = tempfile::tempdir().map_err(|e| FileError::io(Path::new("tmp"))(e))?;
        let run = tmp.path().join("run");
        let into = tmp.path().join("so-far");
        let err = study.report_so_far(&run, &into).unwrap_err().to_string();
        assert!(err.contains("no run of this study has started"), "{err}");

        let staging = tmp.path().join(".run.partial");
        std::fs::create_dir_all(&staging).map_err(FileError::io(&staging))?;
        study.manifest().write(&staging)?;
        let err = study.report_so_far(&run, &into).unwrap_err().to_string();
        assert!(
            err.contains("no case of the self-check's 3 has finished"),
            "{err}"
        );

        // The withheld case finished; another's record is being written (no end of line yet).
        let w = all
            .iter()
            .position(|c| matches!(c.expectation, Expectation::Withheld { .. }))
            .unwrap_or_default();
        let cut = (w + 1) % names.len();
        let finished = CaseOutcome {
            name: names[w].clone(),
            expectation: all[w].expectation.clone(),
            verdict: "explained".into(),
            ranked: vec![vec!["pixel_noise".into()]],
            ranked_labels: vec!["pixel_noise".into()],
            best_shrink: Some(0.9),
            param_rel_errors: vec![0.05],
            param_errors_in_sd: vec![0.5],
            params_in_ci95: vec![true],
            eval_seeds: 4,
        };
        let record = serde_json::to_string(&finished).unwrap_or_default();
        let log = staging.join(crate::shard::LOG);
        let lines = format!("{w}\t{record}\n{cut}\t{{\"name\": \"{}\"", names[cut]);
        std::fs::write(&log, &lines).map_err(FileError::io(&log))?;
        let SoFar::Written {
            finished: 1,
            total: 3,
            files,
        } = study.report_so_far(&run, &into)?
        else {
            panic!("one of three cases reported")
        };
        assert_eq!(files.len(), 4, "{files:?}");
        let readme = std::fs::read_to_string(into.join("README.md")).unwrap_or_default();
        assert!(
            readme.contains("**So far: 1 of the plan's 3 cases finished**"),
            "{readme}"
        );
        let others: Vec<&str> = (0..names.len())
            .filter(|&u| u != w)
            .map(|u| names[u].as_str())
            .collect();
        let waiting = format!("not finished yet: {}.", others.join(", "));
        assert!(readme.contains(&waiting), "{readme}");
        assert!(
            readme.contains(&format!("| {} | explained |", names[w])),
            "{readme}"
        );
        let summary: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(into.join("summary.json")).unwrap_or_default(),
        )
        .unwrap_or_default();
        assert_eq!(summary["top1_strong"]["n"], 1, "{summary}");
        // The run's own files are as they were: the record being written is not touched.
        assert_eq!(std::fs::read_to_string(&log).ok(), Some(lines.clone()));
        assert!(!run.exists());
        // Asked again, the report is replaced.
        study.report_so_far(&run, &into)?;

        for own in [
            run.clone(),
            run.join("so-far"),
            staging.clone(),
            tmp.path().into(),
        ] {
            let err = study.report_so_far(&run, &own).unwrap_err().to_string();
            assert!(
                err.contains("apart from the run's own"),
                "{}: {err}",
                own.display()
            );
        }
        assert_eq!(std::fs::read_to_string(&log).ok(), Some(lines.clone()));
        let other = SelfCheck::new(all[..2].to_vec(), DiagnoseOptions::default(), text);
        let err = other.report_so_far(&run, &into).unwrap_err().to_string();
        assert!(err.contains("the run there has other inputs"), "{err}");
        Ok(())
    }
}
