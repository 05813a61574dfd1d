//! Render jobs: what to render, as one record.
//!
//! A [`RenderJob`] says everything that decides a render's pixels and files: the scene (a path
//! plus overrides of its resolution, seed and path depth), the sampling rule ([`Criterion`])
//! and its options, the budget (samples per pixel, time, or until converged), the display the
//! image is judged and tone mapped for, the frames of a sequence, a split of one frame across
//! machines (a sample part or a row tile), and the outputs. The CLI turns its arguments into a
//! job; the farm's manifest and every partial film store the job as their record (TOML,
//! versioned: [`RenderJob::from_toml`] refuses a record of another version or with unknown
//! fields); [`run`] renders one. The Python bindings build the same jobs.
//!
//! A job never says how many threads to use: that changes no pixel (renders are deterministic
//! per (seed, pixel, sample index)).

mod driver;
mod merge;
mod observer;

pub use driver::{JobReport, PartReport, SequenceReport, TileReport, run, run_on};
pub use merge::{MergeReport, merge};
pub use observer::{FrameDone, Observer, Refined};

use crate::adaptive::{
    AdaptiveError, AdaptiveSettings, Criterion, ErrorEstimate, PerceptualSettings, Visibility,
};
use crate::deliver::Look;
use crate::display::ToneMapSettings;
use crate::error::SceneError;
use crate::scene::{Scene, SceneDescription};
use perception::adaptation::AdaptationMode;
use perception::tmo::pattanaik00::AdaptationState;
use perception::tmo::{Display, Operator};
use perception::viewing::ViewingConditions;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The record version this aleph writes and reads (the `version` key of a job's TOML).
pub const JOB_VERSION: u32 = 1;

/// One render: see the module docs. `Default` is the bundled defaults for a scene path that
/// must still be set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderJob {
    /// Record version, [`JOB_VERSION`].
    pub version: u32,
    /// The adaptive decision rule (`perceptual`, `uniform`, `variance`).
    pub criterion: Criterion,
    /// The frames `[first, last]` of an animated scene (inclusive). `None`: a still, or the
    /// whole animation of an animated scene.
    pub frames: Option<[i64; 2]>,
    /// The scene and its overrides.
    pub scene: SceneSpec,
    /// How much to render.
    #[serde(default)]
    pub budget: Budget,
    /// Options of the adaptive loop.
    #[serde(default)]
    pub sampling: SamplingOptions,
    /// The display: tone operator or exposure, display luminances, field of view.
    #[serde(default)]
    pub display: DisplaySpec,
    /// Part of one frame, for a farm (`None`: the whole frame).
    pub split: Option<Split>,
    /// Where the files go.
    #[serde(default)]
    pub output: OutputSpec,
}

/// The scene of a job.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// The scene file (TOML; docs/scene-format.md). The CLI makes it absolute.
    pub path: PathBuf,
    /// Image size `[width, height]` in pixels, instead of `camera.resolution`.
    pub resolution: Option<[u32; 2]>,
    /// Random seed, instead of `render.seed`.
    pub seed: Option<u64>,
    /// Maximum path depth, instead of `render.max_depth`.
    pub max_depth: Option<u32>,
    /// SHA-256 of the scene file's bytes, hex: set in records (partial films), so that parts
    /// are matched by the scene's content, not by where it was on each machine.
    pub content_hash: Option<String>,
}

/// How much to render. Neither set: the adaptive rules run until converged, the uniform rule
/// takes the scene's `render.spp`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Budget {
    /// Average samples per pixel (N × pixels in all, for every rule), at least 1.
    pub spp: Option<f64>,
    /// Seconds of rendering (passes, guide and decisions), positive.
    pub time_s: Option<f64>,
}

/// Options of the adaptive loop ([`AdaptiveSettings`] has the meaning of each).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SamplingOptions {
    /// Samples of the first, uniform pass (default 8; at least [`DENOISED_STOP_MIN_SPP`] for
    /// the stop with the denoiser, [`PREVIEW_MIN_SPP`] for a preview).
    pub min_spp: u32,
    /// Cap on any one pixel's samples (default 4096).
    pub max_spp: u32,
    /// The smallest budget the adaptive rules steer, spp. `None` (the default):
    /// [`crate::adaptive::STEER_FROM_SPP`] (128), and with the denoiser no budget is steered
    /// ([`DENOISED_STEER_FROM_SPP`]).
    pub steer_from_spp: Option<f64>,
    /// Fraction of pixels below threshold at which a render without a budget stops; `None`
    /// (the default): the rule's own ([`Criterion::default_converged_fraction`]: 0.8 for the
    /// perceptual rule, 0.995 for the variance rule).
    pub converged_fraction: Option<f64>,
    /// Where visibility is judged (default: display).
    pub visibility: Visibility,
    /// Cycles' noise threshold of the variance rule (default 0.01).
    pub noise_threshold: f32,
    /// Samples per pixel of the albedo guide (default 4).
    pub guide_spp: u32,
    /// The perceptual rule's error estimate (default: half-buffers).
    pub error_estimate: ErrorEstimate,
    /// Saliency weight ω of the Aleph map (Yee et al. 2001; default 0, off).
    pub saliency: f32,
    /// Window of the local adaptation luminance, degrees (default 1).
    pub adaptation_window_deg: f64,
    /// Exposure latitude of the threshold, stops (default 2).
    pub latitude_ev: f64,
    /// Pixels per degree of the viewer (default: the display's, 67.0 ppd).
    pub ppd: Option<f64>,
    /// Whether a sequence's velocity map enters the threshold (default true).
    pub use_velocity: bool,
    /// Reuse across frames: each frame reuses the samples of up to K frames before it
    /// ([`crate::reuse`]). `None` (default): [`DEFAULT_REUSE_WINDOW`] for a sequence rendered
    /// by the perceptual sampler without a time budget or split, else 0 (independent frames).
    pub reuse_window: Option<u32>,
    /// Memory reuse across frames may take, GiB (default 8, [`crate::reuse::DEFAULT_MEMORY`]):
    /// the window's frames, their kept samples and their landing in the current frame. Decides
    /// how many samples a pixel keeps ([`crate::reuse::kept_spp`]) and cuts the window where
    /// its frames' records do not fit ([`RenderJob::reuse_window_for`]), so it decides pixels:
    /// a farm's chunks take the job's value.
    pub reuse_memory_gib: f64,
}

/// The smallest budget the adaptive samplers steer when the image is denoised and the job
/// names none (`sampling.steer_from_spp`, `--steer-from`): none, every `--spp` budget is
/// rendered uniformly and denoised. Measured (docs/denoise.md, "Under a budget, uniform"):
/// with the denoiser in the loop, against uniform sampling with the same denoiser, four seeds,
/// the Cornell box at 256² scored lower by JOD at every budget from 4 to 256 spp (0.69–0.85×
/// the samples at equal JOD at 4–32 spp; at 128 / 256 spp JOD 9.973 / 9.983 against 9.976 /
/// 9.985, FLIP p99 0.0892 / 0.0734 against 0.0871 / 0.0708) and the Mori knob at 256×170
/// level by JOD and lower by FLIP p99 at 128 / 256 spp, while the loop took 1.19× and 1.28×
/// the wall time at 128 spp (`farm-bench`, 5 pairs each) and 4.0× / 2.6× the peak memory. The
/// stop without a budget keeps the denoiser in its loop.
pub const DENOISED_STEER_FROM_SPP: f64 = f64::MAX;

/// The reuse window of a perceptual sequence when the job names none, frames. Measured
/// (docs/reuse.md, video JOD at 2–16 fresh spp): 15 against 7 gives the holodeck pan 3.8–4.0×
/// fewer fresh samples than independent frames at equal JOD instead of 2.7–3.0×, the Lost Empire
/// walkthrough 1.4–2.0× instead of 1.3–1.7×, and the moving-sphere box the same scores.
pub const DEFAULT_REUSE_WINDOW: u32 = 15;

/// Bytes in a GiB.
const GIB: f64 = (1u64 << 30) as f64;

/// The smallest reuse memory a job takes, GiB (1 MiB).
pub const MIN_REUSE_MEMORY_GIB: f64 = 1.0 / 1024.0;

impl SamplingOptions {
    /// [`Self::reuse_memory_gib`] in bytes.
    pub fn reuse_memory(&self) -> u64 {
        (self.reuse_memory_gib * GIB) as u64
    }
}

impl Default for SamplingOptions {
    fn default() -> Self {
        let a = AdaptiveSettings::default();
        SamplingOptions {
            min_spp: a.min_spp,
            max_spp: a.max_spp,
            steer_from_spp: None,
            converged_fraction: None,
            visibility: a.perceptual.visibility,
            noise_threshold: a.variance_threshold,
            guide_spp: a.perceptual.guide_spp,
            error_estimate: a.perceptual.error_estimate,
            saliency: a.perceptual.saliency_weight,
            adaptation_window_deg: a.perceptual.threshold.adaptation_window_deg,
            latitude_ev: a.perceptual.latitude_ev,
            ppd: None,
            use_velocity: a.perceptual.use_velocity,
            reuse_window: None,
            reuse_memory_gib: crate::reuse::DEFAULT_MEMORY as f64 / GIB,
        }
    }
}

/// The display the image is tone mapped for and judged on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DisplaySpec {
    /// Tone operator of the PNG and of display visibility. `None`: Reinhard et al. 2002 for a
    /// still, Pattanaik et al. 2000 (with the viewer's adaptation course) for a sequence, or
    /// the exposure operator when `exposure_ev` is set.
    pub operator: Option<Operator>,
    /// A plain exposure for the PNG, stops (radiance × 2^EV); excludes `operator`.
    pub exposure_ev: Option<f32>,
    /// Adaptation luminance of the operators (default: local, arithmetic over 1°).
    pub adaptation: AdaptationMode,
    /// Maximum display luminance, cd/m² (default: each operator's).
    pub max_cd_m2: Option<f64>,
    /// Display adaptation luminance, cd/m² (default: each operator's).
    pub ambient_cd_m2: Option<f64>,
    /// Horizontal field of view the image fills, degrees (default: 67 pixels per degree).
    pub fov_deg: Option<f64>,
}

impl DisplaySpec {
    /// Checks the display luminances, naming the field and its flag.
    ///
    /// # Errors
    /// [`JobError::Invalid`]: a display maximum or ambient luminance that is not a positive
    /// finite number of cd/m².
    pub fn validate(&self) -> Result<(), JobError> {
        for (field, flag, v) in [
            ("max_cd_m2", "--display-max", self.max_cd_m2),
            ("ambient_cd_m2", "--display-ambient", self.ambient_cd_m2),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0 && v <= perception::tmo::MAX_DISPLAY_CD_M2)
            {
                return Err(JobError::Invalid(format!(
                    "display.{field} ({flag}) must be a positive luminance up to 1e5 cd/m² \
                     (ten times the brightest HDR standard's 10,000), got {v:?}"
                )));
            }
        }
        Ok(())
    }

    /// Tone-map settings with `operator` for an image `width` pixels wide whose radiance is
    /// `luminance_scale` cd/m² per unit.
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming the field: a field of view outside (0°, 180°), or display
    /// luminances out of range.
    pub fn tone_settings(
        &self,
        operator: Operator,
        width: usize,
        luminance_scale: f32,
    ) -> Result<ToneMapSettings, JobError> {
        let view = match self.fov_deg {
            Some(f) => ViewingConditions::from_fov(f, width as f64)
                .map_err(|e| JobError::Invalid(format!("display.fov_deg (--fov): {e}")))?,
            None => ViewingConditions::default(),
        };
        self.validate()?;
        let display = Display {
            max_cd_m2: self.max_cd_m2,
            ambient_cd_m2: self.ambient_cd_m2,
        };
        Ok(ToneMapSettings {
            operator,
            adaptation: self.adaptation,
            view,
            display,
            luminance_scale,
            adaptation_state: None,
        })
    }
}

/// Part of one frame rendered on its own (docs/farm.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Split {
    /// Samples (I−1)·N/K .. I·N/K of every pixel of a uniform render (`--part I/K`): merged,
    /// bit-identical to one machine's render.
    Part {
        /// I, from 1.
        index: u32,
        /// K.
        count: u32,
    },
    /// Rows (I−1)·H/K .. I·H/K of an adaptive render, with `margin` rows on each side also
    /// sampled (`--tile I/K`).
    Tile {
        /// I, from 1.
        index: u32,
        /// K.
        count: u32,
        /// Rows on each side that also take samples.
        margin: u32,
    },
}

/// Where a job's files go.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OutputSpec {
    /// Output path without extension (STEM.exr, STEM.png; STEM.NNNN.* for frames). `None`:
    /// no files (the results reach the [`Observer`] only).
    pub stem: Option<PathBuf>,
    /// Also the false-colour PNGs STEM.spp.png and STEM.ratio.png.
    pub aov: bool,
    /// A sequence also writes STEM.preview.png and STEM.filmstrip.png (a farm task's frame
    /// does not: the finishing job writes them for the whole sequence).
    pub sequence_outputs: bool,
    /// Denoise each frame with Open Image Denoise ([`crate::denoise`]): the EXR's RGB and the
    /// PNG are the denoised image, the raw one is kept as `Noisy.R/G/B`.
    pub denoise: bool,
    /// The model the final image is denoised by ([`crate::denoise::FinalQuality`], default
    /// high); only with `denoise` or `preview`.
    pub denoise_quality: crate::denoise::FinalQuality,
    /// A progressive preview of a still: the perceptual sampler starts at 2 spp and steers
    /// from its first pass ([`RenderJob::adaptive_settings`]), the image is denoised when the
    /// build can ([`crate::denoise::AVAILABLE`]), and STEM.png is rewritten (atomically) after
    /// every pass, until the perceptual stop or the time budget; STEM.exr comes at the end.
    pub preview: bool,
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            stem: None,
            aov: false,
            sequence_outputs: true,
            denoise: false,
            denoise_quality: crate::denoise::FinalQuality::High,
            preview: false,
        }
    }
}

/// The least first-pass samples per pixel of the perceptual stop with the denoiser in its
/// loop (`--denoise` without `--spp`; not a preview). From 8 spp the stop left most pixels
/// where the denoiser smooths hardest and its two denoised halves agree, and lost to uniform
/// sampling in time at equal score. Measured with `benches/denoise_judge.py` (256², wall time
/// against uniform sampling without the denoiser at equal JOD / FLIP mean; two runs for 32),
/// first pass 8 → 32 spp: Cornell box 2.54 / 0.96× → 3.8–4.3 / 1.25–1.41×, Mori knob 0.78 /
/// 0.52× → 1.19–1.32 / 0.90–1.00×, Lost Empire 0.51 / 0.55× → 0.87–1.03 / 0.77–0.91×,
/// holodeck 0.62 / 0.39× → 0.61–0.62 / 0.37× (there the stop runs to about 690 spp either
/// way). 16 spp lay between the two on the other three; on the holodeck all three first
/// passes are within 0.61–0.66 / 0.37–0.40×.
pub const DENOISED_STOP_MIN_SPP: u32 = 32;

/// The converged fraction of a sequence's frames (without a budget), where the still's lower
/// default ([`crate::adaptive::DEFAULT_CONVERGED_FRACTION`]) was not measured to pay.
///
/// The stop with the denoiser in its loop kept it too until 2026-11-30, for its samples: at
/// the still's 80 % it ends after its 32-spp first pass on the Mori knob, the Cornell box and
/// Lost Empire at 256² (96–97 % of the pixels converged there), and on the Mori knob scored
/// JOD 9.944 against 9.970 at 36.2 spp, which uniform renders without the denoiser reach at
/// about 46 spp instead of 59. In time it lost: the Mori knob's stop at 99.5 % took 1.02× the
/// wall time of uniform at its JOD (`farm-bench`, 5 pairs), at 80 % 0.96×; and the holodeck's
/// ran to 697.6 spp in 66 s (98.5 % of its pixels at the 4096-spp cap) where at 80 % it stops
/// at 217 spp in 21 s with JOD 9.958, which uniform reaches at about 400 spp in 1.68× that
/// time (3 pairs) (docs/denoise.md, "The stop with the denoiser at 80 %"). It now takes the
/// still's default.
pub const KEPT_CONVERGED_FRACTION: f64 = 0.995;

/// First-pass samples per pixel of a preview (the fewest the half-buffer estimate needs).
pub const PREVIEW_MIN_SPP: u32 = 2;

/// Errors of a render job. Each message names the file, the frame or the job field (with its
/// command-line flag) it is about.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum JobError {
    /// The job asks for something that cannot be rendered.
    #[error("{0}")]
    Invalid(String),
    /// A job record (a partial film's, a farm manifest's) cannot be used.
    #[error("{path}: {message}")]
    Record {
        /// The file holding the record.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A sampler setting is out of range.
    #[error(transparent)]
    Adaptive(#[from] AdaptiveError),
    /// The outputs could not be written.
    #[error(transparent)]
    Deliver(#[from] crate::deliver::DeliverError),
    /// A file could not be written.
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    /// A partial film could not be read, written or merged.
    #[error(transparent)]
    Partial(#[from] crate::partial::PartialError),
    /// The image could not be denoised.
    #[error(transparent)]
    Denoise(#[from] crate::denoise::DenoiseError),
}

impl RenderJob {
    /// A job for the scene at `path` with every default: the perceptual rule until converged,
    /// the default display, no files.
    pub fn new(path: impl Into<PathBuf>) -> RenderJob {
        RenderJob {
            version: JOB_VERSION,
            criterion: Criterion::Perceptual,
            frames: None,
            scene: SceneSpec {
                path: path.into(),
                ..SceneSpec::default()
            },
            budget: Budget::default(),
            sampling: SamplingOptions::default(),
            display: DisplaySpec::default(),
            split: None,
            output: OutputSpec::default(),
        }
    }

    /// The job as a TOML record.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a render job serializes to TOML")
    }

    /// Reads a TOML record written by [`RenderJob::to_toml`]; `origin` names the file it came
    /// from in errors.
    ///
    /// # Errors
    /// [`JobError::Record`]: not TOML, not a render job (unknown or missing keys), or written
    /// by an aleph whose record version differs.
    pub fn from_toml(text: &str, origin: &Path) -> Result<RenderJob, JobError> {
        let record = |message: String| JobError::Record {
            path: origin.to_path_buf(),
            message,
        };
        #[derive(Deserialize)]
        struct Version {
            version: Option<u32>,
        }
        let v: Version = toml::from_str(text)
            .map_err(|e| record(format!("the render record is not aleph's: {e}")))?;
        match v.version {
            Some(JOB_VERSION) => {}
            Some(other) => {
                return Err(record(format!(
                    "the render record has version {other}; this aleph reads version \
                     {JOB_VERSION} (render it again with this aleph)"
                )));
            }
            None => {
                return Err(record(
                    "the render record has no version: it was written by an older aleph or \
                     another program (render it again with this aleph)"
                        .into(),
                ));
            }
        }
        toml::from_str(text).map_err(|e| record(format!("the render record is not aleph's: {e}")))
    }

    /// Checks what can be checked without the scene.
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming the first bad field and its flag.
    pub fn validate(&self) -> Result<(), JobError> {
        let bad = |m: String| Err(JobError::Invalid(m));
        if let Some(n) = self.budget.spp
            && !(n.is_finite() && n >= 1.0)
        {
            return bad(format!("budget.spp (--spp) must be at least 1, got {n:?}"));
        }
        if let Some([w, h]) = self.scene.resolution {
            crate::scene::check_resolution(w, h)
                .map_err(|m| JobError::Invalid(format!("scene.resolution (--resolution): {m}")))?;
        }
        if self.scene.max_depth == Some(0) {
            return bad("scene.max_depth (--max-depth) must be at least 1, got 0".into());
        }
        if let Some(t) = self.budget.time_s
            && !(t.is_finite() && t > 0.0 && t <= 1e9)
        {
            return bad(format!(
                "budget.time_s (--time) must be a positive number of seconds up to 1e9, got {t:?}"
            ));
        }
        if let Some(ev) = self.display.exposure_ev {
            if !ev.is_finite() {
                return bad(
                    "display.exposure_ev (--exposure) must be a finite number of stops".into(),
                );
            }
            if self.display.operator.is_some() {
                return bad("display.exposure_ev (--exposure) and display.operator (--tonemap) exclude each other".into());
            }
        }
        self.display.validate()?;
        if let Some(stem) = &self.output.stem {
            check_stem(stem)?;
        }
        if let Some([a, b]) = self.frames
            && a > b
        {
            return bad(format!(
                "frames: the first frame ({a}) is after the last ({b})"
            ));
        }
        if let Some(split) = self.split {
            self.validate_split(split)?;
        }
        if self.output.denoise {
            if !crate::denoise::AVAILABLE {
                return bad(format!("--denoise: {}", crate::denoise::HOW_TO_BUILD));
            }
            if self.split.is_some() {
                return bad(
                    "--denoise with --part/--tile: a part holds some of the samples; denoise \
                     the whole image (render it on one machine)"
                        .into(),
                );
            }
        }
        if self.output.denoise_quality != crate::denoise::FinalQuality::High && !self.denoises() {
            return bad(
                "--denoise-quality (output.denoise_quality): nothing is denoised; add --denoise"
                    .into(),
            );
        }
        self.validate_preview()?;
        self.validate_reuse()
    }

    /// A preview is one still, rendered whole by the perceptual sampler.
    fn validate_preview(&self) -> Result<(), JobError> {
        if !self.output.preview {
            return Ok(());
        }
        let bad = |m: &str| Err(JobError::Invalid(format!("--preview: {m}")));
        if self.split.is_some() {
            return bad("a preview is rendered whole, not as --part/--tile");
        }
        if self.frames.is_some() {
            return bad("a preview is of one still; --frames/--frame render a sequence");
        }
        if self.criterion != Criterion::Perceptual {
            return bad(
                "a preview refines where the perceptual sampler sees error; use --sampler \
                 perceptual (the default)",
            );
        }
        Ok(())
    }

    /// Whether the image is denoised: `--denoise`, or a preview in a build that can.
    pub fn denoises(&self) -> bool {
        self.output.denoise || (self.output.preview && crate::denoise::AVAILABLE)
    }

    fn validate_reuse(&self) -> Result<(), JobError> {
        let m = self.sampling.reuse_memory_gib;
        if !(m.is_finite() && (MIN_REUSE_MEMORY_GIB..=1e6).contains(&m)) {
            return Err(JobError::Invalid(format!(
                "sampling.reuse_memory_gib (--reuse-memory) must be a size in GiB from \
                 {MIN_REUSE_MEMORY_GIB} (1 MiB) to 1e6, got {m}"
            )));
        }
        let Some(k) = self.sampling.reuse_window.filter(|&k| k > 0) else {
            return Ok(());
        };
        let bad = |m: String| Err(JobError::Invalid(m));
        if k > crate::reuse::MAX_WINDOW {
            return bad(format!(
                "sampling.reuse_window (--reuse-window) must be at most {} frames, got {k}",
                crate::reuse::MAX_WINDOW
            ));
        }
        if self.criterion != Criterion::Perceptual {
            return bad(format!(
                "--reuse-window {k}: reuse across frames takes the perceptual sampler (the {} \
                 sampler renders independent frames: it is a baseline)",
                self.criterion.name()
            ));
        }
        if self.budget.time_s.is_some() {
            return bad(format!(
                "--reuse-window {k} and --time exclude each other: a frame's time budget \
                 cannot be kept while earlier frames decide its samples (give --reuse-window 0)"
            ));
        }
        if self.split.is_some() {
            return bad(format!(
                "--reuse-window {k} and --part/--tile exclude each other: a split frame \
                 renders on its own (a farm splits a reusing sequence into chunks of frames)"
            ));
        }
        Ok(())
    }

    /// The reuse window this job renders a sequence with: the job's, or by default
    /// [`DEFAULT_REUSE_WINDOW`] for the perceptual sampler without a time budget or split,
    /// else 0.
    pub fn reuse_window(&self) -> u32 {
        match self.sampling.reuse_window {
            Some(k) => k,
            None if self.criterion == Criterion::Perceptual
                && self.budget.time_s.is_none()
                && self.split.is_none() =>
            {
                DEFAULT_REUSE_WINDOW
            }
            None => 0,
        }
    }

    /// The reuse memory, bytes.
    pub fn reuse_memory(&self) -> u64 {
        self.sampling.reuse_memory()
    }

    /// The reuse window a sequence of `pixels`-pixel frames renders with: [`Self::reuse_window`],
    /// cut to the frames whose records fit in the reuse memory ([`crate::reuse::window_for`];
    /// 0 where not even one does). At the default 8 GiB a window of 15 frames fits up to
    /// 2.2 M pixels (1920×1080 whole), 3840×2160 takes 3.
    pub fn reuse_window_for(&self, pixels: usize) -> u32 {
        crate::reuse::window_for(pixels, self.reuse_window(), self.reuse_memory())
    }

    fn validate_split(&self, split: Split) -> Result<(), JobError> {
        let bad = |m: String| Err(JobError::Invalid(m));
        let (i, k) = match split {
            Split::Part { index, count } | Split::Tile { index, count, .. } => (index, count),
        };
        if i == 0 || i > k {
            return bad(format!("split: part {i} of {k} (expected 1 ≤ I ≤ K)"));
        }
        if matches!(self.frames, Some([a, b]) if a != b) {
            return bad("--part/--tile render one frame: give --frame N, not --frames".into());
        }
        match (split, self.criterion) {
            (Split::Part { .. }, Criterion::Perceptual | Criterion::Variance) => bad(
                "--part splits the samples of a uniform render (--sampler uniform); the \
                 perceptual and variance samplers split one frame by rows (--tile I/K) or a \
                 sequence by frames (docs/farm.md)"
                    .into(),
            ),
            (Split::Tile { .. }, Criterion::Uniform) => bad(
                "--tile splits an adaptive render by rows; a uniform render splits by samples: \
                 --part I/K"
                    .into(),
            ),
            _ => Ok(()),
        }
    }

    /// The scene description with the job's overrides.
    ///
    /// # Errors
    /// As [`SceneDescription::read`].
    pub fn scene_description(&self) -> Result<SceneDescription, SceneError> {
        Ok(self.with_overrides(SceneDescription::read(&self.scene.path)?))
    }

    /// `desc` with the job's overrides of resolution, seed and path depth (for a scene
    /// described in memory, as the Python bindings' dictionaries).
    pub fn with_overrides(&self, mut desc: SceneDescription) -> SceneDescription {
        if let Some([w, h]) = self.scene.resolution {
            desc.camera.resolution = [w, h];
        }
        if let Some(s) = self.scene.seed {
            desc.render.seed = Some(s);
        }
        if let Some(d) = self.scene.max_depth {
            desc.render.max_depth = Some(d);
        }
        desc
    }

    /// Loads the scene with the job's overrides.
    ///
    /// # Errors
    /// As [`Scene::load`].
    pub fn load_scene(&self) -> Result<Scene, SceneError> {
        Scene::load_description(self.scene_description()?)
    }

    /// The operator of the PNG and of display visibility: the job's, else the exposure
    /// operator for `exposure_ev`, else Reinhard for a still and PTYG in a sequence.
    pub fn operator(&self, in_sequence: bool) -> Operator {
        match (self.display.operator, self.display.exposure_ev, in_sequence) {
            (Some(op), _, _) => op,
            (None, Some(_), _) => Operator::Exposure,
            (None, None, false) => Operator::Reinhard,
            (None, None, true) => Operator::Ptyg,
        }
    }

    /// The adaptive loop's settings and the PNG's look for `scene` (at its frame); `adaptation`
    /// is the viewer's state in a sequence ([`crate::sequence::FrameContext`]), `None` for a
    /// still.
    ///
    /// # Errors
    /// [`JobError::Invalid`] or [`JobError::Adaptive`] naming the setting out of range.
    pub fn settings(
        &self,
        scene: &Scene,
        adaptation: Option<AdaptationState>,
    ) -> Result<(AdaptiveSettings, Look), JobError> {
        let op = self.operator(adaptation.is_some());
        let mut tone = self.display.tone_settings(
            op,
            scene.camera.width as usize,
            scene.settings.luminance_scale,
        )?;
        tone.adaptation_state = adaptation;
        let sequence = scene.animation.is_some();
        let mut settings = self.adaptive_settings_for(scene.settings.spp, tone, sequence)?;
        let pixels = scene.camera.width as usize * scene.camera.height as usize;
        settings.reuse_frame_memory =
            crate::reuse::frame_memory(self.reuse_window_for(pixels), self.reuse_memory());
        let look = match (self.display.operator, self.display.exposure_ev) {
            (None, Some(ev)) => Look::Exposure(Some(ev)),
            _ => Look::Tone(settings.tone),
        };
        Ok((settings, look))
    }

    /// The stop's converged fraction: the job's, or when it names none the rule's own
    /// ([`Criterion::default_converged_fraction`]) for a still, with the denoiser or not,
    /// [`KEPT_CONVERGED_FRACTION`] for a frame of a `sequence`.
    fn converged_fraction(&self, sequence: bool) -> f64 {
        match self.sampling.converged_fraction {
            Some(f) => f,
            None if sequence => KEPT_CONVERGED_FRACTION,
            None => self.criterion.default_converged_fraction(),
        }
    }

    /// The adaptive loop's settings with display `tone`; `uniform_spp` is the scene's
    /// `render.spp`.
    ///
    /// # Errors
    /// As [`RenderJob::settings`].
    pub fn adaptive_settings(
        &self,
        uniform_spp: u32,
        tone: ToneMapSettings,
    ) -> Result<AdaptiveSettings, JobError> {
        self.adaptive_settings_for(uniform_spp, tone, false)
    }

    /// As [`RenderJob::adaptive_settings`], for a frame of a sequence when `sequence` (its
    /// stop's converged fraction, [`RenderJob::converged_fraction`]).
    fn adaptive_settings_for(
        &self,
        uniform_spp: u32,
        tone: ToneMapSettings,
        sequence: bool,
    ) -> Result<AdaptiveSettings, JobError> {
        self.validate()?;
        let s = &self.sampling;
        let mut tone = tone;
        if let Some(ppd) = s.ppd {
            tone.view = tone
                .view
                .with_ppd(ppd)
                .map_err(|e| JobError::Invalid(format!("sampling.ppd (--ppd): {e}")))?;
        }
        let defaults = AdaptiveSettings::default();
        let settings = AdaptiveSettings {
            criterion: self.criterion,
            min_spp: s.min_spp,
            max_spp: s.max_spp,
            steer_from_spp: s.steer_from_spp.unwrap_or(if self.denoises() {
                DENOISED_STEER_FROM_SPP
            } else {
                crate::adaptive::STEER_FROM_SPP
            }),
            budget_spp: self.budget.spp,
            uniform_spp,
            time_budget: self.budget.time_s.map(Duration::from_secs_f64),
            converged_fraction: self.converged_fraction(sequence),
            tone,
            perceptual: PerceptualSettings {
                visibility: s.visibility,
                threshold: perception::threshold::ThresholdParams {
                    adaptation_window_deg: s.adaptation_window_deg,
                    ..defaults.perceptual.threshold
                },
                saliency_weight: s.saliency,
                error_estimate: s.error_estimate,
                guide_spp: s.guide_spp,
                use_velocity: s.use_velocity,
                latitude_ev: s.latitude_ev,
            },
            variance_threshold: s.noise_threshold,
            rows: None,
            denoise: self.denoises(),
            denoise_quality: self.output.denoise_quality,
            reuse_frame_memory: crate::reuse::frame_memory(
                self.reuse_window(),
                self.reuse_memory(),
            ),
        };
        let settings = if self.output.preview {
            AdaptiveSettings {
                min_spp: PREVIEW_MIN_SPP,
                steer_from_spp: 0.0,
                ..settings
            }
        } else if settings.denoise && self.budget.spp.is_none() {
            AdaptiveSettings {
                min_spp: s.min_spp.max(DENOISED_STOP_MIN_SPP),
                ..settings
            }
        } else {
            settings
        };
        settings.validate()?;
        Ok(settings)
    }

    /// The output stem: the job's, or the scene's name (its folder's name for `scene.toml`)
    /// in the working directory.
    pub fn stem(&self) -> PathBuf {
        match &self.output.stem {
            Some(s) => s.clone(),
            None => PathBuf::from(scene_name(&self.scene.path)),
        }
    }

    /// What decides the pixels of a frame: the job without its split, outputs and scene path,
    /// with the scene's content hash. Two parts of one render have equal image keys.
    pub fn image_key(&self) -> RenderJob {
        RenderJob {
            split: None,
            output: OutputSpec::default(),
            scene: SceneSpec {
                path: PathBuf::new(),
                ..self.scene.clone()
            },
            ..self.clone()
        }
    }
}

/// Refuses an output stem that names no file of its own: empty, `.` or `..`, or ending in a
/// path separator (`-o .` would write the hidden `..exr`, `-o sub/` writes `sub/.exr`).
///
/// # Errors
/// [`JobError::Invalid`] naming the stem.
pub fn check_stem(stem: &Path) -> Result<(), JobError> {
    let text = stem.as_os_str().to_string_lossy();
    let dot = text == "." || text.ends_with("/.");
    if text.is_empty()
        || text.ends_with(std::path::is_separator)
        || dot
        || stem.file_name().is_none()
    {
        return Err(JobError::Invalid(format!(
            "-o {text:?}: the output needs a file name (OUT writes OUT.exr and OUT.png), not a \
             directory"
        )));
    }
    Ok(())
}

/// A scene's name for default outputs: the file's stem, or its folder's name for `scene.toml`.
pub fn scene_name(path: &Path) -> String {
    match path
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .as_deref()
    {
        Some("scene") | None => path
            .parent()
            .and_then(|p| p.file_name())
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| "render".into()),
        Some(s) => s.to_string(),
    }
}

/// SHA-256 of the file at `path`, hex.
///
/// # Errors
/// [`SceneError::Io`] naming the file.
pub fn content_hash(path: &Path) -> Result<String, SceneError> {
    use sha2::Digest;
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(format!("{:x}", sha2::Sha256::digest(&bytes)))
}
