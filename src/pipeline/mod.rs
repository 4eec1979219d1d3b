//! Orchestration: the jobs the CLI runs, composed from the pure core and `io`.
//!
//! Each job takes a validated scenario and an output directory and returns a summary the CLI
//! prints; nothing here is maths.

pub mod truth;
