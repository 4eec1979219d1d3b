//! Moment matching for the effects whose parameters map onto one statistic of the gap map
//! (edge width, rolling-shutter readout, noise at two grey levels, JPEG blockiness): the
//! parameter is moved until the simulated statistic equals the real one, by secant steps on a
//! coordinate in which the statistic is close to linear. Each step is one simulation on the fit
//! seeds, so a fit costs 2–3 simulations where a bracketing search over Σ z² costs 8–9, and it
//! lands on the solution of "simulated = real" instead of the best point of a coarse bracket.
//!
//! Pure: the caller runs the simulations and passes the resulting gap maps.

use super::gap::GapMap;

/// The real value, the simulations' mean and the standard error of the real value of one
/// channel, averaged over its unbanded cells (every phase in `phases`, or all when empty).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelMeans {
    pub real: f64,
    pub sim: f64,
    /// The seeds' spread of the channel, divided by √cells: the sampling error of `real`.
    pub real_std: f64,
}

/// [`ChannelMeans`] of `channel` in `gap`; `None` when the channel has no finite cell.
pub fn channel_means(gap: &GapMap, channel: &str, phases: &[&str]) -> Option<ChannelMeans> {
    let cells: Vec<_> = gap
        .cells
        .iter()
        .filter(|c| c.key.channel == channel && c.key.band.is_none())
        .filter(|c| phases.is_empty() || phases.contains(&c.key.phase))
        .filter(|c| c.real.is_finite() && c.sim_mean.is_finite())
        .collect();
    if cells.is_empty() {
        return None;
    }
    let n = cells.len() as f64;
    let spread = (cells
        .iter()
        .map(|c| {
            if c.sim_std.is_finite() {
                c.sim_std * c.sim_std
            } else {
                0.0
            }
        })
        .sum::<f64>()
        / n)
        .sqrt();
    Some(ChannelMeans {
        real: cells.iter().map(|c| c.real).sum::<f64>() / n,
        sim: cells.iter().map(|c| c.sim_mean).sum::<f64>() / n,
        real_std: spread / n.sqrt(),
    })
}

/// The next coordinate of a secant solve of m(x) = target from the evaluated `(x, m)` pairs
/// (oldest first), and the slope used. The first step uses the model slope `slope0`; later
/// steps the secant through the last two points, unless it disagrees with the model by more
/// than 5× or has the wrong sign (simulation noise between two close points), when the model
/// slope is kept.
pub fn secant_step(history: &[(f64, f64)], target: f64, slope0: f64) -> Option<(f64, f64)> {
    let &(x, m) = history.last()?;
    let mut slope = slope0;
    if let [.., (x0, m0), (x1, m1)] = history {
        let s = (m1 - m0) / (x1 - x0);
        if s.is_finite() && s * slope0 > 0.0 && (s / slope0).abs() > 0.2 && (s / slope0) < 5.0 {
            slope = s;
        }
    }
    if slope == 0.0 || !slope.is_finite() {
        return None;
    }
    let next = x + (target - m) / slope;
    next.is_finite().then_some((next, slope))
}

/// Pixel noise in the coordinates where the noise variance at radiance s is linear:
/// var/span² = a·s + b with a = 1/FW and b = RN²/FW².
pub fn noise_to_linear(full_well_e: f64, read_noise_e: f64) -> (f64, f64) {
    let a = 1.0 / full_well_e;
    (a, (read_noise_e * a).powi(2))
}

/// Inverse of [`noise_to_linear`]; `None` unless a > 0 and b ≥ 0.
pub fn noise_from_linear(a: f64, b: f64) -> Option<(f64, f64)> {
    (a > 0.0 && b >= 0.0 && a.is_finite() && b.is_finite()).then(|| (1.0 / a, b.sqrt() / a))
}

/// The JPEG quantisation scale (IJG convention, percent of the base tables) of `quality`, the
/// coordinate in which blockiness grows about linearly: the tables, and with them the blocks'
/// steps, scale with it. `quality` is rounded and clamped to 1–100 first, as the renderer does,
/// so the scale is the one a simulation at `quality` actually used.
pub fn jpeg_scale_of_quality(quality: f64) -> f64 {
    let q = quality.round().clamp(1.0, 100.0);
    if q < 50.0 {
        5000.0 / q
    } else {
        200.0 - 2.0 * q
    }
}

/// The (continuous) quality whose [`jpeg_scale_of_quality`] is `scale`, clamped to 1–100.
pub fn quality_of_jpeg_scale(scale: f64) -> f64 {
    let q = if scale > 100.0 {
        5000.0 / scale
    } else {
        (200.0 - scale) / 2.0
    };
    q.clamp(1.0, 100.0)
}

/// |d quality / d scale| at `quality` (continuous form of [`quality_of_jpeg_scale`]).
pub fn quality_per_jpeg_scale(quality: f64) -> f64 {
    if quality < 50.0 {
        quality * quality / 5000.0
    } else {
        0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secant_solves_a_curved_monotone_moment_in_three_steps() {
        // m(x) = sqrt(x + 0.1) (edge width against σ², a curved map), model slope off by 2×.
        let m = |x: f64| (x + 0.1f64).sqrt();
        let target = m(2.0);
        let mut h = vec![(0.5, m(0.5))];
        for _ in 0..3 {
            let (x, _) = secant_step(&h, target, 0.6).unwrap();
            h.push((x, m(x)));
        }
        let x = h.last().unwrap().0;
        assert!((x - 2.0).abs() < 0.02, "{h:?}");
    }

    #[test]
    fn a_secant_of_the_wrong_sign_falls_back_to_the_model_slope() {
        let h = [(1.0, 1.0), (1.1, 0.9)];
        let (x, slope) = secant_step(&h, 2.0, 1.0).unwrap();
        assert_eq!(slope, 1.0);
        assert!((x - 2.2).abs() < 1e-12);
    }

    #[test]
    fn the_jpeg_scale_follows_the_ijg_tables_and_inverts() {
        assert_eq!(jpeg_scale_of_quality(50.0), 100.0);
        assert_eq!(jpeg_scale_of_quality(25.0), 200.0);
        assert_eq!(jpeg_scale_of_quality(75.0), 50.0);
        assert_eq!(jpeg_scale_of_quality(100.0), 0.0);
        // Rounded as the renderer rounds, clamped to its range.
        assert_eq!(jpeg_scale_of_quality(29.6), jpeg_scale_of_quality(30.0));
        assert_eq!(jpeg_scale_of_quality(-3.0), 5000.0);
        let mut last = f64::INFINITY;
        for q in 1..=100 {
            let s = jpeg_scale_of_quality(q as f64);
            assert!(s < last, "not decreasing at {q}");
            last = s;
            assert!((quality_of_jpeg_scale(s) - q as f64).abs() < 1e-9, "{q}");
            // The derivative matches a central difference of the continuous inverse.
            let h = 1e-4;
            let num = (quality_of_jpeg_scale(s - h) - quality_of_jpeg_scale(s + h)) / (2.0 * h);
            if q > 1 && q != 50 && q < 100 {
                assert!(
                    (num - quality_per_jpeg_scale(q as f64)).abs() < 1e-6,
                    "{q}: {num}"
                );
            }
        }
    }

    #[test]
    fn noise_coordinates_round_trip() {
        for (fw, rn) in [(2000.0, 185.0), (50.0, 0.0), (1e6, 4000.0)] {
            let (a, b) = noise_to_linear(fw, rn);
            let (f2, r2) = noise_from_linear(a, b).unwrap();
            assert!((f2 / fw - 1.0).abs() < 1e-12 && (r2 - rn).abs() < 1e-9 * rn.max(1.0));
        }
        assert!(noise_from_linear(-1.0, 0.0).is_none());
    }
}
