//! The composed scene: wheel pose → render layers (`SceneAt`) and ground-truth image positions.

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use thiserror::Error;

use super::geometry::{black_rectangles, CellRect, PlacedMarker};
use super::tessellate::{projected_quad, subdivisions};
use super::SceneConfig;
use crate::camera::Camera;
use crate::marker::cells;
use crate::render::shapes::{Layer, Polygon, SceneAt, SceneSnapshot};
use crate::render::texture::{
    value_of, BackgroundTexture, GridSpec, LayerContent, LevelMap, PlaneMap, TextureMesh,
    TexturedFill,
};
use crate::validation::Problems;
use std::sync::Arc;

/// Polygons follow the exact image of every edge within this distance, px.
pub const TOLERANCE_PX: f64 = 0.001;

/// The driven wheel at one instant, as the mechanism module reports it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WheelPose {
    /// Rotation of the driven disc, rad, from +x towards +y (clockwise in the image).
    pub theta2_rad: f64,
    /// Displacement of the disc centre from the nominal rotation centre in the plane, m.
    pub centre_offset_m: [f64; 2],
}

/// Axis-aligned bounding box in pixels (OpenCV convention).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundingBox {
    pub min_px: DVec2,
    pub max_px: DVec2,
}

/// Why a scene cannot be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SceneError {
    #[error("invalid scene configuration: {0}")]
    Invalid(String),
    #[error("{0}: part of it is not in front of the camera")]
    BehindCamera(String),
}

/// One printed marker: its cell grid and the black cells merged into rectangles.
#[derive(Debug, Clone, PartialEq)]
struct MarkerArt {
    side_cells: usize,
    border_bits: usize,
    rects: Vec<CellRect>,
    size_m: f64,
    margin_m: f64,
}

impl MarkerArt {
    fn new(
        dict: crate::marker::Dictionary,
        id: usize,
        border_bits: usize,
        size_mm: f64,
        margin_mm: f64,
    ) -> Result<Self, SceneError> {
        let grid = cells(dict, id, border_bits).map_err(|e| SceneError::Invalid(e.to_string()))?;
        Ok(MarkerArt {
            side_cells: grid.len(),
            border_bits,
            rects: black_rectangles(&grid),
            size_m: size_mm * 1e-3,
            margin_m: margin_mm * 1e-3,
        })
    }
}

/// The scene seen by one camera; pure and thread-safe.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    config: SceneConfig,
    camera: Camera,
    marker: MarkerArt,
    reference: Option<(MarkerArt, PlacedMarker)>,
    distorted: bool,
    /// The disc outline with the wheel axis where it belongs (no runout): the renderer asks
    /// for a snapshot per row and per exposure sample, and rebuilding thousands of rim
    /// vertices each time would dominate rendering.
    disc_at_rest: Polygon,
    /// The textured disc (`scene.appearance` with a disc or marker texture).
    textured: Option<TexturedDisc>,
    background: Option<Arc<BackgroundTexture>>,
}

/// A disc drawn from textures: its arrangement in the wheel's frame, and the camera's map of
/// the world plane (z = 0) to camera coordinates, x·ex + y·ey + origin.
#[derive(Debug, Clone)]
struct TexturedDisc {
    mesh: Arc<TextureMesh>,
    ex: DVec3,
    ey: DVec3,
    origin: DVec3,
}

impl PartialEq for TexturedDisc {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.mesh, &other.mesh)
            && (self.ex, self.ey, self.origin) == (other.ex, other.ey, other.origin)
    }
}

impl Scene {
    pub fn new(config: &SceneConfig, camera: Camera) -> Result<Scene, SceneError> {
        let mut problems = Problems::new();
        config.validate("scene", &mut problems);
        if !problems.is_empty() {
            let msg: Vec<String> = problems.iter().map(|p| p.to_string()).collect();
            return Err(SceneError::Invalid(msg.join("; ")));
        }
        let m = &config.marker;
        let marker = MarkerArt::new(
            m.dictionary,
            m.id,
            m.border_bits,
            m.size_mm,
            m.white_margin_mm,
        )?;
        let reference = if config.reference_marker.enabled {
            let r = &config.reference_marker;
            let art = MarkerArt::new(
                r.dictionary,
                r.id,
                r.border_bits,
                r.size_mm,
                r.white_margin_mm,
            )?;
            let centre = DVec2::from(r.position_mm) * 1e-3;
            let placed = PlacedMarker::new(
                centre,
                r.orientation_deg.to_radians(),
                art.size_m,
                art.margin_m,
            );
            Some((art, placed))
        } else {
            None
        };
        let rim_m = config.disc_radius_mm * 1e-3;
        for k in 0..720 {
            let a = 2.0 * PI * k as f64 / 720.0;
            if camera
                .try_project(DVec3::new(rim_m * a.cos(), rim_m * a.sin(), 0.0))
                .is_none()
            {
                return Err(SceneError::BehindCamera("scene.disc_radius_mm".into()));
            }
        }
        if let Some((_, placed)) = &reference {
            if placed
                .paper_corners_m()
                .iter()
                .any(|&p| camera.try_project(p).is_none())
            {
                return Err(SceneError::BehindCamera("scene.reference_marker".into()));
            }
        }
        let distorted = camera.config().lens_distortion.enabled;
        let mut scene = Scene {
            config: config.clone(),
            camera,
            marker,
            reference,
            distorted,
            disc_at_rest: Polygon {
                vertices_px: Vec::new(),
            },
            textured: None,
            background: None,
        };
        scene.disc_at_rest = scene.build_disc_polygon([0.0, 0.0]);
        scene.attach_appearance()?;
        Ok(scene)
    }

    /// Builds the textured disc and the background from `scene.appearance`'s textures.
    fn attach_appearance(&mut self) -> Result<(), SceneError> {
        let a = &self.config.appearance;
        let l = &a.loaded;
        let unloaded = (a.disc_file.is_some() && l.disc.is_none())
            || (a.marker_file.is_some() && l.marker.is_none())
            || (a.background_file.is_some() && l.background.is_none());
        if unloaded {
            return Err(SceneError::Invalid(
                "scene.appearance names textures that were not read (scenarios read them when \
                 loaded)"
                    .into(),
            ));
        }
        if let Some(bg) = &l.background {
            let size = (
                self.camera.width_px() as usize,
                self.camera.height_px() as usize,
            );
            if (bg.0.width, bg.0.height) != size {
                return Err(SceneError::Invalid(format!(
                    "scene.appearance.background_file: {}x{} texels for a {}x{} px camera",
                    bg.0.width, bg.0.height, size.0, size.1
                )));
            }
            self.background = Some(Arc::clone(bg));
        }
        if l.disc.is_none() && l.marker.is_none() {
            return Ok(());
        }
        let c = &self.config;
        let rest = self.placed_marker(&WheelPose::default());
        let outer = match &l.disc {
            Some(t) => {
                let s_m = a.disc_mm_per_texel * 1e-3;
                let [cu, cv] = a
                    .disc_centre_texel
                    .unwrap_or([(t.width as f64 - 1.0) / 2.0, (t.height as f64 - 1.0) / 2.0]);
                LayerContent::Grid(GridSpec {
                    texture: Arc::clone(t),
                    origin: -DVec2::new(cu + 0.5, cv + 0.5) * s_m,
                    step_u: DVec2::new(s_m, 0.0),
                    step_v: DVec2::new(0.0, s_m),
                })
            }
            None => LayerContent::Uniform(value_of(c.disc_radiance)),
        };
        // A marker texture spans the paper itself (the black square without a margin); a
        // uniform paper is the one the marker layers draw.
        let paper = if l.marker.is_some() {
            rest.paper_corners_m()
        } else {
            self.paper_corners_m(&self.marker, &rest)
        }
        .map(|p| p.truncate());
        let inner = match &l.marker {
            Some(t) => {
                let cells = self.marker.side_cells as f64;
                let tpc = a.marker_texels_per_cell as f64;
                let margin = super::MarkerTexels::new(
                    self.marker.side_cells,
                    c.marker.size_mm,
                    c.marker.white_margin_mm,
                    a.marker_texels_per_cell,
                )
                .margin
                .round();
                let per_texel = 1.0 / (cells * tpc);
                let o = rest.at(-margin * per_texel, -margin * per_texel).truncate();
                LayerContent::Grid(GridSpec {
                    texture: Arc::clone(t),
                    origin: o,
                    step_u: rest.at(per_texel, 0.0).truncate() - rest.at(0.0, 0.0).truncate(),
                    step_v: rest.at(0.0, per_texel).truncate() - rest.at(0.0, 0.0).truncate(),
                })
            }
            None => LayerContent::Uniform(value_of(c.paper_radiance)),
        };
        let mesh = TextureMesh::new(
            c.disc_radius_mm * 1e-3,
            self.disc_at_rest.vertices_px.len(),
            paper,
            outer,
            inner,
        )
        .map_err(|e| SceneError::Invalid(format!("scene.appearance: {e}")))?;
        let origin = self.camera.to_camera_m(DVec3::ZERO);
        self.textured = Some(TexturedDisc {
            mesh: Arc::new(mesh),
            ex: self.camera.to_camera_m(DVec3::X) - origin,
            ey: self.camera.to_camera_m(DVec3::Y) - origin,
            origin,
        });
        Ok(())
    }

    /// The map of the wheel's frame (metres, the disc centre at the origin) to the image at
    /// `pose`: world = R(θ2)·p + offset, then the camera.
    fn wheel_map(&self, t: &TexturedDisc, pose: &WheelPose) -> PlaneMap {
        self.wheel_map_with(t.ex, t.ey, t.origin, pose)
    }

    /// The map of the wheel's frame (metres, the disc centre at the origin) to the image at
    /// `pose`, the one a textured disc is drawn through (what a calibration mosaics the disc's
    /// texture with).
    pub fn wheel_plane_map(&self, pose: &WheelPose) -> PlaneMap {
        let origin = self.camera.to_camera_m(DVec3::ZERO);
        let ex = self.camera.to_camera_m(DVec3::X) - origin;
        let ey = self.camera.to_camera_m(DVec3::Y) - origin;
        self.wheel_map_with(ex, ey, origin, pose)
    }

    fn wheel_map_with(&self, ex: DVec3, ey: DVec3, origin: DVec3, pose: &WheelPose) -> PlaneMap {
        let (sn, cs) = pose.theta2_rad.sin_cos();
        let o = DVec2::from(pose.centre_offset_m);
        PlaneMap {
            plane_to_camera: glam::DMat3::from_cols(
                ex * cs + ey * sn,
                -ex * sn + ey * cs,
                ex * o.x + ey * o.y + origin,
            ),
            lens: self
                .camera
                .config()
                .lens_distortion
                .enabled
                .then(|| self.camera.config().lens_distortion.clone()),
            focal_px: self.camera.focal_px(),
            principal_point_px: self.camera.principal_point_px(),
            transform: None,
        }
    }

    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    pub fn config(&self) -> &SceneConfig {
        &self.config
    }

    /// The disc marker placed in the world for this wheel pose.
    pub fn placed_marker(&self, pose: &WheelPose) -> PlacedMarker {
        let m = &self.config.marker;
        let phi = m.angle_on_disc_deg.to_radians() + pose.theta2_rad;
        let centre = DVec2::from(pose.centre_offset_m)
            + m.radius_mm * 1e-3 * DVec2::new(phi.cos(), phi.sin());
        PlacedMarker::new(
            centre,
            phi + m.orientation_deg.to_radians(),
            self.marker.size_m,
            self.marker.margin_m,
        )
    }

    fn project4(&self, c: [DVec3; 4]) -> [[f64; 2]; 4] {
        c.map(|p| self.camera.project(p).to_array())
    }

    /// Outer corners of the disc marker's black square, px: TL, TR, BR, BL as printed (OpenCV order).
    pub fn marker_corners_px_at(&self, pose: &WheelPose) -> [[f64; 2]; 4] {
        self.project4(self.placed_marker(pose).corners_m())
    }

    /// Image of the disc marker's centre, px.
    pub fn marker_centre_px_at(&self, pose: &WheelPose) -> DVec2 {
        self.camera.project(self.placed_marker(pose).centre_m)
    }

    /// Image of the (possibly displaced) disc centre, px.
    pub fn rotation_centre_px_at(&self, pose: &WheelPose) -> DVec2 {
        self.camera
            .project(DVec2::from(pose.centre_offset_m).extend(0.0))
    }

    /// Bounding box of the disc marker including its white margin, px.
    pub fn marker_bbox_px_at(&self, pose: &WheelPose) -> BoundingBox {
        let poly = projected_quad(
            &self.camera,
            &self.placed_marker(pose).paper_corners_m(),
            TOLERANCE_PX,
            self.distorted,
        );
        let min_px = poly
            .iter()
            .fold(DVec2::splat(f64::INFINITY), |a, &p| a.min(p));
        let max_px = poly
            .iter()
            .fold(DVec2::splat(f64::NEG_INFINITY), |a, &p| a.max(p));
        BoundingBox { min_px, max_px }
    }

    /// Outer corners of the static reference marker's black square (OpenCV order), if enabled.
    pub fn reference_marker_corners_px(&self) -> Option<[[f64; 2]; 4]> {
        self.reference
            .as_ref()
            .map(|(_, placed)| self.project4(placed.corners_m()))
    }

    /// Everything visible for this wheel pose.
    pub fn snapshot_at(&self, pose: &WheelPose) -> SceneSnapshot {
        let c = &self.config;
        let mut layers = Vec::new();
        if let Some((art, placed)) = &self.reference {
            layers.extend(self.marker_layers(art, placed, None));
        }
        let level = super::marker_levels::level_at(&c.appearance.marker_levels, pose.theta2_rad);
        match &self.textured {
            None => {
                layers.push(Layer {
                    texture: None,
                    radiance: c.disc_radiance as f32,
                    polygons: vec![self.disc_polygon(pose)],
                });
                layers.extend(self.marker_layers(
                    &self.marker,
                    &self.placed_marker(pose),
                    level.as_ref(),
                ));
            }
            Some(t) => layers.extend(self.textured_layers(t, pose, level)),
        }
        SceneSnapshot {
            background: self.background.clone(),
            background_radiance: c.background_radiance as f32,
            layers,
        }
    }

    /// The textured disc (its marker's paper included), then the ink when the paper is
    /// uniform.
    fn textured_layers(
        &self,
        t: &TexturedDisc,
        pose: &WheelPose,
        level: Option<LevelMap>,
    ) -> Vec<Layer> {
        let map = self.wheel_map(t, pose);
        let outline = Polygon {
            vertices_px: t
                .mesh
                .outline_plane()
                .into_iter()
                .map(|p| map.to_image(p))
                .collect(),
        };
        let placed = self.placed_marker(pose);
        let uniform_paper = t.mesh.paper_is_uniform();
        let [paper, ink] = self.marker_layers(&self.marker, &placed, level.as_ref());
        let mut layers = vec![Layer {
            radiance: self.config.disc_radiance as f32,
            polygons: vec![outline],
            texture: Some(TexturedFill {
                mesh: Arc::clone(&t.mesh),
                map,
                core_px: uniform_paper.then(|| paper.polygons[0].clone()),
                paper_level: level,
            }),
        }];
        if uniform_paper {
            layers.push(ink);
        }
        layers
    }

    fn disc_polygon(&self, pose: &WheelPose) -> Polygon {
        if pose.centre_offset_m == [0.0, 0.0] {
            return self.disc_at_rest.clone();
        }
        self.build_disc_polygon(pose.centre_offset_m)
    }

    fn build_disc_polygon(&self, centre_offset_m: [f64; 2]) -> Polygon {
        let centre = DVec2::from(centre_offset_m).extend(0.0);
        let r_m = self.config.disc_radius_mm * 1e-3;
        // Sagitta r·(1 − cos(π/n)) ≈ r·π²/(2n²) below the tolerance at the nominal scale; the
        // subdivision check then covers tilt and distortion.
        let r_px = r_m * 1e3 / self.camera.image_scale_mm_per_px();
        let n0 = (PI * (r_px / (2.0 * TOLERANCE_PX)).sqrt()).ceil() as usize;
        let circle = move |s: f64| {
            centre + r_m * DVec3::new((2.0 * PI * s).cos(), (2.0 * PI * s).sin(), 0.0)
        };
        // Untilted and undistorted the image is an exact circle and 1 − cos x ≤ x²/2 makes n0
        // sufficient; otherwise measure.
        let n = if self.distorted || self.camera.config().perspective_tilt.enabled {
            subdivisions(
                &self.camera,
                &circle,
                0.0,
                1.0,
                n0.max(16),
                TOLERANCE_PX,
                1 << 18,
            )
        } else {
            n0.max(16)
        };
        Polygon {
            vertices_px: (0..n)
                .map(|k| self.camera.project(circle(k as f64 / n as f64)))
                .collect(),
        }
    }

    /// Cell-lattice subdivisions per cell so that every cell edge follows its image within the
    /// tolerance; 1 without distortion (straight lines stay straight under a pinhole).
    fn lattice_per_cell(&self, art: &MarkerArt, placed: &PlacedMarker) -> usize {
        if !self.distorted {
            return 1;
        }
        let side = art.side_cells;
        let mut worst = 1;
        for k in 0..=side {
            let t = k as f64 / side as f64;
            let row = move |s: f64| placed.at(s, t);
            let col = move |s: f64| placed.at(t, s);
            for line in [&row as &dyn Fn(f64) -> DVec3, &col] {
                let n = subdivisions(&self.camera, line, 0.0, 1.0, side, TOLERANCE_PX, side * 256);
                worst = worst.max(n.div_ceil(side));
            }
        }
        worst
    }

    /// White paper then black cells (one layer of disjoint polygons sharing lattice vertices).
    ///
    /// The paper's outline must never be anti-aliased in a pixel that the ink covers only in
    /// part: "over" compositing would let it show through the ink's partial coverage c, adding
    /// c·(1 − c)·(paper − below) (13–17 DN at the seed's levels, a square ~0.27 px too small).
    /// With a margin the outline lies outside the black square; without one the paper is only
    /// visible in the white cells, so its outline is drawn along the middle of the black border
    /// ring, where the ink covers whole pixels.
    /// The corners of the paper as drawn (see [`Self::marker_layers`]), world frame.
    fn paper_corners_m(&self, art: &MarkerArt, placed: &PlacedMarker) -> [DVec3; 4] {
        if art.margin_m > 0.0 {
            placed.paper_corners_m()
        } else {
            let e = 0.5 * art.border_bits as f64 / art.side_cells as f64;
            [
                placed.at(e, e),
                placed.at(1.0 - e, e),
                placed.at(1.0 - e, 1.0 - e),
                placed.at(e, 1.0 - e),
            ]
        }
    }

    /// The marker's paper and ink, their radiances mapped by `level` when one is given.
    fn marker_layers(
        &self,
        art: &MarkerArt,
        placed: &PlacedMarker,
        level: Option<&LevelMap>,
    ) -> [Layer; 2] {
        let radiance = |r: f64| level.map_or(r, |l| l.radiance(r)) as f32;
        let paper_corners = self.paper_corners_m(art, placed);
        let paper = Polygon {
            vertices_px: projected_quad(&self.camera, &paper_corners, TOLERANCE_PX, self.distorted),
        };
        let m = self.lattice_per_cell(art, placed);
        let l = (art.side_cells * m) as f64;
        let pt = |i: usize, j: usize| self.camera.project(placed.at(i as f64 / l, j as f64 / l));
        let polygons = art
            .rects
            .iter()
            .map(|r| {
                let (c0, c1, r0, r1) = (r.col0 * m, r.col1 * m, r.row0 * m, r.row1 * m);
                let vertices_px = if m == 1 && !self.distorted {
                    vec![pt(c0, r0), pt(c1, r0), pt(c1, r1), pt(c0, r1)]
                } else {
                    let mut v = Vec::new();
                    v.extend((c0..c1).map(|i| pt(i, r0)));
                    v.extend((r0..r1).map(|j| pt(c1, j)));
                    v.extend((c0 + 1..=c1).rev().map(|i| pt(i, r1)));
                    v.extend((r0 + 1..=r1).rev().map(|j| pt(c0, j)));
                    v
                };
                Polygon { vertices_px }
            })
            .collect();
        [
            Layer {
                texture: None,
                radiance: radiance(self.config.paper_radiance),
                polygons: vec![paper],
            },
            Layer {
                texture: None,
                radiance: radiance(self.config.ink_radiance),
                polygons,
            },
        ]
    }

    /// Attaches the wheel motion, giving a scene that can be looked at any instant.
    pub fn animate<M: Fn(f64) -> WheelPose + Sync>(self, motion: M) -> AnimatedScene<M> {
        AnimatedScene {
            scene: self,
            motion,
        }
    }
}

/// A [`Scene`] driven by a wheel motion `t_s → WheelPose`; implements [`SceneAt`].
pub struct AnimatedScene<M: Fn(f64) -> WheelPose + Sync> {
    pub scene: Scene,
    pub motion: M,
}

impl<M: Fn(f64) -> WheelPose + Sync> AnimatedScene<M> {
    pub fn pose(&self, t_s: f64) -> WheelPose {
        (self.motion)(t_s)
    }

    /// Disc marker corners at `t_s`, px, OpenCV order (TL, TR, BR, BL as printed).
    pub fn marker_corners_px(&self, t_s: f64) -> [[f64; 2]; 4] {
        self.scene.marker_corners_px_at(&self.pose(t_s))
    }

    pub fn marker_centre_px(&self, t_s: f64) -> DVec2 {
        self.scene.marker_centre_px_at(&self.pose(t_s))
    }

    pub fn rotation_centre_px(&self, t_s: f64) -> DVec2 {
        self.scene.rotation_centre_px_at(&self.pose(t_s))
    }

    /// Disc marker bounding box incl. white margin at `t_s`, px.
    pub fn marker_bbox_px(&self, t_s: f64) -> BoundingBox {
        self.scene.marker_bbox_px_at(&self.pose(t_s))
    }

    pub fn reference_marker_corners_px(&self) -> Option<[[f64; 2]; 4]> {
        self.scene.reference_marker_corners_px()
    }
}

impl<M: Fn(f64) -> WheelPose + Sync> SceneAt for AnimatedScene<M> {
    fn snapshot(&self, t_s: f64) -> SceneSnapshot {
        self.scene.snapshot_at(&self.pose(t_s))
    }
}
