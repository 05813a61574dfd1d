//! Behaviour tests of the metric on synthetic images. Each expectation is derived in a comment
//! from the models' published numbers, not from the code's output.

use super::*;
use crate::rng_for_tests::Lcg;

/// pdiff's viewing: a 256-pixel-wide image filling 45° (ppd = 5.4; only low frequencies are
/// resolvable, so fine-pattern tests use FLIP's 67 ppd instead).
fn view_for(w: usize) -> ViewingConditions {
    ViewingConditions::from_fov(45.0, w as f64).unwrap()
}

#[test]
fn identical_images_show_no_difference() {
    let (w, h) = (96, 64);
    let mut rng = Lcg(7);
    let img: Vec<f32> = (0..w * h).map(|_| 10.0 + 200.0 * rng.next()).collect();
    let r = visible_difference(&img, &img, w, h, &view_for(w)).unwrap();
    assert_eq!(r.visible_pixels, 0);
    assert!(!r.different);
    assert!(r.ratio.iter().all(|&x| x == 0.0));
}

/// A flat 100 cd/m² field with a 64×64 patch raised by `step` (relative). The reference is
/// flat, so its map is the TVI alone: ΔL_T = 5.559 cd/m² (Ward 1997), a Weber fraction of 5.6 %.
fn patch_step(step: f32) -> DiffResult {
    let (w, h) = (128, 128);
    let reference = vec![100.0f32; w * h];
    let test: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if (32..96).contains(&x) && (32..96).contains(&y) {
                100.0 * (1.0 + step)
            } else {
                100.0
            }
        })
        .collect();
    visible_difference(&reference, &test, w, h, &view_for(w)).unwrap()
}

#[test]
fn a_20_percent_step_is_visible_and_2_percent_is_not() {
    // 20 cd/m² > 5.559: every one of the 4096 patch pixels is visible.
    let big = patch_step(0.20);
    assert_eq!(big.visible_pixels, 64 * 64);
    assert!(big.different);
    // 2 cd/m² < 5.559: nothing is.
    let small = patch_step(0.02);
    assert_eq!(small.visible_pixels, 0);
    assert!(!small.different);
}

/// Adds uniform noise of ±`amp` (relative) to each pixel.
fn noisy(img: &[f32], amp: f32, seed: u64) -> Vec<f32> {
    let mut rng = Lcg(seed);
    img.iter()
        .map(|&v| (v * (1.0 + amp * (2.0 * rng.next() - 1.0))).max(0.0))
        .collect()
}

#[test]
fn noise_is_visible_on_a_flat_field_but_masked_on_a_fine_checkerboard() {
    // FLIP's viewing (67 ppd) so that a 1-pixel checkerboard is a 33 cpd pattern.
    let view = ViewingConditions::default();
    let (w, h) = (128, 128);
    // Flat 100 cd/m²: ΔL_T = 5.56. Uniform noise of ±20 % (±20 cd/m²) exceeds it in
    // (20 − 5.56)/20 = 72 % of pixels.
    let flat = vec![100.0f32; w * h];
    let r = DiffMetric::new(w, h, view, ThresholdParams::default(), 100)
        .unwrap()
        .compare(&flat, &noisy(&flat, 0.2, 1))
        .unwrap();
    assert!(
        (r.visible_fraction - 0.72).abs() < 0.03,
        "{}",
        r.visible_fraction
    );
    // Checkerboard of 20 and 180 cd/m² (L_a = 100): the 33 cpd pattern has Daly sensitivity
    // ≈ 10 vs a peak of ≈ 237 (E ≈ 24) and masks strongly, so F reaches the cap of 10 and
    // ΔL_T = 55.6 cd/m². ±20 % noise is at most ±36 cd/m² on the bright squares: never visible.
    let checker: Vec<f32> = (0..w * h)
        .map(|i| {
            if (i % w + i / w) % 2 == 0 {
                20.0
            } else {
                180.0
            }
        })
        .collect();
    let r = DiffMetric::new(w, h, view, ThresholdParams::default(), 100)
        .unwrap()
        .compare(&checker, &noisy(&checker, 0.2, 2))
        .unwrap();
    // Away from the borders, where the band analysis sees the full pattern.
    let interior_visible = (0..w * h)
        .filter(|&i| (8..w - 8).contains(&(i % w)) && (8..h - 8).contains(&(i / w)))
        .filter(|&i| r.ratio[i] > 1.0)
        .count();
    assert_eq!(interior_visible, 0);
}

#[test]
fn a_noisy_test_image_cannot_mask_itself() {
    // Reference flat; the test is the same field with strong noise. If the test's own contrast
    // set the masking (pdiff's max of the two), the noise would raise its own threshold; with the
    // reference alone it is judged against the TVI: visible.
    let view = ViewingConditions::default();
    let (w, h) = (64, 64);
    let flat = vec![100.0f32; w * h];
    let test = noisy(&flat, 0.5, 3);
    let r = DiffMetric::new(w, h, view, ThresholdParams::default(), 100)
        .unwrap()
        .compare(&flat, &test)
        .unwrap();
    // ±50 cd/m² uniform against 5.56: visible in (50 − 5.56)/50 = 89 % of pixels.
    assert!(
        (r.visible_fraction - 0.89).abs() < 0.03,
        "{}",
        r.visible_fraction
    );
}

#[test]
fn bad_input_is_an_error() {
    let v = ViewingConditions::default();
    assert!(visible_difference(&[1.0; 4], &[1.0; 6], 2, 2, &v).is_err());
    assert!(visible_difference(&[], &[], 0, 0, &v).is_err());
    assert!(visible_difference(&[1.0, f32::NAN, 1.0, 1.0], &[1.0; 4], 2, 2, &v).is_err());
    assert!(visible_difference(&[1.0; 4], &[1.0, -2.0, 1.0, 1.0], 2, 2, &v).is_err());
}
