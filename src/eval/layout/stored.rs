//! Frames and rates as the evaluation buffers store them: four padded columns per frame
//! ([`Stored`]), and the rates of every body ([`Rates`]).

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
