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
                });
            }
        }
    }
    tris
}
