//! Photometry: luminance from linear RGB and the conversion of image units to cd/m².
//!
//! # References
//! - ITU-R Recommendation BT.709-6 (2015), item 3.2: luminance weights of the Rec.709 primaries
//!   with D65 white.
//! - Ward Larson, Rushmeier & Piatko 1997, "A Visibility Matching Tone Reproduction Operator for
//!   High Dynamic Range Scenes", IEEE TVCG 3(4), section 5.1: scotopic luminance from CIE XYZ.

/// Rec.709 luminance weight of linear red (ITU-R BT.709-6).
pub const REC709_R: f32 = 0.2126;
/// Rec.709 luminance weight of linear green (ITU-R BT.709-6).
pub const REC709_G: f32 = 0.7152;
/// Rec.709 luminance weight of linear blue (ITU-R BT.709-6).
pub const REC709_B: f32 = 0.0722;

/// Luminous efficacy of radiation at 555 nm, lm/W: the factor from radiometric units
/// (W·sr⁻¹·m⁻²) to photometric ones (cd/m²) for the photopic luminosity function (CIE 1924).
pub const LUMINOUS_EFFICACY_LM_PER_W: f32 = 683.0;

/// Relative luminance Y of a linear Rec.709 RGB triple: Y = 0.2126 R + 0.7152 G + 0.0722 B
/// (ITU-R BT.709-6). Y is in the same units as the input (relative, or cd/m² if the RGB values
/// are already calibrated).
#[inline]
pub fn luminance(r: f32, g: f32, b: f32) -> f32 {
    REC709_R * r + REC709_G * g + REC709_B * b
}

/// Luminance of every pixel of an interleaved RGB image (`rgb.len()` = 3 × pixels), multiplied
/// by `scale_cd_m2` (cd/m² per image unit; 1 keeps relative luminance).
///
/// # Panics
/// If `rgb.len()` is not a multiple of 3.
pub fn luminance_image(rgb: &[f32], scale_cd_m2: f32) -> Vec<f32> {
    assert!(
        rgb.len().is_multiple_of(3),
        "RGB buffer length {} is not a multiple of 3",
        rgb.len()
    );
    rgb.chunks_exact(3)
        .map(|p| luminance(p[0], p[1], p[2]) * scale_cd_m2)
        .collect()
}
