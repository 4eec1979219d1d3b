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
            self.push(
                field,
                format!(
                    "must be in [{}, {}], got {}",
                    short(lo),
                    short(hi),
                    short(value)
                ),
            );
        }
    }

    /// `value` must follow `previous` (the list's entry before it) strictly, in `what` (`time`,
    /// `angle`) with `unit` after each number.
    pub fn increasing(
        &mut self,
        field: impl Into<String>,
        value: f64,
        previous: f64,
        (what, unit): (&str, &str),
    ) {
        if value <= previous {
            self.push(
                field,
                format!(
                    "entries must be in increasing {what}: {}{unit} follows {}{unit}",
                    short(value),
                    short(previous)
                ),
            );
        }
    }

    /// `value` must be finite and strictly positive.
    pub fn positive(&mut self, field: impl Into<String>, value: f64) {
        if !value.is_finite() || value <= 0.0 {
            self.push(field, format!("must be > 0, got {}", short(value)));
        }
    }

    /// `value` must be finite and ≥ 0.
    pub fn non_negative(&mut self, field: impl Into<String>, value: f64) {
        if !value.is_finite() || value < 0.0 {
            self.push(field, format!("must be >= 0, got {}", short(value)));
        }
    }
}

/// `text` with every number quoted in backticks that is longer than 12 characters written
/// with [`short`]: serde and toml print a float's every digit (`1e308` as 309 of them).
pub fn shorten_quoted_numbers(text: &str) -> String {
    text.split('`')
        .enumerate()
        .map(|(k, part)| match part.parse::<f64>() {
            Ok(v) if k % 2 == 1 && part.len() > 12 => short(v),
            _ => part.to_string(),
        })
        .collect::<Vec<_>>()
        .join("`")
}

/// A number as short as it can be written and still read back exactly: plain decimal up to 8
/// characters (`10000`, `0.00001`), else plain or scientific, whichever is shorter (`1e308`,
/// `2.5e-300`; never 309 digits).
pub fn short(v: f64) -> String {
    let plain = format!("{v}");
    let sci = format!("{v:e}");
    if plain.len() > 8 && sci.len() < plain.len() {
        sci
    } else {
        plain
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
    fn long_quoted_numbers_are_shortened_and_nothing_else_changes() {
        let long = format!("{}", 1e308);
        let text = format!("invalid type: floating point `{long}`, expected usize");
        assert_eq!(
            shorten_quoted_numbers(&text),
            "invalid type: floating point `1e308`, expected usize"
        );
        let kept = "field `detector.roi` is `12345`; `x` `0.1`";
        assert_eq!(shorten_quoted_numbers(kept), kept);
        assert_eq!(shorten_quoted_numbers("no quotes 1e308"), "no quotes 1e308");
    }

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
    fn numbers_are_printed_short() {
        // Regression: messages printed 1e308 as 309 digits.
        assert_eq!(short(1e308), "1e308");
        assert_eq!(short(-1e-300), "-1e-300");
        assert_eq!(short(0.00001), "0.00001");
        assert_eq!(short(1e12), "1e12");
        assert_eq!(short(1234.5), "1234.5");
        assert_eq!(short(0.1 + 0.2), "0.30000000000000004");
        assert_eq!(short(f64::NAN), "NaN");
        for v in [1e308, 3.7e-12, 123456789.0, 0.1 + 0.2] {
            assert_eq!(short(v).parse::<f64>().unwrap(), v);
        }
        let mut p = Problems::new();
        p.range("scene.disc_radius_mm", 1e308, 0.1, 1e4);
        assert_eq!(
            p.0[0].to_string(),
            "scene.disc_radius_mm: must be in [0.1, 10000], got 1e308"
        );
    }

    #[test]
    fn join_paths() {
        assert_eq!(join("", "seed"), "seed");
        assert_eq!(join("camera", "fps"), "camera.fps");
    }
}
