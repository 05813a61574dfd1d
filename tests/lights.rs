//! Lights other than emissive triangles, against analytic solutions: the environment (furnace
//! tests), the sun, point and spot lights.

use crate::util::*;
use aleph::film::Film;
use aleph::integrator::Strategy;
use aleph::scene::Scene;
use std::f64::consts::PI;

fn lum(p: &aleph::film::PixelStats) -> f64 {
    aleph::math::luminance(p.mean().as_vec3()) as f64
}

/// Every pixel of `film` within its Šidák-corrected z-test of `expected(x, y)`, and the
/// standard error small enough (below `max_rel_se` of the value) for the test to mean something.
fn assert_pixels(film: &Film, what: &str, max_rel_se: f64, expected: impl Fn(usize, usize) -> f64) {
    let z = sidak_z(0.01, film.len());
    for (i, p) in film.pixels.iter().enumerate() {
        let (x, y) = (i % film.width as usize, i / film.width as usize);
        let want = expected(x, y);
        let se = p.lum_std_error();
        let got = lum(p);
        assert!(
            (got - want).abs() <= z * se + 1e-6 * want.abs(),
            "{what}: pixel ({x}, {y}) {got} vs {want} (se {se})"
        );
        assert!(
            se <= max_rel_se * want.abs().max(1e-3),
            "{what}: se {se} of {want}"
        );
    }
}

/// A white furnace: surfaces of albedo 1 under a uniform environment L leave the radiance field
/// uniform (nothing is absorbed), so every pixel is L, whatever the geometry. The open box (a
/// cube [-1,1]³ without its +z face, seen through the opening) makes paths bounce many times:
/// this needs every bounce Russian roulette keeps alive, and MIS of BSDF and environment
/// samples. Then a convex cube of albedo ρ sees only the environment: exactly ρL.
#[test]
fn environment_furnace() {
    let dir = tempdir();
    let (l, rho) = (1.5f64, 0.6f64);
    // Open box: the cube's five faces other than +z, facing inward.
    let mut box_obj = String::from("mtllib m.mtl\n");
    let cube = cube_obj(1.0, true, "white", 0);
    for line in cube.lines() {
        // Inward faces are written reversed; the +z face is the one over vertices 5..8.
        if line.starts_with("f ")
            && line.contains('5')
            && line.contains('6')
            && line.contains('7')
            && line.contains('8')
        {
            continue;
        }
        box_obj += line;
        box_obj += "\n";
    }
    let scene_toml = |obj: &str, env: &str| {
        format!(
            r#"
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
vfov_deg = 30.0
resolution = [10, 10]
[render]
sample_generator = "independent"
max_depth = 200
seed = 5
[[mesh]]
file = "{obj}"
[[light]]
type = "environment"
{env}
"#
        )
    };
    write_files(
        dir.path(),
        &[
            ("box.obj", &box_obj),
            (
                "cube.obj",
                &format!("mtllib m.mtl\n{}", cube_obj(0.5, false, "grey", 0)),
            ),
            (
                "m.mtl",
                &format!("newmtl white\nKd 1 1 1\nnewmtl grey\nKd {rho} {rho} {rho}\n"),
            ),
            (
                "box.toml",
                &scene_toml("box.obj", &format!("radiance = [{l}, {l}, {l}]")),
            ),
            (
                "cube.toml",
                &scene_toml("cube.obj", &format!("radiance = [{l}, {l}, {l}]")),
            ),
        ],
    );
    let open_box = Scene::load(&dir.path().join("box.toml")).unwrap();
    for strategy in [Strategy::Mis, Strategy::BsdfOnly, Strategy::LightOnly] {
        let film = render(&open_box, strategy, 1024);
        let (mean, se) = image_mean_and_se(&film);
        assert!(
            (mean - l).abs() <= 4.0 * se,
            "{strategy:?}: open box {mean} ± {se} vs {l}"
        );
        assert!(se < 0.01 * l, "{strategy:?}: se {se}");
        if strategy != Strategy::LightOnly {
            assert_pixels(&film, &format!("{strategy:?} open box"), 0.05, |_, _| l);
        }
    }
    // The convex cube fills the centre of the view; the rest is the environment itself.
    let cube = Scene::load(&dir.path().join("cube.toml")).unwrap();
    for strategy in [Strategy::Mis, Strategy::BsdfOnly, Strategy::LightOnly] {
        let film = render(&cube, strategy, 256);
        let centre = &film.pixels[5 * 10 + 5];
        let z = sidak_z(0.01, 2);
        let want = rho * l;
        let se = centre.lum_std_error();
        assert!(
            (lum(centre) - want).abs() <= z * se + 1e-6,
            "{strategy:?}: cube {} vs {want} ± {se}",
            lum(centre)
        );
        let corner = lum(&film.pixels[0]);
        assert!(
            (corner - l).abs() < 1e-5,
            "{strategy:?}: background {corner} vs {l}"
        );
    }
}

/// A diffuse plane y = 0 of albedo ρ seen from straight above through a narrow lens (0.1°: the
/// radiance varies by less than 1e-3 over a pixel's footprint).
fn plane_scene(dir: &std::path::Path, rho: f64, light: &str) -> Scene {
    let obj = "mtllib m.mtl\nusemtl p\nv -50 0 -50\nv 50 0 -50\nv 50 0 50\nv -50 0 50\nf 1 4 3 2\n";
    let toml = format!(
        r#"
[camera]
position = [0.3, 10.0, 0.2]
look_at = [0.3, 0.0, 0.2]
up = [0.0, 0.0, -1.0]
vfov_deg = 0.1
resolution = [6, 6]
[render]
sample_generator = "independent"
max_depth = 1
seed = 9
[[mesh]]
file = "p.obj"
{light}
"#
    );
    write_files(
        dir,
        &[
            ("p.obj", obj),
            ("m.mtl", &format!("newmtl p\nKd {rho} {rho} {rho}\n")),
            ("scene.toml", &toml),
        ],
    );
    Scene::load(&dir.join("scene.toml")).unwrap()
}

/// The point (x, z) of the plane seen at the centre of pixel `k` of [`plane_scene`]'s 6×6
/// image: the camera at height 10 over (0.3, 0.2) looks down with image right = +x and image
/// down = +z, half-width 10 tan 0.05°.
fn plane_point(k: usize) -> (f64, f64) {
    let half = 10.0 * 0.05f64.to_radians().tan();
    let s = |i: usize| (2.0 * (i as f64 + 0.5) / 6.0 - 1.0) * half;
    (0.3 + s(k % 6), 0.2 + s(k / 6))
}

/// A point light of intensity I at height h above the plane point (0.3, 0, 0.2) + offset gives
/// the reflected radiance ρ/π · I cos θ / d² (deterministic: one light, no variance beyond the
/// pixel's footprint). The spot version is full inside its cone and dark outside it.
#[test]
fn point_and_spot_lights_match_inverse_square_law() {
    let dir = tempdir();
    let rho = 0.5f64;
    let i = 40.0f64;
    let (lx, ly, lz) = (1.3f64, 2.0f64, -0.6f64);
    let scene = plane_scene(
        dir.path(),
        rho,
        &format!(
            "[[light]]\ntype = \"point\"\nposition = [{lx}, {ly}, {lz}]\nintensity = [{i}, {i}, {i}]"
        ),
    );
    let film = render(&scene, Strategy::Mis, 4);
    for (k, p) in film.pixels.iter().enumerate() {
        let (x, z) = plane_point(k);
        let (dx, dz) = (x - lx, z - lz);
        let d2 = dx * dx + dz * dz + ly * ly;
        let want = rho / PI * i * (ly / d2.sqrt()) / d2;
        assert!(
            (lum(p) / want - 1.0).abs() < 1e-3,
            "point: {} vs {want}",
            lum(p)
        );
    }
    // BSDF sampling cannot reach a delta light.
    let dark = render(&scene, Strategy::BsdfOnly, 4);
    assert!(dark.pixels.iter().all(|p| lum(p) == 0.0));

    // A spot aimed at the viewed point (cone 20°, falloff 5°) lights it fully; aimed 30° away,
    // not at all.
    for (aim, full) in [
        ((0.3, 0.0, 0.2), true),
        (
            (0.3 + 2.0 * 30f64.to_radians().tan() * 3.0, 0.0, 0.2),
            false,
        ),
    ] {
        let sub = dir.path().join(format!("spot{full}"));
        std::fs::create_dir_all(&sub).unwrap();
        let scene = plane_scene(
            &sub,
            rho,
            &format!(
                "[[light]]\ntype = \"spot\"\nposition = [0.3, 2.0, 0.2]\nlook_at = [{}, {}, {}]\n\
                 intensity = [{i}, {i}, {i}]\ncone_angle_deg = 20.0\ncone_delta_deg = 5.0",
                aim.0, aim.1, aim.2
            ),
        );
        let film = render(&scene, Strategy::Mis, 4);
        for (k, p) in film.pixels.iter().enumerate() {
            let (x, z) = plane_point(k);
            let (dx, dz) = (x - 0.3, z - 0.2);
            let d2 = dx * dx + dz * dz + 4.0;
            let want = if full {
                rho / PI * i * (2.0 / d2.sqrt()) / d2
            } else {
                0.0
            };
            assert!(
                (lum(p) - want).abs() <= 1e-3 * want + 1e-7,
                "spot {full}: {} vs {want}",
                lum(p)
            );
        }
    }
}

/// A sun of irradiance E straight above the plane gives ρE/π, by all three strategies (the
/// sun is a cone of finite size that BSDF samples can hit); a wider sun too.
#[test]
fn sun_gives_rho_e_over_pi() {
    let rho = 0.7f64;
    let e = 3.0f64;
    for diameter in [0.53, 10.0] {
        let dir = tempdir();
        let scene = plane_scene(
            dir.path(),
            rho,
            &format!(
                "[[light]]\ntype = \"sun\"\ndirection = [0.0, 1.0, 0.0]\nirradiance = [{e}, {e}, {e}]\n\
                 angular_diameter_deg = {diameter}"
            ),
        );
        let want = rho * e / PI;
        for strategy in [Strategy::Mis, Strategy::LightOnly] {
            let film = render(&scene, strategy, 64);
            let (mean, se) = image_mean_and_se(&film);
            // Light sampling of a sun straight above: cos θ varies by < 1e-5 over a 0.53° disc.
            let tol = (4.0 * se).max(2e-5 * want);
            assert!(
                (mean - want).abs() <= tol,
                "{diameter}° {strategy:?}: {mean} ± {se} vs {want}"
            );
        }
        if diameter > 1.0 {
            // BSDF sampling hits a 10° disc often enough to converge.
            let film = render(&scene, Strategy::BsdfOnly, 4096);
            let (mean, se) = image_mean_and_se(&film);
            assert!(
                (mean - want).abs() <= 4.0 * se,
                "{diameter}° BSDF: {mean} ± {se} vs {want}"
            );
            assert!(se < 0.03 * want);
        }
    }
}

/// An HDR environment map (the bundled Venice sunset) around a glossy and a diffuse cube: light
/// sampling, BSDF sampling and MIS converge to the same image.
#[test]
fn environment_map_strategies_agree() {
    let dir = tempdir();
    std::fs::copy(
        repo("tests/data/venice_sunset_1k.hdr"),
        dir.path().join("env.hdr"),
    )
    .unwrap();
    // A grey cube at the origin and a small glossy one beside it.
    let small: String = cube_obj(0.25, false, "gloss", 8)
        .lines()
        .map(|line| match line.strip_prefix("v ") {
            Some(rest) => {
                let v: Vec<f32> = rest
                    .split_whitespace()
                    .map(|t| t.parse().unwrap())
                    .collect();
                format!("v {} {} {}\n", v[0] + 0.9, v[1] + 0.3, v[2] + 0.4)
            }
            None => format!("{line}\n"),
        })
        .collect();
    let obj = format!("mtllib m.mtl\n{}{small}", cube_obj(0.5, false, "grey", 0));
    let toml = r#"
[camera]
position = [1.5, 1.2, 3.0]
look_at = [0.2, 0.0, 0.0]
vfov_deg = 45.0
resolution = [12, 12]
[render]
sample_generator = "independent"
seed = 2
[[mesh]]
file = "s.obj"
[[light]]
type = "environment"
file = "env.hdr"
rotate_deg = 40.0
strength = 0.5
"#;
    write_files(
        dir.path(),
        &[
            ("s.obj", &obj),
            (
                "m.mtl",
                "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl gloss\nKd 0.2 0.2 0.2\nKs 0.5 0.5 0.5\nNs 100\n",
            ),
            ("scene.toml", toml),
        ],
    );
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
    assert_strategies_agree(&scene, 1024);
}

/// 1,800 small emitters (a 30 × 30 grid of quads hovering 0.2 over a floor, facing it): choosing
/// a light through the light BVH, by its importance at the shading point, must converge faster
/// than choosing by power alone (each floor point is lit mostly by the few emitters just above
/// it), and both must agree on the image.
#[test]
fn light_bvh_beats_power_selection_on_many_small_lights() {
    let dir = tempdir();
    let mut obj = String::from(
        "mtllib m.mtl\nusemtl floor\nv -16 0 -16\nv 16 0 -16\nv 16 0 16\nv -16 0 16\nf 1 4 3 2\nusemtl lamp\n",
    );
    let mut v = 4;
    for i in 0..30 {
        for j in 0..30 {
            let (x, z) = (-14.5 + i as f32, -14.5 + j as f32);
            let h = 0.05;
            obj += &format!(
                "v {} 0.2 {}\nv {} 0.2 {}\nv {} 0.2 {}\nv {} 0.2 {}\nf {} {} {} {}\n",
                x - h,
                z - h,
                x + h,
                z - h,
                x + h,
                z + h,
                x - h,
                z + h,
                v + 1,
                v + 2,
                v + 3,
                v + 4
            );
            v += 4;
        }
    }
    let toml = |sampler: &str| {
        format!(
            r#"
[camera]
position = [0.3, 12.0, 0.4]
look_at = [0.3, 0.0, 0.4]
up = [0.0, 0.0, -1.0]
vfov_deg = 60.0
resolution = [24, 24]
[render]
sample_generator = "independent"
max_depth = 1
light_sampler = "{sampler}"
[[mesh]]
file = "l.obj"
"#
        )
    };
    write_files(
        dir.path(),
        &[
            ("l.obj", &obj),
            (
                "m.mtl",
                "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\nKe 10 10 10\n",
            ),
            ("bvh.toml", &toml("bvh")),
            ("power.toml", &toml("power")),
        ],
    );
    let mut results = Vec::new();
    for name in ["bvh", "power"] {
        let scene = Scene::load(&dir.path().join(format!("{name}.toml"))).unwrap();
        assert_eq!(scene.lights.triangle_count(), 1800);
        let film = render(&scene, Strategy::Mis, 64);
        let (mean, se) = image_mean_and_se(&film);
        let var: f64 =
            film.pixels.iter().map(|p| p.lum_variance()).sum::<f64>() / film.len() as f64;
        results.push((mean, se, var));
    }
    let (b, p) = (results[0], results[1]);
    let se = (b.1 * b.1 + p.1 * p.1).sqrt();
    assert!(
        (b.0 - p.0).abs() <= 4.0 * se,
        "bvh {} vs power {} (se {se})",
        b.0,
        p.0
    );
    // Mean per-sample variance: measured 6.1× lower with the BVH; at least 3× is required.
    assert!(b.2 < p.2 / 3.0, "variance: bvh {} vs power {}", b.2, p.2);
    eprintln!(
        "per-sample variance: bvh {:.4e}, power {:.4e} ({:.1}×)",
        b.2,
        p.2,
        p.2 / b.2
    );
}

/// A lossless glass cube (η = 1.5) under a uniform environment L is invisible in radiance:
/// every path through it, however many internal reflections, carries L out (the 1/η² radiance
/// compression on entering undone on leaving). This exercises refraction, total internal
/// reflection and Russian roulette with the refractions' η² undone.
#[test]
fn glass_furnace() {
    let dir = tempdir();
    let l = 0.8f64;
    let toml = format!(
        r#"
[camera]
position = [0.6, 0.7, 3.0]
look_at = [0.0, 0.0, 0.0]
vfov_deg = 25.0
resolution = [8, 8]
[render]
sample_generator = "independent"
seed = 4
[[mesh]]
file = "g.obj"
[[light]]
type = "environment"
radiance = [{l}, {l}, {l}]
"#
    );
    write_files(
        dir.path(),
        &[
            (
                "g.obj",
                &format!("mtllib m.mtl\n{}", cube_obj(0.5, false, "glass", 0)),
            ),
            ("m.mtl", "newmtl glass\nNi 1.5\nillum 7\n"),
            ("scene.toml", &toml),
        ],
    );
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
    let film = render(&scene, Strategy::Mis, 512);
    let (mean, se) = image_mean_and_se(&film);
    assert!(
        (mean - l).abs() <= 4.0 * se.max(1e-7),
        "{mean} ± {se} vs {l}"
    );
    assert_pixels(&film, "glass", 0.05, |_, _| l);
}

/// Bad light entries are refused with the scene file, the light's number and what is wrong.
#[test]
fn bad_lights_are_refused_with_their_number() {
    let dir = tempdir();
    let obj = format!("mtllib m.mtl\n{}", cube_obj(1.0, false, "a", 0));
    let cases = [
        (
            "type = \"environment\"\nfile = \"missing.hdr\"",
            "missing.hdr",
        ),
        ("type = \"environment\"", "give a file"),
        (
            "type = \"environment\"\nradiance = [1.0, 1.0, 1.0]\n[[light]]\ntype = \"environment\"\nradiance = [1.0, 1.0, 1.0]",
            "at most one environment",
        ),
        (
            "type = \"sun\"\ndirection = [0.0, 0.0, 0.0]\nirradiance = [1.0, 1.0, 1.0]",
            "direction",
        ),
        (
            "type = \"sun\"\ndirection = [0.0, 1.0, 0.0]\nirradiance = [1.0, 1.0, 1.0]\nangular_diameter_deg = 0.0",
            "angular_diameter_deg",
        ),
        (
            "type = \"point\"\nposition = [0.0, 1.0, 0.0]\nintensity = [-1.0, 1.0, 1.0]",
            "intensity",
        ),
        (
            "type = \"spot\"\nposition = [0.0, 1.0, 0.0]\nlook_at = [0.0, 1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]",
            "look_at",
        ),
        (
            "type = \"spot\"\nposition = [0.0, 1.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\ncone_angle_deg = 10.0\ncone_delta_deg = 20.0",
            "cone_delta_deg",
        ),
    ];
    for (k, (light, needle)) in cases.iter().enumerate() {
        let toml = format!(
            "[camera]\nposition = [0.0, 0.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\nvfov_deg = 40.0\n\
             resolution = [4, 4]\n[[mesh]]\nfile = \"c.obj\"\n[[light]]\n{light}\n"
        );
        let name = format!("s{k}.toml");
        write_files(
            dir.path(),
            &[
                ("c.obj", &obj),
                ("m.mtl", "newmtl a\nKd 0.5 0.5 0.5\n"),
                (&name, &toml),
            ],
        );
        let err = match Scene::load(&dir.path().join(&name)) {
            Ok(_) => panic!("case {k} loaded"),
            Err(e) => e.to_string(),
        };
        assert!(
            err.contains(&name) && err.contains(needle),
            "case {k}: {err}"
        );
        assert!(err.contains("[[light]] #"), "case {k}: {err}");
    }
}

/// Every kind of light at once, with the light BVH active (12 emissive triangles) beside an
/// environment and a sun chosen by power: MIS, light sampling alone and BSDF sampling alone
/// converge to the same image, so the pmfs of the two-level choice are consistent.
#[test]
fn mixed_lights_with_the_bvh_agree_across_strategies() {
    let dir = tempdir();
    let mut obj = format!("mtllib m.mtl\n{}", cube_obj(0.5, false, "grey", 0));
    obj += "usemtl floor\nv -3 -0.5 -3\nv 3 -0.5 -3\nv 3 -0.5 3\nv -3 -0.5 3\nf 9 12 11 10\nusemtl lamp\n";
    let mut v = 12;
    for k in 0..6 {
        let x = -1.5 + 0.6 * k as f32;
        obj += &format!(
            "v {} 1.5 -0.2\nv {} 1.5 -0.2\nv {} 1.5 0.2\nv {} 1.5 0.2\nf {} {} {} {}\n",
            x - 0.1,
            x + 0.1,
            x + 0.1,
            x - 0.1,
            v + 1,
            v + 2,
            v + 3,
            v + 4
        );
        v += 4;
    }
    let toml = r#"
[camera]
position = [1.2, 1.0, 3.0]
look_at = [0.0, 0.0, 0.0]
vfov_deg = 50.0
resolution = [10, 10]
[render]
sample_generator = "independent"
seed = 8
[[mesh]]
file = "s.obj"
[[light]]
type = "environment"
radiance = [0.2, 0.25, 0.3]
[[light]]
type = "sun"
direction = [0.3, 1.0, 0.4]
irradiance = [1.5, 1.4, 1.2]
angular_diameter_deg = 8.0
"#;
    write_files(
        dir.path(),
        &[
            ("s.obj", &obj),
            (
                "m.mtl",
                "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl floor\nKd 0.4 0.4 0.4\nKs 0.2 0.2 0.2\nNs 50\nnewmtl lamp\nKd 0 0 0\nKe 4 4 4\n",
            ),
            ("scene.toml", toml),
        ],
    );
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
    assert_eq!(scene.lights.triangle_count(), 12);
    assert_strategies_agree(&scene, 2048);
}

/// MIS, light sampling alone and BSDF sampling alone give the same image mean within 4
/// standard errors, each standard error under 2 % of the mean (so the test has power).
fn assert_strategies_agree(scene: &Scene, spp: u32) {
    let films: Vec<Film> = [Strategy::Mis, Strategy::LightOnly, Strategy::BsdfOnly]
        .iter()
        .map(|&s| render(scene, s, spp))
        .collect();
    let (m0, s0) = image_mean_and_se(&films[0]);
    for (k, f) in films.iter().enumerate().skip(1) {
        let (m, s) = image_mean_and_se(f);
        let se = (s0 * s0 + s * s).sqrt();
        assert!(
            (m - m0).abs() <= 4.0 * se,
            "strategy {k}: {m} vs MIS {m0} (se {se})"
        );
        assert!(se < 0.02 * m0, "se {se} of {m0}");
    }
}

/// Without the light BVH the light is chosen by the first coordinate of the point's 2-D sample,
/// remapped (as Mitsuba 3 does), so a stratified set of 2-D samples stays stratified over the
/// whole emitter set: on the Cornell box's quad light (two triangles), 2^k points of a
/// scrambled Sobol' (0,2)-sequence split between the triangles in proportion to their power to
/// within one sample, at every power of two. A choice made by a separate number (`uc`, here
/// fixed at 0, which alone would always pick the first triangle) fails this.
#[test]
fn light_choice_keeps_the_two_dimensional_sample_stratified() {
    let scene = Scene::load(&repo("scenes/cornell-box/scene.toml")).unwrap();
    let lights = &scene.lights;
    assert!(!lights.chooses_with_own_sample());
    assert_eq!(lights.triangle_count(), 2);
    let verts: Vec<[glam::Vec3; 3]> = lights
        .triangle_ids()
        .map(|t| scene.geometry.world_vertices(t, 0.0))
        .collect();
    let area = |v: &[glam::Vec3; 3]| 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length();
    let share0 = area(&verts[0]) / (area(&verts[0]) + area(&verts[1]));
    // Barycentric containment, with a tolerance for points on the shared edge.
    let inside = |v: &[glam::Vec3; 3], p: glam::Vec3| {
        let n = (v[1] - v[0]).cross(v[2] - v[0]);
        let edge = |a: glam::Vec3, b: glam::Vec3| {
            (b - a).cross(p - a).dot(n) >= -1e-6 * n.length_squared()
        };
        edge(v[0], v[1]) && edge(v[1], v[2]) && edge(v[2], v[0])
    };
    let c = (verts[0][0] + verts[0][1] + verts[0][2]) / 3.0;
    let p_ref = glam::Vec3::new(c.x, 1.0, c.z);
    for seed in 0..4u64 {
        let mut on0 = 0usize;
        for i in 0..256u32 {
            let u = aleph::sampler::sobol::shuffled_scrambled_sobol2d(i, seed);
            let ls = lights
                .sample(
                    p_ref,
                    glam::Vec3::Y,
                    0.0,
                    u,
                    0.0,
                    &scene.geometry,
                    &scene.materials,
                    &scene.textures,
                )
                .expect("the light faces the point");
            let (a, b) = (inside(&verts[0], ls.p), inside(&verts[1], ls.p));
            assert!(a || b, "sample {i} at {:?} is on neither triangle", ls.p);
            on0 += (a && !b) as usize;
            let n = i as usize + 1;
            if n.is_power_of_two() && n >= 4 {
                let want = share0 as f64 * n as f64;
                assert!(
                    (on0 as f64 - want).abs() <= 1.0,
                    "seed {seed}: {on0} of the first {n} samples on triangle 0, want {want:.2}"
                );
            }
        }
    }
}

/// Direct light on an unoccluded diffuse plane under a sun and a constant sky, by light
/// sampling alone: the sky sampled cosine-weighted about the normal gives ρ L per sample, and a
/// light chosen in proportion to the irradiance it delivers (sun E cos θ, sky π L) is weighted
/// by 1/p, so every sample equals the exact ρ/π (E cos θ + π L). Per-sample standard
/// deviations under 2 % of the mean (the sun's 0.53° disc leaves about 0.5 %: the choice
/// weights the disc's largest cosine, the light its mean). With the sky chosen by its power
/// over the whole sphere and sampled uniformly there, they were about 100 %.
#[test]
fn sun_and_sky_light_samples_are_exact_on_an_open_plane() {
    let (rho, e, l) = (0.6f64, 3.0f64, 0.4f64);
    let dir = tempdir();
    let scene = plane_scene(
        dir.path(),
        rho,
        &format!(
            "[[light]]\ntype = \"sun\"\ndirection = [0.8, 0.6, 0.0]\nirradiance = [{e}, {e}, {e}]\n\
             [[light]]\ntype = \"environment\"\nradiance = [{l}, {l}, {l}]"
        ),
    );
    let want = rho / PI * (e * 0.6 + PI * l);
    let film = render(&scene, Strategy::LightOnly, 64);
    let (mean, se) = image_mean_and_se(&film);
    assert!(
        (mean - want).abs() <= (4.0 * se).max(1e-3 * want),
        "{mean} ± {se} vs {want}"
    );
    for p in &film.pixels {
        let sd = p.lum_variance().max(0.0).sqrt();
        assert!(sd < 0.02 * want, "per-sample sd {sd:.4} of {want:.4}");
    }
}
