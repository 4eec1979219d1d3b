//! Field-level validation problems shared by every configuration section.
//!
//! Each section of a scenario owns its config struct and a `validate(&self, path, problems)`
//! method; the scenario loader collects all problems and reports them with the file name.
//! A problem always names the full dotted field path and, where one exists, the allowed range.

use std::fmt;

/// One invalid field: `field` is the dotted path inside the scenario (`mechanism.slots`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    pub field: String,
    pub message: String,
}

/// The problems as an indented bullet list, one per line (for error messages).
pub fn bullet_list(problems: &[Problem]) -> String {
    problems
        .iter()
        .map(|p| format!("  - {p}"))
        .collect::<Vec<_>>()
        .join("\n")
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

/// Collects problems; helpers keep the messages uniform ("must be in [a, b], got x").
#[derive(Debug, Default, Clone)]
pub struct Problems(pub Vec<Problem>);

impl Problems {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn push(&mut self, field: impl Into<String>, message: impl Into<String>) {
        self.0.push(Problem {
            field: field.into(),
            message: message.into(),
        });
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    pub fn len(&self) -> usize {
        self.0.len()
    }

    pub fn iter(&self) -> impl Iterator<Item = &Problem> {
        self.0.iter()
    }

    /// `value` must be finite and inside `[lo, hi]` (inclusive).
    pub fn range(&mut self, field: impl Into<String>, value: f64, lo: f64, hi: f64) {
        if !value.is_finite() || value < lo || value > hi {
            self.push(field, format!("must be in [{lo}, {hi}], got {value}"));
        }
    }

    /// `value` must be finite and strictly positive.
    pub fn positive(&mut self, field: impl Into<String>, value: f64) {
        if !value.is_finite() || value <= 0.0 {
            self.push(field, format!("must be > 0, got {value}"));
        }
    }

    /// `value` must be finite and ≥ 0.
    pub fn non_negative(&mut self, field: impl Into<String>, value: f64) {
        if !value.is_finite() || value < 0.0 {
            self.push(field, format!("must be >= 0, got {value}"));
        }
    }
}

/// Joins a parent path and a field name: `join("camera", "fps")` → `camera.fps`.
pub fn join(parent: &str, field: &str) -> String {
    if parent.is_empty() {
        field.to_string()
    } else {
        format!("{parent}.{field}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_messages_name_field_and_bounds() {
        let mut p = Problems::new();
        p.range("camera.fps", -1.0, 0.1, 1000.0);
        p.positive("mechanism.crank_radius_mm", 0.0);
        p.non_negative("effects.pixel_noise.read_noise_e", f64::NAN);
        p.range("ok", 5.0, 0.0, 10.0);
        let msgs: Vec<String> = p.iter().map(|x| x.to_string()).collect();
        assert_eq!(msgs.len(), 3);
        assert_eq!(msgs[0], "camera.fps: must be in [0.1, 1000], got -1");
        assert_eq!(msgs[1], "mechanism.crank_radius_mm: must be > 0, got 0");
        assert!(msgs[2].starts_with("effects.pixel_noise.read_noise_e: must be >= 0"));
    }

    #[test]
    fn join_paths() {
        assert_eq!(join("", "seed"), "seed");
        assert_eq!(join("camera", "fps"), "camera.fps");
    }
}
