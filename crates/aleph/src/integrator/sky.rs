//! Light through one refraction: next-event estimation of the lights at infinity (the sun and
//! the environment) for a point that sees them only through one smooth dielectric surface, such
//! as the floor of a pool under its water.
//!
//! A shadow ray stops at glass, so without this such a point is lit by the sky only where a
//! BSDF-sampled path happens to leave through the surface towards the light: for the 0.53° sun
//! disc about one path in 10⁴–10⁵, each carrying 10⁴–10⁵ times the mean, so the pool's floor
//! stays a scatter of fireflies at any sample count (the bundled Lost Empire's water: about
//! one pixel in 4,000 at 4,096 spp, which held two references of different seeds to a
//! ColorVideoVDP score of 9.78 against each other, 9.99 with those pixels filtered).
//!
//! The estimator is manifold next-event estimation (Hanika, Droske & Fascione 2015) reduced to
//! the case it solves in closed form: one refracting vertex on a plane, a light at infinity.
//! From the point x and a light direction ω_a drawn as usual (pdf p(ω_a)):
//! 1. the shadow ray from x along ω_a meets no opaque surface but some dielectric (it skips
//!    dielectrics and notes them, so a point in the open pays nothing more); then a probe
//!    ray finds the nearest, the refracting surface, and its shading normal n;
//! 2. Snell's law on that plane gives the direction ω_x from x whose refraction leaves along
//!    ω_a; a ray along ω_x must meet a dielectric of the same index and normal at y;
//! 3. a shadow ray from y along ω_a must leave the scene.
//!
//! Radiance leaving the light side along ω_a enters x's side as T·Tf·η²·L (Fresnel
//! transmittance, the material's filter and the η² compression of radiance, Veach 1997 §5.2,
//! η = η_x / η_light), and the refraction maps solid angle as η² cos θ_x dω_x = cos θ_a dω_a
//! (conservation of étendue), so the estimate is
//! f(ω_x) |cos θ(x, ω_x)| T Tf L(ω_a) cos θ_a / (cos θ_x p(ω_a)), the η² cancelling, θ_a and θ_x
//! the angles to n.
//!
//! The paths it estimates are taken away from BSDF sampling (a partition of path space, so
//! nothing is counted twice): a BSDF-sampled path from a vertex x where this estimator ran,
//! through one refraction at y and out to a light at infinity, counts nothing when step 1
//! from x along its exit direction finds a dielectric of y's index and normal and x could have
//! drawn that direction ([`Integrator::estimated_through_glass`]); where step 1 finds anything
//! else, such as an opaque surface on the straight way or a curved surface whose normal
//! differs from y's, the BSDF-sampled path keeps its light as before. The test `light_through_one_refraction_matches_bsdf_sampling` compares both
//! strategies on a pool lit by a sun.

use super::{Integrator, Vertex, shading_normal};
use crate::bsdf::{Bsdf, fresnel_dielectric};
use crate::geometry::{Hit, Ray, offset_origin};
use crate::light::LightSample;
use crate::material::MaterialKind;
use crate::scene::Scene;
use glam::Vec3;

/// Shading normals of two hits count as the same plane when their dot product is at least
/// this (0.08° apart).
const SAME_PLANE: f32 = 1.0 - 1e-6;

/// A smooth dielectric hit: the hit, its shading normal and index (inside / outside) and its
/// transmission filter.
pub(super) struct Glass {
    hit: Hit,
    n: Vec3,
    ior: f32,
    filter: Vec3,
}

/// The closest surface along `ray` when it is a smooth dielectric, else `None`.
fn glass_along(scene: &Scene, ray: &Ray) -> Option<Glass> {
    let hit = scene.geometry.intersect(ray)?;
    let material = &scene.materials[scene.geometry.tris.material(hit.tri as usize) as usize];
    let Bsdf::Dielectric(d) = material.bsdf(hit.uv, &scene.textures) else {
        return None;
    };
    let n = shading_normal(scene, &hit, ray.time, material);
    Some(Glass {
        hit,
        n,
        ior: d.ior,
        filter: d.transmittance,
    })
}

/// The probe of step 2: the dielectric the ray from `p` (geometric normal `ng`) along `w` meets
/// first, if it is one.
fn probe(scene: &Scene, p: Vec3, ng: Vec3, w: Vec3, time: f32) -> Option<Glass> {
    let ray = Ray {
        o: offset_origin(p, ng, w),
        d: w,
        t_max: f32::INFINITY,
        time,
    };
    glass_along(scene, &ray)
}

/// The straight way from `p` (geometric normal `ng`) along `w` to infinity: `Ok(None)` when
/// nothing is in the way, `Ok(Some(glass))` when only dielectrics are (the nearest of them),
/// `Err(())` when an opaque surface is; with the rays traced (1, or 2 through glass).
pub(super) fn straight_way(
    scene: &Scene,
    p: Vec3,
    ng: Vec3,
    w: Vec3,
    time: f32,
) -> (Result<Option<Glass>, ()>, u32) {
    let geo = &scene.geometry;
    let glass = std::cell::Cell::new(false);
    let opaque = |t: u32| {
        let m = &scene.materials[geo.tris.material(t as usize) as usize];
        let dielectric = matches!(m.kind, MaterialKind::Dielectric { .. });
        glass.set(glass.get() || dielectric);
        !dielectric
    };
    if !geo.unoccluded_by(offset_origin(p, ng, w), w, f32::INFINITY, time, opaque) {
        return (Err(()), 1);
    }
    if !glass.get() {
        return (Ok(None), 1);
    }
    (Ok(probe(scene, p, ng, w, time)), 2)
}

impl Integrator {
    /// The light sample `ls` of a light at infinity, whose straight way from vertex `at` meets
    /// only dielectrics, `first` the nearest, estimated through one refraction there (module
    /// docs): (its contribution scaled by the throughput `beta`, rays traced after step 1).
    pub(super) fn sky_through_glass(
        &self,
        scene: &Scene,
        at: &Vertex,
        beta: Vec3,
        ls: &LightSample,
        first: Glass,
    ) -> (Vec3, u32) {
        let (p, ng, time) = (at.hit.p, at.hit.ng, at.time);
        let wa = ls.wi;
        // The light's side of the plane, and η = η_x / η_light.
        let (n_light, eta) = if wa.dot(first.n) > 0.0 {
            (first.n, first.ior)
        } else {
            (-first.n, 1.0 / first.ior)
        };
        let Some(into_x) = crate::math::refract(wa, n_light, eta) else {
            return (Vec3::ZERO, 0);
        };
        let wx = -into_x.normalize();
        if wx.dot(at.ng_side) <= 0.0 {
            return (Vec3::ZERO, 0);
        }
        let wi = at.frame.to_local(wx);
        let f = at.bsdf.eval(at.wo, wi);
        if f.max_element() <= 0.0 {
            return (Vec3::ZERO, 0);
        }
        let Some(y) = probe(scene, p, ng, wx, time) else {
            return (Vec3::ZERO, 1);
        };
        if y.ior != first.ior || y.n.dot(first.n) < SAME_PLANE {
            return (Vec3::ZERO, 1);
        }
        let out = offset_origin(y.hit.p, y.hit.ng, wa);
        if !scene.geometry.unoccluded(out, wa, f32::INFINITY, time) {
            return (Vec3::ZERO, 2);
        }
        let t = 1.0 - fresnel_dielectric((-wx).dot(y.n), y.ior);
        let (cos_a, cos_x) = (wa.dot(y.n).abs(), wx.dot(y.n).abs());
        if cos_x <= 0.0 {
            return (Vec3::ZERO, 2);
        }
        let l = beta * f * wi.z.abs() * y.filter * ls.le * (t * cos_a / (cos_x * ls.pdf));
        (l, 2)
    }

    /// True when the light a BSDF-sampled path brings from infinity along `w`, leaving through
    /// one refraction at a dielectric of index `ior` and shading normal `n` after the
    /// non-delta vertex at `p` (geometric normal `ng`), is already counted by
    /// [`Integrator::sky_through_glass`] at that vertex, when it could draw `w` (module docs:
    /// the partition); with the rays traced.
    pub(super) fn estimated_through_glass(
        &self,
        scene: &Scene,
        (p, ng): (Vec3, Vec3),
        (n, ior): (Vec3, f32),
        w: Vec3,
        time: f32,
    ) -> (bool, u32) {
        let (way, rays) = straight_way(scene, p, ng, w, time);
        let same = matches!(way, Ok(Some(g)) if g.ior == ior && g.n.dot(n) >= SAME_PLANE);
        (same, rays)
    }
}
