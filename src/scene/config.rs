//! Scene configuration (the `[scene]` scenario section) and its field-level validation.

use serde::{Deserialize, Serialize};

use super::appearance::AppearanceConfig;
use crate::marker::Dictionary;
use crate::validation::{join, Problems};

/// The marker stuck on the driven disc.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MarkerConfig {
    /// ArUco dictionary (`"4x4_50"`, …, `"7x7_1000"`, `"aruco_original"`; OpenCV's
    /// `"DICT_4X4_50"` spelling is accepted). Default `"4x4_50"` (seed rig).
    pub dictionary: Dictionary,
    /// Marker id in the dictionary, in [0, count − 1]. Default 0.
    pub id: usize,
    /// Edge of the black square (outer edge of the black border, white margin excluded), mm,
    /// in [0.1, 10000]. Default 32.
    pub size_mm: f64,
    /// Black border width in cells, in [1, 4]. Default 1.
    pub border_bits: usize,
    /// White paper around the black square on each side, mm, in [0, 10000]. Default 8: OpenCV drops a
    /// candidate closer than `min_marker_distance_rate` × perimeter to another, and the paper's
    /// outline is such a candidate, so a thin margin makes detection fail.
    pub white_margin_mm: f64,
    /// Distance from the rotation centre to the marker centre, mm, in [0, 10000]. Default 145
    /// (seed: ≈ 744 px × 0.195 mm/px).
    pub radius_mm: f64,
    /// Marker rotation on the disc relative to the radial direction, degrees; 0 = the printed
    /// left→right axis points radially outwards. Default 0.
    pub orientation_deg: f64,
    /// Angular position of the marker centre on the disc at theta2 = 0, degrees from +x towards
    /// +y. Default 0.
    pub angle_on_disc_deg: f64,
}

impl Default for MarkerConfig {
    fn default() -> Self {
        Self {
            dictionary: Dictionary::Dict4x4_50,
            id: 0,
            size_mm: 32.0,
            border_bits: 1,
            white_margin_mm: 8.0,
            radius_mm: 145.0,
            orientation_deg: 0.0,
            angle_on_disc_deg: 0.0,
        }
    }
}

/// A static marker on the frame / base plate (not moving with the disc).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferenceMarkerConfig {
    /// Draw the reference marker. Default false.
    pub enabled: bool,
    /// ArUco dictionary (as for the disc marker). Default `"4x4_50"`.
    pub dictionary: Dictionary,
    /// Marker id, in [0, count − 1]. Default 1.
    pub id: usize,
    /// Edge of the black square, mm, in [0.1, 10000]. Default 60.
    pub size_mm: f64,
    /// Black border width in cells, in [1, 4]. Default 1.
    pub border_bits: usize,
    /// White paper around the black square on each side, mm, in [0, 10000]. Default 12.
    pub white_margin_mm: f64,
    /// Marker centre in the disc plane [x, y], mm (world frame). Default [-280, 0].
    pub position_mm: [f64; 2],
    /// Rotation of the printed left→right axis from +x towards +y, degrees. Default 0.
    pub orientation_deg: f64,
}

impl Default for ReferenceMarkerConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            dictionary: Dictionary::Dict4x4_50,
            id: 1,
            size_mm: 60.0,
            border_bits: 1,
            white_margin_mm: 12.0,
            position_mm: [-280.0, 0.0],
            orientation_deg: 0.0,
        }
    }
}

/// What the camera sees: background, driven disc, its marker and an optional reference marker.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SceneConfig {
    /// Radius of the driven disc, mm, in [0.1, 10000]; its image at most 1e6 px. Default 180.
    pub disc_radius_mm: f64,
    /// Linear radiance of the disc surface, in [0, 1]. Default 0.55 (orange disc in grey).
    pub disc_radiance: f64,
    /// Linear radiance behind the disc, in [0, 1]. Default 0.2.
    pub background_radiance: f64,
    /// Linear radiance of the white paper (margin and white cells), in [0, 1]. Default 1.0.
    pub paper_radiance: f64,
    /// Linear radiance of the black ink, in [0, 1]. Default 0.04.
    pub ink_radiance: f64,
    /// The marker on the disc.
    pub marker: MarkerConfig,
    /// Optional static reference marker (drawn under the disc where they overlap).
    pub reference_marker: ReferenceMarkerConfig,
    /// Textures measured from footage (`scene::appearance`): the disc, the marker, the
    /// background. Default: none (uniform radiances).
    #[serde(skip_serializing_if = "AppearanceConfig::is_empty")]
    pub appearance: AppearanceConfig,
}

impl Default for SceneConfig {
    fn default() -> Self {
        Self {
            disc_radius_mm: 180.0,
            disc_radiance: 0.55,
            background_radiance: 0.2,
            paper_radiance: 1.0,
            ink_radiance: 0.04,
            marker: MarkerConfig::default(),
            reference_marker: ReferenceMarkerConfig::default(),
            appearance: AppearanceConfig::default(),
        }
    }
}

fn check_marker_common(
    path: &str,
    dictionary: Dictionary,
    id: usize,
    size_mm: f64,
    border_bits: usize,
    white_margin_mm: f64,
    problems: &mut Problems,
) {
    let count = dictionary.marker_count();
    if id >= count {
        problems.push(
            join(path, "id"),
            format!(
                "must be in [0, {}] for {}, got {id}",
                count - 1,
                dictionary.opencv_name()
            ),
        );
    }
    problems.range(join(path, "size_mm"), size_mm, 0.1, 1e4);
    problems.range(join(path, "border_bits"), border_bits as f64, 1.0, 4.0);
    problems.range(join(path, "white_margin_mm"), white_margin_mm, 0.0, 1e4);
}

impl MarkerConfig {
    /// Distance from the rotation centre to the farthest corner of the white paper, mm.
    pub fn paper_extent_mm(&self) -> f64 {
        let half = self.size_mm / 2.0 + self.white_margin_mm;
        let o = self.orientation_deg.to_radians();
        let (u, v) = ((o.cos(), o.sin()), (-o.sin(), o.cos()));
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .map(|&(a, b)| {
                let x = self.radius_mm + half * (a * u.0 + b * v.0);
                let y = half * (a * u.1 + b * v.1);
                x.hypot(y)
            })
            .fold(0.0, f64::max)
    }

    pub fn validate(&self, path: &str, problems: &mut Problems) {
        check_marker_common(
            path,
            self.dictionary,
            self.id,
            self.size_mm,
            self.border_bits,
            self.white_margin_mm,
            problems,
        );
        problems.range(join(path, "radius_mm"), self.radius_mm, 0.0, 1e4);
        problems.range(
            join(path, "orientation_deg"),
            self.orientation_deg,
            -360.0,
            360.0,
        );
        problems.range(
            join(path, "angle_on_disc_deg"),
            self.angle_on_disc_deg,
            -360.0,
            360.0,
        );
    }
}

impl ReferenceMarkerConfig {
    /// Checks the fields whether or not the marker is drawn (a sweep may switch it on).
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        check_marker_common(
            path,
            self.dictionary,
            self.id,
            self.size_mm,
            self.border_bits,
            self.white_margin_mm,
            problems,
        );
        let p = join(path, "position_mm");
        problems.range(format!("{p}[0]"), self.position_mm[0], -1e5, 1e5);
        problems.range(format!("{p}[1]"), self.position_mm[1], -1e5, 1e5);
        problems.range(
            join(path, "orientation_deg"),
            self.orientation_deg,
            -360.0,
            360.0,
        );
    }
}

impl SceneConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(join(path, "disc_radius_mm"), self.disc_radius_mm, 0.1, 1e4);
        for (name, v) in [
            ("disc_radiance", self.disc_radiance),
            ("background_radiance", self.background_radiance),
            ("paper_radiance", self.paper_radiance),
            ("ink_radiance", self.ink_radiance),
        ] {
            problems.range(join(path, name), v, 0.0, 1.0);
        }
        let mpath = join(path, "marker");
        self.marker.validate(&mpath, problems);
        let extent = self.marker.paper_extent_mm();
        if extent.is_finite() && self.disc_radius_mm.is_finite() && extent > self.disc_radius_mm {
            problems.push(
                join(&mpath, "radius_mm"),
                format!(
                    "the marker paper reaches {extent:.2} mm from the rotation centre; it must lie on the disc \
                     (<= disc_radius_mm = {})",
                    self.disc_radius_mm
                ),
            );
        }
        self.reference_marker
            .validate(&join(path, "reference_marker"), problems);
        let m = &self.marker;
        let cells = (m.id < m.dictionary.marker_count() && (1..=4).contains(&m.border_bits))
            .then(|| m.dictionary.marker_size_bits() + 2 * m.border_bits);
        self.appearance.validate(
            &join(path, "appearance"),
            cells,
            m.size_mm,
            m.white_margin_mm,
            problems,
        );
    }
}
