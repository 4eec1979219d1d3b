//! `geneva render SCENARIO --out DIR [--frames A..B] [--roi MARGIN] [--video FILE.mp4]`.

use anyhow::{bail, Context, Result};
use geneva_vision::pipeline::render_job::{render_job, RenderJob};
use geneva_vision::scenario;
use std::path::{Path, PathBuf};

fn parse_range(text: &str) -> Result<std::ops::Range<usize>> {
    let Some((a, b)) = text.split_once("..") else {
        bail!("--frames `{text}`: expected A..B (end exclusive)")
    };
    let a: usize = a
        .trim()
        .parse()
        .with_context(|| format!("--frames `{text}`: start"))?;
    let b: usize = b
        .trim()
        .parse()
        .with_context(|| format!("--frames `{text}`: end"))?;
    Ok(a..b)
}

pub fn run(
    spec: &str,
    out: &Path,
    frames: Option<&str>,
    roi: Option<usize>,
    video: Option<PathBuf>,
) -> Result<()> {
    let s = scenario::load_any(spec)?;
    let job = RenderJob {
        frames: frames.map(parse_range).transpose()?,
        roi_margin_px: roi,
        png: video.is_none(),
        video,
    };
    let bar = super::run_cmd::progress_bar(0, "render");
    let summary = render_job(&s, out, &job, &|done, total| {
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
    for f in summary.files {
        println!("wrote {}", f.display());
    }
    Ok(())
}
