//! The sun: a distant disc of finite angular size (a light at infinity that BSDF-sampled rays
//! also reach, so it takes part in MIS).

use super::LightSample;
use crate::math::Frame;
use glam::Vec3;
use std::f32::consts::PI;

/// The sun's mean angular diameter seen from the Earth, degrees (0.5332°; 0.53° in practice).
pub const SUN_ANGULAR_DIAMETER_DEG: f32 = 0.53;

/// A distant light of finite angular size: a disc of uniform radiance subtending a cone of
/// half-angle α around `direction`. Its shadows are soft, with a penumbra of angle 2α.
///
/// Specified by the irradiance E (W·m⁻²) it gives a surface facing it; a uniform disc of
/// angular radius α gives E = L · π sin²α (the projected solid angle of the cone), so its
/// radiance is L = E / (π sin²α). Directions are sampled uniformly in the cone, with
/// pdf 1 / (2π (1 − cos α)), and the light is also hit by BSDF-sampled rays (MIS applies).
#[derive(Clone, Debug)]
pub struct Sun {
    /// Unit direction towards the sun.
    pub direction: Vec3,
    /// Radiance of the disc, W·sr⁻¹·m⁻².
    pub radiance: Vec3,
    /// Irradiance on a surface facing the sun, W·m⁻².
    pub irradiance: Vec3,
    /// 1 − cos α, computed as 2 sin²(α/2) to keep its digits for tiny discs.
    one_minus_cos: f32,
    frame: Frame,
}

impl Sun {
    /// A sun towards `direction` (any length > 0) giving `irradiance` (W·m⁻²) on a surface facing
    /// it, with angular diameter `diameter_deg` in (0, 180). `None` for a zero direction or a
    /// diameter out of range.
    pub fn new(direction: Vec3, irradiance: Vec3, diameter_deg: f32) -> Option<Sun> {
        let direction = direction.normalize_or_zero();
        if direction == Vec3::ZERO || !(diameter_deg > 0.0 && diameter_deg < 180.0) {
            return None;
        }
        let alpha = 0.5 * diameter_deg.to_radians();
        let s = (0.5 * alpha).sin();
        let one_minus_cos = 2.0 * s * s;
        let sin2 = alpha.sin() * alpha.sin();
        Some(Sun {
            direction,
            radiance: irradiance / (PI * sin2),
            irradiance,
            one_minus_cos,
            frame: Frame::from_normal(direction),
        })
    }

    /// Luminance of the irradiance the disc can deliver to a surface of unit normal `n`
    /// (W·m⁻², luminance-weighted): Y(E) times the largest cosine over the disc,
    /// clamp(n · s + sin α, 0, 1), so it is zero only where the whole disc is below the surface;
    /// Y(E)/4, its mean over normals, for `n` = 0 (no normal). A weight for choosing among the
    /// lights at infinity ([`super::Lights`]).
    #[inline]
    pub fn irradiance_on(&self, n: Vec3) -> f32 {
        let y = crate::math::luminance(self.irradiance.max(Vec3::ZERO));
        if n == Vec3::ZERO {
            return 0.25 * y;
        }
        // sin α from 1 − cos α = 2 sin²(α/2): sin α = 2 sin(α/2) cos(α/2).
        let s_half = (0.5 * self.one_minus_cos).sqrt();
        let sin_a = 2.0 * s_half * (1.0 - s_half * s_half).max(0.0).sqrt();
        y * (n.dot(self.direction) + sin_a).clamp(0.0, 1.0)
    }

    /// Solid angle of the disc, sr.
    #[inline]
    pub fn solid_angle(&self) -> f32 {
        2.0 * PI * self.one_minus_cos
    }

    /// True when unit direction `d` points into the disc (|d − s|² ≤ 2(1 − cos α), exact in
    /// f32 even for the real sun's 1 − cos α ≈ 1e-5).
    #[inline]
    pub fn contains(&self, d: Vec3) -> bool {
        (d - self.direction).length_squared() <= 2.0 * self.one_minus_cos
    }

    /// Radiance seen along unit direction `d`.
    #[inline]
    pub fn radiance_towards(&self, d: Vec3) -> Vec3 {
        if self.contains(d) {
            self.radiance
        } else {
            Vec3::ZERO
        }
    }

    /// A direction uniformly in the cone: (unit direction, solid-angle pdf).
    #[inline]
    pub fn sample(&self, u: glam::Vec2) -> (Vec3, f32) {
        // 1 − cos θ = u (1 − cos α); sin θ from it without cancellation.
        let omc = u.x * self.one_minus_cos;
        let sin_t = (omc * (2.0 - omc)).max(0.0).sqrt();
        let cos_t = 1.0 - omc;
        let phi = 2.0 * PI * u.y;
        let local = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
        let d = self.frame.from_local(local).normalize();
        (d, 1.0 / self.solid_angle())
    }

    /// Solid-angle pdf of [`Sun::sample`] for unit direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        if self.contains(d) {
            1.0 / self.solid_angle()
        } else {
            0.0
        }
    }
}

impl Sun {
    /// Next-event sample from `p_ref` with the point's 2-D number `u`, the light chosen with
    /// probability `pmf`.
    #[inline]
    pub(super) fn sample_from(&self, p_ref: Vec3, u: glam::Vec2, pmf: f32) -> LightSample {
        let (wi, pdf) = self.sample(u);
        LightSample::infinite(p_ref, wi, self.radiance, pmf * pdf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn sun_irradiance_is_its_parameter() {
        // E = ∫cone L cos θ dω, by sampling the cone, for the real sun and a wide one.
        for diameter in [SUN_ANGULAR_DIAMETER_DEG, 30.0] {
            let sun = Sun::new(
                Vec3::new(0.3, 1.0, -0.2),
                Vec3::new(1000.0, 900.0, 800.0),
                diameter,
            )
            .unwrap();
            let mut rng = Rng::new(1, 2);
            let n = 100_000;
            let mut e = Vec3::ZERO;
            for _ in 0..n {
                let (d, pdf) = sun.sample(rng.uniform2());
                assert!(sun.contains(d) || (d - sun.direction).length_squared() < 1e-9);
                e += sun.radiance * d.dot(sun.direction) / pdf;
            }
            e /= n as f32;
            assert!(
                (e / sun.irradiance - Vec3::ONE).abs().max_element() < 2e-3,
                "{diameter}: {e}"
            );
        }
    }
}
