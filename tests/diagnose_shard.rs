//! A diagnosis split into shards of candidate fits and merged gives the report of a one-machine
//! run, byte for byte (`diagnosis.json`, `diagnosis.md`) except the wall time, which no two
//! runs share: the `elapsed_s` field of the JSON and the number after "simulations in" of the
//! Markdown are masked, nothing else. A merge with a shard missing names the missing candidates
//! and writes no report. The footage is the self-check's withheld strong pixel noise, 3 s, 2
//! seeds, diagnosed without pixel noise among the candidates (lighting, compression, optical
//! blur), so no single candidate explains it and the pair stage runs, at merge time, as do the
//! best candidate's refits on fresh seeds and its fits on two footages simulated at its stated
//! values (the bootstrap of the footage's own noise).
//!
//! The one-machine run is made on one thread, the shards and the merge on all, both at once (the
//! one-thread run would otherwise leave a core idle for half of CI's longest test): the fits that
//! run concurrently (shards' candidates; the merge's pairs, refits and bootstrap footages, a
//! wave at a time) must give the report of fits run one after another, byte for byte.

#![cfg(feature = "opencv-detector")]

use geneva_vision::pipeline::analyze::Source;
use geneva_vision::pipeline::diagnose::shards::Mode;
use geneva_vision::pipeline::diagnose::{
    diagnose_with, DiagnoseError, DiagnoseOptions, Diagnosis, Finished,
};
use geneva_vision::pipeline::selfcheck::{cases, render_case, suite_base, SuitePlan};
use geneva_vision::scenario::effects::Effect;
use geneva_vision::shard::Shard;
use std::path::Path;

mod common;

/// The report with the wall time masked.
fn masked(dir: &Path, file: &str) -> String {
    let text = std::fs::read_to_string(dir.join(file)).unwrap();
    text.lines()
        .map(|l| {
            if l.trim_start().starts_with("\"elapsed_s\"") {
                "\"elapsed_s\": <wall time>".to_string()
            } else if let Some((head, tail)) = l.split_once(" simulations in ") {
                let rest = tail.split_once(" s.").map_or("", |(_, r)| r);
                format!("{head} simulations in <wall time> s.{rest}")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn sharded_diagnosis_merges_into_the_one_machine_report() {
    let tmp = tempfile::tempdir().unwrap();
    let base = suite_base(3.0).unwrap();
    let case = cases(&base, &SuitePlan::quick(Effect::PixelNoise), &[])
        .into_iter()
        .find(|c| c.name.starts_with("withheld-pixel_noise"))
        .unwrap();
    let frames = tmp.path().join("frames");
    render_case(&case, &frames).unwrap();
    let source = Source::Frames {
        dir: frames.clone(),
        timestamps: frames.join("timestamps.csv"),
    };
    let options = DiagnoseOptions {
        seeds: 2,
        fit_seeds: 2,
        effects: Some(vec![
            Effect::Lighting,
            Effect::Compression,
            Effect::OpticalBlur,
        ]),
        bootstrap: 2,
        ..Default::default()
    };
    let run = |out: &Path, mode: Mode| {
        diagnose_with(&case.nominal, &source, out, &options, mode, &|_, _, _| {})
    };

    let whole_dir = tmp.path().join("whole");
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let sharded = tmp.path().join("sharded");
    // The one-thread run and the sharded one at the same time; neither reads a file the other
    // writes.
    let (whole_run, (merged, units, sharded_s)) = std::thread::scope(|scope| {
        let whole = scope.spawn(|| {
            let t = std::time::Instant::now();
            let r = one_thread.install(|| run(&whole_dir, Mode::Whole));
            (r, t.elapsed().as_secs_f64())
        });
        let sharded_part = shards_then_merge(&sharded, &run);
        (whole.join().unwrap(), sharded_part)
    });
    let (whole_run, whole_s) = whole_run;
    let Finished::Diagnosis(whole, _) = whole_run.unwrap() else {
        panic!("a whole run writes a report")
    };
    eprintln!(
        "whole on one thread {whole_s:.1} s; 2 shards + merge in sequence {sharded_s:.1} s, both at \
         once; {} candidates, pair tried: {}, {} simulations",
        units.len(),
        whole.pair_tried,
        whole.simulations
    );

    assert_eq!(merged.simulations, whole.simulations);
    assert!(
        whole.pair_tried,
        "the pair stage is part of what is compared"
    );
    for file in ["diagnosis.json", "diagnosis.md"] {
        assert_eq!(
            masked(&whole_dir, file),
            masked(&sharded, file),
            "{file} differs"
        );
    }
    assert!(sharded.join("shards/0/manifest.json").is_file());

    // The best candidate (compression here, the pair with lighting in its group) was fitted
    // again on two sets of fresh seeds at merge time, each refit's parameters keyed as in its
    // own `params`, and each stated value and ± pools the three fits (`diagnose::fit_noise`).
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(whole_dir.join("diagnosis.json")).unwrap())
            .unwrap();
    let best = &report["ranking"][0];
    assert_eq!(common::check_pooled_refit(best), Ok(2), "{best}");
    let own: Vec<&String> = best["params"].as_object().unwrap().keys().collect();
    for run in 0..2 {
        let again = best["refit"]["runs"][run]["params"].as_object().unwrap();
        assert_eq!(own, again.keys().collect::<Vec<_>>(), "{best}");
    }
    // Then on two footages simulated at the pooled values: their spread widens the pool's ±
    // and a bias they show is taken off only if significant (rare on one degree of freedom),
    // either way as recomputed here from the JSON.
    assert_eq!(common::check_bootstrap(best), Ok(2), "{best}");
    // Its 95 % intervals take t on the degrees of freedom of its refits and footages, as
    // recomputed from the JSON.
    let intervals = common::check_ci95(best);
    assert!(intervals.is_ok(), "{intervals:?}");

    // Shards of other inputs are refused, naming the change.
    let other = DiagnoseOptions {
        fit_seeds: 3,
        ..options.clone()
    };
    let e = match diagnose_with(
        &case.nominal,
        &source,
        &sharded,
        &other,
        Mode::Merge,
        &|_, _, _| {},
    ) {
        Ok(_) => panic!("a merge of shards from other inputs succeeded"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("fit_seeds") && e.contains("2 → 3"), "{e}");
}

/// Shard 0, a merge refused for shard 1 missing, shard 1 (twice: the second run repeats
/// nothing), then the merge, into `sharded`: the merged report, the candidates (units) of the
/// shards and the wall time.
fn shards_then_merge(
    sharded: &Path,
    run: &(dyn Fn(&Path, Mode) -> Result<Finished, DiagnoseError> + Sync),
) -> (Box<Diagnosis>, Vec<String>, f64) {
    let t = std::time::Instant::now();
    let shard = |i| Mode::Shard {
        shard: Shard::new(i, 2).unwrap(),
        restart: false,
    };
    let Finished::Shard(r0) = run(sharded, shard(0)).unwrap() else {
        panic!("a shard writes no report")
    };
    assert!(r0.complete);
    // Shard 1 not run yet: the merge names what is missing and writes nothing final.
    let e = match run(sharded, Mode::Merge) {
        Ok(_) => panic!("a merge with shard 1/2 missing succeeded"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("shard 1/2 not started"), "{e}");
    let units: Vec<String> = serde_json::from_str::<serde_json::Value>(
        &std::fs::read_to_string(sharded.join("shards/0/manifest.json")).unwrap(),
    )
    .unwrap()["inputs"]["prefix"]["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    assert!(units.len() >= 2, "{units:?}");
    for name in units.iter().skip(1).step_by(2) {
        assert!(e.contains(name.as_str()), "`{name}` named in: {e}");
    }
    assert!(!sharded.join("diagnosis.json").exists());
    assert!(!sharded.join("diagnosis.md").exists());

    run(sharded, shard(1)).unwrap();
    // Re-running a finished shard repeats nothing.
    let Finished::Shard(again) = run(sharded, shard(1)).unwrap() else {
        panic!("a shard writes no report")
    };
    assert!(again.already_complete && again.units_run == 0);
    let Finished::Diagnosis(merged, _) = run(sharded, Mode::Merge).unwrap() else {
        panic!("a merge writes a report")
    };
    (merged, units, t.elapsed().as_secs_f64())
}
