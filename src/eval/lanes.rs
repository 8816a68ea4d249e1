//! The lane types of the batch kernels: [`Lanes`] (eight configurations, as stored between
//! kernels) and the register-sized views a kernel computes with ([`LaneNum`]: `Lanes` itself, and
//! on x86-64 the AVX2 `Y4` and AVX-512 `Z8`), with the transposition of joint rows into lanes and
//! the streaming stores of results.

// Index loops over lanes and rows are the shape the vectoriser expects here.
#![allow(clippy::needless_range_loop)]

use crate::eval::arith::Arith;
use crate::eval::kernel::{Frame, Num};
use crate::eval::trig;
use std::ops::{Add, Mul, Neg, Sub};

/// Number of configurations a batch kernel evaluates together.
pub(crate) const LANES: usize = 8;
// `each_lane!(8, ..)` writes out this many lanes.
const _: () = assert!(LANES == 8);

/// [`LANES`] values, one per configuration; arithmetic is lane-wise.
/// Aligned to its size, so that a lane vector never straddles two cache lines (a load that
/// does cannot be forwarded from the store before it, and spilled frames are stored and reloaded
/// once per joint).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(crate) struct Lanes(pub(crate) [f64; LANES]);

impl Lanes {
    /// The values of `chunks`, one chunk after the other.
    #[inline(always)]
    pub(crate) fn flat(chunks: &[Lanes]) -> &[f64] {
        // SAFETY: `Lanes` is `repr(C)` around `[f64; LANES]`, of size `8 · LANES` (a multiple of
        // its alignment, so no padding): a slice of it is `LANES · len` initialised `f64`.
        unsafe { std::slice::from_raw_parts(chunks.as_ptr().cast(), LANES * chunks.len()) }
    }

    /// [`Lanes::flat`], writable.
    #[inline(always)]
    pub(crate) fn flat_mut(chunks: &mut [Lanes]) -> &mut [f64] {
        // SAFETY: as in `flat`; every bit pattern is a valid `f64`.
        unsafe { std::slice::from_raw_parts_mut(chunks.as_mut_ptr().cast(), LANES * chunks.len()) }
    }
}

const _: () = assert!(size_of::<Lanes>() == LANES * size_of::<f64>());

/// `[e(0), e(1), …, e(7)]` for the lane index `i`, written out rather than looped: the lane-wise
/// operations of the baseline build's lane type inline into thousands per kernel, and as loops
/// each one was rotated, then fully unrolled, by the optimiser (most of the crate's build time).
/// Written out, the optimiser sees the straight-line code it would have unrolled them into.
macro_rules! each_lane {
    (8, |$i:ident| $e:expr) => {
        [
            {
                let $i = 0;
                $e
            },
            {
                let $i = 1;
                $e
            },
            {
                let $i = 2;
                $e
            },
            {
                let $i = 3;
                $e
            },
            {
                let $i = 4;
                $e
            },
            {
                let $i = 5;
                $e
            },
            {
                let $i = 6;
                $e
            },
            {
                let $i = 7;
                $e
            },
        ]
    };
}

macro_rules! lanewise {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for Lanes {
            type Output = Lanes;
            #[inline(always)]
            fn $method(self, rhs: Lanes) -> Lanes {
                Lanes(each_lane!(8, |i| self.0[i] $op rhs.0[i]))
            }
        }
    };
}
lanewise!(Add, add, +);
lanewise!(Sub, sub, -);
lanewise!(Mul, mul, *);

impl Neg for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn neg(self) -> Lanes {
        Lanes(each_lane!(8, |i| -self.0[i]))
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
        (s[i], c[i]) = trig::sin_cos_reduced::<A>(x[i]);
        big |= x[i].abs() >= trig::REDUCTION_LIMIT;
    }
    // Rare: arguments beyond the fast reduction (or NaN never reaches here: inputs are checked).
    if big {
        for i in 0..W {
            if x[i].abs() >= trig::REDUCTION_LIMIT {
                (s[i], c[i]) = x[i].sin_cos();
            }
        }
    }
    (s, c)
}

/// Panics unless every row `rows[l]` of `dof` entries lies within `qs` (what the vector loads of
/// a transposition rely on).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn assert_rows_within(qs: &[f64], rows: &[usize; LANES], dof: usize) {
    // The last row decides: one check rather than one per row.
    let last = rows.iter().fold(0, |m, &r| m.max(r));
    let in_bounds = last
        .checked_mul(dof)
        .and_then(|o| o.checked_add(dof))
        .is_some_and(|e| e <= qs.len());
    assert!(in_bounds, "rows {rows:?} of {} entries", qs.len());
}

/// The lane number of a batch kernel: one [`Lanes`] as `PARTS` values of `LANES / PARTS`
/// configurations each (a kernel evaluates the parts one after the other, so that a frame of
/// this type fits the registers). Stored between kernels as [`Lanes`].
pub(crate) trait LaneNum: Num {
    /// Number of values of this type in one [`Lanes`].
    const PARTS: usize;
    /// `q` (as [`LaneNum::transpose`] wrote it) read as `PARTS` runs of `q.len()` values, the
    /// run of part 0 first.
    fn cast(q: &[Lanes]) -> &[Self];
    /// Part `part` of `x`.
    fn get(x: &Lanes, part: usize) -> Self;
    /// Writes `self` as part `part` of `x`.
    fn put(self, x: &mut Lanes, part: usize);
    /// Writes `self` as the whole of `x` (a type of one part: a whole [`Lanes`] is one cache
    /// line), around the caches where the type can (a non-temporal store: the line is not read
    /// first and does not evict other data); the writing thread must then call
    /// [`fence_streams`] before the memory is read or written again. By default, and on other
    /// architectures, an ordinary store.
    #[inline(always)]
    fn stream(self, x: &mut Lanes) {
        self.put(x, 0);
    }
    /// Whether every lane `x` is [`crate::eval::layout::within`] `(scale, offset, lower, upper)`.
    fn admitted(x: Self, scale: f64, offset: f64, lower: f64, upper: f64) -> bool;
    /// Transposes rows of `qs` (row-major, `q.len()` entries per row) into lanes: entry `j` of
    /// rows `rows[0..8]`, in the layout [`LaneNum::cast`] reads.
    ///
    /// # Panics
    /// If a row is not within `qs`.
    fn transpose(q: &mut [Lanes], qs: &[f64], rows: [usize; LANES]);
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
        let ok = each_lane!(8, |i| crate::eval::layout::within(
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

impl<N: LaneNum> Frame<N> {
    /// Part `part` of a stored frame.
    #[inline(always)]
    pub(crate) fn get(f: &Frame<Lanes>, part: usize) -> Self {
        // Written out rather than looped (see `each_lane`).
        let r = |i: usize| {
            [
                N::get(&f.r[i][0], part),
                N::get(&f.r[i][1], part),
                N::get(&f.r[i][2], part),
            ]
        };
        Frame {
            r: [r(0), r(1), r(2)],
            p: [
                N::get(&f.p[0], part),
                N::get(&f.p[1], part),
                N::get(&f.p[2], part),
            ],
        }
    }
    /// Writes the columns of `self` chosen by `COLUMNS` (bit `i` for rotation column `i`, bit 3
    /// for the origin) as part `part` of `f`.
    #[inline(always)]
    pub(crate) fn put_columns<const COLUMNS: u8>(&self, f: &mut Frame<Lanes>, part: usize) {
        for i in 0..3 {
            if COLUMNS & (1 << i) != 0 {
                for j in 0..3 {
                    self.r[i][j].put(&mut f.r[i][j], part);
                }
            }
        }
        if COLUMNS & 8 != 0 {
            for j in 0..3 {
                self.p[j].put(&mut f.p[j], part);
            }
        }
    }
    /// Writes `self` as part `part` of `f`.
    #[inline(always)]
    pub(crate) fn put(&self, f: &mut Frame<Lanes>, part: usize) {
        for i in 0..3 {
            for j in 0..3 {
                self.r[i][j].put(&mut f.r[i][j], part);
            }
            self.p[i].put(&mut f.p[i], part);
        }
    }
    /// Writes `self` as the whole of `f` with [`LaneNum::stream`] (a type of one part), in
    /// memory order: twelve whole lines.
    #[inline(always)]
    pub(crate) fn stream(&self, f: &mut Frame<Lanes>) {
        for i in 0..3 {
            for j in 0..3 {
                self.r[i][j].stream(&mut f.r[i][j]);
            }
        }
        for j in 0..3 {
            self.p[j].stream(&mut f.p[j]);
        }
    }
}

/// Orders the calling thread's [`LaneNum::stream`] stores before its later memory accesses (and
/// so before anything it then synchronises with): required before streamed memory is used.
#[inline(always)]
pub(crate) fn fence_streams() {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE is part of x86-64; a fence has no other effect.
    unsafe {
        std::arch::x86_64::_mm_sfence();
    }
}

/// Four `f64` in one AVX register: the lane type of [`crate::eval::arith::Fused`] (AVX2), two per
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
        crate::eval::arith::within_all_256(x.0, limits)
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
/// fits the 32 registers). Only the lane type of [`crate::eval::arith::Fused512`].
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
