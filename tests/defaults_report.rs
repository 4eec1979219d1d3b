//! `reports/defaults/`: the generator runs on a tiny spread and ranks its best first; the
//! toolkit's default estimator is the best of the committed table (read from it, not restated
//! here); `geneva analyze` says which estimator it used and why.
#![cfg(feature = "opencv-detector")]

use geneva_vision::estimate::EstimatorConfig;
use geneva_vision::pipeline::defaults_study::{
    candidates, defaults_report, rank, Spread, RANKING_HEADER,
};
use std::path::Path;
use std::process::Command;

#[test]
fn the_generator_runs_on_a_tiny_spread_and_ranks_its_best_first() {
    let dir = tempfile::tempdir().unwrap();
    let spread = Spread::tiny();
    let study = defaults_report(dir.path(), &spread).unwrap();
    for name in ["README.md", "ranking.csv", "per_setup.csv"] {
        assert!(
            study.files.iter().any(|f| f.ends_with(name)),
            "{name}: {:?}",
            study.files
        );
    }
    assert_eq!(study.results.len(), spread.points().len());
    for r in &study.results {
        assert!(r.frames_detected > r.frames_total / 2, "{:?}", r.point);
    }
    // The ranking is the pure ranking of the results, best (fewest failures, lowest score) first.
    let names: Vec<String> = study.candidates.iter().map(|c| c.name.clone()).collect();
    assert_eq!(rank(&study.results, &names), study.ranking);
    let first = &study.ranking[0];
    assert_eq!(first.failures, 0);
    assert!(study
        .ranking
        .iter()
        .all(|r| r.failures > 0 || r.score >= first.score));
    assert!(first.score >= 1.0 && first.score.is_finite());
    let csv = std::fs::read_to_string(dir.path().join("ranking.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap(), RANKING_HEADER.join(","));
    assert_eq!(lines.count(), candidates().len());
    assert_eq!(best_of(&csv), first.name);
    let md = std::fs::read_to_string(dir.path().join("README.md")).unwrap();
    assert!(md.contains(&format!("**Best: `{}`**", first.name)), "{md}");
}

/// The candidate in the first data row of a ranking.csv.
fn best_of(csv: &str) -> String {
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "candidate").unwrap();
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(row[0], "1");
    row[col].to_string()
}

#[test]
fn the_default_estimator_is_the_best_of_the_committed_table() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("reports/defaults/ranking.csv");
    let csv = std::fs::read_to_string(&path).unwrap();
    let best = best_of(&csv);
    assert!(
        candidates().iter().any(|c| c.name == best),
        "{best} is not a candidate"
    );
    assert_eq!(EstimatorConfig::default().choice_name(), best);
}

fn write_tracks(path: &Path) {
    // A 40 px marker on a 300 px orbit turning at 0.5 rad/s, 60 frames at 30 fps.
    let mut text =
        String::from("frame,t_s,marker_id,x0_px,y0_px,x1_px,y1_px,x2_px,y2_px,x3_px,y3_px\n");
    for k in 0..60 {
        let t = k as f64 / 30.0;
        let a = 0.5 * t;
        let (c, s) = (a.cos(), a.sin());
        let mut cells = vec![k.to_string(), t.to_string(), "0".to_string()];
        for (dx, dy) in [(-20.0, -20.0), (20.0, -20.0), (20.0, 20.0), (-20.0, 20.0)] {
            let (x, y) = (300.0 + dx, dy);
            cells.push((960.0 + c * x - s * y).to_string());
            cells.push((540.0 + s * x + c * y).to_string());
        }
        text.push_str(&(cells.join(",") + "\n"));
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn analyze_says_which_estimator_it_used_and_why() {
    let dir = tempfile::tempdir().unwrap();
    let tracks = dir.path().join("tracks.csv");
    write_tracks(&tracks);
    let run = |extra: &[&str], out: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_geneva"))
            .current_dir(dir.path())
            .args(["analyze", "--tracks", "tracks.csv", "--out", out])
            .args(extra)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(
            o.status.success(),
            "{stdout}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        stdout
            .lines()
            .find(|l| l.starts_with("estimator "))
            .unwrap_or_else(|| panic!("no estimator line: {stdout}"))
            .to_string()
    };
    let default = EstimatorConfig::default();
    let line = run(&[], "a");
    // A data-driven λ is shown as resolved on this track, so compare the fixed parts.
    let fixed = format!(
        "/ {} / {} —",
        default.marker_centre.name(),
        default.rotation_centre.name()
    );
    assert!(line.contains(&fixed), "{line}");
    assert!(
        line.contains("no --scenario") && line.contains("reports/defaults/"),
        "{line}"
    );
    let line = run(&["--scenario", "seed-internal-4k"], "b");
    assert!(
        line.contains("seed / corner_mean / seed — chosen by scenario `seed-internal-4k`"),
        "{line}"
    );
}

#[test]
fn the_seed_scenarios_keep_the_seed_estimator() {
    for name in ["seed-internal-4k", "seed-external-4k"] {
        let s = geneva_vision::scenario::load_any(name).unwrap();
        assert_eq!(
            s.estimator.choice_name(),
            "seed / corner_mean / seed",
            "{name}"
        );
    }
}

#[test]
fn the_seed_reports_better_settings_use_the_default_estimator() {
    let base = geneva_vision::scenario::load_any("seed-internal-4k").unwrap();
    let better = geneva_vision::scenario::with_overrides(
        &base,
        &geneva_vision::pipeline::reports::better_overrides(),
        Path::new("test"),
    )
    .unwrap();
    assert_eq!(
        better.estimator.choice_name(),
        EstimatorConfig::default().choice_name()
    );
    assert_eq!(
        better.estimator.differentiator,
        EstimatorConfig::default().differentiator
    );
}
