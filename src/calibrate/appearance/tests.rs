use super::*;
use crate::pipeline::rig::Rig;
use crate::render::effects::EffectsConfig;
use crate::render::texture::radiance_of;
use crate::render::{render_frame, FrameRequest, PixelRect};
use crate::scenario::Scenario;
use std::path::Path;
use std::sync::Arc;

const ANCHORS: LevelAnchors = LevelAnchors::BYTE_SCALE;

/// The `fast` rig (a 64 px marker) with only an optical blur of `sigma_px`.
fn rig_scenario(sigma_px: f64) -> Scenario {
    let mut s = crate::scenario::from_str("extend = \"fast\"\n", Path::new("t.toml")).unwrap();
    s.effects = EffectsConfig::none();
    s.effects.optical_blur.enabled = true;
    s.effects.optical_blur.sigma_px = sigma_px;
    s
}

fn layout_of(s: &Scenario) -> MarkerLayout {
    crate::diagnose::image::marker_layout(s).unwrap()
}

/// A marker texture of `tpc` texels per cell whose ink and paper vary slowly (a shading across
/// the paper and a blotch), as a printed marker under a lamp does.
fn printed_texture(s: &Scenario, tpc: u32) -> Texture {
    let layout = layout_of(s);
    let cells = layout.side_cells();
    let m = (layout.margin_cells().unwrap() * tpc as f64).round() as usize;
    let side = cells * tpc as usize + 2 * m;
    let values = (0..side * side)
        .map(|k| {
            let (i, j) = ((k % side) as f64, (k / side) as f64);
            let g = |v: f64| (v + 0.5 - m as f64) / tpc as f64;
            let (gx, gy) = (g(i), g(j));
            let shade = 0.06 * (gx / cells as f64) - 0.04 * (gy / cells as f64);
            let blotch = 0.08 * (-((gx - 2.0).powi(2) + (gy - 4.0).powi(2)) / 4.5).exp();
            let base = match layout.material(gx, gy) {
                Material::Ink => 0.15,
                _ => 0.75,
            };
            value_of(base + shade - blotch)
        })
        .collect();
    Texture {
        width: side,
        height: side,
        values,
    }
}

/// Renders `s` at t = 0 over the marker's window; the window and its true corners.
fn render_marker(s: &Scenario) -> (crate::render::GrayImage, [[f64; 2]; 4]) {
    let rig = Rig::new(s).unwrap();
    let scene = rig.animated();
    let corners = scene.marker_corners_px(0.0);
    let (x0, y0) = (
        corners.iter().map(|c| c[0]).fold(f64::INFINITY, f64::min),
        corners.iter().map(|c| c[1]).fold(f64::INFINITY, f64::min),
    );
    let window = PixelRect::new(x0 as i64 - 30, y0 as i64 - 30, 130, 130);
    let req = FrameRequest {
        index: 0,
        t_s: 0.0,
        window,
    };
    (render_frame(&scene, &rig.settings, &req), corners)
}

fn view(img: &crate::render::GrayImage) -> GrayView<'_> {
    GrayView {
        data: &img.data,
        width: img.window.width,
        height: img.window.height,
        origin_px: (img.window.x0 as i32, img.window.y0 as i32),
    }
}

fn with_marker_texture(mut s: Scenario, t: Texture, tpc: u32) -> Scenario {
    let a = &mut s.scene.appearance;
    a.marker_file = Some("marker.png".into());
    a.marker_texels_per_cell = tpc;
    a.loaded.marker = Some(Arc::new(t));
    s
}

/// A printed marker rendered by the renderer and measured back: the sampled texels hold the
/// texture that drew it (to the 8-bit footage's rounding and the blur of a slow shading), the
/// guard band takes the local level, and a render of the measured texture reproduces the
/// footage to a DN.
#[test]
fn a_rendered_marker_texture_is_measured_back_and_renders_the_footage_again() {
    let sigma = 0.8;
    let s = rig_scenario(sigma);
    let layout = layout_of(&s);
    let tpc = texels_per_cell(10.7, layout.margin_cells().unwrap()).unwrap();
    let truth = printed_texture(&s, tpc);
    let footage_scenario = with_marker_texture(s.clone(), truth.clone(), tpc);
    let (footage, corners) = render_marker(&footage_scenario);
    let views = [RegisteredView {
        image: view(&footage),
        corners_px: corners,
        light_gain: 1.0,
    }];
    let got = marker_appearance(&views, &layout, sigma, &ANCHORS).unwrap();
    assert_eq!(got.texels_per_cell, tpc);
    assert_eq!(
        (got.texture.width, got.texture.height),
        (truth.width, truth.height)
    );
    assert!(
        got.sampled_texels > got.texture.values.len() / 5,
        "{} of {} sampled",
        got.sampled_texels,
        got.texture.values.len()
    );
    // Sampled texels hold the truth to the footage's rounding and the blur of the shading;
    // the guard band its material's level nearby (the blotch changes it by up to 0.04 there).
    let (mut worst_sampled, mut worst_level) = (0.0f32, 0.0f32);
    for (k, &sampled) in got.sampled_mask.iter().enumerate() {
        let d = (radiance_of(got.texture.values[k]) - radiance_of(truth.values[k])).abs();
        if sampled {
            worst_sampled = worst_sampled.max(d);
        } else {
            worst_level = worst_level.max(d);
        }
    }
    assert!(
        worst_sampled < 3.0 / 255.0,
        "worst sampled texel {worst_sampled}"
    );
    assert!(worst_level < 0.04, "worst level texel {worst_level}");
    // The measured texture renders the footage again.
    let again = with_marker_texture(s, got.texture.clone(), got.texels_per_cell);
    let (render, _) = render_marker(&again);
    let diffs: Vec<f64> = footage
        .data
        .iter()
        .zip(&render.data)
        .map(|(a, b)| *a as f64 - *b as f64)
        .collect();
    let rms = (diffs.iter().map(|d| d * d).sum::<f64>() / diffs.len() as f64).sqrt();
    let max = diffs.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    // At most the guard band's level error (0.04 × 255 DN), a DN on average.
    assert!(rms < 1.0 && max <= 10.0, "rms {rms} DN, max {max} DN");
    // A uniform marker renders it far worse: the test can tell.
    let (plain, _) = render_marker(&rig_scenario(sigma));
    let plain_rms = (footage
        .data
        .iter()
        .zip(&plain.data)
        .map(|(a, b)| (*a as f64 - *b as f64).powi(2))
        .sum::<f64>()
        / diffs.len() as f64)
        .sqrt();
    assert!(
        plain_rms > 5.0 * rms.max(0.2),
        "uniform {plain_rms} DN, measured {rms} DN"
    );
}

/// A print with detail of a few pixels (lines 3.5 px apart across the paper, as a 3-D print's or
/// a tape's): the mosaic holds it blurred once by the footage and the render blurs it again, so
/// the texture as sampled renders the lines too faint; restored, the re-render is closer to the
/// footage, and the cells' edges take no halo.
#[test]
fn fine_detail_is_restored_so_that_the_render_blurs_it_once() {
    let sigma = 0.8;
    let s = rig_scenario(sigma);
    let layout = layout_of(&s);
    let tpc = texels_per_cell(10.7, layout.margin_cells().unwrap()).unwrap();
    let mut truth = printed_texture(&s, tpc);
    let texel_px = 10.7 / tpc as f64;
    for (k, v) in truth.values.iter_mut().enumerate() {
        let x = (k % truth.width) as f64 * texel_px;
        let r = radiance_of(*v) as f64;
        if r > 0.5 {
            *v = value_of(r + 0.12 * (std::f64::consts::TAU * x / 3.5).sin());
        }
    }
    let (footage, corners) = render_marker(&with_marker_texture(s.clone(), truth, tpc));
    let views = [RegisteredView {
        image: view(&footage),
        corners_px: corners,
        light_gain: 1.0,
    }];
    // Compared where the texture was sampled (the guard band holds a level, not the lines).
    let h = Homography::from_corners(&corners, layout.side_cells()).unwrap();
    let margin = (layout.margin_cells().unwrap() * tpc as f64).round();
    let w = footage.window;
    let rerender_rms = |restore: bool| {
        let got = mosaic_marker(&views, &layout, sigma, &ANCHORS, restore).unwrap();
        let side = got.texture.width;
        let mut pixels: Vec<usize> = got
            .sampled_mask
            .iter()
            .enumerate()
            .filter(|(_, &m)| m)
            .filter_map(|(k, _)| {
                let g = |v: usize| (v as f64 + 0.5 - margin) / tpc as f64;
                let [x, y] = h.map(g(k % side), g(k / side));
                let (i, j) = (x.round() as i64 - w.x0, y.round() as i64 - w.y0);
                ((0..w.width as i64).contains(&i) && (0..w.height as i64).contains(&j))
                    .then_some(j as usize * w.width + i as usize)
            })
            .collect();
        pixels.sort_unstable();
        pixels.dedup();
        let again = with_marker_texture(s.clone(), got.texture, got.texels_per_cell);
        let (render, _) = render_marker(&again);
        let d2: Vec<f64> = pixels
            .iter()
            .map(|&p| (footage.data[p] as f64 - render.data[p] as f64).powi(2))
            .collect();
        (d2.iter().sum::<f64>() / d2.len() as f64).sqrt()
    };
    let (restored, sampled) = (rerender_rms(true), rerender_rms(false));
    assert!(
        restored < 0.75 * sampled,
        "re-render RMS restored {restored:.2} DN, as sampled {sampled:.2} DN"
    );
}

#[test]
fn restoration_stays_within_its_material_and_keeps_flat_regions() {
    // Ink texels at 0.1 beside paper at 0.8: a flat region is its own mean, so the step
    // leaves it; no paper value leaks into the ink across the boundary.
    let side = 8;
    let material: Vec<Material> = (0..side * side)
        .map(|k| {
            if k % side < 4 {
                Material::Ink
            } else {
                Material::Paper
            }
        })
        .collect();
    let mut sampled: Vec<Option<f64>> = material
        .iter()
        .map(|m| Some(if *m == Material::Ink { 0.1 } else { 0.8 }))
        .collect();
    sampled[0] = None;
    let before = sampled.clone();
    restore_sampled(&mut sampled, &material, side, 1.5);
    for (a, b) in sampled.iter().zip(&before) {
        match (a, b) {
            (Some(a), Some(b)) => assert!((a - b).abs() < 1e-12, "{a} vs {b}"),
            (a, b) => assert_eq!(a, b),
        }
    }
    // A bright texel among dark ones is raised further (its contrast restored).
    sampled[3 * side + 1] = Some(0.3);
    restore_sampled(&mut sampled, &material, side, 1.0);
    assert!(sampled[3 * side + 1].unwrap() > 0.3);
    assert!(
        sampled[3 * side + 2].unwrap() < 0.1,
        "its neighbour darkened"
    );
}

#[test]
fn sampled_texels_are_those_clear_of_every_edge_by_the_guard_band() {
    let sigma = 1.5;
    let s = rig_scenario(sigma);
    let layout = layout_of(&s);
    let (footage, corners) = render_marker(&s);
    let views = [RegisteredView {
        image: view(&footage),
        corners_px: corners,
        light_gain: 1.0,
    }];
    let sharp = marker_appearance(&views, &layout, 0.3, &ANCHORS).unwrap();
    let blurred = marker_appearance(&views, &layout, sigma, &ANCHORS).unwrap();
    // A wider blur leaves fewer texels clear of the edges.
    assert!(blurred.guard_px > sharp.guard_px);
    assert!(blurred.sampled_texels < sharp.sampled_texels);
    assert_eq!(
        blurred.sampled_texels + blurred.level_texels,
        blurred.texture.values.len()
    );
    // The uniform marker comes back uniform: every texel at its material's level.
    let t = &blurred.texture;
    let m = (layout.margin_cells().unwrap() * blurred.texels_per_cell as f64).round();
    for j in 0..t.height {
        for i in 0..t.width {
            let g = |v: usize| (v as f64 + 0.5 - m) / blurred.texels_per_cell as f64;
            let want = match layout.material(g(i), g(j)) {
                Material::Ink => s.scene.ink_radiance,
                _ => s.scene.paper_radiance,
            };
            let r = radiance_of(t.values[j * t.width + i]) as f64;
            assert!(
                (r - want).abs() < 2.5 / 255.0,
                "texel ({i}, {j}) {r} vs {want}"
            );
        }
    }
}

#[test]
fn texels_per_cell_put_the_margin_on_whole_texels_and_a_texel_within_a_pixel() {
    // A margin of 15/16 cell: multiples of 16 only.
    assert_eq!(texels_per_cell(10.7, 0.9375), Some(16));
    assert_eq!(texels_per_cell(20.0, 0.9375), Some(32));
    assert_eq!(texels_per_cell(100.0, 0.9375), Some(64));
    // A margin of one cell: any; the fewest at least a pixel.
    assert_eq!(texels_per_cell(3.2, 1.0), Some(4));
    assert_eq!(texels_per_cell(0.5, 1.0), Some(1));
    // No count up to 64 makes a margin of 1/3·1/67 whole.
    assert_eq!(texels_per_cell(5.0, 1.0 / 201.0), None);
}

#[test]
fn level_anchors_map_linearly_and_clamp() {
    let a = LevelAnchors {
        ink_dn: 50.0,
        ink_radiance: 0.1,
        paper_dn: 200.0,
        paper_radiance: 0.7,
    };
    assert!((a.radiance(125.0) - 0.4).abs() < 1e-12);
    assert_eq!(a.radiance(0.0), 0.0);
    assert!((a.radiance(255.0) - 0.92).abs() < 1e-12);
    assert_eq!(a.radiance(400.0), 1.0);
}

#[test]
fn no_views_or_no_margin_is_an_error_not_a_texture() {
    let s = rig_scenario(0.5);
    let layout = layout_of(&s);
    assert_eq!(
        marker_appearance(&[], &layout, 0.5, &ANCHORS),
        Err(AppearanceError::NoViews)
    );
    let no_margin = MarkerLayout {
        margin_frac: None,
        ..layout
    };
    let (footage, corners) = render_marker(&s);
    let views = [RegisteredView {
        image: view(&footage),
        corners_px: corners,
        light_gain: 1.0,
    }];
    assert_eq!(
        marker_appearance(&views, &no_margin, 0.5, &ANCHORS),
        Err(AppearanceError::NoMargin)
    );
}

/// Views under a drifting light are brought to the anchors' light before they are averaged: a
/// frame seen at 80 % of the light mosaics, with its gain stated, into the texture of the frame
/// at full light (to the 8-bit rounding), and without it into a texture 10 % darker on average.
#[test]
fn a_view_under_a_dimmer_light_mosaics_into_the_same_texture_once_its_gain_is_stated() {
    let sigma = 0.8;
    let s = rig_scenario(sigma);
    let layout = layout_of(&s);
    let tpc = texels_per_cell(10.7, layout.margin_cells().unwrap()).unwrap();
    let footage_scenario = with_marker_texture(s.clone(), printed_texture(&s, tpc), tpc);
    let (footage, corners) = render_marker(&footage_scenario);
    let dim = crate::render::GrayImage {
        window: footage.window,
        data: footage
            .data
            .iter()
            .map(|&v| (v as f64 * 0.8).round() as u8)
            .collect(),
    };
    fn at(
        img: &crate::render::GrayImage,
        corners_px: [[f64; 2]; 4],
        light_gain: f64,
    ) -> RegisteredView<'_> {
        RegisteredView {
            image: view(img),
            corners_px,
            light_gain,
        }
    }
    let alone = marker_appearance(&[at(&footage, corners, 1.0)], &layout, sigma, &ANCHORS).unwrap();
    let stated = marker_appearance(
        &[at(&footage, corners, 1.0), at(&dim, corners, 0.8)],
        &layout,
        sigma,
        &ANCHORS,
    )
    .unwrap();
    let unstated = marker_appearance(
        &[at(&footage, corners, 1.0), at(&dim, corners, 1.0)],
        &layout,
        sigma,
        &ANCHORS,
    )
    .unwrap();
    let diff = |m: &MarkerAppearance| -> (f64, f64) {
        let d: Vec<f64> = (0..m.texture.values.len())
            .filter(|&k| alone.sampled_mask[k])
            .map(|k| {
                (radiance_of(m.texture.values[k]) - radiance_of(alone.texture.values[k])) as f64
            })
            .collect();
        let worst = d.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        (d.iter().sum::<f64>() / d.len() as f64, worst)
    };
    let (mean, worst) = diff(&stated);
    assert!(
        mean.abs() < 0.5 / 255.0 && worst < 1.5 / 255.0,
        "{mean} {worst}"
    );
    let (mean, _) = diff(&unstated);
    assert!(mean < -0.03, "unstated: {mean}");
    assert_eq!(
        ANCHORS.under_unit_gain(100.0, 0.8),
        125.0,
        "about radiance 0's level"
    );
    let offset = LevelAnchors {
        ink_dn: 40.0,
        ink_radiance: 0.1,
        paper_dn: 200.0,
        paper_radiance: 0.9,
    };
    // Radiance 0 sits at 20 DN: 120 DN (radiance 0.5) at gain 2 is 70 DN (0.25) at gain 1.
    assert!((offset.under_unit_gain(120.0, 2.0) - 70.0).abs() < 1e-12);
}

/// A texture is drawn where the spread beyond the null is at least 1 DN and at least the null's
/// own spread, in either material; the null is what noise alone leaves in the mean, or the same
/// mosaic of renders of the uniform marker.
#[test]
fn a_texture_needs_a_dn_beyond_its_null_and_more_than_the_null_itself() {
    assert!(shows_texture([1.5, 0.0], [0.5, 0.5]));
    assert!(shows_texture([0.0, 1.0], [0.5, 1.0]));
    assert!(!shows_texture([0.9, 0.9], [0.1, 0.1]), "under 1 DN");
    assert!(
        !shows_texture([1.2, 1.2], [1.5, 1.5]),
        "under the null's own spread"
    );
}
