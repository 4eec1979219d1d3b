//! The crank motion from the measured marker angle: sense of rotation, crank phase at the first
//! frame, mean crank speed and (when the data resolve it) the per-engagement polynomial, by
//! least squares of the exact Geneva kinematics φ(t) = A + θ2(θ1(t)) − θ2(θ1(0)).

use super::{CalibrateError, Fitted, GeometryFit};
use crate::estimate::lm;
use crate::mechanism::drive_speed::CrankMotion;
use crate::mechanism::kinematics::{Geneva, GenevaKind};
use crate::mechanism::DriveSpeedConfig;
use crate::numeric::angle::wrap_pi_upper;
use crate::scenario::Scenario;
use std::f64::consts::{PI, TAU};

/// What the motion fit needs.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionInput {
    pub kind: GenevaKind,
    pub slots: u32,
    /// (t_s from the first frame, marker angle about the rotation centre, unwrapped rad): the
    /// poses fitted.
    pub track: Vec<(f64, f64)>,
    /// The same on every frame (dense, for the angle noise and the count of moving frames).
    pub dense: Vec<(f64, f64)>,
    /// 95 % uncertainty the rotation centre's position gives every marker angle (the angles
    /// are measured about the fitted centre): U(centre)/R, rad.
    pub centre_angle_u95_rad: f64,
}

impl MotionInput {
    pub fn from_geometry(g: &GeometryFit, base: &Scenario) -> Result<Self, CalibrateError> {
        Ok(Self {
            kind: base.mechanism.kind,
            slots: base.mechanism.slots,
            track: g.track.clone(),
            dense: g.raw_track.clone(),
            centre_angle_u95_rad: match g.centre_px {
                Some([x, y]) => {
                    x.u95.hypot(y.u95) / (g.radius_mm.value / g.mm_per_px.value).max(1.0)
                }
                None => 0.0,
            },
        })
    }
}

/// The fitted crank motion.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionFit {
    /// +1 when the marker angle grows from +x towards +y (clockwise on screen), −1 otherwise.
    pub sense: f64,
    /// Crank angle at the first frame (scenario `mechanism.theta1_start_rad`), in (−π, π].
    pub theta1_start_rad: Fitted,
    /// Constant-speed fit: the mean crank speed, signed.
    pub omega1_rad_s: Fitted,
    /// Per-engagement polynomial (end, mid), when the data resolve a difference.
    pub polynomial: Option<(Fitted, Fitted)>,
    /// The polynomial's mid − end and its uncertainty (reported even when not resolved).
    pub polynomial_difference: Option<Fitted>,
    /// Marker angle at the first frame from the fit (scenario `scene.marker.angle_on_disc_deg`).
    pub angle_first_deg: Fitted,
    /// Engagements (whole or partial) within the footage.
    pub engagements: usize,
    /// Frames where the wheel turns.
    pub moving_frames: usize,
    /// RMS residual of the angle fit and the angle noise from second differences, rad.
    pub rms_residual_rad: f64,
    pub angle_noise_rad: f64,
}

/// θ2(t) − θ2(0) for a crank motion.
fn wheel_rel(geneva: &Geneva, crank: &CrankMotion, t: f64) -> f64 {
    geneva.wheel_angle_abs_rad(crank.state(t).theta1_rad)
        - geneva.wheel_angle_abs_rad(crank.state(0.0).theta1_rad)
}

/// Robust angle noise σ from second differences (MAD/0.6745/√6): insensitive to smooth motion.
fn angle_noise(track: &[(f64, f64)]) -> f64 {
    let mut d2: Vec<f64> = track
        .windows(3)
        .map(|w| (w[2].1 - 2.0 * w[1].1 + w[0].1).abs())
        .collect();
    if d2.is_empty() {
        return 0.0;
    }
    d2.sort_by(f64::total_cmp);
    d2[d2.len() / 2] / 0.6745 / 6f64.sqrt()
}

/// Standard-error inflation for residuals that are correlated from pose to pose: √((1 + ρ)/(1 − ρ))
/// with ρ the lag-1 autocorrelation of the residuals in time order (an AR(1) process has
/// (1 − ρ)/(1 + ρ) as many independent samples). Pose errors that follow the marker's angle
/// on the pixel grid, and wheel dynamics the kinematic model does not have, are smooth in time:
/// the Jacobian's errors, which assume independent residuals, are too small by this factor.
pub(crate) fn ar1_inflation(residuals: &[f64]) -> f64 {
    let ss: f64 = residuals.iter().map(|r| r * r).sum();
    if residuals.len() < 3 || ss <= 0.0 {
        return 1.0;
    }
    let lag: f64 = residuals.windows(2).map(|w| w[0] * w[1]).sum();
    let rho = (lag / ss).clamp(0.0, 0.95);
    ((1.0 + rho) / (1.0 - rho)).sqrt()
}

/// Fits the crank motion to the marker angle track.
pub fn fit_motion(
    input: &MotionInput,
    notes: &mut Vec<String>,
) -> Result<MotionFit, CalibrateError> {
    let track = &input.track;
    if track.len() < 3 {
        return Err(CalibrateError::Missing(format!(
            "the motion fit needs the marker in at least 3 frames, it was found in {}",
            track.len()
        )));
    }
    let geneva = Geneva::new(input.kind, input.slots);
    let dense = if input.dense.len() >= 3 {
        &input.dense
    } else {
        track
    };
    let noise = angle_noise(dense);
    let total = dense[dense.len() - 1].1 - dense[0].1;
    if total.abs() < (20.0 * noise).max(2e-3) {
        return Err(CalibrateError::Unresolved {
            what: "motion".into(),
            reason: format!(
                "the marker turns by only {:.4}° over the footage: the crank phase and speed \
                 cannot be measured (pass --single-frame to calibrate the image formation only)",
                total.to_degrees()
            ),
        });
    }
    let sense = total.signum();
    let dir = sense * input.kind.sign();
    let ts: Vec<f64> = track.iter().map(|p| p.0).collect();
    let phis: Vec<f64> = track.iter().map(|p| p.1).collect();
    let t_span = ts[ts.len() - 1] - ts[0];
    let moving_frames = dense
        .windows(2)
        .filter(|w| (w[1].1 - w[0].1).abs() > 6.0 * noise + 1e-6)
        .count();

    // Residuals of the constant-speed model for (θ10, |ω|, A).
    let constant = |p: &[f64], out: &mut Vec<f64>| -> bool {
        let w = p[1];
        if !(w > 1e-3 && w < 1000.0) {
            return false;
        }
        let th0 = p[0];
        let w0 = geneva.wheel_angle_abs_rad(th0);
        out.clear();
        out.extend(
            ts.iter()
                .zip(&phis)
                .map(|(t, phi)| phi - p[2] - (geneva.wheel_angle_abs_rad(th0 + dir * w * t) - w0)),
        );
        true
    };
    // Grid over speed and phase (A solved in closed form), thinned to ≤ 150 frames.
    let step = track.len().div_ceil(150);
    let sub: Vec<(f64, f64)> = track.iter().step_by(step).copied().collect();
    let mut cands: Vec<(f64, f64, f64, f64)> = Vec::new();
    let n_w = 320;
    let (w_lo, w_hi) = (0.05f64.max(0.2 * PI / t_span.max(1e-3)), 60.0f64);
    for i in 0..n_w {
        let w = w_lo * (w_hi / w_lo).powf(i as f64 / (n_w - 1) as f64);
        for j in 0..96 {
            let th0 = -PI + TAU * j as f64 / 96.0;
            let w0 = geneva.wheel_angle_abs_rad(th0);
            let pred: Vec<f64> = sub
                .iter()
                .map(|(t, _)| geneva.wheel_angle_abs_rad(th0 + dir * w * t) - w0)
                .collect();
            let a = sub.iter().zip(&pred).map(|(s, p)| s.1 - p).sum::<f64>() / sub.len() as f64;
            let cost: f64 = sub
                .iter()
                .zip(&pred)
                .map(|(s, p)| (s.1 - a - p).powi(2))
                .sum();
            cands.push((cost, th0, w, a));
        }
    }
    cands.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut best: Option<lm::LmFit> = None;
    for c in cands.iter().take(12) {
        let fit = lm::minimise(&constant, &[c.1, c.2, c.3], &[1e-6, 1e-7, 1e-7], 100);
        if let Some(f) = fit {
            if best.as_ref().is_none_or(|b| f.cost < b.cost) {
                best = Some(f);
            }
        }
    }
    let fit = best.ok_or_else(|| CalibrateError::Unresolved {
        what: "motion".into(),
        reason: "the kinematic model could not be fitted to the marker angle".into(),
    })?;
    let inflate = ar1_inflation(&fit.residuals);
    let se: Vec<f64> = fit.std_errors().iter().map(|s| s * inflate).collect();
    let n = track.len() as f64;
    let rms = (fit.cost / n).sqrt();
    // Which engagements lie within the footage (crank angle 0 mod 2π is the middle of one).
    let th0 = fit.params[0];
    let w = fit.params[1];
    let beta = geneva.engagement_half_angle_rad();
    let u0 = dir * th0;
    let u1 = u0 + w * t_span;
    let first_k = ((u0 - beta) / TAU).ceil() as i64;
    let last_k = ((u1 + beta) / TAU).floor() as i64;
    let engagements = (last_k - first_k + 1).max(0) as usize;
    if moving_frames < 3 {
        return Err(CalibrateError::Unresolved {
            what: "motion".into(),
            reason: "fewer than 3 frames show the wheel turning".into(),
        });
    }
    // Floors for what the residuals do not show: pose errors that do not average out.
    let floor_th = (noise / n.sqrt()).max(5e-4);
    let theta1 = Fitted::from_sigma(wrap_pi_upper(th0), se[0], floor_th);
    let omega = Fitted::from_sigma(dir * w, se[1], 1e-4 * w);
    let angle_first = Fitted::from_sigma(
        wrap_pi_upper(fit.params[2]).to_degrees(),
        se[2].to_degrees(),
        noise.to_degrees() / n.sqrt(),
    );

    // The per-engagement polynomial: mid and end speeds (same sign), tried from the constant fit.
    let poly = |p: &[f64], out: &mut Vec<f64>| -> bool {
        let (end, mid) = (p[1], p[2]);
        if !(end > 1e-3 && mid > 1e-3 && end < 1000.0 && mid < 1000.0) {
            return false;
        }
        let cfg = DriveSpeedConfig::PolynomialPerEngagement {
            end_rad_s: dir * end,
            mid_rad_s: dir * mid,
        };
        let Ok(crank) = CrankMotion::new(&cfg, &geneva, p[0]) else {
            return false;
        };
        out.clear();
        out.extend(
            ts.iter()
                .zip(&phis)
                .map(|(t, phi)| phi - p[3] - wheel_rel(&geneva, &crank, *t)),
        );
        true
    };
    let mut polynomial = None;
    let mut polynomial_difference = None;
    let (mut theta1, mut angle_first, mut rms) = (theta1, angle_first, rms);
    if engagements > 0 && moving_frames >= 8 {
        if let Some(pf) = lm::minimise(
            &poly,
            &[th0, w, w, fit.params[2]],
            &[1e-6, 1e-7, 1e-7, 1e-7],
            100,
        ) {
            if let Some(cov) = pf.covariance() {
                let pinflate = ar1_inflation(&pf.residuals);
                let diff = pf.params[2] - pf.params[1];
                let sd = (cov[(1, 1)] + cov[(2, 2)] - 2.0 * cov[(1, 2)])
                    .max(0.0)
                    .sqrt()
                    * pinflate;
                let d = Fitted::from_sigma(dir * diff, sd, 1e-4 * (pf.params[1] + pf.params[2]));
                polynomial_difference = Some(d);
                if diff.abs() > d.u95 && pf.cost < fit.cost {
                    let pse: Vec<f64> = pf.std_errors().iter().map(|s| s * pinflate).collect();
                    theta1 = Fitted::from_sigma(wrap_pi_upper(pf.params[0]), pse[0], floor_th);
                    angle_first = Fitted::from_sigma(
                        wrap_pi_upper(pf.params[3]).to_degrees(),
                        pse[3].to_degrees(),
                        noise.to_degrees() / n.sqrt(),
                    );
                    rms = (pf.cost / n).sqrt();
                    polynomial = Some((
                        // The same floor as the constant speed's.
                        Fitted::from_sigma(
                            dir * pf.params[1],
                            cov[(1, 1)].max(0.0).sqrt() * pinflate,
                            1e-4 * pf.params[1],
                        ),
                        Fitted::from_sigma(
                            dir * pf.params[2],
                            cov[(2, 2)].max(0.0).sqrt() * pinflate,
                            1e-4 * pf.params[2],
                        ),
                    ));
                } else {
                    notes.push(format!(
                        "per-engagement speed variation not resolved: mid − end = {d} rad/s \
                         (95 %) includes zero; the calibrated drive speed is constant"
                    ));
                }
            }
        }
    } else {
        notes.push(
            "per-engagement speed variation not tested: too few frames inside an engagement".into(),
        );
    }
    // The fit takes the centre as exact; its uncertainty moves the marker angle with it.
    let angle_first_deg = Fitted::new(
        angle_first.value,
        angle_first
            .u95
            .hypot(input.centre_angle_u95_rad.to_degrees()),
    );
    Ok(MotionFit {
        sense,
        theta1_start_rad: theta1,
        omega1_rad_s: omega,
        polynomial,
        polynomial_difference,
        angle_first_deg,
        engagements,
        moving_frames,
        rms_residual_rad: rms,
        angle_noise_rad: noise,
    })
}
