//! The number traits every kernel is generic over: [`Arith`] (the multiply–add policy of an
//! instantiation), [`Col`] (four `f64` of a padded column), [`Num`] (what a kernel computes
//! with: one `f64` or a lane type) and [`LaneNum`] (a register-sized view of [`Lanes`]), and the
//! limit decision [`within`] they all make.

use crate::eval::simd::lanes::{LANES, Lanes};
use std::ops::{Add, Mul, Neg, Sub};

/// Multiply–add policy of a kernel instantiation.
pub(crate) trait Arith: Copy {
    /// Four `f64` handled as one vector, with this policy's multiply–add.
    type Col: Col;
    /// The `f64` of a batch chunk, one per configuration, as this instruction set holds them.
    type Lanes: LaneNum;
    /// Whether [`Arith::mul_add`] rounds once (then the exact product error
    /// `a * b − RN(a * b)` is one operation away).
    const FUSED: bool;
    /// Whether this instantiation runs in a function compiled for AVX-512 (where a vector of
    /// [`Lanes`] is one 512-bit register).
    const WIDE: bool = false;
    /// `a * b + c`.
    fn mul_add(a: f64, b: f64, c: f64) -> f64;
}

/// Four `f64` (a padded column of a rigid frame) in one vector. Every operation is the same,
/// entry by entry and bit for bit, as the scalar operation of the owning [`Arith`].
pub(crate) trait Col: Copy {
    fn load(v: &[f64; 4]) -> Self;
    /// The frame of padded columns `[r0, r1, r2, p]` written as its twelve entries in that order
    /// (the first three of each column), in whole-vector stores: a caller's copy of the result
    /// in 16-byte pieces then reads each piece from one store (a load that spans two stores
    /// waits for both to reach the cache, which four 3-entry stores caused on every copy).
    fn store_frame(frame: [Self; 4], out: &mut [f64; 12]);
    /// All four entries.
    fn store(self, out: &mut [f64; 4]);
    fn splat(x: f64) -> Self;
    /// The vector of `e`, put together in registers (for entries loaded one by one: a vector
    /// load of entries just stored one by one waits for every store).
    fn from_entries(e: [f64; 4]) -> Self;
    /// `a * b + c`, entry by entry.
    fn mul_add(a: Self, b: Self, c: Self) -> Self;
    fn mul(a: Self, b: Self) -> Self;
    fn add(a: Self, b: Self) -> Self;
    fn sub(a: Self, b: Self) -> Self;
    fn neg(self) -> Self;
    /// Entries `[1, 2, 0, 3]` (for cross products).
    fn yzx(self) -> Self;
    /// Entries `[2, 0, 1, 3]`.
    fn zxy(self) -> Self;
    /// Whether every entry `x` is [`crate::eval::simd::traits::within`] the limits of the same entry of
    /// `(scale, offset, lower, upper)`.
    fn admitted(x: Self, limits: [Self; 4]) -> bool;
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
    /// Whether every lane `x` is [`crate::eval::simd::traits::within`] `(scale, offset, lower, upper)`.
    fn admitted(x: Self, scale: f64, offset: f64, lower: f64, upper: f64) -> bool;
    /// Transposes rows of `qs` (row-major, `q.len()` entries per row) into lanes: entry `j` of
    /// rows `rows[0..8]`, in the layout [`LaneNum::cast`] reads.
    ///
    /// # Panics
    /// If a row is not within `qs`.
    fn transpose(q: &mut [Lanes], qs: &[f64], rows: [usize; LANES]);
}

/// A number the kernels compute with.
pub(crate) trait Num:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    fn splat(x: f64) -> Self;
    fn mul_add<A: Arith>(a: Self, b: Self, c: Self) -> Self;
    fn sin_cos<A: Arith>(x: Self) -> (Self, Self);
    /// `2 / x`, lane by lane (the scale of a quaternion's rotation matrix, `2 / (e · e)`).
    fn two_over(self) -> Self;
}

/// Whether `x` is finite with `lower ≤ scale · x + offset ≤ upper`, the product and the sum
/// rounded separately: the decision of every limit check on a value.
#[inline(always)]
pub(crate) fn within(x: f64, (scale, offset, lower, upper): (f64, f64, f64, f64)) -> bool {
    let value = scale * x + offset;
    x.is_finite() & (value >= lower) & (value <= upper)
}
