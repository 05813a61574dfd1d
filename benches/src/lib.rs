//! Fixtures shared by the benchmarks in `benches/benches/`.

use aleph::geometry::TriangleAttributes;
use glam::{Vec2, Vec3};
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
