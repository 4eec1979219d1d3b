//! The calibration round trip on printed markers: the round trip's random rigs with the marker
//! drawn from a texture (a shading across the paper and the ink, and a blotch, each of random
//! direction, size and strength, as a print under a lamp looks), calibrated like any footage.
//! What is judged: whether `calibrate` measures the marker's texture (it must, here, and must
//! not on the uniform markers of the round trip), and whether the calibrated scenario renders
//! the re-render check's frame, which the texture's mosaic leaves out, down to its noise.

use super::calibrate::CalibrateJobError;
use super::calibrate_roundtrip::{draw_case, render_and_calibrate, CaseResult};
use crate::calibrate::appearance::texels_per_cell;
use crate::calibrate::output::ReRenderCheck;
use crate::calibrate::residual::MAX_SMOOTHED_RETENTION;
use crate::imagestats::Material;
use crate::render::texture::value_of;
use crate::rng::{stream, Stream};
use crate::scenario::Scenario;
use rand::Rng;
use std::path::Path;

/// Printed cases in the report.
pub const PRINTED_CASES: usize = 10;

/// Where the printed cases' rigs are drawn from, apart from the uniform ones'.
const PRINTED_CASE_OFFSET: usize = 5000;

/// One printed case's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct PrintedResult {
    pub index: usize,
    /// Spread of the drawn texture's paper, in radiance (its shading and blotch).
    pub paper_spread: f64,
    pub texture_written: bool,
    /// Why the calibration drew the marker uniform, when it did (its note).
    pub why_uniform: Option<String>,
    /// The check's frame was left out of the texture's mosaic.
    pub check_frame_held_out: bool,
    pub check: Option<ReRenderCheck>,
}

/// The drawn marker texture of `truth` (random shading and blotch from `seed`, `index`) at
/// `tpc` texels per cell: values, side, and the paper's spread.
fn printed_texture(
    truth: &Scenario,
    layout: &crate::imagestats::MarkerLayout,
    seed: u64,
    index: usize,
    tpc: u32,
) -> (Vec<u16>, usize, f64) {
    let mut r = stream(seed, Stream::MonteCarlo, 0x20_0000 + index as u64);
    let cells = layout.side_cells();
    let margin = (layout.margin_cells().unwrap_or(0.0) * tpc as f64).round() as usize;
    let side = cells * tpc as usize + 2 * margin;
    let direction = r.gen_range(0.0..std::f64::consts::TAU);
    let shade_amp = r.gen_range(0.04..0.12);
    let (bx, by) = (
        r.gen_range(0.0..cells as f64),
        r.gen_range(0.0..cells as f64),
    );
    let width = r.gen_range(1.0..2.5);
    let blotch_amp = r.gen_range(0.03..0.1);
    // Room for the variation below the paper's radiance (a clipped paper stays under 1).
    let paper = truth.scene.paper_radiance.min(1.0) - shade_amp - 0.01;
    let ink = truth.scene.ink_radiance + shade_amp / 3.0 + blotch_amp / 3.0 + 0.01;
    let mut papers = Vec::new();
    let values = (0..side * side)
        .map(|k| {
            let g = |v: usize| (v as f64 + 0.5 - margin as f64) / tpc as f64;
            let (gx, gy) = (g(k % side), g(k / side));
            let along = ((gx - cells as f64 / 2.0) * direction.cos()
                + (gy - cells as f64 / 2.0) * direction.sin())
                / cells as f64;
            let blotch = (-((gx - bx).powi(2) + (gy - by).powi(2)) / (2.0 * width * width)).exp();
            let variation = shade_amp * along - blotch_amp * blotch;
            let v = match layout.material(gx, gy) {
                Material::Ink => ink + variation / 3.0,
                _ => {
                    papers.push(paper + variation);
                    paper + variation
                }
            };
            value_of(v)
        })
        .collect();
    let spread = crate::numeric::robust::sample_sd(&papers);
    (values, side, spread)
}

/// Draws printed case `index`, renders and calibrates it in `dir`.
pub fn run_printed_case(
    seed: u64,
    index: usize,
    dir: &Path,
) -> Result<PrintedResult, CalibrateJobError> {
    let (text, truth) = draw_case(seed, PRINTED_CASE_OFFSET + index, dir)?;
    let io = |file: &Path| {
        let file = file.to_path_buf();
        move |source| CalibrateJobError::RoundTripWrite { file, source }
    };
    // About two texels per pixel: the texture is finer than the footage resolves.
    let layout =
        crate::diagnose::image::marker_layout(&truth).map_err(CalibrateJobError::MarkerLayout)?;
    let tpc = texels_per_cell(16.0, layout.margin_cells().unwrap_or(1.0)).unwrap_or(16);
    let (values, side, paper_spread) = printed_texture(&truth, &layout, seed, index, tpc);
    let marker = dir.join("marker.png");
    crate::io::texture_png::write_texture(&marker, side, side, &values)?;
    let path = dir.join("truth.toml");
    let printed = format!(
        "{text}\n[scene.appearance]\nmarker_file = \"marker.png\"\nmarker_texels_per_cell = {tpc}\n"
    );
    std::fs::write(&path, printed).map_err(io(&path))?;
    let truth = crate::scenario::load(&path).map_err(|source| CalibrateJobError::Scenario {
        path: path.clone(),
        source,
    })?;
    let out = render_and_calibrate(&truth, dir)?;
    let a = out.calibration.appearance.as_ref();
    Ok(PrintedResult {
        index,
        paper_spread,
        texture_written: a.is_some(),
        why_uniform: out
            .calibration
            .notes
            .iter()
            .find(|n| n.starts_with("appearance: the marker is drawn uniform"))
            .cloned(),
        check_frame_held_out: a.is_some_and(|a| a.check_frame_held_out),
        check: out.check,
    })
}

/// The report's section on printed markers, beside the uniform cases' `uniform` results, and
/// the per-case CSV.
pub fn printed_section(uniform: &[CaseResult], printed: &[PrintedResult]) -> (String, String) {
    let n = printed.len();
    let count = |f: &dyn Fn(&PrintedResult) -> bool| printed.iter().filter(|r| f(r)).count();
    let checked = |f: &dyn Fn(&ReRenderCheck) -> bool| {
        count(&|r| r.texture_written && r.check.as_ref().is_some_and(f))
    };
    let rows = [
        (
            "texture written on a uniform marker (the cases above: noise alone is no appearance)"
                .to_string(),
            format!(
                "{}/{}",
                uniform.iter().filter(|r| r.texture_written).count(),
                uniform.len()
            ),
        ),
        (
            "texture written on a printed marker".into(),
            format!("{}/{n}", count(&|r| r.texture_written)),
        ),
        (
            "… not written: the marker never rests in the footage (a moving marker is smeared \
             by its motion over the exposure, so none is measured)"
                .into(),
            format!(
                "{}/{n}",
                count(&|r| r
                    .why_uniform
                    .as_deref()
                    .is_some_and(|w| w.contains("never at rest")))
            ),
        ),
        (
            "… with the re-render check's frame left out of its mosaic".into(),
            format!("{}/{n}", count(&|r| r.check_frame_held_out)),
        ),
        (
            format!(
                "held-out frame: the residual smoothed at 2 px keeps at most {MAX_SMOOTHED_RETENTION:.2} of its sd"
            ),
            format!(
                "{}/{n}",
                checked(&|k| k.structure.footage.smoothed_retention <= MAX_SMOOTHED_RETENTION)
            ),
        ),
        (
            "held-out frame: residual RMS ≤ 1.2 × what the fitted model predicts".into(),
            format!("{}/{n}", checked(&|k| k.ratio() <= 1.2)),
        ),
        (
            "held-out frame: every test of the re-render check passed".into(),
            format!("{}/{n}", checked(&|k| k.passed())),
        ),
    ];
    let mut md = format!(
        "## Printed markers\n\n{n} more random rigs (drawn as above) whose marker is printed: \
         its paper and ink drawn from a texture with a shading across it (4–12 % of full scale \
         over the marker, random direction) and a blotch (1–2.5 cells wide, 3–10 %), at about \
         two texels per pixel (`pipeline::calibrate_printed`). `calibrate` must measure the \
         texture here and must not on the uniform markers above; the calibrated scenario \
         renders the re-render check's frame, which the texture's mosaic leaves out when the \
         footage has another static frame.\n\n| criterion | measured |\n|---|---|\n"
    );
    for (what, figure) in rows {
        md.push_str(&format!("| {what} | {figure} |\n"));
    }
    md.push_str(
        "\nPer printed case, in `printed.csv`: the drawn paper's spread, whether a texture was \
         written (and why not), whether the check's frame was held out, and the check's figures \
         (where a texture was written and the check still fails, they say which test).\n",
    );
    let mut csv = String::from(
        "case,paper_spread,texture_written,check_frame_held_out,rerender_ratio,\
         smoothed_retention,edge_energy_ratio,model_edge_energy_ratio,rerender_passed,why_uniform\n",
    );
    for r in printed {
        let k = r.check.as_ref();
        let f = |g: &dyn Fn(&ReRenderCheck) -> String| k.map_or(String::new(), g);
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{}\n",
            r.index,
            r.paper_spread,
            r.texture_written,
            r.check_frame_held_out,
            f(&|k| k.ratio().to_string()),
            f(&|k| k.structure.footage.smoothed_retention.to_string()),
            f(&|k| k.structure.footage.edge_energy_ratio.to_string()),
            f(&|k| k.structure.model.edge_energy_ratio.to_string()),
            f(&|k| k.passed().to_string()),
            r.why_uniform
                .as_deref()
                .map_or(String::new(), |w| format!("\"{}\"", w.replace('"', "'"))),
        ));
    }
    (md, csv)
}
