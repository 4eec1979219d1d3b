//! Rotation centre from point tracks: the seed's bisector construction, Kåsa and Taubin algebraic
//! fits, and a geometric (orthogonal-distance) Levenberg–Marquardt refinement. Every fit shares one
//! centre among all signals and gives each signal its own radius.
//!
//! Uncertainty for every method: the Jacobian of the orthogonal distances at the returned
//! solution gives cov = s² (JᵀJ)⁻¹ with s² = Σd²/(N − 2 − S) (S signals); for the algebraic fits
//! this is the first-order uncertainty of the geometric estimate evaluated at their solution.

use super::config::RotationCentreMethod;
use super::error::EstimateError;
use crate::numeric::linalg;

/// A fitted rotation centre (pixels, OpenCV convention).
#[derive(Debug, Clone, PartialEq)]
pub struct RotationCentre {
    pub centre_px: [f64; 2],
    /// One radius per signal, in the order the tracks were given.
    pub radii_px: Vec<f64>,
    /// 1-σ uncertainty of the centre (x, y).
    pub centre_sigma_px: [f64; 2],
    /// 1-σ uncertainty of each radius.
    pub radius_sigma_px: Vec<f64>,
    /// RMS orthogonal distance of all points to their circles.
    pub rms_residual_px: f64,
    pub method: RotationCentreMethod,
}

/// Fits the centre from `tracks[s]` = points of signal s over the detected frames (corners 0–3
/// then the marker centre; the seed method uses tracks 0 and 2). `min_arc_deg` rejects arcs too
/// short to constrain a centre.
pub fn fit_rotation_centre(
    tracks: &[Vec<[f64; 2]>],
    method: RotationCentreMethod,
    min_arc_deg: f64,
) -> Result<RotationCentre, EstimateError> {
    let n = tracks.iter().map(|t| t.len()).min().unwrap_or(0);
    if tracks.is_empty() || n < 3 {
        return Err(EstimateError::TooFewFrames {
            what: "rotation centre",
            got: n,
            need: 3,
        });
    }
    let centre = match method {
        RotationCentreMethod::Seed => {
            if tracks.len() < 3 {
                return Err(EstimateError::Degenerate(
                    "seed method needs corner 0 and corner 2 tracks".into(),
                ));
            }
            seed_centre(&tracks[0], &tracks[2])?
        }
        RotationCentreMethod::Kasa => kasa(tracks)?,
        RotationCentreMethod::Taubin => taubin(tracks)?,
        RotationCentreMethod::Geometric => geometric(tracks, taubin(tracks)?)?,
    };
    let span = arc_span_deg(tracks, centre);
    if span < min_arc_deg {
        return Err(EstimateError::ArcTooShort {
            span_deg: span,
            min_deg: min_arc_deg,
        });
    }
    Ok(with_uncertainty(tracks, centre, method))
}

/// The seed's construction (gurrajo/Geneva `find_center`): with n detected frames, frames
/// i₁ = ⌊n/2⌋ and i₂ = ⌊3n/4⌋; the perpendicular bisector of corner 0 between them (eq. 3.1,
/// sampled at x = 0 and x = 100) and that of corner 2, intersected by the cross product in
/// homogeneous coordinates, each coordinate truncated towards zero (Python `int`).
pub fn seed_centre(corner0: &[[f64; 2]], corner2: &[[f64; 2]]) -> Result<[f64; 2], EstimateError> {
    let n = corner0.len().min(corner2.len());
    if n < 3 {
        return Err(EstimateError::TooFewFrames {
            what: "seed rotation centre",
            got: n,
            need: 3,
        });
    }
    let i1 = n / 2;
    let i2 = (3 * n) / 4;
    let line = |p: [f64; 2], q: [f64; 2]| -> Result<[f64; 3], EstimateError> {
        let (x1, y1, x2, y2) = (p[0], p[1], q[0], q[1]);
        if y2 == y1 {
            return Err(EstimateError::Degenerate(format!(
                "seed bisector undefined: equal y ({y1}) in frames {i1} and {i2} (eq. 3.1 divides by y2 - y1)"
            )));
        }
        let f = |x: f64| {
            (y1 + y2) / 2.0 + (x2 - x1) / (y2 - y1) * (x1 + x2) / 2.0 - (x2 - x1) / (y2 - y1) * x
        };
        Ok(cross([0.0, f(0.0), 1.0], [100.0, f(100.0), 1.0]))
    };
    let l1 = line(corner0[i1], corner0[i2])?;
    let l2 = line(corner2[i1], corner2[i2])?;
    let [x, y, z] = cross(l1, l2);
    if z == 0.0 || !(x / z).is_finite() || !(y / z).is_finite() {
        return Err(EstimateError::Degenerate(
            "seed bisectors are parallel".into(),
        ));
    }
    Ok([(x / z).trunc(), (y / z).trunc()])
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Centroid and scale of all points, so the algebraic fits work on O(1) numbers.
fn normalisation(tracks: &[Vec<[f64; 2]>]) -> ([f64; 2], f64) {
    let all: Vec<[f64; 2]> = tracks.iter().flatten().copied().collect();
    let n = all.len() as f64;
    let mx = all.iter().map(|p| p[0]).sum::<f64>() / n;
    let my = all.iter().map(|p| p[1]).sum::<f64>() / n;
    let s = (all
        .iter()
        .map(|p| (p[0] - mx).powi(2) + (p[1] - my).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    ([mx, my], if s > 0.0 { s } else { 1.0 })
}

/// Per-signal-centred moments of (z, x, y), z = x² + y², in normalised coordinates.
/// Eliminating each signal's constant term (its radius) centres that signal's columns.
fn centred_moments(tracks: &[Vec<[f64; 2]>], m: [f64; 2], s: f64) -> ([[f64; 3]; 3], f64) {
    let mut mom = [[0.0; 3]; 3];
    let mut z_sum = 0.0;
    let mut count = 0.0;
    for tr in tracks {
        let pts: Vec<[f64; 3]> = tr
            .iter()
            .map(|p| {
                let x = (p[0] - m[0]) / s;
                let y = (p[1] - m[1]) / s;
                [x * x + y * y, x, y]
            })
            .collect();
        let k = pts.len() as f64;
        let mean: [f64; 3] = [0, 1, 2].map(|c| pts.iter().map(|p| p[c]).sum::<f64>() / k);
        for p in &pts {
            let d = [p[0] - mean[0], p[1] - mean[1], p[2] - mean[2]];
            for a in 0..3 {
                for b in 0..3 {
                    mom[a][b] += d[a] * d[b];
                }
            }
            z_sum += p[0];
            count += 1.0;
        }
    }
    (mom, z_sum / count)
}

/// Kåsa: minimise Σ(z + D x + E y + F_s)²; centre = (−D/2, −E/2).
pub fn kasa(tracks: &[Vec<[f64; 2]>]) -> Result<[f64; 2], EstimateError> {
    let (m, s) = normalisation(tracks);
    let (mom, _) = centred_moments(tracks, m, s);
    let a = vec![vec![mom[1][1], mom[1][2]], vec![mom[2][1], mom[2][2]]];
    let b = vec![-mom[1][0], -mom[2][0]];
    let de = linalg::solve_rows(&a, &b).ok_or_else(|| {
        EstimateError::Degenerate(
            "points are collinear or coincident (Kasa system singular)".into(),
        )
    })?;
    let c = [m[0] - de[0] / 2.0 * s, m[1] - de[1] / 2.0 * s];
    finite_centre(c)
}

/// Taubin: minimise Σ(A z + B x + C y + D_s)² subject to mean |∇|² = 4A² z̄ + B² + C² = 1 (data
/// centred globally), i.e. the smallest generalised eigenvector of (M, diag(4 z̄, 1, 1)).
pub fn taubin(tracks: &[Vec<[f64; 2]>]) -> Result<[f64; 2], EstimateError> {
    let (m, s) = normalisation(tracks);
    let (mom, z_mean) = centred_moments(tracks, m, s);
    let nd = [(4.0 * z_mean).sqrt(), 1.0, 1.0];
    let sym = nalgebra::DMatrix::from_fn(3, 3, |a, b| mom[a][b] / (nd[a] * nd[b]));
    let (w, v) = linalg::sym_eigen(&sym);
    let k = (0..3).min_by(|&i, &j| w[i].total_cmp(&w[j])).unwrap_or(0);
    let coef = [v[(0, k)] / nd[0], v[(1, k)] / nd[1], v[(2, k)] / nd[2]];
    let scale = coef.iter().fold(0.0_f64, |a, c| a.max(c.abs()));
    if coef[0].abs() <= 1e-12 * scale {
        return Err(EstimateError::Degenerate(
            "points are collinear (Taubin fit is a line)".into(),
        ));
    }
    let c = [
        m[0] - coef[1] / (2.0 * coef[0]) * s,
        m[1] - coef[2] / (2.0 * coef[0]) * s,
    ];
    finite_centre(c)
}

fn finite_centre(c: [f64; 2]) -> Result<[f64; 2], EstimateError> {
    if c[0].is_finite() && c[1].is_finite() {
        Ok(c)
    } else {
        Err(EstimateError::Degenerate(
            "centre is not finite (collinear points)".into(),
        ))
    }
}

fn mean_radius(track: &[[f64; 2]], c: [f64; 2]) -> f64 {
    track
        .iter()
        .map(|p| (p[0] - c[0]).hypot(p[1] - c[1]))
        .sum::<f64>()
        / track.len() as f64
}

fn sum_sq(tracks: &[Vec<[f64; 2]>], c: [f64; 2]) -> f64 {
    tracks
        .iter()
        .map(|tr| {
            let r = mean_radius(tr, c);
            tr.iter()
                .map(|p| ((p[0] - c[0]).hypot(p[1] - c[1]) - r).powi(2))
                .sum::<f64>()
        })
        .sum()
}

/// Normal matrix JᵀJ of the orthogonal distances for parameters (cx, cy, r_0..r_S), and Jᵀd.
fn normal_equations(
    tracks: &[Vec<[f64; 2]>],
    c: [f64; 2],
    radii: &[f64],
) -> (Vec<Vec<f64>>, Vec<f64>, f64) {
    let np = 2 + tracks.len();
    let mut jtj = vec![vec![0.0; np]; np];
    let mut jtd = vec![0.0; np];
    let mut ssr = 0.0;
    for (s, tr) in tracks.iter().enumerate() {
        for p in tr {
            let dx = p[0] - c[0];
            let dy = p[1] - c[1];
            let dist = dx.hypot(dy).max(1e-12);
            let d = dist - radii[s];
            let mut row = vec![0.0; np];
            row[0] = -dx / dist;
            row[1] = -dy / dist;
            row[2 + s] = -1.0;
            for a in 0..np {
                jtd[a] += row[a] * d;
                for b in 0..np {
                    jtj[a][b] += row[a] * row[b];
                }
            }
            ssr += d * d;
        }
    }
    (jtj, jtd, ssr)
}

/// Levenberg–Marquardt on orthogonal distances from `start`.
pub fn geometric(tracks: &[Vec<[f64; 2]>], start: [f64; 2]) -> Result<[f64; 2], EstimateError> {
    let mut c = start;
    let mut radii: Vec<f64> = tracks.iter().map(|t| mean_radius(t, c)).collect();
    let mut lambda = 1e-3;
    let mut ssr = normal_equations(tracks, c, &radii).2;
    for _ in 0..100 {
        let (jtj, jtd, _) = normal_equations(tracks, c, &radii);
        let mut damped = jtj.clone();
        for (i, row) in damped.iter_mut().enumerate() {
            row[i] += lambda * jtj[i][i].max(1e-12);
        }
        let neg: Vec<f64> = jtd.iter().map(|v| -v).collect();
        let Some(step) = linalg::solve_rows(&damped, &neg) else {
            lambda *= 10.0;
            continue;
        };
        let c_new = [c[0] + step[0], c[1] + step[1]];
        let r_new: Vec<f64> = radii.iter().zip(&step[2..]).map(|(r, d)| r + d).collect();
        let ssr_new = normal_equations(tracks, c_new, &r_new).2;
        if ssr_new.is_finite() && ssr_new <= ssr {
            let converged = step[0].hypot(step[1]) < 1e-10 * (1.0 + c[0].hypot(c[1]));
            c = c_new;
            radii = r_new;
            let improvement = ssr - ssr_new;
            ssr = ssr_new;
            lambda = (lambda / 10.0).max(1e-12);
            if converged || improvement <= 1e-15 * ssr.max(1e-300) {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e12 {
                break;
            }
        }
    }
    finite_centre(c)
}

/// Angular span (degrees) of the points about `c`, over all signals: 360° minus the largest gap.
pub fn arc_span_deg(tracks: &[Vec<[f64; 2]>], c: [f64; 2]) -> f64 {
    tracks
        .iter()
        .map(|tr| {
            let mut a: Vec<f64> = tr
                .iter()
                .map(|p| (p[1] - c[1]).atan2(p[0] - c[0]))
                .collect();
            a.sort_by(f64::total_cmp);
            let mut gap = a[0] + std::f64::consts::TAU - a[a.len() - 1];
            for w in a.windows(2) {
                gap = gap.max(w[1] - w[0]);
            }
            (std::f64::consts::TAU - gap).to_degrees()
        })
        .fold(0.0, f64::max)
}

fn with_uncertainty(
    tracks: &[Vec<[f64; 2]>],
    c: [f64; 2],
    method: RotationCentreMethod,
) -> RotationCentre {
    let radii: Vec<f64> = tracks.iter().map(|t| mean_radius(t, c)).collect();
    let (jtj, _, ssr) = normal_equations(tracks, c, &radii);
    let n_pts: usize = tracks.iter().map(|t| t.len()).sum();
    let dof = n_pts.saturating_sub(2 + tracks.len()).max(1) as f64;
    let s2 = ssr / dof;
    let cov = linalg::invert_rows(&jtj).map(|inv| match frame_clustered_meat(tracks, c, &radii) {
        Some((meat, scale)) => sandwich(&inv, &meat, scale),
        None => inv
            .iter()
            .map(|row| row.iter().map(|v| s2 * v).collect())
            .collect(),
    });
    let sd = |i: usize| {
        cov.as_ref()
            .map_or(f64::INFINITY, |m| m[i][i].max(0.0).sqrt())
    };
    RotationCentre {
        centre_px: c,
        centre_sigma_px: [sd(0), sd(1)],
        radius_sigma_px: (0..tracks.len()).map(|s| sd(2 + s)).collect(),
        radii_px: radii,
        rms_residual_px: (sum_sq(tracks, c) / n_pts as f64).sqrt(),
        method,
    }
}

/// The "meat" Σ_k g_k g_kᵀ of a covariance clustered by frame, with g_k the gradient of frame k's
/// orthogonal distances over every track, and the small-sample factor G/(G−1)·(N−1)/(N−K). The
/// points of one frame are not independent: the marker centre is made of the corners (the
/// pipeline's fifth track is their mean), so the usual s²·(JᵀJ)⁻¹ counts it as new data and
/// reported a centre σ 9.5 % too small. Clustering by frame counts each frame once, whatever
/// its tracks share. `None` when the tracks are not frame-aligned (different lengths) or are one
/// track (nothing to share).
fn frame_clustered_meat(
    tracks: &[Vec<[f64; 2]>],
    c: [f64; 2],
    radii: &[f64],
) -> Option<(Vec<Vec<f64>>, f64)> {
    let frames = tracks.first()?.len();
    if tracks.len() < 2 || tracks.iter().any(|t| t.len() != frames) {
        return None;
    }
    let np = 2 + tracks.len();
    let points = frames * tracks.len();
    if frames < 2 || points <= np {
        return None;
    }
    let mut meat = vec![vec![0.0; np]; np];
    for k in 0..frames {
        let mut g = vec![0.0; np];
        for (s, tr) in tracks.iter().enumerate() {
            let (dx, dy) = (tr[k][0] - c[0], tr[k][1] - c[1]);
            let dist = dx.hypot(dy).max(1e-12);
            let d = dist - radii[s];
            g[0] -= dx / dist * d;
            g[1] -= dy / dist * d;
            g[2 + s] -= d;
        }
        for a in 0..np {
            for b in 0..np {
                meat[a][b] += g[a] * g[b];
            }
        }
    }
    let (g, n, p) = (frames as f64, points as f64, np as f64);
    Some((meat, g / (g - 1.0) * (n - 1.0) / (n - p)))
}

/// `scale`·A⁻¹·M·A⁻¹ for a symmetric `inv` = A⁻¹.
fn sandwich(inv: &[Vec<f64>], meat: &[Vec<f64>], scale: f64) -> Vec<Vec<f64>> {
    let n = inv.len();
    let mut left = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..n {
            left[i][j] = (0..n).map(|k| inv[i][k] * meat[k][j]).sum();
        }
    }
    (0..n)
        .map(|i| {
            (0..n)
                .map(|j| scale * (0..n).map(|k| left[i][k] * inv[k][j]).sum::<f64>())
                .collect()
        })
        .collect()
}
