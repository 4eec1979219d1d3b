//! The marker's printed layout in grid coordinates (cells; the black square is [0, N]², x right
//! and y down as printed) and the homography that maps it onto the image through the four
//! detected corners.

use super::StatsError;
use crate::marker::{cells, Dictionary};

/// What the camera sees at a point of the marker's plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Material {
    /// Black ink (border and black cells).
    Ink,
    /// White paper (white cells and the white margin).
    Paper,
    /// Whatever lies beyond the paper (the disc, the base plate), or right outside the black
    /// square when the margin is not known.
    Surround,
}

impl Material {
    pub(crate) fn index(self) -> usize {
        match self {
            Material::Ink => 0,
            Material::Paper => 1,
            Material::Surround => 2,
        }
    }
}

/// The printed marker: cell grid (with its black border) and optional white margin.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerLayout {
    /// `cells[row][col]`, row 0 at the top as printed, `true` = white; includes the border.
    pub cells: Vec<Vec<bool>>,
    /// Black border width, cells.
    pub border_bits: usize,
    /// White paper around the black square on each side, in units of the black square's side
    /// (`white_margin_mm / size_mm`); `None` when unknown.
    pub margin_frac: Option<f64>,
}

impl MarkerLayout {
    /// The layout of marker `id` of `dictionary` with `border_bits` black border cells.
    pub fn new(
        dictionary: Dictionary,
        id: usize,
        border_bits: usize,
        margin_frac: Option<f64>,
    ) -> Result<Self, StatsError> {
        let grid =
            cells(dictionary, id, border_bits).map_err(|e| StatsError::Invalid(e.to_string()))?;
        Self::from_cells(grid, border_bits, margin_frac)
    }

    /// A layout from an explicit square cell grid (`true` = white).
    pub fn from_cells(
        cells: Vec<Vec<bool>>,
        border_bits: usize,
        margin_frac: Option<f64>,
    ) -> Result<Self, StatsError> {
        let n = cells.len();
        if n < 3 || cells.iter().any(|r| r.len() != n) {
            return Err(StatsError::Invalid(format!(
                "marker cell grid must be square with at least 3 cells per side, got {n} rows"
            )));
        }
        if border_bits == 0 || 2 * border_bits >= n {
            return Err(StatsError::Invalid(format!(
                "border_bits {border_bits} does not fit a {n}-cell marker"
            )));
        }
        if let Some(m) = margin_frac {
            if !(m.is_finite() && m >= 0.0) {
                return Err(StatsError::Invalid(format!(
                    "margin_frac must be finite and >= 0, got {m}"
                )));
            }
        }
        Ok(Self {
            cells,
            border_bits,
            margin_frac,
        })
    }

    /// Cells per side N (data bits plus both borders).
    pub fn side_cells(&self) -> usize {
        self.cells.len()
    }

    /// White margin in cells, if known.
    pub fn margin_cells(&self) -> Option<f64> {
        self.margin_frac.map(|m| m * self.side_cells() as f64)
    }

    /// Material at grid point (gx, gy) (cells).
    pub fn material(&self, gx: f64, gy: f64) -> Material {
        let n = self.side_cells() as f64;
        if (0.0..n).contains(&gx) && (0.0..n).contains(&gy) {
            let (c, r) = (gx.floor() as usize, gy.floor() as usize);
            return if self.cells[r][c] {
                Material::Paper
            } else {
                Material::Ink
            };
        }
        match self.margin_cells() {
            Some(m) if gx >= -m && gx < n + m && gy >= -m && gy < n + m => Material::Paper,
            _ => Material::Surround,
        }
    }

    /// Grid positions (cells) where the material can change along either axis: the cell lines
    /// and the margin's outer edges.
    pub(crate) fn breaks(&self) -> Vec<f64> {
        let n = self.side_cells();
        let mut b: Vec<f64> = (0..=n).map(|k| k as f64).collect();
        if let Some(m) = self.margin_cells() {
            if m > 0.0 {
                b.insert(0, -m);
                b.push(n as f64 + m);
            }
        }
        b
    }
}

/// A plane projective map from marker grid coordinates (cells) to image pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Homography {
    /// Row-major 3×3 matrix, grid → image.
    pub h: [[f64; 3]; 3],
    inv: [[f64; 3]; 3],
}

impl Homography {
    /// The map taking the grid corners (0,0), (N,0), (N,N), (0,N) onto `corners_px` (OpenCV
    /// order). Errors for a degenerate or non-convex quadrilateral.
    pub fn from_corners(corners_px: &[[f64; 2]; 4], side_cells: usize) -> Result<Self, StatsError> {
        let degenerate = |reason: &str| StatsError::Degenerate {
            corners_px: *corners_px,
            reason: reason.to_string(),
        };
        if corners_px.iter().flatten().any(|v| !v.is_finite()) {
            return Err(degenerate("not finite"));
        }
        // Convexity: the four cross products of consecutive sides share one sign.
        let mut sign = 0.0;
        for i in 0..4 {
            let (a, b, c) = (
                corners_px[i],
                corners_px[(i + 1) % 4],
                corners_px[(i + 2) % 4],
            );
            let cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
            if cross.abs() < 1e-6 {
                return Err(degenerate("three corners are collinear"));
            }
            if sign == 0.0 {
                sign = cross.signum();
            } else if cross.signum() != sign {
                return Err(degenerate("the quadrilateral is not convex"));
            }
        }
        let n = side_cells as f64;
        let src = [[0.0, 0.0], [n, 0.0], [n, n], [0.0, n]];
        let mut a = vec![vec![0.0; 8]; 8];
        let mut b = vec![0.0; 8];
        for k in 0..4 {
            let ([x, y], [u, v]) = (src[k], corners_px[k]);
            a[2 * k] = vec![x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y];
            b[2 * k] = u;
            a[2 * k + 1] = vec![0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y];
            b[2 * k + 1] = v;
        }
        let p = crate::numeric::linalg::solve_rows(&a, &b)
            .ok_or_else(|| degenerate("no homography maps the square onto them"))?;
        let h = [[p[0], p[1], p[2]], [p[3], p[4], p[5]], [p[6], p[7], 1.0]];
        let inv =
            crate::numeric::linalg::invert3(&h).ok_or_else(|| degenerate("singular homography"))?;
        Ok(Self { h, inv })
    }

    /// Image point of grid point (gx, gy).
    #[inline]
    pub fn map(&self, gx: f64, gy: f64) -> [f64; 2] {
        apply(&self.h, gx, gy)
    }

    /// Grid point of image point (x, y).
    #[inline]
    pub fn unmap(&self, x: f64, y: f64) -> [f64; 2] {
        apply(&self.inv, x, y)
    }
}

#[inline]
fn apply(m: &[[f64; 3]; 3], x: f64, y: f64) -> [f64; 2] {
    let w = m[2][0] * x + m[2][1] * y + m[2][2];
    [
        (m[0][0] * x + m[0][1] * y + m[0][2]) / w,
        (m[1][0] * x + m[1][1] * y + m[1][2]) / w,
    ]
}
