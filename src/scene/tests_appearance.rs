//! Scenes with an appearance: uniform textures draw what the uniform radiances draw, a window is
//! the same bits as the full frame with every effect and every texture on, and the independent
//! renderer draws the same picture its own way.

use super::tests_render::ALL_EFFECTS_TOML;
use crate::pipeline::rig::Rig;
use crate::render::effects::EffectsConfig;
use crate::render::frame::render_linear;
use crate::render::texture::{value_of, BackgroundTexture, Texture};
use crate::render::{render_frame, FrameRequest, PixelRect};
use crate::scenario::Scenario;
use rand::Rng;
use std::path::Path;
use std::sync::Arc;

fn scenario() -> Scenario {
    crate::scenario::from_str(ALL_EFFECTS_TOML, Path::new("all-effects.toml")).unwrap()
}

/// A texture of `w`×`h` texels: `base` plus seeded noise of ± `spread` (16-bit units).
fn texture(w: usize, h: usize, base: u16, spread: i32, seed: u64) -> Arc<Texture> {
    let mut rng = crate::rng::stream(seed, crate::rng::Stream::MonteCarlo, 7);
    let values = (0..w * h)
        .map(|_| {
            let d = if spread > 0 {
                rng.gen_range(-spread..=spread)
            } else {
                0
            };
            (base as i32 + d).clamp(0, 65535) as u16
        })
        .collect();
    Arc::new(Texture {
        width: w,
        height: h,
        values,
    })
}

/// Disc texture of 1 mm texels (about a pixel of the rig) covering the disc, centred on the
/// wheel; marker texture at 4 texels per cell; background the camera's size.
fn with_textures(mut s: Scenario, disc: bool, marker: bool, background: bool) -> Scenario {
    let a = &mut s.scene.appearance;
    let spread = 9000;
    if disc {
        let n = (2.0 * s.scene.disc_radius_mm).ceil() as usize + 4;
        a.disc_file = Some("disc.png".into());
        a.disc_mm_per_texel = 1.0;
        a.loaded.disc = Some(texture(n, n, value_of(s.scene.disc_radiance), spread, 1));
    }
    if marker {
        let tpc = 4;
        let t = crate::scene::MarkerTexels::new(
            s.scene.marker.dictionary.marker_size_bits() + 2 * s.scene.marker.border_bits,
            s.scene.marker.size_mm,
            s.scene.marker.white_margin_mm,
            tpc,
        );
        let side = t.side.round() as usize;
        a.marker_file = Some("marker.png".into());
        a.marker_texels_per_cell = tpc;
        a.loaded.marker = Some(texture(side, side, 30000, 30000, 2));
    }
    if background {
        let (w, h) = (s.camera.width_px as usize, s.camera.height_px as usize);
        a.background_file = Some("background.png".into());
        let t = texture(w, h, value_of(s.scene.background_radiance), spread, 3);
        a.loaded.background = Some(Arc::new(BackgroundTexture((*t).clone())));
    }
    s
}

#[test]
fn a_uniform_disc_texture_draws_what_the_uniform_disc_draws() {
    let mut plain = scenario();
    plain.effects = EffectsConfig::none();
    let textured = with_textures(plain.clone(), true, false, false);
    let a = &textured.scene.appearance;
    let flat = a.loaded.disc.as_ref().unwrap();
    let flat = Arc::new(Texture {
        values: vec![value_of(plain.scene.disc_radiance); flat.values.len()],
        ..(**flat).clone()
    });
    let mut textured = textured.clone();
    textured.scene.appearance.loaded.disc = Some(flat);
    for (index, t_s) in [(1u64, 0.05), (27, 0.9)] {
        let render = |s: &Scenario| {
            let rig = Rig::new(s).unwrap();
            let rect = rig.frame_rect();
            let req = FrameRequest {
                index,
                t_s,
                window: rect,
            };
            let scene = rig.animated();
            render_linear(&scene, &rig.settings, &req, &rect).data
        };
        let (p, t) = (render(&plain), render(&textured));
        let worst = p
            .iter()
            .zip(&t)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        // The textured outline's vertices turn with the wheel, the uniform disc's stay put:
        // two polygons within `TOLERANCE_PX` of the circle, apart by at most twice that over a
        // pixel's ≤ 1.5 px of rim, times the disc's contrast; and the textured radiances are
        // 16-bit (≤ 7.6e-6 off).
        let contrast = (plain.scene.disc_radiance - plain.scene.background_radiance).abs();
        let bound = 2.0 * crate::scene::TOLERANCE_PX * 1.5 * contrast + 1e-5;
        assert!((worst as f64) < bound, "t {t_s}: worst {worst} > {bound}");
    }
}

#[test]
fn a_window_is_the_full_frame_bit_for_bit_with_every_texture_and_effect_on() {
    for (disc, marker) in [(true, false), (false, true), (false, false)] {
        let mut s = with_textures(scenario(), disc, marker, true);
        s.scene.appearance.marker_levels = glossy_levels();
        let rig = Rig::new(&s).unwrap();
        let scene = rig.animated();
        let full_rect = rig.frame_rect();
        let mut rng = crate::rng::stream(9, crate::rng::Stream::MonteCarlo, 0);
        for (index, t_s) in [(1u64, 0.05), (27, 0.9)] {
            let req = |window| FrameRequest { index, t_s, window };
            let full = render_frame(&scene, &rig.settings, &req(full_rect));
            let c = scene.marker_centre_px(t_s);
            for k in 0..4 {
                // Half the windows about the marker, half anywhere.
                let (cx, cy) = if k % 2 == 0 {
                    (c.x as i64, c.y as i64)
                } else {
                    (rng.gen_range(0..480), rng.gen_range(0..300))
                };
                let window = PixelRect::new(
                    cx - rng.gen_range(5..60),
                    cy - rng.gen_range(5..60),
                    rng.gen_range(1..120),
                    rng.gen_range(1..100),
                );
                let roi = render_frame(&scene, &rig.settings, &req(window));
                assert_eq!(
                    roi,
                    full.crop(&window),
                    "disc {disc} marker {marker} t {t_s} window {window:?}"
                );
            }
        }
    }
}

/// A marker whose level changes with the wheel's angle: brighter ink at 0°, darker at 180°.
fn glossy_levels() -> Vec<crate::scene::MarkerLevelAt> {
    [(0.0, 0.8, 0.15), (90.0, 1.0, 0.0), (180.0, 1.1, -0.05)]
        .map(|(angle_deg, gain, offset)| crate::scene::MarkerLevelAt {
            angle_deg,
            gain,
            offset,
        })
        .to_vec()
}

/// Renders the whole frame `index` at `t_s`.
fn whole_frame(s: &Scenario, index: u64, t_s: f64) -> crate::render::GrayImage {
    let rig = Rig::new(s).unwrap();
    let req = FrameRequest {
        index,
        t_s,
        window: rig.frame_rect(),
    };
    let scene = rig.animated();
    render_frame(&scene, &rig.settings, &req)
}

#[test]
fn the_marker_drawn_at_a_level_is_the_marker_of_those_levels_bit_for_bit() {
    // In a dwell the wheel stands still over the exposure and the readout (20 ms), so the
    // level is one map over the frame.
    // The reference marker stands beside the wheel: no level is applied to it, so the
    // comparison with stated levels leaves it out.
    let mut base = scenario();
    base.scene.paper_radiance = 1.0;
    base.scene.reference_marker.enabled = false;
    base.detector.reference_marker_id = None;
    let rig = Rig::new(&base).unwrap();
    let scene = rig.animated();
    let theta = |t: f64| scene.pose(t).theta2_rad;
    let t_s = (1..400)
        .map(|k| k as f64 * 0.01)
        .find(|&t| theta(t - 0.03) == theta(t + 0.03))
        .expect("a dwell");
    let levels = crate::scene::marker_levels::level_at;
    let level = levels(&glossy_levels(), theta(t_s)).unwrap();
    assert!(
        level.gain != 1.0,
        "a dwell where the table changes the marker"
    );
    for (disc, marker) in [(false, false), (true, false), (false, true)] {
        let plain = with_textures(base.clone(), disc, marker, false);
        let mut glossy = plain.clone();
        glossy.scene.appearance.marker_levels = glossy_levels();
        let mut mapped = plain.clone();
        let sc = &mut mapped.scene;
        sc.paper_radiance = level.radiance(sc.paper_radiance);
        sc.ink_radiance = level.radiance(sc.ink_radiance);
        if let Some(t) = &sc.appearance.loaded.marker {
            let values = t.values.iter().map(|&v| level.value(v)).collect();
            sc.appearance.loaded.marker = Some(Arc::new(Texture {
                values,
                ..(**t).clone()
            }));
        }
        let (g, m, p) = (
            whole_frame(&glossy, 3, t_s),
            whole_frame(&mapped, 3, t_s),
            whole_frame(&plain, 3, t_s),
        );
        let differ = |a: &crate::render::GrayImage, b: &crate::render::GrayImage| {
            a.data.iter().zip(&b.data).filter(|(x, y)| x != y).count()
        };
        assert_eq!(
            differ(&g, &m),
            0,
            "disc texture {disc}, marker texture {marker}"
        );
        assert!(
            differ(&g, &p) > 100,
            "the level changes the picture (disc {disc}, marker {marker})"
        );
        // The independent renderer samples textures bilinearly and maps the sample: the same
        // picture as sampling the mapped texture, to the 16-bit rounding of the mapped values.
        let independent = |s: &Scenario| {
            let rig = Rig::new(s).unwrap();
            let scene = rig.animated();
            crate::render::independent::render_frame_independent(&scene, &rig.settings, 3, t_s)
                .unwrap()
        };
        let (gi, mi) = (independent(&glossy), independent(&mapped));
        let worst = gi
            .data
            .iter()
            .zip(&mi.data)
            .map(|(a, b)| a.abs_diff(*b))
            .max();
        assert!(worst <= Some(1), "independent renderer: {worst:?} DN apart");
        assert!(
            differ(&gi, &independent(&plain)) > 100,
            "independent renderer draws the level"
        );
    }
}
