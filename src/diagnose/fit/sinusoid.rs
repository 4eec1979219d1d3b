//! A disc vibration fitted as a sinusoid: its frequency from the angle residual's peak, its
//! amplitude and phase from the residual's sinusoid at that frequency matched to the footage's
//! through a gain measured on the fit seeds and placements derived from them.

use super::{FitError, Fitter};
use crate::diagnose::plan;
use crate::diagnose::spectrum;
use crate::diagnose::trials::trial_theta_residuals;
use crate::scenario::effects::Effect;

/// The frequency a disc-vibration fit starts from: the peak of the angle residual after the
/// aligned nominal motion (`residual_peak_hz`, clamped to the search range `search_hz`), or,
/// only when that residual shows none, the peak above a smooth trend (`trend_peak_hz`).
pub(super) fn vibration_start_hz(
    residual_peak_hz: Option<f64>,
    search_hz: (f64, f64),
    trend_peak_hz: impl FnOnce() -> Option<f64>,
) -> Option<f64> {
    match residual_peak_hz {
        Some(f) if f.is_finite() => Some(f.clamp(search_hz.0, search_hz.1)),
        _ => trend_peak_hz(),
    }
}

/// The sinusoid A·sin(ωt + φ) as its complex amplitude (A cos φ, A sin φ): its sin and cos
/// coefficients.
fn complex(amplitude: f64, phase_rad: f64) -> [f64; 2] {
    [amplitude * phase_rad.cos(), amplitude * phase_rad.sin()]
}

/// Placements (simulation seeds, each with its own sub-pixel placement) a vibration's gain is
/// measured on ([`spectrum::invert_through_gain`]): its spread from one placement to the next
/// is part of the amplitude's ±, so it needs more draws than a fit's few seeds give it (with
/// 2, its sd rests on one degree of freedom). The 12 more simulations of the angle alone cost
/// about 7 s per fit of 180 frames on a 2-core host.
pub const GAIN_PLACEMENTS: usize = 8;

/// Offset between the fit seeds and the further placement seeds derived from them: far above
/// any seed the diagnosis draws otherwise, so a refit's set stays disjoint from the others'.
const PLACEMENT_SEED_STRIDE: u64 = 1 << 40;

/// The fit seeds, then seeds derived from them (each fit seed plus a multiple of
/// [`PLACEMENT_SEED_STRIDE`], in turn) up to [`GAIN_PLACEMENTS`] in all: disjoint fit-seed sets
/// give disjoint placement sets.
pub fn gain_placement_seeds(fit_seeds: &[u64]) -> Vec<u64> {
    let n = fit_seeds.len();
    (0..GAIN_PLACEMENTS.max(n))
        .filter_map(|k| {
            let round = (k / n.max(1)) as u64;
            let seed = fit_seeds.get(k % n.max(1))?;
            Some(seed.wrapping_add(round.wrapping_mul(PLACEMENT_SEED_STRIDE)))
        })
        .collect()
}

impl Fitter<'_> {
    /// The disc vibration from the sinusoid at its frequency in the angle residual
    /// ([`spectrum::sinusoid_fit`]), its frequency refined on the real residual around `start`'s.
    /// The residual's sinusoid is a complex amplitude c (amplitude and phase), linear in the
    /// vibration's: c(A) = c₀ + h·A, where c₀ is what the residual holds at that frequency with no
    /// vibration (the motion's own content there, which adds to the vibration with its phase)
    /// and h the pipeline's complex gain. Simulations at A = 0 and at the footage's amplitude on
    /// [`GAIN_PLACEMENTS`] seeds (the fit seeds first), each its own sub-pixel placement, give
    /// c₀ and h (common random numbers), and the footage's c then gives A = |(c − c₀) / h|, with
    /// the gain's spread over the placements in its ± ([`spectrum::invert_through_gain`]: the
    /// gain of an unrefined detector to a sub-pixel motion depends on the placement, and the
    /// footage's is one of them). `None` when the residual
    /// gives no sinusoid, the gain vanishes or A leaves its search range (the caller then
    /// searches Σ z²).
    ///
    /// Σ z² over the angle's bands matches band power, which also holds the detector's error:
    /// footage whose detection error is smaller than the simulation's (another renderer's edges,
    /// a sharper lens) then takes part of the vibration for noise. On the independent
    /// renderer's footage that fitted a 2 mrad vibration at 1.37 mrad. A sinusoid's
    /// least-squares amplitude holds only the error at its own frequency.
    #[allow(clippy::type_complexity)] // (values, stds, method), as in `Fitted`
    pub(super) fn disc_vibration_by_sinusoid(
        &self,
        prior: &[(Effect, Vec<f64>)],
        start: &[f64],
    ) -> Result<Option<(Vec<f64>, Vec<f64>, String)>, FitError> {
        let e = Effect::DiscVibration;
        let (t, residual) = (self.real.t_s, self.real.theta_residual);
        let span_s = match (t.first(), t.last()) {
            (Some(a), Some(b)) if b > a => b - a,
            _ => return Ok(None),
        };
        // A periodogram bin is 1/(4 T): refine within two of them.
        let Some(real) = spectrum::sinusoid_fit_refined(t, residual, start[1], 0.5 / span_s)
            .filter(|r| r.amplitude > 0.0 && r.frequency_hz < self.ctx.nyquist_hz)
        else {
            return Ok(None);
        };
        let f = real.frequency_hz;
        let (lo, hi) = e.params()[0].search;
        let probe = real.amplitude.clamp(lo, hi);
        let seeds = gain_placement_seeds(&self.fit_seeds);
        // Complex amplitudes (sin, cos coefficients) of the simulations at amplitude `a`, one
        // per placement seed.
        let simulated = |a: f64| -> Result<Option<Vec<[f64; 2]>>, FitError> {
            let mut applied: Vec<(Effect, Vec<f64>)> = prior.to_vec();
            applied.push((e, vec![a, f]));
            let trial = self.trial_with(&applied)?;
            *self.simulations.borrow_mut() += seeds.len();
            let sims = trial_theta_residuals(&self.ctx, &trial, &seeds)?;
            let fits: Vec<[f64; 2]> = sims
                .iter()
                .filter_map(|(t, r)| spectrum::sinusoid_fit(t, r, f))
                .map(|s| complex(s.amplitude, s.phase_rad))
                .collect();
            Ok((fits.len() == sims.len()).then_some(fits))
        };
        let (Some(without), Some(with)) = (simulated(0.0)?, simulated(probe)?) else {
            return Ok(None);
        };
        let c = complex(real.amplitude, real.phase_rad);
        let Some(inv) =
            spectrum::invert_through_gain(c, real.amplitude_std, &without, &with, probe)
        else {
            return Ok(None);
        };
        let gain = inv.gain;
        // A pipeline that passes less than a tenth of the vibration cannot be inverted.
        if gain <= 0.1 {
            return Ok(None);
        }
        let amplitude = inv.amplitude;
        if !(amplitude > lo && amplitude < hi) {
            return Ok(None);
        }
        let sd_amplitude = inv.amplitude_std;
        // Cramér–Rao for a sinusoid's frequency over T s: √6·σ_A / (2π A T).
        let sd_frequency =
            6.0f64.sqrt() * real.amplitude_std / (std::f64::consts::TAU * real.amplitude * span_s);
        let method = format!(
            "amplitude of the sinusoid at {f:.3} Hz in the angle residual (least squares; \
             frequency refined on the footage's residual), inverted through the pipeline's \
             complex gain {gain:.3} (sd {:.3} from one placement on the pixel grid to the next, \
             which the ± holds: the footage's placement is one of them) and the residual's own \
             content there ({:.3} mrad), from simulations at 0 and {:.3} mrad on {} placements \
             (the {} fit seeds and {} more); footage {:.3} ± {:.3} mrad",
            inv.gain_spread,
            1e3 * inv.content_without,
            1e3 * probe,
            seeds.len(),
            self.fit_seeds.len(),
            seeds.len().saturating_sub(self.fit_seeds.len()),
            1e3 * real.amplitude,
            1e3 * real.amplitude_std
        );
        Ok(Some((
            vec![amplitude, f],
            vec![sd_amplitude, sd_frequency],
            method,
        )))
    }

    /// The strongest frequency of the real angle residual above the low band, with its power.
    pub(super) fn theta_peak_hz(&self, nyquist_hz: f64) -> Option<(f64, f64)> {
        let (t, th) = self.real.theta_det;
        // Residual after a smooth trend: the aligned motion is not needed for a peak search.
        let trend = crate::diagnose::bands::smooth(
            t,
            th,
            crate::diagnose::bands::gaussian_sigma_for_cutoff_s(nyquist_hz / 10.0),
        );
        let r: Vec<f64> = th.iter().zip(&trend).map(|(a, b)| a - b).collect();
        plan::dominant_frequency_hz(t, &r, nyquist_hz / 10.0, 0.98 * nyquist_hz, 0.02)
    }

    /// A disc vibration's start frequency (`values[1]`, with a ± of 0.05 Hz in `stds[1]`): the
    /// peak of the angle residual after the aligned nominal motion (the start already holds it,
    /// as the `theta_peak` cell and the sinusoid read it); the peak above a smooth trend only
    /// when that residual shows none. A trend keeps the motion's own harmonics above its cutoff
    /// (Nyquist / 10): on an external drive filmed at 60 fps they outgrew a 7 Hz vibration at
    /// 3.2 Hz, and the sinusoid found nothing there.
    pub(super) fn start_vibration_frequency(
        &self,
        search_hz: (f64, f64),
        values: &mut [f64],
        stds: &mut [f64],
    ) {
        let peak_hz = vibration_start_hz(self.real.theta_peak_hz, search_hz, || {
            self.theta_peak_hz(self.ctx.nyquist_hz).map(|(f, _)| f)
        });
        if let Some(f) = peak_hz {
            values[1] = f;
            stds[1] = 0.05;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_vibrations_gain_is_measured_on_the_fit_seeds_and_placements_derived_from_them(
    ) -> Result<(), String> {
        let a = gain_placement_seeds(&[2007, 2008]);
        let b = gain_placement_seeds(&[3007, 3008]);
        if a.len() != GAIN_PLACEMENTS || a[..2] != [2007, 2008] {
            return Err(format!("{a:?}"));
        }
        let distinct: std::collections::BTreeSet<u64> = a.iter().chain(&b).copied().collect();
        if distinct.len() != 2 * GAIN_PLACEMENTS {
            return Err(format!("not disjoint: {a:?} {b:?}"));
        }
        // More fit seeds than placements: the fit seeds alone; three: 8 from them in turn.
        let many: Vec<u64> = (0..10).collect();
        if gain_placement_seeds(&many) != many || gain_placement_seeds(&[1, 2, 3]).len() != 8 {
            return Err("wrong count".into());
        }
        if !gain_placement_seeds(&[]).is_empty() {
            return Err("seeds from no fit seed".into());
        }
        Ok(())
    }

    #[test]
    fn a_vibrations_frequency_starts_at_the_residuals_peak_not_the_trends() {
        // The trend's peak (the motion's harmonics above its cutoff) is read only when the
        // residual after the aligned motion has no peak.
        let trend_called = std::cell::Cell::new(false);
        let trend = || {
            trend_called.set(true);
            Some(3.2)
        };
        assert_eq!(
            vibration_start_hz(Some(7.0), (0.2, 200.0), trend),
            Some(7.0)
        );
        assert!(!trend_called.get());
        assert_eq!(
            vibration_start_hz(Some(500.0), (0.2, 200.0), || None),
            Some(200.0)
        );
        assert_eq!(
            vibration_start_hz(None, (0.2, 200.0), || Some(3.2)),
            Some(3.2)
        );
        assert_eq!(
            vibration_start_hz(Some(f64::NAN), (0.2, 200.0), || Some(3.2)),
            Some(3.2)
        );
        assert_eq!(vibration_start_hz(None, (0.2, 200.0), || None), None);
    }
}
