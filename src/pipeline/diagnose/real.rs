//! The real measurement: detection and estimation through the same code as `geneva analyze`
//! (the nominal scenario's detector and estimator), then one more pass over the frames for the
//! image statistics around each detected marker. No truth exists here.

use super::DiagnoseError;
use crate::detect::GrayView;
use crate::diagnose::image::{frame_image, measures_image};
use crate::diagnose::record::{FrameRecord, RealMeasurement, Record};
use crate::imagestats::MarkerLayout;
use crate::io::tracks_csv::TrackRow;
use crate::pipeline::analyze::{analyze, AnalyzeOptions, Source};
use crate::scenario::Scenario;
use std::path::Path;

/// Fewest detected frames a diagnosis needs.
pub const MIN_DETECTED_FRAMES: usize = 30;

/// Size of the first frame of `source` (none for a corner track).
fn first_frame_size(source: &Source) -> Result<Option<(usize, usize)>, DiagnoseError> {
    match source {
        Source::Tracks(_) => Ok(None),
        Source::Frames { dir, .. } => {
            let files = crate::io::images::list_image_files(dir).map_err(DiagnoseError::from)?;
            let first = files
                .first()
                .ok_or_else(|| DiagnoseError::NoFrames { dir: dir.clone() })?;
            let img = crate::io::images::read_gray(first).map_err(DiagnoseError::from)?;
            Ok(Some((img.width, img.height)))
        }
        Source::Video(path) => {
            let info = crate::io::video::probe(path).map_err(DiagnoseError::from)?;
            Ok(Some((info.width_px, info.height_px)))
        }
    }
}

/// Checks what can be checked before any long work: the frame size against the nominal camera.
pub fn check_source(nominal: &Scenario, source: &Source) -> Result<(), DiagnoseError> {
    if let Some((w, h)) = first_frame_size(source)? {
        let (cw, ch) = (
            nominal.camera.width_px as usize,
            nominal.camera.height_px as usize,
        );
        if (w, h) != (cw, ch) {
            return Err(DiagnoseError::FrameSize {
                width_px: w,
                height_px: h,
                camera_width_px: cw,
                camera_height_px: ch,
            });
        }
    }
    Ok(())
}

fn too_few(d: &crate::detect::DetectorConfig, detected: usize, frames: usize) -> DiagnoseError {
    if detected == 0 {
        DiagnoseError::MarkerNeverFound {
            marker_id: d.marker_id,
            dictionary: d.dictionary.clone(),
            frames,
        }
    } else {
        DiagnoseError::TooFewDetections {
            detected,
            frames,
            needed: MIN_DETECTED_FRAMES,
        }
    }
}

/// Runs detection and estimation on `source` (files of `geneva analyze` go to `work_dir`) and
/// the image pass; errors when the marker is never found or found in too few frames.
pub fn measure_real(
    nominal: &Scenario,
    source: &Source,
    layout: &MarkerLayout,
    work_dir: &Path,
    progress: &dyn Fn(usize, usize),
) -> Result<RealMeasurement, DiagnoseError> {
    check_source(nominal, source)?;
    let options = AnalyzeOptions::from_scenario(nominal, 1.0);
    let d = &nominal.detector;
    let out = match analyze(source, &options, work_dir, progress) {
        Ok(out) => out,
        // Too few detections for an estimate: say how many, in the diagnosis' terms (the
        // tracks file named by the error lies in a folder that is not kept).
        Err(crate::pipeline::analyze::AnalyzeError::Estimate {
            frames,
            tracks,
            source,
        }) => {
            let detected = crate::io::tracks_csv::read_tracks(&tracks, None)
                .map(|rows| rows.iter().filter(|r| r.corners_px.is_some()).count())
                .unwrap_or(0);
            // Enough detections that cannot be estimated (a marker that hardly moves): the
            // estimate's own reason, not a count that is no shortfall.
            if detected >= MIN_DETECTED_FRAMES {
                return Err(DiagnoseError::RealEstimate {
                    detected,
                    frames,
                    source,
                });
            }
            return Err(too_few(d, detected, frames));
        }
        Err(e) => return Err(DiagnoseError::Measure(Box::new(e))),
    };
    let detected = out.tracks.iter().filter(|r| r.corners_px.is_some()).count();
    if detected < MIN_DETECTED_FRAMES {
        return Err(too_few(d, detected, out.tracks.len()));
    }
    if let Some((frame, t_s)) = out
        .tracks
        .iter()
        .find(|r| r.t_s < 0.0)
        .map(|r| (r.frame, r.t_s))
    {
        return Err(DiagnoseError::NegativeFrameTime { frame, t_s });
    }
    let has_reference =
        nominal.detector.reference_marker_id.is_some() && nominal.scene.reference_marker.enabled;
    let mut frames: Vec<FrameRecord> = out
        .tracks
        .iter()
        .map(|r: &TrackRow| FrameRecord {
            t_s: r.t_s,
            corners_px: r.corners_px,
            reference_px: r.reference_px,
            image: None,
        })
        .collect();
    let has_images = !matches!(source, Source::Tracks(_));
    if has_images {
        image_pass(source, layout, &mut frames)?;
    }
    Ok(RealMeasurement {
        record: Record {
            frames,
            has_images,
            has_reference,
        },
        // Row by row, as `frames`: the analysis's own estimate also holds placeholders for
        // frame numbers absent from a track.
        estimate: out.estimate_at_rows(),
    })
}

/// Decodes the frames again and measures the image statistics where the marker was found.
fn image_pass(
    source: &Source,
    layout: &MarkerLayout,
    frames: &mut [FrameRecord],
) -> Result<(), DiagnoseError> {
    let n = frames.len();
    let mut visit = |k: usize, data: &[u8], w: usize, h: usize| {
        if !measures_image(k, n) {
            return;
        }
        if let Some(f) = frames.get_mut(k) {
            if let Some(c) = f.corners_px {
                f.image = Some(frame_image(GrayView::full(data, w, h), &c, layout));
            }
        }
    };
    match source {
        Source::Frames { dir, .. } => {
            let files = crate::io::images::list_image_files(dir).map_err(DiagnoseError::from)?;
            for (k, file) in files.iter().enumerate() {
                if !measures_image(k, n) {
                    continue;
                }
                // Frames that cannot be read again were already counted by the detection pass.
                if let Ok(img) = crate::io::images::read_gray(file) {
                    visit(k, &img.data, img.width, img.height);
                }
            }
        }
        Source::Video(path) => {
            let mut v = crate::io::video::VideoFrames::open(path).map_err(DiagnoseError::from)?;
            let (w, h) = (v.info().width_px, v.info().height_px);
            while let Ok(Some(f)) = v.next_frame() {
                visit(f.index, &f.data, w, h);
            }
        }
        Source::Tracks(_) => {}
    }
    Ok(())
}
