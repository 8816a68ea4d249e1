//! One body's pose step for a single configuration, on padded columns ([`Frame4`] of
//! [`Col`](crate::eval::simd::traits::Col)): the operations of [`super::pose_lanes`] four entries
//! per vector, and a link's pose from its body's frame.

use crate::eval::kernel::joint::term_value;
use crate::eval::layout::body::{Body, CheapPlacement, Placement, ZTail};
use crate::eval::layout::stored::{C4, Stored};
use crate::eval::simd::traits::{Arith, Col};
use crate::model::joint::{Axis, Term};
use crate::model::transform::Transform;

/// A rigid frame in vector registers: columns `[r0, r1, r2, p]`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame4<C>(pub(crate) [C; 4]);

impl<C: Col> Frame4<C> {
    #[inline(always)]
    pub(crate) fn identity() -> Self {
        let (one, zero) = (1.0, 0.0);
        Frame4([
            C::load(&[one, zero, zero, zero]),
            C::load(&[zero, one, zero, zero]),
            C::load(&[zero, zero, one, zero]),
            C::splat(zero),
        ])
    }

    // Arrays of vectors are written out here and below rather than built with `[T; N]::map`:
    // inlined into a large dispatched function, `map` can compile to a call of its own that
    // passes every vector through memory.
    #[inline(always)]
    pub(crate) fn load(s: &[C4; 4]) -> Self {
        Frame4([
            C::load(&s[0]),
            C::load(&s[1]),
            C::load(&s[2]),
            C::load(&s[3]),
        ])
    }

    /// Stores the columns whole (four stores instead of twelve entries).
    #[inline(always)]
    pub(crate) fn store(self, out: &mut Stored) {
        for (c, o) in self.0.into_iter().zip(out.iter_mut()) {
            c.store(o);
        }
    }
}

impl<C: Col> Frame4<C> {
    /// The frame as a [`Transform`] (the padding dropped).
    #[inline(always)]
    pub(crate) fn to_transform(self) -> Transform {
        let mut t = Transform::IDENTITY;
        C::store_frame(self.0, t.entries_mut());
        t
    }
}

/// The pose of a link: `body · offset`, the frame of the link's body followed by the link's
/// constant offset (the fixed joints folded at load time), composed in registers as the kernels
/// compose placements. Every way of reading a link pose (a full, incremental or one-link
/// evaluation, a batch) goes through here, so they agree bit for bit.
///
/// Dispatched to the AVX2 build on AVX-512 machines as well: compiled for AVX-512, the compiler
/// folds the broadcasts into the multiply–adds and writes the result through two-source
/// permutes, and a read cost 3–9 ns more on Zen 4 (Panda modified DH `tcp`, Panda URDF
/// `panda_hand_tcp`; the same for links without an offset).
#[inline(always)]
pub(crate) fn link_pose_generic<A: Arith>(body: &[C4; 4], offset: &Placement) -> Transform {
    let mut f = Frame4::<A::Col>::load(body);
    place::<A>(&mut f.0, offset);
    f.to_transform()
}

crate::eval::simd::isa::fma_dispatch!(avx2 pub(crate) fn link_pose(body: &[C4; 4], offset: &Placement) -> Transform => link_pose_generic);

/// [`link_pose_generic`] of each of `links` from the stored body frames, each written as a
/// row-major homogeneous matrix at `out[16 k..]` (one dispatch for all of them).
#[inline(always)]
fn write_link_matrices_generic<A: Arith>(
    chain: &crate::eval::layout::chain::Chain,
    frames: &[Stored],
    links: &[crate::model::chain::LinkId],
    out: &mut [f64],
) {
    for (&link, m) in links.iter().zip(out.chunks_exact_mut(16)) {
        let carrier = chain.carrier(link);
        let t = match carrier.body {
            Some(b) => link_pose_generic::<A>(&frames[b], &carrier.offset),
            None => carrier.offset.to_transform(),
        };
        for (r, row) in t.to_rows().iter().enumerate() {
            m[4 * r..4 * r + 4].copy_from_slice(row);
        }
    }
}

crate::eval::simd::isa::fma_dispatch!(avx2 pub(crate) fn write_link_matrices(chain: &crate::eval::layout::chain::Chain, frames: &[Stored], links: &[crate::model::chain::LinkId], out: &mut [f64]) => write_link_matrices_generic);

/// [`link_pose_generic`] with the body frame's entries read one by one, `entry(c, i)` being row
/// `i` of column `c` (a batch's frame, from the lanes of its chunk): each column is put
/// together in registers. (Written to an array for [`link_pose`], the entries cost a batch read
/// about 13 ns on Zen 5: each column's vector load waited for the four stores before it.)
/// The same operations as [`link_pose_generic`], so the same bits.
#[inline(always)]
pub(crate) fn link_pose_from_entries<A: Arith>(
    entry: impl Fn(usize, usize) -> f64,
    offset: &Placement,
) -> Transform {
    let column = |c| A::Col::from_entries([entry(c, 0), entry(c, 1), entry(c, 2), 0.0]);
    let mut f = Frame4::<A::Col>([column(0), column(1), column(2), column(3)]);
    place::<A>(&mut f.0, offset);
    f.to_transform()
}

/// `c₀ u₀ + c₁ u₁ + c₂ u₂ + base` for constant coefficients `u`, innermost term first (the order
/// of `kernel::frame::apply_const_add`).
#[inline(always)]
pub(crate) fn combine_const<C: Col>(c: &[C; 4], u: [f64; 3], base: C) -> C {
    let u = [C::splat(u[0]), C::splat(u[1]), C::splat(u[2])];
    C::mul_add(
        c[0],
        u[0],
        C::mul_add(c[1], u[1], C::mul_add(c[2], u[2], base)),
    )
}

/// Columns `i`, `j` turned by the angle with sine `s` and cosine `c` (see `kernel::frame::plane`).
#[inline(always)]
fn plane<C: Col>(f: &mut [C; 4], i: usize, j: usize, s: f64, c: f64) {
    let (ci, cj) = (f[i], f[j]);
    let (s, c) = (C::splat(s), C::splat(c));
    f[i] = C::mul_add(c, ci, C::mul(s, cj));
    f[j] = C::mul_add(c, cj, C::mul(s, ci).neg());
}

/// Replaces the rotation columns by `r · A(axis, θ)` (eq. 2.112; see `kernel::frame::rotate_columns`).
#[inline(always)]
fn rotate_columns<A: Arith>(f: &mut [A::Col; 4], axis: &Axis, s: f64, c: f64) {
    match *axis {
        Axis::X => plane(f, 1, 2, s, c),
        Axis::Y => plane(f, 2, 0, s, c),
        Axis::Z => plane(f, 0, 1, s, c),
        Axis::NegX => plane(f, 1, 2, -s, c),
        Axis::NegY => plane(f, 2, 0, -s, c),
        Axis::NegZ => plane(f, 0, 1, -s, c),
        Axis::General(v) => {
            let a = crate::eval::kernel::frame::rodrigues::<f64, A>(v, s, c);
            let old = *f;
            for j in 0..3 {
                let (a0, a1, a2) = (
                    A::Col::splat(a[j][0]),
                    A::Col::splat(a[j][1]),
                    A::Col::splat(a[j][2]),
                );
                f[j] = A::Col::mul_add(
                    old[0],
                    a0,
                    A::Col::mul_add(old[1], a1, A::Col::mul(old[2], a2)),
                );
            }
        }
    }
}

/// `f ← f · placement`.
#[inline(always)]
pub(crate) fn place<A: Arith>(f: &mut [A::Col; 4], placement: &Placement) {
    match placement {
        Placement::Identity => {}
        Placement::Translation(t) => f[3] = combine_const(f, *t, f[3]),
        Placement::ScrewX { a, c, s } => {
            f[3] = A::Col::mul_add(A::Col::splat(*a), f[0], f[3]);
            rotate_columns::<A>(f, &Axis::X, *s, *c);
        }
        Placement::OffsetRot { t, axis, c, s } => {
            f[3] = combine_const(f, *t, f[3]);
            // Constant indices in each arm (see `kernel::frame::place`).
            match axis {
                0 => plane(f, 1, 2, *s, *c),
                1 => plane(f, 2, 0, *s, *c),
                _ => plane(f, 0, 1, *s, *c),
            }
        }
        Placement::General(t) => {
            let zero = A::Col::splat(0.0);
            *f = [
                combine_const(f, t.r[0], zero),
                combine_const(f, t.r[1], zero),
                combine_const(f, t.r[2], zero),
                combine_const(f, t.p, f[3]),
            ];
        }
    }
}

/// `f ← f · M(θ, d)` (eq. 2.119; see `kernel::pose_lanes::apply_motion`); the axis is the one `f`'s columns
/// carry.
#[inline(always)]
fn apply_motion<A: Arith>(f: &mut [A::Col; 4], body: &Body, q: &[f64], sin_cos: (f64, f64)) {
    let m = &body.motion;
    match m.d {
        Term::Const(0.0) => {}
        d => {
            let d = A::Col::splat(term_value::<f64, A>(&d, q));
            let z = axis_of(f, &m.axis);
            f[3] = A::Col::mul_add(d, z, f[3]);
        }
    }
    match m.theta {
        Term::Const(0.0) => {}
        Term::Const(_) => match body.ball {
            // A ball joint's body, whose θ is NaN (`Body::ball`): its own step, in the arm that
            // otherwise only sliding joints with a constant θ (a DH row's offset) take.
            Some(ball) => crate::eval::kernel::ball::turn_columns(f, ball, q),
            None => {
                let (s, c) = m.const_sin_cos;
                rotate_columns::<A>(f, &m.axis, s, c);
            }
        },
        Term::Var { .. } => rotate_columns::<A>(f, &m.axis, sin_cos.0, sin_cos.1),
    }
}

/// `f ← f · M(θ, d) · post` for the shape [`ZTail`] describes (see `kernel::pose_lanes::z_tail`).
#[inline(always)]
fn z_tail<A: Arith>(
    f: &mut [A::Col; 4],
    body: &Body,
    tail: &ZTail,
    q: &[f64],
    sin_cos: (f64, f64),
) {
    crate::eval::kernel::joint::by_shape!(tail.motion, z_motion::<A>(f, body, q, sin_cos));
    cheap_place::<A>(f, &tail.post);
}

/// `f ← f · M(θ, d)` about z for the kinds of d and θ in `MOTION` (see `kernel::pose_lanes::z_motion`).
#[cfg_attr(not(debug_assertions), inline(always))] // (see `by_shape!`)
fn z_motion<A: Arith, const MOTION: u8>(
    f: &mut [A::Col; 4],
    body: &Body,
    q: &[f64],
    sin_cos: (f64, f64),
) {
    type C<A> = <A as Arith>::Col;
    let m = &body.motion;
    if ZTail::d_kind(MOTION) != ZTail::ZERO {
        let d = C::<A>::splat(term_value::<f64, A>(&m.d, q));
        f[3] = C::<A>::mul_add(d, f[2], f[3]);
    }
    match ZTail::theta_kind(MOTION) {
        ZTail::ZERO => {}
        ZTail::CONSTANT => plane(f, 0, 1, m.const_sin_cos.0, m.const_sin_cos.1),
        _ => plane(f, 0, 1, sin_cos.0, sin_cos.1),
    }
}

/// `f ← f · placement` for a [`CheapPlacement`]: one jump on its shape (see
/// `kernel::pose_lanes::cheap_place`).
#[inline(always)]
fn cheap_place<A: Arith>(f: &mut [A::Col; 4], p: &CheapPlacement) {
    crate::eval::kernel::joint::by_shape!(p.shape, cheap_steps::<A>(f, p));
}

/// The steps of a [`CheapPlacement`] of shape `SHAPE` (see `kernel::pose_lanes::cheap_steps`).
#[cfg_attr(not(debug_assertions), inline(always))] // (see `by_shape!`)
fn cheap_steps<A: Arith, const SHAPE: u8>(f: &mut [A::Col; 4], p: &CheapPlacement) {
    if SHAPE & CheapPlacement::ALONG_X != 0 {
        f[3] = A::Col::mul_add(A::Col::splat(p.x), f[0], f[3]);
    }
    if SHAPE & CheapPlacement::TRANSLATE != 0 {
        f[3] = combine_const(f, p.t, f[3]);
    }
    match CheapPlacement::turn(SHAPE) {
        CheapPlacement::NO_TURN => {}
        CheapPlacement::ANY_TURN => plane(f, 1, 2, p.s, p.c),
        turn => {
            // `plane` with s = ±1 (see `kernel::pose_lanes::cheap_steps`).
            let (c, c1, c2) = (A::Col::splat(p.c), f[1], f[2]);
            let (s_c2, s_c1) = if turn == CheapPlacement::NEGATIVE_QUARTER {
                (c2.neg(), c1.neg())
            } else {
                (c2, c1)
            };
            f[1] = A::Col::mul_add(c, c1, s_c2);
            f[2] = A::Col::mul_add(c, c2, s_c1.neg());
        }
    }
}

/// The columns of `parent`, or of the world frame for `None`. (A function, not a closure: a
/// closure that is not inlined is a call, and every vector register is caller-saved.)
#[inline(always)]
fn columns_or_world<C: Col>(parent: Option<&Frame4<C>>) -> [C; 4] {
    match parent {
        Some(f) => f.0,
        None => Frame4::identity().0,
    }
}

/// The frame of a body from its parent's frame (`None`: the body hangs from the world), with the
/// steps of `kernel::pose_lanes::pose_step`.
#[cfg_attr(not(debug_assertions), inline(always))] // (see `by_shape!`)
pub(crate) fn pose_step<A: Arith>(
    parent: Option<&Frame4<A::Col>>,
    body: &Body,
    q: &[f64],
    sin_cos: (f64, f64),
) -> Frame4<A::Col> {
    let mut f = columns_or_world(parent);
    match &body.pre_steps {
        Some(p) => cheap_place::<A>(&mut f, p),
        None => place::<A>(&mut f, &body.pre),
    }
    if let Some(tail) = &body.z_tail {
        z_tail::<A>(&mut f, body, tail, q, sin_cos);
    } else {
        apply_motion::<A>(&mut f, body, q, sin_cos);
        place::<A>(&mut f, &body.post);
    }
    Frame4(f)
}

/// The frame of a body that hangs from the world: [`pose_step`] from the world frame, or the
/// frame of a floating joint's body ([`crate::eval::kernel::floating`]).
#[cfg_attr(not(debug_assertions), inline(always))]
pub(crate) fn root_step<A: Arith>(body: &Body, q: &[f64], sin_cos: (f64, f64)) -> Frame4<A::Col> {
    if body.floating {
        // The usual floating base, without placements: its frame built in registers, on the
        // critical path of every body after it. (Through the out-of-line `floating::frame`,
        // stored and loaded back, the Unitree G1 took about 40 ns more than without its base.)
        let t = match (body.pre, body.post) {
            (Placement::Identity, Placement::Identity) => crate::eval::kernel::floating::own(q),
            _ => crate::eval::kernel::floating::frame(body, q),
        };
        let column = |v: [f64; 3]| A::Col::from_entries([v[0], v[1], v[2], 0.0]);
        Frame4([column(t.r[0]), column(t.r[1]), column(t.r[2]), column(t.p)])
    } else {
        pose_step::<A>(None, body, q, sin_cos)
    }
}

/// The joint axis in the world frame from a frame whose rotation maps the joint's axis.
#[inline(always)]
pub(crate) fn axis_of<C: Col>(f: &[C; 4], axis: &Axis) -> C {
    match *axis {
        Axis::X => f[0],
        Axis::Y => f[1],
        Axis::Z => f[2],
        Axis::NegX => f[0].neg(),
        Axis::NegY => f[1].neg(),
        Axis::NegZ => f[2].neg(),
        Axis::General(v) => combine_const(f, v, C::splat(0.0)),
    }
}

#[cfg(test)]
mod tests;
