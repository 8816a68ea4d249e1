//! Many configurations at once: link poses of `n` configurations of one chain, eight per pass
//! through the kernels (one configuration per SIMD lane), on one thread or several.
//!
//! Configurations are given row-major (`qs[i * dof + j]` is joint entry `j` of configuration
//! `i`). Results are the same as [`forward_kinematics`](crate::forward_kinematics) gives for each
//! configuration, to the last bit on the same instruction set.

#[macro_use]
mod macros;
pub mod arrays;
mod blocks;
mod claims;
mod data;
mod fold;
mod jacobians;
mod lanes32;
mod matrices;
mod poses;
mod rates;
pub mod single_precision;
mod threads;

pub use arrays::{
    ArrayError, Interrupt, LinkArrays, LinkSelection, Motion, Overflow, Uninterrupted, Workers,
    write_jacobian_batch, write_link_batch,
};
pub use data::{BatchData, BatchError};
pub use fold::{fold_block_len, forward_kinematics_batch_fold, forward_kinematics_batch_fold_par};
pub use jacobians::{
    jacobian_batch, jacobian_batch_par, jacobian_dot_batch, jacobian_dot_batch_par,
};
pub use poses::{
    BatchLinkPoses, BatchPoses, forward_kinematics_batch, forward_kinematics_batch_par,
    forward_kinematics_batch_to, forward_kinematics_batch_to_par,
};
pub use rates::{
    BatchAccelerations, BatchVelocities, forward_accelerations_batch,
    forward_accelerations_batch_par, forward_velocities_batch, forward_velocities_batch_par,
};
pub use threads::PARALLEL_WORK;
