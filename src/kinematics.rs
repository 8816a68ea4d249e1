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

use crate::arith::{Arith, Separate, fma_dispatch};
use crate::chain::{Body, Chain, LinkId, Placement};
use crate::data::{Data, LimitPolicy};
use crate::error::StateError;
use crate::joint::{Axis, Motion, Term, rotate_columns};
use crate::transform::{Transform, add3, cross3, scale3, sub3};
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
    pub fn world_from_link(&self, link: LinkId) -> Transform {
        let l = self.chain.link(link);
        match l.body {
            None => l.offset.to_transform(),
            Some(b) => {
                let body = &self.data.world_from_body[b];
                match l.offset {
                    Placement::Identity => *body,
                    offset => body * &offset.to_transform(),
                }
            }
        }
    }

    /// The frame a link's motion is computed for, and the link's offset from it.
    fn carrier(&self, link: LinkId) -> Option<(usize, [f64; 3])> {
        let l = self.chain.link(link);
        let b = l.body?;
        let r = match l.offset {
            Placement::Identity => [0.0; 3],
            _ => sub3(self.world_from_link(link).p, self.data.world_from_body[b].p),
        };
        Some((b, r))
    }

    fn velocity(&self, link: LinkId) -> LinkVelocity {
        let (omega, v) = match self.carrier(link) {
            None => ([0.0; 3], [0.0; 3]),
            Some((b, r)) => {
                let w = self.data.omega[b];
                (w, add3(self.data.vel[b], cross3(w, r)))
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

    fn acceleration(&self, link: LinkId) -> LinkAcceleration {
        let (alpha, a) = match self.carrier(link) {
            None => ([0.0; 3], [0.0; 3]),
            Some((b, r)) => {
                let (w, al) = (self.data.omega[b], self.data.alpha[b]);
                let a = add3(
                    self.data.acc[b],
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
    pub fn world_from_link(&self, link: LinkId) -> Transform {
        self.poses.world_from_link(link)
    }

    /// Angular velocity of `link` and linear velocity of its origin, world frame.
    #[must_use]
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
    pub fn world_from_link(&self, link: LinkId) -> Transform {
        self.poses.world_from_link(link)
    }

    /// Angular velocity of `link` and linear velocity of its origin, world frame.
    #[must_use]
    pub fn velocity(&self, link: LinkId) -> LinkVelocity {
        self.poses.velocity(link)
    }

    /// Angular acceleration of `link` and classical acceleration of its origin, world frame.
    #[must_use]
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

/// Checks `q` (length, finiteness, and limits under [`LimitPolicy::Enforce`]).
///
/// # Errors
/// [`StateError`] naming the first entry at fault.
pub fn check_q(chain: &Chain, q: &[f64], policy: LimitPolicy) -> Result<(), StateError> {
    check_values(chain, q, "q")?;
    if policy == LimitPolicy::Enforce {
        for c in &chain.limit_checks {
            let value = c.scale * q[c.index] + c.offset;
            if !c.limits.contains(value) {
                return Err(StateError::OutOfLimits {
                    joint: chain.joints()[c.joint].name().to_string(),
                    component: c.component,
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
pub fn forward_kinematics<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
) -> Result<Poses<'a>, StateError> {
    data.assert_matches(chain);
    check_q(chain, q, data.limit_policy)?;
    poses_all(chain, data, q);
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
pub fn forward_kinematics_incremental<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
) -> Result<Poses<'a>, StateError> {
    data.assert_matches(chain);
    check_q(chain, q, data.limit_policy)?;
    if data.poses_valid {
        poses_incremental(chain, data, q);
    } else {
        poses_all(chain, data, q);
    }
    data.last_q.copy_from_slice(q);
    data.poses_valid = true;
    Ok(Poses { chain, data })
}

/// Computes the pose of one link, evaluating only the joints between the base and that link.
///
/// # Errors
/// As [`forward_kinematics`].
///
/// # Panics
/// If `data` was created for another chain, or `link` comes from another chain with more links.
pub fn forward_kinematics_to(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    link: LinkId,
) -> Result<Transform, StateError> {
    data.assert_matches(chain);
    check_q(chain, q, data.limit_policy)?;
    let l = chain.link(link);
    let Some(body) = l.body else {
        return Ok(l.offset.to_transform());
    };
    poses_path(chain, data, q, body);
    data.poses_valid = false;
    Ok(Poses { chain, data }.world_from_link(link))
}

/// Computes poses, angular velocities and origin velocities of every link.
///
/// # Errors
/// As [`forward_kinematics`], and for `q_dot` of the wrong length or with a non-finite entry.
///
/// # Panics
/// If `data` was created for another chain.
pub fn forward_velocities<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
    q_dot: &[f64],
) -> Result<Velocities<'a>, StateError> {
    data.assert_matches(chain);
    check_q(chain, q, data.limit_policy)?;
    check_values(chain, q_dot, "q_dot")?;
    velocities_all(chain, data, q, q_dot);
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
pub fn forward_accelerations<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
) -> Result<Accelerations<'a>, StateError> {
    data.assert_matches(chain);
    check_q(chain, q, data.limit_policy)?;
    check_values(chain, q_dot, "q_dot")?;
    check_values(chain, q_ddot, "q_ddot")?;
    accelerations_all(chain, data, q, q_dot, q_ddot);
    data.last_q.copy_from_slice(q);
    data.poses_valid = true;
    Ok(Accelerations {
        poses: Poses { chain, data },
    })
}

// ---------------------------------------------------------------------------------------------
// Kernels

/// `f ← f · placement`.
#[inline(always)]
fn place<A: Arith>(f: &mut Transform, placement: &Placement) {
    match *placement {
        Placement::Identity => {}
        Placement::Translation(t) => f.p = apply_add::<A>(&f.r, t, f.p),
        Placement::ScrewX { a, c, s } => {
            f.p = axpy::<A>(a, f.r[0], f.p);
            rotate_columns::<A>(&mut f.r, &Axis::X, s, c);
        }
        Placement::General(t) => *f = compose::<A>(f, &t),
    }
}

/// `R u + p`.
#[inline(always)]
fn apply_add<A: Arith>(r: &[[f64; 3]; 3], u: [f64; 3], p: [f64; 3]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        *o = A::mul_add(
            r[0][k],
            u[0],
            A::mul_add(r[1][k], u[1], A::mul_add(r[2][k], u[2], p[k])),
        );
    }
    out
}

/// `s x + y`.
#[inline(always)]
fn axpy<A: Arith>(s: f64, x: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    [
        A::mul_add(s, x[0], y[0]),
        A::mul_add(s, x[1], y[1]),
        A::mul_add(s, x[2], y[2]),
    ]
}

/// `a · b` for rigid transforms.
#[inline(always)]
fn compose<A: Arith>(a: &Transform, b: &Transform) -> Transform {
    let zero = [0.0; 3];
    Transform {
        r: [
            apply_add::<A>(&a.r, b.r[0], zero),
            apply_add::<A>(&a.r, b.r[1], zero),
            apply_add::<A>(&a.r, b.r[2], zero),
        ],
        p: apply_add::<A>(&a.r, b.p, a.p),
    }
}

/// The joint axis in the world frame, given the joint frame's rotation.
#[inline(always)]
fn axis_world<A: Arith>(r: &[[f64; 3]; 3], axis: &Axis) -> [f64; 3] {
    match *axis {
        Axis::X => r[0],
        Axis::Y => r[1],
        Axis::Z => r[2],
        Axis::NegX => r[0].map(|x| -x),
        Axis::NegY => r[1].map(|x| -x),
        Axis::NegZ => r[2].map(|x| -x),
        Axis::General(v) => apply_add::<A>(r, v, [0.0; 3]),
    }
}

/// `f ← f · M(θ, d)` (eq. 2.119): translate by `d` along the axis, rotate by θ about it (the two
/// commute).
#[inline(always)]
fn apply_motion<A: Arith>(f: &mut Transform, m: &Motion, q: &[f64], z: &[f64; 3]) {
    match m.d {
        Term::Const(0.0) => {}
        d => f.p = axpy::<A>(d.value::<A>(q), *z, f.p),
    }
    let (s, c) = match m.theta {
        Term::Const(0.0) => return,
        Term::Const(_) => m.const_sin_cos,
        theta => theta.value::<A>(q).sin_cos(),
    };
    rotate_columns::<A>(&mut f.r, &m.axis, s, c);
}

/// The joint frame (parent body frame · pre), before the joint's motion.
#[inline(always)]
fn joint_frame<A: Arith>(world_from_body: &[Transform], body: &Body) -> Transform {
    match body.parent {
        Some(p) => {
            let mut f = world_from_body[p];
            place::<A>(&mut f, &body.pre);
            f
        }
        None => body.pre.to_transform(),
    }
}

/// Pose of one body from its parent's.
#[inline(always)]
fn pose_step<A: Arith>(world_from_body: &[Transform], body: &Body, q: &[f64]) -> Transform {
    let mut f = joint_frame::<A>(world_from_body, body);
    let z = match body.motion.d {
        Term::Const(0.0) => [0.0; 3],
        _ => axis_world::<A>(&f.r, &body.motion.axis),
    };
    apply_motion::<A>(&mut f, &body.motion, q, &z);
    place::<A>(&mut f, &body.post);
    f
}

#[inline(always)]
fn poses_all_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64]) {
    let poses = &mut data.world_from_body;
    for (k, body) in chain.bodies.iter().enumerate() {
        poses[k] = pose_step::<A>(poses, body, q);
    }
}

#[inline(always)]
fn poses_path_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], body: usize) {
    data.path.clear();
    let mut k = Some(body);
    while let Some(b) = k {
        data.path.push(b);
        k = chain.bodies[b].parent;
    }
    let poses = &mut data.world_from_body;
    for &k in data.path.iter().rev() {
        poses[k] = pose_step::<A>(poses, &chain.bodies[k], q);
    }
}

#[inline(always)]
fn poses_incremental_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64]) {
    let changed = |t: &Term| match *t {
        Term::Var { index, .. } => q[index].to_bits() != data.last_q[index].to_bits(),
        Term::Const(_) => false,
    };
    for (k, body) in chain.bodies.iter().enumerate() {
        let dirty = changed(&body.motion.theta)
            || changed(&body.motion.d)
            || body.parent.is_some_and(|p| data.dirty[p]);
        data.dirty[k] = dirty;
        if dirty {
            data.world_from_body[k] = pose_step::<A>(&data.world_from_body, body, q);
        }
    }
}

/// Origin, ω, v, α and a of a body's parent (all zero for a body hanging from the world).
#[derive(Clone, Copy)]
struct ParentMotion {
    origin: [f64; 3],
    omega: [f64; 3],
    v: [f64; 3],
    alpha: [f64; 3],
    a: [f64; 3],
}

#[inline(always)]
fn parent_motion(data: &Data, body: &Body) -> ParentMotion {
    match body.parent {
        Some(p) => ParentMotion {
            origin: data.world_from_body[p].p,
            omega: data.omega[p],
            v: data.vel[p],
            alpha: data.alpha[p],
            a: data.acc[p],
        },
        None => ParentMotion {
            origin: [0.0; 3],
            omega: [0.0; 3],
            v: [0.0; 3],
            alpha: [0.0; 3],
            a: [0.0; 3],
        },
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
    for (k, body) in chain.bodies.iter().enumerate() {
        let mut f = joint_frame::<A>(&data.world_from_body, body);
        let p_joint = f.p;
        let z = axis_world::<A>(&f.r, &body.motion.axis);
        apply_motion::<A>(&mut f, &body.motion, q, &z);
        place::<A>(&mut f, &body.post);
        data.world_from_body[k] = f;

        let ParentMotion {
            origin: p_parent,
            omega: w_p,
            v: v_p,
            alpha: al_p,
            a: a_p,
        } = parent_motion(data, body);
        let m = &body.motion;
        let (th_d, d_d) = (m.theta.rate(q_dot), m.d.rate(q_dot));
        let u = sub3(f.p, p_joint);
        let r = sub3(f.p, p_parent);
        let z_u = cross3(z, u);
        // eq. (2.120): velocity of the origin relative to the parent.
        let v_rel = add3(scale3(d_d, z), scale3(th_d, z_u));
        let w_r = cross3(w_p, r);
        data.omega[k] = axpy::<A>(th_d, z, w_p);
        data.vel[k] = add3(add3(v_p, w_r), v_rel);
        if ACC {
            let (th_dd, d_dd) = (m.theta.rate(q_ddot), m.d.rate(q_ddot));
            // eq. (2.125): d'' z + α_rel × u + ω_rel × (ω_rel × u), relative to the parent.
            let a_rel = add3(
                add3(scale3(d_dd, z), scale3(th_dd, z_u)),
                scale3(th_d * th_d, cross3(z, z_u)),
            );
            data.alpha[k] = add3(add3(al_p, scale3(th_dd, z)), cross3(w_p, scale3(th_d, z)));
            // eq. (2.75): tangential, normal, Coriolis and local terms.
            let tangential = cross3(al_p, r);
            let normal = cross3(w_p, w_r);
            let coriolis = scale3(2.0, cross3(w_p, v_rel));
            data.acc[k] = add3(add3(a_p, add3(tangential, normal)), add3(coriolis, a_rel));
        }
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
fma_dispatch!(fn poses_incremental(chain: &Chain, data: &mut Data, q: &[f64]) => poses_incremental_generic);
fma_dispatch!(fn velocities_all(chain: &Chain, data: &mut Data, q: &[f64], q_dot: &[f64]) => velocities_generic);
fma_dispatch!(fn accelerations_all(chain: &Chain, data: &mut Data, q: &[f64], q_dot: &[f64], q_ddot: &[f64]) => accelerations_generic);

/// The constant transform `M(θ, d)` of a motion whose terms are constants (a fixed joint),
/// computed once at load time.
pub(crate) fn constant_motion(m: &Motion) -> Placement {
    let mut f = Transform::IDENTITY;
    let z = axis_world::<Separate>(&f.r, &m.axis);
    apply_motion::<Separate>(&mut f, m, &[], &z);
    Placement::from_transform(&f)
}
