//! Wheel dynamics with pin–slot clearance: the crank motion is prescribed; the wheel is a rigid
//! disc on a bearing with Coulomb friction (Karnopp stick/slip) and is pushed by a penalty
//! contact (spring + damper, compressive only) between the pin and the two walls of the slot it
//! is in, active while the pin overlaps the slot radially (near the mouth the pin touches the
//! wall's corner, modelled as a sharp edge against the round pin). Outside engagement the wheel is free
//! (no locking disc), so it may coast past the index and be hit at the next entry.
//!
//! Integration: semi-implicit (symplectic) Euler at a fixed step (default 1e-5 s), first order in
//! the step; a zero crossing of ω2 is captured at exactly 0 so Karnopp's stick band is never
//! skipped. Results are stored on a coarser output grid for interpolation.

use super::drive_speed::CrankMotion;
use super::kinematics::{Geneva, GenevaKind};
use std::f64::consts::PI;

/// Karnopp zero-velocity band, rad/s.
const STICK_BAND_RAD_S: f64 = 1e-6;

/// Physical parameters in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DynamicsParams {
    pub inertia_kg_m2: f64,
    pub static_torque_n_m: f64,
    pub kinetic_torque_n_m: f64,
    pub stiffness_n_m: f64,
    pub damping_n_s_m: f64,
    /// Half the clearance (slot width − pin diameter) / 2, m.
    pub half_clearance_m: f64,
    /// Pin radius, m (rounds the contact with the slot-mouth corners).
    pub pin_radius_m: f64,
    pub crank_radius_m: f64,
    pub step_s: f64,
    /// Output grid spacing, s (a whole number of steps).
    pub output_step_s: f64,
}

/// Wheel motion on the output grid (absolute wheel angle, same convention as
/// [`Geneva::wheel_angle_abs_rad`]), plus the contact-side changes at full rate.
#[derive(Debug, Clone, PartialEq)]
pub struct DynamicsResult {
    pub output_step_s: f64,
    pub theta2_rad: Vec<f64>,
    pub omega2_rad_s: Vec<f64>,
    pub alpha2_rad_s2: Vec<f64>,
    /// (t_s, side): side +1 / −1 = pin touching the slot wall on the wheel's ± side, 0 = free.
    pub contact_changes: Vec<(f64, i8)>,
}

/// Largest step for which the semi-implicit Euler contact oscillation stays well resolved
/// (ω_n·h ≤ 0.2 and damping rate·h ≤ 0.2 at the largest pin radius `rho_max_m`).
pub fn max_stable_step_s(p: &DynamicsParams, rho_max_m: f64) -> f64 {
    let k_rot = p.stiffness_n_m * rho_max_m * rho_max_m / p.inertia_kg_m2;
    let c_rot = p.damping_n_s_m * rho_max_m * rho_max_m / p.inertia_kg_m2;
    (0.2 / k_rot.sqrt()).min(if c_rot > 0.0 {
        0.2 / c_rot
    } else {
        f64::INFINITY
    })
}

/// Contact torque on the wheel, N·m, and the touching side.
pub fn contact_torque(
    geneva: &Geneva,
    p: &DynamicsParams,
    theta1_rad: f64,
    omega1_rad_s: f64,
    theta2_abs_rad: f64,
    omega2_rad_s: f64,
) -> (f64, i8) {
    let r = p.crank_radius_m;
    let [x, y, dx, dy] = geneva.pin_position_per_r(theta1_rad);
    let (px, py) = (r * x, r * y);
    let (vx, vy) = (r * dx * omega1_rad_s, r * dy * omega1_rad_s);
    let rho = px.hypot(py);
    let mouth = r * geneva.ratio_m() * (PI / geneva.slots as f64).cos();
    // Depth of the pin centre past the slot mouth; the pin overlaps the slot from −pin radius.
    let depth = match geneva.kind {
        GenevaKind::Internal => rho - mouth,
        GenevaKind::External => mouth - rho,
    };
    let rp = p.pin_radius_m;
    if depth <= -rp {
        return (0.0, 0);
    }
    // Before its centre passes the mouth the pin can only touch the wall's corner, which lets
    // it sit further out sideways: the force builds up as the pin slides in instead of
    // switching on with a finite penetration.
    let corner_allowance = if depth < 0.0 {
        rp - (rp * rp - depth * depth).sqrt()
    } else {
        0.0
    };
    let pitch = geneva.index_angle_rad();
    let j = ((py.atan2(px) - theta2_abs_rad) / pitch).round();
    let (sn, cs) = (theta2_abs_rad + j * pitch).sin_cos();
    let d = -px * sn + py * cs; // offset of the pin centre from the slot centreline
    let along = px * cs + py * sn;
    let d_dot = -vx * sn + vy * cs - omega2_rad_s * along;
    let side = if d >= 0.0 { 1.0 } else { -1.0 };
    let pen = d.abs() - p.half_clearance_m - corner_allowance;
    if pen <= 0.0 {
        return (0.0, 0);
    }
    let force = (p.stiffness_n_m * pen + p.damping_n_s_m * side * d_dot).max(0.0);
    (side * force * along, side as i8)
}

/// One semi-implicit step of the wheel speed under applied torque `tau` with Karnopp friction.
/// Returns (new ω2, acceleration over the step).
pub fn friction_step(p: &DynamicsParams, omega_rad_s: f64, tau_n_m: f64) -> (f64, f64) {
    let h = p.step_s;
    let j = p.inertia_kg_m2;
    let a = if omega_rad_s.abs() <= STICK_BAND_RAD_S {
        if tau_n_m.abs() <= p.static_torque_n_m {
            return (0.0, -omega_rad_s / h);
        }
        (tau_n_m - p.static_torque_n_m * tau_n_m.signum()) / j
    } else {
        (tau_n_m - p.kinetic_torque_n_m * omega_rad_s.signum()) / j
    };
    let w = omega_rad_s + a * h;
    if w * omega_rad_s < 0.0 {
        // Landing exactly on zero lets the next step decide stick or breakaway.
        return (0.0, -omega_rad_s / h);
    }
    (w, a)
}

/// Integrates the wheel from (θ2 abs, ω2) at t = 0 to `duration_s`.
pub fn simulate(
    geneva: &Geneva,
    p: &DynamicsParams,
    crank: &CrankMotion,
    theta2_abs0_rad: f64,
    omega2_0_rad_s: f64,
    duration_s: f64,
) -> DynamicsResult {
    let h = p.step_s;
    let every = ((p.output_step_s / h).round() as usize).max(1);
    let n_out = (duration_s / (every as f64 * h)).ceil() as usize + 1;
    let mut res = DynamicsResult {
        output_step_s: every as f64 * h,
        theta2_rad: Vec::with_capacity(n_out),
        omega2_rad_s: Vec::with_capacity(n_out),
        alpha2_rad_s2: Vec::with_capacity(n_out),
        contact_changes: Vec::new(),
    };
    let (mut th, mut w) = (theta2_abs0_rad, omega2_0_rad_s);
    let mut last_side = 0i8;
    let total = (n_out - 1) * every;
    for i in 0..=total {
        let t = i as f64 * h;
        let c = crank.state(t);
        let (tau, side) = contact_torque(geneva, p, c.theta1_rad, c.omega1_rad_s, th, w);
        if side != last_side {
            res.contact_changes.push((t, side));
            last_side = side;
        }
        let (w_new, a) = friction_step(p, w, tau);
        if i % every == 0 {
            res.theta2_rad.push(th);
            res.omega2_rad_s.push(w);
            res.alpha2_rad_s2.push(a);
        }
        w = w_new;
        th += h * w;
    }
    res
}

impl DynamicsResult {
    /// (θ2, ω2, α2, jerk2) at `t_s` (clamped to the simulated span): cubic Hermite on θ2 (slopes
    /// ω2) and ω2 (slopes α2), linear α2, jerk as the α2 grid slope.
    pub fn sample(&self, t_s: f64) -> [f64; 4] {
        let n = self.theta2_rad.len();
        let dt = self.output_step_s;
        if n < 2 {
            return [
                self.theta2_rad[0],
                self.omega2_rad_s[0],
                self.alpha2_rad_s2[0],
                0.0,
            ];
        }
        let x = (t_s / dt).clamp(0.0, (n - 1) as f64);
        let k = (x.floor() as usize).min(n - 2);
        let s = x - k as f64;
        let herm = |y0: f64, y1: f64, d0: f64, d1: f64| {
            let (s2, s3) = (s * s, s * s * s);
            (2.0 * s3 - 3.0 * s2 + 1.0) * y0
                + (s3 - 2.0 * s2 + s) * dt * d0
                + (-2.0 * s3 + 3.0 * s2) * y1
                + (s3 - s2) * dt * d1
        };
        let (th, w, a) = (&self.theta2_rad, &self.omega2_rad_s, &self.alpha2_rad_s2);
        [
            herm(th[k], th[k + 1], w[k], w[k + 1]),
            herm(w[k], w[k + 1], a[k], a[k + 1]),
            a[k] + s * (a[k + 1] - a[k]),
            (a[k + 1] - a[k]) / dt,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::drive_speed::DriveSpeedConfig;

    fn seed_params(half_clearance_m: f64, stiffness: f64, step_s: f64) -> DynamicsParams {
        let (m, g, rb) = (0.348, 9.81, 0.004);
        DynamicsParams {
            inertia_kg_m2: 0.5 * m * 0.17 * 0.17,
            static_torque_n_m: 0.194 * m * g * rb,
            kinetic_torque_n_m: 0.089 * m * g * rb,
            stiffness_n_m: stiffness,
            damping_n_s_m: 50.0,
            half_clearance_m,
            pin_radius_m: 4.75e-3,
            crank_radius_m: 0.025 * (PI / 4.0).sin(),
            step_s,
            output_step_s: 1e-4,
        }
    }

    #[test]
    fn free_wheel_decelerates_at_tk_over_j_then_sticks() {
        let p = seed_params(0.0, 1e6, 1e-5);
        let decel = p.kinetic_torque_n_m / p.inertia_kg_m2;
        let mut w = 0.05;
        let mut steps = 0;
        while w > 0.0 {
            let (wn, a) = friction_step(&p, w, 0.0);
            if wn > 0.0 {
                assert!((a + decel).abs() < 1e-12 * decel, "a {a} vs −{decel}");
            }
            w = wn;
            steps += 1;
        }
        let expected = (0.05 / decel / p.step_s).ceil() as i64;
        assert!(
            (steps as i64 - expected).abs() <= 1,
            "stopped after {steps}, expected {expected}"
        );
        // Sticks under any torque below the static level, breaks away above it.
        assert_eq!(
            friction_step(&p, 0.0, 0.99 * p.static_torque_n_m),
            (0.0, 0.0)
        );
        let (wn, a) = friction_step(&p, 0.0, 2.0 * p.static_torque_n_m);
        assert!(wn > 0.0 && (a - p.static_torque_n_m / p.inertia_kg_m2).abs() < 1e-9);
    }

    fn engaged_error(half_clearance_m: f64, stiffness: f64, step_s: f64) -> (f64, DynamicsResult) {
        let gv = Geneva::new(GenevaKind::Internal, 4);
        let p = seed_params(half_clearance_m, stiffness, step_s);
        let cfg = DriveSpeedConfig::Constant { omega1_rad_s: 1.55 };
        let th0 = -gv.engagement_half_angle_rad() - 0.3;
        let crank = CrankMotion::new(&cfg, &gv, th0).unwrap();
        let dur = 4.2;
        let res = simulate(&gv, &p, &crank, gv.wheel_angle_abs_rad(th0), 0.0, dur);
        let mut worst: f64 = 0.0;
        for (k, th) in res.theta2_rad.iter().enumerate() {
            let c = crank.state(k as f64 * res.output_step_s);
            worst = worst.max((th - gv.wheel_angle_abs_rad(c.theta1_rad)).abs());
        }
        (worst, res)
    }

    #[test]
    fn converges_to_kinematics_as_clearance_vanishes() {
        let mut prev = f64::INFINITY;
        let mut errs = Vec::new();
        for half in [0.25e-3, 0.05e-3, 0.01e-3, 0.0] {
            let (e, _) = engaged_error(half, 1e8, 1e-5);
            errs.push(e);
            assert!(e < prev, "error did not shrink: {errs:?}");
            prev = e;
        }
        // With no clearance only the contact compliance remains (torque/(k ρ²) ≈ 1e-5 rad).
        assert!(errs[3] < 1e-4, "{errs:?}");
        assert!(
            errs[0] > 5e-3,
            "0.25 mm half clearance should show: {errs:?}"
        );
    }

    #[test]
    fn step_size_convergence() {
        let (_, r1) = engaged_error(0.25e-3, 1e6, 2e-5);
        let (_, r2) = engaged_error(0.25e-3, 1e6, 1e-5);
        let (_, r_ref) = engaged_error(0.25e-3, 1e6, 2.5e-6);
        let dist = |a: &DynamicsResult, b: &DynamicsResult| {
            a.theta2_rad
                .iter()
                .zip(&b.theta2_rad)
                .take(20_000) // first 2 s: one entry with impacts
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        };
        let (e1, e2) = (dist(&r1, &r_ref), dist(&r2, &r_ref));
        assert!(
            e2 < e1,
            "halving the step must reduce the error: {e1} -> {e2}"
        );
        assert!(e2 < 1e-3, "{e2}");
    }

    #[test]
    fn clearance_makes_the_pin_bounce_at_entry() {
        let (_, res) = engaged_error(0.25e-3, 1e6, 1e-5);
        let sides: Vec<i8> = res
            .contact_changes
            .iter()
            .filter(|c| c.1 != 0)
            .map(|c| c.1)
            .collect();
        let flips = sides.windows(2).filter(|w| w[0] != w[1]).count();
        assert!(sides.len() > 3, "contacts {:?}", res.contact_changes);
        assert!(flips >= 1, "no wall-to-wall bounce: {sides:?}");
        let peak = res.alpha2_rad_s2.iter().fold(0.0f64, |m, a| m.max(a.abs()));
        // Ideal peak |α2| for this drive is 1.0·ω1² ≈ 2.4 rad/s²; impacts are far larger.
        assert!(peak > 10.0, "peak α2 {peak}");
    }
}
