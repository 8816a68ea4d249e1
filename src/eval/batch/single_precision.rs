//! Batches in single precision: link poses of many configurations computed in `f32`, sixteen
//! configurations per pass (one AVX-512 register, two AVX2 registers), on one thread or
//! several, for uses that need
//! throughput more than the last digits (sampling, collision checking, workspace maps).
//!
//! The same kernels as the `f64` batch ([`super`]) run on `f32` lanes, with two differences
//! that keep the error small and independent of the joint angles:
//! - each θ is computed and reduced modulo π/2 in `f64` (the reduction of `sin`/`cos`, exact for
//!   |θ| < 8·10⁵ rad), and only the remainder `r` (|r| ≤ π/4) goes to `f32`, as a rounded value
//!   and a first-order correction; `sin r` and `cos r` then come from short `f32` polynomials
//!   (within about one `f32` ulp). An angle of 100 rad is as accurate as one of 1 rad, where
//!   computing θ in `f32` would lose 2⁻²⁴ · 100;
//! - joint values are checked against the limits in `f64`, before any rounding, so a batch is
//!   accepted or rejected exactly as the `f64` batch does.
//!
//! Everything else (the frames, sliding joints' `d`, the constant placements) is `f32`, so
//! errors are of order 2⁻²⁴ ≈ 6·10⁻⁸ of the reach per joint; the reference tests bound them at
//! 16 ulp of `f32` (2⁻²³) of the reach in position and of 1 in rotation (measured on the reference
//! robots: at most 2.4 and 3.8, about 3·10⁻⁷ of the reach; see the table in the README). Link poses are read as [`Transform`] (`f64` holding the
//! `f32` results; a link's fixed offset from its joint's frame is applied in `f64`).
//!
//! # Examples
//! ```
//! use kinechain::Chain;
//! use kinechain::eval::batch::single_precision::{BatchData, forward_kinematics_batch_to};
//! let chain = Chain::from_file("robots/planar3.yaml")?;
//! let mut data = BatchData::new(&chain);
//! let tip = chain.link_id("link3")?;
//! let qs = [0.0, 0.0, 0.0, 1.5707963267948966, 0.0, 0.0]; // two configurations
//! let poses = forward_kinematics_batch_to(&chain, &mut data, &qs, tip)?;
//! let y = poses.world_from_link(1).translation().y;
//! assert!((y - 9.0).abs() < 1e-5);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![allow(clippy::needless_range_loop)]

use crate::eval::batch::blocks::transpose_chunk;
use crate::eval::batch::data::{
    BatchError, LaneCheck, batch_rows, first_error, first_error_on_path,
};
use crate::eval::batch::fold::{block_len, fold_blocks};
use crate::eval::batch::lanes32::{F16, Lanes32, WIDTH, Wide32, sin_cos};
use crate::eval::batch::poses::lane_pose;
use crate::eval::batch::threads::{par_chunks_checked, worth_parallel};
use crate::eval::checks::LimitPolicy;
use crate::eval::kernel::frame::Frame;
use crate::eval::layout::body::{Body, Placement};
use crate::eval::layout::chain::Chain;
use crate::eval::simd::isa::fma_dispatch;
use crate::eval::simd::lanes::{LANES, Lanes};
use crate::eval::simd::traits::{Arith, LaneNum, Num};
use crate::model::chain::LinkId;
use crate::model::joint::Term;
use crate::model::transform::Transform;

/// `(sin θ, cos θ)` of `body` in the sixteen configurations whose joint values (`f64`) are the
/// lanes of `q_lo` (configurations 0–7) and `q_hi` (8–15).
#[inline(always)]
fn body_sin_cos<A: Arith>(body: &Body, q_lo: &[Lanes], q_hi: &[Lanes]) -> (F16, F16) {
    let theta = &body.motion.theta;
    if let Term::Const(_) = theta {
        return (F16::splat(0.0), F16::splat(1.0));
    }
    let lo = crate::eval::kernel::joint::term_value::<Lanes, A>(theta, q_lo);
    let hi = crate::eval::kernel::joint::term_value::<Lanes, A>(theta, q_hi);
    sin_cos::<A>(std::array::from_fn(|i| {
        if i < LANES { lo.0[i] } else { hi.0[i - LANES] }
    }))
}

/// One chunk's joint values as transposed for the instruction set (`raw`), in `f64` lanes
/// (`q64`: configurations 0–7, then 8–15, `dof` entries each) and in `f32` (`q32`).
#[derive(Clone, Debug, Default)]
struct Scratch {
    raw: Vec<Lanes>,
    q64: Vec<Lanes>,
    q32: Vec<F16>,
}

impl Scratch {
    fn new(dof: usize) -> Self {
        Scratch {
            raw: vec![Lanes::splat(0.0); 2 * dof],
            q64: vec![Lanes::splat(0.0); 2 * dof],
            q32: vec![F16::splat(0.0); dof],
        }
    }
}

/// Buffers for evaluating batches of configurations of one chain in single precision; grows to
/// the largest batch seen and is reused.
#[derive(Clone, Debug, Default)]
pub struct BatchData {
    /// Chunk-major: `frames[c * bodies + k]` holds body `k` of configurations `16c..16c+16`.
    pub(crate) frames: Vec<Frame<F16>>,
    /// [`forward_kinematics_batch_to`]: the link's body frame of each chunk, and the bodies from
    /// the base to it.
    pub(crate) link_frames: Vec<Frame<F16>>,
    pub(crate) path: Vec<usize>,
    /// What that path reads of `q`.
    pub(crate) reads: crate::eval::layout::chain::PathReads,
    scratch: Scratch,
    pub(crate) len: usize,
    pub(crate) bodies: usize,
    pub(crate) dof: usize,
    pub(crate) limit_policy: LimitPolicy,
}

impl BatchData {
    /// Empty buffers for `chain`.
    #[must_use]
    pub fn new(chain: &Chain) -> Self {
        BatchData {
            frames: Vec::new(),
            link_frames: Vec::new(),
            path: Vec::with_capacity(chain.bodies.len()),
            reads: crate::eval::layout::chain::PathReads::new(chain),
            scratch: Scratch::new(chain.nq()),
            len: 0,
            bodies: chain.bodies.len(),
            dof: chain.nq(),
            limit_policy: LimitPolicy::Enforce,
        }
    }

    limit_policy_methods!();

    /// The number of chunks of `qs`, after checking its length (and, on one thread, its
    /// configurations when the kernels cannot check them on their lanes).
    fn prepare(
        &mut self,
        chain: &Chain,
        qs: &[f64],
        check: Option<LaneCheck<'_>>,
        parallel: bool,
    ) -> Result<usize, BatchError> {
        let shape = (self.bodies, self.dof);
        // The parallel path's tasks check their own rows when the kernels cannot.
        let check_rows = check.is_none() && !parallel;
        let what = "crate::eval::batch::single_precision::BatchData";
        self.len = batch_rows(what, shape, self.limit_policy, chain, qs, check_rows)?;
        Ok(self.len.div_ceil(WIDTH))
    }
}

/// Poses of every link for each configuration of `qs` (row-major, `dof` entries per
/// configuration), computed in `f32`, on the calling thread.
///
/// # Errors
/// As [`super::forward_kinematics_batch`]: [`BatchError`] naming the first configuration that
/// has a non-finite entry or (under [`LimitPolicy::Enforce`]) a value outside a joint's limits,
/// a `qs` whose length is not a multiple of the chain's dof, or a chain without moving joints.
///
/// # Panics
/// If `data` was created for another chain.
pub fn forward_kinematics_batch<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
) -> Result<BatchPoses<'a>, BatchError> {
    all_links(chain, data, qs, false)
}

/// As [`forward_kinematics_batch`], with the chunks of sixteen configurations shared between the
/// calling thread and rayon's pool, as [`super::forward_kinematics_batch_par`] does (batches
/// of fewer than [`super::PARALLEL_WORK`] joint evaluations run on the calling thread). Results
/// are identical to the single-threaded call.
///
/// # Errors
/// As [`forward_kinematics_batch`] (the same configuration is named).
///
/// # Panics
/// If `data` was created for another chain.
pub fn forward_kinematics_batch_par<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
) -> Result<BatchPoses<'a>, BatchError> {
    all_links(chain, data, qs, true)
}

fn all_links<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    parallel: bool,
) -> Result<BatchPoses<'a>, BatchError> {
    let parallel = parallel && worth_parallel(qs, chain.nq(), chain.bodies.len());
    let check = LaneCheck::of(chain, data.limit_policy);
    let chunks = data.prepare(chain, qs, check, parallel)?;
    let bodies = chain.bodies.len().max(1);
    data.frames
        .resize(chunks * bodies, Frame::splat(&Transform::IDENTITY));
    run_chunks(
        chain,
        qs,
        (data.limit_policy, check, None),
        &mut data.scratch,
        parallel,
        bodies,
        &mut data.frames,
        bodies,
        |check, s, c, frames| {
            chunk_poses(
                chain, check, &mut s.raw, &mut s.q64, &mut s.q32, qs, c, frames,
            )
        },
    )?;
    Ok(BatchPoses { chain, data })
}

/// The pose of one link for each configuration of `qs` (row-major), computed in `f32`: only the
/// joints between the base and that link are evaluated, and only that link's pose is kept. On
/// the calling thread ([`forward_kinematics_batch_to_par`] shares the batch with rayon's pool).
///
/// # Errors
/// As [`forward_kinematics_batch`].
///
/// # Panics
/// If `data` was created for another chain, or `link` comes from another chain with more links.
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
/// [`super::PARALLEL_WORK`] joint evaluations run on the calling thread). The poses are the same, bit
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
    let body = chain.carrier(link).body;
    chain.body_path(body, &mut data.path);
    // Only what the path reads of `q` is transposed and checked (see the `f64` batch).
    chain.path_reads(body, &mut data.reads);
    let reads = std::mem::take(&mut data.reads);
    let result = path_kernels(chain, data, qs, &reads, parallel);
    data.reads = reads;
    result?;
    Ok(BatchLinkPoses { chain, data, link })
}

/// The kernels of [`batch_to`] on the path in `data.path`, which reads `reads`.
fn path_kernels(
    chain: &Chain,
    data: &mut BatchData,
    qs: &[f64],
    reads: &crate::eval::layout::chain::PathReads,
    parallel: bool,
) -> Result<(), BatchError> {
    let parallel = parallel && worth_parallel(qs, chain.nq(), data.path.len());
    let check = LaneCheck::for_path(chain, data.limit_policy, reads);
    let chunks = data.prepare(chain, qs, check, parallel)?;
    data.link_frames
        .resize(chunks, Frame::splat(&Transform::IDENTITY));
    let path = &data.path;
    run_chunks(
        chain,
        qs,
        (data.limit_policy, check, Some(reads)),
        &mut data.scratch,
        parallel,
        path.len(),
        &mut data.link_frames,
        1,
        |check, s, c, out| {
            chunk_path(
                chain,
                check,
                path,
                &mut s.raw,
                &mut s.q64,
                &mut s.q32,
                qs,
                c,
                &mut out[0],
            )
        },
    )
}

block_eval!(Single, WIDTH, Frame<F16>);

/// Configurations per block of [`forward_kinematics_batch_fold`] for `chain`: a multiple of
/// sixteen (the configurations of one pass through the kernels) whose frames, 48 bytes per body
/// and configuration, fill at most 256 KiB (sixteen for a chain too long for that).
#[must_use]
pub fn fold_block_len(chain: &Chain) -> usize {
    block_len::<Single>(chain)
}

/// As [`super::forward_kinematics_batch_fold`], in `f32`: every link's poses, block by block
/// ([`fold_block_len`] configurations per block, fewer in the last), are folded with
/// `fold(acc, first, poses)` while the block's frames are in cache, on the calling thread
/// ([`forward_kinematics_batch_fold_par`] shares runs of blocks with rayon's pool). The poses are those of [`forward_kinematics_batch`], bit for
/// bit.
///
/// # Errors
/// As [`forward_kinematics_batch`] (the first bad configuration is named). Blocks before it may
/// have been folded; their result is dropped.
///
/// # Examples
/// ```
/// use kinechain::{Chain, LimitPolicy, eval::batch::single_precision::forward_kinematics_batch_fold_par};
/// let chain = Chain::from_file("robots/planar3.yaml")?;
/// let tip = chain.link_id("link3")?;
/// let qs: Vec<f64> = (0..1000).flat_map(|i| [0.001 * i as f64, 0.0, 0.0]).collect();
/// // How many configurations put the tip above y = 4.
/// let above = forward_kinematics_batch_fold_par(
///     &chain,
///     &qs,
///     LimitPolicy::Enforce,
///     || 0,
///     |n, _first, poses| {
///         n + (0..poses.len()).filter(|&i| poses.world_from_link(i, tip).translation().y > 4.0).count()
///     },
///     |a, b| a + b,
/// )?;
/// // 9 sin θ > 4 from θ = 0.4606 rad, configuration 461.
/// assert_eq!(above, 1000 - 461);
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
    fold_blocks::<Single, T>(chain, qs, policy, false, identity, fold, reduce)
}

/// As [`forward_kinematics_batch_fold`], the blocks shared between the calling thread and
/// rayon's pool in runs of consecutive blocks (about 32 runs per thread), each thread evaluating
/// into buffers of its own; each run is folded from `identity()`, and the runs' results are
/// combined with `reduce` in the order of their blocks (so `reduce` must be associative, and
/// `identity()` neutral for it). Batches of fewer than [`super::PARALLEL_WORK`] joint evaluations stay
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
    fold_blocks::<Single, T>(chain, qs, policy, true, identity, fold, reduce)
}

/// Runs `eval(check, scratch, c, out)` for every chunk `c` of sixteen configurations of `qs`,
/// `out` its `width` frames of `outs`: on the calling thread and rayon's pool when `parallel`
/// (each thread with scratch buffers of its own; `bodies` evaluated per configuration, for the
/// size of a run), else on the calling thread with `scratch`. The error of the first bad
/// configuration if `eval` (or the check before it) rejects one.
#[allow(clippy::too_many_arguments)]
fn run_chunks(
    chain: &Chain,
    qs: &[f64],
    (policy, check, reads): (
        LimitPolicy,
        Option<LaneCheck<'_>>,
        Option<&crate::eval::layout::chain::PathReads>,
    ),
    scratch: &mut Scratch,
    parallel: bool,
    bodies: usize,
    outs: &mut [Frame<F16>],
    width: usize,
    eval: impl Fn(Option<LaneCheck<'_>>, &mut Scratch, usize, &mut [Frame<F16>]) -> bool + Sync + Send,
) -> Result<(), BatchError> {
    let all_ok = if parallel {
        let dof = chain.nq();
        // Items of two eight-row chunks (one of sixteen configurations), as the f64 batch counts.
        par_chunks_checked(
            chain,
            (policy, check),
            qs,
            2,
            bodies,
            outs,
            width,
            || Scratch::new(dof),
            |check, s, c0, out| eval(check, s, c0 / 2, out),
        )
    } else {
        let mut all_ok = true;
        for (c, out) in outs.chunks_exact_mut(width).enumerate() {
            all_ok &= eval(check, scratch, c, out);
        }
        all_ok
    };
    match (all_ok, check.and_then(|c| c.entries).and(reads)) {
        (true, _) => Ok(()),
        (false, Some(reads)) => first_error_on_path(chain, qs, policy, reads),
        (false, None) => first_error(chain, qs, policy),
    }
}

batch_len!(BatchPoses, BatchLinkPoses);

/// Link poses of every configuration of a single-precision batch.
#[derive(Clone, Copy, Debug)]
pub struct BatchPoses<'a> {
    pub(crate) chain: &'a Chain,
    pub(crate) data: &'a BatchData,
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
            let f = &self.data.frames[(index / WIDTH) * self.data.bodies + b];
            lane_link_pose(f, index % WIDTH, offset)
        })
    }
}

/// One link's pose in every configuration of a single-precision batch.
#[derive(Clone, Copy, Debug)]
pub struct BatchLinkPoses<'a> {
    pub(crate) chain: &'a Chain,
    pub(crate) data: &'a BatchData,
    pub(crate) link: LinkId,
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
            lane_link_pose(&self.data.link_frames[index / WIDTH], index % WIDTH, offset)
        })
    }
}

/// `f`'s frame in lane `lane`, widened to `f64`, followed by `offset`, as
/// [`crate::eval::kernel::pose_columns::link_pose`] composes it.
#[inline(always)]
fn lane_link_pose_generic<A: Arith>(f: &Frame<F16>, lane: usize, offset: &Placement) -> Transform {
    let lane = lane % WIDTH;
    let column = |c: usize| if c < 3 { &f.r[c] } else { &f.p };
    crate::eval::kernel::pose_columns::link_pose_from_entries::<A>(
        |c, i| f64::from(column(c)[i].0[lane]),
        offset,
    )
}

fma_dispatch!(avx2 fn lane_link_pose(f: &Frame<F16>, lane: usize, offset: &Placement) -> Transform => lane_link_pose_generic);

/// Chunk `c` of `qs` (configurations `16c..16c + 16`; the last chunk repeats its last
/// configuration in the unused lanes): its joint values in `f64` lanes in `q64` (entries of
/// configurations 0–7, then of 8–15), checked with `check`, and in `f32` in `q32`. The rows are
/// transposed as the `f64` batch does it (`raw`, in the layout of the instruction set's lane
/// type), then put in lane order. False if a configuration is rejected.
#[inline(always)]
fn load_chunk<A: Arith>(
    check: Option<LaneCheck<'_>>,
    raw: &mut [Lanes],
    q64: &mut [Lanes],
    q32: &mut [F16],
    qs: &[f64],
    c: usize,
) -> bool {
    let dof = q32.len();
    let mut ok = true;
    for (half, lanes) in raw.chunks_exact_mut(dof).enumerate() {
        ok &= transpose_chunk::<A::Lanes>(check, lanes, qs, 2 * c + half);
    }
    // A one-link kernel's entries only (`check`'s, when not all of `q`).
    match check.and_then(|c| c.entries) {
        Some(entries) => to_lane_order::<A>(raw, q64, q32, entries.iter().copied()),
        None => to_lane_order::<A>(raw, q64, q32, 0..dof),
    }
    ok
}

/// Entries `entries` of the transposed rows `raw` in lane order, in `f64` (`q64`) and `f32`
/// (`q32`).
#[inline(always)]
fn to_lane_order<A: Arith>(
    raw: &[Lanes],
    q64: &mut [Lanes],
    q32: &mut [F16],
    entries: impl Iterator<Item = usize> + Clone,
) {
    let dof = q32.len();
    let (lo, hi) = q64.split_at_mut(dof);
    for (half, out) in [lo, hi].into_iter().enumerate() {
        let parts = A::Lanes::cast(&raw[half * dof..(half + 1) * dof]);
        for j in entries.clone() {
            for part in 0..A::Lanes::PARTS {
                parts[part * dof + j].put(&mut out[j], part);
            }
        }
    }
    let (lo, hi) = q64.split_at(dof);
    for j in entries {
        let x = &mut q32[j];
        for l in 0..LANES {
            x.0[l] = lo[j].0[l] as f32;
            x.0[l + LANES] = hi[j].0[l] as f32;
        }
    }
}

/// Every body's frame of chunk `c` of `qs`, written to `frames`. False if `check` rejects a
/// configuration (the frames are then meaningless). The buffers of a [`Scratch`] are passed
/// apart here and in [`chunk_path_generic`]: passed whole, with the same code inside, the Panda's
/// batch took 9.3–9.5 ns per configuration instead of 10.1–10.5 (alternated `kinechain bench`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn chunk_poses_generic<A: Wide32>(
    chain: &Chain,
    check: Option<LaneCheck<'_>>,
    raw: &mut [Lanes],
    q64: &mut [Lanes],
    q32: &mut [F16],
    qs: &[f64],
    c: usize,
    frames: &mut [Frame<F16>],
) -> bool {
    type N<A> = <A as Wide32>::Lanes32;
    let ok = load_chunk::<A>(check, raw, q64, q32, qs, c);
    let (lo, hi) = q64.split_at(q32.len());
    let q = N::<A>::view(q32);
    let mut f = N::<A>::identity();
    for (k, body) in chain.bodies.iter().enumerate() {
        let (s, c) = body_sin_cos::<A>(body, lo, hi);
        let sin_cos = (N::<A>::from_f16(s), N::<A>::from_f16(c));
        f = match body.parent {
            _ if body.follows_previous => {
                crate::eval::kernel::pose_lanes::pose_step::<N<A>, A>(Some(&f), body, q, sin_cos)
            }
            Some(p) => crate::eval::kernel::pose_lanes::pose_step::<N<A>, A>(
                Some(N::<A>::frame(&frames[p])),
                body,
                q,
                sin_cos,
            ),
            None if body.floating => *N::<A>::frame(&floating_frame(body, lo, hi)),
            None => crate::eval::kernel::pose_lanes::pose_step::<N<A>, A>(None, body, q, sin_cos),
        };
        N::<A>::store(&f, &mut frames[k]);
    }
    ok
}

fma_dispatch!(#[allow(clippy::too_many_arguments)] fn chunk_poses(chain: &Chain, check: Option<LaneCheck<'_>>, raw: &mut [Lanes], q64: &mut [Lanes], q32: &mut [F16], qs: &[f64], c: usize, frames: &mut [Frame<F16>]) -> bool => chunk_poses_generic);

/// The frame of the last body of `path` (base first, each body the parent of the next) for chunk
/// `c` of `qs`, built in `out`. False if `check` rejects a configuration.
///
/// Each body's frame is written to `out` and read back as the next one's parent, as the
/// all-links kernel does through its frames. Kept in a local variable instead, the sixteen-lane
/// frame (twelve 64-byte vectors) was spilled to the stack piecemeal once `pose_step` had the
/// general placement and the shape-coded steps on one path: 4 096 configurations to the end
/// link, UR5 63–65 µs and Panda 81–82 µs against 34.1 and 41.6 through `out` (all links: 35 and
/// 45).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn chunk_path_generic<A: Wide32>(
    chain: &Chain,
    check: Option<LaneCheck<'_>>,
    path: &[usize],
    raw: &mut [Lanes],
    q64: &mut [Lanes],
    q32: &mut [F16],
    qs: &[f64],
    c: usize,
    out: &mut Frame<F16>,
) -> bool {
    type N<A> = <A as Wide32>::Lanes32;
    let ok = load_chunk::<A>(check, raw, q64, q32, qs, c);
    let (lo, hi) = q64.split_at(q32.len());
    let q = N::<A>::view(q32);
    for (i, &k) in path.iter().enumerate() {
        let body = &chain.bodies[k];
        let (s, c) = body_sin_cos::<A>(body, lo, hi);
        let sin_cos = (N::<A>::from_f16(s), N::<A>::from_f16(c));
        // The first body hangs from the world, each next one from the one before it.
        let f = if i == 0 && body.floating {
            *N::<A>::frame(&floating_frame(body, lo, hi))
        } else {
            crate::eval::kernel::pose_lanes::pose_step::<N<A>, A>(
                (i > 0).then_some(N::<A>::frame(out)),
                body,
                q,
                sin_cos,
            )
        };
        N::<A>::store(&f, out);
    }
    ok
}

/// A floating joint's body's frame in each of the sixteen lanes, from the lane's own seven
/// entries of `q` in double precision (`lo`: configurations 0–7, `hi`: 8–15), then rounded.
#[inline(never)]
fn floating_frame(body: &Body, lo: &[Lanes], hi: &[Lanes]) -> Frame<F16> {
    let zero = F16([0.0; WIDTH]);
    let mut out = Frame {
        r: [[zero; 3]; 3],
        p: [zero; 3],
    };
    for lane in 0..WIDTH {
        let half = if lane < LANES { lo } else { hi };
        let own: [f64; 7] = std::array::from_fn(|j| half[j].0[lane % LANES]);
        let t = crate::eval::kernel::floating::frame(body, &own);
        for c in 0..3 {
            for i in 0..3 {
                out.r[c][i].0[lane] = t.r[c][i] as f32;
            }
            out.p[c].0[lane] = t.p[c] as f32;
        }
    }
    out
}

fma_dispatch!(#[allow(clippy::too_many_arguments)] fn chunk_path(chain: &Chain, check: Option<LaneCheck<'_>>, path: &[usize], raw: &mut [Lanes], q64: &mut [Lanes], q32: &mut [F16], qs: &[f64], c: usize, out: &mut Frame<F16>) -> bool => chunk_path_generic);

#[cfg(test)]
mod tests;
