//! Running a job from Python: the render runs on a thread of its own with the GIL released,
//! while the calling thread waits for its events, calls the progress callback and checks for
//! signals. Ctrl-C (or an exception in the callback) raises a flag that the render's next
//! sample batch (a row of pixels) or pass sees; it then unwinds: staged output files are
//! removed (`aleph::output::AtomicOutputs`), frames already written stay, and the exception
//! reaches the caller.

use crate::job::RenderJob;
use aleph::adaptive::PassReport;
use aleph::job::{FrameDone, JobReport, Observer};
use aleph::output::ChannelData;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How often the waiting thread checks for signals and reports samples, at most.
const TICK: Duration = Duration::from_millis(100);
/// The least time between two `samples` progress reports.
const SAMPLES_EVERY: Duration = Duration::from_millis(250);
/// Worker threads per core `threads=` accepts at most (as the CLI's `--threads`).
const MAX_THREADS_PER_CORE: usize = 16;

/// A progress report, passed to the `progress` callback of `aleph.render`.
#[pyclass(module = "aleph", frozen, get_all)]
#[derive(Clone, Debug)]
pub struct Progress {
    /// `"samples"` (samples were taken), `"pass"` (a pass of the adaptive loop ended) or
    /// `"frame"` (a frame is done).
    pub kind: &'static str,
    /// The frame number in a sequence, else None.
    pub frame: Option<i64>,
    /// Samples taken since the previous report (`tqdm.update(p.samples)`).
    pub samples: u64,
    /// Samples taken so far by the whole job.
    pub total_samples: u64,
    /// Samples the job will take in all, when its budget says (spp × pixels × frames);
    /// None when it runs until converged.
    pub expected_samples: Option<u64>,
    /// For `"pass"`: the pass number (0 = the first, uniform pass).
    pub pass_index: Option<usize>,
    /// For `"pass"`: mean samples per pixel of the frame after the pass.
    pub mean_spp: Option<f64>,
    /// For `"pass"`: fraction of pixels whose error is below the threshold.
    pub converged_fraction: Option<f64>,
}

#[pymethods]
impl Progress {
    fn __repr__(&self) -> String {
        let opt = |v: Option<String>| v.unwrap_or_else(|| "None".into());
        format!(
            "Progress(kind={:?}, frame={}, samples={}, total_samples={}, expected_samples={}, \
             pass_index={}, mean_spp={}, converged_fraction={})",
            self.kind,
            opt(self.frame.map(|f| f.to_string())),
            self.samples,
            self.total_samples,
            opt(self.expected_samples.map(|n| n.to_string())),
            opt(self.pass_index.map(|n| n.to_string())),
            opt(self.mean_spp.map(|x| format!("{x:.3}"))),
            opt(self.converged_fraction.map(|x| format!("{x:.4}"))),
        )
    }
}

/// What the render thread tells the waiting thread.
enum Event {
    /// The scene is loaded; the job's expected samples, if its budget says.
    Loaded(Option<u64>),
    /// A pass ended.
    Pass(Option<i64>, PassReport),
    /// A frame is done.
    Frame(Option<i64>),
    /// The render thread ends.
    Done,
}

/// The payload of the unwinding that stops a cancelled render.
struct Cancelled;

/// One rendered frame, as the render thread keeps it.
struct FrameOut {
    index: Option<i64>,
    width: usize,
    height: usize,
    rgb: Vec<f32>,
    channels: Vec<(String, ChannelData)>,
    attributes: Vec<(String, String)>,
    display: Vec<u8>,
    stats: Vec<(&'static str, f64)>,
    samples: u64,
    passes: usize,
    stop: &'static str,
}

/// The render thread's observer: forwards events, counts samples, keeps the frames and
/// unwinds when cancelled.
struct Collector {
    events: Sender<Event>,
    cancel: Arc<AtomicBool>,
    samples: Arc<AtomicU64>,
    frames: Mutex<Vec<FrameOut>>,
    failure: Mutex<Option<PyErr>>,
}

impl Collector {
    fn check(&self) {
        if self.cancel.load(Ordering::Relaxed) {
            // resume_unwind skips the panic hook: nothing is printed.
            std::panic::resume_unwind(Box::new(Cancelled));
        }
    }
}

impl Observer for Collector {
    fn pass(&self, frame: Option<i64>, report: &PassReport) {
        self.check();
        let _ = self.events.send(Event::Pass(frame, *report));
    }

    fn samples(&self, n: u64) {
        self.samples.fetch_add(n, Ordering::Relaxed);
        self.check();
    }

    fn frame_done(&self, done: &FrameDone<'_>) {
        match frame_out(done) {
            Ok(f) => {
                let index = f.index;
                self.frames.lock().unwrap().push(f);
                let _ = self.events.send(Event::Frame(index));
            }
            Err(e) => {
                self.failure.lock().unwrap().get_or_insert(e);
            }
        }
        self.check();
    }
}

/// A frame's arrays: the radiance, the EXR's other channels (by name), the display image.
fn frame_out(done: &FrameDone<'_>) -> PyResult<FrameOut> {
    let (scene, r) = (done.scene, done.result);
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    // The image the outputs show: denoised when the job denoises, the raw render kept as
    // `Noisy.R/G/B` beside the denoiser's albedo and normal, as in the EXR.
    let rgb = done
        .denoised
        .map_or_else(|| r.film.mean_rgb(), |d| d.rgb.clone());
    let (mut channels, mut attributes) = aleph::deliver::exr_layers(scene, done.settings, r);
    if let Some(d) = done.denoised {
        aleph::deliver::denoise_layers(d, &mut channels, &mut attributes);
    }
    let (display, _) = aleph::deliver::display_image(&rgb, w, h, done.display)
        .map_err(|e| crate::OutputError::new_err(e.to_string()))?;
    let mut stats = vec![
        ("mean_spp", r.mean_spp()),
        ("converged_fraction", r.converged_fraction),
        ("wall_s", r.wall.as_secs_f64()),
        ("render_s", r.stats.wall.as_secs_f64()),
        ("decision_s", r.decision_time.as_secs_f64()),
    ];
    if let Some(reuse) = &r.reuse {
        stats.push(("reused_spp", reuse.mean_history_spp));
        stats.push(("reused_fraction", reuse.reused_fraction));
    }
    Ok(FrameOut {
        index: scene.animation.map(|_| scene.frame.index),
        width: w,
        height: h,
        rgb,
        channels,
        attributes,
        display,
        stats,
        samples: r.film.total_samples(),
        passes: r.passes.len(),
        stop: r.stop.describe(),
    })
}

/// Renders `job` (`aleph.render` and `RenderJob.render` call this): returns the frames (a list
/// of dicts of arrays) and the job's report (a dict).
///
/// # Errors
/// The job's exception (`SceneError`, `JobError`, `OutputError`), `KeyboardInterrupt` after
/// Ctrl-C, or the progress callback's own exception.
#[pyfunction]
#[pyo3(signature = (job, *, threads=None, progress=None))]
pub fn run<'py>(
    py: Python<'py>,
    job: &RenderJob,
    threads: Option<usize>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(Vec<Bound<'py, PyDict>>, Bound<'py, PyDict>)> {
    let pool = thread_pool(threads)?;
    let (tx, rx) = channel();
    let collector = Collector {
        events: tx.clone(),
        cancel: Arc::new(AtomicBool::new(false)),
        samples: Arc::new(AtomicU64::new(0)),
        frames: Mutex::new(Vec::new()),
        failure: Mutex::new(None),
    };
    let (outcome, stopped) = std::thread::scope(|s| {
        let worker = s.spawn(|| {
            let r = std::panic::catch_unwind(AssertUnwindSafe(|| {
                let go = || render(job, &collector);
                match &pool {
                    Some(p) => p.install(go),
                    None => go(),
                }
            }));
            let _ = tx.send(Event::Done);
            r
        });
        let waiter = Waiter {
            rx: Mutex::new(rx),
            cancel: collector.cancel.clone(),
            samples: collector.samples.clone(),
            reported: 0,
            expected: None,
            last_report: Instant::now(),
        };
        let stopped = waiter.wait(py, progress.as_ref());
        (worker.join(), stopped)
    });
    if let Some(e) = stopped {
        return Err(e);
    }
    let report = match outcome {
        Ok(Ok(Ok(report))) => report,
        Ok(Ok(Err(e))) => return Err(e),
        Ok(Err(payload)) | Err(payload) => return Err(internal_error(payload)),
    };
    if let Some(e) = collector.failure.lock().unwrap().take() {
        return Err(e);
    }
    let frames = collector.frames.into_inner().unwrap();
    let frames = frames
        .into_iter()
        .map(|f| frame_dict(py, f))
        .collect::<PyResult<Vec<_>>>()?;
    Ok((frames, report_dict(py, &report)?))
}

/// A rayon pool of `threads` workers, or None for the global pool (all cores).
fn thread_pool(threads: Option<usize>) -> PyResult<Option<rayon::ThreadPool>> {
    let Some(n) = threads else { return Ok(None) };
    let max = MAX_THREADS_PER_CORE * std::thread::available_parallelism().map_or(1, |n| n.get());
    if n == 0 || n > max {
        return Err(crate::JobError::new_err(format!(
            "threads={n}: give 1 to {max} ({MAX_THREADS_PER_CORE} per core); the image does \
             not depend on it"
        )));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map(Some)
        .map_err(|e| crate::JobError::new_err(format!("threads={n}: {e}")))
}

/// Loads the scene (from its file or dictionary) and runs the job.
fn render(job: &RenderJob, collector: &Collector) -> PyResult<JobReport> {
    let scene = crate::job::load(&job.job.scene.path, job.inline.as_ref(), Some(&job.job))?;
    let _ = collector
        .events
        .send(Event::Loaded(expected_samples(&job.job, &scene)));
    collector.check();
    aleph::job::run_on(&job.job, &scene, collector).map_err(crate::job_error)
}

/// spp × pixels × frames when the budget (or the uniform sampler's scene spp) fixes it.
fn expected_samples(job: &aleph::job::RenderJob, scene: &aleph::scene::Scene) -> Option<u64> {
    let pixels = scene.camera.width as f64 * scene.camera.height as f64;
    let frames = match (job.frames, scene.animation) {
        (Some([a, b]), _) => (b - a + 1) as f64,
        (None, Some(a)) => (a.frame_end - a.frame_start + 1) as f64,
        (None, None) => 1.0,
    };
    let spp = match (job.budget.spp, job.criterion) {
        (Some(b), _) => b,
        (None, aleph::adaptive::Criterion::Uniform) if job.budget.time_s.is_none() => {
            scene.settings.spp as f64
        }
        _ => return None,
    };
    Some((spp * pixels * frames).round() as u64)
}

/// The calling thread while the render runs.
struct Waiter {
    rx: Mutex<Receiver<Event>>,
    cancel: Arc<AtomicBool>,
    samples: Arc<AtomicU64>,
    reported: u64,
    expected: Option<u64>,
    last_report: Instant,
}

impl Waiter {
    /// Waits for the render thread to end, reporting progress; returns the exception that
    /// stopped it (Ctrl-C, the callback's), if any.
    fn wait(mut self, py: Python<'_>, progress: Option<&Bound<'_, PyAny>>) -> Option<PyErr> {
        let mut stopped: Option<PyErr> = None;
        loop {
            let rx = &self.rx;
            let event = py.detach(|| rx.lock().unwrap().recv_timeout(TICK));
            let report = match event {
                Ok(Event::Done) | Err(RecvTimeoutError::Disconnected) => break,
                Ok(Event::Loaded(expected)) => {
                    self.expected = expected;
                    None
                }
                Ok(Event::Pass(frame, p)) => Some(self.progress("pass", frame, Some(&p))),
                Ok(Event::Frame(frame)) => Some(self.progress("frame", frame, None)),
                Err(RecvTimeoutError::Timeout) => (self.last_report.elapsed() >= SAMPLES_EVERY
                    && self.samples.load(Ordering::Relaxed) > self.reported)
                    .then(|| self.progress("samples", None, None)),
            };
            if stopped.is_some() {
                continue;
            }
            let called = match (report, progress) {
                (Some(p), Some(cb)) => cb.call1((p,)).map(|_| ()),
                _ => Ok(()),
            };
            if let Err(e) = called.and_then(|_| py.check_signals()) {
                self.cancel.store(true, Ordering::Relaxed);
                stopped = Some(e);
            }
        }
        stopped
    }

    fn progress(
        &mut self,
        kind: &'static str,
        frame: Option<i64>,
        p: Option<&PassReport>,
    ) -> Progress {
        let total = self.samples.load(Ordering::Relaxed);
        let new = total - self.reported;
        self.reported = total;
        self.last_report = Instant::now();
        Progress {
            kind,
            frame,
            samples: new,
            total_samples: total,
            expected_samples: self.expected,
            pass_index: p.map(|p| p.pass),
            mean_spp: p.map(|p| p.mean_spp),
            converged_fraction: p.map(|p| p.converged_fraction),
        }
    }
}

/// A panic of the render thread that was not a cancellation: a bug, reported in one line.
fn internal_error(payload: Box<dyn std::any::Any + Send>) -> PyErr {
    let msg = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_default();
    crate::AlephError::new_err(format!(
        "internal error: {msg} (a bug: please report it with the input)"
    ))
}

/// A frame as a dict: `rgb` float32 (H, W, 3), `aovs` {EXR channel name: (H, W) array},
/// `display` uint8 (H, W, 3), `attributes`, `stats`, `frame`, `stop`.
fn frame_dict(py: Python<'_>, f: FrameOut) -> PyResult<Bound<'_, PyDict>> {
    let (w, h) = (f.width, f.height);
    let d = PyDict::new(py);
    d.set_item("frame", f.index)?;
    d.set_item("rgb", PyArray1::from_vec(py, f.rgb).reshape([h, w, 3])?)?;
    d.set_item(
        "display",
        PyArray1::from_vec(py, f.display).reshape([h, w, 3])?,
    )?;
    let aovs = PyDict::new(py);
    for (name, data) in f.channels {
        match data {
            ChannelData::F32(v) => {
                aovs.set_item(name, PyArray1::from_vec(py, v).reshape([h, w])?)?
            }
            ChannelData::U32(v) => {
                aovs.set_item(name, PyArray1::from_vec(py, v).reshape([h, w])?)?
            }
        }
    }
    d.set_item("aovs", aovs)?;
    let attributes = PyDict::new(py);
    for (k, v) in f.attributes {
        attributes.set_item(k, v)?;
    }
    d.set_item("attributes", attributes)?;
    let stats = PyDict::new(py);
    for (k, v) in f.stats {
        stats.set_item(k, v)?;
    }
    stats.set_item("samples", f.samples)?;
    stats.set_item("passes", f.passes)?;
    stats.set_item("stop", f.stop)?;
    d.set_item("stats", stats)?;
    Ok(d)
}

/// The job's report as a dict (`kind`, and for a sequence its frames, fps, mean spp, times).
fn report_dict<'py>(py: Python<'py>, report: &JobReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    match report {
        JobReport::Sequence(s) => {
            d.set_item("kind", "sequence")?;
            d.set_item("frames", s.frames)?;
            d.set_item("fps", s.fps)?;
            d.set_item("mean_spp", s.mean_spp)?;
            d.set_item("wall_s", s.wall.as_secs_f64())?;
            d.set_item("prepass_s", s.prepass.as_secs_f64())?;
            d.set_item("perception_s", s.perception.as_secs_f64())?;
        }
        JobReport::Part(p) => {
            d.set_item("kind", "part")?;
            d.set_item("path", &p.path)?;
        }
        JobReport::Tile(t) => {
            d.set_item("kind", "tile")?;
            d.set_item("path", &t.path)?;
        }
        _ => d.set_item("kind", "still")?,
    }
    Ok(d)
}
