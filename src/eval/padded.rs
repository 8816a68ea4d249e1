//! The single-configuration kernels (poses, velocities, accelerations) on padded columns.
//!
//! A frame is held as four columns of four `f64` (the rotation columns and the origin, each with a
//! zero fourth entry), so that a column fits one 256-bit register and composing two frames is
//! twelve vector multiply–adds. Every pose entry goes through the same operations, in the same
//! order, as in the generic kernel of [`crate::eval::kernel`] that the batch path runs: single and batch
//! results are the same bit for bit (the tests below check it), only the instructions differ. The
//! rate recursion (eqs. 2.120–2.127, 2.75) computes its cross products on the same columns.

use crate::eval::arith::{Arith, Col};
use crate::eval::kernel::term_value;
use crate::eval::layout::{Body, CheapPlacement, Placement, RateTerm, ZTail};
use crate::model::joint::{Axis, Term};
use crate::model::transform::Transform;

/// A column padded to four entries (the last one is zero), as stored.
pub(crate) type C4 = [f64; 4];

/// A rigid frame as stored: padded columns `[r0, r1, r2, p]`, aligned to a column's 32 bytes so
/// that no column straddles two cache lines, wherever the allocator puts a buffer of frames.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct Stored(pub(crate) [C4; 4]);

impl std::ops::Deref for Stored {
    type Target = [C4; 4];
    #[inline(always)]
    fn deref(&self) -> &[C4; 4] {
        &self.0
    }
}

impl std::ops::DerefMut for Stored {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [C4; 4] {
        &mut self.0
    }
}

/// Padded columns of `t`.
pub(crate) fn stored(t: &Transform) -> Stored {
    let pad = |v: [f64; 3]| [v[0], v[1], v[2], 0.0];
    Stored([pad(t.r[0]), pad(t.r[1]), pad(t.r[2]), pad(t.p)])
}

/// The three entries of a padded column.
#[inline(always)]
pub(crate) fn cut(v: &C4) -> [f64; 3] {
    [v[0], v[1], v[2]]
}

/// Per-body motion state of the rate recursion, as stored in [`crate::Data`]: ω, v, α and a in
/// world coordinates, each padded like a frame column so that one vector store or load moves it
/// (aligned like [`Stored`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct Rates {
    pub(crate) omega: C4,
    pub(crate) v: C4,
    pub(crate) alpha: C4,
    pub(crate) a: C4,
}

impl Rates {
    pub(crate) const ZERO: Rates = Rates {
        omega: [0.0; 4],
        v: [0.0; 4],
        alpha: [0.0; 4],
        a: [0.0; 4],
    };
}

/// The transform held in padded columns.
#[inline]
pub(crate) fn transform(s: &Stored) -> Transform {
    Transform {
        r: [cut(&s[0]), cut(&s[1]), cut(&s[2])],
        p: cut(&s[3]),
    }
}

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

crate::eval::arith::fma_dispatch!(avx2 pub(crate) fn link_pose(body: &[C4; 4], offset: &Placement) -> Transform => link_pose_generic);

/// [`link_pose_generic`] of each of `links` from the stored body frames, each written as a
/// row-major homogeneous matrix at `out[16 k..]` (one dispatch for all of them).
#[inline(always)]
fn write_link_matrices_generic<A: Arith>(
    chain: &crate::eval::chain::Chain,
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

crate::eval::arith::fma_dispatch!(avx2 pub(crate) fn write_link_matrices(chain: &crate::eval::chain::Chain, frames: &[Stored], links: &[crate::model::chain::LinkId], out: &mut [f64]) => write_link_matrices_generic);

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
/// of `kernel::apply_const_add`).
#[inline(always)]
fn combine_const<C: Col>(c: &[C; 4], u: [f64; 3], base: C) -> C {
    let u = [C::splat(u[0]), C::splat(u[1]), C::splat(u[2])];
    C::mul_add(
        c[0],
        u[0],
        C::mul_add(c[1], u[1], C::mul_add(c[2], u[2], base)),
    )
}

/// Columns `i`, `j` turned by the angle with sine `s` and cosine `c` (see `kernel::plane`).
#[inline(always)]
fn plane<C: Col>(f: &mut [C; 4], i: usize, j: usize, s: f64, c: f64) {
    let (ci, cj) = (f[i], f[j]);
    let (s, c) = (C::splat(s), C::splat(c));
    f[i] = C::mul_add(c, ci, C::mul(s, cj));
    f[j] = C::mul_add(c, cj, C::mul(s, ci).neg());
}

/// Replaces the rotation columns by `r · A(axis, θ)` (eq. 2.112; see `kernel::rotate_columns`).
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
            let a = crate::eval::kernel::rodrigues::<f64, A>(v, s, c);
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
            // Constant indices in each arm (see `kernel::place`).
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

/// `f ← f · M(θ, d)` (eq. 2.119; see `kernel::apply_motion`); the axis is the one `f`'s columns
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
        Term::Const(_) => {
            let (s, c) = m.const_sin_cos;
            rotate_columns::<A>(f, &m.axis, s, c);
        }
        Term::Var { .. } => rotate_columns::<A>(f, &m.axis, sin_cos.0, sin_cos.1),
    }
}

/// `f ← f · M(θ, d) · post` for the shape [`ZTail`] describes (see `kernel::z_tail`).
#[inline(always)]
fn z_tail<A: Arith>(
    f: &mut [A::Col; 4],
    body: &Body,
    tail: &ZTail,
    q: &[f64],
    sin_cos: (f64, f64),
) {
    crate::eval::kernel::by_shape!(tail.motion, z_motion::<A>(f, body, q, sin_cos));
    cheap_place::<A>(f, &tail.post);
}

/// `f ← f · M(θ, d)` about z for the kinds of d and θ in `MOTION` (see `kernel::z_motion`).
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
/// `kernel::cheap_place`).
#[inline(always)]
fn cheap_place<A: Arith>(f: &mut [A::Col; 4], p: &CheapPlacement) {
    crate::eval::kernel::by_shape!(p.shape, cheap_steps::<A>(f, p));
}

/// The steps of a [`CheapPlacement`] of shape `SHAPE` (see `kernel::cheap_steps`).
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
            // `plane` with s = ±1 (see `kernel::cheap_steps`).
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
/// steps of `kernel::pose_step`.
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
fn cross<C: Col>(a: C, b: C) -> C {
    C::sub(C::mul(a.yzx(), b.zxy()), C::mul(a.zxy(), b.yzx()))
}

/// `a × b + c` in two multiply–adds (`c` enters the first).
#[inline(always)]
fn cross_add<C: Col>(a: C, b: C, c: C) -> C {
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

/// The joint axis in the world frame from a frame whose rotation maps the joint's axis.
#[inline(always)]
fn axis_of<C: Col>(f: &[C; 4], axis: &Axis) -> C {
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
fn rates_on_parent_z<A: Arith, const ACC: bool>(
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
fn rates_sliding<A: Arith, const ACC: bool>(
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

/// The rates of a body whose frame is `f`, for the cases its [`Body::rate_shape`] names.
#[inline(always)]
fn body_rates<A: Arith, const ACC: bool>(
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
        if shape & Body::ON_PARENT_Z != 0 {
            return rates_on_parent_z::<A, ACC>(parent, body, f, q_dot, q_ddot);
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

#[cfg(test)]
mod tests;
