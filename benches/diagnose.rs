//! Wall time of one diagnosis: 300 frames of 1280×720 footage with a
//! withheld rolling shutter (30 ms readout), all candidates, from the frames and from the
//! tracks CSV the frame run wrote; then the same footage with a withheld axis runout instead,
//! whose candidate costs most per trial. Targets on the 2-core reference machine: ≤ 5 min from frames,
//! ≤ 2 min from tracks.
//! Stage wall times (measuring, aligning, simulating the nominal, each fit) go to stderr; the
//! figures, with the machine's load average beside them, to stdout.
//! Run: `cargo bench --bench diagnose` (or `cargo xtask bench`). `GENEVA_BENCH_ONLY=runout`
//! (or `frames`, `tracks`, comma-separated; `tracks` needs `frames`) runs only those figures;
//! `GENEVA_BENCH_KEEP=DIR` keeps the footage and the diagnoses in DIR, a new or empty folder (to
//! compare the outputs of two builds: an optimisation that keeps the floating-point order keeps
//! them bit for bit). An unknown figure name or a non-empty DIR stops the run before any work.

use geneva_vision::diagnose::scoring::Expectation;
use geneva_vision::pipeline::analyze::Source;
use geneva_vision::pipeline::diagnose::selfcheck::{
    level_values, render_case, suite_base, Case, Level, PostProcess,
};
use geneva_vision::pipeline::diagnose::{diagnose, DiagnoseOptions, Diagnosis, StageLog};
use geneva_vision::scenario::effects::Effect;
use geneva_vision::scenario::Scenario;
use std::path::Path;
use std::time::Instant;

mod common;
use common::{cpu_time_s, load_average, peak_rss_mb};

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
    println!("threads: {}", rayon::current_num_threads());
    let only: Option<Vec<String>> = std::env::var("GENEVA_BENCH_ONLY")
        .ok()
        .map(|o| o.split(',').map(|x| x.trim().to_string()).collect());
    // A misspelt figure would run nothing and still succeed: refuse it.
    if let Some(only) = &only {
        for figure in only {
            assert!(
                ["frames", "tracks", "runout"].contains(&figure.as_str()),
                "GENEVA_BENCH_ONLY: unknown figure `{figure}` (frames, tracks, runout)"
            );
        }
        assert!(
            !only.iter().any(|f| f == "tracks") || only.iter().any(|f| f == "frames"),
            "GENEVA_BENCH_ONLY: `tracks` reads the tracks.csv the `frames` figure writes; add `frames`"
        );
    }
    let runs = |figure: &str| only.as_ref().is_none_or(|o| o.iter().any(|x| x == figure));
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
    let nominal = suite_base(10.0).expect("built-in rig");
    if runs("frames") {
        let rolling_shutter = withheld(&nominal, Effect::RollingShutter, &[0.03], root);
        let from_frames = timed(&nominal, &rolling_shutter, &root.join("from-frames"));
        report(
            &format!(
                "{} frames {}x{}, all candidates",
                from_frames.0.frames, nominal.camera.width_px, nominal.camera.height_px
            ),
            &from_frames,
            300.0,
        );
        if runs("tracks") {
            let tracks = Source::Tracks(root.join("from-frames/real/tracks.csv"));
            let from_tracks = timed(&nominal, &tracks, &root.join("from-tracks"));
            report("the same from its tracks.csv", &from_tracks, 120.0);
        }
    }
    if !runs("runout") {
        println!("diagnose: peak memory {:.0} MB", peak_rss_mb());
        return;
    }
    // The costliest candidate to fit: every trial of a runout realigns the crank motion through
    // its own wobble (estimator passes on exact corners) besides simulating the footage.
    let runout_values = level_values(Effect::AxisRunout, Level::Strong, nominal.frame_timing.fps);
    let runout = withheld(&nominal, Effect::AxisRunout, &runout_values, root);
    let runout = timed(&nominal, &runout, &root.join("runout"));
    report(
        &format!(
            "{} frames with a withheld {:.1} mm axis runout, all candidates",
            runout.0.frames,
            1e3 * runout_values[0]
        ),
        &runout,
        300.0,
    );
    println!("diagnose: peak memory {:.0} MB", peak_rss_mb());
}

/// Footage of `nominal` with `effect` at `values` (and another seed), rendered into a folder of
/// `tmp` named after the effect: the source a diagnosis reads.
fn withheld(nominal: &Scenario, effect: Effect, values: &[f64], tmp: &Path) -> Source {
    let mut data = nominal.clone();
    effect.apply(&mut data, values);
    data.seed = nominal.seed + 17;
    let case = Case {
        name: "bench".into(),
        expectation: Expectation::Withheld {
            effect: effect.name().into(),
            also: vec![],
            strong: true,
            form: false,
        },
        data,
        nominal: nominal.clone(),
        post: PostProcess::None,
        effects: None,
        truths: Vec::new(),
        renderer: Default::default(),
    };
    let frames = tmp.join(format!("frames-{}", effect.name()));
    let started = Instant::now();
    render_case(&case, &frames).expect("render");
    eprintln!(
        "  rendered the footage of a withheld {} in {:.1} s (not part of the figure)",
        effect.name(),
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

fn report(what: &str, (d, wall_s, cpu_s): &(Diagnosis, f64, f64), target_s: f64) {
    let threads = rayon::current_num_threads() as f64;
    println!(
        "diagnose: {what}: {wall_s:.1} s wall (target <= {target_s:.0} s) at load {}; CPU {cpu_s:.1} s (÷ {threads} cores = {:.1} s: the wall time on idle cores kept busy); {} simulations, {} candidate(s) fitted, {} screened out by signature, {} bounded out, {} not judged; verdict {}",
        load_average(),
        cpu_s / threads,
        d.simulations,
        d.ranking.len(),
        d.screened_out.len(),
        d.bounded_out.len(),
        d.not_judged.len(),
        d.verdict.as_str(),
    );
}
