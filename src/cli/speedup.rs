//! `aleph speedup [SCENE]`: how much perceptual sampling saves at equal quality.

use super::render::{SamplingArgs, default_scene};
use super::tonemap::{OperatorArg, ToneArgs};
use super::{parse_resolution, with_threads};
use aleph::adaptive::Criterion;
use aleph::output::{AtomicOutputs, write_png};
use aleph::scene::SceneDescription;
use aleph_speedup::{Arm, LATITUDE_EV, METRICS, Row, Scores, Sweep, SweepSpec, samples_for, sweep};
use anyhow::bail;
use clap::Args;
use perception::tmo::Operator;
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

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
    /// Tone operator of the judged display images (default: Reinhard for a still, as `render`
    /// writes; PTYG with the carried adaptation state for a sequence).
    #[arg(long, value_enum, value_name = "OP")]
    tonemap: Option<OperatorArg>,
    /// Frames of an animated scene, FIRST-LAST (default: the whole [animation] range). Each
    /// frame gets its own reference and sweep; the sequence's speedup is at equal mean score.
    #[arg(long, value_name = "A-B", value_parser = super::render::parse_frames)]
    frames: Option<(i64, i64)>,
    /// Also render the perceptual sampler's own stop (no budget, as `aleph render` runs by
    /// default) and report the uniform spp and wall time that reach each of its scores. Put
    /// budgets in the sweep that bracket the stop's scores (up to 1024 spp or more).
    #[arg(long)]
    stop: bool,
    /// Only these samplers besides uniform, which every table compares with (default: every
    /// one the scene has: variance and perceptual, and for a sequence the perceptual sampler
    /// without velocity and, with --reuse-window above 0, reuse).
    #[arg(long, value_enum, value_name = "ARM,…", value_delimiter = ',')]
    arms: Option<Vec<ArmArg>>,
    #[command(flatten)]
    sampling: SamplingArgs,
    #[command(flatten)]
    tone: ToneArgs,
}

/// An arm of the sweep, by the name its tables and files give it.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum ArmArg {
    Uniform,
    Variance,
    Perceptual,
    PerceptualNovelocity,
    Reuse,
}

impl From<ArmArg> for Arm {
    fn from(a: ArmArg) -> Arm {
        match a {
            ArmArg::Uniform => Arm::Uniform,
            ArmArg::Variance => Arm::Variance,
            ArmArg::Perceptual => Arm::Perceptual,
            ArmArg::PerceptualNovelocity => Arm::PerceptualNoVelocity,
            ArmArg::Reuse => Arm::Reuse,
        }
    }
}

pub fn run(args: SpeedupArgs) -> anyhow::Result<ExitCode> {
    let scene_path = args.scene.clone().unwrap_or_else(default_scene);
    let mut desc = SceneDescription::read(&scene_path)?;
    let (w, h) = args.resolution.unwrap_or((256, 256));
    aleph::scene::check_resolution(w, h).map_err(|m| anyhow::anyhow!("--resolution: {m}"))?;
    desc.camera.resolution = [w, h];
    desc.render.seed = Some(args.seed);
    if args.budgets.is_empty() || args.budgets.iter().any(|b| !(b.is_finite() && *b >= 1.0)) {
        bail!("--budgets must be numbers ≥ 1, got {:?}", args.budgets);
    }
    let cap = args.sampling.max_spp;
    if let Some(b) = args.budgets.iter().find(|&&b| b > cap as f64) {
        bail!(
            "--budgets {b}: more than --max-spp {cap}, the most any one pixel takes, so the \
             perceptual sampler could not spend it; raise --max-spp"
        );
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
    with_threads(args.threads, move || run_sweep(desc, &dir, &args))?
}

/// The library's sweep, then the table, CSVs and plots.
fn run_sweep(desc: SceneDescription, dir: &Path, args: &SpeedupArgs) -> anyhow::Result<ExitCode> {
    // The reuse arm's window, cut to what the reuse memory holds as `aleph render` cuts it.
    let [w, h] = desc.camera.resolution;
    let pixels = w as usize * h as usize;
    let reuse_asked = args
        .sampling
        .reuse_window
        .unwrap_or(aleph::job::DEFAULT_REUSE_WINDOW);
    let reuse_memory = args.sampling.options().reuse_memory();
    let spec = SweepSpec {
        budgets: args.budgets.clone(),
        reference_spp: args.reference_spp,
        seed: args.seed,
        frames: args.frames,
        operator: args.tonemap.map(Operator::from),
        stop: args.stop,
        reuse_window: aleph::reuse::window_for(pixels, reuse_asked, reuse_memory),
        arms: args
            .arms
            .as_ref()
            .map(|a| a.iter().map(|&a| Arm::from(a)).collect()),
    };
    // Every sampler setting but the sampler, budget and display; the luminance scale is the
    // scene's (set by the sweep).
    let w = desc.camera.resolution[0] as usize;
    let tone = args.tone.settings(Operator::Exposure, w, 1.0)?;
    let mut base = args
        .sampling
        .settings(Criterion::Perceptual, None, 1, tone)?;
    base.reuse_frame_memory = aleph::reuse::frame_memory(spec.reuse_window, reuse_memory);
    let result = sweep(desc, dir, &spec, &base, &|line| eprintln!("{line}"))?;
    let report = report(&result, args, &scene_name(args));
    print!("{report}");
    let mut out = AtomicOutputs::new();
    out.stage_bytes(&dir.join("speedup.csv"), csv(&result.rows).as_bytes())?;
    if let Some(stop) = &result.stop {
        out.stage_bytes(
            &dir.join("stop.csv"),
            csv(std::slice::from_ref(stop)).as_bytes(),
        )?;
    }
    if result.frames > 0 {
        out.stage_bytes(&dir.join("frames.csv"), result.per_frame_csv.as_bytes())?;
    }
    out.stage_bytes(&dir.join("speedup.md"), report.as_bytes())?;
    let (png, pw, ph) = plot_png(&result.rows, &result.floor)?;
    let plot_path = dir.join("speedup.png");
    out.stage(&plot_path, |wr| write_png(wr, &plot_path, pw, ph, &png))?;
    out.stage_bytes(
        &dir.join("speedup.svg"),
        plot_svg(&result.rows, &result.floor)?.as_bytes(),
    )?;
    out.commit()?;
    eprintln!("wrote {}", dir.display());
    Ok(ExitCode::SUCCESS)
}

fn scene_name(args: &SpeedupArgs) -> String {
    args.scene
        .clone()
        .unwrap_or_else(default_scene)
        .display()
        .to_string()
}

fn csv(rows: &[Row]) -> String {
    let mut s = format!(
        "sampler,budget_spp,mean_spp,guide_spp,wall_s,perception_s,{}\n",
        Scores::CSV_HEADER
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{:.4},{:.4},{:.4},{:.4},{}",
            r.sampler.name(),
            r.budget,
            r.mean_spp,
            r.guide_spp,
            r.wall_s,
            r.decision_s,
            r.scores.csv_fields()
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

fn report(sw: &Sweep, args: &SpeedupArgs, scene: &str) -> String {
    let (rows, floor, ceilings, frames) = (&sw.rows, &sw.floor, &sw.ceilings, sw.frames);
    let (w, h, ppd) = (sw.width, sw.height, sw.ppd);
    let mut s = String::new();
    let _ = writeln!(s, "# aleph speedup: {scene}");
    if frames > 0 {
        let _ = writeln!(
            s,
            "\nA sequence of {frames} frames, each with its own reference and sweep: spp and scores are means over the frames, wall times are sums (per-frame rows in `frames.csv`). The judged display is {} with the viewer's adaptation carried from frame to frame.",
            sw.operator.label()
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
    let _ = writeln!(
        s,
        "\nThe same renders graded {LATITUDE_EV} stops darker and brighter (the ends of the exposure latitude the sampler must hold), FLIP mean / p99:\n\n| sampler | budget spp | −{LATITUDE_EV} EV | +{LATITUDE_EV} EV |\n|---|---|---|---|"
    );
    for r in rows {
        let (d, b) = (r.scores.graded[0], r.scores.graded[1]);
        let _ = writeln!(
            s,
            "| {} | {} | {:.4} / {:.4} | {:.4} / {:.4} |",
            r.sampler.name(),
            r.budget,
            d.mean,
            d.p99,
            b.mean,
            b.p99
        );
    }
    equal_score_tables(&mut s, rows, frames);
    if !ceilings.is_empty() {
        let _ = writeln!(
            s,
            "\n## Ceiling\n\nThe best any allocation could do with perfect knowledge of each pixel's FLIP error (per-pixel fits a·n^−β to the uniform renders, β = {:.3}):\n",
            ceilings[0].1.beta
        );
        let _ = writeln!(
            s,
            "| budget spp | ceiling speedup, FLIP mean | ceiling speedup, FLIP p99 | ceiling speedup in wall time, FLIP mean |"
        );
        let _ = writeln!(s, "|---|---|---|---|");
        for (b, c) in ceilings {
            let time = c.time_mean.map_or("—".into(), |t| format!("{t:.2}×"));
            let _ = writeln!(s, "| {b} | {:.2}× | {:.2}× | {time} |", c.mean, c.p99);
        }
        let _ = writeln!(
            s,
            "\nIn wall time: each pixel's cost per sample timed over {} samples, and the allocation that reaches uniform's FLIP mean in the least time, n_i ∝ (a_i / c_i)^(1/(1+β)) (Cochran 1977, §5.5). Where samples cost alike it equals the ceiling in samples; where some pixels' samples are cheap (a directly seen sky), uniform spends little time on them and the ceiling in time is lower.",
            aleph_speedup::COST_SPP
        );
    }
    if !sw.oracle.is_empty() {
        let _ = writeln!(
            s,
            "\n## Against the oracle\n\nSpearman rank correlation of the perceptual sampler's samples per pixel with the oracle's allocation at the displayed exposure (from the same per-pixel fits: n_i ∝ a_i^(1/(1+β)) for FLIP mean, a_i^(1/β) for FLIP p99, one ranking); maps side by side in `oracle/Bspp.png` (oracle for the mean, for p99, aleph's; log scale from budget/8 to 8 × budget). The time per sample of each allocation, relative to uniform's, from the pixels' measured costs: above 1, the allocation's wall time falls short of its sample savings by that factor.\n\n| budget spp | rank correlation with the oracle | time per sample, aleph's allocation | time per sample, FLIP-mean oracle's |\n|---|---|---|---|"
        );
        for o in &sw.oracle {
            let rank = match o.rank {
                Some(r) => format!("{r:.3}"),
                None => "— (every pixel the same count: rendered uniformly)".into(),
            };
            let (ca, co) = match o.cost {
                Some((a, b)) => (format!("{a:.3}×"), format!("{b:.3}×")),
                None => ("—".into(), "—".into()),
            };
            let _ = writeln!(s, "| {} | {rank} | {ca} | {co} |", o.budget);
        }
    }
    if let Some(stop) = &sw.stop {
        stop_report(&mut s, rows, stop);
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

/// One table per score of [`METRICS`]: the spp and wall time each arm needs for the uniform
/// sampler's scores, and the speedups.
fn equal_score_tables(s: &mut String, rows: &[Row], frames: usize) {
    for (label, read) in METRICS {
        let metric = |r: &Row| read(&r.scores);
        let _ = writeln!(s, "\n## Equal {label}\n");
        let _ = writeln!(
            s,
            "| target {label} | uniform spp | variance spp | perceptual spp | speedup vs uniform (spp) | vs variance (spp) | speedup vs uniform (time) | vs variance (time) |{}",
            if frames > 0 {
                " perceptual without velocity spp | velocity's gain (spp) | reuse fresh spp | reuse vs uniform (spp) | reuse vs uniform (time) |"
            } else {
                ""
            }
        );
        let _ = writeln!(
            s,
            "|---|---|---|---|---|---|---|---|{}",
            if frames > 0 {
                "---|---|---|---|---|"
            } else {
                ""
            }
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
                let (rs, rt) = (spp(Arm::Reuse), time(Arm::Reuse));
                format!(
                    " {} | {} | {} | {} | {} |",
                    f(ns),
                    ratio(ns, ps),
                    f(rs),
                    ratio(us, rs),
                    ratio(ut, rt)
                )
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
}

/// The section on the perceptual sampler's own stop: for each score, the uniform spp and wall
/// time that reach it (log-log interpolation over the sweep's uniform renders).
fn stop_report(s: &mut String, rows: &[Row], stop: &Row) {
    let _ = writeln!(
        s,
        "\n## The default stop\n\nThe perceptual sampler without a budget (`aleph render`'s default: until the converged fraction of pixels is below threshold): {:.1} spp mean, {:.2} s wall time ({:.3} s of it in the perception model). For each of its scores, the uniform render that reaches it (spp and wall time interpolated over the uniform renders above; — where the stop is better than the sweep's largest budget or worse than its smallest):\n\n| score | the stop | uniform spp | uniform s | stop's time ÷ uniform's |\n|---|---|---|---|---|",
        stop.mean_spp, stop.wall_s, stop.decision_s
    );
    let mut worst: Option<(f64, f64)> = Some((0.0, 0.0));
    for (label, read) in METRICS {
        let metric = |r: &Row| read(&r.scores);
        let target = read(&stop.scores);
        let spp = samples_for(&curve(rows, Arm::Uniform, |r| r.mean_spp, metric), target);
        let time = samples_for(&curve(rows, Arm::Uniform, |r| r.wall_s, metric), target);
        worst = match (worst, spp, time) {
            (Some((ws, wt)), Some(a), Some(b)) => Some((ws.max(a), wt.max(b))),
            _ => None,
        };
        let f = |v: Option<f64>, p: usize| v.map(|x| format!("{x:.p$}")).unwrap_or("—".into());
        let ratio = time.map(|t| format!("{:.2}×", stop.wall_s / t));
        let _ = writeln!(
            s,
            "| {label} | {target:.4} | {} | {} | {} |",
            f(spp, 0),
            f(time, 2),
            ratio.unwrap_or("—".into())
        );
    }
    let _ = match worst {
        Some((spp, t)) => writeln!(
            s,
            "\nA uniform render that reaches every one of these scores needs {spp:.0} spp and {t:.2} s: the stop takes {:.2}× its samples and {:.2}× its time.",
            stop.mean_spp / spp.max(1e-9),
            stop.wall_s / t.max(1e-9)
        ),
        None => writeln!(
            s,
            "\nAt least one score lies outside the uniform renders' range: widen `--budgets`."
        ),
    };
}

type Series = (Arm, RGBColor);
const SERIES: [Series; 5] = [
    (Arm::Uniform, RGBColor(90, 90, 90)),
    (Arm::Variance, RGBColor(30, 110, 200)),
    (Arm::Perceptual, RGBColor(220, 60, 30)),
    (Arm::PerceptualNoVelocity, RGBColor(240, 160, 40)),
    (Arm::Reuse, RGBColor(40, 160, 80)),
];

/// A log-axis range around the positive finite values of `v` (20 % margins), never below
/// `floor` and always ascending by at least a factor of two: scores of 0 everywhere, or none
/// finite, still give an axis (plotters' log axis loops on an empty or reversed range).
fn log_range(v: &[f64], floor: f64) -> (f64, f64) {
    let ok = v.iter().copied().filter(|x| x.is_finite() && *x > 0.0);
    let lo = ok.clone().fold(f64::INFINITY, f64::min);
    let hi = ok.fold(0.0, f64::max);
    if !lo.is_finite() {
        return (floor, floor * 1e4);
    }
    let lo = (lo * 0.8).max(floor);
    (lo, (hi * 1.25).max(lo * 2.0))
}
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
        let (x0, x1) = log_range(&xs, 1e-4);
        let (y0, y1) = log_range(&ys, 1e-5);
        let mut chart = ChartBuilder::on(panel)
            .caption(format!("{mname} vs {xname}"), ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
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

/// Registers the bundled DejaVu Sans as plotters' "sans-serif" for the charts (once).
fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            aleph::display::LABEL_FONT,
        );
    });
}

fn plot_png(rows: &[Row], floor: &Scores) -> anyhow::Result<(Vec<u8>, u32, u32)> {
    register_font();
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
    register_font();
    let mut s = String::new();
    draw(
        SVGBackend::with_string(&mut s, (1200, 900)).into_drawing_area(),
        rows,
        floor,
    )
    .map_err(|e| anyhow::anyhow!("plot: {e}"))?;
    Ok(s)
}
