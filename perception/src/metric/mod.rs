//! A visible-difference metric on aleph's models, in the spirit of Yee & Newman's pdiff
//! (Yee 2004, "A Perceptual Metric for Production Testing", JGT 9(4)): a pixel differs visibly
//! when the luminance difference between a reference and a test image exceeds the threshold map
//! ΔL_T(x) of [`crate::threshold`] there.
//!
//! Unlike pdiff, which masks with the larger band contrast of the two images, the threshold map
//! here — adaptation and masking — is computed from the **reference alone**: otherwise the noise
//! of a noisy test render masks itself and a grainy image passes as equal to its reference. There is no colour test; only luminance differences are judged.

use crate::error::{PerceptionError, Result, check_image};
use crate::threshold::{ThresholdMap, ThresholdMapper, ThresholdParams};
use crate::viewing::ViewingConditions;
use rayon::prelude::*;

/// pdiff's default: images are "different" when at least this many pixels differ visibly.
pub const DEFAULT_FAIL_PIXELS: usize = 100;

/// The outcome of a comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct DiffResult {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Per pixel |L_ref − L_test| / ΔL_T(x): the difference in threshold units (visible above 1),
    /// row-major.
    pub ratio: Vec<f32>,
    /// Number of pixels with ratio > 1.
    pub visible_pixels: usize,
    /// visible_pixels / (width × height).
    pub visible_fraction: f64,
    /// True when `visible_pixels` ≥ the fail limit.
    pub different: bool,
}

/// Compares test images against references of one size, reusing the FFT plans.
#[derive(Debug)]
pub struct DiffMetric {
    mapper: ThresholdMapper,
    fail_pixels: usize,
}

impl DiffMetric {
    /// A metric for `width × height` images seen under `view`, judging "different" from
    /// `fail_pixels` visibly different pixels.
    ///
    /// # Errors
    /// As [`ThresholdMapper::new`].
    pub fn new(
        width: usize,
        height: usize,
        view: ViewingConditions,
        params: ThresholdParams,
        fail_pixels: usize,
    ) -> Result<DiffMetric> {
        Ok(DiffMetric {
            mapper: ThresholdMapper::new(width, height, view, params)?,
            fail_pixels,
        })
    }

    /// The threshold map of a reference (compute it once to compare many test images).
    ///
    /// # Errors
    /// As [`ThresholdMapper::compute`].
    pub fn reference_map(&self, reference: &[f32]) -> Result<ThresholdMap> {
        self.mapper.compute(reference, None)
    }

    /// Compares `test` against `reference` (luminance in cd/m², row-major).
    ///
    /// # Errors
    /// [`PerceptionError`] for wrong sizes or NaN, infinite or negative pixels.
    pub fn compare(&self, reference: &[f32], test: &[f32]) -> Result<DiffResult> {
        let map = self.reference_map(reference)?;
        self.compare_with_map(&map, reference, test)
    }

    /// Compares `test` against `reference` with the reference's precomputed threshold map.
    ///
    /// # Errors
    /// [`PerceptionError`] for wrong sizes or NaN, infinite or negative pixels.
    pub fn compare_with_map(
        &self,
        map: &ThresholdMap,
        reference: &[f32],
        test: &[f32],
    ) -> Result<DiffResult> {
        let (w, h) = (map.width, map.height);
        check_image("reference", reference, w, h, 1, true)?;
        check_image("test", test, w, h, 1, true)?;
        let ratio: Vec<f32> = reference
            .par_iter()
            .zip(test.par_iter())
            .zip(map.threshold.par_iter())
            .map(|((r, t), th)| (r - t).abs() / th.max(f32::MIN_POSITIVE))
            .collect();
        let visible_pixels = ratio.par_iter().filter(|&&r| r > 1.0).count();
        Ok(DiffResult {
            width: w,
            height: h,
            visible_fraction: visible_pixels as f64 / (w * h) as f64,
            different: visible_pixels >= self.fail_pixels,
            visible_pixels,
            ratio,
        })
    }
}

/// One-call comparison with default threshold parameters and pdiff's fail limit.
///
/// # Errors
/// [`PerceptionError::SizeMismatch`] if the buffers differ in length; otherwise as
/// [`DiffMetric::compare`].
pub fn visible_difference(
    reference: &[f32],
    test: &[f32],
    width: usize,
    height: usize,
    view: &ViewingConditions,
) -> Result<DiffResult> {
    if reference.len() != test.len() {
        return Err(PerceptionError::BufferSize {
            what: "test",
            len: test.len(),
            expected: reference.len(),
            width,
            height,
            channels: 1,
        });
    }
    DiffMetric::new(
        width,
        height,
        *view,
        ThresholdParams::default(),
        DEFAULT_FAIL_PIXELS,
    )?
    .compare(reference, test)
}

#[cfg(test)]
mod tests;
