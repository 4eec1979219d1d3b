//! Rendered output checked with outside tools: OpenCV finds the projected corners where the
//! geometry says, and the MP4 keeps the variable frame timestamps (read back with ffprobe).
#![cfg(feature = "opencv-detector")]

use geneva_vision::detect::{ArucoDetector, CornerRefinement, GrayView};
use geneva_vision::pipeline::render_job::{render_job, RenderJob};
use geneva_vision::pipeline::rig::Rig;
use geneva_vision::render::{render_frame, FrameRequest};
use geneva_vision::scenario;
use std::path::Path;

/// A noiseless render (optical blur σ = 0.5 px as measured on the real frame, no noise, no motion
/// blur) detected with SUBPIX at poses along a run, for markers of 64, 80 and 128 px, against the
/// projected ground truth in OpenCV's convention.
///
/// Measured here (OpenCV 4.6): cornerSubPix (win 5) pulls corners *inward* by ~0.12 px per axis
/// on an axis-aligned marker and leaves 0.1–0.25 px corner errors at rotated poses (0.41 px on
/// perfectly sharp, blur-free edges), so the 0.1 px per-corner target is NOT met by
/// OpenCV's refinement; the errors are nearly symmetric, so the marker centre — what the angle
/// uses — stays within 0.08 px. The test pins these measured limits (centre < 0.08 px, corners
/// < 0.3 px) so a regression in the renderer's geometry (which is exact to 1e-4 px) or a
/// convention slip (0.5 px) fails it.
#[test]
fn subpix_corners_match_the_projected_marker() {
    for (scale, seed) in [(0.5, 1u64), (0.25, 2), (0.4, 3)] {
        let text = format!(
            "extend = \"fast\"\nseed = {seed}\n[camera.focal]\nkind = \"image_scale\"\nmm_per_px = {scale}\n\
             [effects.pixel_noise]\nenabled = false\n[effects.optical_blur]\nenabled = true\nsigma_px = 0.5\n[effects.motion_blur]\nenabled = false\n\
             [scene.marker]\nradius_mm = 60.0\n"
        );
        let s = scenario::from_str(&text, Path::new("t.toml")).unwrap();
        let rig = Rig::new(&s).unwrap();
        let scene = rig.animated();
        let mut cfg = s.detector.clone();
        cfg.corner_refinement_method = CornerRefinement::Subpix;
        let detector = ArucoDetector::new(&cfg).unwrap();
        let side_px = 32.0 / scale;
        assert!(side_px >= 50.0);
        for (frame, &t_s) in rig.frame_times.as_slice().iter().enumerate().step_by(7) {
            let img = render_frame(
                &scene,
                &rig.settings,
                &FrameRequest {
                    index: frame as u64,
                    t_s,
                    window: rig.frame_rect(),
                },
            );
            let found = detector
                .detect(GrayView::full(
                    &img.data,
                    rig.settings.width_px,
                    rig.settings.height_px,
                ))
                .unwrap();
            let d = found
                .iter()
                .find(|d| d.id == 0)
                .unwrap_or_else(|| panic!("marker not found, frame {frame}, scale {scale}"));
            let truth = scene.marker_corners_px(t_s);
            let mean = |c: &[[f64; 2]; 4]| {
                [
                    c.iter().map(|p| p[0]).sum::<f64>() / 4.0,
                    c.iter().map(|p| p[1]).sum::<f64>() / 4.0,
                ]
            };
            let (cd, ct) = (mean(&d.corners_px), mean(&truth));
            let dist =
                |a: [f64; 2], b: [f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
            assert!(
                dist(cd, ct) < 0.08,
                "centre off by {:.3} px (frame {frame}, {side_px:.0} px)",
                dist(cd, ct)
            );
            for (i, (got, want)) in d.corners_px.iter().zip(&truth).enumerate() {
                let raw = dist(*got, *want);
                assert!(
                    raw < 0.3,
                    "corner {i} off by {raw:.3} px (frame {frame}, {side_px:.0} px)"
                );
            }
        }
    }
}

/// `render --video` writes an MP4 whose frame times (ffprobe) are the scenario's variable
/// timestamps, to the 90 kHz timescale.
#[test]
fn video_keeps_variable_timestamps() {
    let s = scenario::from_str(
        "extend = \"fast\"\nduration_s = 0.5\n[frame_timing.model]\nkind = \"vfr\"\njitter_s = 0.0003\nfirst_interval_s = 0.06\n",
        Path::new("t.toml"),
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let video = dir.path().join("v.mp4");
    let job = RenderJob {
        video: Some(video.clone()),
        ..RenderJob::default()
    };
    render_job(&s, dir.path(), &job, &|_, _| {}).unwrap();
    let info = geneva_vision::io::video::probe(&video).unwrap();
    let expected = s.frame_times().unwrap().into_vec();
    assert_eq!(info.timestamps_s.len(), expected.len());
    for (got, want) in info.timestamps_s.iter().zip(&expected) {
        assert!(
            (got - want).abs() <= 1.0 / 90000.0 + 1e-9,
            "{got} vs {want}"
        );
    }
    // Not resampled to a constant rate: the long first interval survives.
    let iv: Vec<f64> = info.timestamps_s.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(iv[0] > 1.5 * iv[1], "first interval {} vs {}", iv[0], iv[1]);
}
