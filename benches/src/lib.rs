//! Fixtures shared by the benchmarks in `benches/benches/`.

use aleph::geometry::{Ray, TriangleAttributes, offset_origin};
use aleph::rng::Rng;
use aleph::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Path of a file in the repository.
pub fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// A large procedural mesh: a `n × n` height-field terrain (2·n² triangles) with a
/// sum-of-sines surface, for BVH build benchmarks.
pub fn terrain(n: usize) -> Vec<TriangleAttributes> {
    let h = |i: usize, j: usize| {
        let (x, z) = (i as f32 / n as f32, j as f32 / n as f32);
        Vec3::new(
            x,
            0.05 * ((13.0 * x).sin() + (17.0 * z).cos() + (31.0 * (x + z)).sin()),
            z,
        )
    };
    let mut tris = Vec::with_capacity(2 * n * n);
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (h(i, j), h(i + 1, j), h(i + 1, j + 1), h(i, j + 1));
            for p in [[a, b, c], [a, c, d]] {
                tris.push(TriangleAttributes {
                    p,
                    n: None,
                    uv: [Vec2::ZERO; 3],
                    material: 0,
                    light: u32::MAX,
                    instance: aleph::geometry::STATIC_INSTANCE,
                });
            }
        }
    }
    tris
}

/// The luminance (cd/m², 1.0 = 100 cd/m²) of `tests/data/Desk.exr`, a real HDR photograph,
/// resampled bilinearly to `w × h`.
pub fn desk_luminance(w: usize, h: usize) -> Vec<f32> {
    let img = aleph::imageio::read_image(&repo("tests/data/Desk.exr")).expect("Desk.exr");
    let lum = perception::photometry::luminance_image(&img.rgb, 100.0);
    let (sw, sh) = (img.width, img.height);
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        let fy = ((y as f32 + 0.5) * sh as f32 / h as f32 - 0.5).clamp(0.0, (sh - 1) as f32);
        let (y0, ty) = (fy as usize, fy.fract());
        let y1 = (y0 + 1).min(sh - 1);
        for x in 0..w {
            let fx = ((x as f32 + 0.5) * sw as f32 / w as f32 - 0.5).clamp(0.0, (sw - 1) as f32);
            let (x0, tx) = (fx as usize, fx.fract());
            let x1 = (x0 + 1).min(sw - 1);
            let a = lum[y0 * sw + x0] * (1.0 - tx) + lum[y0 * sw + x1] * tx;
            let b = lum[y1 * sw + x0] * (1.0 - tx) + lum[y1 * sw + x1] * tx;
            out.push(a * (1.0 - ty) + b * ty);
        }
    }
    out
}

/// Three sets of rays on `scene`, deterministic for the scene and its camera's size: camera
/// rays (one through each pixel, jittered by PCG32), bounce rays (from each camera ray's hit, a
/// cosine-weighted direction about the side of the geometric normal the camera sees) and shadow
/// rays (from the same hits to a random point of a 20 × 20 m square 100 m above the centre of
/// the scene's bounds, `t_max` just short of it). For ray-casting benchmarks.
pub fn ray_sets(scene: &Scene) -> (Vec<Ray>, Vec<Ray>, Vec<Ray>) {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let camera: Vec<Ray> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let mut rng = Rng::for_sample(0x5eed, i as u64, 0);
            scene.camera_ray(0, (i % w, i / w), 0, rng.uniform2(), 0.0)
        })
        .collect();
    let bounds = (0..scene.geometry.tris.len())
        .flat_map(|i| scene.geometry.tris.positions(i))
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let centre = bounds.0.lerp(bounds.1, 0.5);
    let top = Vec3::new(centre.x, bounds.1.y + 100.0, centre.z);
    let (bounce, shadow): (Vec<Option<Ray>>, Vec<Option<Ray>>) = camera
        .par_iter()
        .enumerate()
        .map(|(i, r)| {
            let Some(hit) = scene.geometry.intersect(r) else {
                return (None, None);
            };
            let mut rng = Rng::for_sample(0x5eed, i as u64, 1);
            let n = if hit.ng.dot(r.d) < 0.0 {
                hit.ng
            } else {
                -hit.ng
            };
            let d = cosine_about(n, rng.uniform2());
            let o = offset_origin(hit.p, hit.ng, d);
            let bounce = Ray {
                o,
                d,
                t_max: f32::INFINITY,
                time: 0.0,
            };
            let u = rng.uniform2() - Vec2::splat(0.5);
            let to = top + Vec3::new(20.0 * u.x, 0.0, 20.0 * u.y) - hit.p;
            let (dist, dl) = (to.length(), to.normalize());
            let shadow = Ray {
                o: offset_origin(hit.p, hit.ng, dl),
                d: dl,
                t_max: dist * (1.0 - 1e-4),
                time: 0.0,
            };
            (Some(bounce), Some(shadow))
        })
        .unzip();
    let keep = |v: Vec<Option<Ray>>| v.into_iter().flatten().collect();
    (camera, keep(bounce), keep(shadow))
}

/// A cosine-weighted direction about unit `n` for `u` in [0, 1)².
fn cosine_about(n: Vec3, u: Vec2) -> Vec3 {
    let (r, phi) = (u.x.sqrt(), std::f32::consts::TAU * u.y);
    let (t, b) = n.any_orthonormal_pair();
    let z = (1.0 - u.x).max(0.0).sqrt();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize()
}
