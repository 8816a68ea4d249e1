//! The lane storage of the batch kernels: [`Lanes`], eight `f64` (one per configuration) as
//! stored between kernels, its lane-wise arithmetic, and the streaming-store fence.

// Index loops over lanes and rows are the shape the vectoriser expects here.
#![allow(clippy::needless_range_loop)]

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
pub(crate) use each_lane;

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

/// Panics unless every row `rows[l]` of `dof` entries lies within `qs` (what the vector loads of
/// a transposition rely on).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn assert_rows_within(qs: &[f64], rows: &[usize; LANES], dof: usize) {
    // The last row decides: one check rather than one per row.
    let last = rows.iter().fold(0, |m, &r| m.max(r));
    let in_bounds = last
        .checked_mul(dof)
        .and_then(|o| o.checked_add(dof))
        .is_some_and(|e| e <= qs.len());
    assert!(in_bounds, "rows {rows:?} of {} entries", qs.len());
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
