//! `geneva_vision._native`: the library's jobs for Python. Every function here converts
//! arguments, runs one library call with the GIL released, and converts the result: arrays as
//! NumPy arrays, reports as JSON text that `geneva_vision/__init__.py` turns into dicts. No
//! measurement logic lives here.
#![cfg(feature = "opencv-detector")]

mod convert;

use convert::{array1, error_text, json_object};
use geneva_vision::io::output_dir::{refuse_inputs_inside, Input, OutputDir};
use geneva_vision::pipeline::analyze::{
    analyze as analyze_job, AnalyzeError, AnalyzeOptions, Source,
};
use geneva_vision::pipeline::error_bars::{error_bars, write_error_bars, ErrorBarOptions};
use geneva_vision::pipeline::render_job::{render_each, render_job, RenderJob, Renderer};
use geneva_vision::pipeline::rig::Rig;
use geneva_vision::scenario::{self, Scenario};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::{Path, PathBuf};

create_exception!(
    _native,
    GenevaError,
    PyException,
    "A job of geneva-vision failed; the message names the file, field or frame."
);
create_exception!(
    _native,
    ScenarioError,
    GenevaError,
    "A scenario could not be loaded: the message names the file and the field."
);

/// A job's failure as a `GenevaError` carrying the library's message and its causes.
fn failed(e: &(dyn std::error::Error + 'static)) -> PyErr {
    GenevaError::new_err(error_text(e))
}

/// A Python callable `progress(what, done, total)`, or nothing. Called from the library's
/// worker threads: each call takes the GIL for the call only.
struct Progress(Option<Py<PyAny>>);

impl Progress {
    fn report(&self, what: &str, done: usize, total: usize) {
        if let Some(callback) = &self.0 {
            Python::with_gil(|py| {
                // A failing progress display must not abort the job: its error is shown.
                if let Err(e) = callback.call1(py, (what, done, total)) {
                    e.print(py);
                }
            });
        }
    }
}

/// `spec` (a scenario file or built-in name) with `overrides` (a JSON object of dotted field
/// paths and values, `{"camera.distance_m": 0.4}`) applied and validated again.
fn load_scenario(spec: &str, overrides: Option<&str>) -> PyResult<Scenario> {
    let base = scenario::load_any(spec).map_err(|e| ScenarioError::new_err(error_text(&e)))?;
    let Some(text) = overrides else {
        return Ok(base);
    };
    let pairs = json_object(text)
        .map_err(|why| ScenarioError::new_err(format!("{spec}: overrides: {why}")))?;
    scenario::with_overrides(&base, &pairs, Path::new(spec))
        .map_err(|e| ScenarioError::new_err(error_text(&e)))
}

/// The files that loading `spec` reads, named for messages (an output folder must not hold
/// them: committing it would delete them).
fn scenario_inputs(option: &str, spec: &str) -> Vec<Input> {
    scenario::files_read(spec)
        .into_iter()
        .map(|(what, path)| Input::new(format!("{option} {what}"), path))
        .collect()
}

/// The footage named by exactly one of `video`, `frames` + `timestamps`, `tracks`.
fn source(
    video: Option<PathBuf>,
    frames: Option<PathBuf>,
    timestamps: Option<PathBuf>,
    tracks: Option<PathBuf>,
) -> PyResult<(Source, Vec<Input>)> {
    match (video, frames, timestamps, tracks) {
        (Some(v), None, None, None) => Ok((Source::Video(v.clone()), vec![Input::new("video", v)])),
        (None, Some(dir), Some(ts), None) => Ok((
            Source::Frames {
                dir: dir.clone(),
                timestamps: ts.clone(),
            },
            vec![Input::new("frames", dir), Input::new("timestamps", ts)],
        )),
        (None, None, None, Some(t)) => {
            Ok((Source::Tracks(t.clone()), vec![Input::new("tracks", t)]))
        }
        (None, Some(_), None, None) => Err(PyValueError::new_err(
            "frames= needs timestamps= (a CSV with one time in seconds per frame)",
        )),
        _ => Err(PyValueError::new_err(
            "give exactly one footage: video=, frames= with timestamps=, or tracks=",
        )),
    }
}

fn renderer(name: &str) -> PyResult<Renderer> {
    match name {
        "own" => Ok(Renderer::Own),
        "independent" => Ok(Renderer::Independent),
        other => Err(PyValueError::new_err(format!(
            "renderer `{other}`: expected `own` or `independent`"
        ))),
    }
}

/// The resolved scenario as JSON.
#[pyfunction]
#[pyo3(signature = (spec, overrides=None))]
fn scenario_json(py: Python<'_>, spec: &str, overrides: Option<&str>) -> PyResult<String> {
    let s = py.allow_threads(|| load_scenario(spec, overrides))?;
    serde_json::to_string(&s).map_err(|e| GenevaError::new_err(format!("{spec}: {e}")))
}

/// What `geneva scenario check` says: the work, the rig's frames and the warnings, as JSON.
#[pyfunction]
#[pyo3(signature = (spec, overrides=None))]
fn check_scenario(py: Python<'_>, spec: &str, overrides: Option<&str>) -> PyResult<String> {
    py.allow_threads(|| {
        let s = load_scenario(spec, overrides)?;
        let work = geneva_vision::pipeline::workload::Workload::of(&s, true);
        let mut warnings: Vec<String> = Vec::new();
        let mut frames = None;
        let over_limits = work.over_limits();
        if over_limits.is_none() {
            let rig = Rig::new(&s).map_err(|e| failed(&e))?;
            geneva_vision::pipeline::run::measurable(&rig).map_err(|e| failed(&e))?;
            frames = Some(rig.frame_times.len());
            warnings.extend(geneva_vision::pipeline::run::detection_warnings(&rig));
        }
        warnings.extend(
            scenario::clipping::warnings(&s)
                .into_iter()
                .map(|w| format!("{}: {}", w.field, w.message)),
        );
        Ok(serde_json::json!({
            "name": s.name,
            "frames": frames,
            "work": work.to_string(),
            "over_limits": over_limits,
            "warnings": warnings,
        })
        .to_string())
    })
}

/// The true motion at `t_s` (default: the frame times): ideal and, where the scenario has
/// dynamics, actual.
#[pyfunction]
#[pyo3(signature = (spec, overrides=None, t_s=None))]
fn kinematics<'py>(
    py: Python<'py>,
    spec: &str,
    overrides: Option<&str>,
    t_s: Option<PyReadonlyArray1<'py, f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let times: Option<Vec<f64>> = t_s.map(|a| a.as_array().to_vec());
    let (times, rows, has_actual) = py.allow_threads(|| {
        let s = load_scenario(spec, overrides)?;
        let rig = Rig::new(&s).map_err(|e| failed(&e))?;
        let times = times.unwrap_or_else(|| rig.frame_times.as_slice().to_vec());
        if let Some(bad) = times.iter().position(|t| !t.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "t_s[{bad}] = {}: times must be finite seconds",
                times[bad]
            )));
        }
        let rows = rig.mechanism.truth_rows(&times);
        Ok((times, rows, rig.mechanism.has_actual_motion()))
    })?;
    let out = PyDict::new(py);
    out.set_item("t_s", PyArray1::from_vec(py, times))?;
    type Pick = fn(&geneva_vision::mechanism::MotionSample) -> f64;
    let columns: [(&str, Pick); 6] = [
        ("theta1_rad", |m| m.theta1_rad),
        ("omega1_rad_s", |m| m.omega1_rad_s),
        ("theta2_rad", |m| m.theta2_rad),
        ("omega2_rad_s", |m| m.omega2_rad_s),
        ("alpha2_rad_s2", |m| m.alpha2_rad_s2),
        ("jerk2_rad_s3", |m| m.jerk2_rad_s3),
    ];
    for (name, pick) in columns {
        out.set_item(name, array1(py, rows.iter().map(|(ideal, _)| pick(ideal))))?;
        if has_actual {
            let actual = format!("actual_{name}");
            out.set_item(actual, array1(py, rows.iter().map(|(_, a)| pick(a))))?;
        }
    }
    let phases: Vec<&str> = rows.iter().map(|(i, _)| i.phase.as_str()).collect();
    out.set_item("phase", PyList::new(py, phases)?)?;
    Ok(out)
}

/// Frames `start..end` as one `uint8` array (frames, height, width).
#[pyfunction]
#[pyo3(signature = (spec, overrides, start, end, renderer_name, progress=None))]
fn render<'py>(
    py: Python<'py>,
    spec: &str,
    overrides: Option<&str>,
    start: usize,
    end: usize,
    renderer_name: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let which = renderer(renderer_name)?;
    let progress = Progress(progress);
    let (shape, data) = py.allow_threads(|| {
        let s = load_scenario(spec, overrides)?;
        let (w, h) = (s.camera.width_px as usize, s.camera.height_px as usize);
        // One buffer of the final size, reserved once the range has been checked (the first
        // frame arrives only then): the frames are copied in as they are drawn.
        let mut data: Vec<u8> = Vec::new();
        let report = |done, total| progress.report("render", done, total);
        render_each(&s, start..end, which, &report, &mut |img| {
            if data.is_empty() {
                data.reserve_exact((end - start) * img.data.len());
            }
            data.extend_from_slice(&img.data)
        })
        .map_err(|e| failed(&e))?;
        let frames = data.len() / (w * h).max(1);
        Ok::<_, PyErr>(([frames, h, w], data))
    })?;
    Ok(PyArray1::from_vec(py, data).reshape(shape)?.into_any())
}

/// `geneva render` into `out`: PNG frames (or an MP4 at `video`), `timestamps.csv`, `truth.csv`.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (spec, overrides, out, start, end, video, renderer_name, progress=None))]
fn render_files(
    py: Python<'_>,
    spec: &str,
    overrides: Option<&str>,
    out: PathBuf,
    start: Option<usize>,
    end: Option<usize>,
    video: Option<PathBuf>,
    renderer_name: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<PathBuf>> {
    let which = renderer(renderer_name)?;
    let progress = Progress(progress);
    py.allow_threads(|| {
        let s = load_scenario(spec, overrides)?;
        refuse_inputs_inside(&out, &scenario_inputs("scenario", spec)).map_err(|e| failed(&e))?;
        let staged = OutputDir::create(&out).map_err(|e| failed(&e))?;
        let video = match video {
            Some(v) => Some(std::path::absolute(&v).map_err(|e| failed(&e))?),
            None => None,
        };
        // A video inside the output folder goes into the staging folder like the rest.
        let video = video.map(|abs| match abs.strip_prefix(staged.dir()) {
            Ok(rel) => staged.path().join(rel),
            Err(_) => abs,
        });
        let outside = video
            .clone()
            .filter(|v| !v.starts_with(staged.path()))
            .into_iter();
        let job = RenderJob {
            frames: start.zip(end).map(|(a, b)| a..b),
            roi_margin_px: None,
            png: video.is_none(),
            video,
            renderer: which,
        };
        render_job(&s, staged.path(), &job, &|done, total| {
            progress.report("render", done, total)
        })
        .map_err(|e| failed(&e))?;
        let mut files = staged.commit().map_err(|e| failed(&e))?;
        files.extend(outside);
        Ok(files)
    })
}

/// `geneva analyze` into `out`: the measured θ2, ω2, α2 of every signal and, with a scenario,
/// their error bars. Returns the arrays; `warnings` holds what the CLI prints as warnings.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (out, video, frames, timestamps, tracks, spec, overrides, angle_sign, error_bar_seeds, k_sigma, progress=None))]
fn analyze<'py>(
    py: Python<'py>,
    out: PathBuf,
    video: Option<PathBuf>,
    frames: Option<PathBuf>,
    timestamps: Option<PathBuf>,
    tracks: Option<PathBuf>,
    spec: Option<&str>,
    overrides: Option<&str>,
    angle_sign: f64,
    error_bar_seeds: usize,
    k_sigma: f64,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    if angle_sign.abs() != 1.0 {
        return Err(PyValueError::new_err("angle_sign must be +1 or -1"));
    }
    if error_bar_seeds == 1 {
        return Err(PyValueError::new_err(
            "error_bar_seeds: an RMS needs at least 2 seeds (0 turns the error bars off)",
        ));
    }
    if !(k_sigma.is_finite() && k_sigma > 0.0) {
        return Err(PyValueError::new_err(format!(
            "k_sigma: expected a positive number, got {k_sigma}"
        )));
    }
    let (src, mut inputs) = source(video, frames, timestamps, tracks)?;
    let progress = Progress(progress);
    let done = py.allow_threads(|| {
        let rig = spec.map(|s| load_scenario(s, overrides)).transpose()?;
        if let Some(s) = spec {
            inputs.extend(scenario_inputs("scenario", s));
        }
        refuse_inputs_inside(&out, &inputs).map_err(|e| failed(&e))?;
        let options = match &rig {
            Some(s) => AnalyzeOptions::from_scenario(s, angle_sign),
            None => AnalyzeOptions {
                angle_sign,
                ..AnalyzeOptions::default()
            },
        };
        let staged = OutputDir::create(&out).map_err(|e| failed(&e))?;
        let analysis = match analyze_job(&src, &options, staged.path(), &|done, total| {
            progress.report("detect", done, total)
        }) {
            Ok(a) => a,
            // The detections are the expensive part and are complete: they are kept, as the
            // command line keeps them, so that another estimator can be tried on them.
            Err(e @ AnalyzeError::Estimate { .. })
                if staged.path().join("tracks.csv").is_file() =>
            {
                staged.commit().map_err(|c| failed(&c))?;
                let kept = out.join("tracks.csv");
                return Err(GenevaError::new_err(format!(
                    "{}; the detections are kept in {}: analyze(tracks=...) tries another \
                     estimator on them",
                    error_text(&e),
                    kept.display()
                )));
            }
            Err(e) => return Err(failed(&e)),
        };
        let mut warnings = Vec::new();
        let mut bars = None;
        if let Some(s) = rig.filter(|_| error_bar_seeds > 0) {
            let opts = ErrorBarOptions {
                seeds: error_bar_seeds,
                k_sigma,
            };
            let made = error_bars(&s, &analysis, angle_sign, &opts, &|done, total| {
                progress.report("simulate", done, total)
            });
            match made {
                Ok(b) => {
                    let lines =
                        write_error_bars(staged.path(), &analysis, &b).map_err(|e| failed(&e))?;
                    bars = Some((b, lines));
                }
                // The analysis stands without them, as on the command line.
                Err(e) => warnings.push(format!("no error bars: {}", error_text(&e))),
            }
        }
        let files = staged.commit().map_err(|e| failed(&e))?;
        Ok::<_, PyErr>((analysis, bars, warnings, files))
    })?;
    convert::analysis_dict(py, &out, done)
}

/// `geneva run` into `out`; returns `budget.json`'s text and the files written.
#[pyfunction]
#[pyo3(signature = (spec, overrides, out, full_frame, progress=None))]
fn run(
    py: Python<'_>,
    spec: &str,
    overrides: Option<&str>,
    out: PathBuf,
    full_frame: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Vec<PathBuf>)> {
    let progress = Progress(progress);
    py.allow_threads(|| {
        let s = load_scenario(spec, overrides)?;
        refuse_inputs_inside(&out, &scenario_inputs("scenario", spec)).map_err(|e| failed(&e))?;
        let staged = OutputDir::create(&out).map_err(|e| failed(&e))?;
        let options = geneva_vision::pipeline::run::RunOptions {
            roi: !full_frame,
            ..Default::default()
        };
        geneva_vision::pipeline::run::run(&s, staged.path(), &options, &|done, total| {
            progress.report("render+detect", done, total)
        })
        .map_err(|e| failed(&e))?;
        let files = staged.commit().map_err(|e| failed(&e))?;
        Ok((read_text(&out.join("budget.json"))?, files))
    })
}

/// `geneva montecarlo` into `out` (resumes a study left incomplete there); returns
/// `budget.json`'s text and whether every seed is done (always true: an incomplete study is an
/// error).
#[pyfunction]
#[pyo3(signature = (spec, overrides, out, seeds, full_frame, progress=None))]
fn montecarlo(
    py: Python<'_>,
    spec: &str,
    overrides: Option<&str>,
    out: PathBuf,
    seeds: usize,
    full_frame: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, bool)> {
    use geneva_vision::pipeline::montecarlo::{monte_carlo_study, MonteCarloRun};
    let progress = Progress(progress);
    py.allow_threads(|| {
        let s = load_scenario(spec, overrides)?;
        refuse_inputs_inside(&out, &scenario_inputs("scenario", spec)).map_err(|e| failed(&e))?;
        let report = |done: usize, total: usize| progress.report("montecarlo", done, total);
        let control = geneva_vision::shard::Control {
            progress: &report,
            stop: &|| false,
        };
        let run = MonteCarloRun {
            seeds,
            roi: !full_frame,
            shard: None,
            restart: false,
            control: &control,
        };
        let outcome = monte_carlo_study(&s, &out, &run).map_err(|e| failed(&e))?;
        if !outcome.report.complete {
            return Err(GenevaError::new_err(format!(
                "montecarlo ended with {} of {} seeds done; the same call resumes it in {}",
                outcome.report.units_resumed + outcome.report.units_run,
                outcome.report.units_total,
                out.display()
            )));
        }
        Ok((read_text(&out.join("budget.json"))?, true))
    })
}

/// `geneva calibrate` into `out`; returns the calibration as JSON text.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (base, out, video, frames, timestamps, image, single_frame, progress=None))]
fn calibrate(
    py: Python<'_>,
    base: &str,
    out: PathBuf,
    video: Option<PathBuf>,
    frames: Option<PathBuf>,
    timestamps: Option<PathBuf>,
    image: Option<PathBuf>,
    single_frame: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    use geneva_vision::pipeline::calibrate::Footage;
    let (footage, mut inputs) = match (image, video, frames, timestamps) {
        (Some(i), None, None, None) => (Footage::Image(i.clone()), vec![Input::new("image", i)]),
        (None, v, f, t) => match source(v, f, t, None)? {
            (Source::Video(v), inputs) => (Footage::Video(v), inputs),
            (Source::Frames { dir, timestamps }, inputs) => {
                (Footage::Frames { dir, timestamps }, inputs)
            }
            (Source::Tracks(_), _) => unreachable!("no tracks were given"),
        },
        _ => {
            return Err(PyValueError::new_err(
                "give exactly one footage: image=, video=, or frames= with timestamps=",
            ))
        }
    };
    inputs.extend(scenario_inputs("base", base));
    let progress = Progress(progress);
    py.allow_threads(|| {
        refuse_inputs_inside(&out, &inputs).map_err(|e| failed(&e))?;
        let options = geneva_vision::calibrate::CalibrateOptions { single_frame };
        let done = geneva_vision::pipeline::calibrate::calibrate(
            &footage,
            base,
            &out,
            &options,
            &|done, total| progress.report("measure", done, total),
        )
        .map_err(|e| failed(&e))?;
        convert::calibration_json(&done)
    })
}

/// `geneva diagnose` into `out`; returns `diagnosis.json`'s text and the files written.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (spec, overrides, out, video, frames, timestamps, tracks, effects, seeds, max_minutes, progress=None))]
fn diagnose(
    py: Python<'_>,
    spec: &str,
    overrides: Option<&str>,
    out: PathBuf,
    video: Option<PathBuf>,
    frames: Option<PathBuf>,
    timestamps: Option<PathBuf>,
    tracks: Option<PathBuf>,
    effects: Option<Vec<String>>,
    seeds: usize,
    max_minutes: Option<f64>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Vec<PathBuf>)> {
    use geneva_vision::diagnose::simulator::SimMeter;
    use geneva_vision::pipeline::diagnose::{diagnose as diagnose_job, DiagnoseOptions};
    use geneva_vision::scenario::effects::Effect;
    let (src, mut inputs) = source(video, frames, timestamps, tracks)?;
    let effects = effects
        .map(|names| {
            names
                .iter()
                .map(|n| {
                    Effect::from_name(n).ok_or_else(|| {
                        PyValueError::new_err(format!(
                            "effects: `{n}` is not an effect; the vocabulary is: {}",
                            Effect::names()
                        ))
                    })
                })
                .collect::<PyResult<Vec<Effect>>>()
        })
        .transpose()?;
    if let Some(m) = max_minutes.filter(|m| !(m.is_finite() && *m > 0.0)) {
        return Err(PyValueError::new_err(format!(
            "max_minutes {m}: must be a positive number of minutes"
        )));
    }
    if seeds < 2 {
        return Err(PyValueError::new_err(
            "seeds: a spread needs at least 2 simulated seeds",
        ));
    }
    let progress = Progress(progress);
    py.allow_threads(|| {
        let nominal = load_scenario(spec, overrides)?;
        inputs.extend(scenario_inputs("scenario", spec));
        refuse_inputs_inside(&out, &inputs).map_err(|e| failed(&e))?;
        let meter = std::sync::Arc::new(SimMeter::default());
        let options = DiagnoseOptions {
            seeds,
            effects,
            max_minutes,
            meter: Some(meter.clone()),
            ..DiagnoseOptions::default()
        };
        let (_, files) = diagnose_job(&nominal, &src, &out, &options, &|stage, _, _| {
            progress.report(stage, meter.done(), meter.planned())
        })
        .map_err(|e| failed(&e))?;
        Ok((read_text(&out.join("diagnosis.json"))?, files))
    })
}

fn read_text(path: &Path) -> PyResult<String> {
    std::fs::read_to_string(path)
        .map_err(|e| GenevaError::new_err(format!("{}: {e}", path.display())))
}

/// The built-in scenario names.
#[pyfunction]
fn builtin_scenarios() -> Vec<&'static str> {
    scenario::builtin_names()
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("GenevaError", m.py().get_type::<GenevaError>())?;
    m.add("ScenarioError", m.py().get_type::<ScenarioError>())?;
    m.add_function(wrap_pyfunction!(scenario_json, m)?)?;
    m.add_function(wrap_pyfunction!(check_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(builtin_scenarios, m)?)?;
    m.add_function(wrap_pyfunction!(kinematics, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(render_files, m)?)?;
    m.add_function(wrap_pyfunction!(analyze, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(montecarlo, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    Ok(())
}
