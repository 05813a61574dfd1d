//! The render driver: runs the integrator over the film in parallel, deterministically.

use crate::film::{Film, HalfSplit, PixelStats};
use crate::integrator::{Integrator, Strategy};
use crate::reuse::Sample;
use crate::rng::Rng;
use crate::sampler::cmj::{CmjSampler, CmjTable};
use crate::sampler::{SampleStreams, Sampler, SobolSampler};
use crate::scene::SampleGenerator;
use crate::scene::Scene;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Counters of one or more render passes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Camera samples taken.
    pub samples: u64,
    /// Rays traced (closest-hit and shadow).
    pub rays: u64,
    /// Samples whose radiance was NaN or infinite: they are counted here and contribute zero
    /// (the sample index is consumed so every pixel's stream stays aligned).
    pub nonfinite: u64,
    /// Wall-clock time.
    pub wall: Duration,
}

impl std::ops::AddAssign for RenderStats {
    fn add_assign(&mut self, o: RenderStats) {
        self.samples += o.samples;
        self.rays += o.rays;
        self.nonfinite += o.nonfinite;
        self.wall += o.wall;
    }
}

/// Takes the next `count` samples (film indices `n .. n + count`, drawn as samples
/// `pass.offset + n ..` of the pixel's sequences) of pixel (x, y); with `record`, each sample
/// is also appended to it ([`crate::reuse::Sample`]). Adds the rays traced and the
/// non-finite samples to `tally`.
#[inline]
fn sample_pixel(
    scene: &Scene,
    integrator: &Integrator,
    pass: &Pass,
    (x, y): (u32, u32),
    (px, count): (&mut PixelStats, u32),
    tally: &mut (u64, u64),
    mut record: Option<&mut Vec<Sample>>,
) {
    let (seed, streams) = (pass.seed, pass.streams);
    let index = y as u64 * scene.camera.width as u64 + x as u64;
    let table = match (scene.settings.sample_generator, streams) {
        (SampleGenerator::Sobol, SampleStreams::Fixed(total)) if count > 0 => {
            Some(CmjTable::new(seed, index, total))
        }
        _ => None,
    };
    for _ in 0..count {
        let n = pass.offset.wrapping_add(px.n as u64);
        let time = scene.sample_time(seed, index, n);
        let r = match scene.settings.sample_generator {
            SampleGenerator::Sobol => match (&table, streams) {
                (Some(t), _) => {
                    let rng = CmjSampler::for_sample(t, n);
                    trace(scene, integrator, seed, (x, y), n, time, rng)
                }
                (None, SampleStreams::Halves) => {
                    let rng = SobolSampler::for_sample(seed, index, n);
                    trace(scene, integrator, seed, (x, y), n, time, rng)
                }
                (None, _) => {
                    let rng = SobolSampler::for_sample_whole(seed, index, n);
                    trace(scene, integrator, seed, (x, y), n, time, rng)
                }
            },
            SampleGenerator::Independent => {
                let rng = Rng::for_sample(seed, index, n);
                trace(scene, integrator, seed, (x, y), n, time, rng)
            }
        };
        tally.0 += r.rays as u64;
        let v = if r.radiance.is_finite() {
            r.radiance
        } else {
            tally.1 += 1;
            glam::Vec3::ZERO
        };
        if streams == SampleStreams::Blocks {
            px.add_block(v);
        } else {
            px.add(v);
        }
        if let Some(rec) = record.as_deref_mut() {
            rec.push(Sample::new(scene, r.first, time, v));
        }
    }
}

/// One camera sample: its ray through the pixel (sub-pixel offset from the sample's first two
/// dimensions) and the path traced from it.
#[inline]
fn trace(
    scene: &Scene,
    integrator: &Integrator,
    seed: u64,
    pixel: (u32, u32),
    n: u64,
    time: f32,
    mut rng: impl Sampler,
) -> crate::integrator::PathResult {
    let ray = scene.camera_ray(seed, pixel, n, rng.uniform2(), time);
    integrator.radiance(scene, ray, &mut rng)
}

/// Adds `counts[i]` samples to pixel i of `film` (row-major), drawn as `streams` says, in
/// parallel over rows; the film's half-buffers take the layout of `streams`
/// ([`SampleStreams::split`]). The result
/// is bit-identical for any thread count. `progress` is called (from worker threads) with 0
/// when a row starts and with the number of samples the row took when it ends; a caller that
/// must stop the render may unwind from it (`std::panic::resume_unwind`, as the Python
/// bindings do on Ctrl-C): rows not yet started then start no work.
///
/// # Panics
/// If `counts.len()` differs from the film's pixel count, the film's size differs from the
/// camera's, or the film holds samples of another half-buffer layout.
pub fn render_counts(
    scene: &Scene,
    integrator: &Integrator,
    film: &mut Film,
    counts: &[u32],
    streams: SampleStreams,
    progress: &(dyn Fn(u64) + Sync),
) -> RenderStats {
    render_counts_seeded(
        scene,
        integrator,
        film,
        counts,
        scene.frame_seed(),
        streams,
        progress,
    )
}

/// As [`render_counts`] with an explicit seed (auxiliary renders such as the adaptive sampler's
/// guide use a seed of their own so that their samples are independent of the image's).
pub fn render_counts_seeded(
    scene: &Scene,
    integrator: &Integrator,
    film: &mut Film,
    counts: &[u32],
    seed: u64,
    streams: SampleStreams,
    progress: &(dyn Fn(u64) + Sync),
) -> RenderStats {
    let pass = Pass {
        counts,
        seed,
        streams,
        offset: 0,
    };
    render_rows(scene, integrator, film, &pass, false, progress).0
}

/// As [`render_counts_seeded`], the film's sample n drawn as sample `offset + n` of the
/// pixel's sequences, and every sample taken returned too, grouped by pixel (row-major) and in
/// the order taken: what a frame keeps for the frames after it to reuse
/// ([`crate::reuse::FrameSamples`], whose frames draw consecutive runs of one sequence per
/// pixel, [`crate::reuse::base_offset`]).
pub fn render_counts_recorded(
    scene: &Scene,
    integrator: &Integrator,
    film: &mut Film,
    pass: &Pass,
    progress: &(dyn Fn(u64) + Sync),
) -> (RenderStats, Vec<Sample>) {
    render_rows(scene, integrator, film, pass, true, progress)
}

/// The samples of one pass: how many per pixel (row-major), the seed, how they are drawn and
/// the index in the pixel's sequences of the film's sample 0.
#[derive(Clone, Copy, Debug)]
pub struct Pass<'a> {
    /// Samples per pixel, row-major.
    pub counts: &'a [u32],
    /// The seed of the sequences.
    pub seed: u64,
    /// How the half-buffers' samples are drawn.
    pub streams: SampleStreams,
    /// The sequences' index of the film's sample 0 (even: the half-buffers keep their streams).
    pub offset: u64,
}

/// The rows of `film` in parallel (see [`render_counts`]); with `record`, every sample is
/// returned too, grouped by pixel.
fn render_rows(
    scene: &Scene,
    integrator: &Integrator,
    film: &mut Film,
    pass: &Pass,
    record: bool,
    progress: &(dyn Fn(u64) + Sync),
) -> (RenderStats, Vec<Sample>) {
    let counts = pass.counts;
    assert_eq!(counts.len(), film.len());
    assert_eq!(
        (film.width, film.height),
        (scene.camera.width, scene.camera.height)
    );
    let split = pass.streams.split();
    if film.split != split {
        assert!(
            film.pixels.iter().all(|p| p.count() == 0),
            "a film's half-buffers keep one layout: {:?} samples added to a {:?} film",
            pass.streams,
            film.split
        );
        film.split = split;
    }
    assert!(split == HalfSplit::Interleaved || pass.offset == 0);
    let start = Instant::now();
    let rays = AtomicU64::new(0);
    let nonfinite = AtomicU64::new(0);
    let w = film.width as usize;
    let rows: Vec<Vec<Sample>> = film
        .pixels
        .par_chunks_mut(w)
        .zip(counts.par_chunks(w))
        .enumerate()
        .map(|(y, (row, row_counts))| {
            progress(0);
            let (mut tally, mut s) = ((0u64, 0u64), 0u64);
            let mut kept = Vec::new();
            if record {
                kept.reserve(row_counts.iter().map(|&c| c as usize).sum());
            }
            for (x, (px, &c)) in row.iter_mut().zip(row_counts).enumerate() {
                let at = (x as u32, y as u32);
                let rec = record.then_some(&mut kept);
                sample_pixel(scene, integrator, pass, at, (px, c), &mut tally, rec);
                s += c as u64;
            }
            rays.fetch_add(tally.0, Ordering::Relaxed);
            nonfinite.fetch_add(tally.1, Ordering::Relaxed);
            progress(s);
            kept
        })
        .collect();
    let stats = RenderStats {
        samples: counts.iter().map(|&c| c as u64).sum(),
        rays: rays.into_inner(),
        nonfinite: nonfinite.into_inner(),
        wall: start.elapsed(),
    };
    (stats, if record { rows.concat() } else { Vec::new() })
}

/// Each pixel's measured cost: the wall time per camera sample, in seconds, of `spp` samples
/// taken in it (rows in parallel, as a render runs; the radiance is discarded), in
/// [`COST_PASSES`] passes over the image so that a stall of the machine lands on different
/// pixels' shares rather than on whole rows. Row-major, one value per pixel. A measurement of
/// this machine, not deterministic: it feeds reports (the wall-time ceiling of
/// `aleph speedup`), never an image.
pub fn pixel_costs(scene: &Scene, strategy: Strategy, spp: u32) -> Vec<f32> {
    let integrator = Integrator {
        max_depth: scene.settings.max_depth,
        strategy,
    };
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let seed = scene.frame_seed();
    let spp = spp.max(1);
    let mut pixels = vec![PixelStats::default(); w * h];
    let mut seconds = vec![0f64; w * h];
    let passes = COST_PASSES.min(spp);
    let pass = Pass {
        counts: &[],
        seed,
        streams: SampleStreams::Halves,
        offset: 0,
    };
    for p in 0..passes {
        let count = spp * (p + 1) / passes - spp * p / passes;
        pixels
            .par_chunks_mut(w)
            .zip(seconds.par_chunks_mut(w))
            .enumerate()
            .for_each(|(y, (row, secs))| {
                let mut tally = (0u64, 0u64);
                for (x, (px, t_px)) in row.iter_mut().zip(secs.iter_mut()).enumerate() {
                    let t = Instant::now();
                    let at = (x as u32, y as u32);
                    sample_pixel(scene, &integrator, &pass, at, (px, count), &mut tally, None);
                    *t_px += t.elapsed().as_secs_f64();
                }
            });
    }
    seconds.iter().map(|&t| (t / spp as f64) as f32).collect()
}

/// Passes over the image of [`pixel_costs`].
pub const COST_PASSES: u32 = 4;

/// Renders `spp` samples in every pixel into a new film (one pass, progress reported per row;
/// a pattern of `spp` points per pixel, [`SampleStreams::Fixed`], as the uniform sampler of a
/// job).
pub fn render_uniform(
    scene: &Scene,
    strategy: Strategy,
    spp: u32,
    progress: &(dyn Fn(u64) + Sync),
) -> (Film, RenderStats) {
    render_uniform_streams(scene, strategy, spp, SampleStreams::Fixed(spp), progress)
}

/// As [`render_uniform`], the samples drawn as `streams` says ([`SampleStreams::Halves`] for a
/// reference whose half-buffers must be independent, e.g. to measure its own noise floor).
pub fn render_uniform_streams(
    scene: &Scene,
    strategy: Strategy,
    spp: u32,
    streams: SampleStreams,
    progress: &(dyn Fn(u64) + Sync),
) -> (Film, RenderStats) {
    let integrator = Integrator {
        max_depth: scene.settings.max_depth,
        strategy,
    };
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    let counts = vec![spp; film.len()];
    let stats = render_counts(scene, &integrator, &mut film, &counts, streams, progress);
    (film, stats)
}

/// Renders the first-hit albedo guide ([`crate::integrator::albedo`]) with `spp` jittered
/// samples per pixel under `seed`; returns interleaved RGB, deterministic for any thread count.
pub fn render_albedo(scene: &Scene, spp: u32, seed: u64) -> Vec<f32> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let mut out = vec![0f32; 3 * w * h];
    out.par_chunks_mut(3 * w).enumerate().for_each(|(y, row)| {
        for x in 0..w {
            let mut acc = glam::Vec3::ZERO;
            for k in 0..spp {
                let index = (y * w + x) as u64;
                let time = scene.sample_time(seed, index, k as u64);
                let mut rng = Rng::for_sample(seed, index, k as u64);
                let ray =
                    scene.camera_ray(seed, (x as u32, y as u32), k as u64, rng.uniform2(), time);
                let a = crate::integrator::albedo(scene, ray, &mut rng);
                if a.is_finite() {
                    acc += a;
                }
            }
            let a = acc / spp.max(1) as f32;
            row[3 * x..3 * x + 3].copy_from_slice(&a.to_array());
        }
    });
    out
}
