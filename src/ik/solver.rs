//! The solver: the variables a problem moves, the evaluation of the error and its Jacobian,
//! and the damped, bounded steps with restarts.

use crate::eval::jacobian::stored_jacobian;
use crate::eval::layout::chain::Chain;
use crate::eval::layout::stored::transform;
use crate::eval::sampling::{SplitMix, between, range};
use crate::eval::{Data, JacobianFrame, LimitPolicy, Poses};
use crate::eval::{check_q, forward_kinematics, forward_kinematics_to};
use crate::model::transform::{Transform, add3, cross3, sub3};
use std::f64::consts::TAU;
use std::time::Instant;

use super::goal::{
    Goal, IkError, Options, Prepared, Solution, check_options, check_target, start_of,
};
use super::math::{
    cholesky_solve, dot, mat3_apply, mul_rt, mul_tr, normalize4, quat_exp, quat_mul,
    right_jacobian_inverse, rotation_log, step6, transpose_apply,
};
use super::variables::{Var, distance, variables, wrap};

/// The best attempt so far: its configuration, its score (the distance to the seed of a
/// solution under [`Options::closest`], else the squared residual), residuals and success.
pub(super) type Best = (Vec<f64>, f64, Vec<[f64; 2]>, bool);

/// A reusable solver for a chain and a list of goals: it holds the buffers, so a solve allocates
/// nothing but its result.
pub struct Solver<'c> {
    pub(super) chain: &'c Chain,
    pub(super) goals: Vec<Prepared>,
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
    pub(super) start: Vec<f64>,
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
pub(super) const LAMBDA_FLOOR: f64 = 1e-12;

/// Accepted steps in a row that each lower `E` by less than 1 % end an attempt: the search is
/// at a local minimum (most often against a joint limit) and a restart does better. (Fewer
/// end attempts sooner — 3 takes the Panda's 2 000 random targets from 42.8 to 36.8 iterations
/// a solve — but leave a failure's answer short of its least-squares minimum.)
pub(super) const STALL: usize = 6;

/// Every other restart draws each joint uniformly from the middle part of its range, this
/// fraction of it (starts near a limit end at that limit more often); the others from the whole
/// range (targets whose answers lie at the limits need those). Panda, 2 000 random targets:
/// always the whole range 42.8 iterations a solve, always the middle half 35.4.
pub(super) const RESTART_SPAN: f64 = 0.5;

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
            check_target(t).map_err(|why| IkError::Target { index, why })?;
        }
        match q0 {
            Some(q) => {
                check_q(self.chain, q, LimitPolicy::Enforce).map_err(IkError::Seed)?;
                self.start.copy_from_slice(q);
            }
            None => self.start = start_of(self.chain, self.options.start),
        }
        Ok(self.run(targets))
    }

    /// The search, on checked targets and seed (`self.start`).
    pub(super) fn run(&mut self, targets: &[Transform]) -> Solution {
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
                self.restart(&mut q, &mut rng, attempts % 2 == 1);
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

    /// A random configuration within the limits for the moving scalar entries (in the middle
    /// [`RESTART_SPAN`] of each range if `middle`); the others (locked joints, floating and ball joints) keep
    /// the start's values.
    fn restart(&self, q: &mut [f64], rng: &mut SplitMix, middle: bool) {
        let span = if middle { RESTART_SPAN } else { 1.0 };
        q.copy_from_slice(&self.start);
        for v in &self.vars {
            if let Var::Scalar { q: i, lo, hi, .. } = *v {
                let (a, b) = range(lo, hi);
                let m = 0.5 * (a + b);
                let (a, b) = (m + span * (a - m), m + span * (b - m));
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
        step6(&self.j, &self.held, lambda, &self.e, &mut self.step)
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
                Poses {
                    chain,
                    data: &self.data,
                }
                .world_from_link(goal.link)
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
                    let b = Poses {
                        chain,
                        data: &self.data,
                    }
                    .world_from_link(base);
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
pub(super) fn relative_jacobian(a: &mut [f64], base: &[f64], r: [f64; 3], rb: &[[f64; 3]; 3]) {
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
pub(super) fn gather(
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
