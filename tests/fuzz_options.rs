//! The command line's option space (issue 35): every option that takes a value, of `render`,
//! `tonemap`, `diff`, `merge`, `speedup` and `farm slurm`, read from the subcommand's own `--help` (so a new
//! option is fuzzed without editing this file), given each of a list of values that break
//! numerics and parsers (0, negative, NaN, ±inf, 1e308, 2³², 2⁶⁴, empty, words, malformed
//! pairs) and, for the farm script writer, bytes that would inject commands into a batch script.
//! Each case runs the real CLI in a process of its own. The invariants:
//! - no panic and no abort: the exit status is 0 or 2 (a located error);
//! - no hang: the case ends within [`BOUND`];
//! - an error names its source: the flag (`--spp`), as clap and the job's checks do;
//! - nothing is written outside the asked location: the scratch directory holds only the
//!   outputs the case asked for, and the bundled scene's folder is unchanged;
//! - a farm script that was written parses (`bash -n`) and, run as Slurm would run its task,
//!   executes nothing it was not meant to (no `PWNED` file appears).

use crate::util::{repo, tempdir};
use std::ffi::OsString;
use std::os::unix::ffi::OsStringExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The longest a case may take: tiny images at 2 spp finish in well under a second.
const BOUND: Duration = Duration::from_secs(60);

/// Values that break numeric options and parsers.
const NUMERIC: &[&str] = &[
    "0",
    "-1",
    "-0",
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-308",
    "4294967296",
    "18446744073709551616",
    "",
    "x",
    "0x0",
    "99999x99999",
    "1-0",
    "3/2",
    "0/0",
];

/// Values that would inject commands into a shell script, and bytes that are not text.
fn injections() -> Vec<OsString> {
    let mut v: Vec<OsString> = [
        "a\ntouch PWNED",
        "a\rtouch PWNED",
        "$(touch PWNED)",
        "`touch PWNED`",
        "a;touch PWNED",
        "a' ; touch PWNED ; '",
        "a\" ; touch PWNED ; \"",
        "a b",
        "a\u{1}b",
        "--x=$(touch PWNED)",
    ]
    .iter()
    .map(OsString::from)
    .collect();
    v.push(OsString::from_vec(vec![0xff, b'a', 0xfe]));
    v
}

/// The options of `aleph SUB` that take a value, from its `--help`.
fn value_options(sub: &[&str]) -> Vec<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(sub)
        .arg("--help")
        .output()
        .unwrap();
    let help = String::from_utf8(out.stdout).unwrap();
    let mut opts = Vec::new();
    for line in help.lines() {
        let t = line.trim_start();
        let t = t.strip_prefix("-o, ").unwrap_or(t);
        let Some(rest) = t.strip_prefix("--") else {
            continue;
        };
        let name: String = rest
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
            .collect();
        let after = &rest[name.len()..];
        if after.starts_with(" <") || after.starts_with("=<") || after.starts_with(" [<") {
            opts.push(format!("--{name}"));
        }
    }
    assert!(
        opts.len() >= 2,
        "no options found in `aleph {sub:?} --help`"
    );
    opts
}

/// What one case ran and how it ended.
struct Outcome {
    code: Option<i32>,
    stderr: String,
    elapsed: Duration,
}

/// Runs the CLI in `cwd` with `args`, killing it past [`BOUND`].
fn run(cwd: &Path, args: &[OsString]) -> Outcome {
    let t = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .current_dir(cwd)
        .args(args)
        .env("RAYON_NUM_THREADS", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = Vec::new();
        std::io::Read::read_to_end(&mut stderr, &mut s).ok();
        String::from_utf8_lossy(&s).to_string()
    });
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if t.elapsed() > BOUND {
            child.kill().ok();
            child.wait().ok();
            break None;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    Outcome {
        code: status.and_then(|s| s.code()),
        stderr: reader.join().unwrap(),
        elapsed: t.elapsed(),
    }
}

/// Every file under `dir`, relative to it, sorted.
fn tree(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p.clone());
            }
            out.push(p.strip_prefix(dir).unwrap().to_path_buf());
        }
    }
    out.sort();
    out
}

/// One subcommand's cases: `base` are its fixed arguments (with `{out}` for the output
/// location), `defaults` the options the base gives that a fuzzed option replaces, `outputs`
/// the file names a successful case may leave in the working directory.
struct Sub<'a> {
    name: &'a [&'a str],
    base: Vec<OsString>,
    defaults: Vec<(&'a str, &'a str)>,
    /// Arguments after the fuzzed option (`farm slurm`'s `-- RENDER OPTIONS`).
    tail: Vec<OsString>,
    outputs: &'a [&'a str],
}

fn os(v: &[&str]) -> Vec<OsString> {
    v.iter().map(OsString::from).collect()
}

/// Runs every option of `sub` with every value; returns the broken invariants.
fn fuzz_sub(sub: &Sub, values: &[OsString], work: &Path, scene_dir: &Path) -> Vec<String> {
    let scene_files = tree(scene_dir);
    let mut failures = Vec::new();
    for opt in value_options(sub.name) {
        for value in values {
            let mut args: Vec<OsString> = os(sub.name);
            args.extend(sub.base.iter().cloned());
            for (flag, v) in &sub.defaults {
                if *flag != opt {
                    args.extend(os(&[flag, v]));
                }
            }
            let mut joined = OsString::from(&opt);
            joined.push("=");
            joined.push(value);
            args.push(joined);
            args.extend(sub.tail.iter().cloned());
            let o = run(work, &args);
            let case = format!("aleph {args:?}");
            let why = broken(&o, &opt, value, work, sub.outputs).or_else(|| {
                (sub.name[0] == "farm")
                    .then(|| check_farm_scripts(work))
                    .flatten()
            });
            if let Some(why) = why {
                failures.push(format!("{case}: {why}"));
            }
            if tree(scene_dir) != scene_files {
                failures.push(format!("{case}: wrote into the scene's folder"));
            }
            std::fs::remove_dir_all(work).unwrap();
            std::fs::create_dir(work).unwrap();
        }
    }
    failures
}

/// The invariant a case broke, if any. A successful case may leave files whose names start
/// with one of `outputs` or with the value it gave (an output option's file).
fn broken(
    o: &Outcome,
    opt: &str,
    value: &OsString,
    work: &Path,
    outputs: &[&str],
) -> Option<String> {
    let e = &o.stderr;
    if o.elapsed > BOUND || o.code.is_none() {
        return Some(format!(
            "no exit within {BOUND:?} (or killed by a signal): {e}"
        ));
    }
    if !matches!(o.code, Some(0 | 2)) || e.contains("panicked") {
        return Some(format!("exit {:?}: {e}", o.code));
    }
    // The source is the flag (or -o for --output), or for a path the path itself.
    let shown = value.to_string_lossy();
    let named = e.contains(opt)
        || (opt == "--output" && e.contains("-o "))
        || (shown.len() >= 3 && e.contains(shown.as_ref()));
    if o.code == Some(2) && !named {
        return Some(format!("the error does not name {opt}: {e}"));
    }
    let stray: Vec<_> = tree(work)
        .into_iter()
        .filter(|p| {
            let top = p.components().next().unwrap().as_os_str();
            let name = top.to_string_lossy();
            let first = Path::new(value).components().next();
            let asked = !value.is_empty()
                && (top.as_encoded_bytes().starts_with(value.as_encoded_bytes())
                    || first.is_some_and(|c| c.as_os_str() == top));
            !asked && !outputs.iter().any(|o| name.starts_with(o))
        })
        .collect();
    if !stray.is_empty() {
        return Some(format!("wrote {stray:?}"));
    }
    if tree(work).iter().any(|p| p.ends_with("PWNED")) {
        return Some("a command was injected".into());
    }
    None
}

/// Every farm directory a case wrote: its scripts parse, and running the first array task as
/// Slurm would executes no injected command.
fn check_farm_scripts(work: &Path) -> Option<String> {
    let farm = work.join("farm");
    if !farm.join("render.sbatch").exists() {
        return None;
    }
    for script in ["render.sbatch", "finish.sbatch"] {
        let ok = Command::new("bash")
            .arg("-n")
            .arg(farm.join(script))
            .status()
            .unwrap()
            .success();
        if !ok {
            return Some(format!("{script} does not parse"));
        }
    }
    Command::new("bash")
        .arg(farm.join("render.sbatch"))
        .current_dir(work)
        .env("SLURM_ARRAY_TASK_ID", "0")
        .output()
        .unwrap();
    tree(work)
        .iter()
        .any(|p| p.ends_with("PWNED"))
        .then(|| "a command was injected".into())
}

#[test]
fn fuzz_command_line_options() {
    let d = tempdir();
    let work = d.path().join("work");
    std::fs::create_dir(&work).unwrap();
    let scene_dir = repo("scenes/cornell-box");
    let scene = OsString::from(scene_dir.join("scene.toml"));
    let img = d.path().join("in.exr");
    std::fs::copy(repo("tests/data/cornell_mitsuba_32.exr"), &img).unwrap();
    let img = OsString::from(img);
    // A partial film for merge.
    let part = d.path().join("p");
    let made = run(
        d.path(),
        &[
            os(&["render"]),
            vec![scene.clone()],
            os(&["--resolution", "8x8", "--sampler", "uniform", "--spp", "2"]),
            os(&["--part", "1/1", "-o"]),
            vec![part.clone().into()],
        ]
        .concat(),
    );
    assert_eq!(made.code, Some(0), "{}", made.stderr);
    let part = OsString::from(d.path().join("p.part-1-of-1.exr"));
    let numeric = os(NUMERIC);
    let mut farm_values = numeric.clone();
    farm_values.extend(injections());
    let subs = [
        Sub {
            name: &["render"],
            base: vec![scene.clone()],
            defaults: vec![("--resolution", "8x6"), ("--spp", "2"), ("--output", "out")],
            tail: vec![],
            outputs: &["out"],
        },
        Sub {
            name: &["tonemap"],
            base: vec![img.clone(), "out.png".into()],
            defaults: vec![],
            tail: vec![],
            outputs: &["out"],
        },
        Sub {
            name: &["diff"],
            base: vec![img.clone(), img.clone()],
            defaults: vec![],
            tail: vec![],
            outputs: &[],
        },
        Sub {
            name: &["merge"],
            base: vec![part],
            defaults: vec![("--output", "out")],
            tail: vec![],
            outputs: &["out"],
        },
        Sub {
            name: &["speedup"],
            base: vec![scene.clone()],
            defaults: vec![
                ("--resolution", "8x6"),
                ("--reference-spp", "16"),
                ("--budgets", "4,8"),
                ("--output", "sweep"),
            ],
            tail: vec![],
            outputs: &["sweep"],
        },
        Sub {
            name: &["farm", "slurm"],
            base: vec![scene],
            defaults: vec![("--output", "farm")],
            tail: os(&["--", "--resolution", "8x6", "--spp", "2"]),
            outputs: &["farm"],
        },
    ];
    let mut failures = Vec::new();
    let t = Instant::now();
    let mut cases = 0;
    for sub in &subs {
        let values = if sub.name[0] == "farm" {
            &farm_values
        } else {
            &numeric
        };
        cases += value_options(sub.name).len() * values.len();
        failures.extend(fuzz_sub(sub, values, &work, &scene_dir));
    }
    eprintln!(
        "option fuzz: {cases} cases in {:.1} s",
        t.elapsed().as_secs_f64()
    );
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
