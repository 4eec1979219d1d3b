//! Writing CSV tables with a fixed header through the `csv` crate (cells holding a comma, a quote
//! or a line break are quoted); numbers in full precision (`{}` of f64 round-trips).

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
#[error("{file}: {message}")]
pub struct CsvError {
    pub file: PathBuf,
    pub message: String,
}

/// A CSV file being written row by row (streaming: memory stays flat in the row count).
pub struct CsvWriter {
    path: PathBuf,
    out: csv::Writer<BufWriter<File>>,
    columns: usize,
}

impl CsvWriter {
    pub fn create(path: &Path, header: &[&str]) -> Result<Self, CsvError> {
        let file = File::create(path).map_err(|e| CsvError {
            file: path.into(),
            message: format!("cannot create: {e}"),
        })?;
        let mut w = Self {
            path: path.into(),
            out: csv::WriterBuilder::new()
                .has_headers(false)
                .from_writer(BufWriter::new(file)),
            columns: header.len(),
        };
        w.record(header)?;
        Ok(w)
    }

    /// Writes one row of already-formatted cells; the count must match the header.
    pub fn row(&mut self, cells: &[String]) -> Result<(), CsvError> {
        if cells.len() != self.columns {
            return Err(CsvError {
                file: self.path.clone(),
                message: format!("row has {} cells, header has {}", cells.len(), self.columns),
            });
        }
        self.record(cells)
    }

    fn record<T: AsRef<[u8]>>(&mut self, cells: &[T]) -> Result<(), CsvError> {
        self.out.write_record(cells).map_err(|e| CsvError {
            file: self.path.clone(),
            message: e.to_string(),
        })
    }

    pub fn finish(mut self) -> Result<(), CsvError> {
        self.out.flush().map_err(|e| CsvError {
            file: self.path.clone(),
            message: e.to_string(),
        })
    }
}

/// Formats a float for CSV: shortest round-trip representation, empty cell for NaN (missing).
pub fn num(v: f64) -> String {
    if v.is_nan() {
        String::new()
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_header_rows_and_round_trips_floats() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        let mut w = CsvWriter::create(&p, &["t_s", "x_px"]).unwrap();
        w.row(&[num(0.1), num(f64::NAN)]).unwrap();
        w.row(&[num(1.0 / 3.0), num(-2.5)]).unwrap();
        assert!(w.row(&[num(1.0)]).is_err());
        w.finish().unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "t_s,x_px");
        assert_eq!(lines[1], "0.1,");
        let back: f64 = lines[2].split(',').next().unwrap().parse().unwrap();
        assert_eq!(back, 1.0 / 3.0);
    }

    #[test]
    fn a_cell_with_a_comma_or_a_quote_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        let cells = [
            "frames, cropped".to_string(),
            "the \"reference\" marker".to_string(),
            "two\nlines".to_string(),
        ];
        let mut w = CsvWriter::create(&p, &["a", "b", "c"]).unwrap();
        w.row(&cells).unwrap();
        w.finish().unwrap();
        let mut r = csv::Reader::from_path(&p).unwrap();
        assert_eq!(r.headers().unwrap(), vec!["a", "b", "c"]);
        let rows: Vec<csv::StringRecord> = r.records().map(|r| r.unwrap()).collect();
        assert_eq!(rows.len(), 1);
        assert_eq!(
            rows[0].iter().collect::<Vec<_>>(),
            cells.iter().map(String::as_str).collect::<Vec<_>>()
        );
    }
}
