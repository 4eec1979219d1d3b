//! Whether layers nest across an exposure: every pixel a later layer touches in any sample is
//! fully covered by the earlier layer in every sample (the ink of a marker inside its paper,
//! the paper inside the disc). Then the exposure average of their "over" composite equals the
//! composite of their mean coverages (see [`super::exposure`]).
//!
//! The test is geometric and conservative: the earlier layer must be one convex polygon in
//! every sample, and every vertex of the later layer (all samples) must lie at least √2 px
//! (a pixel diagonal) plus a rounding allowance inside every one of those polygons. A pixel
//! the later layer touches contains a point of the convex hull of those vertices, so all of
//! it lies inside the earlier polygon, whose exact coverage there is then exactly 1.

use super::RigidTransform;
use crate::render::shapes::{Polygon, SceneSnapshot};
use glam::DVec2;

/// Depth a vertex must have inside the outer polygon: a pixel diagonal, plus room for the
/// rasteriser's 2⁻¹⁶ px vertex grid and interpolation rounding.
const DEPTH_PX: f64 = std::f64::consts::SQRT_2 + 1e-3;

/// Whether each layer of `layers` (indices into every sample's layer list, in compositing
/// order) nests inside the one before it over all `samples`, each seen through its optional
/// image transform.
pub(super) fn layers_nest(
    samples: &[SceneSnapshot],
    transforms: &[Option<RigidTransform>],
    layers: &[usize],
) -> bool {
    if samples.len() != transforms.len() {
        return false;
    }
    let vertices = |s: usize, j: usize| -> Option<Vec<Vec<DVec2>>> {
        let layer = samples[s].layers.get(j)?;
        Some(
            layer
                .polygons
                .iter()
                .map(|p| transformed(p, transforms[s].as_ref()))
                .collect(),
        )
    };
    // What a later layer must nest in: a uniform layer's polygon; a textured layer's uniform
    // core (the marker's paper, where its value is one constant), none without one.
    let holder = |s: usize, j: usize| -> Option<Vec<Vec<DVec2>>> {
        let layer = samples[s].layers.get(j)?;
        match &layer.texture {
            None => vertices(s, j),
            Some(t) => t
                .core_px
                .as_ref()
                .map(|p| vec![transformed(p, transforms[s].as_ref())]),
        }
    };
    for pair in layers.windows(2) {
        let (outer, inner) = (pair[0], pair[1]);
        let mut inner_points = Vec::new();
        for s in 0..samples.len() {
            let Some(polys) = vertices(s, inner) else {
                return false;
            };
            inner_points.extend(polys.into_iter().flatten());
        }
        if inner_points.is_empty() {
            continue;
        }
        if inner_points.iter().any(|p| !p.is_finite()) {
            return false;
        }
        let hull = convex_hull(inner_points);
        for s in 0..samples.len() {
            let Some(polys) = holder(s, outer) else {
                return false;
            };
            let [outer_polygon] = polys.as_slice() else {
                return false;
            };
            let Some(planes) = convex_half_planes(outer_polygon) else {
                return false;
            };
            let deep = hull
                .iter()
                .all(|&p| planes.iter().all(|&(n, d)| n.dot(p) - d >= DEPTH_PX));
            if !deep {
                return false;
            }
        }
    }
    true
}

fn transformed(p: &Polygon, t: Option<&RigidTransform>) -> Vec<DVec2> {
    p.vertices_px
        .iter()
        .map(|&v| t.map_or(v, |t| t.apply(v)))
        .collect()
}

/// Inward unit normals `n` and offsets `d` (inside: n·p − d > 0) of a convex, simple polygon
/// with non-zero area; `None` for anything else (non-convex, self-intersecting, degenerate).
fn convex_half_planes(v: &[DVec2]) -> Option<Vec<(DVec2, f64)>> {
    if v.len() < 3 || v.iter().any(|p| !p.is_finite()) {
        return None;
    }
    let n = v.len();
    let twice_area: f64 = (0..n).map(|i| v[i].perp_dot(v[(i + 1) % n])).sum();
    if twice_area == 0.0 {
        return None;
    }
    let orientation = twice_area.signum();
    // Every turn the same way (collinear allowed) and the area of the hull: convex and simple
    // (a star polygon turns consistently but its area differs from its hull's).
    for i in 0..n {
        let (a, b, c) = (v[i], v[(i + 1) % n], v[(i + 2) % n]);
        if (b - a).perp_dot(c - b) * orientation < 0.0 {
            return None;
        }
    }
    let hull = convex_hull(v.to_vec());
    let m = hull.len();
    let hull_twice_area: f64 = (0..m).map(|i| hull[i].perp_dot(hull[(i + 1) % m])).sum();
    if (hull_twice_area.abs() - twice_area.abs()).abs() > 1e-9 * hull_twice_area.abs() {
        return None;
    }
    // The hull is counter-clockwise in the maths sense; its interior is left of each edge.
    Some(
        (0..m)
            .filter_map(|i| {
                let (a, b) = (hull[i], hull[(i + 1) % m]);
                let e = b - a;
                let len = e.length();
                (len > 0.0).then(|| {
                    let normal = DVec2::new(-e.y, e.x) / len;
                    (normal, normal.dot(a))
                })
            })
            .collect(),
    )
}

/// Convex hull (Andrew's monotone chain), counter-clockwise in the maths sense (x right,
/// y up), without collinear points.
fn convex_hull(mut points: Vec<DVec2>) -> Vec<DVec2> {
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let mut hull: Vec<DVec2> = Vec::with_capacity(2 * points.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(points.iter())
        } else {
            Box::new(points.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2 {
                let (a, b) = (hull[hull.len() - 2], hull[hull.len() - 1]);
                if (b - a).perp_dot(p - b) <= 0.0 {
                    hull.pop();
                } else {
                    break;
                }
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::shapes::Layer;

    fn square(cx: f64, cy: f64, half: f64, angle: f64) -> Polygon {
        crate::render::test_scenes::rotated_square(DVec2::new(cx, cy), 2.0 * half, angle)
    }

    fn scene(paper: Polygon, ink: Vec<Polygon>) -> SceneSnapshot {
        SceneSnapshot {
            background: None,
            background_radiance: 0.2,
            layers: vec![
                Layer {
                    texture: None,
                    radiance: 0.9,
                    polygons: vec![paper],
                },
                Layer {
                    texture: None,
                    radiance: 0.1,
                    polygons: ink,
                },
            ],
        }
    }

    #[test]
    fn hull_drops_interior_and_collinear_points() {
        let pts = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(2.0, 2.0),
            DVec2::new(0.0, 2.0),
            DVec2::new(1.0, 1.0),
        ];
        let h = convex_hull(pts);
        assert_eq!(h.len(), 4);
        assert!(!h.contains(&DVec2::new(1.0, 1.0)));
    }

    #[test]
    fn half_planes_refuse_non_convex_and_star_polygons() {
        assert!(convex_half_planes(&square(0.0, 0.0, 5.0, 0.3).vertices_px).is_some());
        let dart = [
            DVec2::new(0.0, 0.0),
            DVec2::new(4.0, 2.0),
            DVec2::new(0.0, 4.0),
            DVec2::new(1.0, 2.0),
        ];
        assert!(convex_half_planes(&dart).is_none());
        let star: Vec<DVec2> = (0..5)
            .map(|i| {
                let a = i as f64 * 4.0 * std::f64::consts::PI / 5.0;
                DVec2::new(a.cos(), a.sin()) * 10.0
            })
            .collect();
        assert!(convex_half_planes(&star).is_none());
    }

    #[test]
    fn ink_deep_inside_moving_paper_nests_and_near_the_edge_does_not() {
        let samples: Vec<SceneSnapshot> = (0..5)
            .map(|i| {
                let x = 50.0 + 0.3 * i as f64;
                scene(
                    square(x, 40.0, 20.0, 0.1),
                    vec![square(x, 40.0, 12.0, 0.1), square(x + 2.0, 41.0, 3.0, 0.1)],
                )
            })
            .collect();
        let none = vec![None; samples.len()];
        assert!(layers_nest(&samples, &none, &[0, 1]));
        // Ink reaching to within one pixel of the paper edge: a pixel there is only partly
        // covered by paper.
        let close: Vec<SceneSnapshot> = (0..5)
            .map(|i| {
                let x = 50.0 + 0.3 * i as f64;
                scene(square(x, 40.0, 20.0, 0.0), vec![square(x, 40.0, 19.0, 0.0)])
            })
            .collect();
        assert!(!layers_nest(&close, &none, &[0, 1]));
        // Paper moving so far that the first sample's ink leaves the last sample's paper.
        let far: Vec<SceneSnapshot> = (0..5)
            .map(|i| {
                let x = 50.0 + 3.0 * i as f64;
                scene(square(x, 40.0, 20.0, 0.0), vec![square(x, 40.0, 12.0, 0.0)])
            })
            .collect();
        assert!(!layers_nest(&far, &none, &[0, 1]));
        // A transform (camera vibration) moves the vertices too: a static scene shaken by
        // 3 px per sample no longer nests.
        let still: Vec<SceneSnapshot> = (0..5)
            .map(|_| {
                scene(
                    square(50.0, 40.0, 20.0, 0.0),
                    vec![square(50.0, 40.0, 12.0, 0.0)],
                )
            })
            .collect();
        let shaken: Vec<Option<RigidTransform>> = (0..5)
            .map(|i| {
                Some(RigidTransform {
                    centre_px: DVec2::ZERO,
                    rotation_rad: 0.0,
                    translation_px: DVec2::new(3.0 * i as f64, 0.0),
                })
            })
            .collect();
        assert!(layers_nest(&still, &none, &[0, 1]));
        assert!(!layers_nest(&still, &shaken, &[0, 1]));
    }
}
