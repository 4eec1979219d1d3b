//! `tracks.csv`: per-frame marker corners (OpenCV corner order and pixel convention).
//!
//! Columns: `frame, t_s, marker_id, x0_px, y0_px, …, x3_px, y3_px`, then optionally the static
//! reference marker's `ref_x0_px … ref_y3_px`. A frame where the marker was not detected has an
//! empty `marker_id` and empty corner cells: missing, never interpolated.

use super::csv_out::{num, CsvError, CsvWriter};
use std::path::{Path, PathBuf};

pub type Corners = [[f64; 2]; 4];

/// One frame of a track.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackRow {
    pub frame: usize,
    pub t_s: f64,
    pub marker_id: i32,
    pub corners_px: Option<Corners>,
    pub reference_px: Option<Corners>,
}

const CORNER_COLUMNS: [&str; 8] = [
    "x0_px", "y0_px", "x1_px", "y1_px", "x2_px", "y2_px", "x3_px", "y3_px",
];
const REF_COLUMNS: [&str; 8] = [
    "ref_x0_px",
    "ref_y0_px",
    "ref_x1_px",
    "ref_y1_px",
    "ref_x2_px",
    "ref_y2_px",
    "ref_x3_px",
    "ref_y3_px",
];

/// Streaming writer for tracks.
pub struct TracksWriter {
    inner: CsvWriter,
    with_reference: bool,
}

impl TracksWriter {
    pub fn create(path: &Path, with_reference: bool) -> Result<Self, CsvError> {
        let mut header = vec!["frame", "t_s", "marker_id"];
        header.extend_from_slice(&CORNER_COLUMNS);
        if with_reference {
            header.extend_from_slice(&REF_COLUMNS);
        }
        Ok(Self {
            inner: CsvWriter::create(path, &header)?,
            with_reference,
        })
    }

    pub fn row(&mut self, r: &TrackRow) -> Result<(), CsvError> {
        let mut cells = vec![r.frame.to_string(), num(r.t_s)];
        let corners = |c: &Option<Corners>, cells: &mut Vec<String>| match c {
            Some(c) => cells.extend(c.iter().flat_map(|p| [num(p[0]), num(p[1])])),
            None => cells.extend(std::iter::repeat_n(String::new(), 8)),
        };
        cells.push(if r.corners_px.is_some() {
            r.marker_id.to_string()
        } else {
            String::new()
        });
        corners(&r.corners_px, &mut cells);
        if self.with_reference {
            corners(&r.reference_px, &mut cells);
        }
        self.inner.row(&cells)
    }

    pub fn finish(self) -> Result<(), CsvError> {
        self.inner.finish()
    }
}

#[derive(Debug, thiserror::Error)]
pub enum TracksReadError {
    #[error("{file}: cannot read")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: line {line}: {message}")]
    Header {
        file: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{file}: line {line}: missing column(s) {} (need frame, t_s, marker_id, x0_px … y3_px)", missing.join(", "))]
    MissingColumns {
        file: PathBuf,
        line: usize,
        missing: Vec<String>,
    },
    #[error("{file}: line {line}, column `{column}`: {message}")]
    Cell {
        file: PathBuf,
        line: usize,
        column: String,
        message: String,
    },
    #[error("{file}: line {line}: frame {frame} has t_s {t_s} s, not after the previous frame's {previous_s} s")]
    Time {
        file: PathBuf,
        line: usize,
        frame: usize,
        t_s: f64,
        previous_s: f64,
    },
    #[error("{file}: line {line}: frame {frame} appears again (first on line {first_line})")]
    DuplicateFrame {
        file: PathBuf,
        line: usize,
        frame: usize,
        first_line: usize,
    },
    #[error("{file}: line {line}: frame {frame} comes after frame {previous} (line {previous_line}); frames must increase")]
    FrameOrder {
        file: PathBuf,
        line: usize,
        frame: usize,
        previous: usize,
        previous_line: usize,
    },
    #[error("{file}: line {line}: marker_id {id} is not the analysed marker {expected} (set by the scenario's `detector.marker_id`)")]
    UnknownMarker {
        file: PathBuf,
        line: usize,
        id: i32,
        expected: i32,
    },
    #[error("{file}: no frames")]
    Empty { file: PathBuf },
}

/// Largest frame number a track may hold (a billion frames: over a year at 30 fps).
pub const MAX_FRAME: usize = 1_000_000_000;
/// Largest corner coordinate magnitude, px: far outside any image, small enough that every
/// derived quantity (squared distances, circle fits) stays finite.
pub const MAX_COORDINATE_PX: f64 = 1e6;
/// Longest line accepted, bytes (a row of 19 numbers is a few hundred).
pub const MAX_LINE_BYTES: usize = 1 << 16;
/// Largest timestamp magnitude, s (about 30 years).
pub const MAX_TIME_S: f64 = 1e9;

/// Reads a tracks CSV written by `geneva run`/`analyze` (or by hand with the same columns),
/// line by line. `expected_marker_id`: when given, a row naming another marker is an error.
pub fn read_tracks(
    path: &Path,
    expected_marker_id: Option<i32>,
) -> Result<Vec<TrackRow>, TracksReadError> {
    let file = std::fs::File::open(path).map_err(|source| TracksReadError::Read {
        file: path.to_path_buf(),
        source,
    })?;
    read_tracks_from(std::io::BufReader::new(file), path, expected_marker_id)
}

/// [`read_tracks`] from any reader (bytes need not be UTF-8: such a line is an error naming
/// it); `path` only names the source in errors.
pub fn read_tracks_from<R: std::io::BufRead>(
    mut reader: R,
    path: &Path,
    expected_marker_id: Option<i32>,
) -> Result<Vec<TrackRow>, TracksReadError> {
    use std::io::{BufRead, Read};
    let read_err = |source| TracksReadError::Read {
        file: path.to_path_buf(),
        source,
    };
    let mut parser = TracksParser::new(path, expected_marker_id);
    let mut buf = Vec::new();
    loop {
        buf.clear();
        let limit = MAX_LINE_BYTES as u64 + 1;
        if (&mut reader)
            .take(limit)
            .read_until(b'\n', &mut buf)
            .map_err(read_err)?
            == 0
        {
            break;
        }
        if buf.len() > MAX_LINE_BYTES {
            return Err(TracksReadError::Header {
                file: path.to_path_buf(),
                line: parser.line_no + 1,
                message: format!("line longer than {MAX_LINE_BYTES} bytes: not a tracks file"),
            });
        }
        match std::str::from_utf8(&buf) {
            Ok(line) => parser.line(line)?,
            Err(_) => {
                return Err(TracksReadError::Header {
                    file: path.to_path_buf(),
                    line: parser.line_no + 1,
                    message: "not UTF-8 text".into(),
                })
            }
        }
    }
    parser.finish()
}

/// Parses tracks CSV text; `path` only names the source in errors.
pub fn parse_tracks(
    text: &str,
    path: &Path,
    expected_marker_id: Option<i32>,
) -> Result<Vec<TrackRow>, TracksReadError> {
    let mut parser = TracksParser::new(path, expected_marker_id);
    for line in text.split_inclusive('\n') {
        parser.line(line)?;
    }
    parser.finish()
}

/// Column positions found in the header.
struct Columns {
    count: usize,
    frame: usize,
    t_s: usize,
    marker_id: usize,
    corners: [usize; 8],
    reference: Option<[usize; 8]>,
}

/// Line-at-a-time tracks parser (memory: the rows, never the text).
struct TracksParser {
    file: PathBuf,
    expected_marker_id: Option<i32>,
    line_no: usize,
    columns: Option<Columns>,
    rows: Vec<TrackRow>,
    previous_line: usize,
}

impl TracksParser {
    fn new(path: &Path, expected_marker_id: Option<i32>) -> Self {
        Self {
            file: path.to_path_buf(),
            expected_marker_id,
            line_no: 0,
            columns: None,
            rows: Vec::new(),
            previous_line: 0,
        }
    }

    fn line(&mut self, raw: &str) -> Result<(), TracksReadError> {
        self.line_no += 1;
        // A UTF-8 byte-order mark (spreadsheet exports) is not part of the first column's name.
        let raw = if self.line_no == 1 {
            raw.strip_prefix('\u{feff}').unwrap_or(raw)
        } else {
            raw
        };
        let line = raw.trim_end_matches(['\n', '\r']);
        if line.trim().is_empty() {
            return Ok(());
        }
        // Every writer ends its lines; a last line without one is a file cut mid-row, whose
        // last number may be cut too (`…,242` read as `…,24` moved a fitted centre by 300 px).
        if !raw.ends_with('\n') {
            return Err(TracksReadError::Header {
                file: self.file.clone(),
                line: self.line_no,
                message: format!(
                    "the file ends inside this line, after `{}` (no end of line): the file was \
                     cut and the last value may be too; end the line if it is complete",
                    line.rsplit(',').next().unwrap_or(line).trim()
                ),
            });
        }
        match &self.columns {
            None => {
                self.columns = Some(self.header(line)?);
                Ok(())
            }
            Some(_) => self.row(line),
        }
    }

    fn header(&self, line: &str) -> Result<Columns, TracksReadError> {
        let names: Vec<&str> = line.split(',').map(str::trim).collect();
        // A set, not a scan of the names before each: a hostile header of 10⁵ columns.
        let mut seen = std::collections::HashSet::with_capacity(names.len());
        for n in &names {
            if !n.is_empty() && !seen.insert(*n) {
                return Err(TracksReadError::Header {
                    file: self.file.clone(),
                    line: self.line_no,
                    message: format!("column `{n}` appears twice"),
                });
            }
        }
        let col = |n: &str| names.iter().position(|h| *h == n);
        let required: Vec<&str> = ["frame", "t_s", "marker_id"]
            .into_iter()
            .chain(CORNER_COLUMNS)
            .collect();
        let missing: Vec<String> = required
            .iter()
            .filter(|n| col(n).is_none())
            .map(|n| n.to_string())
            .collect();
        if !missing.is_empty() {
            return Err(TracksReadError::MissingColumns {
                file: self.file.clone(),
                line: self.line_no,
                missing,
            });
        }
        let positions = |cols: &[&str; 8]| -> Option<[usize; 8]> {
            let v: Option<Vec<usize>> = cols.iter().map(|n| col(n)).collect();
            v.and_then(|v| v.try_into().ok())
        };
        let reference = positions(&REF_COLUMNS);
        let some_ref: Vec<&str> = REF_COLUMNS
            .iter()
            .copied()
            .filter(|n| col(n).is_some())
            .collect();
        if reference.is_none() && !some_ref.is_empty() {
            return Err(TracksReadError::Header {
                file: self.file.clone(),
                line: self.line_no,
                message: format!(
                    "reference columns incomplete: {} given, need all of ref_x0_px … ref_y3_px",
                    some_ref.join(", ")
                ),
            });
        }
        Ok(Columns {
            count: names.len(),
            frame: col("frame").unwrap_or(0),
            t_s: col("t_s").unwrap_or(0),
            marker_id: col("marker_id").unwrap_or(0),
            corners: positions(&CORNER_COLUMNS).unwrap_or_default(),
            reference,
        })
    }

    fn cell_err(&self, column: &str, message: String) -> TracksReadError {
        TracksReadError::Cell {
            file: self.file.clone(),
            line: self.line_no,
            column: column.into(),
            message,
        }
    }

    fn row(&mut self, line: &str) -> Result<(), TracksReadError> {
        let Some(cols) = &self.columns else {
            return Ok(());
        };
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != cols.count {
            return Err(self.cell_err(
                "",
                format!("row has {} cells, header has {}", cells.len(), cols.count),
            ));
        }
        let number = |k: usize, name: &str, limit: f64| -> Result<Option<f64>, TracksReadError> {
            let c = cells[k];
            if c.is_empty() {
                return Ok(None);
            }
            match c.parse::<f64>() {
                Ok(v) if v.is_finite() && v.abs() <= limit => Ok(Some(v)),
                Ok(v) if v.is_finite() => {
                    Err(self.cell_err(name, format!("{c} is outside [-{limit:e}, {limit:e}]")))
                }
                _ => Err(self.cell_err(name, format!("`{c}` is not a finite number"))),
            }
        };
        let frame_cell = cells[cols.frame];
        let frame = frame_cell
            .parse::<usize>()
            .ok()
            .filter(|&f| f <= MAX_FRAME)
            .ok_or_else(|| {
                self.cell_err(
                    "frame",
                    format!("`{frame_cell}` is not a frame number in [0, {MAX_FRAME}]"),
                )
            })?;
        let t_s = number(cols.t_s, "t_s", MAX_TIME_S)?
            .ok_or_else(|| self.cell_err("t_s", "empty".into()))?;
        if let Some(prev) = self.rows.last() {
            if frame == prev.frame {
                return Err(TracksReadError::DuplicateFrame {
                    file: self.file.clone(),
                    line: self.line_no,
                    frame,
                    first_line: self.previous_line,
                });
            }
            if frame < prev.frame {
                return Err(TracksReadError::FrameOrder {
                    file: self.file.clone(),
                    line: self.line_no,
                    frame,
                    previous: prev.frame,
                    previous_line: self.previous_line,
                });
            }
            if t_s <= prev.t_s {
                return Err(TracksReadError::Time {
                    file: self.file.clone(),
                    line: self.line_no,
                    frame,
                    t_s,
                    previous_s: prev.t_s,
                });
            }
        }
        let read_corners =
            |ids: &[usize; 8], names: &[&str; 8]| -> Result<Option<Corners>, TracksReadError> {
                let mut v = [0.0; 8];
                let mut given = 0;
                let mut first_empty = None;
                for (k, (&i, n)) in ids.iter().zip(names).enumerate() {
                    match number(i, n, MAX_COORDINATE_PX)? {
                        Some(x) => {
                            v[k] = x;
                            given += 1;
                        }
                        None => {
                            first_empty.get_or_insert(k);
                        }
                    }
                }
                match (given, first_empty) {
                    (0, _) => Ok(None),
                    (_, Some(k)) => {
                        Err(self.cell_err(names[k], "empty while other corners are given".into()))
                    }
                    (_, None) => Ok(Some([
                        [v[0], v[1]],
                        [v[2], v[3]],
                        [v[4], v[5]],
                        [v[6], v[7]],
                    ])),
                }
            };
        let corners_px = read_corners(&cols.corners, &CORNER_COLUMNS)?;
        let reference_px = match &cols.reference {
            Some(ids) => read_corners(ids, &REF_COLUMNS)?,
            None => None,
        };
        let id_cell = cells[cols.marker_id];
        let marker_id = if id_cell.is_empty() {
            if corners_px.is_some() {
                return Err(self.cell_err(
                    "marker_id",
                    "empty while the corners are given (which marker are they?)".into(),
                ));
            }
            -1
        } else {
            let id: i32 = id_cell.parse().map_err(|_| {
                self.cell_err("marker_id", format!("`{id_cell}` is not an integer"))
            })?;
            match self.expected_marker_id {
                Some(expected) if id != expected => {
                    return Err(TracksReadError::UnknownMarker {
                        file: self.file.clone(),
                        line: self.line_no,
                        id,
                        expected,
                    })
                }
                _ => id,
            }
        };
        self.rows.push(TrackRow {
            frame,
            t_s,
            marker_id,
            corners_px,
            reference_px,
        });
        self.previous_line = self.line_no;
        Ok(())
    }

    fn finish(self) -> Result<Vec<TrackRow>, TracksReadError> {
        if self.rows.is_empty() {
            return Err(TracksReadError::Empty { file: self.file });
        }
        Ok(self.rows)
    }
}

/// Runs of absent frame numbers between the first and last row (rows sorted by frame).
pub fn frame_gaps(rows: &[TrackRow]) -> Vec<std::ops::RangeInclusive<usize>> {
    rows.windows(2)
        .filter(|w| w[1].frame > w[0].frame + 1)
        .map(|w| w[0].frame + 1..=w[1].frame - 1)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_tracks_t(text: &str, p: &Path) -> Result<Vec<TrackRow>, TracksReadError> {
        parse_tracks(text, p, None)
    }

    const HEAD: &str = "frame,t_s,marker_id,x0_px,y0_px,x1_px,y1_px,x2_px,y2_px,x3_px,y3_px\n";

    fn row(frame: usize, id: &str) -> String {
        format!("{frame},{},{id},1,2,3,4,5,6,7,8\n", frame as f64 / 30.0)
    }

    #[test]
    fn utf8_bom_before_the_header_is_accepted() {
        // Regression: a BOM gave "missing column(s) [\"frame\"]".
        let text = format!("\u{feff}{HEAD}{}", row(0, "0"));
        let rows = parse_tracks(&text, Path::new("bom.csv"), Some(0)).unwrap();
        assert_eq!(rows.len(), 1);
        // Through the file reader too.
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bom.csv");
        std::fs::write(&p, text.as_bytes()).unwrap();
        assert_eq!(read_tracks(&p, Some(0)).unwrap().len(), 1);
    }

    #[test]
    fn a_file_cut_inside_its_last_row_is_an_error_naming_the_line() {
        // Regression: `…,242` cut to `…,24` was read as a corner 218 px away, exit 0.
        let whole = format!("{HEAD}{}{}", row(0, "0"), row(1, "0"));
        assert_eq!(parse_tracks_t(&whole, Path::new("t.csv")).unwrap().len(), 2);
        let cut = &whole[..whole.len() - 2];
        let err = parse_tracks_t(cut, Path::new("t.csv")).unwrap_err();
        let text = err.to_string();
        assert!(
            matches!(err, TracksReadError::Header { line: 3, .. }) && text.contains("cut"),
            "{text}"
        );
        // Through the streaming reader too.
        let err = read_tracks_from(cut.as_bytes(), Path::new("t.csv"), Some(0)).unwrap_err();
        assert!(
            matches!(err, TracksReadError::Header { line: 3, .. }),
            "{err}"
        );
        // A header alone without its line end is cut as well (no row can follow it).
        assert!(parse_tracks_t(HEAD.trim_end(), Path::new("t.csv")).is_err());
    }

    #[test]
    fn frame_numbers_are_kept_and_gaps_listed() {
        // Regression: frames 50–59 came out as 10–19 and 40 absent frames counted as none.
        let text: String = std::iter::once(HEAD.to_string())
            .chain((0..10).chain(50..60).map(|f| row(f, "0")))
            .collect();
        let rows = parse_tracks(&text, Path::new("t.csv"), Some(0)).unwrap();
        let frames: Vec<usize> = rows.iter().map(|r| r.frame).collect();
        assert_eq!(frames[10..], (50..60).collect::<Vec<_>>()[..]);
        assert_eq!(frame_gaps(&rows), vec![10..=49]);
    }

    #[test]
    fn duplicate_and_backward_frames_are_errors_naming_the_lines() {
        let p = Path::new("t.csv");
        let e =
            parse_tracks(&format!("{HEAD}{}{}", row(0, "0"), row(0, "0")), p, None).unwrap_err();
        assert!(
            matches!(
                e,
                TracksReadError::DuplicateFrame {
                    line: 3,
                    frame: 0,
                    first_line: 2,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("t.csv: line 3"), "{e}");
        let e =
            parse_tracks(&format!("{HEAD}{}{}", row(5, "0"), row(4, "0")), p, None).unwrap_err();
        assert!(
            matches!(e, TracksReadError::FrameOrder { line: 3, .. }),
            "{e}"
        );
    }

    #[test]
    fn a_marker_other_than_the_analysed_one_is_an_error_naming_the_line() {
        let p = Path::new("t.csv");
        let text = format!("{HEAD}{}{}", row(0, "0"), row(1, "7"));
        let e = parse_tracks(&text, p, Some(0)).unwrap_err();
        assert!(
            matches!(
                e,
                TracksReadError::UnknownMarker {
                    line: 3,
                    id: 7,
                    expected: 0,
                    ..
                }
            ),
            "{e}"
        );
        // Without an expectation the id is kept as written.
        assert_eq!(parse_tracks(&text, p, None).unwrap()[1].marker_id, 7);
        // Corners without an id cannot be attributed.
        let e = parse_tracks(&format!("{HEAD}{}", row(0, "")), p, None).unwrap_err();
        assert!(e.to_string().contains("marker_id"), "{e}");
    }

    #[test]
    fn out_of_range_numbers_are_errors_naming_line_and_column() {
        // Regression: a corner of 1e308 gave an error with no line number.
        let p = Path::new("t.csv");
        let text = format!("{HEAD}{}1,0.5,0,1e308,2,3,4,5,6,7,8\n", row(0, "0"));
        let e = parse_tracks(&text, p, None).unwrap_err().to_string();
        assert!(
            e.contains("t.csv: line 3") && e.contains("x0_px") && e.contains("1e308"),
            "{e}"
        );
        let e = parse_tracks(&format!("{HEAD}99999999999,0,0,1,2,3,4,5,6,7,8\n"), p, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("frame"), "{e}");
        let e = parse_tracks(&format!("{HEAD}0,1e300,0,1,2,3,4,5,6,7,8\n"), p, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("t_s"), "{e}");
    }

    #[test]
    fn header_problems_name_the_line() {
        let p = Path::new("t.csv");
        let e = parse_tracks("frame,frame,t_s\n", p, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 1") && e.contains("twice"), "{e}");
        let head = HEAD.trim_end().to_string() + ",ref_x0_px\n";
        let e = parse_tracks(&head, p, None).unwrap_err().to_string();
        assert!(e.contains("reference columns incomplete"), "{e}");
        let e = parse_tracks("\n\nframe,t_s\n", p, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("marker_id"), "{e}");
    }

    #[test]
    fn round_trip_with_missing_frames_and_reference() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("tracks.csv");
        let c: Corners = [[1.5, 2.25], [3.0, 4.0], [5.0, 6.0], [7.0, 8.125]];
        let rows = vec![
            TrackRow {
                frame: 0,
                t_s: 0.0,
                marker_id: 0,
                corners_px: Some(c),
                reference_px: Some(c),
            },
            TrackRow {
                frame: 1,
                t_s: 1.0 / 30.0,
                marker_id: -1,
                corners_px: None,
                reference_px: Some(c),
            },
        ];
        let mut w = TracksWriter::create(&p, true).unwrap();
        for r in &rows {
            w.row(r).unwrap();
        }
        w.finish().unwrap();
        assert_eq!(read_tracks(&p, Some(0)).unwrap(), rows);
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let p = Path::new("t.csv");
        let e = parse_tracks_t("frame,t_s,x0_px\n0,0,1\n", p)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("t.csv") && e.contains("marker_id") && e.contains("y3_px"),
            "{e}"
        );
        let head = "frame,t_s,marker_id,x0_px,y0_px,x1_px,y1_px,x2_px,y2_px,x3_px,y3_px\n";
        let e = parse_tracks_t(
            &format!("{head}0,0.1,0,1,2,3,4,5,6,7,8\n1,0.05,0,1,2,3,4,5,6,7,8\n"),
            p,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 3") && e.contains("frame 1"), "{e}");
        let e = parse_tracks_t(&format!("{head}0,0.1,0,1,abc,3,4,5,6,7,8\n"), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("y0_px") && e.contains("abc"), "{e}");
        let e = parse_tracks_t(&format!("{head}0,0.1,0,1,,3,4,5,6,7,8\n"), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("y0_px") && e.contains("empty"), "{e}");
        let e = parse_tracks_t(&format!("{head}0,0.1,0,1,2\n"), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("cells"), "{e}");
        assert!(parse_tracks_t("", p).is_err());
    }
}
