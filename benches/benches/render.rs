//! Path-tracer throughput on the bundled Cornell box and BVH build times.
//!
//! `cargo bench -p aleph-benches --bench render`. Throughput is reported by criterion in
//! samples per second (elements = camera samples); the rays per sample of this scene are printed
//! once at the start so rays/s = samples/s × rays/sample.

use aleph::geometry::Geometry;
use aleph::integrator::Strategy;
use aleph::render::render_uniform;
use aleph::scene::{Scene, SceneDescription};
use aleph_benches::{repo, terrain};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

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

criterion_group!(benches, path_tracing, bvh_build);
criterion_main!(benches);
