//! Running a batch: the blocks of configurations, the threads they run on, and the signals
//! (Ctrl-C) that stop them.
//!
//! The threads are pools of this module's own, not rayon's global pool: a child made by
//! `os.fork()` (or a `multiprocessing` pool with the `fork` start method) inherits a pool
//! without its threads, and its next batch would wait for them forever. Each pool is tagged with
//! the process that built it; a process that finds a pool of another process builds its own.

use kinechain::eval::batch::BatchData;
use kinechain::{Chain as Inner, LimitPolicy, StateError as KStateError};
use pyo3::prelude::*;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How often a running batch looks for a signal (Ctrl-C) sent to the interpreter.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Pools kept for different `threads=` values (the default's and a few others).
const MAX_POOLS: usize = 8;

/// What an evaluation failed on: a configuration's state, the threads, or a Python exception
/// raised meanwhile (`KeyboardInterrupt`).
pub(crate) enum Failure {
    State(Option<usize>, KStateError),
    /// A result that is not finite although the inputs are: `what` (`pose`, `omega`, …) of
    /// `link` in configuration `index`.
    Overflow {
        index: Option<usize>,
        what: &'static str,
        link: String,
    },
    Threads(String),
    Python(PyErr),
}

impl Failure {
    /// The configuration it names (0 where none).
    fn index(&self) -> usize {
        match self {
            Failure::State(i, _) | Failure::Overflow { index: i, .. } => i.unwrap_or(0),
            Failure::Threads(_) | Failure::Python(_) => 0,
        }
    }
}

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

/// Looks for a pending signal at most every [`SIGNAL_POLL`], taking the GIL for it (the batch
/// runs without it); the exception its handler raises (`KeyboardInterrupt`) is the error.
pub(crate) struct SignalWatch {
    last: Instant,
}

impl SignalWatch {
    pub(crate) fn new() -> Self {
        SignalWatch {
            last: Instant::now(),
        }
    }

    pub(crate) fn poll(&mut self) -> PyResult<()> {
        if self.last.elapsed() < SIGNAL_POLL {
            return Ok(());
        }
        self.last = Instant::now();
        Python::attach(|py| py.check_signals())
    }
}

/// Runs `f` on the calling thread (`threads == Some(1)`) or on this process's pool of `threads`,
/// while the calling thread (without the GIL) looks for signals: a `KeyboardInterrupt` stops
/// the work at its next check of `stop` and is the call's error.
pub(crate) fn on_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce(&AtomicBool) -> T + Send,
) -> Result<T, Failure> {
    let stop = AtomicBool::new(false);
    if threads == Some(1) {
        return Ok(f(&stop));
    }
    let pool = pool(threads).map_err(Failure::Threads)?;
    let (sent, received) = std::sync::mpsc::channel();
    let mut interrupted = None;
    let result = pool.in_place_scope(|s| {
        let stop = &stop;
        s.spawn(move |_| {
            let _ = sent.send(f(stop));
        });
        let mut watch = SignalWatch::new();
        loop {
            match received.recv_timeout(SIGNAL_POLL) {
                Ok(result) => return Some(result),
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                    if interrupted.is_none()
                        && let Err(e) = watch.poll()
                    {
                        stop.store(true, Ordering::Relaxed);
                        interrupted = Some(e);
                    }
                }
                // The work panicked (the scope passes the panic on).
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => return None,
            }
        }
    });
    match (interrupted, result) {
        (Some(e), _) => Err(Failure::Python(e)),
        (None, Some(result)) => Ok(result),
        (None, None) => Err(Failure::Threads("the evaluation stopped".into())),
    }
}

/// Runs `f(data, range)` on the configurations `0..n` in blocks of `block` (in parallel
/// unless `threads == Some(1)`, each thread with batch buffers of its own checking under
/// `policy`), and fails with the failure of the lowest configuration among the blocks that
/// fail (every block runs; a block reports its own first failure). A signal stops the run
/// between blocks.
pub(crate) fn in_blocks(
    (chain, policy): (&Inner, LimitPolicy),
    n: usize,
    block: usize,
    threads: Option<usize>,
    f: impl Fn(&mut BatchData, std::ops::Range<usize>) -> Result<(), Failure> + Sync + Send,
) -> Result<(), Failure> {
    let make = || BatchData::new(chain).with_limit_policy(policy);
    let block = block.max(1);
    let range = |b: usize| b * block..((b + 1) * block).min(n);
    let blocks = n.div_ceil(block);
    let first = if threads == Some(1) {
        let mut data = make();
        let mut watch = SignalWatch::new();
        let mut first = None;
        for b in 0..blocks {
            watch.poll().map_err(Failure::Python)?;
            if let Err(e) = f(&mut data, range(b)) {
                first = Some(e);
                break;
            }
        }
        first
    } else {
        on_threads(threads, |stop| {
            (0..blocks)
                .into_par_iter()
                .map_init(make, |data, b| {
                    if stop.load(Ordering::Relaxed) {
                        return Ok(());
                    }
                    f(data, range(b))
                })
                .filter_map(Result::err)
                .min_by_key(Failure::index)
        })?
    };
    first.map_or(Ok(()), Err)
}
