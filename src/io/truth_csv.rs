//! `truth.csv`: the mechanism's ideal (and, when it differs, actual) motion at given times.

use super::csv_out::{num, CsvError, CsvWriter};
use crate::mechanism::MotionSample;
use std::path::Path;

pub const IDEAL_COLUMNS: [&str; 10] = [
    "t_s",
    "theta1_rad",
    "omega1_rad_s",
    "alpha1_rad_s2",
    "theta2_rad",
    "omega2_rad_s",
    "alpha2_rad_s2",
    "jerk2_rad_s3",
    "phase",
    "index",
];

pub const ACTUAL_COLUMNS: [&str; 6] = [
    "theta2_actual_rad",
    "omega2_actual_rad_s",
    "alpha2_actual_rad_s2",
    "jerk2_actual_rad_s3",
    "centre_offset_x_m",
    "centre_offset_y_m",
];

/// Writes one row per (ideal, actual) pair; actual columns only when `with_actual`.
pub fn write_truth_csv(
    path: &Path,
    rows: &[(MotionSample, MotionSample)],
    with_actual: bool,
) -> Result<(), CsvError> {
    let mut header: Vec<&str> = IDEAL_COLUMNS.to_vec();
    if with_actual {
        header.extend_from_slice(&ACTUAL_COLUMNS);
    }
    let mut w = CsvWriter::create(path, &header)?;
    for (i, a) in rows {
        let mut cells = vec![
            num(i.t_s),
            num(i.theta1_rad),
            num(i.omega1_rad_s),
            num(i.alpha1_rad_s2),
            num(i.theta2_rad),
            num(i.omega2_rad_s),
            num(i.alpha2_rad_s2),
            num(i.jerk2_rad_s3),
            i.phase.as_str().to_string(),
            i.index.to_string(),
        ];
        if with_actual {
            cells.extend([
                num(a.theta2_rad),
                num(a.omega2_rad_s),
                num(a.alpha2_rad_s2),
                num(a.jerk2_rad_s3),
                num(a.centre_offset_m[0]),
                num(a.centre_offset_m[1]),
            ]);
        }
        w.row(&cells)?;
    }
    w.finish()
}
