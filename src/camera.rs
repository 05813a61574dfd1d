//! The pinhole camera.

use crate::geometry::Ray;
use glam::{Vec2, Vec3};

/// A pinhole camera with a box pixel filter: each sample is a uniformly jittered point inside
/// its pixel.
///
/// Image coordinates: pixel (x, y) covers [x, x+1) × [y, y+1), x to the right, y **down**
/// (row 0 is the top of the image).
#[derive(Clone, Debug)]
pub struct Camera {
    /// Eye position (world).
    pub position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half_v: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Vertical field of view in degrees.
    pub vfov_deg: f32,
}

impl Camera {
    /// A camera at `position` looking at `look_at`, with `up` giving the vertical, the vertical
    /// field of view in degrees (0, 180) and the resolution. Returns `None` when the look
    /// direction is zero or parallel to `up`.
    pub fn look_at(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        vfov_deg: f32,
        width: u32,
        height: u32,
    ) -> Option<Camera> {
        let forward = (look_at - position).normalize_or_zero();
        let right = forward.cross(up).normalize_or_zero();
        if forward == Vec3::ZERO || right == Vec3::ZERO {
            return None;
        }
        let up = right.cross(forward);
        Some(Camera {
            position,
            forward,
            right,
            up,
            tan_half_v: (0.5 * vfov_deg.to_radians()).tan(),
            width,
            height,
            vfov_deg,
        })
    }

    /// Horizontal field of view in degrees.
    pub fn hfov_deg(&self) -> f32 {
        let aspect = self.width as f32 / self.height as f32;
        2.0 * (self.tan_half_v * aspect).atan().to_degrees()
    }

    /// The primary ray through pixel (x, y) at sub-pixel offset `u` ∈ [0,1)².
    #[inline]
    pub fn generate_ray(&self, x: u32, y: u32, u: Vec2) -> Ray {
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * (x as f32 + u.x) / self.width as f32 - 1.0) * self.tan_half_v * aspect;
        let sy = (1.0 - 2.0 * (y as f32 + u.y) / self.height as f32) * self.tan_half_v;
        let d = (self.forward + self.right * sx + self.up * sy).normalize();
        Ray {
            o: self.position,
            d,
            t_max: f32::INFINITY,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_forward_and_corners_span_the_fov() {
        let c = Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 90.0, 100, 50).unwrap();
        let r = c.generate_ray(50, 25, Vec2::ZERO);
        assert!((r.d - -Vec3::Z).length() < 1e-6);
        // Top edge at 45° above the axis for a 90° vertical FOV.
        let top = c.generate_ray(50, 0, Vec2::ZERO);
        assert!((top.d.y / -top.d.z - 1.0).abs() < 1e-5);
        // Left edge: tan(h/2) = aspect × tan(v/2) = 2, to the left (−x).
        let left = c.generate_ray(0, 25, Vec2::ZERO);
        assert!((left.d.x / -left.d.z + 2.0).abs() < 1e-5);
        assert!((c.hfov_deg() - 2.0 * 2f32.atan().to_degrees()).abs() < 1e-3);
        assert!(Camera::look_at(Vec3::ZERO, Vec3::Y, Vec3::Y, 40.0, 1, 1).is_none());
    }
}
