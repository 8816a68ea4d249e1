//! Forward kinematics along the chain: every link's pose (eqs. 2.109, 2.119, 2.129), and on
//! request its velocity and acceleration (eqs. 2.120–2.127), in one pass from the base outwards.
//!
//! Three levels, each selected by the function called, so that a pose query does no velocity
//! work and a velocity query no acceleration work:
//!
//! | function | computes |
//! |---|---|
//! | [`forward_kinematics`] | poses |
//! | [`forward_velocities`] | poses, angular velocity ω and origin velocity v |
//! | [`forward_accelerations`] | the above, angular acceleration α and classical origin acceleration a |
//!
//! plus [`forward_kinematics_to`] (only the links on the path to one link) and
//! [`forward_kinematics_incremental`] (only the joints whose `q` changed, and their descendants).
//! The poses also give each link's geometric Jacobian ([`Poses::jacobian`]).
//!
//! # Frames and kinds
//! Every quantity is expressed in the world (base) frame unless its name says `local`. `v` is the
//! velocity of the link-frame origin, `d/dt` of the pose's translation; `a` is the **classical**
//! acceleration of that origin, `d²/dt²` of the translation — not the linear part of a spatial
//! acceleration, which differs from it by `ω × v`.
//!
//! # The recursion
//! For a joint with unit axis `z` (world frame) through the joint-frame origin `p_j`, parent body
//! origin `p_P` and child origin `p`, with `u = p − p_j` and `r = p − p_P`, the child moves
//! relative to its parent with (eqs. 2.120, 2.123–2.125)
//! `v_rel = ḋ z + θ̇ z × u` and `a_rel = d̈ z + θ̈ z × u + θ̇² z × (z × u)`;
//! composing with the parent's motion as a moving frame (eqs. 2.66, 2.75):
//! ```text
//! ω = ω_P + θ̇ z
//! α = α_P + θ̈ z + ω_P × θ̇ z
//! v = v_P + ω_P × r + v_rel
//! a = a_P + α_P × r + ω_P × (ω_P × r) + 2 ω_P × v_rel + a_rel
//! ```
//! (tangential, normal, Coriolis and local terms of eq. 2.75).

use crate::eval::error::StateError;
use crate::eval::arith::{Arith, Separate, fma_dispatch};
use crate::eval::data::{Data, LimitPolicy};
use crate::eval::kernel::{self, Lanes};
use crate::eval::padded::{self, Frame4, Rates4};
use crate::eval::chain::Chain;
use crate::eval::layout::{Body, DenseLimits, Placement};
use crate::model::chain::LinkId;
use crate::model::joint::{Motion, Term};
use crate::model::transform::{Transform, add3, cross3, scale3, sub3};
use nalgebra::Vector3;
use std::ops::Range;

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

/// Poses of every link after [`forward_kinematics`] or [`forward_kinematics_incremental`].
#[derive(Clone, Copy, Debug)]
pub struct Poses<'a> {
    chain: &'a Chain,
    data: &'a Data,
}

/// Poses and velocities of every link after [`forward_velocities`].
#[derive(Clone, Copy, Debug)]
pub struct Velocities<'a> {
    poses: Poses<'a>,
}

/// Poses, velocities and accelerations of every link after [`forward_accelerations`].
#[derive(Clone, Copy, Debug)]
pub struct Accelerations<'a> {
    poses: Poses<'a>,
}

impl<'a> Poses<'a> {
    /// The chain evaluated.
    #[must_use]
    pub fn chain(&self) -> &'a Chain {
        self.chain
    }

    /// Pose of `link` in the world frame.
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    #[must_use]
    #[inline]
    pub fn world_from_link(&self, link: LinkId) -> Transform {
        let l = self.chain.carrier(link);
        match l.body {
            None => l.offset.to_transform(),
            // (Also for an identity offset: `link_pose` writes the result in whole vectors.)
            Some(b) => padded::link_pose(&self.data.world_from_body[b], &l.offset),
        }
    }

    /// A moving joint's axis in the world frame: a point on it (the joint-frame origin) and its
    /// unit direction; `None` for a fixed joint.
    ///
    /// # Panics
    /// If `joint` comes from another chain with more joints.
    #[must_use]
    pub fn joint_axis(
        &self,
        joint: crate::model::chain::JointId,
    ) -> Option<(nalgebra::Point3<f64>, Vector3<f64>)> {
        let _ = self.chain.joint(joint);
        let body = self
            .chain
            .bodies
            .iter()
            .find(|b| b.joint == joint.index())?;
        Some(self.axis_of(body))
    }

    /// A body's joint axis in the world frame: the joint-frame origin and the unit direction.
    #[inline]
    fn axis_of(&self, body: &Body) -> (nalgebra::Point3<f64>, Vector3<f64>) {
        let (origin, z) = self.axis_entries(body);
        (origin.into(), z.into())
    }

    /// [`Poses::axis_of`] on plain arrays, read from the parent's stored frame in place.
    #[inline(always)]
    fn axis_entries(&self, body: &Body) -> ([f64; 3], [f64; 3]) {
        let (parent_origin, offset, z) = self.axis_parts(body);
        (add3(parent_origin, offset), z)
    }

    /// The parts of a body's joint axis in the world frame: the origin of the frame before the
    /// joint (the parent body's, or the world's), the joint-frame origin's offset from it in
    /// world axes, and the unit direction.
    #[inline(always)]
    fn axis_parts(&self, body: &Body) -> ([f64; 3], [f64; 3], [f64; 3]) {
        match body.parent {
            Some(p) => {
                let parent = &self.data.world_from_body[p];
                let r = Transform {
                    r: [
                        padded::cut(&parent[0]),
                        padded::cut(&parent[1]),
                        padded::cut(&parent[2]),
                    ],
                    p: [0.0; 3],
                };
                (
                    padded::cut(&parent[3]),
                    r.apply(body.pre_frame.p),
                    r.apply(body.axis_in_parent),
                )
            }
            None => ([0.0; 3], body.pre_frame.p, body.axis_in_parent),
        }
    }

    /// The geometric Jacobian of `link` at the evaluated configuration: the 6 × [`Chain::dof`]
    /// matrix `J` with `[v; ω] = J q̇`, where `v` is the velocity of the link-frame origin and `ω`
    /// the link's angular velocity, both in the world frame (the same quantities as
    /// [`Velocities::velocity`], in the row order Pinocchio and KDL use: linear rows first).
    ///
    /// Column `i` is what entry `i` of `q̇` contributes (eqs. 2.120, 2.121): for a turning joint
    /// with world axis `z` through `p_j`, `[z × (p − p_j); z]`; for a sliding one `[z; 0]`; a
    /// cylindrical joint fills two columns, a mimic joint adds its multiplier times its own
    /// column to its primary's, and joints not between the base and the link leave zeros.
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    ///
    /// # Examples
    /// ```
    /// use kinechain::{Chain, Data, forward_kinematics, forward_velocities, nalgebra::DVector};
    /// let chain = Chain::from_file("robots/puma560.yaml")?;
    /// let mut data = Data::new(&chain);
    /// let (q, qd) = ([0.1, -0.5, 0.3, 0.2, 0.4, 0.0], [0.3, 0.1, -0.2, 0.5, 0.0, 1.0]);
    /// let tool = chain.link_id("tool")?;
    /// let j = forward_kinematics(&chain, &mut data, &q)?.jacobian(tool);
    /// let twist = j * DVector::from_row_slice(&qd);
    /// let v = forward_velocities(&chain, &mut data, &q, &qd)?.velocity(tool);
    /// approx::assert_relative_eq!(twist.fixed_rows::<3>(0).into_owned(), v.v, epsilon = 1e-14);
    /// approx::assert_relative_eq!(twist.fixed_rows::<3>(3).into_owned(), v.omega, epsilon = 1e-14);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn jacobian(&self, link: LinkId) -> nalgebra::Matrix6xX<f64> {
        let mut j = nalgebra::Matrix6xX::zeros(self.chain.dof());
        self.jacobian_into(link, &mut j);
        j
    }

    /// [`Poses::jacobian`] written into `j`, which is resized to 6 × [`Chain::dof`] if it has
    /// another shape (so a reused matrix allocates nothing).
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    pub fn jacobian_into(&self, link: LinkId, j: &mut nalgebra::Matrix6xX<f64>) {
        let p = self.world_from_link(link).p;
        self.path_columns(link, j, |bd| {
            let (origin, z) = self.axis_entries(bd);
            let turning = cross3(z, sub3(p, origin));
            (join(turning, z), join(z, [0.0; 3]))
        });
    }

    /// `j` (resized to 6 × [`Chain::dof`] if it has another shape) ← the sum, over the bodies
    /// from `link` back to the base, of each body's turning and sliding columns (from `columns`)
    /// times its rate terms: a column can take several terms (a mimic joint's, a cylindrical
    /// joint's two), and entries of joints off the path stay zero.
    #[inline(always)]
    fn path_columns(
        &self,
        link: LinkId,
        j: &mut nalgebra::Matrix6xX<f64>,
        mut columns: impl FnMut(&Body) -> ([f64; 6], [f64; 6]),
    ) {
        let dof = self.chain.dof();
        if j.ncols() != dof {
            *j = nalgebra::Matrix6xX::zeros(dof);
        }
        // Column-major: column i is entries 6i..6i + 6, zeroed whole, then added to entry by
        // entry.
        let entries = j.as_mut_slice();
        entries.fill(0.0);
        let mut body = self.chain.carrier(link).body;
        while let Some(b) = body {
            let bd = &self.chain.bodies[b];
            let (turning, sliding) = columns(bd);
            for (rate, terms) in [(bd.theta_rate, turning), (bd.d_rate, sliding)] {
                if rate.scale != 0.0 {
                    let column = &mut entries[6 * rate.index..6 * rate.index + 6];
                    for (c, x) in column.iter_mut().zip(terms) {
                        *c += x * rate.scale;
                    }
                }
            }
            body = bd.parent;
        }
    }

    /// The frame a link's motion is computed for, and the link's offset from it in world axes:
    /// the body's rotation applied to the offset's translation (not the difference of the two
    /// origins, which would cancel and need the link's whole pose).
    #[inline]
    fn carrier(&self, link: LinkId) -> Option<(usize, [f64; 3])> {
        let l = self.chain.carrier(link);
        let b = l.body?;
        let r = match l.offset {
            Placement::Identity => [0.0; 3],
            offset => {
                padded::transform(&self.data.world_from_body[b]).apply(offset.to_transform().p)
            }
        };
        Some((b, r))
    }

    #[inline]
    fn velocity(&self, link: LinkId) -> LinkVelocity {
        let (omega, v) = match self.carrier(link) {
            None => ([0.0; 3], [0.0; 3]),
            Some((b, r)) => {
                let body = &self.data.rates[b];
                let omega = padded::cut(&body.omega);
                (omega, add3(padded::cut(&body.v), cross3(omega, r)))
            }
        };
        LinkVelocity {
            omega: omega.into(),
            v: v.into(),
        }
    }

    /// Link pose, ω, and `u = A ū` for a point `u_bar` of the link.
    fn point_frame(&self, link: LinkId, u_bar: &Vector3<f64>) -> (Transform, [f64; 3]) {
        let pose = self.world_from_link(link);
        let u = pose.apply((*u_bar).into());
        (pose, u)
    }

    fn point_velocity(
        &self,
        link: LinkId,
        u_bar: &Vector3<f64>,
        u_bar_dot: &Vector3<f64>,
    ) -> PointVelocity {
        let (pose, u) = self.point_frame(link, u_bar);
        let v = self.velocity(link);
        let relative = pose.apply((*u_bar_dot).into());
        PointVelocity {
            position: Vector3::from(add3(pose.p, u)),
            velocity: Vector3::from(add3(add3(v.v.into(), cross3(v.omega.into(), u)), relative)),
        }
    }

    fn point_motion(
        &self,
        link: LinkId,
        u_bar: &Vector3<f64>,
        u_bar_dot: &Vector3<f64>,
        u_bar_ddot: &Vector3<f64>,
    ) -> PointMotion {
        let (pose, u) = self.point_frame(link, u_bar);
        let pv = self.point_velocity(link, u_bar, u_bar_dot);
        let w: [f64; 3] = self.velocity(link).omega.into();
        let acc = self.acceleration(link);
        let v_rel = pose.apply((*u_bar_dot).into());
        // eq. (2.75): local, Coriolis, tangential and normal terms, plus the origin's acceleration.
        let parts = AccelerationParts {
            origin: acc.a,
            tangential: Vector3::from(cross3(acc.alpha.into(), u)),
            normal: Vector3::from(cross3(w, cross3(w, u))),
            coriolis: Vector3::from(scale3(2.0, cross3(w, v_rel))),
            local: Vector3::from(pose.apply((*u_bar_ddot).into())),
        };
        PointMotion {
            position: pv.position,
            velocity: pv.velocity,
            acceleration: parts.origin
                + parts.tangential
                + parts.normal
                + parts.coriolis
                + parts.local,
            parts,
        }
    }

    #[inline]
    fn acceleration(&self, link: LinkId) -> LinkAcceleration {
        let (alpha, a) = match self.carrier(link) {
            None => ([0.0; 3], [0.0; 3]),
            Some((b, r)) => {
                let body = &self.data.rates[b];
                let (w, al) = (padded::cut(&body.omega), padded::cut(&body.alpha));
                let a = add3(
                    padded::cut(&body.a),
                    add3(cross3(al, r), cross3(w, cross3(w, r))),
                );
                (al, a)
            }
        };
        LinkAcceleration {
            alpha: alpha.into(),
            a: a.into(),
        }
    }
}

impl<'a> Velocities<'a> {
    /// The chain evaluated.
    #[must_use]
    pub fn chain(&self) -> &'a Chain {
        self.poses.chain
    }

    /// The poses of the same evaluation.
    #[must_use]
    pub fn poses(&self) -> Poses<'a> {
        self.poses
    }

    /// Pose of `link` in the world frame.
    #[must_use]
    #[inline]
    pub fn world_from_link(&self, link: LinkId) -> Transform {
        self.poses.world_from_link(link)
    }

    /// Angular velocity of `link` and linear velocity of its origin, world frame.
    #[must_use]
    #[inline]
    pub fn velocity(&self, link: LinkId) -> LinkVelocity {
        self.poses.velocity(link)
    }

    /// The same as [`Velocities::velocity`] with components in the link's own frame:
    /// `ω̄ = Aᵀ ω` (eq. 2.41) and `v̄ = Aᵀ v`.
    #[must_use]
    pub fn velocity_local(&self, link: LinkId) -> LinkVelocity {
        let pose = self.world_from_link(link);
        let v = self.velocity(link);
        LinkVelocity {
            omega: pose.rotation().transpose() * v.omega,
            v: pose.rotation().transpose() * v.v,
        }
    }

    /// Position and velocity of the point with link coordinates `u_bar` (eqs. 2.52, 2.55).
    #[must_use]
    pub fn point(&self, link: LinkId, u_bar: &Vector3<f64>) -> PointVelocity {
        self.poses.point_velocity(link, u_bar, &Vector3::zeros())
    }

    /// The time derivative `J̇` of [`Poses::jacobian`] at the evaluated state, so that the
    /// link's angular acceleration and the classical acceleration of its origin are
    /// `[a; α] = J q̈ + J̇ q̇` (eqs. 2.122–2.127); `J̇ q̇` is the part of
    /// [`Accelerations::acceleration`] that does not come from `q̈`.
    ///
    /// Each joint axis is fixed in the frame before its joint, which turns with that frame's
    /// angular velocity `ω_j`: a turning column `[z × (p − p_j); z]` changes at
    /// `[ż × (p − p_j) + z × (ṗ − ṗ_j); ż]` with `ż = ω_j × z` (eq. 2.120 for `ṗ_j`, the
    /// velocity of the axis point), a sliding column `[z; 0]` at `[ż; 0]`.
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    ///
    /// # Examples
    /// ```
    /// use kinechain::{Chain, Data, forward_accelerations, forward_velocities, nalgebra::DVector};
    /// let chain = Chain::from_file("robots/stanford.yaml")?; // joint 3 slides
    /// let mut data = Data::new(&chain);
    /// let q = [0.1, -0.5, 0.6, 0.2, 0.4, 0.0];
    /// let (qd, qdd) = ([0.3, 0.1, -0.2, 0.5, 0.0, 1.0], [0.2, -0.4, 0.1, 0.0, 0.3, -0.1]);
    /// let tool = chain.link_id("tool")?;
    /// let vel = forward_velocities(&chain, &mut data, &q, &qd)?;
    /// let (j, j_dot) = (vel.poses().jacobian(tool), vel.jacobian_dot(tool));
    /// let motion = j * DVector::from_row_slice(&qdd) + j_dot * DVector::from_row_slice(&qd);
    /// let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd)?.acceleration(tool);
    /// approx::assert_relative_eq!(motion.fixed_rows::<3>(0).into_owned(), acc.a, epsilon = 1e-14);
    /// approx::assert_relative_eq!(motion.fixed_rows::<3>(3).into_owned(), acc.alpha, epsilon = 1e-14);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn jacobian_dot(&self, link: LinkId) -> nalgebra::Matrix6xX<f64> {
        let mut j = nalgebra::Matrix6xX::zeros(self.chain().dof());
        self.jacobian_dot_into(link, &mut j);
        j
    }

    /// [`Velocities::jacobian_dot`] written into `j`, which is resized to 6 × [`Chain::dof`] if
    /// it has another shape (so a reused matrix allocates nothing).
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    pub fn jacobian_dot_into(&self, link: LinkId, j: &mut nalgebra::Matrix6xX<f64>) {
        let poses = &self.poses;
        let p = poses.world_from_link(link).p;
        let p_dot: [f64; 3] = self.velocity(link).v.into();
        poses.path_columns(link, j, |bd| {
            let (parent_origin, offset, z) = poses.axis_parts(bd);
            let origin = add3(parent_origin, offset);
            // The frame before the joint turns at ω and its origin moves at v; the axis point
            // at v + ω × offset (the offset in world axes, not a difference of origins).
            let (omega, origin_dot) = match bd.parent {
                Some(parent) => {
                    let rates = &poses.data.rates[parent];
                    let (omega, v) = (padded::cut(&rates.omega), padded::cut(&rates.v));
                    (omega, add3(v, cross3(omega, offset)))
                }
                None => ([0.0; 3], [0.0; 3]),
            };
            let z_dot = cross3(omega, z);
            let turning = add3(
                cross3(z_dot, sub3(p, origin)),
                cross3(z, sub3(p_dot, origin_dot)),
            );
            (join(turning, z_dot), join(z_dot, [0.0; 3]))
        });
    }
}

impl<'a> Accelerations<'a> {
    /// The chain evaluated.
    #[must_use]
    pub fn chain(&self) -> &'a Chain {
        self.poses.chain
    }

    /// The poses of the same evaluation.
    #[must_use]
    pub fn poses(&self) -> Poses<'a> {
        self.poses
    }

    /// The velocities of the same evaluation.
    #[must_use]
    pub fn velocities(&self) -> Velocities<'a> {
        Velocities { poses: self.poses }
    }

    /// Pose of `link` in the world frame.
    #[must_use]
    #[inline]
    pub fn world_from_link(&self, link: LinkId) -> Transform {
        self.poses.world_from_link(link)
    }

    /// Angular velocity of `link` and linear velocity of its origin, world frame.
    #[must_use]
    #[inline]
    pub fn velocity(&self, link: LinkId) -> LinkVelocity {
        self.poses.velocity(link)
    }

    /// Angular acceleration of `link` and classical acceleration of its origin, world frame.
    #[must_use]
    #[inline]
    pub fn acceleration(&self, link: LinkId) -> LinkAcceleration {
        self.poses.acceleration(link)
    }

    /// The same as [`Accelerations::velocity`] with components in the link's own frame.
    #[must_use]
    pub fn velocity_local(&self, link: LinkId) -> LinkVelocity {
        self.velocities().velocity_local(link)
    }

    /// The same as [`Accelerations::acceleration`] with components in the link's own frame:
    /// `ᾱ = Aᵀ α`, `ā = Aᵀ a`.
    #[must_use]
    pub fn acceleration_local(&self, link: LinkId) -> LinkAcceleration {
        let rt = self.world_from_link(link).rotation().transpose();
        let a = self.acceleration(link);
        LinkAcceleration {
            alpha: rt * a.alpha,
            a: rt * a.a,
        }
    }

    /// Position, velocity and acceleration of the point fixed at link coordinates `u_bar`:
    /// `r̈ = R̈ + α × u + ω × (ω × u)` with `u = A ū` (eqs. 2.52, 2.55 and the fixed-point case
    /// of 2.75).
    #[must_use]
    pub fn point(&self, link: LinkId, u_bar: &Vector3<f64>) -> PointMotion {
        let zero = Vector3::zeros();
        self.poses.point_motion(link, u_bar, &zero, &zero)
    }

    /// A point moving in the link frame, at `u_bar` with velocity `u_bar_dot` and acceleration
    /// `u_bar_ddot` relative to the link (link coordinates): eq. (2.75),
    /// `r̈ = R̈ + A ü + 2 ω × (A u̇) + α × u + ω × (ω × u)`.
    #[must_use]
    pub fn moving_point(
        &self,
        link: LinkId,
        u_bar: &Vector3<f64>,
        u_bar_dot: &Vector3<f64>,
        u_bar_ddot: &Vector3<f64>,
    ) -> PointMotion {
        self.poses.point_motion(link, u_bar, u_bar_dot, u_bar_ddot)
    }
}

/// Six entries: `a` then `b`.
#[inline(always)]
fn join(a: [f64; 3], b: [f64; 3]) -> [f64; 6] {
    [a[0], a[1], a[2], b[0], b[1], b[2]]
}

/// Checks length and finiteness of a joint-space vector.
pub(crate) fn check_values(
    chain: &Chain,
    values: &[f64],
    what: &'static str,
) -> Result<(), StateError> {
    if values.len() != chain.dof() {
        return Err(StateError::WrongLength {
            what,
            expected: chain.dof(),
            got: values.len(),
        });
    }
    // Branch-free, two operations per entry: `x · 0` is ±0 for a finite `x` and NaN for ±∞ or
    // NaN, so the sum is 0 exactly when every entry is finite. The entry at fault is looked for
    // only on failure.
    if values.iter().fold(0.0, |sum, x| sum + x * 0.0) == 0.0 {
        return Ok(());
    }
    if let Some(index) = values.iter().position(|x| !x.is_finite()) {
        let (joint, component) = chain.variable(index);
        return Err(StateError::NonFinite {
            what,
            index,
            joint: chain.joints()[joint].name().to_string(),
            component,
            value: values[index],
        });
    }
    Ok(())
}

/// See [`all_valid`]; `A` only selects the target features it is compiled with.
#[inline(always)]
fn all_valid_generic<A: Arith>(chain: &Chain, qs: &[f64], policy: LimitPolicy) -> bool {
    // Plain loops: an iterator adapter's closure is not always inlined into the target-feature
    // function, and would then run as baseline code.
    let mut finite = true;
    for x in qs {
        finite &= x.is_finite();
    }
    finite
        && (policy == LimitPolicy::Ignore
            || qs
                .chunks_exact(chain.dof())
                .all(|q| chain.limit_checks.iter().all(|c| c.admits(q))))
}

/// Checks `q` (length, finiteness, and limits under [`LimitPolicy::Enforce`]).
///
/// # Errors
/// [`StateError`] naming the first entry at fault.
pub fn check_q(chain: &Chain, q: &[f64], policy: LimitPolicy) -> Result<(), StateError> {
    // One branch-free pass when the checks fit one per entry; the entry at fault is looked for
    // only on failure.
    if let (Some(limits), LimitPolicy::Enforce, true) =
        (&chain.dense_limits, policy, q.len() == chain.dof())
        && admitted::<Separate>(q, Some(limits))
    {
        return Ok(());
    }
    check_values(chain, q, "q")?;
    if policy == LimitPolicy::Enforce {
        for c in &chain.limit_checks {
            let value = c.value(q[c.index]);
            if !c.limits.contains(value) {
                return Err(StateError::OutOfLimits {
                    joint: chain.joints()[c.joint].name().to_string(),
                    component: c.component,
                    angular: c.angular,
                    value,
                    lower: c.limits.lower,
                    upper: c.limits.upper,
                });
            }
        }
    }
    Ok(())
}

/// Computes the pose of every link at `q`.
///
/// The inputs are checked, the results are not: finite values large enough to overflow (two
/// sliding joints at 10³⁰⁸ m along one axis, with limits absent or ignored) give infinite
/// entries, as IEEE arithmetic does. This holds for every evaluation function.
///
/// # Errors
/// [`StateError`] if `q` has the wrong length, a non-finite entry, or (under the data's
/// [`LimitPolicy::Enforce`]) a value outside a joint's limits.
///
/// # Panics
/// If `data` was created for another chain.
///
/// # Examples
/// ```
/// use kinechain::{Chain, Data, forward_kinematics};
/// let chain = Chain::from_file("robots/planar3.yaml")?;
/// let mut data = Data::new(&chain);
/// let poses = forward_kinematics(&chain, &mut data, &[0.0, 0.0, 0.0])?;
/// let tip = poses.world_from_link(chain.link_id("link3")?);
/// approx::assert_relative_eq!(tip.translation().x, 9.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[inline]
pub fn forward_kinematics<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
) -> Result<Poses<'a>, StateError> {
    data.assert_matches(chain);
    let done = match kernel_check(chain, q, data.limit_policy) {
        Some(limits) => poses_all_admitted(chain, data, q, limits),
        None => false,
    };
    if !done {
        check_q(chain, q, data.limit_policy)?;
        poses_all(chain, data, q);
    }
    data.last_q.copy_from_slice(q);
    data.poses_valid = true;
    Ok(Poses { chain, data })
}

/// Like [`forward_kinematics`], but recomputes only the joints whose inputs differ from the
/// previous full evaluation with this `data`, and the joints below them. The result is bit for
/// bit the same as a full evaluation (each pose is always composed from its parent's, never
/// updated in place, so there is no drift).
///
/// # Errors
/// As [`forward_kinematics`].
///
/// # Panics
/// If `data` was created for another chain.
#[inline]
pub fn forward_kinematics_incremental<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
) -> Result<Poses<'a>, StateError> {
    data.assert_matches(chain);
    if data.poses_valid {
        let (first, start) = first_changed(chain, data, q)?;
        if first != usize::MAX {
            if is_tail(chain, first) {
                poses_tail(chain, data, q, first);
            } else {
                poses_incremental(chain, data, q, first);
            }
            // Only the entries that differ are written: a loop the compiler does not turn into
            // a call to `memcpy`, which for the one or two entries of a typical update costs
            // more than the copy.
            for (last, x) in data.last_q[start..].iter_mut().zip(&q[start..]) {
                if last.to_bits() != x.to_bits() {
                    *last = *x;
                }
            }
        }
    } else {
        check_q(chain, q, data.limit_policy)?;
        poses_all(chain, data, q);
        data.last_q.copy_from_slice(q);
        data.poses_valid = true;
    }
    Ok(Poses { chain, data })
}

/// The first body that reads an entry of `q` differing (bit for bit) from the last evaluation's
/// or a later entry (`usize::MAX` when none differs), and the index of the first entry that
/// differs. Only the entries from there on are checked: the others were checked then, under the
/// same limit policy (changing the policy invalidates the poses).
///
/// # Errors
/// As [`check_q`].
fn first_changed(chain: &Chain, data: &Data, q: &[f64]) -> Result<(usize, usize), StateError> {
    if q.len() != chain.dof() {
        check_values(chain, q, "q")?;
    }
    let start = first_difference(q, &data.last_q);
    let Some(&first) = chain.first_body_from.get(start) else {
        return Ok((usize::MAX, start));
    };
    let rest = &q[start..];
    let ok = match (data.limit_policy, &chain.dense_limits) {
        (LimitPolicy::Ignore, _) => rest.iter().all(|x| x.is_finite()),
        (LimitPolicy::Enforce, Some(limits)) => {
            (start..).zip(rest).all(|(i, &x)| limits.admits(i, x))
        }
        (LimitPolicy::Enforce, None) => false,
    };
    if !ok {
        // Decides, and names the entry at fault.
        check_q(chain, q, data.limit_policy)?;
    }
    Ok((first, start))
}

/// The index of the first entry of `a` whose bits differ from `b`'s (`a.len()` when none does),
/// compared four entries at a time: moving the last joints of an arm skips the unchanged
/// head in a vector compare or two instead of one branch per entry.
fn first_difference(a: &[f64], b: &[f64]) -> usize {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut start = 0;
    for (x, y) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        let bits = |i: usize| x[i].to_bits() ^ y[i].to_bits();
        if (bits(0) | bits(1)) | (bits(2) | bits(3)) != 0 {
            break;
        }
        start += 4;
    }
    a[start..]
        .iter()
        .zip(&b[start..])
        .position(|(x, y)| x.to_bits() != y.to_bits())
        .map_or(n, |i| start + i)
}

/// Computes the pose of one link, evaluating only the joints between the base and that link.
///
/// # Errors
/// As [`forward_kinematics`].
///
/// # Panics
/// If `data` was created for another chain, or `link` comes from another chain with more links.
#[inline]
pub fn forward_kinematics_to(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    link: LinkId,
) -> Result<Transform, StateError> {
    data.assert_matches(chain);
    let l = chain.carrier(link);
    let Some(body) = l.body else {
        check_q(chain, q, data.limit_policy)?;
        return Ok(l.offset.to_transform());
    };
    let done = match kernel_check(chain, q, data.limit_policy) {
        Some(limits) => poses_path_admitted(chain, data, q, body, limits),
        None => false,
    };
    if !done {
        check_q(chain, q, data.limit_policy)?;
        poses_path(chain, data, q, body);
    }
    data.poses_valid = false;
    Ok(padded::link_pose(&data.world_from_body[body], &l.offset))
}

/// Computes poses, angular velocities and origin velocities of every link.
///
/// # Errors
/// As [`forward_kinematics`], and for `q_dot` of the wrong length or with a non-finite entry.
///
/// # Panics
/// If `data` was created for another chain.
#[inline]
pub fn forward_velocities<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
    q_dot: &[f64],
) -> Result<Velocities<'a>, StateError> {
    data.assert_matches(chain);
    let done = match kernel_check(chain, q, data.limit_policy) {
        Some(limits) if q_dot.len() == chain.dof() => {
            rates_admitted(chain, data, q, q_dot, None, limits)
        }
        _ => false,
    };
    if !done {
        check_q(chain, q, data.limit_policy)?;
        check_values(chain, q_dot, "q_dot")?;
        velocities_all(chain, data, q, q_dot);
    }
    data.last_q.copy_from_slice(q);
    data.poses_valid = true;
    Ok(Velocities {
        poses: Poses { chain, data },
    })
}

/// Computes poses, velocities, angular accelerations and classical origin accelerations of
/// every link.
///
/// # Errors
/// As [`forward_velocities`], and for `q_ddot` of the wrong length or with a non-finite entry.
///
/// # Panics
/// If `data` was created for another chain.
#[inline]
pub fn forward_accelerations<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
) -> Result<Accelerations<'a>, StateError> {
    data.assert_matches(chain);
    let dof = chain.dof();
    let done = match kernel_check(chain, q, data.limit_policy) {
        Some(limits) if q_dot.len() == dof && q_ddot.len() == dof => {
            rates_admitted(chain, data, q, q_dot, Some(q_ddot), limits)
        }
        _ => false,
    };
    if !done {
        check_q(chain, q, data.limit_policy)?;
        check_values(chain, q_dot, "q_dot")?;
        check_values(chain, q_ddot, "q_ddot")?;
        accelerations_all(chain, data, q, q_dot, q_ddot);
    }
    data.last_q.copy_from_slice(q);
    data.poses_valid = true;
    Ok(Accelerations {
        poses: Poses { chain, data },
    })
}

// ---------------------------------------------------------------------------------------------
// Loops over the bodies, single configuration (the per-body work is in `crate::eval::kernel`).

#[inline(always)]
fn poses_all_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64]) {
    let _ = poses_prefix::<A>(chain, data, q, chain.bodies.len());
}

/// What the dispatched kernels can check of `q` themselves, deciding as [`check_q`] does under
/// `policy`: finiteness only (`Some(None)`), or the limits one per entry (`Some(Some(_))`).
/// `None` when they cannot (the wrong length, or limits that are not one per entry).
#[inline(always)]
fn kernel_check<'a>(
    chain: &'a Chain,
    q: &[f64],
    policy: LimitPolicy,
) -> Option<Option<&'a DenseLimits>> {
    match (policy, &chain.dense_limits) {
        _ if q.len() != chain.dof() => None,
        (LimitPolicy::Ignore, _) => Some(None),
        (LimitPolicy::Enforce, Some(limits)) => Some(Some(limits)),
        (LimitPolicy::Enforce, None) => None,
    }
}

/// Whether `q` (of the chain's length) passes the check [`kernel_check`] chose: finiteness, or
/// [`crate::eval::layout::within`] the limits of each entry. Four entries per vector compare on the
/// AVX paths (a loop over single entries stays scalar, about 40 instructions more on a
/// seven-joint arm), each against one contiguous block of limit columns.
#[inline(always)]
pub(crate) fn admitted<A: Arith>(q: &[f64], limits: Option<&DenseLimits>) -> bool {
    match limits {
        // Another length is not decided here (`check_q` decides).
        Some(limits) if limits.blocks().len() != q.len().div_ceil(4) => false,
        Some(limits) => admitted_rows::<A>(q, limits.blocks().iter()),
        None => admitted_rows::<A>(q, std::iter::repeat(&DenseLimits::FREE)),
    }
}

/// [`admitted`] with the limit columns of each block of four entries of `q` from `columns`,
/// which has one block for each (the last one for the completed rest).
#[inline(always)]
fn admitted_rows<'c, A: Arith>(
    q: &[f64],
    mut columns: impl Iterator<Item = &'c [[f64; 4]; 4]>,
) -> bool {
    let (blocks, rest) = q.as_chunks::<4>();
    let mut ok = true;
    for (x, c) in blocks.iter().zip(&mut columns) {
        ok &= admitted_block::<A>(x, c);
    }
    if !rest.is_empty() {
        ok &= match columns.next() {
            Some(c) => admitted_block::<A>(&completed(rest), c),
            None => false,
        };
    }
    ok
}

/// The last (one to three) entries of `q` completed with zeros, which the padding of the limit
/// columns admits (entry by entry: a copy of variable length would be a library call).
#[inline(always)]
fn completed(rest: &[f64]) -> [f64; 4] {
    let entry = |i: usize| rest.get(i).copied().unwrap_or(0.0);
    [entry(0), entry(1), entry(2), 0.0]
}

/// [`admitted`] for four entries `x` of `q` against their columns `[scale, offset, lower,
/// upper]`.
#[inline(always)]
fn admitted_block<A: Arith>(x: &[f64; 4], [s, o, l, u]: &[[f64; 4]; 4]) -> bool {
    use crate::eval::arith::Col;
    type C<A> = <A as Arith>::Col;
    let columns = [
        C::<A>::load(s),
        C::<A>::load(o),
        C::<A>::load(l),
        C::<A>::load(u),
    ];
    C::<A>::admitted(C::<A>::load(x), columns)
}

/// [`poses_all_generic`] if `q` passes the check [`kernel_check`] chose, checked in the same
/// dispatched call (a separate baseline call costs about a tenth of a 7-joint evaluation).
/// False, with nothing computed, otherwise.
#[inline(always)]
fn poses_all_admitted_generic<A: Arith>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    limits: Option<&DenseLimits>,
) -> bool {
    let admitted = admitted::<A>(q, limits);
    if admitted {
        poses_all_generic::<A>(chain, data, q);
    }
    admitted
}

/// [`poses_path_generic`] if `q` passes `limits`, as in [`poses_all_admitted_generic`].
#[inline(always)]
fn poses_path_admitted_generic<A: Arith>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    body: usize,
    limits: Option<&DenseLimits>,
) -> bool {
    let admitted = admitted::<A>(q, limits);
    if admitted {
        poses_path_generic::<A>(chain, data, q, body);
    }
    admitted
}

/// Poses of bodies `0..n` (parents come first, so they are all there); returns the last one
/// (the identity for `n = 0`).
#[inline(always)]
fn poses_prefix<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], n: usize) -> Frame4<A::Col> {
    let chunks = chain.turning_before[n].div_ceil(kernel::LANES);
    sin_cos_chunks::<A>(chain, data, q, 0..chunks);
    compose_prefix::<A>(chain, data, q, n)
}

/// `sin`/`cos` of the angles gathered in chunks `chunks` of [`Chain::theta_gather`], into the
/// same chunks of `data.sin` and `data.cos`.
#[inline(always)]
fn sin_cos_chunks<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], chunks: Range<usize>) {
    let from = chunks.start;
    kernel::all_sin_cos::<A>(
        &chain.theta_gather[chunks],
        q,
        Lanes::flat_mut(&mut data.sin[from..]),
        Lanes::flat_mut(&mut data.cos[from..]),
    );
}

/// The values of `a` and `b` (`data.sin` and `data.cos`, of one length), cut to the shorter
/// one's length so that one comparison checks an index into both.
#[inline(always)]
fn same_length<'a>(a: &'a [Lanes], b: &'a [Lanes]) -> (&'a [f64], &'a [f64]) {
    let (a, b) = (Lanes::flat(a), Lanes::flat(b));
    let m = a.len().min(b.len());
    (&a[..m], &b[..m])
}

/// [`poses_prefix`] once the trigonometry of bodies `0..n` is in `data`.
#[inline(always)]
fn compose_prefix<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], n: usize) -> Frame4<A::Col> {
    // Sliced to `n` first, so that indexing by `k < n` needs no bounds checks.
    let frames = &mut data.world_from_body[..n];
    let (bodies, slots) = (&chain.bodies[..n], &chain.trig_slot[..n]);
    let (sin, cos) = same_length(&data.sin, &data.cos);
    let mut f = Frame4::<A::Col>::identity();
    for (k, (body, &slot)) in bodies.iter().zip(slots).enumerate() {
        // The previous body's frame stays in registers; only branches read a parent from memory.
        // (One call per case, so that the frame is never reached through an optional pointer.)
        let sin_cos = (sin[slot], cos[slot]);
        f = match body.parent {
            _ if body.follows_previous => padded::pose_step::<A>(Some(&f), body, q, sin_cos),
            Some(p) => padded::pose_step::<A>(Some(&Frame4::load(&frames[p])), body, q, sin_cos),
            None => padded::pose_step::<A>(None, body, q, sin_cos),
        };
        f.store(&mut frames[k]);
    }
    f
}

/// The frames of the bodies on the path from the base to `body`, and of no other, into
/// `data.world_from_body`. The caller reads the link's pose from the last one with
/// [`padded::link_pose`], as every other way of reading a pose does: ending the kernel with that
/// composition and store instead, in its AVX-512 build, made a one-link call 5–10 ns slower than a
/// full evaluation and a read of the same link on Zen 4 (a Panda finger).
#[inline(always)]
fn poses_path_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], body: usize) {
    // A body's ancestors all have smaller indices: the trigonometry of bodies 0..=body covers the
    // path (vectorised, so computing a few bodies off the path costs nothing).
    let chunks = chain.turning_before[body + 1].div_ceil(kernel::LANES);
    sin_cos_chunks::<A>(chain, data, q, 0..chunks);
    // The path is a run of the leading serial bodies (no index list), then the rest of the path
    // (for a branch), listed from the body back towards the base.
    data.path.clear();
    let mut run = Some(body);
    while let Some(b) = run.filter(|&b| b >= chain.serial_run) {
        data.path.push(b);
        run = chain.bodies[b].parent;
    }
    let mut f = match run {
        Some(b) => compose_prefix::<A>(chain, data, q, b + 1),
        None => Frame4::identity(),
    };
    let frames = &mut data.world_from_body;
    let (sin, cos) = same_length(&data.sin, &data.cos);
    for &k in data.path.iter().rev() {
        // Each next body's parent is the previous one, whose frame stays in registers.
        let body = &chain.bodies[k];
        let slot = chain.trig_slot[k];
        let sin_cos = (sin[slot], cos[slot]);
        f = match body.parent {
            Some(_) => padded::pose_step::<A>(Some(&f), body, q, sin_cos),
            None => padded::pose_step::<A>(None, body, q, sin_cos),
        };
        f.store(&mut frames[k]);
    }
}

#[inline(always)]
fn poses_incremental_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], first: usize) {
    // Bodies come parents first, so none before `first` (the first body reading a changed
    // entry) moves.
    if chain.is_serial() {
        poses_from::<A>(chain, data, q, first);
        return;
    }
    let changed = |t: &Term| match *t {
        Term::Var { index, .. } => q[index].to_bits() != data.last_q[index].to_bits(),
        Term::Const(_) => false,
    };
    let frames = &mut data.world_from_body;
    let mut f = Frame4::<A::Col>::identity();
    let mut previous_done = false;
    for (k, body) in (first..).zip(&chain.bodies[first..]) {
        let dirty = body.parent.is_some_and(|p| p >= first && data.dirty[p])
            || changed(&body.motion.theta)
            || changed(&body.motion.d);
        data.dirty[k] = dirty;
        if dirty {
            // The frame just computed stays in registers when it is the parent's.
            let sin_cos = kernel::body_sin_cos::<f64, A>(body, q);
            f = match body.parent {
                _ if body.follows_previous && previous_done => {
                    padded::pose_step::<A>(Some(&f), body, q, sin_cos)
                }
                Some(p) => {
                    padded::pose_step::<A>(Some(&Frame4::load(&frames[p])), body, q, sin_cos)
                }
                None => padded::pose_step::<A>(None, body, q, sin_cos),
            };
            f.store(&mut frames[k]);
        }
        previous_done = dirty;
    }
}

/// Poses of bodies `first..` of a serial chain (each body hangs from the one before), the
/// bodies before `first` being up to date; the trigonometry vectorised like a full evaluation's.
#[inline(always)]
fn poses_from<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], first: usize) {
    let chunk = chain.turning_before[first] / kernel::LANES;
    sin_cos_chunks::<A>(chain, data, q, chunk..chain.theta_gather.len());
    let frames = &mut data.world_from_body;
    let mut f = match first.checked_sub(1) {
        Some(p) => Frame4::load(&frames[p]),
        None => Frame4::identity(),
    };
    let (sin, cos) = same_length(&data.sin, &data.cos);
    let bodies = chain.bodies[first..].iter().zip(&chain.trig_slot[first..]);
    for (k, (body, &slot)) in (first..).zip(bodies) {
        let sin_cos = (sin[slot], cos[slot]);
        f = match body.parent {
            Some(_) => padded::pose_step::<A>(Some(&f), body, q, sin_cos),
            None => padded::pose_step::<A>(None, body, q, sin_cos),
        };
        f.store(&mut frames[k]);
    }
}

/// Whether the bodies from `first` on are few enough for [`poses_tail`] ([`Chain`]'s
/// `tail_start`: at most four, of which at most two turn; a sliding or fixed-θ body needs no
/// `sin`/`cos`). In a tree they may include bodies that did not move; recomputing one gives the
/// same frame, bit for bit.
#[inline(always)]
fn is_tail(chain: &Chain, first: usize) -> bool {
    first >= chain.tail_start
}

/// Poses of the bodies from `first` on ([`is_tail`]), the bodies before `first` being up to
/// date, with their trigonometry in scalar code: a function of its own, so that moving the last
/// joints (the common incremental update) runs none of the set-up of the vectorised or tree
/// paths.
#[inline(always)]
fn poses_tail_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], first: usize) {
    let frames = &mut data.world_from_body;
    let mut f = Frame4::<A::Col>::identity();
    // (Not `enumerate().skip(first)`, here or in `poses_from` and `poses_incremental_generic`:
    // it divides by the size of a body to count them.)
    for (k, body) in (first..).zip(&chain.bodies[first..]) {
        let sin_cos = kernel::body_sin_cos::<f64, A>(body, q);
        // The parent's frame stays in registers when it was just computed.
        f = match body.parent {
            _ if body.follows_previous && k > first => {
                padded::pose_step::<A>(Some(&f), body, q, sin_cos)
            }
            Some(p) => padded::pose_step::<A>(Some(&Frame4::load(&frames[p])), body, q, sin_cos),
            None => padded::pose_step::<A>(None, body, q, sin_cos),
        };
        f.store(&mut frames[k]);
    }
}

#[inline(always)]
fn rates_all_generic<A: Arith, const ACC: bool>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
) {
    sin_cos_chunks::<A>(chain, data, q, 0..chain.theta_gather.len());
    // Sliced to the number of bodies first, so that indexing by body needs no bounds checks.
    let n = chain.bodies.len();
    let (frames, rates) = (&mut data.world_from_body[..n], &mut data.rates[..n]);
    let slots = &chain.trig_slot[..n];
    let (sin, cos) = same_length(&data.sin, &data.cos);
    let mut previous = (Frame4::<A::Col>::identity(), Rates4::zero());
    for (k, (body, &slot)) in chain.bodies.iter().zip(slots).enumerate() {
        // The previous body's state stays in registers; only branches read a parent from memory.
        // (One call per case, as in `poses_prefix`.)
        let sin_cos = (sin[slot], cos[slot]);
        previous = match body.parent {
            _ if body.follows_previous => {
                padded::rates_step::<A, ACC>(Some(&previous), body, q, q_dot, q_ddot, sin_cos)
            }
            Some(p) => {
                let loaded = (Frame4::load(&frames[p]), Rates4::from_rates(&rates[p]));
                padded::rates_step::<A, ACC>(Some(&loaded), body, q, q_dot, q_ddot, sin_cos)
            }
            None => padded::rates_step::<A, ACC>(None, body, q, q_dot, q_ddot, sin_cos),
        };
        previous.0.store(&mut frames[k]);
        previous.1.store::<ACC>(&mut rates[k]);
    }
}

/// [`rates_all_generic`] if `q` passes the check [`kernel_check`] chose and the rates (of the
/// chain's length) are finite, checked in the same dispatched call as in
/// [`poses_all_admitted_generic`]. False, with nothing computed, otherwise.
#[inline(always)]
fn rates_admitted_generic<A: Arith, const ACC: bool>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
    limits: Option<&DenseLimits>,
) -> bool {
    let admitted = admitted::<A>(q, limits)
        & admitted::<A>(q_dot, None)
        & (!ACC || admitted::<A>(q_ddot, None));
    if admitted {
        rates_all_generic::<A, ACC>(chain, data, q, q_dot, q_ddot);
    }
    admitted
}

/// [`rates_admitted_generic`] with accelerations when `q_ddot` is given.
#[inline(always)]
fn rates_admitted_either_generic<A: Arith>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: Option<&[f64]>,
    limits: Option<&DenseLimits>,
) -> bool {
    match q_ddot {
        Some(q_ddot) => rates_admitted_generic::<A, true>(chain, data, q, q_dot, q_ddot, limits),
        None => rates_admitted_generic::<A, false>(chain, data, q, q_dot, &[], limits),
    }
}

#[inline(always)]
fn velocities_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], q_dot: &[f64]) {
    rates_all_generic::<A, false>(chain, data, q, q_dot, &[]);
}

#[inline(always)]
fn accelerations_generic<A: Arith>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
) {
    rates_all_generic::<A, true>(chain, data, q, q_dot, q_ddot);
}

fma_dispatch!(fn poses_all(chain: &Chain, data: &mut Data, q: &[f64]) => poses_all_generic);
fma_dispatch!(fn poses_path(chain: &Chain, data: &mut Data, q: &[f64], body: usize) => poses_path_generic);
fma_dispatch!(fn poses_all_admitted(chain: &Chain, data: &mut Data, q: &[f64], limits: Option<&DenseLimits>) -> bool => poses_all_admitted_generic);
fma_dispatch!(fn poses_path_admitted(chain: &Chain, data: &mut Data, q: &[f64], body: usize, limits: Option<&DenseLimits>) -> bool => poses_path_admitted_generic);
fma_dispatch!(
    /// True when every entry of `qs` (whole configurations of `chain`) is finite and, under
    /// [`LimitPolicy::Enforce`], within its joint's limits: what [`check_q`] accepts, decided for
    /// a batch whose limits the kernels cannot check on their lanes (no
    /// [`Chain::dense_limits`](crate::Chain)), in a finiteness pass that vectorises.
    pub(crate) fn all_valid(chain: &Chain, qs: &[f64], policy: LimitPolicy) -> bool => all_valid_generic
);
fma_dispatch!(fn poses_incremental(chain: &Chain, data: &mut Data, q: &[f64], first: usize) => poses_incremental_generic);
fma_dispatch!(fn poses_tail(chain: &Chain, data: &mut Data, q: &[f64], first: usize) => poses_tail_generic);
fma_dispatch!(fn rates_admitted(chain: &Chain, data: &mut Data, q: &[f64], q_dot: &[f64], q_ddot: Option<&[f64]>, limits: Option<&DenseLimits>) -> bool => rates_admitted_either_generic);
fma_dispatch!(fn velocities_all(chain: &Chain, data: &mut Data, q: &[f64], q_dot: &[f64]) => velocities_generic);
fma_dispatch!(fn accelerations_all(chain: &Chain, data: &mut Data, q: &[f64], q_dot: &[f64], q_ddot: &[f64]) => accelerations_generic);

/// The constant transform `M(θ, d)` of a motion whose terms are constants (a fixed joint),
/// computed once at load time.
pub(crate) fn constant_motion(m: &Motion) -> Placement {
    let body = Body::new(None, Placement::Identity, *m, Placement::Identity, 0);
    let f = kernel::pose_step::<f64, Separate>(None, &body, &[], (0.0, 1.0));
    Placement::from_transform(&f.into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Buffers that evaluate values outside the joints' limits too (some test values are).
    fn unchecked(chain: &Chain) -> Data {
        let mut data = Data::new(chain);
        data.set_limit_policy(LimitPolicy::Ignore);
        data
    }

    /// `forward_kinematics_to` evaluates the bodies from the base to the link's and no other:
    /// after a full evaluation at `q0`, one link at `q1` rewrites exactly the frames of its path,
    /// and those equal a full evaluation at `q1`; every other body keeps its frame of `q0`.
    #[test]
    fn one_link_evaluates_only_its_path() {
        let chain = Chain::from_file(concat!(env!("CARGO_MANIFEST_DIR"), "/robots/panda.urdf"))
            .expect("bundled robot");
        let q0: Vec<f64> = (0..chain.dof()).map(|i| 0.01 * i as f64).collect();
        let q1: Vec<f64> = q0.iter().map(|x| x + 0.3).collect();
        let frames_at = |q: &[f64]| {
            let mut data = unchecked(&chain);
            forward_kinematics(&chain, &mut data, q).expect("finite");
            data.world_from_body.clone()
        };
        let (before, after) = (frames_at(&q0), frames_at(&q1));
        assert!(
            before.iter().zip(&after).all(|(a, b)| a != b),
            "every body moves"
        );
        for (link, path_len) in [
            ("panda_link4", 4),
            ("panda_rightfinger", 8),
            ("panda_hand_tcp", 7),
        ] {
            let id = chain.link_id(link).expect("a Panda link");
            let mut path = Vec::new();
            chain.body_path(chain.carrier(id).body, &mut path);
            assert_eq!(path.len(), path_len, "{link}");
            let mut data = unchecked(&chain);
            forward_kinematics(&chain, &mut data, &q0).expect("finite");
            forward_kinematics_to(&chain, &mut data, &q1, id).expect("finite");
            for (k, frame) in data.world_from_body.iter().enumerate() {
                let want = if path.contains(&k) {
                    &after[k]
                } else {
                    &before[k]
                };
                assert_eq!(frame, want, "{link}: body {k}");
            }
        }
    }

    /// An incremental update that moves only the last joints writes the frames from the first
    /// body reading a changed entry on, and reads only that body's parent before it: frames
    /// further up, overwritten here with NaN after the first evaluation, stay as they are, and the
    /// recomputed ones equal a fresh evaluation bit for bit.
    #[test]
    fn an_incremental_update_leaves_the_unchanged_head_alone() {
        for (file, moved) in [
            ("robots/ur5.yaml", 1),
            ("robots/panda.urdf", 2),
            ("robots/panda_mdh.yaml", 3),
        ] {
            let chain = Chain::from_file(format!("{}/{file}", env!("CARGO_MANIFEST_DIR")))
                .expect("bundled robot");
            let n = chain.dof();
            let q0: Vec<f64> = (0..n).map(|i| 0.01 * i as f64).collect();
            let mut q1 = q0.clone();
            for x in &mut q1[n - moved..] {
                *x += 0.02;
            }
            let first = chain.first_body_from[n - moved];
            let mut data = unchecked(&chain);
            forward_kinematics(&chain, &mut data, &q0).expect("finite");
            let parent = chain.bodies[first].parent.expect("a moving parent");
            let unset = padded::Stored([[f64::NAN; 4]; 4]);
            for (k, frame) in data.world_from_body.iter_mut().enumerate().take(first) {
                if k != parent {
                    *frame = unset;
                }
            }
            forward_kinematics_incremental(&chain, &mut data, &q1).expect("finite");
            let mut fresh = unchecked(&chain);
            forward_kinematics(&chain, &mut fresh, &q1).expect("finite");
            for (k, (frame, want)) in data
                .world_from_body
                .iter()
                .zip(&fresh.world_from_body)
                .enumerate()
            {
                if k < first && k != parent {
                    assert!(
                        frame.iter().flatten().all(|x| x.is_nan()),
                        "{file}: body {k} was rewritten"
                    );
                } else {
                    assert_eq!(frame, want, "{file}: body {k}");
                }
            }
        }
    }
}
