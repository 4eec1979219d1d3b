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
    #[error("{file}: cannot read: {source}")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: missing column(s) {missing:?} (need frame, t_s, marker_id, x0_px … y3_px)")]
    MissingColumns { file: PathBuf, missing: Vec<String> },
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
    #[error("{file}: no frames")]
    Empty { file: PathBuf },
}

/// Reads a tracks CSV written by `geneva run`/`analyze` (or by hand with the same columns).
pub fn read_tracks(path: &Path) -> Result<Vec<TrackRow>, TracksReadError> {
    let file = path.to_path_buf();
    let text = std::fs::read_to_string(path).map_err(|source| TracksReadError::Read {
        file: file.clone(),
        source,
    })?;
    parse_tracks(&text, path)
}

/// Parses tracks CSV text; `path` only names the source in errors.
pub fn parse_tracks(text: &str, path: &Path) -> Result<Vec<TrackRow>, TracksReadError> {
    let file = path.to_path_buf();
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(TracksReadError::Empty { file });
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
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
        return Err(TracksReadError::MissingColumns { file, missing });
    }
    let idx = |n: &str| col(n).unwrap_or(0);
    let corner_idx: Vec<usize> = CORNER_COLUMNS.iter().map(|n| idx(n)).collect();
    let ref_idx: Option<Vec<usize>> = REF_COLUMNS.iter().map(|n| col(n)).collect();
    let mut rows: Vec<TrackRow> = Vec::new();
    for (i, line) in lines {
        let line_no = i + 1;
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let cell = |k: usize, name: &str| -> Result<&str, TracksReadError> {
            cells.get(k).copied().ok_or_else(|| TracksReadError::Cell {
                file: file.clone(),
                line: line_no,
                column: name.into(),
                message: format!("row has {} cells, header has {}", cells.len(), names.len()),
            })
        };
        let number = |k: usize, name: &str| -> Result<Option<f64>, TracksReadError> {
            let c = cell(k, name)?;
            if c.is_empty() {
                return Ok(None);
            }
            c.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(Some)
                .ok_or_else(|| TracksReadError::Cell {
                    file: file.clone(),
                    line: line_no,
                    column: name.into(),
                    message: format!("`{c}` is not a finite number"),
                })
        };
        let frame_cell = cell(idx("frame"), "frame")?;
        let frame: usize = frame_cell.parse().map_err(|_| TracksReadError::Cell {
            file: file.clone(),
            line: line_no,
            column: "frame".into(),
            message: format!("`{frame_cell}` is not a frame index"),
        })?;
        let t_s = number(idx("t_s"), "t_s")?.ok_or_else(|| TracksReadError::Cell {
            file: file.clone(),
            line: line_no,
            column: "t_s".into(),
            message: "empty".into(),
        })?;
        if let Some(prev) = rows.last() {
            if t_s <= prev.t_s {
                return Err(TracksReadError::Time {
                    file,
                    line: line_no,
                    frame,
                    t_s,
                    previous_s: prev.t_s,
                });
            }
        }
        let read_corners =
            |ids: &[usize], names: &[&str]| -> Result<Option<Corners>, TracksReadError> {
                let v: Vec<Option<f64>> = ids
                    .iter()
                    .zip(names)
                    .map(|(k, n)| number(*k, n))
                    .collect::<Result<_, _>>()?;
                if v.iter().all(Option::is_none) {
                    return Ok(None);
                }
                if let Some(k) = v.iter().position(Option::is_none) {
                    return Err(TracksReadError::Cell {
                        file: file.clone(),
                        line: line_no,
                        column: names[k].into(),
                        message: "empty while other corners are given".into(),
                    });
                }
                let c: Vec<f64> = v.into_iter().flatten().collect();
                Ok(Some([
                    [c[0], c[1]],
                    [c[2], c[3]],
                    [c[4], c[5]],
                    [c[6], c[7]],
                ]))
            };
        let corners_px = read_corners(&corner_idx, &CORNER_COLUMNS)?;
        let reference_px = match &ref_idx {
            Some(ids) => read_corners(ids, &REF_COLUMNS)?,
            None => None,
        };
        let id_cell = cell(idx("marker_id"), "marker_id")?;
        let marker_id = if id_cell.is_empty() {
            -1
        } else {
            id_cell.parse().map_err(|_| TracksReadError::Cell {
                file: file.clone(),
                line: line_no,
                column: "marker_id".into(),
                message: format!("`{id_cell}` is not an integer"),
            })?
        };
        rows.push(TrackRow {
            frame,
            t_s,
            marker_id,
            corners_px,
            reference_px,
        });
    }
    if rows.is_empty() {
        return Err(TracksReadError::Empty { file });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert_eq!(read_tracks(&p).unwrap(), rows);
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let p = Path::new("t.csv");
        let e = parse_tracks("frame,t_s,x0_px\n0,0,1\n", p)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("t.csv") && e.contains("marker_id") && e.contains("y3_px"),
            "{e}"
        );
        let head = "frame,t_s,marker_id,x0_px,y0_px,x1_px,y1_px,x2_px,y2_px,x3_px,y3_px\n";
        let e = parse_tracks(
            &format!("{head}0,0.1,0,1,2,3,4,5,6,7,8\n1,0.05,0,1,2,3,4,5,6,7,8\n"),
            p,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 3") && e.contains("frame 1"), "{e}");
        let e = parse_tracks(&format!("{head}0,0.1,0,1,abc,3,4,5,6,7,8\n"), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("y0_px") && e.contains("abc"), "{e}");
        let e = parse_tracks(&format!("{head}0,0.1,0,1,,3,4,5,6,7,8\n"), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("y0_px") && e.contains("empty"), "{e}");
        let e = parse_tracks(&format!("{head}0,0.1,0,1,2\n"), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("cells"), "{e}");
        assert!(parse_tracks("", p).is_err());
    }
}
