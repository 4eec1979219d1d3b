//! Nuisance alignment of the motion: what no user knows exactly and what is not an effect — the
//! crank phase at the first frame (equivalently a time offset), the mean crank speed, the sense
//! of rotation and the marker's angular offset — fitted to the measured marker angle before any
//! effect is judged. Without it every case looks like a gap.
//!
//! The measured angle θ̂(t) (screen, counter-clockwise positive, unwrapped) is modelled as
//! σ·θ2(t; θ1₀, s) + c, where θ2 is the nominal mechanism's ideal kinematics relative to t = 0
//! with the crank starting at θ1₀ and every speed of the nominal drive profile scaled by s
//! (negative s: the crank turns the other way), σ the nominal camera's screen sense and c a
//! constant. The loss is the RMS of the 90 % smallest residuals, so impacts, over-rotation and
//! other effects do not pull the fit. A coarse grid over (θ1₀, s) is followed by a compass
//! search around the best grid points.

use crate::mechanism::{DriveSpeedConfig, Mechanism, Phase};
use crate::scenario::Scenario;
use std::f64::consts::TAU;

/// Fraction of residuals kept by the trimmed loss.
const KEEP_FRACTION: f64 = 0.9;
/// Speed scales searched: |s| from 1/2 to 2 of the nominal, both senses.
const SPEED_SCALE_RANGE: (f64, f64) = (0.5, 2.0);

/// The fitted motion nuisance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionAlignment {
    /// Crank angle at t = 0, rad (the scenario's `mechanism.theta1_start_rad`).
    pub theta1_start_rad: f64,
    /// Factor applied to every speed of the nominal drive profile (negative: reversed).
    pub speed_scale: f64,
    /// Screen angle offset c, rad.
    pub offset_rad: f64,
    /// Trimmed RMS of the angle residual at the optimum, rad.
    pub rms_residual_rad: f64,
    /// Trimmed RMS with the nominal's own start angle and speed (offset fitted), rad.
    pub nominal_rms_residual_rad: f64,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum AlignError {
    #[error("the motion cannot be aligned: {0}")]
    Degenerate(String),
}

/// The drive profile `d` with every speed multiplied by `k`.
pub fn scale_drive(d: &DriveSpeedConfig, k: f64) -> DriveSpeedConfig {
    match d {
        DriveSpeedConfig::Constant { omega1_rad_s } => DriveSpeedConfig::Constant {
            omega1_rad_s: omega1_rad_s * k,
        },
        DriveSpeedConfig::PolynomialPerEngagement {
            end_rad_s,
            mid_rad_s,
        } => DriveSpeedConfig::PolynomialPerEngagement {
            end_rad_s: end_rad_s * k,
            mid_rad_s: mid_rad_s * k,
        },
        DriveSpeedConfig::Table {
            t_s,
            omega1_rad_s,
            file,
        } => DriveSpeedConfig::Table {
            t_s: t_s.clone(),
            omega1_rad_s: omega1_rad_s.iter().map(|w| w * k).collect(),
            file: file.clone(),
        },
    }
}

/// The nominal with the motion nuisance applied (start angle, scaled speeds).
pub fn apply_motion(nominal: &Scenario, a: &MotionAlignment) -> Scenario {
    let mut s = nominal.clone();
    s.mechanism.theta1_start_rad = Some(a.theta1_start_rad);
    s.drive_speed = scale_drive(&nominal.drive_speed, a.speed_scale);
    s
}

/// Ideal wheel angle θ2(t) − θ2(0) of the nominal with start angle `theta1_0` and speed scale
/// `k`, at `t_s`; `None` when the configuration is invalid.
fn ideal_theta2(nominal: &Scenario, theta1_0: f64, k: f64, t_s: &[f64]) -> Option<Vec<f64>> {
    let mut mech = nominal.mechanism.clone();
    mech.theta1_start_rad = Some(theta1_0);
    let drive = scale_drive(&nominal.drive_speed, k);
    let mut dynamics = nominal.dynamics.clone();
    dynamics.enabled = false;
    dynamics.disc_vibration.enabled = false;
    dynamics.axis_runout.enabled = false;
    let duration = t_s.last().copied().unwrap_or(1.0).max(1e-3) + 1.0;
    let m = Mechanism::new(&mech, &drive, &dynamics, duration).ok()?;
    Some(t_s.iter().map(|&t| m.ideal(t).theta2_rad).collect())
}

/// Robust offset and trimmed RMS of `theta − sign·model`.
fn trimmed_fit(theta: &[f64], model: &[f64], sign: f64) -> (f64, f64) {
    let mut r: Vec<f64> = theta.iter().zip(model).map(|(a, m)| a - sign * m).collect();
    let mut sorted = r.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    r.iter_mut().for_each(|x| *x -= median);
    let mut sq: Vec<f64> = r.iter().map(|x| x * x).collect();
    sq.sort_by(f64::total_cmp);
    let keep = ((sq.len() as f64 * KEEP_FRACTION).ceil() as usize).clamp(1, sq.len());
    // Offset: mean of the kept residuals (refines the median).
    let mut kept: Vec<f64> = r.clone();
    kept.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
    let shift = kept[..keep].iter().sum::<f64>() / keep as f64;
    let rms = (sq[..keep].iter().sum::<f64>() / keep as f64).sqrt();
    (median + shift, rms)
}

/// Fits the motion nuisance to the measured screen angle `theta_rad` at `t_s` (detected frames
/// only, unwrapped). `screen_sign` is +1 when the nominal wheel's θ2 grows counter-clockwise on
/// screen.
pub fn align_motion(
    nominal: &Scenario,
    t_s: &[f64],
    theta_rad: &[f64],
    screen_sign: f64,
) -> Result<MotionAlignment, AlignError> {
    let n = t_s.len().min(theta_rad.len());
    if n < 10 {
        return Err(AlignError::Degenerate(format!(
            "{n} detected frames (at least 10 needed)"
        )));
    }
    // At most ~200 frames in the grid search (evenly spaced); all of them in the refinement.
    let stride = n.div_ceil(200).max(1);
    let sub: Vec<usize> = (0..n).step_by(stride).collect();
    let t_sub: Vec<f64> = sub.iter().map(|&k| t_s[k]).collect();
    let th_sub: Vec<f64> = sub.iter().map(|&k| theta_rad[k]).collect();
    let loss = |t: &[f64], th: &[f64], theta1_0: f64, k: f64| -> f64 {
        match ideal_theta2(nominal, theta1_0, k, t) {
            Some(m) => trimmed_fit(th, &m, screen_sign).1,
            None => f64::INFINITY,
        }
    };

    // Coarse grid: 3° in θ1₀, 4 % in |s|, both senses.
    let mut grid: Vec<(f64, f64, f64)> = Vec::new();
    let steps_s =
        ((SPEED_SCALE_RANGE.1 / SPEED_SCALE_RANGE.0).ln() / 0.04f64.ln_1p()).ceil() as usize;
    for sense in [1.0, -1.0] {
        for j in 0..=steps_s {
            let k = sense * SPEED_SCALE_RANGE.0 * 1.04f64.powi(j as i32);
            for i in 0..120 {
                let theta1_0 = TAU * i as f64 / 120.0;
                grid.push((loss(&t_sub, &th_sub, theta1_0, k), theta1_0, k));
            }
        }
    }
    grid.sort_by(|a, b| a.0.total_cmp(&b.0));

    // Compass search from the best few grid points, on all frames.
    let (t_all, th_all) = (&t_s[..n], &theta_rad[..n]);
    let mut best = (f64::INFINITY, 0.0, 1.0);
    for &(_, theta1_0, k) in grid.iter().take(4) {
        let (mut a, mut ln_k) = (theta1_0, k.abs().ln());
        let sense = k.signum();
        let mut f = loss(t_all, th_all, a, sense * ln_k.exp());
        let (mut da, mut dk) = (TAU / 240.0, 0.02);
        while da > 1e-6 {
            let mut improved = false;
            for (pa, pk) in [(da, 0.0), (-da, 0.0), (0.0, dk), (0.0, -dk)] {
                let g = loss(t_all, th_all, a + pa, sense * (ln_k + pk).exp());
                if g < f {
                    (f, a, ln_k) = (g, a + pa, ln_k + pk);
                    improved = true;
                }
            }
            if !improved {
                da *= 0.5;
                dk *= 0.5;
            }
        }
        if f < best.0 {
            best = (f, a.rem_euclid(TAU), sense * ln_k.exp());
        }
    }
    if !best.0.is_finite() {
        return Err(AlignError::Degenerate(
            "no start angle and speed give a valid motion".into(),
        ));
    }
    let model = ideal_theta2(nominal, best.1, best.2, t_all).unwrap_or_default();
    let (offset, rms) = trimmed_fit(th_all, &model, screen_sign);
    let nominal_start = nominal
        .mechanism
        .theta1_start_resolved_rad(nominal.drive_speed.direction());
    let nominal_rms = ideal_theta2(nominal, nominal_start, 1.0, t_all)
        .map(|m| trimmed_fit(th_all, &m, screen_sign).1)
        .unwrap_or(f64::INFINITY);
    Ok(MotionAlignment {
        theta1_start_rad: best.1,
        speed_scale: best.2,
        offset_rad: offset,
        rms_residual_rad: rms,
        nominal_rms_residual_rad: nominal_rms,
    })
}

/// Phase of the aligned nominal motion at each time (phases of real data come from here).
pub fn phases(aligned: &Scenario, t_s: &[f64]) -> Vec<Phase> {
    let mut dynamics = aligned.dynamics.clone();
    dynamics.enabled = false;
    let duration = t_s.last().copied().unwrap_or(1.0).max(1e-3) + 1.0;
    match Mechanism::new(
        &aligned.mechanism,
        &aligned.drive_speed,
        &dynamics,
        duration,
    ) {
        Ok(m) => t_s.iter().map(|&t| m.ideal(t).phase).collect(),
        Err(_) => vec![Phase::Dwell; t_s.len()],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_start_angle_speed_and_offset_from_a_noisy_angle() {
        let nominal = crate::scenario::load_any("fast").unwrap();
        let t: Vec<f64> = (0..300).map(|k| k as f64 / 30.0).collect();
        let truth_start = 2.0;
        let truth_k = 1.13;
        let model = ideal_theta2(&nominal, truth_start, truth_k, &t).unwrap();
        // Screen sense −1, offset 0.7 rad, ±1 mrad noise and two 50 mrad outliers.
        let mut theta: Vec<f64> = model
            .iter()
            .enumerate()
            .map(|(k, m)| -m + 0.7 + 1e-3 * ((k * 37 % 11) as f64 / 5.0 - 1.0))
            .collect();
        theta[100] += 0.05;
        theta[200] -= 0.05;
        let a = align_motion(&nominal, &t, &theta, -1.0).unwrap();
        assert!((a.speed_scale - truth_k).abs() < 2e-3, "{a:?}");
        let d = (a.theta1_start_rad - truth_start + std::f64::consts::PI).rem_euclid(TAU)
            - std::f64::consts::PI;
        assert!(d.abs() < 5e-3, "{a:?}");
        assert!((a.offset_rad - 0.7).abs() < 2e-3, "{a:?}");
        assert!(a.rms_residual_rad < 1.5e-3, "{a:?}");
        assert!(a.nominal_rms_residual_rad > 10.0 * a.rms_residual_rad);
    }

    #[test]
    fn a_reversed_crank_is_found() {
        let nominal = crate::scenario::load_any("fast").unwrap();
        let t: Vec<f64> = (0..200).map(|k| k as f64 / 30.0).collect();
        let model = ideal_theta2(&nominal, 1.0, -0.9, &t).unwrap();
        let theta: Vec<f64> = model.iter().map(|m| m + 0.1).collect();
        let a = align_motion(&nominal, &t, &theta, 1.0).unwrap();
        assert!((a.speed_scale + 0.9).abs() < 2e-3, "{a:?}");
    }

    #[test]
    fn too_few_frames_is_an_error() {
        let nominal = crate::scenario::load_any("fast").unwrap();
        assert!(align_motion(&nominal, &[0.0; 5], &[0.0; 5], 1.0).is_err());
    }
}
