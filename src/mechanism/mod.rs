//! (placeholder: filled by the mechanism work)
use crate::validation::Problems;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MechanismConfig {}

impl MechanismConfig {
    pub fn validate(&self, _path: &str, _problems: &mut Problems) {}
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DriveSpeedConfig {}

impl DriveSpeedConfig {
    pub fn validate(&self, _path: &str, _problems: &mut Problems) {}
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsConfig {}

impl DynamicsConfig {
    pub fn validate(&self, _path: &str, _problems: &mut Problems) {}
}
