//! Render time per frame (full frame and a ~300×300 region of interest) for 1920×1080 and
//! 3840×2160 with a marker-like scene, optical blur, lighting and pixel noise on.
//! Run: `cargo bench --no-default-features --bench render [-- NAME_FILTER]`.

use geneva_vision::render::test_scenes::SpinningMarker;
use geneva_vision::render::{
    render_frame_with, EffectsConfig, FrameBuffers, FrameRequest, PixelRect, RenderSettings,
};
use glam::DVec2;
use std::time::Instant;

fn time_per_frame_ms(
    scene: &SpinningMarker,
    settings: &RenderSettings,
    window: PixelRect,
    frames: u64,
) -> (f64, u64) {
    // One warm-up frame (buffer allocation, thread pool start); buffers are reused after.
    let mut buffers = FrameBuffers::default();
    let _ = render_frame_with(
        scene,
        settings,
        &FrameRequest {
            index: 0,
            t_s: 0.0,
            window,
        },
        &mut buffers,
    );
    // Only the renders are timed; the hash of every frame is taken outside the clock.
    let mut elapsed_s = 0.0;
    let mut checksum = 0u64;
    for i in 0..frames {
        let start = Instant::now();
        let img = render_frame_with(
            scene,
            settings,
            &FrameRequest {
                index: i,
                t_s: i as f64 / 30.0,
                window,
            },
            &mut buffers,
        );
        elapsed_s += start.elapsed().as_secs_f64();
        checksum = fnv1a(checksum, &img.data);
    }
    (elapsed_s * 1e3 / frames as f64, checksum)
}

/// FNV-1a over the frame bytes: printed so an optimisation can be checked to keep every bit.
fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    if h == 0 {
        h = 0xcbf2_9ce4_8422_2325;
    }
    for &b in bytes {
        h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
    }
    h
}

fn main() {
    let blur_noise = {
        let mut fx = EffectsConfig::none();
        let d = EffectsConfig::default();
        fx.optical_blur = d.optical_blur;
        fx.pixel_noise = d.pixel_noise;
        fx.lighting = d.lighting;
        fx
    };
    let only = |f: &dyn Fn(&mut EffectsConfig)| {
        let mut fx = EffectsConfig::none();
        f(&mut fx);
        fx
    };
    let configs = [
        ("raster + quantise only", EffectsConfig::none()),
        ("blur only", only(&|fx| fx.optical_blur.enabled = true)),
        ("noise only", only(&|fx| fx.pixel_noise.enabled = true)),
        ("blur+noise+lighting", blur_noise),
        (
            "defaults (+motion blur, spinning 3 rad/s)",
            EffectsConfig::default(),
        ),
        ("defaults + rolling shutter", {
            let mut fx = EffectsConfig::default();
            fx.rolling_shutter.enabled = true;
            fx
        }),
    ];
    // Optional filter: `cargo bench --bench render -- noise` runs the configs whose name
    // contains "noise".
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    println!("threads: {}", rayon::current_num_threads());
    for (name, effects) in configs {
        if !filter.is_empty() && !filter.iter().any(|f| name.contains(f.as_str())) {
            continue;
        }
        for (w, h, side) in [(1920usize, 1080usize, 120.0), (3840, 2160, 240.0)] {
            let settings = RenderSettings {
                width_px: w,
                height_px: h,
                effects: effects.clone(),
                seed: 7,
            };
            let centre = DVec2::new(w as f64 * 0.55, h as f64 * 0.45);
            let scene = SpinningMarker {
                centre_px: centre,
                side_px: side,
                rate_rad_s: 3.0,
            };
            let (full, full_hash) = time_per_frame_ms(&scene, &settings, settings.frame_rect(), 10);
            let roi = PixelRect::new(centre.x as i64 - 150, centre.y as i64 - 150, 300, 300);
            let (roi_ms, roi_hash) = time_per_frame_ms(&scene, &settings, roi, 200);
            println!(
                "{name:42} {w}x{h}: full frame {full:8.2} ms/frame, ROI 300x300 {roi_ms:7.3} \
                 ms/frame  [hash {full_hash:016x} {roi_hash:016x}]"
            );
        }
    }
}
