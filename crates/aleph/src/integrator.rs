//! Unidirectional path tracing of the rendering equation (Kajiya 1986) with next-event
//! estimation, BSDF sampling and multiple importance sampling (Veach & Guibas 1995).
//!
//! At every non-delta vertex the estimator takes one light sample (a light chosen as
//! [`crate::light::Lights`] describes, then a point or direction on it) and one BSDF sample, and
//! weights each with the power heuristic (β = 2) against the other strategy's pdf for the same
//! direction; point and spot lights, which BSDF sampling cannot reach, get weight 1. Rays that
//! leave the scene see the environment and the suns, MIS-weighted the same way. Emitters are seen
//! directly by camera rays and after delta bounces with weight 1. Russian roulette (Arvo & Kirk
//! 1990) starts after [`RR_START_DEPTH`] bounces with survival probability min(1, max channel of
//! the throughput × the η² of the refractions crossed), floored at 5 %, so the estimator stays
//! unbiased while `max_depth` only stops pathological paths. It starts at bounce 5, as Mitsuba 3
//! starts it (`rr_depth` 5): on the Cornell box (256², 3 seeds, relMSE against an 8192-spp
//! Mitsuba reference), starting at bounce 3 gave 1.39× / 1.49× the relMSE at 16 / 64 spp (depth
//! 8; 1.37× / 1.47× at depth 64) for 1/1.28 of the CPU time per sample (paired runs), so bounce
//! 5 reaches equal error in 1.08–1.17× less time; with independent numbers aleph's per-sample
//! relMSE then equals Mitsuba's `independent` sampler's (0.01102 / 0.00278 against 0.01098 /
//! 0.00279). (An earlier measurement had found the two starts equally efficient.)
//!
//! Textures seen from the camera, directly or through mirrors and glass, are filtered over a
//! fixed share of the pixel's footprint, carried as a ray cone ([`TEXTURE_FOOTPRINT_PIXELS`]).

use crate::geometry::{Hit, Ray, offset_origin};
use crate::light::LightSample;
use crate::light::environment::Environment;
use crate::math::Frame;
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::scene::Scene;
use crate::texture::Footprint;
use glam::{Vec2, Vec3};

/// Bounce at which Russian roulette starts (Mitsuba 3's `rr_depth`; measured in the module docs).
pub const RR_START_DEPTH: u32 = 5;

/// Width, in pixels, of the footprint over which textures seen from the camera are filtered:
/// a surface's textures are looked up over the area a cone of this width per pixel covers
/// there (a ray cone), so that texture detail finer than the pixel is averaged in part by the
/// lookup instead of by the samples. An eighth of a pixel, pbrt-v4's floor for its camera ray
/// differentials (it scales them by max(⅛, 1/√spp)), fixed so that a pixel's samples
/// converge to the same image whatever their number (the adaptive sampler's half-buffers must
/// agree in mean). The filtered image is not the point-sampled one: measured against
/// point-sampled 1024-spp references (docs/benchmarks.md, "Textures filtered over an eighth
/// of a pixel"), the holodeck's and Lost Empire's uniform renders come closer to them at
/// 4–32 spp by FLIP and at 4–64 spp by relMSE; a quarter of a pixel gained more against its
/// own reference but left a floor of FLIP mean 0.076 against the point-sampled one at 64 spp
/// on the holodeck, where uniform sampling reaches 0.053.
pub const TEXTURE_FOOTPRINT_PIXELS: f32 = 0.125;

/// A ray cone (Amanatides 1984; Akenine-Möller et al. 2019, "Texture Level of Detail
/// Strategies for Real-Time Ray Tracing", Ray Tracing Gems ch. 20): the width of the footprint
/// a path from the camera covers grows as `spread × distance`, through mirrors and glass as
/// through empty space (curvature ignored); after a diffuse or glossy bounce the path no longer
/// stands for a pixel's area, and textures are looked up at a point (`spread` 0).
#[derive(Clone, Copy, Debug)]
struct Cone {
    /// Footprint width per unit distance along the path (radians, small-angle).
    spread: f32,
    /// Distance travelled from the camera to the current ray's origin.
    travelled: f32,
}

impl Cone {
    /// The cone of a camera ray: [`TEXTURE_FOOTPRINT_PIXELS`] of the pixel's angular size at
    /// the image centre (2 tan(fov/2) / height).
    fn camera(scene: &Scene) -> Cone {
        let cam = &scene.camera;
        let pixel = 2.0 * (0.5 * cam.vfov_deg.to_radians()).tan() / cam.height.max(1) as f32;
        Cone {
            spread: pixel * TEXTURE_FOOTPRINT_PIXELS,
            travelled: 0.0,
        }
    }

    /// A path that no longer stands for a pixel's footprint.
    const POINT: Cone = Cone {
        spread: 0.0,
        travelled: 0.0,
    };

    /// The cone after a delta bounce at `hit`: it goes on widening.
    fn through(self, hit: &Hit) -> Cone {
        Cone {
            travelled: self.travelled + hit.t,
            ..self
        }
    }

    /// The cone after a bounce at `hit`: [`Cone::through`] a delta bounce, else none.
    fn after(self, hit: &Hit, delta: bool) -> Cone {
        if delta {
            self.through(hit)
        } else {
            Cone::POINT
        }
    }

    /// The cone's footprint on the surface at `hit` seen along `d` (unit), for
    /// [`crate::material::Material::bsdf`]: its width in texture coordinates is the width w at
    /// the hit times √(uv area ÷ world area) of the triangle, over √|cos θ| (the footprint's
    /// area, w² / |cos θ|, taken as a square; cos θ floored at 1/16), bounded by the triangle's
    /// texture coordinates. A point lookup where the cone has no spread, the triangle's texture
    /// coordinates are degenerate or the material has no texture.
    fn footprint(
        self,
        scene: &Scene,
        hit: &Hit,
        d: Vec3,
        time: f32,
        material: &crate::material::Material,
    ) -> Footprint {
        if self.spread <= 0.0 || !material.is_textured() {
            return Footprint::POINT;
        }
        let uv = scene.geometry.tris.uvs(hit.tri as usize);
        let v = scene.geometry.world_vertices(hit.tri, time);
        let (a, b) = (uv[1] - uv[0], uv[2] - uv[0]);
        let uv_area = (a.x * b.y - a.y * b.x).abs();
        let area = (v[1] - v[0]).cross(v[2] - v[0]).length();
        let w = self.spread * (self.travelled + hit.t);
        let cos = d.dot(hit.ng).abs().max(1.0 / 16.0);
        let width = w * (uv_area / (area * cos)).sqrt();
        if !(width.is_finite() && width > 0.0) {
            return Footprint::POINT;
        }
        Footprint {
            width,
            lo: uv[0].min(uv[1]).min(uv[2]),
            hi: uv[0].max(uv[1]).max(uv[2]),
        }
    }
}

/// Which light-transport strategies are used (MIS by default; the single strategies exist for
/// tests and comparisons: all three converge to the same image).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Strategy {
    /// Light sampling and BSDF sampling combined with the power heuristic.
    #[default]
    Mis,
    /// Next-event estimation only: emitters hit by BSDF-sampled rays are ignored except after
    /// a delta bounce or from the camera.
    LightOnly,
    /// BSDF sampling only: no shadow rays, emitters count when hit.
    BsdfOnly,
}

/// Path-tracer parameters.
#[derive(Clone, Copy, Debug)]
pub struct Integrator {
    /// Maximum number of bounces (path segments after the camera ray).
    pub max_depth: u32,
    /// Strategy.
    pub strategy: Strategy,
}

/// Radiance estimate of one camera ray and its cost.
#[derive(Clone, Copy, Debug)]
pub struct PathResult {
    /// Radiance along the ray, linear Rec.709, W·sr⁻¹·m⁻².
    pub radiance: Vec3,
    /// Rays traced (closest-hit plus shadow).
    pub rays: u32,
    /// What the camera ray hit first, for reuse across frames ([`crate::reuse`]).
    pub first: FirstHit,
}

/// The first surface a camera ray hit: its triangle and the world-space point at the ray's
/// time, or, where the ray left the scene, `tri == u32::MAX` and the ray's direction.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FirstHit {
    /// Triangle index; `u32::MAX` for a miss.
    pub tri: u32,
    /// World-space hit point (the unit direction of the ray for a miss).
    pub at: Vec3,
}

impl FirstHit {
    /// A ray that hit nothing, going `d`.
    pub fn miss(d: Vec3) -> FirstHit {
        FirstHit {
            tri: u32::MAX,
            at: d,
        }
    }

    /// A ray that hit `hit`.
    pub fn of(hit: &Hit) -> FirstHit {
        FirstHit {
            tri: hit.tri,
            at: hit.p,
        }
    }
}

/// Largest emitted luminance reported by [`albedo`] (emitters are much brighter than any
/// reflectance; capping keeps their edges strong but finite in the guide).
pub const ALBEDO_EMITTER_CAP: f32 = 10.0;

/// Emitted radiance scaled so its luminance is at most [`ALBEDO_EMITTER_CAP`].
fn capped(le: Vec3) -> Vec3 {
    let y = crate::math::luminance(le);
    if y > ALBEDO_EMITTER_CAP {
        le * (ALBEDO_EMITTER_CAP / y)
    } else {
        le
    }
}

/// The first-hit albedo along `ray`, the noise-free guide of the adaptive sampler (as denoisers'
/// albedo AOVs): the diffuse (Kd) plus specular (Ks) reflectance of the first non-delta surface,
/// following up to 8 ideal-specular bounces and weighting by their reflectance; an emitter
/// reports its radiance scaled so its luminance is at most [`ALBEDO_EMITTER_CAP`]; a miss
/// reports the environment and suns seen there, capped the same way. Uses `rng` only for the
/// choice at dielectrics (reflect or refract by Fresnel).
pub fn albedo(scene: &Scene, ray: Ray, rng: &mut impl Sampler) -> Vec3 {
    first_surface(scene, ray, rng).albedo
}

/// What [`first_surface`] found along a camera ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstSurface {
    /// [`albedo`]'s value.
    pub albedo: Vec3,
    /// The interpolated normal (before bump mapping) of the surface reported, world space,
    /// facing the ray; zero for a miss or a path lost among specular bounces.
    pub normal: Vec3,
    /// The index into `scene.materials` of that surface's material when its colours come from
    /// a texture ([`crate::material::Material::is_textured`]) and it is not an emitter seen
    /// directly; `None` otherwise (an untextured surface, an emitter, a miss).
    pub textured: Option<u32>,
}

/// [`albedo`] and the normal of the surface it reports: the albedo and normal auxiliary images
/// a denoiser takes (Open Image Denoise's, as Cycles' "Denoising Albedo" and "Denoising
/// Normal" passes), and whether that surface is textured.
pub fn first_surface(scene: &Scene, mut ray: Ray, rng: &mut impl Sampler) -> FirstSurface {
    use crate::bsdf::Bsdf;
    let mut weight = Vec3::ONE;
    let mut cone = Cone::camera(scene);
    let surface = |albedo: Vec3, normal: Vec3, textured: Option<u32>| FirstSurface {
        albedo,
        normal,
        textured,
    };
    for _ in 0..8 {
        let Some(hit) = scene.geometry.intersect(&ray) else {
            let sky = capped(scene.lights.infinite_radiance_unweighted(ray.d));
            return surface(weight * sky, Vec3::ZERO, None);
        };
        let facing = if ray.d.dot(hit.ns) > 0.0 {
            -hit.ns
        } else {
            hit.ns
        };
        let tris = &scene.geometry.tris;
        let index = tris.material(hit.tri as usize);
        let material = &scene.materials[index as usize];
        let footprint = cone.footprint(scene, &hit, ray.d, ray.time, material);
        if tris.light(hit.tri as usize) != u32::MAX && -ray.d.dot(hit.ng) > 0.0 {
            let le = capped(material.emitted(hit.uv, footprint, &scene.textures));
            return surface(weight * le, facing, None);
        }
        let bsdf = material.bsdf(hit.uv, footprint, &scene.textures);
        cone = cone.through(&hit);
        let textured = material.is_textured().then_some(index);
        match bsdf {
            Bsdf::Lambert(l) => return surface(weight * l.reflectance, facing, textured),
            Bsdf::Glossy(g) => return surface(weight * (g.kd + g.ks), facing, textured),
            Bsdf::Mirror(_) | Bsdf::Dielectric(_) => {
                let ns = if !bsdf.is_transmissive() && ray.d.dot(hit.ng) > 0.0 {
                    -hit.ns
                } else {
                    hit.ns
                };
                let frame = Frame::from_normal(ns);
                let wo = frame.to_local(-ray.d);
                let Some(s) = bsdf.sample(wo, rng.uniform(), rng.uniform2()) else {
                    return surface(Vec3::ZERO, Vec3::ZERO, None);
                };
                weight *= s.f * s.wi.z.abs() / s.pdf;
                let wi = frame.from_local(s.wi);
                ray = Ray {
                    o: offset_origin(hit.p, hit.ng, wi),
                    d: wi,
                    t_max: f32::INFINITY,
                    time: ray.time,
                };
            }
        }
    }
    surface(Vec3::ZERO, Vec3::ZERO, None)
}

/// The shading normal at `hit` with the material's bump or normal map applied: the map's
/// tangent-space normal is carried into the frame of the interpolated normal and the tangent
/// ∂p/∂u (Gram–Schmidt), with ∂p/∂v fixing the handedness (pbrt-v4 §10.5.3 for the tangents).
/// Falls back to the unperturbed normal where the texture coordinates are degenerate or the
/// result would face away from the geometric normal (the geometric normal still decides every
/// side test, so a bump map cannot leak light through a surface).
#[inline]
fn shading_normal(
    scene: &Scene,
    hit: &Hit,
    time: f32,
    material: &crate::material::Material,
) -> Vec3 {
    let Some(bump) = &material.bump else {
        return hit.ns;
    };
    let geo = &scene.geometry;
    let uv = geo.tris.uvs(hit.tri as usize);
    let v = geo.world_vertices(hit.tri, time);
    let (duv1, duv2) = (uv[1] - uv[0], uv[2] - uv[0]);
    let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
    let det = duv1.x * duv2.y - duv1.y * duv2.x;
    if det.abs() < 1e-20 {
        return hit.ns;
    }
    let dpdu = (e1 * duv2.y - e2 * duv1.y) / det;
    let dpdv = (e2 * duv1.x - e1 * duv2.x) / det;
    let n = hit.ns;
    let tu = (dpdu - n * n.dot(dpdu)).normalize_or_zero();
    if tu == Vec3::ZERO || !tu.is_finite() {
        return hit.ns;
    }
    let mut tv = n.cross(tu);
    if tv.dot(dpdv) < 0.0 {
        tv = -tv;
    }
    let tn = bump.tangent_normal(hit.uv, &scene.textures);
    let p = (tu * tn.x + tv * tn.y + n * tn.z).normalize_or_zero();
    if p.dot(hit.ng) <= 1e-4 || !p.is_finite() {
        return hit.ns;
    }
    p
}

/// True when nothing blocks the light sample `ls` from the hit point: a shadow ray to a point
/// just short of a surface sample, to the position of a point light, or out to infinity.
#[inline]
pub(crate) fn shadow_ray_clear(
    geo: &crate::geometry::Geometry,
    hit: &Hit,
    ls: &LightSample,
    time: f32,
) -> bool {
    let o = offset_origin(hit.p, hit.ng, ls.wi);
    if ls.dist.is_infinite() {
        return geo.unoccluded(o, ls.wi, f32::INFINITY, time);
    }
    let target = if ls.on_surface {
        offset_origin(ls.p, ls.n, -ls.wi)
    } else {
        ls.p
    };
    let d = target - o;
    let dist = d.length();
    dist > 0.0 && geo.unoccluded(o, d / dist, dist, time)
}

/// A path vertex as light sampling sees it: the hit, the scene time, the BSDF in its shading
/// frame, the outgoing direction in that frame, the shading normal and the geometric normal on
/// the side light may arrive from.
struct Vertex<'a> {
    hit: &'a Hit,
    time: f32,
    bsdf: &'a crate::bsdf::Bsdf,
    frame: &'a Frame,
    wo: Vec3,
    ns: Vec3,
    ng_side: Vec3,
}

impl Integrator {
    /// Radiance from the lights at infinity along `d`, for a ray that left the scene after a
    /// vertex of shading normal `prev_n` whose BSDF sample had density `prev_pdf` (or was a
    /// delta bounce, or the camera).
    #[inline]
    fn escaped(
        &self,
        scene: &Scene,
        d: Vec3,
        prev_delta: bool,
        prev_pdf: f32,
        prev_n: Vec3,
    ) -> Vec3 {
        if !scene.lights.has_infinite() {
            return Vec3::ZERO;
        }
        if prev_delta || self.strategy == Strategy::BsdfOnly {
            return scene.lights.infinite_radiance_unweighted(d);
        }
        if self.strategy == Strategy::LightOnly {
            return Vec3::ZERO;
        }
        scene.lights.infinite_radiance(
            d,
            prev_n,
            Some(|light_pdf| power_heuristic(prev_pdf, light_pdf)),
        )
    }

    /// One light sample at vertex `at` with random numbers (`uc`, `u`), MIS-weighted against
    /// BSDF sampling and scaled by the path throughput `beta`: (its contribution to the path's
    /// radiance, shadow rays traced).
    #[inline(always)]
    fn direct_light(
        &self,
        scene: &Scene,
        at: &Vertex,
        beta: Vec3,
        uc: f32,
        u: Vec2,
    ) -> (Vec3, u32) {
        let geo = &scene.geometry;
        let Some(ls) = scene.lights.sample(
            at.hit.p,
            at.ns,
            uc,
            u,
            at.time,
            geo,
            &scene.materials,
            &scene.textures,
        ) else {
            return (Vec3::ZERO, 0);
        };
        if !(ls.le.max_element() > 0.0 && ls.pdf > 0.0 && ls.wi.dot(at.ng_side) > 0.0) {
            return (Vec3::ZERO, 0);
        }
        let wi = at.frame.to_local(ls.wi);
        let f = at.bsdf.eval(at.wo, wi);
        if f.max_element() <= 0.0 {
            return (Vec3::ZERO, 0);
        }
        if !shadow_ray_clear(geo, at.hit, &ls, at.time) {
            return (Vec3::ZERO, 1);
        }
        let w = if self.strategy == Strategy::Mis && !ls.delta {
            power_heuristic(ls.pdf, at.bsdf.pdf(at.wo, wi))
        } else {
            1.0
        };
        (beta * f * wi.z.abs() * ls.le * (w / ls.pdf), 1)
    }

    /// MIS weight of emission that BSDF sampling hit (the previous vertex at `prev`, sampled
    /// with solid-angle pdf `bsdf_pdf`): the power heuristic against light sampling, or the
    /// single strategy's 0 or 1.
    #[inline]
    fn emission_weight(
        &self,
        scene: &Scene,
        hit: &crate::geometry::Hit,
        time: f32,
        bsdf_pdf: f32,
        prev: (Vec3, Vec3),
    ) -> f32 {
        match self.strategy {
            Strategy::Mis => {
                let light_pdf = scene
                    .lights
                    .pdf(&scene.geometry, hit.tri, time, prev, hit.p);
                power_heuristic(bsdf_pdf, light_pdf)
            }
            Strategy::LightOnly => 0.0,
            Strategy::BsdfOnly => 1.0,
        }
    }

    /// The radiance a path sees emitted at `hit` (before its throughput) and its MIS weight
    /// against light sampling (1 when the previous vertex `(delta, pdf, point, normal)` was
    /// specular).
    #[inline]
    fn emitted_seen(
        &self,
        scene: &Scene,
        hit: &crate::geometry::Hit,
        time: f32,
        material: &crate::material::Material,
        footprint: Footprint,
        (prev_delta, prev_pdf, prev_p, prev_n): (bool, f32, Vec3, Vec3),
    ) -> (Vec3, f32) {
        let le = material.emitted(hit.uv, footprint, &scene.textures);
        let w = if prev_delta {
            1.0
        } else {
            self.emission_weight(scene, hit, time, prev_pdf, (prev_p, prev_n))
        };
        (le, w)
    }

    /// Estimates the radiance arriving along `ray`, a camera ray of `scene.camera`: the
    /// textures it and its mirror and glass bounces see are filtered over its pixel's
    /// footprint ([`TEXTURE_FOOTPRINT_PIXELS`]).
    /// `rng` gives the path's canonical random numbers in order: per vertex the light choice
    /// (1-D; passed over unless [`crate::light::Lights::chooses_with_own_sample`], the point's
    /// first coordinate choosing otherwise), the point on the light (2-D), the lobe choice
    /// (1-D), the direction (2-D), then Russian roulette (1-D).
    pub fn radiance(&self, scene: &Scene, mut ray: Ray, rng: &mut impl Sampler) -> PathResult {
        let geo = &scene.geometry;
        let mut l = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut rays = 0u32;
        // State of the previous vertex, for MIS on emitters hit by BSDF sampling.
        let mut prev_delta = true;
        let mut prev_pdf = 0.0f32;
        let mut prev_p = ray.o;
        let mut prev_n = Vec3::ZERO;
        let mut eta_scale = 1.0f32;
        let mut depth = 0u32;
        let mut first = FirstHit::miss(ray.d);
        let mut cone = Cone::camera(scene);
        let env_map = scene.lights.environment_map();
        loop {
            let ahead = LightAhead::draw(env_map, rng);
            rays += 1;
            let Some(hit) = geo.intersect(&ray) else {
                l += beta * self.escaped(scene, ray.d, prev_delta, prev_pdf, prev_n);
                break;
            };
            ahead.prefetch_texels();
            if depth == 0 {
                first = FirstHit::of(&hit);
            }
            let tri = hit.tri as usize;
            let material = &scene.materials[geo.tris.material(tri) as usize];
            let wo_world = -ray.d;
            let footprint = cone.footprint(scene, &hit, ray.d, ray.time, material);

            // Emission seen along the ray (one-sided: front face only).
            if geo.tris.light(tri) != u32::MAX && wo_world.dot(hit.ng) > 0.0 {
                let prev = (prev_delta, prev_pdf, prev_p, prev_n);
                let (le, w) = self.emitted_seen(scene, &hit, ray.time, material, footprint, prev);
                l += beta * le * w;
            }
            if depth >= self.max_depth {
                break;
            }

            let bsdf = material.bsdf(hit.uv, footprint, &scene.textures);
            // Shading frame: opaque surfaces are two-sided, so face the frame towards wo.
            let flip = !bsdf.is_transmissive() && wo_world.dot(hit.ng) < 0.0;
            let sign = if flip { -1.0 } else { 1.0 };
            let ns = sign * shading_normal(scene, &hit, ray.time, material);
            let ng_side = sign * hit.ng;
            let frame = Frame::from_normal(ns);
            let wo = frame.to_local(wo_world);

            // Next-event estimation.
            let nee = !bsdf.is_delta() && self.strategy != Strategy::BsdfOnly;
            let own = scene.lights.chooses_with_own_sample();
            let (uc_light, u_light) = ahead.numbers(rng, nee && own, nee);
            if nee {
                let at = Vertex {
                    hit: &hit,
                    time: ray.time,
                    bsdf: &bsdf,
                    frame: &frame,
                    wo,
                    ns,
                    ng_side,
                };
                let (le, traced) = self.direct_light(scene, &at, beta, uc_light, u_light);
                l += le;
                rays += traced;
            }

            // BSDF sampling (numbers the BSDF ignores are passed over, not computed).
            let (uses_uc, uses_u) = bsdf.sample_uses();
            let uc = rng.uniform_if(uses_uc);
            let u = rng.uniform2_if(uses_u);
            let Some(s) = bsdf.sample(wo, uc, u) else {
                break;
            };
            if s.pdf <= 0.0 {
                break;
            }
            let wi_world = frame.from_local(s.wi);
            // Reject directions on the wrong side of the geometric surface (shading-normal
            // light leaks), unless the BSDF transmits.
            let reflect_geo = wi_world.dot(hit.ng) * wo_world.dot(hit.ng) > 0.0;
            let reflect_local = s.wi.z * wo.z > 0.0;
            if reflect_geo != reflect_local {
                break;
            }
            beta *= s.f * s.wi.z.abs() / s.pdf;
            if !beta.is_finite() || beta.max_element() <= 0.0 {
                break;
            }
            prev_delta = s.delta;
            cone = cone.after(&hit, s.delta);
            prev_pdf = s.pdf;
            prev_p = hit.p;
            prev_n = ns;
            ray = Ray {
                o: offset_origin(hit.p, hit.ng, wi_world),
                d: wi_world,
                t_max: f32::INFINITY,
                time: ray.time,
            };
            depth += 1;

            eta_scale *= s.eta * s.eta;
            if depth >= RR_START_DEPTH {
                let Some(q) = roulette(beta, eta_scale, rng) else {
                    break;
                };
                beta /= q;
            }
        }
        PathResult {
            radiance: l,
            rays,
            first,
        }
    }
}

/// The light sample's numbers (`uc`, `u`) for the vertex the next ray finds, drawn before the
/// ray is cast when the scene has an environment map, which then starts loading the map's
/// bucket for `u` while the ray traverses the BVH ([`Environment::prefetch_sample`]) and its
/// texels once the ray has hit ([`LightAhead::prefetch_texels`]): on a 1k map the bucket and
/// then the texels each missed the last-level cache, one after the other, at every light
/// sample. The same numbers in the same order as drawing them at the vertex; those a vertex
/// would have passed over (a path that ends there, a delta BSDF, a light choice without its
/// own number) are computed and not used.
struct LightAhead<'a>(Option<(&'a Environment, f32, Vec2)>);

impl<'a> LightAhead<'a> {
    /// Draws the numbers if `env` is a map (else nothing: they are drawn at the vertex).
    #[inline]
    fn draw(env: Option<&'a Environment>, rng: &mut impl Sampler) -> Self {
        LightAhead(env.map(|env| {
            let (uc, u) = (rng.uniform(), rng.uniform2());
            env.prefetch_sample(u);
            (env, uc, u)
        }))
    }

    /// Starts loading the texels the map's sample will read, once the bucket has had time.
    #[inline]
    fn prefetch_texels(&self) {
        if let Some((env, _, u)) = self.0 {
            env.prefetch_sample_texels(u);
        }
    }

    /// The numbers drawn ahead, or else drawn now: `uc` if `uses_uc`, `u` if `uses_u` (each
    /// passed over otherwise, [`Sampler::uniform_if`]).
    #[inline]
    fn numbers(&self, rng: &mut impl Sampler, uses_uc: bool, uses_u: bool) -> (f32, Vec2) {
        match self.0 {
            Some((_, uc, u)) => (uc, u),
            None => (rng.uniform_if(uses_uc), rng.uniform2_if(uses_u)),
        }
    }
}

/// Russian roulette (one canonical number from `rng`): the survival probability q, or `None`
/// when the path ends. q follows the throughput `beta` with the refractions' 1/η² compression
/// undone (`eta_scale`, pbrt-v4's etaScale): a path inside glass is not dimmer, only denser;
/// clamped to [0.05, 1]. The survivor's throughput is divided by q.
#[inline]
fn roulette(beta: Vec3, eta_scale: f32, rng: &mut impl Sampler) -> Option<f32> {
    let q = (beta * eta_scale).max_element().clamp(0.05, 1.0);
    (rng.uniform() < q).then_some(q)
}
