//! The body of a floating joint: its frame from the position and Euler parameters in `q`, and
//! its rates, which are entries of `q̇` and `q̈`.
//!
//! With `p = (x, y, z)` and `e = (e0, e1, e2, e3)` (the quaternion's w, x, y, z) the first seven
//! entries of `q`, the body's frame is `pre · [A(e) p; 0 1] · post` (eq. 2.109), `A(e)` the
//! rotation matrix of the Euler parameters (eq. 2.13) of `e / |e|`. Written with
//! `s = 2 / (e · e)`, the entries `1 − s (e2² + e3²)`, `s (e1 e2 − e0 e3)`, … are those of the
//! normalised parameters, so that a quaternion off unit length by rounding (as logs store them)
//! is used as the rotation it stands for; the checks refuse one farther off
//! ([`QUATERNION_TOLERANCE`]).
//!
//! The joint hangs from the world, so its rates relative to its parent are the body's own: the
//! first six entries of `q̇` are the velocity of the body's origin and its angular velocity, and
//! those of `q̈` their time derivatives (the classical acceleration of the origin and the
//! angular acceleration), all in world axes. The Euler parameters' rate follows from the angular
//! velocity by eq. 2.46, `ω = 2 E ė` (as `ė = ½ Eᵀ ω` for unit `e`).
//!
//! The frame is computed in plain `f64` operations (no fused multiply–add), once per
//! configuration, by the single and the batch kernels alike: the same bits on every path and
//! instruction set.

use crate::eval::layout::body::Body;
use crate::model::transform::Transform;

/// How far the norm of a floating joint's quaternion may be from 1 for `q` to be evaluated
/// (as the rotation of the normalised quaternion): `| |e| − 1 | ≤ 10⁻³`. Quaternions written with
/// four decimals (0.7071) or stored in single precision pass; a zero, or one off by a factor,
/// is an error naming the joint.
pub const QUATERNION_TOLERANCE: f64 = 1e-3;

/// Whether `e` (four entries) is a quaternion the kernels evaluate: finite, with a norm within
/// [`QUATERNION_TOLERANCE`] of 1.
#[must_use]
pub(crate) fn admits(e: &[f64]) -> bool {
    let [e0, e1, e2, e3] = match e {
        &[a, b, c, d] => [a, b, c, d],
        _ => return false,
    };
    // The batch kernels' lane check sums in this order too.
    let n2 = ((e0 * e0 + e1 * e1) + e2 * e2) + e3 * e3;
    let (lo, hi) = squared_norm_band();
    n2 >= lo && n2 <= hi
}

/// The squared norms a quaternion may have: `[(1 − tol)², (1 + tol)²]`.
#[must_use]
pub(crate) fn squared_norm_band() -> (f64, f64) {
    (
        (1.0 - QUATERNION_TOLERANCE) * (1.0 - QUATERNION_TOLERANCE),
        (1.0 + QUATERNION_TOLERANCE) * (1.0 + QUATERNION_TOLERANCE),
    )
}

/// The frame of the floating joint's body at `q` (its first seven entries; `q` holds at least
/// seven). Out of line, and marked cold: the kernels of chains without a floating joint test
/// one flag for it at their root bodies and keep their code as it was.
#[cold]
#[inline(never)]
#[must_use]
pub(crate) fn frame(body: &Body, q: &[f64]) -> Transform {
    placed(body, own(q))
}

/// The motion `[A(e) p]` of the joint at `q`, before `pre` and `post`: eq. 2.13 of the
/// normalised parameters, column by column (`r[c]` is column `c`). The batch kernels compute the
/// same expressions on lanes (`pose_lanes::floating_frame`).
#[inline(always)]
#[must_use]
pub(crate) fn own(q: &[f64]) -> Transform {
    let r = crate::eval::kernel::ball::columns([q[3], q[4], q[5], q[6]]);
    Transform {
        r,
        p: [q[0], q[1], q[2]],
    }
}

/// `pre · own · post`, each product only when its placement is not the identity (the usual
/// floating base has neither).
#[inline]
pub(crate) fn placed(body: &Body, own: Transform) -> Transform {
    use crate::eval::layout::body::Placement;
    let before = match body.pre {
        Placement::Identity => own,
        _ => body.pre_frame * own,
    };
    match body.post {
        Placement::Identity => before,
        post => before * post.to_transform(),
    }
}

/// The body's angular velocity, origin velocity, angular acceleration and classical origin
/// acceleration (world axes): entries 3–5 and 0–2 of `q_dot`, then of `q_ddot` (zero without).
#[inline]
#[must_use]
pub(crate) fn rates(q_dot: &[f64], q_ddot: Option<&[f64]>) -> [[f64; 3]; 4] {
    let three = |a: &[f64], i: usize| [a[i], a[i + 1], a[i + 2]];
    let (alpha, a) = match q_ddot {
        Some(dd) => (three(dd, 3), three(dd, 0)),
        None => ([0.0; 3], [0.0; 3]),
    };
    [three(q_dot, 3), three(q_dot, 0), alpha, a]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::layout::body::Placement;
    use crate::model::joint::{Axis, Motion, Term};

    fn body(pre: Transform) -> Body {
        Body::new(
            None,
            Placement::from_transform(&pre),
            Motion::new(Axis::Z, Term::Const(0.0), Term::Const(0.0)),
            Placement::Identity,
            0,
        )
    }

    #[test]
    fn the_frame_is_the_euler_parameters_rotation_of_the_normalised_quaternion() {
        let b = body(Transform::IDENTITY);
        // A turn of 90° about z: e = (cos 45°, 0, 0, sin 45°).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let f = frame(&b, &[1.0, 2.0, 3.0, h, 0.0, 0.0, h]);
        let x = f.apply([1.0, 0.0, 0.0]);
        assert!((x[0]).abs() < 1e-15 && (x[1] - 1.0).abs() < 1e-15 && x[2] == 0.0);
        assert_eq!(f.p, [1.0, 2.0, 3.0]);
        // The same rotation from a quaternion scaled off unit length (and negated): the same
        // matrix within rounding.
        let g = frame(&b, &[1.0, 2.0, 3.0, -h * 1.0005, 0.0, 0.0, -h * 1.0005]);
        for c in 0..3 {
            for i in 0..3 {
                assert!((f.r[c][i] - g.r[c][i]).abs() < 1e-15);
            }
        }
        // Against the orientation module's Euler parameters (eq. 2.13) for a general one.
        let e = [0.3, -0.5, 0.7, 0.2];
        let n = e.iter().map(|x| x * x).sum::<f64>().sqrt();
        let unit = e.map(|x| x / n);
        let ep = crate::orientation::EulerParameters {
            e0: unit[0],
            e1: unit[1],
            e2: unit[2],
            e3: unit[3],
        };
        let want = ep.to_matrix();
        let f = frame(&b, &[0.0, 0.0, 0.0, e[0], e[1], e[2], e[3]]);
        for c in 0..3 {
            for i in 0..3 {
                assert!((f.r[c][i] - want[(i, c)]).abs() < 4e-16, "{c} {i}");
            }
        }
    }

    #[test]
    fn the_joint_origin_places_the_motion() {
        let pre = Transform::from_xyz_rpy([0.5, 0.0, 0.0], [0.0, 0.0, std::f64::consts::FRAC_PI_2]);
        let f = frame(&body(pre), &[1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
        // The translation along the joint frame's x, which the origin turned onto world y.
        assert!((f.p[0] - 0.5).abs() < 1e-15 && (f.p[1] - 1.0).abs() < 1e-15);
    }

    #[test]
    #[allow(clippy::approx_constant)] // 0.7071: a quaternion written with four decimals
    fn quaternions_are_admitted_near_unit_length_only() {
        assert!(admits(&[1.0, 0.0, 0.0, 0.0]));
        // Written with four decimals.
        let h = 0.7071_f64;
        assert!(admits(&[h, 0.0, 0.0, h]));
        assert!(admits(&[1.0 + 9e-4, 0.0, 0.0, 0.0]));
        assert!(!admits(&[1.0 + 2e-3, 0.0, 0.0, 0.0]));
        assert!(!admits(&[0.0; 4]));
        assert!(!admits(&[f64::NAN, 0.0, 0.0, 1.0]));
        assert!(!admits(&[f64::INFINITY, 0.0, 0.0, 1.0]));
        assert!(!admits(&[2.0, 0.0, 0.0, 0.0]));
    }
}
