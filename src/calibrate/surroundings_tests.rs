use super::*;
use crate::render::texture::radiance_of;
use glam::{DMat3, DVec3};

/// Metres per pixel of the test camera, and its principal point.
const M_PER_PX: f64 = 0.5e-3;
const PP: DVec2 = DVec2::new(200.0, 200.0);
const RADIUS_M: f64 = 0.13;

/// A camera 0.3 m in front of the wheel's plane, looking straight at it, the wheel turned by
/// `theta`: wheel point p (m) → pixel PP + R(θ)·p / M_PER_PX.
fn wheel_map(theta: f64) -> PlaneMap {
    let (s, c) = theta.sin_cos();
    let (ex, ey) = (DVec3::X, DVec3::Y);
    PlaneMap {
        plane_to_camera: DMat3::from_cols(
            ex * c + ey * s,
            -ex * s + ey * c,
            DVec3::new(0.0, 0.0, 0.3),
        ),
        lens: None,
        focal_px: 0.3 / M_PER_PX,
        principal_point_px: PP,
        transform: None,
    }
}

const ANCHORS: LevelAnchors = LevelAnchors::BYTE_SCALE;

/// The disc's true grey level at wheel point p, DN: a smooth pattern of 20 px periods.
fn disc_dn(p: DVec2) -> f64 {
    let tau = std::f64::consts::TAU;
    110.0 + 40.0 * (tau * p.x / 0.010).sin() * (tau * p.y / 0.013).cos()
}

/// The marker's paper, a 40 mm square centred 100 mm out along the wheel's +x.
fn paper() -> [DVec2; 4] {
    [(0.08, -0.02), (0.12, -0.02), (0.12, 0.02), (0.08, 0.02)].map(|(x, y)| DVec2::new(x, y))
}

/// A crop of `side` px centred on the marker at wheel angle `theta`, drawn exactly (no blur):
/// the paper at 230 DN, the disc's pattern, 20 DN beyond the rim, all × `gain`.
fn crop(theta: f64, side: usize, gain: f64) -> (Vec<u8>, (i32, i32)) {
    let map = wheel_map(theta);
    let centre = map.to_image(DVec2::new(0.1, 0.0));
    let origin = (
        (centre.x - side as f64 / 2.0).round() as i32,
        (centre.y - side as f64 / 2.0).round() as i32,
    );
    let q = paper();
    let data = (0..side * side)
        .map(|k| {
            let px = DVec2::new(
                (origin.0 + (k % side) as i32) as f64,
                (origin.1 + (k / side) as i32) as f64,
            );
            let p = map.to_plane(px).unwrap();
            let dn = if p.length() > RADIUS_M {
                20.0
            } else if distance_to_quad(p, &q) == 0.0 {
                230.0
            } else {
                disc_dn(p)
            };
            (gain * dn).round().clamp(0.0, 255.0) as u8
        })
        .collect();
    (data, origin)
}

fn view<'a>(
    data: &'a [u8],
    origin: (i32, i32),
    side: usize,
    theta: f64,
    gain: f64,
) -> PlaneView<'a> {
    PlaneView {
        image: GrayView {
            data,
            width: side,
            height: side,
            origin_px: origin,
        },
        wheel_map: wheel_map(theta),
        light_gain: gain,
    }
}

const GEOMETRY: DiscGeometry = DiscGeometry {
    radius_m: RADIUS_M,
    paper_m: [
        DVec2::new(0.08, -0.02),
        DVec2::new(0.12, -0.02),
        DVec2::new(0.12, 0.02),
        DVec2::new(0.08, 0.02),
    ],
    m_per_px: M_PER_PX,
};

/// The disc texture of two frames of the wheel at rest (turned by 90° between them, the second
/// under 10 % more light) holds the disc's pattern in the wheel's frame around the marker to
/// within the bilinear sample's error (a sine of 20 px period: about 0.5 DN at most), the
/// frames' rounding and the texture's own rounding to whole grey levels (0.5 DN at most each);
/// texels far from the marker, which no frame shows, keep the uniform level.
#[test]
fn the_disc_texture_holds_the_disc_in_the_wheel_frame_around_the_marker() {
    let side = 160;
    let (a, oa) = crop(0.0, side, 1.0);
    let (b, ob) = crop(std::f64::consts::FRAC_PI_2, side, 1.1);
    let views = [
        view(&a, oa, side, 0.0, 1.0),
        view(&b, ob, side, std::f64::consts::FRAC_PI_2, 1.1),
    ];
    let uniform = 0.3;
    let d = disc_texture(&views, &GEOMETRY, 0.5, &ANCHORS, uniform).unwrap();
    let t = &d.mosaic.texture;
    assert_eq!(d.mosaic.frames, 2);
    assert_eq!(t.width, t.height);
    assert!(
        (d.texel_m - PX_PER_DISC_TEXEL * M_PER_PX).abs() < 1e-6,
        "{}",
        d.texel_m
    );
    let [cu, cv] = d.centre_texel;
    let at = |p: DVec2| {
        let (i, j) = (
            (p.x / d.texel_m + cu).round(),
            (p.y / d.texel_m + cv).round(),
        );
        let p = DVec2::new((i - cu) * d.texel_m, (j - cv) * d.texel_m);
        let v = t.get(i as i64, j as i64)?;
        Some((p, radiance_of(v) as f64 * 255.0))
    };
    let (mut worst, mut sum, mut n) = (0.0f64, 0.0, 0);
    for k in 0..4000 {
        // Points 5–15 mm outside the paper, all round it.
        let a = k as f64 * 0.0157;
        let r = 0.025 + 0.010 * ((k * 7919) % 100) as f64 / 100.0;
        let Some((p, got)) = at(DVec2::new(0.1, 0.0) + r * DVec2::new(a.cos(), a.sin())) else {
            continue;
        };
        if distance_to_quad(p, &GEOMETRY.paper_m) < 0.005 || p.length() > RADIUS_M - 0.004 {
            continue;
        }
        let e = (got - disc_dn(p)).abs();
        worst = worst.max(e);
        sum += e;
        n += 1;
    }
    assert!(n > 1000, "{n}");
    let mean = sum / n as f64;
    assert!(worst < 1.5 && mean < 0.5, "worst {worst}, mean {mean}");
    let (_, far) = at(DVec2::new(-0.1, 0.0)).unwrap();
    assert!((far - uniform * 255.0).abs() < 0.01, "{far}");
    assert!(d.mosaic.sampled_texels > 1200 && d.mosaic.filled_texels > 0);
    assert!(
        (d.mosaic.frames_per_texel - 2.0).abs() < 0.2,
        "{}",
        d.mosaic.frames_per_texel
    );
    assert!(d.mosaic.spread_dn > 20.0, "{}", d.mosaic.spread_dn);
}

/// The background texture takes the pixels beyond the rim (by the guard band) from the frames,
/// and their mean where no frame shows it (here 20 DN everywhere: what lies beyond the rim).
#[test]
fn the_background_texture_takes_what_lies_beyond_the_rim() {
    let side = 160;
    let (a, oa) = crop(0.0, side, 1.0);
    let views = [view(&a, oa, side, 0.0, 1.0)];
    let m = background_texture(&views, RADIUS_M, M_PER_PX, (600, 400), 0.5, &ANCHORS).unwrap();
    let t = &m.texture;
    assert_eq!((t.width, t.height), (600, 400));
    let dn = |x: i64, y: i64| radiance_of(t.get(x, y).unwrap()) as f64 * 255.0;
    let map = wheel_map(0.0);
    let (mut beyond, mut far) = (0, 0);
    for y in oa.1 as i64..oa.1 as i64 + side as i64 {
        for x in oa.0 as i64..oa.0 as i64 + side as i64 {
            let p = map.to_plane(DVec2::new(x as f64, y as f64)).unwrap();
            if p.length() > RADIUS_M + 4.0 * M_PER_PX {
                assert!((dn(x, y) - 20.0).abs() < 0.01, "({x}, {y}): {}", dn(x, y));
                beyond += 1;
            }
        }
    }
    assert!(beyond > 500, "{beyond}");
    for (x, y) in [(0, 0), (5, 390), (100, 20)] {
        far += 1;
        assert!((dn(x, y) - 20.0).abs() < 0.01, "({x}, {y}): {}", dn(x, y));
    }
    assert_eq!(far, 3);
    assert_eq!(m.frames, 1);
    assert!(m.spread_dn < 0.01, "{}", m.spread_dn);
}

/// A marker whose paper fills every frame leaves no disc to sample, and says so.
#[test]
fn a_view_without_disc_gives_an_error_not_a_texture() {
    let side = 8;
    let (a, oa) = crop(0.0, side, 1.0);
    let views = [view(&a, oa, side, 0.0, 1.0)];
    assert!(matches!(
        disc_texture(&views, &GEOMETRY, 0.5, &ANCHORS, 0.3),
        Err(SurroundError::NothingSampled { .. })
    ));
    assert_eq!(
        disc_texture(&[], &GEOMETRY, 0.5, &ANCHORS, 0.3).unwrap_err(),
        SurroundError::NoViews
    );
}
