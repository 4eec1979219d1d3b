//! `kinematics.csv`: per frame and signal, the measured θ2, ω2, α2 (wheel convention) and, for
//! synthetic runs, the truth beside them (actual motion, ideal kinematics, resolvable truth,
//! phase).

use super::csv_out::{num, CsvError, CsvWriter};
use crate::budget::compare::{SignalErrors, TruthSeries};
use crate::estimate::MeasuredSignal;
use std::path::Path;

/// A measured signal's columns: real measurements ([`MeasuredSignal`]) and synthetic ones
/// judged against a truth ([`SignalErrors`]) are written the same way.
pub trait SignalColumns {
    fn name(&self) -> &str;
    fn theta2_rad(&self) -> &[f64];
    fn omega2_rad_s(&self) -> &[f64];
    fn alpha2_rad_s2(&self) -> &[f64];
}

macro_rules! signal_columns {
    ($t:ty) => {
        impl SignalColumns for $t {
            fn name(&self) -> &str {
                &self.signal
            }
            fn theta2_rad(&self) -> &[f64] {
                &self.theta2_rad
            }
            fn omega2_rad_s(&self) -> &[f64] {
                &self.omega2_rad_s
            }
            fn alpha2_rad_s2(&self) -> &[f64] {
                &self.alpha2_rad_s2
            }
        }
    };
}
signal_columns!(SignalErrors);
signal_columns!(MeasuredSignal);

/// Writes rows frame-major (all signals of frame 0, then frame 1, ...). The truths (actual,
/// ideal, resolvable) are absent for real footage. `frame_numbers` (one per entry of
/// `frames_t_s`) gives each row the input's frame number, `None` leaving that entry out (a
/// placeholder for an absent frame); without it, entries are numbered from 0.
pub fn write_kinematics_csv<S: SignalColumns>(
    path: &Path,
    frames_t_s: &[f64],
    signals: &[S],
    truth: Option<(&TruthSeries, &TruthSeries, &TruthSeries)>,
    frame_numbers: Option<&[Option<usize>]>,
) -> Result<(), CsvError> {
    let mut header = vec![
        "frame",
        "t_s",
        "signal",
        "theta2_rad",
        "omega2_rad_s",
        "alpha2_rad_s2",
    ];
    if truth.is_some() {
        header.extend([
            "true_theta2_rad",
            "true_omega2_rad_s",
            "true_alpha2_rad_s2",
            "ideal_theta2_rad",
            "ideal_omega2_rad_s",
            "ideal_alpha2_rad_s2",
            "resolvable_theta2_rad",
            "resolvable_omega2_rad_s",
            "resolvable_alpha2_rad_s2",
            "phase",
        ]);
    }
    let mut w = CsvWriter::create(path, &header)?;
    for (i, t) in frames_t_s.iter().enumerate() {
        let frame = match frame_numbers {
            Some(numbers) => match numbers.get(i).copied().flatten() {
                Some(f) => f,
                None => continue,
            },
            None => i,
        };
        for s in signals {
            let mut cells = vec![
                frame.to_string(),
                num(*t),
                s.name().to_string(),
                num(s.theta2_rad()[i]),
                num(s.omega2_rad_s()[i]),
                num(s.alpha2_rad_s2()[i]),
            ];
            if let Some((actual, ideal, resolvable)) = truth {
                cells.extend([
                    num(actual.theta2_rad[i]),
                    num(actual.omega2_rad_s[i]),
                    num(actual.alpha2_rad_s2[i]),
                    num(ideal.theta2_rad[i]),
                    num(ideal.omega2_rad_s[i]),
                    num(ideal.alpha2_rad_s2[i]),
                    num(resolvable.theta2_rad[i]),
                    num(resolvable.omega2_rad_s[i]),
                    num(resolvable.alpha2_rad_s2[i]),
                    actual.phase[i].to_string(),
                ]);
            }
            w.row(&cells)?;
        }
    }
    w.finish()
}
