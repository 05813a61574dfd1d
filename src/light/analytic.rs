//! Lights given by a formula rather than by geometry: the sun (a distant disc of finite angular
//! size) and point and spot lights (delta lights).

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

/// A point light of radiant intensity `intensity` (W·sr⁻¹), optionally confined to a cone (a
/// spot light). A delta light: reached only by next-event estimation, never by a BSDF-sampled
/// ray, so it takes no part in MIS.
///
/// A spot light's intensity falls from full inside `cos_start` to zero outside `cos_total` with
/// the smoothstep of cos θ (pbrt-v4's `SpotLight::I`, §12.2.1).
#[derive(Clone, Debug)]
pub struct PointLight {
    /// Position, world units.
    pub position: Vec3,
    /// Radiant intensity on the axis, W·sr⁻¹.
    pub intensity: Vec3,
    /// Spot cone: unit axis, cos of the total half-angle, cos of the start of the falloff.
    pub spot: Option<(Vec3, f32, f32)>,
}

impl PointLight {
    /// Intensity towards unit direction `w` (from the light outwards), W·sr⁻¹.
    #[inline]
    pub fn intensity_towards(&self, w: Vec3) -> Vec3 {
        match self.spot {
            None => self.intensity,
            Some((axis, cos_total, cos_start)) => {
                let c = w.dot(axis);
                if c <= cos_total {
                    return Vec3::ZERO;
                }
                if c >= cos_start {
                    return self.intensity;
                }
                let t = ((c - cos_total) / (cos_start - cos_total)).clamp(0.0, 1.0);
                self.intensity * (t * t * (3.0 - 2.0 * t))
            }
        }
    }

    /// Radiant power, W (luminance-weighted by the caller): 4π I for a point light and
    /// 2π I (1 − (cos_start + cos_total)/2) for a spot (pbrt-v4's `SpotLight::Phi`).
    pub fn power_factor(&self) -> f32 {
        match self.spot {
            None => 4.0 * PI,
            Some((_, cos_total, cos_start)) => 2.0 * PI * (1.0 - 0.5 * (cos_start + cos_total)),
        }
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

    #[test]
    fn spot_falloff_is_smooth_and_bounded() {
        let spot = PointLight {
            position: Vec3::ZERO,
            intensity: Vec3::ONE,
            spot: Some((Vec3::Y, 30f32.to_radians().cos(), 25f32.to_radians().cos())),
        };
        let at = |deg: f32| {
            spot.intensity_towards(Vec3::new(
                deg.to_radians().sin(),
                deg.to_radians().cos(),
                0.0,
            ))
            .x
        };
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(24.0), 1.0);
        assert_eq!(at(31.0), 0.0);
        let mid = at(27.5);
        assert!(mid > 0.3 && mid < 0.7, "{mid}");
        // Power: 2π(1 − (cos 25° + cos 30°)/2), within the point light's 4π.
        assert!(spot.power_factor() > 0.0 && spot.power_factor() < 4.0 * PI);
    }
}
