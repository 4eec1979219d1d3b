//! Per-source decomposition of an error variance.
//!
//! Runs: `none` (no optional effect), `all` (every effect), each effect `alone`, and each effect
//! `left out`. The *alone* contribution of effect k is V(k alone) − V(none); the *left-out*
//! contribution is V(all) − V(all without k). Shares are alone contributions as a fraction of
//! V(all) − V(none); the interaction is what the alone contributions do not explain, so
//! Σ shares + interaction = 1 exactly (by construction, and tested).

use serde::{Deserialize, Serialize};

/// Variances measured for one quantity (ω2 or α2 error), in (unit)².
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VarianceRuns {
    pub none: f64,
    pub all: f64,
    /// (effect name, variance with only this effect on)
    pub alone: Vec<(String, f64)>,
    /// (effect name, variance with every effect but this one)
    pub left_out: Vec<(String, f64)>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SourceShare {
    pub effect: String,
    /// V(alone) − V(none)
    pub alone_contribution: f64,
    /// V(all) − V(all without it)
    pub left_out_contribution: f64,
    /// alone contribution / (V(all) − V(none))
    pub share: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Decomposition {
    pub total_added_variance: f64,
    pub sources: Vec<SourceShare>,
    /// 1 − Σ shares: the part of the variance that comes from effects acting together.
    pub interaction_share: f64,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DecomposeError {
    #[error("effect `{0}` has an `alone` run but no `left out` run")]
    Unpaired(String),
    #[error("non-finite variance for `{0}`")]
    NonFinite(String),
}

pub fn decompose(runs: &VarianceRuns) -> Result<Decomposition, DecomposeError> {
    for (name, v) in [("none", runs.none), ("all", runs.all)] {
        if !v.is_finite() {
            return Err(DecomposeError::NonFinite(name.into()));
        }
    }
    let total = runs.all - runs.none;
    let mut sources = Vec::new();
    for (name, v_alone) in &runs.alone {
        let v_out = runs
            .left_out
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
            .ok_or_else(|| DecomposeError::Unpaired(name.clone()))?;
        if !v_alone.is_finite() || !v_out.is_finite() {
            return Err(DecomposeError::NonFinite(name.clone()));
        }
        let alone = v_alone - runs.none;
        sources.push(SourceShare {
            effect: name.clone(),
            alone_contribution: alone,
            left_out_contribution: runs.all - v_out,
            share: if total != 0.0 { alone / total } else { 0.0 },
        });
    }
    let interaction_share = 1.0 - sources.iter().map(|s| s.share).sum::<f64>();
    Ok(Decomposition {
        total_added_variance: total,
        sources,
        interaction_share,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn independent_sources_have_no_interaction() {
        // Independent additive sources: variances add, so the interaction is zero.
        let (v0, a, b) = (0.1, 2.0, 6.0);
        let runs = VarianceRuns {
            none: v0,
            all: v0 + a + b,
            alone: vec![("noise".into(), v0 + a), ("blur".into(), v0 + b)],
            left_out: vec![("noise".into(), v0 + b), ("blur".into(), v0 + a)],
        };
        let d = decompose(&runs).unwrap();
        assert!((d.sources[0].share - 0.25).abs() < 1e-12);
        assert!((d.sources[1].share - 0.75).abs() < 1e-12);
        assert!(d.interaction_share.abs() < 1e-12);
        assert!((d.sources[0].left_out_contribution - a).abs() < 1e-12);
    }

    #[test]
    fn missing_pair_is_an_error() {
        let runs = VarianceRuns {
            none: 0.0,
            all: 1.0,
            alone: vec![("x".into(), 0.5)],
            left_out: vec![],
        };
        assert_eq!(
            decompose(&runs).unwrap_err(),
            DecomposeError::Unpaired("x".into())
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn shares_and_interaction_sum_to_one(v0 in 0.0f64..1.0, parts in proptest::collection::vec(0.01f64..10.0, 1..6), extra in -1.0f64..5.0) {
            let sum: f64 = parts.iter().sum();
            let all = v0 + sum + extra.max(-0.5 * sum);
            let runs = VarianceRuns {
                none: v0,
                all,
                alone: parts.iter().enumerate().map(|(i, p)| (format!("e{i}"), v0 + p)).collect(),
                left_out: parts.iter().enumerate().map(|(i, p)| (format!("e{i}"), all - p)).collect(),
            };
            let d = decompose(&runs).unwrap();
            let total: f64 = d.sources.iter().map(|s| s.share).sum::<f64>() + d.interaction_share;
            prop_assert!((total - 1.0).abs() < 1e-9);
        }
    }
}
