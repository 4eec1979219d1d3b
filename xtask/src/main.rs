//! `cargo xtask`: the project's set-up and maintenance tasks.
//!
//! - `cargo xtask demo`    — install what is missing, then run the main job on the embedded
//!   default scenario (output under `out/demo/`).
//! - `cargo xtask test`    — install what is missing, then `cargo fmt --check`, clippy with
//!   `-D warnings` (default features and `--no-default-features`), the whole test suite (under
//!   cargo-nextest when it is installed, `.config/nextest.toml`; else `cargo test`), the
//!   library's tests without OpenCV and, as root on Debian, the real-Slurm integration test
//!   (`slurm.rs`).
//! - `cargo xtask bench`   — run the benchmarks and print their figures, then again the ones
//!   that state their target (extra arguments go to `cargo bench`: `cargo xtask bench --bench
//!   diagnose` runs one).
//! - `cargo xtask fuzz [--inputs N] [--seed S] [--show target:index]` — every parser of user
//!   input on N generated inputs (default 1,000,000 each; `tests/fuzz.rs`), printing count, wall
//!   time and peak allocation per parser; `--show` prints one input of the campaign instead.
//! - `cargo xtask statistics` — the statistical tests CI runs reduced, whole: the false alarms
//!   of `tests/diagnose_own_render.rs` on 20 nominals and the interval coverage of
//!   `tests/diagnose_coverage.rs` on 40 footages, each with its binomial bound.
//! - `cargo xtask reports` — regenerate the reports `geneva reports` makes, deterministically.
//! - `cargo xtask diagnosis [NAME…|all]` — the diagnosis self-check suites committed under
//!   `reports/`, each by name (the table [`SUITES`]; no name lists them with their commands).
//! - `cargo xtask deps [--pbr]` — only check/install the system packages (with `--pbr`, also
//!   those of the path-traced footage: Blender, Python's OpenCV and NumPy).
//! - `cargo xtask pbr-suite [--quick] [--cases a,b] [ARGS…]` — path-traced footage (`tools/pbr/`)
//!   through `geneva calibrate` → `geneva diagnose`, scored into `reports/diagnosis-pbr/`
//!   (resumable; ARGS go to `tools/pbr/pbr.py suite`).
//!
//! Architecture invariant: xtask has no dependencies and builds without OpenCV, so it can run on
//! a machine where nothing but Rust is installed and set that machine up.

use std::process::{exit, Command};

mod python;
mod slurm;
mod system;
mod tally;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let task = args.first().map(String::as_str).unwrap_or("help");
    let rest = &args[args.len().min(1)..];
    let result = match task {
        "deps" => system::ensure_packages().and_then(|_| {
            if rest.iter().any(|a| a == "--pbr") {
                system::ensure(system::PBR_PACKAGES)
            } else {
                Ok(())
            }
        }),
        "pbr-suite" => system::ensure_packages()
            .and_then(|_| system::ensure(system::PBR_PACKAGES))
            .and_then(|_| pbr_suite(rest)),
        "demo" => system::ensure_packages().and_then(|_| demo(rest)),
        "test" => system::ensure_packages().and_then(|_| test(rest)),
        "slurm-test" => system::ensure_packages().and_then(|_| {
            match slurm::integration_test(&slurm::geneva_binary()?)? {
                slurm::Outcome::Ran => Ok(()),
                slurm::Outcome::Skipped(why) => {
                    eprintln!("xtask: SKIPPED the real-Slurm integration test: {why}");
                    Ok(())
                }
            }
        }),
        "python-test" => system::ensure_packages().and_then(|_| {
            let started = std::time::Instant::now();
            let mut tally = tally::Tally::default();
            let result = python::test(&mut tally);
            eprintln!("{}", tally.summary(started));
            result
        }),
        "bench" => system::ensure_packages().and_then(|_| bench(rest)),
        "fuzz" => fuzz(rest),
        "statistics" => system::ensure_packages().and_then(|_| statistics()),
        "reports" => system::ensure_packages().and_then(|_| reports(rest)),
        "diagnosis" => system::ensure_packages().and_then(|_| diagnosis(rest)),
        _ => {
            eprintln!(
                "usage: cargo xtask <task>\n\n  demo     run the main job on the embedded default scenario (out/demo/)\n  test     run the whole test suite (and the real-Slurm test as root on Debian)\n  slurm-test  only the real-Slurm integration test\n  python-test  only the Python module's tests (builds it into target/python-venv/)\n  bench    run the benchmarks and print figures\n  fuzz     every parser on --inputs N generated inputs (default 1000000)\n  statistics  the statistical tests whole: 20 own-render nulls, 40 interval-coverage footages\n  reports  regenerate the reports `geneva reports` makes (minutes)\n  diagnosis [NAME…|all]  the named diagnosis self-check suites into reports/ (no name: list them; hours each; resumable, --shard I/N)\n  pbr-suite  path-traced footage (tools/pbr) through calibrate and diagnose into reports/diagnosis-pbr/ (hours; resumable; --quick: three cases)\n  deps     check and install the system packages (--pbr: also Blender and Python's OpenCV for tools/pbr)"
            );
            Ok(())
        }
    };
    if let Err(message) = result {
        eprintln!("xtask {task}: {message}");
        exit(1);
    }
}

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string()))
}

fn run(mut command: Command) -> Result<(), String> {
    eprintln!("xtask: running {command:?}");
    let started = std::time::Instant::now();
    let status = command
        .status()
        .map_err(|e| format!("could not start {command:?}: {e}"))?;
    took(&command, started);
    succeeded(&command, status)
}

/// Says how long a command took, so that a slow `cargo xtask test` shows which step to look at.
fn took(command: &Command, started: std::time::Instant) {
    let s = started.elapsed().as_secs();
    let program = command.get_program().to_string_lossy();
    let args: Vec<_> = command.get_args().map(|a| a.to_string_lossy()).collect();
    eprintln!(
        "xtask: `{program} {}` took {} min {:02} s",
        args.join(" "),
        s / 60,
        s % 60
    );
}

/// Ok for a command that exited with success, else an error naming it and its status.
fn succeeded(command: &Command, status: std::process::ExitStatus) -> Result<(), String> {
    if status.success() {
        Ok(())
    } else {
        Err(format!("{command:?} failed with {status}"))
    }
}

/// `cargo run --release --bin geneva -- SUBCOMMAND --out OUT EXTRA…`
fn geneva(subcommand: &str, out: &str, extra: &[String]) -> Result<(), String> {
    let mut command = cargo();
    command.args([
        "run",
        "--release",
        "--bin",
        "geneva",
        "--",
        subcommand,
        "--out",
        out,
    ]);
    command.args(extra);
    run(command)
}

fn demo(extra: &[String]) -> Result<(), String> {
    geneva("demo", "out/demo", extra)
}

fn test(extra: &[String]) -> Result<(), String> {
    let started = std::time::Instant::now();
    let mut tally = tally::Tally::default();
    let result = test_counted(extra, &mut tally);
    eprintln!("{}", tally.summary(started));
    result?;
    if tally.failed > 0 {
        return Err(format!("{} tests failed", tally.failed));
    }
    Ok(())
}

/// Property tests explore a fixed sequence of cases, so a green run stays green; set
/// PROPTEST_RNG_SEED yourself to explore other cases (failures are saved under
/// proptest-regressions/ and replayed first).
fn fixed_proptest_seed(command: &mut Command) {
    if std::env::var_os("PROPTEST_RNG_SEED").is_none() {
        command.env("PROPTEST_RNG_SEED", "20261123");
    }
}

/// The oldest cargo-nextest that reads `.config/nextest.toml` (its test priorities).
const NEXTEST_MIN: (u64, u64, u64) = (0, 9, 91);

/// Whether a recent enough `cargo nextest` is installed (and not declined with
/// `GENEVA_TEST_RUNNER=cargo`); says why not when it is not.
fn have_nextest() -> bool {
    if std::env::var("GENEVA_TEST_RUNNER").is_ok_and(|r| r == "cargo") {
        return false;
    }
    let version = cargo()
        .args(["nextest", "--version"])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| nextest_version(&String::from_utf8_lossy(&o.stdout)));
    match version {
        Some(v) if v >= NEXTEST_MIN => true,
        Some((a, b, c)) => {
            eprintln!("xtask: cargo-nextest {a}.{b}.{c} is older than 0.9.91");
            false
        }
        None => {
            eprintln!("xtask: cargo-nextest is not installed");
            false
        }
    }
}

/// The version in `cargo nextest --version`'s first line (`cargo-nextest 0.9.143 (…)`).
fn nextest_version(text: &str) -> Option<(u64, u64, u64)> {
    let word = text.lines().next()?.split_whitespace().nth(1)?;
    let mut parts = word.split('.').map(|p| p.parse::<u64>().ok());
    Some((parts.next()??, parts.next()??, parts.next()??))
}

/// The workspace's tests, `extra` passed on as test filters and options. With cargo-nextest
/// installed its runner takes them: it keeps both cores busy across test binaries, where
/// `cargo test` runs the binaries one after another and a binary's last long test leaves a core
/// idle (the suite's wall time on a 2-core machine: README.md). nextest does not run doc tests,
/// so `cargo test --doc` follows it. Without nextest, `cargo test` runs everything.
fn suite(extra: &[String], tally: &mut tally::Tally) -> Result<(), String> {
    if !have_nextest() {
        eprintln!("xtask: running the suite with `cargo test`");
        let mut command = cargo();
        command.args(["test", "--workspace"]);
        fixed_proptest_seed(&mut command);
        command.args(extra);
        return tally::run_counted(command, tally);
    }
    let mut command = cargo();
    command.args(["nextest", "run", "--workspace", "--no-fail-fast"]);
    fixed_proptest_seed(&mut command);
    command.args(extra);
    tally::run_counted_with(
        command,
        tally,
        tally::Stream::Stderr,
        tally::Tally::add_nextest_line,
    )?;
    if extra.is_empty() {
        let mut doc = cargo();
        doc.args(["test", "--workspace", "--doc"]);
        tally::run_counted(doc, tally)?;
    }
    Ok(())
}

/// Makes the Python module's environment and, as root on Debian (unless the Slurm test is
/// opted out of), installs the Slurm packages. A failure is only reported here: the steps that
/// need them set them up again and fail there, naming what is missing.
fn prepare_last_steps() {
    if let Err(e) = python::environment() {
        eprintln!("xtask: the Python environment could not be set up yet: {e}");
    }
    let slurm_wanted = system::is_root()
        && std::path::Path::new("/etc/debian_version").exists()
        && system::has_dpkg()
        && std::env::var_os("GENEVA_SKIP_SLURM_TEST").is_none();
    if slurm_wanted {
        if let Err(e) = system::ensure(slurm::PACKAGES) {
            eprintln!("xtask: the Slurm packages could not be installed yet: {e}");
        }
    }
}

/// Everything `cargo xtask test` runs, counted into `tally`.
fn test_counted(extra: &[String], tally: &mut tally::Tally) -> Result<(), String> {
    // What the last steps download (the Python environment, the Slurm packages) arrives while
    // the lints and the build keep the CPU busy.
    let downloads = std::thread::spawn(prepare_last_steps);
    // Formatting and lints first: they fail in seconds where the tests take minutes.
    let mut fmt = cargo();
    fmt.args(["fmt", "--all", "--check"]);
    run(fmt)?;
    for features in [&[][..], &["--no-default-features"][..]] {
        let mut clippy = cargo();
        clippy.args(["clippy", "--workspace", "--all-targets"]);
        clippy.args(features);
        clippy.args(["--", "-D", "warnings"]);
        run(clippy)?;
    }
    // Library, binaries, integration tests and doc tests; benchmarks run only under `xtask bench`.
    suite(extra, tally)?;
    // The pure core without OpenCV, as Cargo.toml promises (the clippy pass above has built every
    // target without it; the library holds the core's tests).
    let mut core = cargo();
    core.args(["test", "--no-default-features", "--lib"]);
    fixed_proptest_seed(&mut core);
    tally::run_counted(core, tally)?;
    // The Python module, built as a user installs it, under pytest.
    if downloads.join().is_err() {
        return Err("the Python environment's and Slurm packages' set-up panicked".into());
    }
    python::test(tally)?;
    pbr_ci_case(tally)?;
    // The real-Slurm test of `geneva slurm script`: as root on Debian it must run, unless the
    // user opts out (then it counts as skipped); `GENEVA_REQUIRE_SLURM_TEST` (set by CI) makes
    // any skip an error.
    let required = std::env::var_os("GENEVA_REQUIRE_SLURM_TEST").is_some();
    let what = "the real-Slurm integration test (xtask/src/slurm.rs)";
    let skip = if std::env::var_os("GENEVA_SKIP_SLURM_TEST").is_some() {
        Some("GENEVA_SKIP_SLURM_TEST is set".to_string())
    } else {
        // `cargo test` has just built the binary its integration tests run: use that one.
        match slurm::integration_test(&slurm::test_binary()?)? {
            slurm::Outcome::Ran => {
                tally.passed += 1;
                None
            }
            slurm::Outcome::Skipped(why) => Some(why),
        }
    };
    if let Some(why) = skip {
        if required {
            return Err(format!(
                "{what} did not run ({why}) and GENEVA_REQUIRE_SLURM_TEST is set"
            ));
        }
        tally.skip(what, &why);
    }
    Ok(())
}

/// The Python that runs `tools/pbr/`: `PBR_PYTHON`, else Debian's (where `python3-opencv` and
/// `python3-numpy` install), else the first `python3` on PATH.
fn pbr_python() -> String {
    std::env::var("PBR_PYTHON").unwrap_or_else(|_| {
        if std::path::Path::new("/usr/bin/python3").exists() {
            "/usr/bin/python3".into()
        } else {
            "python3".into()
        }
    })
}

/// The path-traced footage's small case (`tests/pbr_footage.rs`, about a minute): run when
/// Blender is installed, SKIPPED with the reason otherwise. CI does not install Blender
/// (`cargo xtask deps --pbr` does).
fn pbr_ci_case(tally: &mut tally::Tally) -> Result<(), String> {
    if !system::has_program("blender") {
        // Counted once, by libtest, as the ignored test it is.
        eprintln!(
            "xtask: SKIPPED the path-traced footage case (tests/pbr_footage.rs): Blender is not \
             installed (`cargo xtask deps --pbr` installs it with Python's OpenCV and NumPy)"
        );
        return Ok(());
    }
    // The ignored test runs now: it is counted by this run, not as skipped.
    tally.ignored = tally.ignored.saturating_sub(1);
    // `--workspace` selects the packages the suite's test build selected, so Cargo unifies the
    // same features and reuses that build instead of compiling the crate again.
    let mut command = cargo();
    command.args([
        "test",
        "--workspace",
        "--test",
        "pbr_footage",
        "--",
        "--ignored",
        "--nocapture",
    ]);
    command.env("PBR_PYTHON", pbr_python());
    tally::run_counted(command, tally)
}

/// `cargo xtask pbr-suite ARGS…`: builds the release binary, then runs the suite of
/// `tools/pbr/suite.py` with it.
fn pbr_suite(extra: &[String]) -> Result<(), String> {
    let mut build = cargo();
    build.args(["build", "--release", "--bin", "geneva"]);
    run(build)?;
    let target = std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".into());
    let binary = std::path::Path::new(&target).join("release").join("geneva");
    let mut command = Command::new(pbr_python());
    command.args(["tools/pbr/pbr.py", "suite", "--geneva"]);
    command.arg(&binary);
    command.args(extra);
    run(command)
}

/// `cargo bench --workspace EXTRA…` (e.g. `--bench diagnose --bench decompose` for two of them),
/// its output passed through as it comes, then the lines that state a target gathered at the end:
/// the figures to compare, with what each is measured against, after pages of progress.
fn bench(extra: &[String]) -> Result<(), String> {
    use std::io::{BufRead, BufReader};
    let mut command = cargo();
    command.args(["bench", "--workspace"]);
    command.args(extra);
    command.stdout(std::process::Stdio::piped());
    eprintln!("xtask: running {command:?}");
    let mut child = command
        .spawn()
        .map_err(|e| format!("could not start {command:?}: {e}"))?;
    let mut figures = Vec::new();
    if let Some(stdout) = child.stdout.take() {
        for line in BufReader::new(stdout).lines() {
            let line = line.map_err(|e| format!("reading the benchmarks' output: {e}"))?;
            println!("{line}");
            if line.contains("target") {
                figures.push(line);
            }
        }
    }
    let status = child
        .wait()
        .map_err(|e| format!("waiting for {command:?}: {e}"))?;
    if !figures.is_empty() {
        println!("\nxtask bench: the figures with a target");
        for f in &figures {
            println!("  {}", f.trim());
        }
    }
    if status.success() {
        Ok(())
    } else {
        Err(format!("{command:?} failed with {status}"))
    }
}

/// The statistical tests whole (CI runs a stated few cases of each, with the bound that follows
/// from the count).
fn statistics() -> Result<(), String> {
    let mut command = cargo();
    command.args([
        "test",
        "--test",
        "diagnose_own_render",
        "--test",
        "diagnose_coverage",
        "--",
        "--nocapture",
    ]);
    command.env("GENEVA_OWN_RENDER_CASES", "20");
    command.env("GENEVA_COVERAGE_CASES", "40");
    run(command)
}

/// The parser fuzzing campaign of `tests/fuzz.rs`, long: `--inputs N` per parser (default one
/// million), `--seed S` for other inputs. The test profile is optimised (opt-level 2), so this
/// reuses `cargo test`'s build.
fn fuzz(extra: &[String]) -> Result<(), String> {
    let mut inputs = "1000000".to_string();
    let mut seed = None;
    let mut show = None;
    let mut args = extra.iter();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--inputs" => inputs = args.next().ok_or("--inputs needs a number")?.clone(),
            "--seed" => seed = Some(args.next().ok_or("--seed needs a number")?.clone()),
            "--show" => show = Some(args.next().ok_or("--show needs target:index")?.clone()),
            other => {
                return Err(format!(
                    "unknown argument `{other}` (--inputs N, --seed S, --show target:index)"
                ))
            }
        }
    }
    inputs
        .parse::<u64>()
        .map_err(|_| format!("--inputs {inputs}: not a count"))?;
    let mut command = cargo();
    command.args(["test", "--test", "fuzz", "--", "--nocapture"]);
    match &show {
        Some(spec) => {
            command.args(["--ignored", "--exact", "show_input"]);
            command.env("GENEVA_FUZZ_SHOW", spec);
        }
        None => {
            command.args([
                "--test-threads",
                "1",
                "every_parser_survives_generated_inputs",
            ]);
        }
    }
    command.env("GENEVA_FUZZ_INPUTS", &inputs);
    if let Some(seed) = seed {
        command.env("GENEVA_FUZZ_SEED", seed);
    }
    run(command)
}

fn reports(extra: &[String]) -> Result<(), String> {
    geneva("reports", "reports", extra)
}

/// The diagnosis self-check suites committed under `reports/`: each suite's name, the folder it
/// writes, what it shows and the `geneva diagnose-selfcheck` plan that makes it. Every suite
/// films 6 s of 1280×720 footage at 30 fps on the built-in `fast` rig; "independent" suites draw
/// the footage with the second renderer (`render::independent`), the others with the project's
/// own, and the nominal is always simulated by the project's renderer. A whole suite takes from
/// about 20 minutes (the near-limit plans) to a few hours (48 null cases) on a 2-core machine.
struct Suite {
    name: &'static str,
    folder: &'static str,
    shows: &'static str,
    plan: Plan,
}

/// A self-check plan: `--levels` (`strong`, `weak` = near the detection limit, `form` = in a form
/// the candidate does not parametrise), withheld single-effect cases per effect and level, null,
/// mains-flicker, excluded-candidate and two-effect cases, and the seeds whose strong single
/// cases alone are run (`--only`; empty: the whole plan).
struct Plan {
    levels: &'static str,
    seeds_per_case: usize,
    nulls: usize,
    flicker: usize,
    excluded: usize,
    pairs: usize,
    novel: usize,
    only_seeds: &'static [usize],
}

/// The withheld effects of the self-check's plan, in its order (`selfcheck::withheld_effects`).
const WITHHELD_EFFECTS: &[&str] = &[
    "drive_speed",
    "backlash",
    "disc_vibration",
    "axis_runout",
    "camera_vibration",
    "frame_timing",
    "timebase",
    "pixel_noise",
    "optical_blur",
    "motion_blur",
    "rolling_shutter",
    "lens_distortion",
    "perspective_tilt",
    "compression",
    "lighting",
];

/// Only single-effect cases: `seeds` per effect at `levels`.
const fn singles(levels: &'static str, seeds: usize) -> Plan {
    Plan {
        levels,
        seeds_per_case: seeds,
        nulls: 0,
        flicker: 0,
        excluded: 0,
        pairs: 0,
        novel: 0,
        only_seeds: &[],
    }
}

/// Every withheld effect at the strong level, 1 seed; 4 null, 1 flicker, 2 excluded-candidate
/// cases.
const STRONG: Plan = Plan {
    nulls: 4,
    flicker: 1,
    excluded: 2,
    ..singles("strong", 1)
};

/// The strong single cases of some seeds of a 3-seed plan.
const fn seeds(only_seeds: &'static [usize]) -> Plan {
    Plan {
        only_seeds,
        ..singles("strong", 3)
    }
}

/// 48 null cases: nothing withheld, each its own seed, nuisance and rendering perturbation.
const NULLS: Plan = Plan {
    nulls: 48,
    ..singles("strong", 0)
};

/// Causes outside the vocabulary: 4 mains-flicker beats and 12 effects excluded from the
/// candidates (`selfcheck::excluded_effects`).
const OUT_OF_VOCABULARY: Plan = Plan {
    flicker: 4,
    excluded: 12,
    ..singles("strong", 0)
};

/// Effects outside the vocabulary drawn onto the footage (`render::novel::KINDS`), each kind
/// once.
const NOVEL: Plan = Plan {
    novel: 8,
    ..singles("strong", 0)
};

/// Two effects withheld at once (`selfcheck::withheld_pairs`), both at the strong level.
const PAIRS: Plan = Plan {
    pairs: 5,
    ..singles("strong", 0)
};

const SUITES: &[Suite] = &[
    Suite {
        name: "strong",
        folder: "reports/diagnosis",
        shows: "every effect withheld at the strong level, null and out-of-vocabulary cases, project's renderer",
        plan: STRONG,
    },
    Suite {
        name: "independent",
        folder: "reports/diagnosis-independent",
        shows: "the same plan on footage drawn by the independent renderer",
        plan: STRONG,
    },
    Suite {
        name: "seed-1",
        folder: "reports/diagnosis-seed-1",
        shows: "every effect at the strong level at a second seed, project's renderer",
        plan: seeds(&[1]),
    },
    Suite {
        name: "independent-seeds-1-2",
        folder: "reports/diagnosis-independent-seeds-1-2",
        shows: "every effect at the strong level at seeds 1 and 2, independent renderer",
        plan: seeds(&[1, 2]),
    },
    Suite {
        name: "near-limit",
        folder: "reports/diagnosis-near-limit",
        shows: "every effect near the detection limit, project's renderer",
        plan: singles("weak", 1),
    },
    Suite {
        name: "near-limit-independent",
        folder: "reports/diagnosis-near-limit-independent",
        shows: "every effect near the detection limit, independent renderer",
        plan: singles("weak", 1),
    },
    Suite {
        name: "forms-independent",
        folder: "reports/diagnosis-forms-independent",
        shows: "effects in forms their candidates do not parametrise, independent renderer",
        plan: singles("form", 1),
    },
    Suite {
        name: "pairs-independent",
        folder: "reports/diagnosis-pairs-independent",
        shows: "two effects withheld at once, independent renderer",
        plan: PAIRS,
    },
    Suite {
        name: "nulls",
        folder: "reports/diagnosis-nulls",
        shows: "48 null cases (the false-alarm rate), project's renderer",
        plan: NULLS,
    },
    Suite {
        name: "nulls-independent",
        folder: "reports/diagnosis-nulls-independent",
        shows: "the same 48 null cases, independent renderer",
        plan: NULLS,
    },
    Suite {
        name: "out-of-vocabulary",
        folder: "reports/diagnosis-out-of-vocabulary",
        shows: "16 causes outside the candidates, project's renderer",
        plan: OUT_OF_VOCABULARY,
    },
    Suite {
        name: "novel",
        folder: "reports/diagnosis-novel",
        shows: "8 kinds of effect no candidate models, drawn onto the project's renderer's footage",
        plan: NOVEL,
    },
    Suite {
        name: "out-of-vocabulary-independent",
        folder: "reports/diagnosis-out-of-vocabulary-independent",
        shows: "the same 16 causes, independent renderer",
        plan: OUT_OF_VOCABULARY,
    },
];

impl Suite {
    /// The `geneva diagnose-selfcheck` arguments after `--out`.
    fn arguments(&self) -> Vec<String> {
        let p = &self.plan;
        let mut args: Vec<String> = [
            ("--levels", p.levels.to_string()),
            ("--seeds-per-case", p.seeds_per_case.to_string()),
            ("--nulls", p.nulls.to_string()),
            ("--flicker", p.flicker.to_string()),
            ("--excluded", p.excluded.to_string()),
            ("--pairs", p.pairs.to_string()),
            ("--novel", p.novel.to_string()),
            ("--duration-s", "6".to_string()),
        ]
        .into_iter()
        .flat_map(|(flag, value)| [flag.to_string(), value])
        .collect();
        if self.name.contains("independent") {
            args.extend(["--renderer".to_string(), "independent".to_string()]);
        }
        if !p.only_seeds.is_empty() {
            let cases: Vec<String> = p
                .only_seeds
                .iter()
                .flat_map(|seed| {
                    WITHHELD_EFFECTS
                        .iter()
                        .map(move |e| format!("withheld-{e}-strong-{seed}"))
                })
                .collect();
            args.push("--only".to_string());
            args.push(cases.join(","));
        }
        args
    }
}

/// `cargo xtask diagnosis [NAME…|all] [-- OPTIONS…]`: the named suites of [`SUITES`] into their
/// folders (options such as `--shard I/N`, `--yes` or `--restart` go to every run); no name
/// lists the suites and their commands.
fn diagnosis(rest: &[String]) -> Result<(), String> {
    let (names, options): (Vec<&String>, Vec<&String>) =
        rest.iter().partition(|a| !a.starts_with("--"));
    let options: Vec<String> = options.into_iter().cloned().collect();
    if names.is_empty() {
        println!("cargo xtask diagnosis NAME… | all  [--shard I/N] [--yes] [--restart]\n");
        for s in SUITES {
            println!("  {:<30} {} → {}/", s.name, s.shows, s.folder);
            println!(
                "  {:<30} geneva diagnose-selfcheck --out {} {}\n",
                "",
                s.folder,
                s.arguments().join(" ")
            );
        }
        return Ok(());
    }
    let chosen: Vec<&Suite> = if names.iter().any(|n| n.as_str() == "all") {
        SUITES.iter().collect()
    } else {
        names
            .iter()
            .map(|n| {
                SUITES.iter().find(|s| s.name == n.as_str()).ok_or_else(|| {
                    format!(
                        "no suite `{n}` (the suites: {}, or all)",
                        SUITES.iter().map(|s| s.name).collect::<Vec<_>>().join(", ")
                    )
                })
            })
            .collect::<Result<_, _>>()?
    };
    for suite in chosen {
        let mut args = suite.arguments();
        args.extend(options.iter().cloned());
        geneva("diagnose-selfcheck", suite.folder, &args)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn nextest_versions_are_read_off_its_version_line() {
        let v = super::nextest_version("cargo-nextest 0.9.143 (60fa45f63 2026-08-04)\nrelease: x");
        assert_eq!(v, Some((0, 9, 143)));
        assert!(v.unwrap() >= super::NEXTEST_MIN);
        assert!(super::nextest_version("cargo-nextest 0.9.90").unwrap() < super::NEXTEST_MIN);
        assert_eq!(
            super::nextest_version("error: no such command: `nextest`"),
            None
        );
        assert_eq!(super::nextest_version(""), None);
    }
}
