//! `base=` of `Chain.fk` and `Chain.jacobian`: the links' motion relative to another link, in
//! its frame. `fk` evaluates the links and the base in one call and composes the results here
//! (`base_from_link = world_from_baseᵀ world_from_link`, and the relative rates of
//! `kinechain::Velocities::velocity_relative` and `Accelerations::acceleration_relative`, the
//! same formulas on the arrays); `jacobian` calls the core's `Poses::jacobian_relative`.

use crate::arrays::{float_array, rows};
use crate::errors::{Error, StateError, error};
use crate::links::Links;
use crate::results::FkResult;
use crate::robot::Robot;
use kinechain::nalgebra::{Matrix3, Vector3};
use kinechain::{JacobianFrame, LimitPolicy, forward_kinematics};
use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyString};
use std::sync::Arc;

/// The names `links=` asks for (every link for `None`).
fn names(robot: &Robot, links: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<String>> {
    match links {
        None => Ok(robot
            .inner
            .links()
            .iter()
            .map(|l| l.name().to_string())
            .collect()),
        Some(l) if l.is_instance_of::<PyString>() => Ok(vec![l.extract()?]),
        Some(l) => l.try_iter()?.map(|x| x?.extract::<String>()).collect(),
    }
}

/// A `(.., k, w)` array's rows `(.., k)` as `(n, k, w)` flat.
fn flat(a: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let a = a.cast::<PyArrayDyn<f64>>()?.readonly();
    Ok(a.as_slice()?.to_vec())
}

fn vec3(s: &[f64]) -> Vector3<f64> {
    Vector3::new(s[0], s[1], s[2])
}

/// `Chain.fk(..., base=)`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn fk_relative<'py>(
    robot: &Robot,
    py: Python<'py>,
    given: (
        &Bound<'py, PyAny>,
        Option<&Bound<'py, PyAny>>,
        Option<&Bound<'py, PyAny>>,
    ),
    links: Option<&Bound<'py, PyAny>>,
    base: &str,
    policy: LimitPolicy,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<FkResult> {
    let chain = &robot.inner;
    chain.link_id(base).map_err(|e| error(&e))?;
    let names = names(robot, links)?;
    let mut asked = names.clone();
    asked.push(base.to_string());
    let list = PyList::new(py, &asked)?;
    let world = crate::fk::fk(robot, py, given, Some(list.as_any()), policy, threads, None)?;
    let k = names.len();
    let poses = world.poses.bind(py);
    let shape: Vec<usize> = poses.cast::<PyArrayDyn<f64>>()?.shape().to_vec();
    let lead = &shape[..shape.len() - 3];
    let n: usize = lead.iter().product();
    let p = flat(poses)?;
    let get = |x: &Option<Py<PyAny>>| x.as_ref().map(|a| flat(a.bind(py))).transpose();
    let (w, v, al, a) = (
        get(&world.omega)?,
        get(&world.v)?,
        get(&world.alpha)?,
        get(&world.a)?,
    );
    let mut out_p = vec![0.0; n * k * 16];
    let mut out_w = w.as_ref().map(|_| vec![0.0; n * k * 3]);
    let mut out_v = v.as_ref().map(|_| vec![0.0; n * k * 3]);
    let mut out_al = al.as_ref().map(|_| vec![0.0; n * k * 3]);
    let mut out_a = a.as_ref().map(|_| vec![0.0; n * k * 3]);
    for row in 0..n {
        let m = |l: usize| &p[(row * (k + 1) + l) * 16..(row * (k + 1) + l + 1) * 16];
        let rot = |m: &[f64]| Matrix3::new(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
        let pos = |m: &[f64]| Vector3::new(m[3], m[7], m[11]);
        let (rb, pb) = (rot(m(k)), pos(m(k)));
        let rt = rb.transpose();
        let r3 = |x: &[f64], l: usize| vec3(&x[(row * (k + 1) + l) * 3..]);
        for l in 0..k {
            let (rl, pl) = (rot(m(l)), pos(m(l)));
            let (r, o) = (rt * rl, rt * (pl - pb));
            let dst = &mut out_p[(row * k + l) * 16..(row * k + l + 1) * 16];
            for i in 0..3 {
                for j in 0..3 {
                    dst[4 * i + j] = r[(i, j)];
                }
                dst[4 * i + 3] = o[i];
            }
            dst[12..].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
            let d = pl - pb;
            let at = (row * k + l) * 3;
            if let (Some(w), Some(v), Some(ow), Some(ov)) = (&w, &v, &mut out_w, &mut out_v) {
                let (wl, wb, vl, vb) = (r3(w, l), r3(w, k), r3(v, l), r3(v, k));
                ow[at..at + 3].copy_from_slice((rt * (wl - wb)).as_slice());
                ov[at..at + 3].copy_from_slice((rt * (vl - vb - wb.cross(&d))).as_slice());
                if let (Some(al), Some(a), Some(oal), Some(oa)) = (&al, &a, &mut out_al, &mut out_a)
                {
                    let (all, alb, accl, accb) = (r3(al, l), r3(al, k), r3(a, l), r3(a, k));
                    let d_dot = vl - vb;
                    oal[at..at + 3].copy_from_slice((rt * (all - alb - wb.cross(&wl))).as_slice());
                    let rel = accl
                        - accb
                        - alb.cross(&d)
                        - wb.cross(&wb.cross(&d))
                        - 2.0 * wb.cross(&(d_dot - wb.cross(&d)));
                    oa[at..at + 3].copy_from_slice((rt * rel).as_slice());
                }
            }
        }
    }
    let make = |data: Vec<f64>, tail: &[usize]| -> PyResult<Py<PyAny>> {
        let mut dims: Vec<usize> = lead.to_vec();
        dims.push(k);
        dims.extend_from_slice(tail);
        Ok(numpy::PyArray1::from_vec(py, data)
            .reshape(dims)?
            .into_any()
            .unbind())
    };
    let links = Links::new(py, chain, names, Vec::new())?;
    Ok(FkResult {
        links: Arc::new(links),
        poses: make(out_p, &[4, 4])?,
        omega: out_w.map(|x| make(x, &[3])).transpose()?,
        v: out_v.map(|x| make(x, &[3])).transpose()?,
        alpha: out_al.map(|x| make(x, &[3])).transpose()?,
        a: out_a.map(|x| make(x, &[3])).transpose()?,
    })
}

/// `Chain.jacobian(..., base=)`: `(6, dof)` or `(N, 6, dof)`, rows `[v; ω]` of the motion
/// relative to `base`, in its axes.
#[allow(clippy::too_many_arguments)]
pub(crate) fn jacobian_relative<'py>(
    robot: &Robot,
    py: Python<'py>,
    q: &Bound<'py, PyAny>,
    link: &str,
    base: &str,
    point: Option<[f64; 3]>,
    frame: &str,
    policy: LimitPolicy,
) -> PyResult<Py<PyAny>> {
    let chain = &robot.inner;
    if frame != "world" {
        return Err(Error::new_err(
            "with base, the Jacobian is in the base's axes: frame must be \"world\" (the default)",
        ));
    }
    let frame = match point {
        None => JacobianFrame::World,
        Some(u) if u.iter().all(|x| x.is_finite()) => JacobianFrame::Point(u),
        Some(u) => return Err(Error::new_err(format!("point {u:?} is not finite"))),
    };
    let (l, b) = (
        chain.link_id(link).map_err(|e| error(&e))?,
        chain.link_id(base).map_err(|e| error(&e))?,
    );
    let q = float_array(q, "q")?;
    let (n, batched) = rows(chain, &q, "q")?;
    let q = q.as_slice()?;
    let (nq, dof) = (chain.nq(), chain.nv());
    let mut out = vec![0.0; n * 6 * dof];
    let result: Result<(), kinechain::StateError> = py.detach(|| {
        let mut data = kinechain::Data::new(chain).with_limit_policy(policy);
        for (row, dst) in out.chunks_exact_mut(6 * dof.max(1)).enumerate().take(n) {
            let poses = forward_kinematics(chain, &mut data, &q[row * nq..(row + 1) * nq])?;
            let j = poses.jacobian_relative(l, b, frame);
            for r in 0..6 {
                for c in 0..dof {
                    dst[r * dof + c] = j[(r, c)];
                }
            }
        }
        Ok(())
    });
    result.map_err(|e| StateError::new_err(kinechain::error::error_chain(&e)))?;
    let dims: Vec<usize> = if batched {
        vec![n, 6, dof]
    } else {
        vec![6, dof]
    };
    Ok(numpy::PyArray1::from_vec(py, out)
        .reshape(dims)?
        .into_any()
        .unbind())
}
