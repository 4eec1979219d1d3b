//! The pose-independent part of a textured layer: its arrangement in the plane.
//!
//! The layer covers a disc D (a regular n-gon about the plane's origin, the polygon the scene
//! draws for the disc) split into the marker's paper square P and the rest D ∖ P; each part holds
//! either a texture grid or one uniform radiance ([`LayerContent`]). The arrangement's edges
//! are:
//! * **grid edges**: the unit edges of each grid's lines that lie inside the grid's region (the
//!   disc grid's region is D ∖ P, clipped exactly where the region boundary crosses its lines;
//!   the paper grid covers P exactly, its outermost lines being P's boundary);
//! * **boundary polylines**: the edges of D and of P, split at every point where a grid line of
//!   either side crosses them, each sub-segment knowing the piece on each side.
//!
//! Every vertex has one identity — a grid corner, or a point of the plane computed once — so
//! the pieces meeting at an edge share its end points bit for bit after projection and the
//! partition has no gap or overlap in the rasteriser's integers.

use super::{LevelMap, Texture};
use glam::DVec2;
use std::f64::consts::PI;
use std::sync::Arc;

/// Texels per block side: a window visits the blocks whose image can reach it.
pub const BLOCK: usize = 16;

/// A texture grid placed in the plane: texel (i, j) covers the parallelogram
/// origin + [i, i + 1]·step_u + [j, j + 1]·step_v (grid-line coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct GridSpec {
    pub texture: Arc<Texture>,
    /// Plane point of the texture's outer corner before texel (0, 0), metres.
    pub origin: DVec2,
    /// Plane vector of one texel along the texture's rows (u, columns increase) and columns
    /// (v, rows increase), metres; u × v must keep the plane's orientation.
    pub step_u: DVec2,
    pub step_v: DVec2,
}

impl GridSpec {
    /// The plane point at grid-line coordinates (u, v).
    #[inline]
    pub fn plane_at(&self, u: f64, v: f64) -> DVec2 {
        self.origin + u * self.step_u + v * self.step_v
    }

    /// Grid-line coordinates of plane point `p`.
    pub fn grid_at(&self, p: DVec2) -> DVec2 {
        let d = p - self.origin;
        let det = self.step_u.perp_dot(self.step_v);
        DVec2::new(d.perp_dot(self.step_v) / det, self.step_u.perp_dot(d) / det)
    }

    fn texel_size(&self) -> f64 {
        self.step_u.length().min(self.step_v.length())
    }
}

/// What fills one part of the layer.
#[derive(Debug, Clone, PartialEq)]
pub enum LayerContent {
    Grid(GridSpec),
    /// One radiance, as a 16-bit value (radiance × 65535, rounded).
    Uniform(u16),
}

/// Why a mesh cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    #[error("the {what} texture ({width}x{height} texels) does not cover {region}")]
    TextureTooSmall {
        what: &'static str,
        width: usize,
        height: usize,
        region: &'static str,
    },
    #[error("the marker's paper reaches the disc's rim (it must lie inside the disc's outline)")]
    PaperOutsideDisc,
    #[error("the paper texture's grid must span the marker's paper exactly (corner {corner} is {miss_mm:.4} mm off)")]
    PaperGridMisplaced { corner: usize, miss_mm: f64 },
    #[error("a textured layer needs a texture in at least one part")]
    NoTexture,
}

/// A vertex of the arrangement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Vertex {
    /// Grid corner (k, l) of grid `grid` (grid-line coordinates).
    Corner { grid: u8, k: i32, l: i32 },
    /// A plane point of [`TextureMesh::points`].
    Point(u32),
}

/// The piece on one side of a boundary sub-segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Side {
    Texel {
        grid: u8,
        i: i32,
        j: i32,
    },
    Uniform(u16),
    /// The uniform marker paper (the inner part), which a [`super::LevelMap`] maps.
    Paper(u16),
    Empty,
}

/// One edge of D or P as a polyline, directed with the part it bounds on its +n side (n the
/// direction turned by +90°, x right and y down).
#[derive(Debug, Clone)]
pub(crate) struct Boundary {
    pub vertices: Vec<Vertex>,
    /// Per sub-segment: the piece on its −n side (outside) and on its +n side (inside).
    pub sides: Vec<(Side, Side)>,
    /// Part of D's outline: its sub-segments carry the layer's coverage.
    pub outline: bool,
}

/// A stretch of a grid line inside its grid's region, in the line's coordinate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Interval {
    pub lo: f64,
    pub hi: f64,
    pub lo_vertex: Vertex,
    pub hi_vertex: Vertex,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BlockClass {
    /// No piece of the block lies in the region.
    Outside,
    /// The whole (closed) block lies inside the region: its unit edges are drawn whole.
    Inside,
    /// A region boundary crosses the block: its unit edges are clipped by the line intervals.
    Mixed,
}

/// One grid with its clipping.
#[derive(Debug, Clone)]
pub(crate) struct Grid {
    pub spec: GridSpec,
    pub blocks_u: usize,
    pub blocks_v: usize,
    pub class: Vec<BlockClass>,
    /// Inside intervals of vertical line k (k = 0 ..= width), along v.
    pub vlines: Vec<Vec<Interval>>,
    /// Inside intervals of horizontal line l (l = 0 ..= height), along u.
    pub hlines: Vec<Vec<Interval>>,
    /// The outermost lines are the region's boundary (the paper grid): never grid edges.
    pub outer_lines_are_boundary: bool,
}

impl Grid {
    pub fn width(&self) -> usize {
        self.spec.texture.width
    }

    pub fn height(&self) -> usize {
        self.spec.texture.height
    }

    pub fn block_class(&self, bu: usize, bv: usize) -> BlockClass {
        self.class[bv * self.blocks_u + bu]
    }
}

/// A textured layer's arrangement (see the module docs).
#[derive(Debug, Clone)]
pub struct TextureMesh {
    pub(crate) grids: Vec<Grid>,
    pub(crate) points: Vec<DVec2>,
    pub(crate) boundaries: Vec<Boundary>,
    disc_radius: f64,
    disc_sides: usize,
    paper: [DVec2; 4],
    outer: LayerContent,
    inner: LayerContent,
    /// The paper's grid, when the paper is textured.
    pub(crate) inner_grid: Option<u8>,
}

/// Relative tolerance (of a texel) within which a point counts as on a boundary or a grid line.
const SNAP: f64 = 1e-9;

impl TextureMesh {
    /// The arrangement of a disc of `disc_radius` (plane units) drawn as the regular
    /// `disc_sides`-gon with vertex k at angle 2πk/n (x towards y), split by the paper square
    /// `paper` (corners in printed order: top-left, top-right, bottom-right, bottom-left) into
    /// `outer` (the disc around the paper) and `inner` (the paper). A paper grid must span the
    /// paper exactly (its outer corners on `paper`'s corners).
    pub fn new(
        disc_radius: f64,
        disc_sides: usize,
        paper: [DVec2; 4],
        outer: LayerContent,
        inner: LayerContent,
    ) -> Result<TextureMesh, MeshError> {
        let mut mesh = TextureMesh {
            grids: Vec::new(),
            points: Vec::new(),
            boundaries: Vec::new(),
            disc_radius,
            disc_sides: disc_sides.max(3),
            paper,
            outer,
            inner,
            inner_grid: None,
        };
        if matches!(
            (&mesh.outer, &mesh.inner),
            (LayerContent::Uniform(_), LayerContent::Uniform(_))
        ) {
            return Err(MeshError::NoTexture);
        }
        if paper.iter().any(|&p| mesh.disc_distance(p) <= 0.0) {
            return Err(MeshError::PaperOutsideDisc);
        }
        let outer_grid = mesh.add_outer_grid()?;
        let inner_grid = mesh.add_inner_grid()?;
        mesh.inner_grid = inner_grid;
        mesh.build_boundaries(outer_grid, inner_grid);
        if let Some(g) = outer_grid {
            mesh.build_line_intervals(g);
        }
        Ok(mesh)
    }

    /// The disc's outline vertices in the plane (vertex k at angle 2πk/n).
    pub fn outline_plane(&self) -> Vec<DVec2> {
        (0..self.disc_sides).map(|k| self.disc_vertex(k)).collect()
    }

    /// The paper's corners in the plane (printed order).
    pub fn paper_plane(&self) -> [DVec2; 4] {
        self.paper
    }

    /// Whether the paper is one uniform piece (the marker's ink is then drawn over the layer).
    pub fn paper_is_uniform(&self) -> bool {
        matches!(self.inner, LayerContent::Uniform(_))
    }

    /// The uniform paper's radiance, when the paper is uniform.
    pub fn paper_radiance(&self) -> Option<f32> {
        match self.inner {
            LayerContent::Uniform(w) => Some(super::radiance_of(w)),
            LayerContent::Grid(_) => None,
        }
    }

    /// Whether plane point `p` lies inside the disc's outline.
    pub fn in_disc(&self, p: DVec2) -> bool {
        self.disc_distance(p) >= 0.0
    }

    /// The layer's radiance at plane point `p`, the disc's part continued beyond its rim,
    /// sampling a texture bilinearly between texel centres (edge-clamped) when `bilinear`, else
    /// piecewise constant.
    pub fn radiance_at(&self, p: DVec2, bilinear: bool) -> Option<f32> {
        self.radiance_with(p, bilinear, None)
    }

    /// As [`Self::radiance_at`], the paper's radiance mapped by `level` when one is given.
    pub fn radiance_with(&self, p: DVec2, bilinear: bool, level: Option<&LevelMap>) -> Option<f32> {
        let on_paper = self.paper_distance(p) >= 0.0;
        let r = self.content_radiance(
            if on_paper { &self.inner } else { &self.outer },
            p,
            bilinear,
        );
        Some(match level {
            Some(l) if on_paper => l.radiance(r as f64) as f32,
            _ => r,
        })
    }

    fn content_radiance(&self, content: &LayerContent, p: DVec2, bilinear: bool) -> f32 {
        match content {
            LayerContent::Uniform(w) => super::radiance_of(*w),
            LayerContent::Grid(g) => {
                let q = g.grid_at(p);
                let t = &g.texture;
                if !bilinear {
                    t.radiance_clamped(q.x.floor() as i64, q.y.floor() as i64)
                } else {
                    let (x, y) = (q.x - 0.5, q.y - 0.5);
                    let (i, j) = (x.floor(), y.floor());
                    let (fx, fy) = ((x - i) as f32, (y - j) as f32);
                    let (i, j) = (i as i64, j as i64);
                    let a =
                        t.radiance_clamped(i, j) * (1.0 - fx) + t.radiance_clamped(i + 1, j) * fx;
                    let b = t.radiance_clamped(i, j + 1) * (1.0 - fx)
                        + t.radiance_clamped(i + 1, j + 1) * fx;
                    a * (1.0 - fy) + b * fy
                }
            }
        }
    }

    fn disc_vertex(&self, k: usize) -> DVec2 {
        let a = 2.0 * PI * (k % self.disc_sides) as f64 / self.disc_sides as f64;
        self.disc_radius * DVec2::new(a.cos(), a.sin())
    }

    /// Signed distance of `p` inside the disc polygon (positive inside), measured to the edge
    /// of its sector: the polygon is convex and star-shaped about the origin.
    fn disc_distance(&self, p: DVec2) -> f64 {
        let n = self.disc_sides as f64;
        let a = p.y.atan2(p.x).rem_euclid(2.0 * PI);
        let k = ((a / (2.0 * PI) * n).floor() as usize).min(self.disc_sides - 1);
        inside_distance(self.disc_vertex(k), self.disc_vertex(k + 1), p)
    }

    /// Signed distance of `p` inside the paper square (positive inside).
    fn paper_distance(&self, p: DVec2) -> f64 {
        (0..4)
            .map(|e| inside_distance(self.paper[e], self.paper[(e + 1) % 4], p))
            .fold(f64::INFINITY, f64::min)
    }

    fn add_outer_grid(&mut self) -> Result<Option<u8>, MeshError> {
        let LayerContent::Grid(spec) = self.outer.clone() else {
            return Ok(None);
        };
        let (w, h) = (spec.texture.width, spec.texture.height);
        let covers = (0..self.disc_sides).all(|k| {
            let q = spec.grid_at(self.disc_vertex(k));
            q.x >= 0.0 && q.y >= 0.0 && q.x <= w as f64 && q.y <= h as f64
        });
        if !covers {
            return Err(MeshError::TextureTooSmall {
                what: "disc",
                width: w,
                height: h,
                region: "the disc",
            });
        }
        let eps = SNAP * spec.texel_size();
        let (bu, bv) = (w.div_ceil(BLOCK), h.div_ceil(BLOCK));
        let mut class = Vec::with_capacity(bu * bv);
        for by in 0..bv {
            for bx in 0..bu {
                let (u0, v0) = ((bx * BLOCK) as f64, (by * BLOCK) as f64);
                let (u1, v1) = (
                    ((bx + 1) * BLOCK).min(w) as f64,
                    ((by + 1) * BLOCK).min(h) as f64,
                );
                let sq = [
                    spec.plane_at(u0, v0),
                    spec.plane_at(u1, v0),
                    spec.plane_at(u1, v1),
                    spec.plane_at(u0, v1),
                ];
                class.push(self.classify_block(&sq, eps));
            }
        }
        self.grids.push(Grid {
            spec,
            blocks_u: bu,
            blocks_v: bv,
            class,
            vlines: Vec::new(),
            hlines: Vec::new(),
            outer_lines_are_boundary: false,
        });
        Ok(Some((self.grids.len() - 1) as u8))
    }

    /// Where a block of the disc grid (its plane corners `sq`) lies against D ∖ P.
    fn classify_block(&self, sq: &[DVec2; 4], eps: f64) -> BlockClass {
        let nearest = nearest_to_origin(sq);
        if nearest > self.disc_radius + eps || sq.iter().all(|&p| self.paper_distance(p) > eps) {
            return BlockClass::Outside;
        }
        let in_disc = sq.iter().all(|&p| self.disc_distance(p) > eps);
        if in_disc && separated(sq, &self.paper, eps) {
            BlockClass::Inside
        } else {
            BlockClass::Mixed
        }
    }

    fn add_inner_grid(&mut self) -> Result<Option<u8>, MeshError> {
        let LayerContent::Grid(spec) = self.inner.clone() else {
            return Ok(None);
        };
        let (w, h) = (spec.texture.width, spec.texture.height);
        let corners = [
            spec.plane_at(0.0, 0.0),
            spec.plane_at(w as f64, 0.0),
            spec.plane_at(w as f64, h as f64),
            spec.plane_at(0.0, h as f64),
        ];
        let tol = 1e-6 * spec.texel_size();
        for (c, (a, b)) in corners.iter().zip(&self.paper).enumerate() {
            let miss = a.distance(*b);
            if miss > tol {
                return Err(MeshError::PaperGridMisplaced {
                    corner: c,
                    miss_mm: miss * 1e3,
                });
            }
        }
        // The paper's corners are the grid's: one identity each.
        self.paper = corners;
        let (bu, bv) = (w.div_ceil(BLOCK), h.div_ceil(BLOCK));
        self.grids.push(Grid {
            spec,
            blocks_u: bu,
            blocks_v: bv,
            class: vec![BlockClass::Inside; bu * bv],
            vlines: Vec::new(),
            hlines: Vec::new(),
            outer_lines_are_boundary: true,
        });
        Ok(Some((self.grids.len() - 1) as u8))
    }

    fn add_point(&mut self, p: DVec2) -> Vertex {
        self.points.push(p);
        Vertex::Point((self.points.len() - 1) as u32)
    }

    /// The plane position of a vertex.
    pub(crate) fn vertex_plane(&self, v: Vertex) -> DVec2 {
        match v {
            Vertex::Corner { grid, k, l } => {
                self.grids[grid as usize].spec.plane_at(k as f64, l as f64)
            }
            Vertex::Point(i) => self.points[i as usize],
        }
    }

    /// The boundary polylines of D and P with their crossings and sides.
    fn build_boundaries(&mut self, outer_grid: Option<u8>, inner_grid: Option<u8>) {
        // D's outline.
        let n = self.disc_sides;
        let disc_ids: Vec<Vertex> = (0..n)
            .map(|k| self.add_point(self.disc_vertex(k)))
            .collect();
        if let Some(g) = outer_grid {
            for &v in &disc_ids {
                self.vertex_on_lines(g, v);
            }
        }
        for k in 0..n {
            let (a, b) = (disc_ids[k], disc_ids[(k + 1) % n]);
            let mut stops = vec![(0.0, a)];
            if let Some(g) = outer_grid {
                stops.extend(self.crossings(g, a, b));
            }
            self.push_boundary(stops, b, true);
        }
        // P's edges.
        let paper_ids: [Vertex; 4] = match inner_grid {
            Some(g) => {
                let (w, h) = (
                    self.grids[g as usize].width() as i32,
                    self.grids[g as usize].height() as i32,
                );
                [(0, 0), (w, 0), (w, h), (0, h)].map(|(k, l)| Vertex::Corner { grid: g, k, l })
            }
            None => self.paper.map(|p| self.add_point(p)),
        };
        if let Some(g) = outer_grid {
            for &v in &paper_ids {
                self.vertex_on_lines(g, v);
            }
        }
        for e in 0..4 {
            let (a, b) = (paper_ids[e], paper_ids[(e + 1) % 4]);
            let mut stops = vec![(0.0, a)];
            if let Some(g) = outer_grid {
                stops.extend(self.crossings(g, a, b));
            }
            if let Some(g) = inner_grid {
                stops.extend(self.paper_grid_corners(g, e));
            }
            self.push_boundary(stops, b, false);
        }
    }

    /// The inner grid's corners strictly inside paper edge `e` (t = k / N along it).
    fn paper_grid_corners(&self, g: u8, e: usize) -> Vec<(f64, Vertex)> {
        let (w, h) = (
            self.grids[g as usize].width() as i32,
            self.grids[g as usize].height() as i32,
        );
        let corner = |k: i32, l: i32| Vertex::Corner { grid: g, k, l };
        match e {
            0 => (1..w)
                .map(|k| (k as f64 / w as f64, corner(k, 0)))
                .collect(),
            1 => (1..h)
                .map(|l| (l as f64 / h as f64, corner(w, l)))
                .collect(),
            2 => (1..w)
                .map(|k| (k as f64 / w as f64, corner(w - k, h)))
                .collect(),
            _ => (1..h)
                .map(|l| (l as f64 / h as f64, corner(0, h - l)))
                .collect(),
        }
    }

    /// Records polygon vertex `v` on the lines of grid `g` it lies on (to [`SNAP`]): a line
    /// through a vertex whose edges run along it or end on it has its inside stretches split
    /// there.
    fn vertex_on_lines(&mut self, g: u8, v: Vertex) {
        let p = self.vertex_plane(v);
        let grid = &mut self.grids[g as usize];
        let q = grid.spec.grid_at(p);
        let (w, h) = (grid.width() as f64, grid.height() as f64);
        if grid.vlines.is_empty() {
            grid.vlines = vec![Vec::new(); w as usize + 1];
            grid.hlines = vec![Vec::new(); h as usize + 1];
        }
        let at = |c: f64| Interval {
            lo: c,
            hi: c,
            lo_vertex: v,
            hi_vertex: v,
        };
        if (q.x - q.x.round()).abs() < SNAP && q.x.round() >= 0.0 && q.x.round() <= w {
            grid.vlines[q.x.round() as usize].push(at(q.y));
        }
        if (q.y - q.y.round()).abs() < SNAP && q.y.round() >= 0.0 && q.y.round() <= h {
            grid.hlines[q.y.round() as usize].push(at(q.x));
        }
    }

    /// Where the lines of grid `g` cross the segment a → b strictly between its ends, each
    /// crossing a new plane point or, when it falls on a grid corner, that corner. Records the
    /// crossings on the grid lines too.
    fn crossings(&mut self, g: u8, a: Vertex, b: Vertex) -> Vec<(f64, Vertex)> {
        let (pa, pb) = (self.vertex_plane(a), self.vertex_plane(b));
        let spec = self.grids[g as usize].spec.clone();
        let (w, h) = (spec.texture.width as i64, spec.texture.height as i64);
        let (qa, qb) = (spec.grid_at(pa), spec.grid_at(pb));
        let mut out = Vec::new();
        let mut line_hits: Vec<(bool, i64, f64, Vertex)> = Vec::new();
        for vertical in [true, false] {
            let (ca, cb) = if vertical { (qa.x, qb.x) } else { (qa.y, qb.y) };
            if ca == cb {
                continue;
            }
            let limit = if vertical { w } else { h };
            let lo = ca.min(cb).ceil().max(0.0) as i64;
            let hi = ca.max(cb).floor().min(limit as f64) as i64;
            for line in lo..=hi {
                let t = (line as f64 - ca) / (cb - ca);
                // The end points are the polygon's vertices, recorded on the lines they lie on
                // by `vertex_on_lines`.
                if !(t > 0.0 && t < 1.0) {
                    continue;
                }
                let along = if vertical {
                    qa.y + t * (qb.y - qa.y)
                } else {
                    qa.x + t * (qb.x - qa.x)
                };
                let snapped = along.round();
                let vertex = if (along - snapped).abs() < SNAP {
                    let (k, l) = if vertical {
                        (line, snapped as i64)
                    } else {
                        (snapped as i64, line)
                    };
                    Vertex::Corner {
                        grid: g,
                        k: k as i32,
                        l: l as i32,
                    }
                } else {
                    self.add_point(pa + t * (pb - pa))
                };
                let along = if matches!(vertex, Vertex::Corner { .. }) {
                    snapped
                } else {
                    along
                };
                out.push((t, vertex));
                line_hits.push((vertical, line, along, vertex));
            }
        }
        let grid = &mut self.grids[g as usize];
        if grid.vlines.is_empty() {
            grid.vlines = vec![Vec::new(); w as usize + 1];
            grid.hlines = vec![Vec::new(); h as usize + 1];
        }
        // Crossings are collected as degenerate intervals first; `build_line_intervals` sorts
        // them and turns them into the inside stretches.
        for (vertical, line, along, v) in line_hits {
            let lines = if vertical {
                &mut grid.vlines
            } else {
                &mut grid.hlines
            };
            lines[line as usize].push(Interval {
                lo: along,
                hi: along,
                lo_vertex: v,
                hi_vertex: v,
            });
        }
        out
    }

    /// Sorts the stops of one boundary edge (from `stops[0]`), appends its end `last`, drops
    /// repeated vertices and assigns each sub-segment its sides.
    fn push_boundary(&mut self, mut stops: Vec<(f64, Vertex)>, last: Vertex, outline: bool) {
        stops[1..].sort_by(|x, y| x.0.total_cmp(&y.0));
        stops.push((1.0, last));
        let mut vertices: Vec<Vertex> = Vec::with_capacity(stops.len());
        for (_, v) in stops {
            if vertices.last() != Some(&v) {
                vertices.push(v);
            }
        }
        let sides = vertices
            .windows(2)
            .map(|pair| {
                let (pa, pb) = (self.vertex_plane(pair[0]), self.vertex_plane(pair[1]));
                let d = pb - pa;
                if d.length() == 0.0 {
                    return (Side::Empty, Side::Empty);
                }
                let normal = DVec2::new(-d.y, d.x) / d.length();
                let mid = 0.5 * (pa + pb);
                let step = 1e-6 * self.min_texel();
                let (outside, inside) = (mid - step * normal, mid + step * normal);
                if outline {
                    (Side::Empty, self.side_of(&self.outer, 0, inside))
                } else {
                    let og = 0;
                    let ig = if matches!(self.outer, LayerContent::Grid(_)) {
                        1
                    } else {
                        0
                    };
                    let inside = match self.side_of(&self.inner, ig, inside) {
                        Side::Uniform(w) => Side::Paper(w),
                        side => side,
                    };
                    (self.side_of(&self.outer, og, outside), inside)
                }
            })
            .collect();
        self.boundaries.push(Boundary {
            vertices,
            sides,
            outline,
        });
    }

    fn min_texel(&self) -> f64 {
        self.grids
            .iter()
            .map(|g| g.spec.texel_size())
            .fold(f64::INFINITY, f64::min)
    }

    /// The piece of `content` (grid index `g` when a grid) at plane point `p`.
    fn side_of(&self, content: &LayerContent, g: u8, p: DVec2) -> Side {
        match content {
            LayerContent::Uniform(w) => Side::Uniform(*w),
            LayerContent::Grid(spec) => {
                let q = spec.grid_at(p);
                let (i, j) = (q.x.floor() as i64, q.y.floor() as i64);
                if spec.texture.get(i, j).is_some() {
                    Side::Texel {
                        grid: g,
                        i: i as i32,
                        j: j as i32,
                    }
                } else {
                    Side::Empty
                }
            }
        }
    }

    /// Turns the crossings recorded on each line of grid `g` (the disc grid) into the
    /// stretches of the line inside D ∖ P.
    fn build_line_intervals(&mut self, g: u8) {
        let spec = self.grids[g as usize].spec.clone();
        let (w, h) = (spec.texture.width, spec.texture.height);
        let eps = SNAP * spec.texel_size();
        let grid = &mut self.grids[g as usize];
        let mut vlines = std::mem::take(&mut grid.vlines);
        let mut hlines = std::mem::take(&mut grid.hlines);
        if vlines.is_empty() {
            vlines = vec![Vec::new(); w + 1];
            hlines = vec![Vec::new(); h + 1];
        }
        for (vertical, lines, length) in [(true, &mut vlines, h), (false, &mut hlines, w)] {
            for (line, hits) in lines.iter_mut().enumerate() {
                let mut stops: Vec<(f64, Vertex)> =
                    hits.iter().map(|i| (i.lo, i.lo_vertex)).collect();
                stops.sort_by(|a, b| a.0.total_cmp(&b.0));
                let corner = |along: usize| {
                    let (k, l) = if vertical {
                        (line, along)
                    } else {
                        (along, line)
                    };
                    Vertex::Corner {
                        grid: g,
                        k: k as i32,
                        l: l as i32,
                    }
                };
                let mut bounds = vec![(0.0, corner(0))];
                bounds.extend(
                    stops
                        .into_iter()
                        .filter(|s| s.0 > 0.0 && s.0 < length as f64),
                );
                bounds.push((length as f64, corner(length)));
                let mut inside = Vec::new();
                for pair in bounds.windows(2) {
                    let ((lo, lv), (hi, hv)) = (pair[0], pair[1]);
                    if hi - lo <= 2.0 * SNAP {
                        continue;
                    }
                    let mid = 0.5 * (lo + hi);
                    let p = if vertical {
                        spec.plane_at(line as f64, mid)
                    } else {
                        spec.plane_at(mid, line as f64)
                    };
                    if self_distance(self.disc_radius, self.disc_sides, &self.paper, p, eps) {
                        inside.push(Interval {
                            lo,
                            hi,
                            lo_vertex: lv,
                            hi_vertex: hv,
                        });
                    }
                }
                *hits = inside;
            }
        }
        let grid = &mut self.grids[g as usize];
        grid.vlines = vlines;
        grid.hlines = hlines;
    }
}

/// Whether `p` lies inside the regular disc polygon and outside the paper, both by more than
/// `eps` (a point on a boundary is on neither side).
fn self_distance(radius: f64, sides: usize, paper: &[DVec2; 4], p: DVec2, eps: f64) -> bool {
    let n = sides as f64;
    let vertex = |k: usize| {
        let a = 2.0 * PI * (k % sides) as f64 / n;
        radius * DVec2::new(a.cos(), a.sin())
    };
    let a = p.y.atan2(p.x).rem_euclid(2.0 * PI);
    let k = ((a / (2.0 * PI) * n).floor() as usize).min(sides - 1);
    let in_disc = inside_distance(vertex(k), vertex(k + 1), p) > eps;
    let in_paper = (0..4)
        .map(|e| inside_distance(paper[e], paper[(e + 1) % 4], p))
        .fold(f64::INFINITY, f64::min);
    in_disc && in_paper < -eps
}

/// Signed distance of `p` from the line a → b, positive on its +n side (n = direction turned
/// by +90°, x right and y down).
fn inside_distance(a: DVec2, b: DVec2, p: DVec2) -> f64 {
    let d = b - a;
    let len = d.length();
    if len == 0.0 {
        return 0.0;
    }
    d.perp_dot(p - a) / len
}

/// Distance from the origin to the nearest point of the convex quadrilateral `sq`.
fn nearest_to_origin(sq: &[DVec2; 4]) -> f64 {
    let inside = (0..4).all(|e| inside_distance(sq[e], sq[(e + 1) % 4], DVec2::ZERO) >= 0.0)
        || (0..4).all(|e| inside_distance(sq[e], sq[(e + 1) % 4], DVec2::ZERO) <= 0.0);
    if inside {
        return 0.0;
    }
    (0..4)
        .map(|e| {
            let (a, b) = (sq[e], sq[(e + 1) % 4]);
            let d = b - a;
            let t = (-a.dot(d) / d.length_squared()).clamp(0.0, 1.0);
            (a + t * d).length()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Whether two convex quadrilaterals are apart by more than `eps` along one of their edge
/// normals (separating axes).
fn separated(a: &[DVec2; 4], b: &[DVec2; 4], eps: f64) -> bool {
    let axes = (0..4)
        .map(|e| a[(e + 1) % 4] - a[e])
        .chain((0..4).map(|e| b[(e + 1) % 4] - b[e]));
    for d in axes {
        let len = d.length();
        if len == 0.0 {
            continue;
        }
        let n = DVec2::new(-d.y, d.x) / len;
        let (amin, amax) = a
            .iter()
            .map(|p| n.dot(*p))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
        let (bmin, bmax) = b
            .iter()
            .map(|p| n.dot(*p))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
        if amax + eps < bmin || bmax + eps < amin {
            return true;
        }
    }
    false
}
