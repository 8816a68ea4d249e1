//! The batch buffers [`BatchData`], the batch error, and the checks of a batch's
//! configurations (on the lanes, or before the kernels).

// Index loops over lanes and rows are the shape the vectoriser expects here.
#![allow(clippy::needless_range_loop)]

use crate::eval::checks::{LimitPolicy, all_valid, check_q};
use crate::eval::error::StateError;
use crate::eval::kernel::frame::Frame;
use crate::eval::kernel::frame::V3;
use crate::eval::layout::chain::Chain;
use crate::eval::layout::limits::DenseLimits;
use crate::eval::simd::lanes::{LANES, Lanes};
use crate::eval::simd::traits::{LaneNum, Num};
use crate::model::transform::Transform;

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
    pub(crate) frames: Vec<Frame<Lanes>>,
    /// One block's joint values (one chunk's for the all-links kernel), transposed into lanes.
    pub(crate) q_lanes: Vec<Lanes>,
    /// [`forward_kinematics_batch_to`]: the link's body frame of each chunk, and the bodies from
    /// the base to it.
    pub(crate) link_frames: Vec<Frame<Lanes>>,
    pub(crate) path: Vec<usize>,
    /// What that path reads of `q`.
    pub(crate) reads: crate::eval::layout::chain::PathReads,
    /// The all-links kernel's frames of the bodies read again, when it streams ([`streams`]).
    pub(crate) kept: Vec<Frame<Lanes>>,
    /// The rate batches' ω and v, and α and a, of each body, chunk-major like `frames`; and one
    /// chunk's `q`, `q̇`, `q̈` transposed into lanes.
    pub(crate) velocities: Vec<Pair>,
    pub(crate) accelerations: Vec<Pair>,
    pub(crate) rate_lanes: Vec<Lanes>,
    /// One Jacobian, column-major, before it is written out row-major.
    pub(crate) jacobian: Vec<f64>,
    /// The lane Jacobian kernel's columns of one chunk, and its path bodies' joint origins and
    /// directions.
    pub(crate) jacobian_lanes: Vec<Lanes>,
    pub(crate) axes: Vec<[[Lanes; 3]; 2]>,
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
            q_lanes: vec![Lanes::splat(0.0); BLOCK * chain.nq()],
            link_frames: Vec::new(),
            path: Vec::with_capacity(chain.bodies.len()),
            reads: crate::eval::layout::chain::PathReads::new(chain),
            kept: Vec::new(),
            velocities: Vec::new(),
            accelerations: Vec::new(),
            rate_lanes: vec![Lanes::splat(0.0); chain.nq() + 2 * chain.nv()],
            jacobian: vec![0.0; 6 * chain.nv()],
            jacobian_lanes: Vec::new(),
            axes: Vec::new(),
            len: 0,
            bodies: chain.bodies.len(),
            dof: chain.nq(),
            limit_policy: LimitPolicy::Enforce,
        }
    }

    limit_policy_methods!();

    /// Records the number of configurations in `qs` and returns its number of chunks; checks
    /// the configurations first unless `check` is false (the kernels check their lanes, or the
    /// parallel path checks each chunk in its own task; both then call
    /// [`BatchData::first_error`] on failure).
    pub(crate) fn prepare(
        &mut self,
        chain: &Chain,
        qs: &[f64],
        check: bool,
    ) -> Result<usize, BatchError> {
        let shape = (self.bodies, self.dof);
        self.len = batch_rows("BatchData", shape, self.limit_policy, chain, qs, check)?;
        Ok(self.len.div_ceil(LANES))
    }

    /// Room for every body of `chunks` chunks; returns the number of frames that is.
    pub(crate) fn size_frames(&mut self, chunks: usize) -> usize {
        let zero = Frame::splat(&Transform::IDENTITY);
        let frames = chunks * self.bodies;
        self.frames.resize(frames, zero);
        frames
    }

    /// The error for the first configuration of `qs` that [`check_q`] rejects (`Ok` if none).
    pub(crate) fn first_error(&self, chain: &Chain, qs: &[f64]) -> Result<(), BatchError> {
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
pub(crate) fn streams(frames: usize) -> bool {
    frames.saturating_mul(size_of::<Frame<Lanes>>())
        > crate::eval::simd::isa::last_level_cache_bytes()
}

/// The length of the all-links kernel's `kept` when it streams: up to the last body whose frame a
/// branch reads again (none for a serial chain).
pub(crate) fn kept_len(chain: &Chain) -> usize {
    chain
        .bodies
        .iter()
        .rposition(|b| b.branches)
        .map_or(0, |k| k + 1)
}

/// The number of configurations in `qs` (rows of the chain's [`nq`](crate::Model::nq)
/// entries), or the error for a length that is not a multiple of it (the index given is that of
/// the incomplete row) or for a chain without moving joints.
pub(crate) fn configurations(chain: &Chain, qs: &[f64]) -> Result<usize, BatchError> {
    let nq = chain.nq();
    if nq == 0 {
        return Err(BatchError {
            index: 0,
            source: StateError::NoDegreesOfFreedom,
        });
    }
    let n = qs.len() / nq;
    if !qs.len().is_multiple_of(nq) {
        return Err(BatchError {
            index: n,
            source: crate::eval::checks::wrong_length(chain, "q", nq, qs.len() % nq),
        });
    }
    Ok(n)
}

/// The number of configurations in `qs`, for buffers named `what` that were created for a chain
/// of `(bodies, dof)`; checks every configuration under `policy` when `check` is true.
///
/// # Panics
/// If the buffers were created for another chain than `chain`.
pub(crate) fn batch_rows(
    what: &str,
    (bodies, dof): (usize, usize),
    policy: LimitPolicy,
    chain: &Chain,
    qs: &[f64],
    check: bool,
) -> Result<usize, BatchError> {
    crate::eval::checks::assert_buffers_match(what, bodies, dof, chain);
    let n = configurations(chain, qs)?;
    if check && !all_valid(chain, qs, policy) {
        first_error(chain, qs, policy)?;
    }
    Ok(n)
}

/// The error for the first configuration of `qs` that [`check_q`] rejects under `policy`
/// (`Ok` if none).
pub(crate) fn first_error(
    chain: &Chain,
    qs: &[f64],
    policy: LimitPolicy,
) -> Result<(), BatchError> {
    for (index, q) in qs.chunks_exact(chain.nq()).enumerate() {
        check_q(chain, q, policy).map_err(|source| BatchError { index, source })?;
    }
    Ok(())
}

/// [`first_error`] for a one-link kernel whose path reads `reads` (its check, [`LaneCheck`]'s
/// `entries`).
pub(crate) fn first_error_on_path(
    chain: &Chain,
    qs: &[f64],
    policy: LimitPolicy,
    reads: &crate::eval::layout::chain::PathReads,
) -> Result<(), BatchError> {
    for (index, q) in qs.chunks_exact(chain.nq()).enumerate() {
        crate::eval::checks::check_q_entries(chain, q, reads, policy)
            .map_err(|source| BatchError { index, source })?;
    }
    Ok(())
}

/// What a chunk kernel checks on its lanes after transposing them: every entry finite, and
/// within the chain's limit columns under [`LimitPolicy::Enforce`], and a floating joint's
/// quaternion near unit length (the decisions of [`check_q`], made on eight configurations per
/// vector).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneCheck<'a> {
    pub(crate) limits: Option<&'a DenseLimits>,
    /// The first entry of each quaternion in `q` ([`crate::Model::quaternions`]).
    pub(crate) quaternions: &'a [(crate::model::chain::JointId, usize)],
    /// The entries a one-link kernel reads, when not all of `q` ([`Chain::path_reads`]): only
    /// they are transposed and checked (and `quaternions` are theirs).
    pub(crate) entries: Option<&'a [usize]>,
}

impl<'a> LaneCheck<'a> {
    /// `None` when the limits do not fit one check per entry ([`Chain::dense_limits`]): the
    /// configurations are then checked before evaluation.
    pub(crate) fn of(chain: &'a Chain, policy: LimitPolicy) -> Option<LaneCheck<'a>> {
        let quaternions = chain.quaternions();
        match (policy, &chain.dense_limits) {
            (LimitPolicy::Ignore, _) => Some(LaneCheck {
                limits: None,
                quaternions,
                entries: None,
            }),
            (LimitPolicy::Enforce, Some(limits)) => Some(LaneCheck {
                limits: Some(limits),
                quaternions,
                entries: None,
            }),
            (LimitPolicy::Enforce, None) => None,
        }
    }

    /// The check of a one-link kernel whose path reads `reads`: [`LaneCheck::of`], on those
    /// entries only (when they are not all of `q` and the lanes can check them).
    pub(crate) fn for_path(
        chain: &'a Chain,
        policy: LimitPolicy,
        reads: &'a crate::eval::layout::chain::PathReads,
    ) -> Option<LaneCheck<'a>> {
        let check = LaneCheck::of(chain, policy)?;
        Some(match reads.all {
            true => check,
            false => LaneCheck {
                quaternions: &reads.quaternions,
                entries: Some(&reads.entries),
                ..check
            },
        })
    }

    /// Whether every lane of every entry of `q` passes.
    #[inline(always)]
    pub(crate) fn admits<N: LaneNum>(check: Option<Self>, q: &[N]) -> bool {
        let mut ok = true;
        let Some(check) = check else {
            return ok;
        };
        match (check.limits, check.entries) {
            (None, None) => {
                for &x in q {
                    ok &= N::admitted(x, 1.0, 0.0, f64::NEG_INFINITY, f64::INFINITY);
                }
            }
            (Some(limits), None) => {
                for (j, &x) in q.iter().enumerate() {
                    let (scale, offset, lower, upper) = limits.entry(j);
                    ok &= N::admitted(x, scale, offset, lower, upper);
                }
            }
            (limits, Some(entries)) => {
                for &j in entries {
                    let (scale, offset, lower, upper) =
                        limits.map_or((1.0, 0.0, f64::NEG_INFINITY, f64::INFINITY), |l| l.entry(j));
                    ok &= N::admitted(q[j], scale, offset, lower, upper);
                }
            }
        }
        for &(_, i) in check.quaternions {
            // `floating::admits`: the squared norm within the squared tolerance band.
            let n2 =
                ((q[i] * q[i] + q[i + 1] * q[i + 1]) + q[i + 2] * q[i + 2]) + q[i + 3] * q[i + 3];
            let (lo, hi) = crate::eval::kernel::floating::squared_norm_band();
            ok &= N::admitted(n2, 1.0, 0.0, lo, hi);
        }
        ok
    }
}

/// Chunks of [`LANES`] configurations per block of [`forward_kinematics_batch_to`]: with four
/// lanes per value its kernel goes through the path once per block, each body over all chunks of
/// the block (sixteen values of four lanes), rather than through the whole path once per chunk
/// (with eight lanes per register it does the latter, see [`block_path_generic`]). The
/// code for a body's shape and its constants are then chosen once per block, and each of its
/// steps is a loop over independent frames instead of a link of one dependency chain; the frames
/// go through memory (a block's 6 KiB stay in the first-level cache), and each step rewrites only
/// the columns it changes.
///
/// The all-links kernel keeps one chunk at a time: there every body's frame is written anyway,
/// and writing it once per step instead of once per body cost more than it saved (Panda 45.6 →
/// 47.5 ns per configuration, modified DH Panda 37.5 → 39.3; UR5 34.2 → 32.8).
pub(crate) const BLOCK: usize = 8;

/// Two vectors of every body's motion for one chunk, lane-major: `[ω, v]` or `[α, a]`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub(crate) struct Pair(pub(crate) [[Lanes; 3]; 2]);

impl Pair {
    pub(crate) const ZERO: Pair = Pair([[Lanes([0.0; LANES]); 3]; 2]);

    #[inline(always)]
    pub(crate) fn get<N: LaneNum>(&self, part: usize) -> [V3<N>; 2] {
        self.0.map(|v| v.map(|x| N::get(&x, part)))
    }

    #[inline(always)]
    pub(crate) fn put<N: LaneNum>(&mut self, [a, b]: [V3<N>; 2], part: usize) {
        for (out, v) in self.0.iter_mut().zip([a, b]) {
            for (o, x) in out.iter_mut().zip(v) {
                x.put(o, part);
            }
        }
    }

    /// The two vectors of lane `lane`.
    #[inline]
    pub(crate) fn lane(&self, lane: usize) -> [[f64; 3]; 2] {
        self.0.map(|v| v.map(|x| x.0[lane]))
    }
}
