//! `geneva analyze`'s error bars (target: within 2× of the analysis alone plus one Monte Carlo
//! run of the same frames on as many seeds): 8 s of the `fast` rig (240 frames of 1280×720)
//! rendered once to PNG with its timestamps, then analysed without bars, analysed with bars on 16
//! seeds, and run as a 16-seed Monte Carlo. Prints the three wall times, the ratio against the
//! target, the machine's load and the peak memory.
//! Run: `cargo bench --bench error_bars` (or `cargo xtask bench`).

use geneva_vision::pipeline::analyze::{analyze, AnalyzeOptions, Source};
use geneva_vision::pipeline::error_bars::{error_bars, ErrorBarOptions};
use geneva_vision::pipeline::montecarlo::{monte_carlo, MonteCarloOptions};
use geneva_vision::pipeline::render_job::{render_job, RenderJob};
use geneva_vision::scenario;
use std::time::Instant;

mod common;
use common::{load_average, peak_rss_mb};

fn main() {
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let seeds = ErrorBarOptions::default().seeds;
    let mut rig = scenario::load_any("fast").expect("built-in");
    rig.duration_s = 8.0;
    let dir = tempfile::tempdir().expect("temp dir");
    let frames = dir.path().join("frames");
    let job = RenderJob {
        png: true,
        ..RenderJob::default()
    };
    render_job(&rig, &frames, &job, &|_, _| {}).expect("render");
    let options = AnalyzeOptions::from_scenario(&rig, AnalyzeOptions::default().angle_sign);
    let source = Source::Frames {
        dir: frames.clone(),
        timestamps: frames.join("timestamps.csv"),
    };
    let t = Instant::now();
    let analysis = analyze(&source, &options, &dir.path().join("a"), &|_, _| {}).expect("analyze");
    let analyze_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let bars = error_bars(
        &rig,
        &analysis,
        options.angle_sign,
        &ErrorBarOptions::default(),
        &|_, _| {},
    )
    .expect("error bars");
    let bars_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mc = MonteCarloOptions {
        seeds,
        write_files: false,
        ..MonteCarloOptions::default()
    };
    monte_carlo(&rig, &dir.path().join("mc"), &mc).expect("monte carlo");
    let mc_s = t.elapsed().as_secs_f64();
    let with = analyze_s + bars_s;
    let budget = 2.0 * (analyze_s + mc_s);
    println!(
        "error bars, 240 frames of 1280×720, {} seeds: analyze {analyze_s:.1} s + bars {bars_s:.1} s \
         = {with:.1} s against analyze + Monte Carlo {:.1} s (target: within 2×, ≤ {budget:.1} s; \
         {}); load {}, peak memory {:.0} MB",
        bars.seeds.len(),
        analyze_s + mc_s,
        if with <= budget { "met" } else { "NOT met" },
        load_average(),
        peak_rss_mb()
    );
}
