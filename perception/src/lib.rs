//! # perception
//!
//! Models of the human visual system for rendering, working on plain image buffers: row-major
//! `f32` slices of `width × height` pixels (RGB interleaved as `[r, g, b, r, g, b, …]` where a
//! colour image is expected, one value per pixel otherwise). The crate knows nothing of the
//! renderer; any HDR image can be used.
//!
//! - [`photometry`]: luminance from linear Rec.709 RGB, calibration to cd/m², scotopic luminance.
//! - [`viewing`]: [`ViewingConditions`](viewing::ViewingConditions), pixels per degree and frame rate.
//! - [`tvi`]: threshold-versus-intensity (Ferwerda et al. 1996, Ward Larson et al. 1997).
//! - [`csf`]: Daly's 1993 CSF, the Kelly–Daly spatiovelocity CSF, eye movement, masking.
//! - [`adaptation`]: global and local adaptation luminance (FFT convolution).
//! - [`threshold`]: the threshold map ΔL_T(x) (Ramasubramanian et al. 1999, Yee et al. 2001).
//! - [`tmo`]: tone reproduction (TR, FPSG, WRP, PTYG with time-dependent adaptation, Reinhard,
//!   exposure).
//! - [`saliency`]: Itti–Koch–Niebur saliency and the saliency-weighted threshold (Yee's Aleph map).
//! - [`metric`]: the visible-difference metric (pdiff-like, reference-only masking).
//! - [`fft`]: planned 2-D real FFTs.
//!
//! ```
//! use perception::photometry::luminance;
//! use perception::tvi::tvi_ward97;
//! // Linear Rec.709 white has relative luminance 1.
//! assert!((luminance(1.0, 1.0, 1.0) - 1.0).abs() < 1e-6);
//! // At 100 cd/m² the smallest visible increment is about 5.6 cd/m² (Weber fraction 5.6 %).
//! assert!((tvi_ward97(100.0) - 5.559).abs() < 1e-3);
//! ```
#![deny(missing_docs)]

pub mod adaptation;
pub mod csf;
pub mod error;
pub mod fft;
pub mod metric;
pub mod photometry;
pub mod saliency;
mod table;
pub mod threshold;
pub mod tmo;
pub mod tvi;
pub mod viewing;

pub use error::{PerceptionError, Result};

#[cfg(test)]
mod rng_for_tests {
    /// A small deterministic generator for test images (Knuth's MMIX LCG, top bits).
    pub struct Lcg(pub u64);
    impl Lcg {
        /// Uniform in [0, 1).
        pub fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
    }
}
