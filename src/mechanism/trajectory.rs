//! The run's truth trajectory: continuous multi-cycle crank and wheel motion over time, ideal
//! (closed-form kinematics) and actual (clearance dynamics when enabled, plus disc vibration and
//! axis runout), with phase labels and index counts.
//!
//! θ2 is reported relative to the wheel's angle at t = 0 (θ2(0) = 0 for the ideal motion) and
//! accumulates over cycles; `index` counts engagements completed after t = 0.

use super::config::MechanismConfig;
use super::contact::ContactLaw;
use super::drive_speed::{CrankMotion, DriveSpeedConfig};
use super::dynamics::{
    max_stable_step_s, simulate, CrankDrive, DynamicsParams, DynamicsResult,
    MAX_PENETRATION_PIN_RADII,
};
use super::dynamics_config::{CrankModel, DynamicsConfig, GRAVITY_M_S2};
use super::effects::{axis_runout_offset_m, disc_vibration_offsets};
use super::error::MechanismError;
use super::kinematics::{Geneva, GenevaKind};
use crate::validation::Problems;
use std::f64::consts::PI;

/// Phase of one index cycle, from the crank position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Phase {
    Dwell,
    Entry,
    Drive,
    Exit,
}

impl Phase {
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Dwell => "dwell",
            Phase::Entry => "entry",
            Phase::Drive => "drive",
            Phase::Exit => "exit",
        }
    }
}

/// Motion at one instant. Angles in rad (global frame, counter-clockwise positive),
/// `centre_offset_m` is the wheel-centre displacement in metres (axis runout).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionSample {
    pub t_s: f64,
    pub theta1_rad: f64,
    pub omega1_rad_s: f64,
    pub alpha1_rad_s2: f64,
    pub theta2_rad: f64,
    pub omega2_rad_s: f64,
    pub alpha2_rad_s2: f64,
    pub jerk2_rad_s3: f64,
    pub phase: Phase,
    pub index: u32,
    pub centre_offset_m: [f64; 2],
}

/// A configured run: crank motion, geometry and (optionally) the simulated wheel dynamics.
#[derive(Debug, Clone)]
pub struct Mechanism {
    geneva: Geneva,
    entry_exit_fraction: f64,
    crank: CrankMotion,
    direction: f64,
    theta2_abs0_rad: f64,
    u0: f64,
    dynamics: Option<DynamicsResult>,
    dynamics_params: Option<DynamicsParams>,
    dyn_cfg: DynamicsConfig,
    duration_s: f64,
}

impl Mechanism {
    pub fn new(
        mech: &MechanismConfig,
        drive: &DriveSpeedConfig,
        dynamics: &DynamicsConfig,
        duration_s: f64,
    ) -> Result<Self, MechanismError> {
        if !(duration_s.is_finite() && duration_s > 0.0) {
            return Err(MechanismError::Duration(duration_s));
        }
        let mut p = Problems::new();
        mech.validate("mechanism", &mut p);
        drive.validate("drive_speed", &mut p);
        dynamics.validate("dynamics", &mut p);
        if !p.is_empty() {
            let msg: Vec<String> = p.iter().map(|x| x.to_string()).collect();
            return Err(MechanismError::InvalidConfig(msg.join("; ")));
        }
        let geneva = mech.geneva();
        let direction = drive.direction();
        let theta1_0 = mech.theta1_start_resolved_rad(direction);
        let crank = CrankMotion::new(drive, &geneva, theta1_0)?;
        let c0 = crank.state(0.0);
        let theta2_abs0_rad = geneva.wheel_angle_abs_rad(c0.theta1_rad);
        let dyn_result = if dynamics.enabled {
            let params = dynamics_params(mech, dynamics);
            let h_max = stable_step_limit_s(mech, dynamics);
            if params.step_s > h_max {
                return Err(MechanismError::InvalidConfig(format!(
                    "dynamics.step_s: must be <= {} s for this contact stiffness, \
                     damping and wheel inertia, got {}",
                    crate::validation::short(h_max),
                    crate::validation::short(params.step_s)
                )));
            }
            let w0 = geneva.wheel_state(&c0).omega2_rad_s;
            // A little beyond the end so interpolation at duration_s has both neighbours.
            let span = duration_s + 2.0 * dynamics.output_step_s;
            let result = simulate(&geneva, &params, &crank, theta2_abs0_rad, w0, span);
            let (depth, t_s) = result.deepest_penetration;
            let limit = MAX_PENETRATION_PIN_RADII * params.pin_radius_m;
            if depth > limit {
                return Err(MechanismError::WallBreakthrough {
                    t_s,
                    depth_mm: depth * 1e3,
                    limit_mm: limit * 1e3,
                });
            }
            Some((result, params))
        } else {
            None
        };
        let (dyn_result, dynamics_params) = dyn_result.unzip();
        Ok(Self {
            geneva,
            entry_exit_fraction: mech.entry_exit_fraction,
            crank,
            direction,
            theta2_abs0_rad,
            u0: direction * c0.theta1_rad,
            dynamics: dyn_result,
            dynamics_params,
            dyn_cfg: dynamics.clone(),
            duration_s,
        })
    }

    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    pub fn geneva(&self) -> Geneva {
        self.geneva
    }

    /// The simulated dynamics, when enabled.
    pub fn dynamics(&self) -> Option<&DynamicsResult> {
        self.dynamics.as_ref()
    }

    /// The SI parameters the dynamics ran with, when enabled.
    pub fn dynamics_params(&self) -> Option<&DynamicsParams> {
        self.dynamics_params.as_ref()
    }

    /// Crank progress p ∈ [0, 1] through the engagement at crank angle `theta1_rad` (0 = entry,
    /// 1 = exit), or `None` in dwell.
    pub fn engagement_progress(&self, theta1_rad: f64) -> Option<f64> {
        let p = self.crank_progress(theta1_rad);
        (0.0..=1.0).contains(&p).then_some(p)
    }

    /// [`Mechanism::engagement_progress`] continued linearly in crank angle into the dwell on
    /// either side (below 0 before entry, above 1 after exit).
    pub fn crank_progress(&self, theta1_rad: f64) -> f64 {
        let beta = self.geneva.engagement_half_angle_rad();
        let (_, phi) = Geneva::wrap_crank(self.direction * theta1_rad);
        (phi + beta) / (2.0 * beta)
    }

    /// The wheel's turning sense while indexing: +1 counter-clockwise, −1 clockwise.
    pub fn index_direction(&self) -> f64 {
        self.direction * self.geneva.kind.sign()
    }

    fn phase_and_index(&self, theta1_rad: f64) -> (Phase, u32) {
        let beta = self.geneva.engagement_half_angle_rad();
        let u = self.direction * theta1_rad;
        let (_, phi) = Geneva::wrap_crank(u);
        let phase = if phi.abs() > beta {
            Phase::Dwell
        } else {
            let p = (phi + beta) / (2.0 * beta);
            if p < self.entry_exit_fraction {
                Phase::Entry
            } else if p > 1.0 - self.entry_exit_fraction {
                Phase::Exit
            } else {
                Phase::Drive
            }
        };
        let exits = |u: f64| ((u - beta) / (2.0 * PI)).floor();
        let index = (exits(u) - exits(self.u0)).max(0.0) as u32;
        (phase, index)
    }

    /// Exact kinematic motion at `t_s`.
    pub fn ideal(&self, t_s: f64) -> MotionSample {
        let c = self.crank.state(t_s);
        let w = self.geneva.wheel_state(&c);
        let (phase, index) = self.phase_and_index(c.theta1_rad);
        MotionSample {
            t_s,
            theta1_rad: c.theta1_rad,
            omega1_rad_s: c.omega1_rad_s,
            alpha1_rad_s2: c.alpha1_rad_s2,
            theta2_rad: w.theta2_rad - self.theta2_abs0_rad,
            omega2_rad_s: w.omega2_rad_s,
            alpha2_rad_s2: w.alpha2_rad_s2,
            jerk2_rad_s3: w.jerk2_rad_s3,
            phase,
            index,
            centre_offset_m: [0.0, 0.0],
        }
    }

    /// Motion the camera sees: dynamics (if enabled, clamped to the simulated span) or the ideal
    /// motion, plus disc vibration and axis runout when enabled.
    pub fn actual(&self, t_s: f64) -> MotionSample {
        let mut s = self.ideal(t_s);
        if let Some(d) = &self.dynamics {
            if let Some([th1, w1, a1]) = d.sample_crank(t_s) {
                s.theta1_rad = th1;
                s.omega1_rad_s = w1;
                s.alpha1_rad_s2 = a1;
            }
            let [th, w, a, j] = d.sample(t_s);
            s.theta2_rad = th - self.theta2_abs0_rad;
            s.omega2_rad_s = w;
            s.alpha2_rad_s2 = a;
            s.jerk2_rad_s3 = j;
        }
        let v = disc_vibration_offsets(&self.dyn_cfg.disc_vibration, t_s);
        s.theta2_rad += v[0];
        s.omega2_rad_s += v[1];
        s.alpha2_rad_s2 += v[2];
        s.jerk2_rad_s3 += v[3];
        s.centre_offset_m = axis_runout_offset_m(&self.dyn_cfg.axis_runout, t_s, s.theta2_rad);
        s
    }

    /// True when the actual motion can differ from the ideal kinematics (dynamics, disc
    /// vibration or axis runout enabled).
    pub fn has_actual_motion(&self) -> bool {
        self.dynamics.is_some()
            || self.dyn_cfg.disc_vibration.enabled
            || self.dyn_cfg.axis_runout.enabled
    }

    /// (ideal, actual) for each time, for the truth CSV.
    pub fn truth_rows(&self, times_s: &[f64]) -> Vec<(MotionSample, MotionSample)> {
        times_s
            .iter()
            .map(|&t| (self.ideal(t), self.actual(t)))
            .collect()
    }
}

/// SI parameters of the dynamics model from the configuration.
pub fn dynamics_params(mech: &MechanismConfig, d: &DynamicsConfig) -> DynamicsParams {
    let radius_m = mech.wheel_radius_mm * 1e-3;
    let inertia = d
        .wheel_inertia_kg_m2
        .unwrap_or(0.5 * d.wheel_mass_kg * radius_m * radius_m);
    let load_n = d.wheel_mass_kg * GRAVITY_M_S2;
    let rb = d.bearing_radius_mm * 1e-3;
    DynamicsParams {
        inertia_kg_m2: inertia,
        static_torque_n_m: d.mu_static * load_n * rb,
        kinetic_torque_n_m: d.mu_kinetic * load_n * rb,
        contact: ContactLaw::new(
            d.contact_model,
            d.contact_stiffness_n_m,
            d.contact_damping_n_s_m,
            d.contact_restitution,
        ),
        half_clearance_m: 0.5 * mech.clearance_mm() * 1e-3,
        pin_radius_m: 0.5 * mech.pin_diameter_mm * 1e-3,
        crank_radius_m: mech.crank_radius_derived_mm() * 1e-3,
        crank: match d.crank.model {
            CrankModel::Prescribed => CrankDrive::Prescribed,
            CrankModel::Servo => CrankDrive::Servo {
                inertia_kg_m2: d.crank.inertia_kg_m2(),
                stiffness_n_m_rad: d.crank.stiffness_n_m_rad,
                damping_n_m_s_rad: d.crank.damping_n_m_s_rad,
            },
        },
        step_s: d.step_s,
        output_step_s: d.output_step_s,
    }
}

/// Largest stable integration step for the contact stiffness, damping and wheel inertia, s
/// (at the largest pin radius from the wheel axis, where the contact acts most stiffly).
pub fn stable_step_limit_s(mech: &MechanismConfig, d: &DynamicsConfig) -> f64 {
    let rho_max_m = match mech.kind {
        GenevaKind::Internal => mech.centre_distance_mm + mech.crank_radius_derived_mm(),
        GenevaKind::External => mech.centre_distance_mm * (PI / mech.slots as f64).cos(),
    } * 1e-3;
    max_stable_step_s(&dynamics_params(mech, d), rho_max_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn poly() -> DriveSpeedConfig {
        DriveSpeedConfig::PolynomialPerEngagement {
            end_rad_s: -1.55,
            mid_rad_s: -1.40,
        }
    }

    #[test]
    fn phases_in_order_index_counts_and_continuity() {
        for kind in [GenevaKind::Internal, GenevaKind::External] {
            for drive in [poly(), DriveSpeedConfig::Constant { omega1_rad_s: 2.0 }] {
                let mech = MechanismConfig {
                    kind,
                    slots: 5,
                    wheel_radius_mm: 60.0,
                    ..Default::default()
                };
                let m = Mechanism::new(&mech, &drive, &DynamicsConfig::default(), 20.0).unwrap();
                let s0 = m.ideal(0.0);
                assert_eq!(s0.phase, Phase::Dwell, "starts in dwell");
                assert_eq!(s0.theta2_rad, 0.0);
                let mut seq = vec![s0.phase];
                let mut prev = s0;
                let dt = 1e-3;
                for i in 1..=20_000 {
                    let s = m.ideal(i as f64 * dt);
                    assert!(
                        (s.theta2_rad - prev.theta2_rad).abs() < 3.0 * dt,
                        "θ2 jump at {}",
                        s.t_s
                    );
                    assert!((s.omega2_rad_s - prev.omega2_rad_s).abs() < 0.05, "ω2 jump");
                    if s.phase != *seq.last().unwrap() {
                        seq.push(s.phase);
                    }
                    assert!(s.index >= prev.index && s.index <= prev.index + 1);
                    // Completed indexes ↔ accumulated wheel angle.
                    if s.phase == Phase::Dwell {
                        let expect = s.index as f64 * 2.0 * PI / 5.0;
                        assert!(
                            (s.theta2_rad.abs() - expect).abs() < 1e-9,
                            "{} vs {expect}",
                            s.theta2_rad
                        );
                    }
                    prev = s;
                }
                let order = [Phase::Dwell, Phase::Entry, Phase::Drive, Phase::Exit];
                for (k, ph) in seq.iter().enumerate() {
                    assert_eq!(*ph, order[k % 4], "sequence {seq:?}");
                }
                let completed = seq.iter().skip(1).filter(|p| **p == Phase::Dwell).count();
                assert!(completed >= 4);
                assert_eq!(prev.index as usize, completed);
                // Wheel turns against an external crank, with an internal one.
                let sense = (prev.theta2_rad * prev.omega1_rad_s).signum();
                assert_eq!(sense, kind.sign());
            }
        }
    }

    #[test]
    fn actual_equals_ideal_without_effects_and_adds_them_when_enabled() {
        let mech = MechanismConfig::default();
        let m = Mechanism::new(&mech, &poly(), &DynamicsConfig::default(), 3.0).unwrap();
        for i in 0..30 {
            let t = 0.1 * i as f64;
            assert_eq!(m.ideal(t), m.actual(t));
        }
        let mut d = DynamicsConfig::default();
        d.disc_vibration.enabled = true;
        d.axis_runout.enabled = true;
        let m = Mechanism::new(&mech, &poly(), &d, 3.0).unwrap();
        let rows = m.truth_rows(&[0.0, 0.5, 1.7]);
        for (i, a) in rows {
            let off = a.centre_offset_m[0].hypot(a.centre_offset_m[1]);
            assert!((off - 5e-5).abs() < 1e-15);
            assert!((a.theta2_rad - i.theta2_rad).abs() <= 2e-4 + 1e-15);
        }
    }

    #[test]
    fn seed_run_with_dynamics_tracks_kinematics() {
        let mech = MechanismConfig::default();
        let d = DynamicsConfig {
            enabled: true,
            ..Default::default()
        };
        let m = Mechanism::new(&mech, &poly(), &d, 10.0).unwrap();
        // Peak ideal ω2 = 0.414·1.40 (seed's 0.58 rad/s plateau); actual stays near it.
        let mut peak_i: f64 = 0.0;
        let mut worst: f64 = 0.0;
        let mut worst_drive: f64 = 0.0;
        for i in 0..10_000 {
            let t = i as f64 * 1e-3;
            let (a, b) = (m.ideal(t), m.actual(t));
            peak_i = peak_i.max(a.omega2_rad_s.abs());
            let e = (a.theta2_rad - b.theta2_rad).abs();
            worst = worst.max(e);
            if a.phase == Phase::Drive {
                worst_drive = worst_drive.max(e);
            }
        }
        assert!(
            (peak_i - 1.40 * (2f64.sqrt() - 1.0)).abs() < 1e-3,
            "{peak_i}"
        );
        // In drive the pin holds the wheel within half the clearance at the smallest radius it
        // can push from (the slot mouth), plus the contact's compliance at the largest force.
        let p = m.dynamics_params().unwrap();
        let dynamics = m.dynamics().unwrap();
        let peak_force = dynamics
            .impacts
            .iter()
            .fold(0.0f64, |f, im| f.max(im.peak_force_n));
        let mouth_m = p.crank_radius_m * m.geneva().ratio_m() * (PI / 4.0).cos();
        let drive_bound = (p.half_clearance_m + peak_force / p.contact.stiffness_n_m()) / mouth_m;
        assert!(
            worst_drive > 1e-3 && worst_drive <= drive_bound,
            "{worst_drive} vs {drive_bound}"
        );
        // Elsewhere the largest departure is the over-rotation left after exit, bounded by the
        // band derived from the seed (the wheel waits there until the next pin catches it).
        let (_, over_max) = super::super::engagements::overrotation_band_rad(&m).unwrap();
        assert!(worst <= over_max.max(drive_bound), "{worst} vs {over_max}");
        eprintln!("seed dynamics: max |Δθ2| {worst:.4} rad (bound {over_max:.4}), in drive {worst_drive:.4} (bound {drive_bound:.4})");
    }

    #[test]
    fn new_rejects_bad_input_with_field_names() {
        let mech = MechanismConfig {
            slots: 2,
            ..Default::default()
        };
        let e = Mechanism::new(&mech, &poly(), &DynamicsConfig::default(), 1.0).unwrap_err();
        assert!(
            e.to_string()
                .contains("mechanism.slots: must be in [3, 36], got 2"),
            "{e}"
        );
        let e = Mechanism::new(
            &MechanismConfig::default(),
            &poly(),
            &DynamicsConfig::default(),
            0.0,
        )
        .unwrap_err();
        assert_eq!(e, MechanismError::Duration(0.0));
        let table = DriveSpeedConfig::Table {
            t_s: vec![],
            omega1_rad_s: vec![],
            file: Some("x.csv".into()),
        };
        let e = Mechanism::new(
            &MechanismConfig::default(),
            &table,
            &DynamicsConfig::default(),
            1.0,
        )
        .unwrap_err();
        assert!(e.to_string().contains("drive_speed.t_s"), "{e}");
        let stiff = DynamicsConfig {
            enabled: true,
            contact_stiffness_n_m: 1e10,
            step_s: 1e-4,
            output_step_s: 1e-4,
            ..Default::default()
        };
        let e = Mechanism::new(&MechanismConfig::default(), &poly(), &stiff, 1.0).unwrap_err();
        assert!(
            e.to_string().contains("dynamics.step_s: must be <= "),
            "{e}"
        );
    }
}
