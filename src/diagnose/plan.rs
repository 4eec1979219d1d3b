//! Which cells each candidate effect can move (its signature), used to screen candidates
//! cheaply before the expensive fits, and the direct first guesses of parameters from the real
//! measurement (refined afterwards by simulation).

use super::cells::CellKey;
use super::gap::{excess, GapMap};
use crate::numeric::dist::{normal_cdf, normal_pdf};
use crate::scenario::effects::Effect;

/// Channels an effect changes and its fit aims at (Σ z² over them is the fit objective).
/// Screening also counts [`screening_only`] cells.
pub fn signature(e: Effect) -> &'static [&'static str] {
    const KIN: &[&str] = &["theta", "omega", "alpha"];
    match e {
        Effect::DriveSpeed => KIN,
        Effect::Backlash | Effect::Overrotation => &["theta", "omega", "alpha", "missing"],
        Effect::DiscVibration => KIN,
        Effect::AxisRunout => &["radius", "theta", "omega", "alpha"],
        Effect::CameraVibration => &[
            "radius",
            "theta",
            "omega",
            "alpha",
            "reference_x",
            "reference_y",
            "rigid_residual",
        ],
        Effect::FrameTiming => &[
            "interval_median",
            "interval_jitter",
            "first_interval",
            "long_intervals",
            "alternation",
        ],
        Effect::Timebase => &[
            "interval_median",
            "interval_jitter",
            "first_interval",
            "long_intervals",
            "alternation",
            "theta",
            "omega",
            "alpha",
        ],
        Effect::PixelNoise => &[
            "noise_ink",
            "noise_paper",
            "flicker_paper",
            "flicker_ink",
            "theta",
            "omega",
            "alpha",
            "rigid_residual",
            "missing",
        ],
        Effect::OpticalBlur => &[
            "edge_across",
            "edge_along",
            "rigid_residual",
            "theta",
            "missing",
        ],
        Effect::MotionBlur => &[
            "edge_motion",
            "edge_across",
            "edge_along",
            "rigid_residual",
            "theta",
            "omega",
            "alpha",
            "missing",
        ],
        Effect::RollingShutter => &[
            "rs_fine",
            "rs_readout",
            "stretch_x",
            "stretch_diag",
            "rigid_residual",
            "theta",
            "omega",
            "alpha",
        ],
        Effect::LensDistortion => &[
            "radius",
            "side",
            "stretch_x",
            "stretch_diag",
            "theta",
            "omega",
            "alpha",
            "rigid_residual",
        ],
        Effect::PerspectiveTilt => &[
            "stretch_x",
            "stretch_diag",
            "side",
            "radius",
            "theta",
            "omega",
            "alpha",
            "rigid_residual",
        ],
        Effect::Compression => &[
            "blockiness",
            "noise_ink",
            "noise_paper",
            "edge_across",
            "edge_along",
            "rigid_residual",
            "theta",
            "missing",
        ],
        // A video codec smooths the noise and the edges as its bitrate falls, unevenly (a 32 px
        // marker's static edges at 0.04 bit/px: 4.6 px² more variance across the motion than
        // along it, z = 53); its motion compensation bends a moving marker's shape with its
        // velocity (H.264 at 1 Mbit/s on 2 s of the quiet 1280×720 rig: a readout implied by
        // shape against velocity of +0.027 s against the nominal's −0.019 s, z = 5.9, its only
        // significant cells); and its key frames differ from the predicted frames between
        // them: a level that pumps at the group of pictures' rate.
        Effect::VideoCodec => &[
            "noise_ink",
            "noise_paper",
            "blockiness",
            "edge_across",
            "edge_along",
            "edge_motion",
            "rs_fine",
            "rs_readout",
            "flicker_paper",
            "flicker_ink",
            "rigid_residual",
            "theta",
            "missing",
        ],
        Effect::Lighting => &[
            "ink",
            "paper",
            "background",
            "noise_ink",
            "noise_paper",
            "missing",
        ],
    }
}

/// Cells an effect moves but that its fit does not aim at: they count when screening (an
/// effect whose gap lies there is fitted), not in the fit objective.
///
/// A tilt or a lens distortion changes the marker's shape with its position on the image, and
/// so with the angle and the velocity, which moves the readout implied by shape against
/// velocity (`rs_fine`, `rs_readout`). Out of screening, a (−22°, −28°) tilt that put 98.8 % of
/// its gap in `rs_fine` was bounded out unfitted, and so were a (−8°, 15°) tilt and a k1 + k2
/// lens (`unexplained`, rolling shutter or a k1 lens at its bound the best partial). In the fit
/// objective, footage whose only gap was a rolling shutter's `rs_fine` (z = 12.8), rolling
/// shutter excluded from the candidates, came out `explained` by a k1 = 0.11 lens bent to close
/// that one cell: a silent misattribution. Fitted on the shape, side, radius and kinematic cells
/// alone, a real tilt or lens closes `rs_fine` as a consequence, and a rolling shutter's
/// `rs_fine` gives a lens nothing to fit.
pub fn screening_only(e: Effect) -> &'static [&'static str] {
    match e {
        Effect::LensDistortion | Effect::PerspectiveTilt => &["rs_fine", "rs_readout"],
        _ => &[],
    }
}

/// Whether `channel` is one of the angle's (θ, ω̂ and α̂ residuals, the angle's spectral peak).
pub fn is_angle_channel(channel: &str) -> bool {
    matches!(channel, "theta" | "omega" | "alpha" | "theta_peak")
}

/// Whether `key` belongs to `e`'s signature (the cells its fit aims at).
pub fn in_signature(e: Effect, key: &CellKey) -> bool {
    let sig = signature(e);
    // The angle residual's spectral peak belongs to every effect that moves the angle.
    sig.contains(&key.channel) || (key.channel == "theta_peak" && sig.contains(&"theta"))
}

/// Whether `key` can hold `e`'s gap: its signature or its [`screening_only`] cells.
pub fn in_screening(e: Effect, key: &CellKey) -> bool {
    in_signature(e, key) || screening_only(e).contains(&key.channel)
}

/// Share of the total gap that lies in the cells `e` moves ([`in_screening`]): an upper bound
/// on the shrink the effect could reach. 0 when there is no gap.
pub fn screening_share(e: Effect, gap: &GapMap) -> f64 {
    if gap.total <= 0.0 {
        return 0.0;
    }
    let z0 = gap.options.dead_zone_z;
    gap.cells
        .iter()
        .filter(|c| in_screening(e, &c.key))
        .map(|c| excess(c.z, z0))
        .sum::<f64>()
        / gap.total
}

/// The second effects worth fitting beside `first` when `first` alone leaves `remainder` (its
/// gap map, judged on fresh seeds) with significant cells: of `candidates` (the effects with a
/// significant cell of the nominal gap in their signature), those other than `first` and its
/// switch-mates with a significant cell of the remainder among the cells they move, the largest
/// share of the remainder first, at most `n`.
///
/// The nominal gap cannot choose them: when the first cause dominates it, a second one holds a
/// sliver of it. A 10 ms motion blur and a 1 px camera shake filmed together put 99.8 % of the
/// nominal gap in the blur's cells; the shake's share (0.2 %) bounded it out of the single
/// fits, the runners-up of those (a JPEG quality) were tried as the second effect, and the
/// shake's cells (θ and radius at 3–10 Hz, z 4–7) were left unexplained.
pub fn second_effects(
    first: Effect,
    candidates: &[Effect],
    remainder: &GapMap,
    n: usize,
) -> Vec<Effect> {
    let mut shares: Vec<(Effect, f64)> = candidates
        .iter()
        .copied()
        .filter(|&e| e != first && !first.shares_switch_with().contains(&e))
        .filter(|&e| signature_significant(e, remainder))
        .map(|e| (e, screening_share(e, remainder)))
        .collect();
    // Stable: equal shares keep the candidates' order.
    shares.sort_by(|a, b| b.1.total_cmp(&a.1));
    shares.into_iter().take(n).map(|(e, _)| e).collect()
}

/// The runner-up single worth pairing with `first` besides those [`second_effects`] chose
/// (`chosen`): the best-ranked of `singles` (fitted alone, best first, each with its score)
/// that is neither `first`, a switch-mate of it, nor already chosen, and closed some of the gap
/// alone (score > 0). None when no such single was fitted.
///
/// The remainder cannot always choose it: a second cause whose cells the first one's fit
/// overlaps leaves no significant cell of its own. A disc vibration filmed with a 2 mm axis
/// runout scored 0.675 alone, beside the runout's 0.681, yet the runout's remainder held none
/// of its cells, and the pairs tried were the runout with a camera shake, a lens and a tilt.
pub fn runner_up_second(
    first: Effect,
    singles: &[(Effect, f64)],
    chosen: &[Effect],
) -> Option<Effect> {
    singles
        .iter()
        .find(|(e, score)| {
            *e != first
                && !first.shares_switch_with().contains(e)
                && !chosen.contains(e)
                && *score > 0.0
        })
        .map(|(e, _)| *e)
}

/// Remaining total gap D (units of D: Σ max(0, |z| − 2)²) above which a single effect that
/// explains the gap gets a second look for a second cause: its remainder has no significant
/// cell, yet sums to more than a comparison that agrees leaves.
///
/// Over 95 independent cells of z ~ N(0, 1) (a gap map's size on the self-check's rigs), D's
/// 99th percentile is 5.1 and its 99.9th 7.6 (Monte Carlo, 40 000 draws); over the stored
/// `explained` diagnoses of the self-checks run before this rule (about 150 distinct single-effect cases,
/// both renderers, both rigs) the best single left more than 8 twice: a weak tilt (9.3) and an
/// optical blur of 1.4 px filmed with a JPEG quality of 35 (11.5), which the JPEG quality alone
/// "explained": its six edge-width cells at |z| ≈ 3.4 each missed Benjamini–Hochberg by a hair.
pub const SECOND_LOOK_REMAINDER: f64 = 8.0;

/// Share of an explaining single's remainder that a second effect's cells must hold for the
/// second look to try it: the cause of what is left, not a bystander to it.
pub const SECOND_LOOK_SHARE: f64 = 0.5;

/// Share of the single's remainder a second-look pair must close to be kept
/// (D_pair ≤ (1 − this) · D_single): a second effect fitted to seed noise lowers D by the
/// noise's luck, not by half.
pub const SECOND_LOOK_CLOSE: f64 = 0.5;

/// The second effects worth a second look beside `first` when `first` alone explains the gap
/// but leaves `remainder` (its gap map on fresh seeds) above [`SECOND_LOOK_REMAINDER`]: of
/// `candidates`, those other than `first` and its switch-mates whose cells hold at least
/// [`SECOND_LOOK_SHARE`] of the remainder, the largest share first, at most `n`. None when the
/// remainder is within what noise leaves.
pub fn second_look_effects(
    first: Effect,
    candidates: &[Effect],
    remainder: &GapMap,
    n: usize,
) -> Vec<Effect> {
    if remainder.total.is_nan() || remainder.total <= SECOND_LOOK_REMAINDER {
        return Vec::new();
    }
    let mut shares: Vec<(Effect, f64)> = candidates
        .iter()
        .copied()
        .filter(|&e| e != first && !first.shares_switch_with().contains(&e))
        .map(|e| (e, screening_share(e, remainder)))
        .filter(|(_, share)| *share >= SECOND_LOOK_SHARE)
        .collect();
    shares.sort_by(|a, b| b.1.total_cmp(&a.1));
    shares.into_iter().take(n).map(|(e, _)| e).collect()
}

/// Standard uncertainties from the nominal's value that a second-look pair's second effect
/// must lie, on its first fit, to be kept ([`judge_second_look_pair`]); twice the verdict's
/// [`super::verdict::DISTINCT_Z`] because a first fit's ± (two fit seeds) understates its
/// spread: the own renderer's weak tilt, paired with a rolling shutter, fitted a readout of
/// 1.10 ± 0.50 ms against the nominal's 0.5 ms (1.2 σ), and both refits on fresh seeds put it
/// at 0.5 ms exactly (pooled 0.70 ± 0.69 ms, 0.3 σ). A second cause the second look found (an
/// optical blur of 1.417 ± 0.029 px against the nominal's 0.7 px) lies tens of σ off.
pub const SECOND_LOOK_DISTINCT_Z: f64 = 2.0;

/// What a second look does with a pair it fitted ([`judge_second_look_pair`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SecondLookPair {
    /// Ranked beside the single: it closed a good part of what the single left, with a second
    /// effect the data tell from the nominal.
    Kept,
    /// Set aside: it left more than (1 − [`SECOND_LOOK_CLOSE`]) of the single's remainder.
    ClosesTooLittle,
    /// Set aside: it closed enough, but every fitted value of its second effect lies within
    /// [`SECOND_LOOK_DISTINCT_Z`] standard uncertainties of the nominal's, so the pair is the
    /// single under another name and what it closed was closed by the fit seeds' luck.
    SecondAtNominal,
}

impl SecondLookPair {
    pub fn kept(self) -> bool {
        self == Self::Kept
    }
}

/// Judges a second-look pair from the remaining gap the single left (`single_remainder`), the
/// one the pair leaves (`pair_remainder`, NaN is never kept) and whether its second effect's
/// first-fit values tell it from the nominal at [`SECOND_LOOK_DISTINCT_Z`]
/// ([`super::verdict::tells_from_nominal_at`]; `None`,
/// a value the data do not determine, does not set it aside: the verdict's own guard judges it
/// again on the refitted ±). The remainder rule comes first, so a pair that closes too little
/// is reported as such whatever its values.
pub fn judge_second_look_pair(
    single_remainder: f64,
    pair_remainder: f64,
    second_tells: Option<bool>,
) -> SecondLookPair {
    let closes_enough = pair_remainder <= (1.0 - SECOND_LOOK_CLOSE) * single_remainder;
    if !closes_enough {
        SecondLookPair::ClosesTooLittle
    } else if second_tells == Some(false) {
        SecondLookPair::SecondAtNominal
    } else {
        SecondLookPair::Kept
    }
}

/// How far a pair's second effect must lower the fit objective (Σ z² over both effects'
/// signature cells on the fit seeds, the first effect at its values) below the nominal's own
/// setting of it, per parameter fitted, to count as doing something
/// ([`second_lowers_fit`]): Akaike's 2, the verdict's [`super::verdict::PENALTY_PER_PARAM`] on
/// the gap, since a parameter fitted to noise alone lowers a χ² by about 1. The fits search
/// from a generic start with a few evaluations, and could end where the objective is higher
/// than with the effect as the nominal has it: beside a 2.2 mm runout, a drive-speed variation
/// fitted at +2.9 % gave 80.0 where none gave 78.5, a tilt at (−1.0°, −0.7°) 122.3 where none
/// gave 120.5, and a lens fitted at k1 = 0 exactly the nominal's 120.5. Each pair then left
/// 28–48 of the 14.3 the runout alone left.
pub const SECOND_DROP_PER_PARAM: f64 = super::verdict::PENALTY_PER_PARAM;

/// Whether a second effect fitted with `params` parameters lowers the fit objective from
/// `nominal_sum_z2` (the effect as the nominal has it) to `fitted_sum_z2` by more than
/// [`SECOND_DROP_PER_PARAM`] per parameter. A failed simulation's infinite objective never
/// does; NaN never does.
pub fn second_lowers_fit(nominal_sum_z2: f64, fitted_sum_z2: f64, params: usize) -> bool {
    fitted_sum_z2.is_finite()
        && nominal_sum_z2 - fitted_sum_z2 > SECOND_DROP_PER_PARAM * params as f64
}

/// Whether a pair's backfit keeps the first effect's refitted values: when they leave the fit
/// objective (Σ z² over both effects' signature cells on the fit seeds, the second effect at
/// its values) no higher than the values the first effect had, `refit_sum_z2` against
/// `kept_sum_z2`; or when the old values' objective failed and the refit's did not. A refit
/// searches from a generic start with a few evaluations and can end above the point it
/// replaces: beside a drive-speed variation, a 2.15 mm runout refitted at 1.30 mm gave 86.4
/// where 2.15 mm gave 80.0, and the pair then left 2× what the runout alone did. A failed or
/// NaN refit never replaces.
pub fn backfit_keeps_refit(kept_sum_z2: f64, refit_sum_z2: f64) -> bool {
    refit_sum_z2.is_finite() && (refit_sum_z2 <= kept_sum_z2 || !kept_sum_z2.is_finite())
}

/// Whether a cell `e` moves ([`in_screening`]) is significant.
pub fn signature_significant(e: Effect, gap: &GapMap) -> bool {
    gap.significant().any(|c| in_screening(e, &c.key))
}

/// Optical blur σ that moves a measured edge σ from `sim_px` (nominal optical σ
/// `nominal_px`) to `real_px`, adding in quadrature (Gaussian blurs add variances).
pub fn guess_optical_sigma(real_px: f64, sim_px: f64, nominal_px: f64) -> f64 {
    (nominal_px * nominal_px + real_px * real_px - sim_px * sim_px)
        .max(0.05 * 0.05)
        .sqrt()
}

/// Exposure (s) that adds the measured extra edge variance across the motion: a box of length
/// v·T adds (v·T)²/12 to the edge's second moment.
pub fn guess_exposure_s(extra_variance_px2: f64, speed_px_s: f64, nominal_s: f64) -> f64 {
    if speed_px_s <= 0.0 {
        return nominal_s.max(1e-3);
    }
    (nominal_s * nominal_s + 12.0 * extra_variance_px2 / (speed_px_s * speed_px_s))
        .max(1e-8)
        .sqrt()
}

/// Variance (normalised units², 1 = the tone curve's span) of what the tone curve passes at a
/// level `mu` (0 = black, 1 = white) when the sensor adds Gaussian noise of σ `sigma`: the
/// signal is clamped to [0, 1] before the tone curve, so a white paper at the clip keeps only
/// 0.34 σ² of its noise variance (a censored normal's variance).
pub fn clipped_variance(mu: f64, sigma: f64) -> f64 {
    if sigma.is_nan() || sigma <= 0.0 {
        return 0.0;
    }
    let (a, b) = (-mu / sigma, (1.0 - mu) / sigma);
    let (pa, pb) = (normal_cdf(a), normal_cdf(b));
    let (fa, fb) = (normal_pdf(a), normal_pdf(b));
    // W = clamp(Z, a, b): its mass at a and b plus the normal between them.
    let tail = |z: f64, p: f64| if p > 0.0 { z * p } else { 0.0 };
    let m1 = tail(a, pa) + (fa - fb) + tail(b, 1.0 - pb);
    let m2 = tail(a * a, pa) + (pb - pa + a * fa - b * fb) + tail(b * b, 1.0 - pb);
    sigma * sigma * (m2 - m1 * m1).max(0.0)
}

/// The sensor's noise variance (normalised units², before the clip) at level `mu` whose
/// [`clipped_variance`] is `clipped`: bisection on σ, along which the clipped variance rises.
/// `None` when no σ up to the whole span gives it, or the input is not finite.
pub fn unclipped_variance(mu: f64, clipped: f64) -> Option<f64> {
    if !(clipped.is_finite() && mu.is_finite()) {
        return None;
    }
    if clipped <= 0.0 {
        return Some(0.0);
    }
    let (mut lo, mut hi) = (0.0f64, 2.0f64);
    if clipped_variance(mu, hi) < clipped {
        return None;
    }
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if clipped_variance(mu, mid) < clipped {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let sigma = 0.5 * (lo + hi);
    Some(sigma * sigma)
}

/// The sensor's noise variance (normalised units², before the clip) at radiance `s` from the
/// noise σ measured in DN behind a linear tone curve spanning `span_dn` DN: the 8-bit
/// quantisation (1/12 DN²) taken off, then the clip at black and white undone.
pub fn sensor_variance(sigma_dn: f64, s: f64, span_dn: f64) -> Option<f64> {
    let measured = (sigma_dn * sigma_dn - 1.0 / 12.0).max(0.0) / (span_dn * span_dn);
    unclipped_variance(s, measured)
}

/// Full well and read noise (e⁻) from the noise σ (DN) measured on two radiances `s_ink` and
/// `s_paper` of a linear tone curve spanning `span_dn` DN from radiance 0 to 1: the sensor's
/// variance ([`sensor_variance`]: quantisation off, clip undone) is s/FW + RN²/FW². `None`
/// when the two levels do not separate shot from read noise (the paper's sensor noise not
/// above the ink's).
///
/// The clip matters: a paper at radiance 1 is at the white clip, where the tone curve passes a
/// third of the noise variance. Read as unclipped, such footage shows less noise on the paper
/// than on the ink, the opposite of shot noise, and no noise model fitted it.
pub fn guess_noise(
    sigma_ink_dn: f64,
    sigma_paper_dn: f64,
    s_ink: f64,
    s_paper: f64,
    span_dn: f64,
) -> Option<(f64, f64)> {
    let vi = sensor_variance(sigma_ink_dn, s_ink, span_dn)?;
    let vp = sensor_variance(sigma_paper_dn, s_paper, span_dn)?;
    if !(vp > vi && s_paper > s_ink) {
        return None;
    }
    let fw = (s_paper - s_ink) / (vp - vi);
    let rn2 = (vi - s_ink / fw) * fw * fw;
    Some((fw, rn2.max(0.0).sqrt()))
}

/// Black and white levels (DN) of a linear tone curve that put radiances `s_ink` and
/// `s_paper` at the measured ink and paper levels.
pub fn guess_levels(ink_dn: f64, paper_dn: f64, s_ink: f64, s_paper: f64) -> Option<(f64, f64)> {
    if s_paper <= s_ink {
        return None;
    }
    let span = (paper_dn - ink_dn) / (s_paper - s_ink);
    let black = ink_dn - span * s_ink;
    Some((black, black + span))
}

/// Black level, white level (DN) and gamma of the tone curve DN = black + (white − black)·s^(1/γ)
/// that put radiances `s_ink`, `s_paper` and a mid-tone `s_mid` (the disc around the marker) at
/// the measured levels: γ by bisection on [0.3, 3] (the mid-tone's predicted level rises
/// monotonically with γ), then the two levels. `None` when the mid-tone is not strictly between
/// ink and paper or no γ in range fits it.
pub fn guess_tone(
    levels_dn: [f64; 3],
    s_ink: f64,
    s_paper: f64,
    s_mid: f64,
) -> Option<(f64, f64, f64)> {
    let [ink, paper, mid] = levels_dn;
    if !(s_ink < s_mid && s_mid < s_paper && ink < mid && mid < paper && s_ink >= 0.0) {
        return None;
    }
    let predicted = |gamma: f64| {
        let u = |s: f64| s.powf(1.0 / gamma);
        ink + (paper - ink) * (u(s_mid) - u(s_ink)) / (u(s_paper) - u(s_ink))
    };
    let (mut lo, mut hi) = (0.3f64, 3.0f64);
    if !(predicted(lo) <= mid && mid <= predicted(hi)) {
        return None;
    }
    for _ in 0..60 {
        let m = (lo * hi).sqrt();
        if predicted(m) < mid {
            lo = m;
        } else {
            hi = m;
        }
    }
    let gamma = (lo * hi).sqrt();
    let (ui, up) = (s_ink.powf(1.0 / gamma), s_paper.powf(1.0 / gamma));
    let span = (paper - ink) / (up - ui);
    let black = ink - span * ui;
    Some((black, black + span, gamma))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tone_is_recovered_from_three_levels() {
        let (b, w, g) = (90.0, 170.0, 1.6);
        let dn = |s: f64| b + (w - b) * f64::powf(s, 1.0 / g);
        let (s_i, s_p, s_m) = (0.04, 1.0, 0.55);
        let (b2, w2, g2) = guess_tone([dn(s_i), dn(s_p), dn(s_m)], s_i, s_p, s_m).unwrap();
        assert!((b2 - b).abs() < 1e-6 && (w2 - w).abs() < 1e-6 && (g2 - g).abs() < 1e-6);
        // A mid level outside ink..paper has no tone.
        assert!(guess_tone([50.0, 200.0, 210.0], s_i, s_p, s_m).is_none());
    }

    /// A gap map of `cells` (channel, phase, z, significant) in the drive phase.
    fn remainder_of(cells: &[(&'static str, f64, bool)]) -> GapMap {
        use crate::diagnose::gap::{CellGap, GapOptions};
        let options = GapOptions::default();
        let cells: Vec<CellGap> = cells
            .iter()
            .map(|&(channel, z, significant)| CellGap {
                key: CellKey {
                    channel,
                    phase: "drive",
                    band: None,
                },
                real: z,
                sim_mean: 0.0,
                sim_std: 1.0,
                sims: 4,
                z,
                p: if significant { 1e-6 } else { 0.5 },
                significant,
            })
            .collect();
        let total = cells.iter().map(|c| excess(c.z, options.dead_zone_z)).sum();
        GapMap {
            cells,
            total,
            options,
        }
    }

    #[test]
    fn second_effects_are_chosen_on_what_the_first_leaves() {
        // The motion blur + camera shake footage: after the blur, the shake's cells are left
        // (radius and ω̂), the edges are closed, and a JPEG quality moves nothing that is left.
        let left = remainder_of(&[
            ("radius", 4.4, true),
            ("omega", 5.4, true),
            ("edge_across", 1.0, false),
            ("blockiness", 0.5, false),
        ]);
        let candidates = [
            Effect::MotionBlur,
            Effect::Compression,
            Effect::CameraVibration,
            Effect::Backlash,
            Effect::AxisRunout,
        ];
        let second = second_effects(Effect::MotionBlur, &candidates, &left, 3);
        // Camera vibration and runout move the radius and ω̂ (the larger share; equal shares
        // keep the candidates' order), the backlash ω̂ only; compression nothing that is left.
        assert_eq!(
            second,
            vec![
                Effect::CameraVibration,
                Effect::AxisRunout,
                Effect::Backlash
            ]
        );
        assert_eq!(
            second_effects(Effect::MotionBlur, &candidates, &left, 1),
            vec![Effect::CameraVibration]
        );
        // Never the first itself or an effect sharing its switch.
        let after_backlash = second_effects(
            Effect::Backlash,
            &[
                Effect::Overrotation,
                Effect::Backlash,
                Effect::CameraVibration,
            ],
            &left,
            3,
        );
        assert_eq!(after_backlash, vec![Effect::CameraVibration]);
        // Nothing significant left: no second effect.
        let closed = remainder_of(&[("radius", 1.0, false), ("omega", 1.5, false)]);
        assert!(second_effects(Effect::MotionBlur, &candidates, &closed, 3).is_empty());
    }

    #[test]
    fn the_runner_up_single_is_paired_when_the_remainder_did_not_choose_it() {
        // The disc vibration + runout footage: the runout first, the vibration a hair behind.
        let singles = [
            (Effect::AxisRunout, 0.681),
            (Effect::DiscVibration, 0.675),
            (Effect::Overrotation, 0.637),
        ];
        let chosen = [
            Effect::CameraVibration,
            Effect::LensDistortion,
            Effect::PerspectiveTilt,
        ];
        assert_eq!(
            runner_up_second(Effect::AxisRunout, &singles, &chosen),
            Some(Effect::DiscVibration)
        );
        // Already chosen: the next one.
        assert_eq!(
            runner_up_second(Effect::AxisRunout, &singles, &[Effect::DiscVibration]),
            Some(Effect::Overrotation)
        );
        // Only the first, or runners-up that closed nothing alone: none.
        assert_eq!(
            runner_up_second(Effect::AxisRunout, &singles[..1], &chosen),
            None
        );
        let idle = [(Effect::AxisRunout, 0.681), (Effect::MotionBlur, -0.03)];
        assert_eq!(runner_up_second(Effect::AxisRunout, &idle, &chosen), None);
        // A switch-mate of the first is never its second.
        let with_mate = [(Effect::Backlash, 0.9), (Effect::Overrotation, 0.8)];
        assert_eq!(runner_up_second(Effect::Backlash, &with_mate, &[]), None);
    }

    #[test]
    fn a_second_effect_counts_only_when_it_lowers_the_fit_below_the_nominal_by_two_per_parameter() {
        // The runout pairs of the seed-1 disc vibration + runout footage (commit e8389b2).
        assert!(
            !second_lowers_fit(78.48, 79.98, 1),
            "drive speed above the nominal's"
        );
        assert!(
            !second_lowers_fit(120.48, 122.26, 2),
            "tilt above the nominal's"
        );
        assert!(
            !second_lowers_fit(120.48, 120.48, 1),
            "lens at the nominal's k1 = 0"
        );
        // Two per parameter: 4.01 below with two parameters counts, 4.0 does not.
        assert!(second_lowers_fit(100.0, 95.99, 2));
        assert!(!second_lowers_fit(100.0, 96.0, 2));
        assert!(second_lowers_fit(100.0, 97.9, 1));
        // A simulation that failed (infinite) or NaN never counts; a nominal that failed
        // does not stop a second that simulated.
        assert!(!second_lowers_fit(100.0, f64::INFINITY, 1));
        assert!(!second_lowers_fit(f64::INFINITY, f64::INFINITY, 1));
        assert!(!second_lowers_fit(f64::NAN, 1.0, 1));
        assert!(!second_lowers_fit(100.0, f64::NAN, 1));
        assert!(second_lowers_fit(f64::INFINITY, 50.0, 1));
    }

    #[test]
    fn a_backfit_keeps_the_refit_only_where_it_does_not_climb() {
        // The pair footage's runout refitted beside a drive-speed variation: 1.30 mm gave 86.4 where the
        // single's 2.15 mm gave 80.0.
        assert!(!backfit_keeps_refit(80.0, 86.4));
        // The seed-0 shake refitted beside a motion blur: 1.20 → 0.93 px lowered 79.5 → 71.7.
        assert!(backfit_keeps_refit(79.5, 71.7));
        // A refit that ends where it started is kept (same values, same objective).
        assert!(backfit_keeps_refit(42.0, 42.0));
        // Failures: a failed or NaN refit never replaces; a failed old point always yields.
        assert!(!backfit_keeps_refit(80.0, f64::INFINITY));
        assert!(!backfit_keeps_refit(80.0, f64::NAN));
        assert!(!backfit_keeps_refit(f64::INFINITY, f64::INFINITY));
        assert!(backfit_keeps_refit(f64::INFINITY, 90.0));
        assert!(backfit_keeps_refit(f64::NAN, 90.0));
    }

    #[test]
    fn a_second_look_keeps_a_pair_that_halves_the_remainder_with_a_second_off_the_nominal() {
        use SecondLookPair::*;
        // Rig 2's blur + JPEG: the pair left 0.0 of 11.5 with a blur far from the nominal's.
        assert_eq!(judge_second_look_pair(11.5, 0.0, Some(true)), Kept);
        // The motion-blur pair tried beside it left 11.2: too little, whatever its values.
        assert_eq!(
            judge_second_look_pair(11.5, 11.2, Some(true)),
            ClosesTooLittle
        );
        assert_eq!(
            judge_second_look_pair(11.5, 11.2, Some(false)),
            ClosesTooLittle
        );
        // The weak tilt's 27.5 closed to 3.4 by a readout first fitted at 1.10 ± 0.50 ms, within
        // 2 σ (SECOND_LOOK_DISTINCT_Z) of the nominal's 0.5 ms: the single under another name.
        assert_eq!(
            judge_second_look_pair(27.5, 3.4, Some(false)),
            SecondAtNominal
        );
        // Undetermined values are left to the verdict's guard.
        assert_eq!(judge_second_look_pair(27.5, 3.4, None), Kept);
        // Exactly half is kept; just above is not; NaN never is.
        assert_eq!(judge_second_look_pair(10.0, 5.0, Some(true)), Kept);
        assert_eq!(
            judge_second_look_pair(10.0, 5.0 + 1e-9, Some(true)),
            ClosesTooLittle
        );
        assert_eq!(
            judge_second_look_pair(10.0, f64::NAN, Some(true)),
            ClosesTooLittle
        );
        assert!(Kept.kept() && !ClosesTooLittle.kept() && !SecondAtNominal.kept());
    }

    #[test]
    fn a_second_look_tries_the_effects_that_hold_what_an_explaining_single_leaves() {
        // The optical blur + JPEG footage after the JPEG quality alone: six edge-width cells
        // at |z| ≈ 3.4, none significant, 11.5 in all; the blockiness closed.
        let mut cells: Vec<(&'static str, f64, bool)> = ["edge_across", "edge_along"]
            .iter()
            .flat_map(|c| [(*c, 3.4, false), (*c, 3.4, false), (*c, 3.35, false)])
            .collect();
        cells.push(("blockiness", 0.3, false));
        let left = remainder_of(&cells);
        assert!(left.total > SECOND_LOOK_REMAINDER && left.n_significant() == 0);
        let candidates = [
            Effect::Compression,
            Effect::OpticalBlur,
            Effect::MotionBlur,
            Effect::Lighting,
        ];
        let second = second_look_effects(Effect::Compression, &candidates, &left, 3);
        assert!(second.contains(&Effect::OpticalBlur), "{second:?}");
        assert!(!second.contains(&Effect::Compression));
        assert!(
            !second.contains(&Effect::Lighting),
            "it moves no edge width"
        );
        assert!(
            second_effects(Effect::Compression, &candidates, &left, 3).is_empty(),
            "the first look needs a significant cell"
        );
        // Within what noise leaves: no second look.
        let small = remainder_of(&[("edge_across", 3.4, false), ("edge_along", 3.4, false)]);
        assert!(small.total < SECOND_LOOK_REMAINDER);
        assert!(second_look_effects(Effect::Compression, &candidates, &small, 3).is_empty());
        // A remainder spread over cells no one candidate moves: a bystander holding under half
        // of it is not tried.
        let spread = remainder_of(&[
            ("edge_across", 3.4, false),
            ("edge_along", 3.4, false),
            ("omega", 3.4, false),
            ("radius", 3.4, false),
            ("blockiness", 3.4, false),
            ("noise_paper", 3.4, false),
        ]);
        assert!(spread.total > SECOND_LOOK_REMAINDER);
        // Only the motion blur's cells (the edges and the motion's) hold half of it; the
        // optical blur's edges hold a third, the lighting's grey levels less.
        let tried = second_look_effects(Effect::Compression, &candidates, &spread, 3);
        assert_eq!(tried, vec![Effect::MotionBlur], "{tried:?}");
        assert!(screening_share(Effect::MotionBlur, &spread) >= SECOND_LOOK_SHARE);
        assert!(screening_share(Effect::OpticalBlur, &spread) < SECOND_LOOK_SHARE);
        assert!(screening_share(Effect::Lighting, &spread) < SECOND_LOOK_SHARE);
        let nan = GapMap {
            total: f64::NAN,
            ..left.clone()
        };
        assert!(second_look_effects(Effect::Compression, &candidates, &nan, 3).is_empty());
    }

    #[test]
    fn every_effect_has_a_signature_of_known_channels() {
        for e in Effect::ALL {
            assert!(!signature(e).is_empty());
            for c in signature(e) {
                assert!(
                    super::super::cells::channel(c).is_some(),
                    "{}: {c}",
                    e.name()
                );
            }
            for c in screening_only(e) {
                assert!(
                    super::super::cells::channel(c).is_some(),
                    "{}: {c}",
                    e.name()
                );
                assert!(!signature(e).contains(c), "{}: {c} twice", e.name());
            }
        }
    }

    #[test]
    fn noise_guess_inverts_the_noise_model() {
        let (fw, rn, span) = (20000.0, 185.0, 155.0);
        // Measured behind the clip at black and white: the white paper keeps a third of its
        // noise variance, and shows less noise than the ink (1.02 DN against 1.47 DN).
        let sigma = |s: f64| {
            let sensor = (s / fw + rn * rn / (fw * fw)).sqrt();
            (span * span * clipped_variance(s, sensor) + 1.0 / 12.0).sqrt()
        };
        assert!(sigma(1.0) < sigma(0.04));
        let (g_fw, g_rn) = guess_noise(sigma(0.04), sigma(1.0), 0.04, 1.0, span).unwrap();
        assert!((g_fw / fw - 1.0).abs() < 1e-6 && (g_rn / rn - 1.0).abs() < 1e-6);
        assert!(guess_noise(2.0, 1.0, 0.04, 1.0, span).is_none());
        // Far from the clip nothing is undone.
        let v = sensor_variance(1.5, 0.5, span).unwrap();
        assert!((v * span * span - (1.5f64.powi(2) - 1.0 / 12.0)).abs() < 1e-9);
    }

    #[test]
    fn a_normal_clamped_at_its_mean_keeps_a_third_of_its_variance() {
        // Var(min(Z, 0)) = 1/2 − 1/(2π).
        let expected = 0.5 - 0.5 / std::f64::consts::PI;
        assert!((clipped_variance(1.0, 0.01) / 1e-4 - expected).abs() < 1e-6);
        assert!((clipped_variance(0.0, 0.01) / 1e-4 - expected).abs() < 1e-6);
        assert_eq!(clipped_variance(0.5, 0.0), 0.0);
        assert_eq!(unclipped_variance(0.5, f64::NAN), None);
        // More than a two-point 0/1 distribution can hold is out of reach.
        assert_eq!(unclipped_variance(0.5, 0.3), None);
    }

    proptest::proptest! {
        #[test]
        fn the_clip_is_undone_at_any_level_and_noise(mu in 0.0f64..=1.0, sigma in 1e-4f64..0.5) {
            let clipped = clipped_variance(mu, sigma);
            proptest::prop_assert!(clipped <= sigma * sigma * (1.0 + 1e-9));
            // Far from the clip (|μ − clip| > 3σ) hardly anything is lost.
            if mu > 3.0 * sigma && 1.0 - mu > 3.0 * sigma {
                proptest::prop_assert!(clipped > 0.97 * sigma * sigma);
            }
            let back = unclipped_variance(mu, clipped).unwrap();
            proptest::prop_assert!((back.sqrt() / sigma - 1.0).abs() < 1e-6, "{} for {}", back.sqrt(), sigma);
        }
    }

    #[test]
    fn level_and_blur_guesses_invert_their_models() {
        let (b, w) = guess_levels(51.0 + 0.04 * 155.0, 206.0, 0.04, 1.0).unwrap();
        assert!((b - 51.0).abs() < 1e-9 && (w - 206.0).abs() < 1e-9);
        let g = guess_optical_sigma(
            (1.2f64.powi(2) + 0.3f64.powi(2)).sqrt(),
            (0.5f64.powi(2) + 0.3f64.powi(2)).sqrt(),
            0.5,
        );
        assert!((g - 1.2).abs() < 1e-9);
        // v = 100 px/s, T = 10 ms adds (1 px)²/12.
        assert!((guess_exposure_s(1.0 / 12.0, 100.0, 0.0) - 0.01).abs() < 1e-12);
    }
}

/// Frequency (Hz) of the strongest sinusoid in `x` sampled at `t_s` (NaN skipped), searched
/// from `f_min_hz` to `f_max_hz` in steps of `df_hz` with the Lomb–Scargle periodogram (exact
/// for uneven sampling); with its power normalised by the series' variance. `None` for fewer
/// than 8 samples.
pub fn dominant_frequency_hz(
    t_s: &[f64],
    x: &[f64],
    f_min_hz: f64,
    f_max_hz: f64,
    df_hz: f64,
) -> Option<(f64, f64)> {
    let pts: Vec<(f64, f64)> = t_s
        .iter()
        .zip(x)
        .filter(|(t, v)| t.is_finite() && v.is_finite())
        .map(|(t, v)| (*t, *v))
        .collect();
    if pts.len() < 8 || !(df_hz > 0.0 && f_max_hz > f_min_hz) {
        return None;
    }
    let mean = pts.iter().map(|p| p.1).sum::<f64>() / pts.len() as f64;
    let var = pts.iter().map(|p| (p.1 - mean).powi(2)).sum::<f64>() / pts.len() as f64;
    if var <= 0.0 {
        return None;
    }
    let mut best = (f_min_hz, -1.0);
    let steps = ((f_max_hz - f_min_hz) / df_hz).floor() as usize;
    for i in 0..=steps {
        let f = f_min_hz + i as f64 * df_hz;
        let w = std::f64::consts::TAU * f;
        let (s2, c2) = pts.iter().fold((0.0, 0.0), |(s, c), p| {
            (s + (2.0 * w * p.0).sin(), c + (2.0 * w * p.0).cos())
        });
        let tau = s2.atan2(c2) / (2.0 * w);
        let (mut yc, mut ys, mut cc, mut ss) = (0.0, 0.0, 0.0, 0.0);
        for p in &pts {
            let a = w * (p.0 - tau);
            let (s, c) = a.sin_cos();
            let y = p.1 - mean;
            yc += y * c;
            ys += y * s;
            cc += c * c;
            ss += s * s;
        }
        let power = 0.5 * (yc * yc / cc.max(1e-300) + ys * ys / ss.max(1e-300)) / var;
        if power > best.1 {
            best = (f, power);
        }
    }
    Some(best)
}

#[cfg(test)]
mod periodogram_tests {
    use super::*;

    #[test]
    fn finds_an_aliased_vibration() {
        // 25 Hz sampled at 29.87 fps appears at |25 − 29.87| = 4.87 Hz.
        let t: Vec<f64> = (0..300).map(|k| k as f64 / 29.87).collect();
        let x: Vec<f64> = t
            .iter()
            .map(|&s| 1e-3 * (std::f64::consts::TAU * 25.0 * s + 0.4).sin())
            .collect();
        let (f, p) = dominant_frequency_hz(&t, &x, 0.2, 14.9, 0.01).unwrap();
        assert!((f - 4.87).abs() < 0.02, "{f}");
        assert!(p > 50.0, "{p}");
    }
}
