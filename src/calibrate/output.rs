//! The calibrated scenario (fields that extend the base, each with its uncertainty as a TOML
//! comment) and the calibration report, as text. One list of [`Override`]s feeds both the file
//! and the typed scenario (`scenario::with_overrides`), so they cannot disagree.

use super::exposure::ExposureDrift;
use super::residual::{self, StructureCheck};
use super::{significant_decimals, Calibration, Fitted};
use crate::mechanism::Mechanism;
use crate::scenario::Scenario;
use std::fmt::Write;
use toml::Value;

/// One field of the calibrated scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// Dotted path (`camera.focal.mm_per_px`).
    pub path: String,
    pub value: Value,
    /// How it was measured, with its uncertainty.
    pub comment: String,
}

/// Where the calibration's inputs and outputs live.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputContext {
    /// The `extend` target written into the scenario (built-in name or absolute path).
    pub extend: String,
    /// The footage, for the header.
    pub footage: String,
    /// Timestamps file next to the scenario (`timestamps.csv`), `None` in single-frame mode.
    pub timestamps_file: Option<String>,
    pub width_px: usize,
    pub height_px: usize,
    /// Timestamp of the last frame from the first, s.
    pub last_t_s: f64,
    /// The footage's frame interval, s: the shorter of its median interval and its fitted mean
    /// rate's (the validator bounds an exposure by the timing log's median interval); `None`
    /// without timestamps.
    pub frame_interval_s: Option<f64>,
}

/// The re-rendering check: the calibrated scenario rendered at a footage frame's instant.
#[derive(Debug, Clone, PartialEq)]
pub struct ReRenderCheck {
    pub frame: usize,
    pub t_s: f64,
    /// Window compared (x0, y0, width, height), px.
    pub window: (i64, i64, usize, usize),
    /// RMS of footage − noise-free, uncompressed render over the window, DN, after the render is
    /// aligned to the footage by [`Self::alignment`] (when accepted).
    pub residual_rms_dn: f64,
    /// The same RMS before the alignment, DN.
    pub unaligned_rms_dn: f64,
    /// The marker's sub-pixel pose correction that best aligns the render to the footage,
    /// linearised on the render's gradients: shift x and y (px), rotation (deg) and scale
    /// (relative) about the marker's centre. `None` when the fit was singular or moved the
    /// marker by more than `MAX_ALIGNMENT_PX` at its corners (then the residual is unaligned).
    pub alignment: Option<[f64; 4]>,
    /// RMS of footage − render the fitted model predicts over the same pixels, DN: the fitted
    /// noise σ, the render's own rounding to whole DN (1/12 DN²) and, with the fitted
    /// compression, the codec's distortion of the clean render, in quadrature.
    pub expected_noise_dn: f64,
    /// Structure in the aligned residual against a residual the noise model draws.
    pub structure: StructureCheck,
}

pub use super::rerender::MAX_ALIGNMENT_PX;

/// The largest residual RMS over the RMS the fitted model predicts that passes.
pub const MAX_RESIDUAL_RATIO: f64 = 1.2;

impl ReRenderCheck {
    pub fn ratio(&self) -> f64 {
        self.residual_rms_dn / self.expected_noise_dn.max(1e-9)
    }

    /// The residual is as large as the fitted model predicts and holds no structure the noise
    /// model does not: the scenario reproduces the footage down to its noise.
    pub fn passed(&self) -> bool {
        self.ratio() <= MAX_RESIDUAL_RATIO && self.structure.passed()
    }

    /// What is left, one sentence per failed test (empty when passed).
    pub fn failures(&self) -> Vec<String> {
        let mut out = Vec::new();
        let ratio = self.ratio();
        if ratio.is_nan() || ratio > MAX_RESIDUAL_RATIO {
            out.push(format!(
                "the residual's RMS is {:.2} × what the fitted model predicts (at most \
                 {MAX_RESIDUAL_RATIO})",
                self.ratio()
            ));
        }
        out.extend(self.structure.failures.iter().cloned());
        out
    }

    /// Each test's figures (footage, noise model, limit) and whether it passed.
    pub fn figure_lines(&self) -> Vec<(String, bool)> {
        let (f, m) = (&self.structure.footage, &self.structure.model);
        let tri = |a: &[f64; 3]| format!("{:+.2}/{:+.2}/{:+.2}", a[0], a[1], a[2]);
        let quad = |a: &[f64; 4]| format!("{:+.2}/{:+.2}/{:+.2}/{:+.2}", a[0], a[1], a[2], a[3]);
        let limits = residual::limits(m);
        vec![
            (
                format!(
                    "residual RMS {:.2} DN, the fitted model predicts {:.2} DN: ratio {:.2} (at \
                     most {MAX_RESIDUAL_RATIO})",
                    self.residual_rms_dn,
                    self.expected_noise_dn,
                    self.ratio()
                ),
                self.ratio() <= MAX_RESIDUAL_RATIO,
            ),
            (
                format!(
                    "smoothed at {} px the residual keeps {:.2} of its sd (white noise {:.2}, the \
                     noise model {:.2}; at most {:.2})",
                    residual::SMOOTHING_SIGMA_PX,
                    f.smoothed_retention,
                    residual::white_noise_retention(),
                    m.smoothed_retention,
                    limits.smoothed_retention
                ),
                f.smoothed_retention <= limits.smoothed_retention,
            ),
            (
                format!(
                    "autocorrelation at 1/2/3 px {} (the noise model {}; at most {:.2} above it)",
                    tri(&f.autocorrelation),
                    tri(&m.autocorrelation),
                    residual::MAX_EXCESS_AUTOCORRELATION
                ),
                (0..3).all(|k| {
                    f.autocorrelation[k] - m.autocorrelation[k]
                        <= residual::MAX_EXCESS_AUTOCORRELATION
                }),
            ),
            (
                format!(
                    "energy on the marker's edges over the flat regions' {:.2} (the noise model \
                     {:.2}; at most {:.2})",
                    f.edge_energy_ratio, m.edge_energy_ratio, limits.edge_energy_ratio
                ),
                f.edge_energy_ratio <= limits.edge_energy_ratio,
            ),
            (
                format!(
                    "correlation with the render's level/gradient across/gradient down/Laplacian \
                     {} (the noise model {}; at most {:.2} apart)",
                    quad(&f.render_correlation),
                    quad(&m.render_correlation),
                    residual::MAX_RENDER_CORRELATION
                ),
                (0..4).all(|t| {
                    (f.render_correlation[t] - m.render_correlation[t]).abs()
                        <= residual::MAX_RENDER_CORRELATION
                }),
            ),
        ]
    }
}

fn num(v: f64, decimals: usize) -> Value {
    let s = format!("{v:.decimals$}");
    Value::Float(s.parse().unwrap_or(v))
}

/// A value written with two more decimals than its uncertainty shows.
fn fitted_value(f: &Fitted) -> Value {
    num(f.value, significant_decimals(f.u95) + 2)
}

fn ov(path: &str, value: Value, comment: impl Into<String>) -> Override {
    Override {
        path: path.into(),
        value,
        comment: comment.into(),
    }
}

/// A time inside one frame that the base states longer than the footage allows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CappedTime {
    /// The scenario field (`effects.motion_blur.exposure_s`, `effects.rolling_shutter.readout_s`).
    pub field: &'static str,
    /// The base's value, s.
    pub base_s: f64,
    /// The value written: one frame interval at the footage's rate, rounded down to a
    /// microsecond so that the written number never exceeds it.
    pub capped_s: f64,
}

/// The exposure and readout the base has on and states longer than the footage's frame
/// interval `interval_s`, capped there. No camera exposes or reads a frame out for longer than
/// the time between two frames, and the scenario validator refuses it: a base that keeps the
/// default 4 ms exposure cannot describe footage filmed at more than 250 fps as it is.
pub fn capped_to_frame_interval(base: &Scenario, interval_s: f64) -> Vec<CappedTime> {
    if !(interval_s.is_finite() && interval_s > 0.0) {
        return Vec::new();
    }
    let capped_s = (interval_s * 1e6).floor() / 1e6;
    crate::scenario::times_inside_one_frame_of(base)
        .into_iter()
        .filter(|t| t.on && t.value_s > interval_s)
        .map(|t| CappedTime {
            field: t.field,
            base_s: t.value_s,
            capped_s,
        })
        .collect()
}

/// The note a capped time leaves in `calibration.md` and beside the field.
pub fn capped_time_note(c: &CappedTime) -> String {
    format!(
        "the base's {} = {} s is longer than one frame interval of the footage: capped at {} s, \
         an upper bound (no camera takes longer than its frame interval); `geneva diagnose` fits \
         the real value",
        c.field, c.base_s, c.capped_s
    )
}

/// The footage's frame interval for [`capped_to_frame_interval`]: the shorter of the median
/// interval of `times_s` and one interval at the fitted mean rate `fps`; `None` when neither is
/// a positive number.
pub fn footage_frame_interval_s(times_s: &[f64], fps: f64) -> Option<f64> {
    [
        crate::timing::median_interval_s(times_s),
        if fps > 0.0 { 1.0 / fps } else { f64::NAN },
    ]
    .into_iter()
    .filter(|d| d.is_finite() && *d > 0.0)
    .reduce(f64::min)
}

/// The scenario fields the calibration sets.
pub fn overrides(cal: &Calibration, ctx: &OutputContext, base: &Scenario) -> Vec<Override> {
    let g = &cal.geometry;
    let im = &cal.imaging;
    let mut o = Vec::new();
    o.push(ov(
        "name",
        Value::String("calibrated".into()),
        "calibrated from the footage",
    ));
    let fps = cal.timing.as_ref().map_or(base.frame_timing.fps, |t| t.fps);
    let duration = if ctx.timestamps_file.is_some() {
        ctx.last_t_s + 0.5 / fps
    } else {
        (0.5 / base.frame_timing.fps).max(1e-3)
    };
    o.push(ov(
        "duration_s",
        num(duration.max(1e-3), 6),
        format!(
            "{} frames over {:.4} s (+ half a frame)",
            cal.frames, ctx.last_t_s
        ),
    ));
    o.push(ov(
        "camera.width_px",
        Value::Integer(ctx.width_px as i64),
        "footage",
    ));
    o.push(ov(
        "camera.height_px",
        Value::Integer(ctx.height_px as i64),
        "footage",
    ));
    codec_overrides(cal.codec.as_ref(), &mut o);
    o.push(ov(
        "camera.focal.kind",
        Value::String("image_scale".into()),
        "",
    ));
    o.push(ov(
        "camera.focal.mm_per_px",
        num(g.mm_per_px.value, significant_decimals(g.mm_per_px.u95) + 2),
        format!(
            "± {:.*} (95 %): pose fit of {} marker poses ({}), side ≈ {:.2} px",
            significant_decimals(g.mm_per_px.u95),
            g.mm_per_px.u95,
            g.poses,
            if g.from_edges {
                "edge-fitted corners"
            } else {
                "OpenCV corners"
            },
            g.side_px
        ),
    ));
    if let Some([cx, cy]) = g.centre_px {
        o.push(ov(
            "camera.rotation_centre_px",
            Value::Array(vec![fitted_value(&cx), fitted_value(&cy)]),
            format!(
                "± [{:.*}, {:.*}] px (95 %): pose fit over {:.0}° of rotation, RMS {:.3} px",
                significant_decimals(cx.u95),
                cx.u95,
                significant_decimals(cy.u95),
                cy.u95,
                g.arc_deg,
                g.rms_residual_px
            ),
        ));
    }
    let t = &g.tilt;
    // Not fitted (too few poses): the base's tilt stands.
    o.extend(t.fitted.then(|| {
        ov(
            "camera.perspective_tilt.enabled",
            Value::Boolean(t.significant),
            if t.significant {
                format!("marker aspect {:.4}", t.aspect)
            } else {
                format!(
                    "tilt x {}°, y {}° (95 %) not distinguishable from 0 (marker aspect {:.4})",
                    t.tilt_x_deg, t.tilt_y_deg, t.aspect
                )
            },
        )
    }));
    if t.significant {
        o.push(ov(
            "camera.perspective_tilt.tilt_x_deg",
            fitted_value(&t.tilt_x_deg),
            format!(
                "± {:.*}° (95 %), with camera.distance_m = {} (the base's)",
                significant_decimals(t.tilt_x_deg.u95),
                t.tilt_x_deg.u95,
                g.distance_m
            ),
        ));
        o.push(ov(
            "camera.perspective_tilt.tilt_y_deg",
            fitted_value(&t.tilt_y_deg),
            format!(
                "± {:.*}° (95 %)",
                significant_decimals(t.tilt_y_deg.u95),
                t.tilt_y_deg.u95
            ),
        ));
    }
    o.push(ov(
        "scene.marker.radius_mm",
        fitted_value(&g.radius_mm),
        format!(
            "± {:.*} mm (95 %): pose fit",
            significant_decimals(g.radius_mm.u95),
            g.radius_mm.u95
        ),
    ));
    o.push(ov(
        "scene.marker.orientation_deg",
        fitted_value(&g.orientation_deg),
        format!(
            "± {:.*}° (95 %): printed top side against the radius",
            significant_decimals(g.orientation_deg.u95),
            g.orientation_deg.u95
        ),
    ));
    let angle = cal
        .motion
        .as_ref()
        .map_or(g.angle_first_deg, |m| m.angle_first_deg);
    o.push(ov(
        "scene.marker.angle_on_disc_deg",
        fitted_value(&angle),
        format!(
            "± {:.*}° (95 %): marker angle at the first frame",
            significant_decimals(angle.u95),
            angle.u95
        ),
    ));
    // The marker's paper must lie on the drawn disc.
    let mut placed = base.scene.marker.clone();
    placed.radius_mm = g.radius_mm.value;
    placed.orientation_deg = g.orientation_deg.value;
    let extent = placed.paper_extent_mm();
    if extent > base.scene.disc_radius_mm {
        o.push(ov(
            "scene.disc_radius_mm",
            num(extent.ceil() + 1.0, 1),
            "enlarged to hold the measured marker radius",
        ));
    }
    if let Some(m) = &cal.motion {
        o.push(ov(
            "mechanism.theta1_start_rad",
            fitted_value(&m.theta1_start_rad),
            format!(
                "± {:.*} rad (95 %): crank angle at the first frame, kinematic fit of the marker angle over {} engagement(s), RMS {:.2e} rad",
                significant_decimals(m.theta1_start_rad.u95),
                m.theta1_start_rad.u95,
                m.engagements,
                m.rms_residual_rad
            ),
        ));
        match &m.polynomial {
            Some((end, mid)) => {
                o.push(ov(
                    "drive_speed.kind",
                    Value::String("polynomial_per_engagement".into()),
                    "the per-engagement speed variation is resolved",
                ));
                o.push(ov(
                    "drive_speed.end_rad_s",
                    fitted_value(end),
                    format!(
                        "± {:.*} rad/s (95 %)",
                        significant_decimals(end.u95),
                        end.u95
                    ),
                ));
                o.push(ov(
                    "drive_speed.mid_rad_s",
                    fitted_value(mid),
                    format!(
                        "± {:.*} rad/s (95 %)",
                        significant_decimals(mid.u95),
                        mid.u95
                    ),
                ));
            }
            None => {
                o.push(ov("drive_speed.kind", Value::String("constant".into()), ""));
                o.push(ov(
                    "drive_speed.omega1_rad_s",
                    fitted_value(&m.omega1_rad_s),
                    format!(
                        "± {:.*} rad/s (95 %): mean crank speed",
                        significant_decimals(m.omega1_rad_s.u95),
                        m.omega1_rad_s.u95
                    ),
                ));
            }
        }
    }
    if let Some(file) = &ctx.timestamps_file {
        o.push(ov(
            "frame_timing.fps",
            num(fps, 6),
            "fitted mean rate (geneva timing fit)",
        ));
        o.push(ov(
            "frame_timing.model.kind",
            Value::String("log".into()),
            "the footage's own timestamps",
        ));
        o.push(ov(
            "frame_timing.model.file",
            Value::String(file.clone()),
            "",
        ));
        o.push(ov(
            "frame_timing.model.format",
            Value::String("frames_csv".into()),
            "",
        ));
    }
    if let Some(interval_s) = ctx.frame_interval_s {
        for c in capped_to_frame_interval(base, interval_s) {
            o.push(ov(c.field, num(c.capped_s, 6), capped_time_note(&c)));
        }
    }
    o.push(ov("effects.lighting.enabled", Value::Boolean(true), ""));
    o.push(ov(
        "effects.lighting.black_level_dn",
        num(im.black_level_dn, 3),
        if im.ink_radiance == 0.0 {
            "the ink's clipping level"
        } else {
            "ink level − 5σ of its noise (room for the noise below the ink)"
        },
    ));
    o.push(ov(
        "effects.lighting.white_level_dn",
        num(im.white_level_dn, 3),
        if im.paper_radiance == 1.0 {
            "the paper's clipping level"
        } else {
            "paper level + 5σ of its noise"
        },
    ));
    o.push(ov(
        "effects.lighting.gamma",
        num(1.0, 1),
        "levels are mapped linearly",
    ));
    o.extend(exposure_overrides(&im.exposure));
    o.push(ov(
        "scene.ink_radiance",
        num(im.ink_radiance, 5),
        format!("ink {} DN (95 %, {} frames)", im.ink_dn, im.level_frames),
    ));
    o.push(ov(
        "scene.paper_radiance",
        num(im.paper_radiance, 5),
        format!("paper {} DN (95 %)", im.paper_dn),
    ));
    if let (Some(r), Some(d)) = (im.disc_radiance, im.disc_dn) {
        o.push(ov(
            "scene.disc_radiance",
            num(r, 5),
            format!("disc around the marker's paper {d} DN (95 %)"),
        ));
    }
    if let (Some(b), Some(p)) = (im.blur_sigma_px, im.blur_sigma_param_px) {
        o.push(ov("effects.optical_blur.enabled", Value::Boolean(true), ""));
        o.push(ov(
            "effects.optical_blur.sigma_px",
            fitted_value(&p),
            format!(
                "± {:.*} (95 %): PSF σ {} px from {} edge fits (the renderer's kernel is sampled at whole pixels)",
                significant_decimals(p.u95),
                p.u95,
                b,
                im.blur_edges
            ),
        ));
    }
    if let Some(m) = im.sharpening.filter(|m| m.significant) {
        o.push(ov("effects.sharpening.enabled", Value::Boolean(true), ""));
        o.push(ov(
            "effects.sharpening.amount",
            num(m.amount, 3),
            format!(
                "± {:.3} (95 %): the halo of {} edge fits (residual RMS {:.2} → {:.2} DN)",
                1.96 * m.amount_se,
                m.edges,
                m.rms_without_dn,
                m.rms_with_dn
            ),
        ));
        o.push(ov("effects.sharpening.sigma_px", num(m.sigma_px, 2), ""));
    }
    let n = &im.noise;
    if n.footage_not_identifiable.is_some() {
        // Not measured: the base's noise, as σ in DN at the footage's levels, flagged.
        let on = base.effects.pixel_noise.enabled;
        o.push(ov(
            "effects.pixel_noise.enabled",
            Value::Boolean(on),
            "NOT IDENTIFIABLE from this footage (calibration.md says why): the base's noise",
        ));
        if on {
            o.push(ov(
                "effects.pixel_noise.full_well_e",
                num(n.full_well_e, 1),
                format!(
                    "the base's σ {:.2} DN at the ink, {:.2} DN at the paper, under these levels; \
                     not measured",
                    n.ink_sigma_dn.value, n.paper_sigma_dn.value
                ),
            ));
            o.push(ov(
                "effects.pixel_noise.read_noise_e",
                num(n.read_noise_e, 2),
                "the base's; not measured",
            ));
        }
        return compression_overrides(im, o);
    }
    o.push(ov("effects.pixel_noise.enabled", Value::Boolean(true), ""));
    o.push(ov(
        "effects.pixel_noise.full_well_e",
        num(n.full_well_e, 1),
        format!(
            "σ {} DN at the ink, {} DN at the paper (95 %){}",
            n.ink_sigma_dn,
            n.paper_sigma_dn,
            if n.shot_resolved {
                ""
            } else {
                "; no measurable shot noise"
            }
        ),
    ));
    o.push(ov(
        "effects.pixel_noise.read_noise_e",
        num(n.read_noise_e, 2),
        n.source.clone(),
    ));
    compression_overrides(im, o)
}

/// The compression fields, appended to `o`.
/// `effects.lighting.gain_drift_per_s` and `gain_reference_s`: the drift when the footage shows
/// one, else steady light, saying why.
fn exposure_overrides(e: &ExposureDrift) -> Vec<Override> {
    match e {
        ExposureDrift::Fitted(f) if f.significant() => vec![
            ov(
                "effects.lighting.gain_drift_per_s",
                num(f.drift_per_s.value, 7),
                format!(
                    "± {:.*} per s (95 %): the marker's contrast over {} stretches of the footage",
                    significant_decimals(f.drift_per_s.u95),
                    f.drift_per_s.u95,
                    f.blocks
                ),
            ),
            ov(
                "effects.lighting.gain_reference_s",
                num(f.reference_s, 4),
                "the footage's median time: the levels hold there",
            ),
        ],
        ExposureDrift::Fitted(f) => vec![ov(
            "effects.lighting.gain_drift_per_s",
            num(0.0, 1),
            format!(
                "steady: no drift beyond ± {:.*} per s (95 %, {} stretches of the footage)",
                significant_decimals(f.drift_per_s.u95),
                f.drift_per_s.u95,
                f.blocks
            ),
        )],
        ExposureDrift::NotIdentifiable(why) => vec![ov(
            "effects.lighting.gain_drift_per_s",
            num(0.0, 1),
            format!("NOT IDENTIFIABLE ({why}): steady light assumed"),
        )],
    }
}

/// The calibration.md row of the light's drift: (value, how).
fn exposure_row(e: &ExposureDrift) -> (String, String) {
    match e {
        ExposureDrift::Fitted(f) => (
            format!(
                "{}{}",
                f.drift_per_s.map(|d| 100.0 * d),
                if f.significant() {
                    ""
                } else {
                    " (steady: not written)"
                }
            ),
            format!(
                "the marker's contrast (paper − ink) over {} stretches of {} frames, fitted as \
                 c₀·(1 + d·(t − {:.2} s)) {}; residual {:.2} DN",
                f.blocks,
                f.frames,
                f.reference_s,
                f.gradient_phrase(),
                f.residual_rms_dn
            ),
        ),
        ExposureDrift::NotIdentifiable(why) => (
            "not identifiable".into(),
            format!("{why}; steady light assumed"),
        ),
    }
}

fn codec_overrides(codec: Option<&super::codec::CodecReading>, o: &mut Vec<Override>) {
    if let Some(r) = codec {
        let c = &r.config;
        let how = format!("read from the container: {}", r.how);
        o.push(ov(
            "effects.video_codec.enabled",
            Value::Boolean(false),
            "the footage's noise, blur and levels already hold the codec",
        ));
        o.push(ov(
            "effects.video_codec.codec",
            Value::String(c.codec.ffprobe_name().into()),
            how.clone(),
        ));
        if let Some(b) = c.bitrate_bps {
            o.push(ov("effects.video_codec.bitrate_bps", num(b, 0), ""));
        }
        o.push(ov(
            "effects.video_codec.gop_frames",
            Value::Integer(c.gop_frames as i64),
            "",
        ));
        o.push(ov(
            "effects.video_codec.b_frames",
            Value::Integer(c.b_frames as i64),
            "",
        ));
        o.push(ov(
            "effects.video_codec.preset",
            Value::String(c.preset.clone()),
            "assumed",
        ));
    }
}

fn compression_overrides(im: &super::ImagingFit, mut o: Vec<Override>) -> Vec<Override> {
    match im.jpeg_quality {
        Some((q, (lo, hi), k)) => {
            o.push(ov("effects.compression.enabled", Value::Boolean(true), ""));
            o.push(ov(
                "effects.compression.quality",
                Value::Integer(q as i64),
                format!("IJG quality {lo}–{hi} from the DCT quantiser ({k} frames)"),
            ));
        }
        None => o.push(ov(
            "effects.compression.enabled",
            Value::Boolean(false),
            match im.blockiness {
                Some(b) => format!("no JPEG quantiser found (blockiness {b:.2})"),
                None => "not measured".into(),
            },
        )),
    }
    o
}

/// Marker-angle offset that the base's wheel dynamics add to the ideal kinematics over the
/// footage's frames (mean actual − ideal θ2), rad; `None` without dynamics.
pub fn dynamics_offset_rad(scenario: &Scenario, times_s: &[f64]) -> Option<f64> {
    if !scenario.dynamics.enabled || times_s.is_empty() {
        return None;
    }
    let m = Mechanism::new(
        &scenario.mechanism,
        &scenario.drive_speed,
        &scenario.dynamics,
        scenario.duration_s,
    )
    .ok()?;
    let d: f64 = times_s
        .iter()
        .map(|&t| m.actual(t).theta2_rad - m.ideal(t).theta2_rad)
        .sum();
    Some(d / times_s.len() as f64)
}

/// The scenario file: a header, `extend`, then the fields grouped by table with comments.
pub fn scenario_toml(overrides: &[Override], ctx: &OutputContext, cal: &Calibration) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Calibrated by `geneva calibrate` from {} ({} frames, marker in {}).",
        ctx.footage, cal.frames, cal.detected_frames
    );
    let _ = writeln!(
        s,
        "# Uncertainties are expanded (≈ 95 %); calibration.md says how each value was measured."
    );
    let _ = writeln!(s, "extend = {}", Value::String(ctx.extend.clone()));
    let mut sections: Vec<(String, Vec<&Override>)> = Vec::new();
    for o in overrides {
        let (sec, _) = o.path.rsplit_once('.').unwrap_or(("", &o.path));
        match sections.iter_mut().find(|(k, _)| k == sec) {
            Some((_, v)) => v.push(o),
            None => sections.push((sec.to_string(), vec![o])),
        }
    }
    sections.sort_by_key(|(k, _)| !k.is_empty());
    for (sec, items) in &sections {
        if !sec.is_empty() {
            let _ = writeln!(s, "\n[{sec}]");
        }
        for o in items {
            let key = o.path.rsplit('.').next().unwrap_or(&o.path);
            if o.comment.is_empty() {
                let _ = writeln!(s, "{key} = {}", o.value);
            } else {
                let _ = writeln!(s, "{key} = {}  # {}", o.value, o.comment);
            }
        }
        if sec == "frame_timing.model" {
            if let Some(t) = &cal.timing {
                let _ = writeln!(
                    s,
                    "# Fitted VFR model (geneva timing fit), for a synthetic schedule instead of the log:\n\
                     # kind = \"vfr\", first_interval_s = {:.6}, pair_alternation_s = {:.6}, jitter_s = {:.3e}, \
                     drop_probability = {:.5}, rate_error_ppm = 0 (fps above)",
                    t.first_interval_s,
                    t.pair_alternation_s.abs(),
                    t.jitter_s,
                    t.drop_probability
                );
            }
        }
    }
    s
}

/// The `## Appearance` section: what the marker texture holds and where it came from.
fn appearance_markdown(
    s: &mut String,
    a: Option<&crate::calibrate::appearance::AppearanceRecord>,
    surroundings: &[String],
) {
    let _ = writeln!(s, "\n## Appearance\n");
    let around = if surroundings.is_empty() {
        "The disc around the paper and the background are drawn uniform.".to_string()
    } else {
        surroundings.join(" ")
    };
    let Some(a) = a else {
        let _ = writeln!(
            s,
            "The marker is drawn with uniform ink and paper at the fitted levels (no texture was \
             measured: the notes say why). {around}"
        );
        return;
    };
    let total = (a.sampled_texels + a.level_texels).max(1);
    let _ = writeln!(
        s,
        "The marker's paper and ink are drawn from `{}` ({} texels per cell, {:.1} px per cell in \
         the footage): mosaicked from {} registered frame(s){}. {} of {} texels ({:.0} %) were \
         sampled from the footage; the other {} lie within {:.1} px of an edge between ink and \
         paper or of the paper's rim, where the footage holds its blur of both sides, and take \
         their material's level from the nearest sampled texels, so that the render's edges stay \
         sharp and are blurred once, by the fitted σ. Texture within that band of an edge is not \
         reproduced. {}",
        a.file,
        a.texels_per_cell,
        a.px_per_cell,
        a.frames,
        if a.check_frame_held_out {
            ", the re-rendering check's frame left out"
        } else {
            ", the re-rendering check's frame among them (one frame cannot be left out of its \
             own mosaic: the check then tests the levels, blur and pose, not the texture)"
        },
        a.sampled_texels,
        total,
        100.0 * a.sampled_texels as f64 / total as f64,
        a.level_texels,
        a.guard_px,
        around,
    );
}

/// The marker's level by wheel angle: the bins measured and whether the scenario draws them.
fn marker_levels_markdown(s: &mut String, t: Option<&crate::calibrate::marker_levels::LevelTable>) {
    let Some(t) = t else {
        return;
    };
    let written = t.shows_levels();
    let _ = writeln!(
        s,
        "\nThe marker's level by the wheel's angle, on {} slow frame(s) (no corner moving 1.5 px \
         from a neighbouring frame), against {:.2} / {:.2} DN (ink / paper) drawn: {}\n",
        t.frames,
        t.reference_dn[0],
        t.reference_dn[1],
        if written {
            "the scenario draws it (`scene.appearance.marker_levels`), interpolated in the angle \
             between the bins"
        } else {
            "within the noise, not written"
        }
    );
    let _ = writeln!(
        s,
        "| θ2 (°) | frames | ink (DN, ± 1 s.e.) | paper (DN, ± 1 s.e.) |\n|---|---|---|---|"
    );
    for b in &t.bins {
        let _ = writeln!(
            s,
            "| {:.1} | {} | {:.2} ± {:.2} | {:.2} ± {:.2} |",
            b.angle_deg, b.frames, b.level_dn[0], b.se_dn[0], b.level_dn[1], b.se_dn[1]
        );
    }
}

/// The noise by grey level: each level's measured σ against the model and whether the scenario
/// draws the factors.
fn noise_levels_markdown(
    s: &mut String,
    fit: Option<&crate::calibrate::noise_levels::NoiseLevelFit>,
) {
    let Some(fit) = fit.filter(|f| !f.points.is_empty()) else {
        return;
    };
    let _ = writeln!(
        s,
        "\nThe pixel noise by grey level, the temporal σ of each static run's ink, paper and \
         surround against the fitted electrons (anchored on the run they were fitted on): {}\n",
        if fit.shows_levels() {
            "the scenario draws the factors (`effects.pixel_noise.level_gain`), interpolated in \
             the level"
        } else {
            "within 10 % or within the noise, not written"
        }
    );
    let _ = writeln!(
        s,
        "| level (DN) | σ measured (DN) | σ of the electrons (DN) | factor on the sensor's σ (± 1 s.e.) | from |\n|---|---|---|---|---|"
    );
    for p in &fit.points {
        let _ = writeln!(
            s,
            "| {:.1} | {:.3} | {:.3} | {:.3} ± {:.3} | {} |",
            p.level_dn,
            p.measured_dn,
            p.model_dn,
            p.gain,
            p.gain_se,
            p.what.join("; ")
        );
    }
    for why in &fit.skipped {
        let _ = writeln!(s, "\nLeft out: {why}.");
    }
}

/// The calibration report (markdown).
pub fn calibration_markdown(
    cal: &Calibration,
    ctx: &OutputContext,
    check: Option<&ReRenderCheck>,
) -> String {
    let g = &cal.geometry;
    let im = &cal.imaging;
    let mut s = String::new();
    let _ = writeln!(s, "# Calibration of {}\n", ctx.footage);
    let _ = writeln!(
        s,
        "{} frames ({}×{} px), marker detected in {}. Every value is given with its expanded \
         uncertainty (≈ 95 % coverage, k = 2 on the fit's standard error plus a small floor). \
         Pixel coordinates follow OpenCV's convention (the centre of pixel (i, j) is at (i, j)).\n",
        cal.frames, ctx.width_px, ctx.height_px, cal.detected_frames
    );
    let _ = writeln!(
        s,
        "| quantity | value (± 95 %) | unit | how it was measured |"
    );
    let _ = writeln!(s, "|---|---|---|---|");
    let mut row = |q: &str, v: String, u: &str, how: String| {
        let _ = writeln!(s, "| {q} | {v} | {u} | {how} |");
    };
    row(
        "image scale",
        g.mm_per_px.to_string(),
        "mm/px",
        format!(
            "pose fit with the project's camera model: {} poses ({}), marker side ≈ {:.2} px, RMS {:.3} px",
            g.poses,
            if g.from_edges {
                "corners from edge-profile fits of the four sides"
            } else {
                "OpenCV corners with a fitted inset"
            },
            g.side_px,
            g.rms_residual_px
        ),
    );
    if let Some([cx, cy]) = g.centre_px {
        row(
            "rotation centre x, y",
            format!("{cx}, {cy}"),
            "px",
            format!("pose fit over {:.0}° of rotation", g.arc_deg),
        );
    } else {
        row(
            "rotation centre x, y",
            format!("{:.2}, {:.2}", g.centre_used_px[0], g.centre_used_px[1]),
            "px",
            "the base's (single frame: not measured)".into(),
        );
    }
    row(
        "marker radius",
        g.radius_mm.to_string(),
        "mm",
        "pose fit".into(),
    );
    row(
        "marker orientation on the disc",
        g.orientation_deg.to_string(),
        "deg",
        "printed right axis against the radial direction, pose fit".into(),
    );
    let tilt = &g.tilt;
    if !tilt.fitted {
        row(
            "perspective tilt x, y",
            "not fitted".into(),
            "deg",
            format!(
                "needs at least 8 marker poses (none in single-frame mode); the base's tilt is kept; marker aspect {:.4}",
                tilt.aspect
            ),
        );
    } else {
        row(
        "perspective tilt x, y",
        format!("{}, {}", tilt.tilt_x_deg, tilt.tilt_y_deg),
        "deg",
        format!(
            "pose fit with camera.distance_m = {} m (the base's; sets the focal length with the scale); marker aspect {:.4}; {}",
            g.distance_m,
            tilt.aspect,
            if tilt.significant { "enabled" } else { "not distinguishable from 0: disabled" }
        ),
    );
    }
    if let Some(m) = &cal.motion {
        row(
            "sense of rotation",
            if m.sense > 0.0 {
                "clockwise on screen".into()
            } else {
                "counter-clockwise on screen".into()
            },
            "–",
            "sign of the marker's total turn".into(),
        );
        row(
            "marker angle at the first frame",
            m.angle_first_deg.to_string(),
            "deg",
            "kinematic fit (scene.marker.angle_on_disc_deg)".into(),
        );
        row(
            "crank angle at the first frame",
            m.theta1_start_rad.to_string(),
            "rad",
            format!(
                "least squares of the exact Geneva kinematics to the unwrapped marker angle ({} engagement(s), {} moving frames, RMS {:.2e} rad, angle noise {:.2e} rad)",
                m.engagements, m.moving_frames, m.rms_residual_rad, m.angle_noise_rad
            ),
        );
        row(
            "mean crank speed",
            m.omega1_rad_s.to_string(),
            "rad/s",
            "constant-speed fit".into(),
        );
        match (&m.polynomial, &m.polynomial_difference) {
            (Some((e, mi)), _) => row(
                "crank speed at engagement ends / middle",
                format!("{e} / {mi}"),
                "rad/s",
                "per-engagement polynomial fit (resolved)".into(),
            ),
            (None, Some(d)) => row(
                "per-engagement speed variation (mid − end)",
                d.to_string(),
                "rad/s",
                "not resolved: the constant speed is used".into(),
            ),
            _ => {}
        }
    }
    if let Some(t) = &cal.timing {
        row(
            "frame rate",
            format!("{:.4} ± {:.4}", t.fps, 2.0 * t.fps_stderr),
            "fps",
            format!(
                "VFR fit of the footage's timestamps (first interval {:.2} ms, jitter {:.3} ms, {} dropped); the scenario replays the timestamps themselves",
                t.first_interval_s * 1e3,
                t.jitter_s * 1e3,
                t.dropped_frames
            ),
        );
    }
    row(
        "ink level",
        im.ink_dn.to_string(),
        "DN",
        format!(
            "trimmed mean of well-inside pixels, median over {} frames",
            im.level_frames
        ),
    );
    row(
        "paper level",
        im.paper_dn.to_string(),
        "DN",
        "white cells and margin, same way".into(),
    );
    if let Some(d) = im.disc_dn {
        row(
            "disc level",
            d.to_string(),
            "DN",
            "ring beyond the marker's paper".into(),
        );
    }
    if let Some(b) = im.blur_sigma_px {
        row(
            "optical blur σ (PSF)",
            b.to_string(),
            "px",
            format!(
                "erf edge-profile fits with free levels, median over {} edges of static frames; scenario sigma_px {}",
                im.blur_edges,
                im.blur_sigma_param_px.map_or("–".into(), |p| p.to_string())
            ),
        );
    }
    if let Some(m) = &im.sharpening {
        row(
            "sharpening (unsharp mask)",
            format!(
                "{:.3} ± {:.3}, σ {:.2}",
                m.amount,
                1.96 * m.amount_se,
                m.sigma_px
            ),
            "–, px",
            format!(
                "edge fits under each mask, residual RMS {:.2} → {:.2} DN over {} edges; {}",
                m.rms_without_dn,
                m.rms_with_dn,
                m.edges,
                if m.significant {
                    "drawn (the scenario's values are matched by rendering: see the notes)"
                } else {
                    "not drawn: too weak to tell from the edges' noise"
                }
            ),
        );
    }
    let n = &im.noise;
    let shown = |f: &Fitted| match &n.footage_not_identifiable {
        None => f.to_string(),
        Some(_) => format!("not identifiable (the base's {:.2} written)", f.value),
    };
    let how = match &n.footage_not_identifiable {
        None => n.source.clone(),
        Some(why) => format!("{why}; the scenario carries {}", n.source),
    };
    row(
        "noise σ at the ink",
        shown(&n.ink_sigma_dn),
        "DN",
        how.clone(),
    );
    row("noise σ at the paper", shown(&n.paper_sigma_dn), "DN", how);
    row(
        "shot + read noise",
        format!(
            "full well {:.0} e⁻, read {:.1} e⁻",
            n.full_well_e, n.read_noise_e
        ),
        "e⁻",
        if n.shot_resolved {
            "σ² = α + β·(DN − black) through the ink and paper points".into()
        } else {
            "σ does not grow with the level: read noise only".into()
        },
    );
    let sensor =
        |m: usize, level: f64| n.sensor_sigma_dn(m, level, im.black_level_dn, im.white_level_dn);
    row(
        "sensor noise σ at the ink / paper (before compression, with the 1/√12 DN quantisation)",
        match &n.not_identifiable {
            None => {
                let show = |m: usize, level: f64| {
                    let f = sensor(m, level);
                    if n.quantisation_limited[m] {
                        format!("{:.2} (not identifiable below ½ DN: {f})", f.value)
                    } else {
                        f.to_string()
                    }
                };
                format!("{} / {}", show(0, im.ink_dn.value), show(1, im.paper_dn.value))
            }
            Some(_) => format!(
                "not identifiable (the scenario's electrons give {:.2} / {:.2})",
                sensor(0, im.ink_dn.value).value,
                sensor(1, im.paper_dn.value).value
            ),
        },
        "DN",
        match &n.not_identifiable {
            None => "the fitted electrons; interval: the measured σ's through the match's sensitivity (footage and simulation) plus the match's residual".into(),
            Some(why) => why.clone(),
        },
    );
    match im.jpeg_quality {
        Some((q, (lo, hi), k)) => row(
            "JPEG quality",
            format!("{q} ({lo}–{hi})"),
            "–",
            format!("maximum likelihood of the IJG table on block-DCT coefficients (Fan & de Queiroz 2003), {k} of {} frames", im.compression_frames),
        ),
        None => row("JPEG quality", "none found".into(), "–", format!("{} frames examined", im.compression_frames)),
    }
    {
        let (value, how) = exposure_row(&im.exposure);
        row("light's drift over the footage", value, "%/s", how);
    }
    if let Some(b) = im.blockiness {
        row(
            "8-px blockiness B/A",
            format!("{b:.3}"),
            "–",
            "Wang, Sheikh & Bovik 2002 (≈ 1 without block coding)".into(),
        );
    }
    if let (Some(i), Some(p)) = (im.reference_ink_dn, im.reference_paper_dn) {
        row(
            "reference marker ink / paper",
            format!("{i} / {p}"),
            "DN",
            "the static marker's well-inside pixels".into(),
        );
    }
    if let Some(b) = im.reference_blur_sigma_px {
        row(
            "reference marker blur σ",
            b.to_string(),
            "px",
            "its four sides".into(),
        );
    }
    appearance_markdown(&mut s, cal.appearance.as_ref(), &cal.surroundings);
    marker_levels_markdown(&mut s, cal.marker_levels.as_ref());
    noise_levels_markdown(&mut s, cal.noise_levels.as_ref());
    if let Some(c) = check {
        let _ = writeln!(
            s,
            "\n## Re-rendering check: {}\n\nFrame {} (t = {:.4} s) rendered from the calibrated \
             scenario, compared with the footage over the marker window ({}×{} px at {}, {}). The \
             scenario reproduces the footage only if footage − render is as large as the fitted \
             model predicts and holds no structure that a residual the model draws (its render \
             with noise and codec − its clean render) does not: structure wider than a few \
             pixels, correlated neighbours, energy along the marker's edges, or a residual that \
             follows the render's level, gradients or blur. `overlay.png` shows the footage, the \
             render, their difference and the residual smoothed at 2 px.\n",
            if c.passed() { "passed" } else { "failed" },
            c.frame,
            c.t_s,
            c.window.2,
            c.window.3,
            c.window.0,
            c.window.1,
        );
        let _ = writeln!(s, "| test | figures | passed |\n|---|---|---|");
        for (k, (text, ok)) in c.figure_lines().into_iter().enumerate() {
            let name = [
                "residual RMS",
                "smoothed at 2 px",
                "autocorrelation",
                "edge energy",
                "render correlation",
            ]
            .get(k)
            .copied()
            .unwrap_or("");
            let _ = writeln!(
                s,
                "| {name} | {text} | {} |",
                if ok { "yes" } else { "**no**" }
            );
        }
        let failures = c.failures();
        if !failures.is_empty() {
            let _ = writeln!(s, "\nWhat is left in the residual:\n");
            for f in &failures {
                let _ = writeln!(s, "- {f}");
            }
        }
        let _ = writeln!(
            s,
            "\nThe RMS is that of footage − the render without noise or compression; the fitted \
             model's prediction holds its noise σ, the render's rounding to whole DN (1/12 DN²) \
             and, with the fitted compression, the codec's distortion of the clean render, in \
             quadrature. {}",
            match c.alignment {
                Some([dx, dy, rot, scale]) => format!(
                    "The render was first aligned to the footage by the marker's sub-pixel pose \
                     correction that fits best (shift ({dx:.3}, {dy:.3}) px, rotation {rot:.4}°, \
                     scale {:+.3} %; linearised on the render's gradients): at sub-DN noise an \
                     edge shifted by a few hundredths of a pixel, within the pose's uncertainty, \
                     is most of the difference. Before it the RMS was {:.3} DN.",
                    100.0 * scale,
                    c.unaligned_rms_dn
                ),
                None => format!(
                    "No pose alignment: the best one would move the marker by more than \
                     {MAX_ALIGNMENT_PX} px (or was singular), so the residual is the unaligned one \
                     ({:.3} DN RMS).",
                    c.unaligned_rms_dn
                ),
            }
        );
    }
    if let Some(t) = &cal.timing {
        let _ = writeln!(s, "\n## Frame timing\n\n```\n{t}\n```");
    }
    if !cal.notes.is_empty() {
        let _ = writeln!(s, "\n## Notes\n");
        for n in &cal.notes {
            let _ = writeln!(s, "- {n}");
        }
    }
    s
}
