//! `aleph diff`: exit status 0 (no visible difference), 1 (visible), 2 (error), like pdiff.

use crate::util::*;
use aleph::output::{AtomicOutputs, write_exr};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Writes a grey linear EXR of luminance `f(x, y)` (R = G = B).
fn grey_exr(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> f32) {
    let rgb: Vec<f32> = (0..w * h).flat_map(|i| [f(i % w, i / w); 3]).collect();
    let mut out = AtomicOutputs::new();
    out.stage(path, |wr| write_exr(wr, path, w, h, &rgb, &[], &[]))
        .unwrap();
    out.commit().unwrap();
}

fn diff(args: &[&Path], flags: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aleph"))
        .arg("diff")
        .args(args)
        .args(flags)
        .output()
        .unwrap()
}

fn patch_pair(dir: &Path, step: f32) -> (PathBuf, PathBuf) {
    let (a, b) = (dir.join("ref.exr"), dir.join(format!("test{step}.exr")));
    grey_exr(&a, 96, 96, |_, _| 1.0);
    grey_exr(&b, 96, 96, |x, y| {
        if (24..72).contains(&x) && (24..72).contains(&y) {
            1.0 + step
        } else {
            1.0
        }
    });
    (a, b)
}

#[test]
fn identical_images_pass_with_exit_0() {
    let d = tempdir();
    let (a, _) = patch_pair(d.path(), 0.0);
    let o = diff(&[&a, &a], &[]);
    assert_eq!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("PASS: 0 of 9216"));
}

#[test]
fn a_20_percent_patch_fails_and_a_2_percent_patch_passes() {
    // At 100 cd/m² (value 1 × the default scale of 100) the TVI threshold is 5.56 cd/m²: a
    // +20 cd/m² patch of 48×48 = 2304 pixels is visible, +2 cd/m² is not.
    let d = tempdir();
    let (a, b) = patch_pair(d.path(), 0.2);
    let o = diff(
        &[&a, &b],
        &[
            "--json",
            "--map",
            d.path().join("map.png").to_str().unwrap(),
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["visible_pixels"], 2304);
    assert_eq!(j["different"], true);
    assert_eq!(j["luminance_scale_cd_m2"], 100.0);
    let map = image::open(d.path().join("map.png")).unwrap().to_rgb8();
    assert_eq!(map.dimensions(), (96, 96));
    // Inside the patch the map is red, outside grey.
    let (inside, outside) = (map.get_pixel(48, 48), map.get_pixel(5, 5));
    assert!(inside[0] > inside[1] + 50, "{inside:?}");
    assert_eq!(outside[0], outside[1]);

    let (a, b) = patch_pair(d.path(), 0.02);
    let o = diff(&[&a, &b], &[]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    // In the Weber region the threshold is 5.56 % of L_a: at 1000 cd/m² a 6 % step (60 cd/m²)
    // exceeds ΔL = 55.6 cd/m².
    let (a, b) = patch_pair(d.path(), 0.06);
    assert_eq!(
        diff(&[&a, &b], &["--luminance-scale", "1000"])
            .status
            .code(),
        Some(1)
    );
}

#[test]
fn errors_exit_2_and_name_the_file() {
    let d = tempdir();
    let (a, _) = patch_pair(d.path(), 0.0);
    let small = d.path().join("small.exr");
    grey_exr(&small, 10, 10, |_, _| 1.0);
    let o = diff(&[&a, &small], &[]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("small.exr") && e.contains("same size"), "{e}");

    let o = diff(&[&a, &d.path().join("nope.png")], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nope.png"));

    let txt = d.path().join("x.txt");
    std::fs::write(&txt, "hello").unwrap();
    let o = diff(&[&a, &txt], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unsupported image format"));

    let nan = d.path().join("nan.exr");
    grey_exr(
        &nan,
        96,
        96,
        |x, y| if (x, y) == (3, 4) { f32::NAN } else { 1.0 },
    );
    let o = diff(&[&a, &nan], &[]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("nan.exr") && e.contains("(3, 4)"), "{e}");

    for bad in [
        ["--fov", "0"],
        ["--fov", "200"],
        ["--luminance-scale", "-1"],
    ] {
        let o = diff(&[&a, &a], &bad);
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
    }
}

#[test]
fn real_hdr_photographs_load_with_counted_clamping() {
    // Desk.exr holds negative values (a photograph's noise floor): clamped to 0 and counted.
    let desk = repo("tests/data/Desk.exr");
    let o = diff(&[&desk, &desk], &["--json"]);
    assert_eq!(o.status.code(), Some(0));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(j["clamped_negative_values"].as_u64().unwrap() > 0);
    let hdr = repo("tests/data/venice_sunset_1k.hdr");
    assert_eq!(diff(&[&hdr, &hdr], &[]).status.code(), Some(0));
}
