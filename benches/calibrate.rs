//! `geneva calibrate` on 300 frames of 4K footage (speed target: under a minute on
//! the 2-core machine): `seed-internal-4k` (3840×2160, 10 s at ~30 fps with the phone's VFR
//! timing, seed effects) rendered once to JPEG frames (quality 95, like the phone's; ~0.5 GB,
//! where PNGs or a video's intermediate PNGs would need several GB) with their timestamps, then
//! calibrated from them (decode, detect, measure, fit, match by simulation, write). Prints the
//! calibration's wall time, frames/s and peak memory, and a few fitted values beside the truth.
//! Run: `cargo bench --bench calibrate` (or `cargo xtask bench`).

use geneva_vision::calibrate::CalibrateOptions;
use geneva_vision::pipeline::calibrate::{calibrate, Footage};
use geneva_vision::pipeline::rig::Rig;
use geneva_vision::render::{render_frame, FrameRequest, PixelRect};
use geneva_vision::scenario;
use geneva_vision::timing::{to_frames_csv, Timestamps};
use rayon::prelude::*;
use std::time::Instant;

mod common;
use common::peak_rss_mb;

fn main() {
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let truth = scenario::load_any("seed-internal-4k").expect("built-in");
    let dir = tempfile::tempdir().expect("temp dir");
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).expect("frames dir");
    let t0 = Instant::now();
    let rig = Rig::new(&truth).expect("rig");
    let times = rig.frame_times.as_slice().to_vec();
    let scene = rig.animated();
    let (w, h) = (
        truth.camera.width_px as usize,
        truth.camera.height_px as usize,
    );
    let indices: Vec<usize> = (0..times.len()).collect();
    for chunk in indices.chunks(4) {
        chunk.par_iter().for_each(|&k| {
            let img = render_frame(
                &scene,
                &rig.settings,
                &FrameRequest {
                    index: k as u64,
                    t_s: times[k],
                    window: PixelRect::new(0, 0, w, h),
                },
            );
            jpeg_encoder::Encoder::new_file(frames.join(format!("frame_{k:04}.jpg")), 95)
                .expect("jpeg file")
                .encode(&img.data, w as u16, h as u16, jpeg_encoder::ColorType::Luma)
                .expect("jpeg");
        });
    }
    let ts = dir.path().join("timestamps.csv");
    std::fs::write(
        &ts,
        to_frames_csv(&Timestamps::new(times.clone()).expect("timestamps")),
    )
    .expect("timestamps");
    eprintln!(
        "calibrate bench: rendered {} frames of {w}×{h} to JPEG in {:.1} s (not timed below)",
        times.len(),
        t0.elapsed().as_secs_f64()
    );
    let base = dir.path().join("base.toml");
    std::fs::write(
        &base,
        "extend = \"seed-internal-4k\"\n[scene.marker]\nsize_mm = 32.0\n",
    )
    .expect("base");
    let t = Instant::now();
    let out = calibrate(
        &Footage::Frames {
            dir: frames.clone(),
            timestamps: ts,
        },
        &base.display().to_string(),
        &dir.path().join("cal"),
        &CalibrateOptions {
            single_frame: false,
        },
        &|_, _| {},
    )
    .expect("calibrate");
    let secs = t.elapsed().as_secs_f64();
    let c = &out.calibration;
    println!(
        "calibrate 3840×2160, {} JPEG frames: {:.1} s, {:.1} frames/s, peak memory {:.0} MB",
        c.frames,
        secs,
        c.frames as f64 / secs,
        peak_rss_mb()
    );
    let scale = match truth.camera.focal {
        geneva_vision::camera::FocalConfig::ImageScale { mm_per_px } => Some(mm_per_px),
        _ => None,
    };
    println!(
        "  fitted: scale {} mm/px (truth {:?}), blur σ {:?} px (truth {}), centre {:?} px",
        c.geometry.mm_per_px,
        scale,
        c.imaging.blur_sigma_param_px.map(|b| b.to_string()),
        truth.effects.optical_blur.sigma_px,
        c.geometry.centre_px.map(|[x, y]| format!("({x}, {y})"))
    );
}
