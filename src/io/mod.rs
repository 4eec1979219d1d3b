//! (placeholder)
pub mod images;
pub mod video;
