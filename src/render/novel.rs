//! Effects outside the diagnosis's vocabulary, drawn onto rendered frames: what a real camera or
//! rig does that no effect of [`crate::scenario::effects`] models. The self-check films them to
//! check that `diagnose` answers `unexplained` rather than take a flexible candidate for their
//! cause (`pipeline::selfcheck`). Each is a pure function of the frame, its index, its
//! time and where the marker is; the marker's slip on the wheel ([`Novel::Creep`]) changes the
//! motion instead and is drawn by the renderer.

use std::f64::consts::TAU;

/// One effect outside the vocabulary, with its strength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Novel {
    /// The marker slips on the wheel at `rate_deg_s` while the wheel dwells (tape creeping under
    /// a stiff marker).
    Creep { rate_deg_s: f64 },
    /// The camera mount gives way once: from `at_s` on, the image is shifted by (dx, dy) px.
    MountStep { at_s: f64, shift_px: [f64; 2] },
    /// Autofocus breathing: the image scale about the frame centre swings by
    /// ±`amplitude_frac` at `frequency_hz`.
    ZoomBreathing {
        amplitude_frac: f64,
        frequency_hz: f64,
    },
    /// A specular glare at `centre_px`: + `peak_dn` × a Gaussian of σ `sigma_px`, clipped at 255.
    Glare {
        centre_px: [f64; 2],
        sigma_px: f64,
        peak_dn: f64,
    },
    /// A cable in front of the rig: a dark band of `width_px` at grey `level_dn` along the line
    /// through `through_px` at `angle_deg` from the image x axis.
    Cable {
        through_px: [f64; 2],
        angle_deg: f64,
        width_px: f64,
        level_dn: f64,
    },
    /// Autofocus hunting: bursts of blur, σ = `sigma_px` × max(0, sin(2π t / `period_s`))⁴.
    FocusHunt { sigma_px: f64, period_s: f64 },
    /// The encoder repeats a frame under load: every `every`-th frame is its predecessor's
    /// image under its own timestamp.
    DuplicatedFrames { every: usize },
    /// Rolling-shutter banding under mains light: row gain 1 + `amplitude_frac` ·
    /// sin(2π (y / `wavelength_px` − `drift_hz` · t)).
    FlickerBanding {
        amplitude_frac: f64,
        wavelength_px: f64,
        drift_hz: f64,
    },
}

impl Novel {
    /// A short name for case names and reports.
    pub fn kind(&self) -> &'static str {
        match self {
            Novel::Creep { .. } => "creep",
            Novel::MountStep { .. } => "mount_step",
            Novel::ZoomBreathing { .. } => "zoom_breathing",
            Novel::Glare { .. } => "glare",
            Novel::Cable { .. } => "cable",
            Novel::FocusHunt { .. } => "focus_hunt",
            Novel::DuplicatedFrames { .. } => "duplicated_frames",
            Novel::FlickerBanding { .. } => "flicker_banding",
        }
    }
}

/// The kinds, in the order the self-check takes them.
pub const KINDS: [&str; 8] = [
    "creep",
    "mount_step",
    "zoom_breathing",
    "glare",
    "cable",
    "focus_hunt",
    "duplicated_frames",
    "flicker_banding",
];

/// A grey frame, row-major.
pub struct Frame<'a> {
    pub data: &'a mut [u8],
    pub width: usize,
    pub height: usize,
}

/// Draws `novel` on frame `index` at `t_s`. `previous` is the frame before it as drawn (a
/// duplicated frame copies it); the creep is not drawn here.
pub fn draw(novel: &Novel, frame: Frame<'_>, t_s: f64, index: usize, previous: &[u8]) {
    let (w, h) = (frame.width, frame.height);
    let data = frame.data;
    match *novel {
        Novel::Creep { .. } => {}
        Novel::MountStep { at_s, shift_px } => {
            if t_s >= at_s {
                let src = data.to_vec();
                warp(&src, data, w, h, |x, y| (x - shift_px[0], y - shift_px[1]));
            }
        }
        Novel::ZoomBreathing {
            amplitude_frac,
            frequency_hz,
        } => {
            let s = 1.0 + amplitude_frac * (TAU * frequency_hz * t_s).sin();
            let (cx, cy) = (0.5 * w as f64, 0.5 * h as f64);
            let src = data.to_vec();
            warp(&src, data, w, h, |x, y| {
                (cx + (x - cx) / s, cy + (y - cy) / s)
            });
        }
        Novel::Glare {
            centre_px,
            sigma_px,
            peak_dn,
        } => {
            for (i, v) in data.iter_mut().enumerate() {
                let (dx, dy) = ((i % w) as f64 - centre_px[0], (i / w) as f64 - centre_px[1]);
                let add = peak_dn * (-(dx * dx + dy * dy) / (2.0 * sigma_px * sigma_px)).exp();
                *v = (*v as f64 + add).round().min(255.0) as u8;
            }
        }
        Novel::Cable {
            through_px,
            angle_deg,
            width_px,
            level_dn,
        } => {
            let (s, c) = angle_deg.to_radians().sin_cos();
            for (i, v) in data.iter_mut().enumerate() {
                let (dx, dy) = (
                    (i % w) as f64 - through_px[0],
                    (i / w) as f64 - through_px[1],
                );
                // Distance from the line, and the band's area coverage of the pixel (1 px ramp).
                let d = (dx * s - dy * c).abs();
                let cover = (0.5 * width_px + 0.5 - d).clamp(0.0, 1.0);
                *v = (*v as f64 * (1.0 - cover) + level_dn * cover).round() as u8;
            }
        }
        Novel::FocusHunt { sigma_px, period_s } => {
            let sigma = sigma_px * (TAU * t_s / period_s).sin().max(0.0).powi(4);
            if sigma > 0.05 {
                gaussian_blur(data, w, h, sigma);
            }
        }
        Novel::DuplicatedFrames { every } => {
            if every > 0 && index > 0 && index % every == 0 && previous.len() == data.len() {
                data.copy_from_slice(previous);
            }
        }
        Novel::FlickerBanding {
            amplitude_frac,
            wavelength_px,
            drift_hz,
        } => {
            for (y, row) in data.chunks_mut(w).enumerate() {
                let g = 1.0
                    + amplitude_frac * (TAU * (y as f64 / wavelength_px - drift_hz * t_s)).sin();
                for v in row {
                    *v = (*v as f64 * g).round().clamp(0.0, 255.0) as u8;
                }
            }
        }
    }
}

/// `dst` at each pixel centre (x, y) = `src` bilinearly at `from(x, y)`, edges clamped.
fn warp(src: &[u8], dst: &mut [u8], w: usize, h: usize, from: impl Fn(f64, f64) -> (f64, f64)) {
    let at = |x: i64, y: i64| -> f64 {
        let (x, y) = (x.clamp(0, w as i64 - 1), y.clamp(0, h as i64 - 1));
        src[y as usize * w + x as usize] as f64
    };
    for (i, v) in dst.iter_mut().enumerate() {
        let (sx, sy) = from((i % w) as f64, (i / w) as f64);
        let (x0, y0) = (sx.floor(), sy.floor());
        let (fx, fy) = (sx - x0, sy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
        let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
        *v = (top * (1.0 - fy) + bottom * fy).round().clamp(0.0, 255.0) as u8;
    }
}

/// Separable Gaussian blur of σ `sigma_px` (kernel to 3σ, edges clamped).
fn gaussian_blur(data: &mut [u8], w: usize, h: usize, sigma_px: f64) {
    let r = (3.0 * sigma_px).ceil() as i64;
    let k: Vec<f64> = (-r..=r)
        .map(|d| (-(d * d) as f64 / (2.0 * sigma_px * sigma_px)).exp())
        .collect();
    let norm: f64 = k.iter().sum();
    let pass = |src: &[f64], dst: &mut [f64], along_x: bool| {
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let mut acc = 0.0;
                for (j, kv) in k.iter().enumerate() {
                    let d = j as i64 - r;
                    let (sx, sy) = if along_x {
                        ((x + d).clamp(0, w as i64 - 1), y)
                    } else {
                        (x, (y + d).clamp(0, h as i64 - 1))
                    };
                    acc += kv * src[(sy * w as i64 + sx) as usize];
                }
                dst[(y * w as i64 + x) as usize] = acc / norm;
            }
        }
    };
    let a: Vec<f64> = data.iter().map(|&v| v as f64).collect();
    let mut b = vec![0.0; a.len()];
    pass(&a, &mut b, true);
    let mut c = vec![0.0; a.len()];
    pass(&b, &mut c, false);
    for (v, x) in data.iter_mut().zip(c) {
        *v = x.round().clamp(0.0, 255.0) as u8;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Vec<u8> {
        (0..w * h).map(|i| ((i % w) * 4 + (i / w)) as u8).collect()
    }

    fn drawn(novel: &Novel, t_s: f64, index: usize, prev: &[u8]) -> Vec<u8> {
        let mut d = ramp(40, 30);
        draw(
            novel,
            Frame {
                data: &mut d,
                width: 40,
                height: 30,
            },
            t_s,
            index,
            prev,
        );
        d
    }

    #[test]
    fn a_mount_step_shifts_the_image_from_its_instant_on() {
        let n = Novel::MountStep {
            at_s: 1.0,
            shift_px: [3.0, 2.0],
        };
        let before = drawn(&n, 0.5, 0, &[]);
        assert_eq!(before, ramp(40, 30));
        let after = drawn(&n, 1.5, 0, &[]);
        let src = ramp(40, 30);
        // Inside the image, pixel (x, y) now shows (x − 3, y − 2).
        assert_eq!(after[10 * 40 + 20], src[8 * 40 + 17]);
    }

    #[test]
    fn zoom_breathing_keeps_the_centre_and_scales_about_it() {
        let n = Novel::ZoomBreathing {
            amplitude_frac: 0.1,
            frequency_hz: 0.25,
        };
        // At t = 1 s the scale is 1.1: pixel centre (20, 15) stays, (30, 15) shows ≈ (29.09, 15).
        let d = drawn(&n, 1.0, 0, &[]);
        let src = ramp(40, 30);
        assert_eq!(d[15 * 40 + 20], src[15 * 40 + 20]);
        let want = src[15 * 40 + 29] as f64 * 0.909 + src[15 * 40 + 30] as f64 * 0.091;
        assert!((d[15 * 40 + 30] as f64 - want).abs() <= 1.0);
    }

    #[test]
    fn a_glare_brightens_around_its_centre_and_clips() {
        let n = Novel::Glare {
            centre_px: [10.0, 10.0],
            sigma_px: 3.0,
            peak_dn: 300.0,
        };
        let d = drawn(&n, 0.0, 0, &[]);
        assert_eq!(d[10 * 40 + 10], 255);
        assert_eq!(d[29 * 40 + 39], ramp(40, 30)[29 * 40 + 39]);
    }

    #[test]
    fn a_cable_covers_its_band_and_nothing_far_from_it() {
        let n = Novel::Cable {
            through_px: [0.0, 12.0],
            angle_deg: 0.0,
            width_px: 3.0,
            level_dn: 7.0,
        };
        let d = drawn(&n, 0.0, 0, &[]);
        assert!((0..40).all(|x| d[12 * 40 + x] == 7));
        assert_eq!(d[20 * 40 + 5], ramp(40, 30)[20 * 40 + 5]);
    }

    #[test]
    fn focus_hunting_blurs_in_bursts_only() {
        let n = Novel::FocusHunt {
            sigma_px: 2.0,
            period_s: 2.0,
        };
        assert_eq!(drawn(&n, 1.5, 0, &[]), ramp(40, 30), "sin < 0: sharp");
        let mut step: Vec<u8> = (0..40 * 30)
            .map(|i| if i % 40 < 20 { 0 } else { 200 })
            .collect();
        draw(
            &n,
            Frame {
                data: &mut step,
                width: 40,
                height: 30,
            },
            0.5,
            0,
            &[],
        );
        assert!(
            step[5 * 40 + 19] > 40 && step[5 * 40 + 20] < 160,
            "{:?}",
            &step[200..240]
        );
        assert_eq!(step[5 * 40], 0);
    }

    #[test]
    fn every_nth_frame_repeats_its_predecessor() {
        let n = Novel::DuplicatedFrames { every: 5 };
        let prev = vec![9u8; 40 * 30];
        assert_eq!(drawn(&n, 0.0, 10, &prev), prev);
        assert_eq!(drawn(&n, 0.0, 11, &prev), ramp(40, 30));
        assert_eq!(drawn(&n, 0.0, 0, &prev), ramp(40, 30));
    }

    #[test]
    fn banding_modulates_rows() {
        let n = Novel::FlickerBanding {
            amplitude_frac: 0.5,
            wavelength_px: 8.0,
            drift_hz: 0.0,
        };
        let d = drawn(&n, 0.0, 0, &[]);
        let src = ramp(40, 30);
        assert_eq!(
            d[40 + 1],
            (src[40 + 1] as f64 * (1.0 + 0.5 * (TAU / 8.0).sin())).round() as u8
        );
    }
}
