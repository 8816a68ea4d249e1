//! Euler parameters, the angle and axis of rotation, Rodriguez parameters and direction cosines
//! (sec. 2.1–2.7, 2.10), the elementary rotations, and the singularity error they share with
//! the Euler angles.

use nalgebra::{Matrix3, Matrix3x4, Matrix4, Quaternion, Unit, UnitQuaternion, Vector3, Vector4};

/// A representation or rate map is undefined (or would divide by ~0) at this rotation.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("{representation} is undefined here: {reason}")]
pub struct Singular {
    /// The representation, e.g. `Euler angles z-x-z`.
    pub representation: &'static str,
    /// Why, e.g. `θ = 0 (gimbal lock)`.
    pub reason: &'static str,
}

/// Below this |sin θ| (or |cos θ|) an inverse rate map is reported singular instead of dividing:
/// the rates it would return exceed 10¹² |ω|.
pub const RATE_SINGULARITY: f64 = 1e-12;

/// The skew matrix `[v]x` of eq. 2.6: `[v]x u = v × u`.
#[must_use]
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Rodrigues' formula (eq. 2.9; for a joint, eq. 2.112): `A = I + [v]x sin θ + 2 [v]x² sin²(θ/2)`,
/// for a unit axis `v`. The same matrix as the exponential form `exp(θ [v]x)` (eq. 2.26).
#[must_use]
pub fn rotation_matrix(axis: &Unit<Vector3<f64>>, angle: f64) -> Matrix3<f64> {
    let k = skew(axis);
    let half = (0.5 * angle).sin();
    Matrix3::identity() + k * angle.sin() + k * k * (2.0 * half * half)
}

/// Rotation about x (a simple rotation, sec. 2.1).
#[must_use]
pub fn rot_x(angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// Rotation about y.
#[must_use]
pub fn rot_y(angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// Rotation about z.
#[must_use]
pub fn rot_z(angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

// ---------------------------------------------------------------------------------------------
// Euler parameters

/// Euler parameters (eq. 2.10): `e₀ = cos(θ/2)`, `(e₁, e₂, e₃) = v sin(θ/2)`, with
/// `e₀² + e₁² + e₂² + e₃² = 1` (eq. 2.11). The same numbers as a unit quaternion `w, x, y, z`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EulerParameters {
    /// `e₀ = cos(θ/2)`.
    pub e0: f64,
    /// `e₁ = v₁ sin(θ/2)`.
    pub e1: f64,
    /// `e₂ = v₂ sin(θ/2)`.
    pub e2: f64,
    /// `e₃ = v₃ sin(θ/2)`.
    pub e3: f64,
}

impl EulerParameters {
    /// The parameters of a rotation by `angle` about the unit `axis` (eq. 2.10).
    #[must_use]
    pub fn from_axis_angle(axis: &Unit<Vector3<f64>>, angle: f64) -> Self {
        let (s, c) = (0.5 * angle).sin_cos();
        EulerParameters {
            e0: c,
            e1: axis.x * s,
            e2: axis.y * s,
            e3: axis.z * s,
        }
    }

    /// The parameters of a rotation matrix, with `e₀ ≥ 0` (Shepperd's method: the largest of
    /// `e₀², e₁², e₂², e₃²` is taken from the diagonal, the others from off-diagonal sums and
    /// differences, so no step divides by a small number).
    #[must_use]
    pub fn from_matrix(a: &Matrix3<f64>) -> Self {
        let t = a.trace();
        let d = [t, a[(0, 0)], a[(1, 1)], a[(2, 2)]];
        let k = (0..4).fold(0, |best, i| if d[i] > d[best] { i } else { best });
        let e = match k {
            0 => {
                let s = 2.0 * (1.0 + t).sqrt(); // 4 e0
                [
                    0.25 * s,
                    (a[(2, 1)] - a[(1, 2)]) / s,
                    (a[(0, 2)] - a[(2, 0)]) / s,
                    (a[(1, 0)] - a[(0, 1)]) / s,
                ]
            }
            1 => {
                let s = 2.0 * (1.0 + 2.0 * a[(0, 0)] - t).sqrt(); // 4 e1
                [
                    (a[(2, 1)] - a[(1, 2)]) / s,
                    0.25 * s,
                    (a[(0, 1)] + a[(1, 0)]) / s,
                    (a[(0, 2)] + a[(2, 0)]) / s,
                ]
            }
            2 => {
                let s = 2.0 * (1.0 + 2.0 * a[(1, 1)] - t).sqrt(); // 4 e2
                [
                    (a[(0, 2)] - a[(2, 0)]) / s,
                    (a[(0, 1)] + a[(1, 0)]) / s,
                    0.25 * s,
                    (a[(1, 2)] + a[(2, 1)]) / s,
                ]
            }
            _ => {
                let s = 2.0 * (1.0 + 2.0 * a[(2, 2)] - t).sqrt(); // 4 e3
                [
                    (a[(1, 0)] - a[(0, 1)]) / s,
                    (a[(0, 2)] + a[(2, 0)]) / s,
                    (a[(1, 2)] + a[(2, 1)]) / s,
                    0.25 * s,
                ]
            }
        };
        let sign = if e[0] < 0.0 { -1.0 } else { 1.0 };
        EulerParameters {
            e0: sign * e[0],
            e1: sign * e[1],
            e2: sign * e[2],
            e3: sign * e[3],
        }
        .normalized()
    }

    /// Scaled to unit norm (eq. 2.11). The zero vector has no direction: its entries become NaN.
    #[must_use]
    pub fn normalized(&self) -> Self {
        let n = self.as_vector().norm();
        EulerParameters {
            e0: self.e0 / n,
            e1: self.e1 / n,
            e2: self.e2 / n,
            e3: self.e3 / n,
        }
    }

    /// `[e₀, e₁, e₂, e₃]`.
    #[must_use]
    pub fn as_vector(&self) -> Vector4<f64> {
        Vector4::new(self.e0, self.e1, self.e2, self.e3)
    }

    /// From `[e₀, e₁, e₂, e₃]` (not normalised).
    #[must_use]
    pub fn from_vector(e: &Vector4<f64>) -> Self {
        EulerParameters {
            e0: e[0],
            e1: e[1],
            e2: e[2],
            e3: e[3],
        }
    }

    /// The rotation matrix (eq. 2.14), equal to `E Ēᵀ` (eq. 2.20).
    #[must_use]
    pub fn to_matrix(&self) -> Matrix3<f64> {
        let EulerParameters { e0, e1, e2, e3 } = *self;
        Matrix3::new(
            1.0 - 2.0 * (e2 * e2 + e3 * e3),
            2.0 * (e1 * e2 - e0 * e3),
            2.0 * (e1 * e3 + e0 * e2),
            2.0 * (e1 * e2 + e0 * e3),
            1.0 - 2.0 * (e1 * e1 + e3 * e3),
            2.0 * (e2 * e3 - e0 * e1),
            2.0 * (e1 * e3 - e0 * e2),
            2.0 * (e2 * e3 + e0 * e1),
            1.0 - 2.0 * (e1 * e1 + e2 * e2),
        )
    }

    /// `E` of eq. (2.21): `ω = 2 E ė` (eq. 2.46).
    #[must_use]
    pub fn e_matrix(&self) -> Matrix3x4<f64> {
        let EulerParameters { e0, e1, e2, e3 } = *self;
        Matrix3x4::new(-e1, e0, -e3, e2, -e2, e3, e0, -e1, -e3, -e2, e1, e0)
    }

    /// `Ē` of eq. (2.22): `ω̄ = 2 Ē ė` (eq. 2.45).
    #[must_use]
    pub fn e_bar_matrix(&self) -> Matrix3x4<f64> {
        let EulerParameters { e0, e1, e2, e3 } = *self;
        Matrix3x4::new(-e1, e0, e3, -e2, -e2, -e3, e0, e1, -e3, e2, -e1, e0)
    }

    /// `H(p)` with `p ⊗ q = H(p) q`: the Euler parameters of `A(p) A(q)` (the rotation `q`
    /// followed by `p` in the single-frame sense, or `p` then `q` about body axes).
    #[must_use]
    pub fn h_matrix(&self) -> Matrix4<f64> {
        let EulerParameters { e0, e1, e2, e3 } = *self;
        Matrix4::new(
            e0, -e1, -e2, -e3, e1, e0, -e3, e2, e2, e3, e0, -e1, e3, -e2, e1, e0,
        )
    }

    /// The Euler parameters of `A(self) A(other)`.
    #[must_use]
    pub fn compose(&self, other: &EulerParameters) -> Self {
        Self::from_vector(&(self.h_matrix() * other.as_vector()))
    }

    /// Global angular velocity from parameter rates: `ω = 2 E ė` (eq. 2.46, `G = 2E`, eq. 2.60).
    #[must_use]
    pub fn omega(&self, e_dot: &Vector4<f64>) -> Vector3<f64> {
        2.0 * self.e_matrix() * e_dot
    }

    /// Body angular velocity from parameter rates: `ω̄ = 2 Ē ė` (eq. 2.45, `Ḡ = 2Ē`, eq. 2.59).
    #[must_use]
    pub fn omega_local(&self, e_dot: &Vector4<f64>) -> Vector3<f64> {
        2.0 * self.e_bar_matrix() * e_dot
    }

    /// Parameter rates from the global angular velocity: `ė = ½ Eᵀ ω` (from `E Eᵀ = I`,
    /// eq. 2.23, and `eᵀė = 0`). Defined everywhere.
    #[must_use]
    pub fn rates(&self, omega: &Vector3<f64>) -> Vector4<f64> {
        0.5 * self.e_matrix().transpose() * omega
    }

    /// Parameter rates from the body angular velocity: `ė = ½ Ēᵀ ω̄`.
    #[must_use]
    pub fn rates_from_local(&self, omega_local: &Vector3<f64>) -> Vector4<f64> {
        0.5 * self.e_bar_matrix().transpose() * omega_local
    }
}

/// `e₀ + e₁i + e₂j + e₃k`: nalgebra's unit quaternion is the same rotation (`q.to_rotation_matrix()`
/// equals [`EulerParameters::to_matrix`]). Taken as it is when its norm is 1 to rounding (a few
/// ulps), otherwise normalised.
impl From<EulerParameters> for UnitQuaternion<f64> {
    fn from(e: EulerParameters) -> Self {
        let q = Quaternion::new(e.e0, e.e1, e.e2, e.e3);
        if (q.norm_squared() - 1.0).abs() <= 8.0 * f64::EPSILON {
            Unit::new_unchecked(q)
        } else {
            Unit::new_normalize(q)
        }
    }
}

/// `e₀ = w`, `(e₁, e₂, e₃) = (i, j, k)`, exactly.
impl From<UnitQuaternion<f64>> for EulerParameters {
    fn from(q: UnitQuaternion<f64>) -> Self {
        EulerParameters {
            e0: q.w,
            e1: q.i,
            e2: q.j,
            e3: q.k,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Angle and axis

/// A rotation by `angle` in `[0, π]` about the unit `axis` (eq. 2.9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisAngle {
    /// Unit axis of rotation.
    pub axis: Unit<Vector3<f64>>,
    /// Angle of rotation in `[0, π]`.
    pub angle: f64,
}

impl AxisAngle {
    /// The angle and axis of a rotation matrix, through its Euler parameters:
    /// `θ = 2 atan2(|(e₁, e₂, e₃)|, e₀)`, accurate near 0 and π where `acos((tr A − 1)/2)` is not.
    ///
    /// # Errors
    /// [`Singular`] for the identity (θ = 0: every axis is an axis of rotation).
    pub fn from_matrix(a: &Matrix3<f64>) -> Result<Self, Singular> {
        let e = EulerParameters::from_matrix(a);
        let v = Vector3::new(e.e1, e.e2, e.e3);
        let s = v.norm();
        if s == 0.0 {
            return Err(Singular {
                representation: "angle and axis",
                reason: "θ = 0 (identity: no unique axis)",
            });
        }
        Ok(AxisAngle {
            axis: Unit::new_unchecked(v / s),
            angle: 2.0 * s.atan2(e.e0),
        })
    }

    /// The rotation matrix (eq. 2.9).
    #[must_use]
    pub fn to_matrix(&self) -> Matrix3<f64> {
        rotation_matrix(&self.axis, self.angle)
    }
}

// ---------------------------------------------------------------------------------------------
// Rodriguez parameters

/// Rodriguez parameters `γ = v tan(θ/2)` (eq. 2.77); `γᵢ = eᵢ/e₀` (eq. 2.88). Infinite at θ = π.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RodriguezParameters(pub Vector3<f64>);

impl RodriguezParameters {
    /// From a rotation matrix.
    ///
    /// # Errors
    /// [`Singular`] at θ = π, where `tan(θ/2)` is infinite, and so close to it that
    /// `tan(θ/2)` overflows `f64` (see [`RodriguezParameters::from_euler_parameters`]).
    pub fn from_matrix(a: &Matrix3<f64>) -> Result<Self, Singular> {
        Self::from_euler_parameters(&EulerParameters::from_matrix(a))
    }

    /// From Euler parameters (eq. 2.88).
    ///
    /// # Errors
    /// [`Singular`] when `e₀ = 0` (θ = π), or so small that `eᵢ/e₀` overflows `f64` (θ within
    /// about 10⁻³⁰⁸ of π).
    pub fn from_euler_parameters(e: &EulerParameters) -> Result<Self, Singular> {
        // (`e₀ = 0` gives an infinite or NaN quotient too.)
        let g = Vector3::new(e.e1, e.e2, e.e3) / e.e0;
        if g.iter().any(|x| !x.is_finite()) {
            return Err(Singular {
                representation: "Rodriguez parameters",
                reason: "θ = π, or too close to π for f64 (tan(θ/2) is infinite)",
            });
        }
        Ok(RodriguezParameters(g))
    }

    /// Euler parameters: `e₀ = 1/√(1+γ²)`, `eᵢ = γᵢ e₀` (the inverse of eq. 2.88).
    #[must_use]
    pub fn to_euler_parameters(&self) -> EulerParameters {
        let g = &self.0;
        let g2 = g.norm_squared();
        if g2.is_finite() {
            let e0 = 1.0 / (1.0 + g2).sqrt();
            return EulerParameters {
                e0,
                e1: g.x * e0,
                e2: g.y * e0,
                e3: g.z * e0,
            };
        }
        // γ² overflows (θ within about 10⁻¹⁵⁴ of π): the same with γ scaled by its largest
        // entry m, e₀ = (1/m)/√(1/m² + |γ/m|²) and eᵢ = (γᵢ/m)/√(1/m² + |γ/m|²).
        let m = g.amax();
        let (u, r) = (g / m, 1.0 / m);
        let d = (r * r + u.norm_squared()).sqrt();
        EulerParameters {
            e0: r / d,
            e1: u.x / d,
            e2: u.y / d,
            e3: u.z / d,
        }
    }

    /// The rotation matrix (eq. 2.84): `A = I + 2/(1+γ²) ([γ]x + [γ]x²)`; through the Euler
    /// parameters (eq. 2.14) when γ² overflows.
    #[must_use]
    pub fn to_matrix(&self) -> Matrix3<f64> {
        let g2 = self.0.norm_squared();
        if !g2.is_finite() {
            return self.to_euler_parameters().to_matrix();
        }
        let k = skew(&self.0);
        Matrix3::identity() + (k + k * k) * (2.0 / (1.0 + g2))
    }

    /// `G` of eq. (2.91), `ω = G γ̇`: `2/(1+γ²) (I + [γ]x)`.
    #[must_use]
    pub fn g_matrix(&self) -> Matrix3<f64> {
        (Matrix3::identity() + skew(&self.0)) * (2.0 / (1.0 + self.0.norm_squared()))
    }

    /// `Ḡ` of eq. (2.90), `ω̄ = Ḡ γ̇`: `2/(1+γ²) (I − [γ]x)`.
    #[must_use]
    pub fn g_bar_matrix(&self) -> Matrix3<f64> {
        (Matrix3::identity() - skew(&self.0)) * (2.0 / (1.0 + self.0.norm_squared()))
    }

    /// `γ̇` from the global angular velocity: `G⁻¹ ω` with `G⁻¹ = ½ (I − [γ]x + γγᵀ)` (no
    /// singularity while γ is finite), computed as `½ (ω − γ × ω + γ (γ·ω))`: the matrix `γγᵀ`
    /// would overflow for `|γ|` beyond about 10¹⁵⁴ (θ that close to π) even where `γ̇` is finite.
    #[must_use]
    pub fn rates(&self, omega: &Vector3<f64>) -> Vector3<f64> {
        let g = &self.0;
        0.5 * (omega - g.cross(omega) + g * g.dot(omega))
    }

    /// `γ̇` from the body angular velocity: `Ḡ⁻¹ ω̄` with `Ḡ⁻¹ = ½ (I + [γ]x + γγᵀ)`, computed as
    /// `½ (ω̄ + γ × ω̄ + γ (γ·ω̄))` (see [`RodriguezParameters::rates`]).
    #[must_use]
    pub fn rates_from_local(&self, omega_local: &Vector3<f64>) -> Vector3<f64> {
        let g = &self.0;
        0.5 * (omega_local + g.cross(omega_local) + g * g.dot(omega_local))
    }
}

// ---------------------------------------------------------------------------------------------
// Direction cosines and successive rotations

/// A body frame whose axes are given in the global frame by possibly unnormalised vectors
/// (sec. 2.8: the direction cosines αᵢⱼ of each axis are its normalised components).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FrameError {
    /// An axis is zero or not finite.
    #[error("axis {axis} is zero or not finite")]
    ZeroAxis {
        /// 1, 2 or 3.
        axis: usize,
    },
    /// The axes are not orthogonal (eq. 2.101 fails).
    #[error("axes are not orthogonal: max |αₖ·αₗ| = {deviation:e}")]
    NotOrthogonal {
        /// Largest dot product of two normalised axes.
        deviation: f64,
    },
    /// The axes form a left-handed frame.
    #[error("axes form a left-handed frame")]
    LeftHanded,
    /// The tolerance is not in `[0, 0.5)`.
    #[error("orthogonality tolerance {tolerance} is not in [0, 0.5)")]
    InvalidTolerance {
        /// The tolerance given.
        tolerance: f64,
    },
}

/// The rotation matrix whose columns are the direction cosines of the body axes (eqs. 2.97–2.99):
/// each given axis is normalised; they must be orthogonal within `tolerance` (eq. 2.101) and
/// right-handed. The tolerance bounds `|αₖ·αₗ|` and is inclusive (0 asks for exactly orthogonal
/// axes). It must be below 0.5, which keeps the axes independent: the eigenvalues of their Gram
/// matrix are then at least `1 − 2·tolerance` (Gershgorin), while three axes in one plane can
/// have every `|αₖ·αₗ|` at 0.5.
///
/// # Errors
/// [`FrameError`] naming what is wrong.
pub fn from_direction_cosines(
    axes: [Vector3<f64>; 3],
    tolerance: f64,
) -> Result<Matrix3<f64>, FrameError> {
    if !(0.0..0.5).contains(&tolerance) {
        return Err(FrameError::InvalidTolerance { tolerance });
    }
    let mut unit = [Vector3::zeros(); 3];
    for (i, a) in axes.iter().enumerate() {
        // Scaled by the largest component first, so that an axis of tiny or huge (finite)
        // components is normalised rather than taken for zero or infinite.
        let u = normalize_axis([a.x, a.y, a.z]).ok_or(FrameError::ZeroAxis { axis: i + 1 })?;
        unit[i] = Vector3::from(u);
    }
    let deviation = unit[0]
        .dot(&unit[1])
        .abs()
        .max(unit[0].dot(&unit[2]).abs())
        .max(unit[1].dot(&unit[2]).abs());
    if deviation > tolerance {
        return Err(FrameError::NotOrthogonal { deviation });
    }
    let a = Matrix3::from_columns(&unit);
    if a.determinant() < 0.0 {
        return Err(FrameError::LeftHanded);
    }
    Ok(a)
}

/// Successive rotations about axes fixed in the body, by the multiframe method (sec. 2.3,
/// Example 2.5): each axis is given in body components, and `A = A₁ A₂ ⋯ Aₙ`.
#[must_use]
pub fn multiframe(rotations: &[(Unit<Vector3<f64>>, f64)]) -> Matrix3<f64> {
    rotations
        .iter()
        .fold(Matrix3::identity(), |a, (axis, angle)| {
            a * rotation_matrix(axis, *angle)
        })
}

/// The same successive rotations by the single-frame method (sec. 2.3, Example 2.4): before
/// each rotation its body axis is expressed in the global frame, `vₖ = A vₖ`, and the rotation
/// about it premultiplies, `A ← A(vₖ, θₖ) A`. Equal to [`multiframe`].
#[must_use]
pub fn single_frame(rotations: &[(Unit<Vector3<f64>>, f64)]) -> Matrix3<f64> {
    rotations
        .iter()
        .fold(Matrix3::identity(), |a, (axis, angle)| {
            let global = Unit::new_normalize(a * axis.into_inner());
            rotation_matrix(&global, *angle) * a
        })
}

/// Normalises an axis given in a file or by a caller; `None` if it is zero or not finite.
pub(crate) fn normalize_axis(v: [f64; 3]) -> Option<[f64; 3]> {
    if v.iter().any(|x| !x.is_finite()) {
        return None;
    }
    // Exact coordinate axes stay exact (a norm computed in floating point could round).
    let nonzero = v.iter().filter(|x| **x != 0.0).count();
    if nonzero == 1 {
        return Some(v.map(|x| if x == 0.0 { 0.0 } else { x.signum() }));
    }
    let scale = v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    if scale == 0.0 {
        return None;
    }
    // Scale first so that tiny or huge components neither underflow nor overflow.
    let w = v.map(|x| x / scale);
    let n = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    Some(w.map(|x| x / n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::orientation::angles::wrap;
    use std::f64::consts::{PI, TAU};

    #[test]
    fn axes_normalise_and_zero_axes_are_refused() {
        assert_eq!(normalize_axis([0.0, -3.0, 0.0]), Some([0.0, -1.0, 0.0]));
        // Tiny components must not underflow to a zero norm; the result is within 1 ulp.
        let v = normalize_axis([1e-300, 1e-300, 0.0]).unwrap_or([0.0; 3]);
        assert!((v[0] - std::f64::consts::FRAC_1_SQRT_2).abs() <= 1.2e-16);
        assert_eq!(normalize_axis([0.0; 3]), None);
        assert_eq!(normalize_axis([f64::NAN, 1.0, 0.0]), None);
    }

    #[test]
    fn wrapping_is_exact_and_half_open() {
        // Inside the range nothing changes, not even the last bit of a tiny negative angle.
        for a in [-0.1, -1e-20, -0.0, 0.0, 3.0, PI, (-PI).next_up()] {
            assert_eq!(wrap(a).to_bits(), a.to_bits(), "{a}");
        }
        assert_eq!(wrap(-PI), PI);
        assert_eq!(wrap(PI.next_up()), PI.next_up() - TAU);
        // Outside, one shift by exactly 2π.
        for a in [PI.next_up(), 3.5, TAU, -3.5, -TAU, (-PI).next_down()] {
            let w = wrap(a);
            assert!(w > -PI && w <= PI, "{a} -> {w}");
            assert_eq!((a - w).abs(), TAU, "{a}");
        }
    }
}
