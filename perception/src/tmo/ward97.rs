//! WRP: Ward Larson, Rushmeier & Piatko 1997, "A Visibility Matching Tone Reproduction Operator
//! for High Dynamic Range Scenes", IEEE TVCG 3(4), §4 (histogram adjustment with the human
//! contrast-sensitivity ceiling, eqs. 4–9); reference implementation Radiance `pcond`.
//!
//! 1. A histogram of b = ln L_a over the foveal samples (the adaptation map over ~1°, clamped to
//!    [1e-4, 1e5] cd/m²), [`NUM_BINS`] bins between its minimum and maximum.
//! 2. Display brightness B_d(b) = ln L_dmin + (ln L_dmax − ln L_dmin) P(b), P the cumulative
//!    distribution (eq. 6).
//! 3. The slope of the mapping may not exceed what human contrast sensitivity allows (eq. 9):
//!    f(b_i) ≤ T Δb / (ln L_dmax − ln L_dmin) · [ΔL_t(L_d) L_w] / [ΔL_t(L_w) L_d], with ΔL_t
//!    Ward's TVI; bins above are trimmed and the cumulative distribution recomputed until the
//!    trimmings are at most 2.5 % of the remaining total T.
//! 4. If T falls to 2.5 % of the original count, the scene's range fits the display and no
//!    compression is needed: a linear mapping puts the brightest foveal sample at L_dmax.
//! 5. Per pixel, L_d = exp(B_d(ln L_w)) with P interpolated between bin centres, and the display
//!    value is (L_d − L_dmin)/(L_dmax − L_dmin) times the pixel's colour ratios.
//! 6. Mesopic colour loss (§5.1): between 5.62e-3 and 5.62 cd/m² of adaptation the colour
//!    ratios are blended towards grey, linearly in log L_a; below, the pixel is grey.
//!
//! **Deviation from the seed's Table 3**, which does not run as printed: it builds the histogram
//! on linear adaptation values but reads the bins back as logarithms (`exp(llmin + i·Δb)`), and
//! its final lookup drops the histogram's minimum (`d = L·bin_scale` instead of
//! `(ln L − b_min)·bin_scale`), and it has no linear fallback. We follow the paper.

use super::unit;
use crate::photometry::luminance;
use crate::tvi::tvi_ward97;
use rayon::prelude::*;

/// Histogram bins (the paper uses 100).
pub const NUM_BINS: usize = 100;
/// Lower clamp of foveal luminance, cd/m².
pub const L_MIN_CD_M2: f64 = 1e-4;
/// Upper clamp of foveal luminance, cd/m².
pub const L_MAX_CD_M2: f64 = 1e5;
/// Trimming tolerance: 2.5 % of the count.
pub const TOLERANCE: f64 = 0.025;
/// Lower end of the mesopic range for colour loss, cd/m².
pub const MESOPIC_LOW_CD_M2: f64 = 5.62e-3;
/// Upper end of the mesopic range for colour loss, cd/m².
pub const MESOPIC_HIGH_CD_M2: f64 = 5.62;

/// The WRP operator's display.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ward97 {
    /// Maximum display luminance L_dmax, cd/m² (default 100, Ward's).
    pub display_max_cd_m2: f64,
    /// Display dynamic range L_dmax / L_dmin (default 32).
    pub display_range: f64,
    /// Apply mesopic colour loss (default true).
    pub mesopic: bool,
}

impl Default for Ward97 {
    fn default() -> Self {
        Ward97 {
            display_max_cd_m2: 100.0,
            display_range: 32.0,
            mesopic: true,
        }
    }
}

/// The mapping found by histogram adjustment.
#[derive(Clone, Debug, PartialEq)]
pub enum Mapping {
    /// B_d at bin centres: `b_min + (i + 0.5) Δb` ↦ `bd[i]` (ln cd/m²).
    Histogram {
        /// ln L of the first bin's lower edge.
        b_min: f64,
        /// Bin width in ln L.
        db: f64,
        /// ln L_d at each bin centre.
        bd: Vec<f64>,
    },
    /// L_d = scale · L_w (the range fits the display).
    Linear {
        /// cd/m² on the display per cd/m² in the world.
        scale: f64,
    },
}

impl Ward97 {
    /// L_dmin = L_dmax / range.
    pub fn display_min_cd_m2(&self) -> f64 {
        self.display_max_cd_m2 / self.display_range
    }

    /// Builds the mapping from foveal adaptation samples (cd/m²).
    pub fn build(&self, foveal_cd_m2: &[f32]) -> Mapping {
        let b: Vec<f64> = foveal_cd_m2
            .iter()
            .map(|&l| (l as f64).clamp(L_MIN_CD_M2, L_MAX_CD_M2).ln())
            .collect();
        let b_min = b.iter().cloned().fold(f64::INFINITY, f64::min);
        let b_max = b.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let (ld_min, ld_max) = (self.display_min_cd_m2(), self.display_max_cd_m2);
        let log_d = (ld_max / ld_min).ln();
        let linear = Mapping::Linear {
            scale: ld_max / b_max.exp(),
        };
        if b_max - b_min <= 1e-9 {
            return linear;
        }
        let db = (b_max - b_min) / NUM_BINS as f64;
        let mut histo = vec![0f64; NUM_BINS];
        for &x in &b {
            let i = (((x - b_min) / db) as usize).min(NUM_BINS - 1);
            histo[i] += 1.0;
        }
        let t0 = b.len() as f64;
        let mut total = t0;
        let cumulative = |h: &[f64], total: f64| -> Vec<f64> {
            // P at bin centres: counts below the bin plus half the bin.
            let mut acc = 0.0;
            h.iter()
                .map(|&c| {
                    let p = (acc + 0.5 * c) / total;
                    acc += c;
                    p
                })
                .collect()
        };
        loop {
            let p = cumulative(&histo, total);
            let mut trimmings = 0.0;
            for i in 0..NUM_BINS {
                let lw = (b_min + (i as f64 + 0.5) * db).exp();
                let ld = (ld_min.ln() + log_d * p[i]).exp();
                let ceiling = total * db / log_d * (tvi_ward97(ld) * lw) / (tvi_ward97(lw) * ld);
                if histo[i] > ceiling {
                    trimmings += histo[i] - ceiling;
                    histo[i] = ceiling;
                }
            }
            total -= trimmings;
            if total <= TOLERANCE * t0 {
                return linear;
            }
            if trimmings <= TOLERANCE * total {
                break;
            }
        }
        let p = cumulative(&histo, total);
        Mapping::Histogram {
            b_min,
            db,
            bd: p.iter().map(|&pi| ld_min.ln() + log_d * pi).collect(),
        }
    }

    /// Display luminance (cd/m²) of world luminance `l_w` under `mapping`.
    pub fn display_luminance(&self, mapping: &Mapping, l_w_cd_m2: f64) -> f64 {
        match mapping {
            Mapping::Linear { scale } => scale * l_w_cd_m2,
            Mapping::Histogram { b_min, db, bd } => {
                let x = (l_w_cd_m2.clamp(L_MIN_CD_M2, L_MAX_CD_M2).ln() - b_min) / db - 0.5;
                let x = x.clamp(0.0, (NUM_BINS - 1) as f64);
                let i = (x as usize).min(NUM_BINS - 2);
                let f = x - i as f64;
                ((1.0 - f) * bd[i] + f * bd[i + 1]).exp()
            }
        }
    }

    /// Maps linear RGB (cd/m²) to display values in [0, 1]; `foveal_cd_m2` is the adaptation
    /// map (local mean over ~1°), used both for the histogram and for mesopic colour loss.
    pub fn map(
        &self,
        rgb_cd_m2: &[f32],
        _width: usize,
        _height: usize,
        foveal_cd_m2: &[f32],
    ) -> Vec<f32> {
        let mapping = self.build(foveal_cd_m2);
        let (ld_min, ld_max) = (self.display_min_cd_m2(), self.display_max_cd_m2);
        let (lo, hi) = (MESOPIC_LOW_CD_M2.log10(), MESOPIC_HIGH_CD_M2.log10());
        rgb_cd_m2
            .par_chunks_exact(3)
            .zip(foveal_cd_m2.par_iter())
            .flat_map_iter(|(p, &la)| {
                let lw = luminance(p[0], p[1], p[2]) as f64;
                if lw <= 0.0 {
                    return [0.0; 3];
                }
                let ld = self.display_luminance(&mapping, lw);
                let d = (ld - ld_min) / (ld_max - ld_min);
                let s = if self.mesopic {
                    ((la.max(1e-10) as f64).log10() - lo) / (hi - lo)
                } else {
                    1.0
                }
                .clamp(0.0, 1.0);
                let c = |v: f32| unit(d * (s * v as f64 / lw + (1.0 - s)));
                [c(p[0]), c(p[1]), c(p[2])]
            })
            .collect()
    }
}
