//! Fused multiply–add: the [`Fused`] and [`Fused512`] policies and the x86-64 vector types they
//! compute with ([`Avx`] columns, [`Y4`] and [`Z8`] lanes). Only instantiated inside functions
//! compiled with the matching target features (see [`crate::eval::simd::isa`]).

// Index loops over lanes and rows are the shape the vectoriser expects here.
#![allow(clippy::needless_range_loop)]

use crate::eval::simd::lanes::{LANES, Lanes, assert_rows_within};
use crate::eval::simd::portable::lanes_sin_cos;
use crate::eval::simd::traits::{Arith, Col, LaneNum, Num};
use std::ops::{Add, Mul, Neg, Sub};

/// One rounding (hardware FMA). Only instantiated inside functions compiled with the `fma`
/// and `avx2` target features, or (tests) after [`isa`] has reported them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fused;

impl Arith for Fused {
    #[cfg(target_arch = "x86_64")]
    type Col = Avx;
    #[cfg(not(target_arch = "x86_64"))]
    type Col = Portable<Fused>;
    #[cfg(target_arch = "x86_64")]
    type Lanes = crate::eval::simd::fused::Y4;
    #[cfg(not(target_arch = "x86_64"))]
    type Lanes = Lanes;
    const FUSED: bool = true;
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

/// [`Fused`] with the batch lanes in AVX-512 registers ([`Z8`]): only instantiated inside
/// functions compiled with the `avx512f` target feature. Every operation is the one [`Fused`]
/// performs, so results are the same bit for bit.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fused512;

#[cfg(target_arch = "x86_64")]
impl Arith for Fused512 {
    type Col = Avx;
    type Lanes = Z8;
    const FUSED: bool = true;
    const WIDE: bool = true;
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

/// [`Col`] in an AVX register, with FMA.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx(std::arch::x86_64::__m256d);

/// [`crate::eval::simd::traits::within`] for four values at once, each against the same entry of
/// `(scale, offset, lower, upper)`: the product and the sum rounded separately, then three
/// compares. Used by [`Avx`] and the AVX2 batch lanes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn within_all_256(
    x: std::arch::x86_64::__m256d,
    [scale, offset, lower, upper]: [std::arch::x86_64::__m256d; 4],
) -> bool {
    use std::arch::x86_64::{
        _CMP_GE_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm256_add_pd, _mm256_and_pd, _mm256_andnot_pd,
        _mm256_cmp_pd, _mm256_movemask_pd, _mm256_mul_pd, _mm256_set1_pd,
    };
    // SAFETY: only called from code compiled with, or dispatched to after detecting, AVX.
    unsafe {
        let value = _mm256_add_pd(_mm256_mul_pd(scale, x), offset);
        let abs = _mm256_andnot_pd(_mm256_set1_pd(-0.0), x);
        let finite = _mm256_cmp_pd::<_CMP_LT_OQ>(abs, _mm256_set1_pd(f64::INFINITY));
        let low = _mm256_cmp_pd::<_CMP_GE_OQ>(value, lower);
        let high = _mm256_cmp_pd::<_CMP_LE_OQ>(value, upper);
        _mm256_movemask_pd(_mm256_and_pd(finite, _mm256_and_pd(low, high))) == 0b1111
    }
}

// SAFETY (every `unsafe` block below): `Avx` is the column type of `Fused` only, and `Fused` runs
// only where `isa()` has reported AVX2 and FMA (inside the `fma_dispatch!` functions, or in tests
// guarded by that check); the pointer operations read and write through references of the
// stated sizes.
#[cfg(target_arch = "x86_64")]
impl Col for Avx {
    #[inline(always)]
    fn admitted(x: Self, [scale, offset, lower, upper]: [Self; 4]) -> bool {
        within_all_256(x.0, [scale.0, offset.0, lower.0, upper.0])
    }
    #[inline(always)]
    fn load(v: &[f64; 4]) -> Self {
        use std::arch::x86_64::_mm256_loadu_pd;
        Avx(unsafe { _mm256_loadu_pd(v.as_ptr()) })
    }
    #[inline(always)]
    fn store_frame([r0, r1, r2, p]: [Self; 4], out: &mut [f64; 12]) {
        use std::arch::x86_64::_mm256_storeu_pd as store;
        use std::arch::x86_64::{_mm256_blend_pd as blend, _mm256_permute4x64_pd as permute};
        // Three vectors of four entries, each a blend of two permuted columns (the compiler
        // chooses the shuffles: six on AVX-512, where it has two-source permutes).
        unsafe {
            // [r0x r0y r0z r1x]
            let a = blend::<0b1000>(r0.0, permute::<0b00_00_00_00>(r1.0));
            // [r1y r1z r2x r2y]
            let b = blend::<0b1100>(
                permute::<0b00_00_10_01>(r1.0),
                permute::<0b01_00_00_00>(r2.0),
            );
            // [r2z px py pz]
            let c = blend::<0b0001>(
                permute::<0b10_01_00_00>(p.0),
                permute::<0b00_00_00_10>(r2.0),
            );
            let out = out.as_mut_ptr();
            store(out, a);
            store(out.add(4), b);
            store(out.add(8), c);
        }
    }
    #[inline(always)]
    fn store(self, out: &mut [f64; 4]) {
        use std::arch::x86_64::_mm256_storeu_pd;
        unsafe { _mm256_storeu_pd(out.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        use std::arch::x86_64::_mm256_set1_pd;
        Avx(unsafe { _mm256_set1_pd(x) })
    }
    #[inline(always)]
    fn from_entries(e: [f64; 4]) -> Self {
        use std::arch::x86_64::_mm256_set_pd;
        Avx(unsafe { _mm256_set_pd(e[3], e[2], e[1], e[0]) })
    }
    #[inline(always)]
    fn mul_add(a: Self, b: Self, c: Self) -> Self {
        use std::arch::x86_64::_mm256_fmadd_pd;
        Avx(unsafe { _mm256_fmadd_pd(a.0, b.0, c.0) })
    }
    #[inline(always)]
    fn mul(a: Self, b: Self) -> Self {
        use std::arch::x86_64::_mm256_mul_pd;
        Avx(unsafe { _mm256_mul_pd(a.0, b.0) })
    }
    #[inline(always)]
    fn add(a: Self, b: Self) -> Self {
        use std::arch::x86_64::_mm256_add_pd;
        Avx(unsafe { _mm256_add_pd(a.0, b.0) })
    }
    #[inline(always)]
    fn sub(a: Self, b: Self) -> Self {
        use std::arch::x86_64::_mm256_sub_pd;
        Avx(unsafe { _mm256_sub_pd(a.0, b.0) })
    }
    #[inline(always)]
    fn neg(self) -> Self {
        use std::arch::x86_64::{_mm256_set1_pd, _mm256_xor_pd};
        Avx(unsafe { _mm256_xor_pd(self.0, _mm256_set1_pd(-0.0)) })
    }
    #[inline(always)]
    fn yzx(self) -> Self {
        use std::arch::x86_64::_mm256_permute4x64_pd;
        Avx(unsafe { _mm256_permute4x64_pd::<0b11_00_10_01>(self.0) })
    }
    #[inline(always)]
    fn zxy(self) -> Self {
        use std::arch::x86_64::_mm256_permute4x64_pd;
        Avx(unsafe { _mm256_permute4x64_pd::<0b11_01_00_10>(self.0) })
    }
}

/// Four `f64` in one AVX register: the lane type of [`crate::eval::simd::fused::Fused`] (AVX2), two per
/// [`Lanes`]. A frame of eight-lane values would be 24 of the 16 registers, and spilled at
/// every step; one of four fits.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct Y4(std::arch::x86_64::__m256d);

// `Y4` is read through pointers to `Lanes`: two fit one, each aligned to its size.
#[cfg(target_arch = "x86_64")]
const _: () = assert!(
    2 * size_of::<Y4>() == size_of::<Lanes>()
        && align_of::<Lanes>().is_multiple_of(align_of::<Y4>())
);

// SAFETY (every `unsafe` block of the `Y4` impls): `Y4` is the lane type of `Fused` only, which
// runs inside the `fma_dispatch!` functions compiled with `avx2` and `fma` (selected when `isa()`
// reports them); the pointer casts stay within a `Lanes` or a slice of them (checked sizes above),
// and every bit pattern is a valid `f64`.
#[cfg(target_arch = "x86_64")]
impl LaneNum for Y4 {
    const PARTS: usize = 2;
    #[inline(always)]
    fn cast(q: &[Lanes]) -> &[Self] {
        unsafe { std::slice::from_raw_parts(q.as_ptr().cast(), 2 * q.len()) }
    }
    #[inline(always)]
    fn get(x: &Lanes, part: usize) -> Self {
        let half = &x.0[4 * part..4 * part + 4];
        Y4(unsafe { std::arch::x86_64::_mm256_loadu_pd(half.as_ptr()) })
    }
    #[inline(always)]
    fn put(self, x: &mut Lanes, part: usize) {
        let half = &mut x.0[4 * part..4 * part + 4];
        unsafe { std::arch::x86_64::_mm256_storeu_pd(half.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn admitted(x: Self, scale: f64, offset: f64, lower: f64, upper: f64) -> bool {
        let limits = [
            Y4::splat(scale).0,
            Y4::splat(offset).0,
            Y4::splat(lower).0,
            Y4::splat(upper).0,
        ];
        crate::eval::simd::fused::within_all_256(x.0, limits)
    }
    /// Part 0 (rows 0..4) of every entry, then part 1: four entries of four rows at a time,
    /// read as whole vectors (masked past the end of a row) and transposed in registers.
    #[inline(always)]
    fn transpose(q: &mut [Lanes], qs: &[f64], rows: [usize; LANES]) {
        use std::arch::x86_64::{
            __m256d, __m256i, _mm256_loadu_pd, _mm256_maskload_pd, _mm256_permute2f128_pd,
            _mm256_setr_epi64x, _mm256_unpackhi_pd, _mm256_unpacklo_pd,
        };
        /// Rows `a` as four columns: rows interleaved in pairs, then 128-bit halves exchanged.
        #[inline(always)]
        fn columns(a: [__m256d; 4]) -> [__m256d; 4] {
            // SAFETY: see the `Y4` impls.
            unsafe {
                let lo01 = _mm256_unpacklo_pd(a[0], a[1]);
                let hi01 = _mm256_unpackhi_pd(a[0], a[1]);
                let lo23 = _mm256_unpacklo_pd(a[2], a[3]);
                let hi23 = _mm256_unpackhi_pd(a[2], a[3]);
                [
                    _mm256_permute2f128_pd::<0x20>(lo01, lo23),
                    _mm256_permute2f128_pd::<0x20>(hi01, hi23),
                    _mm256_permute2f128_pd::<0x31>(lo01, lo23),
                    _mm256_permute2f128_pd::<0x31>(hi01, hi23),
                ]
            }
        }
        let dof = q.len();
        assert_rows_within(qs, &rows, dof);
        let out = Y4::cast_mut(q);
        let full = dof - dof % 4;
        let n = dof - full;
        // Lane i of the mask (sign bit set) loads entry `full + i` of the last, partial block.
        let lane = |i: usize| -i64::from(i < n);
        // SAFETY: see the `Y4` impls.
        let mask: __m256i = unsafe { _mm256_setr_epi64x(lane(0), lane(1), lane(2), lane(3)) };
        for part in 0..2 {
            let starts: [usize; 4] = std::array::from_fn(|l| rows[4 * part + l] * dof);
            let out = &mut out[part * dof..(part + 1) * dof];
            for first in (0..full).step_by(4) {
                // SAFETY: see the `Y4` impls; each load reads entries `first..first + 4` of a
                // row, within `qs` as checked above.
                let a = std::array::from_fn(|l| unsafe {
                    _mm256_loadu_pd(qs.as_ptr().add(starts[l] + first))
                });
                for (o, c) in out[first..first + 4].iter_mut().zip(columns(a)) {
                    *o = Y4(c);
                }
            }
            if n > 0 {
                // SAFETY: as above, for entries `full..dof` (masked entries are not read).
                let a = std::array::from_fn(|l| unsafe {
                    _mm256_maskload_pd(qs.as_ptr().add(starts[l] + full), mask)
                });
                for (o, c) in out[full..].iter_mut().zip(columns(a)) {
                    *o = Y4(c);
                }
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Y4 {
    #[inline(always)]
    fn cast_mut(q: &mut [Lanes]) -> &mut [Self] {
        // SAFETY: see the `Y4` impls.
        unsafe { std::slice::from_raw_parts_mut(q.as_mut_ptr().cast(), 2 * q.len()) }
    }
}

/// Eight `f64` in one AVX-512 register: [`Lanes`] for kernels compiled with `avx512f`, where an
/// array of eight would be assembled and spilled through memory (a frame is twelve of them, and
/// fits the 32 registers). Only the lane type of [`crate::eval::simd::fused::Fused512`].
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct Z8(std::arch::x86_64::__m512d);

// `Z8` and `Lanes` are read through each other's pointers: same size and alignment, and every
// bit pattern is valid for both.
#[cfg(target_arch = "x86_64")]
const _: () =
    assert!(size_of::<Z8>() == size_of::<Lanes>() && align_of::<Z8>() == align_of::<Lanes>());

// SAFETY (every `unsafe` block of the `Z8` impls): `Z8` is the lane type of `Fused512` only, which
// runs only inside the `fma_dispatch!` functions compiled with `avx512f` (selected when `isa()`
// reports it); the casts are between types of equal size and alignment (checked above).
#[cfg(target_arch = "x86_64")]
impl LaneNum for Z8 {
    const PARTS: usize = 1;
    #[inline(always)]
    fn cast(q: &[Lanes]) -> &[Self] {
        unsafe { std::slice::from_raw_parts(q.as_ptr().cast(), q.len()) }
    }
    #[inline(always)]
    fn get(x: &Lanes, _: usize) -> Self {
        Z8::from_lanes(*x)
    }
    #[inline(always)]
    fn put(self, x: &mut Lanes, _: usize) {
        *x = self.lanes();
    }
    #[inline(always)]
    fn stream(self, x: &mut Lanes) {
        // SAFETY: see the `Z8` impls; a `Lanes` is 64-byte aligned, as the store requires.
        unsafe { std::arch::x86_64::_mm512_stream_pd(x.0.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn admitted(x: Self, scale: f64, offset: f64, lower: f64, upper: f64) -> bool {
        use std::arch::x86_64::{
            _CMP_GE_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm512_abs_pd, _mm512_add_pd, _mm512_cmp_pd_mask,
            _mm512_mul_pd, _mm512_set1_pd,
        };
        // SAFETY: see the `Z8` impls.
        unsafe {
            let splat = _mm512_set1_pd;
            let value = _mm512_add_pd(_mm512_mul_pd(splat(scale), x.0), splat(offset));
            let finite = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(_mm512_abs_pd(x.0), splat(f64::INFINITY));
            let low = _mm512_cmp_pd_mask::<_CMP_GE_OQ>(value, splat(lower));
            let high = _mm512_cmp_pd_mask::<_CMP_LE_OQ>(value, splat(upper));
            finite & low & high == u8::MAX
        }
    }
    /// Eight rows read with masked loads (eight joints at a time) and transposed in registers
    /// (24 shuffles per eight joints), each lane vector written whole. (Entries stored one by one
    /// and read back as a vector would stall the load; the compiler's vectorised form of the
    /// lane loop scatters, and a gather per joint costs about a sixth of a one-link batch on
    /// AMD cores.)
    #[inline(always)]
    fn transpose(q: &mut [Lanes], qs: &[f64], rows: [usize; LANES]) {
        use std::arch::x86_64::{
            __m512d, _mm512_maskz_loadu_pd, _mm512_shuffle_f64x2, _mm512_unpackhi_pd,
            _mm512_unpacklo_pd,
        };
        let dof = q.len();
        assert_rows_within(qs, &rows, dof);
        let starts = rows.map(|r| r * dof);
        let q = Z8::cast_mut(q);
        for (block, out) in q.chunks_mut(LANES).enumerate() {
            let first = block * LANES;
            let mask = u8::MAX >> (LANES - out.len());
            // SAFETY: see the `Z8` impls; each load reads entries `first..first + out.len()` of
            // a row (masked entries are not read), within `qs` as checked above.
            unsafe {
                let a: [__m512d; LANES] = std::array::from_fn(|l| {
                    _mm512_maskz_loadu_pd(mask, qs.as_ptr().add(starts[l] + first))
                });
                // Pairs of rows interleaved, then 128-bit blocks, then 256-bit halves.
                let t: [__m512d; LANES] = std::array::from_fn(|i| {
                    let (x, y) = (a[2 * (i / 2)], a[2 * (i / 2) + 1]);
                    if i % 2 == 0 {
                        _mm512_unpacklo_pd(x, y)
                    } else {
                        _mm512_unpackhi_pd(x, y)
                    }
                });
                let blocks = |x: __m512d, y: __m512d, odd: bool| {
                    if odd {
                        _mm512_shuffle_f64x2::<0xdd>(x, y)
                    } else {
                        _mm512_shuffle_f64x2::<0x88>(x, y)
                    }
                };
                // u[i] for i < 4 holds columns (i, i + 4) of rows 0..4; u[i + 4] of rows 4..8.
                let u: [__m512d; LANES] = std::array::from_fn(|i| {
                    let (half, k) = (i / 4, i % 4);
                    blocks(t[4 * half + k % 2], t[4 * half + 2 + k % 2], k >= 2)
                });
                for (j, o) in out.iter_mut().enumerate() {
                    let k = j % 4;
                    *o = Z8(blocks(u[k], u[k + 4], j >= 4));
                }
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Z8 {
    #[inline(always)]
    fn cast_mut(q: &mut [Lanes]) -> &mut [Self] {
        // SAFETY: see the `Z8` impls.
        unsafe { std::slice::from_raw_parts_mut(q.as_mut_ptr().cast(), q.len()) }
    }
    #[inline(always)]
    fn lanes(self) -> Lanes {
        // SAFETY: as above (same size, every bit pattern valid).
        unsafe { std::mem::transmute::<Z8, Lanes>(self) }
    }
    #[inline(always)]
    fn from_lanes(x: Lanes) -> Self {
        // SAFETY: as above.
        unsafe { std::mem::transmute::<Lanes, Z8>(x) }
    }
}

/// The arithmetic of a lane type held in one SIMD register of `$width` doubles: operators,
/// splat and multiply–add by intrinsics, `sin`/`cos` by the lane loop of [`lanes_sin_cos`]
/// (which the compiler vectorises to the same width).
#[cfg(target_arch = "x86_64")]
macro_rules! simd_num {
    ($ty:ident, $width:literal, $add:ident, $sub:ident, $mul:ident, $xor:ident, $set1:ident, $fmadd:ident) => {
        impl Add for $ty {
            type Output = $ty;
            #[inline(always)]
            fn add(self, rhs: $ty) -> $ty {
                // SAFETY: see the type's `LaneNum` impl.
                $ty(unsafe { std::arch::x86_64::$add(self.0, rhs.0) })
            }
        }
        impl Sub for $ty {
            type Output = $ty;
            #[inline(always)]
            fn sub(self, rhs: $ty) -> $ty {
                // SAFETY: as above.
                $ty(unsafe { std::arch::x86_64::$sub(self.0, rhs.0) })
            }
        }
        impl Mul for $ty {
            type Output = $ty;
            #[inline(always)]
            fn mul(self, rhs: $ty) -> $ty {
                // SAFETY: as above.
                $ty(unsafe { std::arch::x86_64::$mul(self.0, rhs.0) })
            }
        }
        impl Neg for $ty {
            type Output = $ty;
            #[inline(always)]
            fn neg(self) -> $ty {
                // SAFETY: as above.
                $ty(unsafe { std::arch::x86_64::$xor(self.0, std::arch::x86_64::$set1(-0.0)) })
            }
        }
        impl Num for $ty {
            #[inline(always)]
            fn splat(x: f64) -> Self {
                // SAFETY: as above.
                $ty(unsafe { std::arch::x86_64::$set1(x) })
            }
            #[inline(always)]
            fn mul_add<A: Arith>(a: Self, b: Self, c: Self) -> Self {
                if A::FUSED {
                    // SAFETY: as above.
                    $ty(unsafe { std::arch::x86_64::$fmadd(a.0, b.0, c.0) })
                } else {
                    a * b + c
                }
            }
            #[inline(always)]
            fn sin_cos<A: Arith>(x: Self) -> (Self, Self) {
                // SAFETY: as above (same size, every bit pattern valid).
                let lanes = unsafe { std::mem::transmute::<$ty, [f64; $width]>(x) };
                let (s, c) = lanes_sin_cos::<A, $width>(lanes);
                // SAFETY: as above.
                unsafe {
                    (
                        std::mem::transmute::<[f64; $width], $ty>(s),
                        std::mem::transmute::<[f64; $width], $ty>(c),
                    )
                }
            }
            #[inline(always)]
            fn two_over(self) -> Self {
                // SAFETY: as for `sin_cos`.
                let lanes = unsafe { std::mem::transmute::<$ty, [f64; $width]>(self) };
                // SAFETY: as above.
                unsafe { std::mem::transmute::<[f64; $width], $ty>(lanes.map(|x| 2.0 / x)) }
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
simd_num!(
    Y4,
    4,
    _mm256_add_pd,
    _mm256_sub_pd,
    _mm256_mul_pd,
    _mm256_xor_pd,
    _mm256_set1_pd,
    _mm256_fmadd_pd
);

#[cfg(target_arch = "x86_64")]
simd_num!(
    Z8,
    8,
    _mm512_add_pd,
    _mm512_sub_pd,
    _mm512_mul_pd,
    _mm512_xor_pd,
    _mm512_set1_pd,
    _mm512_fmadd_pd
);
