//! The footage's video codec read from its container: the codec, the bitrate, the group of
//! pictures and the B-frames, as `effects.video_codec` states them. Nothing here is fitted to
//! pixels: each value is what the stream says, and the reading says where it came from.
//!
//! Why it is written switched off: the noise, blur and levels `calibrate` fits are measured on
//! the decoded footage, so they already hold what the codec did to them; drawing the codec on
//! top would apply it twice. The reading tells the user (and the diagnosis) how the footage was
//! coded, and a scenario that models the sensor before the codec can switch it on.

use crate::render::effects::{VideoCodec, VideoCodecConfig};

/// How the footage was coded, with where each value came from.
#[derive(Debug, Clone, PartialEq)]
pub struct CodecReading {
    /// The values, `enabled = false` (see the module's note).
    pub config: VideoCodecConfig,
    /// Where each value came from, one sentence.
    pub how: String,
}

/// The coding of a stream: `codec_name`, the stream's and the file's `bit_rate` (bit/s) and each
/// frame's picture type (`I`, `P`, `B`, `?`). `Err` says why no reading can be made.
pub fn read_codec(
    codec_name: Option<&str>,
    stream_bit_rate_bps: Option<f64>,
    file_bit_rate_bps: Option<f64>,
    picture_types: &str,
) -> Result<CodecReading, String> {
    let name = codec_name.ok_or("the container names no codec")?;
    let codec = VideoCodec::from_ffprobe_name(name).ok_or_else(|| {
        format!("`{name}` is not a codec `effects.video_codec` draws (h264, hevc)")
    })?;
    let (bitrate_bps, rate_from) = match (stream_bit_rate_bps, file_bit_rate_bps) {
        (Some(b), _) => (b, "the video stream's bit_rate"),
        (None, Some(b)) => (
            b,
            "the file's bit_rate (no stream bit_rate; it includes any audio)",
        ),
        (None, None) => return Err("the container states no bitrate".into()),
    };
    let types: Vec<char> = picture_types.chars().collect();
    let keys: Vec<usize> = (0..types.len()).filter(|&i| types[i] == 'I').collect();
    let (gop_frames, gop_from) = match keys.as_slice() {
        [] => return Err("no frame is marked as a key frame (picture type I)".into()),
        [_] => (
            types.len().clamp(1, 1000),
            format!("one key frame in {} frames: at least the clip", types.len()),
        ),
        _ => {
            let mut gaps: Vec<usize> = keys.windows(2).map(|w| w[1] - w[0]).collect();
            gaps.sort_unstable();
            (
                gaps[gaps.len() / 2].clamp(1, 1000),
                format!("median distance between {} key frames", keys.len()),
            )
        }
    };
    let b_frames = types
        .split(|&t| t != 'B')
        .map(|run| run.len())
        .max()
        .unwrap_or(0)
        .min(16);
    let unknown = types.iter().filter(|&&t| t == '?').count();
    let config = VideoCodecConfig {
        enabled: false,
        codec,
        bitrate_bps: Some(bitrate_bps.clamp(1e4, 1e9)),
        gop_frames: gop_frames as u32,
        b_frames: b_frames as u32,
        ..Default::default()
    };
    let mut how = format!(
        "{name} at {:.2} Mbit/s ({rate_from}), a key frame every {gop_frames} frames \
         ({gop_from}), up to {b_frames} consecutive B-frames, from ffprobe's picture types; \
         preset {} assumed (a stream does not record it)",
        bitrate_bps / 1e6,
        config.preset
    );
    if unknown > 0 {
        how.push_str(&format!(
            "; {unknown} of {} frames state no picture type",
            types.len()
        ));
    }
    Ok(CodecReading { config, how })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_phone_clip_reads_as_its_codec_bitrate_group_and_b_frames() {
        let types = "IPBBPBBPBBPIPBBPBBPBBPIPBBP";
        let r = read_codec(Some("h264"), Some(1.6e7), Some(1.7e7), types).unwrap();
        assert_eq!(r.config.codec, VideoCodec::H264);
        assert_eq!(r.config.bitrate_bps, Some(1.6e7));
        assert_eq!(r.config.gop_frames, 11);
        assert_eq!(r.config.b_frames, 2);
        assert!(!r.config.enabled);
        assert!(
            r.how.contains("16.00 Mbit/s (the video stream's bit_rate)"),
            "{}",
            r.how
        );
        assert!(
            r.how.contains("median distance between 3 key frames"),
            "{}",
            r.how
        );
    }

    #[test]
    fn one_key_frame_and_the_file_rate_say_so() {
        let r = read_codec(Some("hevc"), None, Some(8e6), "IPPPPPPP?P").unwrap();
        assert_eq!(r.config.codec, VideoCodec::Hevc);
        assert_eq!(r.config.gop_frames, 10);
        assert_eq!(r.config.b_frames, 0);
        assert!(r.how.contains("the file's bit_rate"), "{}", r.how);
        assert!(r.how.contains("one key frame in 10 frames"), "{}", r.how);
        assert!(
            r.how.contains("1 of 10 frames state no picture type"),
            "{}",
            r.how
        );
    }

    #[test]
    fn what_cannot_be_read_says_why() {
        let e = read_codec(Some("mjpeg"), Some(1e7), None, "IIII").unwrap_err();
        assert!(e.contains("`mjpeg` is not a codec"), "{e}");
        let e = read_codec(Some("h264"), None, None, "IPPP").unwrap_err();
        assert!(e.contains("no bitrate"), "{e}");
        let e = read_codec(Some("h264"), Some(1e7), None, "PPPP").unwrap_err();
        assert!(e.contains("no frame is marked as a key frame"), "{e}");
        assert!(read_codec(None, Some(1e7), None, "I").is_err());
    }
}
