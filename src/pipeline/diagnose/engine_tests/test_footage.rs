//! Footage for the tests of a real fitter: the self-check's strong backlash (0.5 mm) on 2 s,
//! rendered and measured as real footage, as a diagnosis measures it.

use super::*;
use crate::diagnose::image;
use crate::diagnose::record::RealMeasurement;
use crate::imagestats::MarkerLayout;
use crate::pipeline::analyze::Source;
use crate::pipeline::diagnose::real;
use crate::pipeline::selfcheck::{cases, render_case, suite_base, Case, SuitePlan};
use std::path::Path;

/// The case (its footage rig and its nominal, the same rig without the clearance), the marker
/// layout and the measured footage; the frames and the measurement are written under `dir`.
pub(super) fn withheld_backlash(
    dir: &Path,
) -> Result<(Case, MarkerLayout, RealMeasurement), Box<dyn std::error::Error>> {
    let plan = SuitePlan {
        null_cases: 0,
        flicker_cases: 0,
        ..SuitePlan::quick(Effect::Backlash)
    };
    let case = cases(&suite_base(2.0)?, &plan, &[])
        .into_iter()
        .find(|c| c.name.starts_with("withheld-backlash-strong"))
        .ok_or("the plan's backlash case")?;
    let frames = dir.join("frames");
    render_case(&case, &frames)?;
    let source = Source::Frames {
        dir: frames.clone(),
        timestamps: frames.join("timestamps.csv"),
    };
    let layout = image::marker_layout(&case.nominal)?;
    let measured = real::measure_real(
        &case.nominal,
        &source,
        &layout,
        &dir.join("real"),
        &|_, _| {},
    )?;
    Ok((case, layout, measured))
}
