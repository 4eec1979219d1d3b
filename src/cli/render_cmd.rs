//! `geneva render SCENARIO --out DIR [--frames A..B] [--roi MARGIN] [--video FILE.mp4]`.

use anyhow::{bail, Context, Result};
use geneva_vision::pipeline::render_job::{render_job, RenderJob, Renderer};
use geneva_vision::scenario;
use std::path::{Path, PathBuf};

/// `A..B` (end exclusive), `A..=B` (end inclusive) or `A` (one frame); never empty.
fn parse_range(text: &str) -> Result<std::ops::Range<usize>> {
    let number = |s: &str, what: &str| -> Result<usize> {
        s.trim().parse().with_context(|| {
            format!(
                "--frames `{text}`: {what} `{}` is not a frame number",
                s.trim()
            )
        })
    };
    let range = if let Some((a, b)) = text.split_once("..=") {
        number(a, "start")?..number(b, "end")?.saturating_add(1)
    } else if let Some((a, b)) = text.split_once("..") {
        number(a, "start")?..number(b, "end")?
    } else {
        let a = number(text, "frame")?;
        a..a.saturating_add(1)
    };
    if range.start >= range.end {
        bail!(
            "--frames `{text}` holds no frame (A..B excludes B: `{0}..{1}` or `{0}` renders frame {0})",
            range.start,
            range.start + 1
        );
    }
    Ok(range)
}

pub fn run(
    spec: &str,
    out: &Path,
    frames: Option<&str>,
    roi: Option<usize>,
    video: Option<PathBuf>,
    independent: bool,
    yes: bool,
) -> Result<()> {
    super::refuse_inputs_inside(out, &super::scenario_inputs("", spec))?;
    let s = scenario::load_any(spec)?;
    let mut work = geneva_vision::pipeline::workload::Workload::of(&s, false);
    if let Some(r) = frames.map(parse_range).transpose()? {
        work.frames = work.frames.min(r.len() as f64);
    }
    super::work::confirm(&format!("rendering {}", s.name), &work, yes)?;
    let staged = geneva_vision::io::output_dir::OutputDir::create(out)?;
    // A video inside the output folder is written into the staging folder like the rest (the
    // old folder, swapped out at the commit, would take it with it).
    let video = match video {
        Some(v) => {
            let abs = std::path::absolute(&v).with_context(|| format!("{}", v.display()))?;
            Some(match abs.strip_prefix(staged.dir()) {
                Ok(rel) => staged.path().join(rel),
                Err(_) => abs,
            })
        }
        None => None,
    };
    let job = RenderJob {
        frames: frames.map(parse_range).transpose()?,
        roi_margin_px: roi,
        png: video.is_none(),
        video,
        renderer: if independent {
            Renderer::Independent
        } else {
            Renderer::Own
        },
    };
    let bar = super::run_cmd::progress_bar(0, "render");
    let summary = render_job(&s, staged.path(), &job, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .with_context(|| format!("scenario {}", s.name))?;
    bar.finish_and_clear();
    println!(
        "rendered {} frames of {} into {}",
        summary.frames,
        s.name,
        out.display()
    );
    // A video given outside the folder is written where it was asked.
    let outside: Vec<_> = summary
        .files
        .iter()
        .filter(|f| !f.starts_with(staged.path()))
        .cloned()
        .collect();
    super::run_cmd::print_files(&staged.commit()?);
    super::run_cmd::print_files(&outside);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::parse_range;

    #[test]
    fn frame_ranges_exclusive_inclusive_and_single() {
        assert_eq!(parse_range("5..8").unwrap(), 5..8);
        assert_eq!(parse_range("5..=8").unwrap(), 5..9);
        assert_eq!(parse_range("5").unwrap(), 5..6);
        // Regression: `--frames 5..5` was reported as "outside the scenario's 60 frames".
        let e = parse_range("5..5").unwrap_err().to_string();
        assert!(e.contains("holds no frame") && e.contains("5..6"), "{e}");
        assert!(parse_range("7..3").is_err());
        assert!(parse_range("a..3")
            .unwrap_err()
            .to_string()
            .contains("start"));
    }
}
