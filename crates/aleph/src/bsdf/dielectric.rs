use super::BsdfSample;
use glam::Vec3;

/// Smooth dielectric interface: specular reflection and refraction weighted by the exact
/// unpolarised Fresnel reflectance (Born & Wolf; pbrt-v4 `FrDielectric`, §9.3).
///
/// The local +z axis is the outward geometric side: `wo.z > 0` means the ray arrives from
/// outside (relative index `ior`), `wo.z < 0` from inside (1/`ior`).
#[derive(Clone, Copy, Debug)]
pub struct Dielectric {
    /// Index of refraction of the inside relative to the outside (MTL `Ni`), > 0.
    pub ior: f32,
    /// Transmission filter per RGB channel (MTL `Tf`), each in [0, 1]; multiplies refracted
    /// light. Reflection is untinted.
    pub transmittance: Vec3,
}

/// Unpolarised Fresnel reflectance of a dielectric interface for the cosine `cos_i` of the
/// incident angle (negative when arriving from inside) and relative index `eta` = η_inside /
/// η_outside. Returns 1 on total internal reflection.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let (cos_i, eta) = if cos_i < 0.0 {
        (-cos_i, 1.0 / eta)
    } else {
        (cos_i, eta)
    };
    let cos_i = cos_i.min(1.0);
    let sin2_i = 1.0 - cos_i * cos_i;
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

impl Dielectric {
    /// Chooses reflection with probability F and refraction with 1 − F using `uc`.
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let r = fresnel_dielectric(wo.z, self.ior);
        let t = 1.0 - r;
        if uc < r || t <= 0.0 {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return Some(BsdfSample {
                f: Vec3::splat(r / wi.z.abs()),
                wi,
                pdf: r,
                delta: true,
                eta: 1.0,
            });
        }
        // Refraction. eta is the index of the side wi enters relative to the side of wo.
        let (eta, n) = if wo.z > 0.0 {
            (self.ior, Vec3::Z)
        } else {
            (1.0 / self.ior, -Vec3::Z)
        };
        let wi = crate::math::refract(wo, n, eta)?;
        // Radiance is compressed by η² on entering a denser medium (Veach 1997 §5.2).
        let f = self.transmittance * (t / (eta * eta)) / wi.z.abs();
        Some(BsdfSample {
            f,
            wi,
            pdf: t,
            delta: true,
            eta,
        })
    }
}
