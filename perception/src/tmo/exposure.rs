//! Constant scaling, the seed paper's baseline ("multiply the entire image by a constant",
//! §7, Figure 4): display = k · L_w / L_dmax with one k for the whole image.

use super::unit;
use crate::adaptation::log_average;
use crate::photometry::luminance_image;
use rayon::prelude::*;

/// Constant scaling. With `scale = None` the scale maps the log-average luminance to `key`
/// (0.18 of the display maximum by default, the photographic middle grey of Reinhard et al.
/// 2002 eq. 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exposure {
    /// Display value per cd/m² (overrides `key`).
    pub scale: Option<f64>,
    /// Display value given to the log-average luminance when `scale` is `None` (default 0.18).
    pub key: f64,
}

impl Default for Exposure {
    fn default() -> Self {
        Exposure {
            scale: None,
            key: 0.18,
        }
    }
}

impl Exposure {
    /// Maps linear RGB (cd/m²) to display values, clipping at 1.
    pub fn map(&self, rgb_cd_m2: &[f32]) -> Vec<f32> {
        let k = self.scale.unwrap_or_else(|| {
            let lum = luminance_image(rgb_cd_m2, 1.0);
            self.key / log_average(&lum).max(1e-9) as f64
        });
        rgb_cd_m2.par_iter().map(|&c| unit(c as f64 * k)).collect()
    }
}
