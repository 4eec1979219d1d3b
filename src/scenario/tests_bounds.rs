//! Physical bounds: every numeric field of a scenario has a finite documented range,
//! so no value `check` accepts can make `run` panic or allocate without bound, and combinations
//! that make a run impossible are reported by `check` too.

use super::*;

/// Built-ins and variants that together select every `kind` and switch every section on, so
/// that every numeric field of the scenario format appears in one of them.
fn bases() -> Vec<Value> {
    let variants = [
        "extend = \"fast\"",
        "extend = \"seed-internal-4k\"",
        "extend = \"seed-external-4k\"",
        r#"extend = "fast"
mechanism.crank_radius_mm = 17.677669529663689
mechanism.theta1_start_rad = 0.5
[camera.focal]
kind = "physical"
focal_length_mm = 4.0
sensor_width_mm = 6.0
[drive_speed]
kind = "polynomial_per_engagement"
end_rad_s = -1.55
mid_rad_s = -1.40
[frame_timing.model]
kind = "vfr"
[estimator.differentiator]
kind = "savitzky_golay"
window_s = 0.3
[estimator.timebase]
kind = "constant_fps"
fps_hz = 30.0
[dynamics]
enabled = true
wheel_inertia_kg_m2 = 0.005
[effects.camera_vibration]
enabled = true
x_px = [{ amplitude = 0.1, frequency_hz = 5.0, phase_rad = 0.0 }]
[scene.reference_marker]
enabled = true
[detector]
reference_marker_id = 1
"#,
        r#"extend = "fast"
[camera.focal]
kind = "field_of_view"
hfov_deg = 60.0
[drive_speed]
kind = "table"
t_s = [0.0, 1.0]
omega1_rad_s = [-1.5, -1.6]
[frame_timing.model]
kind = "log"
file = "builtin:model_test1"
[estimator.differentiator]
kind = "kalman_rts"
lambda_per_s6 = 1e9
"#,
    ];
    variants
        .iter()
        .map(|text| {
            let s = from_str(text, Path::new("variant.toml")).unwrap_or_else(|e| panic!("{e}"));
            Value::try_from(&s).unwrap()
        })
        .collect()
}

/// Paths of every numeric leaf (array elements as `path[i]`).
fn numeric_leaves(v: &Value, path: &str, out: &mut Vec<String>) {
    match v {
        Value::Integer(_) | Value::Float(_) => out.push(path.to_string()),
        Value::Table(t) => {
            for (k, x) in t {
                let p = if path.is_empty() {
                    k.clone()
                } else {
                    format!("{path}.{k}")
                };
                numeric_leaves(x, &p, out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                numeric_leaves(x, &format!("{path}[{i}]"), out);
            }
        }
        _ => {}
    }
}

fn leaf_mut<'a>(v: &'a mut Value, path: &str) -> &'a mut Value {
    let mut cur = v;
    for part in path.split('.') {
        let (key, index) = match part.split_once('[') {
            Some((k, i)) => (k, Some(i.trim_end_matches(']').parse::<usize>().unwrap())),
            None => (part, None),
        };
        cur = cur.as_table_mut().unwrap().get_mut(key).unwrap();
        if let Some(i) = index {
            cur = &mut cur.as_array_mut().unwrap()[i];
        }
    }
    cur
}

fn with_leaf(base: &Value, path: &str, x: Value) -> Result<Scenario, ScenarioError> {
    let mut v = base.clone();
    *leaf_mut(&mut v, path) = x;
    finish(v, Path::new("probe.toml"))
}

#[test]
fn every_numeric_field_refuses_extreme_values_naming_itself() {
    // Regression: 17 fields accepted 1e308; disc radius and focal length of 1e308 panicked in
    // `run`, 1e12 aborted on a gigabytes-large allocation.
    let mut checked = 0;
    for base in bases() {
        let mut leaves = Vec::new();
        numeric_leaves(&base, "", &mut leaves);
        for path in leaves.iter().filter(|p| *p != "seed") {
            let field = path.split('[').next().unwrap();
            let extremes = match leaf_mut(&mut base.clone(), path) {
                Value::Integer(_) => vec![Value::Integer(i64::MAX), Value::Integer(i64::MIN)],
                _ => vec![Value::Float(1e308), Value::Float(-1e308)],
            };
            for x in extremes {
                let shown = x.to_string();
                match with_leaf(&base, path, x) {
                    Ok(_) => panic!("{path} = {shown} accepted"),
                    Err(e) => {
                        let text = e.to_string();
                        assert!(text.contains(field), "{path} = {shown}: {text}");
                        assert!(text.len() < 2000, "{path}: message of {} bytes", text.len());
                    }
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 400, "{checked}");
}

#[test]
fn values_from_the_issue_are_named_errors() {
    let base = Value::try_from(load_builtin("fast").unwrap()).unwrap();
    for (path, x) in [
        ("scene.disc_radius_mm", 1e12),
        ("scene.disc_radius_mm", 1e308),
        ("dynamics.wheel_mass_kg", 1e-300),
        ("camera.focal.mm_per_px", 1e-300),
    ] {
        let e = with_leaf(&base, path, Value::Float(x))
            .unwrap_err()
            .to_string();
        assert!(e.contains(path), "{path} = {x}: {e}");
    }
    let physical = |focal: f64| {
        from_str(
            &format!(
                "extend = \"fast\"\n[camera.focal]\nkind = \"physical\"\nfocal_length_mm = {focal:e}\n\
                 sensor_width_mm = 6.0\n"
            ),
            Path::new("f.toml"),
        )
    };
    for focal in [1e12, 1e308] {
        let e = physical(focal).unwrap_err().to_string();
        assert!(e.contains("camera.focal.focal_length_mm"), "{e}");
    }
}

fn problems_of(text: &str) -> Vec<String> {
    match from_str(text, Path::new("c.toml")) {
        Ok(_) => Vec::new(),
        Err(e) => e.problems().iter().map(|p| p.to_string()).collect(),
    }
}

#[test]
fn combinations_that_make_a_run_impossible_are_check_errors() {
    // Regression: a detector marker id other than the drawn one passed `check`; `run` reported
    // only "too few detected frames: 0".
    let p = problems_of("extend = \"fast\"\ndetector.marker_id = 3\n");
    assert!(
        p.len() == 1 && p[0].starts_with("detector.marker_id") && p[0].contains("scene.marker.id"),
        "{p:?}"
    );
    let p = problems_of("extend = \"fast\"\ndetector.dictionary = \"5x5_50\"\n");
    assert!(
        p.iter().any(|m| m.starts_with("detector.dictionary")),
        "{p:?}"
    );
    // A larger dictionary of the same bit size decodes the drawn marker.
    assert!(problems_of("extend = \"fast\"\ndetector.dictionary = \"4x4_1000\"\n").is_empty());
    let p = problems_of("extend = \"fast\"\ndetector.marker_border_bits = 2\n");
    assert!(
        p.iter()
            .any(|m| m.starts_with("detector.marker_border_bits")),
        "{p:?}"
    );
    // Regression: a 0.1 g wheel with the default contact stiffness passed `check` and failed in
    // `run`; the step limit is now a check error naming the fields it depends on.
    let p = problems_of(
        "extend = \"seed-internal-4k\"\ndynamics.wheel_mass_kg = 1e-4\ndynamics.contact_stiffness_n_m = 1e10\n",
    );
    assert!(
        p.len() == 1
            && p[0].starts_with("dynamics.step_s: must be <=")
            && p[0].contains("contact_stiffness_n_m = 1e10"),
        "{p:?}"
    );
    // A disc far larger than the image at this scale.
    let p = problems_of(
        "extend = \"fast\"\nscene.disc_radius_mm = 10000.0\ncamera.focal.mm_per_px = 0.001\n\
         scene.marker.radius_mm = 100.0\n",
    );
    assert!(
        p.iter()
            .any(|m| m.starts_with("scene.disc_radius_mm: images")),
        "{p:?}"
    );
}

#[test]
fn an_exposure_or_a_readout_longer_than_a_frame_interval_is_a_check_error() {
    // The self-check's registry probes (20 ms, 30 ms) on a 60 fps rig: each fine alone, but no
    // camera exposes or reads out a frame for longer than the 16.7 ms between two frames.
    let p = problems_of(
        "extend = \"fast\"\nframe_timing.fps = 60.0\neffects.motion_blur.enabled = true\neffects.motion_blur.exposure_s = 0.02\n\
         effects.rolling_shutter.enabled = true\neffects.rolling_shutter.readout_s = 0.03\n",
    );
    assert_eq!(p.len(), 2, "{p:?}");
    assert!(
        p[0].starts_with("effects.motion_blur.exposure_s: 0.02 s is longer than one frame")
            && p[0].contains("at frame_timing.fps = 60"),
        "{p:?}"
    );
    assert!(
        p[1].starts_with("effects.rolling_shutter.readout_s: 0.03 s"),
        "{p:?}"
    );
    // The same values at 30 fps (33.3 ms), an exposure of exactly one interval, and a readout
    // that is switched off are all possible.
    assert!(problems_of(
        "extend = \"fast\"\neffects.motion_blur.enabled = true\neffects.motion_blur.exposure_s = 0.02\n\
         effects.rolling_shutter.enabled = true\neffects.rolling_shutter.readout_s = 0.03\n"
    )
    .is_empty());
    assert!(problems_of(
        "extend = \"fast\"\nframe_timing.fps = 50.0\neffects.motion_blur.enabled = true\neffects.motion_blur.exposure_s = 0.02\n"
    )
    .is_empty());
    assert!(problems_of(
        "extend = \"fast\"\nframe_timing.fps = 60.0\neffects.rolling_shutter.enabled = false\n\
         effects.rolling_shutter.readout_s = 0.03\n"
    )
    .is_empty());
    // A variable frame rate's clock runs at its actual rate: +10 % makes 20 ms too long at 50 fps.
    let p = problems_of(
        "extend = \"fast\"\nframe_timing.fps = 50.0\neffects.motion_blur.enabled = true\neffects.motion_blur.exposure_s = 0.02\n\
         [frame_timing.model]\nkind = \"vfr\"\nrate_error_ppm = 100000.0\n",
    );
    assert!(
        p.iter()
            .any(|m| m.starts_with("effects.motion_blur.exposure_s")),
        "{p:?}"
    );
}

#[test]
fn a_timing_logs_own_rate_bounds_the_exposure_not_a_stale_nominal_rate() {
    let dir = tempfile::tempdir().unwrap();
    let log_at = |name: &str, fps: f64| {
        let t: Vec<f64> = (0..40).map(|k| k as f64 / fps).collect();
        let ts = crate::timing::Timestamps::new(t).unwrap();
        std::fs::write(dir.path().join(name), crate::timing::to_frames_csv(&ts)).unwrap();
    };
    log_at("fast.csv", 120.0);
    log_at("slow.csv", 30.0);
    let scenario = |log: &str, fps: f64| {
        let path = dir.path().join(format!("{log}.toml"));
        std::fs::write(
            &path,
            format!(
                "extend = \"builtin:fast\"\nframe_timing.fps = {fps:.1}\n\
                 effects.motion_blur.enabled = true\neffects.motion_blur.exposure_s = 0.02\n\
                 [frame_timing.model]\nkind = \"log\"\nfile = \"{log}\"\nformat = \"frames_csv\"\n"
            ),
        )
        .unwrap();
        load(&path)
    };
    // A 120 fps log (8.3 ms) under a stale 30 fps: the 20 ms exposure is refused, naming the
    // field and the log.
    match scenario("fast.csv", 30.0) {
        Err(ScenarioError::Invalid { problems, .. }) => {
            assert_eq!(problems.len(), 1, "{problems:?}");
            assert_eq!(problems[0].field, "effects.motion_blur.exposure_s");
            assert!(
                problems[0]
                    .message
                    .starts_with("0.02 s is longer than one frame interval")
                    && problems[0]
                        .message
                        .contains("(8.333 ms, the median interval of the timing log ")
                    && problems[0].message.contains("fast.csv"),
                "{problems:?}"
            );
        }
        other => panic!("{other:?}"),
    }
    // A 30 fps log (33 ms) under a stale 120 fps: possible, and accepted.
    let s = scenario("slow.csv", 120.0).unwrap();
    assert!(s.timing_log.is_some());
}
