//! Parity of the generated marker tables with OpenCV: every id of every supported dictionary,
//! drawn by OpenCV's `drawMarker`, equals the image built from `marker::cells`, pixel for pixel.
#![cfg(feature = "opencv-detector")]

use geneva_vision::marker::{cells, Dictionary};
use opencv::aruco;
use opencv::core::Mat;
use opencv::prelude::*;

/// OpenCV's drawMarker image of `id` at `k` pixels per cell.
fn opencv_marker(dict: Dictionary, id: usize, border_bits: usize, k: usize) -> Vec<u8> {
    let d = aruco::get_predefined_dictionary_i32(dict.opencv_id()).expect("dictionary");
    let side = (dict.marker_size_bits() + 2 * border_bits) * k;
    let mut img = Mat::default();
    aruco::draw_marker(&d, id as i32, side as i32, &mut img, border_bits as i32)
        .expect("drawMarker");
    assert_eq!((img.rows() as usize, img.cols() as usize), (side, side));
    img.data_bytes().expect("continuous u8 image").to_vec()
}

/// The same image from our cell grid (white = 255, black = 0), row-major.
fn our_marker(dict: Dictionary, id: usize, border_bits: usize, k: usize) -> Vec<u8> {
    let grid = cells(dict, id, border_bits).expect("cells");
    let side = grid.len() * k;
    let mut out = Vec::with_capacity(side * side);
    for y in 0..side {
        for x in 0..side {
            out.push(if grid[y / k][x / k] { 255 } else { 0 });
        }
    }
    out
}

fn check(dict: Dictionary, border_bits: usize, k: usize, ids: impl Iterator<Item = usize>) {
    for id in ids {
        let a = opencv_marker(dict, id, border_bits, k);
        let b = our_marker(dict, id, border_bits, k);
        assert!(
            a == b,
            "{} id {id} border {border_bits}: differs from drawMarker",
            dict.opencv_name()
        );
    }
}

#[test]
fn dict_4x4_1000_matches_opencv_for_every_id() {
    check(Dictionary::Dict4x4_1000, 1, 4, 0..1000);
}

#[test]
fn dict_6x6_1000_matches_opencv_for_every_id() {
    check(Dictionary::Dict6x6_1000, 1, 4, 0..1000);
}

#[test]
fn every_dictionary_matches_opencv_for_every_id() {
    for dict in Dictionary::ALL {
        check(dict, 1, 2, 0..dict.marker_count());
    }
}

#[test]
fn wider_borders_match_opencv() {
    for dict in [
        Dictionary::Dict4x4_50,
        Dictionary::Dict5x5_100,
        Dictionary::Dict7x7_250,
    ] {
        check(dict, 2, 3, (0..dict.marker_count()).step_by(7));
        check(dict, 3, 1, (0..dict.marker_count()).step_by(11));
    }
}
