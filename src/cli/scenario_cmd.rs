//! `geneva scenario check|show|effects|list`.

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
    Show {
        scenario: String,
        /// Switch these effects off first (comma-separated vocabulary names, through the
        /// effect registry, with the effects that share their switch): the rig as a diagnosis
        /// is told it when these effects are withheld from its nominal.
        #[arg(long, value_delimiter = ',')]
        without: Vec<String>,
        /// Then switch this effect on with these values, `NAME=V1,V2,…` in the registry's
        /// parameter order (`geneva scenario effects` lists them), through the effect
        /// registry; repeatable.
        #[arg(long = "with", value_name = "NAME=VALUES")]
        with: Vec<String>,
    },
    /// Print the effect vocabulary as JSON: each effect's kind, scenario section and parameters
    /// (path, unit, valid and search ranges, probe) with the values the diagnosis self-check
    /// withholds it at (strong and near the limit) on a rig filmed at `--fps`.
    Effects {
        #[arg(long, default_value_t = 30.0)]
        fps: f64,
    },
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
                    for w in geneva_vision::pipeline::run::detection_warnings(&rig) {
                        println!("warning: {w}");
                    }
                }
            }
            // Valid, but clipping its own noise: say so, with the statement that keeps the levels.
            for w in scenario::clipping::warnings(&s) {
                println!("warning: {}: {}", w.field, w.message);
            }
            println!("{spec}: ok ({})", s.name);
            Ok(())
        }
        ScenarioCmd::Show {
            scenario: spec,
            without,
            with,
        } => {
            let mut s = scenario::load_any(&spec)?;
            let without = super::effects_arg::parse_effects(Some(&without))?.unwrap_or_default();
            for e in without {
                e.switch_off(&mut s);
                for mate in e.shares_switch_with() {
                    mate.switch_off(&mut s);
                }
            }
            for arg in &with {
                let (effect, values) = parse_with(arg)?;
                anyhow::ensure!(
                    effect.apply(&mut s, &values),
                    "--with {arg}: {} takes {} values ({})",
                    effect.name(),
                    effect.params().len(),
                    effect
                        .params()
                        .iter()
                        .map(|p| p.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
            let problems = s.validate();
            anyhow::ensure!(
                problems.is_empty(),
                "{spec} with the effects switched: {}",
                problems
                    .iter()
                    .map(|p| p.to_string())
                    .collect::<Vec<_>>()
                    .join("; ")
            );
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
        ScenarioCmd::Effects { fps } => {
            anyhow::ensure!(
                fps.is_finite() && fps > 0.0,
                "--fps {fps}: a frame rate must be positive"
            );
            println!("{:#}", vocabulary_json(fps));
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

/// `NAME=V1,V2,…`: an effect of the vocabulary and its parameter values.
fn parse_with(arg: &str) -> Result<(geneva_vision::scenario::effects::Effect, Vec<f64>)> {
    use geneva_vision::scenario::effects::Effect;
    let (name, values) = arg
        .split_once('=')
        .with_context(|| format!("--with {arg}: write NAME=V1,V2,… (e.g. backlash=0.5)"))?;
    let effect = Effect::from_name(name).with_context(|| {
        format!(
            "--with {arg}: `{name}` is not an effect; the vocabulary is: {}",
            Effect::names()
        )
    })?;
    let values = values
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .with_context(|| format!("--with {arg}: `{v}` is not a finite number"))
        })
        .collect::<Result<Vec<f64>>>()?;
    Ok((effect, values))
}

/// The vocabulary as `geneva scenario effects` prints it (see its help).
fn vocabulary_json(fps: f64) -> serde_json::Value {
    use geneva_vision::pipeline::selfcheck::{level_values, timebase_schedule, Level};
    use geneva_vision::scenario::effects::Effect;
    use serde_json::json;
    let effects: Vec<serde_json::Value> = Effect::ALL
        .iter()
        .map(|&e| {
            let strong = level_values(e, Level::Strong, fps);
            let weak = level_values(e, Level::Weak, fps);
            let params: Vec<serde_json::Value> = e
                .params_on(fps)
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    json!({
                        "name": p.name,
                        "path": p.path,
                        "unit": p.unit,
                        "valid": [p.valid.0, p.valid.1],
                        "search": [p.search.0, p.search.1],
                        "log_scale": p.log_scale,
                        "probe": p.probe,
                        "strong": strong[i],
                        "weak": weak[i],
                    })
                })
                .collect();
            json!({
                "name": e.name(),
                "kind": format!("{:?}", e.kind()).to_lowercase(),
                "section": e.section(),
                "description": e.description(),
                "shares_switch_with": e.shares_switch_with().iter().map(|m| m.name()).collect::<Vec<_>>(),
                "params": params,
            })
        })
        .collect();
    json!({
        "fps_hz": fps,
        "effects": effects,
        // A withheld timebase is frames taken on a phone's schedule and stamped at a constant
        // rate: the schedule at each level.
        "timebase_schedule": {
            "strong": timebase_schedule(Level::Strong, fps),
            "weak": timebase_schedule(Level::Weak, fps),
        },
    })
}
