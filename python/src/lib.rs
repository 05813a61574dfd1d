//! `aleph._aleph`: the extension module behind the Python package `aleph` (python/aleph).
//!
//! It exposes the libraries, not the command line: render jobs ([`job::RenderJob`], run by
//! [`run::run`] with the GIL released, progress through a callback, Ctrl-C stopping the render
//! cleanly) and the perception model on any image ([`see`]). Errors become Python exceptions
//! carrying the libraries' located messages, the same words the CLI prints:
//!
//! | exception          | raised when                                              |
//! |--------------------|----------------------------------------------------------|
//! | `SceneError`       | the scene (or a mesh, texture, image) cannot be loaded   |
//! | `JobError`         | the job or a setting is out of range or contradictory    |
//! | `PerceptionError`  | the perception model rejects an image or a parameter     |
//! | `OutputError`      | a file cannot be written                                 |
//!
//! all subclasses of `AlephError`. Wrong array shapes and types raise `ValueError` and
//! `TypeError` as numpy's own functions do.

mod convert;
mod job;
mod run;
mod see;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    aleph,
    AlephError,
    PyException,
    "Base class of aleph's errors; the message names the file, frame or setting."
);
create_exception!(
    aleph,
    SceneError,
    AlephError,
    "A scene, mesh, texture or image cannot be loaded (the message names the file)."
);
create_exception!(
    aleph,
    JobError,
    AlephError,
    "A render job or setting is out of range or contradictory (the message names the option)."
);
create_exception!(
    aleph,
    PerceptionError,
    AlephError,
    "The perception model rejects an image or a parameter (NaN, negative, wrong size)."
);
create_exception!(
    aleph,
    OutputError,
    AlephError,
    "An output file cannot be written (the message names the file)."
);

/// The exception for an error of a render job, by its kind.
pub(crate) fn job_error(e: aleph::job::JobError) -> PyErr {
    use aleph::job::JobError as E;
    let msg = e.to_string();
    match e {
        E::Scene(_) => SceneError::new_err(msg),
        E::Deliver(_) | E::Output(_) | E::Partial(_) => OutputError::new_err(msg),
        _ => JobError::new_err(msg),
    }
}

/// The exception for an error of the perception model.
pub(crate) fn perception_error(e: perception::PerceptionError) -> PyErr {
    PerceptionError::new_err(e.to_string())
}

#[pymodule]
fn _aleph(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("DENOISER", aleph::denoise::AVAILABLE)?;
    m.add("AlephError", py.get_type::<AlephError>())?;
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("JobError", py.get_type::<JobError>())?;
    m.add("PerceptionError", py.get_type::<PerceptionError>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    m.add_class::<job::RenderJob>()?;
    m.add_class::<run::Progress>()?;
    m.add_function(wrap_pyfunction!(run::run, m)?)?;
    m.add_function(wrap_pyfunction!(job::load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(see::threshold_map, m)?)?;
    m.add_function(wrap_pyfunction!(see::diff, m)?)?;
    m.add_function(wrap_pyfunction!(see::tonemap, m)?)?;
    m.add_function(wrap_pyfunction!(see::to_srgb8, m)?)?;
    m.add_function(wrap_pyfunction!(see::read_image, m)?)?;
    m.add_function(wrap_pyfunction!(see::operators, m)?)?;
    Ok(())
}
