//! `geneva diagnose` end to end through the binary on the two sources the other diagnosis tests
//! do not reach: a video (`--video`: ffprobe timestamps, ffmpeg decode, image channels) and a
//! corner track (`--tracks`: no image, so the image-formation candidates are not judged). Both
//! run every candidate, as a user would, on 4 s of the `fast` rig; the footage is drawn on
//! another seed than the nominal's simulations. The evaluation and fit seeds are cut (4 and 2,
//! no refits) to keep CI short; with the defaults the track case gave the same verdict and
//! leader (drive speed −0.146 against −0.15, 334 simulations), and the intervals' widths are
//! what `tests/diagnose_coverage.rs` checks at the defaults.

#![cfg(feature = "opencv-detector")]

use common::geneva_ok as geneva;
use std::path::Path;

mod common;

/// The nominal: `fast` on 4 s (a diagnosis needs at least 30 frames with the marker).
const NOMINAL: &str = "extend = \"fast\"\nduration_s = 4.0\n";

/// Writes the nominal and the footage's scenario (the nominal resolved, with `with` switched on
/// and another seed) into `dir`.
fn scenarios(dir: &Path, with: &[&str]) {
    std::fs::write(dir.join("nominal.toml"), NOMINAL).unwrap();
    let mut args = vec!["scenario", "show", "nominal.toml"];
    for w in with {
        args.extend(["--with", w]);
    }
    let resolved = geneva(dir, &args);
    assert!(resolved.contains("\nseed = 7\n"), "{resolved}");
    let footage = resolved.replace("\nseed = 7\n", "\nseed = 101\n");
    std::fs::write(dir.join("footage.toml"), footage).unwrap();
}

/// `geneva diagnose` of `source` (its arguments) against the nominal, every candidate; the JSON.
fn diagnose(dir: &Path, source: &[&str]) -> serde_json::Value {
    let mut args = vec!["diagnose", "--scenario", "nominal.toml"];
    args.extend(source);
    args.extend([
        "--out",
        "diagnosis",
        "--seeds",
        "4",
        "--fit-seeds",
        "2",
        "--no-refit",
    ]);
    geneva(dir, &args);
    let text = std::fs::read_to_string(dir.join("diagnosis/diagnosis.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn a_video_of_the_nominal_itself_has_no_gap() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    scenarios(d, &[]);
    geneva(
        d,
        &["render", "footage.toml", "--video", "f.mp4", "--out", "r"],
    );
    let json = diagnose(d, &["--video", "f.mp4"]);
    assert_eq!(json["verdict"], "no_gap", "{json:#}");
    assert_eq!(json["remainder"]["reason"], "no_significant_cell");
    // The image channels were compared: a video is more than its corner track.
    let md = std::fs::read_to_string(d.join("diagnosis/diagnosis.md")).unwrap();
    assert!(md.contains("120 real frames (120 with the marker)"), "{md}");
    assert!(!md.contains("corner track only"), "{md}");
}

#[test]
fn a_drive_speed_variation_in_a_corner_track_is_explained_and_fitted() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let truth = -0.15;
    scenarios(d, &[&format!("drive_speed={truth}")]);
    geneva(d, &["run", "footage.toml", "--out", "run"]);
    let json = diagnose(d, &["--tracks", "run/tracks.csv"]);
    assert_eq!(json["verdict"], "explained", "{json:#}");
    let best = &json["ranking"][0];
    assert_eq!(
        best["effects"],
        serde_json::json!(["drive_speed"]),
        "{best:#}"
    );
    let fitted = best["params"]["variation_frac"].as_f64().unwrap();
    let sd = best["params_std"]["variation_frac"].as_f64().unwrap();
    let ci = &best["params_ci95"]["variation_frac"];
    let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
    assert!(sd > 0.0 && lo < fitted && fitted < hi, "{best:#}");
    assert!(
        lo <= truth && truth <= hi,
        "truth {truth} outside {ci}: {best:#}"
    );
    // A track has no pixels: no image-formation candidate is judged on it.
    let md = std::fs::read_to_string(d.join("diagnosis/diagnosis.md")).unwrap();
    assert!(md.contains("corner track only, no image channels"), "{md}");
    let ranked: Vec<&str> = json["ranking"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|r| r["effects"].as_array().unwrap())
        .filter_map(|e| e.as_str())
        .collect();
    for image_effect in [
        "pixel_noise",
        "optical_blur",
        "motion_blur",
        "compression",
        "lighting",
    ] {
        assert!(!ranked.contains(&image_effect), "{ranked:?}");
    }
}
