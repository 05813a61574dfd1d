//! Threshold map and visible-difference metric on a real HDR photograph (Desk.exr resampled)
//! at 512×512 and 1920×1080, FLIP's default viewing (67 ppd). The goal for the map is
//! 1920×1080 in under 0.25 s on 2 cores. Uses mimalloc, as the aleph binary does: the map
//! allocates large buffers each call and glibc returns them to the OS, so every call would
//! otherwise pay for fresh page faults.

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use aleph_benches::desk_luminance;
use criterion::{Criterion, criterion_group, criterion_main};
use perception::metric::DiffMetric;
use perception::threshold::{ThresholdMapper, ThresholdParams};
use perception::viewing::ViewingConditions;

fn threshold_map(c: &mut Criterion) {
    let mut g = c.benchmark_group("threshold_map");
    g.sample_size(10);
    for (w, h) in [(512, 512), (1920, 1080)] {
        let lum = desk_luminance(w, h);
        let m = ThresholdMapper::new(
            w,
            h,
            ViewingConditions::default(),
            ThresholdParams::default(),
        )
        .unwrap();
        g.bench_function(format!("{w}x{h}"), |b| {
            b.iter(|| m.compute(&lum, None).unwrap())
        });
        let vel: Vec<f32> = (0..w * h)
            .flat_map(|i| [((i % w) as f32 / w as f32) * 8.0, 0.0])
            .collect();
        g.bench_function(format!("{w}x{h}_velocity"), |b| {
            b.iter(|| m.compute(&lum, Some(&vel)).unwrap())
        });
        g.bench_function(format!("{w}x{h}_plan"), |b| {
            b.iter(|| {
                ThresholdMapper::new(
                    w,
                    h,
                    ViewingConditions::default(),
                    ThresholdParams::default(),
                )
                .unwrap()
            })
        });
    }
    g.finish();
}

fn metric(c: &mut Criterion) {
    let mut g = c.benchmark_group("visible_difference");
    g.sample_size(10);
    for (w, h) in [(512, 512), (1920, 1080)] {
        let reference = desk_luminance(w, h);
        let test: Vec<f32> = reference
            .iter()
            .enumerate()
            .map(|(i, &v)| v * (1.0 + 0.1 * (((i * 2_654_435_761) % 1000) as f32 / 500.0 - 1.0)))
            .collect();
        let m = DiffMetric::new(
            w,
            h,
            ViewingConditions::default(),
            ThresholdParams::default(),
            100,
        )
        .unwrap();
        g.bench_function(format!("{w}x{h}"), |b| {
            b.iter(|| m.compare(&reference, &test).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, threshold_map, metric);
criterion_main!(benches);
