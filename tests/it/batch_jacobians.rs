//! Jacobians in every frame, single and batched: batched equal single bit for bit; `J q̇` and
//! `J q̈ + J̇ q̇` give the velocities and accelerations of the recursion; `J̇` is the finite
//! difference of batched `J`; the batched world Jacobian agrees with the `k` crate's.

use crate::common::*;
use kinechain::eval::batch::{
    BatchData, jacobian_batch, jacobian_batch_par, jacobian_dot_batch, jacobian_dot_batch_par,
};
use kinechain::nalgebra::{DVector, Matrix6xX, Vector3, Vector6};
use kinechain::{
    Chain, Data, JacobianFrame, LimitPolicy, StateError, forward_accelerations, forward_velocities,
};

const FRAMES: [JacobianFrame; 3] = [
    JacobianFrame::World,
    JacobianFrame::Link,
    JacobianFrame::Point([0.05, -0.02, 0.1]),
];

fn samples(chain: &Chain, n: usize, seed: u64) -> [Vec<f64>; 3] {
    let mut rng = rng(seed);
    let qs = (0..n).flat_map(|_| random_q(chain, &mut rng)).collect();
    let qds = random_vec(n * chain.dof(), 2.0, &mut rng);
    let qdds = random_vec(n * chain.dof(), 5.0, &mut rng);
    [qs, qds, qdds]
}

/// Configuration `i`'s matrix of a batch's output.
fn matrix(out: &[f64], i: usize, dof: usize) -> Matrix6xX<f64> {
    Matrix6xX::from_row_slice(&out[6 * dof * i..6 * dof * (i + 1)])
}

#[test]
fn batched_jacobians_equal_single_ones_bit_for_bit() {
    for (file, chain) in all_models() {
        let dof = chain.dof();
        if dof == 0 {
            continue;
        }
        let n = 37;
        let [qs, qds, _] = samples(&chain, n, 3);
        let mut single = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut batch = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut j = vec![0.0; n * 6 * dof];
        let mut j_dot = vec![0.0; n * 6 * dof];
        for link in link_ids(&chain) {
            for frame in FRAMES {
                jacobian_batch(&chain, &mut batch, &qs, link, frame, &mut j).unwrap();
                jacobian_dot_batch(&chain, &mut batch, &qs, &qds, link, frame, &mut j_dot).unwrap();
                for i in 0..n {
                    let rows = i * dof..(i + 1) * dof;
                    let vel =
                        forward_velocities(&chain, &mut single, &qs[rows.clone()], &qds[rows])
                            .unwrap();
                    assert_eq!(
                        matrix(&j, i, dof),
                        vel.poses().jacobian_in(link, frame),
                        "{file} {link:?} {frame:?} {i}"
                    );
                    assert_eq!(
                        matrix(&j_dot, i, dof),
                        vel.jacobian_dot_in(link, frame),
                        "{file} {link:?} {frame:?} {i} J̇"
                    );
                }
            }
        }
    }
}

/// The parallel batches (pieces of 512 configurations on the pool) equal the one-thread ones.
#[test]
fn parallel_jacobian_batches_equal_one_thread() {
    for file in ["robots/panda.urdf", "robots/cylindrical.yaml"] {
        let chain = repo_chain(file);
        let dof = chain.dof();
        let n = 1300;
        let [qs, qds, _] = samples(&chain, n, 5);
        let mut data = BatchData::new(&chain);
        let link = chain.end_link();
        let (mut a, mut b) = (vec![0.0; n * 6 * dof], vec![1.0; n * 6 * dof]);
        for frame in FRAMES {
            jacobian_batch(&chain, &mut data, &qs, link, frame, &mut a).unwrap();
            jacobian_batch_par(&chain, &mut data, &qs, link, frame, &mut b).unwrap();
            assert_eq!(a, b, "{file} {frame:?}");
            jacobian_dot_batch(&chain, &mut data, &qs, &qds, link, frame, &mut a).unwrap();
            jacobian_dot_batch_par(&chain, &mut data, &qs, &qds, link, frame, &mut b).unwrap();
            assert_eq!(a, b, "{file} {frame:?} J̇");
        }
        // The first bad configuration is named, wherever its piece runs.
        let mut bad = qs.clone();
        bad[1100 * dof + dof - 1] = f64::NAN;
        bad[1250 * dof] = f64::INFINITY;
        let e = jacobian_batch_par(&chain, &mut data, &bad, link, FRAMES[0], &mut b).unwrap_err();
        assert_eq!(e.index, 1100);
        let mut bad_qd = qds.clone();
        bad_qd[900 * dof + dof - 1] = f64::NAN;
        let e = jacobian_dot_batch_par(&chain, &mut data, &qs, &bad_qd, link, FRAMES[0], &mut b)
            .unwrap_err();
        assert_eq!(e.index, 900, "{file} {e:?}");
        assert!(
            matches!(e.source, StateError::NonFinite { what: "q_dot", index, .. } if index == dof - 1)
        );
    }
}

/// `J q̇` is the frame's velocity and `J q̈ + J̇ q̇` its acceleration, as the recursion gives them:
/// the link origin's in world axes; in link axes `v̄ = Aᵀ v`, `ω̄ = Aᵀ ω` and their time
/// derivatives `Aᵀ (a − ω × v)`, `Aᵀ α`; and a point's.
#[test]
fn jacobians_give_the_recursions_velocities_and_accelerations() {
    for (file, chain) in all_models() {
        let dof = chain.dof();
        if dof == 0 {
            continue;
        }
        let [qs, qds, qdds] = samples(&chain, 4, 17);
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let scale = 1.0 + chain.reach();
        for i in 0..4 {
            let rows = i * dof..(i + 1) * dof;
            let (q, qd, qdd) = (&qs[rows.clone()], &qds[rows.clone()], &qdds[rows]);
            let acc = forward_accelerations(&chain, &mut data, q, qd, qdd).unwrap();
            let expected: Vec<(JacobianFrame, LinkId, Vector6<f64>, Vector6<f64>)> =
                link_ids(&chain)
                    .into_iter()
                    .flat_map(|l| {
                        let (v, a) = (acc.velocity(l), acc.acceleration(l));
                        let rt = acc.world_from_link(l).rotation().transpose();
                        let u = Vector3::from(FRAMES[2].point());
                        let p = acc.point(l, &u);
                        let six = |lin: Vector3<f64>, ang: Vector3<f64>| {
                            Vector6::new(lin.x, lin.y, lin.z, ang.x, ang.y, ang.z)
                        };
                        [
                            (FRAMES[0], l, six(v.v, v.omega), six(a.a, a.alpha)),
                            (
                                FRAMES[1],
                                l,
                                six(rt * v.v, rt * v.omega),
                                six(rt * (a.a - v.omega.cross(&v.v)), rt * a.alpha),
                            ),
                            (
                                FRAMES[2],
                                l,
                                six(p.velocity, v.omega),
                                six(p.acceleration, a.alpha),
                            ),
                        ]
                    })
                    .collect();
            let vel = forward_velocities(&chain, &mut data, q, qd).unwrap();
            let (qd, qdd) = (DVector::from_row_slice(qd), DVector::from_row_slice(qdd));
            for (frame, l, twist, motion) in expected {
                let j = vel.poses().jacobian_in(l, frame);
                let j_dot = vel.jacobian_dot_in(l, frame);
                let got = &j * &qd;
                let got_acc = &j * &qdd + &j_dot * &qd;
                let tol = 1e-13 * scale * (1.0 + twist.norm() + motion.norm());
                assert!(
                    (got - twist).norm() < tol,
                    "{file} {l:?} {frame:?}: {got} {twist}"
                );
                assert!(
                    (got_acc - motion).norm() < tol,
                    "{file} {l:?} {frame:?}: {got_acc} {motion}"
                );
            }
        }
    }
}

/// `J̇` is the central difference of batched `J` along `q̇`: `(J(q + h q̇) − J(q − h q̇)) / 2h`.
#[test]
fn jacobian_rates_are_differences_of_batched_jacobians() {
    for file in [
        "robots/panda.urdf",
        "robots/stanford.yaml",
        "robots/cylindrical.yaml",
    ] {
        let chain = repo_chain(file);
        let dof = chain.dof();
        let n = 20;
        let [qs, qds, _] = samples(&chain, n, 23);
        let h = 1e-6;
        let step =
            |s: f64| -> Vec<f64> { qs.iter().zip(&qds).map(|(q, v)| q + s * h * v).collect() };
        let mut data = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let link = chain.end_link();
        let size = n * 6 * dof;
        for frame in FRAMES {
            let (mut plus, mut minus, mut j_dot) =
                (vec![0.0; size], vec![0.0; size], vec![0.0; size]);
            jacobian_batch(&chain, &mut data, &step(1.0), link, frame, &mut plus).unwrap();
            jacobian_batch(&chain, &mut data, &step(-1.0), link, frame, &mut minus).unwrap();
            jacobian_dot_batch(&chain, &mut data, &qs, &qds, link, frame, &mut j_dot).unwrap();
            for k in 0..size {
                let fd = (plus[k] - minus[k]) / (2.0 * h);
                assert!(
                    (fd - j_dot[k]).abs() < 1e-7,
                    "{file} {frame:?} entry {k}: {fd} {}",
                    j_dot[k]
                );
            }
        }
    }
}

/// The batched world Jacobian of the Panda's hand against the `k` crate's (same joints, no
/// mimic on the path), to 2e-14.
#[test]
fn batched_world_jacobian_matches_k() {
    let path = robots_dir().join("panda.urdf");
    let chain = Chain::from_file(&path).unwrap();
    let robot = k::Chain::<f64>::from_urdf_file(&path).unwrap();
    let arm = k::SerialChain::from_end(robot.find_link("panda_hand").unwrap());
    let ids: Vec<usize> = arm
        .iter_joints()
        .map(|j| {
            chain
                .variables()
                .position(|(id, _)| chain.joint(id).name() == j.name)
                .unwrap()
        })
        .collect();
    let dof = chain.dof();
    let n = 50;
    let [qs, _, _] = samples(&chain, n, 29);
    let mut data = BatchData::new(&chain);
    let mut out = vec![0.0; n * 6 * dof];
    let hand = chain.link_id("panda_hand").unwrap();
    jacobian_batch(&chain, &mut data, &qs, hand, JacobianFrame::World, &mut out).unwrap();
    for i in 0..n {
        let q = &qs[i * dof..(i + 1) * dof];
        arm.set_joint_positions(&ids.iter().map(|&c| q[c]).collect::<Vec<_>>())
            .unwrap();
        let theirs = k::jacobian(&arm);
        let ours = matrix(&out, i, dof);
        for (col, &c) in ids.iter().enumerate() {
            for r in 0..6 {
                assert!(
                    (ours[(r, c)] - theirs[(r, col)]).abs() < 2e-14,
                    "{i} ({r}, {c})"
                );
            }
        }
        // Columns of joints off the path (the fingers) are zero.
        for c in (0..dof).filter(|c| !ids.contains(c)) {
            assert!(ours.column(c).iter().all(|&x| x == 0.0));
        }
    }
}

#[test]
fn output_of_the_wrong_length_is_an_error() {
    let chain = repo_chain("robots/puma560.yaml");
    let mut data = BatchData::new(&chain);
    let qs = vec![0.0; 6 * 3];
    let mut out = vec![0.0; 6 * 6 * 3 - 1];
    let tool = chain.link_id("tool").unwrap();
    let e =
        jacobian_batch(&chain, &mut data, &qs, tool, JacobianFrame::World, &mut out).unwrap_err();
    assert_eq!(
        e.source,
        StateError::OutputLength {
            expected: 108,
            got: 107
        }
    );
    assert_eq!(e.to_string(), "configuration 0");
    let e = jacobian_dot_batch(
        &chain,
        &mut data,
        &qs,
        &qs[..12],
        tool,
        JacobianFrame::Link,
        &mut vec![0.0; 108],
    )
    .unwrap_err();
    assert!(matches!(
        e.source,
        StateError::WrongRows { what: "q_dot", .. }
    ));
}

use kinechain::LinkId;
