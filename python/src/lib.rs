//! `kinechain._kinechain`, the compiled half of the Python package: a `Chain` class over
//! `kinechain::Chain` whose evaluations take and return numpy arrays, running with the GIL
//! released (on all cores for a batch of configurations, or as many threads as asked). The
//! Python half (`kinechain/__init__.py`) adds the result class and the array-like conversions.
//!
//! The binding converts and checks arrays and calls the core, which computes, blocks, schedules
//! and writes the outputs. Nothing here panics on what a user passes: shapes, lengths, names,
//! non-finite values and values out of limits are checked and raised as `kinechain.StateError` /
//! `kinechain.Error`, files as `kinechain.LoadError`.
//!
//! Its modules, each using only those before it: `errors`, `arrays` (numpy in and out), `spare`
//! (output arrays of single calls, reused once released), `files` (interruptible reads), `run`
//! (threads and signals), `links` (the links a call asks for), `results` (the result class), `outputs` (the arrays a call writes),
//! `robot` (what evaluations use of a chain), `fk`, `jacobian`, `chain` (the class),
//! `regression`, `orientation`, `logs` (ROS bags), `bench` (the core timed from Rust, for the benchmarks).

mod arrays;
mod bench;
mod chain;
mod errors;
mod files;
mod fk;
mod ik;
mod jacobian;
mod layouts;
mod links;
mod logs;
mod methods;
mod orientation;
mod outputs;
mod regression;
mod relative;
mod results;
mod robot;
mod run;
mod spare;
mod tf;

use chain::Chain;
use errors::{Error, LoadError, LogError, StateError};
use orientation::_orientation;
use pyo3::prelude::*;
use regression::{_compare, _record_golden, _verify_golden};
use results::FkResult;

#[pymodule]
fn _kinechain(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Chain>()?;
    m.add_class::<FkResult>()?;
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("LoadError", m.py().get_type::<LoadError>())?;
    m.add("StateError", m.py().get_type::<StateError>())?;
    m.add("LogError", m.py().get_type::<LogError>())?;
    m.add_function(wrap_pyfunction!(logs::_read_joint_states, m)?)?;
    m.add_function(wrap_pyfunction!(_orientation, m)?)?;
    m.add_function(wrap_pyfunction!(chain::_expand_xacro, m)?)?;
    m.add_function(wrap_pyfunction!(_record_golden, m)?)?;
    m.add_function(wrap_pyfunction!(_verify_golden, m)?)?;
    m.add_function(wrap_pyfunction!(_compare, m)?)?;
    m.add_function(wrap_pyfunction!(bench::_rust_batch, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
