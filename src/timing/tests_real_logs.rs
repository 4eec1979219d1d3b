//! Tests on the seed's nine real phone logs (copied into data/phone-frame-timing/).

use std::collections::BTreeSet;

use super::*;

macro_rules! log {
    ($n:literal) => {
        (
            concat!("model_test", $n),
            include_str!(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/data/phone-frame-timing/model_test",
                $n,
                ".showinfo.log"
            )),
        )
    };
}

const LOGS: [(&str, &str); 9] = [
    log!("1"),
    log!("2"),
    log!("3"),
    log!("4"),
    log!("5"),
    log!("6"),
    log!("7"),
    log!("8"),
    log!("9"),
];

/// The `n:` values as a plain substring scan finds them (independent of the parser).
fn n_fields(text: &str) -> Vec<u64> {
    text.match_indices("] n:")
        .map(|(i, _)| {
            let digits: String = text[i + 4..]
                .trim_start()
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            digits.parse().unwrap()
        })
        .collect()
}

#[test]
fn every_real_log_parses_to_its_own_frame_count() {
    for (name, text) in LOGS {
        let ns = n_fields(text);
        let unique: BTreeSet<u64> = ns.iter().copied().collect();
        assert_eq!(unique.len(), ns.len(), "{name}: some n: repeats");
        let max_n = *unique.last().unwrap();
        assert_eq!(
            unique.len() as u64,
            max_n + 1,
            "{name}: n: values not contiguous"
        );
        let ts = parse_showinfo(text).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(ts.len() as u64, max_n + 1, "{name}");
    }
}

#[test]
fn real_logs_contain_whole_second_and_interleaved_frames() {
    // Independently: find the frame whose pts_time is printed "1" and check it was parsed as 1 s.
    let mut whole_seconds = 0;
    let mut interleaved = 0;
    for (name, text) in LOGS {
        let ts = parse_showinfo(text).unwrap();
        // Physical lines: a progress record, a bare `\r`, then the showinfo record.
        for record in text.split('\n') {
            let Some(i) = record.find("] n:") else {
                continue;
            };
            let n = n_fields(&record[i..])[0] as usize;
            if record.starts_with("frame=") {
                interleaved += 1;
            }
            if record.contains("pts_time:1 ") {
                whole_seconds += 1;
                assert_eq!(ts.as_slice()[n], 1.0, "{name} frame {n}");
            }
        }
    }
    // Only model_test9 has a frame exactly at 1 s (the seed's regex parser lost it).
    assert_eq!(whole_seconds, 1);
    assert!(
        interleaved > 100,
        "only {interleaved} interleaved frame lines"
    );
}

fn all_stats() -> Vec<(&'static str, TimingStats)> {
    LOGS.iter()
        .map(|(name, text)| {
            (
                *name,
                TimingStats::of(&parse_showinfo(text).unwrap()).unwrap(),
            )
        })
        .collect()
}

#[test]
fn real_log_statistics_against_the_brief() {
    let stats = all_stats();
    let mut total_intervals = 0.0;
    let mut total_span = 0.0;
    let mut steady_intervals = 0.0;
    let mut steady_span = 0.0;
    for (name, s) in &stats {
        eprintln!("--- {name}\n{s}");
        total_intervals += (s.count - 1) as f64;
        total_span += s.span_s;
        steady_intervals += (s.count - 2) as f64;
        steady_span += s.span_s - s.first_interval_s;
        // Steady rate: the brief's 29.865 fps, within 0.02 fps, in every log.
        assert!(
            (s.steady_fps - 29.865).abs() < 0.02,
            "{name}: steady {} fps",
            s.steady_fps
        );
        // No drops; intervals within ±0.15 ms of 33.48 ms once the first gap is over.
        assert_eq!(s.dropped_frames, 0, "{name}");
        assert!(
            s.min_interval_s > 0.03329 && s.max_interval_s < 0.03362,
            "{name}"
        );
        // The "paired ±0.1 ms" excursions: the largest deviation is 0.1–0.2 ms ...
        let excursion =
            (s.max_interval_s - s.median_interval_s).max(s.median_interval_s - s.min_interval_s);
        assert!(
            excursion > 0.00008 && excursion < 0.0002,
            "{name}: {excursion}"
        );
        // ... but they are sporadic: the mean paired difference is far below 0.1 ms.
        assert!(s.mean_abs_alternation_s < 0.00004, "{name}");
        assert!(s.coherent_alternation_s < 0.00001, "{name}");
    }
    let pooled_fps = total_intervals / total_span;
    let pooled_steady_fps = steady_intervals / steady_span;
    eprintln!("pooled mean {pooled_fps:.4} fps, pooled steady {pooled_steady_fps:.4} fps");
    assert!(
        (pooled_steady_fps - 29.865).abs() < 0.005,
        "{pooled_steady_fps}"
    );
    // First gap: the brief says 36–67 ms. The logs give 33.5–63.4 ms (one log has no gap).
    let firsts: Vec<f64> = stats.iter().map(|(_, s)| s.first_interval_s).collect();
    let lo = firsts.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = firsts.iter().copied().fold(0.0, f64::max);
    eprintln!("first interval {:.4} .. {:.4} ms", lo * 1e3, hi * 1e3);
    assert!(hi > 0.060 && hi < 0.067, "{hi}");
    assert!(lo < 0.036, "{lo}");
    assert_eq!(firsts.iter().filter(|&&f| f > 0.045).count(), 8);
}

#[test]
fn fit_of_real_logs_is_close_to_stats() {
    for (name, text) in LOGS {
        let ts = parse_showinfo(text).unwrap();
        let s = TimingStats::of(&ts).unwrap();
        let fit = fit_vfr(&ts).unwrap();
        eprintln!("--- {name}\n{fit}");
        assert!(
            (fit.fps - s.steady_fps).abs() < 0.01,
            "{name}: {} vs {}",
            fit.fps,
            s.steady_fps
        );
        assert!(
            (fit.first_interval_s - s.first_interval_s).abs() < 1e-4,
            "{name}"
        );
        assert!(fit.jitter_s < 1e-4, "{name}");
        assert_eq!(fit.dropped_frames, 0);
        // The fitted config is valid and schedulable.
        let mut problems = crate::validation::Problems::new();
        fit.config.validate("frame_timing", &mut problems);
        assert!(problems.is_empty(), "{name}: {:?}", problems);
    }
}

#[test]
fn exact_pts_agree_with_printed_pts_time_to_print_precision() {
    for (name, text) in LOGS {
        let printed = parse_showinfo(text).unwrap();
        let exact = parse_showinfo_pts(text).unwrap();
        assert_eq!(printed.len(), exact.len(), "{name}");
        for (k, (p, e)) in printed.as_slice().iter().zip(exact.as_slice()).enumerate() {
            // 6 significant digits: half a unit in the last place.
            let ulp = 10f64.powi(e.abs().max(1e-9).log10().floor() as i32 - 5);
            assert!(
                (p - e).abs() <= 0.5 * ulp + 1e-12,
                "{name} frame {k}: {p} vs {e}"
            );
        }
        let s_exact = TimingStats::of(&exact).unwrap();
        let s_printed = TimingStats::of(&printed).unwrap();
        eprintln!(
            "{name}: interval std exact {:.4} ms, printed {:.4} ms",
            s_exact.interval_std_s * 1e3,
            s_printed.interval_std_s * 1e3
        );
        assert!(
            s_exact.interval_std_s <= s_printed.interval_std_s + 1e-6,
            "{name}"
        );
    }
}
