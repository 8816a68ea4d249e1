//! `Chain._ik`: inverse kinematics of rows of targets, the work in [`kinechain::ik`], without the
//! GIL and on the module's pools; `kinechain/__init__.py`'s `Chain.ik` reads the shapes and makes
//! the result.

use crate::arrays::{float_array, thread_count};
use crate::chain::Chain;
use crate::errors::{Error, StateError};
use crate::run::{Signals, with_workers};
use kinechain::Transform;
use kinechain::error::error_chain;
use kinechain::eval::batch::Workers;
use kinechain::ik::{BatchOut, Distance, Goal, IkError, Options, Solver, Start, solve_batch};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;

/// What `_ik` returns: `q (N, nq)`, `success (N,)`, `position_error (N, k)`,
/// `rotation_error (N, k)`, `iterations (N,)`, `restarts (N,)`.
type Arrays<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<bool>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<u32>>,
);

fn ik_error(e: &IkError) -> PyErr {
    match e {
        IkError::Seed(_)
        | IkError::Target { .. }
        | IkError::Row { .. }
        | IkError::Length { .. } => StateError::new_err(error_chain(e)),
        _ => Error::new_err(error_chain(e)),
    }
}

#[pymethods]
impl Chain {
    /// Inverse kinematics of `n` rows of `k` targets (`targets`: `n · k` row-major 4 × 4
    /// matrices), one goal per entry of `links` (with its base link, point and weights), from
    /// `q0` (`(n, nq)`, or `None` for the start `start` names). See `Chain.ik`.
    #[pyo3(signature = (links, bases, points, weights, targets, n, q0, *, seed, threads, position_tolerance, rotation_tolerance, iterations, max_attempts, time_limit, closest, locked, start))]
    #[allow(clippy::too_many_arguments)]
    fn _ik<'py>(
        &self,
        py: Python<'py>,
        links: Vec<String>,
        bases: Vec<Option<String>>,
        points: Vec<[f64; 3]>,
        weights: Vec<[f64; 6]>,
        targets: &Bound<'py, PyAny>,
        n: usize,
        q0: Option<&Bound<'py, PyAny>>,
        seed: u64,
        threads: Option<&Bound<'py, PyAny>>,
        position_tolerance: f64,
        rotation_tolerance: f64,
        iterations: usize,
        max_attempts: usize,
        time_limit: Option<f64>,
        closest: Option<&str>,
        locked: Vec<String>,
        start: &str,
    ) -> PyResult<Arrays<'py>> {
        let chain = &self.robot.inner;
        let threads = thread_count(threads)?;
        let k = links.len();
        if bases.len() != k || points.len() != k || weights.len() != k {
            return Err(Error::new_err(
                "links, bases, points and weights differ in length",
            ));
        }
        let mut goals = Vec::with_capacity(k);
        for (((link, base), point), w) in links.iter().zip(&bases).zip(&points).zip(&weights) {
            let mut goal = Goal::pose(
                chain
                    .link_id(link)
                    .map_err(|e| Error::new_err(error_chain(&e)))?,
            )
            .at_point(*point)
            .with_weights(*w);
            if let Some(b) = base {
                goal = goal.relative_to(
                    chain
                        .link_id(b)
                        .map_err(|e| Error::new_err(error_chain(&e)))?,
                );
            }
            goals.push(goal);
        }
        let locked = locked
            .iter()
            .map(|name| {
                chain
                    .joint_id(name)
                    .map_err(|e| Error::new_err(format!("locked: {}", error_chain(&e))))
            })
            .collect::<PyResult<Vec<_>>>()?;
        let time_limit = match time_limit {
            None => None,
            Some(t) if t.is_finite() && t > 0.0 => Some(std::time::Duration::from_secs_f64(t)),
            Some(t) => {
                return Err(Error::new_err(format!(
                    "time_limit {t}: a positive number of seconds"
                )));
            }
        };
        let closest = match closest {
            None => None,
            Some("l2") => Some(Distance::L2),
            Some("linf") => Some(Distance::LInf),
            Some(other) => {
                return Err(Error::new_err(format!(
                    "closest must be None, \"l2\" or \"linf\", not {other:?}"
                )));
            }
        };
        let start = match start {
            "mid" => Start::MidLimits,
            "neutral" => Start::Neutral,
            other => {
                return Err(Error::new_err(format!(
                    "start must be \"mid\" or \"neutral\", not {other:?}"
                )));
            }
        };
        let options = Options {
            position_tolerance,
            rotation_tolerance,
            iterations_per_attempt: iterations,
            max_attempts,
            seed,
            time_limit,
            closest,
            locked,
            start,
        };
        let mut solver = Solver::new(chain, goals, options).map_err(|e| ik_error(&e))?;
        let t = float_array(targets, "target")?;
        let t = t.as_slice()?;
        if t.len() != n * k * 16 {
            return Err(StateError::new_err(format!(
                "target has {} entries, expected {}",
                t.len(),
                n * k * 16
            )));
        }
        let mut transforms = Vec::with_capacity(n * k);
        for (i, m) in t.chunks_exact(16).enumerate() {
            let rows = [
                [m[0], m[1], m[2], m[3]],
                [m[4], m[5], m[6], m[7]],
                [m[8], m[9], m[10], m[11]],
                [m[12], m[13], m[14], m[15]],
            ];
            let tr = Transform::try_from_rows(&rows).map_err(|e| {
                let what = if n == 1 {
                    String::new()
                } else {
                    format!("row {}, ", i / k)
                };
                StateError::new_err(format!(
                    "target ({what}goal {} on '{}'): {e}",
                    i % k,
                    links[i % k]
                ))
            })?;
            transforms.push(tr);
        }
        let nq = chain.nq();
        let seeds = match q0 {
            None => None,
            Some(q) => {
                let a = float_array(q, "q0")?;
                let v = a.as_slice()?.to_vec();
                if v.len() != n * nq {
                    return Err(StateError::new_err(format!(
                        "q0 has {} entries: expected {nq} per row ({} rows)",
                        v.len(),
                        n
                    )));
                }
                Some(v)
            }
        };
        let mut q = vec![0.0; n * nq];
        let mut success = vec![false; n];
        let mut pe = vec![0.0; n * k];
        let mut re = vec![0.0; n * k];
        let mut its = vec![0u32; n];
        let mut rs = vec![0u32; n];
        let mut signals = Signals::default();
        let out = BatchOut {
            q: &mut q,
            success: &mut success,
            position_error: &mut pe,
            rotation_error: &mut re,
            iterations: &mut its,
            restarts: &mut rs,
        };
        // One row: solved here with this solver (a batch would copy it for its worker).
        if n == 1 {
            let s = py
                .detach(|| solver.solve(&transforms, seeds.as_deref()))
                .map_err(|e| ik_error(&e))?;
            out.q.copy_from_slice(&s.q);
            out.success[0] = s.success;
            out.position_error.copy_from_slice(&s.position_error);
            out.rotation_error.copy_from_slice(&s.rotation_error);
            out.iterations[0] = u32::try_from(s.iterations).unwrap_or(u32::MAX);
            out.restarts[0] = u32::try_from(s.restarts).unwrap_or(u32::MAX);
        } else {
            let result = py.detach(|| {
                with_workers(threads, |workers: Workers<'_>| {
                    solve_batch(
                        &solver,
                        &transforms,
                        seeds.as_deref(),
                        out,
                        workers,
                        &mut signals,
                    )
                })
            })?;
            if let Err(e) = result {
                if let (IkError::Interrupted, Some(raised)) = (&e, signals.raised) {
                    return Err(raised);
                }
                return Err(ik_error(&e));
            }
        }
        let shape2 = |v: Vec<f64>, cols: usize| PyArray1::from_vec(py, v).reshape([n, cols]);
        Ok((
            shape2(q, nq)?,
            PyArray1::from_vec(py, success),
            shape2(pe, k)?,
            shape2(re, k)?,
            PyArray1::from_vec(py, its),
            PyArray1::from_vec(py, rs),
        ))
    }
}
