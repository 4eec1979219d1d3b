//! Simulated measurements for the diagnosis: the aligned nominal (or a candidate) rendered at
//! the real frame times by a [`Simulator`], and turned into the same cells as the real
//! measurement. Seeds are shared by every configuration (common random numbers), so two
//! configurations differ by their settings, not by a new draw.

use super::nominal::{motion_reference, Aligned};
use super::simulator::{SimMeter, SimulateError, Simulator};
use crate::diagnose::cells::{
    angle_residual, detected_angle, image_cells, missing_cells, residual, timing_cells,
    track_cells, Cells, MotionReference,
};
use crate::diagnose::record::Record;
use crate::estimate::{estimate, Estimate};
use crate::imagestats::MarkerLayout;
use crate::scenario::Scenario;
use crate::timing::{FrameTimingConfig, Timestamps};
use std::borrow::Cow;

/// Where a configuration's footage timestamps come from (the timing channels).
#[derive(Debug, Clone)]
pub enum TimingSource {
    /// Draws of a frame-timing model (a log model gives the log itself).
    Model {
        config: FrameTimingConfig,
        log: Option<Timestamps>,
        duration_s: f64,
    },
    /// The recorder wrote k / fps (the `timebase` hypothesis).
    ConstantRate { fps_hz: f64, frames: usize },
}

impl TimingSource {
    pub fn times(&self, seed: u64) -> Option<Vec<f64>> {
        match self {
            TimingSource::Model {
                config,
                log,
                duration_s,
            } => config
                .schedule(*duration_s, seed, log.as_ref())
                .ok()
                .map(|t| t.into_vec()),
            TimingSource::ConstantRate { fps_hz, frames } => {
                Some((0..*frames).map(|k| k as f64 / fps_hz).collect())
            }
        }
    }
}

/// One configuration to simulate: the scenario rendered (at its own frame schedule) and
/// measured, the analysis times when they differ from the render times, and the timing source.
#[derive(Debug, Clone)]
pub struct Trial {
    pub scenario: Scenario,
    /// The footage's timestamps are k / fps (the `timebase` hypothesis: frames were taken on the
    /// scenario's own schedule but stamped at a constant rate); `None`: the render times.
    pub stamped_fps: Option<f64>,
    pub timing: TimingSource,
}

/// Everything fixed across simulations of one diagnosis.
#[derive(Clone, Copy)]
pub struct SimContext<'a> {
    /// Renders and detects the frames.
    pub simulator: &'a dyn Simulator,
    pub aligned: &'a Aligned,
    pub layout: &'a MarkerLayout,
    pub with_images: bool,
    pub nyquist_hz: f64,
    pub height_px: f64,
    /// The real footage's frame times, s, and which of its frames have no detection: a
    /// simulation loses those frames too before it is measured ([`lost_like_real`]).
    pub real_frames: Option<RealFrames<'a>>,
    /// Counts every simulation run in this context.
    pub meter: &'a SimMeter,
}

/// The real footage's frame times and its frames without a detection, in frame order.
#[derive(Clone, Copy)]
pub struct RealFrames<'a> {
    pub t_s: &'a [f64],
    pub missing: &'a [bool],
}

/// Which of a simulation's frames, at times `sim_t_s`, fall on a real frame without a detection:
/// the real frame nearest in time, when it lies within half the footage's median interval
/// `median_dt_s` (a trial on another schedule, a frame the footage dropped, matches none).
/// Both time lists are in increasing order.
pub fn lost_like_real(sim_t_s: &[f64], real: RealFrames<'_>, median_dt_s: f64) -> Vec<bool> {
    let tol_s = 0.5 * median_dt_s;
    sim_t_s
        .iter()
        .map(|&t| {
            let i = real.t_s.partition_point(|&r| r < t);
            let nearest = [i.checked_sub(1), Some(i)]
                .into_iter()
                .flatten()
                .filter(|&k| k < real.t_s.len())
                .min_by(|&a, &b| (real.t_s[a] - t).abs().total_cmp(&(real.t_s[b] - t).abs()));
            nearest.is_some_and(|k| {
                (real.t_s[k] - t).abs() < tol_s && real.missing.get(k).copied().unwrap_or(false)
            })
        })
        .collect()
}

/// The estimate of a record with `scenario`'s estimator.
pub fn estimate_record(scenario: &Scenario, record: &Record) -> Result<Estimate, SimulateError> {
    let with_reference = record.has_reference
        && scenario.estimator.reference_compensation != crate::estimate::ReferenceCompensation::Off;
    let refs = record.references();
    estimate(
        &scenario.estimator,
        &record.t_s(),
        &record.corners(),
        with_reference.then_some(refs.as_slice()),
    )
    .map_err(SimulateError::Estimate)
}

/// Track and image cells of a record measured with `scenario`'s estimator.
pub fn measurement_cells(
    ctx: &SimContext<'_>,
    scenario: &Scenario,
    record: &Record,
) -> Result<Cells, SimulateError> {
    let (record, own_missing) = masked_like_real(ctx, record);
    let est = estimate_record(scenario, &record)?;
    let (reference, _) = motion_reference(&ctx.aligned.reference, &record, &est);
    let mut cells = cells_of(ctx, &record, &est, &reference);
    if let Some(own) = own_missing {
        cells.extend(missing_cells(&own, &reference.phase));
    }
    Ok(cells)
}

/// `record` with the frames the real footage lost taken out too ([`lost_like_real`]), and its
/// own frames without a detection before that; the record itself, and no list, when the
/// footage lost no frame (nothing to take out, and its `missing` cells are already its own).
///
/// A detector loses the frames it cannot read, and which those are depends on how the footage
/// was drawn: heavy smear on another renderer lost 8 of the 9 frames at each drive's peak speed
/// where the simulation lost 6 %. Measured on different frames, the two differ where nothing
/// but the frame selection differs: ω and α differentiated across the footage's gaps, edge
/// widths read on its slower frames (the exposure fitted 17 % low). Measured on the same
/// frames they compare like with like; the `missing` cells keep each side's own losses.
fn masked_like_real<'r>(
    ctx: &SimContext<'_>,
    record: &'r Record,
) -> (Cow<'r, Record>, Option<Vec<bool>>) {
    let Some(real) = ctx.real_frames.filter(|r| r.missing.iter().any(|&m| m)) else {
        return (Cow::Borrowed(record), None);
    };
    let own: Vec<bool> = record
        .frames
        .iter()
        .map(|f| f.corners_px.is_none())
        .collect();
    let mut out = record.clone();
    let lost = lost_like_real(&record.t_s(), real, 0.5 / ctx.nyquist_hz);
    for (f, lost) in out.frames.iter_mut().zip(lost) {
        // The moving marker's corners and the image statistics read around them; a static
        // reference marker is found or lost on its own, as the footage's was.
        if lost {
            f.corners_px = None;
            f.image = None;
        }
    }
    (Cow::Owned(out), Some(own))
}

/// Track and image cells of a record, its estimate and the motion reference it is read against.
fn cells_of(
    ctx: &SimContext<'_>,
    record: &Record,
    est: &Estimate,
    reference: &MotionReference,
) -> Cells {
    let mut cells = track_cells(record, est, reference, ctx.nyquist_hz, ctx.height_px);
    cells.extend(image_cells(
        record,
        ctx.aligned.geometry.rotation_centre_px,
        &reference.phase,
        ctx.nyquist_hz,
        ctx.height_px,
    ));
    cells
}

/// Draws the sub-pixel placement of the marker for one seed: the rotation centre moves by up to
/// ±½ px in x and y and the marker by up to ±½ px along its arc. Alignment knows positions only
/// to a fraction of a pixel, and corner quantisation (most of the detection error of a still
/// marker) depends on exactly that fraction, so the seeds must sample it.
pub fn jitter_placement(s: &mut Scenario, seed: u64, marker_radius_px: f64) {
    use rand::Rng;
    let mut r = crate::rng::stream(seed, crate::rng::Stream::DiagnoseNuisance, 0);
    let (u, v, w): (f64, f64, f64) = (r.gen(), r.gen(), r.gen());
    if let Some(c) = s.camera.rotation_centre_px.as_mut() {
        c[0] += u - 0.5;
        c[1] += v - 0.5;
    }
    if marker_radius_px > 1.0 {
        s.scene.marker.angle_on_disc_deg += ((w - 0.5) / marker_radius_px).to_degrees();
    }
}

/// The record of `trial` on `seed`, and the scenario it was simulated with (the seed and the
/// placement jitter applied; frames re-stamped at a constant rate when the trial says so).
fn trial_record(
    ctx: &SimContext<'_>,
    trial: &Trial,
    seed: u64,
    images: bool,
) -> Result<(Scenario, Record), SimulateError> {
    let mut s = trial.scenario.clone();
    s.seed = seed;
    jitter_placement(&mut s, seed, ctx.aligned.geometry.marker_radius_px);
    let mut record = ctx
        .simulator
        .record(&s, ctx.layout, ctx.with_images && images)?;
    ctx.meter.count(1);
    if let Some(fps) = trial.stamped_fps {
        for (k, f) in record.frames.iter_mut().enumerate() {
            f.t_s = k as f64 / fps;
        }
    }
    Ok((s, record))
}

/// A simulated footage measured as the real one is (as `pipeline::diagnose::real` and the
/// diagnosis's prefix measure it): its cells, frame times, the angle of its detected frames and
/// its angle residual after the aligned nominal motion, with that residual's spectral peak.
pub struct SimulatedFootage {
    pub cells: Cells,
    pub t_s: Vec<f64>,
    pub t_det_s: Vec<f64>,
    pub theta_det_rad: Vec<f64>,
    pub theta_residual: Vec<f64>,
    pub theta_peak_hz: Option<f64>,
}

/// `trial` on one data `seed`, measured as real footage: the cells are exactly
/// [`trial_cells`]'s for that seed, the residual [`trial_theta_residuals`]'s.
pub fn simulated_footage(
    ctx: &SimContext<'_>,
    trial: &Trial,
    seed: u64,
) -> Result<SimulatedFootage, SimulateError> {
    let (s, record) = trial_record(ctx, trial, seed, true)?;
    let (record, own_missing) = masked_like_real(ctx, &record);
    let est = estimate_record(&s, &record)?;
    let (reference, _) = motion_reference(&ctx.aligned.reference, &record, &est);
    let mut cells = cells_of(ctx, &record, &est, &reference);
    if let Some(own) = own_missing {
        cells.extend(missing_cells(&own, &reference.phase));
    }
    if let Some(t) = trial.timing.times(seed) {
        cells.extend(timing_cells(&t));
    }
    let t_s = record.t_s();
    let theta = &est.primary_series().theta_rad;
    let angle = angle_residual(&t_s, theta, &reference.theta_rad, ctx.nyquist_hz);
    let (t_det_s, theta_det_rad) = detected_angle(&t_s, theta);
    Ok(SimulatedFootage {
        cells,
        t_s,
        t_det_s,
        theta_det_rad,
        theta_residual: angle.residual_rad,
        theta_peak_hz: angle.peak_hz,
    })
}

/// Cells of `trial` for each of `seeds` (seeds and frames in parallel, results in the seeds'
/// order). `images: false` skips the image statistics (when nothing that uses them is compared).
pub fn trial_cells(
    ctx: &SimContext<'_>,
    trial: &Trial,
    seeds: &[u64],
    images: bool,
) -> Result<Vec<Cells>, SimulateError> {
    per_seed(seeds, |seed| {
        let (s, record) = trial_record(ctx, trial, seed, images)?;
        let mut cells = measurement_cells(ctx, &s, &record)?;
        if let Some(t) = trial.timing.times(seed) {
            cells.extend(timing_cells(&t));
        }
        Ok(cells)
    })
}

/// `job` on each seed, all at once (rayon), the results in the seeds' order and the first
/// error in that order: the same whatever the thread count.
///
/// Why not one seed after the other: each simulation ends in serial work (the estimator, the
/// cells) that leaves a core idle beside a fit running alone; the next seed's frames fill it.
fn per_seed<T: Send, E: Send>(
    seeds: &[u64],
    job: impl Fn(u64) -> Result<T, E> + Sync,
) -> Result<Vec<T>, E> {
    use rayon::prelude::*;
    let results: Vec<Result<T, E>> = seeds.par_iter().map(|&seed| job(seed)).collect();
    results.into_iter().collect()
}

/// A series sampled at frame times: (times in s, values; NaN where the marker was not found).
pub type FrameSeries = (Vec<f64>, Vec<f64>);

/// The angle residual after the aligned nominal motion, rad, of `trial` on each of `seeds`: the
/// series the `theta` cells are computed from, measured exactly as the real footage's.
pub fn trial_theta_residuals(
    ctx: &SimContext<'_>,
    trial: &Trial,
    seeds: &[u64],
) -> Result<Vec<FrameSeries>, SimulateError> {
    per_seed(seeds, |seed| {
        let (s, record) = trial_record(ctx, trial, seed, false)?;
        let (record, _) = masked_like_real(ctx, &record);
        let est = estimate_record(&s, &record)?;
        let (reference, _) = motion_reference(&ctx.aligned.reference, &record, &est);
        Ok((
            record.t_s(),
            residual(&est.primary_series().theta_rad, &reference.theta_rad),
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_run_at_once_keep_their_order_and_the_first_error_in_it() {
        let job = |seed: u64| -> Result<u64, u64> {
            // Later seeds finish first, so completion order is not seed order.
            std::thread::sleep(std::time::Duration::from_millis(20 - seed));
            if seed % 5 == 3 {
                Err(seed)
            } else {
                Ok(seed * seed)
            }
        };
        for threads in [1, 4] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let ok = pool.install(|| per_seed(&[4, 0, 2, 1], job)).unwrap();
            assert_eq!(ok, vec![16, 0, 4, 1], "{threads} threads");
            let first = pool.install(|| per_seed(&[1, 8, 2, 3, 13], job));
            assert!(first == Err(8), "{threads} threads: {first:?}");
        }
    }

    #[test]
    fn a_simulated_frame_is_lost_where_the_nearest_real_frame_was_lost() {
        let real_t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let missing = [false, true, false, true, false];
        let real = RealFrames {
            t_s: &real_t,
            missing: &missing,
        };
        // The same schedule: frame for frame.
        assert_eq!(lost_like_real(&real_t, real, 1.0), missing.to_vec());
        // Another schedule: each simulated frame takes its nearest real frame's fate, within
        // half an interval; a frame between two real ones, or past their end, takes none.
        let sim_t = [0.1, 0.9, 1.45, 1.55, 2.6, 3.4, 4.2, 9.0, -3.0];
        assert_eq!(
            lost_like_real(&sim_t, real, 1.0),
            vec![false, true, true, false, true, true, false, false, false]
        );
        // A real frame exactly half an interval away is not the same frame.
        assert_eq!(lost_like_real(&[1.5], real, 1.0), vec![false]);
        assert!(lost_like_real(&[], real, 1.0).is_empty());
        // A loss list shorter than the times (no caller builds one) counts the rest as kept.
        let short = RealFrames {
            t_s: &real_t,
            missing: &missing[..2],
        };
        assert_eq!(lost_like_real(&[1.0, 3.0], short, 1.0), vec![true, false]);
    }
}
