//! Smoke test of the OpenCV set-up: a marker drawn by OpenCV's own `drawMarker` is detected with
//! the right id and the corner convention pinned down (centre of pixel (i, j) is at (i, j)).
#![cfg(feature = "opencv-detector")]

use geneva_vision::detect::{ArucoDetector, CornerRefinement, DetectorConfig, GrayView};
use opencv::prelude::*;

/// A white `size × size` image with DICT_4X4_50 marker `id` covering pixels `at..at+side`.
fn white_with_marker(size: usize, at: usize, side: usize, id: i32) -> Vec<u8> {
    let dict = opencv::aruco::get_predefined_dictionary_i32(0).unwrap();
    let mut marker = opencv::core::Mat::default();
    opencv::aruco::draw_marker(&dict, id, side as i32, &mut marker, 1).unwrap();
    assert_eq!(
        (marker.cols() as usize, marker.rows() as usize),
        (side, side)
    );
    let bytes = marker.data_bytes().unwrap();
    let mut img = vec![255u8; size * size];
    for r in 0..side {
        img[(at + r) * size + at..(at + r) * size + at + side]
            .copy_from_slice(&bytes[r * side..(r + 1) * side]);
    }
    img
}

fn detect(
    method: CornerRefinement,
    img: &[u8],
    size: usize,
) -> Vec<geneva_vision::detect::Detection> {
    let cfg = DetectorConfig {
        corner_refinement_method: method,
        ..DetectorConfig::default()
    };
    ArucoDetector::new(&cfg)
        .unwrap()
        .detect(GrayView::full(img, size, size))
        .unwrap()
}

#[test]
fn drawn_marker_is_found_with_exact_unrefined_corners() {
    let img = white_with_marker(400, 100, 200, 0);
    let dets = detect(CornerRefinement::None, &img, 400);
    assert_eq!(dets.len(), 1);
    assert_eq!(dets[0].id, 0);
    // Pixels 100..=299 are black: OpenCV reports the centres of the outermost black pixels,
    // half a pixel inside the true edges at 99.5 and 299.5, clockwise from top-left.
    assert_eq!(
        dets[0].corners_px,
        [
            [100.0, 100.0],
            [299.0, 100.0],
            [299.0, 299.0],
            [100.0, 299.0]
        ]
    );
}

#[test]
fn origin_is_added_to_corners() {
    let img = white_with_marker(400, 100, 200, 3);
    let view = GrayView {
        data: &img,
        width: 400,
        height: 400,
        origin_px: (1000, 20),
    };
    let cfg = DetectorConfig::default();
    let dets = ArucoDetector::new(&cfg).unwrap().detect(view).unwrap();
    assert_eq!(dets[0].id, 3);
    assert_eq!(dets[0].corners_px[0], [1100.0, 120.0]);
}

#[test]
fn refinement_methods_land_where_measured() {
    let img = white_with_marker(400, 100, 200, 0);
    let true_edges = [[99.5, 99.5], [299.5, 99.5], [299.5, 299.5], [99.5, 299.5]];
    for (method, offset, tol) in [
        // SUBPIX lands within ~0.1 px of the true edge (measured 99.56 for the top-left).
        (CornerRefinement::Subpix, 0.0, 0.1),
        // CONTOUR fits lines through the contour pixel centres: the unrefined convention.
        (CornerRefinement::Contour, 0.5, 0.05),
        // APRILTAG is shifted +0.5 px from the true edge.
        (CornerRefinement::Apriltag, 0.5, 0.1),
    ] {
        let dets = detect(method, &img, 400);
        assert_eq!(dets.len(), 1, "{method:?}");
        eprintln!("{method:?}: corners {:?}", dets[0].corners_px);
        assert_eq!(dets[0].id, 0);
        for (c, t) in dets[0].corners_px.iter().zip(true_edges) {
            // Offsets point inwards for the unrefined convention, along +x/+y for APRILTAG.
            let inward = [
                if t[0] < 200.0 { 1.0 } else { -1.0 },
                if t[1] < 200.0 { 1.0 } else { -1.0 },
            ];
            let expect = if method == CornerRefinement::Apriltag {
                [t[0] + offset, t[1] + offset]
            } else {
                [t[0] + offset * inward[0], t[1] + offset * inward[1]]
            };
            assert!(
                (c[0] - expect[0]).abs() <= tol && (c[1] - expect[1]).abs() <= tol,
                "{method:?}: corner {c:?}, expected {expect:?} ± {tol}"
            );
        }
    }
}

#[test]
fn blank_image_has_no_markers_and_bad_sizes_are_errors() {
    let img = vec![255u8; 100 * 80];
    let det = ArucoDetector::new(&DetectorConfig::default()).unwrap();
    assert!(det
        .detect(GrayView::full(&img, 100, 80))
        .unwrap()
        .is_empty());
    assert!(det.detect(GrayView::full(&img, 100, 81)).is_err());
    let bad = DetectorConfig {
        dictionary: "9x9_50".into(),
        ..DetectorConfig::default()
    };
    assert!(ArucoDetector::new(&bad)
        .unwrap_err()
        .to_string()
        .contains("detector.dictionary"));
}
