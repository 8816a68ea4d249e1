//! `kinechain._kinechain`, the compiled half of the Python package: a `Chain` class over
//! `kinechain::Chain` whose evaluations take and return numpy arrays, running with the GIL
//! released (on all cores for a batch of configurations, or as many threads as asked). The
//! Python half (`kinechain/__init__.py`) adds the result class and the array-like conversions.
//!
//! Nothing here panics on what a user passes: shapes, lengths, names, non-finite values and
//! values out of limits are checked and raised as `kinechain.StateError` / `kinechain.Error`,
//! files as `kinechain.LoadError`.

use kinechain::eval::batch::{
    BatchData, forward_kinematics_batch, forward_kinematics_batch_par, forward_kinematics_batch_to,
    forward_kinematics_batch_to_par,
};
use kinechain::regression::{self, variable_names};
use kinechain::{
    Chain as Inner, Data, LimitPolicy, LinkId, StateError as KStateError, Transform,
    error::error_chain, forward_accelerations, forward_kinematics, forward_kinematics_to,
    forward_velocities,
};
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use rayon::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;

pyo3::create_exception!(
    kinechain,
    Error,
    PyValueError,
    "Any error of kinechain (a ValueError)."
);
pyo3::create_exception!(
    kinechain,
    LoadError,
    Error,
    "A robot file or text that cannot be loaded; the message names the file, line, column and joint."
);
pyo3::create_exception!(
    kinechain,
    StateError,
    Error,
    "Joint values that cannot be evaluated (wrong shape or length, not finite, out of limits); the message names the joint."
);

fn load_error(e: &dyn std::error::Error) -> PyErr {
    LoadError::new_err(error_chain(e))
}

fn state_error(e: &dyn std::error::Error) -> PyErr {
    StateError::new_err(error_chain(e))
}

/// A robot: links, joints, limits; immutable, shared between threads. Made by `kinechain.load`
/// or the `from_*` methods.
#[pyclass(module = "kinechain", name = "Chain", frozen)]
struct Chain {
    inner: Arc<Inner>,
    /// The text it was loaded from, and its format (`urdf` or `yaml`): what pickling ships.
    source: String,
    format: &'static str,
}

impl Chain {
    fn from_text(text: String, format: &str) -> PyResult<Self> {
        let (inner, format) = match format {
            "urdf" => (Inner::from_urdf_str(&text), "urdf"),
            "yaml" => (Inner::from_dh_yaml_str(&text), "yaml"),
            other => {
                return Err(Error::new_err(format!(
                    "unknown format '{other}' (urdf or yaml)"
                )));
            }
        };
        let inner = inner.map_err(|e| load_error(&e))?;
        Ok(Chain {
            inner: Arc::new(inner),
            source: text,
            format,
        })
    }

    fn link_ids(&self, links: Option<Vec<String>>) -> PyResult<(Vec<LinkId>, Vec<String>)> {
        let chain = &*self.inner;
        let names: Vec<String> = match links {
            Some(names) => names,
            None => chain.links().iter().map(|l| l.name().to_string()).collect(),
        };
        let ids = names
            .iter()
            .map(|n| chain.link_id(n).map_err(|e| Error::new_err(e.to_string())))
            .collect::<PyResult<Vec<_>>>()?;
        Ok((ids, names))
    }
}

/// The rows of a `(dof,)` or `(N, dof)` array: `(N, batched)`.
fn rows(chain: &Inner, a: &PyReadonlyArrayDyn<'_, f64>, what: &str) -> PyResult<(usize, bool)> {
    let shape = a.shape();
    let dof = chain.dof();
    let (n, batched, len) = match shape {
        [len] => (1, false, *len),
        [n, len] => (*n, true, *len),
        _ => {
            return Err(StateError::new_err(format!(
                "{what} has shape {shape:?}: expected ({dof},) or (N, {dof})"
            )));
        }
    };
    if len != dof {
        return Err(StateError::new_err(format!(
            "{what} has {len} entries per configuration; the chain '{}' has {dof} degrees of freedom (joints in q order: {})",
            chain.name(),
            variable_names(chain).join(", ")
        )));
    }
    Ok((n, batched))
}

/// A view of an output array written by several threads, each at rows of its own.
#[derive(Clone, Copy)]
struct Out {
    ptr: *mut f64,
    len: usize,
}
// SAFETY: every thread writes a range of its own (one configuration's rows), and the array
// outlives the evaluation (it is written with the GIL released but held by the caller's frame).
unsafe impl Send for Out {}
unsafe impl Sync for Out {}

impl Out {
    fn new(a: &Bound<'_, PyArrayDyn<f64>>) -> Self {
        // A new array, C-contiguous: its data is `len` values.
        Out {
            ptr: a.data(),
            len: a.len(),
        }
    }

    /// Entries `[start, start + n)`.
    ///
    /// # Safety
    /// No other live slice may overlap these entries.
    #[allow(clippy::mut_from_ref)]
    unsafe fn part(&self, start: usize, n: usize) -> &mut [f64] {
        assert!(
            start + n <= self.len,
            "output range {start}+{n} of {}",
            self.len
        );
        // SAFETY: in bounds (asserted); not overlapping (the caller's promise).
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(start), n) }
    }
}

fn write_pose(t: &Transform, out: &mut [f64]) {
    for (r, row) in t.to_rows().iter().enumerate() {
        out[4 * r..4 * r + 4].copy_from_slice(row);
    }
}

/// Runs `f` on rayon's global pool, or on a pool of `threads` threads.
fn on_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T, String> {
    match threads {
        None => Ok(f()),
        Some(0) => Err("threads must be at least 1".into()),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map(|pool| pool.install(f))
            .map_err(|e| format!("cannot start {n} threads: {e}")),
    }
}

/// What an evaluation failed on: a configuration's state, or the threads.
enum Failure {
    State(Option<usize>, KStateError),
    Threads(String),
}

impl Failure {
    fn into_py(self, batched: bool) -> PyErr {
        match self {
            Failure::State(Some(i), e) if batched => {
                StateError::new_err(format!("configuration {i}: {}", error_chain(&e)))
            }
            Failure::State(_, e) => state_error(&e),
            Failure::Threads(m) => Error::new_err(m),
        }
    }
}

#[pymethods]
impl Chain {
    /// Loads a robot file: a DH table (`.yaml`, `.yml`) or a URDF file (`.urdf`).
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        let inner = Inner::from_file(&path).map_err(|e| load_error(&e))?;
        let source = std::fs::read_to_string(&path)
            .map_err(|e| LoadError::new_err(format!("{}: {e}", path.display())))?;
        let format = match kinechain::io::Format::from_path(&path) {
            Some(kinechain::io::Format::Urdf) => "urdf",
            _ => "yaml",
        };
        Ok(Chain {
            inner: Arc::new(inner),
            source,
            format,
        })
    }

    /// A robot from URDF text.
    #[staticmethod]
    fn from_urdf_string(text: String) -> PyResult<Self> {
        Chain::from_text(text, "urdf")
    }

    /// A robot from DH YAML text.
    #[staticmethod]
    fn from_yaml_string(text: String) -> PyResult<Self> {
        Chain::from_text(text, "yaml")
    }

    /// A robot from its text and format (`urdf` or `yaml`); what unpickling calls.
    #[staticmethod]
    fn _from_source(text: String, format: &str) -> PyResult<Self> {
        Chain::from_text(text, format)
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let make = slf.get_type().getattr("_from_source")?;
        let me = slf.get();
        (make, (me.source.clone(), me.format)).into_pyobject(slf.py())
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Chain>()
            .is_ok_and(|o| o.get().source == self.source && o.get().format == self.format)
    }

    fn __hash__(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        (&self.source, self.format).hash(&mut h);
        h.finish()
    }

    fn __repr__(&self) -> String {
        format!(
            "Chain(name='{}', dof={}, links={})",
            kinechain::error::escape_controls(self.inner.name()).replace('\'', "\\'"),
            self.inner.dof(),
            self.inner.links().len()
        )
    }

    /// The robot's name.
    #[getter]
    fn name(&self) -> String {
        self.inner.name().to_string()
    }

    /// Entries of a configuration `q`.
    #[getter]
    fn dof(&self) -> usize {
        self.inner.dof()
    }

    /// The name of each entry of `q`, in order: the independent joints depth-first from the root
    /// (as `kinechain info` lists them); a cylindrical joint's two as `NAME.theta`, `NAME.d`.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        variable_names(&self.inner)
    }

    /// Every link, in the chain's order.
    #[getter]
    fn link_names(&self) -> Vec<String> {
        self.inner
            .links()
            .iter()
            .map(|l| l.name().to_string())
            .collect()
    }

    /// Smallest admitted value of each entry of `q` (-inf where unlimited).
    #[getter]
    fn lower<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.lower())
    }

    /// Largest admitted value of each entry of `q` (inf where unlimited).
    #[getter]
    fn upper<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.upper())
    }

    /// A configuration inside the limits (0 where admitted, else the middle of the range).
    fn neutral<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.neutral())
    }

    /// The evaluation behind `Chain.fk`: a dict of `links`, `poses` and, with `qd` (and `qdd`),
    /// `omega`, `v` (and `alpha`, `a`).
    #[pyo3(signature = (q, qd=None, qdd=None, links=None, check_limits=true, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn _fk<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArrayDyn<'py, f64>,
        qd: Option<PyReadonlyArrayDyn<'py, f64>>,
        qdd: Option<PyReadonlyArrayDyn<'py, f64>>,
        links: Option<Vec<String>>,
        check_limits: bool,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let chain = &*self.inner;
        let (n, batched) = rows(chain, &q, "q")?;
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
        let (ids, names) = self.link_ids(links)?;
        let l = ids.len();
        let lead: Vec<usize> = if batched { vec![n] } else { vec![] };
        let dims = |tail: &[usize]| [lead.as_slice(), &[l], tail].concat();
        let poses = PyArrayDyn::<f64>::zeros(py, dims(&[4, 4]), false);
        let rates: Vec<Bound<'py, PyArrayDyn<f64>>> = (0..2 * level)
            .map(|_| PyArrayDyn::<f64>::zeros(py, dims(&[3]), false))
            .collect();
        let policy = if check_limits {
            LimitPolicy::Enforce
        } else {
            LimitPolicy::Ignore
        };
        let (q, qd, qdd) = (
            q.as_slice()?,
            qd.as_ref().map(|a| a.as_slice()).transpose()?,
            qdd.as_ref().map(|a| a.as_slice()).transpose()?,
        );
        let pose_out = Out::new(&poses);
        let rate_out: Vec<Out> = rates.iter().map(Out::new).collect();
        let dof = chain.dof();
        let result = py.detach(|| {
            if level == 0 && batched && n > 0 {
                return on_threads(threads, || {
                    batch_poses(chain, policy, q, &ids, pose_out, threads != Some(1))
                })
                .map_err(Failure::Threads)?;
            }
            let one = |data: &mut Data, i: usize| -> Result<(), KStateError> {
                fn row(a: &[f64], i: usize, dof: usize) -> &[f64] {
                    &a[i * dof..(i + 1) * dof]
                }
                // SAFETY: row i's ranges of the outputs, written by this call alone.
                let pose = unsafe { pose_out.part(i * l * 16, l * 16) };
                let mut parts: Vec<&mut [f64]> = rate_out
                    .iter()
                    .map(|o| unsafe { o.part(i * l * 3, l * 3) })
                    .collect();
                match (qd, qdd) {
                    (None, _) if l == 1 => {
                        write_pose(
                            &forward_kinematics_to(chain, data, row(q, i, dof), ids[0])?,
                            pose,
                        );
                    }
                    (None, _) => {
                        let p = forward_kinematics(chain, data, row(q, i, dof))?;
                        for (k, &id) in ids.iter().enumerate() {
                            write_pose(&p.world_from_link(id), &mut pose[16 * k..16 * k + 16]);
                        }
                    }
                    (Some(qd), None) => {
                        let v = forward_velocities(chain, data, row(q, i, dof), row(qd, i, dof))?;
                        for (k, &id) in ids.iter().enumerate() {
                            write_pose(&v.world_from_link(id), &mut pose[16 * k..16 * k + 16]);
                            let lv = v.velocity(id);
                            parts[0][3 * k..3 * k + 3].copy_from_slice(lv.omega.as_slice());
                            parts[1][3 * k..3 * k + 3].copy_from_slice(lv.v.as_slice());
                        }
                    }
                    (Some(qd), Some(qdd)) => {
                        let a = forward_accelerations(
                            chain,
                            data,
                            row(q, i, dof),
                            row(qd, i, dof),
                            row(qdd, i, dof),
                        )?;
                        for (k, &id) in ids.iter().enumerate() {
                            write_pose(&a.world_from_link(id), &mut pose[16 * k..16 * k + 16]);
                            let (lv, la) = (a.velocity(id), a.acceleration(id));
                            parts[0][3 * k..3 * k + 3].copy_from_slice(lv.omega.as_slice());
                            parts[1][3 * k..3 * k + 3].copy_from_slice(lv.v.as_slice());
                            parts[2][3 * k..3 * k + 3].copy_from_slice(la.alpha.as_slice());
                            parts[3][3 * k..3 * k + 3].copy_from_slice(la.a.as_slice());
                        }
                    }
                }
                Ok(())
            };
            per_row(chain, policy, n, threads, one)
        });
        result.map_err(|f| f.into_py(batched))?;
        let dict = PyDict::new(py);
        dict.set_item("links", names)?;
        dict.set_item("poses", poses)?;
        for (key, a) in ["omega", "v", "alpha", "a"].iter().zip(rates) {
            dict.set_item(key, a)?;
        }
        Ok(dict)
    }

    /// The evaluation behind `Chain.jacobian`: `(6, dof)` or `(N, 6, dof)`, rows v then ω.
    #[pyo3(signature = (q, link, check_limits=true, threads=None))]
    fn _jacobian<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArrayDyn<'py, f64>,
        link: String,
        check_limits: bool,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let chain = &*self.inner;
        let (n, batched) = rows(chain, &q, "q")?;
        let id = chain
            .link_id(&link)
            .map_err(|e| Error::new_err(e.to_string()))?;
        let dof = chain.dof();
        let dims: Vec<usize> = if batched {
            vec![n, 6, dof]
        } else {
            vec![6, dof]
        };
        let out = PyArrayDyn::<f64>::zeros(py, dims, false);
        let policy = if check_limits {
            LimitPolicy::Enforce
        } else {
            LimitPolicy::Ignore
        };
        let q = q.as_slice()?;
        let o = Out::new(&out);
        let result = py.detach(|| {
            per_row(chain, policy, n, threads, |data: &mut Data, i: usize| {
                let poses = forward_kinematics(chain, data, &q[i * dof..(i + 1) * dof])?;
                let j = poses.jacobian(id);
                // SAFETY: row i's range, written by this call alone.
                let dst = unsafe { o.part(i * 6 * dof, 6 * dof) };
                for r in 0..6 {
                    for c in 0..dof {
                        dst[r * dof + c] = j[(r, c)];
                    }
                }
                Ok(())
            })
        });
        result.map_err(|f| f.into_py(batched))?;
        Ok(out)
    }
}

/// The options of a regression record or comparison.
fn regression_options(
    samples: usize,
    seed: u64,
    level: &str,
    links: Option<Vec<String>>,
) -> PyResult<regression::Options> {
    let level = match level {
        "pose" => regression::Level::Pose,
        "vel" => regression::Level::Vel,
        "acc" => regression::Level::Acc,
        other => {
            return Err(Error::new_err(format!(
                "level '{other}': expected 'pose', 'vel' or 'acc'"
            )));
        }
    };
    Ok(regression::Options {
        samples,
        seed,
        level,
        links: links.unwrap_or_default(),
    })
}

fn tolerances(position: f64, rotation: f64, rates: f64) -> PyResult<regression::Tolerances> {
    for (what, x) in [("position", position), ("rotation", rotation), ("rates", rates)] {
        if !(x.is_finite() && x >= 0.0) {
            return Err(Error::new_err(format!(
                "tolerance of {what} {x}: expected a finite number >= 0"
            )));
        }
    }
    Ok(regression::Tolerances {
        position,
        rotation,
        rates,
    })
}

/// A report as `(passed, table for people, JSON text)`.
fn report_parts(report: &regression::Report) -> PyResult<(bool, String, String)> {
    let json = serde_json::to_string(report).map_err(|e| Error::new_err(e.to_string()))?;
    Ok((report.passed(), report.to_string(), json))
}

fn regression_error(e: &regression::RegressionError) -> PyErr {
    Error::new_err(error_chain(e))
}

/// Records `chain` into the golden file `path` (what `kinechain record -o path` writes).
#[pyfunction]
#[pyo3(signature = (chain, path, samples, seed, level, links))]
fn _record_golden(
    chain: &Bound<'_, Chain>,
    path: PathBuf,
    samples: usize,
    seed: u64,
    level: &str,
    links: Option<Vec<String>>,
) -> PyResult<()> {
    let options = regression_options(samples, seed, level, links)?;
    let golden =
        regression::record(&chain.get().inner, &options).map_err(|e| regression_error(&e))?;
    let mut text = Vec::new();
    regression::write_golden(&golden, &mut text).map_err(|e| Error::new_err(e.to_string()))?;
    std::fs::write(&path, text)
        .map_err(|e| Error::new_err(format!("cannot write {}: {e}", path.display())))
}

/// Verifies `chain` against the golden file `path`: `(passed, table, JSON)`.
#[pyfunction]
fn _verify_golden(
    chain: &Bound<'_, Chain>,
    path: PathBuf,
    tol_position: f64,
    tol_rotation: f64,
    tol_rates: f64,
) -> PyResult<(bool, String, String)> {
    let text = std::fs::read_to_string(&path)
        .map_err(|e| Error::new_err(format!("cannot read {}: {e}", path.display())))?;
    let golden = regression::read_golden(&text, &path.display().to_string())
        .map_err(|e| regression_error(&e))?;
    let tol = tolerances(tol_position, tol_rotation, tol_rates)?;
    let report =
        regression::verify(&chain.get().inner, &golden, &tol).map_err(|e| regression_error(&e))?;
    report_parts(&report)
}

/// Compares two chains: `(passed, table, JSON)`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (a, b, samples, seed, level, links, tol_position, tol_rotation, tol_rates))]
fn _compare(
    a: &Bound<'_, Chain>,
    b: &Bound<'_, Chain>,
    samples: usize,
    seed: u64,
    level: &str,
    links: Option<Vec<String>>,
    tol_position: f64,
    tol_rotation: f64,
    tol_rates: f64,
) -> PyResult<(bool, String, String)> {
    let options = regression_options(samples, seed, level, links)?;
    let tol = tolerances(tol_position, tol_rotation, tol_rates)?;
    let report = regression::compare(&a.get().inner, &b.get().inner, &options, &tol)
        .map_err(|e| regression_error(&e))?;
    report_parts(&report)
}

/// Every link asked for of a batch of poses, through the batch kernels (all links, or the one
/// link's path alone), on the pool when `parallel`.
fn batch_poses(
    chain: &Inner,
    policy: LimitPolicy,
    qs: &[f64],
    ids: &[LinkId],
    out: Out,
    parallel: bool,
) -> Result<(), Failure> {
    let n = qs.len() / chain.dof().max(1);
    let l = ids.len();
    let mut data = BatchData::new(chain).with_limit_policy(policy);
    let fail = |e: kinechain::eval::batch::BatchError| Failure::State(Some(e.index), e.source);
    // SAFETY: the whole output, written by this thread alone.
    let all = unsafe { out.part(0, n * l * 16) };
    if l == 1 {
        let poses = if parallel {
            forward_kinematics_batch_to_par(chain, &mut data, qs, ids[0])
        } else {
            forward_kinematics_batch_to(chain, &mut data, qs, ids[0])
        }
        .map_err(fail)?;
        for (i, dst) in all.chunks_exact_mut(16).enumerate() {
            write_pose(&poses.world_from_link(i), dst);
        }
    } else {
        let poses = if parallel {
            forward_kinematics_batch_par(chain, &mut data, qs)
        } else {
            forward_kinematics_batch(chain, &mut data, qs)
        }
        .map_err(fail)?;
        for (i, row) in all.chunks_exact_mut(16 * l).enumerate() {
            for (k, &id) in ids.iter().enumerate() {
                write_pose(&poses.world_from_link(i, id), &mut row[16 * k..16 * k + 16]);
            }
        }
    }
    Ok(())
}

/// Runs `one(data, i)` for every configuration `i < n`, on the pool (each thread with a `Data` of
/// its own), and returns the failure of the first configuration that fails.
fn per_row(
    chain: &Inner,
    policy: LimitPolicy,
    n: usize,
    threads: Option<usize>,
    one: impl Fn(&mut Data, usize) -> Result<(), KStateError> + Sync + Send,
) -> Result<(), Failure> {
    let make = || Data::new(chain).with_limit_policy(policy);
    let first = on_threads(threads, || {
        if n < 64 || threads == Some(1) {
            let mut data = make();
            (0..n).find_map(|i| one(&mut data, i).err().map(|e| (i, e)))
        } else {
            (0..n)
                .into_par_iter()
                .with_min_len(32)
                .map_init(make, |data, i| one(data, i).err().map(|e| (i, e)))
                .find_map_first(|x| x)
        }
    })
    .map_err(Failure::Threads)?;
    match first {
        None => Ok(()),
        Some((i, e)) => Err(Failure::State(Some(i), e)),
    }
}

/// Orientation coordinates of every rotation in `r` (shape `(..., 3, 3)`, or `(..., 4, 4)`
/// poses whose rotation block is read): `quaternion` (w, x, y, z: Euler parameters),
/// `rpy` (roll, pitch, yaw), `euler_zxz` (φ, θ, ψ), `axis_angle` (x, y, z, angle) or
/// `rodrigues` (γ1, γ2, γ3); NaN where the coordinates are undefined (gimbal lock, the identity's
/// axis, Rodriguez parameters at θ = π), as the command line prints `null`.
#[pyfunction]
fn _orientation<'py>(
    py: Python<'py>,
    kind: &str,
    r: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    use kinechain::nalgebra::Matrix3;
    use kinechain::orientation::{
        AxisAngle, EulerParameters, EulerZxz, RodriguezParameters, Rpy,
    };
    let shape = r.shape().to_vec();
    let side = match shape.as_slice() {
        [.., 3, 3] => 3,
        [.., 4, 4] => 4,
        _ => {
            return Err(StateError::new_err(format!(
                "rotations of shape {shape:?}: expected (..., 3, 3) or (..., 4, 4)"
            )));
        }
    };
    let width = match kind {
        "quaternion" | "axis_angle" => 4,
        "rpy" | "euler_zxz" | "rodrigues" => 3,
        other => {
            return Err(Error::new_err(format!(
                "orientation '{other}': expected quaternion, rpy, euler_zxz, axis_angle or rodrigues"
            )));
        }
    };
    let values = r.as_slice()?;
    if let Some(bad) = values.iter().position(|x| !x.is_finite()) {
        return Err(StateError::new_err(format!(
            "rotation entry {bad} (flat index) is not finite"
        )));
    }
    let n = values.len() / (side * side);
    let mut dims = shape[..shape.len() - 2].to_vec();
    dims.push(width);
    let out = PyArrayDyn::<f64>::zeros(py, dims, false);
    let o = Out::new(&out);
    // SAFETY: the whole of a new array, written here alone.
    let dst = unsafe { o.part(0, n * width) };
    for (m, d) in values.chunks_exact(side * side).zip(dst.chunks_exact_mut(width)) {
        let a = Matrix3::from_fn(|i, j| m[i * side + j]);
        let nan = [f64::NAN; 4];
        let v: [f64; 4] = match kind {
            "quaternion" => {
                let e = EulerParameters::from_matrix(&a);
                [e.e0, e.e1, e.e2, e.e3]
            }
            "rpy" => Rpy::from_matrix(&a).map_or(nan, |x| [x.roll, x.pitch, x.yaw, 0.0]),
            "euler_zxz" => EulerZxz::from_matrix(&a).map_or(nan, |x| [x.phi, x.theta, x.psi, 0.0]),
            "axis_angle" => AxisAngle::from_matrix(&a)
                .map_or(nan, |x| [x.axis.x, x.axis.y, x.axis.z, x.angle]),
            _ => RodriguezParameters::from_matrix(&a).map_or(nan, |x| [x.0.x, x.0.y, x.0.z, 0.0]),
        };
        d.copy_from_slice(&v[..width]);
    }
    Ok(out)
}

#[pymodule]
fn _kinechain(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Chain>()?;
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("LoadError", m.py().get_type::<LoadError>())?;
    m.add("StateError", m.py().get_type::<StateError>())?;
    m.add_function(wrap_pyfunction!(_orientation, m)?)?;
    m.add_function(wrap_pyfunction!(_record_golden, m)?)?;
    m.add_function(wrap_pyfunction!(_verify_golden, m)?)?;
    m.add_function(wrap_pyfunction!(_compare, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
