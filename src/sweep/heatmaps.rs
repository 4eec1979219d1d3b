//! Heatmaps of a finished sweep (placeholder until written).
