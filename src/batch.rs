//! Many configurations at once: link poses of `n` configurations of one chain, eight per pass
//! through the kernels (one configuration per SIMD lane), on one thread or several.
//!
//! Configurations are given row-major (`qs[i * dof + j]` is joint entry `j` of configuration
//! `i`). Results are the same as [`forward_kinematics`](crate::forward_kinematics) gives for each
//! configuration, to the last bit on the same instruction set.

use crate::arith::{Arith, fma_dispatch};
use crate::chain::{Chain, LinkId, Placement};
use crate::data::LimitPolicy;
use crate::error::StateError;
use crate::kernel::{self, Frame, LANES, Lanes, Num};
use crate::kinematics::{all_valid, check_q};
use crate::transform::Transform;
use rayon::prelude::*;

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
    /// One chunk's joint values, transposed into lanes.
    q_lanes: Vec<Lanes>,
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
            q_lanes: vec![Lanes::splat(0.0); chain.dof()],
            len: 0,
            bodies: chain.bodies.len(),
            dof: chain.dof(),
            limit_policy: LimitPolicy::Enforce,
        }
    }

    /// Chooses whether evaluations check joint limits (default [`LimitPolicy::Enforce`]).
    pub fn set_limit_policy(&mut self, policy: LimitPolicy) {
        self.limit_policy = policy;
    }

    /// Sizes the buffers for `qs`; checks the configurations unless `check` is false (the
    /// parallel path checks each chunk in its own task, then calls [`BatchData::first_error`]).
    fn prepare(&mut self, chain: &Chain, qs: &[f64], check: bool) -> Result<usize, BatchError> {
        assert!(
            self.bodies == chain.bodies.len() && self.dof == chain.dof(),
            "kinechain: BatchData was created for another chain"
        );
        let dof = chain.dof();
        let n = qs.len().checked_div(dof).unwrap_or(0);
        if dof == 0 || !qs.len().is_multiple_of(dof) {
            return Err(BatchError {
                index: n,
                source: StateError::WrongLength {
                    what: "q",
                    expected: dof,
                    got: if dof == 0 { qs.len() } else { qs.len() % dof },
                },
            });
        }
        if check && !all_valid(chain, qs, self.limit_policy) {
            self.first_error(chain, qs)?;
        }
        let chunks = n.div_ceil(LANES);
        let zero = Frame::splat(&Transform::IDENTITY);
        self.frames.resize(chunks * self.bodies, zero);
        self.len = n;
        Ok(chunks)
    }

    /// The error for the first configuration of `qs` that [`check_q`] rejects (`Ok` if none).
    fn first_error(&self, chain: &Chain, qs: &[f64]) -> Result<(), BatchError> {
        for (index, q) in qs.chunks_exact(chain.dof()).enumerate() {
            check_q(chain, q, self.limit_policy).map_err(|source| BatchError { index, source })?;
        }
        Ok(())
    }
}

/// Link poses of every configuration of a batch.
#[derive(Clone, Copy, Debug)]
pub struct BatchPoses<'a> {
    chain: &'a Chain,
    data: &'a BatchData,
}

impl BatchPoses<'_> {
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

    /// Pose of `link` in configuration `index`, world frame.
    ///
    /// # Panics
    /// If `index >= self.len()` or `link` comes from another chain.
    #[must_use]
    pub fn world_from_link(&self, index: usize, link: LinkId) -> Transform {
        assert!(
            index < self.data.len,
            "configuration {index} of {}",
            self.data.len
        );
        let l = self.chain.link(link);
        let Some(b) = l.body else {
            return l.offset.to_transform();
        };
        let f = &self.data.frames[(index / LANES) * self.data.bodies + b];
        let lane = index % LANES;
        let body = Transform {
            r: f.r.map(|c| c.map(|x| x.0[lane])),
            p: f.p.map(|x| x.0[lane]),
        };
        match l.offset {
            Placement::Identity => body,
            offset => body * offset.to_transform(),
        }
    }
}

/// Poses of every link for each configuration of `qs` (row-major, `dof` entries per
/// configuration), on the calling thread.
///
/// # Errors
/// [`BatchError`] naming the first configuration that has a non-finite entry or (under
/// [`LimitPolicy::Enforce`]) a value outside a joint's limits, or a `qs` whose length is not a
/// multiple of the chain's dof. Nothing is evaluated then.
///
/// # Panics
/// If `data` was created for another chain.
///
/// # Examples
/// ```
/// use kinechain::{Chain, batch::{BatchData, forward_kinematics_batch}};
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
    let chunks = data.prepare(chain, qs, true)?;
    let bodies = chain.bodies.len().max(1);
    for (c, frames) in data
        .frames
        .chunks_exact_mut(bodies)
        .take(chunks)
        .enumerate()
    {
        chunk_poses(chain, frames, &mut data.q_lanes, qs, c);
    }
    Ok(BatchPoses { chain, data })
}

/// As [`forward_kinematics_batch`], with the chunks of eight configurations spread over the
/// threads of rayon's global pool (set its size with `RAYON_NUM_THREADS` or
/// `rayon::ThreadPoolBuilder`). Results are identical to the single-threaded call.
///
/// # Errors
/// As [`forward_kinematics_batch`] (the same configuration is named). Chunks of valid
/// configurations may have been evaluated by the other threads meanwhile; no result is returned.
///
/// # Panics
/// If `data` was created for another chain.
pub fn forward_kinematics_batch_par<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
) -> Result<BatchPoses<'a>, BatchError> {
    // Below this many configurations, waking the pool costs more than the second thread saves
    // (measured on a 2-vCPU VM: even at 1 024 configurations, about 10 µs of fork–join).
    const PARALLEL_FROM: usize = 2048;
    if qs.len() < PARALLEL_FROM * chain.dof() {
        return forward_kinematics_batch(chain, data, qs);
    }
    // Each task checks its own configurations before evaluating them (one pass over the batch
    // and one fork–join, not two); the first bad configuration is looked for only on failure.
    let chunks = data.prepare(chain, qs, false)?;
    let bodies = chain.bodies.len().max(1);
    let policy = data.limit_policy;
    let dof = chain.dof();
    let all_ok = data.frames[..chunks * chain.bodies.len()]
        .par_chunks_mut(bodies)
        .enumerate()
        .with_min_len(16)
        .map_init(
            || vec![Lanes::splat(0.0); dof],
            |q_lanes, (c, frames)| {
                let rows = &qs[c * LANES * dof..((c + 1) * LANES * dof).min(qs.len())];
                let ok = all_valid(chain, rows, policy);
                if ok {
                    chunk_poses(chain, frames, q_lanes, qs, c);
                }
                ok
            },
        )
        .reduce(|| true, |a, b| a & b);
    if !all_ok {
        data.first_error(chain, qs)?;
    }
    Ok(BatchPoses { chain, data })
}

/// One chunk: configurations `8c .. 8c + 8` (the last chunk repeats its last configuration in
/// the unused lanes).
#[inline(always)]
fn chunk_poses_generic<A: Arith>(
    chain: &Chain,
    frames: &mut [Frame<Lanes>],
    q: &mut [Lanes],
    qs: &[f64],
    c: usize,
) {
    let dof = chain.dof();
    let n = qs.len() / dof;
    let rows: [usize; LANES] = std::array::from_fn(|l| (c * LANES + l).min(n - 1));
    // Transpose this chunk's configurations into lanes: q[j] holds entry j of the 8.
    for (j, qj) in q.iter_mut().enumerate() {
        *qj = Lanes(std::array::from_fn(|l| qs[rows[l] * dof + j]));
    }
    let q: &[Lanes] = q;
    // Trigonometry first, for all bodies, so that it does not compete with the composition for
    // registers; the frames are written to `frames` and then read back one at a time.
    for (k, body) in chain.bodies.iter().enumerate() {
        let (s, c) = kernel::body_sin_cos::<Lanes, A>(body, q);
        frames[k].r[0][0] = s;
        frames[k].r[0][1] = c;
    }
    let mut f = Frame::splat(&Transform::IDENTITY);
    for (k, body) in chain.bodies.iter().enumerate() {
        let sin_cos = (frames[k].r[0][0], frames[k].r[0][1]);
        f = match body.parent {
            Some(p) if p + 1 == k => kernel::pose_step::<Lanes, A>(Some(&f), body, q, sin_cos),
            Some(p) => kernel::pose_step::<Lanes, A>(Some(&frames[p]), body, q, sin_cos),
            None => kernel::pose_step::<Lanes, A>(None, body, q, sin_cos),
        };
        frames[k] = f;
    }
}

fma_dispatch!(fn chunk_poses(chain: &Chain, frames: &mut [Frame<Lanes>], q: &mut [Lanes], qs: &[f64], c: usize) => chunk_poses_generic);
