//! Reading images for the `diff` and `tonemap` commands: OpenEXR (exr crate), Radiance `.hdr`,
//! PNG and JPEG (image crate).

use std::path::{Path, PathBuf};

/// How the values of a loaded image are to be read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Encoding {
    /// Linear scene-referred values (EXR, Radiance HDR): cd/m² = Y × luminance scale.
    Linear,
    /// sRGB-encoded display values in [0, 1] (PNG, JPEG), already decoded to linear here;
    /// white is shown at [`perception::photometry::SRGB_WHITE_CD_M2`].
    DisplaySrgb,
}

/// An RGB image in linear values.
#[derive(Clone, Debug)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Interleaved linear RGB, row-major, row 0 at the top.
    pub rgb: Vec<f32>,
    /// What the values mean.
    pub encoding: Encoding,
    /// The EXR `whiteLuminance` attribute, cd/m² of RGB (1, 1, 1), when the file has one.
    pub white_luminance: Option<f32>,
    /// Negative values that were clamped to 0 on load (HDR photographs can hold a few).
    pub clamped_negative: usize,
}

/// Errors reading an image; each names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImageError {
    /// The file is missing or unreadable.
    #[error("{}: cannot read: {message}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// The file's format is not one aleph reads.
    #[error("{}: unsupported image format (aleph reads .exr, .hdr, .png, .jpg/.jpeg)", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
    },
    /// A pixel is NaN or infinite.
    #[error("{}: pixel ({x}, {y}) is not finite", path.display())]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// Column.
        x: usize,
        /// Row.
        y: usize,
    },
    /// The image has no pixels.
    #[error("{}: image is empty", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// Every pixel is black: there is no luminance to adapt to or tone map.
    #[error("{}: every pixel is black (nothing to tone map)", path.display())]
    AllBlack {
        /// The file.
        path: PathBuf,
    },
    /// The luminance scale (cd/m² per unit) is not a positive number.
    #[error("{}: {origin} must be a positive number of cd/m² per unit, got {value}", path.display())]
    LuminanceScale {
        /// The image file.
        path: PathBuf,
        /// Where the value came from: the `--luminance-scale` option or the file's
        /// `whiteLuminance` attribute.
        origin: &'static str,
        /// The value.
        value: f32,
    },
}

impl RgbImage {
    /// cd/m² per unit of the image's values: display-encoded images (PNG, JPEG) show white at
    /// [`perception::photometry::SRGB_WHITE_CD_M2`] (100); linear ones take `explicit` (a
    /// user's `--luminance-scale`), else the EXR's `whiteLuminance`, else 100 (so 1.0 is a
    /// 100 cd/m² display white). The one rule of `aleph diff` and `aleph tonemap`.
    ///
    /// # Errors
    /// [`ImageError::LuminanceScale`] naming `path` and where the bad value came from.
    pub fn luminance_scale(&self, path: &Path, explicit: Option<f32>) -> Result<f32, ImageError> {
        let white = perception::photometry::SRGB_WHITE_CD_M2;
        let (value, origin) = match (self.encoding, explicit, self.white_luminance) {
            (Encoding::DisplaySrgb, _, _) => (white, "the display white"),
            (Encoding::Linear, Some(k), _) => (k, "--luminance-scale"),
            (Encoding::Linear, None, Some(k)) => (k, "the file's whiteLuminance attribute"),
            (Encoding::Linear, None, None) => (white, "the default"),
        };
        if value.is_finite() && value > 0.0 {
            Ok(value)
        } else {
            Err(ImageError::LuminanceScale {
                path: path.to_path_buf(),
                origin,
                value,
            })
        }
    }

    /// True when every value is zero.
    pub fn is_black(&self) -> bool {
        self.rgb.iter().all(|&v| v == 0.0)
    }
}

fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default()
}

/// Reads an image. EXR and HDR are linear; PNG and JPEG are decoded from sRGB to linear display
/// values in [0, 1]. Negative values are clamped to 0 and counted; NaN or infinite values are an
/// error.
///
/// # Errors
/// [`ImageError`] naming the file.
pub fn read_image(path: &Path) -> Result<RgbImage, ImageError> {
    let read_err = |message: String| ImageError::Read {
        path: path.to_path_buf(),
        message,
    };
    if !path.exists() {
        return Err(read_err("file not found".into()));
    }
    let ext = extension(path);
    let mut img = match ext.as_str() {
        "exr" => read_exr(path).map_err(read_err)?,
        "hdr" | "png" | "jpg" | "jpeg" => {
            let dynimg = image::ImageReader::open(path)
                .map_err(|e| read_err(e.to_string()))?
                .with_guessed_format()
                .map_err(|e| read_err(e.to_string()))?
                .decode()
                .map_err(|e| read_err(e.to_string()))?;
            let linear = ext == "hdr";
            let rgb32 = dynimg.into_rgb32f();
            let (w, h) = (rgb32.width() as usize, rgb32.height() as usize);
            let mut rgb = rgb32.into_raw();
            if !linear {
                for v in rgb.iter_mut() {
                    *v = perception::photometry::srgb_to_linear(*v);
                }
            }
            RgbImage {
                width: w,
                height: h,
                rgb,
                encoding: if linear {
                    Encoding::Linear
                } else {
                    Encoding::DisplaySrgb
                },
                white_luminance: None,
                clamped_negative: 0,
            }
        }
        _ => {
            return Err(ImageError::Unsupported {
                path: path.to_path_buf(),
            });
        }
    };
    if img.width == 0 || img.height == 0 {
        return Err(ImageError::Empty {
            path: path.to_path_buf(),
        });
    }
    for (i, v) in img.rgb.iter_mut().enumerate() {
        if !v.is_finite() {
            let p = i / 3;
            return Err(ImageError::NonFinite {
                path: path.to_path_buf(),
                x: p % img.width,
                y: p / img.width,
            });
        }
        if *v < 0.0 {
            *v = 0.0;
            img.clamped_negative += 1;
        }
    }
    Ok(img)
}

/// Every channel of the first layer of an EXR file, by name (`R`, `Even.G`, `spp`, …), as f32
/// planes in row-major order: for aleph's own multi-layer files (cached references, partial
/// films) that [`read_image`]'s RGB view does not cover.
///
/// # Errors
/// [`ImageError::Read`] naming the file (missing, malformed, or larger than
/// [`MAX_IMAGE_PIXELS`]).
pub fn read_exr_channels(
    path: &Path,
) -> Result<std::collections::HashMap<String, Vec<f32>>, ImageError> {
    let layer = read_first_layer(path)?;
    Ok(layer
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect())
}

/// The first layer of an EXR file with every channel as stored.
fn read_first_layer(
    path: &Path,
) -> Result<exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>, ImageError> {
    let err = |message: String| ImageError::Read {
        path: path.to_path_buf(),
        message,
    };
    check_exr_size(path).map_err(err)?;
    let img = exr::prelude::read_all_flat_layers_from_file(path).map_err(|e| err(e.to_string()))?;
    img.layer_data
        .into_iter()
        .next()
        .ok_or_else(|| err("no layer".into()))
}

/// An EXR's first layer as stored: size, 32-bit integer and float channels by name, and text
/// attributes.
#[derive(Debug, Default)]
pub struct RawExr {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The data window's origin, pixels (aleph writes (0, 0)).
    pub origin: [i32; 2],
    /// u32 channels (bit patterns such as a partial film's sums), row-major.
    pub u32s: std::collections::HashMap<String, Vec<u32>>,
    /// f32 channels, row-major.
    pub f32s: std::collections::HashMap<String, Vec<f32>>,
    /// Text attributes.
    pub text: std::collections::HashMap<String, String>,
}

/// The first layer of an EXR file exactly as stored ([`RawExr`]).
///
/// # Errors
/// [`ImageError::Read`] naming the file (missing, malformed, or larger than
/// [`MAX_IMAGE_PIXELS`]).
pub fn read_exr_raw(path: &Path) -> Result<RawExr, ImageError> {
    let layer = read_first_layer(path)?;
    let mut raw = RawExr {
        width: layer.size.width() as u32,
        height: layer.size.height() as u32,
        origin: [
            layer.attributes.layer_position.x(),
            layer.attributes.layer_position.y(),
        ],
        ..Default::default()
    };
    for (k, v) in &layer.attributes.other {
        if let exr::meta::attribute::AttributeValue::Text(t) = v {
            raw.text.insert(k.to_string(), t.to_string());
        }
    }
    for c in layer.channel_data.list {
        match c.sample_data {
            exr::prelude::FlatSamples::U32(v) => {
                raw.u32s.insert(c.name.to_string(), v);
            }
            exr::prelude::FlatSamples::F32(v) => {
                raw.f32s.insert(c.name.to_string(), v);
            }
            exr::prelude::FlatSamples::F16(_) => {}
        }
    }
    Ok(raw)
}

/// Refuses a header whose layers claim more than [`MAX_IMAGE_PIXELS`].
fn check_exr_size(path: &Path) -> Result<(), String> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| e.to_string())?;
    for h in &meta.headers {
        let (w, hh) = (h.layer_size.width(), h.layer_size.height());
        if w.checked_mul(hh).is_none_or(|n| n > MAX_IMAGE_PIXELS) {
            return Err(format!(
                "the header says {w}×{hh} pixels, more than aleph reads ({MAX_IMAGE_PIXELS})"
            ));
        }
    }
    Ok(())
}

/// Largest image aleph reads, pixels: 2^28 (16384 × 16384), about 3 GiB as f32 RGB. A header
/// claiming more (a corrupt or hostile file) is refused before anything is allocated; the exr
/// crate would otherwise try to allocate it and abort the process.
pub const MAX_IMAGE_PIXELS: usize = 1 << 28;

fn read_exr(path: &Path) -> Result<RgbImage, String> {
    use exr::prelude::*;
    check_exr_size(path)?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |resolution, _| {
                (
                    resolution.width(),
                    vec![0f32; resolution.width() * resolution.height() * 3],
                )
            },
            |(w, buf): &mut (usize, Vec<f32>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let i = 3 * (pos.y() * *w + pos.x());
                buf[i] = r;
                buf[i + 1] = g;
                buf[i + 2] = b;
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| e.to_string())?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    Ok(RgbImage {
        width: w,
        height: h,
        rgb: layer.channel_data.pixels.1.clone(),
        encoding: self::Encoding::Linear,
        white_luminance: layer.attributes.white_luminance.or(image
            .attributes
            .other
            .get(&Text::from("whiteLuminance"))
            .and_then(|a| match a {
                AttributeValue::F32(v) => Some(*v),
                _ => None,
            })),
        clamped_negative: 0,
    })
}
