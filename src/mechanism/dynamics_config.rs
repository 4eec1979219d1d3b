//! `[dynamics]` section: wheel inertia, bearing friction, pin–slot contact, integration step, and
//! the `disc_vibration` / `axis_runout` sub-tables, with validation.

use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

/// Standard gravity, m/s²: the bearing's normal load is the wheel's weight.
pub const GRAVITY_M_S2: f64 = 9.81;

/// `[dynamics]`: wheel driven through pin–slot clearance by the prescribed crank motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsConfig {
    /// Simulate the clearance dynamics (else the actual wheel motion is the ideal kinematics).
    /// Default false.
    pub enabled: bool,
    /// Wheel mass, kg. Default 0.348 (seed).
    pub wheel_mass_kg: f64,
    /// Wheel inertia about its axis, kg·m²; default none = uniform disc ½·m·R² with
    /// R = `mechanism.wheel_radius_mm`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wheel_inertia_kg_m2: Option<f64>,
    /// Bearing static friction coefficient μs, in [mu_kinetic, 2]. Default 0.194 (seed).
    pub mu_static: f64,
    /// Bearing kinetic friction coefficient μk, in [0, mu_static]. Default 0.089 (seed).
    pub mu_kinetic: f64,
    /// Effective bearing friction radius, mm (friction torque = μ·m·g·radius). Default 4.
    pub bearing_radius_mm: f64,
    /// Pin–slot-wall penalty contact stiffness, N/m, in [1, 1e10]. Default 1e6.
    pub contact_stiffness_n_m: f64,
    /// Pin–slot-wall contact damping, N·s/m, >= 0 (force stays compressive). Default 50.
    pub contact_damping_n_s_m: f64,
    /// Fixed integration step (semi-implicit Euler), s, in [1e-7, 1e-4]. Default 1e-5.
    pub step_s: f64,
    /// Output grid spacing that `actual()` interpolates, s, in [step_s, 1e-2]; rounded to a
    /// whole number of steps. Default 1e-4.
    pub output_step_s: f64,
    /// Rotational oscillation of the wheel added to the actual motion.
    pub disc_vibration: DiscVibrationConfig,
    /// Wheel centre wobble added to the actual motion.
    pub axis_runout: AxisRunoutConfig,
}

impl Default for DynamicsConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            wheel_mass_kg: 0.348,
            wheel_inertia_kg_m2: None,
            mu_static: 0.194,
            mu_kinetic: 0.089,
            bearing_radius_mm: 4.0,
            contact_stiffness_n_m: 1e6,
            contact_damping_n_s_m: 50.0,
            step_s: 1e-5,
            output_step_s: 1e-4,
            disc_vibration: DiscVibrationConfig::default(),
            axis_runout: AxisRunoutConfig::default(),
        }
    }
}

/// `[dynamics.disc_vibration]`: θ2 += Σ amplitude·sin(2π·frequency·t + phase).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DiscVibrationConfig {
    /// Add the vibration to the actual motion. Default false.
    pub enabled: bool,
    /// Sinusoidal components. Default one component: 2e-4 rad at 25 Hz, phase 0.
    pub components: Vec<VibrationComponent>,
}

impl Default for DiscVibrationConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            components: vec![VibrationComponent {
                amplitude_rad: 2e-4,
                frequency_hz: 25.0,
                phase_rad: 0.0,
            }],
        }
    }
}

/// One sinusoid of the disc vibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VibrationComponent {
    /// Amplitude, rad, in [0, 0.1].
    pub amplitude_rad: f64,
    /// Frequency, Hz, in [0, 10000].
    pub frequency_hz: f64,
    /// Phase at t = 0, rad. Default 0.
    #[serde(default)]
    pub phase_rad: f64,
}

/// `[dynamics.axis_runout]`: wheel centre offset amplitude·(cos ψ, sin ψ) with
/// ψ = cycles_per_wheel_rev·θ2 + 2π·frequency_hz·t + phase_rad (global frame, metres).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AxisRunoutConfig {
    /// Add the runout to the actual motion. Default false.
    pub enabled: bool,
    /// Centre offset radius, m, in [0, 0.01]. Default 5e-5.
    pub amplitude_m: f64,
    /// Wobble cycles per wheel revolution (1 = eccentric axis). Default 1.
    pub cycles_per_wheel_rev: f64,
    /// Additional time-driven wobble frequency, Hz, in [0, 10000]. Default 0.
    pub frequency_hz: f64,
    /// Phase, rad. Default 0.
    pub phase_rad: f64,
}

impl Default for AxisRunoutConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            amplitude_m: 5e-5,
            cycles_per_wheel_rev: 1.0,
            frequency_hz: 0.0,
            phase_rad: 0.0,
        }
    }
}

impl DynamicsConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        let f = |name: &str| join(path, name);
        problems.positive(f("wheel_mass_kg"), self.wheel_mass_kg);
        if let Some(j) = self.wheel_inertia_kg_m2 {
            problems.positive(f("wheel_inertia_kg_m2"), j);
        }
        problems.range(f("mu_static"), self.mu_static, 0.0, 2.0);
        let mu_s = if self.mu_static.is_finite() {
            self.mu_static.clamp(0.0, 2.0)
        } else {
            2.0
        };
        problems.range(f("mu_kinetic"), self.mu_kinetic, 0.0, mu_s);
        problems.range(f("bearing_radius_mm"), self.bearing_radius_mm, 0.0, 100.0);
        problems.range(
            f("contact_stiffness_n_m"),
            self.contact_stiffness_n_m,
            1.0,
            1e10,
        );
        problems.range(
            f("contact_damping_n_s_m"),
            self.contact_damping_n_s_m,
            0.0,
            1e6,
        );
        problems.range(f("step_s"), self.step_s, 1e-7, 1e-4);
        let lo = if self.step_s.is_finite() {
            self.step_s.max(1e-7)
        } else {
            1e-7
        };
        problems.range(f("output_step_s"), self.output_step_s, lo, 1e-2);
        let dv = join(path, "disc_vibration");
        for (i, c) in self.disc_vibration.components.iter().enumerate() {
            let p = format!("{}[{i}]", join(&dv, "components"));
            problems.range(join(&p, "amplitude_rad"), c.amplitude_rad, 0.0, 0.1);
            problems.range(join(&p, "frequency_hz"), c.frequency_hz, 0.0, 1e4);
            problems.range(join(&p, "phase_rad"), c.phase_rad, -1e3, 1e3);
        }
        let ar = join(path, "axis_runout");
        problems.range(
            join(&ar, "amplitude_m"),
            self.axis_runout.amplitude_m,
            0.0,
            0.01,
        );
        problems.range(
            join(&ar, "cycles_per_wheel_rev"),
            self.axis_runout.cycles_per_wheel_rev,
            -100.0,
            100.0,
        );
        problems.range(
            join(&ar, "frequency_hz"),
            self.axis_runout.frequency_hz,
            0.0,
            1e4,
        );
        problems.range(
            join(&ar, "phase_rad"),
            self.axis_runout.phase_rad,
            -1e3,
            1e3,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_valid_and_messages_name_fields() {
        let mut p = Problems::new();
        DynamicsConfig::default().validate("dynamics", &mut p);
        assert!(p.is_empty(), "{:?}", p);
        let mut bad = DynamicsConfig {
            mu_static: 0.05,
            step_s: 1e-3,
            ..Default::default()
        };
        bad.disc_vibration.components[0].amplitude_rad = -1.0;
        bad.axis_runout.amplitude_m = 1.0;
        let mut p = Problems::new();
        bad.validate("dynamics", &mut p);
        let m: Vec<String> = p.iter().map(|x| x.to_string()).collect();
        assert_eq!(
            m,
            vec![
                "dynamics.mu_kinetic: must be in [0, 0.05], got 0.089",
                "dynamics.step_s: must be in [0.0000001, 0.0001], got 0.001",
                "dynamics.output_step_s: must be in [0.001, 0.01], got 0.0001",
                "dynamics.disc_vibration.components[0].amplitude_rad: must be in [0, 0.1], got -1",
                "dynamics.axis_runout.amplitude_m: must be in [0, 0.01], got 1",
            ]
        );
    }

    #[test]
    fn toml_sub_tables() {
        let c: DynamicsConfig = toml::from_str(
            "enabled = true\n[disc_vibration]\nenabled = true\n\
             components = [{ amplitude_rad = 0.001, frequency_hz = 12.0 }]\n\
             [axis_runout]\nenabled = true\namplitude_m = 1e-4\n",
        )
        .unwrap();
        assert!(c.enabled && c.disc_vibration.enabled && c.axis_runout.enabled);
        assert_eq!(c.disc_vibration.components[0].phase_rad, 0.0);
        assert!(toml::from_str::<DynamicsConfig>("[axis_runout]\nfoo = 1").is_err());
        let s = toml::to_string(&DynamicsConfig::default()).unwrap();
        assert_eq!(
            toml::from_str::<DynamicsConfig>(&s).unwrap(),
            DynamicsConfig::default()
        );
    }
}
