//! `geneva diagnose --scenario NOMINAL (--video F | --frames DIR --timestamps F | --tracks F)
//! --out DIR [--effects a,b,c] [--seeds N] [--fit-seeds N] [--refits N | --no-refit] [--bootstrap B] [--max-minutes M] [--shard I/N [--restart] | --merge]`.
//! With `--shard I/N` the candidate fits are split across machines (written under
//! `DIR/shards/I/`); `--merge`, with the same arguments, writes the report a one-machine run
//! would have written.

use super::eta;
use anyhow::{bail, Result};
use clap::Args;
use geneva_vision::diagnose::simulator::SimMeter;
use geneva_vision::pipeline::diagnose::shards::Mode;
use geneva_vision::pipeline::diagnose::{
    candidate_name, diagnose_with, DiagnoseOptions, Finished, StageLog,
};
use geneva_vision::scenario;
use geneva_vision::shard::Shard;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct DiagnoseArgs {
    /// The rig as believed: a scenario file or built-in name (often `geneva calibrate`'s output).
    #[arg(long)]
    scenario: String,
    #[command(flatten)]
    source: super::source_args::SourceArgs,
    /// Candidate effects, comma separated (default: the whole vocabulary).
    #[arg(long, value_delimiter = ',')]
    effects: Option<Vec<String>>,
    /// Simulated seeds per configuration (the nominal's spread, every candidate's judgement).
    #[arg(long, default_value_t = 6, value_parser = parse_count)]
    seeds: usize,
    /// Evaluation seeds to raise `--seeds` to when no cell is significant on `--seeds` but some
    /// would be with unlimited seeds (0: never).
    #[arg(long, default_value_t = geneva_vision::pipeline::diagnose::ESCALATE_SEEDS, value_parser = parse_count)]
    escalate_seeds: usize,
    /// Simulated seeds per objective evaluation in the candidate fits (at least 2): more cost
    /// time in proportion and make the fitted values less dependent on the fit's own noise
    /// (on one footage of a 0.5 mm clearance, three sets of 2 seeds gave 0.43–0.49 mm and five
    /// sets of 3 gave 0.46–0.53 mm, sd 0.024).
    #[arg(long, default_value_t = DiagnoseOptions::default().fit_seeds, value_parser = parse_fit_seeds)]
    fit_seeds: usize,
    /// Fit the best candidate again on this many sets of fresh fit seeds and state the mean of
    /// all its fits, with the seed noise their spread shows (each refit costs about one fit;
    /// more make the ± surer: one refit's difference had one degree of freedom and understated
    /// a drive speed's seed noise about twofold).
    #[arg(long, default_value_t = DiagnoseOptions::default().refits, conflicts_with = "no_refit", value_parser = parse_count)]
    refits: usize,
    /// `--refits 0`: the best candidate's values and ± are its first fit's (faster; its ± then
    /// do not hold the fit seeds' own noise, which can be several times larger).
    #[arg(long)]
    no_refit: bool,
    /// Fit the best candidate on this many footages simulated at its stated values (fresh data
    /// seeds, each measured and fitted as the real footage): their spread, the footage's own
    /// noise, widens its ± where the fit's curvature undercounts it (a random camera shake's
    /// stated value spread 2.3× its ± over four footages). Each costs about one fit; 3 or more
    /// when the best candidate is a random process (shake, vibration, noise, timing jitter).
    /// 0 (the default) is off; 1 is refused (one fit has no spread).
    #[arg(long, default_value_t = DiagnoseOptions::default().bootstrap, value_parser = parse_bootstrap)]
    bootstrap: usize,
    /// Cap on the candidate search, minutes; what was not tried is reported. It is checked
    /// before each candidate joins a wave of fits (two at a time), once before the pair stage
    /// (up to 3 pairs, all run once it starts) and before each wave of refits after the
    /// first: work started before the cap runs to its end, so the run can overrun the cap by
    /// about one wave's time, and by the pair stage's when it starts just before the cap.
    #[arg(long)]
    max_minutes: Option<f64>,
    #[arg(long, default_value = "out/diagnose")]
    out: PathBuf,
    /// Fit only shard I/N of the candidates into DIR/shards/I/ (every shard recomputes the
    /// real measurement and the nominal simulations); no report until `--merge`.
    #[arg(long, value_parser = super::sweep_cmd::parse_shard, conflicts_with_all = ["merge", "max_minutes"])]
    shard: Option<Shard>,
    /// With --shard: discard a shard folder written from other inputs.
    #[arg(long, requires = "shard")]
    restart: bool,
    /// Write the report from the complete shards in DIR/shards/ (same arguments as the shards).
    #[arg(long, conflicts_with = "max_minutes")]
    merge: bool,
    /// Run even when the nominal's simulations alone are estimated above the time or memory
    /// limits.
    #[arg(long)]
    yes: bool,
}

pub fn run(a: DiagnoseArgs) -> Result<()> {
    let source = a.source.source()?;
    let mut inputs = a.source.inputs();
    inputs.extend(super::scenario_inputs("--scenario", &a.scenario));
    super::refuse_inputs_inside(&a.out, &inputs)?;
    let nominal = scenario::load_any(&a.scenario)?;
    let effects = super::effects_arg::parse_effects(a.effects.as_deref())?;
    if let geneva_vision::pipeline::analyze::Source::Tracks(path) = &source {
        let rows =
            geneva_vision::io::tracks_csv::read_tracks(path, Some(nominal.detector.marker_id));
        // An unreadable track is refused, by name, by the diagnosis itself.
        if let Some(n) = rows
            .ok()
            .and_then(|r| geneva_vision::pipeline::analyze::numbering_mismatch(&r))
        {
            eprintln!("warning: {}: {n}", path.display());
        }
    }
    if let Some(m) = a.max_minutes {
        if !(m.is_finite() && m > 0.0) {
            bail!("--max-minutes {m}: must be a positive number of minutes");
        }
    }
    let refits = if a.no_refit { 0 } else { a.refits };
    let meter = std::sync::Arc::new(SimMeter::default());
    let simulations =
        least_simulations(a.seeds, a.escalate_seeds, a.fit_seeds, refits, a.bootstrap);
    let work = geneva_vision::pipeline::workload::Workload::of(&nominal, true).times(simulations);
    super::work::confirm(
        &format!(
            "the diagnosis: at least {simulations} simulations of {} (the nominal on up to {} \
             seeds, then one candidate's fit of {} seeds × {EVALUATIONS_PER_FIT} evaluations, \
             {refits} refits and {} bootstrap footages alike; every further candidate adds a fit)",
            nominal.name,
            a.seeds.max(a.escalate_seeds),
            a.fit_seeds,
            a.bootstrap
        ),
        &work,
        a.yes,
    )?;
    let options = DiagnoseOptions {
        seeds: a.seeds,
        escalate_seeds: a.escalate_seeds,
        fit_seeds: a.fit_seeds,
        refits,
        bootstrap: a.bootstrap,
        effects,
        max_minutes: a.max_minutes,
        meter: Some(meter.clone()),
        ..DiagnoseOptions::default()
    };
    let bar = indicatif::ProgressBar::new(1);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg:40} {bar:25} {pos}/{len} simulations [{elapsed}, {prefix}]",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    // Without a terminal (logs, CI) each new stage is one line with the elapsed time and the
    // simulations run and planned.
    let plain = !std::io::IsTerminal::is_terminal(&std::io::stderr());
    let log = StageLog::new();
    let started = std::time::Instant::now();
    let figures = || {
        let (done, planned) = (meter.done(), meter.planned());
        let eta = eta::left(started.elapsed().as_secs_f64(), done, planned);
        (done, planned, eta)
    };
    let mode = match (a.shard, a.merge) {
        (Some(shard), _) => Mode::Shard {
            shard,
            restart: a.restart,
        },
        (None, true) => Mode::Merge,
        (None, false) => Mode::Whole,
    };
    // The simulations run on other threads: the bar reads their count twice a second, until
    // the diagnosis returns or unwinds (the guard stops it either way).
    let running = std::sync::atomic::AtomicBool::new(true);
    struct Stop<'a>(&'a std::sync::atomic::AtomicBool);
    impl Drop for Stop<'_> {
        fn drop(&mut self) {
            self.0.store(false, std::sync::atomic::Ordering::Relaxed);
        }
    }
    let finished = std::thread::scope(|scope| {
        if !plain {
            scope.spawn(|| {
                while running.load(std::sync::atomic::Ordering::Relaxed) {
                    let (done, planned, eta) = figures();
                    bar.set_length(planned.max(1) as u64);
                    bar.set_position(done as u64);
                    bar.set_prefix(eta);
                    std::thread::sleep(std::time::Duration::from_millis(500));
                }
            });
        }
        let _stop = Stop(&running);
        diagnose_with(&nominal, &source, &a.out, &options, mode, &|stage, _, _| {
            if plain {
                if let Some(line) = log.line(stage) {
                    let (done, planned, eta) = figures();
                    eprintln!("{line} ({done} of {planned} simulations planned, {eta})");
                }
            } else {
                bar.set_message(stage.to_string());
            }
        })
    })?;
    bar.finish_and_clear();
    let (d, files) = match finished {
        Finished::Diagnosis(d, files) => (d, files),
        Finished::Shard(r) => {
            println!(
                "shard {}: {} candidate fit(s), {} run now, {} found done{}",
                a.shard.map(|s| s.to_string()).unwrap_or_default(),
                r.units_total,
                r.units_run,
                r.units_resumed,
                if r.complete { "; complete" } else { "" }
            );
            return Ok(());
        }
    };
    println!("verdict: {}", d.verdict.as_str());
    println!(
        "gap: D0 = {:.1}, {} of {} cells significant",
        d.nominal_gap.total,
        d.nominal_gap.n_significant(),
        d.nominal_gap.cells.len()
    );
    for (i, r) in d.ranking.iter().take(5).enumerate() {
        println!(
            "  {}. {:<32} shrink {:>5.1} %  score {:.2}  significant cells left {}",
            i + 1,
            candidate_name(&r.evaluated),
            100.0 * r.shrink,
            r.score,
            r.evaluated.outcome.significant_left
        );
    }
    if !d.not_tried.is_empty() {
        println!(
            "not tried (--max-minutes): {}",
            d.not_tried
                .iter()
                .map(|e| e.name())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    println!("{} simulations in {:.0} s", d.simulations, d.elapsed_s);
    for f in &files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

/// The fewest objective evaluations a candidate's fit takes (a bracket and a few golden-section
/// or Brent steps; most fits take 10–40).
const EVALUATIONS_PER_FIT: f64 = 8.0;

/// A lower bound on a diagnosis's simulations: the nominal on its seeds (raised to the
/// escalation's), and the best candidate's fit, its refits and its bootstrap footages, each
/// `fit_seeds` seeds × [`EVALUATIONS_PER_FIT`].
fn least_simulations(
    seeds: usize,
    escalate_seeds: usize,
    fit_seeds: usize,
    refits: usize,
    bootstrap: usize,
) -> f64 {
    let fits = 1.0 + refits as f64 + bootstrap as f64;
    seeds.max(escalate_seeds) as f64 + fit_seeds as f64 * EVALUATIONS_PER_FIT * fits
}

/// The most of any seed, refit or footage count an option takes: beyond it a diagnosis would
/// run for years, and its bookkeeping alone would not fit in memory.
const MAX_COUNT: usize = 100_000;

/// `--seeds`, `--escalate-seeds`, `--refits`: a whole number up to [`MAX_COUNT`].
pub(super) fn parse_count(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if n <= MAX_COUNT => Ok(n),
        Ok(n) => Err(format!(
            "{n}: at most {MAX_COUNT} (a diagnosis of that many simulations would run for years)"
        )),
        Err(_) => Err(format!("`{text}` is not a whole number")),
    }
}

/// `--fit-seeds`: a whole number of at least 2 (a fit's z-scores need the seeds' spread).
pub(super) fn parse_fit_seeds(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n) if n > MAX_COUNT => parse_count(text),
        Ok(n) if n >= 2 => Ok(n),
        Ok(n) => Err(format!(
            "{n} fit seeds: at least 2 are needed (a fit compares the footage with the seeds' spread)"
        )),
        Err(_) => Err(format!("`{text}` is not a whole number of seeds")),
    }
}

/// `--bootstrap`: 0 (off) or at least 2 footages (one footage's fit has no spread to measure).
pub(super) fn parse_bootstrap(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(1) => Err(
            "1 bootstrap footage: the footage's own noise is the spread of at least 2 footage fits \
             (3 or more to pin it; 0 turns the bootstrap off)"
                .to_string(),
        ),
        Ok(n) if n <= MAX_COUNT => Ok(n),
        Ok(_) => parse_count(text),
        Err(_) => Err(format!("`{text}` is not a whole number of footages")),
    }
}

#[cfg(test)]
mod tests {
    use super::{
        least_simulations, parse_bootstrap, parse_count, parse_fit_seeds, EVALUATIONS_PER_FIT,
    };

    #[test]
    fn one_bootstrap_footage_is_refused() {
        assert_eq!(parse_bootstrap("0"), Ok(0));
        assert_eq!(parse_bootstrap("4"), Ok(4));
        assert!(parse_bootstrap("1").unwrap_err().contains("at least 2"));
        assert!(parse_bootstrap("-2").is_err());
    }

    #[test]
    fn fit_seeds_below_two_are_refused() {
        assert_eq!(parse_fit_seeds("3"), Ok(3));
        assert!(parse_fit_seeds("1").unwrap_err().contains("at least 2"));
        assert!(parse_fit_seeds("x").is_err());
    }

    #[test]
    fn counts_that_would_run_for_years_are_refused_naming_the_limit() {
        for parse in [parse_fit_seeds, parse_bootstrap, parse_count] {
            assert_eq!(parse("100000"), Ok(100_000));
            let why = parse("1000000000").unwrap_err();
            assert!(why.contains("at most 100000"), "{why}");
        }
    }

    #[test]
    fn the_work_estimate_grows_with_every_option_that_multiplies_work() {
        let base = least_simulations(6, 12, 3, 2, 0);
        assert_eq!(base, 12.0 + 3.0 * EVALUATIONS_PER_FIT * 3.0);
        assert!(least_simulations(6, 12, 30, 2, 0) > 8.0 * base);
        assert!(least_simulations(6, 12, 3, 20, 0) > 6.0 * base);
        assert!(least_simulations(6, 12, 3, 2, 30) > 9.0 * base);
        assert!(least_simulations(6000, 0, 3, 2, 0) > 60.0 * base);
    }
}
