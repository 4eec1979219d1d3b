//! End-to-end throughput of `geneva run` on the seed scenario (3840×2160, ~300 frames, seed
//! effects on): frames/s with ROI detection (the whole run: render, detect, estimate, budget)
//! and frames/s of full-frame rendering + detection on a subset, plus peak memory (VmHWM).
//! Run: `cargo bench --bench pipeline` (or `cargo xtask bench`).

use geneva_vision::pipeline::frames::{detect_frames, FrameLoopOptions};
use geneva_vision::pipeline::rig::Rig;
use geneva_vision::pipeline::run::{run, RunOptions};
use geneva_vision::scenario;
use std::time::Instant;

fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .map(|l| l.to_string())
        })
        .and_then(|l| {
            l.split_whitespace()
                .nth(1)
                .and_then(|v| v.parse::<f64>().ok())
        })
        .map(|kb| kb / 1024.0)
        .unwrap_or(f64::NAN)
}

fn main() {
    // `cargo test --benches` runs this binary without `--bench`: do nothing then.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let s = scenario::load_builtin("seed-internal-4k").expect("built-in scenario");
    let dir = std::env::temp_dir().join("geneva-bench-pipeline");
    println!("threads: {}", rayon::current_num_threads());
    let start = Instant::now();
    let out = run(
        &s,
        &dir,
        &RunOptions {
            plots: false,
            ..RunOptions::default()
        },
        &|_, _| {},
    )
    .expect("run");
    let secs = start.elapsed().as_secs_f64();
    println!(
        "seed-internal-4k end to end, ROI detection: {} frames in {:.2} s = {:.1} frames/s ({} ROI, {} full); peak memory {:.0} MB",
        out.detections.len(),
        secs,
        out.detections.len() as f64 / secs,
        out.roi_frames,
        out.full_frames,
        peak_rss_mb()
    );
    let rig = Rig::new(&s).expect("rig");
    let frames = 0..24.min(rig.frame_times.len());
    let count = frames.len();
    let start = Instant::now();
    detect_frames(
        &rig,
        frames,
        FrameLoopOptions {
            roi: false,
            chunk_frames: 8,
        },
        |_| Ok(()),
        &|_| {},
    )
    .expect("full frame");
    let secs = start.elapsed().as_secs_f64();
    println!(
        "seed-internal-4k render + full-frame detection: {count} frames in {:.2} s = {:.2} frames/s; peak memory {:.0} MB",
        secs,
        count as f64 / secs,
        peak_rss_mb()
    );
}
