//! Motion of one link relative to another (`base=`): `Poses::base_from_link`,
//! `Poses::jacobian_relative`, `Velocities::velocity_relative` and
//! `Accelerations::acceleration_relative` against central differences of `base_from_link` along
//! a trajectory `q(t) = q + q̇ t + ½ q̈ t²`, on the floating G1 (hand relative to torso, foot
//! relative to pelvis) and the Panda (hand relative to link 3).

use crate::common::repo_chain;
use kinechain::nalgebra::{DVector, Matrix3, Vector3};
use kinechain::{
    Chain, Data, JacobianFrame, LimitPolicy, forward_accelerations, forward_kinematics,
};

/// The angular velocity `ω` with `Ṙ = ω^ R`, from `R(t ± h)` (in the axes of `R`'s frame).
fn omega_of(minus: &Matrix3<f64>, plus: &Matrix3<f64>, now: &Matrix3<f64>, h: f64) -> Vector3<f64> {
    let w = (plus - minus) / (2.0 * h) * now.transpose();
    Vector3::new(
        w[(2, 1)] - w[(1, 2)],
        w[(0, 2)] - w[(2, 0)],
        w[(1, 0)] - w[(0, 1)],
    ) * 0.5
}

fn check(chain: &Chain, pairs: &[(&str, &str)]) {
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let nq = chain.nq();
    let q = chain.random_configurations(1, 3, (-0.5, 0.5));
    let qd: Vec<f64> = (0..chain.nv())
        .map(|i| 0.3 * ((i as f64) * 0.7).sin())
        .collect();
    let qdd: Vec<f64> = (0..chain.nv())
        .map(|i| 0.2 * ((i as f64) * 1.3).cos())
        .collect();
    // q(t) for the joints without quaternions; a floating base's quaternion integrated from w.
    let at = |t: f64| -> Vec<f64> {
        let (mut out, mut v) = (q.clone(), 0);
        for j in chain.joints() {
            let (Some(qi), Some(_)) = (j.q_index(), j.v_index()) else {
                continue;
            };
            match j.kind() {
                kinechain::JointKind::Floating => {
                    for k in 0..3 {
                        out[qi + k] += qd[v + k] * t + 0.5 * qdd[v + k] * t * t;
                    }
                    // Angular velocity w(t) = w + ε t in world axes, the base frame's parent
                    // being the world: R(t) = exp(∫w) R(0) (w and ε parallel here: exact).
                    let w = Vector3::new(qd[v + 3], qd[v + 4], qd[v + 5]);
                    let e = Vector3::new(qdd[v + 3], qdd[v + 4], qdd[v + 5]);
                    let turn = w * t + e * (0.5 * t * t);
                    let r0 = kinechain::orientation::EulerParameters::from_vector(
                        &kinechain::nalgebra::Vector4::new(
                            q[qi + 3],
                            q[qi + 4],
                            q[qi + 5],
                            q[qi + 6],
                        ),
                    )
                    .to_matrix();
                    let r = kinechain::nalgebra::Rotation3::new(turn).into_inner() * r0;
                    let e = kinechain::orientation::EulerParameters::from_matrix(&r).as_vector();
                    out[qi + 3..qi + 7].copy_from_slice(e.as_slice());
                    v += 6;
                }
                kind => {
                    for k in 0..kind.dof() {
                        out[qi + k] += qd[v + k] * t + 0.5 * qdd[v + k] * t * t;
                    }
                    v += kind.dof();
                }
            }
        }
        out
    };
    let _ = nq;
    let h = 1e-4;
    for &(link, base) in pairs {
        let (l, b) = (chain.link_id(link).unwrap(), chain.link_id(base).unwrap());
        let rel = |t: f64, data: &mut Data| {
            forward_kinematics(chain, data, &at(t))
                .unwrap()
                .base_from_link(b, l)
        };
        let (m, z, p) = (rel(-h, &mut data), rel(0.0, &mut data), rel(h, &mut data));
        let v_fd = (p.translation() - m.translation()) / (2.0 * h);
        let w_fd = omega_of(&m.rotation(), &p.rotation(), &z.rotation(), h);
        let a_fd = (p.translation() - 2.0 * z.translation() + m.translation()) / (h * h);
        let acc = forward_accelerations(chain, &mut data, &q, &qd, &qdd).unwrap();
        let v = acc.velocity_relative(l, b);
        assert!(
            (v.v - v_fd).norm() < 1e-7,
            "{link}/{base}: v {} vs {}",
            v.v,
            v_fd
        );
        assert!(
            (v.omega - w_fd).norm() < 1e-7,
            "{link}/{base}: ω {} vs {}",
            v.omega,
            w_fd
        );
        let a = acc.acceleration_relative(l, b);
        assert!(
            (a.a - a_fd).norm() < 1e-5,
            "{link}/{base}: a {} vs {}",
            a.a,
            a_fd
        );
        // α: the rate of ω_rel (base axes), from ω_rel at ±h.
        let wrel = |t: f64, data: &mut Data| {
            let qt = at(t);
            let qdt: Vec<f64> = qd.iter().zip(&qdd).map(|(v, e)| v + e * t).collect();
            kinechain::forward_velocities(chain, data, &qt, &qdt)
                .unwrap()
                .velocity_relative(l, b)
                .omega
        };
        let alpha_fd = (wrel(h, &mut data) - wrel(-h, &mut data)) / (2.0 * h);
        let acc = forward_accelerations(chain, &mut data, &q, &qd, &qdd).unwrap();
        let a = acc.acceleration_relative(l, b);
        assert!(
            (a.alpha - alpha_fd).norm() < 1e-6,
            "{link}/{base}: α {} vs {}",
            a.alpha,
            alpha_fd
        );
        // J q̇ = the relative twist, with the point's velocity for a point.
        let poses = acc.poses();
        let j = poses.jacobian_relative(l, b, JacobianFrame::World);
        let twist = &j * DVector::from_row_slice(&qd);
        assert!((twist.fixed_rows::<3>(0) - v.v).norm() < 1e-12);
        assert!((twist.fixed_rows::<3>(3) - v.omega).norm() < 1e-12);
        let u = [0.0, 0.05, 0.1];
        let jp = poses.jacobian_relative(l, b, JacobianFrame::Point(u));
        let tp = &jp * DVector::from_row_slice(&qd);
        let r_u = z.rotation() * Vector3::from(u);
        assert!((tp.fixed_rows::<3>(0) - (v.v + v.omega.cross(&r_u))).norm() < 1e-12);
    }
}

#[test]
fn relative_poses_rates_and_jacobians_are_the_rates_of_base_from_link() {
    check(
        &repo_chain("robots/g1.urdf+floating"),
        &[
            ("left_rubber_hand", "torso_link"),
            ("right_ankle_roll_link", "pelvis"),
        ],
    );
    check(
        &repo_chain("robots/panda.urdf"),
        &[("panda_hand", "panda_link3")],
    );
}

#[test]
fn a_relative_jacobian_in_link_axes_is_the_base_axes_one_turned_into_the_link() {
    let chain = repo_chain("robots/panda.urdf");
    let (l, b) = (
        chain.link_id("panda_hand").unwrap(),
        chain.link_id("panda_link3").unwrap(),
    );
    let mut data = Data::new(&chain);
    let q = chain.random_configurations(1, 5, (-1.0, 1.0));
    let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
    let in_base = poses.jacobian_relative(l, b, JacobianFrame::World);
    let in_link = poses.jacobian_relative(l, b, JacobianFrame::Link);
    let turn: Matrix3<f64> = poses.base_from_link(b, l).rotation().transpose();
    for c in 0..chain.dof() {
        for half in [0, 3] {
            let want = turn
                * Vector3::new(
                    in_base[(half, c)],
                    in_base[(half + 1, c)],
                    in_base[(half + 2, c)],
                );
            for k in 0..3 {
                assert!((in_link[(half + k, c)] - want[k]).abs() < 1e-14);
            }
        }
    }
}
