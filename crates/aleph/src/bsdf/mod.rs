//! Bidirectional scattering distribution functions.
//!
//! The four classes of the seed paper (Yee, Dutré & Pattanaik, "Fundamentals of Lighting and
//! Perception", §2): diffuse ([`Lambert`]), ideal specular ([`Mirror`]), glossy ([`Glossy`]: a
//! Lambertian base plus a GGX microfacet lobe) and transparent ([`Dielectric`]: a smooth
//! Fresnel interface).
//!
//! # Conventions
//! - All directions are in the local shading frame ([`crate::math::Frame`]): the normal is +z,
//!   so cos θ = `w.z`. Both `wo` and `wi` point away from the surface.
//! - `eval` returns f(wo, wi) in sr⁻¹ **without** the cosine factor; the integrator multiplies
//!   by |cos θ_i|.
//! - `pdf` is per unit solid angle of `wi`.
//! - Delta lobes (mirror, smooth dielectric) are never returned by `eval`/`pdf` (both give 0).
//!   Their samples follow pbrt-v4's convention: `pdf` is the discrete probability of choosing
//!   the lobe and `f` is the lobe's weight divided by |cos θ_i|, so f·|cos θ_i|/pdf is the
//!   throughput, and `delta` is set.
//! - Light is transported from the camera (radiance mode): refraction scales by 1/η².
//! - Opaque BSDFs reflect only into the hemisphere of `wo`; the integrator flips the shading
//!   frame to the side of `wo` for them (two-sided surfaces).

mod dielectric;
mod glossy;
mod lambert;
mod mirror;

pub use dielectric::{Dielectric, fresnel_dielectric};
pub use glossy::{Ggx, Glossy};
pub use lambert::Lambert;
pub use mirror::Mirror;

use glam::{Vec2, Vec3};

/// Result of sampling a BSDF (pbrt-v4 `BSDFSample`).
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// BSDF value f(wo, wi) in sr⁻¹ (for delta lobes, weight / |cos θ_i|).
    pub f: Vec3,
    /// Sampled incident direction, local frame, unit length.
    pub wi: Vec3,
    /// Solid-angle pdf of `wi` (for delta lobes, the discrete probability of the lobe).
    pub pdf: f32,
    /// True when `wi` was chosen by a delta lobe.
    pub delta: bool,
    /// Relative index of refraction η_t/η_i crossed by a refraction (1 for reflection): `f`
    /// holds the radiance compression 1/η² (Veach 1997 §5.2), which Russian roulette undoes.
    pub eta: f32,
}

/// A BSDF at one shading point, with its textures already looked up.
#[derive(Clone, Copy, Debug)]
pub enum Bsdf {
    /// Lambertian diffuse reflection.
    Lambert(Lambert),
    /// Ideal specular reflection.
    Mirror(Mirror),
    /// Lambertian base plus GGX specular reflection.
    Glossy(Glossy),
    /// Smooth dielectric interface (reflection and refraction).
    Dielectric(Dielectric),
}

impl Bsdf {
    /// f(wo, wi) in sr⁻¹, without the cosine; zero for delta lobes.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            Bsdf::Lambert(b) => b.eval(wo, wi),
            Bsdf::Mirror(_) | Bsdf::Dielectric(_) => Vec3::ZERO,
            Bsdf::Glossy(b) => b.eval(wo, wi),
        }
    }

    /// Solid-angle pdf of sampling `wi` given `wo`; zero for delta lobes.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Lambert(b) => b.pdf(wo, wi),
            Bsdf::Mirror(_) | Bsdf::Dielectric(_) => 0.0,
            Bsdf::Glossy(b) => b.pdf(wo, wi),
        }
    }

    /// Samples `wi` from `wo` with a lobe-selection number `uc` and a 2-D number `u`, both in
    /// [0,1). `None` when no direction can be produced (e.g. `wo` below the surface).
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        match self {
            Bsdf::Lambert(b) => b.sample(wo, u),
            Bsdf::Mirror(b) => b.sample(wo),
            Bsdf::Glossy(b) => b.sample(wo, uc, u),
            Bsdf::Dielectric(b) => b.sample(wo, uc),
        }
    }

    /// Which of [`Bsdf::sample`]'s random numbers it uses: (the lobe choice `uc`, the 2-D `u`).
    #[inline]
    pub fn sample_uses(&self) -> (bool, bool) {
        match self {
            Bsdf::Lambert(_) => (false, true),
            Bsdf::Mirror(_) => (false, false),
            Bsdf::Glossy(_) => (true, true),
            Bsdf::Dielectric(_) => (true, false),
        }
    }

    /// True when every lobe is a delta (no point in light sampling).
    #[inline]
    pub fn is_delta(&self) -> bool {
        matches!(self, Bsdf::Mirror(_) | Bsdf::Dielectric(_))
    }

    /// True when the BSDF transmits (the shading frame must keep its geometric side).
    #[inline]
    pub fn is_transmissive(&self) -> bool {
        matches!(self, Bsdf::Dielectric(_))
    }
}

#[inline]
pub(crate) fn same_hemisphere(a: Vec3, b: Vec3) -> bool {
    a.z * b.z > 0.0
}

#[cfg(test)]
mod tests;
