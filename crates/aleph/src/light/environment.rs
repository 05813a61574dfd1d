//! The environment light: radiance arriving from infinitely far away in every direction, from a
//! constant colour or an equirectangular (latitude–longitude) HDR image.
//!
//! # Mapping
//! The same as Mitsuba 3's `envmap` (so scenes and references carry over): a world direction d
//! is first rotated by the inverse of the light's rotation (about +y, `rotate_deg`), then
//! u = atan2(d.x, −d.z) / 2π (wrapped to [0, 1)) and v = acos(d.y) / π, with v = 0 the top row
//! of the image (+y, the zenith). The image's centre column (u = ½) looks along +z.
//!
//! # Sampling
//! A piecewise-constant 2-D distribution over the texels with weights luminance × the texel's
//! solid angle (pbrt-v4 §12.5.2, "Image Infinite Lights", weights by sin θ); within its texel a
//! direction is drawn uniformly in φ and in cos θ, so the solid-angle density is constant over
//! each texel, p(ω) = P(texel) / Ω(texel), with no 1/sin θ spike at the poles. Texels are
//! looked up bilinearly, so each texel's weight is the largest luminance of its 3×3
//! neighbourhood: every direction with radiance has non-zero density.

use crate::math::luminance;
use crate::sampling::Distribution2D;
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// cos θ₀ − cos θ₁ of image row `r` of `height` (θ from the zenith, θ₀ = πr/h): the row's
/// solid angle over 2π.
#[inline]
fn row_solid_angle(r: usize, height: usize) -> f32 {
    let t0 = PI * r as f32 / height as f32;
    let t1 = PI * (r + 1) as f32 / height as f32;
    // cos a − cos b = 2 sin((a+b)/2) sin((b−a)/2), without cancellation.
    2.0 * (0.5 * (t0 + t1)).sin() * (0.5 * (t1 - t0)).sin()
}

/// Radiance from every direction at infinity.
#[derive(Clone, Debug)]
pub struct Environment {
    /// World → map space.
    to_map: Mat3,
    /// Map → world space.
    to_world: Mat3,
    source: Source,
}

#[derive(Clone, Debug)]
enum Source {
    Constant(Vec3),
    Map {
        width: usize,
        height: usize,
        /// Row-major linear RGB radiance (strength applied), row 0 = zenith.
        texels: Vec<Vec3>,
        dist: Distribution2D,
        /// Mean luminance over the sphere (solid-angle weighted).
        mean_y: f32,
    },
}

impl Environment {
    /// A uniform environment of radiance `radiance` (W·sr⁻¹·m⁻², linear RGB).
    pub fn constant(radiance: Vec3) -> Environment {
        Environment {
            to_map: Mat3::IDENTITY,
            to_world: Mat3::IDENTITY,
            source: Source::Constant(radiance.max(Vec3::ZERO)),
        }
    }

    /// An equirectangular map of `width × height` row-major linear RGB texels (radiance,
    /// W·sr⁻¹·m⁻², after multiplying by `strength`), turned by `rotate_deg` about +y. Returns
    /// `None` when the map is empty, has a size mismatch, or is black everywhere.
    pub fn from_map(
        width: usize,
        height: usize,
        rgb: &[Vec3],
        strength: f32,
        rotate_deg: f32,
    ) -> Option<Environment> {
        if width == 0 || height == 0 || rgb.len() != width * height {
            return None;
        }
        let texels: Vec<Vec3> = rgb
            .iter()
            .map(|&c| (c * strength).max(Vec3::ZERO))
            .collect();
        let y: Vec<f32> = texels.iter().map(|&c| luminance(c)).collect();
        let mut weights = vec![0f32; width * height];
        let mut sum_y = 0f64;
        let mut sum_w = 0f64;
        for r in 0..height {
            let sin_t = row_solid_angle(r, height);
            for c in 0..width {
                let mut m = 0f32;
                for dr in [-1i64, 0, 1] {
                    let rr = (r as i64 + dr).clamp(0, height as i64 - 1) as usize;
                    for dc in [-1i64, 0, 1] {
                        let cc = (c as i64 + dc).rem_euclid(width as i64) as usize;
                        m = m.max(y[rr * width + cc]);
                    }
                }
                weights[r * width + c] = m * sin_t;
                sum_y += (y[r * width + c] * sin_t) as f64;
                sum_w += sin_t as f64;
            }
        }
        let dist = Distribution2D::new(&weights, width, height)?;
        let to_world = Mat3::from_rotation_y(rotate_deg.to_radians());
        Some(Environment {
            to_map: to_world.transpose(),
            to_world,
            source: Source::Map {
                width,
                height,
                texels,
                dist,
                mean_y: (sum_y / sum_w) as f32,
            },
        })
    }

    /// Mean luminance over the sphere of directions (for choosing among lights by power).
    pub fn mean_luminance(&self) -> f32 {
        match &self.source {
            Source::Constant(c) => luminance(*c),
            Source::Map { mean_y, .. } => *mean_y,
        }
    }

    /// Largest radiance of any direction, per channel.
    pub fn max_radiance(&self) -> Vec3 {
        match &self.source {
            Source::Constant(c) => *c,
            Source::Map { texels, .. } => texels.iter().fold(Vec3::ZERO, |a, &t| a.max(t)),
        }
    }

    /// (u, v) of a unit world direction.
    #[inline]
    fn uv(&self, d: Vec3) -> Vec2 {
        let m = self.to_map * d;
        let mut u = m.x.atan2(-m.z) * (0.5 / PI);
        if u < 0.0 {
            u += 1.0;
        }
        let v = m.y.clamp(-1.0, 1.0).acos() / PI;
        Vec2::new(
            u.min(1.0 - f32::EPSILON / 2.0),
            v.min(1.0 - f32::EPSILON / 2.0),
        )
    }

    /// Unit world direction of (u, v), and sin θ.
    #[cfg(test)]
    fn direction(&self, p: Vec2) -> (Vec3, f32) {
        let (phi, theta) = (2.0 * PI * p.x, PI * p.y);
        let (sp, cp) = phi.sin_cos();
        let (st, ct) = theta.sin_cos();
        (self.to_world * Vec3::new(st * sp, ct, -st * cp), st)
    }

    /// Radiance arriving from world direction `d` (unit; pointing away from the receiver).
    #[inline]
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        match &self.source {
            Source::Constant(c) => *c,
            Source::Map {
                width,
                height,
                texels,
                ..
            } => {
                let uv = self.uv(d);
                let x = uv.x * *width as f32 - 0.5;
                let y = uv.y * *height as f32 - 0.5;
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = (x - x0, y - y0);
                let (w, h) = (*width as i64, *height as i64);
                let t = |dx: i64, dy: i64| {
                    let cx = (x0 as i64 + dx).rem_euclid(w) as usize;
                    let cy = (y0 as i64 + dy).clamp(0, h - 1) as usize;
                    texels[cy * *width + cx]
                };
                (t(0, 0) * (1.0 - fx) + t(1, 0) * fx) * (1.0 - fy)
                    + (t(0, 1) * (1.0 - fx) + t(1, 1) * fx) * fy
            }
        }
    }

    /// Samples a direction: (unit world direction, radiance, solid-angle pdf). `None` only for
    /// a degenerate sample at a pole.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        match &self.source {
            Source::Constant(c) => {
                let d = crate::sampling::square_to_uniform_sphere(u);
                Some((d, *c, 0.25 / PI))
            }
            Source::Map { dist, height, .. } => {
                let (p, pdf_uv) = dist.sample(u);
                // Within its row, a texel is sampled uniformly in cos θ (equal solid angle), so
                // the density is constant over the texel: p(ω) = p(u, v) / (2π h Δcos θ).
                let h = *height;
                let y = p.y * h as f32;
                let r = (y as usize).min(h - 1);
                let t = (y - r as f32).clamp(0.0, 1.0);
                let c0 = (PI * r as f32 / h as f32).cos();
                let cos_t = (c0 - t * row_solid_angle(r, h)).clamp(-1.0, 1.0);
                let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
                let phi = 2.0 * PI * p.x;
                let (sp, cp) = phi.sin_cos();
                let d = self.to_world * Vec3::new(sin_t * sp, cos_t, -sin_t * cp);
                let pdf = pdf_uv / (2.0 * PI * h as f32 * row_solid_angle(r, h));
                if pdf.is_nan() || pdf <= 0.0 {
                    return None;
                }
                Some((d, self.radiance(d), pdf))
            }
        }
    }

    /// Solid-angle density with which [`Environment::sample`] picks world direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        match &self.source {
            Source::Constant(_) => 0.25 / PI,
            Source::Map { dist, height, .. } => {
                let uv = self.uv(d);
                let r = ((uv.y * *height as f32) as usize).min(height - 1);
                dist.density(uv) / (2.0 * PI * *height as f32 * row_solid_angle(r, *height))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chi2::chi2_test;
    use crate::rng::Rng;

    pub(super) fn random_map(w: usize, h: usize, seed: u64) -> Vec<Vec3> {
        let mut rng = Rng::new(seed, 7);
        (0..w * h)
            .map(|i| {
                // A few bright texels among dim ones, and a black band.
                let base = if i % 13 == 0 { 20.0 } else { 1.0 };
                let row = i / w;
                let k = if row == h / 3 { 0.0 } else { base };
                Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * k
            })
            .collect()
    }

    #[test]
    fn mapping_follows_mitsuba_and_round_trips() {
        let env = Environment::constant(Vec3::ONE);
        // Zenith is v = 0; u = ½ looks along +z; u = 0 along −z.
        assert!(env.uv(Vec3::Y).y < 1e-6);
        assert!((env.uv(Vec3::Z).x - 0.5).abs() < 1e-6);
        assert!(env.uv(-Vec3::Z).x < 1e-6);
        assert!((env.uv(Vec3::X).x - 0.25).abs() < 1e-6);
        let mut rng = Rng::new(4, 4);
        let rot = Environment::from_map(8, 4, &[Vec3::ONE; 32], 1.0, 37.0).unwrap();
        for _ in 0..1000 {
            let p = rng.uniform2();
            let (d, _) = rot.direction(p);
            assert!((d.length() - 1.0).abs() < 1e-5);
            let back = rot.uv(d);
            let du = (back.x - p.x).abs();
            assert!(du.min(1.0 - du) < 1e-4 && (back.y - p.y).abs() < 1e-4);
        }
    }

    #[test]
    fn map_sampling_matches_pdf_chi2() {
        for (rot, seed) in [(0.0, 1), (73.0, 2)] {
            let env = Environment::from_map(24, 12, &random_map(24, 12, seed), 1.0, rot).unwrap();
            let r = chi2_test(
                &format!("env-{rot}"),
                400_000,
                seed,
                |_, u| env.sample(u).map(|s| s.0),
                |w| env.pdf(w),
            );
            // Significance 0.001: over eight map/sample seeds the p-values were 0.013–0.80,
            // while a wrong density fails by far (sampling by rows but claiming a per-texel
            // constant density gave p = 2e-91).
            assert!(r.p_value > 0.001, "{r:?}");
            assert!((r.pdf_integral - 1.0).abs() < 1e-3, "{r:?}");
        }
    }

    #[test]
    fn sampled_radiance_and_pdf_agree_with_lookups() {
        let env = Environment::from_map(16, 8, &random_map(16, 8, 3), 2.5, 10.0).unwrap();
        let mut rng = Rng::new(5, 5);
        // ∫ L dω by importance sampling equals the same integral by uniform sampling.
        let (mut is, mut us) = (0f64, 0f64);
        let n = 200_000;
        for _ in 0..n {
            if let Some((d, l, pdf)) = env.sample(rng.uniform2()) {
                assert!((l - env.radiance(d)).abs().max_element() < 1e-4);
                assert!((pdf - env.pdf(d)).abs() <= 1e-3 * pdf);
                is += (luminance(l) / pdf) as f64;
            }
            let d = crate::sampling::square_to_uniform_sphere(rng.uniform2());
            us += (luminance(env.radiance(d)) * 4.0 * PI) as f64;
        }
        let (is, us) = (is / n as f64, us / n as f64);
        assert!((is / us - 1.0).abs() < 0.02, "{is} vs {us}");
        // The mean luminance is that integral over 4π (to texel quadrature accuracy).
        assert!((env.mean_luminance() as f64 * 4.0 * PI as f64 / us - 1.0).abs() < 0.05);
    }
}
