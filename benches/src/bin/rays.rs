//! Ray-casting throughput of aleph's BVH on a scene, for `benches/peer/vs_embree_rays.py`,
//! which casts the same rays through Mitsuba 3 (Embree) in a process of its own.
//!
//! ```text
//! cargo run --release -p aleph-benches --bin rays -- SCENE.toml OUT.bin [--resolution WxH] [--rounds N]
//! ```
//!
//! Makes three sets of rays, deterministic for the scene and size: *camera* rays (one per
//! pixel, jittered by PCG32), *bounce* rays (from each camera ray's hit, a cosine-weighted
//! direction about the side of the geometric normal the camera sees: incoherent, as a path's
//! second segment is) and *shadow* rays (from the same hits towards a random point of a
//! 20 × 20 m square 100 m above the scene's centre, occlusion only). Then casts each set
//! `--rounds` times (default 5) in parallel on all cores through `Geometry::intersect`
//! (closest hit, with its hit record) or `Geometry::unoccluded`, and prints each set's rays,
//! hit fraction and median rays per second. `OUT.bin` holds the sets for the peer: a
//! little-endian u32 count, then per ray origin xyz, direction xyz and t_max (7 × f32), then per
//! ray aleph's answer (f32: the hit distance, `inf` for a miss; for shadow rays 1 when
//! unoccluded, 0 when blocked), one set after the other in the order above.

use aleph::geometry::Ray;
use aleph::scene::{Scene, SceneDescription};
use aleph_benches::ray_sets;
use rayon::prelude::*;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    if let Err(e) = run() {
        eprintln!("rays: {e}");
        std::process::exit(1);
    }
}

struct Args {
    scene: PathBuf,
    out: PathBuf,
    resolution: Option<[u32; 2]>,
    rounds: usize,
}

fn args() -> Result<Args, String> {
    let mut a = std::env::args().skip(1);
    let usage = "usage: rays SCENE.toml OUT.bin [--resolution WxH] [--rounds N]";
    let scene = a.next().ok_or(usage)?.into();
    let out = a.next().ok_or(usage)?.into();
    let (mut resolution, mut rounds) = (None, 5);
    while let Some(flag) = a.next() {
        let v = a.next().ok_or(format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--resolution" => {
                let (w, h) = v.split_once('x').ok_or("--resolution is WxH")?;
                let p = |s: &str| s.parse::<u32>().map_err(|e| format!("--resolution: {e}"));
                resolution = Some([p(w)?, p(h)?]);
            }
            "--rounds" => rounds = v.parse().map_err(|e| format!("--rounds: {e}"))?,
            _ => return Err(format!("unknown option {flag}; {usage}")),
        }
    }
    Ok(Args {
        scene,
        out,
        resolution,
        rounds: rounds.max(1),
    })
}

fn run() -> Result<(), String> {
    let a = args()?;
    let mut desc = SceneDescription::read(&a.scene).map_err(|e| e.to_string())?;
    if let Some(r) = a.resolution {
        desc.camera.resolution = r;
    }
    let scene = Scene::load_description(desc).map_err(|e| e.to_string())?;
    let (camera, bounce, shadow) = ray_sets(&scene);
    let geo = &scene.geometry;
    let closest = |r: &Ray| geo.intersect(r).map_or(f32::INFINITY, |h| h.t);
    let clear = |r: &Ray| geo.unoccluded(r.o, r.d, r.t_max, r.time) as u32 as f32;
    let mut file = Vec::new();
    for (name, rays, cast) in [
        ("camera", &camera, &closest as &(dyn Fn(&Ray) -> f32 + Sync)),
        ("bounce", &bounce, &closest),
        ("shadow", &shadow, &clear),
    ] {
        let (answers, rate) = time_set(rays, cast, a.rounds);
        let hits = answers
            .iter()
            .filter(|&&t| {
                if name == "shadow" {
                    t == 0.0
                } else {
                    t.is_finite()
                }
            })
            .count();
        println!(
            "{name}: {} rays, {:.1} % {}, {:.2} M rays/s (median of {} rounds, {} threads)",
            rays.len(),
            100.0 * hits as f64 / rays.len() as f64,
            if name == "shadow" { "blocked" } else { "hit" },
            rate / 1e6,
            a.rounds,
            rayon::current_num_threads()
        );
        write_set(&mut file, rays, &answers);
    }
    let tmp = a.out.with_extension("bin.part");
    std::fs::File::create(&tmp)
        .and_then(|mut f| f.write_all(&file))
        .and_then(|_| std::fs::rename(&tmp, &a.out))
        .map_err(|e| format!("{}: {e}", a.out.display()))
}

/// Casts `rays` `rounds` times in parallel: (the answers, the median rays per second).
fn time_set(rays: &[Ray], cast: &(dyn Fn(&Ray) -> f32 + Sync), rounds: usize) -> (Vec<f32>, f64) {
    let mut answers = Vec::new();
    let mut rates: Vec<f64> = (0..rounds)
        .map(|_| {
            let start = Instant::now();
            answers = rays.par_iter().with_min_len(256).map(cast).collect();
            rays.len() as f64 / start.elapsed().as_secs_f64()
        })
        .collect();
    rates.sort_by(f64::total_cmp);
    (answers, rates[rates.len() / 2])
}

/// Appends a set to the output: its count, its rays, aleph's answers.
fn write_set(out: &mut Vec<u8>, rays: &[Ray], answers: &[f32]) {
    out.extend((rays.len() as u32).to_le_bytes());
    for r in rays {
        for v in [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.t_max] {
            out.extend(v.to_le_bytes());
        }
    }
    for a in answers {
        out.extend(a.to_le_bytes());
    }
}
