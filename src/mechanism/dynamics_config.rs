//! `[dynamics]` section: wheel inertia, bearing friction, pin–slot contact, integration step, and
//! the `disc_vibration` / `axis_runout` sub-tables, with validation.

use super::contact::ContactModel;
use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

/// Standard gravity, m/s²: the bearing's normal load is the wheel's weight.
pub const GRAVITY_M_S2: f64 = 9.81;

/// Smallest restitution the Hunt–Crossley law accepts (its damping grows without bound as
/// e → 0).
pub const MIN_RESTITUTION: f64 = 0.01;

/// Default pin–slot restitution (calibrated on the seed rig, within 3D-printed PLA's range).
pub const DEFAULT_RESTITUTION: f64 = 0.35;

/// `[dynamics]`: wheel driven through pin–slot clearance by the prescribed crank motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsConfig {
    /// Simulate the clearance dynamics (else the actual wheel motion is the ideal kinematics).
    /// Default false.
    pub enabled: bool,
    /// Wheel mass, kg, in [1e-4, 1e4]. Default 0.348 (seed).
    pub wheel_mass_kg: f64,
    /// Wheel inertia about its axis, kg·m², in [1e-12, 1e6]; default none = uniform disc ½·m·R² with
    /// R = `mechanism.wheel_radius_mm`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wheel_inertia_kg_m2: Option<f64>,
    /// Bearing static friction coefficient μs, in [mu_kinetic, 2]. Default 0.194 (seed).
    pub mu_static: f64,
    /// Bearing kinetic friction coefficient μk, in [0, mu_static]. Default 0.089 (seed).
    pub mu_kinetic: f64,
    /// Effective bearing friction radius, mm (friction torque = μ·m·g·radius). Default 4.
    pub bearing_radius_mm: f64,
    /// Pin–slot contact law: `hunt_crossley` (damping tied to `contact_restitution`) or
    /// `penalty` (linear spring + `contact_damping_n_s_m`, the model before restitution).
    /// Default `hunt_crossley`.
    pub contact_model: ContactModel,
    /// Pin–slot-wall contact stiffness (line contact, linear), N/m, in [1, 1e10]. Default 1e6.
    pub contact_stiffness_n_m: f64,
    /// `penalty` only: contact damping, N·s/m, >= 0 (force stays compressive). Default 50.
    pub contact_damping_n_s_m: f64,
    /// `hunt_crossley` only: coefficient of restitution of one pin–wall impact, in [0.01, 1].
    /// Default 0.35 (3D-printed PLA on PLA, calibrated on the seed rig; scenarios/README.md).
    pub contact_restitution: f64,
    /// Fixed integration step (semi-implicit Euler), s, in [1e-7, 1e-4]. Default 1e-5.
    pub step_s: f64,
    /// Output grid spacing that `actual()` interpolates, s, in [step_s, 1e-2]; rounded to a
    /// whole number of steps. Default 1e-4.
    pub output_step_s: f64,
    /// The crank's drive: exact prescribed motion, or a servo the wheel's load can push.
    pub crank: CrankConfig,
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
            contact_model: ContactModel::HuntCrossley,
            contact_stiffness_n_m: 1e6,
            contact_damping_n_s_m: 50.0,
            contact_restitution: DEFAULT_RESTITUTION,
            step_s: 1e-5,
            output_step_s: 1e-4,
            crank: CrankConfig::default(),
            disc_vibration: DiscVibrationConfig::default(),
            axis_runout: AxisRunoutConfig::default(),
        }
    }
}

/// How the crank moves under the wheel's load (`dynamics.crank.model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CrankModel {
    /// Exactly the `[drive_speed]` profile (the seed's measured crank motion).
    #[default]
    Prescribed,
    /// A crank of finite inertia held to the profile by a servo (spring + damper).
    Servo,
}

/// `[dynamics.crank]`: the crank disc and, for `model = "servo"`, the servo holding it to the
/// prescribed motion. The seed gives only the disc's mass (17 g); the servo's figures are
/// hobby-servo orders of magnitude (see scenarios/README.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CrankConfig {
    /// `prescribed` or `servo`. Default `prescribed`.
    pub model: CrankModel,
    /// Crank disc mass, kg, in [1e-4, 1e4]. Default 0.017 (seed).
    pub disc_mass_kg: f64,
    /// Crank disc radius (uniform disc ½·m·R²), mm, in [0.1, 1e4]. Default 25.
    pub disc_radius_mm: f64,
    /// Motor rotor and gears reflected to the crank axis, kg·m², >= 0. Default 1e-3.
    pub reflected_inertia_kg_m2: f64,
    /// Servo position stiffness, N·m/rad, >= 0. Default 2.
    pub stiffness_n_m_rad: f64,
    /// Servo speed damping, N·m·s/rad, >= 0. Default 0.03.
    pub damping_n_m_s_rad: f64,
}

impl Default for CrankConfig {
    fn default() -> Self {
        Self {
            model: CrankModel::Prescribed,
            disc_mass_kg: 0.017,
            disc_radius_mm: 25.0,
            reflected_inertia_kg_m2: 1e-3,
            stiffness_n_m_rad: 2.0,
            damping_n_m_s_rad: 0.03,
        }
    }
}

impl CrankConfig {
    /// Crank-side inertia about the crank axis, kg·m².
    pub fn inertia_kg_m2(&self) -> f64 {
        let r = self.disc_radius_mm * 1e-3;
        0.5 * self.disc_mass_kg * r * r + self.reflected_inertia_kg_m2
    }

    fn validate(&self, path: &str, problems: &mut Problems) {
        let f = |name: &str| join(path, name);
        // The same span as the wheel's: a watch train to an indexing table.
        problems.range(f("disc_mass_kg"), self.disc_mass_kg, 1e-4, 1e4);
        problems.range(f("disc_radius_mm"), self.disc_radius_mm, 0.1, 1e4);
        problems.range(
            f("reflected_inertia_kg_m2"),
            self.reflected_inertia_kg_m2,
            0.0,
            100.0,
        );
        problems.range(f("stiffness_n_m_rad"), self.stiffness_n_m_rad, 0.0, 1e6);
        problems.range(f("damping_n_m_s_rad"), self.damping_n_m_s_rad, 0.0, 1e6);
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

impl AxisRunoutConfig {
    /// Whether a camera can see this runout at all. A centre offset that turns with the wheel
    /// (1 cycle per revolution: an eccentric axis) moves the marker exactly as a marker stuck
    /// elsewhere on a true wheel would, and one that stands still (0 cycles) only moves the
    /// rotation centre: without a time-driven part, both are the marker's and the centre's own
    /// position, which the analysis fits anyway.
    pub fn is_visible(&self) -> bool {
        let c = self.cycles_per_wheel_rev;
        self.frequency_hz != 0.0 || (c.abs() > 1e-9 && (c - 1.0).abs() > 1e-9)
    }
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
        // A 0.1 g watch wheel to a 10 t indexing table.
        problems.range(f("wheel_mass_kg"), self.wheel_mass_kg, 1e-4, 1e4);
        if let Some(j) = self.wheel_inertia_kg_m2 {
            problems.range(f("wheel_inertia_kg_m2"), j, 1e-12, 1e6);
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
        let e = self.contact_restitution;
        if !(MIN_RESTITUTION..=1.0).contains(&e) {
            problems.push(
                f("contact_restitution"),
                format!(
                    "must be in [{MIN_RESTITUTION}, 1] (a restitution above 1 creates energy, \
                     one near 0 needs unbounded damping), got {e}"
                ),
            );
        }
        problems.range(f("step_s"), self.step_s, 1e-7, 1e-4);
        let lo = if self.step_s.is_finite() {
            self.step_s.max(1e-7)
        } else {
            1e-7
        };
        problems.range(f("output_step_s"), self.output_step_s, lo, 1e-2);
        self.crank.validate(&join(path, "crank"), problems);
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
                "dynamics.step_s: must be in [1e-7, 0.0001], got 0.001",
                "dynamics.output_step_s: must be in [0.001, 0.01], got 0.0001",
                "dynamics.disc_vibration.components[0].amplitude_rad: must be in [0, 0.1], got -1",
                "dynamics.axis_runout.amplitude_m: must be in [0, 0.01], got 1",
            ]
        );
    }

    #[test]
    fn impossible_contact_and_crank_parameters_name_their_fields() {
        let messages = |c: &DynamicsConfig| {
            let mut p = Problems::new();
            c.validate("dynamics", &mut p);
            p.iter().map(|x| x.to_string()).collect::<Vec<_>>()
        };
        for (e, shown) in [(-0.2, "-0.2"), (1.5, "1.5"), (0.0, "0"), (f64::NAN, "NaN")] {
            let m = messages(&DynamicsConfig {
                contact_restitution: e,
                ..Default::default()
            });
            assert_eq!(
                m,
                vec![format!(
                    "dynamics.contact_restitution: must be in [0.01, 1] (a restitution above 1 \
                     creates energy, one near 0 needs unbounded damping), got {shown}"
                )]
            );
        }
        let mut c = DynamicsConfig::default();
        c.crank.disc_mass_kg = 0.0;
        c.crank.reflected_inertia_kg_m2 = -1e-3;
        c.crank.damping_n_m_s_rad = -1.0;
        c.contact_stiffness_n_m = 0.0;
        let m = messages(&c);
        assert_eq!(
            m,
            vec![
                "dynamics.contact_stiffness_n_m: must be in [1, 1e10], got 0",
                "dynamics.crank.disc_mass_kg: must be in [0.0001, 10000], got 0",
                "dynamics.crank.reflected_inertia_kg_m2: must be in [0, 100], got -0.001",
                "dynamics.crank.damping_n_m_s_rad: must be in [0, 1000000], got -1",
            ]
        );
        // The contact model and the crank model are closed sets.
        assert!(toml::from_str::<DynamicsConfig>("contact_model = \"elastic\"").is_err());
        assert!(toml::from_str::<DynamicsConfig>("[crank]\nmodel = \"stepper\"").is_err());
        let c: DynamicsConfig =
            toml::from_str("contact_model = \"penalty\"\n[crank]\nmodel = \"servo\"").unwrap();
        assert_eq!(c.contact_model, ContactModel::Penalty);
        assert_eq!(c.crank.model, CrankModel::Servo);
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
