//! Measuring the seed rig's real frame to set the renderer's defaults: marker ink and paper
//! levels (DN), noise on flat areas (DN), and the optical blur σ (px) from an erf-type fit of a
//! straight marker edge. Pure functions over decoded pixels; the test reads the real JPEG.
//!
//! Edge model (exactly what the renderer produces for a straight edge): pixel value
//! a + b·F(x − e), with F the step integrated over the 1-px pixel box and blurred by a Gaussian
//! of σ: F(u) = G(u + ½) − G(u − ½), G(s) = s·Φ(s/σ) + σ·φ(s/σ). Each row is fitted on its own
//! (e, σ by coarse-to-fine grid search, a, b by linear least squares), so a slight tilt of the
//! edge does no harm; the reported σ is the median over rows.

use super::image::GrayImage;
use super::raster::PixelRect;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum MeasureError {
    #[error("JPEG decoding failed: {0}")]
    Decode(String),
    #[error("region {0:?} is not inside the image")]
    Region(PixelRect),
    #[error("no row of {0:?} could be fitted")]
    NoFit(PixelRect),
}

/// Decodes a JPEG into 8-bit luma (BT.601 weights for colour images).
pub fn decode_jpeg_luma(bytes: &[u8]) -> Result<GrayImage, MeasureError> {
    let mut d = jpeg_decoder::Decoder::new(bytes);
    let pixels = d
        .decode()
        .map_err(|e| MeasureError::Decode(e.to_string()))?;
    let info = d
        .info()
        .ok_or_else(|| MeasureError::Decode("no image info".into()))?;
    let (w, h) = (info.width as usize, info.height as usize);
    let data = match info.pixel_format {
        jpeg_decoder::PixelFormat::L8 => pixels,
        jpeg_decoder::PixelFormat::RGB24 => pixels
            .chunks_exact(3)
            .map(|p| {
                (0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64).round() as u8
            })
            .collect(),
        other => {
            return Err(MeasureError::Decode(format!(
                "unsupported pixel format {other:?}"
            )))
        }
    };
    Ok(GrayImage {
        window: PixelRect::new(0, 0, w, h),
        data,
    })
}

fn region_values(img: &GrayImage, rect: &PixelRect) -> Result<Vec<Vec<f64>>, MeasureError> {
    if img.window.intersect(rect) != *rect || rect.is_empty() {
        return Err(MeasureError::Region(*rect));
    }
    Ok((rect.y0..rect.y1())
        .map(|y| {
            (rect.x0..rect.x1())
                .map(|x| img.get(x, y).unwrap_or(0) as f64)
                .collect()
        })
        .collect())
}

/// Median level (DN) of a flat region and its pixel noise σ (DN), estimated from horizontal
/// neighbour differences (σ = std(Δ)/√2, insensitive to slow illumination gradients).
pub fn flat_level_and_noise(img: &GrayImage, rect: &PixelRect) -> Result<(f64, f64), MeasureError> {
    let rows = region_values(img, rect)?;
    let mut all: Vec<f64> = rows.iter().flatten().copied().collect();
    all.sort_by(|a, b| a.total_cmp(b));
    let median = all[all.len() / 2];
    let diffs: Vec<f64> = rows
        .iter()
        .flat_map(|r| r.windows(2).map(|w| w[1] - w[0]))
        .collect();
    let n = diffs.len().max(1) as f64;
    let mean = diffs.iter().sum::<f64>() / n;
    let var = diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n;
    Ok((median, (var / 2.0).sqrt()))
}

/// Pixel-box-integrated blurred step (see module docs).
fn edge_model(u: f64, sigma: f64) -> f64 {
    let g = |s: f64| {
        s * crate::numeric::dist::normal_cdf(s / sigma)
            + sigma * (-(s * s) / (2.0 * sigma * sigma)).exp() / (2.0 * std::f64::consts::PI).sqrt()
    };
    g(u + 0.5) - g(u - 0.5)
}

/// Residual sum of squares of the best a + b·F(x − e) for given (e, σ).
fn rss(xs: &[f64], vs: &[f64], e: f64, sigma: f64) -> f64 {
    let f: Vec<f64> = xs.iter().map(|x| edge_model(x - e, sigma)).collect();
    let n = xs.len() as f64;
    let (sf, sv) = (f.iter().sum::<f64>(), vs.iter().sum::<f64>());
    let sff = f.iter().map(|v| v * v).sum::<f64>();
    let sfv = f.iter().zip(vs).map(|(a, b)| a * b).sum::<f64>();
    let det = n * sff - sf * sf;
    if det.abs() < 1e-12 {
        return f64::INFINITY;
    }
    let b = (n * sfv - sf * sv) / det;
    let a = (sv - b * sf) / n;
    f.iter()
        .zip(vs)
        .map(|(fi, v)| (v - a - b * fi).powi(2))
        .sum()
}

/// Edge position and σ for one row profile (values at integer x).
fn fit_row(xs: &[f64], vs: &[f64]) -> Option<(f64, f64)> {
    let (lo, hi) = vs
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), &v| (l.min(v), h.max(v)));
    if hi - lo < 20.0 {
        return None;
    }
    // Start at the half-level crossing.
    let mid = (lo + hi) / 2.0;
    let e0 = xs
        .windows(2)
        .zip(vs.windows(2))
        .find(|(_, v)| (v[0] - mid) * (v[1] - mid) <= 0.0)
        .map(|(x, _)| x[0] + 0.5)?;
    let mut best = (f64::INFINITY, e0, 1.0);
    let search = |e_c: f64,
                  e_half: f64,
                  e_step: f64,
                  s_lo: f64,
                  s_hi: f64,
                  s_step: f64,
                  best: &mut (f64, f64, f64)| {
        let ne = (2.0 * e_half / e_step).round() as i64;
        let ns = ((s_hi - s_lo) / s_step).round() as i64;
        for i in 0..=ne {
            let e = e_c - e_half + i as f64 * e_step;
            for j in 0..=ns {
                let s = s_lo + j as f64 * s_step;
                let r = rss(xs, vs, e, s);
                if r < best.0 {
                    *best = (r, e, s);
                }
            }
        }
    };
    search(e0, 2.0, 0.1, 0.2, 5.0, 0.1, &mut best);
    let (e1, s1) = (best.1, best.2);
    search(
        e1,
        0.1,
        0.005,
        (s1 - 0.1).max(0.05),
        s1 + 0.1,
        0.005,
        &mut best,
    );
    Some((best.1, best.2))
}

/// Result of fitting a near-vertical edge crossing `strip` row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeFit {
    /// Median Gaussian σ over rows, px.
    pub sigma_px: f64,
    /// Rows that could be fitted.
    pub rows: usize,
    /// Edge x position (absolute px) per fitted row.
    pub edge_x_px: Vec<f64>,
}

/// Fits the blurred-edge model to each row of `strip` (the strip must contain one
/// near-vertical edge with flat levels on both sides).
pub fn fit_vertical_edge(img: &GrayImage, strip: &PixelRect) -> Result<EdgeFit, MeasureError> {
    let rows = region_values(img, strip)?;
    let xs: Vec<f64> = (strip.x0..strip.x1()).map(|x| x as f64).collect();
    let fits: Vec<(f64, f64)> = rows.iter().filter_map(|vs| fit_row(&xs, vs)).collect();
    if fits.is_empty() {
        return Err(MeasureError::NoFit(*strip));
    }
    let mut sigmas: Vec<f64> = fits.iter().map(|f| f.1).collect();
    sigmas.sort_by(|a, b| a.total_cmp(b));
    Ok(EdgeFit {
        sigma_px: sigmas[sigmas.len() / 2],
        rows: fits.len(),
        edge_x_px: fits.iter().map(|f| f.0).collect(),
    })
}

#[cfg(test)]
mod tests;
