use super::*;
use crate::eval::simd::portable::Separate;
use crate::measure::worse;

/// Sixteen angles uniform in `[−scale, scale)`, from the xorshift generator `state`.
fn angles(state: &mut u64, scale: f64) -> [f64; WIDTH] {
    std::array::from_fn(|_| {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        scale * ((*state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0)
    })
}

/// The single-precision `sin`/`cos` against the standard library's `f64` ones, over angles
/// from 10⁻⁸ to 10⁵ rad: within 2⁻²³ absolutely (one `f32` ulp near 1; measured 9.2·10⁻⁸,
/// at values near 0.74, where that is 1.5 ulp), as accurate at 10⁵ rad as near 0 since the
/// reduction is done in `f64`.
#[test]
fn agrees_with_the_standard_library() {
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut worst_abs = 0.0_f64;
    for scale in [1e-8, 1e-3, 1.0, 3.0, 10.0, 1e3, 1e5] {
        for _ in 0..20_000 {
            let theta = angles(&mut state, scale);
            let (s, c) = sin_cos::<Separate>(theta);
            for i in 0..WIDTH {
                let (sw, cw) = theta[i].sin_cos();
                worst_abs = worse(worst_abs, (f64::from(s.0[i]) - sw).abs());
                worst_abs = worse(worst_abs, (f64::from(c.0[i]) - cw).abs());
            }
        }
    }
    assert!(worst_abs <= 2f64.powi(-23), "worst {worst_abs:e}");
    // Beyond the reduction's range, the library's values rounded to f32.
    let (s, c) = sin_cos::<Separate>([1e7; WIDTH]);
    assert_eq!(
        (s.0[0], c.0[0]),
        (1e7_f64.sin() as f32, 1e7_f64.cos() as f32)
    );
}

/// The remainder's rounding to `f32` (`r_lo`) is carried into `sin`: over 8·10⁵ angles in
/// [−10, 10] rad the mean error of `sin` is 0.3356 `f32` ulps of the correctly rounded value
/// with the term, 0.3383 without it and 0.3463 with its sign flipped (the worst case stays
/// within one ulp in all three, which is all the test above sees).
#[test]
fn the_remainders_rounding_makes_sin_more_accurate() {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let (mut sum, mut count) = (0.0_f64, 0u64);
    for _ in 0..50_000 {
        let theta = angles(&mut state, 10.0);
        let (s, _) = sin_cos::<Separate>(theta);
        for i in 0..WIDTH {
            let want = theta[i].sin();
            let rounded = (want as f32).abs();
            let ulp = f64::from(rounded.next_up() - rounded);
            sum += (f64::from(s.0[i]) - want).abs() / ulp;
            count += 1;
        }
    }
    let mean = sum / count as f64;
    assert!(mean <= 0.337, "mean error {mean:.5} f32 ulp");
}

/// Multiples of π/2 as doubles leave residues of about 10⁻¹⁶ after the reduction; those are
/// taken as zero, so `sin`/`cos` are exactly 0 and ±1 there (as `f32`, the residues would
/// be 1.2·10⁻¹⁶ and, cubed in the polynomial, subnormal). An angle just past the threshold
/// keeps its sine.
#[test]
fn quarter_turns_are_exact() {
    use std::f64::consts::{FRAC_PI_2, PI};
    let angles = [
        0.0,
        FRAC_PI_2,
        PI,
        -PI,
        3.0 * FRAC_PI_2,
        -FRAC_PI_2,
        2.0 * PI,
        1e-13,
    ];
    let expected = [
        (0.0, 1.0),
        (1.0, 0.0),
        (0.0, -1.0),
        (0.0, -1.0),
        (-1.0, 0.0),
        (-1.0, 0.0),
        (0.0, 1.0),
        (0.0, 1.0),
    ];
    let theta: [f64; WIDTH] = std::array::from_fn(|i| angles.get(i).copied().unwrap_or(1e-11));
    let (s, c) = sin_cos::<Separate>(theta);
    for (i, &(sin, cos)) in expected.iter().enumerate() {
        assert_eq!((s.0[i], c.0[i]), (sin, cos), "θ = {}", theta[i]);
    }
    assert_eq!(s.0[WIDTH - 1], 1e-11);
}
