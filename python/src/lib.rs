//! `surae._surae`: the native part of the `surae` Python package.
//!
//! * [`arrays`]: functions on numpy arrays that need no files (`envelope`, `simulate`, the
//!   bundled trial);
//! * [`commands`]: `identify`, `diagnose` and `design`, which run the application library's
//!   jobs (`surae_app`, the code under the command line) into a folder and return the JSON
//!   they wrote, so a Python result is the command line's result by construction;
//! * [`run`]: runs a command on a worker thread with the GIL released, shows progress, and
//!   stops it on Ctrl-C (KeyboardInterrupt).
//!
//! Bad input raises `surae.InputError` (a `ValueError`) with the command line's one-line
//! message (without its `error: ` prefix); a failure that is not the input's fault raises
//! `RuntimeError`.

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

mod arrays;
mod commands;
mod convert;
mod run;

create_exception!(
    surae,
    InputError,
    PyValueError,
    "Unusable input: the message is the command line's one-line error (file, line and column, \
     or key / column name)."
);

/// The Python exception for a command's failure.
pub(crate) fn failure_to_py(f: surae_app::AppError) -> PyErr {
    match f {
        surae_app::AppError::BadInput(m) => InputError::new_err(m),
        surae_app::AppError::Interrupted => {
            pyo3::exceptions::PyKeyboardInterrupt::new_err("interrupted")
        }
        other => PyRuntimeError::new_err(other.to_string()),
    }
}

/// An `InputError` from anything printable.
pub(crate) fn bad(msg: impl std::fmt::Display) -> PyErr {
    InputError::new_err(msg.to_string())
}

#[pymodule]
fn _surae(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add_function(wrap_pyfunction!(arrays::envelope, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::bundled_trial, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::bundled_unloaded, m)?)?;
    m.add_function(wrap_pyfunction!(commands::identify, m)?)?;
    m.add_function(wrap_pyfunction!(commands::diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(commands::design, m)?)?;
    Ok(())
}
