//! Error budgets: where truth meets measurement. The resolvable truth (what the frames can
//! follow), statistics of measured-minus-true series per signal and motion phase, Monte Carlo
//! aggregation over seeds, per-source variance decomposition and the analytic bounds they are
//! compared with. Pure: numbers in, numbers out.

pub mod bounds;
pub mod compare;
pub mod decompose;
pub mod detectability;
pub mod error_bars;
pub mod judge;
pub mod montecarlo;
pub mod report;
pub mod resolvable;
pub mod stats;

pub use bounds::{
    half_pixel_bound, predict_noise, Exceedance, HalfPixelBound, LinearWeights, NoisePrediction,
};
pub use decompose::{decompose, Decomposition, PairedRuns};
pub use montecarlo::MeanCi;
pub use stats::ErrorStats;
