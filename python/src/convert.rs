//! Python values to TOML: a scene given as a dictionary is the scene file's tables, so it
//! is written as TOML text and parsed by the same code as a file (same defaults, same
//! messages for an unknown key or a wrong type).

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

/// A dictionary of the scene format's tables as TOML text.
///
/// # Errors
/// `TypeError` naming the key whose value has no TOML form (None, objects).
pub fn dict_to_toml(dict: &Bound<'_, PyDict>) -> PyResult<String> {
    let table = table(dict, "")?;
    toml::to_string(&toml::Value::Table(table))
        .map_err(|e| PyTypeError::new_err(format!("scene dictionary: {e}")))
}

fn table(dict: &Bound<'_, PyDict>, at: &str) -> PyResult<toml::Table> {
    let mut out = toml::Table::new();
    for (k, v) in dict.iter() {
        let key: String = k.extract().map_err(|_| {
            PyTypeError::new_err(format!("scene dictionary{at}: keys must be strings"))
        })?;
        let here = format!("{at}.{key}");
        out.insert(key, value(&v, &here)?);
    }
    Ok(out)
}

fn value(v: &Bound<'_, PyAny>, at: &str) -> PyResult<toml::Value> {
    use toml::Value as V;
    if v.is_instance_of::<PyBool>() {
        return Ok(V::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return Ok(V::Integer(v.extract()?));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(V::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(V::String(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        return Ok(V::Table(table(d, at)?));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items = v
            .try_iter()?
            .enumerate()
            .map(|(i, x)| value(&x?, &format!("{at}[{i}]")))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(V::Array(items));
    }
    // os.PathLike (a mesh or texture path), numpy scalars and arrays.
    if let Ok(p) = v.call_method0("__fspath__") {
        return Ok(V::String(p.extract()?));
    }
    if v.hasattr("tolist")? {
        return value(&v.call_method0("tolist")?, at);
    }
    Err(PyTypeError::new_err(format!(
        "scene dictionary{at}: a {} has no TOML form (use numbers, strings, lists and \
         dictionaries)",
        v.get_type().name()?
    )))
}
