//! `aleph render` of an animated scene: frames one after another, numbered outputs, the
//! viewer's adaptation carried across frames, an animated preview and a filmstrip.

use super::render::{RenderArgs, frame_settings, render_with_progress, summary_line};
use aleph::deliver::{with_ext, write_render};
use aleph::display::filmstrip;
use aleph::output::{AtomicOutputs, write_apng, write_png};
use aleph::scene::Scene;
use aleph::sequence::AdaptationCourse;
use anyhow::Context;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// `STEM.NNNN`: the numbering compositing tools expect (four digits, more when needed).
pub fn numbered(stem: &Path, frame: i64) -> PathBuf {
    with_ext(stem, &format!("{frame:04}"))
}

/// Largest width of the animated preview; larger frames are shrunk by an integer factor.
const PREVIEW_MAX_WIDTH: usize = 640;

/// Box-shrinks 8-bit RGB by an integer factor.
fn shrink(rgb8: &[u8], w: usize, h: usize, f: usize) -> Vec<u8> {
    if f <= 1 {
        return rgb8.to_vec();
    }
    let (nw, nh) = (w / f, h / f);
    let mut out = vec![0u8; 3 * nw * nh];
    for y in 0..nh {
        for x in 0..nw {
            for c in 0..3 {
                let mut s = 0u32;
                for dy in 0..f {
                    for dx in 0..f {
                        s += rgb8[3 * ((y * f + dy) * w + x * f + dx) + c] as u32;
                    }
                }
                out[3 * (y * nw + x) + c] = (s / (f * f) as u32) as u8;
            }
        }
    }
    out
}

/// Renders frames `first..=last` of `scene` (already validated) to numbered outputs.
pub fn render_sequence(
    scene: &mut Scene,
    first: i64,
    last: i64,
    stem: &Path,
    args: &RenderArgs,
) -> anyhow::Result<ExitCode> {
    let anim = scene.animation.context("the scene is not animated")?;
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let start = Instant::now();
    let course = AdaptationCourse::compute(scene, last)?.context("the scene is not animated")?;
    let prepass_s = start.elapsed().as_secs_f64();

    let multi = MultiProgress::with_draw_target(ProgressDrawTarget::stderr());
    let seq_bar = multi.add(ProgressBar::new(last.abs_diff(first) + 1));
    seq_bar.set_style(
        ProgressStyle::with_template(
            "sequence {pos}/{len} frames [{bar:30}] {elapsed} (eta {eta})",
        )
        .unwrap(),
    );
    let frame_bar = multi.add(ProgressBar::new_spinner());
    frame_bar.set_style(ProgressStyle::with_template("{spinner} {elapsed} {msg}").unwrap());
    frame_bar.enable_steady_tick(Duration::from_millis(200));

    let mut displays = Vec::new();
    let (mut samples, mut pixels, mut perception_s) = (0u64, 0u64, 0.0);
    for f in first..=last {
        scene.set_frame(f)?;
        let (settings, look) = frame_settings(scene, args, &course)?;
        frame_bar.reset_elapsed();
        let result = render_with_progress(scene, &settings, &frame_bar, &format!("frame {f}: "))?;
        let fstem = numbered(stem, f);
        let written = write_render(scene, &fstem, &settings, &result, look, args.aov)?;
        let line = summary_line(scene, &settings, &result, &fstem, &written.look);
        multi.suspend(|| println!("{line}"));
        samples += result.film.total_samples();
        pixels += result.film.len() as u64;
        perception_s += result.decision_time.as_secs_f64();
        displays.push((f, written.display));
        seq_bar.inc(1);
    }
    frame_bar.finish_and_clear();
    seq_bar.finish_and_clear();

    if !args.sequence_outputs {
        return Ok(ExitCode::SUCCESS);
    }
    let (preview, strip) = write_sequence_outputs(stem, &displays, w, h, anim.fps)?;
    let wall = start.elapsed().as_secs_f64();
    println!(
        "{}: sequence of {} frames ({first}-{last} at {} fps), {:.1} spp mean, {:.1} s \
         ({:.2} s/frame; {:.2} s adaptation pre-passes, {:.2} s perception) -> {}, {}",
        scene.path.display(),
        displays.len(),
        anim.fps,
        samples as f64 / pixels.max(1) as f64,
        wall,
        wall / displays.len().max(1) as f64,
        prepass_s,
        perception_s,
        preview.display(),
        strip.display(),
    );
    Ok(ExitCode::SUCCESS)
}

/// Writes `STEM.preview.png` (animated PNG at `fps`) and `STEM.filmstrip.png`, together.
pub(super) fn write_sequence_outputs(
    stem: &Path,
    displays: &[(i64, Vec<u8>)],
    w: usize,
    h: usize,
    fps: f64,
) -> anyhow::Result<(PathBuf, PathBuf)> {
    let factor = w.div_ceil(PREVIEW_MAX_WIDTH).max(1);
    let (pw, ph) = ((w / factor).max(1), (h / factor).max(1));
    let frames: Vec<Vec<u8>> = displays
        .iter()
        .map(|(_, d)| shrink(d, w, h, factor))
        .collect();
    let preview = with_ext(stem, "preview.png");
    let strip_path = with_ext(stem, "filmstrip.png");
    let (strip, sw, sh) = filmstrip(displays, w, h);
    let mut out = AtomicOutputs::new();
    out.stage(&preview, |wr| {
        write_apng(wr, &preview, pw as u32, ph as u32, &frames, fps)
    })?;
    out.stage(&strip_path, |wr| write_png(wr, &strip_path, sw, sh, &strip))?;
    out.commit().context("writing the sequence's preview")?;
    Ok((preview, strip_path))
}
