//! Contrast sensitivity functions (sensitivity = 1 / threshold contrast) and the eye-movement
//! model that turns image velocity into retinal velocity.
//!
//! # References
//! - Daly 1993, "The Visible Differences Predictor: An Algorithm for the Assessment of Image
//!   Fidelity", in Digital Images and Human Vision (A. B. Watson, ed.), MIT Press, pp. 179–206:
//!   the static CSF with adaptation luminance, image size, viewing distance, eccentricity and
//!   orientation (his eqs. for S, S1, A_l, B_l, r_a, r_e, r_θ).
//! - Kelly 1979, "Motion and vision. II. Stabilized spatio-temporal threshold surface", JOSA
//!   69(10); Daly 1998, "Engineering observations from spatiovelocity and spatiotemporal visual
//!   models", Proc. SPIE 3299, eq. 6 (the spatiovelocity CSF) and eq. 8 (smooth-pursuit eye
//!   movement); constants as corrected by Myszkowski, Rokita & Tawara 2000, "Perception-Based
//!   Fast Rendering and Antialiasing of Walkthrough Sequences", IEEE TVCG 6(4), eq. 2.

use std::f64::consts::PI;

/// Kelly–Daly constant c0 (Daly 1998, Myszkowski et al. 2000).
pub const KD_C0: f64 = 1.14;
/// Kelly–Daly constant c1.
pub const KD_C1: f64 = 0.67;
/// Kelly–Daly constant c2.
pub const KD_C2: f64 = 1.7;
/// Smallest retinal velocity, deg/s: the eyes' drift (Daly 1998); the Kelly–Daly CSF tends to
/// zero for a perfectly stabilised image, which real viewing never is.
pub const DRIFT_VELOCITY_DEG_S: f64 = 0.15;
/// Smooth-pursuit gain g_sp (Daly 1998 eq. 8).
pub const PURSUIT_GAIN: f64 = 0.82;
/// Minimum eye velocity v_min, deg/s (Daly 1998 eq. 8).
pub const PURSUIT_MIN_DEG_S: f64 = 0.15;
/// Maximum smooth-pursuit eye velocity v_max, deg/s (Daly 1998 eq. 8).
pub const PURSUIT_MAX_DEG_S: f64 = 80.0;

/// Daly's peak sensitivity scale P (Daly 1993).
pub const DALY_P: f64 = 250.0;
/// Daly's ε (Daly 1993).
pub const DALY_EPSILON: f64 = 0.9;

/// Kelly–Daly spatiovelocity CSF S(ρ, v_R) (Daly 1998 eq. 6 with Myszkowski et al. 2000's
/// constants): S = c0 · k · c2 · v · (2π c1 ρ)² · exp(−4π c1 ρ / ρ_max), with
/// k = 6.1 + 7.3 |log10(c2 v / 3)|³ and ρ_max = 45.9 / (c2 v + 2).
///
/// `rho_cpd` is spatial frequency in cycles per degree; `retinal_velocity_deg_s` is the retinal
/// velocity in deg/s, clamped to ≥ [`DRIFT_VELOCITY_DEG_S`]. The peak lies at ρ_max/(2π c1).
pub fn csf_kelly_daly(rho_cpd: f64, retinal_velocity_deg_s: f64) -> f64 {
    let v = retinal_velocity_deg_s.max(DRIFT_VELOCITY_DEG_S);
    let k = 6.1 + 7.3 * (KD_C2 * v / 3.0).log10().abs().powi(3);
    let rho_max = 45.9 / (KD_C2 * v + 2.0);
    let a = 2.0 * PI * KD_C1 * rho_cpd;
    KD_C0 * k * KD_C2 * v * a * a * (-4.0 * PI * KD_C1 * rho_cpd / rho_max).exp()
}

/// Frequency (cpd) where [`csf_kelly_daly`] peaks at retinal velocity `v`: ρ_max / (2π c1).
pub fn kelly_daly_peak_cpd(retinal_velocity_deg_s: f64) -> f64 {
    let v = retinal_velocity_deg_s.max(DRIFT_VELOCITY_DEG_S);
    45.9 / (KD_C2 * v + 2.0) / (2.0 * PI * KD_C1)
}

/// Retinal velocity left after smooth-pursuit eye tracking (Daly 1998 eq. 8): the eye follows at
/// v_E = min(g_sp · v_I + v_min, v_max), and v_R = |v_I − v_E|, clamped to ≥ the drift velocity.
/// All in deg/s. Note that v_R dips to its clamp near v_I = 0.83 deg/s, where the eye's minimum
/// velocity equals the unmatched part of the motion.
pub fn retinal_velocity(image_velocity_deg_s: f64) -> f64 {
    let vi = image_velocity_deg_s.abs();
    let ve = (PURSUIT_GAIN * vi + PURSUIT_MIN_DEG_S).min(PURSUIT_MAX_DEG_S);
    (vi - ve).abs().max(DRIFT_VELOCITY_DEG_S)
}

/// Where the eye is assumed to look when content moves (Daly 1998; Yee et al. 2001 §4).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum EyeTracking {
    /// Every pixel's motion is assumed to be followed by smooth pursuit ([`retinal_velocity`]):
    /// the conservative choice when the viewer's target is unknown, since it gives each pixel
    /// the smallest retinal velocity any gaze could give it (Daly 1998; Yee et al. 2001).
    #[default]
    PerPixel,
    /// The eye pursues one target whose image velocity is this vector (deg/s, x right, y
    /// down), as Yee et al. 2001 assume for the salient object: the eye moves at
    /// v_E = min(g_sp |v_T| + v_min, v_max) along v_T, and each pixel's retinal velocity is
    /// |v_I − v_E|, clamped to ≥ the drift velocity.
    Target([f64; 2]),
}

/// Retinal velocity (deg/s) of content moving at image velocity `v_i` (deg/s, a 2-D vector)
/// under the eye-tracking assumption `eye` (Daly 1998 eq. 8, with the eye's velocity vector
/// taken from the tracked target for [`EyeTracking::Target`]).
pub fn retinal_velocity_tracked(v_i: [f64; 2], eye: EyeTracking) -> f64 {
    match eye {
        EyeTracking::PerPixel => retinal_velocity(v_i[0].hypot(v_i[1])),
        EyeTracking::Target(t) => {
            let speed = t[0].hypot(t[1]);
            let (ex, ey) = if speed > 0.0 {
                let ve = (PURSUIT_GAIN * speed + PURSUIT_MIN_DEG_S).min(PURSUIT_MAX_DEG_S);
                (t[0] / speed * ve, t[1] / speed * ve)
            } else {
                (0.0, 0.0)
            };
            (v_i[0] - ex).hypot(v_i[1] - ey).max(DRIFT_VELOCITY_DEG_S)
        }
    }
}

/// Parameters of Daly's 1993 static CSF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DalyCsfParams {
    /// Image area i², deg² (the stimulus size term; large images make it ≈ 1).
    pub image_area_deg2: f64,
    /// Viewing distance d, m.
    pub distance_m: f64,
    /// Eccentricity e, degrees (0 = foveal).
    pub eccentricity_deg: f64,
    /// Orientation θ, radians (0 = horizontal or vertical, where sensitivity is highest).
    pub orientation_rad: f64,
}

impl Default for DalyCsfParams {
    /// A 10° × 10° foveal image at 0.5 m (the values of aleph's `docs/DESIGN.md` §5 anchors).
    fn default() -> Self {
        DalyCsfParams {
            image_area_deg2: 100.0,
            distance_m: 0.5,
            eccentricity_deg: 0.0,
            orientation_rad: 0.0,
        }
    }
}

fn daly_s1(rho: f64, l: f64, i2: f64) -> f64 {
    if rho <= 0.0 {
        return 0.0;
    }
    let a_l = 0.801 * (1.0 + 0.7 / l).powf(-0.2);
    let b_l = 0.3 * (1.0 + 100.0 / l).powf(0.15);
    let er = DALY_EPSILON * rho;
    let size = ((3.23 * (rho * rho * i2).powf(-0.3)).powi(5) + 1.0).powf(-0.2);
    size * a_l * er * (-b_l * er).exp() * (1.0 + 0.06 * (b_l * er).exp()).sqrt()
}

/// Daly 1993 static CSF: S = P · min[S1(ρ / (r_a r_e r_θ), l, i²), S1(ρ, l, i²)] with
/// S1 = [(3.23 (ρ² i²)^−0.3)^5 + 1]^−1/5 · A_l ε ρ · exp(−B_l ε ρ) · sqrt(1 + 0.06 exp(B_l ε ρ)),
/// A_l = 0.801 (1 + 0.7/l)^−0.2, B_l = 0.3 (1 + 100/l)^0.15, r_a = 0.856 d^0.14,
/// r_e = 1/(1 + 0.24 e), r_θ = 0.11 cos 4θ + 0.89, P = 250, ε = 0.9.
///
/// `rho_cpd` in cycles per degree, `adapt_lum_cd_m2` (l) in cd/m² (clamped to ≥ 1e-4).
/// The peak falls and moves to lower frequencies as l drops (≈ 237 at 3.2 cpd for 100 cd/m²,
/// 118 at 1.8 cpd for 1 cd/m², with the default parameters).
pub fn csf_daly93(rho_cpd: f64, adapt_lum_cd_m2: f64, p: &DalyCsfParams) -> f64 {
    let l = adapt_lum_cd_m2.max(1e-4);
    let r_a = 0.856 * p.distance_m.max(1e-3).powf(0.14);
    let r_e = 1.0 / (1.0 + 0.24 * p.eccentricity_deg.abs());
    let r_t = 0.11 * (4.0 * p.orientation_rad).cos() + 0.89;
    let i2 = p.image_area_deg2.max(1e-6);
    DALY_P * daly_s1(rho_cpd / (r_a * r_e * r_t), l, i2).min(daly_s1(rho_cpd, l, i2))
}

/// The peak (frequency in cpd, sensitivity) of [`csf_daly93`] at luminance `l`, found by golden-
/// section search on log ρ over [0.05, 60] cpd, to 1e-9 in log ρ (49 evaluations: each step
/// keeps one of the two interior points and evaluates one new one).
pub fn daly93_peak(adapt_lum_cd_m2: f64, p: &DalyCsfParams) -> (f64, f64) {
    let f = |lr: f64| -csf_daly93(lr.exp(), adapt_lum_cd_m2, p);
    let (mut a, mut b) = (0.05f64.ln(), 60f64.ln());
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    while b - a > 1e-9 {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    let r = (0.5 * (a + b)).exp();
    (r, csf_daly93(r, adapt_lum_cd_m2, p))
}

/// Masking constants of Daly 1993's threshold-elevation function.
pub const MASK_K1: f64 = 0.0153;
/// See [`MASK_K1`].
pub const MASK_K2: f64 = 392.498;
/// Masking slope s.
pub const MASK_S: f64 = 0.7;
/// Masking exponent b.
pub const MASK_B: f64 = 4.0;

/// Threshold elevation by visual masking (Daly 1993): T_e(c) = [1 + (k1 (k2 c)^s)^b]^(1/b) with
/// k1 = 0.0153, k2 = 392.498, s = 0.7, b = 4, where c is the masker's contrast in threshold
/// units (contrast × sensitivity, dimensionless, ≥ 0). T_e(0.1) = 1.0004, T_e(1) = 1.190; for
/// large c it grows as c^0.7.
pub fn masking_elevation(c_threshold_units: f64) -> f64 {
    let c = c_threshold_units.max(0.0);
    (1.0 + (MASK_K1 * (MASK_K2 * c).powf(MASK_S)).powf(MASK_B)).powf(1.0 / MASK_B)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs()
    }

    #[test]
    fn kelly_daly_anchor_table() {
        // aleph's `docs/DESIGN.md` §5 [calc]: v_R, ρ_peak, S_peak, S(1), S(4), S(10).
        let table = [
            (0.15, 4.84, 245.4, 51.3, 237.3, 124.0),
            (1.0, 2.95, 250.6, 108.2, 226.0, 24.1),
            (2.0, 2.02, 231.2, 155.6, 127.6, 2.1),
            (5.0, 1.04, 169.8, 169.6, 8.4, 0.0),
        ];
        for (v, rp, sp, s1, s4, s10) in table {
            assert!(close(kelly_daly_peak_cpd(v), rp, 2e-3), "peak at v={v}");
            assert!(close(csf_kelly_daly(rp, v), sp, 2e-3), "S_peak at v={v}");
            assert!(close(csf_kelly_daly(1.0, v), s1, 2e-3));
            assert!(close(csf_kelly_daly(4.0, v), s4, 2e-3));
            assert!((csf_kelly_daly(10.0, v) - s10).abs() <= 0.06 + 2e-3 * s10);
            // It is a peak: lower on both sides.
            assert!(csf_kelly_daly(rp * 1.1, v) < csf_kelly_daly(rp, v));
            assert!(csf_kelly_daly(rp / 1.1, v) < csf_kelly_daly(rp, v));
        }
    }

    #[test]
    fn high_frequency_sensitivity_drops_with_retinal_velocity() {
        // Above the static peak (4.84 cpd) sensitivity falls monotonically with velocity, e.g.
        // at 8 cpd: 181.5, 156.3, 122.5, 59.9, 9.7, 0.1 for v = 0.15, 0.3, 0.5, 1, 2, 4 deg/s
        // (computed from Daly 1998 eq. 6). Below the peak it first rises (4 cpd: 237 → 248).
        for rho in [6.0, 8.0, 16.0] {
            let mut prev = f64::INFINITY;
            for v in [0.15, 0.3, 0.5, 1.0, 2.0, 4.0] {
                let s = csf_kelly_daly(rho, v);
                assert!(s < prev, "S({rho}, {v}) = {s} not below {prev}");
                prev = s;
            }
        }
    }

    #[test]
    fn eye_tracking_model() {
        // Static: only drift remains.
        assert_eq!(retinal_velocity(0.0), DRIFT_VELOCITY_DEG_S);
        // Near v_I = 0.15/0.18 = 0.833 the pursuit matches the motion: v_R hits the clamp.
        assert_eq!(retinal_velocity(0.15 / 0.18), DRIFT_VELOCITY_DEG_S);
        // 10 deg/s: v_E = 8.35, v_R = 1.65.
        assert!((retinal_velocity(10.0) - 1.65).abs() < 1e-12);
        // Tracking a target: the target itself keeps Daly's per-pixel residual, static content
        // slips across the retina at the eye's own speed, and content moving against the
        // target at the sum.
        let eye = EyeTracking::Target([10.0, 0.0]);
        assert!((retinal_velocity_tracked([10.0, 0.0], eye) - 1.65).abs() < 1e-12);
        assert!((retinal_velocity_tracked([0.0, 0.0], eye) - 8.35).abs() < 1e-12);
        assert!((retinal_velocity_tracked([-10.0, 0.0], eye) - 18.35).abs() < 1e-12);
        assert_eq!(
            retinal_velocity_tracked([3.0, 4.0], EyeTracking::PerPixel),
            retinal_velocity(5.0)
        );
        // Beyond pursuit's 80 deg/s limit the eye lags: 200 deg/s → v_R = 120.
        assert!((retinal_velocity(200.0) - 120.0).abs() < 1e-12);
    }

    #[test]
    fn daly93_peaks_fall_and_shift_with_luminance() {
        // aleph's `docs/DESIGN.md` §5 [calc] (d = 0.5 m, e = 0, θ = 0, i² = 100 deg²).
        let p = DalyCsfParams::default();
        for (l, s_peak, rho_peak) in [
            (100.0, 236.9, 3.19),
            (10.0, 180.9, 2.48),
            (1.0, 117.6, 1.81),
        ] {
            let (r, s) = daly93_peak(l, &p);
            assert!(close(s, s_peak, 1e-3), "l={l}: peak {s} vs {s_peak}");
            assert!(close(r, rho_peak, 0.01), "l={l}: at {r} vs {rho_peak}");
        }
        // Fall-off: well above the peak, sensitivity drops steeply (factor > 10 by 30 cpd).
        assert!(csf_daly93(30.0, 100.0, &p) < csf_daly93(3.19, 100.0, &p) / 10.0);
        // and below it (low-frequency roll-off).
        assert!(csf_daly93(0.2, 100.0, &p) < csf_daly93(3.19, 100.0, &p) / 3.0);
    }

    #[test]
    fn masking_anchor_values() {
        assert!(close(masking_elevation(1.0), 1.190, 1e-3));
        assert!(close(masking_elevation(0.1), 1.0004, 1e-4));
        assert_eq!(masking_elevation(0.0), 1.0);
        // Asymptote: T_e ≈ k1 (k2 c)^s for large c.
        let c = 1e4;
        assert!(close(
            masking_elevation(c),
            MASK_K1 * (MASK_K2 * c).powf(MASK_S),
            1e-6
        ));
    }
}
