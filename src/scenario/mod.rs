//! Scenario files: one TOML file describes a whole synthetic experiment — mechanism, drive
//! speed, dynamics, scene, camera, frame timing, imaging effects, detector and estimator.
//!
//! This module owns parsing (serde, `deny_unknown_fields` everywhere), `extend` resolution,
//! validation and the built-in scenarios. It reads files; it is the only part of the core that
//! does (data files that a scenario names are loaded here too, so everything downstream is pure).
//!
//! Architecture invariant: a [`Scenario`] that left [`load`] or [`load_builtin`] has passed
//! [`Scenario::validate`]; downstream code may rely on every range check documented there.

mod builtin;
pub mod clipping;
mod cross;
pub mod effects;
mod error;
mod external;
mod merge;
mod typed;

pub use builtin::{builtin_names, builtin_text, DEFAULT_SCENARIO};
pub use cross::{times_inside_one_frame_of, TimeInsideOneFrame};
pub use error::ScenarioError;
pub use external::builtin_data;

use crate::camera::CameraConfig;
use crate::detect::DetectorConfig;
use crate::estimate::EstimatorConfig;
use crate::mechanism::{DriveSpeedConfig, DynamicsConfig, MechanismConfig};
use crate::render::EffectsConfig;
use crate::scene::SceneConfig;
use crate::timing::{FrameTimingConfig, Timestamps, TimingError};
use crate::validation::Problems;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use toml::Value;

/// A fully resolved scenario (after `extend`), in SI units unless a field name says otherwise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scenario {
    /// Short name used in reports and output folders.
    pub name: String,
    /// Free text.
    pub description: String,
    /// Master seed: every random stream (timing, noise, vibration) derives from it.
    pub seed: u64,
    /// Length of the simulated recording, seconds.
    pub duration_s: f64,
    pub mechanism: MechanismConfig,
    pub drive_speed: DriveSpeedConfig,
    pub dynamics: DynamicsConfig,
    pub scene: SceneConfig,
    pub camera: CameraConfig,
    pub frame_timing: FrameTimingConfig,
    pub effects: EffectsConfig,
    pub detector: DetectorConfig,
    pub estimator: EstimatorConfig,
    /// The frame-timing log named by `frame_timing.model.file`, read by the loader.
    #[serde(skip)]
    pub timing_log: Option<Timestamps>,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            name: "unnamed".into(),
            description: String::new(),
            seed: 1,
            duration_s: 10.0,
            mechanism: Default::default(),
            drive_speed: Default::default(),
            dynamics: Default::default(),
            scene: Default::default(),
            camera: Default::default(),
            frame_timing: Default::default(),
            effects: Default::default(),
            detector: Default::default(),
            estimator: Default::default(),
            timing_log: None,
        }
    }
}

impl Scenario {
    /// Checks every field's range, then the combinations (`cross`); returns all problems at once.
    pub fn validate(&self) -> Problems {
        let mut problems = Problems::new();
        if self.name.trim().is_empty() {
            problems.push("name", "must not be empty");
        }
        problems.range("duration_s", self.duration_s, 1e-3, 3600.0);
        self.mechanism.validate("mechanism", &mut problems);
        self.drive_speed.validate("drive_speed", &mut problems);
        self.dynamics.validate("dynamics", &mut problems);
        self.scene.validate("scene", &mut problems);
        self.camera.validate("camera", &mut problems);
        self.frame_timing.validate("frame_timing", &mut problems);
        self.effects.validate("effects", &mut problems);
        self.detector.validate("detector", &mut problems);
        self.estimator.validate("estimator", &mut problems);
        // Combinations only make sense once every field is in range.
        if problems.is_empty() {
            cross::check(self, &mut problems);
        }
        problems
    }

    /// The frame times of this scenario's camera (deterministic for the seed).
    pub fn frame_times(&self) -> Result<Timestamps, TimingError> {
        self.frame_timing
            .schedule(self.duration_s, self.seed, self.timing_log.as_ref())
    }

    /// The resolved scenario as TOML (what `geneva scenario show` prints).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_else(|e| format!("# cannot serialise: {e}\n"))
    }
}

/// Where a scenario came from, for messages.
#[derive(Debug, Clone, PartialEq)]
pub enum Origin {
    File(PathBuf),
    Builtin(&'static str),
}

/// Loads, resolves (`extend`), deserialises and validates the scenario file at `path`.
pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
    let value = resolve_file(path, &mut Vec::new())?;
    finish(value, path)
}

/// Loads a built-in scenario by name (`seed-internal-4k`, ...).
pub fn load_builtin(name: &str) -> Result<Scenario, ScenarioError> {
    let pseudo = PathBuf::from(format!("builtin:{name}"));
    let value = resolve_builtin(name, &pseudo, &mut Vec::new())?;
    finish(value, &pseudo)
}

/// Loads `spec`: `builtin:NAME` is always the built-in; otherwise an existing *file* of that
/// name, then a built-in of that name, else the path (whose error names it). A directory named
/// like a built-in (an output folder `fast/`) is not a scenario file and never shadows it.
pub fn load_any(spec: &str) -> Result<Scenario, ScenarioError> {
    if let Some(name) = spec.strip_prefix("builtin:") {
        return load_builtin(name);
    }
    let path = Path::new(spec);
    if path.is_file() || builtin_text(spec).is_none() {
        load(path)
    } else {
        load_builtin(spec)
    }
}

/// The fields that `spec` (a file, or a built-in name) and the files it extends state
/// themselves, merged, before defaults apply: what a user wrote, as opposed to what a default
/// supplied (`geneva calibrate` checks that the base states the marker's side).
pub fn stated_fields(spec: &str) -> Result<Value, ScenarioError> {
    let path = Path::new(spec);
    if path.exists() || builtin_text(spec).is_none() {
        resolve_file(path, &mut Vec::new())
    } else {
        let pseudo = PathBuf::from(format!("builtin:{spec}"));
        resolve_builtin(spec, &pseudo, &mut Vec::new())
    }
}

/// The files that loading `spec` reads, each with what it is for messages: the scenario file,
/// the files it extends (`extend`) and the data files it names (every `file` and `*_file` key,
/// e.g. `frame_timing.model.file`). Nothing for a built-in or built-in data. A chain that does
/// not resolve is listed as far as it does: loading names its error.
pub fn files_read(spec: &str) -> Vec<(String, PathBuf)> {
    let path = Path::new(spec);
    if spec.starts_with("builtin:") || !(path.is_file() || builtin_text(spec).is_none()) {
        return Vec::new();
    }
    let mut chain = Vec::new();
    let value = resolve_file(path, &mut chain).ok();
    let mut out: Vec<(String, PathBuf)> = chain
        .into_iter()
        .filter(|p| !p.to_string_lossy().starts_with("builtin:"))
        .enumerate()
        .map(|(k, p)| {
            let what = if k == 0 {
                "scenario".to_string()
            } else {
                format!("scenario {spec}'s extend base")
            };
            (what, p)
        })
        .collect();
    if out.is_empty() {
        out.push(("scenario".to_string(), path.to_path_buf()));
    }
    fn data_files(v: &Value, at: &str, spec: &str, out: &mut Vec<(String, PathBuf)>) {
        let Value::Table(t) = v else { return };
        for (key, x) in t {
            let field = if at.is_empty() {
                key.clone()
            } else {
                format!("{at}.{key}")
            };
            match x {
                Value::String(s)
                    if (key == "file" || key.ends_with("_file"))
                        && !s.is_empty()
                        && !merge::is_builtin_ref(s) =>
                {
                    out.push((format!("scenario {spec}'s {field}"), PathBuf::from(s)));
                }
                other => data_files(other, &field, spec, out),
            }
        }
    }
    if let Some(v) = &value {
        data_files(v, "", spec, &mut out);
    }
    out
}

/// Parses scenario text that claims to come from `file` (used by tests and by `load`).
pub fn from_str(text: &str, file: &Path) -> Result<Scenario, ScenarioError> {
    let mut value = parse_toml(text, file)?;
    let dir = file.parent().unwrap_or(Path::new("")).to_path_buf();
    merge::anchor_paths(&mut value, &dir);
    let value = apply_extend(value, file, &dir, &mut vec![file.to_path_buf()])?;
    finish(value, file)
}

/// A copy of `base` with fields replaced by dotted path (`camera.distance_m = 0.4`), validated
/// again. Data already loaded from files (timing logs) carries over unless the override changes
/// the timing model. `origin` names the file the overrides came from, for messages.
pub fn with_overrides(
    base: &Scenario,
    overrides: &[(String, Value)],
    origin: &Path,
) -> Result<Scenario, ScenarioError> {
    let mut value = Value::try_from(base).map_err(|e| ScenarioError::Field {
        file: origin.to_path_buf(),
        field: String::new(),
        message: format!("cannot represent the base scenario: {e}"),
    })?;
    for (path, v) in overrides {
        set_dotted(&mut value, path, v.clone()).map_err(|message| ScenarioError::Field {
            file: origin.to_path_buf(),
            field: path.clone(),
            message,
        })?;
    }
    let timing_changed = overrides
        .iter()
        .any(|(p, _)| p.starts_with("frame_timing.model"));
    let scenario = typed::deserialize(value, origin)?;
    validated_with_data(scenario, origin, |s| {
        if timing_changed {
            external::load_external(s, origin)
        } else {
            s.timing_log = base.timing_log.clone();
            external::attach_appearance(s, origin, Some(base))
        }
    })
}

/// Sets `a.b.c` in a TOML table, creating intermediate tables.
fn set_dotted(root: &mut Value, path: &str, v: Value) -> Result<(), String> {
    let mut parts = path.split('.').peekable();
    let mut cur = root;
    while let Some(key) = parts.next() {
        if key.is_empty() {
            return Err("empty path segment".into());
        }
        let table = cur
            .as_table_mut()
            .ok_or_else(|| format!("`{key}`: parent is not a table"))?;
        if parts.peek().is_none() {
            table.insert(key.to_string(), v);
            return Ok(());
        }
        cur = table
            .entry(key.to_string())
            .or_insert_with(|| Value::Table(Default::default()));
    }
    Err("empty path".into())
}

fn finish(value: Value, file: &Path) -> Result<Scenario, ScenarioError> {
    let scenario = typed::deserialize(value, file)?;
    validated_with_data(scenario, file, |s| external::load_external(s, file))
}

/// Validates `scenario`, attaches its data files (`attach`, only once it is valid) and, when
/// that brought a timing log, validates again: the checks that depend on the frame interval
/// read the log's own (`cross::frame_interval_s`), which the scenario's `frame_timing.fps` need
/// not state. `file` names the scenario in the error.
fn validated_with_data(
    mut scenario: Scenario,
    file: &Path,
    attach: impl FnOnce(&mut Scenario) -> Result<(), ScenarioError>,
) -> Result<Scenario, ScenarioError> {
    let mut problems = scenario.validate();
    if problems.is_empty() {
        attach(&mut scenario)?;
        if scenario.timing_log.is_some() {
            problems = scenario.validate();
        }
    }
    if problems.is_empty() {
        Ok(scenario)
    } else {
        Err(ScenarioError::Invalid {
            file: file.to_path_buf(),
            problems: problems.0,
        })
    }
}

fn parse_toml(text: &str, file: &Path) -> Result<Value, ScenarioError> {
    text.parse::<toml::Table>()
        .map(Value::Table)
        .map_err(|e| ScenarioError::Syntax {
            file: file.to_path_buf(),
            message: crate::errors::full(&e),
        })
}

fn resolve_file(path: &Path, chain: &mut Vec<PathBuf>) -> Result<Value, ScenarioError> {
    if path.is_dir() {
        return Err(ScenarioError::NotAFile {
            file: path.to_path_buf(),
        });
    }
    let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Read {
        file: path.to_path_buf(),
        source,
    })?;
    let mut value = parse_toml(&text, path)?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    merge::anchor_paths(&mut value, &dir);
    chain.push(path.to_path_buf());
    apply_extend(value, path, &dir, chain)
}

fn resolve_builtin(
    name: &str,
    pseudo: &Path,
    chain: &mut Vec<PathBuf>,
) -> Result<Value, ScenarioError> {
    let text = builtin_text(name).ok_or_else(|| ScenarioError::UnknownBuiltin {
        name: name.to_string(),
        known: builtin_names().join(", "),
    })?;
    let value = parse_toml(text, pseudo)?;
    chain.push(pseudo.to_path_buf());
    apply_extend(value, pseudo, Path::new(""), chain)
}

/// Resolves the `extend` key of `value` (if any) and merges `value` over its base.
fn apply_extend(
    mut value: Value,
    file: &Path,
    dir: &Path,
    chain: &mut Vec<PathBuf>,
) -> Result<Value, ScenarioError> {
    let target = match value.as_table_mut().and_then(|t| t.remove("extend")) {
        None => return Ok(value),
        Some(Value::String(s)) => s,
        Some(other) => {
            return Err(ScenarioError::Field {
                file: file.to_path_buf(),
                field: "extend".into(),
                message: format!(
                    "must be a string (a built-in name or a path), got {}",
                    other.type_str()
                ),
            })
        }
    };
    let extend_err = |message: String| ScenarioError::Extend {
        file: file.to_path_buf(),
        target: target.clone(),
        message,
    };
    if chain.len() > 16 {
        return Err(extend_err("`extend` chain deeper than 16 files".into()));
    }
    let candidate = dir.join(&target);
    let mut base = if candidate.is_file() {
        if chain.iter().any(|p| same_file(p, &candidate)) {
            return Err(extend_err("`extend` forms a cycle".into()));
        }
        resolve_file(&candidate, chain).map_err(|e| match e {
            ScenarioError::Read { source, .. } => extend_err(format!("cannot read: {source}")),
            other => other,
        })?
    } else {
        let name = target.strip_prefix("builtin:").unwrap_or(&target);
        let name = name.trim_end_matches(".toml");
        let name = name.rsplit('/').next().unwrap_or(name);
        if builtin_text(name).is_none() {
            return Err(extend_err(format!(
                "neither a file ({}) nor a built-in scenario ({})",
                candidate.display(),
                builtin_names().join(", ")
            )));
        }
        let pseudo = PathBuf::from(format!("builtin:{name}"));
        if chain.contains(&pseudo) {
            return Err(extend_err("`extend` forms a cycle".into()));
        }
        resolve_builtin(name, &pseudo, chain)?
    };
    merge::deep_merge(&mut base, value);
    Ok(base)
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_bounds;
