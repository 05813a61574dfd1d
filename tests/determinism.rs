//! Renders are bit-identical for any thread count and any split of the samples into passes.

use crate::util::*;
use aleph::film::Film;
use aleph::integrator::{Integrator, Strategy};
use aleph::render::render_counts;
use aleph::sampler::SampleStreams;
use aleph::scene::{Scene, SceneDescription};

fn small_cornell() -> Scene {
    let mut desc = SceneDescription::read(&repo("scenes/cornell-box/scene.toml")).unwrap();
    desc.camera.resolution = [24, 20];
    Scene::load_description(desc).unwrap()
}

fn render_on(threads: usize, scene: &Scene, spp: u32) -> Film {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| render(scene, Strategy::Mis, spp))
}

#[test]
fn one_and_two_threads_give_identical_films() {
    let scene = small_cornell();
    let a = render_on(1, &scene, 16);
    let b = render_on(2, &scene, 16);
    assert!(a == b, "films differ between 1 and 2 threads");
    let c = render_on(3, &scene, 16);
    assert!(a == c, "films differ between 1 and 3 threads");
}

#[test]
fn adding_samples_later_continues_each_pixel_stream() {
    let scene = small_cornell();
    let integ = Integrator {
        max_depth: scene.settings.max_depth,
        strategy: Strategy::Mis,
    };
    // The uniform render (a pattern of 12 points per pixel) equals 12 samples added in one
    // pass; each layout continues its pixels' samples across passes.
    let once = render_on(2, &scene, 12);
    for streams in [
        SampleStreams::Fixed(12),
        SampleStreams::Whole,
        SampleStreams::Halves,
    ] {
        let mut single = Film::new(24, 20);
        let n = single.len();
        render_counts(&scene, &integ, &mut single, &vec![12; n], streams, &|_| {});
        if streams == SampleStreams::Fixed(12) {
            assert!(single == once, "render_counts differs from render_uniform");
        }
        // 4 + 8 samples in two passes, with an uneven split across pixels in between.
        let mut film = Film::new(24, 20);
        render_counts(&scene, &integ, &mut film, &vec![4; n], streams, &|_| {});
        let uneven: Vec<u32> = (0..n).map(|i| (i % 3) as u32).collect();
        render_counts(&scene, &integ, &mut film, &uneven, streams, &|_| {});
        let rest: Vec<u32> = uneven.iter().map(|&u| 8 - u).collect();
        render_counts(&scene, &integ, &mut film, &rest, streams, &|_| {});
        assert!(
            film == single,
            "{streams:?}: multi-pass film differs from single pass"
        );
    }
}

#[test]
fn cli_output_is_identical_for_one_and_two_threads() {
    let dir = tempdir();
    let run = |threads: &str, out: &str| {
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_aleph"))
            .args([
                "render",
                "--spp",
                "16",
                // Steered (a budget this small is rendered uniformly by default).
                "--steer-from",
                "0",
                "--resolution",
                "32x24",
                "--threads",
                threads,
                "-o",
            ])
            .arg(dir.path().join(out))
            .arg(repo("scenes/cornell-box/scene.toml"))
            .output()
            .unwrap();
        assert!(
            status.status.success(),
            "{}",
            String::from_utf8_lossy(&status.stderr)
        );
    };
    run("1", "a");
    run("2", "b");
    let read = |f: &str| std::fs::read(dir.path().join(f)).unwrap();
    // Header attribute order may vary (the exr crate keeps them in a HashMap); the pixels of
    // every channel must not.
    let channels = |f: &str| {
        let img = exr::prelude::read_all_flat_layers_from_file(dir.path().join(f)).unwrap();
        img.layer_data[0]
            .channel_data
            .list
            .iter()
            .map(|c| {
                (
                    c.name.to_string(),
                    c.sample_data
                        .values_as_f32()
                        .map(f32::to_bits)
                        .collect::<Vec<_>>(),
                )
            })
            .collect::<Vec<_>>()
    };
    let (a, b) = (channels("a.exr"), channels("b.exr"));
    assert_eq!(
        a.iter().map(|c| c.0.clone()).collect::<Vec<_>>(),
        [
            "B",
            "Depth.Z",
            "Error.Y",
            "G",
            "IndexOB",
            "Normal.X",
            "Normal.Y",
            "Normal.Z",
            "R",
            "Threshold.Y",
            "spp"
        ]
    );
    assert!(a == b, "EXR channels differ");
    assert!(read("a.png") == read("b.png"), "PNG files differ");
}
