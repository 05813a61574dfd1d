//! Triangle geometry and ray intersection through four-wide BVHs ([`crate::bvh`]: obvhs' PLOC
//! build by Meister & Bittner 2018, collapsed to four children per node, four triangles per
//! SIMD test).
//!
//! Two levels: the static triangles of a scene sit in one BVH in world space, exactly as in a
//! still; every mesh with keyframed motion has a BVH of its own in its rest space (built once)
//! and is an [`Instance`] whose world-space box covers its motion over the whole animation. A
//! ray at time t enters an instance whose box it crosses by the inverse of the instance's
//! transform at t ([`TransformTrack::at`]); distances along the ray are the same in both spaces
//! because the transformed direction is not renormalised.

use crate::animation::TransformTrack;
use crate::bvh::Bvh;
use glam::{Affine3A, Vec2, Vec3, Vec3A};
use std::time::Duration;

/// A ray with origin `o`, unit direction `d`, valid for t in (0, `t_max`), at scene time
/// `time`.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin (world space).
    pub o: Vec3,
    /// Direction (world space, unit length).
    pub d: Vec3,
    /// Largest valid distance.
    pub t_max: f32,
    /// Scene time, seconds: moving geometry is intersected where it is at this time.
    pub time: f32,
}

/// `TriangleAttributes::instance` of a static triangle (world space).
pub const STATIC_INSTANCE: u32 = u32::MAX;

/// One triangle's shading attributes, as [`Triangles`] stores and returns them.
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
    /// The moving instance the triangle belongs to (its `p` and `n` are then in the instance's
    /// rest space), or [`STATIC_INSTANCE`] (world space).
    pub instance: u32,
}

impl TriangleAttributes {
    /// Unit geometric normal from the winding (v1 − v0) × (v2 − v0).
    #[inline]
    pub fn geometric_normal(&self) -> Vec3 {
        crate::math::robust_normalize((self.p[1] - self.p[0]).cross(self.p[2] - self.p[0]))
    }

    /// Surface area.
    #[inline]
    pub fn area(&self) -> f32 {
        0.5 * crate::math::robust_length((self.p[1] - self.p[0]).cross(self.p[2] - self.p[0]))
    }
}

/// The scene's triangles, by id: each one's attributes as a [`TriangleAttributes`], stored in
/// 56 bytes instead of that struct's 112: positions, material, light and instance inline,
/// per-vertex normals and texture coordinates out of line, only for triangles that have them
/// (a mesh without normals or coordinates, such as a 1M-triangle heightfield, takes 56 MB
/// instead of 112). [`Triangles::get`] returns exactly what was pushed.
#[derive(Clone, Debug)]
pub struct Triangles {
    stored: Vec<StoredTriangle>,
    normals: Vec<[Vec3; 3]>,
    /// Entry 0 is all zero: the coordinates of every triangle without its own, so that a
    /// lookup needs no branch.
    uvs: Vec<[Vec2; 3]>,
}

impl Default for Triangles {
    fn default() -> Triangles {
        Triangles {
            stored: Vec::new(),
            normals: Vec::new(),
            uvs: vec![[Vec2::ZERO; 3]],
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct StoredTriangle {
    p: [Vec3; 3],
    material: u32,
    light: u32,
    instance: u32,
    /// Index into `normals`, or [`ABSENT`].
    n: u32,
    /// Index into `uvs`: 0 when all three coordinates are zero.
    uv: u32,
}

/// No out-of-line attribute.
const ABSENT: u32 = u32::MAX;

impl Triangles {
    /// Reserves room for `n` more triangles, with room for their normals and texture
    /// coordinates where the flags say they have them (one allocation per array instead of a
    /// doubling series, whose freed blocks the allocator would keep).
    pub fn reserve(&mut self, n: usize, normals: bool, uvs: bool) {
        self.stored.reserve(n);
        if normals {
            self.normals.reserve(n);
        }
        if uvs {
            self.uvs.reserve(n);
        }
    }

    /// Appends a triangle; its id is the previous [`Triangles::len`].
    ///
    /// # Panics
    /// With 2³² − 1 triangles having normals or texture coordinates.
    pub fn push(&mut self, t: TriangleAttributes) {
        // The index the next entry of an out-of-line array of `len` entries gets.
        let next = |len: usize| -> u32 {
            u32::try_from(len)
                .ok()
                .filter(|&i| i != ABSENT)
                .expect("fewer than 2^32 - 1 triangles with normals or coordinates")
        };
        let n = match t.n {
            Some(normals) => {
                let i = next(self.normals.len());
                self.normals.push(normals);
                i
            }
            None => ABSENT,
        };
        let uv = if t.uv == [Vec2::ZERO; 3] {
            0
        } else {
            let i = next(self.uvs.len());
            self.uvs.push(t.uv);
            i
        };
        self.stored.push(StoredTriangle {
            p: t.p,
            material: t.material,
            light: t.light,
            instance: t.instance,
            n,
            uv,
        });
    }

    /// Triangle `i`'s attributes.
    ///
    /// # Panics
    /// If `i` is out of range.
    #[inline]
    pub fn get(&self, i: usize) -> TriangleAttributes {
        let s = &self.stored[i];
        TriangleAttributes {
            p: s.p,
            n: (s.n != ABSENT).then(|| self.normals[s.n as usize]),
            uv: self.uvs(i),
            material: s.material,
            light: s.light,
            instance: s.instance,
        }
    }

    /// Triangle `i`'s vertex positions.
    #[inline]
    pub fn positions(&self, i: usize) -> [Vec3; 3] {
        self.stored[i].p
    }

    /// Triangle `i`'s per-vertex texture coordinates (zero when it has none).
    #[inline]
    pub fn uvs(&self, i: usize) -> [Vec2; 3] {
        self.uvs[self.stored[i].uv as usize]
    }

    /// Triangle `i`'s material index.
    #[inline]
    pub fn material(&self, i: usize) -> u32 {
        self.stored[i].material
    }

    /// Triangle `i`'s instance ([`STATIC_INSTANCE`] when it does not move).
    #[inline]
    pub fn instance(&self, i: usize) -> u32 {
        self.stored[i].instance
    }

    /// Triangle `i`'s emitter index (`u32::MAX` when it does not emit).
    #[inline]
    pub fn light(&self, i: usize) -> u32 {
        self.stored[i].light
    }

    /// Sets triangle `i`'s emitter index.
    pub fn set_light(&mut self, i: usize, light: u32) {
        self.stored[i].light = light;
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.stored.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.stored.is_empty()
    }
}

impl From<Vec<TriangleAttributes>> for Triangles {
    fn from(v: Vec<TriangleAttributes>) -> Triangles {
        let mut t = Triangles::default();
        t.reserve(v.len(), true, true);
        for a in v {
            t.push(a);
        }
        t
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

/// A mesh in rigid (keyframed) motion: its BVH in rest space, its transform over time, and a
/// world-space box that covers it over the animation's time range.
pub struct Instance {
    /// Rest space → world space over time.
    pub track: TransformTrack,
    blas: Bvh,
    bounds_min: Vec3A,
    bounds_max: Vec3A,
    /// Rest-space bounds of its triangles.
    rest: (Vec3, Vec3),
}

impl Instance {
    /// Parametric entry distance of the ray into the instance's box, if it enters it before
    /// `t_max` (slab test; `inv_d` = 1/d).
    #[inline]
    fn enters(&self, o: Vec3A, inv_d: Vec3A, t_max: f32) -> bool {
        let t0 = (self.bounds_min - o) * inv_d;
        let t1 = (self.bounds_max - o) * inv_d;
        let near = t0.min(t1).max_element().max(0.0);
        let far = t0.max(t1).min_element().min(t_max);
        near <= far
    }
}

/// World-space box covering rest-space box [`lo`, `hi`] under `track` over [`t0`, `t1`]:
/// the union of the box's transformed corners at 256 uniform times and every key time in the
/// range, padded by the largest distance any corner moves between consecutive times (which
/// bounds how far the interpolated path strays from the sampled points).
fn motion_bounds(track: &TransformTrack, lo: Vec3, hi: Vec3, t0: f32, t1: f32) -> (Vec3A, Vec3A) {
    const SAMPLES: usize = 256;
    let mut times: Vec<f32> = (0..=SAMPLES)
        .map(|k| t0 + (t1 - t0) * k as f32 / SAMPLES as f32)
        .chain(
            track
                .keys()
                .iter()
                .map(|k| k.time_s)
                .filter(|&t| t > t0 && t < t1),
        )
        .collect();
    times.sort_by(f32::total_cmp);
    let corners: Vec<Vec3> = (0..8)
        .map(|c| {
            Vec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            )
        })
        .collect();
    let (mut bmin, mut bmax) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let mut pad = 0.0f32;
    let mut prev: Option<Vec<Vec3>> = None;
    for &t in &times {
        let m = track.at(t);
        let now: Vec<Vec3> = corners.iter().map(|&c| m.transform_point3(c)).collect();
        for &p in &now {
            bmin = bmin.min(p);
            bmax = bmax.max(p);
        }
        if let Some(prev) = &prev {
            for (a, b) in prev.iter().zip(&now) {
                pad = pad.max(a.distance(*b));
            }
        }
        prev = Some(now);
    }
    let pad = pad + 1e-4 * bmin.abs().max(bmax.abs()).max_element().max(1.0);
    ((bmin - pad).into(), (bmax + pad).into())
}

/// One thread's instance poses ([`Geometry::pose`]): each instance's transform and inverse at
/// one time, for one geometry (its `id`: a geometry dropped and another built at the same
/// address is not taken for it). Filled as the instances are asked for; the same values as
/// computed afresh, so renders do not depend on which thread asked first.
struct Poses {
    geometry: u64,
    /// The time's bits (`u32::MAX`, a NaN's, before the first).
    time: u32,
    poses: Vec<Option<(Affine3A, Affine3A)>>,
}

thread_local! {
    static POSES: std::cell::RefCell<Poses> = const {
        std::cell::RefCell::new(Poses {
            geometry: u64::MAX,
            time: u32::MAX,
            poses: Vec::new(),
        })
    };
}

/// All triangles of a scene with their BVHs.
pub struct Geometry {
    /// This geometry's number among those built in the process ([`Poses`]).
    id: u64,
    /// The static triangles' BVH (world space), if there are any.
    stat: Option<Bvh>,
    /// Moving meshes.
    instances: Vec<Instance>,
    /// Attributes by triangle id.
    pub tris: Triangles,
    /// Time spent building the BVHs.
    pub build_time: Duration,
    /// Alpha cut-outs, if any material has one.
    cutouts: Option<Cutouts>,
    /// Bit i of word i / 64: whether triangle i's material has a cut-out mask (empty without
    /// cut-outs). Every candidate hit asks, and a bit per triangle stays in cache where the
    /// triangles' materials (4 bytes each, 0.9 MB on Lost Empire) do not.
    cut_tris: Vec<u64>,
}

/// A single-channel coverage mask (MTL `map_d`): texels in [0, 1], row 0 at the top, looked up
/// bilinearly with repeat wrapping and tested against ½ (an alpha test: deterministic, the same
/// for camera and shadow rays).
#[derive(Clone, Debug)]
pub struct AlphaMask {
    width: usize,
    height: usize,
    texels: Vec<u8>,
}

impl AlphaMask {
    /// A mask from row-major coverage values in [0, 1] (clamped). `None` for an empty or
    /// mismatched size.
    pub fn new(width: usize, height: usize, coverage: &[f32]) -> Option<AlphaMask> {
        if width == 0 || height == 0 || coverage.len() != width * height {
            return None;
        }
        let texels = coverage
            .iter()
            .map(|&a| (a.clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect();
        Some(AlphaMask {
            width,
            height,
            texels,
        })
    }

    /// True when the surface is present at texture coordinates `uv` (OBJ convention, v = 0 at
    /// the bottom): bilinear coverage ≥ ½.
    #[inline]
    pub fn covers(&self, uv: Vec2) -> bool {
        let x = uv.x.rem_euclid(1.0) * self.width as f32 - 0.5;
        let y = (1.0 - uv.y.rem_euclid(1.0)) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (w, h) = (self.width as i64, self.height as i64);
        let t = |dx: i64, dy: i64| {
            let cx = (x0 as i64 + dx).rem_euclid(w) as usize;
            let cy = (y0 as i64 + dy).rem_euclid(h) as usize;
            self.texels[cy * self.width + cx] as f32
        };
        let a = (t(0, 0) * (1.0 - fx) + t(1, 0) * fx) * (1.0 - fy)
            + (t(0, 1) * (1.0 - fx) + t(1, 1) * fx) * fy;
        a >= 127.5
    }
}

/// The cut-out masks of a scene and which material uses which.
#[derive(Clone, Debug)]
pub struct Cutouts {
    /// Mask index of each material, `u32::MAX` for an opaque one.
    pub by_material: Vec<u32>,
    /// The masks.
    pub masks: Vec<AlphaMask>,
}

impl Geometry {
    /// Builds the BVH over `tris`, all static (at least one triangle; degenerate ones are kept
    /// but never hit).
    pub fn new(tris: impl Into<Triangles>) -> Geometry {
        Geometry::with_instances(tris, Vec::new(), (0.0, 0.0))
    }

    /// Builds a two-level structure: triangles whose `instance` is [`STATIC_INSTANCE`] in one
    /// world-space BVH, the triangles of instance i (in rest space) in a BVH of their own moved
    /// by `tracks[i]`, with boxes covering the motion over `time_range` (seconds, every shutter
    /// of the sequence included). Needs at least one triangle.
    ///
    /// # Panics
    /// If a triangle names an instance without a track, or a track has no triangle.
    pub fn with_instances(
        tris: impl Into<Triangles>,
        tracks: Vec<TransformTrack>,
        time_range: (f32, f32),
    ) -> Geometry {
        let tris: Triangles = tris.into();
        let start = std::time::Instant::now();
        let mut ids: Vec<Vec<u32>> = vec![Vec::new(); tracks.len()];
        let mut static_ids = Vec::new();
        for i in 0..tris.len() {
            let inst = tris.instance(i);
            if inst == STATIC_INSTANCE {
                static_ids.push(i as u32);
            } else {
                ids[inst as usize].push(i as u32);
            }
        }
        let stat = (!static_ids.is_empty())
            .then(|| Bvh::build(&static_ids, |i| tris.positions(i as usize)));
        let instances = tracks
            .into_iter()
            .zip(ids)
            .map(|(track, ids)| {
                assert!(!ids.is_empty(), "an instance without triangles");
                let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                for &i in &ids {
                    for p in tris.positions(i as usize) {
                        lo = lo.min(p);
                        hi = hi.max(p);
                    }
                }
                let (bounds_min, bounds_max) =
                    motion_bounds(&track, lo, hi, time_range.0, time_range.1);
                Instance {
                    blas: Bvh::build(&ids, |i| tris.positions(i as usize)),
                    track,
                    bounds_min,
                    bounds_max,
                    rest: (lo, hi),
                }
            })
            .collect();
        static BUILT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        Geometry {
            id: BUILT.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            stat,
            instances,
            tris,
            build_time: start.elapsed(),
            cutouts: None,
            cut_tris: Vec::new(),
        }
    }

    /// Sets the alpha cut-outs (materials whose triangles are skipped by every ray where their
    /// mask is below ½). `None` or a set without masks makes every surface opaque.
    pub fn set_cutouts(&mut self, cutouts: Option<Cutouts>) {
        self.cutouts = cutouts.filter(|c| !c.masks.is_empty());
        self.cut_tris = match &self.cutouts {
            Some(c) => {
                let mut bits = vec![0u64; self.tris.len().div_ceil(64)];
                for i in 0..self.tris.len() {
                    let m = self.tris.material(i) as usize;
                    if c.by_material.get(m).is_some_and(|&k| k != u32::MAX) {
                        bits[i / 64] |= 1 << (i % 64);
                    }
                }
                bits
            }
            None => Vec::new(),
        };
    }

    /// True when triangle `tri` is present at barycentrics (b1, b2): always, unless its
    /// material has a cut-out mask that is below ½ there.
    #[inline]
    fn present(&self, tri: u32, b1: f32, b2: f32) -> bool {
        let Some(c) = &self.cutouts else { return true };
        let t = tri as usize;
        if self.cut_tris[t / 64] & 1 << (t % 64) == 0 {
            return true;
        }
        let m = c.by_material[self.tris.material(t) as usize];
        let uvs = self.tris.uvs(t);
        let uv = uvs[0] * (1.0 - b1 - b2) + uvs[1] * b1 + uvs[2] * b2;
        c.masks[m as usize].covers(uv)
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// True when some geometry moves.
    pub fn has_motion(&self) -> bool {
        !self.instances.is_empty()
    }

    /// The transform of triangle `tri`'s instance at `time` (`None` for a static triangle).
    #[inline]
    pub fn transform_at(&self, tri: u32, time: f32) -> Option<Affine3A> {
        self.instance_transform(self.tris.instance(tri as usize), time)
    }

    /// Instance `inst`'s transform (rest space → world) at `time`; `None` for
    /// [`STATIC_INSTANCE`].
    #[inline]
    pub fn instance_transform(&self, inst: u32, time: f32) -> Option<Affine3A> {
        (inst != STATIC_INSTANCE).then(|| self.pose(inst as usize, time).0)
    }

    /// Instance `k`'s transform at `time` and its inverse, from this thread's [`Poses`]: the
    /// rays of one path sample share its time, so a path poses each instance once instead of
    /// at every ray that enters its box (a slerp and an inverse each).
    #[inline]
    fn pose(&self, k: usize, time: f32) -> (Affine3A, Affine3A) {
        POSES.with_borrow_mut(|p| {
            if p.geometry != self.id || p.time != time.to_bits() {
                p.geometry = self.id;
                p.time = time.to_bits();
                p.poses.clear();
                p.poses.resize(self.instances.len(), None);
            }
            *p.poses[k].get_or_insert_with(|| {
                let m = self.instances[k].track.at(time);
                (m, m.inverse())
            })
        })
    }

    /// The world-space boxes of the moving instances posed at `time`: each rest box's eight
    /// corners transformed and boxed (min, max), one per instance, for [`segment_meets_boxes`].
    pub fn moving_boxes(&self, time: f32) -> Vec<(Vec3, Vec3)> {
        self.instances
            .iter()
            .map(|inst| {
                let m = inst.track.at(time);
                let (lo, hi) = inst.rest;
                let (mut bmin, mut bmax) =
                    (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                for c in 0..8 {
                    let p = Vec3::new(
                        if c & 1 == 0 { lo.x } else { hi.x },
                        if c & 2 == 0 { lo.y } else { hi.y },
                        if c & 4 == 0 { lo.z } else { hi.z },
                    );
                    let q = m.transform_point3(p);
                    bmin = bmin.min(q);
                    bmax = bmax.max(q);
                }
                (bmin, bmax)
            })
            .collect()
    }

    /// The world-space vertices of triangle `tri` at `time`.
    #[inline]
    pub fn world_vertices(&self, tri: u32, time: f32) -> [Vec3; 3] {
        let p = self.tris.positions(tri as usize);
        match self.transform_at(tri, time) {
            None => p,
            Some(m) => p.map(|p| m.transform_point3(p)),
        }
    }

    /// Closest intersection along `ray` (at `ray.time`), if any.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let o: Vec3A = ray.o.into();
        let d: Vec3A = ray.d.into();
        let mut best: Option<(u32, f32, f32, f32)> = None;
        let mut t_max = ray.t_max;
        if let Some(stat) = &self.stat
            && let Some(h) = stat.closest(o, d, t_max, |t, b1, b2| self.present(t, b1, b2))
        {
            t_max = h.1;
            best = Some(h);
        }
        let mut best_xf = None;
        if !self.instances.is_empty() {
            let inv_d = d.recip();
            for (k, inst) in self.instances.iter().enumerate() {
                if !inst.enters(o, inv_d, t_max) {
                    continue;
                }
                let (m, inv) = self.pose(k, ray.time);
                let (oi, di) = (inv.transform_point3a(o), inv.transform_vector3a(d));
                if let Some(h) = inst
                    .blas
                    .closest(oi, di, t_max, |t, b1, b2| self.present(t, b1, b2))
                {
                    t_max = h.1;
                    best = Some(h);
                    best_xf = Some(m);
                }
            }
        }
        let (tri, t, b1, b2) = best?;
        Some(self.hit(tri, t, b1, b2, best_xf.as_ref()))
    }

    /// The hit record of triangle `tri` at distance `t` and barycentrics (b1, b2), with the
    /// instance transform `xf` at the ray's time for a moving triangle.
    #[inline]
    fn hit(&self, tri: u32, t: f32, b1: f32, b2: f32, xf: Option<&Affine3A>) -> Hit {
        let a = self.tris.get(tri as usize);
        let b0 = 1.0 - b1 - b2;
        let (p, ng, n) = match xf {
            None => (a.p, a.geometric_normal(), a.n),
            Some(m) => {
                let p = a.p.map(|v| m.transform_point3(v));
                let ng = crate::math::robust_normalize((p[1] - p[0]).cross(p[2] - p[0]));
                let nm = m.matrix3.inverse().transpose();
                (
                    p,
                    ng,
                    a.n.map(|n| n.map(|v| Vec3::from(nm * Vec3A::from(v)))),
                )
            }
        };
        let pos = p[0] * b0 + p[1] * b1 + p[2] * b2;
        let ns = match n {
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
        Hit {
            t,
            p: pos,
            ng,
            ns,
            uv,
            tri,
        }
    }

    /// True when nothing blocks the segment from `o` along unit `d` up to distance `t_max` at
    /// scene time `time`.
    #[inline]
    pub fn unoccluded(&self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> bool {
        let o: Vec3A = o.into();
        let d: Vec3A = d.into();
        if let Some(stat) = &self.stat
            && !stat.unoccluded(o, d, t_max, |t, b1, b2| self.present(t, b1, b2))
        {
            return false;
        }
        if self.instances.is_empty() {
            return true;
        }
        let inv_d = d.recip();
        self.instances.iter().enumerate().all(|(k, inst)| {
            if !inst.enters(o, inv_d, t_max) {
                return true;
            }
            let inv = self.pose(k, time).1;
            inst.blas.unoccluded(
                inv.transform_point3a(o),
                inv.transform_vector3a(d),
                t_max,
                |t, b1, b2| self.present(t, b1, b2),
            )
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

/// Whether the segment from `o` to `o + d` (any length) passes through any of `boxes`
/// ((min, max) pairs, e.g. [`Geometry::moving_boxes`]; slab test).
pub fn segment_meets_boxes(boxes: &[(Vec3, Vec3)], o: Vec3, d: Vec3) -> bool {
    let inv = d.recip();
    boxes.iter().any(|&(bmin, bmax)| {
        let t0 = (bmin - o) * inv;
        let t1 = (bmax - o) * inv;
        let near = t0.min(t1).max_element().max(0.0);
        let far = t0.max(t1).min_element().min(1.0);
        near <= far
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Triangles with and without normals and texture coordinates come back exactly as pushed,
    /// in 56 bytes each plus their out-of-line attributes.
    #[test]
    fn triangles_return_what_was_pushed() {
        let v = |k: f32| Vec3::new(k, 2.0 * k, -k);
        let all: Vec<TriangleAttributes> = (0..40)
            .map(|i| {
                let k = i as f32;
                TriangleAttributes {
                    p: [v(k), v(k + 0.5), v(k + 0.25)],
                    n: (i % 3 == 0).then_some([Vec3::X, Vec3::Y, Vec3::Z]),
                    uv: if i % 4 == 1 {
                        [Vec2::new(k, 0.0), Vec2::ONE, Vec2::ZERO]
                    } else {
                        [Vec2::ZERO; 3]
                    },
                    material: i,
                    light: if i % 5 == 0 { i / 5 } else { u32::MAX },
                    instance: if i < 20 { STATIC_INSTANCE } else { 0 },
                }
            })
            .collect();
        let mut t = Triangles::default();
        t.reserve(all.len(), true, true);
        for &a in &all {
            t.push(a);
        }
        let t2 = Triangles::from(all.clone());
        assert_eq!(t.len(), all.len());
        for (i, a) in all.iter().enumerate() {
            for got in [t.get(i), t2.get(i)] {
                assert_eq!(format!("{got:?}"), format!("{a:?}"), "triangle {i}");
            }
            assert_eq!(t.positions(i), a.p);
            assert_eq!(t.uvs(i), a.uv);
            assert_eq!(
                (t.material(i), t.light(i), t.instance(i)),
                (a.material, a.light, a.instance)
            );
        }
        assert_eq!((t.normals.len(), t.uvs.len()), (14, 1 + 10));
        assert_eq!(std::mem::size_of::<StoredTriangle>(), 56);
        t.set_light(3, 7);
        assert_eq!(t.get(3).light, 7);
    }

    /// Two geometries whose one moving triangle slides along x at different speeds, asked in
    /// turn on one thread at the same times: each pose is its own track's, and a ray at a
    /// time meets the triangle where that geometry has moved it.
    #[test]
    fn each_geometry_poses_its_own_instances() {
        let key = |t: f32, x: f32| crate::animation::TransformKey {
            time_s: t,
            translate: Vec3::new(x, 0.0, 0.0),
            rotate: glam::Quat::IDENTITY,
            scale: Vec3::ONE,
        };
        let geometry = |speed: f32| {
            let tri = TriangleAttributes {
                p: [
                    Vec3::new(-0.5, -0.5, -1.0),
                    Vec3::new(0.5, -0.5, -1.0),
                    Vec3::new(0.0, 0.5, -1.0),
                ],
                n: None,
                uv: [Vec2::ZERO; 3],
                material: 0,
                light: u32::MAX,
                instance: 0,
            };
            let track = TransformTrack::new(vec![key(0.0, 0.0), key(1.0, speed)]).unwrap();
            Geometry::with_instances(vec![tri], vec![track], (0.0, 1.0))
        };
        let (slow, fast) = (geometry(1.0), geometry(4.0));
        for t in [0.25f32, 0.25, 0.5, 0.75, 0.75] {
            for (g, speed) in [(&slow, 1.0), (&fast, 4.0), (&slow, 1.0)] {
                let m = g.instance_transform(0, t).unwrap();
                assert_eq!(m.translation.x, speed * t, "t = {t}");
                // A ray along -z through x = speed · t hits the triangle's moved centre line.
                let o = Vec3::new(speed * t, 0.0, 0.0);
                let ray = Ray {
                    o,
                    d: -Vec3::Z,
                    t_max: f32::INFINITY,
                    time: t,
                };
                let hit = g.intersect(&ray).expect("a hit");
                assert!((hit.p.x - speed * t).abs() < 1e-5, "t = {t}: {:?}", hit.p);
                assert!(!g.unoccluded(o, -Vec3::Z, 10.0, t));
                assert!(g.unoccluded(o + Vec3::new(0.7, 0.0, 0.0), -Vec3::Z, 10.0, t));
            }
        }
    }
}
