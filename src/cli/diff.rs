//! `aleph diff REF TEST`: does a viewer see a difference? Exit 0 = no, 1 = yes, 2 = error.

use aleph::imageio::{RgbImage, read_image};
use aleph::output::{AtomicOutputs, encode_srgb8, write_png};
use anyhow::{Context, bail};
use clap::Args;
use perception::metric::{DEFAULT_FAIL_PIXELS, DiffMetric};
use perception::photometry::luminance_image;
use perception::threshold::ThresholdParams;
use perception::viewing::ViewingConditions;
use std::path::PathBuf;
use std::process::ExitCode;

/// pdiff's default field of view, degrees.
const DEFAULT_FOV_DEG: f64 = 45.0;

#[derive(Args, Debug)]
pub struct DiffArgs {
    /// Reference image (.exr, .hdr, .png, .jpg).
    reference: PathBuf,
    /// Test image, same size.
    test: PathBuf,
    /// Horizontal field of view the image fills, degrees (pdiff's default: 45); it must put
    /// 1e-6 to 1000 pixels in a degree.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    fov: Option<f64>,
    /// Pixels per degree instead of a field of view, 1e-6 to 1000 (FLIP's monitor default is
    /// 67).
    #[arg(long, value_name = "PPD", conflicts_with = "fov")]
    ppd: Option<f64>,
    /// cd/m² per unit of linear (EXR/HDR) values. Default: the EXR's whiteLuminance attribute
    /// if present, else 100 (value 1 = a 100 cd/m² display white). PNG/JPEG white is 100 cd/m².
    #[arg(long, value_name = "K", allow_negative_numbers = true)]
    luminance_scale: Option<f32>,
    /// "Different" from this many visibly different pixels (pdiff's default: 100); at least 1
    /// (1 fails on any visible pixel; 0 would call identical images different).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_FAIL_PIXELS,
        value_parser = at_least_one)]
    fail_pixels: usize,
    /// Write a difference map: the reference's luminance in grey, visible differences in red
    /// (brighter = further above threshold).
    #[arg(long, value_name = "OUT.png")]
    map: Option<PathBuf>,
    /// Print the result as JSON on stdout.
    #[arg(long)]
    json: bool,
}

fn luminance_cd_m2(
    img: &RgbImage,
    path: &std::path::Path,
    scale: Option<f32>,
) -> anyhow::Result<(Vec<f32>, f32)> {
    let k = img.luminance_scale(path, scale)?;
    Ok((luminance_image(&img.rgb, k), k))
}

pub fn run(args: DiffArgs) -> anyhow::Result<ExitCode> {
    if let Some(m) = &args.map {
        let png = m
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !png {
            bail!(
                "{}: --map writes a PNG: give a name ending in .png",
                m.display()
            );
        }
        aleph::output::check_output_location(m)?;
    }
    let r = read_image(&args.reference)?;
    let t = read_image(&args.test)?;
    if (r.width, r.height) != (t.width, t.height) {
        bail!(
            "{} is {}×{} but {} is {}×{}: images must have the same size",
            args.reference.display(),
            r.width,
            r.height,
            args.test.display(),
            t.width,
            t.height
        );
    }
    let view = match (args.ppd, args.fov) {
        (Some(ppd), _) => ViewingConditions::default()
            .with_ppd(ppd)
            .context("--ppd")?,
        (None, fov) => ViewingConditions::from_fov(fov.unwrap_or(DEFAULT_FOV_DEG), r.width as f64)
            .context("--fov")?,
    };
    let (lr, kr) = luminance_cd_m2(&r, &args.reference, args.luminance_scale)?;
    let (lt, _) = luminance_cd_m2(&t, &args.test, args.luminance_scale)?;
    let metric = DiffMetric::new(
        r.width,
        r.height,
        view,
        ThresholdParams::default(),
        args.fail_pixels,
    )?;
    let map = metric.reference_map(&lr)?;
    let result = metric.compare_with_map(&map, &lr, &lt)?;

    if let Some(path) = &args.map {
        let mut out = AtomicOutputs::new();
        let display = aleph::imaging::difference_overlay(&lr, &result.ratio);
        let bytes = encode_srgb8(&display);
        out.stage(path, |w| {
            write_png(w, path, r.width as u32, r.height as u32, &bytes)
        })?;
        out.commit()?;
    }

    let clamped = r.clamped_negative + t.clamped_negative;
    if args.json {
        let j = serde_json::json!({
            "reference": args.reference,
            "test": args.test,
            "width": r.width,
            "height": r.height,
            "pixels_per_degree": view.ppd,
            "luminance_scale_cd_m2": kr,
            "visible_pixels": result.visible_pixels,
            "visible_fraction": result.visible_fraction,
            "fail_pixels": args.fail_pixels,
            "different": result.different,
            "clamped_negative_values": clamped,
        });
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        println!(
            "{}: {} of {} pixels visibly different ({:.4} %), limit {}, at {:.2} pixels per degree{}",
            if result.different { "FAIL" } else { "PASS" },
            result.visible_pixels,
            r.width * r.height,
            100.0 * result.visible_fraction,
            args.fail_pixels,
            view.ppd,
            if clamped > 0 {
                format!(" ({clamped} negative values clamped to 0)")
            } else {
                String::new()
            }
        );
    }
    Ok(if result.different {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

/// `--fail-pixels`: a count of at least 1.
fn at_least_one(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(0) => Err("must be at least 1 (0 would call identical images different)".into()),
        Ok(n) => Ok(n),
        Err(e) => Err(e.to_string()),
    }
}
