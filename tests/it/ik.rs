//! Inverse kinematics (`kinechain::ik`): fixed target sets solved from random, mid-limit and
//! tracking seeds, checked by an independent evaluation of the answers; limits held; masks,
//! position-only, locked joints, relative goals, a floating base with four goals; unreachable and
//! singular targets; single = batch = threads bit for bit; every error.

use crate::common::repo_chain;
use kinechain::eval::batch::{Uninterrupted, Workers};
use kinechain::ik::{BatchOut, Distance, Goal, IkError, Options, Solution, Solver, solve_batch};
use kinechain::{
    Chain, Data, LimitPolicy, LinkId, Transform, check_q, forward_kinematics, forward_kinematics_to,
};

/// The world pose of `link` at `q`.
fn pose(chain: &Chain, q: &[f64], link: LinkId) -> Transform {
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    forward_kinematics_to(chain, &mut data, q, link).unwrap()
}

/// Position and rotation-angle gaps between two poses, computed from the matrices (not by the
/// solver's code): `|p − p*|` and the angle of `R*ᵀ R` from its trace.
fn gap(a: &Transform, b: &Transform) -> (f64, f64) {
    let dp = (a.translation() - b.translation()).norm();
    let r = b.rotation().transpose() * a.rotation();
    let c = ((r.trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
    // acos loses digits near 0: the angle from the skew part there.
    let s = (r - r.transpose()).norm() / (2.0 * std::f64::consts::SQRT_2);
    (dp, s.atan2(c))
}

/// `n` targets of `link` from random configurations within the limits.
fn targets(chain: &Chain, link: LinkId, n: usize, seed: u64) -> (Vec<f64>, Vec<Transform>) {
    let qs = chain.random_configurations(n, seed, (-1.0, 1.0));
    let t = qs
        .chunks(chain.nq())
        .map(|q| pose(chain, q, link))
        .collect();
    (qs, t)
}

/// A solution's claims hold: `q` within every limit, and where it says success, an independent
/// evaluation within the tolerance.
fn verify(chain: &Chain, link: LinkId, target: &Transform, s: &Solution) {
    check_q(chain, &s.q, LimitPolicy::Enforce).unwrap();
    let (dp, dr) = gap(&pose(chain, &s.q, link), target);
    if s.success {
        assert!(
            dp <= 1e-6 && dr <= 1e-6,
            "claimed success at {dp:e} m, {dr:e} rad"
        );
    }
    assert!(
        (dp - s.position_error[0]).abs() < 1e-9,
        "{dp} vs {}",
        s.position_error[0]
    );
    assert!(
        (dr - s.rotation_error[0]).abs() < 1e-9,
        "{dr} vs {}",
        s.rotation_error[0]
    );
}

#[test]
fn arms_reach_every_target_from_random_mid_limit_and_tracking_seeds() {
    for (file, link, n) in [
        ("robots/panda.urdf", "panda_hand", 300),
        ("robots/ur5.yaml", "tool0", 300),
        ("robots/iiwa7.yaml", "link7", 300),
        ("robots/puma560.yaml", "tool", 200),
    ] {
        let chain = repo_chain(file);
        let l = chain.link_id(link).unwrap();
        let (qs, ts) = targets(&chain, l, n, 11);
        let seeds = chain.random_configurations(n, 12, (-1.0, 1.0));
        let mut solver = Solver::new(&chain, vec![Goal::pose(l)], Options::default()).unwrap();
        let nq = chain.nq();
        let mut solved = [0; 3];
        for (i, t) in ts.iter().enumerate() {
            let tracking: Vec<f64> = qs[i * nq..(i + 1) * nq]
                .iter()
                .zip(
                    chain
                        .joints()
                        .iter()
                        .filter_map(|j| j.limits().first().copied()),
                )
                .enumerate()
                .map(|(k, (x, l))| {
                    let x = x + if k % 2 == 0 { 0.1 } else { -0.1 };
                    l.map_or(x, |l| x.clamp(l.lower, l.upper))
                })
                .collect();
            for (slot, seed) in [
                Some(&seeds[i * nq..(i + 1) * nq]),
                None,
                Some(&tracking[..]),
            ]
            .into_iter()
            .enumerate()
            {
                let s = solver.solve(std::slice::from_ref(t), seed).unwrap();
                verify(&chain, l, t, &s);
                solved[slot] += usize::from(s.success);
            }
        }
        assert_eq!(
            solved, [n; 3],
            "{file}: solved from random, mid-limit, tracking seeds"
        );
    }
}

#[test]
fn limits_hold_for_targets_and_seeds_at_the_limits() {
    let chain = repo_chain("robots/panda.urdf");
    let hand = chain.link_id("panda_hand").unwrap();
    let (lo, hi): (Vec<f64>, Vec<f64>) = chain
        .joints()
        .iter()
        .filter(|j| j.q_index().is_some())
        .map(|j| j.limits()[0].map_or((0.0, 0.0), |l| (l.lower, l.upper)))
        .unzip();
    let mut solver = Solver::new(&chain, vec![Goal::pose(hand)], Options::default()).unwrap();
    let mut solved = 0;
    for mask in 0u32..64 {
        // Joints at their lower or upper limit, or just inside, by the bits of `mask`.
        let q: Vec<f64> = (0..chain.nq())
            .map(|k| match (mask >> (k % 6)) & 1 {
                0 if k % 3 == 0 => lo[k],
                0 => lo[k] + 1e-3 * (hi[k] - lo[k]),
                _ if k % 2 == 0 => hi[k],
                _ => hi[k] - 1e-3 * (hi[k] - lo[k]),
            })
            .collect();
        let target = pose(&chain, &q, hand);
        let reversed: Vec<f64> = q
            .iter()
            .enumerate()
            .map(|(k, x)| (lo[k] + hi[k] - x).clamp(lo[k], hi[k]))
            .collect();
        for seed in [None, Some(&reversed[..]), Some(&q[..])] {
            let s = solver.solve(&[target], seed).unwrap();
            verify(&chain, hand, &target, &s);
            for (k, x) in s.q.iter().enumerate() {
                assert!(
                    lo[k] <= *x && *x <= hi[k],
                    "q[{k}] = {x} outside [{}, {}]",
                    lo[k],
                    hi[k]
                );
            }
            solved += usize::from(s.success);
        }
    }
    // 188 of 192 on the hosts measured: with three to six joints at their limits the target lies
    // on the edge of the workspace, where the limits leave a sliver of joint space to find. The
    // count depends on rounding (instruction sets differ between hosts); the limits never do.
    assert!(solved >= 184, "{solved} of 192");
}

#[test]
fn an_unreachable_target_is_a_least_squares_failure_not_an_error() {
    // The planar arm reaches 9 m; a point 12 m out is 3 m beyond, at best.
    let chain = repo_chain("robots/planar3.yaml");
    let tip = chain.link_id("link3").unwrap();
    let options = Options {
        max_attempts: 5,
        ..Options::default()
    };
    let mut solver = Solver::new(&chain, vec![Goal::position(tip)], options).unwrap();
    let far = Transform::from_xyz_rpy([12.0, 0.0, 0.0], [0.0; 3]);
    let s = solver.solve(&[far], Some(&[0.3, -0.2, 0.4])).unwrap();
    assert!(!s.success);
    assert!(
        (s.position_error[0] - 3.0).abs() < 1e-6,
        "{}",
        s.position_error[0]
    );
    assert_eq!(s.rotation_error[0], 0.0, "orientation is free");
    assert_eq!(s.restarts, 4);
    // Panda poses pushed 5 cm outward from the base: failures with their residuals.
    let chain = repo_chain("robots/panda.urdf");
    let hand = chain.link_id("panda_hand").unwrap();
    let mut solver = Solver::new(
        &chain,
        vec![Goal::pose(hand)],
        Options {
            max_attempts: 3,
            ..Options::default()
        },
    )
    .unwrap();
    let (_, ts) = targets(&chain, hand, 20, 5);
    let mut failed = 0;
    for t in &ts {
        // The elbow straight: the reach along the target's direction from the shoulder.
        let mut far = *t;
        let p = t.translation();
        let shoulder = kinechain::nalgebra::Vector3::new(0.0, 0.0, 0.333);
        let out = (p - shoulder).normalize() * (1.2 - (p - shoulder).norm()).max(0.05);
        far = Transform::from_parts(&far.rotation(), &(p + out));
        let s = solver.solve(&[far], None).unwrap();
        verify(&chain, hand, &far, &s);
        failed += usize::from(!s.success);
        assert!(s.position_error[0] > 1e-3);
    }
    assert_eq!(failed, 20);
}

#[test]
fn singular_targets_converge_without_blowing_up() {
    // The planar arm stretched straight (its Jacobian loses a rank), and a target on the axis of
    // the UR5's base joint (the base angle is then arbitrary).
    let chain = repo_chain("robots/planar3.yaml");
    let tip = chain.link_id("link3").unwrap();
    let straight = pose(&chain, &[0.0, 0.0, 0.0], tip);
    let mut solver = Solver::new(&chain, vec![Goal::pose(tip)], Options::default()).unwrap();
    let s = solver.solve(&[straight], Some(&[0.5, -0.4, 0.2])).unwrap();
    verify(&chain, tip, &straight, &s);
    assert!(s.success, "{s:?}");
    let ur5 = repo_chain("robots/ur5.yaml");
    let wrist = ur5.link_id("wrist_1_link").unwrap();
    let mut solver = Solver::new(&ur5, vec![Goal::position(wrist)], Options::default()).unwrap();
    let on_axis = Transform::from_xyz_rpy([0.0, 0.0, 0.5], [0.0; 3]);
    let s = solver.solve(&[on_axis], None).unwrap();
    assert!(s.q.iter().all(|x| x.is_finite()));
    check_q(&ur5, &s.q, LimitPolicy::Enforce).unwrap();
}

#[test]
fn position_only_on_a_three_joint_arm_and_a_free_tool_axis() {
    let chain = repo_chain("robots/puma560.yaml");
    let link3 = chain.link_id("link3").unwrap();
    let (qs, ts) = targets(&chain, link3, 50, 3);
    let mut solver = Solver::new(&chain, vec![Goal::position(link3)], Options::default()).unwrap();
    assert_eq!(solver.moving(), 3, "only the joints before link3 move");
    for (i, t) in ts.iter().enumerate() {
        // Orientation way off: it does not count.
        let target = Transform::from_parts(&Transform::rot_x(2.0).rotation(), &t.translation());
        let s = solver.solve(&[target], None).unwrap();
        assert!(s.success, "{i}: {s:?}");
        let (dp, _) = gap(&pose(&chain, &s.q, link3), &target);
        assert!(dp < 1e-6);
        assert_eq!(
            &s.q[3..],
            &chain.neutral_mid()[3..],
            "joints after link3 keep the start"
        );
        let _ = &qs;
    }
    // The Panda's hand with the turn about its z axis free: a target turned about its own z.
    let panda = repo_chain("robots/panda.urdf");
    let hand = panda.link_id("panda_hand").unwrap();
    let goal = Goal::pose(hand).with_weights([1.0, 1.0, 1.0, 1.0, 1.0, 0.0]);
    let mut solver = Solver::new(&panda, vec![goal], Options::default()).unwrap();
    let (_, ts) = targets(&panda, hand, 50, 4);
    for t in &ts {
        let turned = *t * Transform::rot_z(1.3);
        let s = solver.solve(&[turned], None).unwrap();
        assert!(s.success);
        let got = pose(&panda, &s.q, hand);
        let (dp, _) = gap(&got, &turned);
        let z = (got.rotation().column(2) - turned.rotation().column(2)).norm();
        assert!(dp < 1e-6 && z < 1e-6, "{dp:e} {z:e}");
    }
}

trait MidLimits {
    fn neutral_mid(&self) -> Vec<f64>;
}
impl MidLimits for Chain {
    fn neutral_mid(&self) -> Vec<f64> {
        let l = self.link_id("link3").unwrap();
        Solver::new(self, vec![Goal::pose(l)], Options::default())
            .unwrap()
            .default_start()
    }
}

#[test]
fn locked_joints_keep_the_seed_and_relative_goals_place_one_link_in_anothers_frame() {
    let chain = repo_chain("robots/panda.urdf");
    let hand = chain.link_id("panda_hand").unwrap();
    let j1 = chain.joint_id("panda_joint1").unwrap();
    let (qs, ts) = targets(&chain, hand, 30, 6);
    let options = Options {
        locked: vec![j1],
        ..Options::default()
    };
    let mut solver = Solver::new(&chain, vec![Goal::pose(hand)], options).unwrap();
    assert_eq!(solver.moving(), 6);
    let nq = chain.nq();
    for (i, t) in ts.iter().enumerate() {
        // Seeds sharing the target's joint 1, so the target stays reachable.
        let mut seed = Solver::new(&chain, vec![Goal::pose(hand)], Options::default())
            .unwrap()
            .default_start();
        seed[0] = qs[i * nq];
        let s = solver.solve(&[*t], Some(&seed)).unwrap();
        assert!(s.success, "{i}");
        assert_eq!(s.q[0].to_bits(), seed[0].to_bits());
    }
    // G1: the left hand relative to the torso, the right foot relative to the pelvis.
    let g1 = repo_chain("robots/g1.urdf+floating");
    let (hand, torso) = (
        g1.link_id("left_rubber_hand").unwrap(),
        g1.link_id("torso_link").unwrap(),
    );
    let (foot, pelvis) = (
        g1.link_id("right_ankle_roll_link").unwrap(),
        g1.link_id("pelvis").unwrap(),
    );
    let goals = vec![
        Goal::pose(hand).relative_to(torso),
        Goal::pose(foot).relative_to(pelvis),
    ];
    let mut solver = Solver::new(&g1, goals, Options::default()).unwrap();
    let qs = g1.random_configurations(20, 8, (-1.0, 1.0));
    let mut data = Data::new(&g1).with_limit_policy(LimitPolicy::Ignore);
    for q in qs.chunks(g1.nq()) {
        let p = forward_kinematics(&g1, &mut data, q).unwrap();
        let rel = |l, b| p.world_from_link(b).inverse() * p.world_from_link(l);
        let ts = [rel(hand, torso), rel(foot, pelvis)];
        let s = solver.solve(&ts, None).unwrap();
        assert!(s.success, "{s:?}");
        let p = forward_kinematics(&g1, &mut data, &s.q).unwrap();
        for (t, (l, b)) in ts.iter().zip([(hand, torso), (foot, pelvis)]) {
            let got = p.world_from_link(b).inverse() * p.world_from_link(l);
            let (dp, dr) = gap(&got, t);
            assert!(dp < 1e-6 && dr < 1e-6);
        }
        assert_eq!(
            &s.q[..7],
            &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            "the base does not move the relative poses"
        );
    }
}

#[test]
fn a_floating_humanoid_places_both_feet_and_both_hands_from_the_neutral_pose() {
    let g1 = repo_chain("robots/g1.urdf+floating");
    let names = [
        "left_ankle_roll_link",
        "right_ankle_roll_link",
        "left_rubber_hand",
        "right_rubber_hand",
    ];
    let links: Vec<LinkId> = names.iter().map(|n| g1.link_id(n).unwrap()).collect();
    let goals = links.iter().map(|&l| Goal::pose(l)).collect();
    let options = Options {
        start: kinechain::ik::Start::Neutral,
        ..Options::default()
    };
    let mut solver = Solver::new(&g1, goals, options).unwrap();
    let qs = g1.random_configurations(40, 9, (-0.3, 0.3));
    let mut data = Data::new(&g1).with_limit_policy(LimitPolicy::Ignore);
    let mut solved = 0;
    for q in qs.chunks(g1.nq()) {
        let p = forward_kinematics(&g1, &mut data, q).unwrap();
        let ts: Vec<Transform> = links.iter().map(|&l| p.world_from_link(l)).collect();
        let s = solver.solve(&ts, None).unwrap();
        check_q(&g1, &s.q, LimitPolicy::Enforce).unwrap();
        let norm: f64 = s.q[3..7].iter().map(|x| x * x).sum::<f64>();
        assert!((norm - 1.0).abs() < 1e-12, "the base quaternion stays unit");
        if s.success {
            let p = forward_kinematics(&g1, &mut data, &s.q).unwrap();
            for (t, &l) in ts.iter().zip(&links) {
                let (dp, dr) = gap(&p.world_from_link(l), t);
                assert!(dp < 1e-6 && dr < 1e-6);
            }
        }
        solved += usize::from(s.success);
    }
    assert!(solved >= 40, "{solved} of 40");
}

#[test]
fn one_solve_a_batch_and_any_number_of_threads_give_the_same_bits() {
    let chain = repo_chain("robots/panda.urdf");
    let hand = chain.link_id("panda_hand").unwrap();
    let n = 200;
    let (_, ts) = targets(&chain, hand, n, 21);
    let seeds = chain.random_configurations(n, 22, (-1.0, 1.0));
    let options = Options {
        closest: None,
        seed: 7,
        ..Options::default()
    };
    let mut solver = Solver::new(&chain, vec![Goal::pose(hand)], options).unwrap();
    let nq = chain.nq();
    let single: Vec<Solution> = ts
        .iter()
        .enumerate()
        .map(|(i, t)| {
            solver
                .solve(&[*t], Some(&seeds[i * nq..(i + 1) * nq]))
                .unwrap()
        })
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    for workers in [Workers::Here, Workers::Pool(&pool)] {
        let (mut q, mut ok, mut pe, mut re, mut it, mut rs) = (
            vec![0.0; n * nq],
            vec![false; n],
            vec![0.0; n],
            vec![0.0; n],
            vec![0; n],
            vec![0; n],
        );
        let out = BatchOut {
            q: &mut q,
            success: &mut ok,
            position_error: &mut pe,
            rotation_error: &mut re,
            iterations: &mut it,
            restarts: &mut rs,
        };
        solve_batch(&solver, &ts, Some(&seeds), out, workers, &mut Uninterrupted).unwrap();
        for (i, s) in single.iter().enumerate() {
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&q[i * nq..(i + 1) * nq]), bits(&s.q), "row {i}");
            assert_eq!(ok[i], s.success);
            assert_eq!(pe[i].to_bits(), s.position_error[0].to_bits());
            assert_eq!(it[i] as usize, s.iterations);
        }
    }
}

#[test]
fn the_closest_solution_to_the_seed_is_no_farther_than_the_first() {
    let chain = repo_chain("robots/ur5.yaml");
    let tool = chain.link_id("tool0").unwrap();
    let (qs, ts) = targets(&chain, tool, 10, 31);
    let nq = chain.nq();
    let mut first = Solver::new(&chain, vec![Goal::pose(tool)], Options::default()).unwrap();
    for metric in [Distance::L2, Distance::LInf] {
        let options = Options {
            closest: Some(metric),
            max_attempts: 20,
            ..Options::default()
        };
        let mut closest = Solver::new(&chain, vec![Goal::pose(tool)], options).unwrap();
        for (i, t) in ts.iter().enumerate() {
            let seed: Vec<f64> = qs[i * nq..(i + 1) * nq]
                .iter()
                .map(|x| x + 0.4)
                .map(|x: f64| x.min(6.2))
                .collect();
            let (a, b) = (
                first.solve(&[*t], Some(&seed)).unwrap(),
                closest.solve(&[*t], Some(&seed)).unwrap(),
            );
            assert!(a.success && b.success);
            assert_eq!(b.restarts, 19, "it searches through every attempt");
            let d = |q: &[f64]| {
                let it = q.iter().zip(&seed).map(|(x, y)| (x - y).abs());
                match metric {
                    Distance::L2 => it.map(|x| x * x).sum::<f64>().sqrt(),
                    _ => it.fold(0.0, f64::max),
                }
            };
            assert!(d(&b.q) <= d(&a.q) + 1e-12);
        }
    }
}

#[test]
fn what_cannot_be_posed_is_an_error_naming_it() {
    let chain = repo_chain("robots/ur5.yaml");
    let other = repo_chain("robots/g1.urdf");
    let tool = chain.link_id("tool0").unwrap();
    let far = other.link_id("right_rubber_hand").unwrap();
    let message = |e: IkError| e.to_string();
    assert!(matches!(
        Solver::new(&chain, vec![], Options::default()),
        Err(IkError::NoGoal)
    ));
    assert!(
        message(Solver::new(&chain, vec![Goal::pose(far)], Options::default()).unwrap_err())
            .contains("not a link of this chain")
    );
    let zero = Goal::pose(tool).with_weights([0.0; 6]);
    assert!(
        message(Solver::new(&chain, vec![zero], Options::default()).unwrap_err())
            .contains("every weight is 0")
    );
    let nan = Goal::pose(tool).with_weights([1.0, f64::NAN, 1.0, 1.0, 1.0, 1.0]);
    assert!(
        message(Solver::new(&chain, vec![nan], Options::default()).unwrap_err())
            .contains("weight NaN")
    );
    let bad_tol = Options {
        position_tolerance: 0.0,
        ..Options::default()
    };
    assert!(
        message(Solver::new(&chain, vec![Goal::pose(tool)], bad_tol).unwrap_err())
            .contains("position_tolerance")
    );
    let lock = Options {
        locked: vec![other.joint_id("right_wrist_yaw_joint").unwrap()],
        ..Options::default()
    };
    assert!(matches!(
        Solver::new(&chain, vec![Goal::pose(tool)], lock),
        Err(IkError::UnknownJoint(_))
    ));
    let mut solver = Solver::new(&chain, vec![Goal::pose(tool)], Options::default()).unwrap();
    let t = pose(&chain, &[0.1; 6], tool);
    assert!(matches!(
        solver.solve(&[t, t], None),
        Err(IkError::TargetCount { got: 2, goals: 1 })
    ));
    let mut sheared = t.to_homogeneous();
    sheared[(0, 1)] += 0.1;
    let sheared = Transform::from_rows(&[
        [
            sheared[(0, 0)],
            sheared[(0, 1)],
            sheared[(0, 2)],
            sheared[(0, 3)],
        ],
        [
            sheared[(1, 0)],
            sheared[(1, 1)],
            sheared[(1, 2)],
            sheared[(1, 3)],
        ],
        [
            sheared[(2, 0)],
            sheared[(2, 1)],
            sheared[(2, 2)],
            sheared[(2, 3)],
        ],
    ]);
    assert!(message(solver.solve(&[sheared], None).unwrap_err()).contains("not orthonormal"));
    let nan_target = Transform::from_xyz_rpy([f64::NAN, 0.0, 0.0], [0.0; 3]);
    assert!(message(solver.solve(&[nan_target], None).unwrap_err()).contains("non-finite"));
    assert!(message(solver.solve(&[t], Some(&[0.0; 5])).unwrap_err()).contains("seed q0"));
    let e = message(
        solver
            .solve(&[t], Some(&[7.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
            .unwrap_err(),
    );
    assert!(e.contains("shoulder_pan"), "{e}");
    let e = message(
        solver
            .solve(&[t], Some(&[f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]))
            .unwrap_err(),
    );
    assert!(e.contains("seed q0"), "{e}");
}
