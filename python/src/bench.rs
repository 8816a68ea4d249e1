//! `_rust_batch`, for the benchmarks: the time the core takes for a batch, called from Rust
//! in this process with no Python in between, so that `python/benchmarks/panda.py` can give
//! the binding's cost as a ratio measured in the same run. The work is what `Chain.fk` and
//! `Chain.jacobian` do on one thread, written by the core into outputs allocated (and their
//! pages touched) before the clock starts: the core's own time, without the allocation that a
//! new numpy result costs.

use crate::arrays::rows;
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
/// world-frame Jacobian of that link.
#[pyfunction]
#[pyo3(signature = (chain, q, qd=None, qdd=None, links=None, jacobian=None, repeats=5))]
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
) -> PyResult<f64> {
    let robot = &chain.get().robot;
    let inner = &robot.inner;
    let (n, batched) = rows(inner, &q, "q")?;
    if !batched || inner.dof() == 0 {
        return Err(StateError::new_err(
            "q must be a batch (N, dof) of a chain with joints",
        ));
    }
    let links = robot.links.get(py, inner, links)?;
    let (q, qd, qdd) = (
        q.as_slice()?,
        qd.as_ref().map(|a| a.as_slice()).transpose()?,
        qdd.as_ref().map(|a| a.as_slice()).transpose()?,
    );
    let level = usize::from(qd.is_some()) + usize::from(qdd.is_some());
    let l = links.selection.ids().len();
    let (dof, policy) = (inner.dof(), LimitPolicy::Enforce);
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
    let make = || lens.iter().map(|&k| vec![0.0; k]).collect::<Vec<_>>();
    let selection = &links.selection;
    py.detach(|| {
        let mut outs = make();
        let mut best = f64::INFINITY;
        for _ in 0..repeats.max(1) {
            let start = Instant::now();
            let result = match jacobian {
                Some(id) => write_jacobian_batch(
                    inner,
                    policy,
                    q,
                    n,
                    id,
                    JacobianFrame::World,
                    &mut outs[0],
                    Workers::Here,
                    &mut Uninterrupted,
                ),
                None => {
                    let (poses, rest) = outs.split_at_mut(1);
                    let mut rates: [&mut [f64]; 4] = Default::default();
                    for (r, v) in rates.iter_mut().zip(rest.iter_mut()) {
                        *r = v;
                    }
                    let out = LinkArrays {
                        poses: &mut poses[0],
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
            result.map_err(|e| array_error(e, true, None))?;
            best = best.min(start.elapsed().as_secs_f64());
        }
        Ok(best)
    })
}
