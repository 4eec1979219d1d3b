//! Fuzzing of every parser of user input, on stable Rust, deterministic from a seed: input k of a
//! target is a pure function of `rng::stream(seed, Fuzz, (target, k))` — an arbitrary byte string
//! or a structure-aware mutation of a real file ([`inputs`]). Each input must be parsed or refused
//! without a panic (caught), within a time bound (a watchdog aborts on a hang, naming the input),
//! within an allocation bound (when the caller's binary measures allocations), and a refusal must
//! be a typed error with a non-empty message, naming the file where the parser knows it, whose
//! `source()` chain never repeats text (`{:#}` of anyhow prints each cause once).
//!
//! `tests/fuzz.rs` runs a few thousand inputs per parser in CI; `cargo xtask fuzz` runs a million.

pub mod inputs;
pub mod targets;

use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rand::Rng;
use rayon::prelude::*;

use crate::errors::{chain, repeated_segment};
use crate::rng::{stream, Stream};
pub use targets::{corpus, parse, Rejection, Target};

/// Peak bytes allocated by the calling thread, measured by the binary's global allocator
/// (`reset` starts a new measurement, `peak_bytes` reads it).
#[derive(Clone, Copy)]
pub struct AllocMeter {
    pub reset: fn(),
    pub peak_bytes: fn() -> usize,
}

/// Limits an input must stay within.
#[derive(Clone, Copy, Debug)]
pub struct Bounds {
    /// Hang guard, not a speed check: an input still running after this aborts the process,
    /// printing the target and index. Speed is a figure of the campaign's report (the slowest
    /// input per parser), not a failure.
    pub hang: Duration,
    /// Peak bytes one input may allocate beyond what was live before it.
    pub alloc_bytes: usize,
}

impl Default for Bounds {
    fn default() -> Self {
        Self {
            hang: Duration::from_secs(60),
            alloc_bytes: 256 << 20,
        }
    }
}

/// What went wrong with one input.
#[derive(Debug, Clone, PartialEq)]
pub enum Fault {
    Panic(String),
    Alloc(usize),
    EmptyMessage,
    /// The error does not name the file (for parsers that know it).
    Unnamed(String),
    /// One cause's text appears inside another's: printed twice by `{:#}`.
    Repeated(String),
}

/// A failing input, reproducible from (seed, target, index).
#[derive(Debug, Clone)]
pub struct Failure {
    pub index: u64,
    pub fault: Fault,
    pub input: Vec<u8>,
}

/// The outcome of a campaign on one target.
#[derive(Debug, Clone)]
pub struct Report {
    pub target: Target,
    pub inputs: u64,
    pub accepted: u64,
    pub rejected: u64,
    pub failures: Vec<Failure>,
    /// Failures beyond the first few kept in `failures`.
    pub failures_total: u64,
    pub wall: Duration,
    pub slowest: Duration,
    /// Largest per-input allocation peak, bytes (0 without an [`AllocMeter`]), and its input.
    pub peak_alloc_bytes: usize,
    pub peak_alloc_index: u64,
    /// The slowest input.
    pub slowest_index: u64,
}

/// Input `index` of `target` under `seed`: a quarter arbitrary bytes, the rest mutations of a
/// seed file (spliced with another).
pub fn input(seed: u64, target: Target, index: u64, corpus: &[Vec<u8>]) -> Vec<u8> {
    let target_id = Target::ALL.iter().position(|&t| t == target).unwrap_or(0) as u64;
    let mut rng = stream(seed, Stream::Fuzz, (target_id << 48) ^ index);
    if corpus.is_empty() || rng.gen_bool(0.25) {
        return inputs::arbitrary(&mut rng);
    }
    let a = &corpus[rng.gen_range(0..corpus.len())];
    let b = &corpus[rng.gen_range(0..corpus.len())];
    inputs::mutate(&mut rng, a, b)
}

/// Checks one refusal: non-empty, naming the file where the parser knows it, no repeated text.
pub fn check_rejection(target: Target, error: &Rejection, path: &Path) -> Option<Fault> {
    let segments = chain(error.as_ref());
    if segments[0].trim().is_empty() {
        return Some(Fault::EmptyMessage);
    }
    let whole = segments.join(": ");
    if target.names_file() && !whole.contains(&path.display().to_string()) {
        return Some(Fault::Unnamed(whole));
    }
    repeated_segment(&segments).map(|_| Fault::Repeated(whole))
}

/// Parses one input under the bounds; `Ok(accepted)` or the fault.
pub fn check_one(
    target: Target,
    bytes: &[u8],
    path: &Path,
    bounds: &Bounds,
    meter: Option<AllocMeter>,
) -> (Result<bool, Fault>, Duration, usize) {
    if let Some(m) = meter {
        (m.reset)();
    }
    let start = Instant::now();
    let outcome = catch_unwind(AssertUnwindSafe(|| parse(target, bytes, path)));
    let took = start.elapsed();
    let peak = meter.map_or(0, |m| (m.peak_bytes)());
    let verdict = match outcome {
        Err(payload) => Err(Fault::Panic(panic_text(payload.as_ref()))),
        Ok(_) if peak > bounds.alloc_bytes => Err(Fault::Alloc(peak)),
        Ok(Ok(())) => Ok(true),
        Ok(Err(e)) => match check_rejection(target, &e, path) {
            Some(fault) => Err(fault),
            None => Ok(false),
        },
    };
    (verdict, took, peak)
}

fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "non-text panic payload".into())
}

/// Failures kept with their inputs per report.
const KEPT_FAILURES: usize = 8;

/// Runs inputs `0..count` of `target` (in parallel; the outcome does not depend on the thread
/// count). A watchdog aborts the process if one input runs longer than `bounds.hang`.
pub fn campaign(
    target: Target,
    repo: &Path,
    seed: u64,
    count: u64,
    bounds: Bounds,
    meter: Option<AllocMeter>,
) -> std::io::Result<Report> {
    let corpus = corpus(target, repo)?;
    let path = target.pseudo_path(repo);
    let in_flight: Arc<Mutex<BTreeMap<usize, (u64, Instant)>>> = Arc::default();
    let done = Arc::new(AtomicBool::new(false));
    let watchdog = {
        let (in_flight, done) = (in_flight.clone(), done.clone());
        std::thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(200));
                let stuck = in_flight
                    .lock()
                    .ok()
                    .and_then(|m| m.values().find(|(_, t)| t.elapsed() > bounds.hang).copied());
                if let Some((index, _)) = stuck {
                    eprintln!(
                        "fuzz: {} input {index} (seed {seed}) has run for more than {:?}: a hang",
                        target.name(),
                        bounds.hang
                    );
                    std::process::abort();
                }
            }
        })
    };
    let start = Instant::now();
    let results: Vec<(u64, Result<bool, Fault>, Duration, usize)> = (0..count)
        .into_par_iter()
        .map(|index| {
            let bytes = input(seed, target, index, &corpus);
            let slot = rayon::current_thread_index().unwrap_or(usize::MAX);
            if let Ok(mut m) = in_flight.lock() {
                m.insert(slot, (index, Instant::now()));
            }
            let (verdict, took, peak) = check_one(target, &bytes, &path, &bounds, meter);
            if let Ok(mut m) = in_flight.lock() {
                m.remove(&slot);
            }
            (index, verdict, took, peak)
        })
        .collect();
    let wall = start.elapsed();
    done.store(true, Ordering::Relaxed);
    let _ = watchdog.join();
    let mut report = Report {
        target,
        inputs: count,
        accepted: 0,
        rejected: 0,
        failures: Vec::new(),
        failures_total: 0,
        wall,
        slowest: Duration::ZERO,
        peak_alloc_bytes: 0,
        peak_alloc_index: 0,
        slowest_index: 0,
    };
    for (index, verdict, took, peak) in results {
        if took > report.slowest {
            (report.slowest, report.slowest_index) = (took, index);
        }
        if peak > report.peak_alloc_bytes {
            (report.peak_alloc_bytes, report.peak_alloc_index) = (peak, index);
        }
        match verdict {
            Ok(true) => report.accepted += 1,
            Ok(false) => report.rejected += 1,
            Err(fault) => {
                report.failures_total += 1;
                if report.failures.len() < KEPT_FAILURES {
                    report.failures.push(Failure {
                        index,
                        fault,
                        input: input(seed, target, index, &corpus),
                    });
                }
            }
        }
    }
    Ok(report)
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:<17} {:>9} inputs  {:>8.1} s  {:>9.0} inputs/s  accepted {:>8}  refused {:>9}  failures {:>3}  slowest {:>7.1} ms (#{})  peak alloc {:>7.2} MiB (#{})",
            self.target.name(),
            self.inputs,
            self.wall.as_secs_f64(),
            self.inputs as f64 / self.wall.as_secs_f64().max(1e-9),
            self.accepted,
            self.rejected,
            self.failures_total,
            self.slowest.as_secs_f64() * 1e3,
            self.slowest_index,
            self.peak_alloc_bytes as f64 / (1 << 20) as f64,
            self.peak_alloc_index,
        )
    }
}
