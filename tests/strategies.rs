//! NEE-only, BSDF-only and MIS estimates of the same scene must agree within their standard
//! errors (they are unbiased estimators of the same integral).

use crate::util::*;
use aleph::integrator::Strategy;
use aleph::scene::{Scene, SceneDescription};

/// The bundled Cornell box at 16×16 with the tall box made glossy (GGX α = 0.3) and the short
/// box a mirror, so that every BSDF class the integrator handles takes part.
fn scene() -> Scene {
    let mut desc = SceneDescription::read(&repo("scenes/cornell-box/scene.toml")).unwrap();
    desc.camera.resolution = [16, 16];
    // Per-pixel z-tests assume independent samples (σ/√n).
    desc.render.sample_generator = Some(aleph::scene::SampleGenerator::Independent);
    let extra: SceneDescription = SceneDescription::parse(
        r#"
[camera]
position = [0, 0, 0]
look_at = [0, 0, -1]
vfov_deg = 40
resolution = [1, 1]
[materials.tallBox]
type = "glossy"
reflectance = [0.3, 0.3, 0.3]
specular = [0.5, 0.5, 0.5]
alpha = 0.3
[materials.shortBox]
type = "mirror"
reflectance = [0.8, 0.8, 0.8]
"#,
        std::path::Path::new("overrides.toml"),
    )
    .unwrap();
    desc.materials = extra.materials;
    Scene::load_description(desc).unwrap()
}

#[test]
fn nee_bsdf_and_mis_agree() {
    let scene = scene();
    let spp = 2048;
    let mis = render(&scene, Strategy::Mis, spp);
    let nee = render(&scene, Strategy::LightOnly, spp);
    let bsdf = render(&scene, Strategy::BsdfOnly, spp);
    let n = mis.len();
    // Per-pixel tests need a trustworthy per-pixel variance. BSDF-only sampling of this small
    // light is heavy-tailed: at 2048 spp some pixels see no light hit at all, and their sample
    // variance is 0 (measured: at 32768 spp every pixel agrees with MIS within 2.4 σ). It is
    // therefore checked on the whole-image mean only.
    for (name, other, per_pixel) in [("light-only", &nee, true), ("bsdf-only", &bsdf, false)] {
        // Whole-image mean: a precise test of bias.
        let (m1, s1) = image_mean_and_se(&mis);
        let (m2, s2) = image_mean_and_se(other);
        let se = (s1 * s1 + s2 * s2).sqrt();
        assert!(
            (m1 - m2).abs() <= 4.0 * se,
            "{name}: MIS {m1} vs {m2}, se {se}"
        );
        if !per_pixel {
            continue;
        }
        // Per pixel, Šidák-corrected at a 1 % family-wise level.
        let z = sidak_z(0.01, n);
        let mut worst = 0.0f64;
        for (a, b) in mis.pixels.iter().zip(&other.pixels) {
            let ya = aleph::math::luminance(a.mean().as_vec3()) as f64;
            let yb = aleph::math::luminance(b.mean().as_vec3()) as f64;
            let se = (a.lum_std_error().powi(2) + b.lum_std_error().powi(2)).sqrt();
            if se > 0.0 {
                worst = worst.max((ya - yb).abs() / se);
            } else {
                assert_eq!(ya, yb);
            }
        }
        assert!(worst <= z, "{name}: worst pixel |Δ|/se = {worst} > {z}");
    }
    // MIS should be no noisier than the worse single strategy on the image as a whole.
    let (_, s_mis) = image_mean_and_se(&mis);
    let (_, s_bsdf) = image_mean_and_se(&bsdf);
    assert!(s_mis < s_bsdf, "MIS se {s_mis} vs BSDF-only se {s_bsdf}");
}
