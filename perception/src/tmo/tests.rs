//! Tone-operator tests. Expected values for TR, FPSG and PTYG were computed with an independent
//! Python transcription of the seed paper's Tables 1, 2 and 4 (the listings as printed, in
//! double precision).

use super::*;

fn close3(a: &[f32], b: [f64; 3], tol: f64) {
    for (x, y) in a.iter().zip(b) {
        assert!((*x as f64 - y).abs() <= tol, "{a:?} vs {b:?}");
    }
}

#[test]
fn tr_agrees_with_the_listing() {
    let tr = tumblin93::Tumblin93::default();
    close3(
        &tr.map(&[50.0, 100.0, 25.0], &[80.0]),
        [0.150398, 0.300795, 0.075199],
        2e-6,
    );
    close3(
        &tr.map(&[0.5, 0.4, 0.3], &[1.0]),
        [0.075051, 0.060041, 0.045030],
        2e-6,
    );
    close3(
        &tr.map(&[3000.0, 2500.0, 2000.0], &[1000.0]),
        [1.0, 1.0, 0.975072],
        2e-6,
    );
}

#[test]
fn fpsg_agrees_with_the_listing_in_photopic_light_and_adds_rods_in_the_dark() {
    // The listing's tviWard97 uses 5.559e-2 L above 10^1.9 cd/m², Ferwerda's photopic fit
    // 10^−1.255 L = 5.55904e-2 L: they differ by 7.7e-6 relative, hence the tolerance.
    let f = ferwerda96::Ferwerda96::default();
    close3(
        &f.map(&[50.0, 100.0, 25.0], &[80.0]),
        [0.169362, 0.338725, 0.084681],
        4e-6,
    );
    close3(
        &f.map(&[2000.0, 1500.0, 1000.0], &[1000.0]),
        [0.541959, 0.406470, 0.270980],
        4e-6,
    );
    close3(
        &f.map(&[5.0, 6.0, 7.0], &[10.0]),
        [0.070266, 0.084320, 0.098373],
        4e-6,
    );
    // Mesopic: k(10^−2.5) = 1, k(10^0.8) = 0, halfway at 10^−0.85.
    assert_eq!(ferwerda96::mesopic_k(10f64.powf(-3.0)), 1.0);
    assert_eq!(ferwerda96::mesopic_k(10f64.powf(1.0)), 0.0);
    assert!((ferwerda96::mesopic_k(10f64.powf(-0.85)) - 0.5).abs() < 1e-12);
    // In the dark the rod term adds an achromatic component: a saturated red pixel keeps some
    // grey (G and B above zero) and is brighter than its cone term alone.
    let dark = f.map(&[0.01, 0.0, 0.0], &[0.005]);
    assert!(dark[1] > 0.0 && (dark[1] - dark[2]).abs() < 1e-7);
    let (m_p, _) = f.scale_factors(0.005);
    assert!(dark[0] as f64 > m_p * 0.01 / 125.0);
}

#[test]
fn ptyg_agrees_with_the_listing() {
    let p = pattanaik00::Pattanaik00::default();
    let check = |rgb: [f32; 3], a: f64, expect: [f64; 3]| {
        let (bc, br) = pattanaik00::bleaching(a, a);
        let ad = pattanaik00::PixelAdaptation {
            a_cone: a,
            a_rod: a,
            b_cone: bc,
            b_rod: br,
        };
        close3(&p.map_pixel(rgb, ad), expect, 3e-5);
    };
    check([50.0, 100.0, 25.0], 80.0, [0.235055, 0.339568, 0.162721]);
    check([0.5, 0.4, 0.3], 0.3, [0.083095, 0.080010, 0.076228]);
    check([300.0, 200.0, 100.0], 50.0, [1.496521, 1.011278, 0.517609]);
    // σ anchors computed by hand from Pattanaik et al. 2000's σ_cone formula.
    assert!((pattanaik00::sigma_cone(1.0) - 75.35).abs() < 0.01);
    assert!((pattanaik00::sigma_cone(100.0) - 1628.1).abs() < 0.1);
    assert!((pattanaik00::bleaching(1.0, 1.0).1 - 0.038462).abs() < 1e-6);
    // The clipped map stays in [0, 1].
    let out = p.map(&[300.0, 200.0, 100.0], &[50.0]);
    assert!(out.iter().all(|v| (0.0..=1.0).contains(v)));
}

#[test]
fn reinhard_follows_equation_4() {
    // Two pixels of grey 1 and 100 cd/m²: log average 10 (ignoring δ), L_m = 0.018 and 1.8,
    // L_white = 1.8: L_d(1.8) = 1.8 (1 + 1.8/3.24)/2.8 = 1.0, L_d(0.018) = 0.018 (1 +
    // 0.018/3.24)/1.018 = 0.017780.
    // Two rows of the two pixels: each bright pixel has a bright neighbour, so L_white is the
    // paper's largest L_m.
    let img = [1.0, 1.0, 1.0, 100.0, 100.0, 100.0];
    let out = reinhard02::Reinhard02::default().map(&[img, img].concat(), 2);
    for row in [0, 6] {
        assert!((out[row] - 0.017780).abs() < 2e-5, "{}", out[row]);
        assert!((out[row + 3] - 1.0).abs() < 1e-4, "{}", out[row + 3]);
    }
}

/// A field of grey with a bright 3 × 3 light and values around it, as an HDR render holds them.
fn lit_field(w: usize, h: usize) -> Vec<f32> {
    let mut lum = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            lum[y * w + x] = 5.0 + 40.0 * ((x * 7 + y * 13) % 17) as f32 / 17.0;
        }
    }
    for y in 3..6 {
        for x in 10..13 {
            lum[y * w + x] = 2000.0;
        }
    }
    lum
}

#[test]
fn reinhard_white_ignores_a_lone_firefly_and_keeps_the_papers_maximum_otherwise() {
    let (w, h) = (24, 16);
    let lum = lit_field(w, h);
    // The light's pixels have neighbours as bright: the paper's maximum.
    assert_eq!(reinhard02::white_luminance(&lum, w), 2000.0);
    let grey = |l: &[f32]| l.iter().flat_map(|&v| [v, v, v]).collect::<Vec<f32>>();
    let op = reinhard02::Reinhard02::default();
    let clean = op.map(&grey(&lum), w);
    // One sample of a 1024-spp pixel 10⁵ times the rest: a firefly of about 100 × the light.
    let mut fly = lum.clone();
    let f = 12 * w + 4;
    fly[f] = 2.0e5;
    assert_eq!(reinhard02::white_luminance(&fly, w), 2000.0);
    let noisy = op.map(&grey(&fly), w);
    // The log average moves by the firefly's own term, (ln 2e5 − ln v) / N of a stop's fraction;
    // every other pixel keeps its display value to within that.
    let lbar_ratio = (((2.0e5f64).ln() - (lum[f] as f64).ln()) / (w * h) as f64).exp();
    for (i, (a, b)) in clean.iter().zip(&noisy).enumerate() {
        if i / 3 != f {
            assert!(
                (a - b).abs() <= 1.01 * (lbar_ratio - 1.0) as f32 * a + 1e-6,
                "pixel {i}: {a} against {b}"
            );
        }
    }
    assert_eq!(noisy[3 * f], 1.0, "the firefly is drawn white");
    // Without the cap the firefly would have set white, and the light would no longer be
    // drawn white (eq. 4 with L_white the firefly's L_m); with it, the light stays white.
    let lbar = crate::adaptation::log_average(&fly) as f64;
    let (lm_light, lm_fly) = (2000.0 * 0.18 / lbar, 2.0e5 * 0.18 / lbar);
    let uncapped = lm_light * (1.0 + lm_light / (lm_fly * lm_fly)) / (1.0 + lm_light);
    assert!(
        uncapped < 0.99,
        "the test's firefly would move the white ({uncapped})"
    );
    assert_eq!(noisy[3 * (4 * w + 11)], 1.0, "the light is drawn white");
    // An edge case: a 1 × 1 image is its own white; an empty one has none.
    assert_eq!(reinhard02::white_luminance(&[7.0], 1), 7.0);
    assert_eq!(reinhard02::white_luminance(&[], 3), 0.0);
}

#[test]
fn reinhard_white_holds_still_under_a_noisy_highlight() {
    // A glint of 6 × 6 pixels on the lit field, each pixel a Monte Carlo estimate of 200:
    // log-normal noise (σ = 0.4 in log, unit mean), a new realisation per render.
    let (w, h) = (24, 16);
    // One stream for all renders, each taking the next 72 numbers (reseeding per render with
    // related seeds would correlate the renders' first numbers).
    let mut rng = crate::rng_for_tests::Lcg(17);
    let mut render = || {
        let mut lum = lit_field(w, h);
        for y in 8..14 {
            for x in 2..8 {
                // Box–Muller, u1 in (0, 1] for its logarithm.
                let (u1, u2) = (1.0 - rng.next() as f64, rng.next() as f64);
                let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                lum[y * w + x] = (200.0 * (0.4 * z - 0.08).exp()) as f32;
            }
        }
        lum
    };
    // Standard deviation of ln v.
    let sd_log = |v: &[f32]| {
        let l: Vec<f64> = v.iter().map(|&x| (x as f64).ln()).collect();
        let m = l.iter().sum::<f64>() / l.len() as f64;
        (l.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (l.len() - 1) as f64).sqrt()
    };
    let glint = || (8..14).flat_map(|y| (2..8).map(move |x| y * w + x));
    let renders = 256;
    let (mut whites, mut maxima) = (Vec::new(), Vec::new());
    for _ in 0..renders {
        let lum = render();
        // The light's 3 × 3 patch (2000) is brighter than the glint: it sets the white.
        assert_eq!(reinhard02::white_luminance(&lum, w), 2000.0);
        // Without the light the glint sets it: the paper's white is its brightest pixel.
        let dim: Vec<f32> = lum
            .iter()
            .map(|&v| if v == 2000.0 { 40.0 } else { v })
            .collect();
        whites.push(reinhard02::white_luminance(&dim, w));
        maxima.push(glint().map(|i| dim[i]).fold(0f32, f32::max));
    }
    // For 36 normal deviates of σ = 0.4 the largest has a standard deviation of 0.194 and the
    // 9th largest of 0.091 (0.47 times; 200 000 simulated sets). Over 256 renders each
    // estimate is within about 4.4 % (1/√(2 · 256)), their ratio about 6 %: 0.7 lies more than
    // five standard errors above 0.47. Measured: 0.089 against 0.196 (0.45); with the white
    // the largest capped value, as before `WHITE_RANK`, 0.166 against 0.196 (0.85), which fails.
    let (sd_white, sd_max) = (sd_log(&whites), sd_log(&maxima));
    assert!(
        sd_max > 0.15,
        "the test's noise would not move the paper's white (sd of ln {sd_max:.3})"
    );
    assert!(
        sd_white < 0.7 * sd_max,
        "the white moves with the glint's noise: sd of ln {sd_white:.3} against the brightest \
         pixel's {sd_max:.3}"
    );
}

/// A log-uniform ramp of luminance from 1e-2 to 1e4 cd/m² (six decades, far beyond 32:1).
fn ramp(n: usize) -> Vec<f32> {
    (0..n)
        .map(|i| 10f32.powf(-2.0 + 6.0 * i as f32 / (n - 1) as f32))
        .collect()
}

#[test]
fn wrp_is_monotone_uses_the_display_range_and_respects_the_ceiling() {
    let w = ward97::Ward97::default();
    let lum = ramp(4096);
    let mapping = w.build(&lum);
    let ward97::Mapping::Histogram { b_min, db, bd } = &mapping else {
        panic!("six decades must be compressed, got {mapping:?}");
    };
    // Monotone, spanning [L_dmin, L_dmax] = [3.125, 100].
    assert!(bd.windows(2).all(|p| p[1] >= p[0]));
    let (lo, hi) = (
        w.display_luminance(&mapping, 1e-2),
        w.display_luminance(&mapping, 1e4),
    );
    assert!(
        (lo / 3.125 - 1.0).abs() < 0.05 && (hi / 100.0 - 1.0).abs() < 0.05,
        "{lo} {hi}"
    );
    // The contrast ceiling (eq. 9): between bin centres, dL_d/dL_w ≤ ΔL_t(L_d)/ΔL_t(L_w), i.e.
    // d ln L_d / d ln L_w ≤ [ΔL_t(L_d) L_w]/[ΔL_t(L_w) L_d]; allow the 2.5 % trimming tolerance.
    for i in 0..bd.len() - 1 {
        let slope = (bd[i + 1] - bd[i]) / db;
        let lw = (b_min + (i as f64 + 1.0) * db).exp();
        let ld = (0.5 * (bd[i] + bd[i + 1])).exp();
        let ceiling = crate::tvi::tvi_ward97(ld) * lw / (crate::tvi::tvi_ward97(lw) * ld);
        assert!(
            slope <= ceiling * 1.06,
            "bin {i}: slope {slope} > ceiling {ceiling}"
        );
    }
    // Display values run from 0 to 1 and never decrease with luminance.
    let rgb: Vec<f32> = lum.iter().flat_map(|&l| [l; 3]).collect();
    let out = w.map(&rgb, lum.len(), 1, &lum);
    let g: Vec<f32> = out.chunks(3).map(|p| p[1]).collect();
    for (i, p) in g.windows(2).enumerate() {
        assert!(
            p[1] >= p[0] - 1e-6,
            "not monotone at {i}: {} then {} (L = {})",
            p[0],
            p[1],
            lum[i]
        );
    }
    assert!(out[1] < 0.01 && out[out.len() - 2] > 0.95);
}

#[test]
fn wrp_two_level_image_follows_the_papers_rule() {
    let w = ward97::Ward97::default();
    // Two levels 10:1 apart fit the display's 32:1: no compression, the linear operator keeps the
    // world ratio exactly (contrast is neither lost nor exaggerated) and the brighter level goes
    // to L_dmax.
    let lum: Vec<f32> = (0..1000)
        .map(|i| if i % 2 == 0 { 5.0 } else { 50.0 })
        .collect();
    let m = w.build(&lum);
    assert!(matches!(m, ward97::Mapping::Linear { .. }), "{m:?}");
    let (a, b) = (w.display_luminance(&m, 5.0), w.display_luminance(&m, 50.0));
    assert!((b / a - 10.0).abs() < 1e-9 && (b - 100.0).abs() < 1e-9);
    // Two levels 1000:1 apart: the histogram has two spikes whose ceilings (T Δb / ln 32 each,
    // Δb = ln 1000 / 100) sum to 4 % of T, so they are trimmed below the 2.5 % tolerance: the
    // operator falls back to linear, and the display ratio never exceeds the world's.
    let lum: Vec<f32> = (0..1000)
        .map(|i| if i % 2 == 0 { 1.0 } else { 1000.0 })
        .collect();
    let m = w.build(&lum);
    let (a, b) = (
        w.display_luminance(&m, 1.0),
        w.display_luminance(&m, 1000.0),
    );
    assert!(b / a <= 1000.0 * (1.0 + 1e-9));
}

#[test]
fn time_course_reaches_steady_state_and_shows_glare_then_recovery() {
    use pattanaik00::AdaptationState;
    // Steady state is a fixed point.
    let mut s = AdaptationState::steady(100.0, 80.0);
    let s0 = s;
    s.advance(100.0, 80.0, 1.0 / 24.0);
    assert!((s.cone_neural - s0.cone_neural).abs() < 1e-9);
    assert!((s.cone_pigment - s0.cone_pigment).abs() < 1e-12);
    assert!((s.rod_pigment - s0.rod_pigment).abs() < 1e-12);
    // Neural adaptation after one time constant covers 1 − 1/e of a step.
    let mut s = AdaptationState::steady(0.01, 0.01);
    s.advance(1000.0, 1000.0, pattanaik00::CONE_NEURAL_TAU_S);
    assert!(((s.cone_neural - 0.01) / (1000.0 - 0.01) - (1.0 - (-1f64).exp())).abs() < 1e-9);
    // Walking from darkness (0.01 cd/m²) into light (500 cd/m²): a mid-grey pixel looks much
    // brighter (glare) on the first frame than after ten seconds (recovery).
    let p = pattanaik00::Pattanaik00::default();
    let frame = vec![500.0f32; 3];
    let mut s = AdaptationState::steady(0.01, 0.01);
    let (gc, gr) = AdaptationState::stimulus(&frame);
    s.advance(gc, gr, 1.0 / 24.0);
    let first = p.map_dynamic(&frame, &s)[1];
    for _ in 0..240 {
        s.advance(gc, gr, 1.0 / 24.0);
    }
    let later = p.map_dynamic(&frame, &s)[1];
    assert!(first > 1.5 * later, "first {first}, after 10 s {later}");
    // The rod pigment, exactly integrated, stays in [0, 1] even for huge steps.
    let mut s = AdaptationState::steady(0.001, 0.001);
    s.advance(1e6, 1e6, 1.0);
    assert!((0.0..=1.0).contains(&s.rod_pigment));
}

#[test]
fn every_operator_maps_into_the_unit_range_and_rejects_bad_input() {
    let (w, h) = (16, 8);
    let rgb: Vec<f32> = (0..w * h)
        .flat_map(|i| {
            let l = 10f32.powf(-3.0 + 7.0 * i as f32 / (w * h) as f32);
            [l, 0.7 * l, 0.4 * l]
        })
        .collect();
    let lum = crate::photometry::luminance_image(&rgb, 1.0);
    for op in Operator::ALL {
        let out = apply(op, &rgb, w, h, &lum, &Display::default()).unwrap();
        assert!(
            out.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)),
            "{op:?}"
        );
        assert!(out.iter().any(|&v| v > 0.05), "{op:?} is black");
    }
    let black = vec![0.0f32; 3 * w * h];
    assert!(
        apply(
            Operator::Tr,
            &black,
            w,
            h,
            &vec![0.0; w * h],
            &Display::default()
        )
        .is_err()
    );
    let mut nan = rgb.clone();
    nan[7] = f32::NAN;
    assert!(apply(Operator::Wrp, &nan, w, h, &lum, &Display::default()).is_err());
    let bad = Display {
        max_cd_m2: Some(-1.0),
        ambient_cd_m2: None,
    };
    assert!(apply(Operator::Fpsg, &rgb, w, h, &lum, &bad).is_err());
    assert_eq!(Operator::from_name("ptyg"), Some(Operator::Ptyg));
    assert_eq!(Operator::from_name("nope"), None);
}
