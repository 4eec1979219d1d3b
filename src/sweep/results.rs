//! results.csv: one tidy row per (point, seed), in (point, seed) order; each row is the record
//! of one work unit (see `shard`), so the file is the same whoever computed the rows. Columns: point, key, one per axis, seed_index, seed, the
//! metrics, status (`ok`, `invalid`, `failed`), error.

use super::error::SweepError;
use super::PointMetrics;
use std::path::Path;

/// Metric column names, in [`PointMetrics::to_cells`] order.
pub const METRICS: [&str; 10] = [
    "theta_rms_rad",
    "omega_rms_rad_s",
    "alpha_rms_rad_s2",
    "omega_p95_rad_s",
    "alpha_p95_rad_s2",
    "frames_total",
    "frames_detected",
    "engaged_alpha_noise_rad_s2",
    "mean_frame_interval_s",
    "kalman_lambda_per_s6",
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
    pub fn values(&self) -> [f64; 10] {
        [
            self.theta_rms_rad,
            self.omega_rms_rad_s,
            self.alpha_rms_rad_s2,
            self.omega_p95_rad_s,
            self.alpha_p95_rad_s2,
            self.frames_total as f64,
            self.frames_detected as f64,
            self.engaged_alpha_noise_rad_s2,
            self.mean_frame_interval_s,
            self.kalman_lambda_per_s6,
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
            engaged_alpha_noise_rad_s2: v[7],
            mean_frame_interval_s: v[8],
            kalman_lambda_per_s6: v[9],
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

/// One row as a results.csv line (no line end): the record of one work unit.
pub fn row_line(row: &ResultRow) -> Result<String, csv::Error> {
    to_line(&cells(row))
}

/// The header line of results.csv (no line end).
pub fn header_line(axis_names: &[String]) -> Result<String, csv::Error> {
    to_line(&header(axis_names))
}

/// Reads the rows of a finished results.csv.
pub fn read(path: &Path, axis_names: &[String]) -> Result<Vec<ResultRow>, SweepError> {
    let text = std::fs::read_to_string(path).map_err(|source| SweepError::Read {
        file: path.to_path_buf(),
        source,
    })?;
    parse(&text, path, axis_names)
}

/// Parses results.csv text that claims to come from `path`, checking its header.
pub fn parse(text: &str, path: &Path, axis_names: &[String]) -> Result<Vec<ResultRow>, SweepError> {
    if text.trim().is_empty() {
        return Ok(Vec::new());
    }
    let expected = header(axis_names);
    let mut reader = csv::ReaderBuilder::new().from_reader(text.as_bytes());
    let found: Vec<String> = reader
        .headers()
        .map_err(SweepError::csv(path))?
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
        let record = record.map_err(SweepError::csv(path))?;
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

fn to_line(cells: &[String]) -> Result<String, csv::Error> {
    let mut w = csv::WriterBuilder::new()
        .terminator(csv::Terminator::Any(b'\n'))
        .from_writer(Vec::new());
    w.write_record(cells)?;
    let bytes = w
        .into_inner()
        .map_err(|e| csv::Error::from(std::io::Error::other(crate::errors::full(&e))))?;
    let mut line = String::from_utf8_lossy(&bytes).into_owned();
    line.pop(); // the terminator
    Ok(line)
}
