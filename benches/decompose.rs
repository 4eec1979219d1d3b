//! The 4K per-source decomposition of the report (`reports/decomposition/4k-seed-settings`):
//! the internal seed rig at 3840×2160, 4 s, seed settings, over the built-in effects it has on,
//! with the report's seed rule (4 seeds, then more until every share's 95 % CI half-width is
//! below 5 percentage points, at most 16), then with the default rule of `geneva decompose`
//! (at most 64). Prints the wall time of each (target: under 10 minutes on the 2-core machine),
//! the seeds, why they stopped, and the widest half-width.
//! The machine's load and the CPU time are printed beside every wall time.
//! `GENEVA_BENCH_DECOMPOSE_RULES=report` (or `default`) runs one rule only.
//! Run: `cargo bench --bench decompose` (or `cargo xtask bench`).

use geneva_vision::budget::decompose::SeedRule;
use geneva_vision::pipeline::decompose::{decompose_effects, DecomposeOptions};
use geneva_vision::pipeline::reports::{
    decomposition_scenario, DECOMPOSITION_CASES, REPORT_SEED_RULE,
};
use std::time::Instant;

mod common;
use common::{cpu_time_s, load_average};

fn main() {
    // `cargo test --benches` runs this binary without `--bench`: do nothing then.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let (folder, label, w, h, scale, better) = DECOMPOSITION_CASES[0];
    let sc = decomposition_scenario(folder, w, h, scale, better).expect("scenario");
    println!(
        "decomposition {label} ({folder}), threads: {}",
        rayon::current_num_threads()
    );
    let only = std::env::var("GENEVA_BENCH_DECOMPOSE_RULES").unwrap_or_default();
    for (name, rule) in [
        ("report rule", REPORT_SEED_RULE),
        ("default rule", SeedRule::default()),
    ] {
        if !only.is_empty() && !name.starts_with(only.as_str()) {
            continue;
        }
        let started = Instant::now();
        let cpu0 = cpu_time_s();
        let d = decompose_effects(&sc, &DecomposeOptions { rule, roi: true }, &|line| {
            println!("  [{:6.0} s] {line}", started.elapsed().as_secs_f64())
        })
        .expect("decomposition");
        let secs = started.elapsed().as_secs_f64();
        let cpu_s = cpu_time_s() - cpu0;
        let threads = rayon::current_num_threads() as f64;
        println!(
            "4K decomposition, {name} (cap {}): {:.1} s ({:.1} min; target < 10 min) at load {}; CPU {:.0} s (÷ {threads} cores = {:.1} min: the wall time on idle cores kept busy); {} sources, {} seeds ({:?}: {}), {} pipeline runs ({:.2} s a run); widest share half-width ω2 {:.1} pp, α2 {:.1} pp",
            rule.cap,
            secs,
            secs / 60.0,
            load_average(),
            cpu_s,
            cpu_s / threads / 60.0,
            d.sources.len(),
            d.seeds,
            d.stop,
            d.stop.describe(),
            d.runs,
            secs / d.runs as f64,
            100.0 * d.omega.widest_share_half_width(),
            100.0 * d.alpha.widest_share_half_width(),
        );
    }
}
