//! Tabulated functions of a positive argument, interpolated linearly in log2 of the argument.
//! The per-pixel models (CSF, masking, TVI) are smooth in log space, so a few dozen entries
//! per octave reproduce them to well under 0.1 % at a fraction of the cost of `powf`/`exp`.

use rayon::prelude::*;

/// f(x) sampled at log2-uniform points over [lo, hi]; outside, the end values are held.
#[derive(Clone, Debug)]
pub(crate) struct LogTable {
    log_lo: f32,
    inv_step: f32,
    values: Vec<f32>,
}

impl LogTable {
    /// Samples `f` at `n` ≥ 2 points between `lo` > 0 and `hi` > `lo`.
    pub fn new(lo: f64, hi: f64, n: usize, f: impl Fn(f64) -> f64 + Sync) -> LogTable {
        let (a, b) = (lo.log2(), hi.log2());
        let step = (b - a) / (n - 1) as f64;
        let values = (0..n)
            .into_par_iter()
            .map(|i| f((a + i as f64 * step).exp2()) as f32)
            .collect();
        LogTable {
            log_lo: a as f32,
            inv_step: (1.0 / step) as f32,
            values,
        }
    }

    /// Interpolated value at `x` (x ≤ 0 gives the first entry).
    #[inline(always)]
    pub fn get(&self, x: f32) -> f32 {
        if x > 0.0 {
            self.get_log2(fast_log2(x))
        } else {
            self.values[0]
        }
    }

    /// Interpolated value at the point whose log2 is `l2` (to share one logarithm between
    /// several tables of the same argument).
    #[inline(always)]
    pub fn get_log2(&self, l2: f32) -> f32 {
        let t = (l2 - self.log_lo) * self.inv_step;
        let last = (self.values.len() - 2) as f32;
        // NaN-safe clamp into [0, n − 2] so that i and i + 1 are in bounds.
        let t = if t > 0.0 { t } else { 0.0 };
        let t = if t < last { t } else { last };
        // SAFETY: t is finite and in [0, n − 2] after the two clamps above (a NaN fails the
        // first comparison and becomes 0), so it fits an i32.
        let i = unsafe { t.to_int_unchecked::<i32>() } as usize;
        let f = t - i as f32;
        let pair = &self.values[i..i + 2];
        pair[0] + f * (pair[1] - pair[0])
    }
}

/// log2 of a positive normal f32 to within 1.4e-3 (exponent bits plus a least-squares cubic in
/// the mantissa; 0.1 % in the argument).
#[inline(always)]
pub(crate) fn fast_log2(x: f32) -> f32 {
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000); // in [1, 2)
    // Least-squares cubic for log2(m) on [1, 2), max error 1.33e-3.
    let p = -2.133_886_6 + m * (3.010_851 + m * (-1.029_558_4 + m * 0.153_924_65));
    e as f32 + p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_log2_is_accurate() {
        let mut x = 1e-6f32;
        while x < 1e6 {
            assert!((fast_log2(x) - x.log2()).abs() < 2e-3, "{x}");
            x *= 1.37;
        }
    }

    #[test]
    fn table_reproduces_a_power_law() {
        let t = LogTable::new(1e-3, 1e3, 6 * 20 * 4, |x| x.powf(0.7));
        let mut x = 1e-3f32;
        while x < 1e3 {
            let exact = x.powf(0.7);
            assert!(
                (t.get(x) - exact).abs() < 2e-3 * exact,
                "{x}: {} vs {exact}",
                t.get(x)
            );
            x *= 1.11;
        }
        assert_eq!(t.get(1e9), t.get(1e3));
    }
}
