//! (placeholder: filled by the render work)
use serde::{Deserialize, Serialize};
use crate::validation::Problems;

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SceneConfig {}

impl SceneConfig {
    pub fn validate(&self, _path: &str, _problems: &mut Problems) {}
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EffectsConfig {}

impl EffectsConfig {
    pub fn validate(&self, _path: &str, _problems: &mut Problems) {}
}
