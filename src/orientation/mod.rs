//! Orientation coordinates of Shabana ch. 2 (sec. 2.1–2.8, 2.10): the rotation matrix, angle and
//! axis of rotation, Euler parameters, Rodriguez parameters, Euler angles (z-x-z and x-y-z),
//! direction cosines and URDF roll–pitch–yaw; conversions between them, and the maps between
//! their time derivatives and the angular velocity.
//!
//! Conventions: a rotation matrix `A` maps body (local) components to global ones, `x = A x̄`;
//! `ω` is the angular velocity in global components and `ω̄ = Aᵀω` in body components. Angles
//! are in radians.
//!
//! Extraction is written to stay accurate where the textbook formulas lose digits: Euler
//! parameters by Shepperd's method (the largest of four candidates first), the angle of rotation
//! as `2 atan2(|e|, e₀)` instead of `acos((tr A − 1)/2)` (sec. 2.10, ill-conditioned near 0 and
//! π), and Euler angles through the sum and difference of the outer angles, which stay well
//! defined near gimbal lock, so that a result near (not at) a singularity still recomposes to
//! the input matrix to ~1e-15. At a singularity the representation is undefined and a
//! [`Singular`] error is returned; no function returns NaN for a finite rotation.

mod angles;
mod parameters;

pub use angles::{EulerXyz, EulerZxz, Rpy};
pub(crate) use parameters::normalize_axis;
pub use parameters::{
    AxisAngle, EulerParameters, FrameError, RATE_SINGULARITY, RodriguezParameters, Singular,
    from_direction_cosines, multiframe, rot_x, rot_y, rot_z, rotation_matrix, single_frame, skew,
};
