//! What a solve is asked and what it answers: goals, options, solutions and errors.

use crate::eval::error::StateError;
use crate::eval::layout::chain::Chain;
use crate::eval::sampling::between;
use crate::model::chain::{JointId, LinkId};
use crate::model::transform::{NotRigid, Transform};
use std::time::Duration;

/// What to place: a link (or a point fixed on it), which components of its pose count, and the
/// frame its target is given in.
#[derive(Clone, Debug, PartialEq)]
pub struct Goal {
    pub(super) link: LinkId,
    pub(super) point: [f64; 3],
    pub(super) base: Option<LinkId>,
    pub(super) weights: [f64; 6],
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
    #[error("target {index}: {why}")]
    Target {
        /// Index of the target.
        index: usize,
        /// Why.
        why: NotRigid,
    },
    /// The seed cannot be evaluated: wrong length, non-finite, or outside a joint's limits.
    #[error("seed q0: {0}")]
    Seed(StateError),
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
    #[error("row {row}: {error}")]
    Row {
        /// The row.
        row: usize,
        /// Why.
        error: Box<IkError>,
    },
    /// The batch was stopped by its [`Interrupt`](crate::eval::batch::Interrupt).
    #[error("the solve was interrupted")]
    Interrupted,
}

pub(super) fn check_options(o: &Options) -> Result<(), IkError> {
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
pub(super) fn check_target(t: &Transform) -> Result<(), NotRigid> {
    Transform::try_from_homogeneous(&t.to_homogeneous()).map(|_| ())
}

/// The configuration [`Start`] names.
pub(super) fn start_of(chain: &Chain, start: Start) -> Vec<f64> {
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

/// A goal with what the evaluation needs of it.
#[derive(Clone, Debug)]
pub(super) struct Prepared {
    pub(super) goal: Goal,
    /// Whether the weights differ within the position or the rotation half, so that the error
    /// must be turned into the target's axes before weighting.
    pub(super) turn: bool,
    pub(super) sqrt_w: [f64; 6],
    pub(super) counted: [bool; 6],
}
