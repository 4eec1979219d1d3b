//! results.csv: one tidy row per (point, seed), appended as each run finishes and read back to
//! resume a sweep and to summarise it. Columns: point, key, one per axis, seed_index, seed, the
//! metrics, status (`ok`, `invalid`, `failed`), error.

use super::error::SweepError;
use super::PointMetrics;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Metric column names, in [`PointMetrics::to_cells`] order.
pub const METRICS: [&str; 9] = [
    "theta_rms_rad",
    "omega_rms_rad_s",
    "alpha_rms_rad_s2",
    "omega_p95_rad_s",
    "alpha_p95_rad_s2",
    "frames_total",
    "frames_detected",
    "dwell_alpha_std_rad_s2",
    "mean_frame_interval_s",
];

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Evaluated; metrics present.
    Ok,
    /// The point's settings do not form a valid scenario (never evaluated).
    Invalid,
    /// The evaluator returned an error.
    Failed,
}

impl Status {
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Invalid => "invalid",
            Status::Failed => "failed",
        }
    }
    fn parse(s: &str) -> Option<Self> {
        match s {
            "ok" => Some(Status::Ok),
            "invalid" => Some(Status::Invalid),
            "failed" => Some(Status::Failed),
            _ => None,
        }
    }
}

/// One row of results.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct ResultRow {
    pub point: usize,
    pub key: String,
    pub labels: Vec<String>,
    pub seed_index: usize,
    pub seed: u64,
    pub metrics: Option<PointMetrics>,
    pub status: Status,
    pub error: String,
}

impl PointMetrics {
    /// Values in [`METRICS`] order (counts as f64).
    pub fn values(&self) -> [f64; 9] {
        [
            self.theta_rms_rad,
            self.omega_rms_rad_s,
            self.alpha_rms_rad_s2,
            self.omega_p95_rad_s,
            self.alpha_p95_rad_s2,
            self.frames_total as f64,
            self.frames_detected as f64,
            self.dwell_alpha_std_rad_s2,
            self.mean_frame_interval_s,
        ]
    }

    fn from_values(v: &[f64]) -> Self {
        Self {
            theta_rms_rad: v[0],
            omega_rms_rad_s: v[1],
            alpha_rms_rad_s2: v[2],
            omega_p95_rad_s: v[3],
            alpha_p95_rad_s2: v[4],
            frames_total: v[5] as usize,
            frames_detected: v[6] as usize,
            dwell_alpha_std_rad_s2: v[7],
            mean_frame_interval_s: v[8],
        }
    }
}

/// The header for a sweep with these axis names.
pub fn header(axis_names: &[String]) -> Vec<String> {
    let mut h = vec!["point".to_string(), "key".to_string()];
    h.extend(axis_names.iter().cloned());
    h.push("seed_index".into());
    h.push("seed".into());
    h.extend(METRICS.iter().map(|s| s.to_string()));
    h.push("status".into());
    h.push("error".into());
    h
}

fn cells(row: &ResultRow) -> Vec<String> {
    let mut c = vec![row.point.to_string(), row.key.clone()];
    c.extend(row.labels.iter().cloned());
    c.push(row.seed_index.to_string());
    c.push(row.seed.to_string());
    match &row.metrics {
        Some(m) => c.extend(m.values().iter().map(|v| v.to_string())),
        None => c.extend(METRICS.iter().map(|_| String::new())),
    }
    c.push(row.status.as_str().into());
    c.push(row.error.clone());
    c
}

/// Reads the rows of an existing results.csv (none if it does not exist). A last line cut off
/// by an interruption (no trailing newline) is dropped from the file: that run is redone.
pub fn read(path: &Path, axis_names: &[String]) -> Result<Vec<ResultRow>, SweepError> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(source) => {
            return Err(SweepError::Read {
                file: path.to_path_buf(),
                source,
            })
        }
    };
    let complete = match text.rfind('\n') {
        Some(i) => &text[..=i],
        None => "",
    };
    if complete.len() != text.len() {
        std::fs::write(path, complete).map_err(|e| SweepError::io(path, e))?;
    }
    if complete.trim().is_empty() {
        return Ok(Vec::new());
    }
    let expected = header(axis_names);
    let mut reader = csv::ReaderBuilder::new().from_reader(complete.as_bytes());
    let found: Vec<String> = reader
        .headers()
        .map_err(|e| SweepError::io(path, e))?
        .iter()
        .map(String::from)
        .collect();
    if found != expected {
        return Err(SweepError::HeaderMismatch {
            file: path.to_path_buf(),
            expected: expected.join(","),
            found: found.join(","),
        });
    }
    let n_axes = axis_names.len();
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| SweepError::io(path, e))?;
        let line = record.position().map(|p| p.line()).unwrap_or(0);
        let bad = |message: String| SweepError::Row {
            file: path.to_path_buf(),
            line,
            message,
        };
        let get = |i: usize| record.get(i).unwrap_or("");
        let num = |i: usize| -> Result<u64, SweepError> {
            get(i).parse::<u64>().map_err(|_| {
                bad(format!(
                    "column `{}`: not an integer: `{}`",
                    expected[i],
                    get(i)
                ))
            })
        };
        let status_col = 4 + n_axes + METRICS.len();
        let status = Status::parse(get(status_col))
            .ok_or_else(|| bad(format!("unknown status `{}`", get(status_col))))?;
        let metrics = if status == Status::Ok {
            let mut v = Vec::with_capacity(METRICS.len());
            for i in 0..METRICS.len() {
                let col = 4 + n_axes + i;
                // NaN is written as "NaN" and parses back.
                v.push(get(col).parse::<f64>().map_err(|_| {
                    bad(format!(
                        "column `{}`: not a number: `{}`",
                        expected[col],
                        get(col)
                    ))
                })?);
            }
            Some(PointMetrics::from_values(&v))
        } else {
            None
        };
        rows.push(ResultRow {
            point: num(0)? as usize,
            key: get(1).to_string(),
            labels: (0..n_axes).map(|a| get(2 + a).to_string()).collect(),
            seed_index: num(2 + n_axes)? as usize,
            seed: num(3 + n_axes)?,
            metrics,
            status,
            error: get(status_col + 1).to_string(),
        });
    }
    Ok(rows)
}

/// Appends rows to results.csv, one flushed line per row, so an interruption loses at most the
/// line being written.
pub struct Appender {
    path: PathBuf,
    file: File,
}

impl Appender {
    /// Opens `path` for appending, writing the header first when the file is new or empty.
    pub fn open(path: &Path, axis_names: &[String]) -> Result<Self, SweepError> {
        let mut file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(|e| SweepError::io(path, format!("cannot open for appending: {e}")))?;
        let empty = file.metadata().map(|m| m.len() == 0).unwrap_or(true);
        if empty {
            let line = to_line(&header(axis_names)).map_err(|e| SweepError::io(path, e))?;
            file.write_all(&line).map_err(|e| SweepError::io(path, e))?;
        }
        Ok(Self {
            path: path.to_path_buf(),
            file,
        })
    }

    /// Writes one row as a single `write` of a complete line.
    pub fn append(&mut self, row: &ResultRow) -> Result<(), SweepError> {
        let line = to_line(&cells(row)).map_err(|e| SweepError::io(&self.path, e))?;
        self.file
            .write_all(&line)
            .and_then(|_| self.file.flush())
            .map_err(|e| SweepError::io(&self.path, e))
    }
}

fn to_line(cells: &[String]) -> Result<Vec<u8>, csv::Error> {
    let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
    w.write_record(cells)?;
    w.into_inner()
        .map_err(|e| csv::Error::from(std::io::Error::other(e.to_string())))
}
