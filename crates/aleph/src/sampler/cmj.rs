//! Correlated multi-jittered sampling (Kensler 2013, "Correlated Multi-Jittered Sampling",
//! Pixar Technical Memo 13-01) for a pixel whose number of samples N is known before it is
//! rendered (a uniform render, or a part of one): each dimension pair is an m × r jittered grid
//! whose points are also stratified into m r strata along each axis, the columns' sub-strata
//! shuffled by one permutation and the rows' by another ("correlated"), and the samples visit
//! the cells in an order of their own (padding, so the pairs are independent of each other); a
//! single dimension is N jittered strata in an order of its own.
//!
//! The grid is m × r = N exactly where N has a divisor m ≤ √N no smaller than half of ⌊√N⌋
//! (every power of two: 512 = 16 × 32); otherwise (a prime N, say) m = ⌊√N⌋, r = ⌈N / m⌉, and
//! the m r − N cells no sample visits are a random set: the grid's columns and rows are
//! shuffled per pixel and dimension pair, so every point is uniform on the square and the
//! estimate unbiased. (The first version had neither: its grid was ⌊√N⌋ × ⌈N / ⌊√N⌋⌉ and its
//! empty cells always the last row's, so at 512 spp, as 22 × 24, a strip of 3 % of the square
//! was never sampled, and uniform renders at 32, 128 and 512 spp were biased.)
//!
//! Kensler draws the permutations with a hash per sample; here they are drawn once per pixel
//! and dimension (Fisher–Yates shuffles from PCG32, [`CmjTable::new`]) and read per sample,
//! as a hashed permutation costs 33–43 ns a point against 9–13 for a Sobol' point. The table
//! depends on the seed, the pixel, the dimension and N only, so every part of a split render
//! draws the same points.
//!
//! Why: on discontinuous integrands of the unit square (random half-planes and discs, 20 000
//! point sets a size) Owen-scrambled Sobol' ([`super::sobol`]) has 1.14–1.20× the variance of
//! this pattern at 16–256 points; a path tracer's error is mostly such edges and penumbrae.
//!
//! **Deep dimensions** ([`CMJ_DEEP_DIMENSIONS`]). The first [`CMJ_DIMENSIONS`] dimensions have
//! patterns of their own (their permutations cost about two random numbers a point at N = 16:
//! giving every dimension one cost 1.12× the CPU time for 20 dimensions, 1.24× for all).
//! Past them, a path's later bounces draw from one more pattern, the pixel's *base* pattern:
//! each deep dimension lays out the base pattern's N points in an order of its own and
//! rotated by an offset of its own, once per pixel when a sample first uses it, and its
//! samples read them. Measured on the Cornell box (256², depth 8, seeds 1–8, the 8192-spp
//! Mitsuba reference of `benches/peer/`), relMSE at 16 / 64 spp: PCG32 past dimension 10
//! 0.006726 / 0.001332 (± 0.000031 / 0.000007), deep dimensions from the base pattern
//! 0.006561 / 0.001274 (± 0.000034 / 0.000006), −2.5 % / −4.4 %, level with Mitsuba 3's
//! `multijitter` (0.00656 / 0.00130), for 1.01–1.04× the CPU time (paired whole processes, 9
//! and 5 pairs), so the time to equal relMSE is unchanged (0.99–1.01×). Lost Empire (240×150,
//! its own 1024-spp reference, seeds 1–4): 0.002863 / 0.000564 → 0.002852 / 0.000560 for
//! 1.015× the CPU time; the holodeck (160²): 0.001245 / 0.000275 → 0.001221 / 0.000272 for
//! 1.02×. Tried first and dropped: patterns of their own for 20 dimensions (0.006631 /
//! 0.001296 for 1.05–1.07×), and the base points read through a stored order and rotated per
//! sample (1.09×). A farm part of a uniform render (`--part`) lays out every deep dimension its
//! samples use, as the whole render does.

use super::{Padded, PaddedPattern};
use crate::rng::{Rng, mix64};
use glam::Vec2;
use std::cell::{Cell, OnceCell, RefCell};

/// Dimensions with patterns of their own in the pixel's table (the first bounces of a path),
/// as many as [`super::sobol::QMC_DIMENSIONS`]; then [`CMJ_DEEP_DIMENSIONS`].
pub const CMJ_DIMENSIONS: u32 = super::sobol::QMC_DIMENSIONS;

/// Dimensions below this and from [`CMJ_DIMENSIONS`] on (a path's later bounces) are drawn
/// from the pixel's base pattern, one more correlated multi-jittered pattern of N points,
/// each dimension visiting its points in an order of its own (padding) and shifted by an
/// offset of its own modulo 1 (a Cranley–Patterson rotation, which keeps each point in a
/// stratum of its own on the torus; a single dimension takes the points' first coordinates,
/// which lie in N strata): stratified like the first dimensions for about what PCG32 costs
/// (see the module docs, "Deep dimensions"). The rest from PCG32.
pub const CMJ_DEEP_DIMENSIONS: u32 = 64;

/// Largest N whose deep dimensions come from the base pattern (their points take
/// 8 · ([`CMJ_DEEP_DIMENSIONS`] − [`CMJ_DIMENSIONS`]) · N bytes a pixel being rendered, 7 MB
/// here); above it they come from PCG32, so that a pixel's table stays within that memory
/// (a render of a million samples a pixel would otherwise hold 430 MB a thread).
pub const CMJ_DEEP_MAX_SAMPLES: u32 = 16_384;

/// One dimension's permutations, drawn when a sample first uses the dimension: the samples'
/// order over the cells, and where the dimension starts a pair the grid's columns and rows and
/// their sub-strata.
#[derive(Clone, Debug, Default)]
struct Dimension {
    order: OnceCell<Vec<u32>>,
    strata: OnceCell<Strata>,
    /// Key of the samples' jitters in this dimension.
    jitter: u64,
}

/// A dimension pair's permutations: where the grid's columns and rows go, and the sub-strata
/// (along the other axis) of each column and of each row.
#[derive(Clone, Debug)]
struct Strata {
    column_at: Vec<u32>,
    row_at: Vec<u32>,
    columns: Vec<u32>,
    rows: Vec<u32>,
}

/// The grid m × r of `total` samples: m r = N with the divisor m ≤ √N nearest √N, unless that
/// is below half of ⌊√N⌋; then m = ⌊√N⌋ and r = ⌈N / m⌉ (m r ≥ N).
fn grid(total: u32) -> (u32, u32) {
    let root = ((total as f64).sqrt() as u32).max(1);
    let m = (1..=root)
        .rev()
        .find(|&m| total.is_multiple_of(m))
        .unwrap_or(1);
    let m = if 2 * m >= root { m } else { root };
    (m, total.div_ceil(m))
}

/// A pixel's correlated multi-jittered patterns, one per dimension below [`CMJ_DIMENSIONS`].
#[derive(Clone, Debug)]
pub struct CmjTable {
    total: u32,
    m: u32,
    r: u32,
    seed: u64,
    pixel: u64,
    dims: Vec<Dimension>,
    key: (u64, u64),
    /// The base pattern's N points (its permutations those of dimension slot
    /// [`CMJ_DIMENSIONS`]), made when a sample first goes past [`CMJ_DIMENSIONS`].
    base: OnceCell<Vec<Vec2>>,
    /// The deep dimensions' points, N each from dimension [`CMJ_DIMENSIONS`] on, in one
    /// buffer (taken from this thread's pool, sized when first used); bit k of `deep_drawn`:
    /// dimension [`CMJ_DIMENSIONS`] + k laid out.
    deep: RefCell<Vec<Vec2>>,
    deep_drawn: Cell<u64>,
}

/// Deep dimensions, past the patterns of their own.
const DEEP: usize = (CMJ_DEEP_DIMENSIONS - CMJ_DIMENSIONS) as usize;
const _: () = assert!(DEEP <= 64, "one bit a deep dimension");

/// A uniformly random permutation of 0..n (Fisher–Yates, Lemire's multiply-shift for the
/// index).
fn shuffled(n: u32, rng: &mut Rng) -> Vec<u32> {
    let mut v: Vec<u32> = (0..n).collect();
    for i in (1..n as usize).rev() {
        let j = ((rng.next_u32() as u64 * (i as u64 + 1)) >> 32) as usize;
        v.swap(i, j);
    }
    v
}

impl CmjTable {
    /// The patterns of pixel `pixel_index` under `seed` for `total` samples (at least 1).
    pub fn new(seed: u64, pixel_index: u64, total: u32) -> CmjTable {
        let total = total.max(1);
        let (m, r) = grid(total);
        CmjTable {
            total,
            m,
            r,
            seed,
            pixel: pixel_index,
            // The last slot is the base pattern's.
            dims: (0..=CMJ_DIMENSIONS as u64)
                .map(|d| Dimension {
                    jitter: mix64(
                        seed ^ mix64(pixel_index ^ d.wrapping_mul(0xA076_1D64_78BD_642F)),
                    ),
                    ..Dimension::default()
                })
                .collect(),
            key: (seed ^ 0x243F_6A88_85A3_08D3, pixel_index),
            base: OnceCell::new(),
            deep: RefCell::new(POOL.with(|p| p.borrow_mut().pop()).unwrap_or_default()),
            deep_drawn: Cell::new(0),
        }
    }

    /// The base pattern's points, made when first needed.
    fn base(&self) -> &[Vec2] {
        self.base.get_or_init(|| {
            (0..self.total)
                .map(|s| self.point(CMJ_DIMENSIONS as usize, s))
                .collect()
        })
    }

    /// Deep dimensions `d`, `d + 1` (`d` ≥ [`CMJ_DIMENSIONS`]) of sample `s`: the base
    /// pattern's points in the dimension's order, rotated by its offset, laid out when a
    /// sample first uses the dimension.
    #[inline]
    fn deep_pair(&self, d: usize, s: u32) -> Vec2 {
        let k = d - CMJ_DIMENSIONS as usize;
        let n = self.total as usize;
        if self.deep_drawn.get() & (1 << k) == 0 {
            self.lay_out(d);
        }
        self.deep.borrow()[k * n + s as usize]
    }

    /// Lays out deep dimension `d`: the base points rotated by the dimension's offset modulo 1
    /// and shuffled (the inside-out form of the Fisher–Yates shuffle, two 32-bit indices from
    /// each SplitMix64 output of the dimension's own key), in one pass.
    #[cold]
    fn lay_out(&self, d: usize) {
        let k = d - CMJ_DIMENSIONS as usize;
        let n = self.total as usize;
        let base = self.base();
        let key = mix64(self.seed ^ 0xBB67_AE85_84CA_A73B ^ mix64(self.pixel ^ (d as u64) << 40));
        let (sx, sy) = two_units(mix64(key));
        let shift = Vec2::new(sx, sy);
        let mut deep = self.deep.borrow_mut();
        // Sized at the pixel's first deep dimension (a pooled buffer of the right size is
        // kept as it is: every entry of a dimension is written before it is read).
        deep.resize(DEEP * n, Vec2::ZERO);
        let out = &mut deep[k * n..(k + 1) * n];
        let mut bits = 0u64;
        for i in 0..n {
            let u = if i % 2 == 0 {
                bits = mix64(key ^ (i as u64 + 1));
                bits as u32
            } else {
                (bits >> 32) as u32
            };
            let j = ((u as u64 * (i as u64 + 1)) >> 32) as usize;
            let b = base[i];
            out[i] = out[j];
            out[j] = Vec2::new(rotate(b.x, shift.x), rotate(b.y, shift.y));
        }
        self.deep_drawn.set(self.deep_drawn.get() | 1 << k);
    }

    /// Deep dimension `d` of sample `s`: the first coordinate of its point (the base
    /// pattern's N first coordinates lie in N strata).
    #[inline]
    fn deep_value(&self, d: usize, s: u32) -> f32 {
        self.deep_pair(d, s).x
    }

    /// The PCG32 stream of dimension `d`'s permutations (`part` 0: the order, 1: the strata).
    fn rng(&self, d: usize, part: u64) -> Rng {
        Rng::for_sample(
            self.seed ^ 0x6A09_E667_F3BC_C909,
            self.pixel,
            2 * d as u64 + part,
        )
    }

    fn order(&self, d: usize) -> &[u32] {
        self.dims[d]
            .order
            .get_or_init(|| shuffled(self.total, &mut self.rng(d, 0)))
    }

    fn strata(&self, d: usize) -> &Strata {
        self.dims[d].strata.get_or_init(|| {
            let mut rng = self.rng(d, 1);
            let columns = shuffled(self.m, &mut rng);
            let rows = shuffled(self.r, &mut rng);
            Strata {
                column_at: shuffled(self.m, &mut rng),
                row_at: shuffled(self.r, &mut rng),
                columns,
                rows,
            }
        })
    }

    /// Two 24-bit jitters in [0, 1) of sample `s` in dimension `d`.
    #[inline]
    fn jitter(&self, d: usize, s: u32) -> (f32, f32) {
        two_units(mix64(self.dims[d].jitter ^ s as u64))
    }

    /// Point `s` (< N) of the pattern starting at dimension `d`.
    #[inline]
    fn point(&self, d: usize, s: u32) -> Vec2 {
        let cell = self.order(d)[s as usize];
        let st = self.strata(d);
        let (row, col) = ((cell / self.m) as usize, (cell % self.m) as usize);
        let (jx, jy) = self.jitter(d, s);
        let (m, r) = (self.m as f32, self.r as f32);
        let x = (st.column_at[col] as f32 + (st.rows[row] as f32 + jx) / r) / m;
        let y = (st.row_at[row] as f32 + (st.columns[col] as f32 + jy) / m) / r;
        Vec2::new(x.min(ONE_BELOW), y.min(ONE_BELOW))
    }

    /// Value `s` (< N) of the single dimension `d`.
    #[inline]
    fn value(&self, d: usize, s: u32) -> f32 {
        let (j, _) = self.jitter(d, s);
        ((self.order(d)[s as usize] as f32 + j) / self.total as f32).min(ONE_BELOW)
    }
}

/// Two 24-bit values in [0, 1) from the top and bottom bits of `j`.
#[inline]
fn two_units(j: u64) -> (f32, f32) {
    let k = 1.0 / (1u32 << 24) as f32;
    ((j >> 40) as f32 * k, (j & 0xff_ffff) as f32 * k)
}

/// `x + shift` modulo 1, below 1.
#[inline]
fn rotate(x: f32, shift: f32) -> f32 {
    let y = x + shift;
    (if y >= 1.0 { y - 1.0 } else { y }).min(ONE_BELOW)
}

/// Largest buffer kept for reuse (points): 4 MiB.
const MAX_POOLED: usize = 1 << 19;

thread_local! {
    /// Buffers of dropped tables' deep points, for the next pixel's table on this thread.
    static POOL: RefCell<Vec<Vec<Vec2>>> = const { RefCell::new(Vec::new()) };
}

impl Drop for CmjTable {
    fn drop(&mut self) {
        let v = std::mem::take(self.deep.get_mut());
        if v.capacity() > 0 && v.capacity() <= MAX_POOLED {
            // A thread holds one table at a time: a few buffers are enough.
            let _ = POOL.try_with(|p| {
                let mut p = p.borrow_mut();
                if p.len() < 4 {
                    p.push(v);
                }
            });
        }
    }
}

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// The canonical random numbers of sample `index` (< N) of a pixel whose table is `table`.
#[derive(Clone, Debug)]
pub struct CmjSampler<'a> {
    table: &'a CmjTable,
    index: u32,
    /// The dimension counter, and the PCG32 stream past [`CMJ_DIMENSIONS`].
    dims: Padded,
}

impl<'a> CmjSampler<'a> {
    /// Sample `sample_index` of the pixel of `table`.
    ///
    /// # Panics
    /// If `sample_index` is not below the table's N.
    pub fn for_sample(table: &'a CmjTable, sample_index: u64) -> Self {
        assert!(
            sample_index < table.total as u64,
            "sample beyond the pixel's N"
        );
        let (s, p) = table.key;
        CmjSampler {
            table,
            index: sample_index as u32,
            dims: Padded::new(
                if table.total <= CMJ_DEEP_MAX_SAMPLES {
                    CMJ_DEEP_DIMENSIONS
                } else {
                    CMJ_DIMENSIONS
                },
                (s, p, sample_index),
            ),
        }
    }
}

impl PaddedPattern for CmjSampler<'_> {
    #[inline]
    fn dims(&mut self) -> &mut Padded {
        &mut self.dims
    }

    #[inline]
    fn value(&self, d: u32) -> f32 {
        if d < CMJ_DIMENSIONS {
            self.table.value(d as usize, self.index)
        } else {
            self.table.deep_value(d as usize, self.index)
        }
    }

    #[inline]
    fn point(&self, d: u32) -> Vec2 {
        if d < CMJ_DIMENSIONS {
            self.table.point(d as usize, self.index)
        } else {
            self.table.deep_pair(d as usize, self.index)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    /// The points of every dimension pair: one in each cell of the m × r grid, and one in
    /// each of the m r strata of each axis (the multi-jittered property); a single dimension:
    /// one in each of its N strata. For square and non-square N.
    #[test]
    fn each_pixel_pattern_is_correlated_multi_jittered() {
        for (total, pixel) in [(16u32, 3u64), (64, 11), (12, 5), (30, 7)] {
            let table = CmjTable::new(9, pixel, total);
            let (m, r) = (table.m, table.r);
            let points: Vec<[Vec2; 2]> = (0..total as u64)
                .map(|s| {
                    let mut c = CmjSampler::for_sample(&table, s);
                    [c.uniform2(), Vec2::new(c.uniform(), 0.0)]
                })
                .collect();
            let mut cells = vec![0u32; (m * r) as usize];
            let (mut xs, mut ys) = (vec![0u32; (m * r) as usize], vec![0u32; (m * r) as usize]);
            let mut singles = vec![0u32; total as usize];
            for [p, q] in &points {
                assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
                let (cx, cy) = ((p.x * m as f32) as u32, (p.y * r as f32) as u32);
                cells[(cy * m + cx) as usize] += 1;
                xs[(p.x * (m * r) as f32) as usize] += 1;
                ys[(p.y * (m * r) as f32) as usize] += 1;
                singles[(q.x * total as f32) as usize] += 1;
            }
            assert!(
                cells.iter().all(|&c| c <= 1),
                "N {total}: a cell holds two points"
            );
            assert!(
                xs.iter().all(|&c| c <= 1) && ys.iter().all(|&c| c <= 1),
                "N {total}"
            );
            assert!(singles.iter().all(|&c| c == 1), "N {total}: a 1-D stratum");
            if m * r == total {
                assert!(cells.iter().all(|&c| c == 1));
            }
        }
    }

    /// The grid is exact (m r = N) for every power of two and near-square N, and falls back to
    /// ⌊√N⌋ columns where N's divisors are unbalanced.
    #[test]
    fn the_grid_is_exact_where_n_has_a_balanced_divisor() {
        for (n, want) in [
            (1, (1, 1)),
            (2, (1, 2)),
            (8, (2, 4)),
            (32, (4, 8)),
            (128, (8, 16)),
            (512, (16, 32)),
            (2048, (32, 64)),
            (30, (5, 6)),
            (37, (6, 7)),
            (94, (9, 11)),
        ] {
            assert_eq!(grid(n), want, "N {n}");
        }
    }

    /// Every point is uniform on the square for any N, including the N whose grid has empty
    /// cells: over 4 096 pixels the fraction of points in each corner region [a, 1) × [b, 1)
    /// is its area within 4 standard errors (independent points' standard error, which
    /// stratification only lowers). Fails on the first version's grid (⌊√N⌋ columns, the
    /// last row's cells empty, no shuffle): at N = 7, as 2 × 4, 1.5 % of the points fell in
    /// [0.4, 1) × [0.86, 1), whose area is 8.4 %.
    #[test]
    fn every_point_is_uniform_for_any_n() {
        for total in [3u32, 7, 32, 37, 94, 128] {
            let regions = [(0.4f32, 0.86f32), (0.8, 0.95), (0.0, 0.9), (0.9, 0.0)];
            let mut hits = [[0u64; 4]; 2];
            let pixels = 4096u64;
            for pixel in 0..pixels {
                let table = CmjTable::new(3, pixel, total);
                for s in 0..total as u64 {
                    let mut c = CmjSampler::for_sample(&table, s);
                    let (p, q) = (c.uniform2(), Vec2::new(c.uniform(), c.uniform()));
                    for (k, &(a, b)) in regions.iter().enumerate() {
                        hits[0][k] += (p.x >= a && p.y >= b) as u64;
                        hits[1][k] += (q.x >= a && q.y >= b) as u64;
                    }
                }
            }
            let n = (pixels * total as u64) as f64;
            for (k, &(a, b)) in regions.iter().enumerate() {
                let area = ((1.0 - a) * (1.0 - b)) as f64;
                let se = (area * (1.0 - area) / n).sqrt();
                for h in hits {
                    let f = h[k] as f64 / n;
                    assert!(
                        (f - area).abs() < 4.0 * se,
                        "N {total}, region {k}: {f} against {area}"
                    );
                }
            }
        }
    }

    /// The dimensions past the patterns of their own come from the base pattern: each deep
    /// dimension of a pixel's N samples is a rotation of N stratified values, so on the circle
    /// its sorted values are never 2/N apart (independent values at N = 16 and 64 leave a gap
    /// that wide in most pixels); and over many pixels every deep value and pair is uniform
    /// and two deep dimensions are uncorrelated (E[x y] = ¼), for N with and without an exact
    /// grid, N = 1 included (its deep dimensions differ by their rotations alone).
    #[test]
    fn deep_dimensions_are_stratified_uniform_and_uncorrelated() {
        let deep = (CMJ_DEEP_DIMENSIONS - CMJ_DIMENSIONS) as usize;
        // The widest gap between neighbouring values on the circle.
        let max_gap = |mut v: Vec<f32>| {
            v.sort_by(f32::total_cmp);
            let wrap = 1.0 - v[v.len() - 1] + v[0];
            v.windows(2).map(|w| w[1] - w[0]).fold(wrap, f32::max)
        };
        for total in [16u32, 64] {
            let mut wide = 0;
            for pixel in 0..200u64 {
                let table = CmjTable::new(5, pixel, total);
                let mut dims = vec![Vec::new(); deep];
                for s in 0..total as u64 {
                    let mut c = CmjSampler::for_sample(&table, s);
                    for _ in 0..CMJ_DIMENSIONS {
                        c.uniform();
                    }
                    for v in dims.iter_mut() {
                        v.push(c.uniform());
                    }
                }
                for v in dims {
                    let gap = max_gap(v);
                    assert!(
                        gap < 2.0 / total as f32,
                        "N {total}, pixel {pixel}: gap {gap}"
                    );
                }
                // The same test fails for independent values: count how often.
                let mut rng = Rng::for_sample(7, pixel, total as u64);
                let v: Vec<f32> = (0..total).map(|_| rng.uniform()).collect();
                wide += usize::from(max_gap(v) >= 2.0 / total as f32);
            }
            assert!(
                wide > 150,
                "N {total}: the gap test would not tell ({wide} of 200)"
            );
        }
        for total in [1u32, 3, 16, 37] {
            let pixels = 4096u64;
            let (mut inside, mut xy, mut pair_inside) = (0u64, 0.0f64, 0u64);
            let mut n = 0u64;
            for pixel in 0..pixels {
                let table = CmjTable::new(3, pixel, total);
                for s in 0..total as u64 {
                    let mut c = CmjSampler::for_sample(&table, s);
                    for _ in 0..CMJ_DIMENSIONS + 3 {
                        c.uniform();
                    }
                    let (x, y) = (c.uniform(), c.uniform());
                    let p = c.uniform2();
                    inside += u64::from(x >= 0.6);
                    pair_inside += u64::from(p.x >= 0.3 && p.y >= 0.8);
                    xy += (x * y) as f64;
                    n += 1;
                }
            }
            let nf = n as f64;
            let check = |hits: u64, area: f64, what: &str| {
                let se = (area * (1.0 - area) / nf).sqrt();
                let f = hits as f64 / nf;
                assert!(
                    (f - area).abs() < 4.0 * se,
                    "N {total}, {what}: {f} against {area}"
                );
            };
            check(inside, 0.4, "a deep value");
            check(pair_inside, 0.7 * 0.2, "a deep pair");
            // Var(x y) for independent uniforms is 7/144.
            let se = (7.0 / 144.0 / nf).sqrt();
            assert!(
                (xy / nf - 0.25).abs() < 4.0 * se,
                "N {total}: E[x y] {}",
                xy / nf
            );
        }
    }

    /// Above [`CMJ_DEEP_MAX_SAMPLES`] the deep dimensions come from PCG32: the base pattern and
    /// its points are never made (at the limit they are).
    #[test]
    fn deep_dimensions_are_bounded_in_memory() {
        for (total, made) in [
            (CMJ_DEEP_MAX_SAMPLES, true),
            (CMJ_DEEP_MAX_SAMPLES + 1, false),
        ] {
            let table = CmjTable::new(1, 2, total);
            let mut c = CmjSampler::for_sample(&table, 3);
            let v: Vec<f32> = (0..CMJ_DIMENSIONS + 4).map(|_| c.uniform()).collect();
            assert!(v.iter().all(|x| (0.0..1.0).contains(x)));
            assert_eq!(table.base.get().is_some(), made, "N {total}");
        }
    }

    /// Over many pixels the points are uniform: the mean of x, y and x y over 4 096 pixels of
    /// 16 points is within 4 standard errors of ¼ and ½.
    #[test]
    fn the_patterns_are_uniform_over_pixels() {
        let (mut sx, mut sy, mut sxy, mut k) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for pixel in 0..4096 {
            let table = CmjTable::new(1, pixel, 16);
            for s in 0..16 {
                let p = CmjSampler::for_sample(&table, s).uniform2();
                sx += p.x as f64;
                sy += p.y as f64;
                sxy += (p.x * p.y) as f64;
                k += 1.0;
            }
        }
        // Each pixel's 16 points are stratified, so the pixel means vary far less than
        // independent points; bound with the independent standard error (conservative).
        let se = (1.0 / 12.0 / k).sqrt();
        assert!((sx / k - 0.5).abs() < 4.0 * se && (sy / k - 0.5).abs() < 4.0 * se);
        assert!((sxy / k - 0.25).abs() < 4.0 * se);
    }
}
