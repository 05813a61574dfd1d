//! Materials: what a surface's BSDF and emission are, before texture lookup.
//!
//! # Mapping from MTL (documented in `docs/scene-format.md`)
//! Checked in this order for each `newmtl`:
//! 1. **Transparent** ([`MaterialKind::Dielectric`]): `illum` 4, 6, 7 or 9, or dissolve `d` < 1,
//!    or `Tr` > 0. Index of refraction `Ni` (1.5 when absent or not positive); clear, as `Tf`
//!    is not read as a filter (Blender's importer reads it as a transmission weight).
//! 2. **Ideal specular** ([`MaterialKind::Mirror`]): `illum` 5 or 8, or `Ks` non-zero with `Ns` ≥
//!    10000 (GGX α < 0.014, indistinguishable from a mirror). Reflectance `Ks` (white if zero).
//! 3. **Glossy** ([`MaterialKind::Glossy`]): `Ks` non-zero or `map_Ks` present. Diffuse `Kd` plus a
//!    GGX lobe of reflectance `Ks` and α = sqrt(2/(Ns + 2)) (Walter et al. 2007 §5.2); where
//!    Kd + Ks > 1 both are scaled down to conserve energy.
//! 4. **Diffuse** ([`MaterialKind::Diffuse`]): Lambertian `Kd` otherwise.
//!
//! Any class may also emit: a non-zero `Ke` (or `map_Ke`) makes every triangle of the material a
//! one-sided area light emitting radiance `Ke` (W·sr⁻¹·m⁻²) on the side its winding faces.
//!
//! Textures (`map_Kd`, `map_Ks`, `map_Ke`) replace the corresponding constant, as Blender's OBJ
//! importer does, except that `map_Ke` multiplies `Ke`. The `-mm base gain` option is honoured
//! (value = base + gain × texel); other options are parsed and ignored. `map_d` is an alpha
//! cut-out ([`crate::geometry::AlphaMask`]), `bump`/`map_bump`/`norm` a bump or normal map
//! ([`crate::texture::BumpMap`]). The full mapping and the ignored statements are listed in
//! `docs/scene-format.md`.

use crate::bsdf::{Bsdf, Dielectric, Ggx, Glossy, Lambert, Mirror};
use crate::texture::{Footprint, Texture};
use glam::{Vec2, Vec3};

/// A colour that is constant or comes from a texture.
#[derive(Clone, Copy, Debug)]
pub enum ColorSource {
    /// A constant linear RGB value.
    Constant(Vec3),
    /// `base + gain × texel` of texture `id` in the scene's texture list.
    Texture {
        /// Index into the scene's textures.
        id: u32,
        /// Additive base (`-mm` first value, default 0).
        base: f32,
        /// Gain (`-mm` second value, default 1).
        gain: f32,
    },
}

impl ColorSource {
    /// The value at texture coordinates `uv`, filtered over a footprint `footprint` wide in
    /// texture coordinates ([`Texture::lookup_over`]; 0 for a point lookup).
    #[inline]
    pub fn eval(&self, uv: Vec2, footprint: Footprint, textures: &[Texture]) -> Vec3 {
        match *self {
            ColorSource::Constant(c) => c,
            ColorSource::Texture { id, base, gain } => {
                Vec3::splat(base) + gain * textures[id as usize].lookup_over(uv, footprint)
            }
        }
    }

    /// The mean value over the texture (the constant itself if constant).
    pub fn mean(&self, textures: &[Texture]) -> Vec3 {
        match *self {
            ColorSource::Constant(c) => c,
            ColorSource::Texture { id, base, gain } => {
                Vec3::splat(base) + gain * textures[id as usize].mean()
            }
        }
    }

    /// The largest value over the texture, per channel (the constant itself if constant).
    pub fn max(&self, textures: &[Texture]) -> Vec3 {
        match *self {
            ColorSource::Constant(c) => c,
            ColorSource::Texture { id, base, gain } => {
                Vec3::splat(base) + gain * textures[id as usize].max()
            }
        }
    }

    /// True for a constant zero colour.
    pub fn is_black(&self) -> bool {
        matches!(self, ColorSource::Constant(c) if c.max_element() <= 0.0)
    }
}

/// The scattering class of a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaterialKind {
    /// Lambertian reflection of `kd`.
    Diffuse,
    /// Ideal specular reflection of `ks`.
    Mirror,
    /// Lambertian `kd` plus GGX `ks` with width `alpha`.
    Glossy {
        /// GGX α.
        alpha: f32,
    },
    /// Smooth dielectric with relative index `ior`, transmission tinted by `transmittance`.
    Dielectric {
        /// Index of refraction (inside / outside).
        ior: f32,
    },
}

/// A surface material.
#[derive(Clone, Debug)]
pub struct Material {
    /// Name (MTL `newmtl`, or the light's name for explicit lights).
    pub name: String,
    /// Scattering class.
    pub kind: MaterialKind,
    /// Diffuse reflectance (`Kd`), linear RGB in [0, 1].
    pub kd: ColorSource,
    /// Specular reflectance (`Ks`), linear RGB in [0, 1].
    pub ks: ColorSource,
    /// Transmission filter of a dielectric (`[materials.NAME] transmittance`; white from an MTL),
    /// linear RGB in [0, 1].
    pub transmittance: Vec3,
    /// Emitted radiance (W·sr⁻¹·m⁻²) on the front side, if the material emits.
    pub emission: Option<ColorSource>,
    /// Index of its alpha cut-out mask (MTL `map_d`) in the scene's
    /// [`crate::geometry::Cutouts`], if any.
    pub cutout: Option<u32>,
    /// Its bump or normal map, if any.
    pub bump: Option<crate::texture::BumpMap>,
}

impl Material {
    /// The BSDF at texture coordinates `uv`, its textures filtered over `footprint`
    /// ([`ColorSource::eval`]; [`Footprint::POINT`] for point lookups).
    #[inline]
    pub fn bsdf(&self, uv: Vec2, footprint: Footprint, textures: &[Texture]) -> Bsdf {
        match self.kind {
            MaterialKind::Diffuse => Bsdf::Lambert(Lambert {
                reflectance: self
                    .kd
                    .eval(uv, footprint, textures)
                    .clamp(Vec3::ZERO, Vec3::ONE),
            }),
            MaterialKind::Mirror => Bsdf::Mirror(Mirror {
                reflectance: self
                    .ks
                    .eval(uv, footprint, textures)
                    .clamp(Vec3::ZERO, Vec3::ONE),
            }),
            MaterialKind::Glossy { alpha } => Bsdf::Glossy(Glossy::new(
                self.kd.eval(uv, footprint, textures),
                self.ks.eval(uv, footprint, textures),
                alpha,
            )),
            MaterialKind::Dielectric { ior } => Bsdf::Dielectric(Dielectric {
                ior,
                transmittance: self.transmittance,
            }),
        }
    }

    /// Emitted radiance at `uv` (front side), its texture filtered over `footprint` as
    /// [`Material::bsdf`]'s; zero if the material does not emit.
    #[inline]
    pub fn emitted(&self, uv: Vec2, footprint: Footprint, textures: &[Texture]) -> Vec3 {
        match &self.emission {
            Some(e) => e.eval(uv, footprint, textures).max(Vec3::ZERO),
            None => Vec3::ZERO,
        }
    }

    /// True when any of its colours comes from a texture.
    pub fn is_textured(&self) -> bool {
        let t = |c: &ColorSource| matches!(c, ColorSource::Texture { .. });
        t(&self.kd) || t(&self.ks) || self.emission.as_ref().is_some_and(t)
    }

    /// GGX α for a Phong exponent `Ns`.
    pub fn alpha_from_ns(ns: f32) -> f32 {
        Ggx::alpha_from_phong_exponent(ns)
    }
}
