//! The adaptive loop of a frame that reuses earlier frames' samples ([`crate::reuse`]).
//!
//! 1. The base pass ([`crate::reuse::BasePass`]): half the budget's fresh samples everywhere
//!    (under a budget below 2 spp, one sample in half the pixels, a checkerboard that
//!    alternates frame by frame), drawn before anything is judged ([`render_base`] renders it
//!    alone for a warm-up frame).
//! 2. The window's frames land in this frame ([`crate::reuse::ReuseWindow::reproject`]); the
//!    test of each against the fresh samples drops history where light changed on unchanged
//!    surfaces. The test is repeated after every pass with all the fresh samples so far,
//!    which resolve smaller changes. Until the last pass the history is the window's base
//!    passes ([`crate::reuse::Reused::Base`]), so that what the passes are given depends on
//!    the K frames before this one alone; the image then reuses every fresh sample of the
//!    window ([`crate::reuse::Reused::All`]). Every pass's samples are kept for the frames
//!    after this one.
//! 3. Then, pass by pass, the perceptual criterion judges the combined estimate (fresh and
//!    reused, half-buffer error plus the test's bias bound, against the velocity-aware
//!    threshold map) and the pixels whose error is visible get about n_eff (r² − 1) more fresh
//!    samples (at most doubling their effective count n_eff = fresh + reused per pass, at most
//!    [`REUSE_CAP_SHARE`] × the frame's budget in all).
//!    Under a budget the first of these passes instead spends [`FLOOR_SHARE`] of what is left
//!    raising the pixels with the fewest effective samples to one level (water-filling): it
//!    evens out the noise between disoccluded and reused pixels before the model ranks them.
//! 4. Under a budget, once nothing is visible, the rest is spent the same way. Without a budget
//!    the loop stops at the converged fraction.
//!
//! A budget under `steer_from_spp` (128 by default, as for stills) skips steps 3 and 4: the
//! rest of the budget after the base pass levels the effective counts in one pass (the
//! water-filling of step 3, leaving out pixels without noise) and nothing is judged, so no
//! guide and no threshold map are made ([`judges`]). Measured (docs/reuse.md; video JOD at
//! 2 / 4 / 8 / 16 fresh spp, levelled against judged): the walkthrough 8.52 / 9.09 / 9.56 /
//! 9.72 against 8.46 / 9.14 / 9.57 / 9.73, in 0.16 s per frame at 2 spp against 0.29 s; the
//! holodeck pan 8.43 / 9.09 / 9.48 / 9.68 against 8.50 / 9.10 / 9.49 / 9.68 (both before
//! samples were landed one by one); the moving-sphere box, where an object moves, 6.41 / 6.97 /
//! 7.29 / 7.17 against 6.47 / 7.02 / 7.30 / 7.18, in 0.15 s per frame at 4 spp against 0.25 s.

use super::allocate::{Allocation, fit_to_budget, stratified_floor};
use super::criterion::{Judge, NEGLIGIBLE_NOISE_CONTRAST, relative_noise};
use super::{
    AdaptiveError, AdaptiveResult, AdaptiveSettings, Criterion, LoopState, PassReport, ReuseReport,
    StopReason, judge_for,
};
use crate::film::Film;
use crate::gbuffer::GBuffer;
use crate::integrator::{Integrator, Strategy};
use crate::reuse::{BasePass, FrameSamples, Reprojected, ReuseWindow, Reused, Tested};
use crate::sampler::SampleStreams;
use crate::scene::Scene;
use crate::velocity::velocity_from_gbuffer;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Under a per-frame budget B no pixel gets more than REUSE_CAP_SHARE · B fresh samples
/// (rounded down to a stratified total, never past `max_spp`): a disoccluded pixel has no
/// history and may need many times the budget to match its reused neighbours.
pub const REUSE_CAP_SHARE: f64 = 8.0;

/// Share of a frame's budget (after its first pass) spent raising the pixels with the fewest
/// effective samples to a common level before the perceptual criterion ranks them: the model
/// ranks pixels only roughly (as the still sampler's floor, `allocate::FLOOR_SHARE`), and
/// without the level a 32-spp holodeck frame left its disoccluded pixels at 3.5 fresh samples
/// while a tenth of the image took 168 and more (relative RMSE 0.153 there, against uniform's
/// 0.012).
pub const FLOOR_SHARE: f64 = 0.75;

/// Most passes after the first.
const MAX_PASSES: usize = 8;

/// The base pass of `scene`'s current frame (its G-buffer and the samples of
/// [`crate::reuse::BasePass`], in two independent half-buffers), as later frames reuse it:
/// the same samples [`render_reusing`] draws first, so a warm-up frame rendered this way
/// gives a window equal to the sequence's. `window_frames`: the frames the frame's own window
/// would hold in the sequence ([`crate::reuse::window_frames`]) under a window of `k`; the
/// budget is the sequence's, scheduled by [`crate::reuse::start_up_budget`].
///
/// # Errors
/// As [`render_reusing`].
pub fn render_base(
    scene: &Scene,
    s: &AdaptiveSettings,
    window_frames: usize,
    k: u32,
) -> Result<FrameSamples, AdaptiveError> {
    s.validate()?;
    let s = &scheduled(s, window_frames, k);
    Ok(base_pass(scene, s, window_frames, &|_| {})?.1)
}

/// `s` with the frame's own budget ([`crate::reuse::start_up_budget`]).
fn scheduled(s: &AdaptiveSettings, window_frames: usize, k: u32) -> AdaptiveSettings {
    AdaptiveSettings {
        budget_spp: s
            .budget_spp
            .map(|b| crate::reuse::start_up_budget(b, window_frames, k)),
        ..s.clone()
    }
}

/// The base pass in a new loop state, the frame's samples as later frames reuse them, and its
/// G-buffer.
fn base_pass(
    scene: &Scene,
    s: &AdaptiveSettings,
    window_frames: usize,
    sample_progress: &(dyn Fn(u64) + Sync),
) -> Result<(LoopState, FrameSamples, GBuffer), AdaptiveError> {
    let gbuffer = GBuffer::render(scene);
    let mut st = LoopState::new(scene, s)?;
    let base = BasePass::of(s.budget_spp, s.steers(), window_frames);
    let counts = base.counts(scene.frame.index, (gbuffer.width, gbuffer.height));
    let pass = crate::render::Pass {
        counts: &counts,
        seed: crate::reuse::base_seed(scene),
        streams: SampleStreams::Halves,
        offset: base.offset(scene.frame.index),
    };
    let samples = st.render_recorded(scene, &integrator_of(scene), &pass, sample_progress);
    let cap = crate::reuse::kept_spp(st.film.len(), s.reuse_frame_memory);
    let frame = FrameSamples::new(scene, (&st.film, base), &gbuffer, samples, cap);
    Ok((st, frame, gbuffer))
}

fn integrator_of(scene: &Scene) -> Integrator {
    Integrator {
        max_depth: scene.settings.max_depth,
        strategy: Strategy::Mis,
    }
}

/// Renders `scene`'s current frame reusing the base passes of the frames in `window`
/// (the perceptual criterion only; see the module docs). `s.budget_spp` is the sequence's
/// budget of *fresh* samples, scheduled for the frame by its window
/// ([`crate::reuse::start_up_budget`]); `None` renders until the converged fraction. Returns
/// the frame and its own base pass, for the window of the frames after it.
///
/// # Errors
/// As [`super::render_adaptive`]; also [`AdaptiveError::Settings`] for a criterion other than
/// the perceptual one.
pub fn render_reusing(
    scene: &Scene,
    s: &AdaptiveSettings,
    window: &ReuseWindow,
    progress: &(dyn Fn(&PassReport) + Sync),
    sample_progress: &(dyn Fn(u64) + Sync),
) -> Result<(AdaptiveResult, FrameSamples), AdaptiveError> {
    s.validate()?;
    if s.criterion != Criterion::Perceptual || s.rows.is_some() {
        return Err(AdaptiveError::Settings(
            "reuse across frames takes the perceptual sampler on whole frames".into(),
        ));
    }
    let start = Instant::now();
    let s = &scheduled(s, window.len(), window.k());
    let (st, base, gbuffer) = base_pass(scene, s, window.len(), sample_progress)?;
    let velocity = velocity_from_gbuffer(scene, &gbuffer);
    let t_reuse = Instant::now();
    let reprojected = window.reproject(scene, &gbuffer);
    let mut frame = Frame {
        st,
        own: base,
        reprojected,
        tested: Tested::default(),
        tested_with: None,
        reuse_time: t_reuse.elapsed(),
    };
    frame.retest(Reused::Base);
    let (judgement, stop, guide_stats) = if judges(scene, s) {
        let (judgement, stop, judge) =
            frame.judged(scene, s, velocity.as_ref(), progress, sample_progress)?;
        (Some(judgement), stop, judge.guide_stats())
    } else {
        (
            None,
            frame.levelled(scene, s, progress, sample_progress),
            None,
        )
    };
    // The image reuses every fresh sample of the window's frames; the passes were allocated
    // by their base passes alone (see crate::reuse, "The window").
    frame.retest(Reused::All);
    let (st, own) = (frame.st, frame.own);
    let reuse = reuse_report(&st.film, window.len(), frame.reuse_time);
    let converged_fraction = st.passes.last().map_or(0.0, |p| p.converged_fraction);
    let (threshold, error) = judgement.map(|j| (j.threshold, j.error)).unzip();
    let result = AdaptiveResult {
        film: st.film,
        stats: st.stats,
        guide_stats,
        passes: st.passes,
        stop,
        converged_fraction,
        threshold,
        error,
        units: s.units(),
        decision_time: st.decision_time,
        wall: start.elapsed(),
        velocity,
        gbuffer: Some(gbuffer),
        reuse: Some(reuse),
        denoised: None,
        denoise_time: Duration::ZERO,
    };
    Ok((result, own))
}

/// A reusing frame in the making: its loop state, the window reprojected into it and what
/// the last test against its fresh samples kept.
struct Frame {
    st: LoopState,
    /// Every fresh sample so far, for the frames after it.
    own: FrameSamples,
    reprojected: Reprojected,
    tested: Tested,
    /// What the last test took: which samples of the window and how many fresh samples the
    /// frame had rendered.
    tested_with: Option<(Reused, u64)>,
    reuse_time: Duration,
}

impl Frame {
    /// The test of the reprojected frames' `reused` samples again, with every fresh sample so
    /// far (more of them resolve smaller changes); what it keeps becomes the film's history.
    /// Skipped where the last test had the same inputs: the same fresh samples, and the same
    /// window samples (every window frame's samples its base pass's, as under a budget of 1
    /// fresh spp, so that [`Reused::Base`] and [`Reused::All`] land alike).
    fn retest(&mut self, reused: Reused) {
        let fresh = self.st.stats.samples;
        let same_window = |last: Reused| last == reused || self.reprojected.base_is_all();
        if matches!(self.tested_with, Some((last, n)) if n == fresh && same_window(last)) {
            return;
        }
        let t = Instant::now();
        self.tested = retest(&self.reprojected, &mut self.st.film, reused);
        self.tested_with = Some((reused, fresh));
        self.reuse_time += t.elapsed();
    }

    /// Renders a pass of `counts` fresh samples (the frame's own streams) and keeps them for
    /// the frames after it.
    fn render(&mut self, scene: &Scene, counts: &[u32], sample_progress: &(dyn Fn(u64) + Sync)) {
        let pass = crate::render::Pass {
            counts,
            seed: scene.frame_seed(),
            streams: SampleStreams::Halves,
            offset: 0,
        };
        let samples = self
            .st
            .render_recorded(scene, &integrator_of(scene), &pass, sample_progress);
        self.own.add_pass(scene, counts, &samples);
    }

    /// The perceptual loop (steps 3 and 4 of the module docs): returns the last judgement,
    /// why it stopped, and the judge (for its guide's statistics).
    fn judged(
        &mut self,
        scene: &Scene,
        s: &AdaptiveSettings,
        velocity: Option<&crate::velocity::VelocityMap>,
        progress: &(dyn Fn(&PassReport) + Sync),
        sample_progress: &(dyn Fn(u64) + Sync),
    ) -> Result<(super::criterion::Judgement, StopReason, Judge), AdaptiveError> {
        let n_px = self.st.film.len();
        let budget_total = s.budget_spp.map(|b| (b * n_px as f64).round() as u64);
        let t_setup = Instant::now();
        let mut judge = judge_for(scene, s, velocity, &self.st.film)?;
        self.st.decision_time += t_setup.elapsed();
        let cap = fresh_cap(s);
        loop {
            let st = &mut self.st;
            let t0 = Instant::now();
            let (mut judgement, guide_time) = judge.judge(scene, &st.film, s, None)?;
            add_bias(
                &mut judgement.error,
                &self.tested.bias,
                scene.settings.luminance_scale,
            );
            let noise = judge.relative_noise(&st.film);
            let ratio = Judge::ratio(&judgement, noise.as_deref());
            st.decision_time += t0.elapsed().saturating_sub(guide_time);
            let converged = st.report(&ratio, progress);
            let remaining = budget_total.map(|b| b.saturating_sub(st.region_samples()));
            if remaining.is_some_and(|r| (r as f64) < 0.002 * n_px as f64) {
                return Ok((judgement, StopReason::Budget, judge));
            }
            if remaining.is_none() && converged >= s.converged_fraction {
                return Ok((judgement, StopReason::Converged, judge));
            }
            if st.passes.len() > MAX_PASSES {
                let reason = if remaining.is_some() {
                    StopReason::Budget
                } else {
                    StopReason::MaxSpp
                };
                return Ok((judgement, reason, judge));
            }
            let done = converged >= super::converged_target(s, remaining);
            let alloc = next_pass(st, &ratio, remaining, done, cap);
            if alloc.total() == 0 {
                let reason = if done {
                    StopReason::Converged
                } else {
                    StopReason::MaxSpp
                };
                return Ok((judgement, reason, judge));
            }
            self.render(scene, &alloc.want, sample_progress);
            self.retest(Reused::Base);
        }
    }

    /// A frame that is not judged ([`judges`]; as a still under `steer_from_spp` is rendered
    /// uniformly): the rest of the budget after the base pass raises the pixels with the fewest effective
    /// samples (fresh and reused) to one level, in one pass, leaving out those without noise
    /// (as [`Judge::ratio`] does); nothing is judged. Returns why it stopped.
    fn levelled(
        &mut self,
        scene: &Scene,
        s: &AdaptiveSettings,
        progress: &(dyn Fn(&PassReport) + Sync),
        sample_progress: &(dyn Fn(u64) + Sync),
    ) -> StopReason {
        let st = &mut self.st;
        let t0 = Instant::now();
        let noisy: Vec<f32> = relative_noise(&st.film)
            .into_iter()
            .map(|q| {
                if q < NEGLIGIBLE_NOISE_CONTRAST {
                    0.0
                } else {
                    1.0
                }
            })
            .collect();
        let unjudged = vec![f32::INFINITY; st.film.len()];
        st.report(&unjudged, progress);
        let n_px = st.film.len();
        let total = s.budget_spp.map_or(0, |b| (b * n_px as f64).round() as u64);
        let remaining = total.saturating_sub(st.region_samples());
        let cap = fresh_cap(s);
        let mut alloc = Allocation::empty(n_px);
        water_fill(&mut alloc, &st.film, &noisy, remaining, cap);
        fit_to_budget(&mut alloc, &st.film, &noisy, remaining, cap);
        st.decision_time += t0.elapsed();
        if alloc.total() > 0 {
            // No test of the base passes again: render_reusing tests every reused sample next.
            self.render(scene, &alloc.want, sample_progress);
            self.st.report(&unjudged, progress);
        }
        StopReason::Budget
    }
}

/// Whether a reusing frame is judged: under a budget of `steer_from_spp` or more (as a still
/// is) or without a budget. Else its fresh samples are levelled with the reused ones
/// ([`Frame::levelled`]), also where an object moves: the test against the fresh samples
/// still drops reused light that changed, and on the moving-sphere box (128², frames 0–11,
/// video JOD at 2 / 4 / 8 / 16 fresh spp) the judge bought 6.47 / 7.02 / 7.30 / 7.18 against
/// 6.41 / 6.97 / 7.29 / 7.17 levelled for 0.25 s a frame at 4 spp against 0.15 s (docs/reuse.md).
fn judges(_: &Scene, s: &AdaptiveSettings) -> bool {
    s.steers()
}

/// The most fresh samples one pixel may take (see [`REUSE_CAP_SHARE`]).
fn fresh_cap(s: &AdaptiveSettings) -> u32 {
    match s.budget_spp {
        Some(b) => stratified_floor(REUSE_CAP_SHARE * b).min(s.max_spp),
        None => s.max_spp,
    }
}

/// Tests the reprojected frames against `film`'s fresh samples and makes what is kept the
/// film's history; returns the bias bounds (the history is moved into the film).
fn retest(reprojected: &Reprojected, film: &mut Film, reused: Reused) -> Tested {
    film.history = None;
    let mut tested = reprojected.test(film, reused);
    film.history = Some(std::mem::take(&mut tested.history));
    tested
}

/// The next pass: under a budget (`remaining` samples left) the first judged pass levels the
/// effective counts with [`FLOOR_SHARE`] of it (disoccluded pixels come up to their reused
/// neighbours before the model ranks anything); later ones follow the model ([`plan`]), and
/// once everything is invisible (`converged`) or nothing is wanted the rest levels the counts
/// again; all fitted to the budget.
fn next_pass(
    st: &LoopState,
    ratio: &[f32],
    remaining: Option<u64>,
    converged: bool,
    cap: u32,
) -> Allocation {
    let mut alloc = match (remaining, st.passes.len()) {
        (Some(rem), 1) => {
            let mut a = Allocation::empty(st.film.len());
            let floor = (FLOOR_SHARE * rem as f64) as u64;
            water_fill(&mut a, &st.film, ratio, floor, cap);
            a
        }
        _ => plan(&st.film, ratio, cap),
    };
    if let Some(rem) = remaining {
        if alloc.total() == 0 || converged {
            water_fill(&mut alloc, &st.film, ratio, rem, cap);
        }
        fit_to_budget(&mut alloc, &st.film, ratio, rem, cap);
    }
    alloc
}

/// error ← √(error² + bias²), the bias bound of the reuse test in scene cd/m².
fn add_bias(error: &mut [f32], bias: &[f32], luminance_scale: f32) {
    error
        .par_iter_mut()
        .zip(bias.par_iter())
        .for_each(|(e, &b)| {
            let b = b * luminance_scale;
            *e = (*e * *e + b * b).sqrt();
        });
}

/// Pixels above threshold get about n_eff (r² − 1) more fresh samples, at most n_eff (one
/// doubling of the effective count) and never past `cap` fresh samples.
fn plan(film: &Film, ratio: &[f32], cap: u32) -> Allocation {
    let want: Vec<u32> = (0..film.len())
        .into_par_iter()
        .map(|i| {
            let r = ratio[i];
            let n = film.pixels[i].count();
            if r <= 1.0 || n >= cap {
                return 0;
            }
            let eff = film.effective_count(i).max(1.0);
            let q = r.min(1e3) as f64;
            let c = (eff * (q * q - 1.0)).ceil().min(eff.ceil()).max(1.0);
            (c as u32).min(cap - n)
        })
        .collect();
    let reopen = want.iter().map(|&c| c > 0).collect();
    Allocation { want, reopen }
}

/// Spends up to `remaining` samples raising the pixels with noise (ratio > 0) and the fewest
/// effective samples to a common level (never past `cap` fresh samples).
fn water_fill(alloc: &mut Allocation, film: &Film, ratio: &[f32], remaining: u64, cap: u32) {
    let spare = remaining.saturating_sub(alloc.total());
    let mut open: Vec<(usize, f64, u32)> = Vec::with_capacity(film.len());
    open.extend(
        (0..film.len())
            .filter(|&i| ratio[i] > 0.0)
            .map(|i| {
                let n = film.pixels[i].count() + alloc.want[i];
                (
                    i,
                    film.effective_count(i) + alloc.want[i] as f64,
                    cap.saturating_sub(n),
                )
            })
            .filter(|&(_, _, room)| room > 0),
    );
    if open.is_empty() || spare == 0 {
        return;
    }
    for (i, c) in fill(&open, spare, water_level(&open, spare)) {
        if c > 0 {
            alloc.want[i] += c as u32;
            alloc.reopen[i] = true;
        }
    }
}

/// The samples each pixel `(i, n_eff, room)` of `open` takes under `spare` samples, the water
/// level bracketed by `(lo, hi)` ([`water_level`]): what it takes at `lo`, and what that
/// leaves one each to the pixels that take one more at `hi`, in the order of the levels at
/// which they do ([`step_level`]; one level: fewest effective samples first, then pixel
/// order). The level rises in steps (every pixel of one effective count at once: a sky of
/// exactly K + 1 frames' samples), so the bracket's last step is shared out. With `(lo, hi)`
/// adjacent doubles those pixels all step at `hi`; with a wider bracket of width under 1 each
/// takes exactly one step inside it, and the order of their levels gives the same pixels as
/// bisecting on to adjacent doubles would.
fn fill(open: &[(usize, f64, u32)], spare: u64, (lo, hi): (f64, f64)) -> Vec<(usize, u64)> {
    let mut takes: Vec<(usize, u64)> = open.iter().map(|o| (o.0, take_to(lo, o))).collect();
    let left = spare.saturating_sub(takes.iter().map(|t| t.1).sum());
    if left == 0 {
        return takes;
    }
    let mut next: Vec<(f64, f64, usize, usize)> = open
        .iter()
        .enumerate()
        .filter(|&(k, o)| take_to(hi, o) > takes[k].1)
        .map(|(k, &(i, eff, _))| (step_level(takes[k].1, eff), eff, i, k))
        .collect();
    next.sort_by(|a, b| {
        (a.0.total_cmp(&b.0))
            .then(a.1.total_cmp(&b.1))
            .then(a.2.cmp(&b.2))
    });
    one_each(&mut takes, next.into_iter().map(|t| t.3), left);
    takes
}

/// One more sample each to the first `left` entries of `takes` in `order` (indices into it).
fn one_each(takes: &mut [(usize, u64)], order: impl IntoIterator<Item = usize>, left: u64) {
    for k in order.into_iter().take(left as usize) {
        takes[k].1 += 1;
    }
}

/// The least level (a double) at which a pixel of effective count `eff` that takes `m`
/// samples below it takes m + 1 ([`take_to`]: ⌈level − eff⌉ > m in floating point), found
/// from m + eff a double at a time (the rounded sum lies within an ulp or two of it).
fn step_level(m: u64, eff: f64) -> f64 {
    let steps = |level: f64| (level - eff).ceil() > m as f64;
    let mut level = m as f64 + eff;
    if steps(level) {
        while steps(level.next_down()) {
            level = level.next_down();
        }
    } else {
        while !steps(level) {
            level = level.next_up();
        }
    }
    level
}

/// The fresh samples a pixel `(i, effective count, room)` of [`water_fill`] takes to reach
/// `level`: ⌈level − n_eff⌉, at least 0, at most its room. Monotone in `level` (a rounded
/// subtraction is).
fn take_to(level: f64, &(_, eff, room): &(usize, f64, u32)) -> u64 {
    ((level - eff).ceil().max(0.0) as u64).min(room as u64)
}

/// The water level of [`water_fill`] under `spare` samples, bracketed by bisection: `(lo,
/// hi)` with cost(lo) ≤ `spare` < cost(hi) (or `hi` at the doubling's cap of 10⁹), cost
/// being the samples every pixel of `open` takes ([`take_to`]), down to a width under 1,
/// where every pixel whose count differs between the ends takes exactly one step and
/// [`fill`] orders those steps without bisecting on (to adjacent doubles: about 53 more
/// passes over the pixels left, 2 ms a frame on the moving-sphere box at 128², where
/// thousands of pixels have effective counts a rounding below 1). A pixel that takes as
/// many at `lo` as at `hi` takes that many at any level between (the count is monotone), so
/// each step evaluates only the pixels whose count still differs.
fn water_level(open: &[(usize, f64, u32)], spare: u64) -> (f64, f64) {
    let cost = |level: f64| -> u64 { open.par_iter().map(|o| take_to(level, o)).sum() };
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let mut above = cost(hi) > spare;
    while !above && hi < 1e9 {
        lo = hi;
        hi *= 2.0;
        above = cost(hi) > spare;
    }
    let (mut active, mut settled) = (open.to_vec(), 0u64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        // The interval is down to adjacent doubles: no later step moves `lo`.
        if mid == lo || mid == hi {
            break;
        }
        active.retain(|o| {
            let at_lo = take_to(lo, o);
            if at_lo == take_to(hi, o) {
                settled += at_lo;
                return false;
            }
            true
        });
        if above && hi - lo < 1.0 {
            break;
        }
        if settled + active.iter().map(|o| take_to(mid, o)).sum::<u64>() <= spare {
            lo = mid
        } else {
            hi = mid
        }
    }
    (lo, hi)
}

fn reuse_report(film: &Film, frames: usize, time: Duration) -> ReuseReport {
    let n = film.len().max(1) as f64;
    let weights: Vec<f64> = (0..film.len()).map(|i| film.history_weight(i)).collect();
    ReuseReport {
        frames,
        mean_history_spp: weights.iter().sum::<f64>() / n,
        reused_fraction: weights.iter().filter(|&&w| w > 0.0).count() as f64 / n,
        time,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// The bisection of [`water_level`] as it was written first: every pixel evaluated at
    /// every step.
    fn water_level_every_pixel(open: &[(usize, f64, u32)], spare: u64) -> (f64, f64) {
        let cost = |level: f64| -> u64 { open.iter().map(|o| take_to(level, o)).sum() };
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        while cost(hi) <= spare && hi < 1e9 {
            lo = hi;
            hi *= 2.0;
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if mid == lo || mid == hi {
                break;
            }
            if cost(mid) <= spare {
                lo = mid
            } else {
                hi = mid
            }
        }
        (lo, hi)
    }

    /// [`fill`] as it was written first: the leftover of the full bisection's `lo` (adjacent
    /// doubles) one each to the pixels that step at `hi`, fewest effective samples first.
    fn fill_every_pixel(open: &[(usize, f64, u32)], spare: u64) -> Vec<(usize, u64)> {
        let (lo, hi) = water_level_every_pixel(open, spare);
        let mut takes: Vec<(usize, u64)> = open.iter().map(|o| (o.0, take_to(lo, o))).collect();
        let left = spare.saturating_sub(takes.iter().map(|t| t.1).sum());
        let mut next: Vec<(usize, f64, usize)> = open
            .iter()
            .enumerate()
            .filter(|(_, o)| take_to(hi, o) > take_to(lo, o))
            .map(|(k, &(i, eff, _))| (i, eff, k))
            .collect();
        next.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        one_each(&mut takes, next.into_iter().map(|t| t.2), left);
        takes
    }

    #[test]
    fn the_water_fill_is_the_full_bisections() {
        let mut rng = Rng::new(7, 0);
        for case in 0..400 {
            let n = 1 + (rng.uniform() * 400.0) as usize;
            // Effective counts in steps of whole frames (ties), a rounding or two below them
            // (as Kish counts of equal weights come out), or arbitrary; rooms from 1 up, every
            // fourth case one room for all.
            let room = 1 + (rng.uniform() * 9.0) as u32;
            let open: Vec<(usize, f64, u32)> = (0..n)
                .map(|i| {
                    let whole = (rng.uniform() * 12.0).floor() as f64;
                    let eff = match case % 3 {
                        0 => whole,
                        1 => {
                            let below = (rng.uniform() * 3.0) as u32;
                            (0..below).fold(whole.max(1.0) as f32, |e, _| e.next_down()) as f64
                        }
                        _ => rng.uniform() as f64 * 40.0,
                    };
                    let r = if case % 4 == 0 {
                        room
                    } else {
                        1 + (rng.uniform() * 9.0) as u32
                    };
                    (i, eff, r)
                })
                .collect();
            let spare = (rng.uniform() * 6.0 * n as f32) as u64;
            let (lo, hi) = water_level(&open, spare);
            let cost = |level: f64| -> u64 { open.iter().map(|o| take_to(level, o)).sum() };
            assert!(cost(lo) <= spare, "case {case}");
            assert!(cost(hi) > spare || hi >= 1e9, "case {case}");
            assert_eq!(
                fill(&open, spare, (lo, hi)),
                fill_every_pixel(&open, spare),
                "case {case}"
            );
        }
    }
}
