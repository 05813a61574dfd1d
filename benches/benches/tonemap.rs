//! Every tone operator on a 4K (3840×2160) HDR image: Desk.exr resampled, 1.0 = 100 cd/m².
//! `apply` takes a precomputed adaptation map (local 1° mean); `pipeline` includes computing it
//! (one FFT convolution).

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

use aleph::display::{ToneMapSettings, tone_map};
use aleph_benches::desk_luminance;
use criterion::{Criterion, criterion_group, criterion_main};
use perception::adaptation::{AdaptationMode, adaptation_luminance};
use perception::tmo::{Display, Operator, apply};
use perception::viewing::ViewingConditions;

fn operators(c: &mut Criterion) {
    let (w, h) = (3840, 2160);
    let lum = desk_luminance(w, h);
    // A warm-tinted colour image from the luminance.
    let rgb: Vec<f32> = lum.iter().flat_map(|&l| [1.2 * l, l, 0.6 * l]).collect();
    let view = ViewingConditions::default();
    let adapt =
        adaptation_luminance(&lum, w, h, &view, AdaptationMode::LocalArithmetic, 1.0).unwrap();
    let mut g = c.benchmark_group("tonemap_4k");
    g.sample_size(10);
    for op in Operator::ALL {
        g.bench_function(format!("apply_{}", op.name()), |b| {
            b.iter(|| apply(op, &rgb, w, h, &adapt, &Display::default()).unwrap())
        });
    }
    let raw: Vec<f32> = rgb.iter().map(|v| v / 100.0).collect();
    g.bench_function("pipeline_wrp_local", |b| {
        b.iter(|| tone_map(&raw, w, h, &ToneMapSettings::default()).unwrap())
    });
    g.bench_function("adaptation_local_1deg", |b| {
        b.iter(|| {
            adaptation_luminance(&lum, w, h, &view, AdaptationMode::LocalArithmetic, 1.0).unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, operators);
criterion_main!(benches);
