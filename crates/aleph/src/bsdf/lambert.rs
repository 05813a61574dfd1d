use super::{BsdfSample, same_hemisphere};
use crate::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Lambertian reflection, f = ρ/π (Lambert 1760), sampled by the cosine-weighted hemisphere.
#[derive(Clone, Copy, Debug)]
pub struct Lambert {
    /// Diffuse reflectance ρ per RGB channel, each in [0, 1].
    pub reflectance: Vec3,
}

impl Lambert {
    /// f(wo, wi) = ρ/π when both lie above the surface.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z > 0.0 && wi.z > 0.0 {
            self.reflectance * FRAC_1_PI
        } else {
            Vec3::ZERO
        }
    }

    /// cos θ_i / π above the surface.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z > 0.0 && same_hemisphere(wo, wi) {
            square_to_cosine_hemisphere_pdf(wi)
        } else {
            0.0
        }
    }

    /// Cosine-weighted sample of the upper hemisphere.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = square_to_cosine_hemisphere(u);
        let pdf = square_to_cosine_hemisphere_pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            f: self.reflectance * FRAC_1_PI,
            wi,
            pdf,
            delta: false,
            eta: 1.0,
        })
    }
}
