//! The film: per-pixel sample buffers that the perception module and the adaptive sampler read.
//!
//! For every pixel the film keeps
//! - the RGB sums of its two half-buffers A and B, whose total is the pixel's RGB sum and whose
//!   difference estimates its error; which samples go to which half is the film's
//!   [`HalfSplit`] (even and odd indices, or the power-of-two blocks of one sequence);
//! - the sum of squared luminance Σ Y², for the sample variance;
//! - the sample count n (samples 0..n have been taken; the next has index n).
//!
//! Values are linear Rec.709 radiance in W·sr⁻¹·m⁻². Every sum is an [`ExactSum`]: the f32
//! samples are added without rounding, so a sum does not depend on the order or grouping of its
//! samples. That is what makes a film rendered in parts on several machines and merged
//! ([`Film::merge`], [`crate::partial`]) bit-identical to the same samples rendered in one go. A
//! pixel's samples are added in index order, so adding more later continues its random stream
//! exactly (see [`crate::rng`]).

use glam::{DVec3, Vec3};

/// A sum of f64 values kept as an unevaluated pair `hi + lo` (Knuth's TwoSum; Ogita, Rump &
/// Oishi 2005, "Accurate sum and dot product", Algorithm 3.1 without the final rounding).
///
/// Each [`add`](ExactSum::add) is error-free in `hi`; the rounding errors collect in `lo`, which
/// adds them exactly as long as they fit in its 53 bits. For sums of f32 samples and their
/// (24-bit mantissas) that holds whenever no sample is below about 2⁻⁸⁰ of its pixel's sum: the
/// pair then holds the exact real sum, whatever the order or grouping of the additions, and
/// [`value`](ExactSum::value) is that sum correctly rounded to f64. Squares of samples span
/// twice the range, so a sum of squares may round; it is then accurate to about 2⁻¹⁰⁰ of its
/// value. Equality compares the exact sums (the canonical pair of
/// [`normalized`](ExactSum::normalized)).
#[derive(Clone, Copy, Debug, Default)]
pub struct ExactSum {
    hi: f64,
    lo: f64,
}

impl ExactSum {
    /// The pair `hi + lo` (for files; [`normalized`](ExactSum::normalized) first for a
    /// canonical form).
    pub fn from_parts(hi: f64, lo: f64) -> ExactSum {
        ExactSum { hi, lo }
    }

    /// `(hi, lo)`.
    pub fn parts(&self) -> (f64, f64) {
        (self.hi, self.lo)
    }

    /// Adds `x` (TwoSum: `hi + x = s + e` exactly).
    #[inline]
    pub fn add(&mut self, x: f64) {
        let s = self.hi + x;
        let bp = s - self.hi;
        let e = (self.hi - (s - bp)) + (x - bp);
        self.hi = s;
        self.lo += e;
    }

    /// Adds another sum.
    #[inline]
    pub fn merge(&mut self, o: &ExactSum) {
        self.add(o.hi);
        self.add(o.lo);
    }

    /// The sum rounded to f64.
    #[inline]
    pub fn value(&self) -> f64 {
        self.hi + self.lo
    }

    /// The canonical pair of the same sum: `hi` = the sum rounded to f64, `lo` = the exact rest.
    pub fn normalized(&self) -> ExactSum {
        let mut n = ExactSum {
            hi: self.hi,
            lo: 0.0,
        };
        n.add(self.lo);
        n
    }
}

impl PartialEq for ExactSum {
    fn eq(&self, o: &ExactSum) -> bool {
        let (a, b) = (self.normalized(), o.normalized());
        a.hi == b.hi && a.lo == b.lo
    }
}

/// Three [`ExactSum`]s, for RGB.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExactRgb(pub [ExactSum; 3]);

impl ExactRgb {
    /// Adds an RGB value.
    #[inline]
    pub fn add(&mut self, v: DVec3) {
        self.0[0].add(v.x);
        self.0[1].add(v.y);
        self.0[2].add(v.z);
    }

    /// Adds another sum.
    #[inline]
    pub fn merge(&mut self, o: &ExactRgb) {
        for c in 0..3 {
            self.0[c].merge(&o.0[c]);
        }
    }

    /// The sums rounded to f64.
    #[inline]
    pub fn value(&self) -> DVec3 {
        DVec3::new(self.0[0].value(), self.0[1].value(), self.0[2].value())
    }
}

/// Which of a pixel's samples its two half-buffers hold.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HalfSplit {
    /// Half-buffer A holds the samples of even index, B those of odd index (equal halves, one
    /// sample apart at odd counts). For independent half-buffer streams
    /// ([`crate::sampler::SampleStreams::Halves`]) and for patterns whose halves are random
    /// halves ([`crate::sampler::SampleStreams::Whole`], [`crate::sampler::SampleStreams::Fixed`]).
    #[default]
    Interleaved,
    /// The power-of-two blocks of one scrambled sequence
    /// ([`crate::sampler::SampleStreams::Blocks`]): with n samples taken (n ≥ 2), A holds
    /// samples 0..P and B samples P..n, P the largest power of two below n; one sample: A.
    /// At n = 2^k both halves are (0, k − 1, 2)-nets and at n = 3 · 2^(k − 2) they hold
    /// 2^(k − 1) and 2^(k − 2) points, each a net. Samples are added in index order; at a
    /// power of two B joins A before the next sample ([`PixelStats::add_block`]).
    Blocks,
}

impl HalfSplit {
    /// Samples in half-buffers A and B of a pixel holding samples `first..n` (`first` is 0
    /// for a [`HalfSplit::Blocks`] film).
    #[inline]
    pub fn counts(self, first: u32, n: u32) -> (u32, u32) {
        match self {
            HalfSplit::Interleaved => (n.div_ceil(2) - first.div_ceil(2), n / 2 - first / 2),
            HalfSplit::Blocks if n <= 1 => (n, 0),
            HalfSplit::Blocks => {
                let p = 1 << (31 - (n - 1).leading_zeros());
                (p, n - p)
            }
        }
    }

    /// The factor k with E[(k (Y_A − Y_B))²] = Var(Y_mean) for independent halves of `n_a` and
    /// `n_b` samples: √(n_a n_b) / (n_a + n_b), ½ for equal halves. [`HalfSplit::Interleaved`]
    /// returns ½ whatever the counts (they differ by at most one sample).
    #[inline]
    pub fn difference_scale(self, n_a: f64, n_b: f64) -> f64 {
        match self {
            HalfSplit::Interleaved => 0.5,
            HalfSplit::Blocks if n_a + n_b > 0.0 => (n_a * n_b).sqrt() / (n_a + n_b),
            HalfSplit::Blocks => 0.0,
        }
    }
}

/// Sample statistics of one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelStats {
    /// RGB sum of half-buffer A: the samples with even index under [`HalfSplit::Interleaved`]
    /// (hence the name), the first power-of-two block under [`HalfSplit::Blocks`].
    pub sum_even: ExactRgb,
    /// RGB sum of half-buffer B: the samples with odd index, or the block after A's.
    pub sum_odd: ExactRgb,
    /// Σ Y² over all samples (Y = Rec.709 luminance of the sample). Not exact when the squares
    /// span more than the pair holds (see [`ExactSum`]): a merged film's Σ Y² may then differ
    /// from a single render's by about 2⁻¹⁰⁰ of its value. It only feeds variance estimates,
    /// never the image.
    pub sum_lum2: ExactSum,
    /// Number of samples taken (the next sample's index): samples `first..n` are in the sums.
    pub n: u32,
    /// Index of the first sample in the sums: 0, except in a partial film that holds a range of
    /// samples rendered on its own ([`crate::partial`]).
    pub first: u32,
}

impl PixelStats {
    /// Adds the sample with index `self.n`.
    #[inline]
    pub fn add(&mut self, rgb: Vec3) {
        self.add_to_half(rgb, self.n.is_multiple_of(2));
    }

    /// Adds the sample with index `self.n` to a [`HalfSplit::Blocks`] film's pixel: at a
    /// power-of-two count half-buffer B first joins A, then the sample goes to B (sample 0 to
    /// A). The pixel's sum, count and Σ Y² are those [`PixelStats::add`] gives.
    #[inline]
    pub fn add_block(&mut self, rgb: Vec3) {
        if self.n.is_power_of_two() {
            let b = std::mem::take(&mut self.sum_odd);
            self.sum_even.merge(&b);
        }
        self.add_to_half(rgb, self.n == 0);
    }

    /// Adds the sample with index `self.n` to half-buffer A (`to_a`) or B, and to Σ Y².
    #[inline]
    fn add_to_half(&mut self, rgb: Vec3, to_a: bool) {
        let v = rgb.as_dvec3();
        if to_a {
            self.sum_even.add(v);
        } else {
            self.sum_odd.add(v);
        }
        let y = crate::math::luminance(rgb) as f64;
        self.sum_lum2.add(y * y);
        self.n += 1;
    }

    /// Samples in the sums (`n − first`).
    #[inline]
    pub fn count(&self) -> u32 {
        self.n - self.first
    }

    /// RGB sum of all samples.
    #[inline]
    pub fn sum(&self) -> DVec3 {
        let mut s = self.sum_even;
        s.merge(&self.sum_odd);
        s.value()
    }

    /// Mean radiance (zero when no samples).
    #[inline]
    pub fn mean(&self) -> DVec3 {
        if self.count() == 0 {
            DVec3::ZERO
        } else {
            self.sum() / self.count() as f64
        }
    }

    /// Number of samples in half-buffer A (even indices).
    #[inline]
    pub fn n_even(&self) -> u32 {
        HalfSplit::Interleaved.counts(self.first, self.n).0
    }

    /// Number of samples in half-buffer B (odd indices).
    #[inline]
    pub fn n_odd(&self) -> u32 {
        HalfSplit::Interleaved.counts(self.first, self.n).1
    }

    /// Mean of half-buffer A (even indices; zero when empty).
    #[inline]
    pub fn mean_even(&self) -> DVec3 {
        self.half_means(HalfSplit::Interleaved).0
    }

    /// Mean of half-buffer B (odd indices; zero when empty).
    #[inline]
    pub fn mean_odd(&self) -> DVec3 {
        self.half_means(HalfSplit::Interleaved).1
    }

    /// Means of half-buffers A and B under `split` (zero where a half is empty).
    #[inline]
    pub fn half_means(&self, split: HalfSplit) -> (DVec3, DVec3) {
        let (na, nb) = split.counts(self.first, self.n);
        let mean = |s: &ExactRgb, n: u32| {
            if n == 0 {
                DVec3::ZERO
            } else {
                s.value() / n as f64
            }
        };
        (mean(&self.sum_even, na), mean(&self.sum_odd, nb))
    }

    /// Unbiased sample variance of the luminance of one sample (0 with fewer than 2 samples).
    #[inline]
    pub fn lum_variance(&self) -> f64 {
        if self.count() < 2 {
            return 0.0;
        }
        let n = self.count() as f64;
        let m = self.mean();
        let mean_y = crate::math::luminance(m.as_vec3()) as f64;
        ((self.sum_lum2.value() - n * mean_y * mean_y) / (n - 1.0)).max(0.0)
    }

    /// Standard error of the pixel's mean luminance: sqrt(variance / n).
    #[inline]
    pub fn lum_std_error(&self) -> f64 {
        if self.count() < 2 {
            return f64::INFINITY;
        }
        (self.lum_variance() / self.count() as f64).sqrt()
    }

    /// Adds the samples of `o`, which must follow on from these (`o.first == self.n`) or come
    /// before them (`o.n == self.first`); `false` (and nothing changed) otherwise.
    pub fn merge(&mut self, o: &PixelStats) -> bool {
        if o.count() == 0 {
            return true;
        }
        if self.count() == 0 {
            *self = *o;
            return true;
        }
        if o.first == self.n {
            self.n = o.n;
        } else if o.n == self.first {
            self.first = o.first;
        } else {
            return false;
        }
        self.sum_even.merge(&o.sum_even);
        self.sum_odd.merge(&o.sum_odd);
        self.sum_lum2.merge(&o.sum_lum2);
        true
    }
}
/// Samples of earlier frames reprojected onto one pixel of this frame ([`crate::reuse`]):
/// weighted sums kept per half-buffer, so that the half-buffer error estimate covers the
/// reused samples' noise as it covers the fresh ones'. A weight is a (fractional) number of
/// samples: the resampled count times the weight the reuse gave that frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HistoryPixel {
    /// Weighted RGB sum of reused even-index samples, W·sr⁻¹·m⁻² × samples.
    pub sum_even: DVec3,
    /// Weighted RGB sum of reused odd-index samples.
    pub sum_odd: DVec3,
    /// Weight (samples) of the even sums.
    pub n_even: f64,
    /// Weight (samples) of the odd sums.
    pub n_odd: f64,
    /// Weighted Σ Y² of the reused samples.
    pub sum_lum2: f64,
    /// Radiance added to each of the pixel's means (both half-buffers and all samples),
    /// W·sr⁻¹·m⁻²: this pixel's share of the held fireflies dropped on its surface nearby
    /// ([`crate::reuse`], "Held fireflies"). Not a sample: it adds no weight and no variance.
    pub spread: DVec3,
}

impl HistoryPixel {
    /// The means of half-buffer A, half-buffer B and all samples of a pixel whose fresh
    /// samples are `p` and reused ones these (zero where a buffer is empty), without the
    /// spread light.
    pub fn sample_means(&self, p: &PixelStats) -> (DVec3, DVec3, DVec3) {
        let mean = |s: DVec3, n: f64| if n > 0.0 { s / n } else { DVec3::ZERO };
        let (se, so) = (p.sum_even.value(), p.sum_odd.value());
        let (ne, no) = (p.n_even() as f64, p.n_odd() as f64);
        (
            mean(se + self.sum_even, ne + self.n_even),
            mean(so + self.sum_odd, no + self.n_odd),
            mean(
                se + so + self.sum_even + self.sum_odd,
                ne + no + self.weight(),
            ),
        )
    }

    /// Total weight, samples.
    pub fn weight(&self) -> f64 {
        self.n_even + self.n_odd
    }
}

/// A `width × height` grid of [`PixelStats`], row-major, row 0 at the top, with the samples
/// reused from earlier frames, if any.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major pixel statistics of the samples traced for this film.
    pub pixels: Vec<PixelStats>,
    /// Samples of earlier frames reprojected onto these pixels (row-major), which every image
    /// of the film ([`Film::mean_rgb`] and the half-buffers) combines with the fresh ones;
    /// `None` for a film of fresh samples only.
    pub history: Option<Vec<HistoryPixel>>,
    /// Which samples each pixel's half-buffers hold (set by the first render into the film,
    /// [`crate::render::render_counts`]). A film with history is [`HalfSplit::Interleaved`].
    pub split: HalfSplit,
}

impl Film {
    /// An empty film.
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![PixelStats::default(); width as usize * height as usize],
            history: None,
            split: HalfSplit::Interleaved,
        }
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.pixels.len()
    }

    /// True when the film has no pixels.
    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    /// The statistics of pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> &PixelStats {
        &self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Pixel `i`'s means of half-buffer A, half-buffer B and all samples, fresh and reused
    /// (zero where a buffer is empty).
    #[inline]
    pub fn means(&self, i: usize) -> (DVec3, DVec3, DVec3) {
        let p = &self.pixels[i];
        let Some(h) = self.reused(i) else {
            let (a, b) = p.half_means(self.split);
            return (a, b, p.mean());
        };
        debug_assert_eq!(self.split, HalfSplit::Interleaved, "a film with history");
        // A spread excess may be negative in a channel (a dropped firefly of another colour
        // than the rest lowered that channel's mean); a mean stays at or above zero.
        let spread = |m: DVec3| (m + h.spread).max(DVec3::ZERO);
        let (a, b, all) = h.sample_means(p);
        (spread(a), spread(b), spread(all))
    }

    /// Pixel `i`'s reused samples, if it has any (or a share of spread light).
    #[inline]
    fn reused(&self, i: usize) -> Option<HistoryPixel> {
        self.history
            .as_ref()
            .map(|h| h[i])
            .filter(|h| h.weight() > 0.0 || h.spread != DVec3::ZERO)
    }

    /// The factor that turns pixel `i`'s half-buffer difference into an estimate of its
    /// mean's error ([`HalfSplit::difference_scale`]): ½ for interleaved halves.
    #[inline]
    pub fn difference_scale(&self, i: usize) -> f64 {
        let p = &self.pixels[i];
        let (na, nb) = self.split.counts(p.first, p.n);
        self.split.difference_scale(na as f64, nb as f64)
    }

    /// Samples behind pixel `i`'s estimate: its fresh count plus the reused weight.
    #[inline]
    pub fn effective_count(&self, i: usize) -> f64 {
        self.pixels[i].count() as f64 + self.history_weight(i)
    }

    /// The reused weight of pixel `i` (0 without history), samples.
    #[inline]
    pub fn history_weight(&self, i: usize) -> f64 {
        self.history.as_ref().map_or(0.0, |h| h[i].weight())
    }

    /// Standard error of pixel `i`'s mean luminance over its fresh and reused samples,
    /// sqrt(var / n_eff) (infinite under 2 samples).
    pub fn lum_std_error(&self, i: usize) -> f64 {
        let p = &self.pixels[i];
        let Some(h) = self.reused(i) else {
            return p.lum_std_error();
        };
        let n = self.effective_count(i);
        if n < 2.0 {
            return f64::INFINITY;
        }
        // The samples' own mean: the spread light is no sample.
        let y = crate::math::luminance(h.sample_means(p).2.as_vec3()) as f64;
        let var = ((p.sum_lum2.value() + h.sum_lum2 - n * y * y) / (n - 1.0)).max(0.0);
        (var / n).sqrt()
    }

    /// Mean radiance per pixel as interleaved RGB `f32` (3 × pixels), fresh and reused
    /// samples together.
    pub fn mean_rgb(&self) -> Vec<f32> {
        self.interleaved(|m| m.2)
    }

    /// Half-buffer A (even samples) mean per pixel as interleaved RGB.
    pub fn mean_rgb_even(&self) -> Vec<f32> {
        self.interleaved(|m| m.0)
    }

    /// Half-buffer B (odd samples) mean per pixel as interleaved RGB.
    pub fn mean_rgb_odd(&self) -> Vec<f32> {
        self.interleaved(|m| m.1)
    }

    fn interleaved(&self, pick: impl Fn((DVec3, DVec3, DVec3)) -> DVec3) -> Vec<f32> {
        (0..self.len())
            .flat_map(|i| pick(self.means(i)).as_vec3().to_array())
            .collect()
    }

    /// Sample count per pixel.
    pub fn spp(&self) -> Vec<u32> {
        self.pixels.iter().map(|p| p.count()).collect()
    }

    /// Total number of samples over all pixels.
    pub fn total_samples(&self) -> u64 {
        self.pixels.iter().map(|p| p.count() as u64).sum()
    }

    /// An empty film whose pixels take their next samples from index `first` on: a partial
    /// film for the sample range `first..` ([`crate::partial`]).
    pub fn starting_at(width: u32, height: u32, first: u32) -> Film {
        let px = PixelStats {
            n: first,
            first,
            ..Default::default()
        };
        Film {
            width,
            height,
            pixels: vec![px; width as usize * height as usize],
            history: None,
            split: HalfSplit::Interleaved,
        }
    }

    /// Adds the samples of `other`, a film of the same size whose every pixel holds the sample
    /// range just before or just after this film's. The RGB sums and counts of the result equal,
    /// bit for bit, those of the film that took all the samples in one go, and so does its image
    /// (the sums are exact, see [`ExactSum`]); Σ Y² agrees to about 2⁻¹⁰⁰.
    ///
    /// # Errors
    /// A message naming the first pixel whose ranges do not meet, or the sizes; `self` is then
    /// unchanged.
    pub fn merge(&mut self, other: &Film) -> Result<(), String> {
        if self.split != HalfSplit::Interleaved || other.split != HalfSplit::Interleaved {
            return Err(
                "a film whose half-buffers are blocks of one sequence holds no sample \
                        range another film can continue"
                    .into(),
            );
        }
        if (self.width, self.height) != (other.width, other.height) {
            return Err(format!(
                "sizes differ: {}×{} and {}×{}",
                self.width, self.height, other.width, other.height
            ));
        }
        let mut merged = self.pixels.clone();
        for (i, (a, b)) in merged.iter_mut().zip(&other.pixels).enumerate() {
            if !a.merge(b) {
                let (x, y) = (i % self.width as usize, i / self.width as usize);
                return Err(format!(
                    "pixel ({x}, {y}): samples {}..{} and {}..{} do not meet",
                    a.first, a.n, b.first, b.n
                ));
            }
        }
        self.pixels = merged;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_and_statistics() {
        let mut p = PixelStats::default();
        for v in [1.0f32, 3.0, 2.0, 6.0, 4.0] {
            p.add(Vec3::splat(v));
        }
        assert_eq!(p.n, 5);
        assert_eq!((p.n_even(), p.n_odd()), (3, 2));
        assert!((p.mean().x - 3.2).abs() < 1e-12);
        assert!((p.mean_even().x - 7.0 / 3.0).abs() < 1e-12);
        assert!((p.mean_odd().x - 4.5).abs() < 1e-12);
        // Grey has luminance equal to its value: sample variance of {1,3,2,6,4} is 3.7.
        assert!((p.lum_variance() - 3.7).abs() < 1e-5);
    }

    #[test]
    fn block_halves_are_the_power_of_two_blocks() {
        // Sample i has value i: at n = 12, A holds 0..8 (mean 3.5) and B 8..12 (mean 9.5).
        let mut film = Film::new(1, 1);
        film.split = HalfSplit::Blocks;
        let mut seen = Vec::new();
        for i in 0..12u32 {
            film.pixels[0].add_block(Vec3::splat(i as f32));
            seen.push(HalfSplit::Blocks.counts(0, i + 1));
        }
        assert_eq!(
            seen,
            [
                (1, 0),
                (1, 1),
                (2, 1),
                (2, 2),
                (4, 1),
                (4, 2),
                (4, 3),
                (4, 4),
                (8, 1),
                (8, 2),
                (8, 3),
                (8, 4)
            ]
        );
        let (a, b, all) = film.means(0);
        assert_eq!((a.x, b.x, all.x), (3.5, 9.5, 5.5));
        assert!((film.difference_scale(0) - 32f64.sqrt() / 12.0).abs() < 1e-15);
        assert_eq!(HalfSplit::Blocks.difference_scale(4.0, 4.0), 0.5);
        // A block film holds no sample range another film can continue.
        let other = Film::new(1, 1);
        assert!(film.merge(&other).is_err());
    }

    /// f32 samples over 2⁻³⁰ … 2³⁰ with heavy tails, as path tracing gives.
    fn samples(n: usize, seed: u64) -> Vec<Vec3> {
        let mut rng = crate::rng::Rng::for_sample(seed, 0, 0);
        (0..n)
            .map(|_| {
                let (a, b) = rng.uniform2().into();
                let e = (a * 60.0 - 30.0).round();
                Vec3::new(b * e.exp2(), (1.0 - b) * 0.5, b * b * 1e3)
            })
            .collect()
    }

    #[test]
    fn exact_sums_do_not_depend_on_grouping() {
        let xs = samples(5000, 7);
        let mut whole = PixelStats::default();
        xs.iter().for_each(|&v| whole.add(v));
        for cut in [1usize, 2, 777, 2500, 4999] {
            let mut a = PixelStats::default();
            xs[..cut].iter().for_each(|&v| a.add(v));
            let mut b = PixelStats {
                n: cut as u32,
                first: cut as u32,
                ..Default::default()
            };
            xs[cut..].iter().for_each(|&v| b.add(v));
            let mut ab = a;
            assert!(ab.merge(&b));
            let mut ba = b;
            assert!(ba.merge(&a));
            for m in [ab, ba] {
                assert_eq!(m.sum_even, whole.sum_even, "cut {cut}");
                assert_eq!(m.sum_odd, whole.sum_odd, "cut {cut}");
                // Squares span twice the range: Σ Y² is accurate to the pair's 2^-100, not exact.
                let (l, r) = (m.sum_lum2.value(), whole.sum_lum2.value());
                assert!(
                    (l - r).abs() <= 2f64.powi(-98) * r.abs(),
                    "cut {cut}: {l} {r}"
                );
                assert_eq!((m.n, m.first), (whole.n, whole.first));
                let bits = |p: &PixelStats| p.mean().to_array().map(f64::to_bits);
                assert_eq!(bits(&m), bits(&whole));
                assert_eq!((m.n_even(), m.n_odd()), (whole.n_even(), whole.n_odd()));
            }
        }
        // The sum is the exactly rounded real sum: compare with a sum in i128 fixed point
        // (every value here is a multiple of 2^-54 below 2^30).
        let fixed: i128 = xs
            .iter()
            .map(|v| (v.x as f64 * 2f64.powi(60)) as i128)
            .sum();
        let exact = fixed as f64 / 2f64.powi(60);
        let mut s = ExactSum::default();
        xs.iter().for_each(|v| s.add(v.x as f64));
        assert_eq!(s.value(), exact);
        // A plain f64 sum in another order differs: the test can tell.
        let fwd: f64 = xs.iter().map(|v| v.x as f64).sum();
        let rev: f64 = xs.iter().rev().map(|v| v.x as f64).sum();
        assert_ne!(fwd.to_bits(), rev.to_bits());
    }

    #[test]
    fn merge_refuses_ranges_that_do_not_meet() {
        let mut a = Film::starting_at(2, 1, 0);
        let mut b = Film::starting_at(2, 1, 8);
        a.pixels
            .iter_mut()
            .for_each(|p| (0..4).for_each(|_| p.add(Vec3::ONE)));
        b.pixels
            .iter_mut()
            .for_each(|p| (0..4).for_each(|_| p.add(Vec3::ONE)));
        let before = a.clone();
        let err = a.merge(&b).unwrap_err();
        assert!(
            err.contains("pixel (0, 0): samples 0..4 and 8..12"),
            "{err}"
        );
        assert_eq!(a, before);
        assert!(
            a.merge(&Film::new(3, 1))
                .unwrap_err()
                .contains("sizes differ")
        );
    }
}
