//! Evaluation: the [`Data`](data::Data) workspace, the single-configuration and batch kernels,
//! arithmetic dispatch, `sin`/`cos`, and the public evaluation functions.
//!
//! This layer may use [`crate::model`] and [`crate::orientation`], never [`crate::io`] or the
//! command line.

pub(crate) mod arith;
pub mod batch;
pub mod chain;
pub mod data;
pub mod error;
pub mod jacobian;
pub(crate) mod kernel;
pub mod kinematics;
pub(crate) mod lanes;
pub(crate) mod layout;
pub(crate) mod padded;
pub mod results;
pub(crate) mod trig;
