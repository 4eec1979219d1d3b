//! `geneva scenario check|show|list`.

use anyhow::Result;
use clap::Subcommand;
use geneva_vision::scenario;

#[derive(Subcommand, Debug)]
pub enum ScenarioCmd {
    /// Validate a scenario file (or built-in name); prints every problem with its field.
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
