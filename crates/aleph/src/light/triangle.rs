//! Emissive triangles: one-sided diffuse area emitters (MTL `Ke`, `[[light]]` quads), sampled
//! uniformly by area and converted to solid angle at the receiver: pdf_ω = pdf_A · d² / |cos θ_l|
//! (Veach 1997, eq. 8.10).

use super::{LightBounds, LightSample};
use crate::geometry::{Geometry, STATIC_INSTANCE, Triangles};
use crate::material::Material;
use crate::sampling::square_to_uniform_triangle;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// A triangle's world vertices, unit normal (from the winding) and area.
pub type TriangleShape = ([Vec3; 3], Vec3, f32);

/// An emissive triangle of the scene's geometry.
#[derive(Clone, Debug)]
pub struct TriangleLight {
    /// The triangle's index in the geometry.
    pub tri: u32,
    /// Its shape when it does not move (`None` for a moving one, computed at each time).
    shape: Option<TriangleShape>,
}

/// A triangle's vertices, unit normal (from the winding) and area.
#[inline]
fn triangle_shape(v: [Vec3; 3]) -> TriangleShape {
    let cross = (v[1] - v[0]).cross(v[2] - v[0]);
    (
        v,
        crate::math::robust_normalize(cross),
        0.5 * crate::math::robust_length(cross),
    )
}

impl TriangleLight {
    /// Triangle `tri` of `tris` as a light (its shape stored if it is static).
    pub(super) fn new(tris: &Triangles, tri: u32) -> TriangleLight {
        let i = tri as usize;
        TriangleLight {
            tri,
            shape: (tris.instance(i) == STATIC_INSTANCE).then(|| triangle_shape(tris.positions(i))),
        }
    }

    /// World vertices, unit normal and area at scene time `time`.
    #[inline]
    pub fn shape(&self, geo: &Geometry, time: f32) -> TriangleShape {
        match self.shape {
            Some(s) => s,
            None => triangle_shape(geo.world_vertices(self.tri, time)),
        }
    }

    /// Bounds for the light BVH with relative power `phi`. A moving emitter's triangle is in
    /// rest space: any direction, any nearby place, importance never zero (unbiased, if less
    /// sharp).
    pub(super) fn bounds(&self, tris: &Triangles, phi: f32) -> LightBounds {
        let t = tris.get(self.tri as usize);
        let moving = t.instance != STATIC_INSTANCE;
        LightBounds {
            lo: t.p[0].min(t.p[1]).min(t.p[2]),
            hi: t.p[0].max(t.p[1]).max(t.p[2]),
            phi,
            w: t.geometric_normal(),
            cos_o: if moving { -1.0 } else { 1.0 },
            cos_e: if moving { -1.0 } else { 0.0 },
            two_sided: false,
        }
    }

    /// Next-event sample from `p_ref` at scene time `time`: a point uniform in area from the
    /// 2-D number `u`, the light chosen with probability `pmf`. `None` for a degenerate or
    /// grazing configuration, or when `p_ref` is behind the emitter.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(super) fn sample_from(
        &self,
        pmf: f32,
        p_ref: Vec3,
        u: Vec2,
        time: f32,
        geo: &Geometry,
        materials: &[Material],
        textures: &[Texture],
    ) -> Option<LightSample> {
        let tri = self.tri;
        let (v, n, area) = self.shape(geo, time);
        let b = square_to_uniform_triangle(u);
        let b0 = 1.0 - b.x - b.y;
        let p = v[0] * b.x + v[1] * b.y + v[2] * b0;
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
        let (uvs, material) = (geo.tris.uvs(tri as usize), geo.tris.material(tri as usize));
        let uv = uvs[0] * b.x + uvs[1] * b.y + uvs[2] * b0;
        let le =
            materials[material as usize].emitted(uv, crate::texture::Footprint::POINT, textures);
        let pdf = pmf / area * dist2 / cos_l;
        Some(LightSample {
            p,
            n,
            le,
            wi,
            dist,
            pdf,
            delta: false,
            on_surface: true,
        })
    }

    /// What converts the choice probability into the solid-angle pdf of point `p_light` seen
    /// from `p_ref` at time `time`: (area, d², cos θ_l), or `None` where the pdf is 0 (behind,
    /// grazing, degenerate).
    #[inline]
    pub(super) fn area_to_solid_angle(
        &self,
        geo: &Geometry,
        time: f32,
        p_ref: Vec3,
        p_light: Vec3,
    ) -> Option<(f32, f32, f32)> {
        let (_, n, area) = self.shape(geo, time);
        let d = p_light - p_ref;
        let dist2 = d.length_squared();
        let cos_l = (-d.dot(n) / dist2.sqrt()).max(0.0);
        if cos_l <= 1e-7 || area <= 0.0 {
            return None;
        }
        Some((area, dist2, cos_l))
    }
}
