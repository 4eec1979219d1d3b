//! `[mechanism]` section: Geneva drive geometry, start angle and phase split, with validation.

use super::kinematics::{Geneva, GenevaKind};
use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// `[mechanism]`: geometry of the Geneva drive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MechanismConfig {
    /// `internal` or `external`. Default `internal` (the seed's drive).
    pub kind: GenevaKind,
    /// Number of slots n, 3..=36. Default 4.
    pub slots: u32,
    /// Distance between crank and wheel axes L, mm, in [0.1, 10000]. Default 25 (seed).
    pub centre_distance_mm: f64,
    /// Crank radius r, mm; optional, must equal L·sin(π/n) within 0.5 % when given.
    /// Default none (derived).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crank_radius_mm: Option<f64>,
    /// Pin diameter, mm, in [0.01, 1000] and at most `slot_width_mm`. Default 9.5 (seed: 0.5 mm
    /// clearance).
    pub pin_diameter_mm: f64,
    /// Slot width, mm, in [0.01, 1000]. Default 10.
    pub slot_width_mm: f64,
    /// Outer radius of the driven disc, mm, in [0.1, 10000]; must clear the slot ends. Default
    /// 170 (holds the seed's marker at 145 mm).
    pub wheel_radius_mm: f64,
    /// Crank angle θ1 at t = 0, rad, in [−1000, 1000], from the line of centres (0 = pin
    /// deepest). Default none:
    /// in dwell, 20 % of the dwell angle before the next entry (depends on the crank direction).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub theta1_start_rad: Option<f64>,
    /// Fraction of each engagement's crank angle labelled `entry` (and, at the end, `exit`),
    /// in [0, 0.5). Default 0.15.
    pub entry_exit_fraction: f64,
}

impl Default for MechanismConfig {
    fn default() -> Self {
        Self {
            kind: GenevaKind::Internal,
            slots: 4,
            centre_distance_mm: 25.0,
            crank_radius_mm: None,
            pin_diameter_mm: 9.5,
            slot_width_mm: 10.0,
            wheel_radius_mm: 170.0,
            theta1_start_rad: None,
            entry_exit_fraction: 0.15,
        }
    }
}

/// Relative tolerance on a given crank radius.
const CRANK_RADIUS_TOL: f64 = 0.005;

impl MechanismConfig {
    pub fn geneva(&self) -> Geneva {
        Geneva::new(self.kind, self.slots)
    }

    /// r = L·sin(π/n), mm (the given value is only checked, never used).
    pub fn crank_radius_derived_mm(&self) -> f64 {
        self.centre_distance_mm * (PI / self.slots.max(1) as f64).sin()
    }

    /// Pin–slot clearance (slot width − pin diameter), mm.
    pub fn clearance_mm(&self) -> f64 {
        self.slot_width_mm - self.pin_diameter_mm
    }

    /// Crank angle at t = 0 for a crank turning with sign `direction` (±1).
    pub fn theta1_start_resolved_rad(&self, direction: f64) -> f64 {
        self.theta1_start_rad.unwrap_or_else(|| {
            let beta = self.geneva().engagement_half_angle_rad();
            let dwell = 2.0 * PI - 2.0 * beta;
            direction * (-beta - 0.2 * dwell)
        })
    }

    pub fn validate(&self, path: &str, problems: &mut Problems) {
        let f = |name: &str| join(path, name);
        if !(3..=36).contains(&self.slots) {
            problems.push(
                f("slots"),
                format!("must be in [3, 36], got {}", self.slots),
            );
        }
        // Physical bounds: from a watch movement (0.1 mm) to an industrial indexer (10 m).
        problems.range(f("centre_distance_mm"), self.centre_distance_mm, 0.1, 1e4);
        problems.range(f("pin_diameter_mm"), self.pin_diameter_mm, 0.01, 1e3);
        problems.range(f("slot_width_mm"), self.slot_width_mm, 0.01, 1e3);
        problems.range(f("wheel_radius_mm"), self.wheel_radius_mm, 0.1, 1e4);
        if !(0.0..0.5).contains(&self.entry_exit_fraction) {
            problems.push(
                f("entry_exit_fraction"),
                format!(
                    "must be in [0, 0.5), got {}",
                    crate::validation::short(self.entry_exit_fraction)
                ),
            );
        }
        if let Some(t) = self.theta1_start_rad {
            problems.range(f("theta1_start_rad"), t, -1e3, 1e3);
        }
        // Geometry checks need sane basic values.
        let basics_ok =
            (3..=36).contains(&self.slots) && (0.1..=1e4).contains(&self.centre_distance_mm);
        if !basics_ok {
            return;
        }
        let r = self.crank_radius_derived_mm();
        if let Some(given) = self.crank_radius_mm {
            if !given.is_finite() || (given - r).abs() > CRANK_RADIUS_TOL * r {
                problems.push(
                    f("crank_radius_mm"),
                    format!(
                        "must equal centre_distance_mm·sin(π/slots) = {r:.4} within 0.5 %, got {given}"
                    ),
                );
            }
        }
        if self.pin_diameter_mm > self.slot_width_mm {
            problems.push(
                f("pin_diameter_mm"),
                format!(
                    "must be <= slot_width_mm ({}), got {}",
                    crate::validation::short(self.slot_width_mm),
                    crate::validation::short(self.pin_diameter_mm)
                ),
            );
        }
        let l = self.centre_distance_mm;
        let pin_r = self.pin_diameter_mm.max(0.0) / 2.0;
        let mouth = l * (PI / self.slots as f64).cos();
        match self.kind {
            GenevaKind::Internal => {
                // The deepest pin position (L + r from the wheel axis) must lie inside the disc.
                let need = l + r + pin_r;
                if self.wheel_radius_mm <= need {
                    problems.push(
                        f("wheel_radius_mm"),
                        format!(
                            "must be > centre_distance + crank radius + pin radius = {need:.3} mm \
                             for an internal drive, got {}",
                            self.wheel_radius_mm
                        ),
                    );
                }
            }
            GenevaKind::External => {
                // The slot mouth is at L·cos(π/n); the slot bottom (L − r − pin radius) must
                // stay clear of the axis.
                if self.wheel_radius_mm < mouth {
                    problems.push(
                        f("wheel_radius_mm"),
                        format!(
                            "must be >= centre_distance·cos(π/slots) = {mouth:.3} mm (slot mouth) \
                             for an external drive, got {}",
                            self.wheel_radius_mm
                        ),
                    );
                }
                if l - r - pin_r <= 0.0 {
                    problems.push(
                        f("pin_diameter_mm"),
                        format!(
                            "slot bottom would reach the wheel axis: need pin radius < L − r = \
                             {:.3} mm, got {pin_r}",
                            l - r
                        ),
                    );
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn messages(c: &MechanismConfig) -> Vec<String> {
        let mut p = Problems::new();
        c.validate("mechanism", &mut p);
        p.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn defaults_are_valid_and_seed_like() {
        let c = MechanismConfig::default();
        assert!(messages(&c).is_empty(), "{:?}", messages(&c));
        assert!((c.crank_radius_derived_mm() - 25.0 / 2f64.sqrt()).abs() < 1e-12);
        assert!((c.clearance_mm() - 0.5).abs() < 1e-12);
        let ext = MechanismConfig {
            kind: GenevaKind::External,
            wheel_radius_mm: 20.0,
            ..c
        };
        assert!(messages(&ext).is_empty(), "{:?}", messages(&ext));
    }

    #[test]
    fn each_invalid_field_has_its_message() {
        let base = MechanismConfig::default();
        let m = messages(&MechanismConfig {
            slots: 2,
            ..base.clone()
        });
        assert_eq!(m, vec!["mechanism.slots: must be in [3, 36], got 2"]);

        let m = messages(&MechanismConfig {
            crank_radius_mm: Some(20.0),
            ..base.clone()
        });
        assert_eq!(
            m,
            vec![
                "mechanism.crank_radius_mm: must equal centre_distance_mm·sin(π/slots) = \
                  17.6777 within 0.5 %, got 20"
            ]
        );
        assert!(messages(&MechanismConfig {
            crank_radius_mm: Some(17.7),
            ..base.clone()
        })
        .is_empty());

        let m = messages(&MechanismConfig {
            pin_diameter_mm: 10.5,
            ..base.clone()
        });
        assert_eq!(
            m,
            vec!["mechanism.pin_diameter_mm: must be <= slot_width_mm (10), got 10.5"]
        );

        let m = messages(&MechanismConfig {
            centre_distance_mm: -1.0,
            ..base.clone()
        });
        assert_eq!(
            m,
            vec!["mechanism.centre_distance_mm: must be in [0.1, 10000], got -1"]
        );

        let m = messages(&MechanismConfig {
            wheel_radius_mm: 40.0,
            ..base.clone()
        });
        assert_eq!(m.len(), 1);
        assert!(m[0].starts_with(
            "mechanism.wheel_radius_mm: must be > centre_distance + crank radius + pin radius = \
             47.428 mm"
        ));

        let ext = MechanismConfig {
            kind: GenevaKind::External,
            wheel_radius_mm: 10.0,
            ..base
        };
        let m = messages(&ext);
        assert!(m[0].starts_with("mechanism.wheel_radius_mm: must be >= centre_distance·cos"));

        let m = messages(&MechanismConfig {
            entry_exit_fraction: 0.5,
            ..Default::default()
        });
        assert_eq!(
            m,
            vec!["mechanism.entry_exit_fraction: must be in [0, 0.5), got 0.5"]
        );
    }

    #[test]
    fn toml_defaults_and_unknown_fields() {
        let c: MechanismConfig = toml::from_str("kind = \"external\"\nslots = 6").unwrap();
        assert_eq!(c.kind, GenevaKind::External);
        assert_eq!(c.slots, 6);
        assert_eq!(c.pin_diameter_mm, 9.5);
        assert!(toml::from_str::<MechanismConfig>("slot = 6").is_err());
        let s = toml::to_string(&MechanismConfig::default()).unwrap();
        assert_eq!(
            toml::from_str::<MechanismConfig>(&s).unwrap(),
            MechanismConfig::default()
        );
    }
}
