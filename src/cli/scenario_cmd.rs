//! `geneva scenario check|show|list`.

use anyhow::{Context, Result};
use clap::Subcommand;
use geneva_vision::pipeline::rig::Rig;
use geneva_vision::pipeline::workload::Workload;
use geneva_vision::scenario;

#[derive(Subcommand, Debug)]
pub enum ScenarioCmd {
    /// Validate a scenario file (or built-in name): every problem with its field, the
    /// combinations that make a run impossible, the rig's geometry in every frame, and the work a
    /// run will do.
    Check { scenario: String },
    /// Print the fully resolved scenario (after `extend`) as TOML.
    Show { scenario: String },
    /// List the built-in scenarios.
    List,
}

pub fn run(cmd: ScenarioCmd) -> Result<()> {
    match cmd {
        ScenarioCmd::Check { scenario: spec } => {
            let s = scenario::load_any(&spec)?;
            let work = Workload::of(&s, true);
            println!("work: {work}");
            match work.over_limits() {
                // Building the rig integrates the dynamics, which is part of that work.
                Some(why) => println!(
                    "note: {why}: `run` needs --yes; the rig (geometry in every frame) was not built"
                ),
                None => {
                    let rig = Rig::new(&s).with_context(|| spec.clone())?;
                    geneva_vision::pipeline::run::measurable(&rig).with_context(|| spec.clone())?;
                    println!(
                        "rig: {} frames, the marker inside the image in every one",
                        rig.frame_times.len()
                    );
                }
            }
            // Valid, but clipping its own noise: say so, with the statement that keeps the levels.
            for w in scenario::clipping::warnings(&s) {
                println!("warning: {}: {}", w.field, w.message);
            }
            println!("{spec}: ok ({})", s.name);
            Ok(())
        }
        ScenarioCmd::Show { scenario: spec } => {
            let s = scenario::load_any(&spec)?;
            print!("{}", s.to_toml());
            // The camera both ways: physically and as an image scale, whichever the file gave.
            match geneva_vision::camera::Camera::new(&s.camera) {
                Ok(camera) => {
                    println!();
                    for line in camera.describe().lines() {
                        println!("# {line}");
                    }
                }
                Err(e) => println!("# camera: {e}"),
            }
            Ok(())
        }
        ScenarioCmd::List => {
            for name in scenario::builtin_names() {
                println!("{name}");
            }
            Ok(())
        }
    }
}
