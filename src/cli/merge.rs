//! `aleph merge PART... -o OUT`: the parts of one render (sample parts or row tiles, from
//! several machines) summed into the files the render writes on one machine
//! ([`aleph::job::merge`]; the parts' records are compared as render jobs).

use super::render::strip_image_ext;
use super::with_threads;
use anyhow::Context;
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Partial films (`aleph render --part I/K` or `--tile I/K`), all K parts of one render, in
    /// any order.
    #[arg(required = true, value_name = "PART")]
    parts: Vec<PathBuf>,
    /// Output path without extension: writes OUT.exr and OUT.png (OUT.NNNN.* for a frame of a
    /// sequence), the files the render's command line writes on one machine.
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
    /// Worker threads (tone mapping and velocity; default: all cores).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
}

impl MergeArgs {
    /// Merge `parts` into `output` with `threads` workers.
    pub(super) fn new(parts: Vec<PathBuf>, output: PathBuf, threads: Option<usize>) -> MergeArgs {
        MergeArgs {
            parts,
            output,
            threads,
        }
    }
}

pub fn run(args: MergeArgs) -> anyhow::Result<ExitCode> {
    let start = Instant::now();
    let absolute = |p: &Path| std::path::absolute(p).with_context(|| p.display().to_string());
    let parts: Vec<PathBuf> = args
        .parts
        .iter()
        .map(|p| absolute(p))
        .collect::<Result<_, _>>()?;
    let stem = absolute(&strip_image_ext(&args.output))?;
    // Before reading any part: the output's directory exists.
    let mut exr = stem.clone().into_os_string();
    exr.push(".exr");
    aleph::output::check_output_location(Path::new(&exr))?;
    let r = with_threads(args.threads, move || aleph::job::merge(&parts, &stem))??;
    println!(
        "{}: merged {} {}, {:.1} spp, {}×{}, {:.2} s ({:.2} s reading and summing) -> {}, {} \
         ({})",
        r.scene.display(),
        r.parts,
        if r.tiles { "row tiles" } else { "sample parts" },
        r.mean_spp,
        r.size.0,
        r.size.1,
        start.elapsed().as_secs_f64(),
        r.read.as_secs_f64(),
        r.files.0.display(),
        r.files.1.display(),
        r.look
    );
    Ok(ExitCode::SUCCESS)
}
