//! [`Fitter::with_clearance_free`] on a real fitter: footage rendered with a withheld 0.5 mm
//! backlash, measured as real footage, and diagnosed against a nominal that states 0.3 mm, as
//! a diagnosis builds it ([`crate::diagnose::footing::Footing`]).

use super::*;
use crate::diagnose::footing::Footing;
use crate::diagnose::gap::GapOptions;
use crate::pipeline::diagnose::simulate::RenderDetect;

#[test]
fn a_stated_clearance_is_refitted_against_the_clearance_free_motion(
) -> Result<(), Box<dyn std::error::Error>> {
    let tmp = tempfile::tempdir()?;
    // The self-check's strong backlash (0.5 mm), on 2 s of footage.
    let (case, layout, measured) = super::test_footage::withheld_backlash(tmp.path())?;
    let truth_mm = Effect::Backlash.values(&case.data)[0];
    // The user's nominal states a clearance of 0.3 mm; without it, the self-check's own.
    let mut stated = case.nominal.clone();
    stated.dynamics.enabled = true;
    stated.mechanism.pin_diameter_mm = stated.mechanism.slot_width_mm - 0.3;
    let mut free_nominal = stated.clone();
    Effect::Backlash.switch_off(&mut free_nominal);
    assert!(Effect::Backlash.is_on(&stated) && !Effect::Backlash.is_on(&free_nominal));

    let effects = [Effect::Backlash];
    let (fit_seeds, eval_seeds) = (vec![2000, 2001], vec![1000, 1001]);
    let footing = Footing::new(&stated, &measured, &layout, Some(&effects), &RenderDetect)?;
    let plain = footing.fitter(
        &stated,
        &layout,
        fit_seeds.clone(),
        eval_seeds.clone(),
        GapOptions::default(),
    )?;
    let footing_free = Footing::new(
        &free_nominal,
        &measured,
        &layout,
        Some(&effects),
        &RenderDetect,
    )?;
    let free = || {
        footing_free.fitter(
            &free_nominal,
            &layout,
            fit_seeds.clone(),
            eval_seeds.clone(),
            GapOptions::default(),
        )
    };

    // Against the stated motion: the cells cannot tell 0.5 mm from its mirror about 0.3 mm, and
    // the method says so.
    let mirrored = plain.fork().fit(Effect::Backlash, &[])?;
    assert!(mirrored.method.contains("caution"), "{}", mirrored.method);
    // Against the clearance-free motion: exactly the fit a nominal without the clearance gives
    // (a fit is a pure function of its fitter's inputs), with the stated one named.
    let withheld = free()?.fit(Effect::Backlash, &[])?;
    let fitter = plain.with_clearance_free(free()?);
    let delegated = fitter.fit(Effect::Backlash, &[])?;
    assert_eq!(delegated.values, withheld.values);
    assert_eq!(delegated.stds, withheld.stds);
    assert!(
        delegated.method.starts_with(&withheld.method)
            && delegated.method.contains("0.300 mm")
            && !delegated.method.contains("caution"),
        "{}",
        delegated.method
    );
    let error = |f: &Fitted| (f.values[0] - truth_mm).abs();
    assert!(
        error(&delegated) < error(&mirrored),
        "truth {truth_mm} mm: against the stated motion {:?}, against the clearance-free one {:?}",
        mirrored.values,
        delegated.values
    );
    // A refit on other seeds and a fork go the same way; the friction stays on the stated
    // motion, its caution with it.
    let refit = fitter
        .fork()
        .refit_on_seeds(&[Effect::Backlash], &[2002, 2003])
        .0?;
    let mut free_refit = free()?;
    free_refit.fit_seeds = vec![2002, 2003];
    assert_eq!(
        refit[0].values,
        free_refit.fit(Effect::Backlash, &[])?.values
    );
    let friction = fitter.fork().fit(Effect::Overrotation, &[])?;
    assert!(friction.method.contains("caution"), "{}", friction.method);
    // A bootstrap footage of a delegated clearance is drawn and fitted on the clearance-free
    // side as well.
    let (fits, simulations) = fitter.fork().fit_on_simulated_footage(
        fitter.nominal_sims(),
        &[(Effect::Backlash, delegated.values.clone())],
        5007,
    );
    let fits = fits?;
    assert!(simulations > 0 && fits.len() == 1);
    assert!(fits[0].method.contains("0.300 mm"), "{}", fits[0].method);
    Ok(())
}
