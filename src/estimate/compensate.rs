//! Camera-motion compensation: a static reference marker's apparent motion is camera motion, so
//! the inverse of that motion (relative to the reference's first detected frame) is applied to the
//! moving marker's corners frame by frame. Frames where the reference is missing are dropped
//! (returned as `None`) rather than left uncompensated.

use super::config::ReferenceCompensation;
use super::marker_centre::corner_mean;

type Corners = [[f64; 2]; 4];

/// Compensated corner tracks and the number of moving-marker frames lost because the reference
/// was not detected in them.
pub fn compensate(
    corners: &[Option<Corners>],
    reference: &[Option<Corners>],
    mode: ReferenceCompensation,
) -> (Vec<Option<Corners>>, usize) {
    let Some(anchor) = reference.iter().flatten().next().copied() else {
        return (corners.to_vec(), 0);
    };
    if mode == ReferenceCompensation::Off {
        return (corners.to_vec(), 0);
    }
    let mut lost = 0;
    let out = corners
        .iter()
        .zip(reference)
        .map(|(c, r)| match (c, r) {
            (Some(c), Some(r)) => {
                let (rot, shift) = match mode {
                    ReferenceCompensation::Rigid => rigid_to(r, &anchor),
                    _ => {
                        let a = corner_mean(&anchor);
                        let b = corner_mean(r);
                        ([[1.0, 0.0], [0.0, 1.0]], [a[0] - b[0], a[1] - b[1]])
                    }
                };
                Some(c.map(|p| {
                    [
                        rot[0][0] * p[0] + rot[0][1] * p[1] + shift[0],
                        rot[1][0] * p[0] + rot[1][1] * p[1] + shift[1],
                    ]
                }))
            }
            (Some(_), None) => {
                lost += 1;
                None
            }
            _ => None,
        })
        .collect();
    (out, lost)
}

/// Least-squares rotation R and shift t with R·src + t ≈ dst (2-D Procrustes, closed form).
pub fn rigid_to(src: &Corners, dst: &Corners) -> ([[f64; 2]; 2], [f64; 2]) {
    let ms = corner_mean(src);
    let md = corner_mean(dst);
    let (mut sdot, mut scross) = (0.0, 0.0);
    for (p, q) in src.iter().zip(dst) {
        let a = [p[0] - ms[0], p[1] - ms[1]];
        let b = [q[0] - md[0], q[1] - md[1]];
        sdot += a[0] * b[0] + a[1] * b[1];
        scross += a[0] * b[1] - a[1] * b[0];
    }
    let phi = scross.atan2(sdot);
    let (s, c) = phi.sin_cos();
    let rot = [[c, -s], [s, c]];
    let shift = [
        md[0] - (c * ms[0] - s * ms[1]),
        md[1] - (s * ms[0] + c * ms[1]),
    ];
    (rot, shift)
}
