//! Where a batch runs: the calling thread or a pool of this module's own, and the signals
//! (Ctrl-C) that stop it. The blocks, the outputs and the scheduling are the core's
//! ([`kinechain::eval::batch::write_link_batch`]); this module chooses its [`Workers`] and
//! answers its [`Interrupt`].
//!
//! The pools are not rayon's global pool: a child made by `os.fork()` (or a `multiprocessing`
//! pool with the `fork` start method) inherits a pool without its threads, and its next batch
//! would wait for them forever. Each pool is tagged with the process that built it; a process
//! that finds a pool of another process builds its own.

use crate::errors::Error;
use kinechain::eval::batch::{Interrupt, Workers};
use pyo3::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Pools kept for different `threads=` values (the default's and a few others).
const MAX_POOLS: usize = 8;

/// This process's pools, by thread count (`None`: one thread per core).
struct Pools {
    pid: u32,
    pools: HashMap<Option<usize>, Arc<rayon::ThreadPool>>,
}

static POOLS: Mutex<Option<Pools>> = Mutex::new(None);

/// The pool of `threads` threads (one per core for `None`) of this process.
fn pool(threads: Option<usize>) -> Result<Arc<rayon::ThreadPool>, String> {
    let pid = std::process::id();
    let mut guard = POOLS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if guard.as_ref().is_none_or(|p| p.pid != pid) {
        // Pools inherited through `fork` have no threads in this process: forgotten, not
        // dropped (dropping would wake threads that are not there).
        if let Some(inherited) = guard.take() {
            std::mem::forget(inherited);
        }
        *guard = Some(Pools {
            pid,
            pools: HashMap::new(),
        });
    }
    let pools = &mut guard.as_mut().ok_or("no pools")?.pools;
    if let Some(p) = pools.get(&threads) {
        return Ok(Arc::clone(p));
    }
    if pools.len() >= MAX_POOLS {
        pools.retain(|k, _| k.is_none());
    }
    let built = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| format!("cannot start {} threads: {e}", threads.unwrap_or(0)))?;
    let built = Arc::new(built);
    pools.insert(threads, Arc::clone(&built));
    Ok(built)
}

/// The core's [`Interrupt`] for a batch run without the GIL: takes the GIL to look for a
/// pending signal, and keeps the exception its handler raises (`KeyboardInterrupt`), which is
/// then the call's error.
#[derive(Default)]
pub(crate) struct Signals {
    pub(crate) raised: Option<PyErr>,
}

impl Interrupt for Signals {
    fn interrupted(&mut self) -> bool {
        if let Err(e) = Python::attach(|py| py.check_signals()) {
            self.raised = Some(e);
        }
        self.raised.is_some()
    }
}

/// `f` with the workers of `threads=`: the calling thread for 1, else this process's pool of
/// that many threads (one per core for `None`).
pub(crate) fn with_workers<T>(
    threads: Option<usize>,
    f: impl FnOnce(Workers<'_>) -> T,
) -> PyResult<T> {
    if threads == Some(1) {
        return Ok(f(Workers::Here));
    }
    let pool = pool(threads).map_err(Error::new_err)?;
    Ok(f(Workers::Pool(&pool)))
}
