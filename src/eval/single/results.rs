//! What the evaluation functions return: views of a [`Data`] buffer filled by one evaluation,
//! giving each link's pose ([`Poses`]), velocity ([`Velocities`]) and acceleration
//! ([`Accelerations`]), points fixed on links, and geometric Jacobians and their rates.
//!
//! Every quantity is in the world (base) frame; `v` is the velocity of the link-frame origin and
//! `a` its classical acceleration (see [`crate::eval::single::kinematics`]).

use crate::eval::error::StateError;
use crate::eval::jacobian::JacobianFrame;
use crate::eval::layout::body::Body;
use crate::eval::layout::chain::Chain;
use crate::eval::link_rates::{
    AccelerationParts, LinkAcceleration, LinkVelocity, PointMotion, PointVelocity,
    link_acceleration, link_velocity, offset_in_world,
};
use crate::eval::single::data::Data;
use crate::model::chain::LinkId;
use crate::model::transform::{Transform, add3, cross3, scale3};
use nalgebra::Vector3;

/// Poses of every link after [`forward_kinematics`](crate::forward_kinematics) or [`forward_kinematics_incremental`](crate::forward_kinematics_incremental).
#[derive(Clone, Copy, Debug)]
pub struct Poses<'a> {
    pub(crate) chain: &'a Chain,
    pub(crate) data: &'a Data,
}

/// Poses and velocities of every link after [`forward_velocities`](crate::forward_velocities).
#[derive(Clone, Copy, Debug)]
pub struct Velocities<'a> {
    pub(crate) poses: Poses<'a>,
}

/// Poses, velocities and accelerations of every link after [`forward_accelerations`](crate::forward_accelerations).
#[derive(Clone, Copy, Debug)]
pub struct Accelerations<'a> {
    pub(crate) poses: Poses<'a>,
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
            Some(b) => crate::eval::kernel::pose_columns::link_pose(
                &self.data.world_from_body[b],
                &l.offset,
            ),
        }
    }

    /// Pose of `link` in `base`'s frame: `base_from_link = world_from_baseᵀ · world_from_link`
    /// (the inverse of eq. 2.109's transform, then the composition).
    ///
    /// # Panics
    /// If a link comes from another chain with more links.
    #[must_use]
    pub fn base_from_link(&self, base: LinkId, link: LinkId) -> Transform {
        self.world_from_link(base).inverse() * self.world_from_link(link)
    }

    /// The Jacobian of `link`'s motion relative to `base`, in `base`'s axes (6 × dof, rows
    /// `[v; ω]`): `[v; ω]_rel = J q̇` with `ω_rel = R_bᵀ (ω − ω_b)` and `v_rel = R_bᵀ (v − v_b −
    /// ω_b × r)`, the rates of `base_from_link`'s rotation and origin (`r` the link origin's
    /// offset from the base origin, world axes; eqs. 2.41 and 2.120 for a point seen from a
    /// moving frame). With `JacobianFrame::Point(ū)` the point's velocity replaces the origin's;
    /// with `JacobianFrame::Link` both halves are in the link's own axes instead of the base's
    /// (turned by `(R_bᵀ R)ᵀ`).
    ///
    /// # Panics
    /// If a link comes from another chain with more links.
    #[must_use]
    pub fn jacobian_relative(
        &self,
        link: LinkId,
        base: LinkId,
        frame: JacobianFrame,
    ) -> nalgebra::Matrix6xX<f64> {
        let in_link_axes = frame == JacobianFrame::Link;
        let frame = if in_link_axes {
            JacobianFrame::World
        } else {
            frame
        };
        let mut j = self.jacobian_in(link, frame);
        let jb = self.jacobian(base);
        let pose = self.world_from_link(link);
        let b = self.world_from_link(base);
        let p = add3(pose.p, pose.apply(frame.point()));
        let r = crate::model::transform::sub3(p, b.p);
        // Base axes, or the link's: `Aᵀ` of the frame the rows are written in.
        let rt = if in_link_axes {
            pose.rotation().transpose()
        } else {
            b.rotation().transpose()
        };
        for c in 0..j.ncols() {
            let wb = Vector3::new(jb[(3, c)], jb[(4, c)], jb[(5, c)]);
            let v = Vector3::new(j[(0, c)], j[(1, c)], j[(2, c)])
                - Vector3::new(jb[(0, c)], jb[(1, c)], jb[(2, c)])
                - wb.cross(&Vector3::from(r));
            let w = Vector3::new(j[(3, c)], j[(4, c)], j[(5, c)]) - wb;
            let (v, w) = (rt * v, rt * w);
            for k in 0..3 {
                j[(k, c)] = v[k];
                j[(3 + k, c)] = w[k];
            }
        }
        j
    }

    /// Writes the pose of each of `links` as a 4 × 4 homogeneous matrix (world frame,
    /// row-major, last row `0 0 0 1`), link `k`'s 16 entries from `16 k`: a C-ordered
    /// `(links.len(), 4, 4)` array. The entries are those of
    /// [`world_from_link`](Poses::world_from_link)`(link).to_rows()` bit for bit, written in one
    /// pass.
    ///
    /// # Errors
    /// [`StateError::OutputLength`] when `out` does not have `16 · links.len()` entries.
    ///
    /// # Panics
    /// If a link comes from another chain with more links.
    pub fn write_matrices(&self, links: &[LinkId], out: &mut [f64]) -> Result<(), StateError> {
        if out.len() != 16 * links.len() {
            return Err(StateError::OutputLength {
                expected: 16 * links.len(),
                got: out.len(),
            });
        }
        crate::eval::kernel::pose_columns::write_link_matrices(
            self.chain,
            &self.data.world_from_body,
            links,
            out,
        );
        Ok(())
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
        let (parent_origin, offset, z) = crate::eval::jacobian::axis_parts(self, body);
        (add3(parent_origin, offset), z)
    }

    /// The geometric Jacobian of `link` at the evaluated configuration: the 6 × [`Chain::dof`](crate::Model::dof)
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

    /// [`Poses::jacobian`] written into `j`, which is resized to 6 × [`Chain::dof`](crate::Model::dof) if it has
    /// another shape (so a reused matrix allocates nothing).
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    pub fn jacobian_into(&self, link: LinkId, j: &mut nalgebra::Matrix6xX<f64>) {
        self.jacobian_in_into(link, JacobianFrame::World, j);
    }

    /// The Jacobian of `link` in `frame` ([`JacobianFrame`]: world axes at the link origin, link
    /// axes at the link origin, or world axes at a point fixed on the link): 6 × [`Chain::dof`](crate::Model::dof),
    /// rows `[v; ω]`.
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    ///
    /// # Examples
    /// ```
    /// use kinechain::{Chain, Data, JacobianFrame, forward_velocities, nalgebra::{DVector, Vector3}};
    /// let chain = Chain::from_file("robots/puma560.yaml")?;
    /// let mut data = Data::new(&chain);
    /// let (q, qd) = ([0.1, -0.5, 0.3, 0.2, 0.4, 0.0], [0.3, 0.1, -0.2, 0.5, 0.0, 1.0]);
    /// let tool = chain.link_id("tool")?;
    /// let u = Vector3::new(0.0, 0.0, 0.1); // 10 cm along the tool's z axis
    /// let vel = forward_velocities(&chain, &mut data, &q, &qd)?;
    /// let j = vel.poses().jacobian_in(tool, JacobianFrame::Point(u.into()));
    /// let twist = j * DVector::from_row_slice(&qd);
    /// approx::assert_relative_eq!(twist.fixed_rows::<3>(0).into_owned(), vel.point(tool, &u).velocity, epsilon = 1e-14);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn jacobian_in(&self, link: LinkId, frame: JacobianFrame) -> nalgebra::Matrix6xX<f64> {
        let mut j = nalgebra::Matrix6xX::zeros(self.chain.dof());
        self.jacobian_in_into(link, frame, &mut j);
        j
    }

    /// [`Poses::jacobian_in`] written into `j`, which is resized to 6 × [`Chain::dof`](crate::Model::dof) if it
    /// has another shape (so a reused matrix allocates nothing).
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    pub fn jacobian_in_into(
        &self,
        link: LinkId,
        frame: JacobianFrame,
        j: &mut nalgebra::Matrix6xX<f64>,
    ) {
        if j.ncols() != self.chain.dof() {
            *j = nalgebra::Matrix6xX::zeros(self.chain.dof());
        }
        crate::eval::jacobian::stored_jacobian(
            self.chain,
            &self.data.world_from_body,
            link,
            frame,
            j.as_mut_slice(),
        );
    }

    /// The frame a link's motion is computed for, and the link's offset from it in world axes
    /// ([`offset_in_world`]).
    #[inline]
    fn carrier(&self, link: LinkId) -> Option<(usize, [f64; 3])> {
        let l = self.chain.carrier(link);
        let b = l.body?;
        Some((
            b,
            offset_in_world(
                &crate::eval::layout::stored::transform(&self.data.world_from_body[b]),
                &l.offset,
            ),
        ))
    }

    #[inline]
    fn velocity(&self, link: LinkId) -> LinkVelocity {
        match self.carrier(link) {
            None => link_velocity([0.0; 3], [0.0; 3], [0.0; 3]),
            Some((b, r)) => {
                let body = &self.data.rates[b];
                link_velocity(
                    crate::eval::layout::stored::cut(&body.omega),
                    crate::eval::layout::stored::cut(&body.v),
                    r,
                )
            }
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
        match self.carrier(link) {
            None => link_acceleration([[0.0; 3]; 3], [0.0; 3]),
            Some((b, r)) => {
                let body = &self.data.rates[b];
                let (w, al, a) = (
                    crate::eval::layout::stored::cut(&body.omega),
                    crate::eval::layout::stored::cut(&body.alpha),
                    crate::eval::layout::stored::cut(&body.a),
                );
                link_acceleration([w, al, a], r)
            }
        }
    }
}

/// `pairs(link)`'s two vectors of each of `links` into `outs`, link `k`'s three entries from
/// `3 k` of each: C-ordered `(links.len(), 3)` arrays.
fn write_rates(
    links: &[LinkId],
    [x, y]: [&mut [f64]; 2],
    pair: impl Fn(LinkId) -> [Vector3<f64>; 2],
) -> Result<(), StateError> {
    let expected = 3 * links.len();
    if let Some(got) = [x.len(), y.len()].into_iter().find(|&n| n != expected) {
        return Err(StateError::OutputLength { expected, got });
    }
    for (k, &link) in links.iter().enumerate() {
        let [a, b] = pair(link);
        x[3 * k..3 * k + 3].copy_from_slice(a.as_slice());
        y[3 * k..3 * k + 3].copy_from_slice(b.as_slice());
    }
    Ok(())
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

    /// Writes ω and the origin's v of each of `links` (world frame), link `k`'s three entries
    /// from `3 k` of `omega` and `v`: C-ordered `(links.len(), 3)` arrays, the entries of
    /// [`velocity`](Velocities::velocity) bit for bit.
    ///
    /// # Errors
    /// [`StateError::OutputLength`] when `omega` or `v` does not have `3 · links.len()` entries
    /// (nothing is written then).
    ///
    /// # Panics
    /// If a link comes from another chain with more links.
    pub fn write_velocities(
        &self,
        links: &[LinkId],
        omega: &mut [f64],
        v: &mut [f64],
    ) -> Result<(), StateError> {
        write_rates(links, [omega, v], |l| {
            let r = self.velocity(l);
            [r.omega, r.v]
        })
    }

    /// The motion of `link` relative to `base`, in `base`'s axes: `ω_rel = R_bᵀ (ω − ω_b)` and
    /// `v_rel = R_bᵀ (v − v_b − ω_b × r)`, `r = o − o_b` (eq. 2.120 with the base as the moving
    /// reference): the rates of [`Poses::base_from_link`]'s rotation and origin.
    #[must_use]
    pub fn velocity_relative(&self, link: LinkId, base: LinkId) -> LinkVelocity {
        let (l, b) = (self.velocity(link), self.velocity(base));
        let r = self.world_from_link(link).translation() - self.world_from_link(base).translation();
        let rt = self.world_from_link(base).rotation().transpose();
        LinkVelocity {
            omega: rt * (l.omega - b.omega),
            v: rt * (l.v - b.v - b.omega.cross(&r)),
        }
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

    /// [`Velocities::jacobian_dot`] written into `j`, which is resized to 6 × [`Chain::dof`](crate::Model::dof) if
    /// it has another shape (so a reused matrix allocates nothing).
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    pub fn jacobian_dot_into(&self, link: LinkId, j: &mut nalgebra::Matrix6xX<f64>) {
        self.jacobian_dot_in_into(link, JacobianFrame::World, j);
    }

    /// The time derivative of [`Poses::jacobian_in`] in `frame`, so that `J q̈ + J̇ q̇` is the time
    /// derivative of `J q̇`: for [`JacobianFrame::World`] and [`JacobianFrame::Point`], `[a; α]`,
    /// the classical acceleration of the frame's point and the angular acceleration, world axes;
    /// for [`JacobianFrame::Link`], the derivative of the link-axes components `[Aᵀ v; Aᵀ ω]`,
    /// which is `[Aᵀ (a − ω × v); Aᵀ α]` (`d/dt Aᵀ x = Aᵀ (ẋ − ω × x)`).
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    #[must_use]
    pub fn jacobian_dot_in(&self, link: LinkId, frame: JacobianFrame) -> nalgebra::Matrix6xX<f64> {
        let mut j = nalgebra::Matrix6xX::zeros(self.chain().dof());
        self.jacobian_dot_in_into(link, frame, &mut j);
        j
    }

    /// [`Velocities::jacobian_dot_in`] written into `j`, resized as [`Poses::jacobian_in_into`]
    /// resizes.
    ///
    /// # Panics
    /// If `link` comes from another chain with more links.
    pub fn jacobian_dot_in_into(
        &self,
        link: LinkId,
        frame: JacobianFrame,
        j: &mut nalgebra::Matrix6xX<f64>,
    ) {
        if j.ncols() != self.chain().dof() {
            *j = nalgebra::Matrix6xX::zeros(self.chain().dof());
        }
        crate::eval::jacobian::jacobian_dot(&self.poses, link, frame, j.as_mut_slice());
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

    /// Writes α and the origin's classical acceleration a of each of `links` (world frame), in
    /// the layout of [`Velocities::write_velocities`]; the entries of
    /// [`acceleration`](Accelerations::acceleration) bit for bit.
    ///
    /// # Errors
    /// [`StateError::OutputLength`] when `alpha` or `a` does not have `3 · links.len()` entries.
    ///
    /// # Panics
    /// If a link comes from another chain with more links.
    pub fn write_accelerations(
        &self,
        links: &[LinkId],
        alpha: &mut [f64],
        a: &mut [f64],
    ) -> Result<(), StateError> {
        write_rates(links, [alpha, a], |l| {
            let r = self.acceleration(l);
            [r.alpha, r.a]
        })
    }

    /// [`Velocities::velocity_relative`] of the same evaluation.
    #[must_use]
    pub fn velocity_relative(&self, link: LinkId, base: LinkId) -> LinkVelocity {
        self.velocities().velocity_relative(link, base)
    }

    /// The acceleration of `link` relative to `base`, in `base`'s axes: the second rates of
    /// [`Poses::base_from_link`]'s origin and the first of its angular velocity,
    /// `α_rel = R_bᵀ (α − α_b − ω_b × ω)` and
    /// `a_rel = R_bᵀ (a − a_b − α_b × r − ω_b × (ω_b × r) − 2 ω_b × (ṙ − ω_b × r))`, `r = o − o_b`,
    /// `ṙ = v − v_b` (eq. 2.127's terms with the base as the moving reference: the transport,
    /// centripetal and Coriolis accelerations taken away).
    #[must_use]
    pub fn acceleration_relative(&self, link: LinkId, base: LinkId) -> LinkAcceleration {
        let (vl, vb) = (self.velocity(link), self.velocity(base));
        let (al, ab) = (self.acceleration(link), self.acceleration(base));
        let r = self.world_from_link(link).translation() - self.world_from_link(base).translation();
        let rt = self.world_from_link(base).rotation().transpose();
        let w = vb.omega;
        let r_dot = vl.v - vb.v;
        LinkAcceleration {
            alpha: rt * (al.alpha - ab.alpha - w.cross(&vl.omega)),
            a: rt
                * (al.a
                    - ab.a
                    - ab.alpha.cross(&r)
                    - w.cross(&w.cross(&r))
                    - 2.0 * w.cross(&(r_dot - w.cross(&r)))),
        }
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

/// A single evaluation as the state a Jacobian is computed from.
impl crate::eval::jacobian::State for Poses<'_> {
    fn chain(&self) -> &Chain {
        self.chain
    }
    #[inline(always)]
    fn body_frame(&self, b: usize) -> Transform {
        crate::eval::layout::stored::transform(&self.data.world_from_body[b])
    }
    #[inline(always)]
    fn body_rates(&self, b: usize) -> [[f64; 3]; 2] {
        let rates = &self.data.rates[b];
        [
            crate::eval::layout::stored::cut(&rates.omega),
            crate::eval::layout::stored::cut(&rates.v),
        ]
    }
    #[inline(always)]
    fn link_pose(&self, link: LinkId) -> Transform {
        self.world_from_link(link)
    }
    #[inline(always)]
    fn link_rates(&self, link: LinkId) -> [[f64; 3]; 2] {
        let v = self.velocity(link);
        [v.omega.into(), v.v.into()]
    }
}
