//! Image statistics measured on frames from the project's own renderer with known blur, noise,
//! levels and JPEG quality.

use super::*;
use crate::marker::Dictionary;
use crate::render::effects::optical_blur::effective_sigma_px;
use crate::render::effects::EffectsConfig;
use crate::render::frame::{render_frame, FrameRequest, RenderSettings};
use crate::render::shapes::{Layer, Polygon, SceneSnapshot};
use crate::render::test_scenes::Moving;
use crate::render::{GrayImage, PixelRect};
use crate::scene::black_rectangles;
use glam::DVec2;

/// Radiances of the test scene: ink and paper stay clear of the tone curve's clipping.
const INK: f32 = 0.05;
const PAPER: f32 = 0.95;
const SURROUND: f32 = 0.5;

struct Setup {
    paper: f32,
    corners: [[f64; 2]; 4],
    layout: MarkerLayout,
    fx: EffectsConfig,
    size: usize,
}

impl Setup {
    /// A 4x4_50 id-7 marker (6 cells) with a margin of 1/4 side, centred in a `size`² frame,
    /// `side_px` wide, turned by `angle_rad`, with a slight perspective (corners moved by up to
    /// `skew_px`).
    fn new(size: usize, side_px: f64, angle_rad: f64, skew_px: f64) -> Setup {
        let c = size as f64 / 2.0 - 0.5 + 0.37;
        let h = side_px / 2.0;
        let (s, co) = angle_rad.sin_cos();
        let base = [(-h, -h), (h, -h), (h, h), (-h, h)];
        let jitter = [(0.3, -1.0), (-0.6, 0.2), (1.0, 0.5), (-0.2, 0.8)];
        let corners = std::array::from_fn(|k| {
            let (x, y) = base[k];
            [
                c + co * x - s * y + skew_px * jitter[k].0,
                c + s * x + co * y + skew_px * jitter[k].1,
            ]
        });
        Setup {
            paper: PAPER,
            corners,
            layout: MarkerLayout::new(Dictionary::Dict4x4_50, 7, 1, Some(0.25)).unwrap(),
            fx: EffectsConfig::none(),
            size,
        }
    }

    fn snapshot(&self) -> SceneSnapshot {
        let n = self.layout.side_cells() as f64;
        let h = Homography::from_corners(&self.corners, self.layout.side_cells()).unwrap();
        let quad = |a: f64, b: f64, c: f64, d: f64| Polygon {
            vertices_px: [(a, b), (c, b), (c, d), (a, d)]
                .iter()
                .map(|&(x, y)| DVec2::from(h.map(x, y)))
                .collect(),
        };
        let m = self.layout.margin_cells().unwrap_or(0.0);
        let ink = black_rectangles(&self.layout.cells)
            .iter()
            .map(|r| quad(r.col0 as f64, r.row0 as f64, r.col1 as f64, r.row1 as f64))
            .collect();
        SceneSnapshot {
            background: None,
            background_radiance: SURROUND,
            layers: vec![
                Layer {
                    texture: None,
                    radiance: self.paper,
                    polygons: vec![quad(-m, -m, n + m, n + m)],
                },
                Layer {
                    texture: None,
                    radiance: INK,
                    polygons: ink,
                },
            ],
        }
    }

    fn render(&self, index: u64) -> GrayImage {
        let s = RenderSettings {
            width_px: self.size,
            height_px: self.size,
            effects: self.fx.clone(),
            seed: 11,
        };
        let scene = Moving {
            base: self.snapshot(),
            velocity_px_s: DVec2::ZERO,
        };
        render_frame(
            &scene,
            &s,
            &FrameRequest {
                index,
                t_s: 0.0,
                window: s.frame_rect(),
            },
        )
    }

    /// Levels 40/210 DN, blur σ and mild noise: the usual edge-test frame.
    fn standard(size: usize, side_px: f64, angle_rad: f64, skew_px: f64, sigma: f64) -> Setup {
        let mut s = Setup::new(size, side_px, angle_rad, skew_px);
        s.levels(40.0, 210.0);
        s.blur(sigma);
        s.noise(20000.0, 100.0);
        s
    }

    fn levels(&mut self, black: f64, white: f64) {
        self.fx.lighting.enabled = true;
        self.fx.lighting.black_level_dn = black;
        self.fx.lighting.white_level_dn = white;
    }

    fn blur(&mut self, sigma: f64) {
        self.fx.optical_blur.enabled = sigma > 0.0;
        self.fx.optical_blur.sigma_px = sigma;
    }

    fn noise(&mut self, full_well_e: f64, read_noise_e: f64) {
        self.fx.pixel_noise.enabled = true;
        self.fx.pixel_noise.full_well_e = full_well_e;
        self.fx.pixel_noise.read_noise_e = read_noise_e;
    }

    /// Expected DN level and noise σ (with quantisation) at radiance `s`.
    fn expect(&self, s: f64) -> (f64, f64) {
        let l = &self.fx.lighting;
        let span = l.white_level_dn - l.black_level_dn;
        let p = &self.fx.pixel_noise;
        let var = if p.enabled {
            span * span * (s * p.full_well_e + p.read_noise_e.powi(2)) / p.full_well_e.powi(2)
        } else {
            0.0
        };
        (l.black_level_dn + span * s, (var + 1.0 / 12.0).sqrt())
    }
}

fn view(img: &GrayImage) -> GrayView<'_> {
    GrayView {
        data: &img.data,
        width: img.window.width,
        height: img.window.height,
        origin_px: (img.window.x0 as i32, img.window.y0 as i32),
    }
}

#[test]
fn levels_and_noise_of_ink_paper_and_surround_match_the_rendered_ones() {
    let mut s = Setup::new(240, 120.0, 0.3, 1.5);
    s.levels(40.0, 210.0);
    s.blur(0.8);
    s.noise(4000.0, 40.0);
    let img = s.render(0);
    let lv = marker_levels(&view(&img), &s.corners, &s.layout, &LevelOptions::default()).unwrap();
    let sur = lv.surround.clone().expect("surround ring measured");
    for (name, st, rad) in [
        ("ink", &lv.ink, INK),
        ("paper", &lv.paper, PAPER),
        ("surround", &sur, SURROUND),
    ] {
        let (level, sigma) = s.expect(rad as f64);
        assert!(
            (st.median_dn - level).abs() <= 0.6 && (st.trimmed_mean_dn - level).abs() < 0.3,
            "{name}: median {} mean {} vs {level}",
            st.median_dn,
            st.trimmed_mean_dn
        );
        assert!(
            (st.noise_sigma_dn / sigma - 1.0).abs() < 0.08,
            "{name}: σ {} vs {sigma}",
            st.noise_sigma_dn
        );
        assert!(
            (st.noise_sigma_diff_dn / sigma - 1.0).abs() < 0.1,
            "{name}: σ(diff) {} vs {sigma}",
            st.noise_sigma_diff_dn
        );
        assert!(st.pixels > 300 && st.pairs > 200, "{name}: {st:?}");
        assert_eq!(st.clipping, None, "{name}");
    }
    // The regions keep the guard: no ink pixel within 3 px of the paper.
    let regions =
        marker_regions(&view(&img), &s.corners, &s.layout, &LevelOptions::default()).unwrap();
    assert_eq!(regions.ink.len(), lv.ink.pixels);
}

#[test]
fn paper_at_the_white_level_is_reported_clipped_with_its_unclipped_noise() {
    // Radiance 1 maps to the white level and the tone curve clips the noise above it.
    let mut s = Setup::new(240, 120.0, 0.3, 1.5);
    s.paper = 1.0;
    s.levels(40.0, 210.0);
    s.blur(0.8);
    s.noise(4000.0, 40.0);
    let img = s.render(0);
    let lv = marker_levels(&view(&img), &s.corners, &s.layout, &LevelOptions::default()).unwrap();
    let c = lv.paper.clipping.clone().expect("clipped");
    let (_, sigma) = s.expect(1.0);
    assert!(c.high && c.level_dn == 210.0 && c.fraction > 0.4, "{c:?}");
    assert!(
        (c.sigma_dn / sigma - 1.0).abs() < 0.1,
        "{} vs {sigma}",
        c.sigma_dn
    );
    assert!(lv.paper.noise_sigma_dn < 0.7 * sigma);
    assert_eq!(lv.ink.clipping, None);
}

/// Ink 1.6σ above the black level: the tone curve cuts its lower tail, which piles up at the
/// black level (≈ 5 % of the pixels, far below the 30 % a pile at the region's own mean makes).
/// The pile is reported with the censored normal's mean and σ; the plain σ of the region is
/// biased low (the round trip's ink noise came out 10–12 % low on such footage).
#[test]
fn ink_near_the_black_level_is_reported_censored_with_its_uncut_noise() {
    let mut s = Setup::new(240, 120.0, 0.3, 1.5);
    s.levels(40.0, 210.0);
    s.blur(0.8);
    s.noise(1000.0, 30.0);
    let img = s.render(0);
    let lv = marker_levels(&view(&img), &s.corners, &s.layout, &LevelOptions::default()).unwrap();
    let (level, sigma) = s.expect(INK as f64);
    assert!((level - 40.0) / sigma < 2.0, "{level} {sigma}");
    let c = lv.ink.clipping.clone().expect("censored");
    assert!(!c.high && c.level_dn == 40.0, "{c:?}");
    assert!(c.fraction > MIN_PILE_FRACTION && c.fraction < 0.3, "{c:?}");
    assert!((c.mean_dn - level).abs() < 0.6, "{c:?} vs {level}");
    assert!((c.sigma_dn / sigma - 1.0).abs() < 0.08, "{c:?} vs {sigma}");
    assert!(lv.ink.noise_sigma_dn < 0.97 * sigma, "{:?}", lv.ink);
    // The paper, 1.2σ below the white level here, has its upper tail cut the same way.
    let (level, sigma) = s.expect(PAPER as f64);
    let p = lv.paper.clipping.clone().expect("censored above");
    assert!(p.high && p.level_dn == 210.0 && p.fraction < 0.3, "{p:?}");
    assert!((p.mean_dn - level).abs() < 0.6, "{p:?} vs {level}");
    assert!((p.sigma_dn / sigma - 1.0).abs() < 0.08, "{p:?} vs {sigma}");
}

#[test]
fn outer_edges_recover_blur_sigma_from_0_3_to_2_5_px() {
    for &(sigma, side, angle) in &[
        (0.3, 120.0, 0.3),
        (0.6, 120.0, 1.1),
        (1.0, 90.0, 0.06),
        (1.6, 120.0, 0.7),
        (2.5, 150.0, 0.2),
    ] {
        let s = Setup::standard(240, side, angle, 1.5, sigma);
        let img = s.render(1);
        let fits = outer_edge_profiles(&view(&img), &s.corners, &s.layout, &EdgeOptions::default());
        let mut ok = Vec::new();
        for (k, f) in fits.into_iter().enumerate() {
            let f = f.unwrap_or_else(|e| panic!("σ {sigma} side {k}: {e}"));
            // The renderer's kernel is sampled at whole pixels: compare with the σ it applies.
            let eff = effective_sigma_px(sigma);
            eprintln!(
                "σ {sigma} (eff {eff:.4}) side {k}: {:.4} ± {:.4}",
                f.sigma_px, f.sigma_stderr_px
            );
            assert!(
                (f.sigma_px - eff).abs() < (0.04 * eff).max(0.04),
                "σ {sigma} (effective {eff}) side {k}: fitted {} ± {}",
                f.sigma_px,
                f.sigma_stderr_px
            );
            assert!(f.sigma_stderr_px > 0.0 && f.sigma_stderr_px < 0.05 * sigma.max(0.5));
            // The fitted line is the true one: the given corners are exact.
            assert!(
                f.offset_px.abs() < 0.03,
                "σ {sigma} side {k}: offset {}",
                f.offset_px
            );
            let (ink, _) = s.expect(INK as f64);
            let (paper, _) = s.expect(PAPER as f64);
            assert!((f.ink_dn.unwrap() - ink).abs() < 1.0, "{f:?}");
            assert!((f.paper_dn.unwrap() - paper).abs() < 1.0, "{f:?}");
            // Outer normals point away from the marker centre.
            let c = [
                s.corners.iter().map(|p| p[0]).sum::<f64>() / 4.0,
                s.corners.iter().map(|p| p[1]).sum::<f64>() / 4.0,
            ];
            let out = (f.point_px[0] - c[0]) * f.normal[0] + (f.point_px[1] - c[1]) * f.normal[1];
            assert!(out > 0.0, "side {k} normal points inwards");
            ok.push(f);
        }
        let refined = refined_corners(&ok, s.layout.side_cells()).unwrap();
        for (p, q) in refined.iter().zip(&s.corners) {
            assert!((p[0] - q[0]).hypot(p[1] - q[1]) < 0.05, "{p:?} vs {q:?}");
        }
    }
}

#[test]
fn shifted_corners_are_corrected_by_the_edge_fit() {
    // OpenCV's unrefined corners sit about half a pixel inside: the fitted lines do not.
    let s = Setup::standard(240, 120.0, 0.4, 0.0, 0.7);
    let img = s.render(2);
    let c = [
        s.corners.iter().map(|p| p[0]).sum::<f64>() / 4.0,
        s.corners.iter().map(|p| p[1]).sum::<f64>() / 4.0,
    ];
    let shrunk = s.corners.map(|p| {
        let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
        let r = dx.hypot(dy);
        [p[0] - 0.7 * dx / r, p[1] - 0.7 * dy / r]
    });
    let fits: Vec<EdgeProfile> =
        outer_edge_profiles(&view(&img), &shrunk, &s.layout, &EdgeOptions::default())
            .into_iter()
            .map(|f| f.unwrap())
            .collect();
    for f in &fits {
        assert!((f.sigma_px - 0.7).abs() < 0.04, "{}", f.sigma_px);
        assert!(
            (f.offset_px - 0.7 / 2f64.sqrt()).abs() < 0.05,
            "{}",
            f.offset_px
        );
    }
    let refined = refined_corners(&fits, s.layout.side_cells()).unwrap();
    let side = square_fit(&refined).unwrap().side_px;
    assert!((side - 120.0).abs() < 0.05, "{side}");
}

#[test]
fn small_marker_with_strong_blur_models_the_cells_behind_the_border() {
    // 8-px cells and σ 2.5: the band reaches the first row of inner cells.
    let mut s = Setup::new(128, 48.0, 0.2, 0.5);
    s.levels(30.0, 220.0);
    s.blur(2.5);
    s.noise(20000.0, 100.0);
    let img = s.render(3);
    let fits = outer_edge_profiles(&view(&img), &s.corners, &s.layout, &EdgeOptions::default());
    for f in fits {
        let f = f.unwrap();
        assert!((f.sigma_px / 2.5 - 1.0).abs() < 0.06, "{}", f.sigma_px);
    }
}

#[test]
fn inner_cell_edges_measure_the_same_blur() {
    let s = Setup::standard(240, 150.0, 0.5, 1.0, 1.2);
    let img = s.render(4);
    let inner = inner_edge_profiles(
        &view(&img),
        &s.corners,
        &s.layout,
        &EdgeOptions {
            sigma_hint_px: 1.5,
            ..Default::default()
        },
        1,
    );
    assert!(inner.len() >= 3, "{} inner edges", inner.len());
    for f in &inner {
        assert!(
            (f.sigma_px / 1.2 - 1.0).abs() < 0.08,
            "{:?}: {}",
            f.edge,
            f.sigma_px
        );
    }
}

#[test]
fn temporal_noise_of_static_regions_matches_the_renderer() {
    let mut s = Setup::new(200, 110.0, 0.1, 0.0);
    s.levels(40.0, 210.0);
    s.blur(0.6);
    s.noise(3000.0, 30.0);
    let frames: Vec<GrayImage> = (0..6).map(|k| s.render(k)).collect();
    let views: Vec<GrayView<'_>> = frames.iter().map(view).collect();
    let regions =
        marker_regions(&views[0], &s.corners, &s.layout, &LevelOptions::default()).unwrap();
    for (name, px, rad) in [("ink", &regions.ink, INK), ("paper", &regions.paper, PAPER)] {
        let t = temporal_noise(&views, px).unwrap();
        let (level, sigma) = s.expect(rad as f64);
        assert!((t.level_dn - level).abs() < 0.3, "{name}: {}", t.level_dn);
        assert!(
            (t.sigma_dn / sigma - 1.0).abs() < 0.05,
            "{name}: {} vs {sigma}",
            t.sigma_dn
        );
        assert!(t.sigma_stderr_dn < 0.02 * sigma);
        assert_eq!((t.frames, t.pixels), (6, px.len()));
    }
    assert!(temporal_noise(&views[..1], &regions.ink).is_err());
}

#[test]
fn blockiness_and_quality_estimate_follow_the_jpeg_quality() {
    let mut base = Setup::new(256, 150.0, 0.35, 1.0);
    base.levels(40.0, 210.0);
    base.blur(0.8);
    base.noise(2000.0, 20.0);
    let plain = base.render(5);
    let b0 = blockiness(&view(&plain), None).unwrap();
    assert!((b0.ratio - 1.0).abs() < 0.05, "uncompressed: {b0:?}");
    assert_eq!(jpeg_quality(&view(&plain), None, 1024).unwrap(), None);
    let mut last_ratio = 0.0;
    for q in [95u8, 90, 80, 65, 50] {
        let mut s = Setup::new(256, 150.0, 0.35, 1.0);
        s.fx = base.fx.clone();
        s.fx.compression.enabled = true;
        s.fx.compression.quality = q;
        let img = s.render(5);
        let b = blockiness(&view(&img), None).unwrap();
        // At q ≥ 90 the blocks hide under the noise; below they stand out on the 8-px grid.
        assert!(b.ratio > last_ratio, "q {q}: {b:?}");
        if q <= 80 {
            assert!(b.ratio > 1.1, "q {q}: {b:?}");
            assert_eq!((b.best_phase_x, b.best_phase_y), (0, 0), "q {q}: {b:?}");
        }
        last_ratio = b.ratio;
        eprintln!("q {q}: {b:?}");
        let est = jpeg_quality(&view(&img), None, 1024)
            .unwrap()
            .expect("quantised");
        eprintln!("q {q}: {est:?}");
        assert!(
            est.quality_range.0 <= q && q <= est.quality_range.1 && est.quality.abs_diff(q) <= 2,
            "q {q}: {est:?}"
        );
    }
}

/// `s` uncompressed is not JPEG; compressed at each of `qualities` it is, at that quality.
fn assert_jpeg_only_when_compressed(mut s: Setup, qualities: &[u8], what: &str) {
    let plain = s.render(3);
    let est = jpeg_quality(&view(&plain), None, 1024).unwrap();
    assert_eq!(est, None, "{what} uncompressed: {est:?}");
    for &q in qualities {
        s.fx.compression.enabled = true;
        s.fx.compression.quality = q;
        let img = s.render(3);
        let est = jpeg_quality(&view(&img), None, 1024).unwrap();
        assert!(
            est.as_ref().is_some_and(|e| e.quality.abs_diff(q) <= 2),
            "{what} at q {q}: {est:?}"
        );
    }
}

/// A quiet uncompressed render (noise below 1 DN) is not JPEG: its block-DCT coefficients
/// spread continuously about 0 and a coarse table that rounds them all to 0 explains them no
/// better than no quantiser (the step-1 lattice null once lost to such tables: round-trip cases
/// with < 1 DN of noise were reported as JPEG). The same frames compressed still are.
#[test]
fn quiet_uncompressed_renders_are_not_taken_for_jpeg() {
    for (full_well, read) in [(40000.0, 40.0), (60000.0, 60.0), (100000.0, 50.0)] {
        let mut s = Setup::new(256, 150.0, 0.35, 1.0);
        s.levels(40.0, 210.0);
        s.blur(0.5);
        s.noise(full_well, read);
        let (_, sigma) = s.expect(1.0);
        assert!(sigma < 1.0, "{sigma}");
        assert_jpeg_only_when_compressed(s, &[95, 80], &format!("noise {sigma:.2} DN"));
    }
}

/// A frame that is mostly flat to a fraction of a DN (a small marker in a large uncompressed
/// frame, σ ≈ 0.1 DN at the ink) is not JPEG either: a table that rounds every small coefficient
/// to 0 out-scores one Laplace continuum on such zero-inflated coefficients by ~3 nats per block
/// (the round trip took these renders for quality 87), but the coefficients beyond the zero bin
/// do not sit on its lattice. Compressed, the same frame still is JPEG.
#[test]
fn mostly_flat_uncompressed_frames_are_not_taken_for_jpeg() {
    let mut s = Setup::new(512, 110.0, 0.35, 1.0);
    s.levels(65.0, 172.0);
    s.blur(0.55);
    s.noise(170000.0, 58.0);
    assert_jpeg_only_when_compressed(s, &[95, 87], "mostly flat");
}

#[test]
fn square_fit_measures_size_aspect_and_shear() {
    let sq = [[10.0, 10.0], [110.0, 10.0], [110.0, 110.0], [10.0, 110.0]];
    let f = square_fit(&sq).unwrap();
    assert!((f.side_px - 100.0).abs() < 1e-9 && f.rms_residual_px < 1e-9);
    assert!((f.aspect - 1.0).abs() < 1e-12 && f.shear.abs() < 1e-12);
    assert!(f.angle_rad.abs() < 1e-12);
    // Compressed vertically by cos 10°, then turned: aspect = cos 10°, minor axis turned too.
    let (a, t) = (10f64.to_radians().cos(), 0.4f64);
    let turn = |p: [f64; 2]| {
        let (x, y) = (p[0] - 60.0, (p[1] - 60.0) * a);
        [
            60.0 + t.cos() * x - t.sin() * y,
            60.0 + t.sin() * x + t.cos() * y,
        ]
    };
    let g = square_fit(&sq.map(turn)).unwrap();
    assert!((g.aspect - a).abs() < 1e-9, "{}", g.aspect);
    assert!(
        ((g.minor_axis_angle_rad - (t + std::f64::consts::FRAC_PI_2))
            .rem_euclid(std::f64::consts::PI))
        .min(
            std::f64::consts::PI
                - (g.minor_axis_angle_rad - (t + std::f64::consts::FRAC_PI_2))
                    .rem_euclid(std::f64::consts::PI)
        ) < 1e-9
    );
    assert!(g.rms_residual_px > 0.5 && g.affine_rms_residual_px < 1e-9);
    // A rolling-shutter shear x' = x + κ·y.
    let k = 0.02;
    let h = square_fit(&sq.map(|p| [p[0] + k * (p[1] - 60.0), p[1]])).unwrap();
    assert!((h.shear - k).abs() < 1e-12, "{}", h.shear);
    // A perspective quadrilateral leaves an affine remainder.
    let p = square_fit(&[[10.0, 10.0], [110.0, 12.0], [108.0, 108.0], [10.0, 110.0]]).unwrap();
    assert!(p.affine_rms_residual_px > 0.1);
}

#[test]
fn bad_regions_are_errors_not_numbers() {
    let mut s = Setup::new(160, 100.0, 0.0, 0.0);
    s.levels(40.0, 210.0);
    let img = s.render(0);
    let v = view(&img);
    // Partly outside the view.
    let off = s.corners.map(|p| [p[0] + 60.0, p[1]]);
    assert!(matches!(
        marker_levels(&v, &off, &s.layout, &LevelOptions::default()),
        Err(StatsError::OutsideView { .. })
    ));
    assert!(
        outer_edge_profiles(&v, &off, &s.layout, &EdgeOptions::default())
            .iter()
            .any(|r| matches!(r, Err(StatsError::OutsideView { .. })))
    );
    // Collinear corners.
    let flat = [[10.0, 10.0], [20.0, 10.0], [30.0, 10.0], [40.0, 10.0]];
    assert!(matches!(
        marker_levels(&v, &flat, &s.layout, &LevelOptions::default()),
        Err(StatsError::Degenerate { .. })
    ));
    // A marker of 12 px: 2-px cells leave nothing well inside.
    let tiny = [[70.0, 70.0], [82.0, 70.0], [82.0, 82.0], [70.0, 82.0]];
    assert!(matches!(
        marker_levels(&v, &tiny, &s.layout, &LevelOptions::default()),
        Err(StatsError::TooFew { .. })
    ));
    // A window that does not hold whole blocks.
    let small = GrayView {
        data: &img.data[..7 * 7],
        width: 7,
        height: 7,
        origin_px: (0, 0),
    };
    assert!(jpeg_quality(&small, None, 100).is_err());
    assert!(blockiness(&small, None).is_err());
    // A view whose buffer is too short.
    let broken = GrayView {
        data: &img.data[..10],
        width: 160,
        height: 160,
        origin_px: (0, 0),
    };
    assert!(matches!(
        blockiness(&broken, None),
        Err(StatsError::Invalid(_))
    ));
    let _ = PixelRect::new(0, 0, 1, 1);
}

/// A 64×64 view whose pixel (x, y) is `f(x, y)`, and its pixels split at x = 32 into two flat
/// regions (ink left, paper right).
fn split_patch(f: impl Fn(i64, i64) -> u8) -> (Vec<u8>, MarkerRegions) {
    let data: Vec<u8> = (0..64i64)
        .flat_map(|y| (0..64i64).map(move |x| (x, y)))
        .map(|(x, y)| f(x, y))
        .collect();
    let all: Vec<(i64, i64)> = (0..64i64)
        .flat_map(|y| (0..64i64).map(move |x| (x, y)))
        .collect();
    let (ink, paper): (Vec<_>, Vec<_>) = all.into_iter().partition(|&(x, _)| x < 32);
    let regions = MarkerRegions {
        ink,
        paper,
        surround: Vec::new(),
    };
    (data, regions)
}

/// Deterministic noise of a few DN at (x, y).
fn hash_noise(x: i64, y: i64) -> i64 {
    let h = (x as u64)
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add((y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F));
    ((h >> 59) as i64) - 16
}

#[test]
fn flat_region_blockiness_sees_block_steps_and_not_the_edge_between_regions() {
    let level = |x: i64| if x < 32 { 40 } else { 200 };
    fn view_of(data: &[u8]) -> GrayView<'_> {
        GrayView {
            data,
            width: 64,
            height: 64,
            origin_px: (0, 0),
        }
    }
    // Noise alone, with the step between the regions on a block boundary (x = 32): ≈ 1.
    let (data, regions) = split_patch(|x, y| (level(x) + hash_noise(x, y) / 4) as u8);
    let b = flat_region_blockiness(&view_of(&data), &regions).unwrap();
    assert!((b - 1.0).abs() < 0.25, "{b}");
    // The same noise with each 8×8 block offset by its own level: the block boundaries stand out.
    let (data, regions) = split_patch(|x, y| {
        let block = ((x / 8) * 5 + (y / 8) * 3) % 7 - 3;
        (level(x) + hash_noise(x, y) / 4 + 3 * block) as u8
    });
    let b = flat_region_blockiness(&view_of(&data), &regions).unwrap();
    assert!(b > 3.0, "{b}");
    // Without noise nothing differs inside a region: no blocks to see.
    let (data, regions) = split_patch(|x, _| level(x) as u8);
    assert_eq!(flat_region_blockiness(&view_of(&data), &regions), Some(1.0));
    // Too few pairs of either kind: no figure.
    let few = MarkerRegions {
        ink: (0..6).map(|x| (x, 0)).collect(),
        paper: Vec::new(),
        surround: Vec::new(),
    };
    assert_eq!(flat_region_blockiness(&view_of(&data), &few), None);
}
