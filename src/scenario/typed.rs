//! From the merged TOML value to a typed [`Scenario`], with errors that name the field.
//!
//! serde reports a type error inside a section chosen by `kind` (an internally tagged enum such
//! as `camera.focal`) at the section, because the enum buffers its table before choosing the
//! variant. The field is found again by removing the section's keys one at a time: the first key
//! whose removal changes the error is the culprit.

use super::{Scenario, ScenarioError};
use std::path::Path;
use toml::Value;

pub fn deserialize(value: Value, file: &Path) -> Result<Scenario, ScenarioError> {
    let error = match attempt(value.clone()) {
        Ok(s) => return Ok(s),
        Err(e) => e,
    };
    let (mut field, message) = error;
    if let Some(key) = culprit(&value, &field, &message) {
        field = if field.is_empty() {
            key
        } else {
            format!("{field}.{key}")
        };
    }
    Err(ScenarioError::Field {
        file: file.to_path_buf(),
        field,
        message,
    })
}

/// Deserialises, returning the error's path and its message without the toml crate's trailing
/// "in `path`" line (the path is reported as the field).
fn attempt(value: Value) -> Result<Scenario, (String, String)> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let text = crate::validation::shorten_quoted_numbers(&e.into_inner().to_string());
        let message = text
            .lines()
            .filter(|l| !(l.starts_with("in `") && l.ends_with('`')))
            .collect::<Vec<_>>()
            .join("\n")
            .trim()
            .to_string();
        (if path == "." { String::new() } else { path }, message)
    })
}

/// The table at a dotted serde path (`a.b[2].c`), if it is one.
fn table_at<'a>(root: &'a mut Value, path: &str) -> Option<&'a mut toml::Table> {
    let mut cur = root;
    if !path.is_empty() {
        for part in path.split('.') {
            let (key, index) = match part.split_once('[') {
                Some((k, rest)) => (k, rest.trim_end_matches(']').parse::<usize>().ok()),
                None => (part, None),
            };
            cur = cur.as_table_mut()?.get_mut(key)?;
            if let Some(i) = index {
                cur = cur.as_array_mut()?.get_mut(i)?;
            }
        }
    }
    cur.as_table_mut()
}

fn culprit(value: &Value, path: &str, message: &str) -> Option<String> {
    let mut probe = value.clone();
    let keys: Vec<String> = {
        let table = table_at(&mut probe, path)?;
        if !table.contains_key("kind") {
            return None;
        }
        table.keys().filter(|k| *k != "kind").cloned().collect()
    };
    keys.into_iter().find(|key| {
        let mut without = value.clone();
        if let Some(t) = table_at(&mut without, path) {
            t.remove(key);
        }
        match attempt(without) {
            Ok(_) => true,
            Err((p, m)) => p != path || m != message,
        }
    })
}

#[cfg(test)]
mod tests {
    use crate::scenario::from_str;
    use std::path::Path;

    fn field_error(text: &str) -> String {
        from_str(text, Path::new("t.toml")).unwrap_err().to_string()
    }

    #[test]
    fn type_errors_in_kind_sections_name_the_field() {
        // Regression: "field `camera.focal`: invalid type ..." named only the section.
        let e = field_error(
            "extend = \"fast\"\n[camera.focal]\nkind = \"physical\"\nfocal_length_mm = \"x\"\n\
             sensor_width_mm = 5.0\n",
        );
        assert!(e.contains("field `camera.focal.focal_length_mm`"), "{e}");
        assert!(!e.contains("\nin `"), "{e}");
        let e = field_error(
            "extend = \"fast\"\n[estimator.differentiator]\nkind = \"savitzky_golay\"\norder = 2.5\n",
        );
        assert!(e.contains("field `estimator.differentiator.order`"), "{e}");
        let e = field_error(
            "extend = \"fast\"\n[frame_timing.model]\nkind = \"vfr\"\njitter_s = [1]\n",
        );
        assert!(e.contains("field `frame_timing.model.jitter_s`"), "{e}");
        // Plain sections were already right and stay so.
        let e = field_error("extend = \"fast\"\n[camera]\nwidth_px = \"x\"\n");
        assert!(e.contains("field `camera.width_px`"), "{e}");
        // An unknown kind names the section's kind.
        let e = field_error("extend = \"fast\"\n[camera.focal]\nkind = \"nope\"\n");
        assert!(e.contains("camera.focal"), "{e}");
    }
}
