//! Floating joints anywhere in a tree and any number of them (the free bodies of a scene): seven
//! entries of `q` where each stands, six of `q̇` (the velocity of its body's origin and its
//! angular velocity relative to its parent, world axes). Poses against a product of the joints'
//! own transforms, rates against finite differences along a trajectory, Jacobians against the
//! rates, batches and every evaluation mode against single evaluations, the 256-bit evaluation,
//! layouts, and what stays refused.

use crate::common::{advance, link_poses, random_q, random_vec, rng, rotation};
use kinechain::nalgebra::{DVector, Vector3};
use kinechain::{
    Chain, Data, LimitPolicy, Transform, forward_accelerations, forward_kinematics,
    forward_velocities,
};

/// An arm whose second link carries a floating joint ("grip", under a moving joint, its frame
/// placed and turned), then a free box with a hinged lid hanging from the world after it, and a
/// free ball declared last: no floating base, three floating joints where they stand.
const SCENE: &str = r#"<robot name="scene">
  <link name="world"/><link name="base"/><link name="upper"/><link name="carried"/><link name="tip"/>
  <link name="box"/><link name="lid"/><link name="ball"/>
  <joint name="mount" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 0.1"/></joint>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.3" rpy="0.1 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="grip" type="floating"><parent link="upper"/><child link="carried"/>
    <origin xyz="0.1 0.2 0.4" rpy="0.3 0.2 0.1"/></joint>
  <joint name="twist" type="revolute"><parent link="carried"/><child link="tip"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="box_free" type="floating"><parent link="world"/><child link="box"/>
    <origin xyz="1 0 0" rpy="0 0 0.5"/></joint>
  <joint name="lid_hinge" type="revolute"><parent link="box"/><child link="lid"/>
    <origin xyz="0 0.1 0.05"/><axis xyz="1 0 0"/><limit lower="0" upper="1.5" effort="1" velocity="1"/></joint>
  <joint name="ball_free" type="floating"><parent link="world"/><child link="ball"/></joint>
</robot>"#;

fn scene() -> Chain {
    Chain::from_urdf_str(SCENE).unwrap()
}

/// The scene, and the scene with a floating base (its root, `world`, then floats too).
fn scenes() -> Vec<(Chain, &'static str)> {
    let mut b = scene().description().clone();
    let floating = b.floating_base().build().unwrap();
    vec![(scene(), "scene"), (floating, "floating scene")]
}

#[test]
fn each_floating_joint_takes_seven_entries_of_q_where_it_stands() {
    let chain = scene();
    assert_eq!((chain.nq(), chain.nv()), (24, 21));
    assert!(chain.floating_joint().is_none());
    let names = kinechain::regression::variable_names(&chain);
    let free = |j: &str| ["x", "y", "z", "qw", "qx", "qy", "qz"].map(|c| format!("{j}.{c}"));
    let mut want = vec!["shoulder".to_string()];
    want.extend(free("grip"));
    want.push("twist".into());
    want.extend(free("box_free"));
    want.push("lid_hinge".into());
    want.extend(free("ball_free"));
    assert_eq!(names, want);
    let rates = kinechain::regression::velocity_names(&chain);
    assert_eq!(
        rates[1..7],
        [
            "grip.vx", "grip.vy", "grip.vz", "grip.wx", "grip.wy", "grip.wz"
        ]
    );
    let quaternions: Vec<usize> = chain.quaternions().iter().map(|q| q.1).collect();
    assert_eq!(quaternions, [4, 12, 20]);
    // Neutral: each at its origin, unturned; the sampler keeps each quaternion unit.
    let q = chain.neutral();
    assert_eq!(q[1..8], [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
    for q in chain.random_configurations(5, 3, (-1.0, 1.0)).chunks(24) {
        kinechain::check_q(&chain, q, LimitPolicy::Enforce).unwrap();
    }
    // With a floating base, the base is the first joint and the others follow.
    let (floating, _) = scenes().remove(1);
    assert_eq!(floating.joints()[0].name(), "root_joint");
    assert!(floating.floating_joint().is_some());
    assert_eq!((floating.nq(), floating.nv()), (31, 27));
}

#[test]
fn poses_are_the_product_of_the_joints_own_transforms() {
    let chain = scene();
    let mut r = rng(3);
    let t = |xyz: [f64; 3], rpy: [f64; 3]| Transform::from_xyz_rpy(xyz, rpy);
    let free =
        |q: &[f64]| Transform::from_parts(&rotation(&q[3..7]), &Vector3::new(q[0], q[1], q[2]));
    for _ in 0..20 {
        let mut q = random_q(&chain, &mut r);
        // A quaternion scaled off unit length, as logs store them: the same rotation.
        for x in &mut q[12..16] {
            *x *= 1.0 - 3e-4;
        }
        let got = link_poses(&chain, &q);
        let base = t([0.0, 0.0, 0.1], [0.0; 3]);
        let upper = base * t([0.0, 0.0, 0.3], [0.1, 0.0, 0.0]) * Transform::rot_z(q[0]);
        let carried = upper * t([0.1, 0.2, 0.4], [0.3, 0.2, 0.1]) * free(&q[1..8]);
        let tip = carried * t([0.0, 0.0, 0.2], [0.0; 3]) * Transform::rot_y(q[8]);
        let boxed = t([1.0, 0.0, 0.0], [0.0, 0.0, 0.5]) * free(&q[9..16]);
        let lid = boxed * t([0.0, 0.1, 0.05], [0.0; 3]) * Transform::rot_x(q[16]);
        let ball = free(&q[17..24]);
        for (name, want) in [
            ("base", base),
            ("upper", upper),
            ("carried", carried),
            ("tip", tip),
            ("box", boxed),
            ("lid", lid),
            ("ball", ball),
        ] {
            let i = chain.link_id(name).unwrap().index();
            let err = (got[i].to_homogeneous() - want.to_homogeneous())
                .abs()
                .max();
            assert!(err < 2e-15, "{name}: {err:e}");
        }
    }
}

#[test]
fn rates_are_the_time_derivatives_of_poses_along_q_dot() {
    for (chain, label) in scenes() {
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut r = rng(5);
        let h = 1e-5;
        let ids: Vec<_> = chain
            .links()
            .iter()
            .map(|l| chain.link_id(l.name()).unwrap())
            .collect();
        for _ in 0..8 {
            let q = random_q(&chain, &mut r);
            let qd = random_vec(chain.nv(), 1.0, &mut r);
            let qdd = random_vec(chain.nv(), 1.0, &mut r);
            let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
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
                assert!(
                    (v_fd - vel.v).norm() < 1e-8,
                    "{label} link {i}: v {v_fd} {}",
                    vel.v
                );
                let r_dot = (after[i].rotation() - before[i].rotation()) / (2.0 * h);
                let w = r_dot * now[i].rotation().transpose();
                let omega_fd = Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
                assert!((omega_fd - vel.omega).norm() < 1e-8, "{label} link {i}: ω");
                let a_fd = (v_after[i].v - v_before[i].v) / (2.0 * h);
                assert!(
                    (a_fd - accel.a).norm() < 1e-7,
                    "{label} link {i}: a {a_fd} {}",
                    accel.a
                );
                let alpha_fd = (v_after[i].omega - v_before[i].omega) / (2.0 * h);
                assert!(
                    (alpha_fd - accel.alpha).norm() < 1e-7,
                    "{label} link {i}: α"
                );
            }
        }
    }
    // Relative to its parent at its q̇ (world axes): the carried link against the upper arm.
    let chain = scene();
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let mut r = rng(6);
    let q = random_q(&chain, &mut r);
    let qd = random_vec(chain.nv(), 1.0, &mut r);
    let v = forward_velocities(&chain, &mut data, &q, &qd).unwrap();
    let (upper, carried) = (
        chain.link_id("upper").unwrap(),
        chain.link_id("carried").unwrap(),
    );
    let relative = v.velocity(carried).omega - v.velocity(upper).omega;
    assert!((relative - Vector3::new(qd[4], qd[5], qd[6])).norm() < 1e-15);
    // A free body hanging from the world moves at its own q̇.
    let ball = v.velocity(chain.link_id("ball").unwrap());
    assert_eq!(ball.v, Vector3::new(qd[15], qd[16], qd[17]));
    assert_eq!(ball.omega, Vector3::new(qd[18], qd[19], qd[20]));
}

#[test]
fn jacobians_map_q_dot_to_link_velocities_with_six_columns_a_floating_joint() {
    for (chain, label) in scenes() {
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut r = rng(8);
        let grip = chain
            .joint(chain.joint_id("grip").unwrap())
            .v_index()
            .unwrap();
        for _ in 0..8 {
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
            // The grip's slides on the tip: along the world axes; its turns: about them.
            let tip = chain.link_id("tip").unwrap();
            let j = acc.poses().jacobian(tip);
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = 1.0;
                assert_eq!(j.fixed_view::<3, 1>(0, grip + k).into_owned(), e);
                assert_eq!(
                    j.fixed_view::<3, 1>(3, grip + k).into_owned(),
                    Vector3::zeros()
                );
                assert_eq!(j.fixed_view::<3, 1>(3, grip + 3 + k).into_owned(), e);
            }
            // Nothing of another body's joints moves the tip.
            let ball = chain
                .joint(chain.joint_id("ball_free").unwrap())
                .v_index()
                .unwrap();
            assert!(j.columns(ball, 6).iter().all(|&x| x == 0.0));
        }
    }
}

#[test]
fn batches_equal_single_evaluations_bit_for_bit() {
    for (chain, label) in scenes() {
        crate::common::assert_batches_equal_single(&chain, label);
    }
}

#[test]
fn every_single_evaluation_mode_gives_the_full_evaluations_bits() {
    use kinechain::{forward_kinematics_incremental, forward_kinematics_to};
    let chain = scene();
    let mut r = rng(34);
    let (mut inc, mut one) = (Data::new(&chain), Data::new(&chain));
    for d in [&mut inc, &mut one] {
        d.set_limit_policy(LimitPolicy::Ignore);
    }
    let mut q = random_q(&chain, &mut r);
    for step in 0..30 {
        // Move the grip's position, the box's quaternion, a revolute joint, or everything.
        let next = random_q(&chain, &mut r);
        match step % 4 {
            0 => q[1..4].copy_from_slice(&next[1..4]),
            1 => q[12..16].copy_from_slice(&next[12..16]),
            2 => q[8] = next[8],
            _ => q.copy_from_slice(&next),
        }
        let want = link_poses(&chain, &q);
        let got = forward_kinematics_incremental(&chain, &mut inc, &q).unwrap();
        for (l, w) in chain.links().iter().zip(&want) {
            let id = chain.link_id(l.name()).unwrap();
            assert_eq!(got.world_from_link(id), *w, "step {step} {}", l.name());
            let alone = forward_kinematics_to(&chain, &mut one, &q, id).unwrap();
            assert_eq!(alone, *w, "step {step} {} alone", l.name());
        }
    }
}

#[cfg(feature = "reference")]
#[test]
fn floating_joints_are_within_a_few_ulps_of_the_256_bit_evaluation() {
    for (chain, label) in scenes() {
        crate::common::assert_within_8_ulp_of_the_256_bit_evaluation(&chain, label);
    }
}

#[test]
fn joint_vectors_go_to_other_layouts_and_back() {
    use kinechain::eval::layouts::Layout;
    for (chain, label) in scenes() {
        let mut r = rng(12);
        let q = random_q(&chain, &mut r);
        let qd = random_vec(chain.nv(), 1.0, &mut r);
        let qdd = random_vec(chain.nv(), 1.0, &mut r);
        let mujoco =
            crate::common::assert_layout_round_trip(&chain, Layout::Mujoco, (&q, &qd, &qdd), label);
        let pin = crate::common::assert_layout_round_trip(
            &chain,
            Layout::Pinocchio,
            (&q, &qd, &qdd),
            label,
        );
        // The ball hangs from the world: MuJoCo keeps its world velocity and gives its angular
        // velocity in its own axes; Pinocchio gives both in its own axes.
        let (ball_q, ball_v) = {
            let j = chain.joint(chain.joint_id("ball_free").unwrap());
            (j.q_index().unwrap(), j.v_index().unwrap())
        };
        let r_ball = link_poses(&chain, &q)[chain.link_id("ball").unwrap().index()].rotation();
        let w = Vector3::new(qd[ball_v + 3], qd[ball_v + 4], qd[ball_v + 5]);
        let v = Vector3::new(qd[ball_v], qd[ball_v + 1], qd[ball_v + 2]);
        let mq = mujoco.q_dot.as_ref().unwrap();
        let mv = &mq[mq.len() - 6..];
        assert!(
            (Vector3::new(mv[0], mv[1], mv[2]) - v).norm() < 1e-15,
            "{label}"
        );
        assert!(
            (Vector3::new(mv[3], mv[4], mv[5]) - r_ball.transpose() * w).norm() < 1e-14,
            "{label}"
        );
        // Pinocchio lists a link's child joints by name (the ball before the box): its
        // quaternion as x y z w somewhere in Pinocchio's q.
        let want = [q[ball_q + 4], q[ball_q + 5], q[ball_q + 6], q[ball_q + 3]];
        assert!(pin.q.windows(4).any(|w| w == want), "{label}");
    }
}

#[test]
fn two_floating_joints_in_a_row_are_refused_and_a_floating_base_on_a_floating_robot_too() {
    let in_a_row = r#"<robot name="r"><link name="a"/><link name="b"/><link name="c"/><link name="d"/>
      <joint name="f1" type="floating"><parent link="a"/><child link="b"/></joint>
      <joint name="weld" type="fixed"><parent link="b"/><child link="c"/></joint>
      <joint name="f2" type="floating"><parent link="c"/><child link="d"/></joint></robot>"#;
    let e = kinechain::error::error_chain(&Chain::from_urdf_str(in_a_row).unwrap_err());
    assert!(
        e.contains("floating joint 'f2'") && e.contains("below floating joint 'f1'"),
        "{e}"
    );
    let floats = r#"<robot name="r"><link name="w"/><link name="b"/>
      <joint name="free" type="floating"><parent link="w"/><child link="b"/></joint></robot>"#;
    let mut b = Chain::from_urdf_str(floats).unwrap().description().clone();
    let e = b.floating_base().build().unwrap_err().to_string();
    assert!(e.contains("two floating joints in a row"), "{e}");
    // A revolute joint between them: both float, each relative to its parent.
    let apart = in_a_row.replace(r#"type="fixed""#, r#"type="continuous""#);
    let chain = Chain::from_urdf_str(&apart).unwrap();
    assert_eq!((chain.nq(), chain.nv()), (15, 13));
    let q = chain.neutral();
    let mut d = Data::new(&chain);
    forward_kinematics(&chain, &mut d, &q).unwrap();
}

/// The MJCF pick scene: two arms and ten free boxes.
fn pick() -> Chain {
    Chain::from_file(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mjcf/scene/pick.xml"),
    )
    .unwrap()
}

#[test]
fn one_link_evaluations_of_a_scene_equal_the_full_ones_bit_for_bit() {
    use kinechain::eval::batch::{
        BatchData, forward_kinematics_batch_to, forward_kinematics_batch_to_par, single_precision,
    };
    let chain = pick();
    let mut r = rng(40);
    let n = 3000;
    let qs: Vec<f64> = (0..n).flat_map(|_| random_q(&chain, &mut r)).collect();
    let mut full = Data::new(&chain);
    let mut one = Data::new(&chain);
    let mut batch = BatchData::new(&chain);
    let mut batch32 = single_precision::BatchData::new(&chain);
    for d in [&mut full, &mut one] {
        d.set_limit_policy(LimitPolicy::Ignore);
    }
    batch.set_limit_policy(LimitPolicy::Ignore);
    batch32.set_limit_policy(LimitPolicy::Ignore);
    let all32 = single_precision::forward_kinematics_batch(&chain, &mut batch32, &qs).unwrap();
    let all32: Vec<Vec<Transform>> = (0..n)
        .map(|i| {
            chain
                .links()
                .iter()
                .map(|l| all32.world_from_link(i, chain.link_id(l.name()).unwrap()))
                .collect()
        })
        .collect();
    for link in [
        "left/hand",
        "right/wrist_3_link",
        "top_07",
        "box_09",
        "table_top",
    ] {
        let id = chain.link_id(link).unwrap();
        let b = forward_kinematics_batch_to(&chain, &mut batch, &qs, id).unwrap();
        let got: Vec<Transform> = (0..n).map(|i| b.world_from_link(i)).collect();
        let p = forward_kinematics_batch_to_par(&chain, &mut batch, &qs, id).unwrap();
        let got_par: Vec<Transform> = (0..n).map(|i| p.world_from_link(i)).collect();
        let f =
            single_precision::forward_kinematics_batch_to(&chain, &mut batch32, &qs, id).unwrap();
        for (i, q) in qs.chunks(chain.nq()).enumerate() {
            let want = forward_kinematics(&chain, &mut full, q)
                .unwrap()
                .world_from_link(id);
            assert_eq!(
                kinechain::forward_kinematics_to(&chain, &mut one, q, id).unwrap(),
                want,
                "{link} {i}"
            );
            assert_eq!(got[i], want, "{link} batch {i}");
            assert_eq!(got_par[i], want, "{link} parallel batch {i}");
            assert_eq!(
                f.world_from_link(i),
                all32[i][id.index()],
                "{link} f32 batch {i}"
            );
        }
    }
}

#[test]
fn a_one_link_evaluation_checks_the_span_of_q_its_path_reads() {
    use kinechain::StateError;
    use kinechain::eval::batch::{BatchData, forward_kinematics_batch_to, single_precision};
    let chain = pick();
    let hand = chain.link_id("left/hand").unwrap();
    let top = chain.link_id("top_07").unwrap();
    let box_entry = chain
        .joint(chain.joint_id("box_07").unwrap())
        .q_index()
        .unwrap();
    let mut q = chain.keyframes()[0].1.clone();
    let mut data = Data::new(&chain);
    // A box's quaternion at zero: the Panda's hand is evaluated, the box and all links refused.
    q[box_entry + 3..box_entry + 7].fill(0.0);
    kinechain::forward_kinematics_to(&chain, &mut data, &q, hand).unwrap();
    assert!(matches!(
        kinechain::forward_kinematics_to(&chain, &mut data, &q, top),
        Err(StateError::BadQuaternion { .. })
    ));
    assert!(forward_kinematics(&chain, &mut data, &q).is_err());
    let qs: Vec<f64> = [q.clone(), chain.keyframes()[0].1.clone()].concat();
    let mut batch = BatchData::new(&chain);
    forward_kinematics_batch_to(&chain, &mut batch, &qs, hand).unwrap();
    let e = forward_kinematics_batch_to(&chain, &mut batch, &qs, top).unwrap_err();
    assert_eq!(e.index, 0);
    let mut batch32 = single_precision::BatchData::new(&chain);
    single_precision::forward_kinematics_batch_to(&chain, &mut batch32, &qs, hand).unwrap();
    assert!(single_precision::forward_kinematics_batch_to(&chain, &mut batch32, &qs, top).is_err());
    // Within the hand's span: an entry out of its limits, a NaN, named in the error as
    // `check_q` names them; the wrong length, whatever the link.
    let mut q = chain.keyframes()[0].1.clone();
    q[3] = 1.0; // joint4's limits are [-3.0718, -0.0698]
    let e = kinechain::forward_kinematics_to(&chain, &mut data, &q, hand).unwrap_err();
    assert!(e.to_string().contains("left/joint4"), "{e}");
    let qs: Vec<f64> = [chain.keyframes()[0].1.clone(), q.clone()].concat();
    let e = forward_kinematics_batch_to(&chain, &mut batch, &qs, hand).unwrap_err();
    assert_eq!(e.index, 1);
    let e = kinechain::error::error_chain(&e);
    assert!(e.contains("left/joint4"), "{e}");
    q[3] = f64::NAN;
    assert!(matches!(
        kinechain::forward_kinematics_to(&chain, &mut data, &q, hand),
        Err(StateError::NonFinite { index: 3, .. })
    ));
    assert!(matches!(
        kinechain::forward_kinematics_to(&chain, &mut data, &q[1..], top),
        Err(StateError::WrongLengthParts { .. })
    ));
}
