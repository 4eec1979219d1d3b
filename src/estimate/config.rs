//! The `[estimator]` scenario section: which marker centre, rotation-centre method, camera-motion
//! compensation, differentiator, time base and primary signal the estimate uses.

use serde::{Deserialize, Serialize};

use super::differentiate::Differentiator;
use crate::validation::{join, Problems};

/// How the marker centre is computed from its four corners.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum MarkerCentreMethod {
    /// Mean of the four corners (what the seed study did; default: the best of
    /// `reports/defaults/`). Biased under perspective.
    #[default]
    CornerMean,
    /// Intersection of the two diagonals: the projection of the printed centre, exact under
    /// perspective.
    DiagonalIntersection,
}

/// How the rotation centre of the driven disc is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum RotationCentreMethod {
    /// The seed's method: perpendicular bisectors of corner 0 and of corner 2 between the detected
    /// frames at indices ⌊n/2⌋ and ⌊3n/4⌋, intersected, truncated towards zero to whole pixels.
    Seed,
    /// Kåsa algebraic circle fit, one centre shared by all five signals.
    Kasa,
    /// Taubin algebraic circle fit, one centre shared by all five signals (default: the best of
    /// `reports/defaults/`).
    #[default]
    Taubin,
    /// Taubin start refined by Levenberg–Marquardt on orthogonal distances.
    Geometric,
}

impl MarkerCentreMethod {
    /// The scenario spelling.
    pub fn name(self) -> &'static str {
        match self {
            MarkerCentreMethod::CornerMean => "corner_mean",
            MarkerCentreMethod::DiagonalIntersection => "diagonal_intersection",
        }
    }
}

impl RotationCentreMethod {
    /// The scenario spelling.
    pub fn name(self) -> &'static str {
        match self {
            RotationCentreMethod::Seed => "seed",
            RotationCentreMethod::Kasa => "kasa",
            RotationCentreMethod::Taubin => "taubin",
            RotationCentreMethod::Geometric => "geometric",
        }
    }
}

/// Camera-motion compensation from a static reference marker.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceCompensation {
    /// No compensation (the reference track, if given, is ignored). Default.
    #[default]
    Off,
    /// Subtract the reference marker centre's displacement from its first detected frame.
    Translation,
    /// Undo the reference marker's 2-D rigid motion (rotation + translation, Procrustes fit).
    Rigid,
}

/// Which per-frame timestamps the derivatives use.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Timebase {
    /// Real per-frame timestamps as given (default).
    #[default]
    Timestamps,
    /// Assume frame k was taken at k / fps_hz (the "constant 30 fps" assumption); k is the input
    /// frame index, so missing frames still widen the step.
    ConstantFps {
        /// Assumed frame rate, Hz; default 30.0.
        #[serde(default = "default_timebase_fps")]
        fps_hz: f64,
    },
}

/// One angle signal: a corner, the marker centre, or the fusion of all five.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Signal {
    Corner0,
    Corner1,
    Corner2,
    Corner3,
    /// Marker centre (default).
    #[default]
    Centre,
    /// Radius²-weighted fusion of the five signals.
    Fused,
}

impl Signal {
    /// All six signals in output order (corners 0–3, centre, fused).
    pub const ALL: [Signal; 6] = [
        Signal::Corner0,
        Signal::Corner1,
        Signal::Corner2,
        Signal::Corner3,
        Signal::Centre,
        Signal::Fused,
    ];

    /// Name used in CSV files and reports (the serde name).
    pub fn name(self) -> &'static str {
        match self {
            Signal::Corner0 => "corner0",
            Signal::Corner1 => "corner1",
            Signal::Corner2 => "corner2",
            Signal::Corner3 => "corner3",
            Signal::Centre => "centre",
            Signal::Fused => "fused",
        }
    }

    /// Position in [`Signal::ALL`].
    pub fn index(self) -> usize {
        Signal::ALL.iter().position(|s| *s == self).unwrap_or(0)
    }
}

fn default_timebase_fps() -> f64 {
    30.0
}

/// Estimator configuration (`[estimator]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EstimatorConfig {
    /// Marker-centre method: `"corner_mean"` (default, seed) or `"diagonal_intersection"`.
    /// The defaults of the three choices below are the best of `reports/defaults/`.
    pub marker_centre: MarkerCentreMethod,
    /// Rotation-centre method: `"seed"`, `"kasa"`, `"taubin"` (default), `"geometric"`.
    pub rotation_centre: RotationCentreMethod,
    /// Camera-motion compensation from the reference marker: `"off"` (default), `"translation"`,
    /// `"rigid"`.
    pub reference_compensation: ReferenceCompensation,
    /// Numerical differentiator (`kind = "seed" | "central3" | "savitzky_golay" | "kalman_rts"`);
    /// default `kalman_rts` with λ chosen automatically.
    pub differentiator: Differentiator,
    /// Time base (`kind = "timestamps"` default, or `kind = "constant_fps"` with `fps_hz`).
    pub timebase: Timebase,
    /// Signal reported as the primary measurement; default `"centre"`.
    pub primary_signal: Signal,
    /// Smallest arc (about the fitted centre) the circle fits accept, degrees; default 10.0.
    pub min_arc_deg: f64,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        Self {
            marker_centre: MarkerCentreMethod::default(),
            rotation_centre: RotationCentreMethod::default(),
            reference_compensation: ReferenceCompensation::default(),
            differentiator: Differentiator::default(),
            timebase: Timebase::default(),
            primary_signal: Signal::default(),
            min_arc_deg: 10.0,
        }
    }
}

impl EstimatorConfig {
    /// The three choices `reports/defaults/` ranks, comma-free:
    /// `differentiator / marker centre / rotation centre`.
    pub fn choice_name(&self) -> String {
        format!(
            "{} / {} / {}",
            self.differentiator.label(),
            self.marker_centre.name(),
            self.rotation_centre.name()
        )
    }

    /// Pushes one problem per invalid field, with its dotted path and allowed range.
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(join(path, "min_arc_deg"), self.min_arc_deg, 0.0, 360.0);
        if let Timebase::ConstantFps { fps_hz } = self.timebase {
            problems.range(
                join(&join(path, "timebase"), "fps_hz"),
                fps_hz,
                0.1,
                100_000.0,
            );
        }
        self.differentiator
            .validate(&join(path, "differentiator"), problems);
    }
}
