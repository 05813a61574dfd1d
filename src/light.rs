//! Area lights: every emissive triangle is a one-sided diffuse emitter.
//!
//! Next-event estimation picks a triangle with probability proportional to its emitted power
//! (luminance of the mean emitted radiance × area × π; any positive weight keeps the estimator
//! unbiased, power makes it efficient), samples a point uniformly on it (area pdf 1/A) and
//! converts to solid angle at the receiver: pdf_ω = pdf_A · d² / |cos θ_l| (Veach 1997 eq. 8.10).

use crate::geometry::{Geometry, TriangleAttributes};
use crate::material::Material;
use crate::sampling::{Distribution1D, square_to_uniform_triangle};
use crate::texture::Texture;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A point sampled on a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Point on the emitter.
    pub p: Vec3,
    /// Unit geometric normal of the emitter (its emitting side).
    pub n: Vec3,
    /// Emitted radiance towards the receiver (W·sr⁻¹·m⁻²), zero if the receiver is behind.
    pub le: Vec3,
    /// Unit direction from the receiver to `p`.
    pub wi: Vec3,
    /// Distance from the receiver to `p`.
    pub dist: f32,
    /// Solid-angle pdf at the receiver (includes the choice of triangle).
    pub pdf: f32,
}

/// The scene's emitters and the distribution used to choose among them.
#[derive(Clone, Debug)]
pub struct Lights {
    /// Triangle id of each emitter.
    pub tris: Vec<u32>,
    dist: Distribution1D,
}

impl Lights {
    /// Collects emissive triangles and assigns `light` indices into `tris`. Returns `None` if
    /// nothing emits (or all emitters have zero area).
    pub fn build(
        tris: &mut [TriangleAttributes],
        materials: &[Material],
        textures: &[Texture],
    ) -> Option<Lights> {
        let mut ids = Vec::new();
        let mut powers: Vec<(f32, f64)> = Vec::new();
        for (i, t) in tris.iter_mut().enumerate() {
            t.light = u32::MAX;
            let m = &materials[t.material as usize];
            let Some(e) = &m.emission else { continue };
            let y = crate::math::luminance(e.mean(textures).max(Vec3::ZERO));
            let p32 = y * t.area() * PI;
            // Also in f64: the power of a bright, large emitter overflows f32 and that of a
            // faint, tiny one underflows it; such lights must not silently vanish.
            let p64 = y as f64 * t.area() as f64 * std::f64::consts::PI;
            if p64 > 0.0 && p64.is_finite() {
                t.light = ids.len() as u32;
                ids.push(i as u32);
                powers.push((p32, p64));
            }
        }
        let f32_ok = powers.iter().all(|&(p, _)| p > 0.0 && p.is_finite());
        let weights: Vec<f32> = if f32_ok {
            powers.iter().map(|&(p, _)| p).collect()
        } else {
            // Relative weights, which f32 holds whatever the absolute scale.
            let max = powers.iter().map(|&(_, p)| p).fold(0.0, f64::max);
            powers
                .iter()
                .map(|&(_, p)| ((p / max) as f32).max(f32::MIN_POSITIVE))
                .collect()
        };
        let dist = Distribution1D::new(weights)?;
        Some(Lights { tris: ids, dist })
    }

    /// Number of emissive triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when there are no emitters (never for a built set).
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Total emitted power weight (relative units; for statistics).
    pub fn total_power(&self) -> f64 {
        self.dist.total()
    }

    /// Samples a point on an emitter as seen from `p_ref` at scene time `time` (moving
    /// emitters are where they are then). `uc` chooses the triangle, `u` the point. Returns
    /// `None` for a degenerate configuration (zero distance or grazing).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn sample(
        &self,
        p_ref: Vec3,
        uc: f32,
        u: Vec2,
        time: f32,
        geo: &Geometry,
        materials: &[Material],
        textures: &[Texture],
    ) -> Option<LightSample> {
        let (li, pmf) = self.dist.sample(uc);
        let tri = self.tris[li];
        let t = &geo.tris[tri as usize];
        let v = geo.world_vertices(tri, time);
        let b = square_to_uniform_triangle(u);
        let b0 = 1.0 - b.x - b.y;
        let p = v[0] * b.x + v[1] * b.y + v[2] * b0;
        let cross = (v[1] - v[0]).cross(v[2] - v[0]);
        let n = crate::math::robust_normalize(cross);
        let area = 0.5 * crate::math::robust_length(cross);
        let d = p - p_ref;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 || area <= 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        let cos_l = -wi.dot(n);
        if cos_l <= 1e-7 {
            return None; // back of a one-sided emitter, or grazing
        }
        let uv = t.uv[0] * b.x + t.uv[1] * b.y + t.uv[2] * b0;
        let le = materials[t.material as usize].emitted(uv, textures);
        let pdf = pmf / area * dist2 / cos_l;
        Some(LightSample {
            p,
            n,
            le,
            wi,
            dist,
            pdf,
        })
    }

    /// Solid-angle pdf with which [`Lights::sample`] would pick point `p_light` on emitter
    /// triangle `tri` (whose `light` index is set) from `p_ref` at scene time `time`.
    #[inline]
    pub fn pdf(&self, geo: &Geometry, tri: u32, time: f32, p_ref: Vec3, p_light: Vec3) -> f32 {
        let light = geo.tris[tri as usize].light;
        if light == u32::MAX {
            return 0.0;
        }
        let v = geo.world_vertices(tri, time);
        let cross = (v[1] - v[0]).cross(v[2] - v[0]);
        let n = crate::math::robust_normalize(cross);
        let area = 0.5 * crate::math::robust_length(cross);
        let d = p_light - p_ref;
        let dist2 = d.length_squared();
        let cos_l = (-d.dot(n) / dist2.sqrt()).max(0.0);
        if cos_l <= 1e-7 || area <= 0.0 {
            return 0.0;
        }
        self.dist.pmf(light as usize) / area * dist2 / cos_l
    }
}
