//! Joint kinds and a joint's own motion: a rotation θ about a unit axis `v` and a translation `d`
//! along it, the cylindrical joint of Shabana eq. (2.119) of which revolute and prismatic joints
//! are the special cases with `d` or `θ` constant.

use crate::orientation::{rotation_matrix, skew};
use nalgebra::{Matrix4, Unit, Vector3};

/// The closed set of joint kinds kinechain models.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum JointKind {
    /// Rotation about the axis, with limits.
    Revolute,
    /// Rotation about the axis, without limits.
    Continuous,
    /// Translation along the axis.
    Prismatic,
    /// Rotation θ about and translation d along the same axis (eq. 2.119); two entries of `q`,
    /// θ then d.
    Cylindrical,
    /// No motion.
    Fixed,
    /// A free rigid motion of the child relative to the parent: a translation, then a rotation
    /// by a unit quaternion. Seven entries of `q` (x, y, z in the joint frame, then the
    /// quaternion w, x, y, z: Shabana's Euler parameters θ0…θ3) and six of `q̇` (the velocity of
    /// the child's origin and the child's angular velocity, relative to the parent, in world
    /// axes; `q̈` their time derivatives). Only between the root link and the rest of a robot.
    Floating,
    /// A rotation of the child relative to the parent by a unit quaternion, about the joint
    /// origin. Four entries of `q` (the quaternion w, x, y, z) and three of `q̇` (the child's
    /// angular velocity relative to the parent, in world axes; `q̈` its rate as seen from the
    /// parent, in world axes). Anywhere in a tree (MJCF `ball`, SDF `ball`).
    Ball,
}

impl JointKind {
    /// Degrees of freedom of an independent joint of this kind: its entries of `q̇` (and of
    /// `q`, but for the quaternion joints, [`JointKind::nq`]).
    #[must_use]
    pub const fn dof(self) -> usize {
        match self {
            JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic => 1,
            JointKind::Cylindrical => 2,
            JointKind::Fixed => 0,
            JointKind::Floating => 6,
            JointKind::Ball => 3,
        }
    }

    /// Entries of `q` an independent joint of this kind takes: its degrees of freedom, but seven
    /// for a floating joint (a position and a quaternion) and four for a ball joint.
    #[must_use]
    pub const fn nq(self) -> usize {
        match self {
            JointKind::Floating => 7,
            JointKind::Ball => 4,
            kind => kind.dof(),
        }
    }

    /// Where the quaternion (w, x, y, z) of a joint of this kind starts among its entries of `q`:
    /// 3 for a floating joint, 0 for a ball joint, `None` for the others.
    #[must_use]
    pub const fn quaternion(self) -> Option<usize> {
        match self {
            JointKind::Floating => Some(3),
            JointKind::Ball => Some(0),
            _ => None,
        }
    }

    /// The names of the components of `q` a joint of this kind takes, when it takes more than
    /// one (`NAME.theta` and `NAME.d` of a cylindrical joint), and of `q̇`.
    #[must_use]
    pub const fn components(self) -> (&'static [&'static str], &'static [&'static str]) {
        match self {
            JointKind::Cylindrical => (&["theta", "d"], &["theta", "d"]),
            JointKind::Floating => (
                &["x", "y", "z", "qw", "qx", "qy", "qz"],
                &["vx", "vy", "vz", "wx", "wy", "wz"],
            ),
            JointKind::Ball => (&["qw", "qx", "qy", "qz"], &["wx", "wy", "wz"]),
            _ => (&[], &[]),
        }
    }

    /// Lower-case name as used in robot files (`revolute`, `continuous`, ...).
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            JointKind::Revolute => "revolute",
            JointKind::Continuous => "continuous",
            JointKind::Prismatic => "prismatic",
            JointKind::Cylindrical => "cylindrical",
            JointKind::Fixed => "fixed",
            JointKind::Floating => "floating",
            JointKind::Ball => "ball",
        }
    }

    /// Whether the joint rotates (revolute, continuous, cylindrical).
    #[must_use]
    pub const fn rotates(self) -> bool {
        matches!(
            self,
            JointKind::Revolute | JointKind::Continuous | JointKind::Cylindrical
        )
    }

    /// Whether the joint translates (prismatic, cylindrical).
    #[must_use]
    pub const fn translates(self) -> bool {
        matches!(self, JointKind::Prismatic | JointKind::Cylindrical)
    }
}

impl std::fmt::Display for JointKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Closed interval of allowed values of one joint coordinate (rad or m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Smallest allowed value.
    pub lower: f64,
    /// Largest allowed value.
    pub upper: f64,
}

impl Limits {
    /// Whether `value` lies in `[lower, upper]`.
    #[must_use]
    pub fn contains(&self, value: f64) -> bool {
        value >= self.lower && value <= self.upper
    }
}

/// The unit axis of a joint, with the coordinate axes recognised so that the kernels can use
/// their exact, cheaper form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Axis {
    X,
    Y,
    Z,
    NegX,
    NegY,
    NegZ,
    /// Any other unit vector.
    General([f64; 3]),
}

impl Axis {
    /// The unit vector.
    pub(crate) fn vector(&self) -> [f64; 3] {
        match *self {
            Axis::X => [1.0, 0.0, 0.0],
            Axis::Y => [0.0, 1.0, 0.0],
            Axis::Z => [0.0, 0.0, 1.0],
            Axis::NegX => [-1.0, 0.0, 0.0],
            Axis::NegY => [0.0, -1.0, 0.0],
            Axis::NegZ => [0.0, 0.0, -1.0],
            Axis::General(v) => v,
        }
    }

    /// Classifies a unit vector (exact comparisons: only an exact ±e_i is special).
    pub(crate) fn from_unit(v: [f64; 3]) -> Axis {
        match v {
            [1.0, 0.0, 0.0] => Axis::X,
            [0.0, 1.0, 0.0] => Axis::Y,
            [0.0, 0.0, 1.0] => Axis::Z,
            [-1.0, 0.0, 0.0] => Axis::NegX,
            [0.0, -1.0, 0.0] => Axis::NegY,
            [0.0, 0.0, -1.0] => Axis::NegZ,
            _ => Axis::General(v),
        }
    }
}

/// One scalar of a joint's motion (θ or d): a constant, or `scale * q[index] + offset`.
///
/// Independent joints have `scale = 1`; a mimic joint reads its primary joint's entry with the
/// mimic multiplier and offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Term {
    Const(f64),
    Var {
        index: usize,
        scale: f64,
        offset: f64,
    },
}

/// The moving part of a joint: `[A(v, θ), v d; 0, 1]` (eq. 2.119) with θ and d each a [`Term`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Motion {
    pub(crate) axis: Axis,
    pub(crate) theta: Term,
    pub(crate) d: Term,
    /// `(sin θ, cos θ)` when θ is constant, computed once at load time.
    pub(crate) const_sin_cos: (f64, f64),
}

impl Motion {
    pub(crate) fn new(axis: Axis, theta: Term, d: Term) -> Motion {
        let const_sin_cos = match theta {
            Term::Const(t) => t.sin_cos(),
            Term::Var { .. } => (0.0, 1.0),
        };
        Motion {
            axis,
            theta,
            d,
            const_sin_cos,
        }
    }

    /// The entries of `q` that θ and d read (none, one or two).
    pub(crate) fn variables(&self) -> impl Iterator<Item = usize> {
        [self.theta, self.d].into_iter().filter_map(|t| match t {
            Term::Var { index, .. } => Some(index),
            Term::Const(_) => None,
        })
    }
}

/// Which Denavit–Hartenberg convention a row follows (see [`dh_transform`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DhConvention {
    /// Distal: joint `i` turns about z of frame `i − 1`, `T = Rz(θ) Tz(d) Tx(a) Rx(α)`.
    Standard,
    /// Proximal (Craig), the form of eq. 2.129: `T = Rx(α) Tx(a) Rz(θ) Tz(d)`, where `a` and `α`
    /// are Craig's `a_{i−1}`, `α_{i−1}`.
    Modified,
}

/// The 4×4 transform `parent_from_link` of one Denavit–Hartenberg row, written out entry by entry
/// (eq. 2.129 for the modified convention). For a revolute joint θ is `q` plus the row's offset,
/// for a prismatic one `d` is.
///
/// The chain does not multiply these matrices: a DH file loads into a constant placement and a
/// joint about z (eq. 2.119), which composes in fewer operations and gives the same transform
/// within rounding.
///
/// ```
/// use kinechain::model::joint::{DhConvention, dh_transform};
/// // Modified DH: the x-axis twist and offset come first, so θ turns about the new z.
/// let t = dh_transform(DhConvention::Modified, 0.5, std::f64::consts::FRAC_PI_2, 0.2, 0.0);
/// approx::assert_relative_eq!(t.fixed_view::<3, 1>(0, 3).into_owned(),
///     kinechain::nalgebra::Vector3::new(0.5, -0.2, 0.0), epsilon = 1e-16);
/// ```
#[must_use]
#[inline]
pub fn dh_transform(
    convention: DhConvention,
    a: f64,
    alpha: f64,
    d: f64,
    theta: f64,
) -> Matrix4<f64> {
    let (st, ct) = theta.sin_cos();
    let (sa, ca) = alpha.sin_cos();
    #[rustfmt::skip]
    let t = match convention {
        DhConvention::Modified => Matrix4::new(
            ct,      -st,      0.0, a,
            st * ca, ct * ca,  -sa, -d * sa,
            st * sa, ct * sa,  ca,  d * ca,
            0.0,     0.0,      0.0, 1.0,
        ),
        DhConvention::Standard => Matrix4::new(
            ct,  -st * ca, st * sa,  a * ct,
            st,  ct * ca,  -ct * sa, a * st,
            0.0, sa,       ca,       d,
            0.0, 0.0,      0.0,      1.0,
        ),
    };
    t
}

/// The 4×4 transform of a joint that turns by θ about and slides by `d` along the unit axis `v`
/// (eq. 2.119): `T = [[A(v, θ), v d], [0, 1]]`. A revolute joint has `d` constant, a prismatic
/// joint θ constant.
#[must_use]
pub fn joint_transform(axis: &Unit<Vector3<f64>>, theta: f64, d: f64) -> Matrix4<f64> {
    let mut t = Matrix4::identity();
    t.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&rotation_matrix(axis, theta));
    t.fixed_view_mut::<3, 1>(0, 3)
        .copy_from(&(axis.into_inner() * d));
    t
}

/// Time derivative of [`joint_transform`] (eqs. 2.121–2.122):
/// `Ṫ = [[θ̇ [v]x A, v ḋ], [0, 0]]`.
#[must_use]
pub fn joint_transform_dot(
    axis: &Unit<Vector3<f64>>,
    theta: f64,
    theta_dot: f64,
    d_dot: f64,
) -> Matrix4<f64> {
    let mut t = Matrix4::zeros();
    let a_dot = skew(axis) * rotation_matrix(axis, theta) * theta_dot; // eq. (2.117)
    t.fixed_view_mut::<3, 3>(0, 0).copy_from(&a_dot);
    t.fixed_view_mut::<3, 1>(0, 3)
        .copy_from(&(axis.into_inner() * d_dot));
    t
}

/// Second time derivative of [`joint_transform`] (eqs. 2.126–2.127):
/// `T̈ = [[A ([v]x θ̈ + [v]x² θ̇²), v d̈], [0, 0]]` (using `[v]x A = A [v]x`, eq. 2.128).
#[must_use]
pub fn joint_transform_ddot(
    axis: &Unit<Vector3<f64>>,
    theta: f64,
    theta_dot: f64,
    theta_ddot: f64,
    d_ddot: f64,
) -> Matrix4<f64> {
    let k = skew(axis);
    let a_ddot = rotation_matrix(axis, theta) * (k * theta_ddot + k * k * (theta_dot * theta_dot));
    let mut t = Matrix4::zeros();
    t.fixed_view_mut::<3, 3>(0, 0).copy_from(&a_ddot);
    t.fixed_view_mut::<3, 1>(0, 3)
        .copy_from(&(axis.into_inner() * d_ddot));
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_reports_its_freedoms_and_its_name() {
        use JointKind::*;
        // (kind, dof, rotates, translates, name)
        let table = [
            (Revolute, 1, true, false, "revolute"),
            (Continuous, 1, true, false, "continuous"),
            (Prismatic, 1, false, true, "prismatic"),
            (Cylindrical, 2, true, true, "cylindrical"),
            (Fixed, 0, false, false, "fixed"),
            (Floating, 6, false, false, "floating"),
            (Ball, 3, false, false, "ball"),
        ];
        for (kind, dof, rotates, translates, name) in table {
            assert_eq!(kind.dof(), dof, "{name}");
            assert_eq!(kind.rotates(), rotates, "{name}");
            assert_eq!(kind.translates(), translates, "{name}");
            assert_eq!(kind.as_str(), name);
            assert_eq!(kind.to_string(), name);
        }
    }

    #[test]
    fn only_exact_coordinate_axes_take_their_special_form() {
        let cases = [
            ([1.0, 0.0, 0.0], Axis::X),
            ([0.0, 1.0, 0.0], Axis::Y),
            ([0.0, 0.0, 1.0], Axis::Z),
            ([-1.0, 0.0, 0.0], Axis::NegX),
            ([0.0, -1.0, 0.0], Axis::NegY),
            ([0.0, 0.0, -1.0], Axis::NegZ),
        ];
        for (v, axis) in cases {
            assert_eq!(Axis::from_unit(v), axis, "{v:?}");
            assert_eq!(axis.vector(), v);
        }
        // Off a coordinate axis by the smallest normal component: a general axis, kept as given.
        let near = [1.0, 0.0, f64::MIN_POSITIVE];
        assert_eq!(Axis::from_unit(near), Axis::General(near));
        let tilted = [0.6, 0.0, -0.8];
        assert_eq!(Axis::from_unit(tilted).vector(), tilted);
    }
}
