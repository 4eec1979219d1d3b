//! The scene's appearance as measured (the `[scene.appearance]` scenario section): textures
//! that replace the uniform radiances of the disc, the marker and the background.
//!
//! * **Disc** (`disc_file`): the disc and everything on it (print lines, tape, stains) in the
//!   wheel's frame. Texel (i, j) is the square of side `disc_mm_per_texel` centred at
//!   ((i − c_u)·s, (j − c_v)·s) mm in the wheel frame, (c_u, c_v) = `disc_centre_texel` (OpenCV's
//!   convention: texel (i, j) has its centre at (i, j)); the texture's columns run along the
//!   wheel's +x and its rows along +y, which at θ2 = 0 are the world's (x right, y down in the
//!   untilted image), and it turns with the wheel. Under the marker's paper it is not drawn.
//! * **Marker** (`marker_file`): the marker's paper (black square and white margin) in the
//!   marker's printed frame, `marker_texels_per_cell` texels per cell, row 0 at the printed top:
//!   the cell lattice lies on texel edges, so the ink's edges stay exact, and the texture moves
//!   with the marker's stated place on the disc. It spans the paper exactly: (cells + 2·margin
//!   cells)·texels per cell texels a side. Without it, the paper and ink are drawn uniform.
//! * **Background** (`background_file`): what the camera sees behind the disc, one texel per
//!   camera pixel; it stays with the camera (camera vibration does not move it).
//!
//! * **Marker levels** (`marker_levels`): the marker's radiance as a function of the wheel's
//!   angle (a glossy print reflecting the lamp), see [`super::marker_levels`]; with or without
//!   a marker texture.
//!
//! Files are grey PNGs of 8 or 16 bits holding linear radiance (full scale = 1, the same
//! radiance as `disc_radiance`), read once by the scenario loader into [`LoadedAppearance`].

use crate::render::texture::{BackgroundTexture, Texture};
use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The `[scene.appearance]` section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AppearanceConfig {
    /// Grey PNG (8 or 16 bit, linear radiance) of the disc in the wheel's frame; relative to
    /// the scenario file. Default: none (the disc is `disc_radiance`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub disc_file: Option<String>,
    /// Side of one disc texel on the disc, mm, in (0, 100]. Required with `disc_file`.
    pub disc_mm_per_texel: f64,
    /// Where the wheel centre lies in the disc texture, texels [column, row] (OpenCV
    /// convention: texel (i, j) is centred at (i, j)). Default: the texture's centre.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub disc_centre_texel: Option<[f64; 2]>,
    /// Grey PNG of the marker's paper in its printed frame. Default: none (uniform paper and
    /// ink, `paper_radiance` and `ink_radiance`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub marker_file: Option<String>,
    /// Marker texels per cell, in [1, 64]; the white margin must be a whole number of texels.
    /// Required with `marker_file`.
    pub marker_texels_per_cell: u32,
    /// Grey PNG of the background, the camera's size. Default: none (`background_radiance`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub background_file: Option<String>,
    /// The marker's level by wheel angle (`scene::marker_levels`). Default: none (the marker's
    /// radiance at every angle as stated).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub marker_levels: Vec<super::MarkerLevelAt>,
    /// The textures, read by the scenario loader.
    #[serde(skip)]
    pub loaded: LoadedAppearance,
}

impl Default for AppearanceConfig {
    fn default() -> Self {
        Self {
            disc_file: None,
            disc_mm_per_texel: 0.0,
            disc_centre_texel: None,
            marker_file: None,
            marker_texels_per_cell: 0,
            background_file: None,
            marker_levels: Vec::new(),
            loaded: LoadedAppearance::default(),
        }
    }
}

/// The textures an [`AppearanceConfig`] names, once read.
#[derive(Debug, Clone, Default)]
pub struct LoadedAppearance {
    pub disc: Option<Arc<Texture>>,
    pub marker: Option<Arc<Texture>>,
    pub background: Option<Arc<BackgroundTexture>>,
}

impl PartialEq for LoadedAppearance {
    fn eq(&self, other: &Self) -> bool {
        fn same<T: PartialEq>(a: &Option<Arc<T>>, b: &Option<Arc<T>>) -> bool {
            match (a, b) {
                (None, None) => true,
                (Some(a), Some(b)) => Arc::ptr_eq(a, b) || a == b,
                _ => false,
            }
        }
        same(&self.disc, &other.disc)
            && same(&self.marker, &other.marker)
            && same(&self.background, &other.background)
    }
}

/// The marker's geometry in texels for a marker texture of `texels_per_cell`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerTexels {
    /// Cells across the black square (border included).
    pub cells: usize,
    /// Texels of white margin on each side (a whole number when the layout allows one).
    pub margin: f64,
    /// Texels a side of the whole paper.
    pub side: f64,
}

impl MarkerTexels {
    pub fn new(cells: usize, size_mm: f64, margin_mm: f64, texels_per_cell: u32) -> Self {
        let tpc = texels_per_cell as f64;
        let margin = margin_mm / (size_mm / cells as f64) * tpc;
        Self {
            cells,
            margin,
            side: cells as f64 * tpc + 2.0 * margin,
        }
    }

    /// Whether the margin is a whole number of texels (to 10⁻⁶ texel).
    pub fn margin_is_whole(&self) -> bool {
        (self.margin - self.margin.round()).abs() < 1e-6
    }
}

impl AppearanceConfig {
    /// Whether the section states nothing (it is then left out of a written scenario).
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }

    /// Whether any texture is named.
    pub fn any(&self) -> bool {
        self.disc_file.is_some() || self.marker_file.is_some() || self.background_file.is_some()
    }

    /// Field checks that need no file (`marker_cells` is the marker's cells across, border
    /// included; `size_mm`, `margin_mm` its printed size and margin).
    pub fn validate(
        &self,
        path: &str,
        marker_cells: Option<usize>,
        size_mm: f64,
        margin_mm: f64,
        problems: &mut Problems,
    ) {
        for (name, file) in [
            ("disc_file", &self.disc_file),
            ("marker_file", &self.marker_file),
            ("background_file", &self.background_file),
        ] {
            if file.as_deref().is_some_and(|f| f.trim().is_empty()) {
                problems.push(join(path, name), "must name a file (or be left out)");
            }
        }
        super::marker_levels::validate(&self.marker_levels, &join(path, "marker_levels"), problems);
        if self.disc_file.is_some() {
            let s = self.disc_mm_per_texel;
            if !(s.is_finite() && s > 0.0 && s <= 100.0) {
                problems.push(
                    join(path, "disc_mm_per_texel"),
                    format!(
                        "must be in (0, 100] mm with disc_file, got {}",
                        crate::validation::short(s)
                    ),
                );
            }
            if let Some(c) = self.disc_centre_texel {
                if !c.iter().all(|v| v.is_finite() && v.abs() <= 1e6) {
                    problems.push(
                        join(path, "disc_centre_texel"),
                        "must be two finite texel coordinates",
                    );
                }
            }
        }
        if self.marker_file.is_some() {
            let tpc = self.marker_texels_per_cell;
            if !(1..=64).contains(&tpc) {
                problems.push(
                    join(path, "marker_texels_per_cell"),
                    format!("must be in [1, 64] with marker_file, got {tpc}"),
                );
            } else if let Some(cells) = marker_cells {
                let t = MarkerTexels::new(cells, size_mm, margin_mm, tpc);
                if t.margin.is_finite() && !t.margin_is_whole() {
                    problems.push(
                        join(path, "marker_texels_per_cell"),
                        format!(
                            "the white margin must be a whole number of texels: {tpc} texels per \
                             cell make it {:.3}",
                            t.margin
                        ),
                    );
                }
            }
        }
    }
}
