//! Velocities and accelerations (eqs. 2.120–2.127): finite differences of poses on every bundled
//! robot, the joint's 4×4 forms against their vector forms, points on links (eqs. 2.52, 2.55,
//! 2.75), link-frame components, algebraic properties, a closed form, and the `k` Jacobian.

use crate::common::*;
use kinechain::nalgebra::{Matrix3, Vector3, Vector4};
use kinechain::{
    Chain, Data, LimitPolicy, LinkId, Transform, forward_accelerations, forward_kinematics,
    forward_velocities,
};
use proptest::prelude::*;

fn robots() -> Vec<(String, Chain)> {
    let mut out: Vec<(String, Chain)> = robot_files()
        .into_iter()
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, Chain::from_file(&p).unwrap())
        })
        .collect();
    out.push((
        "placed before and after".to_string(),
        placed_before_and_after(),
    ));
    out.push(("scaled mimics".to_string(), scaled_mimics()));
    out
}

/// A serial chain of links `l0`…`l5` joined by `joints` (name, kind, axis), each joint's spec
/// finished by `finish(index, spec)`.
fn five_joints(
    name: &str,
    joints: [(&str, kinechain::JointKind, [f64; 3]); 5],
    finish: impl Fn(usize, kinechain::JointSpec) -> kinechain::JointSpec,
) -> Chain {
    let mut b = kinechain::ChainBuilder::new(name);
    b.link("l0");
    for (i, (joint, kind, axis)) in joints.into_iter().enumerate() {
        let (parent, child) = (format!("l{i}"), format!("l{}", i + 1));
        b.link(child.clone());
        b.joint(finish(
            i,
            kinechain::JointSpec::new(joint, kind, parent, child).with_axis(axis),
        ));
    }
    b.build().unwrap()
}

/// Joints of every kind placed both before and after their motion, about z, y, x and a general
/// axis, one of them with nothing before it: the forms of the rate recursion that no robot file
/// gives (files place a joint on one side only).
fn placed_before_and_after() -> Chain {
    use kinechain::JointKind::{Cylindrical, Prismatic, Revolute};
    let origin = Transform::from_xyz_rpy([0.1, -0.2, 0.3], [0.4, -0.5, 0.6]);
    let post = Transform::from_xyz_rpy([0.2, 0.1, -0.1], [-0.3, 0.2, 0.7]);
    let joints = [
        ("j1", Revolute, [0.0, 0.0, 1.0]),
        ("j2", Prismatic, [0.0, 1.0, 0.0]),
        ("j3", Cylindrical, [0.6, 0.0, 0.8]),
        ("j4", Revolute, [1.0, 0.0, 0.0]),
        ("j5", Cylindrical, [0.0, 0.0, 1.0]),
    ];
    five_joints("placed", joints, |i, spec| {
        let spec = spec.with_post(post);
        if i == 3 {
            spec
        } else {
            spec.with_origin(origin)
        }
    })
}

/// Mimic joints whose multipliers are not ±1 (every bundled robot's are): a turning joint
/// following another at half its angle, a sliding one at −2.5 times another's travel, and one
/// following the first mimic (so its primary's entry at 0.5 · 3 = 1.5 times).
fn scaled_mimics() -> Chain {
    use kinechain::JointKind::{Prismatic, Revolute};
    let origin = Transform::from_xyz_rpy([0.3, 0.1, 0.2], [0.2, 0.3, -0.4]);
    let joints = [
        ("drive", Revolute, [0.0, 0.0, 1.0]),
        ("slide", Prismatic, [0.0, 1.0, 0.0]),
        ("half", Revolute, [0.6, 0.0, 0.8]),
        ("follow", Prismatic, [1.0, 0.0, 0.0]),
        ("triple", Revolute, [0.0, 1.0, 0.0]),
    ];
    five_joints("mimics", joints, |i, spec| {
        let spec = spec.with_origin(origin);
        match i {
            2 => spec.with_mimic("drive", 0.5, 0.3),
            3 => spec.with_mimic("slide", -2.5, 0.1),
            4 => spec.with_mimic("half", 3.0, -0.2),
            _ => spec,
        }
    })
}

/// Poses of every link along `q(t) = q + q̇ t + q̈ t²/2`.
fn poses_at(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    t: f64,
) -> Vec<Transform> {
    let qt: Vec<f64> = (0..q.len())
        .map(|i| q[i] + qd[i] * t + 0.5 * qdd[i] * t * t)
        .collect();
    let poses = forward_kinematics(chain, data, &qt).unwrap();
    (0..chain.links().len())
        .map(|i| poses.world_from_link(LinkId::from_index(chain, i)))
        .collect()
}

trait FromIndex {
    fn from_index(chain: &Chain, i: usize) -> LinkId;
}

impl FromIndex for LinkId {
    fn from_index(chain: &Chain, i: usize) -> LinkId {
        chain.link_id(chain.links()[i].name()).unwrap()
    }
}

/// The 12 numbers of a pose: 9 rotation entries then the translation.
fn flat(t: &Transform) -> [f64; 12] {
    let r = t.to_rows();
    [
        r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2], r[2][0], r[2][1], r[2][2], r[0][3],
        r[1][3], r[2][3],
    ]
}

/// Fourth-order central differences of every link's pose at step `h`: first and second time
/// derivatives, each 12 numbers per link.
fn differences(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    h: f64,
) -> (Vec<[f64; 12]>, Vec<[f64; 12]>) {
    let f: Vec<Vec<[f64; 12]>> = [-2.0, -1.0, 0.0, 1.0, 2.0]
        .iter()
        .map(|k| {
            poses_at(chain, data, q, qd, qdd, k * h)
                .iter()
                .map(flat)
                .collect()
        })
        .collect();
    let n = chain.links().len();
    let mut d1 = vec![[0.0; 12]; n];
    let mut d2 = vec![[0.0; 12]; n];
    for l in 0..n {
        for k in 0..12 {
            let (m2, m1, z, p1, p2) = (f[0][l][k], f[1][l][k], f[2][l][k], f[3][l][k], f[4][l][k]);
            d1[l][k] = (-p2 + 8.0 * p1 - 8.0 * m1 + m2) / (12.0 * h);
            d2[l][k] = (-p2 + 16.0 * p1 - 30.0 * z + 16.0 * m1 - m2) / (12.0 * h * h);
        }
    }
    (d1, d2)
}

/// `vee` of the skew part of `Ṙ Rᵀ` (eq. 2.27 gives ω; with R̈ it gives α, as `[ω]x²` is
/// symmetric).
fn vee_of_skew(dr: &[f64; 12], pose: &Transform) -> [f64; 3] {
    let dr = Matrix3::new(
        dr[0], dr[1], dr[2], dr[3], dr[4], dr[5], dr[6], dr[7], dr[8],
    );
    let w = dr * pose.rotation().transpose();
    [
        0.5 * (w[(2, 1)] - w[(1, 2)]),
        0.5 * (w[(0, 2)] - w[(2, 0)]),
        0.5 * (w[(1, 0)] - w[(0, 1)]),
    ]
}

/// Finite differences against the computed rates, for every link of every bundled robot at seeded
/// random states.
///
/// Tolerance, per quantity: the rounding bound of the stencil plus an estimate of its truncation
/// error. The poses are accurate to 16 ulp of the reach (measured ≤ 8, `tests/reference.rs`), and
/// the first-derivative stencil multiplies that by (1+8+8+1)/12 / h, the second-derivative one by
/// (1+16+30+16+1)/12 / h². The truncation error of a fourth-order stencil at h is 1/15 of the
/// change between steps h and 2h (Richardson); the test allows the whole change. ω and α come
/// from three products of entries of `Ṙ` or `R̈` with entries of R (|·| ≤ 1), so their bound is
/// three times that of an entry.
#[test]
fn rates_match_finite_differences_on_every_robot() {
    let mut rng = rng(3);
    for (name, chain) in robots() {
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let reach = chain.reach().max(1.0);
        let pose_error = 16.0 * f64::EPSILON * reach;
        for _ in 0..5 {
            let q = random_q(&chain, &mut rng);
            let qd = random_vec(chain.dof(), 1.0, &mut rng);
            let qdd = random_vec(chain.dof(), 1.0, &mut rng);
            let (h1, h2) = (1e-3, 1e-2);
            let (d1, _) = differences(&chain, &mut data, &q, &qd, &qdd, h1);
            let (d1_2h, _) = differences(&chain, &mut data, &q, &qd, &qdd, 2.0 * h1);
            let (_, d2) = differences(&chain, &mut data, &q, &qd, &qdd, h2);
            let (_, d2_2h) = differences(&chain, &mut data, &q, &qd, &qdd, 2.0 * h2);
            let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
            for l in 0..chain.links().len() {
                let id = LinkId::from_index(&chain, l);
                let pose = acc.world_from_link(id);
                let (v, a) = (acc.velocity(id), acc.acceleration(id));
                let tol1 = |k: usize| (d1[l][k] - d1_2h[l][k]).abs() + 1.5 * pose_error / h1;
                let tol2 = |k: usize| (d2[l][k] - d2_2h[l][k]).abs() + 5.4 * pose_error / (h2 * h2);
                let max_tol = |tol: &dyn Fn(usize) -> f64| (0..9).map(tol).fold(0.0, f64::max);
                let w_fd = vee_of_skew(&d1[l], &pose);
                let al_fd = vee_of_skew(&d2[l], &pose);
                for k in 0..3 {
                    let what = format!("{name} {} component {k}", chain.links()[l].name());
                    assert!((v.v[k] - d1[l][9 + k]).abs() <= tol1(9 + k), "v {what}");
                    assert!((a.a[k] - d2[l][9 + k]).abs() <= tol2(9 + k), "a {what}");
                    assert!(
                        (v.omega[k] - w_fd[k]).abs() <= 3.0 * max_tol(&tol1),
                        "omega {what}"
                    );
                    assert!(
                        (a.alpha[k] - al_fd[k]).abs() <= 3.0 * max_tol(&tol2),
                        "alpha {what}"
                    );
                }
            }
        }
    }
}

/// Eqs. (2.119), (2.122), (2.127) applied to a point equal the vector forms (2.118), (2.120),
/// (2.123)–(2.125), and `Ṫ`, `T̈` are the time derivatives of `T`.
#[test]
fn joint_4x4_forms_equal_the_vector_forms_and_differentiate_t() {
    let chain = Chain::from_file(robots_dir().join("cylindrical.yaml")).unwrap();
    let joint = chain.joint_id("joint").unwrap();
    let mut rng = rng(4);
    for _ in 0..50 {
        let q = random_vec(2, 3.0, &mut rng);
        let qd = random_vec(2, 2.0, &mut rng);
        let qdd = random_vec(2, 2.0, &mut rng);
        let u = random_vec(3, 1.0, &mut rng);
        let u = Vector3::new(u[0], u[1], u[2]);
        let s = chain.joint_screw(joint, &q, &qd, &qdd).unwrap();
        let v = s.axis.into_inner();
        let a = kinechain::orientation::rotation_matrix(&s.axis, s.theta);
        let k = kinechain::orientation::skew(&v);
        let uh = Vector4::new(u.x, u.y, u.z, 1.0);
        let r = v * s.d + a * u; // eq. (2.118)
        let r_dot = v * s.d_dot + k * a * u * s.theta_dot; // eq. (2.120)
        let r_ddot =
            v * s.d_ddot + a * (k * u * s.theta_ddot + k * k * u * s.theta_dot * s.theta_dot); // eq. (2.124)
        assert!(((s.transform() * uh).xyz() - r).norm() < 1e-14);
        assert!(((s.transform_dot() * uh).xyz() - r_dot).norm() < 1e-13);
        assert!(((s.transform_ddot() * uh).xyz() - r_ddot).norm() < 1e-12);
        // Eq. (2.125): the same as α × u + ω × (ω × u) in the joint frame, u = A ū.
        let (w, al, au) = (v * s.theta_dot, v * s.theta_ddot, a * u);
        assert!((v * s.d_ddot + al.cross(&au) + w.cross(&w.cross(&au)) - r_ddot).norm() < 1e-12);

        // T(t) along θ(t), d(t) with the given rates; central differences, step 1e-4. First
        // derivative: truncation h²/6 |T'''| with |T'''| up to θ̇³ ≈ 8 per entry, ≈ 1.3e-8 per
        // entry and a few times that over the 16 entries; rounding 1e-16/h = 1e-12. Second:
        // truncation h²/12 |T''''| ≈ 1.3e-8 per entry, rounding 4·1e-16/h² = 4e-8 per entry.
        let h = 1e-4;
        let t_at = |t: f64| {
            let th = s.theta + s.theta_dot * t + 0.5 * s.theta_ddot * t * t;
            let d = s.d + s.d_dot * t + 0.5 * s.d_ddot * t * t;
            kinechain::model::joint::joint_transform(&s.axis, th, d)
        };
        let dt = (t_at(h) - t_at(-h)) / (2.0 * h);
        let ddt = (t_at(h) - 2.0 * t_at(0.0) + t_at(-h)) / (h * h);
        assert!(
            (dt - s.transform_dot()).norm() < 2e-7,
            "{}",
            (dt - s.transform_dot()).norm()
        );
        assert!(
            (ddt - s.transform_ddot()).norm() < 1e-6,
            "{}",
            (ddt - s.transform_ddot()).norm()
        );
    }
}

/// Every joint's screw (θ and d from the joint's entry of `q`, its multiplier and offset for a
/// mimic joint, and its constant offsets) composes the link poses: the child's pose is the
/// parent's · origin · `T(θ, d)` (eq. 2.119) · post, within 4 ulp of the reach (measured: 1.9),
/// on every bundled robot and the chains built in code (mimic joints with offsets among them).
#[test]
fn joint_screws_compose_the_link_poses() {
    let mut rng = rng(41);
    let mut checked = 0;
    for (name, chain) in robots() {
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let reach = chain.reach().max(1.0);
        for _ in 0..3 {
            let q = random_q(&chain, &mut rng);
            let zero = vec![0.0; chain.dof()];
            let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
            // (A file may declare its joints in another order than depth first.)
            for joint in chain.joints() {
                let spec = chain
                    .description()
                    .joints()
                    .iter()
                    .find(|s| s.name == joint.name())
                    .unwrap();
                let id = chain.joint_id(joint.name()).unwrap();
                let screw = chain.joint_screw(id, &q, &zero, &zero).unwrap();
                let composed = poses.world_from_link(joint.parent()).to_homogeneous()
                    * spec.origin.to_homogeneous()
                    * screw.transform()
                    * spec.post.to_homogeneous();
                let child = poses.world_from_link(joint.child()).to_homogeneous();
                let error = (composed - child).abs().max();
                assert!(
                    error < 4.0 * f64::EPSILON * reach,
                    "{name} joint {}: {error:e}",
                    joint.name()
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 200, "{checked}");
}

/// The chain composes the joints' relative motion: for a one-joint chain the link's velocity
/// equals `Ṫ` applied to the origin, and ω = θ̇ v (eq. 2.116).
#[test]
fn chain_rates_compose_the_joint_forms() {
    let chain = Chain::from_file(robots_dir().join("cylindrical.yaml")).unwrap();
    let (joint, arm) = (
        chain.joint_id("joint").unwrap(),
        chain.link_id("arm").unwrap(),
    );
    let mut data = Data::new(&chain);
    let (q, qd, qdd) = ([0.7, 1.2], [2.0, -0.5], [-1.0, 0.3]);
    let s = chain.joint_screw(joint, &q, &qd, &qdd).unwrap();
    let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
    let origin = Vector4::new(0.0, 0.0, 0.0, 1.0);
    assert!((acc.velocity(arm).v - (s.transform_dot() * origin).xyz()).norm() < 1e-15);
    assert!((acc.acceleration(arm).a - (s.transform_ddot() * origin).xyz()).norm() < 1e-15);
    assert!((acc.velocity(arm).omega - s.axis.into_inner() * 2.0).norm() < 1e-15);
}

/// A point moving in a link (eq. 2.75): its computed velocity and acceleration equal finite
/// differences of `r(t) = R(t) + A(t) ū(t)`; its parts add up; a fixed point has no Coriolis or
/// local part.
#[test]
fn points_on_links_match_finite_differences() {
    let chain = Chain::from_file(robots_dir().join("puma560.yaml")).unwrap();
    let tool = chain.link_id("tool").unwrap();
    let mut data = Data::new(&chain);
    let mut rng = rng(5);
    for _ in 0..20 {
        let q = random_q(&chain, &mut rng);
        let qd = random_vec(6, 1.0, &mut rng);
        let qdd = random_vec(6, 1.0, &mut rng);
        let v = |r: &mut _| {
            let x = random_vec(3, 0.2, r);
            Vector3::new(x[0], x[1], x[2])
        };
        let (u, ud, udd) = (v(&mut rng), v(&mut rng), v(&mut rng));
        let r_at = |data: &mut Data, t: f64| {
            let qt: Vec<f64> = (0..6)
                .map(|i| q[i] + qd[i] * t + 0.5 * qdd[i] * t * t)
                .collect();
            let ut = u + ud * t + udd * (0.5 * t * t);
            forward_kinematics(&chain, data, &qt)
                .unwrap()
                .world_from_link(tool)
                .transform_point(&ut.into())
                .coords
        };
        let h = 1e-3;
        let f: Vec<Vector3<f64>> = [-2.0, -1.0, 0.0, 1.0, 2.0]
            .iter()
            .map(|k| r_at(&mut data, k * h))
            .collect();
        let d1 = (-f[4] + f[3] * 8.0 - f[1] * 8.0 + f[0]) / (12.0 * h);
        let d2 = (-f[4] + f[3] * 16.0 - f[2] * 30.0 + f[1] * 16.0 - f[0]) / (12.0 * h * h);
        let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
        let m = acc.moving_point(tool, &u, &ud, &udd);
        assert!((m.position - f[2]).norm() < 1e-15);
        // Five-point stencils, h = 1e-3: truncation h⁴/30 |r⁽⁵⁾| and h⁴/90 |r⁽⁶⁾| (3e-14 and 1e-14
        // times derivatives of order 1–10); rounding ≈ 1.5 ε |r| / h ≈ 3e-13 and
        // ≈ 5 ε |r| / h² ≈ 1e-9 for |r| ≈ 1 m. Bounds: about ten times those.
        assert!(
            (m.velocity - d1).norm() < 3e-11,
            "{}",
            (m.velocity - d1).norm()
        );
        assert!(
            (m.acceleration - d2).norm() < 1e-8,
            "{}",
            (m.acceleration - d2).norm()
        );
        let p = m.parts;
        let sum = p.origin + p.tangential + p.normal + p.coriolis + p.local;
        assert_eq!(sum, m.acceleration);
        let fixed = acc.point(tool, &u);
        assert_eq!(fixed.parts.coriolis, Vector3::zeros());
        assert_eq!(fixed.parts.local, Vector3::zeros());
        assert_eq!(fixed.parts.tangential, p.tangential);
        assert_eq!(fixed.parts.normal, p.normal);
        // The moving point's Coriolis term is 2 ω × (A u̇).
        let w = acc.velocity(tool).omega;
        let a = acc.world_from_link(tool).rotation();
        assert!((p.coriolis - 2.0 * w.cross(&(a * ud))).norm() < 1e-15);
    }
}

/// Link-frame components: `ω̄ = Aᵀω` is the vee of `AᵀȦ` (eq. 2.29).
#[test]
fn local_components() {
    let chain = Chain::from_file(robots_dir().join("iiwa7.yaml")).unwrap();
    let flange = chain.link_id("flange").unwrap();
    let mut data = Data::new(&chain);
    let mut rng = rng(6);
    let q = random_q(&chain, &mut rng);
    let qd = random_vec(7, 1.0, &mut rng);
    let h = 1e-6;
    let at = |data: &mut Data, t: f64| {
        let qt: Vec<f64> = (0..7).map(|i| q[i] + qd[i] * t).collect();
        forward_kinematics(&chain, data, &qt)
            .unwrap()
            .world_from_link(flange)
            .rotation()
    };
    let a_dot = (at(&mut data, h) - at(&mut data, -h)) / (2.0 * h);
    let a = at(&mut data, 0.0);
    let w_bar = a.transpose() * a_dot; // [ω̄]x
    let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qd).unwrap();
    let local = acc.velocity_local(flange);
    let want = Vector3::new(w_bar[(2, 1)], w_bar[(0, 2)], w_bar[(1, 0)]);
    // Central difference, h = 1e-6: truncation h²/6 |A'''| ≈ 1e-12, rounding ε / h ≈ 2e-10.
    assert!((local.omega - want).norm() < 1e-9);
    assert!((local.v - a.transpose() * acc.velocity(flange).v).norm() < 1e-15);
    let la = acc.acceleration_local(flange);
    assert!((la.alpha - a.transpose() * acc.acceleration(flange).alpha).norm() < 1e-14);
    assert!((la.a - a.transpose() * acc.acceleration(flange).a).norm() < 1e-14);
}

/// The planar three-link arm against its closed form.
#[test]
fn planar_arm_closed_form() {
    let chain = Chain::from_file(robots_dir().join("planar3.yaml")).unwrap();
    let tip = chain.link_id("link3").unwrap();
    let mut data = Data::new(&chain);
    let lengths = [4.0, 3.0, 2.0];
    let mut rng = rng(8);
    for _ in 0..100 {
        let q = random_q(&chain, &mut rng);
        let qd = random_vec(3, 2.0, &mut rng);
        let qdd = random_vec(3, 2.0, &mut rng);
        let (mut x, mut y, mut vx, mut vy, mut ax, mut ay) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let (mut phi, mut w, mut al) = (0.0, 0.0, 0.0);
        for k in 0..3 {
            phi += q[k];
            w += qd[k];
            al += qdd[k];
            let (s, c) = f64::sin_cos(phi);
            x += lengths[k] * c;
            y += lengths[k] * s;
            vx -= lengths[k] * s * w;
            vy += lengths[k] * c * w;
            ax -= lengths[k] * (c * w * w + s * al);
            ay += lengths[k] * (c * al - s * w * w);
        }
        let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
        let p = acc.world_from_link(tip).translation();
        let (v, a) = (acc.velocity(tip), acc.acceleration(tip));
        let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-14 * scale;
        assert!(close(p.x, x, 9.0) && close(p.y, y, 9.0) && p.z == 0.0);
        assert!(close(v.v.x, vx, 60.0) && close(v.v.y, vy, 60.0) && v.v.z == 0.0);
        assert!(close(a.a.x, ax, 500.0) && close(a.a.y, ay, 500.0));
        assert_eq!([v.omega.x, v.omega.y], [0.0, 0.0]);
        assert!(close(v.omega.z, w, 6.0) && close(a.alpha.z, al, 6.0));
    }
}

fn vel_of(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    qd: &[f64],
    link: LinkId,
) -> [Vector3<f64>; 2] {
    let v = forward_velocities(chain, data, q, qd)
        .unwrap()
        .velocity(link);
    [v.omega, v.v]
}

proptest! {
    // A fixed seed: the same cases on every run.
    #![proptest_config(ProptestConfig {
        cases: 64,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x7261_7465),
        ..ProptestConfig::default()
    })]

    /// v and ω are linear in q̇; with q̇ = 0, α and a are linear in q̈; the base is at rest.
    #[test]
    fn rates_are_linear_and_the_base_is_at_rest(
        robot in 0usize..12,
        seed in any::<u64>(),
        a in -3.0f64..3.0,
        b in -3.0f64..3.0,
    ) {
        let all = robots();
        let (_, chain) = &all[robot % all.len()];
        let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
        let mut r = rng(seed);
        let q = random_q(chain, &mut r);
        let x = random_vec(chain.dof(), 1.0, &mut r);
        let y = random_vec(chain.dof(), 1.0, &mut r);
        let combo: Vec<f64> = x.iter().zip(&y).map(|(x, y)| a * x + b * y).collect();
        let zero = vec![0.0; chain.dof()];
        let tip = chain.end_link();
        let scale = chain.reach().max(1.0) * chain.dof() as f64;
        let [wx, vx] = vel_of(chain, &mut data, &q, &x, tip);
        let [wy, vy] = vel_of(chain, &mut data, &q, &y, tip);
        let [wc, vc] = vel_of(chain, &mut data, &q, &combo, tip);
        let tol = 1e-13 * scale * (a.abs() + b.abs() + 1.0);
        prop_assert!((wc - (wx * a + wy * b)).norm() <= tol);
        prop_assert!((vc - (vx * a + vy * b)).norm() <= tol);

        let acc_of = |data: &mut Data, qdd: &[f64]| {
            let acc = forward_accelerations(chain, data, &q, &zero, qdd).unwrap();
            let l = acc.acceleration(tip);
            [l.alpha, l.a]
        };
        let [alx, ax] = acc_of(&mut data, &x);
        let [aly, ay] = acc_of(&mut data, &y);
        let [alc, ac] = acc_of(&mut data, &combo);
        prop_assert!((alc - (alx * a + aly * b)).norm() <= tol);
        prop_assert!((ac - (ax * a + ay * b)).norm() <= tol);

        let acc = forward_accelerations(chain, &mut data, &q, &x, &y).unwrap();
        let base = LinkId::from_index(chain, 0);
        prop_assert_eq!(acc.velocity(base).omega, Vector3::zeros());
        prop_assert_eq!(acc.velocity(base).v, Vector3::zeros());
        prop_assert_eq!(acc.acceleration(base).alpha, Vector3::zeros());
        prop_assert_eq!(acc.acceleration(base).a, Vector3::zeros());
    }
}

/// For every leaf link of every URDF `k` loads: the link's twist equals `k`'s Jacobian times q̇,
/// and `Poses::jacobian` equals `k`'s Jacobian times the map from q̇ to the rates of the joints on
/// the link's path (mimic joints follow their primary), both to 2e-14 (the two differ by at most
/// 4.4e-15 on these arms, whose reach is below 2 m).
#[test]
fn end_link_jacobian_and_twist_match_k() {
    let files = k_urdf_files();
    let mut rng = rng(9);
    let mut checked = 0;
    for path in files {
        let chain = Chain::from_file(&path).unwrap();
        let robot = k::Chain::<f64>::from_urdf_file(&path).unwrap();
        let mut data = Data::new(&chain);
        let leaves: Vec<usize> = (0..chain.links().len())
            .filter(|&l| chain.joints().iter().all(|j| j.parent().index() != l))
            .collect();
        for _ in 0..10 {
            let q = random_q(&chain, &mut rng);
            let qd = random_vec(chain.dof(), 1.0, &mut rng);
            let vel = forward_velocities(&chain, &mut data, &q, &qd).unwrap();
            for &leaf in &leaves {
                let name = chain.links()[leaf].name();
                let Some(node) = robot.find_link(name) else {
                    continue;
                };
                let arm = k::SerialChain::from_end(node);
                // k's joint vector along the path, from our q (mimic joints follow their primary).
                let ids: Vec<_> = arm
                    .iter_joints()
                    .map(|j| chain.joint_id(&j.name).unwrap())
                    .collect();
                let positions: Vec<f64> = ids
                    .iter()
                    .map(|&id| chain.joint_position(id, &q).unwrap())
                    .collect();
                let rates: Vec<f64> = ids
                    .iter()
                    .map(|&id| {
                        let s = chain.joint_screw(id, &q, &qd, &qd).unwrap();
                        s.theta_dot + s.d_dot
                    })
                    .collect();
                arm.set_joint_positions(&positions).unwrap();
                let jac = k::jacobian(&arm);
                let twist = &jac * k::nalgebra::DVector::from_vec(rates);
                let link = chain.link_id(name).unwrap();
                let ours = vel.velocity(link);
                // Column i of the map: the path joints' rates when only q̇[i] is 1.
                let map = k::nalgebra::DMatrix::from_fn(ids.len(), chain.dof(), |row, i| {
                    let mut unit = vec![0.0; chain.dof()];
                    unit[i] = 1.0;
                    let s = chain.joint_screw(ids[row], &q, &unit, &unit).unwrap();
                    s.theta_dot + s.d_dot
                });
                let expected = &jac * map;
                let jacobian = vel.poses().jacobian(link);
                for (row, col) in (0..6).flat_map(|r| (0..chain.dof()).map(move |c| (r, c))) {
                    assert!(
                        (jacobian[(row, col)] - expected[(row, col)]).abs() < 2e-14,
                        "{} {name} J[({row}, {col})]: {} against k's {}",
                        path.display(),
                        jacobian[(row, col)],
                        expected[(row, col)]
                    );
                }
                for i in 0..3 {
                    assert!(
                        (twist[i] - ours.v[i]).abs() < 2e-14,
                        "{} {name} v",
                        path.display()
                    );
                    assert!(
                        (twist[3 + i] - ours.omega[i]).abs() < 2e-14,
                        "{} {name} ω",
                        path.display()
                    );
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 100, "{checked}");
}

/// The geometric Jacobian of every link of every bundled robot (mimic and cylindrical joints,
/// fixed links, links off the path of some joints): `J q̇` is the link's twist from the
/// velocity recursion (to 2e-15 of the chain's reach per unit rate and joint, about nine
/// rounding errors), and each column is the central difference of the link's pose in that entry
/// of `q` (to 1e-8): its position's for the linear rows, `vee(dR/dq Rᵀ)` for the angular ones.
#[test]
fn jacobian_columns_are_twists_per_unit_rate() {
    let mut rng = rng(31);
    let mut checked = 0;
    for (name, chain) in robots() {
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let reach = (0..chain.links().len())
            .map(|l| {
                let q = vec![0.0; chain.dof()];
                let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
                poses
                    .world_from_link(LinkId::from_index(&chain, l))
                    .translation()
                    .norm()
            })
            .fold(1.0, f64::max);
        let mut j = kinechain::nalgebra::Matrix6xX::zeros(0);
        for _ in 0..3 {
            let q = random_q(&chain, &mut rng);
            let qd = random_vec(chain.dof(), 1.0, &mut rng);
            let twists: Vec<_> = {
                let vel = forward_velocities(&chain, &mut data, &q, &qd).unwrap();
                (0..chain.links().len())
                    .map(|l| vel.velocity(LinkId::from_index(&chain, l)))
                    .collect()
            };
            let jacobians: Vec<_> = {
                let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
                (0..chain.links().len())
                    .map(|l| {
                        poses.jacobian_into(LinkId::from_index(&chain, l), &mut j);
                        j.clone()
                    })
                    .collect()
            };
            let h = 1e-6;
            for i in 0..chain.dof() {
                let mut q_plus = q.clone();
                let mut q_minus = q.clone();
                q_plus[i] += h;
                q_minus[i] -= h;
                let plus = poses_at(&chain, &mut data, &q_plus, &qd, &qd, 0.0);
                let minus = poses_at(&chain, &mut data, &q_minus, &qd, &qd, 0.0);
                let centre = poses_at(&chain, &mut data, &q, &qd, &qd, 0.0);
                for l in 0..chain.links().len() {
                    let column = jacobians[l].column(i);
                    let dp = (plus[l].translation() - minus[l].translation()) / (2.0 * h);
                    let dr = (plus[l].rotation() - minus[l].rotation()) / (2.0 * h)
                        * centre[l].rotation().transpose();
                    let omega = Vector3::new(dr[(2, 1)], dr[(0, 2)], dr[(1, 0)]);
                    for k in 0..3 {
                        assert!(
                            (column[k] - dp[k]).abs() < 1e-8 * reach,
                            "{name} link {l} q[{i}]: linear {column} against {dp}"
                        );
                        assert!(
                            (column[3 + k] - omega[k]).abs() < 1e-8,
                            "{name} link {l} q[{i}]: angular {column} against {omega}"
                        );
                    }
                }
            }
            let qd = kinechain::nalgebra::DVector::from_column_slice(&qd);
            let rate = qd.amax().max(1e-300);
            for (l, (jl, twist)) in jacobians.iter().zip(&twists).enumerate() {
                let ours = jl * &qd;
                for k in 0..3 {
                    assert!(
                        (ours[k] - twist.v[k]).abs() < 2e-15 * reach * rate * chain.dof() as f64,
                        "{name} link {l}: v {ours} against {}",
                        twist.v
                    );
                    assert!(
                        (ours[3 + k] - twist.omega[k]).abs() < 2e-15 * rate * chain.dof() as f64,
                        "{name} link {l}: ω {ours} against {}",
                        twist.omega
                    );
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 300, "{checked}");
}

/// The Jacobian's time derivative on every link of every bundled robot: `J q̈ + J̇ q̇` is the
/// link's classical acceleration and angular acceleration from the recursion (to 2e-15 of the
/// reach per unit rate² and joint, about nine rounding errors), and `J̇` is the central
/// difference of `J` along `q̇`, `(J(q + h q̇) − J(q − h q̇)) / 2h` (to 1e-8 of the reach per unit
/// rate, for h = 1e-6, where rounding alone is about 1e-10).
#[test]
fn jacobian_derivative_gives_the_acceleration_and_the_jacobian_rate() {
    use kinechain::nalgebra::{DVector, Matrix6xX};
    let mut rng = rng(37);
    let mut checked = 0;
    for (name, chain) in robots() {
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let (reach, dof) = (chain.reach().max(1.0), chain.dof() as f64);
        let links: Vec<LinkId> = (0..chain.links().len())
            .map(|l| LinkId::from_index(&chain, l))
            .collect();
        let jacobians_at = |data: &mut Data, q: &[f64]| -> Vec<Matrix6xX<f64>> {
            let poses = forward_kinematics(&chain, data, q).unwrap();
            links.iter().map(|&l| poses.jacobian(l)).collect()
        };
        for _ in 0..3 {
            let q = random_q(&chain, &mut rng);
            let qd = random_vec(chain.dof(), 1.0, &mut rng);
            let qdd = random_vec(chain.dof(), 1.0, &mut rng);
            let h = 1e-6;
            let step = |sign: f64| -> Vec<f64> {
                q.iter().zip(&qd).map(|(x, v)| x + sign * h * v).collect()
            };
            let plus = jacobians_at(&mut data, &step(1.0));
            let minus = jacobians_at(&mut data, &step(-1.0));
            let jacobians = jacobians_at(&mut data, &q);
            let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
            let rate = qd
                .iter()
                .chain(&qdd)
                .fold(1e-300_f64, |m, x| m.max(x.abs()));
            let (qd_v, qdd_v) = (DVector::from_row_slice(&qd), DVector::from_row_slice(&qdd));
            let mut j_dot = Matrix6xX::zeros(0);
            for (i, &link) in links.iter().enumerate() {
                acc.velocities().jacobian_dot_into(link, &mut j_dot);
                let difference = (&plus[i] - &minus[i]) / (2.0 * h);
                let worst = (&j_dot - &difference).amax();
                assert!(
                    worst < 1e-8 * reach * rate,
                    "{name} link {i}: J̇ {j_dot} against differences {difference}"
                );
                let motion = &jacobians[i] * &qdd_v + &j_dot * &qd_v;
                let expected = acc.acceleration(link);
                for k in 0..3 {
                    let bound = 2e-15 * reach * rate * rate * dof;
                    assert!(
                        (motion[k] - expected.a[k]).abs() < bound,
                        "{name} link {i}: a {motion} against {}",
                        expected.a
                    );
                    assert!(
                        (motion[3 + k] - expected.alpha[k]).abs() < bound,
                        "{name} link {i}: α {motion} against {}",
                        expected.alpha
                    );
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 300, "{checked}");
}
