//! `aleph render --part I/K` (a partial film) and `aleph merge PART... -o OUT`.
//!
//! A part records its recipe: the working directory and the render's command line without the
//! options that do not change the image (`-o`, `--part`, `--threads`). `merge` checks that the
//! parts share it, sums their films ([`aleph::partial::merge_parts`]), and writes the outputs
//! the same command line would have written on one machine, through the same code.

use super::render::{
    RenderArgs, SamplerArg, frame_settings, scene_description, still_settings, with_ext,
};
use super::sequence::numbered;
use super::with_threads;
use aleph::adaptive::{AdaptiveResult, SamplerKind, StopReason};
use aleph::deliver::write_render;
use aleph::display::ToneMapSettings;
use aleph::partial::{merge_parts, part_path, render_part, write_partial};
use aleph::render::RenderStats;
use aleph::scene::Scene;
use aleph::sequence::AdaptationCourse;
use anyhow::{Context, bail};
use clap::{Args, Parser};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// What the parts of one render share.
#[derive(Serialize, Deserialize, Debug, PartialEq)]
struct Recipe {
    /// The working directory the command line's relative paths are relative to.
    cwd: PathBuf,
    /// The command line after `render`, without `-o`, `--part` and `--threads`.
    args: Vec<String>,
}

/// Options of a render command line that take a value and do not change the image.
const NOT_IN_RECIPE: [&str; 4] = ["-o", "--output", "--part", "--threads"];

/// `argv` without the options that do not change the image.
fn recipe_args(argv: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    let mut skip_next = false;
    for a in argv {
        if std::mem::take(&mut skip_next) {
            continue;
        }
        if NOT_IN_RECIPE.contains(&a.as_str()) {
            skip_next = true;
        } else if !NOT_IN_RECIPE
            .iter()
            .any(|o| a.starts_with(&format!("{o}=")) || (*o == "-o" && a.starts_with("-o")))
        {
            out.push(a.clone());
        }
    }
    out
}

/// Parses a render command line (after `render`).
#[derive(Parser, Debug)]
#[command(name = "aleph render", no_binary_name = true)]
struct RenderLine {
    #[command(flatten)]
    args: RenderArgs,
}

/// Parses a render command line (after `render`) as `aleph render` would, keeping it in `argv`.
pub(super) fn parse_render(argv: &[String]) -> anyhow::Result<RenderArgs> {
    let mut line = RenderLine::try_parse_from(argv)?;
    line.args.argv = argv.to_vec();
    Ok(line.args)
}

/// Renders part `(i, k)` of `scene` (loaded from `args`) to `STEM[.NNNN].part-I-of-K.exr`.
pub(super) fn render_part_file(
    mut scene: Scene,
    stem: &Path,
    args: &RenderArgs,
    (i, k): (u32, u32),
) -> anyhow::Result<ExitCode> {
    if !matches!(args.sampler, SamplerArg::Uniform) {
        bail!(
            "--part splits the samples of a uniform render (--sampler uniform); the perceptual \
             and variance samplers decide where samples go from all of a pixel's neighbours, so \
             they split across machines by frames (docs/farm.md)"
        );
    }
    let stem = match (args.frames, args.frame, scene.animation) {
        (Some(_), _, _) => bail!("--part renders one frame: give --frame N, not --frames"),
        (None, Some(f), Some(_)) => {
            scene.set_frame(f)?;
            numbered(stem, f)
        }
        (None, Some(_), None) => bail!(
            "{}: --frame needs an animated scene (this one has no [animation] table)",
            scene.path.display()
        ),
        (None, None, Some(_)) => bail!(
            "{}: --part on an animated scene renders one frame: give --frame N",
            scene.path.display()
        ),
        (None, None, None) => stem.to_path_buf(),
    };
    let settings = args.sampling.settings(
        SamplerKind::Uniform,
        args.spp,
        scene.settings.spp,
        ToneMapSettings::default(),
    )?;
    let spp = settings.uniform_total_spp();
    if k > spp {
        bail!("--part {i}/{k}: {k} parts of {spp} samples per pixel would leave parts empty");
    }
    let recipe = Recipe {
        cwd: std::env::current_dir().context("the working directory")?,
        args: recipe_args(&args.argv),
    };
    let recipe = toml::to_string(&recipe).context("recording the recipe")?;
    let path = part_path(&stem, i, k);
    aleph::output::check_output_location(&path)?;
    let start = Instant::now();
    let (part, stats) = render_part(&scene, spp, i, k, recipe, &|_| {});
    write_partial(&path, &part)?;
    let (w, h) = (scene.camera.width, scene.camera.height);
    println!(
        "{}: part {i}/{k}: samples {}..{} of {spp} per pixel, {w}×{h}, {:.2} s ({:.2} s \
         rendering, {:.2} M samples/s) -> {}",
        scene.path.display(),
        part.first,
        part.end,
        start.elapsed().as_secs_f64(),
        stats.wall.as_secs_f64(),
        stats.samples as f64 / stats.wall.as_secs_f64().max(1e-9) / 1e6,
        path.display()
    );
    Ok(ExitCode::SUCCESS)
}

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Partial films (`aleph render --part I/K`), all K parts of one render, in any order.
    #[arg(required = true, value_name = "PART")]
    parts: Vec<PathBuf>,
    /// Output path without extension: writes OUT.exr and OUT.png (OUT.NNNN.* for a frame of a
    /// sequence), the files the render's command line writes on one machine.
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
    /// Worker threads (tone mapping and velocity; default: all cores).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
}

impl MergeArgs {
    /// Merge `parts` into `output` with `threads` workers.
    pub(super) fn new(parts: Vec<PathBuf>, output: PathBuf, threads: Option<usize>) -> MergeArgs {
        MergeArgs {
            parts,
            output,
            threads,
        }
    }
}

/// The output stem of `-o`: an `.exr`/`.png` extension is dropped, as `render` does.
fn output_stem(o: &Path) -> PathBuf {
    match o
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
    {
        Some(e) if e == "exr" || e == "png" => o.with_extension(""),
        _ => o.to_path_buf(),
    }
}

pub fn run(args: MergeArgs) -> anyhow::Result<ExitCode> {
    let start = Instant::now();
    let absolute = |p: &Path| std::path::absolute(p).with_context(|| p.display().to_string());
    let parts: Vec<PathBuf> = args
        .parts
        .iter()
        .map(|p| absolute(p))
        .collect::<Result<_, _>>()?;
    let stem = absolute(&output_stem(&args.output))?;
    let (film, recipe_text) = merge_parts(&parts)?;
    let recipe: Recipe = toml::from_str(&recipe_text)
        .with_context(|| format!("{}: the recipe is not aleph's", parts[0].display()))?;
    let render_args = parse_render(&recipe.args)
        .with_context(|| format!("{}: the recorded command line", parts[0].display()))?;
    // The render's relative paths (the scene) are relative to where it ran.
    std::env::set_current_dir(&recipe.cwd).with_context(|| {
        format!(
            "{}: the render's working directory {}",
            parts[0].display(),
            recipe.cwd.display()
        )
    })?;
    let read_s = start.elapsed().as_secs_f64();
    let n = parts.len();
    with_threads(args.threads, move || {
        deliver_merged(film, &render_args, &stem, n, start, read_s)
    })?
}

/// Loads the recipe's scene and writes the merged film as its render would have been written.
fn deliver_merged(
    film: aleph::film::Film,
    args: &RenderArgs,
    stem: &Path,
    n_parts: usize,
    start: Instant,
    read_s: f64,
) -> anyhow::Result<ExitCode> {
    let scene_path = args
        .scene
        .clone()
        .unwrap_or_else(super::render::default_scene);
    let mut scene = Scene::load_description(scene_description(args, &scene_path)?)?;
    let (settings, look, stem) = match args.frame {
        Some(f) => {
            let course =
                AdaptationCourse::compute(&mut scene, f)?.context("the scene is not animated")?;
            scene.set_frame(f)?;
            let (s, l) = frame_settings(&scene, args, &course)?;
            (s, l, numbered(stem, f))
        }
        None => {
            let (s, l) = still_settings(&scene, args)?;
            (s, l, stem.to_path_buf())
        }
    };
    if (film.width, film.height) != (scene.camera.width, scene.camera.height) {
        bail!(
            "the parts are {}×{} but the scene renders {}×{}",
            film.width,
            film.height,
            scene.camera.width,
            scene.camera.height
        );
    }
    let result = AdaptiveResult {
        stats: RenderStats::default(),
        guide_stats: None,
        passes: Vec::new(),
        stop: StopReason::Budget,
        converged_fraction: 1.0,
        threshold: None,
        error: None,
        units: "",
        decision_time: Duration::ZERO,
        wall: start.elapsed(),
        velocity: aleph::velocity::render_velocity(&scene),
        film,
    };
    let written = write_render(&scene, &stem, &settings, &result, look, false)?;
    println!(
        "{}: merged {n_parts} parts, {:.1} spp, {}×{}, {:.2} s ({read_s:.2} s reading and \
         summing) -> {}, {} ({})",
        scene.path.display(),
        result.mean_spp(),
        scene.camera.width,
        scene.camera.height,
        start.elapsed().as_secs_f64(),
        with_ext(&stem, "exr").display(),
        with_ext(&stem, "png").display(),
        written.look
    );
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recipe_drops_only_what_does_not_change_the_image() {
        let argv: Vec<String> = [
            "s.toml",
            "-o",
            "x",
            "--spp=8",
            "--part",
            "1/2",
            "--threads=3",
            "-oy",
            "--seed",
            "4",
            "--output=z",
            "--threads",
            "2",
        ]
        .map(String::from)
        .to_vec();
        assert_eq!(recipe_args(&argv), ["s.toml", "--spp=8", "--seed", "4"]);
    }
}
