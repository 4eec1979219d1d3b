//! The exposure average of K snapshots over one window: per pixel, the first sample plus each
//! further sample in order, times 1/K — computed so that only the pixels some moving layer can
//! reach cost K renders.
//!
//! When the leading layers composite identically in every sample ([`StaticCoverage`]'s base),
//! every pixel outside the union of the other layers' footprints has the same value `v` in all
//! K samples, so its average is `((v + v) + … + v) · (1/K)` — evaluated once per distinct `v`
//! (a window outside the moving layers holds a handful of values: background, disc, disc edge).
//! The K renders then only cover that union. The result has the same bits as rendering every
//! sample over the whole window.

use super::composite::{blend_coverage_clipped, StaticCoverage};
use super::{PixelRect, PreparedSnapshot, RasterScratch};

/// Buffers of [`average_exposure`], reused from window to window.
#[derive(Debug, Default)]
pub struct ExposureScratch {
    raster: RasterScratch,
    statics: StaticCoverage,
    sum: Vec<f32>,
    sample: Vec<f32>,
}

/// Averages the renders of `window` at the K `snaps` (all samples of one exposure) into `out`
/// (row-major, `window.len()` values). `fixed` gives the static layers when the caller already
/// knows them ([`super::static_layers`] of `snaps`).
pub fn average_exposure(
    window: &PixelRect,
    snaps: &[PreparedSnapshot],
    fixed: Option<&[bool]>,
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
    match fixed {
        Some(f) => scratch.statics.compute_with(snaps, f, window),
        None => scratch.statics.compute(snaps, window),
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
    let mut hull: Option<(i64, i64, i64, i64)> = None;
    for s in snaps {
        for layer in s.layers.iter().skip(prefix) {
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
            if let Some((fp, cov)) = statics.layer(j) {
                blend_coverage_clipped(fp, cov, layer.radiance, sub, out);
                continue;
            }
            let fp = layer.footprint(sub);
            if !fp.is_empty() {
                layer.blend_into(&fp, sub, &mut raster.acc, out, skip_uncovered);
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
        let (s, c) = angle.sin_cos();
        Polygon {
            vertices_px: [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .iter()
                .map(|&(u, v)| DVec2::new(cx + half * (c * u - s * v), cy + half * (s * u + c * v)))
                .collect(),
        }
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

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// A static disc under a moving marker-like pair of squares, with an optional static
        /// layer on top: the shortcut gives the bits of the plain per-sample average.
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
            let snaps: Vec<PreparedSnapshot> = (0..k)
                .map(|i| {
                    let d = i as f64 * step;
                    let mut layers = vec![
                        Layer { radiance: 0.45, polygons: vec![disc(40.0, 40.0, 33.3)] },
                        Layer { radiance: 0.9, polygons: vec![square(cx + d, cy, 9.3, turn * i as f64)] },
                        Layer { radiance: 0.1, polygons: vec![square(cx + d, cy, 5.1, turn * i as f64)] },
                    ];
                    if top {
                        layers.push(Layer { radiance: 0.7, polygons: vec![square(12.2, 61.7, 4.4, 0.3)] });
                    }
                    PreparedSnapshot::new(&SceneSnapshot { background_radiance: 0.2, layers }, None)
                })
                .collect();
            let window = PixelRect::new(wx, wy, ww, wh);
            let mut out = vec![0.0; window.len()];
            let mut scratch = ExposureScratch::default();
            average_exposure(&window, &snaps, None, &mut scratch, &mut out);
            let want = reference(&window, &snaps);
            let same = out.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits());
            prop_assert!(same);
        }
    }
}
