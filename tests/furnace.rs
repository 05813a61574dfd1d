//! White-furnace tests: closed enclosures whose radiance is known analytically.

use crate::util::*;
use aleph::integrator::Strategy;
use aleph::scene::Scene;

/// Builds a scene of a cube enclosure [-2,2]³ (faces inward) around a cube object [-1,1]³ (faces
/// outward), with the camera between them looking at the object's +z face, which fills the view.
fn furnace_scene(dir: &std::path::Path, enclosure_mtl: &str, object_mtl: &str) -> Scene {
    let obj = format!(
        "mtllib m.mtl\no enclosure\n{}o object\n{}",
        cube_obj(2.0, true, "enc", 0),
        cube_obj(1.0, false, "obj", 8)
    );
    let mtl = format!("newmtl enc\n{enclosure_mtl}\nnewmtl obj\n{object_mtl}\n");
    let toml = r#"
[camera]
position = [0.0, 0.0, 1.9]
look_at = [0.0, 0.0, 0.0]
vfov_deg = 60.0
resolution = [12, 12]
[render]
sample_generator = "independent"
max_depth = 64
seed = 3
[[mesh]]
file = "f.obj"
"#;
    write_files(
        dir,
        &[("f.obj", &obj), ("m.mtl", &mtl), ("scene.toml", toml)],
    );
    Scene::load(&dir.join("scene.toml")).unwrap()
}

/// Every surface has albedo ρ and emits Le: the rendering equation's solution is the constant
/// L = Le / (1 − ρ) (a geometric series over bounces), which needs every bounce that Russian
/// roulette keeps alive. Checked per pixel (Šidák-corrected z-test) and over the image.
#[test]
fn uniform_emitting_enclosure_converges_to_le_over_one_minus_rho() {
    let dir = tempdir();
    let (rho, le) = (0.5f64, 1.0f64);
    let m = format!("Kd {rho} {rho} {rho}\nKe {le} {le} {le}");
    let scene = furnace_scene(dir.path(), &m, &m);
    let expected = le / (1.0 - rho);
    for strategy in [Strategy::Mis, Strategy::LightOnly, Strategy::BsdfOnly] {
        let film = render(&scene, strategy, 512);
        let z = sidak_z(0.01, film.len());
        // Light-only sampling of an enclosure whose emitting walls meet at right angles has a
        // 1/d² weight for receivers near the edges: its per-pixel sample variance is unreliable
        // (a few rare huge samples), so it is tested on the image mean only. MIS weights are
        // bounded, BSDF-only samples are too, so their per-pixel z-tests are valid.
        // Every pixel sees the same constant radiance through the same estimator, so the
        // per-sample variance is pooled over the image: a pixel's own estimate is unreliable
        // here, because after Russian roulette starts (bounce 5, throughput 1/32 under a 5 %
        // floor) a pixel's value turns on how many of its ~26 surviving paths it drew, and a
        // pixel that drew few also measures a small variance.
        let per_pixel = strategy != Strategy::LightOnly;
        let pooled = film.pixels.iter().map(|p| p.lum_variance()).sum::<f64>() / film.len() as f64;
        for p in film.pixels.iter().filter(|_| per_pixel) {
            let y = aleph::math::luminance(p.mean().as_vec3()) as f64;
            let se = (pooled / p.count() as f64).sqrt();
            assert!(
                (y - expected).abs() <= z * se,
                "{strategy:?}: pixel {y} vs {expected} (se {se})"
            );
        }
        let (mean, se) = image_mean_and_se(&film);
        assert!(
            (mean - expected).abs() <= 4.0 * se,
            "{strategy:?}: {mean} ± {se} vs {expected}"
        );
        // The standard error is small enough for the test to mean something: within 1 %.
        assert!(se < 0.01 * expected, "se {se}");
    }
}

/// A convex diffuse object of albedo ρ inside a black enclosure that emits Le towards it sees
/// only the enclosure, so its reflected radiance is exactly ρ·Le.
#[test]
fn convex_object_in_emitting_black_enclosure_reflects_rho_le() {
    let dir = tempdir();
    let (rho, le) = (0.6f64, 2.0f64);
    let scene = furnace_scene(
        dir.path(),
        &format!("Kd 0 0 0\nKe {le} {le} {le}"),
        &format!("Kd {rho} {rho} {rho}"),
    );
    let expected = rho * le;
    for strategy in [Strategy::Mis, Strategy::LightOnly, Strategy::BsdfOnly] {
        let film = render(&scene, strategy, 256);
        let z = sidak_z(0.01, film.len());
        for p in &film.pixels {
            let y = aleph::math::luminance(p.mean().as_vec3()) as f64;
            let se = p.lum_std_error();
            assert!(
                (y - expected).abs() <= z * se.max(1e-6),
                "{strategy:?}: {y} vs {expected} (se {se})"
            );
        }
        let (mean, se) = image_mean_and_se(&film);
        assert!(
            (mean - expected).abs() <= 4.0 * se.max(1e-6),
            "{strategy:?}: {mean} ± {se}"
        );
    }
}

/// The default sample generator (Owen-scrambled Sobol', randomised QMC) converges to the
/// furnace's analytic L = Le/(1 − ρ) = 2: the image mean over 16 renders with independent seeds,
/// tested against the spread of those 16 (RQMC's error is not σ/√n within one render).
#[test]
fn sobol_samples_converge_to_the_furnace_solution() {
    let dir = tempdir();
    let m = "Kd 0.5 0.5 0.5\nKe 1 1 1".to_string();
    let mut scene = furnace_scene(dir.path(), &m, &m);
    scene.settings.sample_generator = aleph::scene::SampleGenerator::Sobol;
    let k = 16;
    let means: Vec<f64> = (0..k)
        .map(|s| {
            scene.settings.seed = 1000 + s;
            image_mean_and_se(&render(&scene, Strategy::Mis, 64)).0
        })
        .collect();
    let mean = means.iter().sum::<f64>() / k as f64;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
    let se = (var / k as f64).sqrt();
    // t(15) two-sided at 0.001 is 4.07.
    assert!((mean - 2.0).abs() <= 4.07 * se, "{mean} ± {se}");
    assert!(se < 0.005, "se {se}");
}
