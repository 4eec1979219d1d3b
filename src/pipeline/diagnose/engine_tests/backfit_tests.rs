//! [`Fitter::backfit_first`] on a real fitter: footage rendered with a withheld backlash,
//! measured as real footage, and a fitter built on it as a diagnosis builds it
//! ([`crate::diagnose::footing::Footing`]). The guard's rule itself is
//! [`crate::diagnose::plan::backfit_keeps_refit`]'s; this checks what the backfit does with it.

use super::*;
use crate::diagnose::footing::Footing;
use crate::diagnose::gap::GapOptions;
use crate::pipeline::diagnose::simulate::RenderDetect;

/// `effect` at `values`, as a fit of `kind` would state it.
fn stated(effect: Effect, values: Vec<f64>, kind: FitKind) -> Fitted {
    let n = values.len();
    Fitted {
        effect,
        values,
        stds: vec![0.01; n],
        method: "stated by the test".into(),
        simulations: 0,
        runout_form: None,
        kind,
    }
}

#[test]
fn the_backfit_takes_a_moment_matched_refit_and_keeps_the_lower_of_two_searches(
) -> Result<(), Box<dyn std::error::Error>> {
    let tmp = tempfile::tempdir()?;
    // The plan's strong backlash, on 2 s of footage.
    let (case, layout, measured) = super::test_footage::withheld_backlash(tmp.path())?;
    let nominal = case.nominal.clone();
    let clearance: Vec<f64> = Effect::Backlash
        .nominal_values(&case.data, nominal.frame_timing.fps)
        .into_iter()
        .map(|v| v.ok_or("the footage's clearance"))
        .collect::<Result<_, _>>()?;
    let effects = [Effect::Backlash, Effect::Timebase];
    let footing = Footing::new(&nominal, &measured, &layout, Some(&effects), &RenderDetect)?;
    let fitter = footing.fitter(
        &nominal,
        &layout,
        vec![2000, 2001],
        vec![1000, 1001],
        GapOptions::default(),
    )?;

    // The second effect: the timebase at the timestamps' median rate, read off them without a
    // simulation. Beside it (a constant rate this jittered footage does not have) the backlash
    // fits far from its 0.5 mm on 2 s of footage: what is tested is which values the backfit
    // keeps, not how well they fit.
    let second = fitter.fit(Effect::Timebase, &[])?;
    assert_eq!(second.kind, FitKind::Measured);
    let others = vec![(second.effect, second.values.clone())];
    // What the backfit's own refit gives: a fit is a pure function of the fitter's inputs.
    let refit = fitter.fit(Effect::Backlash, &others)?;
    assert_eq!(refit.kind, FitKind::SumZ2Search, "{}", refit.method);
    let objective = |values: &[f64]| fitter.objective_beside(&others, Effect::Backlash, values).0;
    let refit_sum_z2 = objective(&refit.values);
    assert!(refit_sum_z2.is_finite(), "{refit_sum_z2}");
    let backfit = |first: Fitted| -> Result<Fitted, FitError> {
        let out = fitter.backfit_first(vec![first, second.clone()])?;
        assert_eq!(out.len(), 2);
        assert_eq!(
            out[1].values, second.values,
            "the second effect is not refitted"
        );
        Ok(out[0].clone())
    };
    let search_top = Effect::Backlash.params()[0].search.1;

    // Alone, a fit is returned as it came.
    let alone = stated(Effect::Backlash, vec![search_top], FitKind::SumZ2Search);
    let out = fitter.backfit_first(vec![alone.clone()])?;
    assert_eq!(out[0].values, alone.values);
    assert_eq!(out[0].method, alone.method);

    // A search that ended at the top of its range: the refit is lower and is taken.
    let far = stated(Effect::Backlash, vec![search_top], FitKind::SumZ2Search);
    let far_sum_z2 = objective(&far.values);
    assert!(refit_sum_z2 < far_sum_z2, "{refit_sum_z2} vs {far_sum_z2}");
    let out = backfit(far)?;
    assert_eq!(out.values, refit.values);
    assert_eq!(out.method, refit.method);

    // Values around the refit's end, and the truth. A search of a simulated objective ends
    // within its tolerance, not at the minimum: some of them leave a lower Σ z² beside the
    // other effect than the refit does, some a higher one, so both of the guard's answers are
    // asked for (the fitter is deterministic: these are the same on every run).
    let r = refit.values[0];
    let tried: Vec<(Vec<f64>, f64)> = [0.95, 0.98, 1.02, 1.05]
        .iter()
        .map(|k| vec![k * r])
        .chain([clearance.clone()])
        .map(|values| {
            let sum_z2 = objective(&values);
            (values, sum_z2)
        })
        .collect();
    let sums: Vec<f64> = tried.iter().map(|t| t.1).collect();
    assert!(
        sums.iter().any(|&v| v < refit_sum_z2) && sums.iter().any(|&v| v > refit_sum_z2),
        "{sums:?} against the refit's {refit_sum_z2}"
    );
    for (values, kept_sum_z2) in tried {
        // Matched on moments: the refit is taken whatever its Σ z², even where the values it
        // replaces leave a lower one.
        let out = backfit(stated(
            Effect::Backlash,
            values.clone(),
            FitKind::MomentMatch,
        ))?;
        assert_eq!(out.values, refit.values);
        assert_eq!(out.kind, FitKind::SumZ2Search);
        // Two searches: the values that leave the lower Σ z² stay.
        let out = backfit(stated(
            Effect::Backlash,
            values.clone(),
            FitKind::SumZ2Search,
        ))?;
        if kept_sum_z2 < refit_sum_z2 {
            assert_eq!(out.values, values);
            assert!(
                out.method
                    .starts_with("stated by the test; refitted beside timebase")
                    && out.method.ends_with("which are kept"),
                "{}",
                out.method
            );
        } else {
            assert_eq!(out.values, refit.values, "{kept_sum_z2} vs {refit_sum_z2}");
            assert_eq!(out.method, refit.method);
        }
    }
    Ok(())
}
