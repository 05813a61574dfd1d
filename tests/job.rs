//! The render-job layer through the library alone: a sequence, sample parts and row tiles
//! rendered and merged without the CLI give the pixels the CLI gave before the render job
//! existed (the golden hashes), and job records are versioned and compared by content.

use crate::golden::{GOLDEN, hash_outputs};
use crate::util::{repo, tempdir};
use aleph::adaptive::Criterion;
use aleph::job::{self, FrameDone, JobError, Observer, RenderJob, Split};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

fn golden(name: &str) -> u64 {
    GOLDEN.iter().find(|(n, _)| *n == name).unwrap().1
}

/// The golden cases' small still: 40×30, depth 4.
fn small(scene: &str) -> RenderJob {
    let mut job = RenderJob::new(repo(scene));
    job.scene.resolution = Some([40, 30]);
    job.scene.max_depth = Some(4);
    job
}

/// Counts the frames an observer is shown.
#[derive(Default)]
struct Frames(AtomicUsize);

impl Observer for Frames {
    fn frame_done(&self, d: &FrameDone<'_>) {
        assert!(d.result.film.total_samples() > 0);
        self.0.fetch_add(1, Ordering::Relaxed);
    }
}

#[test]
fn the_stops_converged_fraction_defaults_by_rule_denoiser_and_sequence() {
    // A still's perceptual stop ends at 80 % of the pixels; the denoised stop, a sequence's
    // frames and Cycles' rule keep 99.5 %, where the lower fraction was not measured to pay;
    // a fraction the job names is used as it is everywhere.
    // (The denoised case needs a `--features denoise` build, whose CI step runs this test.)
    use aleph::adaptive::{Criterion, DEFAULT_CONVERGED_FRACTION};
    let fraction = |job: &RenderJob| {
        let scene = job.load_scene().unwrap();
        job.settings(&scene, None).unwrap().0.converged_fraction
    };
    let still = small("scenes/cornell-box/scene.toml");
    let mut denoised = still.clone();
    denoised.output.denoise = true;
    let mut variance = still.clone();
    variance.criterion = Criterion::Variance;
    let sequence = small("scenes/cornell-motion/scene.toml");
    assert_eq!(DEFAULT_CONVERGED_FRACTION, 0.8);
    assert_eq!(fraction(&still), 0.8);
    if aleph::denoise::AVAILABLE {
        assert_eq!(fraction(&denoised), 0.8);
    }
    assert_eq!(fraction(&variance), 0.995);
    assert_eq!(fraction(&sequence), job::KEPT_CONVERGED_FRACTION);
    let named = [still, variance, sequence]
        .into_iter()
        .chain(aleph::denoise::AVAILABLE.then_some(denoised));
    for mut j in named {
        j.sampling.converged_fraction = Some(0.7);
        assert_eq!(fraction(&j), 0.7);
    }
}

#[test]
fn a_sequence_renders_through_the_library() {
    let dir = tempdir();
    let mut job = RenderJob::new(repo("scenes/cornell-motion/scene.toml"));
    job.frames = Some([2, 4]);
    job.scene.resolution = Some([32, 24]);
    job.budget.spp = Some(8.0);
    job.sampling.steer_from_spp = Some(0.0);
    job.sampling.min_spp = 4;
    job.sampling.reuse_window = Some(0);
    job.output.stem = Some(dir.path().join("seq"));
    let frames = Frames::default();
    let report = job::run(&job, &frames).unwrap();
    assert!(matches!(report, job::JobReport::Sequence(_)));
    assert_eq!(frames.0.load(Ordering::Relaxed), 3);
    assert_eq!(
        hash_outputs(dir.path()).0,
        golden("cornell-motion sequence")
    );
    // Without an output stem nothing is written, and the frames still reach the observer.
    let files = || std::fs::read_dir(dir.path()).unwrap().count();
    let before = files();
    job.output.stem = None;
    let frames = Frames::default();
    job::run(&job, &frames).unwrap();
    assert_eq!(frames.0.load(Ordering::Relaxed), 3);
    assert_eq!(files(), before);
}

/// Renders every part of `job` (split `make(i)` for i in 1..=k) into `dir`; returns the files.
fn render_parts(job: &RenderJob, k: u32, make: impl Fn(u32) -> Split, dir: &Path) -> Vec<PathBuf> {
    (1..=k)
        .map(|i| {
            let mut part = job.clone();
            part.split = Some(make(i));
            match job::run(&part, &()).unwrap() {
                job::JobReport::Part(r) => r.path,
                job::JobReport::Tile(r) => r.path,
                other => panic!("not a part: {other:?}"),
            }
        })
        .inspect(|p| assert!(p.starts_with(dir)))
        .collect()
}

#[test]
fn sample_parts_and_tiles_render_and_merge_through_the_library() {
    let dir = tempdir();
    let mut job = small("scenes/cornell-box/scene.toml");
    job.criterion = Criterion::Uniform;
    job.budget.spp = Some(8.0);
    job.output.stem = Some(dir.path().join("p"));
    let mut parts = render_parts(&job, 3, |index| Split::Part { index, count: 3 }, dir.path());
    parts.reverse();
    job::merge(&parts, &dir.path().join("m")).unwrap();
    assert_eq!(
        hash_outputs(dir.path()).0,
        golden("cornell-box parts merged")
    );

    let dir = tempdir();
    let mut job = small("scenes/cornell-box/scene.toml");
    job.budget.spp = Some(16.0);
    job.sampling.steer_from_spp = Some(0.0);
    job.sampling.min_spp = 4;
    job.output.stem = Some(dir.path().join("t"));
    let tile = |index| Split::Tile {
        index,
        count: 2,
        margin: 4,
    };
    let tiles = render_parts(&job, 2, tile, dir.path());
    job::merge(&tiles, &dir.path().join("m")).unwrap();
    assert_eq!(
        hash_outputs(dir.path()).0,
        golden("cornell-box tiles merged")
    );
}

#[test]
fn records_round_trip_and_refuse_other_versions_and_foreign_keys() {
    let mut job = small("scenes/cornell-box/scene.toml");
    job.frames = Some([1, 1]);
    job.split = Some(Split::Tile {
        index: 1,
        count: 2,
        margin: 3,
    });
    job.display.operator = Some(perception::tmo::Operator::Wrp);
    let text = job.to_toml();
    let origin = Path::new("x.exr");
    assert_eq!(RenderJob::from_toml(&text, origin).unwrap(), job);
    let old = text.replace("version = 1", "version = 7");
    let e = RenderJob::from_toml(&old, origin).unwrap_err().to_string();
    assert!(e.starts_with("x.exr: ") && e.contains("version 7"), "{e}");
    let foreign = format!("{text}\nfavourite_colour = \"red\"\n");
    let e = RenderJob::from_toml(&foreign, origin)
        .unwrap_err()
        .to_string();
    assert!(e.contains("favourite_colour"), "{e}");
    let e = RenderJob::from_toml("cwd = \"/\"\nargs = []\n", origin).unwrap_err();
    assert!(matches!(e, JobError::Record { .. }) && e.to_string().contains("no version"));
}

/// Copies the bundled Cornell box into `dir`.
fn copy_box(dir: &Path) -> PathBuf {
    for f in [
        "scene.toml",
        "CornellBox-Original.obj",
        "CornellBox-Original.mtl",
    ] {
        std::fs::copy(repo("scenes/cornell-box").join(f), dir.join(f)).unwrap();
    }
    dir.join("scene.toml")
}

#[test]
fn parts_match_by_scene_content_not_path_and_refuse_other_renders() {
    // Part 1 from the repository's scene, part 2 from a copy elsewhere (another machine's
    // mount): one render.
    let dir = tempdir();
    let copy = tempdir();
    let mut job = small("scenes/cornell-box/scene.toml");
    job.criterion = Criterion::Uniform;
    job.budget.spp = Some(4.0);
    job.output.stem = Some(dir.path().join("p"));
    let part = |job: &RenderJob, index| {
        let mut j = job.clone();
        j.split = Some(Split::Part { index, count: 2 });
        job::run(&j, &()).unwrap();
    };
    part(&job, 1);
    let mut moved = job.clone();
    moved.scene.path = copy_box(copy.path());
    part(&moved, 2);
    let p = |i| dir.path().join(format!("p.part-{i}-of-2.exr"));
    job::merge(&[p(1), p(2)], &dir.path().join("m")).unwrap();
    // Another budget is another render: refused, naming the file and the difference.
    let mut other = job.clone();
    other.budget.spp = Some(6.0);
    part(&other, 2);
    let e = job::merge(&[p(1), p(2)], &dir.path().join("n"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("p.part-2-of-2.exr") && e.contains("spp = 6"),
        "{e}"
    );
    assert!(!dir.path().join("n.exr").exists());
    // A scene edited since the parts were rendered is refused.
    part(&moved, 1);
    part(&moved, 2);
    std::fs::write(
        copy.path().join("scene.toml"),
        std::fs::read_to_string(copy.path().join("scene.toml")).unwrap() + "\n# edited\n",
    )
    .unwrap();
    let e = job::merge(&[p(2), p(1)], &dir.path().join("n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("has changed"), "{e}");
}
