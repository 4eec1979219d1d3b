//! Edge-profile fits on the marker's grid lines: blur σ, edge position and material levels.
//!
//! A fit takes every pixel within a band across one straight grid line of the marker (an outer
//! side of the black square or a boundary between inner cells), away from the places along the
//! line where the pattern across it changes (cell corners), and fits the blurred, pixel-integrated
//! profile of the *known* pattern across the line: all material changes within reach (the inner
//! cells behind a border, the end of the white margin) are part of the model, so a band wider
//! than one cell is not a problem. Free parameters: the edge line's offset and tilt relative to
//! the line through the given corners, σ, and one level per material present (linear, solved at
//! every step: variable projection). Uncertainties come from the Jacobian at the solution.

use super::grid::{Homography, MarkerLayout, Material};
use super::{check_view, pixel, view_bounds, StatsError};
use crate::detect::GrayView;
use crate::estimate::lm;
use crate::numeric::dist::{normal_cdf, normal_pdf};
use nalgebra::{DMatrix, DVector};
use std::cell::RefCell;

/// Sampling and guard settings of an edge fit.
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeOptions {
    /// The largest blur σ expected, px: sets the band width and the guard kept from cell
    /// corners along the edge. Default 2.5.
    pub sigma_hint_px: f64,
    /// Half-width of the sampled band across the edge, px. Default `4·sigma_hint_px + 2`.
    pub half_width_px: Option<f64>,
    /// At most this many pixels per edge (evenly thinned beyond). Default 6000.
    pub max_samples: usize,
    /// Fewer usable pixels than this is an error. Default 40.
    pub min_samples: usize,
    /// The unsharp mask the footage went through after its blur, when known: the profile is
    /// then the mask applied to the blurred step. Default none.
    pub sharpening: Option<EdgeSharpening>,
}

/// An unsharp mask `v + amount·(v − G ∗ v)` (G Gaussian of `sigma_px`) applied to the pixels
/// across an edge. On a blurred, pixel-integrated step it gives (1 + amount)·R(σ) −
/// amount·R(√(σ² + sigma_px²)), R the step response (the mask's blur of pixel values treated as
/// a continuous Gaussian, exact to within the whole-pixel sampling of its taps).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeSharpening {
    pub amount: f64,
    pub sigma_px: f64,
}

impl Default for EdgeOptions {
    fn default() -> Self {
        Self {
            sigma_hint_px: 2.5,
            half_width_px: None,
            max_samples: 6000,
            min_samples: 40,
            sharpening: None,
        }
    }
}

/// A straight segment of a grid line of the marker (grid units: cells, black square [0, N]²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridEdge {
    /// `true`: on the line gy = `line`, running along gx; `false`: on gx = `line`.
    pub horizontal: bool,
    pub line: f64,
    /// Extent along the line, cells (`from` < `to`).
    pub from: f64,
    pub to: f64,
}

impl GridEdge {
    /// Outer side `side` (0..4) of an N-cell marker: side k runs from corner k to corner k+1
    /// (0: top, 1: right, 2: bottom, 3: left as printed).
    pub fn outer_side(side: usize, n: usize) -> GridEdge {
        let n = n as f64;
        let (horizontal, line) = match side % 4 {
            0 => (true, 0.0),
            1 => (false, n),
            2 => (true, n),
            _ => (false, 0.0),
        };
        GridEdge {
            horizontal,
            line,
            from: 0.0,
            to: n,
        }
    }

    fn grid_point(&self, t: f64, n: f64) -> (f64, f64) {
        if self.horizontal {
            (t, n)
        } else {
            (n, t)
        }
    }

    fn split(&self, g: [f64; 2]) -> (f64, f64) {
        if self.horizontal {
            (g[0], g[1])
        } else {
            (g[1], g[0])
        }
    }
}

/// One fitted edge.
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeProfile {
    pub edge: GridEdge,
    /// Unit normal of the edge in the image, pointing from its ink side to the other side
    /// (outer sides: outwards).
    pub normal: [f64; 2],
    /// The fitted edge line: a point at the middle of the segment, absolute px…
    pub point_px: [f64; 2],
    /// …and its unit direction (from the segment's `from` end to its `to` end).
    pub direction: [f64; 2],
    /// Gaussian blur σ, px, and its standard error.
    pub sigma_px: f64,
    pub sigma_stderr_px: f64,
    /// Offset of the fitted line from the line through the given corners, along `normal`, at
    /// the middle of the segment, px, and its standard error.
    pub offset_px: f64,
    pub offset_stderr_px: f64,
    /// Fitted levels (DN) of the materials the band contains.
    pub ink_dn: Option<f64>,
    pub paper_dn: Option<f64>,
    pub surround_dn: Option<f64>,
    /// RMS of the fit residuals, DN.
    pub rms_residual_dn: f64,
    /// Pixels used.
    pub samples: usize,
    /// Length of the segment in the image, px.
    pub length_px: f64,
}

/// [`step_response`] through the unsharp mask `sharpening`, if any.
fn sharpened_response(
    x: f64,
    sigma: f64,
    a: f64,
    b: f64,
    sharpening: Option<EdgeSharpening>,
) -> f64 {
    match sharpening {
        None => step_response(x, sigma, a, b),
        Some(m) => {
            let wide = sigma.hypot(m.sigma_px);
            (1.0 + m.amount) * step_response(x, sigma, a, b)
                - m.amount * step_response(x, wide, a, b)
        }
    }
}

/// [`step_response_d`] through the unsharp mask `sharpening`, if any (d/dσ through σ_wide too).
fn sharpened_response_d(
    x: f64,
    sigma: f64,
    a: f64,
    b: f64,
    sharpening: Option<EdgeSharpening>,
) -> [f64; 3] {
    match sharpening {
        None => step_response_d(x, sigma, a, b),
        Some(m) => {
            let wide = sigma.hypot(m.sigma_px);
            let (n, w) = (
                step_response_d(x, sigma, a, b),
                step_response_d(x, wide, a, b),
            );
            let (k, g) = (1.0 + m.amount, m.amount);
            [
                k * n[0] - g * w[0],
                k * n[1] - g * w[1],
                k * n[2] - g * w[2] * sigma / wide,
            ]
        }
    }
}

/// Response of a pixel centred at signed distance `x` (px) from an ideal 0 → 1 step, for a
/// Gaussian PSF of `sigma` and a pixel box whose projections on the edge normal are `a` ≥ `b`
/// wide (|cos θ|, |sin θ|): E[Φ((x + a·U₁ + b·U₂)/σ)], U uniform on (−½, ½).
pub(crate) fn step_response(x: f64, sigma: f64, a: f64, b: f64) -> f64 {
    if x > 0.0 {
        return 1.0 - step_response(-x, sigma, a, b);
    }
    if x < -(0.5 * (a + b) + 8.5 * sigma) {
        return 0.0;
    }
    if b < 0.1 {
        // The narrow box only adds its variance b²/12 (exact to second order).
        let s = (sigma * sigma + b * b / 12.0).sqrt();
        let g = |u: f64| u * normal_cdf(u / s) + s * normal_pdf(u / s);
        return (g(x + 0.5 * a) - g(x - 0.5 * a)) / a;
    }
    // H = ∫∫Φ: H(u) = (u² + σ²)/2·Φ(u/σ) + uσ/2·φ(u/σ).
    let h = |u: f64| {
        let z = u / sigma;
        0.5 * (u * u + sigma * sigma) * normal_cdf(z) + 0.5 * u * sigma * normal_pdf(z)
    };
    let (p, q) = (0.5 * (a + b), 0.5 * (a - b));
    (h(x + p) - h(x + q) - h(x - q) + h(x - p)) / (a * b)
}

/// [`step_response`] and its derivatives in `x` and in `sigma`, from the same Φ and φ values:
/// with g(u) = u·Φ(u/s) + s·φ(u/s), g′ = Φ and ∂g/∂s = φ; with H as there, H′(u) = u·Φ(u/σ) +
/// σ·φ(u/σ) and ∂H/∂σ = σ·Φ(u/σ). The response itself has the bits of [`step_response`].
pub(crate) fn step_response_d(x: f64, sigma: f64, a: f64, b: f64) -> [f64; 3] {
    if x > 0.0 {
        let [r, r_x, r_sigma] = step_response_d(-x, sigma, a, b);
        return [1.0 - r, r_x, -r_sigma];
    }
    if x < -(0.5 * (a + b) + 8.5 * sigma) {
        return [0.0; 3];
    }
    if b < 0.1 {
        let s = (sigma * sigma + b * b / 12.0).sqrt();
        let g = |u: f64| {
            let (cdf, pdf) = (normal_cdf(u / s), normal_pdf(u / s));
            [u * cdf + s * pdf, cdf, pdf]
        };
        let (hi, lo) = (g(x + 0.5 * a), g(x - 0.5 * a));
        return [
            (hi[0] - lo[0]) / a,
            (hi[1] - lo[1]) / a,
            sigma / s * (hi[2] - lo[2]) / a,
        ];
    }
    let h = |u: f64| {
        let z = u / sigma;
        let (cdf, pdf) = (normal_cdf(z), normal_pdf(z));
        [
            0.5 * (u * u + sigma * sigma) * cdf + 0.5 * u * sigma * pdf,
            u * cdf + sigma * pdf,
            sigma * cdf,
        ]
    };
    let (p, q) = (0.5 * (a + b), 0.5 * (a - b));
    let (hp, hq, hmq, hmp) = (h(x + p), h(x + q), h(x - q), h(x - p));
    std::array::from_fn(|i| (hp[i] - hq[i] - hmq[i] + hmp[i]) / (a * b))
}

/// One material interval across the edge, in px along the normal from the reference line.
#[derive(Debug, Clone, Copy)]
struct Interval {
    lo: f64,
    hi: f64,
    material: usize,
}

#[derive(Debug, Clone, Copy)]
struct Sample {
    value: f64,
    /// Signed distance from the reference line along the normal, px.
    d: f64,
    /// Position along the segment, normalised to [−½, ½].
    tau: f64,
    first: usize,
    count: usize,
}

/// Materials across the line at position `t` along it, over grid-normal coordinates
/// [n_lo, n_hi]: `(start, end, material)` with equal neighbours merged (ends unbounded).
fn normal_profile(
    layout: &MarkerLayout,
    edge: &GridEdge,
    breaks: &[f64],
    t: f64,
    n_lo: f64,
    n_hi: f64,
) -> Vec<(f64, f64, Material)> {
    let mut cuts: Vec<f64> = breaks
        .iter()
        .copied()
        .filter(|b| *b > n_lo && *b < n_hi)
        .collect();
    cuts.insert(0, f64::NEG_INFINITY);
    cuts.push(f64::INFINITY);
    let mut out: Vec<(f64, f64, Material)> = Vec::new();
    for w in cuts.windows(2) {
        let mid = match (w[0].is_finite(), w[1].is_finite()) {
            (true, true) => 0.5 * (w[0] + w[1]),
            (false, true) => w[1].min(n_hi) - 1e-3,
            (true, false) => w[0].max(n_lo) + 1e-3,
            (false, false) => 0.5 * (n_lo + n_hi),
        };
        let (gx, gy) = edge.grid_point(t, mid);
        let m = layout.material(gx, gy);
        match out.last_mut() {
            Some(last) if last.2 == m => last.1 = w[1],
            _ => out.push((w[0], w[1], m)),
        }
    }
    out
}

/// Stretches of the normal coordinate where two profiles differ in material.
fn differing(p: &[(f64, f64, Material)], q: &[(f64, f64, Material)]) -> Vec<(f64, f64)> {
    let at = |prof: &[(f64, f64, Material)], n: f64| {
        prof.iter().find(|iv| n >= iv.0 && n < iv.1).map(|iv| iv.2)
    };
    let mut cuts: Vec<f64> = p
        .iter()
        .chain(q)
        .flat_map(|iv| [iv.0, iv.1])
        .filter(|v| v.is_finite())
        .collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    if cuts.is_empty() {
        return if at(p, 0.0) != at(q, 0.0) {
            vec![(f64::NEG_INFINITY, f64::INFINITY)]
        } else {
            Vec::new()
        };
    }
    let mut bounds = vec![f64::NEG_INFINITY];
    bounds.extend(cuts);
    bounds.push(f64::INFINITY);
    let mut out: Vec<(f64, f64)> = Vec::new();
    for w in bounds.windows(2) {
        let mid = match (w[0].is_finite(), w[1].is_finite()) {
            (true, true) => 0.5 * (w[0] + w[1]),
            (false, _) => w[1] - 1.0,
            (_, false) => w[0] + 1.0,
        };
        if at(p, mid) != at(q, mid) {
            match out.last_mut() {
                Some(last) if last.1 == w[0] => last.1 = w[1],
                _ => out.push((w[0], w[1])),
            }
        }
    }
    out
}

/// Fits the edge on grid segment `edge` of the marker with corners `corners_px`.
pub fn fit_grid_edge(
    view: &GrayView<'_>,
    corners_px: &[[f64; 2]; 4],
    layout: &MarkerLayout,
    edge: &GridEdge,
    options: &EdgeOptions,
) -> Result<EdgeProfile, StatsError> {
    check_view(view)?;
    let what = || {
        format!(
            "edge on grid line {} = {} ({}..{})",
            if edge.horizontal { "y" } else { "x" },
            edge.line,
            edge.from,
            edge.to
        )
    };
    if edge.from.partial_cmp(&edge.to) != Some(std::cmp::Ordering::Less) || !edge.line.is_finite() {
        return Err(StatsError::Invalid(format!("{}: empty segment", what())));
    }
    let hint = options.sigma_hint_px.max(0.1);
    let n_cells = layout.side_cells();
    let h = Homography::from_corners(corners_px, n_cells)?;
    let map = |t: f64, n: f64| {
        let (gx, gy) = edge.grid_point(t, n);
        h.map(gx, gy)
    };
    let a_px = map(edge.from, edge.line);
    let b_px = map(edge.to, edge.line);
    let length_px = (b_px[0] - a_px[0]).hypot(b_px[1] - a_px[1]);
    if length_px.is_nan() || length_px < 3.0 {
        return Err(StatsError::TooFew {
            what: format!("{}: segment length in px", what()),
            got: length_px.max(0.0) as usize,
            need: 3,
        });
    }
    let dir = [
        (b_px[0] - a_px[0]) / length_px,
        (b_px[1] - a_px[1]) / length_px,
    ];
    let mid_t = 0.5 * (edge.from + edge.to);
    let mut normal = [-dir[1], dir[0]];
    let probe = map(mid_t, edge.line + 0.01);
    let probe0 = map(mid_t, edge.line);
    if normal[0] * (probe[0] - probe0[0]) + normal[1] * (probe[1] - probe0[1]) < 0.0 {
        normal = [-normal[0], -normal[1]];
    }
    let lo = map(mid_t, edge.line - 0.5);
    let hi = map(mid_t, edge.line + 0.5);
    let cell_n_px = (hi[0] - lo[0]).hypot(hi[1] - lo[1]);
    let cell_t_px = length_px / (edge.to - edge.from);
    let band_px = options.half_width_px.unwrap_or(4.0 * hint + 2.0);
    let reach_cells = (band_px + 8.5 * hint + 2.0) / cell_n_px;
    let band_cells = band_px / cell_n_px;
    let breaks = layout.breaks();
    let limit = layout.margin_cells().unwrap_or(0.0) + 0.5;
    let nf = n_cells as f64;

    // Where along the line the pattern across it changes: guard those places.
    let profile_at = |t: f64| {
        normal_profile(
            layout,
            edge,
            &breaks,
            t,
            edge.line - reach_cells,
            edge.line + reach_cells,
        )
    };
    let mut t_cuts: Vec<f64> = breaks
        .iter()
        .copied()
        .filter(|b| *b > edge.from && *b < edge.to)
        .collect();
    t_cuts.insert(0, edge.from);
    t_cuts.push(edge.to);
    let segments: Vec<(f64, f64)> = t_cuts.windows(2).map(|w| (w[0], w[1])).collect();
    let profiles: Vec<Vec<(f64, f64, Material)>> = segments
        .iter()
        .map(|(a, b)| profile_at(0.5 * (a + b)))
        .collect();
    // Near a cut the pattern across the line changes over some stretch of the normal: keep
    // samples a guard away from that stretch (the boundary running across the line there).
    let guard_px = 3.0 * hint + 1.0;
    let guard_n = guard_px / cell_n_px;
    let mut zones: Vec<(f64, f64, f64)> = Vec::new();
    for (j, &c) in t_cuts.iter().enumerate() {
        let left = if j == 0 {
            profile_at(c - 1e-3)
        } else {
            profiles[j - 1].clone()
        };
        let right = if j + 1 == t_cuts.len() {
            profile_at(c + 1e-3)
        } else {
            profiles[j].clone()
        };
        for (na, nb) in differing(&left, &right) {
            zones.push((c, na - guard_n, nb + guard_n));
        }
    }
    let usable: Vec<(f64, f64, usize)> = segments
        .iter()
        .enumerate()
        .map(|(k, &(a, b))| (a, b, k))
        .collect();
    // Report the normal from the ink side.
    if let Some(&(a, b, _)) = usable
        .iter()
        .max_by(|x, y| (x.1 - x.0).total_cmp(&(y.1 - y.0)))
    {
        let t = 0.5 * (a + b);
        let (gx, gy) = edge.grid_point(t, edge.line + 0.25);
        let (hx, hy) = edge.grid_point(t, edge.line - 0.25);
        if layout.material(gx, gy) == Material::Ink && layout.material(hx, hy) != Material::Ink {
            normal = [-normal[0], -normal[1]];
        }
    }
    let flipped = {
        let q = [probe[0] - probe0[0], probe[1] - probe0[1]];
        normal[0] * q[0] + normal[1] * q[1] < 0.0
    };

    // Pixels of the band.
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for t in [edge.from, edge.to] {
        for nn in [edge.line - 1.3 * band_cells, edge.line + 1.3 * band_cells] {
            let p = map(t, nn);
            xs.push(p[0]);
            ys.push(p[1]);
        }
    }
    let fold = |v: &[f64], f: fn(f64, f64) -> f64, init: f64| v.iter().copied().fold(init, f);
    let x0 = fold(&xs, f64::min, f64::INFINITY).floor() as i64;
    let x1 = fold(&xs, f64::max, f64::NEG_INFINITY).ceil() as i64;
    let y0 = fold(&ys, f64::min, f64::INFINITY).floor() as i64;
    let y1 = fold(&ys, f64::max, f64::NEG_INFINITY).ceil() as i64;
    let (vx0, vy0, vx1, vy1) = view_bounds(view);
    if x0 < vx0 || y0 < vy0 || x1 > vx1 || y1 > vy1 {
        return Err(StatsError::OutsideView {
            what: what(),
            x0,
            y0,
            x1,
            y1,
        });
    }
    let mut samples: Vec<Sample> = Vec::new();
    let mut intervals: Vec<Interval> = Vec::new();
    let mut present = [false; 3];
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (xf, yf) = (x as f64, y as f64);
            let d = normal[0] * (xf - a_px[0]) + normal[1] * (yf - a_px[1]);
            if d.abs() > band_px {
                continue;
            }
            let g = h.unmap(xf, yf);
            if !(g[0] >= -limit && g[0] <= nf + limit && g[1] >= -limit && g[1] <= nf + limit) {
                continue;
            }
            let (t, nn) = edge.split(g);
            let Some(&(_, _, seg)) = usable.iter().find(|u| t >= u.0 && t <= u.1) else {
                continue;
            };
            if zones
                .iter()
                .any(|z| (t - z.0).abs() * cell_t_px < guard_px && nn >= z.1 && nn <= z.2)
            {
                continue;
            }
            let Some(value) = pixel(view, x, y) else {
                continue;
            };
            let first = intervals.len();
            let prof = &profiles[seg];
            // Offsets along the (final) normal; grid order runs against it when flipped.
            let offset = |nn: f64| {
                if nn.is_finite() {
                    let p = map(t, nn);
                    normal[0] * (p[0] - a_px[0]) + normal[1] * (p[1] - a_px[1])
                } else if flipped {
                    -nn
                } else {
                    nn
                }
            };
            for &(s, e, m) in prof {
                let (lo, hi) = if flipped {
                    (offset(e), offset(s))
                } else {
                    (offset(s), offset(e))
                };
                present[m.index()] = true;
                intervals.push(Interval {
                    lo,
                    hi,
                    material: m.index(),
                });
            }
            let along = dir[0] * (xf - a_px[0]) + dir[1] * (yf - a_px[1]);
            samples.push(Sample {
                value: value as f64,
                d,
                tau: along / length_px - 0.5,
                first,
                count: intervals.len() - first,
            });
        }
    }
    if samples.len() > options.max_samples.max(1) {
        let keep = options.max_samples.max(1);
        let n = samples.len();
        samples = (0..keep).map(|k| samples[k * n / keep]).collect();
    }
    if samples.len() < options.min_samples.max(8) {
        return Err(StatsError::TooFew {
            what: what(),
            got: samples.len(),
            need: options.min_samples.max(8),
        });
    }
    let materials: Vec<usize> = (0..3).filter(|&m| present[m]).collect();
    let (wa, wb) = {
        let (c, s) = (normal[0].abs(), normal[1].abs());
        (c.max(s), c.min(s))
    };
    let rows = RefCell::new(WeightRows::default());
    let model = EdgeModel {
        samples: &samples,
        intervals: &intervals,
        materials: &materials,
        box_a: wa,
        box_b: wb,
        sharpening: options.sharpening,
        max_sigma: 3.0 * hint + 5.0,
        max_offset: 0.5 * band_px,
        rows: Some(&rows),
    };
    let residuals = |p: &[f64], out: &mut Vec<f64>| model.residuals(p, out).is_some();
    // Coarse start: the edge position over a small grid at a middling σ, on every
    // [`COARSE_STRIDE`]-th sample. The grid only picks the basin the fit starts from, which a
    // share of the samples ranks as all of them do; on all of them it had cost a third of the
    // fit.
    let coarse_samples: Vec<Sample> = samples.iter().step_by(COARSE_STRIDE).copied().collect();
    let coarse = EdgeModel {
        samples: &coarse_samples,
        rows: None,
        ..model
    };
    let mut best = (f64::INFINITY, 0.0);
    let mut buf = Vec::new();
    for k in -8..=8 {
        let e0 = k as f64 * 0.25;
        if coarse.residuals(&[e0, 0.0, 1.0], &mut buf).is_some() {
            let c: f64 = buf.iter().map(|r| r * r).sum();
            if c < best.0 {
                best = (c, e0);
            }
        }
    }
    let jacobian = |p: &[f64], r: &[f64]| model.jacobian(p, r);
    let fit = lm::minimise_with_jacobian(
        &residuals,
        &jacobian,
        &[best.1, 0.0, 1.0],
        &[1e-4, 1e-4, 1e-4],
        60,
    )
    .ok_or_else(|| StatsError::NoFit {
        what: what(),
        reason: "no admissible start".into(),
    })?;
    let mut out = Vec::new();
    let levels = model
        .residuals(&fit.params, &mut out)
        .ok_or_else(|| StatsError::NoFit {
            what: what(),
            reason: "levels not determined".into(),
        })?;
    let se = fit.std_errors();
    let (e0, e1, sigma) = (fit.params[0], fit.params[1], fit.params[2]);
    if !se[2].is_finite() {
        return Err(StatsError::NoFit {
            what: what(),
            reason: "σ not determined by the data".into(),
        });
    }
    let level = |m: Material| {
        materials
            .iter()
            .position(|&k| k == m.index())
            .map(|i| levels[i])
            .filter(|v| v.is_finite())
    };
    let mid = [
        a_px[0] + dir[0] * 0.5 * length_px,
        a_px[1] + dir[1] * 0.5 * length_px,
    ];
    let fdir = [
        dir[0] + normal[0] * e1 / length_px,
        dir[1] + normal[1] * e1 / length_px,
    ];
    let fl = fdir[0].hypot(fdir[1]);
    Ok(EdgeProfile {
        edge: *edge,
        normal,
        point_px: [mid[0] + normal[0] * e0, mid[1] + normal[1] * e0],
        direction: [fdir[0] / fl, fdir[1] / fl],
        sigma_px: sigma,
        sigma_stderr_px: se[2],
        offset_px: e0,
        offset_stderr_px: se[0],
        ink_dn: level(Material::Ink),
        paper_dn: level(Material::Paper),
        surround_dn: level(Material::Surround),
        rms_residual_dn: (fit.cost / samples.len() as f64).sqrt(),
        samples: samples.len(),
        length_px,
    })
}

/// The response `previous` holds for `boundary` (the same bits: a boundary the previous interval
/// shares), else `compute`'s: a response is a pure function of its boundary, so either way the
/// bits are the same.
fn shared_or<T: Copy>(previous: &[(f64, T); 2], boundary: f64, compute: impl FnOnce() -> T) -> T {
    previous
        .iter()
        .find(|(b, _)| b.to_bits() == boundary.to_bits())
        .map_or_else(compute, |&(_, r)| r)
}

/// Adds to `w[slot[m]]` the weight of each material m across the edge at a pixel `x` px from
/// the fitted line: the share of the pixel's blurred response that falls in its intervals.
///
/// Neighbouring intervals share a boundary (one's `hi` is the next one's `lo`, or the reverse
/// where the normal runs against the grid order): its response, a pure function of the boundary
/// here, is computed once and reused bit for bit. The responses are most of an edge fit's cost.
#[allow(clippy::too_many_arguments)] // the model's fixed pieces
fn add_material_weights(
    x: f64,
    intervals: &[Interval],
    sigma: f64,
    box_a: f64,
    box_b: f64,
    sharpening: Option<EdgeSharpening>,
    slot: &[usize; 3],
    w: &mut [f64],
) {
    let response = |previous: &[(f64, f64); 2], boundary: f64| {
        shared_or(previous, boundary, || {
            sharpened_response(x - boundary, sigma, box_a, box_b, sharpening)
        })
    };
    let mut previous = [(f64::NAN, 0.0); 2];
    for iv in intervals {
        let upper = if iv.lo.is_finite() {
            response(&previous, iv.lo)
        } else {
            1.0
        };
        let lower = if iv.hi.is_finite() {
            response(&previous, iv.hi)
        } else {
            0.0
        };
        previous = [(iv.lo, upper), (iv.hi, lower)];
        w[slot[iv.material]] += upper - lower;
    }
}

/// Every how many samples the coarse start of an edge fit reads.
const COARSE_STRIDE: usize = 4;

/// [`add_material_weights`] with the weights' derivatives in `x` (into `w_x`) and in `sigma`
/// (into `w_sigma`).
#[allow(clippy::too_many_arguments)] // the model's fixed pieces, as `add_material_weights` takes
fn add_material_weights_d(
    x: f64,
    intervals: &[Interval],
    sigma: f64,
    box_a: f64,
    box_b: f64,
    sharpening: Option<EdgeSharpening>,
    slot: &[usize; 3],
    w: &mut [f64],
    w_x: &mut [f64],
    w_sigma: &mut [f64],
) {
    // A boundary shared with the previous interval is computed once, as in
    // [`add_material_weights`].
    let response = |previous: &[(f64, [f64; 3]); 2], boundary: f64, unbounded: f64| {
        if !boundary.is_finite() {
            return [unbounded, 0.0, 0.0];
        }
        shared_or(previous, boundary, || {
            sharpened_response_d(x - boundary, sigma, box_a, box_b, sharpening)
        })
    };
    let mut previous = [(f64::NAN, [0.0; 3]); 2];
    for iv in intervals {
        let upper = response(&previous, iv.lo, 1.0);
        let lower = response(&previous, iv.hi, 0.0);
        previous = [(iv.lo, upper), (iv.hi, lower)];
        let m = slot[iv.material];
        w[m] += upper[0] - lower[0];
        w_x[m] += upper[1] - lower[1];
        w_sigma[m] += upper[2] - lower[2];
    }
}

/// The weights of every sample and their derivatives at one set of parameters, as the last
/// residual pass computed them (n × k each, row-major).
#[derive(Default)]
struct WeightRows {
    p_bits: Option<[u64; 3]>,
    w: Vec<f64>,
    w_x: Vec<f64>,
    w_sigma: Vec<f64>,
}

/// The profile model over the collected samples; parameters (offset, tilt, σ).
#[derive(Clone, Copy)]
struct EdgeModel<'a> {
    samples: &'a [Sample],
    intervals: &'a [Interval],
    materials: &'a [usize],
    box_a: f64,
    box_b: f64,
    sharpening: Option<EdgeSharpening>,
    max_sigma: f64,
    max_offset: f64,
    /// Where a residual pass leaves its weights' derivatives for the Jacobian at the same
    /// parameters (the Levenberg–Marquardt solver asks for it right after the residuals of the
    /// point it accepts): the Φ and φ values are most of an edge fit's cost, and the Jacobian
    /// pass recomputed them. `None` where no Jacobian follows (the coarse start).
    rows: Option<&'a RefCell<WeightRows>>,
}

impl EdgeModel<'_> {
    /// Fills the residuals for (e0, e1, σ) and returns the fitted levels, `None` where the
    /// parameters are outside their range or the levels are not determined.
    fn residuals(&self, p: &[f64], out: &mut Vec<f64>) -> Option<Vec<f64>> {
        let (e0, e1, sigma) = (p[0], p[1], p[2]);
        let admissible = (0.05..=self.max_sigma).contains(&sigma)
            && e0.abs() <= self.max_offset
            && e1.abs() <= self.max_offset;
        if !admissible {
            return None;
        }
        let k = self.materials.len();
        let mut slot = [usize::MAX; 3];
        for (i, &m) in self.materials.iter().enumerate() {
            slot[m] = i;
        }
        let n = self.samples.len();
        let mut weights = vec![0.0; n * k];
        let mut ata = vec![vec![0.0; k]; k];
        let mut atb = vec![0.0; k];
        let mut rows = self.rows.map(|c| c.borrow_mut());
        if let Some(c) = rows.as_deref_mut() {
            c.p_bits = None;
            for v in [&mut c.w_x, &mut c.w_sigma] {
                v.clear();
                v.resize(n * k, 0.0);
            }
        }
        for (idx, (s, w)) in self
            .samples
            .iter()
            .zip(weights.chunks_exact_mut(k))
            .enumerate()
        {
            let x = s.d - (e0 + e1 * s.tau);
            let intervals = &self.intervals[s.first..s.first + s.count];
            let (a, b) = (self.box_a, self.box_b);
            match rows.as_deref_mut() {
                Some(c) => {
                    let at = idx * k..(idx + 1) * k;
                    let (w_x, w_sigma) = (&mut c.w_x[at.clone()], &mut c.w_sigma[at]);
                    let m = self.sharpening;
                    add_material_weights_d(x, intervals, sigma, a, b, m, &slot, w, w_x, w_sigma);
                }
                None => add_material_weights(x, intervals, sigma, a, b, self.sharpening, &slot, w),
            }
            for i in 0..k {
                atb[i] += w[i] * s.value;
                for j in 0..k {
                    ata[i][j] += w[i] * w[j];
                }
            }
        }
        if let Some(mut c) = rows {
            c.w.clone_from(&weights);
            c.p_bits = Some([e0.to_bits(), e1.to_bits(), sigma.to_bits()]);
        }
        // Materials within reach of the model but not of the sampled band carry no weight:
        // leave them out of the solve (their level is NaN, reported as absent).
        let active: Vec<usize> = (0..k).filter(|&i| ata[i][i] > 1e-6).collect();
        if active.is_empty() {
            return None;
        }
        let sub_a: Vec<Vec<f64>> = active
            .iter()
            .map(|&i| active.iter().map(|&j| ata[i][j]).collect())
            .collect();
        let sub_b: Vec<f64> = active.iter().map(|&i| atb[i]).collect();
        let sol = crate::numeric::linalg::solve_rows(&sub_a, &sub_b)?;
        let mut levels = vec![f64::NAN; k];
        for (&i, v) in active.iter().zip(sol) {
            levels[i] = v;
        }
        out.clear();
        out.extend(
            self.samples
                .iter()
                .zip(weights.chunks_exact(k))
                .map(|(s, w)| {
                    w.iter()
                        .zip(&levels)
                        .filter(|(_, l)| l.is_finite())
                        .map(|(a, b)| a * b)
                        .sum::<f64>()
                        - s.value
                }),
        );
        Some(levels)
    }

    /// ∂r/∂(e0, e1, σ) of [`Self::residuals`] at `p`, whose residuals are `r`: the levels solve
    /// a linear least-squares problem at every `p`, so r = W·ℓ − v with ℓ = (WᵀW)⁻¹Wᵀv, and
    /// ∂r = ∂W·ℓ − W·(WᵀW)⁻¹(Wᵀ·∂W·ℓ + ∂Wᵀ·r) (Golub and Pereyra's derivative of the
    /// projected residual, over the materials the solve keeps). One pass over the samples, where
    /// forward differences took three.
    fn jacobian(&self, p: &[f64], r: &[f64]) -> Option<DMatrix<f64>> {
        let (e0, e1, sigma) = (p[0], p[1], p[2]);
        let (n, k) = (self.samples.len(), self.materials.len());
        if r.len() != n {
            return None;
        }
        let mut slot = [usize::MAX; 3];
        for (i, &m) in self.materials.iter().enumerate() {
            slot[m] = i;
        }
        // W and its derivatives in e0, e1 and σ, n × k each.
        let mut w = DMatrix::<f64>::zeros(n, k);
        let mut dw = [
            DMatrix::<f64>::zeros(n, k),
            DMatrix::<f64>::zeros(n, k),
            DMatrix::<f64>::zeros(n, k),
        ];
        let (mut row, mut row_x, mut row_sigma) = (vec![0.0; k], vec![0.0; k], vec![0.0; k]);
        let p_bits = [e0.to_bits(), e1.to_bits(), sigma.to_bits()];
        let cached = self
            .rows
            .map(|c| c.borrow())
            .filter(|c| c.p_bits == Some(p_bits) && c.w.len() == n * k);
        for (i, s) in self.samples.iter().enumerate() {
            if let Some(c) = &cached {
                let at = i * k..(i + 1) * k;
                row.copy_from_slice(&c.w[at.clone()]);
                row_x.copy_from_slice(&c.w_x[at.clone()]);
                row_sigma.copy_from_slice(&c.w_sigma[at]);
            } else {
                row.fill(0.0);
                row_x.fill(0.0);
                row_sigma.fill(0.0);
                add_material_weights_d(
                    s.d - (e0 + e1 * s.tau),
                    &self.intervals[s.first..s.first + s.count],
                    sigma,
                    self.box_a,
                    self.box_b,
                    self.sharpening,
                    &slot,
                    &mut row,
                    &mut row_x,
                    &mut row_sigma,
                );
            }
            for m in 0..k {
                w[(i, m)] = row[m];
                // x = d − e0 − e1·τ.
                dw[0][(i, m)] = -row_x[m];
                dw[1][(i, m)] = -row_x[m] * s.tau;
                dw[2][(i, m)] = row_sigma[m];
            }
        }
        // The materials the solve keeps, as [`Self::residuals`] chooses them.
        let active: Vec<usize> = (0..k)
            .filter(|&m| w.column(m).norm_squared() > 1e-6)
            .collect();
        if active.is_empty() {
            return None;
        }
        let w = w.select_columns(&active);
        let wtw = w.tr_mul(&w);
        let v = DVector::from_iterator(n, self.samples.iter().map(|s| s.value));
        let levels = crate::numeric::linalg::solve(&wtw, &w.tr_mul(&v))?;
        let r = DVector::from_column_slice(r);
        let mut jac = DMatrix::<f64>::zeros(n, 3);
        for (j, d) in dw.iter().enumerate() {
            let d = d.select_columns(&active);
            let d_levels = &d * &levels;
            let t = w.tr_mul(&d_levels) + d.tr_mul(&r);
            let c = crate::numeric::linalg::solve(&wtw, &t)?;
            jac.set_column(j, &(d_levels - &w * c));
        }
        Some(jac)
    }
}

/// Fits the four outer sides of the black square (side k from corner k to corner k+1).
pub fn outer_edge_profiles(
    view: &GrayView<'_>,
    corners_px: &[[f64; 2]; 4],
    layout: &MarkerLayout,
    options: &EdgeOptions,
) -> [Result<EdgeProfile, StatsError>; 4] {
    let n = layout.side_cells();
    std::array::from_fn(|side| {
        fit_grid_edge(
            view,
            corners_px,
            layout,
            &GridEdge::outer_side(side, n),
            options,
        )
    })
}

/// Fits every straight run of boundaries between inner cells of different colour that is at
/// least `min_run_cells` long (the fits that succeed; runs too small for the blur give errors and
/// are left out).
pub fn inner_edge_profiles(
    view: &GrayView<'_>,
    corners_px: &[[f64; 2]; 4],
    layout: &MarkerLayout,
    options: &EdgeOptions,
    min_run_cells: usize,
) -> Vec<EdgeProfile> {
    let n = layout.side_cells();
    let c = &layout.cells;
    let mut edges = Vec::new();
    for horizontal in [true, false] {
        for line in 1..n {
            let differs = |k: usize| {
                if horizontal {
                    c[line - 1][k] != c[line][k]
                } else {
                    c[k][line - 1] != c[k][line]
                }
            };
            let mut k = 0;
            while k < n {
                if !differs(k) {
                    k += 1;
                    continue;
                }
                let start = k;
                while k < n && differs(k) {
                    k += 1;
                }
                if k - start >= min_run_cells.max(1) {
                    edges.push(GridEdge {
                        horizontal,
                        line: line as f64,
                        from: start as f64,
                        to: k as f64,
                    });
                }
            }
        }
    }
    edges
        .iter()
        .filter_map(|e| fit_grid_edge(view, corners_px, layout, e, options).ok())
        .collect()
}

/// Corners from the four fitted outer sides (side k from corner k to corner k+1): corner k is
/// the intersection of sides k−1 and k. `None` unless all four outer sides are given and the
/// lines intersect.
pub fn refined_corners(profiles: &[EdgeProfile], side_cells: usize) -> Option<[[f64; 2]; 4]> {
    let side = |k: usize| {
        let want = GridEdge::outer_side(k, side_cells);
        profiles
            .iter()
            .find(|p| p.edge.horizontal == want.horizontal && p.edge.line == want.line)
    };
    let sides: Vec<&EdgeProfile> = (0..4).map(side).collect::<Option<_>>()?;
    let mut out = [[0.0; 2]; 4];
    for (k, o) in out.iter_mut().enumerate() {
        let (p, q) = (sides[(k + 3) % 4], sides[k]);
        let det = p.direction[0] * q.direction[1] - p.direction[1] * q.direction[0];
        if det.abs() < 1e-9 {
            return None;
        }
        let w = [q.point_px[0] - p.point_px[0], q.point_px[1] - p.point_px[1]];
        let s = (w[0] * q.direction[1] - w[1] * q.direction[0]) / det;
        *o = [
            p.point_px[0] + s * p.direction[0],
            p.point_px[1] + s * p.direction[1],
        ];
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference: E[Φ((x + aU₁ + bU₂)/σ)] by a fine midpoint rule.
    fn brute(x: f64, sigma: f64, a: f64, b: f64) -> f64 {
        let m = 400;
        let mut s = 0.0;
        for i in 0..m {
            for j in 0..m {
                let u1 = (i as f64 + 0.5) / m as f64 - 0.5;
                let u2 = (j as f64 + 0.5) / m as f64 - 0.5;
                s += normal_cdf((x + a * u1 + b * u2) / sigma);
            }
        }
        s / (m * m) as f64
    }

    #[test]
    fn step_response_matches_numerical_integration() {
        for &(sigma, theta) in &[
            (0.3, 0.0),
            (0.5, 0.3),
            (1.2, 0.785),
            (2.5, 0.05),
            (0.1, 0.6),
        ] {
            let (a, b) = (f64::cos(theta).abs(), f64::sin(theta).abs());
            let (a, b) = (a.max(b), a.min(b));
            for &x in &[-3.0, -1.0, -0.4, 0.0, 0.2, 0.7, 2.0] {
                let got = step_response(x, sigma, a, b);
                let want = brute(x, sigma, a, b);
                assert!(
                    (got - want).abs() < 2e-4,
                    "σ {sigma} θ {theta} x {x}: {got} vs {want}"
                );
            }
        }
        assert!((normal_cdf(1.959963984540054) - 0.975).abs() < 1e-7);
    }

    /// Through a mask, the response is the mask's combination of two step responses, and its
    /// derivatives (in σ through the wide one's √(σ² + σm²) too) match central differences.
    #[test]
    fn the_sharpened_response_and_its_derivatives_match_their_definition() {
        let m = EdgeSharpening {
            amount: 0.7,
            sigma_px: 1.3,
        };
        let h = 1e-5;
        for &(sigma, a, b) in &[(0.4, 1.0, 0.0), (1.1, 0.8, 0.6)] {
            for &x in &[-2.5, -0.6, 0.0, 0.3, 1.7] {
                let want = 1.7 * step_response(x, sigma, a, b)
                    - 0.7 * step_response(x, sigma.hypot(1.3), a, b);
                assert_eq!(sharpened_response(x, sigma, a, b, Some(m)), want);
                let [r, r_x, r_s] = sharpened_response_d(x, sigma, a, b, Some(m));
                assert!((r - want).abs() < 1e-12);
                let f = |x: f64, s: f64| sharpened_response(x, s, a, b, Some(m));
                let dx = (f(x + h, sigma) - f(x - h, sigma)) / (2.0 * h);
                let ds = (f(x, sigma + h) - f(x, sigma - h)) / (2.0 * h);
                assert!((r_x - dx).abs() < 1e-7, "x {x} σ {sigma}: {r_x} vs {dx}");
                assert!((r_s - ds).abs() < 1e-7, "x {x} σ {sigma}: {r_s} vs {ds}");
                assert_eq!(
                    sharpened_response(x, sigma, a, b, None),
                    step_response(x, sigma, a, b)
                );
            }
        }
        // The halo: past the step the sharpened response overshoots 1, before it undershoots 0.
        assert!(sharpened_response(1.5, 0.4, 1.0, 0.0, Some(m)) > 1.01);
        assert!(sharpened_response(-1.5, 0.4, 1.0, 0.0, Some(m)) < -0.01);
    }

    /// The derivatives of the step response against central differences (step 1e-5: their
    /// truncation error is ~1e-10 here, far below the 1e-7 allowed), and the response itself
    /// bit for bit, on both branches (a narrow box, b < 0.1, and a wide one).
    #[test]
    fn step_response_derivatives_match_central_differences() {
        let h = 1e-5;
        for &(sigma, theta) in &[(0.3, 0.0), (0.5, 0.3), (1.2, 0.785), (2.5, 0.05)] {
            let (a, b) = (f64::cos(theta).abs(), f64::sin(theta).abs());
            let (a, b) = (a.max(b), a.min(b));
            for &x in &[-3.0, -1.0, -0.4, -0.05, 0.2, 0.7, 2.0] {
                let [r, r_x, r_sigma] = step_response_d(x, sigma, a, b);
                assert_eq!(r.to_bits(), step_response(x, sigma, a, b).to_bits());
                let dx = (step_response(x + h, sigma, a, b) - step_response(x - h, sigma, a, b))
                    / (2.0 * h);
                let ds = (step_response(x, sigma + h, a, b) - step_response(x, sigma - h, a, b))
                    / (2.0 * h);
                assert!(
                    (r_x - dx).abs() < 1e-7,
                    "σ {sigma} θ {theta} x {x}: {r_x} vs {dx}"
                );
                assert!(
                    (r_sigma - ds).abs() < 1e-7,
                    "σ {sigma} θ {theta} x {x}: {r_sigma} vs {ds}"
                );
            }
        }
    }

    /// The edge model's Jacobian (the derivative of the residual with the levels re-solved at
    /// every parameter) against central differences of its residuals, column by column, on an
    /// edge with three materials seen through a tilted pixel box and a narrow one.
    #[test]
    fn edge_model_jacobian_matches_central_differences() {
        for (box_a, box_b) in [(0.9, 0.4), (1.0, 0.02)] {
            let mut samples = Vec::new();
            let mut intervals = Vec::new();
            for i in 0..300 {
                let d = -6.0 + 12.0 * (i as f64 + 0.5) / 300.0;
                let tau = ((i * 37) % 300) as f64 / 300.0 - 0.5;
                let first = intervals.len();
                for (lo, hi, material) in [
                    (f64::NEG_INFINITY, 0.0, 0),
                    (0.0, 2.0, 1),
                    (2.0, f64::INFINITY, 2),
                ] {
                    intervals.push(Interval { lo, hi, material });
                }
                samples.push(Sample {
                    value: 0.0,
                    d,
                    tau,
                    first,
                    count: 3,
                });
            }
            // Values of a known edge, with a deterministic ripple for residuals.
            let truth = [0.2, -0.1, 1.1];
            let levels = [30.0, 200.0, 120.0];
            let slot = [0, 1, 2];
            for (i, s) in samples.iter_mut().enumerate() {
                let mut w = [0.0; 3];
                let x = s.d - (truth[0] + truth[1] * s.tau);
                let iv = &intervals[s.first..s.first + s.count];
                add_material_weights(x, iv, truth[2], box_a, box_b, None, &slot, &mut w);
                let ripple = 3.0 * ((i * 7919) % 13) as f64 / 13.0 - 1.5;
                s.value = w.iter().zip(levels).map(|(w, l)| w * l).sum::<f64>() + ripple;
            }
            let model = EdgeModel {
                samples: &samples,
                intervals: &intervals,
                materials: &[0, 1, 2],
                box_a,
                box_b,
                sharpening: None,
                max_sigma: 12.5,
                max_offset: 5.0,
                rows: None,
            };
            let p = [0.05, 0.1, 1.3];
            let mut r = Vec::new();
            model.residuals(&p, &mut r).unwrap();
            let jac = model.jacobian(&p, &r).unwrap();
            // With the residual pass's rows kept, the same residuals and the same Jacobian, bit
            // for bit: from the rows at the point they were made, recomputed elsewhere.
            let rows = RefCell::new(WeightRows::default());
            let kept = EdgeModel {
                rows: Some(&rows),
                ..model
            };
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let mut r_kept = Vec::new();
            kept.residuals(&p, &mut r_kept).unwrap();
            assert_eq!(bits(&r_kept), bits(&r));
            assert_eq!(rows.borrow().p_bits, Some(p.map(f64::to_bits)));
            let jac_kept = kept.jacobian(&p, &r_kept).unwrap();
            assert_eq!(bits(jac_kept.as_slice()), bits(jac.as_slice()));
            let elsewhere = [0.0, 0.0, 1.0];
            let mut r_else = Vec::new();
            model.residuals(&elsewhere, &mut r_else).unwrap();
            assert_eq!(
                bits(kept.jacobian(&elsewhere, &r_else).unwrap().as_slice()),
                bits(model.jacobian(&elsewhere, &r_else).unwrap().as_slice())
            );
            let h = 1e-6;
            for j in 0..3 {
                let (mut up, mut down) = (p, p);
                up[j] += h;
                down[j] -= h;
                let (mut ru, mut rd) = (Vec::new(), Vec::new());
                model.residuals(&up, &mut ru).unwrap();
                model.residuals(&down, &mut rd).unwrap();
                let numeric: Vec<f64> = ru
                    .iter()
                    .zip(&rd)
                    .map(|(u, d)| (u - d) / (2.0 * h))
                    .collect();
                let scale = numeric.iter().map(|v| v * v).sum::<f64>().sqrt();
                let err = numeric
                    .iter()
                    .zip(jac.column(j).iter())
                    .map(|(n, a)| (n - a) * (n - a))
                    .sum::<f64>()
                    .sqrt();
                assert!(
                    err < 1e-5 * scale,
                    "box ({box_a}, {box_b}), parameter {j}: |analytic − numeric| {err:e} of {scale:e}"
                );
            }
        }
    }

    #[test]
    fn material_weights_reuse_shared_boundaries_bit_for_bit() {
        // Boundaries in grid order and against it (a flipped normal), with unbounded ends, a
        // material met twice and a boundary beyond the response's reach.
        let iv = |lo: f64, hi: f64, material: usize| Interval { lo, hi, material };
        let inf = f64::INFINITY;
        let profiles = [
            vec![
                iv(-inf, -0.7, 2),
                iv(-0.7, 0.3, 1),
                iv(0.3, 1.9, 0),
                iv(1.9, inf, 1),
            ],
            vec![
                iv(1.9, inf, 1),
                iv(0.3, 1.9, 0),
                iv(-0.7, 0.3, 1),
                iv(-inf, -0.7, 2),
            ],
            vec![iv(-inf, 40.0, 0), iv(40.0, inf, 1)],
        ];
        let slot = [0, 1, 2];
        for intervals in &profiles {
            for &(sigma, a, b) in &[(0.6, 0.9, 0.4), (1.3, 1.0, 0.02), (0.2, 0.8, 0.6)] {
                for &x in &[-2.3, -0.7, 0.0, 0.31, 1.2, 2.8] {
                    let mut got = [0.0; 3];
                    add_material_weights(x, intervals, sigma, a, b, None, &slot, &mut got);
                    // Every boundary's response computed afresh, in the same order.
                    let mut want = [0.0; 3];
                    for i in intervals {
                        let upper = if i.lo.is_finite() {
                            step_response(x - i.lo, sigma, a, b)
                        } else {
                            1.0
                        };
                        let lower = if i.hi.is_finite() {
                            step_response(x - i.hi, sigma, a, b)
                        } else {
                            0.0
                        };
                        want[i.material] += upper - lower;
                    }
                    for m in 0..3 {
                        assert_eq!(got[m].to_bits(), want[m].to_bits(), "x {x} σ {sigma} m {m}");
                    }
                    // The derivative version shares boundaries too: its weights are the same
                    // bits, its derivatives those of every boundary computed afresh.
                    let (mut w, mut w_x, mut w_s) = ([0.0; 3], [0.0; 3], [0.0; 3]);
                    add_material_weights_d(
                        x, intervals, sigma, a, b, None, &slot, &mut w, &mut w_x, &mut w_s,
                    );
                    let (mut want_x, mut want_s) = ([0.0; 3], [0.0; 3]);
                    for i in intervals {
                        let at = |bound: f64| {
                            if bound.is_finite() {
                                step_response_d(x - bound, sigma, a, b)
                            } else {
                                [0.0; 3]
                            }
                        };
                        let (upper, lower) = (at(i.lo), at(i.hi));
                        want_x[i.material] += upper[1] - lower[1];
                        want_s[i.material] += upper[2] - lower[2];
                    }
                    for m in 0..3 {
                        assert_eq!(w[m].to_bits(), want[m].to_bits(), "x {x} σ {sigma} m {m}");
                        assert_eq!(w_x[m].to_bits(), want_x[m].to_bits(), "x {x} m {m}");
                        assert_eq!(w_s[m].to_bits(), want_s[m].to_bits(), "x {x} m {m}");
                    }
                }
            }
        }
    }
}
