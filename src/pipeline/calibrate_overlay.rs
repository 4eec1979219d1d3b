//! `overlay.png` of `geneva calibrate`: the footage's marker window beside the calibrated render
//! and what is left between them, with the re-render check's figures written under the panels.
//!
//! Panels, left to right: the footage; the calibrated render at the same instant (with its noise
//! and codec); 128 + 4·(footage − clean render); the aligned residual smoothed at 2 px, scaled so
//! that the noise model's smoothed residual looks as strong as the raw difference's noise
//! (structure the render misses stands out there, noise fades).

use super::calibrate::{CalibrateJobError, Crop};
use crate::calibrate::output::ReRenderCheck;
use crate::calibrate::residual::{white_noise_retention, Grid};
use crate::render::{GrayImage, PixelRect};
use plotters::prelude::*;
use std::path::Path;

/// What the overlay shows.
pub(crate) struct OverlayPanels<'a> {
    pub footage: &'a Crop,
    pub full: &'a GrayImage,
    pub clean: &'a GrayImage,
    /// The compared window (absolute), where `smoothed` lives.
    pub window: PixelRect,
    pub smoothed: &'a Grid,
}

/// Gain of the raw difference panel.
const DIFFERENCE_GAIN: f64 = 4.0;
const GAP_PX: usize = 8;
const LINE_PX: usize = 17;
/// The caption needs this much width for its longest lines.
const MIN_WIDTH_PX: usize = 1100;

pub(crate) fn write_overlay(
    path: &Path,
    p: &OverlayPanels<'_>,
    check: &ReRenderCheck,
) -> Result<(), CalibrateJobError> {
    let rect = p.footage.rect;
    let (w, h) = (rect.width, rect.height);
    let smooth_gain = DIFFERENCE_GAIN / white_noise_retention();
    let mut lines = vec![format!(
        "re-render check {} | footage | render | 128 + {DIFFERENCE_GAIN}·(footage − clean render) \
         | aligned residual smoothed at 2 px, 128 + {smooth_gain:.0}·(…)",
        if check.passed() { "passed" } else { "FAILED" }
    )];
    lines.extend(
        check
            .figure_lines()
            .into_iter()
            .map(|(text, ok)| format!("{} {text}", if ok { "ok  " } else { "FAIL" })),
    );
    let panels_w = 4 * w + 3 * GAP_PX;
    let ow = panels_w.max(MIN_WIDTH_PX);
    let oh = h + GAP_PX + LINE_PX * lines.len() + GAP_PX;
    let mut rgb = vec![255u8; ow * oh * 3];
    let mut put = |x: usize, y: usize, v: u8| {
        let i = 3 * (y * ow + x);
        rgb[i..i + 3].fill(v);
    };
    let grey = |v: f64| (128.0 + v).round().clamp(0.0, 255.0) as u8;
    for y in 0..h {
        for x in 0..w {
            let (ax, ay) = (rect.x0 + x as i64, rect.y0 + y as i64);
            let a = p.footage.data[y * w + x];
            let b = p.full.get(ax, ay).unwrap_or(0);
            let c = p.clean.get(ax, ay).unwrap_or(0);
            let (sx, sy) = (ax - p.window.x0, ay - p.window.y0);
            let s = p
                .smoothed
                .get(sx, sy)
                .map_or(128, |v| grey(smooth_gain * v));
            put(x, y, a);
            put(w + GAP_PX + x, y, b);
            put(
                2 * (w + GAP_PX) + x,
                y,
                grey(DIFFERENCE_GAIN * (a as f64 - c as f64)),
            );
            put(3 * (w + GAP_PX) + x, y, s);
        }
    }
    crate::plot::register_font();
    let err = |e: String| CalibrateJobError::Overlay {
        file: path.to_path_buf(),
        message: e,
    };
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (ow as u32, oh as u32)).into_drawing_area();
        let font = ("sans-serif", 13).into_font().color(&BLACK);
        for (k, line) in lines.iter().enumerate() {
            let y = (h + GAP_PX + k * LINE_PX) as i32;
            root.draw(&Text::new(line.clone(), (4, y), font.clone()))
                .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    crate::plot::write_rgb_png(path, ow as u32, oh as u32, &rgb).map_err(|e| err(e.message))?;
    Ok(())
}
