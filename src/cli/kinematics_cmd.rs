//! `geneva kinematics SCENARIO --out DIR`: truth trajectory CSV and plots.

use anyhow::{Context, Result};
use geneva_vision::pipeline::truth::write_truth;
use geneva_vision::scenario;
use std::path::Path;

pub fn run(spec: &str, out: &Path) -> Result<()> {
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
