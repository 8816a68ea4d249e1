//! `_rust_batch`, for the benchmarks: the time the core takes for a batch, called from Rust
//! in this process with no Python in between, so that `python/benchmarks/panda.py` can give
//! the binding's cost as a ratio measured in the same run. The work is what `Chain.fk` and
//! `Chain.jacobian` do on one thread, written by the core into outputs allocated (and their
//! pages touched) before the clock starts, as a call with `out=` does; or, with `fresh`, into
//! numpy arrays made (and dropped) inside the timed run, as a call that returns new arrays does.

use crate::arrays::{entries, new_array, rows};
use crate::chain::Chain;
use crate::errors::{Error, StateError, array_error};
use kinechain::eval::batch::{
    LinkArrays, Motion, Uninterrupted, Workers, write_jacobian_batch, write_link_batch,
};
use kinechain::{JacobianFrame, LimitPolicy};
use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use std::time::Instant;

/// The shortest of `repeats` runs, in seconds, of the batch of `q` (`(N, dof)`) with `qd`,
/// `qdd`: the poses (and rates) of `links` (every link for `None`), or with `jacobian` the
/// world-frame Jacobian of that link; with `fresh`, each run allocates its outputs.
#[pyfunction]
#[pyo3(signature = (chain, q, qd=None, qdd=None, links=None, jacobian=None, repeats=5, fresh=false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn _rust_batch(
    py: Python<'_>,
    chain: &Bound<'_, Chain>,
    q: PyReadonlyArrayDyn<'_, f64>,
    qd: Option<PyReadonlyArrayDyn<'_, f64>>,
    qdd: Option<PyReadonlyArrayDyn<'_, f64>>,
    links: Option<&Bound<'_, PyAny>>,
    jacobian: Option<&str>,
    repeats: usize,
    fresh: bool,
) -> PyResult<f64> {
    let robot = &chain.get().robot;
    let inner = &robot.inner;
    let (n, batched) = rows(inner, &q, "q")?;
    if !batched || inner.nq() == 0 {
        return Err(StateError::new_err(
            "q must be a batch (N, dof) of a chain with joints",
        ));
    }
    let links = robot.links(py, links)?;
    let (q, qd, qdd) = (
        q.as_slice()?,
        qd.as_ref().map(|a| a.as_slice()).transpose()?,
        qdd.as_ref().map(|a| a.as_slice()).transpose()?,
    );
    let level = usize::from(qd.is_some()) + usize::from(qdd.is_some());
    let l = links.selection.ids().len();
    let (dof, policy) = (inner.nv(), LimitPolicy::Enforce);
    let jacobian = jacobian
        .map(|name| {
            inner
                .link_id(name)
                .map_err(|e| Error::new_err(e.to_string()))
        })
        .transpose()?;
    let lens: Vec<usize> = match jacobian {
        Some(_) => vec![n * 6 * dof],
        None => std::iter::once(n * l * 16)
            .chain((0..2 * level).map(|_| n * l * 3))
            .collect(),
    };
    let selection = &links.selection;
    // One run of the core into `outs`.
    let run = |outs: &mut [&mut [f64]]| match jacobian {
        Some(id) => write_jacobian_batch(
            inner,
            policy,
            q,
            n,
            id,
            JacobianFrame::World,
            &mut *outs[0],
            Workers::Here,
            &mut Uninterrupted,
        ),
        None => {
            let (poses, rest) = outs.split_at_mut(1);
            let mut rates: [&mut [f64]; 4] = Default::default();
            for (r, v) in rates.iter_mut().zip(rest.iter_mut()) {
                *r = &mut **v;
            }
            let out = LinkArrays {
                poses: &mut *poses[0],
                rates,
            };
            write_link_batch(
                inner,
                policy,
                Motion { q, qd, qdd },
                n,
                selection,
                out,
                Workers::Here,
                &mut Uninterrupted,
            )
        }
    };
    let mut best = f64::INFINITY;
    // Written once before the clock starts (their pages touched), as an `out=` reused.
    let mut kept: Vec<Vec<f64>> = match fresh {
        true => Vec::new(),
        false => lens.iter().map(|&k| vec![f64::NAN; k]).collect(),
    };
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        if fresh {
            // numpy arrays made, written and dropped, as a call returning new arrays does.
            let arrays = lens
                .iter()
                .map(|&k| new_array(py, numpy::ndarray::Ix1(k)))
                .collect::<PyResult<Vec<_>>>()?;
            let mut outs = Vec::with_capacity(arrays.len());
            for a in &arrays {
                // SAFETY: new arrays, not handed out (dropped below), each taken once.
                outs.push(unsafe { entries(a)? });
            }
            py.detach(|| run(&mut outs))
                .map_err(|e| array_error(e, true, None))?;
            drop(outs);
            drop(arrays);
        } else {
            let mut outs: Vec<&mut [f64]> = kept.iter_mut().map(|v| &mut v[..]).collect();
            py.detach(|| run(&mut outs))
                .map_err(|e| array_error(e, true, None))?;
        }
        best = best.min(start.elapsed().as_secs_f64());
    }
    Ok(best)
}
