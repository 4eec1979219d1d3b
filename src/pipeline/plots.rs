//! Plots of measured against true ω2 and α2, like the seed's Figures 5.1 and 5.2 (against the
//! crank angle) and against time.

use crate::budget::compare::{SignalErrors, TruthSeries};
use crate::mechanism::{Geneva, MotionSample};
use crate::plot::{stacked_png, Panel, PlotError, Series, MEASURED, SECOND, TRUTH};
use std::path::{Path, PathBuf};

fn pick<'a>(signals: &'a [SignalErrors], name: &str) -> Option<&'a SignalErrors> {
    signals.iter().find(|s| s.signal == name)
}

pub fn plot_measured_vs_truth(
    out_dir: &Path,
    name: &str,
    signals: &[SignalErrors],
    truth: &TruthSeries,
    samples: &[MotionSample],
) -> Result<Vec<PathBuf>, PlotError> {
    let mut files = Vec::new();
    let t = &truth.t_s;
    let mut w_series = vec![Series::line(
        "truth (actual motion)",
        t.iter()
            .copied()
            .zip(truth.omega2_rad_s.iter().copied())
            .collect(),
        TRUTH,
    )];
    let mut a_series = vec![Series::line(
        "truth (actual motion)",
        t.iter()
            .copied()
            .zip(truth.alpha2_rad_s2.iter().copied())
            .collect(),
        TRUTH,
    )];
    for (sig, color) in [("centre", SECOND), ("fused", MEASURED)] {
        if let Some(s) = pick(signals, sig) {
            w_series.push(Series::points(
                format!("measured ({sig})"),
                t.iter()
                    .copied()
                    .zip(s.omega2_rad_s.iter().copied())
                    .collect(),
                color,
            ));
            a_series.push(Series::points(
                format!("measured ({sig})"),
                t.iter()
                    .copied()
                    .zip(s.alpha2_rad_s2.iter().copied())
                    .collect(),
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
    let engaged: Vec<usize> = (0..samples.len())
        .filter(|&i| truth.phase[i] != "dwell")
        .collect();
    if !engaged.is_empty() {
        let deg = |i: usize| Geneva::wrap_crank(samples[i].theta1_rad).1.to_degrees();
        let series_of =
            |v: &dyn Fn(usize) -> f64| engaged.iter().map(|&i| (deg(i), v(i))).collect::<Vec<_>>();
        let mut w = vec![Series::points(
            "truth",
            series_of(&|i| truth.omega2_rad_s[i]),
            TRUTH,
        )];
        let mut a = vec![Series::points(
            "truth",
            series_of(&|i| truth.alpha2_rad_s2[i]),
            TRUTH,
        )];
        if let Some(s) = pick(signals, "fused") {
            w.push(Series::points(
                "measured (fused)",
                series_of(&|i| s.omega2_rad_s[i]),
                MEASURED,
            ));
            a.push(Series::points(
                "measured (fused)",
                series_of(&|i| s.alpha2_rad_s2[i]),
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
