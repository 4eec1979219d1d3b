//! All file formats in one place: CSV tables, PNG frames, images and video in (ffmpeg), JSON.
//!
//! Architecture invariant: the pure core never opens a file; it hands rows and images to this
//! module. Every error names the file (and the row or frame where there is one).

pub mod csv_out;
pub mod images;
pub mod json;
pub mod kinematics_csv;
pub mod output_dir;
pub mod png_out;
pub mod texture_png;
pub mod timing_log;
pub mod tracks_csv;
pub mod truth_csv;
pub mod video;
pub mod video_codec;
pub mod video_out;
