//! The footage's sharpening (pure): the unsharp mask `v + amount·(v − G_σ ∗ v)` that a phone's
//! image processor applies after its tone curve, measured on the marker's straight edges.
//!
//! Method: the edge-profile fit (`imagestats::edge`) models the blurred, pixel-integrated step
//! with free levels, position and blur σ; given a mask it models the sharpened step
//! (1 + a)·R(σ) − a·R(√(σ² + σ_m²)), which has the halo — a bright rim on the light side, a
//! dark one on the ink side — that no blur has. The mask (a, σ_m) is the one that minimises the
//! edges' total squared residual with every edge refitted: for each σ_m of a grid, a golden
//! section in a; then σ_m refined about the best at its a. Its standard error comes from the
//! cost's curvature in a (residual variance s² = cost / (n − p), var(a) = 2s² / ∂²cost/∂a²).
//!
//! A mask is reported when it is worth drawing and told from the noise: a ≥ [`MIN_AMOUNT`],
//! a ≥ [`Z_AMOUNT`] standard errors, and the residual RMS down by ≥ [`MIN_RMS_GAIN`] (on
//! uncompressed and JPEG footage of this project's renderer without a mask, the best a stays
//! below 0.06 and the RMS gain below 1 %; see the tests).

use crate::imagestats::EdgeSharpening;
use crate::numeric::minimize::golden_section_min;

/// Smallest mask reported: below it, an edge's halo is under 2 % of its contrast.
pub const MIN_AMOUNT: f64 = 0.1;
/// Standard errors the amount must stand above zero.
pub const Z_AMOUNT: f64 = 5.0;
/// Relative drop of the edges' residual RMS the mask must bring.
pub const MIN_RMS_GAIN: f64 = 0.03;
/// The mask's σ grid, px, and the amount's search range.
const SIGMA_GRID_PX: [f64; 6] = [0.5, 0.7, 1.0, 1.4, 2.0, 2.8];
const MAX_AMOUNT: f64 = 3.0;
const GOLDEN_STEPS: usize = 14;

/// The edges' fit under one mask: Σ residual², samples, free parameters (per edge: position,
/// tilt, σ and its levels), edges fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeCost {
    pub ss_dn2: f64,
    pub samples: usize,
    pub parameters: usize,
    pub edges: usize,
}

/// The measured mask.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SharpeningFit {
    pub amount: f64,
    pub amount_se: f64,
    pub sigma_px: f64,
    /// Residual RMS of the edges without a mask and with this one, DN.
    pub rms_without_dn: f64,
    pub rms_with_dn: f64,
    pub edges: usize,
    /// Whether it passes [`MIN_AMOUNT`], [`Z_AMOUNT`] and [`MIN_RMS_GAIN`].
    pub significant: bool,
}

impl SharpeningFit {
    pub fn mask(&self) -> EdgeSharpening {
        EdgeSharpening {
            amount: self.amount,
            sigma_px: self.sigma_px,
        }
    }

    /// One line for the calibration's notes.
    pub fn describe(&self) -> String {
        format!(
            "unsharp mask {:.3} ± {:.3} (σ {:.2} px) on {} edges: residual RMS {:.2} → {:.2} DN",
            self.amount,
            1.96 * self.amount_se,
            self.sigma_px,
            self.edges,
            self.rms_without_dn,
            self.rms_with_dn
        )
    }
}

/// The mask that fits the edges best, `cost(None)` being the fit without one; `None` when the
/// edges cannot be fitted.
pub fn fit_sharpening(
    cost: &(dyn Fn(Option<EdgeSharpening>) -> Option<EdgeCost> + Sync),
) -> Option<SharpeningFit> {
    let plain = cost(None)?;
    let ss = |amount: f64, sigma_px: f64| -> f64 {
        let mask = (amount > 0.0).then_some(EdgeSharpening { amount, sigma_px });
        cost(mask)
            .filter(|c| c.edges == plain.edges)
            .map_or(f64::INFINITY, |c| c.ss_dn2)
    };
    let best_amount =
        |sigma_px: f64| golden_section_min(|a| ss(a, sigma_px), 0.0, MAX_AMOUNT, GOLDEN_STEPS);
    let mut best = (plain.ss_dn2, 0.0, SIGMA_GRID_PX[0], 0usize);
    for (i, &s) in SIGMA_GRID_PX.iter().enumerate() {
        let a = best_amount(s);
        let c = ss(a, s);
        if c < best.0 {
            best = (c, a, s, i);
        }
    }
    let (_, mut amount, mut sigma_px, i) = best;
    if amount > 0.0 {
        let lo = SIGMA_GRID_PX[i.saturating_sub(1)];
        let hi = SIGMA_GRID_PX[(i + 1).min(SIGMA_GRID_PX.len() - 1)];
        sigma_px = golden_section_min(|s| ss(amount, s), lo, hi, GOLDEN_STEPS);
        amount = best_amount(sigma_px);
    }
    let with = ss(amount, sigma_px);
    let (with, amount) = if with < plain.ss_dn2 {
        (with, amount)
    } else {
        (plain.ss_dn2, 0.0)
    };
    let dof = plain.samples.saturating_sub(plain.parameters + 2).max(1) as f64;
    let s2 = with / dof;
    let h = 0.02;
    let curvature =
        (ss(amount + h, sigma_px) - 2.0 * with + ss((amount - h).max(0.0), sigma_px)) / (h * h);
    let amount_se = if curvature > 0.0 && curvature.is_finite() {
        (2.0 * s2 / curvature).sqrt()
    } else {
        f64::INFINITY
    };
    let n = plain.samples.max(1) as f64;
    let (rms_without_dn, rms_with_dn) = ((plain.ss_dn2 / n).sqrt(), (with / n).sqrt());
    let significant = amount >= MIN_AMOUNT
        && amount >= Z_AMOUNT * amount_se
        && rms_with_dn <= (1.0 - MIN_RMS_GAIN) * rms_without_dn;
    Some(SharpeningFit {
        amount,
        amount_se,
        sigma_px,
        rms_without_dn,
        rms_with_dn,
        edges: plain.edges,
        significant,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Edges whose squared residual is n·σ² at the truth and grows quadratically away from it.
    fn bowl(
        truth: Option<(f64, f64)>,
    ) -> impl Fn(Option<EdgeSharpening>) -> Option<EdgeCost> + Sync {
        move |mask: Option<EdgeSharpening>| {
            let (a, s) = mask.map_or((0.0, 1.0), |m| (m.amount, m.sigma_px));
            let (ta, ts) = truth.unwrap_or((0.0, 1.0));
            // The mask's σ only matters as far as there is a mask.
            let miss = (a - ta).powi(2) + (a.min(ta) * (s - ts)).powi(2);
            Some(EdgeCost {
                ss_dn2: 4000.0 * 4.0 + 2.0e5 * miss,
                samples: 4000,
                parameters: 24,
                edges: 4,
            })
        }
    }

    #[test]
    fn the_mask_that_fits_the_edges_best_is_found_and_reported() {
        let fit = fit_sharpening(&bowl(Some((0.65, 1.3)))).expect("fits");
        assert!((fit.amount - 0.65).abs() < 0.01, "{fit:?}");
        assert!((fit.sigma_px - 1.3).abs() < 0.02, "{fit:?}");
        assert!(fit.significant, "{fit:?}");
        // The curvature is 2·2e5 in the amount: se = √(2·s²/4e5) with s² = 16000/3974.
        let want_se = (2.0 * 16000.0 / 3974.0 / 4.0e5f64).sqrt();
        assert!(
            (fit.amount_se / want_se - 1.0).abs() < 0.05,
            "{fit:?} vs {want_se}"
        );
        assert!(fit.rms_with_dn < 0.97 * fit.rms_without_dn);
    }

    #[test]
    fn edges_without_a_mask_get_none_that_counts() {
        let fit = fit_sharpening(&bowl(None)).expect("fits");
        assert!(fit.amount < MIN_AMOUNT, "{fit:?}");
        assert!(!fit.significant, "{fit:?}");
        // A small mask that barely changes the residual is not reported either.
        let weak = |mask: Option<EdgeSharpening>| {
            let a = mask.map_or(0.0, |m| m.amount);
            Some(EdgeCost {
                ss_dn2: 16000.0 + 100.0 * ((a - 0.3).powi(2) / 0.09 - 1.0),
                samples: 4000,
                parameters: 24,
                edges: 4,
            })
        };
        let fit = fit_sharpening(&weak).expect("fits");
        assert!((fit.amount - 0.3).abs() < 0.02, "{fit:?}");
        assert!(!fit.significant, "a 0.3 % drop of the RMS: {fit:?}");
        // Edges that cannot be fitted give no answer.
        assert_eq!(fit_sharpening(&|_| None), None);
    }
}
