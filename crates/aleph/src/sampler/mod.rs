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
