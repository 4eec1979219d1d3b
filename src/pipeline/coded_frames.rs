//! Frames of a rig whose scenario records through a video codec (`effects.video_codec`): the
//! whole clip rendered in parallel chunks, encoded in frame order, decoded, and the frames of the
//! requested range handed on in order.
//!
//! Why the whole clip: the encoder's key frames, B-frames and rate control depend on every frame
//! around the one asked for, so a part of a clip decodes exactly as in the whole one only when
//! the whole clip was encoded. Every frame is whole (the codec predicts across the image), so
//! the region-of-interest renderer does not apply here.

use super::rig::Rig;
use crate::io::video_codec::{CodecError, Encoder};
use crate::render::FrameBuffers;
use rayon::prelude::*;

/// Draws frame `index` whole, row-major grey, into a new buffer (`FrameBuffers` are per thread).
pub type RenderWhole<'a, E> = dyn Fn(usize, &mut FrameBuffers) -> Result<Vec<u8>, E> + Sync + 'a;

/// Renders every frame of `rig` with `render`, `chunk_frames` at a time, through the codec, and
/// calls `sink(index, pixels)` for each frame of `range` in order. Memory holds one chunk of
/// frames and the clip's bitstream.
pub fn through_codec<E: From<CodecError> + Send>(
    rig: &Rig,
    render: &RenderWhole<'_, E>,
    range: std::ops::Range<usize>,
    chunk_frames: usize,
    sink: &mut dyn FnMut(usize, Vec<u8>) -> Result<(), E>,
) -> Result<(), E> {
    let cfg = &rig.scenario.effects.video_codec;
    let (w, h) = (rig.settings.width_px, rig.settings.height_px);
    let count = rig.frame_times.len();
    let mut encoder = Encoder::start(cfg, w, h, rig.scenario.frame_timing.fps)?;
    let chunk = chunk_frames.max(1);
    for start in (0..count).step_by(chunk) {
        let end = (start + chunk).min(count);
        let images: Vec<Result<Vec<u8>, E>> = (start..end)
            .into_par_iter()
            .map_init(FrameBuffers::default, |buffers, i| render(i, buffers))
            .collect();
        for image in images {
            encoder.write_frame(&image?)?;
        }
    }
    let encoded = encoder.finish()?;
    let mut decoder = encoded.decode()?;
    let mut index = 0;
    while let Some(frame) = decoder.next_frame()? {
        if range.contains(&index) {
            sink(index, frame)?;
        }
        index += 1;
    }
    Ok(())
}
