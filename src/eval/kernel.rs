//! The evaluation kernels, written once for any number type [`Num`]: one `f64` (a single
//! configuration) or [`Lanes`] of `f64` (eight configurations at once, in SIMD registers), each
//! with fused or separate multiply–add ([`Arith`]).
//!
//! One body (a moving joint with its constant placements folded in) is evaluated as
//! `frame = parent · pre · M(θ, d) · post` (eq. 2.119 for `M`). The batch kernels use these
//! directly; single configurations use the same operations on padded columns
//! ([`crate::eval::padded`]), which also holds the rate recursion.

// Index loops over lanes and rows are the shape the vectoriser expects here.
#![allow(clippy::needless_range_loop)]

use crate::eval::arith::Arith;
use crate::eval::lanes::lanes_sin_cos;
pub(crate) use crate::eval::lanes::{LANES, LaneNum, Lanes, fence_streams};
#[cfg(target_arch = "x86_64")]
pub(crate) use crate::eval::lanes::{Y4, Z8};
use crate::eval::layout::{Body, CheapPlacement, Placement, ZTail};
use crate::eval::trig;
use crate::model::joint::{Axis, Term};
use std::ops::{Add, Mul, Neg, Sub};

/// A number the kernels compute with.
pub(crate) trait Num:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    fn splat(x: f64) -> Self;
    fn mul_add<A: Arith>(a: Self, b: Self, c: Self) -> Self;
    fn sin_cos<A: Arith>(x: Self) -> (Self, Self);
}

impl Num for f64 {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn mul_add<A: Arith>(a: Self, b: Self, c: Self) -> Self {
        A::mul_add(a, b, c)
    }
    #[inline(always)]
    fn sin_cos<A: Arith>(x: Self) -> (Self, Self) {
        trig::sin_cos::<A>(x)
    }
}

/// `r u + p` (the columns of `r` are its vectors).
#[inline(always)]
fn mat_vec_add<N: Num, A: Arith>(r: &[[N; 3]; 3], u: &V3<N>, p: V3<N>) -> V3<N> {
    let mut out = p;
    for k in 0..3 {
        out[k] = N::mul_add::<A>(
            r[0][k],
            u[0],
            N::mul_add::<A>(r[1][k], u[1], N::mul_add::<A>(r[2][k], u[2], p[k])),
        );
    }
    out
}

/// A rigid frame: rotation columns and origin.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub(crate) struct Frame<N> {
    pub(crate) r: [[N; 3]; 3],
    pub(crate) p: [N; 3],
}

impl<N: Num> Frame<N> {
    #[inline(always)]
    pub(crate) fn splat(f: &crate::model::transform::Transform) -> Self {
        Frame {
            r: f.r.map(|c| c.map(N::splat)),
            p: f.p.map(N::splat),
        }
    }
}

impl From<Frame<f64>> for crate::model::transform::Transform {
    #[inline(always)]
    fn from(f: Frame<f64>) -> Self {
        crate::model::transform::Transform { r: f.r, p: f.p }
    }
}

pub(crate) type V3<N> = [N; 3];

/// `s x + y`.
#[inline(always)]
pub(crate) fn axpy<N: Num, A: Arith>(s: N, x: V3<N>, y: V3<N>) -> V3<N> {
    [
        N::mul_add::<A>(s, x[0], y[0]),
        N::mul_add::<A>(s, x[1], y[1]),
        N::mul_add::<A>(s, x[2], y[2]),
    ]
}

/// `R u + p` with a constant `u`.
#[inline(always)]
pub(crate) fn apply_const_add<N: Num, A: Arith>(r: &[[N; 3]; 3], u: [f64; 3], p: V3<N>) -> V3<N> {
    mat_vec_add::<N, A>(r, &u.map(N::splat), p)
}

/// A rotation about +e_k mixes the two other columns (i, j) in cyclic order:
/// `col_i' = c col_i + s col_j`, `col_j' = c col_j − s col_i` (about −e_k, `s` changes sign).
#[inline(always)]
fn plane<N: Num, A: Arith>(r: &mut [[N; 3]; 3], i: usize, j: usize, s: N, c: N) {
    let (ci, cj) = (r[i], r[j]);
    for k in 0..3 {
        r[i][k] = N::mul_add::<A>(c, ci[k], s * cj[k]);
        r[j][k] = N::mul_add::<A>(c, cj[k], -(s * ci[k]));
    }
}

/// Columns of Rodrigues' rotation matrix (eq. 2.112) about the unit axis `v`, given
/// `s = sin θ`, `c = cos θ`, as `A = c I + s [v]x + (1 − c) v vᵀ`.
#[inline(always)]
pub(crate) fn rodrigues<N: Num, A: Arith>(v: [f64; 3], s: N, c: N) -> [[N; 3]; 3] {
    let w = N::splat(1.0) - c;
    let [x, y, z] = v.map(N::splat);
    let (wx, wy, wz) = (w * x, w * y, w * z);
    let (sx, sy, sz) = (s * x, s * y, s * z);
    [
        [
            N::mul_add::<A>(wx, x, c),
            N::mul_add::<A>(wx, y, sz),
            N::mul_add::<A>(wx, z, -sy),
        ],
        [
            N::mul_add::<A>(wy, x, -sz),
            N::mul_add::<A>(wy, y, c),
            N::mul_add::<A>(wy, z, sx),
        ],
        [
            N::mul_add::<A>(wz, x, sy),
            N::mul_add::<A>(wz, y, -sx),
            N::mul_add::<A>(wz, z, c),
        ],
    ]
}

/// Replaces the columns `r` by `r · A(axis, θ)` given `s = sin θ`, `c = cos θ` (eq. 2.112).
#[inline(always)]
fn rotate_columns<N: Num, A: Arith>(r: &mut [[N; 3]; 3], axis: &Axis, s: N, c: N) {
    match *axis {
        Axis::X => plane::<N, A>(r, 1, 2, s, c),
        Axis::Y => plane::<N, A>(r, 2, 0, s, c),
        Axis::Z => plane::<N, A>(r, 0, 1, s, c),
        Axis::NegX => plane::<N, A>(r, 1, 2, -s, c),
        Axis::NegY => plane::<N, A>(r, 2, 0, -s, c),
        Axis::NegZ => plane::<N, A>(r, 0, 1, -s, c),
        Axis::General(v) => {
            let a = rodrigues::<N, A>(v, s, c);
            let old = *r;
            for (j, col) in r.iter_mut().enumerate() {
                for (k, out) in col.iter_mut().enumerate() {
                    *out = N::mul_add::<A>(
                        old[0][k],
                        a[j][0],
                        N::mul_add::<A>(old[1][k], a[j][1], old[2][k] * a[j][2]),
                    );
                }
            }
        }
    }
}

/// `f ← f · placement`.
#[inline(always)]
pub(crate) fn place<N: Num, A: Arith>(f: &mut Frame<N>, placement: &Placement) {
    match placement {
        Placement::Identity => {}
        Placement::Translation(t) => f.p = apply_const_add::<N, A>(&f.r, *t, f.p),
        Placement::ScrewX { a, c, s } => {
            f.p = axpy::<N, A>(N::splat(*a), f.r[0], f.p);
            rotate_columns::<N, A>(&mut f.r, &Axis::X, N::splat(*s), N::splat(*c));
        }
        Placement::OffsetRot { t, axis, c, s } => {
            f.p = apply_const_add::<N, A>(&f.r, *t, f.p);
            let (s, c) = (N::splat(*s), N::splat(*c));
            // Constant column indices in each arm: a frame indexed by a value known only at run
            // time would be kept in memory rather than in registers.
            match axis {
                0 => plane::<N, A>(&mut f.r, 1, 2, s, c),
                1 => plane::<N, A>(&mut f.r, 2, 0, s, c),
                _ => plane::<N, A>(&mut f.r, 0, 1, s, c),
            }
        }
        Placement::General(t) => {
            let zero = [N::splat(0.0); 3];
            let r = f.r;
            *f = Frame {
                r: [
                    apply_const_add::<N, A>(&r, t.r[0], zero),
                    apply_const_add::<N, A>(&r, t.r[1], zero),
                    apply_const_add::<N, A>(&r, t.r[2], zero),
                ],
                p: apply_const_add::<N, A>(&r, t.p, f.p),
            };
        }
    }
}

/// Value of a θ or d term at `q`.
#[inline(always)]
pub(crate) fn term_value<N: Num, A: Arith>(t: &Term, q: &[N]) -> N {
    match *t {
        Term::Const(v) => N::splat(v),
        Term::Var {
            index,
            scale,
            offset,
        } => N::mul_add::<A>(N::splat(scale), q[index], N::splat(offset)),
    }
}

/// `(sin θ, cos θ)` of a body at `q`.
#[inline(always)]
pub(crate) fn body_sin_cos<N: Num, A: Arith>(body: &Body, q: &[N]) -> (N, N) {
    match body.motion.theta {
        Term::Const(_) => (N::splat(0.0), N::splat(1.0)),
        theta => N::sin_cos::<A>(term_value::<N, A>(&theta, q)),
    }
}

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
        Term::Const(_) => (N::splat(m.const_sin_cos.0), N::splat(m.const_sin_cos.1)),
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

/// Calls `$f::<…, SHAPE>(args)` for a four-bit shape code `$shape` resolved at load time (a
/// [`CheapPlacement::shape`], a [`ZTail::motion`]): one jump through a table instead of one
/// test per step, each arm the code for its shape.
///
/// The functions it calls, and the pose steps that call it, are always inlined in optimised
/// builds only (`debug_assertions` off, as in `--release`): without optimisation nothing shares
/// stack slots, and sixteen inlined arms at each of a kernel's steps gave the batch kernel a
/// frame of 2.1 MB, more than a spawned thread's 2 MiB stack (a crate's own tests, run in debug,
/// overflowed it; the largest frame is now below 0.3 MB). Called instead, they run the same
/// arithmetic, without the caller's target features.
macro_rules! by_shape {
    ($shape:expr, $f:ident::<$($g:ty),*>($($arg:expr),*)) => {
        match $shape & 15 {
            0 => $f::<$($g,)* 0>($($arg),*),
            1 => $f::<$($g,)* 1>($($arg),*),
            2 => $f::<$($g,)* 2>($($arg),*),
            3 => $f::<$($g,)* 3>($($arg),*),
            4 => $f::<$($g,)* 4>($($arg),*),
            5 => $f::<$($g,)* 5>($($arg),*),
            6 => $f::<$($g,)* 6>($($arg),*),
            7 => $f::<$($g,)* 7>($($arg),*),
            8 => $f::<$($g,)* 8>($($arg),*),
            9 => $f::<$($g,)* 9>($($arg),*),
            10 => $f::<$($g,)* 10>($($arg),*),
            11 => $f::<$($g,)* 11>($($arg),*),
            12 => $f::<$($g,)* 12>($($arg),*),
            13 => $f::<$($g,)* 13>($($arg),*),
            14 => $f::<$($g,)* 14>($($arg),*),
            15 => $f::<$($g,)* 15>($($arg),*),
            // `& 15` leaves no other value; the compiler drops this arm.
            _ => unreachable!(),
        }
    };
}
pub(crate) use by_shape;

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
        Axis::NegX => r[0].map(|x| -x),
        Axis::NegY => r[1].map(|x| -x),
        Axis::NegZ => r[2].map(|x| -x),
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

/// `sin θ` and `cos θ` of every body at `q`, [`LANES`] joints at a time (vectorised: the
/// single-configuration kernels take the trigonometry off their dependency chain this way).
/// `sin` and `cos` have room for a whole number of chunks. θ is computed straight from `q`
/// (a value assembled lane by lane in memory and read back as a vector would stall the load).
#[inline(always)]
pub(crate) fn all_sin_cos<A: Arith>(
    gather: &[crate::eval::layout::ThetaGather],
    q: &[f64],
    sin: &mut [f64],
    cos: &mut [f64],
) {
    if A::WIDE
        && let [g] = gather
        && crate::eval::arith::narrow_trig()
    {
        // Two 256-bit halves: the same operations lane by lane, so the same bits (see
        // `narrow_trig` for when and why).
        let (s_out, c_out) = (&mut sin[..LANES], &mut cos[..LANES]);
        for ((s, c), first) in s_out
            .chunks_exact_mut(4)
            .zip(c_out.chunks_exact_mut(4))
            .zip([0, 4])
        {
            gathered_sin_cos::<A, 4>(g, first, q, s, c);
        }
        return;
    }
    for ((g, s_out), c_out) in gather
        .iter()
        .zip(sin.chunks_exact_mut(LANES))
        .zip(cos.chunks_exact_mut(LANES))
    {
        gathered_sin_cos::<A, LANES>(g, 0, q, s_out, c_out);
    }
}

/// `sin θ` and `cos θ` of lanes `first..first + W` of the chunk `g` into `s_out` and `c_out`
/// (`W` entries each), in one vector of `W` lanes.
#[inline(always)]
fn gathered_sin_cos<A: Arith, const W: usize>(
    g: &crate::eval::layout::ThetaGather,
    first: usize,
    q: &[f64],
    s_out: &mut [f64],
    c_out: &mut [f64],
) {
    // The gather closure does no arithmetic (a closure is not always inlined into the
    // target-feature function, and `mul_add` outside it would be a library call).
    let gathered: [f64; W] = std::array::from_fn(|i| q[g.index[first + i]]);
    let mut theta = [0.0; W];
    for i in 0..W {
        theta[i] = A::mul_add(g.scale[first + i], gathered[i], g.offset[first + i]);
    }
    let (s, c) = lanes_sin_cos::<A, W>(theta);
    s_out.copy_from_slice(&s);
    c_out.copy_from_slice(&c);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::arith::Separate;
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
