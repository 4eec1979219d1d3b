//! The held-out check of the candidate a verdict rests on ([`crate::diagnose::holdout`]): its
//! prediction of the slow angle residual, simulated on the evaluation seeds beside the nominal's,
//! against the footage's.

use super::fit::Fitter;
use super::simulate::{trial_theta_residuals, FrameSeries};
use super::{DiagnoseError, Ranked};
use crate::diagnose::holdout::{slow_waveform_check, Series, WaveformCheck};
use crate::scenario::effects::Effect;

/// What the held-out check found for the candidate a verdict rests on.
#[derive(Debug, Clone, PartialEq)]
pub enum HeldOut {
    /// Compared ([`WaveformCheck::fails`] says whether the prediction failed).
    Judged(WaveformCheck),
    /// Not compared, and why.
    NotJudged(&'static str),
}

impl HeldOut {
    pub fn fails(&self) -> bool {
        matches!(self, HeldOut::Judged(c) if c.fails())
    }
}

/// Why a candidate with a vibration is not judged.
pub const PHASE_NOT_FITTED: &str =
    "a vibration's fit states no phase, so its slow waveform is not predicted";
/// Why a footage with too few comparable frames is not judged.
pub const TOO_FEW_FRAMES: &str = "too few frames with the marker in the real and simulated footage";

fn view(v: &[FrameSeries]) -> Vec<Series<'_>> {
    v.iter()
        .map(|(t, x)| (t.as_slice(), x.as_slice()))
        .collect()
}

/// The check of `r` (fitted values as judged) on `seeds`, and the simulations it ran.
pub fn check(
    fitter: &Fitter<'_>,
    r: &Ranked,
    seeds: &[u64],
) -> Result<(HeldOut, usize), DiagnoseError> {
    let effects: Vec<Effect> = r.evaluated.effects.iter().map(|f| f.effect).collect();
    if !effects.iter().all(|e| e.predicts_slow_angle()) {
        return Ok((HeldOut::NotJudged(PHASE_NOT_FITTED), 0));
    }
    let applied: Vec<(Effect, Vec<f64>)> = r
        .evaluated
        .effects
        .iter()
        .map(|f| (f.effect, f.values.clone()))
        .collect();
    let candidate = trial_theta_residuals(&fitter.ctx, &fitter.trial_with(&applied)?, seeds)?;
    let nominal = trial_theta_residuals(&fitter.ctx, &fitter.base, seeds)?;
    let found = slow_waveform_check(
        (fitter.real_t_s, fitter.real_theta_residual),
        &view(&nominal),
        &view(&candidate),
        fitter.ctx.nyquist_hz,
    );
    let held_out = found.map_or(HeldOut::NotJudged(TOO_FEW_FRAMES), HeldOut::Judged);
    Ok((held_out, 2 * seeds.len()))
}
