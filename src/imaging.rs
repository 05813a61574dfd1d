//! Scene-independent image helpers of the renderer, in one place: window filters (box mean,
//! median, 3×3 maximum), integer downscaling, and false colour.
//!
//! Images are row-major `w × h` slices, interleaved when they have several channels. The
//! perception crate keeps its own running-sum box blur (`perception::threshold`, for the
//! masking model's band energies at large radii): it cannot depend on the renderer, and the
//! renderer's direct sums here are what the sampler's decisions were measured with, so the two
//! are not merged (their roundings differ, and with them the rendered images).

use rayon::prelude::*;

/// Mean over the (2r+1) × (2r+1) window around each pixel of a row-major `w × h` image, with
/// edges clamped (the border pixels repeat). The one box filter of the renderer: 3×3 for the
/// adaptive sampler's error estimate, 5×5 for FLIP's p99 pooling.
pub fn box_mean(v: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    box_mean_interleaved(v, w, h, 1, r)
}

/// Median over the (2r+1) × (2r+1) window around each pixel of a row-major `w × h` image (the
/// window cut at the borders; of an even count, the upper middle value). Unlike [`box_mean`]
/// it ignores isolated outliers, such as one pixel's time inflated by a stall of the machine.
///
/// # Panics
/// If `v.len() != w · h`.
pub fn median_filter(v: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    assert_eq!(v.len(), w * h, "median_filter: buffer is not {w}×{h}");
    (0..w * h)
        .into_par_iter()
        .map_init(Vec::new, |win: &mut Vec<f32>, i| {
            let (x, y) = (i % w, i / w);
            win.clear();
            for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
                win.extend_from_slice(
                    &v[yy * w + x.saturating_sub(r)..yy * w + (x + r + 1).min(w)],
                );
            }
            let mid = win.len() / 2;
            *win.select_nth_unstable_by(mid, f32::total_cmp).1
        })
        .collect()
}

/// Largest value over the 3×3 window around each pixel of a row-major `w × h` image (the
/// window cut at the borders).
///
/// # Panics
/// If `v.len() != w · h`.
pub fn max_filter3(v: &[f32], w: usize, h: usize) -> Vec<f32> {
    assert_eq!(v.len(), w * h, "max_filter3: buffer is not {w}×{h}");
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut m = f32::NEG_INFINITY;
            for yy in y.saturating_sub(1)..(y + 2).min(h) {
                for xx in x.saturating_sub(1)..(x + 2).min(w) {
                    m = m.max(v[yy * w + xx]);
                }
            }
            m
        })
        .collect()
}

/// [`box_mean`] of each channel of an image with `c` interleaved channels (`w × h × c`),
/// separably: a horizontal pass, then a vertical one, rows in parallel.
///
/// # Panics
/// If `v.len() != w · h · c`.
pub fn box_mean_interleaved(v: &[f32], w: usize, h: usize, c: usize, r: usize) -> Vec<f32> {
    assert_eq!(v.len(), w * h * c, "box_mean: buffer is not {w}×{h}×{c}");
    let row = w * c;
    let clamp = |i: i64, n: usize| i.clamp(0, n as i64 - 1) as usize;
    let mut across = vec![0f32; v.len()];
    across
        .par_chunks_mut(row.max(1))
        .zip(v.par_chunks(row.max(1)))
        .for_each(|(out, src)| {
            for x in 0..w {
                for ch in 0..c {
                    let mut s = 0.0;
                    for dx in -(r as i64)..=r as i64 {
                        s += src[clamp(x as i64 + dx, w) * c + ch];
                    }
                    out[x * c + ch] = s;
                }
            }
        });
    let norm = ((2 * r + 1) * (2 * r + 1)) as f32;
    let mut out = vec![0f32; v.len()];
    out.par_chunks_mut(row.max(1))
        .enumerate()
        .for_each(|(y, o)| {
            for dy in -(r as i64)..=r as i64 {
                let yy = clamp(y as i64 + dy, h);
                let src = &across[yy * row..(yy + 1) * row];
                o.iter_mut().zip(src).for_each(|(a, b)| *a += b);
            }
            o.iter_mut().for_each(|a| *a /= norm);
        });
    out
}

/// Box-filter downscale of interleaved RGB by an integer factor `f`: each output pixel is the
/// mean of an `f × f` block (summed in f64), the last `w mod f` columns and `h mod f` rows
/// dropped. Returns the image and its size.
pub fn box_shrink<T: Copy + Default>(
    rgb: &[T],
    (w, h): (usize, usize),
    f: usize,
    to: impl Fn(T) -> f64,
    from: impl Fn(f64) -> T,
) -> (Vec<T>, usize, usize) {
    if f <= 1 {
        return (rgb.to_vec(), w, h);
    }
    let (nw, nh) = (w / f, h / f);
    let mut out = vec![T::default(); 3 * nw * nh];
    for y in 0..nh {
        for x in 0..nw {
            for c in 0..3 {
                let mut s = 0.0;
                for dy in 0..f {
                    for dx in 0..f {
                        s += to(rgb[3 * ((y * f + dy) * w + x * f + dx) + c]);
                    }
                }
                out[3 * (y * nw + x) + c] = from(s / (f * f) as f64);
            }
        }
    }
    (out, nw, nh)
}

/// Box-filter downscale of linear interleaved RGB by an integer factor ([`box_shrink`]).
pub fn downscale(rgb: &[f32], w: usize, h: usize, f: usize) -> (Vec<f32>, usize, usize) {
    box_shrink(rgb, (w, h), f, |v| v as f64, |v| v as f32)
}

/// Box-filter downscale of 8-bit interleaved RGB (`w × h`) by an integer factor `f`, each
/// value the block mean rounded down; the image is `w / f × h / f`.
pub fn shrink_rgb8(rgb8: &[u8], w: usize, h: usize, f: usize) -> Vec<u8> {
    box_shrink(rgb8, (w, h), f, |v| v as f64, |v| v as u8).0
}

/// False-colour 8-bit RGB of positive values on a log scale from `lo` (dark) to `hi` (bright),
/// with FLIP's magma colour map (Andersson et al. 2020, as shipped by the nv-flip crate).
pub fn false_colour(values: &[f32], lo: f32, hi: f32) -> Vec<u8> {
    let lut = nv_flip::magma_lut().to_vec();
    let (l0, l1) = (lo.max(1e-30).ln(), hi.max(lo * 1.0001).ln());
    values
        .iter()
        .flat_map(|&v| {
            let t = if v > 0.0 {
                ((v.ln() - l0) / (l1 - l0)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let i = (t * 255.0).round() as usize;
            [lut[3 * i], lut[3 * i + 1], lut[3 * i + 2]]
        })
        .collect()
}

/// The `aleph diff` overlay, display-linear RGB: the reference's luminance `lum` as grey (log
/// average at 0.18, halved), with pixels whose error/threshold `ratio` exceeds 1 in red, more
/// saturated the larger the ratio (log2 ratio / 4, at least ¼).
///
/// # Panics
/// If `lum` and `ratio` differ in length.
pub fn difference_overlay(lum: &[f32], ratio: &[f32]) -> Vec<f32> {
    assert_eq!(lum.len(), ratio.len(), "difference_overlay: sizes differ");
    let mean = lum.iter().map(|&v| v as f64).sum::<f64>() / lum.len().max(1) as f64;
    let grey_scale = 0.18 / mean.max(1e-9) as f32;
    let mut display = Vec::with_capacity(3 * lum.len());
    for (&l, &ratio) in lum.iter().zip(ratio) {
        let g = 0.5 * (l * grey_scale).min(1.0);
        if ratio > 1.0 {
            let a = (ratio.log2() / 4.0).clamp(0.25, 1.0);
            display.extend_from_slice(&[a.max(g), g * (1.0 - a), g * (1.0 - a)]);
        } else {
            display.extend_from_slice(&[g, g, g]);
        }
    }
    display
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn median_filter_removes_spikes_and_keeps_edges() {
        // A step edge (left half 1, right half 5) with two one-pixel spikes: the 5×5 median
        // gives back the step exactly, spikes gone.
        let (w, h) = (12, 9);
        let step = |i: usize| if i % w < w / 2 { 1.0f32 } else { 5.0 };
        let mut v: Vec<f32> = (0..w * h).map(step).collect();
        v[4 * w + 2] = 1000.0;
        v[w + 9] = -300.0;
        let m = median_filter(&v, w, h, 2);
        for (i, &got) in m.iter().enumerate() {
            assert_eq!(got, step(i), "pixel ({}, {})", i % w, i / w);
        }
        // Against a direct sort of each window on a pseudo-random image, corners included.
        let mut rng = Rng::new(7, 0);
        let v: Vec<f32> = (0..w * h).map(|_| rng.uniform()).collect();
        let m = median_filter(&v, w, h, 1);
        for y in 0..h {
            for x in 0..w {
                let mut win = Vec::new();
                for yy in y.saturating_sub(1)..(y + 2).min(h) {
                    for xx in x.saturating_sub(1)..(x + 2).min(w) {
                        win.push(v[yy * w + xx]);
                    }
                }
                win.sort_by(f32::total_cmp);
                assert_eq!(m[y * w + x], win[win.len() / 2]);
            }
        }
    }

    #[test]
    fn separable_box_mean_equals_the_direct_window_sum() {
        // The direct definition: the mean of the clamped (2r+1)² window, channel by channel.
        let (w, h, c) = (13, 7, 3);
        let mut rng = Rng::new(5, 0);
        let v: Vec<f32> = (0..w * h * c).map(|_| rng.uniform() * 10.0).collect();
        for r in [0usize, 1, 2, 4, 9] {
            let got = box_mean_interleaved(&v, w, h, c, r);
            for y in 0..h {
                for x in 0..w {
                    for ch in 0..c {
                        let mut s = 0.0f64;
                        for dy in -(r as i64)..=r as i64 {
                            for dx in -(r as i64)..=r as i64 {
                                let xx = (x as i64 + dx).clamp(0, w as i64 - 1) as usize;
                                let yy = (y as i64 + dy).clamp(0, h as i64 - 1) as usize;
                                s += v[(yy * w + xx) * c + ch] as f64;
                            }
                        }
                        let want = s / ((2 * r + 1) * (2 * r + 1)) as f64;
                        let g = got[(y * w + x) * c + ch] as f64;
                        assert!(
                            (g - want).abs() < 1e-5 * want.max(1.0),
                            "r {r} ({x},{y},{ch})"
                        );
                    }
                }
            }
        }
        let plane: Vec<f32> = v.iter().step_by(3).copied().collect();
        let one = box_mean(&plane, w, h, 2);
        let three = box_mean_interleaved(&v, w, h, 3, 2);
        assert!(one.iter().zip(three.iter().step_by(3)).all(|(a, b)| a == b));
    }
}
