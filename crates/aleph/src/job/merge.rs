//! Merging the parts of one render (sample parts or row tiles, from several machines) into the
//! files the render writes on one machine.
//!
//! Parts belong together when their records ([`RenderJob`], stored in each partial film) have
//! equal [`RenderJob::image_key`]s: the same options in any order or spelling, the same scene
//! by content (its SHA-256), wherever it was on each machine. The scene is then loaded from
//! the first part's record, and must still have that content.

use super::driver::split_frame;
use super::{JobError, RenderJob, content_hash};
use crate::adaptive::{AdaptiveResult, StopReason};
use crate::deliver::{with_ext, write_render};
use crate::partial::{Merged, merge_parts_with};
use crate::render::RenderStats;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What [`merge`] wrote.
#[derive(Clone, Debug)]
pub struct MergeReport {
    /// The scene file.
    pub scene: PathBuf,
    /// Number of parts merged.
    pub parts: usize,
    /// Whether they were row tiles (else sample parts).
    pub tiles: bool,
    /// Mean samples per pixel of the merged frame.
    pub mean_spp: f64,
    /// Frame size.
    pub size: (u32, u32),
    /// The files written: the EXR and the PNG.
    pub files: (PathBuf, PathBuf),
    /// Words for the PNG's look.
    pub look: String,
    /// Wall time reading and summing the parts.
    pub read: Duration,
}

/// Refuses a merge whose outputs (`STEM.exr`, `STEM.png`, and a frame's `STEM.NNNN.*`) would
/// replace one of its input parts.
fn check_outputs_are_not_inputs(parts: &[PathBuf], stem: &Path) -> Result<(), JobError> {
    let canon = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let inputs: Vec<PathBuf> = parts.iter().map(|p| canon(p)).collect();
    let dir = stem.parent().map(canon).unwrap_or_default();
    let name = stem
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    for (part, input) in parts.iter().zip(&inputs) {
        let same_dir = input.parent() == Some(dir.as_path());
        let file = input
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        // STEM.exr / STEM.png, or a frame's STEM.NNNN.exr / .png.
        let written = file
            .strip_prefix(&format!("{name}."))
            .map(|rest| {
                let rest = rest.split_once('.').map_or(rest, |(n, ext)| {
                    if n.chars().all(|c| c.is_ascii_digit() || c == '-') {
                        ext
                    } else {
                        rest
                    }
                });
                rest == "exr" || rest == "png"
            })
            .unwrap_or(false);
        if same_dir && written {
            return Err(JobError::Invalid(format!(
                "-o {}: the merged files would replace the input part {}",
                stem.display(),
                part.display()
            )));
        }
    }
    Ok(())
}

/// Parses two part records and says how they differ, if they do.
fn same_render(a: &str, b: &str) -> Result<(), String> {
    let parse = |t: &str| RenderJob::from_toml(t, Path::new("")).map_err(|e| e.to_string());
    let (ja, jb) = (parse(a)?, parse(b)?);
    let (ka, kb) = (ja.image_key(), jb.image_key());
    if ka == kb {
        return Ok(());
    }
    let (ta, tb) = (ka.to_toml(), kb.to_toml());
    let diff: Vec<String> = ta
        .lines()
        .zip(tb.lines())
        .filter(|(x, y)| x != y)
        .map(|(x, y)| format!("{x}  ≠  {y}"))
        .collect();
    Err(format!("their records differ: {}", diff.join("; ")))
}

/// Merges the partial films `parts` (all K parts of one frame, in any order) and writes
/// `STEM.exr` and `STEM.png` (`STEM.NNNN.*` for a frame of a sequence) as the render would on
/// one machine (bit for bit for sample parts).
///
/// # Errors
/// [`JobError::Partial`] naming the part that cannot be read or does not fit;
/// [`JobError::Record`] for a record this aleph cannot use, a scene whose content changed, or
/// parts whose samples disagree with their record; otherwise as [`super::run`].
pub fn merge(parts: &[PathBuf], stem: &Path) -> Result<MergeReport, JobError> {
    let start = Instant::now();
    super::check_stem(stem)?;
    check_outputs_are_not_inputs(parts, stem)?;
    let merged = merge_parts_with(parts, &same_render)?;
    let first = &parts[0];
    let job = RenderJob::from_toml(&merged.recipe, first)?;
    let record_err = |message: String| JobError::Record {
        path: first.clone(),
        message,
    };
    let hash = content_hash(&job.scene.path)?;
    if job.scene.content_hash.as_deref() != Some(hash.as_str()) {
        return Err(record_err(format!(
            "the scene {} has changed since the parts were rendered (its content differs)",
            job.scene.path.display()
        )));
    }
    let read = start.elapsed();
    let scene = job.load_scene()?;
    let (scene, adaptation, stem) = split_frame(&job, &scene, stem)?;
    let (settings, look) = job.settings(&scene, adaptation)?;
    let Merged {
        film,
        threshold_error,
        tiles,
        ..
    } = merged;
    if (film.width, film.height) != (scene.camera.width, scene.camera.height) {
        return Err(record_err(format!(
            "the parts are {}×{} but their record renders {}×{}",
            film.width, film.height, scene.camera.width, scene.camera.height
        )));
    }
    if !tiles {
        let want = settings.uniform_total_spp();
        if let Some(n) = film.spp().iter().find(|&&n| n != want) {
            return Err(record_err(format!(
                "the parts hold {n} samples per pixel but their record asks for {want}"
            )));
        }
    }
    let (threshold, error) = threshold_error.unzip();
    let converged_fraction = match (&threshold, &error) {
        (Some(t), Some(e)) => {
            e.iter().zip(t).filter(|(e, t)| e <= t).count() as f64 / e.len().max(1) as f64
        }
        _ => 1.0,
    };
    let result = AdaptiveResult {
        stats: RenderStats::default(),
        guide_stats: None,
        passes: Vec::new(),
        stop: StopReason::Budget,
        converged_fraction,
        units: if threshold.is_some() {
            settings.units()
        } else {
            ""
        },
        threshold,
        error,
        decision_time: Duration::ZERO,
        wall: start.elapsed(),
        velocity: crate::velocity::render_velocity(&scene),
        gbuffer: Some(crate::gbuffer::GBuffer::render_aovs(&scene)),
        reuse: None,
        denoised: None,
        denoise_time: std::time::Duration::ZERO,
        film,
    };
    let written = write_render(&scene, &stem, &settings, &result, look, false, None)?;
    Ok(MergeReport {
        scene: scene.path.clone(),
        parts: parts.len(),
        tiles,
        mean_spp: result.mean_spp(),
        size: (scene.camera.width, scene.camera.height),
        files: (with_ext(&stem, "exr"), with_ext(&stem, "png")),
        look: written.look,
        read,
    })
}
