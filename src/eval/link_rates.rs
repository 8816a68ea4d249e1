//! The velocity and acceleration of a link or of a point on it, from those of the body that
//! carries it (eqs. 2.55 and 2.75), and the public types that hold them.

use crate::eval::layout::body::Placement;
use crate::model::transform::{Transform, add3, cross3};
use nalgebra::Vector3;

/// Angular velocity and linear velocity of a link-frame origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkVelocity {
    /// Angular velocity ω (rad/s).
    pub omega: Vector3<f64>,
    /// Velocity of the link-frame origin (m/s).
    pub v: Vector3<f64>,
}

/// Angular acceleration and classical linear acceleration of a link-frame origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkAcceleration {
    /// Angular acceleration α = dω/dt (rad/s²).
    pub alpha: Vector3<f64>,
    /// Classical acceleration of the link-frame origin, d²p/dt² (m/s²).
    pub a: Vector3<f64>,
}

/// Position and velocity of a point of a link (world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointVelocity {
    /// Position `r = R + A ū` (eq. 2.52).
    pub position: Vector3<f64>,
    /// Velocity `ṙ = Ṙ + ω × u (+ A dū/dt for a moving point)` (eq. 2.55), `u = A ū`.
    pub velocity: Vector3<f64>,
}

/// The parts of a point's acceleration (eq. 2.75), world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelerationParts {
    /// Classical acceleration of the link-frame origin, `R̈`.
    pub origin: Vector3<f64>,
    /// Tangential part `α × u`.
    pub tangential: Vector3<f64>,
    /// Normal (centripetal) part `ω × (ω × u)`.
    pub normal: Vector3<f64>,
    /// Coriolis part `2 ω × (A dū/dt)` (zero for a point fixed on the link).
    pub coriolis: Vector3<f64>,
    /// Local part `A d²ū/dt²`, the point's acceleration relative to the link (zero for a fixed point).
    pub local: Vector3<f64>,
}

/// Position, velocity and acceleration of a point of a link (world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointMotion {
    /// Position `r = R + A ū` (eq. 2.52).
    pub position: Vector3<f64>,
    /// Velocity (eq. 2.55, plus `A dū/dt` for a moving point).
    pub velocity: Vector3<f64>,
    /// Classical acceleration, the sum of [`PointMotion::parts`] (eq. 2.75).
    pub acceleration: Vector3<f64>,
    /// The acceleration's parts.
    pub parts: AccelerationParts,
}

/// A link's offset from the frame of the body that carries it, in world axes: the body's
/// rotation applied to the offset's translation (not the difference of the two origins, which
/// would cancel and need the link's whole pose).
#[inline]
pub(crate) fn offset_in_world(body: &Transform, offset: &Placement) -> [f64; 3] {
    match offset {
        Placement::Identity => [0.0; 3],
        offset => body.apply(offset.to_transform().p),
    }
}

/// A link's ω and origin velocity from its body's ω and origin velocity `v`, the link's origin
/// `r` from the body's (eq. 2.55): `v + ω × r`.
#[inline]
pub(crate) fn link_velocity(omega: [f64; 3], v: [f64; 3], r: [f64; 3]) -> LinkVelocity {
    LinkVelocity {
        omega: omega.into(),
        v: add3(v, cross3(omega, r)).into(),
    }
}

/// A link's α and classical origin acceleration from its body's `[ω, α, a]`, the link's origin
/// `r` from the body's (eq. 2.75 for a point fixed on the body): `a + α × r + ω × (ω × r)`.
#[inline]
pub(crate) fn link_acceleration([w, al, a]: [[f64; 3]; 3], r: [f64; 3]) -> LinkAcceleration {
    LinkAcceleration {
        alpha: al.into(),
        a: add3(a, add3(cross3(al, r), cross3(w, cross3(w, r)))).into(),
    }
}
