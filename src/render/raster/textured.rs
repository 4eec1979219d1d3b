//! A textured layer over one window: its coverage and its radiance-weighted coverage, both as
//! integer deposits of the uniform layers' rasteriser ([`super::Edge`]).
//!
//! The layer is a partition into pieces of constant radiance (`render::texture`). Each piece's
//! boundary, weighted by the piece's 16-bit radiance, summed over the pieces, is the
//! arrangement's *jump network*: every edge weighted by the difference of the radiances on its
//! two sides. Rasterised and prefix-summed along a row it gives Σ radiance × exact area for
//! every pixel, in integers. A window draws only the pieces of the texture blocks whose image
//! can reach it (`S`): the network of the pieces in `S` (an edge between a piece in `S` and one
//! outside it carries the inside piece's radiance alone) gives the same integers in the
//! window's pixels as the whole network, since every piece that touches them is in `S` and a
//! closed piece adds nothing where it does not reach. A window's pixels are therefore the bits
//! of the same pixels of the whole frame.
//!
//! Bounds: a deposit of weight w (≤ 65535) into one cell is at most 2·ONE²·w < 2⁴⁹, and a
//! pixel's prefix sum is at most FULL · 65535; summed over up to 4096 exposure samples the
//! values stay below 2⁶¹.

use super::{to_fixed, Edge, PixelRect, RigidTransform};
use crate::render::texture::build::{BlockClass, Side, Vertex, BLOCK};
use crate::render::texture::{LevelMap, PlaneMap, TextureMesh, TexturedFill};
use glam::{DMat3, DVec2};
use std::sync::Arc;

/// Image margin (px) around a block's or a boundary's projected corners: a straight plane
/// edge bulges by its sagitta under lens distortion (far below this at any accepted
/// distortion), and vertices snap to the fixed-point grid.
const MARGIN_PX: f64 = 1.0;

/// A textured layer prepared for one exposure sample.
#[derive(Debug)]
pub(super) struct PreparedFill {
    mesh: Arc<TextureMesh>,
    /// Plane → image (camera vibration included).
    map: PlaneMap,
    /// Per grid: grid-line coordinates → image.
    grid_maps: Vec<PlaneMap>,
    /// +1 when the map keeps the plane's orientation, −1 when it mirrors it.
    orientation: i64,
    /// Per grid, per block: image bounding box (x0, y0, x1, y1), px, margin included.
    block_boxes: Vec<Vec<[f64; 4]>>,
    /// Per boundary polyline: the image rows its end points span, margin included.
    boundary_rows: Vec<(f64, f64)>,
    /// The paper's level at this instant.
    paper_level: Option<LevelMap>,
}

impl PartialEq for PreparedFill {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.mesh, &other.mesh)
            && self.map == other.map
            && self.paper_level == other.paper_level
    }
}

/// Buffers of [`PreparedFill::deposit`], reused from window to window.
#[derive(Debug, Default)]
pub struct FillScratch {
    selected: Vec<Vec<bool>>,
    corners: Vec<(i64, i64)>,
    polyline: Vec<(i64, i64)>,
}

fn fixed(p: DVec2) -> (i64, i64) {
    (to_fixed(p.x), to_fixed(p.y))
}

impl PreparedFill {
    pub(super) fn new(fill: &TexturedFill, transform: Option<&RigidTransform>) -> PreparedFill {
        let mesh = Arc::clone(&fill.mesh);
        let mut map = fill.map.clone();
        map.transform = transform.copied();
        let grid_maps: Vec<PlaneMap> = mesh
            .grids
            .iter()
            .map(|g| {
                let s = &g.spec;
                let affine = DMat3::from_cols(
                    s.step_u.extend(0.0),
                    s.step_v.extend(0.0),
                    s.origin.extend(1.0),
                );
                PlaneMap {
                    plane_to_camera: map.plane_to_camera * affine,
                    ..map.clone()
                }
            })
            .collect();
        let orientation = map.orientation_at(DVec2::ZERO);
        let block_boxes = mesh
            .grids
            .iter()
            .zip(&grid_maps)
            .map(|(g, gm)| {
                let (w, h) = (g.width(), g.height());
                let cols = g.blocks_u + 1;
                let mut corners = Vec::with_capacity(cols * (g.blocks_v + 1));
                for by in 0..=g.blocks_v {
                    for bx in 0..=g.blocks_u {
                        let (u, v) = ((bx * BLOCK).min(w), (by * BLOCK).min(h));
                        corners.push(gm.to_image(DVec2::new(u as f64, v as f64)));
                    }
                }
                let mut boxes = Vec::with_capacity(g.blocks_u * g.blocks_v);
                for by in 0..g.blocks_v {
                    for bx in 0..g.blocks_u {
                        let c = [
                            corners[by * cols + bx],
                            corners[by * cols + bx + 1],
                            corners[(by + 1) * cols + bx],
                            corners[(by + 1) * cols + bx + 1],
                        ];
                        boxes.push(bounds(&c, MARGIN_PX));
                    }
                }
                boxes
            })
            .collect();
        let boundary_rows = mesh
            .boundaries
            .iter()
            .map(|b| {
                let first = project(&mesh, &map, &grid_maps, b.vertices[0]);
                let last = project(&mesh, &map, &grid_maps, b.vertices[b.vertices.len() - 1]);
                (
                    first.y.min(last.y) - MARGIN_PX,
                    first.y.max(last.y) + MARGIN_PX,
                )
            })
            .collect();
        PreparedFill {
            mesh,
            map,
            grid_maps,
            orientation,
            block_boxes,
            boundary_rows,
            paper_level: fill.paper_level,
        }
    }

    /// The level map of grid `g`'s values: the paper's level on the paper's grid.
    fn level_of_grid(&self, g: usize) -> Option<&LevelMap> {
        self.paper_level
            .as_ref()
            .filter(|_| self.mesh.inner_grid == Some(g as u8))
    }

    /// The layer's outline in the image (the disc polygon), for its bounds.
    pub(super) fn outline_px(&self) -> Vec<DVec2> {
        self.mesh
            .outline_plane()
            .into_iter()
            .map(|p| self.map.to_image(p))
            .collect()
    }

    /// Adds the layer's coverage deposits into `cov` and its radiance deposits (16-bit
    /// radiance units) into `rad`, both over `window` (rows of `window.width + 1` cells).
    pub(super) fn deposit(
        &self,
        window: &PixelRect,
        cov: &mut [i64],
        rad: &mut [i64],
        scratch: &mut FillScratch,
    ) {
        if window.is_empty() {
            return;
        }
        // Pixel (x, y) covers [x − ½, x + ½] × [y − ½, y + ½].
        let (wx0, wx1) = (window.x0 as f64 - 0.5, window.x1() as f64 - 0.5);
        let (wy0, wy1) = (window.y0 as f64 - 0.5, window.y1() as f64 - 0.5);
        scratch
            .selected
            .resize_with(self.mesh.grids.len(), Vec::new);
        for (boxes, sel) in self.block_boxes.iter().zip(scratch.selected.iter_mut()) {
            sel.clear();
            sel.extend(
                boxes
                    .iter()
                    .map(|b| b[0] <= wx1 && b[2] >= wx0 && b[1] <= wy1 && b[3] >= wy0),
            );
        }
        for g in 0..self.mesh.grids.len() {
            self.deposit_grid(g, window, rad, scratch);
        }
        self.deposit_boundaries(window, (wy0, wy1), cov, rad, scratch);
    }

    /// The grid edges of grid `g` in its selected blocks.
    fn deposit_grid(
        &self,
        g: usize,
        window: &PixelRect,
        rad: &mut [i64],
        scratch: &mut FillScratch,
    ) {
        let grid = &self.mesh.grids[g];
        let gm = &self.grid_maps[g];
        let (w, h) = (grid.width() as i64, grid.height() as i64);
        let texture = &grid.spec.texture;
        let level = self.level_of_grid(g);
        let FillScratch {
            selected, corners, ..
        } = scratch;
        let sel = &selected[g];
        let bu = grid.blocks_u;
        let is_selected = |bx: i64, by: i64| -> bool {
            bx >= 0
                && by >= 0
                && (bx as usize) < bu
                && (by as usize) < grid.blocks_v
                && sel[by as usize * bu + bx as usize]
        };
        // The radiance of texel (i, j) when its block is drawn, else 0.
        let value = |i: i64, j: i64| -> i64 {
            if i < 0
                || j < 0
                || i >= w
                || j >= h
                || !is_selected(i / BLOCK as i64, j / BLOCK as i64)
            {
                return 0;
            }
            let v = texture.values[j as usize * texture.width + i as usize];
            level.map_or(v, |l| l.value(v)) as i64
        };
        let s = self.orientation;
        let skip_outer = grid.outer_lines_are_boundary;
        for by in 0..grid.blocks_v {
            for bx in 0..bu {
                if !sel[by * bu + bx] {
                    continue;
                }
                let class = grid.block_class(bx, by);
                if class == BlockClass::Outside {
                    continue;
                }
                let (k0, l0) = ((bx * BLOCK) as i64, (by * BLOCK) as i64);
                let (k1, l1) = ((k0 + BLOCK as i64).min(w), (l0 + BLOCK as i64).min(h));
                let stride = (k1 - k0 + 1) as usize;
                corners.clear();
                for l in l0..=l1 {
                    for k in k0..=k1 {
                        corners.push(fixed(gm.to_image(DVec2::new(k as f64, l as f64))));
                    }
                }
                let corner =
                    |k: i64, l: i64| corners[(l - l0) as usize * stride + (k - k0) as usize];
                let last_k = if is_selected(bx as i64 + 1, by as i64) {
                    k1 - 1
                } else {
                    k1
                };
                let last_l = if is_selected(bx as i64, by as i64 + 1) {
                    l1 - 1
                } else {
                    l1
                };
                // Vertical unit edges (k, l) → (k, l + 1): texel (k, l) on their −n side.
                for k in k0..=last_k {
                    if skip_outer && (k == 0 || k == w) {
                        continue;
                    }
                    for l in l0..l1 {
                        let arg = s * (value(k, l) - value(k - 1, l));
                        if arg == 0 {
                            continue;
                        }
                        if class == BlockClass::Inside {
                            put(corner(k, l), corner(k, l + 1), arg, window, rad);
                        } else {
                            for iv in &grid.vlines[k as usize] {
                                let (lo, hi) = (iv.lo, iv.hi);
                                if lo >= (l + 1) as f64 || hi <= l as f64 {
                                    continue;
                                }
                                let a = if lo > l as f64 {
                                    self.fixed_vertex(iv.lo_vertex)
                                } else {
                                    corner(k, l)
                                };
                                let b = if hi < (l + 1) as f64 {
                                    self.fixed_vertex(iv.hi_vertex)
                                } else {
                                    corner(k, l + 1)
                                };
                                put(a, b, arg, window, rad);
                            }
                        }
                    }
                }
                // Horizontal unit edges (k, l) → (k + 1, l): texel (k, l − 1) on their −n side.
                for l in l0..=last_l {
                    if skip_outer && (l == 0 || l == h) {
                        continue;
                    }
                    for k in k0..k1 {
                        let arg = s * (value(k, l - 1) - value(k, l));
                        if arg == 0 {
                            continue;
                        }
                        if class == BlockClass::Inside {
                            put(corner(k, l), corner(k + 1, l), arg, window, rad);
                        } else {
                            for iv in &grid.hlines[l as usize] {
                                let (lo, hi) = (iv.lo, iv.hi);
                                if lo >= (k + 1) as f64 || hi <= k as f64 {
                                    continue;
                                }
                                let a = if lo > k as f64 {
                                    self.fixed_vertex(iv.lo_vertex)
                                } else {
                                    corner(k, l)
                                };
                                let b = if hi < (k + 1) as f64 {
                                    self.fixed_vertex(iv.hi_vertex)
                                } else {
                                    corner(k + 1, l)
                                };
                                put(a, b, arg, window, rad);
                            }
                        }
                    }
                }
            }
        }
    }

    /// The boundary polylines that reach the window's rows: their coverage (the outline) and
    /// their radiance jumps.
    fn deposit_boundaries(
        &self,
        window: &PixelRect,
        (wy0, wy1): (f64, f64),
        cov: &mut [i64],
        rad: &mut [i64],
        scratch: &mut FillScratch,
    ) {
        let s = self.orientation;
        let FillScratch {
            selected, polyline, ..
        } = scratch;
        let value = |side: Side| -> i64 {
            match side {
                Side::Uniform(w) => w as i64,
                Side::Paper(w) => self.paper_level.map_or(w, |l| l.value(w)) as i64,
                Side::Empty => 0,
                Side::Texel { grid, i, j } => {
                    let g = &self.mesh.grids[grid as usize];
                    let (bx, by) = (i as usize / BLOCK, j as usize / BLOCK);
                    if selected[grid as usize][by * g.blocks_u + bx] {
                        let v =
                            g.spec.texture.values[j as usize * g.spec.texture.width + i as usize];
                        self.level_of_grid(grid as usize).map_or(v, |l| l.value(v)) as i64
                    } else {
                        0
                    }
                }
            }
        };
        for (b, &(y0, y1)) in self.mesh.boundaries.iter().zip(&self.boundary_rows) {
            if y1 < wy0 || y0 > wy1 {
                continue;
            }
            polyline.clear();
            polyline.extend(b.vertices.iter().map(|&v| self.fixed_vertex(v)));
            for (pair, &(outside, inside)) in polyline.windows(2).zip(&b.sides) {
                if b.outline {
                    put(pair[0], pair[1], -s, window, cov);
                }
                let arg = s * (value(outside) - value(inside));
                if arg != 0 {
                    put(pair[0], pair[1], arg, window, rad);
                }
            }
        }
    }

    fn fixed_vertex(&self, v: Vertex) -> (i64, i64) {
        fixed(project(&self.mesh, &self.map, &self.grid_maps, v))
    }
}

/// The image of vertex `v`: grid corners through their grid's map, plane points through the
/// plane's (the one function each identity always goes through).
fn project(mesh: &TextureMesh, map: &PlaneMap, grid_maps: &[PlaneMap], v: Vertex) -> DVec2 {
    match v {
        Vertex::Corner { grid, k, l } => {
            grid_maps[grid as usize].to_image(DVec2::new(k as f64, l as f64))
        }
        Vertex::Point(i) => map.to_image(mesh.points[i as usize]),
    }
}

/// Deposits the edge a → b with weight `arg` (see `Edge::new`) over `window` into `acc`.
#[inline]
fn put(a: (i64, i64), b: (i64, i64), arg: i64, window: &PixelRect, acc: &mut [i64]) {
    // An edge above, below or right of the window's rows deposits nothing there (`to_fixed`
    // puts pixel row r at [r, r + 1) · ONE).
    let (top, bottom) = (window.y0 * super::ONE, window.y1() * super::ONE);
    if (a.1 <= top && b.1 <= top)
        || (a.1 >= bottom && b.1 >= bottom)
        || a.0.min(b.0) >= window.x1() * super::ONE
    {
        return;
    }
    if let Some(e) = Edge::new(a, b, arg) {
        e.deposit(window, acc);
    }
}

fn bounds(points: &[DVec2], margin: f64) -> [f64; 4] {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in points {
        b[0] = b[0].min(p.x);
        b[1] = b[1].min(p.y);
        b[2] = b[2].max(p.x);
        b[3] = b[3].max(p.y);
    }
    [b[0] - margin, b[1] - margin, b[2] + margin, b[3] + margin]
}
