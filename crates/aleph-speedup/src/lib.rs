#![deny(missing_docs)]
//! Equal-quality benchmarking of the samplers against a high-spp reference
//!
//! Every image is judged against the reference on the *displayed* images (one tone curve,
//! frozen from the reference, for all of them) by three measures:
//! - **FLIP** (Andersson et al. 2020, NVIDIA's metric through the `nv-flip` crate, LDR, at the
//!   viewer's pixels per degree): the mean of the error map (the headline: it is independent of
//!   aleph's own model), and its 99th percentile after a 5×5 box filter ("is there still visible
//!   noise anywhere?");
//! - aleph's own visible-pixel fraction ([`perception::metric::DiffMetric`] on display
//!   luminance, the reference setting the masking);
//! - relMSE = mean((x − ref)² / (ref² + 0.01)) over the linear RGB values.
//!
//! Speedups are read at equal score: for a target score, the samples (and wall time) each
//! sampler needed are interpolated log–log between the budgets of the sweep, and
//! speedup = uniform / perceptual (FLIP falls only as about spp^−0.4, so score differences
//! must never be quoted as savings).

mod sweep;

pub use sweep::{
    Arm, COST_SPP, OracleRow, Row, STOP_IMAGE, SpeedupError, Sweep, SweepSpec, frame_key,
    frame_list, frames_csv_header, grade_dir, image_path, reference_key, sweep,
};

use aleph::display::FrozenToneMap;
use aleph::output::encode_srgb8;
use perception::metric::DiffMetric;
use perception::threshold::ThresholdParams;
use perception::viewing::ViewingConditions;

/// The exposure latitude of the judged display: the EXR graded this many stops darker and
/// brighter than the displayed exposure is judged too (issue 12: savings must not come from
/// noise that a grade reveals).
pub const LATITUDE_EV: f64 = 2.0;

/// The grades judged beside the displayed image, in stops.
pub const GRADES_EV: [f64; 2] = [-LATITUDE_EV, LATITUDE_EV];

/// FLIP scores of an image graded by `ev` stops under the same frozen curve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GradedFlip {
    /// The grade, stops (negative: darker).
    pub ev: f64,
    /// Mean of the FLIP error map.
    pub mean: f64,
    /// 99th percentile of the FLIP map after a 5×5 box filter.
    pub p99: f64,
}

/// Scores of one image against the reference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Scores {
    /// Mean of the FLIP error map.
    pub flip_mean: f64,
    /// 99th percentile of the FLIP map after a 5×5 box filter.
    pub flip_p99: f64,
    /// Fraction of pixels aleph's metric calls visibly different.
    pub visible_fraction: f64,
    /// Relative mean squared error of the linear values.
    pub relmse: f64,
    /// FLIP at the ends of the exposure latitude ([`GRADES_EV`]: darker, then brighter).
    pub graded: [GradedFlip; 2],
}

impl Scores {
    /// CSV header of [`Scores::csv_fields`].
    pub const CSV_HEADER: &'static str = "flip_mean,flip_p99,visible_fraction,relmse,\
        flip_mean_ev-2,flip_p99_ev-2,flip_mean_ev+2,flip_p99_ev+2";

    /// The scores as CSV fields, in the order of [`Scores::CSV_HEADER`].
    pub fn csv_fields(&self) -> String {
        let (d, b) = (self.graded[0], self.graded[1]);
        format!(
            "{:.6},{:.6},{:.6},{:.8},{:.6},{:.6},{:.6},{:.6}",
            self.flip_mean,
            self.flip_p99,
            self.visible_fraction,
            self.relmse,
            d.mean,
            d.p99,
            b.mean,
            b.p99
        )
    }

    /// Field-wise `self + k · o` (the grades' `ev` are taken from `o`).
    pub fn add_scaled(&mut self, o: &Scores, k: f64) {
        self.flip_mean += k * o.flip_mean;
        self.flip_p99 += k * o.flip_p99;
        self.visible_fraction += k * o.visible_fraction;
        self.relmse += k * o.relmse;
        for (a, b) in self.graded.iter_mut().zip(&o.graded) {
            a.ev = b.ev;
            a.mean += k * b.mean;
            a.p99 += k * b.p99;
        }
    }
}

/// A score the sweep reads speedups at: its label and how to read it.
pub type Metric = (&'static str, fn(&Scores) -> f64);

/// The FLIP scores speedups are read at: mean and p99 at the displayed exposure and at both
/// ends of the latitude.
pub const METRICS: [Metric; 6] = [
    ("FLIP mean", |s| s.flip_mean),
    ("FLIP p99", |s| s.flip_p99),
    ("FLIP mean at −2 EV", |s| s.graded[0].mean),
    ("FLIP p99 at −2 EV", |s| s.graded[0].p99),
    ("FLIP mean at +2 EV", |s| s.graded[1].mean),
    ("FLIP p99 at +2 EV", |s| s.graded[1].p99),
];

/// The judge: the reference's display image, its threshold map, and the frozen tone curve.
pub struct Judge {
    width: usize,
    height: usize,
    reference: Vec<f32>,
    reference_srgb: Vec<u8>,
    reference_lum: Vec<f32>,
    frozen: FrozenToneMap,
    metric: DiffMetric,
    map: perception::threshold::ThresholdMap,
    ppd: f32,
    /// The reference at each grade of [`GRADES_EV`]: its curve and display sRGB.
    grades: Vec<(FrozenToneMap, Vec<u8>)>,
}

/// The `p`-quantile (0–1) by sorting.
pub fn quantile(v: &[f32], p: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let i = ((s.len() - 1) as f64 * p).round() as usize;
    s[i] as f64
}

impl Judge {
    /// A judge for `reference` (linear RGB, `width × height`), displayed with `frozen` and seen
    /// under `view`.
    ///
    /// # Errors
    /// From the perception models.
    pub fn new(
        reference: Vec<f32>,
        width: usize,
        height: usize,
        frozen: FrozenToneMap,
        view: ViewingConditions,
    ) -> perception::Result<Judge> {
        let display = frozen.map(&reference)?;
        let reference_srgb = encode_srgb8(&display);
        let reference_lum = frozen.display_luminance(&reference)?;
        let metric = DiffMetric::new(width, height, view, ThresholdParams::default(), 100)?;
        let map = metric.reference_map(&reference_lum)?;
        let grades = GRADES_EV
            .iter()
            .map(|&ev| {
                let g = frozen.graded(ev);
                let srgb = encode_srgb8(&g.map(&reference)?);
                Ok((g, srgb))
            })
            .collect::<perception::Result<Vec<_>>>()?;
        Ok(Judge {
            grades,
            width,
            height,
            reference,
            reference_srgb,
            reference_lum,
            frozen,
            metric,
            map,
            ppd: view.ppd as f32,
        })
    }

    /// The display sRGB of an image under the frozen curve.
    ///
    /// # Errors
    /// From the tone operator.
    pub fn display_srgb(&self, rgb: &[f32]) -> perception::Result<Vec<u8>> {
        Ok(encode_srgb8(&self.frozen.map(rgb)?))
    }

    /// FLIP error map of an image against the reference.
    ///
    /// # Errors
    /// From the tone operator.
    pub fn flip_map(&self, rgb: &[f32]) -> perception::Result<Vec<f32>> {
        let test = self.display_srgb(rgb)?;
        Ok(self.flip_srgb(&self.reference_srgb, &test))
    }

    /// The display sRGB of an image graded by `GRADES_EV[k]` stops.
    ///
    /// # Errors
    /// From the tone operator.
    pub fn graded_srgb(&self, k: usize, rgb: &[f32]) -> perception::Result<Vec<u8>> {
        Ok(encode_srgb8(&self.grades[k].0.map(rgb)?))
    }

    fn flip_srgb(&self, reference: &[u8], test: &[u8]) -> Vec<f32> {
        let (w, h) = (self.width as u32, self.height as u32);
        let r = nv_flip::FlipImageRgb8::with_data(w, h, reference);
        let t = nv_flip::FlipImageRgb8::with_data(w, h, test);
        nv_flip::flip(r, t, self.ppd).to_vec()
    }

    /// FLIP mean and 5×5-pooled p99 of a FLIP map; returns the pooled map too.
    fn flip_stats(&self, fmap: &[f32]) -> (f64, f64, Vec<f32>) {
        let mean = fmap.iter().map(|&v| v as f64).sum::<f64>() / fmap.len() as f64;
        let filtered = aleph::imaging::box_mean(fmap, self.width, self.height, 2);
        (mean, quantile(&filtered, 0.99), filtered)
    }

    /// Scores an image (linear RGB).
    ///
    /// # Errors
    /// From the perception models.
    pub fn score(&self, rgb: &[f32]) -> perception::Result<Scores> {
        Ok(self.score_with_map(rgb)?.0)
    }

    /// Scores an image and returns its 5×5-filtered FLIP map too.
    ///
    /// # Errors
    /// From the perception models.
    pub fn score_with_map(&self, rgb: &[f32]) -> perception::Result<(Scores, Vec<f32>)> {
        let fmap = self.flip_map(rgb)?;
        let (flip_mean, flip_p99, filtered) = self.flip_stats(&fmap);
        let mut graded = [GradedFlip::default(); 2];
        for (k, g) in graded.iter_mut().enumerate() {
            let test = self.graded_srgb(k, rgb)?;
            let (mean, p99, _) = self.flip_stats(&self.flip_srgb(&self.grades[k].1, &test));
            *g = GradedFlip {
                ev: GRADES_EV[k],
                mean,
                p99,
            };
        }
        let lum = self.frozen.display_luminance(rgb)?;
        let diff = self
            .metric
            .compare_with_map(&self.map, &self.reference_lum, &lum)?;
        let relmse = rgb
            .iter()
            .zip(&self.reference)
            .map(|(&x, &r)| ((x - r) as f64).powi(2) / ((r as f64).powi(2) + 1e-2))
            .sum::<f64>()
            / rgb.len() as f64;
        Ok((
            Scores {
                flip_mean,
                flip_p99,
                visible_fraction: diff.visible_fraction,
                relmse,
                graded,
            },
            filtered,
        ))
    }

    /// The reference's own noise floor: the scores of one half-buffer against the other.
    ///
    /// # Errors
    /// From the perception models.
    pub fn floor(
        even: &[f32],
        odd: &[f32],
        width: usize,
        height: usize,
        frozen: FrozenToneMap,
        view: ViewingConditions,
    ) -> perception::Result<Scores> {
        Judge::new(even.to_vec(), width, height, frozen, view)?.score(odd)
    }
}

/// The best any allocation could do, from per-pixel fits of FLIP error to uniform renders:
/// with each pixel's 5×5-filtered FLIP error modelled as a_i n^−β (β from
/// the image means of two uniform budgets, a_i from both maps), the ceiling speedups at budget
/// `n` are, for FLIP mean, n over the budget at which the mean-optimal allocation
/// n_i ∝ a_i^(1/(1+β)) matches uniform's mean; and for FLIP p99, n over the mean of
/// n_i = (a_i / p99_uniform)^(1/β), the samples that bring every pixel to uniform's 99th
/// percentile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ceiling {
    /// Fitted exponent β.
    pub beta: f64,
    /// Ceiling speedup for FLIP mean.
    pub mean: f64,
    /// Ceiling speedup for FLIP p99.
    pub p99: f64,
    /// Ceiling speedup in wall time for FLIP mean, given each pixel's measured cost per sample
    /// ([`time_ceiling`]); `None` without a cost map.
    pub time_mean: Option<f64>,
}

/// The ceiling speedup in wall time at equal FLIP mean: uniform's time at budget `n` over the
/// least time any allocation needs to reach uniform's mean error, with pixel i's error
/// a_i n_i^−β (`beta`, `a`, as [`flip_coefficients`] fits) and its cost c_i seconds per
/// sample (`cost`, e.g. [`aleph::render::pixel_costs`]). Minimising Σ c_i n_i at
/// Σ a_i n_i^−β fixed gives n_i = k (a_i / c_i)^(1/(1+β)) (the optimum allocation with
/// variable cost per unit of stratified sampling, Cochran 1977, *Sampling Techniques*, §5.5,
/// with error falling as n^−β instead of n^−1), and k follows in closed form: the error is
/// k^−β S with S = Σ a_i^(1/(1+β)) c_i^(β/(1+β)), and the time k S. Pixels with a_i = 0 cost
/// nothing in the optimum and n c_i in uniform. Equal costs give the FLIP-mean
/// [`Ceiling::mean`] in samples. Costs are clamped to 1 ns.
///
/// # Panics
/// If `a` and `cost` differ in length.
pub fn time_ceiling(beta: f64, a: &[f64], cost: &[f32], n: f64) -> f64 {
    assert_eq!(a.len(), cost.len());
    let c = |i: usize| (cost[i] as f64).max(1e-9);
    let e = 1.0 / (1.0 + beta);
    let (mut err_u, mut time_u, mut s) = (0.0, 0.0, 0.0);
    for (i, &ai) in a.iter().enumerate() {
        time_u += n * c(i);
        if ai > 0.0 {
            err_u += ai * n.powf(-beta);
            s += ai.powf(e) * c(i).powf(beta * e);
        }
    }
    if err_u <= 0.0 {
        return 1.0;
    }
    let k = (s / err_u).powf(1.0 / beta);
    time_u / (k * s)
}

/// Time per sample of an allocation (`counts[i]` samples in pixel i) relative to a uniform
/// one's, from each pixel's cost per sample: (Σ c_i n_i / Σ n_i) / mean(c_i). Above 1 the
/// allocation's samples are dearer than uniform's, so its wall time falls short of its
/// sample savings.
///
/// # Panics
/// If the lengths differ.
pub fn relative_sample_cost(counts: &[f32], cost: &[f32]) -> f64 {
    assert_eq!(counts.len(), cost.len());
    let n: f64 = counts.iter().map(|&v| v as f64).sum();
    let weighted: f64 = counts
        .iter()
        .zip(cost)
        .map(|(&v, &c)| v as f64 * c as f64)
        .sum();
    let mean_c = cost.iter().map(|&c| c as f64).sum::<f64>() / cost.len() as f64;
    weighted / n.max(1e-300) / mean_c.max(1e-300)
}

/// Per-pixel FLIP coefficients from two uniform renders' 5×5-filtered FLIP maps (`n_lo`,
/// `map_lo`), (`n_hi`, `map_hi`): β from the ratio of the image means, and a_i (each pixel's
/// error at one sample, e_i = a_i n^−β) as the geometric mean of the two maps' estimates.
/// `None` when the maps do not fall with n.
pub fn flip_coefficients(
    n_lo: f64,
    map_lo: &[f32],
    n_hi: f64,
    map_hi: &[f32],
) -> Option<(f64, Vec<f64>)> {
    let mean = |m: &[f32]| m.iter().map(|&v| v as f64).sum::<f64>() / m.len() as f64;
    let (m_lo, m_hi) = (mean(map_lo), mean(map_hi));
    if !(m_lo > 0.0 && m_hi > 0.0 && n_hi > n_lo) {
        return None;
    }
    let beta = (m_lo / m_hi).ln() / (n_hi / n_lo).ln();
    if beta.is_nan() || beta <= 0.01 {
        return None;
    }
    let a = map_lo
        .iter()
        .zip(map_hi)
        .map(|(&l, &h)| ((l as f64 * n_lo.powf(beta)) * (h as f64 * n_hi.powf(beta))).sqrt())
        .collect();
    Some((beta, a))
}

/// The oracle's allocations at mean budget `n` from FLIP coefficients (`beta`, `a`): for FLIP
/// mean, n_i ∝ a_i^(1/(1+β)) (minimising Σ a_i n_i^−β at Σ n_i fixed); for FLIP p99, n_i ∝
/// a_i^(1/β) (every pixel brought to one error). Each is scaled to mean `n`.
pub fn oracle_allocations(beta: f64, a: &[f64], n: f64) -> (Vec<f32>, Vec<f32>) {
    let scaled = |e: f64| -> Vec<f32> {
        let w: Vec<f64> = a.iter().map(|&ai| ai.max(0.0).powf(e)).collect();
        let k = n * w.len() as f64 / w.iter().sum::<f64>().max(1e-300);
        w.iter().map(|&wi| (wi * k) as f32).collect()
    };
    (scaled(1.0 / (1.0 + beta)), scaled(1.0 / beta))
}

/// Spearman's rank correlation of two equally long samples (ties ranked by their mean rank).
///
/// # Panics
/// If the lengths differ.
pub fn rank_correlation(x: &[f32], y: &[f32]) -> f64 {
    assert_eq!(x.len(), y.len());
    let ranks = |v: &[f32]| -> Vec<f64> {
        let mut idx: Vec<usize> = (0..v.len()).collect();
        idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
        let mut r = vec![0.0; v.len()];
        let mut i = 0;
        while i < idx.len() {
            let mut j = i;
            while j + 1 < idx.len() && v[idx[j + 1]] == v[idx[i]] {
                j += 1;
            }
            for &k in &idx[i..=j] {
                r[k] = 0.5 * (i + j) as f64;
            }
            i = j + 1;
        }
        r
    };
    let (rx, ry) = (ranks(x), ranks(y));
    let m = (x.len() as f64 - 1.0) / 2.0;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in rx.iter().zip(&ry) {
        sxy += (a - m) * (b - m);
        sxx += (a - m) * (a - m);
        syy += (b - m) * (b - m);
    }
    sxy / (sxx * syy).sqrt().max(1e-300)
}

/// Fits the ceiling from two uniform renders' 5×5-filtered FLIP maps (`n_lo`, `map_lo`),
/// (`n_hi`, `map_hi`), evaluated at budget `n`; with `cost` (seconds per sample per pixel)
/// also in wall time ([`time_ceiling`]).
pub fn ceiling(
    n_lo: f64,
    map_lo: &[f32],
    n_hi: f64,
    map_hi: &[f32],
    n: f64,
    cost: Option<&[f32]>,
) -> Option<Ceiling> {
    let (beta, a) = flip_coefficients(n_lo, map_lo, n_hi, map_hi)?;
    let time_mean = cost
        .filter(|c| c.len() == a.len())
        .map(|c| time_ceiling(beta, &a, c, n));
    let a: Vec<f64> = a.into_iter().filter(|&a| a > 0.0).collect();
    if a.is_empty() {
        return None;
    }
    let px = map_lo.len() as f64;
    let uni: Vec<f32> = a.iter().map(|ai| (ai * n.powf(-beta)) as f32).collect();
    // Pixels with a_i = 0 have zero error at any n: they count in the mean as zeros.
    let mean_u = uni.iter().map(|&v| v as f64).sum::<f64>() / px;
    let mut with_zeros = uni.clone();
    with_zeros.resize(map_lo.len(), 0.0);
    let p99_u = quantile(&with_zeros, 0.99);
    let w: Vec<f64> = a.iter().map(|ai| ai.powf(1.0 / (1.0 + beta))).collect();
    let ws: f64 = w.iter().sum();
    let mean_opt = |budget: f64| -> f64 {
        a.iter()
            .zip(&w)
            .map(|(ai, wi)| ai * (budget * px * wi / ws).powf(-beta))
            .sum::<f64>()
            / px
    };
    let (mut lo, mut hi) = (1e-3 * n, n);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if mean_opt(mid) > mean_u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let need = a
        .iter()
        .map(|ai| (ai / p99_u).powf(1.0 / beta))
        .sum::<f64>()
        / px;
    Some(Ceiling {
        beta,
        mean: n / hi,
        p99: n / need.max(1e-9),
        time_mean,
    })
}

/// Linear interpolation in log–log of the x at which a decreasing curve (x_i, y_i), x
/// increasing, reaches `target`. `None` if the curve never gets that low (or starts below it).
pub fn samples_for(curve: &[(f64, f64)], target: f64) -> Option<f64> {
    if curve.is_empty() || target <= 0.0 {
        return None;
    }
    if curve[0].1 <= target {
        return if curve[0].1 == target {
            Some(curve[0].0)
        } else {
            None
        };
    }
    for p in curve.windows(2) {
        let ((x0, y0), (x1, y1)) = (p[0], p[1]);
        if y1 <= target && y0 > target {
            let (lx0, lx1, ly0, ly1) = (x0.ln(), x1.ln(), y0.ln(), y1.ln());
            let t = (target.ln() - ly0) / (ly1 - ly0);
            return Some((lx0 + t * (lx1 - lx0)).exp());
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_log_interpolation() {
        // y = x^-0.5: y = 0.25 at x = 16.
        let curve: Vec<(f64, f64)> = [1.0f64, 4.0, 64.0]
            .iter()
            .map(|&x| (x, x.powf(-0.5)))
            .collect();
        assert!((samples_for(&curve, 0.25).unwrap() - 16.0).abs() < 1e-9);
        assert!(samples_for(&curve, 0.01).is_none());
        assert!(samples_for(&curve, 2.0).is_none());
    }

    #[test]
    fn ceiling_of_a_two_region_image() {
        // Half the pixels have FLIP error 4 n^-0.5, half 1 n^-0.5. Uniform at n = 16: errors
        // 1 and 0.25, mean 0.625, p99 1. Bringing every pixel to 1 needs n_i = (a_i/1)^2 = 16
        // and 1: mean 8.5, so the p99 ceiling is 16/8.5 = 1.88. Mean-optimal: n_i ∝ a_i^(2/3),
        // i.e. 4^(2/3) : 1 = 2.52 : 1; solving for mean 0.625 gives a budget of 14.7 (ceiling 1.09).
        let (lo, hi) = (4.0, 64.0);
        let map = |n: f64| -> Vec<f32> {
            (0..1000).map(|i| if i < 500 { 4.0 * n.powf(-0.5) } else { n.powf(-0.5) } as f32).collect()
        };
        let c = ceiling(lo, &map(lo), hi, &map(hi), 16.0, None).unwrap();
        assert!((c.beta - 0.5).abs() < 1e-9);
        assert!((c.p99 - 16.0 / 8.5).abs() < 1e-6, "{c:?}");
        // Mean-optimal: weights 2.52 and 1; at budget B, n = 2B·w/(w1 + w2).
        let w1 = 4f64.powf(2.0 / 3.0);
        let mean_at = |b: f64| {
            0.5 * (4.0 * (2.0 * b * w1 / (w1 + 1.0)).powf(-0.5) + (2.0 * b / (w1 + 1.0)).powf(-0.5))
        };
        let expected = 16.0 / {
            let (mut a, mut z) = (0.1, 16.0);
            for _ in 0..100 {
                let m = 0.5 * (a + z);
                if mean_at(m) > 0.625 { a = m } else { z = m }
            }
            z
        };
        assert!((c.mean - expected).abs() < 1e-6, "{} vs {expected}", c.mean);
        assert!(c.mean > 1.0 && c.mean < 1.2);
    }

    #[test]
    fn time_ceiling_against_a_brute_force_two_pixel_search() {
        // Two pixels with errors a_i n^-β and costs c_i per sample. Uniform at n = 100 has mean
        // error 0.5 (a_1 + a_2) 100^-β and time 100 (c_1 + c_2). The cheapest allocation with the
        // same mean error, found by scanning n_1 (n_2 then follows from the error) in 10⁶ steps,
        // must match the closed form.
        let brute = |beta: f64, a: [f64; 2], c: [f64; 2]| {
            let n = 100.0f64;
            let err = 0.5 * (a[0] + a[1]) * n.powf(-beta);
            let mut best = f64::INFINITY;
            for k in 1..1_000_000 {
                let n1 = k as f64 * 1e-3;
                let rest = 2.0 * err - a[0] * n1.powf(-beta);
                if rest <= 0.0 {
                    continue;
                }
                let n2 = (rest / a[1]).powf(-1.0 / beta);
                best = best.min(c[0] * n1 + c[1] * n2);
            }
            n * (c[0] + c[1]) / best
        };
        for (beta, a, c) in [
            (0.5, [1.0, 1.0], [1.0, 4.0]),
            (0.33, [3.0, 1.0], [1.0, 12.0]),
            (0.5, [4.0, 1.0], [2.0, 2.0]),
        ] {
            let got = time_ceiling(beta, &a, &[c[0] as f32, c[1] as f32], 100.0);
            let want = brute(beta, a, c);
            assert!(
                (got - want).abs() < 1e-4 * want,
                "β {beta}, a {a:?}, c {c:?}: {got} vs {want}"
            );
            assert!(got >= 1.0 - 1e-9);
        }
        // Equal costs: the time ceiling is the sample ceiling of `ceiling` for FLIP mean.
        let map = |n: f64| -> Vec<f32> {
            (0..1000).map(|i| if i < 500 { 4.0 * n.powf(-0.5) } else { n.powf(-0.5) } as f32).collect()
        };
        let cost = vec![1e-6f32; 1000];
        let c = ceiling(4.0, &map(4.0), 64.0, &map(64.0), 16.0, Some(&cost)).unwrap();
        let t = c.time_mean.unwrap();
        assert!((t - c.mean).abs() < 1e-6, "{t} vs {}", c.mean);
        // One sample at cost 1 and three at cost 3: 10 / 4 per sample against a mean cost of 2.
        assert!((relative_sample_cost(&[1.0, 3.0], &[1.0, 3.0]) - 1.25).abs() < 1e-12);
    }

    #[test]
    fn rank_correlation_of_monotone_reversed_and_tied_samples() {
        let x: Vec<f32> = (0..50).map(|i| i as f32).collect();
        let up: Vec<f32> = x.iter().map(|v| v.powi(3) + 1.0).collect();
        let down: Vec<f32> = x.iter().map(|v| -v).collect();
        assert!((rank_correlation(&x, &up) - 1.0).abs() < 1e-12);
        assert!((rank_correlation(&x, &down) + 1.0).abs() < 1e-12);
        // Spearman of (1, 2, 3, 4) against (1, 1, 2, 2): ranks (0.5, 0.5, 2.5, 2.5) against
        // (0, 1, 2, 3) give 4 / sqrt(4 · 5) = 0.894.
        let r = rank_correlation(&[1.0, 2.0, 3.0, 4.0], &[1.0, 1.0, 2.0, 2.0]);
        assert!((r - 4.0 / 20f64.sqrt()).abs() < 1e-12, "{r}");
    }

    #[test]
    fn oracle_allocations_of_a_two_region_image() {
        // a = 4 and 1, β = 0.5: the mean-optimal allocation is ∝ a^(2/3) (2.52 : 1), the p99
        // one ∝ a^2 (16 : 1), each with mean n.
        let a = [4.0, 1.0];
        let (mean, p99) = oracle_allocations(0.5, &a, 10.0);
        let w = 4f64.powf(2.0 / 3.0);
        assert!(
            (mean[0] as f64 - 20.0 * w / (w + 1.0)).abs() < 1e-4,
            "{mean:?}"
        );
        assert!((mean[1] as f64 - 20.0 / (w + 1.0)).abs() < 1e-4);
        assert!((p99[0] as f64 - 20.0 * 16.0 / 17.0).abs() < 1e-4, "{p99:?}");
        assert!((p99[1] as f64 - 20.0 / 17.0).abs() < 1e-4);
    }

    #[test]
    fn quantiles() {
        let v: Vec<f32> = (0..=100).map(|i| i as f32).collect();
        assert_eq!(quantile(&v, 0.99), 99.0);
        assert_eq!(quantile(&v, 0.0), 0.0);
    }
}
