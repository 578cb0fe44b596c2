//! Python values in and out: numpy arrays of float64, JSON-like dicts, paths.

use crate::bad;
use numpy::{PyArray1, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use std::path::PathBuf;

/// `obj` as a contiguous float64 numpy array (any array-like numpy accepts).
fn as_f64_array<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", np.getattr("float64")?)?;
    let arr = np
        .call_method("ascontiguousarray", (obj,), Some(&kwargs))
        .map_err(|e| bad(format!("{what}: not an array of numbers ({e})")))?;
    arr.extract::<PyReadonlyArrayDyn<'py, f64>>()
        .map_err(|e| bad(format!("{what}: not an array of numbers ({e})")))
}

/// A 1-D array of numbers.
pub(crate) fn vec1(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    let a = as_f64_array(obj, what)?;
    if a.ndim() != 1 {
        return Err(bad(format!(
            "{what}: expected a 1-D array, got shape {:?}",
            a.shape()
        )));
    }
    Ok(a.as_array().iter().copied().collect())
}

/// A 1-D array (one channel) or a 2-D array of shape (channels, samples); the bool says
/// whether the input was 1-D.
pub(crate) fn channels(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<(Vec<Vec<f64>>, bool)> {
    let a = as_f64_array(obj, what)?;
    match a.ndim() {
        1 => Ok((vec![a.as_array().iter().copied().collect()], true)),
        2 => {
            let v = a.as_array();
            Ok((
                v.outer_iter()
                    .map(|row| row.iter().copied().collect())
                    .collect(),
                false,
            ))
        }
        _ => Err(bad(format!(
            "{what}: expected a 1-D array or a 2-D array (channels, samples), got shape {:?}",
            a.shape()
        ))),
    }
}

/// A numpy array owning `v`.
pub(crate) fn array<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_vec(py, v)
}

/// A params / effects / truth argument: a JSON file, or the JSON itself as a dict.
pub(crate) enum JsonArg {
    /// A file to read.
    Path(PathBuf),
    /// The document given inline.
    Value(serde_json::Value),
}

/// Reads a params-like argument: `None`, a path (`str` or `os.PathLike`), or a dict.
pub(crate) fn json_arg(obj: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Option<JsonArg>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    if obj.is_instance_of::<PyDict>() {
        let py = obj.py();
        let text: String = py
            .import("json")?
            .call_method1("dumps", (obj,))
            .map_err(|e| bad(format!("{what}: not JSON-serialisable ({e})")))?
            .extract()?;
        let v = serde_json::from_str(&text)
            .map_err(|e| bad(format!("{what}: not valid JSON ({e})")))?;
        return Ok(Some(JsonArg::Value(v)));
    }
    path_arg(obj, what).map(|p| Some(JsonArg::Path(p)))
}

/// A path argument (`str` or `os.PathLike`).
pub(crate) fn path_arg(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<PathBuf> {
    if obj.is_instance_of::<PyString>() {
        return Ok(PathBuf::from(obj.extract::<String>()?));
    }
    obj.extract::<PathBuf>().map_err(|_| {
        bad(format!(
            "{what}: expected a path or a dict, got {}",
            obj.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_else(|_| "?".into())
        ))
    })
}

/// `json.loads(text)`: plain dicts, lists, floats, ints, strings, bools and None.
pub(crate) fn json_to_py<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}
