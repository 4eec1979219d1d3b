//! "Over" compositing of a prepared snapshot's layers onto the background, fused with the
//! coverage prefix sum so that only the cells an edge touched cost a conversion.
//!
//! Per pixel the result is exactly `v ← v·(1 − c) + radiance·c` for every layer in order, with
//! `c` the exact coverage of [`PreparedLayer::coverage`] — the fusion only changes which pixels
//! share a hoisted `c`:
//! * along a row, coverage changes only at cells holding a deposit; between them the running
//!   sum, hence `c`, is constant and the blend is a vectorised loop with constant factors;
//! * left of a row's first deposit and right of its last one with a zero sum, `c = 0`, and the
//!   blend `v·1 + r·0` returns `v` unchanged whenever no value can be −0 or non-finite (checked
//!   once per snapshot), so those pixels are skipped.
//!
//! Layers that do not move during an exposure ([`StaticCoverage`]) have their coverage computed
//! once per window and reused by every sample.

use super::textured::FillScratch;
use super::{textured_scales, PixelRect, PreparedLayer, PreparedSnapshot, FULL, ONE};

/// Reusable buffers for [`PreparedSnapshot::render_into`].
#[derive(Debug, Default)]
pub struct RasterScratch {
    /// Deposit accumulator, all zero between uses (each use re-zeroes the cells it touched).
    pub(super) acc: Vec<i64>,
    /// A textured layer's radiance deposits (cleared by each use).
    pub(super) rad: Vec<i64>,
    pub(super) fill: FillScratch,
}

/// A static layer's coverage over its footprint, and a textured layer's radiance there.
#[derive(Debug)]
pub(super) struct StaticLayer {
    pub fp: PixelRect,
    pub cov: Vec<f32>,
    pub rad: Option<Vec<f32>>,
}

/// Coverage of the layers whose edges are identical in every sample of an exposure, over one
/// window (computed once, blended by every sample).
///
/// When the leading layers are identical in every sample (same edges and radiance, same
/// background), their composite over the window is also identical: it is computed once into
/// `base` and every sample starts from a copy of it (the same per-pixel operations in the same
/// order, so the same bits).
#[derive(Debug, Default)]
pub struct StaticCoverage {
    /// Per layer index: its coverage (and radiance) over its footprint if static.
    layers: Vec<Option<StaticLayer>>,
    acc: Vec<i64>,
    /// Number of leading layers whose contribution is the same in every sample (0: no `base`).
    prefix: usize,
    /// Background plus the first `prefix` layers over `base_window`.
    base: Vec<f32>,
    base_window: Option<PixelRect>,
    /// Rasteriser buffers for compositing `base`.
    raster: RasterScratch,
}

/// Per layer index: whether the layer has the same non-empty edges in every sample of `snaps`
/// (all samples of one exposure). Only worth asking for more than one sample.
pub fn static_layers(snaps: &[PreparedSnapshot]) -> Vec<bool> {
    let n_layers = snaps.iter().map(|s| s.layers.len()).min().unwrap_or(0);
    (0..n_layers)
        .map(|j| {
            let first = &snaps[0].layers[j];
            snaps.len() > 1
                && !first.edges.is_empty()
                && snaps[1..].iter().all(|s| s.layers[j].same_edges(first))
        })
        .collect()
}

/// Number of leading layers that every sample of `snaps` composites identically: same layer
/// count and background bits, and per layer the same edges (`fixed`, or empty everywhere) and
/// the same radiance bits.
pub(super) fn identical_prefix(snaps: &[PreparedSnapshot], fixed: &[bool]) -> usize {
    let Some(first) = snaps.first() else {
        return 0;
    };
    if snaps.len() < 2
        || snaps
            .iter()
            .any(|s| s.layers.len() != first.layers.len() || !s.same_background(first))
    {
        return 0;
    }
    let mut n = 0;
    for (j, layer) in first.layers.iter().enumerate() {
        let same_edges = fixed.get(j).copied().unwrap_or(false)
            || (layer.edges.is_empty() && snaps.iter().all(|s| s.layers[j].edges.is_empty()));
        let r = layer.radiance.to_bits();
        if !same_edges || snaps.iter().any(|s| s.layers[j].radiance.to_bits() != r) {
            break;
        }
        n += 1;
    }
    n
}

impl StaticCoverage {
    /// Rasterises over `window` the coverage of the static layers `fixed` (= [`static_layers`]
    /// of `snaps`, all samples of one exposure) and precomposites the leading layers that every
    /// sample shares. Only worth it for more than one sample.
    pub fn compute_with(&mut self, snaps: &[PreparedSnapshot], fixed: &[bool], window: &PixelRect) {
        let n_layers = snaps.iter().map(|s| s.layers.len()).min().unwrap_or(0);
        self.prefix = if window.is_empty() {
            0
        } else {
            identical_prefix(snaps, fixed).min(n_layers)
        };
        self.layers.resize_with(n_layers, || None);
        for j in 0..n_layers {
            let first = &snaps[0].layers[j];
            let fp = first.footprint(window);
            // Precomposited layers need no coverage of their own: the base holds them.
            if j < self.prefix || !fixed.get(j).copied().unwrap_or(false) || fp.is_empty() {
                self.layers[j] = None;
                continue;
            }
            let mut st = self.layers[j].take().unwrap_or(StaticLayer {
                fp,
                cov: Vec::new(),
                rad: None,
            });
            st.fp = fp;
            st.cov.clear();
            st.cov.resize(fp.len(), 0.0);
            if first.fill.is_some() {
                let mut rad = st.rad.take().unwrap_or_default();
                rad.clear();
                rad.resize(fp.len(), 0.0);
                first.textured_coverage(&fp, &mut self.raster, &mut st.cov, &mut rad);
                st.rad = Some(rad);
            } else {
                st.rad = None;
                first.coverage(&fp, &mut self.acc, &mut st.cov);
            }
            self.layers[j] = Some(st);
        }
        if self.prefix == 0 {
            return;
        }
        // Exactly the first steps of `render_with_static` without statics, for any sample.
        let first = &snaps[0];
        let skip_uncovered = first.uncovered_unchanged();
        self.base_window = Some(*window);
        self.base.clear();
        self.base.resize(window.len(), 0.0);
        first.fill_background(window, &mut self.base);
        for layer in &first.layers[..self.prefix] {
            if layer.edges.is_empty() {
                continue;
            }
            let fp = layer.footprint(window);
            if !fp.is_empty() {
                layer.blend_into(
                    &fp,
                    window,
                    &mut self.raster,
                    &mut self.base,
                    skip_uncovered,
                );
            }
        }
    }

    pub(super) fn layer(&self, j: usize) -> Option<&StaticLayer> {
        self.layers.get(j).and_then(|l| l.as_ref())
    }

    /// The number of precomposited leading layers and their composite over `window`, when the
    /// last computation was for `window` and found any.
    pub(super) fn base_of(&self, window: &PixelRect) -> Option<(usize, &[f32])> {
        (self.prefix > 0 && self.base_window == Some(*window))
            .then(|| (self.prefix, &self.base[..window.len()]))
    }
}

impl PreparedSnapshot {
    /// Linear radiance of every pixel of `window` (row-major, `window.len()` values) into `out`:
    /// background, then each layer "over" it: v ← v·(1 − c) + radiance·c.
    pub fn render_into(&self, window: &PixelRect, scratch: &mut RasterScratch, out: &mut [f32]) {
        self.render_with_static(window, scratch, None, out);
    }

    /// [`Self::render_into`] taking the coverage of the layers in `statics` (computed for this
    /// `window` from exposure samples that include this snapshot) instead of rasterising them,
    /// and starting from its precomposited leading layers when there are any.
    pub fn render_with_static(
        &self,
        window: &PixelRect,
        scratch: &mut RasterScratch,
        statics: Option<&StaticCoverage>,
        out: &mut [f32],
    ) {
        let first_layer = match statics {
            Some(s) if s.prefix > 0 && s.base_window == Some(*window) => {
                out[..window.len()].copy_from_slice(&s.base);
                s.prefix
            }
            _ => {
                self.fill_background(window, &mut out[..window.len()]);
                0
            }
        };
        if window.is_empty() {
            return;
        }
        let skip_uncovered = self.uncovered_unchanged();
        for (j, layer) in self.layers.iter().enumerate().skip(first_layer) {
            if layer.edges.is_empty() {
                continue;
            }
            if let Some(st) = statics.and_then(|s| s.layer(j)) {
                blend_coverage_clipped(st, layer.radiance, window, out);
                continue;
            }
            // Only the layer's bounding box can change (coverage is 0 elsewhere); the integer
            // rasteriser gives the same coverage there whatever window it runs on.
            let fp = layer.footprint(window);
            if !fp.is_empty() {
                layer.blend_into(&fp, window, scratch, out, skip_uncovered);
            }
        }
    }
}

impl PreparedSnapshot {
    /// Whether blending a layer with coverage 0 leaves every value unchanged: no value can be
    /// −0 or non-finite (`v·1 + r·0 = v` then).
    pub(super) fn uncovered_unchanged(&self) -> bool {
        let clean = |v: f32| v.is_finite() && v.is_sign_positive();
        clean(self.background_radiance) && self.layers.iter().all(|l| clean(l.radiance))
    }

    /// The background's radiance over `window` (row-major) into `out`: the uniform radiance,
    /// or the background texture's pixels.
    pub(super) fn fill_background(&self, window: &PixelRect, out: &mut [f32]) {
        match &self.background {
            None => out[..window.len()].fill(self.background_radiance),
            Some(bg) => {
                for (row, o) in out[..window.len()]
                    .chunks_exact_mut(window.width.max(1))
                    .enumerate()
                {
                    bg.row_into(window.x0, window.y0 + row as i64, o);
                }
            }
        }
    }
}

impl PreparedLayer {
    /// Blends this layer over `out` (a `window` buffer) inside its footprint `fp`.
    pub(super) fn blend_into(
        &self,
        fp: &PixelRect,
        window: &PixelRect,
        raster: &mut RasterScratch,
        out: &mut [f32],
        skip_uncovered: bool,
    ) {
        if self.fill.is_some() {
            self.blend_textured(fp, window, raster, out);
            return;
        }
        let acc = &mut raster.acc;
        let (row_lo, row_hi) = (fp.y0 * ONE, fp.y1() * ONE);
        if self.y_max <= row_lo || self.y_min >= row_hi {
            return;
        }
        let w = fp.width;
        let stride = w + 1;
        let n = stride * fp.height;
        if acc.len() < n {
            acc.resize(n, 0);
        }
        let acc = &mut acc[..n];
        for e in &self.edges {
            if e.yb > row_lo && e.ya < row_hi {
                e.deposit(fp, acc);
            }
        }
        let r = self.radiance;
        let scale = 1.0 / FULL as f64;
        let coverage = |sum: i64| (sum as f64 * scale).clamp(0.0, 1.0) as f32;
        for (row, a) in acc.chunks_exact_mut(stride).enumerate() {
            let start = window.index(fp.x0, fp.y0 + row as i64).unwrap_or(0);
            let o = &mut out[start..start + w];
            let Some(lo) = first_nonzero(a) else {
                if !skip_uncovered {
                    blend_constant(o, r, 0.0);
                }
                continue;
            };
            let hi = last_nonzero(a).unwrap_or(lo);
            if !skip_uncovered {
                blend_constant(&mut o[..lo.min(w)], r, 0.0);
            }
            let end = (hi + 1).min(w);
            let mut sum = 0i64;
            let mut x = lo;
            while x < end {
                sum += a[x];
                let c = coverage(sum);
                o[x] = o[x] * (1.0 - c) + r * c;
                x += 1;
                let run_end = next_nonzero(a, x, end);
                blend_constant(&mut o[x..run_end], r, c);
                x = run_end;
            }
            if end < w {
                let c = coverage(sum);
                if !(skip_uncovered && c == 0.0) {
                    blend_constant(&mut o[end..], r, c);
                }
            }
            a[lo..=hi].fill(0);
        }
    }
}

impl PreparedLayer {
    /// A textured layer over `out` inside its footprint: v ← v·(1 − c) + R with c its
    /// coverage and R its radiance-weighted coverage.
    fn blend_textured(
        &self,
        fp: &PixelRect,
        window: &PixelRect,
        raster: &mut RasterScratch,
        out: &mut [f32],
    ) {
        let Some(fill) = &self.fill else {
            return;
        };
        let stride = fp.width + 1;
        let n = stride * fp.height;
        let acc = &mut raster.acc;
        if acc.len() < n {
            acc.resize(n, 0);
        }
        raster.rad.clear();
        raster.rad.resize(n, 0);
        fill.deposit(fp, &mut acc[..n], &mut raster.rad, &mut raster.fill);
        let (cs, rs) = textured_scales(1);
        for (row, (a, r)) in acc[..n]
            .chunks_exact_mut(stride)
            .zip(raster.rad.chunks_exact(stride))
            .enumerate()
        {
            let start = window.index(fp.x0, fp.y0 + row as i64).unwrap_or(0);
            let o = &mut out[start..start + fp.width];
            let (mut sc, mut sr) = (0i64, 0i64);
            for ((v, a), r) in o.iter_mut().zip(a.iter()).zip(r) {
                sc += a;
                sr += r;
                let c = (sc as f64 * cs).clamp(0.0, 1.0) as f32;
                let rv = (sr as f64 * rs).clamp(0.0, 1.0) as f32;
                *v = *v * (1.0 - c) + rv;
            }
            a.fill(0);
        }
    }
}

/// Cells scanned at once when looking for deposits (an OR over a block vectorises).
const SCAN: usize = 16;

/// Index of the first non-zero cell.
fn first_nonzero(a: &[i64]) -> Option<usize> {
    let mut base = 0;
    for block in a.chunks(SCAN) {
        if block.iter().fold(0, |m, &v| m | v) != 0 {
            return block.iter().position(|&v| v != 0).map(|i| base + i);
        }
        base += block.len();
    }
    None
}

/// Index of the last non-zero cell.
fn last_nonzero(a: &[i64]) -> Option<usize> {
    let mut end = a.len();
    for block in a.rchunks(SCAN) {
        let start = end - block.len();
        if block.iter().fold(0, |m, &v| m | v) != 0 {
            return block.iter().rposition(|&v| v != 0).map(|i| start + i);
        }
        end = start;
    }
    None
}

/// First index in `from .. end` whose deposit is non-zero (`end` if none).
#[inline]
fn next_nonzero(a: &[i64], from: usize, end: usize) -> usize {
    let mut i = from;
    while i + SCAN <= end && a[i..i + SCAN].iter().fold(0, |m, &v| m | v) == 0 {
        i += SCAN;
    }
    while i < end && a[i] == 0 {
        i += 1;
    }
    i
}

/// `v ← v·(1 − c) + r·c` with one coverage for the whole run.
#[inline]
fn blend_constant(out: &mut [f32], r: f32, c: f32) {
    let (keep, add) = (1.0 - c, r * c);
    for v in out {
        *v = *v * keep + add;
    }
}

/// `v ← v·(1 − c) + r·c` with a static layer's per-pixel coverage `c` (for a textured layer
/// `v ← v·(1 − c) + R` with its per-pixel radiance R), for the pixels of its footprint inside
/// `sub`, into a `sub` buffer.
pub(super) fn blend_coverage_clipped(st: &StaticLayer, r: f32, sub: &PixelRect, out: &mut [f32]) {
    let fp = &st.fp;
    let clip = fp.intersect(sub);
    if clip.is_empty() {
        return;
    }
    let dx = (clip.x0 - fp.x0) as usize;
    for y in clip.y0..clip.y1() {
        let at = (y - fp.y0) as usize * fp.width + dx;
        let c = &st.cov[at..][..clip.width];
        let start = sub.index(clip.x0, y).unwrap_or(0);
        let o = &mut out[start..start + clip.width];
        match &st.rad {
            None => {
                for (v, &c) in o.iter_mut().zip(c) {
                    *v = *v * (1.0 - c) + r * c;
                }
            }
            Some(rad) => {
                for ((v, &c), &rv) in o.iter_mut().zip(c).zip(&rad[at..][..clip.width]) {
                    *v = *v * (1.0 - c) + rv;
                }
            }
        }
    }
}
