//! MJCF: what the reader makes of each feature, worked out by hand from MuJoCo's documented
//! semantics, and its errors. (Agreement with MuJoCo itself, on these files and on MuJoCo
//! Menagerie's robots, is tested from Python, where MuJoCo is installed.)

use crate::common::Scratch;
use kinechain::io::{Format, LoadOptions};
use kinechain::nalgebra::{Matrix3, Rotation3, Vector3};
use kinechain::{Chain, Data, JointKind, LimitPolicy, forward_kinematics};
use std::f64::consts::PI;
use std::path::PathBuf;

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/mjcf")
}

fn mjcf(text: &str) -> Chain {
    Chain::from_str_with(text, Format::Mjcf, "robot", &LoadOptions::default()).unwrap()
}

/// Position and rotation of `link` at `q`.
fn pose(chain: &Chain, q: &[f64], link: &str) -> (Vector3<f64>, Matrix3<f64>) {
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let poses = forward_kinematics(chain, &mut data, q).unwrap();
    let t = poses.world_from_link(chain.link_id(link).unwrap());
    (t.translation(), t.rotation())
}

fn close(a: &Vector3<f64>, b: &Vector3<f64>) -> bool {
    (a - b).abs().max() < 1e-14
}

fn close_m(a: &Matrix3<f64>, b: &Matrix3<f64>) -> bool {
    (a - b).abs().max() < 1e-14
}

#[test]
fn the_feature_file_reads_as_mujoco_defines_it() {
    let chain = Chain::from_file(data_dir().join("features.xml")).unwrap();
    assert_eq!(chain.name(), "features");
    assert_eq!(
        kinechain::regression::variable_names(&chain),
        ["yaw", "shoulder", "shoulder_roll", "elbow", "extend"]
    );
    let deg = PI / 180.0;
    // qpos0: each joint's ref, from the element or its class (`wrist` through a frame's
    // childclass for shoulder_roll and elbow), hinge refs in degrees.
    let keys = chain.keyframes();
    assert_eq!(keys.len(), 2);
    assert_eq!(keys[0].0, "home");
    assert_eq!(keys[0].1, [0.1, 0.2, 0.3, 0.4, 0.05]);
    assert_eq!(keys[1].0, "zero");
    let want = [0.0, -15.0 * deg, 10.0 * deg, 10.0 * deg, 0.05];
    for (a, b) in keys[1].1.iter().zip(want) {
        assert!((a - b).abs() < 1e-15, "{:?}", keys[1].1);
    }
    // Limits: the top class's range (autolimits), limited="false", the slide class's range.
    let kind = |name: &str| chain.joint(chain.joint_id(name).unwrap()).kind();
    assert_eq!(kind("yaw"), JointKind::Revolute);
    assert_eq!(kind("elbow"), JointKind::Continuous);
    assert_eq!(kind("extend"), JointKind::Prismatic);
    assert!((chain.lower()[0] + 90.0 * deg).abs() < 1e-15);
    assert!((chain.upper()[4] - 0.2).abs() < 1e-15);
    for link in [
        "world",
        "base",
        "site:base",
        "upper",
        "upper/shoulder",
        "lower",
        "welded",
        "tool",
        "tip",
        "world_marker",
        "stand",
        "stand_top",
    ] {
        assert!(chain.link_id(link).is_ok(), "no link {link}");
    }
    assert!(
        chain
            .warnings()
            .iter()
            .any(|w| w.contains("equality constraints (1 joint)")),
        "{:?}",
        chain.warnings()
    );
    // The included body: a pose with no joint, `euler="0 0 90"` read in the file's sequence
    // ZYX: 90° about x.
    let (p, r) = pose(&chain, &keys[1].1, "stand");
    assert!(close(&p, &Vector3::new(-1.0, 0.0, 0.5)));
    assert!(close_m(
        &r,
        Rotation3::from_axis_angle(&Vector3::x_axis(), PI / 2.0).matrix()
    ));
}

#[test]
fn a_hinge_turns_about_its_pos_and_moves_by_qpos_minus_ref() {
    let chain = mjcf(
        r#"<mujoco><compiler angle="radian"/><worldbody>
             <body name="b" pos="0 0 1"><joint axis="0 0 1" pos="1 0 0" ref="0.5"/></body>
           </worldbody></mujoco>"#,
    );
    // At q = ref the body is where the file puts it.
    let (p, r) = pose(&chain, &[0.5], "b");
    assert!(close(&p, &Vector3::new(0.0, 0.0, 1.0)));
    assert!(close_m(&r, &Matrix3::identity()));
    // A quarter turn on from there about the point (1, 0, 0) of the body: the origin moves to
    // (1, -1).
    let (p, _) = pose(&chain, &[0.5 + PI / 2.0], "b");
    assert!(close(&p, &Vector3::new(1.0, -1.0, 1.0)), "{p}");
}

#[test]
fn a_slide_moves_along_its_axis_by_qpos_minus_ref() {
    let chain = mjcf(
        r#"<mujoco><worldbody><body name="b" euler="0 0 90">
             <joint type="slide" axis="1 0 0" ref="0.25" range="0 1"/></body>
           </worldbody></mujoco>"#,
    );
    assert_eq!(
        chain.joint(chain.joint_id("joint#0").unwrap()).kind(),
        JointKind::Prismatic
    );
    let (p, _) = pose(&chain, &[0.75], "b");
    // The axis is the body's x, which the body's 90° (degrees by default) turns to world y.
    assert!(close(&p, &Vector3::new(0.0, 0.5, 0.0)), "{p}");
}

#[test]
fn euler_sequences_are_intrinsic_in_lower_case_and_extrinsic_in_upper_case() {
    let rot = |axis: Vector3<f64>, a: f64| {
        *Rotation3::from_axis_angle(&kinechain::nalgebra::Unit::new_normalize(axis), a).matrix()
    };
    let (x, y, z) = (Vector3::x(), Vector3::y(), Vector3::z());
    let (a, b, c) = (0.3, -0.7, 1.1);
    for (seq, want) in [
        ("xyz", rot(x, a) * rot(y, b) * rot(z, c)),
        ("XYZ", rot(z, c) * rot(y, b) * rot(x, a)),
        ("zyx", rot(z, a) * rot(y, b) * rot(x, c)),
        ("xYz", rot(y, b) * rot(x, a) * rot(z, c)),
    ] {
        let chain = mjcf(&format!(
            r#"<mujoco><compiler angle="radian" eulerseq="{seq}"/><worldbody>
                 <body name="b" euler="{a} {b} {c}"/></worldbody></mujoco>"#
        ));
        let (_, r) = pose(&chain, &[], "b");
        assert!(close_m(&r, &want), "{seq}: {r} vs {want}");
    }
}

#[test]
fn every_orientation_attribute_gives_the_rotation_mujoco_gives() {
    let s = 0.5f64.sqrt();
    for (attr, want) in [
        // Normalised quaternion: 90° about z.
        (
            r#"quat="2 0 0 2""#,
            Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0),
        ),
        // Normalised without overflowing.
        (
            r#"quat="1e300 0 0 1e300""#,
            Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0),
        ),
        (
            r#"axisangle="0 0 1e308 90""#,
            Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0),
        ),
        // A non-unit axis is normalised; the angle is in degrees.
        (
            r#"axisangle="0 0 5 90""#,
            Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0),
        ),
        // xyaxes: y made orthogonal to x, z = x × y.
        (
            r#"xyaxes="0 2 0 -1 3 0""#,
            Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0),
        ),
        // zaxis: the smallest rotation taking z to the axis (here about -y... about x by -45°).
        (
            r#"zaxis="0 1 1""#,
            Matrix3::new(1.0, 0.0, 0.0, 0.0, s, s, 0.0, -s, s),
        ),
        // zaxis = -z: half a turn about x.
        (
            r#"zaxis="0 0 -3""#,
            Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0),
        ),
    ] {
        let chain = mjcf(&format!(
            r#"<mujoco><worldbody><body name="b" {attr}/></worldbody></mujoco>"#
        ));
        let (_, r) = pose(&chain, &[], "b");
        assert!(close_m(&r, &want), "{attr}: {r}");
    }
}

#[test]
fn a_free_joint_places_its_body_by_qpos_alone() {
    let chain = Chain::from_file(data_dir().join("free.xml")).unwrap();
    assert_eq!((chain.nq(), chain.nv()), (9, 8));
    assert_eq!(
        &kinechain::regression::variable_names(&chain)[..4],
        ["root.x", "root.y", "root.z", "root.qw"]
    );
    let mut q = vec![0.0; 9];
    q[..7].copy_from_slice(&[1.0, 2.0, 3.0, s(), 0.0, 0.0, s()]);
    let (p, r) = pose(&chain, &q, "torso");
    assert!(close(&p, &Vector3::new(1.0, 2.0, 3.0)));
    assert!(close_m(
        &r,
        &Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    ));
    // The keyframe, and qpos0 from the body's pose: the file's position and orientation.
    assert_eq!(chain.keyframes()[0].1[2], 0.8);
    let (p, _) = pose(&chain, &chain.keyframes()[0].1, "foot");
    assert!(p.z < 0.8);
}

#[test]
fn a_ball_joint_turns_its_body_about_its_pos_by_four_entries_of_qpos() {
    let chain = Chain::from_file(data_dir().join("ball.xml")).unwrap();
    assert_eq!((chain.nq(), chain.nv()), (18, 14));
    assert_eq!(
        &kinechain::regression::variable_names(&chain)[..6],
        [
            "waist.qw",
            "waist.qx",
            "waist.qy",
            "waist.qz",
            "lift",
            "shoulder.qw"
        ]
    );
    // The ranged ball (its cone) is reported, once, and not turned into limits.
    let said: Vec<_> = chain
        .warnings()
        .iter()
        .filter(|w| w.contains("ball joint"))
        .collect();
    assert_eq!(said.len(), 1, "{said:?}");
    assert!(said[0].contains("'wrist'"));
    // The pendulum's ball at the body origin: the bob swings about it. A quarter turn about x
    // takes the bob from below the pivot to beside it.
    let mut q = chain.neutral();
    let pivot = q.len() - 4;
    q[pivot..].copy_from_slice(&[s(), s(), 0.0, 0.0]);
    let (p, _) = pose(&chain, &q, "bob");
    assert!(close(&p, &Vector3::new(1.0, 1.5, 1.0)), "{p}");
    // The waist turns the torso about its pos (0.1 below the torso's origin): the origin
    // moves on a circle of radius 0.1 about that point.
    let (rest, _) = pose(&chain, &chain.neutral(), "torso");
    let mut turned = chain.neutral();
    turned[..4].copy_from_slice(&[0.0, 1.0, 0.0, 0.0]);
    let (p, _) = pose(&chain, &turned, "torso");
    let (_, r) = pose(&chain, &chain.neutral(), "torso");
    let centre = rest - r * Vector3::new(0.0, 0.0, 0.1);
    assert!(((p - centre).norm() - 0.1).abs() < 1e-14);
    assert!((p - rest).norm() > 0.19);
}

fn s() -> f64 {
    0.5f64.sqrt()
}

#[test]
fn a_site_sharing_a_body_name_is_qualified_and_unnamed_elements_are_named_by_mujoco_id() {
    let chain = mjcf(
        r#"<mujoco><worldbody><body name="hand"><joint/><site name="hand" pos="0 0 1"/>
             <body><site/><joint/><joint type="slide"/></body><site name=""/></body>
             <body><site name="x"/></body></worldbody></mujoco>"#,
    );
    assert!(chain.link_id("site:hand").is_ok());
    // Joints 0, 1, 2 and bodies 1, 2, 3 as MuJoCo numbers them; sites body by body: the hand's
    // two (0, 1), then the unnamed body's (2), then the last body's (3).
    assert_eq!(
        kinechain::regression::variable_names(&chain),
        ["joint#0", "joint#1", "joint#2"]
    );
    for link in [
        "body#2",
        "body#2/joint#1",
        "body#3",
        "site#1",
        "site#2",
        "x",
    ] {
        assert!(chain.link_id(link).is_ok(), "{link}");
    }
    // A made-up name the file already uses takes one # more.
    let chain = mjcf(
        r#"<mujoco><worldbody><body><joint/><site name="body#1"/></body>
             <body name="b"><joint name="joint#0"/></body></worldbody></mujoco>"#,
    );
    assert_eq!(
        kinechain::regression::variable_names(&chain),
        ["joint##0", "joint#0"]
    );
    assert!(chain.link_id("body##1").is_ok());
}

#[test]
fn frames_place_joints_and_sites_and_a_free_body_may_follow_an_arm() {
    let chain = Chain::from_file(data_dir().join("scene/frames_and_names.xml")).unwrap();
    let names = kinechain::regression::variable_names(&chain);
    assert_eq!(
        names,
        [
            "joint#0",
            "joint##1",
            "joint#1",
            "joint#3.qw",
            "joint#3.qx",
            "joint#3.qy",
            "joint#3.qz",
            "joint#4.x",
            "joint#4.y",
            "joint#4.z",
            "joint#4.qw",
            "joint#4.qx",
            "joint#4.qy",
            "joint#4.qz"
        ]
    );
    assert!(chain.floating_joint().is_none());
    // The first hinge turns about the axis its frame turns (body x → body y), through the point
    // the frame places.
    // euler="0.1 0.2 0.3" in MuJoCo's default sequence xyz: about the moving axes, x first.
    let turn_about = |axis: kinechain::nalgebra::Unit<Vector3<f64>>, a: f64| {
        Rotation3::from_axis_angle(&axis, a)
    };
    let body = turn_about(Vector3::x_axis(), 0.1)
        * turn_about(Vector3::y_axis(), 0.2)
        * turn_about(Vector3::z_axis(), 0.3);
    let axis = body * Vector3::y();
    let anchor = Vector3::new(0.0, 0.0, 0.5) + body * Vector3::new(0.1, 0.05, 0.0);
    let mut q = chain.neutral();
    let (p0, _) = pose(&chain, &q, "body#1");
    q[0] = 0.7;
    let (p1, r1) = pose(&chain, &q, "body#1");
    let turn = Rotation3::from_axis_angle(&kinechain::nalgebra::Unit::new_normalize(axis), 0.7);
    assert!(close(&p1, &(anchor + turn * (p0 - anchor))), "{p1} {p0}");
    assert!(close_m(&r1, &(turn * body).into_inner()));
    // The free ball: its qpos0 is where the frame puts it; a keyframe shorter than nq takes the
    // rest from qpos0.
    let keys = chain.keyframes();
    assert_eq!(keys[0].0, "short");
    let (c, s) = (0.25f64.cos(), 0.25f64.sin());
    let want_p = Vector3::new(1.0, 0.0, 0.0)
        + Rotation3::from_euler_angles(0.0, 0.0, 0.5) * Vector3::new(0.0, 0.5, 1.0);
    assert!(close(
        &Vector3::from_column_slice(&keys[0].1[7..10]),
        &want_p
    ));
    assert!((keys[0].1[10] - c).abs() < 1e-15 && (keys[0].1[13] - s).abs() < 1e-15);
    assert_eq!(keys[0].1[..2], [0.2, -0.3]);
}

#[test]
fn replicas_are_placed_step_by_step_and_named_with_suffixes() {
    let chain = Chain::from_file(data_dir().join("scene/replicate.xml")).unwrap();
    assert_eq!(chain.nq(), 33);
    let names = kinechain::regression::variable_names(&chain);
    // Inner suffixes first, two digits for eleven copies, one for three.
    assert_eq!(names[..3], ["stem00-0", "stem01-0", "stem02-0"]);
    assert_eq!(names[11], "stem00-1");
    assert!(chain.link_id("tip10-2").is_ok() && chain.link_id("row-2").is_ok());
    // Copy k of the inner row: turned k·5° about y, at the sum of the offsets turned by the
    // copies before it; the outer rows likewise about z.
    let q = vec![0.0; 33];
    let (p, r) = pose(&chain, &q, "leaf02-1");
    let (rz, ry) = (
        Rotation3::from_euler_angles(0.0, 0.0, 20f64.to_radians()),
        |k: f64| Rotation3::from_euler_angles(0.0, (5.0 * k).to_radians(), 0.0),
    );
    let inner = Vector3::new(0.1, 0.0, 0.0) + ry(1.0) * Vector3::new(0.1, 0.0, 0.0);
    let want = Vector3::new(0.0, 0.5, 0.0) + rz * (inner + ry(2.0) * Vector3::new(0.0, 0.0, 0.1));
    assert!((p - want).norm() < 1e-14, "{p} {want}");
    assert!(close_m(&r, &(rz * ry(2.0)).into_inner()));
}

#[test]
fn attached_models_keep_their_own_settings_and_take_prefixes() {
    let chain = Chain::from_file(data_dir().join("scene/attach.xml")).unwrap();
    let names = kinechain::regression::variable_names(&chain);
    // The cup's free joint is unnamed in its file: named by its MuJoCo id here.
    assert_eq!(names[..4], ["turn", "a/shoulder", "a/wrist", "joint#3.x"]);
    assert!(chain.link_id("w/grip").is_ok() && chain.link_id("copy/a/grip").is_ok());
    assert!(chain.link_id("f/shelf_mark").is_ok());
    // Keyframes: the model's own, then the attached model's under each prefix, its values for
    // the joints it brought and qpos0 for the others.
    let keys = chain.keyframes();
    let key_names: Vec<&str> = keys.iter().map(|k| k.0.as_str()).collect();
    assert_eq!(key_names, ["mine", "k/ready"]);
    let tilt = names.iter().position(|n| n == "k/tilt").unwrap();
    // (qpos values are radians whatever the compiler's angle units.)
    assert_eq!(
        keys[1].1[tilt..tilt + 8],
        [10.0, 0.1, 0.2, 0.3, 0.0, 1.0, 0.0, 0.0]
    );
    assert_eq!(keys[1].1[0], 0.0);
    assert_eq!(keys[0].1[0], 0.3);
    // The child's angles are radians and its Euler sequence ZYX, whatever the parent's.
    let (p, _) = pose(&chain, &chain.neutral(), "w/arm");
    assert!(close(&p, &Vector3::new(0.1, 0.0, 0.0)));
    let (_, r) = pose(&chain, &chain.neutral(), "w/arm");
    // ZYX, upper case: about the fixed axes, Z first, so Y's turn multiplies from the left.
    let want = Rotation3::from_axis_angle(&Vector3::y_axis(), 0.2)
        * Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
    assert!(close_m(&r, want.matrix()), "{r}");
}

#[test]
fn a_free_body_aligned_with_its_inertial_frame_keeps_its_sites_in_place() {
    let aligned = Chain::from_file(data_dir().join("scene/alignfree.xml")).unwrap();
    let text = std::fs::read_to_string(data_dir().join("scene/alignfree.xml")).unwrap();
    let plain = mjcf(&text.replace(r#"alignfree="true""#, r#"alignfree="false""#));
    // At qpos0 every site is where it is without the alignment; the bodies are not.
    for site in [
        "corner",
        "stick_end",
        "weighted_site",
        "kept_site",
        "cluster_site",
        "tensor_site",
    ] {
        let qa0 = zero_key(&aligned);
        let qp0 = zero_key(&plain);
        let (a, ra) = pose(&aligned, &qa0, site);
        let (b, rb) = pose(&plain, &qp0, site);
        assert!(
            (a - b).norm() < 1e-14 && (ra - rb).abs().max() < 1e-14,
            "{site}"
        );
    }
    // The brick's frame is its geom's: at (0.01, 0.02, 0.03) in the body, turned 40° about z.
    let q = zero_key(&aligned);
    let (p, _) = pose(&aligned, &q, "brick");
    let r = Rotation3::from_axis_angle(&Vector3::x_axis(), 10f64.to_radians())
        * Rotation3::from_axis_angle(&Vector3::y_axis(), 20f64.to_radians())
        * Rotation3::from_axis_angle(&Vector3::z_axis(), 30f64.to_radians());
    let want = Vector3::new(0.1, 0.2, 0.3) + r * Vector3::new(0.01, 0.02, 0.03);
    assert!(close(&p, &want), "{p} {want}");
    // Unmoved: align="false", and a free body with a child.
    for body in ["kept", "parent"] {
        assert_eq!(
            pose(&aligned, &q, body).0,
            pose(&plain, &zero_key(&plain), body).0
        );
    }
    // The tensor body's frame: its principal axes, moments decreasing (the columns of its
    // rotation are eigenvectors of the inertia, in that order).
    let (_, r) = pose(&aligned, &q, "tensor");
    let inertia = Matrix3::new(0.3, 0.01, 0.02, 0.01, 0.25, 0.03, 0.02, 0.03, 0.2);
    let d = r.transpose() * inertia * r;
    assert!(
        d[(0, 1)].abs() < 1e-15 && d[(0, 2)].abs() < 1e-15 && d[(1, 2)].abs() < 1e-15,
        "{d}"
    );
    assert!(d[(0, 0)] > d[(1, 1)] && d[(1, 1)] > d[(2, 2)]);
    // A body whose inertial frame is a mesh's is refused, naming it.
    let mesh = text.replace(
        r#"<geom type="box" size="0.02 0.03 0.04" pos="0.01 0.02 0.03" euler="0 0 40"/>"#,
        r#"<geom type="mesh" mesh="part"/>"#,
    );
    let e = mjcf_error_or_any(&mesh);
    assert!(e.contains("mesh geom with mass"), "{e}");
}

/// `qpos0` of `alignfree.xml` (its free joints where the file puts them): the key its
/// `<size nkey="2">` adds.
fn zero_key(chain: &Chain) -> Vec<f64> {
    chain.keyframes()[1].1.clone()
}

#[test]
fn an_included_file_may_have_any_root_element() {
    let chain = Chain::from_file(data_dir().join("scene/legacy.xml")).unwrap();
    assert_eq!(kinechain::regression::variable_names(&chain), ["hinge"]);
    assert!(chain.link_id("handle").is_ok());
}

#[test]
fn errors_name_the_line_and_what_is_wrong() {
    for (text, line, says) in [
        (
            "<mujoco><worldbody>\n<body><joint type=\"screw\"/></body></worldbody></mujoco>",
            2,
            "type 'screw'",
        ),
        (
            "<mujoco><worldbody><body>\n<joint range=\"1 -1\"/></body></worldbody></mujoco>",
            2,
            "lower bound",
        ),
        (
            "<mujoco><worldbody><body><joint/>\n<body><freejoint/></body></body></worldbody></mujoco>",
            2,
            "not in a top-level body",
        ),
        (
            "<mujoco><worldbody>\n<body quat=\"1 0 0 0\" euler=\"0 0 1\"/></worldbody></mujoco>",
            2,
            "one orientation",
        ),
        (
            "<mujoco><worldbody>\n<body childclass=\"nope\"/></worldbody></mujoco>",
            2,
            "'nope' is not defined",
        ),
        (
            "<mujoco><worldbody><body><joint/></body></worldbody>\n<keyframe><key qpos=\"1 2\"/></keyframe></mujoco>",
            2,
            "nq = 1",
        ),
        (
            "<mujoco><worldbody>\n<body pos=\"0 0\"/></worldbody></mujoco>",
            2,
            "it takes 3",
        ),
        (
            "<mujoco><worldbody>\n<body pos=\"0 nan 0\"/></worldbody></mujoco>",
            2,
            "not a finite number",
        ),
        (
            "<mujoco><worldbody>\n<flexcomp type=\"grid\"/></worldbody></mujoco>",
            2,
            "deformable",
        ),
        (
            "<mujoco><worldbody>\n<replicate count=\"0\"/></worldbody></mujoco>",
            2,
            "positive whole number",
        ),
        (
            "<mujoco><worldbody>\n<attach model=\"m\" prefix=\"p\"/></worldbody></mujoco>",
            2,
            "no model asset 'm'",
        ),
        (
            "<mujoco><worldbody><body name=\"a\"/>\n<body name=\"a\"/></worldbody></mujoco>",
            2,
            "repeated name 'a' in body (the first is at line 1, column 20)",
        ),
        (
            "<mujoco><worldbody>\n<joint/></worldbody></mujoco>",
            2,
            "world body has no joints",
        ),
        ("<mujoco>\n<worldbody></mujoco>", 2, "not well-formed"),
        ("<robot name=\"r\">\n</robot><x/>", 2, ""),
    ] {
        let e = mjcf_error_or_any(text);
        assert!(e.contains(says), "{text}: {e}");
        if !says.is_empty() {
            assert!(e.contains(&format!("line {line}")), "{text}: {e}");
        }
    }
}

fn mjcf_error_or_any(text: &str) -> String {
    match Chain::from_str_with(text, Format::Mjcf, "robot", &LoadOptions::default()) {
        Ok(_) => panic!("{text} loaded"),
        Err(e) => e.kind().to_string(),
    }
}

#[test]
fn includes_are_read_once_and_their_errors_name_the_included_file() {
    let dir = Scratch::new("mjcf-include");
    dir.write("main.xml", r#"<mujoco><include file="a.xml"/></mujoco>"#);
    dir.write("a.xml", "<mujoco>\n<include file=\"main.xml\"/></mujoco>");
    let e = Chain::from_file(dir.path("main.xml")).unwrap_err();
    let message = e.kind().to_string();
    assert!(
        message.contains("includes itself") && message.contains("a.xml"),
        "{message}"
    );
    assert!(message.contains("line 2"), "{message}");

    dir.write(
        "twice.xml",
        r#"<mujoco><include file="b.xml"/><include file="b.xml"/></mujoco>"#,
    );
    dir.write("b.xml", "<mujoco><option/></mujoco>");
    let message = Chain::from_file(dir.path("twice.xml"))
        .unwrap_err()
        .kind()
        .to_string();
    assert!(message.contains("a second time"), "{message}");

    dir.write(
        "missing.xml",
        r#"<mujoco><include file="nowhere.xml"/></mujoco>"#,
    );
    let message = Chain::from_file(dir.path("missing.xml"))
        .unwrap_err()
        .kind()
        .to_string();
    assert!(message.contains("'nowhere.xml' is not found"), "{message}");

    dir.write("broken.xml", r#"<mujoco><include file="c.xml"/></mujoco>"#);
    dir.write(
        "c.xml",
        "<mujoco>\n<worldbody>\n<body pos=\"1\"/></worldbody></mujoco>",
    );
    let e = Chain::from_file(dir.path("broken.xml")).unwrap_err();
    let message = e.kind().to_string();
    assert!(
        message.contains("c.xml") && message.contains("line 3"),
        "{message}"
    );

    // A string's includes are looked up in the directory given.
    let text = r#"<mujoco><include file="b.xml"/><worldbody><body name="x"/></worldbody></mujoco>"#;
    let options = LoadOptions::default().with_base_dir(dir.path(""));
    assert!(Chain::from_str_with(text, Format::Mjcf, "r", &options).is_ok());
}

#[test]
fn an_xml_file_whose_root_is_robot_is_read_as_urdf() {
    let dir = Scratch::new("mjcf-urdf");
    let text = std::fs::read_to_string(crate::common::robots_dir().join("panda.urdf")).unwrap();
    dir.write("panda.xml", &text);
    let chain = Chain::from_file(dir.path("panda.xml")).unwrap();
    assert_eq!(chain.name(), "panda");
}

#[test]
fn an_error_has_the_line_and_column_of_the_attribute_at_fault() {
    let text = "<mujoco><worldbody>\n<body><joint type=\"screw\"/></body></worldbody></mujoco>";
    let e = Chain::from_str_with(text, Format::Mjcf, "robot", &LoadOptions::default()).unwrap_err();
    assert_eq!(e.position(), Some((2, Some(14))));
}

#[test]
fn couplings_on_request_make_followers_of_linear_joint_equalities() {
    let text = r#"<mujoco><compiler angle="radian"/><worldbody>
        <body name="a"><joint name="x" ref="0.2"/>
          <body name="b" pos="1 0 0"><joint name="y" ref="-0.1" axis="0 1 0"/></body></body>
      </worldbody>
      <equality><joint joint1="y" joint2="x" polycoef="0.3 2 0 0 0"/></equality>
      <keyframe><key name="k" qpos="0.5 0.9"/></keyframe></mujoco>"#;
    let plain = mjcf(text);
    let coupled = Chain::from_str_with(
        text,
        Format::Mjcf,
        "r",
        &LoadOptions::default().with_couplings(true),
    )
    .unwrap();
    assert_eq!((plain.nq(), coupled.nq()), (2, 1));
    assert_eq!(coupled.keyframes()[0].1, [0.5]);
    assert!(coupled.warnings().is_empty(), "{:?}", coupled.warnings());
    // y − y0 = a0 + a1 (x − x0)
    for x in [-1.0, 0.2, 0.7] {
        let y = -0.1 + 0.3 + 2.0 * (x - 0.2);
        let (p, r) = pose(&coupled, &[x], "b");
        let (p2, r2) = pose(&plain, &[x, y], "b");
        assert!(close(&p, &p2) && close_m(&r, &r2));
    }
    let bent = text.replace("0.3 2 0 0 0", "0 1 0.5 0 0");
    let options = LoadOptions::default().with_couplings(true);
    let e = Chain::from_str_with(&bent, Format::Mjcf, "r", &options).unwrap_err();
    let message = e.kind().to_string();
    assert!(
        message.contains("not linear") && message.contains("line 5"),
        "{message}"
    );
    // Without the option the same file loads, the coupling reported.
    assert!(mjcf(&bent).warnings()[0].contains("1 joint"));
}

#[test]
fn fusestatic_keeps_static_bodies_and_says_when_ids_may_differ() {
    // MuJoCo fuses `S` (no joints) into `A`: its bodies are world, A, C and the unnamed one
    // (id 3). kinechain keeps `S` as a link where MuJoCo's frames put it, so the unnamed body
    // is `body#4`, and a warning at the compiler says so.
    let text = r#"<mujoco>
  <compiler fusestatic="true"/>
  <worldbody>
    <body name="A">
      <joint name="a" axis="1 0 0"/>
      <body name="S" pos="0 0 1">
        <site name="s1"/>
        <body name="C" pos="0 1 0"><joint name="c"/></body>
      </body>
      <body pos="1 0 0"><joint/><site/></body>
    </body>
  </worldbody>
</mujoco>"#;
    let chain = mjcf(text);
    assert_eq!(
        kinechain::regression::variable_names(&chain),
        ["a", "c", "joint#2"]
    );
    assert!(chain.link_id("S").is_ok() && chain.link_id("body#4").is_ok());
    let said: Vec<_> = chain
        .warnings()
        .iter()
        .filter(|w| w.contains("fusestatic"))
        .collect();
    assert_eq!(said.len(), 1, "{:?}", chain.warnings());
    assert!(said[0].starts_with("line 2 column 13:"), "{}", said[0]);
    assert!(
        said[0].contains("1 unnamed bodies and 1 unnamed sites"),
        "{}",
        said[0]
    );
    // Without unnamed elements, or without a body to fuse, names are MuJoCo's: no warning.
    let named = text.replace("<body pos=\"1 0 0\"><joint/><site/></body>", "");
    assert!(mjcf(&named).warnings().is_empty());
    let nothing_to_fuse = text.replace("<site name=\"s1\"/>", "<joint name=\"s\"/>");
    assert!(mjcf(&nothing_to_fuse).warnings().is_empty());
}

#[test]
fn menageries_single_cube_scene_loads_with_the_cube_last_in_q() {
    // The Panda (an include of an include) and one unnamed free body after it: q is MuJoCo's
    // qpos (nq 16), the cube's free joint is unnamed, so `joint#9` (MuJoCo's id 9), and each
    // keyframe puts the cube where its last seven entries say.
    let chain =
        Chain::from_file(data_dir().join("menagerie/franka_emika_panda/mjx_single_cube.xml"))
            .unwrap();
    assert_eq!((chain.nq(), chain.nv()), (16, 15));
    let names = kinechain::regression::variable_names(&chain);
    assert_eq!(names[0], "joint1");
    assert_eq!(
        names[9..],
        [
            "joint#9.x",
            "joint#9.y",
            "joint#9.z",
            "joint#9.qw",
            "joint#9.qx",
            "joint#9.qy",
            "joint#9.qz"
        ]
    );
    let keys: Vec<&str> = chain.keyframes().iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(keys, ["home", "pickup", "pickup1"]);
    for (_, q) in chain.keyframes() {
        let (p, r) = pose(&chain, q, "box");
        assert!(close(&p, &Vector3::new(q[9], q[10], q[11])), "{p}");
        let quat = kinechain::nalgebra::UnitQuaternion::from_quaternion(
            kinechain::nalgebra::Quaternion::new(q[12], q[13], q[14], q[15]),
        );
        assert!(close_m(&r, quat.to_rotation_matrix().matrix()), "{r}");
    }
    // The mocap target stays where the file puts it.
    assert!(
        chain
            .warnings()
            .iter()
            .any(|w| w.contains("'mocap_target' is a mocap body"))
    );
}
