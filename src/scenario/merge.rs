//! `extend`: a scenario may name a base scenario (a built-in name or a path relative to itself)
//! and override any of its fields. Tables merge key by key, recursively; arrays and scalars
//! replace the base's value whole (so a list of vibration components is never half-merged).
//! A table whose `kind` changes (e.g. `drive_speed` from `polynomial_per_engagement` to
//! `constant`) replaces the base table whole: the old variant's fields mean nothing to the new.

use toml::Value;

/// Deep-merges `over` into `base` (in place): tables recursively, everything else replaced.
pub fn deep_merge(base: &mut Value, over: Value) {
    match (base, over) {
        (Value::Table(base_table), Value::Table(over_table)) => {
            for (key, value) in over_table {
                match base_table.get_mut(&key) {
                    Some(existing)
                        if existing.is_table() && value.is_table() && !kind_changes(existing, &value) =>
                    {
                        deep_merge(existing, value)
                    }
                    _ => {
                        base_table.insert(key, value);
                    }
                }
            }
        }
        (base, over) => *base = over,
    }
}

fn kind_changes(base: &Value, over: &Value) -> bool {
    match (base.get("kind"), over.get("kind")) {
        (Some(a), Some(b)) => a != b,
        _ => false,
    }
}

/// Rewrites every relative path stored under a key named `file` or ending in `_file` so it is
/// relative to the current directory instead of to the scenario that wrote it: after merging,
/// nobody knows any more which file a key came from.
pub fn anchor_paths(value: &mut Value, dir: &std::path::Path) {
    match value {
        Value::Table(table) => {
            for (key, v) in table.iter_mut() {
                let is_path_key = key == "file" || key.ends_with("_file");
                match v {
                    Value::String(s) if is_path_key && !s.is_empty() && !is_builtin_ref(s) => {
                        let p = std::path::Path::new(s.as_str());
                        if p.is_relative() {
                            *s = dir.join(p).to_string_lossy().into_owned();
                        }
                    }
                    other => anchor_paths(other, dir),
                }
            }
        }
        Value::Array(items) => items.iter_mut().for_each(|v| anchor_paths(v, dir)),
        _ => {}
    }
}

/// Data shipped inside the binary is referred to as `builtin:NAME`; such paths are not anchored.
pub fn is_builtin_ref(s: &str) -> bool {
    s.starts_with("builtin:")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(s: &str) -> Value {
        toml::from_str(s).unwrap()
    }

    #[test]
    fn tables_merge_and_scalars_replace() {
        let mut base = v("a = 1\n[t]\nx = 1\ny = 2\nlist = [1, 2]\n[t.inner]\nz = 3");
        deep_merge(&mut base, v("[t]\ny = 20\nlist = [9]\n[t.inner]\nw = 4"));
        assert_eq!(
            base,
            v("a = 1\n[t]\nx = 1\ny = 20\nlist = [9]\n[t.inner]\nz = 3\nw = 4")
        );
    }

    #[test]
    fn a_changed_kind_replaces_the_table() {
        let mut base = v("[d]\nkind = \"poly\"\nend = 1\n[e]\nkind = \"a\"\nx = 1");
        deep_merge(&mut base, v("[d]\nkind = \"constant\"\nw = 2\n[e]\nkind = \"a\"\ny = 2"));
        assert_eq!(base, v("[d]\nkind = \"constant\"\nw = 2\n[e]\nkind = \"a\"\nx = 1\ny = 2"));
    }

    #[test]
    fn relative_file_paths_are_anchored_to_their_scenario() {
        let mut value = v("[frame_timing]\nfile = \"logs/a.log\"\n[x]\ntable_file = \"/abs/t.csv\"\n[y]\nfile = \"builtin:seed\"");
        anchor_paths(&mut value, std::path::Path::new("scenarios"));
        assert_eq!(
            value["frame_timing"]["file"].as_str(),
            Some("scenarios/logs/a.log")
        );
        assert_eq!(value["x"]["table_file"].as_str(), Some("/abs/t.csv"));
        assert_eq!(value["y"]["file"].as_str(), Some("builtin:seed"));
    }
}
