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
/// with the magma colour map (FLIP's, Andersson et al. 2020: [`MAGMA`]).
pub fn false_colour(values: &[f32], lo: f32, hi: f32) -> Vec<u8> {
    let lut: Vec<u8> = MAGMA.iter().flatten().copied().collect();
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

/// The magma colour map, 256 entries of 8-bit sRGB: van der Walt & Smith's perceptually uniform
/// map for matplotlib (CC0), as FLIP's error maps show it (the table the nv-flip crate ships,
/// copied so that the renderer does not depend on a judge).
pub const MAGMA: [[u8; 3]; 256] = [
    [0, 0, 4],
    [1, 0, 5],
    [1, 1, 6],
    [1, 1, 8],
    [2, 1, 9],
    [2, 2, 11],
    [2, 2, 13],
    [3, 3, 15],
    [3, 3, 18],
    [4, 4, 20],
    [5, 4, 22],
    [6, 5, 24],
    [6, 5, 26],
    [7, 6, 28],
    [8, 7, 30],
    [9, 7, 32],
    [10, 8, 34],
    [11, 9, 36],
    [12, 9, 38],
    [13, 10, 41],
    [14, 11, 43],
    [16, 11, 45],
    [17, 12, 47],
    [18, 13, 49],
    [19, 13, 52],
    [20, 14, 54],
    [21, 14, 56],
    [22, 15, 59],
    [24, 15, 61],
    [25, 16, 63],
    [26, 16, 66],
    [28, 16, 68],
    [29, 17, 71],
    [30, 17, 73],
    [32, 17, 75],
    [33, 17, 78],
    [34, 17, 80],
    [36, 18, 83],
    [37, 18, 85],
    [39, 18, 88],
    [41, 17, 90],
    [42, 17, 92],
    [44, 17, 95],
    [45, 17, 97],
    [47, 17, 99],
    [49, 17, 101],
    [51, 16, 103],
    [52, 16, 105],
    [54, 16, 107],
    [56, 16, 108],
    [57, 15, 110],
    [59, 15, 112],
    [61, 15, 113],
    [63, 15, 114],
    [64, 15, 116],
    [66, 15, 117],
    [68, 15, 118],
    [69, 16, 119],
    [71, 16, 120],
    [73, 16, 120],
    [74, 16, 121],
    [76, 17, 122],
    [78, 17, 123],
    [79, 18, 123],
    [81, 18, 124],
    [82, 19, 124],
    [84, 19, 125],
    [86, 20, 125],
    [87, 21, 126],
    [89, 21, 126],
    [90, 22, 126],
    [92, 22, 127],
    [93, 23, 127],
    [95, 24, 127],
    [96, 24, 128],
    [98, 25, 128],
    [100, 26, 128],
    [101, 26, 128],
    [103, 27, 128],
    [104, 28, 129],
    [106, 28, 129],
    [107, 29, 129],
    [109, 29, 129],
    [110, 30, 129],
    [112, 31, 129],
    [114, 31, 129],
    [115, 32, 129],
    [117, 33, 129],
    [118, 33, 129],
    [120, 34, 129],
    [121, 34, 130],
    [123, 35, 130],
    [124, 35, 130],
    [126, 36, 130],
    [128, 37, 130],
    [129, 37, 129],
    [131, 38, 129],
    [132, 38, 129],
    [134, 39, 129],
    [136, 39, 129],
    [137, 40, 129],
    [139, 41, 129],
    [140, 41, 129],
    [142, 42, 129],
    [144, 42, 129],
    [145, 43, 129],
    [147, 43, 128],
    [148, 44, 128],
    [150, 44, 128],
    [152, 45, 128],
    [153, 45, 128],
    [155, 46, 127],
    [156, 46, 127],
    [158, 47, 127],
    [160, 47, 127],
    [161, 48, 126],
    [163, 48, 126],
    [165, 49, 126],
    [166, 49, 125],
    [168, 50, 125],
    [170, 51, 125],
    [171, 51, 124],
    [173, 52, 124],
    [174, 52, 123],
    [176, 53, 123],
    [178, 53, 123],
    [179, 54, 122],
    [181, 54, 122],
    [183, 55, 121],
    [184, 55, 121],
    [186, 56, 120],
    [188, 57, 120],
    [189, 57, 119],
    [191, 58, 119],
    [192, 58, 118],
    [194, 59, 117],
    [196, 60, 117],
    [197, 60, 116],
    [199, 61, 115],
    [200, 62, 115],
    [202, 62, 114],
    [204, 63, 113],
    [205, 64, 113],
    [207, 64, 112],
    [208, 65, 111],
    [210, 66, 111],
    [211, 67, 110],
    [213, 68, 109],
    [214, 69, 108],
    [216, 69, 108],
    [217, 70, 107],
    [219, 71, 106],
    [220, 72, 105],
    [222, 73, 104],
    [223, 74, 104],
    [224, 76, 103],
    [226, 77, 102],
    [227, 78, 101],
    [228, 79, 100],
    [229, 80, 100],
    [231, 82, 99],
    [232, 83, 98],
    [233, 84, 98],
    [234, 86, 97],
    [235, 87, 96],
    [236, 88, 96],
    [237, 90, 95],
    [238, 91, 94],
    [239, 93, 94],
    [240, 95, 94],
    [241, 96, 93],
    [242, 98, 93],
    [242, 100, 92],
    [243, 101, 92],
    [244, 103, 92],
    [244, 105, 92],
    [245, 107, 92],
    [246, 108, 92],
    [246, 110, 92],
    [247, 112, 92],
    [247, 114, 92],
    [248, 116, 92],
    [248, 118, 92],
    [249, 120, 93],
    [249, 121, 93],
    [249, 123, 93],
    [250, 125, 94],
    [250, 127, 94],
    [250, 129, 95],
    [251, 131, 95],
    [251, 133, 96],
    [251, 135, 97],
    [252, 137, 97],
    [252, 138, 98],
    [252, 140, 99],
    [252, 142, 100],
    [252, 144, 101],
    [253, 146, 102],
    [253, 148, 103],
    [253, 150, 104],
    [253, 152, 105],
    [253, 154, 106],
    [253, 155, 107],
    [254, 157, 108],
    [254, 159, 109],
    [254, 161, 110],
    [254, 163, 111],
    [254, 165, 113],
    [254, 167, 114],
    [254, 169, 115],
    [254, 170, 116],
    [254, 172, 118],
    [254, 174, 119],
    [254, 176, 120],
    [254, 178, 122],
    [254, 180, 123],
    [254, 182, 124],
    [254, 183, 126],
    [254, 185, 127],
    [254, 187, 129],
    [254, 189, 130],
    [254, 191, 132],
    [254, 193, 133],
    [254, 194, 135],
    [254, 196, 136],
    [254, 198, 138],
    [254, 200, 140],
    [254, 202, 141],
    [254, 204, 143],
    [254, 205, 144],
    [254, 207, 146],
    [254, 209, 148],
    [254, 211, 149],
    [254, 213, 151],
    [254, 215, 153],
    [254, 216, 154],
    [253, 218, 156],
    [253, 220, 158],
    [253, 222, 160],
    [253, 224, 161],
    [253, 226, 163],
    [253, 227, 165],
    [253, 229, 167],
    [253, 231, 169],
    [253, 233, 170],
    [253, 235, 172],
    [252, 236, 174],
    [252, 238, 176],
    [252, 240, 178],
    [252, 242, 180],
    [252, 244, 182],
    [252, 246, 184],
    [252, 247, 185],
    [252, 249, 187],
    [252, 251, 189],
    [252, 253, 191],
];

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
