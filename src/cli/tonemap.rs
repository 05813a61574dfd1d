//! `aleph tonemap IN OUT`: tone reproduction of an HDR image.

use aleph::display::{FrozenToneMap, ToneMapSettings, contact_sheet, tone_map};
use aleph::imageio::{RgbImage, read_image};
use aleph::job::DisplaySpec;
use aleph::output::{AtomicOutputs, encode_srgb8, write_exr, write_png};
use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use perception::adaptation::AdaptationMode;
use perception::tmo::Operator;
use std::path::PathBuf;
use std::process::ExitCode;

/// Tone operators on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum OperatorArg {
    /// Tumblin & Rushmeier 1993 (brightness).
    Tr,
    /// Ferwerda et al. 1996 (threshold visibility, with rods).
    Fpsg,
    /// Ward Larson et al. 1997 (histogram adjustment).
    Wrp,
    /// Pattanaik et al. 2000 (static appearance model).
    Ptyg,
    /// Constant scaling (log average to 0.18).
    Exposure,
    /// Reinhard et al. 2002 (global).
    Reinhard,
}

impl From<OperatorArg> for Operator {
    fn from(o: OperatorArg) -> Operator {
        match o {
            OperatorArg::Tr => Operator::Tr,
            OperatorArg::Fpsg => Operator::Fpsg,
            OperatorArg::Wrp => Operator::Wrp,
            OperatorArg::Ptyg => Operator::Ptyg,
            OperatorArg::Exposure => Operator::Exposure,
            OperatorArg::Reinhard => Operator::Reinhard,
        }
    }
}

/// Adaptation luminance on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum AdaptationArg {
    /// The log average of the whole image.
    Global,
    /// Arithmetic mean over 1° of visual angle.
    Local,
    /// Geometric mean over 1°.
    LocalGeometric,
}

impl From<AdaptationArg> for AdaptationMode {
    fn from(a: AdaptationArg) -> AdaptationMode {
        match a {
            AdaptationArg::Global => AdaptationMode::Global,
            AdaptationArg::Local => AdaptationMode::LocalArithmetic,
            AdaptationArg::LocalGeometric => AdaptationMode::LocalGeometric,
        }
    }
}

/// Tone-mapping options shared by `tonemap` and `render --tonemap`.
#[derive(Args, Debug, Clone)]
pub struct ToneArgs {
    /// Adaptation luminance (WRP always uses its own 1° foveal histogram).
    #[arg(long, value_enum, default_value = "local")]
    pub adaptation: AdaptationArg,
    /// Maximum display luminance, cd/m², up to 1e5 (defaults: TR/FPSG 125, WRP 100, PTYG
    /// 5 × ambient).
    #[arg(long, value_name = "CD", allow_negative_numbers = true)]
    pub display_max: Option<f64>,
    /// Display adaptation luminance L_da, cd/m², up to 1e5 (TR, FPSG, PTYG; default 25).
    #[arg(long, value_name = "CD", allow_negative_numbers = true)]
    pub display_ambient: Option<f64>,
    /// Horizontal field of view the image fills, degrees, for the 1° window; it must put 1e-6
    /// to 1000 pixels in a degree (default: FLIP's monitor, 67 pixels per degree).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub fov: Option<f64>,
}

impl ToneArgs {
    /// The display of a render job with `operator` and `exposure_ev` (the render's own flags).
    pub fn display(&self, operator: Option<Operator>, exposure_ev: Option<f32>) -> DisplaySpec {
        DisplaySpec {
            operator,
            exposure_ev,
            adaptation: self.adaptation.into(),
            max_cd_m2: self.display_max,
            ambient_cd_m2: self.display_ambient,
            fov_deg: self.fov,
        }
    }

    /// Tone-map settings with `op` for an image `width` pixels wide, `luminance_scale` cd/m²
    /// per unit.
    pub fn settings(
        &self,
        op: Operator,
        width: usize,
        luminance_scale: f32,
    ) -> anyhow::Result<ToneMapSettings> {
        Ok(self
            .display(Some(op), None)
            .tone_settings(op, width, luminance_scale)?)
    }
}

#[derive(Args, Debug)]
pub struct TonemapArgs {
    /// HDR input (.exr or .hdr; PNG/JPEG are read as display values with white at 100 cd/m²).
    input: PathBuf,
    /// Output: .png (sRGB, 8-bit) or .exr (display-linear values, 0–1 of display maximum).
    output: Option<PathBuf>,
    /// The operator.
    #[arg(long, value_enum, default_value = "wrp")]
    operator: OperatorArg,
    /// cd/m² per unit of the input (default: the EXR's whiteLuminance, else 100).
    #[arg(long, value_name = "K", allow_negative_numbers = true)]
    luminance_scale: Option<f32>,
    /// Write every operator side by side, labelled, to this PNG.
    #[arg(long, value_name = "OUT.png")]
    contact_sheet: Option<PathBuf>,
    /// Freeze the curve's image-dependent parts (adaptation map, exposure scale, Reinhard's log
    /// average and white) from this HDR image of the same size instead of the input, so that
    /// several renders are displayed by one curve (a judge's reference, say). Read at its own
    /// luminance scale (its whiteLuminance, else 100).
    #[arg(long, value_name = "REF.exr")]
    curve_from: Option<PathBuf>,
    /// Grade the input by this many stops under the frozen curve (input × 2^EV before it, the
    /// curve staying where its image put it): how a user who grades the EXR darker or brighter
    /// sees it. -20 to 20; 0 by default.
    #[arg(long, value_name = "EV", allow_negative_numbers = true)]
    grade: Option<f64>,
    #[command(flatten)]
    tone: ToneArgs,
}

/// The largest grade `--grade` takes, stops either way.
const MAX_GRADE_EV: f64 = 20.0;

/// The curve `settings` gives, frozen from `--curve-from` (or the input `img` itself) and
/// graded by `--grade` stops.
fn frozen_curve(
    args: &TonemapArgs,
    img: &RgbImage,
    settings: &ToneMapSettings,
) -> anyhow::Result<FrozenToneMap> {
    let frozen = match &args.curve_from {
        None => FrozenToneMap::new(&img.rgb, img.width, img.height, settings)
            .with_context(|| format!("{}: freezing the tone curve", args.input.display()))?,
        Some(path) => {
            let r = read_image(path).context("--curve-from")?;
            if (r.width, r.height) != (img.width, img.height) {
                bail!(
                    "{}: --curve-from image is {}×{}, the input {} is {}×{}",
                    path.display(),
                    r.width,
                    r.height,
                    args.input.display(),
                    img.width,
                    img.height
                );
            }
            if r.is_black() {
                return Err(aleph::imageio::ImageError::AllBlack { path: path.clone() }.into());
            }
            let s = ToneMapSettings {
                luminance_scale: r.luminance_scale(path, None)?,
                ..*settings
            };
            FrozenToneMap::new(&r.rgb, r.width, r.height, &s)
                .with_context(|| format!("{}: freezing the tone curve", path.display()))?
                .with_luminance_scale(settings.luminance_scale)
        }
    };
    Ok(frozen.graded(args.grade.unwrap_or(0.0)))
}

pub fn run(args: TonemapArgs) -> anyhow::Result<ExitCode> {
    if args.output.is_none() && args.contact_sheet.is_none() {
        bail!("nothing to write: give OUT (.png or .exr) or --contact-sheet OUT.png");
    }
    if let Some(ev) = args.grade
        && (ev.is_nan() || ev.abs() > MAX_GRADE_EV)
    {
        bail!("--grade {ev}: give a grade from -{MAX_GRADE_EV} to {MAX_GRADE_EV} stops");
    }
    if (args.curve_from.is_some() || args.grade.is_some()) && args.contact_sheet.is_some() {
        bail!(
            "--curve-from and --grade apply to OUT, not to --contact-sheet: give one or the other"
        );
    }
    for out in args.output.iter().chain(&args.contact_sheet) {
        aleph::output::check_output_location(out)?;
    }
    let img = read_image(&args.input)?;
    let k = img.luminance_scale(&args.input, args.luminance_scale)?;
    if img.is_black() {
        return Err(aleph::imageio::ImageError::AllBlack {
            path: args.input.clone(),
        }
        .into());
    }
    let op: Operator = args.operator.into();
    let settings = args.tone.settings(op, img.width, k)?;
    let (w, h) = (img.width as u32, img.height as u32);
    // The model's errors (a luminance that overflows once scaled) name the input file.
    let within = || {
        format!(
            "{}: tone mapping its radiance at {k} cd/m² per unit",
            args.input.display()
        )
    };
    let mut out = AtomicOutputs::new();
    if let Some(path) = &args.output {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        let display = match (&args.curve_from, args.grade) {
            (None, None) => tone_map(&img.rgb, img.width, img.height, &settings),
            _ => frozen_curve(&args, &img, &settings)?.map(&img.rgb),
        }
        .with_context(within)?;
        match ext.as_str() {
            "png" => {
                let bytes = encode_srgb8(&display);
                out.stage(path, |wr| write_png(wr, path, w, h, &bytes))?;
            }
            "exr" => {
                let attrs = vec![
                    (
                        "displayUnits".to_string(),
                        "display-linear, fraction of display maximum luminance (no gamma)"
                            .to_string(),
                    ),
                    ("toneOperator".to_string(), op.label().to_string()),
                ];
                out.stage(path, |wr| write_exr(wr, path, w, h, &display, &[], &attrs))?;
            }
            _ => bail!("{}: output must end in .png or .exr", path.display()),
        }
    }
    if let Some(path) = &args.contact_sheet {
        let (bytes, sw, sh) =
            contact_sheet(&img.rgb, img.width, img.height, &settings).with_context(within)?;
        out.stage(path, |wr| write_png(wr, path, sw, sh, &bytes))?;
    }
    out.commit()?;
    println!(
        "{}: {}×{}, {} cd/m² per unit, operator {}{}{}",
        args.input.display(),
        w,
        h,
        k,
        op.name(),
        if img.clamped_negative > 0 {
            format!(", {} negative values clamped to 0", img.clamped_negative)
        } else {
            String::new()
        },
        args.output
            .as_ref()
            .map(|p| format!(" -> {}", p.display()))
            .unwrap_or_default()
    );
    Ok(ExitCode::SUCCESS)
}
