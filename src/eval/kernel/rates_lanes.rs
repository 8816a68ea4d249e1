//! The rate recursion of [`crate::eval::padded`] (eqs. 2.120, 2.123–2.125 for a joint, 2.75 for
//! the composition) on lanes: the same operations, in the same order, on each configuration of a
//! chunk, so that batched velocities and accelerations equal single evaluations bit for bit.
//! A padded column's shuffles (`yzx`, `zxy`) become index permutations of three lane values.

use crate::eval::kernel::frame::{Frame, V3};
use crate::eval::layout::body::{Body, RateTerm};
use crate::eval::simd::traits::{Arith, Num};

/// Motion of a body in the world frame: ω, v (origin), α, a (origin, classical).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Motion<N> {
    pub(crate) omega: V3<N>,
    pub(crate) v: V3<N>,
    pub(crate) alpha: V3<N>,
    pub(crate) a: V3<N>,
}

impl<N: Num> Motion<N> {
    #[inline(always)]
    pub(crate) fn zero() -> Self {
        let z = [N::splat(0.0); 3];
        Motion {
            omega: z,
            v: z,
            alpha: z,
            a: z,
        }
    }
}

#[inline(always)]
fn yzx<N: Copy>(a: V3<N>) -> V3<N> {
    [a[1], a[2], a[0]]
}

#[inline(always)]
fn zxy<N: Copy>(a: V3<N>) -> V3<N> {
    [a[2], a[0], a[1]]
}

#[inline(always)]
fn add<N: Num>(a: V3<N>, b: V3<N>) -> V3<N> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline(always)]
fn sub<N: Num>(a: V3<N>, b: V3<N>) -> V3<N> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a × b` as `crate::eval::kernel::rates_columns::cross` computes it.
#[inline(always)]
fn cross<N: Num>(a: V3<N>, b: V3<N>) -> V3<N> {
    let (a1, b1, a2, b2) = (yzx(a), zxy(b), zxy(a), yzx(b));
    std::array::from_fn(|k| a1[k] * b1[k] - a2[k] * b2[k])
}

/// `a × b + c` as `crate::eval::kernel::rates_columns::cross_add` computes it.
#[inline(always)]
fn cross_add<N: Num, A: Arith>(a: V3<N>, b: V3<N>, c: V3<N>) -> V3<N> {
    let (a1, b1, a2, b2) = (yzx(a), zxy(b), zxy(a), yzx(b));
    std::array::from_fn(|k| N::mul_add::<A>(a1[k], b1[k], N::mul_add::<A>(-a2[k], b2[k], c[k])))
}

/// `s x`.
#[inline(always)]
fn scale<N: Num>(s: N, x: V3<N>) -> V3<N> {
    x.map(|x| s * x)
}

/// Rate of a θ or d term given `q_dot` (or `q_ddot`) in lanes.
#[inline(always)]
fn term_rate<N: Num>(t: RateTerm, rates: &[N]) -> N {
    N::splat(t.scale) * rates[t.index]
}

/// `α_p + ω_p × θ̇ z + θ̈ z` (eq. 2.123).
#[inline(always)]
fn angular_acceleration<N: Num, A: Arith>(
    parent: &Motion<N>,
    z: V3<N>,
    th_d: N,
    th_dd: N,
) -> V3<N> {
    add(
        parent.alpha,
        cross_add::<N, A>(parent.omega, scale(th_d, z), scale(th_dd, z)),
    )
}

/// The frame and motion of a body's parent (`None`: the world, at rest).
pub(crate) type Parent<'a, N> = Option<(&'a Frame<N>, &'a Motion<N>)>;

/// `crate::eval::kernel::rates_columns::rates_on_parent_z` on lanes.
#[inline(always)]
fn on_parent_z<N: Num, A: Arith, const ACC: bool>(
    parent: Parent<'_, N>,
    body: &Body,
    f: &Frame<N>,
    q_dot: &[N],
    q_ddot: &[N],
) -> Motion<N> {
    let zero = [N::splat(0.0); 3];
    let (z, p_parent, parent) = match parent {
        Some((frame, motion)) => (frame.r[2], frame.p, *motion),
        None => (body.axis_in_parent.map(N::splat), zero, Motion::zero()),
    };
    let slides = body.rate_shape & Body::SLIDES != 0;
    let th_d = term_rate(body.theta_rate, q_dot);
    let r = sub(f.p, p_parent);
    let omega = crate::eval::kernel::frame::axpy::<N, A>(th_d, z, parent.omega);
    let w_r = cross(omega, r);
    let mut out = Motion {
        omega,
        v: add(parent.v, w_r),
        alpha: zero,
        a: zero,
    };
    if slides {
        out.v = crate::eval::kernel::frame::axpy::<N, A>(term_rate(body.d_rate, q_dot), z, out.v);
    }
    if ACC {
        let th_dd = term_rate(body.theta_rate, q_ddot);
        let alpha = angular_acceleration::<N, A>(&parent, z, th_d, th_dd);
        let mut a = cross_add::<N, A>(alpha, r, cross(omega, w_r));
        if slides {
            let d_d = term_rate(body.d_rate, q_dot);
            a = cross_add::<N, A>(omega, scale(N::splat(2.0) * d_d, z), a);
            a = crate::eval::kernel::frame::axpy::<N, A>(term_rate(body.d_rate, q_ddot), z, a);
        }
        out.alpha = alpha;
        out.a = add(parent.a, a);
    }
    out
}

/// `crate::eval::kernel::rates_columns::rates_sliding` on lanes.
#[inline(always)]
fn sliding<N: Num, A: Arith, const ACC: bool>(
    parent: Parent<'_, N>,
    body: &Body,
    f: &Frame<N>,
    z: V3<N>,
    q_dot: &[N],
    q_ddot: &[N],
) -> Motion<N> {
    let zero = [N::splat(0.0); 3];
    let (p_parent, parent) = match parent {
        Some((frame, motion)) => (frame.p, *motion),
        None => (zero, Motion::zero()),
    };
    let r = sub(f.p, p_parent);
    let w_r = cross(parent.omega, r);
    let slides = body.rate_shape & Body::SLIDES != 0;
    let v_rel = scale(term_rate(body.d_rate, q_dot), z);
    let v = add(parent.v, w_r);
    let mut out = Motion {
        omega: parent.omega,
        v: if slides { add(v, v_rel) } else { v },
        alpha: parent.alpha,
        a: zero,
    };
    if ACC {
        let near = if slides {
            let local = cross_add::<N, A>(
                parent.omega,
                scale(N::splat(2.0), v_rel),
                scale(term_rate(body.d_rate, q_ddot), z),
            );
            cross_add::<N, A>(parent.alpha, r, local)
        } else {
            cross(parent.alpha, r)
        };
        let a = add(near, cross(parent.omega, w_r));
        out.a = add(parent.a, a);
    }
    out
}

/// The motion of a ball joint's body with frame `f`: the operations of
/// `crate::eval::kernel::rates_columns::rates_ball` on lanes, so the same bits.
#[inline(always)]
fn ball_motion<N: Num, A: Arith, const ACC: bool>(
    parent: Parent<'_, N>,
    body: &Body,
    ball: crate::eval::layout::body::Ball,
    f: &Frame<N>,
    q_dot: &[N],
    q_ddot: &[N],
) -> Motion<N> {
    let zero = [N::splat(0.0); 3];
    let (p_joint, p_parent, parent) = match parent {
        Some((frame, motion)) => (
            crate::eval::kernel::frame::apply_const_add::<N, A>(
                &frame.r,
                body.pre_frame.p,
                frame.p,
            ),
            frame.p,
            *motion,
        ),
        None => (body.pre_frame.p.map(N::splat), zero, Motion::zero()),
    };
    let w = crate::eval::kernel::ball::rate(ball, q_dot);
    let (r, u) = (sub(f.p, p_parent), sub(f.p, p_joint));
    // A free body's relative velocity is its own entry of `q̇`; a ball's, the turn about `p_j`.
    let v_rel = match ball.free {
        true => crate::eval::kernel::ball::linear_rate(ball, q_dot),
        false => cross(w, u),
    };
    let w_r = cross(parent.omega, r);
    let mut out = Motion {
        omega: add(parent.omega, w),
        v: add(add(parent.v, w_r), v_rel),
        alpha: zero,
        a: zero,
    };
    if ACC {
        let eps = crate::eval::kernel::ball::rate(ball, q_ddot);
        out.alpha = add(parent.alpha, cross_add::<N, A>(parent.omega, w, eps));
        let mut a = cross_add::<N, A>(parent.alpha, r, cross(parent.omega, w_r));
        a = cross_add::<N, A>(parent.omega, scale(N::splat(2.0), v_rel), a);
        a = match ball.free {
            true => add(a, crate::eval::kernel::ball::linear_rate(ball, q_ddot)),
            false => cross_add::<N, A>(w, v_rel, cross_add::<N, A>(eps, u, a)),
        };
        out.a = add(parent.a, a);
    }
    out
}

/// The motion of a body whose frame is `f` (from [`crate::eval::kernel::pose_lanes::pose_step`]), from its parent's:
/// `crate::eval::kernel::rates_columns::body_rates` on lanes. With `ACC = false`, α and a are zero.
#[inline(always)]
pub(crate) fn body_motion<N: Num, A: Arith, const ACC: bool>(
    parent: Parent<'_, N>,
    body: &Body,
    f: &Frame<N>,
    q_dot: &[N],
    q_ddot: &[N],
) -> Motion<N> {
    let zero = [N::splat(0.0); 3];
    let shape = body.rate_shape;
    let (z, z_u) = if shape & Body::NO_POST != 0 {
        let z = if shape & Body::ABOUT_Z != 0 {
            f.r[2]
        } else {
            crate::eval::kernel::pose_lanes::axis_of::<N, A>(&f.r, &body.motion.axis)
        };
        if shape & Body::TURNS == 0 {
            return sliding::<N, A, ACC>(parent, body, f, z, q_dot, q_ddot);
        }
        (z, None)
    } else {
        if shape & (Body::ON_PARENT_Z | Body::BALL) != 0 {
            return match body.ball {
                Some(ball) => ball_motion::<N, A, ACC>(parent, body, ball, f, q_dot, q_ddot),
                None => on_parent_z::<N, A, ACC>(parent, body, f, q_dot, q_ddot),
            };
        }
        let (p_joint, z) = match parent {
            Some((frame, _)) => (
                crate::eval::kernel::frame::apply_const_add::<N, A>(
                    &frame.r,
                    body.pre_frame.p,
                    frame.p,
                ),
                crate::eval::kernel::frame::apply_const_add::<N, A>(
                    &frame.r,
                    body.axis_in_parent,
                    zero,
                ),
            ),
            None => (
                body.pre_frame.p.map(N::splat),
                body.axis_in_parent.map(N::splat),
            ),
        };
        (z, Some(cross(z, sub(f.p, p_joint))))
    };
    let (p_parent, parent) = match parent {
        Some((frame, motion)) => (frame.p, *motion),
        None => (zero, Motion::zero()),
    };
    let th_d = term_rate(body.theta_rate, q_dot);
    let r = sub(f.p, p_parent);
    let slides = shape & Body::SLIDES != 0;
    let v_rel = match (z_u, slides) {
        (Some(z_u), true) => Some(add(
            scale(term_rate(body.d_rate, q_dot), z),
            scale(th_d, z_u),
        )),
        (Some(z_u), false) => Some(scale(th_d, z_u)),
        (None, true) => Some(scale(term_rate(body.d_rate, q_dot), z)),
        (None, false) => None,
    };
    let w_r = cross(parent.omega, r);
    let v = add(parent.v, w_r);
    let mut out = Motion {
        omega: crate::eval::kernel::frame::axpy::<N, A>(th_d, z, parent.omega),
        v: v_rel.map_or(v, |v_rel| add(v, v_rel)),
        alpha: zero,
        a: zero,
    };
    if ACC {
        let th_dd = term_rate(body.theta_rate, q_ddot);
        let w_rel = scale(th_d, z);
        out.alpha = angular_acceleration::<N, A>(&parent, z, th_d, th_dd);
        let mut a = cross_add::<N, A>(parent.alpha, r, cross(parent.omega, w_r));
        if let Some(v_rel) = v_rel {
            a = cross_add::<N, A>(parent.omega, scale(N::splat(2.0), v_rel), a);
            if slides {
                a = crate::eval::kernel::frame::axpy::<N, A>(term_rate(body.d_rate, q_ddot), z, a);
            }
            if let Some(z_u) = z_u {
                a = crate::eval::kernel::frame::axpy::<N, A>(th_dd, z_u, a);
                a = cross_add::<N, A>(w_rel, scale(th_d, z_u), a);
            }
        }
        out.a = add(parent.a, a);
    }
    out
}
