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

#[cfg(not(feature = "denoise"))]
#[test]
fn without_the_feature_denoise_is_refused_with_the_way_to_build_it() {
    let d = tempdir();
    let scene = repo("scenes/cornell-box/scene.toml");
    let o = aleph(
        &[
            "render",
            scene.to_str().unwrap(),
            "--denoise",
            "--spp",
            "4",
            "-o",
            "x",
        ],
        d.path(),
    );
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("--denoise") && e.contains("--features denoise") && e.contains("oidn.sh"),
        "{e}"
    );
    // Refused before rendering: no scene was loaded, nothing written.
    assert!(!e.contains("triangles"), "{e}");
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
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
        assert!(denoised.text.contains_key("denoiser"));
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
