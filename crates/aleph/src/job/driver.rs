//! The driver: one [`RenderJob`] from a loaded scene to its files, for stills, sequences
//! (the library's single frame loop, [`crate::sequence::Sequence`]), sample parts and row
//! tiles. Progress and each frame's result reach an [`Observer`]; the CLI's progress bars and
//! summary lines are one.

use super::observer::{FrameDone, Observer, Refined};
use super::{JobError, RenderJob, Split, content_hash};
use crate::adaptive::{
    AdaptiveResult, AdaptiveSettings, PassReport, Refinement, render_adaptive,
    render_adaptive_refining,
};
use crate::deliver::{Look, numbered, with_ext, write_render, write_sequence_outputs};
use crate::display::ToneMapSettings;
use crate::partial::{part_path, part_range, render_part, tile_of, write_partial};
use crate::render::RenderStats;
use crate::scene::Scene;
use crate::sequence::Sequence;
use perception::tmo::pattanaik00::AdaptationState;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What a job did, beyond its frames.
#[derive(Clone, Debug)]
pub enum JobReport {
    /// A still.
    Still,
    /// A sequence.
    Sequence(SequenceReport),
    /// A sample part (`--part`).
    Part(PartReport),
    /// A row tile (`--tile`).
    Tile(TileReport),
}

/// A rendered sequence.
#[derive(Clone, Debug)]
pub struct SequenceReport {
    /// First and last frame.
    pub frames: (i64, i64),
    /// Frames per second.
    pub fps: f64,
    /// Mean samples per pixel over all frames.
    pub mean_spp: f64,
    /// Wall time of the whole sequence.
    pub wall: Duration,
    /// Wall time of the adaptation pre-passes.
    pub prepass: Duration,
    /// Wall time of the perception model's decisions, all frames.
    pub perception: Duration,
    /// The animated preview and filmstrip, when written.
    pub previews: Option<(PathBuf, PathBuf)>,
    /// The reuse window the frames were rendered with and the one the job asked for
    /// ([`RenderJob::reuse_window_for`] cuts it to what the reuse memory holds), frames.
    pub reuse_window: (u32, u32),
}

/// A rendered sample part.
#[derive(Clone, Debug)]
pub struct PartReport {
    /// Part I of K.
    pub part: (u32, u32),
    /// The sample indices `first..end` every pixel holds, of `spp`.
    pub samples: (u32, u32),
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// Rendering statistics.
    pub stats: RenderStats,
    /// The partial film written.
    pub path: PathBuf,
}

/// A rendered row tile.
#[derive(Clone, Debug)]
pub struct TileReport {
    /// Tile I of K.
    pub tile: (u32, u32),
    /// The tile's rows `start..end`.
    pub rows: (u32, u32),
    /// The rows that took samples (the tile and its margins).
    pub sampled_rows: (u32, u32),
    /// Mean spp over the tile's rows, and all samples over those rows' pixels.
    pub mean_spp: (f64, f64),
    /// Why the loop stopped.
    pub stop: crate::adaptive::StopReason,
    /// Wall time of the adaptive loop.
    pub wall: Duration,
    /// The partial film written.
    pub path: PathBuf,
}

/// Loads the job's scene and renders it ([`run_on`]).
///
/// # Errors
/// [`JobError`], naming the scene file, the frame or the setting; no file is replaced then
/// (outputs are written all or nothing, frame by frame).
pub fn run(job: &RenderJob, observer: &dyn Observer) -> Result<JobReport, JobError> {
    job.validate()?;
    let start = Instant::now();
    let scene = job.load_scene()?;
    observer.loaded(&scene, start.elapsed());
    run_on(job, &scene, observer)
}

/// Renders `job` on `scene` (loaded from the job's scene, at its first frame): a still, the
/// frames of a sequence, or one part of a frame.
///
/// # Errors
/// As [`run`].
pub fn run_on(
    job: &RenderJob,
    scene: &Scene,
    observer: &dyn Observer,
) -> Result<JobReport, JobError> {
    job.validate()?;
    if let Some(stem) = &job.output.stem {
        crate::output::check_output_location(&with_ext(stem, "exr"))?;
        crate::output::check_output_location(&with_ext(stem, "png"))?;
    }
    if let Some(split) = job.split {
        return match split {
            Split::Part { index, count } => {
                render_sample_part(job, scene, (index, count)).map(JobReport::Part)
            }
            Split::Tile {
                index,
                count,
                margin,
            } => render_tile(job, scene, (index, count), margin, observer).map(JobReport::Tile),
        };
    }
    let range = match (job.frames, scene.animation) {
        (Some([a, b]), _) => Some((a, b)),
        (None, Some(a)) => Some((a.frame_start, a.frame_end)),
        (None, None) => None,
    };
    match range {
        Some(_) if job.output.preview => Err(JobError::Invalid(format!(
            "{}: --preview is of one still; this scene is animated (render one --frame \
             without --preview, or the sequence)",
            scene.path.display()
        ))),
        Some((first, last)) => {
            render_sequence(job, scene, first, last, observer).map(JobReport::Sequence)
        }
        None if job.sampling.reuse_window.is_some_and(|k| k > 0) => {
            Err(JobError::Invalid(format!(
                "{}: --reuse-window needs a sequence (this scene has no [animation] table): \
                 frames reuse the samples of the frames before them",
                scene.path.display()
            )))
        }
        None => {
            let (settings, look) = job.settings(scene, None)?;
            let stem = job.output.stem.as_deref();
            render_frame(job, scene, &settings, look, stem, observer)?;
            Ok(JobReport::Still)
        }
    }
}

/// Renders one frame with `settings`, writes it to `stem` (if any) and reports it.
fn render_frame(
    job: &RenderJob,
    scene: &Scene,
    settings: &AdaptiveSettings,
    look: Look,
    stem: Option<&Path>,
    observer: &dyn Observer,
) -> Result<(AdaptiveResult, Vec<u8>), JobError> {
    let result = match stem.filter(|_| job.output.preview) {
        Some(stem) => preview(scene, settings, look, stem, observer)?,
        None => adaptive(scene, settings, None, observer)?.0,
    };
    let display = deliver_frame(job, scene, settings, look, stem, observer, &result)?;
    Ok((result, display))
}

/// The adaptive loop of a preview: after every pass the image (denoised when the loop
/// denoises) goes to STEM.png, atomically, and to the observer.
fn preview(
    scene: &Scene,
    settings: &AdaptiveSettings,
    look: Look,
    stem: &Path,
    observer: &dyn Observer,
) -> Result<AdaptiveResult, JobError> {
    let start = Instant::now();
    let png = with_ext(stem, "png");
    let failed = std::sync::Mutex::new(None);
    let refined = |r: &Refinement| {
        if failed.lock().expect("not poisoned").is_some() {
            return;
        }
        match write_refinement(scene, r, look, &png) {
            Ok(()) => observer.refined(&Refined {
                number: r.number,
                mean_spp: r.film.total_samples() as f64 / r.film.len() as f64,
                denoised: r.denoised.is_some(),
                path: &png,
                elapsed: start.elapsed(),
            }),
            Err(e) => *failed.lock().expect("not poisoned") = Some(e),
        }
    };
    let frame = scene.animation.map(|_| scene.frame.index);
    let pass = |p: &PassReport| observer.pass(frame, p);
    let samples = |n| observer.samples(n);
    let result = render_adaptive_refining(scene, settings, &pass, &samples, &refined)?;
    match failed.into_inner().expect("not poisoned") {
        Some(e) => Err(e),
        None => Ok(result),
    }
}

/// Writes one refinement's display image to `png` (atomically).
fn write_refinement(scene: &Scene, r: &Refinement, look: Look, png: &Path) -> Result<(), JobError> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let raw;
    let rgb = match r.denoised {
        Some(rgb) => rgb,
        None => {
            raw = r.film.mean_rgb();
            &raw
        }
    };
    let (display, _) = crate::deliver::display_image(rgb, w as usize, h as usize, look)?;
    let mut out = crate::output::AtomicOutputs::new();
    out.stage(png, |wr| crate::output::write_png(wr, png, w, h, &display))?;
    out.commit()?;
    Ok(())
}

/// Writes a rendered frame to `stem` (if any) and reports it; returns the display image
/// (empty without a stem).
fn deliver_frame(
    job: &RenderJob,
    scene: &Scene,
    settings: &AdaptiveSettings,
    look: Look,
    stem: Option<&Path>,
    observer: &dyn Observer,
    result: &AdaptiveResult,
) -> Result<Vec<u8>, JobError> {
    let frame = Frame {
        scene,
        settings,
        look,
        stem,
        result,
    };
    let written = frame.write(job)?;
    Ok(frame.report(written, observer))
}

/// A rendered frame, ready to be written and reported.
struct Frame<'a> {
    scene: &'a Scene,
    settings: &'a AdaptiveSettings,
    look: Look,
    stem: Option<&'a Path>,
    result: &'a AdaptiveResult,
}

/// What writing a frame gave ([`Frame::write`]): the display image (empty without a stem),
/// words for the summary, and the image denoised after the loop (when the job denoises and
/// the loop did not).
struct Written {
    display: Vec<u8>,
    words: String,
    late: Option<crate::denoise::Denoised>,
}

impl Frame<'_> {
    /// Denoises the frame when the job asks and its loop did not (a frame that reused earlier
    /// frames, a budget rendered uniformly), with or without files to write; then writes its
    /// files to the stem (if any).
    fn write(&self, job: &RenderJob) -> Result<Written, JobError> {
        let (scene, result) = (self.scene, self.result);
        let t = std::time::Instant::now();
        let late = match (&result.denoised, job.denoises()) {
            (None, true) => {
                let reused = result.reuse.as_ref().map_or(0.0, |r| r.mean_history_spp);
                let spp = result.mean_spp() + reused;
                let mut d = crate::denoise::denoise_render(
                    scene,
                    result.film.mean_rgb(),
                    spp,
                    job.output.denoise_quality,
                )?;
                // Not a frame that reused earlier frames: its film's half-buffers do not hold
                // the reused samples' error.
                if result.reuse.is_none() {
                    d.blend_with_noisy(&result.film, spp);
                }
                Some(d)
            }
            _ => None,
        };
        let denoise_s = (t.elapsed() + result.denoise_time).as_secs_f64();
        let Some(stem) = self.stem else {
            let words = self.look.describe();
            return Ok(Written {
                display: Vec::new(),
                words,
                late,
            });
        };
        let denoised = self.denoised(&late);
        let w = write_render(
            scene,
            stem,
            self.settings,
            result,
            self.look,
            job.output.aov,
            denoised,
        )?;
        let words = match denoised {
            Some(d) if d.noisy_weight > 0.0 => format!(
                "{}; denoised by Open Image Denoise in {denoise_s:.2} s, blended with the \
                 noisy image by their estimated errors (the noisy image {:.1} % of the \
                 weight)",
                w.look,
                100.0 * d.noisy_weight
            ),
            Some(_) => format!(
                "{}; denoised by Open Image Denoise in {denoise_s:.2} s",
                w.look
            ),
            None => w.look,
        };
        Ok(Written {
            display: w.display,
            words,
            late,
        })
    }

    /// The denoised image the outputs show: the loop's, else the one denoised after it.
    fn denoised<'b>(
        &'b self,
        late: &'b Option<crate::denoise::Denoised>,
    ) -> Option<&'b crate::denoise::Denoised> {
        self.result.denoised.as_ref().or(late.as_ref())
    }

    /// Reports the written frame to `observer` (on the driver's thread, as the observer
    /// expects); returns its display image.
    fn report(&self, written: Written, observer: &dyn Observer) -> Vec<u8> {
        observer.frame_done(&FrameDone {
            scene: self.scene,
            settings: self.settings,
            result: self.result,
            stem: self.stem,
            look: &written.words,
            display: self.look,
            denoised: self.denoised(&written.late),
        });
        written.display
    }
}

/// A frame of a sequence, rendered, whose files are written while the next frame renders
/// ([`render_sequence`]).
struct Rendered {
    frame: crate::sequence::FrameContext,
    settings: AdaptiveSettings,
    look: Look,
    stem: Option<PathBuf>,
    result: AdaptiveResult,
}

impl Rendered {
    /// The frame to write and report.
    fn frame(&self) -> Frame<'_> {
        Frame {
            scene: &self.frame.scene,
            settings: &self.settings,
            look: self.look,
            stem: self.stem.as_deref(),
            result: &self.result,
        }
    }
}

/// Runs `render` on this thread while `pending`'s files are written on another (a frame's
/// EXR and PNG are compressed by one thread, 10–15 % of a sequence's wall time at preview
/// resolutions, during which the render's other threads would wait); without rendering
/// threads to spare (`--threads 1`), one after the other.
fn overlapped<R: Send>(
    job: &RenderJob,
    pending: Option<&Rendered>,
    render: impl FnOnce() -> R + Send,
) -> (R, Option<Result<Written, JobError>>) {
    let Some(p) = pending else {
        return (render(), None);
    };
    if rayon::current_num_threads() < 2 {
        let written = p.frame().write(job);
        return (render(), Some(written));
    }
    std::thread::scope(|s| {
        let writer = s.spawn(|| p.frame().write(job));
        let r = render();
        let written = writer
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (r, Some(written))
    })
}

/// The adaptive loop with the observer's progress: independent of other frames, or reusing
/// the base passes of the frames in `window` ([`crate::adaptive::render_reusing`]; then also
/// the frame's own base pass, for the frames after it).
fn adaptive(
    scene: &Scene,
    settings: &AdaptiveSettings,
    window: Option<&crate::reuse::ReuseWindow>,
    observer: &dyn Observer,
) -> Result<(AdaptiveResult, Option<crate::reuse::FrameSamples>), JobError> {
    let frame = scene.animation.map(|_| scene.frame.index);
    let pass = |p: &PassReport| observer.pass(frame, p);
    let samples = |n| observer.samples(n);
    Ok(match window {
        Some(w) => {
            let (r, base) = crate::adaptive::render_reusing(scene, settings, w, &pass, &samples)?;
            (r, Some(base))
        }
        None => (render_adaptive(scene, settings, &pass, &samples)?, None),
    })
}

/// Frames `first..=last`: the viewer's adaptation carried across them, numbered outputs, and
/// the animated preview and filmstrip.
fn render_sequence(
    job: &RenderJob,
    scene: &Scene,
    first: i64,
    last: i64,
    observer: &dyn Observer,
) -> Result<SequenceReport, JobError> {
    let start = Instant::now();
    let k = job.reuse_window_for(scene.camera.width as usize * scene.camera.height as usize);
    let anim_first = scene.animation.map_or(first, |a| a.frame_start);
    let warm = crate::reuse::warm_up_start(first, anim_first, k);
    let whole_from = crate::reuse::window_start(first, anim_first, k);
    let sequence = Sequence::new(scene, warm, last)?;
    observer.sequence_started(first, last);
    let stem = job.output.stem.as_deref();
    let (mut pending, mut finished) = (None, Vec::new());
    let (mut samples, mut pixels, mut perception) = (0u64, 0u64, Duration::ZERO);
    let mut window = crate::reuse::ReuseWindow::new(k);
    for frame in sequence.frames() {
        let frame = frame?;
        window.keep_from(crate::reuse::window_start(frame.index, anim_first, k));
        let (settings, look) = job.settings(&frame.scene, Some(frame.adaptation))?;
        if frame.index < whole_from {
            // A warm-up frame whose base pass alone the frames after it depend on.
            let own = crate::reuse::window_frames(frame.index, anim_first, k);
            window.push(crate::adaptive::render_base(
                &frame.scene,
                &settings,
                own,
                k,
            )?);
            continue;
        }
        if frame.index < first {
            // A warm-up frame whose samples the first frame reuses: rendered, not written.
            let (_, own) = adaptive(&frame.scene, &settings, Some(&window), &())?;
            window.push(own.expect("a reusing frame keeps its samples"));
            continue;
        }
        let fstem = stem.map(|s| numbered(s, frame.index));
        let reused = (k > 0).then_some(&window);
        let (rendered, written) = overlapped(job, pending.as_ref(), || {
            adaptive(&frame.scene, &settings, reused, observer)
        });
        if let (Some(p), Some(written)) = (pending.take(), written) {
            finished.push(p.frame().report(written?, observer));
        }
        let (result, base) = rendered?;
        if let Some(base) = base.filter(|_| frame.index < last) {
            window.push(base);
        }
        samples += result.film.total_samples();
        pixels += result.film.len() as u64;
        perception += result.decision_time;
        pending = Some(Rendered {
            frame,
            settings,
            look,
            stem: fstem,
            result,
        });
    }
    if let Some(p) = pending {
        let written = p.frame().write(job)?;
        finished.push(p.frame().report(written, observer));
    }
    let displays: Vec<(i64, Vec<u8>)> = (first..=last).zip(finished).collect();
    let previews = match stem {
        Some(stem) if job.output.sequence_outputs => {
            let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
            Some(write_sequence_outputs(
                stem,
                &displays,
                w,
                h,
                sequence.fps(),
            )?)
        }
        _ => None,
    };
    Ok(SequenceReport {
        frames: (first, last),
        fps: sequence.fps(),
        mean_spp: samples as f64 / pixels.max(1) as f64,
        wall: start.elapsed(),
        prepass: sequence.prepass_time(),
        perception,
        previews,
        reuse_window: (k, job.reuse_window()),
    })
}

/// The one frame a part or tile renders: the scene at it, the viewer's adaptation there (a
/// sequence's course runs from the animation's first frame) and the frame's output stem.
pub(super) fn split_frame(
    job: &RenderJob,
    scene: &Scene,
    stem: &Path,
) -> Result<(Scene, Option<AdaptationState>, PathBuf), JobError> {
    let bad = |m: &str| Err(JobError::Invalid(format!("{}: {m}", scene.path.display())));
    match (job.frames, scene.animation) {
        (Some([f, _]), Some(_)) => {
            let frame = Sequence::new(scene, f, f)?.frame(f)?;
            Ok((frame.scene, Some(frame.adaptation), numbered(stem, f)))
        }
        (Some(_), None) => {
            bad("--frame needs an animated scene (this one has no [animation] table)")
        }
        (None, Some(_)) => {
            bad("--part/--tile on an animated scene render one frame: give --frame N")
        }
        (None, None) => Ok((scene.clone(), None, stem.to_path_buf())),
    }
}

/// The record a part keeps: the job without split and outputs, with the scene's absolute path
/// and content hash.
pub(super) fn part_record(job: &RenderJob) -> Result<String, JobError> {
    let mut record = job.clone();
    record.split = None;
    record.output = Default::default();
    let path =
        std::path::absolute(&job.scene.path).map_err(|source| crate::error::SceneError::Io {
            path: job.scene.path.clone(),
            source,
        })?;
    record.scene.content_hash = Some(content_hash(&path)?);
    record.scene.path = path;
    Ok(record.to_toml())
}

/// The output stem a split job needs.
fn split_stem(job: &RenderJob) -> Result<&Path, JobError> {
    job.output.stem.as_deref().ok_or_else(|| {
        JobError::Invalid(
            "a part or tile is written to a file: the job needs an output stem".into(),
        )
    })
}

/// Samples (I−1)·N/K .. I·N/K of every pixel, to `STEM[.NNNN].part-I-of-K.exr`.
fn render_sample_part(
    job: &RenderJob,
    scene: &Scene,
    (i, k): (u32, u32),
) -> Result<PartReport, JobError> {
    let (scene, _, stem) = split_frame(job, scene, split_stem(job)?)?;
    let settings = job.adaptive_settings(scene.settings.spp, ToneMapSettings::default())?;
    let spp = settings.uniform_total_spp();
    if k > spp {
        return Err(JobError::Invalid(format!(
            "--part {i}/{k}: {k} parts of {spp} samples per pixel would leave parts empty"
        )));
    }
    let record = part_record(job)?;
    let path = part_path(&stem, i, k, false);
    crate::output::check_output_location(&path)?;
    let (part, stats) = render_part(&scene, spp, i, k, record, &|_| {});
    write_partial(&path, &part)?;
    Ok(PartReport {
        part: (i, k),
        samples: part_range(spp, i, k),
        spp,
        stats,
        path,
    })
}

/// Row tile I of K rendered adaptively to `STEM[.NNNN].tile-I-of-K.exr`: samples go to the
/// tile's rows and `margin` rows on each side, with the budget counted over those rows; the
/// file keeps the tile's own rows.
fn render_tile(
    job: &RenderJob,
    scene: &Scene,
    (i, k): (u32, u32),
    margin: u32,
    observer: &dyn Observer,
) -> Result<TileReport, JobError> {
    let (scene, adaptation, stem) = split_frame(job, scene, split_stem(job)?)?;
    let h = scene.camera.height;
    if k > h {
        return Err(JobError::Invalid(format!(
            "--tile {i}/{k}: {k} tiles of {h} rows would leave tiles empty"
        )));
    }
    let (mut settings, _) = job.settings(&scene, adaptation)?;
    let (y0, y1) = part_range(h, i, k);
    let sampled = (y0.saturating_sub(margin), (y1 + margin).min(h));
    settings.rows = Some(sampled);
    let record = part_record(job)?;
    let path = part_path(&stem, i, k, true);
    crate::output::check_output_location(&path)?;
    let (r, _) = adaptive(&scene, &settings, None, observer)?;
    let te = r.threshold.as_deref().zip(r.error.as_deref());
    let part = tile_of(&r.film, (y0, y1), te, i, k, record);
    write_partial(&path, &part)?;
    let n = part.film.len() as f64;
    Ok(TileReport {
        tile: (i, k),
        rows: (y0, y1),
        sampled_rows: sampled,
        mean_spp: (
            part.film.total_samples() as f64 / n,
            r.film.total_samples() as f64 / n,
        ),
        stop: r.stop,
        wall: r.wall,
        path,
    })
}
