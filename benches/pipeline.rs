//! End-to-end throughput of `geneva run` on the seed scenario (3840×2160, ~300 frames, seed
//! effects on): frames/s with ROI detection (the whole run: render, detect, estimate, budget)
//! and frames/s of full-frame rendering + detection on a subset, plus peak memory (VmHWM).
//! Then the Monte Carlo rate: 1080p, 100-frame runs through the sweep engine (parallel over
//! runs), printed as runs per second and the time a 1000-run sweep takes.
//! Run: `cargo bench --bench pipeline` (or `cargo xtask bench`).

use geneva_vision::pipeline::frames::{detect_frames, FrameLoopOptions};
use geneva_vision::pipeline::rig::Rig;
use geneva_vision::pipeline::run::{run, RunOptions};
use geneva_vision::pipeline::sweep_eval::PipelineEvaluator;
use geneva_vision::scenario;
use geneva_vision::sweep::{run_sweep, SweepSpec};
use std::time::Instant;

mod common;
use common::peak_rss_mb;

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

    monte_carlo_sweep(&dir);
}

/// The Monte Carlo workload through the real sweep engine (`geneva sweep`): a 1080p scenario of
/// 100 frames (the seed rig at 0.39 mm/px, exact kinematics), one point, N seeds run in parallel
/// and appended to results.csv as they finish. N = 48 by default (a 1000-run sweep is
/// extrapolated from it); `GENEVA_BENCH_MC_RUNS=1000` runs the whole sweep.
fn monte_carlo_sweep(dir: &std::path::Path) {
    let runs: usize = std::env::var("GENEVA_BENCH_MC_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(48);
    let work = dir.join("monte-carlo");
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(&work).expect("bench folder");
    let scenario_path = work.join("mc-1080p.toml");
    std::fs::write(
        &scenario_path,
        "extend = \"seed-internal-4k\"\nname = \"mc-1080p\"\nduration_s = 3.34\n[camera]\nwidth_px = 1920\nheight_px = 1080\n[camera.focal]\nkind = \"image_scale\"\nmm_per_px = 0.39\n[dynamics]\nenabled = false\n",
    )
    .expect("bench scenario");
    let frames = Rig::new(&scenario::load(&scenario_path).expect("bench scenario"))
        .expect("rig")
        .frame_times
        .len();
    let spec_path = work.join("mc.toml");
    let spec_text = format!(
        "base = \"mc-1080p.toml\"\nseeds = {runs}\n[[axis]]\nname = \"resolution\"\nlevels = [{{ label = \"1080p\", set = {{ \"camera.width_px\" = 1920, \"camera.height_px\" = 1080 }} }}]\n"
    );
    std::fs::write(&spec_path, &spec_text).expect("sweep file");
    let spec = SweepSpec::load(&spec_path).expect("sweep spec");
    let start = Instant::now();
    let outcome = run_sweep(
        &spec,
        &spec_path,
        &work.join("out"),
        &PipelineEvaluator,
        &|_, _| {},
    )
    .expect("sweep");
    let secs = start.elapsed().as_secs_f64();
    assert_eq!(outcome.jobs_run, runs, "every run must complete");
    let rate = runs as f64 / secs;
    println!(
        "Monte Carlo sweep (geneva sweep engine), 1080p runs of {frames} frames: {runs} runs in {secs:.1} s = {rate:.2} runs/s; a 1000-run sweep takes {:.1} min (target < 5 min); peak memory {:.0} MB",
        1000.0 / rate / 60.0,
        peak_rss_mb()
    );
}
