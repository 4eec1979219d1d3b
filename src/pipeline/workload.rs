//! How much work a job will do, known before any of it is done: frames × pixels, exposure
//! samples, dynamics steps, runs — with a rough time and memory estimate and the limits above
//! which the CLI asks for `--yes`.
//!
//! The estimate is deliberately simple and errs high: time from the per-frame and per-pixel
//! rates of `cargo xtask bench` on the 2-core reference machine (README, Benchmarks), memory
//! from the buffers a run keeps (a full-size canvas and render buffers per worker, a few hundred
//! bytes of results per frame, the dynamics output grid).

use crate::scenario::Scenario;
use crate::timing::TimingModel;
use crate::validation::short;
use std::fmt;

/// Above either limit a job needs an explicit `--yes`.
pub const TIME_LIMIT_S: f64 = 4.0 * 3600.0;
pub const MEMORY_LIMIT_BYTES: f64 = 8e9;

/// Fixed cost of one frame (schedule, detection set-up, estimation, output), s.
const FRAME_OVERHEAD_S: f64 = 4e-3;
/// Pixels rendered and searched per second in a region of interest (one exposure sample).
const ROI_PX_PER_S: f64 = 6e7;
/// Pixels rendered and searched per second on whole frames (one exposure sample).
const FULL_PX_PER_S: f64 = 1e8;
/// Clearance-dynamics steps integrated per second.
const STEPS_PER_S: f64 = 2e7;
/// Bytes kept per frame (detections, truth, per-signal series) and per render worker pixel.
const BYTES_PER_FRAME: f64 = 1024.0;
const BYTES_PER_WORKER_PX: f64 = 6.0;
/// Bytes per dynamics output sample.
const BYTES_PER_DYNAMICS_SAMPLE: f64 = 64.0;

/// The work of `runs` runs of one scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Workload {
    pub runs: f64,
    /// Frames per run (an upper estimate for variable frame rates).
    pub frames: f64,
    pub width_px: usize,
    pub height_px: usize,
    /// Largest number of exposure samples per frame (motion blur), 1 without it.
    pub exposure_samples: f64,
    /// Pixels of the detection window per frame (the whole frame without ROI).
    pub window_px: f64,
    pub dynamics_steps: f64,
    pub dynamics_samples: f64,
    /// Extra memory outside the runs (e.g. a sweep's grid), bytes.
    pub extra_bytes: f64,
    /// Render workers running at once.
    pub workers: f64,
}

impl Workload {
    /// One run of `s`; `roi`: detection in a window around the marker (the default).
    pub fn of(s: &Scenario, roi: bool) -> Workload {
        let fps = s.frame_timing.fps;
        let frames = match (&s.frame_timing.model, &s.timing_log) {
            (TimingModel::Log(_), Some(log)) => log.len() as f64,
            (TimingModel::Vfr(v), _) => s.duration_s * v.actual_fps(fps) + 2.0,
            // Frames k / fps before duration_s: the constant schedule's count.
            _ => s.duration_s * fps,
        }
        .ceil();
        let blur = &s.effects.motion_blur;
        let exposure_samples = match (blur.enabled, blur.samples) {
            (false, _) => 1.0,
            (true, 0) => f64::from(blur.max_samples.max(1)),
            (true, k) => f64::from(k),
        };
        let (w, h) = (s.camera.width_px as usize, s.camera.height_px as usize);
        let full_px = (w * h) as f64;
        let window_px = if roi && s.detector.roi.enabled {
            // The marker's paper in pixels plus the detection margins on each side.
            let paper_mm = s.scene.marker.size_mm + 2.0 * s.scene.marker.white_margin_mm;
            let scale = crate::camera::Camera::new(&s.camera)
                .map(|c| c.image_scale_mm_per_px())
                .unwrap_or(f64::NAN);
            let side = paper_mm / scale + 2.0 * (s.detector.roi.margin_px as f64 + 60.0);
            if side.is_finite() {
                (side * side).min(full_px)
            } else {
                full_px
            }
        } else {
            full_px
        };
        let (dynamics_steps, dynamics_samples) = if s.dynamics.enabled {
            (
                s.duration_s / s.dynamics.step_s,
                s.duration_s / s.dynamics.output_step_s,
            )
        } else {
            (0.0, 0.0)
        };
        Workload {
            runs: 1.0,
            frames,
            width_px: w,
            height_px: h,
            exposure_samples,
            window_px,
            dynamics_steps,
            dynamics_samples,
            extra_bytes: 0.0,
            workers: rayon::current_num_threads() as f64,
        }
    }

    /// `n` runs of this workload.
    pub fn times(mut self, n: f64) -> Workload {
        self.runs *= n;
        self
    }

    pub fn pixels_per_run(&self) -> f64 {
        self.frames * (self.width_px * self.height_px) as f64
    }

    /// Rough wall time on the reference machine, s: every frame found in its detection window
    /// but the first of each run, which is searched whole.
    pub fn time_s(&self) -> f64 {
        let full_px = (self.width_px * self.height_px) as f64;
        let windowed = self.window_px < full_px;
        let rate = if windowed {
            ROI_PX_PER_S
        } else {
            FULL_PX_PER_S
        };
        let per_frame = FRAME_OVERHEAD_S + self.window_px * self.sample_factor() / rate;
        let first = if windowed {
            full_px * self.sample_factor() / FULL_PX_PER_S - self.window_px / rate
        } else {
            0.0
        };
        let per_run = self.frames * per_frame + first.max(0.0) + self.dynamics_steps / STEPS_PER_S;
        self.runs * per_run
    }

    /// The wall time if every frame is searched whole, s: what a run costs when its window
    /// loses the marker (a window that finds nothing is searched again in the whole frame).
    pub fn time_all_frames_whole_s(&self) -> f64 {
        let full_px = (self.width_px * self.height_px) as f64;
        let per_frame = FRAME_OVERHEAD_S + full_px * self.sample_factor() / FULL_PX_PER_S;
        self.runs * (self.frames * per_frame + self.dynamics_steps / STEPS_PER_S)
    }

    /// Each extra exposure sample re-renders the moving layers; detection runs once.
    fn sample_factor(&self) -> f64 {
        1.0 + (self.exposure_samples - 1.0) / 8.0
    }

    /// Rough peak memory, bytes.
    pub fn memory_bytes(&self) -> f64 {
        let full_px = (self.width_px * self.height_px) as f64;
        let per_run = self.frames * BYTES_PER_FRAME
            + self.dynamics_samples * BYTES_PER_DYNAMICS_SAMPLE
            + full_px * BYTES_PER_WORKER_PX;
        // Parallel runs (sweeps, Monte Carlo) each hold their own; one run uses every worker.
        let parallel = self.workers.min(self.runs).max(1.0);
        per_run * parallel
            + full_px * BYTES_PER_WORKER_PX * (self.workers - 1.0).max(0.0)
            + self.extra_bytes
    }

    /// Why this job needs `--yes`, if it does.
    pub fn over_limits(&self) -> Option<String> {
        let (t, m) = (self.time_s(), self.memory_bytes());
        let mut why = Vec::new();
        if t.is_nan() || t > TIME_LIMIT_S {
            why.push(format!(
                "about {} (limit {})",
                duration(t),
                duration(TIME_LIMIT_S)
            ));
        }
        if m.is_nan() || m > MEMORY_LIMIT_BYTES {
            why.push(format!(
                "about {} of memory (limit {})",
                bytes(m),
                bytes(MEMORY_LIMIT_BYTES)
            ));
        }
        (!why.is_empty()).then(|| why.join(" and "))
    }
}

fn duration(s: f64) -> String {
    match s {
        s if !s.is_finite() => "forever".into(),
        s if s < 10.0 => format!("{s:.1} s"),
        s if s < 120.0 => format!("{s:.0} s"),
        s if s < 7200.0 => format!("{:.0} min", s / 60.0),
        s if s < 2.0 * 86400.0 => format!("{:.1} h", s / 3600.0),
        s if s < 1e4 * 86400.0 => format!("{:.0} days", s / 86400.0),
        s => format!("{:.1e} days", s / 86400.0),
    }
}

fn bytes(b: f64) -> String {
    match b {
        b if !b.is_finite() => "unbounded".into(),
        b if b < 1e6 => format!("{:.0} kB", b / 1e3),
        b if b < 1e9 => format!("{:.0} MB", b / 1e6),
        b if b < 1e13 => format!("{:.1} GB", b / 1e9),
        b => format!("{:.1e} GB", b / 1e9),
    }
}

impl fmt::Display for Workload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.runs != 1.0 {
            write!(f, "{} runs of ", short(self.runs))?;
        }
        write!(
            f,
            "{} frames of {}x{} px ({} Mpx per run), up to {} exposure sample(s) per frame",
            short(self.frames),
            self.width_px,
            self.height_px,
            short((self.pixels_per_run() / 1e5).round() / 10.0),
            short(self.exposure_samples)
        )?;
        if self.dynamics_steps > 0.0 {
            write!(
                f,
                ", {} dynamics steps",
                short((self.dynamics_steps / 1e3).round() * 1e3)
            )?;
        }
        let (t, whole) = (self.time_s(), self.time_all_frames_whole_s());
        if whole > 1.5 * t {
            write!(
                f,
                "; estimated {} (up to {} if frames must be searched whole) and {} (rough, \
                 reference machine)",
                duration(t),
                duration(whole),
                bytes(self.memory_bytes())
            )
        } else {
            write!(
                f,
                "; estimated {} and {} (rough, reference machine)",
                duration(t),
                bytes(self.memory_bytes())
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::{from_str, load_builtin};
    use std::path::Path;

    /// A huge frame with a small marker: estimated 0.3 s when only the windows were counted,
    /// it ran 25 s (half its 8000×8000 frames searched whole). The first frame of every run is
    /// searched whole, and the estimate states what every frame searched whole would cost.
    #[test]
    fn the_first_frame_is_searched_whole_and_the_whole_frame_cost_is_stated() {
        let mut s = crate::scenario::load_any("fast").unwrap();
        s.camera.width_px = 8000;
        s.camera.height_px = 8000;
        let w = Workload::of(&s, true);
        assert!(w.window_px < 64e6);
        let one_whole_frame_s = 64e6 / FULL_PX_PER_S;
        assert!(w.time_s() > one_whole_frame_s, "{w}");
        let whole = w.time_all_frames_whole_s();
        assert!(whole > w.frames * one_whole_frame_s, "{w}");
        assert!(
            w.to_string().contains("if frames must be searched whole"),
            "{w}"
        );
        let no_roi = Workload::of(&s, false);
        assert_eq!(no_roi.time_s(), no_roi.time_all_frames_whole_s());
    }

    #[test]
    fn small_runs_pass_and_huge_ones_need_confirmation() {
        let fast = Workload::of(&load_builtin("fast").unwrap(), true);
        assert_eq!(fast.frames, 60.0);
        assert_eq!((fast.width_px, fast.height_px), (1280, 720));
        assert!(fast.over_limits().is_none(), "{fast}");
        assert!(fast.time_s() < 10.0 && fast.memory_bytes() < 1e9, "{fast}");
        // Every field in range, but an hour at 10 kHz of 20000x20000 frames.
        let huge = from_str(
            "extend = \"fast\"\nduration_s = 3600.0\nframe_timing.fps = 10000.0\n\
             camera.width_px = 20000\ncamera.height_px = 20000\n",
            Path::new("huge.toml"),
        )
        .unwrap();
        let w = Workload::of(&huge, true);
        let why = w.over_limits().expect("refused");
        assert!(why.contains("limit"), "{why}");
        // An hour of the clearance dynamics at the smallest step.
        let steps = from_str(
            "extend = \"seed-internal-4k\"\nduration_s = 3600.0\ndynamics.step_s = 1e-7\n\
             dynamics.output_step_s = 1e-7\n",
            Path::new("steps.toml"),
        )
        .unwrap();
        let w = Workload::of(&steps, true);
        assert_eq!(w.dynamics_steps, 3.6e10);
        assert!(w.over_limits().is_some(), "{w}");
        // A sweep of a million runs of `fast`.
        assert!(fast.clone().times(1e6).over_limits().is_some());
    }

    #[test]
    fn estimates_print_short_numbers() {
        let w = Workload::of(&load_builtin("fast").unwrap(), true);
        let text = w.to_string();
        assert!(text.starts_with("60 frames of 1280x720 px"), "{text}");
        assert!(duration(1e300).ends_with("days") && duration(1e300).len() < 20);
        assert_eq!(bytes(2.5e9), "2.5 GB");
    }
}
