//! The marker's level as a function of the wheel's angle, measured on the footage: a glossy
//! toner (or a laminated print) reflects the lamp at some angles, so the ink brightens and
//! darkens as the marker turns while a texture in the marker's frame stays as it is.
//!
//! Only frames in which the marker barely moves are used (a moving marker is smeared over the
//! exposure, which changes its flat regions' levels by the motion's blur, not by the light):
//! their ink and paper levels, brought to the footage's reference light, are binned by the wheel
//! angle θ2 ([`BIN_DEG`] wide). The footage shows an angle-dependent level when two bins differ
//! by more than [`MIN_DEPARTURE_DN`] and by more than [`Z_DEPARTURE`] standard errors (of the
//! bin medians, 1.2533·sd/√n, in quadrature, sd the bin's own or the scatter pooled over the
//! bins, whichever is larger). Each bin then gives the affine map of the
//! marker's radiance that takes the ink and paper the scenario draws (measured the same way on
//! the frames they were taken from) to the bin's (`scene::marker_levels`).

use super::FrameObservation;
use crate::numeric::robust::{median_in_place as median, sample_sd};
use crate::scene::MarkerLevelAt;

/// A frame is slow when no corner moved by this much (px) since the previous frame nor until
/// the next: its smear over any exposure is then below the levels' guard band.
pub const SLOW_PX: f64 = 1.5;

/// Width of an angle bin, degrees.
pub const BIN_DEG: f64 = 5.0;

/// Fewer frames than this leave a bin out. Two: a clip that leaves a dwell after a few frames
/// (its first dwell cut by the start of the recording) shows that angle on two or three slow
/// frames only, and the bins' standard errors already hold how few they are (the departure
/// test below weighs a two-frame bin by the scatter pooled over the bins).
pub const MIN_FRAMES_PER_BIN: usize = 2;

/// A departure smaller than this (DN) is not worth a table: it is within what the levels'
/// fit and the tone curve leave.
pub const MIN_DEPARTURE_DN: f64 = 2.0;

/// Standard errors a departure must exceed.
pub const Z_DEPARTURE: f64 = 5.0;

/// The floor of a median's standard error, DN (8-bit levels, trimmed means of a few hundred
/// pixels).
const SE_FLOOR_DN: f64 = 0.05;

/// One slow frame: the wheel's angle and the marker's ink and paper levels at the reference
/// light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelSample {
    pub theta2_deg: f64,
    /// Ink, paper, DN.
    pub level_dn: [f64; 2],
}

/// The levels of one angle bin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AngleBin {
    /// The mean wheel angle of the bin's frames, degrees in [0, 360).
    pub angle_deg: f64,
    pub frames: usize,
    /// Median ink and paper levels, DN.
    pub level_dn: [f64; 2],
    /// Their standard errors, DN.
    pub se_dn: [f64; 2],
}

/// The measured table.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelTable {
    /// The bins in increasing angle.
    pub bins: Vec<AngleBin>,
    /// The ink and paper levels the scenario draws (measured as the bins are), DN.
    pub reference_dn: [f64; 2],
    /// The slow frames used.
    pub frames: usize,
}

/// Why no table can be measured.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LevelTableError {
    #[error(
        "no angle of the wheel was seen in {MIN_FRAMES_PER_BIN} or more frames with the marker \
         at rest or slow"
    )]
    TooFewFrames,
}

impl LevelTable {
    /// How far the bins' levels spread (ink, paper): highest − lowest, DN.
    pub fn spread_dn(&self) -> [f64; 2] {
        [0, 1].map(|m| {
            let (lo, hi) = self
                .bins
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |a, b| {
                    (a.0.min(b.level_dn[m]), a.1.max(b.level_dn[m]))
                });
            if self.bins.is_empty() {
                0.0
            } else {
                hi - lo
            }
        })
    }

    /// Every pair of bins' difference per material: (|Δ| DN, |Δ| in standard errors).
    fn differences(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.bins.iter().enumerate().flat_map(move |(i, a)| {
            self.bins[i + 1..].iter().flat_map(move |b| {
                [0, 1].map(|m| {
                    let d = (a.level_dn[m] - b.level_dn[m]).abs();
                    (d, d / a.se_dn[m].hypot(b.se_dn[m]))
                })
            })
        })
    }

    /// The largest difference between two angles in standard errors.
    pub fn largest_z(&self) -> f64 {
        self.differences().map(|d| d.1).fold(0.0, f64::max)
    }

    /// Whether the footage shows a level that changes with the angle: two angles whose levels
    /// differ by [`MIN_DEPARTURE_DN`] and [`Z_DEPARTURE`] standard errors.
    pub fn shows_levels(&self) -> bool {
        self.differences()
            .any(|(d, z)| d > MIN_DEPARTURE_DN && z > Z_DEPARTURE)
    }

    /// The table's entries for a linear tone curve of black level `black_dn` (radiance 0) and
    /// span `span_dn` (radiance 1 at black + span): per bin, the map of the marker's radiance
    /// that takes the drawn ink and paper to the bin's. Bins whose contrast is not positive are
    /// left out; gains and offsets are kept in their valid ranges.
    pub fn entries(&self, black_dn: f64, span_dn: f64) -> Vec<MarkerLevelAt> {
        let r = |dn: f64| (dn - black_dn) / span_dn;
        let (ri, rp) = (r(self.reference_dn[0]), r(self.reference_dn[1]));
        if !(span_dn > 0.0 && rp - ri > 1e-6) {
            return Vec::new();
        }
        self.bins
            .iter()
            .filter_map(|b| {
                let (li, lp) = (r(b.level_dn[0]), r(b.level_dn[1]));
                let gain = (lp - li) / (rp - ri);
                if !(gain > 1e-6 && gain <= 10.0) {
                    return None;
                }
                Some(MarkerLevelAt {
                    angle_deg: b.angle_deg,
                    gain,
                    offset: (li - gain * ri).clamp(-1.0, 1.0),
                })
            })
            .collect()
    }
}

/// The direction of the marker's printed x axis in the image, degrees: the mean of its top
/// (TL → TR) and bottom (BL → BR) edges, corners in OpenCV's order.
pub fn marker_image_angle_deg(c: &[[f64; 2]; 4]) -> f64 {
    let dx = (c[1][0] - c[0][0]) + (c[2][0] - c[3][0]);
    let dy = (c[1][1] - c[0][1]) + (c[2][1] - c[3][1]);
    dy.atan2(dx).to_degrees()
}

/// The slow frames of `frames` (in footage order) as samples: the wheel's angle is the marker's
/// image angle less `angle_offset_deg` (its angle on the disc plus its orientation; x right and
/// y down as in the untilted image, so a tilt of τ shifts it by at most about τ²/2), and each
/// trimmed-mean level goes through `to_reference(t_s, dn)` (the footage's light at t brought to
/// the reference light).
pub fn slow_frame_samples(
    frames: &[FrameObservation],
    angle_offset_deg: f64,
    to_reference: &dyn Fn(f64, f64) -> f64,
) -> Vec<LevelSample> {
    let moved = |a: &FrameObservation, b: &FrameObservation| -> Option<f64> {
        let (ca, cb) = (a.corners_px?, b.corners_px?);
        (b.frame == a.frame + 1).then(|| {
            (0..4)
                .map(|k| (ca[k][0] - cb[k][0]).hypot(ca[k][1] - cb[k][1]))
                .fold(0.0, f64::max)
        })
    };
    (1..frames.len().saturating_sub(1))
        .filter_map(|i| {
            let f = &frames[i];
            let slow = moved(&frames[i - 1], f)? < SLOW_PX && moved(f, &frames[i + 1])? < SLOW_PX;
            let (c, l) = (f.corners_px?, f.levels.as_ref()?);
            slow.then(|| LevelSample {
                theta2_deg: marker_image_angle_deg(&c) - angle_offset_deg,
                level_dn: [
                    to_reference(f.t_s, l.ink.trimmed_mean_dn),
                    to_reference(f.t_s, l.paper.trimmed_mean_dn),
                ],
            })
        })
        .collect()
}

/// A median and its standard error, 1.2533·sd/√n floored.
fn median_se(values: &mut [f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let sd = if values.len() > 1 {
        sample_sd(values)
    } else {
        0.0
    };
    (median(values), (1.2533 * sd / n.sqrt()).max(SE_FLOOR_DN))
}

/// The median of the finite `values` (how uniform levels are fitted), `None` when there are
/// none.
pub fn median_level(values: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    (!v.is_empty()).then(|| median(&mut v))
}

/// The mean of the finite `values` (what a texture mosaicked from those frames holds), `None`
/// when there are none.
pub fn mean_level(values: &[f64]) -> Option<f64> {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Bins `samples` by wheel angle; `reference_dn` is the ink and paper the scenario draws.
pub fn measure_level_table(
    samples: &[LevelSample],
    reference_dn: [f64; 2],
) -> Result<LevelTable, LevelTableError> {
    let bins_n = (360.0 / BIN_DEG).round() as usize;
    let mut by_bin: Vec<Vec<&LevelSample>> = vec![Vec::new(); bins_n];
    for s in samples.iter().filter(|s| s.theta2_deg.is_finite()) {
        let a = s.theta2_deg.rem_euclid(360.0);
        by_bin[((a / BIN_DEG) as usize).min(bins_n - 1)].push(s);
    }
    // The scatter of a frame's level about its bin's, pooled over the bins (each bin's own
    // from a few frames is too uncertain to judge its median by).
    let pooled_sd = [0, 1].map(|m| {
        let (ss, dof) = by_bin
            .iter()
            .filter(|v| v.len() >= MIN_FRAMES_PER_BIN)
            .fold((0.0, 0usize), |(ss, dof), v| {
                let x: Vec<f64> = v.iter().map(|s| s.level_dn[m]).collect();
                let sd = sample_sd(&x);
                (ss + sd * sd * (v.len() - 1) as f64, dof + v.len() - 1)
            });
        if dof > 0 {
            (ss / dof as f64).sqrt()
        } else {
            0.0
        }
    });
    let bins: Vec<AngleBin> = by_bin
        .iter()
        .enumerate()
        .filter(|(_, v)| v.len() >= MIN_FRAMES_PER_BIN)
        .map(|(k, v)| {
            let lo = k as f64 * BIN_DEG;
            let angle_deg = v
                .iter()
                .map(|s| s.theta2_deg.rem_euclid(360.0).clamp(lo, lo + BIN_DEG))
                .sum::<f64>()
                / v.len() as f64;
            let stat = |m: usize| {
                let mut x: Vec<f64> = v.iter().map(|s| s.level_dn[m]).collect();
                let (level, se) = median_se(&mut x);
                (
                    level,
                    se.max(1.2533 * pooled_sd[m] / (v.len() as f64).sqrt()),
                )
            };
            let (ink, paper) = (stat(0), stat(1));
            AngleBin {
                angle_deg: angle_deg.min(359.999),
                frames: v.len(),
                level_dn: [ink.0, paper.0],
                se_dn: [ink.1, paper.1],
            }
        })
        .collect();
    if bins.is_empty() {
        return Err(LevelTableError::TooFewFrames);
    }
    Ok(LevelTable {
        frames: bins.iter().map(|b| b.frames).sum(),
        bins,
        reference_dn,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::marker_levels::level_at;
    use rand::Rng;

    /// Frames at angles `angles_deg` whose ink follows `ink(θ)` and paper `paper(θ)`, with
    /// noise of `noise_dn` on each frame's level.
    fn samples(
        angles_deg: impl Iterator<Item = f64>,
        ink: impl Fn(f64) -> f64,
        paper: impl Fn(f64) -> f64,
        noise_dn: f64,
    ) -> Vec<LevelSample> {
        let mut rng = crate::rng::stream(5, crate::rng::Stream::MonteCarlo, 1);
        angles_deg
            .map(|a| {
                let mut n = || noise_dn * (rng.gen::<f64>() - 0.5) * 12f64.sqrt();
                LevelSample {
                    theta2_deg: a,
                    level_dn: [ink(a) + n(), paper(a) + n()],
                }
            })
            .collect()
    }

    fn sweep() -> impl Iterator<Item = f64> {
        (0..600).map(|k| 30.0 + 90.0 * k as f64 / 600.0)
    }

    #[test]
    fn a_level_that_follows_the_angle_is_recovered_as_a_map_of_the_drawn_levels() {
        let ink = |a: f64| 50.0 + 0.5 * (a - 30.0);
        let s = samples(sweep(), ink, |_| 213.0, 0.5);
        let t = measure_level_table(&s, [70.0, 213.0]).unwrap();
        assert!(t.shows_levels());
        assert_eq!(t.bins.len(), 18);
        let (black, span) = (20.0, 200.0);
        let e = t.entries(black, span);
        assert_eq!(e.len(), 18);
        // The map at a bin's angle takes the drawn ink (70 DN) to the footage's there.
        let dn = |r: f64| black + span * r;
        for a in [40.0f64, 77.5, 110.0] {
            let l = level_at(&e, a.to_radians()).unwrap();
            let drawn_ink = l.radiance((70.0 - black) / span);
            let drawn_paper = l.radiance((213.0 - black) / span);
            assert!(
                (dn(drawn_ink) - ink(a)).abs() < 0.6,
                "{a}°: {}",
                dn(drawn_ink)
            );
            assert!(
                (dn(drawn_paper) - 213.0).abs() < 0.3,
                "{a}°: {}",
                dn(drawn_paper)
            );
        }
    }

    #[test]
    fn steady_levels_show_no_table_and_a_small_change_none_either() {
        let r = [60.0, 210.0];
        let flat = samples(sweep(), |_| 60.0, |_| 210.0, 1.5);
        assert!(!measure_level_table(&flat, r).unwrap().shows_levels());
        // 1.8 DN over the sweep: below what is worth a table, however precisely measured.
        let small = samples(sweep(), |a| 60.0 + 0.02 * (a - 75.0), |_| 210.0, 0.1);
        let t = measure_level_table(&small, r).unwrap();
        assert!(t.largest_z() > Z_DEPARTURE, "precisely measured");
        assert!(!t.shows_levels());
    }

    #[test]
    fn two_angles_apart_are_a_table_and_one_angle_off_the_drawn_level_is_not() {
        // Two dwells seen slow, 49 and 99 DN of ink; a texture mosaicked from both holds their
        // mean: the maps take it to each.
        let two = (0..40).map(|k| if k % 2 == 0 { 270.0 } else { 359.0 } + 0.01 * k as f64);
        let ink = |a: f64| if a < 300.0 { 99.0 } else { 49.0 };
        let s = samples(two, ink, |_| 213.0, 0.3);
        let t = measure_level_table(&s, [74.0, 213.0]).unwrap();
        assert!(t.shows_levels(), "{t:?}");
        let e = t.entries(30.0, 200.0);
        let at = |deg: f64| {
            let l = level_at(&e, f64::to_radians(deg)).unwrap();
            30.0 + 200.0 * l.radiance((74.0 - 30.0) / 200.0)
        };
        assert!((at(270.2) - 99.0).abs() < 0.3 && (at(359.2) - 49.0).abs() < 0.3);
        // One angle seen, 10 DN below what is drawn: a level to fit, not an angle's.
        let one = samples(
            (0..20).map(|k| 90.0 + 0.1 * k as f64),
            |_| 60.0,
            |_| 210.0,
            0.3,
        );
        assert!(!measure_level_table(&one, [70.0, 210.0])
            .unwrap()
            .shows_levels());
    }

    #[test]
    fn a_few_noisy_frames_per_angle_are_not_taken_for_a_level_change() {
        // 4 frames per bin with 6 DN of noise: a bin median's error is ~4 DN.
        let few = (0..72).map(|k| 30.0 + 90.0 * k as f64 / 72.0);
        let s = samples(few, |_| 60.0, |_| 210.0, 6.0);
        let t = measure_level_table(&s, [60.0, 210.0]).unwrap();
        assert!(!t.shows_levels(), "largest z {}", t.largest_z());
    }

    fn observed(frame: usize, turn_deg: f64, ink_dn: f64) -> FrameObservation {
        let region = |dn: f64| crate::imagestats::RegionStats {
            median_dn: dn,
            trimmed_mean_dn: dn,
            noise_sigma_dn: 1.0,
            noise_sigma_diff_dn: 1.0,
            pixels: 400,
            pairs: 400,
            clipping: None,
        };
        // A 40 px marker centred 100 px right of the wheel centre at (200, 200).
        let a = turn_deg.to_radians();
        let (u, v) = (
            glam::DVec2::new(a.cos(), a.sin()),
            glam::DVec2::new(-a.sin(), a.cos()),
        );
        let centre = glam::DVec2::splat(200.0) + 100.0 * u;
        let corner = |x: f64, y: f64| (centre + 20.0 * (x * u + y * v)).to_array();
        FrameObservation {
            frame,
            t_s: frame as f64 / 30.0,
            corners_px: Some([
                corner(-1., -1.),
                corner(1., -1.),
                corner(1., 1.),
                corner(-1., 1.),
            ]),
            levels: Some(crate::imagestats::MarkerLevels {
                ink: region(ink_dn),
                paper: region(200.0),
                surround: None,
            }),
            ..Default::default()
        }
    }

    #[test]
    fn only_frames_slow_on_both_sides_are_sampled_at_the_wheel_s_angle() {
        // At rest at 10° (frames 0–4), then turning 2°/frame (1.75 px of corner travel at a
        // radius of ~100 px), then slow at 0.2°/frame; frame 12 has no marker.
        let mut turn = 10.0;
        let frames: Vec<FrameObservation> = (0..20)
            .map(|k| {
                turn += match k {
                    0..=4 => 0.0,
                    5..=9 => 2.0,
                    _ => 0.2,
                };
                let mut f = observed(k, turn, 50.0 + k as f64);
                if k == 12 {
                    f.corners_px = None;
                }
                f
            })
            .collect();
        let s = slow_frame_samples(&frames, 30.0, &|_, dn| dn + 1.0);
        let frames_of: Vec<f64> = s.iter().map(|x| x.level_dn[0] - 51.0).collect();
        // 1–3 at rest (0 and 4 lack a slow neighbour on one side: 4 → 5 turns 2°), 10 is slow
        // on both sides (9 → 10 moves 0.2°), 11 and 13 touch the frame without a marker.
        assert_eq!(
            frames_of,
            vec![1.0, 2.0, 3.0, 10.0, 14.0, 15.0, 16.0, 17.0, 18.0]
        );
        assert!(
            (s[0].theta2_deg - (10.0 - 30.0)).abs() < 1e-9,
            "{}",
            s[0].theta2_deg
        );
    }

    /// A dwell the clip leaves after a few frames (two slow ones at 0°) beside a long one at
    /// 270°, the glossy ink 50 DN darker at 0°: both angles are bins and the table draws them.
    #[test]
    fn two_slow_frames_at_an_angle_make_a_bin() {
        let angles = [0.5, 1.0]
            .into_iter()
            .chain((0..24).map(|k| 270.0 + 0.01 * k as f64));
        let s = samples(
            angles,
            |a| if a < 90.0 { 48.0 } else { 100.0 },
            |_| 220.0,
            1.0,
        );
        let t = measure_level_table(&s, [96.0, 220.0]).unwrap();
        assert_eq!(t.bins.len(), 2);
        assert_eq!((t.bins[0].frames, t.bins[1].frames), (2, 24));
        assert!(t.shows_levels(), "largest z {}", t.largest_z());
    }

    /// Two frames per angle with 6 DN of noise: a two-frame bin's median is ~5 DN off, far
    /// below what the departure test asks of it.
    #[test]
    fn two_noisy_frames_per_angle_are_not_taken_for_a_level_change() {
        let pairs = (0..36).flat_map(|k| [5.0 * k as f64 + 1.0, 5.0 * k as f64 + 2.0]);
        let s = samples(pairs, |_| 60.0, |_| 210.0, 6.0);
        let t = measure_level_table(&s, [60.0, 210.0]).unwrap();
        assert_eq!(t.bins.len(), 36);
        assert!(!t.shows_levels(), "largest z {}", t.largest_z());
    }

    #[test]
    fn angles_wrap_and_a_lone_frame_makes_no_bin() {
        let s = samples(
            [-2.5, 357.0, 358.0, 719.0, 100.0].into_iter(),
            |_| 60.0,
            |_| 200.0,
            0.0,
        );
        let t = measure_level_table(&s, [60.0, 200.0]).unwrap();
        assert_eq!(t.bins.len(), 1);
        assert_eq!(t.bins[0].frames, 4);
        assert!((t.bins[0].angle_deg - 357.875).abs() < 1e-9);
        assert_eq!(
            measure_level_table(&s[4..], [60.0, 200.0]),
            Err(LevelTableError::TooFewFrames)
        );
    }
}
