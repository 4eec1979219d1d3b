//! Turning world curves into image polygons that follow the projected curve within a pixel
//! tolerance (needed under lens distortion, where straight edges image as curves).

use glam::{DVec2, DVec3};

use crate::camera::Camera;

/// Largest distance of the projected curve from its chords, sampled at 1/4, 1/2 and 3/4 of
/// each of `n` uniform segments of the world curve `f(s)`, s ∈ [s0, s1].
fn max_chord_error_px(cam: &Camera, f: &dyn Fn(f64) -> DVec3, s0: f64, s1: f64, n: usize) -> f64 {
    let mut worst: f64 = 0.0;
    let ds = (s1 - s0) / n as f64;
    for i in 0..n {
        let a = s0 + ds * i as f64;
        let pa = cam.project(f(a));
        let pb = cam.project(f(a + ds));
        for q in [0.25, 0.5, 0.75] {
            let p = cam.project(f(a + q * ds));
            worst = worst.max(distance_to_segment(p, pa, pb));
        }
    }
    worst
}

fn distance_to_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + t * ab)).length()
}

/// The smallest uniform subdivision count (starting at `n0`, at most `max_n`) for which the
/// projected curve stays within `tol_px` of its chords.
pub fn subdivisions(
    cam: &Camera,
    f: &dyn Fn(f64) -> DVec3,
    s0: f64,
    s1: f64,
    n0: usize,
    tol_px: f64,
    max_n: usize,
) -> usize {
    let mut n = n0.max(1);
    loop {
        let err = max_chord_error_px(cam, f, s0, s1, n);
        if err <= tol_px || n >= max_n {
            return n;
        }
        // Chord error falls as 1/n² for smooth curves.
        let grow = ((err / tol_px).sqrt() * 1.05 * n as f64).ceil() as usize;
        n = grow.max(n + 1).min(max_n);
    }
}

/// A closed polygon through the projections of `corners` (world, in order), each edge
/// subdivided uniformly so it follows its curved image within `tol_px`.
pub fn projected_quad(
    cam: &Camera,
    corners: &[DVec3; 4],
    tol_px: f64,
    distorted: bool,
) -> Vec<DVec2> {
    let mut out = Vec::new();
    for i in 0..4 {
        let a = corners[i];
        let b = corners[(i + 1) % 4];
        let n = if distorted {
            let edge = move |s: f64| a + s * (b - a);
            subdivisions(cam, &edge, 0.0, 1.0, 1, tol_px, 4096)
        } else {
            1
        };
        for k in 0..n {
            out.push(cam.project(a + (k as f64 / n as f64) * (b - a)));
        }
    }
    out
}
