//! One body's pose step, `frame = parent · pre · M(θ, d) · post` (eq. 2.119 for `M`), for any
//! [`Num`]: on [`Lanes`] (eight configurations, the batch kernels) and on one `f64` (the constant
//! motions computed at load time).

// Index loops over lanes and rows are the shape the vectoriser expects here.
#![allow(clippy::needless_range_loop)]

use crate::eval::kernel::frame::{Frame, V3, apply_const_add, axpy, place, plane, rotate_columns};
use crate::eval::kernel::joint::{by_shape, term_value};
use crate::eval::layout::body::{Body, CheapPlacement, ZTail};
use crate::eval::simd::traits::{Arith, LaneNum, Num};
use crate::model::joint::{Axis, Term};

/// `f ← f · M(θ, d)` (eq. 2.119): translate by `d` along the axis, rotate by θ about it (the two
/// commute). The axis (needed only for a sliding joint) is the one `f`'s columns carry;
/// `sin_cos` is `(sin θ, cos θ)` when θ varies.
#[inline(always)]
fn apply_motion<N: Num, A: Arith>(f: &mut Frame<N>, body: &Body, q: &[N], sin_cos: (N, N)) {
    let m = &body.motion;
    match m.d {
        Term::Const(0.0) => {}
        d => {
            let z = axis_of::<N, A>(&f.r, &m.axis);
            f.p = axpy::<N, A>(term_value::<N, A>(&d, q), z, f.p);
        }
    }
    let (s, c) = match m.theta {
        Term::Const(0.0) => return,
        Term::Const(_) => {
            // A ball joint's body, whose θ is NaN (`Body::ball`): its own step, in the arm that
            // otherwise only sliding joints with a constant θ (a DH row's offset) take.
            if let Some(ball) = body.ball {
                crate::eval::kernel::ball::rarely();
                crate::eval::kernel::ball::turn_lanes::<N, A>(f, ball, q);
                return;
            }
            (N::splat(m.const_sin_cos.0), N::splat(m.const_sin_cos.1))
        }
        _ => sin_cos,
    };
    rotate_columns::<N, A>(&mut f.r, &m.axis, s, c);
}

/// `f ← f · M(θ, d) · post` for the shape [`ZTail`] describes.
#[inline(always)]
fn z_tail<N: Num, A: Arith>(f: &mut Frame<N>, body: &Body, tail: &ZTail, q: &[N], sin_cos: (N, N)) {
    by_shape!(tail.motion, z_motion::<N, A>(f, body, q, sin_cos));
    cheap_place::<N, A>(f, &tail.post);
}

/// `f ← f · M(θ, d)` about z for the kinds of d and θ in `MOTION` (see [`ZTail::motion`]).
#[cfg_attr(not(debug_assertions), inline(always))] // (see `by_shape!`)
pub(crate) fn z_motion<N: Num, A: Arith, const MOTION: u8>(
    f: &mut Frame<N>,
    body: &Body,
    q: &[N],
    sin_cos: (N, N),
) {
    let m = &body.motion;
    if ZTail::d_kind(MOTION) != ZTail::ZERO {
        f.p = axpy::<N, A>(term_value::<N, A>(&m.d, q), f.r[2], f.p);
    }
    match ZTail::theta_kind(MOTION) {
        ZTail::ZERO => {}
        ZTail::CONSTANT => {
            let (s, c) = m.const_sin_cos;
            plane::<N, A>(&mut f.r, 0, 1, N::splat(s), N::splat(c));
        }
        _ => plane::<N, A>(&mut f.r, 0, 1, sin_cos.0, sin_cos.1),
    }
}

/// `f ← f · placement` for a [`CheapPlacement`] (the operations of `place` for its forms).
#[inline(always)]
fn cheap_place<N: Num, A: Arith>(f: &mut Frame<N>, p: &CheapPlacement) {
    by_shape!(p.shape, cheap_steps::<N, A>(f, p));
}

/// The steps of a [`CheapPlacement`] of shape `SHAPE`.
#[cfg_attr(not(debug_assertions), inline(always))] // (see `by_shape!`)
pub(crate) fn cheap_steps<N: Num, A: Arith, const SHAPE: u8>(f: &mut Frame<N>, p: &CheapPlacement) {
    if SHAPE & CheapPlacement::ALONG_X != 0 {
        f.p = axpy::<N, A>(N::splat(p.x), f.r[0], f.p);
    }
    if SHAPE & CheapPlacement::TRANSLATE != 0 {
        f.p = apply_const_add::<N, A>(&f.r, p.t, f.p);
    }
    match CheapPlacement::turn(SHAPE) {
        CheapPlacement::NO_TURN => {}
        CheapPlacement::ANY_TURN => {
            plane::<N, A>(&mut f.r, 1, 2, N::splat(p.s), N::splat(p.c));
        }
        turn => {
            // `plane` with s = ±1, the products s · column written as what they are.
            let (c, r1, r2) = (N::splat(p.c), f.r[1], f.r[2]);
            for k in 0..3 {
                let (s_r2, s_r1) = if turn == CheapPlacement::NEGATIVE_QUARTER {
                    (-r2[k], -r1[k])
                } else {
                    (r2[k], r1[k])
                };
                f.r[1][k] = N::mul_add::<A>(c, r1[k], s_r2);
                f.r[2][k] = N::mul_add::<A>(c, r2[k], -s_r1);
            }
        }
    }
}

/// The axis `r · axis`.
#[inline(always)]
pub(crate) fn axis_of<N: Num, A: Arith>(r: &[[N; 3]; 3], axis: &Axis) -> V3<N> {
    match *axis {
        Axis::X => r[0],
        Axis::Y => r[1],
        Axis::Z => r[2],
        // Written out, not mapped (see `splat3`).
        Axis::NegX => [-r[0][0], -r[0][1], -r[0][2]],
        Axis::NegY => [-r[1][0], -r[1][1], -r[1][2]],
        Axis::NegZ => [-r[2][0], -r[2][1], -r[2][2]],
        Axis::General(v) => apply_const_add::<N, A>(r, v, [N::splat(0.0); 3]),
    }
}

/// Frame of a body from its parent's frame (`None`: the body hangs from the world), given
/// `(sin θ, cos θ)` of its joint: `((parent · pre) · M(θ, d)) · post`, each factor applied to the
/// running frame in place. A DH row or an origin that turns about one axis costs a few column
/// rotations and one or three multiply–adds per origin entry; a general `pre` costs a full
/// product with constant coefficients (broadcast from memory), which measured faster than
/// composing a local frame `pre · M · post` built off the dependency chain (whose entries must be
/// broadcast from registers: the git history of docs/performance.md).
///
/// `pre` and the steps after it take shape codes where the body has them ([`Body::pre_steps`],
/// [`Body::z_tail`]): the operations of `place` and `apply_motion` without matching on kinds, and
/// a translation along x as one multiply–add per entry rather than three whose other two add
/// exact zeros.
#[cfg_attr(not(debug_assertions), inline(always))] // (see `by_shape!`)
pub(crate) fn pose_step<N: Num, A: Arith>(
    parent: Option<&Frame<N>>,
    body: &Body,
    q: &[N],
    sin_cos: (N, N),
) -> Frame<N> {
    let mut f = match parent {
        Some(f) => *f,
        None => Frame::splat(&crate::model::transform::Transform::IDENTITY),
    };
    match &body.pre_steps {
        Some(p) => cheap_place::<N, A>(&mut f, p),
        None => place::<N, A>(&mut f, &body.pre),
    }
    if let Some(tail) = &body.z_tail {
        z_tail::<N, A>(&mut f, body, tail, q, sin_cos);
    } else {
        apply_motion::<N, A>(&mut f, body, q, sin_cos);
        place::<N, A>(&mut f, &body.post);
    }
    f
}

/// The frame of a body that hangs from the world: [`pose_step`] from the world frame, or the
/// frame of a floating joint's body, each lane's from its own seven entries of `q`
/// ([`crate::eval::kernel::floating`], in scalar code, so that every lane has the bits of a
/// single evaluation).
#[inline(always)]
pub(crate) fn root_step<N: LaneNum, A: Arith>(body: &Body, q: &[N], sin_cos: (N, N)) -> Frame<N> {
    if body.floating {
        floating_frame(body, q)
    } else {
        pose_step::<N, A>(None, body, q, sin_cos)
    }
}

/// A floating joint's body's frame in each lane of `N` (`q` one part's joint values): the
/// expressions of [`crate::eval::kernel::floating::frame`] in lane operations (plain products and
/// sums, in the same order, so each lane has the single evaluation's bits; the one division
/// lane by lane, [`Num::two_over`]).
#[inline(always)]
fn floating_frame<N: LaneNum>(body: &Body, q: &[N]) -> Frame<N> {
    let own = Frame {
        r: crate::eval::kernel::ball::columns([q[3], q[4], q[5], q[6]]),
        p: [q[0], q[1], q[2]],
    };
    use crate::eval::layout::body::Placement;
    let before = match body.pre {
        Placement::Identity => own,
        _ => constant_times(&body.pre_frame, &own),
    };
    match body.post {
        Placement::Identity => before,
        post => times_constant(&before, &post.to_transform()),
    }
}

/// `a u` for a constant rotation `a` (columns `a[c]`), as `Transform::apply` sums it.
#[inline(always)]
fn turn<N: Num>(a: &[[f64; 3]; 3], u: &[N; 3]) -> [N; 3] {
    std::array::from_fn(|k| {
        N::splat(a[0][k]) * u[0] + N::splat(a[1][k]) * u[1] + N::splat(a[2][k]) * u[2]
    })
}

/// `a · f` for a constant `a`, in `Transform`'s composition order.
#[inline(always)]
fn constant_times<N: Num>(a: &crate::model::transform::Transform, f: &Frame<N>) -> Frame<N> {
    let moved = turn(&a.r, &f.p);
    Frame {
        r: [
            turn(&a.r, &f.r[0]),
            turn(&a.r, &f.r[1]),
            turn(&a.r, &f.r[2]),
        ],
        p: std::array::from_fn(|k| N::splat(a.p[k]) + moved[k]),
    }
}

/// `f · b` for a constant `b`, in `Transform`'s composition order.
#[inline(always)]
fn times_constant<N: Num>(f: &Frame<N>, b: &crate::model::transform::Transform) -> Frame<N> {
    let apply = |u: [f64; 3]| -> [N; 3] {
        std::array::from_fn(|k| {
            f.r[0][k] * N::splat(u[0]) + f.r[1][k] * N::splat(u[1]) + f.r[2][k] * N::splat(u[2])
        })
    };
    let moved = apply(b.p);
    Frame {
        r: [apply(b.r[0]), apply(b.r[1]), apply(b.r[2])],
        p: std::array::from_fn(|k| f.p[k] + moved[k]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::simd::lanes::{LANES, Lanes};
    use crate::eval::simd::portable::Separate;
    use crate::model::transform::Transform;

    fn max_diff(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> f64 {
        a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, crate::measure::worse)
    }

    #[test]
    fn coordinate_axes_match_the_general_formula() {
        let base = Transform::from_xyz_rpy([0.0; 3], [0.3, -0.7, 1.9]).r;
        let (s, c) = 0.83_f64.sin_cos();
        for v in [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [-1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, -1.0],
        ] {
            let mut special = base;
            rotate_columns::<f64, Separate>(&mut special, &Axis::from_unit(v), s, c);
            let mut general = base;
            rotate_columns::<f64, Separate>(&mut general, &Axis::General(v), s, c);
            assert!(max_diff(&special, &general) < 4.0 * f64::EPSILON, "{v:?}");
        }
        let mut about_z = Transform::IDENTITY.r;
        rotate_columns::<f64, Separate>(&mut about_z, &Axis::General([0.0, 0.0, 1.0]), s, c);
        assert!(max_diff(&about_z, &Transform::rot_z(0.83).r) < f64::EPSILON);
    }

    #[test]
    fn lanes_compute_what_scalars_compute() {
        let xs = [0.1, -2.0, 1e3, 7.5e5, 9e5, -1e7, 0.0, 3.0];
        let (s, c) = Lanes::sin_cos::<Separate>(Lanes(xs));
        for i in 0..LANES {
            assert_eq!((s.0[i], c.0[i]), <f64 as Num>::sin_cos::<Separate>(xs[i]));
        }
        let a = Lanes(xs);
        let m = Lanes::mul_add::<Separate>(a, a, Lanes::splat(1.0));
        for i in 0..LANES {
            assert_eq!(m.0[i], xs[i] * xs[i] + 1.0);
        }
    }
}
