//! Input integrity of `analyze`: damaged inputs are counted and reported, never
//! silently used. Each test reproduces one observed failure on frames rendered from `fast`
//! (1280x720, 60 frames) and checks the result against the undamaged input.
#![cfg(feature = "opencv-detector")]

use geneva_vision::io::png_out::write_gray_png;
use geneva_vision::io::tracks_csv::read_tracks;
use geneva_vision::pipeline::analyze::{analyze, AnalyzeOptions, AnalyzeOutput, Source};
use geneva_vision::pipeline::render_job::{render_job, RenderJob};
use geneva_vision::scenario::{self, Scenario};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

fn fast() -> Scenario {
    scenario::load_builtin("fast").unwrap()
}

/// The 60 rendered frames of `fast` (rendered once per test binary).
fn rendered() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let job = RenderJob {
            png: true,
            ..RenderJob::default()
        };
        render_job(&fast(), dir.path(), &job, &|_, _| {}).unwrap();
        dir
    })
    .path()
}

/// A copy of the rendered frames (PNGs and timestamps.csv) in `dir/frames`.
fn copy_frames(dir: &Path) -> PathBuf {
    let frames = dir.join("frames");
    std::fs::create_dir(&frames).unwrap();
    for entry in std::fs::read_dir(rendered()).unwrap() {
        let p = entry.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if name.ends_with(".png") || name == "timestamps.csv" {
            std::fs::copy(&p, frames.join(name)).unwrap();
        }
    }
    frames
}

fn options() -> AnalyzeOptions {
    AnalyzeOptions::from_scenario(&fast(), -1.0)
}

fn analyze_frames(frames: &Path, out: &Path) -> AnalyzeOutput {
    let source = Source::Frames {
        dir: frames.to_path_buf(),
        timestamps: frames.join("timestamps.csv"),
    };
    analyze(&source, &options(), out, &|_, _| {}).unwrap()
}

fn clean() -> &'static AnalyzeOutput {
    static OUT: OnceLock<(tempfile::TempDir, AnalyzeOutput)> = OnceLock::new();
    &OUT.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let out = analyze_frames(rendered(), &dir.path().join("out"));
        (dir, out)
    })
    .1
}

fn centre_shift_px(a: &AnalyzeOutput, b: &AnalyzeOutput) -> f64 {
    let (p, q) = (
        a.estimate.rotation_centre.centre_px,
        b.estimate.rotation_centre.centre_px,
    );
    (p[0] - q[0]).hypot(p[1] - q[1])
}

#[test]
fn a_frame_of_another_size_is_recorded_unreadable_not_searched() {
    // Regression: one 640x360 PNG in the 1280x720 sequence moved the rotation centre by ~78 px,
    // exit 0, no warning.
    let dir = tempfile::tempdir().unwrap();
    let frames = copy_frames(dir.path());
    let small: Vec<u8> = (0..640 * 360).map(|i| (i % 251) as u8).collect();
    write_gray_png(&frames.join("frame_000030.png"), 640, 360, &small).unwrap();
    let out = analyze_frames(&frames, &dir.path().join("out"));
    assert_eq!(out.input.unreadable.len(), 1, "{:?}", out.input.unreadable);
    let bad = &out.input.unreadable[0];
    assert_eq!(bad.frame, 30);
    assert!(
        bad.reason.contains("640x360") && bad.reason.contains("1280x720"),
        "{}",
        bad.reason
    );
    assert!(out.tracks[30].corners_px.is_none());
    assert_eq!(out.estimate.detected, clean().estimate.detected - 1);
    // One frame fewer of the same detections: the centre moves by far less than a pixel.
    let shift = centre_shift_px(&out, clean());
    assert!(shift < 0.5, "centre moved {shift} px");
    let listed = std::fs::read_to_string(dir.path().join("out/unreadable_frames.csv")).unwrap();
    assert!(listed.starts_with("frame,file,reason\n30,"), "{listed}");
}

#[test]
fn a_zero_byte_png_in_the_middle_is_recorded_and_the_analysis_goes_on() {
    // Regression: a zero-byte PNG aborted the whole analysis.
    let dir = tempfile::tempdir().unwrap();
    let frames = copy_frames(dir.path());
    std::fs::write(frames.join("frame_000020.png"), b"").unwrap();
    let out = analyze_frames(&frames, &dir.path().join("out"));
    assert_eq!(out.input.unreadable.len(), 1);
    assert_eq!(out.input.unreadable[0].frame, 20);
    assert!(out.input.unreadable[0].reason.contains("empty file"));
    assert_eq!(out.tracks.len(), 60);
    assert_eq!(out.estimate.missing, clean().estimate.missing + 1);
}

#[test]
fn a_frame_of_another_pixel_format_is_recorded_unreadable() {
    let dir = tempfile::tempdir().unwrap();
    let frames = copy_frames(dir.path());
    // Frame 10 as an 8-bit RGB PNG of the same picture: a foreign frame in a grey sequence.
    let grey = geneva_vision::io::images::read_gray(&frames.join("frame_000010.png")).unwrap();
    let file = std::fs::File::create(frames.join("frame_000010.png")).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), 1280, 720);
    enc.set_color(png::ColorType::Rgb);
    let rgb: Vec<u8> = grey.data.iter().flat_map(|&v| [v, v, v]).collect();
    enc.write_header().unwrap().write_image_data(&rgb).unwrap();
    let out = analyze_frames(&frames, &dir.path().join("out"));
    assert_eq!(out.input.unreadable.len(), 1);
    assert!(
        out.input.unreadable[0].reason.contains("8-bit RGB PNG"),
        "{}",
        out.input.unreadable[0].reason
    );
}

#[test]
fn a_track_keeps_its_frame_numbers_and_counts_its_gaps() {
    // Regression: frames 50–59 came out numbered 10–19 and 40 absent frames were "0 missing".
    let dir = tempfile::tempdir().unwrap();
    let full = read_tracks(&clean_tracks(), Some(0)).unwrap();
    let text = std::fs::read_to_string(clean_tracks()).unwrap();
    let mut lines = text.lines();
    let mut kept = vec![lines.next().unwrap().to_string()];
    kept.extend(
        lines
            .zip(&full)
            .filter(|(_, r)| r.frame < 10 || r.frame >= 50)
            .map(|(l, _)| l.to_string()),
    );
    let tracks = dir.path().join("gappy.csv");
    std::fs::write(&tracks, kept.join("\n") + "\n").unwrap();
    let out = analyze(
        &Source::Tracks(tracks),
        &options(),
        &dir.path().join("out"),
        &|_, _| {},
    )
    .unwrap();
    assert_eq!(out.input.gaps, vec![10..=49]);
    assert_eq!(out.input.absent(), 40);
    // The estimator sees the 40 absent frames as missing, never as present.
    assert_eq!(out.estimate.frames, 60);
    assert_eq!(out.estimate.missing, 40 + clean().estimate.missing);
    let kin = std::fs::read_to_string(dir.path().join("out/kinematics.csv")).unwrap();
    let frames: std::collections::BTreeSet<usize> = kin
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    let expected: std::collections::BTreeSet<usize> = (0..10).chain(50..60).collect();
    assert_eq!(frames, expected);
}

fn clean_tracks() -> PathBuf {
    // The clean analysis wrote its tracks next to its outputs.
    static P: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    P.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        analyze_frames(rendered(), dir.path());
        let p = dir.path().join("tracks.csv");
        (dir, p)
    })
    .1
    .clone()
}

fn ffmpeg(args: &[&str]) {
    let ok = Command::new("ffmpeg")
        .args(["-v", "error", "-y"])
        .args(args)
        .status()
        .unwrap()
        .success();
    assert!(ok, "ffmpeg {args:?}");
}

#[test]
fn a_truncated_video_is_reported_with_its_last_good_frame() {
    // Regression: an MP4 with the index at the front, cut in half, was analysed as 30 of its
    // 60 frames and reported "0 missing".
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole.mp4");
    let pattern = rendered().join("frame_%06d.png");
    ffmpeg(&[
        "-framerate",
        "30",
        "-i",
        pattern.to_str().unwrap(),
        "-c:v",
        "libx264",
        "-pix_fmt",
        "yuv420p",
        "-movflags",
        "+faststart",
        whole.to_str().unwrap(),
    ]);
    let bytes = std::fs::read(&whole).unwrap();
    let cut = dir.path().join("cut.mp4");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let out = analyze(
        &Source::Video(cut),
        &options(),
        &dir.path().join("out"),
        &|_, _| {},
    )
    .unwrap();
    let t = out.input.truncation.as_ref().expect("truncation reported");
    assert_eq!(t.container_frames, Some(60));
    assert!(t.decoded < 60 && t.decoded == out.tracks.len());
    let (last, t_s) = t.last_good.unwrap();
    assert_eq!(last, t.decoded - 1);
    assert!((t_s - last as f64 / 30.0).abs() < 1e-3);
    assert_eq!(out.input.lost_to_truncation(), Some(60 - t.decoded));
    let text = t.to_string();
    assert!(
        text.contains("lists 60 frames") && text.contains(&format!("last good frame {last}")),
        "{text}"
    );
    // Recorded beside the results, not only on the terminal.
    let note = std::fs::read_to_string(dir.path().join("out").join("truncated_video.txt"))
        .expect("truncated_video.txt");
    assert!(
        note.contains(&text) && note.contains(&format!("{} frames lost", 60 - t.decoded)),
        "{note}"
    );
    // The whole file is not truncated.
    let whole_out = analyze(
        &Source::Video(whole),
        &options(),
        &dir.path().join("out2"),
        &|_, _| {},
    )
    .unwrap();
    assert!(whole_out.input.truncation.is_none());
    assert!(!dir.path().join("out2").join("truncated_video.txt").exists());
    assert_eq!(whole_out.tracks.len(), 60);
}

#[test]
fn a_frame_sequence_numbered_from_its_start_keeps_its_numbers() {
    // `geneva render --frames 5..65`-style output: timestamps numbered from 5.
    let dir = tempfile::tempdir().unwrap();
    let frames = copy_frames(dir.path());
    let ts = std::fs::read_to_string(frames.join("timestamps.csv")).unwrap();
    let renumbered: Vec<String> = ts
        .lines()
        .enumerate()
        .map(|(k, l)| match k {
            0 => l.to_string(),
            _ => {
                let (f, t) = l.split_once(',').unwrap();
                format!("{},{t}", f.parse::<usize>().unwrap() + 5)
            }
        })
        .collect();
    std::fs::write(frames.join("timestamps.csv"), renumbered.join("\n") + "\n").unwrap();
    let out = analyze_frames(&frames, &dir.path().join("out"));
    assert_eq!(out.tracks[0].frame, 5);
    assert_eq!(out.input.first_frame, 5);
    assert_eq!(out.input.last_frame, 64);
}

/// The clean track with its rows rewritten by `edit` (row → new line, or none to drop it).
fn edited_tracks(dir: &Path, name: &str, edit: impl Fn(usize, &str) -> Option<String>) -> PathBuf {
    let text = std::fs::read_to_string(clean_tracks()).unwrap();
    let mut lines = text.lines();
    let mut out = vec![lines.next().unwrap().to_string()];
    out.extend(lines.enumerate().filter_map(|(k, l)| edit(k, l)));
    let path = dir.join(name);
    std::fs::write(&path, out.join("\n") + "\n").unwrap();
    path
}

/// The crank speed scale the diagnosis aligns to the track at `tracks`.
fn aligned_speed_scale(tracks: &Path, work: &Path) -> f64 {
    use geneva_vision::diagnose::image;
    use geneva_vision::diagnose::nominal;
    use geneva_vision::pipeline::diagnose::{real, simulate::RenderDetect};
    let s = fast();
    let layout = image::marker_layout(&s).unwrap();
    let m = real::measure_real(
        &s,
        &Source::Tracks(tracks.into()),
        &layout,
        work,
        &|_, _| {},
    )
    .unwrap();
    let speed = nominal::align(&s, &m.record, &m.estimate, &layout, &RenderDetect)
        .unwrap()
        .motion
        .speed_scale;
    assert_eq!(
        m.record.frames.len(),
        m.estimate.frames,
        "speed scale {speed}: the estimate is not row by row"
    );
    speed
}

#[test]
fn a_decimated_track_is_timed_by_its_times_not_by_its_row_numbers() {
    // Every other row of a clean track, frame numbers and times kept, gave the diagnosis a
    // crank speed of 0.499× (clean 1.002×): its estimate held a placeholder per absent frame
    // number and was paired with the rows by position. So did frame numbers doubled with the
    // times unchanged.
    let dir = tempfile::tempdir().unwrap();
    let clean_path = clean_tracks();
    let clean_speed = aligned_speed_scale(&clean_path, &dir.path().join("clean"));
    let decimated = edited_tracks(dir.path(), "decimated.csv", |k, l| {
        (k % 2 == 0).then(|| l.to_string())
    });
    let doubled = edited_tracks(dir.path(), "doubled.csv", |_, l| {
        let (frame, rest) = l.split_once(',').unwrap();
        Some(format!("{},{rest}", 2 * frame.parse::<usize>().unwrap()))
    });
    for (name, path) in [("decimated", &decimated), ("doubled", &doubled)] {
        let speed = aligned_speed_scale(path, &dir.path().join(name));
        assert!(
            (speed / clean_speed - 1.0).abs() < 0.02,
            "{name}: speed scale {speed}, clean {clean_speed}"
        );
        // The analysis's estimate at the rows is the row-by-row one.
        let out = analyze(
            &Source::Tracks(path.clone()),
            &options(),
            &dir.path().join(format!("{name}-out")),
            &|_, _| {},
        )
        .unwrap();
        let rows = out.estimate_at_rows();
        assert_eq!(rows.frames, out.tracks.len());
        let t: Vec<f64> = out.tracks.iter().map(|r| r.t_s).collect();
        assert_eq!(rows.t_used_s, t, "{name}");
    }
    // Numbers that skip frames the times have no room for are said; honest gaps are not.
    let read = |p: &Path| read_tracks(p, Some(0)).unwrap();
    use geneva_vision::pipeline::analyze::numbering_mismatch;
    assert_eq!(numbering_mismatch(&read(&clean_path)), None);
    assert_eq!(
        numbering_mismatch(&read(&decimated)).map(|m| m.frame_interval_s),
        Some(None)
    );
    let half_doubled = edited_tracks(dir.path(), "half.csv", |k, l| {
        let (frame, rest) = l.split_once(',').unwrap();
        let f: usize = frame.parse().unwrap();
        Some(format!("{},{rest}", if k < 30 { f } else { 2 * f - 29 }))
    });
    let m = numbering_mismatch(&read(&half_doubled)).expect("a mismatch");
    assert_eq!((m.steps, m.first.0, m.first.1), (30, 29, 31));
    let text = m.to_string();
    assert!(
        text.contains("frame 29 → 31") && text.contains("time base"),
        "{text}"
    );
}
