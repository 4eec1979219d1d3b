//! Hand-built snapshots and scenes for the renderer's tests and benchmark: squares,
//! half-planes, rotated rectangles and a fake ArUco-like marker, optionally moving.

use super::shapes::{Layer, Polygon, SceneAt, SceneSnapshot};
use glam::DVec2;

/// Axis-aligned rectangle [x0, x1] × [y0, y1] (pixels), clockwise on screen.
pub fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Polygon {
    Polygon {
        vertices_px: vec![
            DVec2::new(x0, y0),
            DVec2::new(x1, y0),
            DVec2::new(x1, y1),
            DVec2::new(x0, y1),
        ],
    }
}

/// Square of side `side_px` centred at `centre_px`, rotated by `angle_rad`.
pub fn rotated_square(centre_px: DVec2, side_px: f64, angle_rad: f64) -> Polygon {
    let h = side_px / 2.0;
    let (s, c) = angle_rad.sin_cos();
    let corners = [(-h, -h), (h, -h), (h, h), (-h, h)];
    Polygon {
        vertices_px: corners
            .iter()
            .map(|&(x, y)| centre_px + DVec2::new(c * x - s * y, s * x + c * y))
            .collect(),
    }
}

/// A huge square whose right edge passes through `point_px` at `angle_rad` from the vertical
/// (a half-plane "left of the edge" for any practical window).
pub fn half_plane_left_of(point_px: DVec2, angle_rad: f64) -> Polygon {
    let side = 1.0e5;
    let normal = DVec2::new(angle_rad.cos(), angle_rad.sin());
    rotated_square(point_px - normal * (side / 2.0), side, angle_rad)
}

pub fn single_layer(polygons: Vec<Polygon>, radiance: f32, background: f32) -> SceneSnapshot {
    SceneSnapshot {
        background: None,
        background_radiance: background,
        layers: vec![Layer {
            radiance,
            polygons,
            texture: None,
        }],
    }
}

/// A fake ArUco-like marker: white quiet zone, black square, and a pseudo-random 6×6 pattern
/// of white cells (adjacent cells share edges inside one layer).
pub fn marker_snapshot(centre_px: DVec2, side_px: f64, angle_rad: f64) -> SceneSnapshot {
    let (s, c) = angle_rad.sin_cos();
    let place = |u: f64, v: f64| centre_px + DVec2::new(c * u - s * v, s * u + c * v) * side_px;
    let quad = |u0: f64, v0: f64, u1: f64, v1: f64| Polygon {
        vertices_px: vec![place(u0, v0), place(u1, v0), place(u1, v1), place(u0, v1)],
    };
    let mut cells = Vec::new();
    let n = 8.0;
    for j in 1..7 {
        for i in 1..7 {
            if (i * 7 + j * 13 + i * j) % 3 == 0 {
                let (u0, v0) = (i as f64 / n - 0.5, j as f64 / n - 0.5);
                cells.push(quad(u0, v0, u0 + 1.0 / n, v0 + 1.0 / n));
            }
        }
    }
    SceneSnapshot {
        background: None,
        background_radiance: 0.5,
        layers: vec![
            Layer {
                texture: None,
                radiance: 0.95,
                polygons: vec![quad(-0.7, -0.7, 0.7, 0.7)],
            },
            Layer {
                texture: None,
                radiance: 0.05,
                polygons: vec![quad(-0.5, -0.5, 0.5, 0.5)],
            },
            Layer {
                texture: None,
                radiance: 0.95,
                polygons: cells,
            },
        ],
    }
}

/// A snapshot translated by `velocity_px_s · t` from its position at t = 0.
pub struct Moving {
    pub base: SceneSnapshot,
    pub velocity_px_s: DVec2,
}

impl SceneAt for Moving {
    fn snapshot(&self, t_s: f64) -> SceneSnapshot {
        let d = self.velocity_px_s * t_s;
        let mut s = self.base.clone();
        for l in &mut s.layers {
            for p in &mut l.polygons {
                for v in &mut p.vertices_px {
                    *v += d;
                }
            }
        }
        s
    }
}

/// A marker rotating about `centre_px` at `rate_rad_s`.
pub struct SpinningMarker {
    pub centre_px: DVec2,
    pub side_px: f64,
    pub rate_rad_s: f64,
}

impl SceneAt for SpinningMarker {
    fn snapshot(&self, t_s: f64) -> SceneSnapshot {
        marker_snapshot(self.centre_px, self.side_px, self.rate_rad_s * t_s)
    }
}
