//! Sensor noise: shot noise (Poisson, approximated as Gaussian with variance = signal electrons)
//! plus Gaussian read noise, drawn from a counter-based generator keyed by
//! (seed, frame index, x, y) so every pixel's noise is a pure function of its position.
//!
//! A phone's tone curve and denoising make the noise in DN depend on the grey level in ways that
//! shot and read noise through the scenario's tone curve do not draw (more noise in the dark
//! tones, less near the white): `level_gain` scales the noise's σ by a factor interpolated in the
//! pixel's clean grey level, a noise level function relative to the electron model (Liu,
//! Szeliski, Kang, Zitnick & Freeman 2008, "Automatic estimation and removal of noise from a
//! single image", IEEE PAMI 30(2)).

use crate::numeric::dist::normal_quantile;
use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PixelNoiseConfig {
    /// Add shot and read noise. Default: true.
    pub enabled: bool,
    /// Electrons collected at radiance 1 (maps to the white level), in [1, 10⁷]. Default: 20000.
    /// With `read_noise_e` this gives σ ≈ 1.4 DN on the ink and 1.8 DN on the paper at the
    /// default levels; the real 4K frame shows 1.44 DN on the marker ink and only 0.17 DN on the
    /// paper, which the phone's denoising/JPEG flattened (see `render::real_frame`).
    pub full_well_e: f64,
    /// Read noise standard deviation in electrons, in [0, 10⁴]. Default: 185 (reproduces the
    /// 1.44 DN measured on the real frame's marker ink, where shot noise vanishes).
    pub read_noise_e: f64,
    /// The noise's σ by grey level, as a factor on shot + read noise: linear in the pixel's
    /// clean level (before noise, after the tone curve) between the entries, constant beyond
    /// the first and the last. Default: none (factor 1). `geneva calibrate` writes it when the
    /// footage's noise at the levels it holds still departs from the electron model.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub level_gain: Vec<NoiseGainAt>,
}

/// One entry of [`PixelNoiseConfig::level_gain`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseGainAt {
    /// Clean grey level, DN, in [0, 255]; entries strictly increasing.
    pub level_dn: f64,
    /// The factor on the noise's σ at that level, in [0, 10].
    pub gain: f64,
}

impl Default for PixelNoiseConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            full_well_e: 20000.0,
            read_noise_e: 185.0,
            level_gain: Vec::new(),
        }
    }
}

impl PixelNoiseConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(join(path, "full_well_e"), self.full_well_e, 1.0, 1e7);
        problems.range(join(path, "read_noise_e"), self.read_noise_e, 0.0, 1e4);
        let mut last = f64::NEG_INFINITY;
        for (i, e) in self.level_gain.iter().enumerate() {
            let field = format!("{}[{i}]", join(path, "level_gain"));
            problems.range(join(&field, "level_dn"), e.level_dn, 0.0, 255.0);
            problems.range(join(&field, "gain"), e.gain, 0.0, 10.0);
            problems.increasing(join(&field, "level_dn"), e.level_dn, last, ("level", " DN"));
            last = e.level_dn;
        }
    }

    /// The factor on the noise's σ at clean grey level `level_dn` (1 without a table).
    pub fn gain_at(&self, level_dn: f64) -> f64 {
        gain_at(&self.level_gain, level_dn)
    }

    /// Noisy normalised signal (1 = full well) for normalised signal `s` and standard normal `z`.
    #[inline]
    pub fn apply(&self, s: f32, z: f32) -> f32 {
        let fw = self.full_well_e as f32;
        let e = s.max(0.0) * fw;
        let sigma = (e + (self.read_noise_e * self.read_noise_e) as f32).sqrt();
        (e + sigma * z) / fw
    }
}

/// The factor of `table` at `level_dn` (1 when empty): linear between entries, constant
/// beyond the ends.
pub fn gain_at(table: &[NoiseGainAt], level_dn: f64) -> f64 {
    let (Some(first), Some(last)) = (table.first(), table.last()) else {
        return 1.0;
    };
    if level_dn <= first.level_dn {
        return first.gain;
    }
    if level_dn >= last.level_dn {
        return last.gain;
    }
    let i = table.partition_point(|e| e.level_dn <= level_dn);
    let (a, b) = (table[i - 1], table[i]);
    let f = (level_dn - a.level_dn) / (b.level_dn - a.level_dn);
    a.gain + f * (b.gain - a.gain)
}

/// [`gain_at`] in single precision for the renderer's loops (the table's entries as f32).
#[derive(Debug, Clone, PartialEq)]
pub struct LevelGain {
    levels_dn: Vec<f32>,
    gains: Vec<f32>,
}

impl LevelGain {
    /// `None` for an empty table: the noise then takes no factor at all (the same bits as
    /// before tables existed).
    pub fn new(table: &[NoiseGainAt]) -> Option<Self> {
        (!table.is_empty()).then(|| Self {
            levels_dn: table.iter().map(|e| e.level_dn as f32).collect(),
            gains: table.iter().map(|e| e.gain as f32).collect(),
        })
    }

    #[inline]
    pub fn at(&self, level_dn: f32) -> f32 {
        let n = self.levels_dn.len();
        if level_dn <= self.levels_dn[0] {
            return self.gains[0];
        }
        if level_dn >= self.levels_dn[n - 1] {
            return self.gains[n - 1];
        }
        let i = self.levels_dn.partition_point(|&l| l <= level_dn);
        let (l0, l1) = (self.levels_dn[i - 1], self.levels_dn[i]);
        let f = (level_dn - l0) / (l1 - l0);
        self.gains[i - 1] + f * (self.gains[i] - self.gains[i - 1])
    }
}

/// [`PixelNoiseConfig::apply`] with its per-config constants hoisted (same operations, same
/// bits): for a run of pixels in a row.
#[derive(Debug, Clone, Copy)]
pub struct NoiseModel {
    full_well: f32,
    read_var: f32,
}

impl NoiseModel {
    pub fn new(c: &PixelNoiseConfig) -> Self {
        Self {
            full_well: c.full_well_e as f32,
            read_var: (c.read_noise_e * c.read_noise_e) as f32,
        }
    }

    /// Mean electrons and σ for normalised signal `s`.
    #[inline(always)]
    pub fn electrons(&self, s: f32) -> (f32, f32) {
        let e = s.max(0.0) * self.full_well;
        (e, (e + self.read_var).sqrt())
    }

    /// Noisy normalised signal from [`Self::electrons`] and a standard normal `z`.
    #[inline(always)]
    pub fn noisy(&self, e: f32, sigma: f32, z: f32) -> f32 {
        (e + sigma * z) / self.full_well
    }
}

/// SplitMix64 finaliser.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Per-frame key: the pixel hash only has to mix in (x, y).
#[inline]
pub fn frame_key(seed: u64, frame_index: u64) -> u64 {
    mix(mix(seed ^ 0x5049_5845_4C4E_4F49) ^ frame_index.wrapping_mul(0xD1B5_4A32_D192_ED03))
}

/// Table resolution of the inverse normal CDF (bits of the uniform used as index).
const TABLE_BITS: u32 = 12;
const TABLE_LEN: usize = 1 << TABLE_BITS;

/// Φ⁻¹ at u = i / 2¹² for i = 1 ..= 2¹² − 1 (ends unused: the two outer cells are computed
/// exactly). A constant table, built once; linear interpolation inside a cell is accurate to
/// < 2·10⁻⁴ σ except near the tails, which take the exact path.
fn table() -> &'static [f32; TABLE_LEN + 1] {
    static TABLE: std::sync::OnceLock<Box<[f32; TABLE_LEN + 1]>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = Box::new([0.0f32; TABLE_LEN + 1]);
        for (i, v) in t.iter_mut().enumerate().take(TABLE_LEN).skip(1) {
            *v = normal_quantile(i as f64 / TABLE_LEN as f64) as f32;
        }
        t
    })
}

/// Hash multipliers of the pixel position.
const X_MUL: u64 = 0x9E37_79B9_7F4A_7C15;
const Y_MUL: u64 = 0xC2B2_AE3D_27D4_EB4F;

/// A standard normal deviate for pixel (x, y) under `key`: inverse CDF of a 53-bit uniform from
/// a SplitMix64 hash of the position, by table interpolation (exact Acklam formula in the outer
/// 1/2048 of the distribution).
#[inline]
pub fn normal_at(key: u64, x: i64, y: i64) -> f32 {
    let h = mix(key ^ (x as u64).wrapping_mul(X_MUL) ^ (y as u64).wrapping_mul(Y_MUL));
    normal_from_hash(h, table())
}

/// [`normal_at`] for the pixels `x0 .. x0 + out.len()` of row `y` (same values; the row and
/// table look-ups are hoisted and x·X_MUL is stepped by addition, which is exact mod 2⁶⁴).
pub fn normals_row(key: u64, x0: i64, y: i64, out: &mut [f32]) {
    let t = table();
    let key_y = key ^ (y as u64).wrapping_mul(Y_MUL);
    let mut x_term = (x0 as u64).wrapping_mul(X_MUL);
    for o in out {
        *o = normal_from_hash(mix(key_y ^ x_term), t);
        x_term = x_term.wrapping_add(X_MUL);
    }
}

#[inline(always)]
fn normal_from_hash(h: u64, t: &[f32; TABLE_LEN + 1]) -> f32 {
    let idx = (h >> (64 - TABLE_BITS)) as usize;
    if idx == 0 || idx == TABLE_LEN - 1 {
        return tail_normal(h);
    }
    let frac = ((h >> (64 - TABLE_BITS - 24)) & 0xFF_FFFF) as f32 * (1.0 / (1u32 << 24) as f32);
    t[idx] + (t[idx + 1] - t[idx]) * frac
}

/// The exact path for the two outer table cells (1 pixel in 2048), kept out of line.
#[cold]
#[inline(never)]
fn tail_normal(h: u64) -> f32 {
    let u = ((h >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64);
    normal_quantile(u) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_normals_have_unit_moments_and_no_neighbour_correlation() {
        let key = frame_key(42, 7);
        let n = 200_000;
        let z: Vec<f64> = (0..n)
            .map(|i| normal_at(key, i % 500, i / 500) as f64)
            .collect();
        let mean = z.iter().sum::<f64>() / n as f64;
        let var = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
        let kurt = z.iter().map(|v| (v - mean).powi(4)).sum::<f64>() / n as f64 / (var * var);
        let corr = z.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var - 1.0).abs() < 0.01, "{var}");
        assert!((kurt - 3.0).abs() < 0.05, "{kurt}");
        assert!(corr.abs() < 0.01, "{corr}");
        assert_ne!(normal_at(key, 3, 4), normal_at(frame_key(42, 8), 3, 4));
        let mut row = vec![0.0f32; 100_000]; // ~50 pixels take the exact tail path
        normals_row(key, -17, 9, &mut row);
        for (i, z) in row.iter().enumerate() {
            assert_eq!(z.to_bits(), normal_at(key, i as i64 - 17, 9).to_bits());
        }
        let c = PixelNoiseConfig::default();
        let m = NoiseModel::new(&c);
        for (s, z) in [(0.3f32, 0.7f32), (-0.1, -2.0), (1.2, 3.1)] {
            let (e, sigma) = m.electrons(s);
            assert_eq!(m.noisy(e, sigma, z).to_bits(), c.apply(s, z).to_bits());
        }
        assert_eq!(normal_at(key, 3, 4), normal_at(frame_key(42, 7), 3, 4));
    }

    #[test]
    fn level_gain_interpolates_between_entries_and_holds_beyond_them() {
        let t = [
            NoiseGainAt {
                level_dn: 40.0,
                gain: 1.5,
            },
            NoiseGainAt {
                level_dn: 100.0,
                gain: 1.0,
            },
            NoiseGainAt {
                level_dn: 220.0,
                gain: 0.4,
            },
        ];
        let f = LevelGain::new(&t).unwrap();
        for (level, want) in [
            (0.0, 1.5),
            (40.0, 1.5),
            (70.0, 1.25),
            (160.0, 0.7),
            (250.0, 0.4),
        ] {
            assert!((gain_at(&t, level) - want).abs() < 1e-12, "{level}");
            assert!((f.at(level as f32) as f64 - want).abs() < 1e-6, "{level}");
        }
        assert_eq!(gain_at(&[], 80.0), 1.0);
        assert!(LevelGain::new(&[]).is_none());
        let mut c = PixelNoiseConfig {
            level_gain: t.to_vec(),
            ..Default::default()
        };
        let mut p = Problems::default();
        c.validate("effects.pixel_noise", &mut p);
        assert!(p.is_empty());
        c.level_gain.swap(0, 1);
        c.validate("effects.pixel_noise", &mut p);
        assert!(format!("{p:?}").contains("effects.pixel_noise.level_gain[1].level_dn"));
    }
}
