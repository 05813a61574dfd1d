//! Adaptive sampling: where the samples go, and that the loop is honest.

use crate::util::*;
use aleph::adaptive::{
    AdaptiveSettings, Criterion, PerceptualSettings, Visibility, render_adaptive,
};
use aleph::integrator::Strategy;
use aleph::render::render_uniform;
use aleph::scene::Scene;
use std::path::Path;

/// A 2×1 plane at z = 0 facing +z, split at x = 0 into a left material `left` and a right
/// material `right`, lit by a large one-sided quad light in front of it, seen by a camera on
/// the axis with the plane filling the `w × h` image.
fn split_plane(
    dir: &Path,
    left: &str,
    right: &str,
    w: u32,
    h: u32,
    extra: &[(&str, &[u8])],
) -> Scene {
    let obj = "mtllib m.mtl\n\
        v -1 -0.5 0\nv 0 -0.5 0\nv 0 0.5 0\nv -1 0.5 0\nv 1 -0.5 0\nv 1 0.5 0\n\
        vt 0 0\nvt 0 0\nvt 0 1\nvt 0 1\nvt 1 0\nvt 1 1\n\
        usemtl left\nf 1/1 2/2 3/3 4/4\nusemtl right\nf 2/2 5/5 6/6 3/3\n";
    // Texture coordinates of the right half run 0..1 in u; the left half's are unused.
    let mtl = format!("newmtl left\n{left}\nnewmtl right\n{right}\n");
    // The camera sees exactly the plane: height 1 at distance 2 ⇒ vfov = 2 atan(0.25).
    let vfov = 2.0 * 0.25f64.atan().to_degrees();
    let toml = format!(
        "[camera]\nposition = [0, 0, 2]\nlook_at = [0, 0, 0]\nvfov_deg = {vfov}\nresolution = [{w}, {h}]\n\
         [render]\nmax_depth = 4\n[[mesh]]\nfile = \"p.obj\"\n\
         [[light]]\ntype = \"quad\"\ncorner = [-3, -3, 6]\nedge1 = [0, 6, 0]\nedge2 = [6, 0, 0]\nradiance = [2, 2, 2]\n"
    );
    write_files(
        dir,
        &[("p.obj", obj), ("m.mtl", &mtl), ("scene.toml", &toml)],
    );
    for (name, bytes) in extra {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    Scene::load(&dir.join("scene.toml")).unwrap()
}

/// The bundled Cornell box at `w × h`.
fn cornell_box(w: u32, h: u32) -> Scene {
    let mut desc =
        aleph::scene::SceneDescription::read(&repo("scenes/cornell-box/scene.toml")).unwrap();
    desc.camera.resolution = [w, h];
    Scene::load_description(desc).unwrap()
}

/// Mean samples per pixel over columns [x0, x1) (all rows).
fn mean_spp(film: &aleph::film::Film, x0: u32, x1: u32) -> f64 {
    let mut s = 0u64;
    let mut n = 0u64;
    for y in 0..film.height {
        for x in x0..x1 {
            s += film.pixel(x, y).n as u64;
            n += 1;
        }
    }
    s as f64 / n as f64
}

fn png(w: u32, h: u32, f: impl Fn(u32, u32) -> u8) -> Vec<u8> {
    let img = image::GrayImage::from_fn(w, h, |x, y| image::Luma([f(x, y)]));
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .unwrap();
    bytes
}

#[test]
fn textured_half_gets_fewer_samples_than_flat_half_at_equal_luminance() {
    // Right half: a checkerboard of linear albedo 0.1 and 0.9 in squares of 4×4 pixels (sRGB
    // codes 89 and 243), mean 0.5; left half: flat albedo 0.5. At FLIP's 67 ppd the checker's
    // fundamental is 8.4 cpd with contrast 0.8: it masks the bands where pixel noise is most
    // visible (T_e ≈ 33 there), raising the noise threshold ≈ 1.7× (see the perception crate's
    // threshold tests), so the perceptual sampler, which equalises error / threshold, needs
    // ≈ 1.7² ≈ 3× fewer samples there.
    let d = tempdir();
    let (w, h) = (64u32, 64u32);
    // 8 × 16 texels over the 32 × 64-pixel right half: 4 pixels per texel.
    let tex = png(8, 16, |x, y| if (x + y) % 2 == 0 { 89 } else { 243 });
    let scene = split_plane(
        d.path(),
        "Kd 0.5 0.5 0.5",
        "Kd 1 1 1\nmap_Kd checker.png",
        w,
        h,
        &[("checker.png", &tex)],
    );
    // Until converged (capped at 256 spp): under a sample budget every noisy pixel gets 3/4 of
    // it, which leaves the model's ranking too little room to show at a test's small budgets.
    let s = AdaptiveSettings {
        max_spp: 256,
        ..AdaptiveSettings::default()
    };
    let r = render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap();
    let (flat, textured) = (mean_spp(&r.film, 4, 28), mean_spp(&r.film, 36, 60));
    assert!(
        flat > 1.3 * textured,
        "flat half {flat:.1} spp, textured half {textured:.1} spp"
    );
    // The two halves have the same mean luminance (within the noise of the estimate).
    let rgb = r.film.mean_rgb();
    let half_mean = |x0: usize, x1: usize| {
        let mut s = 0.0;
        for y in 0..h as usize {
            for x in x0..x1 {
                s += rgb[3 * (y * w as usize + x) + 1] as f64;
            }
        }
        s / ((x1 - x0) * h as usize) as f64
    };
    let (a, b) = (half_mean(4, 28), half_mean(36, 60));
    assert!((a / b - 1.0).abs() < 0.1, "{a} vs {b}");
}

#[test]
fn dark_regions_tolerate_more_relative_error() {
    // Left half albedo 0.02, right half 0.8, judged in scene luminance calibrated so that the
    // bright half is ≈ 100 cd/m² and the dark ≈ 2.5 cd/m². Diffuse surfaces under the same light
    // have the same *relative* noise at equal spp; Daly's CSF peak falls from ≈ 237 at 100 cd/m²
    // to ≈ 150 at 2.5 cd/m² (and the finer bands fall faster), so the dark half's threshold
    // contrast is ≈ 1.5× larger (more at the finer bands) and it needs ≈ 2× fewer samples or
    // less (the de Vries–Rose regime:
    // thresholds grow more slowly than luminance in the dark).
    let d = tempdir();
    let scene = split_plane(d.path(), "Kd 0.02 0.02 0.02", "Kd 0.8 0.8 0.8", 48, 48, &[]);
    // Radiance of the bright half ≈ ρ E / π with E ≈ 2π · 2 · (solid-angle factor) ≈ 1.1; pick
    // the scale so it is ≈ 100 cd/m².
    let mut scene = scene;
    scene.settings.luminance_scale = 100.0 / 0.8 / 1.1 * 0.8;
    // A viewer at 12 pixels per degree, so that the 1° adaptation window (σ ≈ 5 px) keeps each
    // half adapted to itself rather than to the mixture.
    // At one exposure: graded 2 stops brighter the dark half would be 10 cd/m², and the
    // latitude (tested below) would rightly ask for more samples there.
    let mut s = AdaptiveSettings {
        budget_spp: Some(48.0),
        // Small budgets, to test the loop's decisions (unsteered by default).
        steer_from_spp: 0.0,
        perceptual: PerceptualSettings {
            visibility: Visibility::Scene,
            latitude_ev: 0.0,
            ..Default::default()
        },
        ..AdaptiveSettings::default()
    };
    s.tone.view.ppd = 12.0;
    let r = render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap();
    let (dark, bright) = (mean_spp(&r.film, 2, 18), mean_spp(&r.film, 30, 46));
    // Equal visibility needs (C_bright / C_dark)² as many samples in the dark: ≥ 2× fewer.
    assert!(
        bright > 1.5 * dark,
        "dark {dark:.1} spp, bright {bright:.1} spp"
    );
}

#[test]
fn highlights_clipped_on_display_keep_their_samples_under_the_exposure_latitude() {
    // Left half albedo 0.9, right 0.01: the automatic exposure (log average to 0.18) puts the
    // left half at ≈ 1.7 × display white, so it clips and its noise is invisible as displayed;
    // graded 2 stops darker it is at ≈ 0.43 and its noise shows. Judged as displayed only, the
    // sampler leaves the clipped half at the first pass's samples; with the ±2 EV latitude it
    // samples it as a visible surface.
    let d = tempdir();
    let scene = split_plane(d.path(), "Kd 0.9 0.9 0.9", "Kd 0.01 0.01 0.01", 48, 48, &[]);
    // Until converged (a sample budget would lift every noisy pixel to half of it, clipped or
    // not), capped at 128 spp.
    let spp_left = |latitude_ev: f64| {
        let mut s = AdaptiveSettings {
            max_spp: 128,
            perceptual: PerceptualSettings {
                latitude_ev,
                ..Default::default()
            },
            ..AdaptiveSettings::default()
        };
        // A display that clips: the plain exposure (the default, Reinhard's, keeps highlights).
        s.tone.operator = perception::tmo::Operator::Exposure;
        let r = render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap();
        // The middle rows, where the left half clips (its corners, further from the light, do
        // not).
        let counts = |x0: u32, x1: u32| -> Vec<u32> {
            (16..32)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .map(|(x, y)| r.film.pixel(x, y).n)
                .collect()
        };
        let mean = |c: &[u32]| c.iter().sum::<u32>() as f64 / c.len() as f64;
        let (left, right) = (counts(2, 22), counts(26, 46));
        (mean(&left), *left.iter().min().unwrap(), mean(&right))
    };
    let (clip_left, _, clip_right) = spp_left(0.0);
    let (lat_left, lat_min, lat_right) = spp_left(2.0);
    // As displayed, the clipped pixels keep the first pass's 8 spp (a few near the edge of the
    // halves could take more through the 3×3 pooling); with the latitude every one of them
    // samples past the first pass (12 is the next stratified total), until its noise is
    // invisible 2 EV darker (about 15 spp here; 20 while the first vertex's BSDF sample was
    // drawn from a net, whose error is higher).
    assert!(
        clip_left < 1.25 * 8.0 && lat_min >= 12 && lat_left > 1.5 * clip_left,
        "as displayed: left {clip_left:.1}, right {clip_right:.1} spp; \
         with latitude: left {lat_left:.1} (at least {lat_min}), right {lat_right:.1} spp"
    );
}

#[test]
fn a_constant_pixel_stops_receiving_samples() {
    // The camera looks straight at the black emitting quad (radiance exactly 2 in every sample,
    // no reflection) over a flat grey background: pixels well inside the light's image have
    // zero error and never get more than the first pass, while the rest keep sampling.
    let d = tempdir();
    let obj = "mtllib m.mtl\nv -2 -2 0\nv 2 -2 0\nv 2 2 0\nv -2 2 0\nusemtl grey\nf 1 2 3 4\n";
    // Light 1 faces the camera (+z); light 2, behind the camera, faces the background.
    let toml = "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nvfov_deg = 60\nresolution = [40, 40]\n\
        [render]\nmax_depth = 4\n[[mesh]]\nfile = \"b.obj\"\n\
        [[light]]\ntype = \"quad\"\ncorner = [-0.4, -0.4, 1]\nedge1 = [0.8, 0, 0]\nedge2 = [0, 0.8, 0]\nradiance = [2, 2, 2]\n\
        [[light]]\ntype = \"quad\"\ncorner = [-1, -1, 5]\nedge1 = [0, 2, 0]\nedge2 = [2, 0, 0]\nradiance = [3, 3, 3]\n";
    write_files(
        d.path(),
        &[
            ("b.obj", obj),
            ("m.mtl", "newmtl grey\nKd 0.5 0.5 0.5\n"),
            ("scene.toml", toml),
        ],
    );
    let scene = Scene::load(&d.path().join("scene.toml")).unwrap();
    let s = AdaptiveSettings {
        budget_spp: Some(64.0),
        // Small budgets, to test the loop's decisions (unsteered by default).
        steer_from_spp: 0.0,
        ..AdaptiveSettings::default()
    };
    let r = render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap();
    // The light spans x, y in about [13, 27]; its interior [17, 23] is at least 3 px inside.
    for y in 17..23 {
        for x in 17..23 {
            let p = r.film.pixel(x, y);
            assert_eq!(p.n, s.min_spp, "light pixel ({x}, {y}) got {} samples", p.n);
            assert!((p.mean().x - 2.0).abs() < 1e-6);
        }
    }
    // Meanwhile the budget (64 spp on average) went to the rest of the image. (Not only to the
    // background: graded 2 EV darker, the light's edges are no longer clipped and their
    // antialiasing noise shows, so the exposure latitude samples them too.)
    let mut rest = (0u64, 0u64);
    for y in 0..40 {
        for x in 0..40 {
            if !(17..23).contains(&x) || !(17..23).contains(&y) {
                rest.0 += r.film.pixel(x, y).n as u64;
                rest.1 += 1;
            }
        }
    }
    assert!(
        rest.0 as f64 / rest.1 as f64 > 64.0,
        "rest of the image {} spp",
        rest.0 as f64 / rest.1 as f64
    );
}

#[test]
fn saliency_sends_more_samples_to_the_salient_object() {
    // A red square on a grey plane: the colour channel of the Itti–Koch–Niebur model makes it
    // the most salient region, so with ω = 4 its threshold falls by up to 1 + 4 = 5× and it gets
    // more of the budget than with saliency off.
    let d = tempdir();
    let obj = "mtllib m.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nv 0.2 -0.2 0.01\nv 0.6 -0.2 0.01\nv 0.6 0.2 0.01\nv 0.2 0.2 0.01\n\
        usemtl grey\nf 1 2 3 4\nusemtl red\nf 5 6 7 8\n";
    let toml = "[camera]\nposition = [0, 0, 2.5]\nlook_at = [0, 0, 0]\nvfov_deg = 40\nresolution = [48, 48]\n\
        [render]\nmax_depth = 4\n[[mesh]]\nfile = \"s.obj\"\n\
        [[light]]\ntype = \"quad\"\ncorner = [-2, -2, 4]\nedge1 = [0, 4, 0]\nedge2 = [4, 0, 0]\nradiance = [2, 2, 2]\n";
    write_files(
        d.path(),
        &[
            ("s.obj", obj),
            (
                "m.mtl",
                "newmtl grey\nKd 0.4 0.4 0.4\nnewmtl red\nKd 0.7 0.05 0.05\n",
            ),
            ("scene.toml", toml),
        ],
    );
    let scene = Scene::load(&d.path().join("scene.toml")).unwrap();
    let spp_in_square = |omega: f32| {
        // Until converged (capped): a budget's 3/4 floor would leave the ranking little room.
        let s = AdaptiveSettings {
            max_spp: 256,
            perceptual: PerceptualSettings {
                saliency_weight: omega,
                ..Default::default()
            },
            ..AdaptiveSettings::default()
        };
        let r = render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap();
        // The square spans x ≈ 28..36, y ≈ 20..28 of the 48×48 image.
        let mut t = 0u64;
        for y in 21..27 {
            for x in 29..35 {
                t += r.film.pixel(x, y).n as u64;
            }
        }
        t as f64 / 36.0
    };
    let (off, on) = (spp_in_square(0.0), spp_in_square(4.0));
    assert!(
        on > 1.3 * off,
        "salient square: {on:.1} spp with ω = 4, {off:.1} without"
    );
}

#[test]
fn uniform_with_a_budget_equals_a_plain_render_bit_for_bit() {
    let scene = cornell_box(24, 24);
    for n in [1u32, 5, 16] {
        let s = AdaptiveSettings {
            criterion: Criterion::Uniform,
            budget_spp: Some(n as f64),
            ..AdaptiveSettings::default()
        };
        let a = render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap().film;
        let b = render_uniform(&scene, Strategy::Mis, n, &|_| {}).0;
        assert!(a == b, "uniform budget {n} differs from a plain render");
    }
}

#[test]
fn adaptive_renders_are_identical_for_one_and_two_threads() {
    let scene = cornell_box(40, 32);
    for sampler in [Criterion::Perceptual, Criterion::Variance] {
        let s = AdaptiveSettings {
            criterion: sampler,
            budget_spp: Some(24.0),
            // Small budgets, to test the loop's decisions (unsteered by default).
            steer_from_spp: 0.0,
            ..AdaptiveSettings::default()
        };
        let run = |t: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap();
            pool.install(|| render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap())
        };
        let (a, b) = (run(1), run(2));
        assert!(a.film == b.film, "{sampler:?}: films differ");
        assert_eq!(a.threshold, b.threshold);
        // The budget is spent, to within the last pass's rounding.
        assert!((a.mean_spp() - 24.0).abs() < 0.5, "{}", a.mean_spp());
        assert!(
            a.film.spp().iter().max() > a.film.spp().iter().min(),
            "{sampler:?} did not adapt"
        );
    }
}

#[test]
fn speedup_runs_end_to_end_on_a_tiny_scene() {
    let d = tempdir();
    let out = d.path().join("sp");
    let speedup = |budgets: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_aleph"))
            .args(["speedup", "--resolution", "24x24", "--budgets", budgets])
            .args(["--reference-spp", "64", "--min-spp", "2", "-o"])
            .arg(&out)
            .arg(repo("scenes/cornell-box/scene.toml"))
            .output()
            .unwrap()
    };
    let o = speedup("2,4,8");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(
        table.contains("| perceptual | 8 |") && table.contains("Equal FLIP mean"),
        "{table}"
    );
    let csv = std::fs::read_to_string(out.join("speedup.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3 * 3);
    assert!(csv.starts_with("sampler,budget_spp,mean_spp"));
    // Judged at both ends of the exposure latitude too, with their display images and
    // speedup tables, and against the oracle.
    assert!(
        csv.lines()
            .next()
            .unwrap()
            .ends_with("flip_mean_ev+2,flip_p99_ev+2")
    );
    for grade in ["ev-2", "ev+2"] {
        let img = image::open(out.join(grade).join("perceptual-8spp.png")).unwrap();
        assert_eq!((img.width(), img.height()), (24, 24));
        assert!(out.join(grade).join("reference.png").exists());
    }
    assert!(
        table.contains("Equal FLIP p99 at −2 EV") && table.contains("Equal FLIP mean at +2 EV"),
        "{table}"
    );
    assert!(table.contains("Against the oracle"), "{table}");
    assert!(out.join("oracle").join("8spp.png").exists());
    // The ceiling in wall time and each allocation's time per sample, from the cost map: a
    // ratio on every row (uniformly rendered budgets cost exactly 1.000× uniform).
    assert!(
        table.contains("ceiling speedup in wall time, FLIP mean"),
        "{table}"
    );
    let rows_8: Vec<&str> = table
        .lines()
        .skip_while(|l| !l.starts_with("## Ceiling"))
        .filter(|l| l.starts_with("| 8 |"))
        .collect();
    assert_eq!(rows_8.len(), 2, "{table}");
    assert!(
        !rows_8[0].contains('—') && rows_8[0].matches('×').count() == 3,
        "{rows_8:?}"
    );
    // Budgets under the steering threshold are rendered uniformly: exactly uniform's cost.
    assert!(rows_8[1].contains("| 1.000× |"), "{rows_8:?}");
    let plot = image::open(out.join("speedup.png")).unwrap();
    assert_eq!((plot.width(), plot.height()), (1200, 900));
    assert!(
        std::fs::read_to_string(out.join("speedup.svg"))
            .unwrap()
            .contains("<svg")
    );
    // The reference is cached: a second run reuses it.
    let o = speedup("2");
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("using cached reference"));
}

#[test]
fn speedup_judges_the_renders_own_stop_as_aleph_render_runs_it() {
    let d = tempdir();
    let out = d.path().join("sp");
    let scene = repo("scenes/cornell-box/scene.toml");
    let common = ["--resolution", "24x24", "--min-spp", "2", "--max-spp", "64"];
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args([
            "speedup",
            "--budgets",
            "2,8,64",
            "--reference-spp",
            "64",
            "--stop",
        ])
        .args(common)
        .arg("-o")
        .arg(&out)
        .arg(&scene)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("## The default stop"), "{table}");
    let csv = std::fs::read_to_string(out.join("stop.csv")).unwrap();
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    assert_eq!((row[0], row[1]), ("perceptual", "0"), "{csv}");
    let stop_spp: f64 = row[2].parse().unwrap();
    for sub in [out.clone(), out.join("ev-2"), out.join("ev+2")] {
        assert!(sub.join("perceptual-stop.png").exists());
    }
    // The same render as `aleph render` with the same seed and settings, to the last sample.
    let r = std::process::Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(["render", "--seed", "0"])
        .args(common)
        .arg("-o")
        .arg(d.path().join("r"))
        .arg(&scene)
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let summary = String::from_utf8_lossy(&r.stdout);
    let mean = summary
        .split(" spp mean")
        .next()
        .and_then(|s| s.rsplit(' ').next())
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no mean spp in {summary}"));
    assert!(
        (mean - stop_spp).abs() < 0.05 && stop_spp > 2.0,
        "render {mean} spp, speedup's stop {stop_spp} spp"
    );
}

#[test]
fn settings_out_of_range_are_refused_not_clamped() {
    let scene = cornell_box(8, 8);
    for (s, words) in [
        (
            AdaptiveSettings {
                min_spp: 1,
                ..Default::default()
            },
            "min_spp",
        ),
        (
            AdaptiveSettings {
                max_spp: 4,
                ..Default::default()
            },
            "max_spp",
        ),
        (
            AdaptiveSettings {
                converged_fraction: 1.5,
                ..Default::default()
            },
            "converged_fraction",
        ),
        (
            AdaptiveSettings {
                steer_from_spp: f64::NAN,
                ..Default::default()
            },
            "steer_from_spp",
        ),
    ] {
        let e = match render_adaptive(&scene, &s, &|_| {}, &|_| {}) {
            Ok(_) => panic!("{words}: accepted"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(words), "{e}");
    }
}

#[test]
fn budgets_under_steer_from_are_the_uniform_render_bit_for_bit() {
    // Below `steer_from_spp` both adaptive samplers render the budget uniformly in one pass:
    // the uniform sampler's image exactly, no guide, nothing judged. At it, they steer.
    let scene = cornell_box(24, 24);
    let run = |sampler, budget: f64, steer_from_spp| {
        let s = AdaptiveSettings {
            criterion: sampler,
            budget_spp: Some(budget),
            steer_from_spp,
            ..Default::default()
        };
        render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap()
    };
    let bits = |r: &aleph::adaptive::AdaptiveResult| {
        r.film
            .mean_rgb()
            .iter()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(aleph::adaptive::STEER_FROM_SPP, 128.0);
    let uniform = run(Criterion::Uniform, 32.0, 128.0);
    for sampler in [Criterion::Perceptual, Criterion::Variance] {
        let r = run(sampler, 32.0, 128.0);
        assert_eq!(bits(&r), bits(&uniform), "{sampler:?}");
        assert!(r.film.pixels.iter().all(|p| p.n == 32));
        assert!(r.threshold.is_none() && r.guide_stats.is_none());
        assert_eq!(r.passes.len(), 1);
        // At the boundary (and with the gate off) the sampler judges; the perceptual one
        // allocates unevenly here (Cycles' criterion calls every pixel noisy at 32 spp).
        for steer_from in [32.0, 0.0] {
            let r = run(sampler, 32.0, steer_from);
            assert!(r.threshold.is_some(), "{sampler:?} at {steer_from}");
            assert!(r.passes.len() > 1);
            let n: Vec<u32> = r.film.pixels.iter().map(|p| p.n).collect();
            if sampler == Criterion::Perceptual {
                assert!(n.iter().min() < n.iter().max(), "uniform counts");
            }
        }
    }
}

#[test]
fn a_spent_time_budget_stops_before_another_pass() {
    // A budget far below the first pass: the loop judges once and stops, by time.
    let scene = cornell_box(32, 32);
    let s = AdaptiveSettings {
        time_budget: Some(std::time::Duration::from_micros(1)),
        ..Default::default()
    };
    let r = render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap();
    assert_eq!(r.stop, aleph::adaptive::StopReason::Time);
    assert_eq!(r.passes.len(), 1);
    assert_eq!(r.mean_spp(), s.min_spp as f64);
}

#[test]
fn converged_counts_follow_the_models_own_oracle() {
    // The samples a pixel needs to reach its threshold are (σ_i / ΔL_i)², with σ_i its
    // per-sample standard deviation of scene luminance (measured from an independent 256-spp
    // uniform render) and ΔL_i its threshold (the sampler's final map). Run until converged,
    // the sampler's counts must rank pixels as that oracle does; uniform counts, or counts set
    // by anything else, would not (Spearman ≈ 0).
    let mut desc =
        aleph::scene::SceneDescription::read(&repo("scenes/cornell-box/scene.toml")).unwrap();
    desc.camera.resolution = [40, 40];
    let scene = Scene::load_description(desc.clone()).unwrap();
    let s = AdaptiveSettings {
        max_spp: 1024,
        ..AdaptiveSettings::default()
    };
    let r = render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap();
    let threshold = r.threshold.unwrap();
    desc.render.seed = Some(0x5EED);
    let other = Scene::load_description(desc).unwrap();
    let (film, _) = render_uniform(&other, Strategy::Mis, 256, &|_| {});
    let k = scene.settings.luminance_scale as f64;
    let (mut need, mut got) = (Vec::new(), Vec::new());
    for (i, p) in film.pixels.iter().enumerate() {
        let sigma = p.lum_std_error() * (p.n as f64).sqrt() * k;
        // Pixels the curve clips at every grade have no threshold: nothing to rank.
        if threshold[i] < 1e29 {
            need.push(((sigma / threshold[i] as f64).powi(2)) as f32);
            got.push(r.film.pixels[i].n as f32);
        }
    }
    let rho = aleph_speedup::rank_correlation(&need, &got);
    eprintln!(
        "oracle against converged counts: Spearman {rho:.3} over {} pixels",
        need.len()
    );
    assert!(rho > 0.5, "Spearman {rho:.3} over {} pixels", need.len());
}

#[test]
fn a_budget_lifts_every_noisy_pixel_to_three_quarters_of_it() {
    // Under a 128-spp budget every pixel with any noise gets at least the floor, 3/4 of the
    // budget (96 spp), whatever the model says of it; only pixels with no noise at all (inside
    // the light, where every sample is the same emitted radiance) stay under it. The
    // rest of the budget goes unevenly, no pixel past twice the budget (256 spp), and all of
    // it is spent.
    let scene = cornell_box(40, 32);
    let s = AdaptiveSettings {
        budget_spp: Some(128.0),
        ..AdaptiveSettings::default()
    };
    let r = render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap();
    let mut lifted = 0;
    for p in &r.film.pixels {
        if p.n >= 96 {
            lifted += 1;
        } else {
            assert_eq!(
                p.lum_variance(),
                0.0,
                "a noisy pixel left under the floor at {} spp",
                p.n
            );
        }
    }
    // (The black frame around the box, where rays leave the scene, has no noise either.)
    assert!(lifted > r.film.len() / 2, "{lifted} pixels lifted");
    let hi = *r.film.spp().iter().max().unwrap();
    assert!(hi > 128, "no pixel got more than the budget: max {hi}");
    assert!(hi <= 256, "a pixel got {hi} spp, over twice the budget");
    assert!((r.mean_spp() - 128.0).abs() < 0.5, "{}", r.mean_spp());
}

/// The stop's floor at a mean of `mean` spp: the largest power of two, or three quarters of
/// one, not above it (`STOP_FLOOR_SHARE` = 1).
fn stop_floor(mean: f64) -> u32 {
    (0..20)
        .flat_map(|k| [1u32 << k, 3u32 << k >> 2])
        .filter(|&t| t >= 1 && t as f64 <= mean)
        .max()
        .unwrap()
}

#[test]
fn the_default_stop_lifts_every_noisy_pixel_to_its_mean() {
    // Without a budget the stop keeps a floor of the mean spp (rounded down to a power of two
    // or three quarters of one): a pixel the model calls converged early, but whose
    // noise the judges see (the holodeck's saturated door), is not left at the first pass's
    // count. Only pixels with no noise at all (the light, the black frame) stay under it.
    // (64 × 48: at 40 × 32 the stop converges at a mean under 48 spp, where the floor would
    // not rise above the first pass.)
    let scene = cornell_box(64, 48);
    let r = render_adaptive(&scene, &AdaptiveSettings::default(), &|_| {}, &|_| {}).unwrap();
    assert_eq!(r.stop, aleph::adaptive::StopReason::Converged);
    let floor = stop_floor(r.mean_spp());
    let mut lifted = 0;
    for p in &r.film.pixels {
        if p.n >= floor {
            lifted += 1;
        } else {
            assert_eq!(
                p.lum_variance(),
                0.0,
                "a noisy pixel left under the floor {floor} at {} spp (mean {:.1})",
                p.n,
                r.mean_spp()
            );
        }
    }
    assert!(lifted > r.film.len() / 2, "{lifted} pixels lifted");
    assert!(floor > 8, "floor {floor} not above the first pass");
}

#[test]
fn a_converged_stop_spends_its_last_pass_on_the_floor_alone() {
    // Once the converged fraction is reached, the stop's only further pass lifts the pixels
    // left under its floor (the mean spp, rounded down to a stratified total);
    // the few pixels still above threshold are not doubled again, nor their neighbours. Each
    // pass's film is recorded through the preview's hook and each judgement's converged
    // fraction through the progress reports; at 64 × 48 the box converges with pixels under
    // the floor, so the last pass follows a converged judgement.
    use aleph::adaptive::{PassReport, Refinement, render_adaptive_refining};
    use std::sync::Mutex;
    let scene = cornell_box(64, 48);
    let s = AdaptiveSettings::default();
    let films: Mutex<Vec<Vec<u32>>> = Mutex::new(Vec::new());
    let reports: Mutex<Vec<f64>> = Mutex::new(Vec::new());
    let r = render_adaptive_refining(
        &scene,
        &s,
        &|p: &PassReport| reports.lock().unwrap().push(p.converged_fraction),
        &|_| {},
        &|f: &Refinement| films.lock().unwrap().push(f.film.spp()),
    )
    .unwrap();
    assert_eq!(r.stop, aleph::adaptive::StopReason::Converged);
    let (films, reports) = (films.into_inner().unwrap(), reports.into_inner().unwrap());
    assert!(films.len() >= 3, "{} passes", films.len());
    let (before, after) = (&films[films.len() - 2], &films[films.len() - 1]);
    // The judgement between the last two passes.
    let judged = reports[reports.len() - 2];
    assert!(
        judged >= s.converged_fraction,
        "the last pass followed a judgement at {judged:.4}: not a floor lift (nothing tested)"
    );
    let mean = before.iter().map(|&n| n as f64).sum::<f64>() / before.len() as f64;
    let floor = stop_floor(mean);
    let mut lifted = 0;
    for (i, (&b, &a)) in before.iter().zip(after).enumerate() {
        if a != b {
            assert!(
                b < floor && a == floor,
                "pixel {i}: {b} -> {a} spp in the last pass (floor {floor}, mean {mean:.1})"
            );
            lifted += 1;
        }
    }
    assert!(lifted > 0, "the last pass gave no pixel samples");
}

#[test]
fn a_budget_does_not_depend_on_the_stops_converged_fraction() {
    // The even fill of a budget starts at its own converged fraction (99.5 %), so the stop's
    // `converged_fraction` leaves a budgeted render bit for bit as it is.
    let scene = cornell_box(40, 32);
    let at = |f: f64| {
        let s = AdaptiveSettings {
            budget_spp: Some(128.0),
            converged_fraction: f,
            ..AdaptiveSettings::default()
        };
        render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap()
    };
    let (a, b) = (at(0.5), at(0.995));
    let (sa, sb) = (a.film.spp(), b.film.spp());
    let differ = sa.iter().zip(&sb).filter(|(x, y)| x != y).count();
    assert_eq!(differ, 0, "{differ} pixels' counts differ");
    assert!(a.film.mean_rgb() == b.film.mean_rgb(), "the images differ");
}

#[test]
fn a_budget_leaves_the_directly_seen_sky_to_the_lit_wall() {
    // A diffuse wall under the bundled Venice sunset, filling the lower half of a view that
    // looks 30° up, the smooth evening sky (15° to 30° up) the upper half. The sky seen
    // directly varies only by the pixel filter's jitter over the map's texels: its relative
    // noise is below the eye's lowest contrast threshold after a few samples, so under a
    // 128-spp budget it gets neither the floor (96 spp) nor a share of the even fill, and the
    // noisy wall gets its samples. Uniform sampling would give both 128.
    let dir = tempdir();
    std::fs::copy(
        repo("tests/data/venice_sunset_1k.hdr"),
        dir.path().join("env.hdr"),
    )
    .unwrap();
    let obj = "mtllib m.mtl\nv -10 3.5 -4.33\nv 10 3.5 -4.33\nv 10 -5.16 -9.33\nv -10 -5.16 -9.33\n\
               usemtl wall\nf 1 2 3 4\n";
    let toml = r#"
[camera]
position = [0.0, 1.0, 0.0]
look_at = [0.0, 1.5, -0.866]
vfov_deg = 30.0
resolution = [48, 32]
[render]
max_depth = 3
[[mesh]]
file = "g.obj"
[[light]]
type = "environment"
file = "env.hdr"
"#;
    write_files(
        dir.path(),
        &[
            ("g.obj", obj),
            ("m.mtl", "newmtl wall\nKd 0.5 0.5 0.5\n"),
            ("scene.toml", toml),
        ],
    );
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
    let s = AdaptiveSettings {
        budget_spp: Some(128.0),
        ..AdaptiveSettings::default()
    };
    let r = render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap();
    let rows = |y0: u32, y1: u32| -> Vec<u32> {
        let mut v: Vec<u32> = (y0..y1)
            .flat_map(|y| (0..48).map(move |x| (x, y)))
            .map(|(x, y)| r.film.pixel(x, y).n)
            .collect();
        v.sort_unstable();
        v
    };
    // Rows 0..12 are sky, rows 20..32 wall (its top edge lies at row 16).
    let (sky, wall) = (rows(0, 12), rows(20, 32));
    let median = |v: &[u32]| v[v.len() / 2];
    let mean = |v: &[u32]| v.iter().map(|&n| n as f64).sum::<f64>() / v.len() as f64;
    assert!(
        median(&sky) < 48,
        "sky median {} spp (wall mean {:.1})",
        median(&sky),
        mean(&wall)
    );
    assert!(
        mean(&wall) > 160.0,
        "wall mean {:.1} spp (sky median {})",
        mean(&wall),
        median(&sky)
    );
    assert!((r.mean_spp() - 128.0).abs() < 0.5, "{}", r.mean_spp());
}

/// A render never takes fewer samples than asked without saying so (issue 35, class 5): a
/// uniform budget above --max-spp is rendered in full, in one piece and in parts, and an
/// adaptive budget the cap could not spend is refused, naming both flags.
#[test]
fn budgets_above_the_cap_are_rendered_or_refused_never_cut() {
    let dir = tempdir();
    let d = dir.path();
    let scene = repo("scenes/cornell-box/scene.toml");
    let run = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_aleph"))
            .arg("render")
            .arg(&scene)
            .args(["--resolution", "4x3", "--max-depth", "2", "-o"])
            .arg(d.join("x"))
            .args(extra)
            .output()
            .unwrap()
    };
    let o = run(&["--sampler", "uniform", "--spp", "5000"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && out.contains("5000.0 spp mean"),
        "{out}"
    );
    let o = run(&["--sampler", "uniform", "--spp", "8192", "--part", "1/2"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && out.contains("samples 0..4096 of 8192"),
        "{out}"
    );
    let o = run(&["--spp", "5000"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--spp 5000") && err.contains("--max-spp 4096"),
        "{err}"
    );
}
