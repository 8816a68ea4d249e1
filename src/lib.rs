//! Forward kinematics of robot chains and trees: every link's pose (eqs. 2.109, 2.119, 2.129 of
//! Shabana, *Dynamics of Multibody Systems*, ch. 2), and on request its velocity and
//! acceleration (eqs. 2.120–2.127), from a Denavit–Hartenberg table or a URDF file.
//!
//! A [`Chain`] is the immutable, validated robot (load it with [`Chain::from_file`]); each
//! thread evaluates it into its own [`Data`], sized once, so that evaluations allocate nothing:
//!
//! ```
//! use kinechain::{Chain, Data, forward_kinematics};
//!
//! let chain = Chain::from_file(concat!(env!("CARGO_MANIFEST_DIR"), "/robots/ur5.yaml"))?;
//! let mut data = Data::new(&chain);
//! let poses = forward_kinematics(&chain, &mut data, &chain.neutral())?;
//! let tool = poses.world_from_link(chain.link_id("tool0")?); // link to world coordinates
//! assert!((tool.translation().x + 0.81725).abs() < 1e-12);
//! # Ok::<(), kinechain::Error>(())
//! ```
//!
//! | to compute | call |
//! |---|---|
//! | every link's pose | [`forward_kinematics`] |
//! | poses and velocities (ω, v) | [`forward_velocities`] |
//! | poses, velocities and accelerations (α, classical a) | [`forward_accelerations`] |
//! | one link's pose, evaluating only the joints before it | [`forward_kinematics_to`] |
//! | poses after a few joints moved | [`forward_kinematics_incremental`] |
//! | a link's geometric Jacobian and its derivative | [`Poses::jacobian`], [`Velocities::jacobian_dot`] |
//! | many configurations, on one core or all | [`eval::batch`] |
//! | orientation coordinates (Euler parameters, angles, Rodriguez parameters) | [`orientation`] |
//!
//! Units are radians, metres and seconds; every quantity is in the world (base) frame; `q`
//! lists the independent joints depth-first from the root, as `kinechain info` prints them.
//! Joint values outside the limits, non-finite values and wrong lengths are a [`StateError`]
//! naming the joint; every error converts into [`Error`], so `?` works throughout.
//!
//! The repository's `docs/` has the command line, the file formats, the conventions and
//! equations, and the accuracy and performance measurements.
#![warn(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

#[cfg(feature = "cli")]
#[doc(hidden)]
pub mod cli;
pub mod error;
pub mod eval;
pub mod ik;
pub mod io;
#[doc(hidden)]
pub mod measure;
pub mod model;
pub mod orientation;
#[cfg(feature = "reference")]
#[doc(hidden)]
pub mod reference;
pub mod regression;

#[doc(hidden)]
pub use eval::{Isa, force_isa, force_narrow_trig, isa, narrow_trig};
pub use nalgebra;

pub use error::{Error, FieldProblem, LoadError, LoadErrorKind, ModelError, NameError, StateError};
pub use eval::Chain;
pub use eval::{
    Accelerations, LinkAcceleration, LinkVelocity, Poses, Velocities, check_q,
    forward_accelerations, forward_kinematics, forward_kinematics_incremental,
    forward_kinematics_to, forward_velocities,
};
pub use eval::{Data, LimitPolicy};
pub use eval::{JacobianFrame, QUATERNION_TOLERANCE};
pub use model::builder::{ChainBuilder, JointSpec, MimicSpec};
pub use model::chain::{Joint, JointId, JointScrew, Link, LinkId, Mimic, Model};
pub use model::joint::{JointKind, Limits};
pub use model::transform::{NotRigid, Transform};

/// The Rust examples of the README and of `docs/library.md`, compiled and run as doc tests.
#[cfg(doctest)]
mod documentation {
    #[doc = include_str!("../README.md")]
    struct Readme;
    #[doc = include_str!("../docs/library.md")]
    struct Library;
}
