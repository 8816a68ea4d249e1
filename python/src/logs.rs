//! Joint logs: the `JointState` messages of a ROS bag (MCAP), read in Rust
//! (`kinechain::io::bag`) and handed to `kinechain.logs` as numpy arrays.

use crate::errors::{Error, LogError};
use crate::files::read_interruptibly;
use kinechain::error::error_chain;
use kinechain::io::bag::{JointStateOptions, Missing, TimeSource, read_joint_states};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use std::path::PathBuf;

/// What `_read_joint_states` returns: the names, `time` `(N,)` int64, the positions
/// `(N, J)`, the velocities and efforts `(N, J)` or None, and whether the file was cut off.
type JointStateArrays<'py> = (
    Vec<String>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray2<f64>>,
    Option<Bound<'py, PyArray2<f64>>>,
    Option<Bound<'py, PyArray2<f64>>>,
    bool,
);

/// The `JointState` messages of `topic` in the MCAP file at `path` (see `kinechain.logs`).
#[pyfunction]
#[pyo3(signature = (path, topic, stamp, missing, velocities, efforts, keep_truncated))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn _read_joint_states<'py>(
    py: Python<'py>,
    path: PathBuf,
    topic: String,
    stamp: &str,
    missing: &str,
    velocities: bool,
    efforts: bool,
    keep_truncated: bool,
) -> PyResult<JointStateArrays<'py>> {
    let time = match stamp {
        "header" => TimeSource::Header,
        "log" => TimeSource::Log,
        _ => {
            return Err(Error::new_err(format!(
                "time {stamp:?}: expected 'header' or 'log'"
            )));
        }
    };
    let missing = match missing {
        "hold" => Missing::Hold,
        "null" => Missing::Null,
        _ => {
            return Err(Error::new_err(format!(
                "missing {missing:?}: expected 'hold' or 'null'"
            )));
        }
    };
    let options = JointStateOptions {
        topic,
        time,
        missing,
        velocities,
        efforts,
        keep_truncated,
    };
    let log = read_interruptibly(py, move || read_joint_states(&path, &options))?
        .map_err(|e| LogError::new_err(error_chain(&e)))?;
    let (n, width) = (log.len(), log.names.len());
    let matrix = |v: Vec<f64>| -> PyResult<Bound<'py, PyArray2<f64>>> {
        v.into_pyarray(py)
            .reshape([n, width])
            .map_err(|e| Error::new_err(e.to_string()))
    };
    let velocity = velocities.then(|| matrix(log.velocity)).transpose()?;
    let effort = efforts.then(|| matrix(log.effort)).transpose()?;
    Ok((
        log.names,
        log.time.into_pyarray(py),
        matrix(log.position)?,
        velocity,
        effort,
        log.truncated,
    ))
}
