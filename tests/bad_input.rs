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
    assert_mentions(
        &e,
        &[
            "nothere.png",
            "texture",
            "m.mtl",
            "material \"white\", map_Kd",
        ],
    );
    // Options and no file: an error, not a texture silently left out (issue 35, class 9).
    for (stmt, arg) in [
        ("map_Kd", "-bm 1"),
        ("map_d", "-imfchan r"),
        ("bump", "-bm 2"),
    ] {
        let mtl = format!("newmtl white\nKd 0.5 0.5 0.5\n{stmt} {arg}\n");
        let s = scene_with(d.path(), &toml, &[("m.mtl", &mtl)]);
        let e = fails(d.path(), &s, &[]);
        assert_mentions(
            &e,
            &[
                "m.mtl",
                "\"white\"",
                "names no image file",
                &format!("{stmt} {arg}"),
            ],
        );
    }
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
    assert_mentions(
        &e,
        &["bad.png", "texture", "m.mtl", "material \"white\", map_Kd"],
    );
}

#[test]
fn no_light() {
    let d = tempdir();
    let toml = format!("{CAMERA}[[mesh]]\nfile = \"t.obj\"\n");
    let s = scene_with(d.path(), &toml, &[("t.obj", TRI_OBJ), ("m.mtl", MTL)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "no light"]);
    // The temporary directory's random name may itself hold "Ka" (CI drew `.tmpzNdNKa`).
    let message = e.replace(&d.path().display().to_string(), "<dir>");
    assert!(!message.contains("Ka"), "no ambient colour to name: {e}");
}

/// tinyobjloader's Cornell box writes its light's radiance as an ambient colour (`Ka 20 20
/// 20`), which aleph does not read as emission: the error names the material and both ways
/// to make it emit, and the scene file's way works.
#[test]
fn no_light_names_an_ambient_colour_above_one() {
    let d = tempdir();
    let toml = format!("{CAMERA}[[mesh]]\nfile = \"t.obj\"\n");
    let mtl = "newmtl white\nKa 0.2 0.2 0.2\nKd 0.5 0.5 0.5\nnewmtl lamp\nKa 20 18 16\nKd 1 1 1\n";
    let obj = format!("{TRI_OBJ}v -1 1 -1\nv 1 1 -1\nv 0 1 1\nusemtl lamp\nf 6 5 4\n");
    let s = scene_with(d.path(), &toml, &[("t.obj", &obj), ("m.mtl", mtl)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(
        &e,
        &[
            "scene.toml",
            "no light",
            "\"lamp\"",
            "m.mtl",
            "Ka 20 18 16",
            "Ke 20 18 16",
            "[materials.lamp]",
            "emission = [20, 18, 16]",
        ],
    );
    assert!(!e.contains("\"white\""), "Ka 0.2 is a reflectance: {e}");
    let fixed = format!("{toml}[materials.lamp]\nemission = [20, 18, 16]\n");
    let s = scene_with(d.path(), &fixed, &[("t.obj", &obj), ("m.mtl", mtl)]);
    let scene = aleph::scene::Scene::load(&s);
    assert!(scene.is_ok(), "{:?}", scene.err());
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
fn a_camera_without_a_view_direction_says_so() {
    // look_at equal to position once blamed camera.focus_distance, which nobody had set.
    let d = tempdir();
    let camera = CAMERA.replace("look_at = [0, 1, 0]", "look_at = [0, 1, 3]");
    let s = scene_with(d.path(), &format!("{camera}{LIGHT}"), &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(
        &e,
        &["scene.toml", "camera.look_at", "equals camera.position"],
    );
    assert!(!e.contains("focus_distance"), "{e}");
    // Parallel to up: the camera's own check names it.
    let camera = CAMERA.replace("look_at = [0, 1, 0]", "look_at = [0, 5, 3]");
    let s = scene_with(d.path(), &format!("{camera}{LIGHT}"), &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "parallel to up"]);
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
    assert_mentions(
        &e,
        &["--resolution", "65536×65536", "GiB", "bytes per pixel"],
    );
    // The same size from the scene file names the file and its key.
    let camera = CAMERA.replace("[8, 8]", "[65536, 65536]");
    let s = scene_with(d.path(), &format!("{camera}{LIGHT}"), &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["scene.toml", "camera.resolution 65536×65536", "GiB"]);
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
    // Finite texels whose luminance overflows f32 once scaled: the file is named.
    let huge = d.path().join("huge.exr");
    exr_with_white(&huge, 3e38, 100.0);
    let e = aleph_fails(&["tonemap".as_ref(), huge.as_os_str(), out.as_os_str()]);
    assert_mentions(&e, &["huge.exr"]);
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
        // Flags are named as the flags, not as the scene file's keys.
        (vec!["--max-depth", "0"], "(--max-depth) must be at least 1"),
        (
            vec!["--display-max=-1e308"],
            "(--display-max) must be a positive",
        ),
        (
            vec!["--display-ambient", "NaN"],
            "(--display-ambient) must be",
        ),
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
        assert!(!err.contains("scene.toml"), "{args:?}: {err}");
        assert_eq!(err.matches("error").count(), 1, "{args:?}: {err}");
        assert!(
            t.elapsed().as_secs() < 10,
            "{args:?} took {:?}",
            t.elapsed()
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}

/// Pixels per degree have a documented range, [1e-6, 1000] (issue 35, class 1): `--ppd 1e6`,
/// `--fov 1e-30` and `tonemap --fov 1e-5` aborted on a 68 GB allocation or looped in the
/// adaptation blur, and speedup's FLIP filters grew with ppd for hours; now they are refused
/// before any work, naming the flag. At the edge of the range, and with an adaptation window
/// millions of images wide, renders finish in bounded time and memory (the blur is the
/// image's mean).
#[test]
fn extreme_viewing_conditions_are_refused_or_bounded() {
    let dir = crate::util::tempdir();
    let scene = crate::util::repo("scenes/cornell-box/scene.toml");
    let exr = crate::util::repo("tests/data/Desk.exr");
    let run = |args: &[&str]| {
        let t = std::time::Instant::now();
        let r = Command::new(env!("CARGO_BIN_EXE_aleph"))
            .current_dir(dir.path())
            .args(args)
            .output()
            .unwrap();
        assert!(
            t.elapsed().as_secs() < 20,
            "{args:?} took {:?}",
            t.elapsed()
        );
        (
            r.status.code(),
            String::from_utf8_lossy(&r.stderr).to_string(),
        )
    };
    let s = scene.to_str().unwrap();
    let render = ["render", s, "--resolution", "48x36", "-o", "x"];
    let uniform = ["--spp", "4", "--sampler", "uniform"];
    for (extra, flag) in [
        (&["--ppd", "1e6", "--tonemap", "tr"][..], "(--ppd)"),
        (&["--ppd", "1e-308"][..], "(--ppd)"),
        (&["--fov", "1e-30", "--tonemap", "wrp"][..], "(--fov)"),
    ] {
        let (code, err) = run(&[&render[..], &uniform[..], extra].concat());
        assert_eq!(code, Some(2), "{extra:?}: {err}");
        assert_mentions(&err, &[flag, "pixels per degree", "[1e-6, 1000]"]);
    }
    let (code, err) = run(&[
        "tonemap",
        exr.to_str().unwrap(),
        "t.png",
        "--fov",
        "0.00001",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert_mentions(&err, &["--fov", "pixels per degree"]);
    for extra in [
        &["--ppd", "1000", "--tonemap", "tr", "--spp", "4"][..],
        &[
            "--sampler",
            "perceptual",
            "--spp",
            "160",
            "--adaptation-window",
            "1e30",
        ][..],
    ] {
        let (code, err) = run(&[&render[..], extra].concat());
        assert_eq!(code, Some(0), "{extra:?}: {err}");
    }
}

/// A `w × h` EXR whose RGB at (x, y) is `f(x, y)`.
fn exr_from(path: &Path, w: usize, h: usize, f: impl Fn(usize, usize) -> f32 + Sync) {
    use exr::prelude::*;
    let layer = Layer::new(
        (w, h),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        SpecificChannels::rgb(|p: Vec2<usize>| {
            let v = f(p.x(), p.y());
            (v, v, v)
        }),
    );
    Image::from_layer(layer).write().to_file(path).unwrap();
}

/// Environment maps near f32::MAX were called "black everywhere" (their sampling
/// distribution's row sums overflowed); negative texels were clamped without a word.
#[test]
fn environment_maps_say_what_is_wrong_with_them() {
    let d = tempdir();
    let toml = |strength: f32| {
        format!(
            "[camera]\nposition = [0, 1, 3]\nlook_at = [0, 0, 0]\nvfov_deg = 40.0\nresolution = [8, 6]\n\
             [render]\nspp = 2\n[[mesh]]\nfile = \"t.obj\"\n[[light]]\ntype = \"environment\"\n\
             file = \"env.exr\"\nstrength = {strength:?}\n"
        )
    };
    let env = d.path().join("env.exr");
    exr_from(&env, 8, 4, |_, _| 1e38);
    let s = scene_with(d.path(), &toml(1.0), &[("t.obj", TRI_OBJ), ("m.mtl", MTL)]);
    let e = fails(d.path(), &s, &[]);
    assert!(!e.contains("black"), "{e}");
    assert_mentions(&e, &["scene.toml", "[[light]] #1", "overflows"]);
    exr_from(&env, 8, 4, |_, _| 3e38);
    let s = scene_with(d.path(), &toml(10.0), &[]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["env.exr", "texel (0, 0)", "strength 10", "overflows"]);
    // One negative texel: clamped, rendered, and said.
    exr_from(&env, 8, 4, |x, y| if (x, y) == (3, 1) { -2.0 } else { 0.5 });
    let s = scene_with(d.path(), &toml(1.0), &[]);
    let out = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(["render".as_ref(), s.as_os_str(), "-o".as_ref()])
        .arg(d.path().join("ok"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{e}");
    assert_mentions(&e, &["env.exr", "3 negative texel values clamped"]);
}

/// Object selections that load nothing were an empty mesh without a word (issue 35, class 9).
#[test]
fn object_selections_that_load_nothing_are_refused() {
    let d = tempdir();
    let obj =
        "mtllib m.mtl\nv -1 0 -1\nv 1 0 -1\nv 0 0 1\no a\nusemtl white\nf 1 2 3\no b\nf 1 3 2\n";
    for (select, expect) in [
        ("objects = []", "objects = [] selects no object"),
        (
            "exclude_objects = [\"a\", \"b\"]",
            "leave none of the file's objects [\"a\", \"b\"]",
        ),
        (
            "objects = [\"a\"]\nexclude_objects = [\"a\"]",
            "\"a\" is in both objects and exclude_objects",
        ),
    ] {
        let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n{select}\n");
        let s = scene_with(d.path(), &toml, &[("t.obj", obj), ("m.mtl", MTL)]);
        let e = fails(d.path(), &s, &[]);
        assert_mentions(&e, &["scene.toml", "[[mesh]] #1", "t.obj", expect]);
    }
}

/// A PNG whose header says 0×0 (well-formed otherwise, CRCs correct) is refused naming the
/// file, as a texture, an environment map and an image to tone map (issue 35, class 9).
#[test]
fn a_png_of_zero_size_is_refused_everywhere() {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 == 1 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    fn chunk(kind: &[u8], data: &[u8]) -> Vec<u8> {
        let mut v = (data.len() as u32).to_be_bytes().to_vec();
        let body = [kind, data].concat();
        v.extend(&body);
        v.extend(crc32(&body).to_be_bytes());
        v
    }
    let ihdr = [0, 0, 0, 0, 0, 0, 0, 0, 8, 2, 0, 0, 0];
    // zlib of nothing: header 78 9c, an empty final stored block, adler32 of nothing = 1.
    let idat = [0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01];
    let png = [
        &b"\x89PNG\r\n\x1a\n"[..],
        &chunk(b"IHDR", &ihdr),
        &chunk(b"IDAT", &idat),
        &chunk(b"IEND", &[]),
    ]
    .concat();
    let d = tempdir();
    std::fs::write(d.path().join("zero.png"), &png).unwrap();
    let obj = "mtllib m.mtl\nv -1 0 -1\nv 1 0 -1\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl white\nf 1/1 2/2 3/3\n";
    let mtl = "newmtl white\nKd 0.5 0.5 0.5\nmap_Kd zero.png\n";
    let toml = format!("{CAMERA}{LIGHT}[[mesh]]\nfile = \"t.obj\"\n");
    let s = scene_with(d.path(), &toml, &[("t.obj", obj), ("m.mtl", mtl)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["zero.png", "m.mtl", "map_Kd"]);
    let env = format!(
        "{CAMERA}[[mesh]]\nfile = \"t.obj\"\n[[light]]\ntype = \"environment\"\nfile = \"zero.png\"\n"
    );
    let s = scene_with(d.path(), &env, &[("m.mtl", MTL)]);
    let e = fails(d.path(), &s, &[]);
    assert_mentions(&e, &["zero.png", "[[light]] #1"]);
    let out = d.path().join("o.png");
    let e = aleph_fails(&[
        "tonemap".as_ref(),
        d.path().join("zero.png").as_os_str(),
        out.as_os_str(),
    ]);
    assert_mentions(&e, &["zero.png"]);
    assert!(!out.exists());
}
