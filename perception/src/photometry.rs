//! Photometry: luminance from linear RGB, calibration of image units to cd/m², scotopic
//! luminance.
//!
//! # References
//! - ITU-R Recommendation BT.709-6 (2015), item 3.2: luminance weights of the Rec.709 primaries
//!   with D65 white; IEC 61966-2-1 (sRGB) for the RGB → CIE XYZ matrix of those primaries.
//! - Ward Larson, Rushmeier & Piatko 1997, "A Visibility Matching Tone Reproduction Operator for
//!   High Dynamic Range Scenes", IEEE TVCG 3(4), §5.1: scotopic luminance from CIE XYZ,
//!   Y_s = Y · [1.33 (1 + (Y + Z)/X) − 1.68].

/// Rec.709 luminance weight of linear red (ITU-R BT.709-6).
pub const REC709_R: f32 = 0.2126;
/// Rec.709 luminance weight of linear green (ITU-R BT.709-6).
pub const REC709_G: f32 = 0.7152;
/// Rec.709 luminance weight of linear blue (ITU-R BT.709-6).
pub const REC709_B: f32 = 0.0722;

/// Luminous efficacy of radiation at 555 nm, lm/W: the factor from radiometric units
/// (W·sr⁻¹·m⁻²) to photometric ones (cd/m²) for the photopic luminosity function (CIE 1924).
pub const LUMINOUS_EFFICACY_LM_PER_W: f32 = 683.0;

/// Luminance of display white assumed for sRGB-encoded 8-bit images, cd/m² (the value pdiff
/// and the sRGB standard's reference display use).
pub const SRGB_WHITE_CD_M2: f32 = 100.0;

/// What the values of a luminance image mean (after the pfs `LUMINANCE` tag).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LuminanceKind {
    /// Absolute scene luminance, cd/m².
    Absolute,
    /// Relative luminance with unknown scale (a calibration factor is needed).
    Relative,
    /// Luminance emitted by a display, cd/m².
    Display,
}

/// Relative luminance Y of a linear Rec.709 RGB triple: Y = 0.2126 R + 0.7152 G + 0.0722 B
/// (ITU-R BT.709-6). Y is in the same units as the input.
#[inline]
pub fn luminance(r: f32, g: f32, b: f32) -> f32 {
    REC709_R * r + REC709_G * g + REC709_B * b
}

/// The approximate weights Y ≈ 0.3 R + 0.6 G + 0.1 B used by the listings of the seed paper
/// (Yee, Dutré & Pattanaik, "Fundamentals of Lighting and Perception", Tables 1–4). Use only where
/// exact agreement with those listings matters.
#[inline]
pub fn luminance_seed(r: f32, g: f32, b: f32) -> f32 {
    0.3 * r + 0.6 * g + 0.1 * b
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

/// CIE XYZ of linear Rec.709/sRGB RGB (D65), IEC 61966-2-1 matrix.
#[inline]
pub fn rgb_to_xyz(r: f32, g: f32, b: f32) -> [f32; 3] {
    [
        0.4124 * r + 0.3576 * g + 0.1805 * b,
        REC709_R * r + REC709_G * g + REC709_B * b,
        0.0193 * r + 0.1192 * g + 0.9505 * b,
    ]
}

/// Scotopic luminance from CIE XYZ (Ward Larson et al. 1997 §5.1):
/// Y_s = Y · [1.33 (1 + (Y + Z)/X) − 1.68], in the units of Y. Returns 0 when X ≤ 0.
///
/// For equal-energy white (X = Y = Z) this gives Y_s = 2.31 Y (daylight-like spectra have
/// scotopic/photopic ratios near 2.3–2.5); operators that want equal scotopic and photopic
/// luminance for that white divide by [`SCOTOPIC_EQUAL_ENERGY_RATIO`].
#[inline]
pub fn scotopic_luminance(x: f32, y: f32, z: f32) -> f32 {
    if x <= 0.0 {
        return 0.0;
    }
    (y * (1.33 * (1.0 + (y + z) / x) - 1.68)).max(0.0)
}

/// Y_s / Y of [`scotopic_luminance`] for equal-energy white (X = Y = Z): 1.33 · 3 − 1.68.
pub const SCOTOPIC_EQUAL_ENERGY_RATIO: f32 = 2.31;

/// Decodes an sRGB-encoded value in [0, 1] to linear (IEC 61966-2-1 EOTF).
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rec709_white_has_unit_luminance_and_xyz_of_d65() {
        assert!((luminance(1.0, 1.0, 1.0) - 1.0).abs() < 1e-6);
        let [x, y, z] = rgb_to_xyz(1.0, 1.0, 1.0);
        // D65 white point: x = 0.3127, y = 0.3290 (CIE 15).
        let s = x + y + z;
        assert!((x / s - 0.3127).abs() < 2e-4 && (y / s - 0.3290).abs() < 2e-4);
    }

    #[test]
    fn scotopic_of_equal_energy_white_is_close_to_photopic() {
        // X = Y = Z: 1 + (Y+Z)/X = 3, so Y_s = (1.33 · 3 − 1.68) Y = 2.31 Y.
        assert!((scotopic_luminance(1.0, 1.0, 1.0) - 2.31).abs() < 1e-6);
        assert_eq!(SCOTOPIC_EQUAL_ENERGY_RATIO, 2.31);
    }
}
