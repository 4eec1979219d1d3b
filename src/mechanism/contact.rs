//! Pin–slot contact laws: the normal force as a function of penetration δ and penetration rate
//! δ̇ (both in metres, m/s), compressive only.
//!
//! - `Penalty` (the model before restitution was introduced): F = k·δ + c·δ̇, a linear spring
//!   and dashpot. Its restitution is not a parameter: on the seed rig (k = 1e6 N/m,
//!   c = 50 N·s/m, wheel inertia reflected to the pin 2.8–16 kg) an impact rebounds with about
//!   0.95, which keeps the wheel rattling between the slot walls.
//! - `HuntCrossley`: F = k·δ·(1 + χ·δ̇) with χ = λ(e) / v₀, v₀ the approach speed when the
//!   contact began (Hunt & Crossley, ASME J. Appl. Mech. 42 (1975) 440–445). The damping is tied
//!   to the coefficient of restitution e the way Lankarani & Nikravesh (ASME J. Mech. Des. 112
//!   (1990) 369–376) and Flores, Machado, Silva & Martins (Multibody Syst. Dyn. 25 (2011)
//!   357–375) tie it, but instead of their closed forms (derived for Hertz' exponent 3/2 and,
//!   for Lankarani–Nikravesh, e near 1) λ is solved numerically for the linear line-contact
//!   spring used here, so one impact of any speed and effective mass rebounds with exactly e.
//!   The force is continuous at touch (δ = 0) and never sticks (it is clamped at 0 when the
//!   surfaces separate faster than 1/χ).
//!
//! Restitution of 3D-printed PLA on PLA: no measurement of this low-speed contact was found;
//! the closest, pendulum impacts of 1–3 J on 3D-printed PLA plates (Desu, "Experimental
//! characterization of 3D printed thermoplastic plates subjected to low velocity impact",
//! Ryerson University, 2019), absorbed 32.8–54.9 % of the energy without breaking, a
//! hard-striker restitution of 0.67–0.82. The seed rig's default (0.35, within the 0.3–0.6
//! usually assumed for printed PLA) is calibrated on the seed's observations
//! ([`super::engagements::seed_checks`], `reports/dynamics/`).
//!
//! Why λ(e) is universal: with x = δ/ℓ, τ = t·ω₀ (ω₀² = k/m, ℓ = v₀/ω₀) one impact obeys
//! x'' = −x·max(0, 1 + λ·x'), x(0) = 0, x'(0) = 1, so its restitution depends on λ = χ·v₀ alone.

use serde::{Deserialize, Serialize};

/// Which contact law `[dynamics]` uses (`dynamics.contact_model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ContactModel {
    /// Linear spring + dashpot (`contact_stiffness_n_m`, `contact_damping_n_s_m`).
    Penalty,
    /// Hunt–Crossley damping tied to `contact_restitution`.
    #[default]
    HuntCrossley,
}

impl ContactModel {
    pub fn as_str(self) -> &'static str {
        match self {
            ContactModel::Penalty => "penalty",
            ContactModel::HuntCrossley => "hunt_crossley",
        }
    }
}

/// A contact law with its SI parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactLaw {
    Penalty {
        stiffness_n_m: f64,
        damping_n_s_m: f64,
    },
    HuntCrossley {
        stiffness_n_m: f64,
        /// e, in (0, 1].
        restitution: f64,
        /// λ = χ·v₀ that gives restitution e (0 for e = 1).
        lambda: f64,
    },
}

/// Smallest approach speed χ is computed from, m/s: a touch slower than this (a wall creeping
/// onto the pin) is damped as if it came at this speed, so χ stays finite. The damping is
/// integrated implicitly in the wheel's speed, so a large χ stays stable; it only makes such
/// creeping touches more elastic than `e`.
pub const MIN_APPROACH_SPEED_M_S: f64 = 1e-6;

/// Normal force and its derivative with respect to δ̇ at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactForce {
    /// Elastic part k·δ, N.
    pub spring_n: f64,
    /// Damping part, N (the total spring + damping is ≥ 0).
    pub damping_n: f64,
    /// ∂F/∂δ̇, N·s/m (0 when the force is clamped at zero or the damping is explicit).
    pub d_force_d_rate: f64,
}

impl ContactForce {
    pub fn total_n(&self) -> f64 {
        self.spring_n + self.damping_n
    }
}

impl ContactLaw {
    /// Builds the law; Hunt–Crossley solves λ(e) once.
    pub fn new(
        model: ContactModel,
        stiffness_n_m: f64,
        damping_n_s_m: f64,
        restitution: f64,
    ) -> Self {
        match model {
            ContactModel::Penalty => ContactLaw::Penalty {
                stiffness_n_m,
                damping_n_s_m,
            },
            ContactModel::HuntCrossley => ContactLaw::HuntCrossley {
                stiffness_n_m,
                restitution,
                lambda: hunt_crossley_lambda(restitution),
            },
        }
    }

    pub fn stiffness_n_m(&self) -> f64 {
        match *self {
            ContactLaw::Penalty { stiffness_n_m, .. }
            | ContactLaw::HuntCrossley { stiffness_n_m, .. } => stiffness_n_m,
        }
    }

    /// Force at penetration `delta_m` > 0 and rate `rate_m_s` (> 0 closing), for a contact
    /// that began with approach speed `approach_m_s`. The penalty law damps `legacy_rate_m_s`
    /// (the rate it always used, without the slot-mouth corner term).
    pub fn force(
        &self,
        delta_m: f64,
        rate_m_s: f64,
        legacy_rate_m_s: f64,
        approach_m_s: f64,
    ) -> ContactForce {
        match *self {
            ContactLaw::Penalty {
                stiffness_n_m,
                damping_n_s_m,
            } => {
                let spring = stiffness_n_m * delta_m;
                let total = (spring + damping_n_s_m * legacy_rate_m_s).max(0.0);
                ContactForce {
                    spring_n: spring,
                    damping_n: total - spring,
                    d_force_d_rate: 0.0,
                }
            }
            ContactLaw::HuntCrossley {
                stiffness_n_m,
                lambda,
                ..
            } => {
                let spring = stiffness_n_m * delta_m;
                let chi = lambda / approach_m_s.max(MIN_APPROACH_SPEED_M_S);
                let factor = 1.0 + chi * rate_m_s;
                if factor <= 0.0 {
                    ContactForce {
                        spring_n: spring,
                        damping_n: -spring,
                        d_force_d_rate: 0.0,
                    }
                } else {
                    ContactForce {
                        spring_n: spring,
                        damping_n: spring * chi * rate_m_s,
                        d_force_d_rate: spring * chi,
                    }
                }
            }
        }
    }
}

/// Dimensionless impact x'' = −x·max(0, 1 + λx'), x(0) = 0, x'(0) = 1, integrated with RK4;
/// returns the rebound speed (the restitution for this λ).
pub fn hunt_crossley_restitution(lambda: f64) -> f64 {
    let accel = |x: f64, v: f64| -x * (1.0 + lambda * v).max(0.0);
    let rk4 = |x: f64, v: f64, h: f64| {
        let (k1x, k1v) = (v, accel(x, v));
        let (k2x, k2v) = (
            v + 0.5 * h * k1v,
            accel(x + 0.5 * h * k1x, v + 0.5 * h * k1v),
        );
        let (k3x, k3v) = (
            v + 0.5 * h * k2v,
            accel(x + 0.5 * h * k2x, v + 0.5 * h * k2v),
        );
        let (k4x, k4v) = (v + h * k3v, accel(x + h * k3x, v + h * k3v));
        (
            x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
            v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v),
        )
    };
    // RK4's error at this step is far below 1e-6 in e (tested against a much finer step).
    let h = 4e-3 / (1.0 + lambda).sqrt();
    let (mut x, mut v) = rk4(0.0, 1.0, h);
    // Strong damping leaves a slow, weakly sprung return; 1e7 steps cover e ≥ 1e-3.
    for _ in 0..10_000_000 {
        if v < 0.0 && 1.0 + lambda * v <= 0.0 {
            // Clamped: no force from here on, the surfaces part at this speed.
            return -v;
        }
        let (xn, vn) = rk4(x, v, h);
        if xn <= 0.0 {
            // Last partial step to the crossing (linear estimate of its time: v hardly changes
            // there because the force vanishes with x).
            return -rk4(x, v, h * x / (x - xn)).1;
        }
        (x, v) = (xn, vn);
    }
    0.0
}

/// λ(e): the Hunt–Crossley damping χ·v₀ whose impacts rebound with restitution `e` in (0, 1],
/// by bisection on the monotone [`hunt_crossley_restitution`].
pub fn hunt_crossley_lambda(e: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    let target = e.max(1e-6);
    let mut lo = 0.0;
    let mut hi = 1.0;
    while hunt_crossley_restitution(hi) > target && hi < 1e12 {
        lo = hi;
        hi *= 4.0;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if hunt_crossley_restitution(mid) > target {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-9 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undamped_impact_is_elastic_and_restitution_falls_with_damping() {
        let e1 = hunt_crossley_restitution(0.0);
        assert!((e1 - 1.0).abs() < 1e-9, "{e1}");
        // The integration step is fine enough: a contact with 1000 times the steps agrees.
        let fine = |lambda: f64| {
            let accel = |x: f64, v: f64| -x * (1.0 + lambda * v).max(0.0);
            let h = 4e-6;
            let (mut x, mut v) = (0.0f64, 1.0f64);
            loop {
                let a = accel(x, v);
                let (xh, vh) = (x + 0.5 * h * v, v + 0.5 * h * a);
                let (xn, vn) = (x + h * vh, v + h * accel(xh, vh));
                if xn <= 0.0 && x > 0.0 {
                    return -(v + x / (x - xn) * (vn - v));
                }
                (x, v) = (xn, vn);
            }
        };
        for lambda in [0.3, 2.0] {
            let (a, b) = (hunt_crossley_restitution(lambda), fine(lambda));
            assert!((a - b).abs() < 1e-6, "λ {lambda}: {a} vs {b}");
        }
        let mut prev = 1.0;
        for lambda in [0.1, 0.3, 1.0, 3.0, 10.0, 100.0] {
            let e = hunt_crossley_restitution(lambda);
            assert!(e < prev && e > 0.0, "e({lambda}) = {e} after {prev}");
            prev = e;
        }
    }

    #[test]
    fn lambda_inverts_restitution() {
        for e in [0.01, 0.1, 0.3, 0.45, 0.6, 0.9, 0.99] {
            let lambda = hunt_crossley_lambda(e);
            let back = hunt_crossley_restitution(lambda);
            assert!((back - e).abs() < 1e-6, "e {e}: λ {lambda} gives {back}");
        }
        assert_eq!(hunt_crossley_lambda(1.0), 0.0);
        // Near e = 1 the damping barely changes the undamped path x = sin τ, so the dissipated
        // fraction is 1 − e² = 2·λ·∫₀^π sin τ cos² τ dτ = (4/3)·λ.
        let l = hunt_crossley_lambda(0.99);
        let first_order = 0.75 * (1.0 - 0.99f64 * 0.99);
        assert!((l / first_order - 1.0).abs() < 0.02, "{l} vs {first_order}");
    }

    #[test]
    fn force_is_continuous_at_touch_and_compressive() {
        let law = ContactLaw::new(ContactModel::HuntCrossley, 1e6, 0.0, 0.5);
        let f = law.force(0.0, 1e-3, 0.0, 1e-3);
        assert_eq!(f.total_n(), 0.0);
        let f = law.force(1e-6, -1.0, 0.0, 1e-3);
        assert_eq!(f.total_n(), 0.0, "separating fast: clamped, never tensile");
        assert_eq!(f.d_force_d_rate, 0.0);
        let f = law.force(1e-6, 1e-3, 0.0, 1e-3);
        assert!(f.total_n() > 1.0 && f.d_force_d_rate > 0.0);
        let pen = ContactLaw::new(ContactModel::Penalty, 1e6, 50.0, 0.5);
        assert_eq!(pen.force(1e-6, 9.0, -1.0, 0.0).total_n(), 0.0);
        assert_eq!(pen.force(1e-6, 9.0, 0.01, 0.0).total_n(), 1.5);
    }
}
