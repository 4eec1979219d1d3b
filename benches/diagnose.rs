//! Wall time of one diagnosis with every candidate, the case a user runs between takes: 240
//! frames (8 s at 30 fps) of 1280×960 footage of the `fast` rig, once for each effect of the
//! vocabulary withheld at the strong level and once for a null footage (the rig as nominal, on
//! another seed). Targets on the 2-core reference machine: the worst case ≤ 120 s wall, the
//! median ≤ 60 s; memory ≤ 500 MB.
//!
//! Prints one row per footage (effect, wall, CPU, simulations, verdict) with the machine's load,
//! then the worst and median against their targets. Stage wall times go to stderr.
//! Run: `cargo bench --bench diagnose` (or `cargo xtask bench`). `GENEVA_BENCH_ONLY=null,backlash`
//! (comma-separated footage names: `null` or an effect's name) runs only those rows;
//! `GENEVA_BENCH_KEEP=DIR` keeps the footage and the diagnoses in DIR, a new or empty folder (to
//! compare the outputs of two builds). An unknown name or a non-empty DIR stops the run before
//! any work.

use geneva_vision::diagnose::scoring::Expectation;
use geneva_vision::pipeline::analyze::Source;
use geneva_vision::pipeline::diagnose::{
    candidate_name, diagnose, DiagnoseOptions, Diagnosis, StageLog,
};
use geneva_vision::pipeline::selfcheck::{
    level_values, render_case, suite_base, Case, Level, PostProcess,
};
use geneva_vision::scenario::effects::Effect;
use geneva_vision::scenario::Scenario;
use std::path::Path;
use std::time::Instant;

mod common;
use common::{cpu_time_s, load_average, peak_rss_mb};

/// Targets of the issue this bench measures, s and MB.
const WORST_WALL_TARGET_S: f64 = 120.0;
const MEDIAN_WALL_TARGET_S: f64 = 60.0;
const MEMORY_TARGET_MB: f64 = 500.0;

/// Prints each new stage of a diagnosis with its wall time to stderr.
fn stage_printer(log: &StageLog) -> impl Fn(&str, usize, usize) + '_ {
    move |stage, _, _| {
        if let Some(line) = log.line(stage) {
            eprintln!("  {line}");
        }
    }
}

fn main() {
    // `cargo test --benches` runs this binary without `--bench`: do nothing then.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let footages: Vec<Option<Effect>> = std::iter::once(None)
        .chain(Effect::ALL.iter().copied().map(Some))
        .collect();
    let name = |f: &Option<Effect>| f.map_or("null", |e| e.name());
    let only: Option<Vec<String>> = std::env::var("GENEVA_BENCH_ONLY")
        .ok()
        .map(|o| o.split(',').map(|x| x.trim().to_string()).collect());
    // A misspelt name would run nothing and still succeed: refuse it.
    if let Some(only) = &only {
        for figure in only {
            assert!(
                footages.iter().any(|f| name(f) == figure),
                "GENEVA_BENCH_ONLY: unknown footage `{figure}` (null or an effect's name)"
            );
        }
    }
    let tmp = tempfile::tempdir().expect("temporary folder");
    let keep = std::env::var_os("GENEVA_BENCH_KEEP").map(std::path::PathBuf::from);
    let root = keep.as_deref().unwrap_or(tmp.path());
    std::fs::create_dir_all(root).expect("GENEVA_BENCH_KEEP folder");
    // Another run's footage or diagnoses left there would be mixed with this one's.
    assert!(
        std::fs::read_dir(root).is_ok_and(|mut d| d.next().is_none()),
        "GENEVA_BENCH_KEEP: {} is not an empty folder",
        root.display()
    );
    let mut nominal = suite_base(8.0).expect("built-in rig");
    nominal.camera.height_px = 960;
    println!(
        "threads: {}; {} frames of {}x{}, every candidate, default options",
        rayon::current_num_threads(),
        (nominal.duration_s * nominal.frame_timing.fps).round(),
        nominal.camera.width_px,
        nominal.camera.height_px
    );
    println!(
        "{:<18} {:>8} {:>8} {:>6}  {:<14} load (1/5/15 min)",
        "withheld", "wall s", "CPU s", "sims", "verdict"
    );
    let mut walls = Vec::new();
    for footage in footages
        .iter()
        .filter(|f| only.as_ref().is_none_or(|o| o.iter().any(|x| x == name(f))))
    {
        let source = withheld(&nominal, *footage, root);
        let (d, wall_s, cpu_s) = timed(&nominal, &source, &root.join(name(footage)));
        println!(
            "{:<18} {wall_s:>8.1} {cpu_s:>8.1} {:>6}  {:<14} {}",
            name(footage),
            d.simulations,
            verdict(&d),
            load_average()
        );
        walls.push(wall_s);
    }
    walls.sort_by(f64::total_cmp);
    if let (Some(worst), false) = (walls.last(), walls.is_empty()) {
        let median = if walls.len() % 2 == 1 {
            walls[walls.len() / 2]
        } else {
            0.5 * (walls[walls.len() / 2 - 1] + walls[walls.len() / 2])
        };
        println!(
            "diagnose: worst {worst:.1} s wall (target <= {WORST_WALL_TARGET_S:.0} s), median \
             {median:.1} s (target <= {MEDIAN_WALL_TARGET_S:.0} s) over {} footage(s)",
            walls.len()
        );
    }
    println!(
        "diagnose: peak memory {:.0} MB (target <= {MEMORY_TARGET_MB:.0} MB)",
        peak_rss_mb()
    );
}

/// The verdict and, when explained, by what.
fn verdict(d: &Diagnosis) -> String {
    match d.best.and_then(|b| d.ranking.get(b)) {
        Some(r) if d.verdict.as_str() == "explained" => {
            format!("{} ({})", d.verdict.as_str(), candidate_name(&r.evaluated))
        }
        _ => d.verdict.as_str().to_string(),
    }
}

/// Footage of `nominal` with `effect` withheld at the strong level (none: a null footage), on
/// another seed, rendered into a folder of `root` named after it: the source a diagnosis reads.
fn withheld(nominal: &Scenario, effect: Option<Effect>, root: &Path) -> Source {
    let mut data = nominal.clone();
    let expectation = match effect {
        Some(effect) => {
            let values = level_values(effect, Level::Strong, nominal.frame_timing.fps);
            effect.apply(&mut data, &values);
            Expectation::Withheld {
                effect: effect.name().into(),
                also: vec![],
                strong: true,
                form: false,
            }
        }
        None => Expectation::Null,
    };
    data.seed = nominal.seed + 17;
    let case = Case {
        name: "bench".into(),
        expectation,
        data,
        nominal: nominal.clone(),
        post: PostProcess::None,
        effects: None,
        truths: Vec::new(),
        renderer: Default::default(),
    };
    let frames = root.join(format!("frames-{}", effect.map_or("null", |e| e.name())));
    let started = Instant::now();
    render_case(&case, &frames).expect("render");
    eprintln!(
        "  rendered the footage {} in {:.1} s (not part of the figure)",
        frames.display(),
        started.elapsed().as_secs_f64()
    );
    Source::Frames {
        dir: frames.clone(),
        timestamps: frames.join("timestamps.csv"),
    }
}

/// One diagnosis with the default options: its result, wall time and CPU time, s.
fn timed(nominal: &Scenario, source: &Source, out: &Path) -> (Diagnosis, f64, f64) {
    let started = Instant::now();
    let cpu0 = cpu_time_s();
    let log = StageLog::new();
    let (d, _) = diagnose(
        nominal,
        source,
        out,
        &DiagnoseOptions::default(),
        &stage_printer(&log),
    )
    .expect("diagnosis");
    (d, started.elapsed().as_secs_f64(), cpu_time_s() - cpu0)
}
