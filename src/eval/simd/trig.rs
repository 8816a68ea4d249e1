//! `sin` and `cos` of one argument together, within 1 ulp, branch-free so that a loop over
//! lanes vectorises.
//!
//! The argument is reduced by `k = round(x · 2/π)` and `r = x − k π/2`, the remainder kept as a
//! double-double `(r, tail)`. With a fused multiply–add, π/2 is the sum of three doubles and
//! `x − k·π/2_hi` is one exact operation, so `r` is ready four operations after `x`; without, π/2
//! is split into 33-bit parts so that every product `k · part` is exact for `|k| < 2²⁰`. `sin r`
//! and `cos r` come from minimax polynomials on `[−π/4, π/4]` (the classic fdlibm coefficients,
//! accurate to 2⁻⁵⁸) with a first-order correction for `tail`; the quadrant `k mod 4` swaps and
//! negates them. Arguments with `|x| ≥ 2¹⁹ π/2` (about 8.2·10⁵ rad) are left to the standard
//! library, whose reduction covers the whole `f64` range.

use crate::eval::simd::traits::Arith;
use std::f64::consts::FRAC_2_PI;

/// π/2 in three parts of 33 significant bits, and the remainder.
const PIO2_1: f64 = f64::from_bits(0x3FF9_21FB_5440_0000);

const PIO2_2: f64 = f64::from_bits(0x3DD0_B461_1A60_0000);

const PIO2_3: f64 = f64::from_bits(0x3BA3_198A_2E00_0000);

const PIO2_3_TAIL: f64 = f64::from_bits(0x397B_839A_2520_49C1);

/// π/2 as the sum of three doubles (with a fused multiply–add the products need no spare bits).
const PIO2_HI: f64 = f64::from_bits(0x3FF9_21FB_5444_2D18);

const PIO2_MID: f64 = f64::from_bits(0x3C91_A626_3314_5C07);

const PIO2_LO: f64 = f64::from_bits(0xB91F_1976_B7ED_8FBC);

/// Largest |x| reduced here; beyond it `k` could exceed 2²⁰ and the products would round.
pub(crate) const REDUCTION_LIMIT: f64 = 524_288.0 * std::f64::consts::FRAC_PI_2;

/// 1.5 · 2⁵²: adding it rounds a double of magnitude < 2⁵¹ to an integer in the low mantissa bits.
const ROUNDER: f64 = 6_755_399_441_055_744.0;

// Minimax coefficients of sin r = r + r³ (S1 + r² (S2 + ...)) and
// cos r = 1 − r²/2 + r⁴ (C1 + r² (C2 + ...)) on |r| ≤ π/4.
const S1: f64 = -1.666_666_666_666_663_2e-1;

const S2: f64 = 8.333_333_333_322_49e-3;

const S3: f64 = -1.984_126_982_985_795e-4;

const S4: f64 = 2.755_731_370_707_006_8e-6;

const S5: f64 = -2.505_076_025_340_686_3e-8;

const S6: f64 = 1.589_690_995_211_55e-10;

const C1: f64 = 4.166_666_666_666_66e-2;

const C2: f64 = -1.388_888_888_887_411e-3;

const C3: f64 = 2.480_158_728_947_673e-5;

const C4: f64 = -2.755_731_435_139_066_3e-7;

const C5: f64 = 2.087_572_321_298_175e-9;

const C6: f64 = -1.135_964_755_778_819_5e-11;

/// `(sin x, cos x)`, reduced here for `|x| < REDUCTION_LIMIT` and by the standard library beyond.
#[inline(always)]
pub(crate) fn sin_cos<A: Arith>(x: f64) -> (f64, f64) {
    if x.abs() < REDUCTION_LIMIT {
        sin_cos_reduced::<A>(x)
    } else {
        x.sin_cos()
    }
}

/// `(sin x, cos x)` for `|x| < REDUCTION_LIMIT` (garbage beyond; the caller checks). No branches.
#[inline(always)]
pub(crate) fn sin_cos_reduced<A: Arith>(x: f64) -> (f64, f64) {
    let (r, tail, quadrant) = reduce::<A>(x);

    let z = r * r;
    let v = z * r;
    let z2 = z * z;
    let hz = 0.5 * z;
    // sin(r + tail) ≈ sin r + tail cos r ≈ r + v (S1 + z P(z)) + tail (1 − z/2), P by Estrin's
    // scheme (shorter dependency chain than Horner's; its rounding is scaled by r⁵).
    let ps = A::mul_add(
        z2,
        A::mul_add(z2, S6, A::mul_add(z, S5, S4)),
        A::mul_add(z, S3, S2),
    );
    let sin_r = r + A::mul_add(v, A::mul_add(z, ps, S1), A::mul_add(-hz, tail, tail));
    // cos(r + tail) ≈ cos r − tail sin r ≈ (1 − z/2) + z² Q(z) − r tail, with the rounding
    // error of 1 − z/2 kept.
    let pc = A::mul_add(
        z2,
        A::mul_add(z2, A::mul_add(z, C6, C5), A::mul_add(z, C4, C3)),
        A::mul_add(z, C2, C1),
    );
    let w = 1.0 - hz;
    let cos_r = w + A::mul_add(z2, pc, ((1.0 - w) - hz) - r * tail);

    // Quadrant: k mod 4 = 1 → (cos, −sin), 2 → (−sin, −cos), 3 → (−cos, sin).
    let swap = quadrant & 1 != 0;
    let (s, c) = if swap { (cos_r, sin_r) } else { (sin_r, cos_r) };
    let sin_sign = (quadrant & 2) << 62;
    let cos_sign = (quadrant.wrapping_add(1) & 2) << 62;
    (
        f64::from_bits(s.to_bits() ^ sin_sign),
        f64::from_bits(c.to_bits() ^ cos_sign),
    )
}

/// `(r, tail, k)` with `r + tail = x − k π/2`, `|tail|` far below `|r| ≤ π/4`, and
/// `k = round(x · 2/π)` in the low bits of the third value (`k mod 4` is the quadrant), for
/// `|x| < REDUCTION_LIMIT`. Callers that need only `r` (rounded once) let the compiler drop the
/// operations of the tail.
#[inline(always)]
pub(crate) fn reduce<A: Arith>(x: f64) -> (f64, f64, u64) {
    // k = round(x · 2/π), as a double and in the low bits of `kb`.
    let kb = A::mul_add(x, FRAC_2_PI, ROUNDER);
    let k = kb - ROUNDER;
    let (r, tail) = if A::FUSED {
        reduce_fused::<A>(x, k)
    } else {
        reduce_split(x, k)
    };
    (r, tail, kb.to_bits())
}

/// `x − k π/2` as `(r, tail)` with one rounding per fused multiply–add: `x − k·PIO2_HI` is
/// exact (for `k ≠ 0`, `|x| ≥ π/4`, so `x` and the product are multiples of 2⁻⁵³ and their
/// difference is below 1), and the rest is a two-sum plus the exact error of `k · PIO2_MID`.
/// The remainder `r` is ready after four operations; the tail is needed only at the end.
#[inline(always)]
fn reduce_fused<A: Arith>(x: f64, k: f64) -> (f64, f64) {
    let a = A::mul_add(-k, PIO2_HI, x);
    let t = k * PIO2_MID;
    let t_err = A::mul_add(k, PIO2_MID, -t);
    let r = a - t;
    let tt = a - r;
    let err = (a - (r + tt)) + (tt - t);
    (r, err - A::mul_add(k, PIO2_LO, t_err))
}

/// `x − k π/2` as `(r, tail)` without a fused multiply–add: π/2 in 33-bit parts so that every
/// product is exact, and `x − k·PIO2_1` is exact by Sterbenz' lemma (for `k ≠ 0` the two are
/// within a factor of two; for `k = 0` it is `x`).
#[inline(always)]
fn reduce_split(x: f64, k: f64) -> (f64, f64) {
    let a = x - k * PIO2_1;
    let b = k * PIO2_2;
    let r_hi = a - b;
    // Two-sum error of a − b, then the third part and the tail.
    let bb = a - r_hi;
    let err = (a - (r_hi + bb)) + (bb - b);
    let r_lo = err - (k * PIO2_3 + k * PIO2_3_TAIL);
    let r = r_hi + r_lo;
    (r, (r_hi - r) + r_lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::simd::portable::Separate;
    use crate::measure::worse;

    /// Distance in ulps of the result (relative to max(|expected|, 2⁻¹⁰²²)), and absolute.
    fn ulps(got: f64, want: f64) -> f64 {
        let ulp = (want.abs().max(f64::MIN_POSITIVE)).next_up() - want.abs().max(f64::MIN_POSITIVE);
        (got - want).abs() / ulp
    }

    /// How far [`sin_cos`] is from the standard library over `xs`: the worst distance in ulps of
    /// the result, the worst absolute distance, and the fraction of results that differ at all.
    /// Below [`REDUCTION_LIMIT`] the result must be [`sin_cos_reduced`]'s, bit for bit.
    fn distance<A: Arith>(xs: impl Iterator<Item = f64>) -> (f64, f64, f64) {
        let mut worst: f64 = 0.0;
        let mut worst_abs: f64 = 0.0;
        let (mut differing, mut results) = (0_u32, 0_u32);
        for x in xs {
            let (s, c) = sin_cos::<A>(x);
            if x.abs() < REDUCTION_LIMIT {
                let (sr, cr) = sin_cos_reduced::<A>(x);
                assert_eq!(
                    (s.to_bits(), c.to_bits()),
                    (sr.to_bits(), cr.to_bits()),
                    "{x:e}"
                );
            }
            let (sw, cw) = x.sin_cos();
            worst = worse(worse(worst, ulps(s, sw)), ulps(c, cw));
            worst_abs = worse(worse(worst_abs, (s - sw).abs()), (c - cw).abs());
            differing += u32::from(s != sw) + u32::from(c != cw);
            results += 2;
        }
        (worst, worst_abs, f64::from(differing) / f64::from(results))
    }

    fn random_arguments() -> impl Iterator<Item = f64> {
        let mut state = 0x1234_5678_9abc_def0_u64;
        [1e-8, 1e-3, 1.0, 3.0, 10.0, 1e2, 1e3, 1e4, 1e5, 8e5]
            .into_iter()
            .flat_map(move |scale| {
                (0..200_000).map(move |_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    scale * ((state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0)
                })
            })
    }

    /// The doubles nearest to multiples of π/2 and their neighbours, where one of the results is
    /// small and the reduction's error counts most.
    fn near_multiples_of_half_pi() -> impl Iterator<Item = f64> {
        (1..=524_287_i64)
            .step_by(37)
            .chain([1, 2, 3, 4, 5, 6, 7, 8, 100, 1000, 524_287])
            .flat_map(|k| {
                let x = k as f64 * std::f64::consts::FRAC_PI_2;
                let mut v = vec![];
                let mut y = x;
                for _ in 0..4 {
                    v.push(y);
                    v.push(-y);
                    y = y.next_up();
                }
                y = x;
                for _ in 0..4 {
                    y = y.next_down();
                    v.push(y);
                }
                v
            })
    }

    fn check_against_the_standard_library<A: Arith>() {
        // The standard library (glibc) is correctly rounded in practice, so a 1-ulp distance from
        // it bounds our error by 1.5 ulp of the exact value; the measured worst case is below 1.
        // Most results are also the correctly rounded value: 2.5–2.6% of the random ones are not,
        // and 0.002% of those near multiples of π/2. Each correction term of the reduction or of
        // the polynomials, left out or with its sign flipped, raises the first to 4–12% while the
        // worst case stays within 1 ulp, so the fraction is what shows those terms at work.
        for (name, (worst, worst_abs, differing), most_differing) in [
            ("random", distance::<A>(random_arguments()), 0.03),
            (
                "near k pi/2",
                distance::<A>(near_multiples_of_half_pi()),
                1e-4,
            ),
        ] {
            assert!(worst <= 1.0, "{name}: worst {worst} ulp");
            assert!(
                worst_abs <= f64::EPSILON / 2.0,
                "{name}: worst absolute {worst_abs:e}"
            );
            assert!(
                differing <= most_differing,
                "{name}: {:.2}% not correctly rounded",
                differing * 100.0
            );
        }
    }

    #[test]
    fn agrees_with_the_standard_library_within_one_ulp() {
        check_against_the_standard_library::<Separate>();
        // Outside a function compiled for FMA, `Fused` calls the library's fma (slow, exact).
        check_against_the_standard_library::<crate::eval::simd::fused::Fused>();
    }

    #[test]
    fn exact_cases_and_the_fallback() {
        assert_eq!(sin_cos::<Separate>(0.0), (0.0, 1.0));
        // sin(−0) comes out as +0: equal as numbers, and not worth an operation in the kernel.
        assert_eq!(sin_cos::<Separate>(-0.0), (0.0, 1.0));
        for x in [1e-300, -5e-324, 1e-20] {
            assert_eq!(sin_cos::<Separate>(x), (x, 1.0));
            assert_eq!(sin_cos::<crate::eval::simd::fused::Fused>(x), (x, 1.0));
        }
        for x in [REDUCTION_LIMIT, -1e7, 1e300, f64::MAX] {
            assert_eq!(sin_cos::<Separate>(x), x.sin_cos());
        }
        assert!(sin_cos::<Separate>(f64::NAN).0.is_nan());
    }
}
