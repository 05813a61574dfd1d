//! Owen-scrambled Sobol' sampling, progressive and deterministic per (seed, pixel, sample index).
//!
//! Every pair of dimensions a path consumes is a 2-D Sobol' point (dimensions 0 and 1 of the
//! sequence, a (0,2)-sequence in base 2) with its own hash-based Owen scrambling and its own
//! shuffling of the sample index, after Burley 2020, "Practical Hash-based Owen Scrambling"
//! (JCGT 9(4)), §3–4 (the "padded" 2-D approach of pbrt-v4's `PaddedSobolSampler`, with the
//! index shuffled rather than Morton-ordered, so samples can be added to any pixel at any time
//! and every power-of-two prefix of a pixel's samples stays stratified).
//!
//! One pair is the exception: where a pixel's samples are one sequence, the first vertex's BSDF
//! sample comes from an extensible rank-1 lattice, whose evenly spaced points beat the net's on
//! that integrand's edges ([`LATTICE_PAIR`]); every power-of-two prefix is still stratified.
//!
//! **Layouts of a pixel's samples** ([`super::SampleStreams`]). With independent half-buffers
//! (the variance sampler, the denoised error, reuse across frames) the even and odd samples of
//! a pixel (half-buffers A and B of the film) are two separate sequences with independent
//! scrambles, sample n being point ⌊n/2⌋ of stream n mod 2 ([`SobolSampler::for_sample`]).
//! Each half is an unbiased randomized-QMC estimate on its own, and their difference estimates
//! the error of their mean without bias. Every other render draws all of a pixel's samples
//! from one sequence ([`SobolSampler::for_sample_whole`]), so every power-of-two prefix is one
//! net. The perceptual sampler reads its half-buffers as the sequence's power-of-two blocks
//! ([`crate::film::HalfSplit::Blocks`]: samples 0..P and P..n), each a net: their difference
//! overstates the error of the whole where the net converges faster than Monte Carlo (5.1×
//! in mean square for a smooth integrand at 64 samples, the tests) and matches it where it
//! does not, and the image keeps the whole sequence's stratification. Renders that steer by
//! nothing read hash-paired halves of it instead. A uniform render of a budget, whose pixels'
//! sample count is known before they are rendered, draws a correlated multi-jittered pattern
//! instead ([`super::cmj`], [`super::SampleStreams::Fixed`]), which beats these nets on edges.
//!
//! Dimensions past [`QMC_DIMENSIONS`] come from a PCG32 stream keyed the same way, as deep
//! bounces gain little from stratification: on the Cornell box (256², depth 8, Russian
//! roulette from bounce 5, 3 seeds, relMSE against an 8192-spp Mitsuba reference), Sobol' for
//! every dimension gave 1.01–1.03× lower relMSE at 16 and 64 spp for 1.04× the CPU time per
//! sample (paired runs): no gain in time to equal error, so it was not adopted. Re-measured
//! with one sequence per pixel (2026-11-25): 1.01× / 1.03× lower relMSE (0.00688 / 0.00137) for
//! 1.07× the CPU time (median of 5 paired whole processes at 64 spp, 1.00–1.12×): still none.
//!
//! **What the independent half-buffers cost.** The union of two independently scrambled nets
//! is not a net: on the Cornell box (256², depth 8, 3 seeds, relMSE against an 8192-spp
//! Mitsuba reference) the independent halves give 0.00782 / 0.00158 at 16 / 64 spp, one
//! sequence 0.00698 / 0.00141 (1.12× lower; PCG32 0.01102 / 0.00278). It is the price of an
//! unbiased error estimate; the perceptual sampler stopped paying it with the block layout
//! (its spp at uniform's FLIP mean on the box rose from 0.94× to 0.96× at 256 spp, from 1.03×
//! to 1.04× at 512, docs/benchmarks.md). The even and odd
//! samples of one sequence lie in complementary halves of every dimension pair's square (a
//! pair's shuffled indices differ in their lowest bit, which Sobol' turns into the top bit of
//! both coordinates), so their difference would measure how the integrand differs between those
//! halves, which does not shrink with the sample count; in the one-sequence layout a hash
//! decides which point of each pair goes to which half-buffer, so the halves are random halves
//! of the net and their difference measures the Monte Carlo error σ²/N: conservative (the
//! tests measure 1.02 σ²/N and 31× the net's own error on a smooth integrand), which is why
//! no sampler steers by those; the blocks split the net where its index's top bit changes,
//! which Sobol' turns into the lowest digits, so each block covers the whole square.
//!
//! **The scramble's quality.** An exact nested uniform scramble (each output bit flipped by a
//! hash of the level and the bits above it, 24–32 hashes per coordinate) in place of the
//! Laine–Karras hash gave 0.00705 / 0.00142 on the same box against 0.00696 / 0.00141 with one
//! sequence per pixel: the hash loses nothing measurable, and stays.
//!
//! **Against OpenQMC** (`openqmc-rs` 0.2.4, a port of the Academy Software Foundation's
//! library, tried as the generator: one 4-D domain per dimension pair, every dimension, the
//! same half-buffer streams): its Sobol' sampler gave 1.03× / 1.03× lower relMSE at 16 / 64
//! spp than this generator, its PMJ sampler 1.04× / 0.98×, for 1.16× the CPU time per sample
//! (paired runs): both lose in time to equal error, so this generator stays.
//!
//! **The renderer's default** (`[render] sample_generator = "sobol"`; `"independent"` gives
//! PCG32). Measured on the Cornell box at 256², depth 8, against an 8192-spp Mitsuba reference
//! (benches/peer/vs_mitsuba.py), Russian roulette from bounce 3 then: relMSE 1.28× lower at
//! 16 spp and 1.48× lower at 64 spp than PCG32 with independent halves, for 1.20× the CPU time
//! per sample (median of 6 paired runs), so 1.07× (16 spp) to 1.23× (64 spp) less time to equal
//! relMSE; with roulette from bounce 5 and one sequence, 1.58× / 1.97× lower. Dimension 1 comes from byte tables and single dimensions from a 1-D sequence (two
//! scrambles instead of three); before that it cost 1.34× and did not pay.
//! A single render's per-pixel error is not σ/√n under randomised QMC: the tests that z-test
//! pixels ask for independent samples, and the default is tested over independent seeds.

use super::{Padded, PaddedPattern};
use crate::rng::mix64;
use glam::Vec2;

/// Dimensions drawn from scrambled Sobol' points (the first bounces of a path); the rest from
/// PCG32.
pub const QMC_DIMENSIONS: u32 = 10;

/// The dimension pair that one sequence per pixel ([`SobolSampler::for_sample_whole`]: the
/// perceptual sampler, and renders that draw no CMJ pattern) takes from an extensible rank-1
/// lattice instead of a Sobol' net ([`shuffled_shifted_lattice2d`]): the first vertex's BSDF
/// sample, dimensions 6 and 7 in the integrator's order (the camera's 0–1, then the vertex's
/// light choice 2, light sample 3–4, BSDF choice 5 and BSDF sample 6–7). Where a glossy lobe, or the edge of what the sampled
/// directions see, makes that integrand discontinuous, the lattice's evenly spaced points beat
/// the net's. Measured with uniform renders drawing this sampler (a scratch switch; seeds 0–2,
/// mean squared error against 4096-spp references, relative to uniform CMJ renders, at 16 / 48
/// / 64 spp), the net in this pair against the lattice: Cornell box (256²) 0.99 / 1.29 / 1.03
/// against 0.96 / 1.22 / 0.96; its glossy variant 1.03 / 1.11 / 1.07 against 1.02 / 1.07 /
/// 1.02; the Mori knob in its studio (256×170) 1.04 / 1.09 / 0.99 against 1.03 / 1.06 / 0.96;
/// under the sunset (256×192) 1.10 / 1.20 / 1.18 against 1.07 / 1.15 / 1.12; the holodeck
/// (240×160) 1.04 / 1.15 / 1.08 against 1.00 / 1.12 / 1.05; Lost Empire (256×160) 0.98 / 1.00 /
/// 1.00 against 0.97 / 1.00 / 1.00. The first light sample's pair (3–4) from a lattice too
/// gained more under the sunset (0.93 / 0.94 / 0.91) but lost on the studio knob (1.12 / 1.17 /
/// 1.03), whose small softboxes are rectangles in the map's coordinates: it keeps the net.
/// Since environment maps are sampled along their lookup within each texel (2026-11-28) the
/// light pair's lattice no longer loses there: the perceptual sampler under budgets of 48 / 64
/// spp (`--steer-from 0`, seeds 1–4, relMSE against 2048-spp references, g as here) with the
/// light pair from the lattice too, over without: studio knob 0.99 / 0.95, sunset knob 0.77 /
/// 0.75, Cornell box 1.01 / 1.01, holodeck 1.00 / 1.00, Lost Empire 1.00 / 1.00. Not adopted:
/// at the studio knob's stopping budgets it loses (1.16 / 1.19 / 1.11 at 16 / 24 / 32 spp) and
/// that stop rose from 19.8 to 28.8 spp, 0.90× uniform's samples at equal FLIP mean instead of
/// 1.01× (docs/benchmarks.md, 2026-11-29).
pub const LATTICE_PAIR: u32 = 6;

/// Generator g of the rank-1 lattice of [`LATTICE_PAIR`]: the 2^m-point lattice {(k, k g) / 2^m
/// mod 1} has the largest worst-case shortest vector over 8 ≤ 2^m ≤ 65 536 points of all odd
/// g < 2¹⁷: at least 0.759 / √(2^m) (a hexagonal lattice's is 1.075 / √N), found by Gauss
/// reduction of each lattice's basis.
pub const LATTICE_GENERATOR: u32 = 113_133;

/// A Laine–Karras-style permutation: each output bit depends only on the same and less
/// significant input bits, so reversing the bits around it gives a nested uniform (Owen)
/// scramble (Burley 2020, listing 2). The constants are Vegdahl's improved hash ("Building a
/// Better LK Hash", 2021): with Burley's original constants one pixel of the light-sampling
/// furnace test read 0.71 ± 0.12 for an exact 1.2, a 4σ miss that the better-mixing hash does
/// not show (the original is known to scramble poorly for some seeds).
#[inline]
fn laine_karras_permutation(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Burley 2020, listing 3: nested uniform (Owen) scrambling of a 32-bit fixed-point value.
#[inline]
pub fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// Sobol' dimension 0: the van der Corput sequence in base 2 (bit reversal).
#[inline]
pub fn sobol_dim0(i: u32) -> u32 {
    i.reverse_bits()
}

/// Sobol' dimension 1 (primitive polynomial x + 1, direction numbers v₁ = 2³¹,
/// v_k = v_{k−1} ⊕ (v_{k−1} ≫ 1): the Pascal matrix mod 2).
#[inline]
pub fn sobol_dim1(i: u32) -> u32 {
    sobol_dim1_reversed(i).reverse_bits()
}

/// [`sobol_dim1`] with its bits reversed, the form the Owen scramble works on. The map is
/// linear over GF(2), so it is the XOR of four byte-indexed tables: branch-free, four lookups,
/// and no bit reversal.
#[inline]
fn sobol_dim1_reversed(i: u32) -> u32 {
    let t = &SOBOL1_REVERSED_BYTES;
    t[0][(i & 0xff) as usize]
        ^ t[1][(i >> 8 & 0xff) as usize]
        ^ t[2][(i >> 16 & 0xff) as usize]
        ^ t[3][(i >> 24) as usize]
}

/// Sobol' dimension 1 by its definition, bit by bit (the tables' source and test reference).
const fn sobol_dim1_bits(mut i: u32) -> u32 {
    let (mut r, mut v) = (0u32, 1u32 << 31);
    while i != 0 {
        if i & 1 != 0 {
            r ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    r
}

/// `SOBOL1_REVERSED_BYTES[k][b]` = [`sobol_dim1`] of byte b placed at byte k of the index,
/// bits reversed.
static SOBOL1_REVERSED_BYTES: [[u32; 256]; 4] = {
    let mut t = [[0u32; 256]; 4];
    let mut k = 0;
    while k < 4 {
        let mut b = 0;
        while b < 256 {
            t[k][b] = sobol_dim1_bits((b as u32) << (8 * k)).reverse_bits();
            b += 1;
        }
        k += 1;
    }
    t
};

/// A 32-bit fixed-point fraction as a float in [0, 1) (24 bits, never 1).
#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// Point `index` of the shuffled, Owen-scrambled 2-D Sobol' sequence of stream `seed` (Burley
/// 2020, listing 4, `shuffled_scrambled_sobol2d`).
#[inline]
pub fn shuffled_scrambled_sobol2d(index: u32, seed: u64) -> Vec2 {
    // Three 32-bit seeds from two mixes of the stream seed.
    let a = mix64(seed);
    let b = mix64(a) as u32;
    let i = nested_uniform_scramble(index, a as u32);
    // nested_uniform_scramble(v, s) = LK(reverse(v), s) reversed; dimension 0 is reverse(i) and
    // dimension 1 comes reversed from its tables, so neither is reversed twice.
    let x = laine_karras_permutation(i, (a >> 32) as u32).reverse_bits();
    let y = laine_karras_permutation(sobol_dim1_reversed(i), b).reverse_bits();
    Vec2::new(to_unit(x), to_unit(y))
}

/// Point `index` of the shuffled, randomly shifted extensible rank-1 lattice of stream `seed`
/// (Hickernell, Hong, L'Écuyer & Lemieux 2000, "Extensible lattice sequences for quasi-Monte
/// Carlo quadrature", SIAM J. Sci. Comput. 22(3)): (φ(i), φ(i) · g) mod 1 shifted by a random
/// vector mod 1 (Cranley & Patterson 1976), φ the base-2 radical inverse of the index after the
/// same Owen-scrambled shuffle as the nets' ([`shuffled_scrambled_sobol2d`]), g
/// [`LATTICE_GENERATOR`]. The shuffle permutes each aligned block of 2^m indices among
/// themselves, so every power-of-two prefix of 2^m points is the lattice {(k, k g) / 2^m},
/// shifted: each coordinate one point in each of 2^m equal strata, the points at least
/// 0.759 / √(2^m) apart on the torus; every point is uniform on the unit square.
#[inline]
pub fn shuffled_shifted_lattice2d(index: u32, seed: u64) -> Vec2 {
    let a = mix64(seed);
    let b = mix64(a) as u32;
    let r = nested_uniform_scramble(index, a as u32).reverse_bits();
    let x = r.wrapping_add((a >> 32) as u32);
    let y = r.wrapping_mul(LATTICE_GENERATOR).wrapping_add(b);
    Vec2::new(to_unit(x), to_unit(y))
}

/// Point `index` of the shuffled, Owen-scrambled 1-D Sobol' (van der Corput) sequence of
/// stream `seed`: two scrambles instead of the 2-D point's three.
#[inline]
pub fn shuffled_scrambled_sobol1d(index: u32, seed: u64) -> f32 {
    let a = mix64(seed);
    let i = nested_uniform_scramble(index, a as u32);
    to_unit(laine_karras_permutation(i, (a >> 32) as u32).reverse_bits())
}

/// The canonical random numbers of sample `sample_index` of pixel `pixel_index` under the render
/// seed: dimension pairs from independent scrambled Sobol' sequences, then PCG32.
#[derive(Clone, Debug)]
pub struct SobolSampler {
    /// Seed of this pixel's stream (half-buffer included).
    stream: u64,
    /// Index within the half-buffer's sequence.
    index: u32,
    /// The dimension counter, and the PCG32 stream past [`QMC_DIMENSIONS`].
    dims: Padded,
    /// Whether [`LATTICE_PAIR`] comes from the lattice: for one sequence per pixel; the two
    /// independent half-buffer streams (the variance sampler, the denoised error, reuse across
    /// frames), whose lattice was not measured, keep the net.
    lattice: bool,
}

impl SobolSampler {
    /// The sampler of sample `sample_index` of pixel `pixel_index` under `seed`, its even and
    /// odd samples from two independent sequences ([`super::SampleStreams::Halves`]).
    pub fn for_sample(seed: u64, pixel_index: u64, sample_index: u64) -> Self {
        let half = sample_index & 1;
        let stream = mix64(seed ^ mix64(pixel_index.wrapping_mul(0xD1B5_4A32_D192_ED03) ^ half));
        SobolSampler::new(
            stream,
            (sample_index >> 1) as u32,
            (seed, pixel_index, sample_index),
            false,
        )
    }

    /// The sampler of sample `sample_index` of pixel `pixel_index` under `seed`, all of the
    /// pixel's samples from one sequence ([`super::SampleStreams::Whole`]): samples 2k and
    /// 2k + 1 are points 2k and 2k + 1 of the sequence in an order a hash of (stream, k)
    /// chooses, so the pair, and every power-of-two prefix, is unchanged, but which half-buffer
    /// receives which of its two points is random.
    pub fn for_sample_whole(seed: u64, pixel_index: u64, sample_index: u64) -> Self {
        let stream = mix64(seed ^ mix64(pixel_index.wrapping_mul(0xD1B5_4A32_D192_ED03) ^ 2));
        let swap = mix64(stream ^ (sample_index >> 1)) & 1;
        SobolSampler::new(
            stream,
            (sample_index ^ swap) as u32,
            (seed, pixel_index, sample_index),
            true,
        )
    }

    #[inline]
    /// The sampler of point `index` of stream `stream`, its PCG32 tail keyed by (seed, pixel,
    /// sample), drawing [`LATTICE_PAIR`] from the lattice if `lattice`.
    fn new(stream: u64, index: u32, (seed, pixel, sample): (u64, u64, u64), lattice: bool) -> Self {
        SobolSampler {
            stream,
            index,
            dims: Padded::new(
                QMC_DIMENSIONS,
                (seed ^ 0x243F_6A88_85A3_08D3, pixel, sample),
            ),
            lattice,
        }
    }
}

/// The seed of dimension `d`'s scrambles in pixel stream `stream`.
#[inline]
fn dim_seed(stream: u64, d: u32) -> u64 {
    stream ^ (d as u64).wrapping_mul(0xA076_1D64_78BD_642F)
}

impl PaddedPattern for SobolSampler {
    #[inline]
    fn dims(&mut self) -> &mut Padded {
        &mut self.dims
    }

    #[inline]
    fn value(&self, d: u32) -> f32 {
        shuffled_scrambled_sobol1d(self.index, dim_seed(self.stream, d))
    }

    #[inline]
    fn point(&self, d: u32) -> Vec2 {
        if d == LATTICE_PAIR && self.lattice {
            shuffled_shifted_lattice2d(self.index, dim_seed(self.stream, d))
        } else {
            shuffled_scrambled_sobol2d(self.index, dim_seed(self.stream, d))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    #[test]
    fn sobol_dimensions_are_0_2_sequences() {
        // Every power-of-two prefix of 2^m points has exactly one point in each elementary
        // interval of area 2^−m (all shapes 2^a × 2^(m−a)): the (0, m, 2)-net property.
        for m in 0..=8u32 {
            let n = 1u32 << m;
            for a in 0..=m {
                let (bx, by) = (1u32 << a, 1u32 << (m - a));
                let mut seen = vec![0u32; n as usize];
                for i in 0..n {
                    let x = (sobol_dim0(i) as u64 * bx as u64) >> 32;
                    let y = (sobol_dim1(i) as u64 * by as u64) >> 32;
                    seen[(y * bx as u64 + x) as usize] += 1;
                }
                assert!(seen.iter().all(|&c| c == 1), "m {m}, a {a}");
            }
        }
    }

    #[test]
    fn scrambled_shuffled_prefixes_stay_stratified() {
        // Owen scrambling and the index shuffle preserve the net property of every
        // power-of-two prefix (here for several streams and shapes).
        for seed in [0u64, 7, 123_456_789] {
            for m in [2u32, 4, 6] {
                let n = 1u32 << m;
                for a in [0, m / 2, m] {
                    let (bx, by) = (1usize << a, 1usize << (m - a));
                    let mut seen = vec![0u32; n as usize];
                    for i in 0..n {
                        let p = shuffled_scrambled_sobol2d(i, seed);
                        let x = ((p.x * bx as f32) as usize).min(bx - 1);
                        let y = ((p.y * by as f32) as usize).min(by - 1);
                        seen[y * bx + x] += 1;
                    }
                    assert!(seen.iter().all(|&c| c == 1), "seed {seed}, m {m}, a {a}");
                }
            }
        }
    }

    #[test]
    fn samplers_are_deterministic_and_half_buffers_use_independent_streams() {
        let a: Vec<f32> = {
            let mut s = SobolSampler::for_sample(3, 17, 10);
            (0..40).map(|_| s.uniform()).collect()
        };
        let b: Vec<f32> = {
            let mut s = SobolSampler::for_sample(3, 17, 10);
            (0..40).map(|_| s.uniform()).collect()
        };
        assert_eq!(a, b);
        // The even half's first 2^m samples are stratified on their own, and so are the odd
        // half's: sample 2k and 2k+1 are point k of two different streams.
        for half in 0..2u64 {
            let n = 16u64;
            let mut seen = [0u32; 16];
            for k in 0..n {
                let p = SobolSampler::for_sample(5, 99, 2 * k + half).uniform2();
                let (x, y) = ((p.x * 4.0) as usize, (p.y * 4.0) as usize);
                seen[y * 4 + x] += 1;
            }
            assert!(seen.iter().all(|&c| c == 1), "half {half}: {seen:?}");
        }
        let e = SobolSampler::for_sample(5, 99, 0).uniform2();
        let o = SobolSampler::for_sample(5, 99, 1).uniform2();
        assert_ne!(e, o);
    }

    #[test]
    fn mean_of_a_smooth_integrand_converges_faster_than_random() {
        // ∫∫ x y dx dy = 1/4. With 256 stratified samples the error of randomized QMC is far
        // below Monte Carlo's standard error sqrt(var/n) = sqrt(7/144/256) ≈ 0.0138.
        let n = 256u64;
        let mut worst = 0.0f64;
        for pixel in 0..20u64 {
            let mut s = 0.0f64;
            for i in 0..n {
                let p = SobolSampler::for_sample(1, pixel, i).uniform2();
                s += (p.x * p.y) as f64;
            }
            worst = worst.max((s / n as f64 - 0.25).abs());
        }
        assert!(worst < 0.0138 / 4.0, "worst error {worst}");
    }
}

#[cfg(test)]
mod independence_tests {
    use super::*;
    use crate::sampler::Sampler;

    #[test]
    fn dimension_pairs_of_one_sample_are_independent() {
        // Joint uniformity of two dimensions of the same sample: the counts of (x_a, x_b) in
        // 16 × 16 cells over 100 pixels × 256 samples against the uniform expectation, by χ²
        // (255 degrees of freedom; the 0.999 quantile is about 330).
        let (pixels, spp, cells) = (100u64, 256u64, 16usize);
        for (da, db) in [(0usize, 1usize), (0, 2), (1, 3), (2, 5)] {
            let mut h = vec![0f64; cells * cells];
            for p in 0..pixels {
                for i in 0..spp {
                    let mut s = SobolSampler::for_sample(42, p, i);
                    let v: Vec<f32> = (0..6).map(|_| s.uniform()).collect();
                    let (x, y) = (
                        (v[da] * cells as f32) as usize,
                        (v[db] * cells as f32) as usize,
                    );
                    h[y * cells + x] += 1.0;
                }
            }
            let e = (pixels * spp) as f64 / (cells * cells) as f64;
            let chi2: f64 = h.iter().map(|&o| (o - e) * (o - e) / e).sum();
            assert!(chi2 < 330.0, "dims {da},{db}: χ² = {chi2:.1}");
        }
    }
}

#[cfg(test)]
mod table_tests {
    use super::*;

    #[test]
    fn byte_tables_equal_the_bitwise_definition() {
        let mut x = 0x1234_5678u32;
        for i in (0..70_000u32).chain([u32::MAX, 1 << 31, 0xdead_beef]) {
            assert_eq!(sobol_dim1(i), sobol_dim1_bits(i), "{i}");
            x = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
            assert_eq!(sobol_dim1(x), sobol_dim1_bits(x), "{x}");
        }
    }
}

#[cfg(test)]
mod whole_tests {
    use super::*;
    use crate::sampler::Sampler;
    use std::f64::consts::PI;

    /// sin(πx)·sin(πy): smooth, mean 4/π², variance 1/4 − 16/π⁴.
    fn g(p: Vec2) -> f64 {
        (PI * p.x as f64).sin() * (PI * p.y as f64).sin()
    }

    /// g of the camera's dimensions plus g of the first light sample's, drawn as the
    /// integrator draws them (dimension 2, the light choice, passed over): an additive smooth
    /// integrand whose two terms each are a 2-D net in a sampler that stratifies.
    fn additive(mut s: SobolSampler) -> f64 {
        let a = s.uniform2();
        s.skip();
        g(a) + g(s.uniform2())
    }

    const MEAN: f64 = 2.0 * 4.0 / (PI * PI);
    const VARIANCE: f64 = 2.0 * (0.25 - 16.0 / (PI * PI * PI * PI));

    /// (A, B): the means of the even and odd samples `0..n` of `pixel` drawn by `make`.
    fn halves(make: fn(u64, u64, u64) -> SobolSampler, pixel: u64, n: u64) -> (f64, f64) {
        let (mut a, mut b) = (0.0, 0.0);
        for i in 0..n {
            let v = additive(make(9, pixel, i));
            if i % 2 == 0 { a += v } else { b += v }
        }
        (a / (n / 2) as f64, b / (n / 2) as f64)
    }

    /// The first 2^m points of the camera's pair (0–1), the first light sample's (3–4) and the
    /// first BSDF sample's (6–7) of `pixel`'s whole sequence, drawn as the integrator draws
    /// them (the 1-D choices 2 and 5 passed over).
    fn first_vertex_pairs(pixel: u64, m: u32) -> [Vec<Vec2>; 3] {
        let mut out = [Vec::new(), Vec::new(), Vec::new()];
        for i in 0..1u64 << m {
            let mut s = SobolSampler::for_sample_whole(4, pixel, i);
            out[0].push(s.uniform2());
            s.skip();
            out[1].push(s.uniform2());
            s.skip();
            out[2].push(s.uniform2());
        }
        out
    }

    /// Smallest distance between two of `points` on the unit torus.
    fn min_torus_distance(points: &[Vec2]) -> f32 {
        let mut d = f32::INFINITY;
        for (i, p) in points.iter().enumerate() {
            for q in &points[..i] {
                let v = (*p - *q).abs();
                let w = v.min(Vec2::ONE - v);
                d = d.min(w.length());
            }
        }
        d
    }

    #[test]
    fn every_power_of_two_prefix_of_the_bsdf_pair_is_a_shifted_lattice() {
        // The lattice's guarantee: one point in each of 2^m strata of each coordinate, and
        // every two points at least 0.759 / √(2^m) apart on the torus (the generator's worst
        // case over 8–65 536 points). The Sobol' net of the light pair, as well stratified
        // along each axis, puts some points closer: the test tells the two apart.
        let mut net_closer = 0;
        for pixel in [0u64, 5, 77_777, 123_456] {
            for m in 1..=9u32 {
                let n = 1usize << m;
                let [_, light, bsdf] = first_vertex_pairs(pixel, m);
                for axis in 0..2 {
                    let mut seen = vec![0; n];
                    for p in &bsdf {
                        let c = if axis == 0 { p.x } else { p.y };
                        seen[((c * n as f32) as usize).min(n - 1)] += 1;
                    }
                    assert!(
                        seen.iter().all(|&c| c == 1),
                        "pixel {pixel}, m {m}, axis {axis}"
                    );
                }
                if m >= 3 {
                    let bound = 0.759 / (n as f32).sqrt() - 1e-6;
                    let d = min_torus_distance(&bsdf);
                    assert!(d >= bound, "pixel {pixel}, m {m}: {d} < {bound}");
                    if min_torus_distance(&light) < bound {
                        net_closer += 1;
                    }
                }
            }
        }
        assert!(
            net_closer > 0,
            "the net's points were never closer than the bound"
        );
    }

    #[test]
    fn every_power_of_two_prefix_of_a_whole_pixel_is_a_net() {
        // Camera dimensions (0, 1) and the first light sample's (3, 4): one sample in each
        // elementary interval of every shape, for the first 2^m samples.
        for pixel in [0u64, 5, 77_777] {
            for m in [1u32, 3, 5, 7] {
                let n = 1u64 << m;
                for a in 0..=m {
                    let (bx, by) = (1usize << a, 1usize << (m - a));
                    let (mut cam, mut light) = (vec![0; 1 << m], vec![0; 1 << m]);
                    for i in 0..n {
                        let mut s = SobolSampler::for_sample_whole(4, pixel, i);
                        let c = s.uniform2();
                        s.skip();
                        let l = s.uniform2();
                        for (p, seen) in [(c, &mut cam), (l, &mut light)] {
                            let x = ((p.x * bx as f32) as usize).min(bx - 1);
                            let y = ((p.y * by as f32) as usize).min(by - 1);
                            seen[y * bx + x] += 1;
                        }
                    }
                    assert!(
                        cam.iter().all(|&c| c == 1),
                        "camera: pixel {pixel}, m {m}, a {a}"
                    );
                    assert!(
                        light.iter().all(|&c| c == 1),
                        "light: pixel {pixel}, m {m}, a {a}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_whole_pixel_has_the_error_of_one_net_not_of_two_half_nets() {
        // For a smooth integrand the variance of an Owen-scrambled net of N points falls as
        // N⁻³, so the mean of two independent nets of N/2 has 2 · ¼ · 8 = 4 times the variance
        // of one net of N: twice the RMS error (measured: 1.79×). Over 2000 pixels the RMS is
        // known to about 2 %; 1.5 separates the two layouts by far more than that. Both are far
        // below Monte Carlo's σ/√N (one net: 0.10 of it).
        let (pixels, n) = (2000u64, 64u64);
        let rms = |make: fn(u64, u64, u64) -> SobolSampler| {
            let se: f64 = (0..pixels)
                .map(|p| {
                    let (a, b) = halves(make, p, n);
                    (0.5 * (a + b) - MEAN).powi(2)
                })
                .sum();
            (se / pixels as f64).sqrt()
        };
        let (whole, split) = (
            rms(SobolSampler::for_sample_whole),
            rms(SobolSampler::for_sample),
        );
        let mc = (VARIANCE / n as f64).sqrt();
        assert!(split > 1.5 * whole, "whole {whole:.2e}, halves {split:.2e}");
        assert!(
            whole < mc / 4.0,
            "whole {whole:.2e} against Monte Carlo's {mc:.2e}"
        );
    }

    #[test]
    fn whole_half_buffers_are_unbiased_and_their_difference_is_conservative() {
        // Each half-buffer is a random half of the net: unbiased, so (A − B)/2 has mean 0
        // (within 4 standard errors over the pixels), and E[((A − B)/2)²] is at least the
        // Monte Carlo variance σ²/N of the mean (siblings of a pair lie in opposite halves of
        // every dimension pair's square, which can only add to their difference), far above
        // the net's own error: a safe error estimate for renders that do not steer by it
        // (measured: 1.02 σ²/N, 31 times the mean squared error of the net).
        let (pixels, n) = (4000u64, 32u64);
        let (mut d, mut d2, mut err2) = (0.0f64, 0.0f64, 0.0f64);
        let mut d2s = Vec::new();
        for p in 0..pixels {
            let (a, b) = halves(SobolSampler::for_sample_whole, p, n);
            let h = 0.5 * (a - b);
            d += h;
            d2 += h * h;
            d2s.push(h * h);
            err2 += (0.5 * (a + b) - MEAN).powi(2);
        }
        let k = pixels as f64;
        let (mean_d, mean_d2) = (d / k, d2 / k);
        let se_d = (mean_d2 / k).sqrt();
        assert!(
            mean_d.abs() < 4.0 * se_d,
            "mean (A − B)/2 = {mean_d:.2e} ± {se_d:.2e}"
        );
        let var_d2 = d2s.iter().map(|x| (x - mean_d2).powi(2)).sum::<f64>() / (k - 1.0);
        let se_d2 = (var_d2 / k).sqrt();
        let mc = VARIANCE / n as f64;
        assert!(
            mean_d2 + 4.0 * se_d2 > mc,
            "E[((A − B)/2)²] = {mean_d2:.3e} ± {se_d2:.1e}, σ²/N = {mc:.3e}"
        );
        assert!(
            mean_d2 > 10.0 * err2 / k,
            "estimate {mean_d2:.2e}, true {:.2e}",
            err2 / k
        );
    }

    /// Over `pixels` pixels of `n` samples each in the block layout (the film's own
    /// [`crate::film::PixelStats::add_block`]): the estimates k (A − B) and the errors of the
    /// means, after checking that each pixel's mean is bit for bit the one-sequence layout's.
    fn block_estimates(pixels: u64, n: u64) -> (Vec<f64>, Vec<f64>) {
        use crate::film::{HalfSplit, PixelStats};
        let (mut est, mut err) = (Vec::new(), Vec::new());
        for p in 0..pixels {
            let (mut blocks, mut pairs) = (PixelStats::default(), PixelStats::default());
            for i in 0..n {
                let v = glam::Vec3::splat(additive(SobolSampler::for_sample_whole(9, p, i)) as f32);
                blocks.add_block(v);
                pairs.add(v);
            }
            assert_eq!(blocks.mean(), pairs.mean(), "pixel {p}");
            let split = HalfSplit::Blocks;
            let (na, nb) = split.counts(0, n as u32);
            let a = blocks.sum_even.value().x / na as f64;
            let b = blocks.sum_odd.value().x / nb as f64;
            est.push(split.difference_scale(na as f64, nb as f64) * (a - b));
            err.push(blocks.mean().x - MEAN);
        }
        (est, err)
    }

    #[test]
    fn block_half_buffers_are_unbiased_nets_whose_difference_bounds_the_error() {
        // The perceptual sampler's layout: A = samples 0..P, B = P..n of one sequence. Each
        // half is a net, so k (A − B) has mean 0 (within 4 standard errors) and its mean
        // square is at least the error of the whole net (the halves are anticorrelated, which
        // can only add to their difference) but far below the hash-paired halves' 31×: for a
        // variance falling as N⁻³, E[(A − B)²/4] = V(N/2) − V(N) = 7 V(N) at N = 64, the
        // bound for the unequal halves of N = 96 (64 and 32 points) too (measured: 5.1× and
        // 2.3×). Over 4000 pixels a mean square is known to about 5 %.
        for n in [64u64, 96] {
            let (est, err) = block_estimates(4000, n);
            let k = est.len() as f64;
            let mean = est.iter().sum::<f64>() / k;
            let ms = est.iter().map(|e| e * e).sum::<f64>() / k;
            let se = (ms / k).sqrt();
            assert!(
                mean.abs() < 4.0 * se,
                "N {n}: mean k(A − B) = {mean:.2e} ± {se:.2e}"
            );
            let truth = err.iter().map(|e| e * e).sum::<f64>() / k;
            let ratio = ms / truth;
            assert!(
                (1.0..8.0).contains(&ratio),
                "N {n}: E[(k(A − B))²] = {ms:.2e}, error of the mean {truth:.2e} ({ratio:.2}×)"
            );
        }
    }
}
