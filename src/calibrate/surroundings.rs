//! The disc around the marker and the background behind the disc, measured from the footage
//! (pure): the `scene.appearance.disc_file` and `background_file` a calibrated scenario carries.
//!
//! Why: a real rig is no uniform disc before a uniform background. Tape across the marker's
//! margin, print lines, stains, the light's fall-off over the disc, a base plate and whatever
//! stands behind are real and in no effect's vocabulary; drawn uniform they stay in footage −
//! render, where the re-render check finds structure and a diagnosis finds a gap in the levels
//! around the marker.
//!
//! Method. **Disc**: the centres of a texel grid in the wheel's frame (about a texel per pixel)
//! are mapped into every frame where the wheel was at rest, through that frame's wheel map (the
//! calibrated camera at the frame's wheel pose, [`PlaneMap`]: the map the renderer draws a
//! textured disc through), and the footage is sampled there (bilinear) and averaged over the
//! frames with each frame's light gain divided out. A texel within the blur's reach of the
//! marker's paper (which the marker's own texture draws) or of the disc's rim sees both sides
//! mixed; it takes the local mean of the sampled texels near it instead, as do texels the footage
//! never showed next to sampled ones (the mean over ever wider squares); the rest keep the disc's
//! uniform level. **Background**: what the camera sees beyond the disc stays with the camera:
//! each pixel whose ray meets the wheel's plane beyond the rim by the guard band, in any frame,
//! is averaged over the frames that show it; pixels near those take the local mean, the rest the
//! uniform background level.
//!
//! The footage's blur is in the mosaic and the renderer blurs it again: detail of a pixel or two
//! (print lines, a tape's edge) is drawn wider than the footage shows it, by √2 at the blur's σ.

use crate::calibrate::appearance::{bilinear, Integral, LevelAnchors};
use crate::detect::GrayView;
use crate::imagestats::pixel_at;
use crate::render::texture::{value_of, PlaneMap, Texture};
use glam::DVec2;

/// Largest disc texture side, texels: beyond it the texels grow larger.
pub const MAX_DISC_TEXELS: usize = 2048;
/// Pixels per disc texel. The renderer draws a texture exactly, at a cost that grows with the
/// texel edges a window holds: at 2 px a texel the textured disc costs about as much again as a
/// uniform one (at 1 px, about twice as much again), and what it gives up is detail of a pixel
/// or two, which the footage's blur and the render's second blur leave faint anyway.
pub const PX_PER_DISC_TEXEL: f64 = 2.0;
/// How many blur σ from the paper's outline or the rim a texel must lie to be sampled.
const GUARD_SIGMAS: f64 = 3.0;
/// Added to the guard band, px: the bilinear sample's reach and the registration's error.
const GUARD_EXTRA_PX: f64 = 1.5;
/// Fill squares' half-widths in multiples of the guard band's reach (the last covers what a
/// diagnosis window sees beyond the calibration's).
const FILL_STEPS: [usize; 5] = [1, 2, 4, 8, 16];

/// One frame: the footage around the marker, the map from the wheel's frame (metres, the disc
/// centre at the origin) to the image at that frame, and the light's gain on it relative to the
/// anchors' (its levels are brought to the anchors' light before they are averaged).
#[derive(Debug, Clone)]
pub struct PlaneView<'a> {
    pub image: GrayView<'a>,
    pub wheel_map: PlaneMap,
    pub light_gain: f64,
}

/// The disc as the calibrated scenario states it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiscGeometry {
    pub radius_m: f64,
    /// The marker's paper in the wheel's frame, m (the disc is not drawn under it).
    pub paper_m: [DVec2; 4],
    /// The image's scale on the disc, m per px.
    pub m_per_px: f64,
}

/// A texture measured from the footage, and how.
#[derive(Debug, Clone, PartialEq)]
pub struct Mosaic {
    pub texture: Texture,
    /// Frames that contributed a sample.
    pub frames: usize,
    /// Texels sampled from the footage, and texels that took a local mean.
    pub sampled_texels: usize,
    pub filled_texels: usize,
    /// Guard band about the paper's outline and the rim, px.
    pub guard_px: f64,
    /// The sampled texels' mean and spread, DN (the spread holds texture, shading and what the
    /// footage's noise leaves after averaging over the frames).
    pub mean_dn: f64,
    pub spread_dn: f64,
    /// Frames per sampled texel, averaged (the mean's noise is the footage's over √ of it).
    pub frames_per_texel: f64,
}

/// The disc's texture and where its texels lie in the wheel's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct DiscMosaic {
    pub mosaic: Mosaic,
    /// Side of a texel on the disc, m.
    pub texel_m: f64,
    /// The wheel centre's texel (column, row; OpenCV convention).
    pub centre_texel: [f64; 2],
}

/// Why no texture can be measured.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SurroundError {
    #[error("no frame to measure it on")]
    NoViews,
    #[error("the disc's radius or the image's scale is not a positive number")]
    BadGeometry,
    #[error("the footage shows none of it beyond the guard band of {guard_px:.1} px")]
    NothingSampled { guard_px: f64 },
}

fn guard_px(blur_sigma_px: f64) -> f64 {
    GUARD_SIGMAS * blur_sigma_px.max(0.0) + GUARD_EXTRA_PX
}

/// Distance from `p` to the convex quadrilateral `q` (0 inside).
fn distance_to_quad(p: DVec2, q: &[DVec2; 4]) -> f64 {
    let side = |k: usize| (q[(k + 1) % 4] - q[k]).perp_dot(p - q[k]);
    let signs: Vec<f64> = (0..4).map(side).collect();
    if signs.iter().all(|&s| s >= 0.0) || signs.iter().all(|&s| s <= 0.0) {
        return 0.0;
    }
    (0..4)
        .map(|k| {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            let d = b - a;
            let t = ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0);
            (p - (a + t * d)).length()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The box of texel indices that the view's pixels can see through
/// `to_texel` (the plane points of its rim, 16 per side, grown by 2 texels).
fn view_box(view: &PlaneView<'_>, to_texel: impl Fn(DVec2) -> DVec2) -> Option<Rect> {
    let (x0, y0) = (view.image.origin_px.0 as f64, view.image.origin_px.1 as f64);
    let (w, h) = (view.image.width as f64, view.image.height as f64);
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for k in 0..=16 {
        let s = k as f64 / 16.0;
        for px in [
            DVec2::new(x0 - 1.0 + s * (w + 1.0), y0 - 1.0),
            DVec2::new(x0 - 1.0 + s * (w + 1.0), y0 + h),
            DVec2::new(x0 - 1.0, y0 - 1.0 + s * (h + 1.0)),
            DVec2::new(x0 + w, y0 - 1.0 + s * (h + 1.0)),
        ] {
            let t = to_texel(view.wheel_map.to_plane(px)?);
            lo = lo.min(t);
            hi = hi.max(t);
        }
    }
    Some(Rect {
        x0: lo.x.floor() as i64 - 2,
        y0: lo.y.floor() as i64 - 2,
        x1: hi.x.ceil() as i64 + 3,
        y1: hi.y.ceil() as i64 + 3,
    })
}

/// A rectangle of texel indices, `x0..x1` × `y0..y1`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rect {
    x0: i64,
    y0: i64,
    x1: i64,
    y1: i64,
}

impl Rect {
    fn union(self, o: Rect) -> Rect {
        Rect {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }

    /// Grown by `by` on every side and clipped to `width` × `height`.
    fn grown_within(self, by: i64, width: usize, height: usize) -> Rect {
        Rect {
            x0: (self.x0 - by).max(0),
            y0: (self.y0 - by).max(0),
            x1: (self.x1 + by).min(width as i64),
            y1: (self.y1 + by).min(height as i64),
        }
    }

    fn width(&self) -> usize {
        (self.x1 - self.x0).max(0) as usize
    }

    fn height(&self) -> usize {
        (self.y1 - self.y0).max(0) as usize
    }
}

/// Per-texel sums over the part `rect` of a grid of `width` × `height` (only that part can be
/// sampled or filled), and how many views contributed.
struct Accumulator {
    width: usize,
    height: usize,
    rect: Rect,
    sums: Vec<f64>,
    counts: Vec<u32>,
    views_used: usize,
}

impl Accumulator {
    fn new(width: usize, height: usize, rect: Rect) -> Self {
        let n = rect.width() * rect.height();
        Self {
            width,
            height,
            rect,
            sums: vec![0.0; n],
            counts: vec![0; n],
            views_used: 0,
        }
    }

    /// Adds `dn` to texel (i, j) of the whole grid (ignored outside the rectangle).
    fn add(&mut self, i: i64, j: i64, dn: f64) -> bool {
        let r = &self.rect;
        if i < r.x0 || j < r.y0 || i >= r.x1 || j >= r.y1 {
            return false;
        }
        let k = (j - r.y0) as usize * r.width() + (i - r.x0) as usize;
        self.sums[k] += dn;
        self.counts[k] += 1;
        true
    }

    /// The texture: sampled texels at their mean, those near them at the local mean (squares of
    /// `reach`·[`FILL_STEPS`] texels), both rounded to whole grey levels, the rest at
    /// `uniform_radiance` (`None`: the sampled texels' mean).
    fn finish(
        self,
        anchors: &LevelAnchors,
        reach: usize,
        uniform_radiance: Option<f64>,
        guard_px: f64,
    ) -> Result<Mosaic, SurroundError> {
        let (rw, rh) = (self.rect.width(), self.rect.height());
        let mean_dn: Vec<Option<f64>> = self
            .sums
            .iter()
            .zip(&self.counts)
            .map(|(&s, &n)| (n > 0).then(|| s / n as f64))
            .collect();
        let sampled: Vec<f64> = mean_dn.iter().flatten().copied().collect();
        if sampled.is_empty() {
            return Err(SurroundError::NothingSampled { guard_px });
        }
        let table = Integral::new(rw, rh, |i, j| mean_dn[j * rw + i]);
        // Whole grey levels: finer steps vanish in the render's own rounding, and a texel equal
        // to its neighbour costs the renderer no edge between them.
        let radiance = |dn: f64| anchors.radiance(dn.round());
        let reach = reach.max(1);
        let sampled_mean_dn = sampled.iter().sum::<f64>() / sampled.len() as f64;
        let uniform = uniform_radiance.unwrap_or_else(|| anchors.radiance(sampled_mean_dn));
        let mut values = vec![value_of(uniform); self.width * self.height];
        let mut filled = 0;
        for j in 0..rh {
            for i in 0..rw {
                let v = match mean_dn[j * rw + i] {
                    Some(dn) => radiance(dn),
                    None => match FILL_STEPS.iter().find_map(|&m| table.mean(i, j, m * reach)) {
                        Some(dn) => {
                            filled += 1;
                            radiance(dn)
                        }
                        None => continue,
                    },
                };
                let (x, y) = (i + self.rect.x0 as usize, j + self.rect.y0 as usize);
                values[y * self.width + x] = value_of(v);
            }
        }
        let counts: u64 = self.counts.iter().map(|&n| n as u64).sum();
        Ok(Mosaic {
            texture: Texture {
                width: self.width,
                height: self.height,
                values,
            },
            frames: self.views_used,
            sampled_texels: sampled.len(),
            filled_texels: filled,
            guard_px,
            mean_dn: sampled_mean_dn,
            spread_dn: if sampled.len() >= 2 {
                crate::numeric::robust::sample_sd(&sampled)
            } else {
                0.0
            },
            frames_per_texel: counts as f64 / sampled.len() as f64,
        })
    }
}

/// How far the fill reaches beyond the sampled texels, in texels.
fn fill_extent(reach: usize) -> i64 {
    (FILL_STEPS[FILL_STEPS.len() - 1] * reach.max(1)) as i64
}

/// The disc's texture in the wheel's frame, mosaicked from `views` (frames where the wheel was
/// at rest) with a blur of `blur_sigma_px`, levels mapped to radiance through `anchors`; texels
/// the footage does not show keep `uniform_radiance` (the disc's calibrated level).
pub fn disc_texture(
    views: &[PlaneView<'_>],
    geometry: &DiscGeometry,
    blur_sigma_px: f64,
    anchors: &LevelAnchors,
    uniform_radiance: f64,
) -> Result<DiscMosaic, SurroundError> {
    if views.is_empty() {
        return Err(SurroundError::NoViews);
    }
    let g = geometry;
    if !(g.radius_m > 0.0 && g.m_per_px > 0.0 && g.radius_m.is_finite() && g.m_per_px.is_finite()) {
        return Err(SurroundError::BadGeometry);
    }
    let texel_m_wanted = PX_PER_DISC_TEXEL * g.m_per_px;
    let wanted = (2.0 * g.radius_m / texel_m_wanted).ceil() as usize + 1;
    let side = wanted.clamp(3, MAX_DISC_TEXELS);
    let texel_m = (2.0 * g.radius_m / (side - 1) as f64).max(texel_m_wanted);
    let c = (side - 1) as f64 / 2.0;
    let guard = guard_px(blur_sigma_px);
    let guard_m = guard * g.m_per_px;
    let plane_of = |i: i64, j: i64| DVec2::new((i as f64 - c) * texel_m, (j as f64 - c) * texel_m);
    let reach = (guard * g.m_per_px / texel_m).ceil() as usize + 1;
    let boxes: Vec<Option<Rect>> = views
        .iter()
        .map(|v| view_box(v, |p| p / texel_m + DVec2::splat(c)))
        .collect();
    let Some(all) = boxes.iter().flatten().copied().reduce(Rect::union) else {
        return Err(SurroundError::NothingSampled { guard_px: guard });
    };
    let mut acc = Accumulator::new(side, side, all.grown_within(fill_extent(reach), side, side));
    for (view, b) in views.iter().zip(&boxes) {
        let Some(b) = b.map(|b| b.grown_within(0, side, side)) else {
            continue;
        };
        let mut used = false;
        for j in b.y0..b.y1 {
            for i in b.x0..b.x1 {
                let p = plane_of(i, j);
                if p.length() > g.radius_m - guard_m || distance_to_quad(p, &g.paper_m) < guard_m {
                    continue;
                }
                let x = view.wheel_map.to_image(p);
                if let Some(dn) = bilinear(&view.image, x.x, x.y) {
                    used |= acc.add(i, j, anchors.under_unit_gain(dn, view.light_gain));
                }
            }
        }
        acc.views_used += used as usize;
    }
    let mosaic = acc.finish(anchors, reach, Some(uniform_radiance), guard)?;
    Ok(DiscMosaic {
        mosaic,
        texel_m,
        centre_texel: [c, c],
    })
}

/// The background as a texture of the camera's `size_px` (width, height), one texel per pixel,
/// mosaicked from `views` (any frames: the background stays with the camera) with a blur of
/// `blur_sigma_px`: every pixel that sees the wheel's plane beyond the disc of `radius_m` by
/// the guard band; pixels the footage does not show take the sampled pixels' mean.
pub fn background_texture(
    views: &[PlaneView<'_>],
    radius_m: f64,
    m_per_px: f64,
    size_px: (usize, usize),
    blur_sigma_px: f64,
    anchors: &LevelAnchors,
) -> Result<Mosaic, SurroundError> {
    if views.is_empty() {
        return Err(SurroundError::NoViews);
    }
    if !(radius_m > 0.0 && m_per_px > 0.0 && radius_m.is_finite() && m_per_px.is_finite()) {
        return Err(SurroundError::BadGeometry);
    }
    let guard = guard_px(blur_sigma_px);
    let beyond_m = radius_m + guard * m_per_px;
    let (w, h) = size_px;
    let rect_of = |v: &GrayView<'_>| Rect {
        x0: v.origin_px.0 as i64,
        y0: v.origin_px.1 as i64,
        x1: v.origin_px.0 as i64 + v.width as i64,
        y1: v.origin_px.1 as i64 + v.height as i64,
    };
    let Some(all) = views.iter().map(|v| rect_of(&v.image)).reduce(Rect::union) else {
        return Err(SurroundError::NoViews);
    };
    let reach = guard.ceil() as usize + 1;
    let mut acc = Accumulator::new(w, h, all.grown_within(fill_extent(reach), w, h));
    for view in views {
        let v = &view.image;
        let b = rect_of(v).grown_within(0, w, h);
        let mut used = false;
        let to_plane = view.wheel_map.inverse();
        for y in b.y0..b.y1 {
            for x in b.x0..b.x1 {
                let beyond = to_plane
                    .to_plane(DVec2::new(x as f64, y as f64))
                    .is_some_and(|p| p.length() >= beyond_m);
                if let (true, Some(dn)) = (beyond, pixel_at(v, x, y)) {
                    used |= acc.add(
                        x,
                        y,
                        anchors.under_unit_gain(f64::from(dn), view.light_gain),
                    );
                }
            }
        }
        acc.views_used += used as usize;
    }
    acc.finish(anchors, reach, None, guard)
}

#[cfg(test)]
#[path = "surroundings_tests.rs"]
mod tests;
