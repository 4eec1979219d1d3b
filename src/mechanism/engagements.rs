//! Per-engagement reading of the simulated wheel motion in the seed report's terms (its §4.1–4.3
//! and §5.1–5.4) and the checks that the simulated seed rig shows what the seed observed:
//! impact spikes at entry, one change of the pin from the driving to the braking flank, ω2 on
//! the kinematic curve in mid-drive, no rattle, and the wheel's over-rotation past the index.
//! Pure functions of a [`Mechanism`] with dynamics.
//!
//! Vocabulary:
//! - the *driving* flank is the slot wall the pin pushes to turn the wheel in its index
//!   direction, the *braking* flank the other one;
//! - a *visible* impact is one whose jump of ω2 reaches the seed's velocity resolution (its
//!   doubled half-pixel figure, 0.057 rad/s, §5.3);
//! - a *spike* is what the seed's camera could show: the velocity a perfect detector would
//!   measure with the seed's method (`numpy.gradient` of the angle at the phone's mean frame
//!   interval, a central difference over ±1 frame) departing from the same view of the
//!   kinematic curve by more than 0.057 rad/s; one spike is one such excursion of one sign.

use super::dynamics::Impact;
use super::trajectory::Mechanism;
use std::f64::consts::PI;

/// The seed's doubled velocity error bound (§5.3), rad/s: the smallest ω2 change its camera
/// measurement could show.
pub const SEED_VISIBLE_JUMP_RAD_S: f64 = 0.057;

/// The seed's stated angle error per frame (§5.3), rad: the smallest over-rotation its
/// measurement could see.
pub const SEED_ANGLE_RESOLUTION_RAD: f64 = 0.00095;

/// Mean frame interval of the seed's phone recordings (29.865 fps), s.
pub const SEED_FRAME_INTERVAL_S: f64 = 1.0 / 29.865;

/// Mid-drive: the middle half of the engagement's crank travel, where the seed compared its
/// velocity scatter with the 0.057 rad/s bound ("the low acceleration in the middle of the
/// drive sequence", §5.3).
pub const MID_DRIVE_PROGRESS: (f64, f64) = (0.25, 0.75);

/// Sampling step of the camera view and of the engagement scan, s.
const SCAN_STEP_S: f64 = 1e-3;

/// One impact as an engagement saw it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EngagementImpact {
    /// Crank progress at touch (0 entry, 1 exit; slightly outside at the slot-mouth corners).
    pub progress: f64,
    /// True for the driving flank.
    pub driving: bool,
    /// ω2 jump in the index direction, rad/s.
    pub jump_rad_s: f64,
}

/// One excursion of the camera view of ω2 from the camera view of the kinematic curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spike {
    /// Time of its largest departure, s.
    pub t_s: f64,
    /// That departure in the index direction, rad/s.
    pub peak_rad_s: f64,
}

/// What one complete engagement (entry to the next entry) did.
#[derive(Debug, Clone, PartialEq)]
pub struct EngagementSummary {
    /// 0-based count of complete engagements in the run.
    pub number: usize,
    pub entry_s: f64,
    pub exit_s: f64,
    /// Crank progress where the kinematic |ω2| peaks (the seed's "velocity minimum": ω2 is
    /// negative on its rig).
    pub extremum_progress: f64,
    /// Every impact from the middle of the dwell before to the middle of the dwell after.
    pub impacts: Vec<EngagementImpact>,
    /// Spikes of the camera view beginning before the |ω2| peak.
    pub entry_spikes: Vec<Spike>,
    /// Spikes after the |ω2| peak (the flank change near exit, the exit itself).
    pub late_spikes: Vec<Spike>,
    /// Visible impacts touching in mid-drive (rattle).
    pub mid_drive_impacts: usize,
    /// Crank progress where the pin leaves the driving flank for good.
    pub flank_leave_progress: Option<f64>,
    /// Crank progress of the first touch of the braking flank after the |ω2| peak.
    pub flank_change_progress: Option<f64>,
    /// ω2 jump of that touch in the index direction, rad/s.
    pub flank_change_jump_rad_s: Option<f64>,
    /// Visible impacts on the driving flank after that touch (0 = one flank change).
    pub flank_returns: usize,
    /// Largest |ω2 − ω2 kinematic| over mid-drive, rad/s.
    pub mid_drive_deviation_rad_s: f64,
    /// Wheel angle past the ideal index position before the next pin touches it (or at the end
    /// of the run), in the index direction, rad.
    pub overrotation_rad: f64,
    /// |ω2| at that instant, rad/s (0 = the wheel has come to rest).
    pub end_omega2_rad_s: f64,
}

/// The camera view of ω2 at `t_s`: a central difference of the angle over ±`frame_s`, for the
/// actual and for the ideal motion, both in the index direction.
pub fn camera_view_omega2(m: &Mechanism, t_s: f64, frame_s: f64) -> (f64, f64) {
    let dir = m.index_direction();
    let diff =
        |f: &dyn Fn(f64) -> f64| dir * (f(t_s + frame_s) - f(t_s - frame_s)) / (2.0 * frame_s);
    (
        diff(&|t| m.actual(t).theta2_rad),
        diff(&|t| m.ideal(t).theta2_rad),
    )
}

/// Spikes of the camera view between `from_s` and `to_s`.
pub fn camera_spikes(m: &Mechanism, from_s: f64, to_s: f64, frame_s: f64) -> Vec<Spike> {
    let mut spikes = Vec::new();
    let mut current: Option<Spike> = None;
    let n = ((to_s - from_s) / SCAN_STEP_S).ceil().max(0.0) as usize;
    for k in 0..=n {
        let t = from_s + k as f64 * SCAN_STEP_S;
        let (w, wi) = camera_view_omega2(m, t, frame_s);
        let dev = w - wi;
        if dev.abs() > SEED_VISIBLE_JUMP_RAD_S {
            match current {
                Some(c) if c.peak_rad_s.signum() == dev.signum() => {
                    if dev.abs() > c.peak_rad_s.abs() {
                        current = Some(Spike {
                            t_s: t,
                            peak_rad_s: dev,
                        });
                    }
                }
                other => {
                    spikes.extend(other);
                    current = Some(Spike {
                        t_s: t,
                        peak_rad_s: dev,
                    });
                }
            }
        } else {
            spikes.extend(current.take());
        }
    }
    spikes.extend(current);
    spikes
}

/// Splits the run into engagements and reads each (only engagements whose entry and exit lie
/// inside the run). Empty when the mechanism has no dynamics.
pub fn engagement_summaries(m: &Mechanism) -> Vec<EngagementSummary> {
    let Some(dynamics) = m.dynamics() else {
        return Vec::new();
    };
    let step = SCAN_STEP_S;
    let n = (m.duration_s() / step).floor() as usize;
    let t = |k: usize| k as f64 * step;
    let progress: Vec<Option<f64>> = (0..=n)
        .map(|k| m.engagement_progress(m.ideal(t(k)).theta1_rad))
        .collect();
    let progress_at = |ts: f64| m.crank_progress(m.ideal(ts).theta1_rad);
    // (entry, exit) sample indices of complete engagements.
    let mut spans = Vec::new();
    let mut start = None;
    for k in 1..=n {
        match (progress[k - 1].is_some(), progress[k].is_some()) {
            (false, true) => start = Some(k),
            (true, false) => spans.extend(start.take().map(|s| (s, k - 1))),
            _ => {}
        }
    }
    let dir = m.index_direction();
    spans
        .iter()
        .enumerate()
        .map(|(number, &(s, e))| {
            let next_entry = (e + 1..=n).find(|&k| progress[k].is_some());
            // The engagement owns the impacts from the middle of the dwell before it to the
            // middle of the dwell after it: the pin meets the slot-mouth corners before its
            // centre passes the mouth and leaves them after.
            let lo = number
                .checked_sub(1)
                .map_or(f64::NEG_INFINITY, |p| 0.5 * (t(spans[p].1) + t(s)));
            let hi = next_entry.map_or(f64::INFINITY, |k| 0.5 * (t(e) + t(k)));
            let owned: Vec<&Impact> = dynamics
                .impacts
                .iter()
                .filter(|im| im.t_s > lo && im.t_s <= hi)
                .collect();
            let driving = |im: &Impact| f64::from(im.side) * dir > 0.0;
            let visible = |im: &Impact| im.jump_omega2_rad_s.abs() >= SEED_VISIBLE_JUMP_RAD_S;
            let (peak_k, _) = (s..=e).fold((s, 0.0f64), |best, k| {
                let w = m.ideal(t(k)).omega2_rad_s.abs();
                if w > best.1 {
                    (k, w)
                } else {
                    best
                }
            });
            let t_peak = t(peak_k);
            let flank = owned
                .iter()
                .find(|im| im.t_s >= t_peak && !driving(im))
                .copied();
            let flank_t = flank.map_or(f64::INFINITY, |im| im.t_s);
            let leave = flank.and_then(|_| {
                owned
                    .iter()
                    .filter(|im| driving(im) && im.t_s < flank_t)
                    .map(|im| im.end_s)
                    .reduce(f64::max)
            });
            let (p_lo, p_hi) = MID_DRIVE_PROGRESS;
            let in_mid = |p: f64| (p_lo..=p_hi).contains(&p);
            let mid_drive_deviation_rad_s = (s..=e)
                .filter(|&k| progress[k].is_some_and(in_mid))
                .map(|k| (m.actual(t(k)).omega2_rad_s - m.ideal(t(k)).omega2_rad_s).abs())
                .fold(0.0, f64::max);
            // The wheel's rest position after this engagement: just before the next pin touches
            // it, or before the next entry, or at the end of the run.
            let next_touch = dynamics
                .impacts
                .iter()
                .find(|im| im.t_s > hi)
                .map_or(f64::INFINITY, |im| im.t_s - step);
            let end_t = next_entry
                .map_or(m.duration_s(), |k| t(k - 1))
                .min(next_touch);
            let (ie, ae) = (m.ideal(end_t), m.actual(end_t));
            let frame = SEED_FRAME_INTERVAL_S;
            let spikes = camera_spikes(m, lo.max(frame), hi.min(m.duration_s() - frame), frame);
            let (entry_spikes, late_spikes) = spikes.into_iter().partition(|sp| sp.t_s < t_peak);
            EngagementSummary {
                number,
                entry_s: t(s),
                exit_s: t(e),
                extremum_progress: progress[peak_k].unwrap_or(0.5),
                impacts: owned
                    .iter()
                    .map(|im| EngagementImpact {
                        progress: progress_at(im.t_s),
                        driving: driving(im),
                        jump_rad_s: dir * im.jump_omega2_rad_s,
                    })
                    .collect(),
                entry_spikes,
                late_spikes,
                mid_drive_impacts: owned
                    .iter()
                    .filter(|im| visible(im) && in_mid(progress_at(im.t_s)))
                    .count(),
                flank_leave_progress: leave.map(progress_at),
                flank_change_progress: flank.map(|im| progress_at(im.t_s)),
                flank_change_jump_rad_s: flank.map(|im| dir * im.jump_omega2_rad_s),
                flank_returns: owned
                    .iter()
                    .filter(|im| im.t_s > flank_t && driving(im) && visible(im))
                    .count(),
                mid_drive_deviation_rad_s,
                overrotation_rad: dir * (ae.theta2_rad - ie.theta2_rad),
                end_omega2_rad_s: ae.omega2_rad_s.abs(),
            }
        })
        .collect()
}

/// One observation of the seed checked on a simulated run.
#[derive(Debug, Clone, PartialEq)]
pub struct SeedCheck {
    /// Short name.
    pub name: &'static str,
    /// What the seed reports (section).
    pub seed: &'static str,
    /// The band the simulation must meet and how it follows from the seed.
    pub criterion: String,
    /// What the simulation did (worst engagement).
    pub measured: String,
    pub pass: bool,
}

/// The over-rotation band derived from the seed (rad): at least what the seed could see of it
/// (its angle resolution), at most the clearance offset at the slot mouth (the wheel parked
/// against the braking flank when the pin leaves) plus the coast of a wheel leaving at the
/// seed's velocity resolution against the bearing friction (it saw the wheel stationary in
/// dwell, §4.1, so nothing faster left the pin).
pub fn overrotation_band_rad(m: &Mechanism) -> Option<(f64, f64)> {
    let p = m.dynamics_params()?;
    let g = m.geneva();
    let mouth_m = p.crank_radius_m * g.ratio_m() * (PI / g.slots as f64).cos();
    let friction_rad_s2 = p.kinetic_torque_n_m / p.inertia_kg_m2;
    let coast = if friction_rad_s2 > 0.0 {
        SEED_VISIBLE_JUMP_RAD_S * SEED_VISIBLE_JUMP_RAD_S / (2.0 * friction_rad_s2)
    } else {
        f64::INFINITY
    };
    Some((
        SEED_ANGLE_RESOLUTION_RAD,
        p.half_clearance_m / mouth_m + coast,
    ))
}

/// The seed's observations (§4.1–4.3, §5.1–5.4) as computed checks over every complete
/// engagement of a run with dynamics; empty without engagements.
pub fn seed_checks(m: &Mechanism, engagements: &[EngagementSummary]) -> Vec<SeedCheck> {
    let (Some(band), false) = (overrotation_band_rad(m), engagements.is_empty()) else {
        return Vec::new();
    };
    let worst = |f: &dyn Fn(&EngagementSummary) -> f64| {
        engagements.iter().map(f).fold(f64::NEG_INFINITY, f64::max)
    };
    let least = |f: &dyn Fn(&EngagementSummary) -> f64| {
        engagements.iter().map(f).fold(f64::INFINITY, f64::min)
    };
    let counts: Vec<usize> = engagements.iter().map(|e| e.entry_spikes.len()).collect();
    let entry_ok = counts.iter().all(|&c| (1..=2).contains(&c));
    let leaves: Vec<f64> = engagements
        .iter()
        .map(|e| e.flank_leave_progress.unwrap_or(f64::NAN))
        .collect();
    let flank_ok = engagements.iter().all(|e| {
        e.flank_leave_progress
            .zip(e.flank_change_progress)
            .is_some_and(|(l, c)| l >= e.extremum_progress && l <= c && c <= 1.0 + 1e-9)
            && e.flank_returns == 0
    });
    let mid = worst(&|e| e.mid_drive_deviation_rad_s);
    let rattle = engagements
        .iter()
        .map(|e| e.mid_drive_impacts)
        .sum::<usize>();
    let (over_lo, over_hi) = (
        least(&|e| e.overrotation_rad),
        worst(&|e| e.overrotation_rad),
    );
    let moving = worst(&|e| e.end_omega2_rad_s);
    // The wheel's energy relative to the kinematic motion: at the entry's largest impact and
    // in mid-drive (½·J·Δω², so the ratio of squared speed departures).
    let entry_jump = |e: &EngagementSummary| {
        e.impacts
            .iter()
            .filter(|im| im.progress < e.extremum_progress)
            .map(|im| im.jump_rad_s.abs())
            .fold(0.0, f64::max)
    };
    let growth = worst(&|e| {
        let j = entry_jump(e);
        if j > 0.0 {
            (e.mid_drive_deviation_rad_s / j).powi(2)
        } else {
            0.0
        }
    });
    let ledger = m.dynamics().map(|d| d.energy).unwrap_or_default();
    let residual = ledger.residual_j().abs();
    let scale = ledger.friction_loss_j + ledger.damping_loss_j.abs();
    let fmt_list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:.3}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    vec![
        SeedCheck {
            name: "entry spikes",
            seed: "§4.1/§5.2: the measured ω2 follows the kinematic curve except for two spikes at the beginning; §5.1: an over-rotated wheel makes the pin bounce its way into the slot",
            criterion: format!(
                "1–2 spikes per entry in the camera view (departures > {SEED_VISIBLE_JUMP_RAD_S} rad/s at the seed's frame interval)"
            ),
            measured: format!(
                "{} per engagement",
                counts.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(", ")
            ),
            pass: entry_ok,
        },
        SeedCheck {
            name: "flank change",
            seed: "§4.3: after the |ω2| peak the wheel must be braked; the pin then works on the other slot wall",
            criterion: "the pin leaves the driving flank after the |ω2| peak, touches the braking flank before exit, and never returns (one flank change)".into(),
            measured: format!(
                "leaves at crank progress {}, peak at {:.3}",
                fmt_list(&leaves),
                engagements[0].extremum_progress
            ),
            pass: flank_ok,
        },
        SeedCheck {
            name: "mid-drive ω2",
            seed: "§5.3: in mid-drive the measured ω2 scatters by no more than the doubled error bound 0.057 rad/s",
            criterion: format!(
                "|ω2 − kinematic| ≤ {SEED_VISIBLE_JUMP_RAD_S} rad/s for crank progress {}–{}",
                MID_DRIVE_PROGRESS.0, MID_DRIVE_PROGRESS.1
            ),
            measured: format!("{mid:.4} rad/s worst"),
            pass: mid <= SEED_VISIBLE_JUMP_RAD_S,
        },
        SeedCheck {
            name: "no rattle",
            seed: "§5.2: apart from the entry spikes the velocity follows the kinematic curve",
            criterion: "no visible impact (ω2 jump ≥ 0.057 rad/s) touching in mid-drive".into(),
            measured: format!("{rattle} in all engagements"),
            pass: rattle == 0,
        },
        SeedCheck {
            name: "over-rotation",
            seed: "§2.3/§5.1: the wheel over-rotates at exit because of the pin–slot gap; §4.1: it is stationary again in dwell",
            criterion: format!(
                "{:.5}–{:.5} rad past the index (seed's angle resolution to the half clearance at the slot mouth plus a coast from 0.057 rad/s), at rest before the next entry",
                band.0, band.1
            ),
            measured: format!(
                "{over_lo:.5}–{over_hi:.5} rad, |ω2| ≤ {moving:.4} rad/s before the next entry"
            ),
            pass: over_lo >= band.0 && over_hi <= band.1 && moving == 0.0,
        },
        SeedCheck {
            name: "no energy growth",
            seed: "§5.4: the bouncing is driven by the gap, not sustained by the model",
            criterion: "energy created by the integration ≤ 1e-4 of the energy dissipated; the wheel's energy relative to the kinematic motion in mid-drive below its value at the entry impact".into(),
            measured: format!(
                "residual {residual:.2e} J of {scale:.2e} J dissipated; mid-drive/entry relative energy {growth:.2e}"
            ),
            pass: residual <= 1e-4 * scale && growth < 1.0,
        },
    ]
}
