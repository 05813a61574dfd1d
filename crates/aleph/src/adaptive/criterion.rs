//! The per-pixel criterion of a pass: each pixel's error estimate and its threshold.
//!
//! The perceptual criterion's threshold is ΔL(x) = L_a(x) · C_noise(x) (see the module docs of
//! [`super`]); C_noise comes once from the noise-free guide ([`PerceptualCriterion::guide`]),
//! with the velocity map when the frame moves, and L_a every pass from the current image. The
//! variance criterion is Cycles'.

use super::{AdaptiveError, AdaptiveSettings, ErrorEstimate, Visibility};
use crate::denoise::Aux;
use crate::display::FrozenToneMap;
use crate::film::Film;
use crate::render::{RenderStats, render_albedo};
use crate::scene::Scene;
use perception::adaptation::{adaptation_luminance, log_average};
use perception::csf::EyeTracking;
use perception::photometry::luminance_image;
use perception::threshold::ThresholdMapper;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// The threshold where no change of the pixel is visible at any grade (the tone curve clips
/// it), in the criterion's units.
pub(crate) const NO_THRESHOLD: f32 = 1e30;

/// The threshold map is recomputed (tone curve, adaptation, slopes) once the film's mean spp
/// has grown by this factor since it was last computed; in between only the error is. The
/// maps rest on 5×5-pooled and 1°-smoothed means, which change little between passes.
const REFRESH_SPP_FACTOR: f64 = 4.0;

/// Seed offset of the guide's samples (independent of the image's).
const GUIDE_SEED_XOR: u64 = 0x6A09_E667_F3BC_C908;

/// Per-pixel error and threshold of the current film, in the criterion's units.
pub(crate) struct Judgement {
    pub error: Vec<f32>,
    pub threshold: Vec<f32>,
}

impl Judgement {
    /// error / threshold per pixel.
    pub fn ratio(&self) -> Vec<f32> {
        self.error
            .par_iter()
            .zip(self.threshold.par_iter())
            .map(|(e, t)| e / t.max(1e-30))
            .collect()
    }
}

/// One grade of the image in which visibility is judged: the displayed curve (or the scene
/// scale) with the input multiplied by 2^ev.
struct Grade {
    frozen: Option<FrozenToneMap>,
    scale: f32,
}

impl Grade {
    fn new(frozen: Option<&FrozenToneMap>, scale: f32, ev: f64) -> Grade {
        Grade {
            frozen: frozen.map(|f| f.graded(ev)),
            scale: scale * 2f64.powf(ev) as f32,
        }
    }

    /// Luminance in visibility units: display cd/m² under the graded curve, or scene cd/m².
    fn luminance(&self, rgb: &[f32]) -> perception::Result<Vec<f32>> {
        match &self.frozen {
            Some(f) => f.display_luminance(rgb),
            None => Ok(luminance_image(rgb, self.scale)),
        }
    }
}

/// What the perceptual criterion takes from the guide, once per frame.
struct GuideState {
    /// Threshold RMS contrast of pixel noise (per pixel, dimensionless), one map per grade of
    /// [`AdaptiveSettings::grades_ev`].
    noise_contrast: Vec<Vec<f32>>,
    /// The guide's luminance, its scale at each grade and the eye's tracking: what the noise
    /// contrast is recomputed from when the error's spectrum changes (a denoised image's).
    luminance: Vec<f32>,
    scales: Vec<f32>,
    eye: EyeTracking,
    /// Saliency in [0, 1] of the first pass's display image, when ω > 0.
    saliency: Option<Vec<f32>>,
}

/// The perceptual criterion: half-buffer error against L_a · C_noise.
pub(crate) struct PerceptualCriterion {
    mapper: ThresholdMapper,
    /// Image velocity at the frame's instant, pixels per frame, interleaved (x, y).
    velocity: Option<Vec<f32>>,
    state: Option<GuideState>,
    /// The last threshold map and the mean spp of the film it was computed from.
    threshold: Option<(f64, Vec<f32>)>,
    /// Counters of the guide render, once it ran.
    pub guide_stats: Option<RenderStats>,
    /// The error's power share per band of the threshold map, when it is not white noise (the
    /// denoised image's error, [`denoised_error`]); `None`: white pixel noise.
    shares: Option<Vec<f32>>,
}

/// Interleaved RGB box-filtered over (2r + 1)² pixels, channel by channel.
fn pool_rgb(rgb: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    crate::imaging::box_mean_interleaved(rgb, w, h, 3, r)
}

/// The current image's 5×5-pooled mean, as the grades' slopes read it: the slope is taken at
/// the pooled mean because at the pixel's own mean it would carry the pixel's noise into the
/// threshold (and make it flicker from frame to frame). Computed once per threshold map, shared
/// by the grades.
struct PooledMean {
    /// Pooled interleaved RGB × 1.05 and × 0.95: the ends of the slope's ±5 % interval.
    up: Vec<f32>,
    down: Vec<f32>,
    /// Pooled scene luminance, cd/m².
    y: Vec<f32>,
}

impl PooledMean {
    fn new(mean: &[f32], w: usize, h: usize, scale: f32) -> PooledMean {
        let pooled = pool_rgb(mean, w, h, 2);
        PooledMean {
            up: pooled.par_iter().map(|v| v * 1.05).collect(),
            down: pooled.par_iter().map(|v| v * 0.95).collect(),
            y: pooled
                .par_chunks_exact(3)
                .map(|p| perception::photometry::luminance(p[0], p[1], p[2]) * scale)
                .collect(),
        }
    }
}

impl PerceptualCriterion {
    pub fn new(
        scene: &Scene,
        s: &AdaptiveSettings,
        velocity: Option<Vec<f32>>,
    ) -> perception::Result<Self> {
        let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
        let mut view = s.tone.view;
        if let Some(a) = scene.animation {
            view = view.with_fps(a.fps)?;
        }
        Ok(PerceptualCriterion {
            mapper: ThresholdMapper::new(w, h, view, s.perceptual.threshold)?,
            velocity,
            state: None,
            threshold: None,
            guide_stats: None,
            shares: None,
        })
    }

    /// Renders the albedo guide and computes the noise threshold contrast from it at every
    /// grade (and the saliency of the current display image `mean`, when ω > 0). `lfs` is the
    /// current image in visibility units at each grade: the guide's contrast structure is scaled
    /// to its mean level there.
    fn guide(
        &mut self,
        scene: &Scene,
        s: &AdaptiveSettings,
        mean: &[f32],
        lfs: &[Vec<f32>],
        frozen: Option<&FrozenToneMap>,
    ) -> perception::Result<Duration> {
        let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
        let n_px = w * h;
        let t_guide = Instant::now();
        let spp = s.perceptual.guide_spp.max(1);
        // Common random numbers across the frames of a sequence (the render seed, not the
        // frame's): the guide's own noise then cannot make the masking, and so the threshold,
        // flicker from frame to frame.
        let albedo = render_albedo(scene, spp, scene.settings.seed ^ GUIDE_SEED_XOR);
        let guide_time = t_guide.elapsed();
        self.guide_stats = Some(RenderStats {
            samples: spp as u64 * n_px as u64,
            rays: spp as u64 * n_px as u64,
            nonfinite: 0,
            wall: guide_time,
        });
        let a_lum = luminance_image(&albedo, 1.0);
        let mean_a = a_lum.iter().map(|&v| v as f64).sum::<f64>() / n_px as f64;
        let saliency = if s.perceptual.saliency_weight > 0.0 {
            let display = match frozen {
                Some(f) => f.map(mean)?,
                None => mean.to_vec(),
            };
            Some(perception::saliency::saliency_map(&display, w, h)?)
        } else {
            None
        };
        let eye = match (&saliency, &self.velocity) {
            (Some(sal), Some(v)) => self.tracked_target(sal, v),
            _ => EyeTracking::PerPixel,
        };
        // The guide scaled to each grade's mean level: one threshold computation serves all
        // grades (band contrasts do not change with a scale).
        let scales: Vec<f32> = lfs
            .iter()
            .map(|lf| {
                let mean_f = lf.iter().map(|&v| v as f64).sum::<f64>() / n_px as f64;
                if mean_a > 0.0 && mean_f > 0.0 {
                    (mean_f / mean_a) as f32
                } else {
                    1.0
                }
            })
            .collect();
        let mut state = GuideState {
            noise_contrast: Vec::new(),
            saliency,
            luminance: a_lum,
            scales,
            eye,
        };
        state.noise_contrast = self.noise_contrast(&state)?;
        self.state = Some(state);
        Ok(guide_time)
    }

    /// The threshold RMS contrast of the error at every grade, from the guide: of white pixel
    /// noise, or of an error with the band shares `self.shares`.
    fn noise_contrast(&self, g: &GuideState) -> perception::Result<Vec<Vec<f32>>> {
        let v = self.velocity.as_deref();
        let maps = match &self.shares {
            None => self
                .mapper
                .compute_scaled(&g.luminance, &g.scales, v, g.eye)?,
            Some(sh) => {
                self.mapper
                    .compute_scaled_for_error(&g.luminance, &g.scales, v, g.eye, sh)?
            }
        };
        Ok(maps.into_iter().map(|m| m.noise_contrast).collect())
    }

    /// Takes the spectrum of the denoised image's error `difference` (signed, per pixel): its
    /// band shares replace white noise's in the noise threshold, which is recomputed (with
    /// the whole threshold map) at this judgement.
    fn error_spectrum(&mut self, difference: &[f32]) -> perception::Result<()> {
        let shares = self.mapper.band_power_shares(difference)?;
        // Between refreshes of the threshold map the spectrum is kept unless it moved: the
        // denoised error's shares change by a few per cent from pass to pass.
        if let Some(old) = &self.shares
            && self.threshold.is_some()
            && shares_close(old, &shares)
        {
            return Ok(());
        }
        self.shares = Some(shares);
        self.threshold = None;
        if let Some(mut g) = self.state.take() {
            g.noise_contrast = self.noise_contrast(&g)?;
            self.state = Some(g);
        }
        Ok(())
    }

    /// The eye is assumed to pursue the salient object (Yee et al. 2001): the image velocity
    /// (deg/s) of the pixels whose saliency is at least half the maximum, weighted by saliency.
    fn tracked_target(&self, saliency: &[f32], motion: &[f32]) -> EyeTracking {
        let max = saliency.iter().cloned().fold(0.0f32, f32::max);
        let (mut sx, mut sy, mut sw) = (0.0f64, 0.0f64, 0.0f64);
        for (&s, d) in saliency.iter().zip(motion.chunks_exact(2)) {
            if max > 0.0 && s >= 0.5 * max {
                sx += s as f64 * d[0] as f64;
                sy += s as f64 * d[1] as f64;
                sw += s as f64;
            }
        }
        if sw <= 0.0 {
            return EyeTracking::PerPixel;
        }
        let k = self.mapper.viewing().velocity_deg_s(1.0);
        EyeTracking::Target([sx / sw * k, sy / sw * k])
    }

    /// Error estimate per pixel in scene luminance (cd/m², Y × `scale`); for a denoised image,
    /// its estimated error `denoised` ([`denoised_error`]).
    fn error(film: &Film, s: &AdaptiveSettings, scale: f32, denoised: Option<&[f32]>) -> Vec<f32> {
        if let Some(d) = denoised {
            return d.to_vec();
        }
        match s.perceptual.error_estimate {
            ErrorEstimate::HalfBuffers => {
                let la = luminance_image(&film.mean_rgb_even(), scale);
                let lb = luminance_image(&film.mean_rgb_odd(), scale);
                la.par_iter()
                    .zip(lb.par_iter())
                    .enumerate()
                    .map(|(i, (a, b))| film.difference_scale(i) as f32 * (a - b).abs())
                    .collect()
            }
            ErrorEstimate::StandardError => (0..film.len())
                .into_par_iter()
                .map(|i| {
                    if film.effective_count(i) >= 2.0 {
                        film.lum_std_error(i) as f32 * scale
                    } else {
                        0.0
                    }
                })
                .collect(),
        }
    }

    /// The threshold at one grade referred to scene luminance: L_a · C_noise (a display
    /// luminance change at threshold) over the display's response to scene luminance at the
    /// pixel, dL_d/dY, the slope of the frozen curve across ±5 % of the pixel's mean. Where the
    /// curve clips (slope 0) no change is visible: the threshold is [`NO_THRESHOLD`].
    fn threshold_at_grade(
        s: &AdaptiveSettings,
        lf: &[f32],
        grade: &Grade,
        noise_contrast: &[f32],
        pooled: &PooledMean,
        (w, h): (usize, usize),
    ) -> perception::Result<Vec<f32>> {
        let adapt = adaptation_luminance(
            lf,
            w,
            h,
            &s.tone.view,
            s.perceptual.threshold.adaptation,
            s.perceptual.threshold.adaptation_window_deg,
        )?;
        let up = grade.luminance(&pooled.up)?;
        let down = grade.luminance(&pooled.down)?;
        let y = &pooled.y;
        Ok(adapt
            .par_iter()
            .zip(noise_contrast.par_iter())
            .zip(up.par_iter().zip(down.par_iter()))
            .zip(y.par_iter())
            .map(|(((&a, &c), (&u, &d)), &y)| {
                let slope = (u - d) / (0.1 * y);
                if slope > 0.0 && slope.is_finite() {
                    (a * c / slope).min(NO_THRESHOLD)
                } else {
                    NO_THRESHOLD
                }
            })
            .collect())
    }

    /// Judges the film. Returns the judgement and the time spent rendering the guide (a
    /// rendering cost, not a decision cost).
    pub fn judge(
        &mut self,
        scene: &Scene,
        film: &Film,
        s: &AdaptiveSettings,
        aux: Option<&Aux>,
    ) -> Result<(Judgement, Duration), AdaptiveError> {
        let (w, h) = (film.width as usize, film.height as usize);
        let scale = scene.settings.luminance_scale;
        let spp = film.total_samples() as f64 / film.len() as f64;
        let denoised = aux
            .map(|aux| denoised_error(film, aux, scale))
            .transpose()?;
        if let Some((_, difference)) = &denoised {
            self.error_spectrum(&error_contrast(difference, film, scale))?;
        }
        let denoised = denoised.as_ref().map(|(magnitude, _)| magnitude.as_slice());
        if let Some((at, t)) = &self.threshold
            && spp < REFRESH_SPP_FACTOR * at
        {
            let threshold = t.clone();
            let error = Self::pooled_error(film, s, scale, &threshold, denoised);
            return Ok((Judgement { error, threshold }, Duration::ZERO));
        }
        let mean = film.mean_rgb();
        let frozen = match s.perceptual.visibility {
            // A row tile sees the rest of the image at first-pass noise, whose log average is
            // biased low (Jensen's inequality): fitted to it, the curve came out brighter than
            // the single machine's, clipped the bright wall and stopped early. The tile fits
            // its curve each pass, as one machine does, to its own rows as they are and the
            // rest pooled over 5 × 5 pixels, which removes most of the noise's bias.
            Visibility::Display if s.rows.is_some() => {
                let (a, b) = s.rows.unwrap_or((0, h as u32));
                let pooled = pool_rgb(&mean, w, h, 2);
                let own = a as usize * w * 3..b as usize * w * 3;
                let mix: Vec<f32> = (0..mean.len())
                    .map(|i| if own.contains(&i) { mean[i] } else { pooled[i] })
                    .collect();
                Some(FrozenToneMap::new(&mix, w, h, &s.tone)?)
            }
            Visibility::Display => Some(FrozenToneMap::new(&mean, w, h, &s.tone)?),
            Visibility::Scene => None,
        };
        let grades: Vec<Grade> = s
            .grades_ev()
            .iter()
            .map(|&ev| Grade::new(frozen.as_ref(), scale, ev))
            .collect();
        let lfs = grades
            .iter()
            .map(|g| g.luminance(&mean))
            .collect::<perception::Result<Vec<_>>>()?;
        let guide_time = if self.state.is_none() {
            self.guide(scene, s, &mean, &lfs, frozen.as_ref())?
        } else {
            Duration::ZERO
        };
        let st = self.state.as_ref().expect("set above");
        // The smallest threshold over the grades, each referred to scene luminance through
        // its curve's slope: noise must be invisible however the image is graded within the
        // latitude. A minimum of noise-free maps, so it cannot flicker with the noise.
        let mut threshold = vec![NO_THRESHOLD; w * h];
        let pooled = PooledMean::new(&mean, w, h, scale);
        for ((grade, lf), contrast) in grades.iter().zip(&lfs).zip(&st.noise_contrast) {
            let t = Self::threshold_at_grade(s, lf, grade, contrast, &pooled, (w, h))?;
            threshold
                .par_iter_mut()
                .zip(t.par_iter())
                .for_each(|(a, &b)| *a = a.min(b));
        }
        if let Some(sal) = &st.saliency {
            threshold =
                perception::saliency::aleph_map(&threshold, sal, s.perceptual.saliency_weight)?;
        }
        self.threshold = Some((spp, threshold.clone()));
        let error = Self::pooled_error(film, s, scale, &threshold, denoised);
        Ok((Judgement { error, threshold }, guide_time))
    }

    /// The error, pooled as a ratio over 3×3 pixels so a single lucky pixel is not called
    /// converged (pooling the error itself would carry a light's noise into its dark
    /// neighbours), times the pixel's threshold. Without an average budget the pooled ratio is
    /// at least [`NEIGHBOURHOOD_SHARE`] times the one the 7×7 neighbourhood predicts at the
    /// pixel's spp ([`neighbourhood_ratio`]), so a patch of lucky pixels is not called
    /// converged either.
    fn pooled_error(
        film: &Film,
        s: &AdaptiveSettings,
        scale: f32,
        threshold: &[f32],
        denoised: Option<&[f32]>,
    ) -> Vec<f32> {
        let (w, h) = (film.width as usize, film.height as usize);
        let e = Self::error(film, s, scale, denoised);
        let r: Vec<f32> = e
            .par_iter()
            .zip(threshold.par_iter())
            .map(|(&e, &t)| e / t)
            .collect();
        let local = crate::imaging::box_mean(&r, w, h, 1);
        // Without an average budget no floor protects a pixel whose half-buffers agree by
        // luck (heavy-tailed noise, such as caustics, does that in whole patches): its
        // neighbourhood's noise level guards it.
        let local = if s.budget_spp.is_none() {
            let counts: Vec<u32> = film.pixels.iter().map(|p| p.count()).collect();
            let wide = neighbourhood_ratio(&r, &counts, w, h);
            local
                .par_iter()
                .zip(wide.par_iter())
                .map(|(&l, &g)| l.max(NEIGHBOURHOOD_SHARE * g))
                .collect()
        } else {
            local
        };
        local
            .par_iter()
            .zip(threshold.par_iter())
            .map(|(r, t)| r * t)
            .collect()
    }
}

/// Whether two band-share vectors differ by less than [`SHARES_TOLERANCE`] in every band
/// holding a tenth of the power or more (relative), so the noise threshold need not be
/// recomputed.
fn shares_close(a: &[f32], b: &[f32]) -> bool {
    a.iter().zip(b).all(|(&x, &y)| {
        let m = x.max(y);
        m < 0.1 || (x - y).abs() <= SHARES_TOLERANCE * m
    })
}

/// Relative change of a band's share of the error power that recomputes the noise threshold
/// before the threshold map's own refresh: C scales as 1/√(Σ φ² S²), so a change of 25 % in
/// one band moves it by at most 12 %.
const SHARES_TOLERANCE: f32 = 0.25;

/// The denoised image's signed error `d` (cd/m²) as a contrast, over the film's luminance
/// pooled over 5 × 5 pixels (at least [`CONTRAST_FLOOR_SHARE`] of the image's mean, so black
/// pixels whose halves differ by a trace are not full contrast), limited to ±1: the spectrum
/// that matters to the eye is the contrast's, and without the limit the few pixels on an
/// emitter's edge (whose half-buffers differ by thousands of cd/m², and whose display clips)
/// would be the whole spectrum.
const CONTRAST_FLOOR_SHARE: f32 = 0.01;

fn error_contrast(d: &[f32], film: &Film, scale: f32) -> Vec<f32> {
    let (w, h) = (film.width as usize, film.height as usize);
    let y = luminance_image(&film.mean_rgb(), scale);
    let pooled = crate::imaging::box_mean(&y, w, h, 2);
    let floor =
        CONTRAST_FLOOR_SHARE * y.iter().map(|&v| v as f64).sum::<f64>() as f32 / y.len() as f32;
    d.par_iter()
        .zip(pooled.par_iter())
        .map(|(&e, &l)| (e / l.max(floor).max(1e-30)).clamp(-1.0, 1.0))
        .collect()
}

/// The estimated error of the denoised image in scene luminance (cd/m², Y × `scale`): the
/// half-buffers denoised apart ([`crate::denoise::denoised_difference`]), as magnitude
/// and signed (whose spectrum sets the threshold). Not its bias term: with it the Cornell box
/// (256²) stopped at 191.6 spp instead of 15.5 (JOD 9.92 against 9.83, FLIP mean 0.051
/// against 0.071), 0.96× uniform's speed at equal JOD instead of 2.2×: the filter's bias at
/// the emitter's edges falls slowly with samples, and the loop chased it to the cap.
fn denoised_error(
    film: &Film,
    aux: &Aux,
    scale: f32,
) -> Result<(Vec<f32>, Vec<f32>), AdaptiveError> {
    let d = crate::denoise::denoised_difference(film, aux)?;
    let d: Vec<f32> = d.into_par_iter().map(|x| x * scale).collect();
    Ok((d.par_iter().map(|x| x.abs()).collect(), d))
}

/// Relative noise below which no viewer sees a pixel's noise under any grade: a quarter of the
/// eye's lowest contrast threshold, 1/S_peak ≈ 0.42 % (Daly 1993's CSF peaks at S ≈ 237, at
/// 3.2 cpd and 100 cd/m², `docs/DESIGN.md` §5; it is less sensitive at every other frequency
/// and luminance, and a noise's contrast in any band is at most its RMS contrast). Contrast is
/// taken against the pixel's own channel mean, so the quarter leaves room for a pixel up to 4×
/// brighter than the luminance the eye adapts to around it; no grade within the latitude
/// raises a relative contrast (an exposure keeps it, the tone curves compress it). The pixels
/// this selects are the directly seen sky and environment, whose only variance is the pixel
/// filter's over the map's texels: 10⁻⁴–10⁻² at 8 spp, falling about as 1/n, against 5 % and
/// more for every lit surface (Lost Empire, Mori knob, Cornell box, holodeck at 256²).
pub(crate) const NEGLIGIBLE_NOISE_CONTRAST: f32 = 1e-3;

/// Each pixel's relative noise (row-major): the largest over RGB channels of the half-buffers'
/// half-difference over the channel's mean, and the largest over the pixel's 3×3
/// neighbourhood, so that one pixel whose half-buffers agree by chance among noisy neighbours
/// does not look noise-free. Infinite for a pixel with fewer than 2 samples or with noise in a
/// channel of mean 0.
pub(crate) fn relative_noise(film: &Film) -> Vec<f32> {
    let own: Vec<f32> = (0..film.len())
        .into_par_iter()
        .map(|i| {
            if film.effective_count(i) < 2.0 {
                return f32::INFINITY;
            }
            let (a, b, m) = film.means(i);
            let k = film.difference_scale(i);
            (0..3)
                .map(|c| {
                    let d = k * (a[c] - b[c]).abs();
                    if d == 0.0 { 0.0 } else { (d / m[c]) as f32 }
                })
                .fold(0.0, f32::max)
        })
        .collect();
    crate::imaging::max_filter3(&own, film.width as usize, film.height as usize)
}

/// Radius of the neighbourhood whose noise level guards each pixel's estimate (7×7 pixels).
const NEIGHBOURHOOD_RADIUS: usize = 3;

/// E|r| / √E[r²] for Gaussian noise, √(2/π): scales the neighbourhood's RMS ratio to the mean
/// absolute ratio the local estimate measures, so that for Gaussian noise the guard sits at the
/// local estimate's mean and binds only where that estimate is lucky.
const NEIGHBOURHOOD_SHARE: f32 = 0.797_884_6;

/// The error ratio each pixel's neighbourhood predicts at the pixel's own spp:
/// √(mean over (2R + 1)² of r_j² n_j / n_i). r² n is the per-sample variance over the squared
/// threshold, which does not depend on how many samples a pixel took, so the mean pools
/// pixels of any count; E[r²] of the half-buffer estimate is the squared ratio of the pixel's
/// mean (Var(A − B) / 4 = σ² / n).
fn neighbourhood_ratio(r: &[f32], counts: &[u32], w: usize, h: usize) -> Vec<f32> {
    let s2: Vec<f32> = r
        .par_iter()
        .zip(counts.par_iter())
        .map(|(&r, &n)| if r.is_finite() { r * r * n as f32 } else { 0.0 })
        .collect();
    crate::imaging::box_mean(&s2, w, h, NEIGHBOURHOOD_RADIUS)
        .par_iter()
        .zip(counts.par_iter())
        .map(|(&m, &n)| (m / n.max(1) as f32).sqrt())
        .collect()
}

/// Blender Cycles' noise-threshold criterion (after Dammertz et al. 2010): the difference of
/// the full and even-sample means, relative to √I below 1 and to I above, at the auto exposure
/// of the first pass.
pub(crate) struct VarianceCriterion {
    /// Film exposure: 0.18 / log-average luminance of the first pass.
    exposure: f32,
    threshold: f32,
}

impl VarianceCriterion {
    pub fn new(first_pass: &Film, threshold: f32) -> Self {
        let lum = luminance_image(&first_pass.mean_rgb(), 1.0);
        VarianceCriterion {
            exposure: 0.18 / log_average(&lum).max(1e-9),
            threshold,
        }
    }

    pub fn judge(&self, film: &Film) -> Judgement {
        let mean = film.mean_rgb();
        let even = film.mean_rgb_even();
        let k = self.exposure;
        let error: Vec<f32> = mean
            .par_chunks_exact(3)
            .zip(even.par_chunks_exact(3))
            .map(|(f, a)| {
                let diff = ((f[0] - a[0]).abs() + (f[1] - a[1]).abs() + (f[2] - a[2]).abs()) * k;
                let i = (f[0] + f[1] + f[2]) * k;
                let norm = if i < 1.0 { i.max(0.0).sqrt() } else { i };
                diff / (1e-4 + norm)
            })
            .collect();
        Judgement {
            error,
            threshold: vec![self.threshold; film.len()],
        }
    }
}

/// One of the adaptive criteria.
pub(crate) enum Judge {
    Perceptual(Box<PerceptualCriterion>),
    Variance(VarianceCriterion),
}

impl Judge {
    /// Judges the film; returns the judgement and the guide's render time (if it ran now).
    pub fn judge(
        &mut self,
        scene: &Scene,
        film: &Film,
        s: &AdaptiveSettings,
        aux: Option<&Aux>,
    ) -> Result<(Judgement, Duration), AdaptiveError> {
        match self {
            Judge::Perceptual(p) => p.judge(scene, film, s, aux),
            Judge::Variance(v) => Ok((v.judge(film), Duration::ZERO)),
        }
    }

    /// Each pixel's [`relative_noise`] for the perceptual criterion (`None` for the variance
    /// criterion, which keeps Cycles' rule as it is).
    pub fn relative_noise(&self, film: &Film) -> Option<Vec<f32>> {
        match self {
            Judge::Perceptual(_) => Some(relative_noise(film)),
            Judge::Variance(_) => None,
        }
    }

    /// The error ratio the allocation acts on: error / threshold, and 0 where the relative
    /// noise is below [`NEGLIGIBLE_NOISE_CONTRAST`], as for a pixel without noise: no floor and
    /// no share of an even fill. Uniform sampling spends a quarter of Lost Empire's budget on
    /// its sky (23 % of the pixels at 256²), where no judge can see a difference.
    pub fn ratio(judgement: &Judgement, noise: Option<&[f32]>) -> Vec<f32> {
        let mut ratio = judgement.ratio();
        if let Some(noise) = noise {
            ratio.par_iter_mut().zip(noise).for_each(|(r, &q)| {
                if q < NEGLIGIBLE_NOISE_CONTRAST {
                    *r = 0.0;
                }
            });
        }
        ratio
    }

    /// The mean spp at or above which the next judgement recomputes the threshold map (and
    /// so costs more than one that only updates the error); `None` when every judgement costs
    /// the same (the variance criterion) or none was made yet.
    pub fn next_refresh_spp(&self) -> Option<f64> {
        match self {
            Judge::Perceptual(p) => p.threshold.as_ref().map(|(at, _)| at * REFRESH_SPP_FACTOR),
            Judge::Variance(_) => None,
        }
    }

    /// Counters of the guide render (perceptual only).
    pub fn guide_stats(&self) -> Option<RenderStats> {
        match self {
            Judge::Perceptual(p) => p.guide_stats,
            Judge::Variance(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Stationary noise of per-sample level σ (in threshold units): each pixel's ratio is
    /// σ/√n at its own count, so the neighbourhood predicts σ/√n_i for every pixel whatever
    /// the counts around it.
    #[test]
    fn neighbourhood_ratio_pools_pixels_of_any_count() {
        let (w, h) = (9, 9);
        let sigma = 4.0f32;
        let counts: Vec<u32> = (0..w * h).map(|i| [8, 32, 128, 512][i % 4]).collect();
        let r: Vec<f32> = counts.iter().map(|&n| sigma / (n as f32).sqrt()).collect();
        let got = neighbourhood_ratio(&r, &counts, w, h);
        for (g, &n) in got.iter().zip(&counts) {
            let want = sigma / (n as f32).sqrt();
            assert!(
                (g - want).abs() < 1e-5 * want.max(1.0),
                "{g} against {want} at n = {n}"
            );
        }
    }

    /// Caustic-like noise: each sample is 1, or 51 with probability 0.02 (σ = 7), 64 samples a
    /// pixel, and a threshold at half the mean's standard error, so every pixel truly needs
    /// 4× its samples. Four pixels in ten draw as many outliers into each half-buffer, so
    /// their half-buffers agree exactly; the 3×3-pooled estimate alone (the path under a
    /// budget) calls 27 % of the image converged, the guarded one 0.2 %.
    #[test]
    fn heavy_tailed_noise_leaves_no_lucky_patch_converged() {
        let (w, h) = (48usize, 48usize);
        let mut film = Film::new(w as u32, h as u32);
        for (i, px) in film.pixels.iter_mut().enumerate() {
            let mut rng = crate::rng::Rng::new(7, i as u64);
            for _ in 0..64 {
                let v = if rng.uniform() < 0.02 { 51.0 } else { 1.0 };
                px.add(glam::Vec3::splat(v));
            }
        }
        let threshold = vec![0.5 * 7.0 / 8.0; w * h];
        let called_converged = |s: &AdaptiveSettings| {
            let e = PerceptualCriterion::pooled_error(&film, s, 1.0, &threshold, None);
            e.iter().zip(&threshold).filter(|(e, t)| *e <= *t).count() as f64 / (w * h) as f64
        };
        let guarded = called_converged(&AdaptiveSettings::default());
        let local = called_converged(&AdaptiveSettings {
            budget_spp: Some(256.0),
            ..AdaptiveSettings::default()
        });
        assert!(local > 0.1, "3×3 estimate alone: {local} converged");
        assert!(guarded < 0.01, "guarded estimate: {guarded} converged");
    }

    /// A lucky pixel (no difference between its half-buffers) inside a noisy patch is predicted
    /// at its neighbours' level: √(48/49) of it over 7×7.
    #[test]
    fn a_lucky_pixel_takes_its_neighbourhoods_level() {
        let (w, h) = (7, 7);
        let counts = vec![64u32; w * h];
        let mut r = vec![2.0f32; w * h];
        r[3 * w + 3] = 0.0;
        let got = neighbourhood_ratio(&r, &counts, w, h)[3 * w + 3];
        let want = 2.0 * (48.0f32 / 49.0).sqrt();
        assert!((got - want).abs() < 1e-5, "{got} against {want}");
    }

    /// A 5×5 film whose pixels take `samples[i]` (alternately into half-buffers A and B).
    fn film_of(samples: impl Fn(usize) -> Vec<glam::Vec3>) -> Film {
        let mut film = Film::new(5, 5);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            for v in samples(i) {
                p.add(v);
            }
        }
        film
    }

    #[test]
    fn relative_noise_is_the_largest_channels_over_3x3_pixels() {
        use glam::Vec3;
        // Quiet pixels: half-buffers 1 and 1.0005 in green only, so a half-difference of
        // 2.5e-4 of the channel's mean (1.00025); red and blue carry no noise.
        let quiet = |_| vec![Vec3::new(0.5, 1.0, 2.0), Vec3::new(0.5, 1.0005, 2.0)];
        let q = relative_noise(&film_of(quiet));
        let want = 0.00025 / 1.00025;
        assert!(q.iter().all(|&v| (v - want).abs() < 1e-6), "{q:?}");
        assert!(q.iter().all(|&v| v < NEGLIGIBLE_NOISE_CONTRAST));
        // A noisy pixel (blue half-buffers 2 and 3: 0.5 / 2.5 = 0.2) at (1, 1) makes its 3×3
        // neighbourhood noisy, the rest stays quiet; a pixel whose half-buffers agree by chance
        // among noisy neighbours (the centre of a noisy patch) is not negligible.
        let one_noisy = |i| {
            let mut v = quiet(i);
            if i == 6 {
                v[1].z = 3.0;
            }
            v
        };
        let q = relative_noise(&film_of(one_noisy));
        for (i, &v) in q.iter().enumerate() {
            let (x, y) = (i % 5, i / 5);
            let near = x <= 2 && y <= 2;
            assert_eq!(v > 0.1, near, "pixel ({x}, {y}): {v}");
        }
        let lucky_centre = |i| {
            if i == 12 {
                vec![Vec3::ONE, Vec3::ONE]
            } else {
                vec![Vec3::ONE, Vec3::splat(1.5)]
            }
        };
        assert!(relative_noise(&film_of(lucky_centre))[12] > 0.1);
        // One sample: no estimate, never negligible.
        let q = relative_noise(&film_of(|_| vec![Vec3::ONE]));
        assert!(q.iter().all(|v| v.is_infinite()));
    }
}
