//! The farm through a real Slurm cluster (ignored in the normal suite: it needs one).
//!
//! `.ci/run` starts a single-node cluster with `tests/slurm/cluster.sh start DIR` and runs
//! `SLURM_CONF=DIR/slurm.conf cargo test --release --test slurm -- --ignored`. The test submits
//! a 4-frame sequence split into chunks of frames that reuse each other (perceptual sampler) and a still split into 2 sample parts
//! (uniform) with `aleph farm slurm --submit --wait`, and checks every file against the same
//! command line rendered on one machine, byte for byte. It prints the finishing job's split of
//! the wall time (queueing, rendering, merging).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

fn aleph(args: &[&str], cwd: &Path) -> String {
    let out: Output = Command::new(env!("CARGO_BIN_EXE_aleph"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "aleph {args:?}: {text}");
    text
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_file())
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}

/// Submits `scene` with `farm` options through Slurm, renders the same on one machine, and
/// compares every file. Returns the finishing job's log.
fn through_slurm(root: &Path, name: &str, scene: &str, farm: &[&str], render: &[&str]) -> String {
    let reference = root.join(format!("{name}-single"));
    std::fs::create_dir_all(&reference).unwrap();
    let stem = reference.join(
        Path::new(scene)
            .parent()
            .unwrap()
            .file_name()
            .unwrap()
            .to_str()
            .unwrap(),
    );
    let mut args = vec!["render", scene, "-o", stem.to_str().unwrap()];
    args.extend(render);
    if let Some(i) = farm.iter().position(|a| *a == "--frames") {
        args.extend(["--frames", farm[i + 1]]);
    }
    aleph(&args, root);
    let dir = root.join(name);
    let mut args = vec!["farm", "slurm", scene, "-o", dir.to_str().unwrap()];
    args.extend(farm);
    args.extend(["--submit", "--wait", "--"]);
    args.extend(render);
    let text = aleph(&args, root);
    assert!(text.contains("which has ended"), "{text}");
    for f in files(&reference) {
        let (a, b) = (reference.join(&f), dir.join(&f));
        assert!(
            std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap_or_default(),
            "{name}: {f} differs from the single-machine render"
        );
    }
    let logs = dir.join("logs");
    let finish = files(&logs)
        .into_iter()
        .find(|f| f.starts_with("finish-"))
        .expect("the finishing job's log");
    std::fs::read_to_string(logs.join(finish)).unwrap()
}

#[test]
#[ignore = "needs a Slurm cluster: tests/slurm/cluster.sh start DIR, then SLURM_CONF=DIR/slurm.conf"]
fn farm_through_slurm_equals_one_machine() {
    assert!(
        std::env::var_os("SLURM_CONF").is_some(),
        "SLURM_CONF must name the test cluster's slurm.conf (tests/slurm/cluster.sh)"
    );
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let motion = repo("scenes/cornell-motion/scene.toml");
    let log = through_slurm(
        root,
        "sequence",
        motion.to_str().unwrap(),
        &["--frames", "14-17"],
        // Reusing frames with a window of 1, in chunks of 16 (0-15, 16-31): two tasks, 14-15
        // and 16-17, each rendering the base pass of the frame two before it and the frame
        // before it whole as warm-up.
        &[
            "--resolution",
            "64x64",
            "--spp",
            "16",
            "--reuse-window",
            "1",
        ],
    );
    println!("4-frame sequence reusing frames, split into chunks: {log}");
    let still = repo("scenes/cornell-box/scene.toml");
    let still = still.to_str().unwrap();
    let opts = [
        "--resolution",
        "128x128",
        "--spp",
        "64",
        "--sampler",
        "uniform",
    ];
    let log = through_slurm(root, "still", still, &["--split-samples", "2"], &opts);
    println!("still, 2 sample parts: {log}");
    // A resubmission finds everything done: every task skips.
    let out = root.join("still");
    let mut args = vec!["farm", "slurm", still, "-o", out.to_str().unwrap()];
    args.extend(["--split-samples", "2", "--submit", "--wait", "--"]);
    args.extend(opts);
    let again = aleph(&args, root);
    assert!(again.contains("which has ended"), "{again}");
    for i in 0..2 {
        let log = std::fs::read_to_string(root.join(format!("still/logs/task-{i}.out"))).unwrap();
        assert!(log.contains("already rendered, skipped"), "{log}");
    }
}
