//! Many configurations at once: link poses of `n` configurations of one chain, eight per pass
//! through the kernels (one configuration per SIMD lane), on one thread or several.
//!
//! Configurations are given row-major (`qs[i * dof + j]` is joint entry `j` of configuration
//! `i`). Results are the same as [`forward_kinematics`](crate::forward_kinematics) gives for each
//! configuration, to the last bit on the same instruction set.

use crate::eval::arith::{Arith, fma_dispatch};
use crate::eval::chain::Chain;
use crate::eval::data::LimitPolicy;
use crate::eval::error::StateError;
use crate::eval::kernel::{self, Frame, LANES, LaneNum, Lanes, Num, by_shape};
use crate::eval::kinematics::{all_valid, check_q};
use crate::eval::layout::{Body, CheapPlacement, DenseLimits, Placement, ZTail};
use crate::eval::padded;
use crate::model::chain::LinkId;
use crate::model::joint::Term;
use crate::model::transform::Transform;
use std::sync::{Mutex, PoisonError};

/// `len` and `is_empty` of result views whose `data` counts the batch's configurations.
macro_rules! batch_len {
    ($($view:ident),*) => {
        $(
            impl $view<'_> {
                /// Number of configurations.
                #[must_use]
                pub fn len(&self) -> usize {
                    self.data.len
                }

                /// True for an empty batch.
                #[must_use]
                pub fn is_empty(&self) -> bool {
                    self.data.len == 0
                }
            }
        )*
    };
}

/// `$name`, the batch of the module invoking this, as [`BlockEval`]: its `BatchData`,
/// `BatchPoses` and `forward_kinematics_batch`, `$width` configurations per pass in frames of
/// `$frame`.
macro_rules! block_eval {
    ($name:ident, $width:expr, $frame:ty) => {
        struct $name;

        impl $crate::eval::batch::BlockEval for $name {
            type Data = BatchData;
            type Poses<'a> = BatchPoses<'a>;
            const WIDTH: usize = $width;
            const CHUNK_BYTES: usize = std::mem::size_of::<$frame>();
            fn data(chain: &Chain, policy: LimitPolicy) -> BatchData {
                BatchData::new(chain).with_limit_policy(policy)
            }
            fn poses<'a>(
                chain: &'a Chain,
                data: &'a mut BatchData,
                qs: &[f64],
            ) -> Result<BatchPoses<'a>, BatchError> {
                forward_kinematics_batch(chain, data, qs)
            }
        }
    };
}

/// The limit-policy methods of a `BatchData` (`f64` or `f32`), inside its `impl` block; the
/// type keeps its policy in a field `limit_policy`.
macro_rules! limit_policy_methods {
    () => {
        /// These buffers, with evaluations checking joint limits under `policy` (as
        /// [`BatchData::set_limit_policy`] sets it), in one expression:
        /// `BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore)`.
        #[must_use]
        pub fn with_limit_policy(mut self, policy: LimitPolicy) -> Self {
            self.set_limit_policy(policy);
            self
        }

        /// Chooses whether evaluations check joint limits (default [`LimitPolicy::Enforce`]).
        pub fn set_limit_policy(&mut self, policy: LimitPolicy) {
            self.limit_policy = policy;
        }

        /// The limit policy in force.
        #[must_use]
        pub fn limit_policy(&self) -> LimitPolicy {
            self.limit_policy
        }
    };
}

mod blocks;
mod claims;
mod fold;
mod jacobians;
mod lane_rates;
mod matrices;
mod rates;
pub mod single_precision;

#[allow(clippy::wildcard_imports)]
use blocks::*;
pub(crate) use fold::{BlockEval, block_len, fold_blocks};
pub use fold::{fold_block_len, forward_kinematics_batch_fold, forward_kinematics_batch_fold_par};
pub use jacobians::{
    jacobian_batch, jacobian_batch_par, jacobian_dot_batch, jacobian_dot_batch_par,
};
pub use rates::{
    BatchAccelerations, BatchVelocities, forward_accelerations_batch,
    forward_accelerations_batch_par, forward_velocities_batch, forward_velocities_batch_par,
};

batch_len!(BatchPoses, BatchLinkPoses);

/// Work, in joint evaluations (configurations × moving joints on the evaluated path, fixed
/// joints folded), below which [`forward_kinematics_batch_par`] and a parallel
/// [`forward_kinematics_batch_to`] stay on the calling thread: waking a thread of rayon's pool
/// costs more than it saves. On a 2-vCPU VM (AVX-512 kernels, ≈1.7 ns per joint and
/// configuration) two threads broke even at about 2 000 joint evaluations, 2.5–4 µs of one
/// thread's work, on the UR5, the Panda and a 50-joint chain, and gained 1.1–1.5× at 3 000 to
/// 4 600; this is 500 configurations of a six-joint arm, 30 of a hundred-joint chain.
pub const PARALLEL_WORK: usize = 3_000;

/// Work, in joint evaluations, of the smallest claim a parallel batch is split into (≈2 µs).
const TASK_WORK: usize = 1024;

/// Whether `qs` (rows of `dof` entries) with `bodies` evaluated per configuration is worth
/// splitting over threads ([`PARALLEL_WORK`]).
fn worth_parallel(qs: &[f64], dof: usize, bodies: usize) -> bool {
    qs.len().saturating_mul(bodies.max(1)) >= PARALLEL_WORK.saturating_mul(dof)
}

/// A configuration of a batch cannot be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("configuration {index}")]
#[non_exhaustive]
pub struct BatchError {
    /// Index of the configuration (row of `qs`).
    pub index: usize,
    /// What is wrong with it.
    #[source]
    pub source: StateError,
}

/// Buffers for evaluating batches of configurations of one chain; grows to the largest batch
/// seen and is reused.
#[derive(Clone, Debug, Default)]
pub struct BatchData {
    /// Chunk-major: `frames[c * bodies + k]` holds body `k` of configurations `8c..8c+8`.
    frames: Vec<Frame<Lanes>>,
    /// One block's joint values (one chunk's for the all-links kernel), transposed into lanes.
    q_lanes: Vec<Lanes>,
    /// [`forward_kinematics_batch_to`]: the link's body frame of each chunk, and the bodies from
    /// the base to it.
    link_frames: Vec<Frame<Lanes>>,
    path: Vec<usize>,
    /// The all-links kernel's frames of the bodies read again, when it streams ([`streams`]).
    kept: Vec<Frame<Lanes>>,
    /// The rate batches' ω and v, and α and a, of each body, chunk-major like `frames`; and one
    /// chunk's `q`, `q̇`, `q̈` transposed into lanes.
    velocities: Vec<rates::Pair>,
    accelerations: Vec<rates::Pair>,
    rate_lanes: Vec<Lanes>,
    /// One Jacobian, column-major, before it is written out row-major.
    jacobian: Vec<f64>,
    /// The lane Jacobian kernel's columns of one chunk, and its path bodies' joint origins and
    /// directions.
    jacobian_lanes: Vec<Lanes>,
    axes: Vec<[[Lanes; 3]; 2]>,
    len: usize,
    bodies: usize,
    dof: usize,
    limit_policy: LimitPolicy,
}

impl BatchData {
    /// Empty buffers for `chain`.
    #[must_use]
    pub fn new(chain: &Chain) -> Self {
        BatchData {
            frames: Vec::new(),
            q_lanes: vec![Lanes::splat(0.0); BLOCK * chain.dof()],
            link_frames: Vec::new(),
            path: Vec::with_capacity(chain.bodies.len()),
            kept: Vec::new(),
            velocities: Vec::new(),
            accelerations: Vec::new(),
            rate_lanes: vec![Lanes::splat(0.0); 3 * chain.dof()],
            jacobian: vec![0.0; 6 * chain.dof()],
            jacobian_lanes: Vec::new(),
            axes: Vec::new(),
            len: 0,
            bodies: chain.bodies.len(),
            dof: chain.dof(),
            limit_policy: LimitPolicy::Enforce,
        }
    }

    limit_policy_methods!();

    /// Records the number of configurations in `qs` and returns its number of chunks; checks
    /// the configurations first unless `check` is false (the kernels check their lanes, or the
    /// parallel path checks each chunk in its own task; both then call
    /// [`BatchData::first_error`] on failure).
    fn prepare(&mut self, chain: &Chain, qs: &[f64], check: bool) -> Result<usize, BatchError> {
        let shape = (self.bodies, self.dof);
        self.len = batch_rows("BatchData", shape, self.limit_policy, chain, qs, check)?;
        Ok(self.len.div_ceil(LANES))
    }

    /// Room for every body of `chunks` chunks; returns the number of frames that is.
    fn size_frames(&mut self, chunks: usize) -> usize {
        let zero = Frame::splat(&Transform::IDENTITY);
        let frames = chunks * self.bodies;
        self.frames.resize(frames, zero);
        frames
    }

    /// The error for the first configuration of `qs` that [`check_q`] rejects (`Ok` if none).
    fn first_error(&self, chain: &Chain, qs: &[f64]) -> Result<(), BatchError> {
        first_error(chain, qs, self.limit_policy)
    }
}

/// Whether the single-threaded all-links kernel writes `frames` frames (of one chunk and one
/// body each) around the caches: when they exceed the last-level cache, where they could not stay
/// for the caller anyway. A store to a line that is not cached first reads it from memory,
/// which a streaming store does not. On a 2-core Zen 5 virtual machine, a plain loop writing
/// 64 MiB took 1.83 ms with ordinary stores and 1.16 ms streamed; for 16 MiB, which stays in
/// the 32 MiB cache when written again, streaming took twice as long. The Panda's batch of
/// 65 536 configurations (57 MB of frames) went from 1.59–1.74 ms to 1.24–1.27 ms (medians of
/// 60 calls, five runs alternating the two), the UR5's (44 MB) from 1.04–1.12 to 0.82–0.89.
///
/// The parallel batch does not stream. Over 2 000 calls in a row, the Panda's batch took
/// 1.58–1.60 ms on two streaming threads, 1.24–1.26 ms on two with ordinary stores and
/// 1.26–1.31 ms on one streaming thread (the machine's memory took about 45 GB/s in each case).
/// In short runs, two streaming threads were at times no faster than one (Panda 1.21–1.23 ms),
/// as was a plain loop that streams twelve lines between a few arithmetic instructions, and at
/// best 13% faster than two with ordinary stores (0.73 → 0.63 ms).
fn streams(frames: usize) -> bool {
    frames.saturating_mul(size_of::<Frame<Lanes>>()) > crate::eval::arith::last_level_cache_bytes()
}

/// The length of the all-links kernel's `kept` when it streams: up to the last body whose frame a
/// branch reads again (none for a serial chain).
fn kept_len(chain: &Chain) -> usize {
    chain
        .bodies
        .iter()
        .rposition(|b| b.branches)
        .map_or(0, |k| k + 1)
}

/// The number of configurations in `qs` (rows of the chain's dof), or the error for a length
/// that is not a multiple of it (the index given is that of the incomplete row) or for a chain
/// without moving joints.
fn configurations(chain: &Chain, qs: &[f64]) -> Result<usize, BatchError> {
    let dof = chain.dof();
    if dof == 0 {
        return Err(BatchError {
            index: 0,
            source: StateError::NoDegreesOfFreedom,
        });
    }
    let n = qs.len() / dof;
    if !qs.len().is_multiple_of(dof) {
        return Err(BatchError {
            index: n,
            source: StateError::WrongLength {
                what: "q",
                expected: dof,
                got: qs.len() % dof,
            },
        });
    }
    Ok(n)
}

/// The number of configurations in `qs`, for buffers named `what` that were created for a chain
/// of `(bodies, dof)`; checks every configuration under `policy` when `check` is true.
///
/// # Panics
/// If the buffers were created for another chain than `chain`.
fn batch_rows(
    what: &str,
    (bodies, dof): (usize, usize),
    policy: LimitPolicy,
    chain: &Chain,
    qs: &[f64],
    check: bool,
) -> Result<usize, BatchError> {
    crate::eval::data::assert_buffers_match(what, bodies, dof, chain);
    let n = configurations(chain, qs)?;
    if check && !all_valid(chain, qs, policy) {
        first_error(chain, qs, policy)?;
    }
    Ok(n)
}

/// The error for the first configuration of `qs` that [`check_q`] rejects under `policy`
/// (`Ok` if none).
fn first_error(chain: &Chain, qs: &[f64], policy: LimitPolicy) -> Result<(), BatchError> {
    for (index, q) in qs.chunks_exact(chain.dof()).enumerate() {
        check_q(chain, q, policy).map_err(|source| BatchError { index, source })?;
    }
    Ok(())
}

/// Link poses of every configuration of a batch.
#[derive(Clone, Copy, Debug)]
pub struct BatchPoses<'a> {
    chain: &'a Chain,
    data: &'a BatchData,
}

impl BatchPoses<'_> {
    /// Pose of `link` in configuration `index`, world frame.
    ///
    /// # Panics
    /// If `index >= self.len()` or `link` comes from another chain.
    #[must_use]
    #[inline]
    pub fn world_from_link(&self, index: usize, link: LinkId) -> Transform {
        lane_pose(self.chain, self.data.len, link, index, |b, offset| {
            let f = &self.data.frames[(index / LANES) * self.data.bodies + b];
            lane_link_pose(f, index % LANES, offset)
        })
    }
}

/// Poses of every link for each configuration of `qs` (row-major, `dof` entries per
/// configuration), on the calling thread.
///
/// When the frames (96 bytes per body and configuration) exceed the processor's last-level
/// cache, they are written around the caches with streaming stores: about a quarter faster for
/// such a batch, which could not have stayed in the cache for the caller to read anyway.
///
/// # Errors
/// [`BatchError`] naming the first configuration that has a non-finite entry or (under
/// [`LimitPolicy::Enforce`]) a value outside a joint's limits, a `qs` whose length is not a
/// multiple of the chain's dof, or a chain without moving joints
/// ([`StateError::NoDegreesOfFreedom`]). No result is returned then (the kernels check the
/// entries as they transpose them, so the batch may have been evaluated, without effect).
///
/// # Panics
/// If `data` was created for another chain.
///
/// # Examples
/// ```
/// use kinechain::{Chain, eval::batch::{BatchData, forward_kinematics_batch}};
/// let chain = Chain::from_file("robots/planar3.yaml")?;
/// let mut data = BatchData::new(&chain);
/// let qs = [0.0, 0.0, 0.0, 1.5707963267948966, 0.0, 0.0]; // two configurations
/// let poses = forward_kinematics_batch(&chain, &mut data, &qs)?;
/// let tip = chain.link_id("link3")?;
/// approx::assert_relative_eq!(poses.world_from_link(1, tip).translation().y, 9.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn forward_kinematics_batch<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
) -> Result<BatchPoses<'a>, BatchError> {
    let check = LaneCheck::of(chain, data.limit_policy);
    let chunks = data.prepare(chain, qs, check.is_none())?;
    let stream = streams(data.size_frames(chunks));
    let bodies = chain.bodies.len().max(1);
    if stream {
        data.kept
            .resize(kept_len(chain), Frame::splat(&Transform::IDENTITY));
    }
    let mut all_ok = true;
    for (c, frames) in data
        .frames
        .chunks_exact_mut(bodies)
        .take(chunks)
        .enumerate()
    {
        all_ok &= chunk_poses(
            chain,
            check,
            frames,
            &mut data.q_lanes[..chain.dof()],
            qs,
            c,
            stream,
            &mut data.kept,
        );
    }
    if stream {
        kernel::fence_streams();
    }
    if !all_ok {
        data.first_error(chain, qs)?;
    }
    Ok(BatchPoses { chain, data })
}

/// As [`forward_kinematics_batch`], with the chunks of eight configurations shared between the
/// calling thread and `n - 1` threads of rayon's pool, `n` being its size
/// (`rayon::current_num_threads()`: the global pool's, set with `RAYON_NUM_THREADS` or
/// `rayon::ThreadPoolBuilder`, or the pool the call is made from). Each thread evaluates an
/// equal, contiguous share of the batch in runs of chunks, then takes the last runs left in
/// the others' shares, so a thread that starts late or is paused does less, and a batch
/// evaluated again into the same `data` is mostly written by the same cores. Results are
/// identical to the single-threaded call. A batch of fewer than [`PARALLEL_WORK`] joint
/// evaluations (configurations × moving joints) runs on the calling thread.
///
/// # Errors
/// As [`forward_kinematics_batch`] (the same configuration is named); no result is returned.
///
/// # Panics
/// If `data` was created for another chain.
pub fn forward_kinematics_batch_par<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
) -> Result<BatchPoses<'a>, BatchError> {
    if !worth_parallel(qs, chain.dof(), chain.bodies.len()) {
        return forward_kinematics_batch(chain, data, qs);
    }
    // The first bad configuration is looked for only on failure.
    let chunks = data.prepare(chain, qs, false)?;
    data.size_frames(chunks);
    let bodies = chain.bodies.len().max(1);
    // Ordinary stores, even where one thread streams (see `streams`).
    let all_ok = par_chunks_checked(
        chain,
        data.limit_policy,
        qs,
        1,
        bodies,
        &mut data.frames[..chunks * chain.bodies.len()],
        bodies,
        || vec![Lanes::splat(0.0); chain.dof()],
        |check, q_lanes, c, frames| {
            chunk_poses(chain, check, frames, q_lanes, qs, c, false, &mut [])
        },
    );
    if !all_ok {
        data.first_error(chain, qs)?;
    }
    Ok(BatchPoses { chain, data })
}

/// The pose of `link` in configuration `index` of `len`: `pose(b, offset)`, the frame of the
/// link's body `b` in that configuration followed by the link's offset.
#[inline]
pub(crate) fn lane_pose(
    chain: &Chain,
    len: usize,
    link: LinkId,
    index: usize,
    pose: impl FnOnce(usize, &Placement) -> Transform,
) -> Transform {
    assert!(index < len, "configuration {index} of {len}");
    let l = chain.carrier(link);
    let Some(b) = l.body else {
        return l.offset.to_transform();
    };
    pose(b, &l.offset)
}

/// `f`'s frame in lane `lane` followed by `offset`, as [`padded::link_pose`] composes it.
#[inline(always)]
fn lane_link_pose_generic<A: Arith>(
    f: &Frame<Lanes>,
    lane: usize,
    offset: &Placement,
) -> Transform {
    let lane = lane % LANES;
    let column = |c: usize| if c < 3 { &f.r[c] } else { &f.p };
    padded::link_pose_from_entries::<A>(|c, i| column(c)[i].0[lane], offset)
}

fma_dispatch!(avx2 fn lane_link_pose(f: &Frame<Lanes>, lane: usize, offset: &Placement) -> Transform => lane_link_pose_generic);

/// Runs `eval(check, buffers, c0, out)` for each group of `per_item` chunks of `qs` (its
/// first chunk `c0`, in chunks of [`LANES`]) and its output `out`, the next `item_len` entries of
/// `outs`, on the calling thread and rayon's pool, which claim runs of groups until none is left
/// ([`claims::claimed_in_order`]); `bodies` are the bodies evaluated per configuration, and
/// `buffers` each thread's scratch, made by `scratch`. Each group is checked by the kernel on
/// its lanes, or, when the limits do not allow that, before evaluation. False when some
/// configuration is invalid (the groups after it may then be left unevaluated).
#[allow(clippy::too_many_arguments)]
fn par_chunks_checked<U: Send, S>(
    chain: &Chain,
    policy: LimitPolicy,
    qs: &[f64],
    per_item: usize,
    bodies: usize,
    outs: &mut [U],
    item_len: usize,
    scratch: impl Fn() -> S + Sync,
    eval: impl Fn(Option<LaneCheck<'_>>, &mut S, usize, &mut [U]) -> bool + Sync,
) -> bool {
    let dof = chain.dof();
    let check = LaneCheck::of(chain, policy);
    let rows = per_item * LANES * dof;
    // Groups per claim: at least TASK_WORK joint evaluations (22 chunks of a six-joint arm, one
    // chunk of a chain of 128 joints or more).
    let per_claim = claims::claim_len(
        outs.len().div_ceil(item_len),
        TASK_WORK.div_ceil(per_item * LANES * bodies.max(1)),
    );
    let pieces: Vec<Mutex<&mut [U]>> = outs
        .chunks_mut(per_claim * item_len)
        .map(Mutex::new)
        .collect();
    claims::claimed_in_order(pieces.len(), scratch, |buffers, c| {
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

/// What a chunk kernel checks on its lanes after transposing them: every entry finite, and
/// within the chain's limit columns under [`LimitPolicy::Enforce`] (the decisions of
/// [`check_q`], made on eight configurations per vector).
#[derive(Clone, Copy, Debug)]
enum LaneCheck<'a> {
    Finite,
    Limits(&'a DenseLimits),
}

impl<'a> LaneCheck<'a> {
    /// `None` when the limits do not fit one check per entry ([`Chain::dense_limits`]): the
    /// configurations are then checked before evaluation.
    fn of(chain: &'a Chain, policy: LimitPolicy) -> Option<LaneCheck<'a>> {
        match (policy, &chain.dense_limits) {
            (LimitPolicy::Ignore, _) => Some(LaneCheck::Finite),
            (LimitPolicy::Enforce, Some(limits)) => Some(LaneCheck::Limits(limits)),
            (LimitPolicy::Enforce, None) => None,
        }
    }

    /// Whether every lane of every entry of `q` passes.
    #[inline(always)]
    fn admits<N: LaneNum>(check: Option<Self>, q: &[N]) -> bool {
        let mut ok = true;
        match check {
            None => {}
            Some(LaneCheck::Finite) => {
                for &x in q {
                    ok &= N::admitted(x, 1.0, 0.0, f64::NEG_INFINITY, f64::INFINITY);
                }
            }
            Some(LaneCheck::Limits(limits)) => {
                for (j, &x) in q.iter().enumerate() {
                    let (scale, offset, lower, upper) = limits.entry(j);
                    ok &= N::admitted(x, scale, offset, lower, upper);
                }
            }
        }
        ok
    }
}

/// One link's pose in every configuration of a batch.
#[derive(Clone, Copy, Debug)]
pub struct BatchLinkPoses<'a> {
    chain: &'a Chain,
    data: &'a BatchData,
    link: LinkId,
}

impl BatchLinkPoses<'_> {
    /// The link's pose in configuration `index`, world frame.
    ///
    /// # Panics
    /// If `index >= self.len()`.
    #[must_use]
    #[inline]
    pub fn world_from_link(&self, index: usize) -> Transform {
        lane_pose(self.chain, self.data.len, self.link, index, |_, offset| {
            lane_link_pose(&self.data.link_frames[index / LANES], index % LANES, offset)
        })
    }
}

/// The pose of one link for each configuration of `qs` (row-major): only the joints between
/// the base and that link are evaluated, and only that link's pose is kept (one frame per
/// configuration written to memory instead of one per joint, which is what bounds a large
/// batch of all poses), on the calling thread ([`forward_kinematics_batch_to_par`] shares the
/// batch with rayon's pool). The poses are the same, bit for bit, as [`forward_kinematics_batch`]
/// gives for the link.
///
/// # Errors
/// As [`forward_kinematics_batch`].
///
/// # Panics
/// If `data` was created for another chain, or `link` comes from another chain with more links.
///
/// # Examples
/// ```
/// use kinechain::{Chain, eval::batch::{BatchData, forward_kinematics_batch_to}};
/// let chain = Chain::from_file("robots/planar3.yaml")?;
/// let mut data = BatchData::new(&chain);
/// let tip = chain.link_id("link3")?;
/// let qs = [0.0, 0.0, 0.0, 1.5707963267948966, 0.0, 0.0];
/// let poses = forward_kinematics_batch_to(&chain, &mut data, &qs, tip)?;
/// approx::assert_relative_eq!(poses.world_from_link(1).translation().y, 9.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn forward_kinematics_batch_to<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    link: LinkId,
) -> Result<BatchLinkPoses<'a>, BatchError> {
    batch_to(chain, data, qs, link, false)
}

/// As [`forward_kinematics_batch_to`], the batch shared between the calling thread and rayon's
/// pool as [`forward_kinematics_batch_par`] shares one (batches of fewer than
/// [`PARALLEL_WORK`] joint evaluations run on the calling thread). The poses are the same, bit
/// for bit.
///
/// # Errors
/// As [`forward_kinematics_batch`].
///
/// # Panics
/// As [`forward_kinematics_batch_to`].
pub fn forward_kinematics_batch_to_par<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    link: LinkId,
) -> Result<BatchLinkPoses<'a>, BatchError> {
    batch_to(chain, data, qs, link, true)
}

fn batch_to<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    link: LinkId,
    parallel: bool,
) -> Result<BatchLinkPoses<'a>, BatchError> {
    chain.body_path(chain.carrier(link).body, &mut data.path);
    let parallel = parallel && worth_parallel(qs, chain.dof(), data.path.len());
    let check = LaneCheck::of(chain, data.limit_policy);
    let chunks = data.prepare(chain, qs, !parallel && check.is_none())?;
    let zero = Frame::splat(&Transform::IDENTITY);
    data.link_frames.resize(chunks, zero);
    let path = &data.path;
    if parallel {
        // Groups of fewer chunks than a block when blocks would give a thread fewer than two
        // (a long chain's batch of a few dozen configurations).
        let per_item = (chunks / (2 * rayon::current_num_threads())).clamp(1, BLOCK);
        let all_ok = par_chunks_checked(
            chain,
            data.limit_policy,
            qs,
            per_item,
            path.len(),
            &mut data.link_frames[..chunks],
            per_item,
            || vec![Lanes::splat(0.0); per_item * chain.dof()],
            |check, q_lanes, c0, out| block_path(chain, check, path, q_lanes, qs, c0, out),
        );
        if !all_ok {
            data.first_error(chain, qs)?;
        }
    } else {
        let mut all_ok = true;
        for (b, out) in data.link_frames[..chunks].chunks_mut(BLOCK).enumerate() {
            all_ok &= block_path(chain, check, path, &mut data.q_lanes, qs, b * BLOCK, out);
        }
        if !all_ok {
            data.first_error(chain, qs)?;
        }
    }
    Ok(BatchLinkPoses { chain, data, link })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::data::Data;
    use crate::eval::kinematics::forward_kinematics;

    /// A serial arm, and two chains whose branches read a frame again (the Panda's second finger
    /// hangs from the hand; TIAGo's tree branches too), each with its file and `q` in `n`
    /// configurations (`None`: just past the last-level cache, and not a whole number of chunks)
    /// spread over a few radians (deterministic, every entry different).
    fn chains_and_qs(n: Option<usize>) -> Vec<(&'static str, Chain, Vec<f64>)> {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let files = [
            "robots/ur5.yaml",
            "robots/panda.urdf",
            "tests/data/reference/urdf/tiago_no_hand.urdf",
        ];
        files
            .into_iter()
            .map(|file| {
                let chain = Chain::from_file(root.join(file)).unwrap();
                let frame_bytes = size_of::<Frame<Lanes>>() / LANES;
                let past_cache = || {
                    crate::eval::arith::last_level_cache_bytes()
                        / (frame_bytes * chain.bodies.len())
                        + 13
                };
                let n = n.unwrap_or_else(past_cache);
                let qs = (0..n * chain.dof())
                    .map(|i| ((i as f64) * 0.754_877_666_246_692_7).fract() * 5.0 - 2.5)
                    .collect();
                (file, chain, qs)
            })
            .collect()
    }

    /// The all-links kernel writes the same frames streamed as cached: on baseline x86-64
    /// (four 16-byte streaming stores per line), with the ISA this machine selects (AVX-512
    /// streams whole lines, AVX2 does not stream), and with bodies whose frames are read again by
    /// a branch from the copies kept aside.
    #[test]
    fn streamed_chunks_equal_cached_chunks() {
        for (file, chain, qs) in chains_and_qs(Some(37)) {
            let (bodies, dof) = (chain.bodies.len(), chain.dof());
            let zero = Frame::splat(&Transform::IDENTITY);
            let evaluate = |stream: bool, baseline: bool| {
                let mut frames = vec![zero; 5 * bodies];
                let mut kept = vec![zero; kept_len(&chain)];
                let mut q = vec![Lanes::splat(0.0); dof];
                for (c, out) in frames.chunks_exact_mut(bodies).enumerate() {
                    let ok = if baseline {
                        chunk_poses_generic::<crate::eval::arith::Separate>(
                            &chain, None, out, &mut q, &qs, c, stream, &mut kept,
                        )
                    } else {
                        chunk_poses(&chain, None, out, &mut q, &qs, c, stream, &mut kept)
                    };
                    assert!(ok);
                }
                kernel::fence_streams();
                frames
            };
            for baseline in [true, false] {
                let cached = evaluate(false, baseline);
                assert!(cached.iter().all(|f| *f != zero));
                assert_eq!(
                    evaluate(true, baseline),
                    cached,
                    "{file} baseline {baseline}"
                );
            }
        }
    }

    /// Batches whose frames exceed the last-level cache are written around it on one thread
    /// ([`streams`]); they give, on one thread and on the pool, what single evaluations give, bit
    /// for bit, on the chains of [`chains_and_qs`].
    #[test]
    fn streamed_batches_equal_single_evaluations() {
        for (file, chain, qs) in chains_and_qs(None) {
            let (bodies, dof) = (chain.bodies.len(), chain.dof());
            let n = qs.len() / dof;
            assert!(streams(n.div_ceil(LANES) * bodies), "{file}");
            // Frames that fill the cache exactly are written through it.
            let fill = crate::eval::arith::last_level_cache_bytes() / size_of::<Frame<Lanes>>();
            assert!(!streams(fill) && streams(fill + 1));
            assert!(chain.bodies.iter().any(|b| b.branches) == (file != "robots/ur5.yaml"));
            let mut single = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            let mut data = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            let links: Vec<LinkId> = (0..chain.links().len()).map(LinkId).collect();
            for parallel in [false, true] {
                let poses = if parallel {
                    forward_kinematics_batch_par(&chain, &mut data, &qs)
                } else {
                    forward_kinematics_batch(&chain, &mut data, &qs)
                }
                .unwrap();
                assert_eq!(poses.len(), n);
                for (i, q) in qs.chunks_exact(dof).enumerate() {
                    let want = forward_kinematics(&chain, &mut single, q).unwrap();
                    for &l in &links {
                        assert_eq!(
                            poses.world_from_link(i, l),
                            want.world_from_link(l),
                            "{file} configuration {i} link {l:?} parallel {parallel}"
                        );
                    }
                }
            }
        }
    }
}
