//! The video codec effect through the pipeline: a clip encoded as a phone records it and decoded
//! back renders the same frames whole or in parts and at any thread count, changes the pixels as
//! a codec does, and the marker is detected in its decoded frames, in the window as in the whole
//! frame.
#![cfg(feature = "opencv-detector")]

mod common;

use geneva_vision::pipeline::frames::FrameDetection;
use geneva_vision::pipeline::render_job::{render_each, render_job, RenderJob, RenderJobError};
use geneva_vision::pipeline::rig::Rig;
use geneva_vision::scenario::{self, Scenario};
use std::path::Path;

/// The `fast` rig, 1 s (30 frames) at 640×480, noisy, through H.264 at `codec` (a TOML table
/// body, empty for no codec).
fn rig_with(codec: &str) -> Scenario {
    let text = format!(
        "extend = \"fast\"\nduration_s = 1.0\n[camera]\nwidth_px = 640\nheight_px = 480\n\
         [effects.pixel_noise]\nenabled = true\n{codec}"
    );
    scenario::from_str(&text, Path::new("codec.toml")).unwrap()
}

const H264: &str = "[effects.video_codec]\nenabled = true\nbitrate_bps = 2e6\ngop_frames = 12\n";

fn frames(s: &Scenario, range: std::ops::Range<usize>, threads: usize) -> Vec<Vec<u8>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut out = Vec::new();
    pool.install(|| {
        render_each(s, range, Default::default(), &|_, _| {}, &mut |img| {
            out.push(img.data)
        })
        .unwrap()
    });
    out
}

fn mean_abs_dn(a: &[u8], b: &[u8]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| (x as f64 - y as f64).abs())
        .sum::<f64>()
        / a.len() as f64
}

#[test]
fn a_coded_clip_renders_alike_whole_in_parts_and_at_any_thread_count() {
    let coded = rig_with(H264);
    let whole = frames(&coded, 0..30, 2);
    assert_eq!(whole.len(), 30);
    assert_eq!(whole, frames(&coded, 0..30, 1), "one thread against two");
    assert_eq!(
        frames(&coded, 10..20, 2),
        whole[10..20].to_vec(),
        "a part decodes as in the whole clip"
    );
    // The codec changes every frame, by about what a 2 Mbit/s H.264 of a noisy 640×480 clip
    // loses: more than the requantisation alone (under 0.5 DN), far less than the image's range.
    let plain = frames(&rig_with(""), 0..30, 2);
    for (k, (c, p)) in whole.iter().zip(&plain).enumerate() {
        let d = mean_abs_dn(c, p);
        assert!(
            (0.5..8.0).contains(&d),
            "frame {k}: {d} DN from the uncoded frame"
        );
    }
}

fn detections(s: &Scenario, roi: bool, threads: usize) -> Vec<FrameDetection> {
    let rig = Rig::new(s).unwrap();
    common::detections(&rig, 0..rig.frame_times.len(), roi, threads)
}

#[test]
fn the_marker_is_detected_in_the_decoded_frames_alike_in_the_window() {
    let coded = rig_with(H264);
    let roi = detections(&coded, true, 2);
    assert_eq!(roi.len(), 30);
    assert_eq!(roi, detections(&coded, true, 1), "one thread against two");
    let whole: Vec<_> = detections(&coded, false, 2)
        .into_iter()
        .map(|d| d.corners_px)
        .collect();
    let in_window: Vec<_> = roi.iter().map(|d| d.corners_px).collect();
    assert_eq!(
        in_window, whole,
        "window and whole frame find the same corners"
    );
    // Against the uncoded clip: found in every frame; the rig's corners are whole pixels (no
    // sub-pixel refinement), so a corner moves by at most one pixel per axis, and rarely.
    let plain = detections(&rig_with(""), true, 2);
    let mut moved = Vec::new();
    for (c, p) in roi.iter().zip(&plain) {
        let (c, p) = (c.corners_px.unwrap(), p.corners_px.unwrap());
        for (a, b) in c.iter().zip(&p) {
            moved.push(((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt());
        }
    }
    let max = moved.iter().cloned().fold(0.0, f64::max);
    let mean = moved.iter().sum::<f64>() / moved.len() as f64;
    assert!(
        max <= 1.5 && mean < 0.5,
        "corners moved by the codec: max {max} px, mean {mean} px"
    );
}

#[test]
fn a_window_of_a_coded_clip_and_an_odd_frame_are_refused_naming_why() {
    let dir = tempfile::tempdir().unwrap();
    let job = RenderJob {
        roi_margin_px: Some(10),
        png: true,
        ..Default::default()
    };
    let e = render_job(&rig_with(H264), dir.path(), &job, &|_, _| {}).unwrap_err();
    assert!(matches!(e, RenderJobError::CodecRoi), "{e}");
    assert!(e.to_string().contains("effects.video_codec"), "{e}");

    let text = format!("extend = \"fast\"\n[camera]\nwidth_px = 641\nheight_px = 480\n{H264}");
    let e = scenario::from_str(&text, Path::new("odd.toml")).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("effects.video_codec.enabled") && msg.contains("641×480"),
        "{msg}"
    );
}
