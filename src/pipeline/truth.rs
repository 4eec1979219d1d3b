//! `geneva kinematics`: the truth trajectory as CSV plus plots like the seed's Figures 4.7/4.8.

use crate::io::truth_csv::write_truth_csv;
use crate::mechanism::{Geneva, Mechanism, MechanismError, Phase};
use crate::plot::{stacked_png, Panel, Series, MEASURED, SECOND, TRUTH};
use crate::scenario::Scenario;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum TruthError {
    #[error("mechanism")]
    Mechanism(#[from] MechanismError),
    #[error(transparent)]
    Csv(#[from] crate::io::csv_out::CsvError),
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    #[error("{dir}: cannot create output directory")]
    OutDir {
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: cannot read the times", file.display())]
    TimesFile {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{}, line {line}: {why}", file.display())]
    Times {
        file: PathBuf,
        line: usize,
        why: String,
    },
}

/// What the truth job produced, for printing.
#[derive(Debug, Clone)]
pub struct TruthSummary {
    pub rows: usize,
    pub sample_step_s: f64,
    pub engagements: u32,
    pub peak_omega2_rad_s: f64,
    pub peak_alpha2_rad_s2: f64,
    pub peak_actual_alpha2_rad_s2: Option<f64>,
    pub has_actual: bool,
    pub files: Vec<PathBuf>,
}

impl std::fmt::Display for TruthSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "truth samples       {} (every {} ms)",
            self.rows,
            self.sample_step_s * 1e3
        )?;
        writeln!(f, "engagements         {}", self.engagements)?;
        writeln!(f, "peak |omega2| ideal {:.4} rad/s", self.peak_omega2_rad_s)?;
        writeln!(
            f,
            "peak |alpha2| ideal {:.4} rad/s^2",
            self.peak_alpha2_rad_s2
        )?;
        if let Some(a) = self.peak_actual_alpha2_rad_s2 {
            writeln!(f, "peak |alpha2| actual {a:.1} rad/s^2 (dynamics: impacts)")?;
        }
        for file in &self.files {
            writeln!(f, "wrote {}", file.display())?;
        }
        Ok(())
    }
}

/// Sampling step of the truth CSV: fine enough to show impacts when the dynamics are on.
fn truth_step_s(mechanism: &Mechanism) -> f64 {
    match mechanism.dynamics() {
        Some(d) => d.output_step_s.max(1e-4),
        None => 1e-3,
    }
}

pub fn write_truth(scenario: &Scenario, out_dir: &Path) -> Result<TruthSummary, TruthError> {
    std::fs::create_dir_all(out_dir).map_err(|source| TruthError::OutDir {
        dir: out_dir.into(),
        source,
    })?;
    let mechanism = Mechanism::new(
        &scenario.mechanism,
        &scenario.drive_speed,
        &scenario.dynamics,
        scenario.duration_s,
    )?;
    let step = truth_step_s(&mechanism);
    let n = (scenario.duration_s / step).floor() as usize + 1;
    let times: Vec<f64> = (0..n).map(|k| k as f64 * step).collect();
    let rows = mechanism.truth_rows(&times);
    let has_actual = mechanism.has_actual_motion();
    let csv = out_dir.join("truth.csv");
    write_truth_csv(&csv, &rows, has_actual)?;

    let peak =
        |f: &dyn Fn(usize) -> f64| (0..rows.len()).map(f).fold(0.0f64, |m, v| m.max(v.abs()));
    let summary_peak_w = peak(&|i| rows[i].0.omega2_rad_s);
    let summary_peak_a = peak(&|i| rows[i].0.alpha2_rad_s2);
    let peak_actual = has_actual.then(|| peak(&|i| rows[i].1.alpha2_rad_s2));

    let vs_theta = out_dir.join("omega2_alpha2_vs_theta1.png");
    plot_vs_theta1(&vs_theta, &mechanism, &rows, has_actual, scenario)?;
    let vs_time = out_dir.join("omega2_alpha2_vs_time.png");
    plot_vs_time(&vs_time, &rows, has_actual)?;
    Ok(TruthSummary {
        rows: rows.len(),
        sample_step_s: step,
        engagements: rows.last().map(|r| r.0.index).unwrap_or(0),
        peak_omega2_rad_s: summary_peak_w,
        peak_alpha2_rad_s2: summary_peak_a,
        peak_actual_alpha2_rad_s2: peak_actual,
        has_actual,
        files: vec![csv, vs_theta, vs_time],
    })
}

/// The instants of a `--times` file: one time in seconds per line (the first comma-separated field
/// of it), an optional header line whose first field is `t_s`, blank lines skipped. Every time
/// must be finite; their order is kept.
pub fn parse_times(text: &str) -> Result<Vec<f64>, (usize, String)> {
    let mut times = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let field = line.split(',').next().unwrap_or("").trim();
        if field.is_empty() || (i == 0 && field == "t_s") {
            continue;
        }
        match field.parse::<f64>() {
            Ok(t) if t.is_finite() => times.push(t),
            Ok(t) => return Err((i + 1, format!("the time {t} is not finite"))),
            Err(_) => return Err((i + 1, format!("`{field}` is not a time in seconds"))),
        }
    }
    if times.is_empty() {
        return Err((0, "no time listed".into()));
    }
    Ok(times)
}

/// The motion at the instants listed in `times_file` (see [`parse_times`]): `truth.csv` in
/// `out_dir` with the ideal and the actual columns (wheel angle with dynamics, vibration and
/// runout; the wheel centre's offset), one row per listed time, in its order. This is what a
/// renderer outside the project needs to draw the rig at sub-frame instants (exposure, rolling
/// shutter). Times after `duration_s` extend the simulated span; the clearance dynamics start at
/// 0 s, so before it the actual motion is the ideal one. Returns the number of rows.
pub fn write_truth_at(
    scenario: &Scenario,
    times_file: &Path,
    out_dir: &Path,
) -> Result<usize, TruthError> {
    let text = std::fs::read_to_string(times_file).map_err(|source| TruthError::TimesFile {
        file: times_file.into(),
        source,
    })?;
    let times = parse_times(&text).map_err(|(line, why)| TruthError::Times {
        file: times_file.into(),
        line,
        why,
    })?;
    let last = times.iter().copied().fold(scenario.duration_s, f64::max);
    let mechanism = Mechanism::new(
        &scenario.mechanism,
        &scenario.drive_speed,
        &scenario.dynamics,
        last,
    )?;
    std::fs::create_dir_all(out_dir).map_err(|source| TruthError::OutDir {
        dir: out_dir.into(),
        source,
    })?;
    let rows = mechanism.truth_rows(&times);
    write_truth_csv(&out_dir.join("truth.csv"), &rows, true)?;
    Ok(rows.len())
}

/// Figures 4.7/4.8 of the seed: ω2 and α2 over the first complete engagement against the
/// wrapped crank angle, for the scenario's drive profile and for a constant crank speed equal
/// to its speed at the start of the engagement.
fn plot_vs_theta1(
    path: &Path,
    mechanism: &Mechanism,
    rows: &[(
        crate::mechanism::MotionSample,
        crate::mechanism::MotionSample,
    )],
    has_actual: bool,
    scenario: &Scenario,
) -> Result<(), crate::plot::PlotError> {
    let geneva: Geneva = mechanism.geneva();
    // The first engagement that starts inside the run.
    let start = rows
        .windows(2)
        .position(|w| w[0].0.phase == Phase::Dwell && w[1].0.phase != Phase::Dwell);
    let selected: Vec<&(
        crate::mechanism::MotionSample,
        crate::mechanism::MotionSample,
    )> = match start {
        Some(s) => rows[s + 1..]
            .iter()
            .take_while(|r| r.0.phase != Phase::Dwell)
            .collect(),
        None => rows.iter().filter(|r| r.0.phase != Phase::Dwell).collect(),
    };
    let deg = |r: &crate::mechanism::MotionSample| Geneva::wrap_crank(r.theta1_rad).1.to_degrees();
    let omega1_const = selected.first().map(|r| r.0.omega1_rad_s).unwrap_or(1.0);
    let label = format!("constant omega1 = {omega1_const:.2} rad/s");
    let mut w_series = vec![
        Series::line(
            "ideal (scenario drive)",
            selected
                .iter()
                .map(|r| (deg(&r.0), r.0.omega2_rad_s))
                .collect(),
            TRUTH,
        ),
        Series::line(
            label.clone(),
            selected
                .iter()
                .map(|r| {
                    (
                        deg(&r.0),
                        geneva.omega2_rad_s(Geneva::wrap_crank(r.0.theta1_rad).1, omega1_const),
                    )
                })
                .collect(),
            MEASURED,
        ),
    ];
    let mut a_series = vec![
        Series::line(
            "ideal (scenario drive)",
            selected
                .iter()
                .map(|r| (deg(&r.0), r.0.alpha2_rad_s2))
                .collect(),
            TRUTH,
        ),
        Series::line(
            label,
            selected
                .iter()
                .map(|r| {
                    (
                        deg(&r.0),
                        geneva.alpha2_rad_s2(
                            Geneva::wrap_crank(r.0.theta1_rad).1,
                            omega1_const,
                            0.0,
                        ),
                    )
                })
                .collect(),
            MEASURED,
        ),
    ];
    if has_actual {
        w_series.push(Series::line(
            "actual (dynamics)",
            selected
                .iter()
                .map(|r| (deg(&r.0), r.1.omega2_rad_s))
                .collect(),
            SECOND,
        ));
        a_series.push(Series::line(
            "actual (dynamics)",
            selected
                .iter()
                .map(|r| (deg(&r.0), r.1.alpha2_rad_s2))
                .collect(),
            SECOND,
        ));
    }
    let name = &scenario.name;
    stacked_png(
        path,
        &[
            Panel {
                title: format!("{name}: omega2 over one engagement"),
                x_label: "theta1 (deg)".into(),
                y_label: "omega2 (rad/s)".into(),
                series: w_series,
            },
            Panel {
                title: format!("{name}: alpha2 over one engagement"),
                x_label: "theta1 (deg)".into(),
                y_label: "alpha2 (rad/s^2)".into(),
                series: a_series,
            },
        ],
        1100,
        420,
    )
}

fn plot_vs_time(
    path: &Path,
    rows: &[(
        crate::mechanism::MotionSample,
        crate::mechanism::MotionSample,
    )],
    has_actual: bool,
) -> Result<(), crate::plot::PlotError> {
    let mut w = vec![Series::line(
        "ideal",
        rows.iter().map(|r| (r.0.t_s, r.0.omega2_rad_s)).collect(),
        TRUTH,
    )];
    let mut a = vec![Series::line(
        "ideal",
        rows.iter().map(|r| (r.0.t_s, r.0.alpha2_rad_s2)).collect(),
        TRUTH,
    )];
    if has_actual {
        w.push(Series::line(
            "actual",
            rows.iter().map(|r| (r.1.t_s, r.1.omega2_rad_s)).collect(),
            SECOND,
        ));
        a.push(Series::line(
            "actual",
            rows.iter().map(|r| (r.1.t_s, r.1.alpha2_rad_s2)).collect(),
            SECOND,
        ));
    }
    stacked_png(
        path,
        &[
            Panel {
                title: "omega2 against time".into(),
                x_label: "t (s)".into(),
                y_label: "omega2 (rad/s)".into(),
                series: w,
            },
            Panel {
                title: "alpha2 against time".into(),
                x_label: "t (s)".into(),
                y_label: "alpha2 (rad/s^2)".into(),
                series: a,
            },
        ],
        1100,
        420,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_are_read_in_order_with_an_optional_header() {
        assert_eq!(parse_times("t_s\n0.5\n\n0.25,x\n"), Ok(vec![0.5, 0.25]));
        assert_eq!(parse_times("-0.001\n2"), Ok(vec![-0.001, 2.0]));
        assert_eq!(parse_times("0.1\nabc\n").unwrap_err().0, 2);
        assert_eq!(parse_times("inf\n").unwrap_err().0, 1);
        assert!(parse_times("t_s\n").is_err());
    }

    #[test]
    fn the_motion_at_listed_times_is_the_mechanism_s() {
        let mut s = crate::scenario::load_any("fast").unwrap();
        s.dynamics.disc_vibration.enabled = true;
        s.dynamics.axis_runout.enabled = true;
        let dir = tempfile::tempdir().unwrap();
        let times = [0.0, 1.2345, 0.7, 2.5];
        let file = dir.path().join("times.csv");
        let text: String = times.iter().map(|t| format!("{t}\n")).collect();
        std::fs::write(&file, text).unwrap();
        assert_eq!(write_truth_at(&s, &file, dir.path()).unwrap(), times.len());
        let csv = std::fs::read_to_string(dir.path().join("truth.csv")).unwrap();
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
        let mechanism = Mechanism::new(&s.mechanism, &s.drive_speed, &s.dynamics, 2.5).unwrap();
        let mut differs = false;
        for (line, &t) in lines.zip(&times) {
            let cells: Vec<f64> = line
                .split(',')
                .map(|c| c.parse().unwrap_or(f64::NAN))
                .collect();
            let actual = mechanism.actual(t);
            assert_eq!(cells[col("t_s")], t);
            assert!((cells[col("theta2_actual_rad")] - actual.theta2_rad).abs() < 1e-12);
            assert!((cells[col("centre_offset_x_m")] - actual.centre_offset_m[0]).abs() < 1e-15);
            differs |= cells[col("theta2_actual_rad")] != cells[col("theta2_rad")];
        }
        // The disc's vibration rings after an engagement: the actual motion leaves the ideal
        // one at some listed instant (not at every one: before the first impact they agree).
        assert!(differs, "the actual columns repeat the ideal motion");
    }
}
