use super::*;
use crate::render::test_scenes::*;
use proptest::prelude::*;

fn reversed(p: &Polygon) -> Polygon {
    let mut v = p.vertices_px.clone();
    v.reverse();
    Polygon { vertices_px: v }
}

fn layer(polygons: Vec<Polygon>) -> Layer {
    Layer {
        texture: None,
        radiance: 1.0,
        polygons,
    }
}

#[test]
fn one_pixel_square_at_integer_coordinates_covers_exactly_one_pixel() {
    let window = PixelRect::new(3, 5, 6, 6);
    for poly in [
        rect(5.5, 7.5, 6.5, 8.5),
        reversed(&rect(5.5, 7.5, 6.5, 8.5)),
    ] {
        let cov = layer_coverage(&layer(vec![poly]), &window);
        for y in window.y0..window.y1() {
            for x in window.x0..window.x1() {
                let c = cov[window.index(x, y).unwrap()];
                let want = if (x, y) == (6, 8) { 1.0 } else { 0.0 };
                assert_eq!(c, want, "pixel ({x}, {y})");
            }
        }
    }
}

#[test]
fn half_pixel_offset_square_splits_over_four_pixels() {
    let window = PixelRect::new(0, 0, 4, 4);
    let cov = layer_coverage(&layer(vec![rect(1.0, 1.0, 2.0, 2.0)]), &window);
    for (x, y) in [(1, 1), (2, 1), (1, 2), (2, 2)] {
        assert_eq!(cov[window.index(x, y).unwrap()], 0.25);
    }
    assert!((cov.iter().sum::<f32>() - 1.0).abs() < 1e-6);
}

#[test]
fn polygons_crossing_the_window_sides_are_clipped_exactly() {
    // A triangle much larger than the window: coverage must equal the analytic area per pixel.
    let window = PixelRect::new(126, 88, 8, 8);
    let tri = Polygon {
        vertices_px: vec![
            DVec2::new(-100.0, -100.0),
            DVec2::new(200.0, 150.0),
            DVec2::new(-100.0, 200.0),
        ],
    };
    let cov = layer_coverage(&layer(vec![tri]), &window);
    // The lower-right edge is y = -100 + 250/300·(x + 100); below it the pixel is covered.
    for y in window.y0..window.y1() {
        for x in window.x0..window.x1() {
            let xl = x as f64 - 0.5;
            let line = |x: f64| -100.0 + 250.0 / 300.0 * (x + 100.0);
            // The interior is below the line (towards the third vertex).
            let mut area = 0.0;
            let n = 2000;
            for k in 0..n {
                let xs = xl + (k as f64 + 0.5) / n as f64;
                area +=
                    ((y as f64 + 0.5) - line(xs).max(y as f64 - 0.5)).clamp(0.0, 1.0) / n as f64;
            }
            let got = cov[window.index(x, y).unwrap()] as f64;
            assert!((got - area).abs() < 1e-4, "({x},{y}) got {got} want {area}");
        }
    }
}

#[test]
fn adjacent_polygons_in_one_layer_leave_no_seam() {
    let centre = DVec2::new(20.3, 19.7);
    let side = 24.0;
    let angle = 0.37;
    let (s, c) = f64::sin_cos(angle);
    let place = |u: f64, v: f64| centre + DVec2::new(c * u - s * v, s * u + c * v);
    let mut cells = Vec::new();
    let n = 6;
    let h = side / n as f64;
    for j in 0..n {
        for i in 0..n {
            let (u0, v0) = (i as f64 * h - side / 2.0, j as f64 * h - side / 2.0);
            let mut q = Polygon {
                vertices_px: vec![
                    place(u0, v0),
                    place(u0 + h, v0),
                    place(u0 + h, v0 + h),
                    place(u0, v0 + h),
                ],
            };
            if (i + j) % 2 == 1 {
                q = reversed(&q); // mixed windings must not matter
            }
            cells.push(q);
        }
    }
    let window = PixelRect::new(0, 0, 40, 40);
    let tiled = layer_coverage(&layer(cells), &window);
    let whole = layer_coverage(&layer(vec![rotated_square(centre, side, angle)]), &window);
    let mut interior = 0;
    for (a, b) in tiled.iter().zip(&whole) {
        // Vertices snap to a 2⁻¹⁶ px grid, so differently split outlines differ by ~1e-5.
        assert!((a - b).abs() < 1e-4, "tiled {a} vs whole {b}");
        if *b == 1.0 {
            interior += 1;
            assert_eq!(*a, 1.0, "seam inside the tiled square");
        }
    }
    assert!(interior > 300);
}

#[test]
fn coverage_does_not_depend_on_the_window() {
    let snap = marker_snapshot(DVec2::new(60.2, 47.9), 70.0, 0.3);
    let full = PixelRect::new(0, 0, 128, 96);
    let image = render_snapshot(&snap, &full);
    for (x0, y0, w, h) in [
        (0, 0, 1, 1),
        (17, 23, 31, 9),
        (63, 40, 65, 56),
        (5, 90, 100, 6),
        (127, 0, 1, 96),
    ] {
        let roi = PixelRect::new(x0, y0, w, h);
        let part = render_snapshot(&snap, &roi);
        for y in roi.y0..roi.y1() {
            for x in roi.x0..roi.x1() {
                let a = part[roi.index(x, y).unwrap()];
                let b = image[full.index(x, y).unwrap()];
                assert_eq!(a.to_bits(), b.to_bits(), "pixel ({x}, {y})");
            }
        }
    }
}

/// Edge x position at each row centre measured from coverage sums: for a half-plane filled to
/// the left, Σ_row coverage = x_edge(row centre) − (x0 − 0.5) exactly (the edge is straight).
fn measured_edges(cov: &[f32], window: &PixelRect) -> Vec<f64> {
    cov.chunks_exact(window.width)
        .map(|row| window.x0 as f64 - 0.5 + row.iter().map(|&c| c as f64).sum::<f64>())
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn rendered_edge_lies_within_a_hundredth_of_a_pixel_of_the_geometry(
        px in 0.0f64..1.0, py in 0.0f64..1.0, angle_deg in -40.0f64..40.0,
    ) {
        let point = DVec2::new(50.0 + px, 50.0 + py);
        let angle = angle_deg.to_radians();
        let window = PixelRect::new(20, 30, 60, 40);
        let cov = layer_coverage(&layer(vec![half_plane_left_of(point, angle)]), &window);
        for (k, x_meas) in measured_edges(&cov, &window).iter().enumerate() {
            let y = (window.y0 + k as i64) as f64;
            // Edge direction is (−sin, cos); its x at row y:
            let x_true = point.x - angle.tan() * (y - point.y);
            prop_assert!((x_meas - x_true).abs() <= 0.01, "row {} err {}", y, x_meas - x_true);
            prop_assert!((x_meas - x_true).abs() <= 1e-4, "fixed-point precision: err {}", x_meas - x_true);
        }
    }

    #[test]
    fn total_coverage_equals_polygon_area(
        cx in 20.0f64..30.0, cy in 20.0f64..30.0, side in 1.0f64..20.0, angle in 0.0f64..6.3,
    ) {
        let window = PixelRect::new(0, 0, 50, 50);
        let cov = layer_coverage(&layer(vec![rotated_square(DVec2::new(cx, cy), side, angle)]), &window);
        let total: f64 = cov.iter().map(|&c| c as f64).sum();
        prop_assert!((total - side * side).abs() < 1e-3 * side, "{} vs {}", total, side * side);
    }
}

#[test]
fn over_compositing_follows_layer_order() {
    let snap = SceneSnapshot {
        background: None,
        background_radiance: 0.2,
        layers: vec![
            Layer {
                texture: None,
                radiance: 1.0,
                polygons: vec![rect(-0.5, -0.5, 0.0, 0.5)],
            },
            Layer {
                texture: None,
                radiance: 0.0,
                polygons: vec![rect(-0.5, -0.5, 0.5, 0.0)],
            },
        ],
    };
    let v = render_snapshot(&snap, &PixelRect::new(0, 0, 1, 1))[0];
    // bg 0.2 → half white: 0.6 → half black over it: 0.3.
    assert!((v - 0.3).abs() < 1e-6, "{v}");
}

#[test]
fn rigid_transform_rotates_about_the_centre_then_translates() {
    let t = RigidTransform {
        centre_px: DVec2::new(10.0, 10.0),
        rotation_rad: std::f64::consts::FRAC_PI_2,
        translation_px: DVec2::new(1.0, 0.0),
    };
    let p = t.apply(DVec2::new(12.0, 10.0));
    assert!((p - DVec2::new(11.0, 12.0)).length() < 1e-12);
}

#[test]
fn fast_rounding_matches_the_standard_rounding() {
    use rand::Rng;
    let mut rng = crate::rng::stream(3, crate::rng::Stream::MonteCarlo, 1);
    let special = [
        0.0,
        -0.0,
        0.5,
        -0.5,
        1.5,
        -2.5,
        0.49999999999999994,
        -0.49999999999999994,
        4503599627370495.5,
        4503599627370497.0,
        -1e15 - 0.5,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e300,
    ];
    let random = (0..100_000).map(|i| {
        let scale = 10f64.powi(i % 16);
        (rng.gen::<f64>() - 0.5) * scale
    });
    for v in special.into_iter().chain(random) {
        assert_eq!(super::round_to_i64(v), v.round() as i64, "{v}");
        let half = v.trunc() + 0.5f64.copysign(v);
        assert_eq!(super::round_to_i64(half), half.round() as i64, "{half}");
    }
}
