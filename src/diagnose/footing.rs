//! What a diagnosis reads off the real footage once it is measured, before any candidate: the
//! nominal aligned to it, the real side of every comparison (its cells and series, its frame
//! times and lost frames) and what the runout and tilt candidates start from. [`Footing`] owns
//! it all, so that the [`Fitter`] the diagnosis runs on (and a test's) borrows it from one place.

use super::record::RealMeasurement;
use super::simulator::Simulator;
use crate::diagnose::cells::{image_cells, timing_cells, track_cells, AngleResidual, Cells};
use crate::diagnose::fit::{self, FitError, Fitter, RealSide};
use crate::diagnose::gap::GapOptions;
use crate::diagnose::nominal::{self, Aligned};
use crate::diagnose::pose_tilt::{self, PoseTilt};
use crate::diagnose::runout::RunoutForm;
use crate::diagnose::simulator::SimMeter;
use crate::diagnose::trials::{RealFrames, SimContext};
use crate::imagestats::MarkerLayout;
use crate::scenario::effects::Effect;
use crate::scenario::Scenario;
use std::sync::Arc;

/// The real footage as the fits see it ([`Footing::new`]).
pub struct Footing<'s> {
    /// Renders and measures every simulation of this footage.
    simulator: &'s dyn Simulator,
    pub aligned: Aligned,
    /// Frame times of all frames, s.
    pub t_all_s: Vec<f64>,
    /// Which frames have no detection.
    real_missing: Vec<bool>,
    /// Half the footage's median frame rate, Hz: the top of the highest band.
    pub nyquist_hz: f64,
    height_px: f64,
    has_images: bool,
    /// The real track's time shift against the aligned nominal motion, s.
    pub real_time_shift_s: f64,
    pub real_cells: Cells,
    real_angle: AngleResidual,
    runout_form: Option<RunoutForm>,
    pose_tilt: Option<PoseTilt>,
    /// Times and primary angle of the detected frames.
    t_det_s: Vec<f64>,
    theta_det_rad: Vec<f64>,
    /// Counts the simulations run on this footing (shared with another footing of the same
    /// diagnosis by [`Self::with_meter`]).
    meter: Arc<SimMeter>,
}

impl<'s> Footing<'s> {
    /// Aligns `nominal` to the measured footage and computes its cells; `simulator` renders
    /// and measures every simulation of it from then on. The runout form and the tilt are read
    /// off the real track only when `effects` (`None`: all) holds them: each costs a fit over
    /// every detected frame.
    pub fn new(
        nominal: &Scenario,
        real: &RealMeasurement,
        layout: &MarkerLayout,
        effects: Option<&[Effect]>,
        simulator: &'s dyn Simulator,
    ) -> Result<Self, FitError> {
        let aligned = nominal::align(nominal, &real.record, &real.estimate, layout, simulator)?;
        let t_all_s = real.record.t_s();
        let nyquist_hz = 0.5 / fit::median_interval_s(&t_all_s);
        let real_missing: Vec<bool> = real
            .record
            .frames
            .iter()
            .map(|f| f.corners_px.is_none())
            .collect();
        let height_px = nominal.camera.height_px as f64;
        let (reference, real_time_shift_s) =
            nominal::motion_reference(&aligned.reference, &real.record, &real.estimate);
        let mut real_cells = track_cells(
            &real.record,
            &real.estimate,
            &reference,
            nyquist_hz,
            height_px,
        );
        real_cells.extend(image_cells(
            &real.record,
            aligned.geometry.rotation_centre_px,
            &reference.phase,
            nyquist_hz,
            height_px,
        ));
        real_cells.extend(timing_cells(&t_all_s));
        let primary = &real.estimate.primary_series().theta_rad;
        let real_angle = crate::diagnose::cells::angle_residual(
            &t_all_s,
            primary,
            &reference.theta_rad,
            nyquist_hz,
        );
        let is_candidate = |e: Effect| effects.is_none_or(|c| c.contains(&e));
        let runout_form = if is_candidate(Effect::AxisRunout) {
            crate::diagnose::runout::fit_runout_form(
                &nominal::runout_samples(&aligned, &real.record, real_time_shift_s)?,
                &crate::diagnose::runout::CYCLES_TRIED,
            )
        } else {
            None
        };
        let pose_tilt = is_candidate(Effect::PerspectiveTilt)
            .then(|| pose_tilt::pose_tilt(&aligned.scenario, &real.record))
            .flatten();
        let (t_det_s, theta_det_rad) = crate::diagnose::cells::detected_angle(&t_all_s, primary);
        Ok(Self {
            aligned,
            t_all_s,
            real_missing,
            nyquist_hz,
            height_px,
            has_images: real.record.has_images,
            real_time_shift_s,
            real_cells,
            real_angle,
            runout_form,
            pose_tilt,
            t_det_s,
            theta_det_rad,
            meter: Arc::default(),
            simulator,
        })
    }

    /// This footing counting its simulations into `meter`.
    pub fn with_meter(mut self, meter: Arc<SimMeter>) -> Self {
        self.meter = meter;
        self
    }

    /// What a simulation of this footage needs.
    pub fn sim_context<'a>(&'a self, layout: &'a MarkerLayout) -> SimContext<'a> {
        SimContext {
            simulator: self.simulator,
            aligned: &self.aligned,
            layout,
            with_images: self.has_images,
            nyquist_hz: self.nyquist_hz,
            height_px: self.height_px,
            real_frames: Some(RealFrames {
                t_s: &self.t_all_s,
                missing: &self.real_missing,
            }),
            meter: &self.meter,
        }
    }

    /// The real side of every comparison.
    pub fn real_side(&self) -> RealSide<'_> {
        RealSide {
            cells: &self.real_cells,
            t_s: &self.t_all_s,
            theta_det: (&self.t_det_s, &self.theta_det_rad),
            theta_residual: &self.real_angle.residual_rad,
            theta_peak_hz: self.real_angle.peak_hz,
            runout_form: self.runout_form,
            pose_tilt: self.pose_tilt,
        }
    }

    /// The fitter of a diagnosis of this footage: the aligned nominal at the real frame
    /// times, simulated on `eval_seeds` ([`Fitter::new`]).
    pub fn fitter<'a>(
        &'a self,
        nominal: &'a Scenario,
        layout: &'a MarkerLayout,
        fit_seeds: Vec<u64>,
        eval_seeds: Vec<u64>,
        gap_options: GapOptions,
    ) -> Result<Fitter<'a>, FitError> {
        let base = Fitter::base_trial(&self.aligned, nominal, &self.t_all_s);
        Fitter::new(
            self.sim_context(layout),
            nominal,
            self.real_side(),
            base,
            fit_seeds,
            eval_seeds,
            gap_options,
        )
    }
}
