//! The worked examples of Shabana, *Dynamics of Multibody Systems*, ch. 2, through the library.
//! The book prints 4–5 significant digits, so results are compared at half a unit of the last
//! printed digit.

use kinechain::nalgebra::Vector3;
use kinechain::{
    Chain, ChainBuilder, Data, JointKind, JointSpec, Transform, forward_kinematics,
    forward_velocities,
};

fn assert_close(got: [f64; 3], want: [f64; 3], tol: f64, what: &str) {
    for k in 0..3 {
        assert!(
            (got[k] - want[k]).abs() <= tol,
            "{what}: got {got:?}, book {want:?} (tolerance {tol})"
        );
    }
}

fn cylindrical_arm() -> Chain {
    Chain::from_file(crate::common::robots_dir().join("cylindrical.yaml")).unwrap()
}

/// Ex. 2.2: cylindrical joint about v = (1,1,1)/√3, θ = 30°, d = 3 m; P at ū = (0,1,0).
#[test]
fn example_2_2_cylindrical_joint_position() {
    let chain = cylindrical_arm();
    let mut data = Data::new(&chain);
    let q = [30f64.to_radians(), 3.0];
    let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
    let arm = poses.world_from_link(chain.link_id("arm").unwrap());
    let a = arm.rotation();
    let book = [
        [0.91068, -0.24402, 0.33334],
        [0.33334, 0.91068, -0.24402],
        [-0.24402, 0.33334, 0.91068],
    ];
    // The book computes with √3 rounded, which puts its 0.33334 one unit of the last digit
    // away from the exact 1/3; every other entry agrees to the printed digits.
    for i in 0..3 {
        assert_close([a[(i, 0)], a[(i, 1)], a[(i, 2)]], book[i], 1e-5, "A (book)");
    }
    // Exact (eq. 2.112 with v = (1,1,1)/√3): diagonal c + (1−c)/3, off-diagonal (1−c)/3 ± s/√3.
    let (s30, c30) = 30f64.to_radians().sin_cos();
    let (diag, plus, minus) = (
        c30 + (1.0 - c30) / 3.0,
        (1.0 - c30) / 3.0 + s30 / 3f64.sqrt(),
        (1.0 - c30) / 3.0 - s30 / 3f64.sqrt(),
    );
    let exact = [
        [diag, minus, plus],
        [plus, diag, minus],
        [minus, plus, diag],
    ];
    for i in 0..3 {
        assert_close(
            [a[(i, 0)], a[(i, 1)], a[(i, 2)]],
            exact[i],
            4e-16,
            "A (exact)",
        );
    }
    // R = √3 (1,1,1): the origin translated 3 m along v.
    let s = 3f64.sqrt();
    assert_close(arm.translation().into(), [s, s, s], 1e-15, "R");
    // The book rounds √3 and prints (1.48808, 2.64278, 2.06544); exact to 5 decimals:
    let p = poses
        .world_from_link(chain.link_id("P").unwrap())
        .translation();
    assert_close(p.into(), [1.48803, 2.64273, 2.06538], 5e-6, "r_P");
}

/// Ex. 2.3: r = (2,3,4) rotated 45° about (1,1,1)/√3.
#[test]
fn example_2_3_rotation_about_an_axis() {
    let mut b = ChainBuilder::new("example_2_3");
    b.link("frame").link("body").link("point");
    b.joint(
        JointSpec::new("rotation", JointKind::Continuous, "frame", "body")
            .with_axis([1.0, 1.0, 1.0]),
    );
    b.joint(
        JointSpec::new("r", JointKind::Fixed, "body", "point")
            .with_origin(Transform::from_translation(Vector3::new(2.0, 3.0, 4.0))),
    );
    let chain = b.build().unwrap();
    let mut data = Data::new(&chain);
    let poses = forward_kinematics(&chain, &mut data, &[45f64.to_radians()]).unwrap();
    let r = poses
        .world_from_link(chain.link_id("point").unwrap())
        .translation();
    // Exact, by Rodrigues (eq. 2.9): c r + s (v × r) + (1 − c)(v·r) v with v·r v = (3,3,3) and
    // v × r = (1,−2,1)/√3.
    let (s45, c45) = 45f64.to_radians().sin_cos();
    let k = s45 / 3f64.sqrt();
    let exact = [
        2.0 * c45 + k + 3.0 * (1.0 - c45),
        3.0 * c45 - 2.0 * k + 3.0 * (1.0 - c45),
        4.0 * c45 + k + 3.0 * (1.0 - c45),
    ];
    assert_close(r.into(), exact, 1e-15, "rotated r (exact)");
    assert_close(r.into(), [2.70114, 2.18350, 4.11536], 5e-6, "rotated r");
    // The book multiplies a matrix rounded to 4 digits and prints (2.7010, 2.1836, 4.1154),
    // within 1.5e-4 of the exact values.
    assert_close(
        r.into(),
        [2.7010, 2.1836, 4.1154],
        1.5e-4,
        "rotated r (book)",
    );
    // A rotation keeps lengths.
    assert!((r.norm() - 29f64.sqrt()).abs() < 1e-14);
}

/// Ex. 2.11: body at R = (1,1,−5) rotated 30° about X3; P at ū = (0,1,0); and the inverse
/// transform (eq. 2.110), whose translation is −AᵀR.
#[test]
fn example_2_11_homogeneous_transform_and_inverse() {
    let mut b = ChainBuilder::new("example_2_11");
    b.link("ground").link("body").link("P");
    b.world_from_root(Transform::IDENTITY);
    b.joint(
        JointSpec::new("rotation", JointKind::Continuous, "ground", "body")
            .with_origin(Transform::from_translation(Vector3::new(1.0, 1.0, -5.0))),
    );
    b.joint(
        JointSpec::new("u", JointKind::Fixed, "body", "P")
            .with_origin(Transform::from_translation(Vector3::new(0.0, 1.0, 0.0))),
    );
    let chain = b.build().unwrap();
    let mut data = Data::new(&chain);
    let poses = forward_kinematics(&chain, &mut data, &[30f64.to_radians()]).unwrap();
    let p = poses
        .world_from_link(chain.link_id("P").unwrap())
        .translation();
    assert_close(p.into(), [0.5, 1.8660, -5.0], 5e-5, "r_P");
    let body = poses.world_from_link(chain.link_id("body").unwrap());
    assert_close(
        body.inverse().translation().into(),
        [-1.3660, -0.3660, 5.0],
        5e-5,
        "inverse",
    );
    let identity = body * body.inverse();
    assert!(identity.orthonormality_error() < 1e-15);
    assert!(identity.translation().norm() < 1e-15);
}

/// Ex. 2.8: the arm of Ex. 2.2 translating at 2 m/s and turning at 5 rad/s about the joint axis:
/// velocity of P at θ = 30°.
#[test]
fn example_2_8_cylindrical_joint_velocity() {
    let chain = cylindrical_arm();
    let mut data = Data::new(&chain);
    // Position along the axis does not change P's velocity; take d = 3 m as in Ex. 2.2.
    let q = [30f64.to_radians(), 3.0];
    let vel = forward_velocities(&chain, &mut data, &q, &[5.0, 2.0]).unwrap();
    let p = vel.velocity(chain.link_id("P").unwrap());
    // The book prints (−0.512, −0.512, 4.4881); exact to 5 decimals:
    assert_close(
        p.v.into(),
        [-0.51197, -0.51197, 4.48803],
        5e-6,
        "velocity of P",
    );
    // ω = θ̇ v (eq. 2.116).
    let w = 5.0 / 3f64.sqrt();
    assert_close(p.omega.into(), [w, w, w], 1e-14, "omega");
}

/// Ex. 2.7: a body turning at θ̇ = 10 rad/s about (1,1,1)/√3 has ω = ω̄ = (5.773, 5.773, 5.773).
#[test]
fn example_2_7_angular_velocity_about_a_fixed_axis() {
    let mut b = ChainBuilder::new("example_2_7");
    b.link("frame").link("body");
    b.joint(
        JointSpec::new("spin", JointKind::Continuous, "frame", "body").with_axis([1.0, 1.0, 1.0]),
    );
    let chain = b.build().unwrap();
    let mut data = Data::new(&chain);
    // At t = 0.1 s the body has turned θ = 1 rad.
    let vel = forward_velocities(&chain, &mut data, &[1.0], &[10.0]).unwrap();
    let body = chain.link_id("body").unwrap();
    let w = vel.velocity(body).omega;
    // ω = θ̇ v = 10/√3 (1,1,1); the book prints 5.773 (truncated).
    let exact = 10.0 / 3f64.sqrt();
    assert_close(w.into(), [exact; 3], 1e-14, "omega");
    assert_close(w.into(), [5.773; 3], 1e-3, "omega (book)");
    // The axis is fixed in both frames, so the body-frame components are the same (ω̄ = Aᵀω).
    let w_bar = vel.world_from_link(body).rotation().transpose() * w;
    assert_close(w_bar.into(), w.into(), 1e-14, "omega bar");
}
