//! Linear radiance → 8-bit grey for runs of one row: illumination gain, shot and read noise,
//! tone curve and quantisation, per pixel at its absolute position.
//!
//! Every pixel goes through exactly the operations of the reference per-pixel formula
//! `quantise(tone.dn(noise.apply(v · gain(x, y, g_t(y)), normal_at(key, x, y))))`, where g_t(y)
//! is the light's gain over time at row y's exposure (1 under steady light) and the noise's σ
//! takes the factor of `pixel_noise.level_gain` at the clean level `tone.dn(s)`; the loops only
//! hoist what is constant along a run (gain under even light, the electron count of a flat
//! run) and work in small chunks so the arithmetic vectorises.

use crate::render::effects::lighting::{quantise, LightingConfig, Tone};
use crate::render::effects::pixel_noise::{self, LevelGain, NoiseModel};
use crate::render::effects::EffectsConfig;

/// What a tone-mapped pixel is written as: 8-bit grey (quantised), or the DN before
/// quantisation (for the sharpening that follows the tone curve).
pub(super) trait ToneOut: Copy + Send {
    fn from_dn(dn: f32) -> Self;
}

impl ToneOut for u8 {
    #[inline(always)]
    fn from_dn(dn: f32) -> u8 {
        quantise(dn)
    }
}

impl ToneOut for f32 {
    #[inline(always)]
    fn from_dn(dn: f32) -> f32 {
        dn
    }
}

/// Pixels per chunk: the normals and signals of a chunk stay in L1.
const CHUNK: usize = 256;

/// Everything the conversion of one frame needs.
pub(super) struct ToneMap<'a> {
    lighting: &'a LightingConfig,
    uneven: bool,
    tone: Tone,
    noise: Option<NoiseModel>,
    /// The noise's factor by clean grey level (`None`: 1 everywhere, no operation).
    level_gain: Option<LevelGain>,
    key: u64,
    width_px: usize,
    height_px: usize,
    /// The frame's clock when the light changes over time.
    clock: Option<RowClock<'a>>,
}

/// When each row is exposed: the light's gain over time is taken at the row's exposure.
struct RowClock<'a> {
    fx: &'a EffectsConfig,
    /// Centre of row 0's exposure, s.
    t_s: f64,
    exposure_s: f64,
}

impl<'a> ToneMap<'a> {
    /// The conversion of frame `frame_index`, whose row 0 is exposed around `t_s`.
    pub(super) fn new(
        fx: &'a EffectsConfig,
        seed: u64,
        (frame_index, t_s): (u64, f64),
        width_px: usize,
        height_px: usize,
    ) -> Self {
        Self {
            clock: fx.lighting.varies_in_time().then(|| RowClock {
                fx,
                t_s,
                exposure_s: fx.motion_blur.exposure_or_zero_s(),
            }),
            lighting: &fx.lighting,
            uneven: fx.lighting.uneven(),
            tone: fx.lighting.tone(),
            noise: fx
                .pixel_noise
                .enabled
                .then(|| NoiseModel::new(&fx.pixel_noise)),
            level_gain: LevelGain::new(&fx.pixel_noise.level_gain),
            key: pixel_noise::frame_key(seed, frame_index),
            width_px,
            height_px,
        }
    }

    /// The light's gain over time at row `y` (1 under steady light).
    fn row_gain(&self, y: i64) -> f64 {
        self.clock.as_ref().map_or(1.0, |c| {
            let t = c.t_s + c.fx.rolling_shutter.row_delay_s(y, self.height_px);
            c.fx.lighting.temporal_gain(t, c.exposure_s)
        })
    }

    /// Pixels `x0 .. x0 + out.len()` of row `y`, all of linear radiance `v`.
    pub(super) fn constant_run<O: ToneOut>(&self, v: f32, x0: i64, y: i64, out: &mut [O]) {
        if self.uneven {
            for chunk_start in (0..out.len()).step_by(CHUNK) {
                let n = CHUNK.min(out.len() - chunk_start);
                let values = [v; CHUNK];
                let x = x0 + chunk_start as i64;
                self.run(&values[..n], x, y, &mut out[chunk_start..chunk_start + n]);
            }
            return;
        }
        let s = v * self.row_gain(y) as f32; // as the general path: the same bits
        let Some(noise) = self.noise else {
            out.fill(O::from_dn(self.tone.dn(s)));
            return;
        };
        let (e, sigma) = self.electrons(&noise, s);
        let mut z = [0.0f32; CHUNK];
        for (i, o) in out.chunks_mut(CHUNK).enumerate() {
            let z = &mut z[..o.len()];
            pixel_noise::normals_row(self.key, x0 + (i * CHUNK) as i64, y, z);
            self.tone_chunk(z, o, |z| noise.noisy(e, sigma, z));
        }
    }

    /// Pixels `x0 .. x0 + values.len()` of row `y` with linear radiances `values`.
    pub(super) fn run<O: ToneOut>(&self, values: &[f32], x0: i64, y: i64, out: &mut [O]) {
        let mut s = [0.0f32; CHUNK];
        let mut z = [0.0f32; CHUNK];
        let g_t = self.row_gain(y);
        for (i, (v, o)) in values.chunks(CHUNK).zip(out.chunks_mut(CHUNK)).enumerate() {
            let xc = x0 + (i * CHUNK) as i64;
            let s = &mut s[..v.len()];
            if self.uneven {
                for (j, (s, &v)) in s.iter_mut().zip(v).enumerate() {
                    let g = self.lighting.gain_with(
                        xc + j as i64,
                        y,
                        self.width_px,
                        self.height_px,
                        g_t,
                    );
                    *s = v * g;
                }
            } else {
                let g = g_t as f32;
                for (s, &v) in s.iter_mut().zip(v) {
                    *s = v * g;
                }
            }
            let Some(noise) = self.noise else {
                self.tone_chunk(s, o, |s| s);
                continue;
            };
            let z = &mut z[..v.len()];
            pixel_noise::normals_row(self.key, xc, y, z);
            for (s, &z) in s.iter_mut().zip(z.iter()) {
                let (e, sigma) = self.electrons(&noise, *s);
                *s = noise.noisy(e, sigma, z);
            }
            self.tone_chunk(s, o, |s| s);
        }
    }

    /// Mean electrons and σ of clean signal `s`, σ scaled by the level table at `s`'s clean
    /// grey level.
    #[inline(always)]
    fn electrons(&self, noise: &NoiseModel, s: f32) -> (f32, f32) {
        let (e, sigma) = noise.electrons(s);
        match &self.level_gain {
            None => (e, sigma),
            Some(g) => (e, sigma * g.at(self.tone.dn(s))),
        }
    }

    /// Tone curve (and quantisation, for 8-bit output) of `signal(input[i])` into `out[i]`.
    #[inline(always)]
    fn tone_chunk<O: ToneOut>(&self, input: &[f32], out: &mut [O], signal: impl Fn(f32) -> f32) {
        let t = self.tone;
        if t.inv_gamma == 1.0 {
            for (o, &v) in out.iter_mut().zip(input) {
                let s = signal(v).clamp(0.0, 1.0);
                *o = O::from_dn(t.black_dn + t.span_dn * s);
            }
        } else {
            for (o, &v) in out.iter_mut().zip(input) {
                *o = O::from_dn(t.dn(signal(v)));
            }
        }
    }
}
