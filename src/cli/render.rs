//! `aleph render`.

use super::tonemap::{OperatorArg, ToneArgs};
use super::{parse_resolution, with_threads};
use aleph::display::tone_map;
use aleph::integrator::Strategy;
use aleph::output::{
    AtomicOutputs, ChannelData, auto_exposure_ev, encode_srgb8, expose, write_exr, write_png,
};
use aleph::render::render_uniform;
use aleph::scene::{Scene, SceneDescription};
use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The bundled default scene, found beside the working directory or the source tree.
fn default_scene() -> PathBuf {
    let local = Path::new("scenes/cornell-box/scene.toml");
    if local.exists() {
        return local.to_path_buf();
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/scene.toml")
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML, see docs/scene-format.md). Default: the bundled Cornell box.
    scene: Option<PathBuf>,
    /// Output path without extension: writes OUT.exr and OUT.png. Default: the scene's name
    /// in the current directory.
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
    /// Samples per pixel (overrides the scene's render.spp).
    #[arg(long, value_name = "N")]
    spp: Option<u32>,
    /// Random seed (overrides render.seed).
    #[arg(long, value_name = "S")]
    seed: Option<u64>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Image size WIDTHxHEIGHT (overrides camera.resolution).
    #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
    resolution: Option<(u32, u32)>,
    /// Maximum path depth (overrides render.max_depth).
    #[arg(long, value_name = "N")]
    max_depth: Option<u32>,
    /// Exposure of the PNG in stops (radiance × 2^EV before sRGB encoding) when no --tonemap is
    /// given. Default: automatic, mapping the log-average luminance to 0.18.
    #[arg(
        long,
        value_name = "EV",
        allow_negative_numbers = true,
        conflicts_with = "tonemap"
    )]
    exposure: Option<f32>,
    /// Tone operator for the PNG (the EXR stays linear). Luminance is radiance × the scene's
    /// render.luminance_scale.
    #[arg(long, value_enum, value_name = "OP")]
    tonemap: Option<OperatorArg>,
    #[command(flatten)]
    tone: ToneArgs,
}

/// Output stem: explicit, or the scene's name (its directory's name for `scene.toml`).
fn output_stem(args: &RenderArgs, scene: &Path) -> PathBuf {
    if let Some(o) = &args.output {
        let ext = o
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        return match ext.as_deref() {
            Some("exr") | Some("png") => o.with_extension(""),
            _ => o.clone(),
        };
    }
    let stem = scene.file_stem().map(|s| s.to_string_lossy().to_string());
    let name = match stem.as_deref() {
        Some("scene") | None => scene
            .parent()
            .and_then(|p| p.file_name())
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| "render".into()),
        Some(s) => s.to_string(),
    };
    PathBuf::from(name)
}

fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

pub fn run(args: RenderArgs) -> anyhow::Result<ExitCode> {
    let scene_path = args.scene.clone().unwrap_or_else(default_scene);
    if args.exposure.is_some_and(|e| !e.is_finite()) {
        anyhow::bail!("--exposure must be a finite number of stops");
    }
    let mut desc = SceneDescription::read(&scene_path)?;
    if let Some((w, h)) = args.resolution {
        desc.camera.resolution = [w, h];
    }
    if let Some(s) = args.spp {
        desc.render.spp = Some(s);
    }
    if let Some(s) = args.seed {
        desc.render.seed = Some(s);
    }
    if let Some(d) = args.max_depth {
        desc.render.max_depth = Some(d);
    }
    let stem = output_stem(&args, &scene_path);
    let threads = args.threads;
    let look = Look {
        exposure: args.exposure,
        tonemap: args.tonemap,
        tone: args.tone.clone(),
    };
    with_threads(threads, move || render_and_write(desc, &stem, &look))?
}

/// How the PNG is made from the linear image.
struct Look {
    exposure: Option<f32>,
    tonemap: Option<OperatorArg>,
    tone: ToneArgs,
}

fn render_and_write(desc: SceneDescription, stem: &Path, look: &Look) -> anyhow::Result<ExitCode> {
    let scene = Scene::load_description(desc)?;
    let (w, h) = (scene.camera.width, scene.camera.height);
    let spp = scene.settings.spp;
    let total = w as u64 * h as u64 * spp as u64;
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} rendering [{bar:40}] {percent:>3}% {elapsed}<{eta} {per_sec}",
        )
        .unwrap()
        .progress_chars("=> "),
    );
    let (film, stats) = render_uniform(&scene, Strategy::Mis, spp, &|n| bar.inc(n));
    bar.finish_and_clear();

    let rgb = film.mean_rgb();
    let exr_path = with_ext(stem, "exr");
    let png_path = with_ext(stem, "png");
    let mut out = AtomicOutputs::new();
    let attributes = vec![
        (
            "radianceUnits".to_string(),
            "W.sr^-1.m^-2 (linear Rec.709 RGB)".to_string(),
        ),
        ("sppUnits".to_string(), "samples per pixel".to_string()),
        ("scene".to_string(), scene.path.display().to_string()),
    ];
    out.stage(&exr_path, |wr| {
        write_exr(
            wr,
            &exr_path,
            w,
            h,
            &rgb,
            &[("spp".to_string(), ChannelData::U32(film.spp()))],
            &attributes,
        )
    })?;
    let (display, how) = match look.tonemap {
        Some(op) => {
            let settings =
                look.tone
                    .settings(op.into(), w as usize, scene.settings.luminance_scale)?;
            let d = tone_map(&rgb, w as usize, h as usize, &settings)?;
            (
                encode_srgb8(&d),
                format!("tone operator {}", settings.operator.name()),
            )
        }
        None => {
            let ev = look.exposure.unwrap_or_else(|| auto_exposure_ev(&rgb));
            (encode_srgb8(&expose(&rgb, ev)), format!("{ev:+.2} EV"))
        }
    };
    out.stage(&png_path, |wr| write_png(wr, &png_path, w, h, &display))?;
    out.commit().context("writing outputs")?;

    let secs = stats.wall.as_secs_f64().max(1e-9);
    println!(
        "{}: {w}×{h}, {spp} spp, {:.2} s, {:.2} M samples/s, {:.2} M rays/s, {} non-finite samples dropped -> {}, {} ({how})",
        scene.path.display(),
        secs,
        stats.samples as f64 / secs / 1e6,
        stats.rays as f64 / secs / 1e6,
        stats.nonfinite,
        exr_path.display(),
        png_path.display()
    );
    Ok(ExitCode::SUCCESS)
}
