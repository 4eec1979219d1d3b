//! Conversions between the library's types and Python's: error text, override objects, and
//! the results of `analyze` and `calibrate`.

use geneva_vision::budget::error_bars::{feature_flags, sigma_relative_se};
use geneva_vision::calibrate::Fitted;
use geneva_vision::pipeline::analyze::AnalyzeOutput;
use geneva_vision::pipeline::calibrate::CalibrateOutput;
use geneva_vision::pipeline::error_bars::ErrorBars;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::json;
use std::path::{Path, PathBuf};

/// An error and its causes joined with ": ", each text once (the library's errors return
/// their cause from `source()` without repeating it; a cause already stated is left out).
pub fn error_text(error: &(dyn std::error::Error + 'static)) -> String {
    let mut text = String::new();
    let mut cause: Option<&(dyn std::error::Error + 'static)> = Some(error);
    while let Some(c) = cause {
        let t = c.to_string();
        if !t.is_empty() && !text.contains(&t) {
            if !text.is_empty() {
                text.push_str(": ");
            }
            text.push_str(&t);
        }
        cause = c.source();
    }
    text
}

/// A JSON object of dotted scenario paths and values as TOML values, in its order.
pub fn json_object(text: &str) -> Result<Vec<(String, toml::Value)>, String> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
    let serde_json::Value::Object(map) = value else {
        return Err("expected a mapping of field paths to values".into());
    };
    map.into_iter()
        .map(|(path, v)| {
            let t = toml::Value::try_from(&v)
                .map_err(|e| format!("`{path}` = {v}: not a scenario value ({e})"))?;
            Ok((path, t))
        })
        .collect()
}

pub fn array1<'py>(
    py: Python<'py>,
    values: impl Iterator<Item = f64>,
) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_vec(py, values.collect())
}

/// A per-frame flag as 1.0 (beyond the noise), 0.0 (within it) or NaN (no value or no bar).
fn flag_values(flags: &[Option<bool>]) -> impl Iterator<Item = f64> + '_ {
    flags
        .iter()
        .map(|f| f.map_or(f64::NAN, |b| if b { 1.0 } else { 0.0 }))
}

type Analysed = (
    AnalyzeOutput,
    Option<(ErrorBars, Vec<String>)>,
    Vec<String>,
    Vec<PathBuf>,
);

/// The analysis as a dict of arrays: the rows, each signal's measured values and, with error
/// bars, their σ, the modelled motion and the flags.
pub fn analysis_dict<'py>(
    py: Python<'py>,
    out: &Path,
    (analysis, bars, mut warnings, files): Analysed,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let rows = analysis.sample_rows();
    d.set_item("t_s", array1(py, rows.iter().map(|r| r.0)))?;
    let frame: Vec<i64> = rows.iter().map(|r| r.1 as i64).collect();
    d.set_item("frame", PyArray1::from_vec(py, frame))?;
    let present: Vec<bool> = rows.iter().map(|r| r.2).collect();
    d.set_item("in_input", PyArray1::from_vec(py, present))?;
    let signals = PyDict::new(py);
    for s in &analysis.signals {
        let sd = PyDict::new(py);
        sd.set_item("theta2_rad", PyArray1::from_slice(py, &s.theta2_rad))?;
        sd.set_item("omega2_rad_s", PyArray1::from_slice(py, &s.omega2_rad_s))?;
        sd.set_item("alpha2_rad_s2", PyArray1::from_slice(py, &s.alpha2_rad_s2))?;
        if let Some((all, _)) = &bars {
            if let Some(b) = all.signal(&s.signal) {
                let names = [
                    ("theta2_sigma_rad", "theta2_model_rad"),
                    ("omega2_sigma_rad_s", "omega2_model_rad_s"),
                    ("alpha2_sigma_rad_s2", "alpha2_model_rad_s2"),
                ];
                for (q, (sigma, model)) in names.iter().enumerate() {
                    sd.set_item(*sigma, PyArray1::from_slice(py, &b.sigma[q]))?;
                    sd.set_item(*model, PyArray1::from_slice(py, &b.model[q]))?;
                }
                let jump = &b.omega2_jump_sigma_rad_s;
                sd.set_item("omega2_jump_sigma_rad_s", PyArray1::from_slice(py, jump))?;
                let [alpha, omega_jump] =
                    feature_flags(b, &s.omega2_rad_s, &s.alpha2_rad_s2, all.k_sigma);
                sd.set_item("alpha2_beyond_noise", array1(py, flag_values(&alpha)))?;
                sd.set_item(
                    "omega2_jump_beyond_noise",
                    array1(py, flag_values(&omega_jump)),
                )?;
                let seeds: Vec<i64> = b.seeds.iter().map(|&n| n as i64).collect();
                sd.set_item("sigma_seeds", PyArray1::from_vec(py, seeds))?;
            }
        }
        signals.set_item(&s.signal, sd)?;
    }
    d.set_item("signals", signals)?;
    let c = &analysis.estimate.rotation_centre;
    d.set_item("rotation_centre_px", c.centre_px.to_vec())?;
    d.set_item("rotation_centre_sigma_px", c.centre_sigma_px.to_vec())?;
    d.set_item("detected_frames", analysis.estimate.detected)?;
    let input = &analysis.input;
    if !input.unreadable.is_empty() {
        warnings.push(format!(
            "{} frames unreadable (listed in unreadable_frames.csv)",
            input.unreadable.len()
        ));
    }
    if let Some(n) = &input.numbering {
        warnings.push(n.to_string());
    }
    if let Some(t) = &input.truncation {
        warnings.push(format!("truncated video: {t}"));
    }
    match &bars {
        Some((b, lines)) => {
            let info = PyDict::new(py);
            info.set_item("seeds", b.seeds.len())?;
            info.set_item("k_sigma", b.k_sigma)?;
            info.set_item("sigma_relative_se", sigma_relative_se(b.seeds.len()))?;
            info.set_item("motion_rms_rad", b.motion_rms_rad)?;
            info.set_item("summary", lines.clone())?;
            d.set_item("error_bars", info)?;
        }
        None => d.set_item("error_bars", py.None())?,
    }
    d.set_item("warnings", warnings)?;
    d.set_item("out", out)?;
    d.set_item("files", files)?;
    Ok(d)
}

fn fitted(f: &Fitted) -> serde_json::Value {
    json!({"value": f.value, "u95": f.u95})
}

/// The calibration's figures, the calibrated scenario and its re-render check as JSON text.
pub fn calibration_json(done: &CalibrateOutput) -> PyResult<String> {
    let c = &done.calibration;
    let g = &c.geometry;
    let im = &c.imaging;
    let scenario = serde_json::to_value(&done.scenario)
        .map_err(|e| super::GenevaError::new_err(format!("calibrated scenario: {e}")))?;
    let file = done.files.iter().find(|f| f.ends_with("scenario.toml"));
    let value = json!({
        "scenario": scenario,
        "scenario_file": file,
        "frames": c.frames,
        "detected_frames": c.detected_frames,
        "geometry": {
            "mm_per_px": fitted(&g.mm_per_px),
            "marker_side_px": g.side_px,
            "rotation_centre_px": g.centre_px.map(|[x, y]| [fitted(&x), fitted(&y)]),
            "marker_radius_mm": fitted(&g.radius_mm),
        },
        "motion": c.motion.as_ref().map(|m| json!({
            "omega1_rad_s": fitted(&m.omega1_rad_s),
            "theta1_start_rad": fitted(&m.theta1_start_rad),
            "engagements": m.engagements,
        })),
        "imaging": {
            "ink_dn": fitted(&im.ink_dn),
            "paper_dn": fitted(&im.paper_dn),
            "blur_sigma_px": im.blur_sigma_px.as_ref().map(fitted),
            "noise": {
                "ink_sigma_dn": fitted(&im.noise.ink_sigma_dn),
                "paper_sigma_dn": fitted(&im.noise.paper_sigma_dn),
                "not_identifiable": im.noise.footage_not_identifiable,
                "source": im.noise.source,
            },
        },
        "check": done.check.as_ref().map(|k| json!({
            "passed": k.passed(),
            "frame": k.frame,
            "residual_rms_dn": k.residual_rms_dn,
            "expected_noise_dn": k.expected_noise_dn,
            "ratio": k.ratio(),
        })),
        "notes": c.notes,
        "files": done.files,
    });
    Ok(value.to_string())
}
