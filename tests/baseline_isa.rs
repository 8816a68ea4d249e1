//! The baseline x86-64 kernels (no FMA, no AVX), which a CPU without AVX2 runs: forced for this
//! whole test binary (the choice is process-wide, and each test file is its own process), and
//! checked against the 50-digit references and against the batch kernels of the same path.

mod common;

use common::*;
use kinechain::{Isa, force_isa, isa};

fn use_baseline() {
    force_isa(Some(Isa::Baseline));
    assert_eq!(isa(), Isa::Baseline);
}

#[test]
fn baseline_poses_are_within_8_ulp_of_the_50_digit_reference() {
    use_baseline();
    for path in reference_files() {
        let (position, rotation) = pose_ulps(&path);
        assert!(
            position <= 8.0 && rotation <= 8.0,
            "{}: position {position:.2} ulp of reach, rotation {rotation:.2} ulp",
            path.display()
        );
    }
}

/// The baseline rate kernels (ω, v, α, a of every link) against the 50-digit references, within
/// the 8 ulp of each quantity's largest magnitude that the default path meets.
#[test]
fn baseline_rates_are_within_8_ulp_of_the_50_digit_reference() {
    use_baseline();
    for path in reference_files() {
        let rates = rate_ulps(&path);
        assert!(
            rates.iter().all(|&e| e <= 8.0),
            "{}: omega, v, alpha, a {rates:.2?} ulp of the largest value",
            path.display()
        );
    }
}

#[test]
fn baseline_batches_equal_baseline_single_evaluations_bit_for_bit() {
    use_baseline();
    assert_batches_equal_single_evaluations(
        &[
            "robots/panda.urdf",
            "robots/panda.urdf+floating",
            "robots/snake50.yaml",
            "robots/cylindrical.yaml",
            "tests/data/reference/urdf/tiago_no_hand.urdf",
        ],
        22,
    );
}

#[test]
fn baseline_lane_checks_decide_as_check_q_does() {
    use_baseline();
    assert_lane_checks_decide_as_check_q_does();
}

/// Without a fused multiply–add the fast reduction is exact only below 1.6·10⁶ rad, so larger
/// angles must reach the standard library's `sin`/`cos` (with FMA the reduction stays accurate
/// far beyond, and this could go unnoticed).
#[cfg(feature = "reference")]
#[test]
fn baseline_poses_at_large_angles_are_as_accurate_as_at_small_ones() {
    use_baseline();
    let (position, rotation) = large_angle_pose_ulps("robots/puma560.yaml");
    assert!(
        position <= 8.0 && rotation <= 8.0,
        "position {position:.2} ulp of reach, rotation {rotation:.2} ulp"
    );
}
