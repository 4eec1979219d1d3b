//! The exposure average of K snapshots over one window, decided once per exposure
//! ([`ExposurePlan`]) and computed so that only the pixels some moving layer can reach cost
//! more than a copy.
//!
//! * **Nested moving layers** (global shutter; the usual case: paper inside the disc, ink inside
//!   the paper, checked by [`super::nesting`]): the average of the K "over" composites equals
//!   the composite of the layers' *mean* coverages — at any pixel only the innermost touching
//!   layer varies, over a constant full cover. The K samples' edge deposits are summed in
//!   integers per layer (exact), and one composite pass turns the sums into values. Outside
//!   the moving layers' footprints the value is the static base.
//! * **Otherwise** (layers that overlap without nesting, rolling-shutter rows): per pixel the
//!   first sample plus each further sample in order, times 1/K. When the leading layers are the
//!   same in every sample ([`StaticCoverage`]'s base), pixels outside the moving layers'
//!   footprints hold the same `v` in all samples and get `((v + v) + … + v) · (1/K)`, once per
//!   distinct `v`; the K renders cover only those footprints.
//!
//! Both are pure functions of absolute pixel position (integer deposits, per-pixel arithmetic),
//! so a window gives the same bits as the whole frame; which one applies depends only on the
//! samples.

use super::composite::{blend_coverage_clipped, identical_prefix, static_layers, StaticCoverage};
use super::nesting::layers_nest;
use super::{
    textured_scales, PixelRect, PreparedSnapshot, RasterScratch, RigidTransform, FULL, ONE,
};
use crate::render::shapes::SceneSnapshot;

/// Buffers of [`average_exposure`], reused from window to window.
#[derive(Debug, Default)]
pub struct ExposureScratch {
    raster: RasterScratch,
    statics: StaticCoverage,
    sum: Vec<f32>,
    sample: Vec<f32>,
    /// Per nested moving layer: the K samples' deposits summed, over the moving footprint.
    deposits: Vec<Vec<i64>>,
    /// Per nested moving layer: a textured layer's radiance deposits summed likewise.
    rad_deposits: Vec<Vec<i64>>,
    /// The background over the window when no leading layer is shared by every sample.
    background: Vec<f32>,
}

/// How the samples of one exposure are averaged; depends only on the samples.
#[derive(Debug, Clone, PartialEq)]
pub struct ExposurePlan {
    /// [`static_layers`] of the samples.
    fixed: Vec<bool>,
    /// The layers after the shared leading ones that some sample draws, when they nest (mean
    /// coverages composited once); `None`: average sample by sample.
    nested: Option<Vec<usize>>,
}

impl ExposurePlan {
    /// Sample-by-sample averaging (no nesting check): for rolling-shutter rows, which are too
    /// many to check one by one.
    pub fn per_sample(snaps: &[PreparedSnapshot]) -> Self {
        Self {
            fixed: static_layers(snaps),
            nested: None,
        }
    }

    /// The plan for the prepared `snaps` of `scenes` (the same samples before preparation,
    /// seen through `transforms`).
    pub fn new(
        snaps: &[PreparedSnapshot],
        scenes: &[SceneSnapshot],
        transforms: &[Option<RigidTransform>],
    ) -> Self {
        let fixed = static_layers(snaps);
        let nested = nested_layers(snaps, &fixed, scenes, transforms);
        Self { fixed, nested }
    }

    /// Whether the moving layers nest (the mean-coverage path).
    pub fn is_nested(&self) -> bool {
        self.nested.is_some()
    }
}

/// The moving layers of `snaps` if their average may be taken on mean coverages: same
/// background and per-layer radiance in every sample, no value that a zero-coverage blend
/// would change, and the layers nest.
fn nested_layers(
    snaps: &[PreparedSnapshot],
    fixed: &[bool],
    scenes: &[SceneSnapshot],
    transforms: &[Option<RigidTransform>],
) -> Option<Vec<usize>> {
    let first = snaps.first()?;
    if snaps.len() < 2 || scenes.len() != snaps.len() {
        return None;
    }
    let n_layers = first.layers.len();
    if snaps.iter().any(|s| {
        s.layers.len() != n_layers || !s.same_background(first) || !s.uncovered_unchanged()
    }) {
        return None;
    }
    let prefix = identical_prefix(snaps, fixed).min(n_layers);
    let moving: Vec<usize> = (prefix..n_layers)
        .filter(|&j| snaps.iter().any(|s| !s.layers[j].edges.is_empty()))
        .collect();
    for &j in &moving {
        let r = first.layers[j].radiance.to_bits();
        if snaps.iter().any(|s| s.layers[j].radiance.to_bits() != r) {
            return None;
        }
    }
    layers_nest(scenes, transforms, &moving).then_some(moving)
}

/// Averages the renders of `window` at the K `snaps` (all samples of one exposure) into `out`
/// (row-major, `window.len()` values) as `plan` (made from the same `snaps`) says.
pub fn average_exposure(
    window: &PixelRect,
    snaps: &[PreparedSnapshot],
    plan: &ExposurePlan,
    scratch: &mut ExposureScratch,
    out: &mut [f32],
) {
    let k = snaps.len();
    if k == 0 || window.is_empty() {
        return;
    }
    if k == 1 {
        snaps[0].render_into(window, &mut scratch.raster, out);
        return;
    }
    scratch.statics.compute_with(snaps, &plan.fixed, window);
    if let Some(layers) = &plan.nested {
        average_nested(window, snaps, layers, scratch, out);
        return;
    }
    if scratch.statics.base_of(window).is_some() {
        average_over_base(window, snaps, scratch, out);
        return;
    }
    let ExposureScratch {
        raster,
        statics,
        sample,
        ..
    } = scratch;
    snaps[0].render_with_static(window, raster, Some(statics), out);
    sample.resize(window.len(), 0.0);
    for s in &snaps[1..] {
        s.render_with_static(window, raster, Some(statics), sample);
        for (o, t) in out.iter_mut().zip(sample.iter()) {
            *o += t;
        }
    }
    let inv_k = 1.0 / k as f32;
    out.iter_mut().for_each(|o| *o *= inv_k);
}

/// The average of K equal values, in the order [`average_exposure`] sums them.
#[inline]
fn average_of_equal(v: f32, k: usize, inv_k: f32) -> f32 {
    let mut sum = v;
    for _ in 1..k {
        sum += v;
    }
    sum * inv_k
}

/// [`average_exposure`] when the statics hold a base for `window`.
fn average_over_base(
    window: &PixelRect,
    snaps: &[PreparedSnapshot],
    scratch: &mut ExposureScratch,
    out: &mut [f32],
) {
    let ExposureScratch {
        raster,
        statics,
        sum,
        sample,
        ..
    } = scratch;
    let Some((prefix, base)) = statics.base_of(window) else {
        return;
    };
    let k = snaps.len();
    let inv_k = 1.0 / k as f32;
    let moving = moving_bounds(snaps, prefix, window);
    let mut memo = (base[0].to_bits(), average_of_equal(base[0], k, inv_k));
    let mut average = |v: f32| {
        if v.to_bits() != memo.0 {
            memo = (v.to_bits(), average_of_equal(v, k, inv_k));
        }
        memo.1
    };
    let w = window.width;
    let (mx0, mx1) = if moving.is_empty() {
        (0, 0)
    } else {
        (
            (moving.x0 - window.x0) as usize,
            (moving.x1() - window.x0) as usize,
        )
    };
    for (row, (o, b)) in out
        .chunks_exact_mut(w)
        .zip(base.chunks_exact(w))
        .enumerate()
    {
        let y = window.y0 + row as i64;
        let (a, z) = if y >= moving.y0 && y < moving.y1() {
            (mx0, mx1)
        } else {
            (w, w)
        };
        for (o, &v) in o[..a].iter_mut().zip(&b[..a]) {
            *o = average(v);
        }
        for (o, &v) in o[z..].iter_mut().zip(&b[z..]) {
            *o = average(v);
        }
    }
    if moving.is_empty() {
        return;
    }
    sum.resize(moving.len(), 0.0);
    sample.resize(moving.len(), 0.0);
    snaps[0].render_moving(prefix, statics, window, base, &moving, raster, sum);
    for s in &snaps[1..] {
        s.render_moving(prefix, statics, window, base, &moving, raster, sample);
        for (o, t) in sum.iter_mut().zip(sample.iter()) {
            *o += t;
        }
    }
    for (row, src) in sum.chunks_exact(moving.width).enumerate() {
        let start = (moving.y0 - window.y0) as usize + row;
        let o = &mut out[start * w + mx0..start * w + mx1];
        for (o, &s) in o.iter_mut().zip(src) {
            *o = s * inv_k;
        }
    }
}

/// Bounding box, inside `window`, of the footprints of every layer after the first `prefix`
/// in any sample: outside it every sample equals the base.
fn moving_bounds(snaps: &[PreparedSnapshot], prefix: usize, window: &PixelRect) -> PixelRect {
    let n = snaps.iter().map(|s| s.layers.len()).max().unwrap_or(0);
    footprints_bounds(snaps, prefix..n, window)
}

/// Bounding box, inside `window`, of the footprints of `layers` in every sample.
fn footprints_bounds(
    snaps: &[PreparedSnapshot],
    layers: impl Iterator<Item = usize> + Clone,
    window: &PixelRect,
) -> PixelRect {
    let mut hull: Option<(i64, i64, i64, i64)> = None;
    for s in snaps {
        for layer in layers.clone().filter_map(|j| s.layers.get(j)) {
            if layer.edges.is_empty() {
                continue;
            }
            let fp = layer.footprint(window);
            if fp.is_empty() {
                continue;
            }
            let b = (fp.x0, fp.y0, fp.x1(), fp.y1());
            hull = Some(hull.map_or(b, |h| {
                (h.0.min(b.0), h.1.min(b.1), h.2.max(b.2), h.3.max(b.3))
            }));
        }
    }
    match hull {
        Some((x0, y0, x1, y1)) => PixelRect::new(x0, y0, (x1 - x0) as usize, (y1 - y0) as usize),
        None => PixelRect::new(window.x0, window.y0, 0, 0),
    }
}

/// [`average_exposure`] for nested moving `layers`: the static base, then inside the layers'
/// footprints the composite of their mean coverages.
fn average_nested(
    window: &PixelRect,
    snaps: &[PreparedSnapshot],
    layers: &[usize],
    scratch: &mut ExposureScratch,
    out: &mut [f32],
) {
    let ExposureScratch {
        raster,
        statics,
        deposits,
        rad_deposits,
        background,
        ..
    } = scratch;
    let base: &[f32] = match statics.base_of(window) {
        Some((_, base)) => base,
        None => {
            background.clear();
            background.resize(window.len(), 0.0);
            snaps[0].fill_background(window, background);
            background
        }
    };
    out[..window.len()].copy_from_slice(base);
    let moving = footprints_bounds(snaps, layers.iter().copied(), window);
    if moving.is_empty() {
        return;
    }
    let stride = moving.width + 1;
    let (row_lo, row_hi) = (moving.y0 * ONE, moving.y1() * ONE);
    deposits.resize_with(layers.len(), Vec::new);
    rad_deposits.resize_with(layers.len(), Vec::new);
    let textured: Vec<bool> = layers
        .iter()
        .map(|&j| snaps[0].layers[j].fill.is_some())
        .collect();
    for ((acc, rad), &j) in deposits.iter_mut().zip(rad_deposits.iter_mut()).zip(layers) {
        acc.clear();
        acc.resize(stride * moving.height, 0);
        rad.clear();
        for s in snaps {
            let layer = &s.layers[j];
            if let Some(fill) = &layer.fill {
                rad.resize(stride * moving.height, 0);
                fill.deposit(&moving, acc, rad, &mut raster.fill);
                continue;
            }
            for e in &layer.edges {
                if e.yb > row_lo && e.ya < row_hi {
                    e.deposit(&moving, acc);
                }
            }
        }
    }
    let radiance: Vec<f32> = layers
        .iter()
        .map(|&j| snaps[0].layers[j].radiance)
        .collect();
    // Mean coverage = deposit sum / (K · FULL), exact in integers up to the final division.
    let scale = 1.0 / (snaps.len() as f64 * FULL as f64);
    let (_, rad_scale) = textured_scales(snaps.len());
    let mut sums = vec![0i64; layers.len()];
    let mut rad_sums = vec![0i64; layers.len()];
    let dx = (moving.x0 - window.x0) as usize;
    for row in 0..moving.height {
        let start = (moving.y0 - window.y0) as usize + row;
        let o = &mut out[start * window.width + dx..][..moving.width];
        sums.iter_mut().for_each(|s| *s = 0);
        rad_sums.iter_mut().for_each(|s| *s = 0);
        for (x, v) in o.iter_mut().enumerate() {
            for (m, &r) in radiance.iter().enumerate() {
                sums[m] += deposits[m][row * stride + x];
                let c = (sums[m] as f64 * scale).clamp(0.0, 1.0) as f32;
                if textured[m] {
                    rad_sums[m] += rad_deposits[m][row * stride + x];
                    let rv = (rad_sums[m] as f64 * rad_scale).clamp(0.0, 1.0) as f32;
                    *v = *v * (1.0 - c) + rv;
                } else {
                    *v = *v * (1.0 - c) + r * c;
                }
            }
        }
    }
}

impl PreparedSnapshot {
    /// The pixels `sub` (inside `window`) of [`Self::render_with_static`] over `window`, given
    /// the statics' `base` over `window` and its `prefix` layers, into `out` (`sub.len()`).
    #[allow(clippy::too_many_arguments)]
    fn render_moving(
        &self,
        prefix: usize,
        statics: &StaticCoverage,
        window: &PixelRect,
        base: &[f32],
        sub: &PixelRect,
        raster: &mut RasterScratch,
        out: &mut [f32],
    ) {
        let x = (sub.x0 - window.x0) as usize;
        for (row, o) in out.chunks_exact_mut(sub.width).enumerate() {
            let start = (sub.y0 - window.y0) as usize + row;
            o.copy_from_slice(&base[start * window.width + x..][..sub.width]);
        }
        let skip_uncovered = self.uncovered_unchanged();
        for (j, layer) in self.layers.iter().enumerate().skip(prefix) {
            if layer.edges.is_empty() {
                continue;
            }
            if let Some(st) = statics.layer(j) {
                blend_coverage_clipped(st, layer.radiance, sub, out);
                continue;
            }
            let fp = layer.footprint(sub);
            if !fp.is_empty() {
                layer.blend_into(&fp, sub, raster, out, skip_uncovered);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::shapes::{Layer, Polygon, SceneSnapshot};
    use glam::DVec2;
    use proptest::prelude::*;

    fn square(cx: f64, cy: f64, half: f64, angle: f64) -> Polygon {
        crate::render::test_scenes::rotated_square(DVec2::new(cx, cy), 2.0 * half, angle)
    }

    fn disc(cx: f64, cy: f64, r: f64) -> Polygon {
        Polygon {
            vertices_px: (0..96)
                .map(|i| {
                    let a = i as f64 * std::f64::consts::TAU / 96.0;
                    DVec2::new(cx + r * a.cos(), cy + r * a.sin())
                })
                .collect(),
        }
    }

    /// Reference: every sample rendered over the whole window, summed in order, times 1/K.
    fn reference(window: &PixelRect, snaps: &[PreparedSnapshot]) -> Vec<f32> {
        let mut out = vec![0.0; window.len()];
        let mut sample = vec![0.0; window.len()];
        let mut raster = RasterScratch::default();
        snaps[0].render_into(window, &mut raster, &mut out);
        for s in &snaps[1..] {
            s.render_into(window, &mut raster, &mut sample);
            out.iter_mut().zip(&sample).for_each(|(o, t)| *o += t);
        }
        if snaps.len() > 1 {
            let inv_k = 1.0 / snaps.len() as f32;
            out.iter_mut().for_each(|o| *o *= inv_k);
        }
        out
    }

    fn scenes(
        k: usize,
        (cx, cy): (f64, f64),
        step: f64,
        turn: f64,
        top: bool,
    ) -> Vec<SceneSnapshot> {
        (0..k)
            .map(|i| {
                let d = i as f64 * step;
                let mut layers = vec![
                    Layer {
                        texture: None,
                        radiance: 0.45,
                        polygons: vec![disc(40.0, 40.0, 33.3)],
                    },
                    Layer {
                        texture: None,
                        radiance: 0.9,
                        polygons: vec![square(cx + d, cy, 9.3, turn * i as f64)],
                    },
                    Layer {
                        texture: None,
                        radiance: 0.1,
                        polygons: vec![square(cx + d, cy, 5.1, turn * i as f64)],
                    },
                ];
                if top {
                    layers.push(Layer {
                        texture: None,
                        radiance: 0.7,
                        polygons: vec![square(12.2, 61.7, 4.4, 0.3)],
                    });
                }
                SceneSnapshot {
                    background: None,
                    background_radiance: 0.2,
                    layers,
                }
            })
            .collect()
    }

    fn prepared(scenes: &[SceneSnapshot]) -> Vec<PreparedSnapshot> {
        scenes
            .iter()
            .map(|s| PreparedSnapshot::new(s, None))
            .collect()
    }

    fn averaged(window: &PixelRect, snaps: &[PreparedSnapshot], plan: &ExposurePlan) -> Vec<f32> {
        let mut out = vec![0.0; window.len()];
        average_exposure(
            window,
            snaps,
            plan,
            &mut ExposureScratch::default(),
            &mut out,
        );
        out
    }

    #[test]
    fn small_motion_inside_the_paper_takes_the_nested_path_and_large_motion_does_not() {
        let none = vec![None; 8];
        let slow = scenes(8, (40.0, 40.0), 0.05, 0.001, false);
        assert!(ExposurePlan::new(&prepared(&slow), &slow, &none).is_nested());
        let fast = scenes(8, (40.0, 40.0), 0.8, 0.0, false);
        assert!(!ExposurePlan::new(&prepared(&fast), &fast, &none).is_nested());
        let topped = scenes(8, (40.0, 40.0), 0.05, 0.0, true);
        assert!(!ExposurePlan::new(&prepared(&topped), &topped, &none).is_nested());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// A static disc under a moving marker-like pair of squares, with an optional static
        /// layer on top: sample-by-sample averaging gives the bits of the plain per-sample sum;
        /// the nested path (when the plan allows it) agrees to float rounding; any window gives
        /// the same pixels as a larger one.
        #[test]
        fn average_equals_plain_per_sample_sum(
            k in 1usize..12,
            cx in 20.0f64..60.0,
            cy in 20.0f64..60.0,
            step in 0.0f64..0.8,
            turn in -0.05f64..0.05,
            top in any::<bool>(),
            wx in -10i64..30,
            wy in -10i64..30,
            ww in 1usize..70,
            wh in 1usize..70,
        ) {
            let scenes = scenes(k, (cx, cy), step, turn, top);
            let snaps = prepared(&scenes);
            let window = PixelRect::new(wx, wy, ww, wh);
            let want = reference(&window, &snaps);
            let per_sample = averaged(&window, &snaps, &ExposurePlan::per_sample(&snaps));
            let same = per_sample.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits());
            prop_assert!(same);
            let plan = ExposurePlan::new(&snaps, &scenes, &vec![None; k]);
            let out = averaged(&window, &snaps, &plan);
            let worst = out.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            prop_assert!(worst <= 2e-7, "nested {} worst {worst}", plan.is_nested());
            let big = PixelRect::new(-12, -12, 120, 120);
            let all = averaged(&big, &snaps, &plan);
            for y in window.y0..window.y1() {
                for x in window.x0..window.x1() {
                    let (a, b) = (out[window.index(x, y).unwrap()], all[big.index(x, y).unwrap()]);
                    prop_assert_eq!(a.to_bits(), b.to_bits());
                }
            }
        }
    }
}
