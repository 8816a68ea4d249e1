//! The baseline implementations: the [`Separate`] multiply–add policy, its [`Portable`] column
//! type, and [`Num`] / [`LaneNum`] for `f64` and [`Lanes`], in plain Rust that any target
//! compiles; on x86-64, the batch lanes of the baseline build are [`S8`], four SSE2 registers.

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
    #[cfg(target_arch = "x86_64")]
    type Lanes = S8;
    #[cfg(not(target_arch = "x86_64"))]
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
    /// `eval::simd::lanes::each_lane`: these inline into every body step of the baseline build).
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
    #[inline(always)]
    fn two_over(self) -> Self {
        Lanes(self.0.map(|x| 2.0 / x))
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
    #[inline(always)]
    fn two_over(self) -> Self {
        2.0 / self
    }
}

/// Eight `f64` in four SSE2 registers (part of baseline x86-64): the batch lanes of the baseline
/// build. Each lane-wise operation is one intrinsic per register, the operation [`Lanes`]
/// performs lane by lane, so the results are the same bits; written as eight scalar operations,
/// the baseline batch kernels were among the crate's slowest functions to optimise (the SLP
/// vectoriser rebuilt the pairs from thousands of scalars).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct S8([std::arch::x86_64::__m128d; 4]);

#[cfg(target_arch = "x86_64")]
const _: () =
    assert!(size_of::<S8>() == size_of::<Lanes>() && align_of::<S8>() == align_of::<Lanes>());

#[cfg(target_arch = "x86_64")]
impl S8 {
    /// The eight values.
    #[inline(always)]
    fn lanes(self) -> [f64; LANES] {
        // SAFETY: the same size, and every bit pattern of either is valid.
        unsafe { std::mem::transmute::<S8, [f64; LANES]>(self) }
    }
    #[inline(always)]
    fn from_lanes(x: [f64; LANES]) -> S8 {
        // SAFETY: as in `lanes`.
        unsafe { std::mem::transmute::<[f64; LANES], S8>(x) }
    }
}

/// `S8` arithmetic: one SSE2 intrinsic per register (SSE2 is part of every x86-64 target, so the
/// intrinsics are sound to call anywhere; they take and return values).
#[cfg(target_arch = "x86_64")]
macro_rules! sse2_lanewise {
    ($trait:ident, $method:ident, $intrinsic:ident) => {
        impl std::ops::$trait for S8 {
            type Output = S8;
            #[inline(always)]
            fn $method(self, rhs: S8) -> S8 {
                use std::arch::x86_64::$intrinsic as op;
                let (a, b) = (self.0, rhs.0);
                // SAFETY: SSE2 is part of every x86-64 target; the intrinsic takes values.
                unsafe {
                    S8([
                        op(a[0], b[0]),
                        op(a[1], b[1]),
                        op(a[2], b[2]),
                        op(a[3], b[3]),
                    ])
                }
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
sse2_lanewise!(Add, add, _mm_add_pd);
#[cfg(target_arch = "x86_64")]
sse2_lanewise!(Sub, sub, _mm_sub_pd);
#[cfg(target_arch = "x86_64")]
sse2_lanewise!(Mul, mul, _mm_mul_pd);

#[cfg(target_arch = "x86_64")]
impl std::ops::Neg for S8 {
    type Output = S8;
    #[inline(always)]
    fn neg(self) -> S8 {
        use std::arch::x86_64::{_mm_set1_pd, _mm_xor_pd};
        // SAFETY: SSE2 is part of every x86-64 target; the intrinsics take values.
        unsafe {
            let (a, sign) = (self.0, _mm_set1_pd(-0.0));
            S8([
                _mm_xor_pd(a[0], sign),
                _mm_xor_pd(a[1], sign),
                _mm_xor_pd(a[2], sign),
                _mm_xor_pd(a[3], sign),
            ])
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Num for S8 {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        // SAFETY: as for the arithmetic.
        let v = unsafe { std::arch::x86_64::_mm_set1_pd(x) };
        S8([v; 4])
    }
    #[inline(always)]
    fn mul_add<A: Arith>(a: Self, b: Self, c: Self) -> Self {
        if A::FUSED {
            let (a, b, c) = (a.lanes(), b.lanes(), c.lanes());
            S8::from_lanes(each_lane!(8, |i| A::mul_add(a[i], b[i], c[i])))
        } else {
            a * b + c
        }
    }
    #[inline(always)]
    fn sin_cos<A: Arith>(x: Self) -> (Self, Self) {
        let (s, c) = lanes_sin_cos::<A, LANES>(x.lanes());
        (S8::from_lanes(s), S8::from_lanes(c))
    }
    #[inline(always)]
    fn two_over(self) -> Self {
        S8::from_lanes(self.lanes().map(|x| 2.0 / x))
    }
}

#[cfg(target_arch = "x86_64")]
impl LaneNum for S8 {
    const PARTS: usize = 1;
    #[inline(always)]
    fn cast(q: &[Lanes]) -> &[Self] {
        // SAFETY: the same size and alignment (asserted above), every bit pattern valid.
        unsafe { std::slice::from_raw_parts(q.as_ptr().cast(), q.len()) }
    }
    #[inline(always)]
    fn get(x: &Lanes, _: usize) -> Self {
        S8::from_lanes(x.0)
    }
    #[inline(always)]
    fn put(self, x: &mut Lanes, _: usize) {
        x.0 = self.lanes();
    }
    /// Four non-temporal stores, which fill one line.
    #[inline(always)]
    fn stream(self, x: &mut Lanes) {
        use std::arch::x86_64::_mm_stream_pd;
        for (pair, out) in self.0.into_iter().zip(x.0.chunks_exact_mut(2)) {
            // SAFETY: `out` is two `f64` of a `Lanes` (aligned to 64 bytes), so 16-byte aligned
            // as the store requires.
            unsafe { _mm_stream_pd(out.as_mut_ptr(), pair) }
        }
    }
    #[inline(always)]
    fn admitted(x: Self, scale: f64, offset: f64, lower: f64, upper: f64) -> bool {
        Lanes::admitted(Lanes(x.lanes()), scale, offset, lower, upper)
    }
    #[inline(always)]
    fn transpose(q: &mut [Lanes], qs: &[f64], rows: [usize; LANES]) {
        Lanes::transpose(q, qs, rows);
    }
}
