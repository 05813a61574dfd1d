//! The perception model on any image: the threshold map (Ramasubramanian et al. 1999 with
//! Daly's CSF, `perception::threshold`), the visible-difference test (`perception::metric`,
//! in the manner of Yee & Newman's pdiff) and the tone operators by their papers
//! (`perception::tmo` through `aleph::display`). Arrays arrive as C-contiguous float32 (the
//! Python wrappers convert); the work runs with the GIL released.

use crate::perception_error;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use perception::adaptation::AdaptationMode;
use perception::threshold::{ThresholdMapper, ThresholdParams};
use perception::tmo::{Display, Operator};
use perception::viewing::ViewingConditions;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A tone operator by its command-line name or its paper.
pub fn operator(name: &str) -> PyResult<Operator> {
    let key = name.to_ascii_lowercase().replace(['_', ' '], "-");
    let op = match key.as_str() {
        "tumblin-rushmeier" | "tumblin-rushmeier93" | "tumblin93" => Some(Operator::Tr),
        "ferwerda" | "ferwerda96" => Some(Operator::Fpsg),
        "ward-larson" | "ward-larson97" | "ward97" | "histogram" => Some(Operator::Wrp),
        "pattanaik" | "pattanaik00" => Some(Operator::Ptyg),
        "reinhard02" => Some(Operator::Reinhard),
        k => Operator::from_name(k),
    };
    op.ok_or_else(|| {
        crate::JobError::new_err(format!(
            "operator {name:?}: expected one of exposure, tr (tumblin-rushmeier93), fpsg \
             (ferwerda96), wrp (ward-larson97), ptyg (pattanaik00), reinhard (reinhard02)"
        ))
    })
}

/// The operators: (command-line name, label with the paper).
#[pyfunction]
pub fn operators() -> Vec<(&'static str, &'static str)> {
    Operator::ALL
        .iter()
        .map(|o| (o.name(), o.label()))
        .collect()
}

/// Viewing conditions from pixels per degree, or a horizontal field of view over `width`
/// pixels, or `default_fov` (None: 67.02 ppd, FLIP's monitor).
fn view(
    ppd: Option<f64>,
    fov: Option<f64>,
    width: usize,
    default_fov: Option<f64>,
) -> PyResult<ViewingConditions> {
    let v = match (ppd, fov.or(default_fov)) {
        (Some(_), Some(_)) if fov.is_some() => {
            return Err(PyValueError::new_err("give ppd or fov, not both"));
        }
        (Some(p), _) => ViewingConditions::default().with_ppd(p),
        (None, Some(f)) => ViewingConditions::from_fov(f, width as f64),
        (None, None) => Ok(ViewingConditions::default()),
    };
    v.map_err(perception_error)
}

fn plane(v: &PyReadonlyArray2<'_, f32>, what: &str) -> PyResult<(Vec<f32>, usize, usize)> {
    let s = v.shape();
    let data = v
        .as_slice()
        .map_err(|_| PyValueError::new_err(format!("{what}: not C-contiguous")))?;
    Ok((data.to_vec(), s[1], s[0]))
}

/// The threshold map of a luminance image (cd/m², float32 (H, W)): the smallest visible
/// luminance change per pixel, cd/m²; with `parts`, a dict with the adaptation luminance,
/// the elevations and the noise contrast too.
#[pyfunction]
#[pyo3(signature = (luminance, ppd=None, *, fov=None, adaptation_window=1.0, masking=true,
    frequency=true, parts=false))]
#[allow(clippy::too_many_arguments)]
pub fn threshold_map<'py>(
    py: Python<'py>,
    luminance: PyReadonlyArray2<'py, f32>,
    ppd: Option<f64>,
    fov: Option<f64>,
    adaptation_window: f64,
    masking: bool,
    frequency: bool,
    parts: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let (lum, w, h) = plane(&luminance, "luminance")?;
    let view = view(ppd, fov, w, None)?;
    let params = ThresholdParams {
        adaptation_window_deg: adaptation_window,
        masking,
        frequency,
        ..ThresholdParams::default()
    };
    let map = py
        .detach(|| ThresholdMapper::new(w, h, view, params)?.compute(&lum, None))
        .map_err(perception_error)?;
    let arr = |v: Vec<f32>| PyArray1::from_vec(py, v).reshape([h, w]);
    if !parts {
        return Ok(arr(map.threshold)?.into_any());
    }
    let d = PyDict::new(py);
    d.set_item("threshold", arr(map.threshold)?)?;
    d.set_item("adaptation", arr(map.adaptation)?)?;
    d.set_item("elevation", arr(map.elevation)?)?;
    d.set_item("frequency_elevation", arr(map.frequency_elevation)?)?;
    d.set_item("masking_elevation", arr(map.masking_elevation)?)?;
    d.set_item("noise_contrast", arr(map.noise_contrast)?)?;
    d.set_item("ppd", view.ppd)?;
    Ok(d.into_any())
}

/// Does a viewer see a difference between two luminance images (cd/m², float32 (H, W))?
/// Returns a dict: `ratio` (|ΔL| / threshold of the reference, (H, W)), `visible_pixels`,
/// `visible_fraction`, `different` (at least `fail_pixels` visible), `ppd`.
#[pyfunction]
#[pyo3(signature = (reference, test, ppd=None, *, fov=None, fail_pixels=100))]
pub fn diff<'py>(
    py: Python<'py>,
    reference: PyReadonlyArray2<'py, f32>,
    test: PyReadonlyArray2<'py, f32>,
    ppd: Option<f64>,
    fov: Option<f64>,
    fail_pixels: usize,
) -> PyResult<Bound<'py, PyDict>> {
    if fail_pixels == 0 {
        return Err(PyValueError::new_err(
            "fail_pixels must be at least 1 (0 would call identical images different)",
        ));
    }
    let (r, w, h) = plane(&reference, "reference")?;
    let (t, tw, th) = plane(&test, "test")?;
    if (tw, th) != (w, h) {
        return Err(PyValueError::new_err(format!(
            "reference is {w}×{h} but test is {tw}×{th}: images must have the same size"
        )));
    }
    // pdiff's default field of view, as `aleph diff`.
    let view = view(ppd, fov, w, Some(45.0))?;
    let result = py
        .detach(|| {
            perception::metric::DiffMetric::new(
                w,
                h,
                view,
                ThresholdParams::default(),
                fail_pixels,
            )?
            .compare(&r, &t)
        })
        .map_err(perception_error)?;
    let d = PyDict::new(py);
    d.set_item(
        "ratio",
        PyArray1::from_vec(py, result.ratio).reshape([h, w])?,
    )?;
    d.set_item("visible_pixels", result.visible_pixels)?;
    d.set_item("visible_fraction", result.visible_fraction)?;
    d.set_item("different", result.different)?;
    d.set_item("ppd", view.ppd)?;
    Ok(d)
}

/// Tone maps linear RGB (float32 (H, W, 3), `luminance_scale` cd/m² per unit) with an
/// operator; returns display-linear RGB in [0, 1], float32 (H, W, 3).
#[pyfunction]
#[pyo3(signature = (rgb, operator="reinhard", *, luminance_scale=100.0, ppd=None,
    adaptation="local", display_max=None, display_ambient=None))]
#[allow(clippy::too_many_arguments)]
pub fn tonemap<'py>(
    py: Python<'py>,
    rgb: PyReadonlyArray3<'py, f32>,
    operator: &str,
    luminance_scale: f32,
    ppd: Option<f64>,
    adaptation: &str,
    display_max: Option<f64>,
    display_ambient: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let (data, w, h) = rgb_plane(&rgb)?;
    let adaptation = match adaptation {
        "global" => AdaptationMode::Global,
        "local" => AdaptationMode::LocalArithmetic,
        "local-geometric" => AdaptationMode::LocalGeometric,
        a => {
            return Err(PyValueError::new_err(format!(
                "adaptation {a:?}: expected \"global\", \"local\" or \"local-geometric\""
            )));
        }
    };
    let settings = aleph::display::ToneMapSettings {
        operator: self::operator(operator)?,
        adaptation,
        view: view(ppd, None, w, None)?,
        display: Display {
            max_cd_m2: display_max,
            ambient_cd_m2: display_ambient,
        },
        luminance_scale,
        adaptation_state: None,
    };
    let out = py
        .detach(|| aleph::display::tone_map(&data, w, h, &settings))
        .map_err(perception_error)?;
    Ok(PyArray1::from_vec(py, out).reshape([h, w, 3])?.into_any())
}

fn rgb_plane(v: &PyReadonlyArray3<'_, f32>) -> PyResult<(Vec<f32>, usize, usize)> {
    let s = v.shape();
    if s[2] != 3 {
        return Err(PyValueError::new_err(format!(
            "rgb: expected shape (H, W, 3), got {s:?}"
        )));
    }
    let data = v
        .as_slice()
        .map_err(|_| PyValueError::new_err("rgb: not C-contiguous"))?;
    Ok((data.to_vec(), s[1], s[0]))
}

/// Display-linear RGB in [0, 1] (float32 (H, W, 3)) to 8-bit sRGB, as the PNGs hold it.
#[pyfunction]
pub fn to_srgb8<'py>(
    py: Python<'py>,
    display: PyReadonlyArray3<'py, f32>,
) -> PyResult<Bound<'py, PyAny>> {
    let (data, w, h) = rgb_plane(&display)?;
    let out = aleph::output::encode_srgb8(&data);
    Ok(PyArray1::from_vec(py, out).reshape([h, w, 3])?.into_any())
}

/// Reads an image (.exr, .hdr, .png, .jpg) as linear RGB: returns (rgb float32 (H, W, 3),
/// luminance scale in cd/m² per unit: the EXR's whiteLuminance, else 100; PNG and JPEG are
/// decoded from sRGB with white at 100 cd/m²), the rule of `aleph diff`.
#[pyfunction]
pub fn read_image<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<(Bound<'py, PyAny>, f32)> {
    let img = py
        .detach(|| aleph::imageio::read_image(&path))
        .map_err(|e| crate::SceneError::new_err(e.to_string()))?;
    let scale = img
        .luminance_scale(&path, None)
        .map_err(|e| crate::SceneError::new_err(e.to_string()))?;
    let (w, h) = (img.width, img.height);
    let arr = PyArray1::from_vec(py, img.rgb).reshape([h, w, 3])?;
    Ok((arr.into_any(), scale))
}
