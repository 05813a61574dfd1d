use super::BsdfSample;
use crate::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// The isotropic GGX (Trowbridge–Reitz) microfacet distribution with the height-correlated
/// Smith masking-shadowing function.
///
/// # References
/// - Walter, Marschner, Li & Torrance 2007, "Microfacet Models for Refraction through Rough
///   Surfaces", EGSR: D (eq. 33), Λ (eq. 34's G1 in Λ form), the Torrance–Sparrow BRDF (eq. 20).
/// - Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs", JCGT
///   3(2): height-correlated G2 = 1/(1 + Λ(wo) + Λ(wi)) (eq. 99).
/// - Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4): the sampling
///   routine (listing 1) and its pdf D_wo(h)/(4 |wo·h|) (eq. 17).
#[derive(Clone, Copy, Debug)]
pub struct Ggx {
    /// Width parameter α (= roughness²-style width; α → 0 is a mirror), clamped to ≥ 1e-3.
    pub alpha: f32,
}

impl Ggx {
    /// A distribution of width `alpha`, clamped to [1e-3, 1].
    pub fn new(alpha: f32) -> Self {
        Ggx {
            alpha: alpha.clamp(1e-3, 1.0),
        }
    }

    /// The α that matches a Phong exponent (MTL `Ns`): α = sqrt(2 / (Ns + 2)) (Walter et al.
    /// 2007, §5.2, Beckmann–Phong correspondence, used here for GGX as is customary).
    pub fn alpha_from_phong_exponent(ns: f32) -> f32 {
        (2.0 / (ns.max(0.0) + 2.0)).sqrt()
    }

    /// Microfacet normal distribution D(h) in sr⁻¹ (projected-area normalised).
    #[inline]
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let c2 = h.z * h.z;
        let denom = c2 * (a2 - 1.0) + 1.0;
        a2 / (PI * denom * denom)
    }

    /// Smith Λ(w).
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let c2 = w.z * w.z;
        if c2 <= 0.0 {
            return f32::INFINITY;
        }
        let tan2 = ((1.0 - c2).max(0.0)) / c2;
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    /// Smith masking G1(w) = 1/(1 + Λ(w)).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G2(wo, wi).
    #[inline]
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Samples a visible microfacet normal for `wo` (wo.z > 0), Heitz 2018 listing 1.
    #[inline]
    pub fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        let vh = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        let lensq = vh.x * vh.x + vh.y * vh.y;
        let t1 = if lensq > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let p1 = r * phi.cos();
        let mut p2 = r * phi.sin();
        let s = 0.5 * (1.0 + vh.z);
        p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        Vec3::new(a * nh.x, a * nh.y, nh.z.max(1e-6)).normalize()
    }

    /// Solid-angle pdf of the reflected direction `wi` under visible-normal sampling from `wo`:
    /// G1(wo) D(h) / (4 cos θ_o).
    #[inline]
    pub fn reflection_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        self.g1(wo) * self.d(h) / (4.0 * wo.z)
    }
}

/// Glossy reflection: a Lambertian base of reflectance `kd` plus a GGX Torrance–Sparrow
/// specular lobe f_s = F D G2 / (4 cos θ_o cos θ_i) with constant Fresnel F = `ks` (Walter et
/// al. 2007, eq. 20). The MTL `Kd`/`Ks`/`Ns` triple maps here directly.
///
/// Energy conservation: with `kd + ks ≤ 1` per channel (enforced by [`Glossy::new`], which
/// scales both down where the sum exceeds 1) the directional albedo is ≤ kd + ks ≤ 1, since the
/// single-scattering GGX lobe's albedo is ≤ 1 and F is constant. Reciprocity holds because D,
/// G2 and F are symmetric in (wo, wi).
///
/// Sampling picks the specular lobe with probability `p_spec` = lum(ks)/(lum(kd)+lum(ks))
/// and returns the mixture pdf (one-sample MIS over the two lobes).
#[derive(Clone, Copy, Debug)]
pub struct Glossy {
    /// Diffuse reflectance, [0, 1] per channel.
    pub kd: Vec3,
    /// Specular reflectance (Fresnel at all angles), [0, 1] per channel.
    pub ks: Vec3,
    /// The specular lobe's microfacet distribution.
    pub ggx: Ggx,
    p_spec: f32,
}

impl Glossy {
    /// A glossy BSDF; where kd + ks > 1 in a channel both are scaled by 1/(kd + ks) there.
    pub fn new(kd: Vec3, ks: Vec3, alpha: f32) -> Self {
        let kd = kd.clamp(Vec3::ZERO, Vec3::ONE);
        let ks = ks.clamp(Vec3::ZERO, Vec3::ONE);
        let sum = kd + ks;
        let scale = Vec3::select(sum.cmpgt(Vec3::ONE), Vec3::ONE / sum, Vec3::ONE);
        let (kd, ks) = (kd * scale, ks * scale);
        let wd = crate::math::luminance(kd).max(0.0);
        let ws = crate::math::luminance(ks).max(0.0);
        let p_spec = if wd + ws > 0.0 { ws / (wd + ws) } else { 0.5 };
        Glossy {
            kd,
            ks,
            ggx: Ggx::new(alpha),
            p_spec,
        }
    }

    /// f = kd/π + ks D G2 / (4 cos θ_o cos θ_i), zero unless both lie above the surface.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize();
        let spec = self.ggx.d(h) * self.ggx.g2(wo, wi) / (4.0 * wo.z * wi.z);
        self.kd * FRAC_1_PI + self.ks * spec
    }

    /// Mixture pdf of the two lobes.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.p_spec * self.ggx.reflection_pdf(wo, wi)
            + (1.0 - self.p_spec) * square_to_cosine_hemisphere_pdf(wi)
    }

    /// Picks a lobe with `uc`, samples it with `u`, returns the full f and mixture pdf.
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if uc < self.p_spec {
            let h = self.ggx.sample_visible_normal(wo, u);
            crate::math::reflect(wo, h)
        } else {
            square_to_cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(BsdfSample {
            f: self.eval(wo, wi),
            wi,
            pdf,
            delta: false,
            eta: 1.0,
        })
    }
}
