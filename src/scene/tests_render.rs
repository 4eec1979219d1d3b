//! Renders of whole rigs: a scenario without `scene.appearance` renders the bytes it rendered
//! before appearances existed (hashes taken from the renderer of that time), with every effect
//! on, in full frames and windows, by both renderers.

use crate::pipeline::rig::Rig;
use crate::render::independent::render_frame_independent;
use crate::render::{render_frame, FrameRequest, PixelRect};
use std::path::Path;

/// The built-in `fast` rig, smaller, with every image effect, a tilted distorting camera, a reference
/// marker and an axis runout on.
pub(crate) const ALL_EFFECTS_TOML: &str = r#"
extend = "fast"
[scene.reference_marker]
enabled = true
position_mm = [-150.0, 60.0]
size_mm = 30.0
white_margin_mm = 6.0
[camera]
width_px = 480
height_px = 300
[camera.focal]
kind = "image_scale"
mm_per_px = 0.9
[camera.perspective_tilt]
enabled = true
tilt_x_deg = 8.0
tilt_y_deg = -5.0
[camera.lens_distortion]
enabled = true
k1 = -0.08
k2 = 0.02
[dynamics.axis_runout]
enabled = true
amplitude_m = 0.0004
cycles_per_wheel_rev = 2.0
frequency_hz = 3.0
[effects.motion_blur]
enabled = true
exposure_s = 0.008
max_samples = 12
[effects.rolling_shutter]
enabled = true
readout_s = 0.012
[effects.optical_blur]
enabled = true
sigma_px = 1.1
[effects.camera_vibration]
enabled = true
[effects.camera_vibration.random]
x_rms_px = 0.3
rotation_rms_rad = 0.0005
[effects.lighting]
gradient_x_frac = -0.15
vignetting_frac = 0.2
gamma = 1.3
[effects.pixel_noise]
enabled = true
[effects.compression]
enabled = true
quality = 80
"#;

pub(crate) fn all_effects_rig() -> Rig {
    let s = crate::scenario::from_str(ALL_EFFECTS_TOML, Path::new("all-effects.toml")).unwrap();
    Rig::new(&s).unwrap()
}

/// 64-bit FNV-1a.
fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Hashes of frames of [`ALL_EFFECTS_TOML`]: full frames at a dwell (0.05 s) and in motion
/// (0.9 s), a window around the marker in motion, and the independent renderer's full frame in
/// motion.
fn hashes(rig: &Rig) -> Vec<u64> {
    let scene = rig.animated();
    let full = rig.frame_rect();
    let mut out = Vec::new();
    for (index, t_s) in [(1u64, 0.05), (27, 0.9)] {
        let f = render_frame(
            &scene,
            &rig.settings,
            &FrameRequest {
                index,
                t_s,
                window: full,
            },
        );
        out.push(fnv1a64(&f.data));
    }
    let bbox = scene.marker_bbox_px(0.9);
    let window = PixelRect::new(
        bbox.min_px.x as i64 - 40,
        bbox.min_px.y as i64 - 40,
        (bbox.max_px.x - bbox.min_px.x) as usize + 80,
        (bbox.max_px.y - bbox.min_px.y) as usize + 80,
    );
    let w = render_frame(
        &scene,
        &rig.settings,
        &FrameRequest {
            index: 27,
            t_s: 0.9,
            window,
        },
    );
    out.push(fnv1a64(&w.data));
    let ind = render_frame_independent(&scene, &rig.settings, 27, 0.9).unwrap();
    out.push(fnv1a64(&ind.data));
    out
}

#[test]
fn a_scenario_without_an_appearance_renders_the_bytes_it_always_did() {
    let got = hashes(&all_effects_rig());
    let want: Vec<u64> = vec![
        17651790731566636209,
        99363471514376728,
        852393520596583577,
        14889760452460558729,
    ];
    assert_eq!(got, want, "{got:#x?}");
}
