//! Golden images: every bundled scene, rendered by the CLI with each sampling rule, as a
//! sequence, as sample parts merged and as row tiles merged, must give the same pixels as the
//! version before the render-job refactor (issue 32). The hashes below were recorded by that
//! version (commit 32c614b) with `ALEPH_GOLDEN_RECORD=1 cargo test --release --test tests
//! golden -- --nocapture`, which prints the table instead of checking it.
//!
//! One deliberate change since: the two sequence cases were re-recorded when the filmstrip's
//! frame labels moved from plotters to ab_glyph (so that the renderer library depends on no
//! plotting library). Every frame's EXR and PNG and the animated preview of both sequences
//! were checked byte-identical (`cmp`) to 32c614b's; only `seq.filmstrip.png` changed.
//!
//! Two cases were added with reuse across frames (issue 33) and recorded when it landed: the
//! same two sequences with `--reuse-window 2` (frames 2-4 of the moving-sphere box, after the
//! base passes of frames 0 and 1; the holodeck's frames 0-2). Both were re-recorded when a
//! frame came to reuse only the base passes of the K frames before it (a sliding window, no
//! keyframes), and the three reuse cases again when held fireflies came to be dropped from the
//! reused frames (`aleph::reuse::HELD_OUTLIER_RATIO`; every other case kept its pixels), and
//! again when reused samples came to land one by one where their surface points project
//! instead of resampling pixel means, and a frame to reuse every fresh sample of the K frames
//! before it (2026-11-25; every other case kept its pixels).
//!
//! Every case was re-recorded when Russian roulette moved from bounce 3 to bounce 5 (issue 36,
//! measured in `crates/aleph/src/integrator.rs`): a deliberate change of every path longer
//! than three bounces, so of every image.
//!
//! The uniform cases and the uniform farm parts were re-recorded when uniform renders began
//! drawing each pixel's samples from one Sobol' sequence instead of two (issue 36,
//! `aleph::sampler::SampleStreams`): every adaptive case kept its hash.
//!
//! The Lost Empire and Mori knob cases were re-recorded when the lights at infinity began to
//! be chosen by the irradiance they deliver at the shading point and a constant environment to
//! be sampled cosine-weighted about the normal (issue 36, `aleph::light`): the Mori knob's only
//! light is its map, so its images differ in rounding alone.
//!
//! One case was added when frames where only the camera moves began to level their fresh
//! samples under `--steer-from` instead of judging them (issue 33): the holodeck pan reusing
//! frames without `--steer-from 0`.
//!
//! The three reuse cases were re-recorded when a held firefly's excess came to be spread over
//! its surface instead of lost (`aleph::reuse::SPREAD_RADIUS`); every other case kept its
//! pixels. The moving-sphere box's reuse case again when a reused sample's direct light came
//! to be compared, at an edge, with centres that saw its surface rather than dropped (the
//! holodeck's cases have no moving object and kept theirs).
//!
//! Every case with an emissive triangle was re-recorded when a point on a triangle light came
//! to be sampled by Heitz's low-distortion map instead of the square-root map
//! (`aleph::sampling::square_to_uniform_triangle`, issue 36); Lost Empire and the Mori knob,
//! lit from infinity alone, kept theirs.
//!
//! The uniform cases and the uniform farm parts were re-recorded when uniform renders of a
//! budget came to draw a correlated multi-jittered pattern of that many points per pixel
//! (`aleph::sampler::SampleStreams::Fixed`, issue 36); every adaptive case kept its hash.
//! They were re-recorded again when that pattern's grid columns and rows came to be shuffled
//! per pixel (and its grid to be m × r = N exactly where N allows): the first pattern left
//! the last row's cells empty where m r > N, a bias at 32, 128 and 512 spp.
//!
//! The perceptual cases (each scene's `perceptual` and `converged`, the two sequences of
//! independent frames and the row tiles) were re-recorded when the perceptual sampler came to
//! draw one Sobol' sequence per pixel and read its power-of-two blocks as its half-buffers
//! (`aleph::film::HalfSplit::Blocks`, issue 36); the uniform, variance and reuse cases and
//! the sample parts kept their hashes.
//!
//! The uniform cases and the uniform farm parts were re-recorded when a uniform render's
//! dimensions past the tenth came to be drawn from the pixel's base pattern instead of PCG32
//! (`aleph::sampler::cmj::CMJ_DEEP_DIMENSIONS`, issue 36); every adaptive case kept its hash.
//!
//! The Mori knob's four cases were re-recorded when Reinhard's white stopped being set by a
//! lone pixel more than twice as bright as every neighbour
//! (`perception::tmo::reinhard02::white_luminance`): at 40 × 30 and 6 spp its brightest pixel,
//! 5.39, sits beside 2.45, so its white is now 4.90; its PNGs change and so do the adaptive
//! rules' samples, which measure noise through that curve. Every other case kept its pixels
//! (their brightest pixels have a neighbour at least half as bright).
//!
//! The three reuse cases were re-recorded when window frames came to be weighed at steps in
//! depth by their mean squared error, their bias bounded from the parallax and the contrast
//! across the step (`aleph::reuse::STEP_BIAS`, issue 33); every other case kept its pixels.
//!
//! The moving-sphere box's reuse case was re-recorded when the G-buffer's direct-light
//! signature went from 32 light samples to 16 (`aleph::gbuffer::DIRECT_SAMPLES`, issue 33);
//! every other case kept its pixels (the two holodeck cases move nothing but the camera and
//! have no signature).
//!
//! Every still case but the holodeck's, and the two farm cases, were re-recorded when
//! Reinhard's white came to be the 9th largest neighbour-capped luminance instead of the
//! largest (`perception::tmo::reinhard02::WHITE_RANK`): their PNGs change, and so do the
//! perceptual, variance and converged cases' samples, which measure noise through that curve.
//! The uniform cases' EXRs were checked byte-identical (`cmp`) to the build before; the
//! holodeck's white (its lights) and the sequences (another tone operator) did not move.
//!
//! The three reuse cases were re-recorded when the animation's first frame came to take more
//! than the budget and the frames after it less (`aleph::reuse::start_up_budget`, issue 33);
//! every other case kept its pixels.
//!
//! The moving-sphere box's reuse case was re-recorded when the direct-light signature went
//! from 16 light samples to 8 (`aleph::gbuffer::DIRECT_SAMPLES`, issue 33); every other case
//! kept its pixels.
//!
//! The Lost Empire and Mori knob cases (the two scenes lit by a map) were re-recorded when an
//! environment map's sampling weights became its bilinear radiance integrated over each texel
//! instead of the largest luminance of the 3 × 3 neighbourhood, and a sampled direction's map
//! coordinates came from the sample rather than from atan2 of the direction
//! (`aleph::light::environment`, issue 36): the same light, drawn with a different density;
//! every other case kept its pixels.
//!
//! The `converged` cases of the Cornell box, Lost Empire and the Mori knob were re-recorded
//! when the perceptual stop came to end at 90 % of the pixels below threshold instead of
//! 99.5 %, its converged pass lifting only the pixels under the floor
//! (`aleph::adaptive::DEFAULT_CONVERGED_FRACTION`); the other scenes' `converged` cases kept
//! their pixels, and so did every other case (the budgeted `perceptual` ones included).
//!
//! The `converged` cases of all seven stills were re-recorded when the stop's floor rose from
//! a quarter to half of the mean spp (`STOP_FLOOR_SHARE` in `aleph::adaptive`'s allocation,
//! 2026-11-28); every other case kept its pixels.
//!
//! The Cornell box's `converged` case was re-recorded when the default stop came to end at
//! 80 % of the pixels below threshold instead of 90 % (`DEFAULT_CONVERGED_FRACTION`,
//! 2026-11-28); every other case, the other stills' `converged` ones included, kept its
//! pixels.
//!
//! The perceptual cases (each still's `perceptual` and `converged`, the two sequences of
//! independent frames and the row tiles) were re-recorded when the first vertex's BSDF sample
//! of one sequence per pixel came to be drawn from a rank-1 lattice instead of a net
//! (`aleph::sampler::sobol::LATTICE_PAIR`, 2026-11-28); the uniform, variance and reuse cases
//! and the farm parts kept their pixels.
//!
//! The holodeck's and Lost Empire's cases (the two textured scenes, stills and the pan's
//! three sequences) were re-recorded when camera rays came to look textures up over an eighth
//! of a pixel's footprint through mip maps (`aleph::integrator::TEXTURE_FOOTPRINT_PIXELS`);
//! the scenes without textures kept their pixels.
//!
//! Lost Empire's four still cases were re-recorded when a `map_d` image whose alpha channel is
//! opaque everywhere came to be read by its luminance (Lost Empire's leaves, flowers and rails
//! gained their holes; `tests/surfaces.rs`, `cutouts_let_shadow_rays_through`), and again
//! when a colour texture's alpha came to weigh its mip levels and to bleed into its holes
//! (`aleph::texture::Texture::with_mip_maps_weighted`); the walkthrough's cases and every
//! other scene kept their pixels.
//!
//! The `converged` cases of all seven stills were re-recorded when the stop's floor rose from
//! half to three quarters of the mean spp (`STOP_FLOOR_SHARE`, 2026-11-29), and again the same
//! day when it rose to the whole mean; every other case kept its pixels.
//!
//! Layers added since are not hashed, so that the table keeps guarding the pixels it guarded:
//! the G-buffer (`Depth.Z`, `Normal.X/Y/Z`, `IndexOB`) and `History.spp` of reuse across
//! frames; the sequence cases render independent frames (`--reuse-window 0`), as every
//! sequence did then.
//!
//! What is hashed is the image data, not the files: every EXR channel (name and bit pattern, in
//! name order) and every PNG's decoded pixels, FNV-1a 64. Headers are not hashed: they carry
//! the scene's path and the render's record, which the refactor changes on purpose.

use crate::util::{repo, tempdir};
use std::path::Path;
use std::process::Command;

/// FNV-1a, 64 bits (Fowler–Noll–Vo): stable across Rust versions, unlike `DefaultHasher`.
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
}

/// EXR layers added after the table was recorded (see the module docs).
const UNHASHED: [&str; 6] = [
    "Depth.Z",
    "Normal.X",
    "Normal.Y",
    "Normal.Z",
    "IndexOB",
    "History.spp",
];

/// Hash of the pixel data of every `.exr` and `.png` in `dir` (file names in order).
pub fn hash_outputs(dir: &Path) -> (u64, Vec<String>) {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| {
            (n.ends_with(".exr") && !n.contains(".part-") && !n.contains(".tile-"))
                || n.ends_with(".png")
        })
        .collect();
    names.sort();
    let mut h = Fnv::new();
    for n in &names {
        h.bytes(n.as_bytes());
        let path = dir.join(n);
        if n.ends_with(".exr") {
            let raw = aleph::imageio::read_exr_raw(&path).unwrap();
            let mut f: Vec<_> = raw
                .f32s
                .iter()
                .filter(|(name, _)| !UNHASHED.contains(&name.as_str()))
                .collect();
            f.sort_by(|a, b| a.0.cmp(b.0));
            for (name, v) in f {
                h.bytes(name.as_bytes());
                v.iter().for_each(|x| h.bytes(&x.to_bits().to_le_bytes()));
            }
            let mut u: Vec<_> = raw.u32s.iter().collect();
            u.sort_by(|a, b| a.0.cmp(b.0));
            for (name, v) in u {
                h.bytes(name.as_bytes());
                v.iter().for_each(|x| h.bytes(&x.to_le_bytes()));
            }
        } else {
            let img = image::open(&path).unwrap().to_rgba8();
            h.bytes(&img.width().to_le_bytes());
            h.bytes(&img.height().to_le_bytes());
            h.bytes(img.as_raw());
        }
    }
    (h.0, names)
}

/// Runs `aleph ARGS` in `dir` and fails with its output if it fails.
fn aleph(dir: &Path, args: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "aleph {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Small renders that still exercise every rule: adaptive budgets are steered (`--steer-from 0`).
const STILL: &str = "--resolution 40x30 --max-depth 4";

/// The scene files of the bundled stills.
const STILLS: [&str; 7] = [
    "scenes/cornell-box/scene.toml",
    "scenes/cornell-variants/glossy.toml",
    "scenes/cornell-variants/mirror.toml",
    "scenes/cornell-variants/sphere.toml",
    "scenes/holodeck/scene.toml",
    "scenes/lost-empire/scene.toml",
    "scenes/mori-knob/scene.toml",
];

/// A case: a name and the commands it runs (each in the case's own directory).
type Case = (String, Vec<Vec<String>>);

/// The command `words` (split at blanks) with the bundled scene `scene` after its first word,
/// so that a repository path with blanks stays one argument.
fn cmd(scene: &str, words: &str) -> Vec<String> {
    let mut w = words.split_whitespace().map(String::from);
    let mut out: Vec<String> = w.next().into_iter().collect();
    if !scene.is_empty() {
        out.push(repo(scene).display().to_string());
    }
    out.extend(w);
    out
}

/// Every bundled still with each sampling rule.
fn still_cases() -> Vec<Case> {
    let rules = [
        ("uniform", "--sampler uniform --spp 6"),
        (
            "perceptual",
            "--sampler perceptual --spp 12 --steer-from 0 --min-spp 4",
        ),
        (
            "variance",
            "--sampler variance --spp 12 --steer-from 0 --min-spp 4",
        ),
        ("converged", "--max-spp 32 --min-spp 4"),
    ];
    let mut out = Vec::new();
    for scene in STILLS {
        for (rule, opts) in rules {
            let c = cmd(scene, &format!("render -o out --aov {STILL} {opts}"));
            out.push((format!("{scene} {rule}"), vec![c]));
        }
    }
    out
}

/// The two animated scenes as short sequences.
fn sequence_cases() -> Vec<Case> {
    let opts = "--resolution 32x24 --spp 8 --steer-from 0 --min-spp 4";
    [
        ("cornell-motion", "scenes/cornell-motion/scene.toml", "2-4"),
        ("holodeck pan", "scenes/holodeck/pan.toml", "0-2"),
    ]
    .into_iter()
    .map(|(name, scene, frames)| {
        let c = cmd(
            scene,
            &format!("render -o seq --frames {frames} --reuse-window 0 {opts}"),
        );
        (format!("{name} sequence"), vec![c])
    })
    .chain(
        [
            ("cornell-motion", "scenes/cornell-motion/scene.toml", "2-4"),
            ("holodeck pan", "scenes/holodeck/pan.toml", "0-2"),
        ]
        .into_iter()
        .map(|(name, scene, frames)| {
            let c = cmd(
                scene,
                &format!("render -o seq --frames {frames} --reuse-window 2 {opts}"),
            );
            (format!("{name} sequence reusing frames"), vec![c])
        }),
    )
    .chain(std::iter::once({
        // Under --steer-from with only the camera moving: levelled, nothing judged.
        let c = cmd(
            "scenes/holodeck/pan.toml",
            "render -o seq --frames 0-2 --reuse-window 2 --resolution 32x24 --spp 8 --min-spp 4",
        );
        (
            "holodeck pan sequence reusing frames, levelled".to_string(),
            vec![c],
        )
    }))
    .collect()
}

/// Sample parts (of a still and of a frame) and row tiles, each merged.
fn split_cases() -> Vec<Case> {
    let (cornell, motion) = (
        "scenes/cornell-box/scene.toml",
        "scenes/cornell-motion/scene.toml",
    );
    let uniform = "render -o p --sampler uniform --spp 8";
    let part = |i: &str| cmd(cornell, &format!("{uniform} {STILL} --part {i}"));
    let mpart = |i: &str| {
        cmd(
            motion,
            &format!("{uniform} --resolution 32x24 --frame 3 --part {i}"),
        )
    };
    let tile = |i: &str| {
        let opts = "--spp 16 --steer-from 0 --min-spp 4 --tile-margin 4";
        cmd(cornell, &format!("render -o t {STILL} {opts} --tile {i}"))
    };
    let merge = |parts: &str| cmd("", &format!("merge {parts} -o m"));
    vec![
        (
            "cornell-box parts merged".into(),
            vec![
                part("1/3"),
                part("2/3"),
                part("3/3"),
                merge("p.part-3-of-3.exr p.part-1-of-3.exr p.part-2-of-3.exr"),
            ],
        ),
        (
            "cornell-motion frame parts merged".into(),
            vec![
                mpart("1/2"),
                mpart("2/2"),
                merge("p.0003.part-1-of-2.exr p.0003.part-2-of-2.exr"),
            ],
        ),
        (
            "cornell-box tiles merged".into(),
            vec![
                tile("1/2"),
                tile("2/2"),
                merge("t.tile-1-of-2.exr t.tile-2-of-2.exr"),
            ],
        ),
    ]
}

/// Every case.
fn cases() -> Vec<Case> {
    let mut all = still_cases();
    all.extend(sequence_cases());
    all.extend(split_cases());
    all
}

/// Hashes recorded by the version before the refactor, re-recorded since (see the module docs).
pub const GOLDEN: &[(&str, u64)] = &[
    ("scenes/cornell-box/scene.toml uniform", 0xed7145a2727e4a6b),
    (
        "scenes/cornell-box/scene.toml perceptual",
        0xeff22421cb27da88,
    ),
    ("scenes/cornell-box/scene.toml variance", 0xb4d822fbed79b983),
    (
        "scenes/cornell-box/scene.toml converged",
        0x3d59f9ada869f462,
    ),
    (
        "scenes/cornell-variants/glossy.toml uniform",
        0x4a48dbe4b0184a5f,
    ),
    (
        "scenes/cornell-variants/glossy.toml perceptual",
        0x44a5a6f37650d64b,
    ),
    (
        "scenes/cornell-variants/glossy.toml variance",
        0xe3856c694ec3404e,
    ),
    (
        "scenes/cornell-variants/glossy.toml converged",
        0x88ea9035a3c8d0b3,
    ),
    (
        "scenes/cornell-variants/mirror.toml uniform",
        0x1fef02363dd2e5f7,
    ),
    (
        "scenes/cornell-variants/mirror.toml perceptual",
        0x6380966f8d9098a3,
    ),
    (
        "scenes/cornell-variants/mirror.toml variance",
        0xe8ec0547e4a9ba2d,
    ),
    (
        "scenes/cornell-variants/mirror.toml converged",
        0xde3e4834018b887c,
    ),
    (
        "scenes/cornell-variants/sphere.toml uniform",
        0xfb3d40d014818110,
    ),
    (
        "scenes/cornell-variants/sphere.toml perceptual",
        0xf52ccf35e78e60ea,
    ),
    (
        "scenes/cornell-variants/sphere.toml variance",
        0x1880ab33bd9db414,
    ),
    (
        "scenes/cornell-variants/sphere.toml converged",
        0x21e54b89cf5d9e82,
    ),
    ("scenes/holodeck/scene.toml uniform", 0x03b61deab2072dea),
    ("scenes/holodeck/scene.toml perceptual", 0xa29991e266341dbd),
    ("scenes/holodeck/scene.toml variance", 0xf37b3e44c450120e),
    ("scenes/holodeck/scene.toml converged", 0xfc35a51e34305e51),
    ("scenes/lost-empire/scene.toml uniform", 0xddbef115df771536),
    (
        "scenes/lost-empire/scene.toml perceptual",
        0x16d1484dccc67921,
    ),
    ("scenes/lost-empire/scene.toml variance", 0x2635f8930dd4fd83),
    (
        "scenes/lost-empire/scene.toml converged",
        0xd1c1d87ef84bbb2d,
    ),
    ("scenes/mori-knob/scene.toml uniform", 0x599e250e109ca348),
    ("scenes/mori-knob/scene.toml perceptual", 0x3e17fd87c1fe6d6e),
    ("scenes/mori-knob/scene.toml variance", 0x9a7ac1dbcfe458c5),
    ("scenes/mori-knob/scene.toml converged", 0x3bfca35bc5b90dd5),
    ("cornell-motion sequence", 0xc02011fad3d03cfb),
    ("holodeck pan sequence", 0xffd2268e6e50e2c2),
    ("cornell-motion sequence reusing frames", 0xe382ff993bfd068f),
    ("holodeck pan sequence reusing frames", 0x67cc08a2f6099066),
    (
        "holodeck pan sequence reusing frames, levelled",
        0x88c2877d6f70baa6,
    ),
    ("cornell-box parts merged", 0x281a79598ea67101),
    ("cornell-motion frame parts merged", 0x7cdf508c0c42ee55),
    ("cornell-box tiles merged", 0x4e2447478dcdb00d),
];

#[test]
fn bundled_scenes_render_the_pixels_recorded_before_the_render_job() {
    let record = std::env::var_os("ALEPH_GOLDEN_RECORD").is_some();
    let mut failures = Vec::new();
    for (name, commands) in cases() {
        let dir = tempdir();
        for c in &commands {
            let args: Vec<&str> = c.iter().map(String::as_str).collect();
            aleph(dir.path(), &args);
        }
        let (hash, files) = hash_outputs(dir.path());
        if record {
            println!("    (\"{name}\", 0x{hash:016x}), // {}", files.join(" "));
            continue;
        }
        match GOLDEN.iter().find(|(n, _)| *n == name) {
            Some(&(_, want)) if want == hash => {}
            Some(&(_, want)) => failures.push(format!(
                "{name}: 0x{hash:016x}, recorded 0x{want:016x} ({files:?})"
            )),
            None => failures.push(format!("{name}: no recorded hash")),
        }
    }
    assert!(
        failures.is_empty(),
        "pixels changed:\n{}",
        failures.join("\n")
    );
}
