//! `geneva analyze --scenario` gives every measured sample an error bar from simulations of the
//! rig at the footage's frame times, and flags what stands beyond it: checked where the truth is
//! known (footage this project renders, with and without an effect the scenario lacks).
#![cfg(feature = "opencv-detector")]

mod common;

use common::{geneva, geneva_ok, stderr};
use geneva_vision::pipeline::error_bars_check::coverage_check;
use geneva_vision::pipeline::render_job::Renderer;
use std::path::Path;

/// The `fast` rig placed off the pixel grid's centre, with extra TOML appended.
fn footage(dir: &Path, name: &str, extra: &str) {
    let toml = format!(
        "extend = \"fast\"\nseed = 301\n[camera]\nrotation_centre_px = [639.23, 359.71]\n{extra}"
    );
    std::fs::write(dir.join(format!("{name}.toml")), toml).unwrap();
    geneva_ok(dir, &["render", &format!("{name}.toml"), "--out", name]);
}

fn analyze(dir: &Path, frames: &str, out: &str, scenario: &str) -> std::process::Output {
    geneva(
        dir,
        &[
            "analyze",
            "--frames",
            frames,
            "--timestamps",
            &format!("{frames}/timestamps.csv"),
            "--scenario",
            scenario,
            "--error-bar-seeds",
            "6",
            "--out",
            out,
        ],
    )
}

/// The fused rows of `kinematics.csv` as maps of column to cell.
fn fused_rows(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let header = r.headers().unwrap().clone();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            header
                .iter()
                .zip(rec.iter())
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect::<std::collections::HashMap<_, _>>()
        })
        .filter(|m| m["signal"] == "fused")
        .collect()
}

fn flagged(rows: &[std::collections::HashMap<String, String>]) -> usize {
    rows.iter()
        .filter(|m| m["alpha2_beyond_noise"] == "1")
        .count()
}

#[test]
fn every_sample_gets_an_error_bar_and_a_vibration_the_scenario_lacks_is_flagged() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    footage(d, "plain", "");
    // 3 mrad at 4 Hz: an α2 of up to 1.9 rad/s², some 20 times the α2 bar of this rig.
    footage(
        d,
        "shaken",
        "[dynamics.disc_vibration]\nenabled = true\n[[dynamics.disc_vibration.components]]\n\
         amplitude_rad = 0.003\nfrequency_hz = 4.0\nphase_rad = 0.0\n",
    );
    let o = analyze(d, "plain", "a_plain", "fast");
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("error bars: 6 simulated seeds"), "{stdout}");
    let md = std::fs::read_to_string(d.join("a_plain/error_bars.md")).unwrap();
    assert!(md.contains("not an effect the scenario lacks"), "{md}");
    let plain = fused_rows(&d.join("a_plain/kinematics.csv"));
    assert_eq!(plain.len(), 60);
    for m in &plain {
        for column in [
            "theta2_sigma_rad",
            "omega2_sigma_rad_s",
            "alpha2_sigma_rad_s2",
        ] {
            let v: f64 = m[column].parse().unwrap();
            assert!(
                v.is_finite() && v >= 0.0,
                "frame {}: {column} {v}",
                m["frame"]
            );
        }
        let w: f64 = m["omega2_sigma_rad_s"].parse().unwrap();
        assert!(w > 0.0, "frame {}: a zero ω2 bar", m["frame"]);
    }
    // Nothing in this footage is beyond the model: with Gaussian errors 3 σ is passed by 0.27 %
    // of frames (0.16 of 60); 3 allows for heavier tails without passing a broken bar.
    let null = flagged(&plain);
    assert!(
        null <= 3,
        "{null} of 60 frames flagged on footage of the stated rig"
    );

    let o = analyze(d, "shaken", "a_shaken", "fast");
    assert!(o.status.success(), "{}", stderr(&o));
    let shaken = flagged(&fused_rows(&d.join("a_shaken/kinematics.csv")));
    // |α2| of the vibration passes 3 bars wherever |sin| > 0.15; the smoother takes part of a
    // 4 Hz swing at 30 fps, so a third of the frames is the floor asked for.
    assert!(
        shaken >= 20,
        "only {shaken} of 60 frames flagged with a vibration the scenario lacks"
    );
}

#[test]
fn a_scenario_of_another_camera_gives_no_error_bars_and_keeps_the_analysis() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    footage(d, "plain", "");
    std::fs::write(
        d.join("small.toml"),
        "extend = \"fast\"\n[camera]\nwidth_px = 640\nheight_px = 480\n",
    )
    .unwrap();
    let o = analyze(d, "plain", "a", "small.toml");
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("warning: no error bars")
            && err.contains("640x480")
            && err.contains("1280x720"),
        "{err}"
    );
    let text = std::fs::read_to_string(d.join("a/kinematics.csv")).unwrap();
    assert!(text.starts_with("frame,t_s,signal,theta2_rad"), "{text}");
    assert!(!text.contains("sigma"), "{}", text.lines().next().unwrap());
    assert!(!d.join("a/error_bars.md").exists());
}

#[test]
fn a_track_of_another_image_scale_gives_no_error_bars() {
    // A track carries no frame size: a scenario whose marker shows at another size in the image
    // (here an image scale of 0.65 mm/px instead of 0.5: 23 % smaller) is refused by the
    // marker's size.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    footage(d, "plain", "");
    let o = analyze(d, "plain", "a", "fast");
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::write(
        d.join("far.toml"),
        "extend = \"fast\"\n[camera.focal]\nkind = \"image_scale\"\nmm_per_px = 0.65\n",
    )
    .unwrap();
    let o = geneva(
        d,
        &[
            "analyze",
            "--tracks",
            "a/tracks.csv",
            "--scenario",
            "far.toml",
            "--error-bar-seeds",
            "4",
            "--out",
            "b",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("warning: no error bars") && err.contains("px a side"),
        "{err}"
    );
    assert!(!d.join("b/error_bars.md").exists());
}

#[test]
fn the_error_bars_cover_footage_of_the_simulating_renderer() {
    // Where the bars' model is exact, z = (measured − truth)/σ̂ has an RMS of √(N/(N−2)) for σ̂
    // an RMS over N seeds (E[N/χ²_N] = N/(N−2)): 1.155 for N = 8. Its sampling error: 3
    // footages of 60 frames hold some 20 independent errors per quantity (one per Kalman
    // smoothing span of ~9 frames), so their RMS is known to ±16 % (1/√40); the σ̂ of those
    // spans scatter by 1/√16 each, ±6 % over 20. Together ±17 %; the band is 2 of those.
    let dir = tempfile::tempdir().unwrap();
    let base = geneva_vision::scenario::load_any("fast").unwrap();
    let seeds = 8;
    let c = coverage_check(&base, 3, seeds, Renderer::Own, dir.path()).unwrap();
    let expected = geneva_vision::pipeline::error_bars_check::exact_z_rms(seeds);
    let (lo, hi) = (expected * (1.0 - 0.34), expected * (1.0 + 0.34));
    for r in c.rows.iter().filter(|r| r.phase == "all") {
        eprintln!(
            "{}: z RMS {:.3} over {} frames",
            r.quantity, r.z_rms, r.frames
        );
        assert!(
            (lo..=hi).contains(&r.z_rms),
            "{}: z RMS {:.2} over {} frames, not within {lo:.2}..{hi:.2}",
            r.quantity,
            r.z_rms,
            r.frames
        );
    }
    assert_eq!(c.rows.iter().filter(|r| r.phase == "all").count(), 3);
}
