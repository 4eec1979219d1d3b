//! The grid: cartesian product of the axes, each point with a stable key, its overrides and the
//! scenario built from them (or the reason it could not be built), and the per-run seeds.

use super::error::SweepError;
use super::spec::{value_label, SweepSpec};
use crate::rng::{stream, Stream};
use crate::scenario::{self, Scenario};
use rand::Rng;
use std::path::Path;
use toml::Value;

/// One point of the grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// Position in grid order (first axis slowest).
    pub index: usize,
    /// Level index on each axis.
    pub levels: Vec<usize>,
    /// Label on each axis (same order as the spec's axes).
    pub labels: Vec<String>,
    /// `axis=label` joined with `|`: stable across runs, the resume key.
    pub key: String,
    /// Dotted-path overrides applied to the base scenario.
    pub overrides: Vec<(String, Value)>,
}

/// All points in grid order.
pub fn points(spec: &SweepSpec) -> Vec<Point> {
    let sizes: Vec<usize> = spec.axes.iter().map(axis_len).collect();
    let total: usize = sizes.iter().product();
    (0..total)
        .map(|index| {
            // Mixed radix, last axis fastest.
            let mut rest = index;
            let mut levels = vec![0; sizes.len()];
            for (a, size) in sizes.iter().enumerate().rev() {
                levels[a] = rest % size;
                rest /= size;
            }
            let mut labels = Vec::new();
            let mut overrides = Vec::new();
            for (axis, &l) in spec.axes.iter().zip(&levels) {
                match (&axis.field, &axis.values, &axis.levels) {
                    (Some(field), Some(values), _) => {
                        labels.push(value_label(&values[l]));
                        overrides.push((field.clone(), values[l].clone()));
                    }
                    (_, _, Some(lv)) => {
                        labels.push(lv[l].label.clone());
                        overrides.extend(lv[l].set.iter().map(|(k, v)| (k.clone(), v.clone())));
                    }
                    // A validated spec has one of the two forms.
                    _ => labels.push(String::new()),
                }
            }
            let key = spec
                .axes
                .iter()
                .zip(&labels)
                .map(|(a, l)| format!("{}={}", a.name, l))
                .collect::<Vec<_>>()
                .join("|");
            Point {
                index,
                levels,
                labels,
                key,
                overrides,
            }
        })
        .collect()
}

fn axis_len(axis: &super::spec::AxisSpec) -> usize {
    match (&axis.values, &axis.levels) {
        (Some(v), _) => v.len(),
        (_, Some(l)) => l.len(),
        _ => 0,
    }
}

/// Loads the base scenario: a file relative to the sweep file when it exists, else a built-in.
pub fn load_base(spec: &SweepSpec, spec_path: &Path) -> Result<Scenario, SweepError> {
    let dir = spec_path.parent().unwrap_or(Path::new(""));
    let candidate = dir.join(&spec.base);
    let target = if candidate.is_file() {
        candidate.to_string_lossy().into_owned()
    } else {
        spec.base.clone()
    };
    scenario::load_any(&target).map_err(|source| SweepError::Base {
        file: spec_path.to_path_buf(),
        source,
    })
}

/// The point's scenario, or why its settings do not make one.
pub fn point_scenario(
    base: &Scenario,
    point: &Point,
    spec_path: &Path,
) -> Result<Scenario, scenario::ScenarioError> {
    scenario::with_overrides(base, &point.overrides, spec_path)
}

/// Seed of run `seed_index`. The same for every point (common random numbers): differences
/// between points then come from their settings, not from different noise draws.
pub fn run_seed(base_seed: u64, seed_index: usize) -> u64 {
    stream(base_seed, Stream::MonteCarlo, seed_index as u64).gen()
}
