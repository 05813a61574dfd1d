//! Reused frames weighed at silhouettes by the bias they may carry there ([`super`]; measured
//! in docs/reuse.md, "Silhouettes weighed by their bias").
//!
//! Where the camera translates, the surfaces on the two sides of a step in depth move against
//! each other: d px since a window frame (the parallax, [`parallax`]). That frame's samples in
//! a pixel the step crosses then miss a strip of about d of it (a disoccluded border narrower
//! than the centres' spacing, which the coverage test passes; a side of the front surface
//! turned into view), and counted as if they covered the whole pixel they shift its mean
//! towards the side they saw. Measured on Lost Empire's walkthrough (frame 35, 32 fresh spp,
//! a window of 15): the surfaces beside the sky came out 1.9 % too dark, and the walkthrough's
//! video JOD stopped rising from 16 fresh spp on (docs/reuse.md).
//!
//! The bias of the frame's mean at such a pixel is bounded by b = [`STEP_BIAS`] · min(d, 1) ·
//! ΔY, ΔY the range of the 3 × 3 pixels' mean luminance (the contrast across the step). The
//! frame keeps σ² / (σ² + b²) of its weight there, σ² the variance of its mean (the pixel's
//! per-sample luminance variance over the frame's effective count): the weight that minimises
//! the frame's mean squared error rather than its variance alone, so a frame of few samples,
//! whose noise hides the bias, keeps its history and one of many samples gives it up.

use super::{Layer, Moments, four_neighbours};
use rayon::prelude::*;

/// The bias bound's share of the contrast across a step times the strip's width (see the
/// module docs): a strip of d px misses ½ ΔY on average where the pixel is half covered.
/// Measured (walkthrough frames 32–39, video JOD at 2 / 4 / 8 / 16 / 32 / 64 fresh spp, before
/// 9.382 / 9.635 / 9.783 / 9.831 / 9.837 / 9.852): ¼ gives 9.388 / 9.638 / 9.790 / 9.846 /
/// 9.857 / 9.873 but leaves a dark slab's silhouettes 0.86 % too dark (z = −7.6 in the test
/// `silhouettes_keep_their_mean_where_the_two_sides_move_apart`); ½ gives 9.384 / 9.633 /
/// 9.788 / 9.841 / 9.856 / 9.874 and passes it.
pub const STEP_BIAS: f64 = 0.5;

/// Per pixel of a `w` × `h` frame whose 3 × 3 neighbourhood spans a step in depth (`step`):
/// the largest distance between its centre's displacement to a window frame (`moved`, raster
/// px, `None` where the centre's surface does not project into it) and a 4-neighbour's, i.e.
/// how far the surfaces on the two sides of a step through the pixel moved against each other
/// since (px; about 0 where the step passes beside the pixel); 0 elsewhere.
pub(super) fn parallax(
    (w, h): (usize, usize),
    step: impl Fn(usize) -> bool + Sync,
    moved: &[Option<glam::Vec2>],
) -> Vec<f32> {
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let Some(here) = moved[i].filter(|_| step(i)) else {
                return 0.0;
            };
            four_neighbours(i, (w, h))
                .into_iter()
                .flatten()
                .filter_map(|n| moved[n])
                .map(|m| m.distance(here))
                .fold(0.0, f32::max)
        })
        .collect()
}

/// The pixels with a parallax to any window frame (`parallax[j][i]` > 0, [`parallax`]), in
/// order: the only ones [`weigh`] changes.
pub(super) fn stepped(parallax: &[Vec<f32>], n: usize) -> Vec<u32> {
    (0..n as u32)
        .into_par_iter()
        .filter(|&i| parallax.iter().any(|p| p[i as usize] > 0.0))
        .collect()
}

/// Multiplies `shares[j][i]` (window frame j's share at pixel i, as the test left it; every
/// share 1 where `shares` is empty) by the share of least mean squared error at the pixels
/// with a parallax (`parallax[j][i]` > 0, [`parallax`]; `stepped` lists them, [`stepped`]);
/// see the module docs. `fresh` holds the frame's fresh samples' luminance moments, `layer`
/// the reused ones'.
pub(super) fn weigh(
    layer: &Layer,
    (parallax, stepped): (&[Vec<f32>], &[u32]),
    fresh: &[Moments],
    (w, h): (usize, usize),
    shares: &mut Vec<Vec<f64>>,
) {
    if stepped.is_empty() {
        return;
    }
    if shares.is_empty() {
        *shares = vec![vec![1.0; w * h]; layer.frames.len()];
    }
    let across = across_steps(layer, fresh, (w, h), stepped);
    shares
        .par_iter_mut()
        .zip(&layer.lum)
        .zip(parallax)
        .for_each(|((share, lum), parallax)| {
            for (&i, &(contrast, s2)) in stepped.iter().zip(&across) {
                let (i, k) = (i as usize, &mut share[i as usize]);
                let d = parallax[i] as f64;
                if d <= 0.0 || *k <= 0.0 || lum[i].1 <= 0.0 {
                    continue;
                }
                let b = STEP_BIAS * d.min(1.0) * contrast;
                let var = s2 / lum[i].1;
                if b > 0.0 && var.is_finite() {
                    *k *= var / (var + b * b);
                }
            }
        });
}

/// The 3 × 3 neighbourhood of pixel `i` in a `w` × `h` frame, clipped to it.
fn around(i: usize, (w, h): (usize, usize)) -> impl Iterator<Item = usize> {
    let (x, y) = (i % w, i / w);
    (y.saturating_sub(1)..(y + 2).min(h))
        .flat_map(move |yy| (x.saturating_sub(1)..(x + 2).min(w)).map(move |xx| yy * w + xx))
}

/// Per `stepped` pixel, in order: the range of the 3 × 3 pixels' mean luminance (every
/// sample, fresh and reused; the contrast across the step) and the per-sample luminance
/// variance, at least the 3 × 3 pixels' mean of it (a pixel whose samples all fell on one side
/// shows none, though its mean varies with them).
fn across_steps(
    layer: &Layer,
    fresh: &[Moments],
    size: (usize, usize),
    stepped: &[u32],
) -> Vec<(f64, f64)> {
    let n = size.0 * size.1;
    let mut wanted = vec![false; n];
    for &i in stepped {
        for c in around(i as usize, size) {
            wanted[c] = true;
        }
    }
    let stats: Vec<(f64, f64)> = (0..n)
        .into_par_iter()
        .map(|i| {
            if wanted[i] {
                pixel_stats(layer, fresh, i)
            } else {
                (0.0, 0.0)
            }
        })
        .collect();
    stepped
        .par_iter()
        .map(|&i| {
            let (mut lo, mut hi, mut s2, mut k) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0.0);
            for c in around(i as usize, size) {
                lo = lo.min(stats[c].0);
                hi = hi.max(stats[c].0);
                s2 += stats[c].1;
                k += 1.0;
            }
            (hi - lo, stats[i as usize].1.max(s2 / k))
        })
        .collect()
}

/// Pixel `i`'s mean luminance over every sample, fresh and reused, and their pooled
/// per-sample variance (infinite without a degree of freedom).
fn pixel_stats(layer: &Layer, fresh: &[Moments], i: usize) -> (f64, f64) {
    let f = &fresh[i];
    let (mut sum, mut n, mut within, mut dof) = (f.sum, f.n, f.within, f.dof);
    for (frame, lum) in layer.frames.iter().zip(&layer.lum) {
        let m = Moments::of(lum[i].0, lum[i].1, frame[i].history().sum_lum2);
        sum += m.sum;
        n += m.n;
        within += m.within;
        dof += m.dof;
    }
    let mean = if n > 0.0 { sum / n } else { 0.0 };
    let s2 = if dof > 0.0 {
        within / dof
    } else {
        f64::INFINITY
    };
    (mean, s2)
}
