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
