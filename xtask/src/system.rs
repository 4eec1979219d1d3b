//! System packages the project needs, checked with dpkg and installed with apt-get when root.

use std::process::Command;

/// Debian packages: OpenCV with the contrib ArUco module, clang for the opencv crate's binding
/// generator, pkg-config to find OpenCV, ffmpeg for video in and out.
pub const PACKAGES: &[&str] = &[
    "libopencv-dev",
    "libopencv-contrib-dev",
    "clang",
    "libclang-dev",
    "pkg-config",
    "ffmpeg",
];

/// Debian packages of the path-traced footage (`tools/pbr/`): Blender (Cycles), and Python's
/// OpenCV (its ArUco dictionaries draw the marker) and NumPy (the tool's sensor and codec).
/// Installed by `cargo xtask deps --pbr` and `cargo xtask pbr-suite`, never by `cargo xtask test`.
pub const PBR_PACKAGES: &[&str] = &["blender", "python3-opencv", "python3-numpy"];

/// Whether a program answers `--version` (it is installed and on PATH).
pub fn has_program(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

fn is_installed(package: &str) -> bool {
    Command::new("dpkg-query")
        .args(["-W", "-f=${Status}", package])
        .output()
        .map(|out| {
            out.status.success()
                && String::from_utf8_lossy(&out.stdout).contains("install ok installed")
        })
        .unwrap_or(false)
}

pub fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .map(|out| String::from_utf8_lossy(&out.stdout).trim() == "0")
        .unwrap_or(false)
}

pub fn has_dpkg() -> bool {
    Command::new("dpkg-query")
        .arg("--version")
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// Installs the missing project packages (as root) or explains which ones to install.
pub fn ensure_packages() -> Result<(), String> {
    ensure(PACKAGES)
}

/// Installs the missing `packages` (as root) or explains which ones to install.
pub fn ensure(packages: &[&str]) -> Result<(), String> {
    if !has_dpkg() {
        // Not Debian/Ubuntu: we cannot check by package; trust the build to say what is missing.
        eprintln!(
            "xtask: no dpkg here; make sure these (Debian names) or their equivalents are installed: {}",
            packages.join(" ")
        );
        return Ok(());
    }
    let missing: Vec<&str> = packages
        .iter()
        .copied()
        .filter(|p| !is_installed(p))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    if !is_root() {
        return Err(format!(
            "missing system packages: {list}\ninstall them with:\n  sudo apt-get update && sudo apt-get install -y {list}",
            list = missing.join(" ")
        ));
    }
    eprintln!(
        "xtask: installing missing system packages: {}",
        missing.join(" ")
    );
    let update = Command::new("apt-get")
        .args(["update", "-qq"])
        .env("DEBIAN_FRONTEND", "noninteractive")
        .status()
        .map_err(|e| format!("could not run apt-get update: {e}"))?;
    if !update.success() {
        return Err(format!(
            "apt-get update failed ({update}); packages needed: {}",
            missing.join(" ")
        ));
    }
    let install = Command::new("apt-get")
        .args(["install", "-y", "-qq", "--no-install-recommends"])
        .args(&missing)
        .env("DEBIAN_FRONTEND", "noninteractive")
        .status()
        .map_err(|e| format!("could not run apt-get install: {e}"))?;
    if !install.success() {
        return Err(format!(
            "apt-get install failed ({install}); packages needed: {}",
            missing.join(" ")
        ));
    }
    let still: Vec<&str> = packages
        .iter()
        .copied()
        .filter(|p| !is_installed(p))
        .collect();
    if still.is_empty() {
        Ok(())
    } else {
        Err(format!("still missing after apt-get: {}", still.join(" ")))
    }
}
