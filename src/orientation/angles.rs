//! Euler angles (sec. 2.6): z-x-z, x-y-z, and URDF roll–pitch–yaw, with the maps between their
//! rates and the angular velocity.

use super::parameters::{EulerParameters, RATE_SINGULARITY, Singular, rot_x, rot_y, rot_z};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::{PI, TAU};

/// Wraps an angle in `[−2π, 2π]` (an `atan2` value or the difference of two) to `(−π, π]`,
/// exactly: an angle already there is returned as it is, and otherwise the one shift by 2π
/// subtracts numbers within a factor of two of each other, which is exact (Sterbenz's lemma).
pub(super) fn wrap(a: f64) -> f64 {
    if a > PI {
        a - TAU
    } else if a <= -PI {
        a + TAU
    } else {
        a
    }
}

/// Goldstein's Euler angles (sec. 2.7): `A = Rz(φ) Rx(θ) Rz(ψ)` (eq. 2.96), θ in `[0, π]`.
/// Singular at θ = 0 and θ = π (only φ + ψ or φ − ψ is defined there).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EulerZxz {
    /// Precession φ, about the global z axis.
    pub phi: f64,
    /// Nutation θ, about the line of nodes.
    pub theta: f64,
    /// Spin ψ, about the body z axis.
    pub psi: f64,
}

impl EulerZxz {
    /// The rotation matrix (eq. 2.96).
    #[must_use]
    pub fn to_matrix(&self) -> Matrix3<f64> {
        rot_z(self.phi) * rot_x(self.theta) * rot_z(self.psi)
    }

    /// The angles of a rotation matrix: θ = atan2(√(a₁₃² + a₂₃²), a₃₃) and φ = atan2(a₁₃, −a₂₃)
    /// (both accurate relative to sin θ, which is all the entries need of φ); ψ from φ + ψ (for
    /// θ ≤ π/2) or φ − ψ (beyond), taken from 2×2 minors that stay well conditioned near θ = 0 and
    /// θ = π respectively, so that the large entries, which depend on φ ± ψ, come back exactly.
    /// φ and ψ are in `(−π, π]`.
    ///
    /// # Errors
    /// [`Singular`] at θ = 0 or π exactly (`sin θ = 0`).
    pub fn from_matrix(a: &Matrix3<f64>) -> Result<Self, Singular> {
        let s = a[(0, 2)].hypot(a[(1, 2)]);
        if s == 0.0 {
            return Err(Singular {
                representation: "Euler angles z-x-z",
                reason: "θ = 0 or π (gimbal lock: only φ ± ψ is defined)",
            });
        }
        let theta = s.atan2(a[(2, 2)]);
        // a13 = sθ sφ, a23 = −sθ cφ with sθ > 0.
        let phi = wrap(a[(0, 2)].atan2(-a[(1, 2)]));
        let psi = if a[(2, 2)] >= 0.0 {
            // a21 − a12 = (1 + cθ) sin(φ+ψ), a11 + a22 = (1 + cθ) cos(φ+ψ).
            (a[(1, 0)] - a[(0, 1)]).atan2(a[(0, 0)] + a[(1, 1)]) - phi
        } else {
            // a21 + a12 = (1 − cθ) sin(φ−ψ), a11 − a22 = (1 − cθ) cos(φ−ψ).
            phi - (a[(1, 0)] + a[(0, 1)]).atan2(a[(0, 0)] - a[(1, 1)])
        };
        Ok(EulerZxz {
            phi,
            theta,
            psi: wrap(psi),
        })
    }

    /// Euler parameters (sec. 2.7): `e₀ = cos(θ/2) cos((φ+ψ)/2)`, `e₁ = sin(θ/2) cos((φ−ψ)/2)`,
    /// `e₂ = sin(θ/2) sin((φ−ψ)/2)`, `e₃ = cos(θ/2) sin((φ+ψ)/2)`.
    #[must_use]
    pub fn to_euler_parameters(&self) -> EulerParameters {
        let (st, ct) = (0.5 * self.theta).sin_cos();
        let (ss, cs) = (0.5 * (self.phi + self.psi)).sin_cos();
        let (sd, cd) = (0.5 * (self.phi - self.psi)).sin_cos();
        EulerParameters {
            e0: ct * cs,
            e1: st * cd,
            e2: st * sd,
            e3: ct * ss,
        }
    }

    /// `G` with `ω = G [φ̇, θ̇, ψ̇]` (sec. 2.7).
    #[must_use]
    pub fn g_matrix(&self) -> Matrix3<f64> {
        let (sp, cp) = self.phi.sin_cos();
        let (st, ct) = self.theta.sin_cos();
        Matrix3::new(0.0, cp, st * sp, 0.0, sp, -st * cp, 1.0, 0.0, ct)
    }

    /// `Ḡ` with `ω̄ = Ḡ [φ̇, θ̇, ψ̇]`.
    #[must_use]
    pub fn g_bar_matrix(&self) -> Matrix3<f64> {
        let (ss, cs) = self.psi.sin_cos();
        let (st, ct) = self.theta.sin_cos();
        Matrix3::new(st * ss, cs, 0.0, st * cs, -ss, 0.0, ct, 0.0, 1.0)
    }

    /// Angle rates from the global angular velocity, `G⁻¹ ω` (Example 2.9).
    ///
    /// # Errors
    /// [`Singular`] when |sin θ| < [`RATE_SINGULARITY`].
    pub fn rates(&self, omega: &Vector3<f64>) -> Result<Vector3<f64>, Singular> {
        let (sp, cp) = self.phi.sin_cos();
        let (st, ct) = self.theta.sin_cos();
        if st.abs() < RATE_SINGULARITY {
            return Err(Singular {
                representation: "z-x-z angle rates",
                reason: "sin θ = 0 (gimbal lock)",
            });
        }
        let g_inv = Matrix3::new(-sp * ct, cp * ct, st, st * cp, st * sp, 0.0, sp, -cp, 0.0) / st;
        Ok(g_inv * omega)
    }

    /// Angle rates from the body angular velocity, `Ḡ⁻¹ ω̄`.
    ///
    /// # Errors
    /// [`Singular`] when |sin θ| < [`RATE_SINGULARITY`].
    pub fn rates_from_local(&self, omega_local: &Vector3<f64>) -> Result<Vector3<f64>, Singular> {
        let (ss, cs) = self.psi.sin_cos();
        let (st, ct) = self.theta.sin_cos();
        if st.abs() < RATE_SINGULARITY {
            return Err(Singular {
                representation: "z-x-z angle rates",
                reason: "sin θ = 0 (gimbal lock)",
            });
        }
        let g_inv = Matrix3::new(ss, cs, 0.0, st * cs, -st * ss, 0.0, -ss * ct, -cs * ct, st) / st;
        Ok(g_inv * omega_local)
    }
}

/// Euler angles of the x-y-z sequence (rotations about the body x, then the new y, then the
/// new z axis, as in aerospace and automotive use): `A = Rx(φ) Ry(θ) Rz(ψ)`, θ in `[−π/2, π/2]`.
/// Singular at θ = ±π/2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EulerXyz {
    /// First rotation, about x.
    pub phi: f64,
    /// Second rotation, about the new y.
    pub theta: f64,
    /// Third rotation, about the new z.
    pub psi: f64,
}

impl EulerXyz {
    /// The rotation matrix.
    #[must_use]
    pub fn to_matrix(&self) -> Matrix3<f64> {
        rot_x(self.phi) * rot_y(self.theta) * rot_z(self.psi)
    }

    /// The angles of a rotation matrix: θ = atan2(a₁₃, √(a₁₁² + a₁₂²)), φ = atan2(−a₂₃, a₃₃), and
    /// ψ from φ + ψ (θ ≥ 0) or ψ − φ (θ < 0), taken from 2×2 minors as for z-x-z. φ and ψ are in
    /// `(−π, π]`.
    ///
    /// # Errors
    /// [`Singular`] at θ = ±π/2 exactly (`cos θ = 0`).
    pub fn from_matrix(a: &Matrix3<f64>) -> Result<Self, Singular> {
        let c = a[(0, 0)].hypot(a[(0, 1)]);
        if c == 0.0 {
            return Err(Singular {
                representation: "Euler angles x-y-z",
                reason: "θ = ±π/2 (gimbal lock: only φ ± ψ is defined)",
            });
        }
        let theta = a[(0, 2)].atan2(c);
        // a23 = −sφ cθ, a33 = cφ cθ with cθ > 0.
        let phi = wrap((-a[(1, 2)]).atan2(a[(2, 2)]));
        let psi = if a[(0, 2)] >= 0.0 {
            // a21 + a32 = (1 + sθ) sin(φ+ψ), a22 − a31 = (1 + sθ) cos(φ+ψ).
            (a[(1, 0)] + a[(2, 1)]).atan2(a[(1, 1)] - a[(2, 0)]) - phi
        } else {
            // a21 − a32 = (1 − sθ) sin(ψ−φ), a22 + a31 = (1 − sθ) cos(ψ−φ).
            (a[(1, 0)] - a[(2, 1)]).atan2(a[(1, 1)] + a[(2, 0)]) + phi
        };
        Ok(EulerXyz {
            phi,
            theta,
            psi: wrap(psi),
        })
    }

    /// `G` with `ω = G [φ̇, θ̇, ψ̇]`: the columns are the x axis, `Rx(φ)` y and `Rx(φ) Ry(θ)` z.
    #[must_use]
    pub fn g_matrix(&self) -> Matrix3<f64> {
        let (sp, cp) = self.phi.sin_cos();
        let (st, ct) = self.theta.sin_cos();
        Matrix3::new(1.0, 0.0, st, 0.0, cp, -sp * ct, 0.0, sp, cp * ct)
    }

    /// `Ḡ` with `ω̄ = Ḡ [φ̇, θ̇, ψ̇]`.
    #[must_use]
    pub fn g_bar_matrix(&self) -> Matrix3<f64> {
        let (ss, cs) = self.psi.sin_cos();
        let (st, ct) = self.theta.sin_cos();
        Matrix3::new(ct * cs, ss, 0.0, -ct * ss, cs, 0.0, st, 0.0, 1.0)
    }

    /// Angle rates from the global angular velocity, `G⁻¹ ω`.
    ///
    /// # Errors
    /// [`Singular`] when |cos θ| < [`RATE_SINGULARITY`].
    pub fn rates(&self, omega: &Vector3<f64>) -> Result<Vector3<f64>, Singular> {
        let (sp, cp) = self.phi.sin_cos();
        let (st, ct) = self.theta.sin_cos();
        if ct.abs() < RATE_SINGULARITY {
            return Err(Singular {
                representation: "x-y-z angle rates",
                reason: "cos θ = 0 (gimbal lock)",
            });
        }
        let g_inv = Matrix3::new(ct, sp * st, -cp * st, 0.0, cp * ct, sp * ct, 0.0, -sp, cp) / ct;
        Ok(g_inv * omega)
    }

    /// Angle rates from the body angular velocity, `Ḡ⁻¹ ω̄`.
    ///
    /// # Errors
    /// [`Singular`] when |cos θ| < [`RATE_SINGULARITY`].
    pub fn rates_from_local(&self, omega_local: &Vector3<f64>) -> Result<Vector3<f64>, Singular> {
        let (ss, cs) = self.psi.sin_cos();
        let (st, ct) = self.theta.sin_cos();
        if ct.abs() < RATE_SINGULARITY {
            return Err(Singular {
                representation: "x-y-z angle rates",
                reason: "cos θ = 0 (gimbal lock)",
            });
        }
        let g_inv = Matrix3::new(cs, -ss, 0.0, ct * ss, ct * cs, 0.0, -st * cs, st * ss, ct) / ct;
        Ok(g_inv * omega_local)
    }
}

/// URDF roll–pitch–yaw: `R = Rz(yaw) Ry(pitch) Rx(roll)` (rotations about the fixed x, y, z axes),
/// pitch in `[−π/2, π/2]`. Singular at pitch = ±π/2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rpy {
    /// About x, first.
    pub roll: f64,
    /// About y.
    pub pitch: f64,
    /// About z, last.
    pub yaw: f64,
}

impl Rpy {
    /// The rotation matrix.
    #[must_use]
    pub fn to_matrix(&self) -> Matrix3<f64> {
        rot_z(self.yaw) * rot_y(self.pitch) * rot_x(self.roll)
    }

    /// The angles of a rotation matrix: pitch = atan2(−a₃₁, √(a₁₁² + a₂₁²)), roll = atan2(a₃₂, a₃₃),
    /// and yaw from roll − yaw (pitch ≥ 0) or roll + yaw (pitch < 0), taken from 2×2 minors. Roll
    /// and yaw are in `(−π, π]`.
    ///
    /// # Errors
    /// [`Singular`] at pitch = ±π/2 exactly.
    pub fn from_matrix(a: &Matrix3<f64>) -> Result<Self, Singular> {
        let c = a[(0, 0)].hypot(a[(1, 0)]);
        if c == 0.0 {
            return Err(Singular {
                representation: "roll-pitch-yaw",
                reason: "pitch = ±π/2 (gimbal lock: only roll ± yaw is defined)",
            });
        }
        let pitch = (-a[(2, 0)]).atan2(c);
        // a32 = cp sr, a33 = cp cr with cp > 0.
        let roll = wrap(a[(2, 1)].atan2(a[(2, 2)]));
        let yaw = if a[(2, 0)] <= 0.0 {
            // a12 − a23 = (1 + sp) sin(r − y), a13 + a22 = (1 + sp) cos(r − y).
            roll - (a[(0, 1)] - a[(1, 2)]).atan2(a[(0, 2)] + a[(1, 1)])
        } else {
            // −(a12 + a23) = (1 − sp) sin(r + y), a22 − a13 = (1 − sp) cos(r + y).
            (-(a[(0, 1)] + a[(1, 2)])).atan2(a[(1, 1)] - a[(0, 2)]) - roll
        };
        Ok(Rpy {
            roll,
            pitch,
            yaw: wrap(yaw),
        })
    }
}
