//! The parsers under fuzzing, each called as its command calls it on a file's bytes, and the seed
//! files of their structure-aware mutations (committed scenarios, sweeps, tracks, ffprobe output
//! and the rig's real showinfo logs).

use std::error::Error;
use std::path::{Path, PathBuf};

use crate::timing::{stream_frame_times, LogFormat, Timestamps};

/// A parser of user input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Target {
    /// `scenario::from_str`: TOML, `extend`, deserialisation, validation, external timing logs.
    ScenarioToml,
    /// `SweepSpec::from_str`: TOML, deserialisation, validation.
    SweepToml,
    /// `io::tracks_csv::read_tracks_from` (with and without an expected marker id).
    TracksCsv,
    /// Our `frame,t_s` timestamps CSV.
    TimestampsCsv,
    /// ffmpeg showinfo logs (`pts_time`), then the statistics and the VFR fit of what parses.
    Showinfo,
    /// ffmpeg showinfo logs read by `pts × time_base`.
    ShowinfoPts,
    /// `ffprobe -show_entries frame=pts_time -of csv`.
    FfprobeCsv,
    /// `ffprobe -show_entries frame=pts_time -of json`.
    FfprobeJson,
    /// `io::video::parse_probe_json`: the stream and frame description of a video.
    VideoProbeJson,
    /// `geneva slurm script`'s values (one a line: output folder, scripts folder, binary,
    /// partition, time, memory, then the job's words) through `shard::slurm::scripts`: an
    /// accepted set must give scripts that read back as written (a script line that is not
    /// its template's, a directive split, a command of other words: a panic, i.e. a fault).
    SlurmArgs,
    /// A shard's record file (`units.tsv`, `units.log`: header, `unit<TAB>record<TAB>digest`)
    /// through `shard::parse_record_text`.
    ShardRecords,
    /// A shard's `manifest.json` (`shard::Manifest::from_json`) and `shard.json`
    /// (`shard::parse_shard_json`): accepted when either reads it.
    ShardJson,
}

impl Target {
    pub const ALL: [Target; 12] = [
        Target::ScenarioToml,
        Target::SweepToml,
        Target::TracksCsv,
        Target::TimestampsCsv,
        Target::Showinfo,
        Target::ShowinfoPts,
        Target::FfprobeCsv,
        Target::FfprobeJson,
        Target::VideoProbeJson,
        Target::SlurmArgs,
        Target::ShardRecords,
        Target::ShardJson,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Target::ScenarioToml => "scenario_toml",
            Target::SweepToml => "sweep_toml",
            Target::TracksCsv => "tracks_csv",
            Target::TimestampsCsv => "timestamps_csv",
            Target::Showinfo => "showinfo",
            Target::ShowinfoPts => "showinfo_pts",
            Target::FfprobeCsv => "ffprobe_csv",
            Target::FfprobeJson => "ffprobe_json",
            Target::VideoProbeJson => "video_probe_json",
            Target::SlurmArgs => "slurm_args",
            Target::ShardRecords => "shard_records",
            Target::ShardJson => "shard_json",
        }
    }

    /// The name a file of this kind gets in error messages (inside the repository's
    /// `scenarios/` folder for TOML, so `extend = "fast.toml"` resolves as in a real file).
    pub fn pseudo_path(self, repo: &Path) -> PathBuf {
        match self {
            Target::ScenarioToml => repo.join("scenarios/fuzz-input.toml"),
            Target::SweepToml => repo.join("scenarios/sweeps/fuzz-input.toml"),
            Target::TracksCsv => PathBuf::from("fuzz-input/tracks.csv"),
            Target::VideoProbeJson => PathBuf::from("fuzz-input/video.mp4"),
            Target::ShardRecords => PathBuf::from("fuzz-input/shards/0/units.tsv"),
            Target::ShardJson => PathBuf::from("fuzz-input/shards/0/shard.json"),
            _ => PathBuf::from("fuzz-input.log"),
        }
    }

    /// Whether the parser's errors must name the file (the others name a line or frame; the
    /// caller that opened the file adds its name).
    pub fn names_file(self) -> bool {
        matches!(
            self,
            Target::ScenarioToml
                | Target::SweepToml
                | Target::TracksCsv
                | Target::VideoProbeJson
                | Target::ShardRecords
                | Target::ShardJson
        )
    }

    fn log_format(self) -> Option<LogFormat> {
        match self {
            Target::TimestampsCsv => Some(LogFormat::FramesCsv),
            Target::Showinfo => Some(LogFormat::Showinfo),
            Target::ShowinfoPts => Some(LogFormat::ShowinfoPts),
            Target::FfprobeCsv => Some(LogFormat::FfprobeCsv),
            Target::FfprobeJson => Some(LogFormat::FfprobeJson),
            _ => None,
        }
    }
}

/// A parser's refusal, as the error value the library returns.
pub type Rejection = Box<dyn Error + Send + Sync + 'static>;

/// Text for the parsers that take `&str`: as the file readers would see it (they refuse
/// non-UTF-8 files before parsing; the lossy text exercises the parser all the same).
fn text(bytes: &[u8]) -> std::borrow::Cow<'_, str> {
    String::from_utf8_lossy(bytes)
}

/// Runs `target` on `bytes` (named `path` in errors).
pub fn parse(target: Target, bytes: &[u8], path: &Path) -> Result<(), Rejection> {
    if let Some(format) = target.log_format() {
        let mut times = Vec::new();
        stream_frame_times(bytes, format, &mut |t| {
            times.push(t);
            Ok(())
        })?;
        let ts = Timestamps::new(times)?;
        if target == Target::Showinfo && ts.len() >= 3 {
            // What `geneva timing stats|fit` do next with a parsed log.
            crate::timing::TimingStats::of(&ts)?;
            crate::timing::fit_vfr(&ts)?;
        }
        return Ok(());
    }
    match target {
        Target::ScenarioToml => crate::scenario::from_str(&text(bytes), path).map(drop)?,
        Target::SweepToml => crate::sweep::SweepSpec::from_str(&text(bytes), path).map(drop)?,
        Target::TracksCsv => {
            // Half the inputs as `analyze --tracks` with a scenario's marker id, half without.
            let expected = (bytes.len() % 2 == 0).then_some(0);
            crate::io::tracks_csv::read_tracks_from(bytes, path, expected).map(drop)?
        }
        Target::VideoProbeJson => {
            crate::io::video::parse_probe_json(path, &text(bytes)).map(drop)?
        }
        Target::SlurmArgs => slurm_args(bytes)?,
        Target::ShardRecords => {
            crate::shard::parse_record_text(&text(bytes), path, 1 << 20).map(drop)?
        }
        Target::ShardJson => {
            let t = text(bytes);
            if let Err(e) = crate::shard::Manifest::from_json(&t, path) {
                crate::shard::parse_shard_json(&t, path).map_err(|_| e)?;
            }
        }
        _ => unreachable!("timing formats handled above"),
    }
    Ok(())
}

/// The Slurm script values of one input (see [`Target::SlurmArgs`]); a script that does not
/// read back as written panics, which the campaign counts as a fault.
fn slurm_args(bytes: &[u8]) -> Result<(), Rejection> {
    use crate::shard::slurm::{scripts, Job, ScriptSpec, SlurmError};
    let text = text(bytes);
    let mut lines = text.split('\n');
    let mut next = || lines.next().unwrap_or("").to_string();
    let (out, dir, geneva) = (next(), next(), next());
    let optional = |s: String| (!s.is_empty()).then_some(s);
    let (partition, time, mem) = (optional(next()), optional(next()), optional(next()));
    let study: Vec<String> = lines.map(str::to_string).collect();
    let spec = ScriptSpec {
        job: Job {
            merge: study.iter().rev().cloned().collect(),
            study,
            what: out.clone(),
        },
        out: out.into(),
        scripts: dir.into(),
        geneva: geneva.into(),
        shards: 1 + bytes.len() % 7,
        cpus_per_task: 1 + bytes.len() % 3,
        partition,
        time,
        mem,
    };
    match scripts(&spec) {
        Err(e @ SlurmError::Generated { .. }) => panic!("{e}"),
        other => other.map(drop).map_err(Into::into),
    }
}

/// At most this many lines of a seed file: mutations of a short file are as telling and much
/// cheaper than of a 4,000-line log.
const SEED_LINES: usize = 200;

fn head(bytes: &[u8], lines: usize) -> Vec<u8> {
    bytes
        .split_inclusive(|&b| b == b'\n')
        .take(lines)
        .collect::<Vec<_>>()
        .concat()
}

/// The seed files of `target` under the repository `repo` (committed files; the rig's real logs
/// in `data/phone-frame-timing/`; timestamp formats derived from them).
pub fn corpus(target: Target, repo: &Path) -> std::io::Result<Vec<Vec<u8>>> {
    let read = |rel: &str| std::fs::read(repo.join(rel));
    let logs = || -> std::io::Result<Vec<Vec<u8>>> {
        let mut out = Vec::new();
        for k in 1..=9 {
            let log = read(&format!(
                "data/phone-frame-timing/model_test{k}.showinfo.log"
            ))?;
            out.push(head(&log, SEED_LINES));
        }
        Ok(out)
    };
    // The real logs' times, as the other timestamp formats write them.
    let real_times = || -> std::io::Result<Vec<Timestamps>> {
        Ok(logs()?
            .iter()
            .filter_map(|log| crate::timing::parse_showinfo(&text(log)).ok())
            .collect())
    };
    Ok(match target {
        Target::ScenarioToml => ["fast", "seed-internal-4k", "seed-external-4k"]
            .iter()
            .map(|n| read(&format!("scenarios/{n}.toml")))
            .collect::<Result<_, _>>()?,
        Target::SweepToml => ["fast", "seed-camera", "seed-camera-base"]
            .iter()
            .map(|n| read(&format!("scenarios/sweeps/{n}.toml")))
            .collect::<Result<_, _>>()?,
        Target::TracksCsv => {
            let mut out = vec![head(
                &read("reports/seed-internal-4k/better-settings/seed0/tracks.csv")?,
                SEED_LINES,
            )];
            // A track with the reference marker's columns and an undetected frame.
            let mut with_ref = String::from("frame,t_s,marker_id");
            for c in ["", "ref_"] {
                for k in 0..4 {
                    with_ref.push_str(&format!(",{c}x{k}_px,{c}y{k}_px"));
                }
            }
            with_ref.push('\n');
            for f in 0..12 {
                let t = f as f64 / 30.0;
                if f == 5 {
                    with_ref.push_str(&format!("{f},{t:?},,,,,,,,,,,,,,,,,,\n"));
                } else {
                    with_ref.push_str(&format!(
                        "{f},{t:?},0,10.5,20,30,20.25,30,40,10,40,100,100,120,100,120,120,100,120\n"
                    ));
                }
            }
            out.push(with_ref.into_bytes());
            out
        }
        Target::TimestampsCsv => real_times()?
            .into_iter()
            .map(|t| crate::timing::to_frames_csv(&t).into_bytes())
            .collect(),
        Target::Showinfo | Target::ShowinfoPts => logs()?,
        Target::FfprobeCsv => {
            let mut out = vec![read("tests/data/fuzz/ffprobe-frames.csv")?];
            for t in real_times()? {
                let t = t.as_slice();
                // `csv=p=1`: the section name before each value.
                out.push(
                    t.iter()
                        .map(|t| format!("frame,{t:.6}\n"))
                        .collect::<String>()
                        .into_bytes(),
                );
            }
            out
        }
        Target::FfprobeJson => {
            let mut out = vec![read("tests/data/fuzz/ffprobe-frames.json")?];
            for t in real_times()? {
                let t = t.as_slice();
                let frames: Vec<String> = t
                    .iter()
                    .map(|t| format!("{{\"pts_time\": \"{t:.6}\"}}"))
                    .collect();
                out.push(format!("{{\"frames\": [{}]}}\n", frames.join(",\n")).into_bytes());
            }
            out
        }
        Target::VideoProbeJson => vec![read("tests/data/fuzz/ffprobe-video.json")?],
        Target::ShardRecords => {
            // A record file as a run writes it (digests), and one of the older format.
            let records: std::collections::BTreeMap<usize, String> = [
                (0, "0,fps=30,30,0,1,0.001,0.02,1.5,ok,".to_string()),
                (3, "a\tb\nc \\ d".to_string()),
                (7, String::new()),
            ]
            .into_iter()
            .collect();
            let new = crate::shard::record_file_text(&records).into_bytes();
            vec![new, head(&read("reports/seed-camera/units.tsv")?, 20)]
        }
        Target::ShardJson => vec![
            br#"{"index":1,"count":3,"files":{"manifest.json":"fnv1a64:0123456789abcdef","units.tsv":"fnv1a64:fedcba9876543210","seed0/tracks.csv":"fnv1a64:00000000000000ff"}}"#.to_vec(),
            serde_json::to_vec_pretty(&crate::shard::Manifest::new(
                "sweep",
                8,
                [("seeds".to_string(), serde_json::json!(2)), ("axes".to_string(), serde_json::json!([{"name": "fps", "values": [30.0, 60.0]}]))]
                    .into_iter()
                    .collect(),
            ))
            .map_err(std::io::Error::other)?,
        ],
        Target::SlurmArgs => [
            "/data/sweep out\n/data/slurm\n/opt/geneva\ngpu\n01:00:00\n8G\nsweep\n/data/s.toml",
            "/scratch/mc\n/scratch/mc-slurm\n/usr/bin/geneva\n\n2-12:30\n\nmontecarlo\nfast\n--seeds\n100",
            "/d/it's\n/d/s\n/g\ndebug,long\n30\n512m\ndiagnose\n--scenario\n/d/a b.toml\n--tracks\n/d/t.csv",
        ]
        .iter()
        .map(|s| s.as_bytes().to_vec())
        .collect(),
    })
}
