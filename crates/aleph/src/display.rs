//! The display pipeline shared by `aleph render` and `aleph tonemap`: calibrate linear RGB to
//! cd/m², find adaptation luminance, apply a tone operator from `perception::tmo`, and encode.
//! Also the contact sheet of every operator, labelled, like the seed paper's Figure 4.

use perception::adaptation::{AdaptationMode, adaptation_luminance};
use perception::photometry::luminance_image;
use perception::tmo::pattanaik00::AdaptationState;
use perception::tmo::{Display, Operator};
use perception::viewing::ViewingConditions;
use rayon::prelude::*;

/// How an HDR image becomes a display image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneMapSettings {
    /// The operator.
    pub operator: Operator,
    /// Adaptation luminance: global log average, or a local mean over 1°. WRP always builds its
    /// histogram from the local (foveal, 1°) map, as its paper does.
    pub adaptation: AdaptationMode,
    /// Viewing conditions (pixels per degree) for the 1° window.
    pub view: ViewingConditions,
    /// Display overrides (`None`: each operator's documented defaults).
    pub display: Display,
    /// cd/m² per unit of the linear input.
    pub luminance_scale: f32,
    /// The viewer's adaptation carried from earlier frames of a sequence (Pattanaik et al.
    /// 2000's time course). When set, PTYG maps with it (global, time-dependent adaptation and
    /// bleaching) and the exposure operator's scale is key / the cone adaptation luminance,
    /// instead of each taking its adaptation from the image itself.
    pub adaptation_state: Option<AdaptationState>,
}

impl Default for ToneMapSettings {
    fn default() -> Self {
        ToneMapSettings {
            operator: Operator::Wrp,
            adaptation: AdaptationMode::LocalArithmetic,
            view: ViewingConditions::default(),
            display: Display::default(),
            luminance_scale: 100.0,
            adaptation_state: None,
        }
    }
}

/// Tone maps linear RGB (interleaved, `width × height`) to display-linear RGB in [0, 1]. An
/// all-black image maps to black under every operator.
///
/// # Errors
/// [`perception::PerceptionError`] for bad sizes, NaN/infinite/negative values or bad display
/// settings.
pub fn tone_map(
    rgb: &[f32],
    width: usize,
    height: usize,
    s: &ToneMapSettings,
) -> perception::Result<Vec<f32>> {
    if !(s.luminance_scale.is_finite() && s.luminance_scale > 0.0) {
        return Err(perception::PerceptionError::Parameter {
            name: "luminance scale (cd/m² per unit)",
            value: s.luminance_scale as f64,
            range: "a positive number",
        });
    }
    perception::PerceptionError::check_rgb(rgb, width, height)?;
    if rgb.iter().all(|&v| v == 0.0) {
        // Every operator maps zero luminance to zero display luminance: a black render (a
        // camera facing away from every light) is displayed black, not refused.
        return Ok(vec![0.0; rgb.len()]);
    }
    // The curve frozen from the image itself is the operator's own curve for that image.
    FrozenToneMap::new(rgb, width, height, s)?.map(rgb)
}

/// A tone mapping whose image-dependent parts — the adaptation map, exposure scale, Reinhard's
/// log average and white — are fixed from one image, so that other images (the half-buffers of
/// the same render, later passes) are mapped by exactly the same curve. The adaptive sampler
/// uses it to measure noise in display luminance.
#[derive(Clone, Debug)]
pub struct FrozenToneMap {
    settings: ToneMapSettings,
    width: usize,
    height: usize,
    /// The adaptation map (cd/m²), for the operators that map through one (TR, FPSG, WRP,
    /// static PTYG); empty for the others.
    adaptation: Vec<f32>,
    exposure_scale: f64,
    reinhard: (f64, f64),
}

impl FrozenToneMap {
    /// Freezes the curve that `settings` gives for `rgb` (linear, `width × height`).
    ///
    /// # Errors
    /// As [`tone_map`].
    pub fn new(
        rgb: &[f32],
        width: usize,
        height: usize,
        s: &ToneMapSettings,
    ) -> perception::Result<Self> {
        let rgb_cd: Vec<f32> = rgb.iter().map(|&v| v * s.luminance_scale).collect();
        let lum = luminance_image(&rgb_cd, 1.0);
        let mode = if s.operator == Operator::Wrp {
            AdaptationMode::LocalArithmetic
        } else {
            s.adaptation
        };
        // Only the operators that map through a local adaptation map need it.
        let needs_map = match s.operator {
            Operator::Exposure | Operator::Reinhard => false,
            Operator::Ptyg => s.adaptation_state.is_none(),
            Operator::Tr | Operator::Fpsg | Operator::Wrp => true,
        };
        let adaptation = if needs_map {
            adaptation_luminance(&lum, width, height, &s.view, mode, 1.0)?
        } else {
            Vec::new()
        };
        let exposure = perception::tmo::exposure::Exposure::default();
        let adapted = match s.adaptation_state {
            Some(state) => state.cone_neural,
            None => perception::adaptation::log_average(&lum) as f64,
        };
        let exposure_scale = exposure.key / adapted.max(1e-9);
        let reinhard =
            perception::tmo::reinhard02::Reinhard02::default().parameters(&rgb_cd, width);
        Ok(FrozenToneMap {
            settings: *s,
            width,
            height,
            adaptation,
            exposure_scale,
            reinhard,
        })
    }

    /// The same frozen curve with the image graded by `ev` stops (its input multiplied by
    /// 2^ev before the curve): how a user who grades the EXR brighter (`ev` > 0) or darker
    /// sees it, with the tone curve's image-dependent parts left where the image put them.
    pub fn graded(&self, ev: f64) -> FrozenToneMap {
        let mut g = self.clone();
        g.settings.luminance_scale *= 2f64.powf(ev) as f32;
        g
    }

    /// The same frozen curve for images in other units: `k` cd/m² per unit of the linear
    /// input (the curve was frozen from an image at its own scale; this one is mapped at `k`).
    pub fn with_luminance_scale(mut self, k: f32) -> FrozenToneMap {
        self.settings.luminance_scale = k;
        self
    }

    /// Display luminance in cd/m² of the display's white (value 1): the operator's L_dmax
    /// (TR/FPSG 125, WRP 100, PTYG its white 125; exposure and Reinhard 100, an sRGB display).
    pub fn display_max_cd_m2(&self) -> f64 {
        let d = &self.settings.display;
        match self.settings.operator {
            Operator::Tr | Operator::Fpsg => d.max_cd_m2.unwrap_or(125.0),
            Operator::Wrp => d.max_cd_m2.unwrap_or(100.0),
            Operator::Ptyg => d.max_cd_m2.unwrap_or(
                d.ambient_cd_m2.unwrap_or(25.0) * perception::tmo::pattanaik00::WHITE_FACTOR,
            ),
            Operator::Exposure | Operator::Reinhard => d
                .max_cd_m2
                .unwrap_or(perception::photometry::SRGB_WHITE_CD_M2 as f64),
        }
    }

    /// Maps linear RGB of the frozen size to display-linear RGB in [0, 1] with the frozen curve.
    ///
    /// # Errors
    /// As [`tone_map`] (an all-black image is not an error here).
    pub fn map(&self, rgb: &[f32]) -> perception::Result<Vec<f32>> {
        use perception::tmo::*;
        let s = &self.settings;
        let rgb_cd: Vec<f32> = rgb
            .par_iter()
            .map(|&v| (v * s.luminance_scale).max(0.0))
            .collect();
        let (w, h) = (self.width, self.height);
        perception::PerceptionError::check_rgb(&rgb_cd, w, h)?;
        let display = &s.display;
        display.validate()?;
        Ok(match s.operator {
            Operator::Exposure => exposure::Exposure {
                scale: Some(self.exposure_scale),
                key: 0.18,
            }
            .map(&rgb_cd),
            Operator::Reinhard => reinhard02::Reinhard02 {
                key: 0.18,
                white: Some(self.reinhard.1),
                log_average: Some(self.reinhard.0),
            }
            .map(&rgb_cd, w),
            Operator::Ptyg if s.adaptation_state.is_some() => {
                let p = ptyg_display(display);
                let state = s.adaptation_state.expect("matched");
                pattanaik00::Pattanaik00::map_dynamic(&p, &rgb_cd, &state)
            }
            op => {
                // These operators depend on the image only through the adaptation map.
                let mut out = perception::tmo::apply(op, &rgb_cd, w, h, &self.adaptation, display);
                if matches!(
                    &out,
                    Err(perception::PerceptionError::Parameter {
                        name: "image luminance",
                        ..
                    })
                ) {
                    out = Ok(vec![0.0; rgb.len()]);
                }
                out?
            }
        })
    }

    /// Display luminance (cd/m²) per pixel of linear RGB under the frozen curve.
    ///
    /// # Errors
    /// As [`FrozenToneMap::map`].
    pub fn display_luminance(&self, rgb: &[f32]) -> perception::Result<Vec<f32>> {
        let k = self.display_max_cd_m2() as f32;
        Ok(self
            .map(rgb)?
            .par_chunks_exact(3)
            .map(|p| perception::photometry::luminance(p[0], p[1], p[2]) * k)
            .collect())
    }
}

/// PTYG's display with the overrides of `display` (as `perception::tmo::apply` sets them).
fn ptyg_display(display: &Display) -> perception::tmo::pattanaik00::Pattanaik00 {
    let mut p = perception::tmo::pattanaik00::Pattanaik00::default();
    if let Some(a) = display.ambient_cd_m2 {
        p.display_adaptation_cd_m2 = a;
        p.display_white_cd_m2 = a * perception::tmo::pattanaik00::WHITE_FACTOR;
    }
    if let Some(m) = display.max_cd_m2 {
        p.display_white_cd_m2 = m;
    }
    p
}

/// The bundled DejaVu Sans (Bitstream Vera license, `assets/fonts/LICENSE.md`), for labels.
pub const LABEL_FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// Draws `text` in DejaVu Sans at `font_px` pixels per em onto 8-bit RGB `buf` (`w` wide) with
/// its top-left near (`x`, `y`), white, blended by the glyphs' coverage (ab_glyph's
/// rasterizer); pixels outside the image are skipped.
fn draw_label(buf: &mut [u8], w: usize, (x, y): (i32, i32), text: &str, font_px: f32) {
    use ab_glyph::{Font, FontRef, ScaleFont};
    let Ok(font) = FontRef::try_from_slice(LABEL_FONT) else {
        return;
    };
    let font = font.as_scaled(font_px);
    let h = buf.len() / (3 * w.max(1));
    let baseline = y as f32 + font.ascent();
    let mut pen = x as f32;
    let mut prev = None;
    for c in text.chars() {
        let id = font.glyph_id(c);
        if let Some(p) = prev {
            pen += font.kern(p, id);
        }
        prev = Some(id);
        let glyph = id.with_scale_and_position(font_px, ab_glyph::point(pen, baseline));
        if let Some(g) = font.outline_glyph(glyph) {
            let r = g.px_bounds();
            g.draw(|gx, gy, a| {
                let (px, py) = (r.min.x as i64 + gx as i64, r.min.y as i64 + gy as i64);
                if px < 0 || py < 0 || px as usize >= w || py as usize >= h {
                    return;
                }
                let i = 3 * (py as usize * w + px as usize);
                for v in &mut buf[i..i + 3] {
                    *v = (*v as f32 + (255.0 - *v as f32) * a.clamp(0.0, 1.0)).round() as u8;
                }
            });
        }
        pen += font.h_advance(id);
    }
}

/// A labelled grid of every operator's result (3 columns), each tile at most 480 pixels wide.
/// Returns 8-bit sRGB, width and height.
///
/// # Errors
/// As [`tone_map`].
pub fn contact_sheet(
    rgb: &[f32],
    width: usize,
    height: usize,
    s: &ToneMapSettings,
) -> perception::Result<(Vec<u8>, u32, u32)> {
    let factor = width.div_ceil(480).max(1);
    let (small, tw, th) = crate::imaging::downscale(rgb, width, height, factor);
    let (tw, th) = (tw.max(1), th.max(1));
    let tiles: Vec<(String, Vec<u8>)> = Operator::ALL
        .iter()
        .map(|&op| {
            let d = tone_map(&small, tw, th, &ToneMapSettings { operator: op, ..*s })?;
            Ok((op.label().to_string(), crate::output::encode_srgb8(&d)))
        })
        .collect::<perception::Result<_>>()?;
    Ok(labelled_grid(tiles, tw, th, 3, 17))
}

/// A filmstrip contact sheet of a sequence: the display images of `frames` (frame number and
/// 8-bit sRGB of `width × height` each), shrunk to at most 192 pixels wide, 6 to a row, each
/// labelled with its frame number. Returns 8-bit sRGB, width and height.
pub fn filmstrip(frames: &[(i64, Vec<u8>)], width: usize, height: usize) -> (Vec<u8>, u32, u32) {
    let factor = width.div_ceil(192).max(1);
    let (tw, th) = ((width / factor).max(1), (height / factor).max(1));
    let tiles: Vec<(String, Vec<u8>)> = frames
        .iter()
        .map(|(index, img)| {
            let lin: Vec<f32> = img.iter().map(|&v| v as f32).collect();
            let (small, _, _) = crate::imaging::downscale(&lin, width, height, factor);
            let tile = small.iter().map(|&v| v.round() as u8).collect();
            (format!("frame {index}"), tile)
        })
        .collect();
    labelled_grid(tiles, tw, th, frames.len().clamp(1, 6), 15)
}

/// Tiles of `tw × th` 8-bit sRGB, `cols` to a row on a dark ground, each under its label set
/// in DejaVu Sans at `font_px`. Returns 8-bit sRGB, width and height.
fn labelled_grid(
    tiles: Vec<(String, Vec<u8>)>,
    tw: usize,
    th: usize,
    cols: usize,
    font_px: u32,
) -> (Vec<u8>, u32, u32) {
    let label_h = font_px as usize + 11;
    let rows = tiles.len().div_ceil(cols).max(1);
    let (sw, sh) = (cols * tw, rows * (th + label_h));
    let mut buf: Vec<u8> = [24u8, 24, 24].repeat(sw * sh);
    for (i, (label, tile)) in tiles.into_iter().enumerate() {
        let (cx, cy) = ((i % cols) * tw, (i / cols) * (th + label_h));
        for (row, src) in tile.chunks_exact(3 * tw).take(th).enumerate() {
            let at = 3 * ((cy + label_h + row) * sw + cx);
            buf[at..at + 3 * tw].copy_from_slice(src);
        }
        draw_label(
            &mut buf,
            sw,
            (cx as i32 + 7, cy as i32 + 4),
            &label,
            font_px as f32,
        );
    }
    (buf, sw as u32, sh as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grade_is_the_frozen_curve_of_the_scaled_input() {
        // Exposure and WRP curves, frozen from one image: the image graded by ±2 EV maps as
        // the image × 2^±2 does under the ungraded frozen curve (and is not the same image).
        let (w, h) = (16, 8);
        let rgb: Vec<f32> = (0..w * h * 3)
            .map(|i| 0.01 + (i % 37) as f32 * 0.05)
            .collect();
        for op in [Operator::Exposure, Operator::Wrp] {
            let s = ToneMapSettings {
                operator: op,
                ..ToneMapSettings::default()
            };
            let f = FrozenToneMap::new(&rgb, w, h, &s).unwrap();
            for ev in [-2.0, 2.0] {
                let scaled: Vec<f32> = rgb.iter().map(|v| v * 2f32.powf(ev as f32)).collect();
                let a = f.graded(ev).map(&rgb).unwrap();
                let b = f.map(&scaled).unwrap();
                for (x, y) in a.iter().zip(&b) {
                    assert!(
                        (x - y).abs() <= 1e-6 * y.abs().max(1.0),
                        "{op:?} {ev}: {x} vs {y}"
                    );
                }
                assert_ne!(a, f.map(&rgb).unwrap());
            }
        }
    }
}
