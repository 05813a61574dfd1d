//! The camera: a pinhole, or a thin lens with depth of field.

use crate::animation::CameraKey;
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
    /// Radius of the thin lens's aperture, world units (0: a pinhole, everything sharp).
    pub lens_radius: f32,
    /// Distance from the eye along the view direction to the plane in focus, world units.
    pub focus_distance: f32,
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
            lens_radius: 0.0,
            focus_distance: 1.0,
        })
    }

    /// The same camera with a thin lens of aperture radius `lens_radius` (world units, ≥ 0)
    /// focused at `focus_distance` (> 0) along the view direction (pbrt-v4 §5.2.3).
    pub fn with_lens(mut self, lens_radius: f32, focus_distance: f32) -> Camera {
        self.lens_radius = lens_radius.max(0.0);
        self.focus_distance = focus_distance;
        self
    }

    /// Horizontal field of view in degrees.
    pub fn hfov_deg(&self) -> f32 {
        let aspect = self.width as f32 / self.height as f32;
        2.0 * (self.tan_half_v * aspect).atan().to_degrees()
    }

    /// The camera of a keyframed pose (see [`CameraKey`]) at a resolution; `None` as
    /// [`Camera::look_at`].
    pub fn from_key(k: &CameraKey, width: u32, height: u32) -> Option<Camera> {
        Camera::look_at(k.position, k.look_at, k.up, k.vfov_deg, width, height)
    }

    /// The unit view axis (the direction the camera looks along).
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Distance of world point `p` along the view axis (Blender's `Depth.Z`), m; negative
    /// behind the camera.
    pub fn depth_of(&self, p: Vec3) -> f32 {
        (p - self.position).dot(self.forward)
    }

    /// Continuous raster position (x right, y down, pixel (x, y) covering [x, x+1) × [y, y+1))
    /// of world point `p`, or `None` when `p` is not in front of the camera.
    pub fn raster(&self, p: Vec3) -> Option<Vec2> {
        self.raster_of_direction(p - self.position)
    }

    /// The projection of [`Camera::raster_of_direction`] with its constants folded: one
    /// reciprocal and three dot products a point, for code that projects millions of points
    /// through one camera (reuse across frames lands every kept sample). It rounds differently
    /// from [`Camera::raster`] in the last bits.
    pub fn projection(&self) -> Projection {
        let aspect = self.width as f32 / self.height as f32;
        let (w, h) = (self.width as f32, self.height as f32);
        Projection {
            position: self.position,
            forward: self.forward,
            x: self.right * (0.5 * w / (self.tan_half_v * aspect)),
            y: -self.up * (0.5 * h / self.tan_half_v),
            centre: Vec2::new(0.5 * w, 0.5 * h),
        }
    }

    /// Solid angle (sr) of a pixel in direction `d` (any length, in front of the camera): a
    /// pixel's area on the image plane at unit distance, (2 tan(vfov/2) / height)², times
    /// cos³ of the angle between `d` and the view axis.
    pub fn pixel_solid_angle(&self, d: Vec3) -> f32 {
        let side = 2.0 * self.tan_half_v / self.height as f32;
        let c = d.normalize_or_zero().dot(self.forward).max(0.0);
        side * side * c * c * c
    }

    /// Continuous raster position of the direction `d` (a point at infinity), or `None` when it
    /// points behind the image plane.
    pub fn raster_of_direction(&self, d: Vec3) -> Option<Vec2> {
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let aspect = self.width as f32 / self.height as f32;
        let sx = d.dot(self.right) / z / (self.tan_half_v * aspect);
        let sy = d.dot(self.up) / z / self.tan_half_v;
        Some(Vec2::new(
            0.5 * (sx + 1.0) * self.width as f32,
            0.5 * (1.0 - sy) * self.height as f32,
        ))
    }

    /// The primary ray through pixel (x, y) at sub-pixel offset `u` ∈ [0,1)², at scene time
    /// `time` (seconds), through the centre of the lens.
    #[inline]
    pub fn generate_ray(&self, x: u32, y: u32, u: Vec2, time: f32) -> Ray {
        self.generate_ray_lens(x, y, u, Vec2::splat(0.5), time)
    }

    /// As [`Camera::generate_ray`], through the point of the lens that `lens` ∈ [0,1)² maps to
    /// (concentric disc mapping): the ray leaves that point towards where the pinhole ray meets
    /// the plane of focus, so that plane stays sharp and the rest blurs with distance from it.
    #[inline]
    pub fn generate_ray_lens(&self, x: u32, y: u32, u: Vec2, lens: Vec2, time: f32) -> Ray {
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * (x as f32 + u.x) / self.width as f32 - 1.0) * self.tan_half_v * aspect;
        let sy = (1.0 - 2.0 * (y as f32 + u.y) / self.height as f32) * self.tan_half_v;
        let dir = self.forward + self.right * sx + self.up * sy;
        if self.lens_radius <= 0.0 {
            return Ray {
                o: self.position,
                d: dir.normalize(),
                t_max: f32::INFINITY,
                time,
            };
        }
        let focus = self.position + dir * self.focus_distance;
        let l = crate::sampling::square_to_concentric_disk(lens) * self.lens_radius;
        let o = self.position + self.right * l.x + self.up * l.y;
        Ray {
            o,
            d: (focus - o).normalize(),
            t_max: f32::INFINITY,
            time,
        }
    }
}

/// A camera's projection onto its raster ([`Camera::projection`]): raster position =
/// `centre + (x · d, y · d) / (forward · d)` for a direction `d` from the eye.
#[derive(Clone, Copy, Debug)]
pub struct Projection {
    position: Vec3,
    forward: Vec3,
    x: Vec3,
    y: Vec3,
    centre: Vec2,
}

impl Projection {
    /// The eye position (world).
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// Continuous raster position of world point `p` (as [`Camera::raster`]).
    #[inline]
    pub fn raster(&self, p: Vec3) -> Option<Vec2> {
        self.raster_of_direction(p - self.position)
    }

    /// Continuous raster position of the direction `d` (as [`Camera::raster_of_direction`]).
    #[inline]
    pub fn raster_of_direction(&self, d: Vec3) -> Option<Vec2> {
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let r = 1.0 / z;
        Some(self.centre + Vec2::new(d.dot(self.x), d.dot(self.y)) * r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_forward_and_corners_span_the_fov() {
        let c = Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 90.0, 100, 50).unwrap();
        let r = c.generate_ray(50, 25, Vec2::ZERO, 0.0);
        assert!((r.d - -Vec3::Z).length() < 1e-6);
        // Top edge at 45° above the axis for a 90° vertical FOV.
        let top = c.generate_ray(50, 0, Vec2::ZERO, 0.0);
        assert!((top.d.y / -top.d.z - 1.0).abs() < 1e-5);
        // Left edge: tan(h/2) = aspect × tan(v/2) = 2, to the left (−x).
        let left = c.generate_ray(0, 25, Vec2::ZERO, 0.0);
        assert!((left.d.x / -left.d.z + 2.0).abs() < 1e-5);
        assert!((c.hfov_deg() - 2.0 * 2f32.atan().to_degrees()).abs() < 1e-3);
        assert!(Camera::look_at(Vec3::ZERO, Vec3::Y, Vec3::Y, 40.0, 1, 1).is_none());
    }

    #[test]
    fn raster_inverts_generate_ray() {
        let c = Camera::look_at(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(0.0, 0.5, -1.0),
            Vec3::Y,
            50.0,
            64,
            48,
        )
        .unwrap();
        for (x, y, u) in [(0, 0, Vec2::new(0.25, 0.75)), (40, 17, Vec2::splat(0.5))] {
            let r = c.generate_ray(x, y, u, 0.0);
            let want = Vec2::new(x as f32, y as f32) + u;
            let got = c.raster(r.o + 7.0 * r.d).unwrap();
            assert!((got - want).length() < 1e-3, "{got} vs {want}");
            let folded = c.projection().raster(r.o + 7.0 * r.d).unwrap();
            assert!((folded - want).length() < 1e-3, "{folded} vs {want}");
            let d = c.projection().raster_of_direction(r.d).unwrap();
            assert!((d - want).length() < 1e-3, "{d} vs {want}");
        }
        assert!(c.raster(c.position - (c.forward)).is_none());
        assert!(c.projection().raster(c.position - (c.forward)).is_none());
    }
}
