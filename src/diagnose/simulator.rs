//! The seam between the diagnosis engine and the measurement chain: a [`Simulator`] renders a
//! scenario's frames and detects the marker in them, giving the same [`Record`] the real footage
//! gives. The engine (alignment, trials, fits) calls it and nothing else of the chain, so it
//! stays free of OpenCV; `pipeline::diagnose::simulate` implements it with render → detect.

use super::record::Record;
use crate::imagestats::MarkerLayout;
use crate::scenario::Scenario;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Renders and detects every frame of a scenario.
pub trait Simulator: Sync {
    /// Every frame of `scenario` (seeded by its `seed`) rendered and detected, in frame order;
    /// with each detected frame's image statistics around the marker (as `layout` places them)
    /// when `with_images`.
    fn record(
        &self,
        scenario: &Scenario,
        layout: &MarkerLayout,
        with_images: bool,
    ) -> Result<Record, SimulateError>;
}

/// Why a simulation gave no measurement. The chain's own error is the source, boxed: the
/// engine does not know which chain runs underneath.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    #[error("simulating the nominal: its rig")]
    Rig(#[source] Box<dyn std::error::Error + Send + Sync>),
    #[error("simulating the nominal: rendering and detecting its frames")]
    Frames(#[source] Box<dyn std::error::Error + Send + Sync>),
    #[error("estimating the simulated measurement")]
    Estimate(#[source] crate::estimate::EstimateError),
}

/// How many simulations a diagnosis has run and how many it still plans, read by a progress
/// display while the work runs on other threads. It only counts: no result depends on it.
#[derive(Debug, Default)]
pub struct SimMeter {
    done: AtomicUsize,
    planned: AtomicUsize,
}

impl SimMeter {
    /// Simulations run so far.
    pub fn done(&self) -> usize {
        self.done.load(Ordering::Relaxed)
    }

    /// Simulations the diagnosis expects to run in all, those done included (never fewer than
    /// those done): revised as it decides what to fit.
    pub fn planned(&self) -> usize {
        self.planned.load(Ordering::Relaxed).max(self.done())
    }

    /// States that `more` simulations are planned beyond those run so far.
    pub fn plan_more(&self, more: usize) {
        self.planned.store(self.done() + more, Ordering::Relaxed);
    }

    pub(crate) fn count(&self, n: usize) {
        self.done.fetch_add(n, Ordering::Relaxed);
    }
}
