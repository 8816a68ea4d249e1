//! Output arrays of single calls, handed out again once Python has let go of them.
//!
//! A control loop calls `chain.fk(q)` at every step and drops the previous result; making a
//! new numpy array for every call costs more than the kinematics do. A [`Spare`] keeps the
//! last two pose arrays it handed out, and hands one out again when nothing but the spare
//! refers to it: no other reference (a view, a result, a memoryview each hold one), no weak
//! reference, and its shape, strides, type, flags and memory as they were made (Python code
//! can change a live array's shape, dtype and flags in place). Two, so that a loop holding the
//! previous result while it asks for the next one reuses them in turn.

use crate::arrays::new_array;
use numpy::ndarray::Dimension;
use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// An array made here, and what it was made as.
struct Made {
    array: Py<PyArrayDyn<f64>>,
    descr: usize,
    data: usize,
    flags: std::os::raw::c_int,
}

impl Made {
    fn new(array: &Bound<'_, PyArrayDyn<f64>>) -> Self {
        let (descr, flags) = fields(array);
        Made {
            array: array.clone().unbind(),
            descr,
            data: array.data() as usize,
            flags,
        }
    }

    /// Whether the array is free to be written and handed out again as an array of `dims`.
    fn free(&self, py: Python<'_>, dims: &[usize]) -> bool {
        let a = self.array.bind(py);
        if a.get_refcnt() != 1 || a.data() as usize != self.data || a.shape() != dims {
            return false;
        }
        // C-ordered float64 strides of `dims`.
        let mut stride = std::mem::size_of::<f64>() as isize;
        for (&s, &d) in a.strides().iter().zip(dims).rev() {
            if d > 1 && s != stride {
                return false;
            }
            stride *= d as isize;
        }
        // SAFETY: reads fields of a live numpy array's struct, holding the GIL.
        let weak = unsafe { (*a.as_array_ptr()).weakreflist };
        weak.is_null() && fields(a) == (self.descr, self.flags)
    }
}

/// An array's type descriptor (as an address) and flags.
fn fields(a: &Bound<'_, PyArrayDyn<f64>>) -> (usize, std::os::raw::c_int) {
    // SAFETY: reads fields of a live numpy array's struct, holding the GIL.
    unsafe {
        let p = &*a.as_array_ptr();
        (p.descr as usize, p.flags)
    }
}

/// The last two arrays handed out for one kind of result.
#[derive(Default)]
pub(crate) struct Spare {
    slots: [Option<Made>; 2],
}

impl Spare {
    /// A C-ordered float64 array of shape `dims` for a single call to write: one of the spare
    /// arrays when one is free, a new one (kept as a spare) otherwise.
    pub(crate) fn take<'py, D: Dimension>(
        &mut self,
        py: Python<'py>,
        dims: D,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let slots = &mut self.slots;
        for made in slots.iter().flatten() {
            if made.free(py, dims.slice()) {
                return Ok(made.array.bind(py).clone());
            }
        }
        let array = new_array(py, dims)?;
        // The newest array replaces the older spare.
        slots.swap(0, 1);
        slots[1] = Some(Made::new(&array));
        Ok(array)
    }
}
