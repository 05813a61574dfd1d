//! Tone reproduction: operators that map scene luminance (cd/m²) to display values, after the
//! seed paper (Yee, Dutré & Pattanaik, "Fundamentals of Lighting and Perception", §7 and the
//! listings of its appendix, Tables 1–4) and the papers behind it.
//!
//! Every operator is a pure function over slices: it takes linear RGB already calibrated to
//! cd/m² (interleaved, row-major) and a per-pixel adaptation luminance (cd/m², from
//! [`crate::adaptation`]: global log average or a local mean over ~1°), and returns
//! **display-linear RGB in [0, 1]**, the fraction of the display's maximum luminance, before any
//! gamma or sRGB encoding.
//!
//! | operator | module | preserves | display defaults |
//! |---|---|---|---|
//! | constant scaling | [`exposure`] | ratios | key 0.18 of the log average |
//! | TR | [`tumblin93`] | brightness (Stevens & Stevens) | L_da 25, L_dmax 125 cd/m² |
//! | FPSG | [`ferwerda96`] | threshold visibility, with rods | L_da 25, L_dmax 125 cd/m² |
//! | WRP | [`ward97`] | visibility, histogram adjustment | L_dmax 100 cd/m², 32:1 |
//! | PTYG | [`pattanaik00`] | appearance (cone/rod responses) | G_d 25, white 125 cd/m² |
//! | Reinhard | [`reinhard02`] | photographic key | a = 0.18 |

pub mod exposure;
pub mod ferwerda96;
pub mod pattanaik00;
pub mod reinhard02;
pub mod tumblin93;
pub mod ward97;

use crate::error::{PerceptionError, Result, check_image};

/// The operators, for command lines, render jobs and contact sheets (serialized by their
/// command-line names: `exposure`, `tr`, `fpsg`, `wrp`, `ptyg`, `reinhard`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Operator {
    /// Constant scaling (exposure).
    Exposure,
    /// Tumblin & Rushmeier 1993.
    Tr,
    /// Ferwerda, Pattanaik, Shirley & Greenberg 1996.
    Fpsg,
    /// Ward Larson, Rushmeier & Piatko 1997.
    Wrp,
    /// Pattanaik, Tumblin, Yee & Greenberg 2000 (static).
    Ptyg,
    /// Reinhard, Stark, Shirley & Ferwerda 2002 (global).
    Reinhard,
}

impl Operator {
    /// All operators, in the order of the seed's Figure 4 (then Reinhard).
    pub const ALL: [Operator; 6] = [
        Operator::Exposure,
        Operator::Tr,
        Operator::Fpsg,
        Operator::Wrp,
        Operator::Ptyg,
        Operator::Reinhard,
    ];

    /// Short name as used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Operator::Exposure => "exposure",
            Operator::Tr => "tr",
            Operator::Fpsg => "fpsg",
            Operator::Wrp => "wrp",
            Operator::Ptyg => "ptyg",
            Operator::Reinhard => "reinhard",
        }
    }

    /// A label with the paper.
    pub fn label(self) -> &'static str {
        match self {
            Operator::Exposure => "Constant scaling",
            Operator::Tr => "TR (Tumblin & Rushmeier 1993)",
            Operator::Fpsg => "FPSG (Ferwerda et al. 1996)",
            Operator::Wrp => "WRP (Ward Larson et al. 1997)",
            Operator::Ptyg => "PTYG (Pattanaik et al. 2000)",
            Operator::Reinhard => "Reinhard et al. 2002",
        }
    }

    /// Parses a command-line name.
    pub fn from_name(s: &str) -> Option<Operator> {
        Operator::ALL.into_iter().find(|o| o.name() == s)
    }
}

/// Display settings shared by the operators; `None` keeps each operator's documented default.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Display {
    /// Maximum display luminance L_dmax, cd/m².
    pub max_cd_m2: Option<f64>,
    /// Display adaptation luminance L_da (TR, FPSG; PTYG's G_d), cd/m².
    pub ambient_cd_m2: Option<f64>,
}

/// The brightest display or surround the operators take, cd/m²: 1e5, ten times SMPTE ST 2084's
/// (PQ) 10,000 cd/m² ceiling and about the luminance of a sunlit white surface. Beyond it the
/// operators' display models (Tumblin–Rushmeier's, Pattanaik's) leave f32 range.
pub const MAX_DISPLAY_CD_M2: f64 = 1e5;

impl Display {
    /// Checks that given values are in (0, [`MAX_DISPLAY_CD_M2`]].
    ///
    /// # Errors
    /// [`PerceptionError::Parameter`] otherwise.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("display max (cd/m²)", self.max_cd_m2),
            ("display ambient (cd/m²)", self.ambient_cd_m2),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0 && v <= MAX_DISPLAY_CD_M2)
            {
                return Err(PerceptionError::Parameter {
                    name,
                    value: v,
                    range: "(0, 1e5] cd/m²",
                });
            }
        }
        Ok(())
    }
}

/// Applies `op` with its defaults (overridden by `display`) to linear RGB in cd/m² with the
/// given adaptation luminance. Returns display-linear RGB in [0, 1].
///
/// # Errors
/// [`PerceptionError`] for bad sizes, NaN/infinite/negative values or bad display settings.
pub fn apply(
    op: Operator,
    rgb_cd_m2: &[f32],
    width: usize,
    height: usize,
    adaptation_cd_m2: &[f32],
    display: &Display,
) -> Result<Vec<f32>> {
    check_inputs(rgb_cd_m2, width, height, adaptation_cd_m2)?;
    display.validate()?;
    Ok(match op {
        Operator::Exposure => exposure::Exposure::default().map(rgb_cd_m2),
        Operator::Tr => {
            let mut p = tumblin93::Tumblin93::default();
            if let Some(m) = display.max_cd_m2 {
                p.display_max_cd_m2 = m;
            }
            if let Some(a) = display.ambient_cd_m2 {
                p.display_adaptation_cd_m2 = a;
            }
            p.map(rgb_cd_m2, adaptation_cd_m2)
        }
        Operator::Fpsg => {
            let mut p = ferwerda96::Ferwerda96::default();
            if let Some(m) = display.max_cd_m2 {
                p.display_max_cd_m2 = m;
            }
            if let Some(a) = display.ambient_cd_m2 {
                p.display_adaptation_cd_m2 = a;
            }
            p.map(rgb_cd_m2, adaptation_cd_m2)
        }
        Operator::Wrp => {
            let mut p = ward97::Ward97::default();
            if let Some(m) = display.max_cd_m2 {
                p.display_max_cd_m2 = m;
            }
            p.map(rgb_cd_m2, width, height, adaptation_cd_m2)
        }
        Operator::Ptyg => {
            let mut p = pattanaik00::Pattanaik00::default();
            if let Some(a) = display.ambient_cd_m2 {
                p.display_adaptation_cd_m2 = a;
                p.display_white_cd_m2 = a * pattanaik00::WHITE_FACTOR;
            }
            if let Some(m) = display.max_cd_m2 {
                p.display_white_cd_m2 = m;
            }
            p.map(rgb_cd_m2, adaptation_cd_m2)
        }
        Operator::Reinhard => reinhard02::Reinhard02::default().map(rgb_cd_m2, width),
    })
}

/// Validates an RGB image and its adaptation map.
pub(crate) fn check_inputs(
    rgb: &[f32],
    width: usize,
    height: usize,
    adaptation: &[f32],
) -> Result<()> {
    check_image("RGB", rgb, width, height, 3, true)?;
    check_image("adaptation luminance", adaptation, width, height, 1, true)?;
    if rgb
        .chunks_exact(3)
        .all(|p| p[0] == 0.0 && p[1] == 0.0 && p[2] == 0.0)
    {
        return Err(PerceptionError::Parameter {
            name: "image luminance",
            value: 0.0,
            range: "not all black (nothing to tone map)",
        });
    }
    Ok(())
}

/// Clamps a display value to [0, 1], mapping NaN to 0.
#[inline]
pub(crate) fn unit(v: f64) -> f32 {
    if v > 0.0 { v.min(1.0) as f32 } else { 0.0 }
}

#[cfg(test)]
mod tests;
