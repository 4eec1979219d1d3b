//! Estimation: marker centre, rotation centre, per-signal angle, ω and α from per-frame marker
//! corner tracks (OpenCV pixel convention: the centre of pixel (i, j) is at (i, j)).
//!
//! Missing frames (`None`) are never interpolated: they are excluded from the circle fit and the
//! derivatives (which run on the detected frames' own timestamps, so a gap is a larger step) and
//! come back as NaN in the per-frame outputs.
//!
//! Seed parity (gurrajo/Geneva, `tag_detection_2.py`): the seed's centre construction is
//! [`circle_fit::seed_centre`]; its derivatives are `numpy.gradient(θ, t)` twice
//! ([`Differentiator::Seed`]). Not reproduced: the seed's `t = [0] + pts_times` off-by-one, its
//! dropping of the last 7 frames, its one-shot ±2π unwrap (we unwrap every step), its
//! clockwise-positive angle sign (ours is counter-clockwise on screen positive), and its float32
//! evaluation of the bisector (OpenCV corners are float32 in numpy; we use f64 — a ≈1e-4 px
//! difference that can only change the truncated centre when it lies that close to an integer).

pub mod angle;
pub mod circle_fit;
pub mod compensate;
pub mod config;
pub mod differentiate;
pub mod error;
pub mod kalman;
pub(crate) mod lm;
pub mod marker_centre;
pub mod measured;

#[cfg(test)]
mod tests;

pub use circle_fit::RotationCentre;
pub use config::{
    EstimatorConfig, MarkerCentreMethod, ReferenceCompensation, RotationCentreMethod, Signal,
    Timebase,
};
pub use differentiate::{Derivatives, Differentiator, NoiseGain};
pub use error::EstimateError;
pub use measured::MeasuredSignal;

/// Four marker corners in OpenCV order (TL, TR, BR, BL as printed), pixels.
pub type Corners = [[f64; 2]; 4];

/// θ, ω, α of one signal, aligned with the input frames (NaN where the frame is missing).
#[derive(Debug, Clone, PartialEq)]
pub struct SignalSeries {
    pub signal: Signal,
    /// Unwrapped angle, rad, counter-clockwise on screen positive.
    pub theta_rad: Vec<f64>,
    pub omega_rad_s: Vec<f64>,
    pub alpha_rad_s2: Vec<f64>,
    /// The differentiator actually used, with data-driven parameters (Kalman λ) fixed; its
    /// `noise_gain` is the one that applies to this series.
    pub differentiator: Differentiator,
}

/// Everything the estimator produces for one track.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    pub rotation_centre: RotationCentre,
    /// Corners 0–3, centre, fused — in [`Signal::ALL`] order.
    pub signals: Vec<SignalSeries>,
    /// The configured primary signal (index into `signals` via [`Signal::index`]).
    pub primary: Signal,
    /// Marker centre per frame (after compensation), `None` where missing.
    pub marker_centre_px: Vec<Option<[f64; 2]>>,
    /// Time base actually used, s (per input frame).
    pub t_used_s: Vec<f64>,
    pub frames: usize,
    /// Frames with usable corners (after compensation).
    pub detected: usize,
    /// Frames without usable corners: not detected, or dropped for a missing reference.
    pub missing: usize,
    /// Frames with the moving marker detected but dropped because the reference was missing.
    pub missing_reference: usize,
}

impl Estimate {
    /// The primary signal's series.
    pub fn primary_series(&self) -> &SignalSeries {
        &self.signals[self.primary.index()]
    }
}

/// Runs the whole estimation: compensation → marker centre → rotation centre → angles → fusion →
/// derivatives.
pub fn estimate(
    config: &EstimatorConfig,
    frames_t_s: &[f64],
    corners: &[Option<Corners>],
    reference_corners: Option<&[Option<Corners>]>,
) -> Result<Estimate, EstimateError> {
    let n = frames_t_s.len();
    if corners.len() != n {
        return Err(EstimateError::LengthMismatch {
            what: "corners",
            got: corners.len(),
            expected: n,
        });
    }
    let (corners, missing_reference) = match reference_corners {
        Some(r) if config.reference_compensation != ReferenceCompensation::Off => {
            if r.len() != n {
                return Err(EstimateError::LengthMismatch {
                    what: "reference_corners",
                    got: r.len(),
                    expected: n,
                });
            }
            compensate::compensate(corners, r, config.reference_compensation)
        }
        _ => (corners.to_vec(), 0),
    };
    let t_used: Vec<f64> = match config.timebase {
        Timebase::Timestamps => frames_t_s.to_vec(),
        Timebase::ConstantFps { fps_hz } => (0..n).map(|k| k as f64 / fps_hz).collect(),
    };
    let detected: Vec<usize> = (0..n).filter(|&k| corners[k].is_some()).collect();
    for &k in &detected {
        if corners[k].is_some_and(|c| c.iter().flatten().any(|v| !v.is_finite())) {
            return Err(EstimateError::NonFinite {
                what: "corner",
                frame: k,
            });
        }
    }
    // Five point tracks over the detected frames: corners 0–3 then the marker centre.
    let centres: Vec<Option<[f64; 2]>> = corners
        .iter()
        .map(|c| c.map(|c| marker_centre::marker_centre_px(&c, config.marker_centre)))
        .collect();
    let mut tracks: Vec<Vec<[f64; 2]>> =
        (0..5).map(|_| Vec::with_capacity(detected.len())).collect();
    for &k in &detected {
        let c = corners[k].unwrap_or_default();
        for (s, track) in tracks.iter_mut().take(4).enumerate() {
            track.push(c[s]);
        }
        tracks[4].push(centres[k].unwrap_or_default());
    }
    let rc = circle_fit::fit_rotation_centre(&tracks, config.rotation_centre, config.min_arc_deg)?;

    let mut theta: Vec<Vec<f64>> = Vec::with_capacity(6);
    for track in &tracks {
        let wrapped: Vec<Option<f64>> = track
            .iter()
            .map(|p| Some(angle::screen_angle_rad(*p, rc.centre_px)))
            .collect();
        theta.push(
            crate::numeric::angle::unwrap(&wrapped)
                .into_iter()
                .flatten()
                .collect(),
        );
    }
    theta.push(angle::fuse(&theta, &rc.radii_px, Signal::Centre.index()));

    let t_det: Vec<f64> = detected.iter().map(|&k| t_used[k]).collect();
    let mut signals = Vec::with_capacity(6);
    for (s, th) in Signal::ALL.iter().zip(&theta) {
        let differentiator = config.differentiator.resolved(&t_det, th)?;
        let d = differentiator.differentiate(&t_det, th)?;
        let spread = |v: &[f64]| {
            let mut out = vec![f64::NAN; n];
            for (&k, x) in detected.iter().zip(v) {
                out[k] = *x;
            }
            out
        };
        signals.push(SignalSeries {
            signal: *s,
            theta_rad: spread(th),
            omega_rad_s: spread(&d.omega_rad_s),
            alpha_rad_s2: spread(&d.alpha_rad_s2),
            differentiator,
        });
    }
    Ok(Estimate {
        rotation_centre: rc,
        signals,
        primary: config.primary_signal,
        marker_centre_px: centres,
        t_used_s: t_used,
        frames: n,
        detected: detected.len(),
        missing: n - detected.len(),
        missing_reference,
    })
}
