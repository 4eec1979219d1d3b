//! The Python module's tests: a virtual environment under the target folder with maturin,
//! NumPy, pytest and Matplotlib from PyPI, the module built into it from `python/` by
//! `pip install ./python` (what a user runs), then pytest on `python/tests/` (the
//! notebook-style example among them).

use std::path::{Path, PathBuf};
use std::process::Command;

/// What the tests import beside the module, and the build backend.
const REQUIREMENTS: [&str; 4] = [
    "maturin>=1.5,<2",
    "numpy>=1.21",
    "pytest>=7",
    "matplotlib>=3.5",
];

/// The interpreter the environment is made from: `GENEVA_PYTHON`, else `python3`.
fn base_python() -> String {
    std::env::var("GENEVA_PYTHON").unwrap_or_else(|_| "python3".into())
}

fn target_dir() -> PathBuf {
    PathBuf::from(std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".into()))
}

/// The environment's folder, made (and its requirements installed) when missing.
pub fn environment() -> Result<PathBuf, String> {
    let venv = std::path::absolute(target_dir().join("python-venv"))
        .map_err(|e| format!("target/python-venv: {e}"))?;
    let python = venv.join("bin").join("python");
    if !python.is_file() {
        let mut make = Command::new(base_python());
        make.args(["-m", "venv"]).arg(&venv);
        crate::run(make).map_err(|e| {
            format!("{e}: a Python 3.9+ with venv is needed (Debian: apt-get install python3-venv)")
        })?;
    }
    let mut have = Command::new(&python);
    have.args(["-c", "import maturin, numpy, pytest, matplotlib"]);
    let present = have
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !present {
        let mut install = Command::new(&python);
        install.args(["-m", "pip", "install", "--quiet"]);
        install.args(REQUIREMENTS);
        crate::run(install)?;
    }
    Ok(venv)
}

/// Builds the module into the environment and runs pytest, counting its results.
pub fn test(tally: &mut crate::tally::Tally) -> Result<(), String> {
    let venv = environment()?;
    let python = venv.join("bin").join("python");
    let path = std::env::var_os("PATH").unwrap_or_default();
    let mut paths = vec![venv.join("bin")];
    paths.extend(std::env::split_paths(&path));
    let path = std::env::join_paths(paths).map_err(|e| format!("PATH: {e}"))?;
    let mut install = Command::new(&python);
    install.args([
        "-m",
        "pip",
        "install",
        "--quiet",
        "--no-build-isolation",
        "./python",
    ]);
    // The dev profile shares the dependencies `cargo test` has just built (the OpenCV
    // bindings above all); a user's `pip install ./python` builds the release profile.
    install.env("MATURIN_PEP517_ARGS", "--profile dev");
    install.env("VIRTUAL_ENV", &venv).env("PATH", &path);
    crate::run(install)?;
    let mut pytest = Command::new(&python);
    pytest.args([
        "-m",
        "pytest",
        "-q",
        "-p",
        "no:cacheprovider",
        "python/tests",
    ]);
    pytest.env("PATH", &path);
    // The tests import the installed module, never the source folder's (which lacks the
    // extension): the working directory is the workspace root.
    pytest.current_dir(Path::new("."));
    crate::tally::run_counted_with(
        pytest,
        tally,
        crate::tally::Stream::Stdout,
        crate::tally::Tally::add_pytest_line,
    )
}
