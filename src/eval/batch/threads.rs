//! When a batch is worth several threads, and the parallel loop over chunks of configurations
//! that stops at the first rejected one.

use crate::eval::batch::data::LaneCheck;
use crate::eval::checks::{LimitPolicy, all_valid};
use crate::eval::layout::chain::Chain;
use crate::eval::simd::lanes::LANES;
use std::sync::{Mutex, PoisonError};

/// Work, in joint evaluations (configurations × moving joints on the evaluated path, fixed
/// joints folded), below which [`forward_kinematics_batch_par`](crate::eval::batch::forward_kinematics_batch_par) and a parallel
/// [`forward_kinematics_batch_to`](crate::eval::batch::forward_kinematics_batch_to) stay on the calling thread: waking a thread of rayon's pool
/// costs more than it saves. On a 2-vCPU VM (AVX-512 kernels, ≈1.7 ns per joint and
/// configuration) two threads broke even at about 2 000 joint evaluations, 2.5–4 µs of one
/// thread's work, on the UR5, the Panda and a 50-joint chain, and gained 1.1–1.5× at 3 000 to
/// 4 600; this is 500 configurations of a six-joint arm, 30 of a hundred-joint chain.
pub const PARALLEL_WORK: usize = 3_000;

/// Work, in joint evaluations, of the smallest claim a parallel batch is split into (≈2 µs).
pub(crate) const TASK_WORK: usize = 1024;

/// Whether `qs` (rows of `dof` entries) with `bodies` evaluated per configuration is worth
/// splitting over threads ([`PARALLEL_WORK`]).
pub(crate) fn worth_parallel(qs: &[f64], dof: usize, bodies: usize) -> bool {
    qs.len().saturating_mul(bodies.max(1)) >= PARALLEL_WORK.saturating_mul(dof)
}

/// Runs `eval(check, buffers, c0, out)` for each group of `per_item` chunks of `qs` (its
/// first chunk `c0`, in chunks of [`LANES`]) and its output `out`, the next `item_len` entries of
/// `outs`, on the calling thread and rayon's pool, which claim runs of groups until none is left
/// ([`crate::eval::batch::claims::claimed_in_order`]); `bodies` are the bodies evaluated per configuration, and
/// `buffers` each thread's scratch, made by `scratch`. Each group is checked by the kernel on
/// its lanes with `check` (`LaneCheck::of` or, for one link, `LaneCheck::for_path`), or, when
/// the limits do not allow that (`None`), before evaluation. False when some
/// configuration is invalid (the groups after it may then be left unevaluated).
#[allow(clippy::too_many_arguments)]
pub(crate) fn par_chunks_checked<U: Send, S>(
    chain: &Chain,
    (policy, check): (LimitPolicy, Option<LaneCheck<'_>>),
    qs: &[f64],
    per_item: usize,
    bodies: usize,
    outs: &mut [U],
    item_len: usize,
    scratch: impl Fn() -> S + Sync,
    eval: impl Fn(Option<LaneCheck<'_>>, &mut S, usize, &mut [U]) -> bool + Sync,
) -> bool {
    let dof = chain.nq();
    let rows = per_item * LANES * dof;
    // Groups per claim: at least TASK_WORK joint evaluations (22 chunks of a six-joint arm, one
    // chunk of a chain of 128 joints or more).
    let per_claim = crate::eval::batch::claims::claim_len(
        outs.len().div_ceil(item_len),
        TASK_WORK.div_ceil(per_item * LANES * bodies.max(1)),
    );
    let pieces: Vec<Mutex<&mut [U]>> = outs
        .chunks_mut(per_claim * item_len)
        .map(Mutex::new)
        .collect();
    crate::eval::batch::claims::claimed_in_order(pieces.len(), scratch, |buffers, c| {
        let mut piece = pieces[c].lock().unwrap_or_else(PoisonError::into_inner);
        for (j, out) in piece.chunks_mut(item_len).enumerate() {
            let i = c * per_claim + j;
            let group = &qs[i * rows..((i + 1) * rows).min(qs.len())];
            let valid = check.is_some() || all_valid(chain, group, policy);
            if !(valid && eval(check, buffers, i * per_item, out)) {
                return Err(());
            }
        }
        Ok(())
    })
    .is_ok()
}
