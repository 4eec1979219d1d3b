//! Where a marker lies in the world at one instant, and its black cells merged into disjoint
//! rectangles (pure functions, world units).

use glam::{DVec2, DVec3};

/// A rectangle of cells `[col0, col1) × [row0, row1)` in the printed grid (row 0 at the top).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellRect {
    pub col0: usize,
    pub row0: usize,
    pub col1: usize,
    pub row1: usize,
}

/// Covers exactly the black (`false`) cells of `grid` with disjoint rectangles, greedily: each
/// rectangle grows right as far as the row allows, then down while the whole span is black.
pub fn black_rectangles(grid: &[Vec<bool>]) -> Vec<CellRect> {
    let rows = grid.len();
    let cols = grid.first().map_or(0, |r| r.len());
    let mut used = vec![vec![false; cols]; rows];
    let mut out = Vec::new();
    for r in 0..rows {
        for c in 0..cols {
            if grid[r][c] || used[r][c] {
                continue;
            }
            let mut c1 = c;
            while c1 < cols && !grid[r][c1] && !used[r][c1] {
                c1 += 1;
            }
            let mut r1 = r + 1;
            while r1 < rows && (c..c1).all(|k| !grid[r1][k] && !used[r1][k]) {
                r1 += 1;
            }
            for row in used.iter_mut().take(r1).skip(r) {
                for cell in row.iter_mut().take(c1).skip(c) {
                    *cell = true;
                }
            }
            out.push(CellRect {
                col0: c,
                row0: r,
                col1: c1,
                row1: r1,
            });
        }
    }
    out
}

/// A square marker placed in the disc plane: its centre, the printed right (`u`) and down
/// (`v`) unit axes, the black-square edge and the paper margin, all in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacedMarker {
    pub centre_m: DVec3,
    pub u: DVec3,
    pub v: DVec3,
    pub size_m: f64,
    pub margin_m: f64,
}

impl PlacedMarker {
    /// A marker centred at `centre_m` (plane z = 0) whose printed right axis makes angle
    /// `psi_rad` with +x (towards +y).
    pub fn new(centre_m: DVec2, psi_rad: f64, size_m: f64, margin_m: f64) -> Self {
        let (s, c) = psi_rad.sin_cos();
        PlacedMarker {
            centre_m: centre_m.extend(0.0),
            u: DVec3::new(c, s, 0.0),
            v: DVec3::new(-s, c, 0.0),
            size_m,
            margin_m,
        }
    }

    /// The point at printed coordinates (a, b) ∈ [0, 1]² of the black square (a right, b down).
    pub fn at(&self, a: f64, b: f64) -> DVec3 {
        self.centre_m + (a - 0.5) * self.size_m * self.u + (b - 0.5) * self.size_m * self.v
    }

    /// Outer corners of the black square in OpenCV's order: top-left, top-right, bottom-right,
    /// bottom-left as printed.
    pub fn corners_m(&self) -> [DVec3; 4] {
        [
            self.at(0.0, 0.0),
            self.at(1.0, 0.0),
            self.at(1.0, 1.0),
            self.at(0.0, 1.0),
        ]
    }

    /// Corners of the white paper (black square plus margin), same order.
    pub fn paper_corners_m(&self) -> [DVec3; 4] {
        let e = self.margin_m / self.size_m;
        [
            self.at(-e, -e),
            self.at(1.0 + e, -e),
            self.at(1.0 + e, 1.0 + e),
            self.at(-e, 1.0 + e),
        ]
    }
}
