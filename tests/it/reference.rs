//! Every model of `tests/data/reference/` (URDF, standard and modified DH, axis form, stress):
//! all samples, all links, against answers computed by independent software (Pinocchio, Robotics
//! Toolbox for Python) and against the 50-digit references.

use crate::common::*;
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
                worst = worse(worst, e / scale);
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

/// The crate's own 256-bit evaluation ([`kinechain::reference`], against which `kinechain bench`
/// and the stress tests measure errors) agrees with the independent 50-digit references: poses
/// and ω, v, α, a of every link and sample within 4 ulp (of the reach, of 1 for rotation entries,
/// of each quantity's largest magnitude in the file). It takes the model's constants as loaded, so
/// what is left is their rounding at load time and the final rounding to `f64`: nothing on the DH
/// models, whose constants are the file's numbers, up to 1 ulp on the URDF robots, 3.5 on the
/// 12-joint axis-form chain, each of whose joints turns `rpy` into a rounded matrix (against
/// that file the kernels' rotation entries err by 5.5 ulp).
#[cfg(feature = "reference")]
#[test]
fn the_256_bit_evaluation_matches_the_50_digit_reference() {
    use kinechain::reference::{link_motion, link_poses};
    for path in reference_files() {
        let chain = reference_chain(&path, &read_json(&path));
        let exact = read_json(&hp_path(&path));
        let reach = scale_of(&exact, "pose");
        let mut pose = (0.0_f64, 0.0_f64);
        let (mut worst, mut largest) = ([0.0_f64; 4], [0.0_f64; 4]);
        for sample in exact["samples"].as_array().unwrap() {
            let [q, qd, qdd] = ["q", "qd", "qdd"].map(|k| joint_vector(&chain, &sample[k]));
            let poses = link_poses(&chain, &q);
            let motion = link_motion(&chain, &q, &qd, &qdd);
            for (name, link) in sample["links"].as_object().unwrap() {
                let i = chain.link_id(name).unwrap().index();
                // The two evaluations are the same arithmetic and round to the same pose.
                assert_eq!(poses[i], motion[i].pose, "{name}");
                pose = worse_pose(pose, &poses[i].to_rows(), &matrix4(&link["pose"]));
                let m = &motion[i];
                for (k, got) in [m.omega, m.v, m.alpha, m.a].iter().enumerate() {
                    let want = vec3(&link[RATE_FIELDS[k]]);
                    for c in 0..3 {
                        worst[k] = worse(worst[k], (got[c] - want[c]).abs());
                        largest[k] = largest[k].max(want[c].abs());
                    }
                }
            }
        }
        let (position, rotation) = (pose.0 / (reach * f64::EPSILON), pose.1 / f64::EPSILON);
        let rates: [f64; 4] = std::array::from_fn(|k| worst[k] / (largest[k] * f64::EPSILON));
        eprintln!(
            "{}: position {position:.2} rotation {rotation:.2} omega {:.2} v {:.2} alpha {:.2} a {:.2} ulp",
            path.file_name().unwrap().to_string_lossy(),
            rates[0],
            rates[1],
            rates[2],
            rates[3]
        );
        assert!(
            position <= 4.0 && rotation <= 4.0 && rates.iter().all(|&e| e <= 4.0),
            "{}: position {position:.2}, rotation {rotation:.2}, rates {rates:.2?} ulp",
            path.display()
        );
    }
}

/// The error measures of [`kinechain::reference`] report the largest difference, wherever it
/// is: a position, a rotation entry, or one component of one rate of one link, in metres (or the
/// rate's unit) and in ulps of that rate's largest magnitude.
#[cfg(feature = "reference")]
#[test]
fn the_error_measures_find_the_largest_difference() {
    use kinechain::reference::{LinkMotion, max_errors, max_rate_errors};
    let chain = repo_chain("robots/panda.urdf");
    let q = vec![0.3; chain.dof()];
    let exact = kinechain::reference::link_motion(&chain, &q, &vec![0.5; chain.dof()], &q);
    let poses: Vec<Transform> = exact.iter().map(|m| m.pose).collect();
    assert_eq!(max_errors(&poses, &poses), (0.0, 0.0));
    // Entry (row, column) of a pose moved by `by`.
    let nudge = |t: &Transform, row: usize, column: usize, by: f64| {
        let mut m = t.to_rows();
        m[row][column] += by;
        Transform::from_rows(&[m[0], m[1], m[2]])
    };
    let mut moved = poses.clone();
    moved[5] = nudge(&poses[5], 2, 3, 3e-9);
    moved[7] = nudge(&poses[7], 0, 3, -1e-9);
    moved[9] = nudge(&poses[9], 2, 1, 2e-12);
    let entry = |t: &Transform, row: usize, column: usize| t.to_rows()[row][column];
    let (position, rotation) = max_errors(&moved, &poses);
    assert_eq!(
        position,
        (entry(&moved[5], 2, 3) - entry(&poses[5], 2, 3)).abs()
    );
    assert_eq!(
        rotation,
        (entry(&moved[9], 2, 1) - entry(&poses[9], 2, 1)).abs()
    );
    // A NaN anywhere is reported, not passed over as `f64::max` would.
    moved[3] = nudge(&poses[3], 1, 3, f64::NAN);
    moved[11] = nudge(&poses[11], 0, 0, f64::NAN);
    let (position, rotation) = max_errors(&moved, &poses);
    assert!(position.is_nan() && rotation.is_nan());

    let rows = |m: &LinkMotion| [m.omega, m.v, m.alpha, m.a];
    let mut got: Vec<[[f64; 3]; 4]> = exact.iter().map(rows).collect();
    assert!(
        max_rate_errors(&got, &exact)
            .iter()
            .all(|&e| e == (0.0, 0.0))
    );
    for (k, link, c) in [(0, 3, 1), (1, 8, 2), (2, 11, 0), (3, 12, 2)] {
        got[link][k][c] += 1e-6 * (k + 1) as f64;
    }
    let errors = max_rate_errors(&got, &exact);
    for (k, link, c) in [(0, 3, 1), (1, 8, 2), (2, 11, 0), (3, 12, 2)] {
        let want = rows(&exact[link])[k][c];
        let largest = exact
            .iter()
            .flat_map(|m| rows(m)[k])
            .fold(0.0_f64, |m, x| m.max(x.abs()));
        let error = (got[link][k][c] - want).abs();
        assert_eq!(errors[k], (error, error / (largest * f64::EPSILON)), "{k}");
    }
    got[6][1][0] = f64::NAN;
    assert!(max_rate_errors(&got, &exact)[1].0.is_nan());
}
