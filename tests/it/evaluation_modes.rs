//! The evaluation modes agree bit for bit: one link (only the joints on its path), incremental
//! (only the joints whose inputs changed), and full evaluation.

use crate::common::*;
use kinechain::{
    Chain, Data, LimitPolicy, Poses, Transform, forward_accelerations, forward_kinematics,
    forward_kinematics_incremental, forward_kinematics_to, forward_velocities,
};

fn chains() -> Vec<Chain> {
    let mut out: Vec<Chain> = [
        "puma560.yaml",
        "panda.urdf",
        "cylindrical.yaml",
        "snake50.yaml",
        "stanford.yaml",
    ]
    .iter()
    .map(|f| Chain::from_file(robots_dir().join(f)).unwrap())
    .collect();
    // A tree with fixed frames, a prismatic torso and two branches.
    out.push(Chain::from_file(reference_dir().join("urdf/tiago_no_hand.urdf")).unwrap());
    out
}

/// A buffer for `chain` that does not check limits (random configurations may leave them).
fn unchecked(chain: &Chain) -> Data {
    Data::new(chain).with_limit_policy(LimitPolicy::Ignore)
}

/// Every link's pose, in the chain's link order.
fn link_poses(chain: &Chain, poses: &Poses) -> Vec<Transform> {
    chain
        .links()
        .iter()
        .map(|l| poses.world_from_link(chain.link_id(l.name()).unwrap()))
        .collect()
}

#[test]
fn one_link_equals_the_full_evaluation() {
    let mut rng = rng(11);
    for chain in chains() {
        let (mut full, mut partial) = (unchecked(&chain), unchecked(&chain));
        for _ in 0..10 {
            let q = random_q(&chain, &mut rng);
            let poses = forward_kinematics(&chain, &mut full, &q).unwrap();
            for (i, link) in chain.links().iter().enumerate() {
                let id = chain.link_id(link.name()).unwrap();
                assert_eq!(id.index(), i);
                let one = forward_kinematics_to(&chain, &mut partial, &q, id).unwrap();
                assert_eq!(
                    one,
                    poses.world_from_link(id),
                    "{} {}",
                    chain.name(),
                    link.name()
                );
            }
        }
    }
}

#[test]
fn incremental_updates_equal_fresh_evaluations() {
    let mut rng = rng(12);
    for chain in chains() {
        let (mut fresh, mut inc) = (unchecked(&chain), unchecked(&chain));
        let mut q = random_q(&chain, &mut rng);
        for step in 0..200 {
            // Change one entry, sometimes several, sometimes none.
            if chain.dof() > 0 && step % 7 != 0 {
                let i = step * 31 % chain.dof();
                q[i] += 0.01 * (step as f64).sin();
            }
            if step % 13 == 0 {
                q = random_q(&chain, &mut rng);
            }
            let a = forward_kinematics_incremental(&chain, &mut inc, &q).unwrap();
            let a = link_poses(&chain, &a);
            let b = forward_kinematics(&chain, &mut fresh, &q).unwrap();
            for (pose, fresh_pose) in a.iter().zip(link_poses(&chain, &b)) {
                assert_eq!(*pose, fresh_pose, "{} step {step}", chain.name());
            }
        }
    }
}

#[test]
fn an_incremental_update_back_to_the_previous_configuration_restores_its_poses() {
    // Each entry moved and moved back: the second update must see the entry change again (the
    // record of the last evaluation's q follows every update, whichever path evaluated it).
    let mut rng = rng(13);
    for chain in chains() {
        let (mut fresh, mut inc) = (unchecked(&chain), unchecked(&chain));
        let q0 = random_q(&chain, &mut rng);
        forward_kinematics_incremental(&chain, &mut inc, &q0).unwrap();
        for i in 0..chain.dof() {
            let mut q1 = q0.clone();
            q1[i] += 0.25;
            forward_kinematics_incremental(&chain, &mut inc, &q1).unwrap();
            let back = forward_kinematics_incremental(&chain, &mut inc, &q0).unwrap();
            let back = link_poses(&chain, &back);
            let full = forward_kinematics(&chain, &mut fresh, &q0).unwrap();
            for ((pose, full_pose), link) in back
                .iter()
                .zip(link_poses(&chain, &full))
                .zip(chain.links())
            {
                assert_eq!(
                    *pose,
                    full_pose,
                    "{} entry {i} link {}",
                    chain.name(),
                    link.name()
                );
            }
        }
    }
}

#[test]
fn changes_with_equal_bit_patterns_are_seen_wherever_they_are() {
    // The unchanged head is skipped by comparing bits four entries at a time: entries moved
    // from zero (the home pose), or several moved alike from one value, have changes with equal
    // (or no common) bits, which a careless combination of the comparisons cancels out.
    for chain in chains() {
        let (mut fresh, mut inc) = (unchecked(&chain), unchecked(&chain));
        let n = chain.dof().min(12);
        for from in [0.0, 0.1] {
            let q0 = vec![from; chain.dof()];
            for i in 0..n {
                for j in i..n {
                    forward_kinematics_incremental(&chain, &mut inc, &q0).unwrap();
                    let mut q1 = q0.clone();
                    (q1[i], q1[j]) = (0.3, 0.3);
                    let moved = forward_kinematics_incremental(&chain, &mut inc, &q1).unwrap();
                    let moved = link_poses(&chain, &moved);
                    let full = forward_kinematics(&chain, &mut fresh, &q1).unwrap();
                    assert_eq!(
                        moved,
                        link_poses(&chain, &full),
                        "{} from {from}, entries {i} and {j}",
                        chain.name()
                    );
                }
            }
        }
    }
}

#[test]
fn a_partial_evaluation_does_not_leave_stale_poses_for_incremental_use() {
    let chain = Chain::from_file(robots_dir().join("puma560.yaml")).unwrap();
    let mut data = Data::new(&chain);
    let tool = chain.link_id("tool").unwrap();
    let link2 = chain.link_id("link2").unwrap();
    let q0 = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
    let q1 = [0.2, 0.3, 0.3, 0.4, 0.5, 0.6];
    forward_kinematics_incremental(&chain, &mut data, &q0).unwrap();
    // Moves only the path to link2 to q1.
    forward_kinematics_to(&chain, &mut data, &q1, link2).unwrap();
    let inc = forward_kinematics_incremental(&chain, &mut data, &q1)
        .unwrap()
        .world_from_link(tool);
    let mut fresh = Data::new(&chain);
    let full = forward_kinematics(&chain, &mut fresh, &q1)
        .unwrap()
        .world_from_link(tool);
    assert_eq!(inc, full);
}

#[test]
fn incremental_updates_check_what_changed_and_respect_a_new_limit_policy() {
    use kinechain::StateError;
    let chain = Chain::from_file(robots_dir().join("puma560.yaml")).unwrap();
    let mut data = Data::new(&chain);
    let q = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
    forward_kinematics_incremental(&chain, &mut data, &q).unwrap();
    // A changed entry that is not finite, or out of its limits, is reported by index and joint.
    let mut bad = q;
    bad[4] = f64::NAN;
    let err = forward_kinematics_incremental(&chain, &mut data, &bad).unwrap_err();
    assert!(
        matches!(err, StateError::NonFinite { index: 4, .. }),
        "{err}"
    );
    bad[4] = 100.0;
    let err = forward_kinematics_incremental(&chain, &mut data, &bad).unwrap_err();
    assert!(matches!(err, StateError::OutOfLimits { .. }), "{err}");
    assert!(err.to_string().contains(chain.joints()[4].name()), "{err}");
    // The wrong length is still an error.
    let err = forward_kinematics_incremental(&chain, &mut data, &q[..5]).unwrap_err();
    assert!(matches!(err, StateError::WrongLength { .. }), "{err}");
    // Accepted while limits are ignored; the same q is checked again once they are enforced.
    data.set_limit_policy(LimitPolicy::Ignore);
    forward_kinematics_incremental(&chain, &mut data, &bad).unwrap();
    data.set_limit_policy(LimitPolicy::Enforce);
    let err = forward_kinematics_incremental(&chain, &mut data, &bad).unwrap_err();
    assert!(matches!(err, StateError::OutOfLimits { .. }), "{err}");
}

#[test]
fn limits_checked_apart_from_the_kernels_give_the_same_results() {
    // Under `Enforce` the limits of this chain are checked on their own before evaluating; under
    // `Ignore` only finiteness is, inside the kernels. Both evaluate the same numbers.
    let chain = Chain::from_urdf_str(MIMIC_GRIPPER).unwrap();
    let (q, qd, qdd) = ([0.7, -0.4, 0.02], [0.3, -1.1, 0.05], [-0.8, 0.6, -0.2]);
    let mut enforced = Data::new(&chain);
    let mut ignored = unchecked(&chain);
    let a = forward_accelerations(&chain, &mut enforced, &q, &qd, &qdd).unwrap();
    let b = forward_accelerations(&chain, &mut ignored, &q, &qd, &qdd).unwrap();
    for link in chain.links() {
        let id = chain.link_id(link.name()).unwrap();
        let name = link.name();
        assert_eq!(a.world_from_link(id), b.world_from_link(id), "{name}");
        assert_eq!(a.velocity(id), b.velocity(id), "{name}");
        assert_eq!(a.acceleration(id), b.acceleration(id), "{name}");
    }
    // The right finger moves against the left one: its slide is 0.01 − q₂ along the same axis.
    let (left, right) = (
        chain.link_id("left").unwrap(),
        chain.link_id("right").unwrap(),
    );
    let gap = a.world_from_link(left).translation() - a.world_from_link(right).translation();
    let axis = a.world_from_link(left).rotation() * nalgebra::Vector3::y();
    assert!((gap - (2.0 * q[2] - 0.01) * axis).amax() < 1e-16, "{gap}");
    let closing = a.velocity(left).v - a.velocity(right).v;
    let omega = a.velocity(left).omega;
    let want = 2.0 * qd[2] * axis + omega.cross(&gap);
    assert!((closing - want).amax() < 1e-15, "{closing} {want}");
    let palm = chain.link_id("palm").unwrap();
    for id in [palm, left, right] {
        // (In buffers of their own: `enforced` holds these velocities from the call above.)
        let (va, vb) = (
            forward_velocities(&chain, &mut Data::new(&chain), &q, &qd)
                .unwrap()
                .velocity(id),
            forward_velocities(&chain, &mut unchecked(&chain), &q, &qd)
                .unwrap()
                .velocity(id),
        );
        assert_eq!(va, vb);
        let (pa, pb) = (
            forward_kinematics_to(&chain, &mut enforced, &q, id).unwrap(),
            forward_kinematics_to(&chain, &mut ignored, &q, id).unwrap(),
        );
        assert_eq!(pa, pb);
        let full = forward_kinematics(&chain, &mut enforced, &q).unwrap();
        assert_eq!(full.world_from_link(id), pb);
    }
    // And the limits are enforced: the mimic finger leaves [−0.04, 0] when q₂ < 0.01.
    let err = forward_velocities(&chain, &mut enforced, &[0.7, -0.4, 0.005], &qd).unwrap_err();
    assert!(err.to_string().contains("right"), "{err}");
    forward_velocities(&chain, &mut ignored, &[0.7, -0.4, 0.005], &qd).unwrap();
}

#[test]
fn every_level_gives_the_same_poses() {
    let mut rng = rng(13);
    for chain in chains() {
        let mut data = unchecked(&chain);
        let q = random_q(&chain, &mut rng);
        let qd = random_vec(chain.dof(), 1.0, &mut rng);
        let qdd = random_vec(chain.dof(), 1.0, &mut rng);
        let poses = link_poses(&chain, &forward_kinematics(&chain, &mut data, &q).unwrap());
        let vel: Vec<_> = {
            let v = forward_velocities(&chain, &mut data, &q, &qd).unwrap();
            chain
                .links()
                .iter()
                .map(|l| {
                    let id = chain.link_id(l.name()).unwrap();
                    (v.world_from_link(id), v.velocity(id))
                })
                .collect()
        };
        let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
        for (i, l) in chain.links().iter().enumerate() {
            let id = chain.link_id(l.name()).unwrap();
            assert_eq!(poses[i], vel[i].0);
            assert_eq!(poses[i], acc.world_from_link(id));
            assert_eq!(vel[i].1, acc.velocity(id));
        }
    }
}

/// Fixed joints are folded into their neighbours when the chain is built: an arm with four fixed
/// frames between each pair of joints (and after the last) compiles to one body per moving joint,
/// the units the evaluation works in, like the same arm without them; every fixed frame is where
/// the product of the placements from the base puts it, and reading it is the only work it adds.
#[test]
fn fixed_frames_are_folded_at_load_time() {
    use kinechain::{ChainBuilder, JointKind, JointSpec};
    let placement = |i: usize| {
        let x = i as f64;
        Transform::from_xyz_rpy(
            [0.1 + 0.01 * x, -0.02 * x, 0.05],
            [0.3 - 0.1 * x, 0.2, 0.05 * x],
        )
    };
    // A joint from the last link added to a new one (the axis is ignored for fixed joints).
    fn attach(
        builder: &mut ChainBuilder,
        parent: &mut String,
        kind: JointKind,
        (joint, child): (String, String),
        origin: Transform,
    ) {
        builder.link(child.clone()).joint(
            JointSpec::new(joint, kind, parent.clone(), child.clone())
                .with_origin(origin)
                .with_axis([0.0, 1.0, 1.0]),
        );
        *parent = child;
    }
    let mut builder = ChainBuilder::new("folded");
    builder.link("base");
    let mut parent = "base".to_string();
    let mut fixed = Vec::new();
    for j in 0..3 {
        let names = (format!("j{j}"), format!("link{j}"));
        attach(
            &mut builder,
            &mut parent,
            JointKind::Continuous,
            names,
            placement(j),
        );
        for f in 0..4 {
            let i = 10 + 4 * j + f;
            let names = (format!("fixed{j}_{f}"), format!("frame{j}_{f}"));
            attach(
                &mut builder,
                &mut parent,
                JointKind::Fixed,
                names,
                placement(i),
            );
            fixed.push((parent.clone(), i));
        }
    }
    let chain = builder.build().unwrap();
    assert_eq!(chain.joints().len(), 15);
    assert_eq!(chain.moving_joint_count(), 3);
    let q = [0.4, -1.1, 2.0];
    let mut data = Data::new(&chain);
    let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
    // The product of the placements and joint motions from the base, in the order of the file.
    let mut expected = Transform::IDENTITY;
    let axis = nalgebra::Unit::new_normalize(nalgebra::Vector3::new(0.0, 1.0, 1.0));
    for (j, &angle) in q.iter().enumerate() {
        let turn = nalgebra::Rotation3::from_axis_angle(&axis, angle);
        let motion = Transform::from_parts(turn.matrix(), &nalgebra::Vector3::zeros());
        expected = expected * placement(j) * motion;
        assert_close(
            &poses.world_from_link(chain.link_id(&format!("link{j}")).unwrap()),
            &expected,
        );
        for (name, i) in fixed
            .iter()
            .filter(|(n, _)| n.starts_with(&format!("frame{j}_")))
        {
            expected = expected * placement(*i);
            assert_close(
                &poses.world_from_link(chain.link_id(name).unwrap()),
                &expected,
            );
        }
    }
}

/// Entry by entry within 2e-15, about eight ulps of the entries near 1 (the fold multiplies the
/// placements in another order than the product above; the largest difference is 4.4e-16).
fn assert_close(got: &Transform, want: &Transform) {
    let (g, w) = (got.to_rows(), want.to_rows());
    for (rg, rw) in g.iter().zip(&w) {
        for (a, b) in rg.iter().zip(rw) {
            assert!((a - b).abs() <= 2e-15, "{g:?}\nwant {w:?}");
        }
    }
}

/// `write_matrices` holds each link's `world_from_link(..).to_rows()` bit for bit, for every
/// link of every bundled robot and reference model (links fixed to the world included), in any
/// order and with repeats; a buffer of another length is refused.
#[test]
fn written_matrices_are_the_poses_bit_for_bit() {
    let mut rng = rng(23);
    for (name, chain) in all_models() {
        let mut data = unchecked(&chain);
        let mut ids = link_ids(&chain);
        ids.reverse();
        ids.push(ids[0]);
        let mut out = vec![f64::NAN; 16 * ids.len()];
        for _ in 0..3 {
            let q = random_q(&chain, &mut rng);
            let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
            poses.write_matrices(&ids, &mut out).unwrap();
            for (k, &id) in ids.iter().enumerate() {
                let rows = poses.world_from_link(id).to_rows().concat();
                let bits = |m: &[f64]| m.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(&out[16 * k..16 * k + 16]),
                    bits(&rows),
                    "{name} link {k}"
                );
            }
            assert!(poses.write_matrices(&ids, &mut out[..16]).is_err());
        }
    }
}
