//! (placeholder: filled by the render work)
use crate::validation::Problems;
use serde::{Deserialize, Serialize};

pub mod shapes;

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EffectsConfig {}

impl EffectsConfig {
    pub fn validate(&self, _path: &str, _problems: &mut Problems) {}
}
