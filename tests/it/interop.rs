//! nalgebra interop (transforms, quaternions) and the chain's limit vectors and neutral
//! configuration.

use crate::common::{MIMIC_GRIPPER, random_q, rng, robot_files};
use kinechain::nalgebra::{Isometry3, IsometryMatrix3, Matrix4, UnitQuaternion, Vector3};
use kinechain::orientation::EulerParameters;
use kinechain::{Chain, LimitPolicy, StateError, Transform, check_q, forward_kinematics};

/// Largest entry difference of two 4×4 matrices.
fn max_diff(a: &Matrix4<f64>, b: &Matrix4<f64>) -> f64 {
    (a - b).abs().max()
}

#[test]
fn transforms_convert_to_and_from_nalgebra() {
    let chain = crate::common::repo_chain("robots/panda.urdf");
    let mut r = rng(7);
    let mut data = kinechain::Data::new(&chain);
    for _ in 0..50 {
        let q = random_q(&chain, &mut r);
        let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
        for link in crate::common::link_ids(&chain) {
            let t = poses.world_from_link(link);
            let m: Matrix4<f64> = t.into();
            assert_eq!(m, t.to_homogeneous());
            assert_eq!(Transform::try_from(m).unwrap(), t);
            // The rotation-matrix isometry holds the same numbers.
            let iso: IsometryMatrix3<f64> = t.into();
            assert_eq!(iso.to_homogeneous(), m);
            assert_eq!(Transform::from(iso), t);
            // The quaternion isometry is the same rotation to a few ulps, and its round trip too.
            let iso: Isometry3<f64> = t.into();
            assert!(
                max_diff(&iso.to_homogeneous(), &m) <= 4.0 * f64::EPSILON,
                "{t:?}"
            );
            let back = Transform::from(iso);
            assert!(max_diff(&back.to_homogeneous(), &m) <= 4.0 * f64::EPSILON);
            assert_eq!(back.translation(), t.translation());
            // Points map the same way.
            let p = kinechain::nalgebra::Point3::new(0.1, -0.2, 0.3);
            assert!((iso.transform_point(&p) - t.transform_point(&p)).norm() <= 1e-15);
        }
    }
    // A matrix that is not rigid is refused.
    let mut m = Matrix4::identity();
    m[(0, 0)] = 2.0;
    assert!(Transform::try_from(m).is_err());
}

#[test]
fn euler_parameters_are_nalgebra_quaternions() {
    let axis = kinechain::nalgebra::Unit::new_normalize(Vector3::new(0.3, -1.0, 0.5));
    for angle in [0.0, 1e-9, 0.7, 3.0, std::f64::consts::PI] {
        let e = EulerParameters::from_axis_angle(&axis, angle);
        let q: UnitQuaternion<f64> = e.into();
        assert_eq!((q.w, q.i, q.j, q.k), (e.e0, e.e1, e.e2, e.e3));
        let diff = (q.to_rotation_matrix().into_inner() - e.to_matrix())
            .abs()
            .max();
        assert!(diff <= 2.0 * f64::EPSILON, "{angle}: {diff}");
        assert_eq!(EulerParameters::from(q), e);
        assert_eq!(
            Transform::from(q).rotation(),
            e.to_matrix(),
            "a quaternion's transform is its Euler parameters' matrix"
        );
    }
    // Parameters off the unit sphere are normalised.
    let e = EulerParameters {
        e0: 2.0,
        e1: 0.0,
        e2: 0.0,
        e3: 0.0,
    };
    assert_eq!(UnitQuaternion::from(e), UnitQuaternion::identity());
}

#[test]
fn the_neutral_configuration_and_the_limit_bounds_pass_the_limit_checks() {
    let mut chains: Vec<(String, Chain)> = robot_files()
        .iter()
        .map(|p| (p.display().to_string(), Chain::from_file(p).unwrap()))
        .collect();
    chains.push((
        "gripper".into(),
        Chain::from_urdf_str(MIMIC_GRIPPER).unwrap(),
    ));
    for (name, chain) in &chains {
        let (lower, upper, neutral) = (chain.lower(), chain.upper(), chain.neutral());
        assert_eq!(
            (lower.len(), upper.len(), neutral.len()),
            (chain.dof(), chain.dof(), chain.dof())
        );
        check_q(chain, &neutral, LimitPolicy::Enforce).unwrap_or_else(|e| panic!("{name}: {e}"));
        for i in 0..chain.dof() {
            assert!(
                lower[i] <= neutral[i] && neutral[i] <= upper[i],
                "{name} q[{i}]"
            );
            // Each finite bound is admitted, and the next number beyond it is not.
            for (bound, beyond) in [
                (lower[i], lower[i].next_down()),
                (upper[i], upper[i].next_up()),
            ] {
                if !bound.is_finite() {
                    continue;
                }
                let mut q = neutral.clone();
                q[i] = bound;
                check_q(chain, &q, LimitPolicy::Enforce)
                    .unwrap_or_else(|e| panic!("{name} q[{i}] = {bound}: {e}"));
                q[i] = beyond;
                assert!(
                    matches!(
                        check_q(chain, &q, LimitPolicy::Enforce),
                        Err(StateError::OutOfLimits { .. })
                    ),
                    "{name} q[{i}] = {beyond} passes"
                );
            }
        }
    }
}

#[test]
fn a_mimic_joint_s_limits_narrow_its_primary_s_range() {
    // The follower turns twice as far, offset by 0.1, and is limited to [-1, 1]: the primary's
    // own [-2, 2] narrows to [-0.55, 0.45]; 0 stays neutral.
    let urdf = r#"<robot name="m">
      <link name="a"/><link name="b"/><link name="c"/>
      <joint name="p" type="revolute"><parent link="a"/><child link="b"/>
        <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
      <joint name="f" type="revolute"><parent link="b"/><child link="c"/>
        <mimic joint="p" multiplier="2" offset="0.1"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    </robot>"#;
    let chain = Chain::from_urdf_str(urdf).unwrap();
    assert!(
        (chain.lower()[0] + 0.55).abs() <= 1e-15,
        "{:?}",
        chain.lower()
    );
    assert!(
        (chain.upper()[0] - 0.45).abs() <= 1e-15,
        "{:?}",
        chain.upper()
    );
    assert_eq!(chain.neutral(), vec![0.0]);
    // Limits that exclude 0 put the neutral value in the middle.
    let urdf = urdf.replace(r#"lower="-1" upper="1""#, r#"lower="0.5" upper="1.5""#);
    let chain = Chain::from_urdf_str(&urdf).unwrap();
    let n = chain.neutral()[0];
    assert!((n - 0.45).abs() <= 1e-15, "{n}");
}
