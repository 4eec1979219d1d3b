//! Structure left in the re-render residual (pure): footage − calibrated render over the marker
//! window, judged against the same statistics of a residual the fitted noise model draws
//! (the calibrated scenario rendered with its noise and codec − its clean render).
//!
//! Why: "residual RMS ≤ 1.2 × the fitted noise" passes any render once the fitted noise is
//! large enough to swallow what the render misses (on the real 4K frame a σ of 43–50 DN,
//! fitted to the disc's print lines, tape and glare, passed a uniform white disc at ratio 0.81).
//! Noise is white (or what the codec makes of it); what a render misses is not. Four statistics
//! tell them apart, each against the noise model's own value:
//!
//! - **smoothed at 2 px**: the sd of the residual convolved with a Gaussian of σ = 2 px over the
//!   residual's sd. White noise keeps √(Σw²) of it, ≈ 1/(2σ√π) = 0.141 for the kernel sampled
//!   at whole pixels ([`white_noise_retention`]); structure wider than a few pixels (texture,
//!   shading, glare, a level error) keeps nearly all. At most a third passes;
//! - **autocorrelation at 1, 2 and 3 px** (across and down): white noise has none, a codec
//!   some (the model's value says how much);
//! - **energy along the marker's edges** over that on the flat regions: a blur, an edge position
//!   or an ink spread that the render misses sits on the edges;
//! - **correlation with the render** (its level, its gradient across and down, its Laplacian):
//!   a level, a pose or a blur error follows the render's own shape.

/// Gaussian σ of the smoothing test, px.
pub const SMOOTHING_SIGMA_PX: f64 = 2.0;
/// The smoothing kernel's radius, px (3σ).
const SMOOTHING_RADIUS_PX: i64 = 6;
/// The largest share of its sd that a residual smoothed at 2 px may keep (white noise: 0.141).
pub const MAX_SMOOTHED_RETENTION: f64 = 1.0 / 3.0;
/// How far above the noise model's a residual's autocorrelation at 1–3 px may lie.
pub const MAX_EXCESS_AUTOCORRELATION: f64 = 0.2;
/// How many times the noise model's edge-over-flat energy ratio a residual may reach.
pub const MAX_EDGE_ENERGY_FACTOR: f64 = 2.0;
/// How far the residual's correlation with the render's level, gradients or Laplacian may lie
/// from the noise model's.
pub const MAX_RENDER_CORRELATION: f64 = 0.2;
/// Pixels whose render gradient is at least this share of the window's largest are edge
/// pixels; at most [`FLAT_GRADIENT_SHARE`] of it, flat.
const EDGE_GRADIENT_SHARE: f64 = 0.25;
const FLAT_GRADIENT_SHARE: f64 = 0.05;

/// A window of values (row-major), `NaN` where there is none.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    pub width: usize,
    pub height: usize,
    pub values: Vec<f64>,
}

impl Grid {
    pub fn new(width: usize, height: usize) -> Grid {
        Grid {
            width,
            height,
            values: vec![f64::NAN; width * height],
        }
    }

    /// The value at (x, y), `None` outside or where there is none.
    pub fn get(&self, x: i64, y: i64) -> Option<f64> {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return None;
        }
        let v = self.values[y as usize * self.width + x as usize];
        (!v.is_nan()).then_some(v)
    }

    pub fn set(&mut self, x: usize, y: usize, v: f64) {
        self.values[y * self.width + x] = v;
    }
}

/// The four statistics of one residual.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Structure {
    /// sd of the residual smoothed at [`SMOOTHING_SIGMA_PX`] over its own sd (same pixels).
    pub smoothed_retention: f64,
    /// Autocorrelation at 1, 2 and 3 px, mean of across and down.
    pub autocorrelation: [f64; 3],
    /// Mean squared residual on the render's edges over that on its flat regions.
    pub edge_energy_ratio: f64,
    /// Correlation with the render's level, gradient across, gradient down and Laplacian.
    pub render_correlation: [f64; 4],
    /// Pixels compared.
    pub pixels: usize,
}

/// What the render correlations are with, for messages.
pub const RENDER_TEMPLATES: [&str; 4] = [
    "level",
    "gradient across",
    "gradient down",
    "Laplacian (blur)",
];

/// The sampled, normalised Gaussian of σ = `sigma_px` over ±`radius` px, one axis.
fn kernel(sigma_px: f64, radius: i64) -> Vec<f64> {
    let w: Vec<f64> = (-radius..=radius)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma_px * sigma_px)).exp())
        .collect();
    let s: f64 = w.iter().sum();
    w.into_iter().map(|v| v / s).collect()
}

/// The share of its sd that white noise keeps when smoothed by the test's kernel: √(Σw²) over
/// the separable 2-D kernel, (Σ wₖ²) for each axis. The continuous Gaussian gives 1/(2σ√π).
pub fn white_noise_retention() -> f64 {
    let k = kernel(SMOOTHING_SIGMA_PX, SMOOTHING_RADIUS_PX);
    k.iter().map(|w| w * w).sum::<f64>()
}

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n;
    (m, var.sqrt())
}

fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let (ma, sa) = mean_sd(a);
    let (mb, sb) = mean_sd(b);
    if !(sa > 0.0 && sb > 0.0) {
        return 0.0;
    }
    let c = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - ma) * (y - mb))
        .sum::<f64>()
        / a.len().max(1) as f64;
    c / (sa * sb)
}

/// `residual` at (x, y) where it and `render` both have a value.
fn both_at(residual: &Grid, render: &Grid, x: i64, y: i64) -> Option<f64> {
    match (residual.get(x, y), render.get(x, y)) {
        (Some(r), Some(_)) => Some(r),
        _ => None,
    }
}

/// `residual`'s values, row by row, where it and `render` both have one.
fn residual_values(residual: &Grid, render: &Grid) -> Vec<f64> {
    let (w, h) = (residual.width as i64, residual.height as i64);
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .filter_map(|(x, y)| both_at(residual, render, x, y))
        .collect()
}

/// `residual` (less its mean) smoothed by the test's Gaussian, at the centres whose whole kernel
/// lies on pixels where it and `render` have values.
pub fn smoothed(residual: &Grid, render: &Grid) -> Grid {
    let (w, h) = (residual.width as i64, residual.height as i64);
    let at = |x: i64, y: i64| both_at(residual, render, x, y);
    let (mean, _) = mean_sd(&residual_values(residual, render));
    let k = kernel(SMOOTHING_SIGMA_PX, SMOOTHING_RADIUS_PX);
    let rad = SMOOTHING_RADIUS_PX;
    let mut across = Grid::new(residual.width, residual.height);
    for y in 0..h {
        for x in rad..w - rad {
            let s: Option<f64> = (-rad..=rad)
                .map(|d| at(x + d, y).map(|v| (v - mean) * k[(d + rad) as usize]))
                .sum();
            if let Some(s) = s {
                across.set(x as usize, y as usize, s);
            }
        }
    }
    let mut out = Grid::new(residual.width, residual.height);
    for y in rad..h - rad {
        for x in 0..w {
            let s: Option<f64> = (-rad..=rad)
                .map(|d| across.get(x, y + d).map(|v| v * k[(d + rad) as usize]))
                .sum();
            if let Some(s) = s {
                out.set(x as usize, y as usize, s);
            }
        }
    }
    out
}

/// The statistics of `residual` over the pixels where it and `render` have values.
pub fn structure(residual: &Grid, render: &Grid) -> Structure {
    let (w, h) = (residual.width as i64, residual.height as i64);
    let at = |x: i64, y: i64| both_at(residual, render, x, y);
    let all = residual_values(residual, render);
    let (mean, sd) = mean_sd(&all);
    let smooth = smoothed(residual, render);
    let (mut raw, mut sm) = (Vec::new(), Vec::new());
    for y in 0..h {
        for x in 0..w {
            if let (Some(s), Some(r)) = (smooth.get(x, y), at(x, y)) {
                sm.push(s);
                raw.push(r);
            }
        }
    }
    let smooth = sm;
    let smoothed_retention = if raw.len() > 1 {
        let (_, s_raw) = mean_sd(&raw);
        let (_, s_smooth) = mean_sd(&smooth);
        if s_raw > 0.0 {
            s_smooth / s_raw
        } else {
            0.0
        }
    } else {
        f64::NAN
    };
    let mut autocorrelation = [0.0; 3];
    for (lag, a) in autocorrelation.iter_mut().enumerate() {
        let l = lag as i64 + 1;
        let (mut s, mut n) = (0.0, 0usize);
        for y in 0..h {
            for x in 0..w {
                let Some(v) = at(x, y) else { continue };
                for (dx, dy) in [(l, 0), (0, l)] {
                    if let Some(u) = at(x + dx, y + dy) {
                        s += (v - mean) * (u - mean);
                        n += 1;
                    }
                }
            }
        }
        *a = if n > 0 && sd > 0.0 {
            s / n as f64 / (sd * sd)
        } else {
            0.0
        };
    }
    // The render's gradients and Laplacian where all four neighbours exist.
    let mut rows: Vec<(f64, [f64; 4], f64)> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (Some(r), Some(c)) = (at(x, y), render.get(x, y)) else {
                continue;
            };
            let (Some(e), Some(wv), Some(s), Some(n)) = (
                render.get(x + 1, y),
                render.get(x - 1, y),
                render.get(x, y + 1),
                render.get(x, y - 1),
            ) else {
                continue;
            };
            let (gx, gy) = (0.5 * (e - wv), 0.5 * (s - n));
            rows.push((r, [c, gx, gy, e + wv + s + n - 4.0 * c], gx.hypot(gy)));
        }
    }
    let res: Vec<f64> = rows.iter().map(|r| r.0).collect();
    let render_correlation = std::array::from_fn(|t| {
        let tv: Vec<f64> = rows.iter().map(|r| r.1[t]).collect();
        correlation(&res, &tv)
    });
    let g_max = rows.iter().map(|r| r.2).fold(0.0, f64::max);
    let energy = |keep: &dyn Fn(f64) -> bool| {
        let v: Vec<f64> = rows
            .iter()
            .filter(|r| keep(r.2))
            .map(|r| (r.0 - mean).powi(2))
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let edge = energy(&|g| g >= EDGE_GRADIENT_SHARE * g_max && g_max > 0.0);
    let flat = energy(&|g| g <= FLAT_GRADIENT_SHARE * g_max);
    Structure {
        smoothed_retention,
        autocorrelation,
        edge_energy_ratio: if flat > 0.0 { edge / flat } else { f64::NAN },
        render_correlation,
        pixels: all.len(),
    }
}

/// The footage's residual's statistics against the noise model's, and what is left.
#[derive(Debug, Clone, PartialEq)]
pub struct StructureCheck {
    pub footage: Structure,
    pub model: Structure,
    /// One sentence per failed test, naming what is left; empty when the residual holds no
    /// structure the noise model does not.
    pub failures: Vec<String>,
}

impl StructureCheck {
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }
}

/// The upper limits a footage's residual is held to, given the noise model's own statistics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    pub smoothed_retention: f64,
    pub edge_energy_ratio: f64,
}

/// A third of the sd for the smoothed residual (more where the codec's own residual keeps
/// more: its value plus 0.1), and [`MAX_EDGE_ENERGY_FACTOR`] × the model's edge-over-flat
/// energy (at least that many times 1).
pub fn limits(model: &Structure) -> Limits {
    Limits {
        smoothed_retention: MAX_SMOOTHED_RETENTION.max(model.smoothed_retention + 0.1),
        edge_energy_ratio: MAX_EDGE_ENERGY_FACTOR * model.edge_energy_ratio.max(1.0),
    }
}

/// Judges `footage` (footage − render) against `model` (a residual the noise model draws).
pub fn judge(footage: Structure, model: Structure) -> StructureCheck {
    let mut failures = Vec::new();
    let lim = limits(&model);
    let limit = lim.smoothed_retention;
    let r = footage.smoothed_retention;
    if r.is_nan() || r > limit {
        failures.push(format!(
            "smoothed at {SMOOTHING_SIGMA_PX} px the residual keeps {r:.2} of its sd (white \
             noise {:.2}, the noise model {:.2}, at most {limit:.2}): structure wider than a few \
             pixels that the render does not draw (texture, shading, glare, levels)",
            white_noise_retention(),
            model.smoothed_retention
        ));
    }
    let excess = (0..3)
        .map(|k| footage.autocorrelation[k] - model.autocorrelation[k])
        .fold(f64::NEG_INFINITY, f64::max);
    if excess.is_nan() || excess > MAX_EXCESS_AUTOCORRELATION {
        let show = |a: &[f64; 3]| format!("{:.2}/{:.2}/{:.2}", a[0], a[1], a[2]);
        failures.push(format!(
            "neighbouring residual pixels correlate {} at 1/2/3 px (the noise model {}, at most \
             {MAX_EXCESS_AUTOCORRELATION} above it): the residual is not noise",
            show(&footage.autocorrelation),
            show(&model.autocorrelation)
        ));
    }
    let edge_limit = lim.edge_energy_ratio;
    if footage.edge_energy_ratio.is_nan() || footage.edge_energy_ratio > edge_limit {
        failures.push(format!(
            "along the marker's edges the residual's energy is {:.1} × the flat regions' (the \
             noise model {:.1}, at most {edge_limit:.1}): the edges' blur, position or the ink's \
             spread differ",
            footage.edge_energy_ratio, model.edge_energy_ratio
        ));
    }
    // Against the model's own: noise clipped at the tone curve's ends has a mean offset that
    // follows the level (the model draws it too).
    let excess = |t: usize| (footage.render_correlation[t] - model.render_correlation[t]).abs();
    let worst = (0..4)
        .max_by(|&a, &b| excess(a).total_cmp(&excess(b)))
        .unwrap_or(0);
    if excess(worst).is_nan() || excess(worst) > MAX_RENDER_CORRELATION {
        failures.push(format!(
            "the residual follows the render's {} (correlation {:+.2}, the noise model {:+.2}, \
             at most {MAX_RENDER_CORRELATION} apart)",
            RENDER_TEMPLATES[worst],
            footage.render_correlation[worst],
            model.render_correlation[worst]
        ));
    }
    StructureCheck {
        footage,
        model,
        failures,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::effects::pixel_noise::normal_at;

    const SIZE: usize = 96;

    /// A blurred dark square (ink 50, paper 200 DN, edge σ `blur` px) of half-side 24 px in the
    /// middle of the window: a render.
    fn square(blur: f64) -> Grid {
        let mut g = Grid::new(SIZE, SIZE);
        let c = SIZE as f64 / 2.0 - 0.5;
        let inside = |t: f64| crate::numeric::dist::normal_cdf((24.0 - (t - c).abs()) / blur);
        for y in 0..SIZE {
            for x in 0..SIZE {
                g.set(x, y, 200.0 - 150.0 * inside(x as f64) * inside(y as f64));
            }
        }
        g
    }

    fn noise(key: u64, sigma: f64) -> Grid {
        let mut g = Grid::new(SIZE, SIZE);
        for y in 0..SIZE {
            for x in 0..SIZE {
                g.set(x, y, sigma * normal_at(key, x as i64, y as i64) as f64);
            }
        }
        g
    }

    fn plus(a: &Grid, b: &Grid, k: f64) -> Grid {
        let mut g = a.clone();
        for (v, w) in g.values.iter_mut().zip(&b.values) {
            *v += k * w;
        }
        g
    }

    #[test]
    fn white_noise_keeps_0_14_of_its_sd_when_smoothed_at_2_px() {
        // Σw² of the separable kernel is (Σₖ wₖ²)²; the continuous Gaussian of σ = 2 px gives
        // ∫∫ g² = 1/(4πσ²), so √ of it is 1/(2σ√π) = 0.1410; sampled at whole pixels and cut at
        // 3σ, 0.1413.
        let continuous = 1.0 / (2.0 * SMOOTHING_SIGMA_PX * std::f64::consts::PI.sqrt());
        assert!((continuous - 0.14105).abs() < 1e-5);
        assert!((white_noise_retention() - 0.14134).abs() < 1e-5);
        let render = square(1.0);
        let s = structure(&noise(3, 1.5), &render);
        assert!(
            (s.smoothed_retention - white_noise_retention()).abs() < 0.02,
            "{s:?}"
        );
        assert!(s.autocorrelation.iter().all(|a| a.abs() < 0.03), "{s:?}");
        assert!((s.edge_energy_ratio - 1.0).abs() < 0.25, "{s:?}");
        assert!(s.render_correlation.iter().all(|c| c.abs() < 0.05), "{s:?}");
    }

    #[test]
    fn a_residual_that_is_noise_passes_and_structure_fails_naming_what_is_left() {
        let render = square(1.2);
        let model = structure(&noise(1, 2.0), &render);
        assert!(judge(structure(&noise(2, 2.0), &render), model).passed());
        // Texture the render does not draw (a shading of 3 DN over ~10 px): kept by the
        // smoothing, correlated between neighbours.
        let mut shade = Grid::new(SIZE, SIZE);
        for y in 0..SIZE {
            for x in 0..SIZE {
                shade.set(
                    x,
                    y,
                    3.0 * ((x as f64) / 5.0).sin() * ((y as f64) / 7.0).cos(),
                );
            }
        }
        let c = judge(
            structure(&plus(&noise(2, 2.0), &shade, 1.0), &render),
            model,
        );
        assert!(!c.passed());
        assert!(
            c.failures.iter().any(|f| f.contains("smoothed at 2 px")),
            "{c:?}"
        );
        assert!(c.failures.iter().any(|f| f.contains("correlate")), "{c:?}");
        // A blur the render gets wrong (the footage's edges at σ 1.8 px, the render's at 1.2):
        // energy on the edges, following the render's Laplacian.
        let wrong = plus(&square(1.8), &render, -1.0);
        let c = judge(
            structure(&plus(&noise(2, 2.0), &wrong, 1.0), &render),
            model,
        );
        assert!(c.failures.iter().any(|f| f.contains("edges")), "{c:?}");
        assert!(c.failures.iter().any(|f| f.contains("Laplacian")), "{c:?}");
        // Levels the render gets wrong (the footage's ink 8 DN lighter): follows its level.
        let mut lighter = Grid::new(SIZE, SIZE);
        for (v, r) in lighter.values.iter_mut().zip(&render.values) {
            *v = 8.0 * (200.0 - r) / 150.0;
        }
        let c = judge(
            structure(&plus(&noise(2, 2.0), &lighter, 1.0), &render),
            model,
        );
        assert!(c.failures.iter().any(|f| f.contains("level")), "{c:?}");
    }

    #[test]
    fn the_codec_s_own_correlation_is_allowed_for_through_the_model() {
        // Noise correlated between neighbours in the footage and in the model alike (as JPEG
        // leaves it: here a 2×2 box, correlation ½ at 1 px) passes; the same correlation
        // against a white-noise model fails.
        let corr = |key: u64| {
            let n = noise(key, 2.0);
            let mut g = Grid::new(SIZE, SIZE);
            for y in 0..SIZE as i64 {
                for x in 0..SIZE as i64 {
                    let box2 = [(0, 0), (1, 0), (0, 1), (1, 1)]
                        .iter()
                        .map(|&(dx, dy)| n.get(x + dx, y + dy))
                        .sum::<Option<f64>>();
                    if let Some(v) = box2 {
                        g.set(x as usize, y as usize, v);
                    }
                }
            }
            g
        };
        let render = square(1.0);
        let model = structure(&corr(1), &render);
        assert!((model.autocorrelation[0] - 0.5).abs() < 0.05, "{model:?}");
        assert!(judge(structure(&corr(2), &render), model).passed());
        let white = structure(&noise(1, 2.0), &render);
        assert!(!judge(structure(&corr(2), &render), white).passed());
    }
}
