//! The sixteen `f32` lanes of the single-precision batch: [`F16`], as stored between kernels,
//! and the register types each instruction set computes them in ([`Wide32::Lanes32`]), with
//! `sin`/`cos` in `f32`.
//!
//! [`F16`] is an array, and its arithmetic loops over it: inlined thousands of times into a
//! kernel, each loop was rotated and unrolled by the optimiser again (three copies of the
//! all-links kernel took 114 s of the crate's 250 s of LLVM function passes). The kernels compute
//! with a register type of the instruction set instead, each operation one intrinsic per
//! register ([`S16`]: four SSE registers, part of baseline x86-64; [`A16`]: two AVX registers;
//! [`Z16`]: one AVX-512 register), the same operations in the same order as the loops, so the
//! same bits; `F16` stays the storage between kernels and the type of other architectures.

// Index loops over lanes are the shape the vectoriser expects here.
#![allow(clippy::needless_range_loop)]

use crate::eval::kernel::frame::Frame;
use crate::eval::simd::fused::Fused;
#[cfg(target_arch = "x86_64")]
use crate::eval::simd::fused::Fused512;
use crate::eval::simd::portable::Separate;
use crate::eval::simd::traits::{Arith, Num};
use std::ops::{Add, Mul, Neg, Sub};

/// Number of configurations evaluated together.
pub(crate) const WIDTH: usize = 16;

/// [`WIDTH`] `f32` values, one per configuration, as stored between kernels; arithmetic is
/// lane-wise (loops; the kernels of x86-64 compute with [`Wide32::Lanes32`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(crate) struct F16(pub(crate) [f32; WIDTH]);

macro_rules! lanewise {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for F16 {
            type Output = F16;
            #[inline(always)]
            fn $method(self, rhs: F16) -> F16 {
                let mut out = [0.0; WIDTH];
                for i in 0..WIDTH {
                    out[i] = self.0[i] $op rhs.0[i];
                }
                F16(out)
            }
        }
    };
}

lanewise!(Add, add, +);

lanewise!(Sub, sub, -);

lanewise!(Mul, mul, *);

impl Neg for F16 {
    type Output = F16;
    #[inline(always)]
    fn neg(self) -> F16 {
        F16(self.0.map(|x| -x))
    }
}

/// Reduced angles below this in magnitude (2⁻⁴⁰ ≈ 9·10⁻¹³ rad) are taken as zero. They are
/// rounding residues: a joint at θ = π, stored as a double, leaves r = 1.2·10⁻¹⁶. Their powers in
/// the polynomials (r³ ≈ 10⁻⁴⁸) would underflow to subnormal `f32` values, which the hardware
/// handles slowly: on the Zen 5 host, the UR5 table's configurations at 0 and π took the whole
/// batch from 8.0 to 12.5 ns per configuration. Dropping the residue changes `sin` by at most
/// 9·10⁻¹³, about 10⁻⁵ `f32` ulps of 1.
const TINY: f32 = 9.094_947e-13;

impl Num for F16 {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        F16([x as f32; WIDTH])
    }
    #[inline(always)]
    fn mul_add<A: Arith>(a: Self, b: Self, c: Self) -> Self {
        let mut out = [0.0; WIDTH];
        for i in 0..WIDTH {
            // Fused only inside functions compiled with FMA (see `Arith::FUSED`).
            out[i] = if A::FUSED {
                a.0[i].mul_add(b.0[i], c.0[i])
            } else {
                a.0[i] * b.0[i] + c.0[i]
            };
        }
        F16(out)
    }
    #[inline(always)]
    fn sin_cos<A: Arith>(x: Self) -> (Self, Self) {
        sin_cos::<A>(x.0.map(f64::from))
    }
    #[inline(always)]
    fn two_over(self) -> Self {
        F16(self.0.map(|x| 2.0 / x))
    }
}

// sin r ≈ r + r³ (S1 + r² (S2 + r² S3)) and cos r ≈ 1 − r²/2 + r⁴ (C1 + r² (C2 + r² C3)) on
// |r| ≤ π/4: minimax fits for single precision (those of the Cephes library's `sinf`/`cosf`).
const S1: f32 = -1.666_665_5e-1;

const S2: f32 = 8.332_161e-3;

const S3: f32 = -1.951_529_6e-4;

const C1: f32 = 4.166_664_6e-2;

const C2: f32 = -1.388_731_6e-3;

const C3: f32 = 2.443_315_7e-5;

/// `(sin θ, cos θ)` in `f32` of sixteen angles given in `f64`: reduced in `f64`
/// ([`crate::eval::simd::trig::reduce`]), the remainder rounded to `f32` and the polynomials evaluated there.
/// Angles beyond the reduction's range take the standard library's `f64` functions.
#[inline(always)]
pub(crate) fn sin_cos<A: Arith>(theta: [f64; WIDTH]) -> (F16, F16) {
    let (mut s, mut c) = ([0.0_f32; WIDTH], [0.0_f32; WIDTH]);
    let mut big = false;
    for i in 0..WIDTH {
        let (r64, _, quadrant) = crate::eval::simd::trig::reduce::<A>(theta[i]);
        // r = r₃₂ + r_lo: the rounding of the remainder to f32 is kept, to first order.
        let r = r64 as f32;
        let r_lo = (r64 - f64::from(r)) as f32;
        // A select, not a branch: exact angles (0, ±π/2, π) are common in some batches and
        // not others, and a branch mispredicted once per body cost more than the select.
        let (r, r_lo) = if r.abs() < TINY {
            (0.0, 0.0)
        } else {
            (r, r_lo)
        };
        let z = r * r;
        let mul_add = |a: f32, b: f32, c: f32| if A::FUSED { a.mul_add(b, c) } else { a * b + c };
        let sin_r = mul_add(r * z, mul_add(z, mul_add(z, S3, S2), S1), r);
        let cos_r = mul_add(
            z * z,
            mul_add(z, mul_add(z, C3, C2), C1),
            mul_add(-0.5, z, 1.0),
        );
        // sin(r + r_lo) ≈ sin r + r_lo cos r. The like term of cos, −r_lo sin r, is at most
        // 2⁻²⁵ · 0.71 in size, about a third of an ulp of cos r ∈ [0.71, 1]: added, it never
        // changes the rounded result, so it is left out.
        let sin_r = mul_add(r_lo, cos_r, sin_r);
        // Quadrant k mod 4: 1 → (cos, −sin), 2 → (−sin, −cos), 3 → (−cos, sin).
        let (sr, cr) = if quadrant & 1 != 0 {
            (cos_r, sin_r)
        } else {
            (sin_r, cos_r)
        };
        let quadrant = quadrant as u32;
        s[i] = f32::from_bits(sr.to_bits() ^ ((quadrant & 2) << 30));
        c[i] = f32::from_bits(cr.to_bits() ^ ((quadrant.wrapping_add(1) & 2) << 30));
        big |= theta[i].abs() >= crate::eval::simd::trig::REDUCTION_LIMIT;
    }
    if big {
        for i in 0..WIDTH {
            if theta[i].abs() >= crate::eval::simd::trig::REDUCTION_LIMIT {
                let (sw, cw) = theta[i].sin_cos();
                (s[i], c[i]) = (sw as f32, cw as f32);
            }
        }
    }
    (F16(s), F16(c))
}

/// A number type with the layout of [`F16`], so that buffers of `F16` (joint values, frames) are
/// read and written as it.
///
/// # Safety
/// The type is `repr(C)` around sixteen `f32` lanes in `F16`'s order (64 bytes, aligned to 64),
/// and every bit pattern of it is valid.
pub(crate) unsafe trait Lanes32: Num {
    /// `x` as this type.
    #[inline(always)]
    fn view(x: &[F16]) -> &[Self] {
        const { assert!(size_of::<Self>() == size_of::<F16>() && align_of::<Self>() == 64) };
        // SAFETY: the trait's contract: the same size, alignment and valid bit patterns.
        unsafe { std::slice::from_raw_parts(x.as_ptr().cast(), x.len()) }
    }
    /// A stored frame as this type.
    #[inline(always)]
    fn frame(f: &Frame<F16>) -> &Frame<Self> {
        // SAFETY: `Frame` is `repr(C)` over twelve values; each is read as above.
        unsafe { &*std::ptr::from_ref(f).cast() }
    }
    /// [`Lanes32::frame`], writable.
    #[inline(always)]
    fn frame_mut(f: &mut Frame<F16>) -> &mut Frame<Self> {
        // SAFETY: as in `frame`; every bit pattern of `F16` is valid.
        unsafe { &mut *std::ptr::from_mut(f).cast() }
    }
    /// `x` as this type.
    #[inline(always)]
    fn from_f16(x: F16) -> Self {
        Self::view(std::slice::from_ref(&x))[0]
    }
    /// Writes `f` to the stored frame `out`, value by value: one register store each (a copy of
    /// the whole frame was a 768-byte `memcpy` call per body).
    #[inline(always)]
    fn store(f: &Frame<Self>, out: &mut Frame<F16>) {
        let out = Self::frame_mut(out);
        let ([r0, r1, r2], p) = (&f.r, &f.p);
        out.r[0] = [r0[0], r0[1], r0[2]];
        out.r[1] = [r1[0], r1[1], r1[2]];
        out.r[2] = [r2[0], r2[1], r2[2]];
        out.p = [p[0], p[1], p[2]];
    }
    /// The identity frame, from two splats (the kernel's starting frame, built in registers).
    #[inline(always)]
    fn identity() -> Frame<Self> {
        let (one, zero) = (Self::splat(1.0), Self::splat(0.0));
        Frame {
            r: [[one, zero, zero], [zero, one, zero], [zero, zero, one]],
            p: [zero, zero, zero],
        }
    }
}

// SAFETY: `F16` is the layout itself.
unsafe impl Lanes32 for F16 {}

/// A multiply–add policy and the type its instantiation of the `f32` kernels computes with.
pub(crate) trait Wide32: Arith {
    /// Sixteen `f32` lanes as this policy's instruction set holds them.
    type Lanes32: Lanes32;
}

#[cfg(target_arch = "x86_64")]
impl Wide32 for Separate {
    type Lanes32 = S16;
}

#[cfg(target_arch = "x86_64")]
impl Wide32 for Fused {
    type Lanes32 = A16;
}

#[cfg(target_arch = "x86_64")]
impl Wide32 for Fused512 {
    type Lanes32 = Z16;
}

#[cfg(not(target_arch = "x86_64"))]
impl Wide32 for Separate {
    type Lanes32 = F16;
}

#[cfg(not(target_arch = "x86_64"))]
impl Wide32 for Fused {
    type Lanes32 = F16;
}

/// Sixteen `f32` in four SSE registers (SSE is part of baseline x86-64).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct S16([std::arch::x86_64::__m128; 4]);

/// Sixteen `f32` in two AVX registers: only instantiated inside functions compiled with AVX2 and
/// FMA.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct A16([std::arch::x86_64::__m256; 2]);

/// Sixteen `f32` in one AVX-512 register: only instantiated inside functions compiled with
/// `avx512f` and `avx512dq`.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct Z16([std::arch::x86_64::__m512; 1]);

/// The arithmetic of a register type of [`Lanes32`], one intrinsic per register: `$add`, `$sub`,
/// `$mul` and `$xor` (with `−0.0`, the negation `-x` performs), `$set1`, and `$fmadd` where the
/// policy fuses (the separate product and sum otherwise, as `F16` computes them).
#[cfg(target_arch = "x86_64")]
macro_rules! registers32 {
    ($ty:ident, [$($i:tt),*], $add:ident, $sub:ident, $mul:ident, $xor:ident, $set1:ident, $fmadd:ident) => {
        // SAFETY (every block below): the type is only instantiated inside functions compiled
        // with the instruction set of its intrinsics (see the type), whose arguments are values.
        impl Add for $ty {
            type Output = $ty;
            #[inline(always)]
            fn add(self, rhs: $ty) -> $ty {
                $ty([$(unsafe { std::arch::x86_64::$add(self.0[$i], rhs.0[$i]) }),*])
            }
        }
        impl Sub for $ty {
            type Output = $ty;
            #[inline(always)]
            fn sub(self, rhs: $ty) -> $ty {
                $ty([$(unsafe { std::arch::x86_64::$sub(self.0[$i], rhs.0[$i]) }),*])
            }
        }
        impl Mul for $ty {
            type Output = $ty;
            #[inline(always)]
            fn mul(self, rhs: $ty) -> $ty {
                $ty([$(unsafe { std::arch::x86_64::$mul(self.0[$i], rhs.0[$i]) }),*])
            }
        }
        impl Neg for $ty {
            type Output = $ty;
            #[inline(always)]
            fn neg(self) -> $ty {
                $ty([$(unsafe {
                    std::arch::x86_64::$xor(self.0[$i], std::arch::x86_64::$set1(-0.0))
                }),*])
            }
        }
        impl Num for $ty {
            #[inline(always)]
            fn splat(x: f64) -> Self {
                $ty([$({
                    let _ = $i;
                    unsafe { std::arch::x86_64::$set1(x as f32) }
                }),*])
            }
            #[inline(always)]
            fn mul_add<A: Arith>(a: Self, b: Self, c: Self) -> Self {
                if A::FUSED {
                    $ty([$(unsafe { std::arch::x86_64::$fmadd(a.0[$i], b.0[$i], c.0[$i]) }),*])
                } else {
                    a * b + c
                }
            }
            #[inline(always)]
            fn sin_cos<A: Arith>(x: Self) -> (Self, Self) {
                // SAFETY: the layout of `F16` (the type's `Lanes32` contract).
                let x: F16 = unsafe { std::mem::transmute_copy(&x) };
                let (s, c) = F16::sin_cos::<A>(x);
                (Self::from_f16(s), Self::from_f16(c))
            }
            #[inline(always)]
            fn two_over(self) -> Self {
                // SAFETY: as for `sin_cos`.
                let x: F16 = unsafe { std::mem::transmute_copy(&self) };
                Self::from_f16(x.two_over())
            }
        }
        // SAFETY: `repr(C, align(64))` around 64 bytes of `f32` lanes in order.
        unsafe impl Lanes32 for $ty {}
    };
}

#[cfg(target_arch = "x86_64")]
registers32!(
    S16,
    [0, 1, 2, 3],
    _mm_add_ps,
    _mm_sub_ps,
    _mm_mul_ps,
    _mm_xor_ps,
    _mm_set1_ps,
    _mm_fmadd_ps
);

#[cfg(target_arch = "x86_64")]
registers32!(
    A16,
    [0, 1],
    _mm256_add_ps,
    _mm256_sub_ps,
    _mm256_mul_ps,
    _mm256_xor_ps,
    _mm256_set1_ps,
    _mm256_fmadd_ps
);

#[cfg(target_arch = "x86_64")]
registers32!(
    Z16,
    [0],
    _mm512_add_ps,
    _mm512_sub_ps,
    _mm512_mul_ps,
    _mm512_xor_ps,
    _mm512_set1_ps,
    _mm512_fmadd_ps
);
