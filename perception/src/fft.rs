//! Planned 2-D real FFTs (realfft for the rows, rustfft for the columns), parallel with rayon.
//!
//! The spectrum of an `h × w` real image is stored **transposed**: `wc = w/2 + 1` rows (one per
//! horizontal frequency u = 0..wc) of `h` complex values (vertical frequencies v = 0..h in FFT
//! order), so that column transforms and per-frequency filters run over contiguous memory.

use rayon::prelude::*;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex32;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// A 2-D real FFT of a fixed size, with its plans made once and reused.
pub struct Fft2d {
    w: usize,
    h: usize,
    wc: usize,
    r2c: Arc<dyn RealToComplex<f32>>,
    c2r: Arc<dyn ComplexToReal<f32>>,
    col_fwd: Arc<dyn Fft<f32>>,
    col_inv: Arc<dyn Fft<f32>>,
}

impl std::fmt::Debug for Fft2d {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Fft2d({}×{})", self.w, self.h)
    }
}

/// The smallest n' ≥ n whose prime factors are all 2, 3, 5 or 7 (sizes rustfft handles fast).
pub fn good_size(n: usize) -> usize {
    let mut m = n.max(1);
    loop {
        let mut r = m;
        for p in [2, 3, 5, 7] {
            while r.is_multiple_of(p) {
                r /= p;
            }
        }
        if r == 1 {
            return m;
        }
        m += 1;
    }
}

impl Fft2d {
    /// Plans transforms for `w × h` images (both ≥ 1).
    pub fn new(w: usize, h: usize) -> Fft2d {
        let mut rp = RealFftPlanner::<f32>::new();
        let mut cp = FftPlanner::<f32>::new();
        Fft2d {
            w,
            h,
            wc: w / 2 + 1,
            r2c: rp.plan_fft_forward(w),
            c2r: rp.plan_fft_inverse(w),
            col_fwd: cp.plan_fft_forward(h),
            col_inv: cp.plan_fft_inverse(h),
        }
    }

    /// Width of the real images.
    pub fn width(&self) -> usize {
        self.w
    }

    /// Height of the real images.
    pub fn height(&self) -> usize {
        self.h
    }

    /// Number of horizontal frequencies stored (w/2 + 1).
    pub fn spectrum_rows(&self) -> usize {
        self.wc
    }

    /// Forward transform of a row-major `h × w` image into a transposed spectrum of
    /// `wc × h` values (unnormalised).
    ///
    /// # Panics
    /// If `input.len() != w × h`.
    pub fn forward(&self, input: &[f32]) -> Vec<Complex32> {
        assert_eq!(input.len(), self.w * self.h);
        let (w, h, wc) = (self.w, self.h, self.wc);
        let rows: Vec<Complex32> = input
            .par_chunks(w)
            .map_init(
                || (vec![0f32; w], self.r2c.make_scratch_vec()),
                |(buf, scratch), inp| {
                    buf.copy_from_slice(inp);
                    let mut out = self.r2c.make_output_vec();
                    self.r2c
                        .process_with_scratch(buf, &mut out, scratch)
                        .expect("buffer sizes are planned");
                    out
                },
            )
            .flatten_iter()
            .collect();
        let mut spec = transpose(&rows, h, wc);
        spec.par_chunks_mut(h).for_each_init(
            || vec![Complex32::new(0.0, 0.0); self.col_fwd.get_inplace_scratch_len()],
            |scratch, col| self.col_fwd.process_with_scratch(col, scratch),
        );
        spec
    }

    /// Inverse transform of a transposed spectrum (consumed) into a row-major `h × w` image,
    /// normalised so that `inverse(forward(x)) = x`.
    ///
    /// # Panics
    /// If `spec.len() != wc × h` or `out.len() != w × h`.
    pub fn inverse(&self, mut spec: Vec<Complex32>, out: &mut [f32]) {
        let (w, h, wc) = (self.w, self.h, self.wc);
        assert_eq!(spec.len(), wc * h);
        assert_eq!(out.len(), w * h);
        spec.par_chunks_mut(h).for_each_init(
            || vec![Complex32::new(0.0, 0.0); self.col_inv.get_inplace_scratch_len()],
            |scratch, col| self.col_inv.process_with_scratch(col, scratch),
        );
        let mut rows = transpose(&spec, wc, h);
        let norm = 1.0 / (w * h) as f32;
        rows.par_chunks_mut(wc)
            .zip(out.par_chunks_mut(w))
            .for_each_init(
                || self.c2r.make_scratch_vec(),
                |scratch, (inp, o)| {
                    // A real image's spectrum has real DC and Nyquist bins; clear rounding.
                    inp[0].im = 0.0;
                    if w.is_multiple_of(2) {
                        inp[wc - 1].im = 0.0;
                    }
                    self.c2r
                        .process_with_scratch(inp, o, scratch)
                        .expect("buffer sizes are planned");
                    for v in o.iter_mut() {
                        *v *= norm;
                    }
                },
            );
    }

    /// Spatial frequency in cycles per pixel of spectrum entry (row u, column v) of the
    /// transposed layout: sqrt((u/w)² + (v'/h)²), v' = v wrapped to [−h/2, h/2).
    #[inline]
    pub fn frequency(&self, u: usize, v: usize) -> f64 {
        let fx = u as f64 / self.w as f64;
        let vv = if v < self.h.div_ceil(2) {
            v as f64
        } else {
            v as f64 - self.h as f64
        };
        let fy = vv / self.h as f64;
        (fx * fx + fy * fy).sqrt()
    }
}

/// Transposes a row-major `rows × cols` matrix, in parallel over output rows, in tiles of
/// 16 output rows so that each source cache line is used 16 times.
fn transpose(a: &[Complex32], rows: usize, cols: usize) -> Vec<Complex32> {
    const B: usize = 16;
    let tiles: Vec<Vec<Complex32>> = (0..cols.div_ceil(B))
        .into_par_iter()
        .map(|bi| {
            let (c0, c1) = (bi * B, ((bi + 1) * B).min(cols));
            let mut tile = Vec::with_capacity((c1 - c0) * rows);
            for c in c0..c1 {
                tile.extend((0..rows).map(|r| a[r * cols + c]));
            }
            tile
        })
        .collect();
    let mut t = Vec::with_capacity(rows * cols);
    for tile in tiles {
        t.extend_from_slice(&tile);
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_dc() {
        for (w, h) in [(8, 6), (7, 5), (30, 17)] {
            let fft = Fft2d::new(w, h);
            let img: Vec<f32> = (0..w * h)
                .map(|i| ((i * 37 % 11) as f32).sin() + 2.0)
                .collect();
            let spec = fft.forward(&img);
            // DC = sum of the image.
            let sum: f32 = img.iter().sum();
            assert!((spec[0].re - sum).abs() < 1e-3 * sum.abs());
            let mut back = vec![0f32; w * h];
            fft.inverse(spec, &mut back);
            for (a, b) in img.iter().zip(&back) {
                assert!((a - b).abs() < 1e-4, "{w}×{h}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn a_cosine_lands_in_its_bin() {
        let (w, h) = (32, 16);
        let fft = Fft2d::new(w, h);
        // cos(2π (3x/w + 2y/h)): energy at (u, v) = (3, 2) and its mirror.
        let img: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                (2.0 * std::f32::consts::PI * (3.0 * x / w as f32 + 2.0 * y / h as f32)).cos()
            })
            .collect();
        let spec = fft.forward(&img);
        let at = |u: usize, v: usize| spec[u * h + v].norm();
        assert!((at(3, 2) - (w * h) as f32 / 2.0).abs() < 1e-2);
        assert!(at(3, 3) < 1e-2 && at(2, 2) < 1e-2);
        assert!(
            (fft.frequency(3, 2) - ((3.0f64 / 32.0).powi(2) + (2.0f64 / 16.0).powi(2)).sqrt())
                .abs()
                < 1e-12
        );
        assert!((fft.frequency(0, 15) - 1.0 / 16.0).abs() < 1e-12);
    }

    #[test]
    fn good_sizes() {
        assert_eq!(good_size(1), 1);
        assert_eq!(good_size(11), 12);
        assert_eq!(good_size(1081), 1120);
        assert_eq!(good_size(97), 98);
    }
}
