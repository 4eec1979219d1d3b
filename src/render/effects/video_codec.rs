//! Video codec: the whole clip encoded as a phone records it (H.264 or HEVC, a bitrate or a
//! constant quality, a fixed group of pictures with B-frames) and decoded back, after 8-bit
//! quantisation. This file owns the configuration and the ffmpeg command lines; the encoding
//! itself runs at the I/O edge (`crate::io::video_codec`), because it is a property of the whole
//! sequence, not of one frame.
//!
//! Why fixed arguments: x264 and x265 are bit-exact for a given input and command line when run
//! on one thread, so a scenario with a codec keeps "same inputs and seed → same frames". The
//! group of pictures is fixed (no scene-cut key frames), as a phone's hardware encoder keeps it.
//! Grey frames go in as 4:2:0 with a neutral chroma in the limited (16–235) luma range, as a
//! phone's recording is; the round trip therefore also requantises the levels.

use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

/// The encoder a phone's recording uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VideoCodec {
    /// H.264 / AVC (ffmpeg's libx264).
    H264,
    /// H.265 / HEVC (ffmpeg's libx265).
    Hevc,
}

impl VideoCodec {
    /// The codec's name as ffprobe reports it (`codec_name`).
    pub fn ffprobe_name(self) -> &'static str {
        match self {
            VideoCodec::H264 => "h264",
            VideoCodec::Hevc => "hevc",
        }
    }

    /// The codec of an ffprobe `codec_name`, if it is one this effect draws.
    pub fn from_ffprobe_name(name: &str) -> Option<Self> {
        match name {
            "h264" => Some(VideoCodec::H264),
            "hevc" => Some(VideoCodec::Hevc),
            _ => None,
        }
    }
}

/// The encoder presets of x264 and x265 (speed against efficiency), fastest first.
pub const PRESETS: [&str; 9] = [
    "ultrafast",
    "superfast",
    "veryfast",
    "faster",
    "fast",
    "medium",
    "slow",
    "slower",
    "veryslow",
];

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VideoCodecConfig {
    /// Encode and decode the clip. Default: false.
    pub enabled: bool,
    /// `h264` or `hevc`. Default: `h264`.
    pub codec: VideoCodec,
    /// Average bitrate, bit/s, in [1e4, 1e9] (a phone's 1080p recording: about 1.6e7). When
    /// absent the encoder holds a constant quality, `crf`. Default: absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bitrate_bps: Option<f64>,
    /// Constant rate factor when no bitrate is given, in [0, 51] (lower is better; 0 is lossless
    /// in x264). Default: 23.
    pub crf: f64,
    /// Frames from one key frame to the next, in [1, 1000]. Default: 30.
    pub gop_frames: u32,
    /// Consecutive B-frames at most, in [0, 16]. Default: 2.
    pub b_frames: u32,
    /// Encoder preset, one of [`PRESETS`]. Default: `medium`.
    pub preset: String,
}

impl Default for VideoCodecConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            codec: VideoCodec::H264,
            bitrate_bps: None,
            crf: 23.0,
            gop_frames: 30,
            b_frames: 2,
            preset: "medium".into(),
        }
    }
}

impl VideoCodecConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        if let Some(b) = self.bitrate_bps {
            problems.range(join(path, "bitrate_bps"), b, 1e4, 1e9);
        }
        problems.range(join(path, "crf"), self.crf, 0.0, 51.0);
        problems.range(
            join(path, "gop_frames"),
            self.gop_frames as f64,
            1.0,
            1000.0,
        );
        problems.range(join(path, "b_frames"), self.b_frames as f64, 0.0, 16.0);
        if !PRESETS.contains(&self.preset.as_str()) {
            problems.push(
                join(path, "preset"),
                format!(
                    "`{}` is not a preset; one of {}",
                    self.preset,
                    PRESETS.join(", ")
                ),
            );
        }
    }

    /// Off with the default values (how a scenario without the table reads).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// ffmpeg's arguments that read `width_px` × `height_px` grey frames on stdin at
    /// `nominal_fps` (the rate the bitrate is spread over) and write the raw bitstream on stdout.
    pub fn encoder_args(&self, width_px: usize, height_px: usize, nominal_fps: f64) -> Vec<String> {
        let mut a: Vec<String> = [
            "-hide_banner",
            "-nostdin",
            "-loglevel",
            "error",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "gray",
            "-s",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        a.push(format!("{width_px}x{height_px}"));
        a.push("-framerate".into());
        a.push(format!("{nominal_fps}"));
        a.extend(["-i", "pipe:0", "-an", "-pix_fmt", "yuv420p"].map(String::from));
        let gop = self.gop_frames;
        match self.codec {
            VideoCodec::H264 => {
                a.extend(["-c:v", "libx264", "-threads", "1"].map(String::from));
                a.extend(["-preset".into(), self.preset.clone()]);
                a.extend([
                    "-g".into(),
                    gop.to_string(),
                    "-keyint_min".into(),
                    gop.to_string(),
                ]);
                a.extend(["-sc_threshold".into(), "0".into()]);
                a.extend(["-bf".into(), self.b_frames.to_string()]);
                a.extend(self.rate_args());
                a.extend(["-f", "h264", "pipe:1"].map(String::from));
            }
            VideoCodec::Hevc => {
                a.extend(["-c:v", "libx265"].map(String::from));
                a.extend(["-preset".into(), self.preset.clone()]);
                a.push("-x265-params".into());
                a.push(format!(
                    "pools=none:frame-threads=1:log-level=error:keyint={gop}:min-keyint={gop}:\
                     scenecut=0:bframes={}",
                    self.b_frames
                ));
                a.extend(self.rate_args());
                a.extend(["-f", "hevc", "pipe:1"].map(String::from));
            }
        }
        a
    }

    fn rate_args(&self) -> Vec<String> {
        match self.bitrate_bps {
            Some(b) => vec!["-b:v".into(), format!("{}", b.round() as u64)],
            None => vec!["-crf".into(), format!("{}", self.crf)],
        }
    }

    /// ffmpeg's arguments that read this codec's raw bitstream on stdin and write grey frames on
    /// stdout.
    pub fn decoder_args(&self) -> Vec<String> {
        let demuxer = self.codec.ffprobe_name();
        [
            "-hide_banner",
            "-nostdin",
            "-loglevel",
            "error",
            "-threads",
            "1",
            "-f",
            demuxer,
            "-i",
            "pipe:0",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "gray",
            "pipe:1",
        ]
        .map(String::from)
        .to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_off() {
        let c = VideoCodecConfig::default();
        let mut p = Problems::new();
        c.validate("effects.video_codec", &mut p);
        assert!(p.is_empty(), "{p:?}");
        assert!(c.is_default() && !c.enabled);
    }

    #[test]
    fn bad_values_name_their_fields() {
        let c = VideoCodecConfig {
            bitrate_bps: Some(5.0),
            crf: 60.0,
            gop_frames: 0,
            b_frames: 17,
            preset: "quick".into(),
            ..Default::default()
        };
        let mut p = Problems::new();
        c.validate("effects.video_codec", &mut p);
        let fields: Vec<&str> = p.iter().map(|x| x.field.as_str()).collect();
        for f in ["bitrate_bps", "crf", "gop_frames", "b_frames", "preset"] {
            let f = format!("effects.video_codec.{f}");
            assert!(fields.contains(&f.as_str()), "{f} missing from {fields:?}");
        }
    }

    #[test]
    fn a_bitrate_replaces_the_constant_quality_and_the_group_is_fixed() {
        let mut c = VideoCodecConfig::default();
        let args = c.encoder_args(64, 48, 30.0).join(" ");
        assert!(args.contains("-crf 23") && !args.contains("-b:v"), "{args}");
        assert!(
            args.contains("-g 30 -keyint_min 30 -sc_threshold 0 -bf 2"),
            "{args}"
        );
        assert!(args.contains("-s 64x48 -framerate 30 -i pipe:0"), "{args}");
        c.bitrate_bps = Some(8e6);
        let args = c.encoder_args(64, 48, 30.0).join(" ");
        assert!(
            args.contains("-b:v 8000000") && !args.contains("-crf"),
            "{args}"
        );
        c.codec = VideoCodec::Hevc;
        c.b_frames = 0;
        let args = c.encoder_args(64, 48, 30.0).join(" ");
        assert!(args.contains("libx265"), "{args}");
        assert!(
            args.contains("keyint=30:min-keyint=30:scenecut=0:bframes=0"),
            "{args}"
        );
        assert!(c.decoder_args().join(" ").contains("-f hevc -i pipe:0"));
    }

    #[test]
    fn the_codec_reads_back_from_its_toml_and_ffprobe_names() {
        let c: VideoCodecConfig =
            toml::from_str("enabled = true\ncodec = \"hevc\"\nbitrate_bps = 1.6e7\n").unwrap();
        assert_eq!(c.codec, VideoCodec::Hevc);
        assert_eq!(c.bitrate_bps, Some(1.6e7));
        assert_eq!(
            VideoCodec::from_ffprobe_name("hevc"),
            Some(VideoCodec::Hevc)
        );
        assert_eq!(VideoCodec::from_ffprobe_name("mjpeg"), None);
        assert!(toml::from_str::<VideoCodecConfig>("codec = \"vp9\"\n").is_err());
    }
}
