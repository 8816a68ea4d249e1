//! The package's exceptions, and the core's errors raised as them.

use kinechain::error::error_chain;
use kinechain::eval::batch::ArrayError;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pyo3::create_exception!(
    kinechain,
    Error,
    PyValueError,
    "Any error of kinechain (a ValueError)."
);
pyo3::create_exception!(
    kinechain,
    LoadError,
    Error,
    "A robot file or text that cannot be loaded; the message names the file, line, column and joint."
);
pyo3::create_exception!(
    kinechain,
    StateError,
    Error,
    "Joint values that cannot be evaluated (wrong shape or length, not finite, out of limits); the message names the joint."
);
pyo3::create_exception!(
    kinechain,
    LogError,
    Error,
    "A joint log that cannot be read (a ROS bag, a dataset); the message names the file, topic and message."
);

/// A file or text that does not load, with the causes of `e`.
pub(crate) fn load_error(e: &dyn std::error::Error) -> PyErr {
    LoadError::new_err(error_chain(e))
}

/// `e` as `kinechain.Error`, with its causes.
pub(crate) fn error(e: &dyn std::error::Error) -> PyErr {
    Error::new_err(error_chain(e))
}

/// A batch's error as a `StateError` (naming the configuration when `batched`; one
/// configuration's error has no index to give), or the exception a signal raised meanwhile.
pub(crate) fn array_error(e: ArrayError, batched: bool, signal: Option<PyErr>) -> PyErr {
    match e {
        ArrayError::Interrupted => {
            signal.unwrap_or_else(|| Error::new_err("the evaluation was interrupted"))
        }
        ArrayError::State { source, .. } if !batched => StateError::new_err(error_chain(&source)),
        ArrayError::NotFinite { source, .. } if !batched => {
            StateError::new_err(error_chain(&source))
        }
        e => StateError::new_err(error_chain(&e)),
    }
}
