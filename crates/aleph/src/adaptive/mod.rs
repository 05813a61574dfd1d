//! Adaptive sampling: spend samples only where the remaining error is still visible.
//!
//! One loop serves three samplers; only the per-pixel "needs more" decision differs:
//! - perceptual ([`Criterion::Perceptual`]): error (half-buffer difference, in display or scene cd/m²)
//!   against the threshold map ΔL_T of the `perception` crate (Ramasubramanian et al. 1999; Yee
//!   et al. 2001);
//! - variance ([`Criterion::Variance`]): Blender Cycles' noise-threshold criterion (after Dammertz et al.
//!   2010), the production baseline;
//! - uniform ([`Criterion::Uniform`]): the same budget spread evenly.
//!
//! # The loop
//! 0. A sample budget under `steer_from_spp` ([`STEER_FROM_SPP`], 128) is rendered uniformly
//!    in one pass and nothing is judged: below it the decisions cost more than they save (a
//!    frame reusing earlier frames levels its samples instead: [`render_reusing`]).
//! 1. A uniform pass of `min_spp` samples.
//! 2. Each pass: the error estimate from the two half-buffers is e = k |Y(A) − Y(B)| in
//!    scene luminance, k = √(n_A n_B) / n (½ for equal halves). The perceptual sampler's
//!    halves are the power-of-two blocks of one Sobol' sequence per pixel (samples 0..P and
//!    P..n, [`crate::film::HalfSplit::Blocks`]), so the image keeps the whole sequence's
//!    stratification and e overstates the error only where the net beats Monte Carlo; the
//!    variance sampler's are two independent streams (even and odd samples). The ratio r = e / threshold, averaged over 3×3
//!    pixels so a single lucky pixel is not called converged, says how far a pixel is from
//!    converged. (When the first pass spends a sample budget, nothing is judged.) Without an
//!    average budget (the default stop, a time budget) r is also at least √(2/π) times the
//!    RMS ratio its 7×7 neighbourhood predicts at the pixel's spp (r² n pooled, which does not
//!    depend on the pixels' counts): heavy-tailed noise such as a caustic's leaves whole
//!    patches whose half-buffers agree by luck (without the guard, 14 % of the pixels of
//!    McGuire's sphere box stopped under 128 spp, in patches among neighbours at the
//!    4096-spp cap). Under a budget the floor (step 4) does that job.
//! 3. Pixels with r > 1 (above threshold) get more samples, and so do their 8 neighbours
//!    (re-opening, as Cycles' box pass does, so thin features are not frozen early). Error falls
//!    as 1/√n, so a pixel needs about n (r² − 1) more samples; each pass gives that, at most
//!    doubling a pixel's count (so the estimate is re-checked often), at least n/4 to re-opened
//!    neighbours, and never past `max_spp`.
//!    Pixel totals land on `allocate::stratified_total`s (powers of two and their 3/4), where
//!    each half-buffer's Sobol' samples are whole (0,2)-nets in either layout.
//! 4. Stop when the fraction of converged pixels (r ≤ 1) reaches `converged_fraction` (after
//!    one last pass that only lifts the pixels under the stop's floor, if any are), or at the
//!    average budget (`budget_spp`), the per-pixel cap, or the time budget. With an average
//!    budget B the sampler spends all of it: the perceptual sampler first lifts every pixel
//!    with any noise to 3/4 of B (`allocate::FLOOR_SHARE`) in one pass, and once
//!    `allocate::FILL_FROM_CONVERGED` of the pixels are converged the rest of the budget is
//!    spread evenly
//!    (`allocate::fill_to_level`): the model has no ranking left to act on. Noise below
//!    `criterion::NEGLIGIBLE_NOISE_CONTRAST` of a pixel's mean, a quarter of the eye's lowest
//!    contrast threshold (the directly seen sky), counts as none: such a pixel gets neither
//!    the floor nor a share of the fill, and one within 8× of it approaches them by
//!    doublings (`allocate::NEAR_NEGLIGIBLE_FACTOR`).
//!
//! # The perceptual threshold
//! ΔL_T(x) = ΔL_TVI(L_a(x)) · F(x). L_a is recomputed from the current image (a 1°
//! Gaussian mean, where noise averages out). The elevation F (spatial frequency and masking) is
//! computed once, from a **low-noise guide**: a render of direct illumination only (max depth 1,
//! `guide_spp` samples, independent seed), as Ramasubramanian et al. computed the spatial part
//! of their map from the direct-illumination image. Computing F from the noisy image itself
//! would let its noise mask itself and stop sampling exactly where noise is worst.
//!
//! # Where visibility is judged
//! [`Visibility::Display`] (default): on the image as displayed. The current image's tone curve
//! is frozen ([`crate::display::FrozenToneMap`]) and the threshold L_a · C_noise is found in
//! display cd/m² at each grade of the **exposure latitude** ([`AdaptiveSettings::latitude_ev`],
//! default ±2 EV: the image as displayed, and its input × 2^−2 and × 2^2 under the same curve),
//! then referred to scene luminance through the curve's slope at the pixel (dL_d/dY across ±5 %
//! of the 5×5-pooled mean). The pixel's threshold is the smallest of these: noise must stay
//! invisible however a user grades the EXR within the latitude, so a highlight that clips on
//! the display keeps the samples its noise needs when graded darker. The error is measured in
//! scene luminance, and the threshold map is recomputed only when the mean spp has grown 4×
//! since its last computation. [`Visibility::Scene`]: in scene luminance, cd/m² = Y × the
//! scene's `luminance_scale` (graded the same way), as Ramasubramanian et al. did.
//!
//! # Determinism
//! Every decision is a function of the film, which is bit-identical for any thread count, so
//! the image and the sample-count map are too — except with a time budget, whose stopping pass
//! depends on speed.

mod allocate;
mod criterion;
mod temporal;

pub use temporal::{REUSE_CAP_SHARE, render_base, render_reusing};

use crate::denoise::{Aux, Denoised};
use crate::display::ToneMapSettings;
use crate::film::Film;
use crate::gbuffer::GBuffer;
use crate::integrator::{Integrator, Strategy};
use crate::render::{RenderStats, render_counts};
use crate::sampler::SampleStreams;
use crate::scene::Scene;
use crate::velocity::{VelocityMap, render_velocity};
use allocate::{Allocation, allocate, fit_to_budget};
use criterion::{Judge, Judgement, PerceptualCriterion, VarianceCriterion};
use perception::threshold::ThresholdParams;
use rayon::prelude::*;
use std::cell::{Cell, OnceCell, RefCell};
use std::time::{Duration, Instant};

/// The adaptive decision rule: which per-pixel decision steers the samples (serialized by its
/// command-line name).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Criterion {
    /// Error against the perceptual threshold map.
    Perceptual,
    /// The same number of samples everywhere.
    Uniform,
    /// Cycles' relative noise threshold.
    Variance,
}

impl Criterion {
    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Criterion::Perceptual => "perceptual",
            Criterion::Uniform => "uniform",
            Criterion::Variance => "variance",
        }
    }

    /// The default of [`AdaptiveSettings::converged_fraction`] for this rule: the perceptual
    /// stop's [`DEFAULT_CONVERGED_FRACTION`]; Cycles' rule stops, as in Cycles, once (almost)
    /// every pixel is under its noise threshold, [`VARIANCE_CONVERGED_FRACTION`].
    pub fn default_converged_fraction(self) -> f64 {
        match self {
            Criterion::Perceptual => DEFAULT_CONVERGED_FRACTION,
            Criterion::Uniform | Criterion::Variance => VARIANCE_CONVERGED_FRACTION,
        }
    }
}

/// Where visibility is judged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Visibility {
    /// Display luminance after the tone curve, cd/m².
    Display,
    /// Scene luminance, cd/m² (Y × luminance_scale).
    Scene,
}

/// Why the loop stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// The target fraction of pixels is below threshold.
    Converged,
    /// The average sample budget is spent.
    Budget,
    /// Every pixel that still needs samples is at the per-pixel cap.
    MaxSpp,
    /// The time budget ran out.
    Time,
}

impl StopReason {
    /// Words for the summary line.
    pub fn describe(self) -> &'static str {
        match self {
            StopReason::Converged => "converged",
            StopReason::Budget => "sample budget spent",
            StopReason::MaxSpp => "max spp reached",
            StopReason::Time => "time budget spent",
        }
    }
}

/// How the perceptual sampler estimates a pixel's remaining error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ErrorEstimate {
    /// |Y(A) − Y(B)| / 2 from the two half-buffers, in visibility units.
    HalfBuffers,
    /// The standard error of the mean sqrt(var(Y)/n) from Σ Y², mapped to visibility units by
    /// the pixel's display gain Y_d/Y (more degrees of freedom than one half-buffer difference).
    /// It ranks pixels closer to the FLIP oracle (Spearman 0.67–0.72 against 0.60–0.67 on the
    /// Cornell box at 128–1024 spp) but overstates the error of Owen-scrambled Sobol' samples,
    /// so it stops later (599 against 338 spp on the Cornell box at 256²) and, under a budget,
    /// gains less at equal FLIP p99 on the holodeck; not the default. It reads no half-buffer,
    /// so its passes draw one Sobol' sequence per pixel ([`AdaptiveSettings::streams`]).
    StandardError,
}

/// Cycles' default noise threshold.
pub const CYCLES_DEFAULT_THRESHOLD: f32 = 0.01;

/// Default of [`AdaptiveSettings::steer_from_spp`]: budgets under 128 spp are rendered
/// uniformly. Below it the decisions cannot pay for themselves. Measured on the bundled Cornell
/// box and holodeck at 256² (2048-spp references, FLIP and ColorVideoVDP, ±2 EV), at 16–64 spp:
/// the threshold map still calls 62–90 % of pixels visible, so the allocation barely departs
/// from uniform (0.95–1.07× uniform's samples at equal score), while the guide and the
/// decisions cost 5–25 % of the render's wall time (Cornell box: 0.79–0.92× uniform's speed at
/// equal FLIP p99). From 128 spp the sampler gains (FLIP p99 1.19–1.33×). Blender Cycles
/// likewise samples every pixel 64 times before its adaptive sampling starts at its default
/// noise threshold (automatic minimum ⌈16 / t^0.3⌉ = 64 at t = 0.01).
pub const STEER_FROM_SPP: f64 = 128.0;

/// The default fraction of pixels below threshold at which a render without a budget stops
/// (`--converged`; a still with the perceptual rule). A pixel counts as converged when its
/// *estimated* ratio is at most 1, and the estimate scatters (3 × 3 pooled half-buffer
/// differences: about ±25 % in a flat region), so asking 99.5 % of the estimates under 1
/// drove the typical true ratio to about 0.6 and the last passes doubled pixels (and their
/// neighbours) whose estimates sat just above 1: on the Cornell box at 256² the last three
/// passes took 186 → 241 spp for a JOD of 9.928 against 9.918. Measured at 99.5 / 98 / 95 /
/// 90 % (docs/benchmarks.md, "The stop's tail", four stills, ±2 EV, FLIP and ColorVideoVDP):
/// at 90 % the stop takes 22–30 % fewer samples on the Cornell box, the Mori knob and the
/// holodeck (6 % on Lost Empire), scores better per sample by FLIP mean on all four and at
/// every grade, and by JOD as displayed on the box and the Mori knob (the holodeck 2.92 →
/// 2.70×); 0.82× (box) and 0.75× (Mori knob) the wall time of the 99.5 % stop. Every stop
/// stays at JOD ≥ 9.8 at each grade.
///
/// 80 % since 2026-11-28 (session ae; 90 % before). A pass doubles every pixel still above
/// threshold and re-opens its neighbours, so the converged fraction moves in large steps and
/// the last pass is the dearest: on the Cornell box at 256² from 81.7 % at 142 spp to 93.1 % at
/// 189, on McGuire's glossy box from 84.4 % at 148 spp to 97.1 % at 186, spent on the pixels
/// the model ranks worst, which FLIP's mean does not rank so. Uniform spp at the stop's score
/// over the stop's, 90 → 80 %, FLIP mean / p99 / JOD each as displayed / −2 / +2 EV (seeds 0
/// and 1, the holodeck 0; 4096-spp references; docs/benchmarks.md, "The stop at 80 %"):
/// Cornell box (189.4 → 145.2 spp) 1.01 / 0.76 / 0.97 → 1.06 / 0.86 / 1.05×, 1.02 / 0.89 / 1.61
/// → 1.12 / 1.07 / 1.50×, 1.35 / 0.89 / 2.15 → 1.33 / 1.05 / 1.55×; glossy box (186.5 → 149.4)
/// 0.93 / 0.80 / 0.90 → 1.04 / 0.87 / 0.95×, 0.91 / 0.93 / 1.21 → 1.01 / 1.03 / 1.27×, 1.05 /
/// 0.88 / 1.36 → 1.11 / 0.99 / 1.31×; holodeck 240×160 (597.4 → 434.6) 0.97 / 0.89 / 0.93 →
/// 1.05 / 0.95 / 0.97×, 2.30 / 1.87 / 2.05 → 1.94 / 1.72 / 1.75×, 2.92 / 2.78 / 1.62 → 2.21 /
/// 2.49 / 1.55×; Lost Empire 256×160 (47.1 → 38.7) 0.96 / 1.00 / 1.05 → 1.00 / 1.01 / 1.08×,
/// 1.04 / 1.05 / 0.98 → 1.06 / 1.05 / 1.02×, JOD at ∓2 EV 1.33 / 1.25 → 1.20 / 1.08×; the Mori
/// knob the same stop (its last pass crosses both). The scores under 1 fall from 16 to 7 of
/// the 45, the worst from 0.76 to 0.86× (the box's FLIP mean at −2 EV).
pub const DEFAULT_CONVERGED_FRACTION: f64 = 0.8;

/// The converged fraction of the variance rule's stop (Cycles' noise threshold), kept where it
/// was measured as the baseline: 99.5 % of the pixels under the threshold.
pub const VARIANCE_CONVERGED_FRACTION: f64 = 0.995;

/// Settings of the adaptive loop, grouped by what they configure: the rule, the loop's budget
/// and stop (flat, as every rule reads them), the display, the perceptual rule's model
/// ([`PerceptualSettings`]), the variance rule's threshold, and a tile's rows.
#[derive(Clone, Debug)]
pub struct AdaptiveSettings {
    /// The adaptive decision rule.
    pub criterion: Criterion,
    /// Samples per pixel of the first, uniform pass (default 8; at least 2 for half-buffers).
    pub min_spp: u32,
    /// Cap on any one pixel's samples (default 4096).
    pub max_spp: u32,
    /// The smallest average budget the adaptive samplers steer (default [`STEER_FROM_SPP`]):
    /// a smaller `budget_spp` is rendered uniformly, every pixel `budget_spp` samples, and
    /// nothing is judged (the image is the uniform sampler's, bit for bit); a frame that
    /// reuses earlier frames levels its fresh samples with the reused ones instead
    /// ([`render_reusing`]), nothing judged either. 0 steers
    /// every budget. No effect without a
    /// budget (until converged, or a time budget).
    pub steer_from_spp: f64,
    /// Average samples per pixel to spend (N × pixels in total); `None`: until converged (for
    /// `uniform`: `uniform_spp` everywhere).
    pub budget_spp: Option<f64>,
    /// Samples per pixel of the uniform sampler without a budget (the scene's `render.spp`).
    pub uniform_spp: u32,
    /// Wall-time budget.
    pub time_budget: Option<Duration>,
    /// Fraction of pixels below threshold at which a render without a sample budget stops
    /// (default [`Criterion::default_converged_fraction`] of the default rule,
    /// [`DEFAULT_CONVERGED_FRACTION`]). A budget's even fill does not depend on it
    /// ([`allocate::FILL_FROM_CONVERGED`]).
    pub converged_fraction: f64,
    /// The tone mapping of the displayed image (and the viewing conditions).
    pub tone: ToneMapSettings,
    /// The perceptual rule's visual model and error estimate.
    pub perceptual: PerceptualSettings,
    /// Cycles' noise threshold for the variance rule (default 0.01; that rule only).
    pub variance_threshold: f32,
    /// Rows `start..end` that take samples after the first pass: a tile of one frame split
    /// across machines (default `None`: every row). The first pass still covers the whole image,
    /// so that the threshold map sees every pixel; the budget, the converged fraction and the
    /// stop rule count the tile's pixels only.
    pub rows: Option<(u32, u32)>,
    /// Whether the image is denoised ([`crate::denoise`], the `denoise` feature; default
    /// false): the loop renders the denoiser's auxiliary images before its first pass, the
    /// perceptual rule judges the error of the *denoised* image (its two half-buffers denoised
    /// apart, [`criterion`]'s module docs), and the result carries the denoised image.
    pub denoise: bool,
    /// The model the result is denoised by, when it is ([`crate::denoise::FinalQuality`];
    /// default high).
    pub denoise_quality: crate::denoise::FinalQuality,
    /// Memory a frame that reuses earlier frames, or is reused, may take for reuse, bytes:
    /// its share of the job's reuse memory ([`crate::reuse::frame_memory`]), which decides
    /// how many samples a pixel keeps for the frames after it ([`crate::reuse::kept_spp`]).
    /// Default: the share of [`crate::reuse::DEFAULT_MEMORY`] in the default window of
    /// [`crate::job::DEFAULT_REUSE_WINDOW`] frames, 512 MiB.
    pub reuse_frame_memory: u64,
}

/// Settings of the perceptual rule only.
#[derive(Clone, Debug)]
pub struct PerceptualSettings {
    /// Where visibility is judged (default: display).
    pub visibility: Visibility,
    /// Threshold-map settings.
    pub threshold: ThresholdParams,
    /// Weight ω of visual saliency in the perceptual threshold (Yee et al. 2001's Aleph map,
    /// ΔL / (1 + ω S) with S the Itti–Koch–Niebur saliency of the first pass's display image);
    /// 0 (default) turns it off.
    pub saliency_weight: f32,
    /// Error estimate (default: half-buffers).
    pub error_estimate: ErrorEstimate,
    /// Samples per pixel of the albedo guide (default 4; only antialiasing needs them).
    pub guide_spp: u32,
    /// Whether the threshold takes the frame's velocity map (default true; only sequences have
    /// one): moving content is seen through the spatiovelocity CSF.
    pub use_velocity: bool,
    /// Exposure latitude of the threshold, stops (default 2): noise must stay below threshold
    /// on the image as displayed and graded `latitude_ev` stops darker and brighter under the
    /// same curve, so that a user grading the EXR finds no noise the sampler left. 0 judges
    /// the displayed image only.
    pub latitude_ev: f64,
}

impl Default for PerceptualSettings {
    fn default() -> Self {
        PerceptualSettings {
            visibility: Visibility::Display,
            threshold: ThresholdParams::default(),
            saliency_weight: 0.0,
            error_estimate: ErrorEstimate::HalfBuffers,
            guide_spp: 4,
            use_velocity: true,
            latitude_ev: 2.0,
        }
    }
}

impl Default for AdaptiveSettings {
    fn default() -> Self {
        AdaptiveSettings {
            criterion: Criterion::Perceptual,
            min_spp: 8,
            max_spp: 4096,
            steer_from_spp: STEER_FROM_SPP,
            budget_spp: None,
            uniform_spp: 64,
            time_budget: None,
            converged_fraction: DEFAULT_CONVERGED_FRACTION,
            tone: ToneMapSettings {
                operator: perception::tmo::Operator::Reinhard,
                ..ToneMapSettings::default()
            },
            perceptual: PerceptualSettings::default(),
            variance_threshold: CYCLES_DEFAULT_THRESHOLD,
            rows: None,
            denoise: false,
            denoise_quality: crate::denoise::FinalQuality::High,
            reuse_frame_memory: crate::reuse::frame_memory(
                crate::job::DEFAULT_REUSE_WINDOW,
                crate::reuse::DEFAULT_MEMORY,
            ),
        }
    }
}

impl AdaptiveSettings {
    /// Units of the threshold and error maps this sampler produces.
    pub fn units(&self) -> &'static str {
        match (self.criterion, self.perceptual.visibility) {
            (Criterion::Variance, _) => "Cycles relative error (dimensionless)",
            (_, Visibility::Display) => {
                "scene luminance, cd/m^2 (display thresholds over the tone curve's slope; 1e30 where every grade clips)"
            }
            (_, Visibility::Scene) => "scene luminance, cd/m^2",
        }
    }

    /// The grades the perceptual threshold holds at, stops: 0 (as displayed), then −L and +L
    /// for the latitude L when it is positive.
    pub fn grades_ev(&self) -> Vec<f64> {
        if self.perceptual.latitude_ev > 0.0 {
            vec![
                0.0,
                -self.perceptual.latitude_ev,
                self.perceptual.latitude_ev,
            ]
        } else {
            vec![0.0]
        }
    }

    /// Whether the sampler decides anything: false for the uniform sampler and for an adaptive
    /// one whose budget is under `steer_from_spp` (rendered uniformly).
    pub fn steers(&self) -> bool {
        self.criterion != Criterion::Uniform
            && self.budget_spp.is_none_or(|b| b >= self.steer_from_spp)
    }

    /// How the render's passes draw each pixel's samples ([`SampleStreams`]):
    /// - the perceptual sampler's default estimate: one sequence per pixel whose half-buffers
    ///   are its power-of-two blocks ([`SampleStreams::Blocks`]). Against independent
    ///   half-buffer streams, on the Cornell box at 256² (4096-spp reference, budgets 256 /
    ///   512 / 1024 spp) perceptual spp at uniform's FLIP mean rose from 0.94 / 1.03 / 1.02× to
    ///   0.96 / 1.04 / 1.04×, and on the holodeck at 128² from 0.97–1.06× to 1.07–1.16×
    ///   (docs/benchmarks.md);
    /// - independent half-buffer streams ([`SampleStreams::Halves`]) where the halves must be
    ///   independent: the variance sampler (Cycles' criterion compares half A with the whole)
    ///   and the denoised error (each half denoised on its own);
    /// - one sequence per pixel where nothing reads the halves ([`SampleStreams::Whole`]): the
    ///   uniform sampler, a budget rendered uniformly, the perceptual sampler with
    ///   [`ErrorEstimate::StandardError`], which reads Σ Y².
    pub fn streams(&self) -> SampleStreams {
        let perceptual = self.criterion == Criterion::Perceptual && !self.denoise;
        let estimate = self.perceptual.error_estimate;
        if !self.steers() || (perceptual && estimate == ErrorEstimate::StandardError) {
            SampleStreams::Whole
        } else if perceptual {
            SampleStreams::Blocks
        } else {
            SampleStreams::Halves
        }
    }

    /// The most samples the loop gives one pixel: `max_spp`, and for the perceptual sampler
    /// under a budget B also [`allocate::BUDGET_CAP_SHARE`] · B (rounded down to a stratified
    /// total).
    pub fn pixel_cap(&self) -> u32 {
        match self.perceptual_budget() {
            Some(b) => allocate::stratified_floor(allocate::BUDGET_CAP_SHARE * b).min(self.max_spp),
            None => self.max_spp,
        }
    }

    /// The average budget B when the perceptual sampler renders under one (the floor and the
    /// cap apply only then).
    fn perceptual_budget(&self) -> Option<f64> {
        self.budget_spp
            .filter(|_| self.criterion == Criterion::Perceptual)
    }

    /// Samples per pixel of a uniform render: the budget rounded (at least 1), else
    /// `uniform_spp`. The uniform rule takes it whatever `max_spp` says (the cap is the adaptive
    /// rules'); an adaptive rule rendering a small budget uniformly is held under `max_spp` by
    /// [`AdaptiveSettings::validate`].
    pub fn uniform_total_spp(&self) -> u32 {
        let n = match self.budget_spp {
            Some(b) => b.round().clamp(1.0, u32::MAX as f64) as u32,
            None => self.uniform_spp,
        };
        match self.criterion {
            Criterion::Uniform => n,
            _ => n.min(self.max_spp),
        }
    }
}

/// Errors of an adaptive render.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AdaptiveError {
    /// A setting is out of its range; the message names the setting, its value and the range.
    #[error("{0}")]
    Settings(String),
    /// The perception model rejected an image or the tone settings.
    #[error(transparent)]
    Perception(#[from] perception::PerceptionError),
    /// The denoiser failed.
    #[error(transparent)]
    Denoise(#[from] crate::denoise::DenoiseError),
}

impl AdaptiveSettings {
    /// Checks every setting against its range (the loop never clamps silently).
    ///
    /// # Errors
    /// [`AdaptiveError::Settings`] naming the first bad setting (with the command-line flag
    /// that sets it).
    pub fn validate(&self) -> Result<(), AdaptiveError> {
        let bad = |m: String| Err(AdaptiveError::Settings(m));
        if self.min_spp < 2 {
            return bad(format!(
                "min_spp (--min-spp) must be at least 2 (the error estimate needs both \
                 half-buffers), got {}",
                self.min_spp
            ));
        }
        if self.max_spp < self.min_spp {
            return bad(format!(
                "max_spp (--max-spp, {}) must be at least min_spp (--min-spp, {})",
                self.max_spp, self.min_spp
            ));
        }
        if let Some(b) = self.budget_spp
            && !(b.is_finite() && b >= 1.0)
        {
            return bad(format!("budget_spp (--spp) must be at least 1, got {b}"));
        }
        if let Some(b) = self.budget_spp
            && self.criterion != Criterion::Uniform
            && b > self.max_spp as f64
        {
            return bad(format!(
                "budget_spp (--spp {b}) is more than max_spp (--max-spp {}), the most any one \
                 pixel takes: the budget could not be spent; raise --max-spp",
                self.max_spp
            ));
        }
        if !(self.steer_from_spp.is_finite() && self.steer_from_spp >= 0.0) {
            return bad(format!(
                "steer_from_spp (--steer-from) must be a number ≥ 0, got {}",
                self.steer_from_spp
            ));
        }
        if self.uniform_spp == 0 {
            return bad("uniform_spp (render.spp) must be at least 1".into());
        }
        if !(self.converged_fraction > 0.0 && self.converged_fraction <= 1.0) {
            return bad(format!(
                "converged_fraction (--converged) must be in (0, 1], got {}",
                self.converged_fraction
            ));
        }
        if !(self.variance_threshold.is_finite() && self.variance_threshold > 0.0) {
            return bad(format!(
                "variance_threshold (--noise-threshold) must be positive, got {}",
                self.variance_threshold
            ));
        }
        if !(self.perceptual.saliency_weight.is_finite() && self.perceptual.saliency_weight >= 0.0)
        {
            return bad(format!(
                "saliency_weight (--saliency) must be ≥ 0, got {}",
                self.perceptual.saliency_weight
            ));
        }
        let w = self.perceptual.threshold.adaptation_window_deg;
        if !(w.is_finite() && w > 0.0) {
            return bad(format!(
                "adaptation window (--adaptation-window) must be positive, got {w} degrees"
            ));
        }
        if !(self.perceptual.latitude_ev.is_finite()
            && (0.0..=10.0).contains(&self.perceptual.latitude_ev))
        {
            return bad(format!(
                "exposure latitude (--latitude) must be in [0, 10] stops, got {}",
                self.perceptual.latitude_ev
            ));
        }
        if self.perceptual.guide_spp == 0 {
            return bad("guide_spp (--guide-spp) must be at least 1".into());
        }
        if self.time_budget.is_some_and(|t| t.is_zero()) {
            return bad("time_budget (--time) must be positive".into());
        }
        if self.denoise && !crate::denoise::AVAILABLE {
            return bad(format!("--denoise: {}", crate::denoise::HOW_TO_BUILD));
        }
        Ok(())
    }
}

/// What one pass did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassReport {
    /// Pass number (0 = the uniform first pass).
    pub pass: usize,
    /// Mean samples per pixel after the pass.
    pub mean_spp: f64,
    /// Fraction of pixels at or below threshold before the next allocation.
    pub converged_fraction: f64,
    /// Samples taken in this pass.
    pub samples: u64,
    /// Wall time of rendering those samples (the guide and the judgement excluded).
    pub render: Duration,
}

/// The result of an adaptive render.
#[derive(Clone, Debug)]
pub struct AdaptiveResult {
    /// The sample buffers.
    pub film: Film,
    /// Counters of the image's passes.
    pub stats: RenderStats,
    /// Counters of the guide render (perceptual sampler only).
    pub guide_stats: Option<RenderStats>,
    /// One entry per pass.
    pub passes: Vec<PassReport>,
    /// Why the loop stopped.
    pub stop: StopReason,
    /// Fraction of pixels converged at the end.
    pub converged_fraction: f64,
    /// Last threshold per pixel (perceptual: ΔL_T in `units`; variance: the noise threshold).
    pub threshold: Option<Vec<f32>>,
    /// Last error estimate per pixel (in `units`).
    pub error: Option<Vec<f32>>,
    /// Units of `threshold` and `error`.
    pub units: &'static str,
    /// Time spent deciding: the perception model (its setup and every judgement) or the
    /// variance criterion, excluding rendering (the guide render is in `guide_stats`).
    pub decision_time: Duration,
    /// Total wall time, guide and decisions included.
    pub wall: Duration,
    /// The frame's velocity map (sequences only), whatever the sampler.
    pub velocity: Option<VelocityMap>,
    /// The G-buffer at the pixel centres (`None` only for a film merged from parts).
    pub gbuffer: Option<GBuffer>,
    /// What the frame reused from earlier frames (`None` when it reused nothing).
    pub reuse: Option<ReuseReport>,
    /// The denoised image, when [`AdaptiveSettings::denoise`] is set.
    pub denoised: Option<Denoised>,
    /// Wall time of denoising: the auxiliary images, a preview's refinements and the final
    /// image (all included in `wall`; the judgements' denoising of the half-buffers is in
    /// `decision_time`).
    pub denoise_time: Duration,
}

/// What one frame reused from the frames before it ([`crate::reuse`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReuseReport {
    /// Earlier frames reprojected.
    pub frames: usize,
    /// Mean reused weight per pixel, samples (the EXR's `History.spp`).
    pub mean_history_spp: f64,
    /// Fraction of pixels that reused anything.
    pub reused_fraction: f64,
    /// Wall time of the reprojection and its test against the fresh samples.
    pub time: Duration,
}

impl AdaptiveResult {
    /// Mean samples per pixel of the image (guide excluded).
    pub fn mean_spp(&self) -> f64 {
        self.film.total_samples() as f64 / self.film.len() as f64
    }
}

/// The mutable state of the loop between passes.
struct LoopState {
    film: Film,
    stats: RenderStats,
    passes: Vec<PassReport>,
    /// Rendering time of the samples not yet reported.
    unreported_render: Duration,
    decision_time: Duration,
    /// The pixels (row-major indices) that take samples after the first pass.
    region: std::ops::Range<usize>,
}

impl LoopState {
    /// An empty film and the region of pixels this render owns: all of them, or the rows of
    /// `s.rows` (an error if they are not a range inside the image).
    fn new(scene: &Scene, s: &AdaptiveSettings) -> Result<LoopState, AdaptiveError> {
        let w = scene.camera.width as usize;
        let region = match s.rows {
            None => 0..w * scene.camera.height as usize,
            Some((a, b)) if a < b && b <= scene.camera.height => a as usize * w..b as usize * w,
            Some((a, b)) => {
                return Err(AdaptiveError::Settings(format!(
                    "rows {a}..{b} are not a range inside the image's {} rows",
                    scene.camera.height
                )));
            }
        };
        Ok(LoopState {
            region,
            film: Film::new(scene.camera.width, scene.camera.height),
            stats: RenderStats::default(),
            passes: Vec::new(),
            unreported_render: Duration::ZERO,
            decision_time: Duration::ZERO,
        })
    }

    /// Renders `counts[i]` more samples into pixel i of the film, drawn as `streams` says, and
    /// keeps the pass's statistics and its rendering time (for the next report); returns them.
    fn render(
        &mut self,
        scene: &Scene,
        integrator: &Integrator,
        counts: &[u32],
        streams: SampleStreams,
        sample_progress: &(dyn Fn(u64) + Sync),
    ) -> RenderStats {
        let pass = render_counts(
            scene,
            integrator,
            &mut self.film,
            counts,
            streams,
            sample_progress,
        );
        self.unreported_render += pass.wall;
        self.stats += pass;
        pass
    }

    /// Renders `pass` ([`crate::render::render_counts_recorded`]) and returns every sample
    /// taken.
    fn render_recorded(
        &mut self,
        scene: &Scene,
        integrator: &Integrator,
        pass: &crate::render::Pass,
        sample_progress: &(dyn Fn(u64) + Sync),
    ) -> Vec<crate::reuse::Sample> {
        let (stats, samples) = crate::render::render_counts_recorded(
            scene,
            integrator,
            &mut self.film,
            pass,
            sample_progress,
        );
        self.unreported_render += stats.wall;
        self.stats += stats;
        samples
    }

    /// Records a pass's report (and calls `progress`); returns the fraction converged.
    fn report(&mut self, ratio: &[f32], progress: &(dyn Fn(&PassReport) + Sync)) -> f64 {
        let n_px = self.region.len();
        let taken = self.region_samples();
        let prev: u64 = self.passes.iter().map(|p| p.samples).sum();
        let converged = ratio[self.region.clone()]
            .par_iter()
            .filter(|&&r| r <= 1.0)
            .count() as f64
            / n_px as f64;
        let report = PassReport {
            pass: self.passes.len(),
            mean_spp: taken as f64 / n_px as f64,
            converged_fraction: converged,
            samples: taken - prev,
            render: std::mem::take(&mut self.unreported_render),
        };
        progress(&report);
        self.passes.push(report);
        converged
    }

    /// The loop's result (without guide statistics, G-buffer, reuse or denoised image): the
    /// converged fraction of the last pass, the last judgement's maps.
    fn finish(
        self,
        s: &AdaptiveSettings,
        stop: StopReason,
        judgement: Option<Judgement>,
        velocity: Option<VelocityMap>,
        start: Instant,
    ) -> AdaptiveResult {
        let converged_fraction = self.passes.last().map_or(0.0, |p| p.converged_fraction);
        let (threshold, error) = match judgement {
            Some(j) => (Some(j.threshold), Some(j.error)),
            None => (None, None),
        };
        AdaptiveResult {
            film: self.film,
            stats: self.stats,
            guide_stats: None,
            passes: self.passes,
            stop,
            converged_fraction,
            threshold,
            error,
            units: s.units(),
            decision_time: self.decision_time,
            wall: start.elapsed(),
            velocity,
            gbuffer: None,
            reuse: None,
            denoised: None,
            denoise_time: Duration::ZERO,
        }
    }

    /// Samples taken in the region.
    fn region_samples(&self) -> u64 {
        self.film.pixels[self.region.clone()]
            .iter()
            .map(|p| p.count() as u64)
            .sum()
    }

    /// Keeps the pass inside the region.
    fn clip(&self, alloc: &mut Allocation) {
        let r = &self.region;
        for (i, (c, o)) in alloc.want.iter_mut().zip(&mut alloc.reopen).enumerate() {
            if !r.contains(&i) {
                *c = 0;
                *o = false;
            }
        }
    }
}

/// Renders `scene` adaptively. `progress` is called after every pass.
///
/// # Errors
/// [`AdaptiveError::Settings`] for a setting out of range ([`AdaptiveSettings::validate`]);
/// [`AdaptiveError::Perception`] if the perception model rejects the images (it should not for
/// a valid render) or the tone settings are invalid; [`AdaptiveError::Denoise`] if the
/// denoiser fails.
pub fn render_adaptive(
    scene: &Scene,
    s: &AdaptiveSettings,
    progress: &(dyn Fn(&PassReport) + Sync),
    sample_progress: &(dyn Fn(u64) + Sync),
) -> Result<AdaptiveResult, AdaptiveError> {
    render_with_hooks(scene, s, progress, sample_progress, None)
}

/// The image after a pass of the adaptive loop, for a progressive preview.
pub struct Refinement<'a> {
    /// The refinement's number, 1 for the first image. A preview's first pass of
    /// [`AdaptiveSettings::min_spp`] samples per pixel is shown twice: after its first sample
    /// and when it is whole; each later pass is shown once.
    pub number: usize,
    /// The sample buffers.
    pub film: &'a Film,
    /// The film's mean denoised (interleaved RGB, W·sr⁻¹·m⁻²), when the loop denoises
    /// ([`AdaptiveSettings::denoise`]).
    pub denoised: Option<&'a [f32]>,
}

/// [`render_adaptive`], calling `refined` with the film (and, when the loop denoises, its
/// image denoised by OIDN's fast model, [`crate::denoise::Quality::Fast`]) after every pass
/// that added samples, before it is judged, so a preview shows each refinement as early as it
/// can. The result's image is denoised again by the high-quality model.
///
/// # Errors
/// As [`render_adaptive`].
pub fn render_adaptive_refining(
    scene: &Scene,
    s: &AdaptiveSettings,
    progress: &(dyn Fn(&PassReport) + Sync),
    sample_progress: &(dyn Fn(u64) + Sync),
    refined: &(dyn Fn(&Refinement) + Sync),
) -> Result<AdaptiveResult, AdaptiveError> {
    render_with_hooks(scene, s, progress, sample_progress, Some(refined))
}

fn render_with_hooks(
    scene: &Scene,
    s: &AdaptiveSettings,
    progress: &(dyn Fn(&PassReport) + Sync),
    sample_progress: &(dyn Fn(u64) + Sync),
    refined: Option<&(dyn Fn(&Refinement) + Sync)>,
) -> Result<AdaptiveResult, AdaptiveError> {
    s.validate()?;
    let t_aux = Instant::now();
    let seed = scene.settings.seed;
    // A preview shows its first images (the first pass, twice) with auxiliaries of fewer
    // samples and makes the full ones for its first judgement (`Hooks::aux`); a render makes
    // them first.
    let preview = refined.is_some();
    let first_aux = (s.denoise && preview)
        .then(|| crate::denoise::render_aux(scene, crate::denoise::PREVIEW_FIRST_AUX_SPP, seed));
    let aux = OnceCell::new();
    if s.denoise && !preview {
        let _ = aux.set(crate::denoise::render_aux(
            scene,
            crate::denoise::AUX_SPP,
            seed,
        ));
    }
    let aux_time = t_aux.elapsed();
    let hooks = Hooks {
        progress,
        sample_progress,
        refined,
        scene,
        aux,
        first_aux,
        last: RefCell::new(None),
        denoise_time: Cell::new(Duration::ZERO),
        shown: Cell::new(0),
    };
    // The loop's wall time includes the refinements' denoising (and a preview's full
    // auxiliaries); the auxiliary images made before it and the final denoising are added.
    let mut r = adaptive_loop(scene, s, &hooks)?;
    r.denoise_time = aux_time + hooks.denoise_time.get();
    if s.denoise {
        let t = Instant::now();
        // The refinements were denoised by the fast model; the result by the one the job asks.
        let mut denoised = Denoised::of(
            scene,
            r.film.mean_rgb(),
            hooks.take_aux(),
            r.mean_spp(),
            s.denoise_quality,
        )?;
        // Above 16 spp, the raw render blended back by the two images' errors.
        denoised.blend_with_noisy(&r.film, r.mean_spp());
        r.denoise_time += t.elapsed();
        r.wall += aux_time + t.elapsed();
        r.denoised = Some(denoised);
    }
    r.gbuffer = Some(GBuffer::render_aovs(scene));
    Ok(r)
}

/// What the loop reports to and gives its caller's callbacks.
struct Hooks<'a> {
    progress: &'a (dyn Fn(&PassReport) + Sync),
    sample_progress: &'a (dyn Fn(u64) + Sync),
    refined: Option<&'a (dyn Fn(&Refinement) + Sync)>,
    scene: &'a Scene,
    /// The denoiser's auxiliary images at [`crate::denoise::AUX_SPP`], when the loop
    /// denoises: made before the loop, or for a preview at its first judgement.
    aux: OnceCell<Aux>,
    /// A preview's auxiliary images for its first image, at
    /// [`crate::denoise::PREVIEW_FIRST_AUX_SPP`].
    first_aux: Option<Aux>,
    /// The last refinement's denoised image (fast model).
    last: RefCell<Option<Vec<f32>>>,
    /// Wall time spent denoising: the auxiliary images and the refinements.
    denoise_time: Cell<Duration>,
    /// Refinements shown so far.
    shown: Cell<usize>,
}

impl Hooks<'_> {
    /// The auxiliary images the loop judges by and the result is denoised with ([`Hooks::aux`]),
    /// made now if a preview has not made them yet; `None` when the loop does not denoise.
    fn aux(&self) -> Option<&Aux> {
        if self.aux.get().is_none() && self.first_aux.is_some() {
            let t = Instant::now();
            let seed = self.scene.settings.seed;
            let full = crate::denoise::render_aux(self.scene, crate::denoise::AUX_SPP, seed);
            let _ = self.aux.set(full);
            self.denoise_time.set(self.denoise_time.get() + t.elapsed());
        }
        self.aux.get()
    }

    /// The full auxiliary images, for the result.
    ///
    /// # Panics
    /// If the loop does not denoise.
    fn take_aux(mut self) -> Aux {
        self.aux();
        self.aux.take().expect("the loop denoises")
    }

    /// Shows the film to the refinement callback, if any, denoised first (by the fast model)
    /// when the loop denoises: with a preview's quick auxiliaries until the full ones are
    /// made, for the loop's first judgement (so the first pass is shown twice with the quick
    /// ones).
    fn refined(&self, film: &Film) -> Result<(), AdaptiveError> {
        let Some(refined) = self.refined else {
            return Ok(());
        };
        self.shown.set(self.shown.get() + 1);
        if let Some(aux) = self.aux.get().or(self.first_aux.as_ref()) {
            let t = Instant::now();
            let (w, h) = (film.width as usize, film.height as usize);
            let rgb = crate::denoise::denoise_with(
                &film.mean_rgb(),
                w,
                h,
                aux,
                crate::denoise::Quality::Fast,
            )?;
            self.denoise_time.set(self.denoise_time.get() + t.elapsed());
            *self.last.borrow_mut() = Some(rgb);
        }
        {
            let last = self.last.borrow();
            refined(&Refinement {
                number: self.shown.get(),
                film,
                denoised: last.as_deref(),
            });
        }
        Ok(())
    }
}

/// [`render_adaptive`] without the G-buffer and the final denoising.
/// Renders the loop's first pass, `min_spp` samples in every pixel, and shows it. A preview
/// (a refinement callback) is shown the pixels' first samples before the rest of the pass:
/// the film is the same, as a pixel's later samples continue its sequences
/// ([`crate::render::render_counts`]), and the first image comes in about half the time.
fn render_first_pass(
    st: &mut LoopState,
    scene: &Scene,
    integrator: &Integrator,
    min_spp: u32,
    streams: SampleStreams,
    hooks: &Hooks,
) -> Result<(), AdaptiveError> {
    let n = st.film.len();
    let mut first = min_spp;
    if hooks.refined.is_some() && min_spp > 1 {
        st.render(
            scene,
            integrator,
            &vec![1; n],
            streams,
            hooks.sample_progress,
        );
        hooks.refined(&st.film)?;
        first -= 1;
    }
    st.render(
        scene,
        integrator,
        &vec![first; n],
        streams,
        hooks.sample_progress,
    );
    hooks.refined(&st.film)
}

fn adaptive_loop(
    scene: &Scene,
    s: &AdaptiveSettings,
    hooks: &Hooks,
) -> Result<AdaptiveResult, AdaptiveError> {
    let (progress, sample_progress) = (hooks.progress, hooks.sample_progress);
    let start = Instant::now();
    let integrator = Integrator {
        max_depth: scene.settings.max_depth,
        strategy: Strategy::Mis,
    };
    let velocity = render_velocity(scene);
    let mut st = LoopState::new(scene, s)?;
    if !s.steers() {
        // The uniform sampler, or a budget too small to steer: one uniform pass of the whole
        // budget over the rows this render owns.
        let mut r = render_uniform_budget(scene, s, st, progress, sample_progress, start);
        hooks.refined(&r.film)?;
        r.velocity = velocity;
        return Ok(r);
    }
    let n_px = st.region.len();
    let budget_total = s.budget_spp.map(|b| (b * n_px as f64).round() as u64);
    // A budget below min_spp makes the first pass the whole render (as uniform).
    let min_spp = match budget_total {
        Some(b) => s.min_spp.min((b / n_px as u64).max(1) as u32),
        None => s.min_spp,
    };
    render_first_pass(&mut st, scene, &integrator, min_spp, s.streams(), hooks)?;
    if budget_total.is_some_and(|b| st.region_samples() as f64 >= b as f64 - 0.002 * n_px as f64) {
        return Ok(unjudged(st, s, progress, velocity, start));
    }
    // The threshold mapper's setup (filters, FFT plans) is a decision cost too.
    let t_setup = Instant::now();
    let mut criterion = judge_for(scene, s, velocity.as_ref(), &st.film)?;
    st.decision_time += t_setup.elapsed();
    let mut rate = st.stats.samples as f64 / st.stats.wall.as_secs_f64().max(1e-9);
    let cap = s.pixel_cap();
    let mut cost = JudgeCost::default();
    let (judgement, stop) = loop {
        let t0 = Instant::now();
        let refresh_before = criterion.next_refresh_spp();
        let (judgement, guide_time) = criterion.judge(scene, &st.film, s, hooks.aux())?;
        let noise = criterion.relative_noise(&st.film);
        let ratio = Judge::ratio(&judgement, noise.as_deref());
        let judged = t0.elapsed().saturating_sub(guide_time);
        st.decision_time += judged;
        cost.record(judged, criterion.next_refresh_spp() != refresh_before);
        let converged = st.report(&ratio, progress);
        let remaining = budget_total.map(|b| b.saturating_sub(st.region_samples()));
        let floor = pixel_floor(s, &st);
        // A converged stop is not ended here: its last pass lifts the pixels left under the
        // floor (planned below), and it ends when there are none.
        if let Some(reason) = stop_before_pass(s, &st, remaining, start) {
            break (judgement, reason);
        }
        let done = converged >= converged_target(s, remaining);
        let mut alloc = plan_pass(&st, &ratio, noise.as_deref(), floor, remaining, done, cap);
        if alloc.total() == 0 {
            let reason = if done {
                StopReason::Converged
            } else {
                StopReason::MaxSpp
            };
            break (judgement, reason);
        }
        if let Some(rem) = remaining {
            fit_to_budget(&mut alloc, &st.film, &ratio, rem, cap);
        }
        if let Some(limit) = s.time_budget {
            let refresh_at = criterion.next_refresh_spp();
            let Some(samples) = affordable_samples(&st, limit, start, rate, &cost, refresh_at)
            else {
                break (judgement, StopReason::Time);
            };
            fit_to_budget(&mut alloc, &st.film, &ratio, samples, cap);
        }
        let pass = st.render(
            scene,
            &integrator,
            &alloc.want,
            s.streams(),
            sample_progress,
        );
        rate = pass.samples as f64 / pass.wall.as_secs_f64().max(1e-9);
        hooks.refined(&st.film)?;
    };
    let mut r = st.finish(s, stop, Some(judgement), velocity, start);
    r.guide_stats = criterion.guide_stats();
    Ok(r)
}

/// The per-pixel judge of `s.criterion` (the perceptual one sees the frame's motion unless
/// velocity is off).
fn judge_for(
    scene: &Scene,
    s: &AdaptiveSettings,
    velocity: Option<&crate::velocity::VelocityMap>,
    film: &Film,
) -> Result<Judge, AdaptiveError> {
    Ok(match s.criterion {
        Criterion::Perceptual => {
            let motion = velocity
                .filter(|_| s.perceptual.use_velocity)
                .map(|v| v.motion_px_per_frame());
            Judge::Perceptual(Box::new(PerceptualCriterion::new(scene, s, motion)?))
        }
        _ => Judge::Variance(VarianceCriterion::new(film, s.variance_threshold)),
    })
}

/// The samples the next pass may take to land on the time budget `limit`: what the measured
/// `rate` (samples/s) allows in the time left after the judgement that follows the pass. That
/// judgement costs a refresh of the threshold map if the pass takes the film past the refresh
/// point `refresh_at` (spp), else an update of the error. `None`: too few to be worth a pass
/// (under 0.002 spp), the time is spent.
fn affordable_samples(
    st: &LoopState,
    limit: Duration,
    start: Instant,
    rate: f64,
    cost: &JudgeCost,
    refresh_at: Option<f64>,
) -> Option<u64> {
    let n_px = st.region.len() as f64;
    let taken = st.region_samples() as f64;
    let affordable = |judge: Duration| {
        let left = limit.saturating_sub(start.elapsed() + judge);
        (left.as_secs_f64() * rate) as u64
    };
    let mut samples = affordable(cost.update);
    if refresh_at.is_some_and(|at| (taken + samples as f64) / n_px >= at) {
        samples = affordable(cost.refresh);
    }
    ((samples as f64) >= 0.002 * n_px).then_some(samples)
}

/// The converged fraction that ends the loop's steering: without a budget (`remaining` is
/// `None`) the stop's `converged_fraction`, under one [`allocate::FILL_FROM_CONVERGED`], where
/// the rest of the budget is spread evenly.
fn converged_target(s: &AdaptiveSettings, remaining: Option<u64>) -> f64 {
    match remaining {
        Some(_) => allocate::FILL_FROM_CONVERGED,
        None => s.converged_fraction,
    }
}

/// The next pass's allocation from the current ratios (and relative noise): the doublings
/// above threshold ([`allocate`]), the floor, clipped to the rows this render owns; then, under
/// a budget (`remaining` samples left), the even fill ([`allocate::fill_to_level`]) once the
/// converged fraction is reached (`converged`: the model has no ranking left to act on) or when
/// nothing else wants samples (every pixel the model still wants is at the cap). Without a
/// budget a converged pass only lifts the pixels under the floor: the stop has been reached,
/// and doubling the few pixels still above threshold (with their neighbours, each rounded up
/// to a stratified total) is the tail the converged fraction exists to cut
/// ([`DEFAULT_CONVERGED_FRACTION`]).
fn plan_pass(
    st: &LoopState,
    ratio: &[f32],
    noise: Option<&[f32]>,
    floor: Option<u32>,
    remaining: Option<u64>,
    converged: bool,
    cap: u32,
) -> Allocation {
    let mut alloc = if converged && remaining.is_none() {
        Allocation::empty(st.film.len())
    } else {
        allocate(&st.film, ratio, cap)
    };
    if let Some(f) = floor {
        allocate::raise_to_floor(&mut alloc, &st.film, ratio, noise, f, cap);
    }
    st.clip(&mut alloc);
    if let Some(rem) = remaining.filter(|_| converged || alloc.total() == 0) {
        let region = st.region.clone();
        allocate::fill_to_level(&mut alloc, &st.film, ratio, noise, region, rem, cap);
    }
    alloc
}

/// Measured wall time of the two kinds of judgement, for sizing the last pass of a time budget.
#[derive(Default)]
struct JudgeCost {
    /// The last judgement that recomputed the threshold map (the first one included, which
    /// also made the guide's maps: an overestimate that errs towards ending early).
    refresh: Duration,
    /// The last judgement that only updated the error.
    update: Duration,
}

impl JudgeCost {
    fn record(&mut self, t: Duration, refreshed: bool) {
        if refreshed {
            self.refresh = t;
        } else {
            self.update = t;
        }
        // Until an update has been seen, assume it costs as much as a refresh.
        if self.update.is_zero() {
            self.update = self.refresh;
        }
    }
}

/// The result when the first pass spent the budget: nothing is left to steer, so nothing is
/// judged (judging would only cost time, as the guide and threshold maps did at 8 spp).
fn unjudged(
    mut st: LoopState,
    s: &AdaptiveSettings,
    progress: &(dyn Fn(&PassReport) + Sync),
    velocity: Option<VelocityMap>,
    start: Instant,
) -> AdaptiveResult {
    st.report(&vec![f32::INFINITY; st.film.len()], progress);
    st.finish(s, StopReason::Budget, None, velocity, start)
}

/// The perceptual sampler's floor, rounded down to a stratified total: under a budget B,
/// [`allocate::FLOOR_SHARE`] · B; without one, [`allocate::stop_floor_share`] of the region's
/// current mean spp. `None` for the variance sampler.
fn pixel_floor(s: &AdaptiveSettings, st: &LoopState) -> Option<u32> {
    if s.criterion != Criterion::Perceptual {
        return None;
    }
    let target = match s.budget_spp {
        Some(b) => allocate::FLOOR_SHARE * b,
        None => {
            let share = allocate::stop_floor_share(s.denoise, s.converged_fraction);
            share * st.region_samples() as f64 / st.region.len() as f64
        }
    };
    Some(allocate::stratified_floor(target))
}

/// Why the loop stops before allocating another pass, if it does: the time budget or the
/// sample budget. Convergence ends the loop once the pass it plans is empty ([`plan_pass`]).
fn stop_before_pass(
    s: &AdaptiveSettings,
    st: &LoopState,
    remaining: Option<u64>,
    start: Instant,
) -> Option<StopReason> {
    if s.time_budget.is_some_and(|limit| start.elapsed() >= limit) {
        return Some(StopReason::Time);
    }
    let n_px = st.region.len() as f64;
    if remaining.is_some_and(|r| r == 0 || (r as f64) < 0.002 * n_px) {
        return Some(StopReason::Budget);
    }
    None
}

/// The uniform sampler (and an adaptive one under its `steer_from_spp`): one pass of the whole
/// budget over the render's rows (bit-identical to a plain render of that spp), one pattern of
/// that many points per pixel ([`SampleStreams::Fixed`]: nothing steers by its half-buffers).
fn render_uniform_budget(
    scene: &Scene,
    s: &AdaptiveSettings,
    mut st: LoopState,
    progress: &(dyn Fn(&PassReport) + Sync),
    sample_progress: &(dyn Fn(u64) + Sync),
    start: Instant,
) -> AdaptiveResult {
    let integrator = Integrator {
        max_depth: scene.settings.max_depth,
        strategy: Strategy::Mis,
    };
    let spp = s.uniform_total_spp();
    let mut counts = vec![0; st.film.len()];
    counts[st.region.clone()].fill(spp);
    st.stats += render_counts(
        scene,
        &integrator,
        &mut st.film,
        &counts,
        SampleStreams::Fixed(spp),
        sample_progress,
    );
    let report = PassReport {
        pass: 0,
        mean_spp: spp as f64,
        converged_fraction: 1.0,
        samples: st.stats.samples,
        render: st.stats.wall,
    };
    progress(&report);
    AdaptiveResult {
        film: st.film,
        stats: st.stats,
        guide_stats: None,
        passes: vec![report],
        stop: if s.budget_spp.is_some() {
            StopReason::Budget
        } else {
            StopReason::MaxSpp
        },
        converged_fraction: 1.0,
        threshold: None,
        error: None,
        units: "",
        decision_time: Duration::ZERO,
        wall: start.elapsed(),
        velocity: None,
        gbuffer: None,
        reuse: None,
        denoised: None,
        denoise_time: Duration::ZERO,
    }
}
