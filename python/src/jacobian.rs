//! `Chain.jacobian`: the geometric Jacobian of a link, one configuration with the single
//! kernels, a batch through the core's [`write_jacobian_batch`] without the GIL.

use crate::arrays::{entries, float_array, new_array, rows, thread_count};
use crate::errors::{Error, array_error, error};
use crate::robot::Robot;
use crate::run::{Signals, with_workers};
use kinechain::eval::batch::{ArrayError, Overflow, write_jacobian_batch};
use kinechain::{JacobianFrame, LimitPolicy, forward_kinematics};
use numpy::PyArrayDyn;
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
pub(crate) fn jacobian<'py>(
    robot: &Robot,
    py: Python<'py>,
    q: &Bound<'py, PyAny>,
    link: &str,
    frame: (&str, Option<[f64; 3]>),
    policy: LimitPolicy,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let inner = &robot.inner;
    let threads = thread_count(threads)?;
    let frame = frame_of(frame)?;
    let q = float_array(q, "q")?;
    let (n, batched) = rows(inner, &q, "q")?;
    let id = inner.link_id(link).map_err(|e| error(&e))?;
    let dof = inner.dof();
    let dims: &[usize] = if batched { &[n, 6, dof] } else { &[6, dof] };
    let out = new_array(py, numpy::ndarray::IxDyn(dims))?;
    // SAFETY: a new array, not yet handed out; every entry is written below before it is.
    let dst = unsafe { entries(&out)? };
    let q = q.as_slice()?;
    let mut signals = Signals::default();
    let result = if !batched {
        robot.with_data(policy, |data| {
            let state = |source| ArrayError::State { index: 0, source };
            let j = forward_kinematics(inner, data, q)
                .map_err(state)?
                .jacobian_in(id, frame);
            for r in 0..6 {
                for c in 0..dof {
                    dst[r * dof + c] = j[(r, c)];
                }
            }
            match dst.iter().all(|x| x.is_finite()) {
                true => Ok(()),
                false => Err(ArrayError::NotFinite {
                    index: 0,
                    source: Overflow::new("jacobian", inner.link(id).name()),
                }),
            }
        })
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
    Ok(out)
}
