//! FPSG: Ferwerda, Pattanaik, Shirley & Greenberg 1996, "A Model of Visual Adaptation for
//! Realistic Image Synthesis", SIGGRAPH, §6 eq. 7, the seed paper's Table 2.
//!
//! Threshold-visibility matching with Ward's contrast scale factors, one for the cones and one
//! for the rods: L_d = m_p L_w + k(L_wa) m_s L_ws, where L_ws is the scene's scotopic luminance
//! and
//! - m_p = t_p(L_da) / t_p(L_wa): photopic world thresholds onto the display's;
//! - m_s = t_p(L_da) / t_s(L_wa): scotopic world thresholds onto the display's *photopic*
//!   thresholds, since the display is seen with cones. (A literal reading gives
//!   t_s(L_da)/t_s(L_wa); at a 25 cd/m² display the rods are saturated, so their threshold there
//!   has no meaning for the viewer; we follow the paper's reasoning.)
//! - k(L_wa) is the mesopic blend, 1 at and below log10 L_wa = −2.5 falling linearly in
//!   log10 L_wa to 0 at 0.8, the photopic limit (our choice; Ferwerda et al. only say k goes
//!   from 1 to 0 across the mesopic range).
//!
//! t_p, t_s are Ferwerda's photopic and scotopic TVIs ([`crate::tvi`]). The rod term is
//! achromatic (rods do not see colour). Display values are L_d / L_dmax, clipped to [0, 1].
//!
//! **Agreement with the seed's listing.** The listing scales RGB by
//! tviWard97(L_da) / L_dmax / tviWard97(L_wa) and has no rod term. Above 10^0.8 cd/m² (k = 0)
//! and for a photopic display, tviWard97 equals t_p (it is their minimum, and cones win there),
//! so this operator reproduces the listing exactly; below, it adds the rods.

use super::unit;
use crate::photometry::{rgb_to_xyz, scotopic_luminance};
use crate::tvi::{tvi_photopic, tvi_scotopic};
use rayon::prelude::*;

/// log10 L_wa where the mesopic blend k reaches 1 (all rods), cd/m².
pub const MESOPIC_LOW_LOG10: f64 = -2.5;
/// log10 L_wa where k reaches 0 (all cones).
pub const MESOPIC_HIGH_LOG10: f64 = 0.8;

/// The FPSG operator's display.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ferwerda96 {
    /// Display adaptation luminance L_da, cd/m² (default 25, the seed's `DISPLAY_AMBIENT`).
    pub display_adaptation_cd_m2: f64,
    /// Maximum display luminance L_dmax, cd/m² (default 125).
    pub display_max_cd_m2: f64,
}

impl Default for Ferwerda96 {
    fn default() -> Self {
        Ferwerda96 {
            display_adaptation_cd_m2: 25.0,
            display_max_cd_m2: 125.0,
        }
    }
}

/// The mesopic blend k(L_wa) ∈ [0, 1].
pub fn mesopic_k(l_wa_cd_m2: f64) -> f64 {
    let x = l_wa_cd_m2.max(1e-10).log10();
    ((MESOPIC_HIGH_LOG10 - x) / (MESOPIC_HIGH_LOG10 - MESOPIC_LOW_LOG10)).clamp(0.0, 1.0)
}

impl Ferwerda96 {
    /// The cone and rod scale factors (m_p, m_s) at world adaptation `l_wa` (cd/m²).
    pub fn scale_factors(&self, l_wa_cd_m2: f64) -> (f64, f64) {
        let td = tvi_photopic(self.display_adaptation_cd_m2);
        (td / tvi_photopic(l_wa_cd_m2), td / tvi_scotopic(l_wa_cd_m2))
    }

    /// Maps linear RGB (cd/m²) with per-pixel adaptation to display values in [0, 1].
    pub fn map(&self, rgb_cd_m2: &[f32], adaptation_cd_m2: &[f32]) -> Vec<f32> {
        rgb_cd_m2
            .par_chunks_exact(3)
            .zip(adaptation_cd_m2.par_iter())
            .flat_map_iter(|(p, &la)| {
                let la = la as f64;
                let (m_p, m_s) = self.scale_factors(la);
                let k = mesopic_k(la);
                let rod = if k > 0.0 {
                    let [x, y, z] = rgb_to_xyz(p[0], p[1], p[2]);
                    k * m_s * scotopic_luminance(x, y, z) as f64
                } else {
                    0.0
                };
                let f = |c: f32| unit((m_p * c as f64 + rod) / self.display_max_cd_m2);
                [f(p[0]), f(p[1]), f(p[2])]
            })
            .collect()
    }
}
