//! The sweep file (TOML): which base scenario, which axes to vary, how many seeds per point,
//! the accuracy target, the impact to detect and how "cheapest" is ranked. Parsing and
//! validation only; every error names the file and the field.

use super::error::SweepError;
use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use toml::Value;

/// Column names of results.csv that an axis may not take.
pub const RESERVED_COLUMNS: &[&str] = &["point", "key", "seed_index", "seed", "status", "error"];

/// Cost keys that are not axis names: computed from the point's scenario.
pub const COST_PIXELS: &str = "pixels";
pub const COST_FPS: &str = "fps";

/// A whole sweep file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SweepSpec {
    /// Base scenario: a file path relative to the sweep file, or a built-in name; default `fast`.
    pub base: String,
    /// Runs (seeds) per point, 1..=1000; default 2. Seed k of every point is derived from the
    /// base scenario's seed and k (common random numbers: points differ only by their settings).
    pub seeds: usize,
    /// The axes; the grid is their cartesian product (first axis varies slowest).
    #[serde(rename = "axis")]
    pub axes: Vec<AxisSpec>,
    /// Accuracy the recommended setup must meet: the upper end of the 95 % CI of the per-run
    /// RMS over the point's seeds must be within it.
    pub target: TargetSpec,
    /// The impact that must be detectable in the α trace.
    pub impact: ImpactSpec,
    /// How the cheapest qualifying point is chosen.
    pub cost: CostSpec,
    /// More seeds for the points whose decision the first seeds do not settle; default unset
    /// (every point gets `seeds`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptive: Option<AdaptiveSpec>,
}

/// Adaptive seeds: after each round, every point whose 95 % intervals straddle a decision
/// boundary (ω or α RMS target, impact SNR threshold) gets twice its seeds, up to `max_seeds`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AdaptiveSpec {
    /// Largest number of seeds of a point, in [`seeds`, 1000]; default 16.
    pub max_seeds: usize,
}

impl Default for AdaptiveSpec {
    fn default() -> Self {
        Self { max_seeds: 16 }
    }
}

impl Default for SweepSpec {
    fn default() -> Self {
        Self {
            base: "fast".into(),
            seeds: 2,
            axes: Vec::new(),
            target: TargetSpec::default(),
            impact: ImpactSpec::default(),
            cost: CostSpec::default(),
            adaptive: None,
        }
    }
}

/// One axis: either `field` + `values` (one scenario field) or `levels` (compound settings).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AxisSpec {
    /// Axis name: a column of results.csv and part of each point key; required, unique.
    pub name: String,
    /// Dotted scenario path the values go to (`camera.distance_m`); default unset.
    pub field: Option<String>,
    /// Values of `field` (any TOML value, tables too); default unset.
    pub values: Option<Vec<Value>>,
    /// Named compound levels; default unset.
    pub levels: Option<Vec<LevelSpec>>,
}

/// A named level setting several fields at once (`1080p` = width 1920 + height 1080).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LevelSpec {
    /// Label used in the point key and results.csv; required, unique within the axis.
    pub label: String,
    /// Dotted scenario path → value; required, non-empty.
    pub set: BTreeMap<String, Value>,
}

/// Accuracy target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TargetSpec {
    /// Largest acceptable ω RMS error (upper 95 % bound over seeds), rad/s, > 0; default 0.02.
    pub omega_rms_rad_s: f64,
    /// Largest acceptable α RMS error (upper 95 % bound over seeds), rad/s², > 0; default 1.0.
    pub alpha_rms_rad_s2: f64,
}

impl Default for TargetSpec {
    fn default() -> Self {
        Self {
            omega_rms_rad_s: 0.02,
            alpha_rms_rad_s2: 1.0,
        }
    }
}

/// The impact to detect (see `budget::detectability`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImpactSpec {
    /// Velocity change of the impact, rad/s, > 0; default 0.05.
    pub delta_omega_rad_s: f64,
    /// Duration of the velocity change, s, in [0, 10]; default 0.002.
    pub duration_s: f64,
    /// Detectable when peak |α̂| / σ_α,engaged ≥ this, > 0, for the lower 95 % bound of the SNR
    /// (σ_α,engaged at its upper bound); default 3.
    pub min_snr: f64,
}

impl Default for ImpactSpec {
    fn default() -> Self {
        Self {
            delta_omega_rad_s: 0.05,
            duration_s: 0.002,
            min_snr: 3.0,
        }
    }
}

/// Cost ranking: keys in priority order, each `pixels` (width_px × height_px), `fps`
/// (frame_timing.fps) or an axis name (numeric value, or level position: earlier = cheaper).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CostSpec {
    /// Default `["pixels", "fps"]`.
    pub order: Vec<String>,
}

impl Default for CostSpec {
    fn default() -> Self {
        Self {
            order: vec![COST_PIXELS.into(), COST_FPS.into()],
        }
    }
}

impl SweepSpec {
    /// Parses and validates sweep text that claims to come from `file`.
    pub fn from_str(text: &str, file: &Path) -> Result<Self, SweepError> {
        let de = toml::Deserializer::new(text);
        let spec: SweepSpec = serde_path_to_error::deserialize(de).map_err(|e| {
            let field = e.path().to_string();
            SweepError::Field {
                file: file.to_path_buf(),
                field,
                message: e.into_inner().to_string(),
            }
        })?;
        let problems = spec.validate();
        if problems.is_empty() {
            Ok(spec)
        } else {
            Err(SweepError::Invalid {
                file: file.to_path_buf(),
                problems: problems.0,
            })
        }
    }

    /// Reads, parses and validates the sweep file at `path`.
    pub fn load(path: &Path) -> Result<Self, SweepError> {
        let text = std::fs::read_to_string(path).map_err(|source| SweepError::Read {
            file: path.to_path_buf(),
            source,
        })?;
        Self::from_str(&text, path)
    }

    /// All problems at once, each with its dotted field path and the allowed range.
    pub fn validate(&self) -> Problems {
        let mut p = Problems::new();
        if self.base.trim().is_empty() {
            p.push("base", "must name a scenario file or a built-in scenario");
        }
        if !(1..=1000).contains(&self.seeds) {
            p.push("seeds", format!("must be in [1, 1000], got {}", self.seeds));
        }
        if let Some(a) = &self.adaptive {
            if !(self.seeds.max(2)..=1000).contains(&a.max_seeds) {
                p.push(
                    "adaptive.max_seeds",
                    format!(
                        "must be in [max(seeds, 2), 1000] = [{}, 1000], got {}",
                        self.seeds.max(2),
                        a.max_seeds
                    ),
                );
            }
        }
        if self.axes.is_empty() {
            p.push("axis", "at least one [[axis]] is needed");
        }
        let mut names: Vec<&str> = Vec::new();
        for (i, axis) in self.axes.iter().enumerate() {
            let path = format!("axis[{i}]");
            axis.validate(&path, &mut p);
            if names.contains(&axis.name.as_str()) {
                p.push(
                    join(&path, "name"),
                    format!("duplicate axis name `{}`", axis.name),
                );
            }
            names.push(&axis.name);
        }
        p.positive("target.omega_rms_rad_s", self.target.omega_rms_rad_s);
        p.positive("target.alpha_rms_rad_s2", self.target.alpha_rms_rad_s2);
        p.positive("impact.delta_omega_rad_s", self.impact.delta_omega_rad_s);
        p.range("impact.duration_s", self.impact.duration_s, 0.0, 10.0);
        p.positive("impact.min_snr", self.impact.min_snr);
        for (i, key) in self.cost.order.iter().enumerate() {
            if key != COST_PIXELS && key != COST_FPS && !names.contains(&key.as_str()) {
                p.push(
                    format!("cost.order[{i}]"),
                    format!(
                        "must be `pixels`, `fps` or an axis name ({}), got `{key}`",
                        names.join(", ")
                    ),
                );
            }
        }
        p
    }
}

impl AxisSpec {
    fn validate(&self, path: &str, p: &mut Problems) {
        let name_ok = !self.name.is_empty()
            && self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.');
        if !name_ok {
            p.push(
                join(path, "name"),
                format!(
                    "must be non-empty ASCII letters, digits, `_`, `-`, `.`; got `{}`",
                    self.name
                ),
            );
        }
        if RESERVED_COLUMNS.contains(&self.name.as_str()) {
            p.push(
                join(path, "name"),
                format!(
                    "`{}` is reserved (reserved: {})",
                    self.name,
                    RESERVED_COLUMNS.join(", ")
                ),
            );
        }
        match (&self.field, &self.values, &self.levels) {
            (Some(field), Some(values), None) => {
                check_dotted(&join(path, "field"), field, p);
                if values.is_empty() {
                    p.push(join(path, "values"), "must hold at least one value");
                }
                let labels: Vec<String> = values.iter().map(value_label).collect();
                check_unique(&join(path, "values"), &labels, p);
            }
            (None, None, Some(levels)) => {
                if levels.is_empty() {
                    p.push(join(path, "levels"), "must hold at least one level");
                }
                for (j, level) in levels.iter().enumerate() {
                    let lp = format!("{}[{j}]", join(path, "levels"));
                    if level.label.trim().is_empty() {
                        p.push(join(&lp, "label"), "must not be empty");
                    }
                    if level.set.is_empty() {
                        p.push(join(&lp, "set"), "must set at least one field");
                    }
                    for key in level.set.keys() {
                        check_dotted(&join(&lp, "set"), key, p);
                    }
                }
                let labels: Vec<String> = levels.iter().map(|l| l.label.clone()).collect();
                check_unique(&join(path, "levels"), &labels, p);
            }
            _ => p.push(
                path.to_string(),
                "needs either `field` + `values` or `levels` (not both)",
            ),
        }
    }
}

fn check_dotted(path: &str, dotted: &str, p: &mut Problems) {
    if dotted.is_empty() || dotted.split('.').any(|s| s.is_empty()) {
        p.push(
            path,
            format!("must be a dotted scenario path like `camera.distance_m`, got `{dotted}`"),
        );
    }
}

fn check_unique(path: &str, labels: &[String], p: &mut Problems) {
    for (i, l) in labels.iter().enumerate() {
        if labels[..i].contains(l) {
            p.push(path, format!("duplicate label `{l}`"));
        }
    }
}

/// How a value appears in point keys and CSV columns: strings bare, numbers shortest
/// (`30.0` → `30`), tables and arrays as inline TOML.
pub fn value_label(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Integer(i) => i.to_string(),
        Value::Float(f) => f.to_string(),
        Value::Boolean(b) => b.to_string(),
        other => other.to_string().trim().to_string(),
    }
}
