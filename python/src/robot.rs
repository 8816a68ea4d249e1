//! What an evaluation needs of a loaded chain: the chain, its links (every link's lookup made
//! at load, the last request's kept), and what single calls reuse from one call to the next.

use crate::links::{LinkCache, Links, all_links};
use crate::spare::Spare;
use kinechain::nalgebra::Matrix6xX;
use kinechain::{Chain as Inner, Data, LimitPolicy};
use pyo3::prelude::*;
use std::sync::{Arc, Mutex, TryLockError};

pub(crate) struct Robot {
    pub(crate) inner: Inner,
    /// Every link.
    all: Arc<Links>,
    /// Reused by whichever call finds it free: under one lock, so that a single call takes
    /// one lock.
    reused: Mutex<Reused>,
}

/// What calls reuse: the links of the last request and the spare output arrays, and the
/// buffers of single evaluations.
pub(crate) struct Reused {
    pub(crate) links: LinkCache,
    /// The Jacobian arrays of single calls.
    pub(crate) jacobian_spare: Spare,
    scratch: Option<Scratch>,
}

impl Reused {
    fn new(all: &Arc<Links>) -> Self {
        Reused {
            links: LinkCache::new(Arc::clone(all)),
            jacobian_spare: Spare::default(),
            scratch: None,
        }
    }

    /// The buffers of single evaluations (made on first use), checking joint values under
    /// `policy`.
    pub(crate) fn scratch(&mut self, chain: &Inner, policy: LimitPolicy) -> &mut Scratch {
        let s = self.scratch.get_or_insert_with(|| Scratch {
            data: Data::new(chain),
            q: vec![0.0; chain.nq()],
            j: Matrix6xX::zeros(chain.nv()),
        });
        s.data.set_limit_policy(policy);
        s
    }
}

/// What a single evaluation works in: the core's buffers, and a copy of the joint values.
pub(crate) struct Scratch {
    pub(crate) data: Data,
    /// `nq` entries.
    pub(crate) q: Vec<f64>,
    /// A Jacobian.
    pub(crate) j: Matrix6xX<f64>,
}

impl Robot {
    pub(crate) fn new(py: Python<'_>, inner: Inner) -> PyResult<Self> {
        let all = all_links(py, &inner)?;
        Ok(Robot {
            reused: Mutex::new(Reused::new(&all)),
            all,
            inner,
        })
    }

    /// Runs `f` with what calls reuse, or with a fresh copy when another thread holds it (it
    /// can, while Python code that a link request runs, iterating a user's iterable, lets
    /// another thread in).
    pub(crate) fn with_reused<T>(&self, f: impl FnOnce(&mut Reused) -> T) -> T {
        match self.reused.try_lock() {
            Ok(mut r) => f(&mut r),
            Err(TryLockError::Poisoned(p)) => f(&mut p.into_inner()),
            Err(TryLockError::WouldBlock) => f(&mut Reused::new(&self.all)),
        }
    }

    /// The links asked for (every link for `None`, else a name or an iterable of names).
    pub(crate) fn links(
        &self,
        py: Python<'_>,
        asked: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Arc<Links>> {
        self.with_reused(|r| Ok(Arc::clone(r.links.get(py, &self.inner, asked)?.0)))
    }

    /// Runs `f` with the buffers of single evaluations.
    pub(crate) fn with_data<T>(&self, policy: LimitPolicy, f: impl FnOnce(&mut Data) -> T) -> T {
        self.with_reused(|r| f(&mut r.scratch(&self.inner, policy).data))
    }
}

/// `check_limits=` as the core's policy.
pub(crate) fn policy(check_limits: bool) -> LimitPolicy {
    if check_limits {
        LimitPolicy::Enforce
    } else {
        LimitPolicy::Ignore
    }
}
