//! JPEG traces on the absolute 8-pixel grid: blockiness and the quantiser (quality) estimate.
//!
//! Blockiness follows Z. Wang, H. R. Sheikh and A. C. Bovik, "No-reference perceptual quality
//! assessment of JPEG compressed images", Proc. IEEE ICIP 2002: B = mean |d| of the neighbour
//! differences d that straddle a block boundary, A = mean |d| of those inside blocks (their
//! "activity"), per direction. We report B/A, which is ≈ 1 without block coding and grows as
//! coarser quantisation makes blocks flat inside and discontinuous at their borders.
//!
//! The quality estimate follows the maximum-likelihood quantiser estimation of Z. Fan and R. L.
//! de Queiroz, "Identification of bitmap compression history: JPEG detection and quantizer
//! estimation", IEEE Trans. Image Processing 12(2), 2003: the block-DCT coefficients of a
//! decoded JPEG sit on multiples of the quantiser step Q (plus the decoder's rounding noise);
//! the likelihood of the observed low-frequency coefficients is evaluated for the IJG luminance
//! table (ITU-T T.81 Annex K.1, scaled as libjpeg does) at every quality 1–100, against an
//! unquantised (Q = 1) model, with a Laplacian prior on the coefficients. Blockiness alone
//! cannot give the quality: it depends as much on the content and the noise as on the
//! quantiser, which is why the quality comes from the coefficients.

use super::{check_view, pixel, view_bounds, MarkerRegions, StatsError};
use crate::detect::GrayView;
use crate::render::PixelRect;

/// The 8-px grid blockiness of a region.
#[derive(Debug, Clone, PartialEq)]
pub struct Blockiness {
    /// (B_h + B_v)/(A_h + A_v): ≈ 1 without block coding.
    pub ratio: f64,
    /// B_h / A_h (differences across vertical block boundaries).
    pub ratio_h: f64,
    /// B_v / A_v.
    pub ratio_v: f64,
    /// Mean |d| inside blocks (the activity A), DN.
    pub activity_dn: f64,
    /// Column phase (x mod 8 of the first column right of a boundary) with the largest B_h/A_h;
    /// 0 for JPEG blocks on the absolute grid.
    pub best_phase_x: usize,
    /// Row phase likewise.
    pub best_phase_y: usize,
    /// Neighbour differences used.
    pub pairs: usize,
}

/// The estimated JPEG quantisation.
#[derive(Debug, Clone, PartialEq)]
pub struct JpegQuality {
    /// Most likely IJG quality (1–100).
    pub quality: u8,
    /// Qualities whose tables explain the data within 2 nats of the best (identical tables on
    /// the frequencies used, or too little data to tell them apart).
    pub quality_range: (u8, u8),
    /// Log-likelihood gain of the best table over no quantisation, nats per block.
    pub gain_per_block: f64,
    /// Rounding noise σ of the coefficients that fitted best (0.29 for an 8-bit decode).
    pub coefficient_noise: f64,
    /// Blocks used.
    pub blocks: usize,
}

/// IJG/libjpeg luminance quantisation table (natural order) for `quality` 1–100.
pub fn ijg_luma_table(quality: u8) -> [u16; 64] {
    let q = quality.clamp(1, 100) as u32;
    let scale = if q < 50 { 5000 / q } else { 200 - 2 * q };
    let mut t = [0u16; 64];
    for (o, &v) in t.iter_mut().zip(ANNEX_K1.iter()) {
        *o = ((v as u32 * scale + 50) / 100).clamp(1, 255) as u16;
    }
    t
}

/// ITU-T T.81 Annex K.1 luminance table, natural (row-major, row = vertical frequency) order.
const ANNEX_K1: [u16; 64] = [
    16, 11, 10, 16, 24, 40, 51, 61, 12, 12, 14, 19, 26, 58, 60, 55, 14, 13, 16, 24, 40, 57, 69, 56,
    14, 17, 22, 29, 51, 87, 80, 62, 18, 22, 37, 56, 68, 109, 103, 77, 24, 35, 55, 64, 81, 104, 113,
    92, 49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99,
];

/// The first 15 coefficients in zig-zag order (natural indices).
const ZIGZAG15: [usize; 15] = [0, 1, 8, 16, 9, 2, 3, 10, 17, 24, 32, 25, 18, 11, 4];

/// The part of the view inside `rect` (all of it when `None`), inclusive bounds.
fn region(view: &GrayView<'_>, rect: Option<&PixelRect>) -> (i64, i64, i64, i64) {
    let (vx0, vy0, vx1, vy1) = view_bounds(view);
    match rect {
        None => (vx0, vy0, vx1, vy1),
        Some(r) => (
            r.x0.max(vx0),
            r.y0.max(vy0),
            (r.x1() - 1).min(vx1),
            (r.y1() - 1).min(vy1),
        ),
    }
}

/// Blockiness of flat regions, the diagnosis's compression statistic: [`blockiness`]'s ratio
/// on the same absolute grid, but over the pixels of `regions` only: the mean absolute difference between horizontally or vertically
/// adjacent pixels that straddle an 8-px block boundary (on the absolute grid), divided by the
/// same over pairs that do not, counting only pairs inside one flat region (ink, paper or
/// surround, away from every edge). Edges of the marker never enter, so an uncompressed frame
/// gives 1 up to noise wherever the marker sits; JPEG's block boundaries raise it. `None` with
/// fewer than 50 pairs of either kind.
pub fn flat_region_blockiness(view: &GrayView<'_>, regions: &MarkerRegions) -> Option<f64> {
    let (ox, oy) = (view.origin_px.0 as i64, view.origin_px.1 as i64);
    let value = |x: i64, y: i64| -> Option<f64> {
        let (lx, ly) = (x - ox, y - oy);
        if lx < 0 || ly < 0 || lx >= view.width as i64 || ly >= view.height as i64 {
            return None;
        }
        view.data
            .get(ly as usize * view.width + lx as usize)
            .map(|v| *v as f64)
    };
    let (mut on, mut n_on, mut off, mut n_off) = (0.0, 0usize, 0.0, 0usize);
    for pixels in [&regions.ink, &regions.paper, &regions.surround] {
        let set: std::collections::HashSet<(i64, i64)> = pixels.iter().copied().collect();
        for &(x, y) in pixels.iter() {
            for (dx, dy, coord) in [(1i64, 0i64, x + 1), (0, 1, y + 1)] {
                if !set.contains(&(x + dx, y + dy)) {
                    continue;
                }
                let (Some(a), Some(b)) = (value(x, y), value(x + dx, y + dy)) else {
                    continue;
                };
                if coord.rem_euclid(8) == 0 {
                    on += (a - b).abs();
                    n_on += 1;
                } else {
                    off += (a - b).abs();
                    n_off += 1;
                }
            }
        }
    }
    if n_on < 50 || n_off < 50 {
        return None;
    }
    let (m_on, m_off) = (on / n_on as f64, off / n_off as f64);
    // A frame without noise has no differences at all: no blocks to see.
    Some(if m_off > 1e-9 {
        m_on / m_off
    } else if m_on > 1e-9 {
        f64::INFINITY
    } else {
        1.0
    })
    .filter(|v| v.is_finite())
}

/// Blockiness of `rect ∩ view` (the whole view when `None`) on the absolute 8-px grid.
pub fn blockiness(view: &GrayView<'_>, rect: Option<&PixelRect>) -> Result<Blockiness, StatsError> {
    check_view(view)?;
    let (x0, y0, x1, y1) = region(view, rect);
    // Sums of |d| per phase: index = position of the right/lower pixel mod 8.
    let mut h = [(0.0, 0usize); 8];
    let mut v = [(0.0, 0usize); 8];
    for y in y0..=y1 {
        for x in x0..=x1 {
            let Some(p) = pixel(view, x, y) else { continue };
            if x > x0 {
                if let Some(q) = pixel(view, x - 1, y) {
                    let e = &mut h[x.rem_euclid(8) as usize];
                    e.0 += (p as f64 - q as f64).abs();
                    e.1 += 1;
                }
            }
            if y > y0 {
                if let Some(q) = pixel(view, x, y - 1) {
                    let e = &mut v[y.rem_euclid(8) as usize];
                    e.0 += (p as f64 - q as f64).abs();
                    e.1 += 1;
                }
            }
        }
    }
    let pairs: usize = h.iter().chain(&v).map(|e| e.1).sum();
    let ba = |s: &[(f64, usize); 8], phase: usize| {
        let b = s[phase];
        let (a_sum, a_n) = s
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != phase)
            .fold((0.0, 0), |acc, (_, e)| (acc.0 + e.0, acc.1 + e.1));
        (b.0 / b.1.max(1) as f64, a_sum / a_n.max(1) as f64, b.1, a_n)
    };
    let (bh, ah, nbh, _) = ba(&h, 0);
    let (bv, av, nbv, _) = ba(&v, 0);
    if nbh + nbv < 64 {
        return Err(StatsError::TooFew {
            what: "blockiness: differences across block boundaries".into(),
            got: nbh + nbv,
            need: 64,
        });
    }
    if ah + av < 1e-3 {
        return Err(StatsError::NoFit {
            what: "blockiness".into(),
            reason: "the region is flat (no activity inside blocks)".into(),
        });
    }
    let best = |s: &[(f64, usize); 8]| {
        (0..8)
            .max_by(|&i, &j| {
                let (bi, ai, _, _) = ba(s, i);
                let (bj, aj, _, _) = ba(s, j);
                (bi / ai.max(1e-9)).total_cmp(&(bj / aj.max(1e-9)))
            })
            .unwrap_or(0)
    };
    let safe = |b: f64, a: f64| if a > 1e-9 { b / a } else { 1.0 };
    Ok(Blockiness {
        ratio: (bh + bv) / (ah + av),
        ratio_h: safe(bh, ah),
        ratio_v: safe(bv, av),
        activity_dn: 0.5 * (ah + av),
        best_phase_x: best(&h),
        best_phase_y: best(&v),
        pairs,
    })
}

/// Orthonormal 8-point DCT-II basis: `C[u][x]`.
fn dct_basis() -> [[f64; 8]; 8] {
    let mut c = [[0.0; 8]; 8];
    for (u, row) in c.iter_mut().enumerate() {
        let a = if u == 0 {
            (1.0f64 / 8.0).sqrt()
        } else {
            (2.0f64 / 8.0).sqrt()
        };
        for (x, v) in row.iter_mut().enumerate() {
            *v = a * (((2 * x + 1) * u) as f64 * std::f64::consts::PI / 16.0).cos();
        }
    }
    c
}

/// Σ log p(c | Q, σ) over `coefs`: the unquantised value has a Laplace(0, b) prior, so lattice
/// point kQ has probability 1 − e^(−Q/2b) (k = 0) or e^(−|k|Q/b)·sinh(Q/2b), and the decoded
/// coefficient is that point plus Gaussian rounding noise of σ.
fn log_likelihood(coefs: &[f64], q: f64, sigma: f64, b: f64) -> f64 {
    coefs
        .iter()
        .map(|&c| lattice_density(c, q, sigma, b).max(1e-300).ln())
        .sum()
}

/// p(c | Q, σ) of [`log_likelihood`] for one coefficient.
fn lattice_density(c: f64, q: f64, sigma: f64, b: f64) -> f64 {
    let norm = 1.0 / (sigma * (2.0 * std::f64::consts::PI).sqrt());
    let p0 = 1.0 - (-0.5 * q / b).exp();
    let ln_sinh = (0.5 * q / b).sinh().max(1e-300).ln();
    let reach = (4.0 * sigma / q).ceil().max(1.0) as i64;
    let inv2s2 = 0.5 / (sigma * sigma);
    let k0 = (c / q).round() as i64;
    let mut p = 0.0;
    for k in k0 - reach..=k0 + reach {
        let r = c - k as f64 * q;
        p += if k == 0 {
            p0 * (-r * r * inv2s2).exp()
        } else {
            (ln_sinh - k.unsigned_abs() as f64 * q / b - r * r * inv2s2).exp()
        };
    }
    p * norm
}

/// Noise σ (DN) and Laplace scales b (DN) the unquantised model may take, per frequency.
const UNQUANTISED_SIGMAS: [f64; 5] = [0.3, 0.4, 0.5, 0.7, 1.0];
const UNQUANTISED_SCALES: [f64; 6] = [0.05, 0.1, 0.2, 0.4, 0.8, 1.6];

/// Step of the lattice that stands for a continuum: far below every σ of the unquantised model
/// (the lattice's ripple on the density, e^(−2π²σ²/q²), is below 1e-70).
const CONTINUUM_STEP: f64 = 0.1;

/// Σ log p(c) over `coefs` without any quantiser: a continuous Laplace(b) value plus Gaussian
/// noise σ, at the best σ and b of a grid (and b = mean |c|). Not the step-1 lattice: a quiet
/// uncompressed region gives coefficients spread continuously about 0 by its pixel noise, which
/// a step-1 lattice with a Laplace prior of b ≥ ½ explains worse than a coarse table whose
/// steps all round them to 0 (every quantiser looked likely on flat renders with < 1 DN noise).
fn unquantised_log_likelihood(coefs: &[f64]) -> f64 {
    let mean_abs = coefs.iter().map(|v| v.abs()).sum::<f64>() / coefs.len().max(1) as f64;
    let mut best = f64::NEG_INFINITY;
    for &s in &UNQUANTISED_SIGMAS {
        for &b in UNQUANTISED_SCALES.iter().chain([mean_abs.max(0.05)].iter()) {
            best = best.max(log_likelihood(coefs, CONTINUUM_STEP, s, b));
        }
    }
    best
}

/// Standard score above which the coefficients beyond the zero bin sit on the table's lattice:
/// under no quantisation their phase c/Q mod 1 is uniform and the score is N(0, 1) (a little
/// more after choosing the best of the tables); a decode's rounding noise (σ ≈ 0.3) keeps
/// E cos(2πc/Q) ≥ 0.6 for every step ≥ 2, so any compressed footage with a few hundred such
/// coefficients scores in the tens.
const LATTICE_SUPPORT_Z: f64 = 5.0;

/// Coefficients at non-zero lattice points needed before the lattice is judged at all.
const LATTICE_SUPPORT_MIN: usize = 20;

/// How well the coefficients outside the zero bin (|c| ≥ Q/2, steps Q ≥ 2) of `table` sit on its
/// lattice: Σ cos(2πc/Q)·√(2/n), `None` below [`LATTICE_SUPPORT_MIN`] of them. The likelihood
/// ratio alone cannot tell a quantiser from content that is flat in most blocks: a table that
/// rounds every small coefficient to 0 explains a zero-inflated spread better than one Laplace
/// continuum does, whatever the coefficients beyond zero look like (uncompressed renders with
/// < 1 DN of noise, 95 % flat blocks, scored 3 nats per block for quality 87). Only the
/// coefficients at the lattice's non-zero points show the quantiser itself.
fn lattice_support_z(coefs: &[Vec<f64>], table: &[u16; 64]) -> Option<f64> {
    let (mut sum_cos, mut n) = (0.0, 0usize);
    // Not the DC: a block flat at an integer level has DC = 8·(level − 128), on every lattice
    // of step 2, 4 or 8, compressed or not.
    for (cs, &idx) in coefs.iter().zip(ZIGZAG15.iter()).skip(1) {
        let q = table[idx] as f64;
        if q < 2.0 {
            continue;
        }
        for &c in cs.iter().filter(|c| c.abs() >= 0.5 * q) {
            sum_cos += (2.0 * std::f64::consts::PI * c / q).cos();
            n += 1;
        }
    }
    (n >= LATTICE_SUPPORT_MIN).then(|| sum_cos * (2.0 / n as f64).sqrt())
}

/// Estimates the JPEG quality from the block-DCT coefficients of `rect ∩ view` (whole view when
/// `None`) on the absolute 8-px grid, using at most `max_blocks` blocks (evenly spread; blocks
/// with clipped pixels are skipped). `Ok(None)` when the coefficients show no quantisation
/// coarser than 1 (uncompressed, quality ≥ ~97, or re-processed after decoding).
pub fn jpeg_quality(
    view: &GrayView<'_>,
    rect: Option<&PixelRect>,
    max_blocks: usize,
) -> Result<Option<JpegQuality>, StatsError> {
    check_view(view)?;
    let (x0, y0, x1, y1) = region(view, rect);
    let bx0 = (x0 + 7).div_euclid(8);
    let by0 = (y0 + 7).div_euclid(8);
    let bx1 = (x1 + 1).div_euclid(8); // exclusive
    let by1 = (y1 + 1).div_euclid(8);
    let mut blocks: Vec<(i64, i64)> = Vec::new();
    for by in by0..by1 {
        for bx in bx0..bx1 {
            blocks.push((bx * 8, by * 8));
        }
    }
    if blocks.len() > max_blocks.max(1) {
        let n = blocks.len();
        let keep = max_blocks.max(1);
        blocks = (0..keep).map(|k| blocks[k * n / keep]).collect();
    }
    let c = dct_basis();
    let mut coefs: Vec<Vec<f64>> = vec![Vec::new(); ZIGZAG15.len()];
    let mut used = 0;
    'blocks: for &(bx, by) in &blocks {
        let mut b = [[0.0; 8]; 8];
        for (y, row) in b.iter_mut().enumerate() {
            for (x, v) in row.iter_mut().enumerate() {
                let p = pixel(view, bx + x as i64, by + y as i64).unwrap_or(0);
                if p == 0 || p == 255 {
                    continue 'blocks;
                }
                *v = p as f64 - 128.0;
            }
        }
        // Rows then columns: F = C·B·Cᵀ.
        let mut t = [[0.0; 8]; 8];
        for y in 0..8 {
            for u in 0..8 {
                t[y][u] = (0..8).map(|x| c[u][x] * b[y][x]).sum();
            }
        }
        for (k, &idx) in ZIGZAG15.iter().enumerate() {
            let (v, u) = (idx / 8, idx % 8);
            coefs[k].push((0..8).map(|y| c[v][y] * t[y][u]).sum());
        }
        used += 1;
    }
    if used < 16 {
        return Err(StatsError::TooFew {
            what: "JPEG quality: unclipped 8×8 blocks".into(),
            got: used,
            need: 16,
        });
    }
    // Rounding noise of an 8-bit decode (0.29 DN, more through a colour conversion): a wider
    // σ would let the lattice model explain genuine image noise around zero.
    let sigmas = [0.3, 0.4, 0.5];
    let tables: Vec<[u16; 64]> = (1..=100u8).map(ijg_luma_table).collect();
    // ll[k][s] per distinct step: cache per frequency.
    let mut per_freq: Vec<std::collections::BTreeMap<u16, Vec<f64>>> = Vec::new();
    for (k, &idx) in ZIGZAG15.iter().enumerate() {
        let cs = &coefs[k];
        let b = (cs.iter().map(|v| v.abs()).sum::<f64>() / cs.len() as f64).max(0.5);
        let mut map = std::collections::BTreeMap::new();
        let mut steps: Vec<u16> = tables.iter().map(|t| t[idx]).collect();
        steps.push(1);
        steps.sort_unstable();
        steps.dedup();
        for q in steps {
            let lls = sigmas
                .iter()
                .map(|&s| log_likelihood(cs, q as f64, s, b))
                .collect();
            map.insert(q, lls);
        }
        per_freq.push(map);
    }
    let total = |table: Option<&[u16; 64]>, s: usize| -> f64 {
        ZIGZAG15
            .iter()
            .enumerate()
            .map(|(k, &idx)| {
                let q = table.map_or(1, |t| t[idx]);
                per_freq[k].get(&q).map_or(f64::NEG_INFINITY, |v| v[s])
            })
            .sum()
    };
    let baseline: f64 = coefs.iter().map(|cs| unquantised_log_likelihood(cs)).sum();
    let mut best = (f64::NEG_INFINITY, 0usize, 0usize);
    for (qi, t) in tables.iter().enumerate() {
        for s in 0..sigmas.len() {
            let ll = total(Some(t), s);
            if ll > best.0 {
                best = (ll, qi, s);
            }
        }
    }
    let gain = (best.0 - baseline) / used as f64;
    let coarse = ZIGZAG15.iter().any(|&idx| tables[best.1][idx] > 1);
    let support_z = lattice_support_z(&coefs, &tables[best.1]);
    if !(gain > 0.3 && coarse && support_z.is_some_and(|z| z > LATTICE_SUPPORT_Z)) {
        return Ok(None);
    }
    let close: Vec<usize> = (0..tables.len())
        .filter(|&qi| total(Some(&tables[qi]), best.2) >= best.0 - 2.0)
        .collect();
    let lo = close.iter().copied().min().unwrap_or(best.1);
    let hi = close.iter().copied().max().unwrap_or(best.1);
    Ok(Some(JpegQuality {
        quality: (best.1 + 1) as u8,
        quality_range: ((lo + 1) as u8, (hi + 1) as u8),
        gain_per_block: gain,
        coefficient_noise: sigmas[best.2],
        blocks: used,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ijg_tables_scale_like_libjpeg() {
        assert_eq!(ijg_luma_table(50)[..3], [16, 11, 10]);
        assert_eq!(ijg_luma_table(100).iter().max(), Some(&1));
        assert_eq!(ijg_luma_table(90)[0], 3); // (16·20 + 50)/100
        assert_eq!(ijg_luma_table(1)[63], 255);
    }

    #[test]
    fn dct_basis_is_orthonormal() {
        let c = dct_basis();
        for i in 0..8 {
            for j in 0..8 {
                let s: f64 = (0..8).map(|x| c[i][x] * c[j][x]).sum();
                assert!((s - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
    }
}
