//! Plots of measured against true ω2 and α2, like the seed's Figures 5.1 and 5.2 (against the
//! crank angle) and against time: the dense truth (every output step of the motion) and the
//! resolvable truth as lines, the measurement as points — never the truth sampled at frame times,
//! which draws zigzags that are not in the motion.

use super::rig::Rig;
use crate::budget::compare::{SignalErrors, TruthSeries};
use crate::budget::resolvable::{ResolvableFilter, ResolvableInfo};
use crate::mechanism::{Geneva, Phase};
use crate::plot::{stacked_png, Panel, PlotError, Series, MEASURED, SECOND, THIRD, TRUTH};
use std::path::{Path, PathBuf};

fn pick<'a>(signals: &'a [SignalErrors], name: &str) -> Option<&'a SignalErrors> {
    signals.iter().find(|s| s.signal == name)
}

/// Step of the dense truth: the dynamics' output step when simulated (impacts), else 1 ms.
fn dense_step_s(rig: &Rig) -> f64 {
    match rig.mechanism.dynamics() {
        Some(d) => d.output_step_s.max(1e-4),
        None => 1e-3,
    }
}

/// One instant of the plotted curves.
struct Dense {
    t_s: f64,
    theta1_deg: f64,
    engaged: bool,
    omega: f64,
    alpha: f64,
}

/// `(x, y)` points of the engaged samples, with a gap (NaN) wherever an engagement ends.
fn engaged_line(samples: &[Dense], y: impl Fn(&Dense) -> f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for w in samples.windows(2) {
        if w[0].engaged {
            out.push((w[0].theta1_deg, y(&w[0])));
            if !w[1].engaged {
                out.push((f64::NAN, f64::NAN));
            }
        }
    }
    out
}

pub fn plot_measured_vs_truth(
    out_dir: &Path,
    rig: &Rig,
    signals: &[SignalErrors],
    truth: &TruthSeries,
    info: &ResolvableInfo,
    filter: Option<&ResolvableFilter>,
) -> Result<Vec<PathBuf>, PlotError> {
    let name = &rig.scenario.name;
    let mut files = Vec::new();
    let t = &truth.t_s;
    let (t0, t1) = (
        t.first().copied().unwrap_or(0.0),
        t.last().copied().unwrap_or(0.0),
    );
    let engaged_at = |s: f64| {
        let m = rig.mechanism.ideal(s);
        (
            Geneva::wrap_crank(m.theta1_rad).1.to_degrees(),
            m.phase != Phase::Dwell,
        )
    };
    let step = dense_step_s(rig);
    let dense: Vec<Dense> = (0..=((t1 - t0) / step).floor() as usize)
        .map(|i| {
            let s = t0 + i as f64 * step;
            let m = rig.mechanism.actual(s);
            let (theta1_deg, engaged) = engaged_at(s);
            Dense {
                t_s: s,
                theta1_deg,
                engaged,
                omega: m.omega2_rad_s,
                alpha: m.alpha2_rad_s2,
            }
        })
        .collect();
    // The resolvable truth as a curve: the same filter at a quarter of the frame interval,
    // shifted by the marker's mean exposure delay like the per-frame values.
    let fine_step = info.median_interval_s / 4.0;
    let fine_times: Vec<f64> = if fine_step.is_finite() && fine_step > 0.0 {
        (0..=((t1 - t0) / fine_step).floor() as usize)
            .map(|i| t0 + i as f64 * fine_step)
            .collect()
    } else {
        Vec::new()
    };
    let [_, r_omega, r_alpha] = match filter {
        Some(f) => f.curve(&fine_times, info.marker_delay_mean_s),
        None => [vec![], vec![], vec![]],
    };
    let resolvable: Vec<Dense> = fine_times
        .iter()
        .zip(r_omega.iter().zip(&r_alpha))
        .map(|(&s, (&omega, &alpha))| {
            let (theta1_deg, engaged) = engaged_at(s);
            Dense {
                t_s: s,
                theta1_deg,
                engaged,
                omega,
                alpha,
            }
        })
        .collect();
    let dense_label = format!("truth (actual motion, every {} ms)", step * 1e3);
    let resolvable_label = format!(
        "resolvable truth (exposure {} ms, band-limited to {:.1} Hz)",
        info.exposure_s * 1e3,
        info.nyquist_hz
    );
    let line = |v: &[Dense], f: fn(&Dense) -> f64| v.iter().map(|d| (d.t_s, f(d))).collect();
    let mut w_series = vec![
        Series::line(&dense_label, line(&dense, |d| d.omega), TRUTH),
        Series::line(&resolvable_label, line(&resolvable, |d| d.omega), THIRD),
    ];
    let mut a_series = vec![
        Series::line(&dense_label, line(&dense, |d| d.alpha), TRUTH),
        Series::line(&resolvable_label, line(&resolvable, |d| d.alpha), THIRD),
    ];
    for (sig, color) in [("centre", SECOND), ("fused", MEASURED)] {
        if let Some(s) = pick(signals, sig) {
            let at_frames =
                |v: &[f64]| t.iter().copied().zip(v.iter().copied()).collect::<Vec<_>>();
            w_series.push(Series::points(
                format!("measured ({sig})"),
                at_frames(&s.omega2_rad_s),
                color,
            ));
            a_series.push(Series::points(
                format!("measured ({sig})"),
                at_frames(&s.alpha2_rad_s2),
                color,
            ));
        }
    }
    let vs_time = out_dir.join("measured_vs_true_time.png");
    stacked_png(
        &vs_time,
        &[
            Panel {
                title: format!("{name}: omega2, measured against truth"),
                x_label: "t (s)".into(),
                y_label: "omega2 (rad/s)".into(),
                series: w_series,
            },
            Panel {
                title: format!("{name}: alpha2, measured against truth"),
                x_label: "t (s)".into(),
                y_label: "alpha2 (rad/s^2)".into(),
                series: a_series,
            },
        ],
        1200,
        450,
    )?;
    files.push(vs_time);

    // Figures 5.1/5.2: against the wrapped crank angle over the engaged frames.
    let engaged: Vec<usize> = (0..t.len())
        .filter(|&i| truth.phase[i] != "dwell")
        .collect();
    if !engaged.is_empty() {
        let truth_lines = |f: fn(&Dense) -> f64| {
            vec![
                Series::line(&dense_label, engaged_line(&dense, f), TRUTH),
                Series::line(&resolvable_label, engaged_line(&resolvable, f), THIRD),
            ]
        };
        let mut w = truth_lines(|d| d.omega);
        let mut a = truth_lines(|d| d.alpha);
        if let Some(s) = pick(signals, "fused") {
            let at = |v: &[f64]| {
                engaged
                    .iter()
                    .map(|&i| (engaged_at(t[i]).0, v[i]))
                    .collect::<Vec<_>>()
            };
            w.push(Series::points(
                "measured (fused)",
                at(&s.omega2_rad_s),
                MEASURED,
            ));
            a.push(Series::points(
                "measured (fused)",
                at(&s.alpha2_rad_s2),
                MEASURED,
            ));
        }
        let vs_theta = out_dir.join("measured_vs_true_theta1.png");
        stacked_png(
            &vs_theta,
            &[
                Panel {
                    title: format!("{name}: omega2 against crank angle (engaged frames)"),
                    x_label: "theta1 (deg)".into(),
                    y_label: "omega2 (rad/s)".into(),
                    series: w,
                },
                Panel {
                    title: format!("{name}: alpha2 against crank angle (engaged frames)"),
                    x_label: "theta1 (deg)".into(),
                    y_label: "alpha2 (rad/s^2)".into(),
                    series: a,
                },
            ],
            1200,
            450,
        )?;
        files.push(vs_theta);
    }
    Ok(files)
}
