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
use aleph::adaptive::{AdaptiveResult, AdaptiveSettings, SamplerKind, StopReason};
use aleph::deliver::Look;
use aleph::deliver::write_render;
use aleph::display::ToneMapSettings;
use aleph::partial::{
    Merged, merge_parts, part_path, part_range, render_part, tile_of, write_partial,
};
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
    /// The command line after `render`, without `-o`, `--part`, `--tile` and `--threads`.
    args: Vec<String>,
}

/// Options of a render command line that take a value and do not change the image.
const NOT_IN_RECIPE: [&str; 5] = ["-o", "--output", "--part", "--tile", "--threads"];

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

/// Sets the scene to the one frame a part renders and returns that frame's stem.
fn part_frame(scene: &mut Scene, stem: &Path, args: &RenderArgs) -> anyhow::Result<PathBuf> {
    match (args.frames, args.frame, scene.animation) {
        (Some(_), _, _) => bail!("--part/--tile render one frame: give --frame N, not --frames"),
        (None, Some(f), Some(_)) => {
            scene.set_frame(f)?;
            Ok(numbered(stem, f))
        }
        (None, Some(_), None) => bail!(
            "{}: --frame needs an animated scene (this one has no [animation] table)",
            scene.path.display()
        ),
        (None, None, Some(_)) => bail!(
            "{}: --part/--tile on an animated scene render one frame: give --frame N",
            scene.path.display()
        ),
        (None, None, None) => Ok(stem.to_path_buf()),
    }
}

/// The recipe of this command line, as text.
fn recipe_text(args: &RenderArgs) -> anyhow::Result<String> {
    let recipe = Recipe {
        cwd: std::env::current_dir().context("the working directory")?,
        args: recipe_args(&args.argv),
    };
    toml::to_string(&recipe).context("recording the recipe")
}

/// Sampler settings and look of the one frame (`--frame`, already set on `scene`) or still that
/// `args` render, as `aleph render` computes them: a frame's adaptation course runs from the
/// sequence's start.
fn settings_for(scene: &mut Scene, args: &RenderArgs) -> anyhow::Result<(AdaptiveSettings, Look)> {
    match args.frame {
        Some(f) => {
            let course =
                AdaptationCourse::compute(scene, f)?.context("the scene is not animated")?;
            frame_settings(scene, args, &course)
        }
        None => still_settings(scene, args),
    }
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
             and variance samplers split one frame by rows (--tile I/K) or a sequence by \
             frames (docs/farm.md)"
        );
    }
    let stem = part_frame(&mut scene, stem, args)?;
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
    let recipe = recipe_text(args)?;
    let path = part_path(&stem, i, k, false);
    aleph::output::check_output_location(&path)?;
    let start = Instant::now();
    let (part, stats) = render_part(&scene, spp, i, k, recipe, &|_| {});
    write_partial(&path, &part)?;
    let (w, h) = (scene.camera.width, scene.camera.height);
    println!(
        "{}: part {i}/{k}: samples {}..{} of {spp} per pixel, {w}×{h}, {:.2} s ({:.2} s \
         rendering, {:.2} M samples/s) -> {}",
        scene.path.display(),
        part_range(spp, i, k).0,
        part_range(spp, i, k).1,
        start.elapsed().as_secs_f64(),
        stats.wall.as_secs_f64(),
        stats.samples as f64 / stats.wall.as_secs_f64().max(1e-9) / 1e6,
        path.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// Renders row tile `(i, k)` of `scene` (loaded from `args`) adaptively to
/// `STEM[.NNNN].tile-I-of-K.exr`: samples go to the tile's rows and `--tile-margin` rows on
/// each side, with the budget counted over those rows; the file keeps the tile's own rows.
pub(super) fn render_tile_file(
    mut scene: Scene,
    stem: &Path,
    args: &RenderArgs,
    (i, k): (u32, u32),
) -> anyhow::Result<ExitCode> {
    if matches!(args.sampler, SamplerArg::Uniform) {
        bail!(
            "--tile splits an adaptive render by rows; a uniform render splits by samples: --part I/K"
        );
    }
    let stem = part_frame(&mut scene, stem, args)?;
    let h = scene.camera.height;
    if k > h {
        bail!("--tile {i}/{k}: {k} tiles of {h} rows would leave tiles empty");
    }
    let (mut settings, _) = settings_for(&mut scene, args)?;
    let (y0, y1) = part_range(h, i, k);
    let m = args.tile_margin;
    settings.rows = Some((y0.saturating_sub(m), (y1 + m).min(h)));
    let recipe = recipe_text(args)?;
    let path = part_path(&stem, i, k, true);
    aleph::output::check_output_location(&path)?;
    let bar = indicatif::ProgressBar::hidden();
    let r = super::render::render_with_progress(&scene, &settings, &bar, "")?;
    let te = r.threshold.as_deref().zip(r.error.as_deref());
    let part = tile_of(&r.film, (y0, y1), te, i, k, recipe);
    write_partial(&path, &part)?;
    println!(
        "{}: tile {i}/{k}: rows {y0}..{y1} (samples in rows {}..{}), {:.1} spp mean over the \
         tile, {:.1} spp in all, {}, {:.2} s -> {}",
        scene.path.display(),
        y0.saturating_sub(m),
        (y1 + m).min(h),
        part.film.total_samples() as f64 / part.film.len() as f64,
        r.film.total_samples() as f64 / part.film.len() as f64,
        r.stop.describe(),
        r.wall.as_secs_f64(),
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
    let merged = merge_parts(&parts)?;
    let recipe: Recipe = toml::from_str(&merged.recipe)
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
        deliver_merged(merged, &render_args, &stem, n, start, read_s)
    })?
}

/// Loads the recipe's scene and writes the merged film as its render would have been written.
fn deliver_merged(
    merged: Merged,
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
    if let Some(f) = args.frame {
        scene.set_frame(f)?;
    }
    let (settings, look) = settings_for(&mut scene, args)?;
    let stem = match args.frame {
        Some(f) => numbered(stem, f),
        None => stem.to_path_buf(),
    };
    let film = merged.film;
    if (film.width, film.height) != (scene.camera.width, scene.camera.height) {
        bail!(
            "the parts are {}×{} but the scene renders {}×{}",
            film.width,
            film.height,
            scene.camera.width,
            scene.camera.height
        );
    }
    let (threshold, error) = merged.threshold_error.unzip();
    let converged_fraction = match (&threshold, &error) {
        (Some(t), Some(e)) => {
            e.iter().zip(t).filter(|(e, t)| e <= t).count() as f64 / e.len().max(1) as f64
        }
        _ => 1.0,
    };
    let result = AdaptiveResult {
        stats: RenderStats::default(),
        guide_stats: None,
        passes: Vec::new(),
        stop: StopReason::Budget,
        converged_fraction,
        units: if threshold.is_some() {
            settings.units()
        } else {
            ""
        },
        threshold,
        error,
        decision_time: Duration::ZERO,
        wall: start.elapsed(),
        velocity: aleph::velocity::render_velocity(&scene),
        film,
    };
    let written = write_render(&scene, &stem, &settings, &result, look, false)?;
    println!(
        "{}: merged {n_parts} {}, {:.1} spp, {}×{}, {:.2} s ({read_s:.2} s reading and \
         summing) -> {}, {} ({})",
        scene.path.display(),
        if merged.tiles {
            "row tiles"
        } else {
            "sample parts"
        },
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
