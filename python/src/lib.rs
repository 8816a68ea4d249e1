//! `kinechain._kinechain`, the compiled half of the Python package: a `Chain` class over
//! `kinechain::Chain` whose evaluations take and return numpy arrays, running with the GIL
//! released (on all cores for a batch of configurations, or as many threads as asked). The
//! Python half (`kinechain/__init__.py`) adds the result class and the array-like conversions.
//!
//! Nothing here panics on what a user passes: shapes, lengths, names, non-finite values and
//! values out of limits are checked and raised as `kinechain.StateError` / `kinechain.Error`,
//! files as `kinechain.LoadError`.

use kinechain::JacobianFrame;
use kinechain::eval::batch::{
    BatchError, fold_block_len, forward_accelerations_batch, forward_kinematics_batch,
    forward_kinematics_batch_to, forward_velocities_batch, jacobian_batch,
};
use kinechain::regression::{self, variable_names};
use kinechain::{
    Chain as Inner, Data, LimitPolicy, LinkId, StateError as KStateError, Transform,
    error::error_chain, forward_accelerations, forward_kinematics, forward_kinematics_to,
    forward_velocities,
};
use numpy::ndarray::Dimension;
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyList, PySlice, PyTuple};
use run::{Failure, in_blocks};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

mod files;
mod run;

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

/// A robot: links, joints, limits; immutable, shared between threads. Made by `kinechain.load`
/// or the `from_*` methods.
#[pyclass(module = "kinechain", name = "Chain", frozen)]
struct Chain {
    inner: Arc<Inner>,
    /// The text it was loaded from, and its format (`urdf` or `yaml`): what pickling ships
    /// (with the name, which may have come from the file name).
    source: String,
    format: &'static str,
    /// The file it was loaded from, which the files this package writes never replace.
    origin: Option<PathBuf>,
    /// Every link's id and, for results of every link, the names as one shared Python list and
    /// their positions.
    all_links: Vec<LinkId>,
    link_list: Py<PyList>,
    link_index: Arc<HashMap<String, usize>>,
    /// The positions in `all_links` of the links without a child: the ones a finiteness check
    /// of every link's results reads (see [`check_finite`]).
    leaves: Vec<usize>,
    /// Buffers of single evaluations, reused by whichever call finds them free.
    data: Mutex<Option<Data>>,
    /// The links of the last `links=` request and what [`Chain::link_ids`] made of them,
    /// reused while requests name the same links (a control loop asks for the same ones on
    /// every call; looking them up and building their list took about 400 ns a call).
    requested: Mutex<Option<Requested>>,
}

/// The links of one `links=` request: their names, ids, Python list of names and positions.
struct Requested {
    names: Vec<String>,
    ids: Vec<LinkId>,
    list: Py<PyList>,
    index: Arc<HashMap<String, usize>>,
}

impl Chain {
    fn new(
        py: Python<'_>,
        inner: Inner,
        source: String,
        format: &'static str,
        origin: Option<PathBuf>,
    ) -> PyResult<Self> {
        let names: Vec<String> = inner.links().iter().map(|l| l.name().to_string()).collect();
        let all_links = names
            .iter()
            .map(|n| inner.link_id(n))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| Error::new_err(e.to_string()))?;
        let link_index = names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), i))
            .collect();
        let parents: std::collections::HashSet<LinkId> =
            inner.joints().iter().map(|j| j.parent()).collect();
        let leaves = all_links
            .iter()
            .enumerate()
            .filter(|(_, id)| !parents.contains(id))
            .map(|(k, _)| k)
            .collect();
        Ok(Chain {
            inner: Arc::new(inner),
            source,
            format,
            origin,
            all_links,
            link_list: PyList::new(py, &names)?.unbind(),
            link_index: Arc::new(link_index),
            leaves,
            data: Mutex::new(None),
            requested: Mutex::new(None),
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

    /// The links asked for (every link for `None`; a name or an iterable of names): ids, the
    /// names as a Python list, and their positions.
    #[allow(clippy::type_complexity)]
    fn link_ids(
        &self,
        py: Python<'_>,
        links: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(
        std::borrow::Cow<'_, [LinkId]>,
        Py<PyList>,
        Arc<HashMap<String, usize>>,
    )> {
        let Some(links) = links else {
            return Ok((
                std::borrow::Cow::Borrowed(&self.all_links),
                self.link_list.clone_ref(py),
                Arc::clone(&self.link_index),
            ));
        };
        let asked: Vec<Bound<'_, PyAny>> = if links.is_instance_of::<pyo3::types::PyString>() {
            vec![links.clone()]
        } else {
            links.try_iter()?.collect::<PyResult<_>>()?
        };
        // The same names as the last request: its lookup again, without allocating.
        {
            let cached = self
                .requested
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            if let Some(r) = cached.as_ref()
                && r.names.len() == asked.len()
                && asked.iter().zip(&r.names).all(|(a, n)| {
                    a.cast::<pyo3::types::PyString>()
                        .is_ok_and(|a| a.to_str().is_ok_and(|a| a == n))
                })
            {
                return Ok((
                    std::borrow::Cow::Owned(r.ids.clone()),
                    r.list.clone_ref(py),
                    Arc::clone(&r.index),
                ));
            }
        }
        let names = asked
            .iter()
            .map(|x| x.extract::<String>())
            .collect::<PyResult<Vec<_>>>()?;
        let chain = &*self.inner;
        let ids = names
            .iter()
            .map(|n| chain.link_id(n).map_err(|e| Error::new_err(e.to_string())))
            .collect::<PyResult<Vec<_>>>()?;
        let index: Arc<HashMap<String, usize>> = Arc::new(
            names
                .iter()
                .enumerate()
                .map(|(i, n)| (n.clone(), i))
                .rev()
                .collect(),
        );
        let list = PyList::new(py, &names)?.unbind();
        *self
            .requested
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(Requested {
            names,
            ids: ids.clone(),
            list: list.clone_ref(py),
            index: Arc::clone(&index),
        });
        Ok((std::borrow::Cow::Owned(ids), list, index))
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

impl Failure {
    fn into_py(self, batched: bool) -> PyErr {
        let at = |index: Option<usize>, m: String| match index {
            Some(i) if batched => StateError::new_err(format!("configuration {i}: {m}")),
            _ => StateError::new_err(m),
        };
        match self {
            Failure::State(index, e) => at(index, error_chain(&e)),
            Failure::Overflow { index, what, link } => at(
                index,
                format!(
                    "{what} of link '{}' overflows f64 (not finite): the joint values or rates are too large",
                    kinechain::error::escape_controls(&link)
                ),
            ),
            Failure::Threads(m) => Error::new_err(m),
            Failure::Python(e) => e,
        }
    }
}

/// The first pose among `poses` (rows of `l` links' 4 × 4 matrices) whose position is not
/// finite: `(row, link)`. The rotations cannot overflow (their entries are products of sines
/// and cosines of finite angles); positions can, from finite but huge prismatic values.
fn pose_overflow(poses: &[f64], l: usize) -> Option<(usize, usize)> {
    let finite = |m: &[f64]| m[3].is_finite() & m[7].is_finite() & m[11].is_finite();
    if poses.chunks_exact(16).fold(true, |ok, m| ok & finite(m)) {
        return None;
    }
    let k = poses.chunks_exact(16).position(|m| !finite(m))?;
    Some((k / l.max(1), k % l.max(1)))
}

/// As [`pose_overflow`], for rows of `l` links' 3-vectors (ω, v, α, a).
fn rate_overflow(rates: &[f64], l: usize) -> Option<(usize, usize)> {
    if rates.iter().fold(true, |ok, x| ok & x.is_finite()) {
        return None;
    }
    let k = rates.iter().position(|x| !x.is_finite())? / 3;
    Some((k / l.max(1), k % l.max(1)))
}

/// Whether the positions and rates of the links at `watch` (positions among the `l` links of
/// each row) are finite in every row of `poses` and `rates`.
fn watched_finite(poses: &[f64], rates: &[&[f64]], l: usize, watch: &[usize]) -> bool {
    let mut ok = true;
    for row in poses.chunks_exact(16 * l.max(1)) {
        for &k in watch {
            let m = &row[16 * k..16 * k + 16];
            ok &= m[3].is_finite() & m[7].is_finite() & m[11].is_finite();
        }
    }
    for r in rates {
        for row in r.chunks_exact(3 * l.max(1)) {
            for &k in watch {
                let v = &row[3 * k..3 * k + 3];
                ok &= v[0].is_finite() & v[1].is_finite() & v[2].is_finite();
            }
        }
    }
    ok
}

/// [`Failure::Overflow`] for the first pose or rate of `ids` that is not finite in the rows
/// from `first` on. Only the links at `watch` are read unless one of them is not finite: those
/// with no other link of `ids` below them, since a position or rate that is not finite makes
/// every one below it not finite too (a child's are its parent's plus finite terms).
fn check_finite(
    chain: &Inner,
    (ids, watch): (&[LinkId], &[usize]),
    first: usize,
    poses: &[f64],
    rates: &[&[f64]],
) -> Result<(), Failure> {
    const RATES: [&str; 4] = ["omega", "v", "alpha", "a"];
    if watched_finite(poses, rates, ids.len(), watch) {
        return Ok(());
    }
    let found = pose_overflow(poses, ids.len())
        .map(|at| ("pose", at))
        .or_else(|| {
            rates
                .iter()
                .zip(RATES)
                .find_map(|(r, what)| rate_overflow(r, ids.len()).map(|at| (what, at)))
        });
    match found {
        None => Ok(()),
        Some((what, (row, k))) => Err(Failure::Overflow {
            index: Some(first + row),
            what,
            link: chain.link(ids[k]).name().to_string(),
        }),
    }
}

/// The failure of configuration `first + e.index` of a block that starts at `first`.
fn at_block(first: usize) -> impl Fn(BatchError) -> Failure {
    move |e| Failure::State(Some(first + e.index), e.source)
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
        (make, (me.source.clone(), me.format, me.inner.name())).into_pyobject(slf.py())
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<Chain>().is_ok_and(|o| {
            let o = o.get();
            o.source == self.source
                && o.format == self.format
                && o.inner.name() == self.inner.name()
        })
    }

    fn __hash__(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        (&self.source, self.format, self.inner.name()).hash(&mut h);
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
        let chain = &*self.inner;
        let threads = thread_count(threads)?;
        let q = float_array(q, "q")?;
        let qd = qd.map(|a| float_array(a, "qd")).transpose()?;
        let qdd = qdd.map(|a| float_array(a, "qdd")).transpose()?;
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
        let (ids, names, index) = self.link_ids(py, links)?;
        let l = ids.len();
        // The links a finiteness check reads: every link's leaves, or each link asked for.
        let every: Vec<usize>;
        let watch: &[usize] = match &ids {
            std::borrow::Cow::Borrowed(_) => &self.leaves,
            std::borrow::Cow::Owned(_) => {
                every = (0..l).collect();
                &every
            }
        };
        // The shape `(N, L, *tail)` or `(L, *tail)`, built on the stack (`IxDyn` keeps up to
        // four axes inline).
        let dims = |tail: &[usize]| {
            let mut d = [0; 4];
            let lead = usize::from(batched);
            d[0] = n;
            d[lead] = l;
            d[lead + 1..lead + 1 + tail.len()].copy_from_slice(tail);
            numpy::ndarray::IxDyn(&d[..lead + 1 + tail.len()])
        };
        let poses = match out {
            // The caller's array, reused (no fresh pages to fault in); checked to be exactly
            // what the poses need, and not borrowed elsewhere.
            Some(o) => {
                let a = o
                    .cast::<PyArrayDyn<f64>>()
                    .map_err(|_| StateError::new_err("out must be a numpy array of float64"))?;
                let want = dims(&[4, 4]);
                if a.shape() != want.slice() || !a.is_c_contiguous() {
                    return Err(StateError::new_err(format!(
                        "out has shape {:?}: expected a writeable C-contiguous float64 array of shape {:?}",
                        a.shape(),
                        want.slice()
                    )));
                }
                a.clone()
            }
            // Every entry is written below before the array is handed out (an error drops it
            // unread).
            None => new_array(py, dims(&[4, 4]))?,
        };
        // Held until the poses are written: `out` is writeable and shares no memory with the
        // inputs (numpy's borrow checking refuses an overlap with q's read borrow when both
        // are views of one array; `overlaps` finds views of one buffer made otherwise, as by
        // `np.frombuffer`).
        let _out_borrow = match out {
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
        let rates: Vec<Bound<'py, PyArrayDyn<f64>>> = (0..2 * level)
            .map(|_| new_array(py, dims(&[3])))
            .collect::<PyResult<_>>()?;
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
        let one = |data: &mut Data, i: usize| -> Result<(), KStateError> {
            fn row(a: &[f64], i: usize, dof: usize) -> &[f64] {
                &a[i * dof..(i + 1) * dof]
            }
            // SAFETY: row i's ranges of the outputs, written by this call alone.
            let pose = unsafe { pose_out.part(i * l * 16, l * 16) };
            // SAFETY: as for `pose`; each rate array is taken once per row.
            let part = |k: usize| unsafe { rate_out[k].part(i * l * 3, l * 3) };
            match (qd, qdd) {
                (None, _) if l == 1 => {
                    write_pose(
                        &forward_kinematics_to(chain, data, row(q, i, dof), ids[0])?,
                        pose,
                    );
                }
                (None, _) => {
                    forward_kinematics(chain, data, row(q, i, dof))?.write_matrices(&ids, pose)?;
                }
                (Some(qd), None) => {
                    let v = forward_velocities(chain, data, row(q, i, dof), row(qd, i, dof))?;
                    let parts = [part(0), part(1)];
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
                    let parts = [part(0), part(1), part(2), part(3)];
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
        let result = if !batched || dof == 0 {
            // One configuration: too little work to leave the GIL for, buffers reused. A chain
            // without moving joints has the same poses in every row (the batch kernels cannot
            // count the rows of an empty q).
            self.with_data(policy, |data| {
                (0..n).try_for_each(|i| {
                    one(data, i).map_err(|e| Failure::State(batched.then_some(i), e))
                })
            })
            .and_then(|()| {
                // SAFETY: the whole of each output, written above; nothing else holds them now.
                let (p, r): (&[f64], Vec<&[f64]>) = unsafe {
                    (
                        pose_out.part(0, n * l * 16),
                        rate_out.iter().map(|o| &*o.part(0, n * l * 3)).collect(),
                    )
                };
                check_finite(chain, (&ids, watch), 0, p, &r)
            })
        } else {
            py.detach(|| match qd {
                _ if n == 0 => Ok(()),
                None => batch_poses(chain, policy, q, n, (&ids, watch), pose_out, threads),
                Some(qd) => batch_rates(
                    chain,
                    policy,
                    (q, qd, qdd),
                    n,
                    (&ids, watch),
                    &pose_out,
                    &rate_out,
                    threads,
                ),
            })
        };
        result.map_err(|f| f.into_py(batched))?;
        let mut rates = rates.into_iter().map(|a| Some(a.into_any().unbind()));
        let mut next = || rates.next().flatten();
        Ok(FkResult {
            links: names,
            index,
            poses: poses.into_any().unbind(),
            omega: next(),
            v: next(),
            alpha: next(),
            a: next(),
        })
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
        let chain = &*self.inner;
        let q = float_array(q, "q")?;
        let (n, _) = rows(chain, &q, "q")?;
        let policy = if check_limits {
            LimitPolicy::Enforce
        } else {
            LimitPolicy::Ignore
        };
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
    /// runs the batch kernels without the GIL and writes straight into the returned array.
    #[pyo3(signature = (q, link, *, frame="world", point=None, check_limits=true, threads=None))]
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
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let chain = &*self.inner;
        let threads = thread_count(threads)?;
        let frame = match (frame, point) {
            ("world", None) => JacobianFrame::World,
            ("world", Some(u)) if u.iter().all(|x| x.is_finite()) => JacobianFrame::Point(u),
            ("world", Some(u)) => {
                return Err(Error::new_err(format!("point {u:?} is not finite")));
            }
            ("link", None) => JacobianFrame::Link,
            ("link", Some(_)) => {
                return Err(Error::new_err(
                    "point is given in link coordinates with frame=\"world\" (the point's velocity in world axes)",
                ));
            }
            (other, _) => {
                return Err(Error::new_err(format!(
                    "frame must be \"world\" or \"link\", not {other:?}"
                )));
            }
        };
        let q = float_array(q, "q")?;
        let (n, batched) = rows(chain, &q, "q")?;
        let id = chain
            .link_id(link)
            .map_err(|e| Error::new_err(e.to_string()))?;
        let dof = chain.dof();
        let dims: Vec<usize> = if batched {
            vec![n, 6, dof]
        } else {
            vec![6, dof]
        };
        // Every entry is written below before the array is handed out.
        let out = new_array(py, numpy::ndarray::IxDyn(&dims))?;
        let policy = if check_limits {
            LimitPolicy::Enforce
        } else {
            LimitPolicy::Ignore
        };
        let q = q.as_slice()?;
        let o = Out::new(&out);
        let result = if batched && dof > 0 {
            py.detach(|| {
                in_blocks((chain, policy), n, JACOBIAN_BLOCK, threads, |data, at| {
                    // SAFETY: the block's configurations' range, written by this call alone.
                    let dst = unsafe { o.part(at.start * 6 * dof, at.len() * 6 * dof) };
                    let q = &q[at.start * dof..at.end * dof];
                    jacobian_batch(chain, data, q, id, frame, dst).map_err(at_block(at.start))?;
                    jacobian_finite(chain, id, at.start, dst, dof)
                })
            })
        } else {
            // A chain without moving joints has Jacobians of no columns: nothing to write.
            self.with_data(policy, |data| {
                if dof == 0 {
                    return Ok(());
                }
                let j = forward_kinematics(chain, data, q)
                    .map_err(|e| Failure::State(None, e))?
                    .jacobian_in(id, frame);
                // SAFETY: the whole array, written by this call alone.
                let dst = unsafe { o.part(0, 6 * dof) };
                for r in 0..6 {
                    for c in 0..dof {
                        dst[r * dof + c] = j[(r, c)];
                    }
                }
                jacobian_finite(chain, id, 0, dst, dof)
            })
        };
        result.map_err(|f| f.into_py(batched))?;
        Ok(out)
    }
}

impl Chain {
    /// Runs `f` with this chain's cached single-evaluation buffers (or fresh ones when another
    /// thread holds them), checking joint values under `policy`.
    fn with_data<T>(&self, policy: LimitPolicy, f: impl FnOnce(&mut Data) -> T) -> T {
        if let Ok(mut cached) = self.data.try_lock() {
            let data = cached.get_or_insert_with(|| Data::new(&self.inner));
            data.set_limit_policy(policy);
            return f(data);
        }
        f(&mut Data::new(&self.inner).with_limit_policy(policy))
    }
}

/// `x` as a C-contiguous float64 array: read as it is when it already is one, converted by numpy
/// otherwise (a conversion that fails is a `StateError`).
fn float_array<'py>(x: &Bound<'py, PyAny>, name: &str) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
    let py = x.py();
    // SAFETY: reads the type of a live object, and numpy's array type from its C API.
    let plain = unsafe {
        pyo3::ffi::Py_TYPE(x.as_ptr())
            == numpy::npyffi::PY_ARRAY_API
                .get_type_object(py, numpy::npyffi::NpyTypes::PyArray_Type)
    };
    // A plain ndarray (not a subclass such as a masked array) read in place.
    if plain
        && let Ok(a) = x.cast::<PyArrayDyn<f64>>()
        && a.is_c_contiguous()
        && a.ndim() > 0
    {
        return a
            .try_readonly()
            .map_err(|e| StateError::new_err(format!("{name}: {e}")));
    }
    let numpy = py.import("numpy")?;
    // numpy would drop an imaginary part and a mask without a word.
    if numpy.getattr("iscomplexobj")?.call1((x,))?.is_truthy()? {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "{name} holds complex numbers: joint values are real (pass the real part if that is what is meant)"
        )));
    }
    if numpy
        .getattr("ma")?
        .getattr("is_masked")?
        .call1((x,))?
        .is_truthy()?
    {
        return Err(StateError::new_err(format!(
            "{name} is a masked array with masked entries: a joint value is missing (fill them, or drop the rows)"
        )));
    }
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("dtype", numpy.getattr("float64")?)?;
    let a = numpy
        .getattr("asarray")?
        .call((x,), Some(&kwargs))
        .map_err(|e| {
            StateError::new_err(format!("{name} cannot be read as float64 numbers: {e}"))
        })?;
    // (Before `ascontiguousarray`, which makes a scalar a 1-element vector.)
    if a.getattr("ndim")?.extract::<usize>()? == 0 {
        return Err(StateError::new_err(format!(
            "{name} has shape (): expected (dof,) or (N, dof)"
        )));
    }
    let a = numpy.getattr("ascontiguousarray")?.call1((a,))?;
    let a = a
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|e| StateError::new_err(format!("{name}: {e}")))?;
    a.try_readonly()
        .map_err(|e| StateError::new_err(format!("{name}: {e}")))
}

/// `threads=`: `None`, or a positive integer.
fn thread_count(threads: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
    let Some(t) = threads else { return Ok(None) };
    if t.is_none() {
        return Ok(None);
    }
    match t.extract::<i64>() {
        Ok(n) if n >= 1 && !t.is_instance_of::<pyo3::types::PyBool>() => {
            Ok(Some(usize::try_from(n).unwrap_or(usize::MAX)))
        }
        _ => Err(Error::new_err(format!(
            "threads must be a positive integer, not {}",
            t.repr()?
        ))),
    }
}

/// What `Chain.fk` computed, as numpy arrays whose second-to-last axes follow `links`.
///
/// `poses`: `(L, 4, 4)` or `(N, L, 4, 4)` homogeneous transforms `world_from_link`. With `qd`:
/// `omega` (angular velocity) and `v` (velocity of the link origin), `(L, 3)` or `(N, L, 3)`.
/// With `qd` and `qdd`: `alpha` (angular acceleration) and `a` (classical acceleration of the
/// link origin). Absent quantities are `None`. `r[name]` is one link's pose, `(4, 4)` or
/// `(N, 4, 4)`.
#[pyclass(module = "kinechain", name = "FkResult", frozen)]
struct FkResult {
    /// Shared by every result of the same links (and by the chain): handed out as a copy.
    links: Py<PyList>,
    index: Arc<HashMap<String, usize>>,
    #[pyo3(get)]
    poses: Py<PyAny>,
    #[pyo3(get)]
    omega: Option<Py<PyAny>>,
    #[pyo3(get)]
    v: Option<Py<PyAny>>,
    #[pyo3(get)]
    alpha: Option<Py<PyAny>>,
    #[pyo3(get)]
    a: Option<Py<PyAny>>,
}

#[pymethods]
impl FkResult {
    /// The link names, in the order of the second-to-last axes of the arrays (a new list: the
    /// result's own order cannot be changed through it).
    #[getter]
    fn links<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        PyList::new(py, self.links.bind(py).iter())
    }

    fn __getitem__<'py>(&self, py: Python<'py>, link: &str) -> PyResult<Bound<'py, PyAny>> {
        let Some(&i) = self.index.get(link) else {
            return Err(pyo3::exceptions::PyKeyError::new_err(format!(
                "no link named '{link}' in this result (links: {})",
                self.links
                    .bind(py)
                    .iter()
                    .map(|n| n.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        let full = PySlice::full(py);
        let key = (py.Ellipsis(), i, full.clone(), full);
        self.poses.bind(py).get_item(key)
    }

    fn __len__(&self, py: Python<'_>) -> usize {
        self.links.bind(py).len()
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let shape = self.poses.bind(py).getattr("shape")?.repr()?.to_string();
        let mut s = format!(
            "FkResult(links={}, poses={shape}",
            self.links.bind(py).len()
        );
        for (name, x) in [
            ("omega", &self.omega),
            ("v", &self.v),
            ("alpha", &self.alpha),
            ("a", &self.a),
        ] {
            if x.is_some() {
                s.push_str(", ");
                s.push_str(name);
            }
        }
        s.push(')');
        Ok(s)
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
    for (what, x) in [
        ("position", position),
        ("rotation", rotation),
        ("rates", rates),
    ] {
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
    let me = chain.get();
    let golden = regression::record(&me.inner, &options).map_err(|e| regression_error(&e))?;
    let inputs: Vec<&std::path::Path> = me.origin.iter().map(PathBuf::as_path).collect();
    regression::write_golden_file(&golden, &path, &inputs).map_err(|e| regression_error(&e))
}

/// Verifies `chain` against the golden file `path`: `(passed, table, JSON)`.
#[pyfunction]
fn _verify_golden(
    py: Python<'_>,
    chain: &Bound<'_, Chain>,
    path: PathBuf,
    tol_position: f64,
    tol_rotation: f64,
    tol_rates: f64,
) -> PyResult<(bool, String, String)> {
    let tol = tolerances(tol_position, tol_rotation, tol_rates)?;
    let golden = files::read_interruptibly(py, move || {
        regression::read_golden_file(&path).map_err(|e| error_chain(&e))
    })?
    .map_err(Error::new_err)?;
    let report =
        regression::verify(&chain.get().inner, &golden, &tol).map_err(|e| regression_error(&e))?;
    report_parts(&report)
}

/// Compares two chains, joint `old` of `a` matched to joint `new` of `b` for each pair of
/// `renames`: `(passed, table, JSON)`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (a, b, samples, seed, level, links, tol_position, tol_rotation, tol_rates, renames=None))]
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
    renames: Option<Vec<(String, String)>>,
) -> PyResult<(bool, String, String)> {
    let options = regression_options(samples, seed, level, links)?;
    let tol = tolerances(tol_position, tol_rotation, tol_rates)?;
    let report = regression::compare_renamed(
        &a.get().inner,
        &b.get().inner,
        &options,
        &tol,
        &renames.unwrap_or_default(),
    )
    .map_err(|e| regression_error(&e))?;
    report_parts(&report)
}

/// Configurations per block of a batch with rates: frames, velocities and accelerations
/// (192 bytes per body and configuration) stay in a core's second-level cache.
const RATE_BLOCK: usize = 512;

/// Configurations per block of a one-link batch: the link's frames (96 bytes per configuration)
/// and the transposed `q` stay in a core's second-level cache.
const LINK_BLOCK: usize = 2048;

/// Configurations per block of a batch of Jacobians.
const JACOBIAN_BLOCK: usize = 512;

/// Every link asked for of the `n` configurations `qs`, through the batch kernels (all links, or
/// the one link's path alone), block by block while the frames are in cache, each block written
/// straight into its part of `out` and checked to be finite there.
fn batch_poses(
    chain: &Inner,
    policy: LimitPolicy,
    qs: &[f64],
    n: usize,
    (ids, watch): (&[LinkId], &[usize]),
    out: Out,
    threads: Option<usize>,
) -> Result<(), Failure> {
    let dof = chain.dof();
    let l = ids.len();
    let block = if l == 1 {
        LINK_BLOCK
    } else {
        fold_block_len(chain)
    };
    in_blocks((chain, policy), n, block, threads, |data, at| {
        let q = &qs[at.start * dof..at.end * dof];
        // SAFETY: the block's configurations' range, written by this call alone.
        let rows = unsafe { out.part(at.start * l * 16, at.len() * l * 16) };
        let written = if l == 1 {
            forward_kinematics_batch_to(chain, data, q, ids[0])
                .map_err(at_block(at.start))?
                .write_matrices(rows)
        } else {
            forward_kinematics_batch(chain, data, q)
                .map_err(at_block(at.start))?
                .write_matrices(ids, rows)
        };
        written.map_err(|e| Failure::State(Some(at.start), e))?;
        check_finite(chain, (ids, watch), at.start, rows, &[])
    })
}

/// Poses and rates of `ids` for each of the `n` configurations, from the batch kernels of rates
/// block by block: `pose_out` as `(N, L, 4, 4)`, `rate_out` as ω, v (and α, a with `qdds`),
/// each `(N, L, 3)`.
#[allow(clippy::too_many_arguments)]
fn batch_rates(
    chain: &Inner,
    policy: LimitPolicy,
    (qs, qds, qdds): (&[f64], &[f64], Option<&[f64]>),
    n: usize,
    (ids, watch): (&[LinkId], &[usize]),
    pose_out: &Out,
    rate_out: &[Out],
    threads: Option<usize>,
) -> Result<(), Failure> {
    let dof = chain.dof();
    let l = ids.len();
    in_blocks((chain, policy), n, RATE_BLOCK, threads, |data, at| {
        let rows = at.start * dof..at.end * dof;
        let fail = at_block(at.start);
        // SAFETY: the block's configurations' ranges of each output, written by this call alone
        // (each rate array taken once per block).
        let pose = unsafe { pose_out.part(at.start * l * 16, at.len() * l * 16) };
        let part = |k: usize| unsafe { rate_out[k].part(at.start * l * 3, at.len() * l * 3) };
        let (q, qd) = (&qs[rows.clone()], &qds[rows.clone()]);
        let written = |e| Failure::State(Some(at.start), e);
        match qdds {
            None => {
                let (omega, v) = (part(0), part(1));
                let r = forward_velocities_batch(chain, data, q, qd).map_err(fail)?;
                r.poses()
                    .write_matrices(ids, pose)
                    .and_then(|()| r.write_velocities(ids, omega, v))
                    .map_err(written)?;
                check_finite(chain, (ids, watch), at.start, pose, &[omega, v])
            }
            Some(qdds) => {
                let (omega, v, alpha, a) = (part(0), part(1), part(2), part(3));
                let r =
                    forward_accelerations_batch(chain, data, q, qd, &qdds[rows]).map_err(fail)?;
                let vel = r.velocities();
                vel.poses()
                    .write_matrices(ids, pose)
                    .and_then(|()| vel.write_velocities(ids, omega, v))
                    .and_then(|()| r.write_accelerations(ids, alpha, a))
                    .map_err(written)?;
                check_finite(chain, (ids, watch), at.start, pose, &[omega, v, alpha, a])
            }
        }
    })
}

/// A new, uninitialised C-ordered float64 array of shape `dims`; a `MemoryError` (or numpy's
/// `ValueError` for a shape too large to index) when numpy cannot make it.
fn new_array<'py, D: numpy::ndarray::Dimension>(
    py: Python<'py>,
    dims: D,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    use numpy::npyffi::{NPY_TYPES, NpyTypes, PY_ARRAY_API, npy_intp};
    let mut shape: Vec<npy_intp> = dims
        .slice()
        .iter()
        .map(|&d| npy_intp::try_from(d))
        .collect::<Result<_, _>>()
        .map_err(|_| pyo3::exceptions::PyMemoryError::new_err("array too large"))?;
    let nd = std::os::raw::c_int::try_from(shape.len())
        .map_err(|_| Error::new_err("too many dimensions"))?;
    // SAFETY: numpy's C API, called as rust-numpy calls it: a float64 descriptor (whose
    // reference the call takes), a shape of `nd` entries, no strides or data (numpy allocates
    // them). A null result has set the Python error that `from_owned_ptr_or_err` takes.
    unsafe {
        let descr = PY_ARRAY_API.PyArray_DescrFromType(py, NPY_TYPES::NPY_DOUBLE as _);
        let ptr = PY_ARRAY_API.PyArray_NewFromDescr(
            py,
            PY_ARRAY_API.get_type_object(py, NpyTypes::PyArray_Type),
            descr,
            nd,
            shape.as_mut_ptr(),
            std::ptr::null_mut(),
            std::ptr::null_mut(),
            0,
            std::ptr::null_mut(),
        );
        Ok(Bound::from_owned_ptr_or_err(py, ptr)?.cast_into_unchecked())
    }
}

/// [`Failure::Overflow`] for the first of the Jacobians `j` (rows of `6 × dof`, from
/// configuration `first` on) with an entry that is not finite.
fn jacobian_finite(
    chain: &Inner,
    link: LinkId,
    first: usize,
    j: &[f64],
    dof: usize,
) -> Result<(), Failure> {
    if j.iter().fold(true, |ok, x| ok & x.is_finite()) {
        return Ok(());
    }
    let k = j.iter().position(|x| !x.is_finite()).unwrap_or(0);
    Err(Failure::Overflow {
        index: Some(first + k / (6 * dof).max(1)),
        what: "jacobian",
        link: chain.link(link).name().to_string(),
    })
}

/// Whether the C-contiguous arrays `a` and `b` share memory.
fn overlaps(a: &PyReadonlyArrayDyn<'_, f64>, b: &Bound<'_, PyArrayDyn<f64>>) -> bool {
    let range = |ptr: *const f64, len: usize| {
        let start = ptr as usize;
        start..start + len * std::mem::size_of::<f64>()
    };
    let (x, y) = (
        range(a.as_array().as_ptr(), a.len()),
        range(b.data(), b.len()),
    );
    !x.is_empty() && !y.is_empty() && x.start < y.end && y.start < x.end
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
    use kinechain::orientation::{AxisAngle, EulerParameters, EulerZxz, RodriguezParameters, Rpy};
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
    // Every entry is written below.
    let out = new_array(py, numpy::ndarray::IxDyn(&dims))?;
    let o = Out::new(&out);
    // SAFETY: the whole of a new array, written here alone.
    let dst = unsafe { o.part(0, n * width) };
    for (m, d) in values
        .chunks_exact(side * side)
        .zip(dst.chunks_exact_mut(width))
    {
        let a = Matrix3::from_fn(|i, j| m[i * side + j]);
        let nan = [f64::NAN; 4];
        let v: [f64; 4] = match kind {
            "quaternion" => {
                let e = EulerParameters::from_matrix(&a);
                [e.e0, e.e1, e.e2, e.e3]
            }
            "rpy" => Rpy::from_matrix(&a).map_or(nan, |x| [x.roll, x.pitch, x.yaw, 0.0]),
            "euler_zxz" => EulerZxz::from_matrix(&a).map_or(nan, |x| [x.phi, x.theta, x.psi, 0.0]),
            "axis_angle" => {
                AxisAngle::from_matrix(&a).map_or(nan, |x| [x.axis.x, x.axis.y, x.axis.z, x.angle])
            }
            _ => RodriguezParameters::from_matrix(&a).map_or(nan, |x| [x.0.x, x.0.y, x.0.z, 0.0]),
        };
        d.copy_from_slice(&v[..width]);
    }
    Ok(out)
}

#[pymodule]
fn _kinechain(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Chain>()?;
    m.add_class::<FkResult>()?;
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
