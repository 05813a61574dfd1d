#![deny(missing_docs)]
//! # aleph
//!
//! A physically based path tracer that renders only what a person can see.
//!
//! The renderer side of the workspace: scene loading ([`scene`]), geometry and the BVH
//! ([`geometry`]), the [`camera`] (pinhole or thin lens), [`bsdf`]s and [`material`]s,
//! [`light`]s (emissive triangles, environment, sun, point and spot, a light BVH), the path
//! tracer ([`integrator`]), the sample buffers ([`film`]), the parallel driver ([`render`]) and
//! image [`output`]. The human-visual-system models live in the `perception` crate.
//!
//! ```no_run
//! use aleph::{scene::Scene, render::render_uniform, integrator::Strategy};
//! let scene = Scene::load(std::path::Path::new("scenes/cornell-box/scene.toml")).unwrap();
//! let (film, stats) = render_uniform(&scene, Strategy::Mis, 16, &|_| {});
//! println!("{} samples, {} rays", stats.samples, stats.rays);
//! let rgb = film.mean_rgb(); // linear radiance, W·sr⁻¹·m⁻², interleaved RGB
//! # let _ = rgb;
//! ```

pub mod adaptive;
pub mod animation;
pub mod bsdf;
mod bvh;
pub mod camera;
#[cfg(test)]
mod chi2;
pub mod deliver;
pub mod denoise;
pub mod display;
pub mod error;
pub mod film;
pub mod gbuffer;
pub mod geometry;
pub mod imageio;
pub mod imaging;
pub mod integrator;
pub mod job;
pub mod light;
pub mod material;
pub mod math;
pub mod output;
pub mod partial;
pub mod render;
pub mod reuse;
pub mod rng;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod sequence;
pub mod texture;
pub mod velocity;
