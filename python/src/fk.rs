//! `Chain.fk`: joint values in, poses and rates of the links asked for out, as numpy arrays
//! written by the core (one configuration with the single kernels; a batch through
//! [`write_link_batch`], without the GIL).

use crate::arrays::{copy_vector, entries, float_array, plain_vector, rows, thread_count};
use crate::errors::{StateError, array_error};
use crate::links::Links;
use crate::outputs::Outputs;
use crate::results::FkResult;
use crate::robot::Robot;
use crate::run::{Signals, with_workers};
use kinechain::eval::batch::{ArrayError, LinkArrays, Motion, write_link_batch};
use kinechain::{
    Chain as Inner, Data, LimitPolicy, LinkId, StateError as KStateError, forward_accelerations,
    forward_kinematics, forward_kinematics_to, forward_velocities,
};
use numpy::{PyArray1, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PySlice, PyString};
use std::sync::Arc;

/// How errors name the arrays of an `FkResult` given as `out=`.
const OUT_NAMES: [&str; 5] = ["out.poses", "out.omega", "out.v", "out.alpha", "out.a"];

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
    if qd.is_none()
        && qdd.is_none()
        && out.is_none()
        && let Some(q) = plain_vector(q, inner.nq())
    {
        let (links, poses) = single_poses(robot, py, q, links, policy, false)?;
        return Ok(FkResult {
            links,
            poses,
            omega: None,
            v: None,
            alpha: None,
            a: None,
        });
    }
    let q = float_array(q, "q")?;
    let qd = qd.map(|a| float_array(a, "qd")).transpose()?;
    let qdd = qdd.map(|a| float_array(a, "qdd")).transpose()?;
    let (n, batched) = rows(inner, &q, "q")?;
    for (a, what) in [(&qd, "qd"), (&qdd, "qdd")] {
        if let Some(a) = a {
            let rate_rows = rows(inner, a, what)?;
            if rate_rows != (n, batched) {
                return Err(StateError::new_err(format!(
                    "{what} has shape {:?}, q {:?}: they must have the same rows",
                    a.shape(),
                    q.shape()
                )));
            }
        }
    }
    if qdd.is_some() && qd.is_none() {
        return Err(StateError::new_err(
            "qdd needs qd (accelerations depend on velocities)",
        ));
    }
    let level = usize::from(qd.is_some()) + usize::from(qdd.is_some());
    let links = robot.links(py, links)?;
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
    let shapes = [
        dims(&[4, 4]),
        dims(&[3]),
        dims(&[3]),
        dims(&[3]),
        dims(&[3]),
    ];
    let shapes = &shapes[..1 + 2 * level];
    let inputs: Vec<(&PyReadonlyArrayDyn<'py, f64>, &str)> =
        [(Some(&q), "q"), (qd.as_ref(), "qd"), (qdd.as_ref(), "qdd")]
            .into_iter()
            .filter_map(|(a, n)| a.map(|a| (a, n)))
            .collect();
    let mut outputs = match out {
        None => Outputs::new(py, shapes)?,
        Some(o) => match o.cast::<FkResult>() {
            Ok(r) => {
                let given = r.get().outputs(py, &links, level)?;
                Outputs::caller(&given, &OUT_NAMES, shapes, &inputs)?
            }
            Err(_) => Outputs::caller(std::slice::from_ref(o), &["out"], &shapes[..1], &inputs)?
                .then_new(py, &shapes[1..])?,
        },
    };
    let [pose_out, omega, v, alpha, a] = outputs.slices()?;
    let mut rate_out = [omega, v, alpha, a];
    let (q, qd, qdd) = (
        q.as_slice()?,
        qd.as_ref().map(|a| a.as_slice()).transpose()?,
        qdd.as_ref().map(|a| a.as_slice()).transpose()?,
    );
    let motion = Motion { q, qd, qdd };
    let mut signals = Signals::default();
    let result = if !batched || inner.nq() == 0 {
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
    let mut arrays = outputs.into_arrays();
    let poses = arrays
        .next()
        .ok_or_else(|| crate::errors::Error::new_err("no poses"))?;
    let mut next = || arrays.next();
    Ok(FkResult {
        links,
        poses,
        omega: next(),
        v: next(),
        alpha: next(),
        a: next(),
    })
}

/// `Chain.pose`: one link's pose, `(4, 4)` or `(N, 4, 4)`.
pub(crate) fn pose<'py>(
    robot: &Robot,
    py: Python<'py>,
    q: &Bound<'py, PyAny>,
    link: &Bound<'py, PyString>,
    policy: LimitPolicy,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Py<PyAny>> {
    // (`threads=` is checked on every path, though one configuration runs on this thread.)
    thread_count(threads)?;
    if let Some(v) = plain_vector(q, robot.inner.nq()) {
        return Ok(single_poses(robot, py, v, Some(link.as_any()), policy, true)?.1);
    }
    let r = fk(
        robot,
        py,
        (q, None, None),
        Some(link.as_any()),
        policy,
        threads,
        None,
    )?;
    let full = PySlice::full(py);
    let key = (py.Ellipsis(), 0, full.clone(), full);
    Ok(r.poses.bind(py).get_item(key)?.unbind())
}

/// The poses of one configuration given as a plain float64 vector: the common call, made
/// without borrowing `q` (it is copied into the chain's buffer) or building rate arrays, into
/// a spare array when one is free. `(L, 4, 4)`, or `(4, 4)` when `one` (one link asked for).
fn single_poses<'py>(
    robot: &Robot,
    py: Python<'py>,
    q: &Bound<'py, PyArray1<f64>>,
    links: Option<&Bound<'py, PyAny>>,
    policy: LimitPolicy,
    one_link: bool,
) -> PyResult<(Arc<Links>, Py<PyAny>)> {
    let inner = &robot.inner;
    robot.with_reused(|r| {
        let (links, spare) = r.links.get(py, inner, links)?;
        let links = Arc::clone(links);
        let ids = links.selection.ids();
        let poses = match one_link {
            true => spare.take(py, numpy::ndarray::Ix2(4, 4))?,
            false => spare.take(py, numpy::ndarray::Ix3(ids.len(), 4, 4))?,
        };
        // SAFETY: a new array, or a spare that nothing else refers to; every entry is written
        // below before it is read (an error drops it unread).
        let dst = unsafe { entries(&poses)? };
        let s = r.scratch(inner, policy);
        copy_vector(q, &mut s.q)?;
        let motion = Motion {
            q: &s.q,
            qd: None,
            qdd: None,
        };
        one(inner, &mut s.data, motion, ids, dst, Default::default())
            .map_err(|source| ArrayError::State { index: 0, source })
            .and_then(|()| links.selection.check_finite(inner, 0, dst, &[]))
            .map_err(|e| array_error(e, false, None))?;
        Ok((links, poses.into_any().unbind()))
    })
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
    let (nq, nv, ids) = (chain.nq(), chain.nv(), links.selection.ids());
    let l = ids.len();
    for i in 0..n {
        fn rows_of(a: &[f64], i: usize, width: usize) -> &[f64] {
            &a[i * width..(i + 1) * width]
        }
        let rate = |a| rows_of(a, i, nv);
        let motion = Motion {
            q: rows_of(motion.q, i, nq),
            qd: motion.qd.map(rate),
            qdd: motion.qdd.map(rate),
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
