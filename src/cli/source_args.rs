//! The footage arguments shared by the commands that measure real data: `--video F` or
//! `--frames DIR --timestamps F` ([`FootageArgs`]), flattened into each command beside its own
//! third kind of input — a corner track `--tracks F` for `geneva analyze` and `geneva diagnose`
//! ([`SourceArgs`]), a still `--image F` for `geneva calibrate` — which declares its conflicts
//! with these. Exactly one of the three must be given.

use anyhow::{bail, Context, Result};
use clap::Args;
use geneva_vision::io::output_dir::Input;
use geneva_vision::pipeline::analyze::Source;
use std::path::PathBuf;

#[derive(Args, Debug, Clone, Default)]
pub struct FootageArgs {
    /// A video file (decoded with ffmpeg; timestamps from ffprobe; display rotation honoured).
    #[arg(long, conflicts_with = "frames")]
    video: Option<PathBuf>,
    /// A folder of image files (PNG/JPEG), taken in natural name order; needs --timestamps.
    #[arg(long, requires = "timestamps")]
    frames: Option<PathBuf>,
    /// `frame, t_s` CSV (or any timing log) for --frames.
    #[arg(long)]
    timestamps: Option<PathBuf>,
}

impl FootageArgs {
    /// The files and folders given, named by their options.
    pub fn inputs(&self) -> Vec<Input> {
        let named = [
            ("--video", &self.video),
            ("--frames", &self.frames),
            ("--timestamps", &self.timestamps),
        ];
        named
            .into_iter()
            .filter_map(|(what, p)| p.as_ref().map(|p| Input::new(what, p)))
            .collect()
    }

    /// The one input given: the video (`video`), the frames with their timestamps (`frames`), or
    /// the command's own alternative (`other`, from the option `other_flag`).
    pub fn one_of<T>(
        &self,
        other: Option<T>,
        other_flag: &str,
        video: impl FnOnce(PathBuf) -> T,
        frames: impl FnOnce(PathBuf, PathBuf) -> T,
    ) -> Result<T> {
        Ok(match (&self.video, &self.frames, other) {
            (Some(v), None, None) => video(v.clone()),
            (None, Some(d), None) => frames(
                d.clone(),
                self.timestamps
                    .clone()
                    .context("--frames needs --timestamps")?,
            ),
            (None, None, Some(o)) => o,
            _ => bail!("give exactly one of --video, --frames (with --timestamps) or {other_flag}"),
        })
    }
}

/// The real data of `geneva analyze` and `geneva diagnose`.
#[derive(Args, Debug, Clone, Default)]
pub struct SourceArgs {
    #[command(flatten)]
    footage: FootageArgs,
    /// An existing tracks CSV (frame, t_s, marker_id, x0_px … y3_px): only what a corner track
    /// holds can be measured from it (no image statistics).
    #[arg(long, conflicts_with_all = ["video", "frames"])]
    tracks: Option<PathBuf>,
}

impl SourceArgs {
    /// The files and folders given, named by their options.
    pub fn inputs(&self) -> Vec<Input> {
        let mut v = self.footage.inputs();
        v.extend(self.tracks.as_ref().map(|t| Input::new("--tracks", t)));
        v
    }

    /// The one source given, or an error naming the choices.
    pub fn source(&self) -> Result<Source> {
        self.footage.one_of(
            self.tracks.clone().map(Source::Tracks),
            "--tracks",
            Source::Video,
            |dir, timestamps| Source::Frames { dir, timestamps },
        )
    }
}
