//! (placeholder: filled by the timing work)
use crate::validation::Problems;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FrameTimingConfig {}

impl FrameTimingConfig {
    pub fn validate(&self, _path: &str, _problems: &mut Problems) {}
}
