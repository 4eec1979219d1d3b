//! Where the marker is and how the camera sees it: image scale, perspective tilt, rotation
//! centre, marker radius, orientation on the disc and the marker's angle in every pose.
//!
//! A pose fit with the project's own camera and scene model: the corners of every pose (the
//! edge-fitted ones when enough frames have them, else OpenCV's with a free inset for their
//! half-pixel offset) are predicted by `camera::Camera` for a marker placed like
//! `scene::PlacedMarker` at radius R and angle φ_k about the rotation centre, and the image
//! scale, tilt (x, y), rotation centre (px), R, orientation and every φ_k are fitted together by
//! least squares. The focal length follows from the scale and the base's camera distance
//! (f = 1000·distance_m / mm_per_px), which is all the perspective needs.

use super::{CalibrateError, Fitted, FootageStats};
use crate::camera::{Camera, CameraConfig, FocalConfig};
use crate::estimate::circle_fit::fit_rotation_centre;
use crate::estimate::lm;
use crate::estimate::RotationCentreMethod;
use crate::imagestats::square_fit;
use crate::numeric::angle::{unwrap_in_place, wrap_pi};
use crate::numeric::dist::t975;
use crate::scenario::Scenario;
use crate::scene::PlacedMarker;
use glam::DVec2;

/// Perspective tilt from the pose fit.
#[derive(Debug, Clone, PartialEq)]
pub struct TiltFit {
    /// Camera tilt about its x and y axes (`camera.perspective_tilt`), degrees.
    pub tilt_x_deg: Fitted,
    pub tilt_y_deg: Fitted,
    /// Either component exceeds its 95 % uncertainty: the tilt is enabled.
    pub significant: bool,
    /// The tilt was fitted at all (it needs at least 8 poses; never in single-frame mode):
    /// otherwise the base's tilt is kept and the values above mean nothing.
    pub fitted: bool,
    /// √(λmin/λmax) of the marker's mean image-space metric (1 = square), for the report.
    pub aspect: f64,
}

/// The geometry of the rig.
#[derive(Debug, Clone, PartialEq)]
pub struct GeometryFit {
    /// Marker side in px (similarity fit, mean over the poses), for the report.
    pub side_px: f64,
    /// Poses fitted, and whether their corners came from edge fits.
    pub poses: usize,
    pub from_edges: bool,
    /// Image scale at the (untilted) disc plane, mm/px.
    pub mm_per_px: Fitted,
    /// Rotation centre in the image, px (`None` in single-frame mode: the base's is kept).
    pub centre_px: Option<[Fitted; 2]>,
    /// The centre the poses are placed about (fitted or the base's).
    pub centre_used_px: [f64; 2],
    pub radius_mm: Fitted,
    /// Printed right axis relative to the radial direction, degrees.
    pub orientation_deg: Fitted,
    /// Angle of the marker about the rotation centre in the first pose, degrees from +x
    /// towards +y (in the disc plane).
    pub angle_first_deg: Fitted,
    /// Arc covered by the poses, degrees.
    pub arc_deg: f64,
    /// RMS corner residual of the pose fit, px.
    pub rms_residual_px: f64,
    /// OpenCV's corner inset fitted when their corners were used, px.
    pub inset_px: Option<f64>,
    /// Marker angle per pose (t_s, unwrapped rad) in the disc plane, from the fit.
    pub track: Vec<(f64, f64)>,
    /// The marker-centre angle on every detected frame from OpenCV's corners about the fitted
    /// centre (dense; for the angle noise and the count of moving frames).
    pub raw_track: Vec<(f64, f64)>,
    pub tilt: TiltFit,
    /// The camera distance the perspective was computed with, m (the base's).
    pub distance_m: f64,
}

type Corners = [[f64; 2]; 4];

/// Groups of consecutive poses left out in turn for the tilt's jackknife interval.
const JACKKNIFE_GROUPS: usize = 8;

/// Corner error the pose fit assumes at least, px: edge-fitted corners agree with the renderer
/// to a few hundredths of a pixel, an error that does not average out over poses.
const CORNER_FLOOR_PX: f64 = 0.03;

fn centre_of(c: &Corners) -> [f64; 2] {
    [
        c.iter().map(|p| p[0]).sum::<f64>() / 4.0,
        c.iter().map(|p| p[1]).sum::<f64>() / 4.0,
    ]
}

/// Merges consecutive poses whose centre moved less than 0.3 px (repeated poses would count as
/// independent evidence); keeps the first time.
fn merge_static(poses: &[(f64, Corners)]) -> Vec<(f64, Corners)> {
    let mut out: Vec<(f64, Corners, usize)> = Vec::new();
    for (t, c) in poses {
        let m = centre_of(c);
        if let Some((_, acc, n)) = out.last_mut() {
            let a = centre_of(&acc.map(|p| [p[0] / *n as f64, p[1] / *n as f64]));
            if (a[0] - m[0]).hypot(a[1] - m[1]) < 0.3 {
                for k in 0..4 {
                    acc[k][0] += c[k][0];
                    acc[k][1] += c[k][1];
                }
                *n += 1;
                continue;
            }
        }
        out.push((*t, *c, 1));
    }
    out.into_iter()
        .map(|(t, acc, n)| (t, acc.map(|p| [p[0] / n as f64, p[1] / n as f64])))
        .collect()
}

/// The pose model: parameter layout and corner prediction.
struct PoseModel<'a> {
    base: &'a Scenario,
    width: u32,
    height: u32,
    poses: &'a [(f64, Corners)],
    /// Fit the tilt (else it is 0).
    tilt: bool,
    /// Fit the centre (else the base's).
    centre: Option<[f64; 2]>,
    /// OpenCV corners: fit their inset.
    inset: bool,
}

impl PoseModel<'_> {
    /// Global parameters before the per-pose angles.
    fn globals(&self) -> usize {
        self.shape().globals
    }

    /// Which globals the parameter vector holds.
    fn shape(&self) -> PoseModelShape {
        PoseModelShape {
            globals: 3
                + if self.tilt { 2 } else { 0 }
                + if self.centre.is_none() { 2 } else { 0 }
                + usize::from(self.inset),
            tilt: self.tilt,
            centre: self.centre.is_none(),
            inset: self.inset,
        }
    }

    /// (scale, tx, ty, cx, cy, R_mm, orientation, inset) from a parameter vector, the centre
    /// the given one when it is not fitted.
    fn unpack(&self, p: &[f64]) -> [f64; 8] {
        let mut g = self.shape().values(p);
        if let Some(c) = self.centre {
            (g[3], g[4]) = (c[0], c[1]);
        }
        g
    }

    fn camera(&self, g: &[f64; 8]) -> Option<Camera> {
        let mut cfg: CameraConfig = self.base.camera.clone();
        cfg.width_px = self.width;
        cfg.height_px = self.height;
        cfg.focal = FocalConfig::ImageScale { mm_per_px: g[0] };
        cfg.rotation_centre_px = Some([g[3], g[4]]);
        cfg.perspective_tilt.enabled = self.tilt;
        cfg.perspective_tilt.tilt_x_deg = g[1];
        cfg.perspective_tilt.tilt_y_deg = g[2];
        Camera::new(&cfg).ok()
    }

    fn residuals(&self, p: &[f64], out: &mut Vec<f64>) -> bool {
        let g = self.unpack(p);
        if !(g[0] > 0.0 && g[5] >= 0.0 && g[1].abs() < 60.0 && g[2].abs() < 60.0) {
            return false;
        }
        let Some(cam) = self.camera(&g) else {
            return false;
        };
        let m = &self.base.scene.marker;
        let off = self.globals();
        out.clear();
        for (k, (_, obs)) in self.poses.iter().enumerate() {
            let phi = p[off + k];
            let placed = PlacedMarker::new(
                DVec2::new(phi.cos(), phi.sin()) * (g[5] * 1e-3),
                phi + g[6],
                m.size_mm * 1e-3,
                m.white_margin_mm * 1e-3,
            );
            let mut pred = [[0.0; 2]; 4];
            for (q, w) in pred.iter_mut().zip(placed.corners_m()) {
                let Some(v) = cam.try_project(w) else {
                    return false;
                };
                *q = [v.x, v.y];
            }
            if self.inset {
                let c = centre_of(&pred);
                for q in pred.iter_mut() {
                    let (dx, dy) = (q[0] - c[0], q[1] - c[1]);
                    let l = dx.hypot(dy).max(1e-9);
                    q[0] -= g[7] * dx / l;
                    q[1] -= g[7] * dy / l;
                }
            }
            for (q, o) in pred.iter().zip(obs) {
                out.push(q[0] - o[0]);
                out.push(q[1] - o[1]);
            }
        }
        true
    }
}

/// The geometry fit.
pub fn fit_geometry(
    base: &Scenario,
    stats: &FootageStats,
    single_frame: bool,
    notes: &mut Vec<String>,
) -> Result<GeometryFit, CalibrateError> {
    let detected: Vec<(f64, Corners)> = stats
        .frames
        .iter()
        .filter_map(|f| f.corners_px.map(|c| (f.t_s, c)))
        .collect();
    let refined: Vec<(f64, Corners)> = stats
        .frames
        .iter()
        .filter_map(|f| f.refined_px.map(|c| (f.t_s, c)))
        .collect();
    // Edge-fitted corners are exact to a few hundredths of a pixel where OpenCV's are quantised
    // to the contour: the poses come from them when enough were fitted.
    let from_edges = refined.len() >= 12 || (single_frame && !refined.is_empty());
    let mut poses = merge_static(if from_edges { &refined } else { &detected });
    if poses.len() > 150 {
        let n = poses.len();
        poses = (0..150).map(|k| poses[k * n / 150]).collect();
    }
    if !from_edges {
        notes.push(
            "too few frames had all four marker sides fitted: the poses use OpenCV's corners with \
             a fitted inset, with wider uncertainties"
                .into(),
        );
    }
    if single_frame {
        poses.truncate(1);
    }
    let size_mm = base.scene.marker.size_mm;
    let sides: Vec<f64> = poses
        .iter()
        .filter_map(|p| square_fit(&p.1).ok().map(|s| s.side_px))
        .collect();
    if sides.is_empty() {
        return Err(CalibrateError::Unresolved {
            what: "image scale".into(),
            reason: "no usable marker shape".into(),
        });
    }
    let side_px =
        sides.iter().sum::<f64>() / sides.len() as f64 + if from_edges { 0.0 } else { 1.0 };
    let scale0 = size_mm / side_px;
    let base_centre = base
        .camera
        .rotation_centre_px
        .unwrap_or_else(|| base.camera.image_centre_px());
    let centre0 = if single_frame {
        base_centre
    } else {
        if poses.len() < 3 {
            return Err(CalibrateError::Unresolved {
                what: "rotation centre".into(),
                reason: format!(
                    "the marker takes only {} distinct position(s) in the footage; it must turn \
                     (pass --single-frame to calibrate the image formation only)",
                    poses.len()
                ),
            });
        }
        let tracks: Vec<Vec<[f64; 2]>> = (0..4)
            .map(|k| poses.iter().map(|p| p.1[k]).collect())
            .collect();
        fit_rotation_centre(&tracks, RotationCentreMethod::Geometric, 5.0)
            .map_err(|e| CalibrateError::Unresolved {
                what: "rotation centre".into(),
                reason: e.to_string(),
            })?
            .centre_px
    };
    let mut phis: Vec<f64> = poses
        .iter()
        .map(|p| {
            let m = centre_of(&p.1);
            (m[1] - centre0[1]).atan2(m[0] - centre0[0])
        })
        .collect();
    unwrap_in_place(&mut phis);
    let r0 = poses
        .iter()
        .map(|p| {
            let m = centre_of(&p.1);
            (m[0] - centre0[0]).hypot(m[1] - centre0[1])
        })
        .sum::<f64>()
        / poses.len() as f64
        * scale0;
    let (so, co) = poses
        .iter()
        .zip(&phis)
        .filter_map(|(p, phi)| square_fit(&p.1).ok().map(|s| wrap_pi(s.angle_rad - phi)))
        .fold((0.0, 0.0), |a, o| (a.0 + o.sin(), a.1 + o.cos()));
    let o0 = so.atan2(co);
    let (w, h) = (stats.width_px as u32, stats.height_px as u32);
    let run = |tilt: bool,
               start: &[f64],
               poses: &[(f64, Corners)]|
     -> Option<(lm::LmFit, PoseModelShape)> {
        let model = PoseModel {
            base,
            width: w,
            height: h,
            poses,
            tilt,
            centre: single_frame.then_some(base_centre),
            inset: !from_edges,
        };
        let mut p = Vec::new();
        let mut steps = Vec::new();
        p.push(start[0]);
        steps.push(1e-7 * start[0]);
        if tilt {
            p.extend([start[1], start[2]]);
            steps.extend([1e-4, 1e-4]);
        }
        if !single_frame {
            p.extend([start[3], start[4]]);
            steps.extend([1e-4, 1e-4]);
        }
        p.extend([start[5], start[6]]);
        steps.extend([1e-5, 1e-7]);
        if !from_edges {
            p.push(start[7]);
            steps.push(1e-4);
        }
        p.extend_from_slice(&start[8..]);
        steps.extend(std::iter::repeat_n(1e-7, poses.len()));
        let f = |q: &[f64], out: &mut Vec<f64>| model.residuals(q, out);
        let fit = lm::minimise(&f, &p, &steps, 60)?;
        Some((fit, model.shape()))
    };
    let mut start = vec![scale0, 0.0, 0.0, centre0[0], centre0[1], r0, o0, 0.5];
    start.extend_from_slice(&phis);
    let no_fit = || CalibrateError::Unresolved {
        what: "marker poses".into(),
        reason: "the camera model could not be fitted to the marker corners".into(),
    };
    // Tilt is fitted when the poses can tell it (several, spread over the image).
    let try_tilt = !single_frame && poses.len() >= 8;
    let (mut fit, mut shape) = run(false, &start, &poses).ok_or_else(no_fit)?;
    let mut tilt_fit = TiltFit {
        tilt_x_deg: Fitted::new(0.0, 0.0),
        tilt_y_deg: Fitted::new(0.0, 0.0),
        significant: false,
        fitted: false,
        aspect: mean_aspect(&poses),
    };
    if try_tilt {
        let v = shape.values(&fit.params);
        let mut s2 = vec![v[0], 0.0, 0.0, v[3], v[4], v[5], v[6], v[7]];
        s2.extend_from_slice(&fit.params[shape.globals..]);
        if let Some((tf, tshape)) = run(true, &s2, &poses) {
            let se = tf.std_errors_with_floor(CORNER_FLOOR_PX);
            let (tx, ty) = (tf.params[1], tf.params[2]);
            // The Jacobian's errors assume independent corner errors; the corners of nearby
            // poses share errors (edge-fit biases that follow the marker's angle on the pixel
            // grid), so the interval comes from the scatter of the tilt over the poses: a
            // delete-a-group jackknife with a Student t quantile, never narrower than the
            // Jacobian's.
            let v = tshape.values(&tf.params);
            let phis = &tf.params[tshape.globals..];
            let groups = JACKKNIFE_GROUPS.min(poses.len() / 4);
            let mut reps: Vec<[f64; 2]> = Vec::new();
            for g in 0..groups {
                let (lo, hi) = (g * poses.len() / groups, (g + 1) * poses.len() / groups);
                let kept: Vec<(f64, Corners)> =
                    poses[..lo].iter().chain(&poses[hi..]).copied().collect();
                let mut st = v.to_vec();
                st.extend(phis[..lo].iter().chain(&phis[hi..]));
                if let Some((jf, _)) = run(true, &st, &kept) {
                    reps.push([jf.params[1], jf.params[2]]);
                }
            }
            let jack = |i: usize| -> Option<(f64, f64)> {
                let g = reps.len();
                if g < 3 || g < groups {
                    return None;
                }
                let mean = reps.iter().map(|r| r[i]).sum::<f64>() / g as f64;
                let var = reps.iter().map(|r| (r[i] - mean).powi(2)).sum::<f64>() * (g - 1) as f64
                    / g as f64;
                Some((var.sqrt(), t975(g - 1)))
            };
            let u = |i: usize| match jack(i - 1) {
                Some((sj, t)) => Fitted::new(tf.params[i], t * sj.max(se[i]).hypot(0.02)),
                None => Fitted::from_sigma(tf.params[i], se[i], 0.02),
            };
            tilt_fit.tilt_x_deg = u(1);
            tilt_fit.tilt_y_deg = u(2);
            tilt_fit.fitted = true;
            // Jointly beyond the 99 % χ² bound of two parameters (a 95 % test per component
            // would switch the tilt on by chance in one case of ten), on the reported intervals
            // (jackknife over poses), not only on the Jacobian's errors: a marker track that is
            // no rigid circle (axis runout, a wobbling disc) makes a tilt that the Jacobian
            // calls significant and the poses do not agree on (0.51° ± 0.63° on footage with
            // 2 mm of runout), and a nominal with that tilt on hides the runout from `diagnose`.
            let chi2 =
                |sx: f64, sy: f64| (tx / sx.max(1e-12)).powi(2) + (ty / sy.max(1e-12)).powi(2);
            let sigma_of = |f: &Fitted| f.u95 / 1.96;
            tilt_fit.significant = chi2(se[1], se[2]) > 9.21
                && chi2(
                    sigma_of(&tilt_fit.tilt_x_deg),
                    sigma_of(&tilt_fit.tilt_y_deg),
                ) > 9.21;
            if tilt_fit.significant {
                fit = tf;
                shape = tshape;
            }
        }
    }
    let se = fit.std_errors_with_floor(CORNER_FLOOR_PX);
    let v = shape.values(&fit.params);
    let sv = shape.values(&se);
    let n_pts = fit.residuals.len() as f64;
    let rms = (fit.cost / n_pts).sqrt();
    let mm_per_px = Fitted::from_sigma(v[0], sv[0], v[0] * 0.05 / side_px);
    let centre_px = (!single_frame).then(|| {
        [
            Fitted::from_sigma(v[3], sv[3], 0.02),
            Fitted::from_sigma(v[4], sv[4], 0.02),
        ]
    });
    // The radius in mm carries the scale's uncertainty (its floor is not in the fit).
    let radius_mm = Fitted::from_sigma(v[5], sv[5], 0.5 * v[5] * mm_per_px.u95 / v[0]);
    let corner_floor = if from_edges { 0.03 } else { 0.3 } / side_px;
    let orientation_deg = Fitted::from_sigma(
        wrap_pi(v[6]).to_degrees(),
        sv[6].to_degrees(),
        corner_floor.to_degrees(),
    );
    let angles = &fit.params[shape.globals..];
    let angle_first_deg = Fitted::from_sigma(
        wrap_pi(angles[0]).to_degrees(),
        se[shape.globals].to_degrees(),
        (CORNER_FLOOR_PX / (v[5] / v[0]).max(1.0)).to_degrees(),
    );
    let track: Vec<(f64, f64)> = poses
        .iter()
        .map(|p| p.0)
        .zip(angles.iter().copied())
        .collect();
    let (lo, hi) = angles
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, x| {
            (a.0.min(*x), a.1.max(*x))
        });
    let centre_used = if single_frame {
        base_centre
    } else {
        [v[3], v[4]]
    };
    let mut raw: Vec<f64> = detected
        .iter()
        .map(|d| {
            let m = centre_of(&d.1);
            (m[1] - centre_used[1]).atan2(m[0] - centre_used[0])
        })
        .collect();
    unwrap_in_place(&mut raw);
    let raw_track = detected.iter().map(|d| d.0).zip(raw).collect();
    Ok(GeometryFit {
        side_px,
        poses: poses.len(),
        from_edges,
        mm_per_px,
        centre_px,
        centre_used_px: centre_used,
        radius_mm,
        orientation_deg,
        angle_first_deg,
        arc_deg: if single_frame {
            0.0
        } else {
            (hi - lo).to_degrees().min(360.0)
        },
        rms_residual_px: rms,
        inset_px: shape.inset.then_some(v[7]),
        track,
        raw_track,
        tilt: tilt_fit,
        distance_m: base.camera.distance_m,
    })
}

/// Which globals a fitted parameter vector holds.
struct PoseModelShape {
    globals: usize,
    tilt: bool,
    centre: bool,
    inset: bool,
}

impl PoseModelShape {
    /// (scale, tx, ty, cx, cy, R, o, inset) of a parameter (or standard-error) vector; absent
    /// ones are 0 (the centre then comes from the caller).
    fn values(&self, p: &[f64]) -> [f64; 8] {
        let mut i = 0;
        let mut next = || {
            i += 1;
            p[i - 1]
        };
        let scale = next();
        let (tx, ty) = if self.tilt {
            (next(), next())
        } else {
            (0.0, 0.0)
        };
        let (cx, cy) = if self.centre {
            (next(), next())
        } else {
            (0.0, 0.0)
        };
        let r = next();
        let o = next();
        let inset = if self.inset { next() } else { 0.0 };
        [scale, tx, ty, cx, cy, r, o, inset]
    }
}

/// √(λmin/λmax) of the mean normalised metric A·Aᵀ of the marker shapes.
fn mean_aspect(poses: &[(f64, Corners)]) -> f64 {
    let fits: Vec<_> = poses.iter().filter_map(|p| square_fit(&p.1).ok()).collect();
    if fits.is_empty() {
        return 1.0;
    }
    let (mut p, mut q) = (0.0, 0.0);
    for f in &fits {
        let a = f.affine;
        let m00 = a[0][0] * a[0][0] + a[0][1] * a[0][1];
        let m01 = a[0][0] * a[1][0] + a[0][1] * a[1][1];
        let m11 = a[1][0] * a[1][0] + a[1][1] * a[1][1];
        let h = 0.5 * (m00 + m11);
        p += (m00 - m11) / (2.0 * h);
        q += m01 / h;
    }
    let e = (p.hypot(q) / fits.len() as f64).min(0.999);
    ((1.0 - e) / (1.0 + e)).sqrt()
}
