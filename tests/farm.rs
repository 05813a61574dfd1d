//! Render farms: partial films merge into exactly the single-machine film; `aleph farm`'s batch
//! scripts, run by hand as a scheduler would, write the same bytes as `aleph render`; reruns
//! skip finished work; an interrupted task leaves nothing. The real Slurm run is in
//! `tests/slurm.rs` (ignored here; `.ci/run` starts a cluster and runs it).

use crate::util::{repo, tempdir};
use aleph::adaptive::{AdaptiveSettings, Criterion, render_adaptive};
use aleph::partial::{merge_parts, part_path, read_partial, render_part, write_partial};
use aleph::scene::{Scene, SceneDescription};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn aleph(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap()
}

fn ok(out: &Output) -> String {
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{text}");
    text
}

fn small_box(res: u32) -> Scene {
    let mut d = SceneDescription::read(&repo("scenes/cornell-box/scene.toml")).unwrap();
    d.camera.resolution = [res, res];
    Scene::load_description(d).unwrap()
}

/// The image bits of a film: every pixel's mean RGB as f64 bits, and its sample count.
fn image_bits(f: &aleph::film::Film) -> Vec<(u64, u64, u64, u32)> {
    f.pixels
        .iter()
        .map(|p| {
            let m = p.mean();
            (m.x.to_bits(), m.y.to_bits(), m.z.to_bits(), p.count())
        })
        .collect()
}

#[test]
fn parts_merge_into_the_single_render_bit_for_bit() {
    // The machinery end to end: parts rendered on their own, written, read back and merged in
    // any order. (A plain f64 sum of this scene's samples happens not to round at 13 spp; the
    // film's unit tests show sums that do, and that exact sums don't.)
    let dir = tempdir();
    let scene = small_box(24);
    let spp = 13;
    let settings = AdaptiveSettings {
        criterion: Criterion::Uniform,
        budget_spp: Some(spp as f64),
        ..Default::default()
    };
    let single = render_adaptive(&scene, &settings, &|_| {}, &|_| {}).unwrap();
    let stem = dir.path().join("box");
    for k in [1u32, 2, 5] {
        let paths: Vec<PathBuf> = (1..=k).map(|i| part_path(&stem, i, k, false)).collect();
        // Written in reverse, merged in any order.
        for i in (1..=k).rev() {
            let (part, _) = render_part(&scene, spp, i, k, "r".into(), &|_| {});
            write_partial(&paths[i as usize - 1], &part).unwrap();
            assert_eq!(read_partial(&paths[i as usize - 1]).unwrap(), part);
        }
        let mut shuffled = paths.clone();
        shuffled.rotate_left(1);
        let merged = merge_parts(&shuffled).unwrap();
        assert_eq!(merged.recipe, "r");
        assert_eq!(
            image_bits(&merged.film),
            image_bits(&single.film),
            "{k} parts"
        );
    }
}

#[test]
fn merge_refuses_parts_that_do_not_make_one_render() {
    let scene = small_box(8);
    let dir = tempdir();
    let write = |i: u32, k: u32, recipe: &str, name: &str| {
        let (part, _) = render_part(&scene, 6, i, k, recipe.into(), &|_| {});
        let p = dir.path().join(name);
        write_partial(&p, &part).unwrap();
        p
    };
    let a = write(1, 3, "r", "a.exr");
    let b = write(2, 3, "r", "b.exr");
    let c = write(3, 3, "r", "c.exr");
    let other = write(2, 3, "other", "other.exr");
    let overlap = write(1, 2, "r", "half.exr");
    let err = |paths: &[&PathBuf]| {
        let v: Vec<PathBuf> = paths.iter().map(|p| p.to_path_buf()).collect();
        merge_parts(&v).unwrap_err().to_string()
    };
    assert!(err(&[&a, &c]).contains("holds samples 4..6, but the parts before it end at 2"));
    assert!(err(&[&a, &b]).contains("part 3/3 is missing"));
    assert!(err(&[&a, &a, &b, &c]).contains("part 1/3 again"));
    let e = err(&[&a, &other, &c]);
    assert!(e.starts_with(&other.display().to_string()) && e.contains("recipes differ"));
    assert!(err(&[&a, &overlap]).contains("part of 2"));
    // A part whose data window was shifted by hand (same size, same samples) is refused.
    let shifted = dir.path().join("shifted.exr");
    {
        use exr::prelude::*;
        let mut img = read_all_data_from_file(&b).unwrap();
        img.layer_data[0].attributes.layer_position = Vec2(3, 0);
        img.write().to_file(&shifted).unwrap();
    }
    let e = err(&[&a, &shifted, &c]);
    assert!(
        e.starts_with(&shifted.display().to_string()) && e.contains("data window starts at (3, 0)"),
        "{e}"
    );
    let junk = dir.path().join("junk.exr");
    std::fs::write(&junk, b"not an exr").unwrap();
    assert!(err(&[&junk]).starts_with(&junk.display().to_string()));
    // A plain render is not a partial film.
    let plain = dir.path().join("plain");
    let scene_path = repo("scenes/cornell-box/scene.toml");
    let args = [
        "render",
        scene_path.to_str().unwrap(),
        "--resolution",
        "8x8",
        "--spp",
        "2",
    ];
    let mut args = args.to_vec();
    args.extend(["-o", plain.to_str().unwrap()]);
    ok(&aleph(&args, dir.path()));
    assert!(err(&[&dir.path().join("plain.exr")]).contains("not a partial film"));
}

/// Runs a batch script as Slurm would run array task `index` (or the finishing job).
fn run_script(script: &Path, index: Option<usize>) -> String {
    let mut c = Command::new("bash");
    c.arg(script);
    if let Some(i) = index {
        c.env("SLURM_ARRAY_TASK_ID", i.to_string());
    }
    ok(&c.output().unwrap())
}

/// Files in `dir` (not directories), sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_file())
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}

/// Every file of `reference` is in `farm` with the same bytes.
fn assert_same_files(reference: &Path, farm: &Path) {
    let names = files(reference);
    assert!(!names.is_empty());
    for name in names {
        let (a, b) = (reference.join(&name), farm.join(&name));
        assert!(
            std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap_or_default(),
            "{name} differs"
        );
    }
}

#[test]
fn farm_scripts_give_the_single_machine_files() {
    let dir = tempdir();
    let d = dir.path();
    let scene = repo("scenes/cornell-motion/scene.toml");
    let scene = scene.to_str().unwrap();
    let opts = ["--resolution", "40x40", "--spp", "6"];
    // A sequence of the perceptual sampler reusing frames (the default window: frames 2-4 lie
    // in one chunk, one task; a window of 1: chunks of 16 frames, so 14-17 are two tasks, 14-15
    // and 16-17, the second rendering the base pass of frame 14 and frame 15 whole as
    // warm-up), the same window cut to 1 by a reuse memory of 1 MiB (1600 pixels take 0.4 MB
    // a frame: the window of 15 is cut to the frames 1 MiB holds, and the chunks follow the
    // cut), one of independent frames (a task per frame), and one split by samples (uniform).
    let cases: [(&str, &str, Vec<&str>, usize); 5] = [
        ("frames", "2-4", vec![], 1),
        ("chunks", "14-17", vec!["--reuse-window", "1"], 2),
        ("memory", "14-17", vec!["--reuse-memory", "0.0009765625"], 2),
        ("independent", "2-4", vec!["--reuse-window", "0"], 3),
        ("parts", "2-4", vec!["--sampler", "uniform"], 9),
    ];
    for (name, frames, extra, n) in cases {
        let reference = d.join(format!("{name}-ref"));
        std::fs::create_dir(&reference).unwrap();
        let mut args = vec!["render", scene, "--frames", frames, "-o"];
        let stem = reference.join("cornell-motion");
        args.push(stem.to_str().unwrap());
        args.extend(opts.iter().chain(&extra));
        ok(&aleph(&args, d));
        let farm = d.join(name);
        let split = if name == "parts" { "3" } else { "1" };
        let mut args = vec![
            "farm",
            "slurm",
            scene,
            "--frames",
            frames,
            "--split-samples",
            split,
        ];
        args.extend(["-o", farm.to_str().unwrap(), "--"]);
        args.extend(opts.iter().chain(&extra));
        let text = ok(&aleph(&args, d));
        assert!(text.contains(&format!("{n} tasks")), "{text}");
        for i in 0..n {
            run_script(&farm.join("render.sbatch"), Some(i));
        }
        let report = run_script(&farm.join("finish.sbatch"), None);
        assert!(
            report.contains(&format!("{n} of {n} tasks timed")),
            "{report}"
        );
        assert_same_files(&reference, &farm);
        // The parts are gone once merged; a rerun skips every task and changes nothing.
        assert!(!files(&farm).iter().any(|f| f.contains(".part-")));
        let last = format!(
            "cornell-motion.{:04}.exr",
            frames.split('-').nth(1).unwrap().parse::<u32>().unwrap()
        );
        let before = std::fs::read(farm.join(&last)).unwrap();
        for i in 0..n {
            assert!(run_script(&farm.join("render.sbatch"), Some(i)).contains("skipped"));
        }
        run_script(&farm.join("finish.sbatch"), None);
        assert_eq!(std::fs::read(farm.join(&last)).unwrap(), before);
    }
}

#[test]
fn farm_refuses_what_cannot_split() {
    let dir = tempdir();
    let d = dir.path();
    let out = d.join("f");
    let o = out.to_str().unwrap();
    let motion = repo("scenes/cornell-motion/scene.toml");
    let motion = motion.to_str().unwrap();
    let still = repo("scenes/cornell-box/scene.toml");
    let still = still.to_str().unwrap();
    for (args, expect) in [
        (
            vec!["farm", "slurm", motion, "--split-samples", "2", "-o", o],
            "add `-- --sampler uniform`",
        ),
        (
            vec!["farm", "slurm", still, "--frames", "1-2", "-o", o],
            "needs an animated scene",
        ),
        (
            vec!["farm", "slurm", motion, "--frames", "1-99", "-o", o],
            "outside the scene's",
        ),
        (
            vec!["farm", "slurm", still, "-o", o, "--", "-o", "x"],
            "-o is the farm's to set",
        ),
        (
            vec![
                "farm",
                "slurm",
                still,
                "-o",
                o,
                "--split-samples",
                "9",
                "--",
                "--sampler",
                "uniform",
                "--spp",
                "4",
            ],
            "more parts than the 4 samples",
        ),
        (
            vec!["farm", "task", o, "--index", "0"],
            "farm.toml: cannot read",
        ),
    ] {
        let r = aleph(&args, d);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(expect), "{args:?}: {err}");
        assert!(!out.join("farm.toml").exists(), "{args:?} wrote a manifest");
    }
}

#[test]
fn an_interrupted_task_leaves_nothing() {
    let dir = tempdir();
    let d = dir.path();
    let farm = d.join("f");
    let still = repo("scenes/cornell-box/scene.toml");
    ok(&aleph(
        &[
            "farm",
            "slurm",
            still.to_str().unwrap(),
            "-o",
            farm.to_str().unwrap(),
            "--split-samples",
            "2",
            "--",
            "--sampler",
            "uniform",
            "--spp",
            "100000",
            "--resolution",
            "64x64",
        ],
        d,
    ));
    let before = files(&farm);
    let mut child = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(["farm", "task", farm.to_str().unwrap(), "--index", "1"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(700));
    // Slurm preempts with SIGTERM.
    let pid = child.id().to_string();
    Command::new("kill").args(["-TERM", &pid]).status().unwrap();
    let status = child.wait().unwrap();
    assert!(!status.success());
    assert_eq!(files(&farm), before, "the interrupted task left files");
    assert!(files(&farm.join("logs")).is_empty());
}

/// Renders `scene` perceptually in `k` row tiles with `margin`, each with budget `spp` over its
/// sampled rows, and assembles the tiles' own rows: (image, samples taken on all machines).
fn tiled_render(scene: &Scene, base: &AdaptiveSettings, k: u32, margin: u32) -> (Vec<f32>, u64) {
    let h = scene.camera.height;
    let mut film = aleph::film::Film::new(scene.camera.width, h);
    let mut samples = 0;
    for i in 1..=k {
        let (y0, y1) = aleph::partial::part_range(h, i, k);
        let s = AdaptiveSettings {
            rows: Some((y0.saturating_sub(margin), (y1 + margin).min(h))),
            ..base.clone()
        };
        let r = render_adaptive(scene, &s, &|_| {}, &|_| {}).unwrap();
        samples += r.film.total_samples();
        let tile = aleph::partial::tile_of(&r.film, (y0, y1), None, i, k, String::new());
        let at = y0 as usize * scene.camera.width as usize;
        film.pixels[at..at + tile.film.len()].copy_from_slice(&tile.film.pixels);
    }
    (film.mean_rgb(), samples)
}

/// What a row-tile split of one perceptual frame costs: FLIP (mean, p99) against a 2048-spp
/// reference of the single-machine render and of tiled renders (at the same mean spp per tile,
/// and until converged), and the samples every machine took. Prints a table; asserts nothing (a measurement).
/// `cargo test --release --test tests farm::tile_split_cost -- --ignored --nocapture`
#[test]
#[ignore = "a measurement (about a minute)"]
fn tile_split_cost() {
    // ALEPH_TILE_SCENE=holodeck measures the holodeck at 240×160 instead of the Cornell box.
    let holodeck = std::env::var("ALEPH_TILE_SCENE").is_ok_and(|v| v == "holodeck");
    let scene = if holodeck {
        let mut d = SceneDescription::read(&repo("scenes/holodeck/scene.toml")).unwrap();
        d.camera.resolution = [240, 160];
        Scene::load_description(d).unwrap()
    } else {
        small_box(256)
    };
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let (reference, _) =
        aleph::render::render_uniform(&scene, aleph::integrator::Strategy::Mis, 2048, &|_| {});
    let s = AdaptiveSettings::default();
    let reference = reference.mean_rgb();
    let frozen = aleph::display::FrozenToneMap::new(&reference, w, h, &s.tone).unwrap();
    let judge = aleph_speedup::Judge::new(reference, w, h, frozen, s.tone.view).unwrap();
    println!("spp | split | margin | samples / single | FLIP mean | FLIP p99");
    let vis = match std::env::var("ALEPH_TILE_VISIBILITY").as_deref() {
        Ok("scene") => aleph::adaptive::Visibility::Scene,
        _ => aleph::adaptive::Visibility::Display,
    };
    let budgets: Vec<Option<f64>> = match std::env::var("ALEPH_TILE_BUDGETS").as_deref() {
        Ok("converged") => vec![None],
        Ok("64") => vec![Some(64.0)],
        Ok("64,converged") => vec![Some(64.0), None],
        _ => vec![Some(16.0), Some(64.0), None],
    };
    for spp in budgets {
        // Steered at every budget: under the default --steer-from a tile renders only its
        // own rows uniformly, so the split then costs nothing.
        let one = AdaptiveSettings {
            budget_spp: spp,
            perceptual: aleph::adaptive::PerceptualSettings {
                visibility: vis,
                ..Default::default()
            },
            steer_from_spp: 0.0,
            ..Default::default()
        };
        let r = render_adaptive(&scene, &one, &|_| {}, &|_| {}).unwrap();
        let base = r.film.total_samples() as f64;
        let sc = judge.score(&r.film.mean_rgb()).unwrap();
        let label = spp.map_or("converged".to_string(), |s| format!("{s}"));
        println!(
            "{label} | 1 | - | 1.00 ({:.1} spp) | {:.4} | {:.4}",
            r.mean_spp(),
            sc.flip_mean,
            sc.flip_p99
        );
        // ALEPH_TILE_KS=1 measures one "tile" covering the frame: the single machine with the
        // tiles' display curve.
        let ks: Vec<u32> = match std::env::var("ALEPH_TILE_KS") {
            Ok(v) => v.split(',').filter_map(|k| k.trim().parse().ok()).collect(),
            Err(_) => vec![2, 4],
        };
        for &k in &ks {
            let margins: &[u32] = match (k, spp) {
                (1, _) => &[0],
                (_, Some(_)) => &[0, 16, 64],
                (_, None) => &[16],
            };
            for &margin in margins {
                let (img, n) = tiled_render(&scene, &one, k, margin);
                let sc = judge.score(&img).unwrap();
                println!(
                    "{label} | {k} | {margin} | {:.2} | {:.4} | {:.4}",
                    n as f64 / base,
                    sc.flip_mean,
                    sc.flip_p99
                );
            }
        }
    }
}

#[test]
fn row_tiles_assemble_into_the_frame() {
    let dir = tempdir();
    let d = dir.path();
    let scene = repo("scenes/cornell-box/scene.toml");
    let scene = scene.to_str().unwrap();
    // With a margin that covers the image, each tile's adaptive render is the single machine's
    // (its display curve included), so the assembled files must be its bytes: this checks the
    // assembly, the threshold and error layers, and the recipe. Then the same for a budget
    // under --steer-from, where each tile renders its own rows uniformly.
    let mut tiles = Vec::new();
    for (run, steer) in [("steered", "0"), ("unsteered", "128")] {
        let opts = [
            "--resolution",
            "40x40",
            "--spp",
            "24",
            "--visibility",
            "scene",
            "--steer-from",
            steer,
        ];
        let single = d.join(format!("single-{run}"));
        let mut args = vec!["render", scene, "-o", single.to_str().unwrap()];
        args.extend(opts);
        ok(&aleph(&args, d));
        let stem = d.join(format!("t-{run}"));
        for i in 1..=3 {
            let tile = format!("{i}/3");
            let mut args = vec![
                "render",
                scene,
                "-o",
                stem.to_str().unwrap(),
                "--tile",
                &tile,
            ];
            args.extend(opts);
            args.extend(["--tile-margin", "40"]);
            ok(&aleph(&args, d));
        }
        tiles = (1..=3)
            .map(|i| part_path(&stem, i, 3, true).display().to_string())
            .collect();
        // The perceptual sampler's half-buffers are blocks of one sequence, and say so.
        let split = read_partial(Path::new(&tiles[0])).unwrap().film.split;
        let want = if run == "steered" {
            aleph::film::HalfSplit::Blocks
        } else {
            aleph::film::HalfSplit::Interleaved
        };
        assert_eq!(split, want, "{run}");
        let merged = d.join(format!("merged-{run}"));
        let mut args = vec!["merge", "-o", merged.to_str().unwrap()];
        args.extend(tiles.iter().map(String::as_str));
        let text = ok(&aleph(&args, d));
        assert!(text.contains("merged 3 row tiles"), "{text}");
        for ext in ["exr", "png"] {
            let a = std::fs::read(d.join(format!("single-{run}.{ext}"))).unwrap();
            let b = std::fs::read(d.join(format!("merged-{run}.{ext}"))).unwrap();
            assert!(a == b, "{run}: merged.{ext} differs from the single render");
        }
    }
    // Tiles and sample parts do not mix; a missing tile is named.
    let recipe = aleph::partial::read_part_info(Path::new(&tiles[0]))
        .unwrap()
        .recipe;
    let (part, _) = render_part(&small_box(40), 4, 2, 3, recipe, &|_| {});
    let part_file = d.join("p.exr");
    write_partial(&part_file, &part).unwrap();
    let e = merge_parts(&[PathBuf::from(&tiles[0]), part_file])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("a sample part of 3 of a 40×40 frame, but"),
        "{e}"
    );
    let e = merge_parts(&[PathBuf::from(&tiles[0]), PathBuf::from(&tiles[1])]).unwrap_err();
    assert!(e.to_string().contains("part 3/3 is missing"), "{e}");
    // A uniform render splits by samples, an adaptive one by rows.
    let r = aleph(
        &["render", scene, "--tile", "1/2", "--sampler", "uniform"],
        d,
    );
    assert!(String::from_utf8_lossy(&r.stderr).contains("--part I/K"));
}

/// Values written into a batch script follow Slurm's grammar: a newline or a shell command in
/// any option is refused before anything is written (issue 35, class 3), and good values pass.
#[test]
fn farm_options_cannot_inject_lines_into_the_batch_script() {
    let dir = tempdir();
    let d = dir.path();
    let out = d.join("f");
    let o = out.to_str().unwrap();
    let still = repo("scenes/cornell-box/scene.toml");
    let still = still.to_str().unwrap();
    let base = ["farm", "slurm", still, "-o", o];
    for (extra, flag) in [
        (["--partition", "batch\nrm -rf /tmp/x"], "--partition"),
        (["--partition", "batch;rm"], "--partition"),
        (["--mem", "4G\n#SBATCH --wrap=x"], "--mem"),
        (["--mem", "lots"], "--mem"),
        (["--time-limit", "1:00:00\nrm"], "--time-limit"),
        (["--time-limit", "an hour"], "--time-limit"),
        (["--cpus-per-task", "0"], "--cpus-per-task"),
        (["--sbatch", "--account=lab\nrm -rf /"], "--sbatch"),
        (["--sbatch", "account=lab"], "--sbatch"),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra).collect();
        let r = aleph(&args, d);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{extra:?}: {err}");
        assert!(err.contains(flag), "{extra:?}: {err}");
        assert!(!out.join("farm.toml").exists() && !out.join("render.sbatch").exists());
    }
    let bad_dir = d.join("f\nrm");
    let r = aleph(
        &["farm", "slurm", still, "-o", bad_dir.to_str().unwrap()],
        d,
    );
    assert_eq!(r.status.code(), Some(2));
    assert!(!bad_dir.exists());
    // Good values of every form are written as given, one #SBATCH line each.
    let args = [
        "--partition",
        "batch,gpu-a.1",
        "--mem",
        "4096M",
        "--time-limit",
        "1-02:03:04",
        "--cpus-per-task",
        "2",
        "--sbatch=--account=lab",
    ];
    let all: Vec<&str> = base.iter().copied().chain(args).collect();
    let r = aleph(&all, d);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let script = std::fs::read_to_string(out.join("render.sbatch")).unwrap();
    for line in [
        "#SBATCH --partition=batch,gpu-a.1",
        "#SBATCH --mem=4096M",
        "#SBATCH --time=1-02:03:04",
        "#SBATCH --cpus-per-task=2",
        "#SBATCH --account=lab",
    ] {
        assert!(
            script.lines().any(|l| l == line),
            "{line} missing:\n{script}"
        );
    }
    assert!(
        script
            .lines()
            .all(|l| l.starts_with('#') || l.starts_with("exec ") || l.is_empty())
    );
}

/// `farm finish` before the tasks are done names the missing ones as ranges: 3000 tasks were
/// 3000 indices in one message (a million were 7.9 MB; issue 35, class 8).
#[test]
fn finish_names_missing_tasks_as_ranges() {
    let dir = tempdir();
    let d = dir.path();
    let farm = d.join("f");
    let scene = repo("scenes/cornell-box/scene.toml");
    let args = [
        "farm",
        "slurm",
        scene.to_str().unwrap(),
        "--split-samples",
        "3000",
        "-o",
        farm.to_str().unwrap(),
        "--",
        "--sampler",
        "uniform",
        "--spp",
        "3000",
        "--resolution",
        "4x4",
    ];
    ok(&aleph(&args, d));
    for i in [1, 3] {
        run_script(&farm.join("render.sbatch"), Some(i));
    }
    let out = aleph(&["farm", "finish", farm.to_str().unwrap()], d);
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(
        e.contains("2998 of 3000 tasks have no outputs yet: 0, 2, 4-2999") && e.len() < 300,
        "{e}"
    );
}
