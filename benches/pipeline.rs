//! End-to-end throughput of `geneva run` on the seed scenario (3840×2160, ~300 frames, seed
//! effects on): frames/s with ROI detection (the whole run: render, detect, estimate, budget)
//! and frames/s of full-frame rendering + detection on a subset, plus peak memory (VmHWM).
//! Then the Monte Carlo rate: 1080p, 100-frame runs (the sweep/Monte Carlo workload), runs in
//! parallel over seeds, printed as runs per second and the time a 1000-run sweep would take.
//! Run: `cargo bench --bench pipeline` (or `cargo xtask bench`).

use geneva_vision::pipeline::frames::{detect_frames, FrameLoopOptions};
use geneva_vision::pipeline::rig::Rig;
use geneva_vision::pipeline::run::{run, RunOptions};
use geneva_vision::scenario;
use rayon::prelude::*;
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

    let mc = scenario::from_str(
        "extend = \"seed-internal-4k\"\nname = \"mc-1080p\"\nduration_s = 3.3\n[camera]\nwidth_px = 1920\nheight_px = 1080\n[camera.focal]\nkind = \"image_scale\"\nmm_per_px = 0.39\n[dynamics]\nenabled = false\n",
        std::path::Path::new("bench.toml"),
    )
    .expect("bench scenario");
    let runs = 40u64;
    let start = Instant::now();
    let frames: usize = (0..runs)
        .into_par_iter()
        .map(|k| {
            let mut s = mc.clone();
            s.seed = 1000 + k;
            let o = run(
                &s,
                &dir,
                &RunOptions {
                    plots: false,
                    write_files: false,
                    ..RunOptions::default()
                },
                &|_, _| {},
            )
            .expect("mc run");
            o.detections.len()
        })
        .sum();
    let secs = start.elapsed().as_secs_f64();
    let rate = runs as f64 / secs;
    println!(
        "Monte Carlo, 1080p runs of {} frames: {runs} runs in {:.1} s = {:.2} runs/s; a 1000-run sweep would take {:.1} min (target < 5 min)",
        frames / runs as usize,
        secs,
        rate,
        1000.0 / rate / 60.0
    );
}
