//! One body's velocity and acceleration step for a single configuration, on padded columns
//! (eqs. 2.120–2.127, the recursion in [`crate::eval::single::kinematics`]).

use crate::eval::kernel::pose_columns::axis_of;
use crate::eval::kernel::pose_columns::{Frame4, combine_const, pose_step};
use crate::eval::layout::body::{Body, RateTerm};
use crate::eval::layout::stored::Rates;
use crate::eval::simd::traits::{Arith, Col};

/// Motion state of a body (see `kernel::Rates`) in vector registers.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Rates4<C> {
    pub(crate) omega: C,
    pub(crate) v: C,
    pub(crate) alpha: C,
    pub(crate) a: C,
}

impl<C: Col> Rates4<C> {
    #[inline(always)]
    pub(crate) fn zero() -> Self {
        let z = C::splat(0.0);
        Rates4 {
            omega: z,
            v: z,
            alpha: z,
            a: z,
        }
    }

    #[inline(always)]
    pub(crate) fn from_rates(r: &Rates) -> Self {
        Rates4 {
            omega: C::load(&r.omega),
            v: C::load(&r.v),
            alpha: C::load(&r.alpha),
            a: C::load(&r.a),
        }
    }

    /// Stores ω and v, and α and a when `ACC`.
    #[inline(always)]
    pub(crate) fn store<const ACC: bool>(self, out: &mut Rates) {
        self.omega.store(&mut out.omega);
        self.v.store(&mut out.v);
        if ACC {
            self.alpha.store(&mut out.alpha);
            self.a.store(&mut out.a);
        }
    }
}

/// Frame and rates of a body.
pub(crate) type State<C> = (Frame4<C>, Rates4<C>);

/// `a × b`, with the two permutations of each operand as whole-register shuffles.
#[inline(always)]
pub(crate) fn cross<C: Col>(a: C, b: C) -> C {
    C::sub(C::mul(a.yzx(), b.zxy()), C::mul(a.zxy(), b.yzx()))
}

/// `a × b + c` in two multiply–adds (`c` enters the first).
#[inline(always)]
pub(crate) fn cross_add<C: Col>(a: C, b: C, c: C) -> C {
    C::mul_add(a.yzx(), b.zxy(), C::mul_add(a.zxy().neg(), b.yzx(), c))
}

/// `s x + y`.
#[inline(always)]
fn axpy<C: Col>(s: f64, x: C, y: C) -> C {
    C::mul_add(C::splat(s), x, y)
}

/// `s x`.
#[inline(always)]
fn scale<C: Col>(s: f64, x: C) -> C {
    C::mul(C::splat(s), x)
}

/// Rate of a θ or d term given `q_dot` (or `q_ddot`).
#[inline(always)]
fn term_rate(t: RateTerm, rates: &[f64]) -> f64 {
    t.scale * rates[t.index]
}

/// Frame and rates of a body from its parent's (eqs. 2.120, 2.123–2.125 for the joint, 2.75 for
/// the composition). With `ACC = false`, α and a are zero.
#[inline(always)]
pub(crate) fn rates_step<A: Arith, const ACC: bool>(
    parent: Option<&State<A::Col>>,
    body: &Body,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
    sin_cos: (f64, f64),
) -> State<A::Col> {
    // The same frame as `pose_step`, bit for bit.
    let f = pose_step::<A>(parent.map(|(frame, _)| frame), body, q, sin_cos);
    let rates = body_rates::<A, ACC>(parent, body, &f, q_dot, q_ddot);
    (f, rates)
}

/// Frame and rates of a body that hangs from the world: [`rates_step`] from the world, or those
/// of a floating joint's body, whose rates are entries of `q̇` and `q̈`
/// ([`crate::eval::kernel::floating`]).
#[inline(always)]
pub(crate) fn root_rates_step<A: Arith, const ACC: bool>(
    body: &Body,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
    sin_cos: (f64, f64),
) -> State<A::Col> {
    if !body.floating {
        return rates_step::<A, ACC>(None, body, q, q_dot, q_ddot, sin_cos);
    }
    let f = crate::eval::kernel::pose_columns::root_step::<A>(body, q, sin_cos);
    let [omega, v, alpha, a] =
        crate::eval::kernel::floating::rates(q_dot, if ACC { Some(q_ddot) } else { None });
    let pad = |x: [f64; 3]| A::Col::load(&[x[0], x[1], x[2], 0.0]);
    let rates = Rates4 {
        omega: pad(omega),
        v: pad(v),
        alpha: pad(alpha),
        a: pad(a),
    };
    (f, rates)
}

/// `α = α_p + ω_p × θ̇ z + θ̈ z` (eq. 2.123) for a joint turning about `z` at rates θ̇, θ̈: the
/// body's own terms summed first, so that the chain from parent to child is one addition.
#[inline(always)]
fn angular_acceleration<C: Col>(parent: &Rates4<C>, z: C, th_d: f64, th_dd: f64) -> C {
    C::add(
        parent.alpha,
        cross_add(parent.omega, scale(th_d, z), scale(th_dd, z)),
    )
}

/// The rates of a body whose joint sits at its parent's origin and moves about the parent's z
/// axis ([`Body::ON_PARENT_Z`]: standard DH rows), with frame `f`. The child's origin is then
/// `r = d z + u` from the parent's, `u` fixed in the child and `z` turning with it, so
/// `ṙ = ḋ z + ω × r` with the child's own ω, and (eq. 2.75 for the child, plus the sliding terms)
/// `v = v_p + ω × r + ḋ z`, `a = a_p + α × r + ω × (ω × r) + 2 ḋ ω × z + d̈ z`: four cross
/// products where the general form needs seven.
#[inline(always)]
pub(crate) fn rates_on_parent_z<A: Arith, const ACC: bool>(
    parent: Option<&State<A::Col>>,
    body: &Body,
    f: &Frame4<A::Col>,
    q_dot: &[f64],
    q_ddot: &[f64],
) -> Rates4<A::Col> {
    type C<A> = <A as Arith>::Col;
    let zero = C::<A>::splat(0.0);
    let (z, p_parent, parent) = match parent {
        Some((frame, rates)) => (frame.0[2], frame.0[3], *rates),
        None => (C::<A>::load(&body.axis4), zero, Rates4::zero()),
    };
    let slides = body.rate_shape & Body::SLIDES != 0;
    let th_d = term_rate(body.theta_rate, q_dot);
    let r = C::<A>::sub(f.0[3], p_parent);
    let omega = axpy(th_d, z, parent.omega);
    let w_r = cross(omega, r);
    let mut out = Rates4 {
        omega,
        v: C::<A>::add(parent.v, w_r),
        alpha: zero,
        a: zero,
    };
    if slides {
        out.v = axpy(term_rate(body.d_rate, q_dot), z, out.v);
    }
    if ACC {
        let th_dd = term_rate(body.theta_rate, q_ddot);
        let alpha = angular_acceleration(&parent, z, th_d, th_dd);
        let mut a = cross_add(alpha, r, cross(omega, w_r));
        if slides {
            let d_d = term_rate(body.d_rate, q_dot);
            a = cross_add(omega, scale(2.0 * d_d, z), a);
            a = axpy(term_rate(body.d_rate, q_ddot), z, a);
        }
        out.alpha = alpha;
        out.a = C::<A>::add(parent.a, a);
    }
    out
}

/// The rates of a body whose joint does not turn (θ constant: a prismatic joint, such as a
/// gripper finger) and whose origin lies on the joint axis (no placement after the motion), with
/// frame `f` and joint axis `z` (world): `ω = ω_p`, `α = α_p`, and with `r` from the parent's origin,
/// `v = v_p + ω_p × r + ḋ z`, `a = a_p + α_p × r + ω_p × (ω_p × r) + 2 ω_p × ḋ z + d̈ z`
/// (eqs. 2.120, 2.125 without the turning terms): the general form's products with `θ̇ = θ̈ = 0`
/// left out.
#[inline(always)]
pub(crate) fn rates_sliding<A: Arith, const ACC: bool>(
    parent: Option<&State<A::Col>>,
    body: &Body,
    f: &Frame4<A::Col>,
    z: A::Col,
    q_dot: &[f64],
    q_ddot: &[f64],
) -> Rates4<A::Col> {
    type C<A> = <A as Arith>::Col;
    let zero = C::<A>::splat(0.0);
    let (p_parent, parent) = match parent {
        Some((frame, rates)) => (frame.0[3], *rates),
        None => (zero, Rates4::zero()),
    };
    let r = C::<A>::sub(f.0[3], p_parent);
    let w_r = cross(parent.omega, r);
    // Every body the loaders and the builder make reads an entry of `q`, so one that does not
    // turn slides and `slides` is always true here. The test stays: without it (the same
    // operations unconditionally) the shared kernel was scheduled differently and the Panda URDF
    // accelerations took 143 ns instead of 136 (best of ten alternated runs).
    let slides = body.rate_shape & Body::SLIDES != 0;
    // (`v_rel` is computed whatever the shape: the branch-free form takes fewer instructions;
    // index 0 exists since the body reads an entry.)
    let v_rel = scale(term_rate(body.d_rate, q_dot), z);
    let v = C::<A>::add(parent.v, w_r);
    let mut out = Rates4 {
        omega: parent.omega,
        v: if slides { C::<A>::add(v, v_rel) } else { v },
        alpha: parent.alpha,
        a: zero,
    };
    if ACC {
        // Summed so that the term that arrives last, ω_p × (ω_p × r) (r, then two cross products),
        // enters by one addition: the other terms need only r or z. (A sliding body is often the
        // last of its branch, a gripper finger, where nothing hides this latency.)
        let near = if slides {
            let local = cross_add(
                parent.omega,
                scale(2.0, v_rel),
                scale(term_rate(body.d_rate, q_ddot), z),
            );
            cross_add(parent.alpha, r, local)
        } else {
            cross(parent.alpha, r)
        };
        let a = C::<A>::add(near, cross(parent.omega, w_r));
        out.a = C::<A>::add(parent.a, a);
    }
    out
}

/// The rates of a ball joint's body with frame `f` (the recursion in
/// [`crate::eval::kernel::ball`]): `w` and `ε` from `q̇` and `q̈`, `u` from the joint origin.
#[inline(always)]
fn rates_ball<A: Arith, const ACC: bool>(
    parent: Option<&State<A::Col>>,
    body: &Body,
    ball: crate::eval::layout::body::Ball,
    f: &Frame4<A::Col>,
    q_dot: &[f64],
    q_ddot: &[f64],
) -> Rates4<A::Col> {
    type C<A> = <A as Arith>::Col;
    let zero = C::<A>::splat(0.0);
    let pad = |x: [f64; 3]| C::<A>::from_entries([x[0], x[1], x[2], 0.0]);
    let (p_joint, p_parent, parent) = match parent {
        Some((frame, rates)) => (
            combine_const(&frame.0, body.pre_frame.p, frame.0[3]),
            frame.0[3],
            *rates,
        ),
        None => (C::<A>::load(&body.pre4[3]), zero, Rates4::zero()),
    };
    let w = pad(crate::eval::kernel::ball::rate(ball, q_dot));
    let (r, u) = (C::<A>::sub(f.0[3], p_parent), C::<A>::sub(f.0[3], p_joint));
    // A free body's relative velocity is its own entry of `q̇`; a ball's, the turn about `p_j`.
    let v_rel = match ball.free {
        true => pad(crate::eval::kernel::ball::linear_rate(ball, q_dot)),
        false => cross(w, u),
    };
    let w_r = cross(parent.omega, r);
    let mut out = Rates4 {
        omega: C::<A>::add(parent.omega, w),
        v: C::<A>::add(C::<A>::add(parent.v, w_r), v_rel),
        alpha: zero,
        a: zero,
    };
    if ACC {
        let eps = pad(crate::eval::kernel::ball::rate(ball, q_ddot));
        out.alpha = C::<A>::add(parent.alpha, cross_add(parent.omega, w, eps));
        let mut a = cross_add(parent.alpha, r, cross(parent.omega, w_r));
        a = cross_add(parent.omega, scale(2.0, v_rel), a);
        a = match ball.free {
            true => C::<A>::add(a, pad(crate::eval::kernel::ball::linear_rate(ball, q_ddot))),
            false => cross_add(w, v_rel, cross_add(eps, u, a)),
        };
        out.a = C::<A>::add(parent.a, a);
    }
    out
}

/// The rates of a body whose frame is `f`, for the cases its [`Body::rate_shape`] names.
#[inline(always)]
pub(crate) fn body_rates<A: Arith, const ACC: bool>(
    parent: Option<&State<A::Col>>,
    body: &Body,
    f: &Frame4<A::Col>,
    q_dot: &[f64],
    q_ddot: &[f64],
) -> Rates4<A::Col> {
    type C<A> = <A as Arith>::Col;
    let zero = C::<A>::splat(0.0);
    let shape = body.rate_shape;
    // Without a placement after the motion, the child origin lies on the joint axis (u = d z), so
    // z × u = 0 and the axis is a column of the child frame. Otherwise the joint origin and axis
    // follow from the parent frame and the constant `pre`, or, for a joint at the parent's origin
    // (standard DH rows), the shorter form applies. (Tested here rather than first: in front of
    // every body, the test made the kernels of the other shapes spill more.)
    let (z, z_u) = if shape & Body::NO_POST != 0 {
        let z = if shape & Body::ABOUT_Z != 0 {
            f.0[2]
        } else {
            axis_of(&f.0, &body.motion.axis)
        };
        if shape & Body::TURNS == 0 {
            return rates_sliding::<A, ACC>(parent, body, f, z, q_dot, q_ddot);
        }
        (z, None)
    } else {
        if shape & (Body::ON_PARENT_Z | Body::BALL) != 0 {
            return match body.ball {
                Some(ball) => rates_ball::<A, ACC>(parent, body, ball, f, q_dot, q_ddot),
                None => rates_on_parent_z::<A, ACC>(parent, body, f, q_dot, q_ddot),
            };
        }
        let (p_joint, z) = match parent {
            Some((frame, _)) => (
                combine_const(&frame.0, body.pre_frame.p, frame.0[3]),
                combine_const(&frame.0, body.axis_in_parent, zero),
            ),
            None => (C::<A>::load(&body.pre4[3]), C::<A>::load(&body.axis4)),
        };
        (z, Some(cross(z, C::<A>::sub(f.0[3], p_joint))))
    };
    let (p_parent, parent) = match parent {
        Some((frame, rates)) => (frame.0[3], *rates),
        None => (zero, Rates4::zero()),
    };
    let th_d = term_rate(body.theta_rate, q_dot);
    let r = C::<A>::sub(f.0[3], p_parent);
    // eq. (2.120): velocity of the origin relative to the parent; zero for a turning joint whose
    // child origin lies on its axis.
    let slides = shape & Body::SLIDES != 0;
    let v_rel = match (z_u, slides) {
        (Some(z_u), true) => Some(C::<A>::add(
            scale(term_rate(body.d_rate, q_dot), z),
            scale(th_d, z_u),
        )),
        (Some(z_u), false) => Some(scale(th_d, z_u)),
        (None, true) => Some(scale(term_rate(body.d_rate, q_dot), z)),
        (None, false) => None,
    };
    let w_r = cross(parent.omega, r);
    let v = C::<A>::add(parent.v, w_r);
    let mut out = Rates4 {
        omega: axpy(th_d, z, parent.omega),
        v: v_rel.map_or(v, |v_rel| C::<A>::add(v, v_rel)),
        alpha: zero,
        a: zero,
    };
    if ACC {
        // The terms of this joint are summed first and the parent's α and a added last: each is
        // then one addition per body along the chain, not three or more dependent
        // multiply–adds (the parent's a and α arrive late, at the end of long chains).
        let th_dd = term_rate(body.theta_rate, q_ddot);
        let w_rel = scale(th_d, z);
        out.alpha = angular_acceleration(&parent, z, th_d, th_dd);
        // eq. (2.75): tangential and normal terms of the parent's motion ...
        let mut a = cross_add(parent.alpha, r, cross(parent.omega, w_r));
        // ... and the Coriolis and local terms when the origin moves relative to the parent
        // (eq. 2.125: d'' z + α_rel × u + ω_rel × (ω_rel × u)).
        if let Some(v_rel) = v_rel {
            a = cross_add(parent.omega, scale(2.0, v_rel), a);
            if slides {
                a = axpy(term_rate(body.d_rate, q_ddot), z, a);
            }
            if let Some(z_u) = z_u {
                a = axpy(th_dd, z_u, a);
                a = cross_add(w_rel, scale(th_d, z_u), a);
            }
        }
        out.a = C::<A>::add(parent.a, a);
    }
    out
}
