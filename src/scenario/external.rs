//! Data files a scenario names (drive-speed tables, frame-timing logs) are read here, once, so
//! everything downstream of the loader is pure. `builtin:NAME` refers to data compiled into the
//! binary: the seed rig's nine phone timing logs as `builtin:model_test1` … `builtin:model_test9`.

use super::{Scenario, ScenarioError};
use crate::mechanism::{parse_drive_table_csv, DriveSpeedConfig};
use crate::timing::{load_from_text, TimingModel};
use std::path::{Path, PathBuf};

const PHONE_LOGS: [(&str, &str); 9] = [
    (
        "model_test1",
        include_str!("../../data/phone-frame-timing/model_test1.showinfo.log"),
    ),
    (
        "model_test2",
        include_str!("../../data/phone-frame-timing/model_test2.showinfo.log"),
    ),
    (
        "model_test3",
        include_str!("../../data/phone-frame-timing/model_test3.showinfo.log"),
    ),
    (
        "model_test4",
        include_str!("../../data/phone-frame-timing/model_test4.showinfo.log"),
    ),
    (
        "model_test5",
        include_str!("../../data/phone-frame-timing/model_test5.showinfo.log"),
    ),
    (
        "model_test6",
        include_str!("../../data/phone-frame-timing/model_test6.showinfo.log"),
    ),
    (
        "model_test7",
        include_str!("../../data/phone-frame-timing/model_test7.showinfo.log"),
    ),
    (
        "model_test8",
        include_str!("../../data/phone-frame-timing/model_test8.showinfo.log"),
    ),
    (
        "model_test9",
        include_str!("../../data/phone-frame-timing/model_test9.showinfo.log"),
    ),
];

/// The text of a built-in data file (`builtin:model_test2`).
pub fn builtin_data(reference: &str) -> Option<&'static str> {
    let name = reference.strip_prefix("builtin:")?;
    PHONE_LOGS.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

fn read_text(reference: &str, file: &Path, field: &str) -> Result<String, ScenarioError> {
    let external = |message: String| ScenarioError::External {
        file: file.to_path_buf(),
        field: field.to_string(),
        path: PathBuf::from(reference),
        message,
    };
    if reference.starts_with("builtin:") {
        return builtin_data(reference).map(str::to_string).ok_or_else(|| {
            external("no such built-in data (builtin:model_test1 … builtin:model_test9)".into())
        });
    }
    let bytes = std::fs::read(reference).map_err(|e| external(crate::errors::full(&e)))?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// Reads every data file the scenario names and fills the in-memory fields.
pub fn load_external(scenario: &mut Scenario, file: &Path) -> Result<(), ScenarioError> {
    attach_appearance(scenario, file, None)?;
    if let DriveSpeedConfig::Table {
        t_s,
        omega1_rad_s,
        file: Some(table),
    } = &mut scenario.drive_speed
    {
        if !table.is_empty() && t_s.is_empty() && omega1_rad_s.is_empty() {
            let text = read_text(table, file, "drive_speed.file")?;
            let (t, w) = parse_drive_table_csv(&text).map_err(|e| ScenarioError::External {
                file: file.to_path_buf(),
                field: "drive_speed.file".into(),
                path: PathBuf::from(table.as_str()),
                message: crate::errors::full(&e),
            })?;
            *t_s = t;
            *omega1_rad_s = w;
        }
    }
    if let TimingModel::Log(log) = &scenario.frame_timing.model {
        let text = read_text(&log.file, file, "frame_timing.model.file")?;
        let ts = load_from_text(log.format, &text).map_err(|e| ScenarioError::External {
            file: file.to_path_buf(),
            field: "frame_timing.model.file".into(),
            path: PathBuf::from(log.file.as_str()),
            message: crate::errors::full(&e),
        })?;
        scenario.timing_log = Some(ts);
    }
    Ok(())
}

/// Reads the textures `scene.appearance` names (reusing `base`'s where it names the same
/// file) and checks them against the scene: bit depth and layout (by the reader), a disc
/// texture that covers the disc, a marker texture the size of the marker's paper, a background
/// the camera's size. Errors name the scenario, the field and the texture file.
pub fn attach_appearance(
    scenario: &mut Scenario,
    file: &Path,
    base: Option<&Scenario>,
) -> Result<(), ScenarioError> {
    use crate::render::texture::{BackgroundTexture, Texture};
    use std::sync::Arc;
    let external = |field: &str, path: &str, message: String| ScenarioError::External {
        file: file.to_path_buf(),
        field: format!("scene.appearance.{field}"),
        path: PathBuf::from(path),
        message,
    };
    let read = |field: &str, path: &str| -> Result<Arc<Texture>, ScenarioError> {
        let t = crate::io::texture_png::read_texture(Path::new(path))
            .map_err(|e| external(field, path, e.reason()))?;
        Ok(Arc::new(Texture {
            width: t.width,
            height: t.height,
            values: t.values,
        }))
    };
    let previous = base.map(|b| &b.scene.appearance);
    let a = &scenario.scene.appearance;
    // A file the base names too is the base's texture (the same file, read once).
    let same_file = |name: &Option<String>, old: Option<&Option<String>>| -> bool {
        matches!((name, old), (Some(n), Some(Some(o))) if n == o)
    };
    let disc = match (&a.disc_file, previous) {
        (None, _) => None,
        (Some(_), Some(p))
            if same_file(&a.disc_file, Some(&p.disc_file)) && p.loaded.disc.is_some() =>
        {
            p.loaded.disc.clone()
        }
        (Some(path), _) => Some(read("disc_file", path)?),
    };
    let marker = match (&a.marker_file, previous) {
        (None, _) => None,
        (Some(_), Some(p))
            if same_file(&a.marker_file, Some(&p.marker_file)) && p.loaded.marker.is_some() =>
        {
            p.loaded.marker.clone()
        }
        (Some(path), _) => Some(read("marker_file", path)?),
    };
    let background = match (&a.background_file, previous) {
        (None, _) => None,
        (Some(_), Some(p))
            if same_file(&a.background_file, Some(&p.background_file))
                && p.loaded.background.is_some() =>
        {
            p.loaded.background.clone()
        }
        (Some(path), _) => Some(Arc::new(BackgroundTexture(
            Arc::try_unwrap(read("background_file", path)?).unwrap_or_else(|t| (*t).clone()),
        ))),
    };
    let sc = &scenario.scene;
    if let (Some(t), Some(path)) = (&disc, &a.disc_file) {
        let s = a.disc_mm_per_texel;
        let [cu, cv] = a
            .disc_centre_texel
            .unwrap_or([(t.width as f64 - 1.0) / 2.0, (t.height as f64 - 1.0) / 2.0]);
        // Texel i covers [i − ½, i + ½]: the texture spans [−½, width − ½] texels.
        let reach_mm = s * [
            cu + 0.5,
            t.width as f64 - 0.5 - cu,
            cv + 0.5,
            t.height as f64 - 0.5 - cv,
        ]
        .into_iter()
        .fold(f64::INFINITY, f64::min);
        if reach_mm < sc.disc_radius_mm {
            return Err(external(
                "disc_file",
                path,
                format!(
                    "a texture smaller than the disc: {}x{} texels of {} mm with the wheel \
                     centre at texel ({cu}, {cv}) reach {reach_mm:.3} mm from the centre, the \
                     disc's radius is {} mm (scene.disc_radius_mm)",
                    t.width,
                    t.height,
                    crate::validation::short(s),
                    crate::validation::short(sc.disc_radius_mm)
                ),
            ));
        }
    }
    if let (Some(t), Some(path)) = (&marker, &a.marker_file) {
        let m = &sc.marker;
        let cells = m.dictionary.marker_size_bits() + 2 * m.border_bits;
        let want = crate::scene::MarkerTexels::new(
            cells,
            m.size_mm,
            m.white_margin_mm,
            a.marker_texels_per_cell,
        );
        let side = want.side.round() as usize;
        if t.width != side || t.height != side {
            return Err(external(
                "marker_file",
                path,
                format!(
                    "is {}x{} texels; the marker's paper at {} texels per cell is {side}x{side} \
                     ({cells} cells and {} texels of white margin on each side)",
                    t.width,
                    t.height,
                    a.marker_texels_per_cell,
                    want.margin.round()
                ),
            ));
        }
    }
    if let (Some(BackgroundTexture(t)), Some(path)) = (background.as_deref(), &a.background_file) {
        let (w, h) = (
            scenario.camera.width_px as usize,
            scenario.camera.height_px as usize,
        );
        if (t.width, t.height) != (w, h) {
            return Err(external(
                "background_file",
                path,
                format!(
                    "is {}x{} texels; a background is the camera's size, {w}x{h} px \
                     (camera.width_px, camera.height_px)",
                    t.width, t.height
                ),
            ));
        }
    }
    let loaded = &mut scenario.scene.appearance.loaded;
    loaded.disc = disc;
    loaded.marker = marker;
    loaded.background = background;
    Ok(())
}
