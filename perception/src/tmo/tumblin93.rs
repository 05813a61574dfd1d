//! TR: Tumblin & Rushmeier 1993, "Tone Reproduction for Realistic Images", IEEE CG&A 13(6),
//! as listed in the seed paper's Table 1.
//!
//! Brightness in brils follows Stevens & Stevens: log10 B = 0.004 [(S − 27)(8.4 − R) − 108] with
//! S = 100 + 10 log10 L_a and R = 10 log10(L_a / L), luminances in lamberts. Matching world and
//! display brightness, (S_w − 27)(8.4 − R_w) = (S_d − 27)(8.4 − R_d), gives
//! R_d = 8.4 − (S_w − 27)(8.4 − R_w)/(S_d − 27) and L_d = L_da · 10^(−0.1 R_d).
//!
//! As in the listing, luminance uses the weights 0.3, 0.6, 0.1, lamberts are cd/m² × 0.001/3.18,
//! the output is L_d / L_dmax times the pixel's colour ratios, clipped at 1.

use super::unit;
use crate::photometry::luminance_seed;
use rayon::prelude::*;

/// cd/m² → lamberts as in the seed's listing (1 L = 3183 cd/m², rounded to 3180).
#[inline]
pub fn cd_m2_to_lambert(c: f64) -> f64 {
    c * 0.001 / 3.18
}

/// lamberts → cd/m² as in the seed's listing.
#[inline]
pub fn lambert_to_cd_m2(l: f64) -> f64 {
    l * 3.18 * 1000.0
}

/// The TR operator's display.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tumblin93 {
    /// Display adaptation luminance L_da, cd/m² (default 25, the seed's `DISPLAY_AMBIENT`).
    pub display_adaptation_cd_m2: f64,
    /// Maximum display luminance L_dmax, cd/m² (default 125, `MAX_DISPLAY_LUMINANCE`).
    pub display_max_cd_m2: f64,
}

impl Default for Tumblin93 {
    fn default() -> Self {
        Tumblin93 {
            display_adaptation_cd_m2: 25.0,
            display_max_cd_m2: 125.0,
        }
    }
}

impl Tumblin93 {
    /// Display luminance (cd/m²) for world luminance `l_w` at world adaptation `l_wa`.
    pub fn display_luminance(&self, l_w_cd_m2: f64, l_wa_cd_m2: f64) -> f64 {
        let l_da = cd_m2_to_lambert(self.display_adaptation_cd_m2);
        let s_d = 100.0 + 10.0 * l_da.log10();
        let l_wa = cd_m2_to_lambert(l_wa_cd_m2.max(1e-9));
        let l_w = cd_m2_to_lambert(l_w_cd_m2.max(1e-12));
        let s_w = 100.0 + 10.0 * l_wa.log10();
        let r_w = -10.0 * (l_w / l_wa).log10();
        let r_d = 8.4 - (s_w - 27.0) * (8.4 - r_w) / (s_d - 27.0);
        lambert_to_cd_m2(l_da * 10f64.powf(-0.1 * r_d))
    }

    /// Maps linear RGB (cd/m²) with per-pixel adaptation to display values in [0, 1].
    pub fn map(&self, rgb_cd_m2: &[f32], adaptation_cd_m2: &[f32]) -> Vec<f32> {
        rgb_cd_m2
            .par_chunks_exact(3)
            .zip(adaptation_cd_m2.par_iter())
            .flat_map_iter(|(p, &la)| {
                let y = luminance_seed(p[0], p[1], p[2]) as f64;
                if y <= 0.0 {
                    return [0.0; 3];
                }
                let ld = self.display_luminance(y, la as f64) / self.display_max_cd_m2;
                [
                    unit(ld * p[0] as f64 / y),
                    unit(ld * p[1] as f64 / y),
                    unit(ld * p[2] as f64 / y),
                ]
            })
            .collect()
    }
}
