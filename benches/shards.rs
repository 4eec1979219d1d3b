//! Cost of the work-unit layer itself (no rendering: a trivial evaluator), as the study grows:
//! per-unit overhead of a whole run (log append + flush per unit), a 64-shard run plus the merge,
//! merge time, and the output sizes — the "scale on paper" figures of docs/studies.md.
//! Run: `cargo bench --bench shards` (or `cargo xtask bench`); `GENEVA_BENCH_UNITS=1000,10000`
//! chooses the study sizes (default 1000, 10000, 100000).

use geneva_vision::scenario::Scenario;
use geneva_vision::shard::{Control, Shard};
use geneva_vision::sweep::{
    merge_sweep, run_sweep_with, Evaluator, PointMetrics, SweepRun, SweepSpec,
};
use std::path::Path;
use std::time::Instant;

/// Metrics as a cheap function of the settings and the seed (what a real run would return).
struct Instant0;

#[derive(Debug, thiserror::Error)]
#[error("never")]
struct Never;

impl Evaluator for Instant0 {
    type Error = Never;
    fn evaluate(&self, sc: &Scenario, seed: u64) -> Result<PointMetrics, Never> {
        let fps = sc.frame_timing.fps;
        let j = 1.0 + (seed % 1000) as f64 * 1e-5;
        Ok(PointMetrics {
            theta_rms_rad: 1e-4 * j,
            omega_rms_rad_s: 0.9 / fps * j,
            alpha_rms_rad_s2: 20.0 / fps * j,
            omega_p95_rad_s: 1.8 / fps,
            alpha_p95_rad_s2: 40.0 / fps,
            frames_total: 300,
            frames_detected: 300,
            engaged_alpha_noise_rad_s2: 0.1 * j,
            mean_frame_interval_s: 1.0 / fps,
            kalman_lambda_per_s6: f64::NAN,
        })
    }
}

fn size(dir: &Path) -> u64 {
    let mut total = 0;
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            total += if p.is_dir() {
                size(&p)
            } else {
                e.metadata().map(|m| m.len()).unwrap_or(0)
            };
        }
    }
    total
}

fn main() {
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let sizes: Vec<usize> = std::env::var("GENEVA_BENCH_UNITS")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![1_000, 10_000, 100_000]);
    let root = std::env::temp_dir().join(format!("geneva-bench-shards-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).expect("bench folder");
    println!(
        "threads: {}; trivial evaluator (the unit layer's own cost)",
        rayon::current_num_threads()
    );
    for units in sizes {
        // points × seeds with 100 seeds a point (or fewer for small studies).
        let seeds = 100.min(units);
        let points = units / seeds;
        let values: Vec<String> = (0..points)
            .map(|i| format!("{:.3}", 20.0 + i as f64 * 0.01))
            .collect();
        let spec_path = root.join(format!("s{units}.toml"));
        std::fs::write(
            &spec_path,
            format!(
                "base = \"fast\"\nseeds = {seeds}\n[[axis]]\nname = \"fps\"\nfield = \"frame_timing.fps\"\nvalues = [{}]\n",
                values.join(", ")
            ),
        )
        .expect("sweep file");
        let spec = SweepSpec::load(&spec_path).expect("spec");
        let none = Control::none();
        let whole = root.join(format!("whole{units}"));
        let t = Instant::now();
        let run = SweepRun {
            shard: None,
            restart: false,
            control: &none,
        };
        run_sweep_with(&spec, &spec_path, &whole, &Instant0, &run).expect("whole");
        let whole_s = t.elapsed().as_secs_f64();
        let sharded = root.join(format!("sharded{units}"));
        let t = Instant::now();
        for i in 0..64 {
            let run = SweepRun {
                shard: Some(Shard::new(i, 64).expect("shard")),
                restart: false,
                control: &none,
            };
            run_sweep_with(&spec, &spec_path, &sharded, &Instant0, &run).expect("shard");
        }
        let shards_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        merge_sweep(&spec, &spec_path, &sharded).expect("merge");
        let merge_s = t.elapsed().as_secs_f64();
        let same = std::fs::read(whole.join("results.csv")).ok()
            == std::fs::read(sharded.join("results.csv")).ok();
        println!(
            "{units} units ({points} points × {seeds} seeds): whole run {whole_s:.2} s ({:.0} µs/unit); 64 shards one after another {shards_s:.2} s; merge {merge_s:.2} s; results.csv {:.1} MB, summary.csv {:.2} MB, shards/ {:.1} MB; merged = whole: {same}",
            whole_s / units as f64 * 1e6,
            size_of(&whole.join("results.csv")) as f64 / 1e6,
            size_of(&whole.join("summary.csv")) as f64 / 1e6,
            size(&sharded.join("shards")) as f64 / 1e6,
        );
    }
    let _ = std::fs::remove_dir_all(&root);
}

fn size_of(p: &Path) -> u64 {
    std::fs::metadata(p).map(|m| m.len()).unwrap_or(0)
}
