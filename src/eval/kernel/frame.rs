//! A rigid frame of any [`Num`] ([`Frame`]: rotation columns and origin) and the operations on
//! it the kernels share: rotations about an axis (Rodrigues, eq. 2.43), constant placements, and
//! frames of [`LaneNum`] values read from and written to stored [`Lanes`].

// Index loops over lanes and rows are the shape the vectoriser expects here.
#![allow(clippy::needless_range_loop)]

use crate::eval::layout::body::Placement;
use crate::eval::simd::lanes::Lanes;
use crate::eval::simd::traits::{Arith, LaneNum, Num};
use crate::model::joint::Axis;

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

/// `r u + p` (the columns of `r` are its vectors).
#[inline(always)]
pub(crate) fn mat_vec_add<N: Num, A: Arith>(r: &[[N; 3]; 3], u: &V3<N>, p: V3<N>) -> V3<N> {
    let mut out = p;
    for k in 0..3 {
        out[k] = N::mul_add::<A>(
            r[0][k],
            u[0],
            N::mul_add::<A>(r[1][k], u[1], N::mul_add::<A>(r[2][k], u[2], p[k])),
        );
    }
    out
}

/// A rigid frame: rotation columns and origin.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub(crate) struct Frame<N> {
    pub(crate) r: [[N; 3]; 3],
    pub(crate) p: [N; 3],
}

impl<N: Num> Frame<N> {
    #[inline(always)]
    pub(crate) fn splat(f: &crate::model::transform::Transform) -> Self {
        Frame {
            r: [splat3(f.r[0]), splat3(f.r[1]), splat3(f.r[2])],
            p: splat3(f.p),
        }
    }
}

/// `[N::splat(v[0]), N::splat(v[1]), N::splat(v[2])]`, written out: as `v.map(N::splat)`, the
/// closure is a function of its own, compiled without the kernel's target features, and the
/// `f32` register types' `splat` did not inline into it (one call per body, through memory).
#[inline(always)]
pub(crate) fn splat3<N: Num>(v: [f64; 3]) -> V3<N> {
    [N::splat(v[0]), N::splat(v[1]), N::splat(v[2])]
}

impl From<Frame<f64>> for crate::model::transform::Transform {
    #[inline(always)]
    fn from(f: Frame<f64>) -> Self {
        crate::model::transform::Transform { r: f.r, p: f.p }
    }
}

pub(crate) type V3<N> = [N; 3];

/// `s x + y`.
#[inline(always)]
pub(crate) fn axpy<N: Num, A: Arith>(s: N, x: V3<N>, y: V3<N>) -> V3<N> {
    [
        N::mul_add::<A>(s, x[0], y[0]),
        N::mul_add::<A>(s, x[1], y[1]),
        N::mul_add::<A>(s, x[2], y[2]),
    ]
}

/// `R u + p` with a constant `u`.
#[inline(always)]
pub(crate) fn apply_const_add<N: Num, A: Arith>(r: &[[N; 3]; 3], u: [f64; 3], p: V3<N>) -> V3<N> {
    mat_vec_add::<N, A>(r, &splat3(u), p)
}

/// A rotation about +e_k mixes the two other columns (i, j) in cyclic order:
/// `col_i' = c col_i + s col_j`, `col_j' = c col_j − s col_i` (about −e_k, `s` changes sign).
#[inline(always)]
pub(crate) fn plane<N: Num, A: Arith>(r: &mut [[N; 3]; 3], i: usize, j: usize, s: N, c: N) {
    let (ci, cj) = (r[i], r[j]);
    for k in 0..3 {
        r[i][k] = N::mul_add::<A>(c, ci[k], s * cj[k]);
        r[j][k] = N::mul_add::<A>(c, cj[k], -(s * ci[k]));
    }
}

/// Columns of Rodrigues' rotation matrix (eq. 2.112) about the unit axis `v`, given
/// `s = sin θ`, `c = cos θ`, as `A = c I + s [v]x + (1 − c) v vᵀ`.
#[inline(always)]
pub(crate) fn rodrigues<N: Num, A: Arith>(v: [f64; 3], s: N, c: N) -> [[N; 3]; 3] {
    let w = N::splat(1.0) - c;
    let [x, y, z] = splat3::<N>(v);
    let (wx, wy, wz) = (w * x, w * y, w * z);
    let (sx, sy, sz) = (s * x, s * y, s * z);
    [
        [
            N::mul_add::<A>(wx, x, c),
            N::mul_add::<A>(wx, y, sz),
            N::mul_add::<A>(wx, z, -sy),
        ],
        [
            N::mul_add::<A>(wy, x, -sz),
            N::mul_add::<A>(wy, y, c),
            N::mul_add::<A>(wy, z, sx),
        ],
        [
            N::mul_add::<A>(wz, x, sy),
            N::mul_add::<A>(wz, y, -sx),
            N::mul_add::<A>(wz, z, c),
        ],
    ]
}

/// Replaces the columns `r` by `r · A(axis, θ)` given `s = sin θ`, `c = cos θ` (eq. 2.112).
#[inline(always)]
pub(crate) fn rotate_columns<N: Num, A: Arith>(r: &mut [[N; 3]; 3], axis: &Axis, s: N, c: N) {
    match *axis {
        Axis::X => plane::<N, A>(r, 1, 2, s, c),
        Axis::Y => plane::<N, A>(r, 2, 0, s, c),
        Axis::Z => plane::<N, A>(r, 0, 1, s, c),
        Axis::NegX => plane::<N, A>(r, 1, 2, -s, c),
        Axis::NegY => plane::<N, A>(r, 2, 0, -s, c),
        Axis::NegZ => plane::<N, A>(r, 0, 1, -s, c),
        Axis::General(v) => {
            let a = rodrigues::<N, A>(v, s, c);
            let old = *r;
            for (j, col) in r.iter_mut().enumerate() {
                for (k, out) in col.iter_mut().enumerate() {
                    *out = N::mul_add::<A>(
                        old[0][k],
                        a[j][0],
                        N::mul_add::<A>(old[1][k], a[j][1], old[2][k] * a[j][2]),
                    );
                }
            }
        }
    }
}

/// `f ← f · placement`.
#[inline(always)]
pub(crate) fn place<N: Num, A: Arith>(f: &mut Frame<N>, placement: &Placement) {
    match placement {
        Placement::Identity => {}
        Placement::Translation(t) => f.p = apply_const_add::<N, A>(&f.r, *t, f.p),
        Placement::ScrewX { a, c, s } => {
            f.p = axpy::<N, A>(N::splat(*a), f.r[0], f.p);
            rotate_columns::<N, A>(&mut f.r, &Axis::X, N::splat(*s), N::splat(*c));
        }
        Placement::OffsetRot { t, axis, c, s } => {
            f.p = apply_const_add::<N, A>(&f.r, *t, f.p);
            let (s, c) = (N::splat(*s), N::splat(*c));
            // Constant column indices in each arm: a frame indexed by a value known only at run
            // time would be kept in memory rather than in registers.
            match axis {
                0 => plane::<N, A>(&mut f.r, 1, 2, s, c),
                1 => plane::<N, A>(&mut f.r, 2, 0, s, c),
                _ => plane::<N, A>(&mut f.r, 0, 1, s, c),
            }
        }
        Placement::General(t) => {
            let zero = [N::splat(0.0); 3];
            let r = f.r;
            *f = Frame {
                r: [
                    apply_const_add::<N, A>(&r, t.r[0], zero),
                    apply_const_add::<N, A>(&r, t.r[1], zero),
                    apply_const_add::<N, A>(&r, t.r[2], zero),
                ],
                p: apply_const_add::<N, A>(&r, t.p, f.p),
            };
        }
    }
}

/// `R u` with constant `u`, as [`Transform::apply`] computes it (no fused multiply–adds).
#[inline(always)]
pub(crate) fn rotate<N: Num>(r: &[[N; 3]; 3], u: [f64; 3]) -> [N; 3] {
    let u = splat3::<N>(u);
    std::array::from_fn(|k| r[0][k] * u[0] + r[1][k] * u[1] + r[2][k] * u[2])
}
