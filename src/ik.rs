//! Inverse kinematics: the joint values that put one or several links (or points on them) at
//! target poses, positions or orientations, in the world or relative to another link.
//!
//! # Method
//! Levenberg–Marquardt on the pose error, with the damping that depends on the error (Sugihara,
//! "Solvability-unconcerned inverse kinematics by the Levenberg–Marquardt method", IEEE T-RO 2011):
//! for the stacked, weighted error `e` (each goal's position gap `p* − p` and the rotation vector
//! `log(R* Rᵀ)` of its orientation gap, eq. 2.33 turned into a vector, both in the goal's
//! reference axes) and the Jacobian `J` of the moving point and the link's angular velocity
//! ([`crate::Poses::jacobian_in`], eqs. 2.120–2.121), each step solves
//!
//! ```text
//! (Jᵀ W J + λ I) Δ = Jᵀ W e,        λ = μ (E + λ₀),   E = ½ eᵀ W e
//! ```
//!
//! by Cholesky. A step that does not lower `E` is refused and `μ` grows ten-fold; one that does
//! is taken and `μ` shrinks. The damping that tracks `E` keeps far steps short and lets the last
//! ones converge quadratically (`λ → μ λ₀`, tiny), which is what reaching 1e-6 in a few
//! iterations needs; near a singularity it bounds the step where a pseudo-inverse would not.
//!
//! **Limits hold during the search.** A step is bounded: every entry is cut at its joint's limit,
//! and joints that the step pushes against a limit they stand on are taken out of the system for
//! that step (an active set), so that the others make up for them instead of the whole step being
//! shortened. No answer is ever clamped after the fact: every iterate is within the limits.
//!
//! **Restarts.** When an attempt stalls (no progress for a few steps) or runs out of its
//! iterations, the solver starts again from a configuration drawn uniformly within the limits by
//! a generator seeded with [`Options::seed`] (floating and ball joints keep the start's value), up
//! to [`Options::max_attempts`] attempts. Everything is deterministic: the same inputs give the
//! same bits, alone, in a batch, on any number of threads (an optional
//! [`Options::time_limit`] is the one exception, by its nature).
//!
//! Continuous joints (rotational, without limits) are reported within `(−π, π]`. A floating
//! base or ball joint is solved like any joint (its quaternion updated by the exponential of the
//! step's rotation, so it stays unit), or locked ([`Options::locked`]).
//!
//! ```
//! use kinechain::ik::{Goal, Options, Solver};
//! use kinechain::{Chain, Data, forward_kinematics_to};
//!
//! let chain = Chain::from_file(concat!(env!("CARGO_MANIFEST_DIR"), "/robots/ur5.yaml"))?;
//! let tool = chain.link_id("tool0")?;
//! // A pose the tool can reach: where another configuration puts it.
//! let target = forward_kinematics_to(&chain, &mut Data::new(&chain), &[0.3, -1.2, 1.4, -0.5, 1.1, 0.2], tool)?;
//! let mut solver = Solver::new(&chain, vec![Goal::pose(tool)], Options::default())?;
//! let solution = solver.solve(&[target], None)?;
//! assert!(solution.success);
//! assert!(solution.position_error[0] < 1e-6 && solution.rotation_error[0] < 1e-6);
//! # Ok::<(), kinechain::Error>(())
//! ```

use crate::eval::batch::{Interrupt, Workers};
use crate::eval::jacobian::stored_jacobian;
use crate::eval::layout::chain::Chain;
use crate::eval::layout::stored::transform;
use crate::eval::sampling::{SplitMix, between, range};
use crate::eval::{Data, JacobianFrame, LimitPolicy};
use crate::model::chain::{JointId, LinkId};
use crate::model::joint::JointKind;
use crate::model::transform::{NotRigid, Transform, add3, cross3, sub3};
use crate::{StateError, forward_kinematics, forward_kinematics_to};
use rayon::prelude::*;
use std::f64::consts::{PI, TAU};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// What to place: a link (or a point fixed on it), which components of its pose count, and the
/// frame its target is given in.
#[derive(Clone, Debug, PartialEq)]
pub struct Goal {
    link: LinkId,
    point: [f64; 3],
    base: Option<LinkId>,
    weights: [f64; 6],
}

impl Goal {
    /// The whole pose of `link`'s frame.
    #[must_use]
    pub fn pose(link: LinkId) -> Self {
        Goal {
            link,
            point: [0.0; 3],
            base: None,
            weights: [1.0; 6],
        }
    }

    /// The position of `link`'s origin (or of [`Goal::at_point`]) only; its orientation is free.
    #[must_use]
    pub fn position(link: LinkId) -> Self {
        Goal::pose(link).with_weights([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    }

    /// The orientation of `link` only; its position is free.
    #[must_use]
    pub fn orientation(link: LinkId) -> Self {
        Goal::pose(link).with_weights([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    }

    /// The point with link coordinates `u` is placed instead of the link's origin (a tool
    /// centre point).
    #[must_use]
    pub fn at_point(mut self, u: [f64; 3]) -> Self {
        self.point = u;
        self
    }

    /// The target is given in `base`'s frame (a foot relative to the pelvis, a hand relative to
    /// the torso) rather than the world's.
    #[must_use]
    pub fn relative_to(mut self, base: LinkId) -> Self {
        self.base = Some(base);
        self
    }

    /// Weights of the six error components `[x, y, z, rx, ry, rz]` along the **target's** axes
    /// (position, then rotation vector). 0 frees a component: `[1, 1, 1, 1, 1, 0]` leaves the
    /// rotation about the target's z axis free (a tool that may spin about its axis). A zero
    /// component is not counted in the residuals; the others are counted unweighted.
    #[must_use]
    pub fn with_weights(mut self, weights: [f64; 6]) -> Self {
        self.weights = weights;
        self
    }

    /// The link placed.
    #[must_use]
    pub fn link(&self) -> LinkId {
        self.link
    }

    /// The link whose frame the target is in (`None`: the world).
    #[must_use]
    pub fn base(&self) -> Option<LinkId> {
        self.base
    }

    /// The weights of [`Goal::with_weights`].
    #[must_use]
    pub fn weights(&self) -> [f64; 6] {
        self.weights
    }
}

/// Where a solve starts when it is given no `q0`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Start {
    /// The middle of each joint's limits ([`crate::Chain::neutral`]'s value for a joint without
    /// both limits).
    #[default]
    MidLimits,
    /// [`crate::Chain::neutral`]: zero where the limits allow it.
    Neutral,
}

/// The distance to the seed a [`Options::closest`] search minimises, over the entries of `q` that
/// the solve moves (a quaternion's entries count as coordinates).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Distance {
    /// `√Σ (qᵢ − q0ᵢ)²`.
    L2,
    /// `max |qᵢ − q0ᵢ|`: the largest single joint motion.
    LInf,
}

/// How a solve searches and when it succeeds.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Success: every goal's position within this (m, the norm of its counted components).
    pub position_tolerance: f64,
    /// Success: every goal's rotation angle within this (rad).
    pub rotation_tolerance: f64,
    /// Iterations of one attempt before a restart.
    pub iterations_per_attempt: usize,
    /// Attempts in all (the first from `q0`, the others from random configurations).
    pub max_attempts: usize,
    /// Seed of the restarts' generator.
    pub seed: u64,
    /// Stop after this wall time, between iterations (makes the result depend on the machine).
    pub time_limit: Option<Duration>,
    /// Keep searching through every attempt and return the solution closest to the seed.
    pub closest: Option<Distance>,
    /// Joints that do not move (they keep the seed's values).
    pub locked: Vec<JointId>,
    /// Where a solve without `q0` starts.
    pub start: Start,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            position_tolerance: 1e-6,
            rotation_tolerance: 1e-6,
            iterations_per_attempt: 40,
            max_attempts: 100,
            seed: 0,
            time_limit: None,
            closest: None,
            locked: Vec::new(),
            start: Start::MidLimits,
        }
    }
}

/// The outcome of one solve. No solution is a result too: `success` false, with the best `q`
/// found and its residuals.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// The configuration (`nq` entries), within every joint's limits.
    pub q: Vec<f64>,
    /// Every goal within the tolerances.
    pub success: bool,
    /// Each goal's position error (m).
    pub position_error: Vec<f64>,
    /// Each goal's rotation error (rad).
    pub rotation_error: Vec<f64>,
    /// Iterations in all attempts.
    pub iterations: usize,
    /// Attempts after the first.
    pub restarts: usize,
}

/// What makes a problem or a solve impossible to pose (not failing to converge: that is a
/// [`Solution`] with `success` false).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IkError {
    /// No goal was given.
    #[error("inverse kinematics needs at least one goal")]
    NoGoal,
    /// A goal names a link of another chain.
    #[error("goal {goal}: link index {link} is not a link of this chain ({links} links)")]
    UnknownLink {
        /// The goal's index.
        goal: usize,
        /// The index given.
        link: usize,
        /// Links the chain has.
        links: usize,
    },
    /// A goal's weights or point are not finite, or a weight is negative.
    #[error("goal {goal}: {what}")]
    BadGoal {
        /// The goal's index.
        goal: usize,
        /// What is wrong.
        what: String,
    },
    /// An option is out of its range.
    #[error("option {option}: {what}")]
    BadOption {
        /// The option's name.
        option: &'static str,
        /// What is wrong.
        what: String,
    },
    /// A locked joint of another chain.
    #[error("locked joint index {0} is not a joint of this chain")]
    UnknownJoint(usize),
    /// The number of targets is not the number of goals.
    #[error("{got} targets for {goals} goals")]
    TargetCount {
        /// Targets given.
        got: usize,
        /// Goals of the solver.
        goals: usize,
    },
    /// A target matrix is not a rigid transform.
    #[error("target {index}: {source}")]
    Target {
        /// Index of the target.
        index: usize,
        /// Why.
        source: NotRigid,
    },
    /// The seed cannot be evaluated: wrong length, non-finite, or outside a joint's limits.
    #[error("seed q0: {0}")]
    Seed(#[source] StateError),
    /// An input or output array of a batch has the wrong length.
    #[error("{what} has {got} entries, expected {expected}")]
    Length {
        /// The array.
        what: &'static str,
        /// Entries expected.
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// A row of a batch cannot be solved (its targets or seed).
    #[error("row {row}: {source}")]
    Row {
        /// The row.
        row: usize,
        /// Why.
        source: Box<IkError>,
    },
    /// The batch was stopped by its [`Interrupt`].
    #[error("the solve was interrupted")]
    Interrupted,
}

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
const BATCH_BLOCK: usize = 64;

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
            check_target(t).map_err(|source| IkError::Row {
                row,
                source: Box::new(IkError::Target { index, source }),
            })?;
        }
    }
    if let Some(seeds) = seeds {
        for (row, q) in seeds.chunks_exact(nq.max(1)).enumerate().take(n) {
            crate::check_q(solver.chain, q, LimitPolicy::Enforce).map_err(|e| IkError::Row {
                row,
                source: Box::new(IkError::Seed(e)),
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
type Part<'a> = (
    usize,
    &'a mut [f64],
    &'a mut [bool],
    &'a mut [f64],
    &'a mut [f64],
    &'a mut [u32],
    &'a mut [u32],
);

/// An entry of `q̇` the solve moves.
#[derive(Clone, Copy, Debug)]
enum Var {
    /// A joint coordinate `q[q]` within `[lo, hi]`; `wrap`: rotational and unbounded; `around`:
    /// rotational with limits a whole turn or more apart.
    Scalar {
        q: usize,
        lo: f64,
        hi: f64,
        wrap: bool,
        around: bool,
    },
    /// Component `k` of the translation of the floating joint of body `body`, at `q[q..q + 3]`.
    Shift { body: usize, q: usize, k: usize },
    /// Component `k` of the rotation of the quaternion joint of body `body`, quaternion at
    /// `q[q..q + 4]`.
    Turn { body: usize, q: usize, k: usize },
}

/// A goal with what the evaluation needs of it.
#[derive(Clone, Debug)]
struct Prepared {
    goal: Goal,
    /// Whether the weights differ within the position or the rotation half, so that the error
    /// must be turned into the target's axes before weighting.
    turn: bool,
    sqrt_w: [f64; 6],
    counted: [bool; 6],
}

/// The best attempt so far: its configuration, its score (the distance to the seed of a
/// solution under [`Options::closest`], else the squared residual), residuals and success.
type Best = (Vec<f64>, f64, Vec<[f64; 2]>, bool);

/// A reusable solver for a chain and a list of goals: it holds the buffers, so a solve allocates
/// nothing but its result.
pub struct Solver<'c> {
    chain: &'c Chain,
    goals: Vec<Prepared>,
    options: Options,
    vars: Vec<Var>,
    /// `v` index of each var (column of the full Jacobian).
    columns: Vec<usize>,
    /// Quaternion joints moved by the solve: (body, q of the quaternion).
    data: Data,
    full: Vec<f64>,
    base_j: Vec<f64>,
    /// Weighted Jacobian, `rows × n`, column-major.
    j: Vec<f64>,
    e: Vec<f64>,
    residual: Vec<[f64; 2]>,
    a: Vec<f64>,
    g: Vec<f64>,
    step: Vec<f64>,
    held: Vec<bool>,
    candidate: Vec<f64>,
    candidate_e: Vec<f64>,
    candidate_j: Vec<f64>,
    candidate_residual: Vec<[f64; 2]>,
    start: Vec<f64>,
    one_link: bool,
    /// The quaternion joints' bodies, and the world rotation of each one's joint frame at the
    /// current iterate and at the candidate (the quaternion steps are taken in these axes).
    turn_bodies: Vec<usize>,
    turns: Vec<[[f64; 3]; 3]>,
    candidate_turns: Vec<[[f64; 3]; 3]>,
}

impl std::fmt::Debug for Solver<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Solver")
            .field("goals", &self.goals.len())
            .field("variables", &self.vars.len())
            .field("options", &self.options)
            .finish_non_exhaustive()
    }
}

impl Clone for Solver<'_> {
    fn clone(&self) -> Self {
        Solver {
            chain: self.chain,
            goals: self.goals.clone(),
            options: self.options.clone(),
            vars: self.vars.clone(),
            columns: self.columns.clone(),
            data: Data::new(self.chain).with_limit_policy(LimitPolicy::Ignore),
            full: self.full.clone(),
            base_j: self.base_j.clone(),
            j: self.j.clone(),
            e: self.e.clone(),
            residual: self.residual.clone(),
            a: self.a.clone(),
            g: self.g.clone(),
            step: self.step.clone(),
            held: self.held.clone(),
            candidate: self.candidate.clone(),
            candidate_e: self.candidate_e.clone(),
            candidate_j: self.candidate_j.clone(),
            candidate_residual: self.candidate_residual.clone(),
            start: self.start.clone(),
            one_link: self.one_link,
            turn_bodies: self.turn_bodies.clone(),
            turns: self.turns.clone(),
            candidate_turns: self.candidate_turns.clone(),
        }
    }
}

/// Floor of the damping, relative to `E` (m², rad²): small enough that the last steps are
/// Gauss–Newton steps, large enough to keep `Jᵀ W J + λ I` positive definite in rounding.
const LAMBDA_FLOOR: f64 = 1e-12;

/// Accepted steps in a row that each lower `E` by less than 1 % end an attempt: the search is
/// at a local minimum (most often against a joint limit) and a restart does better.
const STALL: usize = 6;

impl<'c> Solver<'c> {
    /// A solver for `goals` on `chain`.
    ///
    /// # Errors
    /// [`IkError`] for no goal, a link or locked joint of another chain, non-finite or negative
    /// weights, a non-finite point, or options out of range.
    pub fn new(chain: &'c Chain, goals: Vec<Goal>, options: Options) -> Result<Self, IkError> {
        if goals.is_empty() {
            return Err(IkError::NoGoal);
        }
        check_options(&options)?;
        let links = chain.links().len();
        let mut prepared = Vec::with_capacity(goals.len());
        for (i, goal) in goals.into_iter().enumerate() {
            for l in std::iter::once(goal.link).chain(goal.base) {
                if l.0 >= links {
                    return Err(IkError::UnknownLink {
                        goal: i,
                        link: l.0,
                        links,
                    });
                }
            }
            if let Some(w) = goal.weights.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
                return Err(IkError::BadGoal {
                    goal: i,
                    what: format!("weight {w} (weights are finite and ≥ 0)"),
                });
            }
            if goal.weights.iter().all(|w| *w == 0.0) {
                return Err(IkError::BadGoal {
                    goal: i,
                    what: "every weight is 0: nothing to place".into(),
                });
            }
            if goal.point.iter().any(|x| !x.is_finite()) {
                return Err(IkError::BadGoal {
                    goal: i,
                    what: format!("point {:?} is not finite", goal.point),
                });
            }
            let w = goal.weights;
            let turn = !(w[0] == w[1] && w[1] == w[2] && w[3] == w[4] && w[4] == w[5]);
            prepared.push(Prepared {
                sqrt_w: w.map(f64::sqrt),
                counted: w.map(|x| x > 0.0),
                turn,
                goal,
            });
        }
        for j in &options.locked {
            if j.0 >= chain.joints().len() {
                return Err(IkError::UnknownJoint(j.0));
            }
        }
        let vars = variables(chain, &prepared, &options.locked);
        let columns = vars.iter().map(|v| v.1).collect();
        let vars: Vec<Var> = vars.into_iter().map(|v| v.0).collect();
        let (n, rows, dof) = (vars.len(), 6 * prepared.len(), chain.dof());
        let one_link = prepared.len() == 1 && prepared[0].goal.base.is_none();
        let mut turn_bodies: Vec<usize> = vars
            .iter()
            .filter_map(|v| match *v {
                Var::Turn { body, .. } | Var::Shift { body, .. } => Some(body),
                Var::Scalar { .. } => None,
            })
            .collect();
        turn_bodies.dedup();
        let m = turn_bodies.len();
        Ok(Solver {
            turn_bodies,
            turns: vec![[[0.0; 3]; 3]; m],
            candidate_turns: vec![[[0.0; 3]; 3]; m],
            chain,
            goals: prepared,
            options,
            columns,
            data: Data::new(chain).with_limit_policy(LimitPolicy::Ignore),
            full: vec![0.0; 6 * dof],
            base_j: vec![0.0; 6 * dof],
            j: vec![0.0; rows * n],
            e: vec![0.0; rows],
            residual: Vec::new(),
            a: vec![0.0; rows.min(n).pow(2)],
            g: vec![0.0; rows.min(n)],
            step: vec![0.0; n],
            held: vec![false; n],
            candidate: vec![0.0; chain.nq()],
            candidate_e: vec![0.0; rows],
            candidate_j: vec![0.0; rows * n],
            candidate_residual: Vec::new(),
            start: vec![0.0; chain.nq()],
            one_link,
            vars,
        })
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &Options {
        &self.options
    }

    /// The goals.
    pub fn goals(&self) -> impl ExactSizeIterator<Item = &Goal> {
        self.goals.iter().map(|g| &g.goal)
    }

    /// Entries of `q̇` the solve moves: the joints on the goals' paths that are not locked.
    #[must_use]
    pub fn moving(&self) -> usize {
        self.vars.len()
    }

    /// The configuration a solve without `q0` starts from ([`Options::start`]).
    #[must_use]
    pub fn default_start(&self) -> Vec<f64> {
        start_of(self.chain, self.options.start)
    }

    /// Solves for `targets` (one per goal, in the goal's reference frame: the world's, or its
    /// base link's), starting from `q0` (or [`Options::start`]).
    ///
    /// # Errors
    /// [`IkError`] for a wrong number of targets, a target that is not a rigid transform, or a
    /// seed of the wrong length, non-finite or outside the limits.
    pub fn solve(
        &mut self,
        targets: &[Transform],
        q0: Option<&[f64]>,
    ) -> Result<Solution, IkError> {
        if targets.len() != self.goals.len() {
            return Err(IkError::TargetCount {
                got: targets.len(),
                goals: self.goals.len(),
            });
        }
        for (index, t) in targets.iter().enumerate() {
            check_target(t).map_err(|source| IkError::Target { index, source })?;
        }
        match q0 {
            Some(q) => {
                crate::check_q(self.chain, q, LimitPolicy::Enforce).map_err(IkError::Seed)?;
                self.start.copy_from_slice(q);
            }
            None => self.start = start_of(self.chain, self.options.start),
        }
        Ok(self.run(targets))
    }

    /// The search, on checked targets and seed (`self.start`).
    fn run(&mut self, targets: &[Transform]) -> Solution {
        let began = self.options.time_limit.map(|_| Instant::now());
        let mut rng = SplitMix(self.options.seed);
        let mut q = self.start.clone();
        let mut best: Option<Best> = None;
        let (mut iterations, mut attempts) = (0, 0);
        let limit = self.options.time_limit;
        let out_of_time = |began: Option<Instant>| match (began, limit) {
            (Some(b), Some(limit)) => b.elapsed() >= limit,
            _ => false,
        };
        while attempts < self.options.max_attempts {
            if attempts > 0 {
                if out_of_time(began) {
                    break;
                }
                self.restart(&mut q, &mut rng);
            }
            attempts += 1;
            let (ok, used) = self.attempt(&mut q, targets, began);
            iterations += used;
            let error = self.cost_of_residuals();
            let keep = match (&best, ok, self.options.closest) {
                (None, _, _) => true,
                (Some((_, _, _, true)), false, _) => false,
                (Some((_, _, _, false)), true, _) => true,
                (Some((_, d, _, true)), true, Some(metric)) => {
                    distance(metric, &q, &self.start, &self.vars) < *d
                }
                (Some((_, _, _, true)), true, None) => false,
                (Some((_, e, _, false)), false, _) => error < *e,
            };
            if keep {
                let score = match (ok, self.options.closest) {
                    (true, Some(metric)) => distance(metric, &q, &self.start, &self.vars),
                    _ => error,
                };
                best = Some((q.clone(), score, self.residual.clone(), ok));
            }
            if ok && self.options.closest.is_none() {
                break;
            }
        }
        let (q, _, residual, success) = best.unwrap_or((q, f64::INFINITY, Vec::new(), false));
        Solution {
            q,
            success,
            position_error: residual.iter().map(|r| r[0]).collect(),
            rotation_error: residual.iter().map(|r| r[1]).collect(),
            iterations,
            restarts: attempts.saturating_sub(1),
        }
    }

    /// Sum of squares of the residuals, to rank failed attempts.
    fn cost_of_residuals(&self) -> f64 {
        self.residual
            .iter()
            .map(|r| r[0] * r[0] + r[1] * r[1])
            .sum()
    }

    /// A random configuration within the limits for the moving scalar entries; the others (locked
    /// joints, floating and ball joints) keep the start's values.
    fn restart(&self, q: &mut [f64], rng: &mut SplitMix) {
        q.copy_from_slice(&self.start);
        for v in &self.vars {
            if let Var::Scalar { q: i, lo, hi, .. } = *v {
                let (a, b) = range(lo, hi);
                q[i] = between(a, b, rng.unit()).clamp(lo, hi);
            }
        }
    }

    /// One attempt from `q`, which ends holding the attempt's last accepted iterate (with
    /// `self.residual` its residuals). Returns success and iterations used.
    fn attempt(
        &mut self,
        q: &mut [f64],
        targets: &[Transform],
        began: Option<Instant>,
    ) -> (bool, usize) {
        let n = self.vars.len();
        wrap(q, &self.vars);
        let mut cost = self.evaluate(q, targets, true, false);
        let mut mu = 1.0;
        let mut stalled = 0;
        for it in 0..self.options.iterations_per_attempt {
            if self.converged(false) {
                return (true, it);
            }
            if it % 8 == 7
                && let (Some(b), Some(limit)) = (began, self.options.time_limit)
                && b.elapsed() >= limit
            {
                return (false, it);
            }
            let lambda = mu * (cost + LAMBDA_FLOOR);
            self.held.fill(false);
            let mut accepted = false;
            // The step, then once more without the joints it pushes against their limits.
            for _ in 0..2 {
                if !self.solve_step(lambda) {
                    break;
                }
                let newly_held = self.bounded_step(q);
                if !newly_held {
                    break;
                }
            }
            if n > 0 {
                let candidate_cost = {
                    let c = std::mem::take(&mut self.candidate);
                    let cost = self.evaluate(&c, targets, true, true);
                    self.candidate = c;
                    cost
                };
                if candidate_cost < cost {
                    accepted = true;
                    stalled = if candidate_cost > 0.99 * cost {
                        stalled + 1
                    } else {
                        0
                    };
                    cost = candidate_cost;
                    q.copy_from_slice(&self.candidate);
                    std::mem::swap(&mut self.e, &mut self.candidate_e);
                    std::mem::swap(&mut self.j, &mut self.candidate_j);
                    std::mem::swap(&mut self.residual, &mut self.candidate_residual);
                    std::mem::swap(&mut self.turns, &mut self.candidate_turns);
                    mu = (mu * 0.25).max(1e-3);
                }
            }
            if !accepted {
                mu *= 10.0;
                if mu > 1e8 {
                    return (self.converged(false), it + 1);
                }
            }
            if stalled >= STALL {
                return (self.converged(false), it + 1);
            }
        }
        (self.converged(false), self.options.iterations_per_attempt)
    }

    /// Whether the current (or candidate) residuals are within the tolerances.
    fn converged(&self, candidate: bool) -> bool {
        let r = if candidate {
            &self.candidate_residual
        } else {
            &self.residual
        };
        r.iter().all(|r| {
            r[0] <= self.options.position_tolerance && r[1] <= self.options.rotation_tolerance
        })
    }

    /// `self.step` ← the damped step of the variables not held, from `self.j` and `self.e`:
    /// `Δ = (J̃ᵀ J̃ + λ I)⁻¹ J̃ᵀ e = J̃ᵀ (J̃ J̃ᵀ + λ I)⁻¹ e` (`J̃`: the held columns zeroed), the
    /// smaller of the two systems solved (6 × 6 for one pose goal on a 7-joint arm). False if
    /// it cannot be solved (then the step is zero).
    fn solve_step(&mut self, lambda: f64) -> bool {
        let n = self.vars.len();
        let rows = self.e.len();
        let wide = rows <= n;
        if rows == 6 && wide {
            return self.solve_step6(lambda);
        }
        let m = if wide { rows } else { n };
        let a = &mut self.a[..m * m];
        let g = &mut self.g[..m];
        a.fill(0.0);
        if wide {
            // J̃ J̃ᵀ, a sum of the columns' outer products (lower triangle).
            for c in (0..n).filter(|&c| !self.held[c]) {
                let col = &self.j[c * rows..(c + 1) * rows];
                for (r1, &x) in col.iter().enumerate() {
                    if x != 0.0 {
                        for (r2, &y) in col[..=r1].iter().enumerate() {
                            a[r1 * m + r2] += x * y;
                        }
                    }
                }
            }
            g.copy_from_slice(&self.e);
        } else {
            for c1 in 0..n {
                let col1 = &self.j[c1 * rows..(c1 + 1) * rows];
                g[c1] = if self.held[c1] {
                    0.0
                } else {
                    dot(col1, &self.e)
                };
                for c2 in 0..=c1 {
                    if !self.held[c1] && !self.held[c2] {
                        a[c1 * m + c2] = dot(col1, &self.j[c2 * rows..(c2 + 1) * rows]);
                    }
                }
            }
        }
        for k in 0..m {
            a[k * m + k] += lambda;
        }
        if !cholesky_solve(a, m, g) {
            self.step.fill(0.0);
            return false;
        }
        if wide {
            for (c, s) in self.step.iter_mut().enumerate() {
                *s = if self.held[c] {
                    0.0
                } else {
                    dot(&self.j[c * rows..(c + 1) * rows], g)
                };
            }
        } else {
            self.step.copy_from_slice(g);
        }
        true
    }

    /// [`Solver::solve_step`] for one goal of six rows on at least six joints, in fixed-size
    /// arithmetic (the usual problem: a pose of an arm's tool).
    fn solve_step6(&mut self, lambda: f64) -> bool {
        let mut a = nalgebra::Matrix6::<f64>::identity() * lambda;
        for (c, col) in self.j.chunks_exact(6).enumerate() {
            if !self.held[c] {
                let v = nalgebra::Vector6::from_column_slice(col);
                a.syger(1.0, &v, &v, 1.0);
            }
        }
        let Some(cholesky) = a.cholesky() else {
            self.step.fill(0.0);
            return false;
        };
        let y = cholesky.solve(&nalgebra::Vector6::from_column_slice(&self.e));
        for ((s, col), held) in self
            .step
            .iter_mut()
            .zip(self.j.chunks_exact(6))
            .zip(&self.held)
        {
            *s = if *held { 0.0 } else { dot(col, y.as_slice()) };
        }
        true
    }

    /// `self.candidate` ← `q` moved by `self.step`, each scalar cut at its limits. Marks as held
    /// the variables the step pushes out of their range from a limit they stand on, and returns
    /// whether there were new ones (the step is then solved again without them).
    fn bounded_step(&mut self, q: &[f64]) -> bool {
        self.candidate.copy_from_slice(q);
        let mut newly_held = false;
        let mut turns: [([f64; 3], usize, usize); 4] = [([0.0; 3], usize::MAX, 0); 4];
        let mut shifts: [([f64; 3], usize, usize); 4] = [([0.0; 3], usize::MAX, 0); 4];
        let mut rest_turns: Vec<([f64; 3], usize, usize)> = Vec::new();
        let mut rest_shifts: Vec<([f64; 3], usize, usize)> = Vec::new();
        for (k, v) in self.vars.iter().enumerate() {
            let dx = self.step[k];
            match *v {
                Var::Scalar {
                    q: i,
                    lo,
                    hi,
                    around,
                    ..
                } => {
                    let mut x = q[i] + dx;
                    // A joint that turns a whole turn or more goes round instead of stopping.
                    if around && x > hi && x - TAU >= lo {
                        x -= TAU;
                    } else if around && x < lo && x + TAU <= hi {
                        x += TAU;
                    }
                    if ((x < lo && q[i] <= lo) || (x > hi && q[i] >= hi)) && !self.held[k] {
                        self.held[k] = true;
                        newly_held = true;
                    }
                    self.candidate[i] = x.clamp(lo, hi);
                }
                Var::Turn {
                    body,
                    q: i,
                    k: axis,
                } => {
                    gather(&mut turns, &mut rest_turns, body, i, axis, dx);
                }
                Var::Shift {
                    body,
                    q: i,
                    k: axis,
                } => {
                    gather(&mut shifts, &mut rest_shifts, body, i, axis, dx);
                }
            }
        }
        for (w, body, i) in turns.iter().chain(&rest_turns).copied() {
            if body == usize::MAX {
                continue;
            }
            let r = self.turn_frame(body);
            // The turn in the joint frame's axes, applied before the quaternion's own rotation.
            let d = transpose_apply(&r, w);
            let quat = [q[i], q[i + 1], q[i + 2], q[i + 3]];
            let turned = normalize4(quat_mul(quat_exp(d), quat));
            self.candidate[i..i + 4].copy_from_slice(&turned);
        }
        for (v, body, i) in shifts.iter().chain(&rest_shifts).copied() {
            if body == usize::MAX {
                continue;
            }
            let r = self.turn_frame(body);
            let d = transpose_apply(&r, v);
            for k in 0..3 {
                self.candidate[i + k] = q[i + k] + d[k];
            }
        }
        wrap(&mut self.candidate, &self.vars);
        newly_held
    }

    /// The world rotation of the joint frame of quaternion joint `body` at the current iterate.
    fn turn_frame(&self, body: usize) -> [[f64; 3]; 3] {
        self.turn_bodies
            .iter()
            .position(|&b| b == body)
            .map_or(Transform::IDENTITY.r, |k| self.turns[k])
    }

    /// Evaluates `q`: the weighted error, the weighted Jacobian of the moving variables (into the
    /// candidate buffers when `candidate`) and the residuals. Returns `E = ½ eᵀ W e`.
    ///
    /// `data.world_from_body` then holds the frames of `q` — for a candidate too, which is why a
    /// refused candidate is followed by a fresh evaluation of the current iterate only when its
    /// frames are needed (the quaternion steps read them).
    fn evaluate(
        &mut self,
        q: &[f64],
        targets: &[Transform],
        jacobian: bool,
        candidate: bool,
    ) -> f64 {
        let rows = 6 * self.goals.len();
        let (e, j, residual) = if candidate {
            (
                &mut self.candidate_e,
                &mut self.candidate_j,
                &mut self.candidate_residual,
            )
        } else {
            (&mut self.e, &mut self.j, &mut self.residual)
        };
        residual.clear();
        let chain = self.chain;
        let mut cost = 0.0;
        for (g, (prepared, target)) in self.goals.iter().zip(targets).enumerate() {
            let goal = &prepared.goal;
            // The link's pose (and the frames its Jacobian reads).
            let pose = if self.one_link {
                match forward_kinematics_to(chain, &mut self.data, q, goal.link) {
                    Ok(p) => p,
                    Err(_) => return f64::INFINITY,
                }
            } else if g == 0 {
                match forward_kinematics(chain, &mut self.data, q) {
                    Ok(p) => p.world_from_link(goal.link),
                    Err(_) => return f64::INFINITY,
                }
            } else {
                stored_link_pose(chain, &self.data, goal.link)
            };
            let p = add3(pose.p, pose.apply(goal.point));
            let frame = if goal.point == [0.0; 3] {
                JacobianFrame::World
            } else {
                JacobianFrame::Point(goal.point)
            };
            if jacobian {
                stored_jacobian(
                    chain,
                    &self.data.world_from_body,
                    goal.link,
                    frame,
                    &mut self.full,
                );
            }
            // The pose (and Jacobian) in the goal's reference frame.
            let (p, r) = match goal.base {
                None => (p, pose.r),
                Some(base) => {
                    let b = stored_link_pose(chain, &self.data, base);
                    let offset = sub3(p, b.p);
                    if jacobian {
                        stored_jacobian(
                            chain,
                            &self.data.world_from_body,
                            base,
                            JacobianFrame::World,
                            &mut self.base_j,
                        );
                        relative_jacobian(&mut self.full, &self.base_j, offset, &b.r);
                    }
                    (transpose_apply(&b.r, offset), mul_tr(&b.r, &pose.r))
                }
            };
            // Error: position gap and rotation vector of R* Rᵀ, in the reference axes.
            let dp = sub3(target.p, p);
            let dr = rotation_log(&mul_rt(&target.r, &r));
            let mut err = [dp[0], dp[1], dp[2], dr[0], dr[1], dr[2]];
            if prepared.turn {
                let (a, b) = (
                    transpose_apply(&target.r, [err[0], err[1], err[2]]),
                    transpose_apply(&target.r, [err[3], err[4], err[5]]),
                );
                err = [a[0], a[1], a[2], b[0], b[1], b[2]];
            }
            let mut sq = [0.0; 2];
            for (k, x) in err.iter().enumerate() {
                if prepared.counted[k] {
                    sq[k / 3] += x * x;
                }
            }
            residual.push([sq[0].sqrt(), sq[1].sqrt()]);
            let base_row = 6 * g;
            for k in 0..6 {
                let x = err[k] * prepared.sqrt_w[k];
                e[base_row + k] = x;
                cost += 0.5 * x * x;
            }
            if jacobian {
                // The rotation error's rate: `φ̇ = −J_r⁻¹(φ) ω` for `exp(φ^) = R* Rᵀ` (`J_r` the
                // right Jacobian of SO(3)), so that the model is exact to first order however
                // large the error, not only near the target.
                let jr_inv = right_jacobian_inverse(dr);
                for (c, &col) in self.columns.iter().enumerate() {
                    let mut column: [f64; 6] = self.full[6 * col..6 * col + 6]
                        .try_into()
                        .unwrap_or([0.0; 6]);
                    let w = mat3_apply(&jr_inv, [column[3], column[4], column[5]]);
                    column[3..].copy_from_slice(&w);
                    if prepared.turn {
                        let (a, b) = (
                            transpose_apply(&target.r, [column[0], column[1], column[2]]),
                            transpose_apply(&target.r, [column[3], column[4], column[5]]),
                        );
                        column = [a[0], a[1], a[2], b[0], b[1], b[2]];
                    }
                    let out = &mut j[c * rows + base_row..c * rows + base_row + 6];
                    for k in 0..6 {
                        out[k] = column[k] * prepared.sqrt_w[k];
                    }
                }
            }
        }
        // The joint frames of the quaternion joints (parent body's frame, then `pre`): their
        // parents are on a goal's path, so evaluated.
        let turns = if candidate {
            &mut self.candidate_turns
        } else {
            &mut self.turns
        };
        for (out, &body) in turns.iter_mut().zip(&self.turn_bodies) {
            let b = &chain.bodies[body];
            *out = match b.parent {
                Some(p) => (transform(&self.data.world_from_body[p]) * b.pre_frame).r,
                None => b.pre_frame.r,
            };
        }
        cost
    }
}

/// `a` ← the Jacobian of the relative motion: with `J_b` the base's (world axes, at its origin)
/// and `r` the point's offset from the base origin, `[v; ω]_rel = blockdiag(R_bᵀ, R_bᵀ) [v − v_b
/// − ω_b × r; ω − ω_b]` column by column (the time derivative of `R_bᵀ (p − p_b)` and the
/// relative angular velocity, eqs. 2.41 and 2.120).
fn relative_jacobian(a: &mut [f64], base: &[f64], r: [f64; 3], rb: &[[f64; 3]; 3]) {
    for (c, b) in a.chunks_exact_mut(6).zip(base.chunks_exact(6)) {
        let wb = [b[3], b[4], b[5]];
        let v = sub3(sub3([c[0], c[1], c[2]], [b[0], b[1], b[2]]), cross3(wb, r));
        let w = sub3([c[3], c[4], c[5]], wb);
        let (v, w) = (transpose_apply(rb, v), transpose_apply(rb, w));
        c.copy_from_slice(&[v[0], v[1], v[2], w[0], w[1], w[2]]);
    }
}

/// Collects a quaternion joint's step components by body: the common few in a fixed array, any
/// more in `rest`.
fn gather(
    fixed: &mut [([f64; 3], usize, usize); 4],
    rest: &mut Vec<([f64; 3], usize, usize)>,
    body: usize,
    q: usize,
    k: usize,
    dx: f64,
) {
    if let Some(slot) = fixed.iter_mut().find(|s| s.1 == body) {
        slot.0[k] = dx;
    } else if let Some(slot) = fixed.iter_mut().find(|s| s.1 == usize::MAX) {
        *slot = ([0.0; 3], body, q);
        slot.0[k] = dx;
    } else if let Some(slot) = rest.iter_mut().find(|s| s.1 == body) {
        slot.0[k] = dx;
    } else {
        let mut v = [0.0; 3];
        v[k] = dx;
        rest.push((v, body, q));
    }
}

/// Solves `A x = b` in place (`b` ← `x`) for a symmetric positive definite `A` of order `m`,
/// given by its lower triangle, row-major (overwritten by its Cholesky factor). False when `A`
/// is not positive definite in rounding. The systems here are of order 6 to a few dozen, for
/// which a general library's dynamic-size decomposition spends more on its generality than on
/// the arithmetic (measured: a third of a solve's time with `nalgebra`'s).
fn cholesky_solve(a: &mut [f64], m: usize, b: &mut [f64]) -> bool {
    for i in 0..m {
        for j in 0..=i {
            let mut sum = a[i * m + j];
            for k in 0..j {
                sum -= a[i * m + k] * a[j * m + k];
            }
            if i == j {
                if sum.is_nan() || sum <= 0.0 {
                    return false;
                }
                a[i * m + i] = sum.sqrt();
            } else {
                a[i * m + j] = sum / a[j * m + j];
            }
        }
    }
    // L y = b, then Lᵀ x = y.
    for i in 0..m {
        let mut sum = b[i];
        for k in 0..i {
            sum -= a[i * m + k] * b[k];
        }
        b[i] = sum / a[i * m + i];
    }
    for i in (0..m).rev() {
        let mut sum = b[i];
        for k in i + 1..m {
            sum -= a[k * m + i] * b[k];
        }
        b[i] = sum / a[i * m + i];
    }
    true
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `Rᵀ u` for a rotation stored by columns.
fn transpose_apply(r: &[[f64; 3]; 3], u: [f64; 3]) -> [f64; 3] {
    [
        r[0][0] * u[0] + r[0][1] * u[1] + r[0][2] * u[2],
        r[1][0] * u[0] + r[1][1] * u[1] + r[1][2] * u[2],
        r[2][0] * u[0] + r[2][1] * u[1] + r[2][2] * u[2],
    ]
}

/// `Aᵀ B` for rotations stored by columns: column `j` is `Aᵀ b_j`.
fn mul_tr(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    [
        transpose_apply(a, b[0]),
        transpose_apply(a, b[1]),
        transpose_apply(a, b[2]),
    ]
}

/// A link's world pose from the stored body frames of the last evaluation.
fn stored_link_pose(chain: &Chain, data: &Data, link: LinkId) -> Transform {
    let l = chain.carrier(link);
    match l.body {
        Some(b) => {
            crate::eval::kernel::pose_columns::link_pose(&data.world_from_body[b], &l.offset)
        }
        None => l.offset.to_transform(),
    }
}

/// `A Bᵀ` for rotations stored by columns (entry `(i, j)` is `Σ_k A_ik B_jk`), by columns.
fn mul_rt(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (j, column) in m.iter_mut().enumerate() {
        for (i, x) in column.iter_mut().enumerate() {
            *x = a[0][i] * b[0][j] + a[1][i] * b[1][j] + a[2][i] * b[2][j];
        }
    }
    m
}

/// The rotation vector `θ n` of a rotation matrix (stored by columns): `log` of SO(3), with
/// `θ ∈ [0, π]`; near `θ = π`, the axis from the diagonal (where `R − Rᵀ` loses it).
pub(crate) fn rotation_log(r: &[[f64; 3]; 3]) -> [f64; 3] {
    let at = |i: usize, j: usize| r[j][i];
    let w = [
        at(2, 1) - at(1, 2),
        at(0, 2) - at(2, 0),
        at(1, 0) - at(0, 1),
    ];
    let trace = at(0, 0) + at(1, 1) + at(2, 2);
    let c = (0.5 * (trace - 1.0)).clamp(-1.0, 1.0);
    let s = 0.5 * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    let theta = s.atan2(c);
    if c > -0.99 {
        // θ / (2 sin θ), its series where sin θ vanishes with θ.
        let f = if theta < 1e-4 {
            0.5 + theta * theta / 12.0
        } else {
            0.5 * theta / s
        };
        return w.map(|x| f * x);
    }
    // n nᵀ = (R + Rᵀ)/2 − c I over (1 − c): the largest diagonal entry gives a safe component.
    let k = (0..3)
        .max_by(|&a, &b| at(a, a).total_cmp(&at(b, b)))
        .unwrap_or(0);
    let nk = ((at(k, k) - c) / (1.0 - c)).max(0.0).sqrt();
    let mut n = [0.0; 3];
    for (i, x) in n.iter_mut().enumerate() {
        *x = if i == k {
            nk
        } else {
            0.5 * (at(i, k) + at(k, i)) / ((1.0 - c) * nk)
        };
    }
    // The sign that makes sin θ n agree with (R − Rᵀ)/2.
    if n[0] * w[0] + n[1] * w[1] + n[2] * w[2] < 0.0 {
        n = n.map(|x| -x);
    }
    let norm = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|x| theta * x / norm)
}

/// `J_r⁻¹(φ) = I + ½ φ^ + (1/θ² − (1 + cos θ)/(2 θ sin θ)) φ^ φ^`, θ = |φ|, rows by rows.
fn right_jacobian_inverse(phi: [f64; 3]) -> [[f64; 3]; 3] {
    let t2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2];
    let theta = t2.sqrt();
    let c = if theta < 1e-4 {
        1.0 / 12.0 + t2 / 720.0
    } else {
        let (s, co) = theta.sin_cos();
        1.0 / t2 - (1.0 + co) / (2.0 * theta * s)
    };
    let [x, y, z] = phi;
    // φ^ φ^ = φ φᵀ − θ² I.
    let mut m = [
        [1.0, -0.5 * z, 0.5 * y],
        [0.5 * z, 1.0, -0.5 * x],
        [-0.5 * y, 0.5 * x, 1.0],
    ];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, e) in row.iter_mut().enumerate() {
            *e += c * (phi[i] * phi[j] - if i == j { t2 } else { 0.0 });
        }
    }
    m
}

/// `M u` for a matrix stored by rows.
fn mat3_apply(m: &[[f64; 3]; 3], u: [f64; 3]) -> [f64; 3] {
    m.map(|row| row[0] * u[0] + row[1] * u[1] + row[2] * u[2])
}

/// The unit quaternion (w, x, y, z) of the rotation vector `d`.
fn quat_exp(d: [f64; 3]) -> [f64; 4] {
    let angle = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let (s, c) = (0.5 * angle).sin_cos();
    let f = if angle < 1e-8 { 0.5 } else { s / angle };
    [c, f * d[0], f * d[1], f * d[2]]
}

/// Hamilton product `a ⊗ b` (w, x, y, z): the rotation `b`, then `a`.
fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

fn normalize4(q: [f64; 4]) -> [f64; 4] {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    q.map(|x| x / n)
}

/// Unbounded rotational entries into `(−π, π]`.
fn wrap(q: &mut [f64], vars: &[Var]) {
    for v in vars {
        if let Var::Scalar {
            q: i, wrap: true, ..
        } = *v
        {
            let x = q[i];
            if x > PI || x <= -PI {
                let y = x - (2.0 * PI) * ((x + PI) / (2.0 * PI)).floor();
                // y in [−π, π): move −π to π.
                q[i] = if y <= -PI { y + 2.0 * PI } else { y };
            }
        }
    }
}

fn distance(metric: Distance, q: &[f64], seed: &[f64], vars: &[Var]) -> f64 {
    let mut entries = Vec::with_capacity(vars.len());
    for v in vars {
        match *v {
            Var::Scalar { q: i, .. } => entries.push(i),
            Var::Shift { q: i, k, .. } => entries.push(i + k),
            Var::Turn { q: i, k, .. } => {
                entries.push(i + k + 1);
                if k == 0 {
                    entries.push(i);
                }
            }
        }
    }
    let d = entries.iter().map(|&i| (q[i] - seed[i]).abs());
    match metric {
        Distance::L2 => d.map(|x| x * x).sum::<f64>().sqrt(),
        Distance::LInf => d.fold(0.0, f64::max),
    }
}

fn check_options(o: &Options) -> Result<(), IkError> {
    let bad = |option, what: String| Err(IkError::BadOption { option, what });
    for (name, x) in [
        ("position_tolerance", o.position_tolerance),
        ("rotation_tolerance", o.rotation_tolerance),
    ] {
        if !(x.is_finite() && x > 0.0) {
            return bad(name, format!("{x} (a tolerance is finite and > 0)"));
        }
    }
    if o.iterations_per_attempt == 0 {
        return bad("iterations_per_attempt", "0 (at least 1)".into());
    }
    if o.max_attempts == 0 {
        return bad("max_attempts", "0 (at least 1)".into());
    }
    Ok(())
}

/// A target must be a rigid transform (finite, orthonormal within
/// [`Transform::RIGID_TOLERANCE`], not a reflection).
fn check_target(t: &Transform) -> Result<(), NotRigid> {
    Transform::try_from_homogeneous(&t.to_homogeneous()).map(|_| ())
}

/// The configuration [`Start`] names.
fn start_of(chain: &Chain, start: Start) -> Vec<f64> {
    let mut q = chain.neutral();
    if start == Start::MidLimits {
        for (x, (lo, hi)) in q.iter_mut().zip(chain.admitted_ranges()) {
            if lo.is_finite() && hi.is_finite() {
                *x = between(lo, hi, 0.5);
            }
        }
    }
    q
}

/// The variables the goals depend on (the joints on their links' and base links' paths), not
/// locked, with their column in the full Jacobian, in `q̇` order.
fn variables(chain: &Chain, goals: &[Prepared], locked: &[JointId]) -> Vec<(Var, usize)> {
    let dof = chain.dof();
    let mut used = vec![false; dof];
    for g in goals {
        for link in std::iter::once(g.goal.link).chain(g.goal.base) {
            let mut body = chain.carrier(link).body;
            while let Some(b) = body {
                let bd = &chain.bodies[b];
                if bd.floating {
                    used[..6].fill(true);
                } else if let Some(ball) = bd.ball {
                    let n = if ball.free { 6 } else { 3 };
                    used[ball.v..ball.v + n].fill(true);
                } else {
                    for rate in [bd.theta_rate, bd.d_rate] {
                        if rate.scale != 0.0 {
                            used[rate.index] = true;
                        }
                    }
                }
                body = bd.parent;
            }
        }
    }
    let ranges = chain.admitted_ranges();
    let mut vars = Vec::new();
    for (id, joint) in chain.joints().iter().enumerate() {
        let (Some(q), Some(v)) = (joint.q_index(), joint.v_index()) else {
            continue;
        };
        if locked.iter().any(|l| l.0 == id) {
            continue;
        }
        let body_of = || {
            chain
                .bodies
                .iter()
                .position(|b| (b.floating && q == 0) || b.ball.is_some_and(|ball| ball.q == q))
                .unwrap_or(0)
        };
        match joint.kind() {
            JointKind::Floating => {
                let body = body_of();
                for k in 0..3 {
                    vars.push((Var::Shift { body, q, k }, v + k));
                }
                for k in 0..3 {
                    vars.push((Var::Turn { body, q: q + 3, k }, v + 3 + k));
                }
            }
            JointKind::Ball => {
                let body = body_of();
                for k in 0..3 {
                    vars.push((Var::Turn { body, q, k }, v + k));
                }
            }
            kind => {
                for k in 0..kind.dof() {
                    let (lo, hi) = ranges[q + k];
                    let rotational = matches!(kind, JointKind::Revolute | JointKind::Continuous)
                        || (kind == JointKind::Cylindrical && k == 0);
                    let wrap = rotational && !lo.is_finite() && !hi.is_finite();
                    let around = rotational && (hi - lo).is_finite() && hi - lo >= TAU;
                    vars.push((
                        Var::Scalar {
                            q: q + k,
                            lo,
                            hi,
                            wrap,
                            around,
                        },
                        v + k,
                    ));
                }
            }
        }
    }
    vars.retain(|(_, v)| used[*v]);
    vars
}
