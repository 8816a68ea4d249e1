//! Work split over the calling thread and rayon's pool by claiming: each thread owns a
//! contiguous share of the claims and takes them in order; a thread that runs out takes the
//! last claim left in another's share, until none is left.
//!
//! A batch handed to rayon as one parallel iterator waits, on a virtual machine, for the pool to
//! wake before any work starts and for the caller to wake after it ends (≈20 µs for an empty
//! fork–join on a 2-vCPU VM), and a thread that the hypervisor pauses holds up the rest of its
//! split. Here the caller starts at once, a helper that wakes late does less, and no thread is
//! left more than one claim behind. The shares keep a batch evaluated again into the same
//! buffers on the same cores, mostly: where the threads took claims in turn from one counter,
//! each call wrote frames that the other core held, and 4 096 Panda configurations, all links,
//! took longer on two threads than on one.

use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

/// Claims each thread aims for: the work left when the first thread runs out of claims is at most
/// about one claim per thread.
const CLAIMS_PER_THREAD: usize = 32;

/// Items per claim when `items` are shared: at least `at_least`, and few enough for about
/// [`CLAIMS_PER_THREAD`] claims per thread of rayon's current pool.
pub(crate) fn claim_len(items: usize, at_least: usize) -> usize {
    at_least
        .max(items.div_ceil(rayon::current_num_threads() * CLAIMS_PER_THREAD))
        .max(1)
}

/// Checks the caller makes for running helpers before it blocks (about a millisecond of
/// spinning, or more yielding).
const SPINS: usize = 1 << 16;

/// Checks before the caller yields its core between them.
const SPINS_BEFORE_YIELDING: usize = 1 << 10;

/// `work(scratch, c)` for every claim `c` in `0..claims`, on the calling thread and on up to
/// `rayon::current_num_threads() - 1` tasks of rayon's pool (the current one when called from a
/// pool), each thread with its own `scratch()`, made when it first claims. Each thread takes the
/// claims of its share (an equal, contiguous part) in increasing order, then one at a time the
/// last one left in another thread's share. The results come back in claim order; when some
/// claim fails, the error of the first failed claim, and the claims after the first failure seen
/// may be skipped.
pub(crate) fn claimed_in_order<S, T: Send, E: Send>(
    claims: usize,
    scratch: impl Fn() -> S + Sync,
    work: impl Fn(&mut S, usize) -> Result<T, E> + Sync,
) -> Result<Vec<T>, E> {
    let helpers = rayon::current_num_threads()
        .saturating_sub(1)
        .min(claims.saturating_sub(1));
    let threads = helpers + 1;
    // Thread `t`'s share, claims `t * claims / threads ..`; the caller is thread 0, helpers
    // number themselves as they start.
    let shares: Vec<Mutex<Range<usize>>> = (0..threads)
        .map(|t| Mutex::new(t * claims / threads..(t + 1) * claims / threads))
        .collect();
    let take = |t: usize| -> Option<usize> {
        let lock = |t: usize| shares[t].lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(c) = lock(t).next() {
            return Some(c);
        }
        (1..threads).find_map(|k| lock((t + k) % threads).next_back())
    };
    let started = AtomicUsize::new(1);
    let first_failed = AtomicUsize::new(usize::MAX);
    let running = AtomicUsize::new(0);
    let done = Mutex::new(Vec::with_capacity(claims));
    let claim_all = |t: usize| {
        let mut mine = Vec::new();
        let mut buffers = None;
        while let Some(c) = take(t) {
            if c > first_failed.load(Ordering::Relaxed) {
                continue;
            }
            let result = work(buffers.get_or_insert_with(&scratch), c);
            if result.is_err() {
                first_failed.fetch_min(c, Ordering::Relaxed);
            }
            mine.push((c, result));
        }
        // (A thread that panics in `work` never gets here; the scope passes the panic on.)
        done.lock()
            .unwrap_or_else(PoisonError::into_inner)
            .append(&mut mine);
    };
    if helpers == 0 {
        claim_all(0);
    } else {
        rayon::in_place_scope(|scope| {
            for _ in 0..helpers {
                scope.spawn(|_| {
                    running.fetch_add(1, Ordering::Relaxed);
                    claim_all(started.fetch_add(1, Ordering::Relaxed));
                    running.fetch_sub(1, Ordering::Release);
                });
            }
            claim_all(0);
            // A helper that has started finishes its last claim within about one claim's time.
            // Waiting for it here keeps the caller awake, where the scope's own wait may put it
            // to sleep and wake it only after a context switch: on a 2-vCPU VM, batches of 512
            // configurations then took two to three times as long as on one thread. After a
            // while the caller yields, in case the helper waits for its core, and at last leaves
            // the wait to the scope.
            for spin in 0..SPINS {
                if running.load(Ordering::Acquire) == 0 {
                    break;
                }
                if spin < SPINS_BEFORE_YIELDING {
                    std::hint::spin_loop();
                } else {
                    std::thread::yield_now();
                }
            }
        });
    }
    let mut done = done.into_inner().unwrap_or_else(PoisonError::into_inner);
    done.sort_unstable_by_key(|&(c, _)| c);
    done.into_iter().map(|(_, result)| result).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `f()` run in a new pool of `threads` threads.
    fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(f)
    }

    #[test]
    fn results_come_back_in_claim_order() {
        let results = in_pool(3, || {
            claimed_in_order(1000, || (), |(), c| -> Result<usize, ()> { Ok(c * c) })
        });
        assert_eq!(results, Ok((0..1000).map(|c| c * c).collect()));
    }

    /// A claim holds at least what the caller asks, and a large batch splits into about
    /// `CLAIMS_PER_THREAD` claims per thread of the pool.
    #[test]
    fn claims_are_sized_for_the_pool() {
        for threads in [1, 2, 3] {
            in_pool(threads, || {
                assert_eq!(claim_len(0, 0), 1);
                assert_eq!(claim_len(10, 8), 8);
                let items: usize = 1_000_000;
                let claims = items.div_ceil(claim_len(items, 1));
                let aim = threads * CLAIMS_PER_THREAD;
                assert!(
                    (aim - 1..=aim).contains(&claims),
                    "{threads} threads: {claims}"
                );
            });
        }
    }

    #[test]
    fn the_first_failed_claim_is_reported() {
        for threads in [1, 2, 4] {
            let result = in_pool(threads, || {
                claimed_in_order(
                    500,
                    || (),
                    |(), c| if c % 97 == 96 { Err(c) } else { Ok(c) },
                )
            });
            assert_eq!(result, Err(96), "{threads} threads");
        }
    }

    #[test]
    fn the_others_take_what_a_held_up_thread_has_left() {
        let by_caller = Mutex::new(Vec::new());
        let results = in_pool(2, || {
            let caller = std::thread::current().id();
            claimed_in_order(
                1000,
                || (),
                |(), c| -> Result<usize, ()> {
                    if std::thread::current().id() == caller {
                        by_caller.lock().unwrap().push(c);
                    }
                    if c == 0 {
                        std::thread::sleep(std::time::Duration::from_millis(200));
                    }
                    Ok(c)
                },
            )
        });
        assert_eq!(results, Ok((0..1000).collect()));
        // The caller's share is 0..500: it began at the front, the helper took the rest from the
        // back while claim 0 slept.
        let by_caller = by_caller.into_inner().unwrap();
        assert_eq!(by_caller[0], 0);
        assert!(by_caller.windows(2).all(|w| w[1] == w[0] + 1));
        assert!(by_caller.len() < 50, "{by_caller:?}");
    }

    #[test]
    fn no_claims_give_no_results() {
        let result = claimed_in_order(0, || (), |(), c| Ok::<_, ()>(c));
        assert_eq!(result, Ok(Vec::new()));
    }
}
