//! Loader tests: extend, paths, error messages naming file and field.

use super::*;
use std::fs;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    fs::write(&p, text).unwrap();
    p
}

#[test]
fn builtins_load_and_validate() {
    for name in builtin_names() {
        let s = load_builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(s.name, name);
    }
}

#[test]
fn extend_overrides_fields_of_a_builtin_and_of_a_file() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "base.toml",
        "extend = \"fast\"\nname = \"base\"\nduration_s = 3.0\n",
    );
    let child = write(
        dir.path(),
        "child.toml",
        "extend = \"base.toml\"\nname = \"child\"\n",
    );
    let s = load(&child).unwrap();
    assert_eq!(s.name, "child");
    assert_eq!(s.duration_s, 3.0);
    assert_eq!(s.seed, load_builtin("fast").unwrap().seed);
}

#[test]
fn extend_cycle_and_missing_target_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let a = write(dir.path(), "a.toml", "extend = \"b.toml\"\nname = \"a\"\n");
    write(dir.path(), "b.toml", "extend = \"a.toml\"\nname = \"b\"\n");
    let msg = load(&a).unwrap_err().to_string();
    assert!(msg.contains("cycle"), "{msg}");
    let c = write(dir.path(), "c.toml", "extend = \"nowhere.toml\"\n");
    let msg = load(&c).unwrap_err().to_string();
    assert!(
        msg.contains("c.toml") && msg.contains("nowhere.toml"),
        "{msg}"
    );
}

#[test]
fn syntax_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "bad.toml", "name = \n");
    let msg = load(&p).unwrap_err().to_string();
    assert!(msg.contains("bad.toml") && msg.contains("TOML"), "{msg}");
}

#[test]
fn unknown_fields_are_rejected_with_their_path() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "u.toml", "extend = \"fast\"\nnmae = \"typo\"\n");
    let msg = load(&p).unwrap_err().to_string();
    assert!(msg.contains("u.toml") && msg.contains("nmae"), "{msg}");
    let p = write(
        dir.path(),
        "t.toml",
        "extend = \"fast\"\nduration_s = \"long\"\n",
    );
    let msg = load(&p).unwrap_err().to_string();
    assert!(msg.contains("duration_s"), "{msg}");
}

#[test]
fn out_of_range_values_name_field_and_range() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "r.toml",
        "extend = \"fast\"\nduration_s = -2.0\n",
    );
    let err = load(&p).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("r.toml") && msg.contains("duration_s") && msg.contains("must be in"),
        "{msg}"
    );
    assert_eq!(err.problems().len(), 1);
}

#[test]
fn resolved_scenario_round_trips_through_toml() {
    let s = load_builtin(DEFAULT_SCENARIO).unwrap();
    let text = s.to_toml();
    let back = from_str(&text, Path::new("shown.toml")).unwrap();
    assert_eq!(s, back);
}

/// Every field of every built-in scenario is documented in scenarios/README.md (as `section.key`
/// or, for top-level fields, `key`), so the documentation cannot silently fall behind the code.
#[test]
fn every_field_is_documented_in_scenarios_readme() {
    let readme = include_str!("../../scenarios/README.md");
    fn keys(prefix: &str, v: &toml::Value, out: &mut Vec<String>) {
        if let toml::Value::Table(t) = v {
            for (k, child) in t {
                let path = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                match child {
                    toml::Value::Table(_) => keys(&path, child, out),
                    _ => out.push(path),
                }
            }
        }
    }
    let mut missing = Vec::new();
    for name in builtin_names() {
        let value = toml::Value::try_from(load_builtin(name).unwrap()).unwrap();
        let mut all = Vec::new();
        keys("", &value, &mut all);
        for k in all {
            if !readme.contains(&format!("`{k}`")) && !missing.contains(&k) {
                missing.push(k);
            }
        }
    }
    assert!(
        missing.is_empty(),
        "fields not documented in scenarios/README.md: {missing:?}"
    );
}

#[test]
fn timing_logs_and_drive_tables_are_loaded_from_files_and_builtins() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "w.csv", "t_s,omega1_rad_s\n0,-1.5\n20,-1.5\n");
    write(dir.path(), "ts.csv", "frame,t_s\n0,0\n1,0.04\n2,0.07\n");
    let p = write(
        dir.path(),
        "s.toml",
        "extend = \"fast\"\n[drive_speed]\nkind = \"table\"\nfile = \"w.csv\"\n[frame_timing.model]\nkind = \"log\"\nfile = \"ts.csv\"\nformat = \"frames_csv\"\n",
    );
    let s = load(&p).unwrap();
    assert_eq!(s.timing_log.as_ref().unwrap().len(), 3);
    assert_eq!(s.frame_times().unwrap().len(), 3);
    match &s.drive_speed {
        crate::mechanism::DriveSpeedConfig::Table { t_s, .. } => assert_eq!(t_s, &vec![0.0, 20.0]),
        other => panic!("{other:?}"),
    }
    let b = write(
        dir.path(),
        "b.toml",
        "extend = \"fast\"\n[frame_timing.model]\nkind = \"log\"\nfile = \"builtin:model_test2\"\n",
    );
    assert_eq!(load(&b).unwrap().timing_log.unwrap().len(), 429);
    let m = write(
        dir.path(),
        "m.toml",
        "extend = \"fast\"\n[frame_timing.model]\nkind = \"log\"\nfile = \"missing.log\"\n",
    );
    let msg = load(&m).unwrap_err().to_string();
    assert!(
        msg.contains("m.toml")
            && msg.contains("frame_timing.model.file")
            && msg.contains("missing.log"),
        "{msg}"
    );
}

#[test]
fn overrides_replace_fields_and_are_validated() {
    let base = load_builtin("fast").unwrap();
    let o = vec![
        ("duration_s".to_string(), toml::Value::Float(1.5)),
        ("frame_timing.fps".to_string(), toml::Value::Float(60.0)),
    ];
    let s = with_overrides(&base, &o, Path::new("sweep.toml")).unwrap();
    assert_eq!(s.duration_s, 1.5);
    assert_eq!(s.frame_timing.fps, 60.0);
    let bad = vec![("duration_s".to_string(), toml::Value::Float(-1.0))];
    let msg = with_overrides(&base, &bad, Path::new("sweep.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("sweep.toml") && msg.contains("duration_s"),
        "{msg}"
    );
    let unknown = vec![("camera.nonsense".to_string(), toml::Value::Integer(1))];
    assert!(with_overrides(&base, &unknown, Path::new("sweep.toml")).is_err());
}

#[test]
fn overrides_on_a_base_with_a_timing_log_are_checked_against_the_logs_rate() {
    // A 120 fps log under a stale 30 fps: a sweep that sets a 20 ms exposure on it is refused
    // (the log carries over and its 8.3 ms interval bounds the exposure), 5 ms is not.
    let dir = tempfile::tempdir().unwrap();
    let t: Vec<f64> = (0..40).map(|k| k as f64 / 120.0).collect();
    let ts = crate::timing::Timestamps::new(t).unwrap();
    std::fs::write(
        dir.path().join("log.csv"),
        crate::timing::to_frames_csv(&ts),
    )
    .unwrap();
    let path = dir.path().join("base.toml");
    std::fs::write(
        &path,
        "extend = \"builtin:fast\"\nframe_timing.fps = 30.0\n\
         [frame_timing.model]\nkind = \"log\"\nfile = \"log.csv\"\nformat = \"frames_csv\"\n",
    )
    .unwrap();
    let base = load(&path).unwrap();
    let exposure = |s: f64| {
        vec![
            (
                "effects.motion_blur.enabled".to_string(),
                toml::Value::Boolean(true),
            ),
            (
                "effects.motion_blur.exposure_s".to_string(),
                toml::Value::Float(s),
            ),
        ]
    };
    let msg = with_overrides(&base, &exposure(0.02), Path::new("sweep.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("effects.motion_blur.exposure_s") && msg.contains("log.csv"),
        "{msg}"
    );
    let s = with_overrides(&base, &exposure(0.005), Path::new("sweep.toml")).unwrap();
    assert!(s.timing_log.is_some());
}

#[test]
fn builtin_prefix_and_directories_never_shadow_builtins() {
    // Regression: `geneva run fast --out fast` failed the second time: the output folder `fast/`
    // was taken for the scenario file.
    assert_eq!(load_any("builtin:fast").unwrap().name, "fast");
    let e = load_any("builtin:nope").unwrap_err().to_string();
    assert!(e.contains("builtin:nope") && e.contains("fast"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("fast");
    fs::create_dir(&sub).unwrap();
    let e = load_any(sub.to_str().unwrap()).unwrap_err();
    assert!(matches!(e, ScenarioError::NotAFile { .. }), "{e}");
    assert!(e.to_string().contains("is a directory"), "{e}");
    // `extend` takes the prefix too.
    let f = write(
        dir.path(),
        "e.toml",
        "extend = \"builtin:fast\"\nseed = 3\n",
    );
    assert_eq!(load(&f).unwrap().seed, 3);
}

/// `geneva scenario check` names impossible contact parameters by field (and the file).
#[test]
fn impossible_contact_parameters_name_their_field() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "bounce.toml",
        "extend = \"seed-internal-4k\"\n[dynamics]\ncontact_restitution = 1.2\n\
         [dynamics.crank]\nreflected_inertia_kg_m2 = -1.0\n",
    );
    let err = load(&p).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("bounce.toml")
            && msg.contains("dynamics.contact_restitution: must be in [0.01, 1]")
            && msg.contains("dynamics.crank.reflected_inertia_kg_m2"),
        "{msg}"
    );
    assert_eq!(err.problems().len(), 2);
    let p = write(
        dir.path(),
        "model.toml",
        "extend = \"seed-internal-4k\"\n[dynamics]\ncontact_model = \"elastic\"\n",
    );
    let msg = load(&p).unwrap_err().to_string();
    assert!(
        msg.contains("model.toml") && msg.contains("dynamics.contact_model"),
        "{msg}"
    );
}
