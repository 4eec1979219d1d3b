//! `reports/dynamics/`: generated from scratch, it shows the old default failing and the new
//! default meeting the seed's observations, with both plots.

use geneva_vision::pipeline::dynamics_report::dynamics_report;

#[test]
fn dynamics_report_compares_the_old_and_new_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let files = dynamics_report(dir.path()).unwrap();
    for name in [
        "README.md",
        "omega2_alpha2_vs_theta1.png",
        "omega2_alpha2_vs_time.png",
    ] {
        assert!(files.iter().any(|f| f.ends_with(name)), "{name}: {files:?}");
    }
    let md = std::fs::read_to_string(dir.path().join("README.md")).unwrap();
    // Each check row ends with the new default's verdict, and all six pass; the old default
    // fails at least the entry spikes, mid-drive and rattle rows.
    let rows: Vec<&str> = md
        .lines()
        .filter(|l| {
            [
                "entry spikes",
                "flank change",
                "mid-drive ω2",
                "no rattle",
                "over-rotation",
                "no energy growth",
            ]
            .iter()
            .any(|n| l.starts_with(&format!("| {n} |")))
        })
        .collect();
    assert_eq!(rows.len(), 6, "{md}");
    assert!(rows.iter().all(|r| r.ends_with("(yes) |")), "{rows:#?}");
    let old_failures = rows.iter().filter(|r| r.contains("(**no**) |")).count();
    assert!(old_failures >= 3, "{rows:#?}");
    assert!(md.contains("## Restitution") && md.contains("## The load of the wheel on the crank"));
}
