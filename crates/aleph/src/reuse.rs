//! Reuse across frames: each frame of a sequence starts from the samples the frames before it
//! traced on the same surfaces (Myszkowski, Rokita & Tawara 1999; DESIGN.md §12).
//!
//! # What is reused
//! The *base pass* of each of the last K frames (the window, [`ReuseWindow`]): the first
//! [`base_spp`] fresh samples of every pixel, drawn uniformly before anything about the frame
//! was judged, kept per pixel as half-buffer sums. They are reprojected directly into the
//! current frame, each frame once: pixel p's surface x (the G-buffer's hit at the pixel centre, carried with its
//! object) is projected by frame j's camera at frame j's instant, and frame j's sums are
//! resampled there bilinearly over the neighbours that saw the same surface. Reprojecting every
//! window frame directly, rather than the previous frame's accumulated image, resamples each
//! sample once: chained bilinear resampling blurs a panning image a little more every frame
//! (the variance of the blur grows by up to ¼ px² per step).
//!
//! A frame is not reused at p when the view of x turned by more than x's surface allows
//! ([`crate::gbuffer::GBuffer::reuse_angle`]: glossy lobes, mirrors and glass are
//! view-dependent) or when the surface area a pixel covers there changed by more than
//! [`MAX_FOOTPRINT_RATIO`] either way (a pixel's mean is its footprint's average). A neighbour
//! k of frame j is valid for x when
//! - it saw the same object and material;
//! - it does not straddle an edge ([`crate::gbuffer::GBuffer::edge`]) unless the view is
//!   unchanged: its samples mix surfaces in proportions that any shift changes;
//! - its surface point lies within [`PLANE_TOLERANCE`] · depth of x's tangent plane and its
//!   normal within [`NORMAL_TOLERANCE_DEG`] of x's;
//! - in a scene where anything but the camera moves, its direct light
//!   ([`crate::gbuffer::GBuffer::direct`], the same fixed light samples in every frame) is
//!   within [`DIRECT_TOLERANCE`] of x's now: a moving shadow or a light uncovered changes it.
//!   The share kept falls linearly with the change.
//!
//! Valid neighbours are weighted bilinearly and renormalised; under [`MIN_COVERAGE`] of the
//! bilinear weight valid, nothing is reused (a disocclusion).
//!
//! # What is tested
//! Where only the camera moves, light on a surface cannot change, and nothing more is tested.
//! Otherwise the G-buffer still cannot see indirect light that changes on an unchanged surface
//! (a moving object's bounce light, a light uncovered seen only through bounces). The frame's
//! fresh samples test each reprojected frame ([`Reprojected::test`], after every pass): over
//! the 3 × 3, 9 × 9 and 27 × 27 pixels around p ([`TEST_RADII`]), the fresh and the reused
//! mean luminance (each pixel weighing the same) differ by z standard errors (per-sample
//! variance from the pixels' own samples); a frame with z ≥ [`Z_REJECT`] at any scale is
//! dropped at p, and weighted down linearly from [`Z_ACCEPT`]. What the test cannot resolve,
//! the disagreement beyond two standard errors, is kept as a bias bound and added to the
//! pixel's error ([`Tested::bias`]), so the perceptual criterion sends fresh samples where reuse
//! may be wrong.
//!
//! # Held fireflies
//! A reused frame that alone would raise a pixel's mean far above the rest's (a rare caustic
//! path, bright enough to clip) is dropped there ([`HELD_OUTLIER_RATIO`]): independent frames
//! show such a sample for one frame, reuse would hold it still for K, and a still error is
//! seen where flickering noise averages out (ColorVideoVDP scored the moving-sphere box's
//! reuse below independent frames for it until the rule).
//!
//! # The window
//! A frame reuses the base passes of the K frames before it (a sliding window; fewer at the
//! animation's start). A base pass depends on its frame alone, not on what that frame reused,
//! so any frame renders alone after the base passes of its K warm-up frames
//! ([`crate::adaptive::render_base`]), and a farm may cut a sequence anywhere
//! ([`chunk_start`]). The samples a frame adds after its base pass, where perception asked for
//! them, are its own: they depend on its history, and reusing them would chain every frame to
//! the animation's first. Every frame after the first K has the same history (no keyframe
//! whose quality steps down every K + 1 frames: on the moving-sphere box that step was a
//! 3 Hz pulse of the displayed mean, which ColorVideoVDP scored below independent frames).
//! K = 0 gives independent frames.

use crate::film::{Film, HistoryPixel};
use crate::gbuffer::GBuffer;
use crate::scene::Scene;
use glam::{DVec3, Vec2};
use rayon::prelude::*;
use std::collections::VecDeque;

/// Largest distance of a neighbour's surface point from x's tangent plane, as a fraction of
/// x's depth.
pub const PLANE_TOLERANCE: f32 = 0.01;

/// Largest angle between a neighbour's normal and x's, degrees (DESIGN.md §12: ~25°).
pub const NORMAL_TOLERANCE_DEG: f32 = 25.0;

/// Relative change of a surface point's direct light (its [`GBuffer::direct`] signature) at
/// which its history is dropped; smaller changes keep a linearly falling share. A change of a
/// few percent in a smooth region is visible (the contrast threshold is 1–2 %), so the share
/// falls fast; 32 fixed light samples resolve visibility in steps of 1/32, so a still
/// penumbra's neighbours, a step or two apart, keep half or more.
pub const DIRECT_TOLERANCE: f32 = 0.1;

/// A reprojection within this distance (pixels) of a pixel centre takes that pixel alone.
pub const SNAP_PIXELS: f32 = 1e-3;

/// Largest change of the surface area one pixel covers (either way) under which a frame is
/// reused: a pixel's mean is its footprint's average, so a footprint scaled by more averages
/// the surface's gradients differently (a cut to a closer or more oblique view).
pub const MAX_FOOTPRINT_RATIO: f32 = 1.25;

/// Least share of the bilinear weight that must be valid for a frame to be reused at a pixel.
pub const MIN_COVERAGE: f32 = 0.25;

/// z below which a reprojected frame is kept whole.
pub const Z_ACCEPT: f64 = 1.0;

/// z from which a reprojected frame is dropped.
pub const Z_REJECT: f64 = 3.0;

/// The largest reuse window, frames.
pub const MAX_WINDOW: u32 = 64;

/// The first frame whose base pass `frame` reuses: K frames back, not before the animation's
/// first frame `first`; `frame` itself for K = 0.
pub fn window_start(frame: i64, first: i64, k: u32) -> i64 {
    (frame - k as i64).max(first)
}

/// Windows a farm's chunk of frames spans ([`chunk_len`]): a chunk renders K warm-up base
/// passes before its first frame, so longer chunks spend less of the farm on them.
pub const CHUNK_WINDOWS: i64 = 4;

/// Frames in a farm chunk of a window of K: [`CHUNK_WINDOWS`] × (K + 1); 1 for K = 0.
pub fn chunk_len(k: u32) -> i64 {
    if k == 0 {
        1
    } else {
        CHUNK_WINDOWS * (k as i64 + 1)
    }
}

/// The first frame of the farm chunk `frame` belongs to: chunks of [`chunk_len`] frames from
/// the animation's first frame `first`. Where a sequence is cut does not change its bytes
/// ([`window_start`]).
pub fn chunk_start(frame: i64, first: i64, k: u32) -> i64 {
    let len = chunk_len(k);
    first + (frame - first).div_euclid(len) * len
}

/// Share of a frame's fresh budget drawn in its base pass (what later frames reuse); the rest
/// goes where the perceptual criterion finds the combined estimate's error visible.
pub const BASE_SHARE: f64 = 0.5;

/// Samples per pixel of a frame's base pass without a budget (the perceptual stop).
pub const BASE_SPP_UNBUDGETED: u32 = 4;

/// Samples per pixel of the base pass of a frame with fresh budget `budget` spp:
/// ⌊[`BASE_SHARE`] · budget⌋, at least 1; [`BASE_SPP_UNBUDGETED`] without a budget.
pub fn base_spp(budget: Option<f64>) -> u32 {
    match budget {
        Some(b) => ((BASE_SHARE * b).floor() as u32).max(1),
        None => BASE_SPP_UNBUDGETED,
    }
}

/// One frame's base pass, compact, with its G-buffer: what later frames reuse.
#[derive(Clone, Debug)]
pub struct FrameSamples {
    /// The frame number.
    pub index: i64,
    /// The frame's G-buffer.
    pub gbuffer: GBuffer,
    /// Per pixel: sums of even and odd samples (RGB), their counts, Σ Y².
    sums: Vec<Compact>,
}

#[derive(Clone, Copy, Debug, Default)]
struct Compact {
    even: [f32; 3],
    odd: [f32; 3],
    n_even: f32,
    n_odd: f32,
    lum2: f32,
}

impl FrameSamples {
    /// Keeps `film`'s fresh samples (its history is not kept: each frame is reprojected once).
    pub fn new(index: i64, film: &Film, gbuffer: GBuffer) -> FrameSamples {
        let sums = film
            .pixels
            .iter()
            .map(|p| Compact {
                even: p.sum_even.value().as_vec3().to_array(),
                odd: p.sum_odd.value().as_vec3().to_array(),
                n_even: p.n_even() as f32,
                n_odd: p.n_odd() as f32,
                lum2: p.sum_lum2.value() as f32,
            })
            .collect();
        FrameSamples {
            index,
            gbuffer,
            sums,
        }
    }
}

/// The last K frames' base passes.
#[derive(Clone, Debug, Default)]
pub struct ReuseWindow {
    frames: VecDeque<FrameSamples>,
}

impl ReuseWindow {
    /// An empty window.
    pub fn new() -> ReuseWindow {
        ReuseWindow::default()
    }

    /// Adds a frame's samples.
    pub fn push(&mut self, f: FrameSamples) {
        self.frames.push_back(f);
    }

    /// Forgets every frame before `first`.
    pub fn keep_from(&mut self, first: i64) {
        self.frames.retain(|f| f.index >= first);
    }

    /// Frames held.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether it holds no frame.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Reprojects every held frame into `scene`'s current frame, whose G-buffer is `g`.
    pub fn reproject(&self, scene: &Scene, g: &GBuffer) -> Reprojected {
        let (frames, blur): (Vec<Vec<HistoryPixel>>, _) = self
            .frames
            .iter()
            .map(|f| reproject_frame(scene, g, f))
            .unzip();
        let lum = frames
            .iter()
            .map(|f| {
                f.par_iter()
                    .map(|p| (luminance(p.sum_even + p.sum_odd), p.weight()))
                    .collect()
            })
            .collect();
        Reprojected {
            frames,
            blur,
            lum,
            width: g.width,
            height: g.height,
            still_light: !scene.geometry.has_motion(),
        }
    }
}

/// The window's frames reprojected into the current frame (before the test against its fresh
/// samples).
#[derive(Clone, Debug)]
pub struct Reprojected {
    /// Per window frame, per pixel: the resampled sums (weight 0 where nothing is reused).
    frames: Vec<Vec<HistoryPixel>>,
    /// Per window frame, per pixel: the squared resampling bias bound ([`resample`]), Y².
    blur: Vec<Vec<f32>>,
    /// Per window frame, per pixel: the resampled luminance sum and its weight (samples),
    /// computed once for every test.
    lum: Vec<Vec<(f64, f64)>>,
    width: usize,
    height: usize,
    /// Nothing but the camera moves: light cannot change on a surface, so nothing is tested.
    still_light: bool,
}

/// What the test of a [`Reprojected`] window against a frame's fresh samples keeps.
#[derive(Clone, Debug, Default)]
pub struct Tested {
    /// Per pixel: the sum over the window's frames, each weighted by the share the test kept
    /// (the film's history).
    pub history: Vec<HistoryPixel>,
    /// Per pixel: the disagreement between fresh and reused luminance that noise does not
    /// explain (relative luminance Y, as the film), the reuse's bias bound.
    pub bias: Vec<f32>,
}

impl Reprojected {
    /// Tests each reprojected frame against `fresh` (the current frame's fresh samples so far;
    /// see the module docs): weights it down where they disagree, and bounds the bias of what
    /// is kept.
    pub fn test(&self, fresh: &Film) -> Tested {
        let (w, h) = (self.width, self.height);
        assert_eq!((w, h), (fresh.width as usize, fresh.height as usize));
        let fresh_y: Vec<Moments> = fresh
            .pixels
            .iter()
            .map(|p| Moments::of(luminance(p.sum()), p.count() as f64, p.sum_lum2.value()))
            .collect();
        let mut bias = vec![0f32; w * h];
        // Per window frame, per pixel: the share of its samples kept.
        let mut shares: Vec<Vec<f64>> = Vec::with_capacity(self.frames.len());
        for ((f, blur), lum) in self.frames.iter().zip(&self.blur).zip(&self.lum) {
            let blurred = |i: usize| blur_share(&f[i], blur[i], &fresh_y[i]);
            if self.still_light {
                shares.push((0..w * h).into_par_iter().map(blurred).collect());
                continue;
            }
            let reused: Vec<Moments> = f
                .iter()
                .zip(lum)
                .map(|(p, &(l, n))| Moments::of(l, n, p.sum_lum2))
                .collect();
            let scales: Vec<Pooled> = TEST_RADII
                .iter()
                .map(|&r| Pooled::new(&fresh_y, &reused, w, h, r))
                .collect();
            let verdicts: Vec<(f64, f32)> = (0..w * h)
                .into_par_iter()
                .map(|i| {
                    if reused[i].n <= 0.0 {
                        return (0.0, 0.0);
                    }
                    let start = (1.0f64, 0.0f32);
                    scales
                        .iter()
                        .map(|p| p.verdict(i))
                        .fold(start, |a, b| (a.0.min(b.0), a.1.max(b.1)))
                })
                .collect();
            let mut share = vec![0f64; w * h];
            for (i, (keep, b)) in verdicts.into_iter().enumerate() {
                if keep > 0.0 {
                    share[i] = keep * blurred(i);
                    bias[i] = bias[i].max(b);
                }
            }
            shares.push(share);
        }
        let history = self.keep(&shares, &fresh_y);
        Tested { history, bias }
    }

    /// The film's history: per pixel, the window's frames summed with the shares the test
    /// kept (`shares[j][i]`), less the held fireflies ([`HELD_OUTLIER_RATIO`]).
    fn keep(&self, shares: &[Vec<f64>], fresh_y: &[Moments]) -> Vec<HistoryPixel> {
        let floor = HELD_FLOOR_SHARE * mean_sample_luminance(fresh_y);
        (0..self.width * self.height)
            .into_par_iter()
            .map_init(
                || (Vec::new(), Vec::new()),
                |(s, held), i| {
                    s.clear();
                    s.extend(shares.iter().map(|v| v[i]));
                    held.clear();
                    held.extend(self.lum.iter().map(|l| l[i]));
                    let fresh = (fresh_y[i].sum, fresh_y[i].n);
                    drop_held_outliers(held, s, fresh, floor);
                    let mut h = HistoryPixel::default();
                    for (f, &k) in self.frames.iter().zip(s.iter()) {
                        if k > 0.0 {
                            add(&mut h, &f[i], k);
                        }
                    }
                    h
                },
            )
            .collect()
    }
}

/// A reused frame whose samples alone raise a pixel's combined mean by more than this many
/// times the mean of the rest there is dropped at that pixel (the rest: the fresh samples and
/// the other kept frames but the next brightest, and at least [`HELD_FLOOR_SHARE`] of the
/// image's mean). A rare bright sample (a caustic path at a few spp) would otherwise stay where
/// it landed for K frames, a firefly held still, where independent frames show it for one
/// frame. Fresh samples are never dropped, so the rule biases only the reused share of such
/// pixels, and light-tailed noise loses nothing (a 4-sample mean would have to exceed about 9×
/// the rest's at K = 7). Measured on the moving-sphere box (128², frames 0–11, video JOD at
/// 2 / 4 / 8 / 16 fresh spp; uniform 6.17 / 6.71 / 6.96 / 6.86): without the rule 6.25 / 6.43 /
/// 6.54 / 6.67, ratio 3 6.32 / 6.78 / 6.87 / 6.82, ratio 1 6.32 / 6.87 / 7.18 / 7.13, ratio ½
/// 6.27 / 6.85 / 7.22 / 7.21 (docs/reuse.md).
pub const HELD_OUTLIER_RATIO: f64 = 1.0;

/// The least mean an outlier is measured against, as a share of the image's mean sample
/// luminance: in a dark region one bright reused sample is a firefly too.
pub const HELD_FLOOR_SHARE: f64 = 0.05;

/// The fresh samples' mean luminance over the image (per sample).
fn mean_sample_luminance(fresh: &[Moments]) -> f64 {
    let (s, n) = fresh
        .iter()
        .fold((0.0, 0.0), |(s, n), m| (s + m.sum, n + m.n));
    if n > 0.0 { s / n } else { 0.0 }
}

/// The kept frames (share > 0) of the highest and the next highest luminance per sample; the
/// first in `frames` of equals.
fn two_brightest(frames: &[(f64, f64)], shares: &[f64]) -> (Option<usize>, Option<usize>) {
    let (mut top, mut next): (Option<usize>, Option<usize>) = (None, None);
    let brighter = |a: usize, b: Option<usize>| {
        b.is_none_or(|b| per_sample(frames[a]) > per_sample(frames[b]))
    };
    for j in (0..frames.len()).filter(|&j| shares[j] > 0.0) {
        if brighter(j, top) {
            next = top;
            top = Some(j);
        } else if brighter(j, next) {
            next = Some(j);
        }
    }
    (top, next)
}

/// Luminance per sample of a (luminance sum, weight) pair; 0 for no weight.
fn per_sample((l, w): (f64, f64)) -> f64 {
    if w > 0.0 { l / w } else { 0.0 }
}

/// Drops (share 0), one at a time and largest first, the reused frames that
/// [`HELD_OUTLIER_RATIO`] calls outliers at one pixel. `frames[j]` is frame j's resampled
/// luminance sum there and its weight (samples), `shares[j]` the share of it kept so far,
/// `fresh` the fresh samples' luminance sum and count, `floor` the least mean (luminance per
/// sample) an excess is measured against.
fn drop_held_outliers(frames: &[(f64, f64)], shares: &mut [f64], fresh: (f64, f64), floor: f64) {
    loop {
        let (mut sum, mut n) = fresh;
        for (&(l, w), &k) in frames.iter().zip(shares.iter()) {
            sum += k * l;
            n += k * w;
        }
        if n <= 0.0 {
            return;
        }
        // The frame of the highest mean per sample, measured against the rest without it
        // and without the next highest (a second firefly at the pixel would hide the first).
        let (top, next) = two_brightest(frames, shares);
        let worst = top.map(|j| {
            let (l, w) = frames[j];
            let k = shares[j];
            let (mut rest_sum, mut rest_n) = (sum - k * l, n - k * w);
            if let Some(j2) = next {
                rest_sum -= shares[j2] * frames[j2].0;
                rest_n -= shares[j2] * frames[j2].1;
            }
            let rest = if rest_n > 0.0 { rest_sum / rest_n } else { 0.0 };
            let excess = k * (l - w * rest) / n;
            (j, excess / rest.max(floor).max(f64::MIN_POSITIVE))
        });
        match worst {
            Some((j, r)) if r > HELD_OUTLIER_RATIO => shares[j] = 0.0,
            _ => return,
        }
    }
}

/// The share of a resampled frame kept at a pixel whose resampling bias bound is `blur2`
/// (Y²): the weight that minimises the mean squared error of the fresh mean (variance
/// s²/n_fresh, unbiased) combined with this frame's samples (bias² `blur2`), v / (v + b²) with
/// v = s²/n_fresh, taking the frame's per-sample variance s². Resampling a panned image blurs
/// it; as fresh samples grow, a blurred history counts less, so reuse never costs the image
/// more than it gives.
fn blur_share(h: &HistoryPixel, blur2: f32, fresh: &Moments) -> f64 {
    let n = h.weight();
    if blur2 <= 0.0 || n <= 0.0 {
        return 1.0;
    }
    let mean = luminance(h.sum_even + h.sum_odd) / n;
    let s2 = (h.sum_lum2 / n - mean * mean).max(0.0);
    let v = s2 / fresh.n.max(1.0);
    if v <= 0.0 {
        return 0.0;
    }
    v / (v + blur2 as f64)
}

/// Radii (pixels) of the square neighbourhoods over which fresh and reused luminance are
/// compared: 3 × 3, 9 × 9 and 27 × 27 pixels. At 1–2 fresh spp the 3 × 3 test resolves only
/// changes of about the per-sample noise (a path-traced sample's luminance varies by 1–3× its
/// mean on the Cornell box); the larger ones pool 10–700 times more samples and find the
/// changes of indirect light that spread over a region (a light switched on, a moving object's
/// bounce light), at the cost of locating them to the region.
pub const TEST_RADII: [usize; 3] = [1, 4, 13];

/// Luminance sums and count of a set of samples, and their within-pixel sum of squared
/// deviations and its degrees of freedom.
#[derive(Clone, Copy, Default)]
struct Moments {
    sum: f64,
    n: f64,
    within: f64,
    dof: f64,
}

impl Moments {
    fn of(sum: f64, n: f64, sum2: f64) -> Moments {
        let (within, dof) = if n > 1.0 {
            ((sum2 - sum * sum / n).max(0.0), n - 1.0)
        } else {
            (0.0, 0.0)
        };
        Moments {
            sum,
            n,
            within,
            dof,
        }
    }
}

/// Per pixel where the frame is reused: the fresh and the reused mean luminance and the
/// variance of their difference, each summed over the pixel's (2r + 1)² neighbourhood with the
/// number of pixels summed. Every pixel weighs the same on both sides, so the two pooled means
/// estimate the same average whatever the sample counts (weighting by samples would compare
/// the history's adaptively sampled pixels against the fresh pass's uniform ones).
struct Pooled {
    fresh: Vec<f64>,
    reused: Vec<f64>,
    var: Vec<f64>,
    pixels: Vec<f64>,
}

impl Pooled {
    fn new(fresh: &[Moments], reused: &[Moments], w: usize, h: usize, r: usize) -> Pooled {
        let terms: Vec<[f64; 4]> = fresh
            .iter()
            .zip(reused)
            .map(|(f, h)| {
                let dof = f.dof + h.dof;
                if f.n <= 0.0 || h.n <= 0.0 || dof <= 0.0 {
                    return [0.0; 4];
                }
                let s2 = (f.within + h.within) / dof;
                [f.sum / f.n, h.sum / h.n, s2 * (1.0 / f.n + 1.0 / h.n), 1.0]
            })
            .collect();
        let plane = |k: usize| box_sums(&terms.iter().map(|t| t[k]).collect::<Vec<_>>(), w, h, r);
        Pooled {
            fresh: plane(0),
            reused: plane(1),
            var: plane(2),
            pixels: plane(3),
        }
    }

    /// The share of the reprojected frame kept at pixel `i`, and the disagreement bound (Y).
    fn verdict(&self, i: usize) -> (f64, f32) {
        let n = self.pixels[i];
        if n <= 0.0 {
            return (1.0, 0.0);
        }
        let diff = (self.fresh[i] - self.reused[i]).abs() / n;
        let se = self.var[i].max(0.0).sqrt() / n;
        let z = if se > 0.0 {
            diff / se
        } else if diff > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        let keep = ((Z_REJECT - z) / (Z_REJECT - Z_ACCEPT)).clamp(0.0, 1.0);
        let bias = if keep > 0.0 {
            (diff - 2.0 * se).max(0.0)
        } else {
            0.0
        };
        (keep, bias as f32)
    }
}

/// Sums of `v` over each pixel's (2r + 1)² neighbourhood clipped to the image (a summed-area
/// table, Crow 1984).
fn box_sums(v: &[f64], w: usize, h: usize, r: usize) -> Vec<f64> {
    let mut sat = vec![0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            row += v[y * w + x];
            sat[(y + 1) * (w + 1) + x + 1] = sat[y * (w + 1) + x + 1] + row;
        }
    }
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let (x0, y0) = (x.saturating_sub(r), y.saturating_sub(r));
            let (x1, y1) = ((x + r + 1).min(w), (y + r + 1).min(h));
            let at = |x: usize, y: usize| sat[y * (w + 1) + x];
            at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0)
        })
        .collect()
}

fn luminance(v: DVec3) -> f64 {
    crate::math::luminance(v.as_vec3()) as f64
}

fn add(h: &mut HistoryPixel, o: &HistoryPixel, k: f64) {
    h.sum_even += o.sum_even * k;
    h.sum_odd += o.sum_odd * k;
    h.n_even += o.n_even * k;
    h.n_odd += o.n_odd * k;
    h.sum_lum2 += o.sum_lum2 * k;
}

fn scale(h: &mut HistoryPixel, k: f64) {
    if k != 1.0 {
        let mut s = HistoryPixel::default();
        add(&mut s, h, k);
        *h = s;
    }
}

/// Frame `f`'s fresh samples resampled at each pixel of the frame whose G-buffer is `g`.
fn reproject_frame(scene: &Scene, g: &GBuffer, f: &FrameSamples) -> (Vec<HistoryPixel>, Vec<f32>) {
    let cos_normal = NORMAL_TOLERANCE_DEG.to_radians().cos();
    let t = f.gbuffer.time;
    let (then, here) = (scene.camera_at(t), scene.camera_at(g.time));
    (0..g.width * g.height)
        .into_par_iter()
        .map(|i| {
            let Some(sight) = g.sight_by(scene, i, t, (&then, &here)) else {
                return (HistoryPixel::default(), 0.0);
            };
            if sight.turn > g.reuse_angle[i]
                || !(1.0 / MAX_FOOTPRINT_RATIO..=MAX_FOOTPRINT_RATIO)
                    .contains(&sight.footprint_ratio)
            {
                return (HistoryPixel::default(), 0.0);
            }
            let moved = sight.raster.distance(Vec2::new(
                (i % g.width) as f32 + 0.5,
                (i / g.width) as f32 + 0.5,
            )) > SNAP_PIXELS;
            let valid = |k: usize| -> f32 {
                let o = &f.gbuffer;
                if o.object[k] != g.object[i] || o.material[k] != g.material[i] {
                    return 0.0;
                }
                if moved && o.edge[k] {
                    return 0.0;
                }
                if g.is_background(i) {
                    return 1.0;
                }
                let off = (o.position[k] - sight.point).dot(sight.normal).abs();
                if off > PLANE_TOLERANCE * g.depth[i]
                    || o.normal_at(k).dot(sight.normal) < cos_normal
                {
                    return 0.0;
                }
                match (g.direct.get(i), o.direct.get(k)) {
                    (Some(&a), Some(&b)) => direct_light_share(a, b),
                    _ => 1.0,
                }
            };
            let mut taps = Taps::new(f, sight.raster, valid);
            let (bilinear, blur2) = resample(f, &mut taps);
            match catmull_rom(f, &mut taps) {
                Some(sharp) => (sharp, blur2),
                None => (bilinear, blur2),
            }
        })
        .collect()
}

/// The 4 × 4 source pixels around a reprojected position (the Catmull–Rom footprint; the
/// bilinear one is its inner 2 × 2), each neighbour's share from `valid` evaluated once, when
/// first asked for.
struct Taps<F> {
    /// Position relative to the pixel centres: r − ½.
    q: Vec2,
    /// The footprint's inner top-left pixel, ⌊q⌋.
    x1: i64,
    y1: i64,
    w: i64,
    h: i64,
    valid: F,
    /// Shares asked for so far, row-major from (x1 − 1, y1 − 1); NaN: not yet.
    memo: [f32; 16],
}

impl<F: Fn(usize) -> f32> Taps<F> {
    fn new(f: &FrameSamples, r: Vec2, valid: F) -> Taps<F> {
        let q = r - Vec2::splat(0.5);
        Taps {
            q,
            x1: q.x.floor() as i64,
            y1: q.y.floor() as i64,
            w: f.gbuffer.width as i64,
            h: f.gbuffer.height as i64,
            valid,
            memo: [f32::NAN; 16],
        }
    }

    /// The source pixel of tap (i, j) ∈ [0, 4)², at (x1 − 1 + i, y1 − 1 + j); `None` outside
    /// the frame.
    fn index(&self, i: usize, j: usize) -> Option<usize> {
        let (x, y) = (self.x1 - 1 + i as i64, self.y1 - 1 + j as i64);
        (x >= 0 && y >= 0 && x < self.w && y < self.h).then(|| (y * self.w + x) as usize)
    }

    /// The share `valid` gives tap (i, j), whose source pixel is `k`.
    fn share(&mut self, i: usize, j: usize, k: usize) -> f32 {
        let m = &mut self.memo[4 * j + i];
        if m.is_nan() {
            *m = (self.valid)(k);
        }
        *m
    }
}

/// The share of a neighbour's samples kept when the direct-light signatures
/// ([`GBuffer::direct`]) of the two frames are `a` and `b`: 1 when equal (or both NaN: lit by
/// the static scene alone), falling linearly to 0 at a relative change of
/// [`DIRECT_TOLERANCE`]; 0 when only one is NaN.
fn direct_light_share(a: f32, b: f32) -> f32 {
    match (a.is_nan(), b.is_nan()) {
        // Both lit by the static scene alone: unchanged.
        (true, true) => return 1.0,
        // One near a moving object, one not: nothing to compare, so nothing kept.
        (true, false) | (false, true) => return 0.0,
        _ => {}
    }
    let m = a.max(b);
    if m <= 0.0 {
        return 1.0;
    }
    (1.0 - (a - b).abs() / (DIRECT_TOLERANCE * m)).clamp(0.0, 1.0)
}

/// Bilinear resampling of `f`'s sums at the taps' position over the inner four taps, each
/// accepted with its share in [0, 1]: the bilinear weights of the accepted neighbours are
/// renormalised to 1 (nothing under [`MIN_COVERAGE`]) and each neighbour's samples then count
/// with its share.
///
/// Also returns a bound on the squared bias of the resampling, Y²: the spread of the accepted
/// neighbours' mean luminance about their weighted mean beyond what their noise explains,
/// times 1 − the largest weight (0 when one pixel is taken alone).
fn resample<F: Fn(usize) -> f32>(f: &FrameSamples, taps: &mut Taps<F>) -> (HistoryPixel, f32) {
    // A reprojection within 1/1000 pixel of a pixel centre takes that pixel alone, so a still
    // camera reuses every sample unblurred.
    let snap = |t: f32| {
        if t < SNAP_PIXELS {
            0.0
        } else if t > 1.0 - SNAP_PIXELS {
            1.0
        } else {
            t
        }
    };
    let fx = snap(taps.q.x - taps.x1 as f32);
    let fy = snap(taps.q.y - taps.y1 as f32);
    let mut out = HistoryPixel::default();
    let mut covered = 0f32;
    // (bilinear weight, mean luminance, its noise variance) of the accepted neighbours.
    let mut taken = [(0f32, 0f64, 0f64); 4];
    let mut n_taken = 0;
    for (dx, dy, wt) in [
        (0, 0, (1.0 - fx) * (1.0 - fy)),
        (1, 0, fx * (1.0 - fy)),
        (0, 1, (1.0 - fx) * fy),
        (1, 1, fx * fy),
    ] {
        let Some(k) = taps.index(1 + dx, 1 + dy).filter(|_| wt > 0.0) else {
            continue;
        };
        let share = taps.share(1 + dx, 1 + dy, k);
        if share <= 0.0 {
            continue;
        }
        let c = &f.sums[k];
        let px = HistoryPixel {
            sum_even: DVec3::from_array(c.even.map(f64::from)),
            sum_odd: DVec3::from_array(c.odd.map(f64::from)),
            n_even: c.n_even as f64,
            n_odd: c.n_odd as f64,
            sum_lum2: c.lum2 as f64,
        };
        add(&mut out, &px, (wt * share) as f64);
        covered += wt;
        let n = px.weight();
        if n > 0.0 {
            let m = luminance(px.sum_even + px.sum_odd) / n;
            let s2 = (px.sum_lum2 / n - m * m).max(0.0);
            taken[n_taken] = (wt, m, s2 / n);
            n_taken += 1;
        }
    }
    if covered < MIN_COVERAGE {
        return (HistoryPixel::default(), 0.0);
    }
    scale(&mut out, 1.0 / covered as f64);
    (out, resampling_bias2(&taken[..n_taken]))
}

/// Catmull–Rom (bicubic, Keys 1981 with a = −½) resampling of `f`'s per-pixel means at the
/// taps' position, where all 16 taps with a weight are valid and wholly accepted (else `None`:
/// bilinear then). Bilinear resampling blurs a panned image by up to ¼ px² per axis, which on
/// the holodeck's grid of thin bright lines cost more than the reused samples saved (relative
/// RMSE 0.080 against uniform's 0.068 at 32 fresh spp); the cubic keeps the lines. The
/// half-buffer means are combined with the weights, each channel of each half clamped to that
/// half's range over the 4 nearest taps (no ringing, no negative radiance; the halves stay
/// apart, so their difference still measures the noise), and the result counts as
/// 1 / Σ w²/n samples: the count of one mean with the combination's noise variance.
fn catmull_rom<F: Fn(usize) -> f32>(f: &FrameSamples, taps: &mut Taps<F>) -> Option<HistoryPixel> {
    let cubic = |t: f32| -> [f32; 4] {
        if t < SNAP_PIXELS {
            return [0.0, 1.0, 0.0, 0.0];
        }
        if t > 1.0 - SNAP_PIXELS {
            return [0.0, 0.0, 1.0, 0.0];
        }
        let (t2, t3) = (t * t, t * t * t);
        [
            0.5 * (-t3 + 2.0 * t2 - t),
            0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
            0.5 * (-3.0 * t3 + 4.0 * t2 + t),
            0.5 * (t3 - t2),
        ]
    };
    let wx = cubic(taps.q.x - taps.x1 as f32);
    let wy = cubic(taps.q.y - taps.y1 as f32);
    let (mut even, mut odd) = (DVec3::ZERO, DVec3::ZERO);
    let (mut var_e, mut var_o, mut s2) = (0.0, 0.0, 0.0);
    let inf = DVec3::splat(f64::INFINITY);
    // Ranges of the even and of the odd means over the 4 nearest taps.
    let (mut lo_e, mut hi_e, mut lo_o, mut hi_o) = (inf, -inf, inf, -inf);
    for (j, &ky) in wy.iter().enumerate() {
        for (i, &kx) in wx.iter().enumerate() {
            let wt = (kx * ky) as f64;
            if wt == 0.0 {
                continue;
            }
            let k = taps.index(i, j)?;
            let c = &f.sums[k];
            if taps.share(i, j, k) < 1.0 || c.n_even <= 0.0 || c.n_odd <= 0.0 {
                return None;
            }
            let (ne, no) = (c.n_even as f64, c.n_odd as f64);
            let me = DVec3::from_array(c.even.map(f64::from)) / ne;
            let mo = DVec3::from_array(c.odd.map(f64::from)) / no;
            even += me * wt;
            odd += mo * wt;
            var_e += wt * wt / ne;
            var_o += wt * wt / no;
            let n = ne + no;
            let m = luminance((me * ne + mo * no) / n);
            s2 += wt.abs() * (c.lum2 as f64 / n - m * m).max(0.0);
            if (1..=2).contains(&i) && (1..=2).contains(&j) {
                (lo_e, hi_e) = (lo_e.min(me), hi_e.max(me));
                (lo_o, hi_o) = (lo_o.min(mo), hi_o.max(mo));
            }
        }
    }
    let abs_total: f64 = wx.iter().map(|a| a.abs() as f64).sum::<f64>()
        * wy.iter().map(|a| a.abs() as f64).sum::<f64>();
    let (even, odd) = (even.clamp(lo_e, hi_e), odd.clamp(lo_o, hi_o));
    let (ne, no) = (1.0 / var_e, 1.0 / var_o);
    let mean_y = luminance((even * ne + odd * no) / (ne + no));
    Some(HistoryPixel {
        sum_even: even * ne,
        sum_odd: odd * no,
        n_even: ne,
        n_odd: no,
        sum_lum2: (ne + no) * (s2 / abs_total + mean_y * mean_y),
    })
}

/// See [`resample`]: (weight, mean, noise variance) of the neighbours taken.
fn resampling_bias2(taken: &[(f32, f64, f64)]) -> f32 {
    let total: f64 = taken.iter().map(|t| t.0 as f64).sum();
    if taken.len() < 2 || total <= 0.0 {
        return 0.0;
    }
    let mean = taken.iter().map(|t| t.0 as f64 * t.1).sum::<f64>() / total;
    let spread = taken
        .iter()
        .map(|t| t.0 as f64 * (t.1 - mean).powi(2))
        .sum::<f64>()
        / total;
    let noise = taken.iter().map(|t| t.0 as f64 * t.2).sum::<f64>() / total;
    (spread - noise).max(0.0) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seven reused frames of 4 samples each with per-sample means `means`, and 4 fresh
    /// samples of mean 1: the shares `drop_held_outliers` keeps (all start at 1).
    fn kept(means: &[f64], fresh_mean: f64) -> Vec<f64> {
        let frames: Vec<(f64, f64)> = means.iter().map(|&m| (4.0 * m, 4.0)).collect();
        let mut shares = vec![1.0; frames.len()];
        drop_held_outliers(&frames, &mut shares, (4.0 * fresh_mean, 4.0), 0.05);
        shares
    }

    #[test]
    fn a_held_firefly_is_dropped_and_ordinary_noise_kept() {
        // Frame 3 holds one sample of 100 among its four (mean 25.75): it alone would raise
        // the pixel's mean from about 1.0 to 4.1.
        let s = kept(&[1.1, 0.8, 1.3, 25.75, 0.9, 1.0, 1.2], 1.0);
        assert_eq!(s, [1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0]);
        // Per-sample means spread as 4-sample means of an exponential (sd 0.5) stay.
        let s = kept(&[0.4, 1.9, 1.0, 2.1, 0.6, 1.5, 0.7], 1.0);
        assert_eq!(s, [1.0; 7]);
    }

    #[test]
    fn every_held_firefly_goes_but_a_fresh_one_stays() {
        let s = kept(&[30.0, 1.0, 1.0, 1.0, 40.0, 1.0, 1.0], 1.0);
        assert_eq!(s, [0.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0]);
        // A fresh firefly (fresh mean 25) raises the rest's mean; no reused frame is dropped
        // for it, nor is the fresh sample.
        let s = kept(&[1.0, 0.9, 1.1, 1.0, 1.0, 1.2, 0.8], 25.0);
        assert_eq!(s, [1.0; 7]);
    }

    #[test]
    fn in_the_dark_the_floor_decides() {
        // Everything else black: a frame is measured against the floor (0.05 per sample).
        // One of mean 0.01 raises the pixel's mean by 0.0013, kept; one of 1.0 by 0.125, dropped.
        let s = kept(&[0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.0], 0.0);
        assert_eq!(s, [1.0; 7]);
        let s = kept(&[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0], 0.0);
        assert_eq!(s[2], 0.0);
    }

    /// Light-tailed noise loses nothing to the rule: of 20 000 pixels whose 32 samples
    /// (7 × 4 reused, 4 fresh) are exponential with mean 1, no frame is dropped (a 4-sample
    /// mean would have to exceed about 9× the rest's: P ≈ 1e-11 per frame).
    #[test]
    fn light_tailed_noise_is_unbiased() {
        let mut rng = crate::rng::Rng::new(7, 3);
        let mut exp = || -(1.0 - rng.uniform() as f64).ln();
        let (mut dropped, mut total) = (0usize, 0usize);
        for _ in 0..20_000 {
            let means: Vec<f64> = (0..7)
                .map(|_| (0..4).map(|_| exp()).sum::<f64>() / 4.0)
                .collect();
            let fresh = (0..4).map(|_| exp()).sum::<f64>() / 4.0;
            dropped += kept(&means, fresh).iter().filter(|&&k| k == 0.0).count();
            total += 7;
        }
        assert_eq!(dropped, 0, "{dropped} of {total} frames dropped");
    }
}
