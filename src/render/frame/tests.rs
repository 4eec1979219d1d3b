use super::*;
use crate::render::effects::pixel_noise::NoiseGainAt;
use crate::render::effects::{CameraVibrationConfig, RandomVibrationConfig, Sinusoid};
use crate::render::effects::{MotionBlurConfig, PixelNoiseConfig, RollingShutterConfig};
use crate::render::test_scenes::*;
use glam::DVec2;
use rand::Rng;

fn settings(width_px: usize, height_px: usize, effects: EffectsConfig) -> RenderSettings {
    RenderSettings {
        width_px,
        height_px,
        effects,
        seed: 1234,
    }
}

fn request(index: u64, t_s: f64, window: PixelRect) -> FrameRequest {
    FrameRequest { index, t_s, window }
}

/// A vertical edge at x = `x_px` (t = 0) moving right at `v_px_s`; black left, white right.
fn moving_edge(x_px: f64, v_px_s: f64) -> Moving {
    Moving {
        base: single_layer(
            vec![half_plane_left_of(DVec2::new(x_px, 0.0), 0.0)],
            0.0,
            1.0,
        ),
        velocity_px_s: DVec2::new(v_px_s, 0.0),
    }
}

/// Everything on, strong enough to matter in a small frame.
fn all_effects() -> EffectsConfig {
    let mut fx = EffectsConfig::default();
    fx.optical_blur.sigma_px = 1.2;
    fx.motion_blur.exposure_s = 0.01;
    fx.motion_blur.max_samples = 24;
    fx.rolling_shutter.enabled = true;
    fx.rolling_shutter.readout_s = 0.01;
    fx.camera_vibration = CameraVibrationConfig {
        enabled: true,
        x_px: vec![Sinusoid {
            amplitude: 0.7,
            frequency_hz: 13.0,
            phase_rad: 0.3,
        }],
        random: RandomVibrationConfig {
            y_rms_px: 0.3,
            rotation_rms_rad: 0.002,
            ..Default::default()
        },
        ..Default::default()
    };
    fx.lighting.gradient_x_frac = -0.2;
    fx.lighting.vignetting_frac = 0.3;
    fx.lighting.gamma = 1.4;
    fx.lighting.gain_drift_per_s = 0.05;
    fx.lighting.flicker_frac = 0.08;
    fx.lighting.flicker_hz = 100.0;
    fx.compression.enabled = true;
    fx.compression.quality = 70;
    fx.sharpening.enabled = true;
    fx.sharpening.amount = 0.9;
    fx.sharpening.sigma_px = 1.3;
    fx
}

fn spinning() -> SpinningMarker {
    SpinningMarker {
        centre_px: DVec2::new(81.3, 58.6),
        side_px: 70.0,
        rate_rad_s: 3.0,
    }
}

#[test]
fn region_of_interest_is_bit_identical_to_the_full_frame_with_all_effects_on() {
    let s = settings(161, 117, all_effects());
    let scene = spinning();
    let full = render_frame(&scene, &s, &request(3, 0.21, s.frame_rect()));
    assert_eq!(full.window, s.frame_rect());
    let mut rng = crate::rng::stream(5, crate::rng::Stream::MonteCarlo, 0);
    for _ in 0..12 {
        let x0 = rng.gen_range(-10..160);
        let y0 = rng.gen_range(-10..116);
        let window = PixelRect::new(x0, y0, rng.gen_range(1..60), rng.gen_range(1..50));
        let roi = render_frame(&scene, &s, &request(3, 0.21, window));
        assert_eq!(roi.window, window.intersect(&s.frame_rect()));
        assert_eq!(roi, full.crop(&window), "window {window:?}");
    }
}

#[test]
fn region_of_interest_is_bit_identical_under_even_light_that_flickers_and_steps() {
    let mut fx = all_effects();
    fx.lighting.gradient_x_frac = 0.0;
    fx.lighting.vignetting_frac = 0.0;
    fx.lighting.gain_steps = vec![crate::render::effects::lighting::GainStep {
        at_s: 0.212,
        gain: 1.15,
    }];
    let s = settings(161, 117, fx);
    let scene = spinning();
    let full = render_frame(&scene, &s, &request(3, 0.21, s.frame_rect()));
    let mut rng = crate::rng::stream(6, crate::rng::Stream::MonteCarlo, 0);
    for _ in 0..12 {
        let x0 = rng.gen_range(-10..160);
        let y0 = rng.gen_range(-10..116);
        let window = PixelRect::new(x0, y0, rng.gen_range(1..60), rng.gen_range(1..50));
        if window.intersect(&s.frame_rect()).is_empty() {
            continue;
        }
        let roi = render_frame(&scene, &s, &request(3, 0.21, window));
        assert_eq!(roi, full.crop(&window), "window {window:?}");
    }
}

#[test]
fn a_flickering_light_under_a_rolling_shutter_draws_bands_row_by_row() {
    let mut fx = EffectsConfig::none();
    fx.lighting.enabled = true;
    fx.lighting.black_level_dn = 0.0;
    fx.lighting.white_level_dn = 250.0;
    fx.lighting.flicker_frac = 0.2;
    fx.lighting.flicker_hz = 100.0;
    fx.rolling_shutter.enabled = true;
    fx.rolling_shutter.readout_s = 0.03;
    let scene = Moving {
        base: single_layer(vec![], 0.0, 0.6),
        velocity_px_s: DVec2::ZERO,
    };
    let s = settings(16, 120, fx.clone());
    let img = render_frame(&scene, &s, &request(0, 0.0, s.frame_rect()));
    for y in 0..120usize {
        let t = fx.rolling_shutter.row_delay_s(y as i64, 120);
        let want = quantise_f64(250.0 * 0.6 * fx.lighting.temporal_gain(t, 0.0));
        assert!(
            img.data[y * 16..(y + 1) * 16].iter().all(|&v| v == want),
            "row {y}: want {want}"
        );
    }
    // Three periods over the readout: the brightest and darkest rows 0.2 · 150 DN off the mean.
    let (lo, hi) = (
        img.data.iter().min().unwrap(),
        img.data.iter().max().unwrap(),
    );
    assert!((*hi as f64 - 180.0).abs() <= 1.0 && (*lo as f64 - 120.0).abs() <= 1.0);
}

fn quantise_f64(dn: f64) -> u8 {
    (dn + 0.5).clamp(0.0, 255.0) as u8
}

#[test]
fn same_seed_gives_identical_bytes_on_one_and_four_threads() {
    let s = settings(96, 64, all_effects());
    let scene = spinning();
    let render_all = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            (0..6u64)
                .into_par_iter()
                .map(|i| render_frame(&scene, &s, &request(i, i as f64 / 30.0, s.frame_rect())))
                .collect::<Vec<_>>()
        })
    };
    let one = render_all(1);
    let four = render_all(4);
    assert_eq!(one, four);
    let other_seed = RenderSettings {
        seed: 99,
        ..s.clone()
    };
    let again = render_frame(&scene, &other_seed, &request(0, 0.0, s.frame_rect()));
    assert_ne!(again, one[0], "the seed must change the noise");
    assert_ne!(one[0].data, one[1].data);
}

/// Edge-derivative centroid (px) and second moment (px²) of a row profile that rises left → right.
fn edge_moments(row: &[f32], x0: i64) -> (f64, f64) {
    let d: Vec<f64> = row.windows(2).map(|w| (w[1] - w[0]) as f64).collect();
    let total: f64 = d.iter().sum();
    let pos = |i: usize| x0 as f64 + i as f64 + 0.5;
    let mean = d.iter().enumerate().map(|(i, v)| v * pos(i)).sum::<f64>() / total;
    let var = d
        .iter()
        .enumerate()
        .map(|(i, v)| v * (pos(i) - mean).powi(2))
        .sum::<f64>()
        / total;
    (mean, var)
}

fn linear_row(scene: &dyn SceneAt, fx: EffectsConfig, t_s: f64) -> (Vec<f32>, i64) {
    let s = settings(200, 20, fx);
    let rect = PixelRect::new(0, 10, 200, 1);
    (
        render_linear(scene, &s, &request(0, t_s, rect), &rect).data,
        rect.x0,
    )
}

#[test]
fn motion_blur_spreads_the_edge_by_the_distance_moved_during_exposure() {
    let v = 400.0;
    let t = 0.1;
    let mut fx = EffectsConfig::none();
    let (still, x0) = linear_row(&moving_edge(60.3, 0.0), fx.clone(), t);
    let (m0, var0) = edge_moments(&still, x0);
    assert!((m0 - 60.3).abs() < 1e-3, "{m0}");
    for exposure_s in [0.005, 0.0125, 0.025] {
        fx.motion_blur = MotionBlurConfig {
            enabled: true,
            exposure_s,
            ..Default::default()
        };
        let (row, x0) = linear_row(&moving_edge(60.3, v), fx.clone(), t);
        let (m, var) = edge_moments(&row, x0);
        let travel = v * exposure_s;
        // The average position is the position at the exposure centre.
        assert!((m - (60.3 + v * t)).abs() < 0.01, "centroid {m}");
        // A uniform smear of length L adds L²/12 to the variance.
        let want = travel * travel / 12.0;
        assert!(
            ((var - var0) - want).abs() < 0.02 * want + 0.01,
            "L={travel}: Δvar {} vs {want}",
            var - var0
        );
    }
}

#[test]
fn optical_blur_edge_width_matches_sigma() {
    let mut fx = EffectsConfig::none();
    let scene = moving_edge(80.37, 0.0);
    let (still, x0) = linear_row(&scene, fx.clone(), 0.0);
    let (_, var0) = edge_moments(&still, x0);
    for sigma_px in [0.6, 1.5, 3.0] {
        fx.optical_blur.enabled = true;
        fx.optical_blur.sigma_px = sigma_px;
        let (row, x0) = linear_row(&scene, fx.clone(), 0.0);
        let (m, var) = edge_moments(&row, x0);
        assert!((m - 80.37).abs() < 1e-3, "blur must not move the edge: {m}");
        let measured = (var - var0).sqrt();
        assert!(
            (measured - sigma_px).abs() < 0.01 * sigma_px + 0.005,
            "σ {sigma_px}: measured {measured}"
        );
    }
}

#[test]
fn rolling_shutter_shears_a_moving_vertical_edge_by_speed_times_readout() {
    let (v, readout_s, h) = (300.0, 0.02, 40usize);
    let mut fx = EffectsConfig::none();
    fx.rolling_shutter = RollingShutterConfig {
        enabled: true,
        readout_s,
    };
    let s = settings(64, h, fx);
    let rect = s.frame_rect();
    let img = render_linear(&moving_edge(20.25, v), &s, &request(0, 0.01, rect), &rect);
    for (y, row) in img.data.chunks_exact(rect.width).enumerate() {
        // Black (0) left of the edge: the edge sits where the covered width ends.
        let x_meas = -0.5 + row.iter().map(|&c| 1.0 - c as f64).sum::<f64>();
        let t_row = 0.01 + readout_s * y as f64 / h as f64;
        let x_true = 20.25 + v * t_row;
        assert!(
            (x_meas - x_true).abs() < 0.01,
            "row {y}: {x_meas} vs {x_true}"
        );
    }
}

#[test]
fn camera_vibration_translates_the_image_exactly() {
    let mut fx = EffectsConfig::none();
    fx.camera_vibration = CameraVibrationConfig {
        enabled: true,
        x_px: vec![Sinusoid {
            amplitude: 1.7,
            frequency_hz: 5.0,
            phase_rad: 0.0,
        }],
        ..Default::default()
    };
    let scene = moving_edge(50.1, 0.0);
    for t in [0.0, 0.05, 0.11] {
        let (row, x0) = linear_row(&scene, fx.clone(), t);
        let (m, _) = edge_moments(&row, x0);
        let want = 50.1 + 1.7 * (std::f64::consts::TAU * 5.0 * t).sin();
        assert!((m - want).abs() < 1e-3, "t {t}: {m} vs {want}");
    }
}

#[test]
fn noise_variance_matches_shot_plus_read_plus_quantisation() {
    let mut fx = EffectsConfig::none();
    fx.lighting.enabled = true;
    fx.lighting.black_level_dn = 10.0;
    fx.lighting.white_level_dn = 210.0;
    fx.pixel_noise = PixelNoiseConfig {
        enabled: true,
        full_well_e: 1000.0,
        read_noise_e: 5.0,
        level_gain: Vec::new(),
    };
    // Without a level table, and with one that doubles the σ at the dark level (30 DN) and
    // halves it at the mid level (110 DN): a flat run and a row of varying radiance each.
    let table = vec![
        NoiseGainAt {
            level_dn: 30.0,
            gain: 2.0,
        },
        NoiseGainAt {
            level_dn: 110.0,
            gain: 0.5,
        },
    ];
    for (level_gain, gains) in [(Vec::new(), [1.0, 1.0]), (table, [2.0, 0.5])] {
        fx.pixel_noise.level_gain = level_gain;
        for (radiance, g) in [0.1f32, 0.5].into_iter().zip(gains) {
            for ripple in [0.0, 1e-6] {
                // A light gradient far below a DN takes the per-pixel path instead of the flat
                // run's.
                let mut fx = fx.clone();
                fx.lighting.gradient_x_frac = ripple;
                let scene = Moving {
                    base: single_layer(vec![], 0.0, radiance),
                    velocity_px_s: DVec2::ZERO,
                };
                let s = settings(256, 200, fx);
                let img = render_frame(&scene, &s, &request(1, 0.0, s.frame_rect()));
                let n = img.data.len() as f64;
                let mean = img.data.iter().map(|&v| v as f64).sum::<f64>() / n;
                let var = img
                    .data
                    .iter()
                    .map(|&v| (v as f64 - mean).powi(2))
                    .sum::<f64>()
                    / n;
                let gain_dn_per_e = 200.0 / 1000.0;
                let electrons = radiance as f64 * 1000.0;
                let want = g * g * gain_dn_per_e * gain_dn_per_e * (electrons + 25.0) + 1.0 / 12.0;
                assert!(
                    (mean - (10.0 + 200.0 * radiance as f64)).abs() < 0.1,
                    "mean {mean}"
                );
                assert!(
                    (var / want - 1.0).abs() < 0.04,
                    "r {radiance}, gain {g}, ripple {ripple}: var {var} vs {want}"
                );
            }
        }
    }
    fx.pixel_noise.enabled = false;
    let scene = Moving {
        base: single_layer(vec![], 0.0, 0.5),
        velocity_px_s: DVec2::ZERO,
    };
    let s = settings(32, 32, fx);
    let img = render_frame(&scene, &s, &request(1, 0.0, s.frame_rect()));
    assert!(
        img.data.iter().all(|&v| v == 110),
        "noise off leaves the exact quantised level"
    );
}

#[test]
fn automatic_sample_count_follows_image_speed() {
    let mut fx = EffectsConfig::none();
    fx.motion_blur = MotionBlurConfig {
        enabled: true,
        exposure_s: 0.01,
        ..Default::default()
    };
    let s = settings(64, 32, fx);
    // 100 px/s × 10 ms = 1 px → 20 samples of 0.05 px; a still scene needs one.
    let moving = image_travel_px(&moving_edge(10.0, 100.0), &s, 0.0, 0.01, None);
    assert!((moving - 1.0).abs() < 1e-9);
    assert_eq!(s.effects.motion_blur.sample_count(moving), 20);
    assert_eq!(
        image_travel_px(&moving_edge(10.0, 0.0), &s, 0.0, 0.01, None),
        0.0
    );
}

#[test]
fn linear_radiance_of_a_window_is_bit_identical_before_quantisation() {
    // Quantisation could hide one-ulp differences; compare the blurred f32 radiance directly.
    let s = settings(150, 100, all_effects());
    let scene = spinning();
    let full_rect = s.frame_rect();
    let full = render_linear(&scene, &s, &request(2, 0.13, full_rect), &full_rect);
    for window in [
        PixelRect::new(3, 7, 70, 40),
        PixelRect::new(60, 30, 64, 64),
        PixelRect::new(0, 90, 150, 10),
    ] {
        let part = render_linear(&scene, &s, &request(2, 0.13, window), &window);
        for y in window.y0..window.y1() {
            for x in window.x0..window.x1() {
                assert_eq!(
                    part.get(x, y).unwrap().to_bits(),
                    full.get(x, y).unwrap().to_bits(),
                    "({x}, {y}) in {window:?}"
                );
            }
        }
    }
}

#[test]
fn reused_buffers_give_the_same_frames() {
    let s = settings(120, 90, all_effects());
    let scene = spinning();
    let mut buffers = FrameBuffers::default();
    for (i, window) in [
        s.frame_rect(),
        PixelRect::new(10, 20, 33, 17),
        s.frame_rect(),
    ]
    .iter()
    .enumerate()
    {
        let req = request(i as u64, i as f64 * 0.03, *window);
        assert_eq!(
            render_frame_with(&scene, &s, &req, &mut buffers),
            render_frame(&scene, &s, &req)
        );
    }
}

/// A static square under a moving square: only the second layer moves during the exposure.
struct HalfStatic;

impl SceneAt for HalfStatic {
    fn snapshot(&self, t_s: f64) -> SceneSnapshot {
        let dx = 300.0 * t_s;
        SceneSnapshot {
            background: None,
            background_radiance: 0.3,
            layers: vec![
                crate::render::shapes::Layer {
                    texture: None,
                    radiance: 0.9,
                    polygons: vec![rotated_square(DVec2::new(40.3, 30.1), 30.0, 0.4)],
                },
                crate::render::shapes::Layer {
                    texture: None,
                    radiance: 0.1,
                    polygons: vec![rotated_square(DVec2::new(45.0 + dx, 38.7), 20.0, 0.2)],
                },
            ],
        }
    }
}

#[test]
fn exposure_average_matches_summing_whole_sample_renders() {
    // The band renderer skips inactive columns, reuses static layers' coverage and composites
    // mean coverages of the nested moving square; the reference renders every sample over the
    // whole frame and averages them (equal up to float rounding: the raster tests pin the
    // sample-by-sample path bit for bit).
    let mut fx = EffectsConfig::none();
    fx.motion_blur.enabled = true;
    fx.motion_blur.exposure_s = 0.01;
    fx.motion_blur.samples = 7;
    let s = settings(130, 90, fx.clone());
    let t_s = 0.02;
    let rect = s.frame_rect();
    let fast = render_linear(&HalfStatic, &s, &request(0, t_s, rect), &rect);
    let offsets = motion_blur::sample_offsets_s(0.01, 7);
    let mut reference = vec![0.0f32; rect.len()];
    for (i, o) in offsets.iter().enumerate() {
        let sample = crate::render::raster::render_snapshot(&HalfStatic.snapshot(t_s + o), &rect);
        for (r, v) in reference.iter_mut().zip(&sample) {
            *r = if i == 0 { *v } else { *r + v };
        }
    }
    reference.iter_mut().for_each(|r| *r *= 1.0 / 7.0f32);
    for (i, (a, b)) in fast.data.iter().zip(&reference).enumerate() {
        assert!((a - b).abs() <= 2e-7, "pixel {i}: {a} vs {b}");
    }
    // And with the optical blur on, a window still equals the full frame.
    fx.optical_blur.enabled = true;
    let s = settings(130, 90, fx);
    let full = render_linear(&HalfStatic, &s, &request(0, t_s, rect), &rect);
    let window = PixelRect::new(50, 20, 37, 41);
    let part = render_linear(&HalfStatic, &s, &request(0, t_s, window), &window);
    for y in window.y0..window.y1() {
        for x in window.x0..window.x1() {
            assert_eq!(
                part.get(x, y).unwrap().to_bits(),
                full.get(x, y).unwrap().to_bits()
            );
        }
    }
}

#[test]
fn sharpening_adds_the_unsharp_masks_halo_to_a_step() {
    // A vertical step on a pixel boundary (pixel x covers x ± ½), no blur, noise or codec: each pixel of a row is a
    // level, and the mask's blur of a step is the step weighted by the kernel's tail, so the
    // sharpened row follows in closed form from the Gaussian.
    let mut fx = EffectsConfig::none();
    fx.sharpening.enabled = true;
    fx.sharpening.amount = 0.7;
    fx.sharpening.sigma_px = 1.5;
    let s = settings(80, 20, fx.clone());
    let scene = Moving {
        base: single_layer(
            vec![half_plane_left_of(DVec2::new(39.5, 0.0), 0.0)],
            0.2,
            0.8,
        ),
        velocity_px_s: DVec2::ZERO,
    };
    let img = render_frame(&scene, &s, &request(0, 0.0, s.frame_rect()));
    let (dark, bright) = (0.2 * 255.0, 0.8 * 255.0);
    let sigma = fx.sharpening.sigma_px;
    let r = (4.0 * sigma).ceil() as i64;
    let g = |k: i64| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp();
    let total: f64 = (-r..=r).map(g).sum();
    for x in 20..60i64 {
        let level = |x: i64| if x < 40 { dark } else { bright };
        let blurred: f64 = (-r..=r).map(|k| g(k) * level(x + k)).sum::<f64>() / total;
        let want = level(x) + 0.7 * (level(x) - blurred);
        let got = img.data[10 * 80 + x as usize] as f64;
        assert!((got - want).abs() <= 0.51, "x {x}: {got} against {want}");
    }
    // The halo: above the bright level right of the step, below the dark level left of it.
    assert!(img.data[10 * 80 + 40] as f64 > bright + 20.0);
    assert!((img.data[10 * 80 + 39] as f64) < dark - 20.0);
}

#[test]
fn a_scenario_without_sharpening_writes_no_sharpening_table() {
    let text = toml::to_string(&EffectsConfig::default()).unwrap();
    assert!(!text.contains("sharpening"), "{text}");
    let mut fx = EffectsConfig::default();
    fx.sharpening.enabled = true;
    let text = toml::to_string(&fx).unwrap();
    let back: EffectsConfig = toml::from_str(&text).unwrap();
    assert_eq!(back, fx);
}
