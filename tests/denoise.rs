//! `aleph render --denoise` (Intel Open Image Denoise). Without the `denoise` feature the flag
//! is refused before any work with the command that builds it; with it (CI builds it:
//! `eval "$(bash scripts/oidn.sh)" && cargo test --release --features denoise --test tests
//! denoise`) the render's EXR holds the denoised RGB, the raw render as `Noisy.R/G/B` equal to
//! the render without `--denoise`, and the auxiliary images in range, and the denoised image
//! is nearer a high-sample reference than the raw one.

use crate::util::{repo, tempdir};
use std::path::Path;
use std::process::Command;

fn aleph(args: &[&str], cwd: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_aleph"))
        .current_dir(cwd)
        .args(args)
        .output()
        .unwrap()
}

/// Runs `aleph render` of the Cornell box at 4 spp with `flags`, which it must refuse before
/// rendering (exit 2, no scene loaded, nothing written); returns its error output.
fn refused(flags: &[&str]) -> String {
    let d = tempdir();
    let scene = repo("scenes/cornell-box/scene.toml");
    let mut args = vec!["render", scene.to_str().unwrap(), "--spp", "4", "-o", "x"];
    args.extend(flags);
    let o = aleph(&args, d.path());
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(!e.contains("triangles"), "{e}");
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
    e
}

#[cfg(not(feature = "denoise"))]
#[test]
fn without_the_feature_denoise_is_refused_with_the_way_to_build_it() {
    let e = refused(&["--denoise"]);
    assert!(
        e.contains("--denoise") && e.contains("--features denoise") && e.contains("oidn.sh"),
        "{e}"
    );
}

#[test]
fn a_denoise_quality_without_denoising_is_refused() {
    let e = refused(&["--denoise-quality", "fast"]);
    assert!(
        e.contains("--denoise-quality") && e.contains("add --denoise"),
        "{e}"
    );
}

/// The auxiliary images' albedo and normal of `scene`, each pixel the mean of
/// `spp` first-surface samples at independent uniform positions in the pixel (plain jitter, the
/// layout before 2026-11-29), under `seed`.
pub(crate) fn jittered_aux(
    scene: &aleph::scene::Scene,
    spp: u32,
    seed: u64,
) -> (Vec<f32>, Vec<f32>) {
    let w = scene.camera.width as usize;
    let n = w * scene.camera.height as usize;
    let (mut albedo, mut normal) = (vec![0f32; 3 * n], vec![0f32; 3 * n]);
    for i in 0..n {
        let (x, y) = ((i % w) as u32, (i / w) as u32);
        for k in 0..spp as u64 {
            let mut rng = aleph::rng::Rng::for_sample(seed, i as u64, k);
            let ray = scene.camera_ray(seed, (x, y), k, rng.uniform2(), 0.0);
            let first = aleph::integrator::first_surface(scene, ray, &mut rng);
            let (a, nn) = (first.albedo, first.normal);
            // As `render_aux`: an emitter's capped radiance scaled to luminance 1, then [0, 1].
            let l = aleph::math::luminance(a);
            let a = if l > 1.0 { a / l } else { a }.clamp(glam::Vec3::ZERO, glam::Vec3::ONE);
            for c in 0..3 {
                albedo[3 * i + c] += a[c] / spp as f32;
                normal[3 * i + c] += nn[c] / spp as f32;
            }
        }
    }
    (albedo, normal)
}

/// The auxiliary images take their samples at stratified positions (each power-of-two prefix
/// a net over the pixel) and all of `AUX_SPP` only on either side of an edge: against a 1024-sample
/// reference (plain jitter) their albedo and normal are nearer than 16 plainly jittered samples
/// per pixel, by more than a third in RMS (measured 3.3× / 3.0× nearer at 64², 2.9× / 2.9× at
/// 256²); 16 plainly jittered samples at every pixel, the layout before, fail (0.94× / 1.00×).
#[test]
fn the_auxiliary_images_are_stratified_and_as_near_their_reference_with_fewer_samples() {
    let mut job = aleph::job::RenderJob::new(repo("scenes/cornell-box/scene.toml"));
    job.scene.resolution = Some([64, 64]);
    let scene = job.load_scene().unwrap();
    let (ref_a, ref_n) = jittered_aux(&scene, 1024, 77);
    let (old_a, old_n) = jittered_aux(&scene, aleph::denoise::AUX_SPP, 5);
    let aux = aleph::denoise::render_aux(&scene, aleph::denoise::AUX_SPP, 5);
    let rms = |a: &[f32], b: &[f32]| {
        let s: f64 = a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum();
        (s / a.len() as f64).sqrt()
    };
    let (a_new, a_old) = (rms(&aux.albedo, &ref_a), rms(&old_a, &ref_a));
    let (n_new, n_old) = (rms(&aux.normal, &ref_n), rms(&old_n, &ref_n));
    assert!(
        a_new < 0.67 * a_old && n_new < 0.67 * n_old,
        "albedo RMS {a_new:.5} against plain jitter's {a_old:.5}, normal {n_new:.5} against {n_old:.5}"
    );
    // The same images for the same seed.
    assert_eq!(
        aux,
        aleph::denoise::render_aux(&scene, aleph::denoise::AUX_SPP, 5)
    );
}

/// On a textured scene the auxiliary images take all `AUX_SPP` samples only where a texture
/// changes sharply within a pixel: on the holodeck (its walls one textured material under a
/// grid of thin lines) a pixel whose first 4 samples agree in normal and within
/// `AUX_TEXTURE_AGREE` in albedo keeps them. Measured at 128×85: 83 % of the samples of 16 in
/// every pixel, where the layout before (every channel within one 8-bit step) took 94 %, and the
/// albedo 3.6× and the normal 2.0× nearer a 1024-sample reference than 16 plainly jittered
/// samples (the layout before: 0.00991 against 0.00998 albedo RMS now, the normal the same).
#[test]
fn a_textured_surface_keeps_its_first_auxiliary_samples_where_its_texture_changes_little() {
    let mut job = aleph::job::RenderJob::new(repo("scenes/holodeck/scene.toml"));
    job.scene.resolution = Some([128, 85]);
    let scene = job.load_scene().unwrap();
    let spp = aleph::denoise::AUX_SPP;
    let (ref_a, ref_n) = jittered_aux(&scene, 1024, 77);
    let (plain_a, plain_n) = jittered_aux(&scene, spp, 5);
    let (aux, taken) = aleph::denoise::render_aux_counted(&scene, spp, 5);
    let rms = |a: &[f32], b: &[f32]| {
        let s: f64 = a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum();
        (s / a.len() as f64).sqrt()
    };
    let share = taken as f64 / (spp as f64 * 128.0 * 85.0);
    let (a, a_plain) = (rms(&aux.albedo, &ref_a), rms(&plain_a, &ref_a));
    let (n, n_plain) = (rms(&aux.normal, &ref_n), rms(&plain_n, &ref_n));
    eprintln!("share {share:.3}, albedo {a:.5} / {a_plain:.5}, normal {n:.5} / {n_plain:.5}");
    assert!(share < 0.9, "took {share:.3} of {spp} samples a pixel");
    assert!(
        a < 0.5 * a_plain && n < 0.67 * n_plain,
        "albedo RMS {a:.5} against plain jitter's {a_plain:.5}, normal {n:.5} against {n_plain:.5}"
    );
}

#[cfg(feature = "denoise")]
mod with_oidn {
    use super::*;
    use aleph::imageio::read_exr_raw;

    fn render(dir: &Path, stem: &str, spp: &str, extra: &[&str]) -> aleph::imageio::RawExr {
        let scene = repo("scenes/cornell-box/scene.toml");
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "--sampler",
            "uniform",
            "--resolution",
            "64x64",
            "--spp",
            spp,
            "-o",
            stem,
        ];
        args.extend(extra);
        let o = aleph(&args, dir);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        // The summary says whether the image was denoised.
        let said = String::from_utf8_lossy(&o.stdout).contains("denoised by Open Image Denoise");
        assert_eq!(said, extra.contains(&"--denoise"));
        read_exr_raw(&dir.join(format!("{stem}.exr"))).unwrap()
    }

    /// Runs `aleph` with `args` (naming its output `-o STEM`) in `dir`, which must succeed;
    /// returns the EXR it wrote and what it printed.
    fn run_exr(dir: &Path, args: &[&str]) -> (aleph::imageio::RawExr, String) {
        let o = aleph(args, dir);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stem = args[args.iter().position(|a| *a == "-o").unwrap() + 1];
        let exr = read_exr_raw(&dir.join(format!("{stem}.exr"))).unwrap();
        (exr, String::from_utf8_lossy(&o.stdout).into_owned())
    }

    fn channel<'a>(raw: &'a aleph::imageio::RawExr, name: &str) -> &'a [f32] {
        raw.f32s
            .get(name)
            .unwrap_or_else(|| panic!("no channel {name}"))
    }

    /// Relative mean squared error over R, G, B against `reference`: mean of
    /// (a − b)² / (b² + 0.01), the denoising literature's relMSE (Rousselle et al. 2011), so
    /// that the bright light's edge does not outweigh the rest of the image.
    fn rel_mse(
        raw: &aleph::imageio::RawExr,
        prefix: &str,
        reference: &aleph::imageio::RawExr,
    ) -> f64 {
        let mut s = 0.0;
        let mut n = 0;
        for c in ["R", "G", "B"] {
            let name = format!("{prefix}{c}");
            for (a, b) in channel(raw, &name).iter().zip(channel(reference, c)) {
                let (a, b) = (*a as f64, *b as f64);
                s += (a - b).powi(2) / (b * b + 0.01);
                n += 1;
            }
        }
        s / n as f64
    }

    #[test]
    fn the_denoised_render_keeps_the_raw_one_and_is_nearer_the_reference() {
        let d = tempdir();
        let denoised = render(d.path(), "d", "4", &["--denoise"]);
        let plain = render(d.path(), "p", "4", &[]);
        let reference = render(d.path(), "r", "1024", &[]);
        // The raw render is kept bit for bit.
        for c in ["R", "G", "B"] {
            let noisy = channel(&denoised, &format!("Noisy.{c}"));
            assert!(
                noisy
                    .iter()
                    .zip(channel(&plain, c))
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "Noisy.{c} differs from the render without --denoise"
            );
            assert!(
                channel(&denoised, c)
                    .iter()
                    .all(|v| v.is_finite() && *v >= 0.0)
            );
        }
        for c in ["R", "G", "B"] {
            let a = channel(&denoised, &format!("Denoising Albedo.{c}"));
            assert!(
                a.iter().all(|v| (0.0..=1.0).contains(v)),
                "albedo {c} out of [0, 1]"
            );
        }
        let n: Vec<&[f32]> = ["X", "Y", "Z"]
            .iter()
            .map(|c| channel(&denoised, &format!("Denoising Normal.{c}")))
            .collect();
        for (i, ((x, y), z)) in n[0].iter().zip(n[1]).zip(n[2]).enumerate() {
            let len = (x * x + y * y + z * z).sqrt();
            assert!(len <= 1.0 + 1e-4, "normal length {len} at {i}");
        }
        // The reference's own noise at 1024 spp is 1/256 of the 4-spp image's variance, so the
        // raw image's squared error is essentially its variance; the denoiser must take most of
        // it away.
        let raw = rel_mse(&denoised, "Noisy.", &reference);
        let den = rel_mse(&denoised, "", &reference);
        eprintln!("relMSE against 1024 spp: raw {raw:.4}, denoised {den:.4}");
        assert!(den < raw / 3.0, "denoised relMSE {den} against raw {raw}");
        // The metadata names the model that ran: the large one for clean auxiliaries at 4 spp
        // against the 16-spp auxiliary images, the high one without `cleanAux` above 16.
        assert!(
            denoised.text["denoiser"].contains("cleanAux true"),
            "{}",
            denoised.text["denoiser"]
        );
        let above = render(d.path(), "a", "32", &["--denoise"]);
        assert!(
            above.text["denoiser"].contains("quality high, cleanAux false"),
            "{}",
            above.text["denoiser"]
        );
    }

    /// The layers `prefix`R/G/B (or X/Y/Z) of `raw` interleaved, as the denoiser takes them.
    fn interleaved(raw: &aleph::imageio::RawExr, prefix: &str, names: [&str; 3]) -> Vec<f32> {
        let c: Vec<&[f32]> = names
            .iter()
            .map(|n| channel(raw, &format!("{prefix}{n}")))
            .collect();
        (0..c[0].len())
            .flat_map(|i| [c[0][i], c[1][i], c[2][i]])
            .collect()
    }

    #[test]
    fn the_library_denoises_again_to_the_same_bits_and_its_fast_model_denoises_too() {
        let d = tempdir();
        let denoised = render(d.path(), "d", "4", &["--denoise"]);
        let reference = render(d.path(), "r", "1024", &[]);
        let noisy = interleaved(&denoised, "Noisy.", ["R", "G", "B"]);
        let aux = aleph::denoise::Aux {
            albedo: interleaved(&denoised, "Denoising Albedo.", ["R", "G", "B"]),
            normal: interleaved(&denoised, "Denoising Normal.", ["X", "Y", "Z"]),
        };
        let shown = interleaved(&denoised, "", ["R", "G", "B"]);
        // The process's one device, used twice, gives what a fresh process gave (the CLI's,
        // which picked the model for 4 spp against 16-spp auxiliaries: the large one).
        use aleph::denoise::{AUX_SPP, Quality, denoise_with};
        let model = Quality::final_for(4.0, AUX_SPP);
        assert_eq!(model, Quality::HighCleanAux);
        for _ in 0..2 {
            let again = denoise_with(&noisy, 64, 64, &aux, model).unwrap();
            assert!(
                again
                    .iter()
                    .zip(&shown)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            );
        }
        // OIDN hears `cleanAux`: without it the high model gives another image (the `oidn`
        // crate's own setting of it never reached OIDN, and the two were the same bits).
        let noisy_aux = denoise_with(&noisy, 64, 64, &aux, Quality::High).unwrap();
        assert!(noisy_aux.iter().zip(&shown).any(|(a, b)| a != b));
        // The fast model (the preview's refinements) takes most of the noise away too.
        let fast = denoise_with(&noisy, 64, 64, &aux, Quality::Fast).unwrap();
        assert!(fast.iter().all(|v| v.is_finite() && *v >= 0.0));
        let refl = interleaved(&reference, "", ["R", "G", "B"]);
        let rel = |img: &[f32]| {
            let s: f64 = img
                .iter()
                .zip(&refl)
                .map(|(&a, &b)| (a as f64 - b as f64).powi(2) / ((b as f64).powi(2) + 0.01))
                .sum();
            s / img.len() as f64
        };
        let (raw, high, fast) = (rel(&noisy), rel(&shown), rel(&fast));
        eprintln!("relMSE against 1024 spp: raw {raw:.4}, high {high:.4}, fast {fast:.4}");
        assert!(
            fast < raw / 3.0,
            "fast model's relMSE {fast} against raw {raw}"
        );
        // `--denoise-quality fast` denoises the result by that model: the same bits, and
        // the EXR's metadata says so.
        let chosen = render(
            d.path(),
            "f",
            "4",
            &["--denoise", "--denoise-quality", "fast"],
        );
        let fast_shown = interleaved(&chosen, "", ["R", "G", "B"]);
        let fast_again = denoise_with(&noisy, 64, 64, &aux, Quality::Fast).unwrap();
        assert!(
            fast_shown
                .iter()
                .zip(&fast_again)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        assert!(
            chosen.text["denoiser"].contains("quality fast"),
            "{}",
            chosen.text["denoiser"]
        );
    }

    #[test]
    fn above_16_spp_the_noisy_image_is_blended_back_by_the_errors_and_nearer_the_truth() {
        // The holodeck at 96 × 64 and 64 spp: the denoiser (its high model; the auxiliary
        // images have 16 spp) blurs the grid's thin lines and keeps a grain of its own where
        // the raw image is nearly clean. The result blends the raw image back in by the two
        // images' estimated errors (aleph::denoise::Denoised::blend_with_noisy) and must be
        // nearer a 512-spp reference than the denoiser's output alone in more pixels than
        // chance gives, by each pixel's relative squared error (the sum over R, G, B of
        // (a − b)² / (b² + 0.01)); the reference's own noise adds the same expected term to
        // both. (Measured 2026-11-30: nearer in 3620 pixels, farther in 2523, z = 14.0; relMSE raw
        // 0.000289, denoised 0.000417, blended 0.000364.)
        let d = tempdir();
        let scene = repo("scenes/holodeck/scene.toml");
        let run = |stem: &str, spp: &str, extra: &[&str]| {
            let mut args = vec!["render", scene.to_str().unwrap(), "--sampler", "uniform"];
            args.extend(["--resolution", "96x64", "--spp", spp, "-o", stem]);
            args.extend(extra);
            run_exr(d.path(), &args)
        };
        let (blended, said) = run("b", "64", &["--denoise"]);
        let (reference, _) = run("r", "512", &[]);
        assert!(said.contains("blended with the noisy image"), "{said}");
        assert!(blended.text["denoiser"].contains("blended with Noisy"));
        let noisy = interleaved(&blended, "Noisy.", ["R", "G", "B"]);
        let aux = aleph::denoise::Aux {
            albedo: interleaved(&blended, "Denoising Albedo.", ["R", "G", "B"]),
            normal: interleaved(&blended, "Denoising Normal.", ["X", "Y", "Z"]),
        };
        use aleph::denoise::{Quality, denoise_with};
        let alone = denoise_with(&noisy, 96, 64, &aux, Quality::High).unwrap();
        let shown = interleaved(&blended, "", ["R", "G", "B"]);
        let truth = interleaved(&reference, "", ["R", "G", "B"]);
        let err = |img: &[f32]| -> Vec<f64> {
            img.chunks_exact(3)
                .zip(truth.chunks_exact(3))
                .map(|(a, b)| {
                    a.iter()
                        .zip(b)
                        .map(|(&a, &b)| (a as f64 - b as f64).powi(2) / ((b as f64).powi(2) + 0.01))
                        .sum()
                })
                .collect()
        };
        let (e_blend, e_alone, e_raw) = (err(&shown), err(&alone), err(&noisy));
        // A sign test: pixels nearer the reference than the denoiser's output alone against
        // those farther (ties, where the result is the denoiser's, left out); under the
        // hypothesis that keeping the raw image does not help, each is nearer with
        // probability ½. (The mean of the differences is no test here: a few pixels at the
        // light's edge carry most of it.)
        let (nearer, farther) = e_blend.iter().zip(&e_alone).fold((0, 0), |(n, f), (a, b)| {
            (n + (a < b) as u32, f + (a > b) as u32)
        });
        let m = (nearer + farther) as f64;
        let z = (nearer as f64 - m / 2.0) / (m / 4.0).sqrt();
        let rel = |e: &[f64]| e.iter().sum::<f64>() / (3.0 * e.len() as f64);
        eprintln!(
            "relMSE against 512 spp: raw {:.6}, denoised {:.6}, blended {:.6}; nearer than \
             the denoised in {nearer} pixels, farther in {farther}: z = {z:.1}",
            rel(&e_raw),
            rel(&e_alone),
            rel(&e_blend)
        );
        assert!(
            z > 3.0,
            "the blended image is not nearer the reference: z = {z}"
        );
    }

    /// Mean of |v| over each `b × b` block of a `w`-wide image.
    fn blocks(v: &[f32], w: usize, b: usize) -> Vec<f32> {
        let h = v.len() / w;
        let mut out = vec![0.0; (w / b) * (h / b)];
        for (i, x) in v.iter().enumerate() {
            let (px, py) = (i % w / b, i / w / b);
            out[py * (w / b) + px] += x.abs() / (b * b) as f32;
        }
        out
    }

    #[test]
    fn the_denoised_error_estimate_ranks_pixels_like_the_true_error() {
        // The estimate the perceptual sampler steers a denoised render by (the half-buffers
        // denoised apart) against the true error of the denoised full buffer, |Y(D(F)) − Y(ref)|
        // with a 4096-spp reference (its own noise is 1/√512 of the 8-spp input's), over 4 × 4
        // pixel blocks of the 64² Cornell box. It must rank the blocks like the truth, better
        // with its bias term than without, and be of the truth's size; so must the half-buffer
        // part the loop steers by, whose halves are denoised by the fast model. (Measured
        // 2026-11-26: 0.625, 0.487 without the bias term, 0.554 for the loop's fast-model
        // difference, 0.589 for the raw half-buffer difference, which measures the noise the
        // denoiser removes rather than what it leaves; sizes 1.22×, 0.93× and 1.20× the truth.
        // All rank bright blocks first, as the true error does. Against the truth denoised by
        // the large model with `cleanAux`: 0.638, 0.610, 0.620, 0.555.)
        let mut job = aleph::job::RenderJob::new(repo("scenes/cornell-box/scene.toml"));
        job.scene.resolution = Some([64, 64]);
        let scene = job.load_scene().unwrap();
        let (w, h) = (64usize, 64usize);
        let strategy = aleph::integrator::Strategy::Mis;
        let film = crate::util::render(&scene, strategy, 8);
        let reference = crate::util::render(&scene, strategy, 4096).mean_rgb();
        let aux = aleph::denoise::render_aux(&scene, aleph::denoise::AUX_SPP, 1);
        let estimated = aleph::denoise::denoised_error(&film, &aux).unwrap();
        let (estimate, difference) = (estimated.magnitude(), estimated.difference);
        let full = aleph::denoise::denoise(&film.mean_rgb(), w, h, &aux).unwrap();
        let y = |p: &[f32]| perception::photometry::luminance(p[0], p[1], p[2]);
        let truth: Vec<f32> = full
            .chunks_exact(3)
            .zip(reference.chunks_exact(3))
            .map(|(a, b)| y(a) - y(b))
            .collect();
        let raw: Vec<f32> = film
            .mean_rgb_even()
            .chunks_exact(3)
            .zip(film.mean_rgb_odd().chunks_exact(3))
            .map(|(a, b)| 0.5 * (y(a) - y(b)))
            .collect();
        let (e, t, r) = (
            blocks(&estimate, w, 4),
            blocks(&truth, w, 4),
            blocks(&raw, w, 4),
        );
        let d = blocks(&difference, w, 4);
        // What the loop steers by: the half-buffer part with the halves denoised by the fast
        // model.
        let steer = blocks(
            &aleph::denoise::denoised_difference(&film, &aux).unwrap(),
            w,
            4,
        );
        let spearman = aleph_speedup::rank_correlation;
        let (rho, rho_raw, rho_d) = (spearman(&e, &t), spearman(&r, &t), spearman(&d, &t));
        let rho_steer = spearman(&steer, &t);
        let sum = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>();
        let size = sum(&e) / sum(&t);
        let (size_d, size_steer) = (sum(&d) / sum(&t), sum(&steer) / sum(&t));
        eprintln!(
            "Spearman: estimate {rho:.3}, its half-buffer part {rho_d:.3} (fast model \
             {rho_steer:.3}), raw half-buffers {rho_raw:.3}; size {size:.2}× the truth, the \
             half-buffer part {size_d:.2}× (fast model {size_steer:.2}×)"
        );
        assert!(
            rho > 0.5 && rho > rho_d,
            "rank correlation {rho} (half-buffer part {rho_d})"
        );
        assert!(
            (0.5..2.0).contains(&size),
            "estimate {size}× the true error"
        );
        assert!(rho_steer > 0.5, "the fast model's ranks {rho_steer}");
    }

    #[test]
    fn a_budget_with_the_denoiser_is_rendered_uniformly_unless_steer_from_is_given() {
        // Measured no better than uniform with the same denoiser, in more time
        // (aleph::job::DENOISED_STEER_FROM_SPP): the perceptual sampler renders the budget as
        // the uniform sampler does, bit for bit, and says so; --steer-from still steers it.
        let d = tempdir();
        let scene = repo("scenes/cornell-box/scene.toml");
        let run = |stem: &str, extra: &[&str]| {
            let mut args = vec![
                "render",
                scene.to_str().unwrap(),
                "--resolution",
                "32x32",
                "--spp",
                "128",
                "--denoise",
                "-o",
                stem,
            ];
            args.extend(extra);
            run_exr(d.path(), &args)
        };
        let (perceptual, said) = run("p", &[]);
        assert!(
            said.contains("a budget with --denoise (--steer-from steers it): rendered uniformly"),
            "{said}"
        );
        let (uniform, _) = run("u", &["--sampler", "uniform"]);
        for c in ["R", "G", "B", "Noisy.R", "Noisy.G", "Noisy.B"] {
            let same = channel(&perceptual, c)
                .iter()
                .zip(channel(&uniform, c))
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{c} differs from the uniform render");
        }
        let (_, said) = run("s", &["--steer-from", "128"]);
        assert!(said.contains("% of pixels below threshold"), "{said}");
    }

    #[test]
    fn the_stop_with_the_denoiser_starts_from_32_spp_and_a_preview_from_2() {
        let first = |denoise: bool, preview: bool, spp: Option<f64>, min: u32| {
            let mut job = aleph::job::RenderJob::new(repo("scenes/cornell-box/scene.toml"));
            (job.output.denoise, job.output.preview) = (denoise, preview);
            job.budget.spp = spp;
            job.sampling.min_spp = min;
            let tone = aleph::display::ToneMapSettings::default();
            job.adaptive_settings(64, tone).unwrap().min_spp
        };
        let stop = aleph::job::DENOISED_STOP_MIN_SPP;
        assert_eq!(first(true, false, None, 8), stop);
        assert_eq!(first(true, false, None, 64), 64);
        // Under a budget, without the denoiser and in a preview, the first pass is as asked.
        assert_eq!(first(true, false, Some(16.0), 8), 8);
        assert_eq!(first(false, false, None, 8), 8);
        assert_eq!(first(false, true, None, 8), aleph::job::PREVIEW_MIN_SPP);
    }

    #[test]
    fn denoise_refuses_sample_parts() {
        let d = tempdir();
        let scene = repo("scenes/cornell-box/scene.toml");
        let o = aleph(
            &[
                "render",
                scene.to_str().unwrap(),
                "--denoise",
                "--sampler",
                "uniform",
                "--spp",
                "4",
                "--part",
                "1/2",
                "-o",
                "x",
            ],
            d.path(),
        );
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(e.contains("--denoise with --part/--tile"), "{e}");
    }
}

/// A preview through the library: the observer decodes the PNG at every refinement.
mod preview {
    use crate::util::{repo, tempdir};
    use aleph::adaptive::{Criterion, StopReason};
    use aleph::job::{self, FrameDone, JobError, Observer, Refined, RenderJob, Split};
    use std::sync::Mutex;

    /// What the observer saw: (number, mean spp, denoised, elapsed s) per refinement, and the
    /// stop reason and mean spp of the frame.
    #[derive(Default)]
    struct Seen {
        refinements: Mutex<Vec<(usize, f64, bool, f64)>>,
        done: Mutex<Option<(StopReason, f64)>>,
    }

    impl Observer for Seen {
        fn refined(&self, r: &Refined<'_>) {
            // The PNG is whole at every refinement: it decodes, at the render's size.
            let png = image::open(r.path).unwrap_or_else(|e| panic!("{}: {e}", r.path.display()));
            assert_eq!((png.width(), png.height()), (256, 192));
            let row = (r.number, r.mean_spp, r.denoised, r.elapsed.as_secs_f64());
            self.refinements.lock().unwrap().push(row);
        }
        fn frame_done(&self, d: &FrameDone<'_>) {
            let f = &d.result.film;
            let spp = f.total_samples() as f64 / f.len() as f64;
            *self.done.lock().unwrap() = Some((d.result.stop, spp));
        }
    }

    /// A change that makes a preview job invalid.
    type Spoil = fn(&mut RenderJob);

    fn job() -> RenderJob {
        let mut job = RenderJob::new(repo("scenes/cornell-box/scene.toml"));
        job.scene.resolution = Some([256, 192]);
        job.output.preview = true;
        job
    }

    /// Runs a preview of `job` into a new directory; returns what the observer saw and checks
    /// what every preview must do: a whole PNG at each refinement, the first at 1 spp, the
    /// second when the first pass is whole at the preview's 2 spp, each later one with more
    /// samples, the last as many as the delivered frame, denoised when the build can, and the
    /// render's PNG and EXR at the end.
    fn preview(mut job: RenderJob) -> (Vec<(usize, f64, bool, f64)>, StopReason) {
        let dir = tempdir();
        job.output.stem = Some(dir.path().join("p"));
        let seen = Seen::default();
        job::run(&job, &seen).unwrap();
        let rows = seen.refinements.into_inner().unwrap();
        let done = seen.done.into_inner().unwrap();
        let (stop, spp) = done.expect("the frame was reported");
        assert_eq!(rows[0].0, 1);
        let first = job::PREVIEW_MIN_SPP as f64;
        assert!((rows[0].1 - 1.0).abs() < 1e-9, "{rows:?}");
        assert!((rows[1].1 - first).abs() < 1e-9, "{rows:?}");
        for w in rows.windows(2) {
            let next = w[1].0 == w[0].0 + 1 && w[1].1 > w[0].1 && w[1].3 >= w[0].3;
            assert!(next, "{rows:?}");
        }
        let last = rows.last().unwrap().1;
        assert!((last - spp).abs() < 1e-9, "{rows:?} vs {spp}");
        let denoised = rows.iter().all(|r| r.2 == aleph::denoise::AVAILABLE);
        assert!(denoised, "{rows:?}");
        let out = |ext: &str| dir.path().join(format!("p.{ext}"));
        assert!(out("png").is_file() && out("exr").is_file());
        if aleph::denoise::AVAILABLE {
            // The first image was denoised with quick auxiliaries; the result has the full
            // ones, those of a render without --preview.
            let exr = aleph::imageio::read_exr_raw(&out("exr")).unwrap();
            let scene = job.load_scene().unwrap();
            let seed = scene.settings.seed;
            let full = aleph::denoise::render_aux(&scene, aleph::denoise::AUX_SPP, seed);
            let written = &exr.f32s["Denoising Albedo.G"];
            let mut same = full.albedo.chunks_exact(3).zip(written.iter());
            assert!(same.all(|(a, w)| a[1].to_bits() == w.to_bits()));
        }
        (rows, stop)
    }

    #[test]
    fn a_preview_rewrites_a_whole_png_after_every_pass() {
        // Under a sample budget the passes do not depend on the machine's speed.
        let mut job = job();
        job.budget.spp = Some(16.0);
        let (rows, stop) = preview(job);
        assert_eq!(stop, StopReason::Budget);
        assert!(rows.len() >= 3, "{rows:?}");
        assert!((rows.last().unwrap().1 - 16.0).abs() < 0.01, "{rows:?}");
    }

    #[test]
    fn a_preview_stops_on_time() {
        // Every pixel must converge to stop early (about 350 spp here without the denoiser,
        // 95 spp and 3.8 s on 2 cores with it), so the time budget ends it: on a slower or
        // busier machine only sooner.
        let mut job = job();
        job.budget.time_s = Some(1.0);
        job.sampling.converged_fraction = Some(1.0);
        let (rows, stop) = preview(job);
        assert_eq!(stop, StopReason::Time, "{rows:?}");
    }

    #[test]
    fn a_preview_is_of_one_whole_still_by_the_perceptual_sampler() {
        let cases: [(&str, Spoil); 3] = [
            ("--part/--tile", |j| {
                j.split = Some(Split::Tile {
                    index: 1,
                    count: 2,
                    margin: 4,
                })
            }),
            ("--frames", |j| j.frames = Some([0, 2])),
            ("--sampler", |j| j.criterion = Criterion::Uniform),
        ];
        for (words, spoil) in cases {
            let mut job = job();
            spoil(&mut job);
            let e = job.validate().unwrap_err().to_string();
            assert!(e.contains("--preview") && e.contains(words), "{e}");
        }
        // An animated scene without --frames: refused before anything is rendered.
        let dir = tempdir();
        let mut job = RenderJob::new(repo("scenes/cornell-motion/scene.toml"));
        job.output.preview = true;
        job.output.stem = Some(dir.path().join("p"));
        let e = job::run(&job, &()).unwrap_err();
        assert!(matches!(e, JobError::Invalid(_)), "{e}");
        assert!(e.to_string().contains("animated"), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
