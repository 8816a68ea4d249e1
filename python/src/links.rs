//! The links a call asks for: their ids and finiteness-check set (the core's
//! [`LinkSelection`]), their names as one Python list shared by the results, and their
//! positions by name. Every link's is made at load; a `links=` request's is kept and reused
//! while requests name the same links (a control loop asks for the same ones on every call).

use crate::errors::error;
use crate::spare::Spare;
use kinechain::Chain as Inner;
use kinechain::eval::batch::LinkSelection;
use pyo3::prelude::*;
use pyo3::types::{PyList, PyString, PyTuple};
use std::collections::HashMap;
use std::sync::Arc;

/// Links of a result, in the order of its arrays.
pub(crate) struct Links {
    pub(crate) selection: LinkSelection,
    /// The names, as asked for (compared with the next request's without allocating), and the
    /// string objects they were asked with (none for every link).
    names: Vec<String>,
    objects: Vec<Py<PyAny>>,
    pub(crate) list: Py<PyList>,
    /// Each name's first position.
    pub(crate) index: HashMap<String, usize>,
}

impl Links {
    pub(crate) fn new(
        py: Python<'_>,
        chain: &Inner,
        names: Vec<String>,
        objects: Vec<Py<PyAny>>,
    ) -> PyResult<Self> {
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
            objects,
            index,
        })
    }

    /// Whether these are `other`'s links, in the same order.
    pub(crate) fn same_names(&self, other: &Links) -> bool {
        self.names == other.names
    }

    /// Whether `asked` (a name, or a list or tuple of names) names these links, in order;
    /// compared without allocating, the very same string objects first.
    fn named(&self, asked: &Bound<'_, PyAny>) -> bool {
        let same = |i: usize, a: Bound<'_, PyAny>| {
            self.objects.get(i).is_some_and(|o| a.is(o))
                || a.cast::<PyString>()
                    .is_ok_and(|a| a.to_str().is_ok_and(|a| a == self.names[i]))
        };
        if let Ok(list) = asked.cast::<PyList>() {
            list.len() == self.names.len() && list.iter().enumerate().all(|(i, a)| same(i, a))
        } else if let Ok(tuple) = asked.cast::<PyTuple>() {
            tuple.len() == self.names.len() && tuple.iter().enumerate().all(|(i, a)| same(i, a))
        } else {
            asked.is_instance_of::<PyString>() && self.names.len() == 1 && same(0, asked.clone())
        }
    }
}

/// Every link of a chain, the last `links=` request, and the spare pose arrays of single
/// calls on each.
pub(crate) struct LinkCache {
    all: Arc<Links>,
    spare_all: Spare,
    last: Option<(Arc<Links>, Spare)>,
}

impl LinkCache {
    /// A cache of `all`, every link of a chain ([`all_links`]).
    pub(crate) fn new(all: Arc<Links>) -> Self {
        LinkCache {
            all,
            spare_all: Spare::default(),
            last: None,
        }
    }

    /// The links asked for (every link for `None`, else a name or an iterable of names) and
    /// the spare pose arrays of single calls on them.
    pub(crate) fn get(
        &mut self,
        py: Python<'_>,
        chain: &Inner,
        links: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(&Arc<Links>, &mut Spare)> {
        let Some(links) = links else {
            return Ok((&self.all, &mut self.spare_all));
        };
        let reuse = self.last.as_ref().is_some_and(|(l, _)| l.named(links));
        if !reuse {
            let asked: Vec<Bound<'_, PyAny>> = if links.is_instance_of::<PyString>() {
                vec![links.clone()]
            } else {
                links.try_iter()?.collect::<PyResult<_>>()?
            };
            let names = asked
                .iter()
                .map(|x| x.extract::<String>())
                .collect::<PyResult<Vec<_>>>()?;
            let objects = asked.into_iter().map(Bound::unbind).collect();
            let made = Links::new(py, chain, names, objects)?;
            self.last = Some((Arc::new(made), Spare::default()));
        }
        match &mut self.last {
            Some((l, spare)) => Ok((l, spare)),
            None => Err(crate::errors::Error::new_err("no links")),
        }
    }
}

/// Every link of `chain`, in its order.
pub(crate) fn all_links(py: Python<'_>, chain: &Inner) -> PyResult<Arc<Links>> {
    let names = chain.links().iter().map(|l| l.name().to_string()).collect();
    Ok(Arc::new(Links::new(py, chain, names, Vec::new())?))
}
