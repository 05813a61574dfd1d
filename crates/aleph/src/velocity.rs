//! The velocity AOV: image-space motion of the surface seen at each pixel centre.
//!
//! For each pixel the camera ray through its centre at the frame's instant t finds the surface
//! point (a point at infinity along the ray when nothing is hit); that point is carried with its
//! object to t − 1/fps and t + 1/fps and projected by the camera of those times. Motion is in
//! **pixels per frame**; with the viewer's pixels per degree (ppd) it is |v| · fps / ppd degrees
//! per second. It is taken at the instant, not averaged over the shutter (Arnold and Cycles both
//! note that motion vectors and motion blur conflict).
//!
//! # Layout (Blender's Vector pass)
//! Four channels per pixel, as Cycles writes them (`primitive_motion_vector`: `motion_pre −
//! motion_center`, `motion_center − motion_post`, in raster space whose y axis points **up**):
//! - `Vector.X`, `Vector.Y`: p(t − 1) − p(t), the motion *to the previous* frame's position;
//! - `Vector.Z`, `Vector.W`: p(t) − p(t + 1), the motion *from the next* frame's position, i.e.
//!   minus the motion to the next frame.
//!
//! So content moving right by 2 pixels per frame and up by 1 has Vector = (−2, −1, −2, −1).
//! Where the surface point is behind the camera at t ± 1 the corresponding pair is 0.

use crate::camera::Camera;
use crate::gbuffer::{GBuffer, Seen};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// A velocity map in Blender's Vector layout (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct VelocityMap {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Row-major, 4 values per pixel: X, Y (to previous), Z, W (from next); pixels per frame,
    /// y up.
    pub vector: Vec<f32>,
}

impl VelocityMap {
    /// The channel `c` (0 = X … 3 = W) as a plane.
    pub fn channel(&self, c: usize) -> Vec<f32> {
        self.vector.iter().skip(c).step_by(4).copied().collect()
    }

    /// The motion of each pixel's surface point in pixels per frame, interleaved (x right,
    /// y down; the image convention of the `perception` crate): the central difference
    /// (p(t + 1) − p(t − 1)) / 2.
    pub fn motion_px_per_frame(&self) -> Vec<f32> {
        self.vector
            .chunks_exact(4)
            .flat_map(|v| {
                // p(t+1) − p(t−1) = −(Z, W) − (X, Y) in y-up raster; flip y to y-down.
                let dx = -(v[2] + v[0]) * 0.5;
                let dy_up = -(v[3] + v[1]) * 0.5;
                [dx, -dy_up]
            })
            .collect()
    }

    /// Largest motion magnitude in pixels per frame.
    pub fn max_speed(&self) -> f32 {
        self.motion_px_per_frame()
            .chunks_exact(2)
            .map(|d| Vec2::new(d[0], d[1]).length())
            .fold(0.0, f32::max)
    }
}

/// The raster position at time `t` of a surface point: `local` in its object's rest space
/// (moved by the instance transform of triangle `tri`), or a direction at infinity.
enum Tracked {
    Surface { tri: u32, local: Vec3 },
    Infinity(Vec3),
}

/// Where `what` is seen at time `t` by `cam`, the camera then.
fn raster_at(scene: &Scene, cam: &Camera, what: &Tracked, t: f32) -> Option<Vec2> {
    match what {
        Tracked::Surface { tri, local } => {
            let p = match scene.geometry.transform_at(*tri, t) {
                Some(m) => m.transform_point3(*local),
                None => *local,
            };
            cam.raster(p)
        }
        Tracked::Infinity(d) => cam.raster_of_direction(*d),
    }
}

/// Renders the velocity map of the scene's current frame; `None` for a still (no
/// `[animation]`).
pub fn render_velocity(scene: &Scene) -> Option<VelocityMap> {
    let t = scene.frame.time_s as f32;
    velocity_map(scene, |x, y| {
        let ray = scene
            .camera
            .generate_ray(x as u32, y as u32, Vec2::splat(0.5), t);
        match scene.geometry.intersect(&ray) {
            Some(hit) => {
                let local = match scene.geometry.transform_at(hit.tri, t) {
                    Some(m) => m.inverse().transform_point3(hit.p),
                    None => hit.p,
                };
                Tracked::Surface {
                    tri: hit.tri,
                    local,
                }
            }
            None => Tracked::Infinity(ray.d),
        }
    })
}

/// The velocity map of the frame whose G-buffer is `g` ([`GBuffer::render`] of `scene`):
/// equal to [`render_velocity`]'s (the G-buffer traced the same rays through the pixel
/// centres) without tracing them again; `None` for a still.
pub fn velocity_from_gbuffer(scene: &Scene, g: &GBuffer) -> Option<VelocityMap> {
    velocity_map(scene, |x, y| match g.seen[y * g.width + x] {
        Seen::Surface { tri, local, .. } => Tracked::Surface { tri, local },
        Seen::Background(d) => Tracked::Infinity(d),
    })
}

/// The velocity map with each pixel centre's point from `seen(x, y)`.
fn velocity_map(
    scene: &Scene,
    seen: impl Fn(usize, usize) -> Tracked + Sync,
) -> Option<VelocityMap> {
    let anim = scene.animation?;
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let t = scene.frame.time_s as f32;
    let dt = (1.0 / anim.fps) as f32;
    let (before, after) = (scene.camera_at(t - dt), scene.camera_at(t + dt));
    let mut vector = vec![0f32; 4 * w * h];
    vector
        .par_chunks_mut(4 * w)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..w {
                let what = seen(x, y);
                let centre = raster_at(scene, &scene.camera, &what, t)
                    .unwrap_or(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                let up = |v: Vec2| Vec2::new(v.x, -v.y);
                let pre = raster_at(scene, &before, &what, t - dt).map(|p| up(p - centre));
                let post = raster_at(scene, &after, &what, t + dt).map(|p| up(centre - p));
                let out = &mut row[4 * x..4 * x + 4];
                if let Some(v) = pre {
                    out[0] = v.x;
                    out[1] = v.y;
                }
                if let Some(v) = post {
                    out[2] = v.x;
                    out[3] = v.y;
                }
            }
        });
    Some(VelocityMap {
        width: w,
        height: h,
        vector,
    })
}
