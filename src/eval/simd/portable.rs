//! The baseline implementations: the [`Separate`] multiply–add policy, its [`Portable`] column
//! type, and [`Num`] / [`LaneNum`] for `f64` and [`Lanes`], in plain Rust that any target compiles.

// Index loops over lanes and rows are the shape the vectoriser expects here.
#![allow(clippy::needless_range_loop)]

use crate::eval::simd::lanes::each_lane;
use crate::eval::simd::lanes::{LANES, Lanes};
use crate::eval::simd::traits::{Arith, Col, LaneNum, Num};

/// Two roundings: `a * b` then `+ c`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Separate;

impl Arith for Separate {
    type Col = Portable<Separate>;
    type Lanes = Lanes;
    const FUSED: bool = false;
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
}

/// [`Col`] as an array, for any [`Arith`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Portable<A>([f64; 4], std::marker::PhantomData<A>);

impl<A: Arith> Portable<A> {
    /// `[f(0), f(1), f(2), f(3)]`, written out rather than looped (see
    /// `eval::lanes::each_lane`: these inline into every body step of the baseline build).
    #[inline(always)]
    fn map(f: impl Fn(usize) -> f64) -> Self {
        Portable([f(0), f(1), f(2), f(3)], std::marker::PhantomData)
    }
}

impl<A: Arith> Col for Portable<A> {
    #[inline(always)]
    fn admitted(x: Self, [scale, offset, lower, upper]: [Self; 4]) -> bool {
        let ok = |i: usize| {
            crate::eval::simd::traits::within(
                x.0[i],
                (scale.0[i], offset.0[i], lower.0[i], upper.0[i]),
            )
        };
        ok(0) & ok(1) & ok(2) & ok(3)
    }
    #[inline(always)]
    fn load(v: &[f64; 4]) -> Self {
        Portable(*v, std::marker::PhantomData)
    }
    #[inline(always)]
    fn store_frame(frame: [Self; 4], out: &mut [f64; 12]) {
        for (column, entries) in frame.iter().zip(out.chunks_exact_mut(3)) {
            entries.copy_from_slice(&column.0[..3]);
        }
    }
    #[inline(always)]
    fn store(self, out: &mut [f64; 4]) {
        *out = self.0;
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Portable([x; 4], std::marker::PhantomData)
    }
    #[inline(always)]
    fn from_entries(e: [f64; 4]) -> Self {
        Portable(e, std::marker::PhantomData)
    }
    #[inline(always)]
    fn mul_add(a: Self, b: Self, c: Self) -> Self {
        Self::map(|k| A::mul_add(a.0[k], b.0[k], c.0[k]))
    }
    #[inline(always)]
    fn mul(a: Self, b: Self) -> Self {
        Self::map(|k| a.0[k] * b.0[k])
    }
    #[inline(always)]
    fn add(a: Self, b: Self) -> Self {
        Self::map(|k| a.0[k] + b.0[k])
    }
    #[inline(always)]
    fn sub(a: Self, b: Self) -> Self {
        Self::map(|k| a.0[k] - b.0[k])
    }
    #[inline(always)]
    fn neg(self) -> Self {
        Self::map(|k| -self.0[k])
    }
    #[inline(always)]
    fn yzx(self) -> Self {
        let v = self.0;
        Portable([v[1], v[2], v[0], v[3]], std::marker::PhantomData)
    }
    #[inline(always)]
    fn zxy(self) -> Self {
        let v = self.0;
        Portable([v[2], v[0], v[1], v[3]], std::marker::PhantomData)
    }
}

impl Num for Lanes {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Lanes([x; LANES])
    }
    #[inline(always)]
    fn mul_add<A: Arith>(a: Self, b: Self, c: Self) -> Self {
        Lanes(each_lane!(8, |i| A::mul_add(a.0[i], b.0[i], c.0[i])))
    }
    #[inline(always)]
    fn sin_cos<A: Arith>(x: Self) -> (Self, Self) {
        let (s, c) = lanes_sin_cos::<A, LANES>(x.0);
        (Lanes(s), Lanes(c))
    }
}

/// `sin` and `cos` lane by lane (a loop the compiler vectorises to the lane width).
#[inline(always)]
pub(crate) fn lanes_sin_cos<A: Arith, const W: usize>(x: [f64; W]) -> ([f64; W], [f64; W]) {
    let (mut s, mut c) = ([0.0; W], [0.0; W]);
    let mut big = false;
    for i in 0..W {
        (s[i], c[i]) = crate::eval::simd::trig::sin_cos_reduced::<A>(x[i]);
        big |= x[i].abs() >= crate::eval::simd::trig::REDUCTION_LIMIT;
    }
    // Rare: arguments beyond the fast reduction (or NaN never reaches here: inputs are checked).
    if big {
        for i in 0..W {
            if x[i].abs() >= crate::eval::simd::trig::REDUCTION_LIMIT {
                (s[i], c[i]) = x[i].sin_cos();
            }
        }
    }
    (s, c)
}

impl LaneNum for Lanes {
    const PARTS: usize = 1;
    #[inline(always)]
    fn cast(q: &[Lanes]) -> &[Self] {
        q
    }
    #[inline(always)]
    fn get(x: &Lanes, _: usize) -> Self {
        *x
    }
    #[inline(always)]
    fn put(self, x: &mut Lanes, _: usize) {
        *x = self;
    }
    /// Four SSE2 non-temporal stores (part of baseline x86-64), which fill one line.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn stream(self, x: &mut Lanes) {
        use std::arch::x86_64::{_mm_loadu_pd, _mm_stream_pd};
        for (pair, out) in self.0.chunks_exact(2).zip(x.0.chunks_exact_mut(2)) {
            // SAFETY: SSE2 is part of x86-64; `out` is two `f64` of a `Lanes` (aligned to 64
            // bytes), so 16-byte aligned as the store requires, and `pair` two readable `f64`.
            unsafe { _mm_stream_pd(out.as_mut_ptr(), _mm_loadu_pd(pair.as_ptr())) }
        }
    }
    #[inline(always)]
    fn admitted(x: Self, scale: f64, offset: f64, lower: f64, upper: f64) -> bool {
        let ok = each_lane!(8, |i| crate::eval::simd::traits::within(
            x.0[i],
            (scale, offset, lower, upper)
        ));
        ok[0] & ok[1] & ok[2] & ok[3] & ok[4] & ok[5] & ok[6] & ok[7]
    }
    #[inline(always)]
    fn transpose(q: &mut [Lanes], qs: &[f64], rows: [usize; LANES]) {
        let dof = q.len();
        for (j, qj) in q.iter_mut().enumerate() {
            *qj = Lanes(std::array::from_fn(|l| qs[rows[l] * dof + j]));
        }
    }
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
        crate::eval::simd::trig::sin_cos::<A>(x)
    }
}
