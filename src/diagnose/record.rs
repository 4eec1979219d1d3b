//! What one measurement (real footage or one simulated seed) leaves for the diagnosis: per frame
//! the analysis time, the detected corners of the moving and the reference marker, and the image
//! statistics measured on the frame around the marker. Nothing here knows a truth.

use crate::estimate::Corners;

/// Image statistics of one frame around the marker (grey levels in DN, lengths in px). Every
/// field is `None` when the frame did not allow the measurement (marker missing, region too
/// small): the diagnosis never substitutes a value.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrameImage {
    /// Median grey level of the black ink (border and black cells), DN.
    pub ink_dn: Option<f64>,
    /// Median grey level of the white paper (margin and white cells), DN.
    pub paper_dn: Option<f64>,
    /// Median grey level of the disc/background just outside the paper, DN.
    pub background_dn: Option<f64>,
    /// Edge-profile blur σ of each of the marker's four outer sides (px) with the side's unit
    /// normal in the image; the diagnosis sorts them into across / along the motion once the
    /// rotation centre is known.
    pub edges: [Option<SideEdge>; 4],
    /// Noise σ inside the ink, DN.
    pub noise_ink_dn: Option<f64>,
    /// Noise σ inside the paper, DN.
    pub noise_paper_dn: Option<f64>,
    /// 8-px-grid blockiness (1 = none), dimensionless.
    pub blockiness: Option<f64>,
    /// Corners of the marker's outer square from the four fitted outer sides (sub-pixel, OpenCV
    /// order, absolute px), when all four sides fitted: the shape the image channels measure
    /// rolling shutter on, free of the detector's whole-pixel corner quantisation.
    pub refined_corners_px: Option<Corners>,
}

/// Blur of one marker side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SideEdge {
    /// Fitted edge-profile σ, px.
    pub sigma_px: f64,
    /// Unit normal of the side in the image.
    pub normal: [f64; 2],
}

/// One frame of a measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameRecord {
    /// The time the analysis uses for this frame, s (the footage's timestamp).
    pub t_s: f64,
    /// Corners of the moving marker (OpenCV order, absolute px), `None` when not detected.
    pub corners_px: Option<Corners>,
    /// Corners of the static reference marker, when the scenario has one and it was detected.
    pub reference_px: Option<Corners>,
    /// Image statistics, `None` when the measurement has no frames (a corner track).
    pub image: Option<FrameImage>,
}

/// The real data as the diagnosis sees it: its record and the estimate made of it.
#[derive(Debug, Clone)]
pub struct RealMeasurement {
    pub record: Record,
    pub estimate: crate::estimate::Estimate,
}

/// A whole measurement, in frame order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Record {
    pub frames: Vec<FrameRecord>,
    /// Whether the frames themselves were seen (false for a corner track).
    pub has_images: bool,
    /// Whether a reference marker was searched for.
    pub has_reference: bool,
}

impl Record {
    pub fn t_s(&self) -> Vec<f64> {
        self.frames.iter().map(|f| f.t_s).collect()
    }

    pub fn corners(&self) -> Vec<Option<Corners>> {
        self.frames.iter().map(|f| f.corners_px).collect()
    }

    pub fn references(&self) -> Vec<Option<Corners>> {
        self.frames.iter().map(|f| f.reference_px).collect()
    }

    pub fn detected(&self) -> usize {
        self.frames
            .iter()
            .filter(|f| f.corners_px.is_some())
            .count()
    }
}
