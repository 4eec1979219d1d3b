//! The curves of `residuals_before_after.png`: the real measurement's angle and ω residuals
//! after the aligned nominal motion, beside those of the aligned nominal and of the best
//! candidate, each simulated on the diagnosis's first seed. The simulations run here, with the
//! diagnosis's fitter, so that [`super::report`] only draws what it is given.

use super::{candidate_name, DiagnoseError, Diagnosis};
use crate::diagnose::fit::Fitter;
use crate::diagnose::nominal;
use crate::diagnose::record::{RealMeasurement, Record};
use crate::diagnose::trials::{estimate_record, Trial};
use crate::estimate::Estimate;
use crate::scenario::Scenario;

/// A record's residuals after the aligned nominal motion, at its frame times.
#[derive(Debug, Clone, PartialEq)]
pub struct Residuals {
    pub t_s: Vec<f64>,
    pub theta_rad: Vec<f64>,
    pub omega_rad_s: Vec<f64>,
}

/// The real measurement's residuals and the simulated ones to compare them with.
#[derive(Debug, Clone, PartialEq)]
pub struct Overlay {
    pub real: Residuals,
    /// The aligned nominal on the first seed.
    pub nominal: Residuals,
    /// The best candidate's name and its residuals on the first seed, when there is one.
    pub best: Option<(String, Residuals)>,
}

/// The residual curves of `d`: the real measurement's, and the nominal's and the best
/// candidate's simulated on `d`'s first seed with `fitter`.
pub fn overlay(
    d: &Diagnosis,
    fitter: &Fitter<'_>,
    real: &RealMeasurement,
) -> Result<Overlay, DiagnoseError> {
    let seed = d.seeds[0];
    let sim = |trial: &Trial| -> Result<Residuals, DiagnoseError> {
        let mut s = trial.scenario.clone();
        s.seed = seed;
        let mut record = fitter.ctx.simulator.record(&s, fitter.ctx.layout, false)?;
        if let Some(fps) = trial.stamped_fps {
            for (k, f) in record.frames.iter_mut().enumerate() {
                f.t_s = k as f64 / fps;
            }
        }
        residuals(d, &s, &record, None)
    };
    let real = residuals(d, &d.aligned.scenario, &real.record, Some(&real.estimate))?;
    let nominal = sim(&fitter.base)?;
    let best = match d.best {
        Some(b) => {
            let applied = crate::diagnose::fit::applied(&d.ranking[b].evaluated.effects);
            Some((
                candidate_name(&d.ranking[b].evaluated),
                sim(&fitter.trial_with(&applied)?)?,
            ))
        }
        None => None,
    };
    Ok(Overlay {
        real,
        nominal,
        best,
    })
}

/// `record`'s residuals after the aligned motion, from `est` (its estimate) or estimated with
/// `scenario`'s estimator.
fn residuals(
    d: &Diagnosis,
    scenario: &Scenario,
    record: &Record,
    est: Option<&Estimate>,
) -> Result<Residuals, DiagnoseError> {
    let owned;
    let est = match est {
        Some(e) => e,
        None => {
            owned = estimate_record(scenario, record)?;
            &owned
        }
    };
    let (r, _) = nominal::motion_reference(&d.aligned.reference, record, est);
    let p = est.primary_series();
    let minus = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x - y).collect();
    Ok(Residuals {
        t_s: record.t_s(),
        theta_rad: minus(&p.theta_rad, &r.theta_rad),
        omega_rad_s: minus(&p.omega_rad_s, &r.omega_rad_s),
    })
}
