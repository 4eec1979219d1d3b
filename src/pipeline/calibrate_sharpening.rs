//! The footage's sharpening as calibrate measures it: the edge fits of a few frames, refitted
//! under each mask [`crate::calibrate::sharpening::fit_sharpening`] tries.

use super::calibrate::{comparison_window, float_of, residual_rows, window_pixels, Corners, Crop};
use crate::calibrate::output::Override;
use crate::calibrate::rerender::{align, PixelResidual};
use crate::calibrate::sharpening::{fit_sharpening, EdgeCost, SharpeningFit};
use crate::imagestats::{outer_edge_profiles, EdgeOptions, EdgeSharpening, MarkerLayout};
use crate::numeric::minimize::nelder_mead;
use crate::render::GrayImage;
use crate::render::{render_frame, FrameRequest};
use crate::scenario::Scenario;
use rayon::prelude::*;
use toml::Value;

/// Frames whose edges the search refits at every step (static ones first: a moving marker's
/// edges carry its motion blur, which no mask explains).
const SEARCH_FRAMES: usize = 8;
/// Pixels per edge in the search (the final fits use their own cap).
const SEARCH_SAMPLES: usize = 1500;
/// Renders the match may make, and its first simplex's steps as a share of each parameter's
/// range (capped at 1).
const RENDERS: usize = 120;
const STEP_FRAC: f64 = 0.15;
/// Relative drop of footage − render the match must bring to replace the edge fits' reading.
const MIN_GAIN: f64 = 0.01;

/// The mask measured on `jobs` (frame, crop, corners, static), `None` without fittable edges.
pub(super) fn measure_sharpening(
    jobs: &[(usize, Crop, Corners, bool)],
    layout: &MarkerLayout,
    options: &EdgeOptions,
) -> Option<SharpeningFit> {
    let still: Vec<&(usize, Crop, Corners, bool)> = jobs.iter().filter(|j| j.3).collect();
    let chosen: Vec<&(usize, Crop, Corners, bool)> = if still.len() >= 2 {
        spread(&still, SEARCH_FRAMES)
    } else {
        spread(&jobs.iter().collect::<Vec<_>>(), SEARCH_FRAMES)
    };
    if chosen.is_empty() {
        return None;
    }
    let cost = |mask: Option<EdgeSharpening>| -> Option<EdgeCost> {
        let opts = EdgeOptions {
            max_samples: SEARCH_SAMPLES,
            sharpening: mask,
            ..options.clone()
        };
        let fits: Vec<EdgeCost> = chosen
            .par_iter()
            .flat_map_iter(|(_, crop, c, _)| {
                outer_edge_profiles(&crop.view(), c, layout, &opts)
                    .into_iter()
                    .filter_map(Result::ok)
                    .map(|e| {
                        let levels = [e.ink_dn, e.paper_dn, e.surround_dn]
                            .iter()
                            .filter(|l| l.is_some())
                            .count();
                        EdgeCost {
                            ss_dn2: e.rms_residual_dn.powi(2) * e.samples as f64,
                            samples: e.samples,
                            parameters: 3 + levels,
                            edges: 1,
                        }
                    })
            })
            .collect();
        (!fits.is_empty()).then(|| {
            fits.iter().fold(
                EdgeCost {
                    ss_dn2: 0.0,
                    samples: 0,
                    parameters: 0,
                    edges: 0,
                },
                |a, e| EdgeCost {
                    ss_dn2: a.ss_dn2 + e.ss_dn2,
                    samples: a.samples + e.samples,
                    parameters: a.parameters + e.parameters,
                    edges: a.edges + e.edges,
                },
            )
        })
    };
    fit_sharpening(&cost)
}

/// At most `n` of `items`, evenly spread over them.
fn spread<'a, T>(items: &[&'a T], n: usize) -> Vec<&'a T> {
    let len = items.len();
    (0..n.min(len))
        .map(|k| items[k * len / n.min(len)])
        .collect()
}

/// The renderer's mask and optical blur that reproduce the footage's edges (the optical blur
/// alone when `start` is `None`: the footage shows no mask). The edge model reads blur and
/// mask through a continuous approximation (the mask's blur of pixel values as a
/// continuous Gaussian, the pixel grid fine against the blur), which a sub-pixel blur is not,
/// so its reading (`start`, and the blur σ the scenario holds) is a biased view of the
/// renderer's parameters. From there, the calibrated scenario is rendered at `frame` without
/// noise and the parameters (mask amount, mask σ, optical blur σ) are searched together (Nelder–Mead, [`RENDERS`] renders in two runs) for
/// the smallest squared difference to the footage over the marker, after an affine map of the
/// render's grey levels and the sub-pixel pose alignment the re-render check makes. `None`
/// when the render cannot be compared with the footage or the match does not reduce their
/// difference by [`MIN_GAIN`]: the scenario then keeps the edge fits' reading.
#[allow(clippy::too_many_arguments)]
pub(super) fn match_edges_by_render(
    start: Option<&SharpeningFit>,
    frame: usize,
    footage: &Crop,
    corners: &Corners,
    base: &Scenario,
    ovs: &mut [Override],
    typed: &dyn Fn(&[Override]) -> Option<Scenario>,
) -> Option<EdgeMatch> {
    const MASK: [(&str, f64, f64); 2] = [
        ("effects.sharpening.amount", 0.0, 5.0),
        ("effects.sharpening.sigma_px", 0.3, 10.0),
    ];
    // The blur stays near the edge fits' reading (within half of it and 0.3 px): a render
    // that cannot reproduce the footage (another mechanism, a marker elsewhere) would
    // otherwise be blurred until it matches nothing in particular.
    const BLUR_PATH: &str = "effects.optical_blur.sigma_px";
    let b0 = float_of(ovs, BLUR_PATH)?;
    let blur = (
        BLUR_PATH,
        (0.5 * b0 - 0.3).max(0.0),
        (1.5 * b0 + 0.3).min(20.0),
    );
    let mut paths = Vec::new();
    if let Some(m) = start {
        set_float(ovs, MASK[0].0, m.amount);
        set_float(ovs, MASK[1].0, m.sigma_px);
        paths.extend(MASK);
    }
    paths.push(blur);
    let misfit = |o: &[Override]| -> f64 {
        typed(o)
            .and_then(|mut s| {
                s.effects.pixel_noise.enabled = false;
                aligned_rms_dn(&s, frame, footage, corners, base)
            })
            .unwrap_or(f64::INFINITY)
    };
    let before = misfit(ovs);
    if !before.is_finite() {
        return None;
    }
    let now: Vec<f64> = paths.iter().filter_map(|p| float_of(ovs, p.0)).collect();
    if now.len() != paths.len() {
        return None;
    }
    let steps: Vec<f64> = paths
        .iter()
        .map(|p| (p.2 - p.1).min(1.0) * STEP_FRAC)
        .collect();
    // Nelder–Mead, restarted once from its best point with a fresh simplex: a simplex that
    // has collapsed across a shallow valley stops short of its floor.
    let objective = |x: &[f64]| with_values(ovs, &paths, x).map_or(f64::INFINITY, |o| misfit(&o));
    let (first, _) = nelder_mead(objective, &now, &steps, RENDERS / 2);
    let (best, value) = nelder_mead(objective, &first, &steps, RENDERS / 2);
    // A match that barely improves on the start is no evidence against the edge model's
    // reading (a blur of a few tenths of a pixel hardly changes the pixels): keep the reading.
    if value < (1.0 - MIN_GAIN) * before {
        if let Some(o) = with_values(ovs, &paths, &best) {
            ovs.clone_from_slice(&o);
        }
    }
    let after = misfit(ovs);
    if after >= before {
        return None;
    }
    // No interval is claimed from the misfit's curvature: on one frame the amount, the mask's
    // σ and the blur trade along a valley shallower than the model's own error (on footage
    // rendered with a known mask, the curvature's ±0.007 on the amount missed the truth by
    // 0.19), so the match states its values and the caller states what is known about them.
    let fitted: Vec<(&str, f64)> = paths
        .iter()
        .filter_map(|p| float_of(ovs, p.0).map(|v| (p.0, v)))
        .collect();
    for &(path, _) in &fitted {
        if let Some(o) = ovs.iter_mut().find(|o| o.path == path) {
            o.comment = match start {
                Some(m) => format!(
                    "matched by rendering frame {frame} against the footage (edge fits read {})",
                    m.describe()
                ),
                None => format!("matched by rendering frame {frame} against the footage"),
            };
        }
    }
    let find = |path: &str| fitted.iter().find(|f| f.0 == path).map(|f| f.1);
    Some(EdgeMatch {
        before_rms_dn: before,
        after_rms_dn: after,
        blur_px: find(BLUR_PATH)?,
        amount: find(MASK[0].0),
        mask_sigma_px: find(MASK[1].0),
    })
}

/// `base` with `paths` set to `x`, `None` where a value leaves its range.
fn with_values(base: &[Override], paths: &[(&str, f64, f64)], x: &[f64]) -> Option<Vec<Override>> {
    let mut trial = base.to_vec();
    for (&(path, lo, hi), &v) in paths.iter().zip(x) {
        if !(lo..=hi).contains(&v) {
            return None;
        }
        set_float(&mut trial, path, v);
    }
    Some(trial)
}

/// What [`match_edges_by_render`] found: footage − noiseless render before and after, DN RMS, and
/// the matched values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct EdgeMatch {
    pub before_rms_dn: f64,
    pub after_rms_dn: f64,
    pub blur_px: f64,
    pub amount: Option<f64>,
    pub mask_sigma_px: Option<f64>,
}

/// RMS of footage − `s`'s render over the re-render check's window, after its pose alignment.
fn aligned_rms_dn(
    s: &Scenario,
    frame: usize,
    footage: &Crop,
    corners: &Corners,
    base: &Scenario,
) -> Option<f64> {
    let render = render_at(s, frame, footage)?;
    let (win, centre, half_diagonal_px) = comparison_window(corners, base, footage, &render);
    let mut rows = residual_rows(footage, &render, &win, centre);
    // The render's grey levels at this frame, in the same pixel order as `rows`.
    let levels: Vec<f64> = window_pixels(footage, &render, &win)
        .map(|(_, _, _, r)| r as f64)
        .collect();
    if rows.is_empty() || levels.len() != rows.len() {
        return None;
    }
    // The levels are not what is matched here (they are matched later, and a glossy marker's
    // change with the angle is drawn later still): footage ≈ gain·render + offset by least
    // squares first, so only the edges' shape is left to the blur and the mask.
    let n = rows.len() as f64;
    let mean_r = levels.iter().sum::<f64>() / n;
    let footage_of = |p: &PixelResidual, r: f64| p.difference_dn + r;
    let mean_f = rows
        .iter()
        .zip(&levels)
        .map(|(p, &r)| footage_of(p, r))
        .sum::<f64>()
        / n;
    let (sxy, sxx) = rows
        .iter()
        .zip(&levels)
        .fold((0.0, 0.0), |(sxy, sxx), (p, &r)| {
            let (dr, df) = (r - mean_r, footage_of(p, r) - mean_f);
            (sxy + dr * df, sxx + dr * dr)
        });
    let gain = if sxx > 0.0 { sxy / sxx } else { 1.0 };
    for (p, &r) in rows.iter_mut().zip(&levels) {
        let f = footage_of(p, r);
        p.difference_dn = f - (mean_f + gain * (r - mean_r));
        p.jacobian.iter_mut().for_each(|j| *j *= gain);
    }
    let a = align(&rows, half_diagonal_px);
    Some((a.aligned_ss / n).sqrt())
}

/// The window `crop.rect` of frame `frame` of `s`.
fn render_at(s: &Scenario, frame: usize, crop: &Crop) -> Option<GrayImage> {
    let rig = crate::pipeline::rig::Rig::new(s).ok()?;
    let times = rig.frame_times.as_slice();
    let k = frame.min(times.len().checked_sub(1)?);
    let img = render_frame(
        &rig.animated(),
        &rig.settings,
        &FrameRequest {
            index: k as u64,
            t_s: times[k],
            window: crop.rect,
        },
    );
    Some(img)
}

/// Sets `path` to `v` at the precision the scenario is written with (what is searched is what
/// is written).
fn set_float(ovs: &mut [Override], path: &str, v: f64) {
    if let Some(o) = ovs.iter_mut().find(|o| o.path == path) {
        let text = format!("{v:.4}");
        o.value = Value::Float(text.parse().unwrap_or(v));
    }
}
