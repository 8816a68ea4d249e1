//! The links a call asks for: their ids and finiteness-check set (the core's
//! [`LinkSelection`]), their names as one Python list shared by the results, and their
//! positions by name. Every link's is made at load; a `links=` request's is kept and reused
//! while requests name the same links (a control loop asks for the same ones on every call).

use crate::errors::error;
use kinechain::Chain as Inner;
use kinechain::eval::batch::LinkSelection;
use pyo3::prelude::*;
use pyo3::types::{PyList, PyString};
use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

/// Links of a result, in the order of its arrays.
pub(crate) struct Links {
    pub(crate) selection: LinkSelection,
    /// The names, as asked for (compared with the next request's without allocating).
    names: Vec<String>,
    pub(crate) list: Py<PyList>,
    /// Each name's first position.
    pub(crate) index: HashMap<String, usize>,
}

impl Links {
    fn new(py: Python<'_>, chain: &Inner, names: Vec<String>) -> PyResult<Self> {
        let ids = names
            .iter()
            .map(|n| chain.link_id(n).map_err(|e| error(&e)))
            .collect::<PyResult<Vec<_>>>()?;
        let index = names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), i))
            .rev()
            .collect();
        Ok(Links {
            selection: LinkSelection::new(chain, ids),
            list: PyList::new(py, &names)?.unbind(),
            names,
            index,
        })
    }

    /// Whether `asked` are these links' names, in order.
    fn named(&self, asked: &[Bound<'_, PyAny>]) -> bool {
        self.names.len() == asked.len()
            && asked.iter().zip(&self.names).all(|(a, n)| {
                a.cast::<PyString>()
                    .is_ok_and(|a| a.to_str().is_ok_and(|a| a == n))
            })
    }
}

/// Every link of a chain, and the last `links=` request.
pub(crate) struct LinkCache {
    all: Arc<Links>,
    last: Mutex<Option<Arc<Links>>>,
}

impl LinkCache {
    pub(crate) fn new(py: Python<'_>, chain: &Inner) -> PyResult<Self> {
        let names = chain.links().iter().map(|l| l.name().to_string()).collect();
        Ok(LinkCache {
            all: Arc::new(Links::new(py, chain, names)?),
            last: Mutex::new(None),
        })
    }

    /// The links asked for: every link for `None`, else a name or an iterable of names.
    pub(crate) fn get(
        &self,
        py: Python<'_>,
        chain: &Inner,
        links: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Arc<Links>> {
        let Some(links) = links else {
            return Ok(Arc::clone(&self.all));
        };
        let asked: Vec<Bound<'_, PyAny>> = if links.is_instance_of::<PyString>() {
            vec![links.clone()]
        } else {
            links.try_iter()?.collect::<PyResult<_>>()?
        };
        let mut last = self.last.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(l) = last.as_ref()
            && l.named(&asked)
        {
            return Ok(Arc::clone(l));
        }
        let names = asked
            .iter()
            .map(|x| x.extract::<String>())
            .collect::<PyResult<Vec<_>>>()?;
        let made = Arc::new(Links::new(py, chain, names)?);
        *last = Some(Arc::clone(&made));
        Ok(made)
    }
}
