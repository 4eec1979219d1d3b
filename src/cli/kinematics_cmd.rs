//! `geneva kinematics SCENARIO --out DIR [--times FILE]`: truth trajectory CSV and plots, or the
//! motion at listed instants.

use anyhow::{Context, Result};
use geneva_vision::pipeline::truth::write_truth;
use geneva_vision::scenario;
use std::path::Path;

/// `geneva kinematics`: written into `out` all at once.
pub fn run(spec: &str, out: &Path, times: Option<&Path>, yes: bool) -> Result<()> {
    let mut inputs = super::scenario_inputs("", spec);
    if let Some(times) = times {
        inputs.push(geneva_vision::io::output_dir::Input::new(
            "--times".to_string(),
            times.to_path_buf(),
        ));
    }
    super::refuse_inputs_inside(out, &inputs)?;
    let s = scenario::load_any(spec)?;
    let mut work = geneva_vision::pipeline::workload::Workload::of(&s, true);
    // Only the truth: no pixels are rendered.
    (work.window_px, work.width_px, work.height_px) = (0.0, 0, 0);
    super::work::confirm("the truth trajectory", &work, yes)?;
    if let Some(times) = times {
        let staged = geneva_vision::io::output_dir::OutputDir::create(out)?;
        let rows = geneva_vision::pipeline::truth::write_truth_at(&s, times, staged.path())
            .with_context(|| format!("scenario {}", s.name))?;
        println!("motion at {rows} listed instants");
        super::run_cmd::print_files(&staged.commit()?);
        return Ok(());
    }
    let staged = geneva_vision::io::output_dir::OutputDir::create(out)?;
    run_into(spec, staged.path())?;
    super::run_cmd::print_files(&staged.commit()?);
    Ok(())
}

/// Writes into `out` as it is (the caller commits the folder).
pub fn run_into(spec: &str, out: &Path) -> Result<()> {
    let s = scenario::load_any(spec)?;
    let summary = write_truth(&s, out).with_context(|| format!("scenario {}", s.name))?;
    println!(
        "scenario {} ({} {}-slot drive)",
        s.name,
        s.mechanism.kind.as_str(),
        s.mechanism.slots
    );
    print!("{summary}");
    Ok(())
}
