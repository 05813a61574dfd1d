//! Delivering a render: the files a user gets from one frame, written all or nothing.
//!
//! - `STEM.exr`: linear radiance (W·sr⁻¹·m⁻², Rec.709 RGB, f32) with layers `spp` (samples per
//!   pixel), `Threshold.Y` and `Error.Y` (the sampler's last threshold and error, units in the
//!   header), and for a sequence frame Blender's Vector pass (`Vector.X/Y/Z/W`, see
//!   [`crate::velocity`]) with the frame number, fps and shutter in the header; the G-buffer at
//!   the pixel centres as Blender names it (`Depth.Z`, `Normal.X/Y/Z`, `IndexOB`,
//!   [`crate::gbuffer`]); a frame that reused earlier frames adds `History.spp`, the reused
//!   weight (`spp` counts the fresh samples only, [`crate::reuse`]);
//! - `STEM.png`: the display image (8-bit sRGB) through a [`Look`];
//! - with `aov`: `STEM.spp.png` (samples per pixel) and `STEM.ratio.png` (error / threshold,
//!   1/16 to 16), false colour on log scales.
//!
//! Every file is staged as a temporary file and renamed into place only when all were written
//! ([`crate::output::AtomicOutputs`]).

use crate::adaptive::{AdaptiveResult, AdaptiveSettings};
use crate::display::{ToneMapSettings, tone_map};
use crate::output::{
    AtomicOutputs, ChannelData, OutputError, auto_exposure_ev, encode_srgb8, expose, write_exr,
    write_png,
};
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// `STEM.EXT` (the extension appended, never replacing a dot in the stem).
pub fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Errors delivering a render.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DeliverError {
    /// A file could not be written (it names the file).
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The tone operator rejected the image.
    #[error(transparent)]
    Perception(#[from] perception::PerceptionError),
}

/// How the PNG is made from the linear image.
#[derive(Clone, Copy, Debug)]
pub enum Look {
    /// A tone operator (with its adaptation state, in a sequence).
    Tone(ToneMapSettings),
    /// Exposure in stops, or automatic (log average to 0.18).
    Exposure(Option<f32>),
}

impl Look {
    /// Words for a summary line: the operator, or the exposure in stops.
    pub fn describe(&self) -> String {
        match self {
            Look::Tone(t) => format!("tone operator {}", t.operator.name()),
            Look::Exposure(Some(ev)) => format!("{ev:+.2} EV"),
            Look::Exposure(None) => "automatic exposure".into(),
        }
    }
}

/// `STEM.NNNN`: a frame's stem, numbered as compositing tools expect (four digits, more when
/// needed).
pub fn numbered(stem: &Path, frame: i64) -> PathBuf {
    with_ext(stem, &format!("{frame:04}"))
}

/// Largest width of a sequence's animated preview; larger frames are shrunk by an integer
/// factor.
const PREVIEW_MAX_WIDTH: usize = 640;

/// Writes `STEM.preview.png` (an animated PNG at `fps` of the frames' display images, 8-bit
/// sRGB `w × h` each, shrunk to at most 640 pixels wide) and `STEM.filmstrip.png`
/// ([`crate::display::filmstrip`]), all or nothing. Returns their paths.
///
/// # Errors
/// [`DeliverError::Output`] naming the file; nothing is replaced then.
pub fn write_sequence_outputs(
    stem: &Path,
    displays: &[(i64, Vec<u8>)],
    w: usize,
    h: usize,
    fps: f64,
) -> Result<(PathBuf, PathBuf), DeliverError> {
    let factor = w.div_ceil(PREVIEW_MAX_WIDTH).max(1);
    let (pw, ph) = ((w / factor).max(1), (h / factor).max(1));
    let frames: Vec<Vec<u8>> = displays
        .iter()
        .map(|(_, d)| crate::imaging::shrink_rgb8(d, w, h, factor))
        .collect();
    let preview = with_ext(stem, "preview.png");
    let strip_path = with_ext(stem, "filmstrip.png");
    let (strip, sw, sh) = crate::display::filmstrip(displays, w, h);
    let mut out = AtomicOutputs::new();
    out.stage(&preview, |wr| {
        crate::output::write_apng(wr, &preview, pw as u32, ph as u32, &frames, fps)
    })?;
    out.stage(&strip_path, |wr| write_png(wr, &strip_path, sw, sh, &strip))?;
    out.commit()?;
    Ok((preview, strip_path))
}

/// What [`write_render`] wrote.
pub struct Written {
    /// The display image (8-bit sRGB).
    pub display: Vec<u8>,
    /// Words for the summary: the exposure or the operator.
    pub look: String,
}

/// Extra EXR channels (name, samples) and header attributes (name, text).
pub type ExrLayers = (Vec<(String, ChannelData)>, Vec<(String, String)>);

/// The extra channels (beyond R, G, B) and header attributes of a render's EXR, as
/// [`write_render`] writes them (see the module docs for the names): each channel a row-major
/// `width × height` plane. The Python bindings return the same planes as arrays.
pub fn exr_layers(
    scene: &Scene,
    settings: &AdaptiveSettings,
    result: &AdaptiveResult,
) -> ExrLayers {
    let mut attributes = vec![
        (
            "radianceUnits".to_string(),
            "W.sr^-1.m^-2 (linear Rec.709 RGB)".to_string(),
        ),
        ("sppUnits".to_string(), "samples per pixel".to_string()),
        (
            crate::output::WHITE_LUMINANCE.to_string(),
            scene.settings.luminance_scale.to_string(),
        ),
        ("scene".to_string(), scene.path.display().to_string()),
        ("sampler".to_string(), settings.criterion.name().to_string()),
    ];
    let mut extra = vec![("spp".to_string(), ChannelData::U32(result.film.spp()))];
    if let (Some(t), Some(e)) = (&result.threshold, &result.error) {
        extra.push(("Threshold.Y".to_string(), ChannelData::F32(t.clone())));
        extra.push(("Error.Y".to_string(), ChannelData::F32(e.clone())));
        attributes.push(("thresholdUnits".to_string(), result.units.to_string()));
        attributes.push(("errorUnits".to_string(), result.units.to_string()));
    }
    if let (Some(v), Some(a)) = (&result.velocity, scene.animation) {
        for (c, name) in ["X", "Y", "Z", "W"].iter().enumerate() {
            extra.push((format!("Vector.{name}"), ChannelData::F32(v.channel(c))));
        }
        attributes.push((
            "vectorUnits".to_string(),
            "pixels per frame, y up (Blender's Vector pass): X,Y = p(t-1) - p(t), \
             Z,W = p(t) - p(t+1)"
                .to_string(),
        ));
        attributes.push(("alephFrame".to_string(), scene.frame.index.to_string()));
        attributes.push(("alephFps".to_string(), a.fps.to_string()));
        attributes.push(("alephShutter".to_string(), a.shutter.to_string()));
    }
    if let Some(g) = &result.gbuffer {
        gbuffer_layers(g, &mut extra, &mut attributes);
    }
    if let (Some(history), Some(r)) = (&result.film.history, &result.reuse) {
        let weight = history.iter().map(|h| h.weight() as f32).collect();
        extra.push(("History.spp".to_string(), ChannelData::F32(weight)));
        attributes.push((
            "historyUnits".to_string(),
            "samples reused from earlier frames (weighted; spp holds the fresh samples)"
                .to_string(),
        ));
        attributes.push(("alephReuseFrames".to_string(), r.frames.to_string()));
    }
    (extra, attributes)
}

/// A denoised render's layers, as [`write_render`] adds them to [`exr_layers`]' (the Python
/// bindings return the same planes): the raw render `Noisy.R/G/B` and the denoiser's
/// auxiliary images `Denoising Albedo.R/G/B` and `Denoising Normal.X/Y/Z`, each a row-major
/// `width × height` plane, and the `denoiser` attribute.
pub fn denoise_layers(
    d: &crate::denoise::Denoised,
    extra: &mut Vec<(String, ChannelData)>,
    attributes: &mut Vec<(String, String)>,
) {
    let planes = [
        ("Noisy", ["R", "G", "B"], &d.noisy),
        ("Denoising Albedo", ["R", "G", "B"], &d.aux.albedo),
        ("Denoising Normal", ["X", "Y", "Z"], &d.aux.normal),
    ];
    for (layer, names, data) in planes {
        for (c, name) in names.iter().enumerate() {
            let plane = data.iter().skip(c).step_by(3).copied().collect();
            extra.push((format!("{layer}.{name}"), ChannelData::F32(plane)));
        }
    }
    let kept = if d.noisy_weight > 0.0 {
        format!(
            ", blended with Noisy by inverse squared estimated error (Noisy's mean weight \
             {:.4})",
            d.noisy_weight
        )
    } else {
        String::new()
    };
    attributes.push((
        "denoiser".to_string(),
        format!(
            "Intel Open Image Denoise 2.5, RT filter (hdr, {}); R,G,B denoised{kept}, Noisy \
             the render; albedo and normal of the first non-specular surface at up to {} spp \
             ({} where a pixel and its neighbours see one surface)",
            d.quality.describe(),
            crate::denoise::AUX_SPP,
            crate::denoise::AUX_FIRST_SPP
        ),
    ));
}

/// The G-buffer's layers as Blender names them: `Depth.Z`, `Normal.X/Y/Z`, `IndexOB`.
fn gbuffer_layers(
    g: &crate::gbuffer::GBuffer,
    extra: &mut Vec<(String, ChannelData)>,
    attributes: &mut Vec<(String, String)>,
) {
    extra.push(("Depth.Z".to_string(), ChannelData::F32(g.depth.clone())));
    for (c, name) in ["X", "Y", "Z"].iter().enumerate() {
        let plane = g.normal.iter().skip(c).step_by(3).copied().collect();
        extra.push((format!("Normal.{name}"), ChannelData::F32(plane)));
    }
    let index = g.object.iter().map(|&o| o as f32).collect();
    extra.push(("IndexOB".to_string(), ChannelData::F32(index)));
    attributes.push((
        "gbufferUnits".to_string(),
        "at the pixel centre: Depth.Z metres along the view axis (1e10: background), \
         Normal world-space shading normal, IndexOB 0 background / 1 static / 2+i instance i"
            .to_string(),
    ));
}

/// The display image of linear radiance `rgb` (interleaved, `width × height`) through `look`:
/// 8-bit sRGB, interleaved RGB, as the PNG holds it; and words for the summary.
///
/// # Errors
/// [`DeliverError`] if the tone operator rejects the image.
pub fn display_image(
    rgb: &[f32],
    width: usize,
    height: usize,
    look: Look,
) -> Result<(Vec<u8>, String), DeliverError> {
    Ok(match look {
        Look::Tone(tone) => (
            encode_srgb8(&tone_map(rgb, width, height, &tone)?),
            format!("tone operator {}", tone.operator.name()),
        ),
        Look::Exposure(ev) => {
            let ev = ev.unwrap_or_else(|| auto_exposure_ev(rgb));
            (encode_srgb8(&expose(rgb, ev)), format!("{ev:+.2} EV"))
        }
    })
}

/// Writes the outputs of `result` (a render of `scene`'s current frame with `settings`) to
/// `stem` + extensions (see the module docs); `aov` adds the false-colour PNGs. With
/// `denoised`, the EXR's RGB and the PNG are its denoised image, and the EXR keeps the raw
/// render as `Noisy.R/G/B` with the denoiser's `Denoising Albedo.R/G/B` and
/// `Denoising Normal.X/Y/Z` (Blender's names).
///
/// # Errors
/// [`DeliverError`]; nothing is replaced then.
pub fn write_render(
    scene: &Scene,
    stem: &Path,
    settings: &AdaptiveSettings,
    result: &AdaptiveResult,
    look: Look,
    aov: bool,
    denoised: Option<&crate::denoise::Denoised>,
) -> Result<Written, DeliverError> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let film = &result.film;
    let raw;
    let rgb: &[f32] = match denoised {
        Some(d) => &d.rgb,
        None => {
            raw = film.mean_rgb();
            &raw
        }
    };
    let exr_path = with_ext(stem, "exr");
    let png_path = with_ext(stem, "png");
    let mut out = AtomicOutputs::new();
    let (mut extra, mut attributes) = exr_layers(scene, settings, result);
    if let Some(d) = denoised {
        denoise_layers(d, &mut extra, &mut attributes);
    }
    out.stage(&exr_path, |wr| {
        write_exr(wr, &exr_path, w, h, rgb, &extra, &attributes)
    })?;
    let (display, look) = display_image(rgb, w as usize, h as usize, look)?;
    out.stage(&png_path, |wr| write_png(wr, &png_path, w, h, &display))?;
    if aov {
        let spp: Vec<f32> = film.spp().iter().map(|&n| n as f32).collect();
        let (lo, hi) = (
            spp.iter().cloned().fold(f32::INFINITY, f32::min).max(1.0),
            spp.iter().cloned().fold(0.0, f32::max).max(2.0),
        );
        let density = crate::imaging::false_colour(&spp, lo, hi.max(lo * 2.0));
        let spp_path = with_ext(stem, "spp.png");
        out.stage(&spp_path, |wr| write_png(wr, &spp_path, w, h, &density))?;
        if let (Some(t), Some(e)) = (&result.threshold, &result.error) {
            let ratio: Vec<f32> = e.iter().zip(t).map(|(e, t)| e / t.max(1e-30)).collect();
            let img = crate::imaging::false_colour(&ratio, 1.0 / 16.0, 16.0);
            let ratio_path = with_ext(stem, "ratio.png");
            out.stage(&ratio_path, |wr| write_png(wr, &ratio_path, w, h, &img))?;
        }
    }
    out.commit()?;
    Ok(Written { display, look })
}
