//! The marker's level as a function of the wheel's angle (`scene.appearance.marker_levels`):
//! a glossy toner or a laminated print reflects the lamp at some angles of the wheel, so that
//! its ink (and less so its paper) brightens and darkens as the marker turns, which no texture
//! fixed in the marker's frame can draw.
//!
//! Each entry states, at one wheel angle θ2 (degrees, modulo 360), the affine map
//! r ↦ gain·r + offset of the marker's radiance (paper and ink, textured or uniform; clamped to
//! [0, 1]). Between entries the gain and offset are interpolated linearly in the angle, around
//! the circle (the last entry runs on to the first plus 360°), so that the map is continuous and
//! periodic; one entry holds at every angle.

use crate::render::texture::LevelMap;
use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

/// One entry of the table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MarkerLevelAt {
    /// The wheel's angle θ2, degrees, in [0, 360); entries strictly increasing.
    pub angle_deg: f64,
    /// The factor on the marker's radiance, in (0, 10].
    pub gain: f64,
    /// Added to the marker's radiance after the gain, in [−1, 1].
    pub offset: f64,
}

/// Checks a table (`path` names it).
pub fn validate(levels: &[MarkerLevelAt], path: &str, problems: &mut Problems) {
    let mut last = f64::NEG_INFINITY;
    for (i, e) in levels.iter().enumerate() {
        let field = format!("{path}[{i}]");
        problems.range(join(&field, "angle_deg"), e.angle_deg, 0.0, 359.999_999);
        problems.range(join(&field, "gain"), e.gain, 1e-6, 10.0);
        problems.range(join(&field, "offset"), e.offset, -1.0, 1.0);
        problems.increasing(join(&field, "angle_deg"), e.angle_deg, last, ("angle", "°"));
        last = e.angle_deg;
    }
}

/// The marker's level map at wheel angle `theta2_rad`; `None` for an empty table (the marker's
/// radiance as stated).
pub fn level_at(levels: &[MarkerLevelAt], theta2_rad: f64) -> Option<LevelMap> {
    let (first, last) = (levels.first()?, levels.last()?);
    let a = theta2_rad.to_degrees().rem_euclid(360.0);
    let k = levels.partition_point(|e| e.angle_deg <= a);
    let (lo, hi, lo_deg, hi_deg) = match k {
        0 => (last, first, last.angle_deg - 360.0, first.angle_deg),
        k if k == levels.len() => (last, first, last.angle_deg, first.angle_deg + 360.0),
        k => (
            &levels[k - 1],
            &levels[k],
            levels[k - 1].angle_deg,
            levels[k].angle_deg,
        ),
    };
    let span = hi_deg - lo_deg;
    let w = if span > 0.0 {
        ((a - lo_deg) / span).clamp(0.0, 1.0)
    } else {
        0.0
    };
    Some(LevelMap {
        gain: lo.gain + w * (hi.gain - lo.gain),
        offset: lo.offset + w * (hi.offset - lo.offset),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(angle_deg: f64, gain: f64, offset: f64) -> MarkerLevelAt {
        MarkerLevelAt {
            angle_deg,
            gain,
            offset,
        }
    }

    #[test]
    fn an_empty_table_leaves_the_marker_as_stated() {
        assert_eq!(level_at(&[], 1.0), None);
    }

    #[test]
    fn one_entry_holds_at_every_angle() {
        let t = [at(40.0, 0.8, 0.1)];
        for deg in [-400.0, 0.0, 39.0, 40.0, 300.0, 720.0] {
            let l = level_at(&t, f64::to_radians(deg)).unwrap();
            assert_eq!((l.gain, l.offset), (0.8, 0.1), "at {deg}°");
        }
    }

    #[test]
    fn levels_interpolate_between_entries_and_around_the_circle() {
        let t = [at(10.0, 1.0, 0.0), at(100.0, 1.0, 0.3), at(190.0, 0.5, 0.0)];
        let off = |deg: f64| level_at(&t, f64::to_radians(deg)).unwrap().offset;
        assert!((off(10.0) - 0.0).abs() < 1e-12);
        assert!((off(55.0) - 0.15).abs() < 1e-12);
        assert!((off(100.0) - 0.3).abs() < 1e-12);
        // From 190° on to 370° (= 10°): 180° of span, gain 0.5 → 1.
        let g = |deg: f64| level_at(&t, f64::to_radians(deg)).unwrap().gain;
        assert!((g(280.0) - 0.75).abs() < 1e-12);
        assert!((g(-80.0) - 0.75).abs() < 1e-12, "negative angles wrap");
        assert!((g(0.0) - (0.5 + 0.5 * 170.0 / 180.0)).abs() < 1e-12);
        assert!(
            (g(370.0 + 45.0) - 1.0).abs() < 1e-12,
            "a turn later is the same"
        );
    }

    #[test]
    fn the_map_clamps_the_radiance_to_its_range() {
        let l = LevelMap {
            gain: 2.0,
            offset: 0.1,
        };
        assert_eq!(l.radiance(0.7), 1.0);
        assert_eq!(l.radiance(0.2), 0.5);
        let dark = LevelMap {
            gain: 1.0,
            offset: -0.5,
        };
        assert_eq!(dark.radiance(0.2), 0.0);
        assert_eq!(dark.value(65535), 32768);
    }

    #[test]
    fn a_table_out_of_order_or_range_names_the_entry_and_field() {
        let mut p = Problems::new();
        validate(
            &[at(20.0, 1.0, 0.0), at(20.0, 1.0, 0.0), at(400.0, 0.0, 2.0)],
            "scene.appearance.marker_levels",
            &mut p,
        );
        let msgs: Vec<String> = p.iter().map(|m| m.to_string()).collect();
        let all = msgs.join("\n");
        assert!(
            all.contains("scene.appearance.marker_levels[1].angle_deg"),
            "{all}"
        );
        assert!(
            all.contains("scene.appearance.marker_levels[2].angle_deg"),
            "{all}"
        );
        assert!(
            all.contains("scene.appearance.marker_levels[2].gain"),
            "{all}"
        );
        assert!(
            all.contains("scene.appearance.marker_levels[2].offset"),
            "{all}"
        );
        assert_eq!(msgs.len(), 4, "{all}");
    }
}
