//! Lights: emissive triangles (one-sided diffuse area emitters), an environment (constant or an
//! equirectangular HDR map), suns (distant discs of finite angular size), and point and spot
//! lights.
//!
//! Next-event estimation picks one light with probability proportional to its emitted power
//! (luminance-weighted; any positive weight keeps the estimator unbiased, power makes it
//! efficient): an emissive triangle's is Y(Le) × area × π; an infinite light's is its radiance
//! times the area π r² of the scene's bounding disc (4π · π r² · mean Y for the environment,
//! π r² · Y(E) for a sun, as pbrt-v4's `Light::Phi`); a point light's 4π Y(I). The lights at
//! infinity take their summed power's share as one group, and within it each is chosen in
//! proportion to the irradiance it can deliver to the shading point's normal (a sun E cos θ,
//! zero below the surface; an environment its irradiance, Ramamoorthi & Hanrahan 2001), which
//! depends on the point: power counts the sky's whole sphere, a surface sees a hemisphere of
//! it cosine-weighted, and a sun behind the surface brings nothing.
//!
//! On a triangle it samples a point uniformly (area pdf 1/A) and converts to solid angle at the
//! receiver: pdf_ω = pdf_A · d² / |cos θ_l| (Veach 1997 eq. 8.10). The environment and suns are
//! sampled in solid angle directly (a constant environment cosine-weighted about the shading
//! normal); point and spot lights are delta lights.

//!
//! One file per light type: [`triangle`], [`environment`], [`sun`], [`point`] (point and spot);
//! [`Light`] is their sum, and [`Lights`] chooses among them (by power, or through the light
//! [`bvh`]). A new light type is a file here, a variant of [`Light`] with its arms in
//! [`Lights::build`] and [`Lights::sample`], and its parameters in the scene file's
//! `[[light]]` table (`scene/schema.rs`, checked in `scene/lights.rs`).

mod bvh;
pub mod environment;
pub mod point;
pub mod sun;
pub mod triangle;

pub use bvh::{LightBounds, LightBvh};
pub use environment::Environment;
pub use point::PointLight;
pub use sun::{SUN_ANGULAR_DIAMETER_DEG, Sun};
pub use triangle::TriangleLight;

use crate::geometry::{Geometry, Triangles};
use crate::material::Material;
use crate::sampling::Distribution1D;
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

impl LightSample {
    /// A sample of a light at infinity: direction `wi` from `p_ref`, radiance `le`, solid-angle
    /// pdf `pdf` (the choice included).
    #[inline]
    pub(crate) fn infinite(p_ref: Vec3, wi: Vec3, le: Vec3, pdf: f32) -> LightSample {
        LightSample {
            p: p_ref + wi,
            n: -wi,
            le,
            wi,
            dist: f32::INFINITY,
            pdf,
            delta: false,
            on_surface: false,
        }
    }
}

/// One light of the scene.
#[derive(Clone, Debug)]
pub enum Light {
    /// An emissive triangle.
    Triangle(TriangleLight),
    /// The environment (at most one; boxed, as the sun, so that the enum stays the size of a
    /// triangle's entry: the triangles are most of the lights and sampling reads them).
    Environment(Box<Environment>),
    /// A sun.
    Sun(Box<Sun>),
    /// A point or spot light.
    Point(PointLight),
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
    /// ([`LightBvh`]) over the emissive triangles, point and spot lights; the lights at
    /// infinity (as a group) and the BVH as a whole by power. Scenes with fewer than
    /// [`MIN_BVH_LIGHTS`] such lights use power selection.
    #[default]
    Bvh,
    /// In proportion to power alone (the lights at infinity as a group, chosen among by their
    /// irradiance at the point, as with the BVH).
    Power,
}

/// Every light of a scene and how next-event estimation chooses among them.
///
/// Lights are numbered for selection: emissive triangles first (light i is the triangle whose
/// `light` index is i), then the environment, then the suns, then the point and spot lights.
#[derive(Clone, Debug)]
pub struct Lights {
    /// The lights, in selection order.
    lights: Vec<Light>,
    /// How many of them are triangles (they come first).
    n_tris: usize,
    /// How many lights at infinity (environment and suns) follow the triangles.
    n_infinite: usize,
    /// Power distribution over every light ([`LightSampler::Power`]).
    dist: Distribution1D,
    /// [`LightSampler::Bvh`]: the BVH and, by power, the choice among the infinite lights
    /// (their entries first) and the BVH (last entry, if any).
    tree: Option<(LightBvh, Distribution1D)>,
    /// The lights at infinity as one group: the interval of the cumulative distribution
    /// (`dist`'s, or the tree's top level) their entries span, and its width, the group's
    /// probability. Within it a light is chosen by the irradiance it delivers at the shading
    /// point ([`Lights::choose_infinite`]).
    infinite_group: (f32, f32),
}

impl Lights {
    /// Collects emissive triangles, assigns their `light` indices, and joins them with `other`
    /// into one power distribution, and, for [`LightSampler::Bvh`] with at least
    /// [`MIN_BVH_LIGHTS`] triangles, point and spot lights, a light BVH over those. `scene_radius`
    /// is the radius of a sphere bounding the scene (world units; for the power of infinite
    /// lights). Returns `None` if nothing emits.
    ///
    /// Power (luminance-weighted, relative): an emissive triangle's Y(Le) × area × π; an
    /// infinite light's radiance times the area π r² of the scene's bounding disc (4π · π r² ·
    /// mean Y for the environment, π r² · Y(E) for a sun, as pbrt-v4's `Light::Phi`); a point
    /// light's 4π Y(I), a spot's 2π Y(I) (1 − (cos θ_start + cos θ_total)/2).
    pub fn build(
        tris: &mut Triangles,
        materials: &[Material],
        textures: &[Texture],
        other: OtherLights,
        scene_radius: f32,
        sampler: LightSampler,
    ) -> Option<Lights> {
        let mut lights = Vec::new();
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
                tris.set_light(i, lights.len() as u32);
                lights.push(Light::Triangle(TriangleLight::new(tris, i as u32)));
                powers.push(p64);
            }
        }
        let n_tris = lights.len();
        let disc = std::f64::consts::PI * (scene_radius as f64).max(1e-6).powi(2);
        let lum = |v: Vec3| crate::math::luminance(v.max(Vec3::ZERO)) as f64;
        if let Some(env) = other.environment {
            powers.push(4.0 * std::f64::consts::PI * disc * env.mean_luminance() as f64);
            lights.push(Light::Environment(Box::new(env)));
        }
        for sun in other.suns {
            powers.push(disc * lum(sun.irradiance));
            lights.push(Light::Sun(Box::new(sun)));
        }
        let n_infinite = lights.len() - n_tris;
        for p in other.points {
            powers.push(p.power_factor() as f64 * lum(p.intensity));
            lights.push(Light::Point(p));
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
        let n_points = lights.len() - n_tris - n_infinite;
        let tree = match sampler {
            LightSampler::Bvh if n_tris + n_points >= MIN_BVH_LIGHTS => {
                Self::tree(tris, &lights, n_tris, n_infinite, &weights)
            }
            LightSampler::Bvh | LightSampler::Power => None,
        };
        let infinite_group = match &tree {
            Some((_, top)) => (top.cdf(0), top.cdf(n_infinite)),
            None => (dist.cdf(n_tris), dist.cdf(n_tris + n_infinite)),
        };
        Some(Lights {
            lights,
            n_tris,
            n_infinite,
            dist,
            tree,
            infinite_group,
        })
    }

    /// The light BVH over triangles, point and spot lights (by relative power `weights`, in
    /// light order), and the power choice among the infinite lights and the BVH.
    fn tree(
        tris: &Triangles,
        lights: &[Light],
        n_tris: usize,
        n_inf: usize,
        weights: &[f32],
    ) -> Option<(LightBvh, Distribution1D)> {
        let mut items: Vec<(u32, LightBounds)> = Vec::new();
        for (li, light) in lights.iter().enumerate() {
            let bounds = match light {
                Light::Triangle(t) => t.bounds(tris, weights[li]),
                Light::Point(p) => p.bounds(weights[li]),
                Light::Environment(_) | Light::Sun(_) => continue,
            };
            items.push((li as u32, bounds));
        }
        let bvh = LightBvh::build(items, weights.len());
        let mut top: Vec<f32> = weights[n_tris..n_tris + n_inf].to_vec();
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

    /// Every light, in selection order.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// The geometry's index of each emissive triangle, in light order.
    pub fn triangle_ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.lights[..self.n_tris].iter().map(|l| match l {
            Light::Triangle(t) => t.tri,
            _ => unreachable!("triangles come first"),
        })
    }

    /// Number of emissive triangles.
    pub fn triangle_count(&self) -> usize {
        self.n_tris
    }

    /// The environment, if any (a scene has at most one).
    #[inline]
    pub fn environment(&self) -> Option<&Environment> {
        self.lights[self.n_tris..self.n_tris + self.n_infinite]
            .iter()
            .find_map(|l| match l {
                Light::Environment(e) => Some(&**e),
                _ => None,
            })
    }

    /// The environment if it is a map (a constant environment is not), whose sampling tables
    /// and texels a path loads ahead of its light samples ([`Environment::prefetch_sample`]).
    #[inline]
    pub fn environment_map(&self) -> Option<&Environment> {
        self.environment().filter(|e| e.is_map())
    }

    /// The suns.
    pub fn suns(&self) -> impl Iterator<Item = &Sun> + '_ {
        self.lights.iter().filter_map(|l| match l {
            Light::Sun(s) => Some(&**s),
            _ => None,
        })
    }

    /// The point and spot lights.
    pub fn points(&self) -> impl Iterator<Item = &PointLight> + '_ {
        self.lights.iter().filter_map(|l| match l {
            Light::Point(p) => Some(p),
            _ => None,
        })
    }

    /// Total emitted power weight (relative units; for statistics).
    pub fn total_power(&self) -> f64 {
        self.dist.total()
    }

    /// True when light reaches rays that leave the scene (an environment or a sun).
    #[inline]
    pub fn has_infinite(&self) -> bool {
        self.n_infinite > 0
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

    /// Chooses a light for point `p` with shading normal `n` (or zero) with the number `u`:
    /// (light number, probability, `u` remapped into the chosen light's share of [0, 1)). With
    /// the light BVH, the group of infinite lights and the tree by power, then a light in the
    /// tree by importance; without it, every light by power. A light at infinity is then chosen
    /// within its group by [`Lights::choose_infinite`]. `None` when the group is chosen and
    /// none of its lights can light the point (its share of `u` gives no light sample: their
    /// contribution there is zero).
    #[inline]
    fn choose(&self, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32, f32)> {
        let (k, pk, ur) = match &self.tree {
            None => self.dist.sample_remap(u),
            Some((_, top)) => top.sample_remap(u),
        };
        let first = if self.tree.is_some() { 0 } else { self.n_tris };
        if (first..first + self.n_infinite).contains(&k) {
            let (c0, c1) = self.infinite_group;
            let ug = ((u - c0) / (c1 - c0)).clamp(0.0, 1.0 - f32::EPSILON);
            let (li, pi, ui) = self.choose_infinite(n, ug)?;
            return Some((li, (c1 - c0) * pi, ui));
        }
        match &self.tree {
            None => Some((k, pk, ur)),
            Some((bvh, _)) => {
                let (li, pb) = bvh.sample(p, n, ur)?;
                Some((li as usize, pk * pb, ur))
            }
        }
    }

    /// Irradiance luminance the light at infinity `k` (0 = the first after the triangles) can
    /// deliver to a surface of normal `n` (zero: its mean over normals).
    #[inline]
    fn infinite_irradiance(&self, k: usize, n: Vec3) -> f32 {
        match &self.lights[self.n_tris + k] {
            Light::Environment(env) => env.irradiance(n),
            Light::Sun(sun) => sun.irradiance_on(n),
            _ => 0.0,
        }
    }

    /// Chooses among the lights at infinity for a point of shading normal `n` (zero: no
    /// normal) with `u`, in proportion to the irradiance each can deliver there
    /// ([`Environment::irradiance`], [`Sun::irradiance_on`]): (light number, probability within
    /// the group, `u` remapped). A sun below the surface is never chosen, and a sun and a sky
    /// share the samples by what they bring to that surface rather than by their power, which
    /// counts the sky's whole sphere. Measured on Lost Empire (depth 8, 3 seeds, relMSE against
    /// a 2048-spp render) under a sun and a constant sky at 320×200: choosing by power with the
    /// sky sampled over the whole sphere 0.00304 / 0.00059 at 16 / 64 spp, this choice 0.00220
    /// / 0.00042, and with the sky sampled cosine-weighted about the normal too 0.00184 /
    /// 0.00035 (Mitsuba 3's `multijitter`, which picks among its emitters uniformly, 0.00176 /
    /// 0.00037); under the bundled sun and Venice-sunset map at 240×150, 0.00409 / 0.00090
    /// against 0.00315 / 0.00066. `None` when no light at infinity reaches the surface.
    #[inline]
    fn choose_infinite(&self, n: Vec3, u: f32) -> Option<(usize, f32, f32)> {
        let total = self.infinite_total(n)?;
        let mut x = u * total;
        let mut chosen = None;
        for k in 0..self.n_infinite {
            let e = self.infinite_irradiance(k, n);
            if e <= 0.0 {
                continue;
            }
            chosen = Some((k, e, x));
            if x < e {
                break;
            }
            x -= e;
        }
        let (k, e, x) = chosen?;
        Some((
            self.n_tris + k,
            e / total,
            (x / e).clamp(0.0, 1.0 - f32::EPSILON),
        ))
    }

    /// The summed irradiance of the lights at infinity at normal `n`; `None` when it is not a
    /// positive finite number (no light at infinity reaches the surface).
    #[inline]
    fn infinite_total(&self, n: Vec3) -> Option<f32> {
        let total: f32 = (0..self.n_infinite)
            .map(|k| self.infinite_irradiance(k, n))
            .sum();
        (total > 0.0 && total.is_finite()).then_some(total)
    }

    /// The probability with which [`Lights::choose`] picks light `li` at (`p`, `n`).
    #[inline]
    fn choice_pmf(&self, p: Vec3, n: Vec3, li: usize) -> f32 {
        let first_inf = self.n_tris;
        if (first_inf..first_inf + self.n_infinite).contains(&li) {
            let Some(total) = self.infinite_total(n) else {
                return 0.0;
            };
            let (c0, c1) = self.infinite_group;
            return (c1 - c0) * self.infinite_irradiance(li - first_inf, n) / total;
        }
        match &self.tree {
            None => self.dist.pmf(li),
            Some((bvh, top)) => top.pmf(self.n_infinite) * bvh.pmf(p, n, li as u32),
        }
    }
    /// A sphere (centre, radius; world units) holding every point [`Lights::sample`] can
    /// return at scene time `time`: the box of the emissive triangles' world vertices and the
    /// point and spot lights' positions, bounded. `None` when a light is at infinity (its
    /// samples have no position).
    pub fn finite_bounds(&self, geo: &Geometry, time: f32) -> Option<(Vec3, f32)> {
        if self.n_infinite > 0 {
            return None;
        }
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for light in &self.lights {
            let points = match light {
                Light::Triangle(t) => t.shape(geo, time).0,
                Light::Point(p) => [p.position; 3],
                Light::Environment(_) | Light::Sun(_) => return None,
            };
            for q in points {
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
        (lo.cmple(hi).all()).then(|| (0.5 * (lo + hi), 0.5 * (hi - lo).length()))
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
            let (li, pmf, _) = self.choose(p_ref, n_ref, uc)?;
            (li, pmf, u)
        } else {
            let (li, pmf, ux) = self.choose(p_ref, n_ref, u.x)?;
            (li, pmf, Vec2::new(ux, u.y))
        };
        match &self.lights[li] {
            Light::Triangle(t) => t.sample_from(pmf, p_ref, u, time, geo, materials, textures),
            Light::Environment(env) => {
                let (wi, le, pdf) = env.sample(u, n_ref)?;
                Some(LightSample::infinite(p_ref, wi, le, pmf * pdf))
            }
            Light::Sun(sun) => Some(sun.sample_from(p_ref, u, pmf)),
            Light::Point(point) => point.sample_from(p_ref, pmf),
        }
    }

    /// Radiance arriving along unit direction `d` from the lights at infinity, every term with
    /// weight 1 and no density computed: what a camera ray or a ray after a delta bounce sees.
    #[inline]
    pub fn infinite_radiance_unweighted(&self, d: Vec3) -> Vec3 {
        self.infinite_radiance(d, Vec3::ZERO, None::<fn(f32) -> f32>)
    }

    /// Radiance arriving along unit direction `d` from the lights at infinity (a ray that left
    /// the scene after a vertex of shading normal `n`, or zero), each term weighted by
    /// `weight(pdf)`, where pdf is the solid-angle density with which [`Lights::sample`] would
    /// have chosen that light and direction at that vertex (for MIS). With `weight` `None`
    /// every term has weight 1 and no density is computed
    /// ([`Lights::infinite_radiance_unweighted`]).
    #[inline]
    pub fn infinite_radiance(&self, d: Vec3, n: Vec3, weight: Option<impl Fn(f32) -> f32>) -> Vec3 {
        let mut l = Vec3::ZERO;
        let first = self.n_tris;
        for (k, light) in self.lights[first..first + self.n_infinite]
            .iter()
            .enumerate()
        {
            let pmf = || self.choice_pmf(Vec3::ZERO, n, first + k);
            match (light, &weight) {
                (Light::Environment(env), Some(weight)) => {
                    let (le, pdf) = env.radiance_and_pdf(d, n);
                    if le.max_element() > 0.0 {
                        l += le * weight(pmf() * pdf);
                    }
                }
                (Light::Environment(env), None) => l += env.radiance(d),
                (Light::Sun(sun), weight) if sun.contains(d) => {
                    l += sun.radiance * weight.as_ref().map_or(1.0, |w| w(pmf() * sun.pdf(d)));
                }
                _ => {}
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
        let Some(Light::Triangle(t)) = self.lights.get(light as usize) else {
            return 0.0;
        };
        match t.area_to_solid_angle(geo, time, p_ref, p_light) {
            Some((area, dist2, cos_l)) => {
                self.choice_pmf(p_ref, n_ref, light as usize) / area * dist2 / cos_l
            }
            None => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_light_is_the_size_of_a_triangle_entry() {
        assert!(std::mem::size_of::<super::Light>() <= 64);
    }
}
