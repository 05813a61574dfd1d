//! Sequences: the viewer's adaptation carried across frames that still render independently.
//!
//! The displayed sequence follows the time course of adaptation (Pattanaik et al. 2000, §4;
//! [`AdaptationState`]): frame n's tone curve comes from the state reached by starting fully
//! adapted to the first frame of the sequence and advancing by 1/fps through the stimuli of
//! frames first..=n. A frame's stimulus (G_cone, G_rod) is the log average of its photopic and
//! scotopic luminance, which a cheap pre-pass gives: **samples in every 4th pixel of every 4th
//! row**, at least [`PREPASS_MIN_SAMPLES`] in all (1/16 spp on a large image), so that the state
//! at frame n is a deterministic function of the scene and n alone. The pre-pass uses the same
//! random numbers in every frame (common random numbers: the render seed, not the frame's), so
//! its noise cannot make the tone curve flicker: an unchanged image gives an unchanged stimulus. The samples are pooled in blocks of 8 × 8 sampled pixels
//! (32 × 32 image pixels, 64 samples) before the logarithm: the log of single path-traced
//! samples is biased low by their noise (Jensen's inequality; at 1 spp on the Cornell box the
//! adaptation came out several times too dark), while the log average is meant to see the
//! image's own contrast, which at the scale of 1° or more survives the pooling. Any frame can therefore render on any machine without
//! waiting for the others, at the cost of n/16 spp of pre-passes, and the full renders run in any
//! order.

use crate::error::SceneResult;
use crate::film::Film;
use crate::integrator::{Integrator, Strategy};
use crate::render::render_counts_seeded;
use crate::sampler::SampleStreams;
use crate::scene::Scene;
use perception::tmo::pattanaik00::AdaptationState;

/// Spacing of the adaptation pre-pass's pixels, both axes.
pub const PREPASS_STRIDE: usize = 4;

/// Fewest samples of a pre-pass: the log average's noise is then below about 1 % per frame on
/// the bundled scenes, and the neural adaptation's low-pass (t0 = 80 ms) halves it again.
pub const PREPASS_MIN_SAMPLES: usize = 16_384;

/// Sampled pixels per block side pooled before the logarithm.
pub const PREPASS_POOL: usize = 8;

/// Seed offset of the pre-pass (independent of the frame's own samples).
const PREPASS_SEED_XOR: u64 = 0x510E_527F_ADE6_82D1;

/// The stimuli (G_cone, G_rod), cd/m², of the scene's current frame from the 1/16-spp pre-pass.
pub fn adaptation_stimulus(scene: &Scene) -> (f64, f64) {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let sampled = w.div_ceil(PREPASS_STRIDE) * h.div_ceil(PREPASS_STRIDE);
    let spp = PREPASS_MIN_SAMPLES.div_ceil(sampled).max(1) as u32;
    let counts: Vec<u32> = (0..w * h)
        .map(|i| {
            let on = (i % w) % PREPASS_STRIDE == 0 && (i / w) % PREPASS_STRIDE == 0;
            if on { spp } else { 0 }
        })
        .collect();
    let integrator = Integrator {
        max_depth: scene.settings.max_depth,
        strategy: Strategy::Mis,
    };
    let mut film = Film::new(w as u32, h as u32);
    let seed = scene.settings.seed ^ PREPASS_SEED_XOR;
    render_counts_seeded(
        scene,
        &integrator,
        &mut film,
        &counts,
        seed,
        SampleStreams::Halves,
        &|_| {},
    );
    let k = scene.settings.luminance_scale as f64;
    let block = PREPASS_STRIDE * PREPASS_POOL;
    let (bw, bh) = (w.div_ceil(block), h.div_ceil(block));
    let mut sums = vec![(glam::DVec3::ZERO, 0u32); bw * bh];
    for (i, p) in film.pixels.iter().enumerate().filter(|(_, p)| p.n > 0) {
        let b = &mut sums[(i / w) / block * bw + (i % w) / block];
        b.0 += p.sum();
        b.1 += p.count();
    }
    let rgb_cd: Vec<f32> = sums
        .iter()
        .filter(|(_, n)| *n > 0)
        .flat_map(|(s, n)| (*s * (k / *n as f64)).as_vec3().to_array())
        .collect();
    AdaptationState::stimulus(&rgb_cd)
}

/// The viewer's adaptation over a sequence's frames.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptationCourse {
    /// Frames per second.
    pub fps: f64,
    /// The sequence's first frame (fully adapted to it).
    pub first: i64,
    /// Stimuli of frames `first`, `first + 1`, …, cd/m².
    pub stimuli: Vec<(f64, f64)>,
}

impl AdaptationCourse {
    /// Runs the pre-passes of frames first..=`last` of the scene's animation (on views of the
    /// scene at each frame; `scene` is unchanged). `None` for a still.
    ///
    /// # Errors
    /// As [`Scene::at_frame`] (`last` outside the frame range).
    pub fn compute(scene: &Scene, last: i64) -> SceneResult<Option<AdaptationCourse>> {
        let Some(anim) = scene.animation else {
            return Ok(None);
        };
        let mut stimuli = Vec::new();
        for f in anim.frame_start..=last {
            stimuli.push(adaptation_stimulus(&scene.at_frame(f)?));
        }
        Ok(Some(AdaptationCourse {
            fps: anim.fps,
            first: anim.frame_start,
            stimuli,
        }))
    }

    /// The state at frame `frame`: steady for the first frame's stimulus, then advanced by 1/fps
    /// under each later frame's stimulus. Frames past the computed ones hold the last state.
    pub fn state_at(&self, frame: i64) -> AdaptationState {
        let Some(&(c0, r0)) = self.stimuli.first() else {
            return AdaptationState::steady(1.0, 1.0);
        };
        let mut state = AdaptationState::steady(c0, r0);
        let n = (frame - self.first).clamp(0, self.stimuli.len() as i64 - 1) as usize;
        for &(c, r) in &self.stimuli[1..=n] {
            state.advance(c, r, 1.0 / self.fps);
        }
        state
    }
}

/// One frame of a [`Sequence`]: the scene at that frame and the viewer's adaptation state on
/// arriving at it. This is the one place a frame's time reaches the renderer: everything that
/// renders a frame takes `scene` from here.
pub struct FrameContext {
    /// The frame number.
    pub index: i64,
    /// The scene at this frame (a view sharing the loaded scene's world).
    pub scene: Scene,
    /// The viewer's adaptation state at this frame (Pattanaik et al. 2000, §4), for the tone
    /// operator and the display threshold.
    pub adaptation: AdaptationState,
}

/// Frames `first..=last` of an animated scene with the viewer's adaptation course over them:
/// the single frame loop of `aleph render`, `aleph speedup` and the farm's tasks.
pub struct Sequence<'a> {
    scene: &'a Scene,
    first: i64,
    last: i64,
    course: AdaptationCourse,
    prepass: std::time::Duration,
}

impl<'a> Sequence<'a> {
    /// Checks the range and runs the adaptation pre-passes of frames up to `last`.
    ///
    /// # Errors
    /// [`crate::error::SceneError::Invalid`] naming the scene file: a still scene, or `first`
    /// or `last` outside the scene's frame range.
    pub fn new(scene: &'a Scene, first: i64, last: i64) -> SceneResult<Sequence<'a>> {
        let invalid = |message: String| crate::error::SceneError::Invalid {
            path: scene.path.clone(),
            message,
        };
        if scene.animation.is_none() {
            return Err(invalid(
                "frames (--frames, --frame) need an animated scene (this one has no \
                 [animation] table)"
                    .into(),
            ));
        }
        if first > last {
            return Err(invalid(format!(
                "the first frame ({first}) is after the last ({last})"
            )));
        }
        scene.at_frame(first)?;
        scene.at_frame(last)?;
        let start = std::time::Instant::now();
        let course = AdaptationCourse::compute(scene, last)?.expect("an animated scene");
        Ok(Sequence {
            scene,
            first,
            last,
            course,
            prepass: start.elapsed(),
        })
    }

    /// The first and last frame.
    pub fn range(&self) -> (i64, i64) {
        (self.first, self.last)
    }

    /// Frames per second of the scene's animation.
    pub fn fps(&self) -> f64 {
        self.course.fps
    }

    /// The adaptation course (from the animation's first frame to `last`).
    pub fn course(&self) -> &AdaptationCourse {
        &self.course
    }

    /// Wall time of the adaptation pre-passes.
    pub fn prepass_time(&self) -> std::time::Duration {
        self.prepass
    }

    /// Frame `index` (which need not be in the range: a frame before `first` has its state).
    ///
    /// # Errors
    /// As [`Scene::at_frame`].
    pub fn frame(&self, index: i64) -> SceneResult<FrameContext> {
        Ok(FrameContext {
            index,
            scene: self.scene.at_frame(index)?,
            adaptation: self.course.state_at(index),
        })
    }

    /// The frames `first..=last` in order.
    pub fn frames(&self) -> impl Iterator<Item = SceneResult<FrameContext>> + '_ {
        (self.first..=self.last).map(|f| self.frame(f))
    }
}
