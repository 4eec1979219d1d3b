//! Fused rendering of one band of output rows to linear values: exposure samples rasterised
//! and averaged, then the separable optical blur, all in band-sized buffers that stay in cache.
//!
//! Only the columns some layer can reach are computed. Every sample's layers lie inside their
//! bounding boxes, so outside the hull of those boxes (over the band's rows plus the blur
//! margin) every sample is the background, the exposure average is the average of the
//! backgrounds and the blur of that constant is [`constant_response`] applied twice — the same
//! bits the full computation gives there. A band is therefore described by one constant plus the
//! values of an "active" column range.

use super::RowAnchor;
use crate::render::effects::optical_blur::{constant_response, convolve_column, convolve_row};
use crate::render::raster::{
    average_exposure, ExposurePlan, ExposureScratch, PixelRect, PreparedSnapshot,
};

/// Output rows per band: with a blur margin of r rows, (rows + 2r) / rows of the rasterising
/// is repeated, and the band's buffers should stay in L2.
pub(super) const BAND_ROWS: usize = 32;

/// The exposure samples of every row.
pub(super) enum Samples<'a> {
    /// Global shutter: the K prepared snapshots shared by every row, and how they are averaged
    /// (decided once for all bands).
    Global(Vec<PreparedSnapshot>, ExposurePlan),
    /// Rolling shutter: the K prepared snapshots of absolute row y, given the anchor of the
    /// row above it in the band (shapes it may share), and the anchor of row y.
    Rolling(RowSampler<'a>),
}

/// The exposure samples of one rolling-shutter row (see [`Samples::Rolling`]).
pub(super) type RowSampler<'a> =
    Box<dyn Fn(i64, Option<&RowAnchor>) -> (Vec<PreparedSnapshot>, Option<RowAnchor>) + Sync + 'a>;

/// What every band of a frame shares.
pub(super) struct BandPipeline<'a> {
    pub samples: Samples<'a>,
    /// Normalised blur taps (2r + 1 of them); empty without optical blur.
    pub weights: Vec<f32>,
}

/// Buffers of one band, reused from frame to frame.
#[derive(Debug, Default)]
pub struct BandScratch {
    exposure: ExposureScratch,
    radiance: Vec<f32>,
    horizontal: Vec<f32>,
    blurred: Vec<f32>,
    row_samples: Vec<Vec<PreparedSnapshot>>,
}

/// Linear values of a band: `constant` outside columns `x0 .. x0 + width`, `values` (row-major,
/// `width` per row) inside.
pub(super) struct BandValues<'s> {
    pub constant: f32,
    pub x0: i64,
    pub width: usize,
    pub values: &'s [f32],
}

impl BandValues<'_> {
    pub(super) fn row(&self, r: usize) -> &[f32] {
        &self.values[r * self.width..][..self.width]
    }
}

impl BandPipeline<'_> {
    fn radius(&self) -> usize {
        self.weights.len() / 2
    }

    /// Linear values of the pixels of `band` (a block of whole rows of the output rectangle).
    pub(super) fn render<'s>(
        &self,
        band: &PixelRect,
        scratch: &'s mut BandScratch,
    ) -> BandValues<'s> {
        let r = self.radius();
        let ri = r as i64;
        let rows = (band.y0 - ri, band.y1() + ri);
        let n_rows = band.height + 2 * r;
        if let Samples::Rolling(prepare) = &self.samples {
            scratch.row_samples.clear();
            let mut above: Option<RowAnchor> = None;
            for y in rows.0..rows.1 {
                let (samples, anchor) = prepare(y, above.as_ref());
                scratch.row_samples.push(samples);
                above = anchor;
            }
        }
        let snaps_of_row = |i: usize| -> &[PreparedSnapshot] {
            match &self.samples {
                Samples::Global(s, _) => s,
                Samples::Rolling(_) => &scratch.row_samples[i],
            }
        };
        // The uncovered value of each radiance row; rows that disagree (a background changing
        // during a rolling readout) make the whole band active.
        let background = exposure_average(snaps_of_row(0).iter().map(|s| s.background_radiance()));
        // A background texture gives every pixel its own value: the whole band is active.
        let textured = (0..n_rows).any(|i| {
            snaps_of_row(i)
                .iter()
                .any(PreparedSnapshot::has_background_texture)
        });
        let uniform = !textured
            && (1..n_rows).all(|i| {
                exposure_average(snaps_of_row(i).iter().map(|s| s.background_radiance())).to_bits()
                    == background.to_bits()
            });
        let hull = if !uniform {
            Some((band.x0 - ri, band.x1() + ri))
        } else {
            let mut hull: Option<(i64, i64)> = None;
            let mut add = |s: &PreparedSnapshot, y0: i64, y1: i64| {
                if let Some((a, b)) = s.active_columns(y0, y1) {
                    hull = Some(hull.map_or((a, b), |(ha, hb)| (ha.min(a), hb.max(b))));
                }
            };
            match &self.samples {
                Samples::Global(s, _) => s.iter().for_each(|s| add(s, rows.0, rows.1)),
                Samples::Rolling(_) => {
                    for (i, snaps) in scratch.row_samples.iter().enumerate() {
                        let y = rows.0 + i as i64;
                        snaps.iter().for_each(|s| add(s, y, y + 1));
                    }
                }
            }
            hull
        };
        let constant = if r == 0 {
            background
        } else {
            let h = constant_response(&self.weights, background);
            constant_response(&self.weights, h)
        };
        // Output columns whose blur neighbourhood reaches the hull.
        let (oa, ob) = match hull {
            Some((a, b)) => ((a - ri).max(band.x0), (b + ri).min(band.x1())),
            None => (band.x0, band.x0),
        };
        if ob <= oa {
            return BandValues {
                constant,
                x0: band.x0,
                width: 0,
                values: &[],
            };
        }
        let width = (ob - oa) as usize;
        let window = PixelRect::new(oa - ri, rows.0, width + 2 * r, n_rows);
        // Stale contents are fine below: every stage overwrites all of its buffer.
        scratch.radiance.resize(window.len(), 0.0);
        match &self.samples {
            Samples::Global(snaps, plan) => average_exposure(
                &window,
                snaps,
                plan,
                &mut scratch.exposure,
                &mut scratch.radiance,
            ),
            Samples::Rolling(_) => {
                for (i, out) in scratch.radiance.chunks_exact_mut(window.width).enumerate() {
                    let snaps = &scratch.row_samples[i];
                    average_exposure(
                        &window.rows(rows.0 + i as i64, 1),
                        snaps,
                        &ExposurePlan::per_sample(snaps),
                        &mut scratch.exposure,
                        out,
                    );
                }
            }
        }
        if r == 0 {
            return BandValues {
                constant,
                x0: oa,
                width,
                values: &scratch.radiance,
            };
        }
        scratch.horizontal.resize(width * n_rows, 0.0);
        for (h, src) in scratch
            .horizontal
            .chunks_exact_mut(width)
            .zip(scratch.radiance.chunks_exact(window.width))
        {
            convolve_row(src, &self.weights, h);
        }
        scratch.blurred.resize(width * band.height, 0.0);
        for (y, out) in scratch.blurred.chunks_exact_mut(width).enumerate() {
            convolve_column(&scratch.horizontal, width, y, &self.weights, out);
        }
        BandValues {
            constant,
            x0: oa,
            width,
            values: &scratch.blurred,
        }
    }
}

/// The exposure average of K sample values, summed in sample order then scaled by 1/K
/// (exactly what [`average_exposure`] computes per pixel).
fn exposure_average(values: impl Iterator<Item = f32>) -> f32 {
    let mut k = 0usize;
    let mut sum = 0.0f32;
    for v in values {
        sum = if k == 0 { v } else { sum + v };
        k += 1;
    }
    if k > 1 {
        sum * (1.0 / k as f32)
    } else {
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::super::{band_pipeline, FrameRequest, RenderSettings};
    use super::*;
    use crate::render::effects::EffectsConfig;
    use crate::render::shapes::{Layer, SceneAt, SceneSnapshot};
    use crate::render::test_scenes::{rotated_square, SpinningMarker};
    use glam::DVec2;

    /// A static tilted plate (many rows, never moving) behind a spinning marker.
    struct PlateAndMarker(SpinningMarker);

    impl SceneAt for PlateAndMarker {
        fn snapshot(&self, t_s: f64) -> SceneSnapshot {
            let mut s = self.0.snapshot(t_s);
            s.layers.insert(
                0,
                Layer {
                    texture: None,
                    radiance: 0.3,
                    polygons: vec![rotated_square(DVec2::new(60.2, 47.9), 150.0, 0.3)],
                },
            );
            s
        }
    }

    #[test]
    fn rolling_rows_share_unchanged_shapes_and_render_the_bits_of_rows_prepared_alone() {
        let scene = PlateAndMarker(SpinningMarker {
            centre_px: DVec2::new(61.3, 40.6),
            side_px: 50.0,
            rate_rad_s: 3.0,
        });
        // Rolling shutter with and without motion-blur samples, with and without optical blur;
        // a camera vibration moves every row differently, so nothing can be shared there.
        for (k, vibrating) in [(0usize, false), (6, false), (6, true)] {
            let mut fx = EffectsConfig::none();
            fx.rolling_shutter.enabled = true;
            fx.rolling_shutter.readout_s = 0.02;
            fx.motion_blur.enabled = k > 0;
            fx.motion_blur.exposure_s = 0.006;
            fx.motion_blur.samples = k as u32;
            fx.optical_blur.enabled = k > 0;
            fx.optical_blur.sigma_px = 0.9;
            fx.camera_vibration.enabled = vibrating;
            fx.camera_vibration.random.x_rms_px = 0.4;
            let settings = RenderSettings {
                width_px: 120,
                height_px: 90,
                effects: fx,
                seed: 3,
            };
            let frame = FrameRequest {
                index: 2,
                t_s: 0.13,
                window: settings.frame_rect(),
            };
            let shared = band_pipeline(&scene, &settings, &frame);
            let Samples::Rolling(sampler) = &shared.samples else {
                panic!("a rolling shutter samples per row");
            };
            let alone = BandPipeline {
                samples: Samples::Rolling(Box::new(|y, _| sampler(y, None))),
                weights: shared.weights.clone(),
            };
            let rect = settings.frame_rect();
            for b in 0..rect.height.div_ceil(BAND_ROWS) {
                let band = rect.rows(rect.y0 + (b * BAND_ROWS) as i64, BAND_ROWS);
                let (mut sa, mut sb) = (BandScratch::default(), BandScratch::default());
                let (va, vb) = (shared.render(&band, &mut sa), alone.render(&band, &mut sb));
                let bits = |v: &BandValues| {
                    let values: Vec<u32> = v.values.iter().map(|x| x.to_bits()).collect();
                    (v.constant.to_bits(), v.x0, v.width, values)
                };
                assert_eq!(
                    bits(&va),
                    bits(&vb),
                    "k {k}, vibrating {vibrating}, band {b}"
                );
                let rows = &sa.row_samples;
                assert!(rows.len() > 1 && rows.iter().all(|r| r.len() == k.max(1)));
                for pair in rows.windows(2) {
                    // The plate (layer 0) is converted once per band unless the camera moves
                    // it; the marker (layer 1) moves with every row.
                    assert_eq!(pair[1][0].shares_shape(&pair[0][0], 0), !vibrating);
                    assert!(!pair[1][0].shares_shape(&pair[0][0], 1));
                }
                let alone_rows = &sb.row_samples;
                assert!(!alone_rows[1][0].shares_shape(&alone_rows[0][0], 0));
            }
        }
    }
}
