//! Command-line interface: `aleph render`, … Errors print their whole cause chain on stderr and
//! exit with status 2 (status 1 is reserved for "a visible difference was found" by `diff`).

mod diff;
mod farm;
mod merge;
mod render;
mod speedup;
mod tonemap;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// aleph: a physically based path tracer that renders only what a person can see.
#[derive(Parser, Debug)]
#[command(name = "aleph", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene to OUT.exr (linear radiance + spp layer) and OUT.png (display image).
    Render(render::RenderArgs),
    /// Compare two images with aleph's visual model: exit 0 if no difference is visible, 1 if
    /// one is, 2 on an error.
    Diff(diff::DiffArgs),
    /// Tone map an HDR image (EXR, HDR) to PNG or display-linear EXR, or to a labelled contact
    /// sheet of every operator.
    Tonemap(tonemap::TonemapArgs),
    /// Benchmark perceptual sampling against uniform and variance sampling at equal quality
    /// (FLIP, aleph's metric, relMSE) against a cached high-spp reference.
    Speedup(speedup::SpeedupArgs),
    /// Sum the partial films of one render (`render --part I/K`, from several machines) into the
    /// files the render writes on one machine, bit for bit.
    Merge(merge::MergeArgs),
    /// Split a render across a cluster: Slurm job arrays (frames, sample parts), the tasks
    /// they run, and the job that merges the results.
    Farm(farm::FarmArgs),
}

/// Exit status for errors (bad input, I/O failures).
pub const EXIT_ERROR: u8 = 2;

pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if e.kind() == clap::error::ErrorKind::InvalidUtf8 => {
            // clap's message names no argument; name the first that is not text.
            eprintln!("aleph: error: {}", non_utf8_argument());
            return ExitCode::from(EXIT_ERROR);
        }
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Render(args) => render::run(args),
        Command::Merge(args) => merge::run(args),
        Command::Farm(args) => farm::run(args),
        Command::Diff(args) => diff::run(args),
        Command::Tonemap(args) => tonemap::run(args),
        Command::Speedup(args) => speedup::run(args),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("aleph: error: {e:#}");
            ExitCode::from(EXIT_ERROR)
        }
    }
}

/// Names the first command-line argument that is not valid UTF-8 (lossily shown), and the
/// option it belongs to: that option takes text, not arbitrary bytes.
fn non_utf8_argument() -> String {
    let args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let Some(i) = args.iter().position(|a| a.to_str().is_none()) else {
        return "an argument is not valid UTF-8".into();
    };
    let shown = args[i].to_string_lossy();
    let option = match shown.split_once('=') {
        Some((flag, _)) if flag.starts_with("--") => Some(flag.to_string()),
        _ => args
            .get(i.wrapping_sub(1))
            .and_then(|a| a.to_str())
            .filter(|a| a.starts_with('-'))
            .map(str::to_string),
    };
    match option {
        Some(o) => format!("{o}: the value {shown:?} is not valid UTF-8 (this option takes text)"),
        None => format!("argument {i} ({shown:?}) is not valid UTF-8"),
    }
}

/// Parses `WxH` (also `W×H`).
pub fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X', '×'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, got {s:?}"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in {s:?}"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in {s:?}"))?;
    if w == 0 || h == 0 {
        return Err(format!("resolution must be at least 1x1, got {s:?}"));
    }
    Ok((w, h))
}

/// Most worker threads per core `--threads` accepts: more only adds stacks and contention (at
/// 100,000 threads the process ran 74 s and aborted allocating stacks).
const MAX_THREADS_PER_CORE: usize = 16;

/// The most worker threads `--threads` accepts here.
fn max_threads() -> usize {
    MAX_THREADS_PER_CORE * std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Runs `f` on a rayon pool of `threads` workers (all cores when `None`, at most
/// [`MAX_THREADS_PER_CORE`] per core).
pub fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> T + Send,
) -> anyhow::Result<T> {
    match threads {
        None => Ok(f()),
        Some(0) => anyhow::bail!("--threads must be at least 1"),
        Some(n) if n > max_threads() => anyhow::bail!(
            "--threads {n}: at most {} on this machine ({MAX_THREADS_PER_CORE} per core); the \
             image does not depend on it",
            max_threads()
        ),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build()?;
            Ok(pool.install(f))
        }
    }
}
