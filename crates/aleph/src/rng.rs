//! Deterministic random numbers.
//!
//! Every sample value aleph draws is a pure function of `(seed, pixel, sample index, dimension)`,
//! in the manner of pbrt-v4's `Sampler::StartPixelSample`: a [`Rng`] is created for one pixel
//! sample with [`Rng::for_sample`] and then yields the dimensions of that sample's path in order.
//! Images are therefore bit-identical for any thread count and for any order in which samples are
//! added to pixels later (the adaptive sampler relies on this).
//!
//! The generator is PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient
//! Statistically Good Algorithms for Random Number Generation", XSH-RR output), seeded through
//! the SplitMix64 finaliser (Steele et al. 2014) so that neighbouring pixels and indices give
//! uncorrelated streams.

use glam::Vec2;

const PCG_MULT: u64 = 6_364_136_223_846_793_005;

/// SplitMix64 finaliser: a bijective 64-bit mixing function (Steele, Lea & Flood 2014).
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A PCG32 generator (64-bit state, 32-bit output).
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    /// A generator from a 64-bit seed and a stream selector.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Rng {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// The generator for sample `sample_index` of pixel `pixel_index` under the render seed
    /// `seed`. The stream depends on these three numbers only.
    pub fn for_sample(seed: u64, pixel_index: u64, sample_index: u64) -> Self {
        let a = mix64(seed ^ mix64(pixel_index.wrapping_mul(0xA24B_AED4_963E_E407)));
        let b = mix64(a ^ sample_index.wrapping_mul(0x9FB2_1C65_1E98_DF25));
        Rng::new(b, mix64(b ^ 0xDEAD_BEEF_CAFE_F00D))
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform float in [0, 1): 24 random mantissa bits, so the result is never 1.
    #[inline]
    pub fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Two uniform floats in [0, 1)².
    #[inline]
    pub fn uniform2(&mut self) -> Vec2 {
        let x = self.uniform();
        Vec2::new(x, self.uniform())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_is_in_unit_interval_with_correct_mean() {
        let mut rng = Rng::new(42, 7);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let u = rng.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u as f64;
        }
        // Mean of U(0,1) is 1/2 with standard deviation sqrt(1/12)/sqrt(n) = 6.45e-4.
        assert!((sum / n as f64 - 0.5).abs() < 5.0 * 6.45e-4);
    }

    #[test]
    fn streams_depend_only_on_their_key() {
        let a: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_sample(1, 2, 3);
                move |_| r.next_u32()
            })
            .collect();
        let b: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_sample(1, 2, 3);
                move |_| r.next_u32()
            })
            .collect();
        let c: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_sample(1, 2, 4);
                move |_| r.next_u32()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
