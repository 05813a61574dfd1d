//! Point and spot lights: delta lights, reached only by next-event estimation.

use super::{LightBounds, LightSample};
use glam::Vec3;
use std::f32::consts::PI;

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

impl PointLight {
    /// Bounds for the light BVH with relative power `phi`: a point, emitting all around or
    /// into the spot's cone (pbrt-v4's `SpotLight::Bounds`).
    pub(super) fn bounds(&self, phi: f32) -> LightBounds {
        let (w, cos_o, cos_e) = match self.spot {
            None => (Vec3::Y, -1.0, 0.0),
            Some((axis, cos_total, cos_start)) => {
                (axis, cos_start, (cos_total.acos() - cos_start.acos()).cos())
            }
        };
        LightBounds {
            lo: self.position,
            hi: self.position,
            phi,
            w,
            cos_o,
            cos_e,
            two_sided: false,
        }
    }

    /// Next-event sample from `p_ref`, the light chosen with probability `pmf`: the irradiance
    /// I / d² it gives a surface facing it. `None` at the light's own position.
    #[inline]
    pub(super) fn sample_from(&self, p_ref: Vec3, pmf: f32) -> Option<LightSample> {
        let d = self.position - p_ref;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        Some(LightSample {
            p: self.position,
            n: -wi,
            le: self.intensity_towards(-wi) / dist2,
            wi,
            dist,
            pdf: pmf,
            delta: true,
            on_surface: false,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
