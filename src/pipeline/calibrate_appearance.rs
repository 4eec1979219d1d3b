//! The marker texture a calibration writes (`marker.png`, named by the calibrated scenario's
//! `[scene.appearance]`): the frames kept for it, mosaicked by [`crate::calibrate::appearance`].

use super::calibrate::{float_of, round6, CalibrateJobError, Corners, Crop};
use crate::calibrate::appearance::{
    marker_appearance, shows_texture, AppearanceRecord, LevelAnchors, RegisteredView,
};
use crate::calibrate::output::Override;
use crate::calibrate::Calibration;
use crate::imagestats::MarkerLayout;
use crate::render::{render_frame, FrameRequest};
use crate::scenario::Scenario;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use toml::Value;

/// The texture's file name beside the scenario.
pub(crate) const MARKER_FILE: &str = "marker.png";

/// A frame kept for the mosaic: its frame number in the footage, the window around the marker
/// and the marker's corners there.
pub(crate) type MosaicFrame = (usize, Crop, Corners);

/// Measures the marker's texture on `frames` (the re-render check's frame `check_frame` left
/// out when others remain; each frame's levels brought to the calibrated light by its gain at
/// `times_s[frame]`), writes it into `out_dir` and names it in `ovs`. A texture is written
/// only where the footage's mosaic varies beyond that of renders of the calibrated uniform
/// marker (`typed(ovs)`) at the same frames. When no texture can be measured the marker stays
/// uniform and a note says why. Returns the file written.
#[allow(clippy::too_many_arguments)]
pub(crate) fn write_marker_appearance(
    frames: &[MosaicFrame],
    times_s: &[f64],
    check_frame: Option<usize>,
    layout: &MarkerLayout,
    blur_sigma_px: f64,
    ovs: &mut Vec<Override>,
    cal: &mut Calibration,
    base: &Scenario,
    typed: &dyn Fn(&[Override]) -> Result<Scenario, CalibrateJobError>,
    out_dir: &Path,
) -> Result<Option<PathBuf>, CalibrateJobError> {
    let (Some(black), Some(white)) = (
        float_of(ovs, "effects.lighting.black_level_dn"),
        float_of(ovs, "effects.lighting.white_level_dn"),
    ) else {
        return Ok(None);
    };
    let held_out: Vec<&MosaicFrame> = frames.iter().filter(|f| Some(f.0) != check_frame).collect();
    let (chosen, check_frame_held_out) = if held_out.is_empty() {
        (frames.iter().collect::<Vec<_>>(), false)
    } else {
        (held_out, check_frame.is_some())
    };
    let views: Vec<RegisteredView<'_>> = chosen
        .iter()
        .map(|(frame, crop, corners)| RegisteredView {
            image: crop.view(),
            corners_px: *corners,
            light_gain: times_s
                .get(*frame)
                .map_or(1.0, |&t| cal.imaging.exposure.gain_at(t)),
        })
        .collect();
    // The calibrated tone curve is linear (gamma 1): black is radiance 0, white 1.
    let measure_views = |views: &[RegisteredView<'_>], white: f64| {
        let anchors = LevelAnchors {
            ink_dn: black,
            ink_radiance: 0.0,
            paper_dn: white,
            paper_radiance: 1.0,
        };
        marker_appearance(views, layout, blur_sigma_px, &anchors)
    };
    let measure = |white: f64| measure_views(&views, white);
    let mut measured = match measure(white) {
        Ok(m) => m,
        Err(e) => {
            cal.notes.push(format!(
                "appearance: the marker is drawn uniform, no texture was measured ({e})"
            ));
            return Ok(None);
        }
    };
    let n = &cal.imaging.noise;
    let noise_sd_dn = [n.ink_sigma_dn.value, n.paper_sigma_dn.value];
    // What the calibrated uniform marker shows when mosaicked the same way: the noise left in
    // the mean, and the fixed pattern a codec draws on a still marker (a JPEG quantises the
    // same blocks alike in every frame, which the mean keeps).
    let null = typed(ovs).ok().and_then(|s| {
        let at: Vec<(usize, &Crop)> = chosen.iter().map(|(f, c, _)| (*f, c)).collect();
        let renders = render_like(&s, &at)?;
        let views: Vec<RegisteredView<'_>> = renders
            .iter()
            .zip(&views)
            .map(|(r, v)| RegisteredView {
                image: r.view(),
                ..*v
            })
            .collect();
        measure_views(&views, white).ok()
    });
    let left = [0, 1].map(|m| match &null {
        Some(u) => u.spread_dn[m],
        None => measured.noise_left_dn(noise_sd_dn[m]),
    });
    let texture_sd = [0, 1].map(|m| measured.texture_sd_dn(m, left[m]));
    if !shows_texture(texture_sd, left) {
        let beyond = if null.is_some() {
            "what the calibrated uniform marker gives when rendered at the same frames and \
             mosaicked the same way"
        } else {
            "what their noise leaves"
        };
        cal.notes.push(format!(
            "appearance: the marker is drawn uniform: over {} registered frame(s) its ink and \
             paper vary by {:.2} / {:.2} DN, {:.2} / {:.2} DN beyond {beyond} (a texture needs \
             {} DN and at least {:.2} / {:.2} DN)",
            measured.frames,
            measured.spread_dn[0],
            measured.spread_dn[1],
            texture_sd[0],
            texture_sd[1],
            crate::calibrate::appearance::MIN_TEXTURE_SD_DN,
            left[0],
            left[1],
        ));
        return Ok(None);
    }
    // Paper brighter than its mean by more than the room the levels leave for its noise would
    // clip at the white level: the white level moves up to hold it.
    let room = 5.0 * noise_sd_dn[1] + 1.0;
    let wanted = (measured.range_dn[1] + room).min(255.0);
    if wanted > white + 1e-9 && white > black {
        raise_white_level(ovs, cal, base, black, white, wanted);
        if let Ok(m) = measure(wanted) {
            measured = m;
        }
    }
    let path = out_dir.join(MARKER_FILE);
    let t = &measured.texture;
    crate::io::texture_png::write_texture(&path, t.width, t.height, &t.values)?;
    let record = AppearanceRecord::of(&measured, MARKER_FILE, check_frame_held_out);
    ovs.push(Override {
        path: "scene.appearance.marker_file".into(),
        value: Value::String(MARKER_FILE.into()),
        comment: format!(
            "the marker's paper and ink mosaicked from {} frame(s) (texture {:.1} / {:.1} DN sd \
             beyond the noise; {} of {} texels sampled, the rest at their material's level \
             within {:.1} px of an edge)",
            record.frames,
            texture_sd[0],
            texture_sd[1],
            record.sampled_texels,
            record.sampled_texels + record.level_texels,
            record.guard_px
        ),
    });
    ovs.push(Override {
        path: "scene.appearance.marker_texels_per_cell".into(),
        value: Value::Integer(record.texels_per_cell as i64),
        comment: format!("{:.1} px per cell in the footage", record.px_per_cell),
    });
    cal.appearance = Some(record);
    Ok(Some(path))
}

/// Renders `scenario` over each mosaic frame's window at that frame (its time, and its index as
/// the noise's seed), as the footage's frames were kept; `None` when the scenario has no rig or
/// a frame has no time.
pub(crate) fn render_like(scenario: &Scenario, frames: &[(usize, &Crop)]) -> Option<Vec<Crop>> {
    let rig = crate::pipeline::rig::Rig::new(scenario).ok()?;
    let scene = rig.animated();
    let times = rig.frame_times.as_slice();
    frames
        .par_iter()
        .map(|(frame, crop)| {
            let image = render_frame(
                &scene,
                &rig.settings,
                &FrameRequest {
                    index: *frame as u64,
                    t_s: *times.get(*frame)?,
                    window: crop.rect,
                },
            );
            Some(Crop {
                rect: image.window,
                data: image.data,
            })
        })
        .collect()
}

/// Moves the tone curve's white level from `white` to `new_white` DN with the black level kept,
/// keeping every grey level and the noise in DN: each radiance scales by span/span' and the
/// full well by span'/span (the shot variance per DN, span/full well, and the read noise in DN,
/// span·read/full well, stay as they were).
fn raise_white_level(
    ovs: &mut Vec<Override>,
    cal: &mut Calibration,
    base: &Scenario,
    black: f64,
    white: f64,
    new_white: f64,
) {
    let k = (new_white - black) / (white - black);
    for o in ovs.iter_mut() {
        let scaled = match o.path.as_str() {
            "effects.lighting.white_level_dn" => Some(new_white),
            "scene.ink_radiance"
            | "scene.paper_radiance"
            | "scene.disc_radiance"
            | "scene.background_radiance" => o.value.as_float().map(|r| r / k),
            "effects.pixel_noise.full_well_e" => o.value.as_float().map(|f| f * k),
            _ => None,
        };
        if let Some(v) = scaled {
            o.value = Value::Float(round6(v));
        }
    }
    // The radiances the calibration leaves at the base's change with the span too.
    let sc = &base.scene;
    for (path, r) in [
        ("scene.ink_radiance", sc.ink_radiance),
        ("scene.paper_radiance", sc.paper_radiance),
        ("scene.disc_radiance", sc.disc_radiance),
        ("scene.background_radiance", sc.background_radiance),
    ] {
        if !ovs.iter().any(|o| o.path == path) {
            ovs.push(Override {
                path: path.into(),
                value: Value::Float(round6(r / k)),
                comment: "the base's, rescaled with the white level".into(),
            });
        }
    }
    let im = &mut cal.imaging;
    im.white_level_dn = new_white;
    im.ink_radiance /= k;
    im.paper_radiance /= k;
    im.disc_radiance = im.disc_radiance.map(|r| r / k);
    im.noise.full_well_e *= k;
    cal.notes.push(format!(
        "appearance: the white level is raised from {white:.2} to {new_white:.2} DN to hold the \
         paper's brightest texels with room for their noise; radiances and the full well are \
         rescaled so that every grey level and the noise in DN stay as fitted"
    ));
}
