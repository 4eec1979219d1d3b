//! The diagnosis's [`Simulator`]: a scenario rendered and measured through the same code as
//! `geneva run` (its rig, the frame loop's render → detect), with the image statistics around
//! the marker read from the same frames.

use crate::diagnose::image::{frame_image, measures_image};
use crate::diagnose::record::{FrameRecord, Record};
use crate::diagnose::simulator::{SimulateError, Simulator};
use crate::imagestats::MarkerLayout;
use crate::pipeline::frames::{detect_and_inspect_frames, FrameLoopOptions};
use crate::pipeline::rig::Rig;
use crate::scenario::Scenario;

/// Render → detect, frames in parallel (the frame loop's own scheduling).
#[derive(Debug, Clone, Copy, Default)]
pub struct RenderDetect;

impl Simulator for RenderDetect {
    fn record(
        &self,
        scenario: &Scenario,
        layout: &MarkerLayout,
        with_images: bool,
    ) -> Result<Record, SimulateError> {
        let rig = Rig::new(scenario).map_err(|e| SimulateError::Rig(Box::new(e)))?;
        let n = rig.frame_times.len();
        let mut frames: Vec<FrameRecord> = Vec::with_capacity(n);
        detect_and_inspect_frames(
            &rig,
            0..n,
            FrameLoopOptions::default(),
            &|view, det| {
                det.corners_px
                    .filter(|_| with_images && measures_image(det.frame, n))
                    .map(|c| frame_image(view, &c, layout))
            },
            |chunk| {
                frames.extend(chunk.iter().map(|(d, img)| FrameRecord {
                    t_s: d.t_s,
                    corners_px: d.corners_px,
                    reference_px: d.reference_px,
                    image: *img,
                }));
                Ok(())
            },
            &|_| {},
        )
        .map_err(|e| SimulateError::Frames(Box::new(e)))?;
        Ok(Record {
            frames,
            has_images: with_images,
            has_reference: scenario.scene.reference_marker.enabled
                && scenario.detector.reference_marker_id.is_some(),
        })
    }
}
