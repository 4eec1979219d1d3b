//! The counts `cargo xtask test` ends with: tests passed and failed (summed over libtest's
//! `test result:` lines), and every test that did not run — libtest's ignored tests and the
//! checks xtask itself skips (the real-Slurm test, the path-traced case) — each named with why.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Instant;

/// Counts over every `cargo test` run of one `cargo xtask test`.
#[derive(Debug, Default, PartialEq)]
pub struct Tally {
    pub passed: u64,
    pub failed: u64,
    /// Tests libtest ignored (`#[ignore]`): not run, so counted as skipped.
    pub ignored: u64,
    /// Checks that did not run, each with the reason.
    pub skipped: Vec<String>,
}

impl Tally {
    /// Adds one libtest summary line (`test result: ok. 5 passed; 0 failed; 1 ignored; …`);
    /// other lines are left alone. Returns whether the line was one.
    pub fn add_line(&mut self, line: &str) -> bool {
        let Some(rest) = line.trim().strip_prefix("test result: ") else {
            return false;
        };
        for part in rest.split([';', '.']) {
            let mut words = part.split_whitespace();
            let (Some(n), Some(what)) = (words.next(), words.next()) else {
                continue;
            };
            let Ok(n) = n.parse::<u64>() else { continue };
            match what {
                "passed" => self.passed += n,
                "failed" => self.failed += n,
                "ignored" => self.ignored += n,
                _ => {}
            }
        }
        true
    }

    /// Adds cargo-nextest's closing line (`Summary [ 12.3s] 10 tests run: 8 passed (2 slow), 1
    /// failed, 1 timed out, 2 skipped`): skipped tests are the `#[ignore]`d ones and count as
    /// libtest's ignored do; every other outcome but `passed` (failed, timed out, leaky, not run)
    /// counts as a failure. Other lines are left alone. Returns whether the line was one.
    pub fn add_nextest_line(&mut self, line: &str) -> bool {
        let Some(rest) = line.trim().strip_prefix("Summary [") else {
            return false;
        };
        let Some((_, counts)) = rest
            .split_once("tests run: ")
            .or_else(|| rest.split_once("test run: "))
        else {
            return false;
        };
        let mut found = Tally::default();
        for part in counts.split(", ") {
            // "8 passed (2 slow)": the parenthesis qualifies the count.
            let part = part.split_once(" (").map_or(part, |(count, _)| count);
            let Some((n, what)) = part.trim().split_once(' ') else {
                return false;
            };
            let Ok(n) = n.parse::<u64>() else {
                return false;
            };
            match what {
                "passed" => found.passed += n,
                "skipped" => found.ignored += n,
                _ => found.failed += n,
            }
        }
        self.passed += found.passed;
        self.failed += found.failed;
        self.ignored += found.ignored;
        true
    }

    /// Adds pytest's closing line (`3 passed, 1 failed, 2 skipped in 4.21s`, with or without
    /// the `=` rule around it): errors count as failures, skipped tests as skipped. Other lines
    /// are left alone. Returns whether the line was one.
    pub fn add_pytest_line(&mut self, line: &str) -> bool {
        let line = line.trim().trim_matches('=').trim();
        let Some((counts, time)) = line.rsplit_once(" in ") else {
            return false;
        };
        // Past a minute pytest adds the clock time: `in 72.97s (0:01:12)`.
        let time = time.split_once(" (").map_or(time, |(seconds, _)| seconds);
        if !time.ends_with('s') {
            return false;
        }
        let mut found = (0, 0, 0);
        for part in counts.split(", ") {
            let Some((n, what)) = part.split_once(' ') else {
                return false;
            };
            let Ok(n) = n.parse::<u64>() else {
                return false;
            };
            match what {
                "passed" => found.0 += n,
                "failed" | "error" | "errors" => found.1 += n,
                "skipped" => found.2 += n,
                "warning" | "warnings" | "deselected" | "xfailed" | "xpassed" => {}
                _ => return false,
            }
        }
        self.passed += found.0;
        self.failed += found.1;
        if found.2 > 0 {
            self.skip(
                &format!("{} Python tests", found.2),
                "pytest skipped them (named above)",
            );
        }
        true
    }

    /// A check that did not run, printed as it happens and counted.
    pub fn skip(&mut self, what: &str, why: &str) {
        eprintln!("xtask: SKIPPED {what}: {why}");
        self.skipped.push(format!("{what} ({why})"));
    }

    /// The last line: counts, the skipped checks, the wall time.
    pub fn summary(&self, started: Instant) -> String {
        let s = started.elapsed().as_secs();
        let mut line = format!(
            "xtask test: {} passed, {} failed, {} skipped in {} min {:02} s",
            self.passed,
            self.failed,
            self.ignored + self.skipped.len() as u64,
            s / 60,
            s % 60
        );
        if self.ignored > 0 {
            line.push_str(&format!(
                "\n  {} ignored by libtest (#[ignore], named above)",
                self.ignored
            ));
        }
        for s in &self.skipped {
            line.push_str(&format!("\n  skipped: {s}"));
        }
        line
    }
}

/// Runs a `cargo test` command, passing its output through as it comes and adding its summary
/// lines to `tally`.
pub fn run_counted(command: Command, tally: &mut Tally) -> Result<(), String> {
    run_counted_with(command, tally, Stream::Stdout, Tally::add_line)
}

/// The output stream a command prints its summary on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stream {
    /// libtest and pytest.
    Stdout,
    /// cargo-nextest's reporter.
    Stderr,
}

/// Runs a command, passing its `stream` through as it comes (the other is inherited) and adding
/// the lines that `count` recognises to `tally`.
pub fn run_counted_with(
    mut command: Command,
    tally: &mut Tally,
    stream: Stream,
    count: fn(&mut Tally, &str) -> bool,
) -> Result<(), String> {
    eprintln!("xtask: running {command:?}");
    match stream {
        Stream::Stdout => command.stdout(Stdio::piped()),
        Stream::Stderr => command.stderr(Stdio::piped()),
    };
    let started = std::time::Instant::now();
    let mut child = command
        .spawn()
        .map_err(|e| format!("could not start {command:?}: {e}"))?;
    let output: Option<Box<dyn std::io::Read>> = match stream {
        Stream::Stdout => child.stdout.take().map(|o| Box::new(o) as _),
        Stream::Stderr => child.stderr.take().map(|o| Box::new(o) as _),
    };
    if let Some(output) = output {
        for line in BufReader::new(output).lines() {
            let line = line.map_err(|e| format!("reading {command:?}'s output: {e}"))?;
            match stream {
                Stream::Stdout => println!("{line}"),
                Stream::Stderr => eprintln!("{line}"),
            }
            count(tally, &line);
        }
    }
    let status = child
        .wait()
        .map_err(|e| format!("waiting for {command:?}: {e}"))?;
    crate::took(&command, started);
    crate::succeeded(&command, status)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn libtest_summary_lines_are_summed_and_others_left_alone() {
        let mut t = Tally::default();
        assert!(t.add_line(
            "test result: ok. 12 passed; 0 failed; 1 ignored; 0 measured; 3 filtered out; finished in 0.52s"
        ));
        assert!(t.add_line(
            "test result: FAILED. 4 passed; 2 failed; 0 ignored; 0 measured; 0 filtered out; finished in 9.01s"
        ));
        assert!(!t.add_line("test foo::bar ... ok"));
        assert!(!t.add_line("running 12 tests"));
        assert_eq!((t.passed, t.failed, t.ignored), (16, 2, 1));
    }

    #[test]
    fn pytest_closing_lines_are_counted_and_others_left_alone() {
        let mut t = Tally::default();
        assert!(t.add_pytest_line("8 passed in 20.14s"));
        assert!(t.add_pytest_line("9 passed in 72.97s (0:01:12)"));
        assert!(t.add_pytest_line(
            "===== 1 failed, 5 passed, 2 skipped, 3 warnings, 1 error in 1.02s ====="
        ));
        assert!(!t.add_pytest_line("python/tests/test_api.py ....... [100%]"));
        assert!(!t.add_pytest_line("FAILED python/tests/test_api.py::test_x - in 2s"));
        assert!(!t.add_pytest_line("the marker was found in 3 frames"));
        assert_eq!((t.passed, t.failed, t.skipped.len()), (22, 2, 1));
    }

    #[test]
    fn nextest_summary_lines_are_counted_and_others_left_alone() {
        let mut t = Tally::default();
        assert!(t.add_nextest_line(
            "     Summary [   0.170s] 3 tests run: 2 passed, 1 failed, 1 skipped"
        ));
        assert!(t.add_nextest_line(
            "     Summary [ 901.004s] 1431 tests run: 1430 passed (12 slow), 1 timed out, 2 skipped"
        ));
        assert!(t.add_nextest_line("Summary [   1.000s] 1 test run: 1 passed"));
        assert!(!t.add_nextest_line("        PASS [   0.012s] geneva-vision::render frame_hash"));
        assert!(!t.add_nextest_line("    Starting 1431 tests across 40 binaries (2 skipped)"));
        assert_eq!((t.passed, t.failed, t.ignored), (1433, 2, 3));
    }

    #[test]
    fn the_summary_counts_ignored_and_skipped_checks_as_skipped() {
        let mut t = Tally {
            passed: 7,
            failed: 1,
            ignored: 1,
            skipped: Vec::new(),
        };
        t.skip("the Slurm test", "not root");
        let line = t.summary(Instant::now());
        assert!(
            line.starts_with("xtask test: 7 passed, 1 failed, 2 skipped in 0 min 00 s"),
            "{line}"
        );
        assert!(
            line.contains("skipped: the Slurm test (not root)"),
            "{line}"
        );
    }
}
