//! A χ² goodness-of-fit test for sampling routines on the sphere of directions, in the style of
//! Mitsuba's `ChiSquareTest` (`chi2.py`) and pbrt-v4's `bsdfs_test.cpp`.
//!
//! The sphere is cut into `n_theta × n_phi` cells of equal solid angle (uniform in cos θ and φ).
//! The observed histogram of `samples` draws is compared with the expected counts obtained by
//! integrating the claimed pdf over each cell numerically; cells with an expected count below 5
//! are pooled. The statistic is referred to the χ² distribution with (cells − 1) degrees of
//! freedom. On failure the two histograms are written to `target/chi2-<name>.txt`.

use crate::rng::Rng;
use glam::{Vec2, Vec3};
use std::f64::consts::PI;

/// Outcome of a [`chi2_test`].
#[derive(Debug, Clone)]
pub struct Chi2Result {
    /// The χ² statistic.
    pub statistic: f64,
    /// Degrees of freedom after pooling.
    pub dof: usize,
    /// P-value: probability of a statistic at least this large if the pdf is right.
    pub p_value: f64,
    /// ∫ pdf dω over the sphere (should equal the fraction of successful samples).
    pub pdf_integral: f64,
    /// Fraction of draws that produced a direction.
    pub success_fraction: f64,
}

/// Runs the test. `sample(u)` draws a unit direction (or `None`) from three uniform numbers;
/// `pdf(w)` is the claimed solid-angle density. The histogram written on failure goes to
/// `target/chi2-{name}.txt`.
pub fn chi2_test(
    name: &str,
    samples: usize,
    seed: u64,
    mut sample: impl FnMut(f32, Vec2) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f32,
) -> Chi2Result {
    const N_THETA: usize = 20;
    const N_PHI: usize = 40;
    let cell = |w: Vec3| -> usize {
        let z = w.z.clamp(-1.0, 1.0) as f64;
        let it = (((z + 1.0) * 0.5 * N_THETA as f64) as usize).min(N_THETA - 1);
        let mut phi = (w.y as f64).atan2(w.x as f64);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let ip = ((phi / (2.0 * PI) * N_PHI as f64) as usize).min(N_PHI - 1);
        it * N_PHI + ip
    };
    let mut observed = vec![0f64; N_THETA * N_PHI];
    let mut rng = Rng::new(seed, 0x5eed);
    let mut ok = 0usize;
    for _ in 0..samples {
        let uc = rng.uniform();
        let u = rng.uniform2();
        if let Some(w) = sample(uc, u) {
            ok += 1;
            observed[cell(w)] += 1.0;
        }
    }
    // Expected counts: adaptive midpoint quadrature of the pdf over each equal-area cell in
    // (cos θ, φ), refined where a cell's estimate changes under subdivision (sharp lobes).
    let eval = |z: f64, phi: f64| -> f64 {
        let r = (1.0 - z * z).max(0.0).sqrt();
        let w = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
        pdf(w) as f64
    };
    let mut expected = vec![0f64; N_THETA * N_PHI];
    let mut integral = 0.0;
    let dz = 2.0 / N_THETA as f64;
    let dphi = 2.0 * PI / N_PHI as f64;
    for it in 0..N_THETA {
        for ip in 0..N_PHI {
            let z0 = -1.0 + it as f64 * dz;
            let phi0 = ip as f64 * dphi;
            let p = integrate_rect(&eval, z0, phi0, dz, dphi, 0);
            integral += p;
            expected[it * N_PHI + ip] = p * samples as f64;
        }
    }
    // Pool low-expectation cells (sorted by expectation) until each pool has ≥ 5 expected.
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].partial_cmp(&expected[b]).unwrap());
    let (mut stat, mut dof) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for &i in &order {
        if expected[i] == 0.0 {
            if observed[i] > 0.0 {
                // Samples where the pdf claims zero density: infinitely unlikely.
                stat = f64::INFINITY;
            }
            continue;
        }
        if expected[i] < 5.0 {
            pool_o += observed[i];
            pool_e += expected[i];
            if pool_e >= 5.0 {
                stat += (pool_o - pool_e).powi(2) / pool_e;
                dof += 1;
                pool_o = 0.0;
                pool_e = 0.0;
            }
            continue;
        }
        stat += (observed[i] - expected[i]).powi(2) / expected[i];
        dof += 1;
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e).powi(2) / pool_e;
        dof += 1;
    }
    let dof = dof.saturating_sub(1).max(1);
    let p_value = if stat.is_finite() {
        gamma_q(dof as f64 / 2.0, stat / 2.0)
    } else {
        0.0
    };
    let result = Chi2Result {
        statistic: stat,
        dof,
        p_value,
        pdf_integral: integral,
        success_fraction: ok as f64 / samples as f64,
    };
    if p_value < 1e-3 {
        let mut text = format!("{result:?}\n# cell observed expected\n");
        for i in 0..observed.len() {
            text += &format!("{i} {} {:.3}\n", observed[i], expected[i]);
        }
        let _ = std::fs::create_dir_all("target");
        let _ = std::fs::write(format!("target/chi2-{name}.txt"), text);
    }
    result
}

/// ∫∫ f(z, φ) dz dφ over a rectangle: a 4×4 midpoint rule, refined by quadrisection while the
/// refined and coarse estimates differ by more than 1e-8 (absolute probability), to depth 7.
fn integrate_rect(
    f: &impl Fn(f64, f64) -> f64,
    z0: f64,
    p0: f64,
    dz: f64,
    dp: f64,
    depth: u32,
) -> f64 {
    let mid = |z0: f64, p0: f64, dz: f64, dp: f64| -> f64 {
        let mut acc = 0.0;
        for a in 0..4 {
            for b in 0..4 {
                acc += f(
                    z0 + (a as f64 + 0.5) * dz / 4.0,
                    p0 + (b as f64 + 0.5) * dp / 4.0,
                );
            }
        }
        acc / 16.0 * dz * dp
    };
    let coarse = mid(z0, p0, dz, dp);
    let (hz, hp) = (dz / 2.0, dp / 2.0);
    let quads = [(z0, p0), (z0 + hz, p0), (z0, p0 + hp), (z0 + hz, p0 + hp)];
    let fine: f64 = quads.iter().map(|&(z, p)| mid(z, p, hz, hp)).sum();
    if depth >= 7 || (fine - coarse).abs() < 1e-8 {
        return fine;
    }
    quads
        .iter()
        .map(|&(z, p)| integrate_rect(f, z, p, hz, hp, depth + 1))
        .sum()
}

/// Regularised upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a) (Numerical Recipes §6.2:
/// series for x < a + 1, Lentz continued fraction otherwise).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let gln = ln_gamma(a);
    if x < a + 1.0 {
        let mut ap = a;
        let mut sum = 1.0 / a;
        let mut del = sum;
        for _ in 0..10_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - gln).exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (-x + a * x.ln() - gln).exp() * h
    }
}

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, n = 9).
pub fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_q_matches_known_chi2_quantiles() {
        // χ² critical values (NIST/SEMATECH handbook table 1.3.6.7.4): P(χ²_10 > 18.307) = 0.05,
        // P(χ²_1 > 6.635) = 0.01, P(χ²_100 > 135.807) = 0.01.
        assert!((gamma_q(5.0, 18.307 / 2.0) - 0.05).abs() < 2e-4);
        assert!((gamma_q(0.5, 6.635 / 2.0) - 0.01).abs() < 1e-4);
        assert!((gamma_q(50.0, 135.807 / 2.0) - 0.01).abs() < 1e-4);
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
    }

    #[test]
    fn detects_a_wrong_pdf() {
        use crate::sampling::*;
        // Correct: cosine sampling with its pdf.
        let good = chi2_test(
            "cosine-good",
            200_000,
            1,
            |_, u| Some(square_to_cosine_hemisphere(u)),
            square_to_cosine_hemisphere_pdf,
        );
        assert!(good.p_value > 1e-3, "{good:?}");
        // Wrong: cosine sampling checked against a uniform hemisphere pdf.
        let bad = chi2_test(
            "cosine-bad",
            200_000,
            1,
            |_, u| Some(square_to_cosine_hemisphere(u)),
            |w| {
                if w.z > 0.0 {
                    0.5 / std::f32::consts::PI
                } else {
                    0.0
                }
            },
        );
        assert!(bad.p_value < 1e-6, "{bad:?}");
    }
}
