//! A marker's data bits and its full printed cell grid (data bits inside a black border).

use thiserror::Error;

use super::Dictionary;

/// Errors for marker look-ups.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum MarkerError {
    #[error("marker id {id} is out of range for {dictionary} (valid ids 0..={max})")]
    IdOutOfRange {
        dictionary: String,
        id: usize,
        max: usize,
    },
    #[error("border_bits must be >= 1 (OpenCV's detector needs a black border), got {0}")]
    BorderBits(usize),
}

/// The data bits of marker `id`, `bits[row][col]`, row 0 at the top of the marker as printed;
/// `true` = white cell (OpenCV's convention: 1 is white in `getBitsFromByteList`/`drawMarker`).
pub fn marker_bits(dict: Dictionary, id: usize) -> Result<Vec<Vec<bool>>, MarkerError> {
    let codes = dict.codes();
    let code = *codes.get(id).ok_or_else(|| MarkerError::IdOutOfRange {
        dictionary: dict.opencv_name(),
        id,
        max: codes.len() - 1,
    })?;
    let n = dict.marker_size_bits();
    Ok((0..n)
        .map(|r| {
            (0..n)
                .map(|c| (code >> (n * n - 1 - (r * n + c))) & 1 == 1)
                .collect()
        })
        .collect())
}

/// The printed cell grid of marker `id` including `border_bits` black border cells on each
/// side: `(n + 2·border_bits)` rows of as many cells, `true` = white, row 0 at the top.
pub fn cells(
    dict: Dictionary,
    id: usize,
    border_bits: usize,
) -> Result<Vec<Vec<bool>>, MarkerError> {
    if border_bits == 0 {
        return Err(MarkerError::BorderBits(border_bits));
    }
    let bits = marker_bits(dict, id)?;
    let n = bits.len();
    let side = n + 2 * border_bits;
    let inside = |k: usize| k >= border_bits && k < border_bits + n;
    Ok((0..side)
        .map(|r| {
            (0..side)
                .map(|c| inside(r) && inside(c) && bits[r - border_bits][c - border_bits])
                .collect()
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_dictionary_has_distinct_codes_of_the_right_width() {
        for d in Dictionary::ALL {
            let n = d.marker_size_bits();
            let codes = d.codes();
            assert_eq!(codes.len(), d.marker_count(), "{d:?}");
            for &c in codes {
                assert_eq!(c >> (n * n), 0, "{d:?}: code {c:#x} wider than {n}x{n}");
            }
            let mut sorted = codes.to_vec();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), codes.len(), "{d:?} has duplicate codes");
        }
    }

    #[test]
    fn opencv_ids_follow_the_predefined_enum() {
        assert_eq!(Dictionary::Dict4x4_50.opencv_id(), 0);
        assert_eq!(Dictionary::Dict6x6_1000.opencv_id(), 11);
        assert_eq!(Dictionary::ArucoOriginal.opencv_id(), 16);
        assert_eq!(Dictionary::Dict5x5_250.opencv_name(), "DICT_5X5_250");
        for (i, d) in Dictionary::ALL.iter().enumerate() {
            assert_eq!(d.opencv_id(), i as i32, "{d:?}");
        }
    }

    #[test]
    fn id_out_of_range_is_an_error() {
        assert!(marker_bits(Dictionary::Dict4x4_50, 49).is_ok());
        let e = marker_bits(Dictionary::Dict4x4_50, 50).unwrap_err();
        assert!(e.to_string().contains("DICT_4X4_50"), "{e}");
        assert!(cells(Dictionary::Dict4x4_50, 0, 0).is_err());
    }

    #[test]
    fn cells_have_black_border_and_bits_inside() {
        for border in 1..=2 {
            let bits = marker_bits(Dictionary::Dict6x6_250, 17).unwrap();
            let grid = cells(Dictionary::Dict6x6_250, 17, border).unwrap();
            let side = 6 + 2 * border;
            assert_eq!(grid.len(), side);
            for (r, row) in grid.iter().enumerate() {
                assert_eq!(row.len(), side);
                for (c, &white) in row.iter().enumerate() {
                    let in_data =
                        (border..border + 6).contains(&r) && (border..border + 6).contains(&c);
                    let expected = in_data && bits[r - border][c - border];
                    assert_eq!(white, expected, "cell ({r},{c})");
                }
            }
        }
    }

    #[test]
    fn serde_names_and_opencv_aliases() {
        #[derive(serde::Deserialize)]
        struct W {
            d: Dictionary,
        }
        let w: W = toml::from_str("d = \"4x4_50\"").unwrap();
        assert_eq!(w.d, Dictionary::Dict4x4_50);
        let w: W = toml::from_str("d = \"DICT_6X6_1000\"").unwrap();
        assert_eq!(w.d, Dictionary::Dict6x6_1000);
        let w: W = toml::from_str("d = \"aruco_original\"").unwrap();
        assert_eq!(w.d, Dictionary::ArucoOriginal);
        assert!(toml::from_str::<W>("d = \"4x4_51\"").is_err());
    }
}
