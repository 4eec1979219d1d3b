//! The disc's and the background's textures a calibration writes (`disc.png`,
//! `background.png`, named by the calibrated scenario's `[scene.appearance]`): the frames and
//! the calibrated geometry handed to [`crate::calibrate::surroundings`], and the test that a
//! texture draws more than the noise it would freeze into every render.

use super::calibrate::{float_of, round6, CalibrateJobError, Crop};
use super::calibrate_appearance::{render_like, MosaicFrame};
use crate::calibrate::appearance::{LevelAnchors, MIN_TEXTURE_SD_DN};
use crate::calibrate::output::Override;
use crate::calibrate::surroundings::{
    background_texture, disc_texture, DiscGeometry, Mosaic, PlaneView,
};
use crate::calibrate::Calibration;
use crate::pipeline::rig::Rig;
use crate::scenario::Scenario;
use crate::scene::WheelPose;
use std::path::{Path, PathBuf};
use toml::Value;

/// The disc texture's file name beside the scenario.
pub(crate) const DISC_FILE: &str = "disc.png";
/// The background texture's file name beside the scenario.
pub(crate) const BACKGROUND_FILE: &str = "background.png";
/// Fewest background pixels whose mean is written as the background's level.
const MIN_BACKGROUND_PX: usize = 200;

/// The frames the surroundings are mosaicked from.
pub(crate) struct SurroundFrames<'a> {
    /// Frames where the wheel was at rest (the marker's mosaic frames).
    pub disc: &'a [MosaicFrame],
    /// Every frame whose window was kept, with its footage frame number.
    pub background: &'a [(usize, Crop)],
    pub times_s: &'a [f64],
    /// The re-render check's frame, left out of both mosaics when others remain.
    pub check_frame: Option<usize>,
}

/// What the mosaics need of the calibrated scenario.
struct Context<'a> {
    scenario: &'a Scenario,
    rig: Rig,
    anchors: LevelAnchors,
    times_s: &'a [f64],
    gain: &'a dyn Fn(f64) -> f64,
    /// The larger of the fitted noise σ at the ink and at the paper, DN.
    noise_sd_dn: f64,
}

impl Context<'_> {
    /// Each frame's view: its window, the wheel's map at the frame's time, the light's gain.
    fn views<'c>(&self, frames: &'c [(usize, &'c Crop)]) -> Vec<PlaneView<'c>> {
        let scene = self.rig.animated();
        frames
            .iter()
            .filter_map(|(frame, crop)| {
                let t = *self.times_s.get(*frame)?;
                let pose: WheelPose = scene.pose(self.rig.render_time_s(t));
                Some(PlaneView {
                    image: crop.view(),
                    wheel_map: self.rig.scene.wheel_plane_map(&pose),
                    light_gain: (self.gain)(t),
                })
            })
            .collect()
    }

    /// The spread of the same mosaic of the calibrated scenario rendered at the same frames (its
    /// noise left in the mean and a codec's fixed pattern), DN; `None` when it cannot be made.
    fn null_spread(
        &self,
        frames: &[(usize, &Crop)],
        mosaic: impl Fn(&[PlaneView<'_>]) -> Option<Mosaic>,
    ) -> Option<f64> {
        let renders = render_like(self.scenario, frames)?;
        let rendered: Vec<(usize, &Crop)> = frames
            .iter()
            .zip(&renders)
            .map(|((f, _), r)| (*f, r))
            .collect();
        mosaic(&self.views(&rendered)).map(|m| m.spread_dn)
    }

    /// [`Self::null_spread`], or when the renders cannot be made, what the noise leaves in a
    /// mean over `mosaic_frames` frames (the larger of the ink's and the paper's σ: a texture
    /// is then written only where it stands above the noisier of the two).
    fn null_spread_or_noise(
        &self,
        frames: &[(usize, &Crop)],
        mosaic_frames: usize,
        mosaic: impl Fn(&[PlaneView<'_>]) -> Option<Mosaic>,
    ) -> f64 {
        self.null_spread(frames, mosaic)
            .unwrap_or_else(|| self.noise_sd_dn / (mosaic_frames.max(1) as f64).sqrt())
    }
}

/// The spread of `m` beyond `null_sd_dn`, and whether it makes a texture worth drawing (at least
/// [`MIN_TEXTURE_SD_DN`] and at least the null's own spread, as for the marker's texture).
fn texture_beyond(m: &Mosaic, null_sd_dn: f64) -> (f64, bool) {
    let sd = (m.spread_dn.powi(2) - null_sd_dn.powi(2)).max(0.0).sqrt();
    (sd, sd >= MIN_TEXTURE_SD_DN && sd >= null_sd_dn)
}

/// Measures the disc's and the background's appearance on `frames` with the calibrated scenario
/// `typed(ovs)` (its geometry and motion place the wheel in every frame), writes the textures
/// that show more than noise into `out_dir`, names them in `ovs` and says how in
/// `cal.surroundings`; the background's mean level is written as its radiance when the footage
/// shows enough of it. Returns the files written.
pub(crate) fn write_surroundings<'a>(
    frames: &SurroundFrames<'a>,
    blur_sigma_px: f64,
    ovs: &mut Vec<Override>,
    cal: &mut Calibration,
    typed: &dyn Fn(&[Override]) -> Result<Scenario, CalibrateJobError>,
    out_dir: &Path,
) -> Result<Vec<PathBuf>, CalibrateJobError> {
    let (Some(black), Some(white)) = (
        float_of(ovs, "effects.lighting.black_level_dn"),
        float_of(ovs, "effects.lighting.white_level_dn"),
    ) else {
        return Ok(Vec::new());
    };
    let scenario = match typed(ovs) {
        Ok(s) => s,
        Err(e) => {
            cal.notes.push(format!(
                "appearance: the disc and the background are drawn uniform (the calibrated \
                 scenario could not be built to place them: {e})"
            ));
            return Ok(Vec::new());
        }
    };
    let rig = match Rig::new(&scenario) {
        Ok(r) => r,
        Err(e) => {
            cal.notes.push(format!(
                "appearance: the disc and the background are drawn uniform (the calibrated \
                 scenario could not be made renderable to place them: {e})"
            ));
            return Ok(Vec::new());
        }
    };
    let exposure = cal.imaging.exposure.clone();
    let gain = move |t: f64| exposure.gain_at(t);
    let ctx = Context {
        scenario: &scenario,
        rig,
        // The calibrated tone curve is linear (gamma 1): black is radiance 0, white 1.
        anchors: LevelAnchors {
            ink_dn: black,
            ink_radiance: 0.0,
            paper_dn: white,
            paper_radiance: 1.0,
        },
        times_s: frames.times_s,
        gain: &gain,
        noise_sd_dn: cal
            .imaging
            .noise
            .ink_sigma_dn
            .value
            .max(cal.imaging.noise.paper_sigma_dn.value),
    };
    // The check's frame is left out unless it is the only one (as for the marker's texture).
    let held_out = |all: Vec<(usize, &'a Crop)>| without_frame(all, frames.check_frame);
    let disc_frames = held_out(frames.disc.iter().map(|(f, c, _)| (*f, c)).collect());
    let bg_frames = held_out(frames.background.iter().map(|(f, c)| (*f, c)).collect());
    let mut files = Vec::new();
    files.extend(write_disc(
        &ctx,
        &disc_frames,
        blur_sigma_px,
        ovs,
        cal,
        out_dir,
    )?);
    files.extend(write_background(
        &ctx,
        &bg_frames,
        blur_sigma_px,
        ovs,
        cal,
        out_dir,
    )?);
    Ok(files)
}

/// `all` without frame `check`, unless nothing would remain.
fn without_frame(all: Vec<(usize, &Crop)>, check: Option<usize>) -> Vec<(usize, &Crop)> {
    let kept: Vec<_> = all.iter().copied().filter(|m| Some(m.0) != check).collect();
    if kept.is_empty() {
        all
    } else {
        kept
    }
}

fn write_disc(
    ctx: &Context<'_>,
    frames: &[(usize, &Crop)],
    blur_sigma_px: f64,
    ovs: &mut Vec<Override>,
    cal: &mut Calibration,
    out_dir: &Path,
) -> Result<Option<PathBuf>, CalibrateJobError> {
    let scene = &ctx.rig.scene;
    let paper = scene.placed_marker(&WheelPose::default()).paper_corners_m();
    let geometry = DiscGeometry {
        radius_m: ctx.scenario.scene.disc_radius_mm * 1e-3,
        paper_m: paper.map(|p| p.truncate()),
        m_per_px: scene.camera().image_scale_mm_per_px() * 1e-3,
    };
    let uniform = ctx.scenario.scene.disc_radiance;
    let measure = |views: &[PlaneView<'_>]| {
        disc_texture(views, &geometry, blur_sigma_px, &ctx.anchors, uniform)
    };
    let disc = match measure(&ctx.views(frames)) {
        Ok(d) => d,
        Err(e) => {
            cal.notes
                .push(format!("appearance: the disc is drawn uniform ({e})"));
            return Ok(None);
        }
    };
    let m = &disc.mosaic;
    let null = ctx.null_spread_or_noise(frames, m.frames, |v| measure(v).ok().map(|d| d.mosaic));
    let (texture_sd, shows) = texture_beyond(m, null);
    if !shows {
        cal.surroundings.push(format!(
            "The disc around the paper is drawn uniform: over {} frame(s) at rest its {} sampled \
             texels vary by {:.2} DN, {texture_sd:.2} DN beyond the same mosaic of the uniform \
             calibrated disc rendered at those frames ({null:.2} DN; a texture needs \
             {MIN_TEXTURE_SD_DN} DN and at least that).",
            m.frames, m.sampled_texels, m.spread_dn
        ));
        return Ok(None);
    }
    let path = out_dir.join(DISC_FILE);
    let t = &m.texture;
    crate::io::texture_png::write_texture(&path, t.width, t.height, &t.values)?;
    let texel_mm = disc.texel_m * 1e3;
    ovs.push(Override {
        path: "scene.appearance.disc_file".into(),
        value: Value::String(DISC_FILE.into()),
        comment: format!(
            "the disc around the marker mosaicked from {} frame(s) at rest (texture {texture_sd:.1} \
             DN sd beyond the noise; {} texels sampled, {} near them at their local mean, the \
             rest at disc_radiance)",
            m.frames, m.sampled_texels, m.filled_texels
        ),
    });
    ovs.push(Override {
        path: "scene.appearance.disc_mm_per_texel".into(),
        value: Value::Float(round6(texel_mm)),
        comment: "about one texel per pixel".into(),
    });
    ovs.push(Override {
        path: "scene.appearance.disc_centre_texel".into(),
        value: Value::Array(disc.centre_texel.iter().map(|&c| Value::Float(c)).collect()),
        comment: "the wheel's centre".into(),
    });
    cal.surroundings.push(format!(
        "The disc around the paper is drawn from `{DISC_FILE}` ({texel_mm:.3} mm per texel, in \
         the wheel's frame): mosaicked from {} frame(s) at rest, {:.1} per texel on average; {} \
         texels were sampled (their spread {:.2} DN, {texture_sd:.2} DN beyond the same mosaic \
         of the uniform calibrated disc rendered at those frames), {} within {:.1} px of the \
         paper or the rim or next to the sampled ones take the local mean of the sampled texels \
         near them, and the rest of the disc its uniform level. The footage's blur is in the \
         texture and the render blurs it again: detail of a pixel or two is drawn wider than the \
         footage shows it.",
        m.frames, m.frames_per_texel, m.sampled_texels, m.spread_dn, m.filled_texels, m.guard_px
    ));
    Ok(Some(path))
}

fn write_background(
    ctx: &Context<'_>,
    frames: &[(usize, &Crop)],
    blur_sigma_px: f64,
    ovs: &mut Vec<Override>,
    cal: &mut Calibration,
    out_dir: &Path,
) -> Result<Option<PathBuf>, CalibrateJobError> {
    let scene = &ctx.rig.scene;
    let camera = scene.camera();
    let size = (camera.width_px() as usize, camera.height_px() as usize);
    let radius_m = ctx.scenario.scene.disc_radius_mm * 1e-3;
    let m_per_px = camera.image_scale_mm_per_px() * 1e-3;
    let measure = |views: &[PlaneView<'_>]| {
        background_texture(views, radius_m, m_per_px, size, blur_sigma_px, &ctx.anchors)
    };
    let m = match measure(&ctx.views(frames)) {
        Ok(m) if m.sampled_texels >= MIN_BACKGROUND_PX => m,
        Ok(m) => {
            cal.surroundings.push(format!(
                "The background is drawn uniform at the base's level: the footage shows {} \
                 pixel(s) of it beyond the disc's rim (at least {MIN_BACKGROUND_PX} measure it).",
                m.sampled_texels
            ));
            return Ok(None);
        }
        Err(e) => {
            cal.surroundings.push(format!(
                "The background is drawn uniform at the base's level ({e})."
            ));
            return Ok(None);
        }
    };
    // The pixels the footage does not show take the measured mean, not the base's level.
    let level = ctx.anchors.radiance(m.mean_dn);
    ovs.retain(|o| o.path != "scene.background_radiance");
    ovs.push(Override {
        path: "scene.background_radiance".into(),
        value: Value::Float(round6(level)),
        comment: format!(
            "mean of {} background pixel(s) beyond the disc's rim, {:.1} DN",
            m.sampled_texels, m.mean_dn
        ),
    });
    let null = ctx.null_spread_or_noise(frames, m.frames, |v| measure(v).ok());
    let (texture_sd, shows) = texture_beyond(&m, null);
    if !shows {
        cal.surroundings.push(format!(
            "The background is drawn uniform at its mean over {} pixel(s) beyond the rim in {} \
             frame(s), {:.1} DN: they vary by {:.2} DN, {texture_sd:.2} DN beyond the same mosaic \
             of renders ({null:.2} DN; a texture needs {MIN_TEXTURE_SD_DN} DN and at least that).",
            m.sampled_texels, m.frames, m.mean_dn, m.spread_dn
        ));
        return Ok(None);
    }
    let path = out_dir.join(BACKGROUND_FILE);
    let t = &m.texture;
    crate::io::texture_png::write_texture(&path, t.width, t.height, &t.values)?;
    ovs.push(Override {
        path: "scene.appearance.background_file".into(),
        value: Value::String(BACKGROUND_FILE.into()),
        comment: format!(
            "what lies beyond the disc, mosaicked from {} frame(s) (texture {texture_sd:.1} DN sd \
             beyond the noise; {} pixels sampled, the rest at background_radiance)",
            m.frames, m.sampled_texels
        ),
    });
    cal.surroundings.push(format!(
        "The background is drawn from `{BACKGROUND_FILE}` (a texel per pixel, fixed in the \
         image): {} pixel(s) beyond the disc's rim by {:.1} px were sampled in {} frame(s) (their \
         spread {:.2} DN, {texture_sd:.2} DN beyond the same mosaic of renders), {} near them \
         take the local mean, the rest the mean level {:.1} DN.",
        m.sampled_texels, m.guard_px, m.frames, m.spread_dn, m.filled_texels, m.mean_dn
    ));
    Ok(Some(path))
}
