//! Image textures: linear RGB, bilinear filtering, repeat wrapping.

use crate::error::{SceneError, SceneResult};
use glam::{Vec2, Vec3};
use std::path::Path;

/// An RGB image texture in linear Rec.709 values.
///
/// 8- and 16-bit images are taken as sRGB-encoded and decoded with the sRGB EOTF (IEC
/// 61966-2-1); floating-point images (Radiance `.hdr`, EXR) are taken as linear. Alpha is
/// ignored. 8-bit images keep their bytes (3 per texel) and decode them at lookup through a
/// 256-entry table, as pbrt-v4 and Cycles keep byte textures: a quarter of the memory of linear
/// `f32` texels (Lost Empire's 2048² atlas takes 12.6 MB instead of 50), with the same values
/// bit for bit.
#[derive(Clone, Debug)]
pub struct Texture {
    width: usize,
    height: usize,
    /// Row-major texels, row 0 at the top of the image.
    texels: Texels,
    mean: Vec3,
}

/// A texture's storage.
#[derive(Clone, Debug)]
enum Texels {
    /// Linear values.
    Linear(Vec<Vec3>),
    /// 8-bit codes and each code's linear value.
    Bytes {
        codes: Vec<[u8; 3]>,
        decode: Box<[f32; 256]>,
    },
}

impl Texels {
    fn len(&self) -> usize {
        match self {
            Texels::Linear(t) => t.len(),
            Texels::Bytes { codes, .. } => codes.len(),
        }
    }

    /// Texel `i`, linear.
    #[inline(always)]
    fn get(&self, i: usize) -> Vec3 {
        match self {
            Texels::Linear(t) => t[i],
            Texels::Bytes { codes, decode } => byte_texel(codes[i], decode),
        }
    }
}

/// The linear value of an 8-bit texel through its texture's decode table.
#[inline(always)]
fn byte_texel([r, g, b]: [u8; 3], decode: &[f32; 256]) -> Vec3 {
    Vec3::new(decode[r as usize], decode[g as usize], decode[b as usize])
}

/// The linear value of each 8-bit code: the `image` crate's own conversion to `f32` (so a byte
/// texture holds exactly the values its `f32` decode would), then the sRGB EOTF when `srgb`.
fn byte_decode_table(srgb: bool) -> Box<[f32; 256]> {
    let ramp = image::RgbImage::from_fn(256, 1, |x, _| image::Rgb([x as u8; 3]));
    let as_f32 = image::DynamicImage::ImageRgb8(ramp).into_rgb32f();
    let mut table = Box::new([0f32; 256]);
    for (t, p) in table.iter_mut().zip(as_f32.pixels()) {
        *t = if srgb {
            srgb_to_linear(p.0[0])
        } else {
            p.0[0].max(0.0)
        };
    }
    table
}

pub use perception::photometry::srgb_to_linear;

impl Texture {
    /// Loads an image file through the `image` crate.
    ///
    /// # Errors
    /// [`SceneError::Texture`] when the file is missing, unreadable, empty or not a supported
    /// image (PNG, JPEG, Radiance HDR).
    pub fn load(path: &Path) -> SceneResult<Texture> {
        Texture::load_with(path, true)
    }

    /// Loads an image of non-colour data (height or normal map): 8- and 16-bit values are
    /// taken as they are, scaled to [0, 1], without the sRGB decoding.
    ///
    /// # Errors
    /// As [`Texture::load`].
    pub fn load_data(path: &Path) -> SceneResult<Texture> {
        Texture::load_with(path, false)
    }

    fn load_with(path: &Path, srgb: bool) -> SceneResult<Texture> {
        let err = |message: String| SceneError::Texture {
            path: path.to_path_buf(),
            message,
        };
        let reader = image::ImageReader::open(path)
            .map_err(|e| err(e.to_string()))?
            .with_guessed_format()
            .map_err(|e| err(e.to_string()))?;
        let img = reader.decode().map_err(|e| err(e.to_string()))?;
        if img.width() == 0 || img.height() == 0 {
            return Err(err("image has zero size".into()));
        }
        if matches!(
            img.color(),
            image::ColorType::L8
                | image::ColorType::La8
                | image::ColorType::Rgb8
                | image::ColorType::Rgba8
        ) {
            let rgb = img.into_rgb8();
            let (w, h) = (rgb.width() as usize, rgb.height() as usize);
            let codes = rgb.pixels().map(|p| p.0).collect();
            let texels = Texels::Bytes {
                codes,
                decode: byte_decode_table(srgb),
            };
            return Ok(Texture::with_texels(w, h, texels));
        }
        let linear = matches!(
            img.color(),
            image::ColorType::Rgb32F | image::ColorType::Rgba32F
        );
        let rgb = img.into_rgb32f();
        let (w, h) = (rgb.width() as usize, rgb.height() as usize);
        if w == 0 || h == 0 {
            return Err(err("image has zero size".into()));
        }
        let texels: Vec<Vec3> = rgb
            .pixels()
            .map(|p| {
                let c = Vec3::new(p.0[0], p.0[1], p.0[2]);
                if linear || !srgb {
                    c.max(Vec3::ZERO)
                } else {
                    Vec3::new(
                        srgb_to_linear(c.x),
                        srgb_to_linear(c.y),
                        srgb_to_linear(c.z),
                    )
                }
            })
            .collect();
        if texels.iter().any(|t| !t.is_finite()) {
            return Err(err("image contains NaN or infinite values".into()));
        }
        Ok(Texture::from_texels(w, h, texels))
    }

    /// A texture from row-major linear texels (row 0 at the top).
    ///
    /// # Panics
    /// If `texels.len() != width * height` or the size is zero.
    pub fn from_texels(width: usize, height: usize, texels: Vec<Vec3>) -> Texture {
        Texture::with_texels(width, height, Texels::Linear(texels))
    }

    fn with_texels(width: usize, height: usize, texels: Texels) -> Texture {
        assert!(width > 0 && height > 0 && texels.len() == width * height);
        let n = texels.len();
        let mean = (0..n).map(|i| texels.get(i)).sum::<Vec3>() / n as f32;
        Texture {
            width,
            height,
            texels,
            mean,
        }
    }

    /// Width and height in texels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Mean texel value (used to weight emissive textures when choosing lights).
    pub fn mean(&self) -> Vec3 {
        self.mean
    }

    /// Per-channel largest texel value.
    pub fn max(&self) -> Vec3 {
        (0..self.texels.len()).fold(Vec3::ZERO, |a, i| a.max(self.texels.get(i)))
    }

    /// Bilinearly filtered value at texture coordinates `uv` (OBJ convention: v = 0 at the
    /// bottom of the image), wrapping with period 1.
    #[inline]
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        let x = uv.x.rem_euclid(1.0) * self.width as f32 - 0.5;
        let y = (1.0 - uv.y.rem_euclid(1.0)) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let wrap = |i: i64, n: usize| i.rem_euclid(n as i64) as usize;
        let (xi, yi) = (x0 as i64, y0 as i64);
        let at =
            |dx: i64, dy: i64| wrap(yi + dy, self.height) * self.width + wrap(xi + dx, self.width);
        let corners = [at(0, 0), at(1, 0), at(0, 1), at(1, 1)];
        // One match on the storage for the four texels, not one per texel.
        let [t00, t10, t01, t11] = match &self.texels {
            Texels::Linear(t) => corners.map(|i| t[i]),
            Texels::Bytes { codes, decode } => corners.map(|i| byte_texel(codes[i], decode)),
        };
        (t00 * (1.0 - fx) + t10 * fx) * (1.0 - fy) + (t01 * (1.0 - fx) + t11 * fx) * fy
    }
}

/// How a bump or normal map perturbs the shading normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BumpKind {
    /// A height map (MTL `bump`/`map_bump`): the tangent-space normal (−s ∂h/∂x, −s ∂h/∂y, 1)
    /// from central differences of the texel values h ∈ [0, 1] per texel (Blinn 1978, "Simulation
    /// of Wrinkled Surfaces", in texture space): with s = 1 (`-bm 1`), a step of 1 over one
    /// texel is a 45° slope, whatever the scene's scale.
    Height {
        /// `-bm` multiplier.
        scale: f32,
    },
    /// A tangent-space normal map (MTL `norm`, or a bump map whose texels average near
    /// (0.5, 0.5, 1)): RGB = (n + 1) / 2 with +z along the surface normal, +x along +u and +y
    /// along +v (the OpenGL convention Blender and Cycles use).
    Normal,
}

/// A bump or normal map: a texture of non-colour data and how to read it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BumpMap {
    /// Index into the scene's textures (loaded with [`Texture::load_data`]).
    pub texture: u32,
    /// Height or normal map.
    pub kind: BumpKind,
}

impl BumpMap {
    /// The perturbed normal in tangent space (x along +u, y along +v, z along the normal; unit
    /// length) at texture coordinates `uv`.
    #[inline]
    pub fn tangent_normal(&self, uv: Vec2, textures: &[Texture]) -> Vec3 {
        let t = &textures[self.texture as usize];
        match self.kind {
            BumpKind::Normal => {
                let c = t.lookup(uv) * 2.0 - Vec3::ONE;
                let n = c.normalize_or_zero();
                if n.z > 0.0 { n } else { Vec3::Z }
            }
            BumpKind::Height { scale } => {
                let (du, dv) = (1.0 / t.width as f32, 1.0 / t.height as f32);
                let h = |p: Vec2| t.lookup(p).x;
                let sx = 0.5 * (h(uv + Vec2::new(du, 0.0)) - h(uv - Vec2::new(du, 0.0)));
                let sy = 0.5 * (h(uv + Vec2::new(0.0, dv)) - h(uv - Vec2::new(0.0, dv)));
                Vec3::new(-scale * sx, -scale * sy, 1.0).normalize()
            }
        }
    }
}

/// True when a texture's mean texel is within 0.15 of (0.5, 0.5, 1.0) per channel: a
/// tangent-space normal map rather than a height map.
pub fn looks_like_normal_map(t: &Texture) -> bool {
    let m = t.mean();
    (m - Vec3::new(0.5, 0.5, 1.0)).abs().max_element() < 0.15
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decode_matches_standard() {
        // IEC 61966-2-1: encoded 0.5 → 0.21404, 1 → 1, 0.04045 → 0.003130.
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.04045) - 0.003_130_8).abs() < 1e-6);
    }

    /// An 8-bit PNG of every code, loaded as colour and as data: each texel centre reads the
    /// IEC 61966-2-1 decode of code/255 (computed here in f64) and code/255, and a 16-bit PNG of
    /// the same codes × 257 (the same fractions) reads the same values through the f32 path.
    #[test]
    fn byte_textures_read_the_values_of_their_codes() {
        let dir = tempfile::tempdir().unwrap();
        let (p8, p16) = (dir.path().join("a.png"), dir.path().join("b.png"));
        let code = |x: u32, y: u32| ((x + 16 * y) * 7 % 256) as u8;
        image::RgbImage::from_fn(16, 16, |x, y| image::Rgb([code(x, y), 255 - code(x, y), 9]))
            .save(&p8)
            .unwrap();
        image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(16, 16, |x, y| {
            image::Rgb([
                code(x, y) as u16 * 257,
                (255 - code(x, y)) as u16 * 257,
                9 * 257,
            ])
        })
        .save(&p16)
        .unwrap();
        let iec = |c: u8| {
            let v = c as f64 / 255.0;
            if v <= 0.04045 {
                v / 12.92
            } else {
                ((v + 0.055) / 1.055).powf(2.4)
            }
        };
        let colour = Texture::load(&p8).unwrap();
        let data = Texture::load_data(&p8).unwrap();
        let wide = Texture::load(&p16).unwrap();
        assert!(matches!(colour.texels, Texels::Bytes { .. }));
        assert!(matches!(wide.texels, Texels::Linear(_)));
        for (x, y) in (0..16).flat_map(|y| (0..16).map(move |x| (x, y))) {
            let uv = Vec2::new((x as f32 + 0.5) / 16.0, 1.0 - (y as f32 + 0.5) / 16.0);
            let c = code(x, y);
            let (a, d, w) = (colour.lookup(uv), data.lookup(uv), wide.lookup(uv));
            for (got, want) in [(a.x, iec(c)), (a.y, iec(255 - c)), (a.z, iec(9))] {
                assert!(
                    (got as f64 - want).abs() <= 1e-6 * want.max(1e-3),
                    "{got} {want}"
                );
            }
            assert!(
                (d.x as f64 - c as f64 / 255.0).abs() < 1e-7,
                "code {c}: {}",
                d.x
            );
            assert!((w - a).abs().max_element() < 1e-6, "code {c}: {w} {a}");
        }
        assert!((colour.mean() - wide.mean()).abs().max_element() < 1e-6);
    }

    #[test]
    fn bilinear_lookup_interpolates_and_wraps() {
        let t = Texture::from_texels(2, 1, vec![Vec3::ZERO, Vec3::ONE]);
        // Texel centres at u = 0.25 and 0.75.
        assert!((t.lookup(Vec2::new(0.25, 0.5)) - Vec3::ZERO).length() < 1e-6);
        assert!((t.lookup(Vec2::new(0.75, 0.5)) - Vec3::ONE).length() < 1e-6);
        assert!((t.lookup(Vec2::new(0.5, 0.5)) - Vec3::splat(0.5)).length() < 1e-6);
        // Halfway between texel 1 and the wrapped texel 0.
        assert!((t.lookup(Vec2::new(1.0, 0.5)) - Vec3::splat(0.5)).length() < 1e-6);
        assert!((t.lookup(Vec2::new(1.75, 0.5)) - Vec3::ONE).length() < 1e-6);
    }
}
