//! The threshold map: ΔL_T(x), the smallest luminance change a viewer could notice at each
//! pixel, in the manner of Ramasubramanian, Pattanaik & Greenberg 1999 and Yee, Pattanaik &
//! Greenberg 2001.
//!
//! ΔL_T(x) = ΔL_TVI(L_a(x)) · F(x), with ΔL_TVI Ward's combined TVI
//! ([`crate::tvi::tvi_ward97`]) at the local adaptation luminance L_a, and F ≥ 1 the
//! elevation by spatial frequency, retinal velocity and visual masking.
//!
//! # Procedure (an implementation of aleph's `docs/DESIGN.md` §6)
//! 1. L_a: adaptation luminance ([`crate::adaptation`]), by default the Gaussian mean over 1°.
//! 2. One forward real FFT of the mirror-padded luminance. Octave bands k = 0..K−1 centred on
//!    ρ_k = ppd / 2^(k+1) cpd (f_k = 2^−(k+1) cycles/pixel) are cut by raised-cosine windows
//!    on the log-frequency axis, H_k(f) = cos²(π/2 · log2(f/f_k)) for |log2(f/f_k)| < 1 (and
//!    H_0 = 1 above f_0, up to the 2-D corner frequency), the radial profile of the steerable
//!    pyramid (Simoncelli & Freeman 1995). Adjacent windows sum to one and each has unit gain at
//!    its centre, so a sinusoid at ρ_k lands whole in band k; the residual below the last band
//!    is 1 − Σ H_k. Hence the low-pass below band k is L − Σ_(j≤k) B_j, and one inverse FFT
//!    per band gives both. Bands stop at `lowest_band_cpd` or when fewer than two periods fit.
//! 3. Local band contrast (Peli 1990): c_k = sqrt(2 · box(B_k²)) / max(low-pass_k, 1e-4 cd/m²),
//!    the local RMS over a box of one period (radius 2^k px) scaled so a sinusoid of amplitude
//!    A gives A: a steady contrast rather than zeros at the crossings.
//! 4. Sensitivity per band and pixel: S_k = S_Daly93(ρ_k, L_a) · S_KD(ρ_k, v_R) / S_KD(ρ_k, v_drift)
//!    (Daly 1993 for the luminance dependence, Kelly–Daly for velocity as `docs/DESIGN.md` §5 suggests;
//!    static pixels reduce to Daly 1993). v_R from the velocity map through Daly's eye-movement
//!    model. Frequency elevation E_k = S_max(L_a)/S_k, masking elevation M_k = T_e(c_k S_k).
//! 5. Combination: F = (1 + Σ_k w_k E_k M_k) / (1 + Σ_k w_k) with w_k = c_k S_k, the band
//!    contrast in threshold units, clamped to [1, `max_elevation`]. *Deviation from `docs/DESIGN.md` §6,
//!    which weights by c_k alone:* with c_k weights F is a ratio of vanishing quantities in flat
//!    regions and jumps to the high-frequency elevation for contrasts far below visibility;
//!    weighting by visibility, with one unit for the flat field, makes invisible content leave
//!    F ≈ 1 and visible texture dominate.
//! 6. `max_elevation` defaults to 10, pdiff's cap: each factor (CSF, masking) carries tens of
//!    percent of model error and their product is trusted to about a decade, which keeps the
//!    map conservative where an adaptive sampler would otherwise stop early.
//!
//! # References
//! - Ramasubramanian, Pattanaik & Greenberg 1999, "A Perceptually Based Physical Error Metric
//!   for Realistic Image Synthesis", SIGGRAPH, §4 (threshold map from TVI, CSF and masking).
//! - Yee, Pattanaik & Greenberg 2001, "Spatiotemporal Sensitivity and Visual Attention for
//!   Efficient Rendering of Dynamic Environments", ACM TOG 20(1), §3–4 (spatiotemporal CSF with
//!   eye movement, the Aleph map).
//! - Peli 1990, "Contrast in complex images", JOSA A 7(10): local band-limited contrast.
//! - Daly 1993 (CSF and masking) and Daly 1998 (spatiovelocity CSF, eye movement): see
//!   [`crate::csf`].

use crate::adaptation::{
    AdaptationMode, LOG_DELTA_CD_M2, Padding, gaussian_filter, log_average, window_sigma_px,
};
use crate::csf::{
    DRIFT_VELOCITY_DEG_S, DalyCsfParams, EyeTracking, csf_daly93, csf_kelly_daly, daly93_peak,
    masking_elevation, retinal_velocity_tracked,
};
use crate::error::{PerceptionError, Result, check_image};
use crate::fft::Fft2d;
use crate::table::{LogTable, fast_log2};
use crate::tvi::tvi_ward97;
use crate::viewing::ViewingConditions;
use rayon::prelude::*;
use rustfft::num_complex::Complex32;

/// Per-pixel sums accumulated over bands: w, wE, wM, wEM (content-weighted elevations) and
/// Σ φ² S² / M² (the noise detectability).
const NSUM: usize = 5;

/// Floor of the low-pass luminance in band contrasts, cd/m².
const CONTRAST_FLOOR_CD_M2: f32 = 1e-4;

/// Settings of the threshold map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThresholdParams {
    /// How adaptation luminance is found (default: local arithmetic mean).
    pub adaptation: AdaptationMode,
    /// Adaptation window, degrees (default 1).
    pub adaptation_window_deg: f64,
    /// Upper clamp of the elevation F (default 10).
    pub max_elevation: f32,
    /// Centre frequency of the coarsest band considered, cpd (default 0.5).
    pub lowest_band_cpd: f64,
    /// Whether spatial frequency elevates thresholds (E_k; default true).
    pub frequency: bool,
    /// Whether masking elevates thresholds (M_k; default true).
    pub masking: bool,
}

impl Default for ThresholdParams {
    fn default() -> Self {
        ThresholdParams {
            adaptation: AdaptationMode::LocalArithmetic,
            adaptation_window_deg: 1.0,
            max_elevation: 10.0,
            lowest_band_cpd: 0.5,
            frequency: true,
            masking: true,
        }
    }
}

/// A threshold map and its parts, each a row-major `width × height` image.
#[derive(Clone, Debug, PartialEq)]
pub struct ThresholdMap {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// ΔL_T: smallest visible luminance change, cd/m².
    pub threshold: Vec<f32>,
    /// L_a: adaptation luminance, cd/m².
    pub adaptation: Vec<f32>,
    /// F: total elevation over the TVI (≥ 1, ≤ `max_elevation`).
    pub elevation: Vec<f32>,
    /// The frequency part alone: (1 + Σ w E) / (1 + Σ w), for inspection.
    pub frequency_elevation: Vec<f32>,
    /// The masking part alone: (1 + Σ w M) / (1 + Σ w), for inspection.
    pub masking_elevation: Vec<f32>,
    /// Threshold **RMS contrast of per-pixel white noise** (the error of a Monte Carlo
    /// estimate), dimensionless: C_noise = 1 / sqrt(Σ_k φ_k² S_k² / M_k²), where φ_k² is the
    /// share of white-noise power in band k, S_k the band's sensitivity (Daly 1993 at L_a, with
    /// the velocity factor) and M_k the masking by the content *in that band*; noise of RMS
    /// amplitude C_noise · L_a is at detection threshold (quadratic summation of the bands'
    /// detectabilities). Content in other bands does not mask it, so a coarse edge does not hide
    /// fine grain. Unlike `threshold`, this is not anchored to the TVI: the TVI's test stimulus
    /// (a spot) has none of the spectrum of pixel noise, and scaling it by the noise's CSF
    /// attenuation would mix two thresholds; the CSF gives the noise threshold directly, and its
    /// luminance dependence (Daly's A_l, B_l) supplies the Weber and de Vries–Rose behaviour.
    /// Capped at `max_elevation` / S_max(L_a).
    pub noise_contrast: Vec<f32>,
}

/// Adaptation luminance of one scale: a canvas on a level (with that level's decimation), or
/// one global value.
enum Adaptation {
    Local(Vec<f32>, usize),
    Global(f32),
}

/// What every point evaluation needs besides the band: the padding, the image size and the
/// retinal velocity per image pixel (deg/s), if any.
struct PointContext<'a> {
    pad: Padding,
    width: usize,
    height: usize,
    v_retinal: Option<&'a [f32]>,
}

/// The cells of one level's grid that the image's pixels read, directly (level 1, by
/// [`ThresholdMapper::finish`]'s bilinear lookup) or through the coarse-to-fine upsampling
/// ([`upsample2_add`]): columns `x.0..x.1`, rows `y.0..y.1`. The padded canvas around the
/// image (five times its area at 256 × 170) is there for the filters' wrap-around; evaluating
/// the bands' sums only here gives the image the same values bit for bit.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Window {
    x: (usize, usize),
    y: (usize, usize),
}

impl Window {
    /// Columns and rows.
    fn size(self) -> (usize, usize) {
        (self.x.1 - self.x.0, self.y.1 - self.y.0)
    }

    /// The window on the grid one level coarser (`w × h` cells): this window's cells halved,
    /// one cell more on each side for the bilinear taps, clamped to the grid.
    fn coarser(self, w: usize, h: usize) -> Window {
        let half = |(a, b): (usize, usize), n: usize| {
            ((a / 2).saturating_sub(1), (b.div_ceil(2) + 1).min(n))
        };
        Window {
            x: half(self.x, w),
            y: half(self.y, h),
        }
    }
}

/// The bands' sums on one level's `w × h` grid, kept for the cells of `win` only (row-major
/// within it); [`Cells::bilinear`] reads them at grid coordinates.
struct Cells {
    data: Vec<[f32; NSUM]>,
    win: Window,
    w: usize,
    h: usize,
}

impl Cells {
    /// Zero sums on the cells of `win` of a `w × h` grid.
    fn zeros(win: Window, w: usize, h: usize) -> Cells {
        let (ww, wh) = win.size();
        Cells {
            data: vec![[0f32; NSUM]; ww * wh],
            win,
            w,
            h,
        }
    }

    /// The window's rows in parallel: (grid row y, its cells from column `win.x.0`).
    fn par_rows_mut(
        &mut self,
    ) -> impl IndexedParallelIterator<Item = (usize, &mut [[f32; NSUM]])> + '_ {
        let (ww, y0) = (self.win.size().0, self.win.y.0);
        self.data
            .par_chunks_mut(ww)
            .enumerate()
            .map(move |(dy, row)| (y0 + dy, row))
    }

    /// Bilinear interpolation at grid coordinates (x, y) (cell i centred at i), clamped to the
    /// grid. Every cell it reads lies in the window (the windows are nested so, [`Window`]).
    #[inline(always)]
    fn bilinear(&self, x: f32, y: f32) -> [f32; NSUM] {
        let ((x0, x1), fx) = taps(x, self.w);
        let ((y0, y1), fy) = taps(y, self.h);
        let ww = self.win.size().0;
        let at = |x: usize, y: usize| {
            debug_assert!((self.win.x.0..self.win.x.1).contains(&x));
            debug_assert!((self.win.y.0..self.win.y.1).contains(&y));
            self.data[(y - self.win.y.0) * ww + (x - self.win.x.0)]
        };
        let (a, b, c, d) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
        let mut out = [0f32; NSUM];
        for k in 0..NSUM {
            let top = a[k] + fx * (b[k] - a[k]);
            let bot = c[k] + fx * (d[k] - c[k]);
            out[k] = top + fy * (bot - top);
        }
        out
    }
}

/// The two cells a bilinear lookup at coordinate `x` reads on an axis of `n` cells (clamped to
/// it), and the weight of the second.
#[inline(always)]
fn taps(x: f32, n: usize) -> ((usize, usize), f32) {
    let x = x.clamp(0.0, (n - 1) as f32);
    let x0 = x as usize;
    ((x0, (x0 + 1).min(n - 1)), x - x0 as f32)
}

impl PointContext<'_> {
    /// Retinal velocity of the image pixel under full-canvas coordinates.
    #[inline(always)]
    fn velocity_at(&self, xf: f32, yf: f32) -> Option<f32> {
        self.v_retinal.map(|vr| {
            let x = ((xf - self.pad.x0 as f32).floor().max(0.0) as usize).min(self.width - 1);
            let y = ((yf - self.pad.y0 as f32).floor().max(0.0) as usize).min(self.height - 1);
            vr[y * self.width + x]
        })
    }
}

/// One FFT resolution: the padded canvas decimated by `d`.
#[derive(Debug)]
struct Level {
    d: usize,
    fft: Fft2d,
}

/// Per-band constants and tables.
#[derive(Debug)]
struct Band {
    rho_cpd: f64,
    /// Index into `levels` (decimation 2^(k−1) for k ≥ 1, 1 for k = 0).
    level: usize,
    /// Box radius of the local RMS, in pixels of the band's level.
    blur_radius: usize,
    /// Band-pass filter on the level's spectrum grid.
    filter: Vec<f32>,
    /// Low-pass below the band on the level's grid (bands k ≥ 2; finer bands subtract).
    lowpass: Option<Vec<f32>>,
    /// S_Daly93(ρ_k, L_a) by L_a.
    sensitivity: LogTable,
    /// S_KD(ρ_k, v_R)/S_KD(ρ_k, drift) by v_R.
    velocity_ratio: LogTable,
    /// φ_k²: the fraction of the power of per-pixel white noise that falls in this band.
    noise_share: f32,
}

/// Fraction of the power of white noise on the pixel grid passing the window of band `k`:
/// the mean of H_k(f)² over the square [−½, ½]² of frequencies (cycles/pixel).
///
/// The window is radial, and for k ≥ 1 its support (f ≤ 2 f_k ≤ ½) lies inside the disc the
/// square holds, so in polar coordinates with f = f_k 2^x:
/// φ_k² = 2π ln 2 · f_k² ∫₋₁¹ cos⁴(πx/2) 4^x dx. Band 0 is 1 above f_0 = ½ (the square's
/// area outside that disc, 1 − π/4) plus the same integral over x ∈ [−1, 0].
fn noise_share(k: usize) -> f64 {
    use std::f64::consts::{FRAC_PI_2, LN_2, PI};
    let f_k = 1.0 / 2f64.powi(k as i32 + 1);
    let (hi, outer) = if k == 0 {
        (0.0, 1.0 - PI / 4.0)
    } else {
        (1.0, 0.0)
    };
    // Simpson's rule; the integrand is smooth.
    const N: usize = 2000;
    let g = |x: f64| (FRAC_PI_2 * x).cos().powi(4) * 4f64.powf(x);
    let step = (hi + 1.0) / N as f64;
    let inner: f64 = (0..=N)
        .map(|i| {
            let wgt = if i == 0 || i == N {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            wgt * g(-1.0 + i as f64 * step)
        })
        .sum::<f64>()
        * step
        / 3.0;
    outer + 2.0 * PI * LN_2 * f_k * f_k * inner
}

/// Computes threshold maps for images of one size under one set of viewing conditions, with
/// the FFT plans, spectral filters and model tables made once ([`ThresholdMapper::new`]) and
/// reused by every [`ThresholdMapper::compute`].
///
/// Coarse bands are band-limited, so they are synthesised on decimated grids (band k ≥ 1 on a
/// grid 2^(k−1) times coarser, by inverse FFTs of the cropped spectrum), their contributions
/// combined coarse to fine and interpolated bilinearly to full resolution: the cost is about
/// one forward and three full-size inverse FFTs whatever the number of bands.
#[derive(Debug)]
pub struct ThresholdMapper {
    width: usize,
    height: usize,
    pad: Padding,
    levels: Vec<Level>,
    view: ViewingConditions,
    params: ThresholdParams,
    /// Level and filter of the adaptation Gaussian.
    adapt_level: usize,
    adapt_filter: Vec<f32>,
    bands: Vec<Band>,
    /// S_max(L_a): the Daly 1993 peak sensitivity by adaptation luminance.
    peak: LogTable,
    /// ΔL_TVI(L_a).
    tvi: LogTable,
    /// T_e(c) by contrast in threshold units.
    mask: LogTable,
}

/// Raised-cosine octave window of band `k` (centre f_k cycles/px), on frequency `f` cycles/px.
fn band_window(k: usize, f_k: f64, f: f64) -> f64 {
    if f <= 0.0 {
        return 0.0;
    }
    let x = (f / f_k).log2();
    if k == 0 && x >= 0.0 {
        1.0
    } else if x.abs() < 1.0 {
        (std::f64::consts::FRAC_PI_2 * x).cos().powi(2)
    } else {
        0.0
    }
}

/// Frequencies (cycles per full-resolution pixel) of the spectrum grid of a level, in the
/// transposed layout.
fn level_frequencies(fft: &Fft2d, d: usize) -> Vec<f64> {
    let (wc, h) = (fft.spectrum_rows(), fft.height());
    (0..wc * h)
        .into_par_iter()
        .map(|i| fft.frequency(i / h, i % h) / d as f64)
        .collect()
}

impl ThresholdMapper {
    /// Prepares maps for `width × height` images seen under `view`.
    ///
    /// # Errors
    /// [`PerceptionError`] for a zero size or parameters out of range (window ≤ 0,
    /// `max_elevation` < 1, `lowest_band_cpd` ≤ 0).
    pub fn new(
        width: usize,
        height: usize,
        view: ViewingConditions,
        params: ThresholdParams,
    ) -> Result<ThresholdMapper> {
        if width == 0 || height == 0 {
            return Err(PerceptionError::ZeroSize { width, height });
        }
        let bad = |name, value: f64, range| Err(PerceptionError::Parameter { name, value, range });
        if !(params.adaptation_window_deg.is_finite() && params.adaptation_window_deg > 0.0) {
            return bad("adaptation_window_deg", params.adaptation_window_deg, "> 0");
        }
        if params.max_elevation.is_nan() || params.max_elevation < 1.0 {
            return bad("max_elevation", params.max_elevation as f64, "≥ 1");
        }
        if params.lowest_band_cpd.is_nan() || params.lowest_band_cpd <= 0.0 {
            return bad("lowest_band_cpd", params.lowest_band_cpd, "> 0");
        }
        // Number of bands.
        let min_dim = width.min(height) as f64;
        let mut n_bands = 0usize;
        while view.ppd / 2f64.powi(n_bands as i32 + 1) >= params.lowest_band_cpd
            && 2f64.powi(n_bands as i32 + 1) <= min_dim / 2.0
        {
            n_bands += 1;
        }
        let band_d = |k: usize| if k == 0 { 1 } else { 1usize << (k - 1) };
        let max_d = if n_bands == 0 { 1 } else { band_d(n_bands - 1) };
        let sigma = window_sigma_px(params.adaptation_window_deg, &view);
        // The adaptation Gaussian is negligible (< 1e-6) above f = 0.84/σ cycles/px; its level's
        // Nyquist 1/(2d) must exceed that.
        let mut adapt_d = 1usize;
        while adapt_d * 2 <= max_d.max(1) && 1.0 / (2.0 * (adapt_d * 2) as f64) > 0.84 / sigma {
            adapt_d *= 2;
        }
        // Every band's contribution is evaluated on the half-resolution grid (d = 2).
        let align = max_d.max(adapt_d).max(2);
        let pad = Padding::aligned(width, height, (4.0 * sigma).ceil() as usize, align);
        let mut levels = Vec::new();
        let mut d = 1;
        while d <= align {
            levels.push(Level {
                d,
                fft: Fft2d::new(pad.padded_width / d, pad.padded_height / d),
            });
            d *= 2;
        }
        let level_of = |d: usize| d.trailing_zeros() as usize;

        let adapt_level = level_of(adapt_d);
        let k = -2.0 * std::f64::consts::PI.powi(2) * sigma * sigma;
        let adapt_filter = level_frequencies(&levels[adapt_level].fft, adapt_d)
            .par_iter()
            .map(|f| (k * f * f).exp() as f32)
            .collect();

        let csf = DalyCsfParams {
            image_area_deg2: (width as f64 / view.ppd) * (height as f64 / view.ppd),
            distance_m: view.distance_m,
            eccentricity_deg: 0.0,
            orientation_rad: 0.0,
        };
        let mut bands = Vec::new();
        for kb in 0..n_bands {
            let rho_cpd = view.ppd / 2f64.powi(kb as i32 + 1);
            let f_k = 1.0 / 2f64.powi(kb as i32 + 1);
            let d = band_d(kb);
            let freq = level_frequencies(&levels[level_of(d)].fft, d);
            let filter = freq
                .par_iter()
                .map(|&f| band_window(kb, f_k, f) as f32)
                .collect();
            let lowpass = (kb >= 2).then(|| {
                freq.par_iter()
                    .map(|&f| {
                        let above: f64 = (0..=kb)
                            .map(|j| band_window(j, 1.0 / 2f64.powi(j as i32 + 1), f))
                            .sum();
                        (1.0 - above).max(0.0) as f32
                    })
                    .collect()
            });
            let sensitivity = LogTable::new(1e-5, 1e7, 12 * 24, |l| csf_daly93(rho_cpd, l, &csf));
            let s_drift = csf_kelly_daly(rho_cpd, DRIFT_VELOCITY_DEG_S);
            let velocity_ratio = LogTable::new(DRIFT_VELOCITY_DEG_S, 1e3, 14 * 24, |v| {
                (csf_kelly_daly(rho_cpd, v) / s_drift).max(1e-6)
            });
            // One period: 2^(k+1) full pixels = 2^(k+1)/d level pixels; radius half of that.
            let blur_radius = ((1usize << (kb + 1)) / d / 2).max(1);
            bands.push(Band {
                rho_cpd,
                level: level_of(d),
                blur_radius,
                filter,
                lowpass,
                sensitivity,
                velocity_ratio,
                noise_share: noise_share(kb) as f32,
            });
        }
        let peak = LogTable::new(1e-5, 1e7, 12 * 24, |l| daly93_peak(l, &csf).1);
        let tvi = LogTable::new(1e-6, 1e8, 14 * 32, tvi_ward97);
        let mask = LogTable::new(1e-4, 1e7, 11 * 24, masking_elevation);
        Ok(ThresholdMapper {
            width,
            height,
            pad,
            levels,
            view,
            params,
            adapt_level,
            adapt_filter,
            bands,
            peak,
            tvi,
            mask,
        })
    }

    /// Centre frequencies of the bands used, cpd (finest first).
    pub fn band_frequencies_cpd(&self) -> Vec<f64> {
        self.bands.iter().map(|b| b.rho_cpd).collect()
    }

    /// The viewing conditions.
    pub fn viewing(&self) -> &ViewingConditions {
        &self.view
    }

    /// Inverse FFT on `level` of the full spectrum cropped to that level's frequencies and
    /// multiplied by `filter`; returns the level's canvas (full-resolution values).
    fn synthesize(&self, spec: &[Complex32], level: usize, filter: &[f32]) -> Vec<f32> {
        let full = &self.levels[0].fft;
        let lv = &self.levels[level];
        let (h_full, wc, h) = (full.height(), lv.fft.spectrum_rows(), lv.fft.height());
        let scale = 1.0 / (lv.d * lv.d) as f32;
        let half = h.div_ceil(2);
        let small: Vec<Complex32> = (0..wc * h)
            .into_par_iter()
            .with_min_len(4096)
            .map(|i| {
                let (u, v) = (i / h, i % h);
                let vf = if v < half { v } else { h_full - (h - v) };
                spec[u * h_full + vf] * (filter[i] * scale)
            })
            .collect();
        let mut out = vec![0f32; lv.fft.width() * h];
        lv.fft.inverse(small, &mut out);
        out
    }

    /// Computes the threshold map of `luminance` (cd/m², row-major, `width × height`), with an
    /// optional image-velocity map `velocity` (pixels per frame, interleaved x, y per pixel;
    /// converted to deg/s with the viewing conditions' ppd and fps).
    ///
    /// # Errors
    /// [`PerceptionError`] if a buffer has the wrong length or holds NaN, infinite or (for
    /// luminance) negative values.
    pub fn compute(&self, luminance: &[f32], velocity: Option<&[f32]>) -> Result<ThresholdMap> {
        self.compute_tracked(luminance, velocity, EyeTracking::PerPixel)
    }

    /// As [`ThresholdMapper::compute`], with the eye-tracking assumption `eye` that turns image
    /// velocity into retinal velocity ([`retinal_velocity_tracked`]); a target's velocity is
    /// in deg/s.
    ///
    /// # Errors
    /// As [`ThresholdMapper::compute`].
    pub fn compute_tracked(
        &self,
        luminance: &[f32],
        velocity: Option<&[f32]>,
        eye: EyeTracking,
    ) -> Result<ThresholdMap> {
        let mut maps = self.compute_scaled(luminance, &[1.0], velocity, eye)?;
        Ok(maps.pop().expect("one scale"))
    }

    /// The threshold maps of `luminance` multiplied by each of `scales` (the same image seen
    /// brighter or darker, e.g. graded by whole stops), one per scale in that order, as
    /// [`ThresholdMapper::compute_tracked`] would give for each scaled image, at the cost of
    /// one: band contrasts do not change with a scale, so the spectrum and every band are
    /// synthesised once and only the luminance-dependent sensitivities are evaluated per scale.
    ///
    /// # Errors
    /// As [`ThresholdMapper::compute`], and [`PerceptionError::Parameter`] for a scale that is
    /// not finite and positive.
    pub fn compute_scaled(
        &self,
        luminance: &[f32],
        scales: &[f32],
        velocity: Option<&[f32]>,
        eye: EyeTracking,
    ) -> Result<Vec<ThresholdMap>> {
        let white: Vec<f32> = self.bands.iter().map(|b| b.noise_share).collect();
        self.compute_scaled_for_error(luminance, scales, velocity, eye, &white)
    }

    /// The share of the power of `error` (any units, row-major `width × height`, its mean
    /// removed first) that falls in each band of [`ThresholdMapper::band_frequencies_cpd`], in
    /// that order: Σ B_k² / Σ e² over the padded canvas, with B_k the band of the map's
    /// windows (Parseval: the mean of H_k² weighted by the error's power spectrum). For white
    /// noise these are the shares φ_k² that [`ThresholdMap::noise_contrast`] assumes; an error
    /// whose power sits at lower frequencies (a denoised image's blotches) has larger shares
    /// in coarse bands, where the eye is more sensitive. All zero for an error that is
    /// constant.
    ///
    /// # Errors
    /// [`PerceptionError`] if `error` has the wrong length or holds NaN or infinite values.
    pub fn band_power_shares(&self, error: &[f32]) -> Result<Vec<f32>> {
        check_image("error", error, self.width, self.height, 1, false)?;
        let mean = error.iter().map(|&v| v as f64).sum::<f64>() / error.len() as f64;
        let centred: Vec<f32> = error.iter().map(|&v| (v as f64 - mean) as f32).collect();
        let canvas = self.pad.pad(&centred);
        let total = canvas.iter().map(|&v| (v as f64).powi(2)).sum::<f64>() / canvas.len() as f64;
        if total <= 0.0 {
            return Ok(vec![0.0; self.bands.len()]);
        }
        let spec = self.levels[0].fft.forward(&canvas);
        Ok(self
            .bands
            .iter()
            .map(|band| {
                let b = self.synthesize(&spec, band.level, &band.filter);
                let power = b.iter().map(|&v| (v as f64).powi(2)).sum::<f64>() / b.len() as f64;
                (power / total) as f32
            })
            .collect())
    }

    /// As [`ThresholdMapper::compute_scaled`], with the threshold RMS contrast
    /// ([`ThresholdMap::noise_contrast`]) of an error whose power falls in the bands in the
    /// proportions `shares` ([`ThresholdMapper::band_power_shares`]) instead of white noise's:
    /// C = 1 / √(Σ_k φ_k² S_k² / M_k²) with the given φ_k². The other maps are unchanged.
    ///
    /// # Errors
    /// As [`ThresholdMapper::compute_scaled`]; [`PerceptionError::Parameter`] if `shares` does
    /// not hold one finite value ≥ 0 per band.
    pub fn compute_scaled_for_error(
        &self,
        luminance: &[f32],
        scales: &[f32],
        velocity: Option<&[f32]>,
        eye: EyeTracking,
        shares: &[f32],
    ) -> Result<Vec<ThresholdMap>> {
        if shares.len() != self.bands.len() {
            return Err(PerceptionError::Parameter {
                name: "number of band power shares",
                value: shares.len() as f64,
                range: "one per band of band_frequencies_cpd",
            });
        }
        if let Some(&v) = shares.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            return Err(PerceptionError::Parameter {
                name: "band power share",
                value: v as f64,
                range: "finite and ≥ 0",
            });
        }
        let (w, h) = (self.width, self.height);
        check_image("luminance", luminance, w, h, 1, true)?;
        if let Some(v) = velocity {
            check_image("velocity", v, w, h, 2, false)?;
        }
        if let Some(&k) = scales.iter().find(|k| !(k.is_finite() && **k > 0.0)) {
            return Err(PerceptionError::Parameter {
                name: "luminance scale",
                value: k as f64,
                range: "finite and > 0",
            });
        }
        let pad = &self.pad;
        let canvas = pad.pad(luminance);
        let spec = self.levels[0].fft.forward(&canvas);
        // 1. Adaptation luminance per scale, on its level's canvas (None: global).
        let adapt = self.scaled_adaptation(luminance, &canvas, &spec, scales);
        // Retinal velocity per image pixel (deg/s), if any.
        let v_retinal = velocity.map(|v| self.retinal_velocities(v, eye));
        let ctx = PointContext {
            pad: *pad,
            width: w,
            height: h,
            v_retinal: v_retinal.as_deref(),
        };
        let sums = self.band_sums(&spec, canvas, &adapt, &ctx, scales, shares);
        Ok(adapt
            .iter()
            .zip(sums)
            .map(|(a, acc2)| self.finish(a, &acc2, &ctx))
            .collect())
    }

    /// The adaptation luminance at each scale: a canvas on the adaptation level (local modes)
    /// or one value (global).
    fn scaled_adaptation(
        &self,
        luminance: &[f32],
        canvas: &[f32],
        spec: &[Complex32],
        scales: &[f32],
    ) -> Vec<Adaptation> {
        let local = |(c, d): (Option<Vec<f32>>, usize)| Adaptation::Local(c.expect("local"), d);
        match self.params.adaptation {
            AdaptationMode::Global => scales
                .iter()
                .map(|&k| {
                    let scaled: Vec<f32> = luminance.iter().map(|l| l * k).collect();
                    Adaptation::Global(log_average(&scaled))
                })
                .collect(),
            // The arithmetic mean scales with the image: one canvas serves every scale.
            AdaptationMode::LocalArithmetic => {
                let (c, d) = self.adaptation_canvas(canvas, spec);
                let c = c.expect("local mode");
                scales
                    .iter()
                    .map(|&k| Adaptation::Local(c.iter().map(|v| v * k).collect(), d))
                    .collect()
            }
            // The geometric mean (of δ + L) does not: computed for each scale (from the
            // scaled canvas's logarithms; the spectrum is not used).
            AdaptationMode::LocalGeometric => scales
                .iter()
                .map(|&k| {
                    let c: Vec<f32> = canvas.iter().map(|l| l * k).collect();
                    local(self.adaptation_canvas(&c, spec))
                })
                .collect(),
        }
    }

    /// Each level's [`Window`]: the image's own pixels on the full canvas (level 0), then each
    /// coarser level's from the one before.
    fn windows(&self) -> Vec<Window> {
        let pad = &self.pad;
        let mut windows = vec![Window {
            x: (pad.x0, pad.x0 + self.width),
            y: (pad.y0, pad.y0 + self.height),
        }];
        for lv in &self.levels[1..] {
            let last = *windows.last().expect("level 0");
            windows.push(last.coarser(lv.fft.width(), lv.fft.height()));
        }
        windows
    }

    /// Steps 2–5: the bands' sums (w, wE, wM, wEM, noise) per scale on the half-resolution
    /// grid (d = 2; the local amplitude is pooled over at least a period anyway), bands
    /// synthesised once on their own grids and accumulated coarse to fine.
    fn band_sums(
        &self,
        spec: &[Complex32],
        canvas: Vec<f32>,
        adapt: &[Adaptation],
        ctx: &PointContext,
        scales: &[f32],
        shares: &[f32],
    ) -> Vec<Cells> {
        let lv2 = &self.levels[1];
        let (w2, h2) = (lv2.fft.width(), lv2.fft.height());
        let windows = self.windows();
        let mut acc: Vec<Option<Cells>> = (0..scales.len()).map(|_| None).collect();
        for (band, &share) in self.bands.iter().zip(shares).skip(2).rev() {
            let lv = &self.levels[band.level];
            let (lw, lh) = (lv.fft.width(), lv.fft.height());
            let b = self.synthesize(spec, band.level, &band.filter);
            let lp = self.synthesize(spec, band.level, band.lowpass.as_ref().expect("k ≥ 2"));
            let amp = local_amplitude(&b, lw, lh, band.blur_radius);
            for ((a, &k), slot) in adapt.iter().zip(scales).zip(acc.iter_mut()) {
                let point = (band.level, windows[band.level]);
                let mut sums = self.eval_band(band, share, point, &amp, &lp, a, k, ctx);
                if let Some(coarse) = slot {
                    upsample2_add(coarse, &mut sums);
                }
                *slot = Some(sums);
            }
        }
        // Bands 0 and 1: synthesised at full resolution, their energy and low-pass (by
        // subtraction) averaged over 2×2 blocks onto the d = 2 grid.
        let mut acc2: Vec<Cells> = acc
            .into_iter()
            .map(|a| a.unwrap_or_else(|| Cells::zeros(windows[1], w2, h2)))
            .collect();
        let (pw, ph) = (self.pad.padded_width, self.pad.padded_height);
        let mut lowpass = canvas;
        for (band, &share) in self.bands.iter().zip(shares).take(2) {
            let b = self.synthesize(spec, 0, &band.filter);
            lowpass
                .par_iter_mut()
                .zip(b.par_iter())
                .for_each(|(l, bv)| *l -= bv);
            let amp = decimate2(&local_amplitude(&b, pw, ph, band.blur_radius), pw, ph);
            let lp = decimate2(&lowpass, pw, ph);
            for ((a, &k), total) in adapt.iter().zip(scales).zip(acc2.iter_mut()) {
                let sums = self.eval_band(band, share, (1, windows[1]), &amp, &lp, a, k, ctx);
                total
                    .data
                    .par_iter_mut()
                    .zip(sums.data.par_iter())
                    .for_each(|(t, s)| {
                        for j in 0..NSUM {
                            t[j] += s[j];
                        }
                    });
            }
        }
        acc2
    }

    /// One band's contributions on `level`'s grid, in the cells of `win`, for the image scaled
    /// by `k` (amplitude and low-pass of the unscaled image), with the error's power share
    /// `share` in the band.
    #[allow(clippy::too_many_arguments)]
    fn eval_band(
        &self,
        band: &Band,
        share: f32,
        (level, win): (usize, Window),
        amp: &[f32],
        lp: &[f32],
        adapt: &Adaptation,
        k: f32,
        ctx: &PointContext,
    ) -> Cells {
        let lv = &self.levels[level];
        let (lw, d) = (lv.fft.width(), lv.d as f32);
        // Every cell of the window is written once, in row-major order: no zeroing first.
        let data = (win.y.0..win.y.1)
            .into_par_iter()
            .flat_map_iter(|y| {
                let yf = (y as f32 + 0.5) * d;
                (win.x.0..win.x.1).map(move |x| {
                    let i = y * lw + x;
                    let xf = (x as f32 + 0.5) * d;
                    let la = self.adapt_at(adapt, xf, yf);
                    let l2 = fast_log2(la.max(1e-30));
                    let s_max = self.peak.get_log2(l2);
                    let v = ctx.velocity_at(xf, yf);
                    self.contribution(band, share, amp[i] * k, lp[i] * k, l2, s_max, v)
                })
            })
            .collect();
        Cells {
            data,
            win,
            w: lw,
            h: lv.fft.height(),
        }
    }

    /// Adaptation luminance at full-canvas coordinates.
    #[inline(always)]
    fn adapt_at(&self, a: &Adaptation, xf: f32, yf: f32) -> f32 {
        match a {
            Adaptation::Global(g) => *g,
            Adaptation::Local(c, d) => self.sample_level(c, *d, xf, yf),
        }
    }

    /// Per image pixel: adaptation, the bands' sums interpolated from the d = 2 grid, and the
    /// map made from them.
    fn finish(&self, adapt: &Adaptation, acc2: &Cells, ctx: &PointContext) -> ThresholdMap {
        let (w, h) = (ctx.width, ctx.height);
        let pad = &ctx.pad;
        let n = w * h;
        let mut adaptation = vec![0f32; n];
        let mut sum = vec![[0f32; NSUM]; n];
        adaptation
            .par_chunks_mut(w)
            .zip(sum.par_chunks_mut(w))
            .enumerate()
            .for_each(|(y, (ra, rs))| {
                let yf = (pad.y0 + y) as f32 + 0.5;
                for x in 0..w {
                    let xf = (pad.x0 + x) as f32 + 0.5;
                    ra[x] = self.adapt_at(adapt, xf, yf);
                    rs[x] = acc2.bilinear(xf / 2.0 - 0.5, yf / 2.0 - 0.5);
                }
            });

        let fmax = self.params.max_elevation;
        let ratio = |k: usize| -> Vec<f32> {
            sum.par_iter()
                .map(|s| ((1.0 + s[k]) / (1.0 + s[0])).clamp(1.0, fmax))
                .collect()
        };
        let elevation = ratio(3);
        let frequency_elevation = ratio(1);
        let masking_elevation = ratio(2);
        let noise_contrast: Vec<f32> = sum
            .par_iter()
            .zip(adaptation.par_iter())
            .map(|(sm, &la)| {
                let cap = fmax / self.peak.get(la).max(1e-6);
                (1.0 / (sm[4] + 1e-12).sqrt()).min(cap)
            })
            .collect();
        let threshold = adaptation
            .par_iter()
            .zip(elevation.par_iter())
            .map(|(&la, &f)| self.tvi.get(la) * f)
            .collect();
        ThresholdMap {
            width: w,
            height: h,
            threshold,
            adaptation,
            elevation,
            frequency_elevation,
            masking_elevation,
            noise_contrast,
        }
    }

    /// The adaptation luminance on its level's canvas (with that level's decimation), or `None`
    /// (and 1) for global adaptation. `canvas` is the padded luminance, `spec` its spectrum.
    fn adaptation_canvas(&self, canvas: &[f32], spec: &[Complex32]) -> (Option<Vec<f32>>, usize) {
        match self.params.adaptation {
            AdaptationMode::Global => (None, 1),
            AdaptationMode::LocalArithmetic => {
                let mut c = self.synthesize(spec, self.adapt_level, &self.adapt_filter);
                c.iter_mut().for_each(|v| *v = v.max(0.0));
                (Some(c), self.levels[self.adapt_level].d)
            }
            AdaptationMode::LocalGeometric => {
                let logs: Vec<f32> = canvas.iter().map(|&l| (LOG_DELTA_CD_M2 + l).ln()).collect();
                let mut s = self.levels[0].fft.forward(&logs);
                let sigma = window_sigma_px(self.params.adaptation_window_deg, &self.view);
                gaussian_filter(&self.levels[0].fft, &mut s, sigma);
                let mut c = vec![0f32; canvas.len()];
                self.levels[0].fft.inverse(s, &mut c);
                c.iter_mut().for_each(|v| *v = v.exp());
                (Some(c), 1)
            }
        }
    }

    /// Retinal velocity (deg/s) per pixel of an image-velocity map (pixels per frame,
    /// interleaved x, y) under the eye-tracking assumption `eye`.
    fn retinal_velocities(&self, velocity: &[f32], eye: EyeTracking) -> Vec<f32> {
        // px/frame → deg/s per component (velocity_deg_s takes a magnitude).
        let k = self.view.velocity_deg_s(1.0);
        velocity
            .par_chunks(2)
            .map(|d| retinal_velocity_tracked([d[0] as f64 * k, d[1] as f64 * k], eye) as f32)
            .collect()
    }

    /// The weighted terms (w, w E, w M, w E M, φ² S² / M²) of one band at one point, given the
    /// error's power share φ² in the band, the band amplitude and low-pass (cd/m²), log2 of the
    /// adaptation luminance, the peak sensitivity S_max there, and the retinal velocity.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn contribution(
        &self,
        band: &Band,
        share: f32,
        amp: f32,
        lowpass: f32,
        la_log2: f32,
        s_max: f32,
        v_r: Option<f32>,
    ) -> [f32; NSUM] {
        let c = amp / lowpass.max(CONTRAST_FLOOR_CD_M2);
        let mut s = band.sensitivity.get_log2(la_log2);
        if let Some(v) = v_r {
            s *= band.velocity_ratio.get(v);
        }
        let s = s.max(1e-6);
        let e = if self.params.frequency {
            s_max / s
        } else {
            1.0
        };
        let wgt = c * s;
        // T_e(0.05) − 1 = 3e-5: below that masking is nil and the table is skipped.
        let m = if self.params.masking && wgt > 0.05 {
            self.mask.get(wgt)
        } else {
            1.0
        };
        let sm = s / m;
        [wgt, wgt * e, wgt * m, wgt * e * m, share * sm * sm]
    }

    /// Bilinear sample of a level canvas (decimation `d`) at full-canvas coordinates (pixel
    /// centres at half-integers).
    #[inline(always)]
    fn sample_level(&self, c: &[f32], d: usize, xf: f32, yf: f32) -> f32 {
        let lv = &self.levels[d.trailing_zeros() as usize];
        bilinear(
            c,
            lv.fft.width(),
            lv.fft.height(),
            xf / d as f32 - 0.5,
            yf / d as f32 - 0.5,
        )
    }
}

/// Bilinear interpolation of a `w × h` image at continuous pixel coordinates (x, y) (pixel i
/// centred at i), clamped at the borders.
#[inline(always)]
fn bilinear(img: &[f32], w: usize, h: usize, x: f32, y: f32) -> f32 {
    let ((x0, x1), fx) = taps(x, w);
    let ((y0, y1), fy) = taps(y, h);
    let a = img[y0 * w + x0] * (1.0 - fx) + img[y0 * w + x1] * fx;
    let b = img[y1 * w + x0] * (1.0 - fx) + img[y1 * w + x1] * fx;
    a * (1.0 - fy) + b * fy
}

/// Adds the 2× bilinear upsampling of `src` (the grid one level coarser) to `dst`.
fn upsample2_add(src: &Cells, dst: &mut Cells) {
    let x0 = dst.win.x.0;
    dst.par_rows_mut().for_each(|(y, row)| {
        let sy = y as f32 / 2.0 - 0.25;
        for (o, x) in row.iter_mut().zip(x0..) {
            let v = src.bilinear(x as f32 / 2.0 - 0.25, sy);
            for k in 0..NSUM {
                o[k] += v[k];
            }
        }
    });
}

/// Averages 2×2 blocks of a `w × h` image (w, h even) into a `w/2 × h/2` one.
fn decimate2(img: &[f32], w: usize, h: usize) -> Vec<f32> {
    let (w2, h2) = (w / 2, h / 2);
    let mut out = vec![0f32; w2 * h2];
    out.par_chunks_mut(w2).enumerate().for_each(|(y, row)| {
        let (r0, r1) = (
            &img[2 * y * w..(2 * y + 1) * w],
            &img[(2 * y + 1) * w..(2 * y + 2) * w],
        );
        for (x, o) in row.iter_mut().enumerate() {
            *o = 0.25 * (r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1]);
        }
    });
    let _ = h2;
    out
}

/// sqrt(2 · box(B²)) with a box of radius `r`: the local amplitude of a band image.
fn local_amplitude(b: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let sq: Vec<f32> = b.par_iter().map(|v| v * v).collect();
    let mut e = box_blur(&sq, w, h, r);
    e.par_iter_mut()
        .for_each(|v| *v = (2.0 * v.max(0.0)).sqrt());
    e
}

/// Box blur of radius `r` (window 2r + 1) with clamped edges: a horizontal running sum per row,
/// then a vertical running sum over rows, both O(pixels), parallel.
fn box_blur(img: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let norm = 1.0 / (2 * r + 1) as f32;
    let ri = r as i64;
    let mut tmp = vec![0f32; w * h];
    tmp.par_chunks_mut(w)
        .zip(img.par_chunks(w))
        .for_each(|(d, s)| {
            let at = |i: i64| s[i.clamp(0, w as i64 - 1) as usize];
            let mut acc: f32 = (-ri..=ri).map(at).sum();
            for (i, o) in d.iter_mut().enumerate() {
                *o = acc * norm;
                let i = i as i64;
                acc += at(i + ri + 1) - at(i - ri);
            }
        });
    // Vertical pass over strips of columns.
    const STRIP: usize = 64;
    let mut out = vec![0f32; w * h];
    let strips: Vec<usize> = (0..w).step_by(STRIP).collect();
    let cols: Vec<Vec<f32>> = strips
        .par_iter()
        .map(|&x0| {
            let x1 = (x0 + STRIP).min(w);
            let sw = x1 - x0;
            let row = |y: i64| &tmp[y.clamp(0, h as i64 - 1) as usize * w + x0..][..sw];
            let mut acc = vec![0f32; sw];
            for y in -ri..=ri {
                for (a, v) in acc.iter_mut().zip(row(y)) {
                    *a += v;
                }
            }
            let mut strip = vec![0f32; sw * h];
            for y in 0..h as i64 {
                let o = &mut strip[y as usize * sw..(y as usize + 1) * sw];
                for (oo, a) in o.iter_mut().zip(&acc) {
                    *oo = a * norm;
                }
                let (add, sub) = (row(y + ri + 1), row(y - ri));
                for ((a, p), m) in acc.iter_mut().zip(add).zip(sub) {
                    *a += p - m;
                }
            }
            strip
        })
        .collect();
    for (&x0, strip) in strips.iter().zip(&cols) {
        let sw = strip.len() / h;
        for y in 0..h {
            out[y * w + x0..y * w + x0 + sw].copy_from_slice(&strip[y * sw..(y + 1) * sw]);
        }
    }
    out
}

/// Convenience: one threshold map with default parameters (plans made for this call only; use
/// a [`ThresholdMapper`] to compute many maps of one size).
///
/// # Errors
/// As [`ThresholdMapper::new`] and [`ThresholdMapper::compute`].
pub fn threshold_map(
    luminance: &[f32],
    width: usize,
    height: usize,
    view: &ViewingConditions,
    velocity: Option<&[f32]>,
) -> Result<ThresholdMap> {
    ThresholdMapper::new(width, height, *view, ThresholdParams::default())?
        .compute(luminance, velocity)
}

#[cfg(test)]
mod tests;
