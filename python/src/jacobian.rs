//! `Chain.jacobian`: the geometric Jacobian of a link, one configuration with the single
//! kernels, a batch through the core's [`write_jacobian_batch`] without the GIL.

use crate::arrays::{copy_vector, entries, float_array, plain_vector, rows, thread_count};
use crate::errors::{Error, array_error, error};
use crate::outputs::Outputs;
use crate::robot::{Robot, Scratch};
use crate::run::{Signals, with_workers};
use kinechain::eval::batch::{ArrayError, Overflow, write_jacobian_batch};
use kinechain::{Chain as Inner, JacobianFrame, LimitPolicy, LinkId, forward_kinematics};
use pyo3::prelude::*;

/// `frame=` and `point=` as the core's frame.
fn frame_of((frame, point): (&str, Option<[f64; 3]>)) -> PyResult<JacobianFrame> {
    match (frame, point) {
        ("world", None) => Ok(JacobianFrame::World),
        ("world", Some(u)) if u.iter().all(|x| x.is_finite()) => Ok(JacobianFrame::Point(u)),
        ("world", Some(u)) => Err(Error::new_err(format!("point {u:?} is not finite"))),
        ("link", None) => Ok(JacobianFrame::Link),
        ("link", Some(_)) => Err(Error::new_err(
            "point is given in link coordinates with frame=\"world\" (the point's velocity in world axes)",
        )),
        (other, _) => Err(Error::new_err(format!(
            "frame must be \"world\" or \"link\", not {other:?}"
        ))),
    }
}

/// `Chain.jacobian` (see its documentation in [`crate::chain`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn jacobian<'py>(
    robot: &Robot,
    py: Python<'py>,
    q: &Bound<'py, PyAny>,
    link: &str,
    frame: (&str, Option<[f64; 3]>),
    policy: LimitPolicy,
    threads: Option<&Bound<'py, PyAny>>,
    out: Option<&Bound<'py, PyAny>>,
) -> PyResult<Py<PyAny>> {
    let inner = &robot.inner;
    let threads = thread_count(threads)?;
    let frame = frame_of(frame)?;
    let id = inner.link_id(link).map_err(|e| error(&e))?;
    let dof = inner.nv();
    if out.is_none()
        && let Some(q) = plain_vector(q, inner.nq())
    {
        // The common call: `q` copied into the chain's buffer, the result into a spare array.
        return robot.with_reused(|r| {
            let j = r.jacobian_spare.take(py, numpy::ndarray::Ix2(6, dof))?;
            // SAFETY: a new array, or a spare that nothing else refers to; every entry is
            // written below before it is read (an error drops it unread).
            let dst = unsafe { entries(&j)? };
            let s = r.scratch(inner, policy);
            copy_vector(q, &mut s.q)?;
            single(inner, s, None, id, frame, dst).map_err(|e| array_error(e, false, None))?;
            Ok(j.into_any().unbind())
        });
    }
    let q = float_array(q, "q")?;
    let (n, batched) = rows(inner, &q, "q")?;
    let dims: &[usize] = if batched { &[n, 6, dof] } else { &[6, dof] };
    let shape = [numpy::ndarray::IxDyn(dims)];
    let mut outputs = match out {
        None => Outputs::new(py, &shape)?,
        Some(o) => Outputs::caller(std::slice::from_ref(o), &["out"], &shape, &[(&q, "q")])?,
    };
    let [dst] = outputs.slices()?;
    let q = q.as_slice()?;
    let mut signals = Signals::default();
    let result = if !batched {
        robot.with_reused(|r| single(inner, r.scratch(inner, policy), Some(q), id, frame, dst))
    } else if n == 0 || dof == 0 {
        // A chain without moving joints has Jacobians of no columns: nothing to write.
        Ok(())
    } else {
        py.detach(|| {
            with_workers(threads, |workers| {
                write_jacobian_batch(inner, policy, q, n, id, frame, dst, workers, &mut signals)
            })
        })?
    };
    result.map_err(|e| array_error(e, batched, signals.raised))?;
    outputs
        .into_arrays()
        .next()
        .ok_or_else(|| Error::new_err("no Jacobian"))
}

/// One configuration's Jacobian of `id` in `frame`, into `dst` (row-major `6 × dof`): of `q`, or
/// of the joint values in `s.q` for `None`.
fn single(
    chain: &Inner,
    s: &mut Scratch,
    q: Option<&[f64]>,
    id: LinkId,
    frame: JacobianFrame,
    dst: &mut [f64],
) -> Result<(), ArrayError> {
    let Scratch { data, q: copied, j } = s;
    let poses = forward_kinematics(chain, data, q.unwrap_or(copied))
        .map_err(|source| ArrayError::State { index: 0, source })?;
    poses.jacobian_in_into(id, frame, j);
    let dof = chain.nv();
    for (r, row) in dst.chunks_exact_mut(dof).enumerate().take(6) {
        for (c, x) in row.iter_mut().enumerate() {
            *x = j[(r, c)];
        }
    }
    match dst.iter().all(|x| x.is_finite()) {
        true => Ok(()),
        false => Err(ArrayError::NotFinite {
            index: 0,
            source: Overflow::new("jacobian", chain.link(id).name()),
        }),
    }
}
