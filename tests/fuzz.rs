//! A deterministic mutation fuzzer over everything aleph reads: scene TOML, OBJ, MTL, EXR and
//! HDR files, mutated from real seeds and pushed through the loaders (and, when a scene loads, a
//! 1-spp render). Every case must end in `Ok` or in an error that names the mutated file: no
//! panic (in aleph or in a dependency), no NaN in a render, nothing written.
//!
//! The suite runs a fixed corpus in well under a minute. Longer runs:
//! `ALEPH_FUZZ_CASES=20000 ALEPH_FUZZ_SEED=7 cargo test --release --test tests fuzz -- --nocapture`
//! (cases per file kind; any seed). A failing case is written to a temporary directory whose
//! path the failure prints.

use crate::util::*;
use aleph::rng::Rng;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};

/// Values that break parsers and numerics.
const NASTY: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e38",
    "3e38",
    "-3e38",
    "1e-45",
    "0",
    "-0",
    "-1",
    "1e30",
    "65536",
    "4294967296",
    "-9223372036854775809",
    "\"\"",
    "[]",
    "[1]",
    "[1, 2]",
    "[1,2,3,4]",
    "{}",
    "#",
    "\u{0}",
    "é",
    "\\",
    "1 2",
    "999999999999999999999",
];

fn cases() -> usize {
    std::env::var("ALEPH_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(150)
}

fn seed() -> u64 {
    std::env::var("ALEPH_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

/// One random mutation of a text: replace a token, delete or duplicate a line, truncate, or
/// flip a byte.
fn mutate_text(text: &str, rng: &mut Rng) -> Vec<u8> {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let pick = |rng: &mut Rng, n: usize| (rng.next_u32() as usize) % n.max(1);
    for _ in 0..1 + pick(rng, 3) {
        if lines.is_empty() {
            break;
        }
        let li = pick(rng, lines.len());
        match pick(rng, 6) {
            0 | 1 => {
                // Replace one whitespace- or comma-separated token by a nasty value.
                let toks: Vec<&str> = lines[li]
                    .split(|c: char| c.is_whitespace() || c == ',')
                    .filter(|t| !t.is_empty())
                    .collect();
                if !toks.is_empty() {
                    let t = toks[pick(rng, toks.len())].to_string();
                    let v = NASTY[pick(rng, NASTY.len())];
                    lines[li] = lines[li].replacen(&t, v, 1);
                }
            }
            2 => {
                lines.remove(li);
            }
            3 => {
                let l = lines[li].clone();
                lines.insert(li, l);
            }
            4 => {
                let cut = pick(rng, lines[li].len() + 1);
                lines[li] = lines[li].chars().take(cut).collect();
            }
            _ => {
                // Drop a number's sign or digits: "0.5" → "05", "-1" → "1".
                lines[li] = lines[li].replacen('.', "", 1).replacen('-', "", 1);
            }
        }
    }
    (lines.join("\n") + "\n").into_bytes()
}

/// One random mutation of binary data: flips, overwrites with extreme bytes, or truncation,
/// biased to the header (the first 256 bytes) where parsers decide things.
fn mutate_bytes(data: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut v = data.to_vec();
    let pick = |rng: &mut Rng, n: usize| (rng.next_u32() as usize) % n.max(1);
    for _ in 0..1 + pick(rng, 4) {
        let span = if rng.uniform() < 0.7 {
            v.len().min(256)
        } else {
            v.len()
        };
        if span == 0 {
            break;
        }
        let i = pick(rng, span);
        match pick(rng, 4) {
            0 => v[i] ^= 1 << pick(rng, 8),
            1 => v[i] = [0x00, 0xFF, 0x7F, 0x80][pick(rng, 4)],
            2 => {
                let bytes = [0xFF, 0xFF, 0xFF, 0x7F];
                for (k, b) in bytes.iter().enumerate() {
                    if i + k < v.len() {
                        v[i + k] = *b;
                    }
                }
            }
            _ => v.truncate(i.max(1)),
        }
    }
    v
}

/// Runs `f`, turning a panic into `Err("panic: …")`.
fn guarded<T>(f: impl FnOnce() -> Result<T, String>) -> Result<T, String> {
    std::panic::catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|e| {
        let msg = e
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| e.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(format!("panic: {msg}"))
    })
}

/// Loads the scene at `path` and, if it loads, renders 1 spp at no more than 16×16 with the
/// perceptual sampler's full machinery skipped (a uniform pass); checks the image is finite.
fn load_and_render(path: &Path) -> Result<(), String> {
    let mut desc = aleph::scene::SceneDescription::read(path).map_err(|e| e.to_string())?;
    let [w, h] = desc.camera.resolution;
    desc.camera.resolution = [w.clamp(1, 16), h.clamp(1, 16)];
    desc.render.max_depth = desc.render.max_depth.map(|d| d.min(8));
    let scene = aleph::scene::Scene::load_description(desc).map_err(|e| e.to_string())?;
    let (film, _) =
        aleph::render::render_uniform(&scene, aleph::integrator::Strategy::Mis, 1, &|_| {});
    if film.mean_rgb().iter().any(|v| !v.is_finite()) {
        return Err("panic-like: a non-finite pixel".into());
    }
    Ok(())
}

/// Checks one case's outcome: no panic, and an error names one of `files` (the mutated file,
/// or for an OBJ or MTL the scene whose consequence it reports, such as "no light"). On failure,
/// saves the case.
fn check(
    outcome: Result<(), String>,
    files: &[&str],
    dir: &Path,
    case: usize,
    failures: &mut Vec<String>,
) {
    let file = files[0];
    let bad = match &outcome {
        Ok(()) => None,
        Err(e) if e.starts_with("panic") => Some(e.clone()),
        Err(e) if !files.iter().any(|f| e.contains(f)) => {
            Some(format!("error names none of {files:?}: {e}"))
        }
        Err(_) => None,
    };
    if let Some(why) = bad {
        let keep = std::env::temp_dir().join(format!("aleph-fuzz-{file}-{case}"));
        let _ = std::fs::create_dir_all(&keep);
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let _ = std::fs::copy(e.path(), keep.join(e.file_name()));
        }
        failures.push(format!(
            "{file} case {case} (kept in {}): {why}",
            keep.display()
        ));
    }
}

/// The files of the bundled Cornell box, with a small resolution and an animation table so that
/// the keyframe paths are fuzzed too.
fn cornell_files() -> Vec<(String, Vec<u8>)> {
    let toml = std::fs::read_to_string(repo("scenes/cornell-box/scene.toml"))
        .unwrap()
        .replace("resolution = [512, 512]", "resolution = [8, 8]")
        + "\n[animation]\nfps = 24.0\nframes = [0, 2]\n\n[[mesh]]\nfile = \"CornellBox-Original.obj\"\n\
           objects = [\"shortBox\"]\n[[mesh.keys]]\ntime = 0.0\n[[mesh.keys]]\ntime = 1.0\n\
           translate = [0.1, 0.0, 0.0]\nrotate_deg = [0, 30, 0]\n";
    vec![
        ("scene.toml".into(), toml.into_bytes()),
        (
            "CornellBox-Original.obj".into(),
            std::fs::read(repo("scenes/cornell-box/CornellBox-Original.obj")).unwrap(),
        ),
        (
            "CornellBox-Original.mtl".into(),
            std::fs::read(repo("scenes/cornell-box/CornellBox-Original.mtl")).unwrap(),
        ),
    ]
}

fn write_all(dir: &Path, files: &[(String, Vec<u8>)]) {
    for (name, data) in files {
        std::fs::write(dir.join(name), data).unwrap();
    }
}

fn no_outputs(dir: &Path, expected: usize) {
    let n = std::fs::read_dir(dir).unwrap().count();
    assert_eq!(n, expected, "something was written into {}", dir.display());
}

#[test]
fn fuzz_scene_obj_and_mtl_loaders() {
    let base = cornell_files();
    // The unmutated seed loads and renders.
    let d = tempdir();
    write_all(d.path(), &base);
    load_and_render(&d.path().join("scene.toml")).unwrap();
    let mut failures = Vec::new();
    let mut rng = Rng::new(seed(), 0x5CE4E);
    for case in 0..cases() {
        for (k, (name, data)) in base.iter().enumerate() {
            let mut files = base.clone();
            files[k].1 = mutate_text(&String::from_utf8_lossy(data), &mut rng);
            let d = tempdir();
            write_all(d.path(), &files);
            let outcome = guarded(|| load_and_render(&d.path().join("scene.toml")));
            check(
                outcome,
                &[name, "scene.toml"],
                d.path(),
                case,
                &mut failures,
            );
            no_outputs(d.path(), files.len());
        }
    }
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn fuzz_image_readers() {
    let seeds: Vec<(&str, PathBuf)> = vec![
        ("x.exr", repo("tests/data/cornell_mitsuba_32.exr")),
        ("x.hdr", repo("tests/data/venice_sunset_1k.hdr")),
    ];
    let mut failures = Vec::new();
    let mut rng = Rng::new(seed(), 0x1A6E);
    for (name, path) in &seeds {
        let data = std::fs::read(path).unwrap();
        // Only the first part of the large HDR matters to its parser; keep cases fast.
        let data = if name.ends_with(".hdr") {
            let keep = data.len().min(64 * 1024);
            data[..keep].to_vec()
        } else {
            data
        };
        for case in 0..cases() {
            let d = tempdir();
            let p = d.path().join(name);
            std::fs::write(&p, mutate_bytes(&data, &mut rng)).unwrap();
            let outcome = guarded(|| {
                let img = aleph::imageio::read_image(&p).map_err(|e| e.to_string())?;
                img.luminance_scale(&p, None).map_err(|e| e.to_string())?;
                Ok(())
            });
            check(outcome, &[name], d.path(), case, &mut failures);
            no_outputs(d.path(), 1);
        }
    }
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
