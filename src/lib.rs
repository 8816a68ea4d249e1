#![doc = include_str!("../README.md")]
#![warn(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

mod arith;
pub mod batch;
pub mod chain;
#[cfg(feature = "cli")]
pub mod cli;
pub mod convert;
pub mod data;
pub mod error;
pub mod input;
pub mod io;
pub mod joint;
mod kernel;
pub mod kinematics;
pub mod measure;
mod padded;
#[cfg(feature = "reference")]
pub mod reference;
pub mod render;
pub mod rotation;
pub mod transform;
mod trig;
mod xml;

pub use arith::{Isa, force_isa, force_narrow_trig, isa, narrow_trig};
pub use nalgebra;

pub use chain::{
    Chain, ChainBuilder, Joint, JointId, JointScrew, JointSpec, Link, LinkId, Mimic, MimicSpec,
};
pub use data::{Data, LimitPolicy};
pub use error::{FieldProblem, LoadError, LoadErrorKind, ModelError, NameError, StateError};
pub use joint::{JointKind, Limits};
pub use kinematics::{
    Accelerations, LinkAcceleration, LinkVelocity, Poses, Velocities, check_q,
    forward_accelerations, forward_kinematics, forward_kinematics_incremental,
    forward_kinematics_to, forward_velocities,
};
pub use transform::{NotRigid, Transform};
