//! The allocation of a pass: how many more samples each pixel gets from its error ratio.

use crate::film::Film;
use rayon::prelude::*;

/// 3×3 dilation of a mask (row-major `w × h`).
pub(crate) fn dilate3(m: &[bool], w: usize, h: usize) -> Vec<bool> {
    let v: Vec<f32> = m.par_iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
    crate::imaging::max_filter3(&v, w, h)
        .into_par_iter()
        .map(|x| x > 0.0)
        .collect()
}

/// The samples each pixel gets in the next pass.
pub(crate) struct Allocation {
    /// Samples per pixel of the pass (row-major).
    pub want: Vec<u32>,
    /// Pixels that may receive samples: those above the target and their 8 neighbours.
    pub reopen: Vec<bool>,
}

impl Allocation {
    /// No samples for any of `n` pixels.
    pub fn empty(n: usize) -> Allocation {
        Allocation {
            want: vec![0; n],
            reopen: vec![false; n],
        }
    }

    /// Samples in the pass.
    pub fn total(&self) -> u64 {
        self.want.iter().map(|&c| c as u64).sum()
    }
}

/// Pixels with error ratio r above 1 (noise at threshold) need about n (r² − 1) more samples
/// (error falls as 1/√n); each gets that, at most doubling its count, never past `max_spp`;
/// their 8 neighbours are re-opened with at least n/4. Every count is then rounded up so the
/// pixel's total is a [`stratified_total`], where its Sobol' samples are stratified. Perceptual
/// against uniform sampling (both Sobol'), samples saved at equal FLIP p99, without → with
/// rounding to powers of two: Cornell box 256² at 32/64 spp 0.99×/0.78× → 1.04×/1.10×;
/// holodeck 240×160 at 64 spp 0.82× → 1.12× (1.25× at 128).
pub(crate) fn allocate(film: &Film, ratio: &[f32], max_spp: u32) -> Allocation {
    let (w, h) = (film.width as usize, film.height as usize);
    let active: Vec<bool> = ratio.par_iter().map(|&r| r > 1.0).collect();
    let reopen = dilate3(&active, w, h);
    let want = film
        .pixels
        .par_iter()
        .zip(ratio.par_iter())
        .zip(active.par_iter().zip(reopen.par_iter()))
        .map(|((px, &r), (&act, &reo))| {
            let n = px.n;
            if !reo || n >= max_spp {
                return 0;
            }
            let nf = n as f32;
            let mut c = if act {
                let q = r.min(1e3);
                (nf * (q * q - 1.0)).ceil()
            } else {
                0.0
            };
            c = c.max((nf / 4.0).ceil()).max(1.0).min(nf.max(1.0));
            let c = stratified_total(n + c as u32) - n;
            c.min(max_spp - n)
        })
        .collect();
    Allocation { want, reopen }
}

/// The smallest per-pixel total ≥ `n` at which each half-buffer's Owen-scrambled Sobol'
/// samples are stratified: a power of two 2^k, or 3 · 2^(k−2) (≥ 6), whose half-buffers hold
/// two whole (0,2)-nets, of 2^(k−2) and 2^(k−3) points (any aligned block of 2^m consecutive
/// points of a (0,2)-sequence is a (0,m,2)-net; in the block layout of one sequence,
/// [`crate::film::HalfSplit::Blocks`], nets of 2^(k−1) and 2^(k−2) points). The 3/4 steps let an allocation depart from
/// uniform by a quarter of a budget instead of half of it. `n` is at most 2^31.
pub(crate) fn stratified_total(n: u32) -> u32 {
    let p = n.max(1).next_power_of_two();
    let three_quarters = p / 4 * 3;
    if p >= 8 && three_quarters >= n {
        three_quarters
    } else {
        p
    }
}

/// The largest [`stratified_total`] ≤ `x` (at least 1).
pub(crate) fn stratified_floor(x: f64) -> u32 {
    let x = x.clamp(1.0, (1u64 << 31) as f64) as u32;
    let p = 1u32 << x.ilog2();
    let up = p * 3 / 2;
    if p >= 4 && up <= x { up } else { p }
}

/// Under a sample budget B, no pixel whose noise could be seen is left below FLOOR_SHARE · B
/// samples (rounded down to a [`stratified_total`]): the perceptual threshold ranks pixels only
/// roughly as the judges do (Spearman correlation 0.3–0.7 with the FLIP oracle's ranking on
/// the Cornell box), and starving the pixels it misranks costs more than its savings
/// elsewhere. A half-budget floor (the only share between none and uniform while totals were
/// powers of two) lost at equal FLIP mean once the threshold called most pixels converged:
/// Cornell box 256² at 256 / 512 spp 0.97 / 0.82× (uniform is within 5 % of the mean's
/// optimum, so every pixel left at half the budget costs more than the few that get more can
/// return). With 3/4-steps the floor is three quarters of the budget.
pub(crate) const FLOOR_SHARE: f64 = 0.75;

/// Without a budget (the default stop, a time budget) no pixel whose noise could be seen is
/// left below STOP_FLOOR_SHARE of the region's current mean spp (rounded down to a
/// [`stratified_total`]); a converged stop first lifts the pixels under it. The same reason as
/// [`FLOOR_SHARE`]: the threshold misranks some pixels. On the holodeck the stop left its
/// saturated orange door at 8–32 spp, where the display clips the red channel at every grade
/// of the latitude and the luminance-only threshold does not see the noise's hue: graded 2
/// stops darker, its FLIP p99 (0.105) and JOD (9.906) were worse than uniform's at 128 spp.
/// With the floor: 0.047 and 9.987, for 719.5 spp mean against 694.4.
///
/// Half the mean since 2026-11-28 (a quarter before): once the stop ended at 90 % of the
/// pixels, the pixels it starved cost its FLIP mean more than the fed ones returned (FLIP's
/// mean falls about as n^−⅓ where the model ranks them). Uniform spp at the stop's score over
/// the stop's, as displayed / −2 / +2 EV, a quarter → half (seeds 0 and 1, the holodeck 0;
/// 4096-spp references; docs/benchmarks.md): holodeck 240×160 (558.0 → 597.4 spp) FLIP mean
/// 0.84 / 0.76 / 0.79 → 0.97 / 0.89 / 0.93×, p99 2.31 / 1.76 / 2.02 → 2.30 / 1.87 / 2.05×, JOD
/// 2.70 / 2.82 / 1.29 → 2.92 / 2.78 / 1.62×; Cornell box 256² (186.4 → 189.4) FLIP mean 0.98 /
/// 0.71 / 0.94 → 1.01 / 0.76 / 0.97×, p99 0.97 / 0.81 / 1.58 → 1.02 / 0.89 / 1.61×, JOD 1.31 /
/// 0.83 / 2.18 → 1.35 / 0.89 / 2.15×; Mori knob 256×170 (35.0 → 36.2) FLIP mean 0.92 / 1.05 /
/// 0.99 → 0.93 / 1.03 / 1.00×, p99 1.26 / 1.34 / 1.31 → 1.24 / 1.29 / 1.28×, JOD 1.25 / 1.23 /
/// 1.49 → 1.23 / 1.20 / 1.46×; Lost Empire 256×160 (44.5 → 47.1) FLIP mean 1.00 / 0.95 / 1.06
/// → 0.96 / 1.00 / 1.05×, p99 1.08 / 1.10 / 1.02 → 1.04 / 1.05 / 0.98×, JOD at ∓2 EV 1.41 /
/// 1.30 → 1.33 / 1.25×. Three quarters gained more FLIP mean on the holodeck and the box but
/// lost JOD on the Mori knob (1.13 / 1.15 / 1.26×) and the box graded brighter (1.95×).
///
/// The whole mean since 2026-11-29 (the largest stratified total not above it), re-measured with
/// the stop at 80 % on six stills (one seed each, `aleph speedup … --arms uniform --stop`, uniform
/// spp at the stop's score over the stop's: FLIP mean / p99 as displayed, the same at −2 EV, then
/// JOD), half → three quarters → the whole mean: the Cornell box in its original units
/// (`scenes/cornell-original`, 256²; 428.0 → 442.5 → 494.2 spp) 0.82 / 0.92, 0.82 / 0.75, 1.25 →
/// 0.86 / 1.01, 0.85 / 0.82, 1.29 → 0.91 / 1.16, 0.90 / 0.98, 1.32×; Cornell box 256² (141.1 →
/// 149.3 → 162.6) 0.92 / 1.28, 0.90 / 1.19, 1.49 → 0.96 / 1.27, 0.94 / 1.23, 1.44 → 1.00 / 1.22,
/// 0.98 / 1.21, 1.36×; sunset knob 256×192 (75.7 → 76.4 → 79.0) 0.90 / 1.07, 0.90 / 1.04, 1.15 →
/// 0.92 / 1.13, 0.92 / 1.06, 1.15 → 0.97 / 1.18, 0.96 / 1.11, 1.19×; studio knob 256×170 (19.8 →
/// 20.5 → 21.6) 1.01 / 1.82, 1.01 / 1.82, 1.26 → 1.02 / 1.76, 0.98 / 1.76, 1.27 → 1.02 / 1.67, 1.02
/// / 1.67, 1.25×; Lost Empire 256×160 (35.9 → 38.1 → 40.7) 1.03 / 0.92, 1.03 / 1.00, 1.23 → 1.00 /
/// 0.94, 1.00 / 0.97, 1.18 → 1.01 / 0.96, 1.01 / 1.01, 1.13×; holodeck 240×160 (383.6 → 433.1 →
/// 504.7) FLIP mean 0.94 / 0.89 → 1.06 / 1.00 → 1.12 / 1.06×, p99 at −2 EV 2.16 → 2.08 → 1.82×, p99
/// as displayed and JOD beyond the sweep (over 2×). Scores under 1× over the six (seven a still, ±2
/// EV): 16 → 13 → 9, the worst 0.75 → 0.82 → 0.90× (docs/benchmarks.md, "The default stop on a
/// scene nothing was tuned on"). The half-buffer difference that ranks a pixel is one noisy draw of
/// its error: a pass doubles whichever pixels draw high, and the pixels it leaves behind cost
/// FLIP's mean more than the doubled ones return. With the floor at the mean, the stop is a uniform
/// render that grows while the model sees noise, with the pixels still above threshold given more;
/// the top-end gains (p99, JOD) shrink a little.
pub(crate) const STOP_FLOOR_SHARE: f64 = 1.0;

/// The stop's floor share where the stop waits for more than
/// [`super::DEFAULT_CONVERGED_FRACTION`] of the pixels, or judges the denoised image (whose
/// stop waits for 99.5 %): half the mean, as before [`STOP_FLOOR_SHARE`] rose to the whole.
/// There a few pixels that stay above threshold however many samples they get (the holodeck's
/// thin grid lines) double pass after pass, and a floor at the whole mean follows them up,
/// lifting every pixel each time the mean passes the next stratified total, until `max_spp`:
/// the holodeck at 256×170 stopped at 1325.4 spp in 110.8 s (at 99.5 %) and 1278.4 spp in
/// 106.6 s (with the denoiser) against 844.2 spp in 77.7 s and 699.1 spp in 64.4 s with half
/// the mean. At 80 % the stop ends before that, the pixels above threshold being a fifth of
/// the image, not a few.
pub(crate) const HIGH_FRACTION_STOP_FLOOR_SHARE: f64 = 0.5;

/// The floor's share of the mean spp for a stop without a budget: [`STOP_FLOOR_SHARE`] at the
/// default converged fraction or below, without the denoiser; else
/// [`HIGH_FRACTION_STOP_FLOOR_SHARE`].
pub(crate) fn stop_floor_share(denoise: bool, converged_fraction: f64) -> f64 {
    if !denoise && converged_fraction <= super::DEFAULT_CONVERGED_FRACTION {
        STOP_FLOOR_SHARE
    } else {
        HIGH_FRACTION_STOP_FLOOR_SHARE
    }
}

/// Under a sample budget B no pixel gets more than BUDGET_CAP_SHARE · B samples (rounded down
/// to a [`stratified_total`]; the unbudgeted stop keeps only `max_spp`). Without it a few
/// pixels whose noise stays above threshold however many samples they get (a knob's specular
/// highlights, paths that rarely find a light) doubled pass after pass, to 9× the budget on the
/// Mori knob at 128 spp while 85 % of the image stayed at 112, and on the Cornell box at 512
/// spp the third of the image still above threshold took 768 and more. Measured against the
/// same uniform renders (256², perceptual spp at uniform's score, as displayed / −2 / +2 EV),
/// without → with the cap at 2 B: Cornell box 512 spp FLIP mean 0.96 / 0.95 / 1.02 → 1.01 /
/// 1.01 / 1.06×, p99 1.08 / 0.98 / 1.32 → 1.13 / 1.08 / 1.33×, JOD at −2 EV 0.94 → 1.01×; Mori
/// knob 128 spp FLIP mean 0.95 / 0.95 / 0.98 → 0.97 / 0.97 / 1.00×. It costs some of the top
/// gains: holodeck JOD at 1024 spp 2.21 → 1.81× as displayed, Mori knob p99 at −2 EV, 512 spp,
/// 0.98 → 0.94×. It also bounds every speedup at BUDGET_CAP_SHARE×: a uniform render of that
/// many times the budget gives every pixel at least as many samples. At 4 B the holodeck passed
/// 2× at 512 spp (FLIP p99 and JOD), but the Cornell box lost again at 512 spp (FLIP mean
/// 0.96×) and the Mori knob at 128 (0.94×).
pub(crate) const BUDGET_CAP_SHARE: f64 = 2.0;

/// Pixels below `floor` samples are raised to it in one step (never past `max_spp`), unless
/// their ratio is 0: no noise at all (every sample equal, in them and their 8 neighbours), or
/// noise below [`NEGLIGIBLE_NOISE_CONTRAST`]. Pixels whose `noise` (relative, from
/// [`relative_noise`]) is within [`NEAR_NEGLIGIBLE_FACTOR`] of negligible approach the floor by
/// doublings instead, judged again after each. Pixels the tone curve clips at every grade
/// keep the floor: the clipping is judged on pooled means, which a clipped light next to a dark
/// pixel can mislead, and without the floor those pixels cost the holodeck its gains (FLIP p99
/// at −2 EV 0.99 / 1.10× → 0.83 / 0.84× at 64 / 128 spp).
///
/// [`NEGLIGIBLE_NOISE_CONTRAST`]: super::criterion::NEGLIGIBLE_NOISE_CONTRAST
/// [`relative_noise`]: super::criterion::relative_noise
pub(crate) fn raise_to_floor(
    alloc: &mut Allocation,
    film: &Film,
    ratio: &[f32],
    noise: Option<&[f32]>,
    floor: u32,
    max_spp: u32,
) {
    for (i, (c, px)) in alloc.want.iter_mut().zip(&film.pixels).enumerate() {
        let target = floor.min(pass_cap(noise, i, px.n, max_spp));
        if ratio[i] > 0.0 && px.n + *c < target {
            *c = target - px.n;
            alloc.reopen[i] = true;
        }
    }
}

/// The most samples pixel `i`, now at `n`, may reach in this pass outside its own doublings:
/// `max_spp`, or one doubling when its `noise` is within [`NEAR_NEGLIGIBLE_FACTOR`] of
/// [`NEGLIGIBLE_NOISE_CONTRAST`].
///
/// [`NEGLIGIBLE_NOISE_CONTRAST`]: super::criterion::NEGLIGIBLE_NOISE_CONTRAST
fn pass_cap(noise: Option<&[f32]>, i: usize, n: u32, max_spp: u32) -> u32 {
    use super::criterion::NEGLIGIBLE_NOISE_CONTRAST;
    if noise.is_some_and(|q| q[i] < NEAR_NEGLIGIBLE_FACTOR * NEGLIGIBLE_NOISE_CONTRAST) {
        stratified_total(2 * n.max(1)).min(max_spp)
    } else {
        max_spp
    }
}

/// Pixels whose relative noise is below this many times [`NEGLIGIBLE_NOISE_CONTRAST`] reach
/// the floor by doublings, judged again after each, instead of in one step: the directly seen
/// sky and environment sit there at 8 spp (their noise falls about as 1/n, the pixel filter's
/// over smooth texels), and most turn negligible within one or two doublings, where the floor
/// would have given them three quarters of the budget. Lit surfaces start at 5 % and more.
///
/// [`NEGLIGIBLE_NOISE_CONTRAST`]: super::criterion::NEGLIGIBLE_NOISE_CONTRAST
pub(crate) const NEAR_NEGLIGIBLE_FACTOR: f32 = 8.0;

/// The fraction of pixels below threshold from which a budget's rest is spread evenly
/// ([`fill_to_level`]); measured at this value (docs/benchmarks.md, the 3/4 steps and the even
/// fill). The stop without a budget has its own fraction
/// ([`super::AdaptiveSettings::converged_fraction`]).
pub(crate) const FILL_FROM_CONVERGED: f64 = 0.995;

/// Under a sample budget, once [`FILL_FROM_CONVERGED`] of the pixels are invisible to the
/// threshold:
/// every pixel with any noise (ratio > 0) in `region` is raised to one common level, the
/// largest [`stratified_total`] the samples left after `alloc`'s own (`remaining` in all)
/// afford; when not even the next level above the lowest count is affordable, to that level,
/// for [`fit_to_budget`] to scale down. The model then has no ranking left to act on (every
/// pixel's noise is invisible to it), and uniform is within 5 % of the best allocation for
/// FLIP's mean on both bundled scenes, so the rest of the budget is spread evenly; tightening
/// the target on the pixels with the largest ratios instead (the earlier rule) lost at equal
/// FLIP mean on the Cornell box at 512 spp (0.94× uniform as displayed, 0.93× graded −2 EV).
pub(crate) fn fill_to_level(
    alloc: &mut Allocation,
    film: &Film,
    ratio: &[f32],
    noise: Option<&[f32]>,
    region: std::ops::Range<usize>,
    remaining: u64,
    max_spp: u32,
) {
    let spare = remaining.saturating_sub(alloc.total());
    // (pixel, its total after `alloc`, the most it may reach) of the pixels that can still
    // take samples.
    let open: Vec<(usize, u32, u32)> = region
        .map(|i| {
            let n = film.pixels[i].n;
            (i, n + alloc.want[i], pass_cap(noise, i, n, max_spp))
        })
        .filter(|&(i, after, cap)| ratio[i] > 0.0 && after < cap)
        .collect();
    let Some(lowest) = open.iter().map(|&(_, after, _)| after).min() else {
        return;
    };
    let cost = |level: u32| -> u64 {
        open.iter()
            .map(|&(_, after, cap)| level.min(cap).saturating_sub(after) as u64)
            .sum()
    };
    let mut level = stratified_total(lowest + 1).min(max_spp);
    loop {
        let next = stratified_total(level + 1).min(max_spp);
        if next == level || cost(next) > spare {
            break;
        }
        level = next;
    }
    for &(i, after, cap) in &open {
        let to = level.min(cap);
        if to > after {
            alloc.want[i] += to - after;
            alloc.reopen[i] = true;
        }
    }
}

/// Scales an allocation down to `remaining` samples: deterministic rounding down, then the
/// leftover samples one each in pixel order of decreasing ratio.
pub(crate) fn fit_to_budget(
    alloc: &mut Allocation,
    film: &Film,
    ratio: &[f32],
    remaining: u64,
    max_spp: u32,
) {
    let total = alloc.total();
    if total <= remaining {
        return;
    }
    let want = &mut alloc.want;
    let f = remaining as f64 / total as f64;
    for c in want.iter_mut() {
        *c = (*c as f64 * f).floor() as u32;
    }
    let mut left = remaining - want.iter().map(|&c| c as u64).sum::<u64>();
    if left == 0 {
        return;
    }
    let mut order: Vec<usize> = (0..want.len())
        .filter(|&i| alloc.reopen[i] && film.pixels[i].n < max_spp)
        .collect();
    order.sort_by(|&a, &b| ratio[b].total_cmp(&ratio[a]).then(a.cmp(&b)));
    for i in order {
        if left == 0 {
            break;
        }
        if film.pixels[i].n + want[i] < max_spp {
            want[i] += 1;
            left -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_whole_mean_floor_is_for_the_default_stop_alone() {
        let default = crate::adaptive::DEFAULT_CONVERGED_FRACTION;
        assert_eq!(stop_floor_share(false, default), 1.0);
        assert_eq!(stop_floor_share(false, 0.5), 1.0);
        // A stop that waits for more pixels, or judges the denoised image, would follow its
        // few stubborn pixels up to the cap.
        assert_eq!(stop_floor_share(false, 0.995), 0.5);
        assert_eq!(stop_floor_share(true, default), 0.5);
        assert_eq!(stop_floor_share(true, 0.995), 0.5);
    }

    #[test]
    fn the_floor_lifts_visible_pixels_only() {
        let mut film = Film::new(4, 1);
        for (p, n) in film.pixels.iter_mut().zip([8, 8, 32, 8]) {
            p.n = n;
        }
        let mut a = Allocation {
            want: vec![0, 0, 0, 8],
            reopen: vec![false, false, false, true],
        };
        // Pixel 0 is below the floor with visible noise; pixel 1 has none; pixel 2 is above the
        // floor; pixel 3 already gets samples.
        raise_to_floor(&mut a, &film, &[0.5, 0.0, 0.5, 2.0], None, 24, 4096);
        assert_eq!(a.want, [16, 0, 0, 16]);
        assert!(a.reopen[0] && !a.reopen[1]);
    }

    #[test]
    fn pixels_near_negligible_noise_approach_the_floor_by_doublings() {
        let mut film = Film::new(3, 1);
        for p in film.pixels.iter_mut() {
            p.n = 8;
        }
        // Relative noise 5 % (a lit surface), 0.4 % (within 8× of negligible: one doubling),
        // 0.05 % (negligible: the criterion has set its ratio to 0).
        let noise = [0.05, 0.004, 0.0005];
        let ratio = [0.5, 0.5, 0.0];
        let mut a = nothing(3);
        raise_to_floor(&mut a, &film, &ratio, Some(&noise), 96, 4096);
        assert_eq!(a.want, [88, 8, 0]);
        // The even fill stops the near pixel at a doubling too: 1000 spare samples take pixel 0
        // to 768 (the next level, 1024, would cost 1016 + 8).
        let mut b = nothing(3);
        fill_to_level(&mut b, &film, &ratio, Some(&noise), 0..3, 1000, 4096);
        assert_eq!(b.want, [760, 8, 0]);
    }

    fn nothing(n: usize) -> Allocation {
        Allocation {
            want: vec![0; n],
            reopen: vec![false; n],
        }
    }

    #[test]
    fn converged_pixels_fill_to_a_common_level() {
        let mut film = Film::new(4, 1);
        for (p, n) in film.pixels.iter_mut().zip([96, 96, 192, 96]) {
            p.n = n;
        }
        let mut a = nothing(4);
        // 100 samples reach 128 for pixels 0 and 3 (64), not 192 (192); pixel 1 has no noise.
        fill_to_level(&mut a, &film, &[0.5, 0.0, 0.9, 0.2], None, 0..4, 100, 4096);
        assert_eq!(a.want, [32, 0, 0, 32]);
        // Too little for any level: the next one, for fit_to_budget to scale down.
        let mut b = nothing(4);
        fill_to_level(&mut b, &film, &[0.5, 0.0, 0.9, 0.2], None, 0..4, 10, 4096);
        assert_eq!(b.want, [32, 0, 0, 32]);
        // Outside the region nothing moves.
        let mut c = nothing(4);
        fill_to_level(&mut c, &film, &[0.5, 0.0, 0.9, 0.2], None, 0..2, 1000, 4096);
        assert_eq!(c.want[3], 0);
    }

    #[test]
    fn stratified_totals_are_powers_of_two_and_their_three_quarters() {
        let allowed = |m: u32| {
            m.is_power_of_two() || (m.is_multiple_of(3) && (m / 3).is_power_of_two() && m >= 6)
        };
        for n in 1..5000 {
            let t = stratified_total(n);
            assert!(t >= n && allowed(t), "{n} -> {t}");
            assert!(
                (n..t).all(|m| !allowed(m)),
                "{n} -> {t} skips an allowed total"
            );
            let f = stratified_floor(n as f64 + 0.5);
            assert!(f <= n && allowed(f), "floor {n} -> {f}");
            assert!((f + 1..=n).all(|m| !allowed(m)), "floor {n} -> {f}");
        }
        assert_eq!(stratified_floor(0.75 * 512.0), 384);
        assert_eq!(stratified_floor(0.75 * 128.0), 96);
    }

    #[test]
    fn totals_land_on_stratified_totals() {
        let mut film = Film::new(8, 8);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            p.n = [8, 16, 32, 8][i % 4];
        }
        let ratio: Vec<f32> = (0..64).map(|i| (i % 7) as f32 * 0.4).collect();
        let a = allocate(&film, &ratio, 4096);
        let mut grew = 0;
        for (p, &c) in film.pixels.iter().zip(&a.want) {
            if c > 0 {
                grew += 1;
                assert_eq!(p.n + c, stratified_total(p.n + c), "{} + {c}", p.n);
            }
        }
        assert!(grew > 0);
    }
}
