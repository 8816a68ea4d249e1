//! `Chain.random`, `Chain.to_layout` and `Chain.from_layout`: random configurations, and joint
//! vectors in Pinocchio's and MuJoCo's layouts (the core's [`kinechain::eval::layouts`]), one
//! configuration or rows of them.

use crate::arrays::float_array;
use crate::chain::Chain;
use crate::errors::{Error, StateError};
use kinechain::eval::layouts::{JointState, Layout};
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// `layout=` as the core's.
fn layout_of(name: &str) -> PyResult<Layout> {
    match name {
        "pinocchio" => Ok(Layout::Pinocchio),
        "mujoco" => Ok(Layout::Mujoco),
        other => Err(Error::new_err(format!(
            "layout must be \"pinocchio\" or \"mujoco\", not {other:?}"
        ))),
    }
}

/// The rows of an array of `shape` (`(n,)` or `(N, n)`), named `what` in errors.
fn rows_of(shape: &[usize], what: &str) -> PyResult<(usize, bool)> {
    match shape {
        [_] => Ok((1, false)),
        [n, _] => Ok((*n, true)),
        _ => Err(StateError::new_err(format!(
            "{what} has shape {shape:?}: expected one configuration or rows of them"
        ))),
    }
}

/// A vector, or rows of vectors of `width` entries, as numpy.
fn to_array<'py>(
    py: Python<'py>,
    flat: Vec<f64>,
    rows: usize,
    batched: bool,
    width: usize,
) -> PyResult<Bound<'py, PyAny>> {
    if batched {
        let a = PyArray1::from_vec(py, flat);
        Ok(a.reshape([rows, width])?.into_any())
    } else {
        Ok(PyArray1::from_vec(py, flat).into_any())
    }
}

/// Converts `q` (and `qd`, `qdd`) row by row with `convert`, the inputs `n_in` wide per row
/// (`q`, rates) and the outputs `n_out`.
#[allow(clippy::type_complexity)]
fn convert<'py>(
    py: Python<'py>,
    (q, qd, qdd): (
        &Bound<'py, PyAny>,
        Option<&Bound<'py, PyAny>>,
        Option<&Bound<'py, PyAny>>,
    ),
    n_in: (usize, usize),
    n_out: (usize, usize),
    convert: impl Fn(
        &[f64],
        Option<&[f64]>,
        Option<&[f64]>,
    ) -> Result<JointState, kinechain::StateError>,
) -> PyResult<Bound<'py, PyTuple>> {
    let q = float_array(q, "q")?;
    let qd = qd
        .filter(|x| !x.is_none())
        .map(|a| float_array(a, "qd"))
        .transpose()?;
    let qdd = qdd
        .filter(|x| !x.is_none())
        .map(|a| float_array(a, "qdd"))
        .transpose()?;
    if qdd.is_some() && qd.is_none() {
        return Err(StateError::new_err(
            "qdd needs qd (the conversion of accelerations depends on velocities)",
        ));
    }
    let (rows, batched) = rows_of(q.shape(), "q")?;
    let width = |a: &numpy::PyReadonlyArrayDyn<'_, f64>| *a.shape().last().unwrap_or(&0);
    if width(&q) != n_in.0 {
        // The core's message says what makes up a configuration.
        let first = &q.as_slice()?[..width(&q)];
        let message = match convert(first, None, None) {
            Err(e) => kinechain::error::error_chain(&e),
            Ok(_) => format!(
                "q has {} entries per configuration, not {}",
                width(&q),
                n_in.0
            ),
        };
        return Err(StateError::new_err(message));
    }
    for (a, what) in [(&qd, "qd"), (&qdd, "qdd")] {
        if let Some(a) = a
            && (rows_of(a.shape(), what)? != (rows, batched) || width(a) != n_in.1)
        {
            return Err(StateError::new_err(format!(
                "{what} has shape {:?}: expected the rows of q, of {} entries",
                a.shape(),
                n_in.1
            )));
        }
    }
    let (q, qd, qdd) = (
        q.as_slice()?,
        qd.as_ref().map(|a| a.as_slice()).transpose()?,
        qdd.as_ref().map(|a| a.as_slice()).transpose()?,
    );
    let mut out: [Vec<f64>; 3] = Default::default();
    for i in 0..rows {
        let row = |x: &[f64], w: usize| x[i * w..(i + 1) * w].to_vec();
        let s = convert(
            &row(q, n_in.0),
            qd.map(|x| row(x, n_in.1)).as_deref(),
            qdd.map(|x| row(x, n_in.1)).as_deref(),
        )
        .map_err(|e| {
            let at = if batched {
                format!("row {i}: ")
            } else {
                String::new()
            };
            StateError::new_err(format!("{at}{}", kinechain::error::error_chain(&e)))
        })?;
        out[0].extend(s.q);
        out[1].extend(s.q_dot.unwrap_or_default());
        out[2].extend(s.q_ddot.unwrap_or_default());
    }
    let [oq, oqd, oqdd] = out;
    let q = to_array(py, oq, rows, batched, n_out.0)?;
    let rate = |x: Vec<f64>, given: bool| -> PyResult<Bound<'py, PyAny>> {
        if given {
            to_array(py, x, rows, batched, n_out.1)
        } else {
            Ok(py.None().into_bound(py))
        }
    };
    PyTuple::new(
        py,
        [q, rate(oqd, qd.is_some())?, rate(oqdd, qdd.is_some())?],
    )
}

#[pymethods]
impl Chain {
    /// Random configurations: `(nq,)`, or `(n, nq)` for `n` of them, the same for the same
    /// `seed`. Each joint coordinate uniform within its limits ([-π, π] without limits, the 2π
    /// beside a single bound); a floating joint's position uniform in `base` (low, high) along
    /// each axis and its orientation a uniformly random rotation.
    #[pyo3(signature = (n=None, *, seed=0, base=(-1.0, 1.0)))]
    fn random<'py>(
        &self,
        py: Python<'py>,
        n: Option<usize>,
        seed: u64,
        base: (f64, f64),
    ) -> PyResult<Bound<'py, PyAny>> {
        let inner = &self.robot.inner;
        if !(base.0.is_finite() && base.1.is_finite() && base.0 <= base.1) {
            return Err(Error::new_err(format!(
                "base must be a finite (low, high) with low <= high, not {base:?}"
            )));
        }
        let count = n.unwrap_or(1);
        let nq = inner.nq();
        if count
            .checked_mul(nq)
            .is_none_or(|x| x > isize::MAX as usize / 8)
        {
            return Err(pyo3::exceptions::PyMemoryError::new_err(
                "too many configurations",
            ));
        }
        let qs = py.detach(|| inner.random_configurations(count, seed, base));
        let a = PyArray1::from_vec(py, qs);
        match n {
            None => Ok(a.into_any()),
            Some(n) => Ok(a.reshape([n, nq])?.into_any()),
        }
    }

    /// `(q, qd, qdd)` (`None` where not given) in another library's layout: `"pinocchio"` (a
    /// model from `buildModelFromUrdf`, with `JointModelFreeFlyer` for a floating base) or
    /// `"mujoco"` (`qpos`, `qvel`, `qacc`). One configuration or rows of them.
    #[pyo3(signature = (q, qd=None, qdd=None, *, layout))]
    fn to_layout<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        qd: Option<&Bound<'py, PyAny>>,
        qdd: Option<&Bound<'py, PyAny>>,
        layout: &str,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let inner = &self.robot.inner;
        let layout = layout_of(layout)?;
        convert(
            py,
            (q, qd, qdd),
            (inner.nq(), inner.nv()),
            inner.layout_sizes(layout),
            |q, qd, qdd| inner.to_layout(layout, q, qd, qdd),
        )
    }

    /// The inverse of `to_layout`: kinechain's `(q, qd, qdd)` from another library's.
    #[pyo3(signature = (q, qd=None, qdd=None, *, layout))]
    #[allow(clippy::wrong_self_convention)] // the chain converts; the name says from what
    fn from_layout<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        qd: Option<&Bound<'py, PyAny>>,
        qdd: Option<&Bound<'py, PyAny>>,
        layout: &str,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let inner = &self.robot.inner;
        let layout = layout_of(layout)?;
        convert(
            py,
            (q, qd, qdd),
            inner.layout_sizes(layout),
            (inner.nq(), inner.nv()),
            |q, qd, qdd| inner.from_layout(layout, q, qd, qdd),
        )
    }
}
