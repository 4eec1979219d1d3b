//! The `Dictionary` enum: which predefined OpenCV dictionary a marker comes from, its size and
//! where its codes live in the generated tables.

use serde::{Deserialize, Serialize};

use super::dictionaries as tables;

/// An OpenCV predefined ArUco dictionary.
///
/// Scenario names are lower case without the `DICT_` prefix (`"4x4_50"`, `"6x6_1000"`,
/// `"aruco_original"`); OpenCV's spelling (`"DICT_4X4_50"`) is accepted as an alias.
///
/// The variants are declared in OpenCV's order, so the discriminant is OpenCV's id.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[repr(i32)]
pub enum Dictionary {
    #[serde(rename = "4x4_50", alias = "DICT_4X4_50")]
    Dict4x4_50 = 0,
    #[serde(rename = "4x4_100", alias = "DICT_4X4_100")]
    Dict4x4_100,
    #[serde(rename = "4x4_250", alias = "DICT_4X4_250")]
    Dict4x4_250,
    #[serde(rename = "4x4_1000", alias = "DICT_4X4_1000")]
    Dict4x4_1000,
    #[serde(rename = "5x5_50", alias = "DICT_5X5_50")]
    Dict5x5_50,
    #[serde(rename = "5x5_100", alias = "DICT_5X5_100")]
    Dict5x5_100,
    #[serde(rename = "5x5_250", alias = "DICT_5X5_250")]
    Dict5x5_250,
    #[serde(rename = "5x5_1000", alias = "DICT_5X5_1000")]
    Dict5x5_1000,
    #[serde(rename = "6x6_50", alias = "DICT_6X6_50")]
    Dict6x6_50,
    #[serde(rename = "6x6_100", alias = "DICT_6X6_100")]
    Dict6x6_100,
    #[serde(rename = "6x6_250", alias = "DICT_6X6_250")]
    Dict6x6_250,
    #[serde(rename = "6x6_1000", alias = "DICT_6X6_1000")]
    Dict6x6_1000,
    #[serde(rename = "7x7_50", alias = "DICT_7X7_50")]
    Dict7x7_50,
    #[serde(rename = "7x7_100", alias = "DICT_7X7_100")]
    Dict7x7_100,
    #[serde(rename = "7x7_250", alias = "DICT_7X7_250")]
    Dict7x7_250,
    #[serde(rename = "7x7_1000", alias = "DICT_7X7_1000")]
    Dict7x7_1000,
    #[serde(rename = "aruco_original", alias = "DICT_ARUCO_ORIGINAL")]
    ArucoOriginal,
}

impl Dictionary {
    /// Every supported dictionary, in OpenCV's `PREDEFINED_DICTIONARY_NAME` order.
    pub const ALL: [Dictionary; 17] = [
        Dictionary::Dict4x4_50,
        Dictionary::Dict4x4_100,
        Dictionary::Dict4x4_250,
        Dictionary::Dict4x4_1000,
        Dictionary::Dict5x5_50,
        Dictionary::Dict5x5_100,
        Dictionary::Dict5x5_250,
        Dictionary::Dict5x5_1000,
        Dictionary::Dict6x6_50,
        Dictionary::Dict6x6_100,
        Dictionary::Dict6x6_250,
        Dictionary::Dict6x6_1000,
        Dictionary::Dict7x7_50,
        Dictionary::Dict7x7_100,
        Dictionary::Dict7x7_250,
        Dictionary::Dict7x7_1000,
        Dictionary::ArucoOriginal,
    ];

    /// OpenCV's `cv::aruco::PREDEFINED_DICTIONARY_NAME` value (DICT_4X4_50 = 0 … DICT_ARUCO_ORIGINAL = 16).
    pub fn opencv_id(self) -> i32 {
        self as i32
    }

    /// Number of data bits along one side (the border is not counted).
    pub fn marker_size_bits(self) -> usize {
        use Dictionary::*;
        match self {
            Dict4x4_50 | Dict4x4_100 | Dict4x4_250 | Dict4x4_1000 => 4,
            Dict5x5_50 | Dict5x5_100 | Dict5x5_250 | Dict5x5_1000 | ArucoOriginal => 5,
            Dict6x6_50 | Dict6x6_100 | Dict6x6_250 | Dict6x6_1000 => 6,
            Dict7x7_50 | Dict7x7_100 | Dict7x7_250 | Dict7x7_1000 => 7,
        }
    }

    /// Number of markers (valid ids are `0..marker_count()`).
    pub fn marker_count(self) -> usize {
        use Dictionary::*;
        match self {
            Dict4x4_50 | Dict5x5_50 | Dict6x6_50 | Dict7x7_50 => 50,
            Dict4x4_100 | Dict5x5_100 | Dict6x6_100 | Dict7x7_100 => 100,
            Dict4x4_250 | Dict5x5_250 | Dict6x6_250 | Dict7x7_250 => 250,
            Dict4x4_1000 | Dict5x5_1000 | Dict6x6_1000 | Dict7x7_1000 => 1000,
            ArucoOriginal => 1024,
        }
    }

    /// OpenCV's name, e.g. `DICT_4X4_50`.
    pub fn opencv_name(self) -> String {
        match self {
            Dictionary::ArucoOriginal => "DICT_ARUCO_ORIGINAL".to_string(),
            d => {
                let n = d.marker_size_bits();
                format!("DICT_{n}X{n}_{}", d.marker_count())
            }
        }
    }

    /// The packed codes (see [`super::dictionaries`] for the bit layout); OpenCV's smaller
    /// dictionaries are prefixes of the _1000 one (verified by the generator), hence the slice.
    pub(crate) fn codes(self) -> &'static [u64] {
        let full: &'static [u64] = match self.marker_size_bits() {
            _ if self == Dictionary::ArucoOriginal => &tables::DICT_ARUCO_ORIGINAL,
            4 => &tables::DICT_4X4_1000,
            5 => &tables::DICT_5X5_1000,
            6 => &tables::DICT_6X6_1000,
            _ => &tables::DICT_7X7_1000,
        };
        &full[..self.marker_count()]
    }
}

impl Default for Dictionary {
    /// The seed rig's dictionary.
    fn default() -> Self {
        Dictionary::Dict4x4_50
    }
}
