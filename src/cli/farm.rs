//! `aleph farm`: a render split into tasks for a cluster's own scheduler (Slurm), with the
//! results equal to a single machine's.
//!
//! `farm slurm` checks the render, writes `DIR/farm.toml` (the manifest: what each task
//! renders), `DIR/render.sbatch` (a job array, one task per frame, or per frame and sample part)
//! and `DIR/finish.sbatch` (merges sample parts and writes the sequence's preview), and with
//! `--submit` hands both to `sbatch`, the second depending on the first. Each task runs
//! `aleph farm task DIR --index I`, which skips work whose outputs exist (a requeued or rerun
//! task) and writes through temporary files (a failed task leaves nothing). `aleph farm finish
//! DIR` then merges and tone-maps. Nothing in the tasks depends on Slurm: any scheduler that
//! runs `farm task` for every index and then `farm finish` gives the same files (docs/farm.md
//! shows a Kubernetes Indexed Job).

use super::merge::{self, MergeArgs};
use super::render::{self, RenderArgs, default_scene, parse_frames, with_ext};
use super::with_threads;
use aleph::adaptive::Criterion;
use aleph::deliver::{numbered, write_sequence_outputs};
use aleph::job::{RenderJob, Split};
use aleph::partial::part_path;
use anyhow::{Context, bail};
use clap::{Args, Parser, Subcommand};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

#[derive(Args, Debug)]
pub struct FarmArgs {
    #[command(subcommand)]
    command: FarmCommand,
}

#[derive(Subcommand, Debug)]
enum FarmCommand {
    /// Write (and with --submit, submit) a Slurm job array that renders SCENE's frames or
    /// sample parts, and a dependent job that merges them.
    Slurm(Box<SlurmArgs>),
    /// Run task INDEX of a farm directory (what each array task runs).
    Task(TaskArgs),
    /// Merge the sample parts and write the sequence's preview (the job after the array).
    Finish(FinishArgs),
}

#[derive(Args, Debug)]
struct SlurmArgs {
    /// Scene file (default: the bundled Cornell box).
    scene: Option<PathBuf>,
    /// The farm directory: manifest, batch scripts, logs and outputs.
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Frames of an animated scene, FIRST-LAST (default: the scene's whole range).
    #[arg(long, value_name = "A-B", value_parser = parse_frames)]
    frames: Option<(i64, i64)>,
    /// Split every frame's samples into K parts on K tasks (uniform sampler; bit-identical to
    /// one machine).
    #[arg(long, value_name = "K", default_value_t = 1)]
    split_samples: u32,
    /// Split every frame into K row tiles on K tasks (perceptual and variance samplers; the
    /// measured cost is in docs/farm.md).
    #[arg(
        long,
        value_name = "K",
        default_value_t = 1,
        conflicts_with = "split_samples"
    )]
    split_tiles: u32,
    /// Submit the jobs with sbatch.
    #[arg(long)]
    submit: bool,
    /// With --submit: wait until the finishing job has ended (sbatch --wait) and exit with
    /// its status.
    #[arg(long, requires = "submit")]
    wait: bool,
    /// Slurm partition (#SBATCH --partition).
    #[arg(long, value_name = "NAME")]
    partition: Option<String>,
    /// CPUs per task (#SBATCH --cpus-per-task); each task renders with that many threads.
    #[arg(long, value_name = "N")]
    cpus_per_task: Option<u32>,
    /// Memory per task (#SBATCH --mem), e.g. 4G.
    #[arg(long, value_name = "SIZE")]
    mem: Option<String>,
    /// Time limit per task (#SBATCH --time), e.g. 01:00:00.
    #[arg(long, value_name = "LIMIT")]
    time_limit: Option<String>,
    /// Any further #SBATCH option for both jobs, e.g. --sbatch=--account=lab (repeatable).
    #[arg(long = "sbatch", value_name = "OPTION", allow_hyphen_values = true)]
    sbatch: Vec<String>,
    /// The aleph binary the tasks run (default: this one; it must be reachable from the
    /// compute nodes, as must the scene and DIR).
    #[arg(long, value_name = "PATH")]
    aleph: Option<PathBuf>,
    /// Render options for every task (as for `aleph render`), after `--`.
    #[arg(last = true, value_name = "RENDER OPTIONS")]
    render: Vec<String>,
}

#[derive(Args, Debug)]
struct TaskArgs {
    /// The farm directory.
    dir: PathBuf,
    /// Task index, from 0 (Slurm's $SLURM_ARRAY_TASK_ID).
    #[arg(long, value_name = "I")]
    index: usize,
}

#[derive(Args, Debug)]
struct FinishArgs {
    /// The farm directory.
    dir: PathBuf,
}

/// `DIR/farm.toml`: what the tasks render.
#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
struct Manifest {
    /// The aleph binary the batch scripts run.
    aleph: PathBuf,
    /// Output stem inside the farm directory.
    stem: String,
    /// Frames `[first, last]` of an animated scene; none for a still.
    frames: Option<[i64; 2]>,
    /// Parts per frame.
    split: u32,
    /// Whether the parts are row tiles (`--split-tiles`) rather than sample ranges.
    #[serde(default)]
    tiles: bool,
    /// Rows on each side of a tile that also take samples (`--tile-margin`).
    #[serde(default)]
    tile_margin: u32,
    /// The animation's first frame, where the chunks of a render that reuses frames start
    /// (`aleph::reuse::chunk_start`): such a render gets one task per chunk.
    #[serde(default)]
    runs_from: Option<i64>,
    /// Pixels of a frame, which cut a reusing render's window to what its reuse memory holds
    /// (`RenderJob::reuse_window_for`); 0 (a manifest written before it): the window asked.
    #[serde(default)]
    pixels: u64,
    /// The render every task runs a frame or a part of (its frames, split and outputs are the
    /// farm's to set): the render options after `--`, as a render job.
    job: RenderJob,
}

/// What one task renders: frames `[first, last]` (one frame, or a chunk of frames that reuse
/// each other) and a part of them.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Task {
    frames: Option<[i64; 2]>,
    part: Option<(u32, u32)>,
}

impl Manifest {
    fn frame_list(&self) -> Vec<Option<i64>> {
        match self.frames {
            Some([a, b]) => (a..=b).map(Some).collect(),
            None => vec![None],
        }
    }

    /// The frame ranges of the tasks: each frame alone, or with reuse across frames chunks of
    /// `aleph::reuse::chunk_len` frames (a frame reuses the base passes of the K
    /// frames before it, which a chunk renders first as warm-up; longer chunks spend less of
    /// the farm on warm-up).
    fn frame_ranges(&self) -> Vec<Option<[i64; 2]>> {
        let k = match self.pixels {
            0 => self.job.reuse_window(),
            n => self.job.reuse_window_for(n as usize),
        };
        match (self.frames, self.runs_from) {
            (Some([a, b]), Some(start)) if k > 0 && self.split <= 1 => {
                let mut out = Vec::new();
                let mut f = a;
                while f <= b {
                    let len = aleph::reuse::chunk_len(k);
                    let end = (aleph::reuse::chunk_start(f, start, k) + len - 1).min(b);
                    out.push(Some([f, end]));
                    f = end + 1;
                }
                out
            }
            _ => self
                .frame_list()
                .into_iter()
                .map(|f| f.map(|f| [f, f]))
                .collect(),
        }
    }

    /// Tasks in index order: frames outer, parts inner.
    fn tasks(&self) -> Vec<Task> {
        let k = self.split;
        self.frame_ranges()
            .into_iter()
            .flat_map(|frames| {
                (1..=k).map(move |p| Task {
                    frames,
                    part: (k > 1).then_some((p, k)),
                })
            })
            .collect()
    }

    fn read(dir: &Path) -> anyhow::Result<Manifest> {
        let path = dir.join("farm.toml");
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("{}: cannot read the farm manifest", path.display()))?;
        let m: Manifest = toml::from_str(&text)
            .with_context(|| format!("{}: not a farm manifest", path.display()))?;
        // The outputs stay inside the farm folder: the stem is a plain file name.
        let plain = Path::new(&m.stem).components().count() == 1
            && !matches!(m.stem.as_str(), "" | "." | "..")
            && !m.stem.contains(std::path::is_separator);
        if !plain {
            bail!(
                "{}: stem {:?} must be a file name inside the farm folder",
                path.display(),
                m.stem
            );
        }
        Ok(m)
    }

    /// The stem of a frame's outputs (`DIR/STEM` or `DIR/STEM.NNNN`).
    fn frame_stem(&self, dir: &Path, frame: Option<i64>) -> PathBuf {
        let stem = dir.join(&self.stem);
        match frame {
            Some(f) => numbered(&stem, f),
            None => stem,
        }
    }

    /// The render job of a task.
    fn task_job(&self, dir: &Path, t: Task) -> RenderJob {
        let mut job = self.job.clone();
        job.frames = t.frames;
        job.split = t.part.map(|(index, count)| match self.tiles {
            true => Split::Tile {
                index,
                count,
                margin: self.tile_margin,
            },
            false => Split::Part { index, count },
        });
        job.output.stem = Some(dir.join(&self.stem));
        job.output.sequence_outputs = false;
        job
    }

    /// Whether a task's outputs exist, or for a part, its frame was already merged.
    fn task_done(&self, dir: &Path, t: Task) -> bool {
        let done = |t: Task| self.task_outputs(dir, t).iter().all(|p| p.exists());
        done(t) || (t.part.is_some() && done(Task { part: None, ..t }))
    }

    /// The files a task leaves when done.
    fn task_outputs(&self, dir: &Path, t: Task) -> Vec<PathBuf> {
        let frames: Vec<Option<i64>> = match t.frames {
            Some([a, b]) => (a..=b).map(Some).collect(),
            None => vec![None],
        };
        frames
            .into_iter()
            .flat_map(|f| {
                let stem = self.frame_stem(dir, f);
                match t.part {
                    Some((p, k)) => vec![part_path(&stem, p, k, self.tiles)],
                    None => vec![with_ext(&stem, "exr"), with_ext(&stem, "png")],
                }
            })
            .collect()
    }
}

/// Parses a render command line (after `render`) as `aleph render` would.
#[derive(Parser, Debug)]
#[command(name = "aleph render", no_binary_name = true)]
struct RenderLine {
    #[command(flatten)]
    args: RenderArgs,
}

/// Seconds since the Unix epoch.
fn now_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

pub fn run(args: FarmArgs) -> anyhow::Result<ExitCode> {
    match args.command {
        FarmCommand::Slurm(a) => slurm(*a),
        FarmCommand::Task(a) => task(a),
        FarmCommand::Finish(a) => finish(a),
    }
}

/// The render options after `--` (for every task) on `scene`, checked: the farm sets the
/// frames, the split and the outputs.
fn render_options(scene: &Path, options: &[String]) -> anyhow::Result<RenderArgs> {
    let mut argv = vec![scene.display().to_string()];
    argv.extend(options.iter().cloned());
    let args = RenderLine::try_parse_from(&argv)
        .context("the render options")?
        .args;
    let set = [
        ("-o", args.output.is_some()),
        ("--frames", args.frames.is_some()),
        ("--frame", args.frame.is_some()),
        ("--part", args.part.is_some()),
        ("--tile", args.tile.is_some()),
    ];
    if let Some((opt, _)) = set.iter().find(|(_, on)| *on) {
        bail!("{opt} is the farm's to set: give the farm's own options before `--`");
    }
    Ok(args)
}

/// Checks the render the manifest describes before anything is queued.
fn check_render(m: &Manifest) -> anyhow::Result<()> {
    let uniform = m.job.criterion == Criterion::Uniform;
    if m.split > 1 && !m.tiles && !uniform {
        bail!(
            "--split-samples splits a uniform render's samples: add `-- --sampler uniform`; the \
             perceptual and variance samplers split by rows (--split-tiles K) or by frames \
             (docs/farm.md)"
        );
    }
    if m.tiles && uniform {
        bail!("--split-tiles splits an adaptive render; a uniform one splits by --split-samples");
    }
    let scene = m.job.load_scene()?;
    let settings = m
        .job
        .adaptive_settings(scene.settings.spp, Default::default())?;
    if m.tiles && m.split > scene.camera.height {
        bail!(
            "--split-tiles {}: more tiles than the {} rows",
            m.split,
            scene.camera.height
        );
    }
    if m.split > 1 && !m.tiles && m.split > settings.uniform_total_spp() {
        bail!(
            "--split-samples {}: more parts than the {} samples per pixel",
            m.split,
            settings.uniform_total_spp()
        );
    }
    let path = &m.job.scene.path;
    match (m.frames, scene.animation) {
        (Some([a, b]), Some(anim)) if a < anim.frame_start || b > anim.frame_end => bail!(
            "{}: frames {a}-{b} are outside the scene's {}-{}",
            path.display(),
            anim.frame_start,
            anim.frame_end
        ),
        (Some(_), None) => bail!(
            "{}: --frames needs an animated scene (this one has no [animation] table)",
            path.display()
        ),
        _ => Ok(()),
    }
}

/// Checks every value `farm slurm` writes into a batch script against Slurm's own grammar
/// (sbatch(1)), so that no option can add a line or a command to the script a cluster runs:
/// partitions are names (letters, digits, `_`, `-`, `.`), comma-separated; `--mem` a whole
/// number with an optional unit K, M, G or T; `--time-limit` one of sbatch's forms (`M`, `M:S`,
/// `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S`, `UNLIMITED`); `--cpus-per-task` at least 1; each
/// `--sbatch` an option (`-x…` or `--name[=value]`) without blanks or control characters.
fn check_slurm_values(a: &SlurmArgs) -> anyhow::Result<()> {
    let name_ok = |s: &str| {
        !s.is_empty()
            && s.chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
    };
    if let Some(p) = &a.partition
        && !p.split(',').all(name_ok)
    {
        bail!(
            "--partition {p:?}: expected partition names (letters, digits, _ - .), comma-separated"
        );
    }
    if let Some(m) = &a.mem {
        let digits = m.trim_end_matches(['K', 'M', 'G', 'T', 'k', 'm', 'g', 't']);
        let unit_len = m.len() - digits.len();
        if digits.is_empty() || !digits.chars().all(|c| c.is_ascii_digit()) || unit_len > 1 {
            bail!(
                "--mem {m:?}: expected a whole number with an optional unit K, M, G or T (e.g. 4G)"
            );
        }
    }
    if let Some(t) = &a.time_limit
        && !slurm_time_ok(t)
    {
        bail!(
            "--time-limit {t:?}: expected one of sbatch's forms: MINUTES, MINUTES:SECONDS, \
             HOURS:MINUTES:SECONDS, DAYS-HOURS, DAYS-HOURS:MINUTES, DAYS-HOURS:MINUTES:SECONDS \
             or UNLIMITED"
        );
    }
    if a.cpus_per_task == Some(0) {
        bail!("--cpus-per-task must be at least 1");
    }
    for o in &a.sbatch {
        let option = o.starts_with('-') && o.len() > 1;
        if !option || o.chars().any(|c| c.is_whitespace() || c.is_control()) {
            bail!(
                "--sbatch {o:?}: expected one sbatch option such as --account=lab, without \
                 blanks or control characters"
            );
        }
    }
    Ok(())
}

/// Whether `t` is a time limit in one of sbatch's forms.
fn slurm_time_ok(t: &str) -> bool {
    if t.eq_ignore_ascii_case("unlimited") || t.eq_ignore_ascii_case("infinite") {
        return true;
    }
    let num = |s: &str| !s.is_empty() && s.len() <= 9 && s.chars().all(|c| c.is_ascii_digit());
    let (days, rest) = match t.split_once('-') {
        Some((d, r)) => (Some(d), r),
        None => (None, t),
    };
    let parts: Vec<&str> = rest.split(':').collect();
    days.is_none_or(num) && parts.len() <= 3 && parts.iter().all(|p| num(p))
}

/// A job name from the output stem: letters, digits, `_`, `-` and `.` kept, anything else `_`
/// (a scene file's name may hold characters a batch script must not).
fn job_name(stem: &str) -> String {
    stem.chars()
        .map(|c| match c {
            c if c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.') => c,
            _ => '_',
        })
        .collect()
}

/// Shell-quotes a word for a batch script.
fn sh(word: &str) -> String {
    format!("'{}'", word.replace('\'', r"'\''"))
}

/// The two batch scripts.
fn batch_scripts(m: &Manifest, dir: &Path, a: &SlurmArgs, n_tasks: usize) -> (String, String) {
    let mut common = Vec::new();
    if let Some(p) = &a.partition {
        common.push(format!("--partition={p}"));
    }
    if let Some(t) = &a.time_limit {
        common.push(format!("--time={t}"));
    }
    if let Some(mem) = &a.mem {
        common.push(format!("--mem={mem}"));
    }
    if let Some(c) = a.cpus_per_task {
        common.push(format!("--cpus-per-task={c}"));
    }
    common.extend(a.sbatch.iter().cloned());
    let header = |name: &str, extra: &[String]| {
        let mut s = "#!/bin/bash\n".to_string();
        s += &format!(
            "# Written by `aleph farm slurm` for {}.\n",
            m.job.scene.path.display().to_string().escape_debug()
        );
        s += &format!("#SBATCH --job-name=aleph-{name}-{}\n", job_name(&m.stem));
        for o in extra.iter().chain(&common) {
            s += &format!("#SBATCH {o}\n");
        }
        s
    };
    let logs = dir.join("logs");
    let render = header(
        "render",
        &[
            format!("--array=0-{}", n_tasks - 1),
            "--requeue".into(),
            "--open-mode=append".into(),
            format!("--output={}", logs.join("task-%a.out").display()),
        ],
    ) + &format!(
        "# One task per frame{} (per chunk of frames that reuse each other, with reuse \
         across frames); a task whose outputs exist does nothing.\n\
         exec {} farm task {} --index \"$SLURM_ARRAY_TASK_ID\"\n",
        match (m.split > 1, m.tiles) {
            (false, _) => "",
            (true, false) => " and sample part",
            (true, true) => " and row tile",
        },
        sh(&m.aleph.display().to_string()),
        sh(&dir.display().to_string()),
    );
    let finish = header(
        "finish",
        &[format!("--output={}", logs.join("finish-%j.out").display())],
    ) + &format!(
        "exec {} farm finish {}\n",
        sh(&m.aleph.display().to_string()),
        sh(&dir.display().to_string()),
    );
    (render, finish)
}

fn slurm(a: SlurmArgs) -> anyhow::Result<ExitCode> {
    check_slurm_values(&a)?;
    if a.split_samples == 0 || a.split_tiles == 0 {
        bail!("--split-samples and --split-tiles must be at least 1");
    }
    let absolute = |p: &Path| std::path::absolute(p).with_context(|| p.display().to_string());
    let scene = absolute(&a.scene.clone().unwrap_or_else(default_scene))?;
    let dir = absolute(&a.output)?;
    let aleph = match &a.aleph {
        Some(p) => absolute(p)?,
        None => std::env::current_exe().context("the aleph binary's path")?,
    };
    for (what, p) in [("-o", &dir), ("the scene", &scene), ("--aleph", &aleph)] {
        let Some(text) = p.to_str() else {
            bail!(
                "{what} {:?}: a path that is not UTF-8 cannot go into the farm's manifest",
                p
            );
        };
        if text.chars().any(char::is_control) {
            bail!(
                "{what} {:?}: a path with control characters cannot go into a batch script",
                p
            );
        }
    }
    let stem = scene
        .file_stem()
        .filter(|s| *s != "scene")
        .or_else(|| scene.parent().and_then(|p| p.file_name()))
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_else(|| "render".into());
    let desc = aleph::scene::SceneDescription::read(&scene)?;
    let frames = match (a.frames, &desc.animation) {
        (Some((x, y)), _) => Some([x, y]),
        (None, Some(anim)) => Some(anim.frames),
        (None, None) => None,
    };
    let options = render_options(&scene, &a.render)?;
    let job = options.job()?;
    let [w, h] = job.scene.resolution.unwrap_or(desc.camera.resolution);
    let m = Manifest {
        aleph,
        stem,
        frames,
        split: a.split_samples.max(a.split_tiles),
        tiles: a.split_tiles > 1,
        tile_margin: options.tile_margin,
        runs_from: desc.animation.as_ref().map(|anim| anim.frames[0]),
        pixels: w as u64 * h as u64,
        job,
    };
    check_render(&m)?;
    let n_tasks = m.tasks().len();
    std::fs::create_dir_all(dir.join("logs"))
        .with_context(|| format!("{}: cannot create the farm directory", dir.display()))?;
    let (render_sh, finish_sh) = batch_scripts(&m, &dir, &a, n_tasks);
    let mut out = aleph::output::AtomicOutputs::new();
    let manifest = toml::to_string(&m).context("writing the manifest")?;
    for (name, text) in [
        ("farm.toml", manifest),
        ("render.sbatch", render_sh),
        ("finish.sbatch", finish_sh),
    ] {
        let path = dir.join(name);
        out.stage(&path, |w| {
            use std::io::Write;
            w.write_all(text.as_bytes())
                .map_err(|source| aleph::output::OutputError::Io {
                    path: path.clone(),
                    source,
                })
        })?;
    }
    out.commit()?;
    println!(
        "{}: {n_tasks} tasks ({} frame ranges × {} {}) -> {}/render.sbatch, finish.sbatch",
        m.job.scene.path.display(),
        m.frame_ranges().len(),
        m.split,
        if m.tiles { "tiles" } else { "parts" },
        dir.display()
    );
    if !a.submit {
        println!(
            "submit with: jid=$(sbatch --parsable {0}/render.sbatch) && sbatch \
             --dependency=afterok:${{jid%%;*}} {0}/finish.sbatch",
            dir.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    submit(&dir, a.wait)
}

/// Runs sbatch with `args`; returns its stdout.
fn sbatch(args: &[String]) -> anyhow::Result<String> {
    let out = Command::new("sbatch")
        .args(args)
        .output()
        .context("cannot run sbatch (is Slurm installed and on PATH?)")?;
    if !out.status.success() {
        bail!(
            "sbatch {} failed ({}): {}",
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// Submits the array, then the finishing job after it.
fn submit(dir: &Path, wait: bool) -> anyhow::Result<ExitCode> {
    std::fs::write(dir.join("logs/submitted"), format!("{:.3}\n", now_s()))
        .with_context(|| format!("{}: cannot record the submission", dir.display()))?;
    let d = |n: &str| dir.join(n).display().to_string();
    let out = sbatch(&["--parsable".into(), d("render.sbatch")])?;
    let array = out.split(';').next().unwrap_or_default().to_string();
    println!("submitted job array {array}");
    let mut args = vec![
        "--parsable".into(),
        format!("--dependency=afterok:{array}"),
        "--kill-on-invalid-dep=yes".into(),
    ];
    if wait {
        args.push("--wait".into());
    }
    args.push(d("finish.sbatch"));
    let out = sbatch(&args)?;
    println!(
        "submitted finishing job {}{}",
        out.split(';').next().unwrap_or_default(),
        if wait { ", which has ended" } else { "" }
    );
    Ok(ExitCode::SUCCESS)
}

/// Threads a Slurm task was given, if any.
fn slurm_threads() -> Option<usize> {
    std::env::var("SLURM_CPUS_PER_TASK")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&n| n > 0)
}

fn task(a: TaskArgs) -> anyhow::Result<ExitCode> {
    let dir = std::path::absolute(&a.dir).context("the farm directory")?;
    let m = Manifest::read(&dir)?;
    let tasks = m.tasks();
    let Some(&t) = tasks.get(a.index) else {
        bail!(
            "{}: task {} does not exist (the farm has tasks 0-{})",
            dir.join("farm.toml").display(),
            a.index,
            tasks.len().saturating_sub(1)
        );
    };
    let what = match (t.frames, t.part) {
        (Some([f, _]), Some((p, k))) => format!("frame {f}, part {p}/{k}"),
        (Some([f, g]), None) if f == g => format!("frame {f}"),
        (Some([f, g]), None) => format!("frames {f}-{g}"),
        (None, Some((p, k))) => format!("part {p}/{k}"),
        (None, None) => "the image".into(),
    };
    if m.task_done(&dir, t) {
        println!("task {}: {what} already rendered, skipped", a.index);
        return Ok(ExitCode::SUCCESS);
    }
    let start = now_s();
    let job = m.task_job(&dir, t);
    let code = with_threads(slurm_threads(), move || render::run_job(&job))??;
    let end = now_s();
    let timing = dir.join(format!("logs/task-{}.time", a.index));
    std::fs::write(&timing, format!("{start:.3} {end:.3}\n"))
        .with_context(|| format!("{}: cannot write", timing.display()))?;
    println!("task {}: {what} rendered in {:.2} s", a.index, end - start);
    Ok(code)
}

/// Start and end times that the tasks recorded.
fn task_times(dir: &Path, n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .filter_map(|i| std::fs::read_to_string(dir.join(format!("logs/task-{i}.time"))).ok())
        .filter_map(|s| {
            let mut it = s.split_whitespace().map(|v| v.parse::<f64>().ok());
            Some((it.next()??, it.next()??))
        })
        .collect()
}

/// Sorted task indices as ranges ("0-3, 7, 9-12"), at most `max` of them, then how many
/// more ranges there are: a million missing tasks is one line, not every index.
fn index_ranges(sorted: &[usize], max: usize) -> String {
    let mut ranges: Vec<(usize, usize)> = Vec::new();
    for &i in sorted {
        match ranges.last_mut() {
            Some((_, b)) if *b + 1 == i => *b = i,
            _ => ranges.push((i, i)),
        }
    }
    let shown: Vec<String> = ranges
        .iter()
        .take(max)
        .map(|&(a, b)| {
            if a == b {
                a.to_string()
            } else {
                format!("{a}-{b}")
            }
        })
        .collect();
    let more = ranges.len().saturating_sub(max);
    if more > 0 {
        format!("{} and {more} more ranges", shown.join(", "))
    } else {
        shown.join(", ")
    }
}

fn finish(a: FinishArgs) -> anyhow::Result<ExitCode> {
    let start = now_s();
    let clock = Instant::now();
    let dir = std::path::absolute(&a.dir).context("the farm directory")?;
    let m = Manifest::read(&dir)?;
    let tasks = m.tasks();
    let missing: Vec<usize> = (0..tasks.len())
        .filter(|&i| !m.task_done(&dir, tasks[i]))
        .collect();
    if !missing.is_empty() {
        bail!(
            "{}: {} of {} tasks have no outputs yet: {}",
            dir.display(),
            missing.len(),
            tasks.len(),
            index_ranges(&missing, 20)
        );
    }
    let merge_start = Instant::now();
    if m.split > 1 {
        merge_frames(&m, &dir)?;
    }
    let merge_s = merge_start.elapsed().as_secs_f64();
    if let Some([first, last]) = m.frames {
        let stem = dir.join(&m.stem);
        write_preview(&m, &stem, first, last)?;
    }
    report(&dir, tasks.len(), start, merge_s, clock);
    Ok(ExitCode::SUCCESS)
}

/// Merges every frame's parts into its outputs, then removes the parts.
fn merge_frames(m: &Manifest, dir: &Path) -> anyhow::Result<()> {
    for frame in m.frame_list() {
        let whole = Task {
            frames: frame.map(|f| [f, f]),
            part: None,
        };
        if m.task_outputs(dir, whole).iter().all(|p| p.exists()) {
            continue;
        }
        let stem = m.frame_stem(dir, frame);
        let parts: Vec<PathBuf> = (1..=m.split)
            .map(|p| part_path(&stem, p, m.split, m.tiles))
            .collect();
        merge::run(MergeArgs::new(
            parts.clone(),
            dir.join(&m.stem),
            slurm_threads(),
        ))?;
        for p in parts {
            std::fs::remove_file(&p).with_context(|| format!("{}: cannot remove", p.display()))?;
        }
    }
    Ok(())
}

/// Writes the sequence's animated preview and filmstrip from its frames' PNGs.
fn write_preview(m: &Manifest, stem: &Path, first: i64, last: i64) -> anyhow::Result<()> {
    let mut displays = Vec::new();
    let (mut w, mut h) = (0, 0);
    for f in first..=last {
        let png = with_ext(&numbered(stem, f), "png");
        let img = image::open(&png)
            .with_context(|| format!("{}: cannot read", png.display()))?
            .to_rgb8();
        (w, h) = (img.width() as usize, img.height() as usize);
        displays.push((f, img.into_raw()));
    }
    let scene = aleph::scene::SceneDescription::read(&m.job.scene.path)?;
    let fps = scene
        .animation
        .map(|a| a.fps)
        .context("the scene is not animated")?;
    let (preview, strip) = write_sequence_outputs(stem, &displays, w, h, fps)?;
    println!("{}, {}", preview.display(), strip.display());
    Ok(())
}

/// Prints where the wall time went: queueing, rendering, merging.
fn report(dir: &Path, n: usize, finish_start: f64, merge_s: f64, clock: Instant) {
    let times = task_times(dir, n);
    let submitted = std::fs::read_to_string(dir.join("logs/submitted"))
        .ok()
        .and_then(|s| s.trim().parse::<f64>().ok());
    let first_start = times.iter().map(|t| t.0).fold(f64::INFINITY, f64::min);
    let last_end = times.iter().map(|t| t.1).fold(f64::NEG_INFINITY, f64::max);
    let busy: f64 = times.iter().map(|t| t.1 - t.0).sum();
    let mut words = vec![format!("{} of {n} tasks timed", times.len())];
    if let Some(s) = submitted.filter(|_| !times.is_empty()) {
        words.push(format!(
            "queued {:.2} s before the first task",
            first_start - s
        ));
    }
    if !times.is_empty() {
        words.push(format!(
            "rendering {:.2} s from first start to last end ({busy:.2} task-s)",
            last_end - first_start
        ));
        words.push(format!(
            "{:.2} s from the last task to this job",
            finish_start - last_end
        ));
    }
    words.push(format!("merging {merge_s:.2} s"));
    words.push(format!("finishing {:.2} s", clock.elapsed().as_secs_f64()));
    if let Some(s) = submitted {
        words.push(format!("{:.2} s from submission", now_s() - s));
    }
    println!("{}: {}", dir.display(), words.join(", "));
}
