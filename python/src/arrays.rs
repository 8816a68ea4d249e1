//! numpy arrays in and out: joint values read as C-contiguous float64 (in place when they are
//! already), their shapes checked against the chain, and new output arrays whose entries the
//! core writes.

use crate::errors::{Error, StateError};
use kinechain::Chain as Inner;
use kinechain::regression::variable_names;
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// The rows of a `(n,)` or `(N, n)` array of `what` (`q`, of the chain's `nq` entries; a
/// rate, of `nv`): `(N, batched)`.
pub(crate) fn rows(
    chain: &Inner,
    a: &PyReadonlyArrayDyn<'_, f64>,
    what: &str,
) -> PyResult<(usize, bool)> {
    let shape = a.shape();
    let width = if what == "q" { chain.nq() } else { chain.nv() };
    let (n, batched, len) = match shape {
        [len] => (1, false, *len),
        [n, len] => (*n, true, *len),
        _ => {
            return Err(StateError::new_err(format!(
                "{what} has shape {shape:?}: expected ({width},) or (N, {width})"
            )));
        }
    };
    if len != width {
        return Err(StateError::new_err(wrong_width(chain, what, len)));
    }
    Ok((n, batched))
}

/// The message for a `what` of `len` entries per configuration where the chain takes another
/// number: what makes the number up, and the names of the entries.
pub(crate) fn wrong_width(chain: &Inner, what: &str, len: usize) -> String {
    let (width, names) = if what == "q" {
        (chain.nq(), variable_names(chain))
    } else {
        (chain.nv(), kinechain::regression::velocity_names(chain))
    };
    // What the joints of several entries for one rotation take, and the others.
    let own = |j: kinechain::JointId| {
        let kind = chain.joint(j).kind();
        if what == "q" { kind.nq() } else { kind.dof() }
    };
    let parts = chain.quaternions();
    let share = match parts {
        [] => String::new(),
        _ => {
            let each: Vec<String> = parts
                .iter()
                .map(|&(j, _)| {
                    let joint = chain.joint(j);
                    format!(
                        "{} for the {} joint '{}'",
                        own(j),
                        joint.kind(),
                        joint.name()
                    )
                })
                .collect();
            let rest = width - parts.iter().map(|&(j, _)| own(j)).sum::<usize>();
            format!(": {}, {rest} for the others", each.join(", "))
        }
    };
    format!(
        "{what} has {len} entries per configuration; the chain '{}' takes {width}{share} (in order: {})",
        chain.name(),
        names.join(", ")
    )
}

/// `x` as a C-contiguous float64 array: read as it is when it already is one, converted by numpy
/// otherwise (a conversion that fails is a `StateError`).
pub(crate) fn float_array<'py>(
    x: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
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

/// `x` when it is one configuration as a plain numpy vector (not a subclass), float64,
/// C-contiguous, of `len` entries: what single calls are given, read without conversion.
pub(crate) fn plain_vector<'a, 'py>(
    x: &'a Bound<'py, PyAny>,
    len: usize,
) -> Option<&'a Bound<'py, PyArray1<f64>>> {
    // SAFETY: reads the type of a live object, and numpy's array type from its C API.
    let plain = unsafe {
        pyo3::ffi::Py_TYPE(x.as_ptr())
            == numpy::npyffi::PY_ARRAY_API
                .get_type_object(x.py(), numpy::npyffi::NpyTypes::PyArray_Type)
    };
    let a = x.cast::<PyArray1<f64>>().ok()?;
    (plain && a.is_c_contiguous() && a.len() == len).then_some(a)
}

/// Copies the entries of `a` (a C-contiguous vector of `dst.len()` entries, from
/// [`plain_vector`]) into `dst`, holding the GIL.
pub(crate) fn copy_vector(a: &Bound<'_, PyArray1<f64>>, dst: &mut [f64]) -> PyResult<()> {
    // SAFETY: a copy made while the GIL is held, as rust-numpy's safe `to_vec` makes it, into a
    // buffer of ours (no allocation, unlike `to_vec`); the slice lives only for the copy.
    let src = unsafe { a.as_slice() }.map_err(|e| Error::new_err(e.to_string()))?;
    if src.len() != dst.len() {
        return Err(Error::new_err("joint values changed length while read"));
    }
    dst.copy_from_slice(src);
    Ok(())
}

/// `threads=`: `None`, or a positive integer.
pub(crate) fn thread_count(threads: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
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

/// A new, uninitialised C-ordered float64 array of shape `dims`; a `MemoryError` (or numpy's
/// `ValueError` for a shape too large to index) when numpy cannot make it.
pub(crate) fn new_array<'py, D: numpy::ndarray::Dimension>(
    py: Python<'py>,
    dims: D,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    use numpy::npyffi::{NPY_TYPES, NpyTypes, PY_ARRAY_API, npy_intp};
    // The shapes made here have at most four axes: on the stack.
    let mut shape: [npy_intp; 4] = [0; 4];
    let nd = dims.ndim();
    if nd > shape.len() {
        return Err(Error::new_err("too many dimensions"));
    }
    for (s, &d) in shape.iter_mut().zip(dims.slice()) {
        *s = npy_intp::try_from(d)
            .map_err(|_| pyo3::exceptions::PyMemoryError::new_err("array too large"))?;
    }
    let nd =
        std::os::raw::c_int::try_from(nd).map_err(|_| Error::new_err("too many dimensions"))?;
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

/// The entries of `a`, a C-contiguous array, to write.
///
/// # Safety
/// `a` is an array this package has just made ([`new_array`]) and not yet handed to Python:
/// no other reference to its data exists while the slice lives. (rust-numpy's
/// `as_slice_mut` is unsafe for this reason: numpy arrays can alias without its knowledge.)
#[allow(clippy::mut_from_ref)]
pub(crate) unsafe fn entries<'a>(a: &'a Bound<'_, PyArrayDyn<f64>>) -> PyResult<&'a mut [f64]> {
    // SAFETY: the caller's promise above.
    unsafe { a.as_slice_mut() }.map_err(|e| Error::new_err(e.to_string()))
}

/// Whether the C-contiguous arrays `a` and `b` share memory.
pub(crate) fn overlaps(a: &Bound<'_, PyArrayDyn<f64>>, b: &Bound<'_, PyArrayDyn<f64>>) -> bool {
    let range = |a: &Bound<'_, PyArrayDyn<f64>>| {
        let start = a.data() as usize;
        start..start + a.len() * std::mem::size_of::<f64>()
    };
    let (x, y) = (range(a), range(b));
    !x.is_empty() && !y.is_empty() && x.start < y.end && y.start < x.end
}
