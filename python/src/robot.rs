//! What an evaluation needs of a loaded chain: the chain, its links (every link's lookup made
//! at load, the last request's kept), and buffers of single evaluations reused across calls.

use crate::links::LinkCache;
use kinechain::{Chain as Inner, Data, LimitPolicy};
use pyo3::prelude::*;
use std::sync::Mutex;

pub(crate) struct Robot {
    pub(crate) inner: Inner,
    pub(crate) links: LinkCache,
    /// Buffers of single evaluations, reused by whichever call finds them free.
    data: Mutex<Option<Data>>,
}

impl Robot {
    pub(crate) fn new(py: Python<'_>, inner: Inner) -> PyResult<Self> {
        Ok(Robot {
            links: LinkCache::new(py, &inner)?,
            inner,
            data: Mutex::new(None),
        })
    }

    /// Runs `f` with the cached single-evaluation buffers (or fresh ones when another thread
    /// holds them), checking joint values under `policy`.
    pub(crate) fn with_data<T>(&self, policy: LimitPolicy, f: impl FnOnce(&mut Data) -> T) -> T {
        if let Ok(mut cached) = self.data.try_lock() {
            let data = cached.get_or_insert_with(|| Data::new(&self.inner));
            data.set_limit_policy(policy);
            return f(data);
        }
        f(&mut Data::new(&self.inner).with_limit_policy(policy))
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
