//! Detector input and output types (no OpenCV): a borrowed grey image with its absolute origin,
//! and one detected marker with corners in absolute image pixels (OpenCV convention: the centre
//! of pixel (i, j) is at (i, j); corner order as OpenCV returns it, clockwise from the marker's
//! top-left).

/// A borrowed 8-bit grey image (row-major, no padding) whose pixel (0, 0) sits at `origin_px`
/// in the full frame. A full frame has origin (0, 0).
#[derive(Debug, Clone, Copy)]
pub struct GrayView<'a> {
    pub data: &'a [u8],
    pub width: usize,
    pub height: usize,
    pub origin_px: (i32, i32),
}

impl<'a> GrayView<'a> {
    /// A full frame at origin (0, 0).
    pub fn full(data: &'a [u8], width: usize, height: usize) -> Self {
        Self {
            data,
            width,
            height,
            origin_px: (0, 0),
        }
    }
}

/// One detected marker: id and the four corners in absolute image pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    pub id: i32,
    pub corners_px: [[f64; 2]; 4],
}

impl Detection {
    /// Mean of the four corners (the seed script's marker centre), px.
    pub fn centre_px(&self) -> [f64; 2] {
        let mut c = [0.0; 2];
        for p in &self.corners_px {
            c[0] += p[0] / 4.0;
            c[1] += p[1] / 4.0;
        }
        c
    }

    /// Axis-aligned bounding box `(x_min, y_min, x_max, y_max)` of the corners, px.
    pub fn bbox_px(&self) -> (f64, f64, f64, f64) {
        corners_bbox_px(&self.corners_px)
    }
}

/// Axis-aligned bounding box `(x_min, y_min, x_max, y_max)` of four corners, px — the
/// predicted box that ROI detection takes.
pub fn corners_bbox_px(corners_px: &[[f64; 2]; 4]) -> (f64, f64, f64, f64) {
    let xs = corners_px.iter().map(|p| p[0]);
    let ys = corners_px.iter().map(|p| p[1]);
    (
        xs.clone().fold(f64::INFINITY, f64::min),
        ys.clone().fold(f64::INFINITY, f64::min),
        xs.fold(f64::NEG_INFINITY, f64::max),
        ys.fold(f64::NEG_INFINITY, f64::max),
    )
}
