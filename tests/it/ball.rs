//! Ball joints: a rotation by a quaternion anywhere in a tree, four entries of `q` (w, x, y, z)
//! and three of `q̇` (the angular velocity relative to the parent, world axes). Poses against
//! a product of the joints' own transforms, rates against finite differences along a
//! trajectory, Jacobians against the rates, batches against single evaluations, the 256-bit
//! evaluation, the loaders, layouts and errors.

use crate::common::{advance, link_poses, random_q, random_vec, rng, rotation};
use kinechain::nalgebra::Vector3;
use kinechain::{
    Chain, Data, JointKind, LimitPolicy, StateError, Transform, forward_accelerations,
    forward_kinematics, forward_velocities,
};

/// An arm with two ball joints between revolute and prismatic ones, placed off their parents'
/// origins and turned, and a branch (the fingers) after the second ball.
const ARM: &str = "name: ballarm\nconvention: axis\njoints:\n\
    - {name: base, type: revolute, origin: {xyz: [0, 0, 0.3]}, axis: [0, 0, 1], limits: [-3, 3]}\n\
    - {name: shoulder, type: ball, origin: {xyz: [0.1, 0.2, 0.4], rpy: [0.3, 0.2, 0.1]}}\n\
    - {name: elbow, type: revolute, origin: {xyz: [0, 0, 0.35]}, axis: [0, 1, 0], limits: [-2, 2]}\n\
    - {name: wrist, type: ball, origin: {xyz: [0.05, 0, 0.3], rpy: [0, 1.5707963267948966, 0]}}\n\
    - {name: slide, type: prismatic, origin: {xyz: [0, 0, 0.1]}, axis: [1, 0, 0], limits: [0, 0.04]}\n";

fn arm() -> Chain {
    Chain::from_dh_yaml_str(ARM).unwrap()
}

fn arms() -> Vec<(Chain, &'static str)> {
    let mut b = arm().description().clone();
    let floating = b.floating_base().build().unwrap();
    vec![(arm(), "arm"), (floating, "floating arm")]
}

#[test]
fn ball_joints_take_four_entries_of_q_and_three_of_q_dot() {
    let chain = arm();
    assert_eq!((chain.nq(), chain.nv(), chain.dof()), (11, 9, 9));
    let q: Vec<String> = kinechain::regression::variable_names(&chain);
    assert_eq!(
        q,
        [
            "base",
            "shoulder.qw",
            "shoulder.qx",
            "shoulder.qy",
            "shoulder.qz",
            "elbow",
            "wrist.qw",
            "wrist.qx",
            "wrist.qy",
            "wrist.qz",
            "slide"
        ]
    );
    let v = kinechain::regression::velocity_names(&chain);
    assert_eq!(
        v,
        [
            "base",
            "shoulder.wx",
            "shoulder.wy",
            "shoulder.wz",
            "elbow",
            "wrist.wx",
            "wrist.wy",
            "wrist.wz",
            "slide"
        ]
    );
    let shoulder = chain.joint(chain.joint_id("shoulder").unwrap());
    assert_eq!(shoulder.kind(), JointKind::Ball);
    assert_eq!(
        (
            shoulder.q_index(),
            shoulder.v_index(),
            shoulder.nq(),
            shoulder.dof()
        ),
        (Some(1), Some(1), 4, 3)
    );
    let elbow = chain.joint(chain.joint_id("elbow").unwrap());
    assert_eq!((elbow.q_index(), elbow.v_index()), (Some(5), Some(4)));
    let quaternions: Vec<usize> = chain.quaternions().iter().map(|q| q.1).collect();
    assert_eq!(quaternions, [1, 6]);
    assert_eq!(
        chain.neutral(),
        [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]
    );
    assert!(chain.lower()[1..5].iter().all(|x| *x == f64::NEG_INFINITY));
    assert!(chain.upper()[6..10].iter().all(|x| *x == f64::INFINITY));
    assert_eq!(
        kinechain::regression::variable_units(&chain)[..6],
        ["rad", "1", "1", "1", "1", "rad"]
    );
    // Random configurations carry unit quaternions that pass the checks.
    let qs = chain.random_configurations(20, 3, (-1.0, 1.0));
    for q in qs.chunks(chain.nq()) {
        kinechain::check_q(&chain, q, LimitPolicy::Enforce).unwrap();
        for e in [&q[1..5], &q[6..10]] {
            let n: f64 = e.iter().map(|x| x * x).sum();
            assert!((n - 1.0).abs() < 1e-15);
        }
    }
}

#[test]
fn poses_are_the_product_of_the_joints_own_transforms() {
    let chain = arm();
    let mut r = rng(3);
    let t = |xyz: [f64; 3], rpy: [f64; 3]| Transform::from_xyz_rpy(xyz, rpy);
    let turn = |e: &[f64]| Transform::from_parts(&rotation(e), &Vector3::zeros());
    for _ in 0..20 {
        let mut q = random_q(&chain, &mut r);
        // A quaternion scaled off unit length, as logs store them: the same rotation.
        for x in &mut q[6..10] {
            *x *= 1.0 + 4e-4;
        }
        let got = link_poses(&chain, &q);
        let base = t([0.0, 0.0, 0.3], [0.0; 3]) * Transform::rot_z(q[0]);
        let shoulder = base * t([0.1, 0.2, 0.4], [0.3, 0.2, 0.1]) * turn(&q[1..5]);
        let elbow = shoulder * t([0.0, 0.0, 0.35], [0.0; 3]) * Transform::rot_y(q[5]);
        let wrist =
            elbow * t([0.05, 0.0, 0.3], [0.0, std::f64::consts::FRAC_PI_2, 0.0]) * turn(&q[6..10]);
        let slide = wrist
            * t([0.0, 0.0, 0.1], [0.0; 3])
            * Transform::from_translation(Vector3::new(q[10], 0.0, 0.0));
        for (i, want) in [base, shoulder, elbow, wrist, slide].iter().enumerate() {
            let err = (got[i + 1].to_homogeneous() - want.to_homogeneous())
                .abs()
                .max();
            assert!(err < 1e-15, "link {}: {err:e}", i + 1);
        }
    }
}

#[test]
fn rates_are_the_time_derivatives_of_poses_along_q_dot() {
    let chain = arm();
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let mut r = rng(5);
    let h = 1e-5;
    let n = chain.links().len();
    for _ in 0..10 {
        let q = random_q(&chain, &mut r);
        let qd = random_vec(chain.nv(), 1.0, &mut r);
        let qdd = random_vec(chain.nv(), 1.0, &mut r);
        let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
        let ids: Vec<_> = (0..n)
            .map(|i| chain.link_id(chain.links()[i].name()).unwrap())
            .collect();
        let pose_at = |t: f64| link_poses(&chain, &advance(&chain, &q, &qd, &qdd, t).0);
        let rates_at = |t: f64| {
            let (qt, qdt) = advance(&chain, &q, &qd, &qdd, t);
            let mut d = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            let v = forward_velocities(&chain, &mut d, &qt, &qdt).unwrap();
            ids.iter().map(|&id| v.velocity(id)).collect::<Vec<_>>()
        };
        let (after, before, now) = (pose_at(h), pose_at(-h), pose_at(0.0));
        let (v_after, v_before) = (rates_at(h), rates_at(-h));
        for (i, &id) in ids.iter().enumerate() {
            let (vel, accel) = (acc.velocity(id), acc.acceleration(id));
            let v_fd = (after[i].translation() - before[i].translation()) / (2.0 * h);
            assert!((v_fd - vel.v).norm() < 1e-8, "link {i}: v {v_fd} {}", vel.v);
            let r_dot = (after[i].rotation() - before[i].rotation()) / (2.0 * h);
            let w = r_dot * now[i].rotation().transpose();
            let omega_fd = Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
            assert!(
                (omega_fd - vel.omega).norm() < 1e-8,
                "link {i}: ω {omega_fd} {}",
                vel.omega
            );
            let a_fd = (v_after[i].v - v_before[i].v) / (2.0 * h);
            assert!(
                (a_fd - accel.a).norm() < 1e-7,
                "link {i}: a {a_fd} {}",
                accel.a
            );
            let alpha_fd = (v_after[i].omega - v_before[i].omega) / (2.0 * h);
            assert!(
                (alpha_fd - accel.alpha).norm() < 1e-7,
                "link {i}: α {alpha_fd} {}",
                accel.alpha
            );
        }
        // The shoulder link turns relative to the base link at the ball's q̇ (world axes).
        let (base, shoulder) = (ids[1], ids[2]);
        let relative = acc.velocity(shoulder).omega - acc.velocity(base).omega;
        assert!((relative - Vector3::new(qd[1], qd[2], qd[3])).norm() < 1e-15);
    }
}

#[test]
fn jacobians_map_q_dot_to_link_velocities_and_give_ball_joints_three_columns() {
    use kinechain::nalgebra::DVector;
    for (chain, label) in arms() {
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut r = rng(8);
        let wrist = chain
            .joint(chain.joint_id("wrist").unwrap())
            .v_index()
            .unwrap();
        for _ in 0..10 {
            let q = random_q(&chain, &mut r);
            let qd = random_vec(chain.nv(), 1.0, &mut r);
            let qdd = random_vec(chain.nv(), 1.0, &mut r);
            let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
            for l in chain.links().iter().skip(1) {
                let id = chain.link_id(l.name()).unwrap();
                let j = acc.poses().jacobian(id);
                let twist = &j * DVector::from_column_slice(&qd);
                let v = acc.velocity(id);
                let err = (twist.fixed_rows::<3>(0) - v.v).norm()
                    + (twist.fixed_rows::<3>(3) - v.omega).norm();
                assert!(err < 1e-13, "{label} {}: {err:e}", l.name());
                let jd = acc.velocities().jacobian_dot(id);
                let a6 =
                    &j * DVector::from_column_slice(&qdd) + &jd * DVector::from_column_slice(&qd);
                let a = acc.acceleration(id);
                let err =
                    (a6.fixed_rows::<3>(0) - a.a).norm() + (a6.fixed_rows::<3>(3) - a.alpha).norm();
                assert!(err < 1e-12, "{label} {}: {err:e}", l.name());
            }
            // The wrist's columns on the last link: turns about the world axes.
            let end = chain.end_link();
            let j = acc.poses().jacobian(end);
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = 1.0;
                assert_eq!(j.fixed_view::<3, 1>(3, wrist + k).into_owned(), e);
            }
        }
    }
}

#[test]
fn batches_equal_single_evaluations_bit_for_bit() {
    for (chain, label) in arms() {
        crate::common::assert_batches_equal_single(&chain, label);
    }
}

#[test]
fn every_single_evaluation_mode_gives_the_full_evaluations_bits() {
    use kinechain::{forward_kinematics_incremental, forward_kinematics_to};
    let chain = arm();
    let mut r = rng(34);
    let (mut full, mut inc, mut one) = (Data::new(&chain), Data::new(&chain), Data::new(&chain));
    for d in [&mut full, &mut inc, &mut one] {
        d.set_limit_policy(LimitPolicy::Ignore);
    }
    let mut q = random_q(&chain, &mut r);
    for step in 0..30 {
        // Move the first ball, the second, a revolute joint, or everything.
        let next = random_q(&chain, &mut r);
        match step % 4 {
            0 => q[1..5].copy_from_slice(&next[1..5]),
            1 => q[6..10].copy_from_slice(&next[6..10]),
            2 => q[5] = next[5],
            _ => q.copy_from_slice(&next),
        }
        let want = link_poses(&chain, &q);
        let got = forward_kinematics_incremental(&chain, &mut inc, &q).unwrap();
        for (l, w) in chain.links().iter().zip(&want) {
            let id = chain.link_id(l.name()).unwrap();
            assert_eq!(got.world_from_link(id), *w, "step {step} {}", l.name());
        }
        for (l, w) in chain.links().iter().zip(&want) {
            let id = chain.link_id(l.name()).unwrap();
            let alone = forward_kinematics_to(&chain, &mut one, &q, id).unwrap();
            assert_eq!(alone, *w, "step {step} {} alone", l.name());
        }
        let _ = forward_kinematics(&chain, &mut full, &q).unwrap();
    }
}

#[cfg(feature = "reference")]
#[test]
fn ball_joints_are_within_a_few_ulps_of_the_256_bit_evaluation() {
    for (chain, label) in arms() {
        crate::common::assert_within_8_ulp_of_the_256_bit_evaluation(&chain, label);
    }
}

#[test]
fn bad_quaternions_and_lengths_are_errors_naming_the_ball_joint() {
    let chain = arm();
    let mut data = Data::new(&chain);
    let mut q = chain.neutral();
    for (e, norm) in [
        ([0.0; 4], 0.0),
        ([2.0, 0.0, 0.0, 0.0], 2.0),
        ([f64::NAN, 0.0, 0.0, 1.0], f64::NAN),
    ] {
        q[6..10].copy_from_slice(&e);
        let err = forward_kinematics(&chain, &mut data, &q)
            .map(|_| ())
            .unwrap_err();
        match &err {
            StateError::BadQuaternion {
                joint,
                kind,
                first,
                norm: n,
                ..
            } if !norm.is_nan() => {
                assert_eq!((joint.as_str(), *kind, *first), ("wrist", "ball", 6));
                assert_eq!(*n, norm);
                assert!(
                    err.to_string().contains("ball joint 'wrist' (q[6..10]"),
                    "{err}"
                );
            }
            // NaN: the finiteness check names the entry first.
            StateError::NonFinite { .. } => assert!(norm.is_nan()),
            other => panic!("{other:?}"),
        }
    }
    let err = forward_kinematics(&chain, &mut data, &[0.0; 9])
        .map(|_| ())
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "q has 9 entries; the chain takes 11: 4 for the ball joint 'shoulder', 4 for the ball joint 'wrist', 3 for the others"
    );
    let err = forward_velocities(&chain, &mut data, &chain.neutral(), &[0.0; 11])
        .map(|_| ())
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "q_dot has 11 entries; the chain takes 9: 3 for the ball joint 'shoulder', 3 for the ball joint 'wrist', 3 for the others"
    );
    // Batches name the configuration.
    let mut batch = kinechain::eval::batch::BatchData::new(&chain);
    let mut qs: Vec<f64> = (0..20).flat_map(|_| chain.neutral()).collect();
    qs[13 * 11 + 1] = 0.5;
    let e = kinechain::eval::batch::forward_kinematics_batch(&chain, &mut batch, &qs)
        .map(|_| ())
        .unwrap_err();
    assert_eq!(e.index, 13, "{e}");
    assert!(matches!(e.source, StateError::BadQuaternion { .. }), "{e}");
}

#[test]
fn the_loaders_read_ball_joints_and_refuse_what_they_cannot_take() {
    // A DH table has no ball joint; limits on one are refused; URDF cannot write one.
    let dh =
        "name: x\nconvention: standard\njoints:\n  - {name: b, type: ball, a: 0, alpha: 0, d: 0}\n";
    let e = kinechain::error::error_chain(&Chain::from_dh_yaml_str(dh).unwrap_err());
    assert!(e.contains("axis convention"), "{e}");
    let limited = ARM.replace(
        "type: ball, origin: {xyz: [0.1, 0.2, 0.4]",
        "type: ball, limits: [-1, 1], origin: {xyz: [0.1, 0.2, 0.4]",
    );
    let e = kinechain::error::error_chain(&Chain::from_dh_yaml_str(&limited).unwrap_err());
    assert!(e.contains("ball joint"), "{e}");
    let e = kinechain::io::convert::to_urdf(&arm())
        .unwrap_err()
        .to_string();
    assert!(e.contains("joint 'shoulder' is a ball joint"), "{e}");
    // A ball joint's quaternion is not a screw.
    let chain = arm();
    let id = chain.joint_id("shoulder").unwrap();
    let e = chain
        .joint_screw(id, &chain.neutral(), &[0.0; 9], &[0.0; 9])
        .unwrap_err();
    assert!(matches!(e, StateError::NoScrew { .. }));
    // A mimic of a ball joint is refused (a ball joint has no one coordinate).
    let mut b = chain.description().clone();
    b.link("copy");
    b.joint(
        kinechain::JointSpec::new("copy", JointKind::Revolute, "link5", "copy")
            .with_mimic("shoulder", 1.0, 0.0),
    );
    let e = kinechain::error::error_chain(&b.build().unwrap_err());
    assert!(e.contains("shoulder"), "{e}");
}

#[test]
fn joint_vectors_go_to_other_layouts_and_back() {
    use kinechain::eval::layouts::Layout;
    for (chain, label) in arms() {
        let mut r = rng(61);
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let wrist = chain.joint(chain.joint_id("wrist").unwrap());
        let (qi, vi) = (wrist.q_index().unwrap(), wrist.v_index().unwrap());
        for layout in [Layout::Pinocchio, Layout::Mujoco] {
            assert_eq!(chain.layout_sizes(layout), (chain.nq(), chain.nv()));
            for _ in 0..10 {
                let q = random_q(&chain, &mut r);
                let qd = random_vec(chain.nv(), 1.0, &mut r);
                let qdd = random_vec(chain.nv(), 1.0, &mut r);
                let theirs =
                    crate::common::assert_layout_round_trip(&chain, layout, (&q, &qd, &qdd), label);
                // The quaternion's order, and the rates in the axes of the wrist's child link
                // (its frame after the turn).
                let e = &q[qi..qi + 4];
                let theirs_e = &theirs.q[qi..qi + 4];
                match layout {
                    Layout::Pinocchio => assert_eq!(theirs_e, [e[1], e[2], e[3], e[0]]),
                    _ => assert_eq!(theirs_e, e),
                }
                let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
                let r_child = poses.world_from_link(wrist.child()).rotation();
                let local = r_child.transpose() * Vector3::new(qd[vi], qd[vi + 1], qd[vi + 2]);
                let got = &theirs.q_dot.as_deref().unwrap()[vi..vi + 3];
                assert!(
                    (local - Vector3::from_column_slice(got)).norm() < 1e-14,
                    "{label}"
                );
            }
        }
    }
}

#[test]
fn the_command_line_lists_evaluates_and_refuses_ball_joints() {
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_kinechain"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    };
    let file = "tests/data/mjcf/ball.xml";
    let out = run(&["info", file, "--format", "table"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("q has 18 entries"), "{text}");
    assert!(text.contains("10-13  wrist"), "{text}");
    // fk at a configuration given on the command line equals the library's.
    let chain = Chain::from_file(file).unwrap();
    let q = chain.keyframes()[0].1.clone();
    let q_text: Vec<String> = q.iter().map(|x| format!("{x:?}")).collect();
    let out = run(&[
        "fk",
        file,
        "--link",
        "tip",
        "--q",
        &q_text.join(" "),
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let pose = &v["links"]["tip"]["pose"];
    let want = link_poses(&chain, &q)[chain.link_id("tip").unwrap().index()].to_rows();
    for r in 0..3 {
        for c in 0..4 {
            assert_eq!(pose[r][c].as_f64().unwrap(), want[r][c], "{r} {c}");
        }
    }
    // A zero quaternion names the joint; URDF cannot hold a ball joint.
    let mut bad = q_text.clone();
    bad[..4].fill("0".to_string());
    let out = run(&["fk", file, "--q", &bad.join(" ")]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("ball joint 'waist'"),
        "{err}"
    );
    let out = run(&["convert", file]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("is a ball joint"),
        "{err}"
    );
}
