//! Threshold-map tests. Expectations are derived in comments from the models' published numbers.

use super::*;

/// ppd = 32 exactly: a `w`-pixel-wide image filling the matching field of view.
fn view32(w: usize) -> ViewingConditions {
    let half = (w as f64 / 2.0 / 32.0 / (180.0 / std::f64::consts::PI)).atan();
    let v = ViewingConditions::from_fov(2.0 * half.to_degrees(), w as f64).unwrap();
    assert!((v.ppd - 32.0).abs() < 1e-9);
    v
}

#[test]
fn flat_field_threshold_is_the_tvi() {
    // Nothing to mask and no frequency content: F = 1 and ΔL_T = ΔL_TVI(100) = 5.559 cd/m²
    // (Ward 1997: 0.05559 · 100).
    let (w, h) = (128, 96);
    let m = threshold_map(&vec![100.0; w * h], w, h, &view32(w), None).unwrap();
    for i in 0..w * h {
        assert!((m.adaptation[i] - 100.0).abs() < 0.01);
        assert!(
            (m.elevation[i] - 1.0).abs() < 1e-3,
            "F = {}",
            m.elevation[i]
        );
        assert!((m.threshold[i] - 5.559).abs() < 0.01, "{}", m.threshold[i]);
    }
}

#[test]
fn dark_fields_have_smaller_absolute_but_larger_relative_thresholds() {
    // TVI: ΔL(1) = 0.3913 (Weber fraction 39 %), ΔL(100) = 5.559 (5.6 %).
    let (w, h) = (64, 64);
    let v = view32(w);
    let dark = threshold_map(&vec![1.0; w * h], w, h, &v, None).unwrap();
    let bright = threshold_map(&vec![100.0; w * h], w, h, &v, None).unwrap();
    let (d, b) = (dark.threshold[2000], bright.threshold[2000]);
    assert!((d - 0.3913).abs() < 0.005 && (b - 5.559).abs() < 0.01);
    assert!(d / 1.0 > 5.0 * (b / 100.0));
}

#[test]
fn fine_high_contrast_checkerboard_reaches_the_cap() {
    // A 1-pixel checkerboard of 20 and 180 cd/m² (contrast 0.8 at 16 cpd for ppd 32). Daly's
    // CSF at 16 cpd and 100 cd/m² is ≈ 60 against a peak of ≈ 237 (E ≈ 4); the masker is
    // 0.8 × 60 ≈ 50 threshold units, T_e(50) = 0.0153 (392.5 · 50)^0.7 ≈ 15. F = E·M ≈ 60 is
    // clamped to 10, so ΔL_T ≈ 10 × ΔL_TVI(100) = 55.6 cd/m².
    let (w, h) = (128, 128);
    let img: Vec<f32> = (0..w * h)
        .map(|i| {
            if (i % w + i / w) % 2 == 0 {
                20.0
            } else {
                180.0
            }
        })
        .collect();
    let m = threshold_map(&img, w, h, &view32(w), None).unwrap();
    let c = (h / 2) * w + w / 2;
    assert!((m.adaptation[c] - 100.0).abs() < 1.0);
    assert!(
        (m.elevation[c] - 10.0).abs() < 1e-3,
        "F = {}",
        m.elevation[c]
    );
    assert!(
        m.masking_elevation[c] > 5.0,
        "masking {}",
        m.masking_elevation[c]
    );
    assert!((m.threshold[c] - 55.59).abs() < 1.0, "{}", m.threshold[c]);
}

fn grating(w: usize, h: usize, period_px: f32, mean: f32, contrast: f32) -> Vec<f32> {
    (0..w * h)
        .map(|i| {
            let x = (i % w) as f32;
            mean * (1.0 + contrast * (2.0 * std::f32::consts::PI * x / period_px).sin())
        })
        .collect()
}

#[test]
fn velocity_raises_the_threshold_on_fine_detail() {
    // A vertical grating of 8 px period (4 cpd at ppd 32), contrast 0.05 around 100 cd/m²:
    // S_Daly93(4) ≈ 230 ⇒ 11 threshold units, T_e ≈ 5, E ≈ 1: F ≈ 5, below the cap.
    // Moving at 20 deg/s (20 px/frame at 32 fps over 32 ppd) the eye tracks at 16.55 deg/s and
    // 3.45 deg/s stays on the retina, where S_KD(4 cpd) falls to about a fifth of its drift
    // value: E ≈ 5, masking falls to T_e(2.3) ≈ 1.8, and F rises to ≈ 7.
    let (w, h) = (128, 64);
    let view = view32(w).with_fps(32.0).unwrap();
    let img = grating(w, h, 8.0, 100.0, 0.05);
    let mapper = ThresholdMapper::new(w, h, view, ThresholdParams::default()).unwrap();
    let still = mapper.compute(&img, None).unwrap();
    let vel: Vec<f32> = (0..w * h).flat_map(|_| [20.0f32, 0.0]).collect();
    let moving = mapper.compute(&img, Some(&vel)).unwrap();
    let c = (h / 2) * w + w / 2;
    assert!(
        still.elevation[c] > 2.0 && still.elevation[c] < 9.0,
        "still F = {}",
        still.elevation[c]
    );
    assert!(
        moving.threshold[c] > 1.2 * still.threshold[c],
        "moving {} vs still {}",
        moving.threshold[c],
        still.threshold[c]
    );
    // A static velocity map gives the static answer.
    let zero = vec![0f32; 2 * w * h];
    let z = mapper.compute(&img, Some(&zero)).unwrap();
    assert!((z.threshold[c] - still.threshold[c]).abs() < 1e-3 * still.threshold[c]);
}

#[test]
fn bands_cover_nyquist_down_to_half_a_cycle_per_degree() {
    let m = ThresholdMapper::new(512, 512, view32(512), ThresholdParams::default()).unwrap();
    // ppd 32: 16, 8, 4, 2, 1, 0.5 cpd.
    assert_eq!(
        m.band_frequencies_cpd(),
        vec![16.0, 8.0, 4.0, 2.0, 1.0, 0.5]
    );
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let v = ViewingConditions::default();
    assert!(ThresholdMapper::new(0, 5, v, ThresholdParams::default()).is_err());
    let p = ThresholdParams {
        max_elevation: 0.5,
        ..Default::default()
    };
    assert!(ThresholdMapper::new(4, 4, v, p).is_err());
    let m = ThresholdMapper::new(4, 4, v, ThresholdParams::default()).unwrap();
    assert!(m.compute(&[1.0; 15], None).is_err());
    let mut img = vec![1.0f32; 16];
    img[5] = f32::NAN;
    assert!(matches!(
        m.compute(&img, None),
        Err(PerceptionError::NonFinite { x: 1, y: 1, .. })
    ));
    img[5] = -1.0;
    assert!(matches!(
        m.compute(&img, None),
        Err(PerceptionError::Negative { .. })
    ));
    assert!(m.compute(&[1.0; 16], Some(&[0.0; 31])).is_err());
}

#[test]
fn noise_threshold_rises_in_the_dark_and_under_masking_in_its_own_bands() {
    // Flat fields at FLIP's 67 ppd. White pixel noise puts ≈ 52 % of its power in band 0 (33 cpd,
    // where Daly's S ≈ 5 at 100 cd/m²) and most of its *visibility* in bands 1–3 (8–16 cpd,
    // S ≈ 60–180): C_noise = 1/sqrt(Σ φ² S²) ≈ 2 % at 100 cd/m². At 1 cd/m² every S_k falls
    // (peak 117 vs 237, and faster at high frequency), so the threshold contrast rises: dark
    // regions tolerate more relative error (de Vries–Rose regime).
    let v = ViewingConditions::default();
    let (w, h) = (128, 128);
    let m = ThresholdMapper::new(w, h, v, ThresholdParams::default()).unwrap();
    let c = (h / 2) * w + w / 2;
    let at = |l: f32| m.compute(&vec![l; w * h], None).unwrap().noise_contrast[c];
    let (dark, bright) = (at(1.0), at(100.0));
    assert!(bright > 0.01 && bright < 0.04, "C_noise(100) = {bright}");
    assert!(
        dark > 1.5 * bright,
        "C_noise(1) = {dark} vs C_noise(100) = {bright}"
    );
    // Masking is band-specific. A checkerboard of 20 and 180 cd/m² in 4×4-pixel squares has its
    // fundamental at a period of 8 px (8.4 cpd, band 2) with contrast 0.8: c·S ≈ 0.8 · 180 ≈ 144
    // threshold units, T_e ≈ 0.0153 (392.5 · 144)^0.7 ≈ 33, so band 2 — with its neighbours the
    // bands where pixel noise is most visible — stops counting and the threshold rises (the
    // remaining bands keep it below the cap max_elevation / S_max ≈ 0.045).
    let checker = |sq: usize| -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                if ((i % w) / sq + (i / w) / sq).is_multiple_of(2) {
                    20.0
                } else {
                    180.0
                }
            })
            .collect()
    };
    let masked = m.compute(&checker(4), None).unwrap().noise_contrast[c];
    assert!(
        masked > 1.4 * bright && masked <= 0.05,
        "masked {masked} vs {bright}"
    );
    // A 1-pixel checkerboard lives at 47 cpd, beyond band 0's centre, where the noise is
    // already nearly invisible: it masks almost nothing of it.
    let fine = m.compute(&checker(1), None).unwrap().noise_contrast[c];
    assert!(fine < 1.05 * bright, "1-px checker {fine} vs {bright}");
    // A coarse step far away (period ≫ the noise's bands) barely changes it: content in other
    // bands does not mask fine grain.
    let step: Vec<f32> = (0..w * h)
        .map(|i| if i % w < 8 { 1000.0 } else { 100.0 })
        .collect();
    let far = m.compute(&step, None).unwrap().noise_contrast[(h / 2) * w + 100];
    assert!(
        far < 1.3 * bright,
        "far from a coarse edge: {far} vs {bright}"
    );
}

#[test]
fn noise_threshold_rises_with_velocity_as_the_csf_predicts() {
    // Flat field at 100 cd/m² (no masking): C_noise ∝ (Σ_k φ_k² S_k²)^−1/2, and motion multiplies
    // each band's sensitivity by r_k = S_KD(ρ_k, v_R) / S_KD(ρ_k, drift). So the ratio
    // C_noise(v) / C_noise(0) = (Σ φ² S² r²)^−1/2 / (Σ φ² S²)^−1/2 is a weighted quadratic mean of
    // the 1/r_k and must lie in [1 / max r_k, 1 / min r_k], computed here from the public CSF.
    let (w, h) = (128, 64);
    let view = view32(w).with_fps(32.0).unwrap();
    let mapper = ThresholdMapper::new(w, h, view, ThresholdParams::default()).unwrap();
    let img = vec![100.0f32; w * h];
    let c = (h / 2) * w + w / 2;
    let still = mapper.compute(&img, None).unwrap().noise_contrast[c];
    let bands = mapper.band_frequencies_cpd();
    let mut prev = 0.0;
    // (Up to 32 px/frame: faster still, C_noise reaches its cap, max_elevation / S_max.)
    for px_per_frame in [4.0f32, 8.0, 16.0, 32.0] {
        let vel: Vec<f32> = (0..w * h).flat_map(|_| [px_per_frame, 0.0]).collect();
        let moving = mapper.compute(&img, Some(&vel)).unwrap().noise_contrast[c];
        let ratio = (moving / still) as f64;
        let v_r = crate::csf::retinal_velocity(view.velocity_deg_s(px_per_frame as f64));
        let r: Vec<f64> = bands
            .iter()
            .map(|&rho| {
                crate::csf::csf_kelly_daly(rho, v_r)
                    / crate::csf::csf_kelly_daly(rho, crate::csf::DRIFT_VELOCITY_DEG_S)
            })
            .collect();
        let (lo, hi) = (
            1.0 / r.iter().cloned().fold(0.0, f64::max),
            1.0 / r.iter().cloned().fold(f64::INFINITY, f64::min),
        );
        // 1 % for the tables' interpolation.
        assert!(
            ratio >= 0.99 * lo && ratio <= 1.01 * hi,
            "{px_per_frame} px/frame (v_R {v_r:.2} deg/s): ratio {ratio} outside [{lo}, {hi}]"
        );
        // Past the pursuit dip, faster content always has a higher noise threshold.
        assert!(ratio > prev, "{px_per_frame} px/frame: {ratio} <= {prev}");
        prev = ratio;
    }
    assert!(
        prev > 2.0,
        "fast content should tolerate much more noise: {prev}"
    );
}

#[test]
fn tracking_a_target_raises_thresholds_of_what_does_not_move_with_it() {
    // A static grating seen while the eye pursues a target moving at 20 deg/s: the grating slips
    // across the retina at the eye's speed (0.82 · 20 + 0.15 = 16.55 deg/s), so its threshold
    // rises well above the per-pixel assumption (static content, eye at rest). Content moving
    // with the target keeps Daly's per-pixel residual.
    let (w, h) = (128, 64);
    let view = view32(w).with_fps(32.0).unwrap();
    let img = grating(w, h, 8.0, 100.0, 0.05);
    let mapper = ThresholdMapper::new(w, h, view, ThresholdParams::default()).unwrap();
    let c = (h / 2) * w + w / 2;
    let zero = vec![0f32; 2 * w * h];
    let eye = EyeTracking::Target([20.0, 0.0]);
    let per_pixel = mapper.compute(&img, Some(&zero)).unwrap();
    let tracked = mapper.compute_tracked(&img, Some(&zero), eye).unwrap();
    assert!(
        tracked.noise_contrast[c] > 1.5 * per_pixel.noise_contrast[c],
        "tracked {} vs per-pixel {}",
        tracked.noise_contrast[c],
        per_pixel.noise_contrast[c]
    );
    // 20 deg/s = 20 px/frame here (32 fps, 32 ppd): moving with the target.
    let with_target: Vec<f32> = (0..w * h).flat_map(|_| [20.0f32, 0.0]).collect();
    let a = mapper
        .compute_tracked(&img, Some(&with_target), eye)
        .unwrap();
    let b = mapper.compute(&img, Some(&with_target)).unwrap();
    assert!((a.threshold[c] / b.threshold[c] - 1.0).abs() < 1e-3);
}

#[test]
fn scaled_maps_equal_maps_of_the_scaled_image() {
    // compute_scaled shares the spectrum and bands across scales; each of its maps must be the
    // map of the image multiplied by that scale, computed on its own, in every adaptation mode
    // and with motion (the velocity factor is evaluated per scale too).
    let (w, h) = (96, 64);
    let img: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            40.0 + 30.0 * (x * 0.7).sin() * (y * 0.3).cos() + if x > 50.0 { 200.0 } else { 0.0 }
        })
        .collect();
    let vel: Vec<f32> = (0..w * h)
        .flat_map(|i| [(i % 7) as f32 * 0.5, 1.0])
        .collect();
    let scales = [0.25f32, 1.0, 4.0, 1e-3];
    for mode in [
        AdaptationMode::LocalArithmetic,
        AdaptationMode::LocalGeometric,
        AdaptationMode::Global,
    ] {
        let params = ThresholdParams {
            adaptation: mode,
            ..ThresholdParams::default()
        };
        let m = ThresholdMapper::new(w, h, ViewingConditions::default(), params).unwrap();
        for v in [None, Some(vel.as_slice())] {
            let maps = m
                .compute_scaled(&img, &scales, v, EyeTracking::PerPixel)
                .unwrap();
            for (&k, got) in scales.iter().zip(&maps) {
                let scaled: Vec<f32> = img.iter().map(|l| l * k).collect();
                let want = m.compute(&scaled, v).unwrap();
                let close = |a: &[f32], b: &[f32], what: &str| {
                    for (i, (x, y)) in a.iter().zip(b).enumerate() {
                        assert!(
                            (x - y).abs() <= 2e-3 * y.abs().max(1e-6),
                            "{mode:?} k {k} {what}[{i}]: {x} vs {y}"
                        );
                    }
                };
                close(&got.noise_contrast, &want.noise_contrast, "noise_contrast");
                close(&got.threshold, &want.threshold, "threshold");
                close(&got.adaptation, &want.adaptation, "adaptation");
            }
        }
    }
    let m = ThresholdMapper::new(
        w,
        h,
        ViewingConditions::default(),
        ThresholdParams::default(),
    )
    .unwrap();
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert!(matches!(
            m.compute_scaled(&img, &[1.0, bad], None, EyeTracking::PerPixel),
            Err(PerceptionError::Parameter { .. })
        ));
    }
}

#[test]
fn noise_shares_match_the_mean_over_the_frequency_square() {
    // The definition, by the midpoint rule on a 1024² grid of frequencies in [−½, ½]²; the
    // closed form must agree, and the shares of all bands plus the residual below them sum to
    // the whole white-noise power.
    for k in 0..6 {
        const N: usize = 1024;
        let f_k = 1.0 / 2f64.powi(k as i32 + 1);
        let mut acc = 0.0;
        for i in 0..N {
            for j in 0..N {
                let fx = (i as f64 + 0.5) / N as f64 - 0.5;
                let fy = (j as f64 + 0.5) / N as f64 - 0.5;
                acc += band_window(k, f_k, (fx * fx + fy * fy).sqrt()).powi(2);
            }
        }
        let grid = acc / (N * N) as f64;
        let closed = noise_share(k);
        assert!(
            (closed - grid).abs() < 2e-3 * grid + 1e-7,
            "band {k}: closed form {closed} against the grid's {grid}"
        );
    }
    // The windows sum to one, so their squares sum to less: the shares cannot exceed the
    // whole power.
    let total: f64 = (0..12).map(noise_share).sum();
    assert!(total > 0.5 && total < 1.0, "Σ φ² = {total}");
}

/// Uniform white noise in [−1, 1) from a 64-bit LCG (Knuth's MMIX constants).
fn white_noise(n: usize, seed: u64) -> Vec<f32> {
    let mut x = seed;
    (0..n)
        .map(|_| {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((x >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        })
        .collect()
}

/// A mapper for a `w × h` image under the default viewing conditions and parameters.
fn default_mapper(w: usize, h: usize) -> ThresholdMapper {
    let (v, p) = (ViewingConditions::default(), ThresholdParams::default());
    ThresholdMapper::new(w, h, v, p).unwrap()
}

#[test]
fn white_noise_puts_the_analytic_share_of_its_power_in_each_band() {
    // The measured shares of white noise must be the φ_k² the noise threshold assumes
    // (noise_share, by Simpson's rule on the windows). A band holding φ² of N = 65,536
    // independent values' power is estimated from about φ² N/2 independent frequencies
    // (a real image's spectrum is Hermitian), each an exponential variate: relative standard
    // error √(2 / (φ² N)). Bands estimated from fewer than 400 frequencies are not checked.
    let (w, h) = (256, 256);
    let m = default_mapper(w, h);
    let shares = m.band_power_shares(&white_noise(w * h, 7)).unwrap();
    assert_eq!(shares.len(), m.band_frequencies_cpd().len());
    let n = (w * h) as f64;
    for (k, &got) in shares.iter().enumerate() {
        let want = noise_share(k);
        if want * n / 2.0 < 400.0 {
            continue;
        }
        let se = (2.0 / (want * n)).sqrt();
        assert!(
            (got as f64 / want - 1.0).abs() < 5.0 * se,
            "band {k}: {got} vs {want} (relative standard error {se:.3})"
        );
    }
    // A constant has no power anywhere.
    assert!(
        m.band_power_shares(&vec![3.0; w * h])
            .unwrap()
            .iter()
            .all(|&s| s == 0.0)
    );
}

#[test]
fn blotchy_error_is_seen_at_a_lower_contrast_than_white_noise() {
    // The same noise box-filtered over 9×9 pixels (a denoised image's blotches) moves its
    // power from band 0 (33 cpd at 67 ppd, S ≈ 5 at 100 cd/m²) to bands 3–4 (4–8 cpd, near
    // the CSF's peak S ≈ 200); band 0 keeps only the box's sinc² sidelobes, ≈ 1/(9πf)² or a
    // few per cent at f ≈ ¼–½ cycle/pixel. At equal RMS contrast it is far more visible, so
    // its threshold RMS contrast is several times lower. Given white noise's own shares, the
    // threshold is white noise's, bit for bit.
    let (w, h) = (256, 256);
    let m = default_mapper(w, h);
    let white = white_noise(w * h, 11);
    let blotchy = box_blur(&white, w, h, 4);
    let ws = m.band_power_shares(&white).unwrap();
    let bs = m.band_power_shares(&blotchy).unwrap();
    assert!(
        bs[0] < 0.1 * ws[0] && bs[3] > 3.0 * ws[3],
        "{ws:?} vs {bs:?}"
    );
    let flat = vec![100.0; w * h];
    let eye = EyeTracking::PerPixel;
    let c = (h / 2) * w + w / 2;
    let base = m.compute_scaled(&flat, &[1.0], None, eye).unwrap();
    let same = m
        .compute_scaled_for_error(&flat, &[1.0], None, eye, &ws)
        .unwrap();
    let analytic: Vec<f32> = (0..ws.len()).map(|k| noise_share(k) as f32).collect();
    let exact = m
        .compute_scaled_for_error(&flat, &[1.0], None, eye, &analytic)
        .unwrap();
    assert_eq!(exact[0], base[0]);
    let ratio = same[0].noise_contrast[c] / base[0].noise_contrast[c];
    assert!((ratio - 1.0).abs() < 0.05, "measured white shares: {ratio}");
    let blot = m
        .compute_scaled_for_error(&flat, &[1.0], None, eye, &bs)
        .unwrap();
    let lower = base[0].noise_contrast[c] / blot[0].noise_contrast[c];
    assert!(lower > 3.0, "blotchy error's threshold only {lower}× lower");
    // The other maps do not depend on the error.
    assert_eq!(blot[0].threshold, base[0].threshold);
    assert!(
        m.compute_scaled_for_error(&flat, &[1.0], None, eye, &bs[1..])
            .is_err()
    );
    let mut bad = bs.clone();
    bad[0] = f32::NAN;
    assert!(
        m.compute_scaled_for_error(&flat, &[1.0], None, eye, &bad)
            .is_err()
    );
}

/// The bands' sums are evaluated only in each level's window (`Window`): every cell that an
/// image pixel's lookup on the d = 2 grid reads (as `finish` does), and every cell that the
/// upsampling of a level's window reads one level coarser (as `upsample2_add` does), must lie
/// in the window of its level, or the map would read a sum never computed. Checked on image
/// sizes odd and even, wide and tall, where the windows touch the canvas edge and where not.
#[test]
fn every_cell_the_image_reads_lies_in_its_levels_window() {
    let inside = |w: Window, (x, y): (usize, usize)| {
        (w.x.0..w.x.1).contains(&x) && (w.y.0..w.y.1).contains(&y)
    };
    for (w, h) in [(256, 170), (97, 61), (33, 300), (5, 3), (512, 512), (1, 1)] {
        let m = default_mapper(w, h);
        let windows = m.windows();
        let pad = &m.pad;
        let lv1 = &m.levels[1];
        for y in 0..h {
            for x in 0..w {
                let xf = (pad.x0 + x) as f32 + 0.5;
                let yf = (pad.y0 + y) as f32 + 0.5;
                let ((x0, x1), _) = taps(xf / 2.0 - 0.5, lv1.fft.width());
                let ((y0, y1), _) = taps(yf / 2.0 - 0.5, lv1.fft.height());
                for cell in [(x0, y0), (x1, y0), (x0, y1), (x1, y1)] {
                    assert!(
                        inside(windows[1], cell),
                        "{w}×{h}: pixel ({x}, {y}) reads {cell:?}"
                    );
                }
            }
        }
        for l in 1..m.levels.len() - 1 {
            let coarse = &m.levels[l + 1];
            let fine = windows[l];
            for y in fine.y.0..fine.y.1 {
                for x in fine.x.0..fine.x.1 {
                    let ((x0, x1), _) = taps(x as f32 / 2.0 - 0.25, coarse.fft.width());
                    let ((y0, y1), _) = taps(y as f32 / 2.0 - 0.25, coarse.fft.height());
                    for cell in [(x0, y0), (x1, y0), (x0, y1), (x1, y1)] {
                        assert!(
                            inside(windows[l + 1], cell),
                            "{w}×{h}: level {l} cell ({x}, {y}) reads {cell:?} on level {}",
                            l + 1
                        );
                    }
                }
            }
        }
        // The windows are what they save: at 256 × 170 the d = 2 grid's window is under a
        // quarter of the grid.
        if (w, h) == (256, 170) {
            let (ww, wh) = windows[1].size();
            assert!(
                4 * ww * wh < lv1.fft.width() * lv1.fft.height(),
                "{:?}",
                windows[1]
            );
        }
    }
}
