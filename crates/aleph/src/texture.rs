//! Image textures: linear RGB, bilinear filtering, repeat wrapping, and mip maps for lookups
//! over a footprint (trilinear filtering, Williams 1983, "Pyramidal Parametrics").

use crate::error::{SceneError, SceneResult};
use glam::{Vec2, Vec3, Vec4};
use std::path::Path;

/// An RGB image texture in linear Rec.709 values.
///
/// 8- and 16-bit images are taken as sRGB-encoded and decoded with the sRGB EOTF (IEC
/// 61966-2-1); floating-point images (Radiance `.hdr`, EXR) are taken as linear. Alpha is not
/// looked up; a colour texture's alpha weights its mip levels and bleeds its covered colours
/// into its holes ([`Texture::with_mip_maps_weighted`]). 8-bit images keep their bytes (3 per
/// texel) and decode them at lookup through a 256-entry table, as pbrt-v4 and Cycles keep byte
/// textures: a quarter of the memory of linear `f32` texels (Lost Empire's 2048² atlas takes
/// 12.6 MB instead of 50), with the same values bit for bit.
#[derive(Clone, Debug)]
pub struct Texture {
    width: usize,
    height: usize,
    /// Row-major texels, row 0 at the top of the image.
    texels: Texels,
    mean: Vec3,
    /// Mip levels 1, 2, … (each half the size of the one before, rounded up, down to 1 × 1),
    /// empty for a texture without mip maps ([`Texture::with_mip_maps`]).
    mips: Vec<Level>,
}

/// What a texture lookup is filtered over ([`Texture::lookup_over`]): a footprint `width`
/// wide in texture coordinates (the unit square spans the texture), kept inside the texture
/// coordinates' bounds `lo`..`hi` of the surface looked up (its triangle), so that a texture
/// atlas's neighbouring tiles do not bleed in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    /// Width in texture coordinates; 0 for a point lookup.
    pub width: f32,
    /// Lower bounds of the surface's texture coordinates.
    pub lo: Vec2,
    /// Upper bounds of the surface's texture coordinates.
    pub hi: Vec2,
}

impl Footprint {
    /// A lookup at a point (bilinear, at full size).
    pub const POINT: Footprint = Footprint {
        width: 0.0,
        lo: Vec2::ZERO,
        hi: Vec2::ZERO,
    };
}

/// One mip level: `width × height` texels, row-major, row 0 at the top.
#[derive(Clone, Debug)]
struct Level {
    width: usize,
    height: usize,
    texels: Texels,
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
        let (mut texture, coverage) = Texture::load_with(path, true)?;
        if let Some(a) = &coverage {
            texture.bleed_into_holes(a);
        }
        Ok(texture.with_mip_maps_weighted(coverage.as_deref()))
    }

    /// Loads an image of non-colour data (height or normal map): 8- and 16-bit values are
    /// taken as they are, scaled to [0, 1], without the sRGB decoding.
    ///
    /// # Errors
    /// As [`Texture::load`].
    pub fn load_data(path: &Path) -> SceneResult<Texture> {
        Ok(Texture::load_with(path, false)?.0)
    }

    /// The texture, and for a colour texture (`srgb`) its alpha channel (row-major, in [0, 1])
    /// if it has one that is not opaque everywhere.
    fn load_with(path: &Path, srgb: bool) -> SceneResult<(Texture, Option<Vec<f32>>)> {
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
        // Only a colour texture's alpha is used ([`Texture::load`]); data textures skip it.
        let coverage = if srgb { coverage(&img) } else { None };
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
            return Ok((Texture::with_texels(w, h, texels), coverage));
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
        Ok((Texture::from_texels(w, h, texels), coverage))
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
            mips: Vec::new(),
        }
    }

    /// The texture with its mip maps: level k + 1 is level k box-filtered to half its size in
    /// each direction (rounded up), each texel the exact area-weighted mean of the texels of
    /// level k it covers (so every level keeps the texture's mean), down to 1 × 1. Levels of an
    /// 8-bit texture are filtered in linear values and stored as the nearest 8-bit codes of its
    /// decode table (a third more memory in all); others as linear values.
    pub fn with_mip_maps(self) -> Texture {
        self.with_mip_maps_weighted(None)
    }

    /// [`Texture::with_mip_maps`], each level's texels weighted by `coverage` (one alpha in
    /// [0, 1] per texel of the full-size texture, row-major) where given: a level's texel is
    /// the mean of the full-size texels under it weighted by their alpha (the premultiplied
    /// colour's mean over the alpha's), or the plain mean where their alpha is 0 everywhere.
    /// Where a cut-out ([`crate::geometry::AlphaMask`], MTL `map_d`) makes holes, the surface
    /// that remains shows only the covered texels, and their colour is what a minified lookup
    /// should average: with plain means, Lost Empire's leaves (their atlas's holes hold dark
    /// colours) came out 5–18 % darker in 8 × 8-pixel blocks than with point lookups.
    /// [`Texture::load`] also bleeds the covered colours into the holes' first ring
    /// (`Texture::bleed_into_holes`), for the bilinear lookups at full size.
    ///
    /// # Panics
    /// If `coverage` is given and does not have one value per texel.
    pub fn with_mip_maps_weighted(mut self, coverage: Option<&[f32]>) -> Texture {
        use rayon::prelude::*;
        assert!(coverage.is_none_or(|a| a.len() == self.width * self.height));
        let mut mips: Vec<Level> = Vec::new();
        let (mut w, mut h) = (self.width, self.height);
        let mut colour: Vec<Vec3> = Vec::new();
        // With alpha, colours weighted by alpha + ε: the plain mean where every alpha is 0, and
        // within ε / (1/255) = 2.6 × 10⁻⁴ of the alpha-weighted one elsewhere.
        let mut weighted: Vec<Vec4> = Vec::new();
        while w > 1 || h > 1 {
            let size = (w.div_ceil(2), h.div_ceil(2));
            let first = mips.is_empty();
            let shown: Vec<Vec3> = match coverage {
                None => {
                    colour = if first {
                        downsample(&|i| self.texels.get(i), (w, h), size)
                    } else {
                        downsample(&|i| colour[i], (w, h), size)
                    };
                    colour.clone()
                }
                Some(a) => {
                    weighted = if first {
                        let get = |i: usize| {
                            let k = a[i] + WEIGHT_EPSILON;
                            (self.texels.get(i) * k).extend(k)
                        };
                        downsample(&get, (w, h), size)
                    } else {
                        downsample(&|i| weighted[i], (w, h), size)
                    };
                    weighted.iter().map(|p| p.truncate() / p.w).collect()
                }
            };
            let texels = match &self.texels {
                Texels::Linear(_) => Texels::Linear(shown),
                Texels::Bytes { decode, .. } => Texels::Bytes {
                    codes: shown
                        .par_iter()
                        .map(|&c| nearest_codes(c, decode))
                        .collect(),
                    decode: decode.clone(),
                },
            };
            (w, h) = size;
            mips.push(Level {
                width: w,
                height: h,
                texels,
            });
        }
        self.mips = mips;
        self
    }

    /// Gives each transparent texel (alpha 0 in `coverage`) beside a covered one the
    /// alpha-weighted mean colour of its covered 8-neighbours (columns and rows wrap, as the
    /// lookup does): a bilinear lookup on a cut-out surface beside its hole then blends the
    /// surface's own colours, not the hole's (alpha bleeding). Other texels keep their colour.
    /// Without it, Lost Empire's leaves, looked up at a point, had dark fringes at their holes,
    /// up to 6 % of an 8 × 8-pixel block's luminance, and filtered lookups, whose finest level
    /// is this one, were up to 10 % darker than point lookups in such blocks.
    fn bleed_into_holes(&mut self, coverage: &[f32]) {
        use rayon::prelude::*;
        let (w, h) = (self.width, self.height);
        let texels = &self.texels;
        let bled: Vec<(usize, Vec3)> = (0..w * h)
            .into_par_iter()
            .filter(|&i| coverage[i] == 0.0)
            .filter_map(|i| {
                let (x, y) = (i % w, i / w);
                let (mut sum, mut weight) = (Vec3::ZERO, 0.0);
                for (dx, dy) in [
                    (w - 1, h - 1),
                    (0, h - 1),
                    (1, h - 1),
                    (w - 1, 0),
                    (1, 0),
                    (w - 1, 1),
                    (0, 1),
                    (1, 1),
                ] {
                    let j = (y + dy) % h * w + (x + dx) % w;
                    sum += texels.get(j) * coverage[j];
                    weight += coverage[j];
                }
                (weight > 0.0).then(|| (i, sum / weight))
            })
            .collect();
        match &mut self.texels {
            Texels::Linear(t) => bled.iter().for_each(|&(i, c)| t[i] = c),
            Texels::Bytes { codes, decode } => bled
                .iter()
                .for_each(|&(i, c)| codes[i] = nearest_codes(c, decode)),
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
        bilinear(self.width, self.height, &self.texels, uv)
    }

    /// The value at `uv` filtered over `footprint`: trilinear filtering between the two mip
    /// levels whose texel size brackets the footprint's width w, at level of detail
    /// λ = log₂(w · √(W H)) for a texture of W × H texels (Williams 1983; the isotropic
    /// footprint of a ray cone, Akenine-Möller et al. 2019, "Texture Level of Detail Strategies
    /// for Real-Time Ray Tracing", Ray Tracing Gems ch. 20, eq. 20.4). λ is capped where a
    /// level's texel would be wider than the surface's texture-coordinate bounds (along an axis
    /// they span less than the whole texture), and each level's bilinear taps are kept inside
    /// those bounds. Where λ ≤ 0 (the texture is not minified), the width is not finite and
    /// positive, or the texture has no mip maps, this is exactly [`Texture::lookup`].
    #[inline]
    pub fn lookup_over(&self, uv: Vec2, footprint: Footprint) -> Vec3 {
        let (w, h) = (self.width as f32, self.height as f32);
        let lod = (footprint.width * (w * h).sqrt()).log2();
        if self.mips.is_empty() || lod.is_nan() || lod <= 0.0 {
            return self.lookup(uv);
        }
        let span = footprint.hi - footprint.lo;
        let bounded = (span.x < 1.0, span.y < 1.0);
        let extent =
            |bounded: bool, span: f32, n: f32| if bounded { span * n } else { f32::INFINITY };
        let fits = extent(bounded.0, span.x, w).min(extent(bounded.1, span.y, h));
        let lod = lod.min(fits.log2()).min(self.mips.len() as f32);
        if lod.is_nan() || lod <= 0.0 {
            return self.lookup(uv);
        }
        let level = |k: usize| {
            let (lw, lh, texels) = match k {
                0 => (self.width, self.height, &self.texels),
                k => {
                    let l = &self.mips[k - 1];
                    (l.width, l.height, &l.texels)
                }
            };
            let keep = |bounded: bool, x: f32, lo: f32, hi: f32, n: usize| {
                let half = 0.5 / n as f32;
                if bounded && lo + half <= hi - half {
                    x.clamp(lo + half, hi - half)
                } else {
                    x
                }
            };
            let (lo, hi) = (footprint.lo, footprint.hi);
            let at = Vec2::new(
                keep(bounded.0, uv.x, lo.x, hi.x, lw),
                keep(bounded.1, uv.y, lo.y, hi.y, lh),
            );
            bilinear(lw, lh, texels, at)
        };
        let k = lod.floor();
        let f = lod - k;
        let a = level(k as usize);
        if f == 0.0 {
            return a;
        }
        a + (level(k as usize + 1) - a) * f
    }
}

/// Bilinearly filtered value of a `width × height` level at `uv` (v = 0 at the bottom), with
/// repeat wrapping.
#[inline]
fn bilinear(width: usize, height: usize, texels: &Texels, uv: Vec2) -> Vec3 {
    // Texel coordinates plus one, so that they are positive and truncation is the floor
    // (without a call to libm's floorf or fmodf where the CPU has no rounding instruction).
    let unit = |t: f32| {
        if (0.0..1.0).contains(&t) {
            t
        } else {
            t.rem_euclid(1.0)
        }
    };
    let x = unit(uv.x) * width as f32 + 0.5;
    let y = (1.0 - unit(uv.y)) * height as f32 + 0.5;
    let (xi, yi) = (x as usize, y as usize);
    let (fx, fy) = (x - xi as f32, y - yi as f32);
    // Columns xi − 1 and xi, rows yi − 1 and yi, wrapped (xi ≤ width, yi ≤ height).
    let wrap = |i: usize, n: usize| if i >= n { i - n } else { i };
    let (x0, x1) = (wrap(xi + width - 1, width), wrap(xi, width));
    let (r0, r1) = (
        wrap(yi + height - 1, height) * width,
        wrap(yi, height) * width,
    );
    let (t00, t10, t01, t11) = match texels {
        Texels::Linear(t) => (t[r0 + x0], t[r0 + x1], t[r1 + x0], t[r1 + x1]),
        Texels::Bytes { codes, decode } => {
            let d = |i: usize| byte_texel(codes[i], decode);
            (d(r0 + x0), d(r0 + x1), d(r1 + x0), d(r1 + x1))
        }
    };
    (t00 * (1.0 - fx) + t10 * fx) * (1.0 - fy) + (t01 * (1.0 - fx) + t11 * fx) * fy
}

/// For each of `n_out` cells spanning the same length as `n_in` cells, the input cells it
/// overlaps and the share of the output cell each covers (the shares sum to 1).
fn box_weights(n_in: usize, n_out: usize) -> Vec<Vec<(usize, f32)>> {
    let r = n_in as f64 / n_out as f64;
    (0..n_out)
        .map(|o| {
            let (lo, hi) = (o as f64 * r, (o + 1) as f64 * r);
            (lo.floor() as usize..(hi.ceil() as usize).min(n_in))
                .map(|i| {
                    let overlap = (hi.min(i as f64 + 1.0) - lo.max(i as f64)).max(0.0);
                    (i, (overlap / r) as f32)
                })
                .filter(|&(_, w)| w > 0.0)
                .collect()
        })
        .collect()
}

/// The texels `get(i)` of a `w × h` level (row-major) box-filtered to `w2 × h2`: each output
/// texel the area-weighted mean of the input texels under it. Halving an even size is the
/// plain 2 × 2 mean; other sizes go through [`box_weights`], rows then columns.
fn downsample<T>(
    get: &(dyn Fn(usize) -> T + Sync),
    (w, h): (usize, usize),
    (w2, h2): (usize, usize),
) -> Vec<T>
where
    T: Copy + Default + Send + Sync + std::iter::Sum,
    T: std::ops::Add<Output = T> + std::ops::Mul<f32, Output = T>,
{
    use rayon::prelude::*;
    let mut out = vec![T::default(); w2 * h2];
    if w == 2 * w2 && h == 2 * h2 {
        out.par_chunks_mut(w2).enumerate().for_each(|(y, line)| {
            let (r0, r1) = (2 * y * w, (2 * y + 1) * w);
            for (x, o) in line.iter_mut().enumerate() {
                let c = 2 * x;
                *o = (get(r0 + c) + get(r0 + c + 1) + get(r1 + c) + get(r1 + c + 1)) * 0.25;
            }
        });
        return out;
    }
    let (wx, wy) = (box_weights(w, w2), box_weights(h, h2));
    let mut rows = vec![T::default(); w2 * h];
    rows.par_chunks_mut(w2).enumerate().for_each(|(y, line)| {
        for (o, ws) in line.iter_mut().zip(&wx) {
            *o = ws.iter().map(|&(i, a)| get(y * w + i) * a).sum();
        }
    });
    out.par_chunks_mut(w2).zip(&wy).for_each(|(line, ws)| {
        for (x, o) in line.iter_mut().enumerate() {
            *o = ws.iter().map(|&(j, a)| rows[j * w2 + x] * a).sum();
        }
    });
    out
}

/// What [`Texture::with_mip_maps_weighted`] adds to every alpha it weighs texels by, so that a
/// block of transparent texels has their plain mean.
const WEIGHT_EPSILON: f32 = 1e-6;

/// The alpha channel of `img` (row-major, in [0, 1]) if it has one that is not opaque
/// everywhere: what [`Texture::with_mip_maps_weighted`] weighs its levels by.
fn coverage(img: &image::DynamicImage) -> Option<Vec<f32>> {
    use image::DynamicImage::*;
    match img {
        _ if !img.color().has_alpha() => None,
        ImageRgba8(b) => byte_coverage(b.pixels().map(|p| p.0[3])),
        ImageLumaA8(b) => byte_coverage(b.pixels().map(|p| p.0[1])),
        _ => {
            let alpha: Vec<f32> = img
                .to_rgba32f()
                .pixels()
                .map(|p| p.0[3].clamp(0.0, 1.0))
                .collect();
            alpha.iter().any(|&a| a < 1.0).then_some(alpha)
        }
    }
}

/// [`coverage`] of 8-bit alpha values.
fn byte_coverage(alpha: impl Iterator<Item = u8> + Clone) -> Option<Vec<f32>> {
    (alpha.clone().any(|a| a < 255)).then(|| alpha.map(|a| a as f32 / 255.0).collect())
}

/// The 8-bit codes whose decoded values are nearest to `c`, channel by channel (`decode` is
/// non-decreasing).
fn nearest_codes(c: Vec3, decode: &[f32; 256]) -> [u8; 3] {
    c.to_array().map(|v| {
        let i = decode.partition_point(|&d| d < v).min(255);
        if i > 0 && (v - decode[i - 1]).abs() <= (decode[i] - v).abs() {
            (i - 1) as u8
        } else {
            i as u8
        }
    })
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

    /// A texture of `w × h` random texels (deterministic).
    fn noise(w: usize, h: usize, seed: u64) -> Vec<Vec3> {
        let mut rng = crate::rng::Rng::new(seed, 1);
        (0..w * h)
            .map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()))
            .collect()
    }

    /// An RGBA PNG with opaque red texels beside transparent white ones (and a transparent
    /// white corner block). A transparent texel beside an opaque one takes their colour (alpha
    /// bleeding); one with no opaque neighbour keeps its own. Each texel of a level is the mean
    /// of the opaque texels under it, or the plain mean where none is opaque; an image whose
    /// alpha is opaque everywhere keeps its colours and has plain means.
    #[test]
    fn a_colour_textures_alpha_bleeds_into_its_holes_and_weighs_its_mip_levels() {
        let dir = tempfile::tempdir().unwrap();
        let (holes, opaque) = (dir.path().join("a.png"), dir.path().join("b.png"));
        let texel = |x: u32, y: u32| match (x < 4 && y < 4, (x + y).is_multiple_of(2)) {
            (true, _) => image::Rgba([255, 255, 255, 0]),
            (false, true) => image::Rgba([255, 0, 0, 255]),
            (false, false) => image::Rgba([255, 255, 255, 0]),
        };
        image::RgbaImage::from_fn(8, 8, texel).save(&holes).unwrap();
        image::RgbaImage::from_fn(8, 8, |x, y| {
            let mut p = texel(x, y);
            p.0[3] = 255;
            p
        })
        .save(&opaque)
        .unwrap();
        let t = Texture::load(&holes).unwrap();
        let (red, white) = (Vec3::X, Vec3::ONE);
        let near = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 0.01;
        assert!(near(t.texels.get(4 * 8 + 5), red), "a hole beside red");
        assert!(near(t.texels.get(8 + 1), white), "a hole among holes");
        for (k, l) in t.mips.iter().enumerate() {
            let n = 1 << (k + 1);
            for y in 0..l.height {
                for x in 0..l.width {
                    let got = l.texels.get(y * l.width + x);
                    let under =
                        (0..n).flat_map(|j| (0..n).map(move |i| (y * n + j) * 8 + x * n + i));
                    let all_holes = (x + 1) * n <= 4 && (y + 1) * n <= 4;
                    let want = if all_holes {
                        under.map(|i| t.texels.get(i)).sum::<Vec3>() / (n * n) as f32
                    } else {
                        red
                    };
                    assert!(near(got, want), "level {k} ({x}, {y}): {got}, want {want}");
                }
            }
        }
        let plain = Texture::load(&opaque).unwrap();
        assert!(
            near(plain.texels.get(4 * 8 + 5), white),
            "opaque: no bleeding"
        );
        let mean = plain.mips.last().unwrap().texels.get(0);
        assert!(near(mean, plain.mean()), "{mean} {}", plain.mean());
    }

    /// Every level keeps the texture's mean (the box filter covers each texel of the level
    /// below exactly once, odd sizes included), the last is 1 × 1, and each level's texel is
    /// the mean of the texels it covers: for even sizes the plain 2 × 2 mean, computed here
    /// directly.
    #[test]
    fn mip_levels_are_exact_box_means() {
        for (w, h) in [(16, 16), (13, 7), (1, 9), (64, 3)] {
            let t = Texture::from_texels(w, h, noise(w, h, 7)).with_mip_maps();
            let mut size = (w, h);
            for l in &t.mips {
                size = (size.0.div_ceil(2), size.1.div_ceil(2));
                assert_eq!((l.width, l.height), size);
                let n = l.width * l.height;
                let mean = (0..n).map(|i| l.texels.get(i)).sum::<Vec3>() / n as f32;
                // Equal-area cells: the mean of the level is the texture's where the sizes
                // halve exactly; with odd sizes the cells still cover equal areas.
                assert!(
                    (mean - t.mean()).abs().max_element() < 1e-5,
                    "{w}×{h}: {mean} {}",
                    t.mean()
                );
            }
            assert_eq!(size, (1, 1));
            // ⌈log₂ of the larger side⌉ halvings reach 1 × 1.
            let sides = w.max(h) as f64;
            assert_eq!(t.mips.len(), sides.log2().ceil() as usize, "{w}×{h}");
        }
        let base = noise(8, 8, 3);
        let t = Texture::from_texels(8, 8, base.clone()).with_mip_maps();
        let l1 = &t.mips[0];
        for (y, x) in (0..4).flat_map(|y| (0..4).map(move |x| (y, x))) {
            let want = (base[2 * y * 8 + 2 * x]
                + base[2 * y * 8 + 2 * x + 1]
                + base[(2 * y + 1) * 8 + 2 * x]
                + base[(2 * y + 1) * 8 + 2 * x + 1])
                / 4.0;
            assert!((l1.texels.get(y * 4 + x) - want).abs().max_element() < 1e-6);
        }
    }

    /// An 8-bit texture's levels hold the codes nearest their linear means: within half a
    /// code's step of the mean computed in linear values.
    #[test]
    fn byte_levels_round_to_the_nearest_code() {
        let decode = byte_decode_table(true);
        let codes: Vec<[u8; 3]> = (0..64u32)
            .map(|i| [(i * 37 % 256) as u8, (i * 11) as u8, 200])
            .collect();
        let t = Texture::with_texels(
            8,
            8,
            Texels::Bytes {
                codes: codes.clone(),
                decode: decode.clone(),
            },
        )
        .with_mip_maps();
        let top = &t.mips.last().unwrap().texels;
        let got = top.get(0);
        let want = t.mean();
        for c in 0..3 {
            let i = decode.partition_point(|&d| d < want[c]).min(255);
            let step = decode[i.max(1)] - decode[i.max(1) - 1];
            assert!((got[c] - want[c]).abs() <= step, "{got} {want}");
        }
    }

    /// Trilinear lookups: not minified (λ ≤ 0) they are the bilinear lookup bit for bit; far
    /// minified they read the last level, the texture's mean; between two levels they blend
    /// them linearly in λ.
    #[test]
    fn lookups_over_a_footprint_pick_and_blend_levels() {
        let t = Texture::from_texels(32, 32, noise(32, 32, 11)).with_mip_maps();
        let unbounded = |width| Footprint {
            width,
            lo: Vec2::splat(-5.0),
            hi: Vec2::splat(5.0),
        };
        for i in 0..50 {
            let uv = Vec2::new(i as f32 * 0.137, i as f32 * 0.071);
            assert_eq!(t.lookup_over(uv, unbounded(1.0 / 32.0)), t.lookup(uv));
            assert_eq!(t.lookup_over(uv, unbounded(0.0)), t.lookup(uv));
            assert_eq!(t.lookup_over(uv, Footprint::POINT), t.lookup(uv));
            assert!(
                (t.lookup_over(uv, unbounded(4.0)) - t.mean())
                    .abs()
                    .max_element()
                    < 1e-5
            );
            // λ = 1.5: halfway between levels 1 and 2.
            let w = 2f32.powf(1.5) / 32.0;
            let (l1, l2) = (&t.mips[0], &t.mips[1]);
            let a = bilinear(l1.width, l1.height, &l1.texels, uv);
            let b = bilinear(l2.width, l2.height, &l2.texels, uv);
            assert!(
                (t.lookup_over(uv, unbounded(w)) - (a + b) * 0.5)
                    .abs()
                    .max_element()
                    < 1e-5
            );
        }
        // No mip maps: always the bilinear lookup.
        let plain = Texture::from_texels(32, 32, noise(32, 32, 11));
        assert_eq!(
            plain.lookup_over(Vec2::splat(0.3), unbounded(1.0)),
            plain.lookup(Vec2::splat(0.3))
        );
    }

    /// An atlas of two 8 × 8 tiles, black and white: a surface mapped to the white tile and
    /// looked up far minified reads white, not the atlas's grey (the level is capped where a
    /// texel would outgrow the tile, and the taps stay inside it); without the bounds it
    /// reads the grey mean.
    #[test]
    fn footprints_stay_inside_their_tile() {
        let texels: Vec<Vec3> = (0..16 * 8)
            .map(|i| if i % 16 >= 8 { Vec3::ONE } else { Vec3::ZERO })
            .collect();
        let t = Texture::from_texels(16, 8, texels).with_mip_maps();
        let tile = Footprint {
            width: 1.0,
            lo: Vec2::new(0.5, 0.0),
            hi: Vec2::new(1.0, 1.0),
        };
        for i in 0..20 {
            let uv = Vec2::new(0.5 + 0.5 * i as f32 / 19.0, 0.37);
            assert_eq!(t.lookup_over(uv, tile), Vec3::ONE, "{uv}");
        }
        let free = Footprint {
            width: 4.0,
            lo: Vec2::splat(-1.0),
            hi: Vec2::splat(2.0),
        };
        assert!(
            (t.lookup_over(Vec2::new(0.75, 0.37), free) - Vec3::splat(0.5))
                .abs()
                .max_element()
                < 1e-5
        );
    }
}
