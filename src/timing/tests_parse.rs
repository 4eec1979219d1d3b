//! Parser tests on small hand-written logs covering the awkward cases of each format.

use super::*;

const SI: &str = "[Parsed_showinfo_0 @ 0000023884038e40]";

fn showinfo_line(n: u32, pts_time: &str) -> String {
    format!("{SI} n:{n:>4} pts:  {n}000 pts_time:{pts_time:<8} pos: 1 fmt:yuv420p sar:1/1 s:2160x3840 i:P iskey:0 type:P checksum:947DD192 plane_checksum:[F0D0B9C1] mean:[108 118 144 ] stdev:[54.8 12.4 19.7 ]")
}

#[test]
fn showinfo_whole_second_interleaved_crlf_and_garbage() {
    let text = format!(
        "Input #0, mov, from 'x.mp4':\r\n{SI} config in time_base: 1/90000, frame_rate: 179/6\r\n{}\r\n{SI} color_range:tv color_space:unknown\r\nframe=    1 fps=0.0 q=0.0 size=N/A speed=   0x    {}\r\n{}\rframe=    3 fps=5.8 q=-0.0 size=N/A dup=1 drop=0 speed=0.0386x    {}\r\n[out#0/image2 @ 000001] video:1kB trailing garbage pts_time:zz\r\n",
        showinfo_line(0, "0"),
        showinfo_line(1, "0.5"),
        showinfo_line(2, "1"),
        showinfo_line(3, "1.0333"),
    );
    let ts = parse_showinfo(&text).unwrap();
    assert_eq!(ts.as_slice(), &[0.0, 0.5, 1.0, 1.0333]);
    assert_eq!(load_from_text(LogFormat::Showinfo, &text).unwrap(), ts);
}

#[test]
fn showinfo_frames_out_of_order_are_sorted_by_n() {
    let text = [
        showinfo_line(1, "0.1"),
        showinfo_line(0, "0"),
        showinfo_line(2, "0.2"),
    ]
    .join("\n");
    assert_eq!(parse_showinfo(&text).unwrap().as_slice(), &[0.0, 0.1, 0.2]);
}

#[test]
fn showinfo_malformed_frame_line_names_the_line() {
    let text = format!(
        "header\n{}\n{}\n",
        showinfo_line(0, "0"),
        showinfo_line(1, "0.0x3")
    );
    let err = parse_showinfo(&text).unwrap_err();
    assert!(matches!(err, TimingError::Parse { line: 3, .. }), "{err:?}");
    assert!(
        err.to_string().contains("line 3") && err.to_string().contains("0.0x3"),
        "{err}"
    );
    let truncated = format!("{}\n{SI} n:   1 pts:  3000 pts_", showinfo_line(0, "0"));
    let err = parse_showinfo(&truncated).unwrap_err();
    assert!(matches!(err, TimingError::Parse { line: 2, .. }), "{err:?}");
}

#[test]
fn showinfo_missing_or_duplicate_n_is_reported() {
    let gap = [showinfo_line(0, "0"), showinfo_line(2, "0.2")].join("\n");
    let err = parse_showinfo(&gap).unwrap_err();
    assert!(err.to_string().contains("frame 1 is missing"), "{err}");
    let dup = [
        showinfo_line(0, "0"),
        showinfo_line(1, "0.1"),
        showinfo_line(1, "0.2"),
    ]
    .join("\n");
    let err = parse_showinfo(&dup).unwrap_err();
    assert!(
        err.to_string().contains("frame 1 appears more than once"),
        "{err}"
    );
    assert!(parse_showinfo("no frames here\n").is_err());
}

#[test]
fn showinfo_backwards_and_repeated_times_name_the_frame() {
    let back = [
        showinfo_line(0, "0"),
        showinfo_line(1, "0.2"),
        showinfo_line(2, "0.1"),
    ]
    .join("\n");
    let err = parse_showinfo(&back).unwrap_err();
    assert_eq!(
        err,
        TimingError::Backwards {
            frame: 2,
            previous_s: 0.2,
            value_s: 0.1
        }
    );
    let rep = [
        showinfo_line(0, "0"),
        showinfo_line(1, "1"),
        showinfo_line(2, "1.0"),
    ]
    .join("\n");
    let err = parse_showinfo(&rep).unwrap_err();
    assert_eq!(
        err,
        TimingError::Repeated {
            frame: 2,
            previous_s: 1.0,
            value_s: 1.0
        }
    );
}

#[test]
fn ffprobe_csv_variants() {
    let plain = "0.000000\r\n0.033367\r\n1\r\n\r\n";
    assert_eq!(
        parse_ffprobe_csv(plain).unwrap().as_slice(),
        &[0.0, 0.033367, 1.0]
    );
    let tagged = "frame,0.0\nside_data,Display Matrix\nframe,0.0333\nframe,0.0667,0.0667\n";
    assert_eq!(
        load_from_text(LogFormat::FfprobeCsv, tagged)
            .unwrap()
            .as_slice(),
        &[0.0, 0.0333, 0.0667]
    );
    let bad = "0.0\nN/A\n";
    let err = parse_ffprobe_csv(bad).unwrap_err();
    assert!(matches!(err, TimingError::Parse { line: 2, .. }), "{err:?}");
    let back = "0.0\n0.1\n0.05\n";
    assert!(matches!(
        parse_ffprobe_csv(back),
        Err(TimingError::Backwards { frame: 2, .. })
    ));
}

#[test]
fn ffprobe_json_variants() {
    let text = r#"{"frames":[{"media_type":"video","pts_time":"0.000000"},
        {"media_type":"audio","pts_time":"0.010000"},
        {"best_effort_timestamp_time":"0.033"},{"pts_time":1}]}"#;
    assert_eq!(
        load_from_text(LogFormat::FfprobeJson, text)
            .unwrap()
            .as_slice(),
        &[0.0, 0.033, 1.0]
    );
    let missing = r#"{"frames":[{"pts_time":"0"},{"pkt_size":"5"}]}"#;
    assert!(parse_ffprobe_json(missing)
        .unwrap_err()
        .to_string()
        .contains("frames[1]"));
    assert!(parse_ffprobe_json("{\"frames\": [").is_err());
    let rep = r#"{"frames":[{"pts_time":"0.5"},{"pts_time":"0.5"}]}"#;
    assert!(matches!(
        parse_ffprobe_json(rep),
        Err(TimingError::Repeated { frame: 1, .. })
    ));
}

#[test]
fn frames_csv_requires_header_and_round_trips() {
    let ts = Timestamps::new(vec![0.0, 0.1 / 3.0, 0.0667, 1.0, 1e-9 + 1.0]).unwrap();
    let text = to_frames_csv(&ts);
    assert_eq!(parse_frames_csv(&text).unwrap(), ts);
    assert_eq!(
        load_from_text(LogFormat::FramesCsv, &text.replace('\n', "\r\n")).unwrap(),
        ts
    );
    let no_header = "0,0.0\n1,0.1\n";
    assert!(matches!(
        parse_frames_csv(no_header),
        Err(TimingError::Parse { line: 1, .. })
    ));
    let skipped = "frame,t_s\n0,0.0\n2,0.1\n";
    assert!(matches!(
        parse_frames_csv(skipped),
        Err(TimingError::Parse { line: 3, .. })
    ));
    let nan = "frame,t_s\n0,0.0\n1,NaN\n";
    assert!(matches!(
        parse_frames_csv(nan),
        Err(TimingError::NotFinite { frame: 1, .. })
    ));
}

#[test]
fn log_format_names_match_serde() {
    for f in [
        LogFormat::Showinfo,
        LogFormat::ShowinfoPts,
        LogFormat::FfprobeCsv,
        LogFormat::FfprobeJson,
        LogFormat::FramesCsv,
    ] {
        assert_eq!(
            serde_json::to_string(&f).unwrap(),
            format!("\"{}\"", f.name())
        );
    }
}

#[test]
fn showinfo_pts_uses_time_base_and_requires_it() {
    let text = format!(
        "{SI} config in time_base: 1/90000, frame_rate: 179/6\r\n{}\r\nframe=  2 speed=1x   \r{}\r\n",
        showinfo_line(0, "0"),
        showinfo_line(3, "0.0333"),
    )
    .replace(" n:   3", " n:   1");
    // showinfo_line writes pts = n·1000, so frame "3" carries pts 3000 → 3000/90000 s.
    let ts = load_from_text(LogFormat::ShowinfoPts, &text).unwrap();
    assert_eq!(ts.as_slice(), &[0.0, 3000.0 / 90000.0]);
    let no_tb = [showinfo_line(0, "0"), showinfo_line(1, "0.1")].join("\n");
    let err = parse_showinfo_pts(&no_tb).unwrap_err();
    assert!(
        matches!(err, TimingError::Parse { line: 1, .. }) && err.to_string().contains("time_base"),
        "{err}"
    );
    let bad_tb = format!("{SI} config in time_base: 0/0, frame_rate: 0/0\n");
    assert!(matches!(
        parse_showinfo_pts(&bad_tb),
        Err(TimingError::Parse { line: 1, .. })
    ));
}
