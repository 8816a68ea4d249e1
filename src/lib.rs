#![doc = include_str!("../README.md")]
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
pub mod io;
#[doc(hidden)]
pub mod measure;
pub mod model;
pub mod orientation;
#[cfg(feature = "reference")]
pub mod reference;

#[doc(hidden)]
pub use eval::arith::{Isa, force_isa, force_narrow_trig, isa, narrow_trig};
pub use nalgebra;

pub use error::{Error, FieldProblem, LoadError, LoadErrorKind, ModelError, NameError, StateError};
pub use eval::chain::Chain;
pub use eval::data::{Data, LimitPolicy};
pub use eval::kinematics::{
    Accelerations, LinkAcceleration, LinkVelocity, Poses, Velocities, check_q,
    forward_accelerations, forward_kinematics, forward_kinematics_incremental,
    forward_kinematics_to, forward_velocities,
};
pub use model::builder::{ChainBuilder, JointSpec, MimicSpec};
pub use model::chain::{Joint, JointId, JointScrew, Link, LinkId, Mimic, Model};
pub use model::joint::{JointKind, Limits};
pub use model::transform::{NotRigid, Transform};
