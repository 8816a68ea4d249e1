//! The `Chain` class: loading, pickling, names and limits; its evaluations are in [`crate::fk`]
//! and [`crate::jacobian`].

use crate::arrays::{float_array, rows};
use crate::errors::{Error, LoadError, load_error};
use crate::files;
use crate::results::FkResult;
use crate::robot::{Robot, policy};
use kinechain::Chain as Inner;
use kinechain::error::error_chain;
use kinechain::regression::variable_names;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyString, PyTuple};
use std::path::PathBuf;

/// A robot: links, joints, limits; immutable, shared between threads. Made by `kinechain.load`
/// or the `from_*` methods.
#[pyclass(module = "kinechain", name = "Chain", frozen)]
pub(crate) struct Chain {
    /// The chain, its links and its buffers: what evaluations use.
    pub(crate) robot: Robot,
    /// The text it was loaded from, and its format (`urdf` or `yaml`): what pickling ships
    /// (with the name, which may have come from the file name).
    source: String,
    format: &'static str,
    /// The file it was loaded from, which the files this package writes never replace.
    pub(crate) origin: Option<PathBuf>,
}

impl Chain {
    fn new(
        py: Python<'_>,
        inner: Inner,
        source: String,
        format: &'static str,
        origin: Option<PathBuf>,
    ) -> PyResult<Self> {
        Ok(Chain {
            robot: Robot::new(py, inner)?,
            source,
            format,
            origin,
        })
    }

    /// A chain from `text` in `format` (`urdf` or `yaml`), named `name` where the text names no
    /// robot.
    fn from_text(py: Python<'_>, text: String, format: &str, name: &str) -> PyResult<Self> {
        use kinechain::io::Format;
        let (kind, format) = match format {
            "urdf" => (Format::Urdf, "urdf"),
            "yaml" => (Format::DhYaml, "yaml"),
            other => {
                return Err(Error::new_err(format!(
                    "unknown format '{other}' (urdf or yaml)"
                )));
            }
        };
        let inner = Inner::from_str_named(&text, kind, name).map_err(|e| load_error(&e))?;
        Chain::new(py, inner, text, format, None)
    }
}

#[pymethods]
impl Chain {
    /// Loads a robot file: a DH table (`.yaml`, `.yml`) or a URDF file (`.urdf`).
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        // Read once (a FIFO can be read only once), bounded, off the GIL and open to Ctrl-C.
        let read = path.clone();
        let source = files::read_interruptibly(py, move || {
            kinechain::io::read_robot_file(&read).map_err(|e| error_chain(&e))
        })?
        .map_err(LoadError::new_err)?;
        let inner = Inner::from_file_text(&path, &source).map_err(|e| load_error(&e))?;
        let format = match kinechain::io::Format::from_path(&path) {
            Some(kinechain::io::Format::Urdf) => "urdf",
            _ => "yaml",
        };
        let origin = std::fs::canonicalize(&path).ok().or(Some(path));
        Chain::new(py, inner, source, format, origin)
    }

    /// A robot from URDF text.
    #[staticmethod]
    fn from_urdf_string(py: Python<'_>, text: String) -> PyResult<Self> {
        Chain::from_text(py, text, "urdf", "robot")
    }

    /// A robot from DH YAML text.
    #[staticmethod]
    fn from_yaml_string(py: Python<'_>, text: String) -> PyResult<Self> {
        Chain::from_text(py, text, "yaml", "robot")
    }

    /// A robot from its text, format (`urdf` or `yaml`) and name (where the text names none);
    /// what unpickling calls.
    #[staticmethod]
    #[pyo3(signature = (text, format, name="robot"))]
    fn _from_source(py: Python<'_>, text: String, format: &str, name: &str) -> PyResult<Self> {
        Chain::from_text(py, text, format, name)
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let make = slf.get_type().getattr("_from_source")?;
        let me = slf.get();
        (make, (me.source.clone(), me.format, me.robot.inner.name())).into_pyobject(slf.py())
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<Chain>().is_ok_and(|o| {
            let o = o.get();
            o.source == self.source
                && o.format == self.format
                && o.robot.inner.name() == self.robot.inner.name()
        })
    }

    fn __hash__(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        (&self.source, self.format, self.robot.inner.name()).hash(&mut h);
        h.finish()
    }

    fn __repr__(&self) -> String {
        format!(
            "Chain(name='{}', dof={}, links={})",
            kinechain::error::escape_controls(self.robot.inner.name()).replace('\'', "\\'"),
            self.robot.inner.dof(),
            self.robot.inner.links().len()
        )
    }

    /// The robot's name.
    #[getter]
    fn name(&self) -> String {
        self.robot.inner.name().to_string()
    }

    /// Entries of a configuration `q`.
    #[getter]
    fn dof(&self) -> usize {
        self.robot.inner.dof()
    }

    /// The name of each entry of `q`, in order: the independent joints depth-first from the root
    /// (as `kinechain info` lists them); a cylindrical joint's two as `NAME.theta`, `NAME.d`.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        variable_names(&self.robot.inner)
    }

    /// Every link, in the chain's order.
    #[getter]
    fn link_names(&self) -> Vec<String> {
        self.robot
            .inner
            .links()
            .iter()
            .map(|l| l.name().to_string())
            .collect()
    }

    /// Smallest admitted value of each entry of `q` (-inf where unlimited).
    #[getter]
    fn lower<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.robot.inner.lower())
    }

    /// Largest admitted value of each entry of `q` (inf where unlimited).
    #[getter]
    fn upper<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.robot.inner.upper())
    }

    /// A configuration inside the limits (0 where admitted, else the middle of the range).
    fn neutral<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.robot.inner.neutral())
    }

    /// Poses (and with `qd`, `qdd` velocities and accelerations) of the links; see the
    /// package's documentation of `Chain.fk`.
    #[pyo3(signature = (q, qd=None, qdd=None, *, links=None, check_limits=true, threads=None, out=None))]
    #[allow(clippy::too_many_arguments)]
    fn fk<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        qd: Option<&Bound<'py, PyAny>>,
        qdd: Option<&Bound<'py, PyAny>>,
        links: Option<&Bound<'py, PyAny>>,
        check_limits: bool,
        threads: Option<&Bound<'py, PyAny>>,
        out: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<FkResult> {
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
        let dof = chain.dof();
        let q = q.as_slice()?;
        let ok: Vec<bool> = (0..n)
            .map(|i| kinechain::check_q(chain, &q[i * dof..(i + 1) * dof], policy).is_ok())
            .collect();
        Ok(PyArray1::from_vec(py, ok))
    }

    /// The geometric Jacobian of `link`: `(6, dof)` or `(N, 6, dof)`, rows v then ω, so that
    /// `[v; ω] = J q̇`. `frame="world"` (default): v of the link origin (or of `point`, link
    /// coordinates) and ω in world axes; `frame="link"`: both in the link's own axes. A batch
    /// runs the batch kernels without the GIL and writes straight into the returned array (or
    /// into `out`, a C-contiguous float64 array of that shape).
    #[pyo3(signature = (q, link, *, frame="world", point=None, check_limits=true, threads=None, out=None))]
    #[allow(clippy::too_many_arguments)]
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        link: &str,
        frame: &str,
        point: Option<[f64; 3]>,
        check_limits: bool,
        threads: Option<&Bound<'py, PyAny>>,
        out: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
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
