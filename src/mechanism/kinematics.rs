//! Closed-form Geneva kinematics: driven-wheel angle, speed, acceleration and jerk as pure
//! functions of the crank state, for internal and external drives with any slot count n ≥ 3.
//!
//! Conventions (all angles in one global, counter-clockwise-positive frame, wheel centre O2 at
//! the origin, crank centre O1 at (L, 0)):
//! - θ1 is the crank angle measured from the line of centres; θ1 = 0 puts the pin deepest in the
//!   slot. The pin sits at `(L + s·r·cos θ1, s·r·sin θ1)` with s = +1 (internal) or −1 (external).
//! - m = L / r = 1 / sin(π/n). Inside an engagement the pin's polar angle about O2 is
//!   σ·atan(sin θ1 / (m + s·cos θ1)) with σ = s: the external wheel turns opposite to the crank,
//!   the internal wheel the same way as the crank.
//! - Engagement half-angle β: external π/2 − π/n, internal π/2 + π/n; each engagement advances
//!   the wheel by exactly 2π/n.
//!
//! With D = 1 + m² + 2·s·m·cos θ1 and g(θ1) = atan(sin θ1 / (m + s cos θ1)):
//! g' = (s + m cos θ1) / D, g'' = m (1 − m²) sin θ1 / D², g''' = m (1 − m²)(cos θ1·D + 4 s m sin² θ1) / D³,
//! which generalise the seed's eqs (2.6)–(2.8) (internal, n = 4, a = m).

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Internal (crank inside the wheel, slots open inwards) or external Geneva drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GenevaKind {
    External,
    Internal,
}

impl GenevaKind {
    /// s in the module docs: +1 internal, −1 external. Also the wheel's turning sense relative
    /// to the crank.
    pub fn sign(self) -> f64 {
        match self {
            GenevaKind::Internal => 1.0,
            GenevaKind::External => -1.0,
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            GenevaKind::Internal => "internal",
            GenevaKind::External => "external",
        }
    }
}

/// Crank state at one instant: angle, speed, acceleration and jerk (dα1/dt).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CrankState {
    pub theta1_rad: f64,
    pub omega1_rad_s: f64,
    pub alpha1_rad_s2: f64,
    pub jerk1_rad_s3: f64,
}

/// Driven-wheel state derived from the crank state.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WheelState {
    pub theta2_rad: f64,
    pub omega2_rad_s: f64,
    pub alpha2_rad_s2: f64,
    pub jerk2_rad_s3: f64,
}

/// A Geneva drive's kinematic identity: kind and slot count (n ≥ 3, checked by validation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Geneva {
    pub kind: GenevaKind,
    pub slots: u32,
}

impl Geneva {
    pub fn new(kind: GenevaKind, slots: u32) -> Self {
        Self { kind, slots }
    }

    /// m = L / r = 1 / sin(π/n).
    pub fn ratio_m(&self) -> f64 {
        1.0 / (PI / self.slots as f64).sin()
    }

    /// Wheel advance per engagement, 2π/n.
    pub fn index_angle_rad(&self) -> f64 {
        2.0 * PI / self.slots as f64
    }

    /// β: the pin is in a slot for |θ1| ≤ β (θ1 wrapped to (−π, π]).
    pub fn engagement_half_angle_rad(&self) -> f64 {
        let h = PI / self.slots as f64;
        match self.kind {
            GenevaKind::External => PI / 2.0 - h,
            GenevaKind::Internal => PI / 2.0 + h,
        }
    }

    fn d(&self, theta1_rad: f64) -> f64 {
        let m = self.ratio_m();
        1.0 + m * m + 2.0 * self.kind.sign() * m * theta1_rad.cos()
    }

    /// g(θ1), the unsigned pin angle about O2 (valid inside the engagement).
    fn g(&self, theta1_rad: f64) -> f64 {
        let s = self.kind.sign();
        theta1_rad
            .sin()
            .atan2(self.ratio_m() + s * theta1_rad.cos())
    }

    /// dg/dθ1 = (s + m cos θ1) / D.
    pub fn g1(&self, theta1_rad: f64) -> f64 {
        let s = self.kind.sign();
        (s + self.ratio_m() * theta1_rad.cos()) / self.d(theta1_rad)
    }

    /// d²g/dθ1² = m (1 − m²) sin θ1 / D².
    pub fn g2(&self, theta1_rad: f64) -> f64 {
        let m = self.ratio_m();
        let d = self.d(theta1_rad);
        m * (1.0 - m * m) * theta1_rad.sin() / (d * d)
    }

    /// d³g/dθ1³ = m (1 − m²)(cos θ1·D + 4 s m sin² θ1) / D³.
    pub fn g3(&self, theta1_rad: f64) -> f64 {
        let m = self.ratio_m();
        let s = self.kind.sign();
        let d = self.d(theta1_rad);
        let (sn, c) = theta1_rad.sin_cos();
        m * (1.0 - m * m) * (c * d + 4.0 * s * m * sn * sn) / (d * d * d)
    }

    /// θ2 inside an engagement, signed (external opposite to the crank); 0 at θ1 = 0.
    pub fn theta2_rad(&self, theta1_rad: f64) -> f64 {
        self.kind.sign() * self.g(theta1_rad)
    }

    /// ω2 = σ g' ω1.
    pub fn omega2_rad_s(&self, theta1_rad: f64, omega1_rad_s: f64) -> f64 {
        self.kind.sign() * self.g1(theta1_rad) * omega1_rad_s
    }

    /// α2 = σ (g' α1 + g'' ω1²).
    pub fn alpha2_rad_s2(&self, theta1_rad: f64, omega1_rad_s: f64, alpha1_rad_s2: f64) -> f64 {
        self.kind.sign()
            * (self.g1(theta1_rad) * alpha1_rad_s2
                + self.g2(theta1_rad) * omega1_rad_s * omega1_rad_s)
    }

    /// jerk2 = σ (g' j1 + 3 g'' ω1 α1 + g''' ω1³).
    pub fn jerk2_rad_s3(
        &self,
        theta1_rad: f64,
        omega1_rad_s: f64,
        alpha1_rad_s2: f64,
        jerk1_rad_s3: f64,
    ) -> f64 {
        let w = omega1_rad_s;
        self.kind.sign()
            * (self.g1(theta1_rad) * jerk1_rad_s3
                + 3.0 * self.g2(theta1_rad) * w * alpha1_rad_s2
                + self.g3(theta1_rad) * w * w * w)
    }

    /// Splits an unwrapped crank angle into (revolution q, wrapped φ ∈ [−π, π)).
    pub fn wrap_crank(theta1_rad: f64) -> (f64, f64) {
        let q = (theta1_rad / (2.0 * PI)).round();
        (q, theta1_rad - 2.0 * PI * q)
    }

    /// True when the pin is in a slot.
    pub fn is_engaged(&self, theta1_rad: f64) -> bool {
        Self::wrap_crank(theta1_rad).1.abs() <= self.engagement_half_angle_rad()
    }

    /// Absolute wheel angle for an unwrapped crank angle, continuous over any number of cycles:
    /// σ (q·2π/n + h(φ)), h = g inside the engagement and ±π/n in dwell. 0 at θ1 = 0.
    pub fn wheel_angle_abs_rad(&self, theta1_rad: f64) -> f64 {
        let (q, phi) = Self::wrap_crank(theta1_rad);
        let beta = self.engagement_half_angle_rad();
        let half = PI / self.slots as f64;
        let h = if phi > beta {
            half
        } else if phi < -beta {
            -half
        } else {
            self.g(phi)
        };
        self.kind.sign() * (q * self.index_angle_rad() + h)
    }

    /// Full wheel state for a crank state; derivatives vanish in dwell.
    pub fn wheel_state(&self, crank: &CrankState) -> WheelState {
        let th = crank.theta1_rad;
        let theta2_rad = self.wheel_angle_abs_rad(th);
        if !self.is_engaged(th) {
            return WheelState {
                theta2_rad,
                ..Default::default()
            };
        }
        WheelState {
            theta2_rad,
            omega2_rad_s: self.omega2_rad_s(th, crank.omega1_rad_s),
            alpha2_rad_s2: self.alpha2_rad_s2(th, crank.omega1_rad_s, crank.alpha1_rad_s2),
            jerk2_rad_s3: self.jerk2_rad_s3(
                th,
                crank.omega1_rad_s,
                crank.alpha1_rad_s2,
                crank.jerk1_rad_s3,
            ),
        }
    }

    /// Pin centre position relative to O2 in units of the crank radius r, and its
    /// derivative with respect to θ1: `(x, y, dx/dθ1, dy/dθ1)`.
    pub fn pin_position_per_r(&self, theta1_rad: f64) -> [f64; 4] {
        let s = self.kind.sign();
        let (sn, c) = theta1_rad.sin_cos();
        [self.ratio_m() + s * c, s * sn, -s * sn, s * c]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proptest_utils::geneva_kind;
    use proptest::prelude::*;

    /// Crank angle along a cubic in time around t = 0 (so α1 and j1 are non-zero).
    fn crank_at(c: &CrankState, t: f64) -> f64 {
        c.theta1_rad
            + c.omega1_rad_s * t
            + c.alpha1_rad_s2 * t * t / 2.0
            + c.jerk1_rad_s3 * t * t * t / 6.0
    }

    fn num_deriv(f: impl Fn(f64) -> f64, h: f64) -> f64 {
        // Fourth-order central difference.
        (-f(2.0 * h) + 8.0 * f(h) - 8.0 * f(-h) + f(-2.0 * h)) / (12.0 * h)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn derivatives_match_numerical_differentiation(
            kind in geneva_kind(),
            n in 3u32..=12,
            frac in -0.95f64..0.95,
            w1 in prop_oneof![-2.0f64..-0.5, 0.5f64..2.0],
            a1 in -1.0f64..1.0,
            j1 in -1.0f64..1.0,
        ) {
            let gv = Geneva::new(kind, n);
            let c = CrankState {
                theta1_rad: frac * gv.engagement_half_angle_rad(),
                omega1_rad_s: w1,
                alpha1_rad_s2: a1,
                jerk1_rad_s3: j1,
            };
            let cs = |t: f64| CrankState {
                theta1_rad: crank_at(&c, t),
                omega1_rad_s: w1 + a1 * t + j1 * t * t / 2.0,
                alpha1_rad_s2: a1 + j1 * t,
                jerk1_rad_s3: j1,
            };
            let h = 1e-4;
            let w2 = gv.wheel_state(&c);
            let num_w = num_deriv(|t| gv.theta2_rad(cs(t).theta1_rad), h);
            let num_a = num_deriv(|t| { let s = cs(t); gv.omega2_rad_s(s.theta1_rad, s.omega1_rad_s) }, h);
            let num_j = num_deriv(|t| { let s = cs(t); gv.alpha2_rad_s2(s.theta1_rad, s.omega1_rad_s, s.alpha1_rad_s2) }, h);
            let scale = 1.0 + w2.jerk2_rad_s3.abs();
            prop_assert!((num_w - w2.omega2_rad_s).abs() < 1e-8 * (1.0 + w2.omega2_rad_s.abs()), "ω2 {} vs {}", w2.omega2_rad_s, num_w);
            prop_assert!((num_a - w2.alpha2_rad_s2).abs() < 1e-7 * (1.0 + w2.alpha2_rad_s2.abs()), "α2 {} vs {}", w2.alpha2_rad_s2, num_a);
            prop_assert!((num_j - w2.jerk2_rad_s3).abs() < 1e-6 * scale, "jerk2 {} vs {}", w2.jerk2_rad_s3, num_j);
            // The wheel-angle function agrees with the in-engagement closed form.
            prop_assert!((gv.wheel_angle_abs_rad(c.theta1_rad) - gv.theta2_rad(c.theta1_rad)).abs() < 1e-12);
        }

        #[test]
        fn engagement_advances_by_index_and_is_continuous(
            kind in geneva_kind(),
            n in 3u32..=12,
            rev in -3i32..3,
        ) {
            let gv = Geneva::new(kind, n);
            let beta = gv.engagement_half_angle_rad();
            let base = rev as f64 * 2.0 * PI;
            let adv = gv.theta2_rad(beta) - gv.theta2_rad(-beta);
            prop_assert!((adv.abs() - 2.0 * PI / n as f64).abs() < 1e-12);
            prop_assert!(adv * kind.sign() > 0.0, "turning sense");
            let eps = 1e-9;
            for edge in [-beta, beta] {
                let th = base + edge;
                let a = gv.wheel_angle_abs_rad(th - eps);
                let b = gv.wheel_angle_abs_rad(th + eps);
                prop_assert!((a - b).abs() < 1e-8, "θ2 jump {} at {}", a - b, th);
                // ω2 vanishes at the boundaries: continuity with the dwell.
                prop_assert!(gv.omega2_rad_s(edge, 1.0).abs() < 1e-12);
            }
            // Continuity at φ = ±π (revolution wrap), and one index per crank revolution.
            let a = gv.wheel_angle_abs_rad(base + PI - eps);
            let b = gv.wheel_angle_abs_rad(base + PI + eps);
            prop_assert!((a - b).abs() < 1e-8);
            let full = gv.wheel_angle_abs_rad(base + 2.0 * PI) - gv.wheel_angle_abs_rad(base);
            prop_assert!((full - kind.sign() * 2.0 * PI / n as f64).abs() < 1e-12);
        }
    }

    fn peaks(gv: &Geneva) -> (f64, f64) {
        let beta = gv.engagement_half_angle_rad();
        let mut pw: f64 = 0.0;
        let mut pa: f64 = 0.0;
        let steps = 200_000;
        for i in 0..=steps {
            let th = -beta + 2.0 * beta * i as f64 / steps as f64;
            pw = pw.max(gv.omega2_rad_s(th, 1.0).abs());
            pa = pa.max(gv.alpha2_rad_s2(th, 1.0, 0.0).abs());
        }
        (pw, pa)
    }

    #[test]
    fn known_peak_values_n4() {
        let (w, a) = peaks(&Geneva::new(GenevaKind::External, 4));
        assert!((w - 2.414).abs() < 1e-3, "external peak ω2/ω1 {w}");
        assert!((a - 5.407).abs() < 1e-3, "external peak α2/ω1² {a}");
        let (w, a) = peaks(&Geneva::new(GenevaKind::Internal, 4));
        assert!((w - 0.414).abs() < 1e-3, "internal peak ω2/ω1 {w}");
        assert!((a - 1.000).abs() < 1e-3, "internal peak α2/ω1² {a}");
    }

    #[test]
    fn seed_equations_2_6_to_2_8_internal_n4() {
        let gv = Geneva::new(GenevaKind::Internal, 4);
        let a = 1.0 / (45f64.to_radians()).sin();
        for i in 0..=100 {
            let th = (-135.0 + 2.7 * i as f64).to_radians();
            let (w1, a1) = (1.55, -0.3);
            let eq26 = (th.sin() / (1.0 / (45f64.to_radians()).sin() + th.cos())).atan();
            let den = 1.0 + a * a + 2.0 * a * th.cos();
            let eq27 = (a * th.cos() + 1.0) / den * w1;
            let eq28 = (a * th.cos() + 1.0) / den * a1
                + a * th.sin() * (1.0 - a * a) / (den * den) * w1 * w1;
            assert!((gv.theta2_rad(th) - eq26).abs() < 1e-12);
            assert!((gv.omega2_rad_s(th, w1) - eq27).abs() < 1e-12);
            assert!((gv.alpha2_rad_s2(th, w1, a1) - eq28).abs() < 1e-12);
        }
        // Seed: engagement is θ1 ∈ [−135°, 135°].
        assert!((gv.engagement_half_angle_rad() - 135f64.to_radians()).abs() < 1e-12);
    }

    #[test]
    fn pin_polar_angle_is_the_slot_angle() {
        for kind in [GenevaKind::External, GenevaKind::Internal] {
            let gv = Geneva::new(kind, 5);
            let beta = gv.engagement_half_angle_rad();
            for i in 0..=20 {
                let th = -beta + 2.0 * beta * i as f64 / 20.0;
                let p = gv.pin_position_per_r(th);
                assert!((p[1].atan2(p[0]) - gv.theta2_rad(th)).abs() < 1e-12);
            }
            // At the boundary the pin is at the slot mouth radius L cos(π/n) = r·m·cos(π/n).
            let p = gv.pin_position_per_r(beta);
            let rho = p[0].hypot(p[1]);
            assert!((rho - gv.ratio_m() * (PI / 5.0).cos()).abs() < 1e-12);
        }
    }
}
