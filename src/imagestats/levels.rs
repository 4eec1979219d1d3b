//! Grey levels and noise of the marker's flat regions: ink, paper (white cells and margin) and
//! the surround beyond the paper, from pixels at least a guard distance from every material
//! boundary; and noise from the variation of static pixels over frames.

use super::censored::censored_normal_fit;
use super::grid::{Homography, MarkerLayout, Material};
use super::{check_view, pixel, view_bounds, StatsError};
use crate::detect::GrayView;

/// Which pixels count as "well inside" a region.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelOptions {
    /// Distance kept from every material boundary, px (blur and corner error). Default 3.
    pub guard_px: f64,
    /// Width of the surround ring measured beyond the white margin, cells (only when the
    /// margin is known). Default 1.
    pub surround_cells: f64,
    /// Fewer pixels than this in the ink or paper region is an error. Default 30.
    pub min_pixels: usize,
}

impl Default for LevelOptions {
    fn default() -> Self {
        Self {
            guard_px: 3.0,
            surround_cells: 1.0,
            min_pixels: 30,
        }
    }
}

/// Level and noise of one flat region.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionStats {
    /// Median grey level, DN.
    pub median_dn: f64,
    /// Mean of the central 80 % of the values, DN.
    pub trimmed_mean_dn: f64,
    /// Noise σ: RMS residual about a plane fitted to the region (slow illumination gradients
    /// removed), with values beyond 3.5σ left out iteratively, DN (includes the 8-bit
    /// quantisation and any spatially correlated noise).
    pub noise_sigma_dn: f64,
    /// Noise σ from horizontal neighbour differences, std(Δ)/√2, DN: the part of the noise that
    /// is uncorrelated between neighbours (smaller than `noise_sigma_dn` when denoising or
    /// compression correlate neighbours).
    pub noise_sigma_diff_dn: f64,
    /// Pixels used.
    pub pixels: usize,
    /// Neighbour pairs used for `noise_sigma_diff_dn`.
    pub pairs: usize,
    /// The values pile up at one end (a tone curve or the sensor clipped the noise): the extreme
    /// value holds more pixels than the next level inside and either at least 30 % of them or,
    /// over a spread of four levels or more, at least [`MIN_PILE_FRACTION`] (a level a little
    /// above the black level: only its lower tail is cut). (After JPEG compression the pile is
    /// smeared and not detected.)
    pub clipping: Option<Clipping>,
}

/// A region whose noise is cut off at one grey level.
#[derive(Debug, Clone, PartialEq)]
pub struct Clipping {
    /// The level the values pile up at, DN.
    pub level_dn: f64,
    /// `true`: clipped from above (nothing brighter), `false`: from below.
    pub high: bool,
    /// Fraction of the pixels at that level.
    pub fraction: f64,
    /// σ of the noise before clipping (with the 8-bit quantisation, like the unclipped
    /// regions' σ), DN: maximum likelihood of a censored, quantised normal on the region's
    /// histogram ([`censored_normal_fit`]).
    pub sigma_dn: f64,
    /// Mean of the noise before clipping, DN (at or beyond `level_dn` when half the pixels or
    /// more are clipped).
    pub mean_dn: f64,
}

/// Smallest share of a region's pixels at its extreme value that counts as a clipping pile when
/// the values spread over four levels or more: an unclipped normal's extreme level holds a few
/// pixels and fewer than the level inside it.
pub const MIN_PILE_FRACTION: f64 = 0.02;

/// Levels of the three materials around one marker.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerLevels {
    pub ink: RegionStats,
    pub paper: RegionStats,
    /// Beyond the white margin; `None` when the margin is unknown or too little of the ring
    /// is inside the view.
    pub surround: Option<RegionStats>,
}

/// Absolute pixel coordinates of the well-inside regions (row-major order).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MarkerRegions {
    pub ink: Vec<(i64, i64)>,
    pub paper: Vec<(i64, i64)>,
    pub surround: Vec<(i64, i64)>,
}

/// Noise of static pixels from their variation over frames.
#[derive(Debug, Clone, PartialEq)]
pub struct TemporalNoise {
    /// Mean level, DN.
    pub level_dn: f64,
    /// Pooled per-pixel temporal σ after removing each frame's common offset (flicker), DN.
    pub sigma_dn: f64,
    /// Approximate standard error of `sigma_dn`, DN.
    pub sigma_stderr_dn: f64,
    pub pixels: usize,
    pub frames: usize,
}

/// The well-inside pixels of ink, paper and surround of the marker with corners `corners_px`.
/// The black square and its known margin must lie inside the view; the surround ring is clipped
/// to it.
pub fn marker_regions(
    view: &GrayView<'_>,
    corners_px: &[[f64; 2]; 4],
    layout: &MarkerLayout,
    options: &LevelOptions,
) -> Result<MarkerRegions, StatsError> {
    check_view(view)?;
    let n = layout.side_cells() as f64;
    let h = Homography::from_corners(corners_px, layout.side_cells())?;
    let margin = layout.margin_cells();
    let outer = match margin {
        Some(m) => m + options.surround_cells.max(0.0),
        None => 0.0,
    };
    // Smallest cell size in px over the paper: converts the guard to grid units.
    let mut cell_px = f64::INFINITY;
    for &(gx, gy) in &[(0.0, 0.0), (n, 0.0), (n, n), (0.0, n), (n / 2.0, n / 2.0)] {
        let p = h.map(gx, gy);
        let px = h.map(gx + 0.01, gy);
        let py = h.map(gx, gy + 0.01);
        cell_px = cell_px
            .min((px[0] - p[0]).hypot(px[1] - p[1]) / 0.01)
            .min((py[0] - p[0]).hypot(py[1] - p[1]) / 0.01);
    }
    if !(cell_px.is_finite() && cell_px > 0.0) {
        return Err(StatsError::Degenerate {
            corners_px: *corners_px,
            reason: "zero cell size".into(),
        });
    }
    let r = options.guard_px.max(0.0) / cell_px;
    let bbox = |ext: f64| {
        let pts = [
            h.map(-ext, -ext),
            h.map(n + ext, -ext),
            h.map(n + ext, n + ext),
            h.map(-ext, n + ext),
        ];
        let x0 = pts.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
        let x1 = pts.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max);
        let y0 = pts.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
        let y1 = pts.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max);
        (
            x0.floor() as i64,
            y0.floor() as i64,
            x1.ceil() as i64,
            y1.ceil() as i64,
        )
    };
    let (vx0, vy0, vx1, vy1) = view_bounds(view);
    let paper_ext = margin.unwrap_or(0.0);
    let (px0, py0, px1, py1) = bbox(paper_ext);
    if px0 < vx0 || py0 < vy0 || px1 > vx1 || py1 > vy1 {
        return Err(StatsError::OutsideView {
            what: "the marker and its white margin".into(),
            x0: px0,
            y0: py0,
            x1: px1,
            y1: py1,
        });
    }
    let (x0, y0, x1, y1) = bbox(outer);
    let (x0, y0, x1, y1) = (x0.max(vx0), y0.max(vy0), x1.min(vx1), y1.min(vy1));
    let offsets: Vec<(f64, f64)> = {
        let k = [-1.0, -0.5, 0.0, 0.5, 1.0];
        let step = r.clamp(0.0, 1.0);
        let reach = if r > 1.0 { (r / 0.5).ceil() as i32 } else { 2 };
        if r > 1.0 {
            (-reach..=reach)
                .flat_map(|i| {
                    (-reach..=reach)
                        .map(move |j| (i as f64 * r / reach as f64, j as f64 * r / reach as f64))
                })
                .collect()
        } else {
            k.iter()
                .flat_map(|&i| k.iter().map(move |&j| (i * step, j * step)))
                .collect()
        }
    };
    let mut out = MarkerRegions::default();
    for y in y0..=y1 {
        for x in x0..=x1 {
            let g = h.unmap(x as f64, y as f64);
            if !(g[0] >= -outer && g[0] <= n + outer && g[1] >= -outer && g[1] <= n + outer) {
                continue;
            }
            let m = layout.material(g[0], g[1]);
            if m == Material::Surround && margin.is_none() {
                continue;
            }
            if offsets
                .iter()
                .any(|&(dx, dy)| layout.material(g[0] + dx, g[1] + dy) != m)
            {
                continue;
            }
            match m {
                Material::Ink => out.ink.push((x, y)),
                Material::Paper => out.paper.push((x, y)),
                Material::Surround => out.surround.push((x, y)),
            }
        }
    }
    Ok(out)
}

/// Ink, paper and surround levels and noise around the marker with corners `corners_px`.
pub fn marker_levels(
    view: &GrayView<'_>,
    corners_px: &[[f64; 2]; 4],
    layout: &MarkerLayout,
    options: &LevelOptions,
) -> Result<MarkerLevels, StatsError> {
    let regions = marker_regions(view, corners_px, layout, options)?;
    let need = options.min_pixels.max(3);
    let ink = region_stats(view, &regions.ink, "ink", need)?;
    let paper = region_stats(view, &regions.paper, "paper", need)?;
    let surround = region_stats(view, &regions.surround, "surround", need).ok();
    Ok(MarkerLevels {
        ink,
        paper,
        surround,
    })
}

/// Level and noise of the given absolute pixels (row-major order, as [`marker_regions`] gives).
pub fn region_stats(
    view: &GrayView<'_>,
    pixels: &[(i64, i64)],
    what: &str,
    min_pixels: usize,
) -> Result<RegionStats, StatsError> {
    let values: Vec<(f64, f64, f64)> = pixels
        .iter()
        .filter_map(|&(x, y)| pixel(view, x, y).map(|v| (x as f64, y as f64, v as f64)))
        .collect();
    if values.len() < min_pixels.max(3) {
        return Err(StatsError::TooFew {
            what: format!("{what} region"),
            got: values.len(),
            need: min_pixels.max(3),
        });
    }
    let mut hist = [0usize; 256];
    for v in &values {
        hist[v.2 as usize] += 1;
    }
    let n = values.len();
    let quantile_value = |rank: usize| {
        let mut acc = 0;
        for (v, &c) in hist.iter().enumerate() {
            acc += c;
            if acc > rank {
                return v as f64;
            }
        }
        255.0
    };
    let median_dn = if n % 2 == 1 {
        quantile_value(n / 2)
    } else {
        0.5 * (quantile_value(n / 2 - 1) + quantile_value(n / 2))
    };
    let (lo, hi) = (n / 10, n - n / 10);
    let mut sorted: Vec<f64> = values.iter().map(|v| v.2).collect();
    sorted.sort_by(f64::total_cmp);
    let trimmed = &sorted[lo..hi.max(lo + 1)];
    let trimmed_mean_dn = trimmed.iter().sum::<f64>() / trimmed.len() as f64;
    let noise_sigma_dn = plane_residual_sigma(&values).unwrap_or(0.0);
    // Horizontal neighbours that are both in the region (input is row-major).
    let mut diffs = Vec::new();
    for w in pixels.windows(2) {
        if w[1].1 == w[0].1 && w[1].0 == w[0].0 + 1 {
            if let (Some(a), Some(b)) = (pixel(view, w[0].0, w[0].1), pixel(view, w[1].0, w[1].1)) {
                diffs.push(b as f64 - a as f64);
            }
        }
    }
    let noise_sigma_diff_dn = clipped_sigma(&diffs).map_or(0.0, |s| s / std::f64::consts::SQRT_2);
    let clipping = clipping_of(&hist, n, median_dn);
    Ok(RegionStats {
        median_dn,
        trimmed_mean_dn,
        noise_sigma_dn,
        noise_sigma_diff_dn,
        pixels: n,
        pairs: diffs.len(),
        clipping,
    })
}

fn clipping_of(hist: &[usize; 256], n: usize, _median_dn: f64) -> Option<Clipping> {
    let quantile = |q: f64| {
        let rank = ((n as f64 - 1.0) * q).round() as usize;
        let mut acc = 0;
        for (v, &c) in hist.iter().enumerate() {
            acc += c;
            if acc > rank {
                return v;
            }
        }
        255
    };
    let (p02, p50, p98) = (quantile(0.02), quantile(0.5), quantile(0.98));
    let (lower, upper) = ((p50 - p02) as f64, (p98 - p50) as f64);
    // Either a pile at the extreme value (more pixels there than one level inside), or, when
    // compression smeared the pile, one tail much shorter than the other.
    let hi = hist.iter().rposition(|&c| c > 0)?;
    let lo = hist.iter().position(|&c| c > 0)?;
    if hi == lo {
        return None;
    }
    let piled = |level: usize, inner: usize| {
        let f = hist[level] as f64 / n as f64;
        hist[level] > hist[inner] && (f >= 0.3 || (f >= MIN_PILE_FRACTION && hi - lo >= 3))
    };
    let side = |high: bool| -> Option<Clipping> {
        let (extreme, inner) = if high { (hi, hi - 1) } else { (lo, lo + 1) };
        let (long, short) = if high { (lower, upper) } else { (upper, lower) };
        // A short tail alone is not enough: JPEG ringing near edges skews flat regions too.
        let _ = (long, short);
        if !piled(extreme, inner) {
            return None;
        }
        // The pile: the most frequent level on the short side of the median.
        let range: Vec<usize> = if high {
            (p50..=hi).collect()
        } else {
            (lo..=p50).collect()
        };
        // (A pile under 30 % is the extreme level itself: a partly cut tail.)
        let level = if (hist[extreme] as f64) < 0.3 * n as f64 {
            extreme
        } else {
            range
                .into_iter()
                .max_by_key(|&v| (hist[v], if high { v } else { 255 - v }))?
        };
        // Everything beyond the pile is folded into it (JPEG or a soft shoulder can leave a
        // few values past the clip level).
        let mut folded = *hist;
        for v in 0..256 {
            if (high && v > level) || (!high && v < level) {
                folded[level] += folded[v];
                folded[v] = 0;
            }
        }
        let (mean_dn, sigma) = censored_normal_fit(&folded, !high, high)?;
        Some(Clipping {
            level_dn: level as f64,
            high,
            fraction: hist[level] as f64 / n as f64,
            sigma_dn: (sigma * sigma + 1.0 / 12.0).sqrt(),
            mean_dn,
        })
    };
    side(true).or_else(|| side(false))
}

/// RMS of residuals about a least-squares plane, values beyond 3.5σ dropped (three rounds).
fn plane_residual_sigma(values: &[(f64, f64, f64)]) -> Option<f64> {
    let n = values.len() as f64;
    let (mx, my) = (
        values.iter().map(|v| v.0).sum::<f64>() / n,
        values.iter().map(|v| v.1).sum::<f64>() / n,
    );
    let mut keep = vec![true; values.len()];
    let mut sigma = f64::INFINITY;
    for _ in 0..4 {
        let mut a = vec![vec![0.0; 3]; 3];
        let mut b = vec![0.0; 3];
        let mut m = 0usize;
        for (v, _) in values.iter().zip(&keep).filter(|(_, k)| **k) {
            let r = [1.0, v.0 - mx, v.1 - my];
            for i in 0..3 {
                b[i] += r[i] * v.2;
                for j in 0..3 {
                    a[i][j] += r[i] * r[j];
                }
            }
            m += 1;
        }
        if m < 4 {
            return None;
        }
        // A degenerate layout (one row or column) cannot fix a plane: fit the mean only.
        let c = crate::numeric::linalg::solve_rows(&a, &b)
            .unwrap_or_else(|| vec![b[0] / m as f64, 0.0, 0.0]);
        let res = |v: &(f64, f64, f64)| v.2 - c[0] - c[1] * (v.0 - mx) - c[2] * (v.1 - my);
        let ss: f64 = values
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(v, _)| res(v).powi(2))
            .sum();
        sigma = (ss / (m as f64 - 3.0).max(1.0)).sqrt();
        let mut changed = false;
        for (v, k) in values.iter().zip(keep.iter_mut()) {
            let inside = res(v).abs() <= 3.5 * sigma.max(0.5);
            if inside != *k {
                *k = inside;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    Some(sigma)
}

/// Standard deviation with values beyond 3.5σ dropped (three rounds).
fn clipped_sigma(values: &[f64]) -> Option<f64> {
    if values.len() < 3 {
        return None;
    }
    let mut lim = f64::INFINITY;
    let mut sigma = 0.0;
    for _ in 0..4 {
        let kept: Vec<f64> = values.iter().copied().filter(|v| v.abs() <= lim).collect();
        if kept.len() < 3 {
            return None;
        }
        let mean = kept.iter().sum::<f64>() / kept.len() as f64;
        let var = kept.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (kept.len() - 1) as f64;
        sigma = var.sqrt();
        let new_lim = mean.abs() + 3.5 * sigma.max(0.5);
        if new_lim == lim {
            break;
        }
        lim = new_lim;
    }
    Some(sigma)
}

/// Temporal noise of `pixels` (absolute coordinates, static in the scene) over `frames`: the
/// pooled per-pixel variance after removing each frame's mean offset of the set (flicker).
/// Every frame must contain every pixel.
pub fn temporal_noise(
    frames: &[GrayView<'_>],
    pixels: &[(i64, i64)],
) -> Result<TemporalNoise, StatsError> {
    let f = frames.len();
    if f < 2 {
        return Err(StatsError::TooFew {
            what: "temporal noise: frames".into(),
            got: f,
            need: 2,
        });
    }
    let p = pixels.len();
    if p < 2 {
        return Err(StatsError::TooFew {
            what: "temporal noise: pixels".into(),
            got: p,
            need: 2,
        });
    }
    let mut v = vec![0.0; f * p];
    for (k, frame) in frames.iter().enumerate() {
        check_view(frame)?;
        for (i, &(x, y)) in pixels.iter().enumerate() {
            v[k * p + i] = pixel(frame, x, y).ok_or_else(|| StatsError::OutsideView {
                what: format!("temporal noise: pixel ({x}, {y}) of frame {k}"),
                x0: x,
                y0: y,
                x1: x,
                y1: y,
            })? as f64;
        }
    }
    let frame_mean: Vec<f64> = (0..f)
        .map(|k| v[k * p..(k + 1) * p].iter().sum::<f64>() / p as f64)
        .collect();
    let pixel_mean: Vec<f64> = (0..p)
        .map(|i| (0..f).map(|k| v[k * p + i]).sum::<f64>() / f as f64)
        .collect();
    let grand = frame_mean.iter().sum::<f64>() / f as f64;
    let mut ss = 0.0;
    for k in 0..f {
        for i in 0..p {
            let r = v[k * p + i] - pixel_mean[i] - frame_mean[k] + grand;
            ss += r * r;
        }
    }
    let dof = ((f - 1) * (p - 1)) as f64;
    let sigma = (ss / dof).sqrt();
    Ok(TemporalNoise {
        level_dn: grand,
        sigma_dn: sigma,
        sigma_stderr_dn: sigma / (2.0 * dof).sqrt(),
        pixels: p,
        frames: f,
    })
}
