//! The batch kernels: one chunk of configurations (a SIMD lane each) through the bodies, in
//! blocks of bodies whose frames stay in registers.

use crate::eval::batch::data::BLOCK;
use crate::eval::batch::data::LaneCheck;
use crate::eval::kernel::frame::Frame;
use crate::eval::kernel::joint::by_shape;
use crate::eval::layout::body::{Body, CheapPlacement, ZTail};
use crate::eval::layout::chain::Chain;
use crate::eval::simd::isa::fma_dispatch;
use crate::eval::simd::lanes::{LANES, Lanes};
use crate::eval::simd::traits::{Arith, LaneNum, Num};
use crate::model::joint::Term;
use crate::model::transform::Transform;

/// One chunk: configurations `8c .. 8c + 8` (the last chunk repeats its last configuration in
/// the unused lanes). False if `check` rejects one (the frames are then meaningless).
///
/// With `stream` (and a lane type of one part), the frames are written around the caches
/// ([`LaneNum::stream`]), and the frames of bodies that [`Body::branches`] are kept in `kept` (at
/// least up to the last such body) to be read again, instead of being read back from `frames`; the
/// caller then calls [`crate::eval::simd::lanes::fence_streams`] before `frames` is used.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn chunk_poses_generic<A: Arith>(
    chain: &Chain,
    check: Option<LaneCheck<'_>>,
    frames: &mut [Frame<Lanes>],
    q: &mut [Lanes],
    qs: &[f64],
    c: usize,
    stream: bool,
    kept: &mut [Frame<Lanes>],
) -> bool {
    let ok = transpose_chunk::<A::Lanes>(check, q, qs, c);
    // The choice made once per chunk, each kernel compiled without the other's tests.
    // (Four-lane types write half lines, which would be flushed to memory half written.)
    if stream && A::Lanes::PARTS == 1 {
        chunk_frames::<A, true>(chain, frames, q, kept);
    } else {
        chunk_frames::<A, false>(chain, frames, q, kept);
    }
    ok
}

/// The frames of [`chunk_poses_generic`], its joint values transposed into `q`; `STREAM` as its
/// `stream`.
#[inline(always)]
pub(crate) fn chunk_frames<A: Arith, const STREAM: bool>(
    chain: &Chain,
    frames: &mut [Frame<Lanes>],
    q: &[Lanes],
    kept: &mut [Frame<Lanes>],
) {
    let dof = chain.nq();
    // Each body's `sin`/`cos` next to its composition, on eight lanes in one register or as two
    // parts of four. With eight lanes, computing them first for all bodies (into `frames`, read
    // back body by body) was slower on Zen 4: UR5 17.8 → 18.2 ns, Panda 23.5 → 25.3, modified DH
    // Panda 20.0 → 20.8 (best of alternated runs, 4 096 configurations).
    for (part, qp) in A::Lanes::cast(q).chunks_exact(dof).enumerate() {
        let mut f = Frame::splat(&Transform::IDENTITY);
        for (k, body) in chain.bodies.iter().enumerate() {
            let sin_cos = crate::eval::kernel::joint::body_sin_cos::<A::Lanes, A>(body, qp);
            f = match body.parent {
                _ if body.follows_previous => crate::eval::kernel::pose_lanes::pose_step::<
                    A::Lanes,
                    A,
                >(Some(&f), body, qp, sin_cos),
                Some(p) => {
                    let parent = Frame::get(if STREAM { &kept[p] } else { &frames[p] }, part);
                    crate::eval::kernel::pose_lanes::pose_step::<A::Lanes, A>(
                        Some(&parent),
                        body,
                        qp,
                        sin_cos,
                    )
                }
                None => {
                    crate::eval::kernel::pose_lanes::root_step::<A::Lanes, A>(body, qp, sin_cos)
                }
            };
            if STREAM {
                f.stream(&mut frames[k]);
                if body.branches {
                    f.put(&mut kept[k], 0);
                }
            } else {
                f.put(&mut frames[k], part);
            }
        }
    }
}

/// How many chunks ahead of the one being transposed the kernels ask for the joint values: a
/// batch whose `qs` is not in the caches (a large one, read once) otherwise waits for memory at
/// every chunk, since its reads, a few hundred bytes between long computations, are too sparse
/// for the hardware to fetch ahead. Far enough to cover a block of [`BLOCK`] chunks transposed
/// in a row, near enough that the values are still in the cache when they are read.
pub(super) const PREFETCH_CHUNKS: usize = BLOCK;

/// Asks the processor to bring the first `len` entries of `x` (at most) into the cache, one
/// request per 64-byte line; no effect on other architectures.
#[inline(always)]
pub(super) fn prefetch(x: &[f64], len: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // One line more, for a start that is not on a line boundary.
        let x = &x[..(len + 7).min(x.len())];
        for line in x.chunks(8) {
            // SAFETY: a prefetch is a hint that never faults; the address is in `x` anyway.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(line.as_ptr().cast()) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (x, len);
}

/// Chunk `c` of `qs` (configurations `8c..8c + 8`; the last chunk repeats its last
/// configuration in the unused lanes) transposed into `q` in the layout [`LaneNum::cast`]
/// reads, and checked with `check`. False if a configuration is rejected.
#[inline(always)]
pub(crate) fn transpose_chunk<N: LaneNum>(
    check: Option<LaneCheck<'_>>,
    q: &mut [Lanes],
    qs: &[f64],
    c: usize,
) -> bool {
    let dof = q.len();
    let n = qs.len() / dof;
    let rows = std::array::from_fn(|l| (c * LANES + l).min(n - 1));
    // A few entries of long rows (a robot's link in a scene) one by one; otherwise whole rows,
    // in vectors (what is not read is cheaper moved than picked out).
    match check.and_then(|c| c.entries) {
        Some(entries) if 4 * entries.len() <= dof => transpose_entries::<N>(q, qs, rows, entries),
        _ => {
            N::transpose(q, qs, rows);
            prefetch(
                qs.get((c + PREFETCH_CHUNKS) * LANES * dof..)
                    .unwrap_or_default(),
                LANES * dof,
            );
        }
    }
    let mut ok = true;
    for qp in N::cast(q).chunks_exact(dof) {
        ok &= LaneCheck::admits(check, qp);
    }
    ok
}

/// [`LaneNum::transpose`] of `entries` only (the others are left as they are): what a one-link
/// kernel reads of a scene's configurations, entry by entry into the layout [`LaneNum::cast`]
/// reads (part `p`'s entry `j` at value `p · dof + j`).
#[inline(always)]
fn transpose_entries<N: LaneNum>(
    q: &mut [Lanes],
    qs: &[f64],
    rows: [usize; LANES],
    entries: &[usize],
) {
    let dof = q.len();
    let width = LANES / N::PARTS;
    let flat = Lanes::flat_mut(q);
    for part in 0..N::PARTS {
        for &j in entries {
            let at = (part * dof + j) * width;
            for (l, x) in flat[at..at + width].iter_mut().enumerate() {
                *x = qs[rows[part * width + l] * dof + j];
            }
        }
    }
}

/// `(sin θ, cos θ)` of `body` in all eight lanes of a chunk (`q` its joint values as
/// [`transpose_chunk`] wrote them, `dof` per part), in one go: the values of
/// [`crate::eval::kernel::joint::body_sin_cos`], lane for lane.
#[inline(always)]
pub(super) fn chunk_sin_cos<A: Arith>(body: &Body, q: &[Lanes], dof: usize) -> (Lanes, Lanes) {
    if let Term::Const(_) = body.motion.theta {
        return (Lanes::splat(0.0), Lanes::splat(1.0));
    }
    let mut theta = Lanes::splat(0.0);
    for (part, qp) in A::Lanes::cast(q).chunks_exact(dof).enumerate() {
        crate::eval::kernel::joint::term_value::<A::Lanes, A>(&body.motion.theta, qp)
            .put(&mut theta, part);
    }
    Lanes::sin_cos::<A>(theta)
}

fma_dispatch!(#[allow(clippy::too_many_arguments)] pub(super) fn chunk_poses(chain: &Chain, check: Option<LaneCheck<'_>>, frames: &mut [Frame<Lanes>], q: &mut [Lanes], qs: &[f64], c: usize, stream: bool, kept: &mut [Frame<Lanes>]) -> bool => chunk_poses_generic);

/// The frame of the last body of `path` (base first, each body the parent of the next) for
/// chunks `c0 .. c0 + out.len()` of `qs` (at most [`BLOCK`]), built in `out`. False if `check`
/// rejects a configuration (the frames are then meaningless).
#[inline(always)]
pub(super) fn block_path_generic<A: Arith>(
    chain: &Chain,
    check: Option<LaneCheck<'_>>,
    path: &[usize],
    q: &mut [Lanes],
    qs: &[f64],
    c0: usize,
    out: &mut [Frame<Lanes>],
) -> bool {
    let dof = chain.nq();
    let mut ok = true;
    for (i, qc) in q.chunks_exact_mut(dof).take(out.len()).enumerate() {
        ok &= transpose_chunk::<A::Lanes>(check, qc, qs, c0 + i);
    }
    let q = &q[..out.len() * dof];
    if A::Lanes::PARTS == 1 {
        // Eight lanes in one register (32 of them): a chunk's frame stays in registers along the
        // whole path, each body's `sin`/`cos` next to its step, and only the last frame is
        // stored. Faster on Zen 4 than the body-by-body order below, which suits AVX2's 16
        // registers: UR5 URDF tool link 17.4 → 15.4 ns, UR5 DH 17.6 → 15.1, Panda URDF hand
        // 24.1 → 19.8, modified DH Panda 21.1 → 17.0 (best of alternated runs, 4 096
        // configurations, one thread).
        for (qc, f_out) in q.chunks_exact(dof).zip(out.iter_mut()) {
            let qp = A::Lanes::cast(qc);
            let mut f = Frame::<A::Lanes>::splat(&Transform::IDENTITY);
            for (i, &k) in path.iter().enumerate() {
                let body = &chain.bodies[k];
                let sin_cos = crate::eval::kernel::joint::body_sin_cos::<A::Lanes, A>(body, qp);
                // The first body hangs from the world, each next one from the one before it.
                f = if i == 0 {
                    crate::eval::kernel::pose_lanes::root_step::<A::Lanes, A>(body, qp, sin_cos)
                } else {
                    crate::eval::kernel::pose_lanes::pose_step::<A::Lanes, A>(
                        Some(&f),
                        body,
                        qp,
                        sin_cos,
                    )
                };
            }
            f.put(f_out, 0);
        }
        return ok;
    }
    for &k in path {
        block_body::<A>(&chain.bodies[k], q, dof, out);
    }
    ok
}

fma_dispatch!(pub(super) fn block_path(chain: &Chain, check: Option<LaneCheck<'_>>, path: &[usize], q: &mut [Lanes], qs: &[f64], c0: usize, out: &mut [Frame<Lanes>]) -> bool => block_path_generic);

/// `f ← f · body` for the frames `out` of a block's chunks (`q` their joint values, `dof` per
/// chunk; a body that hangs from the world starts from the identity): the operations of
/// [`crate::eval::kernel::pose_lanes::pose_step`], so the frames are those of a single evaluation, bit for bit.
#[inline(always)]
pub(super) fn block_body<A: Arith>(body: &Body, q: &[Lanes], dof: usize, out: &mut [Frame<Lanes>]) {
    let (Some(pre), Some(tail), false) = (&body.pre_steps, &body.z_tail, body.floating) else {
        for (qc, f_out) in q.chunks_exact(dof).zip(out.iter_mut()) {
            for (part, qp) in A::Lanes::cast(qc).chunks_exact(dof).enumerate() {
                let sin_cos = crate::eval::kernel::joint::body_sin_cos::<A::Lanes, A>(body, qp);
                let f = match body.parent {
                    Some(_) => {
                        let f = Frame::get(f_out, part);
                        crate::eval::kernel::pose_lanes::pose_step::<A::Lanes, A>(
                            Some(&f),
                            body,
                            qp,
                            sin_cos,
                        )
                    }
                    None => {
                        crate::eval::kernel::pose_lanes::root_step::<A::Lanes, A>(body, qp, sin_cos)
                    }
                };
                f.put(f_out, part);
            }
        }
        return;
    };
    if body.parent.is_none() {
        out.fill(Frame::splat(&Transform::IDENTITY));
    }
    by_shape!(pre.shape, block_place::<A>(out, pre));
    by_shape!(tail.motion, block_motion::<A>(out, body, q, dof));
    by_shape!(tail.post.shape, block_place::<A>(out, &tail.post));
}

/// `f ← f · p` for every frame of a block, `p` of shape `SHAPE`.
#[cfg_attr(not(debug_assertions), inline(always))] // (see `by_shape!`)
pub(super) fn block_place<A: Arith, const SHAPE: u8>(out: &mut [Frame<Lanes>], p: &CheapPlacement) {
    if SHAPE == 0 {
        return;
    }
    for f_out in out.iter_mut() {
        for part in 0..A::Lanes::PARTS {
            let mut f = Frame::<A::Lanes>::get(f_out, part);
            crate::eval::kernel::pose_lanes::cheap_steps::<A::Lanes, A, SHAPE>(&mut f, p);
            match (SHAPE & 3 != 0, CheapPlacement::turn(SHAPE) != 0) {
                (true, true) => f.put_columns::<0b1110>(f_out, part),
                (true, false) => f.put_columns::<0b1000>(f_out, part),
                _ => f.put_columns::<0b0110>(f_out, part),
            }
        }
    }
}

/// `f ← f · M(θ, d)` about z for every frame of a block, the kinds of θ and d in `MOTION`.
#[cfg_attr(not(debug_assertions), inline(always))] // (see `by_shape!`)
pub(super) fn block_motion<A: Arith, const MOTION: u8>(
    out: &mut [Frame<Lanes>],
    body: &Body,
    q: &[Lanes],
    dof: usize,
) {
    let turns = ZTail::theta_kind(MOTION) != ZTail::ZERO;
    let slides = ZTail::d_kind(MOTION) != ZTail::ZERO;
    if !turns && !slides {
        return;
    }
    for (qc, f_out) in q.chunks_exact(dof).zip(out.iter_mut()) {
        let (sin, cos) = if ZTail::theta_kind(MOTION) == ZTail::VARIABLE {
            chunk_sin_cos::<A>(body, qc, dof)
        } else {
            (Lanes::splat(0.0), Lanes::splat(1.0))
        };
        for (part, qp) in A::Lanes::cast(qc).chunks_exact(dof).enumerate() {
            let sin_cos = (A::Lanes::get(&sin, part), A::Lanes::get(&cos, part));
            let mut f = Frame::<A::Lanes>::get(f_out, part);
            crate::eval::kernel::pose_lanes::z_motion::<A::Lanes, A, MOTION>(
                &mut f, body, qp, sin_cos,
            );
            match (slides, turns) {
                (true, true) => f.put_columns::<0b1011>(f_out, part),
                (true, false) => f.put_columns::<0b1000>(f_out, part),
                _ => f.put_columns::<0b0011>(f_out, part),
            }
        }
    }
}
