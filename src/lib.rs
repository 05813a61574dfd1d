//! # aleph
//!
//! A physically based path tracer that renders only what a person can see.
pub mod bsdf;
pub mod chi2;
pub mod math;
pub mod rng;
pub mod sampling;
