//! The held-out check run over a diagnosis's candidates ([`super`] compares): each
//! candidate's prediction of the slow angle residual, simulated on the evaluation seeds beside
//! the nominal's, against the footage's.

use super::{slow_waveform_check, Series, WaveformCheck};
use crate::diagnose::fit::{applied, Evaluated, FitError, Fitter};
use crate::diagnose::trials::{trial_theta_residuals, FrameSeries};
use std::cell::OnceCell;

/// What the held-out check found for one candidate.
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

/// Checks the candidates of one diagnosis as the verdict tries them, and keeps what it found:
/// each check, the simulations run and the first error. The nominal's residuals are simulated
/// once, at the first check that needs them.
pub struct Judge<'f, 'a> {
    fitter: &'f Fitter<'a>,
    nominal: OnceCell<Vec<FrameSeries>>,
    checked: Vec<(usize, HeldOut)>,
    simulations: usize,
    error: Option<FitError>,
}

impl<'f, 'a> Judge<'f, 'a> {
    /// A judge simulating on `fitter`'s evaluation seeds.
    pub fn new(fitter: &'f Fitter<'a>) -> Self {
        Judge {
            fitter,
            nominal: OnceCell::new(),
            checked: Vec::new(),
            simulations: 0,
            error: None,
        }
    }

    /// Checks candidate `i` of the ranking, `r` (its fitted values as judged), and returns its
    /// check when it failed (`None`: passed, not judged, or a simulation failed, which
    /// [`Judge::finish`] reports; after an error nothing more is simulated).
    pub fn failed(&mut self, i: usize, r: &Evaluated) -> Option<HeldOut> {
        if self.error.is_some() {
            return None;
        }
        match self.check(r) {
            Ok((check, simulations)) => {
                self.simulations += simulations;
                self.checked.push((i, check.clone()));
                check.fails().then_some(check)
            }
            Err(e) => {
                self.error = Some(e);
                None
            }
        }
    }

    /// The check of candidate `best` (when it was checked) and the simulations all checks ran,
    /// or the first error a check met.
    pub fn finish(self, best: Option<usize>) -> Result<(Option<HeldOut>, usize), FitError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        let check = best.and_then(|b| {
            self.checked
                .into_iter()
                .find(|(i, _)| *i == b)
                .map(|(_, h)| h)
        });
        Ok((check, self.simulations))
    }

    /// The check of `r` (its fitted values as judged), and the simulations it ran.
    fn check(&self, r: &Evaluated) -> Result<(HeldOut, usize), FitError> {
        if !r.effects.iter().all(|f| f.effect.predicts_slow_angle()) {
            return Ok((HeldOut::NotJudged(PHASE_NOT_FITTED), 0));
        }
        let f = self.fitter;
        let seeds = &f.eval_seeds;
        let trial = f.trial_with(&applied(&r.effects))?;
        let candidate = trial_theta_residuals(&f.ctx, &trial, seeds)?;
        let mut simulations = seeds.len();
        if self.nominal.get().is_none() {
            let nominal = trial_theta_residuals(&f.ctx, &f.base, seeds)?;
            simulations += seeds.len();
            let _ = self.nominal.set(nominal);
        }
        let nominal = self.nominal.get().map(Vec::as_slice).unwrap_or_default();
        let found = slow_waveform_check(
            (f.real.t_s, f.real.theta_residual),
            &view(nominal),
            &view(&candidate),
            f.ctx.nyquist_hz,
        );
        let held_out = found.map_or(HeldOut::NotJudged(TOO_FEW_FRAMES), HeldOut::Judged);
        Ok((held_out, simulations))
    }
}

fn view(v: &[FrameSeries]) -> Vec<Series<'_>> {
    v.iter()
        .map(|(t, x)| (t.as_slice(), x.as_slice()))
        .collect()
}
