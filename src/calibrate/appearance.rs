//! The marker's appearance measured from the footage (pure): its paper and ink as a texture in
//! the marker's printed frame, the `scene.appearance.marker_file` a calibrated scenario carries,
//! mosaicked from the frames where the marker was registered.
//!
//! Why: a real marker is no uniform ink on uniform paper. Print texture, toner density, paper
//! fibre, a shadow or a glare across it are real and in no effect's vocabulary; rendered with
//! uniform levels they stay in footage − render, where the re-render check rightly finds
//! structure and a diagnosis would find a gap.
//!
//! Method: each texel's centre is mapped into every registered frame through the homography of
//! that frame's four corners (grid → image, [`Homography`]) and the footage sampled there
//! (bilinear), averaged over the frames. A texel within the blur's reach of a material boundary
//! (an ink cell's edge, the paper's outer edge) sees both sides mixed by the camera's blur:
//! sampled, the texture would hold that blur and the renderer would blur it a second time. Such
//! a texel takes its material's local level instead (the mean of the sampled texels of the same
//! material within about a cell), so the texture's edges stay sharp on the cell lattice and the
//! renderer blurs them once, with the fitted σ. What lies closer to an edge than the guard band
//! (texture at a cell's rim) is therefore not reproduced; the calibration says how many texels
//! were measured and how many took a level. The sampled texels hold the footage's blur of the
//! texture's own detail (print lines, a tape's lettering), which the renderer would blur again:
//! they are restored by a few Van Cittert iterations over the sampled texels of their material
//! ([`restore_sampled`]), so that a render blurs that detail about once.
//!
//! Grey levels map to radiance linearly through two anchors, the calibrated ink and paper
//! levels and the radiances that render them (the calibrated tone curve is linear).

use crate::detect::GrayView;
use crate::imagestats::{pixel_at, Homography, MarkerLayout, Material, StatsError};
use crate::render::texture::{value_of, Texture};

/// Largest texels per cell a marker texture may have (the scenario's limit).
pub const MAX_TEXELS_PER_CELL: u32 = 64;

/// How many blur σ from a material boundary a texel must lie to be sampled.
const GUARD_SIGMAS: f64 = 3.0;
/// Added to the guard band, px: the bilinear sample's reach and the registration's error.
const GUARD_EXTRA_PX: f64 = 1.5;

/// One frame where the marker was registered: the footage around it and its four outer
/// corners (OpenCV order: TL, TR, BR, BL as printed), px, and the light's gain on it relative to
/// the anchors' (a drifting exposure: each view's levels are brought to the anchors' light
/// before they are averaged).
#[derive(Debug, Clone, Copy)]
pub struct RegisteredView<'a> {
    pub image: GrayView<'a>,
    pub corners_px: [[f64; 2]; 4],
    pub light_gain: f64,
}

/// Two points of the linear map from grey level (DN) to radiance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelAnchors {
    pub ink_dn: f64,
    pub ink_radiance: f64,
    pub paper_dn: f64,
    pub paper_radiance: f64,
}

impl LevelAnchors {
    /// Lighting off: DN = 255 × radiance.
    #[cfg(test)]
    pub(crate) const BYTE_SCALE: LevelAnchors = LevelAnchors {
        ink_dn: 0.0,
        ink_radiance: 0.0,
        paper_dn: 255.0,
        paper_radiance: 1.0,
    };

    /// The radiance that renders as `dn`, in [0, 1].
    pub fn radiance(&self, dn: f64) -> f64 {
        let span = self.paper_dn - self.ink_dn;
        let r = if span.abs() > 1e-9 {
            self.ink_radiance
                + (dn - self.ink_dn) * (self.paper_radiance - self.ink_radiance) / span
        } else {
            self.paper_radiance
        };
        r.clamp(0.0, 1.0)
    }

    /// The grey level `dn`, seen under a light of gain `gain`, under the anchors' light: the
    /// radiance scales with the gain about the level of radiance 0.
    pub fn under_unit_gain(&self, dn: f64, gain: f64) -> f64 {
        let dr = self.paper_radiance - self.ink_radiance;
        if gain == 1.0 || gain.is_nan() || gain <= 0.0 || dr.abs() < 1e-12 {
            return dn;
        }
        let zero_dn = self.ink_dn - self.ink_radiance * (self.paper_dn - self.ink_dn) / dr;
        zero_dn + (dn - zero_dn) / gain
    }
}

/// The measured marker texture and how it was made.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerAppearance {
    /// The paper (margin included) in the printed frame, row 0 at the printed top.
    pub texture: Texture,
    pub texels_per_cell: u32,
    /// Frames mosaicked.
    pub frames: usize,
    /// Texels sampled from the footage, and texels that took their material's local level.
    pub sampled_texels: usize,
    pub level_texels: usize,
    /// Per texel (row-major), whether it was sampled.
    pub sampled_mask: Vec<bool>,
    /// Mean image size of a cell, px, and the guard band around material boundaries, px.
    pub px_per_cell: f64,
    pub guard_px: f64,
    /// The sampled texels' spread about their material's mean, DN (ink, paper): texture and
    /// shading, plus what the footage's noise leaves after averaging over the frames.
    pub spread_dn: [f64; 2],
    /// The darkest and brightest sampled texel, DN.
    pub range_dn: [f64; 2],
}

impl MarkerAppearance {
    /// What a noise of `noise_sd_dn` in one frame leaves in a mean over the mosaic's frames, DN.
    pub fn noise_left_dn(&self, noise_sd_dn: f64) -> f64 {
        noise_sd_dn / (self.frames.max(1) as f64).sqrt()
    }

    /// The spread of material `m` (0 ink, 1 paper) beyond a null's spread `null_sd_dn` (what
    /// noise alone leaves, [`Self::noise_left_dn`], or the same mosaic of a uniform marker),
    /// DN (0 when the null explains it).
    pub fn texture_sd_dn(&self, m: usize, null_sd_dn: f64) -> f64 {
        (self.spread_dn[m].powi(2) - null_sd_dn.powi(2))
            .max(0.0)
            .sqrt()
    }
}

/// Whether the footage shows the marker's appearance: the spread of the ink or the paper
/// beyond its null, `texture_sd_dn`, is at least [`MIN_TEXTURE_SD_DN`] and at least the null's
/// own spread `null_sd_dn`. A texture also freezes the mean's noise into every render: it pays
/// only where the appearance it draws is larger than what it adds.
pub fn shows_texture(texture_sd_dn: [f64; 2], null_sd_dn: [f64; 2]) -> bool {
    (0..2).any(|m| texture_sd_dn[m] >= MIN_TEXTURE_SD_DN && texture_sd_dn[m] >= null_sd_dn[m])
}

/// The least spread beyond the noise, DN, that makes a marker textured.
pub const MIN_TEXTURE_SD_DN: f64 = 1.0;

/// What a calibration records of the marker texture it wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct AppearanceRecord {
    /// The texture's file, beside the scenario.
    pub file: String,
    pub texels_per_cell: u32,
    pub frames: usize,
    /// Whether the re-render check's frame was left out of the mosaic (a single frame cannot
    /// be).
    pub check_frame_held_out: bool,
    pub sampled_texels: usize,
    pub level_texels: usize,
    pub px_per_cell: f64,
    pub guard_px: f64,
}

impl AppearanceRecord {
    pub fn of(a: &MarkerAppearance, file: &str, check_frame_held_out: bool) -> AppearanceRecord {
        AppearanceRecord {
            file: file.to_string(),
            texels_per_cell: a.texels_per_cell,
            frames: a.frames,
            check_frame_held_out,
            sampled_texels: a.sampled_texels,
            level_texels: a.level_texels,
            px_per_cell: a.px_per_cell,
            guard_px: a.guard_px,
        }
    }
}

/// Why no marker texture can be measured.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AppearanceError {
    #[error(
        "the marker is never at rest in the footage (a moving marker is smeared by its motion)"
    )]
    NoViews,
    #[error("the marker's white margin is not known")]
    NoMargin,
    #[error(
        "no texture of at most {MAX_TEXELS_PER_CELL} texels per cell puts the white margin \
         ({margin_cells:.4} cells) on whole texels"
    )]
    MarginNotWhole { margin_cells: f64 },
    #[error(transparent)]
    Registration(#[from] StatsError),
}

/// Texels per cell for a marker whose cells are `px_per_cell` px across and whose margin is
/// `margin_cells` cells: the fewest that make a texel at most a pixel and the margin a whole
/// number of texels, else the most that keep the margin whole; `None` when none does.
pub fn texels_per_cell(px_per_cell: f64, margin_cells: f64) -> Option<u32> {
    let whole = |t: u32| {
        let m = margin_cells * t as f64;
        (m - m.round()).abs() < 1e-6
    };
    let fitting: Vec<u32> = (1..=MAX_TEXELS_PER_CELL).filter(|&t| whole(t)).collect();
    fitting
        .iter()
        .copied()
        .find(|&t| t as f64 >= px_per_cell)
        .or_else(|| fitting.last().copied())
}

/// Bilinear grey level of `view` at (x, y) px (pixel centres at integers); `None` when a
/// neighbour lies outside the view.
pub(crate) fn bilinear(view: &GrayView<'_>, x: f64, y: f64) -> Option<f64> {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (i, j) = (x0 as i64, y0 as i64);
    let p = |a: i64, b: i64| pixel_at(view, a, b).map(f64::from);
    let (a, b, c, d) = (p(i, j)?, p(i + 1, j)?, p(i, j + 1)?, p(i + 1, j + 1)?);
    Some((a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy)
}

/// Mean length of the quadrilateral's sides over `cells`, px per cell.
fn px_per_cell(corners: &[[f64; 2]; 4], cells: usize) -> f64 {
    (0..4)
        .map(|k| {
            let (a, b) = (corners[k], corners[(k + 1) % 4]);
            (a[0] - b[0]).hypot(a[1] - b[1])
        })
        .sum::<f64>()
        / (4.0 * cells as f64)
}

/// Summed-area table of a texel grid of `width` × `height` (one row and column of zeros in
/// front): local means of the texels that hold a value.
pub(crate) struct Integral {
    width: usize,
    height: usize,
    sums: Vec<f64>,
    counts: Vec<u32>,
}

impl Integral {
    pub(crate) fn new(
        width: usize,
        height: usize,
        value: impl Fn(usize, usize) -> Option<f64>,
    ) -> Integral {
        let w = width + 1;
        let (mut sums, mut counts) = (vec![0.0; w * (height + 1)], vec![0u32; w * (height + 1)]);
        for j in 0..height {
            for i in 0..width {
                let (s, c) = value(i, j).map_or((0.0, 0), |v| (v, 1));
                let k = (j + 1) * w + i + 1;
                sums[k] = s + sums[k - 1] + sums[k - w] - sums[k - w - 1];
                counts[k] = c + counts[k - 1] + counts[k - w] - counts[k - w - 1];
            }
        }
        Integral {
            width,
            height,
            sums,
            counts,
        }
    }

    /// Mean over the square of half-width `r` texels about (i, j), `None` when empty.
    pub(crate) fn mean(&self, i: usize, j: usize, r: usize) -> Option<f64> {
        let w = self.width + 1;
        let (a, b) = (i.saturating_sub(r), j.saturating_sub(r));
        let (c, d) = ((i + r + 1).min(self.width), (j + r + 1).min(self.height));
        let at = |x: usize, y: usize| (self.sums[y * w + x], self.counts[y * w + x]);
        let (s1, n1) = at(c, d);
        let (s2, n2) = at(a, d);
        let (s3, n3) = at(c, b);
        let (s4, n4) = at(a, b);
        let n = n1 + n4 - n2 - n3;
        (n > 0).then(|| (s1 + s4 - s2 - s3) / n as f64)
    }
}

/// The marker texture of `layout` seen in `views` with a blur of `blur_sigma_px`, its levels
/// mapped to radiance through `anchors`.
pub fn marker_appearance(
    views: &[RegisteredView<'_>],
    layout: &MarkerLayout,
    blur_sigma_px: f64,
    anchors: &LevelAnchors,
) -> Result<MarkerAppearance, AppearanceError> {
    mosaic_marker(views, layout, blur_sigma_px, anchors, true)
}

/// [`marker_appearance`], the sampled texels restored ([`restore_sampled`]) or as sampled.
fn mosaic_marker(
    views: &[RegisteredView<'_>],
    layout: &MarkerLayout,
    blur_sigma_px: f64,
    anchors: &LevelAnchors,
    restore: bool,
) -> Result<MarkerAppearance, AppearanceError> {
    if views.is_empty() {
        return Err(AppearanceError::NoViews);
    }
    let cells = layout.side_cells();
    let margin_cells = layout.margin_cells().ok_or(AppearanceError::NoMargin)?;
    let maps: Vec<Homography> = views
        .iter()
        .map(|v| Homography::from_corners(&v.corners_px, cells))
        .collect::<Result<_, _>>()?;
    let scale_px = views
        .iter()
        .map(|v| px_per_cell(&v.corners_px, cells))
        .sum::<f64>()
        / views.len() as f64;
    let tpc = texels_per_cell(scale_px, margin_cells)
        .ok_or(AppearanceError::MarginNotWhole { margin_cells })?;
    let t = tpc as f64;
    let margin_texels = (margin_cells * t).round() as usize;
    let side = cells * tpc as usize + 2 * margin_texels;
    let centre = |k: usize| (k as f64 + 0.5 - margin_texels as f64) / t;
    // Material at every texel centre; a texel is sampled when every texel within the guard band
    // has its material (outside the texture counts as another).
    let material: Vec<Material> = (0..side * side)
        .map(|k| layout.material(centre(k % side), centre(k / side)))
        .collect();
    let guard_px = GUARD_SIGMAS * blur_sigma_px.max(0.0) + GUARD_EXTRA_PX;
    let reach = (guard_px / (scale_px / t)).ceil() as i64;
    let interior = |i: usize, j: usize| -> bool {
        let m = material[j * side + i];
        (-reach..=reach).all(|dj| {
            (-reach..=reach).all(|di| {
                let (a, b) = (i as i64 + di, j as i64 + dj);
                a >= 0
                    && b >= 0
                    && (a as usize) < side
                    && (b as usize) < side
                    && material[b as usize * side + a as usize] == m
            })
        })
    };
    let mut sampled: Vec<Option<f64>> = vec![None; side * side];
    let mut sampled_dn: Vec<Option<f64>> = vec![None; side * side];
    for j in 0..side {
        for i in 0..side {
            if !interior(i, j) {
                continue;
            }
            let (gx, gy) = (centre(i), centre(j));
            let (mut sum, mut n) = (0.0, 0usize);
            for (v, h) in views.iter().zip(&maps) {
                let [x, y] = h.map(gx, gy);
                if let Some(dn) = bilinear(&v.image, x, y) {
                    sum += anchors.under_unit_gain(dn, v.light_gain);
                    n += 1;
                }
            }
            if n > 0 {
                let dn = sum / n as f64;
                sampled_dn[j * side + i] = Some(dn);
                sampled[j * side + i] = Some(anchors.radiance(dn));
            }
        }
    }
    let texel_px = scale_px / t;
    let restore_sigma = if restore {
        resampling_sigma_px(blur_sigma_px, texel_px) / texel_px
    } else {
        0.0
    };
    restore_sampled(&mut sampled, &material, side, restore_sigma);
    let values = fill_levels(&sampled, &material, side, tpc as usize, reach, anchors);
    let sampled_texels = sampled.iter().filter(|v| v.is_some()).count();
    let spread = |m: Material| -> f64 {
        let v: Vec<f64> = sampled_dn
            .iter()
            .zip(&material)
            .filter(|(_, &mm)| mm == m)
            .filter_map(|(d, _)| *d)
            .collect();
        if v.len() < 2 {
            return 0.0;
        }
        crate::numeric::robust::sample_sd(&v)
    };
    Ok(MarkerAppearance {
        texture: Texture {
            width: side,
            height: side,
            values,
        },
        texels_per_cell: tpc,
        frames: views.len(),
        sampled_texels,
        level_texels: side * side - sampled_texels,
        sampled_mask: sampled.iter().map(Option::is_some).collect(),
        px_per_cell: scale_px,
        guard_px,
        spread_dn: [spread(Material::Ink), spread(Material::Paper)],
        range_dn: sampled_dn
            .iter()
            .flatten()
            .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], &d| {
                [lo.min(d), hi.max(d)]
            }),
    })
}

/// The blur a mosaicked texture takes twice, px: the footage's own blur is in every sample,
/// and the renderer blurs the texture again, by its texel's box, the pixel's area and the
/// fitted `blur_sigma_px` (which renders the footage's edges from a sharp step), after the
/// bilinear sample has blurred it once more. The σ of the three in quadrature: variances 1/6 px²
/// (the bilinear sample's triangle), texel²/12 and 1/12 px² (the boxes), σ².
pub(crate) fn resampling_sigma_px(blur_sigma_px: f64, texel_px: f64) -> f64 {
    (1.0 / 6.0 + texel_px * texel_px / 12.0 + 1.0 / 12.0 + blur_sigma_px.max(0.0).powi(2)).sqrt()
}

/// Van Cittert iterations in the deconvolution ([`RESTORE_ITERATIONS`];
/// t_{k+1} = t_k + (t_0 − G ∗ t_k), P. H. van Cittert 1931; P. A. Jansson 1997,
/// "Deconvolution of images and spectra", ch. 3) of the sampled texels, with a Gaussian of
/// `sigma_texels` taken over the sampled texels of the same material only (normalised
/// convolution, 3σ wide): the texture's detail that the mosaic and the render together blur
/// twice comes back near its size in the footage (a detail the Gaussian keeps a fraction b of
/// is kept 1 − (1 − b)^(k+1) after k iterations: 0.3 becomes 0.76 after three), and no material
/// boundary or unsampled texel enters the step, so no halo is drawn at the cells' edges. The
/// noise left in the mosaic grows by at most k + 1 at the finest scale, where the render's blur
/// takes it away again.
pub(crate) fn restore_sampled(
    sampled: &mut [Option<f64>],
    material: &[Material],
    side: usize,
    sigma_texels: f64,
) {
    if sigma_texels.is_nan() || sigma_texels <= 0.05 {
        return;
    }
    let r = (3.0 * sigma_texels).ceil() as i64;
    let w: Vec<f64> = (-r..=r)
        .map(|d| (-0.5 * (d as f64 / sigma_texels).powi(2)).exp())
        .collect();
    let original = sampled.to_vec();
    let smoothed = |t: &[Option<f64>], i: i64, j: i64, m: Material| -> f64 {
        let (mut sum, mut weight) = (0.0, 0.0);
        for dj in -r..=r {
            let b = j + dj;
            if b < 0 || b >= side as i64 {
                continue;
            }
            for di in -r..=r {
                let a = i + di;
                if a < 0 || a >= side as i64 {
                    continue;
                }
                let q = (b * side as i64 + a) as usize;
                if let (Some(u), true) = (t[q], material[q] == m) {
                    let wq = w[(dj + r) as usize] * w[(di + r) as usize];
                    sum += wq * u;
                    weight += wq;
                }
            }
        }
        sum / weight
    };
    for _ in 0..RESTORE_ITERATIONS {
        let current = sampled.to_vec();
        for (k, out) in sampled.iter_mut().enumerate() {
            let (Some(t0), Some(tk)) = (original[k], current[k]) else {
                continue;
            };
            let (i, j) = ((k % side) as i64, (k / side) as i64);
            let blurred = smoothed(&current, i, j, material[k]);
            *out = Some((tk + t0 - blurred).clamp(0.0, 1.0));
        }
    }
}

/// Van Cittert iterations of [`restore_sampled`].
pub const RESTORE_ITERATIONS: usize = 3;

/// Every texel's value: the sampled radiance, else the mean of the nearest sampled texels of
/// its material (within the guard band's reach, then twice it, a cell, four cells), else that
/// material's mean over the marker, else its anchor.
fn fill_levels(
    sampled: &[Option<f64>],
    material: &[Material],
    side: usize,
    tpc: usize,
    reach: i64,
    anchors: &LevelAnchors,
) -> Vec<u16> {
    let tables: Vec<Integral> = [Material::Ink, Material::Paper]
        .iter()
        .map(|&m| {
            Integral::new(side, side, |i, j| {
                let k = j * side + i;
                sampled[k].filter(|_| material[k] == m)
            })
        })
        .collect();
    // The nearest sampled texels first (a guard texel lies within the band's reach of them
    // unless its cell is too narrow to hold any), then wider.
    let near = reach.max(0) as usize + 1;
    let radii = [
        near,
        2 * near,
        tpc.max(2 * near),
        4 * tpc.max(2 * near),
        side,
    ];
    (0..side * side)
        .map(|k| {
            if let Some(r) = sampled[k] {
                return value_of(r);
            }
            let (i, j) = (k % side, k / side);
            let (table, anchor) = match material[k] {
                Material::Ink => (&tables[0], anchors.ink_radiance),
                _ => (&tables[1], anchors.paper_radiance),
            };
            let level = radii
                .iter()
                .find_map(|&r| table.mean(i, j, r))
                .unwrap_or(anchor);
            value_of(level)
        })
        .collect()
}

#[cfg(test)]
mod tests;
