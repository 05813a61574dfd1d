//! Adaptive sampling: spend samples only where the remaining error is still visible.
//!
//! One loop serves three samplers; only the per-pixel "needs more" decision differs:
//! - perceptual ([`SamplerKind::Perceptual`]): error (half-buffer difference, in display or scene cd/m²)
//!   against the threshold map ΔL_T of the `perception` crate (Ramasubramanian et al. 1999; Yee
//!   et al. 2001);
//! - variance ([`SamplerKind::Variance`]): Blender Cycles' noise-threshold criterion (after Dammertz et al.
//!   2010), the production baseline;
//! - uniform ([`SamplerKind::Uniform`]): the same budget spread evenly.
//!
//! # The loop (aleph DESIGN §8)
//! 1. A uniform pass of `min_spp` samples.
//! 2. Each pass: the current image and its two half-buffers (even and odd samples) are mapped to
//!    the luminance in which visibility is judged; the error estimate is e = |Y(A) − Y(B)| / 2,
//!    averaged over 3×3 pixels so a single lucky pixel is not called converged; the ratio
//!    r = e / threshold says how far a pixel is from converged.
//! 3. Pixels with r > t (t = 1: at threshold) get more samples, and so do their 8 neighbours
//!    (re-opening, as Cycles' box pass does, so thin features are not frozen early). Error falls
//!    as 1/√n, so a pixel needs about n (r²/t² − 1) more samples; each pass gives that, at most
//!    doubling a pixel's count (so the estimate is re-checked often), at least n/4 to re-opened
//!    neighbours, and never past `max_spp`.
//! 4. Stop when the fraction of converged pixels (r ≤ 1) reaches `converged_fraction`, or at the
//!    average budget (`budget_spp`), the per-pixel cap, or the time budget. With an average
//!    budget the sampler spends all of it: whenever the target fraction is reached, t is halved
//!    and refinement continues where the ratio is largest.
//!
//! # The perceptual threshold
//! ΔL_T(x) = ΔL_TVI(L_a(x)) · F(x). L_a is recomputed each pass from the current image (a 1°
//! Gaussian mean, where noise averages out). The elevation F (spatial frequency and masking) is
//! computed once, from a **low-noise guide**: a render of direct illumination only (max depth 1,
//! `guide_spp` samples, independent seed), as Ramasubramanian et al. computed the spatial part
//! of their map from the direct-illumination image. Computing F from the noisy image itself
//! would let its noise mask itself and stop sampling exactly where noise is worst.
//!
//! # Where visibility is judged
//! [`Visibility::Display`] (default): on the image as displayed, in display cd/m² — the current
//! image's tone curve is frozen each pass ([`FrozenToneMap`]) and applied to the image and both
//! half-buffers. [`Visibility::Scene`]: in scene luminance, cd/m² = Y × the scene's
//! `luminance_scale`, as Ramasubramanian et al. did.
//!
//! # Determinism
//! Every decision is a function of the film, which is bit-identical for any thread count, so
//! the image and the sample-count map are too — except with a time budget, whose stopping pass
//! depends on speed.

use crate::display::{FrozenToneMap, ToneMapSettings};
use crate::film::Film;
use crate::integrator::{Integrator, Strategy};
use crate::render::{RenderStats, render_albedo, render_counts};
use crate::scene::Scene;
use perception::adaptation::{AdaptationMode, adaptation_luminance, log_average};
use perception::photometry::luminance_image;
use perception::threshold::{ThresholdMapper, ThresholdParams};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Which per-pixel decision steers the samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SamplerKind {
    /// Error against the perceptual threshold map.
    Perceptual,
    /// The same number of samples everywhere.
    Uniform,
    /// Cycles' relative noise threshold.
    Variance,
}

impl SamplerKind {
    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Perceptual => "perceptual",
            SamplerKind::Uniform => "uniform",
            SamplerKind::Variance => "variance",
        }
    }
}

/// Where visibility is judged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorEstimate {
    /// |Y(A) − Y(B)| / 2 from the two half-buffers, in visibility units.
    HalfBuffers,
    /// The standard error of the mean sqrt(var(Y)/n) from Σ Y², mapped to visibility units by
    /// the pixel's display gain Y_d/Y (more degrees of freedom than one half-buffer difference).
    StandardError,
}

/// Cycles' default noise threshold.
pub const CYCLES_DEFAULT_THRESHOLD: f32 = 0.01;

/// Settings of the adaptive loop.
#[derive(Clone, Debug)]
pub struct AdaptiveSettings {
    /// The sampler.
    pub sampler: SamplerKind,
    /// Samples per pixel of the first, uniform pass (default 8; at least 2 for half-buffers).
    pub min_spp: u32,
    /// Cap on any one pixel's samples (default 4096).
    pub max_spp: u32,
    /// Average samples per pixel to spend (N × pixels in total); `None`: until converged (for
    /// `uniform`: `uniform_spp` everywhere).
    pub budget_spp: Option<f64>,
    /// Samples per pixel of the uniform sampler without a budget (the scene's `render.spp`).
    pub uniform_spp: u32,
    /// Wall-time budget.
    pub time_budget: Option<Duration>,
    /// Fraction of pixels below threshold that counts as converged (default 0.995).
    pub converged_fraction: f64,
    /// Where visibility is judged (default: display).
    pub visibility: Visibility,
    /// The tone mapping of the displayed image (and the viewing conditions).
    pub tone: ToneMapSettings,
    /// Threshold-map settings.
    pub threshold: ThresholdParams,
    /// Cycles' noise threshold for the variance sampler (default 0.01).
    pub variance_threshold: f32,
    /// Weight ω of visual saliency in the perceptual threshold (Yee et al. 2001's Aleph map,
    /// ΔL / (1 + ω S) with S the Itti–Koch–Niebur saliency of the first pass's display image);
    /// 0 (default) turns it off.
    pub saliency_weight: f32,
    /// Error estimate of the perceptual sampler (default: half-buffers).
    pub error_estimate: ErrorEstimate,
    /// Samples per pixel of the albedo guide (default 4; only antialiasing needs them).
    pub guide_spp: u32,
}

impl Default for AdaptiveSettings {
    fn default() -> Self {
        AdaptiveSettings {
            sampler: SamplerKind::Perceptual,
            min_spp: 8,
            max_spp: 4096,
            budget_spp: None,
            uniform_spp: 64,
            time_budget: None,
            converged_fraction: 0.995,
            visibility: Visibility::Display,
            tone: ToneMapSettings {
                operator: perception::tmo::Operator::Exposure,
                ..ToneMapSettings::default()
            },
            threshold: ThresholdParams::default(),
            variance_threshold: CYCLES_DEFAULT_THRESHOLD,
            guide_spp: 4,
            error_estimate: ErrorEstimate::HalfBuffers,
            saliency_weight: 0.0,
        }
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
    /// Time spent in the perception model (and the variance criterion), excluding rendering.
    pub decision_time: Duration,
    /// Total wall time, guide and decisions included.
    pub wall: Duration,
}

impl AdaptiveResult {
    /// Mean samples per pixel of the image (guide excluded).
    pub fn mean_spp(&self) -> f64 {
        self.film.total_samples() as f64 / self.film.len() as f64
    }
}

/// 3×3 box mean with clamped edges.
fn box3(v: &[f32], w: usize, h: usize) -> Vec<f32> {
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            let mut s = 0.0;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let xx = (x + dx).clamp(0, w as i64 - 1) as usize;
                    let yy = (y + dy).clamp(0, h as i64 - 1) as usize;
                    s += v[yy * w + xx];
                }
            }
            s / 9.0
        })
        .collect()
}

/// 3×3 dilation of a mask.
fn dilate3(m: &[bool], w: usize, h: usize) -> Vec<bool> {
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let xx = x + dx;
                    let yy = y + dy;
                    xx >= 0
                        && yy >= 0
                        && xx < w as i64
                        && yy < h as i64
                        && m[yy as usize * w + xx as usize]
                })
            })
        })
        .collect()
}

/// Per-pixel error and threshold of the current film.
struct Judgement {
    error: Vec<f32>,
    threshold: Vec<f32>,
}

impl Judgement {
    fn ratio(&self) -> Vec<f32> {
        self.error
            .par_iter()
            .zip(self.threshold.par_iter())
            .map(|(e, t)| e / t.max(1e-30))
            .collect()
    }
}

/// The state the perceptual criterion keeps between passes.
struct PerceptualState {
    /// Threshold RMS contrast of pixel noise, from the guide.
    noise_contrast: Vec<f32>,
    /// Saliency in [0, 1] of the first pass's display image, when ω > 0.
    saliency: Option<Vec<f32>>,
}

/// Luminance in visibility units of linear RGB under a frozen display map or the scene scale.
fn visible_luminance(
    rgb: &[f32],
    frozen: Option<&FrozenToneMap>,
    scale: f32,
) -> perception::Result<Vec<f32>> {
    match frozen {
        Some(f) => f.display_luminance(rgb),
        None => Ok(luminance_image(rgb, scale)),
    }
}

/// Renders `scene` adaptively. `progress` is called after every pass.
///
/// # Errors
/// [`perception::PerceptionError`] if the perception model rejects the images (it should not
/// for a valid render) or the tone settings are invalid.
pub fn render_adaptive(
    scene: &Scene,
    s: &AdaptiveSettings,
    progress: &(dyn Fn(&PassReport) + Sync),
    sample_progress: &(dyn Fn(u64) + Sync),
) -> perception::Result<AdaptiveResult> {
    let start = Instant::now();
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let n_px = w * h;
    let integrator = Integrator {
        max_depth: scene.settings.max_depth,
        strategy: Strategy::Mis,
    };
    let mut film = Film::new(w as u32, h as u32);
    let mut stats = RenderStats::default();
    let mut passes = Vec::new();
    let budget_total = s.budget_spp.map(|b| (b * n_px as f64).round() as u64);
    let mut decision_time = Duration::ZERO;

    // Uniform: one pass of the whole budget (bit-identical to a plain render of that spp).
    if s.sampler == SamplerKind::Uniform {
        let spp = match s.budget_spp {
            Some(b) => b.round().max(1.0) as u32,
            None => s.uniform_spp,
        }
        .min(s.max_spp);
        let counts = vec![spp; n_px];
        stats += render_counts(scene, &integrator, &mut film, &counts, sample_progress);
        passes.push(PassReport {
            pass: 0,
            mean_spp: spp as f64,
            converged_fraction: 1.0,
            samples: stats.samples,
        });
        progress(&passes[0]);
        return Ok(AdaptiveResult {
            film,
            stats,
            guide_stats: None,
            passes,
            stop: if s.budget_spp.is_some() {
                StopReason::Budget
            } else {
                StopReason::MaxSpp
            },
            converged_fraction: 1.0,
            threshold: None,
            error: None,
            units: "",
            decision_time,
            wall: start.elapsed(),
        });
    }

    // First pass.
    let min_spp = match budget_total {
        Some(b) => s.min_spp.min((b / n_px as u64).max(1) as u32),
        None => s.min_spp,
    }
    .clamp(1, s.max_spp);
    stats += render_counts(
        scene,
        &integrator,
        &mut film,
        &vec![min_spp; n_px],
        sample_progress,
    );

    // Guide and threshold elevation (perceptual).
    let mut guide_stats = None;
    let mut perceptual: Option<PerceptualState> = None;
    let mapper = if s.sampler == SamplerKind::Perceptual {
        Some(ThresholdMapper::new(w, h, s.tone.view, s.threshold)?)
    } else {
        None
    };
    let scene_scale = scene.settings.luminance_scale;
    // Cycles' film exposure: the auto exposure of the first pass.
    let cycles_exposure = {
        let lum = luminance_image(&film.mean_rgb(), 1.0);
        0.18 / log_average(&lum).max(1e-9)
    };

    let mut t_level = 1.0f32;
    let mut pass = 0usize;
    let mut prev_taken = 0u64;
    let mut guide_time = Duration::ZERO;
    let (last, stop) = loop {
        let taken = film.total_samples();
        // Judge the current film.
        let t0 = Instant::now();
        let mean = film.mean_rgb();
        let judgement = match s.sampler {
            SamplerKind::Perceptual => {
                let frozen = match s.visibility {
                    Visibility::Display => Some(FrozenToneMap::new(&mean, w, h, &s.tone)?),
                    Visibility::Scene => None,
                };
                let lf = visible_luminance(&mean, frozen.as_ref(), scene_scale)?;
                if perceptual.is_none() {
                    let t_guide = Instant::now();
                    let albedo = render_albedo(
                        scene,
                        s.guide_spp.max(1),
                        scene.settings.seed ^ 0x6A09_E667_F3BC_C908,
                    );
                    guide_time = t_guide.elapsed();
                    guide_stats = Some(RenderStats {
                        samples: (s.guide_spp.max(1) as u64) * n_px as u64,
                        rays: (s.guide_spp.max(1) as u64) * n_px as u64,
                        nonfinite: 0,
                        wall: guide_time,
                    });
                    // The albedo's contrast structure at the current image's luminance level.
                    let a_lum = luminance_image(&albedo, 1.0);
                    let mean_a = a_lum.iter().map(|&v| v as f64).sum::<f64>() / n_px as f64;
                    let mean_f = lf.iter().map(|&v| v as f64).sum::<f64>() / n_px as f64;
                    let k = if mean_a > 0.0 {
                        (mean_f / mean_a) as f32
                    } else {
                        1.0
                    };
                    let g_lum: Vec<f32> = a_lum.iter().map(|&v| v * k).collect();
                    let map = mapper.as_ref().expect("perceptual").compute(&g_lum, None)?;
                    let saliency = if s.saliency_weight > 0.0 {
                        let display = match &frozen {
                            Some(f) => f.map(&mean)?,
                            None => mean.clone(),
                        };
                        Some(perception::saliency::saliency_map(&display, w, h)?)
                    } else {
                        None
                    };
                    perceptual = Some(PerceptualState {
                        noise_contrast: map.noise_contrast,
                        saliency,
                    });
                }
                let st = perceptual.as_ref().expect("set above");
                let e: Vec<f32> = match s.error_estimate {
                    ErrorEstimate::HalfBuffers => {
                        let la =
                            visible_luminance(&film.mean_rgb_even(), frozen.as_ref(), scene_scale)?;
                        let lb =
                            visible_luminance(&film.mean_rgb_odd(), frozen.as_ref(), scene_scale)?;
                        la.par_iter()
                            .zip(lb.par_iter())
                            .map(|(a, b)| 0.5 * (a - b).abs())
                            .collect()
                    }
                    ErrorEstimate::StandardError => film
                        .pixels
                        .par_iter()
                        .zip(mean.par_chunks_exact(3))
                        .zip(lf.par_iter())
                        .map(|((px, rgb), &ld)| {
                            let y = perception::photometry::luminance(rgb[0], rgb[1], rgb[2]);
                            let gain = if y > 0.0 { ld / y } else { 0.0 };
                            let se = if px.n >= 2 {
                                px.lum_std_error() as f32
                            } else {
                                0.0
                            };
                            gain * se
                        })
                        .collect(),
                };
                let error = box3(&e, w, h);
                let adapt = adaptation_luminance(
                    &lf,
                    w,
                    h,
                    &s.tone.view,
                    AdaptationMode::LocalArithmetic,
                    s.threshold.adaptation_window_deg,
                )?;
                let mut threshold: Vec<f32> = adapt
                    .par_iter()
                    .zip(st.noise_contrast.par_iter())
                    .map(|(&a, &c)| a * c)
                    .collect();
                if let Some(sal) = &st.saliency {
                    threshold =
                        perception::saliency::aleph_map(&threshold, sal, s.saliency_weight)?;
                }
                Judgement { error, threshold }
            }
            SamplerKind::Variance => {
                let even = film.mean_rgb_even();
                let k = cycles_exposure;
                let error: Vec<f32> = mean
                    .par_chunks_exact(3)
                    .zip(even.par_chunks_exact(3))
                    .map(|(f, a)| {
                        let diff =
                            ((f[0] - a[0]).abs() + (f[1] - a[1]).abs() + (f[2] - a[2]).abs()) * k;
                        let i = (f[0] + f[1] + f[2]) * k;
                        let norm = if i < 1.0 { i.max(0.0).sqrt() } else { i };
                        diff / (1e-4 + norm)
                    })
                    .collect();
                Judgement {
                    error,
                    threshold: vec![s.variance_threshold; n_px],
                }
            }
            SamplerKind::Uniform => unreachable!("handled above"),
        };
        // The guide's render time is rendering, not a decision cost.
        decision_time += t0.elapsed().saturating_sub(std::mem::take(&mut guide_time));
        let ratio = judgement.ratio();
        let converged = ratio.par_iter().filter(|&&r| r <= 1.0).count() as f64 / n_px as f64;
        let report = PassReport {
            pass,
            mean_spp: taken as f64 / n_px as f64,
            converged_fraction: converged,
            samples: taken - prev_taken,
        };
        prev_taken = taken;
        progress(&report);
        passes.push(report);

        // Stop?
        if let Some(limit) = s.time_budget
            && start.elapsed() >= limit
        {
            break (judgement, StopReason::Time);
        }
        let remaining = budget_total.map(|b| b.saturating_sub(taken));
        if remaining == Some(0) || remaining.is_some_and(|r| (r as f64) < 0.002 * n_px as f64) {
            break (judgement, StopReason::Budget);
        }
        if converged >= s.converged_fraction {
            if budget_total.is_none() {
                break (judgement, StopReason::Converged);
            }
            // With a budget, tighten and keep refining where the ratio is largest.
            while ratio.par_iter().filter(|&&r| r <= t_level).count() as f64 / n_px as f64
                >= s.converged_fraction
                && t_level > 1e-4
            {
                t_level *= 0.5;
            }
        }

        // Allocate the next pass.
        let active: Vec<bool> = ratio.par_iter().map(|&r| r > t_level).collect();
        let reopen = dilate3(&active, w, h);
        let mut want: Vec<u32> = film
            .pixels
            .par_iter()
            .zip(ratio.par_iter())
            .zip(active.par_iter().zip(reopen.par_iter()))
            .map(|((px, &r), (&act, &reo))| {
                let n = px.n;
                if !reo || n >= s.max_spp {
                    return 0;
                }
                let nf = n as f32;
                let mut c = if act {
                    let q = (r / t_level).min(1e3);
                    (nf * (q * q - 1.0)).ceil()
                } else {
                    0.0
                };
                c = c.max((nf / 4.0).ceil()).max(1.0).min(nf.max(1.0));
                (c as u32).min(s.max_spp - n)
            })
            .collect();
        let total_want: u64 = want.iter().map(|&c| c as u64).sum();
        if total_want == 0 {
            let reason = if converged >= s.converged_fraction {
                StopReason::Converged
            } else {
                StopReason::MaxSpp
            };
            break (judgement, reason);
        }
        if let Some(rem) = remaining
            && total_want > rem
        {
            // Scale down to the remaining budget; deterministic rounding down, then hand the
            // leftover samples out one each in pixel order of decreasing ratio.
            let f = rem as f64 / total_want as f64;
            for c in want.iter_mut() {
                *c = (*c as f64 * f).floor() as u32;
            }
            let mut left = rem - want.iter().map(|&c| c as u64).sum::<u64>();
            if left > 0 {
                let mut order: Vec<usize> = (0..n_px)
                    .filter(|&i| reopen[i] && film.pixels[i].n < s.max_spp)
                    .collect();
                order.sort_by(|&a, &b| ratio[b].total_cmp(&ratio[a]).then(a.cmp(&b)));
                for i in order {
                    if left == 0 {
                        break;
                    }
                    if film.pixels[i].n + want[i] < s.max_spp {
                        want[i] += 1;
                        left -= 1;
                    }
                }
            }
        }
        stats += render_counts(scene, &integrator, &mut film, &want, sample_progress);
        pass += 1;
    };
    let judgement = last;
    let converged_fraction = passes.last().map(|p| p.converged_fraction).unwrap_or(0.0);
    let units = match (s.sampler, s.visibility) {
        (SamplerKind::Variance, _) => "Cycles relative error (dimensionless)",
        (_, Visibility::Display) => "display luminance, cd/m^2",
        (_, Visibility::Scene) => "scene luminance, cd/m^2",
    };
    Ok(AdaptiveResult {
        film,
        stats,
        guide_stats,
        passes,
        stop,
        converged_fraction,
        threshold: Some(judgement.threshold),
        error: Some(judgement.error),
        units,
        decision_time,
        wall: start.elapsed(),
    })
}
