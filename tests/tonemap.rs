//! `aleph tonemap` on real HDR images, and `aleph render --tonemap`.

use crate::util::*;
use aleph::output::{AtomicOutputs, write_exr};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn aleph(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(args)
        .output()
        .unwrap()
}

/// Renders `scene` uniformly (`--resolution`, `--spp`, `--seed` as given) to `stem`; returns
/// the EXR's path.
fn render_uniform(scene: &Path, stem: &Path, resolution: &str, spp: &str, seed: &str) -> PathBuf {
    let o = aleph(&[
        "render",
        scene.to_str().unwrap(),
        "--resolution",
        resolution,
        "--sampler",
        "uniform",
        "--spp",
        spp,
        "--seed",
        seed,
        "-o",
        stem.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    stem.with_extension("exr")
}

fn read_display_exr(path: &Path) -> Vec<f32> {
    aleph::imageio::read_image(path).unwrap().rgb
}

#[test]
fn every_operator_on_real_hdr_images_is_finite_in_range_and_not_flat() {
    let d = tempdir();
    for input in ["tests/data/Desk.exr", "tests/data/venice_sunset_1k.hdr"] {
        let input = repo(input);
        for op in ["tr", "fpsg", "wrp", "ptyg", "exposure", "reinhard"] {
            let out = d.path().join(format!("{op}.exr"));
            let o = aleph(&[
                "tonemap",
                input.to_str().unwrap(),
                out.to_str().unwrap(),
                "--operator",
                op,
            ]);
            assert!(
                o.status.success(),
                "{op}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            let v = read_display_exr(&out);
            assert!(
                v.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)),
                "{op} out of range"
            );
            let black = v.iter().filter(|&&x| x <= 0.0).count() as f64 / v.len() as f64;
            let white = v.iter().filter(|&&x| x >= 1.0).count() as f64 / v.len() as f64;
            assert!(
                black < 0.5 && white < 0.5,
                "{op} on {input:?}: {black} black, {white} white"
            );
            let mean = v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
            assert!(mean > 0.02 && mean < 0.9, "{op}: mean {mean}");
        }
    }
}

#[test]
fn png_output_and_contact_sheet() {
    let d = tempdir();
    let png = d.path().join("desk.png");
    let sheet = d.path().join("sheet.png");
    let o = aleph(&[
        "tonemap",
        repo("tests/data/Desk.exr").to_str().unwrap(),
        png.to_str().unwrap(),
        "--operator",
        "tr",
        "--adaptation",
        "global",
        "--contact-sheet",
        sheet.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("negative values clamped"), "{stdout}");
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (644, 874));
    // 3 × 2 tiles of 322×437 (644 / 2 = 322 after halving) plus label bars.
    let sheet = image::open(&sheet).unwrap();
    assert_eq!(sheet.width(), 3 * 322);
    assert_eq!(sheet.height(), 2 * (437 + 28));
}

#[test]
fn bad_input_is_a_clear_error_with_nothing_written() {
    let d = tempdir();
    let out = d.path().join("out.png");
    let check = |args: &[&str], words: &[&str]| {
        let o = aleph(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let e = String::from_utf8_lossy(&o.stderr);
        for w in words {
            assert!(e.contains(w), "{args:?}: {e}");
        }
        assert!(!out.exists());
    };
    let o = out.to_str().unwrap();
    check(&["tonemap", "nope.exr", o], &["nope.exr", "not found"]);
    let txt = d.path().join("a.tiff");
    std::fs::write(&txt, "x").unwrap();
    check(
        &["tonemap", txt.to_str().unwrap(), o],
        &["a.tiff", "unsupported"],
    );
    // All-zero and NaN images.
    let write = |name: &str, v: f32| {
        let p = d.path().join(name);
        let rgb = vec![v; 3 * 16];
        let mut w = AtomicOutputs::new();
        w.stage(&p, |wr| write_exr(wr, &p, 4, 4, &rgb, &[], &[]))
            .unwrap();
        w.commit().unwrap();
        p
    };
    let zero = write("zero.exr", 0.0);
    check(
        &["tonemap", zero.to_str().unwrap(), o],
        &["zero.exr", "every pixel is black"],
    );
    let nan = write("nan.exr", f32::NAN);
    check(
        &["tonemap", nan.to_str().unwrap(), o],
        &["nan.exr", "not finite"],
    );
    let desk = repo("tests/data/Desk.exr");
    check(
        &[
            "tonemap",
            desk.to_str().unwrap(),
            d.path().join("x.jpg").to_str().unwrap(),
        ],
        &["x.jpg", ".png or .exr"],
    );
    check(
        &["tonemap", desk.to_str().unwrap(), o, "--display-max", "-5"],
        &["--display-max", "got -5"],
    );
    check(&["tonemap", desk.to_str().unwrap()], &["nothing to write"]);
}

#[test]
fn render_applies_the_tone_operator_to_the_png_only() {
    let d = tempdir();
    let stem = d.path().join("cb");
    let o = aleph(&[
        "render",
        "--spp",
        "4",
        "--resolution",
        "32x32",
        "--tonemap",
        "reinhard",
        "-o",
        stem.to_str().unwrap(),
        repo("scenes/cornell-box/scene.toml").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("tone operator reinhard"));
    // The EXR is still linear radiance: its light pixels hold the emitted radiance (17, 12, 4),
    // far above display range.
    let exr = aleph::imageio::read_image(&d.path().join("cb.exr")).unwrap();
    assert!(exr.rgb.iter().cloned().fold(0.0, f32::max) > 10.0);
    let png = image::open(d.path().join("cb.png")).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (32, 32));
}

/// The render's EXR carries its luminance scale (OpenEXR's `whiteLuminance`), so `aleph
/// tonemap` with the render's operator gives the render's PNG byte for byte; and
/// `--curve-from REF --grade EV` maps by REF's curve with the input scaled by 2^EV. The exposure
/// operator is linear below white, so both are checked against ratios of the inputs: under
/// one frozen curve, display(a) / display(r) = a / r per pixel and channel, and a grade of −2
/// stops is exactly a quarter of the ungraded display.
#[test]
fn tonemap_reproduces_the_render_and_grades_under_a_frozen_curve() {
    let d = tempdir();
    let scene = repo("scenes/cornell-box/scene.toml");
    let render =
        |stem: &str, seed: &str| render_uniform(&scene, &d.path().join(stem), "24x24", "8", seed);
    let (a, r) = (render("a", "1"), render("r", "2"));
    let p = |name: &str| d.path().join(name);
    let tm = |args: &[&str]| {
        let o = aleph(&[&["tonemap"], args].concat());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).to_string()
    };
    let (a_s, r_s) = (a.to_str().unwrap(), r.to_str().unwrap());
    let out = tm(&[a_s, p("t.png").to_str().unwrap(), "--operator", "reinhard"]);
    assert!(out.contains("683 cd/m² per unit"), "{out}");
    let bytes = |f: &str| image::open(p(f)).unwrap().to_rgb8().into_raw();
    assert_eq!(
        bytes("t.png"),
        bytes("a.png"),
        "tonemap differs from the render's PNG"
    );

    let exposure = |input: &str, out: &str, extra: &[&str]| {
        tm(&[
            &[input, p(out).to_str().unwrap(), "--operator", "exposure"],
            extra,
        ]
        .concat());
        read_display_exr(&p(out))
    };
    let dr = exposure(r_s, "dr.exr", &[]);
    let da = exposure(a_s, "da.exr", &["--curve-from", r_s]);
    let dg = exposure(a_s, "dg.exr", &["--curve-from", r_s, "--grade", "-2"]);
    let (ra, rr) = (read_display_exr(&a), read_display_exr(&r));
    let mut compared = 0;
    for i in 0..ra.len() {
        if dr[i] > 1e-3 && dr[i] < 0.9 && da[i] < 0.9 && ra[i] > 0.0 {
            let want = rr[i] as f64 / ra[i] as f64;
            let got = dr[i] as f64 / da[i] as f64;
            assert!(
                (got / want - 1.0).abs() < 1e-4,
                "pixel {i}: {got} against {want}"
            );
            assert!(
                (dg[i] as f64 / da[i] as f64 - 0.25).abs() < 1e-5,
                "pixel {i}: graded"
            );
            compared += 1;
        }
    }
    assert!(
        compared > ra.len() / 2,
        "only {compared} values below white"
    );
}

#[test]
fn bad_curves_and_grades_are_refused() {
    let d = tempdir();
    let out = d.path().join("out.png");
    let desk = repo("tests/data/Desk.exr");
    let venice = repo("tests/data/venice_sunset_1k.hdr");
    let (desk, o) = (desk.to_str().unwrap(), out.to_str().unwrap());
    for (args, words) in [
        (vec!["--grade", "NaN"], vec!["--grade NaN", "-20 to 20"]),
        (vec!["--grade", "21"], vec!["--grade 21"]),
        (
            vec!["--curve-from", venice.to_str().unwrap()],
            vec!["venice_sunset_1k.hdr", "--curve-from image is", "Desk.exr"],
        ),
        (
            vec!["--curve-from", "nope.exr"],
            vec!["nope.exr", "not found"],
        ),
    ] {
        let r = aleph(&[&["tonemap", desk, o], &args[..]].concat());
        assert_eq!(r.status.code(), Some(2), "{args:?}");
        let e = String::from_utf8_lossy(&r.stderr);
        for w in words {
            assert!(e.contains(w), "{args:?}: {e}");
        }
        assert!(!out.exists());
    }
}

/// The largest of `lum` with each pixel counted as at most twice its brightest 8-neighbour:
/// the white before `perception::tmo::reinhard02::WHITE_RANK`, to show the renders below carry
/// the noise it moved with.
fn brightest_capped(lum: &[f32], w: usize) -> f32 {
    let h = lum.len() / w;
    let at = |x: usize, y: usize| lum[y * w + x];
    let mut m = 0f32;
    for y in 0..h {
        for x in 0..w {
            let mut near = 0f32;
            for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in x.saturating_sub(1)..(x + 2).min(w) {
                    if (nx, ny) != (x, y) {
                        near = near.max(at(nx, ny));
                    }
                }
            }
            m = m.max(at(x, y).min(2.0 * near));
        }
    }
    m
}

#[test]
fn reinhards_white_holds_still_across_renders_of_a_glint() {
    // The Mori knob under the sunset map: the sun's glint on the glossy coat is the brightest
    // thing in view, a few noisy pixels. Four uniform renders of 32 spp, seeds 0-3.
    let d = tempdir();
    let scene = repo("scenes/mori-knob/sunset.toml");
    let (mut whites, mut brightest) = (Vec::new(), Vec::new());
    for seed in 0..4 {
        let stem = d.path().join(format!("s{seed}"));
        let exr = render_uniform(&scene, &stem, "128x96", "32", &seed.to_string());
        let img = aleph::imageio::read_image(&exr).unwrap();
        let lum: Vec<f32> = img
            .rgb
            .chunks_exact(3)
            .map(|p| perception::photometry::luminance(p[0], p[1], p[2]))
            .collect();
        whites.push(perception::tmo::reinhard02::white_luminance(
            &lum, img.width,
        ));
        brightest.push(brightest_capped(&lum, img.width));
    }
    let spread = |v: &[f32]| {
        let (lo, hi) = v
            .iter()
            .fold((f32::MAX, 0f32), |(a, b), &x| (a.min(x), b.max(x)));
        hi / lo
    };
    assert!(
        spread(&brightest) > 1.3,
        "the glint's brightest pixel barely moves ({brightest:?}): the test shows nothing"
    );
    // Measured when written: 1.5 % (the brightest capped pixel: 1.98×, 0.227-0.450 against
    // whites of 0.215-0.218).
    assert!(
        spread(&whites) < 1.05,
        "Reinhard's white moves from render to render: {whites:?}"
    );
}
