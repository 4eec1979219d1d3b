//! Streaming reads and the fit of long logs (guarding against `timing fit` failing on any log of
//! 3,500 frames or more, reading a 200 MB log whole and accepting a log cut mid-number).

use std::io::Read;

use super::tests_fit::{check_recovery_over, phone_like};
use super::*;

const SI: &str = "[Parsed_showinfo_0 @ 0000023884038e40]";

fn showinfo_line(n: u64, t: f64) -> String {
    format!(
        "{SI} n:{n:>4} pts:{:>7} pts_time:{t} pos: 1 fmt:yuv420p sar:1/1 s:2160x3840 i:P \
         iskey:0 type:P checksum:947DD192 mean:[108 118 144 ] stdev:[54.8 12.4 19.7 ]\n",
        (t * 90000.0).round() as i64
    )
}

/// A showinfo log generated line by line as it is read, never held whole: frames at 30 fps
/// with a pair alternation of ±0.1 ms and every 50th frame dropped.
struct GeneratedLog {
    frames: u64,
    next: u64,
    pending: Vec<u8>,
    at: usize,
}

impl GeneratedLog {
    fn new(frames: u64) -> Self {
        GeneratedLog {
            frames,
            next: 0,
            pending: b"ffmpeg version 6.0\n".to_vec(),
            at: 0,
        }
    }

    /// Slot of frame `n` (every 50th slot is skipped) and its time.
    fn time_s(n: u64) -> f64 {
        let slot = n + n / 49;
        let alternation = if slot % 2 == 0 { 5e-5 } else { -5e-5 };
        slot as f64 / 30.0 + if n == 0 { 0.0 } else { alternation }
    }
}

impl Read for GeneratedLog {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.at == self.pending.len() {
            if self.next == self.frames {
                return Ok(0);
            }
            self.pending = showinfo_line(self.next, Self::time_s(self.next)).into_bytes();
            self.at = 0;
            self.next += 1;
        }
        let n = buf.len().min(self.pending.len() - self.at);
        buf[..n].copy_from_slice(&self.pending[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

#[test]
fn a_long_log_streams_through_the_fit_in_constant_memory() {
    // 200,000 frames (about 45 MB of log) generated as they are read: the fit holds only its
    // sums and a 4,096-interval sample, and recovers the generator's rate, alternation and drops.
    let frames = 200_000u64;
    let fit = fit_vfr_passes(|each| {
        let reader = std::io::BufReader::new(GeneratedLog::new(frames));
        stream_frame_times(reader, LogFormat::Showinfo, each).map(|s| {
            assert_eq!(s.frames as u64, frames);
        })
    })
    .unwrap();
    assert_eq!(fit.frames as u64, frames);
    // Frame n sits in slot n + ⌊n/49⌋: one slot skipped after every 49 frames.
    let last = frames - 1;
    assert_eq!(fit.dropped_frames as u64, last / 49);
    assert!((fit.fps - 30.0).abs() < 1e-6, "{}", fit.fps);
    // Printed times have 6 significant digits (≤ 50 µs of rounding beyond 10 s): the fitted
    // alternation is the generator's 0.1 ms within that rounding's averaged error.
    assert!(
        (fit.pair_alternation_s - 1e-4).abs() < 5e-6,
        "{}",
        fit.pair_alternation_s
    );
}

#[test]
fn fits_of_long_schedules_recover_their_parameters() {
    // The old fit's singularity test was not scale-free: it refused every log of about 3,500
    // frames or more. Ten minutes and an hour of a phone-like schedule now fit, within the
    // same statistically derived tolerances as the 20 s logs.
    let v = phone_like();
    for duration_s in [120.0, 600.0, 3600.0] {
        check_recovery_over(30.0, &v, 5, duration_s).unwrap();
    }
}

#[test]
fn the_median_sample_of_a_long_log_is_bounded_and_matches_the_exact_median() {
    // Intervals of 30, 33 and 36 ms in a pattern of period 7 (odd, so every 2^k-th interval
    // keeps the proportions 3 : 1 : 3): the evenly spread sample of a log 10 times longer than
    // MEDIAN_SAMPLE has the exact median, 33 ms, while holding at most MEDIAN_SAMPLE values.
    let pattern = [0.030, 0.036, 0.030, 0.036, 0.030, 0.036, 0.033];
    let all: Vec<f64> = (0..10 * MEDIAN_SAMPLE).map(|k| pattern[k % 7]).collect();
    let mut sample = fit::IntervalSample::default();
    for &d in &all {
        sample.push(d);
        assert!(sample.len() <= MEDIAN_SAMPLE);
    }
    assert_eq!(crate::numeric::robust::median(&all), 0.033);
    assert_eq!(sample.median(), 0.033);
    // Short logs keep every interval: the median is the exact one.
    let mut short = fit::IntervalSample::default();
    for d in [0.5, 0.1, 0.3] {
        short.push(d);
    }
    assert_eq!((short.len(), short.median()), (3, 0.3));
}

#[test]
fn a_log_cut_mid_number_is_an_error_naming_the_line() {
    // Regression: `pts_time:0.29` at the end of a cut log was accepted (jitter then read 1.9 ms).
    let whole: String = (0..6)
        .map(|n| showinfo_line(n, n as f64 * 0.0333))
        .collect();
    let cut = format!("{whole}{SI} n:   6 pts:  17982 pts_time:0.19");
    let err = parse_showinfo(&cut).unwrap_err();
    assert!(matches!(err, TimingError::Parse { line: 7, .. }), "{err:?}");
    assert!(err.to_string().contains("pts_time:0.19"), "{err}");
    // The same line, complete, is accepted.
    assert!(parse_showinfo(&format!("{whole}{}", showinfo_line(6, 0.1998))).is_ok());
    // CSV logs end every line: a last line without its end is a cut.
    let err = parse_ffprobe_csv("0.0\n0.0333\n0.06").unwrap_err();
    assert!(matches!(err, TimingError::Parse { line: 3, .. }), "{err:?}");
    assert!(err.to_string().contains("`0.06`"), "{err}");
    let err = parse_frames_csv("frame,t_s\n0,0.0\n1,0.03").unwrap_err();
    assert!(matches!(err, TimingError::Parse { line: 3, .. }), "{err:?}");
    assert!(parse_frames_csv("frame,t_s\n0,0.0\n1,0.03\n").is_ok());
    // A cut JSON log is a syntax error at its last line.
    let err = parse_ffprobe_json("{\"frames\": [\n{\"pts_time\": \"0.0\"},\n{\"pts_time\": \"0.0")
        .unwrap_err();
    assert!(matches!(err, TimingError::Parse { line: 3, .. }), "{err:?}");
}

#[test]
fn json_frame_errors_name_their_line_and_lines_are_bounded() {
    let text = "{\"frames\": [\n{\"pts_time\": \"0.0\"},\n{\"pts_time\": \"zz\"}\n]}";
    let err = parse_ffprobe_json(text).unwrap_err();
    assert!(
        matches!(err, TimingError::Parse { line: 3, .. }) && err.to_string().contains("frames[1]"),
        "{err:?}"
    );
    let long = format!("0.0\n{}\n", "1".repeat(MAX_LINE_BYTES + 1));
    let err = parse_ffprobe_csv(&long).unwrap_err();
    assert!(matches!(err, TimingError::Parse { line: 2, .. }), "{err:?}");
}

#[test]
fn showinfo_reorders_within_a_window_only() {
    // Frame 0 held back past the window: reported missing rather than buffered without bound.
    let text: String = (1..=REORDER_WINDOW as u64 + 1)
        .map(|n| showinfo_line(n, n as f64 * 0.0333))
        .collect();
    let err = parse_showinfo(&text).unwrap_err();
    assert!(err.to_string().contains("frame 0 is missing"), "{err}");
}

#[test]
fn the_printed_fit_is_a_scenario_section_the_loader_reads_back() {
    // Regression: `timing fit` printed `[model]` where the loader wants `[frame_timing.model]`.
    let text = include_str!("../../data/phone-frame-timing/model_test1.showinfo.log");
    let fit = fit_vfr(&parse_showinfo(text).unwrap()).unwrap();
    let section = fit.scenario_toml();
    assert!(section.contains("[frame_timing.model]"), "{section}");
    let scenario = crate::scenario::from_str(
        &format!("extend = \"fast\"\n{section}"),
        std::path::Path::new("fit.toml"),
    )
    .unwrap_or_else(|e| panic!("{e}\n{section}"));
    assert_eq!(scenario.frame_timing, fit.config);
}
