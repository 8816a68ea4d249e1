//! What a body's joint reads from `q`: the value of θ or d (mimic scale and offset applied), its
//! sine and cosine, one body at a time or gathered for all turning bodies at once, and
//! [`by_shape`], which selects a kernel specialised to a body's shape code.

// Index loops over lanes and rows are the shape the vectoriser expects here.
#![allow(clippy::needless_range_loop)]

use crate::eval::layout::body::Body;
use crate::eval::simd::lanes::LANES;
use crate::eval::simd::portable::lanes_sin_cos;
use crate::eval::simd::traits::{Arith, Num};
use crate::model::joint::Term;

/// Value of a θ or d term at `q`.
#[inline(always)]
pub(crate) fn term_value<N: Num, A: Arith>(t: &Term, q: &[N]) -> N {
    match *t {
        Term::Const(v) => N::splat(v),
        Term::Var {
            index,
            scale,
            offset,
        } => N::mul_add::<A>(N::splat(scale), q[index], N::splat(offset)),
    }
}

/// `(sin θ, cos θ)` of a body at `q`.
#[inline(always)]
pub(crate) fn body_sin_cos<N: Num, A: Arith>(body: &Body, q: &[N]) -> (N, N) {
    match body.motion.theta {
        Term::Const(_) => (N::splat(0.0), N::splat(1.0)),
        theta => N::sin_cos::<A>(term_value::<N, A>(&theta, q)),
    }
}

/// Calls `$f::<…, SHAPE>(args)` for a four-bit shape code `$shape` resolved at load time (a
/// [`CheapPlacement::shape`], a [`ZTail::motion`]): one jump through a table instead of one
/// test per step, each arm the code for its shape.
///
/// The functions it calls, and the pose steps that call it, are always inlined in optimised
/// builds only (`debug_assertions` off, as in `--release`): without optimisation nothing shares
/// stack slots, and sixteen inlined arms at each of a kernel's steps gave the batch kernel a
/// frame of 2.1 MB, more than a spawned thread's 2 MiB stack (a crate's own tests, run in debug,
/// overflowed it; the largest frame is now below 0.3 MB). Called instead, they run the same
/// arithmetic, without the caller's target features.
macro_rules! by_shape {
    ($shape:expr, $f:ident::<$($g:ty),*>($($arg:expr),*)) => {
        match $shape & 15 {
            0 => $f::<$($g,)* 0>($($arg),*),
            1 => $f::<$($g,)* 1>($($arg),*),
            2 => $f::<$($g,)* 2>($($arg),*),
            3 => $f::<$($g,)* 3>($($arg),*),
            4 => $f::<$($g,)* 4>($($arg),*),
            5 => $f::<$($g,)* 5>($($arg),*),
            6 => $f::<$($g,)* 6>($($arg),*),
            7 => $f::<$($g,)* 7>($($arg),*),
            8 => $f::<$($g,)* 8>($($arg),*),
            9 => $f::<$($g,)* 9>($($arg),*),
            10 => $f::<$($g,)* 10>($($arg),*),
            11 => $f::<$($g,)* 11>($($arg),*),
            12 => $f::<$($g,)* 12>($($arg),*),
            13 => $f::<$($g,)* 13>($($arg),*),
            14 => $f::<$($g,)* 14>($($arg),*),
            15 => $f::<$($g,)* 15>($($arg),*),
            // `& 15` leaves no other value; the compiler drops this arm.
            _ => unreachable!(),
        }
    };
}

pub(crate) use by_shape;

/// `sin θ` and `cos θ` of every body at `q`, [`LANES`] joints at a time (vectorised: the
/// single-configuration kernels take the trigonometry off their dependency chain this way).
/// `sin` and `cos` have room for a whole number of chunks. θ is computed straight from `q`
/// (a value assembled lane by lane in memory and read back as a vector would stall the load).
#[inline(always)]
pub(crate) fn all_sin_cos<A: Arith>(
    gather: &[crate::eval::layout::body::ThetaGather],
    q: &[f64],
    sin: &mut [f64],
    cos: &mut [f64],
) {
    if A::WIDE
        && let [g] = gather
        && crate::eval::simd::isa::narrow_trig()
    {
        // Two 256-bit halves: the same operations lane by lane, so the same bits (see
        // `narrow_trig` for when and why).
        let (s_out, c_out) = (&mut sin[..LANES], &mut cos[..LANES]);
        for ((s, c), first) in s_out
            .chunks_exact_mut(4)
            .zip(c_out.chunks_exact_mut(4))
            .zip([0, 4])
        {
            gathered_sin_cos::<A, 4>(g, first, q, s, c);
        }
        return;
    }
    for ((g, s_out), c_out) in gather
        .iter()
        .zip(sin.chunks_exact_mut(LANES))
        .zip(cos.chunks_exact_mut(LANES))
    {
        gathered_sin_cos::<A, LANES>(g, 0, q, s_out, c_out);
    }
}

/// `sin θ` and `cos θ` of lanes `first..first + W` of the chunk `g` into `s_out` and `c_out`
/// (`W` entries each), in one vector of `W` lanes.
#[inline(always)]
fn gathered_sin_cos<A: Arith, const W: usize>(
    g: &crate::eval::layout::body::ThetaGather,
    first: usize,
    q: &[f64],
    s_out: &mut [f64],
    c_out: &mut [f64],
) {
    // The gather closure does no arithmetic (a closure is not always inlined into the
    // target-feature function, and `mul_add` outside it would be a library call).
    let gathered: [f64; W] = std::array::from_fn(|i| q[g.index[first + i]]);
    let mut theta = [0.0; W];
    for i in 0..W {
        theta[i] = A::mul_add(g.scale[first + i], gathered[i], g.offset[first + i]);
    }
    let (s, c) = lanes_sin_cos::<A, W>(theta);
    s_out.copy_from_slice(&s);
    c_out.copy_from_slice(&c);
}
