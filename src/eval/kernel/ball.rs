//! The body of a ball joint: a rotation of the child relative to the parent by the Euler
//! parameters `e = (e0, e1, e2, e3)` (the quaternion's w, x, y, z) read from `q`, about the joint
//! origin, and its rates, which are entries of `q̇` and `q̈`.
//!
//! The body's frame is `parent · pre · [A(e) 0] · post` (eq. 2.109 with no translation), `A(e)`
//! the rotation matrix of the Euler parameters (eq. 2.13) of `e / |e|`, written with
//! `s = 2 / (e · e)` as [`crate::eval::kernel::floating`] writes it (a quaternion off unit length
//! by rounding is the rotation it stands for; the checks refuse one farther off).
//!
//! Rates. The joint's three entries of `q̇` are `w`, the child's angular velocity relative to
//! the parent in world axes, and those of `q̈` are `ε`, the rate of `w` as the parent sees it,
//! in world axes (`ε = A_p u̇` for `w = A_p u`, `u` in the parent's axes; the same as
//! `A ẇ_local` in the child's, so MuJoCo's and Pinocchio's body-frame accelerations turn into it
//! by the child's rotation alone). These are the terms a revolute joint's `θ̇ z` and `θ̈ z`
//! stand for, and with `p_j` the joint origin, `u = o − p_j` the child origin from it and `r`
//! from the parent's origin, the recursion of eqs. 2.120–2.127 becomes
//!
//! ```text
//! ω = ω_p + w                    v = v_p + ω_p × r + w × u
//! α = α_p + ω_p × w + ε          a = a_p + α_p × r + ω_p × (ω_p × r) + 2 ω_p × (w × u)
//!                                      + ε × u + w × (w × u)
//! ```
//!
//! (the Coriolis term from differentiating `w × u` with `u̇ = (ω_p + w) × u` and `ẇ = ω_p × w + ε`,
//! by the Jacobi identity). The Jacobian's three columns of the joint are a turn about each world
//! axis `e_k` through `p_j`, `[e_k × (p − p_j); e_k]`, and their rates those of three revolute
//! axes fixed in the parent's frame, `ė_k = ω_p × e_k`.
//!
//! A floating joint other than the floating base is the same body with a translation `t` (three
//! entries of `q` before the quaternion, in the joint frame): its frame is
//! `parent · pre · [A(e) t] · post`, and its six entries of `q̇` are `(v_rel, w)`: the velocity of
//! the body's origin relative to the parent and the angular velocity relative to it, in world
//! axes; those of `q̈` `(a_rel, ε)` their rates as the parent sees them, in world axes — for a
//! body hanging from the world, its own velocity and acceleration, as for the floating base
//! (`crate::eval::kernel::floating`). Relative motion (eqs. 2.120–2.127 with a moving point) gives
//!
//! ```text
//! ω = ω_p + w                    v = v_p + ω_p × r + v_rel
//! α = α_p + ω_p × w + ε          a = a_p + α_p × r + ω_p × (ω_p × r) + 2 ω_p × v_rel + a_rel
//! ```
//!
//! and the joint's six Jacobian columns are, for each world axis `e_k`, a slide along it
//! `[e_k; 0]` and a turn about it through the body's origin `[e_k × (p − o); e_k]`, both fixed in
//! the parent's frame (`ė_k = ω_p × e_k`).

use crate::eval::kernel::frame::{Frame, mat_vec_add};
use crate::eval::layout::body::Ball;
use crate::eval::simd::traits::{Arith, Col, Num};

/// Marks the path that calls it as rarely taken (a call to a cold function, which the compiler
/// lays out of the way, keeping its registers for the other paths): the ball step inside the
/// batch kernels, so that chains without ball joints keep their register allocation (inlined
/// without it, the ball step made the Panda's batch of poses spill more: 2 % more instructions
/// under callgrind).
#[cold]
#[inline(never)]
pub(crate) fn rarely() {}

/// The columns of `A(e)` (eq. 2.13) of the normalised `e`: `s = 2 / (e · e)`, then each entry's
/// expression, in plain operations (no fused multiply–add), the same on every path.
#[inline(always)]
pub(crate) fn columns<N: Num>([e0, e1, e2, e3]: [N; 4]) -> [[N; 3]; 3] {
    let s = (((e0 * e0 + e1 * e1) + e2 * e2) + e3 * e3).two_over();
    let one = N::splat(1.0);
    [
        [
            one - s * (e2 * e2 + e3 * e3),
            s * (e1 * e2 + e0 * e3),
            s * (e1 * e3 - e0 * e2),
        ],
        [
            s * (e1 * e2 - e0 * e3),
            one - s * (e1 * e1 + e3 * e3),
            s * (e2 * e3 + e0 * e1),
        ],
        [
            s * (e1 * e3 + e0 * e2),
            s * (e2 * e3 - e0 * e1),
            one - s * (e1 * e1 + e2 * e2),
        ],
    ]
}

/// The quaternion of `ball` in `q`.
#[inline(always)]
pub(crate) fn quaternion<N: Copy>(ball: Ball, q: &[N]) -> [N; 4] {
    let i = ball.quaternion();
    [q[i], q[i + 1], q[i + 2], q[i + 3]]
}

/// `f ← f · [A(e) 0]` on lanes (`f ← f · [A(e) t]` for a free body): each new column `r a_c`,
/// summed as a general placement's (`kernel::frame::place`), with the coefficients of the lane's
/// own `A(e)`.
#[inline(always)]
pub(crate) fn turn_lanes<N: Num, A: Arith>(f: &mut Frame<N>, ball: Ball, q: &[N]) {
    if ball.free {
        let t = [q[ball.q], q[ball.q + 1], q[ball.q + 2]];
        f.p = mat_vec_add::<N, A>(&f.r, &t, f.p);
    }
    let a = columns(quaternion(ball, q));
    let (r, zero) = (f.r, [N::splat(0.0); 3]);
    f.r = [
        mat_vec_add::<N, A>(&r, &a[0], zero),
        mat_vec_add::<N, A>(&r, &a[1], zero),
        mat_vec_add::<N, A>(&r, &a[2], zero),
    ];
}

/// `f ← f · [A(e) 0]` (`[A(e) t]` for a free body) on padded columns: the operations of
/// [`turn_lanes`], so the same bits.
#[inline(always)]
pub(crate) fn turn_columns<C: Col>(f: &mut [C; 4], ball: Ball, q: &[f64]) {
    let r = *f;
    // `r₀ u₀ + (r₁ u₁ + (r₂ u₂ + p))`: `mat_vec_add`'s order.
    let column = |u: [f64; 3], p: C| {
        C::mul_add(
            r[0],
            C::splat(u[0]),
            C::mul_add(r[1], C::splat(u[1]), C::mul_add(r[2], C::splat(u[2]), p)),
        )
    };
    if ball.free {
        f[3] = column([q[ball.q], q[ball.q + 1], q[ball.q + 2]], r[3]);
    }
    let a = columns(quaternion(ball, q));
    let zero = C::splat(0.0);
    f[0] = column(a[0], zero);
    f[1] = column(a[1], zero);
    f[2] = column(a[2], zero);
}

/// The joint's `w` (from `q̇`) or `ε` (from `q̈`): its angular rates.
#[inline(always)]
pub(crate) fn rate<N: Copy>(ball: Ball, rates: &[N]) -> [N; 3] {
    let i = ball.angular();
    [rates[i], rates[i + 1], rates[i + 2]]
}

/// A free body's `v_rel` (from `q̇`) or `a_rel` (from `q̈`): its linear rates.
#[inline(always)]
pub(crate) fn linear_rate<N: Copy>(ball: Ball, rates: &[N]) -> [N; 3] {
    [rates[ball.v], rates[ball.v + 1], rates[ball.v + 2]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::simd::portable::Separate;

    #[test]
    fn the_columns_are_the_euler_parameters_matrix_of_the_normalised_quaternion() {
        let e = [0.3, -0.5, 0.7, 0.2];
        let n = e.iter().map(|x| x * x).sum::<f64>().sqrt();
        let ep = crate::orientation::EulerParameters {
            e0: e[0] / n,
            e1: e[1] / n,
            e2: e[2] / n,
            e3: e[3] / n,
        };
        let want = ep.to_matrix();
        let a = columns(e);
        for c in 0..3 {
            for i in 0..3 {
                assert!((a[c][i] - want[(i, c)]).abs() < 4e-16, "{c} {i}");
            }
        }
    }

    #[test]
    fn lanes_and_columns_turn_a_frame_alike_and_as_the_matrix_product() {
        let t = crate::model::transform::Transform::from_xyz_rpy([0.1, 0.2, 0.3], [0.4, -1.1, 2.0]);
        let ball = Ball {
            q: 1,
            v: 0,
            free: false,
        };
        let q = [9.0, 0.6, 0.0, -0.8, 0.1];
        let mut lanes = Frame::<f64>::splat(&t);
        turn_lanes::<f64, Separate>(&mut lanes, ball, &q);
        let pad = |v: [f64; 3]| <Separate as Arith>::Col::load(&[v[0], v[1], v[2], 0.0]);
        let mut cols = [pad(t.r[0]), pad(t.r[1]), pad(t.r[2]), pad(t.p)];
        turn_columns(&mut cols, ball, &q);
        let a = columns([0.6, 0.0, -0.8, 0.1]);
        for c in 0..3 {
            let mut got = [0.0; 4];
            cols[c].store(&mut got);
            assert_eq!(got[..3], lanes.r[c]);
            let want = t.apply(a[c]);
            for i in 0..3 {
                assert!((got[i] - want[i]).abs() < 1e-15);
            }
        }
        assert_eq!(lanes.p, t.p);
    }
}
