//! `kinechain.testing`'s compiled half: golden files recorded and verified, and two chains
//! compared, through the core's `regression` module.

use crate::chain::Chain;
use crate::errors::Error;
use crate::files;
use kinechain::error::error_chain;
use kinechain::regression;
use pyo3::prelude::*;
use std::path::PathBuf;

/// The options of a regression record or comparison.
fn regression_options(
    samples: usize,
    seed: u64,
    level: &str,
    links: Option<Vec<String>>,
) -> PyResult<regression::Options> {
    let level = match level {
        "pose" => regression::Level::Pose,
        "vel" => regression::Level::Vel,
        "acc" => regression::Level::Acc,
        other => {
            return Err(Error::new_err(format!(
                "level '{other}': expected 'pose', 'vel' or 'acc'"
            )));
        }
    };
    Ok(regression::Options {
        samples,
        seed,
        level,
        links: links.unwrap_or_default(),
    })
}

fn tolerances(position: f64, rotation: f64, rates: f64) -> PyResult<regression::Tolerances> {
    for (what, x) in [
        ("position", position),
        ("rotation", rotation),
        ("rates", rates),
    ] {
        if !(x.is_finite() && x >= 0.0) {
            return Err(Error::new_err(format!(
                "tolerance of {what} {x}: expected a finite number >= 0"
            )));
        }
    }
    Ok(regression::Tolerances {
        position,
        rotation,
        rates,
    })
}

/// A report as `(passed, table for people, JSON text)`.
fn report_parts(report: &regression::Report) -> PyResult<(bool, String, String)> {
    let json = serde_json::to_string(report).map_err(|e| Error::new_err(e.to_string()))?;
    Ok((report.passed(), report.to_string(), json))
}

fn regression_error(e: &regression::RegressionError) -> PyErr {
    Error::new_err(error_chain(e))
}

/// Records `chain` into the golden file `path` (what `kinechain record -o path` writes).
#[pyfunction]
#[pyo3(signature = (chain, path, samples, seed, level, links))]
pub(crate) fn _record_golden(
    chain: &Bound<'_, Chain>,
    path: PathBuf,
    samples: usize,
    seed: u64,
    level: &str,
    links: Option<Vec<String>>,
) -> PyResult<()> {
    let options = regression_options(samples, seed, level, links)?;
    let me = chain.get();
    let golden = regression::record(&me.robot.inner, &options).map_err(|e| regression_error(&e))?;
    let inputs: Vec<&std::path::Path> = me.origin.iter().map(PathBuf::as_path).collect();
    regression::write_golden_file(&golden, &path, &inputs).map_err(|e| regression_error(&e))
}

/// Verifies `chain` against the golden file `path`: `(passed, table, JSON)`.
#[pyfunction]
pub(crate) fn _verify_golden(
    py: Python<'_>,
    chain: &Bound<'_, Chain>,
    path: PathBuf,
    tol_position: f64,
    tol_rotation: f64,
    tol_rates: f64,
) -> PyResult<(bool, String, String)> {
    let tol = tolerances(tol_position, tol_rotation, tol_rates)?;
    let golden = files::read_interruptibly(py, move || {
        regression::read_golden_file(&path).map_err(|e| error_chain(&e))
    })?
    .map_err(Error::new_err)?;
    let report = regression::verify(&chain.get().robot.inner, &golden, &tol)
        .map_err(|e| regression_error(&e))?;
    report_parts(&report)
}

/// Compares two chains, joint `old` of `a` matched to joint `new` of `b` for each pair of
/// `renames`: `(passed, table, JSON)`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (a, b, samples, seed, level, links, tol_position, tol_rotation, tol_rates, renames=None))]
pub(crate) fn _compare(
    a: &Bound<'_, Chain>,
    b: &Bound<'_, Chain>,
    samples: usize,
    seed: u64,
    level: &str,
    links: Option<Vec<String>>,
    tol_position: f64,
    tol_rotation: f64,
    tol_rates: f64,
    renames: Option<Vec<(String, String)>>,
) -> PyResult<(bool, String, String)> {
    let options = regression_options(samples, seed, level, links)?;
    let tol = tolerances(tol_position, tol_rotation, tol_rates)?;
    let report = regression::compare_renamed(
        &a.get().robot.inner,
        &b.get().robot.inner,
        &options,
        &tol,
        &renames.unwrap_or_default(),
    )
    .map_err(|e| regression_error(&e))?;
    report_parts(&report)
}
