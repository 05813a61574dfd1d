//! What a render job reports while it runs: the [`Observer`] a caller implements (the CLI's
//! progress bars and summary lines, the Python package's callbacks) and what it is shown.

use crate::adaptive::{AdaptiveResult, AdaptiveSettings, PassReport};
use crate::deliver::Look;
use crate::scene::Scene;
use std::path::Path;
use std::time::Duration;

/// What a render reports while it runs. Every method has an empty default; `()` observes
/// nothing. Called from the rendering thread (never from rayon's workers, except
/// [`Observer::samples`], hence `Sync`).
pub trait Observer: Sync {
    /// The scene was loaded in `load` (by [`run`]; [`run_on`] is handed a loaded scene).
    fn loaded(&self, _scene: &Scene, _load: Duration) {}
    /// A sequence of frames `first..=last` starts (after its adaptation pre-passes).
    fn sequence_started(&self, _first: i64, _last: i64) {}
    /// A pass of the adaptive loop ended (`frame`: the frame number in a sequence).
    fn pass(&self, _frame: Option<i64>, _report: &PassReport) {}
    /// Samples were taken (called from worker threads, often: with 0 when a row of pixels
    /// starts, with its samples when it ends; see [`crate::render::render_counts`] for
    /// stopping a render from here).
    fn samples(&self, _n: u64) {}
    /// A frame (or the still) was rendered and, with an output stem, written.
    fn frame_done(&self, _done: &FrameDone<'_>) {}
    /// A preview's refinement was written ([`super::OutputSpec::preview`]).
    fn refined(&self, _refinement: &Refined<'_>) {}
}

/// One refinement of a preview, as [`Observer::refined`] sees it.
pub struct Refined<'a> {
    /// The refinement's number, 1 for the first image ([`crate::adaptive::Refinement::number`]:
    /// the first image shows each pixel's first sample).
    pub number: usize,
    /// Mean samples per pixel of the image.
    pub mean_spp: f64,
    /// Whether it was denoised.
    pub denoised: bool,
    /// The PNG written.
    pub path: &'a Path,
    /// Wall time since the frame's render began.
    pub elapsed: Duration,
}

impl Observer for () {}

/// One rendered frame, as [`Observer::frame_done`] sees it.
pub struct FrameDone<'a> {
    /// The scene at the frame.
    pub scene: &'a Scene,
    /// The settings it was rendered with.
    pub settings: &'a AdaptiveSettings,
    /// The film, maps and statistics.
    pub result: &'a AdaptiveResult,
    /// The frame's output stem (`None` when the job writes no files).
    pub stem: Option<&'a Path>,
    /// Words for the summary: the operator or exposure of the PNG.
    pub look: &'a str,
    /// How the display image (the PNG) is made from the radiance
    /// ([`crate::deliver::display_image`]).
    pub display: Look,
    /// The denoised image the outputs show, when the job denoises (`--denoise`); the
    /// result's film is then the raw render.
    pub denoised: Option<&'a crate::denoise::Denoised>,
}
