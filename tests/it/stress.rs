//! Numerical stability under stress, against a 256-bit evaluation of the same model
//! (`kinechain::reference`): long chains, large joint values, mixed scales, orthonormality,
//! long incremental runs, nearly parallel axes.
//!
//! The short versions run with the test suite. The long ones (chains up to 10 000 joints,
//! 10⁶ incremental steps) are ignored by default; run them, with their table of measured
//! figures, by
//!
//! ```text
//! cargo test --release --test stress -- --ignored --nocapture
//! ```

use crate::common::*;
use kinechain::nalgebra::Vector3;
use kinechain::reference::{LinkMotion, link_motion, max_rate_errors};
use kinechain::{
    Chain, ChainBuilder, Data, LimitPolicy, Transform, forward_accelerations, forward_kinematics,
    forward_kinematics_incremental,
};
use rand::Rng;

const EPS: f64 = f64::EPSILON;

/// A random chain of `n` joints in the axis form: random rotations and translations of length
/// `length(i)` between joints, random unit axes (or `axis(i)` when given), revolute, prismatic and
/// cylindrical joints.
fn random_chain(
    n: usize,
    seed: u64,
    length: impl Fn(usize) -> f64,
    axis: Option<&dyn Fn(usize) -> [f64; 3]>,
) -> Chain {
    let mut rng = rng(seed);
    let mut b = ChainBuilder::new(format!("random{n}"));
    b.link("link0");
    for i in 1..=n {
        let dir = Vector3::new(
            rng.random::<f64>() - 0.5,
            rng.random::<f64>() - 0.5,
            rng.random::<f64>() - 0.5,
        )
        .normalize();
        let rpy = [
            rng.random::<f64>() * 6.0 - 3.0,
            rng.random::<f64>() * 3.0 - 1.5,
            rng.random::<f64>() * 6.0 - 3.0,
        ];
        let origin = Transform::from_xyz_rpy((dir * length(i)).into(), rpy);
        let kind = random_kind(&mut rng);
        let a = match axis {
            Some(f) => f(i),
            None => [
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
            ],
        };
        b.link(format!("link{i}"));
        b.joint(joint_to_link(i, kind).with_origin(origin).with_axis(a));
    }
    b.build().unwrap()
}

/// Errors of one configuration, in meaningful units: positions in ulp of the reach, rotation
/// entries in ulp of 1, rates relative to their largest magnitude over the chain.
#[derive(Clone, Copy, Debug, Default)]
struct Errors {
    position: f64,
    rotation: f64,
    orthonormality: f64,
    omega: f64,
    v: f64,
    alpha: f64,
    a: f64,
}

impl Errors {
    fn max(self, o: Errors) -> Errors {
        Errors {
            position: worse(self.position, o.position),
            rotation: worse(self.rotation, o.rotation),
            orthonormality: worse(self.orthonormality, o.orthonormality),
            omega: worse(self.omega, o.omega),
            v: worse(self.v, o.v),
            alpha: worse(self.alpha, o.alpha),
            a: worse(self.a, o.a),
        }
    }
}

fn vmax(v: &[f64; 3]) -> f64 {
    v.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
}

/// One random state of `chain`, evaluated by the f64 kernels and by the reference.
fn measure(chain: &Chain, seed: u64, q_scale: f64) -> Errors {
    let mut rng = rng(seed);
    let q: Vec<f64> = (0..chain.dof())
        .map(|_| q_scale * (2.0 * rng.random::<f64>() - 1.0))
        .collect();
    let qd = random_vec(chain.dof(), 1.0, &mut rng);
    let qdd = random_vec(chain.dof(), 1.0, &mut rng);
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let pose_only = forward_kinematics(chain, &mut data, &q).unwrap();
    let pose_only: Vec<Transform> = poses(chain, &pose_only);
    let acc = forward_accelerations(chain, &mut data, &q, &qd, &qdd).unwrap();
    let exact: Vec<LinkMotion> = link_motion(chain, &q, &qd, &qdd);
    let reach = exact
        .iter()
        .fold(1e-300_f64, |m, l| m.max(vmax(&l.pose.translation().into())));
    let mut e = Errors::default();
    let mut rates = Vec::with_capacity(exact.len());
    for (i, want) in exact.iter().enumerate() {
        let id = chain.link_id(chain.links()[i].name()).unwrap();
        let pose = acc.world_from_link(id);
        // The poses of the rate kernels and of the pose kernels (which differ in how they
        // compute `sin`/`cos`).
        for got in [pose, pose_only[i]] {
            let (position, rotation) = pose_entry_errors(&got.to_rows(), &want.pose.to_rows());
            e.position = worse(e.position, position / (reach * EPS));
            e.rotation = worse(e.rotation, rotation / EPS);
        }
        e.orthonormality = worse(e.orthonormality, pose.orthonormality_error() / EPS);
        let (v, a) = (acc.velocity(id), acc.acceleration(id));
        rates.push([v.omega.into(), v.v.into(), a.alpha.into(), a.a.into()]);
    }
    // Each rate in ulps of its largest component over the links.
    let [omega, v, alpha, a] = max_rate_errors(&rates, &exact).map(|(_, ulps)| ulps);
    (e.omega, e.v, e.alpha, e.a) = (omega, v, alpha, a);
    e
}

/// Worst errors over `samples` states of a random chain of `n` joints (unit-scale links).
fn chain_errors(n: usize, samples: u64) -> Errors {
    let chain = random_chain(n, 1000 + n as u64, |_| 0.3, None);
    (0..samples).fold(Errors::default(), |e, s| {
        e.max(measure(&chain, s, std::f64::consts::PI))
    })
}

/// Bound on the error growth with chain length: each joint composes one more rigid transform,
/// whose few roundings (of entries ≤ 1, positions ≤ the reach) can add at most a few ulp; the
/// tests assert 8 n ulp (positions in ulp of the reach, rotations of 1, rates of their largest
/// value), while the measured growth is ~√n (see the long test's fit).
fn linear_bound(n: usize) -> f64 {
    8.0 * n as f64
}

fn assert_within(n: usize, e: &Errors) {
    let b = linear_bound(n);
    for (what, x) in [
        ("position", e.position),
        ("rotation", e.rotation),
        ("orthonormality", e.orthonormality),
        ("omega", e.omega),
        ("v", e.v),
        ("alpha", e.alpha),
        ("a", e.a),
    ] {
        assert!(x <= b, "n = {n}: {what} error {x:.1} ulp > {b}");
    }
}

#[test]
fn chains_of_10_and_100_joints_stay_within_the_linear_bound() {
    for n in [10, 100] {
        let e = chain_errors(n, 3);
        assert_within(n, &e);
    }
}

/// The same bound for standard DH rows, whose rates take the form for a joint at the parent's
/// origin (the child's own ω and α applied to the whole offset).
#[test]
fn standard_dh_chains_of_10_and_100_joints_stay_within_the_linear_bound() {
    for n in [10, 100] {
        let chain = random_standard_dh_chain(n, 2000 + n as u64);
        let e = (0..3).fold(Errors::default(), |e, s| {
            e.max(measure(&chain, s, std::f64::consts::PI))
        });
        eprintln!("standard DH, n = {n}: {e:?}");
        assert_within(n, &e);
    }
}

/// Joint angles up to 10¹⁵ rad (beyond the fast reduction at 8.2·10⁵ rad, where the standard
/// library takes over, and beyond 1.6·10⁶ rad, where the reduction's products would no longer be
/// exact): the result is as accurate as for small angles. And `q + 2πk` agrees with
/// `q` to what the rounding of the input `q + 2πk` allows: a change δ of an angle moves the
/// chain by at most δ times the reach.
#[test]
fn large_joint_values() {
    let chain = random_chain(12, 7, |_| 0.3, None);
    for (seed, scale) in [(1, 1e3), (2, 1e5), (3, 1e6), (5, 1e9), (6, 1e15)] {
        let e = measure(&chain, seed, scale);
        assert_within(12, &e);
    }
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let mut rng = rng(4);
    let reach = chain.reach();
    for k in [1.0, 1e3, 1e5] {
        let q: Vec<f64> = (0..chain.dof())
            .map(|_| 2.0 * rng.random::<f64>() - 1.0)
            .collect();
        let shift = 2.0 * std::f64::consts::PI * k;
        let q2: Vec<f64> = q
            .iter()
            .enumerate()
            .map(|(i, x)| if is_angle(&chain, i) { x + shift } else { *x })
            .collect();
        let a: Vec<Transform> = {
            let p = forward_kinematics(&chain, &mut data, &q).unwrap();
            poses(&chain, &p)
        };
        let b: Vec<Transform> = {
            let p = forward_kinematics(&chain, &mut data, &q2).unwrap();
            poses(&chain, &p)
        };
        // |fl(q + 2πk) − (q + 2πk)| ≤ ulp(2πk)/2 per angle, plus 2πk itself rounds by ulp(2πk)/2,
        // and each of the two evaluations errs by ≤ 8n ulp of the reach.
        let delta = (shift * EPS) * chain.dof() as f64;
        let bound = delta * reach.max(1.0) + 2.0 * linear_bound(12) * EPS * reach;
        for (x, y) in a.iter().zip(&b) {
            assert!(
                pose_error(x, &y.to_rows()) <= bound,
                "k = {k}: {}",
                pose_error(x, &y.to_rows())
            );
        }
    }
}

fn is_angle(chain: &Chain, index: usize) -> bool {
    let (joint, component) = chain.variables().nth(index).unwrap();
    chain.joint(joint).kind().rotates() && component != Some("d")
}

fn poses(chain: &Chain, p: &kinechain::Poses<'_>) -> Vec<Transform> {
    chain
        .links()
        .iter()
        .map(|l| p.world_from_link(chain.link_id(l.name()).unwrap()))
        .collect()
}

/// Links of 1e-6 m and 1e3 m alternating in one chain: errors relative to the reach stay within
/// the bound. (Relative to a micrometre link's own length, world-frame positions cannot be
/// accurate: a coordinate of order 10³ m carries a rounding of 10³ ulp; the long test reports it.)
#[test]
fn mixed_scales() {
    let chain = random_chain(20, 8, |i| if i % 2 == 0 { 1e-6 } else { 1e3 }, None);
    for seed in 0..3 {
        let e = measure(&chain, seed, std::f64::consts::PI);
        assert_within(20, &e);
    }
}

/// Nearly parallel consecutive axes (1e-9 rad apart) are no harder than any others.
#[test]
fn nearly_parallel_axes() {
    let axis = |i: usize| [1e-9 * (i % 3) as f64, 1e-9 * (i % 5) as f64, 1.0];
    let chain = random_chain(30, 9, |_| 0.2, Some(&axis));
    for seed in 0..3 {
        let e = measure(&chain, seed, std::f64::consts::PI);
        assert_within(30, &e);
    }
}

/// Many small updates of one joint, as a control loop makes them: the incremental result is bit
/// for bit a fresh evaluation at every step (each pose is recomputed from its parent, never
/// updated in place, so nothing accumulates).
fn incremental_run(steps: usize) {
    let chain = Chain::from_file(robots_dir().join("panda_mdh.yaml")).unwrap();
    let tcp = chain.link_id("tcp").unwrap();
    let (mut inc, mut fresh) = (Data::new(&chain), Data::new(&chain));
    let mut q = vec![0.1, -0.3, 0.2, -1.8, 0.0, 1.6, 0.5];
    for step in 0..steps {
        q[6] = 0.5 + 1e-3 * ((step as f64) * 1e-3).sin();
        let a = forward_kinematics_incremental(&chain, &mut inc, &q)
            .unwrap()
            .world_from_link(tcp);
        if step % 97 == 0 || step + 1 == steps {
            let b = forward_kinematics(&chain, &mut fresh, &q)
                .unwrap()
                .world_from_link(tcp);
            assert_eq!(a, b, "step {step}");
        }
    }
}

#[test]
fn incremental_updates_do_not_drift() {
    incremental_run(20_000);
}

// ---------------------------------------------------------------------------------------------
// Long runs (ignored by default).

#[test]
#[ignore = "long: cargo test --release --test stress -- --ignored --nocapture"]
fn long_chains_error_growth() {
    println!(
        "\n| joints | position (ulp of reach) | rotation (ulp) | ‖RᵀR − I‖ (ulp) | ω | v | α | a |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut points = Vec::new();
    for n in [10, 100, 1000, 10_000] {
        let samples = if n >= 10_000 { 2 } else { 5 };
        let e = chain_errors(n, samples);
        println!(
            "| {n} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            e.position, e.rotation, e.orthonormality, e.omega, e.v, e.alpha, e.a
        );
        assert_within(n, &e);
        points.push((n as f64, e));
    }
    // Least-squares slope of log(error) against log(n): the growth exponent.
    let fit = |f: fn(&Errors) -> f64| {
        let pts: Vec<(f64, f64)> = points
            .iter()
            .map(|(n, e)| (n.ln(), f(e).max(0.5).ln()))
            .collect();
        let (mx, my) = (
            pts.iter().map(|p| p.0).sum::<f64>() / 4.0,
            pts.iter().map(|p| p.1).sum::<f64>() / 4.0,
        );
        pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
            / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>()
    };
    println!(
        "\ngrowth exponents (error ∝ n^k): position {:.2}, rotation {:.2}, orthonormality {:.2}, ω {:.2}, v {:.2}, α {:.2}, a {:.2}",
        fit(|e| e.position),
        fit(|e| e.rotation),
        fit(|e| e.orthonormality),
        fit(|e| e.omega),
        fit(|e| e.v),
        fit(|e| e.alpha),
        fit(|e| e.a)
    );

    // Mixed scales, relative to each link's own length.
    let chain = random_chain(20, 8, |i| if i % 2 == 0 { 1e-6 } else { 1e3 }, None);
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let q: Vec<f64> = (0..chain.dof()).map(|i| 0.1 * i as f64).collect();
    let p = forward_kinematics(&chain, &mut data, &q).unwrap();
    let ours = poses(&chain, &p);
    let exact = kinechain::reference::link_poses(&chain, &q);
    let mut own: f64 = 0.0;
    for i in 1..ours.len() {
        let len = (exact[i].translation() - exact[i - 1].translation()).norm();
        let e = ((ours[i].translation() - ours[i - 1].translation())
            - (exact[i].translation() - exact[i - 1].translation()))
        .norm();
        own = worse(own, e / (len * EPS));
    }
    println!(
        "mixed 1e-6 m / 1e3 m links: link-to-link vectors err by up to {own:.3e} ulp of their own length (world coordinates of order 1e3 m)"
    );
}

#[test]
#[ignore = "long: cargo test --release --test stress -- --ignored --nocapture"]
fn a_million_incremental_updates() {
    incremental_run(1_000_000);
    println!("10⁶ incremental updates: every checked step bit-identical to a fresh evaluation");
}

/// Largest errors of the geometric Jacobian and of `J̇ q̇` of every link of `chain` at one state,
/// against the 256-bit recursion: column `i` of `J` is the twist at `q̇ = eᵢ` (the twist is
/// linear in `q̇`), and `J̇ q̇` is the acceleration at `q̈ = 0`. The linear rows of `J` in ulps
/// of `reach`, its angular rows (unit axes) in ulps of 1, `J̇ q̇` in ulps of the largest
/// component of `a` and of `α` over the links.
fn jacobian_ulps(chain: &Chain, q: &[f64], qd: &[f64], reach: f64) -> [f64; 3] {
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let dof = chain.dof();
    let columns: Vec<Vec<LinkMotion>> = (0..dof)
        .map(|i| {
            let unit: Vec<f64> = (0..dof).map(|k| if k == i { 1.0 } else { 0.0 }).collect();
            link_motion(chain, q, &unit, &vec![0.0; dof])
        })
        .collect();
    let exact = link_motion(chain, q, qd, &vec![0.0; dof]);
    let vel = kinechain::forward_velocities(chain, &mut data, q, qd).unwrap();
    let qd = kinechain::nalgebra::DVector::from_row_slice(qd);
    let (mut linear, mut angular, mut bias) = (0.0_f64, 0.0_f64, [0.0_f64; 2]);
    let mut largest = [f64::MIN_POSITIVE; 2];
    for (l, link) in chain.links().iter().enumerate() {
        let id = chain.link_id(link.name()).unwrap();
        let j = vel.poses().jacobian(id);
        for (i, column) in columns.iter().enumerate() {
            for k in 0..3 {
                linear = worse(linear, (j[(k, i)] - column[l].v[k]).abs());
                angular = worse(angular, (j[(3 + k, i)] - column[l].omega[k]).abs());
            }
        }
        let j_dot_qd = vel.jacobian_dot(id) * &qd;
        for k in 0..3 {
            for (m, (got, want)) in [
                (j_dot_qd[k], exact[l].a[k]),
                (j_dot_qd[3 + k], exact[l].alpha[k]),
            ]
            .into_iter()
            .enumerate()
            {
                bias[m] = worse(bias[m], (got - want).abs());
                largest[m] = largest[m].max(want.abs());
            }
        }
    }
    [
        linear / (reach * EPS),
        angular / EPS,
        (bias[0] / largest[0]).max(bias[1] / largest[1]) / EPS,
    ]
}

/// The geometric Jacobian and `J̇ q̇` of every link, on every reference model at its samples, on
/// every bundled robot and on random 10-joint chains at random states, against the 256-bit
/// recursion: within 8 ulps, the bound the poses are held to.
#[test]
fn jacobians_against_the_256_bit_recursion() {
    let mut worst = [0.0_f64; 3];
    let mut rng = rng(41);
    let mut check = |name: &str, chain: &Chain, q: &[f64], rng: &mut rand_chacha::ChaCha8Rng| {
        let qd = random_vec(chain.dof(), 1.0, rng);
        let reach = chain.reach().max(f64::MIN_POSITIVE);
        let e = jacobian_ulps(chain, q, &qd, reach);
        for (w, x) in worst.iter_mut().zip(e) {
            *w = worse(*w, x);
        }
        assert!(e.iter().all(|&x| x <= 8.0), "{name}: {e:?} ulps");
    };
    for path in reference_files() {
        let reference = read_json(&path);
        let chain = reference_chain(&path, &reference);
        for sample in reference["samples"].as_array().unwrap().iter().take(5) {
            let q = joint_vector(&chain, &sample["q"]);
            check(&path.display().to_string(), &chain, &q, &mut rng);
        }
    }
    for path in robot_files() {
        let chain = Chain::from_file(&path).unwrap();
        for _ in 0..3 {
            let q = random_q(&chain, &mut rng);
            check(&path.display().to_string(), &chain, &q, &mut rng);
        }
    }
    // Random 10-joint chains of revolute, prismatic and cylindrical joints on random axes.
    for seed in 0..4 {
        let chain = random_chain(10, 500 + seed, |_| 0.3, None);
        let q = random_vec(chain.dof(), 3.0, &mut rng);
        check(&format!("random chain {seed}"), &chain, &q, &mut rng);
    }
    eprintln!(
        "Jacobian, worst: linear rows {:.2} ulp of the reach, angular rows {:.2} ulp, J̇ q̇ {:.2} ulp",
        worst[0], worst[1], worst[2]
    );
}
