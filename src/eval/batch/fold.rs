//! Large batches folded block by block: each block's frames are evaluated into a buffer that
//! stays in cache and handed to the caller's fold before the next block overwrites it.

use crate::eval::batch::data::BatchData;
use crate::eval::batch::data::{BatchError, configurations};
use crate::eval::batch::poses::BatchPoses;
use crate::eval::batch::poses::forward_kinematics_batch;
use crate::eval::batch::threads::worth_parallel;
use crate::eval::checks::LimitPolicy;
use crate::eval::kernel::frame::Frame;
use crate::eval::layout::chain::Chain;
use crate::eval::simd::lanes::{LANES, Lanes};

/// Bytes of frames a block of [`forward_kinematics_batch_fold`] writes at most (unless one chunk
/// of configurations needs more): they stay in a core's second-level cache while the block is
/// folded.
pub(super) const FOLD_BLOCK_BYTES: usize = 256 * 1024;

/// A batch evaluation that [`fold_blocks`] runs block by block: this module's in `f64`,
/// [`single_precision`]'s in `f32`.
pub(crate) trait BlockEval {
    /// Buffers of one thread.
    type Data: Send;
    /// The poses of one block.
    type Poses<'a>;
    /// Configurations per pass through the kernels.
    const WIDTH: usize;
    /// Bytes of one body's frames in one pass.
    const CHUNK_BYTES: usize;
    /// Empty buffers for `chain`, checking joint values under `policy`.
    fn data(chain: &Chain, policy: LimitPolicy) -> Self::Data;
    /// Every link's poses for the configurations of `qs`.
    fn poses<'a>(
        chain: &'a Chain,
        data: &'a mut Self::Data,
        qs: &[f64],
    ) -> Result<Self::Poses<'a>, BatchError>;
}

block_eval!(Double, LANES, Frame<Lanes>);

/// Configurations per block when `E` folds a batch of `chain`: a multiple of `E::WIDTH` whose
/// frames fill at most [`FOLD_BLOCK_BYTES`] (one pass for a chain too long for that).
pub(crate) fn block_len<E: BlockEval>(chain: &Chain) -> usize {
    (FOLD_BLOCK_BYTES / (chain.bodies.len().max(1) * E::CHUNK_BYTES)).max(1) * E::WIDTH
}

/// Configurations per block of [`forward_kinematics_batch_fold`] for `chain`: a multiple of
/// eight (the configurations of one pass through the kernels) whose frames, 96 bytes per body
/// and configuration, fill at most 256 KiB (eight for a chain too long for that).
#[must_use]
pub fn fold_block_len(chain: &Chain) -> usize {
    block_len::<Double>(chain)
}

/// Poses of every link for each configuration of `qs` (row-major), folded block by block into a
/// result while each block's frames are still in cache: `fold(acc, first, poses)` receives the
/// poses of configurations `first .. first + poses.len()` ([`fold_block_len`] per block, fewer
/// in the last), on the calling thread ([`forward_kinematics_batch_fold_par`] shares the blocks
/// with rayon's pool).
///
/// For large batches this is the fast way to use every link's pose: [`forward_kinematics_batch`]
/// keeps every frame of the batch (96 bytes per body and configuration), and beyond a few
/// thousand configurations it is bound by writing them to memory, which two threads share; here
/// the frames never leave the cache. The poses are those of [`forward_kinematics_batch`], bit for
/// bit. [`crate::eval::batch::single_precision::forward_kinematics_batch_fold`] is the same in `f32`.
///
/// # Errors
/// As [`forward_kinematics_batch`] (the first bad configuration is named). Blocks before it may
/// have been folded; their result is dropped.
///
/// # Examples
/// ```
/// use kinechain::{Chain, LimitPolicy, eval::batch::forward_kinematics_batch_fold_par};
/// let chain = Chain::from_file("robots/planar3.yaml")?;
/// let tip = chain.link_id("link3")?;
/// let qs: Vec<f64> = (0..1000).flat_map(|i| [0.001 * i as f64, 0.0, 0.0]).collect();
/// // The highest point the tip reaches.
/// let highest = forward_kinematics_batch_fold_par(
///     &chain,
///     &qs,
///     LimitPolicy::Enforce,
///     || f64::NEG_INFINITY,
///     |top, _first, poses| {
///         (0..poses.len()).fold(top, |top, i| top.max(poses.world_from_link(i, tip).translation().y))
///     },
///     f64::max,
/// )?;
/// approx::assert_relative_eq!(highest, 9.0 * 0.999f64.sin());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn forward_kinematics_batch_fold<T: Send>(
    chain: &Chain,
    qs: &[f64],
    policy: LimitPolicy,
    identity: impl Fn() -> T + Sync + Send,
    fold: impl Fn(T, usize, BatchPoses<'_>) -> T + Sync + Send,
    reduce: impl Fn(T, T) -> T + Sync + Send,
) -> Result<T, BatchError> {
    fold_blocks::<Double, T>(chain, qs, policy, false, identity, fold, reduce)
}

/// As [`forward_kinematics_batch_fold`], the blocks shared between the calling thread and
/// rayon's pool in runs of consecutive blocks (about 32 runs per thread), each thread evaluating
/// into buffers of its own; each run is folded from `identity()`, and the runs' results are
/// combined with `reduce` in the order of their blocks (so `reduce` must be associative, and
/// `identity()` neutral for it). Batches of fewer than [`PARALLEL_WORK`](crate::eval::batch::PARALLEL_WORK) joint evaluations stay
/// on the calling thread.
///
/// # Errors
/// As [`forward_kinematics_batch_fold`]; blocks after the bad configuration may have been
/// folded too, and their result is dropped.
pub fn forward_kinematics_batch_fold_par<T: Send>(
    chain: &Chain,
    qs: &[f64],
    policy: LimitPolicy,
    identity: impl Fn() -> T + Sync + Send,
    fold: impl Fn(T, usize, BatchPoses<'_>) -> T + Sync + Send,
    reduce: impl Fn(T, T) -> T + Sync + Send,
) -> Result<T, BatchError> {
    fold_blocks::<Double, T>(chain, qs, policy, true, identity, fold, reduce)
}

/// [`forward_kinematics_batch_fold`] with the batches of `E`, in blocks of [`block_len`].
pub(crate) fn fold_blocks<E: BlockEval, T: Send>(
    chain: &Chain,
    qs: &[f64],
    policy: LimitPolicy,
    parallel: bool,
    identity: impl Fn() -> T + Sync + Send,
    fold: impl Fn(T, usize, E::Poses<'_>) -> T + Sync + Send,
    reduce: impl Fn(T, T) -> T + Sync + Send,
) -> Result<T, BatchError> {
    // The length is checked once for the whole batch, so that blocks hold whole configurations.
    configurations(chain, qs)?;
    let block = block_len::<E>(chain);
    let rows = block * chain.nq();
    // Folds block `i` into `acc`.
    let step = |data: &mut E::Data, acc: T, (i, qs): (usize, &[f64])| {
        let first = i * block;
        match E::poses(chain, data, qs) {
            Ok(poses) => Ok(fold(acc, first, poses)),
            Err(e) => Err(BatchError {
                index: first + e.index,
                ..e
            }),
        }
    };
    if !(parallel && worth_parallel(qs, chain.nq(), chain.bodies.len())) {
        let mut data = E::data(chain, policy);
        return qs
            .chunks(rows)
            .enumerate()
            .try_fold(identity(), |acc, block| step(&mut data, acc, block));
    }
    // Claims of whole blocks; each thread evaluates into one set of buffers, each claim folds
    // from `identity()`.
    let blocks = qs.len().div_ceil(rows);
    let per_claim = crate::eval::batch::claims::claim_len(blocks, 1);
    let claim_rows = per_claim * rows;
    let folded = crate::eval::batch::claims::claimed_in_order(
        blocks.div_ceil(per_claim),
        || E::data(chain, policy),
        |data: &mut E::Data, c| {
            let claim = &qs[c * claim_rows..((c + 1) * claim_rows).min(qs.len())];
            claim
                .chunks(rows)
                .enumerate()
                .try_fold(identity(), |acc, (i, block)| {
                    step(data, acc, (c * per_claim + i, block))
                })
        },
    )?;
    Ok(folded.into_iter().reduce(reduce).unwrap_or_else(identity))
}
