use super::*;
use crate::render::effects::EffectsConfig;
use crate::render::frame::{render_frame, FrameRequest, RenderSettings};
use crate::render::test_scenes::{half_plane_left_of, single_layer, Moving};
use glam::DVec2;

/// The seed rig's real 4K frame, copied into the repository (from `shared/real/`) so that every
/// checkout, CI's clean clone included, measures it: a missing file fails the test.
const REAL_FRAME: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/data/real/annotated-frame-4k.jpg"
);
/// Regions of the large base-plate marker in the 3840×2160 frame (located on a downscaled
/// copy): paper left of the marker, the marker's left black border, and a strip across the
/// paper → ink edge (near-vertical) between them.
const PAPER: PixelRect = PixelRect {
    x0: 735,
    y0: 1720,
    width: 30,
    height: 200,
};
const INK: PixelRect = PixelRect {
    x0: 805,
    y0: 1760,
    width: 45,
    height: 160,
};
const EDGE_STRIP: PixelRect = PixelRect {
    x0: 762,
    y0: 1730,
    width: 40,
    height: 180,
};

#[test]
fn edge_fit_recovers_the_renderers_blur_sigma() {
    for sigma_px in [0.7, 1.3, 2.2] {
        let mut fx = EffectsConfig::none();
        fx.optical_blur.enabled = true;
        fx.optical_blur.sigma_px = sigma_px;
        fx.lighting.enabled = true;
        fx.lighting.black_level_dn = 30.0;
        fx.lighting.white_level_dn = 200.0;
        let tilt = 0.03;
        let scene = Moving {
            base: single_layer(
                vec![half_plane_left_of(DVec2::new(40.3, 20.0), tilt)],
                1.0,
                0.0,
            ),
            velocity_px_s: DVec2::ZERO,
        };
        let s = RenderSettings {
            width_px: 80,
            height_px: 40,
            effects: fx,
            seed: 1,
        };
        let img = render_frame(
            &scene,
            &s,
            &FrameRequest {
                index: 0,
                t_s: 0.0,
                window: s.frame_rect(),
            },
        );
        let fit = fit_vertical_edge(&img, &PixelRect::new(25, 5, 30, 30)).unwrap();
        assert_eq!(fit.rows, 30);
        // 8-bit quantisation limits the fit; the renderer is exact.
        assert!(
            (fit.sigma_px - sigma_px).abs() < 0.03,
            "σ {sigma_px}: fitted {}",
            fit.sigma_px
        );
        let x_true = 40.3 - tilt.tan() * (5.0 - 20.0);
        assert!(
            (fit.edge_x_px[0] - x_true).abs() < 0.05,
            "{} vs {x_true}",
            fit.edge_x_px[0]
        );
    }
}

#[test]
fn flat_noise_estimate_matches_rendered_noise() {
    let mut fx = EffectsConfig::none();
    fx.pixel_noise.enabled = true;
    fx.pixel_noise.full_well_e = 400.0;
    fx.pixel_noise.read_noise_e = 0.0;
    let scene = Moving {
        base: single_layer(vec![], 0.0, 0.5),
        velocity_px_s: DVec2::ZERO,
    };
    let s = RenderSettings {
        width_px: 100,
        height_px: 100,
        effects: fx,
        seed: 1,
    };
    let img = render_frame(
        &scene,
        &s,
        &FrameRequest {
            index: 0,
            t_s: 0.0,
            window: s.frame_rect(),
        },
    );
    let (level, sigma) = flat_level_and_noise(&img, &s.frame_rect()).unwrap();
    // 200 electrons of 400 at 255 DN: σ² = 255²·200/400² DN² (+ quantisation 1/12 DN²).
    let want = (255.0f64.powi(2) * 200.0 / 160_000.0 + 1.0 / 12.0).sqrt();
    assert!((sigma / want - 1.0).abs() < 0.05, "{sigma} vs {want}");
    assert!((level - 127.5).abs() <= 1.0);
}

/// Measures the real frame and checks the documented defaults against it (prints the numbers).
#[test]
fn defaults_match_the_real_frame_measurement() {
    let bytes = std::fs::read(REAL_FRAME).unwrap_or_else(|e| panic!("{REAL_FRAME}: {e}"));
    let img = decode_jpeg_luma(&bytes).unwrap();
    assert_eq!((img.window.width, img.window.height), (3840, 2160));
    let (paper_dn, paper_noise_dn) = flat_level_and_noise(&img, &PAPER).unwrap();
    let (ink_dn, ink_noise_dn) = flat_level_and_noise(&img, &INK).unwrap();
    let edge = fit_vertical_edge(&img, &EDGE_STRIP).unwrap();
    let span = paper_dn - ink_dn;
    eprintln!(
        "real frame: paper {paper_dn} DN (σ {paper_noise_dn:.2}), ink {ink_dn} DN (σ {ink_noise_dn:.2}), \
         edge σ {:.3} px over {} rows (edge x {:.1}..{:.1})",
        edge.sigma_px,
        edge.rows,
        edge.edge_x_px.first().unwrap(),
        edge.edge_x_px.last().unwrap()
    );
    assert!(edge.rows > 150);
    let d = EffectsConfig::default();
    assert!(
        (d.lighting.black_level_dn - ink_dn).abs() <= 3.0,
        "black default vs {ink_dn}"
    );
    assert!(
        (d.lighting.white_level_dn - paper_dn).abs() <= 3.0,
        "white default vs {paper_dn}"
    );
    assert!(
        (d.optical_blur.sigma_px - edge.sigma_px).abs() <= 0.1,
        "σ default vs {}",
        edge.sigma_px
    );
    // Default noise at the ink (radiance 0: read noise only) reproduces the measured σ.
    let ink_sigma_dn = span * d.pixel_noise.read_noise_e / d.pixel_noise.full_well_e;
    assert!(
        (ink_sigma_dn / ink_noise_dn - 1.0).abs() <= 0.1,
        "ink σ {ink_sigma_dn} vs {ink_noise_dn}"
    );
    // The paper is flattened by the phone's processing: the model's σ there is an upper bound.
    let paper_sigma_dn = span
        * (d.pixel_noise.full_well_e + d.pixel_noise.read_noise_e.powi(2)).sqrt()
        / d.pixel_noise.full_well_e;
    assert!(paper_noise_dn < paper_sigma_dn);
}
