//! Errors of the perception crate.

/// Invalid input to a perception model. Nothing in this crate panics on bad image data; it
/// returns one of these.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PerceptionError {
    /// Width or height is zero.
    #[error("image has zero size ({width}×{height})")]
    ZeroSize {
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
    },
    /// A buffer's length does not match `width × height × channels`.
    #[error("{what}: buffer holds {len} values, expected {expected} ({width}×{height}×{channels})")]
    BufferSize {
        /// Which buffer.
        what: &'static str,
        /// Its length.
        len: usize,
        /// The expected length.
        expected: usize,
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
        /// Values per pixel.
        channels: usize,
    },
    /// Two images that must have the same size do not.
    #[error("images differ in size: {a_width}×{a_height} vs {b_width}×{b_height}")]
    SizeMismatch {
        /// First width.
        a_width: usize,
        /// First height.
        a_height: usize,
        /// Second width.
        b_width: usize,
        /// Second height.
        b_height: usize,
    },
    /// A pixel is NaN or infinite.
    #[error("{what}: pixel ({x}, {y}) is not finite ({value})")]
    NonFinite {
        /// Which buffer.
        what: &'static str,
        /// Column.
        x: usize,
        /// Row.
        y: usize,
        /// The value.
        value: f32,
    },
    /// A luminance is negative.
    #[error("{what}: pixel ({x}, {y}) is negative ({value})")]
    Negative {
        /// Which buffer.
        what: &'static str,
        /// Column.
        x: usize,
        /// Row.
        y: usize,
        /// The value.
        value: f32,
    },
    /// A parameter is outside its valid range; the message gives the range.
    #[error("{name} = {value:?} is out of range: {range}")]
    Parameter {
        /// Parameter name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// The valid range, in words.
        range: &'static str,
    },
    /// A field of view that puts too many or too few pixels in a degree.
    #[error(
        "a field of view of {fov_deg:?}° over {width_px} pixels gives {ppd:?} pixels per \
         degree, outside {range}"
    )]
    FieldOfView {
        /// The horizontal field of view, degrees.
        fov_deg: f64,
        /// The image width, pixels.
        width_px: f64,
        /// The pixels per degree it gives.
        ppd: f64,
        /// The valid range of pixels per degree, in words.
        range: &'static str,
    },
}

/// Result alias.
pub type Result<T> = std::result::Result<T, PerceptionError>;

/// Checks a single-channel image: size non-zero, length `width × height`, every value finite
/// and (if `non_negative`) ≥ 0.
pub(crate) fn check_image(
    what: &'static str,
    data: &[f32],
    width: usize,
    height: usize,
    channels: usize,
    non_negative: bool,
) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(PerceptionError::ZeroSize { width, height });
    }
    let expected = width * height * channels;
    if data.len() != expected {
        return Err(PerceptionError::BufferSize {
            what,
            len: data.len(),
            expected,
            width,
            height,
            channels,
        });
    }
    for (i, &v) in data.iter().enumerate() {
        let p = i / channels;
        if !v.is_finite() {
            return Err(PerceptionError::NonFinite {
                what,
                x: p % width,
                y: p / width,
                value: v,
            });
        }
        if non_negative && v < 0.0 {
            return Err(PerceptionError::Negative {
                what,
                x: p % width,
                y: p / width,
                value: v,
            });
        }
    }
    Ok(())
}

impl PerceptionError {
    /// Checks an interleaved RGB image: size, length, finite and non-negative values.
    ///
    /// # Errors
    /// The corresponding [`PerceptionError`].
    pub fn check_rgb(rgb: &[f32], width: usize, height: usize) -> Result<()> {
        check_image("RGB", rgb, width, height, 3, true)
    }
}
