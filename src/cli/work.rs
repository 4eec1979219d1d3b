//! The work a command is about to do, printed and confirmed before any of it is done.

use anyhow::{bail, Result};
use geneva_vision::pipeline::workload::Workload;
use geneva_vision::scenario::Scenario;
use geneva_vision::sweep::SweepSpec;
use std::path::Path;

/// Refuses a job above the limits unless `yes`; says what it will cost either way when it is
/// large.
pub fn confirm(what: &str, w: &Workload, yes: bool) -> Result<()> {
    if let Some(why) = w.over_limits() {
        if !yes {
            let fewer = if w.runs > 1.0 {
                "fewer points or seeds, "
            } else {
                ""
            };
            bail!(
                "{what} would take {why}: {w}; pass --yes to run it anyway, or ask for \
                 {fewer}a shorter duration_s, a lower resolution, frame rate or fewer exposure \
                 samples"
            );
        }
        eprintln!("warning: {what}: {why} (--yes given): {w}");
    }
    Ok(())
}

/// A sweep's work, computed without expanding its grid: points (the product of the axis
/// lengths) × seeds runs, each costed as the base with every axis at its most expensive value
/// (an upper estimate when costs multiply, as frames × pixels do).
pub fn sweep_workload(spec: &SweepSpec, base: &Scenario, origin: &Path) -> Workload {
    let unit = Workload::of(base, true);
    let base_cost = unit.time_s().max(1e-9);
    let base_memory = unit.memory_bytes().max(1.0);
    let mut points = 1.0f64;
    let mut worst = unit.clone();
    let (mut time_factor, mut memory_factor) = (1.0f64, 1.0f64);
    for axis in &spec.axes {
        let settings: Vec<Vec<(String, toml::Value)>> = match (&axis.values, &axis.levels) {
            (Some(values), _) => values
                .iter()
                .map(|v| vec![(axis.field.clone().unwrap_or_default(), v.clone())])
                .collect(),
            (None, Some(levels)) => levels
                .iter()
                .map(|l| l.set.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
                .collect(),
            (None, None) => Vec::new(),
        };
        points *= settings.len().max(1) as f64;
        // Costing a few hundred values is cheap: a long axis is sampled evenly, ends included.
        let (mut t, mut m) = (1.0f64, 1.0f64);
        let stride = settings.len().div_ceil(256).max(1);
        let sampled = settings
            .iter()
            .step_by(stride)
            .chain(settings.last().filter(|_| settings.len() % stride != 1));
        for set in sampled {
            if let Ok(s) = geneva_vision::scenario::with_overrides(base, set, origin) {
                let w = Workload::of(&s, true);
                t = t.max(w.time_s() / base_cost);
                m = m.max(w.memory_bytes() / base_memory);
                if w.pixels_per_run() > worst.pixels_per_run() {
                    worst = w;
                }
            }
        }
        time_factor *= t;
        memory_factor *= m;
    }
    let runs = points * spec.seeds.max(1) as f64;
    // Scale the worst single-axis run to the combined factors through its frame count.
    let ratio = (time_factor * base_cost / worst.time_s().max(1e-9)).max(1.0);
    worst.frames *= ratio;
    worst.extra_bytes = points * 2500.0 + base_memory * (memory_factor - 1.0).max(0.0);
    worst.times(runs)
}
