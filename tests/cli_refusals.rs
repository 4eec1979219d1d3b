//! Hostile command lines refused before any work, naming what is wrong, and losing nothing: an
//! input inside the output folder it would be deleted with, Slurm values that would inject
//! commands or directives, jobs that would refuse to run, work above the limits.
#![cfg(feature = "opencv-detector")]

mod common;
use common::{geneva, stderr};
use std::path::Path;

/// A folder as geneva commits it: `files` (name, text) and the marker listing them.
fn committed(dir: &Path, files: &[(&str, &str)]) {
    std::fs::create_dir_all(dir).unwrap();
    let mut marker = String::from("# written by geneva\n");
    for (name, text) in files {
        let p = dir.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
        marker.push_str(name);
        marker.push('\n');
    }
    std::fs::write(dir.join(".geneva-output"), marker).unwrap();
}

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(snapshot(&p));
        } else {
            out.push((p.display().to_string(), std::fs::read(&p).unwrap()));
        }
    }
    out.sort();
    out
}

/// Runs `args` in `root`, expects a refusal naming `option` and `path`, and `dir` unchanged.
fn refused_keeping(root: &Path, dir: &str, args: &[&str], option: &str, path: &str) {
    let before = snapshot(&root.join(dir));
    let o = geneva(root, args);
    let e = stderr(&o);
    assert!(!o.status.success(), "{args:?} ran: {e}");
    assert!(
        e.contains(option) && e.contains(path) && e.contains("inside"),
        "{args:?}: {e}"
    );
    assert_eq!(snapshot(&root.join(dir)), before, "{args:?} changed {dir}");
}

#[test]
fn an_input_inside_the_output_folder_is_refused_by_name_and_kept() {
    // `analyze --tracks DIR/tracks.csv --out DIR` (and the same with diagnose, calibrate,
    // analyze --frames, run and diagnose on a calibrate folder's scenario) deleted the input
    // with the folder it replaced, exit 0.
    let root = tempfile::tempdir().unwrap();
    let r = root.path();
    let o = geneva(r, &["run", "fast", "--out", "run"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(r.join("run/tracks.csv").is_file());
    refused_keeping(
        r,
        "run",
        &["analyze", "--tracks", "run/tracks.csv", "--out", "run"],
        "--tracks",
        "run/tracks.csv",
    );
    refused_keeping(
        r,
        "run",
        &[
            "diagnose",
            "--scenario",
            "fast",
            "--tracks",
            "run/tracks.csv",
            "--out",
            "run",
        ],
        "--tracks",
        "run/tracks.csv",
    );
    committed(
        &r.join("render"),
        &[
            ("frame_000000.png", "png"),
            ("timestamps.csv", "frame,t_s\n0,0\n"),
        ],
    );
    for command in ["analyze", "calibrate"] {
        let mut args = vec![
            command,
            "--frames",
            "render",
            "--timestamps",
            "ts.csv",
            "--out",
            "render",
        ];
        if command == "calibrate" {
            args.extend(["--base", "fast"]);
        }
        std::fs::write(r.join("ts.csv"), "frame,t_s\n0,0\n").unwrap();
        refused_keeping(r, "render", &args, "--frames", "render");
    }
    refused_keeping(
        r,
        "render",
        &[
            "analyze",
            "--frames",
            "elsewhere",
            "--timestamps",
            "render/timestamps.csv",
            "--out",
            "render",
        ],
        "--timestamps",
        "render/timestamps.csv",
    );
    let scenario = "extend = \"fast\"\nname = \"calibrated\"\n";
    committed(
        &r.join("cal"),
        &[("scenario.toml", scenario), ("calibration.md", "# c\n")],
    );
    refused_keeping(
        r,
        "cal",
        &["run", "cal/scenario.toml", "--out", "cal"],
        "scenario",
        "cal/scenario.toml",
    );
    refused_keeping(
        r,
        "cal",
        &[
            "diagnose",
            "--scenario",
            "cal/scenario.toml",
            "--tracks",
            "run/tracks.csv",
            "--out",
            "cal",
        ],
        "--scenario",
        "cal/scenario.toml",
    );
    for args in [
        ["kinematics", "cal/scenario.toml", "--out", "cal"],
        ["render", "cal/scenario.toml", "--out", "cal"],
        ["montecarlo", "cal/scenario.toml", "--out", "cal"],
        ["decompose", "cal/scenario.toml", "--out", "cal"],
    ] {
        refused_keeping(r, "cal", &args, "scenario", "cal/scenario.toml");
    }
    // A scenario outside whose extend base or timing log lies inside.
    std::fs::write(r.join("outer.toml"), "extend = \"cal/scenario.toml\"\n").unwrap();
    refused_keeping(
        r,
        "cal",
        &["run", "outer.toml", "--out", "cal"],
        "extend base",
        "cal/scenario.toml",
    );
    // A sweep file inside the folder the sweep writes, and in its staging folder.
    let sweep = "base = \"fast\"\nseeds = 1\n[[axis]]\nname = \"fps\"\nfield = \"frame_timing.fps\"\nvalues = [30.0]\n";
    committed(&r.join("sw"), &[("sweep.toml", sweep)]);
    refused_keeping(
        r,
        "sw",
        &["sweep", "sw/sweep.toml", "--out", "sw"],
        "sweep file",
        "sw/sweep.toml",
    );
    std::fs::create_dir_all(r.join(".sw2.partial")).unwrap();
    std::fs::write(r.join(".sw2.partial/sweep.toml"), sweep).unwrap();
    let o = geneva(r, &["sweep", ".sw2.partial/sweep.toml", "--out", "sw2"]);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("staging folder"), "{e}");
    assert!(r.join(".sw2.partial/sweep.toml").is_file());
}

#[test]
fn slurm_values_that_would_inject_commands_or_directives_are_refused() {
    // A newline in --out, --partition or --time became a command the job script ran; a space
    // split an #SBATCH line; `--mem "8G --wrap=x"` passed another option to sbatch; a `#` in
    // --out cut the log path.
    let root = tempfile::tempdir().unwrap();
    let r = root.path();
    let sweep = "sweep.toml";
    std::fs::write(
        r.join(sweep),
        "base = \"fast\"\nseeds = 1\n[[axis]]\nname = \"fps\"\nfield = \"frame_timing.fps\"\nvalues = [30.0]\n",
    )
    .unwrap();
    let script = |extra: &[&str]| {
        let mut args = vec!["slurm", "script", sweep, "--shards", "2"];
        args.extend_from_slice(extra);
        geneva(r, &args)
    };
    for (extra, needle) in [
        (vec!["--out", "o\ntouch pwned"], "control character"),
        (
            vec!["--out", "o", "--partition", "gpu\ntouch pwned"],
            "--partition",
        ),
        (
            vec!["--out", "o", "--time", "01:00:00\ntouch pwned"],
            "--time",
        ),
        (vec!["--out", "o", "--partition", "gpu long"], "--partition"),
        (vec!["--out", "o", "--mem", "8G --wrap=x"], "--mem"),
        (vec!["--out", "o", "--time", "1:2:3:4"], "--time"),
        (vec!["--out", "a b"], "#SBATCH"),
        (vec!["--out", "o#x"], "#SBATCH"),
        (vec!["--out", "o%j"], "#SBATCH"),
    ] {
        let o = script(&extra);
        let e = stderr(&o);
        assert!(!o.status.success(), "{extra:?} accepted");
        assert!(e.contains(needle), "{extra:?}: {e}");
    }
    let written: Vec<_> = std::fs::read_dir(r)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(written.len(), 1, "nothing but the sweep file: {written:?}");
    assert!(!r.join("pwned").exists());
    // Jobs that would refuse to run get no script.
    let o = geneva(
        r,
        &[
            "slurm",
            "script",
            "--montecarlo",
            "fast",
            "--seeds",
            "0",
            "--out",
            "mc",
            "--shards",
            "2",
        ],
    );
    assert!(
        !o.status.success() && stderr(&o).contains("--seeds 0"),
        "{}",
        stderr(&o)
    );
    std::fs::write(r.join("bad.toml"), "extend = \"fast\"\nduration_s = -1.0\n").unwrap();
    std::fs::write(
        r.join("bad-sweep.toml"),
        std::fs::read_to_string(r.join(sweep))
            .unwrap()
            .replace("\"fast\"", "\"bad.toml\""),
    )
    .unwrap();
    let o = geneva(
        r,
        &[
            "slurm",
            "script",
            "bad-sweep.toml",
            "--out",
            "b",
            "--shards",
            "2",
        ],
    );
    assert!(
        !o.status.success() && stderr(&o).contains("duration_s"),
        "{}",
        stderr(&o)
    );
    let o = geneva(
        r,
        &[
            "slurm",
            "script",
            "--montecarlo",
            "bad.toml",
            "--seeds",
            "3",
            "--out",
            "b",
            "--shards",
            "2",
        ],
    );
    assert!(
        !o.status.success() && stderr(&o).contains("duration_s"),
        "{}",
        stderr(&o)
    );
    assert!(!r.join("mc-slurm").exists() && !r.join("b-slurm").exists());
    // A hostile but legal output folder, its scripts elsewhere: the task runs exactly the
    // intended words (a stand-in geneva prints them, one per line).
    let fake = r.join("fake-geneva");
    std::fs::write(&fake, "#!/bin/bash\nprintf '%s\\n' \"$@\"\n").unwrap();
    std::fs::set_permissions(&fake, std::os::unix::fs::PermissionsExt::from_mode(0o755)).unwrap();
    let out = "it's $(touch pwned) \"q\" `x` #h %j";
    let o = script(&[
        "--out",
        out,
        "--scripts",
        "scripts",
        "--geneva",
        "fake-geneva",
        "--mem",
        "8G",
        "--time",
        "2-12:30",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let task = std::process::Command::new("bash")
        .arg(r.join("scripts/shards.sbatch"))
        .env("SLURM_ARRAY_TASK_ID", "1")
        .current_dir(r)
        .output()
        .unwrap();
    let argv = String::from_utf8_lossy(&task.stdout).into_owned();
    let abs_out = r.join(out).display().to_string();
    let abs_sweep = r.join(sweep).display().to_string();
    assert_eq!(
        argv,
        format!("sweep\n{abs_sweep}\n--out\n{abs_out}\n--shard\n1/2\n"),
        "{}",
        String::from_utf8_lossy(&task.stderr)
    );
    assert!(!r.join("pwned").exists());
    let text = std::fs::read_to_string(r.join("scripts/shards.sbatch")).unwrap();
    for line in text.lines().filter(|l| l.starts_with("#SBATCH")) {
        assert_eq!(line.split_whitespace().count(), 2, "{line}");
    }
}

/// `diagnose --fit-seeds 1000000000` (also `--refits`, `--bootstrap`) aborted on an allocation
/// of 8 GB; the work estimate counted only the nominal's seeds. Now a count beyond any
/// diagnosis is refused naming its limit, and one within it that multiplies the work past the
/// limits is refused without `--yes`, before anything runs or is written.
#[test]
fn diagnosis_options_that_multiply_work_are_counted_and_refused_before_any_work() {
    let root = tempfile::tempdir().unwrap();
    let r = root.path();
    std::fs::write(r.join("tracks.csv"), "frame,t_s\n").unwrap();
    let base = [
        "diagnose",
        "--scenario",
        "fast",
        "--tracks",
        "tracks.csv",
        "--out",
        "d",
    ];
    for option in ["--fit-seeds", "--refits", "--bootstrap", "--seeds"] {
        let mut args = base.to_vec();
        args.extend([option, "1000000000"]);
        let o = geneva(r, &args);
        let e = stderr(&o);
        assert!(!o.status.success(), "{option}: {e}");
        assert!(
            e.contains(option) && e.contains("at most 100000"),
            "{option}: {e}"
        );
    }
    for option in ["--fit-seeds", "--refits", "--bootstrap"] {
        let mut args = base.to_vec();
        args.extend([option, "100000"]);
        let o = geneva(r, &args);
        let e = stderr(&o);
        assert!(!o.status.success(), "{option}: {e}");
        assert!(
            e.contains("--yes") && e.contains("at least") && e.contains("simulations"),
            "{option}: {e}"
        );
    }
    assert!(!r.join("d").exists(), "nothing written");
}

/// A diagnosis's errors name what is wrong in the footage: timestamps that start before 0 s
/// (were "the nominal scenario's mechanism: duration_s must be > 0, got −2.73"), and a marker
/// that is found in every frame but hardly moves (was "found in only 60 of 60 frames; a
/// diagnosis needs at least 30").
#[test]
fn a_diagnosis_names_negative_frame_times_and_a_marker_that_does_not_move() {
    let root = tempfile::tempdir().unwrap();
    let r = root.path();
    let o = geneva(r, &["run", "fast", "--out", "run"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(r.join("run/tracks.csv")).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    let write = |name: &str, edit: &dyn Fn(usize, &mut Vec<String>)| {
        let mut out = format!("{header}\n");
        for (k, row) in rows.iter().enumerate() {
            let mut row = row.clone();
            edit(k, &mut row);
            out.push_str(&row.join(","));
            out.push('\n');
        }
        std::fs::write(r.join(name), out).unwrap();
    };
    write("early.csv", &|_, row| {
        let t: f64 = row[1].parse().unwrap();
        row[1] = format!("{}", t - 5.0);
    });
    let still = rows[0].clone();
    write("still.csv", &|_, row| {
        row[3..].clone_from_slice(&still[3..])
    });
    let diagnose = |tracks: &str| {
        let o = geneva(
            r,
            &[
                "diagnose",
                "--scenario",
                "fast",
                "--tracks",
                tracks,
                "--out",
                "d",
            ],
        );
        assert!(!o.status.success(), "{tracks}: ran");
        stderr(&o)
    };
    let e = diagnose("early.csv");
    assert!(
        e.contains("frame 0") && e.contains("-5 s") && e.contains("must not be negative"),
        "{e}"
    );
    let e = diagnose("still.csv");
    assert!(
        e.contains("found in 60 of 60 frames") && e.contains("cannot be estimated"),
        "{e}"
    );
    assert!(!e.contains("needs at least"), "{e}");
}

/// `analyze` on footage whose marker is never found talked of estimators and "0 detected
/// frames"; it names the id and dictionary it looked for, as `calibrate` and `diagnose` do.
#[test]
fn analyze_names_the_marker_it_never_found() {
    let root = tempfile::tempdir().unwrap();
    let r = root.path();
    let o = geneva(
        r,
        &["render", "fast", "--frames", "0..12", "--out", "frames"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::write(
        r.join("id7.toml"),
        "extend = \"fast\"\n[scene.marker]\nid = 7\n[detector]\nmarker_id = 7\n",
    )
    .unwrap();
    let o = geneva(
        r,
        &[
            "analyze",
            "--frames",
            "frames",
            "--timestamps",
            "frames/timestamps.csv",
            "--scenario",
            "id7.toml",
            "--out",
            "a",
        ],
    );
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(
        e.contains("marker id 7") && e.contains("4x4_50") && e.contains("never found"),
        "{e}"
    );
    assert!(!e.contains("estimator"), "{e}");
    assert!(!r.join("a").exists(), "nothing written");
}

/// `scenario check` passed rigs whose runs then failed with "0 detected frames": paper as dark
/// as the ink, a marker tilted 80°/80° (under a pixel per cell), a camera shake of 10,000 px.
/// It warns of each, naming the fields, and of none on the built-in rigs.
#[test]
fn scenario_check_warns_of_a_marker_no_detector_can_find() {
    let root = tempfile::tempdir().unwrap();
    let r = root.path();
    let cases = [
        ("[scene]\npaper_radiance = 0.0\n", "scene.paper_radiance, scene.ink_radiance"),
        (
            "[camera.perspective_tilt]\nenabled = true\ntilt_x_deg = 80.0\ntilt_y_deg = 80.0\n",
            "camera.perspective_tilt",
        ),
        (
            "[effects.camera_vibration]\nenabled = true\n[effects.camera_vibration.random]\nx_rms_px = 10000.0\n",
            "effects.camera_vibration",
        ),
    ];
    for (section, field) in cases {
        std::fs::write(r.join("s.toml"), format!("extend = \"fast\"\n{section}")).unwrap();
        let o = geneva(r, &["scenario", "check", "s.toml"]);
        let out = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(
            out.contains(&format!("warning: {field}")),
            "{section}: {out}"
        );
    }
    for builtin in ["fast", "seed-internal-4k", "seed-external-4k"] {
        let o = geneva(r, &["scenario", "check", builtin]);
        let out = String::from_utf8_lossy(&o.stdout).to_string();
        for field in [
            "scene.paper_radiance, scene.ink_radiance",
            "camera.perspective_tilt",
            "effects.camera_vibration",
        ] {
            assert!(
                !out.contains(&format!("warning: {field}")),
                "{builtin}: {out}"
            );
        }
    }
}
