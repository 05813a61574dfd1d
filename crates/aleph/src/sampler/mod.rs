//! Samplers, in pbrt-v4's sense: where each camera sample's canonical random numbers in
//! [0, 1) come from. A path asks its [`Sampler`] for dimensions in a fixed order (the
//! integrator's docs give it), and every value depends only on (seed, pixel, sample index), so
//! renders are deterministic for any thread count and any split into passes, parts and tiles.
//!
//! - [`sobol::SobolSampler`]: Owen-scrambled Sobol' points per dimension pair (the default);
//! - [`crate::rng::Rng`]: independent PCG32 numbers (plain Monte Carlo, the baseline).
//!
//! This is not the adaptive decision rule that says where samples go
//! ([`crate::adaptive::Criterion`]), nor next-event estimation's choice of light
//! ([`crate::light::LightSampler`]).

pub mod cmj;
pub mod sobol;

use crate::rng::Rng;
use glam::Vec2;

pub use sobol::SobolSampler;

/// The source of each camera sample's random numbers, as a scene's
/// `[render] sample_generator` names it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SampleGenerator {
    /// Owen-scrambled Sobol' points per dimension pair ([`SobolSampler`]): randomised
    /// quasi-Monte Carlo, lower error per sample.
    #[default]
    Sobol,
    /// Independent PCG32 numbers ([`Rng`]): plain Monte Carlo, whose per-pixel error is σ/√n
    /// (what a z-test on one render assumes).
    Independent,
}

/// How a pixel's samples are drawn from the Sobol' generator (PCG32 numbers are independent
/// per sample either way).
///
/// A render that steers by its error estimate needs half-buffers that are independent
/// estimates; a render that does not (uniform, farm parts of one) gets the lower error of one
/// net. Measured on the Cornell box (256², depth 8, 3 seeds, relMSE against an 8192-spp
/// Mitsuba reference): [`SampleStreams::Halves`] 0.00782 / 0.00158 at 16 / 64 spp,
/// [`SampleStreams::Whole`] 0.00698 / 0.00141 (1.12× lower), PCG32 0.01102 / 0.00278.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SampleStreams {
    /// Even and odd samples (half-buffers A and B of the film) from two independently
    /// scrambled sequences: the half-buffers' difference is an unbiased estimate of the
    /// error of their mean, which the adaptive samplers steer and stop by. Their union is not
    /// a net. The default.
    #[default]
    Halves,
    /// One scrambled sequence per pixel: every power-of-two prefix of a pixel's samples is
    /// one (0, m, 2)-net in each dimension pair. Which sample of each pair (2k, 2k + 1) goes
    /// to half-buffer A is decided by a hash, so each half-buffer is a random half of the net
    /// and their difference is a conservative error estimate (it measures the Monte Carlo
    /// error, not the lower error of the net): for renders that do not steer by it.
    Whole,
    /// One scrambled sequence per pixel, as `Whole`, whose half-buffers are its power-of-two
    /// blocks ([`crate::film::HalfSplit::Blocks`]): with n samples, A holds samples 0..P and B
    /// samples P..n (P the largest power of two below n), so at the stratified totals
    /// (2^k and 3 · 2^(k − 2)) each half is a net and together they are the pixel's whole
    /// sequence. Their difference overstates the error of the mean where the net converges
    /// faster than Monte Carlo (its expectation is V(n/2) − V(n) against V(n) for equal halves,
    /// V(m) the variance of an m-point net) and equals it where it does not. The perceptual
    /// sampler's layout: it costs none of the 1.12× of `Halves`.
    Blocks,
    /// Every pixel takes exactly this many samples in all (indices 0..N; a pass may draw a
    /// part of them), known before it is rendered: a correlated multi-jittered pattern of N
    /// points per pixel ([`cmj`]) with the default generator, whose half-buffers (even and odd
    /// samples) are random halves of it, as with `Whole`. Uniform renders of a budget.
    Fixed(u32),
}

impl SampleStreams {
    /// The film layout of these samples' half-buffers.
    pub fn split(self) -> crate::film::HalfSplit {
        match self {
            SampleStreams::Blocks => crate::film::HalfSplit::Blocks,
            _ => crate::film::HalfSplit::Interleaved,
        }
    }
}

/// A source of canonical random numbers in [0, 1) for one camera sample.
pub trait Sampler {
    /// The next dimension.
    fn uniform(&mut self) -> f32;
    /// The next two dimensions, as one 2-D point.
    fn uniform2(&mut self) -> Vec2;
    /// Passes over the next dimension, exactly as [`Sampler::uniform`] would advance the
    /// source, for a decision that does not need it (the following values are unchanged).
    #[inline]
    fn skip(&mut self) {
        self.uniform();
    }
    /// Passes over the next two dimensions, as [`Sampler::uniform2`] would.
    #[inline]
    fn skip2(&mut self) {
        self.uniform2();
    }
    /// The next dimension if `used`, else ½ after passing over it.
    #[inline]
    fn uniform_if(&mut self, used: bool) -> f32 {
        if used {
            self.uniform()
        } else {
            self.skip();
            0.5
        }
    }
    /// The next two dimensions if `used`, else (½, ½) after passing over them.
    #[inline]
    fn uniform2_if(&mut self, used: bool) -> Vec2 {
        if used {
            self.uniform2()
        } else {
            self.skip2();
            Vec2::splat(0.5)
        }
    }
}

impl Sampler for Rng {
    #[inline]
    fn uniform(&mut self) -> f32 {
        Rng::uniform(self)
    }
    #[inline]
    fn uniform2(&mut self) -> Vec2 {
        Rng::uniform2(self)
    }
}

/// The dimensions of one camera sample drawn from a stratified pattern, and the PCG32 stream
/// of those past the pattern's `limit` (made when first needed, keyed by the render seed, the
/// pixel and the sample): the counter both [`SobolSampler`] and [`cmj::CmjSampler`] keep.
#[derive(Clone, Debug)]
pub(crate) struct Padded {
    dim: u32,
    limit: u32,
    key: (u64, u64, u64),
    tail: Option<Rng>,
}

impl Padded {
    /// Dimension 0 of a sample keyed `key`, its pattern `limit` dimensions deep.
    #[inline]
    pub(crate) fn new(limit: u32, key: (u64, u64, u64)) -> Padded {
        Padded {
            dim: 0,
            limit,
            key,
            tail: None,
        }
    }

    /// The first of the next `k` dimensions, advancing past them, while they are the pattern's.
    #[inline]
    pub(crate) fn take(&mut self, k: u32) -> Option<u32> {
        (self.dim < self.limit).then(|| {
            self.dim += k;
            self.dim - k
        })
    }

    /// The PCG32 stream past the pattern.
    #[inline]
    pub(crate) fn tail(&mut self) -> &mut Rng {
        let (s, p, i) = self.key;
        self.tail.get_or_insert_with(|| Rng::for_sample(s, p, i))
    }

    /// Passes over the next `k` (1 or 2) dimensions: a pattern's cost nothing, the stream's
    /// are drawn (so the following values are unchanged).
    #[inline]
    pub(crate) fn skip(&mut self, k: u32) {
        if self.take(k).is_none() {
            match k {
                1 => drop(self.tail().uniform()),
                _ => drop(self.tail().uniform2()),
            }
        }
    }
}

/// A sampler whose first dimensions come from a stratified pattern and the rest from PCG32
/// ([`Padded`]): [`SobolSampler`] and [`cmj::CmjSampler`]. Its [`Sampler`] draws the
/// pattern's dimension d with `value(d)` or, from there on two at a time, `point(d)`; a
/// skipped pattern dimension costs nothing.
pub(crate) trait PaddedPattern {
    /// The dimension counter and tail stream.
    fn dims(&mut self) -> &mut Padded;
    /// The pattern's value in dimension `d`.
    fn value(&self, d: u32) -> f32;
    /// The pattern's point in dimensions `d`, `d + 1`.
    fn point(&self, d: u32) -> Vec2;
}

impl<T: PaddedPattern> Sampler for T {
    #[inline]
    fn uniform(&mut self) -> f32 {
        match self.dims().take(1) {
            Some(d) => self.value(d),
            None => self.dims().tail().uniform(),
        }
    }

    #[inline]
    fn uniform2(&mut self) -> Vec2 {
        match self.dims().take(2) {
            Some(d) => self.point(d),
            None => self.dims().tail().uniform2(),
        }
    }

    #[inline]
    fn skip(&mut self) {
        self.dims().skip(1);
    }

    #[inline]
    fn skip2(&mut self) {
        self.dims().skip(2);
    }
}
