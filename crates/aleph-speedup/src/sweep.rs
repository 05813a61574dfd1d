//! The equal-quality sweep: cached references, every sampler at every budget, per frame.

use super::{
    Ceiling, GRADES_EV, Judge, Scores, ceiling, flip_coefficients, oracle_allocations,
    rank_correlation, relative_sample_cost,
};
use aleph::adaptive::{AdaptiveResult, AdaptiveSettings, Criterion, render_adaptive};
use aleph::display::FrozenToneMap;
use aleph::film::Film;
use aleph::imaging::false_colour;
use aleph::integrator::Strategy;
use aleph::output::{AtomicOutputs, ChannelData, OutputError, write_exr, write_png};
use aleph::render::{pixel_costs, render_uniform_streams};
use aleph::reuse::ReuseWindow;
use aleph::sampler::SampleStreams;
use aleph::scene::{Scene, SceneDescription};
use aleph::sequence::Sequence;
use perception::tmo::Operator;
use perception::viewing::ViewingConditions;
use std::fmt::Write as _;
use std::hash::Hasher;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One arm of the comparison: a sampler, and for sequences the perceptual sampler without its
/// velocity map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arm {
    /// Uniform sampling.
    Uniform,
    /// Cycles' noise threshold.
    Variance,
    /// The perceptual sampler.
    Perceptual,
    /// The perceptual sampler without the velocity map (sequences).
    PerceptualNoVelocity,
    /// The perceptual sampler reusing earlier frames' samples ([`aleph::reuse`], sequences;
    /// its budget counts fresh samples).
    Reuse,
}

impl Arm {
    /// Every arm; the first three for a still.
    pub const ALL: [Arm; 5] = [
        Arm::Uniform,
        Arm::Variance,
        Arm::Perceptual,
        Arm::PerceptualNoVelocity,
        Arm::Reuse,
    ];

    /// Name in tables and file names.
    pub fn name(self) -> &'static str {
        match self {
            Arm::Uniform => "uniform",
            Arm::Variance => "variance",
            Arm::Perceptual => "perceptual",
            Arm::PerceptualNoVelocity => "perceptual-novelocity",
            Arm::Reuse => "reuse",
        }
    }

    /// The sampler it runs.
    pub fn sampler(self) -> Criterion {
        match self {
            Arm::Uniform => Criterion::Uniform,
            Arm::Variance => Criterion::Variance,
            Arm::Perceptual | Arm::PerceptualNoVelocity | Arm::Reuse => Criterion::Perceptual,
        }
    }
}

/// One arm at one budget: for a sequence, spp and scores are means over its frames and times
/// are sums.
#[derive(Clone, Debug)]
pub struct Row {
    /// The arm.
    pub sampler: Arm,
    /// Average budget, spp.
    pub budget: f64,
    /// Samples per pixel used (mean over frames).
    pub mean_spp: f64,
    /// Samples per pixel of the albedo guide (mean over frames).
    pub guide_spp: f64,
    /// Wall time, s (sum over frames).
    pub wall_s: f64,
    /// Time in the perception model, s (sum over frames).
    pub decision_s: f64,
    /// Scores (means over frames).
    pub scores: Scores,
}

impl Row {
    /// One line for a log: arm, budget, spp used, wall time and scores.
    pub fn summary(&self) -> String {
        let s = &self.scores;
        format!(
            "{:>21} {:>6} spp: {:7.2} spp used, {:7.2} s, FLIP {:.4} (p99 {:.4}), visible {:.4}, relMSE {:.5}",
            self.sampler.name(),
            self.budget,
            self.mean_spp,
            self.wall_s,
            s.flip_mean,
            s.flip_p99,
            s.visible_fraction,
            s.relmse
        )
    }

    /// The columns of [`frames_csv_header`] but `frame`.
    pub fn csv_fields(&self) -> String {
        format!(
            "{},{},{:.4},{:.4},{}",
            self.sampler.name(),
            self.budget,
            self.mean_spp,
            self.wall_s,
            self.scores.csv_fields()
        )
    }
}

/// Header of the per-frame CSV (`frames.csv`): `frame`, then [`Row::csv_fields`]'s columns.
pub fn frames_csv_header() -> String {
    format!(
        "frame,sampler,budget_spp,mean_spp,wall_s,{}",
        Scores::CSV_HEADER
    )
}

/// The cache key of a scene's references: FNV-1a over the scene file, its meshes and the
/// settings that change a reference (resolution, spp, seed, depth, aleph's version). A
/// sequence frame's key appends its number ([`frame_key`]), so the files are read once.
pub fn reference_key(desc: &SceneDescription, spp: u32, seed: u64) -> String {
    struct Fnv(u64);
    impl Hasher for Fnv {
        fn finish(&self) -> u64 {
            self.0
        }
        fn write(&mut self, bytes: &[u8]) {
            for b in bytes {
                self.0 = (self.0 ^ *b as u64).wrapping_mul(0x100_0000_01b3);
            }
        }
    }
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    h.write(&std::fs::read(&desc.path).unwrap_or_default());
    let base = desc.path.parent().unwrap_or(Path::new(""));
    for m in &desc.meshes {
        h.write(&std::fs::read(base.join(&m.file)).unwrap_or_default());
    }
    h.write(
        format!(
            "{:?}|{spp}|{seed}|{:?}|{}",
            desc.camera.resolution,
            desc.render.max_depth,
            env!("CARGO_PKG_VERSION")
        )
        .as_bytes(),
    );
    format!("{:016x}", h.finish())
}

/// The key of one frame's reference under a scene key from [`reference_key`].
pub fn frame_key(scene_key: &str, frame: Option<i64>) -> String {
    match frame {
        None => scene_key.to_string(),
        Some(f) => format!("{scene_key}-{f:04}"),
    }
}

fn planes(film: &Film) -> Vec<(String, ChannelData)> {
    let mut v = Vec::new();
    for (prefix, data) in [("Even", film.mean_rgb_even()), ("Odd", film.mean_rgb_odd())] {
        for (c, name) in ["R", "G", "B"].iter().enumerate() {
            let p: Vec<f32> = data.iter().skip(c).step_by(3).copied().collect();
            v.push((format!("{prefix}.{name}"), ChannelData::F32(p)));
        }
    }
    v.push(("spp".into(), ChannelData::U32(film.spp())));
    v
}

/// The reference: mean, even half and odd half (interleaved RGB each).
struct Reference {
    mean: Vec<f32>,
    even: Vec<f32>,
    odd: Vec<f32>,
}

fn read_reference(path: &Path, n: usize) -> Option<Reference> {
    let ch = aleph::imageio::read_exr_channels(path).ok()?;
    let get = |p: &str| -> Option<Vec<f32>> {
        let (r, g, b) = (
            ch.get(&format!("{p}R"))?,
            ch.get(&format!("{p}G"))?,
            ch.get(&format!("{p}B"))?,
        );
        if r.len() != n {
            return None;
        }
        Some((0..n).flat_map(|i| [r[i], g[i], b[i]]).collect())
    };
    Some(Reference {
        mean: get("")?,
        even: get("Even.")?,
        odd: get("Odd.")?,
    })
}
/// The cached uniform reference of the scene's current frame, rendered when missing.
fn reference_for(
    ref_scene: &Scene,
    path: &Path,
    spp: u32,
    log: &dyn Fn(&str),
) -> Result<Reference, SpeedupError> {
    let (w, h) = (
        ref_scene.camera.width as usize,
        ref_scene.camera.height as usize,
    );
    if let Some(r) = read_reference(path, w * h) {
        log(&format!("using cached reference {}", path.display()));
        return Ok(r);
    }
    log(&format!("rendering the reference: {w}×{h} at {spp} spp …"));
    let t = Instant::now();
    // Independent half-buffers: the reference's noise floor is one half against the other.
    let (film, _) = render_uniform_streams(
        ref_scene,
        Strategy::Mis,
        spp,
        SampleStreams::Halves,
        &|_| {},
    );
    log(&format!(
        "reference rendered in {:.1} s",
        t.elapsed().as_secs_f64()
    ));
    let mean = film.mean_rgb();
    let mut out = AtomicOutputs::new();
    let attrs = vec![
        ("referenceSpp".to_string(), spp.to_string()),
        (
            aleph::output::WHITE_LUMINANCE.to_string(),
            ref_scene.settings.luminance_scale.to_string(),
        ),
    ];
    out.stage(path, |wr| {
        write_exr(wr, path, w as u32, h as u32, &mean, &planes(&film), &attrs)
    })?;
    out.commit()?;
    Ok(Reference {
        mean,
        even: film.mean_rgb_even(),
        odd: film.mean_rgb_odd(),
    })
}

/// Sums over frames of one arm at one budget.
#[derive(Default)]
struct Acc {
    frames: usize,
    mean_spp: f64,
    guide_spp: f64,
    wall_s: f64,
    decision_s: f64,
    scores: Scores,
}

impl Acc {
    fn add(&mut self, r: &Row) {
        self.frames += 1;
        self.mean_spp += r.mean_spp;
        self.guide_spp += r.guide_spp;
        self.wall_s += r.wall_s;
        self.decision_s += r.decision_s;
        self.scores.add_scaled(&r.scores, 1.0);
    }

    /// Means of spp and scores, sums of times.
    fn row(&self, sampler: Arm, budget: f64) -> Row {
        let k = 1.0 / self.frames.max(1) as f64;
        let mut scores = Scores::default();
        scores.add_scaled(&self.scores, k);
        Row {
            sampler,
            budget,
            mean_spp: self.mean_spp * k,
            guide_spp: self.guide_spp * k,
            wall_s: self.wall_s,
            decision_s: self.decision_s,
            scores,
        }
    }
}

/// Where the display image of one render goes: `DIR/ARM-Bspp.png` for a still,
/// `DIR/frames/ARM-Bspp/NNNN.png` for a sequence frame (the layout `benches/cvvdp_judge.py`
/// reads).
pub fn image_path(dir: &Path, arm: &str, frame: Option<i64>) -> PathBuf {
    match frame {
        None => dir.join(format!("{arm}.png")),
        Some(f) => dir.join("frames").join(arm).join(format!("{f:04}.png")),
    }
}

/// The subdirectory of the display images graded by `ev` stops: `ev-2`, `ev+2`.
pub fn grade_dir(ev: f64) -> String {
    format!("ev{ev:+}")
}

/// The frames to judge: `None` once for a still; for an animated scene `range` or its whole
/// frame range.
///
/// # Errors
/// [`SpeedupError::Frames`] for a range on a still or outside the scene's frames.
pub fn frame_list(
    scene: &Scene,
    range: Option<(i64, i64)>,
) -> Result<Vec<Option<i64>>, SpeedupError> {
    let bad = |m: String| {
        Err(SpeedupError::Frames(format!(
            "{}: {m}",
            scene.path.display()
        )))
    };
    match (scene.animation, range) {
        (None, None) => Ok(vec![None]),
        (None, Some(_)) => bad(
            "frames (--frames) need an animated scene (this one has no [animation] table)".into(),
        ),
        (Some(a), range) => {
            let (first, last) = range.unwrap_or((a.frame_start, a.frame_end));
            for f in [first, last] {
                if !a.contains(f) {
                    return bad(format!(
                        "frame {f} is outside the scene's frame range {}-{}",
                        a.frame_start, a.frame_end
                    ));
                }
            }
            Ok((first..=last).map(Some).collect())
        }
    }
}

/// What to sweep.
#[derive(Clone, Debug)]
pub struct SweepSpec {
    /// Average budgets, spp.
    pub budgets: Vec<f64>,
    /// Samples per pixel of the uniform reference.
    pub reference_spp: u32,
    /// Seed of the test renders (the reference uses an independent one).
    pub seed: u64,
    /// Frames of an animated scene (`None`: its whole range).
    pub frames: Option<(i64, i64)>,
    /// Tone operator of the judged display (`None`: Reinhard for a still, PTYG with the
    /// carried adaptation state for a sequence).
    pub operator: Option<Operator>,
    /// The reuse arm's window K, frames (the sweep's arms include it for a sequence when
    /// K > 0).
    pub reuse_window: u32,
    /// Only these arms, besides uniform, which every table compares with (`None`: every arm
    /// the scene has: the first three for a still, the perceptual sampler without velocity
    /// for a sequence, reuse for a sequence with K > 0). An arm the scene does not have is an
    /// error ([`SpeedupError::Frames`]).
    pub arms: Option<Vec<Arm>>,
    /// Also render and judge the perceptual sampler's own stop (no budget: `aleph render`'s
    /// default, until the converged fraction of pixels is below threshold), written as
    /// [`STOP_IMAGE`].
    pub stop: bool,
}

/// The arms of a sweep: those of `every` that `asked` names (all of them for `None`), uniform
/// always first.
fn chosen_arms(every: &[Arm], asked: Option<&[Arm]>) -> Result<Vec<Arm>, SpeedupError> {
    let Some(asked) = asked else {
        return Ok(every.to_vec());
    };
    if let Some(a) = asked.iter().find(|a| !every.contains(a)) {
        return Err(SpeedupError::Frames(format!(
            "--arms {}: this sweep has no such arm (its arms: {})",
            a.name(),
            every
                .iter()
                .map(|a| a.name())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    Ok(every
        .iter()
        .copied()
        .filter(|a| *a == Arm::Uniform || asked.contains(a))
        .collect())
}

/// Name of the stop's display image ([`image_path`]), beside the budgets' `ARM-Bspp`.
pub const STOP_IMAGE: &str = "perceptual-stop";

/// The result of a sweep: one row per arm and budget (means over frames for a sequence).
pub struct Sweep {
    /// Rows, budget-major.
    pub rows: Vec<Row>,
    /// The reference's noise floor (mean over frames).
    pub floor: Scores,
    /// Ceilings of the first frame, per budget.
    pub ceilings: Vec<(f64, Ceiling)>,
    /// How the perceptual sampler's allocation ranks pixels against the oracle's, per budget
    /// (first frame).
    pub oracle: Vec<OracleRow>,
    /// Per-frame rows as CSV (header included).
    pub per_frame_csv: String,
    /// The perceptual sampler's own stop (budget 0), when [`SweepSpec::stop`] asked for it.
    pub stop: Option<Row>,
    /// Number of frames (0 for a still).
    pub frames: usize,
    /// The operator of the judged display.
    pub operator: Operator,
    /// The viewer's pixels per degree.
    pub ppd: f64,
    /// Image size.
    pub width: usize,
    /// Image size.
    pub height: usize,
}

/// The perceptual sampler's allocation against the oracle's at one budget.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OracleRow {
    /// Average budget, spp.
    pub budget: f64,
    /// Spearman correlation of the perceptual counts with the oracle's (both oracles rank
    /// pixels by a_i, so one number serves both); `None` when every pixel has the same count
    /// (a budget under `steer_from_spp`, rendered uniformly), which has no ranking.
    pub rank: Option<f64>,
    /// Time per sample, relative to a uniform allocation's, of the perceptual sampler's
    /// allocation and of the FLIP-mean oracle's ([`relative_sample_cost`]); `None` without a
    /// cost map.
    pub cost: Option<(f64, f64)>,
}

/// Samples per pixel timed for the cost map of a sweep's ceiling in wall time.
pub const COST_SPP: u32 = 16;

/// Errors of a sweep.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SpeedupError {
    /// The scene failed to load or a frame is invalid.
    #[error(transparent)]
    Scene(#[from] aleph::error::SceneError),
    /// A frame range that does not fit the scene.
    #[error("{0}")]
    Frames(String),
    /// A render failed or its settings were refused.
    #[error(transparent)]
    Adaptive(#[from] aleph::adaptive::AdaptiveError),
    /// A perception model failed.
    #[error(transparent)]
    Perception(#[from] perception::PerceptionError),
    /// An output could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A directory could not be created.
    #[error("{}: cannot create directory", path.display())]
    Dir {
        /// The directory.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}

/// Seed offset of the reference's renders (independent of the test renders).
const REFERENCE_SEED_XOR: u64 = 0x5851_F42D_4C95_7F2D;

/// State carried across the frames of a sweep.
struct SweepState {
    acc: Vec<Acc>,
    floor: Acc,
    per_frame: String,
    uniform_maps: Vec<(f64, Vec<f32>)>,
    /// The first frame's measured cost per sample of each pixel ([`pixel_costs`]).
    cost: Option<Vec<f32>>,
    /// The perceptual sampler's samples per pixel at each budget (first frame).
    perceptual_counts: Vec<(f64, Vec<f32>)>,
    /// The perceptual sampler's own stop, summed over frames.
    stop: Acc,
    view: ViewingConditions,
    /// The reuse arm's window at each budget of `budgets`.
    windows: Vec<ReuseWindow>,
    budgets: Vec<f64>,
    /// The reuse window K (frames), and the animation's first frame (runs start there).
    reuse: (u32, i64),
}

/// Renders (and caches in `dir`) a uniform reference per frame, then every arm at every budget
/// of `spec`, judges each against the reference on the displayed images, and writes their
/// display PNGs into `dir` ([`image_path`]). `base` gives every sampler setting but the
/// sampler, budget and display (its tone settings give the viewer and display model). `log`
/// receives a line per render.
///
/// # Errors
/// [`SpeedupError`].
pub fn sweep(
    desc: SceneDescription,
    dir: &Path,
    spec: &SweepSpec,
    base: &AdaptiveSettings,
    log: &dyn Fn(&str),
) -> Result<Sweep, SpeedupError> {
    let mut ref_desc = desc.clone();
    ref_desc.render.seed = Some(spec.seed ^ REFERENCE_SEED_XOR);
    let mut test_desc = desc.clone();
    test_desc.render.seed = Some(spec.seed);
    let scene = Scene::load_description(test_desc)?;
    let ref_scene = Scene::load_description(ref_desc)?;
    let frames = frame_list(&scene, spec.frames)?;
    // Only now that the scene loads: a failed run leaves no empty directory behind.
    std::fs::create_dir_all(dir).map_err(|source| SpeedupError::Dir {
        path: dir.to_path_buf(),
        source,
    })?;
    let sequence = match (frames.first(), frames.last()) {
        (Some(Some(first)), Some(Some(last))) => {
            let start = scene.animation.map_or(*first, |a| a.frame_start);
            let warm = aleph::reuse::warm_up_start(*first, start, spec.reuse_window);
            Some(Sequence::new(&scene, warm, *last)?)
        }
        _ => None,
    };
    let course = sequence.as_ref().map(Sequence::course);
    let arms = sweep_arms(course.is_some(), spec)?;
    let arms = arms.as_slice();
    let default_op = if course.is_some() {
        Operator::Ptyg
    } else {
        Operator::Reinhard
    };
    let operator = spec.operator.unwrap_or(default_op);
    let scene_key = reference_key(&desc, spec.reference_spp, spec.seed);
    let mut st = SweepState {
        acc: (0..arms.len() * spec.budgets.len())
            .map(|_| Acc::default())
            .collect(),
        floor: Acc::default(),
        per_frame: format!("{}\n", frames_csv_header()),
        uniform_maps: Vec::new(),
        cost: None,
        perceptual_counts: Vec::new(),
        stop: Acc::default(),
        view: base.tone.view,
        windows: vec![ReuseWindow::new(spec.reuse_window); spec.budgets.len()],
        budgets: spec.budgets.clone(),
        reuse: (
            spec.reuse_window,
            scene.animation.map_or(0, |a| a.frame_start),
        ),
    };
    if let (Some(Some(first)), Some(seq)) = (frames.first(), &sequence) {
        warm_up_reuse(seq, *first, spec, base, &mut st)?;
    }
    for (k, &frame) in frames.iter().enumerate() {
        let (scene, ref_scene, adaptation) = match (frame, &sequence) {
            (Some(f), Some(seq)) => {
                let ctx = seq.frame(f)?;
                (ctx.scene, ref_scene.at_frame(f)?, Some(ctx.adaptation))
            }
            _ => (scene.clone(), ref_scene.clone(), None),
        };
        let mut tone = base.tone;
        tone.operator = operator;
        tone.luminance_scale = scene.settings.luminance_scale;
        tone.adaptation_state = adaptation;
        // Only a sweep with a ceiling (three uniform budgets or more) uses the cost map.
        if k == 0 && spec.budgets.len() >= 3 {
            st.cost = Some(cost_map(&scene, log));
        }
        let key = frame_key(&scene_key, frame);
        let ref_path = dir.join(format!("reference-{key}.exr"));
        let reference = reference_for(&ref_scene, &ref_path, spec.reference_spp, log)?;
        let ctx = FrameCtx {
            scene: &scene,
            frame,
            first: k == 0,
            tone,
            arms,
            dir,
        };
        sweep_frame(&ctx, &reference, spec, base, &mut st, log)?;
    }
    let rows = budget_rows(&st, spec, arms);
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let (ceilings, oracle) = ceilings_and_oracle(&st, spec, (w, h), dir)?;
    Ok(Sweep {
        rows,
        floor: st.floor.row(Arm::Uniform, 0.0).scores,
        ceilings,
        oracle,
        stop: spec.stop.then(|| st.stop.row(Arm::Perceptual, 0.0)),
        per_frame_csv: st.per_frame,
        frames: frames.iter().flatten().count(),
        operator,
        ppd: st.view.ppd,
        width: scene.camera.width as usize,
        height: scene.camera.height as usize,
    })
}

/// The arms a sweep renders: those `spec.arms` names (all by default) among what the scene
/// allows: uniform, variance and perceptual for a still; the perceptual sampler without
/// velocity too for a sequence, and reuse when its window is above 0.
fn sweep_arms(sequence: bool, spec: &SweepSpec) -> Result<Vec<Arm>, SpeedupError> {
    let every: &[Arm] = if sequence && spec.reuse_window > 0 {
        &Arm::ALL
    } else if sequence {
        &Arm::ALL[..4]
    } else {
        &Arm::ALL[..3]
    };
    chosen_arms(every, spec.arms.as_deref())
}

/// Each pixel's cost per sample (seconds, [`pixel_costs`] over [`COST_SPP`] paths), median
/// filtered over 5 × 5 pixels: a single pixel's time over 16 paths is mostly noise (two
/// Cornell-box maps correlate at 0.09) and stalls of the machine put spikes in it, which the
/// least-time allocation would exploit; the filtered maps correlate at 0.99 (a 5 × 5 mean:
/// 0.61).
fn cost_map(scene: &Scene, log: &dyn Fn(&str)) -> Vec<f32> {
    let t = Instant::now();
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let raw = pixel_costs(scene, Strategy::Mis, COST_SPP);
    let cost = aleph::imaging::median_filter(&raw, w, h, 2);
    log(&format!(
        "pixel costs: {COST_SPP} spp per pixel timed in {:.2} s",
        t.elapsed().as_secs_f64()
    ));
    cost
}

/// One row per budget and arm, in that order, from the accumulated scores.
fn budget_rows(st: &SweepState, spec: &SweepSpec, arms: &[Arm]) -> Vec<Row> {
    spec.budgets
        .iter()
        .enumerate()
        .flat_map(|(bi, &b)| {
            let acc = &st.acc;
            arms.iter()
                .enumerate()
                .map(move |(ai, &arm)| acc[bi * arms.len() + ai].row(arm, b))
        })
        .collect()
}

/// The ceilings at each budget and the oracle's rows.
type CeilingsAndOracle = (Vec<(f64, Ceiling)>, Vec<OracleRow>);

/// Ceilings and oracle sheets of frame size `(w, h)`, for a sweep of three uniform budgets or
/// more (else none): the ceiling (of the first frame), fitted between the second-lowest and the
/// highest uniform budgets (the lowest is the noisiest fit), at each budget of the sweep.
fn ceilings_and_oracle(
    st: &SweepState,
    spec: &SweepSpec,
    (w, h): (usize, usize),
    dir: &Path,
) -> Result<CeilingsAndOracle, SpeedupError> {
    let maps = &st.uniform_maps;
    if maps.len() < 3 {
        return Ok((Vec::new(), Vec::new()));
    }
    let (lo, hi) = (&maps[1], &maps[maps.len() - 1]);
    let cost = st.cost.as_deref();
    let ceilings = spec
        .budgets
        .iter()
        .filter_map(|&b| ceiling(lo.0, &lo.1, hi.0, &hi.1, b, cost).map(|c| (b, c)))
        .collect();
    let oracle = oracle_sheets(lo, hi, &st.perceptual_counts, cost, (w, h), dir)?;
    Ok((ceilings, oracle))
}

/// For each budget of the perceptual sampler: the oracle's allocations (FLIP mean, FLIP p99)
/// from the uniform maps `lo` and `hi`, the rank correlations with the sampler's, and a sheet
/// `DIR/oracle/Bspp.png` of the three maps side by side (oracle for the mean, for p99, aleph's;
/// magma, one log scale from 1/8 to 8 times the budget).
fn oracle_sheets(
    lo: &(f64, Vec<f32>),
    hi: &(f64, Vec<f32>),
    counts: &[(f64, Vec<f32>)],
    cost: Option<&[f32]>,
    (w, h): (usize, usize),
    dir: &Path,
) -> Result<Vec<OracleRow>, SpeedupError> {
    let Some((beta, a)) = flip_coefficients(lo.0, &lo.1, hi.0, &hi.1) else {
        return Ok(Vec::new());
    };
    let mut out = AtomicOutputs::new();
    let mut rows = Vec::new();
    for (budget, aleph) in counts {
        let (mean, p99) = oracle_allocations(beta, &a, *budget);
        rows.push(OracleRow {
            budget: *budget,
            rank: aleph
                .iter()
                .any(|&c| c != aleph[0])
                .then(|| rank_correlation(&mean, aleph)),
            cost: cost.map(|c| {
                (
                    relative_sample_cost(aleph, c),
                    relative_sample_cost(&mean, c),
                )
            }),
        });
        let (lo_v, hi_v) = (*budget as f32 / 8.0, *budget as f32 * 8.0);
        let panels: Vec<Vec<u8>> = [&mean, &p99, aleph]
            .iter()
            .map(|m| false_colour(m, lo_v, hi_v))
            .collect();
        let gap = 4;
        let sw = 3 * w + 2 * gap;
        let mut sheet = vec![255u8; sw * h * 3];
        for (k, p) in panels.iter().enumerate() {
            for y in 0..h {
                let dst = (y * sw + k * (w + gap)) * 3;
                sheet[dst..dst + 3 * w].copy_from_slice(&p[y * w * 3..(y + 1) * w * 3]);
            }
        }
        let path = dir.join("oracle").join(format!("{budget}spp.png"));
        std::fs::create_dir_all(dir.join("oracle")).map_err(|source| SpeedupError::Dir {
            path: dir.join("oracle"),
            source,
        })?;
        out.stage(&path, |wr| {
            write_png(wr, &path, sw as u32, h as u32, &sheet)
        })?;
    }
    out.commit()?;
    Ok(rows)
}

/// One frame's context in a sweep.
struct FrameCtx<'a> {
    scene: &'a Scene,
    frame: Option<i64>,
    first: bool,
    tone: aleph::display::ToneMapSettings,
    arms: &'a [Arm],
    dir: &'a Path,
}

/// Renders one arm with `settings`, judges it and logs its row; returns the row (`budget` 0
/// for the stop) and the image's mean RGB. The first frame's uniform FLIP maps and
/// perceptual sample counts are kept in `st` for the oracle.
fn judged_render(
    ctx: &FrameCtx,
    judge: &Judge,
    settings: &AdaptiveSettings,
    arm: Arm,
    budget: f64,
    st: &mut SweepState,
    log: &dyn Fn(&str),
) -> Result<(Row, Vec<f32>), SpeedupError> {
    let n_px = (ctx.scene.camera.width * ctx.scene.camera.height) as f64;
    let t = Instant::now();
    let r = match arm {
        Arm::Reuse => render_reused(ctx.scene, settings, budget, st)?,
        _ => render_adaptive(ctx.scene, settings, &|_| {}, &|_| {})?,
    };
    let wall = t.elapsed().as_secs_f64();
    let rgb = r.film.mean_rgb();
    let (scores, fmap) = judge.score_with_map(&rgb)?;
    let budgeted = settings.budget_spp.is_some();
    if arm == Arm::Uniform && ctx.first {
        st.uniform_maps.push((budget, fmap));
    }
    if arm == Arm::Perceptual && ctx.first && budgeted {
        let counts = r.film.pixels.iter().map(|p| p.n as f32).collect();
        st.perceptual_counts.push((budget, counts));
    }
    let row = Row {
        sampler: arm,
        budget,
        mean_spp: r.mean_spp(),
        guide_spp: r
            .guide_stats
            .map(|g| g.samples as f64 / n_px)
            .unwrap_or(0.0),
        wall_s: wall,
        decision_s: r.decision_time.as_secs_f64(),
        scores,
    };
    let label = ctx.frame.map(|f| format!("frame {f} ")).unwrap_or_default();
    let stop = if budgeted { "" } else { " (its own stop)" };
    log(&format!("{label}{}{stop}", row.summary()));
    let _ = writeln!(
        st.per_frame,
        "{},{}",
        ctx.frame.unwrap_or(0),
        row.csv_fields()
    );
    Ok((row, rgb))
}

/// The reuse arm's frame at `budget` (fresh spp): the frame reuses the window of that budget,
/// then its base pass joins it.
fn render_reused(
    scene: &Scene,
    settings: &AdaptiveSettings,
    budget: f64,
    st: &mut SweepState,
) -> Result<AdaptiveResult, SpeedupError> {
    let (k, start) = st.reuse;
    let bi = st.windows_index(budget);
    let window = &mut st.windows[bi];
    window.keep_from(aleph::reuse::window_start(scene.frame.index, start, k));
    let mut settings = settings.clone();
    settings.budget_spp = Some(budget);
    let (r, base) = aleph::adaptive::render_reusing(scene, &settings, window, &|_| {}, &|_| {})?;
    window.push(base);
    Ok(r)
}

/// Renders the reuse arm's warm-up (not judged): the base passes of the K frames before the
/// K frames before the first, then those K frames whole, so the sweep's first frame reuses
/// what `aleph render` would ([`aleph::reuse::warm_up_start`]).
fn warm_up_reuse(
    sequence: &Sequence,
    first: i64,
    spec: &SweepSpec,
    base: &AdaptiveSettings,
    st: &mut SweepState,
) -> Result<(), SpeedupError> {
    let (k, start) = st.reuse;
    let whole_from = aleph::reuse::window_start(first, start, k);
    for f in aleph::reuse::warm_up_start(first, start, k)..first {
        let ctx = sequence.frame(f)?;
        for (bi, &budget) in spec.budgets.iter().enumerate() {
            let settings = AdaptiveSettings {
                criterion: Criterion::Perceptual,
                budget_spp: Some(budget),
                ..base.clone()
            };
            if f < whole_from {
                let own = aleph::reuse::window_frames(f, start, k);
                let frame = aleph::adaptive::render_base(&ctx.scene, &settings, own, k)?;
                st.windows[bi].push(frame);
            } else {
                render_reused(&ctx.scene, &settings, budget, st)?;
            }
        }
    }
    Ok(())
}

impl SweepState {
    fn windows_index(&self, budget: f64) -> usize {
        self.budgets
            .iter()
            .position(|&b| b == budget)
            .expect("a budget of the sweep")
    }
}

/// Judges every arm at every budget on one frame (and the perceptual sampler's own stop, if
/// asked), accumulating into `st`.
fn sweep_frame(
    ctx: &FrameCtx,
    reference: &Reference,
    spec: &SweepSpec,
    base: &AdaptiveSettings,
    st: &mut SweepState,
    log: &dyn Fn(&str),
) -> Result<(), SpeedupError> {
    let (w, h) = (
        ctx.scene.camera.width as usize,
        ctx.scene.camera.height as usize,
    );
    let view = base.tone.view;
    st.view = view;
    let frozen = FrozenToneMap::new(&reference.mean, w, h, &ctx.tone)?;
    let judge = Judge::new(reference.mean.clone(), w, h, frozen.clone(), view)?;
    st.floor.add(&Row {
        sampler: Arm::Uniform,
        budget: 0.0,
        mean_spp: 0.0,
        guide_spp: 0.0,
        wall_s: 0.0,
        decision_s: 0.0,
        scores: Judge::floor(&reference.even, &reference.odd, w, h, frozen, view)?,
    });
    let mut images = AtomicOutputs::new();
    // The displayed image in `dir`, each grade's in `dir/ev-2` and `dir/ev+2`.
    let stage_png = |images: &mut AtomicOutputs, name: &str, rgb: &[f32]| {
        for grade in 0..=GRADES_EV.len() {
            let (sub, srgb) = match grade {
                0 => (ctx.dir.to_path_buf(), judge.display_srgb(rgb)?),
                k => (
                    ctx.dir.join(grade_dir(GRADES_EV[k - 1])),
                    judge.graded_srgb(k - 1, rgb)?,
                ),
            };
            let p = image_path(&sub, name, ctx.frame);
            if let Some(parent) = p.parent() {
                std::fs::create_dir_all(parent).map_err(|source| SpeedupError::Dir {
                    path: parent.to_path_buf(),
                    source,
                })?;
            }
            images.stage(&p, |wr| write_png(wr, &p, w as u32, h as u32, &srgb))?;
        }
        Ok::<(), SpeedupError>(())
    };
    stage_png(&mut images, "reference", &reference.mean)?;
    for (bi, &budget) in spec.budgets.iter().enumerate() {
        for (ai, &arm) in ctx.arms.iter().enumerate() {
            let mut settings = AdaptiveSettings {
                criterion: arm.sampler(),
                budget_spp: Some(budget),
                uniform_spp: budget as u32,
                tone: ctx.tone,
                ..base.clone()
            };
            settings.perceptual.use_velocity = arm != Arm::PerceptualNoVelocity;
            let (row, rgb) = judged_render(ctx, &judge, &settings, arm, budget, st, log)?;
            stage_png(&mut images, &format!("{}-{}spp", arm.name(), budget), &rgb)?;
            st.acc[bi * ctx.arms.len() + ai].add(&row);
        }
    }
    if spec.stop {
        // `aleph render`'s own stop: no budget, until the converged fraction (or a cap).
        let settings = AdaptiveSettings {
            criterion: Criterion::Perceptual,
            budget_spp: None,
            tone: ctx.tone,
            ..base.clone()
        };
        let (row, rgb) = judged_render(ctx, &judge, &settings, Arm::Perceptual, 0.0, st, log)?;
        stage_png(&mut images, STOP_IMAGE, &rgb)?;
        st.stop.add(&row);
    }
    images.commit()?;
    Ok(())
}
