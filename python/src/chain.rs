//! The `Chain` class: loading, pickling, names and limits; its evaluations are in
//! [`crate::methods`] (the work in [`crate::fk`] and [`crate::jacobian`]).

use crate::errors::{Error, LoadError, load_error};
use crate::files;
use crate::robot::Robot;
use kinechain::Chain as Inner;
use kinechain::error::error_chain;
use kinechain::io::LoadOptions;
use kinechain::regression::variable_names;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use std::path::PathBuf;

/// A robot: links, joints, limits; immutable, shared between threads. Made by `kinechain.load`
/// or the `from_*` methods.
#[pyclass(module = "kinechain", name = "Chain", frozen)]
pub(crate) struct Chain {
    /// The chain, its links and its buffers: what evaluations use.
    pub(crate) robot: Robot,
    /// The text it was loaded from, and its format (`urdf`, `yaml` or `mjcf`): what pickling ships
    /// (with the name, which may have come from the file name).
    source: String,
    format: &'static str,
    /// How it was loaded (a floating base added; where an MJCF file's includes are), which
    /// pickling ships too.
    options: LoadOptions,
    /// The file it was loaded from, which the files this package writes never replace.
    pub(crate) origin: Option<PathBuf>,
}

impl Chain {
    /// The URDF text the chain was read from (after xacro), if it was read from URDF.
    pub(crate) fn urdf_text(&self) -> Option<String> {
        (self.format == "urdf").then(|| self.source.clone())
    }

    fn new(
        py: Python<'_>,
        inner: Inner,
        (source, format, options): (String, &'static str, LoadOptions),
        origin: Option<PathBuf>,
    ) -> PyResult<Self> {
        Ok(Chain {
            robot: Robot::new(py, inner)?,
            source,
            format,
            options,
            origin,
        })
    }

    /// A chain from `text` in `format` (`urdf`, `yaml` or `mjcf`), named `name` where the text names no
    /// robot.
    fn from_text(
        py: Python<'_>,
        text: String,
        format: &str,
        name: &str,
        options: LoadOptions,
    ) -> PyResult<Self> {
        use kinechain::io::Format;
        let (kind, format) = match format {
            "urdf" => (Format::Urdf, "urdf"),
            "yaml" => (Format::DhYaml, "yaml"),
            "mjcf" => (Format::Mjcf, "mjcf"),
            other => {
                return Err(Error::new_err(format!(
                    "unknown format '{other}' (urdf, yaml or mjcf)"
                )));
            }
        };
        let inner =
            Inner::from_str_with(&text, kind, name, &options).map_err(|e| load_error(&e))?;
        Chain::new(py, inner, (text, format, options), None)
    }
}

/// The load options the Python keywords give.
fn load_options(floating_base: bool, couplings: bool, base_dir: Option<PathBuf>) -> LoadOptions {
    let options = LoadOptions::default()
        .with_floating_base(floating_base)
        .with_couplings(couplings);
    match base_dir {
        Some(dir) => options.with_base_dir(dir),
        None => options,
    }
}

/// The xacro options of the Python keywords.
pub(crate) fn xacro_options(
    args: Option<Vec<(String, String)>>,
    package_paths: Option<Vec<PathBuf>>,
) -> kinechain::io::xacro::XacroOptions {
    let mut options = kinechain::io::xacro::XacroOptions::default();
    for (k, v) in args.unwrap_or_default() {
        options = options.with_arg(k, v);
    }
    for p in package_paths.unwrap_or_default() {
        options = options.with_package_path(p);
    }
    options
}

/// Expands xacro `text` of file `path` without the GIL.
pub(crate) fn expand(
    py: Python<'_>,
    path: &std::path::Path,
    text: &str,
    options: kinechain::io::xacro::XacroOptions,
) -> PyResult<kinechain::io::xacro::Expansion> {
    py.detach(|| kinechain::io::xacro::expand_str(text, path, &options))
        .map_err(|e| load_error(&kinechain::io::error::LoadError::new_xacro(path, e)))
}

/// The URDF that the xacro file `path` expands to (what `kinechain.expand_xacro` returns).
#[pyfunction]
#[pyo3(signature = (path, args=None, package_paths=None))]
pub(crate) fn _expand_xacro(
    py: Python<'_>,
    path: PathBuf,
    args: Option<Vec<(String, String)>>,
    package_paths: Option<Vec<PathBuf>>,
) -> PyResult<String> {
    let read = path.clone();
    let source = files::read_interruptibly(py, move || {
        kinechain::io::read_robot_file(&read).map_err(|e| error_chain(&e))
    })?
    .map_err(LoadError::new_err)?;
    Ok(expand(py, &path, &source, xacro_options(args, package_paths))?.urdf)
}

#[pymethods]
impl Chain {
    /// Loads a robot file: a DH table (`.yaml`, `.yml`), a URDF file (`.urdf`) or an MJCF file
    /// (`.xml`, its includes looked up beside it); with
    /// `floating_base`, a floating joint `root_joint` between the world and its root link.
    #[staticmethod]
    #[pyo3(signature = (path, floating_base=false, couplings=false, args=None, package_paths=None))]
    fn from_file(
        py: Python<'_>,
        path: PathBuf,
        floating_base: bool,
        couplings: bool,
        args: Option<Vec<(String, String)>>,
        package_paths: Option<Vec<PathBuf>>,
    ) -> PyResult<Self> {
        // Read once (a FIFO can be read only once), bounded, off the GIL and open to Ctrl-C.
        let read = path.clone();
        let source = files::read_interruptibly(py, move || {
            kinechain::io::read_robot_file(&read).map_err(|e| error_chain(&e))
        })?
        .map_err(LoadError::new_err)?;
        let mut options = LoadOptions::default()
            .with_floating_base(floating_base)
            .with_couplings(couplings)
            .with_xacro(xacro_options(args, package_paths));
        if kinechain::io::Format::from_path(&path) == Some(kinechain::io::Format::Xacro) {
            // The expanded URDF is the chain's source: what a pickled copy is rebuilt from.
            let expansion = expand(py, &path, &source, options.xacro.clone())?;
            let inner = Inner::from_xacro_expansion(&path, &expansion, &options)
                .map_err(|e| load_error(&e))?;
            let origin = std::fs::canonicalize(&path).ok().or(Some(path.clone()));
            let options = LoadOptions::default().with_floating_base(floating_base);
            return Chain::new(py, inner, (expansion.urdf, "urdf", options), origin);
        }
        let inner =
            Inner::from_file_text_with(&path, &source, &options).map_err(|e| load_error(&e))?;
        let origin = std::fs::canonicalize(&path).ok().or(Some(path.clone()));
        let format = match kinechain::io::Format::from_path(&path) {
            Some(kinechain::io::Format::Urdf) => "urdf",
            Some(kinechain::io::Format::Mjcf) => {
                // An unpickled copy reads the includes from the same directory.
                if let Some(dir) = origin.as_deref().and_then(std::path::Path::parent) {
                    options = options.with_base_dir(dir);
                }
                "mjcf"
            }
            _ => "yaml",
        };
        Chain::new(py, inner, (source, format, options), origin)
    }

    /// A robot from URDF text (with `floating_base`, a floating joint above its root link).
    #[staticmethod]
    #[pyo3(signature = (text, floating_base=false))]
    fn from_urdf_string(py: Python<'_>, text: String, floating_base: bool) -> PyResult<Self> {
        let options = LoadOptions::default().with_floating_base(floating_base);
        Chain::from_text(py, text, "urdf", "robot", options)
    }

    /// A robot from MJCF text, its includes looked up in `base_dir` (by default the current
    /// directory); with `floating_base`, a floating joint above its root link.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir=None, floating_base=false, couplings=false))]
    fn from_mjcf_string(
        py: Python<'_>,
        text: String,
        base_dir: Option<PathBuf>,
        floating_base: bool,
        couplings: bool,
    ) -> PyResult<Self> {
        let options = load_options(floating_base, couplings, base_dir);
        Chain::from_text(py, text, "mjcf", "robot", options)
    }

    /// A robot from DH YAML text (with `floating_base`, a floating joint above its root link).
    #[staticmethod]
    #[pyo3(signature = (text, floating_base=false))]
    fn from_yaml_string(py: Python<'_>, text: String, floating_base: bool) -> PyResult<Self> {
        let options = LoadOptions::default().with_floating_base(floating_base);
        Chain::from_text(py, text, "yaml", "robot", options)
    }

    /// A robot from its text, format (`urdf`, `yaml` or `mjcf`), name (where the text names
    /// none), whether a floating base was added and where an MJCF file's includes are; what
    /// unpickling calls.
    #[staticmethod]
    #[pyo3(signature = (text, format, name="robot", floating_base=false, base_dir=None, couplings=false))]
    fn _from_source(
        py: Python<'_>,
        text: String,
        format: &str,
        name: &str,
        floating_base: bool,
        base_dir: Option<PathBuf>,
        couplings: bool,
    ) -> PyResult<Self> {
        let options = load_options(floating_base, couplings, base_dir);
        Chain::from_text(py, text, format, name, options)
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        let make = slf.get_type().getattr("_from_source")?;
        let me = slf.get();
        let state = (
            me.source.clone(),
            me.format,
            me.robot.inner.name(),
            me.options.floating_base,
            me.options.base_dir.clone(),
            me.options.couplings,
        );
        (make, state).into_pyobject(slf.py())
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<Chain>().is_ok_and(|o| {
            let o = o.get();
            o.source == self.source
                && o.format == self.format
                && o.options == self.options
                && o.robot.inner.name() == self.robot.inner.name()
        })
    }

    fn __hash__(&self) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        (
            &self.source,
            self.format,
            self.options.floating_base,
            self.robot.inner.name(),
        )
            .hash(&mut h);
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

    /// What the loader noticed and did not refuse (MJCF equality constraints not applied, a
    /// ball joint's range not checked, ...); `kinechain.load` also issues each as a
    /// `UserWarning`.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.robot.inner.warnings().to_vec()
    }

    /// Degrees of freedom: the entries of `qd`, `qdd` and the columns of a Jacobian ([`nv`]);
    /// `q` has as many but for floating and ball joints ([`nq`]).
    #[getter]
    fn dof(&self) -> usize {
        self.robot.inner.dof()
    }

    /// Entries of a configuration `q`: `dof`, and one more for a floating joint and for each
    /// ball joint (their orientations are quaternions).
    #[getter]
    fn nq(&self) -> usize {
        self.robot.inner.nq()
    }

    /// Entries of `qd` and `qdd`: `dof`.
    #[getter]
    fn nv(&self) -> usize {
        self.robot.inner.nv()
    }

    /// The name of each entry of `q`, in order: the independent joints depth-first from the root
    /// (as `kinechain info` lists them); a cylindrical joint's two as `NAME.theta`, `NAME.d`, a
    /// floating joint's seven as `NAME.x` … `NAME.qz`.
    #[getter]
    fn q_names(&self) -> Vec<String> {
        variable_names(&self.robot.inner)
    }

    /// The unit of each entry of `q`, in `q_names` order: `"rad"` (a revolute or continuous
    /// joint, a cylindrical joint's θ), `"m"` (a prismatic joint, a cylindrical joint's d, a
    /// floating joint's position) or `"1"` (a floating joint's quaternion).
    #[getter]
    fn q_units(&self) -> Vec<&'static str> {
        kinechain::regression::variable_units(&self.robot.inner)
    }

    /// The robot file's named configurations (MJCF `<key>` elements), by name, in file order:
    /// each a `q` of `nq` entries (MuJoCo's `qpos`).
    #[getter]
    fn keyframes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let dict = pyo3::types::PyDict::new(py);
        for (name, q) in self.robot.inner.keyframes() {
            dict.set_item(name, PyArray1::from_slice(py, q))?;
        }
        Ok(dict)
    }

    /// The name of each entry of `qd` and `qdd`: as `q_names`, a floating joint's six as
    /// `NAME.vx`, `NAME.vy`, `NAME.vz`, `NAME.wx`, `NAME.wy`, `NAME.wz`.
    #[getter]
    fn v_names(&self) -> Vec<String> {
        kinechain::regression::velocity_names(&self.robot.inner)
    }

    /// `q_names` (the name the package first gave them).
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        variable_names(&self.robot.inner)
    }

    /// The tree: every joint (fixed and mimic ones too) in the chain's order as a dict of its
    /// `name`, `type`, `parent` and `child` links, `axis` (joint frame), `origin` and `post`
    /// (4 × 4 nested lists: the child's frame is `parent · origin · M(θ, d) · post`, `M` the
    /// motion about and along `axis`, eq. 2.119), `theta` and `d` at `q = 0`, `q` (the index of
    /// its first entry of `q`, or None) and `mimic` (`joint`, `multiplier`, `offset`, or None).
    #[getter]
    fn joints<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, pyo3::types::PyDict>>> {
        let chain = &self.robot.inner;
        let matrix = |t: &kinechain::Transform| t.to_rows().to_vec();
        chain
            .description()
            .joints()
            .iter()
            .map(|spec| {
                let d = pyo3::types::PyDict::new(py);
                d.set_item("name", &spec.name)?;
                d.set_item("type", spec.kind.as_str())?;
                d.set_item("parent", &spec.parent)?;
                d.set_item("child", &spec.child)?;
                d.set_item("axis", spec.axis.to_vec())?;
                d.set_item("origin", matrix(&spec.origin))?;
                d.set_item("post", matrix(&spec.post))?;
                d.set_item("theta", spec.theta)?;
                d.set_item("d", spec.d)?;
                let q = chain
                    .joint_id(&spec.name)
                    .ok()
                    .and_then(|j| chain.joint(j).q_index());
                d.set_item("q", q)?;
                match &spec.mimic {
                    Some(m) => {
                        let mimic = pyo3::types::PyDict::new(py);
                        mimic.set_item("joint", &m.joint)?;
                        mimic.set_item("multiplier", m.multiplier)?;
                        mimic.set_item("offset", m.offset)?;
                        d.set_item("mimic", mimic)?;
                    }
                    None => d.set_item("mimic", py.None())?,
                }
                Ok(d)
            })
            .collect()
    }

    /// Each link's parent link (None for the root).
    #[getter]
    fn parents(&self) -> std::collections::HashMap<String, Option<String>> {
        let chain = &self.robot.inner;
        chain
            .links()
            .iter()
            .map(|l| {
                let parent = l
                    .parent_joint()
                    .map(|j| chain.link(chain.joint(j).parent()).name().to_string());
                (l.name().to_string(), parent)
            })
            .collect()
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
}
