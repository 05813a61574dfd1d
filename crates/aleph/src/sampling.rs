//! Warps from the unit square to the domains the path tracer samples, with their pdfs and
//! inverses (the triples of Mitsuba's `core/warp.h` and pbrt-v4's `util/sampling.h`), plus a
//! discrete distribution and the MIS power heuristic.
//!
//! Conventions: directions are in a local shading frame where the normal is +z; the pdf of a
//! direction is per unit solid angle (sr⁻¹); the pdf of a point is per unit area.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Cosine-weighted direction on the +z hemisphere (Malley's method over a concentric disk).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Solid-angle pdf of [`square_to_cosine_hemisphere`]: cos θ / π on the upper hemisphere.
#[inline]
pub fn square_to_cosine_hemisphere_pdf(w: Vec3) -> f32 {
    if w.z > 0.0 { w.z * FRAC_1_PI } else { 0.0 }
}

/// Inverse of [`square_to_cosine_hemisphere`].
#[inline]
pub fn cosine_hemisphere_to_square(w: Vec3) -> Vec2 {
    concentric_disk_to_square(Vec2::new(w.x, w.y))
}

/// Shirley–Chiu concentric map from [0,1)² to the unit disk.
#[inline]
pub fn square_to_concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, PI / 4.0 * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - PI / 4.0 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Inverse of [`square_to_concentric_disk`].
#[inline]
pub fn concentric_disk_to_square(p: Vec2) -> Vec2 {
    let r = p.length();
    let mut phi = p.y.atan2(p.x);
    if phi < -PI / 4.0 {
        phi += 2.0 * PI;
    }
    let (a, b) = if phi < PI / 4.0 {
        (r, phi * a_inv(r))
    } else if phi < 3.0 * PI / 4.0 {
        (-(phi - PI / 2.0) * a_inv(r), r)
    } else if phi < 5.0 * PI / 4.0 {
        (-r, -(phi - PI) * a_inv(r))
    } else {
        ((phi - 3.0 * PI / 2.0) * a_inv(r), -r)
    };
    fn a_inv(r: f32) -> f32 {
        4.0 * r / PI
    }
    Vec2::new(0.5 * (a + 1.0), 0.5 * (b + 1.0))
}

/// Uniform point on a triangle as barycentrics (b0, b1); b2 = 1 − b0 − b1. Area pdf 1/area.
/// Heitz 2019, "A Low-Distortion Map Between Triangle and Square" (the map of pbrt-v4's
/// `SampleUniformTriangle`): the square's two halves either side of its diagonal are sheared
/// onto the triangle, so a stratified set of points stays stratified on it. Against the
/// square-root map (Mitsuba 3's `square_to_uniform_triangle`) on the Cornell box (256², depth
/// 8, seeds 1–4, relMSE against an 8192-spp Mitsuba reference): 0.00695 / 0.00140 at 16 / 64
/// spp against 0.00698 / 0.00140, lower or equal for every seed, and no square root.
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    if u.x < u.y {
        let b0 = 0.5 * u.x;
        Vec2::new(b0, u.y - b0)
    } else {
        let b1 = 0.5 * u.y;
        Vec2::new(u.x - b1, b1)
    }
}

/// Inverse of [`square_to_uniform_triangle`].
#[inline]
pub fn uniform_triangle_to_square(b: Vec2) -> Vec2 {
    if b.x < b.y {
        Vec2::new(2.0 * b.x, b.y + b.x)
    } else {
        Vec2::new(b.x + b.y, 2.0 * b.y)
    }
}

/// Uniform direction on the unit sphere; pdf 1/(4π).
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Veach's power heuristic with β = 2 for two strategies taking one sample each (Veach 1997,
/// eq. 9.13): w_f = f² / (f² + g²). Returns 0 when both pdfs are 0; an infinite `f` (a delta
/// strategy) gets weight 1.
#[inline]
pub fn power_heuristic(pdf_f: f32, pdf_g: f32) -> f32 {
    if pdf_f.is_infinite() {
        return 1.0;
    }
    let f2 = pdf_f * pdf_f;
    let g2 = pdf_g * pdf_g;
    if f2 + g2 > 0.0 { f2 / (f2 + g2) } else { 0.0 }
}

/// A discrete distribution over `n` items with given non-negative weights, sampled by inverting
/// its cumulative distribution: a guide table (Chen & Asau 1974, "On generating random
/// variates from an empirical distribution", AIIE Transactions 6(2); Devroye 1986,
/// *Non-Uniform Random Variate Generation* §III.2.4) narrows the binary search to the items
/// between two table entries, so a draw reads about two cache lines instead of log₂ n.
///
/// Layout: `cells[i]` holds the CDF before item i and item i's probability side by side
/// (`n + 1` cells, the last one's CDF 1), so the search's last probe, the inversion within the
/// item and its probability share a cache line; `guide[k]` (G + 1 entries, G the power of two
/// at or above n, at most 2²⁰) is the item a draw of u = k / G returns (exact in f32).
#[derive(Clone, Debug)]
pub struct Distribution1D {
    cells: Vec<Cell>,
    guide: Vec<u32>,
    total: f64,
}

/// One item of a [`Distribution1D`]: the normalised CDF before it (`cdf[0] = 0`, the extra
/// last cell's 1) and its probability, weight / total (in f64, then rounded), kept so that
/// sampling does not divide.
#[derive(Clone, Copy, Debug)]
struct Cell {
    cdf: f32,
    pmf: f32,
}

/// Largest guide table of a [`Distribution1D`], entries (4 MiB).
const GUIDE_MAX: usize = 1 << 20;

impl Distribution1D {
    /// Builds the distribution. Returns `None` if there are no items or the weights sum to zero
    /// (or any weight is negative or not finite).
    pub fn new(weights: Vec<f32>) -> Option<Self> {
        if weights.is_empty() || weights.iter().any(|w| !w.is_finite() || *w < 0.0) {
            return None;
        }
        let mut sums = Vec::with_capacity(weights.len() + 1);
        let mut acc = 0.0f64;
        sums.push(0.0);
        for w in &weights {
            acc += *w as f64;
            sums.push(acc);
        }
        if acc <= 0.0 {
            return None;
        }
        // Weights near f32::MAX sum past it: the partial sums are scaled by a power of two
        // (exact, so the result is the same bits as unscaled wherever that fits in f32).
        let scale = pow2_scale(acc);
        let mut cdf: Vec<f32> = sums
            .iter()
            .map(|&c| ((c * scale) as f32 as f64 / (acc * scale)) as f32)
            .collect();
        *cdf.last_mut().unwrap() = 1.0;
        let cells = cdf
            .iter()
            .zip(
                weights
                    .iter()
                    .map(|&w| (w as f64 / acc) as f32)
                    .chain([0.0]),
            )
            .map(|(&cdf, pmf)| Cell { cdf, pmf })
            .collect();
        let mut d = Distribution1D {
            cells,
            guide: Vec::new(),
            total: acc,
        };
        let g = weights.len().next_power_of_two().min(GUIDE_MAX);
        d.guide = (0..=g)
            .map(|k| d.search(k as f32 / g as f32, 0, weights.len() - 1) as u32)
            .collect();
        Some(d)
    }

    /// The first item i in `lo..=hi` with CDF after it above `u`, or `hi` (binary search);
    /// the item a draw of `u` picks when it lies in `lo..=hi`.
    #[inline]
    fn search(&self, u: f32, mut lo: usize, mut hi: usize) -> usize {
        while lo < hi {
            let mid = (lo + hi) / 2;
            if self.cells[mid + 1].cdf > u {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        lo
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.cells.len() - 1
    }

    /// Always false: an empty distribution cannot be built.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sum of the weights.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Probability of item `i`.
    ///
    /// # Panics
    /// If `i` is not an item (`i ≥ len()`).
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        assert!(i < self.len(), "item {i} of {}", self.len());
        self.cells[i].pmf
    }

    /// Samples an item for `u` in [0,1): returns the item and its probability. Items with zero
    /// weight are never returned.
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32) {
        // First index with cdf[i+1] > u. The item is non-decreasing in u, and G · u is exact
        // (G a power of two), so for k/G ≤ u < (k+1)/G it lies between guide[k] and
        // guide[k + 1]; outside [0, 1) (never drawn) the whole range is searched as before.
        let n = self.len();
        let g = self.guide.len() - 1;
        let mut i = if (0.0..1.0).contains(&u) {
            let k = (u * g as f32) as usize;
            self.search(u, self.guide[k] as usize, self.guide[k + 1] as usize)
        } else {
            self.search(u, 0, n - 1)
        };
        // Skip zero-weight items that a rounding tie could land on.
        while self.cells[i].pmf == 0.0 && i + 1 < n {
            i += 1;
        }
        while self.cells[i].pmf == 0.0 && i > 0 {
            i -= 1;
        }
        (i, self.pmf(i))
    }

    /// The cumulative probability of the items before item `i` (`i` ≤ the number of items).
    #[inline]
    pub fn cdf(&self, i: usize) -> f32 {
        self.cells[i].cdf
    }

    /// Samples an item for `u` ∈ [0, 1) and returns it, its probability, and `u` remapped to
    /// [0, 1) within the item's share of the CDF (so one number can drive a further choice).
    #[inline]
    pub fn sample_remap(&self, u: f32) -> (usize, f32, f32) {
        let (i, pmf) = self.sample(u);
        (i, pmf, self.remap(i, u))
    }

    /// `u` remapped to [0, 1) within item `i`'s share of the CDF, for the item `u` chose
    /// ([`Distribution1D::sample_remap`]).
    #[inline]
    pub fn remap(&self, i: usize, u: f32) -> f32 {
        let (c0, c1) = (self.cells[i].cdf, self.cells[i + 1].cdf);
        let r = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.5 };
        r.clamp(0.0, 1.0 - f32::EPSILON)
    }

    /// Samples the piecewise-constant density on [0, 1) whose n equal cells carry the weights:
    /// returns the point x, its density p(x) = n · pmf(i) and the cell i. Inverting the CDF
    /// inside the cell keeps stratification of `u` (pbrt-v4's `PiecewiseConstant1D::Sample`).
    #[inline]
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        let (i, pmf) = self.sample(u);
        let (c0, c1) = (self.cells[i].cdf, self.cells[i + 1].cdf);
        let n = self.len();
        (point_in_cell(u, i, c0, c1, n), pmf * n as f32, i)
    }

    /// The density at x ∈ [0, 1) of [`Distribution1D::sample_continuous`].
    #[inline]
    pub fn density(&self, x: f32) -> f32 {
        let n = self.len();
        let i = ((x * n as f32) as usize).min(n - 1);
        self.pmf(i) * n as f32
    }
}

/// The point of [`Distribution1D::sample_continuous`] for `u` in cell `i` of `n`, whose CDF
/// runs from `c0` to `c1`: (i + (u − c0) / (c1 − c0)) / n, kept inside the cell.
#[inline]
fn point_in_cell(u: f32, i: usize, c0: f32, c1: f32, n: usize) -> f32 {
    let du = if c1 > c0 {
        ((u - c0) / (c1 - c0)).clamp(0.0, 1.0)
    } else {
        0.5
    };
    let n = n as f32;
    let mut x = ((i as f32 + du) / n).min(1.0 - f32::EPSILON / 2.0);
    // Rounding can carry a point at either end of its cell into the neighbour (du = 1
    // where u lies within an ulp of the cell's upper CDF; (i + du) / n · n just below i):
    // step it back so that [`Distribution1D::density`] finds the cell that was sampled.
    while x > 0.0 && ((x * n) as usize) > i {
        x = x.next_down();
    }
    while ((x * n) as usize) < i {
        x = x.next_up();
    }
    x
}

/// 1, or the power of two that brings `x` (positive, finite) to at most 2¹⁰⁰, so sums of f32
/// weights can be narrowed back to f32 without overflow. Multiplying by it is exact.
fn pow2_scale(x: f64) -> f64 {
    if x <= 2f64.powi(100) {
        1.0
    } else {
        2f64.powi(100 - x.log2().ceil() as i32)
    }
}

/// A piecewise-constant density on [0, 1)², one cell per texel of a `width × height` weight
/// grid (row 0 at v = 0), sampled as a marginal over rows then a conditional within the row
/// (pbrt-v4's `PiecewiseConstant2D`).
///
/// Layout: besides each row's [`Distribution1D`], `buckets` holds every row's guide table again
/// as 16-byte `Bucket`s (row-major, `g` a row), each with the CDF values a draw in it needs,
/// so that the conditional draw reads one record instead of a guide entry and then the CDF it
/// points at: on a 1k environment map both miss the last-level cache, one after the other
/// (`perf`: the two loads were most of the time the renders of Lost Empire and the Mori knob
/// spent drawing from their maps). Memory: 8 bytes a cell in the rows, 4 in their guide
/// tables and 16 in the buckets.
#[derive(Clone, Debug)]
pub struct Distribution2D {
    rows: Vec<Distribution1D>,
    marginal: Distribution1D,
    buckets: Vec<Bucket>,
    g: usize,
}

/// One bucket k of a row's guide table: the draws u ∈ [k/G, (k+1)/G). When they can land on
/// at most two items, `lo` and `lo + 1`, both of non-zero probability, it holds `lo` and the
/// CDF before `lo`, `lo + 1` and `lo + 2` (0 past the row's end): the draw is `lo` if u is below
/// the second, else `lo + 1`, as the row's guided search would find. Otherwise `lo` has [`SLOW`]
/// set and the draw takes the row's own [`Distribution1D::sample_continuous`].
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct Bucket {
    lo: u32,
    cdf: [f32; 3],
}

/// [`Bucket::lo`]'s flag: the bucket is drawn from by the row's own search.
const SLOW: u32 = 1 << 31;

impl Bucket {
    /// Which of the bucket's items (0: `lo`, 1: `lo + 1`) a draw of `u` in it picks, or `None`
    /// if the bucket is [`SLOW`].
    #[inline]
    fn pick(&self, u: f32) -> Option<usize> {
        (self.lo & SLOW == 0).then(|| usize::from(self.cdf[1] <= u))
    }
}

impl Distribution1D {
    /// This distribution's guide table as [`Bucket`]s (G of them, G + 1 guide entries).
    fn buckets(&self) -> impl Iterator<Item = Bucket> + '_ {
        self.guide.windows(2).map(|w| {
            let (lo, hi) = (w[0] as usize, w[1] as usize);
            let fast = hi - lo <= 1 && (lo..=hi).all(|i| self.cells[i].pmf != 0.0);
            let cdf = std::array::from_fn(|j| self.cells.get(lo + j).map_or(0.0, |c| c.cdf));
            let flag = if fast { 0 } else { SLOW };
            Bucket {
                lo: lo as u32 | flag,
                cdf,
            }
        })
    }
}

impl Distribution2D {
    /// Builds from row-major non-negative weights. `None` if the sizes disagree, every weight
    /// is zero, or a row has 2³¹ cells or more.
    pub fn new(weights: &[f32], width: usize, height: usize) -> Option<Self> {
        if width == 0 || height == 0 || weights.len() != width * height || width >= 1 << 31 {
            return None;
        }
        let mut row_sums = Vec::with_capacity(height);
        let mut rows = Vec::with_capacity(height);
        for r in weights.chunks_exact(width) {
            row_sums.push(r.iter().map(|&w| w as f64).sum::<f64>());
            // A row of zeros still needs a valid (never chosen) distribution.
            rows.push(
                Distribution1D::new(r.to_vec())
                    .or_else(|| Distribution1D::new(vec![1.0; width]))?,
            );
        }
        // Row sums scaled by a power of two (exact) so that rows of texels near f32::MAX do
        // not narrow to infinity; a distribution is scale-free.
        let top = row_sums.iter().copied().fold(0.0f64, f64::max);
        if !top.is_finite() {
            return None;
        }
        let scale = pow2_scale(top);
        let marginal = Distribution1D::new(row_sums.iter().map(|&s| (s * scale) as f32).collect())?;
        let g = rows[0].guide.len() - 1;
        let buckets = rows.iter().flat_map(Distribution1D::buckets).collect();
        Some(Distribution2D {
            rows,
            marginal,
            buckets,
            g,
        })
    }

    /// Samples a point (u, v) ∈ [0, 1)²: the row by the marginal's
    /// [`Distribution1D::sample_continuous`], the column as the row's would (the same bits).
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec2 {
        let (v, _, r) = self.marginal.sample_continuous(u.y);
        let row = &self.rows[r];
        if let Some(b) = self.bucket(r, u.x)
            && let Some(j) = b.pick(u.x)
        {
            let i = b.lo as usize + j;
            return Vec2::new(point_in_cell(u.x, i, b.cdf[j], b.cdf[j + 1], row.len()), v);
        }
        Vec2::new(row.sample_continuous(u.x).0, v)
    }

    /// Starts loading the bucket [`Distribution2D::sample`] reads for `u`, so that a draw
    /// issued once other work is done finds it in the cache (a hint: nothing else changes).
    #[inline]
    pub fn prefetch(&self, u: Vec2) {
        if let Some(b) = self.bucket(self.marginal.sample(u.y).0, u.x) {
            crate::math::prefetch(b);
        }
    }

    /// The cell (row, column) [`Distribution2D::sample`] draws `u` from, when its bucket tells
    /// it alone (`None` where the draw takes the row's own search).
    #[inline]
    pub fn cell(&self, u: Vec2) -> Option<(usize, usize)> {
        let r = self.marginal.sample(u.y).0;
        let b = self.bucket(r, u.x)?;
        b.pick(u.x).map(|j| (r, b.lo as usize + j))
    }

    /// The bucket of row `r` a draw of `u` reads (`None` outside [0, 1), where the row searches
    /// all of its items).
    #[inline]
    fn bucket(&self, r: usize, u: f32) -> Option<&Bucket> {
        // k ≤ g − 1: u · g is exact (g a power of two) and below g.
        (0.0..1.0)
            .contains(&u)
            .then(|| &self.buckets[r * self.g + (u * self.g as f32) as usize])
    }

    /// The density at (u, v) ∈ [0, 1)² of [`Distribution2D::sample`].
    pub fn density(&self, p: Vec2) -> f32 {
        let h = self.rows.len();
        let r = ((p.y * h as f32) as usize).min(h - 1);
        self.marginal.density(p.y) * self.rows[r].density(p.x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn cosine_hemisphere_round_trip() {
        let mut rng = Rng::new(1, 1);
        for _ in 0..10_000 {
            let u = rng.uniform2();
            let w = square_to_cosine_hemisphere(u);
            assert!((w.length() - 1.0).abs() < 1e-4);
            let back = cosine_hemisphere_to_square(w);
            assert!(
                (back - u).abs().max_element() < 2e-3,
                "{u:?} -> {w:?} -> {back:?}"
            );
        }
    }

    #[test]
    fn triangle_round_trip_and_inside() {
        let mut rng = Rng::new(2, 1);
        for _ in 0..10_000 {
            let u = rng.uniform2();
            let b = square_to_uniform_triangle(u);
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            let back = uniform_triangle_to_square(b);
            assert!((back - u).abs().max_element() < 1e-3);
        }
    }

    #[test]
    fn distribution_matches_weights() {
        let d = Distribution1D::new(vec![1.0, 0.0, 3.0, 4.0]).unwrap();
        let mut counts = [0usize; 4];
        let mut rng = Rng::new(3, 1);
        let n = 400_000;
        for _ in 0..n {
            let (i, p) = d.sample(rng.uniform());
            assert!((p - d.pmf(i)).abs() < 1e-7);
            counts[i] += 1;
        }
        assert_eq!(counts[1], 0);
        for (i, &c) in counts.iter().enumerate() {
            let p = d.pmf(i) as f64;
            let sd = (n as f64 * p * (1.0 - p)).sqrt();
            assert!((c as f64 - n as f64 * p).abs() <= 5.0 * sd + 1.0);
        }
        assert!(Distribution1D::new(vec![0.0, 0.0]).is_none());
        assert!(Distribution1D::new(vec![]).is_none());
    }

    /// The item a draw picks, by a linear scan of the CDF (the definition the guided binary
    /// search must reproduce): the first item whose CDF after it exceeds `u` (the last if
    /// none), moved off zero-weight items forwards, then backwards.
    fn scanned(d: &Distribution1D, u: f32) -> usize {
        let n = d.len();
        let mut i = (0..n).find(|&i| d.cdf(i + 1) > u).unwrap_or(n - 1);
        while d.pmf(i) == 0.0 && i + 1 < n {
            i += 1;
        }
        while d.pmf(i) == 0.0 && i > 0 {
            i -= 1;
        }
        i
    }

    #[test]
    fn guided_search_picks_the_item_of_a_linear_scan() {
        let mut rng = Rng::new(17, 4);
        for n in [1usize, 2, 3, 5, 64, 100, 1000, 1025] {
            // Runs of zeros, a few heavy items and tiny ones, as an environment map's rows.
            let w: Vec<f32> = (0..n)
                .map(|i| match i % 7 {
                    0 | 1 => 0.0,
                    2 => 1e3 * rng.uniform(),
                    _ => 1e-3 * rng.uniform(),
                })
                .map(|x| if n < 3 { 1.0 + x } else { x })
                .collect();
            let d = Distribution1D::new(w).unwrap();
            let g = d.guide.len() - 1;
            // Uniform draws, every guide boundary k/G and its neighbours, every CDF value and
            // its neighbours, and the ends.
            let mut us: Vec<f32> = (0..20_000).map(|_| rng.uniform()).collect();
            for k in 0..g {
                let b = k as f32 / g as f32;
                us.extend([b, b.next_down(), b.next_up()]);
            }
            for i in 0..=n {
                let c = d.cdf(i);
                us.extend([c, c.next_down(), c.next_up()]);
            }
            us.extend([0.0, 1.0f32.next_down()]);
            for u in us.into_iter().filter(|u| (0.0..1.0).contains(u)) {
                let (i, p) = d.sample(u);
                assert_eq!(i, scanned(&d, u), "n = {n}, u = {u}");
                assert_eq!(p, d.pmf(i));
            }
        }
    }

    #[test]
    fn a_2d_draw_through_the_buckets_is_the_rows_own_draw() {
        // Rows as an environment map's: runs of zeros (buckets spanning many items), heavy
        // items (many buckets each), tiny ones, a row of zeros; widths a power of two and not.
        let mut rng = Rng::new(41, 9);
        for (w, h) in [
            (1usize, 3usize),
            (2, 2),
            (5, 4),
            (64, 8),
            (100, 6),
            (1024, 3),
        ] {
            let weights: Vec<f32> = (0..w * h)
                .map(|i| match (i / w, i % 7) {
                    (1, _) if h > 2 => 0.0,
                    (_, 0 | 1) if w > 2 => 0.0,
                    (_, 2) => 1e3 * rng.uniform(),
                    _ => 1e-3 + 1e-3 * rng.uniform(),
                })
                .collect();
            let d = Distribution2D::new(&weights, w, h).unwrap();
            let fast = d.buckets.iter().filter(|b| b.lo & SLOW == 0).count();
            if w > 2 {
                assert!(
                    fast > 0 && fast < d.buckets.len(),
                    "{w}×{h}: {fast} fast buckets"
                );
            }
            let mut xs: Vec<f32> = (0..4000).map(|_| rng.uniform()).collect();
            for k in 0..d.g {
                let b = k as f32 / d.g as f32;
                xs.extend([b, b.next_down(), b.next_up()]);
            }
            for row in &d.rows {
                for i in 0..=row.len() {
                    let c = row.cdf(i);
                    xs.extend([c, c.next_down(), c.next_up()]);
                }
            }
            xs.extend([0.0, 1.0f32.next_down()]);
            for (j, x) in xs
                .into_iter()
                .filter(|x| (0.0..1.0).contains(x))
                .enumerate()
            {
                let u = Vec2::new(x, ((j as f32 + 0.5) * 0.618_034).fract());
                let (v, pv, r) = d.marginal.sample_continuous(u.y);
                let (want, pu, c) = d.rows[r].sample_continuous(u.x);
                let p = d.sample(u);
                assert_eq!(
                    (p.x.to_bits(), p.y.to_bits()),
                    (want.to_bits(), v.to_bits())
                );
                assert_eq!(d.density(p), pv * pu, "{w}×{h} at {u}");
                if let Some(cell) = d.cell(u) {
                    assert_eq!(cell, (r, c), "{w}×{h} at {u}");
                }
            }
        }
    }

    #[test]
    fn a_continuous_sample_lies_in_the_cell_whose_density_it_reports() {
        // Draws within an ulp of a cell's upper CDF round du to 1 and (i + 1) / n: the point
        // then sat on the next cell's start, where `density` finds the next cell.
        let mut rng = Rng::new(29, 3);
        for n in [3usize, 16, 100, 1024] {
            let w: Vec<f32> = (0..n).map(|_| 0.01 + rng.uniform()).collect();
            let d = Distribution1D::new(w).unwrap();
            for i in 0..n {
                let c = d.cdf(i + 1);
                for u in [c.next_down(), c.next_down().next_down(), d.cdf(i)] {
                    if !(0.0..1.0).contains(&u) {
                        continue;
                    }
                    let (x, p, cell) = d.sample_continuous(u);
                    assert_eq!(
                        ((x * n as f32) as usize).min(n - 1),
                        cell,
                        "n {n} u {u} x {x}"
                    );
                    assert_eq!(p, d.density(x), "n {n} u {u} x {x}");
                }
            }
        }
    }

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (0.3, 0.0), (5.0, 5.0)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
        }
    }
}
