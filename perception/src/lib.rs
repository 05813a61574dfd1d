//! # perception
//!
//! Models of the human visual system for rendering, working on plain image buffers: row-major
//! `f32` slices of `width × height` pixels (RGB interleaved as `[r, g, b, r, g, b, …]` where a
//! colour image is expected, one value per pixel otherwise). The crate knows nothing of the
//! renderer; any HDR image can be used.
//!
//! - [`photometry`]: luminance from linear Rec.709 RGB, calibration to cd/m², scotopic luminance.
//!
//! ```
//! use perception::photometry::luminance;
//! // Linear Rec.709 white has relative luminance 1.
//! assert!((luminance(1.0, 1.0, 1.0) - 1.0).abs() < 1e-6);
//! ```
#![deny(missing_docs)]

pub mod photometry;
