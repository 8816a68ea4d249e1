//! `FkResult`, what `Chain.fk` returns: the arrays, and the links they are of.

use crate::errors::StateError;
use crate::links::Links;
use pyo3::prelude::*;
use pyo3::types::{PyList, PySlice};
use std::sync::Arc;

/// What `Chain.fk` computed, as numpy arrays whose second-to-last axes follow `links`.
///
/// `poses`: `(L, 4, 4)` or `(N, L, 4, 4)` homogeneous transforms `world_from_link`. With `qd`:
/// `omega` (angular velocity) and `v` (velocity of the link origin), `(L, 3)` or `(N, L, 3)`.
/// With `qd` and `qdd`: `alpha` (angular acceleration) and `a` (classical acceleration of the
/// link origin). Absent quantities are `None`. `r[name]` is one link's pose, `(4, 4)` or
/// `(N, 4, 4)`.
#[pyclass(module = "kinechain", name = "FkResult", frozen)]
pub(crate) struct FkResult {
    /// Shared by every result of the same links (and by the chain): the list is handed out
    /// as a copy.
    pub(crate) links: Arc<Links>,
    #[pyo3(get)]
    pub(crate) poses: Py<PyAny>,
    #[pyo3(get)]
    pub(crate) omega: Option<Py<PyAny>>,
    #[pyo3(get)]
    pub(crate) v: Option<Py<PyAny>>,
    #[pyo3(get)]
    pub(crate) alpha: Option<Py<PyAny>>,
    #[pyo3(get)]
    pub(crate) a: Option<Py<PyAny>>,
}

impl FkResult {
    /// Its arrays, to be written again by a call of `level` (poses; with velocities; with
    /// accelerations) on `links`: the same links in the same order, the same quantities.
    pub(crate) fn outputs<'py>(
        &self,
        py: Python<'py>,
        links: &Links,
        level: usize,
    ) -> PyResult<Vec<Bound<'py, PyAny>>> {
        if !self.links.same_names(links) {
            return Err(StateError::new_err(
                "out is the result of a call on other links: it can take the results of a call on the same links, in the same order",
            ));
        }
        let rates = [&self.omega, &self.v, &self.alpha, &self.a];
        let has = rates.iter().take_while(|r| r.is_some()).count();
        if has != 2 * level {
            let what = |k: usize| {
                [
                    "poses",
                    "poses and velocities",
                    "poses, velocities and accelerations",
                ][k / 2]
            };
            return Err(StateError::new_err(format!(
                "out holds {}, this call computes {}: it can take the results of a call that computes the same",
                what(has),
                what(2 * level)
            )));
        }
        Ok(std::iter::once(&self.poses)
            .chain(rates.into_iter().flatten())
            .map(|a| a.bind(py).clone())
            .collect())
    }
}

#[pymethods]
impl FkResult {
    /// The link names, in the order of the second-to-last axes of the arrays (a new list: the
    /// result's own order cannot be changed through it).
    #[getter]
    fn links<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        PyList::new(py, self.links.list.bind(py).iter())
    }

    fn __getitem__<'py>(&self, py: Python<'py>, link: &str) -> PyResult<Bound<'py, PyAny>> {
        let Some(&i) = self.links.index.get(link) else {
            return Err(pyo3::exceptions::PyKeyError::new_err(format!(
                "no link named '{link}' in this result (links: {})",
                self.links
                    .list
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
        self.links.list.bind(py).len()
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let shape = self.poses.bind(py).getattr("shape")?.repr()?.to_string();
        let mut s = format!(
            "FkResult(links={}, poses={shape}",
            self.links.list.bind(py).len()
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
