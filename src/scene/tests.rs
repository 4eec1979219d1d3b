//! Scene tests: marker kinematics in the image, OpenCV corner order against the cell layout,
//! disjoint black polygons with exact area, tessellation tolerance, validation.

use std::f64::consts::PI;

use glam::DVec2;
use proptest::prelude::*;

use super::*;
use crate::camera::{Camera, CameraConfig, LensDistortionConfig};
use crate::marker::{marker_bits, Dictionary};
use crate::render::shapes::SceneAt;
use crate::validation::Problems;

fn camera_at(rc: [f64; 2]) -> Camera {
    Camera::new(&CameraConfig {
        rotation_centre_px: Some(rc),
        ..CameraConfig::default()
    })
    .unwrap()
}

fn pose(theta2_rad: f64) -> WheelPose {
    WheelPose {
        theta2_rad,
        centre_offset_m: [0.0, 0.0],
    }
}

fn shoelace(v: &[DVec2]) -> f64 {
    let n = v.len();
    0.5 * (0..n).map(|i| v[i].perp_dot(v[(i + 1) % n])).sum::<f64>()
}

fn inside(p: DVec2, poly: &[DVec2]) -> bool {
    let n = poly.len();
    let mut c = false;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        if (a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y) {
            c = !c;
        }
    }
    c
}

fn dist_to_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    (p - (a + t * ab)).length()
}

#[test]
fn black_rectangles_cover_each_black_cell_once() {
    for id in [0, 7, 33, 49] {
        let grid = crate::marker::cells(Dictionary::Dict4x4_50, id, 1).unwrap();
        let mut count = vec![vec![0; grid.len()]; grid.len()];
        let rects = black_rectangles(&grid);
        for r in &rects {
            for row in count.iter_mut().take(r.row1).skip(r.row0) {
                for c in row.iter_mut().take(r.col1).skip(r.col0) {
                    *c += 1;
                }
            }
        }
        for (r, row) in grid.iter().enumerate() {
            for (c, &white) in row.iter().enumerate() {
                assert_eq!(
                    count[r][c],
                    if white { 0 } else { 1 },
                    "id {id} cell ({r},{c})"
                );
            }
        }
        // Merging actually happens: the border alone is far fewer than 20 single cells.
        assert!(rects.len() < grid.iter().flatten().filter(|w| !**w).count());
    }
}

#[test]
fn seed_scene_validates_and_bad_marker_is_reported() {
    let mut ok = Problems::new();
    SceneConfig::default().validate("scene", &mut ok);
    assert!(ok.is_empty(), "{ok:?}");
    let mut cfg = SceneConfig::default();
    cfg.marker.radius_mm = 170.0;
    cfg.marker.id = 50;
    let mut p = Problems::new();
    cfg.validate("scene", &mut p);
    let fields: Vec<&str> = p.iter().map(|x| x.field.as_str()).collect();
    assert!(fields.contains(&"scene.marker.radius_mm"), "{fields:?}");
    assert!(fields.contains(&"scene.marker.id"), "{fields:?}");
    assert!(Scene::new(&cfg, camera_at([1919.5, 1079.5])).is_err());
}

#[test]
fn black_layer_area_is_exact_and_cells_match_bits() {
    let rc = [1800.0, 1000.0];
    for (dict, id) in [
        (Dictionary::Dict4x4_50, 0),
        (Dictionary::Dict4x4_50, 17),
        (Dictionary::Dict6x6_250, 101),
    ] {
        let mut cfg = SceneConfig::default();
        cfg.marker.dictionary = dict;
        cfg.marker.id = id;
        cfg.marker.orientation_deg = 23.0;
        let scene = Scene::new(&cfg, camera_at(rc)).unwrap();
        let bits = marker_bits(dict, id).unwrap();
        let n = bits.len();
        let side = n + 2;
        let black_cells = (side * side - bits.iter().flatten().filter(|w| **w).count()) as f64;
        for theta in [0.0, 0.4, 2.1, -1.3] {
            let p = pose(theta);
            let snap = scene.snapshot_at(&p);
            let black = snap.layers.last().unwrap();
            let cell_px = cfg.marker.size_mm / side as f64 / 0.195;
            let area: f64 = black
                .polygons
                .iter()
                .map(|q| shoelace(&q.vertices_px).abs())
                .sum();
            let expected = black_cells * cell_px * cell_px;
            assert!(
                ((area - expected) / expected).abs() < 1e-9,
                "{area} vs {expected}"
            );
            // Independent of the scene's own placement code: walk the cells from the corners.
            let c = scene.marker_corners_px_at(&p).map(DVec2::from);
            let (ex, ey) = ((c[1] - c[0]) / side as f64, (c[3] - c[0]) / side as f64);
            for row in 0..side {
                for col in 0..side {
                    let centre = c[0] + (col as f64 + 0.5) * ex + (row as f64 + 0.5) * ey;
                    let hits = black
                        .polygons
                        .iter()
                        .filter(|q| inside(centre, &q.vertices_px))
                        .count();
                    let data = (1..=n).contains(&row) && (1..=n).contains(&col);
                    let white = data && bits[row - 1][col - 1];
                    assert_eq!(
                        hits,
                        usize::from(!white),
                        "{dict:?} id {id} θ {theta} cell ({row},{col})"
                    );
                }
            }
            // TL → TR → BR → BL is clockwise on screen (y down): positive shoelace area.
            assert!(shoelace(&c) > 0.0);
        }
    }
}

#[test]
fn marker_at_theta_zero_is_upright_right_of_centre() {
    let rc = [1919.5, 1079.5];
    let scene = Scene::new(&SceneConfig::default(), camera_at(rc)).unwrap();
    let c = scene.marker_corners_px_at(&pose(0.0));
    let r_px = 145.0 / 0.195;
    let h = 16.0 / 0.195;
    let expected = [[-h, -h], [h, -h], [h, h], [-h, h]];
    for k in 0..4 {
        let e = DVec2::new(rc[0] + r_px + expected[k][0], rc[1] + expected[k][1]);
        assert!(
            (DVec2::from(c[k]) - e).length() < 1e-9,
            "corner {k}: {:?} vs {e}",
            c[k]
        );
    }
}

#[test]
fn disc_polygon_chord_error_below_tolerance() {
    let rc = [1919.5, 1079.5];
    let cfg = SceneConfig::default();
    let scene = Scene::new(&cfg, camera_at(rc)).unwrap();
    let snap = scene.snapshot_at(&pose(0.3));
    let disc = &snap.layers[0].polygons[0].vertices_px;
    let r_px = cfg.disc_radius_mm / 0.195;
    let c = DVec2::from(rc);
    let n = disc.len();
    let mut worst: f64 = 0.0;
    for i in 0..n {
        assert!(((disc[i] - c).length() - r_px).abs() < 1e-9);
        let mid = 0.5 * (disc[i] + disc[(i + 1) % n]);
        worst = worst.max(r_px - (mid - c).length());
    }
    assert!(worst < TOLERANCE_PX && worst > 0.0, "sagitta {worst}");
}

#[test]
fn distorted_edges_follow_the_curved_image() {
    let cam = Camera::new(&CameraConfig {
        rotation_centre_px: Some([1500.0, 900.0]),
        lens_distortion: LensDistortionConfig {
            enabled: true,
            k1: -0.25,
            k2: 0.08,
            p1: 0.004,
            ..Default::default()
        },
        ..CameraConfig::default()
    })
    .unwrap();
    let mut cfg = SceneConfig::default();
    cfg.marker.orientation_deg = 31.0;
    let scene = Scene::new(&cfg, cam.clone()).unwrap();
    let p = pose(0.7);
    let snap = scene.snapshot_at(&p);
    let black = &snap.layers.last().unwrap().polygons;
    let placed = scene.placed_marker(&p);
    // The outer square's exact image must lie on the black polygons' boundary.
    let mut worst: f64 = 0.0;
    for k in 0..=400 {
        let s = k as f64 / 400.0;
        for q in [
            placed.at(s, 0.0),
            placed.at(1.0, s),
            placed.at(s, 1.0),
            placed.at(0.0, s),
        ] {
            let x = cam.project(q);
            let d = black
                .iter()
                .flat_map(|poly| {
                    let v = &poly.vertices_px;
                    (0..v.len()).map(move |i| dist_to_segment(x, v[i], v[(i + 1) % v.len()]))
                })
                .fold(f64::INFINITY, f64::min);
            worst = worst.max(d);
        }
    }
    assert!(worst <= TOLERANCE_PX * 1.01, "edge deviation {worst} px");
    // Without subdivision the same edges would be visibly off: the check can fail.
    let straight = [placed.at(0.0, 0.0), placed.at(1.0, 0.0)].map(|q| cam.project(q));
    let mid = cam.project(placed.at(0.5, 0.0));
    assert!(dist_to_segment(mid, straight[0], straight[1]) > 10.0 * TOLERANCE_PX);
}

#[test]
fn animated_scene_and_reference_marker() {
    let mut cfg = SceneConfig::default();
    cfg.reference_marker.enabled = true;
    let rc = [1919.5, 1079.5];
    let scene = Scene::new(&cfg, camera_at(rc))
        .unwrap()
        .animate(|t: f64| WheelPose {
            theta2_rad: 0.5 * t,
            centre_offset_m: [1e-4 * t, 0.0],
        });
    let snap = scene.snapshot(1.0);
    assert_eq!(snap.layers.len(), 5);
    assert!((snap.background_radiance - 0.2).abs() < 1e-6);
    let bb = scene.marker_bbox_px(1.0);
    for c in scene.marker_corners_px(1.0) {
        assert!(
            c[0] > bb.min_px.x && c[0] < bb.max_px.x && c[1] > bb.min_px.y && c[1] < bb.max_px.y
        );
    }
    let centre = scene.rotation_centre_px(1.0);
    assert!((centre - DVec2::new(rc[0] + 0.1 / 0.195, rc[1])).length() < 1e-9);
    let r = scene.reference_marker_corners_px().unwrap();
    let mid = (DVec2::from(r[0]) + DVec2::from(r[2])) / 2.0;
    assert!((mid - DVec2::new(rc[0] - 280.0 / 0.195, rc[1])).length() < 1e-9);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn marker_rotates_about_the_rotation_centre(
        theta in -10.0f64..10.0, rx in 1000.0f64..2800.0, ry in 900.0f64..1200.0,
        angle_on_disc_deg in -180.0f64..180.0, orientation_deg in -90.0f64..90.0,
    ) {
        let mut cfg = SceneConfig::default();
        cfg.marker.angle_on_disc_deg = angle_on_disc_deg;
        cfg.marker.orientation_deg = orientation_deg;
        let scene = Scene::new(&cfg, camera_at([rx, ry])).unwrap();
        let c = DVec2::new(rx, ry);
        let scale = 1.0 / 0.195;
        let centre = scene.marker_centre_px_at(&pose(theta));
        prop_assert!(((centre - c).length() - 145.0 * scale).abs() < 1e-8);
        let phi = angle_on_disc_deg.to_radians() + theta;
        let dir = DVec2::new(phi.cos(), phi.sin());
        prop_assert!(((centre - c).normalize() - dir).length() < 1e-9);
        // Rigid rotation of every corner about the rotation centre.
        let c0 = scene.marker_corners_px_at(&pose(0.0));
        let ct = scene.marker_corners_px_at(&pose(theta));
        let rot = DVec2::from_angle(theta);
        for k in 0..4 {
            let expected = c + rot.rotate(DVec2::from(c0[k]) - c);
            prop_assert!((DVec2::from(ct[k]) - expected).length() < 1e-8);
        }
        prop_assert!((scene.rotation_centre_px_at(&pose(theta)) - c).length() < 1e-9);
        let _ = PI;
    }
}

#[test]
fn disc_behind_a_steeply_tilted_camera_is_rejected() {
    use crate::camera::PerspectiveTiltConfig;
    let tilted = |deg: f64| {
        Camera::new(&CameraConfig {
            perspective_tilt: PerspectiveTiltConfig {
                enabled: true,
                tilt_x_deg: deg,
                tilt_y_deg: 0.0,
            },
            ..CameraConfig::default()
        })
        .unwrap()
    };
    // Tilted 70° about x while looking at the origin from 0.3 m above the plane, the camera sits
    // over y = 0.3·tan 70° and its focal plane cuts the disc plane at y = 0.3·(tan 70° + cot 70°)
    // ≈ 0.933 m: a 1 m disc reaches behind the camera, a 0.9 m one does not.
    let big = |r: f64| SceneConfig {
        disc_radius_mm: r,
        ..SceneConfig::default()
    };
    let err = Scene::new(&big(1000.0), tilted(70.0)).unwrap_err();
    assert!(err.to_string().contains("scene.disc_radius_mm"), "{err}");
    assert!(Scene::new(&big(900.0), tilted(70.0)).is_ok());
    // A moderate tilt works, and the disc polygon follows the disc's image (an ellipse).
    let camera = tilted(20.0);
    let scene = Scene::new(&SceneConfig::default(), camera.clone()).unwrap();
    let disc = &scene.snapshot_at(&pose(0.0)).layers[0].polygons[0].vertices_px;
    assert!(disc.len() > 1000);
    disc_polygon_follows_the_disc(&camera, SceneConfig::default().disc_radius_mm, disc);
}

/// Checks `polygon` against the disc of `radius_mm` about the world origin seen by `camera`
/// (pinhole, no distortion), without the scene's projection of the circle: every vertex, cast
/// back as a ray onto the disc plane, lands on the rim (to 1e-9 relative: only rounding); the
/// rays cover the rim once, in order; and the rim point half-way between two vertices is within
/// the tessellation tolerance of their chord (the stated 0.001 px).
fn disc_polygon_follows_the_disc(camera: &Camera, radius_mm: f64, polygon: &[DVec2]) {
    use glam::DVec3;
    let r_m = radius_mm * 1e-3;
    let pos = camera.position_m();
    // Rows of the world-to-camera rotation R: R·e_i is the camera-frame image of axis i.
    let axes = [DVec3::X, DVec3::Y, DVec3::Z].map(|e| camera.to_camera_m(pos + e));
    let (pp, f) = (camera.principal_point_px(), camera.focal_px());
    let on_plane = |p: DVec2| {
        let d_cam = ((p - pp) / f).extend(1.0);
        let d = DVec3::new(axes[0].dot(d_cam), axes[1].dot(d_cam), axes[2].dot(d_cam));
        let q = pos - d * (pos.z / d.z);
        assert!(q.z.abs() < 1e-12);
        DVec2::new(q.x, q.y)
    };
    let n = polygon.len();
    let mut turned = 0.0;
    for k in 0..n {
        let (a, b) = (on_plane(polygon[k]), on_plane(polygon[(k + 1) % n]));
        assert!(
            (a.length() / r_m - 1.0).abs() < 1e-9,
            "vertex {k}: {} m from the axis, rim {r_m} m",
            a.length()
        );
        let step = a.angle_to(b);
        assert!(step > 0.0 && step < 0.1, "vertex {k}: step {step} rad");
        turned += step;
        let mid = (a + b).normalize() * r_m;
        let rim_px = camera.project(mid.extend(0.0));
        let (u, v) = (polygon[k], polygon[(k + 1) % n]);
        let off_chord = (rim_px - u).perp_dot(v - u).abs() / (v - u).length();
        assert!(
            off_chord <= super::compose::TOLERANCE_PX * 1.01,
            "edge {k}: the rim is {off_chord} px off the chord"
        );
    }
    assert!(
        (turned - 2.0 * PI).abs() < 1e-9,
        "the polygon turns {turned} rad"
    );
}

/// With no white margin, the pixels along the black square's outer edge hold exactly the area
/// mix of ink and disc. Before the paper outline moved into the border ring, the paper under the
/// ink showed through the ink's partial coverage c and made them c·(1 − c)·(paper − disc) too
/// bright (13–17 DN at the seed's levels).
#[test]
fn marker_without_margin_has_exact_edge_coverage_on_a_grey_disc() {
    use crate::render::frame::render_linear;
    use crate::render::{EffectsConfig, FrameRequest, PixelRect, RenderSettings};
    let mut cfg = SceneConfig::default();
    cfg.marker.white_margin_mm = 0.0;
    cfg.disc_radiance = 0.55;
    // Shifted by 0.3 px so that every edge cuts its pixels between 20 % and 80 %.
    let scene = Scene::new(&cfg, camera_at([1919.5, 1079.8])).unwrap();
    let c = scene.marker_corners_px_at(&pose(0.0));
    let (xl, xr, yt, yb) = (c[0][0], c[1][0], c[0][1], c[2][1]);
    assert!(
        c[0][1] == c[1][1] && c[0][0] == c[3][0],
        "upright square {c:?}"
    );
    let settings = RenderSettings {
        width_px: 3840,
        height_px: 2160,
        effects: EffectsConfig::none(),
        seed: 1,
    };
    let (x0, y0) = (xl.floor() as i64 - 3, yt.floor() as i64 - 3);
    let rect = PixelRect::new(x0, y0, (xr - xl) as usize + 8, (yb - yt) as usize + 8);
    let animated = scene.clone().animate(|_| pose(0.0));
    let frame = FrameRequest {
        index: 0,
        t_s: 0.0,
        window: rect,
    };
    let img = render_linear(&animated, &settings, &frame, &rect);
    let at = |x: i64, y: i64| img.data[((y - y0) as usize) * rect.width + (x - x0) as usize] as f64;
    let (disc, ink) = (cfg.disc_radiance, cfg.ink_radiance);
    let expected = |coverage: f64| disc * (1.0 - coverage) + ink * coverage;
    // Ink coverage of the pixel holding each edge (pixel i spans [i − 0.5, i + 0.5]).
    let (il, ir, jt, jb) = (
        xl.round() as i64,
        xr.round() as i64,
        yt.round() as i64,
        yb.round() as i64,
    );
    let cov_l = il as f64 + 0.5 - xl;
    let cov_r = xr - (ir as f64 - 0.5);
    let cov_t = jt as f64 + 0.5 - yt;
    let cov_b = yb - (jb as f64 - 0.5);
    for cov in [cov_l, cov_r, cov_t, cov_b] {
        assert!((0.2..=0.8).contains(&cov), "edge coverage {cov}");
    }
    let mut worst: f64 = 0.0;
    for y in jt + 2..=jb - 2 {
        worst = worst.max((at(il, y) - expected(cov_l)).abs());
        worst = worst.max((at(ir, y) - expected(cov_r)).abs());
        // Fully outside and fully inside the square.
        worst = worst.max((at(il - 1, y) - disc).abs());
        worst = worst.max((at(il + 1, y) - ink).abs());
    }
    for x in il + 2..=ir - 2 {
        worst = worst.max((at(x, jt) - expected(cov_t)).abs());
        worst = worst.max((at(x, jb) - expected(cov_b)).abs());
    }
    assert!(
        worst < 1e-5,
        "largest departure from the exact coverage mix: {worst}"
    );
}
