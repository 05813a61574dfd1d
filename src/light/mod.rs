//! Lights: emissive triangles (one-sided diffuse area emitters), an environment (constant or an
//! equirectangular HDR map), suns (distant discs of finite angular size), and point and spot
//! lights.
//!
//! Next-event estimation picks one light with probability proportional to its emitted power
//! (luminance-weighted; any positive weight keeps the estimator unbiased, power makes it
//! efficient): an emissive triangle's is Y(Le) × area × π; an infinite light's is its radiance
//! times the area π r² of the scene's bounding disc (4π · π r² · mean Y for the environment,
//! π r² · Y(E) for a sun, as pbrt-v4's `Light::Phi`); a point light's 4π Y(I).
//!
//! On a triangle it samples a point uniformly (area pdf 1/A) and converts to solid angle at the
//! receiver: pdf_ω = pdf_A · d² / |cos θ_l| (Veach 1997 eq. 8.10). The environment and suns are
//! sampled in solid angle directly; point and spot lights are delta lights.

mod analytic;
mod bvh;
mod environment;

pub use analytic::{PointLight, SUN_ANGULAR_DIAMETER_DEG, Sun};
pub use bvh::{LightBounds, LightBvh};
pub use environment::Environment;

use crate::geometry::{Geometry, Triangles};
use crate::material::Material;
use crate::sampling::{Distribution1D, square_to_uniform_triangle};
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// A light sample: a direction from the receiver and the radiance arriving along it.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Point on the emitter (for an infinite light, a point one unit along `wi`).
    pub p: Vec3,
    /// Unit normal of the emitter at `p` (its emitting side); −`wi` for lights without a
    /// surface.
    pub n: Vec3,
    /// Radiance arriving at the receiver (W·sr⁻¹·m⁻²); for a delta light, the irradiance
    /// I / d² (W·m⁻²) it gives a surface facing it. Zero if the receiver is behind.
    pub le: Vec3,
    /// Unit direction from the receiver to the light.
    pub wi: Vec3,
    /// Distance from the receiver to `p`; infinite for the environment and suns.
    pub dist: f32,
    /// Solid-angle pdf at the receiver (includes the choice of light); for a delta light, the
    /// probability of choosing it.
    pub pdf: f32,
    /// True for point and spot lights (no MIS: BSDF sampling cannot reach them).
    pub delta: bool,
    /// True when `p` lies on a surface (a triangle), so a shadow ray stops short of it.
    pub on_surface: bool,
}

/// The lights that are not triangles, as the scene file gives them.
#[derive(Clone, Debug, Default)]
pub struct OtherLights {
    /// The environment, if any.
    pub environment: Option<Environment>,
    /// Suns.
    pub suns: Vec<Sun>,
    /// Point and spot lights.
    pub points: Vec<PointLight>,
}

/// Fewest lights (emissive triangles, point and spot lights) for which [`LightSampler::Bvh`]
/// builds a tree; with fewer, power selection is used. The tree's importance evaluations cost
/// CPU time: on the Cornell box (2 emissive triangles) they made rendering 1.15× slower (median
/// CPU time of 5 paired runs) for no gain.
pub const MIN_BVH_LIGHTS: usize = 8;

/// How next-event estimation chooses a light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LightSampler {
    /// In proportion to each light's importance at the shading point, through a light BVH
    /// ([`LightBvh`]) over the emissive triangles, point and spot lights; the environment, the
    /// suns and the BVH as a whole by power. Scenes with fewer than [`MIN_BVH_LIGHTS`] such
    /// lights use power selection.
    #[default]
    Bvh,
    /// In proportion to power alone, everywhere the same.
    Power,
}

/// The scene's emitters and the distributions used to choose among them.
///
/// Lights are numbered for selection: emissive triangles first (`tris[i]` is light i), then the
/// environment, then the suns, then the point and spot lights.
#[derive(Clone, Debug)]
pub struct Lights {
    /// Triangle id of each emissive triangle.
    pub tris: Vec<u32>,
    /// World vertices, unit normal and area of each static emissive triangle (as `tris`;
    /// `None` for one that moves), so that sampling does not recompute them.
    shapes: Vec<Option<([Vec3; 3], Vec3, f32)>>,
    /// The environment, suns, point and spot lights.
    pub other: OtherLights,
    /// Power distribution over every light ([`LightSampler::Power`]).
    dist: Distribution1D,
    /// [`LightSampler::Bvh`]: the BVH and, by power, the choice among the infinite lights
    /// (their entries first) and the BVH (last entry, if any).
    tree: Option<(LightBvh, Distribution1D)>,
}

impl Lights {
    /// Collects emissive triangles, assigns their `light` indices, and joins them with `other`
    /// into one power distribution, and, for [`LightSampler::Bvh`] with at least
    /// [`MIN_BVH_LIGHTS`] triangles, point and spot lights, a light BVH over those. `scene_radius`
    /// is the radius of a sphere bounding the scene (world units; for the power of infinite
    /// lights). Returns `None` if nothing emits.
    pub fn build(
        tris: &mut Triangles,
        materials: &[Material],
        textures: &[Texture],
        other: OtherLights,
        scene_radius: f32,
        sampler: LightSampler,
    ) -> Option<Lights> {
        let mut ids = Vec::new();
        let mut powers: Vec<f64> = Vec::new();
        for i in 0..tris.len() {
            tris.set_light(i, u32::MAX);
            let t = tris.get(i);
            let m = &materials[t.material as usize];
            let Some(e) = &m.emission else { continue };
            let y = crate::math::luminance(e.mean(textures).max(Vec3::ZERO));
            // In f64: the power of a bright, large emitter overflows f32 and that of a faint,
            // tiny one underflows it; such lights must not silently vanish.
            let p64 = y as f64 * t.area() as f64 * std::f64::consts::PI;
            if p64 > 0.0 && p64.is_finite() {
                tris.set_light(i, ids.len() as u32);
                ids.push(i as u32);
                powers.push(p64);
            }
        }
        let disc = std::f64::consts::PI * (scene_radius as f64).max(1e-6).powi(2);
        let lum = |v: Vec3| crate::math::luminance(v.max(Vec3::ZERO)) as f64;
        if let Some(env) = &other.environment {
            powers.push(4.0 * std::f64::consts::PI * disc * env.mean_luminance() as f64);
        }
        for sun in &other.suns {
            powers.push(disc * lum(sun.irradiance));
        }
        for p in &other.points {
            powers.push(p.power_factor() as f64 * lum(p.intensity));
        }
        let max = powers.iter().copied().fold(0.0, f64::max);
        if !(max > 0.0 && max.is_finite()) {
            return None;
        }
        // Relative weights, which f32 holds whatever the absolute scale. A light of zero power
        // (a black environment) keeps a tiny weight so that it stays a valid choice.
        let weights: Vec<f32> = powers
            .iter()
            .map(|&p| ((p / max) as f32).max(f32::MIN_POSITIVE))
            .collect();
        let dist = Distribution1D::new(weights.clone())?;
        let tree = match sampler {
            LightSampler::Power => None,
            LightSampler::Bvh if ids.len() + other.points.len() >= MIN_BVH_LIGHTS => {
                Self::tree(tris, &ids, &other, &weights)
            }
            LightSampler::Bvh => None,
        };
        let shapes = ids
            .iter()
            .map(|&i| {
                let i = i as usize;
                (tris.instance(i) == crate::geometry::STATIC_INSTANCE)
                    .then(|| triangle_shape(tris.positions(i)))
            })
            .collect();
        Some(Lights {
            tris: ids,
            shapes,
            other,
            dist,
            tree,
        })
    }

    /// The light BVH over triangles, point and spot lights (by relative power `weights`, in
    /// light order), and the power choice among the infinite lights and the BVH.
    fn tree(
        tris: &Triangles,
        ids: &[u32],
        other: &OtherLights,
        weights: &[f32],
    ) -> Option<(LightBvh, Distribution1D)> {
        let n_inf = other.environment.is_some() as usize + other.suns.len();
        let mut items: Vec<(u32, LightBounds)> = Vec::new();
        for (li, &tri) in ids.iter().enumerate() {
            let t = tris.get(tri as usize);
            let (lo, hi) = (
                t.p[0].min(t.p[1]).min(t.p[2]),
                t.p[0].max(t.p[1]).max(t.p[2]),
            );
            // A moving emitter's triangle is in rest space: any direction, any nearby place,
            // importance never zero (unbiased, if less sharp).
            let moving = t.instance != crate::geometry::STATIC_INSTANCE;
            items.push((
                li as u32,
                LightBounds {
                    lo,
                    hi,
                    phi: weights[li],
                    w: t.geometric_normal(),
                    cos_o: if moving { -1.0 } else { 1.0 },
                    cos_e: if moving { -1.0 } else { 0.0 },
                    two_sided: false,
                },
            ));
        }
        let first_point = ids.len() + n_inf;
        for (k, p) in other.points.iter().enumerate() {
            let li = first_point + k;
            let (w, cos_o, cos_e) = match p.spot {
                None => (Vec3::Y, -1.0, 0.0),
                Some((axis, cos_total, cos_start)) => {
                    (axis, cos_start, (cos_total.acos() - cos_start.acos()).cos())
                }
            };
            items.push((
                li as u32,
                LightBounds {
                    lo: p.position,
                    hi: p.position,
                    phi: weights[li],
                    w,
                    cos_o,
                    cos_e,
                    two_sided: false,
                },
            ));
        }
        let bvh = LightBvh::build(items, weights.len());
        let mut top: Vec<f32> = weights[ids.len()..ids.len() + n_inf].to_vec();
        if let Some(b) = &bvh {
            top.push(b.power().max(f32::MIN_POSITIVE));
        }
        let top = Distribution1D::new(top)?;
        bvh.map(|b| (b, top))
    }

    /// Number of lights (emissive triangles, environment, suns, point and spot lights).
    pub fn len(&self) -> usize {
        self.dist.len()
    }

    /// True when there are no emitters (never for a built set).
    pub fn is_empty(&self) -> bool {
        self.dist.is_empty()
    }

    /// Total emitted power weight (relative units; for statistics).
    pub fn total_power(&self) -> f64 {
        self.dist.total()
    }

    /// True when light reaches rays that leave the scene (an environment or a sun).
    #[inline]
    pub fn has_infinite(&self) -> bool {
        self.other.environment.is_some() || !self.other.suns.is_empty()
    }

    #[inline]
    fn env_index(&self) -> usize {
        self.tris.len()
    }

    #[inline]
    fn sun_index(&self, k: usize) -> usize {
        self.tris.len() + self.other.environment.is_some() as usize + k
    }

    /// True when [`Lights::sample`] chooses the light with a number of its own (`uc`): with the
    /// light BVH. Otherwise the choice reuses the first coordinate of the point's 2-D sample
    /// and remaps it into the chosen light's share of [0, 1), as Mitsuba 3's
    /// `Scene::sample_emitter_direction` does, so the 2-D sample stays stratified over the
    /// whole set of emitters rather than over each emitter separately (a quad light made of
    /// two triangles is sampled as one quad). Measured on the Cornell box (256², 64 spp,
    /// depth 8, seeds 1–4, against a 2048-spp render): relMSE 1.1–2.2 % lower. The BVH keeps
    /// its own number: each of its levels remaps the coordinate again and would leave the
    /// point on a light chosen ten levels down with a coarse grid of positions.
    #[inline]
    pub fn chooses_with_own_sample(&self) -> bool {
        self.tree.is_some()
    }

    /// Chooses a light for point `p` with normal `n` with the number `uc`: (light number,
    /// probability). With the light BVH, the infinite lights and the tree by power, then a
    /// light in the tree by importance; without it, by power ([`Lights::sample`] passes the
    /// point's first coordinate as `uc` then).
    #[inline]
    fn choose(&self, p: Vec3, n: Vec3, uc: f32) -> Option<(usize, f32)> {
        match &self.tree {
            None => Some(self.dist.sample(uc)),
            Some((bvh, top)) => {
                let (k, pk, u) = top.sample_remap(uc);
                let n_inf = top.len() - 1;
                if k < n_inf {
                    return Some((self.tris.len() + k, pk));
                }
                let (li, pb) = bvh.sample(p, n, u)?;
                Some((li as usize, pk * pb))
            }
        }
    }

    /// The probability with which [`Lights::choose`] picks light `li` at (`p`, `n`).
    #[inline]
    fn choice_pmf(&self, p: Vec3, n: Vec3, li: usize) -> f32 {
        match &self.tree {
            None => self.dist.pmf(li),
            Some((bvh, top)) => {
                let n_inf = top.len() - 1;
                let first_inf = self.tris.len();
                if (first_inf..first_inf + n_inf).contains(&li) {
                    top.pmf(li - first_inf)
                } else {
                    top.pmf(n_inf) * bvh.pmf(p, n, li as u32)
                }
            }
        }
    }

    /// Samples a light as seen from `p_ref` (shading normal `n_ref`, or zero) at scene time
    /// `time` (moving emitters are where they are then). `u` gives the point or direction on
    /// the light; `uc` chooses the light when [`Lights::chooses_with_own_sample`], else `u.x`
    /// chooses it and is remapped (`uc` is then ignored). Returns `None` for a degenerate
    /// configuration (zero distance, grazing, a pole of the environment) or when no light can
    /// reach `p_ref`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn sample(
        &self,
        p_ref: Vec3,
        n_ref: Vec3,
        uc: f32,
        u: Vec2,
        time: f32,
        geo: &Geometry,
        materials: &[Material],
        textures: &[Texture],
    ) -> Option<LightSample> {
        let (li, pmf, u) = if self.chooses_with_own_sample() {
            let (li, pmf) = self.choose(p_ref, n_ref, uc)?;
            (li, pmf, u)
        } else {
            let (li, pmf) = self.choose(p_ref, n_ref, u.x)?;
            (li, pmf, Vec2::new(self.dist.remap(li, u.x), u.y))
        };
        if li < self.tris.len() {
            return self.sample_triangle(li, pmf, p_ref, u, time, geo, materials, textures);
        }
        let mut k = li - self.tris.len();
        let infinite = |wi: Vec3, le: Vec3, pdf: f32| LightSample {
            p: p_ref + wi,
            n: -wi,
            le,
            wi,
            dist: f32::INFINITY,
            pdf,
            delta: false,
            on_surface: false,
        };
        if let Some(env) = &self.other.environment {
            if k == 0 {
                let (wi, le, pdf) = env.sample(u)?;
                return Some(infinite(wi, le, pmf * pdf));
            }
            k -= 1;
        }
        if let Some(sun) = self.other.suns.get(k) {
            let (wi, pdf) = sun.sample(u);
            return Some(infinite(wi, sun.radiance, pmf * pdf));
        }
        let light = &self.other.points[k - self.other.suns.len()];
        let d = light.position - p_ref;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        Some(LightSample {
            p: light.position,
            n: -wi,
            le: light.intensity_towards(-wi) / dist2,
            wi,
            dist,
            pdf: pmf,
            delta: true,
            on_surface: false,
        })
    }

    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn sample_triangle(
        &self,
        li: usize,
        pmf: f32,
        p_ref: Vec3,
        u: Vec2,
        time: f32,
        geo: &Geometry,
        materials: &[Material],
        textures: &[Texture],
    ) -> Option<LightSample> {
        let tri = self.tris[li];
        let (v, n, area) = self.shape(li, geo, tri, time);
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
        let le = materials[material as usize].emitted(uv, textures);
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

    /// Radiance arriving along unit direction `d` from the lights at infinity (a ray that left
    /// the scene), each term weighted by `weight(pdf)`, where pdf is the solid-angle density
    /// with which [`Lights::sample`] would have chosen that light and direction (for MIS).
    #[inline]
    pub fn infinite_radiance(&self, d: Vec3, weight: impl Fn(f32) -> f32) -> Vec3 {
        let mut l = Vec3::ZERO;
        if let Some(env) = &self.other.environment {
            let le = env.radiance(d);
            if le.max_element() > 0.0 {
                let pmf = self.choice_pmf(Vec3::ZERO, Vec3::ZERO, self.env_index());
                l += le * weight(pmf * env.pdf(d));
            }
        }
        for (k, sun) in self.other.suns.iter().enumerate() {
            if sun.contains(d) {
                let pmf = self.choice_pmf(Vec3::ZERO, Vec3::ZERO, self.sun_index(k));
                l += sun.radiance * weight(pmf * sun.pdf(d));
            }
        }
        l
    }

    /// Solid-angle pdf with which [`Lights::sample`] would pick point `p_light` on emitter
    /// triangle `tri` (whose `light` index is set) from `p_ref` with normal `n_ref` at scene time
    /// `time`.
    #[inline]
    pub fn pdf(
        &self,
        geo: &Geometry,
        tri: u32,
        time: f32,
        (p_ref, n_ref): (Vec3, Vec3),
        p_light: Vec3,
    ) -> f32 {
        let light = geo.tris.light(tri as usize);
        if light == u32::MAX {
            return 0.0;
        }
        let (_, n, area) = self.shape(light as usize, geo, tri, time);
        let d = p_light - p_ref;
        let dist2 = d.length_squared();
        let cos_l = (-d.dot(n) / dist2.sqrt()).max(0.0);
        if cos_l <= 1e-7 || area <= 0.0 {
            return 0.0;
        }
        self.choice_pmf(p_ref, n_ref, light as usize) / area * dist2 / cos_l
    }
}

/// A triangle's vertices, unit normal (from the winding) and area.
#[inline]
fn triangle_shape(v: [Vec3; 3]) -> ([Vec3; 3], Vec3, f32) {
    let cross = (v[1] - v[0]).cross(v[2] - v[0]);
    (
        v,
        crate::math::robust_normalize(cross),
        0.5 * crate::math::robust_length(cross),
    )
}

impl Lights {
    /// Emitter `li` (triangle `tri`) at scene time `time`: its world vertices, unit normal and
    /// area (stored for a static triangle, computed for a moving one).
    #[inline]
    fn shape(&self, li: usize, geo: &Geometry, tri: u32, time: f32) -> ([Vec3; 3], Vec3, f32) {
        match self.shapes[li] {
            Some(s) => s,
            None => triangle_shape(geo.world_vertices(tri, time)),
        }
    }
}
