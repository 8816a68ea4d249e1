//! Rows of targets solved on a pool, each row bit for bit as one solve.

use crate::eval::LimitPolicy;
use crate::eval::batch::{Interrupt, Workers};
use crate::eval::check_q;
use crate::model::transform::Transform;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use super::goal::{IkError, check_target};
use super::solver::Solver;

/// Where a batch writes: row `i`'s configuration at `q[i nq..]`, its goals' residuals at
/// `position_error[i k..]` and `rotation_error[i k..]` (`k` goals).
#[derive(Debug)]
pub struct BatchOut<'a> {
    /// `n · nq` entries.
    pub q: &'a mut [f64],
    /// `n` entries.
    pub success: &'a mut [bool],
    /// `n · k` entries (m).
    pub position_error: &'a mut [f64],
    /// `n · k` entries (rad).
    pub rotation_error: &'a mut [f64],
    /// `n` entries: iterations in all attempts.
    pub iterations: &'a mut [u32],
    /// `n` entries: attempts after the first.
    pub restarts: &'a mut [u32],
}

/// Rows a worker takes at a time.
pub(super) const BATCH_BLOCK: usize = 64;

/// Solves `n` rows of targets (`targets[i k..(i + 1) k]` for row `i`, `k` goals) from `seeds`
/// (`n · nq` entries; `None`: the solver's start for every row) into `out`, on `workers`, each row
/// exactly as [`Solver::solve`] solves it alone (bit for bit, whatever the threads).
///
/// # Errors
/// [`IkError::Length`] for arrays of the wrong length; [`IkError::Row`] for the first row whose
/// targets or seed [`Solver::solve`] refuses (checked before any work);
/// [`IkError::Interrupted`] when `interrupt` stops it (rows then partly written).
pub fn solve_batch(
    solver: &Solver<'_>,
    targets: &[Transform],
    seeds: Option<&[f64]>,
    out: BatchOut<'_>,
    workers: Workers<'_>,
    interrupt: &mut dyn Interrupt,
) -> Result<(), IkError> {
    let (k, nq) = (solver.goals.len(), solver.chain.nq());
    let n = targets.len() / k;
    let need = |what, expected: usize, got: usize| {
        if expected == got {
            Ok(())
        } else {
            Err(IkError::Length {
                what,
                expected,
                got,
            })
        }
    };
    need("targets", n * k, targets.len())?;
    if let Some(s) = seeds {
        need("q0", n * nq, s.len())?;
    }
    need("q", n * nq, out.q.len())?;
    need("success", n, out.success.len())?;
    need("position_error", n * k, out.position_error.len())?;
    need("rotation_error", n * k, out.rotation_error.len())?;
    need("iterations", n, out.iterations.len())?;
    need("restarts", n, out.restarts.len())?;
    for (row, t) in targets.chunks_exact(k).enumerate() {
        for (index, t) in t.iter().enumerate() {
            check_target(t).map_err(|why| IkError::Row {
                row,
                error: Box::new(IkError::Target { index, why }),
            })?;
        }
    }
    if let Some(seeds) = seeds {
        for (row, q) in seeds.chunks_exact(nq.max(1)).enumerate().take(n) {
            check_q(solver.chain, q, LimitPolicy::Enforce).map_err(|e| IkError::Row {
                row,
                error: Box::new(IkError::Seed(e)),
            })?;
        }
    }
    let BatchOut {
        q,
        success,
        position_error,
        rotation_error,
        iterations,
        restarts,
    } = out;
    let parts: Vec<_> = q
        .chunks_mut(BATCH_BLOCK * nq.max(1))
        .zip(success.chunks_mut(BATCH_BLOCK))
        .zip(position_error.chunks_mut(BATCH_BLOCK * k))
        .zip(rotation_error.chunks_mut(BATCH_BLOCK * k))
        .zip(iterations.chunks_mut(BATCH_BLOCK))
        .zip(restarts.chunks_mut(BATCH_BLOCK))
        .enumerate()
        .map(|(b, (((((q, ok), pe), re), it), rs))| (b * BATCH_BLOCK, q, ok, pe, re, it, rs))
        .collect();
    let default_start = solver.default_start();
    let block = |s: &mut Solver<'_>, part: Part<'_>| {
        let (first, q, ok, pe, re, it, rs) = part;
        for r in 0..ok.len() {
            let row = first + r;
            match seeds {
                Some(seeds) => s.start.copy_from_slice(&seeds[row * nq..(row + 1) * nq]),
                None => s.start.copy_from_slice(&default_start),
            }
            let solution = s.run(&targets[row * k..(row + 1) * k]);
            q[r * nq..(r + 1) * nq].copy_from_slice(&solution.q);
            ok[r] = solution.success;
            for g in 0..k {
                pe[r * k + g] = solution.position_error.get(g).copied().unwrap_or(f64::NAN);
                re[r * k + g] = solution.rotation_error.get(g).copied().unwrap_or(f64::NAN);
            }
            it[r] = u32::try_from(solution.iterations).unwrap_or(u32::MAX);
            rs[r] = u32::try_from(solution.restarts).unwrap_or(u32::MAX);
        }
    };
    let pool = match workers {
        Workers::Pool(pool) if parts.len() > 1 => pool,
        _ => {
            let (mut s, mut last) = (solver.clone(), Instant::now());
            for part in parts {
                if last.elapsed() >= interrupt.interval() {
                    if interrupt.interrupted() {
                        return Err(IkError::Interrupted);
                    }
                    last = Instant::now();
                }
                block(&mut s, part);
            }
            return Ok(());
        }
    };
    let stop = AtomicBool::new(false);
    let (sent, received) = std::sync::mpsc::channel();
    let mut interrupted = false;
    pool.in_place_scope(|scope| {
        let (stop, block) = (&stop, &block);
        scope.spawn(move |_| {
            parts.into_par_iter().for_each_init(
                || solver.clone(),
                |s, part| {
                    if !stop.load(Ordering::Relaxed) {
                        block(s, part);
                    }
                },
            );
            let _ = sent.send(());
        });
        loop {
            match received.recv_timeout(interrupt.interval()) {
                Ok(()) | Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                    if !interrupted && interrupt.interrupted() {
                        stop.store(true, Ordering::Relaxed);
                        interrupted = true;
                    }
                }
            }
        }
    });
    if interrupted {
        return Err(IkError::Interrupted);
    }
    Ok(())
}

/// A block of a batch: its first row and its rows' outputs.
pub(super) type Part<'a> = (
    usize,
    &'a mut [f64],
    &'a mut [bool],
    &'a mut [f64],
    &'a mut [f64],
    &'a mut [u32],
    &'a mut [u32],
);
