//! `Chain.fk`: joint values in, poses and rates of the links asked for out, as numpy arrays
//! written by the core (one configuration with the single kernels; a batch through
//! [`write_link_batch`], without the GIL).

use crate::arrays::{entries, float_array, new_array, overlaps, rows, thread_count};
use crate::errors::{StateError, array_error};
use crate::links::Links;
use crate::results::FkResult;
use crate::robot::Robot;
use crate::run::{Signals, with_workers};
use kinechain::eval::batch::{ArrayError, LinkArrays, Motion, write_link_batch};
use kinechain::{
    Chain as Inner, Data, LimitPolicy, LinkId, StateError as KStateError, forward_accelerations,
    forward_kinematics, forward_kinematics_to, forward_velocities,
};
use numpy::ndarray::Dimension;
use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// Joint values, rates and accelerations as given (`q` always).
type Given<'a, 'py> = (
    &'a Bound<'py, PyAny>,
    Option<&'a Bound<'py, PyAny>>,
    Option<&'a Bound<'py, PyAny>>,
);

/// `Chain.fk` (see the package's documentation).
pub(crate) fn fk<'py>(
    robot: &Robot,
    py: Python<'py>,
    (q, qd, qdd): Given<'_, 'py>,
    links: Option<&Bound<'py, PyAny>>,
    policy: LimitPolicy,
    threads: Option<&Bound<'py, PyAny>>,
    out: Option<&Bound<'py, PyAny>>,
) -> PyResult<FkResult> {
    let inner = &robot.inner;
    let threads = thread_count(threads)?;
    let q = float_array(q, "q")?;
    let qd = qd.map(|a| float_array(a, "qd")).transpose()?;
    let qdd = qdd.map(|a| float_array(a, "qdd")).transpose()?;
    let (n, batched) = rows(inner, &q, "q")?;
    for (a, what) in [(&qd, "qd"), (&qdd, "qdd")] {
        if let Some(a) = a
            && a.shape() != q.shape()
        {
            return Err(StateError::new_err(format!(
                "{what} has shape {:?}, q {:?}: they must be the same",
                a.shape(),
                q.shape()
            )));
        }
    }
    if qdd.is_some() && qd.is_none() {
        return Err(StateError::new_err(
            "qdd needs qd (accelerations depend on velocities)",
        ));
    }
    let level = usize::from(qd.is_some()) + usize::from(qdd.is_some());
    let links = robot.links.get(py, inner, links)?;
    let l = links.selection.ids().len();
    // The shape `(N, L, *tail)` or `(L, *tail)`, built on the stack (`IxDyn` keeps up to four
    // axes inline).
    let dims = |tail: &[usize]| {
        let mut d = [0; 4];
        let lead = usize::from(batched);
        d[0] = n;
        d[lead] = l;
        d[lead + 1..lead + 1 + tail.len()].copy_from_slice(tail);
        numpy::ndarray::IxDyn(&d[..lead + 1 + tail.len()])
    };
    let poses = match out {
        Some(o) => caller_array(o, dims(&[4, 4]))?,
        None => new_array(py, dims(&[4, 4]))?,
    };
    // The caller's array is borrowed for writing until the poses are written: writeable, and
    // sharing no memory with the inputs (numpy's borrow checking refuses an overlap with q's
    // read borrow when both are views of one array; `overlaps` finds views of one buffer made
    // otherwise, as by `np.frombuffer`).
    let mut borrowed = match out {
        Some(_) => {
            let borrow = poses
                .try_readwrite()
                .map_err(|e| StateError::new_err(format!("out: {e}")))?;
            for (a, what) in [(Some(&q), "q"), (qd.as_ref(), "qd"), (qdd.as_ref(), "qdd")] {
                if let Some(a) = a
                    && overlaps(a, &poses)
                {
                    return Err(StateError::new_err(format!(
                        "out shares memory with {what}: the poses would overwrite the joint values they are computed from"
                    )));
                }
            }
            Some(borrow)
        }
        None => None,
    };
    let pose_out: &mut [f64] = match borrowed.as_mut() {
        Some(b) => b.as_slice_mut()?,
        // SAFETY: a new array, not yet handed out; every entry is written below before it is
        // (an error drops it unread).
        None => unsafe { entries(&poses)? },
    };
    let rates: Vec<Bound<'py, PyArrayDyn<f64>>> = (0..2 * level)
        .map(|_| new_array(py, dims(&[3])))
        .collect::<PyResult<_>>()?;
    let mut rate_out: [&mut [f64]; 4] = Default::default();
    for (o, a) in rate_out.iter_mut().zip(&rates) {
        // SAFETY: as for the poses: new arrays, each taken once.
        *o = unsafe { entries(a)? };
    }
    let (q, qd, qdd) = (
        q.as_slice()?,
        qd.as_ref().map(|a| a.as_slice()).transpose()?,
        qdd.as_ref().map(|a| a.as_slice()).transpose()?,
    );
    let motion = Motion { q, qd, qdd };
    let mut signals = Signals::default();
    let result = if !batched || inner.dof() == 0 {
        // One configuration: too little work to leave the GIL for, buffers reused. A chain
        // without moving joints has the same poses in every row (the batch kernels cannot count
        // the rows of an empty q).
        robot.with_data(policy, |data| {
            single_rows(inner, data, motion, n, &links, pose_out, &mut rate_out)
        })
    } else if n == 0 {
        Ok(())
    } else {
        let out = LinkArrays {
            poses: pose_out,
            rates: rate_out,
        };
        let selection = &links.selection;
        py.detach(|| {
            with_workers(threads, |workers| {
                write_link_batch(
                    inner,
                    policy,
                    motion,
                    n,
                    selection,
                    out,
                    workers,
                    &mut signals,
                )
            })
        })?
    };
    result.map_err(|e| array_error(e, batched, signals.raised))?;
    drop(borrowed);
    let mut rates = rates.into_iter().map(|a| Some(a.into_any().unbind()));
    let mut next = || rates.next().flatten();
    Ok(FkResult {
        links,
        poses: poses.into_any().unbind(),
        omega: next(),
        v: next(),
        alpha: next(),
        a: next(),
    })
}

/// `out=`: a writeable C-contiguous float64 array of exactly the shape the poses need.
fn caller_array<'py>(
    o: &Bound<'py, PyAny>,
    want: numpy::ndarray::IxDyn,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let a = o
        .cast::<PyArrayDyn<f64>>()
        .map_err(|_| StateError::new_err("out must be a numpy array of float64"))?;
    if a.shape() != want.slice() || !a.is_c_contiguous() {
        return Err(StateError::new_err(format!(
            "out has shape {:?}: expected a writeable C-contiguous float64 array of shape {:?}",
            a.shape(),
            want.slice()
        )));
    }
    Ok(a.clone())
}

/// The `n` configurations of `motion` one by one with the single kernels, into the rows of
/// `poses` and `rates`, then checked to be finite.
fn single_rows(
    chain: &Inner,
    data: &mut Data,
    motion: Motion<'_>,
    n: usize,
    links: &Links,
    poses: &mut [f64],
    rates: &mut [&mut [f64]; 4],
) -> Result<(), ArrayError> {
    let (dof, ids) = (chain.dof(), links.selection.ids());
    let l = ids.len();
    for i in 0..n {
        fn rows_of(a: &[f64], i: usize, dof: usize) -> &[f64] {
            &a[i * dof..(i + 1) * dof]
        }
        let row = |a| rows_of(a, i, dof);
        let motion = Motion {
            q: row(motion.q),
            qd: motion.qd.map(row),
            qdd: motion.qdd.map(row),
        };
        let pose = &mut poses[i * l * 16..(i + 1) * l * 16];
        let [omega, v, alpha, a] = rates.each_mut().map(|r| {
            if r.is_empty() {
                &mut [][..]
            } else {
                &mut r[i * l * 3..(i + 1) * l * 3]
            }
        });
        one(chain, data, motion, ids, pose, [omega, v, alpha, a])
            .map_err(|source| ArrayError::State { index: i, source })?;
    }
    // The rates asked for are the first ones (ω, v, then α, a); no allocation per call.
    let [omega, v, alpha, a] = rates.each_ref().map(|r| &**r);
    let named = [("omega", omega), ("v", v), ("alpha", alpha), ("a", a)];
    let asked = named.iter().take_while(|(_, r)| !r.is_empty()).count();
    let rates = &named[..asked];
    links.selection.check_finite(chain, 0, poses, rates)
}

/// One configuration's poses and rates of `ids`.
fn one(
    chain: &Inner,
    data: &mut Data,
    Motion { q, qd, qdd }: Motion<'_>,
    ids: &[LinkId],
    pose: &mut [f64],
    [omega, v, alpha, a]: [&mut [f64]; 4],
) -> Result<(), KStateError> {
    match (qd, qdd) {
        (None, _) if ids.len() == 1 => {
            let t = forward_kinematics_to(chain, data, q, ids[0])?;
            pose.copy_from_slice(t.to_rows().as_flattened());
            Ok(())
        }
        (None, _) => forward_kinematics(chain, data, q)?.write_matrices(ids, pose),
        (Some(qd), None) => {
            let r = forward_velocities(chain, data, q, qd)?;
            r.poses().write_matrices(ids, pose)?;
            r.write_velocities(ids, omega, v)
        }
        (Some(qd), Some(qdd)) => {
            let r = forward_accelerations(chain, data, q, qd, qdd)?;
            r.poses().write_matrices(ids, pose)?;
            r.velocities().write_velocities(ids, omega, v)?;
            r.write_accelerations(ids, alpha, a)
        }
    }
}
