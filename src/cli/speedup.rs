//! `aleph speedup [SCENE]`: how much perceptual sampling saves at equal quality.

use super::render::{SamplingArgs, default_scene};
use super::tonemap::{OperatorArg, ToneArgs};
use super::{parse_resolution, with_threads};
use aleph::adaptive::{SamplerKind, render_adaptive};
use aleph::display::FrozenToneMap;
use aleph::film::Film;
use aleph::integrator::Strategy;
use aleph::output::{AtomicOutputs, ChannelData, write_exr, write_png};
use aleph::render::render_uniform;
use aleph::scene::{Scene, SceneDescription};
use aleph::sequence::AdaptationCourse;
use aleph::speedup::{Ceiling, Judge, Scores, ceiling, samples_for};
use anyhow::{Context, bail};
use clap::Args;
use perception::tmo::Operator;
use plotters::prelude::*;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::hash::Hasher;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct SpeedupArgs {
    /// Scene file (default: the bundled Cornell box).
    scene: Option<PathBuf>,
    /// Output directory for the table, CSV, plots, images and the cached reference.
    #[arg(short, long, value_name = "DIR")]
    output: Option<PathBuf>,
    /// Image size (default 256x256).
    #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
    resolution: Option<(u32, u32)>,
    /// Average budgets of the sweep, spp.
    #[arg(long, value_name = "N,N,…", value_delimiter = ',', default_values_t = vec![1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0])]
    budgets: Vec<f64>,
    /// Samples per pixel of the uniform reference.
    #[arg(long, value_name = "N", default_value_t = 4096)]
    reference_spp: u32,
    /// Random seed of the test renders (the reference uses an independent one).
    #[arg(long, value_name = "S", default_value_t = 0)]
    seed: u64,
    /// Worker threads.
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Tone operator of the judged display images (default: exposure for a still, as `render`
    /// writes; PTYG with the carried adaptation state for a sequence).
    #[arg(long, value_enum, value_name = "OP")]
    tonemap: Option<OperatorArg>,
    /// Frames of an animated scene, FIRST-LAST (default: the whole [animation] range). Each
    /// frame gets its own reference and sweep; the sequence's speedup is at equal mean score.
    #[arg(long, value_name = "A-B", value_parser = super::render::parse_frames)]
    frames: Option<(i64, i64)>,
    #[command(flatten)]
    sampling: SamplingArgs,
    #[command(flatten)]
    tone: ToneArgs,
}

/// One arm of the comparison: a sampler, and for sequences the perceptual sampler without its
/// velocity map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Arm {
    Uniform,
    Variance,
    Perceptual,
    PerceptualNoVelocity,
}

impl Arm {
    fn name(self) -> &'static str {
        match self {
            Arm::Uniform => "uniform",
            Arm::Variance => "variance",
            Arm::Perceptual => "perceptual",
            Arm::PerceptualNoVelocity => "perceptual-novelocity",
        }
    }

    fn sampler(self) -> SamplerKind {
        match self {
            Arm::Uniform => SamplerKind::Uniform,
            Arm::Variance => SamplerKind::Variance,
            Arm::Perceptual | Arm::PerceptualNoVelocity => SamplerKind::Perceptual,
        }
    }
}

/// One arm at one budget: for a sequence, spp and scores are means over its frames and times
/// are sums.
#[derive(Clone, Debug)]
struct Row {
    sampler: Arm,
    budget: f64,
    mean_spp: f64,
    guide_spp: f64,
    wall_s: f64,
    decision_s: f64,
    scores: Scores,
}

/// FNV-1a over the scene file, its meshes and the settings that change the reference.
fn reference_key(desc: &SceneDescription, spp: u32, seed: u64, frame: Option<i64>) -> String {
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
            "{:?}|{spp}|{seed}|{:?}|{frame:?}|{}",
            desc.camera.resolution,
            desc.render.max_depth,
            env!("CARGO_PKG_VERSION")
        )
        .as_bytes(),
    );
    format!("{:016x}", h.finish())
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
    let img = exr::prelude::read_all_flat_layers_from_file(path).ok()?;
    let ch: HashMap<String, Vec<f32>> = img.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
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

pub fn run(args: SpeedupArgs) -> anyhow::Result<ExitCode> {
    let scene_path = args.scene.clone().unwrap_or_else(default_scene);
    let mut desc = SceneDescription::read(&scene_path)?;
    let (w, h) = args.resolution.unwrap_or((256, 256));
    desc.camera.resolution = [w, h];
    desc.render.seed = Some(args.seed);
    if args.budgets.is_empty() || args.budgets.iter().any(|b| !(b.is_finite() && *b >= 1.0)) {
        bail!("--budgets must be numbers ≥ 1, got {:?}", args.budgets);
    }
    if args.reference_spp < 2 {
        bail!("--reference-spp must be at least 2");
    }
    let name = match scene_path
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
    {
        Some(stem) if stem != "scene" => stem,
        _ => scene_path
            .parent()
            .and_then(|p| p.file_name())
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_else(|| "scene".into()),
    };
    let dir = args
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("speedup-{name}")));
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("{}: cannot create directory", dir.display()))?;
    with_threads(args.threads, move || sweep(desc, &dir, &args))?
}

/// The cached uniform reference of the scene's current frame, rendered when missing.
fn reference_for(ref_scene: &Scene, path: &Path, spp: u32) -> anyhow::Result<Reference> {
    let (w, h) = (
        ref_scene.camera.width as usize,
        ref_scene.camera.height as usize,
    );
    if let Some(r) = read_reference(path, w * h) {
        eprintln!("using cached reference {}", path.display());
        return Ok(r);
    }
    eprintln!("rendering the reference: {w}×{h} at {spp} spp …");
    let t = Instant::now();
    let (film, _) = render_uniform(ref_scene, Strategy::Mis, spp, &|_| {});
    eprintln!("reference rendered in {:.1} s", t.elapsed().as_secs_f64());
    let mean = film.mean_rgb();
    let mut out = AtomicOutputs::new();
    let attrs = vec![("referenceSpp".to_string(), spp.to_string())];
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
    flip_mean: f64,
    flip_p99: f64,
    visible: f64,
    relmse: f64,
}

impl Acc {
    fn add(&mut self, r: &Row) {
        self.frames += 1;
        self.mean_spp += r.mean_spp;
        self.guide_spp += r.guide_spp;
        self.wall_s += r.wall_s;
        self.decision_s += r.decision_s;
        self.flip_mean += r.scores.flip_mean;
        self.flip_p99 += r.scores.flip_p99;
        self.visible += r.scores.visible_fraction;
        self.relmse += r.scores.relmse;
    }

    /// Means of spp and scores, sums of times.
    fn row(&self, sampler: Arm, budget: f64) -> Row {
        let k = 1.0 / self.frames.max(1) as f64;
        Row {
            sampler,
            budget,
            mean_spp: self.mean_spp * k,
            guide_spp: self.guide_spp * k,
            wall_s: self.wall_s,
            decision_s: self.decision_s,
            scores: Scores {
                flip_mean: self.flip_mean * k,
                flip_p99: self.flip_p99 * k,
                visible_fraction: self.visible * k,
                relmse: self.relmse * k,
            },
        }
    }
}

/// Where the display image of one render goes: `DIR/ARM-Bspp.png` for a still,
/// `DIR/frames/ARM-Bspp/NNNN.png` for a sequence frame (the layout `benches/cvvdp_judge.py`
/// reads).
fn image_path(dir: &Path, arm: &str, frame: Option<i64>) -> PathBuf {
    match frame {
        None => dir.join(format!("{arm}.png")),
        Some(f) => dir.join("frames").join(arm).join(format!("{f:04}.png")),
    }
}

/// The frames to judge: `None` once for a still.
fn frame_list(scene: &Scene, args: &SpeedupArgs) -> anyhow::Result<Vec<Option<i64>>> {
    match (scene.animation, args.frames) {
        (None, None) => Ok(vec![None]),
        (None, Some(_)) => bail!(
            "{}: --frames needs an animated scene (this one has no [animation] table)",
            scene.path.display()
        ),
        (Some(a), range) => {
            let (first, last) = range.unwrap_or((a.frame_start, a.frame_end));
            for f in [first, last] {
                if !a.contains(f) {
                    bail!(
                        "{}: frame {f} is outside the scene's frame range {}-{}",
                        scene.path.display(),
                        a.frame_start,
                        a.frame_end
                    );
                }
            }
            Ok((first..=last).map(Some).collect())
        }
    }
}

fn sweep(desc: SceneDescription, dir: &Path, args: &SpeedupArgs) -> anyhow::Result<ExitCode> {
    let mut ref_desc = desc.clone();
    ref_desc.render.seed = Some(args.seed ^ 0x5851_F42D_4C95_7F2D);
    let key_desc = desc.clone();
    let mut scene = Scene::load_description(desc)?;
    let mut ref_scene = Scene::load_description(ref_desc)?;
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let frames = frame_list(&scene, args)?;
    let course = match frames.last() {
        Some(Some(last)) => AdaptationCourse::compute(&mut scene, *last)?,
        _ => None,
    };
    let arms: &[Arm] = if course.is_some() {
        &[
            Arm::Uniform,
            Arm::Variance,
            Arm::Perceptual,
            Arm::PerceptualNoVelocity,
        ]
    } else {
        &[Arm::Uniform, Arm::Variance, Arm::Perceptual]
    };
    let default_op = if course.is_some() {
        Operator::Ptyg
    } else {
        Operator::Exposure
    };
    let op = args.tonemap.map(Operator::from).unwrap_or(default_op);
    let mut acc: Vec<Acc> = (0..arms.len() * args.budgets.len())
        .map(|_| Acc::default())
        .collect();
    let mut floor_acc = Acc::default();
    let mut per_frame = String::from(
        "frame,sampler,budget_spp,mean_spp,wall_s,flip_mean,flip_p99,visible_fraction,relmse\n",
    );
    let mut uniform_maps: Vec<(f64, Vec<f32>)> = Vec::new();
    let mut view = perception::viewing::ViewingConditions::default();
    for &frame in &frames {
        if let Some(f) = frame {
            scene.set_frame(f)?;
            ref_scene.set_frame(f)?;
        }
        let key = reference_key(&key_desc, args.reference_spp, args.seed, frame);
        let reference = reference_for(
            &ref_scene,
            &dir.join(format!("reference-{key}.exr")),
            args.reference_spp,
        )?;
        let mut tone = args.tone.settings(op, w, scene.settings.luminance_scale)?;
        tone.adaptation_state = course.as_ref().zip(frame).map(|(c, f)| c.state_at(f));
        // The viewer of the judges is the sampler's (one --ppd rule).
        view = args
            .sampling
            .settings(Arm::Uniform.sampler(), None, 1, tone)?
            .tone
            .view;
        let frozen = FrozenToneMap::new(&reference.mean, w, h, &tone)?;
        let judge = Judge::new(reference.mean.clone(), w, h, frozen.clone(), view)?;
        let floor = Judge::floor(&reference.even, &reference.odd, w, h, frozen, view)?;
        floor_acc.add(&Row {
            sampler: Arm::Uniform,
            budget: 0.0,
            mean_spp: 0.0,
            guide_spp: 0.0,
            wall_s: 0.0,
            decision_s: 0.0,
            scores: floor,
        });
        let mut images = AtomicOutputs::new();
        {
            let p = image_path(dir, "reference", frame);
            std::fs::create_dir_all(p.parent().expect("has a parent"))?;
            let srgb = judge.display_srgb(&reference.mean)?;
            images.stage(&p, |wr| write_png(wr, &p, w as u32, h as u32, &srgb))?;
        }
        for (bi, &budget) in args.budgets.iter().enumerate() {
            for (ai, &arm) in arms.iter().enumerate() {
                let mut settings =
                    args.sampling
                        .settings(arm.sampler(), Some(budget), budget as u32, tone)?;
                settings.use_velocity = arm != Arm::PerceptualNoVelocity;
                let t = Instant::now();
                let r = render_adaptive(&scene, &settings, &|_| {}, &|_| {})?;
                let wall = t.elapsed().as_secs_f64();
                let rgb = r.film.mean_rgb();
                let (scores, fmap) = judge.score_with_map(&rgb)?;
                if arm == Arm::Uniform && frame == frames[0] {
                    uniform_maps.push((budget, fmap));
                }
                let row = Row {
                    sampler: arm,
                    budget,
                    mean_spp: r.mean_spp(),
                    guide_spp: r
                        .guide_stats
                        .map(|g| g.samples as f64 / (w * h) as f64)
                        .unwrap_or(0.0),
                    wall_s: wall,
                    decision_s: r.decision_time.as_secs_f64(),
                    scores,
                };
                let label = match frame {
                    Some(f) => format!("frame {f} "),
                    None => String::new(),
                };
                eprintln!(
                    "{label}{:>21} {:>6} spp: {:7.2} spp used, {:7.2} s, FLIP {:.4} (p99 {:.4}), visible {:.4}, relMSE {:.5}",
                    arm.name(),
                    budget,
                    row.mean_spp,
                    wall,
                    scores.flip_mean,
                    scores.flip_p99,
                    scores.visible_fraction,
                    scores.relmse
                );
                let _ = writeln!(
                    per_frame,
                    "{},{},{budget},{:.4},{:.4},{:.6},{:.6},{:.6},{:.8}",
                    frame.unwrap_or(0),
                    arm.name(),
                    row.mean_spp,
                    wall,
                    scores.flip_mean,
                    scores.flip_p99,
                    scores.visible_fraction,
                    scores.relmse
                );
                let png = image_path(dir, &format!("{}-{}spp", arm.name(), budget), frame);
                std::fs::create_dir_all(png.parent().expect("has a parent"))?;
                let srgb = judge.display_srgb(&rgb)?;
                images.stage(&png, |wr| write_png(wr, &png, w as u32, h as u32, &srgb))?;
                acc[bi * arms.len() + ai].add(&row);
            }
        }
        images.commit()?;
    }
    let rows: Vec<Row> = args
        .budgets
        .iter()
        .enumerate()
        .flat_map(|(bi, &b)| {
            let acc = &acc;
            arms.iter()
                .enumerate()
                .map(move |(ai, &arm)| acc[bi * arms.len() + ai].row(arm, b))
        })
        .collect();
    let floor = floor_acc.row(Arm::Uniform, 0.0).scores;
    // The ceiling (of the first frame), fitted between the second-lowest and the highest uniform
    // budgets (the lowest is the noisiest fit), at each budget of the sweep.
    let ceilings: Vec<(f64, Ceiling)> = if uniform_maps.len() >= 3 {
        let (lo, hi) = (&uniform_maps[1], &uniform_maps[uniform_maps.len() - 1]);
        args.budgets
            .iter()
            .filter_map(|&b| ceiling(lo.0, &lo.1, hi.0, &hi.1, b).map(|c| (b, c)))
            .collect()
    } else {
        Vec::new()
    };
    let n_frames = frames.iter().flatten().count();
    let report = report(
        &rows, &floor, args, &scene, w, h, view.ppd, &ceilings, n_frames,
    );
    print!("{report}");
    let mut out = AtomicOutputs::new();
    out.stage_bytes(&dir.join("speedup.csv"), csv(&rows).as_bytes())?;
    if n_frames > 0 {
        out.stage_bytes(&dir.join("frames.csv"), per_frame.as_bytes())?;
    }
    out.stage_bytes(&dir.join("speedup.md"), report.as_bytes())?;
    let (png, pw, ph) = plot_png(&rows, &floor)?;
    let plot_path = dir.join("speedup.png");
    out.stage(&plot_path, |wr| write_png(wr, &plot_path, pw, ph, &png))?;
    out.stage_bytes(
        &dir.join("speedup.svg"),
        plot_svg(&rows, &floor)?.as_bytes(),
    )?;
    out.commit()?;
    eprintln!("wrote {}", dir.display());
    Ok(ExitCode::SUCCESS)
}

fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "sampler,budget_spp,mean_spp,guide_spp,wall_s,perception_s,flip_mean,flip_p99,visible_fraction,relmse\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{:.4},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{:.8}",
            r.sampler.name(),
            r.budget,
            r.mean_spp,
            r.guide_spp,
            r.wall_s,
            r.decision_s,
            r.scores.flip_mean,
            r.scores.flip_p99,
            r.scores.visible_fraction,
            r.scores.relmse
        );
    }
    s
}

fn curve(
    rows: &[Row],
    s: Arm,
    x: impl Fn(&Row) -> f64,
    y: impl Fn(&Row) -> f64,
) -> Vec<(f64, f64)> {
    let mut c: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.sampler == s)
        .map(|r| (x(r), y(r)))
        .collect();
    c.sort_by(|a, b| a.0.total_cmp(&b.0));
    c
}

#[allow(clippy::too_many_arguments)]
fn report(
    rows: &[Row],
    floor: &Scores,
    args: &SpeedupArgs,
    scene: &Scene,
    w: usize,
    h: usize,
    ppd: f64,
    ceilings: &[(f64, Ceiling)],
    frames: usize,
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# aleph speedup: {}", scene.path.display());
    if frames > 0 {
        let _ = writeln!(
            s,
            "\nA sequence of {frames} frames, each with its own reference and sweep: spp and scores are means over the frames, wall times are sums (per-frame rows in `frames.csv`). The judged display is {} with the viewer's adaptation carried from frame to frame.",
            args.tonemap
                .map(Operator::from)
                .unwrap_or(Operator::Ptyg)
                .label()
        );
    }
    let _ = writeln!(
        s,
        "\n{w}×{h}, reference {} spp uniform (its own noise floor, FLIP between its two half-buffers: mean {:.4}, p99 {:.4}); viewer at {:.1} pixels per degree.\n",
        args.reference_spp, floor.flip_mean, floor.flip_p99, ppd
    );
    let _ = writeln!(
        s,
        "| sampler | budget spp | spp used | wall s | perception s | FLIP mean | FLIP p99 | aleph visible | relMSE |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {:.2} | {:.3} | {:.4} | {:.4} | {:.4} | {:.5} |",
            r.sampler.name(),
            r.budget,
            r.mean_spp,
            r.wall_s,
            r.decision_s,
            r.scores.flip_mean,
            r.scores.flip_p99,
            r.scores.visible_fraction,
            r.scores.relmse
        );
    }
    for (label, metric) in [
        (
            "FLIP mean",
            (|r: &Row| r.scores.flip_mean) as fn(&Row) -> f64,
        ),
        ("FLIP p99", |r: &Row| r.scores.flip_p99),
    ] {
        let _ = writeln!(s, "\n## Equal {label}\n");
        let _ = writeln!(
            s,
            "| target {label} | uniform spp | variance spp | perceptual spp | speedup vs uniform (spp) | vs variance (spp) | speedup vs uniform (time) | vs variance (time) |{}",
            if frames > 0 {
                " perceptual without velocity spp | velocity's gain (spp) |"
            } else {
                ""
            }
        );
        let _ = writeln!(
            s,
            "|---|---|---|---|---|---|---|---|{}",
            if frames > 0 { "---|---|" } else { "" }
        );
        let uni = curve(rows, Arm::Uniform, |r| r.mean_spp, metric);
        // Targets: the uniform sampler's scores at its budgets (excluding the extremes).
        let targets: Vec<f64> = uni.iter().skip(1).map(|p| p.1).collect();
        for t in targets {
            let spp = |k| samples_for(&curve(rows, k, |r| r.mean_spp, metric), t);
            let time = |k| samples_for(&curve(rows, k, |r| r.wall_s, metric), t);
            let f = |v: Option<f64>| v.map(|x| format!("{x:.2}")).unwrap_or_else(|| "—".into());
            let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
                (Some(a), Some(b)) if b > 0.0 => format!("{:.2}×", a / b),
                _ => "—".into(),
            };
            let (us, vs, ps) = (spp(Arm::Uniform), spp(Arm::Variance), spp(Arm::Perceptual));
            let (ut, vt, pt) = (
                time(Arm::Uniform),
                time(Arm::Variance),
                time(Arm::Perceptual),
            );
            let extra = if frames > 0 {
                let ns = spp(Arm::PerceptualNoVelocity);
                format!(" {} | {} |", f(ns), ratio(ns, ps))
            } else {
                String::new()
            };
            let _ = writeln!(
                s,
                "| {t:.4} | {} | {} | {} | {} | {} | {} | {} |{extra}",
                f(us),
                f(vs),
                f(ps),
                ratio(us, ps),
                ratio(vs, ps),
                ratio(ut, pt),
                ratio(vt, pt)
            );
        }
    }
    if !ceilings.is_empty() {
        let _ = writeln!(
            s,
            "\n## Ceiling\n\nThe best any allocation could do with perfect knowledge of each pixel's FLIP error (per-pixel fits a·n^−β to the uniform renders, β = {:.3}):\n",
            ceilings[0].1.beta
        );
        let _ = writeln!(
            s,
            "| budget spp | ceiling speedup, FLIP mean | ceiling speedup, FLIP p99 |"
        );
        let _ = writeln!(s, "|---|---|---|");
        for (b, c) in ceilings {
            let _ = writeln!(s, "| {b} | {:.2}× | {:.2}× |", c.mean, c.p99);
        }
    }
    let perc: Vec<&Row> = rows
        .iter()
        .filter(|r| r.sampler == Arm::Perceptual)
        .collect();
    let total: f64 = perc.iter().map(|r| r.wall_s).sum();
    let dec: f64 = perc.iter().map(|r| r.decision_s).sum();
    let guide = perc.iter().map(|r| r.guide_spp).fold(0.0, f64::max);
    let _ = writeln!(
        s,
        "\nPerception overhead of the perceptual sampler: {:.3} s of {:.2} s wall time over the sweep ({:.1} %), plus a {guide:.0}-spp albedo guide per render.",
        dec,
        total,
        100.0 * dec / total.max(1e-9)
    );
    s
}

type Series = (Arm, RGBColor);
const SERIES: [Series; 4] = [
    (Arm::Uniform, RGBColor(90, 90, 90)),
    (Arm::Variance, RGBColor(30, 110, 200)),
    (Arm::Perceptual, RGBColor(220, 60, 30)),
    (Arm::PerceptualNoVelocity, RGBColor(240, 160, 40)),
];

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    rows: &[Row],
    floor: &Scores,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let panels = root.split_evenly((2, 2));
    type Metric<'a> = (&'a str, fn(&Row) -> f64, f64);
    let metrics: [Metric; 2] = [
        ("FLIP mean", |r| r.scores.flip_mean, floor.flip_mean),
        ("FLIP p99 (5×5)", |r| r.scores.flip_p99, floor.flip_p99),
    ];
    type Axis<'a> = (&'a str, fn(&Row) -> f64);
    let axes: [Axis; 2] = [
        ("samples per pixel", |r| r.mean_spp),
        ("wall time (s)", |r| r.wall_s),
    ];
    for (pi, panel) in panels.iter().enumerate() {
        let (mname, mf, fl) = metrics[pi / 2];
        let (xname, xf) = axes[pi % 2];
        let xs: Vec<f64> = rows.iter().map(xf).collect();
        let ys: Vec<f64> = rows.iter().map(mf).chain([fl]).collect();
        let (x0, x1) = (
            xs.iter().cloned().fold(f64::INFINITY, f64::min) * 0.8,
            xs.iter().cloned().fold(0.0, f64::max) * 1.25,
        );
        let (y0, y1) = (
            ys.iter().cloned().fold(f64::INFINITY, f64::min).max(1e-5) * 0.8,
            ys.iter().cloned().fold(0.0, f64::max) * 1.25,
        );
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{mname} vs {xname}"), ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d(
                (x0.max(1e-4)..x1.max(x0 * 2.0)).log_scale(),
                (y0..y1).log_scale(),
            )
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc(xname)
            .y_desc(mname)
            .x_label_formatter(&|v| {
                if *v >= 10.0 {
                    format!("{v:.0}")
                } else {
                    format!("{v:.1}")
                }
            })
            .y_label_formatter(&|v| format!("{v:.2}"))
            .light_line_style(BLACK.mix(0.04))
            .bold_line_style(BLACK.mix(0.15))
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|e| e.to_string())?;
        for (k, color) in SERIES {
            let c = curve(rows, k, xf, mf);
            if c.is_empty() {
                continue;
            }
            chart
                .draw_series(LineSeries::new(c.clone(), color.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(k.name())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                });
            chart
                .draw_series(c.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(|e| e.to_string())?;
        }
        chart
            .draw_series(LineSeries::new(
                vec![(x0.max(1e-4), fl), (x1, fl)],
                BLACK.mix(0.4).stroke_width(1),
            ))
            .map_err(|e| e.to_string())?
            .label("reference noise floor")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK.mix(0.4)));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}

fn plot_png(rows: &[Row], floor: &Scores) -> anyhow::Result<(Vec<u8>, u32, u32)> {
    aleph::display::register_font();
    let (w, h) = (1200u32, 900u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    draw(
        BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area(),
        rows,
        floor,
    )
    .map_err(|e| anyhow::anyhow!("plot: {e}"))?;
    Ok((buf, w, h))
}

fn plot_svg(rows: &[Row], floor: &Scores) -> anyhow::Result<String> {
    aleph::display::register_font();
    let mut s = String::new();
    draw(
        SVGBackend::with_string(&mut s, (1200, 900)).into_drawing_area(),
        rows,
        floor,
    )
    .map_err(|e| anyhow::anyhow!("plot: {e}"))?;
    Ok(s)
}
