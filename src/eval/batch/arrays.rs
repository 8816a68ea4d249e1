//! Batches written into a caller's arrays: the poses, rates and Jacobians of `n`
//! configurations in the layout of C-ordered arrays (numpy's `(N, L, 4, 4)`, `(N, L, 3)` and
//! `(N, 6, dof)`), block by block while a block's frames are in cache, on the calling thread or
//! on a given pool of threads, each block checked to be finite as it is written, and a hook on
//! the calling thread that can stop the run (a host language's Ctrl-C).
//!
//! This is what a binding calls: it converts its arrays to slices and back, and this module
//! does the rest. The values are those of the batch functions
//! ([`forward_kinematics_batch`] and the others),
//! bit for bit, whichever [`Workers`] run them.

use crate::eval::batch::data::{BatchData, BatchError};
use crate::eval::batch::fold::fold_block_len;
use crate::eval::batch::jacobians::jacobian_batch;
use crate::eval::batch::poses::{forward_kinematics_batch, forward_kinematics_batch_to};
use crate::eval::batch::rates::{forward_accelerations_batch, forward_velocities_batch};
use crate::eval::checks::LimitPolicy;
use crate::eval::error::StateError;
use crate::eval::jacobian::JacobianFrame;
use crate::eval::layout::chain::Chain;
use crate::model::chain::LinkId;
use crate::model::error::escape_controls;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Configurations per block of a batch with rates: frames, velocities and accelerations
/// (192 bytes per body and configuration) stay in a core's second-level cache.
const RATE_BLOCK: usize = 512;

/// Configurations per block of a one-link batch: the link's frames (96 bytes per
/// configuration) and the transposed `q` stay in a core's second-level cache.
const LINK_BLOCK: usize = 2048;

/// Configurations per block of a batch of Jacobians.
const JACOBIAN_BLOCK: usize = 512;

/// How often the calling thread asks its [`Interrupt`] whether to stop.
pub const POLL: Duration = Duration::from_millis(50);

/// Which threads evaluate a batch.
#[derive(Clone, Copy, Debug)]
pub enum Workers<'p> {
    /// The calling thread alone, block after block.
    Here,
    /// The threads of `pool`, each with buffers of its own; the calling thread waits (asking
    /// its [`Interrupt`] every [`POLL`]).
    Pool(&'p rayon::ThreadPool),
}

/// Asked on the calling thread, at most every [`interval`](Interrupt::interval), whether a running batch should stop:
/// between blocks on [`Workers::Here`], while the pool works on [`Workers::Pool`]. A batch
/// that stops returns [`ArrayError::Interrupted`], with its outputs partly written.
pub trait Interrupt {
    /// Whether to stop.
    fn interrupted(&mut self) -> bool;

    /// How long the batch runs between two questions ([`POLL`]).
    fn interval(&self) -> Duration {
        POLL
    }
}

/// Never stops.
#[derive(Clone, Copy, Debug, Default)]
pub struct Uninterrupted;

impl Interrupt for Uninterrupted {
    fn interrupted(&mut self) -> bool {
        false
    }
}

/// A batch written into arrays did not complete.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ArrayError {
    /// Configuration `index` cannot be evaluated (not finite, out of limits, …).
    #[error("configuration {index}")]
    State {
        /// The configuration (row of `q`).
        index: usize,
        /// What is wrong with it.
        #[source]
        source: StateError,
    },
    /// A result of configuration `index` is not finite although its joint values are.
    #[error("configuration {index}")]
    NotFinite {
        /// The configuration.
        index: usize,
        /// Which result, of which link.
        #[source]
        source: Overflow,
    },
    /// An input or output does not have the entries the batch needs.
    #[error("{what} has {got} entries, the batch needs {expected}")]
    Length {
        /// `q`, `qd`, `qdd`, `poses`, `omega`, `v`, `alpha`, `a` or `jacobians`.
        what: &'static str,
        /// Entries needed.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// The chain has no moving joints: its configurations are empty, and a batch of them is one
    /// evaluation ([`forward_kinematics`](crate::forward_kinematics)).
    #[error("{0}")]
    NoDegreesOfFreedom(StateError),
    /// The [`Interrupt`] asked to stop.
    #[error("interrupted")]
    Interrupted,
}

/// A result that is not finite although the joint values it comes from are (a prismatic
/// value or a rate so large that a sum overflows).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "{what} of link '{}' overflows f64 (not finite): the joint values or rates are too large",
    escape_controls(link)
)]
#[non_exhaustive]
pub struct Overflow {
    /// `pose`, `omega`, `v`, `alpha`, `a` or `jacobian`.
    pub what: &'static str,
    /// The link's name.
    pub link: String,
}

impl Overflow {
    /// `what` (`pose`, `omega`, `v`, `alpha`, `a` or `jacobian`) of the link named `link`.
    #[must_use]
    pub fn new(what: &'static str, link: &str) -> Self {
        Overflow {
            what,
            link: link.to_string(),
        }
    }
}

impl ArrayError {
    /// The configuration it names (0 where none).
    fn index(&self) -> usize {
        match self {
            ArrayError::State { index, .. } | ArrayError::NotFinite { index, .. } => *index,
            _ => 0,
        }
    }
}

/// Links whose results a batch writes, in order, and those of them whose results its
/// finiteness check reads: the ones with no other selected link below them (a position or rate
/// that is not finite makes every one below it not finite too, since a child's are its
/// parent's plus finite terms). Made once per set of links, not per call.
#[derive(Clone, Debug, PartialEq)]
pub struct LinkSelection {
    ids: Vec<LinkId>,
    watch: Vec<usize>,
}

impl LinkSelection {
    /// `ids`, in this order (a link may appear twice).
    ///
    /// # Panics
    /// If a link comes from another chain with more links.
    #[must_use]
    pub fn new(chain: &Chain, ids: Vec<LinkId>) -> Self {
        let mut above = vec![false; chain.links().len()];
        for &id in &ids {
            let mut at = chain.link(id).parent_joint();
            while let Some(j) = at {
                let parent = chain.joint(j).parent();
                if above[parent.0] {
                    break;
                }
                above[parent.0] = true;
                at = chain.link(parent).parent_joint();
            }
        }
        let watch = (0..ids.len()).filter(|&k| !above[ids[k].0]).collect();
        LinkSelection { ids, watch }
    }

    /// Every link of `chain`, in the chain's order.
    #[must_use]
    pub fn all(chain: &Chain) -> Self {
        Self::new(chain, (0..chain.links().len()).map(LinkId).collect())
    }

    /// The links, in the order of the outputs.
    #[must_use]
    pub fn ids(&self) -> &[LinkId] {
        &self.ids
    }

    /// Checks that rows of poses (`16 · L` entries each, as [`write_link_batch`] writes them)
    /// and of rates (`3 · L` each) are finite, the first of them configuration `first`.
    ///
    /// # Errors
    /// [`ArrayError::NotFinite`] for the first pose, then the first rate, that is not.
    pub fn check_finite(
        &self,
        chain: &Chain,
        first: usize,
        poses: &[f64],
        rates: &[(&'static str, &[f64])],
    ) -> Result<(), ArrayError> {
        let l = self.ids.len().max(1);
        let mut ok = true;
        for row in poses.chunks_exact(16 * l) {
            for &k in &self.watch {
                let m = &row[16 * k..16 * k + 16];
                ok &= m[3].is_finite() & m[7].is_finite() & m[11].is_finite();
            }
        }
        for (_, r) in rates {
            for row in r.chunks_exact(3 * l) {
                for &k in &self.watch {
                    ok &= row[3 * k..3 * k + 3]
                        .iter()
                        .fold(true, |o, x| o & x.is_finite());
                }
            }
        }
        if ok {
            return Ok(());
        }
        // Rotations cannot overflow (products of sines and cosines of finite angles);
        // positions can, from finite but huge prismatic values.
        let pose = poses
            .chunks_exact(16)
            .position(|m| !m[3..12].iter().step_by(4).all(|x| x.is_finite()));
        let found = pose.map(|k| ("pose", k)).or_else(|| {
            rates.iter().find_map(|(what, r)| {
                r.iter()
                    .position(|x| !x.is_finite())
                    .map(|i| (*what, i / 3))
            })
        });
        match found {
            None => Ok(()),
            Some((what, k)) => Err(ArrayError::NotFinite {
                index: first + k / l,
                source: Overflow {
                    what,
                    link: chain.link(self.ids[k % l]).name().to_string(),
                },
            }),
        }
    }
}

/// The joint values of a batch: `n` rows of `dof` entries each; velocities `qd` (for rates)
/// and accelerations `qdd` (for accelerations, with `qd`) in the same layout.
#[derive(Clone, Copy, Debug)]
pub struct Motion<'a> {
    /// Joint values.
    pub q: &'a [f64],
    /// Joint velocities, or `None` for poses alone.
    pub qd: Option<&'a [f64]>,
    /// Joint accelerations (with `qd`), or `None`.
    pub qdd: Option<&'a [f64]>,
}

/// The arrays a batch of link results is written to, C-ordered: `poses` `(N, L, 4, 4)`, and
/// with velocities `omega`, `v` (with accelerations also `alpha`, `a`), each `(N, L, 3)`, for
/// the `L` links of a [`LinkSelection`]. Rates not asked for are empty slices.
#[derive(Debug)]
pub struct LinkArrays<'a> {
    /// World-from-link homogeneous matrices, row-major.
    pub poses: &'a mut [f64],
    /// Angular velocities, then origin velocities, angular accelerations and origin
    /// accelerations (world frame).
    pub rates: [&'a mut [f64]; 4],
}

const RATE_NAMES: [&str; 4] = ["omega", "v", "alpha", "a"];

fn need(what: &'static str, got: usize, expected: usize) -> Result<(), ArrayError> {
    if got == expected {
        Ok(())
    } else {
        Err(ArrayError::Length {
            what,
            expected,
            got,
        })
    }
}

/// One block of a batch of link results: its index, and its parts of the poses and rates.
type Part<'a> = (usize, &'a mut [f64], [&'a mut [f64]; 4]);

/// The first `k` entries of `rest`, which keeps the others.
fn take<'a>(rest: &mut &'a mut [f64], k: usize) -> &'a mut [f64] {
    let (head, tail) = std::mem::take(rest).split_at_mut(k);
    *rest = tail;
    head
}

fn at(first: usize) -> impl Fn(BatchError) -> ArrayError {
    move |e| ArrayError::State {
        index: first + e.index,
        source: e.source,
    }
}

fn written(first: usize) -> impl Fn(StateError) -> ArrayError {
    move |source| ArrayError::State {
        index: first,
        source,
    }
}

/// Poses (and with `motion.qd` velocities, with `motion.qdd` accelerations) of the links of
/// `links` for the `n` configurations of `motion`, into `out`, checked against the joint limits
/// under `policy`: the batch kernels of the one link's path for a single link, of every body
/// otherwise.
///
/// # Errors
/// [`ArrayError::Length`] for an input or output of the wrong length (before anything is
/// written); the lowest configuration that cannot be evaluated or whose results are not finite
/// (every block runs on a pool; on the calling thread the run stops at the first);
/// [`ArrayError::NoDegreesOfFreedom`] for a chain without moving joints;
/// [`ArrayError::Interrupted`].
#[allow(clippy::too_many_arguments)]
pub fn write_link_batch(
    chain: &Chain,
    policy: LimitPolicy,
    motion: Motion<'_>,
    n: usize,
    links: &LinkSelection,
    out: LinkArrays<'_>,
    workers: Workers<'_>,
    interrupt: &mut dyn Interrupt,
) -> Result<(), ArrayError> {
    let (nq, nv, l) = (chain.nq(), chain.nv(), links.ids.len());
    if nq == 0 {
        return Err(ArrayError::NoDegreesOfFreedom(
            StateError::NoDegreesOfFreedom,
        ));
    }
    let level = match (motion.qd, motion.qdd) {
        (None, None) => 0,
        (Some(_), None) => 1,
        (Some(_), Some(_)) => 2,
        (None, Some(_)) => {
            return Err(ArrayError::Length {
                what: "qd",
                expected: n.saturating_mul(nv),
                got: 0,
            });
        }
    };
    let rows = n.checked_mul(nq).ok_or(ArrayError::Length {
        what: "q",
        expected: usize::MAX,
        got: motion.q.len(),
    })?;
    need("q", motion.q.len(), rows)?;
    for (what, x) in [("qd", motion.qd), ("qdd", motion.qdd)] {
        if let Some(x) = x {
            need(what, x.len(), n.saturating_mul(nv))?;
        }
    }
    need("poses", out.poses.len(), n.saturating_mul(l * 16))?;
    for (k, r) in out.rates.iter().enumerate() {
        need(
            RATE_NAMES[k],
            r.len(),
            if k < 2 * level {
                n.saturating_mul(l * 3)
            } else {
                0
            },
        )?;
    }
    let block = block_len(
        match (level, l) {
            (0, 1) => LINK_BLOCK,
            (0, _) => fold_block_len(chain),
            _ => RATE_BLOCK,
        },
        n,
        &workers,
    );
    // Each block's part of every output, split off in order (a batch of no links still
    // evaluates, and so checks, its configurations).
    let (mut poses, mut rates) = (out.poses, out.rates);
    let parts: Vec<Part<'_>> = (0..n.div_ceil(block))
        .map(|b| {
            let len = block.min(n - b * block);
            let pose = take(&mut poses, len * l * 16);
            let rates = rates.each_mut().map(|r| {
                let k = if r.is_empty() { 0 } else { len * l * 3 };
                take(r, k)
            });
            (b, pose, rates)
        })
        .collect();
    let ids = &links.ids[..];
    let eval = |data: &mut BatchData, (b, pose, rates): Part<'_>| {
        let range = b * block..((b + 1) * block).min(n);
        let first = range.start;
        let q = &motion.q[range.start * nq..range.end * nq];
        let span = range.start * nv..range.end * nv;
        let [omega, v, alpha, a] = rates;
        match (motion.qd, motion.qdd) {
            (Some(qd), None) => {
                let r = forward_velocities_batch(chain, data, q, &qd[span]).map_err(at(first))?;
                r.poses()
                    .write_matrices(ids, pose)
                    .and_then(|()| r.write_velocities(ids, omega, v))
                    .map_err(written(first))?;
                links.check_finite(chain, first, pose, &[("omega", omega), ("v", v)])
            }
            (Some(qd), Some(qdd)) => {
                let r = forward_accelerations_batch(chain, data, q, &qd[span.clone()], &qdd[span])
                    .map_err(at(first))?;
                let vel = r.velocities();
                vel.poses()
                    .write_matrices(ids, pose)
                    .and_then(|()| vel.write_velocities(ids, omega, v))
                    .and_then(|()| r.write_accelerations(ids, alpha, a))
                    .map_err(written(first))?;
                links.check_finite(
                    chain,
                    first,
                    pose,
                    &[("omega", omega), ("v", v), ("alpha", alpha), ("a", a)],
                )
            }
            _ if l == 1 => {
                forward_kinematics_batch_to(chain, data, q, ids[0])
                    .map_err(at(first))?
                    .write_matrices(pose)
                    .map_err(written(first))?;
                links.check_finite(chain, first, pose, &[])
            }
            _ => {
                forward_kinematics_batch(chain, data, q)
                    .map_err(at(first))?
                    .write_matrices(ids, pose)
                    .map_err(written(first))?;
                links.check_finite(chain, first, pose, &[])
            }
        }
    };
    run_blocks(chain, policy, parts, workers, interrupt, eval)
}

/// The geometric Jacobians of `link` (as [`jacobian_batch`] computes them) for the `n`
/// configurations `qs`, into `out` (`(N, 6, dof)`, C-ordered), checked against the limits
/// under `policy`, block by block on `workers`.
///
/// # Errors
/// As [`write_link_batch`].
///
/// # Panics
/// If `link` comes from another chain with more links.
#[allow(clippy::too_many_arguments)]
pub fn write_jacobian_batch(
    chain: &Chain,
    policy: LimitPolicy,
    qs: &[f64],
    n: usize,
    link: LinkId,
    frame: JacobianFrame,
    out: &mut [f64],
    workers: Workers<'_>,
    interrupt: &mut dyn Interrupt,
) -> Result<(), ArrayError> {
    let (nq, dof) = (chain.nq(), chain.nv());
    if dof == 0 {
        return Err(ArrayError::NoDegreesOfFreedom(
            StateError::NoDegreesOfFreedom,
        ));
    }
    need("q", qs.len(), n.saturating_mul(nq))?;
    need("jacobians", out.len(), n.saturating_mul(6 * dof))?;
    let mut rest = out;
    let block = block_len(JACOBIAN_BLOCK, n, &workers);
    let parts: Vec<(usize, &mut [f64])> = (0..n.div_ceil(block))
        .map(|b| (b, take(&mut rest, block.min(n - b * block) * 6 * dof)))
        .collect();
    let eval = |data: &mut BatchData, (b, dst): (usize, &mut [f64])| {
        let first = b * block;
        let q = &qs[first * nq..(first + dst.len() / (6 * dof)) * nq];
        jacobian_batch(chain, data, q, link, frame, dst).map_err(at(first))?;
        match dst.iter().position(|x| !x.is_finite()) {
            None => Ok(()),
            Some(k) => Err(ArrayError::NotFinite {
                index: first + k / (6 * dof),
                source: Overflow {
                    what: "jacobian",
                    link: chain.link(link).name().to_string(),
                },
            }),
        }
    };
    run_blocks(chain, policy, parts, workers, interrupt, eval)
}

/// The configurations of a block: `preferred`, or fewer on a pool when a batch of `n` would
/// give each thread fewer than [`PARTS_PER_THREAD`] blocks (so that the threads finish
/// together), whole lanes of eight and at least [`MIN_SHARED_BLOCK`].
fn block_len(preferred: usize, n: usize, workers: &Workers<'_>) -> usize {
    let shared = match workers {
        Workers::Here => return preferred.max(1),
        Workers::Pool(pool) => n
            .div_ceil(pool.current_num_threads().max(1) * PARTS_PER_THREAD)
            .next_multiple_of(8),
    };
    shared
        .clamp(MIN_SHARED_BLOCK.min(preferred), preferred)
        .max(1)
}

/// Blocks per thread that a pool is given at least, where the batch allows.
const PARTS_PER_THREAD: usize = 4;

/// The smallest block a pool is given (smaller ones cost more in scheduling than they save).
const MIN_SHARED_BLOCK: usize = 64;

/// Runs `eval(data, part)` on every part, in order on the calling thread or in parallel on a
/// pool (each thread with batch buffers of its own, checking under `policy`), and fails with
/// the failure of the lowest configuration among the parts that fail, or with
/// [`ArrayError::Interrupted`].
fn run_blocks<P: Send>(
    chain: &Chain,
    policy: LimitPolicy,
    parts: Vec<P>,
    workers: Workers<'_>,
    interrupt: &mut dyn Interrupt,
    eval: impl Fn(&mut BatchData, P) -> Result<(), ArrayError> + Sync,
) -> Result<(), ArrayError> {
    let make = || BatchData::new(chain).with_limit_policy(policy);
    let pool = match workers {
        // One block is no work to share: waking the pool would cost more than it saves.
        Workers::Pool(pool) if parts.len() > 1 => pool,
        _ => {
            let (mut data, mut last) = (make(), Instant::now());
            for part in parts {
                if last.elapsed() >= interrupt.interval() {
                    if interrupt.interrupted() {
                        return Err(ArrayError::Interrupted);
                    }
                    last = Instant::now();
                }
                eval(&mut data, part)?;
            }
            return Ok(());
        }
    };
    let stop = AtomicBool::new(false);
    let (sent, received) = std::sync::mpsc::channel();
    let mut interrupted = false;
    let result = pool.in_place_scope(|s| {
        let (stop, eval) = (&stop, &eval);
        s.spawn(move |_| {
            let first = parts
                .into_par_iter()
                .map_init(make, |data, part| {
                    if stop.load(Ordering::Relaxed) {
                        return Ok(());
                    }
                    eval(data, part)
                })
                .filter_map(Result::err)
                .min_by_key(ArrayError::index);
            let _ = sent.send(first);
        });
        loop {
            match received.recv_timeout(interrupt.interval()) {
                Ok(first) => return first,
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                    if !interrupted && interrupt.interrupted() {
                        stop.store(true, Ordering::Relaxed);
                        interrupted = true;
                    }
                }
                // The work panicked: the scope passes the panic on when it ends.
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => return None,
            }
        }
    });
    match (interrupted, result) {
        (true, _) => Err(ArrayError::Interrupted),
        (false, Some(e)) => Err(e),
        (false, None) => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::{Workers, block_len};

    #[test]
    fn a_pool_gets_at_least_four_blocks_a_thread_of_whole_lanes_where_the_batch_allows() {
        let Ok(pool) = rayon::ThreadPoolBuilder::new().num_threads(2).build() else {
            panic!("no pool of two threads");
        };
        let pool = Workers::Pool(&pool);
        // Large batches keep the preferred block; the calling thread always does.
        assert_eq!(block_len(2048, 1_000_000, &pool), 2048);
        assert_eq!(block_len(2048, 10_000, &Workers::Here), 2048);
        // 10 000 on two threads: eight blocks of 1 256 (a multiple of eight).
        assert_eq!(block_len(2048, 10_000, &pool), 1256);
        assert_eq!(10_000usize.div_ceil(1256), 8);
        // Never below 64, nor above the preferred block when that is smaller.
        assert_eq!(block_len(2048, 100, &pool), 64);
        assert_eq!(block_len(32, 100, &pool), 32);
        assert_eq!(block_len(512, 0, &pool), 64);
    }
}
