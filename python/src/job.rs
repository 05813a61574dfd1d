//! `aleph.RenderJob`: the library's [`aleph::job::RenderJob`] built from keyword arguments,
//! with the CLI's defaults, so that the same options give the same job (and the same pixels)
//! as `aleph render`.

use crate::JobError;
use aleph::adaptive::Criterion;
use aleph::job::{Budget, RenderJob as Job};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};

/// A scene given as a dictionary: its TOML text and the path it stands for (relative file
/// names are resolved beside it, messages name it).
#[derive(Clone, Debug)]
pub struct Inline {
    /// The scene as TOML.
    pub text: String,
    /// `BASE_DIR/<dict>`.
    pub origin: PathBuf,
}

/// A render job: what to render, as one record (the library's `RenderJob`, whose TOML is the
/// record a farm's manifest and every partial film keep).
#[pyclass(module = "aleph", frozen)]
#[derive(Clone)]
pub struct RenderJob {
    /// The library's job.
    pub job: Job,
    /// The scene, when it was given as a dictionary.
    pub inline: Option<Inline>,
}

/// The keyword options of a job, as Python passes them.
pub struct Options<'py> {
    pub spp: Option<f64>,
    pub time: Option<f64>,
    pub sampler: String,
    pub resolution: Option<(u32, u32)>,
    pub seed: Option<u64>,
    pub max_depth: Option<u32>,
    pub frames: Option<Bound<'py, PyAny>>,
    pub reuse_window: Option<u32>,
    pub operator: Option<String>,
    pub exposure: Option<f32>,
    pub fov: Option<f64>,
    pub ppd: Option<f64>,
    pub output: Option<PathBuf>,
    pub aov: bool,
    pub denoise: bool,
    pub denoise_quality: String,
    pub preview: bool,
    pub sampling: Option<Bound<'py, PyDict>>,
    pub display: Option<Bound<'py, PyDict>>,
}

#[pymethods]
impl RenderJob {
    /// See `aleph.RenderJob` in python/aleph/_aleph.pyi for the arguments.
    #[new]
    #[pyo3(signature = (scene, *, spp=None, time=None, sampler="perceptual".to_string(),
        resolution=None, seed=None, max_depth=None, frames=None, reuse_window=None,
        operator=None, exposure=None, fov=None, ppd=None, output=None, aov=false,
        denoise=false, denoise_quality="high".to_string(), preview=false, base_dir=None, sampling=None, display=None))]
    #[allow(clippy::too_many_arguments)]
    fn new<'py>(
        scene: &Bound<'py, PyAny>,
        spp: Option<f64>,
        time: Option<f64>,
        sampler: String,
        resolution: Option<(u32, u32)>,
        seed: Option<u64>,
        max_depth: Option<u32>,
        frames: Option<Bound<'py, PyAny>>,
        reuse_window: Option<u32>,
        operator: Option<String>,
        exposure: Option<f32>,
        fov: Option<f64>,
        ppd: Option<f64>,
        output: Option<PathBuf>,
        aov: bool,
        denoise: bool,
        denoise_quality: String,
        preview: bool,
        base_dir: Option<PathBuf>,
        sampling: Option<Bound<'py, PyDict>>,
        display: Option<Bound<'py, PyDict>>,
    ) -> PyResult<RenderJob> {
        let (path, inline) = scene_source(scene, base_dir)?;
        let options = Options {
            spp,
            time,
            sampler,
            resolution,
            seed,
            max_depth,
            frames,
            reuse_window,
            operator,
            exposure,
            fov,
            ppd,
            output,
            aov,
            denoise,
            denoise_quality,
            preview,
            sampling,
            display,
        };
        Ok(RenderJob {
            job: build(path, options)?,
            inline,
        })
    }

    /// A job from its TOML record (`to_toml`, a farm manifest's job).
    #[staticmethod]
    fn from_toml(text: &str) -> PyResult<RenderJob> {
        let job = Job::from_toml(text, Path::new("<toml>")).map_err(crate::job_error)?;
        job.validate().map_err(crate::job_error)?;
        Ok(RenderJob { job, inline: None })
    }

    /// The job's TOML record.
    fn to_toml(&self) -> String {
        self.job.to_toml()
    }

    /// The scene file (for a dictionary: `BASE_DIR/<dict>`).
    #[getter]
    fn scene(&self) -> PathBuf {
        self.job.scene.path.clone()
    }

    /// The output stem, or None (no files).
    #[getter]
    fn output(&self) -> Option<PathBuf> {
        self.job.output.stem.clone()
    }

    /// The sampler's name.
    #[getter]
    fn sampler(&self) -> &'static str {
        self.job.criterion.name()
    }

    fn __repr__(&self) -> String {
        format!(
            "RenderJob(scene={:?}, sampler={:?}, spp={:?})",
            self.job.scene.path.display().to_string(),
            self.job.criterion.name(),
            self.job.budget.spp
        )
    }
}

/// Loads a scene, without rendering it: its size, geometry, lights and animation, as a dict
/// (`path`, `width`, `height`, `triangles`, `emissive_triangles`, `frames` (first, last) or
/// None, `fps`, `spp`, `seed`, `max_depth`, `luminance_scale` in cd/m² per unit of radiance).
///
/// # Errors
/// `SceneError` naming the file and the problem, as `aleph render` reports it.
#[pyfunction]
#[pyo3(signature = (scene, *, base_dir=None))]
pub fn load_scene<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    base_dir: Option<PathBuf>,
) -> PyResult<Bound<'py, PyDict>> {
    let (path, inline) = scene_source(scene, base_dir)?;
    let s = py.detach(|| load(&path, inline.as_ref(), None))?;
    let d = PyDict::new(py);
    d.set_item("path", &s.path)?;
    d.set_item("width", s.camera.width)?;
    d.set_item("height", s.camera.height)?;
    d.set_item("triangles", s.geometry.len())?;
    d.set_item("emissive_triangles", s.lights.triangle_count())?;
    d.set_item("frames", s.animation.map(|a| (a.frame_start, a.frame_end)))?;
    d.set_item("fps", s.animation.map(|a| a.fps))?;
    d.set_item("spp", s.settings.spp)?;
    d.set_item("seed", s.settings.seed)?;
    d.set_item("max_depth", s.settings.max_depth)?;
    d.set_item("luminance_scale", s.settings.luminance_scale)?;
    Ok(d)
}

/// Loads the scene at `path` (or described by `inline`), with `job`'s overrides.
///
/// # Errors
/// `SceneError` naming the file.
pub fn load(
    path: &Path,
    inline: Option<&Inline>,
    job: Option<&Job>,
) -> PyResult<aleph::scene::Scene> {
    use aleph::scene::{Scene, SceneDescription};
    let err = |e: aleph::error::SceneError| crate::job_error(e.into());
    let desc = match inline {
        Some(i) => SceneDescription::parse(&i.text, &i.origin),
        None => SceneDescription::read(path),
    }
    .map_err(err)?;
    let desc = match job {
        Some(j) => j.with_overrides(desc),
        None => desc,
    };
    Scene::load_description(desc).map_err(err)
}

/// The scene argument: a path (str or os.PathLike, made absolute as the CLI does) or a
/// dictionary of the scene format's tables.
fn scene_source(
    scene: &Bound<'_, PyAny>,
    base_dir: Option<PathBuf>,
) -> PyResult<(PathBuf, Option<Inline>)> {
    if let Ok(dict) = scene.cast::<PyDict>() {
        let text = crate::convert::dict_to_toml(dict)?;
        let base = match base_dir {
            Some(b) => b,
            None => std::env::current_dir().map_err(|e| JobError::new_err(e.to_string()))?,
        };
        let origin = absolute(&base)?.join("<dict>");
        return Ok((origin.clone(), Some(Inline { text, origin })));
    }
    let path: PathBuf = scene.extract().map_err(|_| {
        PyTypeError::new_err("scene: give a path to a scene file (str or os.PathLike) or a dict")
    })?;
    if base_dir.is_some() {
        return Err(JobError::new_err(
            "base_dir: only for a scene given as a dictionary (a scene file's relative paths \
             are resolved beside the file)",
        ));
    }
    Ok((absolute(&path)?, None))
}

fn absolute(path: &Path) -> PyResult<PathBuf> {
    std::path::absolute(path).map_err(|e| JobError::new_err(format!("{}: {e}", path.display())))
}

/// The library's job for `options`, validated (the messages name the CLI's flags).
fn build(path: PathBuf, o: Options<'_>) -> PyResult<Job> {
    let mut job = Job::new(path);
    job.criterion = match o.sampler.as_str() {
        "perceptual" => Criterion::Perceptual,
        "uniform" => Criterion::Uniform,
        "variance" => Criterion::Variance,
        s => {
            return Err(JobError::new_err(format!(
                "sampler {s:?}: expected \"perceptual\", \"uniform\" or \"variance\""
            )));
        }
    };
    // The record's tables first (every option of the adaptive loop and the display, by the
    // job's TOML names), then the keyword options over them.
    if let Some(d) = &o.sampling {
        job.sampling = table(d, "sampling")?;
    }
    if let Some(d) = &o.display {
        job.display = table(d, "display")?;
    }
    job.frames = frames(o.frames.as_ref())?;
    job.scene.resolution = o.resolution.map(|(w, h)| [w, h]);
    job.scene.seed = o.seed;
    job.scene.max_depth = o.max_depth;
    job.budget = Budget {
        spp: o.spp,
        time_s: o.time,
    };
    job.sampling.reuse_window = o.reuse_window.or(job.sampling.reuse_window);
    job.sampling.ppd = o.ppd.or(job.sampling.ppd);
    if let Some(op) = o.operator.as_deref() {
        job.display.operator = Some(crate::see::operator(op)?);
    }
    job.display.exposure_ev = o.exposure.or(job.display.exposure_ev);
    job.display.fov_deg = o.fov.or(job.display.fov_deg);
    job.output.stem = o.output.map(|s| strip_image_ext(&s));
    job.output.aov = o.aov;
    job.output.denoise = o.denoise;
    job.output.denoise_quality = match o.denoise_quality.as_str() {
        "high" => aleph::denoise::FinalQuality::High,
        "fast" => aleph::denoise::FinalQuality::Fast,
        other => {
            return Err(JobError::new_err(format!(
                "denoise_quality: {other:?} is not \"high\" or \"fast\""
            )));
        }
    };
    job.output.preview = o.preview;
    job.validate().map_err(crate::job_error)?;
    Ok(job)
}

/// A job table (`sampling`, `display`) from a dict with the TOML record's field names; the
/// fields it omits keep their defaults.
fn table<T: serde::de::DeserializeOwned>(d: &Bound<'_, PyDict>, what: &str) -> PyResult<T> {
    let text = crate::convert::dict_to_toml(d)?;
    toml::from_str(&text)
        .map_err(|e| JobError::new_err(format!("{what}: {}", e.message().trim_end())))
}

/// `frames`: one frame number or an inclusive `(first, last)` pair.
fn frames(v: Option<&Bound<'_, PyAny>>) -> PyResult<Option<[i64; 2]>> {
    let Some(v) = v else { return Ok(None) };
    if let Ok(f) = v.extract::<i64>() {
        return Ok(Some([f, f]));
    }
    match v.extract::<(i64, i64)>() {
        Ok((a, b)) => Ok(Some([a, b])),
        Err(_) => Err(PyTypeError::new_err(
            "frames: give one frame number or an inclusive (first, last) pair",
        )),
    }
}

/// `-o out.exr` and `-o out.png` mean the stem `out`, as on the command line.
fn strip_image_ext(o: &Path) -> PathBuf {
    match o.extension().and_then(|e| e.to_str()) {
        Some("exr") | Some("png") => o.with_extension(""),
        _ => o.to_path_buf(),
    }
}
