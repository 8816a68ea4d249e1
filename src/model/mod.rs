//! The immutable kinematic model: joints, links, the tree they form, placements, limits, names,
//! and the builder that validates them.
//!
//! This layer knows nothing of evaluation kernels, files or the command line: it may use
//! [`crate::orientation`] and nothing else of the crate.

pub mod builder;
pub mod chain;
pub mod error;
pub mod joint;
pub mod transform;
pub(crate) mod validate;
