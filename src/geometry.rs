//! Triangle geometry and ray intersection through an obvhs compressed wide BVH (CWBVH,
//! Ylitie et al. 2017, built with PLOC by Meister & Bittner 2018).

use glam::{Vec2, Vec3, Vec3A};
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray as BvhRay, RayHit};
use obvhs::triangle::Triangle as BvhTriangle;
use std::time::Duration;

/// A ray with origin `o`, unit direction `d`, valid for t in (0, `t_max`).
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin (world space).
    pub o: Vec3,
    /// Direction (world space, unit length).
    pub d: Vec3,
    /// Largest valid distance.
    pub t_max: f32,
}

/// Per-triangle shading attributes, indexed by triangle id.
#[derive(Clone, Copy, Debug)]
pub struct TriangleAttributes {
    /// Vertex positions.
    pub p: [Vec3; 3],
    /// Per-vertex shading normals (unit), if the mesh has them.
    pub n: Option<[Vec3; 3]>,
    /// Per-vertex texture coordinates (zero when the mesh has none).
    pub uv: [Vec2; 3],
    /// Material index.
    pub material: u32,
    /// Index into the scene's emitter list, or `u32::MAX` when the triangle does not emit.
    pub light: u32,
}

impl TriangleAttributes {
    /// Unit geometric normal from the winding (v1 − v0) × (v2 − v0).
    #[inline]
    pub fn geometric_normal(&self) -> Vec3 {
        (self.p[1] - self.p[0])
            .cross(self.p[2] - self.p[0])
            .normalize_or_zero()
    }

    /// Surface area.
    #[inline]
    pub fn area(&self) -> f32 {
        0.5 * (self.p[1] - self.p[0])
            .cross(self.p[2] - self.p[0])
            .length()
    }
}

/// A ray–surface intersection.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f32,
    /// Position.
    pub p: Vec3,
    /// Unit geometric normal from the winding (not flipped towards the ray).
    pub ng: Vec3,
    /// Unit shading normal, on the same side as `ng`.
    pub ns: Vec3,
    /// Texture coordinates.
    pub uv: Vec2,
    /// Triangle id.
    pub tri: u32,
}

/// Intersection data laid out in BVH leaf order: first vertex and two edges.
#[derive(Clone, Copy)]
struct IsectTri {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
}

impl IsectTri {
    /// Möller–Trumbore (1997); returns (t, b1, b2) for t in (0, t_max).
    #[inline(always)]
    fn intersect(&self, o: Vec3A, d: Vec3A, t_max: f32) -> Option<(f32, f32, f32)> {
        let pvec = d.cross(self.e2);
        let det = self.e1.dot(pvec);
        if det.abs() < 1e-12 {
            return None;
        }
        let inv = 1.0 / det;
        let tvec = o - self.v0;
        let b1 = tvec.dot(pvec) * inv;
        if !(0.0..=1.0).contains(&b1) {
            return None;
        }
        let qvec = tvec.cross(self.e1);
        let b2 = d.dot(qvec) * inv;
        if b2 < 0.0 || b1 + b2 > 1.0 {
            return None;
        }
        let t = self.e2.dot(qvec) * inv;
        if t > 0.0 && t < t_max {
            Some((t, b1, b2))
        } else {
            None
        }
    }
}

/// All triangles of a scene with their BVH.
pub struct Geometry {
    bvh: CwBvh,
    /// Intersection records in BVH slot order.
    isect: Vec<IsectTri>,
    /// BVH slot → triangle id.
    slot_to_tri: Vec<u32>,
    /// Attributes by triangle id.
    pub tris: Vec<TriangleAttributes>,
    /// Time spent building the BVH.
    pub build_time: Duration,
}

impl Geometry {
    /// Builds the BVH over `tris` (at least one triangle; degenerate ones are kept but never
    /// hit).
    pub fn new(tris: Vec<TriangleAttributes>) -> Geometry {
        let start = std::time::Instant::now();
        let bvh_tris: Vec<BvhTriangle> = tris
            .iter()
            .map(|t| BvhTriangle {
                v0: t.p[0].into(),
                v1: t.p[1].into(),
                v2: t.p[2].into(),
            })
            .collect();
        let mut core = Duration::default();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &bvh_tris,
            obvhs::BvhBuildParams::medium_build(),
            &mut core,
        );
        let slot_to_tri = bvh.primitive_indices.clone();
        let isect = slot_to_tri
            .iter()
            .map(|&i| {
                let t = &tris[i as usize];
                IsectTri {
                    v0: t.p[0].into(),
                    e1: (t.p[1] - t.p[0]).into(),
                    e2: (t.p[2] - t.p[0]).into(),
                }
            })
            .collect();
        Geometry {
            bvh,
            isect,
            slot_to_tri,
            tris,
            build_time: start.elapsed(),
        }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Closest intersection along `ray`, if any.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let o: Vec3A = ray.o.into();
        let d: Vec3A = ray.d.into();
        let bray = BvhRay::new(o, d, 0.0, ray.t_max);
        let mut hit = RayHit::none();
        let mut bary = (0.0f32, 0.0f32);
        let found = self.bvh.ray_traverse(bray, &mut hit, |r, slot| {
            match self.isect[slot].intersect(o, d, r.tmax) {
                Some((t, b1, b2)) => {
                    bary = (b1, b2);
                    t
                }
                None => f32::INFINITY,
            }
        });
        if !found {
            return None;
        }
        // The closure only reports hits closer than the current closest, and traversal accepts
        // every one it reports, so `bary` belongs to the final (closest) hit.
        let slot = hit.primitive_id as usize;
        let (t, b1, b2) = (hit.t, bary.0, bary.1);
        let tri = self.slot_to_tri[slot];
        let a = &self.tris[tri as usize];
        let b0 = 1.0 - b1 - b2;
        let p = a.p[0] * b0 + a.p[1] * b1 + a.p[2] * b2;
        let ng = a.geometric_normal();
        let ns = match a.n {
            Some(n) => {
                let s = (n[0] * b0 + n[1] * b1 + n[2] * b2).normalize_or_zero();
                if s == Vec3::ZERO {
                    ng
                } else if s.dot(ng) < 0.0 {
                    -s
                } else {
                    s
                }
            }
            None => ng,
        };
        let uv = a.uv[0] * b0 + a.uv[1] * b1 + a.uv[2] * b2;
        Some(Hit {
            t,
            p,
            ng,
            ns,
            uv,
            tri,
        })
    }

    /// True when nothing blocks the segment from `o` along unit `d` up to distance `t_max`.
    #[inline]
    pub fn unoccluded(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        let o: Vec3A = o.into();
        let d: Vec3A = d.into();
        let bray = BvhRay::new(o, d, 0.0, t_max);
        self.bvh.ray_traverse_miss(bray, |r, slot| {
            match self.isect[slot].intersect(o, d, r.tmax) {
                Some((t, _, _)) => t,
                None => f32::INFINITY,
            }
        })
    }
}

/// Offsets a point off a surface along the geometric normal `ng`, towards the side of `w`, by
/// a distance proportional to the point's magnitude (a conservative bound on f32 rounding of
/// the intersection, after pbrt-v4's `OffsetRayOrigin` in spirit).
#[inline]
pub fn offset_origin(p: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    let eps = 1e-4 + 2e-5 * p.abs().max_element();
    if w.dot(ng) >= 0.0 {
        p + ng * eps
    } else {
        p - ng * eps
    }
}
