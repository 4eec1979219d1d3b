//! The textured layer against an independent reference: every piece (texel ∩ disc ∖ paper,
//! the paper, the paper's texels) clipped against every pixel square in floating point, areas
//! by the shoelace formula.

use super::*;
use crate::render::raster::{textured_layer_values, PixelRect};
use crate::render::shapes::{Layer, Polygon};
use glam::{DMat3, DVec2, DVec3};
use rand::Rng;

/// A pinhole looking at the plane from 1 m with a focal length of 1000 px (1 mm ≈ 1 px),
/// tilted by `tilt` rad, the plane turned by `turn` rad.
fn map(tilt: f64, turn: f64) -> PlaneMap {
    let r = DMat3::from_rotation_x(tilt).transpose();
    let (s, c) = turn.sin_cos();
    let rot = DMat3::from_cols(
        DVec3::new(c, s, 0.0),
        DVec3::new(-s, c, 0.0),
        DVec3::new(0.0003, -0.0002, 1.0),
    );
    PlaneMap {
        plane_to_camera: DMat3::from_cols(r.x_axis, r.y_axis, DVec3::new(0.0, 0.0, 1.0)) * rot,
        lens: None,
        focal_px: 1000.0,
        principal_point_px: DVec2::new(40.3, 35.6),
        transform: None,
    }
}

fn random_texture(w: usize, h: usize, seed: u64) -> Arc<Texture> {
    let mut rng = crate::rng::stream(seed, crate::rng::Stream::MonteCarlo, 11);
    Arc::new(Texture {
        width: w,
        height: h,
        values: (0..w * h).map(|_| rng.gen()).collect(),
    })
}

/// The disc grid (1 mm texels, 48×48, centred on the wheel) and a paper square of side 10 mm
/// at `paper_at` turned by `paper_turn`; `paper_grid`: the paper holds a 10×10 texture.
fn mesh(paper_at: DVec2, paper_turn: f64, paper_grid: bool) -> TextureMesh {
    let mm = 1e-3;
    let disc = GridSpec {
        texture: random_texture(48, 48, 1),
        origin: DVec2::new(-24.0, -24.0) * mm,
        step_u: DVec2::new(mm, 0.0),
        step_v: DVec2::new(0.0, mm),
    };
    let (s, c) = paper_turn.sin_cos();
    let (u, v) = (DVec2::new(c, s), DVec2::new(-s, c));
    let half = 5.0 * mm;
    let centre = paper_at * mm;
    let paper = [
        centre - half * u - half * v,
        centre + half * u - half * v,
        centre + half * u + half * v,
        centre - half * u + half * v,
    ];
    let inner = if paper_grid {
        LayerContent::Grid(GridSpec {
            texture: random_texture(10, 10, 2),
            origin: paper[0],
            step_u: u * mm,
            step_v: v * mm,
        })
    } else {
        LayerContent::Uniform(51234)
    };
    TextureMesh::new(20.0 * mm, 64, paper, LayerContent::Grid(disc), inner).unwrap()
}

fn layer(mesh: &Arc<TextureMesh>, map: &PlaneMap) -> Layer {
    Layer {
        radiance: 0.0,
        polygons: vec![Polygon {
            vertices_px: mesh
                .outline_plane()
                .iter()
                .map(|&p| map.to_image(p))
                .collect(),
        }],
        texture: Some(TexturedFill {
            mesh: Arc::clone(mesh),
            map: map.clone(),
            core_px: None,
            paper_level: None,
        }),
    }
}

fn area(poly: &[DVec2]) -> f64 {
    let n = poly.len();
    if n < 3 {
        return 0.0;
    }
    0.5 * (0..n)
        .map(|i| poly[i].perp_dot(poly[(i + 1) % n]))
        .sum::<f64>()
        .abs()
}

/// `subject` clipped by the convex polygon `clip` (Sutherland–Hodgman).
fn clip(subject: &[DVec2], clip: &[DVec2]) -> Vec<DVec2> {
    let orientation = area_signed(clip).signum();
    let mut out = subject.to_vec();
    for i in 0..clip.len() {
        let (a, b) = (clip[i], clip[(i + 1) % clip.len()]);
        let side = |p: DVec2| orientation * (b - a).perp_dot(p - a);
        let input = std::mem::take(&mut out);
        for j in 0..input.len() {
            let (p, q) = (input[j], input[(j + 1) % input.len()]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                out.push(p + (q - p) * (sp / (sp - sq)));
            }
        }
        if out.is_empty() {
            break;
        }
    }
    out
}

fn area_signed(poly: &[DVec2]) -> f64 {
    let n = poly.len();
    0.5 * (0..n)
        .map(|i| poly[i].perp_dot(poly[(i + 1) % n]))
        .sum::<f64>()
}

/// Coverage and radiance of pixel (x, y) by the reference.
fn reference(mesh: &TextureMesh, map: &PlaneMap, x: i64, y: i64) -> (f64, f64) {
    let px = [
        DVec2::new(x as f64 - 0.5, y as f64 - 0.5),
        DVec2::new(x as f64 + 0.5, y as f64 - 0.5),
        DVec2::new(x as f64 + 0.5, y as f64 + 0.5),
        DVec2::new(x as f64 - 0.5, y as f64 + 0.5),
    ];
    let disc: Vec<DVec2> = mesh
        .outline_plane()
        .iter()
        .map(|&p| map.to_image(p))
        .collect();
    let paper: Vec<DVec2> = mesh
        .paper_plane()
        .iter()
        .map(|&p| map.to_image(p))
        .collect();
    let in_disc = clip(&px, &disc);
    let cov = area(&in_disc);
    let mut rad = 0.0;
    for (g, grid) in mesh.grids.iter().enumerate() {
        let spec = &grid.spec;
        let t = &spec.texture;
        for j in 0..t.height {
            for i in 0..t.width {
                let q: Vec<DVec2> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                    .iter()
                    .map(|&(a, b)| map.to_image(spec.plane_at(i as f64 + a, j as f64 + b)))
                    .collect();
                let here = clip(&in_disc, &q);
                if here.len() < 3 {
                    continue;
                }
                let a = if g == 0 {
                    area(&here) - area(&clip(&here, &paper))
                } else {
                    area(&here)
                };
                rad += a * t.values[j * t.width + i] as f64;
            }
        }
    }
    if let Some(r) = mesh.paper_radiance() {
        rad += area(&clip(&in_disc, &paper)) * (r as f64 * RADIANCE_UNITS as f64).round();
    }
    (cov, rad / RADIANCE_UNITS as f64)
}

#[test]
fn the_textured_layer_is_the_exact_area_mean_of_its_pieces() {
    let cases = [
        (DVec2::new(7.3, -3.1), 0.31, false, 0.0, 0.2),
        (DVec2::new(-6.2, 4.4), -0.72, true, 0.15, -0.4),
        // The paper's edges on the disc grid's lines.
        (DVec2::new(4.0, 3.0), 0.0, false, 0.0, 0.0),
        (DVec2::new(4.0, 3.0), 0.0, true, 0.1, 0.0),
    ];
    for (at, turn, grid, tilt, plane_turn) in cases {
        let mesh = Arc::new(mesh(at, turn, grid));
        let m = map(tilt, plane_turn);
        let l = layer(&mesh, &m);
        let window = PixelRect::new(12, 6, 58, 60);
        let (cov, rad) = textured_layer_values(&l, &window).unwrap();
        let mut worst: (f64, f64) = (0.0, 0.0);
        for y in window.y0..window.y1() {
            for x in window.x0..window.x1() {
                let i = window.index(x, y).unwrap();
                let (c, r) = reference(&mesh, &m, x, y);
                worst.0 = worst.0.max((cov[i] as f64 - c).abs());
                worst.1 = worst.1.max((rad[i] as f64 - r).abs());
            }
        }
        // Vertices snap to 2⁻¹⁶ px: an area is off by at most that times the pixel's edge
        // length (a few pixels of edges in a pixel), in f32.
        assert!(
            worst.0 < 1e-4 && worst.1 < 1e-4,
            "paper at {at} turned {turn}, grid {grid}, tilt {tilt}: worst {worst:?}"
        );
        // Any window gives the bits of the large one.
        for sub in [
            PixelRect::new(30, 20, 7, 9),
            PixelRect::new(12, 40, 58, 3),
            PixelRect::new(50, 6, 20, 60),
        ] {
            let (c2, r2) = textured_layer_values(&l, &sub).unwrap();
            for y in sub.y0..sub.y1() {
                for x in sub.x0..sub.x1() {
                    let (a, b) = (window.index(x, y).unwrap(), sub.index(x, y).unwrap());
                    assert_eq!(cov[a].to_bits(), c2[b].to_bits(), "({x}, {y})");
                    assert_eq!(rad[a].to_bits(), r2[b].to_bits(), "({x}, {y})");
                }
            }
        }
    }
}

#[test]
fn a_texture_that_does_not_cover_the_disc_is_refused() {
    let mm = 1e-3;
    let small = GridSpec {
        texture: random_texture(30, 30, 1),
        origin: DVec2::new(-15.0, -15.0) * mm,
        step_u: DVec2::new(mm, 0.0),
        step_v: DVec2::new(0.0, mm),
    };
    let paper = [
        DVec2::new(0.0, 0.0),
        DVec2::new(mm, 0.0),
        DVec2::new(mm, mm),
        DVec2::new(0.0, mm),
    ];
    let e = TextureMesh::new(
        20.0 * mm,
        64,
        paper,
        LayerContent::Grid(small),
        LayerContent::Uniform(1),
    )
    .unwrap_err();
    assert!(matches!(e, MeshError::TextureTooSmall { .. }), "{e}");
}
