//! Build-time OpenCV version detection: OpenCV 4.7 moved ArUco detection from the contrib
//! `aruco` module to `objdetect::ArucoDetector`; `src/detect/opencv_aruco.rs` picks the API by
//! the `opencv_aruco_objdetect` cfg emitted here.

use std::process::Command;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(opencv_aruco_objdetect)");
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=PKG_CONFIG_PATH");
    if std::env::var_os("CARGO_FEATURE_OPENCV_DETECTOR").is_none() {
        return;
    }
    let version = Command::new("pkg-config")
        .args(["--modversion", "opencv4"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    // Unknown version: assume the 4.6 API this crate is tested against (the opencv crate's own
    // build script reports a missing OpenCV more clearly than we could).
    let Some(version) = version else { return };
    let mut parts = version.split('.').map(|p| p.parse::<u32>().unwrap_or(0));
    let (major, minor) = (parts.next().unwrap_or(0), parts.next().unwrap_or(0));
    if (major, minor) >= (4, 7) {
        println!("cargo::rustc-cfg=opencv_aruco_objdetect");
    }
}
