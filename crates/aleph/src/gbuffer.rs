//! The G-buffer: what the camera ray through each pixel centre sees at the frame's instant,
//! and where that surface was seen in other frames (for reuse across frames, [`crate::reuse`]).
//!
//! # Layers (named as Blender writes them)
//! - `Depth.Z`: distance of the hit along the camera's view axis, metres (scene units);
//!   [`BACKGROUND_DEPTH`] (Blender's 10¹⁰) where the ray leaves the scene.
//! - `Normal.X/Y/Z`: the shading normal at the hit in world space (zero for the background).
//! - `IndexOB`: the object seen: 0 the background, 1 the static geometry, 2 + i moving
//!   instance i (aleph's objects are its instances; Blender writes the object's pass index).
//!
//! The reuse code also keeps the material index and how far the view direction may turn
//! before the radiance the pixel sees changes ([`GBuffer::reuse_angle`]).

use crate::camera::Camera;
use crate::geometry::Ray;
use crate::material::MaterialKind;
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// `Depth.Z` where nothing is hit (Blender's value for the background).
pub const BACKGROUND_DEPTH: f32 = 1e10;

/// `IndexOB` of the background.
pub const BACKGROUND_OBJECT: u32 = 0;

/// How far (radians) the view direction to a glossy surface may turn, as a multiple of its
/// GGX α, before its radiance is no longer reused: the reflected lobe is about 2α wide, and a
/// highlight moves across it as the reflected direction turns with the view, so a turn of a
/// quarter of α moves a highlight by an eighth of its width.
pub const GLOSSY_TURN_PER_ALPHA: f32 = 0.25;

/// What one pixel centre's ray hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Seen {
    /// A surface: triangle `tri`, the hit in its object's rest space and its shading normal
    /// there (world space for static geometry).
    Surface {
        /// Triangle index.
        tri: u32,
        /// Hit point in the object's rest space.
        local: Vec3,
        /// Shading normal in the object's rest space.
        local_normal: Vec3,
    },
    /// Nothing: the direction of the ray (a point at infinity).
    Background(Vec3),
}

/// Where a pixel's surface is seen from another frame's camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sight {
    /// Continuous raster position in that frame (x right, y down).
    pub raster: Vec2,
    /// The surface point in world space at that frame's instant (unused for the background).
    pub point: Vec3,
    /// Its shading normal in world space then (zero for the background).
    pub normal: Vec3,
    /// Angle (radians) between the directions the two cameras see the point from, where the
    /// surface is view-dependent ([`GBuffer::reuse_angle`] finite); 0 elsewhere, where no turn
    /// matters.
    pub turn: f32,
}

/// The G-buffer of one frame, row-major `width × height` (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct GBuffer {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// The frame's instant, seconds.
    pub time: f32,
    /// `Depth.Z` per pixel, m.
    pub depth: Vec<f32>,
    /// `Normal.X/Y/Z`, 3 values per pixel, world space.
    pub normal: Vec<f32>,
    /// `IndexOB` per pixel.
    pub object: Vec<u32>,
    /// Material index per pixel (`u32::MAX` for the background).
    pub material: Vec<u32>,
    /// Hit point in world space per pixel (the ray direction for the background).
    pub position: Vec<Vec3>,
    /// How far the view direction may turn (radians) before the radiance the pixel sees
    /// changes: infinite for view-independent surfaces (diffuse, emitters, the environment),
    /// [`GLOSSY_TURN_PER_ALPHA`] · α for glossy ones, 0 for mirrors and glass.
    pub reuse_angle: Vec<f32>,
    /// What each pixel saw, for [`GBuffer::sight`].
    pub seen: Vec<Seen>,
    /// The direct irradiance's luminance at each pixel's surface point (W·m⁻² weighted by
    /// Rec.709 luminance), estimated from [`DIRECT_SAMPLES`] light samples that are the same
    /// for every pixel and frame (common random numbers): unchanged light at an unchanged
    /// point gives the same value in every frame, a moving shadow or a light switched on does
    /// not. 0 for the background; NaN where no moving object comes near the way from the
    /// point to any of the light samples (nor is the point on one): the direct light there is
    /// that of the static scene, the same in every frame, and costs no shadow ray. Empty when
    /// nothing but the camera moves (no moving instance), and in a G-buffer made by
    /// [`GBuffer::render_aovs`].
    pub direct: Vec<f32>,
    /// Whether each pixel straddles an edge: a 4-neighbour sees another object or material, or
    /// a point off this pixel's tangent plane by more than [`EDGE_PLANE_TOLERANCE`] of its depth.
    /// Such a pixel's samples mix surfaces in proportions that change with any shift of the
    /// view.
    pub edge: Vec<bool>,
    /// Per pixel: the 3 × 3 neighbourhood's pixel (its own index or a neighbour's) whose
    /// surface point is nearest the camera, and whether that neighbourhood spans a step in
    /// depth (a centre off this pixel's tangent plane by more than [`EDGE_PLANE_TOLERANCE`] of
    /// its depth, or the background beside a surface): where it does not, one surface (or
    /// several meeting in a plane) fills the pixel and nothing can be in front of it.
    pub front: Vec<(u32, bool)>,
}

/// Distance off a pixel's tangent plane, as a fraction of its depth, at which a neighbour's
/// point makes the pixel an edge.
pub const EDGE_PLANE_TOLERANCE: f32 = 0.01;

/// Light samples of [`GBuffer::direct`]: 8. The signature only has to tell where a moving
/// object changed the direct light; the test of reused against fresh luminance
/// ([`crate::reuse::Reprojected::test`]) catches what it misses. One shadow ray's change, 1/8
/// of an unshadowed signature, is more than the change at which reuse drops history
/// ([`crate::reuse::DIRECT_TOLERANCE`], a tenth), so in a penumbra a neighbour's sample is
/// dropped more often than at 16: measured on the moving-sphere box (128², frames 0–11,
/// seeds 0 and 1, budgets 1–8 fresh spp), 32, 16, 8 and 4 samples give the reuse arm's video
/// JOD within 0.01 and its FLIP mean within 0.4 % of each other, and every reuse test passes
/// at 4; 8 halves the shadow rays of 16 (the whole 12-frame render at 1 fresh spp took
/// 1/1.10 the wall time, 7 pairs) and keeps twice the resolution of 4 for small occluders.
/// 32 until 2026-11-27, then 16.
pub const DIRECT_SAMPLES: u32 = 8;

impl GBuffer {
    /// Traces the pixel centres of `scene`'s current frame (its instant, the centre of the
    /// lens), with the direct-light signature [`GBuffer::direct`] that reuse across frames
    /// needs where anything but the camera moves.
    pub fn render(scene: &Scene) -> GBuffer {
        Self::traced(scene, scene.geometry.has_motion())
    }

    /// [`GBuffer::render`] without [`GBuffer::direct`] (left empty): the layers an image
    /// writes (`Depth.Z`, `Normal`, `IndexOB`, the `Vector` pass taken from it). The direct
    /// signature costs [`DIRECT_SAMPLES`] shadow rays a pixel wherever a moving object comes
    /// near the way to a light: on the moving-sphere box (128², 2 spp), at 32 light samples,
    /// 16 ms of an independent frame's 47 ms, spent on nothing by a frame that reuses no
    /// history.
    pub fn render_aovs(scene: &Scene) -> GBuffer {
        Self::traced(scene, false)
    }

    /// The G-buffer, with the direct signature where `moving`.
    fn traced(scene: &Scene, moving: bool) -> GBuffer {
        let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
        let t = scene.frame.time_s as f32;
        // What the signature's pre-test needs, only where there is a signature.
        let (boxes, lights) = if moving {
            let lights = scene.lights.finite_bounds(&scene.geometry, t);
            (scene.geometry.moving_boxes(t), lights)
        } else {
            (Vec::new(), None)
        };
        let texels: Vec<(Texel, f32)> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let ray =
                    scene
                        .camera
                        .generate_ray((i % w) as u32, (i / w) as u32, Vec2::splat(0.5), t);
                let texel = trace_centre(scene, &ray, t);
                let direct = match &texel.hit {
                    Some(hit) if moving => {
                        direct_signature(scene, hit, -ray.d, t, (&boxes, lights))
                    }
                    _ => 0.0,
                };
                (texel, direct)
            })
            .collect();
        let mut g = GBuffer {
            width: w,
            height: h,
            time: t,
            depth: Vec::with_capacity(w * h),
            normal: Vec::with_capacity(3 * w * h),
            object: Vec::with_capacity(w * h),
            material: Vec::with_capacity(w * h),
            position: Vec::with_capacity(w * h),
            reuse_angle: Vec::with_capacity(w * h),
            seen: Vec::with_capacity(w * h),
            direct: Vec::with_capacity(w * h),
            edge: Vec::new(),
            front: Vec::new(),
        };
        for (t, direct) in texels {
            g.seen.push(t.seen);
            g.position.push(t.position);
            g.normal.extend(t.normal.to_array());
            g.object.push(t.object);
            g.material.push(t.material);
            g.reuse_angle.push(t.reuse_angle);
            g.depth.push(t.depth);
            if moving {
                g.direct.push(direct);
            }
        }
        g.edge = (0..w * h)
            .into_par_iter()
            .map(|i| g.straddles_edge(i))
            .collect();
        g.front = (0..w * h).into_par_iter().map(|i| g.front_of(i)).collect();
        g
    }

    /// [`GBuffer::front`] of pixel `i`.
    fn front_of(&self, i: usize) -> (u32, bool) {
        let (w, h) = (self.width, self.height);
        let (x, y) = (i % w, i / w);
        let n = self.normal_at(i);
        let (mut front, mut step) = (i, false);
        for yy in y.saturating_sub(1)..(y + 2).min(h) {
            for xx in x.saturating_sub(1)..(x + 2).min(w) {
                let k = yy * w + xx;
                if self.depth[k] < self.depth[front] {
                    front = k;
                }
                step |= if self.is_background(i) || self.is_background(k) {
                    self.is_background(i) != self.is_background(k)
                } else {
                    (self.position[k] - self.position[i]).dot(n).abs()
                        > EDGE_PLANE_TOLERANCE * self.depth[i]
                };
            }
        }
        (front as u32, step)
    }

    /// Whether pixel `i` straddles an edge (see [`GBuffer::edge`]).
    fn straddles_edge(&self, i: usize) -> bool {
        let (w, h) = (self.width, self.height);
        let (x, y) = (i % w, i / w);
        let n = self.normal_at(i);
        let neighbours = [
            (x > 0).then(|| i - 1),
            (x + 1 < w).then(|| i + 1),
            (y > 0).then(|| i - w),
            (y + 1 < h).then(|| i + w),
        ];
        neighbours.into_iter().flatten().any(|k| {
            if self.object[k] != self.object[i] || self.material[k] != self.material[i] {
                return true;
            }
            !self.is_background(i)
                && (self.position[k] - self.position[i]).dot(n).abs()
                    > EDGE_PLANE_TOLERANCE * self.depth[i]
        })
    }

    /// The normal of pixel `i`.
    pub fn normal_at(&self, i: usize) -> Vec3 {
        Vec3::from_slice(&self.normal[3 * i..3 * i + 3])
    }

    /// Whether pixel `i` sees the background.
    pub fn is_background(&self, i: usize) -> bool {
        self.object[i] == BACKGROUND_OBJECT
    }

    /// Where pixel `i`'s surface is seen at scene time `t` by `scene`'s camera then (the
    /// surface carried with its object); `None` when it is behind that camera.
    pub fn sight(&self, scene: &Scene, i: usize, t: f32) -> Option<Sight> {
        self.sight_by(
            scene,
            i,
            t,
            (&scene.camera_at(t), &scene.camera_at(self.time)),
        )
    }

    /// [`GBuffer::sight`] with the cameras given: `cam` at scene time `t`, `here` at this
    /// G-buffer's time (as [`Scene::camera_at`] gives them; a loop over pixels builds them
    /// once).
    pub fn sight_by(
        &self,
        scene: &Scene,
        i: usize,
        t: f32,
        (cam, here): (&Camera, &Camera),
    ) -> Option<Sight> {
        match self.seen[i] {
            Seen::Background(d) => Some(Sight {
                raster: cam.raster_of_direction(d)?,
                point: d,
                normal: Vec3::ZERO,
                turn: 0.0,
            }),
            Seen::Surface {
                local,
                local_normal,
                ..
            } => {
                // The instance from `IndexOB` (2 + i), not from the triangle's record: one
                // lookup fewer into the scene's triangles, per pixel and window frame.
                let instance = self.object[i].checked_sub(2);
                let moving = instance.and_then(|k| scene.geometry.instance_transform(k, t));
                let (point, normal) = match moving {
                    Some(m) => (
                        m.transform_point3(local),
                        m.matrix3.inverse().transpose().mul_vec3(local_normal),
                    ),
                    None => (local, local_normal),
                };
                let now = self.position[i] - here.position;
                let then = point - cam.position;
                let normal = normal.normalize_or_zero();
                // atan2 of the cross and dot products: exact 0 for equal directions, where
                // acos of a rounded dot product is not.
                let turn = if self.reuse_angle[i].is_finite() {
                    now.cross(then).length().atan2(now.dot(then))
                } else {
                    0.0
                };
                Some(Sight {
                    raster: cam.raster(point)?,
                    point,
                    normal,
                    turn,
                })
            }
        }
    }
}

/// One pixel centre's texel.
struct Texel {
    seen: Seen,
    /// World point (the ray direction for the background).
    position: Vec3,
    normal: Vec3,
    object: u32,
    material: u32,
    reuse_angle: f32,
    depth: f32,
    hit: Option<crate::geometry::Hit>,
}

fn trace_centre(scene: &Scene, ray: &Ray, t: f32) -> Texel {
    let Some(hit) = scene.geometry.intersect(ray) else {
        return Texel {
            seen: Seen::Background(ray.d),
            position: ray.d,
            normal: Vec3::ZERO,
            object: BACKGROUND_OBJECT,
            material: u32::MAX,
            reuse_angle: f32::INFINITY,
            depth: BACKGROUND_DEPTH,
            hit: None,
        };
    };
    let tris = &scene.geometry.tris;
    let material = tris.material(hit.tri as usize);
    let instance = tris.instance(hit.tri as usize);
    let (local, local_normal) = match scene.geometry.transform_at(hit.tri, t) {
        Some(m) => (
            m.inverse().transform_point3(hit.p),
            m.matrix3.transpose().mul_vec3(hit.ns),
        ),
        None => (hit.p, hit.ns),
    };
    let object = object_index(instance);
    let reuse_angle = reuse_angle(&scene.materials[material as usize].kind);
    Texel {
        seen: Seen::Surface {
            tri: hit.tri,
            local,
            local_normal: local_normal.normalize_or_zero(),
        },
        position: hit.p,
        normal: hit.ns,
        object,
        material,
        reuse_angle,
        depth: scene.camera.depth_of(hit.p),
        hit: Some(hit),
    }
}

/// `IndexOB` of a surface of instance `instance` (see the module docs).
pub fn object_index(instance: u32) -> u32 {
    if instance == crate::geometry::STATIC_INSTANCE {
        1
    } else {
        instance + 2
    }
}

/// How far the view of a surface of material `kind` may turn (radians) before its radiance
/// changes ([`GBuffer::reuse_angle`]).
pub fn reuse_angle(kind: &MaterialKind) -> f32 {
    match kind {
        MaterialKind::Diffuse => f32::INFINITY,
        MaterialKind::Glossy { alpha } => GLOSSY_TURN_PER_ALPHA * alpha,
        MaterialKind::Mirror | MaterialKind::Dielectric { .. } => 0.0,
    }
}

/// A world-space box: (min, max) corners.
type Box3 = (Vec3, Vec3);

/// A sphere: centre and radius, world units.
type Sphere = (Vec3, f32);

/// [`GBuffer::direct`] at `hit`, seen from direction `wo` (towards the camera): the mean of
/// L·cos/pdf over the fixed light samples (a Kronecker sequence in the light-choice and
/// position dimensions) whose shadow rays are clear; NaN where no light sample's segment
/// meets a box of `moving` (the moving instances at `t`, [`crate::geometry::Geometry::moving_boxes`])
/// and the surface itself is static. `lights`: a sphere holding every light sample's point
/// ([`crate::light::Lights::finite_bounds`]); where no segment from the point to it can meet a
/// moving box, no light is sampled.
fn direct_signature(
    scene: &Scene,
    hit: &crate::geometry::Hit,
    wo: Vec3,
    t: f32,
    (moving, lights): (&[Box3], Option<Sphere>),
) -> f32 {
    let geo = &scene.geometry;
    let moves = geo.tris.instance(hit.tri as usize) != crate::geometry::STATIC_INSTANCE;
    if !moves && lights.is_some_and(|l| !moving.iter().any(|&b| may_meet(hit.p, l, b))) {
        return f32::NAN;
    }
    let ng = if hit.ng.dot(wo) < 0.0 {
        -hit.ng
    } else {
        hit.ng
    };
    let ns = if hit.ns.dot(ng) < 0.0 {
        -hit.ns
    } else {
        hit.ns
    };
    // R3 (Roberts 2018): the plastic-number Kronecker sequence, well spread in 3-D.
    const A: [f32; 3] = [0.819_172_5, 0.671_043_5, 0.549_700_5];
    let samples: [_; DIRECT_SAMPLES as usize] = std::array::from_fn(|s| {
        let u = A.map(|a| (a * (s as f32 + 0.5)).fract());
        let ls = scene.lights.sample(
            hit.p,
            ns,
            u[0],
            Vec2::new(u[1], u[2]),
            t,
            &scene.geometry,
            &scene.materials,
            &scene.textures,
        )?;
        (ls.le.max_element() > 0.0 && ls.pdf > 0.0 && ls.wi.dot(ng) > 0.0).then_some(ls)
    });
    // Static lights, static occluders: unless a moving object is near the way to a light
    // sample (or the surface itself moves), the direct light here is the same in every frame.
    let touched = moves
        || samples.iter().flatten().any(|ls| {
            let reach = if ls.dist.is_finite() { ls.dist } else { 1e6 };
            crate::geometry::segment_meets_boxes(moving, hit.p, ls.wi * reach)
        });
    if !touched {
        return f32::NAN;
    }
    let mut e = 0.0;
    for ls in samples.iter().flatten() {
        if crate::integrator::shadow_ray_clear(geo, hit, ls, t) {
            e += crate::math::luminance(ls.le) * ls.wi.dot(ns).max(0.0) / ls.pdf;
        }
    }
    e / DIRECT_SAMPLES as f32
}

/// Whether a segment from `p` to a point of the sphere `light` (centre, radius) may pass
/// through the box `(lo, hi)`: false only when none can (the box's bounding sphere lies outside
/// the cone from `p` around the light's sphere, or beyond its far end). Conservative: the radii
/// and the angle carry a margin for rounding.
fn may_meet(p: Vec3, (a, ra): Sphere, (lo, hi): Box3) -> bool {
    const MARGIN: f32 = 1e-3;
    let (c, rb) = (0.5 * (lo + hi), 0.5 * (hi - lo).length() * (1.0 + MARGIN));
    let ra = ra * (1.0 + MARGIN);
    let (dc, da) = (c - p, a - p);
    let (lc, la) = (dc.length(), da.length());
    if lc <= rb || la <= ra {
        return true;
    }
    if lc - rb > (la + ra) * (1.0 + MARGIN) {
        return false;
    }
    let spread = (ra / la).asin() + (rb / lc).asin() + MARGIN;
    let angle = (dc.dot(da) / (lc * la)).clamp(-1.0, 1.0).acos();
    angle <= spread
}

#[cfg(test)]
mod may_meet_tests {
    use super::may_meet;
    use crate::geometry::segment_meets_boxes;
    use crate::rng::Rng;
    use glam::Vec3;

    fn point(r: &mut Rng, scale: f32) -> Vec3 {
        Vec3::new(r.uniform(), r.uniform(), r.uniform()) * 2.0 * scale - Vec3::splat(scale)
    }

    /// Never false where a segment from the point to a point of the light's sphere crosses the
    /// box (the exact slab test the signature uses), over random points, spheres and boxes; and
    /// false often enough to pay (the pre-test is not `true` everywhere).
    #[test]
    fn conservative_against_the_slab_test() {
        let mut r = Rng::new(7, 0);
        let (mut crossings, mut refused) = (0, 0);
        for _ in 0..20_000 {
            let p = point(&mut r, 4.0);
            let (a, ra) = (point(&mut r, 4.0), 0.05 + 0.5 * r.uniform());
            let c = point(&mut r, 4.0);
            let half = Vec3::new(r.uniform(), r.uniform(), r.uniform()) * 0.6 + Vec3::splat(0.01);
            let b = (c - half, c + half);
            let verdict = may_meet(p, (a, ra), b);
            refused += usize::from(!verdict);
            for _ in 0..16 {
                // A point in the light's sphere, uniform in its cube and rejected outside.
                let q = a + point(&mut r, ra);
                if (q - a).length() > ra {
                    continue;
                }
                if segment_meets_boxes(&[b], p, q - p) {
                    crossings += 1;
                    assert!(verdict, "p {p} light ({a}, {ra}) box {b:?}: crossed at {q}");
                }
            }
        }
        assert!(crossings > 500, "{crossings} crossings tried");
        assert!(refused > 5000, "only {refused} of 20 000 refused");
    }
}
