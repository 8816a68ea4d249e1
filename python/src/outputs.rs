//! The arrays a call writes its results into: new ones, or the caller's (`out=`), each checked
//! for its shape and borrowed for writing while the core writes it.

use crate::arrays::{entries, new_array, overlaps};
use crate::errors::{Error, StateError};
use numpy::ndarray::{Dimension, IxDyn};
use numpy::{
    PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyReadwriteArrayDyn, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

/// One output array.
enum Output<'py> {
    /// Made by this call, not yet handed out.
    New(Bound<'py, PyArrayDyn<f64>>),
    /// The caller's, borrowed for writing.
    Caller(Bound<'py, PyArrayDyn<f64>>, PyReadwriteArrayDyn<'py, f64>),
}

/// The output arrays of one call, in the order the core writes them.
pub(crate) struct Outputs<'py> {
    arrays: Vec<Output<'py>>,
}

impl<'py> Outputs<'py> {
    /// New arrays of `shapes`.
    pub(crate) fn new(py: Python<'py>, shapes: &[IxDyn]) -> PyResult<Self> {
        let arrays = shapes
            .iter()
            .map(|s| new_array(py, s.clone()).map(Output::New))
            .collect::<PyResult<_>>()?;
        Ok(Outputs { arrays })
    }

    /// The caller's arrays `given` (each named by `names` in errors), which must have
    /// `shapes`, be writeable, C-contiguous and float64, and share no memory with `inputs`
    /// (named) or each other.
    pub(crate) fn caller(
        given: &[Bound<'py, PyAny>],
        names: &[&str],
        shapes: &[IxDyn],
        inputs: &[(&PyReadonlyArrayDyn<'py, f64>, &str)],
    ) -> PyResult<Self> {
        let mut arrays = Vec::with_capacity(given.len());
        for ((o, name), want) in given.iter().zip(names).zip(shapes) {
            let a = o.cast::<PyArrayDyn<f64>>().map_err(|_| {
                StateError::new_err(format!("{name} must be a numpy array of float64"))
            })?;
            if a.shape() != want.slice() || !a.is_c_contiguous() {
                return Err(StateError::new_err(format!(
                    "{name} has shape {:?}: expected a writeable C-contiguous float64 array of shape {:?}",
                    a.shape(),
                    want.slice()
                )));
            }
            // numpy's borrow checking refuses an overlap with another borrow when both are
            // views of one array; `overlaps` finds views of one buffer made otherwise, as by
            // `np.frombuffer`.
            let borrow = a
                .try_readwrite()
                .map_err(|e| StateError::new_err(format!("{name}: {e}")))?;
            for (input, what) in inputs {
                if overlaps(input, a) {
                    return Err(StateError::new_err(format!(
                        "{name} shares memory with {what}: the results would overwrite the values they are computed from"
                    )));
                }
            }
            for (other, other_name) in arrays.iter().zip(names) {
                if let Output::Caller(b, _) = other
                    && overlaps(b, a)
                {
                    return Err(StateError::new_err(format!(
                        "{name} shares memory with {other_name}"
                    )));
                }
            }
            arrays.push(Output::Caller(a.clone(), borrow));
        }
        Ok(Outputs { arrays })
    }

    /// These, then new arrays of `shapes`.
    pub(crate) fn then_new(mut self, py: Python<'py>, shapes: &[IxDyn]) -> PyResult<Self> {
        self.arrays.extend(Outputs::new(py, shapes)?.arrays);
        Ok(self)
    }

    /// The entries of each array, to write, in order (empty slices past the last).
    pub(crate) fn slices<const K: usize>(&mut self) -> PyResult<[&mut [f64]; K]> {
        let mut out: [&mut [f64]; K] = std::array::from_fn(|_| &mut [][..]);
        if self.arrays.len() > K {
            return Err(Error::new_err("too many outputs"));
        }
        for (o, a) in out.iter_mut().zip(self.arrays.iter_mut()) {
            *o = match a {
                // SAFETY: a new array, not yet handed out, taken once here; the core writes
                // every entry before it is read (an error drops it unread).
                Output::New(a) => unsafe { entries(a)? },
                Output::Caller(_, b) => b.as_slice_mut()?,
            };
        }
        Ok(out)
    }

    /// The arrays, their borrows ended.
    pub(crate) fn into_arrays(self) -> impl Iterator<Item = Py<PyAny>> {
        self.arrays.into_iter().map(|a| match a {
            Output::New(a) | Output::Caller(a, _) => a.into_any().unbind(),
        })
    }
}
