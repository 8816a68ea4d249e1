//! Rigid transforms in the 4×4 homogeneous form of Shabana eq. (2.109), stored as a 3×4 block.
//!
//! A [`Transform`] `world_from_link` maps coordinates in the link frame to coordinates in the world
//! frame: `x_world = R x_link + p`. Composition follows the frame names:
//! `world_from_tool = world_from_link * link_from_tool`.

use crate::orientation::EulerParameters;
use nalgebra::{
    Isometry3, IsometryMatrix3, Matrix3, Matrix4, Point3, Rotation3, Translation3, UnitQuaternion,
    Vector3,
};
use std::ops::Mul;

/// A rigid transform `[[R, p], [0, 1]]` (Shabana eq. 2.109): a rotation matrix and a translation.
///
/// Stored as three rotation columns and the translation, all `f64`, so that composing and
/// reading it costs no conversion. Convert at the edges with [`Transform::to_homogeneous`],
/// [`Transform::rotation`] and [`Transform::translation`].
///
/// # Examples
/// ```
/// use kinechain::Transform;
/// use kinechain::nalgebra::Vector3;
/// let a = Transform::from_translation(Vector3::new(1.0, 2.0, 3.0));
/// let b = Transform::rot_z(std::f64::consts::FRAC_PI_2);
/// let c = a * b;
/// assert_eq!(c.translation(), Vector3::new(1.0, 2.0, 3.0));
/// approx::assert_relative_eq!(c.rotation()[(1, 0)], 1.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Transform {
    /// Rotation columns: `r[j]` is column `j` of the rotation matrix.
    pub(crate) r: [[f64; 3]; 3],
    /// Translation (the origin of the child frame in the parent frame).
    pub(crate) p: [f64; 3],
}

// `repr(C)`: `r` then `p`, twelve `f64` without padding (what `entries_mut` relies on).
const _: () = assert!(std::mem::size_of::<Transform>() == 12 * std::mem::size_of::<f64>());
const _: () = assert!(std::mem::align_of::<Transform>() == std::mem::align_of::<f64>());

/// A matrix handed to [`Transform::try_from_homogeneous`] that is not a rigid transform.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum NotRigid {
    /// An entry is NaN or infinite.
    #[error("matrix has a non-finite entry")]
    NonFinite,
    /// The last row is not `[0, 0, 0, 1]`.
    #[error("last row is not [0, 0, 0, 1] (off by {deviation:e})")]
    LastRow {
        /// Largest deviation from `[0, 0, 0, 1]`.
        deviation: f64,
    },
    /// `RᵀR` differs from the identity by more than the tolerance.
    #[error(
        "rotation block is not orthonormal: max |RᵀR − I| = {deviation:e} (tolerance {tolerance:e})"
    )]
    NotOrthonormal {
        /// Largest entry of `|RᵀR − I|`.
        deviation: f64,
        /// The tolerance that was exceeded.
        tolerance: f64,
    },
    /// The rotation block is a reflection.
    #[error("rotation block has determinant {determinant} (a reflection, not a rotation)")]
    Reflection {
        /// The determinant found.
        determinant: f64,
    },
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// The identity transform.
    pub const IDENTITY: Transform = Transform {
        r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        p: [0.0; 3],
    };

    /// Tolerance on `|RᵀR − I|` used when a file gives a transform as a matrix.
    pub const RIGID_TOLERANCE: f64 = 1e-9;

    /// The twelve entries in memory order (the rotation columns, then the translation), for the
    /// kernels' whole-vector stores.
    pub(crate) fn entries_mut(&mut self) -> &mut [f64; 12] {
        // SAFETY: `repr(C)` lays out `r` then `p`, twelve `f64` without padding and with the
        // alignment of `f64` (both asserted above); the borrow of `self` covers the array's.
        unsafe { &mut *std::ptr::from_mut(self).cast::<[f64; 12]>() }
    }

    /// Builds a transform from a rotation matrix and a translation, without checking that the
    /// matrix is a rotation (see [`Transform::try_from_homogeneous`] for a checked version).
    #[must_use]
    pub fn from_parts(rotation: &Matrix3<f64>, translation: &Vector3<f64>) -> Self {
        let mut r = [[0.0; 3]; 3];
        for (j, col) in r.iter_mut().enumerate() {
            for (i, x) in col.iter_mut().enumerate() {
                *x = rotation[(i, j)];
            }
        }
        Transform {
            r,
            p: [translation.x, translation.y, translation.z],
        }
    }

    /// A pure translation.
    #[must_use]
    pub fn from_translation(translation: Vector3<f64>) -> Self {
        Transform {
            p: [translation.x, translation.y, translation.z],
            ..Self::IDENTITY
        }
    }

    /// Builds a transform from rows `[[r00, r01, r02, x], [..], [..]]` (the top three rows of
    /// the homogeneous matrix), without checks.
    #[must_use]
    pub fn from_rows(rows: &[[f64; 4]; 3]) -> Self {
        let mut r = [[0.0; 3]; 3];
        for (j, col) in r.iter_mut().enumerate() {
            for (i, x) in col.iter_mut().enumerate() {
                *x = rows[i][j];
            }
        }
        Transform {
            r,
            p: [rows[0][3], rows[1][3], rows[2][3]],
        }
    }

    /// Checks a 4×4 homogeneous matrix (rows) and converts it: every entry finite, last row
    /// `[0, 0, 0, 1]`, rotation block orthonormal within [`Transform::RIGID_TOLERANCE`] and of
    /// determinant +1. The entries are kept as given (no re-orthonormalisation).
    ///
    /// # Errors
    /// [`NotRigid`] says which of the conditions fails.
    pub fn try_from_rows(rows: &[[f64; 4]; 4]) -> Result<Self, NotRigid> {
        if rows.iter().flatten().any(|x| !x.is_finite()) {
            return Err(NotRigid::NonFinite);
        }
        let last = [0.0, 0.0, 0.0, 1.0];
        let deviation = rows[3]
            .iter()
            .zip(last)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if deviation > Self::RIGID_TOLERANCE {
            return Err(NotRigid::LastRow { deviation });
        }
        let t = Self::from_rows(&[rows[0], rows[1], rows[2]]);
        let deviation = t.orthonormality_error();
        if deviation > Self::RIGID_TOLERANCE {
            return Err(NotRigid::NotOrthonormal {
                deviation,
                tolerance: Self::RIGID_TOLERANCE,
            });
        }
        let determinant = t.rotation().determinant();
        if determinant < 0.0 {
            return Err(NotRigid::Reflection { determinant });
        }
        Ok(t)
    }

    /// Checked conversion from a homogeneous matrix; see [`Transform::try_from_rows`].
    ///
    /// # Errors
    /// [`NotRigid`] when the matrix is not a rigid transform.
    pub fn try_from_homogeneous(m: &Matrix4<f64>) -> Result<Self, NotRigid> {
        let mut rows = [[0.0; 4]; 4];
        for (i, row) in rows.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = m[(i, j)];
            }
        }
        Self::try_from_rows(&rows)
    }

    /// Rotation about x by `angle` (rad).
    #[must_use]
    pub fn rot_x(angle: f64) -> Self {
        let (s, c) = angle.sin_cos();
        Transform {
            r: [[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]],
            p: [0.0; 3],
        }
    }

    /// Rotation about y by `angle` (rad).
    #[must_use]
    pub fn rot_y(angle: f64) -> Self {
        let (s, c) = angle.sin_cos();
        Transform {
            r: [[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]],
            p: [0.0; 3],
        }
    }

    /// Rotation about z by `angle` (rad).
    #[must_use]
    pub fn rot_z(angle: f64) -> Self {
        let (s, c) = angle.sin_cos();
        Transform {
            r: [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]],
            p: [0.0; 3],
        }
    }

    /// URDF origin: translation `xyz`, then `R = Rz(yaw) Ry(pitch) Rx(roll)` (fixed axes x, y, z).
    #[must_use]
    pub fn from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Self {
        let [roll, pitch, yaw] = rpy;
        let (sr, cr) = roll.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let (sy, cy) = yaw.sin_cos();
        // Columns of Rz(yaw) Ry(pitch) Rx(roll), written out so each entry is rounded as few
        // times as possible.
        Transform {
            r: [
                [cy * cp, sy * cp, -sp],
                [cy * sp * sr - sy * cr, sy * sp * sr + cy * cr, cp * sr],
                [cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr],
            ],
            p: xyz,
        }
    }

    /// The rotation matrix.
    #[must_use]
    #[inline]
    pub fn rotation(&self) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| self.r[j][i])
    }

    /// The translation (origin of the child frame in the parent frame).
    #[must_use]
    #[inline]
    pub fn translation(&self) -> Vector3<f64> {
        Vector3::from(self.p)
    }

    /// The 4×4 homogeneous matrix of eq. (2.109).
    #[must_use]
    #[inline]
    pub fn to_homogeneous(&self) -> Matrix4<f64> {
        Matrix4::from_fn(|i, j| match (i, j) {
            (3, 3) => 1.0,
            (3, _) => 0.0,
            (_, 3) => self.p[i],
            _ => self.r[j][i],
        })
    }

    /// The homogeneous matrix as rows, `[[r00, r01, r02, x], .., [0, 0, 0, 1]]`.
    #[must_use]
    #[inline]
    pub fn to_rows(&self) -> [[f64; 4]; 4] {
        let mut m = [[0.0; 4]; 4];
        for (i, row) in m.iter_mut().take(3).enumerate() {
            *row = [self.r[0][i], self.r[1][i], self.r[2][i], self.p[i]];
        }
        m[3][3] = 1.0;
        m
    }

    /// The inverse `[[Rᵀ, −Rᵀp], [0, 1]]` (eq. 2.110; not the transpose of the 4×4 matrix).
    #[must_use]
    pub fn inverse(&self) -> Transform {
        let r = &self.r;
        let mut inv = [[0.0; 3]; 3];
        for (j, col) in inv.iter_mut().enumerate() {
            for (i, x) in col.iter_mut().enumerate() {
                *x = r[i][j];
            }
        }
        let p = self.p;
        let q = [
            -(r[0][0] * p[0] + r[0][1] * p[1] + r[0][2] * p[2]),
            -(r[1][0] * p[0] + r[1][1] * p[1] + r[1][2] * p[2]),
            -(r[2][0] * p[0] + r[2][1] * p[1] + r[2][2] * p[2]),
        ];
        Transform { r: inv, p: q }
    }

    /// Maps a point given in the child frame to the parent frame: `R u + p` (eq. 2.52).
    #[must_use]
    #[inline]
    pub fn transform_point(&self, u: &Point3<f64>) -> Point3<f64> {
        Point3::from(add3(self.p, self.apply(u.coords.into())))
    }

    /// Maps a free vector given in the child frame to the parent frame: `R u`.
    #[must_use]
    #[inline]
    pub fn transform_vector(&self, u: &Vector3<f64>) -> Vector3<f64> {
        Vector3::from(self.apply((*u).into()))
    }

    /// Largest entry of `|RᵀR − I|`: how far the rotation block is from orthonormal (NaN or
    /// infinite if an entry is not finite).
    ///
    /// # Examples
    /// ```
    /// use kinechain::Transform;
    /// let mut rows = Transform::rot_z(0.3).to_rows();
    /// assert!(Transform::from_rows(&[rows[0], rows[1], rows[2]]).orthonormality_error() < 1e-15);
    /// rows[1][2] = f64::NAN;
    /// assert!(Transform::from_rows(&[rows[0], rows[1], rows[2]]).orthonormality_error().is_nan());
    /// ```
    #[must_use]
    pub fn orthonormality_error(&self) -> f64 {
        let mut worst = 0.0_f64;
        for i in 0..3 {
            for j in 0..3 {
                let d = dot3(self.r[i], self.r[j]) - if i == j { 1.0 } else { 0.0 };
                // (NaN propagates: a matrix with a NaN entry is as far from rigid as can be.)
                worst = if worst.is_nan() || d.is_nan() {
                    f64::NAN
                } else {
                    worst.max(d.abs())
                };
            }
        }
        worst
    }

    /// `R u` on plain arrays.
    #[inline(always)]
    pub(crate) fn apply(&self, u: [f64; 3]) -> [f64; 3] {
        let r = &self.r;
        [
            r[0][0] * u[0] + r[1][0] * u[1] + r[2][0] * u[2],
            r[0][1] * u[0] + r[1][1] * u[1] + r[2][1] * u[2],
            r[0][2] * u[0] + r[1][2] * u[1] + r[2][2] * u[2],
        ]
    }
}

/// The homogeneous matrix `[[R, p], [0, 1]]` (exact).
impl From<Transform> for Matrix4<f64> {
    fn from(t: Transform) -> Self {
        t.to_homogeneous()
    }
}

/// Checked: the matrix must be a rigid transform ([`Transform::try_from_homogeneous`]).
impl TryFrom<Matrix4<f64>> for Transform {
    type Error = NotRigid;
    fn try_from(m: Matrix4<f64>) -> Result<Self, NotRigid> {
        Transform::try_from_homogeneous(&m)
    }
}

/// nalgebra's isometry with a rotation matrix: the same numbers, exactly.
impl From<Transform> for IsometryMatrix3<f64> {
    fn from(t: Transform) -> Self {
        IsometryMatrix3::from_parts(
            Translation3::from(t.translation()),
            Rotation3::from_matrix_unchecked(t.rotation()),
        )
    }
}

/// The same numbers, exactly (the rotation is taken as it is, as nalgebra holds it).
impl From<IsometryMatrix3<f64>> for Transform {
    fn from(iso: IsometryMatrix3<f64>) -> Self {
        Transform::from_parts(iso.rotation.matrix(), &iso.translation.vector)
    }
}

/// nalgebra's isometry with a unit quaternion: the rotation's Euler parameters by Shepperd's
/// method ([`EulerParameters::from_matrix`]), within a few ulps of the matrix.
impl From<Transform> for Isometry3<f64> {
    fn from(t: Transform) -> Self {
        Isometry3::from_parts(
            Translation3::from(t.translation()),
            EulerParameters::from_matrix(&t.rotation()).into(),
        )
    }
}

/// The quaternion's rotation matrix (eq. 2.39 of its Euler parameters), within a few ulps.
impl From<Isometry3<f64>> for Transform {
    fn from(iso: Isometry3<f64>) -> Self {
        let e = EulerParameters::from(iso.rotation);
        Transform::from_parts(&e.to_matrix(), &iso.translation.vector)
    }
}

/// Only the rotation of a [`UnitQuaternion`].
impl From<UnitQuaternion<f64>> for Transform {
    fn from(q: UnitQuaternion<f64>) -> Self {
        Transform::from(Isometry3::from_parts(Translation3::identity(), q))
    }
}

impl Mul for Transform {
    type Output = Transform;

    /// Composition: `(a * b)` maps through `b` first, then `a`.
    fn mul(self, rhs: Transform) -> Transform {
        compose(&self, &rhs)
    }
}

impl Mul<&Transform> for &Transform {
    type Output = Transform;

    fn mul(self, rhs: &Transform) -> Transform {
        compose(self, rhs)
    }
}

fn compose(a: &Transform, b: &Transform) -> Transform {
    Transform {
        r: [a.apply(b.r[0]), a.apply(b.r[1]), a.apply(b.r[2])],
        p: add3(a.p, a.apply(b.p)),
    }
}

#[inline(always)]
pub(crate) fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
pub(crate) fn add3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline(always)]
pub(crate) fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
pub(crate) fn scale3(s: f64, a: [f64; 3]) -> [f64; 3] {
    [s * a[0], s * a[1], s * a[2]]
}

/// `a × b` (eq. 2.6: `[a]x b`).
#[inline(always)]
pub(crate) fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn inverse_composes_to_identity() {
        let t = Transform::from_xyz_rpy([0.3, -1.2, 2.0], [0.4, -1.1, 2.9]);
        let i = t * t.inverse();
        assert_relative_eq!(
            i.to_homogeneous(),
            Matrix4::identity(),
            epsilon = 4.0 * f64::EPSILON
        );
    }

    #[test]
    #[allow(clippy::op_ref, reason = "the by-reference `Mul` is what is tested")]
    fn composition_is_the_product_of_homogeneous_matrices() {
        let a = Transform::from_xyz_rpy([0.3, -1.2, 2.0], [0.4, -1.1, 2.9]);
        let b = Transform::from_xyz_rpy([-0.7, 0.5, 0.1], [2.2, 0.3, -0.6]);
        let by_value = a * b;
        assert_eq!(&a * &b, by_value);
        let shift = Vector3::new(0.25, -1.5, 3.0);
        let moved = Transform::from_translation(shift) * a;
        assert_eq!(moved.rotation(), a.rotation());
        assert_eq!(moved.translation(), a.translation() + shift);
        assert_relative_eq!(
            by_value.to_homogeneous(),
            a.to_homogeneous() * b.to_homogeneous(),
            epsilon = 8.0 * f64::EPSILON
        );
    }

    #[test]
    fn rpy_is_rz_ry_rx() {
        let rpy = [0.4, -1.1, 2.9];
        let direct = Transform::from_xyz_rpy([0.0; 3], rpy);
        let product =
            Transform::rot_z(rpy[2]) * Transform::rot_y(rpy[1]) * Transform::rot_x(rpy[0]);
        assert_relative_eq!(
            direct.rotation(),
            product.rotation(),
            epsilon = 4.0 * f64::EPSILON
        );
    }

    #[test]
    fn rows_round_trip() {
        let t = Transform::from_xyz_rpy([0.3, -1.2, 2.0], [0.4, -1.1, 2.9]);
        assert_eq!(Transform::try_from_rows(&t.to_rows()), Ok(t));
    }

    #[test]
    fn non_rigid_matrices_are_rejected() {
        let mut m = Transform::IDENTITY.to_rows();
        m[0][0] = 1.001;
        assert!(matches!(
            Transform::try_from_rows(&m),
            Err(NotRigid::NotOrthonormal { .. })
        ));
        let mut m = Transform::IDENTITY.to_rows();
        m[2][2] = -1.0;
        assert!(matches!(
            Transform::try_from_rows(&m),
            Err(NotRigid::Reflection { .. })
        ));
        let mut m = Transform::IDENTITY.to_rows();
        m[3][0] = 0.5;
        assert!(matches!(
            Transform::try_from_rows(&m),
            Err(NotRigid::LastRow { .. })
        ));
        let mut m = Transform::IDENTITY.to_rows();
        m[1][3] = f64::NAN;
        assert_eq!(Transform::try_from_rows(&m), Err(NotRigid::NonFinite));
    }

    #[test]
    fn the_rigidity_tolerance_is_inclusive() {
        let tol = Transform::RIGID_TOLERANCE;
        // A last row off by exactly the tolerance passes; one step further does not.
        let mut m = Transform::IDENTITY.to_rows();
        m[3][0] = tol;
        assert!(Transform::try_from_rows(&m).is_ok());
        m[3][0] = tol.next_up();
        assert!(matches!(
            Transform::try_from_rows(&m),
            Err(NotRigid::LastRow { .. })
        ));
        // Columns x and y with the dot product `tol` (their squared norms round to 1).
        let mut m = Transform::IDENTITY.to_rows();
        m[0][1] = tol;
        assert_eq!(
            Transform::from_rows(&[m[0], m[1], m[2]]).orthonormality_error(),
            tol
        );
        assert!(Transform::try_from_rows(&m).is_ok());
        m[0][1] = tol.next_up();
        assert!(matches!(
            Transform::try_from_rows(&m),
            Err(NotRigid::NotOrthonormal { .. })
        ));
    }
}
