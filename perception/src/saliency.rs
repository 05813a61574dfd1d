//! Bottom-up visual saliency (Itti, Koch & Niebur 1998) and the saliency-weighted threshold of
//! Yee, Pattanaik & Greenberg 2001 (the "Aleph map").
//!
//! # Model (Itti, Koch & Niebur 1998, "A Model of Saliency-Based Visual Attention for Rapid
//! Scene Analysis", IEEE PAMI 20(11), §2)
//! - Features from linear RGB (r, g, b): intensity I = (r + g + b)/3; colour opponents, with hue
//!   normalised by I and zeroed where I < max(I)/10: R = r − (g + b)/2, G = g − (r + b)/2,
//!   B = b − (r + g)/2, Y = (r + g)/2 − |r − g|/2 − b (negative values set to 0); orientation
//!   from Gabor filters at 0°, 45°, 90°, 135° applied to I.
//! - Dyadic Gaussian pyramids (5-tap binomial filter, 9 levels, σ = 0..8). Centre–surround
//!   differences |c ⊖ s| between centre levels c ∈ {2, 3, 4} and surround levels s = c + δ,
//!   δ ∈ {3, 4} (the surround interpolated to the centre's level): intensity, the double
//!   opponents |(R − G)_c ⊖ (G − R)_s| and |(B − Y)_c ⊖ (Y − B)_s|, and each orientation.
//! - The normaliser N(·) (eq. 3 and §2.2): scale a map to [0, M] (M = 1), find the mean m̄ of its
//!   local maxima other than the global one, and multiply by (M − m̄)²: a map with one strong
//!   peak is promoted, a map with many comparable peaks suppressed.
//! - Conspicuity maps Ī, C̄, Ō are sums of the normalised feature maps at level 4; the saliency
//!   is S = (N(Ī) + N(C̄) + N(Ō))/3, upsampled to the image and scaled to [0, 1].
//!
//! Simplifications, stated: the Gabor filters are 7×7 with wavelength 4 px and σ 1.5 px at each
//! level; local maxima for N(·) are taken over 3×3 neighbourhoods of the level-4 map. Yee et al.
//! add a motion channel; it is left out here (moving content is handled by the velocity term of
//! the threshold map).
//!
//! # Aleph map (Yee et al. 2001, §4.3)
//! Salient regions are watched and get a lower error tolerance: ΔL_A(x) = ΔL_T(x) / (1 + ω S(x)),
//! with a user weight ω ≥ 0 (ω = 0 leaves the map unchanged). Yee et al. modulate the elevation
//! factor by saliency; dividing the whole threshold is the form aleph's `docs/DESIGN.md` §6 suggests and is
//! documented here as our choice.

use crate::error::{PerceptionError, Result, check_image};

const LEVELS: usize = 9;

/// One pyramid level: width, height, values.
#[derive(Clone, Debug)]
struct Level {
    w: usize,
    h: usize,
    v: Vec<f32>,
}

/// Blur with the 5-tap binomial [1 4 6 4 1]/16 in x and y, then take every other pixel.
fn reduce(l: &Level) -> Level {
    const K: [f32; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];
    let (w, h) = (l.w, l.h);
    let at = |v: &[f32], x: i64, y: i64| {
        v[(y.clamp(0, h as i64 - 1) as usize) * w + x.clamp(0, w as i64 - 1) as usize]
    };
    let mut tmp = vec![0f32; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            tmp[y as usize * w + x as usize] =
                (0..5).map(|k| K[k] * at(&l.v, x + k as i64 - 2, y)).sum();
        }
    }
    let (nw, nh) = (w.div_ceil(2).max(1), h.div_ceil(2).max(1));
    let mut out = vec![0f32; nw * nh];
    for y in 0..nh {
        for x in 0..nw {
            let (sx, sy) = ((2 * x) as i64, (2 * y) as i64);
            out[y * nw + x] = (0..5).map(|k| K[k] * at(&tmp, sx, sy + k as i64 - 2)).sum();
        }
    }
    Level {
        w: nw,
        h: nh,
        v: out,
    }
}

fn pyramid(v: Vec<f32>, w: usize, h: usize) -> Vec<Level> {
    let mut p = vec![Level { w, h, v }];
    for _ in 1..LEVELS {
        let next = reduce(p.last().expect("non-empty"));
        p.push(next);
    }
    p
}

/// Bilinear resampling of a level to `w × h` (pixel centres aligned).
fn resample(l: &Level, w: usize, h: usize) -> Vec<f32> {
    let mut out = vec![0f32; w * h];
    let (sx, sy) = (l.w as f32 / w as f32, l.h as f32 / h as f32);
    for y in 0..h {
        let fy = ((y as f32 + 0.5) * sy - 0.5).clamp(0.0, (l.h - 1) as f32);
        let (y0, ty) = (fy as usize, fy.fract());
        let y1 = (y0 + 1).min(l.h - 1);
        for x in 0..w {
            let fx = ((x as f32 + 0.5) * sx - 0.5).clamp(0.0, (l.w - 1) as f32);
            let (x0, tx) = (fx as usize, fx.fract());
            let x1 = (x0 + 1).min(l.w - 1);
            let a = l.v[y0 * l.w + x0] * (1.0 - tx) + l.v[y0 * l.w + x1] * tx;
            let b = l.v[y1 * l.w + x0] * (1.0 - tx) + l.v[y1 * l.w + x1] * tx;
            out[y * w + x] = a * (1.0 - ty) + b * ty;
        }
    }
    out
}

/// The normaliser N(·): scale to [0, 1], multiply by (1 − m̄)² with m̄ the mean of the local
/// maxima (3×3) other than the global maximum.
fn normalise(v: &[f32], w: usize, h: usize) -> Vec<f32> {
    let max = v.iter().cloned().fold(0f32, f32::max);
    if max <= 0.0 {
        return vec![0.0; v.len()];
    }
    let s: Vec<f32> = v.iter().map(|x| x / max).collect();
    let mut sum = 0.0f64;
    let mut count = 0usize;
    for y in 0..h {
        for x in 0..w {
            let c = s[y * w + x];
            if c >= 1.0 || c <= 0.0 {
                continue;
            }
            let mut is_max = true;
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                    if (dx, dy) != (0, 0)
                        && xx >= 0
                        && yy >= 0
                        && xx < w as i64
                        && yy < h as i64
                        && s[yy as usize * w + xx as usize] > c
                    {
                        is_max = false;
                    }
                }
            }
            if is_max {
                sum += c as f64;
                count += 1;
            }
        }
    }
    let mbar = if count > 0 {
        (sum / count as f64) as f32
    } else {
        0.0
    };
    let k = (1.0 - mbar) * (1.0 - mbar);
    s.iter().map(|x| x * k).collect()
}

/// 7×7 Gabor filter response magnitude (even part) at orientation `theta` radians.
fn gabor(l: &Level, theta: f32) -> Level {
    let (w, h) = (l.w, l.h);
    let (c, sn) = (theta.cos(), theta.sin());
    let mut kernel = [[0f32; 7]; 7];
    let mut mean = 0.0;
    for (j, row) in kernel.iter_mut().enumerate() {
        for (i, k) in row.iter_mut().enumerate() {
            let (x, y) = (i as f32 - 3.0, j as f32 - 3.0);
            let xr = x * c + y * sn;
            let env = (-(x * x + y * y) / (2.0 * 1.5 * 1.5)).exp();
            *k = env * (2.0 * std::f32::consts::PI * xr / 4.0).cos();
            mean += *k;
        }
    }
    mean /= 49.0;
    let at = |x: i64, y: i64| {
        l.v[(y.clamp(0, h as i64 - 1) as usize) * w + x.clamp(0, w as i64 - 1) as usize]
    };
    let mut out = vec![0f32; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let mut s = 0.0;
            for (j, row) in kernel.iter().enumerate() {
                for (i, k) in row.iter().enumerate() {
                    s += (k - mean) * at(x + i as i64 - 3, y + j as i64 - 3);
                }
            }
            out[y as usize * w + x as usize] = s.abs();
        }
    }
    Level { w, h, v: out }
}

/// Sum over (c, s) of N(|centre(c) − surround(s)|) at level 4, for maps given per level by
/// `centre` and `surround` pyramids.
fn across_scales(centre: &[Level], surround: &[Level]) -> Vec<f32> {
    let (w4, h4) = (centre[4].w, centre[4].h);
    let mut acc = vec![0f32; w4 * h4];
    for (c, cl) in centre.iter().enumerate().take(5).skip(2) {
        for delta in 3..=4 {
            let s = c + delta;
            if s >= LEVELS {
                continue;
            }
            let (cw, ch) = (cl.w, cl.h);
            let sur = resample(&surround[s], cw, ch);
            let diff: Vec<f32> = cl.v.iter().zip(&sur).map(|(a, b)| (a - b).abs()).collect();
            let d4 = resample(
                &Level {
                    w: cw,
                    h: ch,
                    v: diff,
                },
                w4,
                h4,
            );
            for (a, v) in acc.iter_mut().zip(normalise(&d4, w4, h4)) {
                *a += v;
            }
        }
    }
    acc
}

/// Itti–Koch–Niebur saliency of a linear RGB image (interleaved, `width × height`), in [0, 1]
/// per pixel (row-major).
///
/// # Errors
/// [`PerceptionError`] for a zero size, a wrong length, or NaN/infinite/negative values.
pub fn saliency_map(rgb: &[f32], width: usize, height: usize) -> Result<Vec<f32>> {
    check_image("RGB", rgb, width, height, 3, true)?;
    let n = width * height;
    let intensity: Vec<f32> = rgb
        .chunks_exact(3)
        .map(|p| (p[0] + p[1] + p[2]) / 3.0)
        .collect();
    let imax = intensity.iter().cloned().fold(0f32, f32::max);
    let mut rg = vec![0f32; n];
    let mut gr = vec![0f32; n];
    let mut by = vec![0f32; n];
    let mut yb = vec![0f32; n];
    for (i, p) in rgb.chunks_exact(3).enumerate() {
        let int = intensity[i];
        if int <= 0.0 || int < imax / 10.0 {
            continue;
        }
        let (r, g, b) = (p[0] / int, p[1] / int, p[2] / int);
        let big_r = (r - (g + b) / 2.0).max(0.0);
        let big_g = (g - (r + b) / 2.0).max(0.0);
        let big_b = (b - (r + g) / 2.0).max(0.0);
        let big_y = ((r + g) / 2.0 - (r - g).abs() / 2.0 - b).max(0.0);
        rg[i] = big_r - big_g;
        gr[i] = big_g - big_r;
        by[i] = big_b - big_y;
        yb[i] = big_y - big_b;
    }
    let pi = pyramid(intensity, width, height);
    let i_bar = across_scales(&pi, &pi);
    let c_bar: Vec<f32> = across_scales(&pyramid(rg, width, height), &pyramid(gr, width, height))
        .into_iter()
        .zip(across_scales(
            &pyramid(by, width, height),
            &pyramid(yb, width, height),
        ))
        .map(|(a, b)| a + b)
        .collect();
    let (w4, h4) = (pi[4].w, pi[4].h);
    let mut o_bar = vec![0f32; w4 * h4];
    for k in 0..4 {
        let theta = k as f32 * std::f32::consts::FRAC_PI_4;
        let po: Vec<Level> = pi.iter().map(|l| gabor(l, theta)).collect();
        for (a, v) in o_bar.iter_mut().zip(across_scales(&po, &po)) {
            *a += v;
        }
    }
    let s4: Vec<f32> = normalise(&i_bar, w4, h4)
        .into_iter()
        .zip(normalise(&c_bar, w4, h4))
        .zip(normalise(&o_bar, w4, h4))
        .map(|((a, b), c)| (a + b + c) / 3.0)
        .collect();
    let full = resample(
        &Level {
            w: w4,
            h: h4,
            v: s4,
        },
        width,
        height,
    );
    let max = full.iter().cloned().fold(0f32, f32::max);
    Ok(if max > 0.0 {
        full.iter().map(|v| v / max).collect()
    } else {
        full
    })
}

/// The Aleph map: ΔL_A = ΔL / (1 + ω S), salient regions getting a lower tolerance.
///
/// # Errors
/// [`PerceptionError::Parameter`] if ω is negative or not finite, or the lengths differ.
pub fn aleph_map(threshold: &[f32], saliency: &[f32], omega: f32) -> Result<Vec<f32>> {
    if !(omega.is_finite() && omega >= 0.0) {
        return Err(PerceptionError::Parameter {
            name: "saliency weight ω",
            value: omega as f64,
            range: "≥ 0",
        });
    }
    if threshold.len() != saliency.len() {
        return Err(PerceptionError::BufferSize {
            what: "saliency",
            len: saliency.len(),
            expected: threshold.len(),
            width: threshold.len(),
            height: 1,
            channels: 1,
        });
    }
    Ok(threshold
        .iter()
        .zip(saliency)
        .map(|(t, s)| t / (1.0 + omega * s))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_red_disc_on_grey_is_the_most_salient_thing() {
        // A grey field with a red disc (colour contrast, a single strong peak in the colour
        // channel: N(·) promotes it) on one side and faint grey texture elsewhere.
        let (w, h) = (256, 192);
        let mut rgb = vec![0.4f32; 3 * w * h];
        for y in 0..h {
            for x in 0..w {
                let i = 3 * (y * w + x);
                if (x as f32 - 190.0).powi(2) + (y as f32 - 96.0).powi(2) < 18.0f32.powi(2) {
                    rgb[i] = 0.8;
                    rgb[i + 1] = 0.1;
                    rgb[i + 2] = 0.1;
                } else if ((x / 4) + (y / 4)) % 2 == 0 {
                    for c in 0..3 {
                        rgb[i + c] = 0.42;
                    }
                }
            }
        }
        let s = saliency_map(&rgb, w, h).unwrap();
        let at = |x: usize, y: usize| s[y * w + x];
        assert!(s.iter().all(|v| (0.0..=1.0).contains(v)));
        assert!(at(190, 96) > 0.6, "disc {}", at(190, 96));
        assert!(
            at(60, 96) < 0.3 * at(190, 96),
            "background {} vs disc {}",
            at(60, 96),
            at(190, 96)
        );
        // The Aleph map lowers the threshold where the eye will look.
        let t = vec![2.0f32; w * h];
        let a = aleph_map(&t, &s, 2.0).unwrap();
        assert!(a[96 * w + 190] < 0.6 * 2.0 && (a[96 * w + 60] - 2.0).abs() < 0.6);
        assert!(aleph_map(&t, &s, -1.0).is_err());
        assert!(saliency_map(&[0.0; 5], 1, 1).is_err());
    }
}
