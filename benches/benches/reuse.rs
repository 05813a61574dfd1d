//! Reuse across frames: what a reusing frame costs besides its tracing, at 2 fresh spp with a
//! full window of 15 frames, on the bundled Lost Empire walkthrough at its preview size
//! (240×150; only the camera moves) and the moving-sphere Cornell box (128²; the change test
//! runs).
//!
//! `cargo bench -p aleph-benches --bench reuse`. `reproject` lands every kept sample of the
//! window's 15 frames in frame 15 (docs/reuse.md, step 3: 1.08 M landings on the walk);
//! `test` makes the frame's history from them (steps 4 and 5), as a reusing frame does after
//! each pass. The CLI's summary line reports the two together as "reprojection".

use aleph::adaptive::{AdaptiveSettings, Criterion as Rule, render_reusing};
use aleph::reuse::{ReuseWindow, Reused, window_start};
use aleph::scene::{Scene, SceneDescription};
use aleph::sequence::Sequence;
use aleph_benches::repo;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

/// Window frames (the default `--reuse-window`).
const K: u32 = 15;

fn scene(path: &str, [w, h]: [u32; 2]) -> Scene {
    let mut desc = SceneDescription::read(&repo(path)).unwrap();
    desc.camera.resolution = [w, h];
    Scene::load_description(desc).unwrap()
}

/// Benches frame `K` of `path` at `size` reusing frames 0..K.
fn bench_scene(c: &mut Criterion, name: &str, path: &str, size: [u32; 2]) {
    let scene = scene(path, size);
    let sequence = Sequence::new(&scene, 0, K as i64).unwrap();
    let settings = AdaptiveSettings {
        criterion: Rule::Perceptual,
        budget_spp: Some(2.0),
        ..AdaptiveSettings::default()
    };
    let mut window = ReuseWindow::new(K);
    for f in 0..K as i64 {
        let frame = sequence.frame(f).unwrap();
        window.keep_from(window_start(f, 0, K));
        let (_, own) = render_reusing(&frame.scene, &settings, &window, &|_| {}, &|_| {}).unwrap();
        window.push(own);
    }
    let last = sequence.frame(K as i64).unwrap().scene;
    let (r, _) = render_reusing(&last, &settings, &window, &|_| {}, &|_| {}).unwrap();
    let gbuffer = r.gbuffer.as_ref().unwrap();

    let mut g = c.benchmark_group(name);
    g.sample_size(20);
    g.throughput(Throughput::Elements((size[0] * size[1]) as u64));
    g.bench_function("reproject", |b| b.iter(|| window.reproject(&last, gbuffer)));
    let reprojected = window.reproject(&last, gbuffer);
    g.bench_function("test", |b| {
        b.iter(|| reprojected.test(&r.film, Reused::All))
    });
    g.finish();
}

fn reuse(c: &mut Criterion) {
    bench_scene(
        c,
        "reuse_walk_240x150_2spp",
        "scenes/lost-empire/walk.toml",
        [240, 150],
    );
    bench_scene(
        c,
        "reuse_moving_sphere_box_128x128_2spp",
        "scenes/cornell-motion/scene.toml",
        [128, 128],
    );
}

criterion_group!(benches, reuse);
criterion_main!(benches);
