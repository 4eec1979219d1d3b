//! Wheel dynamics with pin–slot clearance: the crank motion is prescribed; the wheel is a rigid
//! disc on a bearing with Coulomb friction (Karnopp stick/slip) and is pushed by a compressive
//! contact between the pin and the two walls of the slot it is in ([`ContactLaw`]: Hunt–Crossley
//! damping tied to a coefficient of restitution, or the older linear penalty), active while the
//! pin overlaps the slot radially (near the mouth the pin touches the wall's corner, modelled as
//! a sharp edge against the round pin). Outside engagement the wheel is free (no locking disc),
//! so it may coast past the index and be hit at the next entry.
//!
//! Integration: semi-implicit (symplectic) Euler at a fixed step (default 1e-5 s), first order in
//! the step; the Hunt–Crossley damping is linearly implicit in ω2 (its coefficient grows without
//! bound for slow touches, which an explicit step could not damp stably); a zero crossing of ω2
//! is captured at exactly 0 so Karnopp's stick band is never skipped. Results are stored on a
//! coarser output grid for interpolation, with every impact and an energy ledger at full rate.
//!
//! The crank is prescribed (the drive-speed profile, on the seed rig the seed's measurement of
//! the crank) or, with [`CrankDrive::Servo`], a body of finite inertia held to that profile by a
//! spring and damper, which the contact forces push through the pin's lever about the crank
//! axis; every [`Impact`] records the torque and impulse it put on the crank.

use super::contact::{ContactForce, ContactLaw};
use super::drive_speed::CrankMotion;
use super::kinematics::{Geneva, GenevaKind};
use std::f64::consts::PI;

/// Karnopp zero-velocity band, rad/s.
const STICK_BAND_RAD_S: f64 = 1e-6;

/// Deepest penetration, in pin radii, the contact model is taken to hold: a pin this far into
/// a wall (over a millimetre on the seed rig, forces of kilonewtons) has gone through it.
pub const MAX_PENETRATION_PIN_RADII: f64 = 0.25;

/// Physical parameters in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DynamicsParams {
    pub inertia_kg_m2: f64,
    pub static_torque_n_m: f64,
    pub kinetic_torque_n_m: f64,
    pub contact: ContactLaw,
    /// Half the clearance (slot width − pin diameter) / 2, m.
    pub half_clearance_m: f64,
    /// Pin radius, m (rounds the contact with the slot-mouth corners).
    pub pin_radius_m: f64,
    pub crank_radius_m: f64,
    /// How the crank moves: exactly as prescribed, or held to the prescribed motion by a servo.
    pub crank: CrankDrive,
    pub step_s: f64,
    /// Output grid spacing, s (a whole number of steps).
    pub output_step_s: f64,
}

/// The crank's motion: the drive-speed profile exactly (the wheel's load cannot change it), or
/// a crank of finite inertia held to that profile by a servo (torsional spring + damper to the
/// prescribed angle and speed), which the contact forces can push off it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CrankDrive {
    Prescribed,
    Servo {
        /// Crank-side inertia about the crank axis: disc + pin + the motor rotor and gears
        /// reflected through the gear ratio, kg·m².
        inertia_kg_m2: f64,
        /// Position-loop stiffness, N·m/rad.
        stiffness_n_m_rad: f64,
        /// Speed damping (the motor's torque–speed slope plus loop damping), N·m·s/rad.
        damping_n_m_s_rad: f64,
    },
}

/// One contact episode between the pin and a slot wall, from touch to separation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// Time of touch, s.
    pub t_s: f64,
    /// Time the contact ended (or the end of the simulation), s.
    pub end_s: f64,
    /// Wall touched: +1 / −1 = the wheel's ± side (the sign of the torque the wall receives).
    pub side: i8,
    /// Normal approach speed at touch, m/s.
    pub approach_m_s: f64,
    /// The same as a wheel speed: approach speed over the contact's lever about the wheel
    /// axis, rad/s.
    pub approach_rad_s: f64,
    /// Change of ω2 over the impact proper (touch until the normal rate has rebounded to its
    /// first minimum, or separation), rad/s.
    pub jump_omega2_rad_s: f64,
    /// Largest normal force of the episode, N.
    pub peak_force_n: f64,
    /// Largest torque the episode put on the crank (force times the pin's lever about the
    /// crank axis), N·m.
    pub peak_crank_torque_n_m: f64,
    /// Impulse of the contact on the crank over the impact proper, N·m·s.
    pub crank_impulse_n_m_s: f64,
}

/// Energy bookkeeping of one simulation, J. The wheel's kinetic energy, the friction loss and the
/// work of the contacts on the wheel balance exactly by construction; the only energy the
/// scheme can create or destroy is in the contact element, so [`EnergyLedger::residual_j`]
/// is the energy the discrete contacts injected.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EnergyLedger {
    /// Kinetic energy (wheel, and a servo-driven crank) + contact elastic energy at the start, J.
    pub initial_j: f64,
    /// The same at the end, J.
    pub final_j: f64,
    /// Work the drive put in, J (net): the prescribed crank's work on the contacts, or the
    /// servo torque's work on a servo-driven crank.
    pub input_work_j: f64,
    /// Energy dissipated by bearing friction, J (≥ 0).
    pub friction_loss_j: f64,
    /// Energy dissipated by contact damping, J.
    pub damping_loss_j: f64,
    /// Largest wheel kinetic energy seen, J.
    pub peak_kinetic_j: f64,
}

impl EnergyLedger {
    /// Energy created by the integration (> 0) or lost (< 0): final − initial − work in + losses.
    pub fn residual_j(&self) -> f64 {
        self.final_j - self.initial_j - self.input_work_j
            + self.friction_loss_j
            + self.damping_loss_j
    }
}

/// Wheel motion on the output grid (absolute wheel angle, same convention as
/// [`Geneva::wheel_angle_abs_rad`]), plus the contact-side changes, the impacts and the energy
/// ledger at full rate.
#[derive(Debug, Clone, PartialEq)]
pub struct DynamicsResult {
    pub output_step_s: f64,
    pub theta2_rad: Vec<f64>,
    pub omega2_rad_s: Vec<f64>,
    pub alpha2_rad_s2: Vec<f64>,
    /// Crank angle and speed on the output grid when a servo drives the crank (empty when the
    /// crank is prescribed).
    pub theta1_rad: Vec<f64>,
    pub omega1_rad_s: Vec<f64>,
    /// (t_s, side): side +1 / −1 = pin touching the slot wall on the wheel's ± side, 0 = free.
    pub contact_changes: Vec<(f64, i8)>,
    pub impacts: Vec<Impact>,
    pub energy: EnergyLedger,
    /// Deepest penetration of the pin into a wall and when, (m, s).
    pub deepest_penetration: (f64, f64),
}

/// Largest step for which the semi-implicit Euler contact oscillation stays well resolved
/// (ω_n·h ≤ 0.2, and for the explicit penalty damping rate·h ≤ 0.2) at the largest pin radius
/// `rho_max_m`. The Hunt–Crossley damping is implicit and sets no limit.
pub fn max_stable_step_s(p: &DynamicsParams, rho_max_m: f64) -> f64 {
    let k_rot = p.contact.stiffness_n_m() * rho_max_m * rho_max_m / p.inertia_kg_m2;
    let c_rot = match p.contact {
        ContactLaw::Penalty { damping_n_s_m, .. } => {
            damping_n_s_m * rho_max_m * rho_max_m / p.inertia_kg_m2
        }
        ContactLaw::HuntCrossley { .. } => 0.0,
    };
    let mut h = (0.2 / k_rot.sqrt()).min(if c_rot > 0.0 {
        0.2 / c_rot
    } else {
        f64::INFINITY
    });
    if let CrankDrive::Servo {
        inertia_kg_m2,
        stiffness_n_m_rad,
        ..
    } = p.crank
    {
        // The pin's lever about the crank axis is at most the crank radius; the contact and
        // the servo spring act on the crank in series with its inertia. (The servo damping is
        // implicit.)
        let r = p.crank_radius_m;
        let k1 = p.contact.stiffness_n_m() * r * r + stiffness_n_m_rad;
        h = h.min(0.2 / (k1 / inertia_kg_m2).sqrt());
        if let ContactLaw::Penalty { damping_n_s_m, .. } = p.contact {
            h = h.min(0.2 * inertia_kg_m2 / (damping_n_s_m * r * r).max(1e-300));
        }
    }
    h
}

/// Where the pin touches a slot wall at one instant: penetration and its rate split into the
/// part the crank drives and the part proportional to ω2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactGeometry {
    /// +1 / −1: which wall.
    pub side: i8,
    /// Penetration δ, m (> 0).
    pub delta_m: f64,
    /// δ̇ = `rate_crank_m_s` + `rate_per_omega2_m` · ω2.
    pub rate_crank_m_s: f64,
    pub rate_per_omega2_m: f64,
    /// Part of `rate_crank_m_s` due to the pin sliding past the slot-mouth corner, m/s (the
    /// penalty law does not damp it).
    pub corner_rate_m_s: f64,
    /// Torque on the crank per newton of contact force, m (signed, about the crank axis).
    pub crank_lever_m: f64,
}

impl ContactGeometry {
    pub fn rate_m_s(&self, omega2_rad_s: f64) -> f64 {
        self.rate_crank_m_s + self.rate_per_omega2_m * omega2_rad_s
    }

    /// The rate the penalty law damps: lateral only, without the corner term.
    pub fn legacy_rate_m_s(&self, omega2_rad_s: f64) -> f64 {
        self.rate_m_s(omega2_rad_s) + self.corner_rate_m_s
    }

    /// Torque on the wheel for a normal force `force_n`: τ = −F·∂δ̇/∂ω2.
    pub fn wheel_torque_n_m(&self, force_n: f64) -> f64 {
        -force_n * self.rate_per_omega2_m
    }
}

/// The pin–wall contact at (θ1, ω1, θ2 abs), or `None` when the pin touches no wall.
pub fn contact_geometry(
    geneva: &Geneva,
    p: &DynamicsParams,
    theta1_rad: f64,
    omega1_rad_s: f64,
    theta2_abs_rad: f64,
) -> Option<ContactGeometry> {
    let r = p.crank_radius_m;
    let [x, y, dx, dy] = geneva.pin_position_per_r(theta1_rad);
    let (px, py) = (r * x, r * y);
    let (vx, vy) = (r * dx * omega1_rad_s, r * dy * omega1_rad_s);
    let rho = px.hypot(py);
    let mouth = r * geneva.ratio_m() * (PI / geneva.slots as f64).cos();
    // Depth of the pin centre past the slot mouth; the pin overlaps the slot from −pin radius.
    let (depth, depth_rate) = match geneva.kind {
        GenevaKind::Internal => (rho - mouth, (px * vx + py * vy) / rho),
        GenevaKind::External => (mouth - rho, -(px * vx + py * vy) / rho),
    };
    let rp = p.pin_radius_m;
    if depth <= -rp {
        return None;
    }
    let pitch = geneva.index_angle_rad();
    let j = ((py.atan2(px) - theta2_abs_rad) / pitch).round();
    let (sn, cs) = (theta2_abs_rad + j * pitch).sin_cos();
    let d = -px * sn + py * cs; // offset of the pin centre from the slot centreline
    let along = px * cs + py * sn;
    let lateral = -vx * sn + vy * cs; // pin's lateral speed in the slot, crank part
    let side = if d >= 0.0 { 1.0 } else { -1.0 };
    if matches!(p.contact, ContactLaw::Penalty { .. }) {
        return legacy_wall_contact(
            p,
            depth,
            depth_rate,
            d,
            along,
            lateral,
            side,
            [dx, dy],
            [sn, cs],
        );
    }
    // Past the mouth the pin touches the flat wall (normal across the slot); before it, only
    // the wall's corner, a sharp edge against the round pin, pushing along the line from the
    // edge to the pin centre. `n` is that push on the pin in (along the slot, across) axes.
    let radial_off = along - mouth;
    let inside = match geneva.kind {
        GenevaKind::Internal => radial_off >= 0.0,
        GenevaKind::External => radial_off <= 0.0,
    };
    let (pen, nr, nl) = if inside {
        (d.abs() - p.half_clearance_m, 0.0, -side)
    } else {
        let gl = d - side * (p.half_clearance_m + rp);
        let dist = radial_off.hypot(gl);
        if dist <= 0.0 {
            return None;
        }
        (rp - dist, radial_off / dist, gl / dist)
    };
    if pen <= 0.0 {
        return None;
    }
    // Pin-centre velocity relative to the wheel, in the slot axes: the crank part plus ω2 × r.
    let va = vx * cs + vy * sn; // along-slot, crank part (the ω2 part is +ω2·d)
    Some(ContactGeometry {
        side: side as i8,
        delta_m: pen,
        rate_crank_m_s: -(nr * va + nl * lateral),
        rate_per_omega2_m: nl * along - nr * d,
        corner_rate_m_s: 0.0,
        crank_lever_m: r * (nr * (dx * cs + dy * sn) + nl * (-dx * sn + dy * cs)),
    })
}

/// The contact geometry of the penalty model (kept as it was): a lateral force across the slot
/// at all depths, with a corner allowance that lets the pin sit further out sideways before
/// its centre passes the mouth.
#[allow(clippy::too_many_arguments)]
fn legacy_wall_contact(
    p: &DynamicsParams,
    depth: f64,
    depth_rate: f64,
    d: f64,
    along: f64,
    lateral: f64,
    side: f64,
    [dx, dy]: [f64; 2],
    [sn, cs]: [f64; 2],
) -> Option<ContactGeometry> {
    let rp = p.pin_radius_m;
    let (corner_allowance, corner_rate) = if depth < 0.0 {
        let root = (rp * rp - depth * depth).sqrt();
        // d(allowance)/d(depth) = depth / root, bounded where the corner is grazed tangentially.
        (rp - root, depth / root.max(1e-3 * rp) * depth_rate)
    } else {
        (0.0, 0.0)
    };
    let pen = d.abs() - p.half_clearance_m - corner_allowance;
    if pen <= 0.0 {
        return None;
    }
    // The force pushes the wall outward along ±(−sin, cos); on the pin it acts the other way,
    // and its torque about the crank axis is the force times ∂(pin)/∂θ1 along that direction.
    let r = p.crank_radius_m;
    Some(ContactGeometry {
        side: side as i8,
        delta_m: pen,
        rate_crank_m_s: side * lateral - corner_rate,
        rate_per_omega2_m: -side * along,
        corner_rate_m_s: corner_rate,
        crank_lever_m: -side * r * (-dx * sn + dy * cs),
    })
}

/// One semi-implicit step of the wheel speed under applied torque `tau` with Karnopp friction,
/// with effective inertia `inertia_kg_m2` (the wheel's plus h·∂(damping torque)/∂ω2 for the
/// implicit contact damping). Returns (new ω2, acceleration over the step).
pub fn friction_step(
    p: &DynamicsParams,
    inertia_kg_m2: f64,
    omega_rad_s: f64,
    tau_n_m: f64,
) -> (f64, f64) {
    let h = p.step_s;
    let j = inertia_kg_m2;
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

/// A contact episode in progress.
#[derive(Debug, Clone, Copy)]
struct Episode {
    impact: Impact,
    omega_at_touch: f64,
    prev_rate: f64,
    rebounding: bool,
    impact_open: bool,
}

impl Episode {
    fn close_impact(&mut self, omega2: f64) {
        if self.impact_open {
            self.impact.jump_omega2_rad_s = omega2 - self.omega_at_touch;
            self.impact_open = false;
        }
    }
}

/// A servo-driven crank's step: the crank and the wheel solved together with the contact
/// damping implicit (a rank-one coupling through δ̇ = b·ω1 + a·ω2, Sherman–Morrison) and the
/// servo damping implicit; Karnopp friction on the wheel as in [`friction_step`].
struct ServoStep {
    /// Inertias J1 + h·c_servo and J2.
    m1: f64,
    m2: f64,
    /// h·∂F/∂δ̇ and ∂δ̇/∂(ω1, ω2).
    hc: f64,
    b: f64,
    a: f64,
    /// Explicit torques over the step on the crank (servo + contact) and the wheel (contact).
    tau1: f64,
    tau2: f64,
}

impl ServoStep {
    /// Δω1 with the wheel's change fixed at `dw2`.
    fn crank_alone(&self, h: f64, dw2: f64) -> f64 {
        (h * self.tau1 - self.hc * self.b * self.a * dw2) / (self.m1 + self.hc * self.b * self.b)
    }

    /// (Δω1, Δω2) with friction torque `f` on the wheel.
    fn coupled(&self, h: f64, f: f64) -> (f64, f64) {
        let y1 = h * self.tau1 / self.m1;
        let y2 = h * (self.tau2 - f) / self.m2;
        let (u1, u2) = (self.b / self.m1, self.a / self.m2);
        let s =
            self.hc * (self.b * y1 + self.a * y2) / (1.0 + self.hc * (self.b * u1 + self.a * u2));
        (y1 - u1 * s, y2 - u2 * s)
    }

    /// (new ω1, new ω2, α2) from (ω1, ω2).
    fn solve(&self, p: &DynamicsParams, w1: f64, w2: f64) -> (f64, f64, f64) {
        let h = p.step_s;
        let held = |dw2: f64| (w1 + self.crank_alone(h, dw2), 0.0, dw2 / h);
        if w2.abs() <= STICK_BAND_RAD_S {
            // Torque the bearing must hold with the wheel still.
            let dw1 = self.crank_alone(h, -w2);
            let hold = self.tau2 - self.hc / h * self.a * (self.b * dw1 - self.a * w2);
            if hold.abs() <= p.static_torque_n_m {
                return held(-w2);
            }
            let (dw1, dw2) = self.coupled(h, p.static_torque_n_m * hold.signum());
            return (w1 + dw1, w2 + dw2, dw2 / h);
        }
        let (dw1, dw2) = self.coupled(h, p.kinetic_torque_n_m * w2.signum());
        if (w2 + dw2) * w2 < 0.0 {
            // Landing exactly on zero lets the next step decide stick or breakaway.
            return held(-w2);
        }
        (w1 + dw1, w2 + dw2, dw2 / h)
    }
}

/// Integrates the wheel (and a servo-driven crank) from (θ2 abs, ω2) at t = 0 to `duration_s`;
/// a servo-driven crank starts on its prescribed motion.
pub fn simulate(
    geneva: &Geneva,
    p: &DynamicsParams,
    crank: &CrankMotion,
    theta2_abs0_rad: f64,
    omega2_0_rad_s: f64,
    duration_s: f64,
) -> DynamicsResult {
    let h = p.step_s;
    let j_wheel = p.inertia_kg_m2;
    let k = p.contact.stiffness_n_m();
    let every = ((p.output_step_s / h).round() as usize).max(1);
    let n_out = (duration_s / (every as f64 * h)).ceil() as usize + 1;
    let servo = match p.crank {
        CrankDrive::Servo {
            inertia_kg_m2,
            stiffness_n_m_rad,
            damping_n_m_s_rad,
        } => Some((inertia_kg_m2, stiffness_n_m_rad, damping_n_m_s_rad)),
        CrankDrive::Prescribed => None,
    };
    let crank_out = if servo.is_some() { n_out } else { 0 };
    let mut res = DynamicsResult {
        output_step_s: every as f64 * h,
        theta2_rad: Vec::with_capacity(n_out),
        omega2_rad_s: Vec::with_capacity(n_out),
        alpha2_rad_s2: Vec::with_capacity(n_out),
        theta1_rad: Vec::with_capacity(crank_out),
        omega1_rad_s: Vec::with_capacity(crank_out),
        contact_changes: Vec::new(),
        impacts: Vec::new(),
        energy: EnergyLedger::default(),
        deepest_penetration: (0.0, 0.0),
    };
    let (mut th, mut w) = (theta2_abs0_rad, omega2_0_rad_s);
    let c0 = crank.state(0.0);
    let (mut th1, mut w1) = (c0.theta1_rad, c0.omega1_rad_s);
    let mut last_side = 0i8;
    let mut episode: Option<Episode> = None;
    let mut ledger = EnergyLedger::default();
    let total = (n_out - 1) * every;
    for i in 0..=total {
        let t = i as f64 * h;
        // The last step only samples the output; its work would not reach `final_j`.
        let book = i < total;
        let reference = crank.state(t);
        if servo.is_none() {
            (th1, w1) = (reference.theta1_rad, reference.omega1_rad_s);
        }
        let geo = contact_geometry(geneva, p, th1, w1, th);
        let side = geo.map_or(0, |g| g.side);
        if side != last_side {
            res.contact_changes.push((t, side));
            last_side = side;
        }
        let elastic_j = geo.map_or(0.0, |g| 0.5 * k * g.delta_m * g.delta_m);
        if let Some(g) = geo {
            if g.delta_m > res.deepest_penetration.0 {
                res.deepest_penetration = (g.delta_m, t);
            }
            if g.delta_m > MAX_PENETRATION_PIN_RADII * p.pin_radius_m {
                // The wheel has gone through the wall; stop here and let the caller refuse it.
                break;
            }
        }
        let crank_kinetic_j = servo.map_or(0.0, |(j1, _, _)| 0.5 * j1 * w1 * w1);
        let kinetic_j = 0.5 * j_wheel * w * w;
        if i == 0 {
            ledger.initial_j = kinetic_j + crank_kinetic_j + elastic_j;
        }
        ledger.peak_kinetic_j = ledger.peak_kinetic_j.max(kinetic_j);
        // Episode bookkeeping: a new touch starts one, leaving (or switching walls) ends it.
        if episode.is_some_and(|e| e.impact.side != side) {
            if let Some(mut e) = episode.take() {
                e.close_impact(w);
                e.impact.end_s = t;
                res.impacts.push(e.impact);
            }
        }
        if let (None, Some(g)) = (episode, geo) {
            let approach = g.rate_m_s(w).max(0.0);
            episode = Some(Episode {
                impact: Impact {
                    t_s: t,
                    end_s: t,
                    side: g.side,
                    approach_m_s: approach,
                    approach_rad_s: approach / g.rate_per_omega2_m.abs().max(1e-12),
                    jump_omega2_rad_s: 0.0,
                    peak_force_n: 0.0,
                    peak_crank_torque_n_m: 0.0,
                    crank_impulse_n_m_s: 0.0,
                },
                omega_at_touch: w,
                prev_rate: g.rate_m_s(w),
                rebounding: false,
                impact_open: true,
            });
        }
        // Contact force over the step (explicit) and its rate derivative (for the implicit part).
        let contact = match (geo, episode.as_ref()) {
            (Some(g), Some(e)) => {
                let rate = g.rate_m_s(w);
                let f: ContactForce =
                    p.contact
                        .force(g.delta_m, rate, g.legacy_rate_m_s(w), e.impact.approach_m_s);
                Some((g, f, rate))
            }
            _ => None,
        };
        let (w1_new, w_new, a) = match servo {
            None => {
                let (tau, d) = contact.map_or((0.0, 0.0), |(g, f, _)| {
                    // Implicit damping: τ(ω_new) = τ − D·(ω_new − ω), D = ∂F/∂δ̇·(∂δ̇/∂ω2)².
                    let a = g.rate_per_omega2_m;
                    (g.wheel_torque_n_m(f.total_n()), f.d_force_d_rate * a * a)
                });
                let (w_new, a) = friction_step(p, j_wheel + h * d, w, tau);
                (w1, w_new, a)
            }
            Some((j1, ks, cs)) => {
                let servo_tau =
                    ks * (reference.theta1_rad - th1) + cs * (reference.omega1_rad_s - w1);
                let (hc, b, a, f_n, lever) =
                    contact.map_or((0.0, 0.0, 0.0, 0.0, 0.0), |(g, f, _)| {
                        (
                            h * f.d_force_d_rate,
                            -g.crank_lever_m,
                            g.rate_per_omega2_m,
                            f.total_n(),
                            g.crank_lever_m,
                        )
                    });
                let step = ServoStep {
                    m1: j1 + h * cs,
                    m2: j_wheel,
                    hc,
                    b,
                    a,
                    tau1: servo_tau + f_n * lever,
                    tau2: -f_n * a,
                };
                let (w1_new, w_new, a2) = step.solve(p, w1, w);
                if book {
                    let applied = servo_tau - cs * (w1_new - w1);
                    ledger.input_work_j += h * applied * 0.5 * (w1 + w1_new);
                }
                (w1_new, w_new, a2)
            }
        };
        // The force actually applied over the step (implicit damping at the new speeds).
        let dw1 = w1_new - w1;
        let force = contact.map(|(g, f, rate)| {
            let b = if servo.is_some() {
                -g.crank_lever_m
            } else {
                0.0
            };
            let damping_n =
                f.damping_n + f.d_force_d_rate * (g.rate_per_omega2_m * (w_new - w) + b * dw1);
            (g, f.spring_n + damping_n, damping_n, rate)
        });
        let w_mid = 0.5 * (w + w_new);
        let w1_mid = 0.5 * (w1 + w1_new);
        if let (Some((g, force_n, damping_n, rate)), Some(e)) = (force, episode.as_mut()) {
            // δ̇ at mid-step: the crank part scales with the crank speed.
            let crank_rate = if w1 != 0.0 {
                g.rate_crank_m_s * (w1_mid / w1)
            } else {
                0.0
            };
            if book {
                if servo.is_none() {
                    ledger.input_work_j += h * force_n * g.rate_crank_m_s;
                }
                ledger.damping_loss_j += h * damping_n * (crank_rate + g.rate_per_omega2_m * w_mid);
            }
            // Impact bookkeeping: the impact proper ends when the normal rate, after turning
            // negative, stops falling (the rebound is over) or at separation.
            if e.impact_open {
                if rate <= 0.0 {
                    e.rebounding = true;
                }
                if e.rebounding && rate > e.prev_rate {
                    e.close_impact(w);
                }
            }
            e.prev_rate = rate;
            e.impact.peak_force_n = e.impact.peak_force_n.max(force_n);
            let crank_torque = force_n * g.crank_lever_m;
            if crank_torque.abs() > e.impact.peak_crank_torque_n_m.abs() {
                e.impact.peak_crank_torque_n_m = crank_torque;
            }
            if e.impact_open {
                e.impact.crank_impulse_n_m_s += h * crank_torque;
            }
        }
        let tau_contact = force.map_or(0.0, |(g, f, _, _)| g.wheel_torque_n_m(f));
        // Friction torque actually applied over the step (Karnopp may stick): the remainder.
        let friction_torque = tau_contact - j_wheel * (w_new - w) / h;
        if book {
            ledger.friction_loss_j += h * friction_torque * w_mid;
        }
        if i % every == 0 {
            res.theta2_rad.push(th);
            res.omega2_rad_s.push(w);
            res.alpha2_rad_s2.push(a);
            if servo.is_some() {
                res.theta1_rad.push(th1);
                res.omega1_rad_s.push(w1);
            }
        }
        if i == total {
            ledger.final_j = kinetic_j + crank_kinetic_j + elastic_j;
            break;
        }
        w = w_new;
        th += h * w;
        if servo.is_some() {
            w1 = w1_new;
            th1 += h * w1;
        }
    }
    if let Some(mut e) = episode.take() {
        e.close_impact(w);
        e.impact.end_s = total as f64 * h;
        res.impacts.push(e.impact);
    }
    res.energy = ledger;
    res
}

/// The restitution the contact really has on this wheel: a frictionless wheel thrown at
/// 0.3 rad/s into a pin standing still at its deepest point (crank barely turning), e from the
/// first impact's ω2 jump −(1 + e)·ω2.
pub fn measured_restitution(geneva: &Geneva, p: &DynamicsParams) -> f64 {
    let still = super::drive_speed::DriveSpeedConfig::Constant { omega1_rad_s: 1e-9 };
    let Ok(crank) = CrankMotion::new(&still, geneva, 0.0) else {
        return f64::NAN;
    };
    let free = DynamicsParams {
        static_torque_n_m: 0.0,
        kinetic_torque_n_m: 0.0,
        crank: CrankDrive::Prescribed,
        ..*p
    };
    let w0 = 0.3;
    // The wheel crosses half the clearance at the deepest radius long before 0.2 s.
    let res = simulate(geneva, &free, &crank, 0.0, w0, 0.2);
    res.impacts
        .first()
        .map_or(f64::NAN, |im| -im.jump_omega2_rad_s / w0 - 1.0)
}

impl DynamicsResult {
    /// (θ1, ω1, α1) of a servo-driven crank at `t_s` (clamped to the simulated span): cubic
    /// Hermite on θ1 (slopes ω1), linear ω1, α1 as the ω1 grid slope; `None` when the crank
    /// is prescribed.
    pub fn sample_crank(&self, t_s: f64) -> Option<[f64; 3]> {
        let n = self.theta1_rad.len();
        if n < 2 {
            return None;
        }
        let dt = self.output_step_s;
        let x = (t_s / dt).clamp(0.0, (n - 1) as f64);
        let k = (x.floor() as usize).min(n - 2);
        let s = x - k as f64;
        let (th, w) = (&self.theta1_rad, &self.omega1_rad_s);
        let (s2, s3) = (s * s, s * s * s);
        let theta = (2.0 * s3 - 3.0 * s2 + 1.0) * th[k]
            + (s3 - 2.0 * s2 + s) * dt * w[k]
            + (-2.0 * s3 + 3.0 * s2) * th[k + 1]
            + (s3 - s2) * dt * w[k + 1];
        Some([theta, w[k] + s * (w[k + 1] - w[k]), (w[k + 1] - w[k]) / dt])
    }

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
    use crate::mechanism::contact::ContactModel;
    use crate::mechanism::drive_speed::DriveSpeedConfig;

    fn seed_params(half_clearance_m: f64, stiffness: f64, step_s: f64) -> DynamicsParams {
        let (m, g, rb) = (0.348, 9.81, 0.004);
        DynamicsParams {
            inertia_kg_m2: 0.5 * m * 0.17 * 0.17,
            static_torque_n_m: 0.194 * m * g * rb,
            kinetic_torque_n_m: 0.089 * m * g * rb,
            contact: ContactLaw::Penalty {
                stiffness_n_m: stiffness,
                damping_n_s_m: 50.0,
            },
            half_clearance_m,
            pin_radius_m: 4.75e-3,
            crank_radius_m: 0.025 * (PI / 4.0).sin(),
            crank: CrankDrive::Prescribed,
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
            let (wn, a) = friction_step(&p, p.inertia_kg_m2, w, 0.0);
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
            friction_step(&p, p.inertia_kg_m2, 0.0, 0.99 * p.static_torque_n_m),
            (0.0, 0.0)
        );
        let (wn, a) = friction_step(&p, p.inertia_kg_m2, 0.0, 2.0 * p.static_torque_n_m);
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

    fn hunt_crossley(e: f64) -> DynamicsParams {
        DynamicsParams {
            contact: ContactLaw::new(ContactModel::HuntCrossley, 1e6, 0.0, e),
            static_torque_n_m: 0.0,
            kinetic_torque_n_m: 0.0,
            ..seed_params(0.25e-3, 1e6, 1e-5)
        }
    }

    /// A frictionless wheel thrown at a pin that stands still (crank at its deepest point,
    /// barely turning) rebounds with the configured restitution: the first impact changes ω2
    /// by −(1 + e)·ω2.
    #[test]
    fn a_free_wheel_hitting_a_still_pin_rebounds_with_the_restitution() {
        let gv = Geneva::new(GenevaKind::Internal, 4);
        let cfg = DriveSpeedConfig::Constant { omega1_rad_s: 1e-9 };
        let crank = CrankMotion::new(&cfg, &gv, 0.0).unwrap();
        for e in [0.1, 0.35, 0.6, 0.9, 1.0] {
            let w0 = 0.3;
            let res = simulate(&gv, &hunt_crossley(e), &crank, 0.0, w0, 0.1);
            let first = res.impacts[0];
            let measured = -first.jump_omega2_rad_s / w0 - 1.0;
            assert!(
                (measured - e).abs() < 2e-3,
                "e {e}: rebound gives {measured} ({first:?})"
            );
            assert!((first.approach_rad_s - w0).abs() < 1e-3, "{first:?}");
            // Nothing but the contact acts: the energy it creates is a tiny fraction of the throw.
            let ledger = res.energy;
            assert!(
                ledger.residual_j().abs() < 1e-4 * ledger.initial_j,
                "{ledger:?}"
            );
        }
    }

    /// The penalty contact of the seed defaults (k = 1e6 N/m, c = 50 N·s/m) is nearly elastic:
    /// the same throw rebounds with e ≈ 0.95, which is why that model kept the wheel rattling.
    #[test]
    fn the_old_penalty_contact_is_nearly_elastic() {
        let gv = Geneva::new(GenevaKind::Internal, 4);
        let cfg = DriveSpeedConfig::Constant { omega1_rad_s: 1e-9 };
        let crank = CrankMotion::new(&cfg, &gv, 0.0).unwrap();
        let p = DynamicsParams {
            static_torque_n_m: 0.0,
            kinetic_torque_n_m: 0.0,
            ..seed_params(0.25e-3, 1e6, 1e-5)
        };
        let res = simulate(&gv, &p, &crank, 0.0, 0.3, 0.1);
        let e = -res.impacts[0].jump_omega2_rad_s / 0.3 - 1.0;
        assert!(e > 0.93 && e < 0.98, "penalty restitution {e}");
        assert_eq!(measured_restitution(&gv, &p), e);
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
