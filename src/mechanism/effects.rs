//! Additive wheel effects on the actual motion: `disc_vibration` (rotational sinusoids) and
//! `axis_runout` (wheel-centre wobble). Pure functions of time and wheel angle.

use super::dynamics_config::{AxisRunoutConfig, DiscVibrationConfig};
use std::f64::consts::PI;

/// Offsets (θ2, ω2, α2, jerk2) added by the disc vibration at `t_s`; zero when disabled.
pub fn disc_vibration_offsets(cfg: &DiscVibrationConfig, t_s: f64) -> [f64; 4] {
    let mut out = [0.0; 4];
    if !cfg.enabled {
        return out;
    }
    for c in &cfg.components {
        let w = 2.0 * PI * c.frequency_hz;
        let (s, co) = (w * t_s + c.phase_rad).sin_cos();
        out[0] += c.amplitude_rad * s;
        out[1] += c.amplitude_rad * w * co;
        out[2] -= c.amplitude_rad * w * w * s;
        out[3] -= c.amplitude_rad * w * w * w * co;
    }
    out
}

/// Wheel-centre offset, m, in the global frame; zero when disabled.
pub fn axis_runout_offset_m(cfg: &AxisRunoutConfig, t_s: f64, theta2_rad: f64) -> [f64; 2] {
    if !cfg.enabled {
        return [0.0, 0.0];
    }
    let psi =
        cfg.cycles_per_wheel_rev * theta2_rad + 2.0 * PI * cfg.frequency_hz * t_s + cfg.phase_rad;
    [cfg.amplitude_m * psi.cos(), cfg.amplitude_m * psi.sin()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::dynamics_config::VibrationComponent;

    #[test]
    fn vibration_derivatives_are_consistent() {
        let cfg = DiscVibrationConfig {
            enabled: true,
            components: vec![
                VibrationComponent {
                    amplitude_rad: 1e-3,
                    frequency_hz: 7.0,
                    phase_rad: 0.3,
                },
                VibrationComponent {
                    amplitude_rad: 2e-4,
                    frequency_hz: 31.0,
                    phase_rad: 0.0,
                },
            ],
        };
        let h = 1e-6;
        for i in 0..50 {
            let t = 0.0137 * i as f64;
            let (a, b, c) = (
                disc_vibration_offsets(&cfg, t - h),
                disc_vibration_offsets(&cfg, t),
                disc_vibration_offsets(&cfg, t + h),
            );
            for k in 0..3 {
                let num = (c[k] - a[k]) / (2.0 * h);
                assert!(
                    (num - b[k + 1]).abs() < 1e-6 * (1.0 + b[k + 1].abs()),
                    "k {k}"
                );
            }
        }
        let off = DiscVibrationConfig {
            enabled: false,
            ..cfg
        };
        assert_eq!(disc_vibration_offsets(&off, 0.4), [0.0; 4]);
    }

    #[test]
    fn runout_is_a_circle_of_the_amplitude() {
        let cfg = AxisRunoutConfig {
            enabled: true,
            amplitude_m: 1e-4,
            ..Default::default()
        };
        let o = axis_runout_offset_m(&cfg, 0.0, PI / 2.0);
        assert!((o[0]).abs() < 1e-15 && (o[1] - 1e-4).abs() < 1e-15);
        let o = axis_runout_offset_m(&cfg, 3.0, 1.234);
        assert!((o[0].hypot(o[1]) - 1e-4).abs() < 1e-15);
    }
}
