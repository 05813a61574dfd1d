//! The bundled Cornell box agrees with an independent reference: Mitsuba 3's `scalar_rgb` path
//! tracer on the same geometry, materials, light and camera (box filter, max depth 64), made by
//! `benches/peer/mitsuba_cornell.py reference` as 16 renders × 4096 spp at 32×32. The file holds
//! the mean (R, G, B) and its standard error (SE.R, SE.G, SE.B, SE.Y) from the spread of the 16
//! renders. Tolerances come from both standard errors.

use crate::util::*;
use aleph::integrator::Strategy;
use aleph::scene::{Scene, SceneDescription};
use std::collections::HashMap;

fn read_reference() -> (usize, usize, HashMap<String, Vec<f32>>) {
    let img =
        exr::prelude::read_all_flat_layers_from_file(repo("tests/data/cornell_mitsuba_32.exr"))
            .expect("reference EXR");
    let layer = &img.layer_data[0];
    let size = layer.size;
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    (size.0, size.1, channels)
}

fn cornell(seed: u64) -> Scene {
    let mut desc = SceneDescription::read(&repo("scenes/cornell-box/scene.toml")).unwrap();
    desc.camera.resolution = [32, 32];
    desc.render.seed = Some(seed);
    // Per-pixel z-tests assume independent samples (σ/√n).
    desc.render.sample_generator = Some(aleph::scene::SampleGenerator::Independent);
    Scene::load_description(desc).unwrap()
}

#[test]
fn cornell_box_matches_mitsuba_reference_per_pixel() {
    let (w, h, r) = read_reference();
    assert_eq!((w, h), (32, 32));
    let film = render(&cornell(11), Strategy::Mis, 1024);
    let n = w * h;
    let z_max = sidak_z(0.01, n);
    let mut worst = (0.0f64, 0usize);
    for (i, p) in film.pixels.iter().enumerate() {
        let ours = aleph::math::luminance(p.mean().as_vec3()) as f64;
        let refy =
            0.2126 * r["R"][i] as f64 + 0.7152 * r["G"][i] as f64 + 0.0722 * r["B"][i] as f64;
        let se = (p.lum_std_error().powi(2) + (r["SE.Y"][i] as f64).powi(2)).sqrt();
        let z = (ours - refy).abs() / se;
        if z > worst.0 {
            worst = (z, i);
        }
    }
    assert!(
        worst.0 <= z_max,
        "pixel ({}, {}) differs from Mitsuba by {:.2} standard errors (limit {z_max:.2})",
        worst.1 % w,
        worst.1 / w,
        worst.0
    );
}

#[test]
fn cornell_box_matches_mitsuba_reference_in_colour() {
    // Whole-image mean of each channel. Our standard error comes from 16 independent renders
    // (different seeds), like the reference's; the difference is referred to Student's t with
    // ≈ 30 degrees of freedom, Bonferroni over 3 channels at 1 %: |t| < 3.3.
    let (_, _, r) = read_reference();
    let k = 16;
    let mut ours = vec![[0f64; 3]; k];
    for (s, o) in ours.iter_mut().enumerate() {
        let rgb = render(&cornell(100 + s as u64), Strategy::Mis, 64).mean_rgb();
        for (c, oc) in o.iter_mut().enumerate() {
            *oc = rgb
                .iter()
                .skip(c)
                .step_by(3)
                .map(|&v| v as f64)
                .sum::<f64>()
                / (rgb.len() / 3) as f64;
        }
    }
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let m = ours.iter().map(|o| o[c]).sum::<f64>() / k as f64;
        let var = ours.iter().map(|o| (o[c] - m).powi(2)).sum::<f64>() / (k - 1) as f64;
        let se_ours = (var / k as f64).sqrt();
        let ref_mean = r[*name].iter().map(|&v| v as f64).sum::<f64>() / r[*name].len() as f64;
        // SE of the reference image mean: per-pixel SEs are correlated through nothing (pixels
        // are independent), so they add in quadrature.
        let se_ref = r[&format!("SE.{name}")]
            .iter()
            .map(|&v| (v as f64).powi(2))
            .sum::<f64>()
            .sqrt()
            / r[*name].len() as f64;
        let t = (m - ref_mean) / (se_ours.powi(2) + se_ref.powi(2)).sqrt();
        assert!(
            t.abs() < 3.3,
            "{name}: aleph {m:.6} vs Mitsuba {ref_mean:.6} (t = {t:.2})"
        );
    }
}
