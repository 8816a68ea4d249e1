//! The `Chain` class's evaluations: `fk`, `poses`, `pose`, `jacobian` (their work in
//! [`crate::fk`] and [`crate::jacobian`]), and the check of rows of `q`.

use crate::arrays::{float_array, rows};
use crate::chain::Chain;
use crate::results::FkResult;
use crate::robot::policy;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyString;

#[pymethods]
impl Chain {
    /// Poses (and with `qd`, `qdd` velocities and accelerations) of the links; see the
    /// package's documentation of `Chain.fk`.
    #[pyo3(signature = (q, qd=None, qdd=None, *, links=None, base=None, check_limits=true, threads=None, out=None))]
    #[allow(clippy::too_many_arguments)]
    fn fk<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        qd: Option<&Bound<'py, PyAny>>,
        qdd: Option<&Bound<'py, PyAny>>,
        links: Option<&Bound<'py, PyAny>>,
        base: Option<&str>,
        check_limits: bool,
        threads: Option<&Bound<'py, PyAny>>,
        out: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<FkResult> {
        if let Some(base) = base {
            if out.is_some() {
                return Err(crate::errors::Error::new_err(
                    "out= is not taken with base=",
                ));
            }
            return crate::relative::fk_relative(
                &self.robot,
                py,
                (q, qd, qdd),
                links,
                base,
                policy(check_limits),
                threads,
            );
        }
        crate::fk::fk(
            &self.robot,
            py,
            (q, qd, qdd),
            links,
            policy(check_limits),
            threads,
            out,
        )
    }

    /// The poses `world_from_link` of the links asked for, `(L, 4, 4)` for one configuration or
    /// `(N, L, 4, 4)` for rows of them: `fk(q, ...).poses` without the result object.
    #[pyo3(signature = (q, *, links=None, check_limits=true, threads=None, out=None))]
    fn poses<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        links: Option<&Bound<'py, PyAny>>,
        check_limits: bool,
        threads: Option<&Bound<'py, PyAny>>,
        out: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        let r = crate::fk::fk(
            &self.robot,
            py,
            (q, None, None),
            links,
            policy(check_limits),
            threads,
            out,
        )?;
        Ok(r.poses)
    }

    /// The pose `world_from_link` of one link, `(4, 4)` for one configuration or `(N, 4, 4)`
    /// for rows of them: `fk(q, links=[link]).poses[..., 0, :, :]` in one call.
    #[pyo3(signature = (q, link, *, check_limits=true, threads=None))]
    fn pose<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        link: &Bound<'py, PyString>,
        check_limits: bool,
        threads: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        crate::fk::pose(&self.robot, py, q, link, policy(check_limits), threads)
    }

    /// For each row of `q` (`(N, dof)`), whether `fk` would accept it: finite, and within the
    /// limits when `check_limits`.
    #[pyo3(signature = (q, check_limits=true))]
    fn _admitted<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        check_limits: bool,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let chain = &self.robot.inner;
        let q = float_array(q, "q")?;
        let (n, _) = rows(chain, &q, "q")?;
        let policy = policy(check_limits);
        let nq = chain.nq();
        let q = q.as_slice()?;
        let ok: Vec<bool> = (0..n)
            .map(|i| kinechain::check_q(chain, &q[i * nq..(i + 1) * nq], policy).is_ok())
            .collect();
        Ok(PyArray1::from_vec(py, ok))
    }

    /// The geometric Jacobian of `link`: `(6, dof)` or `(N, 6, dof)`, rows v then ω, so that
    /// `[v; ω] = J q̇`. `frame="world"` (default): v of the link origin (or of `point`, link
    /// coordinates) and ω in world axes; `frame="link"`: both in the link's own axes. A batch
    /// runs the batch kernels without the GIL and writes straight into the returned array (or
    /// into `out`, a C-contiguous float64 array of that shape).
    #[pyo3(signature = (q, link, *, frame="world", point=None, base=None, check_limits=true, threads=None, out=None))]
    #[allow(clippy::too_many_arguments)]
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        link: &str,
        frame: &str,
        point: Option<[f64; 3]>,
        base: Option<&str>,
        check_limits: bool,
        threads: Option<&Bound<'py, PyAny>>,
        out: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        if let Some(base) = base {
            if out.is_some() {
                return Err(crate::errors::Error::new_err(
                    "out= is not taken with base=",
                ));
            }
            return crate::relative::jacobian_relative(
                &self.robot,
                py,
                q,
                link,
                base,
                point,
                frame,
                policy(check_limits),
            );
        }
        crate::jacobian::jacobian(
            &self.robot,
            py,
            q,
            link,
            (frame, point),
            policy(check_limits),
            threads,
            out,
        )
    }
}
