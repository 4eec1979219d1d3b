//! `kinematics.csv`: per frame and signal, the measured θ2, ω2, α2 (wheel convention) and, for
//! synthetic runs, the truth beside them (actual motion, ideal kinematics, resolvable truth,
//! phase); for real footage with a scenario, the error bars and flags of `analyze`.

use super::csv_out::{num, CsvError, CsvWriter};
use crate::budget::compare::{SignalErrors, TruthSeries};
use crate::budget::error_bars::SignalBars;
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

/// A measured signal's error bars and its flags (α2 beyond noise, ω2 jump beyond noise), written
/// beside a real measurement.
pub struct BarColumns<'a> {
    pub bars: &'a SignalBars,
    pub flags: [Vec<Option<bool>>; 2],
}

const BAR_HEADER: [&str; 6] = [
    "theta2_sigma_rad",
    "omega2_sigma_rad_s",
    "alpha2_sigma_rad_s2",
    "alpha2_model_rad_s2",
    "alpha2_beyond_noise",
    "omega2_jump_beyond_noise",
];

fn bar_cells(b: &BarColumns, i: usize) -> [String; 6] {
    let flag = |f: Option<bool>| f.map_or(String::new(), |x| u8::from(x).to_string());
    [
        num(b.bars.sigma[0][i]),
        num(b.bars.sigma[1][i]),
        num(b.bars.sigma[2][i]),
        num(b.bars.model[2][i]),
        flag(b.flags[0][i]),
        flag(b.flags[1][i]),
    ]
}

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
    bars: Option<&[BarColumns]>,
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
    if bars.is_some() {
        header.extend(BAR_HEADER);
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
            if let Some(bars) = bars {
                match bars.iter().find(|b| b.bars.signal == s.name()) {
                    Some(b) => cells.extend(bar_cells(b, i)),
                    None => cells.extend(std::iter::repeat_n(String::new(), BAR_HEADER.len())),
                }
            }
            w.row(&cells)?;
        }
    }
    w.finish()
}
