//! What a diagnosis still plans to simulate, for a progress display's estimate of the time
//! left: each candidate fit costs what the fits so far cost on average (before any, what one
//! search of the fit seeds and a judgement on the evaluation seeds cost), and the planned
//! total is revised at each decision (candidates bounded out, pairs chosen, the verdict's
//! checks). It steers nothing: no result depends on it.

use crate::diagnose::simulator::SimMeter;

/// Objective evaluations a fit is expected to take before any has run: one search, which stops
/// at 9 (most candidates search one parameter; a moment match takes fewer, a tilt more).
pub const PRIOR_EVALUATIONS_PER_FIT: usize = 9;

/// The simulations of the candidate fits run so far, and the cost a fit is expected to have.
#[derive(Debug, Clone)]
pub struct Outlook {
    prior_per_fit: usize,
    fits: usize,
    fit_simulations: usize,
}

impl Outlook {
    /// No fit yet: one expected to take [`PRIOR_EVALUATIONS_PER_FIT`] evaluations on
    /// `fit_seeds` seeds, then its judgement on `eval_seeds`.
    pub fn new(fit_seeds: usize, eval_seeds: usize) -> Self {
        Self {
            prior_per_fit: PRIOR_EVALUATIONS_PER_FIT * fit_seeds + eval_seeds,
            fits: 0,
            fit_simulations: 0,
        }
    }

    /// A fit that took `simulations`.
    pub fn fitted(&mut self, simulations: usize) {
        self.fits += 1;
        self.fit_simulations += simulations;
    }

    /// Simulations one more fit is expected to take: the mean of those so far (rounded up).
    pub fn per_fit(&self) -> usize {
        if self.fits == 0 {
            self.prior_per_fit
        } else {
            self.fit_simulations.div_ceil(self.fits)
        }
    }

    /// States on `meter` that `fits` more fits and `other` more simulations are planned.
    pub fn plan(&self, meter: &SimMeter, fits: usize, other: usize) {
        meter.plan_more(fits * self.per_fit() + other);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fit_is_expected_to_cost_the_mean_of_those_run() {
        let mut o = Outlook::new(3, 6);
        assert_eq!(o.per_fit(), PRIOR_EVALUATIONS_PER_FIT * 3 + 6);
        o.fitted(20);
        o.fitted(31);
        assert_eq!(o.per_fit(), 26);
        let meter = SimMeter::default();
        o.plan(&meter, 2, 12);
        assert_eq!(meter.planned(), 64);
        assert_eq!(meter.done(), 0);
    }
}
