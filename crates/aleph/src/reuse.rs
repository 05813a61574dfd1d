//! Reuse across frames: each frame of a sequence starts from the samples the frames before it
//! traced on the same surfaces (Myszkowski, Rokita & Tawara 1999; DESIGN.md §12).
//!
//! # What is reused
//! The fresh samples of each of the last K frames (the window, [`ReuseWindow`]), kept sample
//! by sample ([`Sample`]: the surface point the camera ray hit first,
//! in its object's rest space, the time in the shutter and the radiance). Each window frame is
//! carried into the current frame directly, each sample once (`Landing::land`): its point,
//! moved with its object to the same time in the current frame's shutter, lands in the pixel
//! it projects into there. Nothing is resampled from pixel means, so a panned texture keeps
//! its pixel-thin lines, a pixel that straddles an edge takes the samples of each of its
//! surfaces where they now fall, and a surface seen closer or more obliquely than before
//! takes every sample that falls on it (until 2026-11-25 pixel means were resampled
//! bilinearly, and edges and footprints changed by more than 1.25× were not reused: on Lost
//! Empire's walkthrough 4.7 of 15 reusable spp were kept).
//!
//! A sample is reused where it lands when
//! - the view of its point turned by no more than its material allows
//!   ([`crate::gbuffer::GBuffer::reuse_angle`]: glossy lobes, mirrors and glass are
//!   view-dependent) and the same side of its surface faces the camera;
//! - its frame saw all of the pixel it lands in (`covered_by`): at a disocclusion's border
//!   the samples of the part seen before would stand for the whole pixel;
//! - nothing is in front of it: where no step in depth is near the pixel
//!   ([`crate::gbuffer::GBuffer::front`]) and a centre there sees the sample's surface (same
//!   object and material, within [`PLANE_TOLERANCE`] · depth of the tangent plane, normals
//!   within [`NORMAL_TOLERANCE_DEG`]), or beside a step the sample lies on the nearest surface,
//!   it is taken as shown; elsewhere a ray from the point to the camera tells;
//! - in a scene where anything but the camera moves, its direct light
//!   ([`crate::gbuffer::GBuffer::direct`], the same fixed light samples in every frame) is
//!   within [`DIRECT_TOLERANCE`] of what it was: a moving shadow or a light uncovered changes
//!   it. The share kept falls linearly with the change.
//!
//! Beside a step in depth, where the two sides have moved against each other since a window
//! frame, that frame's samples may miss a strip of the pixel: the frame is weighed there by
//! its mean squared error, its bias bounded from the parallax and the contrast across the step
//! (`steps`, [`STEP_BIAS`]).
//!
//! Each sample counts with the surface area it stands for (its source pixel's footprint shared
//! among that pixel's samples) over the area a pixel covers there now: a surface seen edge-on
//! before and face-on now got few samples per area, and a pixel where it meets a surface seen
//! face-on in both would otherwise take its mean from the denser one (a box's top against its
//! front: 28 % dark on the Cornell box). A pixel's reused samples from one frame are then a
//! weighted mean, counted as Kish's effective number of samples.
//!
//! Consecutive frames' base passes draw consecutive runs of one sequence per pixel
//! ([`BasePass::offset`]): where the camera is still, the K reused base passes are stratified
//! as one render of K times the samples.
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
//! reuse below independent frames for it until the rule). Its light is not wrong, only too
//! concentrated: what the dropped frames added to the pixel's mean is spread evenly over the
//! pixels of the same surface within [`SPREAD_RADIUS`] (`spread`), so the image keeps its
//! light. Dropped outright, it took 24 % of the moving-sphere box's ceiling (lit by bounce
//! light and caustic paths) and 5 % of its floor.
//!
//! # The window
//! A frame reuses every fresh sample of the K frames before it (a sliding window; fewer at the
//! animation's start). Its own later passes, where perception asked for samples, are
//! allocated by the window's *base passes* alone ([`Reused::Base`]), the first samples of
//! each frame ([`BasePass`]), drawn before anything about the frame was judged: a base
//! pass depends on its frame alone, so a frame's later passes depend on the K frames before it
//! and its image ([`Reused::All`]) on the 2K frames before it, never on the animation's first.
//! Any frame renders alone after its warm-up ([`warm_up_start`]: K base passes, then K frames
//! whole), and a farm may cut a sequence anywhere ([`chunk_start`]). Every frame after the
//! first 2K has the same history (no keyframe whose quality steps down every K + 1 frames: on
//! the moving-sphere box that step was a 3 Hz pulse of the displayed mean, which ColorVideoVDP
//! scored below independent frames). K = 0 gives independent frames.

use crate::camera::{Camera, Projection};
use crate::film::{Film, HistoryPixel};
use crate::gbuffer::{GBuffer, object_index, reuse_angle};
use crate::integrator::FirstHit;
use crate::scene::Scene;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::collections::VecDeque;

mod spread;
mod steps;
pub use spread::SPREAD_RADIUS;
pub use steps::STEP_BIAS;

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

/// Frames the window of frame `frame` holds under a window of `k` (the animation's first frame
/// is `first`): min(frame − first, K), what its base pass depends on ([`BasePass::of`]).
pub fn window_frames(frame: i64, first: i64, k: u32) -> usize {
    (frame - window_start(frame, first, k)) as usize
}

/// The first frame that frame `frame` depends on under a window of `k` (the animation's
/// first frame is `first`): its image reuses all the samples of the K frames before it, whose
/// later passes were allocated by the base passes of the K frames before each, so a frame
/// rendered alone first renders the base passes of frames `warm_up_start ..
/// window_start(frame)` and then the frames `window_start(frame) .. frame` whole (unwritten).
pub fn warm_up_start(frame: i64, first: i64, k: u32) -> i64 {
    window_start(window_start(frame, first, k), first, k)
}

/// Windows a farm's chunk of frames spans ([`chunk_len`]): a chunk first renders its warm-up
/// ([`warm_up_start`]: the base passes of K frames, then K frames whole, about 1.5 K frames'
/// samples), so longer chunks spend less of the farm on it: 17 % of a chunk at 8 windows, 35 %
/// at 4.
pub const CHUNK_WINDOWS: i64 = 8;

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

/// Share of their budget each of the K − 1 frames after the animation's first frame gives it
/// under a window of K ≥ 2 ([`start_up_budget`]).
///
/// The first frame has nothing to reuse and the K frames after it reuse its samples (all of
/// them, and its base pass for their allocation), so its error is what a sequence that starts
/// with it shows longest: on the moving-sphere box (128², frames 0–11, seed 0) the reuse arm
/// at 2 fresh spp scored video JOD 6.605, and 6.767 on frames 1–11 alone. With the first frame
/// at 3.8 × the budget and frames 1–14 at 0.8 × (this share, under K = 15) the twelve frames
/// score 6.953 at 2.1 spp mean (seed 1: 6.996; uniform's 8-spp frames: 6.955 / 6.978); 2 × on
/// the first frame without the payback, 6.896 at 2.17 spp; shares 0.1 and 0.3 in
/// docs/reuse.md ("The first frame's start-up").
pub const START_UP_SHARE: f64 = 0.2;

/// The fresh budget, spp, of a frame whose window holds `window_frames` frames
/// ([`window_frames`]) under a window of `k` when the sequence's budget is `budget`: the
/// animation's first frame (an empty window) takes 1 + [`START_UP_SHARE`] · (K − 1) times
/// the budget, the K − 1 frames after it (windows of 1 to K − 1 frames) 1 −
/// [`START_UP_SHARE`] times, so that those first K frames together take K budgets; every other
/// frame, and every frame under K < 2, the budget. A frame's budget so depends on its window
/// alone, and a frame rendered alone (with its warm-up) draws what it draws in the sequence.
/// A sequence from the animation's first frame shorter than K frames takes a little more than
/// its budget on average, one that starts within the first K frames a little less; the
/// summary lines give each frame's own mean.
pub fn start_up_budget(budget: f64, window_frames: usize, k: u32) -> f64 {
    if k < 2 {
        return budget;
    }
    if window_frames == 0 {
        budget * (1.0 + START_UP_SHARE * f64::from(k - 1))
    } else if window_frames < k as usize {
        budget * (1.0 - START_UP_SHARE)
    } else {
        budget
    }
}

/// Share of a frame's fresh budget drawn in its base pass (what later frames reuse); the rest
/// goes where the perceptual criterion finds the combined estimate's error visible.
pub const BASE_SHARE: f64 = 0.5;

/// Samples per pixel of a frame's base pass without a budget (the perceptual stop).
pub const BASE_SPP_UNBUDGETED: u32 = 4;

/// A frame's base pass: about [`BASE_SHARE`] of its fresh budget, drawn before anything about
/// the frame is judged (what the passes of the frames after it are allocated by, see "The
/// window" above).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BasePass {
    /// `n` samples in every pixel: ⌊[`BASE_SHARE`] · budget⌋ under a budget of 2 spp or
    /// more (or one where the frame is judged), [`BASE_SPP_UNBUDGETED`] without a budget.
    Every(u32),
    /// Under a budget below 2 spp, where the frame is not judged and its window holds at
    /// least [`CHECKER_MIN_WINDOW`] frames: one sample in the pixels (x, y) of frame f with
    /// x + y + f even, a checkerboard that alternates frame by frame (half a sample a pixel),
    /// so that half the budget is left to level the effective counts, the pixels that reuse
    /// least first. With one sample everywhere nothing was left for them: on the Lost Empire
    /// walkthrough (frame 15, 240×150, 1 fresh spp, 4 seeds) the 6.6 % of pixels that reused
    /// fewer than 4 samples held 61 % of the frame's relative MSE (docs/reuse.md).
    Checker,
}

/// The fewest window frames under which a frame's base pass may be a checkerboard
/// ([`BasePass::Checker`]): a pixel that takes no base sample lives on about one reused sample
/// a window frame until the level reaches it. On the moving-sphere box (128², 1 fresh spp)
/// frames 1–3 scored FLIP mean 0.200 / 0.202 / 0.182 with a checkerboard against 0.185 / 0.174
/// / 0.174 without, and frames 4–11 0.149–0.161 against 0.157–0.166.
pub const CHECKER_MIN_WINDOW: usize = 4;

impl BasePass {
    /// The base pass of a frame with fresh budget `budget` spp (`None`: the perceptual stop),
    /// judged by the perceptual criterion or not (`judged`; see
    /// [`crate::adaptive::AdaptiveSettings::steers`]), whose window holds `window_frames`
    /// frames (min(f − first, K) for frame f of an animation from frame `first`).
    pub fn of(budget: Option<f64>, judged: bool, window_frames: usize) -> BasePass {
        match budget {
            Some(b) if b < 2.0 && !judged && window_frames >= CHECKER_MIN_WINDOW => {
                BasePass::Checker
            }
            Some(b) => BasePass::Every(((BASE_SHARE * b).floor() as u32).max(1)),
            None => BasePass::Every(BASE_SPP_UNBUDGETED),
        }
    }

    /// Samples pixel (x, y) of frame `frame` takes.
    pub fn count(self, frame: i64, (x, y): (usize, usize)) -> u32 {
        match self {
            BasePass::Every(n) => n,
            BasePass::Checker => u32::from((x as i64 + y as i64 + frame).rem_euclid(2) == 0),
        }
    }

    /// [`BasePass::count`] of every pixel of a `w` × `h` frame, row-major.
    pub fn counts(self, frame: i64, (w, h): (usize, usize)) -> Vec<u32> {
        (0..w * h)
            .map(|i| self.count(frame, (i % w, i / w)))
            .collect()
    }

    /// The index in its pixel's sequences of frame `frame`'s first base-pass sample, the
    /// same in every pixel. [`BasePass::Every`]`(n)`: frame f takes samples f·s .. f·s + n
    /// with s = n rounded up to even (each half-buffer keeps its stream), so the K base
    /// passes a frame reuses are one run of K·s consecutive samples of each pixel's
    /// sequences, stratified as one render's are: where the camera is still, the window is
    /// worth as many samples of one render (drawn from sequences of their own, frame by
    /// frame, they were worth half as many on Lost Empire's textured terrain: relative MSE of
    /// a 2-spp frame with 15 reused frames 0.0090, as uniform at 8 spp, against 0.0039 at
    /// 16). [`BasePass::Checker`]: 2 ⌊f / 2⌋, so that a pixel, which takes a sample every
    /// other frame, takes consecutive points of its half-buffer A stream (sample index f
    /// would give it every other point, all in one half of a dimension's unit interval).
    pub fn offset(self, frame: i64) -> u64 {
        match self {
            BasePass::Every(n) => (frame as u64).wrapping_mul(n.next_multiple_of(2) as u64),
            BasePass::Checker => (frame.div_euclid(2) as u64).wrapping_mul(2),
        }
    }
}

/// One camera sample kept for reuse: the surface its ray hit first, carried with that
/// surface's object, when in the shutter, and its radiance. 32 bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// The triangle the camera ray hit first; `u32::MAX` where the ray left the scene.
    pub tri: u32,
    /// The hit point at the sample's time in the rest space of the triangle's object (world
    /// space for static geometry); the ray's unit direction for a miss.
    pub at: Vec3,
    /// The sample's radiance, W·sr⁻¹·m⁻² (zero for a non-finite sample, as the film counts it).
    pub rgb: Vec3,
    /// The sample's time less its frame's instant, seconds (0 without motion blur): it lands
    /// in a later frame as taken at the same point of that frame's shutter.
    pub dt: f32,
}

impl Sample {
    /// The sample whose camera ray at scene time `time` hit `first` and carried `rgb`.
    pub fn new(scene: &Scene, first: FirstHit, time: f32, rgb: Vec3) -> Sample {
        let moving = (first.tri != u32::MAX)
            .then(|| scene.geometry.transform_at(first.tri, time))
            .flatten();
        let at = moving.map_or(first.at, |m| m.inverse().transform_point3(first.at));
        Sample {
            tri: first.tri,
            at,
            rgb,
            dt: time - scene.frame.time_s as f32,
        }
    }
}

/// The seed of every frame's base pass: the render seed's, the same in every frame (not the
/// frame's own, [`Scene::frame_seed`]), so that the base passes of consecutive frames draw
/// consecutive runs of one sequence per pixel ([`BasePass::offset`]).
pub fn base_seed(scene: &Scene) -> u64 {
    crate::rng::mix64(scene.settings.seed ^ BASE_SEED_KEY)
}

const BASE_SEED_KEY: u64 = 0x9E37_79B9_7F4A_7C15;

/// The memory reuse across frames may take by default, bytes (`--reuse-memory`,
/// [`crate::job::SamplingOptions::reuse_memory_gib`]): the window's frames, their samples and
/// their landing in the current frame. At the default window of 15 frames it holds 1920×1080
/// whole (2 samples kept a pixel) and cuts 3840×2160 to 3 frames ([`window_for`]). Without a
/// bound a 1920×1080 sequence at 16 spp would keep 18 GB of samples, and 3840×2160 would need
/// 22 GB for its per-pixel records alone.
pub const DEFAULT_MEMORY: u64 = 8 << 30;

/// Bytes a kept sample takes: the [`Sample`] and its footprint.
pub const SAMPLE_BYTES: usize = std::mem::size_of::<Sample>() + std::mem::size_of::<f32>();

/// Bytes a pixel takes in each window frame besides its kept samples: the frame's [`View`]
/// record (with its direct-light signature) and, while the frame lands in the current one, two
/// layers of sums ([`Reprojected`]: the base passes and every sample; counted as they land,
/// in their larger form) with their luminance, and the parallax at steps in depth (see
/// [`STEP_BIAS`]).
pub const RECORD_BYTES: usize = std::mem::size_of::<Px>()
    + 2 * std::mem::size_of::<f32>()
    + 2 * (std::mem::size_of::<Splat>() + std::mem::size_of::<(f64, f64)>());

/// Samples a pixel keeps at least (one for each half-buffer).
pub const MIN_KEPT_SPP: u32 = 2;

/// The largest window, at most `k` frames, whose frames fit in `memory` bytes at `pixels`
/// pixels: the K window frames and the frame being rendered each take [`RECORD_BYTES`] and
/// [`MIN_KEPT_SPP`] samples a pixel. 0 (independent frames) where not even one frame fits.
pub fn window_for(pixels: usize, k: u32, memory: u64) -> u32 {
    let frame = pixels.max(1) as u64 * (RECORD_BYTES + MIN_KEPT_SPP as usize * SAMPLE_BYTES) as u64;
    let fits = (memory / frame).saturating_sub(1);
    k.min(fits.min(u32::MAX as u64) as u32)
}

/// Memory each frame of a window of `k` may take out of `memory` bytes (the window's frames
/// and the frame being rendered share it evenly), bytes.
pub fn frame_memory(k: u32, memory: u64) -> u64 {
    memory / (k as u64 + 1)
}

/// Samples per pixel a frame of `pixels` pixels keeps for the frames after it, at most: its
/// first ones (the base pass's, then later passes' in order), as many as fit in `frame_memory`
/// bytes after the pixels' records ([`RECORD_BYTES`]); an even number (as many for each
/// half-buffer) and at least [`MIN_KEPT_SPP`]. With the default memory and window
/// ([`frame_memory`] of 512 MiB): 382 at 240×160, 50 at 512², 2 at 1920×1080.
pub fn kept_spp(pixels: usize, frame_memory: u64) -> u32 {
    let per_pixel = (frame_memory / pixels.max(1) as u64).saturating_sub(RECORD_BYTES as u64);
    let n = (per_pixel / SAMPLE_BYTES as u64).min(u32::MAX as u64);
    (n as u32 & !1).max(MIN_KEPT_SPP)
}

/// One frame's base pass with its G-buffer: what later frames reuse. Its samples are kept one
/// by one ([`Sample`]), so that each lands in the pixel of a later frame that sees its surface
/// point, not resampled from pixel means.
#[derive(Clone, Debug)]
pub struct FrameSamples {
    /// The frame number.
    pub index: i64,
    /// What reuse needs of the frame's G-buffer.
    pub view: View,
    /// Every sample, grouped by pixel (row-major) in the order taken.
    samples: Vec<Sample>,
    /// `start[i]..start[i + 1]`: pixel i's samples (pixels + 1 entries); the k-th of them is
    /// the pixel's sample number k (even k in half-buffer A).
    start: Vec<u32>,
    /// The frame's base pass: each pixel's first [`BasePass::count`] samples (at most `cap`).
    base: BasePass,
    /// Per sample: the surface area its source pixel covered at its point (m²; a miss: the
    /// pixel's solid angle, sr), negative where the side facing the camera was the back of the
    /// winding ([`footprint`]). With the sample, 36 bytes.
    area: Vec<f32>,
    /// Samples a pixel keeps at most ([`kept_spp`]).
    cap: u32,
}

/// What landing needs of a triangle, 20 bytes (a scene's triangles keep 56 and more, and
/// every landing would read them from afar): its unit normal from the winding in its object's
/// rest space, its material and its instance ([`crate::geometry::STATIC_INSTANCE`] for
/// static geometry).
#[derive(Clone, Copy, Debug, Default)]
struct Tri {
    normal: Vec3,
    material: u32,
    instance: u32,
}

/// [`Tri`] of every triangle of `geo`.
fn triangle_table(geo: &crate::geometry::Geometry) -> Vec<Tri> {
    (0..geo.tris.len())
        .into_par_iter()
        .map(|i| Tri {
            normal: triangle_normal(geo, i as u32),
            material: geo.tris.material(i),
            instance: geo.tris.instance(i),
        })
        .collect()
}

impl FrameSamples {
    /// A frame's samples as [`crate::render::render_counts_recorded`] returns them from the
    /// frame's base pass `base` into `film`, of which each pixel keeps at most its first
    /// `cap` ([`kept_spp`]; raised to [`MIN_KEPT_SPP`]).
    ///
    /// # Panics
    /// If the film's pixels do not hold the base pass's counts from sample 0, or `samples`
    /// do not match them.
    pub fn new(
        scene: &Scene,
        (film, base): (&Film, BasePass),
        gbuffer: &GBuffer,
        samples: Vec<Sample>,
        cap: u32,
    ) -> FrameSamples {
        let cap = cap.max(MIN_KEPT_SPP);
        let counts = base.counts(scene.frame.index, (gbuffer.width, gbuffer.height));
        assert!(
            film.len() == counts.len()
                && film
                    .pixels
                    .iter()
                    .zip(&counts)
                    .all(|(p, &c)| p.first == 0 && p.count() == c),
            "a base pass takes its counts in every pixel, from sample 0"
        );
        assert_eq!(
            counts.iter().map(|&c| c as usize).sum::<usize>(),
            samples.len(),
            "one recorded sample per sample taken"
        );
        let mut frame = FrameSamples {
            index: scene.frame.index,
            view: View::of(gbuffer),
            samples: Vec::new(),
            start: vec![0; film.len() + 1],
            base,
            area: Vec::new(),
            cap,
        };
        frame.add_pass(scene, &counts, &samples);
        frame
    }

    /// Pixel i's base-pass samples held (its first ones). Called for every pixel of every
    /// window frame at each landing: (x, y) is found only for a checkerboard.
    fn base_count(&self, i: usize) -> u32 {
        let n = match self.base {
            BasePass::Every(n) => n,
            BasePass::Checker => {
                let w = self.view.width;
                self.base.count(self.index, (i % w, i / w))
            }
        };
        n.min(self.cap)
    }

    /// Appends a later pass of `counts[i]` samples in pixel i, as
    /// [`crate::render::render_counts_recorded`] returns them (grouped by pixel): they follow
    /// each pixel's samples so far, up to the frame's cap in all (the rest are not kept).
    ///
    /// # Panics
    /// If `counts` does not have one entry per pixel or `samples` do not match it.
    pub fn add_pass(&mut self, scene: &Scene, counts: &[u32], samples: &[Sample]) {
        assert_eq!(counts.len() + 1, self.start.len());
        assert_eq!(
            counts.iter().map(|&c| c as usize).sum::<usize>(),
            samples.len()
        );
        let cap = self.cap as usize;
        let new_area: Vec<f32> = samples.par_iter().map(|s| footprint(scene, s)).collect();
        let mut merged = Vec::with_capacity(self.samples.len() + samples.len());
        let mut area = Vec::with_capacity(merged.capacity());
        let mut start = Vec::with_capacity(self.start.len());
        start.push(0u32);
        let mut at = 0usize;
        for (i, &c) in counts.iter().enumerate() {
            let own = self.start[i] as usize..self.start[i + 1] as usize;
            let new = at..at + (c as usize).min(cap - own.len());
            merged.extend_from_slice(&self.samples[own.clone()]);
            area.extend_from_slice(&self.area[own]);
            merged.extend_from_slice(&samples[new.clone()]);
            area.extend_from_slice(&new_area[new]);
            at += c as usize;
            start.push(merged.len() as u32);
        }
        self.samples = merged;
        self.area = area;
        self.start = start;
    }

    /// Samples held.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether it holds no sample.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Whether every pixel holds exactly its base pass's samples, so that a frame's samples
    /// land alike as [`Reused::Base`] and as [`Reused::All`] (the same samples, each with the
    /// same share of its pixel's footprint).
    fn only_base(&self) -> bool {
        self.start
            .windows(2)
            .enumerate()
            .all(|(i, r)| r[1] - r[0] == self.base_count(i))
    }
}

/// What reuse needs of a frame's G-buffer ([`GBuffer`]), one record of 48 bytes per pixel: a
/// window frame keeps this, not the whole G-buffer, and a sample's checks read one place.
#[derive(Clone, Debug)]
pub struct View {
    /// The frame's instant, s.
    pub time: f32,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    px: Vec<Px>,
    /// [`GBuffer::direct`] (empty where nothing but the camera moves).
    direct: Vec<f32>,
}

/// One pixel of a [`View`]: the surface at its centre (world point, depth along the view axis,
/// shading normal, `IndexOB`, material) and [`GBuffer::front`]'s nearest neighbour.
#[derive(Clone, Copy, Debug, Default)]
struct Px {
    position: Vec3,
    depth: f32,
    normal: Vec3,
    object: u32,
    material: u32,
    front: u32,
    /// [`EDGE`], [`STEP`].
    flags: u32,
}

/// [`Px::flags`]: the pixel straddles an edge ([`GBuffer::edge`]).
const EDGE: u32 = 1;
/// [`Px::flags`]: its 3 × 3 neighbourhood spans a step in depth ([`GBuffer::front`]).
const STEP: u32 = 2;

impl View {
    /// The view of `g`.
    pub fn of(g: &GBuffer) -> View {
        let px = (0..g.width * g.height)
            .map(|i| {
                let (front, step) = g.front[i];
                Px {
                    position: g.position[i],
                    depth: g.depth[i],
                    normal: g.normal_at(i),
                    object: g.object[i],
                    material: g.material[i],
                    front,
                    flags: if g.edge[i] { EDGE } else { 0 } | if step { STEP } else { 0 },
                }
            })
            .collect();
        View {
            time: g.time,
            width: g.width,
            height: g.height,
            px,
            direct: g.direct.clone(),
        }
    }
}

impl Px {
    fn is_background(&self) -> bool {
        self.object == crate::gbuffer::BACKGROUND_OBJECT
    }
}

/// [`FrameSamples`]'s area of sample `s` of `scene`'s current frame, at the frame's instant:
/// d² Ω / |cos θ| for a surface at distance d seen at θ from its normal through a pixel of
/// solid angle Ω, signed as the cosine with the triangle's winding normal; Ω for a miss.
fn footprint(scene: &Scene, s: &Sample) -> f32 {
    let cam = &scene.camera;
    if s.tri == u32::MAX {
        return cam.pixel_solid_angle(s.at);
    }
    let geo = &scene.geometry;
    let t = scene.frame.time_s as f32;
    let m = geo.transform_at(s.tri, t);
    let p = m.map_or(s.at, |m| m.transform_point3(s.at));
    let normal = triangle_normal(geo, s.tri);
    let world = m.map_or(normal, |m| normal_to_world(&m, normal));
    let view = cam.position - p;
    let cos = world.dot(view.normalize_or_zero());
    let area = cam.pixel_solid_angle(-view) * view.length_squared() / cos.abs().max(MIN_COSINE);
    if cos < 0.0 { -area } else { area }
}

/// The last K frames' base passes.
#[derive(Clone, Debug, Default)]
pub struct ReuseWindow {
    /// K: the frames it holds at most.
    k: u32,
    frames: VecDeque<FrameSamples>,
    /// The scene's [`Tri`]s, made at the first reprojection (a window serves one scene).
    tris: std::sync::OnceLock<Vec<Tri>>,
}

impl ReuseWindow {
    /// An empty window of `k` frames (what it holds is the caller's: [`ReuseWindow::keep_from`]
    /// with [`window_start`]); `k` sets the frames' budgets ([`start_up_budget`]).
    pub fn new(k: u32) -> ReuseWindow {
        ReuseWindow {
            k,
            ..ReuseWindow::default()
        }
    }

    /// K, the frames the window holds at most.
    pub fn k(&self) -> u32 {
        self.k
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
        let shutter = Shutter::of(scene);
        let angles: Vec<f32> = scene
            .materials
            .iter()
            .map(|m| reuse_angle(&m.kind))
            .collect();
        let view = View::of(g);
        let tris = self.tris.get_or_init(|| triangle_table(&scene.geometry));
        let splats: Vec<_> = self
            .frames
            .par_iter()
            .map(|f| splat_frame(scene, (g, &view), f, (&shutter, &angles, tris)))
            .collect();
        let (mut base, mut all, mut parallax) = (Vec::new(), Vec::new(), Vec::new());
        for (b, a, p) in splats {
            base.push(b);
            all.push(a);
            parallax.push(p);
        }
        Reprojected {
            stepped: steps::stepped(&parallax, g.width * g.height),
            parallax,
            base_is_all: self.frames.iter().all(FrameSamples::only_base),
            base: Layer::new(base),
            all: Layer::new(all),
            width: g.width,
            height: g.height,
            still_light: !scene.geometry.has_motion(),
            surfaces: spread::Surfaces::of(g),
        }
    }
}

/// The window's frames reprojected into the current frame (before the test against its fresh
/// samples).
#[derive(Clone, Debug)]
pub struct Reprojected {
    /// Every window frame's samples are its base pass's: `base` and `all` are equal.
    base_is_all: bool,
    /// The window frames' base passes ([`Reused::Base`]).
    base: Layer,
    /// Every sample of the window frames ([`Reused::All`]).
    all: Layer,
    width: usize,
    height: usize,
    /// Nothing but the camera moves: light cannot change on a surface, so nothing is tested.
    still_light: bool,
    /// What each pixel sees, for spreading held fireflies' light over its surface.
    surfaces: spread::Surfaces,
    /// Per window frame, per pixel: how far the surfaces on the two sides of a step in depth
    /// through the pixel moved against each other since that frame, px ([`steps::parallax`]).
    parallax: Vec<Vec<f32>>,
    /// The pixels with a parallax to any window frame ([`steps::stepped`]).
    stepped: Vec<u32>,
}

/// Which samples of the window's frames: what a frame's fresh samples are allocated by, or
/// what its image is made of (see the module docs, "The window").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reused {
    /// Their base passes: each depends on its frame alone, so what a frame's later passes
    /// depend on stays within the window.
    Base,
    /// All their fresh samples, base pass and later passes.
    All,
}

/// The window's frames reprojected into the current frame, one set of samples of them.
#[derive(Clone, Debug, Default)]
struct Layer {
    /// Per window frame, per pixel: the samples that landed there (weight 0 where nothing is
    /// reused).
    frames: Vec<Vec<Part>>,
    /// Per window frame, per pixel: the reused luminance sum and its weight (samples),
    /// computed once for every test.
    lum: Vec<Vec<(f64, f64)>>,
}

impl Layer {
    /// The layer of the window frames' `(parts, lum)` ([`finish`]), in window order.
    fn new(frames: Vec<FinishedFrame>) -> Layer {
        let (frames, lum) = frames.into_iter().unzip();
        Layer { frames, lum }
    }
}

/// One window frame's splats as history ([`Splat::finish`]) and each pixel's reused luminance
/// sum and weight beside them ([`Layer::lum`]), computed while each part is at hand rather
/// than in a second pass over every window frame's parts (the walkthrough's base and all
/// layers are 39 MB of parts at 240×150; that pass took about 6 ms of a 188-ms frame).
fn finish(layer: &[Splat]) -> FinishedFrame {
    layer
        .iter()
        .map(|s| {
            let p = s.finish();
            (p, (p.lum(), p.weight()))
        })
        .unzip()
}

/// One window frame's samples at one pixel as they land, per half-buffer: Σ w, Σ w², Σ w·RGB
/// and Σ w·Y² of the samples that landed there with weights w (a window frame gives a pixel
/// tens of samples at most, well within f32). As history ([`Splat::finish`]) each half is the
/// weighted mean counted as Kish's effective number of samples, (Σ w)² / Σ w².
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Splat {
    w: [f32; 2],
    w2: [f32; 2],
    rgb: [Vec3; 2],
    lum2: [f32; 2],
}

impl Splat {
    /// Adds a sample of radiance `rgb` to half-buffer A (`even`) or B with weight `w`.
    fn add(&mut self, rgb: Vec3, even: bool, w: f32) {
        let h = usize::from(!even);
        let y = crate::math::luminance(rgb);
        self.w[h] += w;
        self.w2[h] += w * w;
        self.rgb[h] += rgb * w;
        self.lum2[h] += w * y * y;
    }

    /// Half `h`'s effective count and the factor that scales its weighted sums to it.
    fn count(&self, h: usize) -> (f32, f32) {
        if self.w[h] <= 0.0 {
            return (0.0, 0.0);
        }
        let n = self.w[h] * self.w[h] / self.w2[h];
        (n, n / self.w[h])
    }

    /// The sums as history, each half scaled to its effective count (computed once: every
    /// test reads them).
    fn finish(&self) -> Part {
        let ((ne, ke), (no, ko)) = (self.count(0), self.count(1));
        Part {
            n: [ne, no],
            rgb: [self.rgb[0] * ke, self.rgb[1] * ko],
            lum2: self.lum2[0] * ke + self.lum2[1] * ko,
        }
    }
}

/// One window frame's samples at one pixel as history ([`Splat::finish`]): per half-buffer
/// the effective count and the RGB sum scaled to it, and Σ w·Y² scaled alike over both
/// halves.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Part {
    n: [f32; 2],
    rgb: [Vec3; 2],
    lum2: f32,
}

impl Part {
    fn weight(&self) -> f64 {
        (self.n[0] + self.n[1]) as f64
    }

    /// Luminance of the RGB sum of both halves, as history.
    fn lum(&self) -> f64 {
        crate::math::luminance(self.rgb[0] + self.rgb[1]) as f64
    }

    fn history(&self) -> HistoryPixel {
        HistoryPixel {
            sum_even: self.rgb[0].as_dvec3(),
            sum_odd: self.rgb[1].as_dvec3(),
            n_even: self.n[0] as f64,
            n_odd: self.n[1] as f64,
            sum_lum2: self.lum2 as f64,
            spread: DVec3::ZERO,
        }
    }
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
    /// Whether every window frame's samples are its base pass's ([`Reused::Base`] and
    /// [`Reused::All`] are the same samples).
    pub fn base_is_all(&self) -> bool {
        self.base_is_all
    }

    /// Tests each reprojected frame's `reused` samples against `fresh` (the current frame's
    /// fresh samples so far; see the module docs): weights it down where they disagree and,
    /// beside steps in depth, by the bias its parallax may carry ([`STEP_BIAS`]), and bounds
    /// the bias of what is kept.
    pub fn test(&self, fresh: &Film, reused: Reused) -> Tested {
        let layer = match reused {
            Reused::Base => &self.base,
            Reused::All => &self.all,
        };
        let (w, h) = (self.width, self.height);
        assert_eq!((w, h), (fresh.width as usize, fresh.height as usize));
        let fresh_y: Vec<Moments> = fresh
            .pixels
            .par_iter()
            .map(|p| Moments::of(luminance(p.sum()), p.count() as f64, p.sum_lum2.value()))
            .collect();
        // Per window frame, per pixel: the share of its samples kept (none where nothing but
        // the camera moves: everything is kept, and `keep` takes every share as 1). The frames
        // are tested in parallel; the bound is their largest, the same in any order.
        let tested = if self.still_light {
            0
        } else {
            layer.frames.len()
        };
        let bias = std::sync::Mutex::new(vec![0f32; w * h]);
        let mut shares: Vec<Vec<f64>> = layer
            .frames
            .par_iter()
            .zip(layer.lum.par_iter())
            .take(tested)
            .map(|(f, lum)| {
                let (share, b) = test_frame(f, lum, &fresh_y, (w, h));
                let mut bias = bias.lock().unwrap_or_else(|e| e.into_inner());
                for (m, b) in bias.iter_mut().zip(b) {
                    *m = m.max(b);
                }
                share
            })
            .collect();
        let bias = bias.into_inner().unwrap_or_else(|e| e.into_inner());
        let steps = (&self.parallax[..], &self.stepped[..]);
        steps::weigh(layer, steps, &fresh_y, (w, h), &mut shares);
        let history = keep(layer, &shares, fresh, &fresh_y, &self.surfaces);
        Tested { history, bias }
    }
}

/// One window frame's samples `f` (their luminance sums and weights `lum`) tested against the
/// fresh samples `fresh_y` at every pixel of a `w` × `h` image ([`Reprojected::test`]): the
/// share of them kept, and where any is kept the disagreement bound (Y; 0 elsewhere).
fn test_frame(
    f: &[Part],
    lum: &[(f64, f64)],
    fresh_y: &[Moments],
    (w, h): (usize, usize),
) -> (Vec<f64>, Vec<f32>) {
    let reused: Vec<Moments> = f
        .par_iter()
        .zip(lum)
        .map(|(p, &(l, n))| Moments::of(l, n, p.history().sum_lum2))
        .collect();
    let pooled = Pooled::new(fresh_y, &reused, w, h);
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            if reused[i].n <= 0.0 {
                return (0.0, 0.0);
            }
            let (start, xy) = ((1.0f64, 0.0f32), (i % w, i / w));
            let (keep, b) = TEST_RADII
                .iter()
                .map(|&r| pooled.verdict(xy, r))
                .fold(start, |a, b| (a.0.min(b.0), a.1.max(b.1)));
            if keep > 0.0 { (keep, b) } else { (0.0, 0.0) }
        })
        .unzip()
}

/// Per pixel, the least mean a held firefly's excess is measured against
/// ([`drop_held_outliers`]): [`HELD_FLOOR_SHARE`] of the image's mean, or the mean of the
/// pixel's 3 × 3 neighbourhood (every sample, fresh and reused) where that is more. Each
/// window frame gives a pixel about one sample: where a pixel-thin bright line crosses the
/// pixel, a few of them see it, and measured against the pixel's own other samples they looked
/// like fireflies (the holodeck's grid lines went out); its neighbours along the line have
/// such samples too, where a caustic path's do not.
fn outlier_floors(layer: &Layer, fresh_y: &[Moments], (w, h): (usize, usize)) -> Vec<f64> {
    let floor = HELD_FLOOR_SHARE * mean_sample_luminance(fresh_y);
    let means: Vec<f64> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            prefetch(&layer.lum, i + PREFETCH_AHEAD);
            let (mut sum, mut n) = (fresh_y[i].sum, fresh_y[i].n);
            for l in &layer.lum {
                sum += l[i].0;
                n += l[i].1;
            }
            if n > 0.0 { sum / n } else { 0.0 }
        })
        .collect();
    let sat = SummedArea::new(w, h, |i| [means[i], 1.0]);
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let [sum, count] = sat.sums((i % w, i / w), 1);
            (sum / count).max(floor)
        })
        .collect()
}

/// The film's history: per pixel, the layer's frames summed with the shares the test kept
/// (`shares[j][i]`; every share 1 where `shares` is empty), less the held fireflies
/// ([`HELD_OUTLIER_RATIO`]), whose excess over the rest (with the `fresh` film's samples) is
/// spread over their surface ([`spread`]).
fn keep(
    layer: &Layer,
    shares: &[Vec<f64>],
    fresh: &Film,
    fresh_y: &[Moments],
    surfaces: &spread::Surfaces,
) -> Vec<HistoryPixel> {
    let size = (fresh.width as usize, fresh.height as usize);
    let floors = outlier_floors(layer, fresh_y, size);
    let (mut history, excess): (Vec<HistoryPixel>, Vec<DVec3>) = (0..size.0 * size.1)
        .into_par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(s, held), i| {
                let ahead = i + PREFETCH_AHEAD;
                prefetch(&layer.frames, ahead);
                prefetch(&layer.lum, ahead);
                prefetch(shares, ahead);
                s.clear();
                if shares.is_empty() {
                    s.resize(layer.frames.len(), 1.0);
                } else {
                    s.extend(shares.iter().map(|v| v[i]));
                }
                held.clear();
                held.extend(layer.lum.iter().map(|l| l[i]));
                let all = weighted_sum(layer, s, i);
                let counts = (fresh_y[i].sum, fresh_y[i].n);
                if !drop_held_outliers(held, s, counts, floors[i]) {
                    return (all, DVec3::ZERO);
                }
                let kept = weighted_sum(layer, s, i);
                let p = &fresh.pixels[i];
                (kept, all.sample_means(p).2 - kept.sample_means(p).2)
            },
        )
        .unzip();
    let spread = spread::spread(&excess, surfaces);
    for (h, s) in history.iter_mut().zip(spread) {
        h.spread = s;
    }
    history
}

/// How many pixels ahead the per-pixel passes over a window's frames prefetch ([`prefetch`]).
const PREFETCH_AHEAD: usize = 16;

/// Prefetches element `i` of each of `rows` (nothing past a row's end). The passes that read
/// a window's frames side by side ([`keep`], [`outlier_floors`]) follow one to three streams a
/// frame, 15–45 at the default window, more than a CPU's hardware prefetchers track: with the
/// pixel 16 ahead prefetched, the test of a reusing frame (the `reuse` bench's `test`, 15
/// window frames, the same bytes) takes 11.7 ms instead of 15.8 on the Lost Empire walkthrough
/// at 240×150 and 9.5–10.2 ms instead of 10.7 on the moving-sphere box at 128² (criterion,
/// the build without before and after the build with it).
#[inline]
fn prefetch<T>(rows: &[Vec<T>], i: usize) {
    for row in rows {
        if let Some(p) = row.get(i) {
            crate::math::prefetch(p);
        }
    }
}

/// Pixel `i`'s history: the layer's frames summed with `shares` (one per frame).
fn weighted_sum(layer: &Layer, shares: &[f64], i: usize) -> HistoryPixel {
    let mut h = HistoryPixel::default();
    for (f, &k) in layer.frames.iter().zip(shares) {
        if k > 0.0 {
            add(&mut h, &f[i].history(), k);
        }
    }
    h
}

/// A reused frame whose samples alone raise a pixel's combined mean by more than this many
/// times the mean of the rest there is dropped at that pixel (the rest: the fresh samples and
/// the other kept frames but the next brightest, and at least [`HELD_FLOOR_SHARE`] of the
/// image's mean). A rare bright sample (a caustic path at a few spp) would otherwise stay where
/// it landed for K frames, a firefly held still, where independent frames show it for one
/// frame. Fresh samples are never dropped, and what the dropped frames added to the pixel's
/// mean is spread over its surface nearby ([`SPREAD_RADIUS`]), so the rule moves light but
/// loses none; light-tailed noise is not touched (a 4-sample mean would have to exceed about 9×
/// the rest's at K = 7). Measured on the moving-sphere box (128², frames 0–11, video JOD at
/// 2 / 4 / 8 / 16 fresh spp; uniform 6.17 / 6.71 / 6.96 / 6.86): without the rule 6.25 / 6.43 /
/// 6.54 / 6.67, ratio 3 6.32 / 6.78 / 6.87 / 6.82, ratio 1 6.32 / 6.87 / 7.18 / 7.13, ratio ½
/// 6.27 / 6.85 / 7.22 / 7.21 (docs/reuse.md; measured while the dropped light was lost,
/// before the spread).
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
    // (frame, luminance per sample): each frame's divided once.
    let (mut top, mut next) = (None::<(usize, f64)>, None::<(usize, f64)>);
    for j in (0..frames.len()).filter(|&j| shares[j] > 0.0) {
        let v = per_sample(frames[j]);
        if top.is_none_or(|(_, t)| v > t) {
            next = top;
            top = Some((j, v));
        } else if next.is_none_or(|(_, t)| v > t) {
            next = Some((j, v));
        }
    }
    (top.map(|t| t.0), next.map(|t| t.0))
}

/// Luminance per sample of a (luminance sum, weight) pair; 0 for no weight.
fn per_sample((l, w): (f64, f64)) -> f64 {
    if w > 0.0 { l / w } else { 0.0 }
}

/// Drops (share 0), one at a time and largest first, the reused frames that
/// [`HELD_OUTLIER_RATIO`] calls outliers at one pixel. `frames[j]` is frame j's resampled
/// luminance sum there and its weight (samples), `shares[j]` the share of it kept so far,
/// `fresh` the fresh samples' luminance sum and count, `floor` the least mean (luminance per
/// sample) an excess is measured against. A frame is not dropped where it is all the pixel
/// holds. Returns whether any frame was dropped.
fn drop_held_outliers(
    frames: &[(f64, f64)],
    shares: &mut [f64],
    fresh: (f64, f64),
    floor: f64,
) -> bool {
    let mut dropped = false;
    loop {
        let (mut sum, mut n) = fresh;
        for (&(l, w), &k) in frames.iter().zip(shares.iter()) {
            sum += k * l;
            n += k * w;
        }
        if n <= 0.0 {
            return dropped;
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
        // A frame that is all the pixel holds (no fresh sample: a checkerboard base pass,
        // [`BasePass::Checker`]) stays: dropped, it would leave the pixel empty.
        let alone = |j: usize| shares[j] * frames[j].1 >= n;
        match worst {
            Some((j, r)) if r > HELD_OUTLIER_RATIO && !alone(j) => {
                shares[j] = 0.0;
                dropped = true;
            }
            _ => return dropped,
        }
    }
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
/// variance of their difference, with a count of 1, as one summed-area table of the four
/// planes (Crow 1984), so that each is summed over any pixel's (2r + 1)² neighbourhood in four
/// lookups. Every pixel weighs the same on both sides, so the two pooled means estimate the
/// same average whatever the sample counts (weighting by samples would compare the history's
/// adaptively sampled pixels against the fresh pass's uniform ones).
struct Pooled(SummedArea<4>);

impl Pooled {
    fn new(fresh: &[Moments], reused: &[Moments], w: usize, h: usize) -> Pooled {
        Pooled(SummedArea::new(w, h, |i| {
            let (f, h) = (&fresh[i], &reused[i]);
            let dof = f.dof + h.dof;
            if f.n <= 0.0 || h.n <= 0.0 || dof <= 0.0 {
                return [0.0; 4];
            }
            let s2 = (f.within + h.within) / dof;
            [f.sum / f.n, h.sum / h.n, s2 * (1.0 / f.n + 1.0 / h.n), 1.0]
        }))
    }

    /// The share of the reprojected frame kept at pixel `xy`, and the disagreement bound (Y),
    /// pooled over its (2r + 1)² neighbourhood.
    fn verdict(&self, xy: (usize, usize), r: usize) -> (f64, f32) {
        let [fresh, reused, var, n] = self.0.sums(xy, r);
        if n <= 0.0 {
            return (1.0, 0.0);
        }
        let diff = (fresh - reused).abs() / n;
        let se = var.max(0.0).sqrt() / n;
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

/// N planes of per-pixel values as one summed-area table (Crow 1984), so that each is summed
/// over any pixel's (2r + 1)² neighbourhood, clipped to the image, in four lookups.
struct SummedArea<const N: usize> {
    /// (w + 1) × (h + 1) rows of sums, row-major.
    sat: Vec<[f64; N]>,
    w: usize,
    h: usize,
}

impl<const N: usize> SummedArea<N> {
    /// The table of `term(i)` for the w × h pixels i (row-major).
    fn new(w: usize, h: usize, term: impl Fn(usize) -> [f64; N]) -> SummedArea<N> {
        let mut sat = vec![[0f64; N]; (w + 1) * (h + 1)];
        for y in 0..h {
            let mut row = [0f64; N];
            for x in 0..w {
                let t = term(y * w + x);
                let above = sat[y * (w + 1) + x + 1];
                let cell = &mut sat[(y + 1) * (w + 1) + x + 1];
                for k in 0..N {
                    row[k] += t[k];
                    cell[k] = above[k] + row[k];
                }
            }
        }
        SummedArea { sat, w, h }
    }

    /// The N sums over pixel `(x, y)`'s (2r + 1)² neighbourhood clipped to the image.
    fn sums(&self, (x, y): (usize, usize), r: usize) -> [f64; N] {
        let (w, h) = (self.w, self.h);
        let (x0, y0) = (x.saturating_sub(r), y.saturating_sub(r));
        let (x1, y1) = ((x + r + 1).min(w), (y + r + 1).min(h));
        let at = |x: usize, y: usize| self.sat[y * (w + 1) + x];
        let (a, b, c, d) = (at(x1, y1), at(x0, y1), at(x1, y0), at(x0, y0));
        std::array::from_fn(|k| a[k] - b[k] - c[k] + d[k])
    }
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

/// Frame `f`'s samples carried into the frame whose G-buffer is `g`: per pixel of that frame,
/// the sums of the samples that land in it and still see there the surface they saw
/// ([`Landing::land`]), each weighted by its direct-light share and the area it stands for;
/// those of `f`'s base pass, and all of them ([`Reused`]).
fn splat_frame(
    scene: &Scene,
    (g, view): (&GBuffer, &View),
    f: &FrameSamples,
    (shutter, angles, tris): (&Shutter, &[f32], &[Tri]),
) -> (FinishedFrame, FinishedFrame, Vec<f32>) {
    let then = scene.camera_at(f.view.time);
    let cos_normal = NORMAL_TOLERANCE_DEG.to_radians().cos();
    let (covered, parallax) = covered_by(scene, g, f, (&then, shutter.centre()), cos_normal);
    let landing = Landing {
        scene,
        g: view,
        f,
        then: &then,
        shutter,
        cos_normal,
        angles,
        tris,
        covered: &covered,
    };
    // Landed and summed in the samples' order, the window's frames in parallel (one task each:
    // no buffer of landings, and the same bytes for any thread count).
    let mut all = vec![Splat::default(); g.width * g.height];
    let mut base = all.clone();
    for k in 0..f.start.len() - 1 {
        let range = f.start[k] as usize..f.start[k + 1] as usize;
        // A source pixel's footprint is shared by its samples: all, or those of its base pass.
        let held = f.base_count(k);
        let (n_all, n_base) = (range.len() as f32, held as f32);
        for (j, n) in range.enumerate() {
            let s = &f.samples[n];
            if let Some(l) = landing.land(k, n, s) {
                let w = l.share * l.area;
                all[l.pixel as usize].add(s.rgb, j % 2 == 0, w / n_all);
                if j < held as usize {
                    base[l.pixel as usize].add(s.rgb, j % 2 == 0, w / n_base);
                }
            }
        }
    }
    (finish(&base), finish(&all), parallax)
}

/// A window frame's parts and their luminance sums and weights ([`finish`]).
type FinishedFrame = (Vec<Part>, Vec<(f64, f64)>);

/// Where a sample lands ([`Landing::land`]): the pixel, the share kept (direct light) and the
/// area it stands for in pixels of the frame it lands in (its source pixel's footprint there,
/// to be shared by that pixel's samples).
#[derive(Clone, Copy, Debug)]
struct Landed {
    pixel: u32,
    share: f32,
    area: f32,
}

impl Landed {
    fn at(pixel: usize, share: f32, area: f32) -> Landed {
        Landed {
            pixel: pixel as u32,
            share,
            area: area.clamp(1.0 / MAX_AREA_RATIO, MAX_AREA_RATIO),
        }
    }
}

/// Largest ratio, either way, of the surface area a reused sample stands for to the area the
/// pixel it lands in covers (see the module docs); beyond it the weight is clamped, so that a
/// surface seen edge-on in an earlier frame (few samples, each for a large area) does not let
/// one sample outweigh the rest.
pub const MAX_AREA_RATIO: f32 = 8.0;

/// Least |cos| between a surface's normal and the view taken in a footprint's area.
const MIN_COSINE: f32 = 1e-3;

/// A rest-space normal `n` under transform `m`: by the inverse transpose (scaled objects),
/// unit.
fn normal_to_world(m: &glam::Affine3A, n: Vec3) -> Vec3 {
    m.matrix3
        .inverse()
        .transpose()
        .mul_vec3(n)
        .normalize_or_zero()
}

/// The unit geometric normal (from the winding) of triangle `tri` in its object's rest space.
fn triangle_normal(geo: &crate::geometry::Geometry, tri: u32) -> Vec3 {
    let [v0, v1, v2] = geo.tris.positions(tri as usize);
    (v1 - v0).cross(v2 - v0).normalize_or_zero()
}

/// Per pixel of `g`: whether frame `f` saw the whole of the pixel's footprint as it looks now,
/// so that the samples of `f` landing in it are spread over all of it. A pixel part of which
/// `f` did not see (a disocclusion's border: its samples would all come from the part seen,
/// whose radiance may differ, as a box's front face from its top), or saw from too far round
/// (a glossy door frame beside a dark wall, whose samples alone would be kept: the holodeck's
/// door frame showed a row of dark pixels), takes none of them. Taken as: the surface points
/// at the centres of the pixel and its 4-neighbours (inside the image), carried to `f`'s
/// instant, were each seen by `f` ([`seen_by`]; [`covered`]). `cams` are the cameras at `f`'s
/// instant and at `g`'s. Also returns the pixels' parallax since `f` at steps in depth
/// ([`steps::parallax`]).
fn covered_by(
    scene: &Scene,
    g: &GBuffer,
    f: &FrameSamples,
    cams: (&Camera, &Camera),
    cos_normal: f32,
) -> (Vec<bool>, Vec<f32>) {
    let (w, h) = (g.width, g.height);
    let (seen, moved): (Vec<bool>, Vec<Option<Vec2>>) = (0..w * h)
        .into_par_iter()
        .map(|i| seen_by(scene, g, i, f, cams, cos_normal))
        .unzip();
    let parallax = steps::parallax((w, h), |i| g.front[i].1, &moved);
    (covered(&seen, (w, h)), parallax)
}

/// Per pixel of a `w` × `h` frame, row-major: whether its centre and its 4-neighbours' (those
/// inside the frame) are `seen`. The pixel's square reaches half a pixel from its centre, so
/// the 4-neighbours' centres bound its sides; the diagonal neighbours' add only its corners.
/// Asking them too (the 3 × 3 centres, until 2026-11-27) rejected 6 % of the Lost Empire
/// walkthrough's pixels from a window frame on top of the 3.4 % whose own centre was not
/// seen; without them the FLIP mean of the walkthrough, the holodeck pan and the
/// moving-sphere box was lower at 1, 2 and 4 fresh spp, and their relative MSE too but for
/// the box's at 2 (+0.15 %; docs/reuse.md, "Where a window's samples go").
fn covered(seen: &[bool], size: (usize, usize)) -> Vec<bool> {
    (0..size.0 * size.1)
        .into_par_iter()
        .map(|i| {
            seen[i]
                && four_neighbours(i, size)
                    .into_iter()
                    .flatten()
                    .all(|n| seen[n])
        })
        .collect()
}

/// Whether frame `f` saw the surface point at the centre of `g`'s pixel `i` as it looks now:
/// the view of it turned by no more than its material allows, and carried to `f`'s instant it
/// projects into a pixel of `f` that, or one of whose 4-neighbours, saw the same object and
/// material there (within [`PLANE_TOLERANCE`] · depth of its tangent plane, normals within
/// [`NORMAL_TOLERANCE_DEG`]); the background where `f` saw the background. Also returns the
/// point's displacement from the pixel's centre to where it projects in `f` (raster px), where
/// it projects.
fn seen_by(
    scene: &Scene,
    g: &GBuffer,
    i: usize,
    f: &FrameSamples,
    (then, here): (&Camera, &Camera),
    cos_normal: f32,
) -> (bool, Option<Vec2>) {
    let o = &f.view;
    let Some(sight) = g.sight_by(scene, i, o.time, (then, here)) else {
        return (false, None);
    };
    let r = sight.raster;
    let centre = Vec2::new((i % g.width) as f32 + 0.5, (i / g.width) as f32 + 0.5);
    let moved = Some(r - centre);
    // A view-dependent surface seen from too far round is not reusable (see `land`).
    if sight.turn > g.reuse_angle[i] {
        return (false, moved);
    }
    if !(r.x >= 0.0 && r.y >= 0.0 && r.x < o.width as f32 && r.y < o.height as f32) {
        return (false, moved);
    }
    // In range, the truncation is the floor.
    let (kx, ky) = (r.x as usize, r.y as usize);
    let k = ky * o.width + kx;
    let around = [
        Some(k),
        (kx > 0).then(|| k - 1),
        (kx + 1 < o.width).then(|| k + 1),
        (ky > 0).then(|| k - o.width),
        (ky + 1 < o.height).then(|| k + o.width),
    ];
    let seen = around.into_iter().flatten().any(|c| {
        let c = &o.px[c];
        if c.object != g.object[i] || c.material != g.material[i] {
            return false;
        }
        if g.is_background(i) {
            return true;
        }
        (c.position - sight.point).dot(sight.normal).abs() <= PLANE_TOLERANCE * c.depth
            && c.normal.dot(sight.normal) >= cos_normal
    });
    (seen, moved)
}

/// What a sample of frame `f` needs to land in the frame whose G-buffer is `g`.
struct Landing<'a> {
    scene: &'a Scene,
    /// The view of the frame samples land in.
    g: &'a View,
    f: &'a FrameSamples,
    /// The camera at `f`'s instant, and over the shutter of `g`'s frame.
    then: &'a Camera,
    shutter: &'a Shutter,
    cos_normal: f32,
    /// Per material: how far the view may turn ([`reuse_angle`]).
    angles: &'a [f32],
    /// The scene's triangles ([`Tri`]).
    tris: &'a [Tri],
    /// Per pixel of `g`: whether `f` saw all of it ([`covered_by`]).
    covered: &'a [bool],
}

/// Cameras over the shutter of the frame samples land in, a sample taken `dt` after its own
/// frame's instant projecting as the camera was `dt` after this frame's ([`Sample::dt`]).
pub struct Shutter {
    /// The frame's instant, s.
    time: f32,
    /// The projections ([`Camera::projection`]) of the cameras at `time + first + k · step`,
    /// k = 0 ..= [`SHUTTER_CAMERAS`] (one, at `time`, without motion blur).
    proj: Vec<Projection>,
    /// The middle one of those cameras, at the frame's instant.
    centre: Camera,
    first: f32,
    step: f32,
}

/// Intervals the shutter is cut into for [`Shutter`]: a sample projects by the two cameras
/// about its time, its raster position interpolated between them (the camera's motion within
/// 1/16 of a shutter taken as straight).
pub const SHUTTER_CAMERAS: usize = 16;

impl Shutter {
    /// The cameras over the shutter of `scene`'s current frame.
    pub fn of(scene: &Scene) -> Shutter {
        let fr = &scene.frame;
        let time = fr.time_s as f32;
        let (mut cams, first, step) = if !fr.has_motion_blur() || scene.camera_track.is_none() {
            (vec![scene.camera_at(time).into_owned()], 0.0, 1.0)
        } else {
            let first = (fr.open_s - fr.time_s) as f32;
            let step = ((fr.close_s - fr.open_s) / SHUTTER_CAMERAS as f64) as f32;
            let cams = (0..=SHUTTER_CAMERAS)
                .map(|k| scene.camera_at(time + first + k as f32 * step).into_owned())
                .collect();
            (cams, first, step)
        };
        let proj = cams.iter().map(Camera::projection).collect();
        let centre = cams.swap_remove(cams.len() / 2);
        Shutter {
            time,
            proj,
            centre,
            first,
            step,
        }
    }

    /// The camera at the frame's instant.
    fn centre(&self) -> &Camera {
        &self.centre
    }

    /// The cameras about `dt` after the frame's instant and the weight of the second.
    fn about(&self, dt: f32) -> About<'_> {
        if self.proj.len() == 1 {
            return About {
                a: &self.proj[0],
                b: &self.proj[0],
                w: 0.0,
            };
        }
        let x = ((dt - self.first) / self.step).clamp(0.0, SHUTTER_CAMERAS as f32);
        // x ≥ 0 (or NaN, which both give as 0): the truncation is the floor.
        let k = (x as usize).min(SHUTTER_CAMERAS - 1);
        About {
            a: &self.proj[k],
            b: &self.proj[k + 1],
            w: x - k as f32,
        }
    }
}

/// The projections of the two cameras of a [`Shutter`] about one instant, and the weight of
/// the second.
struct About<'a> {
    a: &'a Projection,
    b: &'a Projection,
    w: f32,
}

impl About<'_> {
    /// The camera's position.
    fn position(&self) -> Vec3 {
        self.a.position().lerp(self.b.position(), self.w)
    }

    /// Raster position of world point `p` (or, with `direction`, of the direction `p`);
    /// `None` behind the camera.
    #[inline]
    fn raster(&self, p: Vec3, direction: bool) -> Option<Vec2> {
        let project = |c: &Projection| {
            if direction {
                c.raster_of_direction(p)
            } else {
                c.raster(p)
            }
        };
        if self.w == 0.0 {
            return project(self.a);
        }
        let (a, b) = (project(self.a)?, project(self.b)?);
        Some(a + (b - a) * self.w)
    }
}

impl Landing<'_> {
    /// The pixel of `g` where sample `s` of `f`'s pixel `k` lands and the share of it kept
    /// there; `None` where it is not reused. A sample lands where its surface point, carried
    /// with its object to `g`'s instant, projects; it is reused when
    /// - the view of the point turned by no more than its material allows
    ///   ([`crate::gbuffer::GBuffer::reuse_angle`]: glossy lobes, mirrors and glass are
    ///   view-dependent);
    /// - the pixel's centre, or for a pixel that straddles an edge one of its 4-neighbours'
    ///   centres, sees the same object and material, within [`PLANE_TOLERANCE`] · depth of its
    ///   tangent plane and with a normal within [`NORMAL_TOLERANCE_DEG`] of the sample's
    ///   triangle's (so a point now hidden behind another surface is not reused);
    /// - in a scene where anything but the camera moves, its direct light there
    ///   ([`crate::gbuffer::GBuffer::direct`]) is within [`DIRECT_TOLERANCE`] of what it was
    ///   at `k` (the share falls linearly with the change; nothing where `k`'s centre saw
    ///   another surface than the sample, whose direct light is then unknown).
    ///
    /// A miss lands where its direction projects and is reused where the background is seen.
    fn land(&self, k: usize, n: usize, s: &Sample) -> Option<Landed> {
        let (g, geo) = (self.g, &self.scene.geometry);
        let t = self.shutter.time + s.dt;
        if s.tri == u32::MAX {
            let cams = self.shutter.about(s.dt);
            let i = self.pixel(cams.raster(s.at, true)?)?;
            if !self.covered[i] {
                return None;
            }
            let eye = cams.position();
            let shown = g.px[i].is_background() && g.px[i].flags & STEP == 0;
            if !(shown || geo.unoccluded(eye, s.at, f32::INFINITY, t)) {
                return None;
            }
            let area = self.f.area[n] / self.here().pixel_solid_angle(s.at);
            return Some(Landed::at(i, 1.0, area));
        }
        let tri = &self.tris[s.tri as usize];
        let now = geo.instance_transform(tri.instance, t);
        let p = now.map_or(s.at, |m| m.transform_point3(s.at));
        let cams = self.shutter.about(s.dt);
        let i = self.pixel(cams.raster(p, false)?)?;
        if !self.covered[i] {
            return None;
        }
        let material = tri.material;
        let normal = now.map_or(tri.normal, |m| normal_to_world(&m, tri.normal));
        let eye = cams.position();
        let view = eye - p;
        let cos_now = normal.dot(view.normalize_or_zero());
        // The side seen then is the side seen now (a thin wall's other side is another surface).
        let area_then = self.f.area[n];
        if cos_now * area_then <= 0.0 {
            return None;
        }
        let angle = self.angles[material as usize];
        if angle < f32::INFINITY {
            let before = geo.instance_transform(tri.instance, self.f.view.time);
            let view_then = self.then.position - before.map_or(s.at, |m| m.transform_point3(s.at));
            // atan2 of the cross and dot products: exact 0 for equal directions.
            if view.cross(view_then).length().atan2(view.dot(view_then)) > angle {
                return None;
            }
        }
        // The point at the frame's instant, when the G-buffer saw its surface.
        let p_inst = match now {
            Some(_) if s.dt != 0.0 => geo
                .instance_transform(tri.instance, g.time)
                .map_or(p, |m| m.transform_point3(s.at)),
            _ => p,
        };
        let object = object_index(tri.instance);
        let sees = |c: usize| {
            let c = &g.px[c];
            c.object == object
                && c.material == material
                && (p_inst - c.position).dot(c.normal).abs() <= PLANE_TOLERANCE * c.depth
                && normal.dot(c.normal) >= self.cos_normal
        };
        // Where no step in depth is near, the sample is shown if it lies on the surface a
        // centre there sees (one of several meeting in a plane at a change of material);
        // beside a step, if it lies on the nearest surface there. Else (a surface behind, or
        // one no centre sees) a ray from the point to the camera tells.
        let px = &g.px[i];
        let shown = if px.flags & STEP != 0 {
            sees(px.front as usize)
        } else {
            sees(i) || px.flags & EDGE != 0 && self.neighbours(i).into_iter().flatten().any(sees)
        };
        if !shown {
            let o = crate::geometry::offset_origin(p, normal, view);
            let (d, dist) = ((eye - o).normalize_or_zero(), (eye - o).length());
            if !geo.unoccluded(o, d, dist, t) {
                return None;
            }
        }
        let share = self.direct_share(k, i, (material, object), &sees);
        // The surface area the sample stands for (its source pixel's footprint, shared by that
        // pixel's samples) over the area a pixel covers there now.
        let here = self.here().pixel_solid_angle(-view) * view.length_squared()
            / cos_now.abs().max(MIN_COSINE);
        let area = area_then.abs() / here;
        (share > 0.0).then(|| Landed::at(i, share, area))
    }

    /// The camera at the frame's instant.
    fn here(&self) -> &Camera {
        self.shutter.centre()
    }

    /// The share of a sample of `f`'s pixel `k` on a surface of `(material, object)` kept
    /// where it lands, at `g`'s pixel `i`, for the change of its direct light (see
    /// [`Landing::land`]); `sees(c)`: whether `g`'s pixel `c` sees the sample's surface.
    fn direct_share(
        &self,
        k: usize,
        i: usize,
        (material, object): (u32, u32),
        sees: &dyn Fn(usize) -> bool,
    ) -> f32 {
        let (g, o) = (self.g, &self.f.view);
        if o.direct.is_empty() || g.direct.is_empty() {
            return 1.0;
        }
        // The direct light of the surface the sample lands on, as a centre nearby sees it.
        let now = std::iter::once(Some(i))
            .chain(self.neighbours(i))
            .flatten()
            .find(|&c| sees(c));
        let Some(c) = now else { return 0.0 };
        // Against the same then: its own pixel's centre's, where that saw the sample's
        // surface. At an edge, where it saw the other surface, every 4-neighbour's that saw
        // the sample's must agree, and the two pixels' own centres too (taking only the own
        // centre dropped all samples of the other surface, and darkened the pixels straddling
        // the moving-sphere box's light by 30-50 %).
        let same_then = |t: usize| o.px[t].object == object && o.px[t].material == material;
        if same_then(k) {
            return direct_light_share(g.direct[c], o.direct[k]);
        }
        self.neighbours(k)
            .into_iter()
            .flatten()
            .filter(|&t| same_then(t))
            .map(|t| direct_light_share(g.direct[c], o.direct[t]))
            .reduce(f32::min)
            .map_or(0.0, |s| s.min(direct_light_share(g.direct[i], o.direct[k])))
    }

    /// The pixel of `g` that contains raster position `r`.
    fn pixel(&self, r: Vec2) -> Option<usize> {
        let (w, h) = (self.g.width, self.g.height);
        // In range, the truncation is the floor.
        (r.x >= 0.0 && r.y >= 0.0 && r.x < w as f32 && r.y < h as f32)
            .then(|| r.y as usize * w + r.x as usize)
    }

    /// The 4-neighbours of pixel `i` inside the image.
    fn neighbours(&self, i: usize) -> [Option<usize>; 4] {
        four_neighbours(i, (self.g.width, self.g.height))
    }
}

/// The 4-neighbours of pixel `i` of a `w` × `h` image, inside it: left, right, above, below.
fn four_neighbours(i: usize, (w, h): (usize, usize)) -> [Option<usize>; 4] {
    let (x, y) = (i % w, i / w);
    [
        (x > 0).then(|| i - 1),
        (x + 1 < w).then(|| i + 1),
        (y > 0).then(|| i - w),
        (y + 1 < h).then(|| i + w),
    ]
}

/// The share of a sample's weight kept when the direct-light signatures
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_k_frames_take_k_budgets_and_the_rest_one_each() {
        for k in [0u32, 1, 2, 3, 7, 15, MAX_WINDOW] {
            for budget in [1.0, 2.0, 16.0] {
                let at = |f: i64| start_up_budget(budget, window_frames(f, 0, k), k);
                let first_k: f64 = (0..i64::from(k.max(1))).map(at).sum();
                let want = budget * f64::from(k.max(1));
                assert!((first_k - want).abs() < 1e-9 * want, "K = {k}: {first_k}");
                assert!((i64::from(k)..i64::from(k) + 40).all(|f| at(f) == budget));
                assert!((0..80).all(|f| at(f) > 0.0));
            }
        }
        // Under K = 15 the first frame takes 3.8 budgets, the 14 after it 0.8.
        assert!((start_up_budget(2.0, 0, 15) - 7.6).abs() < 1e-12);
        assert!((start_up_budget(2.0, 14, 15) - 1.6).abs() < 1e-12);
    }

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
    fn a_frame_that_is_all_a_pixel_holds_stays() {
        // No fresh sample (a checkerboard base pass) and one reused frame 100 times the
        // floor: dropped, it would leave the pixel empty.
        let mut shares = [1.0];
        assert!(!drop_held_outliers(
            &[(100.0, 1.0)],
            &mut shares,
            (0.0, 0.0),
            1.0
        ));
        assert_eq!(shares, [1.0]);
        // Beside a second frame, the same frame is a held firefly.
        let mut shares = [1.0, 1.0];
        let frames = [(100.0, 1.0), (1.0, 1.0)];
        assert!(drop_held_outliers(&frames, &mut shares, (0.0, 0.0), 1.0));
        assert_eq!(shares, [0.0, 1.0]);
    }

    #[test]
    fn a_pixel_is_covered_where_its_centre_and_its_4_neighbours_were_seen() {
        // 5 × 4 pixels; one centre not seen at (2, 1).
        let (w, h) = (5, 4);
        let mut seen = vec![true; w * h];
        seen[w + 2] = false;
        let c = covered(&seen, (w, h));
        for y in 0..h {
            for x in 0..w {
                // The unseen pixel and its 4-neighbours are not covered; its diagonal
                // neighbours are (it is not one of their 4-neighbours).
                let near = x.abs_diff(2) + y.abs_diff(1) <= 1;
                assert_eq!(c[y * w + x], !near, "pixel ({x}, {y})");
            }
        }
        // At the frame's border only the neighbours inside it are asked.
        assert!(covered(&[true; 3], (3, 1)).iter().all(|&c| c));
        assert_eq!(covered(&[false, true, true], (3, 1)), [false, false, true]);
    }

    #[test]
    fn a_checkerboard_base_pass_takes_consecutive_points_every_other_frame() {
        let k = CHECKER_MIN_WINDOW;
        assert_eq!(BasePass::of(Some(1.0), false, k), BasePass::Checker);
        assert_eq!(BasePass::of(Some(1.5), false, 15), BasePass::Checker);
        assert_eq!(BasePass::of(Some(1.0), false, k - 1), BasePass::Every(1));
        assert_eq!(BasePass::of(Some(1.0), true, k), BasePass::Every(1));
        assert_eq!(BasePass::of(Some(2.0), false, k), BasePass::Every(1));
        assert_eq!(BasePass::of(Some(9.0), false, k), BasePass::Every(4));
        assert_eq!(
            BasePass::of(None, true, k),
            BasePass::Every(BASE_SPP_UNBUDGETED)
        );
        let (w, h) = (5, 4);
        let b = BasePass::Checker;
        let mut taken = vec![Vec::new(); w * h];
        for f in -3..13i64 {
            let counts = b.counts(f, (w, h));
            assert_eq!(counts.iter().sum::<u32>(), 10, "half of 5 × 4, frame {f}");
            // Even offsets: every base sample goes to half-buffer A's stream, as at 1 spp.
            assert_eq!(b.offset(f) % 2, 0);
            for (i, &c) in counts.iter().enumerate() {
                let neighbour = if i % w + 1 < w { counts[i + 1] } else { 1 - c };
                assert_eq!(c + neighbour, 1, "a checkerboard, frame {f}");
                if c == 1 {
                    // The stream's point index, as the Sobol' sampler takes it (32 bits:
                    // negative frames wrap).
                    taken[i].push((b.offset(f) >> 1) as u32);
                }
            }
        }
        // Each pixel takes a sample every other frame, at consecutive points of its stream
        // (the frame's own index would give it every other point).
        for t in &taken {
            assert_eq!(t.len(), 8);
            assert!(t.windows(2).all(|p| p[1] == p[0].wrapping_add(1)), "{t:?}");
        }
        // Every(n): frame f's run follows frame f − 1's in each stream.
        assert_eq!(BasePass::Every(3).offset(5), 20);
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

    /// A 40 × 30 grey wall: 7 window frames of 4 samples a pixel and 4 fresh ones, mostly
    /// exponential with mean 1, and one sample in 100 a caustic path of 60; every frame kept
    /// by the test. Returns the film with the history `keep` made and the sum over pixels of
    /// the mean with every reused frame.
    fn wall_with_caustic_paths() -> (Film, Vec<f64>) {
        let (w, h) = (40, 30);
        let mut rng = crate::rng::Rng::new(11, 5);
        let mut sample = || {
            let u = rng.uniform() as f64;
            let y = if u < 0.01 {
                60.0
            } else {
                -(1.0 - rng.uniform() as f64).ln()
            };
            Vec3::splat(y as f32)
        };
        let frames: Vec<Vec<Splat>> = (0..7)
            .map(|_| {
                (0..w * h)
                    .map(|_| {
                        let mut p = Splat::default();
                        (0..4).for_each(|k| p.add(sample(), k % 2 == 0, 1.0));
                        p
                    })
                    .collect()
            })
            .collect();
        let layer = Layer::new(frames.iter().map(|f| finish(f)).collect());
        let mut film = Film::new(w as u32, h as u32);
        for p in &mut film.pixels {
            (0..4).for_each(|_| p.add(sample()));
        }
        let every = [1.0; 7];
        let all = (0..w * h)
            .map(|i| {
                luminance(
                    weighted_sum(&layer, &every, i)
                        .sample_means(&film.pixels[i])
                        .2,
                )
            })
            .collect();
        let y: Vec<Moments> = film
            .pixels
            .iter()
            .map(|p| Moments::of(luminance(p.sum()), p.count() as f64, p.sum_lum2.value()))
            .collect();
        let shares = vec![vec![1.0; w * h]; 7];
        let surfaces = spread::Surfaces::wall(w, h);
        film.history = Some(keep(&layer, &shares, &film, &y, &surfaces));
        (film, all)
    }

    #[test]
    fn held_fireflies_are_dropped_where_they_landed_and_their_light_kept() {
        let (film, all) = wall_with_caustic_paths();
        let kept: Vec<f64> = (0..film.len())
            .map(|i| luminance(film.means(i).2))
            .collect();
        // Frames were dropped at some pixels, and the wall is smoother for it...
        let dropped = (0..film.len())
            .filter(|&i| film.history_weight(i) < 27.9)
            .count();
        assert!(dropped > 50, "{dropped} pixels dropped a frame");
        let spread = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
        };
        let (sd, sd_all) = (spread(&kept), spread(&all));
        assert!(sd < 0.85 * sd_all, "sd over the wall {sd} against {sd_all}");
        // ...and the image holds the same light, to f32 rounding (luminance is taken in
        // f32); without the spread it lost a fifth.
        let (sum, sum_all) = (kept.iter().sum::<f64>(), all.iter().sum::<f64>());
        assert!(
            (sum / sum_all - 1.0).abs() < 1e-6,
            "{sum} against {sum_all}"
        );
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
