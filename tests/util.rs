//! Shared fixtures for the integration tests.

use aleph::film::Film;
use aleph::integrator::Strategy;
use aleph::render::render_uniform;
use aleph::scene::Scene;
use std::path::{Path, PathBuf};

/// Path of a file in the repository.
pub fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// A fresh temporary directory.
pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temporary directory")
}

/// Writes `files` (name, contents) into `dir`.
pub fn write_files(dir: &Path, files: &[(&str, &str)]) {
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
}

/// OBJ text of an axis-aligned cube [-h, h]³ whose faces point outward (`inward = false`) or
/// inward, using material `mtl`. Vertex indices are offset by `base` (1-based OBJ indices).
pub fn cube_obj(h: f32, inward: bool, mtl: &str, base: usize) -> String {
    let mut s = format!("usemtl {mtl}\n");
    let v = [
        [-h, -h, -h],
        [h, -h, -h],
        [h, h, -h],
        [-h, h, -h],
        [-h, -h, h],
        [h, -h, h],
        [h, h, h],
        [-h, h, h],
    ];
    for p in v {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    // Outward-facing quads (counter-clockwise seen from outside).
    let faces = [
        [0, 3, 2, 1], // -z
        [4, 5, 6, 7], // +z
        [0, 4, 7, 3], // -x
        [1, 2, 6, 5], // +x
        [0, 1, 5, 4], // -y
        [3, 7, 6, 2], // +y
    ];
    for f in faces {
        let f: Vec<usize> = if inward {
            f.iter().rev().copied().collect()
        } else {
            f.to_vec()
        };
        s += &format!(
            "f {} {} {} {}\n",
            f[0] + base + 1,
            f[1] + base + 1,
            f[2] + base + 1,
            f[3] + base + 1
        );
    }
    s
}

/// Renders `spp` samples per pixel with `strategy`.
pub fn render(scene: &Scene, strategy: Strategy, spp: u32) -> Film {
    render_uniform(scene, strategy, spp, &|_| {}).0
}

/// Šidák-corrected two-sided z threshold for `n` simultaneous tests at family-wise level `alpha`.
pub fn sidak_z(alpha: f64, n: usize) -> f64 {
    let a = 1.0 - (1.0 - alpha).powf(1.0 / n as f64);
    inverse_normal_two_sided(a)
}

/// z such that P(|Z| > z) = a for a standard normal Z (bisection on erfc).
pub fn inverse_normal_two_sided(a: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if erfc(mid / std::f64::consts::SQRT_2) > a {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Complementary error function (Numerical Recipes `erfcc`, relative error < 1.2e-7).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// The luminance mean and standard error of the mean over all pixels of `film`, treating the
/// pixels as independent estimates.
pub fn image_mean_and_se(film: &Film) -> (f64, f64) {
    let n = film.pixels.len() as f64;
    let means: Vec<f64> = film
        .pixels
        .iter()
        .map(|p| aleph::math::luminance(p.mean().as_vec3()) as f64)
        .collect();
    let mean = means.iter().sum::<f64>() / n;
    let var_of_mean: f64 = film
        .pixels
        .iter()
        .map(|p| p.lum_variance() / p.n as f64)
        .sum::<f64>()
        / (n * n);
    (mean, var_of_mean.sqrt())
}
