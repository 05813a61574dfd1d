//! The film: per-pixel sample buffers that the perception module and the adaptive sampler read.
//!
//! For every pixel the film keeps
//! - the RGB sums of the samples with even index (half-buffer A) and odd index (half-buffer B),
//!   whose total is the pixel's RGB sum and whose difference estimates its error;
//! - the sum of squared luminance Σ Y², for the sample variance;
//! - the sample count n (samples 0..n have been taken; the next has index n).
//!
//! Values are linear Rec.709 radiance in W·sr⁻¹·m⁻²; sums are `f64` so that millions of samples
//! do not lose precision. A pixel's samples are added in index order, so adding more later
//! continues its random stream exactly (see [`crate::rng`]).

use glam::{DVec3, Vec3};

/// Sample statistics of one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelStats {
    /// RGB sum of samples with even index (half-buffer A).
    pub sum_even: DVec3,
    /// RGB sum of samples with odd index (half-buffer B).
    pub sum_odd: DVec3,
    /// Σ Y² over all samples (Y = Rec.709 luminance of the sample).
    pub sum_lum2: f64,
    /// Number of samples taken.
    pub n: u32,
}

impl PixelStats {
    /// Adds the sample with index `self.n`.
    #[inline]
    pub fn add(&mut self, rgb: Vec3) {
        let v = rgb.as_dvec3();
        if self.n.is_multiple_of(2) {
            self.sum_even += v;
        } else {
            self.sum_odd += v;
        }
        let y = crate::math::luminance(rgb) as f64;
        self.sum_lum2 += y * y;
        self.n += 1;
    }

    /// Mean radiance (zero when no samples).
    #[inline]
    pub fn mean(&self) -> DVec3 {
        if self.n == 0 {
            DVec3::ZERO
        } else {
            (self.sum_even + self.sum_odd) / self.n as f64
        }
    }

    /// Number of samples in half-buffer A (even indices).
    #[inline]
    pub fn n_even(&self) -> u32 {
        self.n.div_ceil(2)
    }

    /// Number of samples in half-buffer B (odd indices).
    #[inline]
    pub fn n_odd(&self) -> u32 {
        self.n / 2
    }

    /// Mean of half-buffer A (zero when empty).
    #[inline]
    pub fn mean_even(&self) -> DVec3 {
        let n = self.n_even();
        if n == 0 {
            DVec3::ZERO
        } else {
            self.sum_even / n as f64
        }
    }

    /// Mean of half-buffer B (zero when empty).
    #[inline]
    pub fn mean_odd(&self) -> DVec3 {
        let n = self.n_odd();
        if n == 0 {
            DVec3::ZERO
        } else {
            self.sum_odd / n as f64
        }
    }

    /// Unbiased sample variance of the luminance of one sample (0 with fewer than 2 samples).
    #[inline]
    pub fn lum_variance(&self) -> f64 {
        if self.n < 2 {
            return 0.0;
        }
        let n = self.n as f64;
        let m = self.mean();
        let mean_y = crate::math::luminance(m.as_vec3()) as f64;
        ((self.sum_lum2 - n * mean_y * mean_y) / (n - 1.0)).max(0.0)
    }

    /// Standard error of the pixel's mean luminance: sqrt(variance / n).
    #[inline]
    pub fn lum_std_error(&self) -> f64 {
        if self.n < 2 {
            return f64::INFINITY;
        }
        (self.lum_variance() / self.n as f64).sqrt()
    }
}

/// A `width × height` grid of [`PixelStats`], row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major pixel statistics.
    pub pixels: Vec<PixelStats>,
}

impl Film {
    /// An empty film.
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![PixelStats::default(); width as usize * height as usize],
        }
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.pixels.len()
    }

    /// True when the film has no pixels.
    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    /// The statistics of pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> &PixelStats {
        &self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Mean radiance per pixel as interleaved RGB `f32` (3 × pixels).
    pub fn mean_rgb(&self) -> Vec<f32> {
        self.pixels
            .iter()
            .flat_map(|p| p.mean().as_vec3().to_array())
            .collect()
    }

    /// Half-buffer A (even samples) mean per pixel as interleaved RGB.
    pub fn mean_rgb_even(&self) -> Vec<f32> {
        self.pixels
            .iter()
            .flat_map(|p| p.mean_even().as_vec3().to_array())
            .collect()
    }

    /// Half-buffer B (odd samples) mean per pixel as interleaved RGB.
    pub fn mean_rgb_odd(&self) -> Vec<f32> {
        self.pixels
            .iter()
            .flat_map(|p| p.mean_odd().as_vec3().to_array())
            .collect()
    }

    /// Sample count per pixel.
    pub fn spp(&self) -> Vec<u32> {
        self.pixels.iter().map(|p| p.n).collect()
    }

    /// Total number of samples over all pixels.
    pub fn total_samples(&self) -> u64 {
        self.pixels.iter().map(|p| p.n as u64).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_and_statistics() {
        let mut p = PixelStats::default();
        for v in [1.0f32, 3.0, 2.0, 6.0, 4.0] {
            p.add(Vec3::splat(v));
        }
        assert_eq!(p.n, 5);
        assert_eq!((p.n_even(), p.n_odd()), (3, 2));
        assert!((p.mean().x - 3.2).abs() < 1e-12);
        assert!((p.mean_even().x - 7.0 / 3.0).abs() < 1e-12);
        assert!((p.mean_odd().x - 4.5).abs() < 1e-12);
        // Grey has luminance equal to its value: sample variance of {1,3,2,6,4} is 3.7.
        assert!((p.lum_variance() - 3.7).abs() < 1e-5);
    }
}
