//! The allocation of a pass: how many more samples each pixel gets from its error ratio.

use crate::film::Film;
use rayon::prelude::*;

/// 3×3 dilation of a mask (row-major `w × h`).
pub(crate) fn dilate3(m: &[bool], w: usize, h: usize) -> Vec<bool> {
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let xx = x + dx;
                    let yy = y + dy;
                    xx >= 0
                        && yy >= 0
                        && xx < w as i64
                        && yy < h as i64
                        && m[yy as usize * w + xx as usize]
                })
            })
        })
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
    /// Samples in the pass.
    pub fn total(&self) -> u64 {
        self.want.iter().map(|&c| c as u64).sum()
    }
}

/// Pixels with error ratio r above the target `t_level` need about n (r²/t² − 1) more samples
/// (error falls as 1/√n); each gets that, at most doubling its count, never past `max_spp`;
/// their 8 neighbours are re-opened with at least n/4. Every count is then rounded up so the
/// pixel's total is a power of two, where its Sobol' samples are stratified. Perceptual
/// against uniform sampling (both Sobol'), samples saved at equal FLIP p99, without → with
/// the rounding: Cornell box 256² at 32/64 spp 0.99×/0.78× → 1.04×/1.10×; holodeck 240×160 at
/// 64 spp 0.82× → 1.12× (1.25× at 128).
pub(crate) fn allocate(film: &Film, ratio: &[f32], t_level: f32, max_spp: u32) -> Allocation {
    let (w, h) = (film.width as usize, film.height as usize);
    let active: Vec<bool> = ratio.par_iter().map(|&r| r > t_level).collect();
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
                let q = (r / t_level).min(1e3);
                (nf * (q * q - 1.0)).ceil()
            } else {
                0.0
            };
            c = c.max((nf / 4.0).ceil()).max(1.0).min(nf.max(1.0));
            // Up to the next power-of-two total: each half-buffer's Owen-scrambled Sobol'
            // sequence is a (0,2)-net only over power-of-two prefixes.
            let c = (n + c as u32).next_power_of_two() - n;
            c.min(max_spp - n)
        })
        .collect();
    Allocation { want, reopen }
}

/// Under a sample budget B, no pixel whose noise could be seen is left below FLOOR_SHARE · B
/// samples: the perceptual threshold ranks pixels only roughly as the judges do (Spearman
/// correlation 0.3–0.6 with the FLIP oracle's ranking on the Cornell box), and starving the
/// pixels it misranks cost more than its savings elsewhere. Perceptual against uniform at equal
/// score, holodeck 256², 64 / 128 / 256 spp, without → with the floor: FLIP p99 at −2 EV 0.84 /
/// 0.86 / — → 0.99 / 1.10 / 1.23×; ColorVideoVDP JOD 0.95 / 0.85 / — → 1.03 / 1.22 / 1.36×
/// (— : never reached uniform's score). With pixel totals on powers of two, 1/2 is the only
/// share between none and uniform.
pub(crate) const FLOOR_SHARE: f64 = 0.5;

/// Pixels below `floor` samples that the allocation passes over get a doubling (to the next
/// power-of-two total, never past `max_spp`), unless their ratio is exactly 0: no noise at all
/// (every sample equal, in them and their 8 neighbours). Pixels the tone curve clips at every
/// grade keep the floor: the clipping is judged on pooled means, which a clipped light next to
/// a dark pixel can mislead, and without the floor those pixels cost the holodeck its gains
/// (FLIP p99 at −2 EV 0.99 / 1.10× → 0.83 / 0.84× at 64 / 128 spp).
pub(crate) fn raise_to_floor(
    alloc: &mut Allocation,
    film: &Film,
    ratio: &[f32],
    floor: u32,
    max_spp: u32,
) {
    for (i, (c, px)) in alloc.want.iter_mut().zip(&film.pixels).enumerate() {
        if *c == 0 && px.n < floor.min(max_spp) && ratio[i] > 0.0 {
            *c = ((px.n + 1).next_power_of_two().min(max_spp)).saturating_sub(px.n);
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
        raise_to_floor(&mut a, &film, &[0.5, 0.0, 0.5, 2.0], 16, 4096);
        assert_eq!(a.want, [8, 0, 0, 8]);
        assert!(a.reopen[0] && !a.reopen[1]);
    }

    #[test]
    fn totals_land_on_powers_of_two() {
        let mut film = Film::new(8, 8);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            p.n = [8, 16, 32, 8][i % 4];
        }
        let ratio: Vec<f32> = (0..64).map(|i| (i % 7) as f32 * 0.4).collect();
        let a = allocate(&film, &ratio, 1.0, 4096);
        let mut grew = 0;
        for (p, &c) in film.pixels.iter().zip(&a.want) {
            if c > 0 {
                grew += 1;
                assert!((p.n + c).is_power_of_two(), "{} + {c}", p.n);
            }
        }
        assert!(grew > 0);
    }
}
