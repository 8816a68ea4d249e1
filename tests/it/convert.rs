//! `kinechain convert`: every DH and axis-form robot of `robots/` written as URDF loads in
//! kinechain and in the `k` crate, and all link poses agree with the original to 1e-12 at
//! seeded random configurations. This is how the DH robots are cross-checked against `k`.

use crate::common::*;
use kinechain::{Chain, Data, LimitPolicy, forward_kinematics};

/// The robot `name` of `robots/`, and the URDF `convert` writes for it, loaded from a file in
/// `dir` whose path it returns.
fn converted(dir: &Scratch, name: &str) -> (Chain, Chain, String) {
    let original = Chain::from_file(robots_dir().join(name)).unwrap();
    let text = kinechain::io::convert::to_urdf(&original).unwrap();
    let path = dir.write(&name.replace(".yaml", ".urdf"), &text);
    let urdf = Chain::from_file(&path)
        .unwrap_or_else(|e| panic!("{name}: {}\n{text}", kinechain::error::error_chain(&e)));
    (original, urdf, path)
}

#[test]
fn converted_robots_agree_with_the_original_in_kinechain_and_k() {
    let dir = Scratch::new("convert");
    let mut rng = rng(71);
    let mut checked = 0;
    for name in [
        "puma560.yaml",
        "puma560_modified.yaml",
        "stanford.yaml",
        "scara.yaml",
        "ur5.yaml",
        "panda_mdh.yaml",
        "iiwa7.yaml",
        "irb140.yaml",
        "cylindrical.yaml",
        "planar3.yaml",
        "snake50.yaml",
    ] {
        let (original, urdf, path) = converted(&dir, name);
        assert_eq!(urdf.dof(), original.dof(), "{name}");
        // Origins are written without negative zeros (`rpy="0 -0 0"`).
        let text = std::fs::read_to_string(&path).unwrap();
        for origin in text.lines().filter(|l| l.contains("<origin")) {
            assert!(
                !origin.contains("\"-0 ") && !origin.contains(" -0 ") && !origin.contains(" -0\""),
                "{name}: {origin}"
            );
        }
        let k_robot = k::Chain::<f64>::from_urdf_file(&path)
            .unwrap_or_else(|e| panic!("k cannot load {name}: {e}"));
        let (mut a, mut b) = (
            Data::new(&original).with_limit_policy(LimitPolicy::Ignore),
            Data::new(&urdf).with_limit_policy(LimitPolicy::Ignore),
        );
        for _ in 0..20 {
            let q = random_q(&original, &mut rng);
            let ours = forward_kinematics(&original, &mut a, &q).unwrap();
            let theirs = forward_kinematics(&urdf, &mut b, &q).unwrap();
            // k's joint vector, by name (the URDF's q order is the original's).
            let kq: Vec<f64> = k_robot
                .iter_joints()
                .map(|j| {
                    q[urdf
                        .joint(urdf.joint_id(&j.name).unwrap())
                        .q_index()
                        .unwrap()]
                })
                .collect();
            k_robot.set_joint_positions_unchecked(&kq);
            k_robot.update_transforms();
            for link in original.links() {
                let want = ours.world_from_link(original.link_id(link.name()).unwrap());
                let got = theirs.world_from_link(urdf.link_id(link.name()).unwrap());
                assert!(
                    pose_error(&got, &want.to_rows()) < 1e-12,
                    "{name} {}",
                    link.name()
                );
                let m = k_robot
                    .find_link(link.name())
                    .unwrap()
                    .world_transform()
                    .unwrap()
                    .to_homogeneous();
                let k_rows: [[f64; 4]; 4] =
                    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]));
                assert!(
                    pose_error(&want, &k_rows) < 1e-12,
                    "{name} {} (k)",
                    link.name()
                );
                checked += 1;
            }
        }
        // Limits are carried over.
        for j in original.joints().iter().filter(|j| j.dof() == 1) {
            let u = urdf.joint(urdf.joint_id(j.name()).unwrap());
            assert_eq!(u.limits(), j.limits(), "{name} {}", j.name());
        }
    }
    assert!(checked > 2000);
}

#[test]
fn prismatic_joints_without_limits_are_refused() {
    let chain = Chain::from_dh_yaml_str(
        "convention: standard\njoints:\n  - {name: slide, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0}\n",
    )
    .unwrap();
    assert!(matches!(
        kinechain::io::convert::to_urdf(&chain),
        Err(kinechain::io::convert::ConvertError::UnlimitedPrismatic { .. })
    ));
}

/// Fixed and continuous joints are written without a `<limit>` (one of zeros would read as a
/// locked range), and fixed joints without an `<axis>`; limited joints keep both.
#[test]
fn limits_and_axes_are_written_only_where_they_apply() {
    let chain = Chain::from_dh_yaml_str(
        "convention: standard\njoints:\n  \
         - {name: spin, type: revolute, a: 0.5, alpha: 0.3, d: 0, theta: 0}\n  \
         - {name: arm, type: revolute, a: 0.5, alpha: 0, d: 0.1, theta: 0, limits: [-1, 1]}\n  \
         - {name: flange, type: fixed, a: 0, alpha: 0, d: 0.2, theta: 0}\n",
    )
    .unwrap();
    let text = kinechain::io::convert::to_urdf(&chain).unwrap();
    // The file says itself that its zero efforts and velocities are not data.
    assert!(
        text.lines().nth(1).is_some_and(
            |l| l.contains("<!-- Kinematics only") && l.contains("effort and velocity are 0")
        ),
        "{text}"
    );
    // Each joint's element, by name.
    let block = |name: &str| {
        let start = text
            .find(&format!("<joint name=\"{name}\""))
            .unwrap_or_else(|| panic!("no joint {name} in\n{text}"));
        let end = start + text[start..].find("</joint>").unwrap();
        &text[start..end]
    };
    for (name, kind, limit, axis) in [
        ("spin", "continuous", false, true),
        ("spin_post", "fixed", false, false),
        ("arm", "revolute", true, true),
        ("arm_post", "fixed", false, false),
        ("flange", "fixed", false, false),
    ] {
        let b = block(name);
        assert!(b.contains(&format!("type=\"{kind}\"")), "{b}");
        assert_eq!(b.contains("<limit "), limit, "{b}");
        assert_eq!(b.contains("<axis "), axis, "{b}");
    }
    assert!(
        block("arm").contains("<limit lower=\"-1\" upper=\"1\""),
        "{text}"
    );
    let urdf = Chain::from_urdf_str(&text).unwrap();
    assert!(urdf.warnings().is_empty(), "{:?}", urdf.warnings());
    let spin = urdf.joint(urdf.joint_id("spin").unwrap());
    assert_eq!(spin.limits(), [None]);
}

/// A joint locked by its limits (`[0, 0]`) is written as `<limit lower="0" upper="0" effort="0"
/// velocity="0"/>`, every value of which is also what urdf-rs puts in place of a missing
/// `<limit>`: the written file still loads, with the joint locked as in the table, while a
/// revolute joint with no `<limit>` at all (or one in a comment) stays an error.
#[test]
fn a_joint_locked_at_zero_survives_the_round_trip() {
    let chain = Chain::from_dh_yaml_str(
        "convention: standard\njoints:\n  \
         - {name: locked, type: revolute, a: 1, alpha: 0, d: 0, theta: 0, limits: [0, 0]}\n  \
         - {name: free, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0, limits: [0, 0.5]}\n",
    )
    .unwrap();
    let text = kinechain::io::convert::to_urdf(&chain).unwrap();
    let locked_limit = "<limit lower=\"0\" upper=\"0\" effort=\"0\" velocity=\"0\"/>";
    assert!(text.contains(locked_limit), "{text}");
    let urdf = Chain::from_urdf_str(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    // Both joints keep their limits; only the locked one draws a warning.
    let warned = |name: &str| {
        let quoted = format!("'{name}'");
        urdf.warnings().iter().any(|w| w.contains(&quoted))
    };
    for (name, warning) in [("locked", true), ("free", false)] {
        let limits = |c: &Chain| c.joint(c.joint_id(name).unwrap()).limits().to_vec();
        assert_eq!(limits(&urdf), limits(&chain), "{name}");
        assert_eq!(warned(name), warning, "{name}: {:?}", urdf.warnings());
    }

    let without = text.replace(locked_limit, "");
    let commented = text.replace(locked_limit, &format!("<!-- {locked_limit} -->"));
    for text in [without, commented] {
        let e = Chain::from_urdf_str(&text).unwrap_err();
        let message = kinechain::error::error_chain(&e);
        assert!(message.contains("joint 'locked'"), "{message}");
        assert!(message.contains("no <limit> element"), "{message}");
    }
}

/// Names are written as XML attribute values: `&`, `<`, `>` and `"` in them come back unchanged.
#[test]
fn names_with_markup_characters_survive_the_round_trip() {
    let chain = Chain::from_dh_yaml_str(
        "name: 'R&D \"arm\" <2>'\nconvention: modified\nbase: {name: 'base<0>'}\njoints:\n  \
         - {name: 'shoulder & elbow', link: 'upper\"arm', type: revolute, a: 0.3, alpha: 0, d: 0, theta: 0}\n",
    )
    .unwrap();
    let text = kinechain::io::convert::to_urdf(&chain).unwrap();
    let urdf = Chain::from_urdf_str(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(urdf.name(), "R&D \"arm\" <2>");
    let links: Vec<&str> = urdf.links().iter().map(|l| l.name()).collect();
    assert_eq!(links, ["base<0>", "upper\"arm"], "{text}");
    assert!(urdf.joint_id("shoulder & elbow").is_ok(), "{text}");
    // Tab and line feed come back as written (a raw one would read as a space); a control
    // character that XML cannot hold is an error naming it.
    let tabbed = Chain::from_dh_yaml_str(
        "name: \"a\\tb\\nc\"\nconvention: modified\njoints:\n  \
         - {name: j, type: revolute, a: 0.3, alpha: 0, d: 0, theta: 0}\n",
    )
    .unwrap();
    let text = kinechain::io::convert::to_urdf(&tabbed).unwrap();
    assert_eq!(Chain::from_urdf_str(&text).unwrap().name(), "a\tb\nc");
    let control = Chain::from_dh_yaml_str(
        "name: \"a\\x01b\"\nconvention: modified\njoints:\n  \
         - {name: j, type: revolute, a: 0.3, alpha: 0, d: 0, theta: 0}\n",
    )
    .unwrap();
    assert_eq!(
        kinechain::io::convert::to_urdf(&control),
        Err(kinechain::io::convert::ConvertError::NotXml {
            name: "a\u{1}b".into(),
            character: '\u{1}'
        })
    );
}

/// Origins at pitch = ±π/2 exactly (`a₁₁ = a₂₁ = 0`, where roll and yaw are not separately
/// defined) are written with pitch ±π/2, roll 0 and the whole turn about z in yaw, and read back
/// as the same frames. Rz(30°)·Ry(90°) and Ry(−90°)·Rz(−50°) = Rz(50°)·Ry(−90°)·Rx(... ) are given
/// as exact matrices, so that the written angles are known.
#[test]
fn gimbal_locked_origins_survive_the_round_trip() {
    let (s30, c30) = (0.5_f64, 0.75_f64.sqrt());
    let (s50, c50) = 50_f64.to_radians().sin_cos();
    // Rz(30°)·Ry(+90°): a₃₁ = −1, a₁₂ = −sin 30°, a₂₂ = cos 30°.
    let up = [
        [0.0, -s30, c30, 0.0],
        [0.0, c30, s30, 0.0],
        [-1.0, 0.0, 0.0, 0.1],
    ];
    // Rz(50°)·Ry(−90°): a₃₁ = +1, a₁₂ = −sin 50°, a₂₂ = cos 50°.
    let down = [
        [0.0, -s50, -c50, 0.2],
        [0.0, c50, -s50, 0.0],
        [1.0, 0.0, 0.0, 0.0],
    ];
    let matrix = |m: [[f64; 4]; 3]| {
        let rows: Vec<String> = m
            .iter()
            .chain(std::iter::once(&[0.0, 0.0, 0.0, 1.0]))
            .map(|r| format!("[{}, {}, {}, {}]", r[0], r[1], r[2], r[3]))
            .collect();
        format!("[{}]", rows.join(", "))
    };
    let yaml = format!(
        "convention: axis\njoints:\n  \
         - {{name: up, link: l1, type: revolute, origin: {{matrix: {}}}, axis: [0, 0, 1], limits: [-3, 3]}}\n  \
         - {{name: down, link: l2, type: revolute, origin: {{matrix: {}}}, axis: [0, 1, 0], limits: [-3, 3]}}\n",
        matrix(up),
        matrix(down)
    );
    let chain = Chain::from_dh_yaml_str(&yaml).unwrap_or_else(|e| panic!("{e}\n{yaml}"));
    let text = kinechain::io::convert::to_urdf(&chain).unwrap();
    let rpy = |joint: &str| -> [f64; 3] {
        let start = text.find(&format!("<joint name=\"{joint}\"")).unwrap();
        let from = start + text[start..].find("rpy=\"").unwrap() + 5;
        let values: Vec<f64> = text[from..from + text[from..].find('"').unwrap()]
            .split(' ')
            .map(|v| v.parse().unwrap())
            .collect();
        values.try_into().unwrap()
    };
    let half_pi = std::f64::consts::FRAC_PI_2;
    assert_eq!(rpy("up")[..2], [0.0, half_pi], "{text}");
    approx::assert_relative_eq!(rpy("up")[2], 30_f64.to_radians(), max_relative = 1e-15);
    assert_eq!(rpy("down")[..2], [0.0, -half_pi], "{text}");
    approx::assert_relative_eq!(rpy("down")[2], 50_f64.to_radians(), max_relative = 1e-15);

    let urdf = Chain::from_urdf_str(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    let (mut a, mut b) = (Data::new(&chain), Data::new(&urdf));
    for q in [[0.0, 0.0], [0.7, -1.2], [-2.5, 2.9]] {
        let (pa, pb) = (
            forward_kinematics(&chain, &mut a, &q).unwrap(),
            forward_kinematics(&urdf, &mut b, &q).unwrap(),
        );
        for link in ["l1", "l2"] {
            let (ta, tb) = (
                pa.world_from_link(chain.link_id(link).unwrap()),
                pb.world_from_link(urdf.link_id(link).unwrap()),
            );
            approx::assert_relative_eq!(ta.to_homogeneous(), tb.to_homogeneous(), epsilon = 1e-15);
        }
    }
}
