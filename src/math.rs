//! Small geometric helpers shared by the renderer: the shading [`Frame`], reflection and
//! refraction, RGB luminance.

use glam::Vec3;

/// An orthonormal frame (s, t, n). Local coordinates have the normal along +z, so a BSDF only
/// ever sees cos θ = `w.z` (pbrt-v4's `BSDF::RenderToLocal`).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent.
    pub t: Vec3,
    /// Normal (unit length).
    pub n: Vec3,
}

impl Frame {
    /// A frame around the unit normal `n` (Duff et al. 2017, "Building an Orthonormal Basis,
    /// Revisited").
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// World → local.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world.
    #[inline]
    pub fn from_local(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Mirror reflection of `wo` about the normal `n` (both pointing away from the surface).
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + 2.0 * wo.dot(n) * n
}

/// Refraction of `wo` through a surface with normal `n` (on the side of `wo`) and relative index
/// `eta` = η_transmitted / η_incident. Returns `None` on total internal reflection.
#[inline]
pub fn refract(wo: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = wo.dot(n);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wo / eta + (cos_i / eta - cos_t) * n)
}

/// Relative luminance of linear Rec.709 RGB (ITU-R BT.709: 0.2126, 0.7152, 0.0722), the same
/// weights as [`perception::photometry::luminance`].
#[inline]
pub fn luminance(rgb: Vec3) -> f32 {
    perception::photometry::luminance(rgb.x, rgb.y, rgb.z)
}

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
    use rayon::prelude::*;
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
    use rayon::prelude::*;
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
    use rayon::prelude::*;
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

/// |v| that does not overflow: glam's `length` squares the components, which is infinite in f32
/// beyond about 1.8e19 (a triangle's cross product at scene scales of 1e10). Bit-identical to
/// `length` whenever that is finite.
#[inline]
pub fn robust_length(v: Vec3) -> f32 {
    let l = v.length();
    if l.is_finite() {
        return l;
    }
    let m = v.abs().max_element();
    if !m.is_finite() || m == 0.0 {
        return l;
    }
    (v / m).length() * m
}

/// v / |v| (zero for a zero or non-finite vector) that does not overflow; bit-identical to
/// `normalize_or_zero` whenever that is non-zero.
#[inline]
pub fn robust_normalize(v: Vec3) -> Vec3 {
    let n = v.normalize_or_zero();
    if n != Vec3::ZERO {
        return n;
    }
    let m = v.abs().max_element();
    if !m.is_finite() || m == 0.0 {
        return Vec3::ZERO;
    }
    (v / m).normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;
    use crate::sampling::square_to_uniform_sphere;

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

    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        let mut rng = Rng::new(9, 9);
        for _ in 0..1000 {
            let n = square_to_uniform_sphere(rng.uniform2());
            let f = Frame::from_normal(n);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            let v = square_to_uniform_sphere(rng.uniform2());
            assert!((f.from_local(f.to_local(v)) - v).length() < 1e-5);
            assert!((f.to_local(n) - Vec3::Z).length() < 1e-5);
        }
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = Vec3::Z;
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let wt = refract(wo, n, 1.5).unwrap();
        let sin_i = 0.6;
        let sin_t = (wt.x * wt.x + wt.y * wt.y).sqrt() / wt.length();
        assert!((sin_i - 1.5 * sin_t).abs() < 1e-5);
        assert!(wt.z < 0.0);
        // Total internal reflection leaving glass at a grazing angle.
        assert!(refract(Vec3::new(0.9, 0.0, 0.4359).normalize(), n, 1.0 / 1.5).is_none());
    }
}
