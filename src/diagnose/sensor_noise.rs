//! The pixel noise's parameter space, as its fit searches it: the sensor's noise variance at a
//! grey level, the valley of fixed total noise that footage dominated by read noise fixes, the
//! read noise's search step and the cap that keeps a search where the marker can still be found.
//! Pure functions of the sensor's parameters; the fit itself is [`super::fit`]'s.
//!
//! Variances here are the sensor's, in full-well units² at a normalised radiance s (0 black,
//! 1 full scale): s/FW (shot) + RN²/FW² (read), FW the full well and RN the read noise in e⁻.

use crate::scene::SceneConfig;

/// The normalised radiance halfway between the scene's ink and paper: the grey level where the
/// pixel-noise fit measures and caps the sensor's noise.
pub fn mid_grey(scene: &SceneConfig) -> f64 {
    0.5 * (scene.ink_radiance + scene.paper_radiance)
}

/// The sensor's noise variance at normalised radiance `s` (full-well units²) for a full well of
/// `fw_e` and a read noise of `rn_e`.
pub fn sensor_variance(s: f64, fw_e: f64, rn_e: f64) -> f64 {
    s / fw_e + (rn_e / fw_e).powi(2)
}

/// Largest standard deviation of a full well fitted by moment matching on the noise at the ink
/// and paper levels, relative to the full well, for that fit to stand; beyond it the Σ z² search
/// fits the noise.
///
/// The two variances are a·s + b at the two radiances (a = 1/FW, b = RN²/FW²), and sd(FW)/FW =
/// sd(a)/a: at 1 the shot-noise part a is not told from zero at one standard deviation. Where
/// read noise dominates both levels, a is the small difference of two large variances, and the
/// noise channels' renderer tolerance (15 % in σ, taken into the standard deviation) leaves it
/// undetermined: on the strong probe (2000 e⁻, 185 e⁻) drawn by the independent renderer, one
/// seed of three was matched at 496 e⁻ and 42.6 e⁻ with a sampling-only uncertainty of ±24 e⁻
/// (the other two, whose levels the model's shape rejects, were searched: 2031 and 2006 e⁻).
/// Near the limit (124 000 e⁻, shot noise dominating) the ratio is 0.50 on the same renderer.
pub const NOISE_SPLIT_MAX_REL_SD: f64 = 1.0;

/// Whether a moment-matched full well `fw_e` with standard deviation `sd_fw_e` stands
/// ([`NOISE_SPLIT_MAX_REL_SD`]).
pub fn noise_split_determined(fw_e: f64, sd_fw_e: f64) -> bool {
    fw_e > 0.0 && sd_fw_e.is_finite() && sd_fw_e <= NOISE_SPLIT_MAX_REL_SD * fw_e
}

/// The read noise (e⁻) that keeps the sensor's noise variance at normalised radiance
/// `s_ref` at `var_ref` (in full-well units², s/FW + RN²/FW²) for a full well of `fw_e`: the
/// valley of the noise fit, the one combination of the two that footage dominated by read noise
/// fixes. `None` where shot noise alone exceeds `var_ref` (a full well below s_ref/var_ref).
pub fn read_noise_on_valley(fw_e: f64, s_ref: f64, var_ref: f64) -> Option<f64> {
    let rn2 = var_ref * fw_e * fw_e - s_ref * fw_e;
    (fw_e > 0.0 && rn2.is_finite() && rn2 >= 0.0).then(|| rn2.sqrt())
}

/// The full well (e⁻) on [`read_noise_on_valley`]'s valley where the read noise reaches
/// `rn_e`: the root of var_ref·FW² − s_ref·FW − rn² = 0.
pub fn full_well_on_valley(rn_e: f64, s_ref: f64, var_ref: f64) -> f64 {
    (s_ref + (s_ref * s_ref + 4.0 * var_ref * rn_e * rn_e).sqrt()) / (2.0 * var_ref)
}

/// The first step (e⁻) of the coordinate search of the read noise at full well `fw_e` from
/// `rn_e`, with `s_ref` the normalised mid-grey: half the read noise, and never less than the
/// read noise whose variance equals the shot noise's there, √(s_ref·FW). The read noise acts
/// through RN²/FW², so a step that is a fixed share of its range means nothing: the search's
/// default (a sixth of 0–5000 e⁻, 750 e⁻) took a 2000 e⁻ / 185 e⁻ sensor to 935 e⁻, noise of
/// 120 DN at which the marker is found in 36 of 240 frames and every frame but those is
/// searched whole (36 s a simulation at 1280×960 against 3.2 s at 185 e⁻). A step up by this
/// one multiplies the noise variance at mid-grey by 2 to (1 + √5)²/4 ≈ 2.62 (σ by 1.4–1.6),
/// as a 0.3-decade step of the full well halves its shot part; the bracket still doubles the
/// step where the footage's noise lies further away.
pub fn read_noise_step_e(fw_e: f64, rn_e: f64, s_ref: f64) -> f64 {
    (0.5 * rn_e.max(0.0)).max((s_ref.max(0.0) * fw_e.max(0.0)).sqrt())
}

/// How far above the footage's noise (in σ) a pixel-noise search may take the sensor.
///
/// Why: the Σ z² search brackets its minimum by doubling its steps, and from a quiet start it
/// reached full wells whose noise hides the marker: a full well of 300 e⁻ beside 185 e⁻ of
/// read noise (σ about 160 DN at mid-grey) finds it in 11 of 240 frames, and every frame it is
/// not found in is searched whole, 43 s a simulation at 1280×960 against 3.2 s at the
/// footage's own 2000 e⁻. No such sensor filmed a footage whose noise is a small fraction of
/// it, and Σ z² there is far above its minimum (the noise channels are in the signature), so
/// the bound never holds a fit back from the noise the footage shows.
pub const NOISE_SEARCH_MAX_RATIO: f64 = 2.5;

/// The largest sensor noise variance (full-well units², s/FW + RN²/FW² at mid-grey) a
/// pixel-noise search may reach: the nominal sensor's `nominal_variance`, scaled by the
/// footage's noise variance over the nominal simulations' (`real_over_sim_variance`, the
/// 8-bit quantisation taken out of both: measured noise is the sensor's behind a tone curve
/// and blur that are the same in both) and by [`NOISE_SEARCH_MAX_RATIO`]². `None` where
/// either is not a positive finite number.
pub fn noise_variance_cap(nominal_variance: f64, real_over_sim_variance: f64) -> Option<f64> {
    let cap = nominal_variance * real_over_sim_variance * NOISE_SEARCH_MAX_RATIO.powi(2);
    (nominal_variance > 0.0 && real_over_sim_variance > 0.0 && cap.is_finite()).then_some(cap)
}

/// Noise variance (DN²) the 8-bit quantisation adds to any measured σ.
const QUANTISATION_VARIANCE_DN2: f64 = 1.0 / 12.0;

/// The footage's noise variance over the nominal simulations' at one grey level, quantisation
/// taken out of both; `None` where the simulations show no noise beyond it (a nominal without
/// sensor noise: nothing to scale).
pub fn noise_variance_ratio(real_sigma_dn: f64, sim_sigma_dn: f64) -> Option<f64> {
    let sim = sim_sigma_dn * sim_sigma_dn - QUANTISATION_VARIANCE_DN2;
    let real = (real_sigma_dn * real_sigma_dn - QUANTISATION_VARIANCE_DN2).max(0.0);
    (sim > QUANTISATION_VARIANCE_DN2 && real_sigma_dn.is_finite()).then(|| real / sim)
}

/// Bounds of a pixel-noise search ([`noise_variance_cap`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseCap {
    /// Normalised mid-grey between ink and paper, where the variance is capped.
    pub s_ref: f64,
    /// Largest sensor noise variance there, full-well units².
    pub variance: f64,
}

impl NoiseCap {
    /// The search range of parameter `index` (0: full well, 1: read noise) with the other at
    /// `values`, inside `range`: a full well no lower, a read noise no higher, than the cap
    /// allows.
    pub fn bound(&self, index: usize, values: &[f64], range: (f64, f64)) -> (f64, f64) {
        match index {
            0 => {
                let fw_min = full_well_on_valley(values[1], self.s_ref, self.variance);
                (range.0.max(fw_min).min(range.1), range.1)
            }
            _ => match read_noise_on_valley(values[0], self.s_ref, self.variance) {
                Some(rn_max) => (range.0, range.1.min(rn_max).max(range.0)),
                None => range,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Every point of the valley has the total noise it was drawn through, and the full well
        /// of a point's read noise is that point's.
        #[test]
        fn the_noise_valley_keeps_the_total_noise(
            fw0 in 50.0f64..1e6,
            rn0 in 0.0f64..5000.0,
            s_ref in 0.01f64..1.0,
            fw_rel in 0.05f64..20.0,
        ) {
            let var_ref = s_ref / fw0 + (rn0 / fw0).powi(2);
            let fw = fw0 * fw_rel;
            match read_noise_on_valley(fw, s_ref, var_ref) {
                Some(rn) => {
                    let var = s_ref / fw + (rn / fw).powi(2);
                    prop_assert!((var / var_ref - 1.0).abs() < 1e-9, "{var} vs {var_ref}");
                    let back = full_well_on_valley(rn, s_ref, var_ref);
                    prop_assert!((back / fw - 1.0).abs() < 1e-6, "{back} vs {fw}");
                }
                // Only below the full well where shot noise alone makes the total.
                None => prop_assert!(fw < s_ref / var_ref * (1.0 + 1e-9)),
            }
            let rn_back = read_noise_on_valley(fw0, s_ref, var_ref).unwrap_or(0.0);
            prop_assert!((rn_back - rn0).abs() <= 1e-6 * fw0.max(rn0));
        }
    }

    proptest! {
        /// A step up of the read noise multiplies the noise variance at mid-grey by 2 to
        /// 2.62: with r = RN²/(s·FW) the read part's share, the ratio is (1 + 2.25 r)/(1 + r)
        /// for r ≥ 4 and (1 + (√r + 1)²)/(1 + r) below, whose largest value (at √r = 0.618) is
        /// (1 + √5)²/4.
        #[test]
        fn a_read_noise_step_moves_the_noise_by_a_bounded_factor(
            fw in 50.0f64..1e6,
            rn in 0.0f64..5000.0,
            s_ref in 0.01f64..1.0,
        ) {
            let var = |rn: f64| s_ref / fw + (rn / fw).powi(2);
            let ratio = var(rn + read_noise_step_e(fw, rn, s_ref)) / var(rn);
            let golden_sq = (1.0 + 5f64.sqrt()).powi(2) / 4.0;
            prop_assert!(ratio >= 2.0 - 1e-9 && ratio <= golden_sq + 1e-9, "{ratio}");
        }
    }

    proptest! {
        /// Inside the bounds, the sensor's noise at mid-grey stays within the cap wherever the
        /// other parameter holds its value; at the bound it reaches the cap (unless a range end
        /// comes first).
        #[test]
        fn a_capped_noise_search_stays_within_the_cap(
            fw in 50.0f64..1e6,
            rn in 0.0f64..5000.0,
            s_ref in 0.01f64..1.0,
            cap_rel in 1.0f64..100.0,
        ) {
            let var = |fw: f64, rn: f64| s_ref / fw + (rn / fw).powi(2);
            let cap = NoiseCap { s_ref, variance: cap_rel * var(fw, rn) };
            let range_fw = (50.0, 1e6);
            let (lo, hi) = cap.bound(0, &[fw, rn], range_fw);
            prop_assert!(range_fw.0 <= lo && lo <= hi && hi == range_fw.1);
            prop_assert!(var(lo, rn) <= cap.variance * (1.0 + 1e-9) || lo == range_fw.1);
            if lo > range_fw.0 && lo < range_fw.1 {
                prop_assert!((var(lo, rn) / cap.variance - 1.0).abs() < 1e-9);
            }
            let range_rn = (0.0, 5000.0);
            let (lo, hi) = cap.bound(1, &[fw, rn], range_rn);
            prop_assert!(lo == range_rn.0 && lo <= hi && hi <= range_rn.1);
            prop_assert!(var(fw, hi) <= cap.variance * (1.0 + 1e-9));
            if hi < range_rn.1 {
                prop_assert!((var(fw, hi) / cap.variance - 1.0).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn the_noise_cap_scales_the_nominal_by_the_footages_noise_without_quantisation() {
        // Footage σ 10 DN against simulations' 5 DN: four times the variance, less quantisation.
        let q = 1.0 / 12.0;
        let ratio = noise_variance_ratio(10.0, 5.0).unwrap();
        assert!((ratio - (100.0 - q) / (25.0 - q)).abs() < 1e-12);
        let cap = noise_variance_cap(1e-3, ratio).unwrap();
        assert!((cap - 1e-3 * ratio * NOISE_SEARCH_MAX_RATIO.powi(2)).abs() < 1e-15);
        // Simulations with no noise beyond quantisation have nothing to scale.
        assert_eq!(noise_variance_ratio(10.0, 0.3), None);
        assert_eq!(noise_variance_ratio(f64::NAN, 5.0), None);
        assert_eq!(noise_variance_cap(0.0, 4.0), None);
        assert_eq!(noise_variance_cap(1e-3, f64::INFINITY), None);
    }

    #[test]
    fn a_noise_split_the_two_levels_cannot_determine_goes_to_the_search() {
        assert!(noise_split_determined(124_000.0, 61_700.0));
        assert!(!noise_split_determined(496.0, 2_000.0));
        assert!(!noise_split_determined(496.0, f64::INFINITY));
        assert!(!noise_split_determined(496.0, f64::NAN));
        assert!(!noise_split_determined(0.0, 0.0));
    }
}
