//! Proptest strategies for the crate's own domain objects, shared by the unit tests (imageproc's
//! pattern: one module, `crate::proptest_utils`). A strategy used by one test only stays beside
//! it; one that describes a scenario object (frame times, a drive kind, a timing model) lives
//! here, so every test draws it the same way. Integration tests (`tests/`) do not use proptest;
//! this module is `cfg(test)` and they could not see it.

use proptest::prelude::*;

use crate::mechanism::GenevaKind;
use crate::timing::VfrModel;

/// 6 to 29 strictly increasing frame times, uneven: the first 10–80 ms after 0, each next one
/// 10–80 ms after the last.
pub fn frame_times() -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(0.01f64..0.08, 6..30).prop_map(|steps| {
        let mut t = 0.0;
        steps
            .iter()
            .map(|h| {
                t += h;
                t
            })
            .collect()
    })
}

/// Either kind of Geneva drive.
pub fn geneva_kind() -> impl Strategy<Value = GenevaKind> {
    prop_oneof![Just(GenevaKind::External), Just(GenevaKind::Internal)]
}

/// A nominal frame rate (1–240 fps) and a VFR model at it: rate error within ±10⁵ ppm, drop
/// probability up to 0.5, pair alternation and jitter sharing at most half the frame interval
/// (the ordering budget: frames keep their order), and an optional long first interval.
pub fn vfr_model() -> impl Strategy<Value = (f64, VfrModel)> {
    (
        1.0f64..240.0,
        -1e5f64..1e5,
        0.0f64..1.0,
        0.0f64..1.0,
        0.0f64..=0.5,
        0.5f64..3.0,
        any::<bool>(),
    )
        .prop_map(|(fps, ppm, share, used, drop, first, gap)| {
            let interval = 1.0 / (fps * (1.0 + ppm * 1e-6));
            // Use up to the whole ordering budget, split between alternation and jitter.
            let budget = used * 0.5 * interval;
            let v = VfrModel {
                jitter_s: share * budget / 8.0,
                pair_alternation_s: (1.0 - share) * budget,
                first_interval_s: if gap { first * interval } else { 0.0 },
                drop_probability: drop,
                rate_error_ppm: ppm,
            };
            (fps, v)
        })
}
