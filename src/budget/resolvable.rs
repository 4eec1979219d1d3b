//! Resolvable truth: what a camera at the footage's frame rate can follow of the motion, frame by
//! frame, and the aliasing part that no camera at that rate can. Pure numbers: the truth comes in
//! as a function θ2(t), the frames as instants.
//!
//! Definition (the one place it is written in full is docs/resolvable-truth.md):
//! for frame k with timestamp t_k, let τ_k be the centre of the marker's exposure in that frame
//! (timestamp convention and rolling-shutter row time included), E the exposure time, h̃ the
//! median frame interval and f_N = 1/(2h̃) the footage's Nyquist rate. Then
//!
//! * resolvable truth  q_res,k = (g ∗ b_E ∗ q)(τ_k) for q ∈ {θ2, ω2, α2},
//! * band-limited raw  q_bl,k  = (g ∗ q)(t_k),   aliasing part a_k = q(t_k) − q_bl,k,
//!
//! with b_E the unit box of width E (the exposure average; the identity when E = 0) and g a
//! zero-phase low-pass: a sinc with half amplitude at f_N under a Blackman window of
//! [`WINDOW_FRAMES`]·h̃ (flat within 0.2 % up to 0.85 f_N, below 0.2 % from 1.15 f_N on),
//! normalised to unit gain at 0 Hz.
//!
//! ω and α are never sampled: since the filters commute with differentiation,
//! q_res = (c ∗ θ)(τ), (c′ ∗ θ)(τ), (c″ ∗ θ)(τ) with c = g ∗ b_E, evaluated as Riemann sums over
//! θ2 sampled once on a uniform grid of h̃/[`STEPS_PER_FRAME`] (θ is the smoothest of the three,
//! so impacts shorter than a grid step still enter through their effect on θ). The kernels are
//! tabulated finely and the discrete weights at each instant are corrected to the continuous
//! kernels' moments (∫c = 1, ∫c·u = 0; ∫c′ = 0, ∫c′·u = −1, ∫c′·u² = 0; ∫c″ = 0, ∫c″·u = 0,
//! ∫c″·u² = 2),
//! so constant, linear and quadratic motion come out exact. A frame whose kernel reaches outside
//! the span where the truth is known gets NaN.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Length of the filter window in median frame intervals.
pub const WINDOW_FRAMES: f64 = 32.0;
/// Grid steps per median frame interval for the convolution sums.
pub const STEPS_PER_FRAME: f64 = 32.0;
/// How the filter is described in `budget.json`.
pub const FILTER: &str = "zero-phase sinc, half amplitude at the Nyquist rate, Blackman window of 32 median frame intervals";

/// The frames to resolve and what the truth covers.
#[derive(Debug, Clone, Copy)]
pub struct FrameInstants<'a> {
    /// Each frame's timestamp t_k, s, strictly increasing.
    pub timestamps_s: &'a [f64],
    /// Centre of the marker's exposure in each frame τ_k, s.
    pub marker_centres_s: &'a [f64],
    /// Exposure time E, s (0: instantaneous frames).
    pub exposure_s: f64,
    /// Times where the truth function is known: [start, end], s (either may be infinite).
    pub truth_span_s: (f64, f64),
}

/// The parameters of a resolvable truth, as written to `budget.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResolvableInfo {
    pub filter: String,
    /// f_N = 1/(2·median frame interval), Hz.
    pub nyquist_hz: f64,
    pub median_interval_s: f64,
    pub exposure_s: f64,
    /// Filter window length, s.
    pub window_s: f64,
    /// Frames whose filter window lies where the truth is known (the others have none).
    pub frames_defined: usize,
    /// Delay from a frame's timestamp to the centre of the marker's exposure (timestamp
    /// convention and rolling shutter): mean, smallest and largest over the frames, s.
    pub marker_delay_mean_s: f64,
    pub marker_delay_min_s: f64,
    pub marker_delay_max_s: f64,
}

/// Per frame: the resolvable truth and the band-limited raw truth (NaN where undefined).
#[derive(Debug, Clone, PartialEq)]
pub struct Resolvable {
    pub info: ResolvableInfo,
    pub theta2_rad: Vec<f64>,
    pub omega2_rad_s: Vec<f64>,
    pub alpha2_rad_s2: Vec<f64>,
    /// θ2 averaged over each frame's exposure of the marker, not band-limited (b_E ∗ θ2)(τ_k):
    /// what each frame shows, the reference of its detection error.
    pub frame_theta2_rad: Vec<f64>,
    /// (g ∗ q)(t_k) for θ2, ω2, α2: the raw truth minus these is the aliasing part.
    pub band_limited_theta2_rad: Vec<f64>,
    pub band_limited_omega2_rad_s: Vec<f64>,
    pub band_limited_alpha2_rad_s2: Vec<f64>,
}

pub use crate::timing::median_interval_s;

/// sin(a·u)/(π·u) and its first two derivatives (Taylor series near 0).
fn sinc_derivatives(a: f64, u: f64) -> [f64; 3] {
    let x = a * u;
    let k = a / std::f64::consts::PI;
    if x.abs() < 1e-3 {
        let x2 = x * x;
        return [
            k * (1.0 - x2 / 6.0 + x2 * x2 / 120.0),
            k * a * (-x / 3.0 + x * x2 / 30.0),
            k * a * a * (-1.0 / 3.0 + x2 / 10.0),
        ];
    }
    let (s, c) = x.sin_cos();
    let pi = std::f64::consts::PI;
    [
        s / (pi * u),
        (x * c - s) / (pi * u * u),
        (-x * x * s - 2.0 * x * c + 2.0 * s) / (pi * u * u * u),
    ]
}

/// Blackman window over [−T/2, T/2] and its first two derivatives (0 outside).
fn blackman_derivatives(window_s: f64, u: f64) -> [f64; 3] {
    if u.abs() > 0.5 * window_s {
        return [0.0; 3];
    }
    let b = 2.0 * std::f64::consts::PI / window_s;
    let (s1, c1) = (b * u).sin_cos();
    let (s2, c2) = (2.0 * b * u).sin_cos();
    [
        0.42 + 0.5 * c1 + 0.08 * c2,
        -0.5 * b * s1 - 0.16 * b * s2,
        -0.5 * b * b * c1 - 0.32 * b * b * c2,
    ]
}

/// g, g′, g″ of the windowed sinc with cutoff `nyquist_hz` (before normalisation).
fn low_pass(nyquist_hz: f64, window_s: f64, u: f64) -> [f64; 3] {
    let w = blackman_derivatives(window_s, u);
    if w == [0.0; 3] {
        return w;
    }
    let s = sinc_derivatives(2.0 * std::f64::consts::PI * nyquist_hz, u);
    [
        s[0] * w[0],
        s[1] * w[0] + s[0] * w[1],
        s[2] * w[0] + 2.0 * s[1] * w[1] + s[0] * w[2],
    ]
}

/// Gauss–Legendre nodes and weights on [−1, 1], 4 points.
const GL4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
];

/// Table entries per convolution grid step (the kernels are interpolated linearly between).
const TABLE_PER_STEP: usize = 16;

/// c = g ∗ b_E and its first two derivatives, tabulated on [−reach, reach].
#[derive(Debug, Clone)]
struct KernelTable {
    reach_s: f64,
    dx_s: f64,
    values: [Vec<f64>; 3],
}

impl KernelTable {
    fn new(nyquist_hz: f64, window_s: f64, exposure_s: f64, dx_s: f64) -> Self {
        let reach_s = 0.5 * (window_s + exposure_s);
        let n = (reach_s / dx_s).ceil() as usize;
        // Panels of at most 1/16 of a frame interval keep the box average of the smooth g exact
        // to rounding.
        let panels = if exposure_s > 0.0 {
            ((exposure_s * 32.0 * nyquist_hz).ceil() as usize).max(1)
        } else {
            0
        };
        let at = |u: f64| -> [f64; 3] {
            if panels == 0 {
                return low_pass(nyquist_hz, window_s, u);
            }
            let width = exposure_s / panels as f64;
            let mut acc = [0.0; 3];
            for p in 0..panels {
                let mid = -0.5 * exposure_s + (p as f64 + 0.5) * width;
                for (x, w) in GL4 {
                    let v = low_pass(nyquist_hz, window_s, u - (mid + 0.5 * width * x));
                    for (a, v) in acc.iter_mut().zip(v) {
                        *a += 0.5 * w * v / panels as f64;
                    }
                }
            }
            acc
        };
        let rows: Vec<[f64; 3]> = (0..=2 * n)
            .into_par_iter()
            .map(|i| at((i as f64 - n as f64) * dx_s))
            .collect();
        KernelTable {
            reach_s: n as f64 * dx_s,
            dx_s,
            values: [0, 1, 2].map(|d| rows.iter().map(|r| r[d]).collect()),
        }
    }

    /// The d-th derivative at offset `u` (0 outside the table).
    fn at(&self, d: usize, u: f64) -> f64 {
        let x = (u + self.reach_s) / self.dx_s;
        let v = &self.values[d];
        if !(x >= 0.0 && x <= (v.len() - 1) as f64) {
            return 0.0;
        }
        let i = (x.floor() as usize).min(v.len() - 2);
        let f = x - i as f64;
        v[i] + f * (v[i + 1] - v[i])
    }
}

/// θ2 sampled on a uniform grid.
#[derive(Debug, Clone)]
struct ThetaGrid {
    t0_s: f64,
    step_s: f64,
    theta2_rad: Vec<f64>,
}

impl ThetaGrid {
    fn end_s(&self) -> f64 {
        self.t0_s + (self.theta2_rad.len().max(1) - 1) as f64 * self.step_s
    }

    /// [θ, ω, α] of (c ∗ θ) at `tau`, or NaN when the kernel leaves the grid. The discrete
    /// weights are corrected to the continuous kernels' moments (∫c = 1, ∫c·u = 0; ∫c′ = 0,
    /// ∫c′·u = −1, ∫c′·u² = 0; ∫c″ = 0, ∫c″·u = 0, ∫c″·u² = 2, with u = τ − t), and the sums run on
    /// θ − θ(nearest grid point) so a large accumulated angle loses no digits.
    fn filter(&self, table: &KernelTable, tau: f64) -> [f64; 3] {
        if tau - table.reach_s < self.t0_s || tau + table.reach_s > self.end_s() {
            return [f64::NAN; 3];
        }
        let first = ((tau - table.reach_s - self.t0_s) / self.step_s)
            .floor()
            .max(0.0) as usize;
        let last = (((tau + table.reach_s - self.t0_s) / self.step_s).ceil() as usize)
            .min(self.theta2_rad.len() - 1);
        let idx: Vec<usize> = (first..=last).collect();
        let u: Vec<f64> = idx
            .iter()
            .map(|&i| tau - (self.t0_s + i as f64 * self.step_s))
            .collect();
        let h = self.step_s;
        let weights = |d: usize| -> Vec<f64> { u.iter().map(|&x| table.at(d, x) * h).collect() };
        let dot = |w: &[f64], p: i32| -> f64 { w.iter().zip(&u).map(|(w, x)| w * x.powi(p)).sum() };
        let mut w0 = weights(0);
        let s0 = dot(&w0, 0);
        w0.iter_mut().for_each(|w| *w /= s0);
        // ∫c′ = 0, then ∫c′·u = −1.
        let mut w1 = weights(1);
        let s = dot(&w1, 0);
        w1.iter_mut().zip(&w0).for_each(|(a, b)| *a -= s * b);
        let s = -dot(&w1, 1);
        w1.iter_mut().for_each(|w| *w /= s);
        // ∫c″ = 0 and ∫c″·u = 0, then ∫c″·u² = 2.
        let mut w2 = weights(2);
        let a = dot(&w2, 0);
        w2.iter_mut().zip(&w0).for_each(|(x, y)| *x -= a * y);
        let b = dot(&w2, 1);
        w2.iter_mut().zip(&w1).for_each(|(x, y)| *x += b * y);
        let s = 0.5 * dot(&w2, 2);
        w2.iter_mut().for_each(|w| *w /= s);
        // ∫c′·u² = 0 (w2 leaves the lower moments alone), then ∫c·u = 0 (w1 now leaves the
        // second moment alone).
        let m = 0.5 * dot(&w1, 2);
        w1.iter_mut().zip(&w2).for_each(|(x, y)| *x -= m * y);
        let m = dot(&w0, 1);
        w0.iter_mut().zip(&w1).for_each(|(x, y)| *x += m * y);
        let near = ((tau - self.t0_s) / self.step_s)
            .round()
            .clamp(0.0, (self.theta2_rad.len() - 1) as f64) as usize;
        let reference = self.theta2_rad[near];
        let sum = |w: &[f64]| -> f64 {
            w.iter()
                .zip(&idx)
                .map(|(w, &i)| w * (self.theta2_rad[i] - reference))
                .sum()
        };
        [reference + sum(&w0), sum(&w1), sum(&w2)]
    }
}

/// The filters of one footage and the truth they read: evaluates the resolvable truth at any
/// instant (for plots), the same way as for the frames.
#[derive(Debug, Clone)]
pub struct ResolvableFilter {
    grid: ThetaGrid,
    exposed: KernelTable,
}

impl ResolvableFilter {
    /// (g ∗ b_E ∗ q)(t + delay_s) for θ2, ω2, α2 at each of `times_s` (NaN outside the truth).
    pub fn curve(&self, times_s: &[f64], delay_s: f64) -> [Vec<f64>; 3] {
        let v: Vec<[f64; 3]> = times_s
            .par_iter()
            .map(|&t| self.grid.filter(&self.exposed, t + delay_s))
            .collect();
        [0, 1, 2].map(|d| v.iter().map(|x| x[d]).collect())
    }
}

/// (1/E)∫θ over [τ − E/2, τ + E/2] by Gauss–Legendre on panels of at most `panel_s` (θ(τ) for
/// E = 0; NaN for a non-finite frame interval).
fn exposure_average(
    theta2_at: &(dyn Fn(f64) -> f64 + Sync),
    tau: f64,
    exposure_s: f64,
    panel_s: f64,
) -> f64 {
    if exposure_s <= 0.0 {
        return theta2_at(tau);
    }
    if !panel_s.is_finite() || panel_s <= 0.0 {
        return f64::NAN;
    }
    let panels = (exposure_s / panel_s).ceil().max(1.0) as usize;
    let width = exposure_s / panels as f64;
    let mut acc = 0.0;
    for p in 0..panels {
        let mid = tau - 0.5 * exposure_s + (p as f64 + 0.5) * width;
        for (x, w) in GL4 {
            acc += 0.5 * w * theta2_at(mid + 0.5 * width * x);
        }
    }
    acc / panels as f64
}

/// The resolvable and band-limited truth of every frame (see the module documentation).
pub fn resolvable_truth(
    theta2_at: &(dyn Fn(f64) -> f64 + Sync),
    frames: &FrameInstants<'_>,
) -> (Resolvable, Option<ResolvableFilter>) {
    let n = frames.timestamps_s.len();
    let h = median_interval_s(frames.timestamps_s);
    let nyquist_hz = 0.5 / h;
    let window_s = WINDOW_FRAMES * h;
    let exposure_s = frames.exposure_s.max(0.0);
    let delays: Vec<f64> = frames
        .timestamps_s
        .iter()
        .zip(frames.marker_centres_s)
        .map(|(t, c)| c - t)
        .collect();
    let mut info = ResolvableInfo {
        filter: FILTER.to_string(),
        nyquist_hz,
        median_interval_s: h,
        exposure_s,
        window_s,
        frames_defined: 0,
        marker_delay_mean_s: delays.iter().sum::<f64>() / n.max(1) as f64,
        marker_delay_min_s: delays.iter().copied().fold(f64::INFINITY, f64::min),
        marker_delay_max_s: delays.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    };
    let nan = vec![f64::NAN; n];
    // What each frame shows: θ averaged over the marker's exposure, from the same motion the
    // renderer drew (so wherever the motion function answers, also before t = 0).
    let frame_theta2_rad: Vec<f64> = frames
        .marker_centres_s
        .par_iter()
        .map(|&tau| exposure_average(theta2_at, tau, exposure_s, h / STEPS_PER_FRAME))
        .collect();
    let undefined = |info: ResolvableInfo| Resolvable {
        info,
        frame_theta2_rad: frame_theta2_rad.clone(),
        theta2_rad: nan.clone(),
        omega2_rad_s: nan.clone(),
        alpha2_rad_s2: nan.clone(),
        band_limited_theta2_rad: nan.clone(),
        band_limited_omega2_rad_s: nan.clone(),
        band_limited_alpha2_rad_s2: nan.clone(),
    };
    if !h.is_finite() || h <= 0.0 {
        return (undefined(info), None);
    }
    let step_s = h / STEPS_PER_FRAME;
    let dx = step_s / TABLE_PER_STEP as f64;
    let exposed = KernelTable::new(nyquist_hz, window_s, exposure_s, dx);
    let instant = KernelTable::new(nyquist_hz, window_s, 0.0, dx);
    let instants = frames.timestamps_s.iter().chain(frames.marker_centres_s);
    let (lo, hi) = instants.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| {
        (a.min(t), b.max(t))
    });
    let (span_lo, span_hi) = frames.truth_span_s;
    let start = (lo - exposed.reach_s - 2.0 * step_s).max(span_lo);
    let end = (hi + exposed.reach_s + 2.0 * step_s).min(span_hi);
    if end.partial_cmp(&start) != Some(std::cmp::Ordering::Greater) {
        return (undefined(info), None);
    }
    let count = ((end - start) / step_s).floor() as usize + 1;
    let grid = ThetaGrid {
        t0_s: start,
        step_s,
        theta2_rad: (0..count)
            .into_par_iter()
            .map(|i| theta2_at(start + i as f64 * step_s))
            .collect(),
    };
    let per_frame: Vec<([f64; 3], [f64; 3])> = (0..n)
        .into_par_iter()
        .map(|k| {
            let (t, tau) = (frames.timestamps_s[k], frames.marker_centres_s[k]);
            (grid.filter(&exposed, tau), grid.filter(&instant, t))
        })
        .collect();
    info.frames_defined = per_frame.iter().filter(|(r, _)| r[0].is_finite()).count();
    let col = |which: usize, d: usize| -> Vec<f64> {
        per_frame
            .iter()
            .map(|p| if which == 0 { p.0[d] } else { p.1[d] })
            .collect()
    };
    let resolvable = Resolvable {
        info,
        frame_theta2_rad,
        theta2_rad: col(0, 0),
        omega2_rad_s: col(0, 1),
        alpha2_rad_s2: col(0, 2),
        band_limited_theta2_rad: col(1, 0),
        band_limited_omega2_rad_s: col(1, 1),
        band_limited_alpha2_rad_s2: col(1, 2),
    };
    (resolvable, Some(ResolvableFilter { grid, exposed }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{PI, TAU};

    fn frames(n: usize, h: f64) -> Vec<f64> {
        (0..n).map(|k| k as f64 * h).collect()
    }

    fn run(theta: &(dyn Fn(f64) -> f64 + Sync), t: &[f64], exposure_s: f64) -> Resolvable {
        resolvable_truth(
            theta,
            &FrameInstants {
                timestamps_s: t,
                marker_centres_s: t,
                exposure_s,
                truth_span_s: (f64::NEG_INFINITY, f64::INFINITY),
            },
        )
        .0
    }

    /// A sinusoid well inside the band comes through unchanged; with an exposure E it is scaled
    /// by the box's transfer function sin(πfE)/(πfE), written out here.
    #[test]
    fn passband_sinusoid_is_kept_and_exposure_scales_it_by_the_box_response() {
        let h = 1.0 / 30.0;
        let t = frames(120, h);
        let (a, f) = (0.01, 6.0); // 0.4 f_N
        let theta = move |x: f64| 2.0 + a * (TAU * f * x).sin();
        for exposure in [0.0, 0.004, 0.02] {
            let r = run(&theta, &t, exposure);
            let gain = if exposure > 0.0 {
                (PI * f * exposure).sin() / (PI * f * exposure)
            } else {
                1.0
            };
            let w = TAU * f;
            for (k, &x) in t.iter().enumerate() {
                let (s, c) = (w * x).sin_cos();
                assert!((r.theta2_rad[k] - (2.0 + gain * a * s)).abs() < 2e-4 * a);
                assert!((r.frame_theta2_rad[k] - (2.0 + gain * a * s)).abs() < 1e-9 * a);
                assert!((r.omega2_rad_s[k] - gain * a * w * c).abs() < 2e-4 * a * w);
                assert!((r.alpha2_rad_s2[k] + gain * a * w * w * s).abs() < 2e-4 * a * w * w);
            }
        }
    }

    /// Above 1.15 f_N nothing is resolvable: the band-limited truth is ~0 and the aliasing part
    /// is the whole raw motion. At f_N exactly, half the amplitude passes; at 0.85 f_N all of it.
    #[test]
    fn motion_above_the_nyquist_rate_is_aliasing() {
        let h = 1.0 / 30.0;
        let t = frames(120, h);
        // The documented band edges: within 0.2 % of 1 at 0.85 f_N, below 0.2 % from 1.15 f_N.
        for (ratio, gain, tol) in [
            (0.85, 1.0, 2e-3),
            (1.15, 0.0, 2e-3),
            (1.3, 0.0, 2e-3),
            (2.7, 0.0, 2e-3),
            (1.0, 0.5, 2e-3),
        ] {
            let f = ratio * 15.0;
            let theta = move |x: f64| 1e-3 * (TAU * f * x + 0.3).sin();
            let r = run(&theta, &t, 0.0);
            for (k, &x) in t.iter().enumerate() {
                let raw = 1e-3 * (TAU * f * x + 0.3).sin();
                let w = TAU * f;
                let raw_alpha = -w * w * raw;
                assert!((r.band_limited_theta2_rad[k] - gain * raw).abs() < tol * 1e-3);
                assert!(
                    (r.band_limited_alpha2_rad_s2[k] - gain * raw_alpha).abs() < tol * 1e-3 * w * w,
                    "f {f}: {} vs {}",
                    r.band_limited_alpha2_rad_s2[k],
                    gain * raw_alpha
                );
                assert_eq!(r.theta2_rad[k], r.band_limited_theta2_rad[k]);
                // What the (instantaneous) frame shows is the raw motion, aliasing included.
                assert_eq!(r.frame_theta2_rad[k], raw);
            }
        }
    }

    /// ∫g·u² du / ∫g du of the windowed sinc for frame interval `h`, by a fine Riemann sum
    /// written out here (the filter's own passband ripple: a parabola's band-limited version is
    /// shifted by q/2 times it).
    fn second_moment(h: f64) -> f64 {
        let (f, t_w) = (0.5 / h, WINDOW_FRAMES * h);
        let d = h / 256.0;
        let n = (0.5 * t_w / d) as i64;
        let (mut m0, mut m2) = (0.0, 0.0);
        for j in -n..=n {
            let u = j as f64 * d;
            let x = 2.0 * f * u;
            let sinc = if j == 0 {
                1.0
            } else {
                (PI * x).sin() / (PI * x)
            };
            let w = 0.42 + 0.5 * (TAU * u / t_w).cos() + 0.08 * (2.0 * TAU * u / t_w).cos();
            m0 += sinc * w;
            m2 += sinc * w * u * u;
        }
        m2 / m0
    }

    /// Quadratic motion: ω and α exact whatever the exposure (the discrete kernels keep the
    /// continuous moments); θ shifted by q/2 times the second moment of g ∗ b_E (the box adds
    /// E²/12), with non-uniform instants and a large accumulated angle.
    #[test]
    fn quadratic_motion_is_exact() {
        let t: Vec<f64> = (0..90)
            .map(|k| k as f64 / 30.0 + 3e-4 * ((k * 7 % 5) as f64 - 2.0))
            .collect();
        let m2 = second_moment(median_interval_s(&t));
        assert!(m2 > 0.0 && m2 < 1e-5, "{m2}");
        let (a, b, q) = (1000.0, -0.7, 2.4);
        let theta = move |x: f64| a + b * x + 0.5 * q * x * x;
        for exposure in [0.0, 0.01] {
            let r = run(&theta, &t, exposure);
            for (k, &x) in t.iter().enumerate() {
                let shift = 0.5 * q * (m2 + exposure * exposure / 12.0);
                let e = r.theta2_rad[k] - theta(x) - shift;
                // 1e-8: the Riemann sum at h/32 and the interpolated kernel table.
                assert!(e.abs() < 1e-8, "E {exposure}, frame {k}: θ off by {e}");
                let eo = r.omega2_rad_s[k] - (b + q * x);
                assert!(eo.abs() < 1e-9, "E {exposure}, frame {k}: ω off by {eo}");
                let ea = r.alpha2_rad_s2[k] - q;
                assert!(ea.abs() < 1e-7, "E {exposure}, frame {k}: α off by {ea}");
            }
        }
    }

    /// Frames whose window leaves the truth span have no resolvable truth; the marker delay is
    /// reported.
    #[test]
    fn frames_near_the_ends_of_the_truth_are_undefined() {
        let h = 1.0 / 30.0;
        let t = frames(60, h);
        let centres: Vec<f64> = t.iter().map(|x| x + 0.002).collect();
        let r = resolvable_truth(
            &|x: f64| x,
            &FrameInstants {
                timestamps_s: &t,
                marker_centres_s: &centres,
                exposure_s: 0.004,
                truth_span_s: (0.0, 10.0),
            },
        )
        .0;
        // The window reaches (32 h + E)/2 around the marker's instant, plus a grid step or two.
        let reach = 0.5 * (WINDOW_FRAMES * h + 0.004);
        for (k, &x) in t.iter().enumerate() {
            if x + 0.002 < reach {
                assert!(
                    r.theta2_rad[k].is_nan() && r.alpha2_rad_s2[k].is_nan(),
                    "{k}"
                );
            }
            if x + 0.002 > reach + 2.0 * h / STEPS_PER_FRAME {
                assert!((r.omega2_rad_s[k] - 1.0).abs() < 1e-9, "{k}");
            }
        }
        assert!(r.theta2_rad[0].is_nan() && r.theta2_rad[59].is_finite());
        assert_eq!(
            r.info.frames_defined,
            r.theta2_rad.iter().filter(|v| v.is_finite()).count()
        );
        assert!((r.info.marker_delay_mean_s - 0.002).abs() < 1e-12);
        assert!((r.info.nyquist_hz - 15.0).abs() < 1e-9);
    }

    #[test]
    fn median_interval_ignores_a_long_first_gap_and_a_drop() {
        let t = [0.0, 0.055, 0.0883, 0.1216, 0.1882, 0.2215];
        assert!((median_interval_s(&t) - 0.0333).abs() < 1e-9);
        assert!(median_interval_s(&[1.0]).is_nan());
    }
}
