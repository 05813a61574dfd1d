//! Adaptation luminance: the luminance the visual system is adapted to at each pixel.
//!
//! Three choices, as the seed paper describes (Yee, Dutré & Pattanaik, §4 "adaptation"):
//! - **global**: the log average (geometric mean) of the whole image, exp(mean(ln(δ + L)));
//! - **local arithmetic**: the mean over a window of about one degree of visual angle;
//! - **local geometric**: exp of the local mean of ln(δ + L) over the same window.
//!
//! Local means are Gaussian-weighted (FWHM = the window, default 1°, so σ = window / 2.3548 in
//! degrees × pixels per degree) and computed by FFT convolution on an image padded by mirror
//! reflection of 4σ on every side (the Gaussian's weight beyond 4σ is 3e-5), so the borders are not mixed with the opposite edge.
//! δ = 1e-4 cd/m² keeps the logarithm finite on black pixels (below the absolute threshold of
//! vision, 1e-6 cd/m² order, so it does not matter to the visual models).
//!
//! # References
//! - Reinhard, Stark, Shirley & Ferwerda 2002, "Photographic Tone Reproduction for Digital
//!   Images", SIGGRAPH, eq. 1 (log average).
//! - Ramasubramanian, Pattanaik & Greenberg 1999, "A Perceptually Based Physical Error Metric
//!   for Realistic Image Synthesis", SIGGRAPH, §4.1 (adaptation over a 1° foveal window).

use crate::error::{PerceptionError, Result, check_image};
use crate::fft::{Fft2d, good_size};
use crate::viewing::ViewingConditions;

/// δ added before taking logarithms of luminance, cd/m².
pub const LOG_DELTA_CD_M2: f32 = 1e-4;

/// FWHM / σ of a Gaussian: 2 sqrt(2 ln 2).
const FWHM_PER_SIGMA: f64 = 2.354_820_045;

/// How adaptation luminance is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AdaptationMode {
    /// The geometric mean of the whole image.
    Global,
    /// Gaussian-weighted arithmetic mean over the window.
    #[default]
    LocalArithmetic,
    /// Gaussian-weighted geometric mean over the window.
    LocalGeometric,
}

/// The log average (geometric mean) exp(mean(ln(δ + L))) of a luminance image, cd/m².
pub fn log_average(lum: &[f32]) -> f32 {
    if lum.is_empty() {
        return LOG_DELTA_CD_M2;
    }
    let s: f64 = lum
        .iter()
        .map(|&l| ((LOG_DELTA_CD_M2 + l.max(0.0)) as f64).ln())
        .sum();
    (s / lum.len() as f64).exp() as f32
}

/// Mirror-padded layout of an image inside a larger FFT-friendly canvas.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Padding {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Canvas width (≥ width + 2 margin, a product of 2, 3, 5, 7).
    pub padded_width: usize,
    /// Canvas height.
    pub padded_height: usize,
    /// Horizontal offset of the image in the canvas.
    pub x0: usize,
    /// Vertical offset of the image in the canvas.
    pub y0: usize,
}

impl Padding {
    /// A canvas with at least `margin` pixels on every side (never more than the image size).
    pub fn new(width: usize, height: usize, margin: usize) -> Padding {
        Self::aligned(width, height, margin, 1)
    }

    /// As [`Padding::new`], with the canvas size and the image offset multiples of `align` (a
    /// power of two), and canvas / `align` a product of 2, 3, 5 and 7, so that the canvas can
    /// be decimated by any power of two up to `align` for FFTs.
    pub fn aligned(width: usize, height: usize, margin: usize, align: usize) -> Padding {
        let align = align.max(1);
        let dim = |n: usize| -> (usize, usize) {
            let m = margin.min(n);
            let x0 = m.div_ceil(align) * align;
            let total = good_size((x0 + n + m).div_ceil(align)) * align;
            (total, x0)
        };
        let (pw, x0) = dim(width);
        let (ph, y0) = dim(height);
        Padding {
            width,
            height,
            padded_width: pw,
            padded_height: ph,
            x0,
            y0,
        }
    }

    /// Copies `img` into the canvas, filling the margins by mirror reflection (edge pixel not
    /// repeated), periodically continued where the margin exceeds the image.
    pub fn pad(&self, img: &[f32]) -> Vec<f32> {
        let (w, h) = (self.width as i64, self.height as i64);
        let reflect = |i: i64, n: i64| -> usize {
            if n == 1 {
                return 0;
            }
            let period = 2 * n - 2;
            let m = i.rem_euclid(period);
            (if m < n { m } else { period - m }) as usize
        };
        let cols: Vec<usize> = (0..self.padded_width as i64)
            .map(|x| reflect(x - self.x0 as i64, w))
            .collect();
        let mut out = vec![0f32; self.padded_width * self.padded_height];
        for (py, row) in out.chunks_mut(self.padded_width).enumerate() {
            let sy = reflect(py as i64 - self.y0 as i64, h);
            let src = &img[sy * self.width..(sy + 1) * self.width];
            for (o, &sx) in row.iter_mut().zip(&cols) {
                *o = src[sx];
            }
        }
        out
    }

    /// Extracts the image region from a canvas.
    pub fn crop(&self, canvas: &[f32]) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.width * self.height);
        for y in 0..self.height {
            let s = (self.y0 + y) * self.padded_width + self.x0;
            out.extend_from_slice(&canvas[s..s + self.width]);
        }
        out
    }
}

/// σ in pixels of the Gaussian whose FWHM is `window_deg` degrees.
pub fn window_sigma_px(window_deg: f64, view: &ViewingConditions) -> f64 {
    window_deg * view.ppd / FWHM_PER_SIGMA
}

/// Multiplies a transposed spectrum (see [`Fft2d`]) by a Gaussian of standard deviation
/// `sigma_px` pixels: exp(−2π² σ² f²), f in cycles per pixel.
pub fn gaussian_filter(fft: &Fft2d, spec: &mut [rustfft::num_complex::Complex32], sigma_px: f64) {
    let h = fft.height();
    let k = -2.0 * std::f64::consts::PI.powi(2) * sigma_px * sigma_px;
    for (u, col) in spec.chunks_mut(h).enumerate() {
        for (v, c) in col.iter_mut().enumerate() {
            let f = fft.frequency(u, v);
            *c *= (k * f * f).exp() as f32;
        }
    }
}

/// Adaptation luminance of every pixel of a `width × height` luminance image (cd/m²,
/// row-major), over a window of `window_deg` degrees (1° is the usual choice).
///
/// # Errors
/// [`PerceptionError`] for a zero size, a wrong buffer length, NaN/infinite or negative values,
/// or a window that is not positive.
pub fn adaptation_luminance(
    lum: &[f32],
    width: usize,
    height: usize,
    view: &ViewingConditions,
    mode: AdaptationMode,
    window_deg: f64,
) -> Result<Vec<f32>> {
    check_image("luminance", lum, width, height, 1, true)?;
    if !(window_deg.is_finite() && window_deg > 0.0) {
        return Err(PerceptionError::Parameter {
            name: "adaptation window (degrees)",
            value: window_deg,
            range: "a positive number",
        });
    }
    if mode == AdaptationMode::Global {
        return Ok(vec![log_average(lum); lum.len()]);
    }
    let sigma = window_sigma_px(window_deg, view);
    let pad = Padding::new(width, height, (4.0 * sigma).ceil() as usize);
    let fft = Fft2d::new(pad.padded_width, pad.padded_height);
    let geometric = mode == AdaptationMode::LocalGeometric;
    let src: Vec<f32> = if geometric {
        lum.iter().map(|&l| (LOG_DELTA_CD_M2 + l).ln()).collect()
    } else {
        lum.to_vec()
    };
    let mut spec = fft.forward(&pad.pad(&src));
    gaussian_filter(&fft, &mut spec, sigma);
    let mut canvas = vec![0f32; pad.padded_width * pad.padded_height];
    fft.inverse(spec, &mut canvas);
    let mut out = pad.crop(&canvas);
    for v in out.iter_mut() {
        *v = if geometric { v.exp() } else { v.max(0.0) };
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_image_adapts_to_itself() {
        let v = ViewingConditions::from_fov(45.0, 64.0).unwrap();
        let img = vec![50.0f32; 64 * 48];
        for mode in [
            AdaptationMode::Global,
            AdaptationMode::LocalArithmetic,
            AdaptationMode::LocalGeometric,
        ] {
            let a = adaptation_luminance(&img, 64, 48, &v, mode, 1.0).unwrap();
            for x in a {
                assert!((x - 50.0).abs() < 1e-3 * 50.0, "{mode:?}: {x}");
            }
        }
    }

    #[test]
    fn local_mean_of_a_step_is_smooth_and_bounded() {
        // Left half 10, right half 1000 cd/m²; ppd = 32 so a 1° FWHM window has σ = 13.6 px.
        let (w, h) = (256, 64);
        let view = ViewingConditions::from_fov(
            2.0 * (128.0f64 / 32.0 / (180.0 / std::f64::consts::PI))
                .atan()
                .to_degrees(),
            w as f64,
        )
        .unwrap();
        assert!((view.ppd - 32.0).abs() < 1e-9);
        let img: Vec<f32> = (0..w * h)
            .map(|i| if i % w < w / 2 { 10.0 } else { 1000.0 })
            .collect();
        let a =
            adaptation_luminance(&img, w, h, &view, AdaptationMode::LocalArithmetic, 1.0).unwrap();
        let row = &a[32 * w..33 * w];
        // Far from the edge: the plateau values (mirror padding keeps the borders clean).
        assert!(
            (row[0] - 10.0).abs() < 0.1 && (row[w - 1] - 1000.0).abs() < 1.0,
            "{} {}",
            row[0],
            row[w - 1]
        );
        // At the edge: the Gaussian mean of a step is the midpoint, ~505.
        assert!((row[w / 2] - 505.0).abs() < 40.0, "{}", row[w / 2]);
        // Monotone across the edge.
        assert!(row.windows(2).all(|p| p[1] >= p[0] - 1e-2));
        // Geometric mean at the edge ≈ sqrt(10 · 1000) = 100.
        let g =
            adaptation_luminance(&img, w, h, &view, AdaptationMode::LocalGeometric, 1.0).unwrap();
        assert!(
            (g[32 * w + w / 2] / 100.0 - 1.0).abs() < 0.3,
            "{}",
            g[32 * w + w / 2]
        );
    }

    #[test]
    fn log_average_of_known_values() {
        let v = log_average(&[1.0, 100.0]);
        assert!((v - 10.0).abs() < 1e-2);
    }

    #[test]
    fn bad_input_is_an_error() {
        let v = ViewingConditions::default();
        assert!(adaptation_luminance(&[], 0, 0, &v, AdaptationMode::Global, 1.0).is_err());
        assert!(
            adaptation_luminance(&[1.0, f32::NAN], 2, 1, &v, AdaptationMode::Global, 1.0).is_err()
        );
        assert!(adaptation_luminance(&[1.0, -1.0], 2, 1, &v, AdaptationMode::Global, 1.0).is_err());
        assert!(adaptation_luminance(&[1.0, 1.0], 3, 1, &v, AdaptationMode::Global, 1.0).is_err());
        assert!(adaptation_luminance(&[1.0, 1.0], 2, 1, &v, AdaptationMode::Global, 0.0).is_err());
    }
}
