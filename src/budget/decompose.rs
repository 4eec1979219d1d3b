//! Per-source decomposition of a mean square error, with 95 % confidence intervals from paired
//! seeds (common random numbers).
//!
//! Configurations: `none` (no optional effect: what is left is the quantisation of the corners),
//! `all` (every effect of the base scenario), each source `alone` and each source `left out`.
//! Every configuration is run with the same seeds, and seed i draws the same random numbers in
//! every configuration (ARCHITECTURE.md, "Common random numbers"), so the per-seed differences
//! V_i(alone) − V_i(none) measure the effect, not a new draw.
//!
//! The whole, V(all), is split into rows that add up to it: corner quantisation V(none), each
//! source's alone contribution V(alone) − V(none), and the interaction — what the alone
//! contributions leave over, V(all) − V(none) − Σ alone. Shares are rows over V(all). Each row's
//! mean is a mean of paired per-seed values (Student's t interval); each share is a ratio of two
//! means of paired values, whose interval is the delta-method (linearisation) one:
//! R = Ā / B̄, Var R ≈ Var(A_i − R·B_i) / (n B̄²).

use super::montecarlo::MeanCi;
use crate::numeric::dist::t975;
use serde::{Deserialize, Serialize};

/// Per-seed error variances (mean square errors) of every configuration for one quantity, in
/// (unit)². Entry i of every vector comes from the same seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairedRuns {
    pub none: Vec<f64>,
    pub all: Vec<f64>,
    /// The `none` configuration with the scene's exact corners in place of the detector's:
    /// the estimator's own error. When present, V(none) is split into this and the corners'
    /// quantisation V(none) − V(exact).
    #[serde(default)]
    pub exact: Option<Vec<f64>>,
    /// (source name, per-seed value with only this source on)
    pub alone: Vec<(String, Vec<f64>)>,
    /// (source name, per-seed value with every source but this one)
    pub left_out: Vec<(String, Vec<f64>)>,
}

/// One row of the decomposition: a part of V(all) and its share.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// `corner quantisation`, a source name, or `interaction`.
    pub name: String,
    /// The row's part of V(all), (unit)².
    pub variance: MeanCi,
    /// For a source: V(all) − V(all without it) (its cost in the presence of the others).
    pub left_out: Option<MeanCi>,
    /// The row's part over V(all).
    pub share: MeanCi,
}

impl Row {
    /// The share's interval contains 0: with these seeds the row cannot be told from nothing.
    pub fn share_indistinguishable_from_zero(&self) -> bool {
        !(self.share.ci95_low > 0.0 || self.share.ci95_high < 0.0)
    }
}

/// The decomposition of one quantity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Decomposition {
    pub seeds: usize,
    /// V(none), V(all): the configurations themselves.
    pub none: MeanCi,
    pub all: MeanCi,
    /// Every configuration's own variance: (configuration, mean and CI over seeds).
    pub configurations: Vec<(String, MeanCi)>,
    /// `corner quantisation`, the sources in order, `interaction`; their variances add up to
    /// V(all) (per seed, so the means do too).
    pub rows: Vec<Row>,
}

/// Name of the row that holds V(none), or V(none) − V(exact) when the exact-corner run exists:
/// what detecting the corners on the pixel grid adds to the estimator's own error.
pub const QUANTISATION: &str = "corner quantisation";
/// Name of the row that holds V(exact): the estimator's and differentiator's error on the
/// scene's exact corners, against the same truth (no pixels involved).
pub const ESTIMATOR: &str = "estimator on exact corners";
/// Name of the row that holds what the alone contributions leave over.
pub const INTERACTION: &str = "interaction";

impl Decomposition {
    /// The widest 95 % half-width of any share, as a fraction (0.05 = 5 percentage points).
    pub fn widest_share_half_width(&self) -> f64 {
        self.rows
            .iter()
            .map(|r| half_width(&r.share))
            .fold(0.0, f64::max)
    }

    pub fn row(&self, name: &str) -> Option<&Row> {
        self.rows.iter().find(|r| r.name == name)
    }
}

/// Half the width of a 95 % interval (infinite for a single seed, NaN when unknown).
pub fn half_width(m: &MeanCi) -> f64 {
    0.5 * (m.ci95_high - m.ci95_low)
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DecomposeError {
    #[error("source `{0}` has an `alone` run but no `left out` run")]
    Unpaired(String),
    #[error(
        "configuration `{name}` has {found} seed(s), `none` has {expected}: seeds must be paired"
    )]
    Unbalanced {
        name: String,
        found: usize,
        expected: usize,
    },
    #[error("non-finite variance in configuration `{0}`")]
    NonFinite(String),
    #[error("no seeds")]
    NoSeeds,
}

/// Mean and 95 % CI of the ratio Σ a_i / Σ b_i of paired values (delta method, Student's t).
pub fn ratio_ci(a: &[f64], b: &[f64]) -> MeanCi {
    let n = a.len().min(b.len());
    if n == 0 {
        return MeanCi::of(&[]);
    }
    let nf = n as f64;
    let a_mean = a[..n].iter().sum::<f64>() / nf;
    let b_mean = b[..n].iter().sum::<f64>() / nf;
    let r = a_mean / b_mean;
    if n == 1 || !r.is_finite() {
        return MeanCi {
            mean: r,
            ci95_low: f64::NEG_INFINITY,
            ci95_high: f64::INFINITY,
            n,
        };
    }
    let var_d = a[..n]
        .iter()
        .zip(&b[..n])
        .map(|(x, y)| (x - r * y).powi(2))
        .sum::<f64>()
        / (nf - 1.0);
    let half = t975(n - 1) * (var_d / nf).sqrt() / b_mean.abs();
    MeanCi {
        mean: r,
        ci95_low: r - half,
        ci95_high: r + half,
        n,
    }
}

fn diff(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// Splits V(all) into quantisation, per-source and interaction rows with paired CIs.
pub fn decompose(runs: &PairedRuns) -> Result<Decomposition, DecomposeError> {
    let n = runs.none.len();
    if n == 0 {
        return Err(DecomposeError::NoSeeds);
    }
    let mut configs: Vec<(String, &Vec<f64>)> =
        vec![("none".into(), &runs.none), ("all".into(), &runs.all)];
    if let Some(exact) = &runs.exact {
        configs.push(("exact corners".into(), exact));
    }
    for (name, v) in &runs.alone {
        configs.push((format!("{name} alone"), v));
    }
    for (name, v) in &runs.left_out {
        configs.push((format!("{name} left out"), v));
    }
    for (name, v) in &configs {
        if v.len() != n {
            return Err(DecomposeError::Unbalanced {
                name: name.clone(),
                found: v.len(),
                expected: n,
            });
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(DecomposeError::NonFinite(name.clone()));
        }
    }
    let all = &runs.all;
    let mut rows = Vec::new();
    let quantisation = match &runs.exact {
        Some(exact) => {
            rows.push(Row {
                name: ESTIMATOR.into(),
                variance: MeanCi::of(exact),
                left_out: None,
                share: ratio_ci(exact, all),
            });
            diff(&runs.none, exact)
        }
        None => runs.none.clone(),
    };
    rows.push(Row {
        name: QUANTISATION.into(),
        variance: MeanCi::of(&quantisation),
        left_out: None,
        share: ratio_ci(&quantisation, all),
    });
    let mut rest = diff(all, &runs.none);
    for (name, v_alone) in &runs.alone {
        let v_out = runs
            .left_out
            .iter()
            .find(|(m, _)| m == name)
            .map(|(_, v)| v)
            .ok_or_else(|| DecomposeError::Unpaired(name.clone()))?;
        let alone = diff(v_alone, &runs.none);
        rest = diff(&rest, &alone);
        rows.push(Row {
            name: name.clone(),
            variance: MeanCi::of(&alone),
            left_out: Some(MeanCi::of(&diff(all, v_out))),
            share: ratio_ci(&alone, all),
        });
    }
    rows.push(Row {
        name: INTERACTION.into(),
        variance: MeanCi::of(&rest),
        left_out: None,
        share: ratio_ci(&rest, all),
    });
    Ok(Decomposition {
        seeds: n,
        none: MeanCi::of(&runs.none),
        all: MeanCi::of(all),
        configurations: configs
            .iter()
            .map(|(name, v)| (name.clone(), MeanCi::of(v)))
            .collect(),
        rows,
    })
}

/// When to stop adding seeds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SeedRule {
    /// Seeds of the first round (at least 2: one seed has no interval).
    pub initial: usize,
    /// Largest number of seeds.
    pub cap: usize,
    /// Every share's 95 % half-width must be below this (fraction of V(all)).
    pub target_half_width: f64,
}

impl Default for SeedRule {
    fn default() -> Self {
        Self {
            initial: 4,
            cap: 64,
            target_half_width: 0.05,
        }
    }
}

/// Why the seeds stopped.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum StopReason {
    /// Every share's half-width is below the target.
    Settled,
    /// The cap was reached with some half-width still above the target.
    Capped,
}

impl StopReason {
    pub fn describe(self) -> &'static str {
        match self {
            StopReason::Settled => "every share's 95 % CI half-width is below the target",
            StopReason::Capped => {
                "the seed cap was reached before every share's 95 % CI half-width fell below the target"
            }
        }
    }
}

/// After `seeds` seeds whose widest share half-width is `widest`: `Ok(reason)` to stop, or
/// `Err(total)` with the seed count to reach next. The next count extrapolates the half-width as
/// 1/√n (with 20 % to spare), at least 2 more seeds and at most doubling, never past the cap.
pub fn next_seeds(rule: &SeedRule, seeds: usize, widest: f64) -> Result<StopReason, usize> {
    if widest < rule.target_half_width {
        return Ok(StopReason::Settled);
    }
    if seeds >= rule.cap {
        return Ok(StopReason::Capped);
    }
    let ratio = if widest.is_finite() {
        widest / rule.target_half_width
    } else {
        f64::INFINITY
    };
    let wanted = (seeds as f64 * ratio * ratio * 1.2).ceil();
    let wanted = if wanted.is_finite() {
        wanted as usize
    } else {
        usize::MAX
    };
    Err(wanted.min(2 * seeds).max(seeds + 2).min(rule.cap))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;
    use rand_distr::{Distribution, Normal};

    fn stream(i: u64) -> rand_pcg::Pcg64Mcg {
        crate::rng::stream(17, crate::rng::Stream::MonteCarlo, i)
    }

    /// Simulated paired configurations: V = q + Σ_on (c_k + noise_{k,i}) (+ an interaction
    /// `x` when both sources are on), with per-seed noise shared by every configuration in which
    /// the source is on (common random numbers).
    fn simulate(rng: &mut impl Rng, n: usize, q: f64, c: [f64; 2], sd: f64, x: f64) -> PairedRuns {
        let normal = Normal::new(0.0, sd).unwrap();
        let mut runs = PairedRuns {
            none: vec![],
            all: vec![],
            exact: None,
            alone: vec![("a".into(), vec![]), ("b".into(), vec![])],
            left_out: vec![("a".into(), vec![]), ("b".into(), vec![])],
        };
        for _ in 0..n {
            let e = [c[0] + normal.sample(rng), c[1] + normal.sample(rng)];
            runs.none.push(q);
            runs.all.push(q + e[0] + e[1] + x);
            runs.alone[0].1.push(q + e[0]);
            runs.alone[1].1.push(q + e[1]);
            runs.left_out[0].1.push(q + e[1]);
            runs.left_out[1].1.push(q + e[0]);
        }
        runs
    }

    #[test]
    fn independent_sources_have_no_interaction_and_known_shares() {
        let runs = simulate(&mut stream(0), 40, 1.0, [1.0, 2.0], 0.0, 0.0);
        let d = decompose(&runs).unwrap();
        let share = |name: &str| d.row(name).unwrap().share.mean;
        assert!((share(QUANTISATION) - 0.25).abs() < 1e-12);
        assert!((share("a") - 0.25).abs() < 1e-12);
        assert!((share("b") - 0.5).abs() < 1e-12);
        assert!(share(INTERACTION).abs() < 1e-12);
        let a = d.row("a").unwrap();
        assert!((a.left_out.unwrap().mean - 1.0).abs() < 1e-12);
    }

    /// Three seeds worked by hand, with per-seed spread and an interaction, so the shares are
    /// ratios of sums (not means of per-seed ratios) and the intervals the delta-method ones with
    /// Student's t for 2 dof (4.3027). V(none) = 1 each seed, V(all) = 4, 5, 6; `a` alone
    /// 2, 2, 3 (contributions 1, 1, 2), `b` alone 2, 3, 3 (1, 2, 2); the interaction is what
    /// is left, 1 per seed. Share of `a` = 4/15; its residuals a_i − (4/15)·all_i are −1/15, −1/3,
    /// 2/5, whose squares sum to 62/225, variance 31/225; half-width t·√(31/225/3)/5.
    /// Interaction share 3/15; residuals 1 − all_i/5 = 0.2, 0, −0.2, variance 0.04.
    #[test]
    fn shares_and_intervals_match_a_hand_computed_case() {
        let runs = PairedRuns {
            none: vec![1.0; 3],
            all: vec![4.0, 5.0, 6.0],
            exact: None,
            alone: vec![
                ("a".into(), vec![2.0, 2.0, 3.0]),
                ("b".into(), vec![2.0, 3.0, 3.0]),
            ],
            left_out: vec![
                ("a".into(), vec![3.0, 4.0, 4.0]),
                ("b".into(), vec![3.0, 3.0, 4.0]),
            ],
        };
        let d = decompose(&runs).unwrap();
        let close = |x: f64, y: f64| (x - y).abs() < 1e-12;
        let check = |name: &str, share: f64, half: f64| {
            let r = d.row(name).unwrap();
            assert!(
                close(r.share.mean, share),
                "{name}: {:?} vs {share}",
                r.share
            );
            assert!(
                close(r.share.ci95_low, share - half) && close(r.share.ci95_high, share + half),
                "{name}: {:?} vs {share} ± {half}",
                r.share
            );
        };
        // Student's t on 2 degrees of freedom: 4.3027.
        let t2 = t975(2);
        check(QUANTISATION, 3.0 / 15.0, t2 * (0.04f64 / 3.0).sqrt() / 5.0);
        check("a", 4.0 / 15.0, t2 * (31.0f64 / 225.0 / 3.0).sqrt() / 5.0);
        // b: residuals 1 − (5/15)·4, 2 − (5/15)·5, 2 − (5/15)·6 = −1/3, 1/3, 0; variance 1/9.
        check("b", 5.0 / 15.0, t2 * (1.0f64 / 9.0 / 3.0).sqrt() / 5.0);
        check(INTERACTION, 3.0 / 15.0, t2 * (0.04f64 / 3.0).sqrt() / 5.0);
        // Row variances: plain means with t intervals; a's contributions 1, 1, 2 have mean 4/3
        // and standard deviation 1/√3. Its left-out cost: all − (all without a) = 1, 1, 2.
        let a = d.row("a").unwrap();
        assert!(close(a.variance.mean, 4.0 / 3.0), "{:?}", a.variance);
        let half = t2 * (1.0f64 / 3.0).sqrt() / 3f64.sqrt();
        assert!(
            close(a.variance.ci95_high - a.variance.mean, half),
            "{:?}",
            a.variance
        );
        assert!(close(a.left_out.unwrap().mean, 4.0 / 3.0));
        assert!(close(d.row(INTERACTION).unwrap().variance.mean, 1.0));
    }

    /// The share intervals cover the true shares at about the nominal 95 % (binomial tolerance
    /// over 1000 repetitions: ±3σ ≈ ±2.1 %), for the sources and for the interaction, with
    /// paired noise of the size of the contributions.
    #[test]
    fn share_intervals_have_nominal_coverage() {
        let (q, c, x, sd) = (1.0, [0.5, 1.5], 0.4, 0.6);
        let total = q + c[0] + c[1] + x;
        let truth = [q / total, c[0] / total, c[1] / total, x / total];
        let reps = 1000;
        let mut covered = [0usize; 4];
        for r in 0..reps {
            let runs = simulate(&mut stream(r), 12, q, c, sd, x);
            let d = decompose(&runs).unwrap();
            for (k, row) in d.rows.iter().enumerate() {
                if row.share.ci95_low <= truth[k] && truth[k] <= row.share.ci95_high {
                    covered[k] += 1;
                }
            }
        }
        for (k, c) in covered.iter().enumerate() {
            let frac = *c as f64 / reps as f64;
            assert!((frac - 0.95).abs() < 0.022, "row {k}: coverage {frac}");
        }
    }

    /// With the exact-corner run, V(none) splits into the estimator's own error V(exact) and
    /// the quantisation V(none) − V(exact), per seed: the rows still add up to V(all) seed by
    /// seed, and an estimator error that differs from seed to seed by less than the
    /// quantisation is still told apart from it.
    #[test]
    fn the_exact_corner_run_splits_the_estimator_from_the_quantisation() {
        let mut runs = simulate(&mut stream(3), 10, 1.0, [1.0, 2.0], 0.1, 0.0);
        let normal = Normal::new(0.0, 0.05).unwrap();
        let mut rng = stream(4);
        // Seed i: estimator 0.7 + ε_i, quantisation the rest of V(none) = 1.
        let exact: Vec<f64> = (0..10).map(|_| 0.7 + normal.sample(&mut rng)).collect();
        runs.exact = Some(exact.clone());
        let d = decompose(&runs).unwrap();
        assert_eq!(d.rows[0].name, ESTIMATOR);
        assert_eq!(d.rows[1].name, QUANTISATION);
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let total: f64 = d.rows.iter().map(|r| r.variance.mean).sum();
        assert!((total - mean(&runs.all)).abs() < 1e-12, "{total}");
        let e = &d.rows[0];
        let q = &d.rows[1];
        assert!((e.variance.mean - mean(&exact)).abs() < 1e-12);
        assert!((q.variance.mean - (1.0 - mean(&exact))).abs() < 1e-12);
        assert!(e.share.ci95_low > q.share.ci95_high, "{e:?} {q:?}");
        assert!(d.configurations.iter().any(|(n, _)| n == "exact corners"));
        // A run of another length is refused like any unpaired configuration.
        runs.exact.as_mut().unwrap().pop();
        assert!(matches!(
            decompose(&runs).unwrap_err(),
            DecomposeError::Unbalanced { .. }
        ));
    }

    #[test]
    fn an_interaction_is_told_from_zero_and_a_null_source_is_not() {
        let runs = simulate(&mut stream(1), 30, 1.0, [0.0, 2.0], 0.05, 1.0);
        let d = decompose(&runs).unwrap();
        assert!(d.row("a").unwrap().share_indistinguishable_from_zero());
        assert!(!d.row("b").unwrap().share_indistinguishable_from_zero());
        let i = d.row(INTERACTION).unwrap();
        assert!(!i.share_indistinguishable_from_zero(), "{i:?}");
        assert!((i.share.mean - 0.25).abs() < 0.05);
    }

    #[test]
    fn unpaired_unbalanced_and_empty_inputs_are_errors() {
        let mut runs = simulate(&mut stream(2), 3, 1.0, [1.0, 1.0], 0.1, 0.0);
        runs.left_out.pop();
        assert_eq!(
            decompose(&runs).unwrap_err(),
            DecomposeError::Unpaired("b".into())
        );
        let mut runs = simulate(&mut stream(2), 3, 1.0, [1.0, 1.0], 0.1, 0.0);
        runs.alone[1].1.pop();
        assert!(matches!(
            decompose(&runs).unwrap_err(),
            DecomposeError::Unbalanced { .. }
        ));
        let mut runs = simulate(&mut stream(2), 3, 1.0, [1.0, 1.0], 0.1, 0.0);
        runs.all[0] = f64::NAN;
        assert_eq!(
            decompose(&runs).unwrap_err(),
            DecomposeError::NonFinite("all".into())
        );
        let runs = simulate(&mut stream(2), 0, 1.0, [1.0, 1.0], 0.1, 0.0);
        assert_eq!(decompose(&runs).unwrap_err(), DecomposeError::NoSeeds);
    }

    #[test]
    fn seed_rule_extrapolates_and_says_why_it_stops() {
        let rule = SeedRule {
            initial: 4,
            cap: 20,
            target_half_width: 0.05,
        };
        assert_eq!(next_seeds(&rule, 4, 0.04), Ok(StopReason::Settled));
        // 0.1 at 4 seeds → 4·4·1.2 = 19.2 → capped at doubling.
        assert_eq!(next_seeds(&rule, 4, 0.1), Err(8));
        // Just above target: at least two more.
        assert_eq!(next_seeds(&rule, 8, 0.0501), Err(10));
        assert_eq!(next_seeds(&rule, 16, 0.2), Err(20));
        assert_eq!(next_seeds(&rule, 20, 0.2), Ok(StopReason::Capped));
        assert_eq!(next_seeds(&rule, 1, f64::INFINITY), Err(3));
    }
}
