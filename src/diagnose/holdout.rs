//! The held-out check of an explanation: a prediction of what its fit did not use, compared with
//! the footage.
//!
//! Every fit matches cell statistics: band RMS and means per motion phase, magnitudes that say
//! how far the angle departs from the nominal in each phase, not when nor which way. The signed
//! slow angle residual (frame by frame, the slow band of [`super::bands`]: the motion's own time
//! scale) is never fitted. An effect that explains the gap predicts it, up to the seeds' scatter;
//! a flexible candidate that matched the magnitudes of something outside the vocabulary predicts
//! another waveform. A marker creeping on the wheel during each dwell was matched by a crank-speed
//! variation that closed 100 % of the cells; its predicted waveform left most of the footage's.
//!
//! The check compares the real slow residual with the mean simulated one, before (the nominal)
//! and after (the candidate), and states the share of the waveform beyond the seeds' scatter
//! that the candidate leaves:
//!
//! left = (RMS²(real − candidate) − s²) / (RMS²(real − nominal) − s²),
//!
//! with s² the seeds' scatter the real footage shares, mean over frames of var·(1 + 1/N): one
//! real draw against the mean of N. It judges only where the nominal's waveform gap stands out of
//! that scatter ([`GAP_OVER_SCATTER`]); elsewhere the footage holds no waveform to predict.

use super::bands;
use serde::Serialize;

pub mod judge;

/// Largest share of the waveform gap an explanation may leave. A right effect whose value is
/// fitted 30 % off leaves 0.09 of it; a crank-speed variation fitted to a creeping marker's cells
/// left more than half.
pub const LEFT_MAX: f64 = 0.25;

/// The nominal's waveform gap (RMS) must reach this many times the seeds' scatter to be judged.
pub const GAP_OVER_SCATTER: f64 = 3.0;

/// Fewest frames compared.
pub const MIN_FRAMES: usize = 20;

/// A series at frame times: times in s, values (NaN where the marker was not found).
pub type Series<'a> = (&'a [f64], &'a [f64]);

/// The slow angle residual of the footage against the nominal's and a candidate's predictions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WaveformCheck {
    /// Frames compared (real and every simulation finite there).
    pub frames: usize,
    /// RMS of the real slow residual minus the nominal's mean, rad.
    pub nominal_rms_rad: f64,
    /// RMS of the real slow residual minus the candidate's mean, rad.
    pub candidate_rms_rad: f64,
    /// RMS the seeds' scatter leaves between one real draw and the mean of N, rad.
    pub scatter_rms_rad: f64,
    /// Share of the waveform gap beyond the scatter the candidate leaves (0 when it leaves no
    /// more than the scatter); `None` when the nominal's gap does not stand out of the scatter.
    pub left: Option<f64>,
}

impl WaveformCheck {
    /// Whether the candidate fails to predict the waveform it did not fit.
    pub fn fails(&self) -> bool {
        self.left.is_some_and(|l| l > LEFT_MAX)
    }
}

/// The check of a candidate's simulations against the real residual (see the module's
/// documentation). Every series is low-passed to the slow band at its own times and the
/// simulations are then interpolated onto the real frame times. `None` when fewer than
/// [`MIN_FRAMES`] frames can be compared or fewer than two seeds were simulated on either side.
pub fn slow_waveform_check(
    real: Series<'_>,
    nominal: &[Series<'_>],
    candidate: &[Series<'_>],
    nyquist_hz: f64,
) -> Option<WaveformCheck> {
    if nominal.len() < 2 || candidate.len() < 2 {
        return None;
    }
    let sigma_s = bands::gaussian_sigma_for_cutoff_s(bands::band_edges_hz(nyquist_hz)[0][1]);
    let real_t = real.0;
    let slow = |(t, x): Series<'_>| bands::smooth(t, x, sigma_s);
    let onto_real = |s: Series<'_>| interpolate(s.0, &slow(s), real_t);
    let r = slow(real);
    let nom: Vec<Vec<f64>> = nominal.iter().map(|&s| onto_real(s)).collect();
    let cand: Vec<Vec<f64>> = candidate.iter().map(|&s| onto_real(s)).collect();
    let (mut n, mut before2, mut after2, mut var) = (0usize, 0.0, 0.0, 0.0);
    for (i, &ri) in r.iter().enumerate() {
        let (Some((mn, _)), Some((mc, vc))) = (mean_var(&nom, i), mean_var(&cand, i)) else {
            continue;
        };
        if !ri.is_finite() {
            continue;
        }
        n += 1;
        before2 += (ri - mn).powi(2);
        after2 += (ri - mc).powi(2);
        var += vc;
    }
    if n < MIN_FRAMES {
        return None;
    }
    let k = cand.len() as f64;
    let (before2, after2) = (before2 / n as f64, after2 / n as f64);
    let scatter2 = var / n as f64 * (1.0 + 1.0 / k);
    let left = (before2 >= GAP_OVER_SCATTER.powi(2) * scatter2)
        .then(|| ((after2 - scatter2) / (before2 - scatter2)).max(0.0));
    Some(WaveformCheck {
        frames: n,
        nominal_rms_rad: before2.sqrt(),
        candidate_rms_rad: after2.sqrt(),
        scatter_rms_rad: scatter2.sqrt(),
        left,
    })
}

/// Mean and sample variance over the series of frame `i` (`None` when one is not finite there).
fn mean_var(series: &[Vec<f64>], i: usize) -> Option<(f64, f64)> {
    let v: Vec<f64> = series
        .iter()
        .map(|s| s.get(i).copied())
        .collect::<Option<_>>()?;
    if v.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let k = v.len() as f64;
    let m = v.iter().sum::<f64>() / k;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (k - 1.0).max(1.0);
    Some((m, var))
}

/// `x` at times `t_s`, linearly interpolated at `at_s` (both in increasing order); NaN outside
/// `t_s` or where a neighbour is NaN.
fn interpolate(t_s: &[f64], x: &[f64], at_s: &[f64]) -> Vec<f64> {
    at_s.iter()
        .map(|&t| {
            let j = t_s.partition_point(|&s| s < t);
            if j < t_s.len() && t_s[j] == t {
                return x[j];
            }
            if j == 0 || j >= t_s.len() {
                return f64::NAN;
            }
            let (t0, t1) = (t_s[j - 1], t_s[j]);
            let w = (t - t0) / (t1 - t0);
            x[j - 1] * (1.0 - w) + x[j] * w
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    const NYQUIST_HZ: f64 = 15.0;

    fn times(n: usize) -> Vec<f64> {
        (0..n).map(|k| k as f64 / 30.0).collect()
    }

    /// A deterministic stand-in for seed noise: a fast wobble that survives the slow band a
    /// little, different per seed.
    fn noisy(t: &[f64], wave: impl Fn(f64) -> f64, seed: u64) -> Vec<f64> {
        t.iter()
            .enumerate()
            .map(|(k, &s)| {
                let h = (k as u64 + 1)
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(seed.wrapping_mul(1442695040888963407));
                let u = (h >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                wave(s) + 2e-4 * u + 1e-4 * (TAU * 0.2 * s + seed as f64).sin()
            })
            .collect()
    }

    fn check(real: impl Fn(f64) -> f64, cand: impl Fn(f64) -> f64 + Copy) -> WaveformCheck {
        let t = times(240);
        let r = noisy(&t, real, 99);
        let nom: Vec<Vec<f64>> = (0..4).map(|s| noisy(&t, |_| 0.0, s)).collect();
        let can: Vec<Vec<f64>> = (0..4).map(|s| noisy(&t, cand, s + 10)).collect();
        let series = |v: &[Vec<f64>]| -> Vec<Vec<f64>> { v.to_vec() };
        let (nom, can) = (series(&nom), series(&can));
        let nom: Vec<Series<'_>> = nom.iter().map(|x| (t.as_slice(), x.as_slice())).collect();
        let can: Vec<Series<'_>> = can.iter().map(|x| (t.as_slice(), x.as_slice())).collect();
        slow_waveform_check((&t, &r), &nom, &can, NYQUIST_HZ).unwrap()
    }

    #[test]
    fn the_right_waveform_leaves_nothing_and_passes() {
        let wave = |s: f64| 0.01 * (TAU * 0.25 * s).sin();
        let c = check(wave, wave);
        assert!(c.left.is_some_and(|l| l < 0.01), "{c:?}");
        assert!(!c.fails());
        assert!(
            c.nominal_rms_rad > 0.006 && c.candidate_rms_rad < 1e-3,
            "{c:?}"
        );
    }

    #[test]
    fn a_waveform_of_the_right_size_and_the_wrong_shape_fails() {
        // The same RMS in every part of the footage (what the cells compare), another waveform:
        // a ramp that resets (a creep caught up by the alignment) against a sinusoid.
        let saw = |s: f64| 0.0173 * 2.0 * ((s / 2.0).fract() - 0.5);
        let sine = |s: f64| 0.01 * (TAU * 0.25 * s).sin();
        let c = check(saw, sine);
        assert!(c.fails(), "{c:?}");
        assert!(c.left.unwrap() > 0.5, "{c:?}");
    }

    #[test]
    fn a_value_fitted_thirty_per_cent_off_still_passes() {
        let wave = |s: f64| 0.01 * (TAU * 0.25 * s).sin();
        let c = check(wave, |s| 0.7 * wave(s));
        let left = c.left.unwrap();
        assert!((left - 0.09).abs() < 0.02 && !c.fails(), "{c:?}");
    }

    #[test]
    fn no_waveform_beyond_the_scatter_is_not_judged() {
        let c = check(|_| 0.0, |s| 0.01 * (TAU * 0.25 * s).sin());
        assert_eq!(c.left, None, "{c:?}");
        assert!(!c.fails());
    }

    #[test]
    fn simulations_on_another_schedule_are_compared_at_the_real_times() {
        let t = times(240);
        let wave = |s: f64| 0.01 * (TAU * 0.25 * s).sin();
        let r: Vec<f64> = t.iter().map(|&s| wave(s)).collect();
        // Simulated at 25 fps, shifted by a third of a frame: interpolated onto the real times.
        let ts: Vec<f64> = (0..200).map(|k| k as f64 / 25.0 + 0.013).collect();
        let sims: Vec<Vec<f64>> = (0..3)
            .map(|s| ts.iter().map(|&u| wave(u) + 1e-5 * s as f64).collect())
            .collect();
        let zeros: Vec<Vec<f64>> = (0..3)
            .map(|s| ts.iter().map(|_| 1e-5 * s as f64).collect())
            .collect();
        let as_series = |v: &[Vec<f64>]| -> Vec<Vec<f64>> { v.to_vec() };
        let (sims, zeros) = (as_series(&sims), as_series(&zeros));
        let c = slow_waveform_check(
            (&t, &r),
            &zeros
                .iter()
                .map(|x| (ts.as_slice(), x.as_slice()))
                .collect::<Vec<_>>(),
            &sims
                .iter()
                .map(|x| (ts.as_slice(), x.as_slice()))
                .collect::<Vec<_>>(),
            NYQUIST_HZ,
        )
        .unwrap();
        // The real frames outside the simulated span are not compared.
        assert!(c.frames < 240 && c.frames > 200, "{c:?}");
        assert!(c.left.unwrap() < 0.01, "{c:?}");
    }

    #[test]
    fn undetected_frames_and_too_few_seeds_are_handled() {
        let t = times(240);
        let mut r: Vec<f64> = t.iter().map(|&s| 0.01 * (TAU * 0.25 * s).sin()).collect();
        for x in r.iter_mut().skip(100).take(30) {
            *x = f64::NAN;
        }
        let z = vec![0.0; 240];
        let one = [(t.as_slice(), z.as_slice())];
        assert_eq!(slow_waveform_check((&t, &r), &one, &one, NYQUIST_HZ), None);
        let two = [(t.as_slice(), z.as_slice()), (t.as_slice(), z.as_slice())];
        let c = slow_waveform_check((&t, &r), &two, &two, NYQUIST_HZ).unwrap();
        assert_eq!(c.frames, 210);
        assert!(interpolate(&[0.0, 1.0], &[0.0, f64::NAN], &[0.5])[0].is_nan());
        assert_eq!(
            interpolate(&[0.0, 1.0], &[0.0, 2.0], &[0.25, 1.0, 1.5])[..2],
            [0.5, 2.0]
        );
    }
}
