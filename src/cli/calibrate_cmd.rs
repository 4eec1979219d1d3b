//! `geneva calibrate (--video F | --frames DIR --timestamps F | --image F) --base SCENARIO --out DIR
//! [--single-frame]`.

use anyhow::Result;
use clap::Args;
use geneva_vision::calibrate::CalibrateOptions;
use geneva_vision::io::output_dir::Input;
use geneva_vision::pipeline::calibrate::{calibrate, Footage};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct CalibrateArgs {
    #[command(flatten)]
    footage: super::source_args::FootageArgs,
    /// One still image: image formation only (implies --single-frame).
    #[arg(long, conflicts_with_all = ["video", "frames"])]
    image: Option<PathBuf>,
    /// What you know about the rig: a scenario (file or built-in name) that states at least the
    /// marker's side `scene.marker.size_mm`, and the mechanism, marker dictionary and id.
    #[arg(long)]
    base: String,
    /// Calibrate the image formation and the marker's pose from the first frame only (no motion).
    #[arg(long)]
    single_frame: bool,
    #[arg(long, default_value = "out/calibrate")]
    out: PathBuf,
}

pub fn run(a: CalibrateArgs) -> Result<()> {
    let footage = a.footage.one_of(
        a.image.clone().map(Footage::Image),
        "--image",
        Footage::Video,
        |dir, timestamps| Footage::Frames { dir, timestamps },
    )?;
    let mut inputs = a.footage.inputs();
    inputs.extend(a.image.as_ref().map(|i| Input::new("--image", i)));
    inputs.extend(super::scenario_inputs("--base", &a.base));
    super::refuse_inputs_inside(&a.out, &inputs)?;
    let bar = super::run_cmd::progress_bar(0, "measure");
    let options = CalibrateOptions {
        single_frame: a.single_frame,
    };
    let out = calibrate(&footage, &a.base, &a.out, &options, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    let c = &out.calibration;
    let g = &c.geometry;
    println!(
        "{} frames, marker in {}; image scale {} mm/px, marker side {} px",
        c.frames, c.detected_frames, g.mm_per_px, g.side_px
    );
    if let Some([x, y]) = g.centre_px {
        println!(
            "rotation centre ({x}, {y}) px, marker radius {} mm",
            g.radius_mm
        );
    }
    if let Some(m) = &c.motion {
        println!(
            "crank speed {} rad/s, crank angle at the first frame {} rad",
            m.omega1_rad_s, m.theta1_start_rad
        );
    }
    let im = &c.imaging;
    let noise = match &im.noise.footage_not_identifiable {
        None => format!(
            "noise {} / {} DN",
            im.noise.ink_sigma_dn, im.noise.paper_sigma_dn
        ),
        Some(_) => format!(
            "noise not identifiable (the base's {:.2} / {:.2} DN written; calibration.md says why)",
            im.noise.ink_sigma_dn.value, im.noise.paper_sigma_dn.value
        ),
    };
    println!(
        "levels ink {} / paper {} DN, {noise}, blur σ {}",
        im.ink_dn,
        im.paper_dn,
        im.blur_sigma_px
            .map_or("not measured".into(), |b| format!("{b} px"))
    );
    if let Some(k) = &out.check {
        println!(
            "re-render check {}: residual {:.3} DN vs noise {:.3} DN (ratio {:.3}); smoothed at 2 px \
             it keeps {:.2} of its sd (white noise 0.14)",
            if k.passed() { "passed" } else { "FAILED" },
            k.residual_rms_dn,
            k.expected_noise_dn,
            k.ratio(),
            k.structure.footage.smoothed_retention
        );
    }
    for n in &c.notes {
        if n.starts_with("warning:") {
            eprintln!("{n}");
        } else {
            println!("note: {n}");
        }
    }
    for f in &out.files {
        println!("wrote {}", f.display());
    }
    Ok(())
}
