//! Path-tracer throughput on the bundled Cornell box, BVH build times, and ray casting on the
//! bundled Lost Empire (225k triangles).
//!
//! `cargo bench -p aleph-benches --bench render`. Throughput is reported by criterion in
//! samples per second (elements = camera samples); the rays per sample of this scene are printed
//! once at the start so rays/s = samples/s × rays/sample. The ray-casting group reports rays per
//! second (elements = rays) for the camera, bounce and shadow rays of
//! [`aleph_benches::ray_sets`] at 320×200, cast on all threads; `benches/peer/vs_embree_rays.py`
//! casts the same kind of rays through Embree for comparison.

use aleph::geometry::Geometry;
use aleph::integrator::Strategy;
use aleph::render::render_uniform;
use aleph::scene::{Scene, SceneDescription};
use aleph_benches::{ray_sets, repo, terrain};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rayon::prelude::*;

fn cornell(res: u32) -> Scene {
    let mut desc = SceneDescription::read(&repo("scenes/cornell-box/scene.toml")).unwrap();
    desc.camera.resolution = [res, res];
    Scene::load_description(desc).unwrap()
}

fn path_tracing(c: &mut Criterion) {
    let scene = cornell(128);
    let spp = 8;
    let (_, stats) = render_uniform(&scene, Strategy::Mis, spp, &|_| {});
    println!(
        "cornell 128x128: {:.3} rays per sample",
        stats.rays as f64 / stats.samples as f64
    );
    let mut g = c.benchmark_group("path_tracing");
    g.sample_size(10);
    g.throughput(Throughput::Elements(128 * 128 * spp as u64));
    g.bench_function("cornell_128x128_8spp_mis", |b| {
        b.iter(|| render_uniform(&scene, Strategy::Mis, spp, &|_| {}))
    });
    g.finish();
}

fn bvh_build(c: &mut Criterion) {
    let mut g = c.benchmark_group("bvh_build");
    g.sample_size(10);
    let scene = cornell(8);
    let tris = scene.geometry.tris.clone();
    g.throughput(Throughput::Elements(tris.len() as u64));
    g.bench_function("cornell_36_tris", |b| {
        b.iter(|| Geometry::new(tris.clone()))
    });
    let big = terrain(500); // 500 000 triangles
    g.throughput(Throughput::Elements(big.len() as u64));
    g.bench_function("terrain_500k_tris", |b| {
        b.iter(|| Geometry::new(big.clone()))
    });
    g.finish();
}

fn ray_casting(c: &mut Criterion) {
    let mut desc = SceneDescription::read(&repo("scenes/lost-empire/scene.toml")).unwrap();
    desc.camera.resolution = [320, 200];
    let scene = Scene::load_description(desc).unwrap();
    let geo = &scene.geometry;
    let (camera, bounce, shadow) = ray_sets(&scene);
    let mut g = c.benchmark_group("ray_casting_lost_empire");
    g.sample_size(20);
    for (name, rays) in [("camera", &camera), ("bounce", &bounce)] {
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function(name, |b| {
            b.iter(|| {
                rays.par_iter()
                    .with_min_len(256)
                    .filter(|r| geo.intersect(r).is_some())
                    .count()
            })
        });
    }
    g.throughput(Throughput::Elements(shadow.len() as u64));
    g.bench_function("shadow", |b| {
        b.iter(|| {
            shadow
                .par_iter()
                .with_min_len(256)
                .filter(|r| geo.unoccluded(r.o, r.d, r.t_max, r.time))
                .count()
        })
    });
    g.finish();
}

criterion_group!(benches, path_tracing, bvh_build, ray_casting);
criterion_main!(benches);
