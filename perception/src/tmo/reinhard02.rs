//! Reinhard, Stark, Shirley & Ferwerda 2002, "Photographic Tone Reproduction for Digital
//! Images", SIGGRAPH: the global operator, eqs. 1–4.

use super::unit;
use crate::adaptation::log_average;
use crate::photometry::luminance;
use rayon::prelude::*;

/// The global photographic operator: L_m = (a / L̄_w) L_w (eq. 2),
/// L_d = L_m (1 + L_m / L_white²) / (1 + L_m) (eq. 4), colour scaled by L_d / L_w.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reinhard02 {
    /// Key a (default 0.18, "middle grey").
    pub key: f64,
    /// Smallest scaled luminance mapped to white; `None` uses the image's largest L_m, as the
    /// paper suggests.
    pub white: Option<f64>,
    /// The log-average luminance L̄_w, cd/m²; `None` computes it from the image (eq. 1). Fixing
    /// it (and `white`) freezes the curve, e.g. to map half-buffer images identically.
    pub log_average: Option<f64>,
}

impl Default for Reinhard02 {
    fn default() -> Self {
        Reinhard02 {
            key: 0.18,
            white: None,
            log_average: None,
        }
    }
}

impl Reinhard02 {
    /// The curve's parameters for an image: (L̄_w, L_white in scaled units).
    pub fn parameters(&self, rgb_cd_m2: &[f32]) -> (f64, f64) {
        if let (Some(lbar), Some(white)) = (self.log_average, self.white) {
            // Frozen: nothing to read from the image.
            return (lbar.max(1e-9), white);
        }
        let lum: Vec<f32> = rgb_cd_m2
            .par_chunks_exact(3)
            .map(|p| luminance(p[0], p[1], p[2]))
            .collect();
        let lbar = self
            .log_average
            .unwrap_or_else(|| log_average(&lum) as f64)
            .max(1e-9);
        let lmax = lum.iter().fold(0f32, |a, &b| a.max(b)) as f64 * self.key / lbar;
        (lbar, self.white.unwrap_or(lmax))
    }

    /// Maps linear RGB (cd/m²) to display values in [0, 1].
    pub fn map(&self, rgb_cd_m2: &[f32]) -> Vec<f32> {
        let (lbar, white) = self.parameters(rgb_cd_m2);
        let scale = self.key / lbar;
        let white2 = white.max(1e-9).powi(2);
        let mut out = vec![0f32; rgb_cd_m2.len() - rgb_cd_m2.len() % 3];
        out.par_chunks_exact_mut(3)
            .zip(rgb_cd_m2.par_chunks_exact(3))
            .for_each(|(o, p)| {
                let lw = luminance(p[0], p[1], p[2]);
                let lm = lw as f64 * scale;
                let ld = lm * (1.0 + lm / white2) / (1.0 + lm);
                let k = if lw > 0.0 { ld / lw as f64 } else { 0.0 };
                for c in 0..3 {
                    o[c] = unit(p[c] as f64 * k);
                }
            });
        out
    }
}
