//! Evaluation: the compiled [`Chain`], the single-configuration and batch evaluation functions,
//! and what they return. This file is the layer's public face; the rooms behind it, bottom to top:
//!
//! | module | holds | may use |
//! |---|---|---|
//! | `error` | [`StateError`] | nothing of the crate |
//! | `simd` | number traits, lane and vector types, `sin`/`cos`, ISA detection and dispatch | nothing of the crate |
//! | `layout` | the compiled chain: bodies, stored frames, limit tables, [`Chain`] | `simd`, `error`, [`crate::model`] |
//! | `kernel` | one body's pose and rate steps, on lanes and on padded columns | `simd`, `layout` |
//! | `compile` | [`crate::ChainBuilder`] → [`Chain`] | `layout`, `kernel` |
//! | `checks`, `link_rates`, `jacobian`, `layouts` | input checks, link and point rates, Jacobians, other libraries' joint vectors | the above |
//! | `single` | [`forward_kinematics`] and its siblings, [`Data`], [`Poses`] | the above |
//! | [`batch`] | many configurations at once, on one thread or several | the above, never `single` |
//!
//! This layer may use [`crate::model`] and [`crate::orientation`], never [`crate::io`] or the
//! command line. The order is checked by `tests/it/layering.rs`.

pub mod batch;
pub(crate) mod checks;
pub(crate) mod compile;
pub mod error;
pub(crate) mod jacobian;
pub(crate) mod kernel;
pub(crate) mod layout;
pub mod layouts;
pub(crate) mod link_rates;
pub(crate) mod sampling;
pub(crate) mod simd;
pub(crate) mod single;

pub use checks::{LimitPolicy, check_q};
pub use error::StateError;
pub use jacobian::JacobianFrame;
pub use kernel::floating::QUATERNION_TOLERANCE;
pub use layout::chain::Chain;
pub use layouts::{JointState, Layout};
pub use link_rates::{
    AccelerationParts, LinkAcceleration, LinkVelocity, PointMotion, PointVelocity,
};
pub use simd::isa::{Isa, force_isa, force_narrow_trig, isa, narrow_trig};
pub use single::data::Data;
pub use single::kinematics::{
    forward_accelerations, forward_kinematics, forward_kinematics_incremental,
    forward_kinematics_to, forward_velocities,
};
pub use single::results::{Accelerations, Poses, Velocities};
