//! `aleph render`.

use super::tonemap::{OperatorArg, ToneArgs};
use super::{parse_resolution, with_threads};
use aleph::adaptive::{
    AdaptiveResult, AdaptiveSettings, Criterion, ErrorEstimate, PassReport, Visibility,
};
use aleph::display::ToneMapSettings;
use aleph::job::{
    Budget, FrameDone, JobReport, Observer, PartReport, Refined, RenderJob, SamplingOptions,
    SequenceReport, Split, TileReport, scene_name,
};
use aleph::scene::Scene;
use anyhow::Context;
use clap::{Args, ValueEnum};
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use perception::tmo::Operator;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

/// The bundled default scene, found beside the working directory or the source tree.
pub fn default_scene() -> PathBuf {
    let local = Path::new("scenes/cornell-box/scene.toml");
    if local.exists() {
        return local.to_path_buf();
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/scene.toml")
}

/// Samplers on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SamplerArg {
    /// Samples where the remaining error is visible (the threshold map).
    Perceptual,
    /// The same samples everywhere.
    Uniform,
    /// Blender Cycles' noise threshold (the production baseline).
    Variance,
}

impl From<SamplerArg> for Criterion {
    fn from(s: SamplerArg) -> Criterion {
        match s {
            SamplerArg::Perceptual => Criterion::Perceptual,
            SamplerArg::Uniform => Criterion::Uniform,
            SamplerArg::Variance => Criterion::Variance,
        }
    }
}

/// Error estimates on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ErrorEstimateArg {
    /// k |Y(A) − Y(B)| of the two half-buffers: the power-of-two blocks of each pixel's
    /// sequence (k = √(n_A n_B)/n, ½ for equal halves).
    HalfBuffers,
    /// sqrt(var(Y) / n) from the sum of squared luminance.
    StandardError,
}

/// The final denoising's model on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum DenoiseQualityArg {
    /// OIDN's high-quality filter (its large model for clean auxiliary images up to 16 spp).
    High,
    /// OIDN's fast filter.
    Fast,
}

impl From<DenoiseQualityArg> for aleph::denoise::FinalQuality {
    fn from(q: DenoiseQualityArg) -> Self {
        match q {
            DenoiseQualityArg::High => aleph::denoise::FinalQuality::High,
            DenoiseQualityArg::Fast => aleph::denoise::FinalQuality::Fast,
        }
    }
}

/// Where visibility is judged.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum VisibilityArg {
    /// On the displayed image, in display cd/m² after the tone curve.
    Display,
    /// In scene luminance, cd/m² = Y × render.luminance_scale (Ramasubramanian et al.).
    Scene,
}

/// Sampling options shared by `render` and `speedup`.
#[derive(Args, Debug, Clone)]
pub struct SamplingArgs {
    /// Samples of the first, uniform pass of the adaptive samplers (at least 32 for the
    /// perceptual stop with --denoise; 2 for --preview).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 8,
        help_heading = "Adaptive sampling"
    )]
    pub min_spp: u32,
    /// Cap on any one pixel's samples of the adaptive samplers (a uniform render takes its
    /// --spp everywhere; an adaptive --spp above the cap is refused).
    #[arg(
        long,
        value_name = "N",
        default_value_t = 4096,
        help_heading = "Adaptive sampling"
    )]
    pub max_spp: u32,
    /// The smallest --spp budget the adaptive samplers steer: a smaller one is rendered
    /// uniformly and nothing is judged (below 128 spp the decisions measured costlier than
    /// their savings). 0 steers every budget. Default 128; with --denoise no budget is
    /// steered (with the denoiser in its loop the sampler measured no better than uniform
    /// sampling with the same denoiser, in more time), unless this is given.
    #[arg(long, value_name = "SPP", help_heading = "Adaptive sampling")]
    pub steer_from: Option<f64>,
    /// Stop after this many seconds of rendering: the passes, the guide and the decisions
    /// between them (loading the scene and writing the outputs come on top). The last pass is
    /// sized from the measured sample rate to land on the budget. The image then depends on
    /// the machine's speed.
    #[arg(long, value_name = "SECONDS", help_heading = "Adaptive sampling")]
    pub time: Option<f64>,
    /// Where visibility is judged.
    #[arg(
        long,
        value_enum,
        default_value = "display",
        help_heading = "Adaptive sampling"
    )]
    pub visibility: VisibilityArg,
    /// Fraction of pixels below threshold at which a render without --spp stops (default: 0.8
    /// for the perceptual sampler on a still, with --denoise or not; 0.995 for a sequence's
    /// frames and for the variance sampler). A budget's even fill does not depend on it.
    #[arg(long, value_name = "F", help_heading = "Adaptive sampling")]
    pub converged: Option<f64>,
    /// Noise threshold of the variance sampler (Cycles' default 0.01).
    #[arg(
        long,
        value_name = "T",
        default_value_t = 0.01,
        help_heading = "Adaptive sampling"
    )]
    pub noise_threshold: f32,
    /// Antialiasing samples per pixel of the albedo guide that sets the perceptual masking.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 4,
        help_heading = "Adaptive sampling"
    )]
    pub guide_spp: u32,
    /// Error estimate of the perceptual sampler: half-buffer difference or standard error.
    #[arg(
        long,
        value_enum,
        default_value = "half-buffers",
        help_heading = "Adaptive sampling"
    )]
    pub error_estimate: ErrorEstimateArg,
    /// Saliency weight ω: salient regions (Itti–Koch–Niebur) get thresholds ΔL/(1 + ω S),
    /// Yee et al.'s Aleph map. 0 turns it off.
    #[arg(
        long,
        value_name = "W",
        default_value_t = 0.0,
        help_heading = "Adaptive sampling"
    )]
    pub saliency: f32,
    /// Window of the local adaptation luminance for the perceptual threshold, degrees.
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 1.0,
        help_heading = "Adaptive sampling"
    )]
    pub adaptation_window: f64,
    /// Exposure latitude of the perceptual threshold, stops: noise stays invisible on the image
    /// as displayed and graded this many stops darker and brighter. 0: as displayed only.
    #[arg(
        long,
        value_name = "EV",
        default_value_t = 2.0,
        help_heading = "Adaptive sampling"
    )]
    pub latitude: f64,
    /// Pixels per degree of the viewer, 1e-6 to 1000 (default: FLIP's 0.7 m, 3840-pixel
    /// monitor at 0.7 m, 67.0 ppd).
    #[arg(long, value_name = "PPD", help_heading = "Adaptive sampling")]
    pub ppd: Option<f64>,
    /// Sequences: ignore the velocity map in the perceptual threshold (judge every frame as a
    /// still; for comparisons).
    #[arg(long, help_heading = "Adaptive sampling")]
    pub no_velocity: bool,
    /// Sequences: each frame reuses every fresh sample of up to K frames before it (the
    /// perceptual sampler; a frame rendered alone first renders the base passes of the K frames
    /// before those and then those K frames whole). 0 renders independent frames. Default: 15 for the perceptual sampler, 0 for the others and with --time.
    /// Under --spp N the animation's first frame, which has nothing to reuse, draws
    /// N · (1 + 0.2 (K − 1)) fresh spp and the K − 1 frames after it 0.8 N each, so that the
    /// first K frames take K · N; each frame's summary line gives its own.
    #[arg(long, value_name = "K", help_heading = "Adaptive sampling")]
    pub reuse_window: Option<u32>,
    /// Sequences: memory reuse across frames may take, GiB (the window's frames, their kept
    /// samples and their landing), from 1 MiB. It decides how many samples a pixel keeps for
    /// the frames after it, and cuts the window where its frames do not fit (the sequence's
    /// summary says so): 8 GiB holds 15 frames at 1920×1080, 3 at 3840×2160.
    #[arg(
        long,
        value_name = "GiB",
        default_value_t = 8.0,
        help_heading = "Adaptive sampling"
    )]
    pub reuse_memory: f64,
}

impl SamplingArgs {
    /// The adaptive-loop options of a render job.
    pub fn options(&self) -> SamplingOptions {
        SamplingOptions {
            min_spp: self.min_spp,
            max_spp: self.max_spp,
            steer_from_spp: self.steer_from,
            converged_fraction: self.converged,
            visibility: match self.visibility {
                VisibilityArg::Display => Visibility::Display,
                VisibilityArg::Scene => Visibility::Scene,
            },
            noise_threshold: self.noise_threshold,
            guide_spp: self.guide_spp,
            error_estimate: match self.error_estimate {
                ErrorEstimateArg::HalfBuffers => ErrorEstimate::HalfBuffers,
                ErrorEstimateArg::StandardError => ErrorEstimate::StandardError,
            },
            saliency: self.saliency,
            adaptation_window_deg: self.adaptation_window,
            latitude_ev: self.latitude,
            ppd: self.ppd,
            use_velocity: !self.no_velocity,
            reuse_window: self.reuse_window,
            reuse_memory_gib: self.reuse_memory,
        }
    }

    /// Adaptive settings for `criterion` with an optional average budget, through the same
    /// render job `aleph render` builds.
    pub fn settings(
        &self,
        criterion: Criterion,
        budget: Option<f64>,
        uniform_spp: u32,
        tone: ToneMapSettings,
    ) -> anyhow::Result<AdaptiveSettings> {
        let mut job = RenderJob::new(PathBuf::new());
        job.criterion = criterion;
        job.budget = Budget {
            spp: budget,
            time_s: self.time,
        };
        job.sampling = self.options();
        Ok(job.adaptive_settings(uniform_spp, tone)?)
    }
}

#[derive(Args, Debug)]
#[command(group(clap::ArgGroup::new("frame_choice").args(["frames", "frame"])))]
pub struct RenderArgs {
    /// Scene file (TOML, see docs/scene-format.md). Default: the bundled Cornell box.
    pub(super) scene: Option<PathBuf>,
    /// Output path without extension: writes OUT.exr and OUT.png. Default: the scene's name
    /// in the current directory.
    #[arg(short, long, value_name = "OUT")]
    pub(super) output: Option<PathBuf>,
    /// Sampler: perceptual (default) runs until the noise is invisible; uniform and variance are
    /// the baselines.
    #[arg(long, value_enum, default_value = "perceptual")]
    pub(super) sampler: SamplerArg,
    /// Average samples per pixel (N × pixels in total, for every sampler). Without it,
    /// perceptual and variance run until converged and uniform uses the scene's render.spp.
    #[arg(long, value_name = "N")]
    pub(super) spp: Option<f64>,
    /// Random seed (overrides render.seed).
    #[arg(long, value_name = "S")]
    pub(super) seed: Option<u64>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, value_name = "N")]
    pub(super) threads: Option<usize>,
    /// Image size WIDTHxHEIGHT (overrides camera.resolution).
    #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
    pub(super) resolution: Option<(u32, u32)>,
    /// Maximum path depth (overrides render.max_depth).
    #[arg(long, value_name = "N")]
    pub(super) max_depth: Option<u32>,
    /// A plain exposure for the PNG, in stops (radiance × 2^EV before sRGB encoding, clipping
    /// at white), instead of the default display: Reinhard et al. 2002's global operator (key
    /// 0.18, white at the brightest pixel), which keeps highlights. The perceptual sampler then
    /// judges with the automatic exposure (log-average luminance to 0.18).
    #[arg(
        long,
        value_name = "EV",
        allow_negative_numbers = true,
        conflicts_with = "tonemap"
    )]
    pub(super) exposure: Option<f32>,
    /// Tone operator for the PNG (the EXR stays linear) and for display visibility (default for
    /// a still: reinhard). Luminance is radiance × the scene's render.luminance_scale.
    #[arg(long, value_enum, value_name = "OP")]
    pub(super) tonemap: Option<OperatorArg>,
    /// Also write false-colour PNGs: OUT.spp.png (samples per pixel, log scale) and
    /// OUT.ratio.png (error / threshold, log scale from 1/16 to 16).
    #[arg(long)]
    pub(super) aov: bool,
    /// Denoise the image with Intel Open Image Denoise, given the albedo and normal of the
    /// first non-specular surface (16 spp): OUT.png and the EXR's RGB are denoised, the raw
    /// render is kept as Noisy.R/G/B. Needs a build with `--features denoise`
    /// (docs/denoise.md).
    #[arg(long)]
    pub(super) denoise: bool,
    /// The model the final image is denoised by, as Blender's denoiser quality: high (OIDN's
    /// high-quality filter; its large model for clean auxiliary images up to 16 spp) or fast
    /// (OIDN's fast filter: quicker, a worse image per sample; docs/denoise.md).
    #[arg(long, value_enum, value_name = "Q", default_value = "high")]
    pub(super) denoise_quality: DenoiseQualityArg,
    /// A progressive preview of a still: the perceptual sampler from 2 spp, denoised when the
    /// build has the denoiser, OUT.png rewritten (atomically) after every pass until the
    /// perceptual stop or --time; OUT.exr at the end (docs/denoise.md).
    #[arg(long)]
    pub(super) preview: bool,
    /// Frames of an animated scene to render, FIRST-LAST (inclusive; default: the scene's whole
    /// [animation] range). Outputs are numbered OUT.0001.exr, OUT.0001.png, …, plus
    /// OUT.preview.png (an animated PNG) and OUT.filmstrip.png.
    #[arg(long, value_name = "A-B", value_parser = parse_frames, help_heading = "Sequences")]
    pub(super) frames: Option<(i64, i64)>,
    /// One frame of an animated scene (the same image as inside the sequence).
    #[arg(
        long,
        value_name = "N",
        allow_negative_numbers = true,
        help_heading = "Sequences"
    )]
    pub(super) frame: Option<i64>,
    /// Render part I of K of a uniform render's samples (I from 1; samples (I−1)·N/K ..
    /// I·N/K of every pixel, N = --spp) to OUT.part-I-of-K.exr, a partial film. `aleph merge`
    /// sums the K parts into the image a single render gives, bit for bit. Uniform sampler,
    /// one still or one --frame.
    #[arg(long, value_name = "I/K", value_parser = parse_part, help_heading = "Render farms", conflicts_with = "tile")]
    pub(super) part: Option<(u32, u32)>,
    /// Render row tile I of K of an adaptive render (rows (I−1)·H/K .. I·H/K, samples also in
    /// --tile-margin rows on each side, --spp counted over those rows) to
    /// OUT.tile-I-of-K.exr; `aleph merge` assembles the K tiles. Perceptual or variance
    /// sampler, one still or one --frame. Not identical to a single render (docs/farm.md).
    #[arg(long, value_name = "I/K", value_parser = parse_part, help_heading = "Render farms")]
    pub(super) tile: Option<(u32, u32)>,
    /// Rows on each side of a --tile that also take samples, so that the tile's threshold map
    /// sees converged neighbours.
    #[arg(
        long,
        value_name = "ROWS",
        default_value_t = 16,
        help_heading = "Render farms"
    )]
    pub(super) tile_margin: u32,
    #[command(flatten)]
    pub(super) sampling: SamplingArgs,
    #[command(flatten)]
    pub(super) tone: ToneArgs,
}

/// Parses `I/K` with 1 ≤ I ≤ K.
pub(super) fn parse_part(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected I/K with 1 ≤ I ≤ K (part I of K), got {s:?}");
    let (i, k) = s.split_once('/').ok_or_else(bad)?;
    let (i, k): (u32, u32) = (
        i.trim().parse().map_err(|_| bad())?,
        k.trim().parse().map_err(|_| bad())?,
    );
    if i == 0 || i > k {
        return Err(bad());
    }
    Ok((i, k))
}

/// Parses `A-B`, `A..B` or a single frame `N`.
pub(super) fn parse_frames(s: &str) -> Result<(i64, i64), String> {
    let t = s.trim();
    let pair = t.split_once("..").or_else(|| {
        t.get(1..)
            .and_then(|r| r.split_once('-'))
            .map(|(a, b)| (&t[..a.len() + 1], b))
    });
    let (a, b) = pair.unwrap_or((t, t));
    let num = |v: &str| {
        v.trim()
            .parse::<i64>()
            .map_err(|_| format!("expected FIRST-LAST frame numbers, got {s:?}"))
    };
    let (a, b) = (num(a)?, num(b)?);
    if a > b {
        return Err(format!("the first frame ({a}) is after the last ({b})"));
    }
    Ok((a, b))
}

/// Output stem of `-o`: an `.exr`/`.png` extension is dropped.
pub(super) fn strip_image_ext(o: &Path) -> PathBuf {
    let ext = o
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("exr") | Some("png") => o.with_extension(""),
        _ => o.to_path_buf(),
    }
}

impl RenderArgs {
    /// The render job these arguments describe: the scene made absolute, `-o` (or the scene's
    /// name in the working directory) as the output stem.
    pub(super) fn job(&self) -> anyhow::Result<RenderJob> {
        let scene = self.scene.clone().unwrap_or_else(default_scene);
        let absolute =
            std::path::absolute(&scene).with_context(|| format!("{}", scene.display()))?;
        let mut job = RenderJob::new(absolute);
        job.criterion = self.sampler.into();
        job.frames = match (self.frames, self.frame) {
            (Some((a, b)), _) => Some([a, b]),
            (None, Some(f)) => Some([f, f]),
            (None, None) => None,
        };
        job.scene.resolution = self.resolution.map(|(w, h)| [w, h]);
        job.scene.seed = self.seed;
        job.scene.max_depth = self.max_depth;
        job.budget = Budget {
            spp: self.spp,
            time_s: self.sampling.time,
        };
        job.sampling = self.sampling.options();
        job.display = self
            .tone
            .display(self.tonemap.map(Operator::from), self.exposure);
        job.split = match (self.part, self.tile) {
            (Some((index, count)), _) => Some(Split::Part { index, count }),
            (None, Some((index, count))) => Some(Split::Tile {
                index,
                count,
                margin: self.tile_margin,
            }),
            (None, None) => None,
        };
        job.output.stem = Some(match &self.output {
            Some(o) => strip_image_ext(o),
            None => PathBuf::from(scene_name(&scene)),
        });
        job.output.aov = self.aov;
        job.output.denoise = self.denoise;
        job.output.denoise_quality = self.denoise_quality.into();
        job.output.preview = self.preview;
        job.validate()?;
        Ok(job)
    }
}

pub use aleph::deliver::with_ext;

pub fn run(args: RenderArgs) -> anyhow::Result<ExitCode> {
    let job = args.job()?;
    with_threads(args.threads, move || run_job(&job))?
}

/// Renders `job` with progress bars on stderr and a summary line per frame (and per part,
/// tile or sequence) on stdout.
pub(super) fn run_job(job: &RenderJob) -> anyhow::Result<ExitCode> {
    let start = std::time::Instant::now();
    let scene = job.load_scene()?;
    eprintln!("{}", load_line(&scene, start.elapsed()));
    let observer = CliObserver::new(job.criterion.name());
    let report = aleph::job::run_on(job, &scene, &observer);
    observer.finish();
    match report? {
        JobReport::Still => {}
        JobReport::Sequence(r) => {
            if r.previews.is_some() {
                println!("{}", sequence_line(&scene, &r));
            }
        }
        JobReport::Part(r) => println!("{}", part_line(&scene, &r)),
        JobReport::Tile(r) => println!("{}", tile_line(&scene, &r)),
    }
    Ok(ExitCode::SUCCESS)
}

/// Progress bars (a sequence's frames, the current frame's passes) and summary lines.
struct CliObserver {
    multi: MultiProgress,
    /// Whether the black-image warning was given (once per render).
    warned_black: std::sync::atomic::AtomicBool,
    sequence: std::sync::Mutex<Option<ProgressBar>>,
    frame: ProgressBar,
    criterion: &'static str,
}

impl CliObserver {
    fn new(criterion: &'static str) -> CliObserver {
        let multi = MultiProgress::with_draw_target(ProgressDrawTarget::stderr());
        let frame = multi.add(ProgressBar::new_spinner());
        frame.set_style(ProgressStyle::with_template("{spinner} {elapsed} {msg}").unwrap());
        frame.enable_steady_tick(Duration::from_millis(200));
        CliObserver {
            multi,
            warned_black: Default::default(),
            sequence: std::sync::Mutex::new(None),
            frame,
            criterion,
        }
    }

    fn finish(&self) {
        self.frame.finish_and_clear();
        if let Some(bar) = self.sequence.lock().unwrap().take() {
            bar.finish_and_clear();
        }
    }
}

impl Observer for CliObserver {
    fn sequence_started(&self, first: i64, last: i64) {
        let bar = self
            .multi
            .insert(0, ProgressBar::new(last.abs_diff(first) + 1));
        bar.set_style(
            ProgressStyle::with_template(
                "sequence {pos}/{len} frames [{bar:30}] {elapsed} (eta {eta})",
            )
            .unwrap(),
        );
        *self.sequence.lock().unwrap() = Some(bar);
    }

    fn pass(&self, frame: Option<i64>, p: &PassReport) {
        let prefix = frame.map(|f| format!("frame {f}: ")).unwrap_or_default();
        self.frame.set_message(format!(
            "{prefix}{}: pass {}, {:.1} spp mean, {:.1} % converged",
            self.criterion,
            p.pass,
            p.mean_spp,
            100.0 * p.converged_fraction
        ));
    }

    fn refined(&self, r: &Refined<'_>) {
        let what = if r.denoised {
            "denoised"
        } else {
            "not denoised: this build has no denoiser"
        };
        self.multi.suspend(|| {
            eprintln!(
                "preview {}: {:.1} spp mean, {what}, at {:.2} s -> {}",
                r.number,
                r.mean_spp,
                r.elapsed.as_secs_f64(),
                r.path.display()
            )
        });
    }

    fn frame_done(&self, d: &FrameDone<'_>) {
        let stem = d.stem.map(Path::to_path_buf).unwrap_or_default();
        let line = summary_line(d.scene, d.settings, d.result, &stem, d.look);
        self.multi.suspend(|| println!("{line}"));
        let black = d
            .result
            .film
            .pixels
            .iter()
            .all(|p| p.sum() == glam::DVec3::ZERO);
        if black
            && !self
                .warned_black
                .swap(true, std::sync::atomic::Ordering::Relaxed)
        {
            let frame = d
                .scene
                .animation
                .map(|_| format!(" frame {}", d.scene.frame.index));
            self.multi.suspend(|| {
                eprintln!(
                    "warning: {}{}: the image is black (no light reaches the camera); written \
                     as rendered",
                    d.scene.path.display(),
                    frame.unwrap_or_default()
                )
            });
        }
        if let Some(bar) = self.sequence.lock().unwrap().as_ref() {
            bar.inc(1);
        }
        self.frame.reset_elapsed();
    }
}

/// The closing line of a sequence.
fn sequence_line(scene: &Scene, r: &SequenceReport) -> String {
    let (first, last) = r.frames;
    let n = (last - first + 1) as f64;
    let wall = r.wall.as_secs_f64();
    let (preview, strip) = r.previews.clone().unwrap_or_default();
    let (k, asked) = r.reuse_window;
    let reuse = match (k, asked) {
        (0, 0) => String::new(),
        (k, asked) if k == asked => format!(", reuse window {k}"),
        (k, asked) => format!(
            ", reuse window {k} (of {asked}: what --reuse-memory holds at {}×{})",
            scene.camera.width, scene.camera.height
        ),
    };
    format!(
        "{}: sequence of {n} frames ({first}-{last} at {} fps{reuse}), {:.1} spp mean, \
         {wall:.1} s ({:.2} s/frame; {:.2} s adaptation pre-passes, {:.2} s perception) -> {}, \
         {}",
        scene.path.display(),
        r.fps,
        r.mean_spp,
        wall / n,
        r.prepass.as_secs_f64(),
        r.perception.as_secs_f64(),
        preview.display(),
        strip.display(),
    )
}

/// The line of a sample part.
fn part_line(scene: &Scene, r: &PartReport) -> String {
    let ((i, k), (a, b)) = (r.part, r.samples);
    let secs = r.stats.wall.as_secs_f64();
    format!(
        "{}: part {i}/{k}: samples {a}..{b} of {} per pixel, {}×{}, {secs:.2} s rendering, \
         {:.2} M samples/s -> {}",
        scene.path.display(),
        r.spp,
        scene.camera.width,
        scene.camera.height,
        r.stats.samples as f64 / secs.max(1e-9) / 1e6,
        r.path.display()
    )
}

/// The line of a row tile.
fn tile_line(scene: &Scene, r: &TileReport) -> String {
    let ((i, k), (y0, y1), (s0, s1)) = (r.tile, r.rows, r.sampled_rows);
    format!(
        "{}: tile {i}/{k}: rows {y0}..{y1} (samples in rows {s0}..{s1}), {:.1} spp mean over \
         the tile, {:.1} spp in all, {}, {:.2} s -> {}",
        scene.path.display(),
        r.mean_spp.0,
        r.mean_spp.1,
        r.stop.describe(),
        r.wall.as_secs_f64(),
        r.path.display()
    )
}

/// Where a render's wall time went: first pass, later passes, guide, perception.
fn time_split(r: &AdaptiveResult) -> String {
    let first = r.passes.first().map(|p| p.render).unwrap_or_default();
    let later: Duration = r.passes.iter().skip(1).map(|p| p.render).sum();
    let mut parts = vec![format!("first pass {:.2} s", first.as_secs_f64())];
    if r.passes.len() > 1 {
        parts.push(format!(
            "{} more passes {:.2} s",
            r.passes.len() - 1,
            later.as_secs_f64()
        ));
    }
    if let Some(g) = r.guide_stats {
        parts.push(format!("guide {:.2} s", g.wall.as_secs_f64()));
        parts.push(format!("perception {:.2} s", r.decision_time.as_secs_f64()));
    }
    if let Some(reuse) = &r.reuse {
        parts.push(format!("reprojection {:.2} s", reuse.time.as_secs_f64()));
    }
    parts.join(", ")
}

/// What loading cost: triangles, lights, wall time of the whole load and of the BVH build.
pub(super) fn load_line(scene: &Scene, load: std::time::Duration) -> String {
    let l = &scene.lights;
    let mut lights = vec![format!("{} emissive triangles", l.triangle_count())];
    if l.environment().is_some() {
        lights.push("an environment".into());
    }
    let suns = l.suns().count();
    if suns > 0 {
        lights.push(format!("{suns} sun(s)"));
    }
    let points = l.points().count();
    if points > 0 {
        lights.push(format!("{points} point/spot light(s)"));
    }
    format!(
        "{}: {} triangles, {}; loaded in {:.2} s (BVH build {:.2} s)",
        scene.path.display(),
        scene.geometry.len(),
        lights.join(", "),
        load.as_secs_f64(),
        scene.geometry.build_time.as_secs_f64()
    )
}

/// "N spp reused from K earlier frames at P % of pixels".
fn reused(r: &aleph::adaptive::ReuseReport) -> String {
    format!(
        "{:.1} spp reused from {} earlier frames at {:.1} % of pixels",
        r.mean_history_spp,
        r.frames,
        100.0 * r.reused_fraction
    )
}

/// Why a budget was not steered, for the summary line: under `--steer-from`, or a budget with
/// the denoiser ([`aleph::job::DENOISED_STEER_FROM_SPP`]).
fn unsteered(settings: &AdaptiveSettings) -> String {
    if settings.steer_from_spp == aleph::job::DENOISED_STEER_FROM_SPP {
        "a budget with --denoise (--steer-from steers it)".to_string()
    } else {
        format!("budget under --steer-from {} spp", settings.steer_from_spp)
    }
}

/// The one-line summary of a render.
pub(super) fn summary_line(
    scene: &Scene,
    settings: &AdaptiveSettings,
    result: &AdaptiveResult,
    stem: &Path,
    look: &str,
) -> String {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let secs = result.wall.as_secs_f64().max(1e-9);
    let st = &result.stats;
    let guide = result.guide_stats.map(|g| g.samples).unwrap_or(0);
    let frame = match scene.animation {
        Some(_) => format!(" frame {}", scene.frame.index),
        None => String::new(),
    };
    format!(
        "{}{frame}: {w}×{h}, {} sampler, {:.1} spp mean ({} passes{}), {}, {}, \
         {:.2} s ({}), {:.2} M samples/s, {:.2} M rays/s, {} non-finite samples dropped, \
         viewer at {:.1} pixels per degree -> {}, {} ({look})",
        scene.path.display(),
        settings.criterion.name(),
        result.mean_spp(),
        result.passes.len(),
        match (guide > 0, &result.reuse) {
            (true, Some(r)) => format!(
                " + {:.1} spp guide; {}",
                guide as f64 / (w * h) as f64,
                reused(r)
            ),
            (false, Some(r)) => format!("; {}", reused(r)),
            (true, None) => format!(" + {:.1} spp guide", guide as f64 / (w * h) as f64),
            (false, None) => String::new(),
        },
        result.stop.describe(),
        match result.threshold {
            Some(_) => format!(
                "{:.1} % of pixels below threshold",
                100.0 * result.converged_fraction
            ),
            None if result.reuse.is_some() => {
                let why = unsteered(settings);
                format!("{why}: fresh samples levelled with the reused ones, nothing judged")
            }
            None if settings.criterion != Criterion::Uniform && !settings.steers() => {
                format!(
                    "{}: rendered uniformly, nothing judged",
                    unsteered(settings)
                )
            }
            None => "no threshold judged".to_string(),
        },
        secs,
        time_split(result),
        (st.samples + guide) as f64 / st.wall.as_secs_f64().max(1e-9) / 1e6,
        st.rays as f64 / st.wall.as_secs_f64().max(1e-9) / 1e6,
        st.nonfinite,
        settings.tone.view.ppd,
        with_ext(stem, "exr").display(),
        with_ext(stem, "png").display(),
    )
}
