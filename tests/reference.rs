//! Every model of `tests/data/reference/` (URDF, standard and modified DH, axis form, stress):
//! all samples, all links, against answers computed by independent software (Pinocchio, Robotics
//! Toolbox for Python) and against the 50-digit references.

mod common;

use common::*;
use kinechain::{Data, LimitPolicy, Transform, forward_kinematics};

/// Poses agree with the double-precision reference to 1e-12 of the chain's reach (the reference
/// itself is accurate to ~1e-15; 1e-12 leaves room for the 4e-12 disagreement the reference
/// README reports on long chains, while still catching any wrong frame or sign).
#[test]
fn poses_match_the_reference_for_every_model_sample_and_link() {
    for path in reference_files() {
        let reference = read_json(&path);
        let chain = reference_chain(&path, &reference);
        // Sample 20 (all zeros) may violate a limit on purpose; evaluate it anyway.
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let scale = scale_of(&reference, "pose");
        let mut worst: f64 = 0.0;
        let mut checked = 0;
        for sample in reference["samples"].as_array().unwrap() {
            let q = joint_vector(&chain, &sample["q"]);
            let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
            for (name, link) in sample["links"].as_object().unwrap() {
                let id = chain.link_id(name).unwrap();
                let e = pose_error(&poses.world_from_link(id), &matrix4(&link["pose"]));
                worst = worst.max(e / scale);
                checked += 1;
            }
        }
        assert!(checked > 0);
        assert!(
            worst < 1e-12,
            "{}: pose error {worst:e} of reach",
            path.display()
        );
    }
}

/// The textbook evaluation of a DH table, a product of eq. 2.129 matrices
/// (`joint::dh_transform`), agrees with the independent software's poses for both conventions
/// (and the Stanford arm's prismatic row) to 2e-14 of the reach: the double-precision reference
/// is within 1e-14 of exact on these robots (its README), and the product adds a few ulps
/// (measured: at most 2.2e-16).
#[test]
fn products_of_dh_matrices_match_the_reference() {
    let mut models = 0;
    let mut out = Vec::new();
    for path in reference_files() {
        let reference = read_json(&path);
        let Some(product) = DhProduct::of(&reference) else {
            continue;
        };
        let chain = reference_chain(&path, &reference);
        let scale = scale_of(&reference, "pose");
        for sample in reference["samples"].as_array().unwrap() {
            product.poses(&joint_vector(&chain, &sample["q"]), &mut out);
            for (name, link) in sample["links"].as_object().unwrap() {
                let m = &out[product.index(name)];
                let pose = Transform::try_from_homogeneous(m).unwrap();
                let e = pose_error(&pose, &matrix4(&link["pose"]));
                assert!(e / scale < 2e-14, "{}: {name}: {e:e}", path.display());
            }
        }
        models += 1;
    }
    // AL5D, Panda, Puma 560, Stanford, UR5 and the planar example.
    assert_eq!(models, 6);
}

/// ω, v, α and the classical acceleration a of every link agree to 1e-10 of the largest value of
/// each quantity in the file.
#[test]
fn rates_match_the_reference_for_every_model_sample_and_link() {
    for path in reference_files() {
        let reference = read_json(&path);
        let chain = reference_chain(&path, &reference);
        let (errors, _) = rate_errors(&chain, &reference);
        let worst: [f64; 4] =
            std::array::from_fn(|k| errors[k] / scale_of(&reference, RATE_FIELDS[k]));
        for k in 0..4 {
            assert!(
                worst[k] < 1e-10,
                "{}: {} error {:e} (relative)",
                path.display(),
                RATE_FIELDS[k],
                worst[k]
            );
        }
    }
}

/// Against the 50-digit references, with default settings: position errors within 8 ulp of the
/// chain's reach, rotation entries within 8 ulp of 1 (ulp = 2⁻⁵², the spacing of doubles in
/// [1, 2)). A composition of n rigid transforms rounds each entry O(1) times per joint, so
/// errors grow at most ~n ulp and in practice ~√n; the worst measured is below 7.
#[test]
fn poses_are_within_8_ulp_of_the_50_digit_reference() {
    for path in reference_files() {
        let (position, rotation) = pose_ulps(&path);
        eprintln!(
            "{}: position {position:.2} ulp of reach, rotation {rotation:.2} ulp",
            path.file_name().unwrap().to_string_lossy()
        );
        assert!(
            position <= 8.0 && rotation <= 8.0,
            "{}: position {position:.2} ulp of reach, rotation {rotation:.2} ulp",
            path.display()
        );
    }
}

/// Against the 50-digit references, with default settings: ω, v, α and a of every link within
/// 8 ulp of the largest magnitude of each quantity in the file (the bound the poses meet; the
/// recursion rounds each of them O(1) times per joint).
#[test]
fn rates_are_within_8_ulp_of_the_50_digit_reference() {
    for path in reference_files() {
        let [omega, v, alpha, a] = rate_ulps(&path);
        eprintln!(
            "{}: omega {omega:.2} v {v:.2} alpha {alpha:.2} a {a:.2} ulp",
            path.file_name().unwrap().to_string_lossy()
        );
        assert!(
            [omega, v, alpha, a].iter().all(|&e| e <= 8.0),
            "{}: omega {omega:.2} v {v:.2} alpha {alpha:.2} a {a:.2} ulp of the largest value",
            path.display()
        );
    }
}
