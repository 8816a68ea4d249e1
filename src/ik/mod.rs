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

mod batch;
mod goal;
mod math;
mod solver;
mod variables;

pub use batch::{BatchOut, solve_batch};
pub use goal::{Distance, Goal, IkError, Options, Solution, Start};
pub use solver::Solver;
