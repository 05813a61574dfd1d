//! Equal-quality benchmarking of the samplers against a high-spp reference (aleph DESIGN §11).
//!
//! Every image is judged against the reference on the *displayed* images (one tone curve,
//! frozen from the reference, for all of them) by three measures:
//! - **FLIP** (Andersson et al. 2020, NVIDIA's metric through the `nv-flip` crate, LDR, at the
//!   viewer's pixels per degree): the mean of the error map (the headline: it is independent of
//!   aleph's own model), and its 99th percentile after a 5×5 box filter ("is there still visible
//!   noise anywhere?");
//! - aleph's own visible-pixel fraction ([`perception::metric::DiffMetric`] on display
//!   luminance, the reference setting the masking);
//! - relMSE = mean((x − ref)² / (ref² + 0.01)) over the linear RGB values.
//!
//! Speedups are read at equal score: for a target score, the samples (and wall time) each
//! sampler needed are interpolated log–log between the budgets of the sweep, and
//! speedup = uniform / perceptual (DESIGN §11: FLIP falls only as about spp^−0.4, so score
//! differences must never be quoted as savings).

use crate::display::FrozenToneMap;
use crate::film::Film;
use crate::output::encode_srgb8;
use perception::metric::DiffMetric;
use perception::threshold::ThresholdParams;
use perception::viewing::ViewingConditions;

/// Scores of one image against the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scores {
    /// Mean of the FLIP error map.
    pub flip_mean: f64,
    /// 99th percentile of the FLIP map after a 5×5 box filter.
    pub flip_p99: f64,
    /// Fraction of pixels aleph's metric calls visibly different.
    pub visible_fraction: f64,
    /// Relative mean squared error of the linear values.
    pub relmse: f64,
}

/// The judge: the reference's display image, its threshold map, and the frozen tone curve.
pub struct Judge {
    width: usize,
    height: usize,
    reference: Vec<f32>,
    reference_srgb: Vec<u8>,
    reference_lum: Vec<f32>,
    frozen: FrozenToneMap,
    metric: DiffMetric,
    map: perception::threshold::ThresholdMap,
    ppd: f32,
}

/// 5×5 box filter with clamped edges.
fn box5(v: &[f32], w: usize, h: usize) -> Vec<f32> {
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for dy in -2i64..=2 {
                for dx in -2i64..=2 {
                    let xx = (x as i64 + dx).clamp(0, w as i64 - 1) as usize;
                    let yy = (y as i64 + dy).clamp(0, h as i64 - 1) as usize;
                    s += v[yy * w + xx];
                }
            }
            out[y * w + x] = s / 25.0;
        }
    }
    out
}

/// The `p`-quantile (0–1) by sorting.
pub fn quantile(v: &[f32], p: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let i = ((s.len() - 1) as f64 * p).round() as usize;
    s[i] as f64
}

impl Judge {
    /// A judge for `reference` (linear RGB, `width × height`), displayed with `frozen` and seen
    /// under `view`.
    ///
    /// # Errors
    /// From the perception models.
    pub fn new(
        reference: Vec<f32>,
        width: usize,
        height: usize,
        frozen: FrozenToneMap,
        view: ViewingConditions,
    ) -> perception::Result<Judge> {
        let display = frozen.map(&reference)?;
        let reference_srgb = encode_srgb8(&display);
        let reference_lum = frozen.display_luminance(&reference)?;
        let metric = DiffMetric::new(width, height, view, ThresholdParams::default(), 100)?;
        let map = metric.reference_map(&reference_lum)?;
        Ok(Judge {
            width,
            height,
            reference,
            reference_srgb,
            reference_lum,
            frozen,
            metric,
            map,
            ppd: view.ppd as f32,
        })
    }

    /// The display sRGB of an image under the frozen curve.
    ///
    /// # Errors
    /// From the tone operator.
    pub fn display_srgb(&self, rgb: &[f32]) -> perception::Result<Vec<u8>> {
        Ok(encode_srgb8(&self.frozen.map(rgb)?))
    }

    /// FLIP error map of an image against the reference.
    ///
    /// # Errors
    /// From the tone operator.
    pub fn flip_map(&self, rgb: &[f32]) -> perception::Result<Vec<f32>> {
        let test = self.display_srgb(rgb)?;
        let (w, h) = (self.width as u32, self.height as u32);
        let r = nv_flip::FlipImageRgb8::with_data(w, h, &self.reference_srgb);
        let t = nv_flip::FlipImageRgb8::with_data(w, h, &test);
        Ok(nv_flip::flip(r, t, self.ppd).to_vec())
    }

    /// Scores an image (linear RGB).
    ///
    /// # Errors
    /// From the perception models.
    pub fn score(&self, rgb: &[f32]) -> perception::Result<Scores> {
        let fmap = self.flip_map(rgb)?;
        let flip_mean = fmap.iter().map(|&v| v as f64).sum::<f64>() / fmap.len() as f64;
        let flip_p99 = quantile(&box5(&fmap, self.width, self.height), 0.99);
        let lum = self.frozen.display_luminance(rgb)?;
        let diff = self
            .metric
            .compare_with_map(&self.map, &self.reference_lum, &lum)?;
        let relmse = rgb
            .iter()
            .zip(&self.reference)
            .map(|(&x, &r)| ((x - r) as f64).powi(2) / ((r as f64).powi(2) + 1e-2))
            .sum::<f64>()
            / rgb.len() as f64;
        Ok(Scores {
            flip_mean,
            flip_p99,
            visible_fraction: diff.visible_fraction,
            relmse,
        })
    }

    /// The reference's own noise floor: the scores of one half-buffer against the other.
    ///
    /// # Errors
    /// From the perception models.
    pub fn floor(
        film: &Film,
        frozen: &FrozenToneMap,
        view: ViewingConditions,
    ) -> perception::Result<Scores> {
        let j = Judge::new(
            film.mean_rgb_even(),
            film.width as usize,
            film.height as usize,
            frozen.clone(),
            view,
        )?;
        j.score(&film.mean_rgb_odd())
    }
}

/// Linear interpolation in log–log of the x at which a decreasing curve (x_i, y_i), x
/// increasing, reaches `target`. `None` if the curve never gets that low (or starts below it).
pub fn samples_for(curve: &[(f64, f64)], target: f64) -> Option<f64> {
    if curve.is_empty() || target <= 0.0 {
        return None;
    }
    if curve[0].1 <= target {
        return if curve[0].1 == target {
            Some(curve[0].0)
        } else {
            None
        };
    }
    for p in curve.windows(2) {
        let ((x0, y0), (x1, y1)) = (p[0], p[1]);
        if y1 <= target && y0 > target {
            let (lx0, lx1, ly0, ly1) = (x0.ln(), x1.ln(), y0.ln(), y1.ln());
            let t = (target.ln() - ly0) / (ly1 - ly0);
            return Some((lx0 + t * (lx1 - lx0)).exp());
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_log_interpolation() {
        // y = x^-0.5: y = 0.25 at x = 16.
        let curve: Vec<(f64, f64)> = [1.0f64, 4.0, 64.0]
            .iter()
            .map(|&x| (x, x.powf(-0.5)))
            .collect();
        assert!((samples_for(&curve, 0.25).unwrap() - 16.0).abs() < 1e-9);
        assert!(samples_for(&curve, 0.01).is_none());
        assert!(samples_for(&curve, 2.0).is_none());
    }

    #[test]
    fn quantiles() {
        let v: Vec<f32> = (0..=100).map(|i| i as f32).collect();
        assert_eq!(quantile(&v, 0.99), 99.0);
        assert_eq!(quantile(&v, 0.0), 0.0);
    }
}
