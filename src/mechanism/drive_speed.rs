//! Crank (driving disc) speed profiles and their exact time integration: θ1(t), ω1, α1, dα1/dt.
//!
//! Direction: speeds are signed. A negative speed turns the crank clockwise (the seed's crank
//! runs at about −1.55 rad/s). All speeds of one profile must share one sign and be non-zero.
//!
//! The per-engagement polynomial makes ω1 a function of crank angle, so θ1(t) solves an ODE;
//! here t(θ1) = ∫ dθ1 / ω1(θ1) is integrated in closed form (atan / atanh) and inverted in closed
//! form, so θ1(t) is exact to rounding (tested against a fine RK4 to < 1e-9 rad).

use super::error::MechanismError;
use super::kinematics::{CrankState, Geneva};
use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// `[drive_speed]`: the crank speed profile. `kind` selects the variant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum DriveSpeedConfig {
    /// Constant crank speed.
    Constant {
        /// Crank speed ω1, rad/s, signed (negative = clockwise). Default 1.55.
        #[serde(default = "default_end")]
        omega1_rad_s: f64,
    },
    /// The seed's 2nd-order polynomial per engagement: ω1 = `end_rad_s` at both ends of each
    /// engagement, `mid_rad_s` in the middle, quadratic in crank progress p ∈ [0, 1] through the
    /// engagement (ω1 = end + 4 (mid − end) p (1 − p)); constant `end_rad_s` during dwell.
    PolynomialPerEngagement {
        /// ω1 at entry and exit and during dwell, rad/s, signed. Default 1.55.
        #[serde(default = "default_end")]
        end_rad_s: f64,
        /// ω1 at the middle of the engagement, rad/s, same sign as `end_rad_s`. Default 1.40.
        #[serde(default = "default_mid")]
        mid_rad_s: f64,
    },
    /// ω1 sampled over time, linearly interpolated, held constant before the first and after
    /// the last sample.
    Table {
        /// Sample times, s, strictly increasing. Default empty (filled from `file`).
        #[serde(default)]
        t_s: Vec<f64>,
        /// ω1 at each sample, rad/s, signed, non-zero, one sign. Default empty.
        #[serde(default)]
        omega1_rad_s: Vec<f64>,
        /// Optional CSV file (`t_s,omega1_rad_s` header) the scenario loader reads into the
        /// arrays, relative to the scenario file. Default none.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        file: Option<String>,
    },
}

fn default_end() -> f64 {
    1.55
}
fn default_mid() -> f64 {
    1.40
}

impl Default for DriveSpeedConfig {
    fn default() -> Self {
        DriveSpeedConfig::Constant {
            omega1_rad_s: default_end(),
        }
    }
}

/// Largest crank speed magnitude accepted, rad/s (a Geneva drive on camera, not a turbine).
const MAX_SPEED_RAD_S: f64 = 1000.0;

impl DriveSpeedConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        let nonzero = |p: &mut Problems, field: String, v: f64| {
            if !v.is_finite() || v == 0.0 || v.abs() > MAX_SPEED_RAD_S {
                p.push(
                    field,
                    format!(
                        "must be non-zero with |value| <= {MAX_SPEED_RAD_S}, got {}",
                        crate::validation::short(v)
                    ),
                );
            }
        };
        match self {
            DriveSpeedConfig::Constant { omega1_rad_s } => {
                nonzero(problems, join(path, "omega1_rad_s"), *omega1_rad_s)
            }
            DriveSpeedConfig::PolynomialPerEngagement {
                end_rad_s,
                mid_rad_s,
            } => {
                nonzero(problems, join(path, "end_rad_s"), *end_rad_s);
                nonzero(problems, join(path, "mid_rad_s"), *mid_rad_s);
                if end_rad_s * mid_rad_s < 0.0 {
                    problems.push(
                        join(path, "mid_rad_s"),
                        format!(
                            "must have the same sign as end_rad_s ({}), got {}",
                            crate::validation::short(*end_rad_s),
                            crate::validation::short(*mid_rad_s)
                        ),
                    );
                }
            }
            DriveSpeedConfig::Table {
                t_s,
                omega1_rad_s,
                file,
            } => {
                if t_s.is_empty() && omega1_rad_s.is_empty() && file.is_some() {
                    return; // the loader fills the arrays from the file
                }
                if t_s.is_empty() {
                    problems.push(
                        join(path, "t_s"),
                        "must hold at least one sample (or give file)",
                    );
                }
                if t_s.len() != omega1_rad_s.len() {
                    problems.push(
                        join(path, "omega1_rad_s"),
                        format!(
                            "must have the same length as t_s ({}), got {}",
                            t_s.len(),
                            omega1_rad_s.len()
                        ),
                    );
                }
                if let Some((i, &t)) = t_s.iter().enumerate().find(|(_, t)| t.abs() > 1e4) {
                    problems.range(format!("{}[{i}]", join(path, "t_s")), t, -1e4, 1e4);
                }
                for (i, w) in t_s.windows(2).enumerate() {
                    let increasing = w[1] > w[0];
                    if !increasing || !w[0].is_finite() || !w[1].is_finite() {
                        problems.push(
                            format!("{}[{}]", join(path, "t_s"), i + 1),
                            format!(
                                "must be finite and > t_s[{i}] ({}), got {}",
                                crate::validation::short(w[0]),
                                crate::validation::short(w[1])
                            ),
                        );
                        break;
                    }
                }
                for (i, &w) in omega1_rad_s.iter().enumerate() {
                    let field = format!("{}[{i}]", join(path, "omega1_rad_s"));
                    nonzero(problems, field.clone(), w);
                    if w * omega1_rad_s[0] < 0.0 {
                        problems.push(
                            field,
                            format!(
                                "must have the same sign as omega1_rad_s[0], got {}",
                                crate::validation::short(w)
                            ),
                        );
                        break;
                    }
                }
            }
        }
    }

    /// Crank turning sense: +1 (counter-clockwise) or −1.
    pub fn direction(&self) -> f64 {
        let v = match self {
            DriveSpeedConfig::Constant { omega1_rad_s } => *omega1_rad_s,
            DriveSpeedConfig::PolynomialPerEngagement { end_rad_s, .. } => *end_rad_s,
            DriveSpeedConfig::Table { omega1_rad_s, .. } => {
                omega1_rad_s.first().copied().unwrap_or(1.0)
            }
        };
        if v < 0.0 {
            -1.0
        } else {
            1.0
        }
    }
}

/// Parses a `t_s,omega1_rad_s` CSV (header required; blank lines and `#` comments skipped).
pub fn parse_drive_table_csv(text: &str) -> Result<(Vec<f64>, Vec<f64>), MechanismError> {
    let mut t = Vec::new();
    let mut w = Vec::new();
    let mut header_seen = false;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cols: Vec<&str> = line.split(',').map(str::trim).collect();
        let err = |message: String| MechanismError::DriveTable {
            line: i + 1,
            message,
        };
        if !header_seen {
            if cols != ["t_s", "omega1_rad_s"] {
                return Err(err(format!(
                    "expected header `t_s,omega1_rad_s`, got `{line}`"
                )));
            }
            header_seen = true;
            continue;
        }
        if cols.len() != 2 {
            return Err(err(format!("expected 2 columns, got {}", cols.len())));
        }
        let parse = |s: &str, name: &str| {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| err(format!("{name} `{s}` is not a finite number")))
        };
        t.push(parse(cols[0], "t_s")?);
        w.push(parse(cols[1], "omega1_rad_s")?);
    }
    if !header_seen {
        return Err(MechanismError::DriveTable {
            line: 1,
            message: "empty table".into(),
        });
    }
    Ok((t, w))
}

/// The integrated crank motion for one run.
#[derive(Debug, Clone)]
pub enum CrankMotion {
    Constant { theta0_rad: f64, omega_rad_s: f64 },
    Polynomial(PolyMotion),
    Table(TableMotion),
}

impl CrankMotion {
    /// Builds the motion from a validated profile, the drive geometry (engagement extent) and the
    /// crank angle at t = 0.
    pub fn new(
        cfg: &DriveSpeedConfig,
        geneva: &Geneva,
        theta1_start_rad: f64,
    ) -> Result<Self, MechanismError> {
        let mut p = Problems::new();
        cfg.validate("drive_speed", &mut p);
        if let DriveSpeedConfig::Table { t_s, .. } = cfg {
            if t_s.is_empty() {
                p.push("drive_speed.t_s", "table is empty (file not loaded?)");
            }
        }
        if !p.is_empty() {
            let msg: Vec<String> = p.iter().map(|x| x.to_string()).collect();
            return Err(MechanismError::InvalidConfig(msg.join("; ")));
        }
        Ok(match cfg {
            DriveSpeedConfig::Constant { omega1_rad_s } => CrankMotion::Constant {
                theta0_rad: theta1_start_rad,
                omega_rad_s: *omega1_rad_s,
            },
            DriveSpeedConfig::PolynomialPerEngagement {
                end_rad_s,
                mid_rad_s,
            } => CrankMotion::Polynomial(PolyMotion::new(
                *end_rad_s,
                *mid_rad_s,
                geneva.engagement_half_angle_rad(),
                theta1_start_rad,
            )),
            DriveSpeedConfig::Table {
                t_s, omega1_rad_s, ..
            } => CrankMotion::Table(TableMotion::new(t_s, omega1_rad_s, theta1_start_rad)),
        })
    }

    pub fn state(&self, t_s: f64) -> CrankState {
        match self {
            CrankMotion::Constant {
                theta0_rad,
                omega_rad_s,
            } => CrankState {
                theta1_rad: theta0_rad + omega_rad_s * t_s,
                omega1_rad_s: *omega_rad_s,
                alpha1_rad_s2: 0.0,
                jerk1_rad_s3: 0.0,
            },
            CrankMotion::Polynomial(p) => p.state(t_s),
            CrankMotion::Table(tb) => tb.state(t_s),
        }
    }
}

/// Position-dependent polynomial profile, integrated in closed form.
#[derive(Debug, Clone)]
pub struct PolyMotion {
    dir: f64,
    end: f64,
    mid: f64,
    beta: f64,
    engage_time_s: f64,
    rev_time_s: f64,
    /// Crank progress u = dir·θ1 at the start of the revolution containing t = 0.
    u_ref: f64,
    /// Time from that revolution start to t = 0.
    tau0_s: f64,
}

impl PolyMotion {
    fn new(end_rad_s: f64, mid_rad_s: f64, beta: f64, theta1_start_rad: f64) -> Self {
        let dir = if end_rad_s < 0.0 { -1.0 } else { 1.0 };
        let mut pm = PolyMotion {
            dir,
            end: end_rad_s.abs(),
            mid: mid_rad_s.abs(),
            beta,
            engage_time_s: 0.0,
            rev_time_s: 0.0,
            u_ref: 0.0,
            tau0_s: 0.0,
        };
        pm.engage_time_s = 2.0 * beta * (pm.integral(1.0) - pm.integral(-1.0));
        pm.rev_time_s = pm.engage_time_s + (2.0 * PI - 2.0 * beta) / pm.end;
        let u0 = dir * theta1_start_rad;
        let v0 = crate::numeric::angle::wrap_tau(u0 + beta);
        pm.u_ref = u0 - v0;
        pm.tau0_s = pm.time_in_rev(v0);
        pm
    }

    /// I(x) = ½ ∫ dx / (M − Δ x²), x = 2p − 1 ∈ [−1, 1], Δ = mid − end.
    fn integral(&self, x: f64) -> f64 {
        let m = self.mid;
        let delta = self.mid - self.end;
        if delta == 0.0 {
            return x / (2.0 * m);
        }
        let c = (delta.abs() / m).sqrt();
        if delta < 0.0 {
            (x * c).atan() / (2.0 * m * c)
        } else {
            (x * c).atanh() / (2.0 * m * c)
        }
    }

    fn integral_inv(&self, y: f64) -> f64 {
        let m = self.mid;
        let delta = self.mid - self.end;
        if delta == 0.0 {
            return 2.0 * m * y;
        }
        let c = (delta.abs() / m).sqrt();
        if delta < 0.0 {
            (2.0 * m * c * y).tan() / c
        } else {
            (2.0 * m * c * y).tanh() / c
        }
    }

    /// Time from the revolution start (engagement entry) to progress v ∈ [0, 2π).
    fn time_in_rev(&self, v: f64) -> f64 {
        if v <= 2.0 * self.beta {
            let x = v / self.beta - 1.0;
            2.0 * self.beta * (self.integral(x) - self.integral(-1.0))
        } else {
            self.engage_time_s + (v - 2.0 * self.beta) / self.end
        }
    }

    fn progress_at(&self, tau: f64) -> f64 {
        if tau < self.engage_time_s {
            let y = tau / (2.0 * self.beta) + self.integral(-1.0);
            let x = self.integral_inv(y).clamp(-1.0, 1.0);
            (x + 1.0) * self.beta
        } else {
            2.0 * self.beta + (tau - self.engage_time_s) * self.end
        }
    }

    fn state(&self, t_s: f64) -> CrankState {
        let tau = self.tau0_s + t_s;
        let k = (tau / self.rev_time_s).floor();
        let r = tau - k * self.rev_time_s;
        let v = self.progress_at(r);
        let u = self.u_ref + 2.0 * PI * k + v;
        let d = self.dir;
        if v <= 2.0 * self.beta {
            let p = v / (2.0 * self.beta);
            let delta = self.mid - self.end;
            let w = self.end + 4.0 * delta * p * (1.0 - p);
            let dw = 4.0 * delta * (1.0 - 2.0 * p);
            let ddw = -8.0 * delta;
            let pdot = w / (2.0 * self.beta);
            CrankState {
                theta1_rad: d * u,
                omega1_rad_s: d * w,
                alpha1_rad_s2: d * dw * pdot,
                jerk1_rad_s3: d * (ddw * w + dw * dw) * pdot / (2.0 * self.beta),
            }
        } else {
            CrankState {
                theta1_rad: d * u,
                omega1_rad_s: d * self.end,
                alpha1_rad_s2: 0.0,
                jerk1_rad_s3: 0.0,
            }
        }
    }
}

/// Time-tabulated profile: piecewise-linear ω1, integrated exactly (piecewise quadratic θ1).
#[derive(Debug, Clone)]
pub struct TableMotion {
    t_s: Vec<f64>,
    w: Vec<f64>,
    /// ∫ ω1 dt from t_s[0] to t_s[i].
    cum: Vec<f64>,
    theta0_rad: f64,
    /// Φ(0), so that θ1(0) = theta0.
    phi0: f64,
}

impl TableMotion {
    fn new(t_s: &[f64], w: &[f64], theta0_rad: f64) -> Self {
        let mut cum = vec![0.0; t_s.len()];
        for i in 1..t_s.len() {
            cum[i] = cum[i - 1] + 0.5 * (w[i] + w[i - 1]) * (t_s[i] - t_s[i - 1]);
        }
        let mut tm = TableMotion {
            t_s: t_s.to_vec(),
            w: w.to_vec(),
            cum,
            theta0_rad,
            phi0: 0.0,
        };
        tm.phi0 = tm.phi(0.0).0;
        tm
    }

    /// (∫ from t_s[0] to t of ω1, ω1(t), α1(t)).
    fn phi(&self, t: f64) -> (f64, f64, f64) {
        let n = self.t_s.len();
        if t <= self.t_s[0] {
            return (self.w[0] * (t - self.t_s[0]), self.w[0], 0.0);
        }
        if t >= self.t_s[n - 1] {
            return (
                self.cum[n - 1] + self.w[n - 1] * (t - self.t_s[n - 1]),
                self.w[n - 1],
                0.0,
            );
        }
        // partition_point: first knot > t, so t lies in [t_s[i], t_s[i+1]).
        let i = self.t_s.partition_point(|&x| x <= t) - 1;
        let dt = t - self.t_s[i];
        let slope = (self.w[i + 1] - self.w[i]) / (self.t_s[i + 1] - self.t_s[i]);
        (
            self.cum[i] + self.w[i] * dt + 0.5 * slope * dt * dt,
            self.w[i] + slope * dt,
            slope,
        )
    }

    fn state(&self, t_s: f64) -> CrankState {
        let (phi, w, a) = self.phi(t_s);
        CrankState {
            theta1_rad: self.theta0_rad + phi - self.phi0,
            omega1_rad_s: w,
            alpha1_rad_s2: a,
            jerk1_rad_s3: 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::kinematics::GenevaKind;

    /// ω1 as a function of crank angle, written independently from the definition.
    fn poly_omega_of_theta(theta: f64, end: f64, mid: f64, beta: f64) -> f64 {
        let dir = end.signum();
        let u = dir * theta;
        let phi = u - 2.0 * PI * (u / (2.0 * PI)).round();
        if phi.abs() > beta {
            return end;
        }
        let p = (phi + beta) / (2.0 * beta);
        end + 4.0 * (mid - end) * p * (1.0 - p)
    }

    fn rk4_reference(end: f64, mid: f64, beta: f64, th0: f64, t_end: f64, h: f64) -> Vec<f64> {
        // Returns θ1 at every whole 0.5 s.
        let f = |th: f64| poly_omega_of_theta(th, end, mid, beta);
        let mut th = th0;
        let steps = (t_end / h).round() as usize;
        let every = (0.5 / h).round() as usize;
        let mut out = vec![th];
        for i in 0..steps {
            let k1 = f(th);
            let k2 = f(th + 0.5 * h * k1);
            let k3 = f(th + 0.5 * h * k2);
            let k4 = f(th + h * k3);
            th += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            if (i + 1) % every == 0 {
                out.push(th);
            }
        }
        out
    }

    #[test]
    fn polynomial_theta1_matches_fine_rk4_to_1e9() {
        let gv = Geneva::new(GenevaKind::Internal, 4);
        let beta = gv.engagement_half_angle_rad();
        for (end, mid, th0) in [(1.55, 1.40, -2.6), (-1.55, -1.40, 0.3), (1.2, 1.6, 1.0)] {
            let cfg = DriveSpeedConfig::PolynomialPerEngagement {
                end_rad_s: end,
                mid_rad_s: mid,
            };
            let cm = CrankMotion::new(&cfg, &gv, th0).unwrap();
            let reference = rk4_reference(end, mid, beta, th0, 10.0, 2e-5);
            let mut worst: f64 = 0.0;
            for (i, r) in reference.iter().enumerate() {
                let s = cm.state(0.5 * i as f64);
                worst = worst.max((s.theta1_rad - r).abs());
                let w = poly_omega_of_theta(s.theta1_rad, end, mid, beta);
                assert!((s.omega1_rad_s - w).abs() < 1e-12);
            }
            assert!(worst < 1e-9, "θ1 error {worst} rad for end {end} mid {mid}");
        }
    }

    #[test]
    fn polynomial_alpha_and_jerk_are_time_derivatives() {
        let gv = Geneva::new(GenevaKind::External, 6);
        let cfg = DriveSpeedConfig::PolynomialPerEngagement {
            end_rad_s: -1.55,
            mid_rad_s: -1.40,
        };
        let cm = CrankMotion::new(&cfg, &gv, 0.1).unwrap();
        let h = 1e-5;
        let mut checked = 0;
        for i in 0..200 {
            let t = 0.013 + 0.05 * i as f64;
            let (a, b, c) = (cm.state(t - h), cm.state(t), cm.state(t + h));
            // Skip samples straddling an engagement boundary (α1 jumps there).
            if (a.jerk1_rad_s3 == 0.0) != (c.jerk1_rad_s3 == 0.0) {
                continue;
            }
            let dw = (c.omega1_rad_s - a.omega1_rad_s) / (2.0 * h);
            let da = (c.alpha1_rad_s2 - a.alpha1_rad_s2) / (2.0 * h);
            let dth = (c.theta1_rad - a.theta1_rad) / (2.0 * h);
            assert!((dth - b.omega1_rad_s).abs() < 1e-8);
            assert!(
                (dw - b.alpha1_rad_s2).abs() < 1e-6,
                "α1 {} vs {dw}",
                b.alpha1_rad_s2
            );
            assert!(
                (da - b.jerk1_rad_s3).abs() < 1e-5,
                "j1 {} vs {da}",
                b.jerk1_rad_s3
            );
            checked += 1;
        }
        assert!(checked > 150);
    }

    #[test]
    fn table_integrates_piecewise_linear_speed() {
        let gv = Geneva::new(GenevaKind::Internal, 4);
        let cfg = DriveSpeedConfig::Table {
            t_s: vec![-1.0, 1.0, 3.0],
            omega1_rad_s: vec![1.0, 2.0, 2.0],
            file: None,
        };
        let cm = CrankMotion::new(&cfg, &gv, 0.5).unwrap();
        assert!((cm.state(0.0).theta1_rad - 0.5).abs() < 1e-15);
        // ∫0^1 (1.5 + 0.5 t) dt = 1.75; then 2 rad/s until 3 s and held after.
        assert!((cm.state(1.0).theta1_rad - 2.25).abs() < 1e-12);
        assert!((cm.state(4.0).theta1_rad - (2.25 + 6.0)).abs() < 1e-12);
        assert!((cm.state(0.0).alpha1_rad_s2 - 0.5).abs() < 1e-12);
    }

    #[test]
    fn csv_table_parses_and_reports_lines() {
        let (t, w) = parse_drive_table_csv("t_s,omega1_rad_s\n0,1.5\n# c\n\n0.1, 1.6\n").unwrap();
        assert_eq!(t, vec![0.0, 0.1]);
        assert_eq!(w, vec![1.5, 1.6]);
        let e = parse_drive_table_csv("time,w\n0,1\n").unwrap_err();
        assert!(e.to_string().contains("line 1") && e.to_string().contains("header"));
        let e = parse_drive_table_csv("t_s,omega1_rad_s\n0,1\n0.1,x\n").unwrap_err();
        assert_eq!(
            e,
            MechanismError::DriveTable {
                line: 3,
                message: "omega1_rad_s `x` is not a finite number".into()
            }
        );
    }

    #[test]
    fn validation_messages() {
        let mut p = Problems::new();
        DriveSpeedConfig::Constant { omega1_rad_s: 0.0 }.validate("drive_speed", &mut p);
        DriveSpeedConfig::PolynomialPerEngagement {
            end_rad_s: 1.5,
            mid_rad_s: -1.4,
        }
        .validate("drive_speed", &mut p);
        DriveSpeedConfig::Table {
            t_s: vec![0.0, 0.0],
            omega1_rad_s: vec![1.0],
            file: None,
        }
        .validate("drive_speed", &mut p);
        let m: Vec<String> = p.iter().map(|x| x.to_string()).collect();
        assert_eq!(
            m[0],
            "drive_speed.omega1_rad_s: must be non-zero with |value| <= 1000, got 0"
        );
        assert_eq!(
            m[1],
            "drive_speed.mid_rad_s: must have the same sign as end_rad_s (1.5), got -1.4"
        );
        assert!(m[2].starts_with("drive_speed.omega1_rad_s: must have the same length as t_s (2)"));
        assert!(m[3].starts_with("drive_speed.t_s[1]: must be finite and > t_s[0]"));
        assert_eq!(m.len(), 4);
    }

    #[test]
    fn toml_round_trip_and_defaults() {
        let c: DriveSpeedConfig =
            toml::from_str("kind = \"polynomial_per_engagement\"\nend_rad_s = -1.55").unwrap();
        assert_eq!(
            c,
            DriveSpeedConfig::PolynomialPerEngagement {
                end_rad_s: -1.55,
                mid_rad_s: 1.40
            }
        );
        assert!(toml::from_str::<DriveSpeedConfig>("kind = \"constant\"\nbogus = 1").is_err());
        let s = toml::to_string(&DriveSpeedConfig::default()).unwrap();
        assert_eq!(
            toml::from_str::<DriveSpeedConfig>(&s).unwrap(),
            DriveSpeedConfig::default()
        );
    }
}
