//! Reinhard, Stark, Shirley & Ferwerda 2002, "Photographic Tone Reproduction for Digital
//! Images", SIGGRAPH: the global operator, eqs. 1–4.

use super::unit;
use crate::adaptation::log_average;
use crate::photometry::luminance;
use rayon::prelude::*;

/// The global photographic operator: L_m = (a / L̄_w) L_w (eq. 2),
/// L_d = L_m (1 + L_m / L_white²) / (1 + L_m) (eq. 4), colour scaled by L_d / L_w.
///
/// The paper sets L_white to the image's largest L_m. In a Monte Carlo render that maximum is
/// noise. A firefly, a lone pixel thousands of times its neighbours, would at any spp set the
/// white of every other pixel (a 256×170 Lost Empire render at 1024 spp drew 1.5–2 % darker
/// than its 4096-spp reference because of one such pixel), so a pixel counts toward L_white
/// with at most [`WHITE_NEIGHBOUR_RATIO`] times its brightest neighbour's luminance. And a
/// small noisy highlight, a glint of the sun on a glossy coat, is a cluster of pixels whose
/// brightest is the upper tail of its noise: on the Mori knob under a sunset map (256×192) that
/// pixel put L_white 1.02–1.75× the converged image's from one uniform render to the next at
/// 32–128 spp, and the displayed images differed from the reference's by FLIP mean 0.04–0.38
/// where their noise alone scores 0.02–0.04. So L_white is the [`WHITE_RANK`]-th largest capped
/// luminance ([`white_luminance`]; on images over 90,000 pixels the one exceeded by
/// [`WHITE_FRACTION`] of them): the white of a patch of at least 3 × 3 pixels' worth. On that
/// scene the same renders' whites then lie within 0.4 % of each other and at 1.002× the
/// reference's. A highlight smaller than that is drawn white, as a firefly is; where the
/// brightest region is larger (a light source, a lit sky), L_white is the paper's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reinhard02 {
    /// Key a (default 0.18, "middle grey").
    pub key: f64,
    /// Smallest scaled luminance mapped to white; `None` uses the image's largest L_m, as the
    /// paper suggests, with isolated outliers capped and small noisy highlights passed over
    /// ([`white_luminance`]).
    pub white: Option<f64>,
    /// The log-average luminance L̄_w, cd/m²; `None` computes it from the image (eq. 1). Fixing
    /// it (and `white`) freezes the curve, e.g. to map half-buffer images identically.
    pub log_average: Option<f64>,
}

/// How many times its brightest neighbour's luminance a pixel may count toward L_white.
pub const WHITE_NEIGHBOUR_RATIO: f32 = 2.0;

/// Rank of the capped luminance that sets L_white ([`white_luminance`]): the 9th largest, a
/// 3 × 3 patch's worth of pixels (images of fewer than 144 pixels: one in 16 of them, at least
/// the largest).
pub const WHITE_RANK: usize = 9;

/// Share of an image's pixels above L_white on images large enough for it to exceed
/// [`WHITE_RANK`] pixels (over 90,000): 10⁻⁴, so the white does not depend on the resolution
/// a highlight is rendered at.
pub const WHITE_FRACTION: f64 = 1e-4;

/// The luminance that sets Reinhard's white: with each pixel of `lum` (row-major, `width`
/// pixels a row; a last partial row is read as it stands) counted as at most
/// [`WHITE_NEIGHBOUR_RATIO`] times the largest of its up to eight neighbours (a pixel without
/// neighbours, in a 1 × 1 image, as itself), the k-th largest, k = max(min([`WHITE_RANK`],
/// n / 16), ⌈n · [`WHITE_FRACTION`]⌉, 1) for n pixels. Non-finite values count as 0; 0 for an
/// empty or all-dark image.
///
/// # Panics
/// If `width` is 0 and `lum` is not empty.
pub fn white_luminance(lum: &[f32], width: usize) -> f32 {
    if lum.is_empty() {
        return 0.0;
    }
    assert!(
        width > 0,
        "white_luminance: width 0 for {} pixels",
        lum.len()
    );
    let height = lum.len().div_ceil(width);
    let at = |x: usize, y: usize| {
        let v = lum.get(y * width + x).copied().unwrap_or(0.0);
        if v.is_finite() { v.max(0.0) } else { 0.0 }
    };
    let capped_at = |x: usize, y: usize| {
        let v = at(x, y);
        let mut near = f32::NEG_INFINITY;
        for ny in y.saturating_sub(1)..(y + 2).min(height) {
            for nx in x.saturating_sub(1)..(x + 2).min(width) {
                if (nx, ny) != (x, y) {
                    near = near.max(at(nx, ny));
                }
            }
        }
        if near == f32::NEG_INFINITY {
            v
        } else {
            v.min(WHITE_NEIGHBOUR_RATIO * near)
        }
    };
    let n = lum.len();
    let k = WHITE_RANK
        .min(n / 16)
        .max((n as f64 * WHITE_FRACTION).ceil() as usize)
        .clamp(1, n);
    // The k largest of each row's capped values, kept per task and merged: no buffer of the
    // whole image.
    let mut top = (0..height)
        .into_par_iter()
        .fold(Vec::new, |mut acc: Vec<f32>, y| {
            // Values at or below the least of k already held cannot raise the k-th largest
            // (a capped value is at most the pixel's own).
            let floor = if acc.len() >= k {
                acc.iter().copied().fold(f32::INFINITY, f32::min)
            } else {
                -1.0
            };
            acc.extend(
                (0..width.min(n - y * width))
                    .filter(|&x| at(x, y) > floor)
                    .map(|x| capped_at(x, y)),
            );
            keep_largest(&mut acc, k, 4 * k);
            acc
        })
        .reduce(Vec::new, |mut a, b| {
            a.extend(b);
            keep_largest(&mut a, k, 4 * k);
            a
        });
    keep_largest(&mut top, k, k);
    top.iter().copied().fold(f32::INFINITY, f32::min)
}

/// Cuts `v` to its `k` largest values (in any order) once it holds more than `limit`.
fn keep_largest(v: &mut Vec<f32>, k: usize, limit: usize) {
    if v.len() > limit {
        v.select_nth_unstable_by(k - 1, |a, b| b.total_cmp(a));
        v.truncate(k);
    }
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
    /// The curve's parameters for an image (`rgb_cd_m2` interleaved RGB in cd/m², `width`
    /// pixels a row): (L̄_w, L_white in scaled units).
    pub fn parameters(&self, rgb_cd_m2: &[f32], width: usize) -> (f64, f64) {
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
        let lmax = white_luminance(&lum, width) as f64 * self.key / lbar;
        (lbar, self.white.unwrap_or(lmax))
    }

    /// Maps linear RGB (cd/m², interleaved, `width` pixels a row) to display values in [0, 1].
    pub fn map(&self, rgb_cd_m2: &[f32], width: usize) -> Vec<f32> {
        let (lbar, white) = self.parameters(rgb_cd_m2, width);
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
