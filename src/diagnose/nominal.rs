//! The aligned nominal: the user's nominal scenario with the nuisance fitted to the real
//! measurement (crank phase and speed, marker angle and orientation on the disc, image scale,
//! marker radius, rotation-centre and reference-marker image positions), simulated at the real
//! frame times. Also the aligned motion that every residual channel is measured against.

use super::simulator::{SimulateError, Simulator};
use crate::camera::{Camera, FocalConfig};
use crate::diagnose::align::{align_motion, apply_motion, MotionAlignment};
use crate::diagnose::camera_warp::{screen_sign, ViewError};
use crate::diagnose::cells::MotionReference;
use crate::diagnose::record::Record;
use crate::diagnose::shape::marker_shape;
use crate::estimate::angle::screen_angle_rad;
use crate::estimate::{circle_fit, Estimate, RotationCentreMethod};
use crate::mechanism::Mechanism;
use crate::numeric::angle::wrap_pi as wrap;
use crate::scenario::Scenario;
use crate::scene::{Scene, WheelPose};
use crate::timing::{LogModel, Timestamps, TimingModel};
use serde::Serialize;

/// Why the nominal cannot be aligned to the footage.
#[derive(Debug, thiserror::Error)]
pub enum AlignError {
    #[error("the real frame times")]
    FrameTimes(#[source] crate::timing::TimingError),
    #[error(
        "the marker centre does not move along a measurable arc; a diagnosis needs footage where \
         the wheel turns"
    )]
    NoArc(#[source] crate::estimate::EstimateError),
    #[error(
        "the aligned nominal is not a valid scenario: {}",
        crate::validation::bullet_list(problems)
    )]
    AlignedInvalid {
        problems: Vec<crate::validation::Problem>,
    },
    #[error(transparent)]
    View(#[from] ViewError),
    #[error(transparent)]
    Simulate(#[from] SimulateError),
}

/// The image-geometry nuisance fitted to the real marker track.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GeometryAlignment {
    /// Rotation centre of the marker-centre track (geometric circle fit), px.
    pub rotation_centre_px: [f64; 2],
    pub rotation_centre_sigma_px: [f64; 2],
    /// Marker-centre distance from the rotation centre, px.
    pub marker_radius_px: f64,
    /// Median detected marker side, px.
    pub marker_side_px: f64,
    /// Image scale that gives that side, mm/px.
    pub mm_per_px: f64,
    /// Marker radius on the disc, mm.
    pub marker_radius_mm: f64,
    /// Marker angular position on the disc at t = 0, deg.
    pub angle_on_disc_deg: f64,
    /// Marker rotation on the disc, deg.
    pub orientation_deg: f64,
}

/// Everything alignment produced.
#[derive(Debug, Clone)]
pub struct Aligned {
    pub scenario: Scenario,
    pub motion: MotionAlignment,
    pub geometry: GeometryAlignment,
    /// +1 when the nominal wheel's θ2 grows counter-clockwise on screen.
    pub screen_sign: f64,
    /// The aligned motion on a fine grid, for the residual channels.
    pub reference: ReferenceTable,
}

fn circular_median(v: &[f64]) -> f64 {
    // Median of the deviations from the circular mean (robust and wrap-safe).
    let (s, c) = v
        .iter()
        .fold((0.0, 0.0), |(s, c), a| (s + a.sin(), c + a.cos()));
    let m = s.atan2(c);
    let mut d: Vec<f64> = v.iter().map(|a| wrap(a - m)).collect();
    d.sort_by(f64::total_cmp);
    wrap(m + d.get(d.len() / 2).copied().unwrap_or(0.0))
}

fn scene_of(s: &Scenario) -> Result<Scene, AlignError> {
    let camera = Camera::new(&s.camera).map_err(ViewError::NominalCamera)?;
    Ok(Scene::new(&s.scene, camera).map_err(ViewError::NominalScene)?)
}

/// The real frame times as the scenario's frame schedule (a log model that keeps them as they
/// are), and a duration that covers them.
pub fn at_frame_times(s: &mut Scenario, t_s: &[f64]) -> Result<(), AlignError> {
    let ts = Timestamps::new(t_s.to_vec()).map_err(AlignError::FrameTimes)?;
    let last = t_s.last().copied().unwrap_or(0.0);
    let step = if t_s.len() > 1 {
        (last - t_s[0]) / (t_s.len() - 1) as f64
    } else {
        1.0 / 30.0
    };
    s.frame_timing.model = TimingModel::Log(LogModel {
        file: "real footage".into(),
        rebase_to_zero: false,
        offset_s: 0.0,
        ..LogModel::default()
    });
    s.timing_log = Some(ts);
    s.duration_s = (last + 0.5 * step).max(1e-3);
    Ok(())
}

/// Aligns `nominal` to the real measurement.
pub fn align(
    nominal: &Scenario,
    record: &Record,
    est: &Estimate,
    layout: &crate::imagestats::MarkerLayout,
    simulator: &dyn Simulator,
) -> Result<Aligned, AlignError> {
    let sign = screen_sign(&scene_of(nominal)?);
    let t_all = record.t_s();
    let primary = est.primary_series();
    let (t_det, th_det) = crate::diagnose::cells::detected_angle(&t_all, &primary.theta_rad);
    let mut motion =
        align_motion(nominal, &t_det, &th_det, sign).map_err(ViewError::AlignMotion)?;
    let mut s = apply_motion(nominal, &motion);
    // A nominal that states a tilted camera, a distorting lens, a runout or a clearance: its
    // angle warp (or late start) is not a crank speed or phase.
    let (realigned, refit) =
        crate::diagnose::camera_warp::realign_motion(&s, &t_det, &th_det, sign)?;
    if let Some(r) = refit {
        motion = MotionAlignment {
            theta1_start_rad: r.motion.theta1_start_rad,
            speed_scale: motion.speed_scale * r.speed_scale,
            offset_rad: r.motion.offset_rad,
            rms_residual_rad: r.motion.rms_residual_rad,
            nominal_rms_residual_rad: motion.nominal_rms_residual_rad,
        };
        s = realigned;
    }
    at_frame_times(&mut s, &t_all)?;
    let mut geometry = align_geometry(&mut s, record, sign)?;
    refine_by_simulation(&mut s, &mut geometry, record, est, layout, simulator)?;
    let problems = s.validate();
    if !problems.is_empty() {
        return Err(AlignError::AlignedInvalid {
            problems: problems.0,
        });
    }
    let reference = ReferenceTable::new(
        &s,
        sign,
        t_all.first().copied().unwrap_or(0.0),
        t_all.last().copied().unwrap_or(0.0),
    )?;
    Ok(Aligned {
        scenario: s,
        motion,
        geometry,
        screen_sign: sign,
        reference,
    })
}

/// Rounds of [`refine_by_simulation`].
const REFINE_ROUNDS: usize = 2;

/// Matches the aligned geometry measured-to-measured: the aligned nominal is rendered and
/// measured once (no placement jitter), and its image scale and rotation centre are corrected
/// by the difference between what the pipeline measured on it and on the real footage (median
/// detected side; the estimator's rotation centre). The geometric fit in [`align_geometry`]
/// compares detected corners with drawn ones, and detected corners sit where the detector's
/// convention puts them (the centre of the outermost black pixel: about half a pixel inside
/// the edge, more or less with another renderer's edge profile): without this step a marker a
/// pixel too small or a centre half a pixel off shows up as a gap in every moving phase.
fn refine_by_simulation(
    s: &mut Scenario,
    geometry: &mut GeometryAlignment,
    record: &Record,
    est: &Estimate,
    layout: &crate::imagestats::MarkerLayout,
    simulator: &dyn Simulator,
) -> Result<(), AlignError> {
    let median_side = |r: &Record| -> Option<f64> {
        let mut v: Vec<f64> = r
            .frames
            .iter()
            .filter_map(|f| f.corners_px.as_ref().and_then(marker_shape))
            .map(|sh| sh.side_px)
            .collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied()
    };
    let Some(side_real) = median_side(record) else {
        return Ok(());
    };
    let centre_real = est.rotation_centre.centre_px;
    for round in 0..REFINE_ROUNDS {
        let mut trial = s.clone();
        trial.seed = s.seed.wrapping_add(3000 + round as u64);
        let sim = simulator.record(&trial, layout, false)?;
        let (Some(side_sim), Ok(sim_est)) = (
            median_side(&sim),
            super::trials::estimate_record(&trial, &sim),
        ) else {
            return Ok(());
        };
        let ratio = side_real / side_sim;
        if let FocalConfig::ImageScale { mm_per_px } = &mut s.camera.focal {
            // The marker's radius in pixels is measured without bias (a centre); keep it.
            let old = *mm_per_px;
            *mm_per_px = old / ratio;
            s.scene.marker.radius_mm *= *mm_per_px / old;
        }
        let c_sim = sim_est.rotation_centre.centre_px;
        if let Some(c) = s.camera.rotation_centre_px.as_mut() {
            c[0] -= c_sim[0] - centre_real[0];
            c[1] -= c_sim[1] - centre_real[1];
            geometry.rotation_centre_px = *c;
        }
    }
    disc_holds_marker(s);
    let scene = scene_of(s)?;
    geometry.mm_per_px = scene.camera().image_scale_mm_per_px();
    geometry.marker_radius_mm = s.scene.marker.radius_mm;
    Ok(())
}

/// Grows the disc when a fitted marker radius or image scale puts the marker's paper past its
/// edge (lens distortion or a nominal a few per cent off does): the diagnosis measures the
/// marker, never the disc, whose radius only has to hold the marker.
fn disc_holds_marker(s: &mut Scenario) {
    let extent_mm = s.scene.marker.paper_extent_mm();
    if extent_mm.is_finite() && extent_mm > s.scene.disc_radius_mm {
        s.scene.disc_radius_mm = extent_mm * 1.02;
    }
}

/// The scene of `s`, its disc grown first to hold the marker: each step of the geometry fit
/// moves the marker's radius, angle or orientation, and the paper's reach from the centre
/// depends on all three (a calibrated nominal of tilted footage was refused mid-fit with the
/// paper 0.2 mm past the disc).
fn grown_scene_of(s: &mut Scenario) -> Result<Scene, AlignError> {
    disc_holds_marker(s);
    scene_of(s)
}

/// Fits the image geometry of `s` (already motion-aligned) to the real marker track.
fn align_geometry(
    s: &mut Scenario,
    record: &Record,
    sign: f64,
) -> Result<GeometryAlignment, AlignError> {
    let shapes: Vec<(usize, crate::diagnose::shape::MarkerShape, [[f64; 2]; 4])> = record
        .frames
        .iter()
        .enumerate()
        .filter_map(|(k, f)| {
            let c = f.corners_px?;
            marker_shape(&c).map(|sh| (k, sh, c))
        })
        .collect();
    let centres: Vec<[f64; 2]> = shapes.iter().map(|(_, sh, _)| sh.centre_px).collect();
    let rc = circle_fit::fit_rotation_centre(
        std::slice::from_ref(&centres),
        RotationCentreMethod::Geometric,
        2.0,
    )
    .map_err(AlignError::NoArc)?;
    let c = rc.centre_px;
    let r_real = rc.radii_px.first().copied().unwrap_or(0.0);
    let mut sides: Vec<f64> = shapes.iter().map(|(_, sh, _)| sh.side_px).collect();
    sides.sort_by(f64::total_cmp);
    let side_real = sides[sides.len() / 2];

    // The aligned wheel angle at each detected frame.
    let mut dyn_off = s.dynamics.clone();
    dyn_off.enabled = false;
    let mech = Mechanism::new(&s.mechanism, &s.drive_speed, &dyn_off, s.duration_s + 1.0)
        .map_err(ViewError::NominalMechanism)?;
    let theta2: Vec<f64> = shapes
        .iter()
        .map(|(k, _, _)| mech.ideal(record.frames[*k].t_s).theta2_rad)
        .collect();
    // Screen angle of the marker at θ2 = 0 and the corner-0 direction relative to the radius.
    let offsets: Vec<f64> = shapes
        .iter()
        .zip(&theta2)
        .map(|((_, sh, _), th)| wrap(screen_angle_rad(sh.centre_px, c) - sign * th))
        .collect();
    let psi0_real = circular_median(&offsets);
    let betas: Vec<f64> = shapes
        .iter()
        .map(|(_, sh, corners)| {
            wrap(screen_angle_rad(corners[0], sh.centre_px) - screen_angle_rad(sh.centre_px, c))
        })
        .collect();
    let beta_real = circular_median(&betas);

    s.camera.rotation_centre_px = Some(c);
    let zero = WheelPose {
        theta2_rad: 0.0,
        centre_offset_m: [0.0, 0.0],
    };
    for _ in 0..4 {
        // Scale: the marker side.
        let scene = grown_scene_of(s)?;
        let corners = scene.marker_corners_px_at(&zero);
        let side_sim = marker_shape(&corners).map_or(side_real, |sh| sh.side_px);
        let mm_per_px = scene.camera().image_scale_mm_per_px() * side_sim / side_real;
        s.camera.focal = FocalConfig::ImageScale { mm_per_px };
        // Radius, angle and orientation.
        let scene = grown_scene_of(s)?;
        let rc_sim = scene.rotation_centre_px_at(&zero);
        let mc_sim = scene.marker_centre_px_at(&zero);
        let r_sim = (mc_sim.x - rc_sim.x).hypot(mc_sim.y - rc_sim.y);
        if r_sim > 0.0 {
            s.scene.marker.radius_mm *= r_real / r_sim;
            disc_holds_marker(s);
        }
        let psi_sim = screen_angle_rad([mc_sim.x, mc_sim.y], [rc_sim.x, rc_sim.y]);
        s.scene.marker.angle_on_disc_deg =
            wrap(s.scene.marker.angle_on_disc_deg.to_radians() + sign * wrap(psi0_real - psi_sim))
                .to_degrees();
        let scene = grown_scene_of(s)?;
        let corners = scene.marker_corners_px_at(&zero);
        let mc = scene.marker_centre_px_at(&zero);
        let rcs = scene.rotation_centre_px_at(&zero);
        let beta_sim = wrap(
            screen_angle_rad(corners[0], [mc.x, mc.y])
                - screen_angle_rad([mc.x, mc.y], [rcs.x, rcs.y]),
        );
        s.scene.marker.orientation_deg =
            wrap(s.scene.marker.orientation_deg.to_radians() + sign * wrap(beta_real - beta_sim))
                .to_degrees();
    }
    if record.has_reference {
        align_reference(s, record)?;
    }
    let scene = grown_scene_of(s)?;
    Ok(GeometryAlignment {
        rotation_centre_px: c,
        rotation_centre_sigma_px: rc.centre_sigma_px,
        marker_radius_px: r_real,
        marker_side_px: side_real,
        mm_per_px: scene.camera().image_scale_mm_per_px(),
        marker_radius_mm: s.scene.marker.radius_mm,
        angle_on_disc_deg: s.scene.marker.angle_on_disc_deg,
        orientation_deg: s.scene.marker.orientation_deg,
    })
}

/// Moves the static reference marker so its image centre sits where the real one does.
fn align_reference(s: &mut Scenario, record: &Record) -> Result<(), AlignError> {
    let mut xs: Vec<f64> = Vec::new();
    let mut ys: Vec<f64> = Vec::new();
    for f in &record.frames {
        if let Some(sh) = f.reference_px.as_ref().and_then(marker_shape) {
            xs.push(sh.centre_px[0]);
            ys.push(sh.centre_px[1]);
        }
    }
    if xs.is_empty() {
        return Ok(());
    }
    xs.sort_by(f64::total_cmp);
    ys.sort_by(f64::total_cmp);
    let target = [xs[xs.len() / 2], ys[ys.len() / 2]];
    for _ in 0..4 {
        let scene = grown_scene_of(s)?;
        let Some(c) = scene.reference_marker_corners_px() else {
            return Ok(());
        };
        let Some(sh) = marker_shape(&c) else {
            return Ok(());
        };
        let k = scene.camera().image_scale_mm_per_px();
        let p = &mut s.scene.reference_marker.position_mm;
        // World x right, y down, as image x, y for a camera square to the disc.
        p[0] += (target[0] - sh.centre_px[0]) * k;
        p[1] += (target[1] - sh.centre_px[1]) * k;
    }
    Ok(())
}

/// The aligned nominal motion on a fine time grid (1 ms), in screen convention, for residuals.
#[derive(Debug, Clone)]
pub struct ReferenceTable {
    t0_s: f64,
    step_s: f64,
    theta_rad: Vec<f64>,
    omega_rad_s: Vec<f64>,
    alpha_rad_s2: Vec<f64>,
    phase: Vec<crate::mechanism::Phase>,
}

/// Largest time shift between a record and the aligned motion, s.
pub const MAX_TIME_SHIFT_S: f64 = 0.1;

impl ReferenceTable {
    /// Samples `aligned`'s actual motion from before `t_first_s` to after `t_last_s` (by more
    /// than [`MAX_TIME_SHIFT_S`]).
    pub fn new(
        aligned: &Scenario,
        screen_sign: f64,
        t_first_s: f64,
        t_last_s: f64,
    ) -> Result<Self, AlignError> {
        let step_s = 1e-3;
        let t0_s = t_first_s - 2.0 * MAX_TIME_SHIFT_S;
        let t1 = t_last_s + 2.0 * MAX_TIME_SHIFT_S;
        let mech = Mechanism::new(
            &aligned.mechanism,
            &aligned.drive_speed,
            &aligned.dynamics,
            t1 + 0.1,
        )
        .map_err(ViewError::NominalMechanism)?;
        let n = ((t1 - t0_s) / step_s).ceil() as usize + 1;
        let samples: Vec<_> = (0..n)
            .map(|k| mech.actual(t0_s + k as f64 * step_s))
            .collect();
        Ok(Self {
            t0_s,
            step_s,
            theta_rad: samples.iter().map(|m| screen_sign * m.theta2_rad).collect(),
            omega_rad_s: samples
                .iter()
                .map(|m| screen_sign * m.omega2_rad_s)
                .collect(),
            alpha_rad_s2: samples
                .iter()
                .map(|m| screen_sign * m.alpha2_rad_s2)
                .collect(),
            phase: samples.iter().map(|m| m.phase).collect(),
        })
    }

    /// The aligned nominal's wheel angle θ2 (its own convention, not the screen's) at `t_s`.
    pub fn theta2_rad_at(&self, t_s: f64, screen_sign: f64) -> f64 {
        self.interp(&self.theta_rad, t_s) / screen_sign
    }

    /// The aligned nominal's wheel speed (its own convention) at `t_s`, rad/s.
    pub fn omega2_rad_s_at(&self, t_s: f64, screen_sign: f64) -> f64 {
        self.interp(&self.omega_rad_s, t_s) / screen_sign
    }

    fn interp(&self, v: &[f64], t_s: f64) -> f64 {
        let x = ((t_s - self.t0_s) / self.step_s).clamp(0.0, (v.len() - 1) as f64);
        let i = (x.floor() as usize).min(v.len().saturating_sub(2));
        let f = x - i as f64;
        v[i] * (1.0 - f) + v[i + 1] * f
    }

    fn phase_at(&self, t_s: f64) -> crate::mechanism::Phase {
        let x = ((t_s - self.t0_s) / self.step_s)
            .round()
            .clamp(0.0, (self.phase.len() - 1) as f64);
        self.phase[x as usize]
    }

    /// The reference at `t_s` shifted by `shift_s`.
    fn at(
        &self,
        t_s: &[f64],
        shift_s: f64,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<crate::mechanism::Phase>) {
        let tt: Vec<f64> = t_s.iter().map(|t| t + shift_s).collect();
        (
            tt.iter()
                .map(|&t| self.interp(&self.theta_rad, t))
                .collect(),
            tt.iter()
                .map(|&t| self.interp(&self.omega_rad_s, t))
                .collect(),
            tt.iter()
                .map(|&t| self.interp(&self.alpha_rad_s2, t))
                .collect(),
            tt.iter().map(|&t| self.phase_at(t)).collect(),
        )
    }
}

/// Offset and trimmed RMS (central 80 %) of `theta − reference` over finite samples.
fn offset_and_rms(theta: &[f64], reference: &[f64]) -> (f64, f64) {
    let mut d: Vec<f64> = theta
        .iter()
        .zip(reference)
        .map(|(a, b)| a - b)
        .filter(|v| v.is_finite())
        .collect();
    if d.is_empty() {
        return (0.0, f64::INFINITY);
    }
    d.sort_by(f64::total_cmp);
    let lo = d.len() / 10;
    let hi = d.len() - lo;
    let c = d[lo..hi].iter().sum::<f64>() / (hi - lo) as f64;
    let rms = (d[lo..hi].iter().map(|v| (v - c).powi(2)).sum::<f64>() / (hi - lo) as f64).sqrt();
    (c, rms)
}

/// The aligned motion at every frame of `record` (screen convention), with the record's own
/// time shift and angle offset fitted: a capture delay (rolling shutter, a timestamp
/// convention, the first interval of a phone) is nuisance, measured the same way on real and
/// simulated records. Returns the reference and the fitted shift, s.
pub fn motion_reference(
    table: &ReferenceTable,
    record: &Record,
    est: &Estimate,
) -> (MotionReference, f64) {
    let t = record.t_s();
    let primary = &est.primary_series().theta_rad;
    let loss = |shift: f64| offset_and_rms(primary, &table.at(&t, shift).0).1;
    // Grid over ±MAX_TIME_SHIFT_S first.
    let steps = 40;
    let h = 2.0 * MAX_TIME_SHIFT_S / steps as f64;
    let mut best = (f64::INFINITY, 0.0);
    for k in 0..=steps {
        let s = -MAX_TIME_SHIFT_S + k as f64 * h;
        let l = loss(s);
        if l < best.0 {
            best = (l, s);
        }
    }
    // Golden section around the best grid point; kept only when it improves on that point.
    let refined = crate::numeric::minimize::golden_section_min(loss, best.1 - h, best.1 + h, 30);
    let shift = if loss(refined) < best.0 {
        refined
    } else {
        best.1
    };
    let (theta, omega, alpha, phase) = table.at(&t, shift);
    let (offset, _) = offset_and_rms(primary, &theta);
    (
        MotionReference {
            theta_rad: theta.iter().map(|v| v + offset).collect(),
            omega_rad_s: omega,
            alpha_rad_s2: alpha,
            phase,
        },
        shift,
    )
}

/// The marker-centre track of `record` against the aligned nominal's, frame by frame, with what
/// [`crate::diagnose::runout`] needs to read a runout's form off it: the nominal's wheel angle
/// (at the record's fitted time shift), the residual, the image Jacobian of a wheel-centre
/// offset and the radial direction.
pub fn runout_samples(
    aligned: &Aligned,
    record: &Record,
    shift_s: f64,
) -> Result<Vec<crate::diagnose::runout::RunoutSample>, AlignError> {
    let mut s = aligned.scenario.clone();
    let scene = grown_scene_of(&mut s)?;
    // A tenth of a millimetre: far above rounding, far inside the camera's linear range.
    const STEP_M: f64 = 1e-4;
    let mut out = Vec::new();
    for f in &record.frames {
        let Some(c) = f.corners_px else {
            continue;
        };
        let theta2_rad = aligned
            .reference
            .theta2_rad_at(f.t_s + shift_s, aligned.screen_sign);
        let pose = |offset: [f64; 2]| WheelPose {
            theta2_rad,
            centre_offset_m: offset,
        };
        let m = scene.marker_centre_px_at(&pose([0.0, 0.0]));
        let centre = scene.rotation_centre_px_at(&pose([0.0, 0.0]));
        let mx = scene.marker_centre_px_at(&pose([STEP_M, 0.0]));
        let my = scene.marker_centre_px_at(&pose([0.0, STEP_M]));
        let r = m - centre;
        let len = r.length();
        if len.is_nan() || len <= 0.0 {
            continue;
        }
        let measured = crate::estimate::marker_centre::corner_mean(&c);
        out.push(crate::diagnose::runout::RunoutSample {
            t_s: f.t_s,
            theta2_rad,
            omega2_rad_s: aligned
                .reference
                .omega2_rad_s_at(f.t_s + shift_s, aligned.screen_sign),
            residual_px: [measured[0] - m.x, measured[1] - m.y],
            jacobian_px_per_m: [
                [(mx.x - m.x) / STEP_M, (mx.y - m.y) / STEP_M],
                [(my.x - m.x) / STEP_M, (my.y - m.y) / STEP_M],
            ],
            radial: [r.x / len, r.y / len],
        });
    }
    Ok(out)
}
