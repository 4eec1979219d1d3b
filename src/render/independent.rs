//! A second renderer of the same rig, independent of [`super::frame`] in every step where two
//! honest renderers differ with no effect at work. It answers "would the diagnosis raise an
//! alarm on footage that is not this project's own?" (the diagnosis self-check's cross-renderer
//! cases, and `geneva render --renderer independent` for anyone who wants to look).
//!
//! What differs from [`super::frame`] (which renders exact area coverage in linear radiance):
//! - **anti-aliasing**: tiny-skia's (4× vertical supersampling, 8-bit coverage), whose straight
//!   edges land a few hundredths of a pixel off the geometry (`tiny_skia_ref` measures it);
//! - **compositing in display space**: layers are painted as 8-bit grey after the tone curve, as
//!   a 2D drawing library paints, not mixed in linear radiance;
//! - **optical blur**: the Gaussian PSF integrated over each pixel (Φ differences) rather than
//!   sampled at whole pixels, truncated at 4σ, applied in display space with clamped borders;
//! - **motion blur**: the average of [`MOTION_SAMPLES`] whole drawings across the exposure, in
//!   display space (sixteen, whatever the speed: fast motion shows steps);
//! - **rolling shutter**: bands of [`RS_BAND_ROWS`] rows, each drawn at its middle row's time;
//! - **noise**: shot and read noise in linear signal after the blur, from its own random stream
//!   (Box–Muller), so no pixel shares a draw with the other renderer;
//! - **uneven lighting**: its gain applied to the drawn grey about the black level;
//! - **sharpening**: its unsharp mask blurs with the pixel-integrated Gaussian, clamped borders.
//!
//! Shared with [`super::frame`], because they are the rig and not the renderer: the scene's
//! geometry at each instant (mechanism, camera, lens, tilt, runout), the camera-vibration
//! transform, the tone curve's parameters, the noise parameters and the JPEG codec.
//!
//! Architecture invariant: the output depends only on the scene, the settings, the frame index
//! and its time (never on threads or on other frames).

use super::effects::camera_vibration::Vibration;
use super::effects::compression;
use super::effects::lighting::{quantise, Tone};
use super::frame::RenderSettings;
use super::image::GrayImage;
use super::raster::PixelRect;
use super::shapes::{SceneAt, SceneSnapshot};
use super::tiny_skia_ref::opencv_to_tiny_skia;
use crate::numeric::dist::normal_cdf;
use rand::Rng;
use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Transform};

/// Drawings averaged over an exposure (motion blur).
pub const MOTION_SAMPLES: usize = 16;
/// Rows drawn at one instant under a rolling shutter.
pub const RS_BAND_ROWS: usize = 8;
/// The blur kernel's reach, in σ.
const TRUNCATION_SIGMAS: f64 = 4.0;

/// Why a frame could not be drawn.
#[derive(Debug, Clone, thiserror::Error, PartialEq, Eq)]
pub enum IndependentRenderError {
    #[error("frame size {width_px}×{height_px} px cannot be drawn (tiny-skia refused the canvas)")]
    Canvas { width_px: usize, height_px: usize },
}

/// The whole frame `index` at `t_s` (centre of row 0's exposure), drawn by this renderer.
pub fn render_frame_independent(
    scene: &dyn SceneAt,
    settings: &RenderSettings,
    index: u64,
    t_s: f64,
) -> Result<GrayImage, IndependentRenderError> {
    let (w, h) = (settings.width_px, settings.height_px);
    let fx = &settings.effects;
    let tone = fx.lighting.tone();
    let vibration = Vibration::new(&fx.camera_vibration, settings.seed, w, h);
    let exposure_s = fx.motion_blur.exposure_or_zero_s();
    let offsets_s: Vec<f64> = if exposure_s > 0.0 {
        (0..MOTION_SAMPLES)
            .map(|i| exposure_s * ((i as f64 + 0.5) / MOTION_SAMPLES as f64 - 0.5))
            .collect()
    } else {
        vec![0.0]
    };
    let band_rows = if fx.rolling_shutter.enabled {
        RS_BAND_ROWS
    } else {
        h.max(1)
    };
    let canvas_error = IndependentRenderError::Canvas {
        width_px: w,
        height_px: h,
    };
    let mut display = vec![0.0f32; w * h];
    let mut y0 = 0usize;
    while y0 < h {
        let rows = band_rows.min(h - y0);
        let middle = (y0 + rows / 2) as i64;
        let t_band = t_s + fx.rolling_shutter.row_delay_s(middle, h);
        let mut pixmap = Pixmap::new(w as u32, rows as u32).ok_or(canvas_error.clone())?;
        let out = &mut display[y0 * w..(y0 + rows) * w];
        for &o in &offsets_s {
            let t = t_band + o;
            let mut snapshot = scene.snapshot(t);
            if let Some(v) = vibration.as_ref() {
                let transform = v.at(t);
                for layer in &mut snapshot.layers {
                    for p in &mut layer.polygons {
                        for q in &mut p.vertices_px {
                            *q = transform.apply(*q);
                        }
                    }
                    if let Some(tex) = layer.texture.as_mut() {
                        tex.map.transform = Some(transform);
                    }
                }
            }
            draw(&snapshot, &tone, y0, &mut pixmap);
            for (o, px) in out.iter_mut().zip(pixmap.pixels()) {
                *o += px.red() as f32;
            }
        }
        let n = offsets_s.len() as f32;
        out.iter_mut().for_each(|v| *v /= n);
        y0 += rows;
    }
    if fx.optical_blur.enabled && fx.optical_blur.sigma_px > 0.0 {
        display = blur(&display, w, h, fx.optical_blur.sigma_px);
    }
    let mut rng = crate::rng::stream(settings.seed, crate::rng::Stream::IndependentRender, index);
    let noise = fx.pixel_noise.enabled.then_some(&fx.pixel_noise);
    let mut dn = Vec::with_capacity(w * h);
    for (i, &d) in display.iter().enumerate() {
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        let t_row = t_s + fx.rolling_shutter.row_delay_s(y, h);
        let g_t = fx.lighting.temporal_gain(t_row, exposure_s);
        let mut s = linear_signal(&tone, d) * fx.lighting.gain_with(x, y, w, h, g_t);
        if let Some(c) = noise {
            let e = s.max(0.0) as f64 * c.full_well_e;
            let sigma_e =
                (e + c.read_noise_e * c.read_noise_e).sqrt() * c.gain_at(tone.dn(s) as f64);
            s = ((e + sigma_e * standard_normal(&mut rng)) / c.full_well_e) as f32;
        }
        dn.push(tone.dn(s));
    }
    let mask = &fx.sharpening;
    let mut data: Vec<u8> = if mask.active() {
        let blurred = blur(&dn, w, h, mask.sigma_px);
        let a = mask.amount as f32;
        dn.iter()
            .zip(&blurred)
            .map(|(&v, &b)| quantise(v + a * (v - b)))
            .collect()
    } else {
        dn.iter().map(|&v| quantise(v)).collect()
    };
    if fx.compression.enabled {
        if let Ok(p) = compression::jpeg_round_trip(&data, w, h, fx.compression.quality) {
            data = p;
        }
    }
    Ok(GrayImage {
        window: PixelRect::new(0, 0, w, h),
        data,
    })
}

/// Paints `snapshot` over rows `y0 ..` into `pixmap` (background, then each layer over it).
fn draw(snapshot: &SceneSnapshot, tone: &Tone, y0: usize, pixmap: &mut Pixmap) {
    let grey = |radiance: f32| {
        let g = quantise(tone.dn(radiance));
        Color::from_rgba8(g, g, g, 255)
    };
    pixmap.fill(grey(snapshot.background_radiance));
    if let Some(bg) = &snapshot.background {
        let w = pixmap.width() as usize;
        for (i, px) in pixmap.pixels_mut().iter_mut().enumerate() {
            let g = quantise(tone.dn(bg.at((i % w) as i64, (y0 + i / w) as i64)));
            *px = tiny_skia::ColorU8::from_rgba(g, g, g, 255).premultiply();
        }
    }
    paint_layers(snapshot, tone, y0, pixmap);
}

/// Paints the layers of `snapshot` over rows `y0 ..` of `pixmap`, each over the ones before.
fn paint_layers(snapshot: &SceneSnapshot, tone: &Tone, y0: usize, pixmap: &mut Pixmap) {
    let grey = |radiance: f32| {
        let g = quantise(tone.dn(radiance));
        Color::from_rgba8(g, g, g, 255)
    };
    let shift = Transform::from_translate(0.0, -(y0 as f32));
    for layer in &snapshot.layers {
        if let Some(tex) = &layer.texture {
            draw_textured(layer, tex, tone, y0, pixmap);
            continue;
        }
        if let Some(path) = outline(layer) {
            let mut paint = Paint::default();
            paint.set_color(grey(layer.radiance));
            paint.anti_alias = true;
            pixmap.fill_path(&path, &paint, FillRule::Winding, shift, None);
        }
    }
}

/// A layer's polygons as one tiny-skia path in its coordinates (`None` when it has no area to
/// draw).
fn outline(layer: &crate::render::shapes::Layer) -> Option<tiny_skia::Path> {
    let mut pb = PathBuilder::new();
    for polygon in &layer.polygons {
        let mut points = polygon.vertices_px.iter().map(|&p| opencv_to_tiny_skia(p));
        if let Some(first) = points.next() {
            pb.move_to(first.x, first.y);
            for p in points {
                pb.line_to(p.x, p.y);
            }
            pb.close();
        }
    }
    pb.finish()
}

/// Paints a textured layer: its outline as tiny-skia's anti-aliased mask, the texture sampled
/// bilinearly at each pixel's centre (as a GPU samples a texture, not by area), mixed in
/// display space.
fn draw_textured(
    layer: &crate::render::shapes::Layer,
    tex: &crate::render::texture::TexturedFill,
    tone: &Tone,
    y0: usize,
    pixmap: &mut Pixmap,
) {
    let (w, h) = (pixmap.width(), pixmap.height());
    let Some(mut mask) = tiny_skia::Mask::new(w, h) else {
        return;
    };
    let Some(path) = outline(layer) else {
        return;
    };
    mask.fill_path(
        &path,
        FillRule::Winding,
        true,
        Transform::from_translate(0.0, -(y0 as f32)),
    );
    let w = w as usize;
    for (i, (px, &m)) in pixmap.pixels_mut().iter_mut().zip(mask.data()).enumerate() {
        if m == 0 {
            continue;
        }
        let centre = glam::DVec2::new((i % w) as f64, (y0 + i / w) as f64);
        let Some(value) = tex
            .map
            .to_plane(centre)
            .and_then(|p| tex.radiance_at(p, true))
        else {
            continue;
        };
        let g = tone.dn(value).clamp(0.0, 255.0);
        let a = m as f32 / 255.0;
        let mixed = quantise(px.red() as f32 * (1.0 - a) + g * a);
        *px = tiny_skia::ColorU8::from_rgba(mixed, mixed, mixed, 255).premultiply();
    }
    // A uniform paper is painted over it as a polygon (anti-aliased like any other).
    if let (Some(core), Some(r)) = (&tex.core_px, tex.paper_radiance()) {
        let core_px: Vec<glam::DVec2> = core
            .vertices_px
            .iter()
            .map(|&q| tex.map.transform.map_or(q, |t| t.apply(q)))
            .collect();
        let paper = SceneSnapshot {
            background_radiance: 0.0,
            background: None,
            layers: vec![crate::render::shapes::Layer {
                radiance: r,
                polygons: vec![crate::render::shapes::Polygon {
                    vertices_px: core_px,
                }],
                texture: None,
            }],
        };
        paint_layers(&paper, tone, y0, pixmap);
    }
}

/// The linear signal (0 = black level, 1 = white level) that displays as `dn`.
fn linear_signal(tone: &Tone, dn: f32) -> f32 {
    if tone.span_dn <= 0.0 {
        return 0.0;
    }
    let s = ((dn - tone.black_dn) / tone.span_dn).clamp(0.0, 1.0);
    if tone.inv_gamma == 1.0 {
        s
    } else {
        s.powf(1.0 / tone.inv_gamma)
    }
}

/// The Gaussian PSF of `sigma_px` integrated over each pixel: weight k is
/// Φ((k + ½)/σ) − Φ((k − ½)/σ), normalised over ±⌈4σ⌉.
pub fn pixel_integrated_kernel(sigma_px: f64) -> Vec<f32> {
    let r = (TRUNCATION_SIGMAS * sigma_px).ceil().max(1.0) as i64;
    let w: Vec<f64> = (-r..=r)
        .map(|k| normal_cdf((k as f64 + 0.5) / sigma_px) - normal_cdf((k as f64 - 0.5) / sigma_px))
        .collect();
    let sum: f64 = w.iter().sum();
    w.iter().map(|v| (v / sum) as f32).collect()
}

/// Separable blur with borders clamped to the edge pixel.
fn blur(img: &[f32], w: usize, h: usize, sigma_px: f64) -> Vec<f32> {
    let k = pixel_integrated_kernel(sigma_px);
    let r = (k.len() / 2) as i64;
    let mut tmp = vec![0.0f32; img.len()];
    for y in 0..h {
        let row = &img[y * w..(y + 1) * w];
        for x in 0..w {
            tmp[y * w + x] = k
                .iter()
                .enumerate()
                .map(|(j, kw)| kw * row[(x as i64 + j as i64 - r).clamp(0, w as i64 - 1) as usize])
                .sum();
        }
    }
    let mut out = vec![0.0f32; img.len()];
    for y in 0..h {
        for x in 0..w {
            out[y * w + x] = k
                .iter()
                .enumerate()
                .map(|(j, kw)| {
                    kw * tmp[(y as i64 + j as i64 - r).clamp(0, h as i64 - 1) as usize * w + x]
                })
                .sum();
        }
    }
    out
}

/// A standard normal draw (Box–Muller, one of the pair).
fn standard_normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.gen::<f64>().max(f64::MIN_POSITIVE);
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::effects::EffectsConfig;
    use crate::render::shapes::{Layer, Polygon};
    use glam::DVec2;

    struct Still(SceneSnapshot);
    impl SceneAt for Still {
        fn snapshot(&self, _t_s: f64) -> SceneSnapshot {
            self.0.clone()
        }
    }

    fn square(x0: f64, y0: f64, side: f64) -> Polygon {
        Polygon {
            vertices_px: vec![
                DVec2::new(x0, y0),
                DVec2::new(x0 + side, y0),
                DVec2::new(x0 + side, y0 + side),
                DVec2::new(x0, y0 + side),
            ],
        }
    }

    fn settings(effects: EffectsConfig) -> RenderSettings {
        RenderSettings {
            width_px: 48,
            height_px: 40,
            effects,
            seed: 3,
        }
    }

    fn plain() -> EffectsConfig {
        let mut fx = EffectsConfig::default();
        fx.pixel_noise.enabled = false;
        fx.optical_blur.enabled = false;
        fx.compression.enabled = false;
        fx.motion_blur.enabled = false;
        fx.rolling_shutter.enabled = false;
        fx.camera_vibration.enabled = false;
        fx
    }

    fn scene() -> Still {
        Still(SceneSnapshot {
            background: None,
            background_radiance: 1.0,
            layers: vec![Layer {
                texture: None,
                radiance: 0.0,
                polygons: vec![square(10.3, 8.6, 20.0)],
            }],
        })
    }

    #[test]
    fn kernel_is_normalised_and_blurs_more_than_the_sampled_one_at_small_sigma() {
        for sigma in [0.3, 0.5, 1.0, 2.5] {
            let k = pixel_integrated_kernel(sigma);
            let sum: f32 = k.iter().sum();
            assert!((sum - 1.0).abs() < 1e-5, "σ {sigma}: sum {sum}");
            let var = |k: &[f32]| -> f64 {
                let r = (k.len() / 2) as f64;
                k.iter()
                    .enumerate()
                    .map(|(i, w)| *w as f64 * (i as f64 - r).powi(2))
                    .sum()
            };
            let sampled =
                crate::render::effects::optical_blur::kernel(sigma, (3.0 * sigma).ceil() as usize);
            assert!(
                var(&k) > var(&sampled),
                "σ {sigma}: {} vs {}",
                var(&k),
                var(&sampled)
            );
            if sigma >= 1.0 {
                // Integrating over the pixel adds the box's 1/12 px² to σ².
                let want = sigma * sigma + 1.0 / 12.0;
                assert!(
                    (var(&k) - want).abs() < 0.03 * want,
                    "σ {sigma}: {} vs {want}",
                    var(&k)
                );
            }
        }
    }

    #[test]
    fn a_square_lands_where_its_geometry_is_with_the_stated_levels() {
        let s = settings(plain());
        let img = render_frame_independent(&scene(), &s, 0, 0.0).unwrap();
        let tone = s.effects.lighting.tone();
        let (ink, paper) = (quantise(tone.dn(0.0)), quantise(tone.dn(1.0)));
        let at = |x: usize, y: usize| img.data[y * 48 + x];
        assert_eq!(at(20, 18), ink);
        assert_eq!(at(2, 2), paper);
        // The ink's area in pixels (coverage-weighted) is the square's, within the 8-bit
        // anti-aliasing's rounding along its perimeter.
        let area: f64 = img
            .data
            .iter()
            .map(|&v| (paper as f64 - v as f64) / (paper as f64 - ink as f64))
            .sum();
        assert!((area - 400.0).abs() < 1.5, "area {area}");
    }

    #[test]
    fn a_sharpened_square_matches_the_other_renderer_within_their_differences() {
        let mut fx = plain();
        fx.optical_blur.enabled = true;
        fx.optical_blur.sigma_px = 1.0;
        fx.lighting.black_level_dn = 40.0;
        fx.lighting.white_level_dn = 215.0;
        let plain_fx = fx.clone();
        fx.sharpening.enabled = true;
        fx.sharpening.amount = 0.8;
        fx.sharpening.sigma_px = 1.5;
        let s = settings(fx);
        let scene = Still(SceneSnapshot {
            background: None,
            background_radiance: 0.8,
            layers: vec![Layer {
                texture: None,
                radiance: 0.1,
                polygons: vec![square(10.3, 8.6, 20.0)],
            }],
        });
        let ind = render_frame_independent(&scene, &s, 0, 0.0).unwrap();
        let main_renderer = |s: &RenderSettings| {
            crate::render::frame::render_frame(
                &scene,
                s,
                &crate::render::frame::FrameRequest {
                    index: 0,
                    t_s: 0.0,
                    window: s.frame_rect(),
                },
            )
        };
        let main = main_renderer(&s);
        let plain_settings = settings(plain_fx);
        let unsharpened = render_frame_independent(&scene, &plain_settings, 0, 0.0).unwrap();
        let main_unsharpened = main_renderer(&plain_settings);
        // Away from the frame's borders (clamped here, rendered beyond the frame there). The
        // mask's 2-D taps (1 + a)·δ − a·G have an L1 norm of 1 + 2a − 2a·G₀ < 1 + 2a, so the
        // renderers' difference without the mask (anti-aliasing, blur kernels) grows by at most
        // that factor, plus a DN of rounding on each side.
        let worst = |a: &GrayImage, b: &GrayImage| {
            let mut worst = 0i32;
            for y in 6..34 {
                for x in 6..42 {
                    let i = y * 48 + x;
                    worst = worst.max((a.data[i] as i32 - b.data[i] as i32).abs());
                }
            }
            worst
        };
        let (sharp, plain) = (worst(&ind, &main), worst(&unsharpened, &main_unsharpened));
        let bound = (1.0 + 2.0 * s.effects.sharpening.amount) * plain as f64 + 2.0;
        assert!(
            sharp as f64 <= bound,
            "renderers differ by {sharp} DN sharpened, {plain} DN without (bound {bound})"
        );
        // The halo both draw is many times that.
        let halo = worst(&ind, &unsharpened);
        assert!(
            halo >= 20,
            "the sharpening changes pixels by up to {halo} DN only"
        );
    }

    #[test]
    fn same_frame_same_pixels_and_noise_differs_between_frames() {
        let mut fx = plain();
        fx.pixel_noise.enabled = true;
        let s = settings(fx);
        let a = render_frame_independent(&scene(), &s, 5, 0.1).unwrap();
        let b = render_frame_independent(&scene(), &s, 5, 0.1).unwrap();
        let c = render_frame_independent(&scene(), &s, 6, 0.1).unwrap();
        assert_eq!(a, b);
        assert_ne!(a.data, c.data);
    }

    #[test]
    fn noise_has_the_configured_sigma_in_a_mid_grey() {
        let mut fx = plain();
        fx.pixel_noise.enabled = true;
        let s = settings(fx.clone());
        let flat = Still(SceneSnapshot {
            background: None,
            background_radiance: 0.5,
            layers: vec![],
        });
        let tone = fx.lighting.tone();
        let c = &fx.pixel_noise;
        let sigma_e = (0.5 * c.full_well_e + c.read_noise_e * c.read_noise_e).sqrt();
        let want_dn = tone.span_dn as f64 * sigma_e / c.full_well_e;
        let (mut sum2, mut n) = (0.0, 0.0);
        for frame in 0..20 {
            let img = render_frame_independent(&flat, &s, frame, 0.0).unwrap();
            let mean = img.data.iter().map(|&v| v as f64).sum::<f64>() / img.data.len() as f64;
            sum2 += img
                .data
                .iter()
                .map(|&v| (v as f64 - mean).powi(2))
                .sum::<f64>();
            n += img.data.len() as f64 - 1.0;
        }
        // Whole-DN rounding adds 1/12 DN² to the variance.
        let got = (sum2 / n - 1.0 / 12.0).sqrt();
        // 38 400 draws: the sample σ is within 1 % (3 standard errors) of the truth.
        assert!(
            (got - want_dn).abs() < 0.02 * want_dn,
            "σ {got} DN vs {want_dn} DN"
        );
    }
}
