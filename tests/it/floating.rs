//! Floating joints: the base of a humanoid or a quadruped, seven entries of `q` (a position and a
//! quaternion w, x, y, z) and six of `q̇`. Poses against the fixed-base chain moved by the base's
//! pose, rates against finite differences along a trajectory, Jacobians against the rates, the
//! loaders and the errors.

use crate::common::{random_q, random_quaternion, random_vec, rng, robots_dir};
use kinechain::io::LoadOptions;
use kinechain::nalgebra::{Matrix3, Vector3};
use kinechain::{
    Chain, Data, JointKind, LimitPolicy, StateError, Transform, forward_accelerations,
    forward_kinematics, forward_velocities,
};

fn floating(file: &str) -> Chain {
    Chain::from_file_with(
        robots_dir().join(file),
        &LoadOptions::default().with_floating_base(true),
    )
    .unwrap()
}

/// The rotation of the unit quaternion `e` (w, x, y, z), from nalgebra.
fn rotation(e: [f64; 4]) -> Matrix3<f64> {
    let q = kinechain::nalgebra::UnitQuaternion::from_quaternion(
        kinechain::nalgebra::Quaternion::new(e[0], e[1], e[2], e[3]),
    );
    *q.to_rotation_matrix().matrix()
}

#[test]
fn a_floating_base_moves_every_link_with_the_base_pose() {
    for file in ["panda.urdf", "ur5.yaml", "puma560.yaml"] {
        let fixed = Chain::from_file(robots_dir().join(file)).unwrap();
        let chain = floating(file);
        assert_eq!(chain.nq(), fixed.nq() + 7, "{file}");
        assert_eq!(chain.nv(), fixed.nv() + 6);
        assert_eq!(chain.dof(), chain.nv());
        let root = chain.floating_joint().unwrap();
        assert_eq!(chain.joint(root).name(), "root_joint");
        assert_eq!(chain.joint(root).kind(), JointKind::Floating);
        assert_eq!(chain.links()[0].name(), "world");
        let mut r = rng(3);
        let (mut df, mut dx) = (
            Data::new(&fixed).with_limit_policy(LimitPolicy::Ignore),
            Data::new(&chain).with_limit_policy(LimitPolicy::Ignore),
        );
        for _ in 0..20 {
            let qj = random_q(&fixed, &mut r);
            let e = random_quaternion(&mut r);
            let p = random_vec(3, 2.0, &mut r);
            let q: Vec<f64> = p.iter().chain(&e).chain(&qj).copied().collect();
            let base = Transform::from_parts(&rotation(e), &Vector3::new(p[0], p[1], p[2]));
            let moved = forward_kinematics(&chain, &mut dx, &q).unwrap();
            let still = forward_kinematics(&fixed, &mut df, &qj).unwrap();
            for link in fixed.links() {
                let id = fixed.link_id(link.name()).unwrap();
                let want = base * still.world_from_link(id);
                let got = moved.world_from_link(chain.link_id(link.name()).unwrap());
                let err = (got.to_homogeneous() - want.to_homogeneous()).abs().max();
                assert!(
                    err < 2e-15 * (1.0 + fixed.reach()),
                    "{file} {} {err:e}",
                    link.name()
                );
            }
            // The world link stays where it is.
            let w = moved.world_from_link(chain.link_id("world").unwrap());
            assert_eq!(w, Transform::IDENTITY);
        }
    }
}

/// `q` moved by `t` along a motion with rates `qd` and accelerations `qdd` (constant), to the
/// second order in `t`: the base's position by `v t + a t²/2`, its quaternion turned by the
/// rotation vector `ω t + α t²/2` (world axes: multiplied from the left), the joints by
/// `q̇ t + q̈ t²/2`.
fn advance(q: &[f64], qd: &[f64], qdd: &[f64], t: f64) -> Vec<f64> {
    let mut out = q.to_vec();
    for k in 0..3 {
        out[k] += qd[k] * t + 0.5 * qdd[k] * t * t;
    }
    let turn = Vector3::from_fn(|k, _| qd[3 + k] * t + 0.5 * qdd[3 + k] * t * t);
    let dq = kinechain::nalgebra::UnitQuaternion::from_scaled_axis(turn);
    let e = kinechain::nalgebra::Quaternion::new(q[3], q[4], q[5], q[6]);
    let moved = dq.into_inner() * e;
    out[3..7].copy_from_slice(&[moved.w, moved.i, moved.j, moved.k]);
    for (x, (v, a)) in out[7..].iter_mut().zip(qd[6..].iter().zip(&qdd[6..])) {
        *x += v * t + 0.5 * a * t * t;
    }
    out
}

#[test]
fn rates_are_the_time_derivatives_of_poses_along_q_dot() {
    // The velocity convention: q̇ of the base is its origin's velocity and its angular velocity in
    // world axes, q̈ their time derivatives.
    let chain = floating("panda.urdf");
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let mut r = rng(5);
    let h = 1e-5;
    for _ in 0..10 {
        let q = random_q(&chain, &mut r);
        let qd = random_vec(chain.nv(), 1.0, &mut r);
        let qdd = random_vec(chain.nv(), 1.0, &mut r);
        let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
        let (vel, accel): (Vec<_>, Vec<_>) = chain
            .links()
            .iter()
            .enumerate()
            .map(|(i, _)| {
                let id = chain.link_id(chain.links()[i].name()).unwrap();
                (acc.velocity(id), acc.acceleration(id))
            })
            .unzip();
        let pose_at = |t: f64| {
            let q = advance(&q, &qd, &qdd, t);
            let mut d = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            let p = forward_kinematics(&chain, &mut d, &q).unwrap();
            (0..chain.links().len())
                .map(|i| p.world_from_link(chain.link_id(chain.links()[i].name()).unwrap()))
                .collect::<Vec<_>>()
        };
        let rates_at = |t: f64| {
            let qt = advance(&q, &qd, &qdd, t);
            let qdt: Vec<f64> = qd.iter().zip(&qdd).map(|(v, a)| v + a * t).collect();
            let mut d = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            let v = forward_velocities(&chain, &mut d, &qt, &qdt).unwrap();
            (0..chain.links().len())
                .map(|i| v.velocity(chain.link_id(chain.links()[i].name()).unwrap()))
                .collect::<Vec<_>>()
        };
        let (after, before, now) = (pose_at(h), pose_at(-h), pose_at(0.0));
        let (v_after, v_before) = (rates_at(h), rates_at(-h));
        for i in 0..chain.links().len() {
            let v_fd = (after[i].translation() - before[i].translation()) / (2.0 * h);
            assert!(
                (v_fd - vel[i].v).norm() < 1e-8,
                "link {i}: v {v_fd} {}",
                vel[i].v
            );
            let r_dot = (after[i].rotation() - before[i].rotation()) / (2.0 * h);
            let w = r_dot * now[i].rotation().transpose();
            let omega_fd = Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
            assert!(
                (omega_fd - vel[i].omega).norm() < 1e-7,
                "link {i}: ω {omega_fd} {}",
                vel[i].omega
            );
            let a_fd = (v_after[i].v - v_before[i].v) / (2.0 * h);
            assert!(
                (a_fd - accel[i].a).norm() < 1e-7,
                "link {i}: a {a_fd} {}",
                accel[i].a
            );
            let alpha_fd = (v_after[i].omega - v_before[i].omega) / (2.0 * h);
            assert!(
                (alpha_fd - accel[i].alpha).norm() < 1e-7,
                "link {i}: α {alpha_fd} {}",
                accel[i].alpha
            );
        }
        // The base link's own rates are the first entries of q̇ and q̈.
        let base = chain.link_id("panda_link0").unwrap();
        let v = acc.velocity(base);
        assert_eq!(v.v.as_slice(), &qd[0..3]);
        assert_eq!(v.omega.as_slice(), &qd[3..6]);
        let a = acc.acceleration(base);
        assert_eq!(a.a.as_slice(), &qdd[0..3]);
        assert_eq!(a.alpha.as_slice(), &qdd[3..6]);
    }
}

#[test]
fn jacobians_map_q_dot_to_link_velocities_and_have_the_base_columns_first() {
    let chain = floating("panda.urdf");
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let mut r = rng(8);
    for _ in 0..10 {
        let q = random_q(&chain, &mut r);
        let qd = random_vec(chain.nv(), 1.0, &mut r);
        let qdd = random_vec(chain.nv(), 1.0, &mut r);
        let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
        for (i, _) in chain.links().iter().enumerate().skip(1) {
            let id = chain.link_id(chain.links()[i].name()).unwrap();
            let j = acc.poses().jacobian(id);
            assert_eq!(j.ncols(), chain.nv());
            let twist = &j * kinechain::nalgebra::DVector::from_column_slice(&qd);
            let v = acc.velocity(id);
            let err = (twist.fixed_rows::<3>(0) - v.v).norm()
                + (twist.fixed_rows::<3>(3) - v.omega).norm();
            assert!(err < 1e-13, "link {i}: {err:e}");
            // [a; α] = J q̈ + J̇ q̇.
            let jd = acc.velocities().jacobian_dot(id);
            let a6 = &j * kinechain::nalgebra::DVector::from_column_slice(&qdd)
                + &jd * kinechain::nalgebra::DVector::from_column_slice(&qd);
            let a = acc.acceleration(id);
            let err =
                (a6.fixed_rows::<3>(0) - a.a).norm() + (a6.fixed_rows::<3>(3) - a.alpha).norm();
            assert!(err < 1e-12, "link {i}: {err:e}");
            // The base's columns: slides along the world axes, turns about them through the base.
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = 1.0;
                assert_eq!(j.fixed_view::<3, 1>(0, k).into_owned(), e);
                assert_eq!(j.fixed_view::<3, 1>(3, 3 + k).into_owned(), e);
            }
        }
    }
}

#[test]
fn the_loaders_read_floating_joints() {
    let urdf = r#"<robot name="hopper">
      <link name="world"/><link name="body"/><link name="leg"/>
      <joint name="free" type="floating"><parent link="world"/><child link="body"/>
        <origin xyz="0 0 1"/></joint>
      <joint name="knee" type="revolute"><parent link="body"/><child link="leg"/>
        <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    </robot>"#;
    let chain = Chain::from_urdf_str(urdf).unwrap();
    assert_eq!((chain.nq(), chain.nv()), (8, 7));
    let names: Vec<String> = chain
        .variables()
        .map(|(j, c)| format!("{}.{}", chain.joint(j).name(), c.unwrap_or("")))
        .collect();
    assert_eq!(
        names,
        [
            "free.x", "free.y", "free.z", "free.qw", "free.qx", "free.qy", "free.qz", "knee."
        ]
    );
    let v: Vec<&str> = chain.velocity_variables().filter_map(|(_, c)| c).collect();
    assert_eq!(v, ["vx", "vy", "vz", "wx", "wy", "wz"]);
    // The joint's origin places the motion: the neutral pose is 1 m up.
    let mut data = Data::new(&chain);
    assert_eq!(chain.neutral(), [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
    let poses = forward_kinematics(&chain, &mut data, &chain.neutral()).unwrap();
    assert_eq!(
        poses
            .world_from_link(chain.link_id("body").unwrap())
            .translation(),
        Vector3::new(0.0, 0.0, 1.0)
    );
    assert_eq!(chain.lower()[..7], [f64::NEG_INFINITY; 7]);

    let yaml = "name: hopper\nconvention: axis\njoints:\n\
        - {name: free, type: floating, origin: {xyz: [0, 0, 1]}}\n\
        - {name: knee, type: revolute, origin: {xyz: [0, 0, 0]}, axis: [0, 1, 0], limits: [-1, 1]}\n";
    let chain = Chain::from_dh_yaml_str(yaml).unwrap();
    assert_eq!((chain.nq(), chain.nv()), (8, 7));
    let mut data = Data::new(&chain);
    let poses = forward_kinematics(&chain, &mut data, &chain.neutral()).unwrap();
    assert_eq!(
        poses
            .world_from_link(chain.link_id("link1").unwrap())
            .translation(),
        Vector3::new(0.0, 0.0, 1.0)
    );
}

#[test]
fn floating_joints_elsewhere_than_first_are_evaluated_where_they_stand() {
    // Below a moving joint: read, the floating joint's entries after the revolute one's.
    let below = r#"<robot name="r">
      <link name="a"/><link name="b"/><link name="c"/>
      <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="free" type="floating"><parent link="b"/><child link="c"/></joint>
    </robot>"#;
    let chain = Chain::from_urdf_str(below).unwrap();
    assert!(chain.floating_joint().is_none());
    assert_eq!(
        kinechain::regression::variable_names(&chain)[..2],
        ["j", "free.x"]
    );
    // Beside a moving joint that comes first in q, and declared first: either way read, the
    // floating joint the base only when it comes first.
    let beside = |first: &str, second: &str| {
        format!(
            r#"<robot name="r">
      <link name="a"/><link name="b"/><link name="c"/><link name="t"/>
      {first}<joint name="table" type="fixed"><parent link="a"/><child link="t"/></joint>
      {second}</robot>"#
        )
    };
    let free = r#"<joint name="free" type="floating"><parent link="t"/><child link="b"/></joint>"#;
    let arm = r#"<joint name="j" type="revolute"><parent link="a"/><child link="c"/><axis xyz="0 0 1"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>"#;
    let later = Chain::from_urdf_str(&beside(arm, free)).unwrap();
    assert!(later.floating_joint().is_none());
    assert_eq!(
        kinechain::regression::variable_names(&later)[..2],
        ["j", "free.x"]
    );
    let chain = Chain::from_urdf_str(&beside(free, arm)).unwrap();
    assert!(chain.floating_joint().is_some());
    assert_eq!((chain.nq(), chain.nv()), (8, 7));
    // The arm beside the base stays with the world; the table too; in both orders alike.
    let mut q = chain.neutral();
    q[0] = 5.0;
    q[7] = 0.5;
    let mut q_later = later.neutral();
    q_later[1] = 5.0;
    q_later[0] = 0.5;
    let mut data = Data::new(&chain);
    let p = forward_kinematics(&chain, &mut data, &q).unwrap();
    let mut data_later = Data::new(&later);
    let p_later = forward_kinematics(&later, &mut data_later, &q_later).unwrap();
    for link in ["b", "c", "t"] {
        assert_eq!(
            p.world_from_link(chain.link_id(link).unwrap()),
            p_later.world_from_link(later.link_id(link).unwrap()),
            "{link}"
        );
    }
    assert_eq!(
        p.world_from_link(chain.link_id("b").unwrap())
            .translation()
            .x,
        5.0
    );
    assert_eq!(
        p.world_from_link(chain.link_id("c").unwrap())
            .translation()
            .x,
        0.0
    );
    assert_eq!(
        p.world_from_link(chain.link_id("t").unwrap()),
        Transform::IDENTITY
    );
    // A floating base on a robot whose root already floats: two in a row, refused.
    let path = std::env::temp_dir().join(format!("kinechain-floating-{}.urdf", std::process::id()));
    std::fs::write(
        &path,
        r#"<robot name="r"><link name="w"/><link name="b"/>
      <joint name="free" type="floating"><parent link="w"/><child link="b"/></joint></robot>"#,
    )
    .unwrap();
    let e = kinechain::error::error_chain(
        &Chain::from_file_with(&path, &LoadOptions::default().with_floating_base(true))
            .unwrap_err(),
    );
    std::fs::remove_file(&path).ok();
    assert!(e.contains("two floating joints in a row"), "{e}");
    // A mimic of a floating joint, a floating mimic, and a floating joint in a DH row.
    let yaml = "name: r\nconvention: standard\njoints:\n- {name: f, type: floating, a: 0, alpha: 0, d: 0, theta: 0}\n";
    let e = kinechain::error::error_chain(&Chain::from_dh_yaml_str(yaml).unwrap_err());
    assert!(e.contains("axis convention"), "{e}");
}

#[test]
fn bad_quaternions_and_lengths_are_errors_naming_the_floating_joint() {
    let chain = floating("panda.urdf");
    let mut data = Data::new(&chain);
    let mut q = chain.neutral();
    for (e, norm) in [
        ([0.0; 4], 0.0),
        ([2.0, 0.0, 0.0, 0.0], 2.0),
        ([1.002, 0.0, 0.0, 0.0], 1.002),
    ] {
        q[3..7].copy_from_slice(&e);
        match forward_kinematics(&chain, &mut data, &q) {
            Err(StateError::BadQuaternion { joint, norm: n, .. }) => {
                assert_eq!(joint, "root_joint");
                assert!((n - norm).abs() < 1e-12);
            }
            other => panic!("{other:?}"),
        }
    }
    // Near unit length: normalised, the same poses as the unit quaternion's within rounding.
    q[3..7].copy_from_slice(&[1.0 + 5e-4, 0.0, 0.0, 0.0]);
    let p = forward_kinematics(&chain, &mut data, &q)
        .unwrap()
        .world_from_link(chain.end_link());
    let mut unit = chain.neutral();
    unit[..3].copy_from_slice(&q[..3]);
    let mut d2 = Data::new(&chain);
    let u = forward_kinematics(&chain, &mut d2, &unit)
        .unwrap()
        .world_from_link(chain.end_link());
    assert!((p.to_homogeneous() - u.to_homogeneous()).abs().max() < 1e-15);
    // NaN in the quaternion names the component.
    q[5] = f64::NAN;
    let e = forward_kinematics(&chain, &mut data, &q)
        .unwrap_err()
        .to_string();
    assert!(e.contains("root_joint' qy"), "{e}");
    // Lengths say what makes them up.
    let e = forward_kinematics(&chain, &mut data, &q[..14])
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "q has 14 entries; the chain takes 15: 7 for the floating joint 'root_joint', 8 for the others"
    );
    let q = chain.neutral();
    let e = forward_velocities(&chain, &mut data, &q, &[0.0; 15])
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "q_dot has 15 entries; the chain takes 14: 6 for the floating joint 'root_joint', 8 for the others"
    );
    let mut qd = vec![0.0; 14];
    qd[4] = f64::INFINITY;
    let e = forward_velocities(&chain, &mut data, &q, &qd)
        .unwrap_err()
        .to_string();
    assert!(e.contains("q_dot[4] (joint 'root_joint' wy)"), "{e}");
}

#[test]
fn batches_of_a_floating_base_equal_single_evaluations_bit_for_bit() {
    for file in ["panda.urdf", "ur5.yaml", "snake50.yaml"] {
        crate::common::assert_batches_equal_single(&floating(file), file);
    }
}

#[test]
fn batches_refuse_bad_quaternions_naming_the_configuration() {
    use kinechain::eval::batch::{
        BatchData, forward_kinematics_batch, forward_kinematics_batch_to,
    };
    let chain = floating("panda.urdf");
    let nq = chain.nq();
    let mut qs: Vec<f64> = (0..20).flat_map(|_| chain.neutral()).collect();
    qs[13 * nq + 3] = 1.01;
    for policy in [LimitPolicy::Enforce, LimitPolicy::Ignore] {
        let mut batch = BatchData::new(&chain).with_limit_policy(policy);
        let e = forward_kinematics_batch(&chain, &mut batch, &qs).unwrap_err();
        assert_eq!(e.index, 13);
        assert!(
            matches!(e.source, StateError::BadQuaternion { .. }),
            "{e:?}"
        );
        let e = forward_kinematics_batch_to(&chain, &mut batch, &qs, chain.end_link()).unwrap_err();
        assert_eq!(e.index, 13);
    }
    // A row of the wrong length names what makes up a configuration.
    let mut batch = BatchData::new(&chain);
    let e = forward_kinematics_batch(&chain, &mut batch, &qs[..nq + 3]).unwrap_err();
    assert_eq!(e.index, 1);
    assert!(
        e.source
            .to_string()
            .contains("7 for the floating joint 'root_joint'"),
        "{e}"
    );
}

#[test]
fn every_single_evaluation_mode_gives_the_full_evaluations_bits() {
    use kinechain::{forward_kinematics_incremental, forward_kinematics_to};
    let chain = floating("panda.urdf");
    let mut r = rng(34);
    let (mut full, mut inc, mut one) = (Data::new(&chain), Data::new(&chain), Data::new(&chain));
    for (full, inc, one) in [(&mut full, &mut inc, &mut one)] {
        for d in [&mut *full, &mut *inc, &mut *one] {
            d.set_limit_policy(LimitPolicy::Ignore);
        }
        let mut q = random_q(&chain, &mut r);
        for step in 0..30 {
            // Move the base, a joint, or both.
            let next = random_q(&chain, &mut r);
            match step % 3 {
                0 => q[..7].copy_from_slice(&next[..7]),
                1 => q[7 + step % 8] = next[7 + step % 8],
                _ => q.copy_from_slice(&next),
            }
            let want: Vec<Transform> = {
                let p = forward_kinematics(&chain, full, &q).unwrap();
                chain
                    .links()
                    .iter()
                    .map(|l| p.world_from_link(chain.link_id(l.name()).unwrap()))
                    .collect()
            };
            let got = forward_kinematics_incremental(&chain, inc, &q).unwrap();
            for (l, w) in chain.links().iter().zip(&want) {
                assert_eq!(
                    got.world_from_link(chain.link_id(l.name()).unwrap()),
                    *w,
                    "step {step} {}",
                    l.name()
                );
            }
            for (l, w) in chain.links().iter().zip(&want) {
                let id = chain.link_id(l.name()).unwrap();
                assert_eq!(
                    forward_kinematics_to(&chain, one, &q, id).unwrap(),
                    *w,
                    "step {step} {} alone",
                    l.name()
                );
            }
        }
    }
}

#[cfg(feature = "reference")]
#[test]
fn a_floating_base_is_within_a_few_ulps_of_the_256_bit_evaluation() {
    crate::common::assert_within_8_ulp_of_the_256_bit_evaluation(&floating("panda.urdf"), "panda");
}

#[test]
fn joint_vectors_go_to_other_layouts_and_back() {
    use kinechain::eval::layouts::Layout;
    let chain = floating("panda.urdf");
    let mut r = rng(61);
    for layout in [Layout::Pinocchio, Layout::Mujoco] {
        // The Panda's arm joints are limited (no cos/sin), its second finger a mimic.
        assert_eq!(chain.layout_sizes(layout), (chain.nq() + 1, chain.nv() + 1));
        for _ in 0..10 {
            let q = random_q(&chain, &mut r);
            let qd = random_vec(chain.nv(), 1.0, &mut r);
            let qdd = random_vec(chain.nv(), 1.0, &mut r);
            let theirs =
                crate::common::assert_layout_round_trip(&chain, layout, (&q, &qd, &qdd), "panda");
            // The mimicked finger follows its primary.
            let finger = theirs.q[theirs.q.len() - 1];
            assert_eq!(finger, q[q.len() - 1]);
        }
    }
    // A continuous joint is cos, sin in Pinocchio's layout and its angle in MuJoCo's.
    let wheel = Chain::from_urdf_str(
        r#"<robot name="w"><link name="a"/><link name="b"/>
        <joint name="spin" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint></robot>"#,
    )
    .unwrap();
    let pin = wheel
        .to_layout(Layout::Pinocchio, &[0.5], None, None)
        .unwrap();
    assert_eq!(pin.q, [0.5f64.cos(), 0.5f64.sin()]);
    assert_eq!(
        wheel
            .from_layout(Layout::Pinocchio, &pin.q, None, None)
            .unwrap()
            .q,
        [0.5]
    );
    assert_eq!(
        wheel
            .to_layout(Layout::Mujoco, &[0.5], None, None)
            .unwrap()
            .q,
        [0.5]
    );
    let e = wheel
        .from_layout(Layout::Pinocchio, &[1.0], None, None)
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "q in the pinocchio layout has 1 entries; the chain takes 2 there"
    );
}
