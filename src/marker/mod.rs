//! ArUco markers: OpenCV's predefined dictionaries and the black/white cell grid of a marker.
//!
//! The tables in [`dictionaries`] are generated from OpenCV itself
//! (`tools/gen_aruco_dictionaries.cpp`); `tests/marker_parity.rs` checks every id against
//! OpenCV's `drawMarker`.

pub mod cells;
pub mod dictionaries;
pub mod dictionary;

pub use cells::{cells, marker_bits, MarkerError};
pub use dictionary::Dictionary;
