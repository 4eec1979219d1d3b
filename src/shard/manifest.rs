//! The manifest of a folder of records: the study kind, the number of units and the named
//! inputs that determine the records (e.g. the resolved base scenario and the grid), with a
//! fingerprint (64-bit FNV-1a of their canonical JSON). Two manifests with the same fingerprint
//! may share records; otherwise [`Manifest::changes`] says which input changed and where.

use super::{io_err, ShardError};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// What kind of study (`sweep`, `montecarlo`).
    pub kind: String,
    /// Number of work units.
    pub units: usize,
    /// `fnv1a64:` + 16 hex digits over kind, units and inputs.
    pub fingerprint: String,
    /// Named inputs (human names: they appear in messages).
    pub inputs: BTreeMap<String, Value>,
    /// Where the inputs were read from (e.g. the sweep file), for `merge`; not fingerprinted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin: Option<String>,
}

/// 64-bit FNV-1a: stable across platforms and versions (unlike `std`'s hasher).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

impl Manifest {
    pub fn new(kind: &str, units: usize, inputs: BTreeMap<String, Value>) -> Self {
        let canonical = serde_json::to_string(&(kind, units, &inputs)).unwrap_or_default();
        Self {
            kind: kind.into(),
            units,
            fingerprint: format!("fnv1a64:{:016x}", fnv1a64(canonical.as_bytes())),
            inputs,
            origin: None,
        }
    }

    /// Reads `folder/manifest.json` (None when absent).
    pub fn read(folder: &Path) -> Result<Option<Self>, ShardError> {
        let path = folder.join(super::MANIFEST);
        match std::fs::read_to_string(&path) {
            Ok(text) => Self::from_json(&text, &path).map(Some),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(io_err(&path, "read")(e)),
        }
    }

    /// A manifest's JSON text; `path` names it in errors.
    pub fn from_json(text: &str, path: &Path) -> Result<Self, ShardError> {
        serde_json::from_str(text).map_err(|e| ShardError::Log {
            file: path.to_path_buf(),
            line: e.line(),
            message: e.to_string(),
        })
    }

    /// Writes `folder/manifest.json` (pretty, stable key order, newline at the end).
    pub fn write(&self, folder: &Path) -> Result<(), ShardError> {
        let path = folder.join(super::MANIFEST);
        let text = serde_json::to_string_pretty(self).map_err(|e| ShardError::Log {
            file: path.clone(),
            line: 0,
            message: e.to_string(),
        })? + "\n";
        crate::io::output_dir::write_file_atomic(&path, text.as_bytes())?;
        Ok(())
    }

    /// Same study, same inputs: records may be shared.
    pub fn matches(&self, other: &Manifest) -> bool {
        self.kind == other.kind
            && self.units == other.units
            && self.fingerprint == other.fingerprint
    }

    /// What differs from `now` (the current inputs), in words, at most a few per input:
    /// ``base scenario: `camera.distance_m` 0.3 → 0.35``.
    pub fn changes(&self, now: &Manifest) -> Vec<String> {
        let mut out = Vec::new();
        if self.kind != now.kind {
            out.push(format!("study kind: {} → {}", self.kind, now.kind));
        }
        if self.units != now.units {
            out.push(format!("work units: {} → {}", self.units, now.units));
        }
        let keys: std::collections::BTreeSet<&String> =
            self.inputs.keys().chain(now.inputs.keys()).collect();
        for key in keys {
            let (mut a, mut b) = (BTreeMap::new(), BTreeMap::new());
            if let Some(v) = self.inputs.get(key) {
                flatten(v, String::new(), &mut a);
            }
            if let Some(v) = now.inputs.get(key) {
                flatten(v, String::new(), &mut b);
            }
            let paths: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
            let diffs: Vec<String> = paths
                .into_iter()
                .filter(|p| a.get(*p) != b.get(*p))
                .map(|p| {
                    let show = |m: &BTreeMap<String, String>| {
                        m.get(p).cloned().unwrap_or_else(|| "(absent)".into())
                    };
                    let at = if p.is_empty() {
                        String::new()
                    } else {
                        format!("`{p}` ")
                    };
                    format!("{key}: {at}{} → {}", show(&a), show(&b))
                })
                .collect();
            let n = diffs.len();
            out.extend(diffs.into_iter().take(3));
            if n > 3 {
                out.push(format!("{key}: and {} more difference(s)", n - 3));
            }
        }
        if out.is_empty() && self.fingerprint != now.fingerprint {
            out.push(format!(
                "fingerprint {} → {}",
                self.fingerprint, now.fingerprint
            ));
        }
        out
    }
}

fn flatten(v: &Value, path: String, out: &mut BTreeMap<String, String>) {
    let join = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    match v {
        Value::Object(m) => m.iter().for_each(|(k, x)| flatten(x, join(k), out)),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, x)| flatten(x, format!("{path}[{i}]"), out)),
        other => {
            out.insert(path, other.to_string());
        }
    }
}
