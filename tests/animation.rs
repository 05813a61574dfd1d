//! Time: motion blur against an analytic profile, velocity maps against known motion, frames
//! that are reproducible alone, bad keys, and the adaptation time course.

use crate::util::*;
use aleph::integrator::{Integrator, Strategy};
use aleph::render::render_counts;
use aleph::scene::{Scene, SceneDescription};
use std::path::Path;
use std::process::Command;

/// A one-sided emissive square [-2, 0] × [-2, 2] at z = −1, facing +z (towards a camera at the
/// origin looking along −z).
const EMITTER_OBJ: &str = "mtllib e.mtl\nv -2 -2 -1\nv 0 -2 -1\nv 0 2 -1\nv -2 2 -1\n\
                           usemtl glow\nf 1 2 3 4\n";
const EMITTER_MTL: &str = "newmtl glow\nKd 0 0 0\nKe 1 1 1\n";

/// Camera at the origin looking along −z with a 90° vertical field of view over a square image:
/// image x ∈ [−1, 1] on the plane z = −1 maps linearly to raster x ∈ [0, width].
fn camera(res: [u32; 2]) -> String {
    format!(
        "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, -1]\nvfov_deg = 90\nresolution = [{}, {}]\n",
        res[0], res[1]
    )
}

/// The emitter's right edge moves from x = −0.25 at t = −1 s to +0.25 at t = 1 s; frame 0 at
/// 1 fps has its shutter over [−s/2, s/2] s.
fn moving_emitter(dir: &Path, res: [u32; 2], shutter: f64) -> std::path::PathBuf {
    let toml = format!(
        "{}[render]\nmax_depth = 1\n[animation]\nfps = 1.0\nframes = [0, 0]\nshutter = {shutter}\n\
         [[mesh]]\nfile = \"e.obj\"\n[[mesh.keys]]\ntime = -1.0\ntranslate = [-0.25, 0, 0]\n\
         [[mesh.keys]]\ntime = 1.0\ntranslate = [0.25, 0, 0]\n",
        camera(res)
    );
    write_files(
        dir,
        &[
            ("e.obj", EMITTER_OBJ),
            ("e.mtl", EMITTER_MTL),
            ("scene.toml", &toml),
        ],
    );
    dir.join("scene.toml")
}

/// The fraction of the shutter during which image point x (on z = −1) sees the emitter, whose
/// edge is at 0.25 t: lit while 0.25 t > x, for t over [−s/2, s/2].
fn lit_fraction(x: f64, shutter: f64) -> f64 {
    if shutter == 0.0 {
        return if x < 0.0 { 1.0 } else { 0.0 };
    }
    ((shutter / 2.0 - 4.0 * x) / shutter).clamp(0.0, 1.0)
}

#[test]
fn motion_blur_of_a_moving_edge_follows_the_analytic_ramp() {
    let dir = tempdir();
    let (w, spp) = (32u32, 1024u32);
    let shutter = 0.8;
    let scene = Scene::load(&moving_emitter(dir.path(), [w, w], shutter)).unwrap();
    let integrator = Integrator {
        max_depth: 1,
        strategy: Strategy::Mis,
    };
    let mut film = aleph::film::Film::new(w, w);
    let counts: Vec<u32> = (0..w * w).map(|i| if i < w { spp } else { 0 }).collect();
    render_counts(
        &scene,
        &integrator,
        &mut film,
        &counts,
        aleph::sampler::SampleStreams::Halves,
        &|_| {},
    );
    // Expected per pixel: the lit fraction averaged over the pixel's footprint (box filter),
    // by a fine quadrature independent of the renderer. Image x at raster u: 2u/w − 1 (square
    // image, tan of the half field of view is 1).
    let aspect = 1.0;
    let z = sidak_z(1e-3, w as usize);
    let mut ramp_seen = 0;
    for x in 0..w {
        let k = 4000;
        let expected: f64 = (0..k)
            .map(|i| {
                let u = x as f64 + (i as f64 + 0.5) / k as f64;
                lit_fraction((2.0 * u / w as f64 - 1.0) * aspect, shutter)
            })
            .sum::<f64>()
            / k as f64;
        if expected > 0.05 && expected < 0.95 {
            ramp_seen += 1;
        }
        let px = film.pixel(x, 0);
        let got = px.mean().x;
        // Each sample is 1 or 0 (Bernoulli(p)): standard error sqrt(p(1−p)/n).
        let se = (expected * (1.0 - expected) / spp as f64).sqrt().max(1e-9);
        assert!(
            (got - expected).abs() <= z * se + 1e-6,
            "pixel {x}: {got} vs expected {expected} (±{se})"
        );
    }
    assert!(ramp_seen >= 3, "the blur ramp should span pixels");
}

#[test]
fn without_a_shutter_the_edge_is_sharp() {
    let dir = tempdir();
    let w = 32u32;
    let scene = Scene::load(&moving_emitter(dir.path(), [w, w], 0.0)).unwrap();
    let (film, _) = aleph::render::render_uniform(&scene, Strategy::Mis, 64, &|_| {});
    // Only the pixel straddling x = 0 is partially lit.
    let partial = (0..w)
        .filter(|&x| {
            let v = film.pixel(x, 0).mean().x;
            v > 0.0 && v < 1.0
        })
        .count();
    assert!(partial <= 1, "{partial} partially lit pixels");
}

/// The velocity map taken from the G-buffer (as a reusing frame takes it) is the traced one.
fn same_from_gbuffer(scene: &Scene, v: &aleph::velocity::VelocityMap) {
    let g = aleph::gbuffer::GBuffer::render(scene);
    let from_g = aleph::velocity::velocity_from_gbuffer(scene, &g).unwrap();
    assert_eq!(&from_g, v);
}

fn vector_at(v: &aleph::velocity::VelocityMap, x: usize, y: usize) -> [f32; 4] {
    let i = 4 * (y * v.width + x);
    [
        v.vector[i],
        v.vector[i + 1],
        v.vector[i + 2],
        v.vector[i + 3],
    ]
}

#[test]
fn velocity_of_a_moving_object_is_its_projected_motion() {
    let dir = tempdir();
    let w = 32u32;
    let scene = Scene::load(&moving_emitter(dir.path(), [w, w], 0.5))
        .unwrap()
        .at_frame(0)
        .unwrap();
    let v = aleph::velocity::render_velocity(&scene).unwrap();
    same_from_gbuffer(&scene, &v);
    // The emitter moves +0.25 image units per second = per frame; raster x = (X + 1) w / 2, so
    // +0.25 × 16 = 4 pixels per frame to the right. Blender's layout: X,Y = p(t−1) − p(t) =
    // (−4, 0); Z,W = p(t) − p(t+1) = (−4, 0).
    let on = vector_at(&v, 4, 16);
    for (got, want) in on.iter().zip([-4.0, 0.0, -4.0, 0.0]) {
        assert!((got - want).abs() < 1e-3, "{on:?}");
    }
    // Background (a miss, static camera): no motion.
    assert_eq!(vector_at(&v, 28, 16), [0.0; 4]);
    let m = v.motion_px_per_frame();
    assert!((m[2 * (16 * 32 + 4)] - 4.0).abs() < 1e-3);
    assert!((v.max_speed() - 4.0).abs() < 1e-3);
}

#[test]
fn velocity_of_a_camera_pan_moves_static_content_the_other_way() {
    let dir = tempdir();
    let w = 32u32;
    // A static emitter filling the view at z = −1; the camera moves +0.5 in x and +0.25 in y per
    // second (1 fps): content moves left by 0.5 × 16 = 8 px and down by 0.25 × 16 = 4 px.
    let toml = format!(
        "{}[[camera.keys]]\ntime = -1.0\nposition = [-0.5, -0.25, 0]\nlook_at = [-0.5, -0.25, -1]\n\
         [[camera.keys]]\ntime = 1.0\nposition = [0.5, 0.25, 0]\nlook_at = [0.5, 0.25, -1]\n\
         [animation]\nfps = 1.0\nframes = [0, 0]\n[[mesh]]\nfile = \"e.obj\"\n\
         [[mesh]]\nfile = \"e.obj\"\ntransform = {{ translate = [2, 0, 0] }}\n",
        camera([w, w])
    );
    write_files(
        dir.path(),
        &[
            ("e.obj", EMITTER_OBJ),
            ("e.mtl", EMITTER_MTL),
            ("scene.toml", &toml),
        ],
    );
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
    let v = aleph::velocity::render_velocity(&scene).unwrap();
    same_from_gbuffer(&scene, &v);
    // From t−1 to t content moves left (−8) and down (−4 with the Vector pass's y up), so
    // X,Y = p(t−1) − p(t) = (8, 4) and Z,W = p(t) − p(t+1) = (8, 4).
    for (x, y) in [(10, 10), (20, 25)] {
        let got = vector_at(&v, x, y);
        for (g, want) in got.iter().zip([8.0, 4.0, 8.0, 4.0]) {
            assert!((g - want).abs() < 1e-2, "pixel ({x},{y}): {got:?}");
        }
    }
}

fn animated_cornell(dir: &Path) -> std::path::PathBuf {
    let src = repo("scenes/cornell-motion/scene.toml");
    let text = std::fs::read_to_string(&src)
        .unwrap()
        .replace("resolution = [256, 256]", "resolution = [24, 24]")
        .replace("frames = [0, 47]", "frames = [0, 3]");
    for f in ["CornellBox-Sphere.obj", "CornellBox-Sphere.mtl"] {
        std::fs::copy(repo(&format!("scenes/cornell-motion/{f}")), dir.join(f)).unwrap();
    }
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn a_frame_rendered_alone_equals_the_same_frame_in_a_sequence_for_any_thread_count() {
    let dir = tempdir();
    let path = animated_cornell(dir.path());
    let render = |scene: &Scene, threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| aleph::render::render_uniform(scene, Strategy::Mis, 6, &|_| {}).0)
    };
    // In a sequence: frames 0..=3 on one scene.
    let seq = Scene::load(&path).unwrap();
    let mut frames = Vec::new();
    for f in 0..=3 {
        frames.push(render(&seq.at_frame(f).unwrap(), 2).mean_rgb());
    }
    // Alone: a fresh scene, frame 2 only, one thread.
    let alone = Scene::load(&path).unwrap().at_frame(2).unwrap();
    assert_eq!(render(&alone, 1).mean_rgb(), frames[2]);
    assert_eq!(render(&alone, 3).mean_rgb(), frames[2]);
    // Frames are decorrelated, not copies.
    assert_ne!(frames[1], frames[2]);
}

#[test]
fn cli_frame_alone_writes_the_same_files_as_the_sequence() {
    let dir = tempdir();
    let path = animated_cornell(dir.path());
    let run = |out: &str, extra: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_aleph"))
            .args(["render", path.to_str().unwrap(), "--spp", "8", "-o"])
            .arg(dir.path().join(out))
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).to_string()
    };
    let stdout = run("seq", &["--frames", "0-3"]);
    assert!(stdout.contains("sequence of 4 frames"), "{stdout}");
    run("one", &["--frame", "2", "--threads", "1"]);
    for ext in ["exr", "png"] {
        let a = std::fs::read(dir.path().join(format!("seq.0002.{ext}"))).unwrap();
        let b = std::fs::read(dir.path().join(format!("one.0002.{ext}"))).unwrap();
        assert!(a == b, "frame 2 .{ext} differs alone and in the sequence");
    }
    for f in [
        "seq.0000.exr",
        "seq.0003.png",
        "seq.preview.png",
        "seq.filmstrip.png",
    ] {
        assert!(dir.path().join(f).exists(), "{f} missing");
    }
    // The preview is an animated PNG with 4 frames (acTL chunk: num_frames = 4).
    let apng = std::fs::read(dir.path().join("seq.preview.png")).unwrap();
    let at = apng
        .windows(4)
        .position(|w| w == b"acTL")
        .expect("acTL chunk");
    assert_eq!(
        u32::from_be_bytes(apng[at + 4..at + 8].try_into().unwrap()),
        4
    );
    // The EXR carries Blender's Vector pass.
    let exr = std::fs::read(dir.path().join("seq.0001.exr")).unwrap();
    for ch in ["Vector.X", "Vector.W", "vectorUnits"] {
        assert!(exr.windows(ch.len()).any(|w| w == ch.as_bytes()), "{ch}");
    }
}

fn load_err(dir: &Path, toml: &str) -> String {
    write_files(
        dir,
        &[
            ("e.obj", EMITTER_OBJ),
            ("e.mtl", EMITTER_MTL),
            ("scene.toml", toml),
        ],
    );
    let p = dir.join("scene.toml");
    match SceneDescription::read(&p).and_then(|d| d.build()) {
        Ok(_) => panic!("accepted: {toml}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_keys_are_located_errors() {
    let dir = tempdir();
    let cam = camera([4, 4]);
    let mesh = "[[mesh]]\nfile = \"e.obj\"\n";
    let anim = "[animation]\nfps = 24.0\nframes = [0, 10]\n";
    let key = |t: &str| format!("[[mesh.keys]]\ntime = {t}\ntranslate = [0, 0, 0]\n");
    let cases: Vec<(String, Vec<&str>)> = vec![
        (
            format!("{cam}{anim}{mesh}{}{}", key("0.5"), key("0.1")),
            vec!["[[mesh]] #1 key 2", "strictly increasing"],
        ),
        (
            format!("{cam}{anim}{mesh}{}{}", key("0.0"), key("0.0")),
            vec!["[[mesh]] #1 key 2", "duplicates"],
        ),
        (
            format!("{cam}{anim}{mesh}{}{}", key("0.0"), key("0.2")),
            vec!["frames 0-10", "outside the keys of [[mesh]] #1"],
        ),
        (
            format!("{cam}[animation]\nfps = 0\nframes = [0, 1]\n{mesh}"),
            vec!["animation.fps", "positive"],
        ),
        (
            format!("{cam}[animation]\nfps = -24\nframes = [0, 1]\n{mesh}"),
            vec!["animation.fps"],
        ),
        (
            format!("{cam}[animation]\nfps = 24\nframes = [5, 1]\n{mesh}"),
            vec!["animation.frames", "after the last"],
        ),
        (
            format!("{cam}[animation]\nfps = 24\nframes = [0, 1]\nshutter = 1.5\n{mesh}"),
            vec!["animation.shutter"],
        ),
        (
            format!("{cam}{mesh}{}", key("0.0")),
            vec!["[[mesh]] #1 has keys", "no [animation]"],
        ),
        (
            format!("{cam}[[camera.keys]]\ntime = 1.0\n[[camera.keys]]\ntime = 0.5\n{anim}{mesh}"),
            vec!["[camera] key 2", "strictly increasing"],
        ),
        (
            format!(
                "{cam}{anim}{mesh}[[mesh.keys]]\ntime = 0.0\nscale = 0.0\n[[mesh.keys]]\ntime = 1.0\n"
            ),
            vec!["[[mesh]] #1 key 1", "scale"],
        ),
        (
            format!("{cam}{anim}[[mesh]]\nfile = \"e.obj\"\nobjects = [\"nope\"]\n"),
            vec!["e.obj", "\"nope\""],
        ),
    ];
    for (toml, words) in cases {
        let e = load_err(dir.path(), &toml);
        assert!(e.contains("scene.toml") || e.contains("e.obj"), "{e}");
        for w in words {
            assert!(e.contains(w), "{e:?} lacks {w:?}");
        }
    }
}

#[test]
fn frames_outside_the_range_are_refused() {
    let dir = tempdir();
    let path = animated_cornell(dir.path());
    let scene = Scene::load(&path).unwrap();
    let e = scene.at_frame(9).err().unwrap().to_string();
    assert!(e.contains("frame 9") && e.contains("0-3"), "{e}");
    let o = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(["render", path.to_str().unwrap(), "--frames", "2-7", "-o"])
        .arg(dir.path().join("x"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("frame 7"));
}

#[test]
fn adaptation_course_shows_glare_after_a_cut_to_bright_and_slow_dark_adaptation() {
    use aleph::sequence::AdaptationCourse;
    // Stimuli (cd/m²): 5 dark frames, 48 bright frames, then 48 dark frames, at 24 fps.
    let dark = (0.5, 0.5);
    let bright = (500.0, 500.0);
    let stimuli: Vec<(f64, f64)> = std::iter::repeat_n(dark, 5)
        .chain(std::iter::repeat_n(bright, 48))
        .chain(std::iter::repeat_n(dark, 48))
        .collect();
    let course = AdaptationCourse {
        fps: 24.0,
        first: 0,
        stimuli,
    };
    let display = |frame: i64| {
        let tone = aleph::display::ToneMapSettings {
            operator: perception::tmo::Operator::Ptyg,
            luminance_scale: 1.0,
            adaptation_state: Some(course.state_at(frame)),
            ..Default::default()
        };
        let rgb = vec![500.0f32; 3 * 4];
        aleph::display::tone_map(&rgb, 2, 2, &tone).unwrap()[0]
    };
    // First bright frame: still dark-adapted, so the same bright image looks brighter (glare)
    // than a second later; neural adaptation (t0 = 80 ms) has settled after 1 s.
    let (cut, later) = (display(5), display(5 + 24));
    assert!(cut > 1.2 * later, "glare: {cut} vs {later}");
    let s_settled = course.state_at(5 + 24);
    assert!((s_settled.cone_neural / 500.0 - 1.0).abs() < 0.01);
    // Back in the dark: neural adaptation follows within a second, but the bleached pigment
    // recovers over minutes (τ = 110 s cones, 400 s rods), far from its dark steady state.
    let s = course.state_at(5 + 48 + 24);
    assert!((s.cone_neural / 0.5 - 1.0).abs() < 0.05);
    let steady_dark = perception::tmo::pattanaik00::AdaptationState::steady(0.5, 0.5);
    assert!(
        s.rod_pigment < 0.9 * steady_dark.rod_pigment,
        "{s:?} vs {steady_dark:?}"
    );
}

#[test]
fn sequence_speedup_runs_end_to_end_on_a_tiny_scene() {
    let dir = tempdir();
    let path = animated_cornell(dir.path());
    let out = dir.path().join("sp");
    let o = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(["speedup", "--resolution", "16x16", "--budgets", "2,4,8"])
        .args([
            "--reference-spp",
            "32",
            "--min-spp",
            "2",
            "--frames",
            "1-2",
            "-o",
        ])
        .arg(&out)
        .arg(&path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(
        table.contains("A sequence of 2 frames")
            && table.contains("| perceptual-novelocity | 8 |")
            && table.contains("velocity's gain"),
        "{table}"
    );
    // Per-frame rows: 2 frames × 3 budgets × 5 arms (reuse across frames the fifth); the
    // sequence rows: 3 × 5.
    let frames = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    assert_eq!(frames.lines().count(), 1 + 2 * 3 * 5);
    let csv = std::fs::read_to_string(out.join("speedup.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3 * 5);
    assert!(table.contains("| reuse | 8 |"), "{table}");
    // The frames a video judge reads: one folder per arm and budget, and the reference.
    for f in [
        "frames/reference/0001.png",
        "frames/reference/0002.png",
        "frames/perceptual-8spp/0002.png",
        "frames/uniform-2spp/0001.png",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    // Two cached references, one per frame.
    let refs = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| {
            let n = e.as_ref().unwrap().file_name();
            n.to_string_lossy().starts_with("reference-")
        })
        .count();
    assert_eq!(refs, 2);
}

#[test]
fn thresholds_and_tone_curves_do_not_flicker_on_a_static_sequence() {
    use aleph::adaptive::{AdaptiveSettings, Criterion};
    use aleph::sequence::AdaptationCourse;
    // The Cornell box as a sequence without keys: every frame is the same image up to noise.
    let dir = tempdir();
    let src = std::fs::read_to_string(repo("scenes/cornell-box/scene.toml"))
        .unwrap()
        .replace("resolution = [512, 512]", "resolution = [48, 48]")
        + "\n[animation]\nfps = 24.0\nframes = [0, 5]\n";
    std::fs::copy(
        repo("scenes/cornell-box/CornellBox-Original.obj"),
        dir.path().join("CornellBox-Original.obj"),
    )
    .unwrap();
    std::fs::copy(
        repo("scenes/cornell-box/CornellBox-Original.mtl"),
        dir.path().join("CornellBox-Original.mtl"),
    )
    .unwrap();
    std::fs::write(dir.path().join("scene.toml"), src).unwrap();
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
    let course = AdaptationCourse::compute(&scene, 5).unwrap().unwrap();
    let states: Vec<f64> = (0..=5).map(|f| course.state_at(f).cone_neural).collect();
    for w in states.windows(2) {
        assert!(
            (w[1] / w[0] - 1.0).abs() < 0.02,
            "adaptation jumps between identical frames: {states:?}"
        );
    }
    let mut maps = Vec::new();
    for f in [2, 3] {
        let scene = scene.at_frame(f).unwrap();
        let mut s = AdaptiveSettings {
            criterion: Criterion::Perceptual,
            budget_spp: Some(16.0),
            // Small budgets, to test the loop's decisions (unsteered by default).
            steer_from_spp: 0.0,
            ..Default::default()
        };
        s.tone.operator = perception::tmo::Operator::Ptyg;
        s.tone.luminance_scale = scene.settings.luminance_scale;
        s.tone.adaptation_state = Some(course.state_at(f));
        let r = aleph::adaptive::render_adaptive(&scene, &s, &|_| {}, &|_| {}).unwrap();
        maps.push(r.threshold.unwrap());
    }
    let mut rel: Vec<f64> = maps[0]
        .iter()
        .zip(&maps[1])
        .map(|(a, b)| ((b - a) / a.max(1e-9)).abs() as f64)
        .collect();
    rel.sort_by(f64::total_cmp);
    let median = rel[rel.len() / 2];
    let p90 = rel[rel.len() * 9 / 10];
    eprintln!("threshold change between identical frames: median {median:.4}, p90 {p90:.4}");
    assert!(median < 0.05 && p90 < 0.15, "median {median}, p90 {p90}");
}
