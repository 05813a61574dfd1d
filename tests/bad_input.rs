//! Every kind of bad input gives a clear message naming the file and the problem, exit status
//! 2, no panic, and no output file (not even a temporary one).

use crate::util::*;
use std::path::Path;
use std::process::Command;

const CAMERA: &str =
    "[camera]\nposition = [0, 1, 3]\nlook_at = [0, 1, 0]\nvfov_deg = 40\nresolution = [8, 8]\n";
const LIGHT: &str = "[[light]]\ntype = \"quad\"\ncorner = [-0.5, 1.9, -0.5]\nedge1 = [1, 0, 0]\nedge2 = [0, 0, 1]\nradiance = [1, 1, 1]\n";
const TRI_OBJ: &str = "mtllib m.mtl\nv -1 0 -1\nv 1 0 -1\nv 0 0 1\nusemtl white\nf 1 2 3\n";
const MTL: &str = "newmtl white\nKd 0.5 0.5 0.5\n";

/// Runs `aleph render` on `scene` with output into `dir`, expects failure, and returns stderr.
fn fails(dir: &Path, scene: &Path, extra: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .arg("render")
        .arg(scene)
        .arg("-o")
        .arg(dir.join("out"))
        .args(extra)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(
        out.status.code(),
        Some(2),
        "expected exit 2, stderr: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with("out") || n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "output files were written: {left:?}");
    stderr
}

fn scene_with(dir: &Path, toml: &str, files: &[(&str, &str)]) -> std::path::PathBuf {
    write_files(dir, files);
    let p = dir.join("scene.toml");
    std::fs::write(&p, toml).unwrap();
    p
}

fn assert_mentions(stderr: &str, words: &[&str]) {
    for w in words {
        assert!(stderr.contains(w), "stderr lacks {w:?}: {stderr}");
    }
}

#[test]
fn missing_scene_file() {
    let d = tempdir();
    let e = fails(d.path(), &d.path().join("nope.toml"), &[]);
    assert_mentions(&e, &["nope.toml", "cannot read"]);
}

#[test]
fn scene_path_is_a_directory() {
    let d = tempdir();
    std::fs::create_dir(d.path().join("sub.toml")).unwrap();
    let e = fails(d.path(), &d.path().join("sub.toml"), &[]);
    assert_mentions(&e, &["sub.toml", "cannot read"]);
}

#[test]
fn malformed_toml() {
    let d = tempdir();
    let s = scene_with(d.path(), "[camera\nposition = 1", &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "line 1"]);
}

#[test]
fn unknown_key() {
    let d = tempdir();
    let toml = format!("{CAMERA}fov = 3\n{LIGHT}");
    let s = scene_with(d.path(), &toml, &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "unknown field", "fov"]);
}

#[test]
fn missing_obj() {
    let d = tempdir();
    let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"missing.obj\"\n");
    let s = scene_with(d.path(), &toml, &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["missing.obj", "cannot read"]);
}

#[test]
fn missing_mtl() {
    let d = tempdir();
    let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n");
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["m.mtl", "MTL", "not found"]);
}

#[test]
fn missing_texture() {
    let d = tempdir();
    let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n");
    let mtl = "newmtl white\nKd 0.5 0.5 0.5\nmap_Kd nothere.png\n";
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ), ("m.mtl", mtl)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["nothere.png", "texture"]);
}

#[test]
fn corrupt_texture() {
    let d = tempdir();
    let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n");
    let mtl = "newmtl white\nKd 0.5 0.5 0.5\nmap_Kd bad.png\n";
    let s = scene_with(
        d.path(),
        &toml,
        &[
            ("t.obj", TRI_OBJ),
            ("m.mtl", mtl),
            ("bad.png", "this is not a PNG"),
        ],
    );
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["bad.png", "texture"]);
}

#[test]
fn no_light() {
    let d = tempdir();
    let toml = format!("{CAMERA}[[mesh]]\nfile = \"t.obj\"\n");
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ), ("m.mtl", MTL)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "no light"]);
}

#[test]
fn nan_and_infinite_vertices() {
    for bad in ["nan", "inf", "-inf", "NaN"] {
        let d = tempdir();
        let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n");
        let obj = TRI_OBJ.replace("v 1 0 -1", &format!("v 1 {bad} -1"));
        let s = scene_with(d.path(), &toml, &[("t.obj", &obj), ("m.mtl", MTL)]);
        let e = fails(d.path(), &s, &[]);
        assert_mentions(&e, &["t.obj", "line 3", "NaN or infinite"]);
    }
}

#[test]
fn malformed_obj_face() {
    let d = tempdir();
    let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n");
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n";
    let s = scene_with(d.path(), &toml, &[("t.obj", obj)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["t.obj", "invalid OBJ"]);
}

#[test]
fn zero_resolution_in_scene_and_on_command_line() {
    let d = tempdir();
    let toml = format!("{}{LIGHT}", CAMERA.replace("[8, 8]", "[0, 8]"));
    let s = scene_with(d.path(), &toml, &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "resolution", "0×8"]);

    let d = tempdir();
    let s = scene_with(d.path(), &format!("{CAMERA}{LIGHT}"), &[]);
    let out = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(["render", "--resolution", "0x4", "-o"])
        .arg(d.path().join("out"))
        .arg(&s)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("resolution"), "{e}");
    assert!(!d.path().join("out.exr").exists());
}

#[test]
fn unknown_material_override() {
    let d = tempdir();
    let toml = format!(
        "{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n[materials.nosuch]\ntype = \"mirror\"\n"
    );
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ), ("m.mtl", MTL)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "nosuch", "white"]);
}

#[test]
fn output_directory_missing() {
    let d = tempdir();
    let s = scene_with(d.path(), &format!("{CAMERA}{LIGHT}"), &[]);
    let out = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(["render", "-o"])
        .arg(d.path().join("no/such/dir/out"))
        .arg(&s)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("out.exr") && e.contains("cannot write"), "{e}");
}

#[test]
fn output_directory_missing_is_refused_before_rendering() {
    let d = tempdir();
    let s = scene_with(d.path(), &format!("{CAMERA}{LIGHT}"), &[]);
    let out = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(["render", "--spp", "100000", "-o"])
        .arg(d.path().join("no/out"))
        .arg(&s)
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{e}");
    // Named, with the cause once, and no render (100000 spp would take minutes).
    assert!(e.contains("does not exist") && e.contains("no"), "{e}");
    assert_eq!(e.matches("does not exist").count(), 1, "{e}");
    assert!(!e.contains("sampler"), "it rendered first: {e}");
}

#[test]
fn a_failed_png_write_leaves_the_old_exr_in_place() {
    let d = tempdir();
    let s = scene_with(d.path(), &format!("{CAMERA}{LIGHT}"), &[]);
    std::fs::write(d.path().join("out.exr"), b"old").unwrap();
    std::fs::create_dir(d.path().join("out.png")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(["render", "--spp", "2", "-o"])
        .arg(d.path().join("out"))
        .arg(&s)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("out.png"));
    assert_eq!(std::fs::read(d.path().join("out.exr")).unwrap(), b"old");
    let tmp = std::fs::read_dir(d.path())
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".tmp")
        })
        .count();
    assert_eq!(tmp, 0);
}

#[test]
fn mtl_colour_with_two_numbers_is_a_located_error() {
    // tobj 4 panics on `Ke 17 12`; one number is a grey (the MTL specification).
    let d = tempdir();
    let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n");
    let mtl = "newmtl white\nKe 17 12\n";
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ), ("m.mtl", mtl)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["m.mtl", "line 2", "Ke 17 12", "1 or 3 numbers"]);
    let grey = "newmtl white\nKd 0.5\n";
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ), ("m.mtl", grey)]);
    let scene = aleph::scene::Scene::load(&s).unwrap();
    let m = &scene.materials[0];
    assert_eq!(m.name, "white");
    assert!(
        matches!(m.kd, aleph::material::ColorSource::Constant(c) if c == glam::Vec3::splat(0.5))
    );
}

#[test]
fn huge_coordinates_are_located_errors_not_panics() {
    let d = tempdir();
    let light = "[[light]]\ntype = \"quad\"\ncorner = [0, 1.9, 0]\nedge1 = [1e30, 0, 0]\n\
                 edge2 = [0, 0, 1e30]\nradiance = [1, 1, 1]\n";
    let s = scene_with(d.path(), &format!("{CAMERA}{light}"), &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "[[light]] #1", "beyond"]);
    let obj = "mtllib m.mtl\nv -3e38 0 -1\nv 3e38 0 -1\nv 0 0 3e38\nusemtl white\nf 1 2 3\n";
    let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n");
    let s = scene_with(d.path(), &toml, &[("t.obj", obj), ("m.mtl", MTL)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["t.obj", "beyond"]);
}

#[test]
fn arrays_have_exact_lengths() {
    let d = tempdir();
    let cam = CAMERA.replace("resolution = [8, 8]", "resolution = [32, 32, 99]");
    let s = scene_with(d.path(), &format!("{cam}{LIGHT}"), &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "line 5", "exactly 2"]);
    let toml = format!(
        "{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n[materials.white]\nreflectance = [0.5, 0.5, 0.5, 9]\n"
    );
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ), ("m.mtl", MTL)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "exactly 3"]);
}

#[test]
fn a_resolution_beyond_memory_is_refused_with_the_figures() {
    let d = tempdir();
    let s = scene_with(d.path(), &format!("{CAMERA}{LIGHT}"), &[]);
    let e = fails(d.path(), &s, &["--resolution", "65536x65536"]);
    assert_mentions(&e, &["scene.toml", "65536×65536", "GiB", "bytes per pixel"]);
}

/// Runs `aleph ARGS…`, expects exit 2, returns stderr.
fn aleph_fails(args: &[&std::ffi::OsStr]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(args)
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    e
}

#[test]
fn overflowing_emitters_and_scales_name_what_overflows() {
    let d = tempdir();
    let bright = LIGHT.replace("radiance = [1, 1, 1]", "radiance = [3e38, 1, 1]");
    let s = scene_with(d.path(), &format!("{CAMERA}{bright}"), &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "light#1", "overflows"]);
    let s = scene_with(
        d.path(),
        &format!("{CAMERA}[render]\nluminance_scale = 3e38\n{LIGHT}"),
        &[],
    );
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "render.luminance_scale"]);
    let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n");
    let mtl = "newmtl white\nKd 0.5 0.5 0.5\nKe 3e38 3e38 3e38\n";
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ), ("m.mtl", mtl)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "\"white\"", "emission"]);
}

#[test]
fn lights_whose_f32_power_overflows_or_underflows_still_light_the_scene() {
    let d = tempdir();
    // Power 1e9 × (1e15)² × π overflows f32; 1e-38 × (1e-5)² underflows it.
    for (edge, radiance) in [("1e15", "1e9"), ("1e-5", "1e-38")] {
        let light = format!(
            "[[light]]\ntype = \"quad\"\ncorner = [0, 1.9, 0]\nedge1 = [{edge}, 0, 0]\n\
             edge2 = [0, 0, {edge}]\nradiance = [{radiance}, {radiance}, {radiance}]\n"
        );
        let s = scene_with(d.path(), &format!("{CAMERA}{light}"), &[]);
        let scene = aleph::scene::Scene::load(&s).unwrap();
        assert_eq!(scene.lights.len(), 2, "edge {edge}");
    }
}

#[test]
fn a_small_scale_is_invertible() {
    let d = tempdir();
    let toml =
        format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\ntransform = {{ scale = 0.0001 }}\n");
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ), ("m.mtl", MTL)]);
    aleph::scene::Scene::load(&s).unwrap();
    let toml =
        format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\ntransform = {{ scale = 0.0 }}\n");
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ), ("m.mtl", MTL)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["[[mesh]] #1 transform", "invertible"]);
}

fn exr_with_white(path: &Path, rgb: f32, white: f32) {
    use exr::prelude::*;
    let attrs = LayerAttributes {
        white_luminance: Some(white),
        ..Default::default()
    };
    let layer = Layer::new(
        (4, 4),
        attrs,
        Encoding::UNCOMPRESSED,
        SpecificChannels::rgb(|_pos: Vec2<usize>| (rgb, rgb, rgb)),
    );
    Image::from_layer(layer).write().to_file(path).unwrap();
}

#[test]
fn tonemap_and_diff_name_the_file_and_the_bad_value() {
    let d = tempdir();
    let black = d.path().join("black.exr");
    exr_with_white(&black, 0.0, 100.0);
    let out = d.path().join("o.png");
    let e = aleph_fails(&["tonemap".as_ref(), black.as_os_str(), out.as_os_str()]);
    assert_mentions(&e, &["black.exr", "black"]);
    let nan = d.path().join("nan.exr");
    exr_with_white(&nan, 0.5, f32::NAN);
    let e = aleph_fails(&["tonemap".as_ref(), nan.as_os_str(), out.as_os_str()]);
    assert_mentions(&e, &["nan.exr", "whiteLuminance"]);
    assert!(!e.contains("--luminance-scale"), "{e}");
    assert!(!out.exists());
    let good = d.path().join("good.exr");
    exr_with_white(&good, 0.5, 100.0);
    let map = d.path().join("m.exr");
    let e = aleph_fails(&[
        "diff".as_ref(),
        good.as_os_str(),
        good.as_os_str(),
        "--map".as_ref(),
        map.as_os_str(),
    ]);
    assert_mentions(&e, &["m.exr", ".png"]);
    assert!(!map.exists());
}

#[test]
fn speedup_on_a_bad_scene_leaves_no_directory() {
    let d = tempdir();
    let light = "[[light]]\ntype = \"quad\"\ncorner = [0, 1.9, 0]\nedge1 = [1e30, 0, 0]\n\
                 edge2 = [0, 0, 1e30]\nradiance = [1, 1, 1]\n";
    let s = scene_with(d.path(), &format!("{CAMERA}{light}"), &[]);
    let out = d.path().join("sp");
    let e = aleph_fails(&[
        "speedup".as_ref(),
        s.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert_mentions(&e, &["scene.toml", "[[light]] #1"]);
    assert!(!out.exists(), "an empty output directory was left");
}

#[test]
fn one_failed_output_writes_none_of_the_others() {
    // render --aov: the ratio PNG's place is taken by a directory.
    let d = tempdir();
    let s = scene_with(d.path(), &format!("{CAMERA}{LIGHT}"), &[]);
    std::fs::create_dir(d.path().join("out.ratio.png")).unwrap();
    let e = aleph_fails(&[
        "render".as_ref(),
        s.as_os_str(),
        // Above the first pass's 8 spp, so that the sampler judges and has a ratio to write.
        "--spp".as_ref(),
        "16".as_ref(),
        "--steer-from".as_ref(),
        "0".as_ref(),
        "--aov".as_ref(),
        "-o".as_ref(),
        d.path().join("out").as_os_str(),
    ]);
    assert_mentions(&e, &["out.ratio.png"]);
    for f in ["out.exr", "out.png", "out.spp.png"] {
        assert!(!d.path().join(f).exists(), "{f} was written");
    }
    // tonemap: the contact sheet cannot be written, so the main output is not either.
    let exr = d.path().join("in.exr");
    exr_with_white(&exr, 0.5, 100.0);
    let main = d.path().join("main.png");
    let sheet = d.path().join("nodir/sheet.png");
    let e = aleph_fails(&[
        "tonemap".as_ref(),
        exr.as_os_str(),
        main.as_os_str(),
        "--contact-sheet".as_ref(),
        sheet.as_os_str(),
    ]);
    assert_mentions(&e, &["sheet.png"]);
    assert!(!main.exists());
}

/// Outputs land only where asked and never replace an input (issue 35, class 6): `-o .` and
/// `-o sub/` name no file, a merge may not overwrite its own parts, and a farm manifest's stem
/// may not lead out of the farm folder.
#[test]
fn outputs_never_land_elsewhere_or_replace_inputs() {
    let dir = crate::util::tempdir();
    let d = dir.path();
    std::fs::create_dir(d.join("sub")).unwrap();
    let scene = crate::util::repo("scenes/cornell-box/scene.toml");
    let scene = scene.to_str().unwrap();
    let small = ["--resolution", "4x3", "--sampler", "uniform", "--spp", "2"];
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_aleph"))
            .current_dir(d)
            .args(args)
            .output()
            .unwrap()
    };
    for o in [".", "sub/", "sub/."] {
        let mut args = vec!["render", scene, "-o", o];
        args.extend(small);
        let r = run(&args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "-o {o}: {err}");
        assert!(err.contains("needs a file name"), "-o {o}: {err}");
    }
    let listing = |p: &Path| std::fs::read_dir(p).unwrap().count();
    assert_eq!(listing(d), 1, "something was written beside sub/");
    assert_eq!(listing(&d.join("sub")), 0);
    // Two parts, then a merge whose output would be the first part's file.
    for i in ["1/2", "2/2"] {
        let mut args = vec!["render", scene, "-o", "p"];
        args.extend(small);
        args.extend(["--part", i]);
        assert!(run(&args).status.success());
    }
    let before = std::fs::read(d.join("p.part-1-of-2.exr")).unwrap();
    let r = run(&[
        "merge",
        "p.part-1-of-2.exr",
        "p.part-2-of-2.exr",
        "-o",
        "p.part-1-of-2",
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{err}");
    assert!(err.contains("would replace the input part"), "{err}");
    assert_eq!(std::fs::read(d.join("p.part-1-of-2.exr")).unwrap(), before);
    // A farm manifest edited to write outside its folder.
    let farm = d.join("farm");
    let mut args = vec!["farm", "slurm", scene, "-o", "farm", "--"];
    args.extend(small);
    assert!(run(&args).status.success());
    let manifest = farm.join("farm.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let edited = text.replace("stem = \"cornell-box\"", "stem = \"../../x\"");
    assert_ne!(text, edited);
    std::fs::write(&manifest, edited).unwrap();
    let r = run(&["farm", "task", "farm", "--index", "0"]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{err}");
    assert!(
        err.contains("farm.toml") && err.contains("inside the farm folder"),
        "{err}"
    );
    assert!(!d.join("x.exr").exists() && !d.parent().unwrap().join("x.exr").exists());
}

/// A black image is a valid render (issue 35, class 2): a camera facing away from every light
/// writes its EXR and a black PNG with one warning that names the scene, under every operator,
/// and black sample parts merge.
#[test]
fn a_black_render_is_written_with_a_warning() {
    let dir = crate::util::tempdir();
    let d = dir.path();
    for f in ["CornellBox-Original.obj", "CornellBox-Original.mtl"] {
        std::fs::copy(crate::util::repo("scenes/cornell-box").join(f), d.join(f)).unwrap();
    }
    let text = std::fs::read_to_string(crate::util::repo("scenes/cornell-box/scene.toml"))
        .unwrap()
        .replace(
            "look_at = [0.0, 0.989, 0.0]",
            "look_at = [0.0, 0.989, 10.0]",
        );
    assert!(text.contains("10.0]"));
    std::fs::write(d.join("scene.toml"), text).unwrap();
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_aleph"))
            .current_dir(d)
            .args(["render", "scene.toml", "--resolution", "8x6", "--spp", "4"])
            .args(args)
            .output()
            .unwrap()
    };
    for op in ["reinhard", "tr", "fpsg", "wrp", "ptyg", "exposure"] {
        let r = run(&["--tonemap", op, "-o", op]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{op}: {err}");
        assert_eq!(err.matches("the image is black").count(), 1, "{op}: {err}");
        assert!(err.contains("scene.toml"), "{err}");
        let png = image::open(d.join(format!("{op}.png"))).unwrap().to_rgb8();
        assert!(png.as_raw().iter().all(|&v| v == 0), "{op}: not black");
        assert!(d.join(format!("{op}.exr")).exists());
    }
    for i in ["1/2", "2/2"] {
        assert!(
            run(&["--sampler", "uniform", "--part", i, "-o", "p"])
                .status
                .success()
        );
    }
    let r = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .current_dir(d)
        .args(["merge", "p.part-1-of-2.exr", "p.part-2-of-2.exr", "-o", "m"])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(d.join("m.png").exists());
}

/// Options that would loop or allocate without limit are refused before any work, and huge
/// numbers are printed as numbers, not 300 digits (issue 35, classes 1 and 8, in part).
#[test]
fn thread_counts_and_time_budgets_have_limits() {
    let dir = crate::util::tempdir();
    let scene = crate::util::repo("scenes/cornell-box/scene.toml");
    for (args, expect) in [
        (vec!["--threads", "100000"], "--threads 100000: at most"),
        (
            vec!["--threads", "4294967296"],
            "--threads 4294967296: at most",
        ),
        (vec!["--time", "1e300"], "got 1e300"),
        (vec!["--time=-1"], "(--time) must be a positive"),
    ] {
        let t = std::time::Instant::now();
        let r = Command::new(env!("CARGO_BIN_EXE_aleph"))
            .current_dir(dir.path())
            .arg("render")
            .arg(&scene)
            .args(["--resolution", "4x3", "--spp", "2"])
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(expect) && err.len() < 400, "{args:?}: {err}");
        assert_eq!(err.matches("error").count(), 1, "{args:?}: {err}");
        assert!(
            t.elapsed().as_secs() < 10,
            "{args:?} took {:?}",
            t.elapsed()
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}

/// A viewer's pixels per degree or field of view far outside any display (`--ppd 1e6`,
/// `--fov 1e-30`) renders in bounded time and memory: the adaptation window is then millions
/// of images wide and the blur is the image's mean (issue 35, class 1: these aborted on a
/// 68 GB allocation or looped forever in the tone operators' adaptation blur).
#[test]
fn extreme_viewing_conditions_render_in_bounded_memory() {
    let dir = crate::util::tempdir();
    let scene = crate::util::repo("scenes/cornell-box/scene.toml");
    let uniform = ["--spp", "4", "--sampler", "uniform"];
    for args in [
        vec!["--ppd", "1e6", "--tonemap", "tr"],
        vec!["--fov", "1e-30", "--tonemap", "wrp"],
        vec!["--ppd", "1e30", "--sampler", "perceptual", "--spp", "160"],
    ] {
        let t = std::time::Instant::now();
        let perceptual = args.contains(&"perceptual");
        let r = Command::new(env!("CARGO_BIN_EXE_aleph"))
            .current_dir(dir.path())
            .arg("render")
            .arg(&scene)
            .args(["--resolution", "48x36"])
            .args(if perceptual { &[][..] } else { &uniform[..] })
            .args(&args)
            .args(["-o", "x"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{args:?}: {err}");
        assert!(
            t.elapsed().as_secs() < 20,
            "{args:?} took {:?}",
            t.elapsed()
        );
    }
    let exr = crate::util::repo("tests/data/Desk.exr");
    let r = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .current_dir(dir.path())
        .args([
            "tonemap",
            exr.to_str().unwrap(),
            "t.png",
            "--fov",
            "0.00001",
        ])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
}
