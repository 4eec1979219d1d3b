//! The fit objectives a fitter has already simulated, so that asking again costs nothing.
//!
//! A fit objective is deterministic: the same trial, simulated on the same seeds, measured
//! through the same code and compared over the same cells gives the same value, bit for bit.
//! The pair stage asks for objectives that a search has just computed (the second effect at its
//! fitted values, beside the first, for [`crate::diagnose::plan::second_lowers_fit`]; the first
//! effect at its old and new values after a backfit), and each one costs a simulation set on
//! the fit seeds.
//!
//! Architecture invariant: a hit returns exactly what the simulation would, so the memo changes
//! no fitted value, no verdict and no output but the simulation counts. The key is everything
//! the objective depends on: the trial as built (its `Debug` text, which holds every scenario
//! field, the timing source and any refined runout form or matched rotation centre), the seeds,
//! the effects whose signature cells are counted, which of the lens's cells count, and the
//! comparison. A fork starts with an empty memo (`diagnose::fit::Fitter::fork`), so a fork's counts do
//! not depend on what ran before it, and no memo is shared between threads.

use super::objectives::Objectives;
use crate::scenario::effects::Effect;
use std::cell::RefCell;
use std::collections::HashMap;

/// Everything one fit objective depends on, as text (see the module doc).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct MemoKey(String);

impl MemoKey {
    /// `trial_debug` is the trial's `Debug` text; `cells` names which cells count (the lens's
    /// and the comparison's choice); `effects` in any order (the cells counted are their union).
    pub fn new(trial_debug: &str, seeds: &[u64], effects: &[Effect], cells: &str) -> Self {
        let mut names: Vec<&str> = effects.iter().map(|e| e.name()).collect();
        names.sort_unstable();
        names.dedup();
        MemoKey(format!(
            "seeds {seeds:?} | effects {names:?} | cells {cells} | trial {trial_debug}"
        ))
    }
}

/// Objectives by [`MemoKey`]; interior mutability as the fitter's simulation counter has.
#[derive(Debug, Default)]
pub struct ObjectiveMemo {
    by_key: RefCell<HashMap<MemoKey, Objectives>>,
}

impl ObjectiveMemo {
    pub fn get(&self, key: &MemoKey) -> Option<Objectives> {
        self.by_key.borrow().get(key).copied()
    }

    /// Records a computed objective. A failed one (not finite) is not recorded: a failure may be
    /// a resource one, and a later ask simulates again.
    pub fn insert(&self, key: MemoKey, objectives: Objectives) {
        if objectives.sum_z2.is_finite() {
            self.by_key.borrow_mut().insert(key, objectives);
        }
    }

    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.by_key.borrow().len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obj(sum_z2: f64) -> Objectives {
        Objectives {
            sum_z2,
            shared_chi2: sum_z2 / 2.0,
        }
    }

    #[test]
    fn a_key_differs_in_anything_the_objective_depends_on_and_not_in_effect_order() {
        let lens = [Effect::LensDistortion];
        let key = |trial: &str, seeds: &[u64], effects: &[Effect], cells: &str| {
            MemoKey::new(trial, seeds, effects, cells)
        };
        let base = key("Trial { k1: 0.1 }", &[1, 2], &lens, "All");
        assert_eq!(base, key("Trial { k1: 0.1 }", &[1, 2], &lens, "All"));
        let others = [
            key("Trial { k1: 0.2 }", &[1, 2], &lens, "All"),
            key("Trial { k1: 0.1 }", &[1, 3], &lens, "All"),
            key("Trial { k1: 0.1 }", &[2, 1], &lens, "All"),
            key(
                "Trial { k1: 0.1 }",
                &[1, 2],
                &[Effect::PerspectiveTilt],
                "All",
            ),
            key("Trial { k1: 0.1 }", &[1, 2], &lens, "Shape"),
        ];
        for other in others {
            assert_ne!(base, other, "{other:?}");
        }
        let pair = [Effect::AxisRunout, Effect::LensDistortion];
        let swapped = [Effect::LensDistortion, Effect::AxisRunout];
        assert_eq!(
            key("t", &[1], &pair, "All"),
            key("t", &[1], &swapped, "All")
        );
    }

    #[test]
    fn a_recorded_objective_is_returned_bit_for_bit_and_a_failed_one_is_not_kept() {
        let memo = ObjectiveMemo::default();
        let key = MemoKey::new("t", &[7], &[Effect::AxisRunout], "All");
        assert_eq!(memo.get(&key), None);
        memo.insert(key.clone(), obj(0.1 + 0.2));
        assert_eq!(
            memo.get(&key).map(|o| o.sum_z2.to_bits()),
            Some((0.1f64 + 0.2).to_bits())
        );
        let failed = MemoKey::new("u", &[7], &[Effect::AxisRunout], "All");
        memo.insert(failed.clone(), obj(f64::INFINITY));
        memo.insert(failed.clone(), obj(f64::NAN));
        assert_eq!(memo.get(&failed), None);
        assert_eq!(memo.len(), 1);
    }
}
