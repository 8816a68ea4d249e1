//! Joint-space vectors that cannot be evaluated: each rule returns its typed error naming the
//! joint (and for a cylindrical joint the coordinate), never a panic or a NaN result.

use crate::common::limit_probes;
use kinechain::io::input::{
    BatchLine, InputError, csv_header, joint_vector_from_json, joint_vector_from_str,
    parse_batch_line, parse_batch_row,
};
use kinechain::{
    Chain, Data, LimitPolicy, NameError, StateError, forward_accelerations, forward_kinematics,
    forward_kinematics_to, forward_velocities,
};
use serde_json::json;

fn robot(name: &str) -> Chain {
    Chain::from_file(crate::common::robots_dir().join(name)).unwrap()
}

#[test]
fn wrong_lengths() {
    let chain = robot("puma560.yaml");
    let mut data = Data::new(&chain);
    let e = forward_kinematics(&chain, &mut data, &[0.0; 5]).unwrap_err();
    assert_eq!(
        e,
        StateError::WrongLength {
            what: "q",
            expected: 6,
            got: 5
        }
    );
    let e = forward_velocities(&chain, &mut data, &[0.0; 6], &[0.0; 7]).unwrap_err();
    assert!(matches!(
        e,
        StateError::WrongLength {
            what: "q_dot",
            got: 7,
            ..
        }
    ));
    let e = forward_accelerations(&chain, &mut data, &[0.0; 6], &[0.0; 6], &[]).unwrap_err();
    assert!(matches!(
        e,
        StateError::WrongLength {
            what: "q_ddot",
            got: 0,
            ..
        }
    ));
}

#[test]
fn non_finite_entries_name_the_joint_and_coordinate() {
    let chain = robot("puma560.yaml");
    let mut data = Data::new(&chain);
    let mut q = [0.0; 6];
    q[2] = f64::NAN;
    let e = forward_kinematics(&chain, &mut data, &q).unwrap_err();
    assert!(
        matches!(&e, StateError::NonFinite { what: "q", index: 2, joint, component: None, .. } if joint == "j3"),
        "{e:?}"
    );
    let e = forward_velocities(
        &chain,
        &mut data,
        &[0.0; 6],
        &[0.0, 0.0, 0.0, f64::INFINITY, 0.0, 0.0],
    )
    .unwrap_err();
    assert!(matches!(&e, StateError::NonFinite { what: "q_dot", joint, .. } if joint == "j4"));
    // Every position and kind of non-finite value, in rates (alone in an otherwise valid call).
    for index in 0..6 {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut rates = [0.5, -1e300, 1e-310, 0.0, -0.0, 2.0];
            rates[index] = bad;
            let e = forward_velocities(&chain, &mut data, &[0.0; 6], &rates).unwrap_err();
            assert!(
                matches!(e, StateError::NonFinite { what: "q_dot", index: i, .. } if i == index),
                "{e:?}"
            );
        }
    }

    let cyl = robot("cylindrical.yaml");
    let mut data = Data::new(&cyl);
    let e = forward_kinematics(&cyl, &mut data, &[0.0, f64::NEG_INFINITY]).unwrap_err();
    assert!(
        matches!(&e, StateError::NonFinite { joint, component: Some("d"), .. } if joint == "joint"),
        "{e:?}"
    );
    assert!(e.to_string().contains("joint' d)"), "{e}");
}

#[test]
fn non_finite_positions_are_rejected_under_both_policies() {
    // The pose kernels check the entries inside their own call; under either policy a
    // non-finite entry anywhere gives the error naming it, and a valid call afterwards evaluates.
    let chain = robot("puma560.yaml");
    let tip = chain.end_link();
    for policy in [LimitPolicy::Enforce, LimitPolicy::Ignore] {
        let mut data = Data::new(&chain);
        data.set_limit_policy(policy);
        let reference = forward_kinematics_to(&chain, &mut data, &[0.1; 6], tip).unwrap();
        for index in 0..6 {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut q = [0.1; 6];
                q[index] = bad;
                let full = forward_kinematics(&chain, &mut data, &q)
                    .map(|_| ())
                    .unwrap_err();
                let one = forward_kinematics_to(&chain, &mut data, &q, tip).unwrap_err();
                for e in [full, one] {
                    assert!(
                        matches!(e, StateError::NonFinite { what: "q", index: i, .. } if i == index),
                        "{policy:?} {e:?}"
                    );
                }
            }
        }
        let p = forward_kinematics(&chain, &mut data, &[0.1; 6]).unwrap();
        assert_eq!(p.world_from_link(tip), reference, "{policy:?}");
    }
}

#[test]
fn in_kernel_checks_decide_as_check_q_does() {
    // Every entry of the Puma (one block of four and a tail of two), at and just past its
    // limits and non-finite: the pose, one-link and rate paths accept exactly what `check_q`
    // accepts and return its error.
    let chain = robot("puma560.yaml");
    let tool = chain.link_id("tool").unwrap();
    let (mut accepted, mut rejected) = (0, 0);
    for policy in [LimitPolicy::Enforce, LimitPolicy::Ignore] {
        let mut data = Data::new(&chain);
        data.set_limit_policy(policy);
        let moving = chain.joints().iter().filter(|j| !j.limits().is_empty());
        for (i, joint) in moving.enumerate() {
            let limits = joint.limits()[0].unwrap();
            for x in limit_probes(&limits) {
                let mut q = [0.1; 6];
                q[i] = x;
                // Compared as text: an error carrying a NaN is not equal to itself.
                let text = |e: Option<StateError>| format!("{e:?}");
                let want = kinechain::check_q(&chain, &q, policy).err();
                match want {
                    None => accepted += 1,
                    Some(_) => rejected += 1,
                }
                let rates = [0.2; 6];
                let got = [
                    forward_kinematics(&chain, &mut data, &q).map(|_| ()).err(),
                    forward_kinematics_to(&chain, &mut data, &q, tool).err(),
                    forward_velocities(&chain, &mut data, &q, &rates)
                        .map(|_| ())
                        .err(),
                    forward_accelerations(&chain, &mut data, &q, &rates, &rates)
                        .map(|_| ())
                        .err(),
                ];
                for e in got {
                    assert_eq!(text(e), text(want.clone()), "{policy:?} q[{i}] = {x}");
                }
                // Non-finite rates, with a valid q, name the rate.
                if !x.is_finite() {
                    let mut bad = rates;
                    bad[i] = x;
                    for (name, q_dot, q_ddot) in [("q_ddot", &rates, &bad), ("q_dot", &bad, &rates)]
                    {
                        let e = forward_accelerations(&chain, &mut data, &[0.1; 6], q_dot, q_ddot)
                            .map(|_| ())
                            .unwrap_err();
                        assert!(
                            matches!(e, StateError::NonFinite { what, index, .. } if what == name && index == i),
                            "{e:?}"
                        );
                    }
                }
            }
        }
    }
    assert!(
        accepted > 12 && rejected > 18,
        "{accepted} accepted, {rejected} rejected"
    );
}

#[test]
fn limits_are_enforced_by_default_and_can_be_ignored() {
    let chain = robot("puma560.yaml");
    let mut data = Data::new(&chain);
    assert_eq!(data.limit_policy(), LimitPolicy::Enforce);
    // 90 passed where 90° (1.57 rad) was meant.
    let q = [0.0, 90.0, 0.0, 0.0, 0.0, 0.0];
    let e = forward_kinematics(&chain, &mut data, &q).unwrap_err();
    match &e {
        StateError::OutOfLimits {
            joint,
            component,
            angular,
            value,
            lower,
            upper,
        } => {
            assert_eq!((joint.as_str(), *component, *value), ("j2", None, 90.0));
            assert!(*angular);
            assert!((lower - (-45f64).to_radians()).abs() < 1e-15);
            assert!((upper - 225f64.to_radians()).abs() < 1e-15);
        }
        other => panic!("{other:?}"),
    }
    assert!(e.to_string().contains("looks like degrees"), "{e}");
    // The same value is evaluated when the caller asks for it.
    data.set_limit_policy(LimitPolicy::Ignore);
    assert_eq!(data.limit_policy(), LimitPolicy::Ignore);
    assert!(forward_kinematics(&chain, &mut data, &q).is_ok());
    let built = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    assert_eq!(built.limit_policy(), LimitPolicy::Ignore);

    // Cylindrical limits name the coordinate.
    let cyl = robot("cylindrical.yaml");
    let mut data = Data::new(&cyl);
    let e =
        forward_kinematics_to(&cyl, &mut data, &[0.0, 6.0], cyl.link_id("P").unwrap()).unwrap_err();
    assert!(
        matches!(
            e,
            StateError::OutOfLimits {
                component: Some("d"),
                ..
            }
        ),
        "{e:?}"
    );
}

/// The message suggests degrees only for an angle beyond a full turn that, read as degrees, is
/// within the limits; never for a length (a slide, a cylindrical joint's `d`).
#[test]
fn only_angles_that_fit_as_degrees_get_the_degrees_hint() {
    fn hinted(file: &str, q: &[f64]) -> bool {
        let chain = robot(file);
        let e = forward_kinematics(&chain, &mut Data::new(&chain), q).unwrap_err();
        assert!(matches!(e, StateError::OutOfLimits { .. }), "{e:?}");
        e.to_string().contains("looks like degrees")
    }
    // Puma j2: [-45°, 225°].
    let puma = |x: f64| hinted("puma560.yaml", &[0.0, x, 0.0, 0.0, 0.0, 0.0]);
    assert!(puma(90.0) && puma(-40.0) && puma(7.0));
    // Within a turn (4 rad, 6 rad, 2π itself), or outside the limits as degrees (300°, -50°).
    for x in [4.0, 6.0, std::f64::consts::TAU, 300.0, -50.0] {
        assert!(!puma(x), "{x}");
    }
    // Stanford j3 slides over [0.3048, 1.27] m: 50 read as degrees would fit, but it is a length.
    assert!(!hinted("stanford.yaml", &[0.0, 0.0, 50.0, 0.0, 0.0, 0.0]));
    // A cylindrical joint: θ gets the hint, d (limits [-5, 5] m) does not.
    assert!(hinted("cylindrical.yaml", &[90.0, 0.0]));
    assert!(!hinted("cylindrical.yaml", &[0.0, 60.0]));
}

#[test]
fn mimic_joints_are_checked_against_their_own_limits() {
    let text = r#"<?xml version="1.0"?>
<robot name="gripper">
  <link name="palm"/><link name="left"/><link name="right"/>
  <joint name="left_finger" type="prismatic"><parent link="palm"/><child link="left"/>
    <axis xyz="0 1 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/></joint>
  <joint name="right_finger" type="prismatic"><parent link="palm"/><child link="right"/>
    <axis xyz="0 1 0"/><limit lower="-0.04" upper="0" effort="1" velocity="1"/>
    <mimic joint="left_finger" multiplier="-1" offset="0.01"/></joint>
</robot>"#;
    let chain = Chain::from_urdf_str(text).unwrap();
    assert_eq!(chain.dof(), 1);
    let mut data = Data::new(&chain);
    // q = 0.03 puts the mimic at −0.02: fine. q = 0.005 puts it at +0.005 > 0: refused.
    let poses = forward_kinematics(&chain, &mut data, &[0.03]).unwrap();
    let right = poses.world_from_link(chain.link_id("right").unwrap());
    assert!((right.translation().y - (-0.02)).abs() < 1e-17);
    let e = forward_kinematics(&chain, &mut data, &[0.005]).unwrap_err();
    assert!(
        matches!(&e, StateError::OutOfLimits { joint, value, .. } if joint == "right_finger" && (*value - 0.005).abs() < 1e-17),
        "{e:?}"
    );
}

/// A mimic joint whose primary has no limits is the only check of the primary's entry: its
/// limits bound `multiplier · q + offset` (here 2 q + 0.5 within [−1, 1.5], so q within
/// [−0.75, 0.5]) in a single evaluation, `check_q` and batches (the lanes' checks), `f64` and
/// `f32`.
#[test]
fn a_mimic_of_an_unlimited_joint_bounds_its_primarys_entry() {
    use kinechain::eval::batch::{BatchData, forward_kinematics_batch, single_precision as sp};
    use kinechain::{ChainBuilder, JointKind, JointSpec};
    let mut b = ChainBuilder::new("mimic");
    b.link("a").link("b").link("c");
    b.joint(JointSpec::new("drive", JointKind::Continuous, "a", "b"));
    b.joint(
        JointSpec::new("follow", JointKind::Revolute, "b", "c")
            .with_mimic("drive", 2.0, 0.5)
            .with_limits(-1.0, 1.5),
    );
    let chain = b.build().unwrap();
    let mut data = Data::new(&chain);
    let mut batch = BatchData::new(&chain);
    let mut batch32 = sp::BatchData::new(&chain);
    let above = 0.5 + f64::EPSILON;
    let below = -0.75 - f64::EPSILON;
    for (q, admitted) in [
        (0.5, true),
        (above, false),
        (-0.75, true),
        (below, false),
        (0.0, true),
    ] {
        let single = forward_kinematics(&chain, &mut data, &[q]);
        assert_eq!(single.is_ok(), admitted, "{q}");
        if let Err(e) = single {
            assert!(
                matches!(&e, StateError::OutOfLimits { joint, .. } if joint == "follow"),
                "{e:?}"
            );
        }
        assert_eq!(
            kinechain::check_q(&chain, &[q], LimitPolicy::Enforce).is_ok(),
            admitted
        );
        // 19 configurations (two blocks of eight and a rest), the probe at index 9.
        let mut qs = vec![0.0; 19];
        qs[9] = q;
        let want = (!admitted).then_some(9);
        assert_eq!(
            forward_kinematics_batch(&chain, &mut batch, &qs)
                .err()
                .map(|e| e.index),
            want,
            "{q}"
        );
        assert_eq!(
            sp::forward_kinematics_batch(&chain, &mut batch32, &qs)
                .err()
                .map(|e| e.index),
            want,
            "{q}"
        );
    }
}

/// JSON read from text keeps each value's type (the reader that refuses repeated member names
/// builds the values itself): an entry that is not a number is named with the type it has.
#[test]
fn json_text_entries_are_named_by_their_type() {
    let chain = robot("cylindrical.yaml");
    for (entry, found) in [
        ("true", "a boolean"),
        ("null", "null"),
        ("\"0.5\"", "a string"),
        ("[0.5]", "an array"),
        ("{\"theta\": 0.5}", "an object"),
    ] {
        assert_eq!(
            joint_vector_from_str(&chain, &format!("[1.0, {entry}]"), "q").unwrap_err(),
            InputError::NotANumber {
                what: "q",
                index: 1,
                found
            },
            "{entry}"
        );
    }
    // Integers, negative ones among them, read as numbers.
    assert_eq!(
        joint_vector_from_str(&chain, "[-1, 2]", "q").unwrap(),
        vec![-1.0, 2.0]
    );
}

#[test]
fn json_vectors() {
    let chain = robot("cylindrical.yaml");
    let ok = joint_vector_from_json(&chain, &json!({"joint": [0.5, 1.0]}), "q").unwrap();
    assert_eq!(ok, vec![0.5, 1.0]);
    assert_eq!(
        joint_vector_from_json(&chain, &json!({"joint": 0.5}), "q").unwrap_err(),
        InputError::Shape {
            what: "q",
            name: "joint".into(),
            expected: "[theta, d] (two numbers)".into()
        }
    );
    assert!(matches!(
        joint_vector_from_json(&chain, &json!([0.5, "x"]), "qd").unwrap_err(),
        InputError::NotANumber {
            what: "qd",
            index: 1,
            found: "a string"
        }
    ));
    // Keyed by name, each of a cylindrical joint's two entries is named by its own index.
    for (pair, index, found) in [
        (json!([null, 1.0]), 0, "null"),
        (json!([0.5, "x"]), 1, "a string"),
    ] {
        assert_eq!(
            joint_vector_from_json(&chain, &json!({ "joint": pair }), "q")
                .unwrap_err()
                .to_string(),
            format!("q[{index}]: expected a number, found {found}")
        );
    }
    assert!(matches!(
        joint_vector_from_json(&chain, &json!(3), "q").unwrap_err(),
        InputError::NotArrayOrObject {
            found: "a number",
            ..
        }
    ));
    assert!(matches!(
        joint_vector_from_json(&chain, &json!([1, 2, 3]), "q").unwrap_err(),
        InputError::WrongLength {
            expected: 2,
            got: 3,
            ..
        }
    ));

    let panda = robot("panda.urdf");
    let mut q = serde_json::Map::new();
    for j in panda.joints().iter().filter(|j| j.dof() > 0) {
        q.insert(j.name().into(), json!(0.01));
    }
    assert!(joint_vector_from_json(&panda, &json!(q.clone()), "q").is_ok());
    let mut with_mimic = q.clone();
    with_mimic.insert("panda_finger_joint2".into(), json!(0.01));
    assert_eq!(
        joint_vector_from_json(&panda, &json!(with_mimic), "q").unwrap_err(),
        InputError::NotIndependent {
            what: "q",
            name: "panda_finger_joint2".into(),
            reason: "a mimic of 'panda_finger_joint1'".into()
        }
    );
    let mut with_fixed = q.clone();
    with_fixed.insert("panda_joint8".into(), json!(0.0));
    assert!(matches!(
        joint_vector_from_json(&panda, &json!(with_fixed), "q").unwrap_err(),
        InputError::NotIndependent { reason, .. } if reason == "fixed"
    ));
    let mut missing = q.clone();
    missing.remove("panda_joint4");
    assert_eq!(
        joint_vector_from_json(&panda, &json!(missing), "q").unwrap_err(),
        InputError::MissingJoint {
            what: "q",
            name: "panda_joint4".into()
        }
    );
    q.insert("panda_joint9".into(), json!(0.0));
    assert!(matches!(
        joint_vector_from_json(&panda, &json!(q), "q").unwrap_err(),
        InputError::UnknownJoint { name, .. } if name == "panda_joint9"
    ));

    assert!(matches!(
        joint_vector_from_str(&chain, "[0.5, 1", "q").unwrap_err(),
        InputError::Json { .. }
    ));
    assert_eq!(
        joint_vector_from_str(&chain, "0.5, abc", "q").unwrap_err(),
        InputError::ListEntry {
            what: "q",
            index: 1,
            entry: "abc".into()
        }
    );
    // An empty entry is an error, not skipped: `0.5,,1` is not `[0.5, 1]`, nor is `0.5, 1,`.
    for (text, index) in [("0.5,,1", 1), ("0.5, 1,", 2), (",0.5, 1", 0)] {
        let e = joint_vector_from_str(&chain, text, "q").unwrap_err();
        assert_eq!(
            e,
            InputError::ListEntry {
                what: "q",
                index,
                entry: String::new()
            },
            "{text}"
        );
        assert_eq!(
            e.to_string(),
            format!("q[{index}]: empty entry in the list")
        );
    }
    assert_eq!(
        joint_vector_from_str(&chain, "0.5 -1e-3", "q").unwrap(),
        vec![0.5, -1e-3]
    );
    assert_eq!(
        joint_vector_from_str(&chain, " 0.5 , -1e-3 ", "q").unwrap(),
        vec![0.5, -1e-3]
    );
    // A joint named twice is refused, not read as the last value given.
    assert_eq!(
        joint_vector_from_str(&chain, r#"{"joint": [0.5, 1], "joint": [0.6, 1]}"#, "qd")
            .unwrap_err(),
        InputError::DuplicateMember {
            what: "qd",
            name: "joint".into()
        }
    );
}

/// Batch lines: every member named once, none unknown (and named in the error), `qdd` only with
/// `qd`; an exact read of each number.
#[test]
fn batch_lines() {
    let chain = robot("planar3.yaml");
    let line = |text: &str| parse_batch_line(&chain, text);
    assert_eq!(
        line(r#"{"q": [0.1, 0.2, 0.30000000000000004], "qd": [0, 0, 1e-320]}"#).unwrap(),
        BatchLine {
            q: vec![0.1, 0.2, 0.30000000000000004],
            q_dot: Some(vec![0.0, 0.0, 1e-320]),
            q_ddot: None,
        }
    );
    assert_eq!(
        line(r#"{"q": [0, 0, 0], "q": [1, 1, 1]}"#).unwrap_err(),
        InputError::DuplicateMember {
            what: "line",
            name: "q".into()
        }
    );
    assert_eq!(
        line(r#"{"q": {"j1": 0, "j2": 0, "j3": 0, "j2": 1}}"#).unwrap_err(),
        InputError::DuplicateMember {
            what: "line",
            name: "j2".into()
        }
    );
    let e = line(r#"{"q": [0, 0, 0], "qdot": [0, 0, 0]}"#).unwrap_err();
    assert_eq!(
        e,
        InputError::UnknownMember {
            name: "qdot".into()
        }
    );
    assert!(e.to_string().contains(r#""qdot""#), "{e}");
    let e = line(r#"{"q": [0, 0, 0], "qdd": [0, 0, 0]}"#).unwrap_err();
    assert!(e.to_string().contains(r#""qdd" needs "qd""#), "{e}");
    assert!(matches!(
        line(r#"{"q": [0, 0, 0]} {"q": [0, 0, 0]}"#).unwrap_err(),
        InputError::Json { what: "line", .. }
    ));
    // A line that is not an object is `q` alone: a JSON array, or numbers separated by commas
    // or by spaces and tabs (a row of a CSV file).
    let q_alone = BatchLine {
        q: vec![0.1, -2.0, 0.30000000000000004],
        q_dot: None,
        q_ddot: None,
    };
    for text in [
        "[0.1, -2, 0.30000000000000004]",
        "0.1,-2,0.30000000000000004",
        " 0.1, -2.0 ,0.30000000000000004 ",
        "0.1 -2\t0.30000000000000004",
    ] {
        assert_eq!(line(text).unwrap(), q_alone, "{text}");
    }
    assert_eq!(
        line("0.1, 0.2").unwrap_err(),
        InputError::WrongLength {
            what: "q",
            expected: 3,
            got: 2
        }
    );
    assert_eq!(
        line("j1,j2,j3").unwrap_err(),
        InputError::ListEntry {
            what: "q",
            index: 0,
            entry: "j1".into()
        }
    );
}

/// The header row of a CSV file: joint names in any order (a cylindrical joint's name for its two
/// columns), every joint that takes values named once; a line with a number in it, or JSON, is
/// not a header.
#[test]
fn csv_headers() {
    let ur5 = robot("ur5.yaml");
    let columns = |chain: &Chain, text: &str| {
        csv_header(chain, text).map(|h| h.map(|h| h.columns().to_vec()))
    };
    let header = |text: &str| columns(&ur5, text);
    let names = "wrist_3, shoulder_pan, elbow, shoulder_lift, wrist_2, wrist_1";
    assert_eq!(header(names), Some(Ok(vec![5, 0, 2, 1, 4, 3])));
    assert_eq!(
        header(&names.replace(',', " ")),
        Some(Ok(vec![5, 0, 2, 1, 4, 3]))
    );
    for not_a_header in [
        "",
        "  ",
        "0.1,0.2,0.3,0.4,0.5,0.6",
        "wrist_3,1e-3,elbow",
        "[0, 0, 0, 0, 0, 0]",
        r#"{"q": [0, 0, 0, 0, 0, 0]}"#,
    ] {
        assert_eq!(header(not_a_header), None, "{not_a_header}");
    }
    let unknown = header("time,shoulder_pan,shoulder_lift,elbow,wrist_1,wrist_2,wrist_3");
    assert!(
        matches!(unknown, Some(Err(InputError::UnknownJoint { what: "header", ref name, .. })) if name == "time"),
        "{unknown:?}"
    );
    assert_eq!(
        header("shoulder_pan,shoulder_lift,elbow,wrist_1,wrist_2,wrist_2"),
        Some(Err(InputError::DuplicateMember {
            what: "header",
            name: "wrist_2".into()
        }))
    );
    assert_eq!(
        header("shoulder_pan,shoulder_lift,elbow,wrist_1,wrist_2"),
        Some(Err(InputError::MissingJoint {
            what: "header",
            name: "wrist_3".into()
        }))
    );
    assert!(matches!(
        header("shoulder_pan,shoulder_lift,elbow,wrist_1,wrist_2,wrist_3,tool0"),
        Some(Err(InputError::NotIndependent { what: "header", .. }))
    ));

    let cylindrical = robot("cylindrical.yaml");
    assert_eq!(columns(&cylindrical, "joint"), Some(Ok(vec![0, 1])));
    assert!(matches!(
        csv_header(&cylindrical, "joint,joint"),
        Some(Err(InputError::DuplicateMember { .. }))
    ));
}

/// Rows of numbers below a header are read in the header's order; JSON rows keep `q` order, and
/// a row's errors name its entries as they stand in the row. A header read for a chain of
/// another length is refused.
#[test]
fn rows_under_a_csv_header() {
    let ur5 = robot("ur5.yaml");
    let header = csv_header(
        &ur5,
        "wrist_3,shoulder_pan,elbow,shoulder_lift,wrist_2,wrist_1",
    )
    .expect("a row of names")
    .expect("every joint once");
    let row = |line: &str| parse_batch_row(&ur5, line, Some(&header)).map(|l| l.q);
    assert_eq!(
        row("6, 1, 3, 2, 5, 4"),
        Ok(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    );
    assert_eq!(row("6 1 3 2 5 4"), Ok(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
    assert_eq!(
        row("[6, 1, 3, 2, 5, 4]"),
        Ok(vec![6.0, 1.0, 3.0, 2.0, 5.0, 4.0])
    );
    assert_eq!(
        row("6,1,x,2,5,4"),
        Err(InputError::ListEntry {
            what: "q",
            index: 2,
            entry: "x".into()
        })
    );
    for (line, got) in [("6,1,3,2,5", 5), ("6,1,3,2,5,4,7", 7)] {
        assert_eq!(
            row(line),
            Err(InputError::WrongLength {
                what: "q",
                expected: 6,
                got
            }),
            "{line}"
        );
    }
    let planar = robot("planar3.yaml");
    assert_eq!(
        parse_batch_row(&planar, "1,2,3", Some(&header)),
        Err(InputError::WrongLength {
            what: "header",
            expected: 3,
            got: 6
        })
    );
}

#[test]
#[should_panic(expected = "Data was created for another chain")]
fn data_of_another_chain_is_a_programming_error() {
    let puma = robot("puma560.yaml");
    let planar = robot("planar3.yaml");
    let mut data = Data::new(&planar);
    let _ = forward_kinematics(&puma, &mut data, &[0.0; 6]);
}

#[test]
#[should_panic(
    expected = "kinechain: BatchData was created for another chain (3 moving joints, dof 3), not 'puma560' (6 moving joints, dof 6)"
)]
fn batch_data_of_another_chain_is_a_programming_error() {
    let puma = robot("puma560.yaml");
    let planar = robot("planar3.yaml");
    let mut data = kinechain::eval::batch::BatchData::new(&planar);
    let _ = kinechain::eval::batch::forward_kinematics_batch(&puma, &mut data, &[0.0; 6]);
}

#[test]
#[should_panic(
    expected = "single_precision::BatchData was created for another chain (3 moving joints, dof 3), not 'puma560' (6 moving joints, dof 6)"
)]
fn single_precision_data_of_another_chain_is_a_programming_error() {
    use kinechain::eval::batch::single_precision::{BatchData, forward_kinematics_batch};
    let puma = robot("puma560.yaml");
    let planar = robot("planar3.yaml");
    let mut data = BatchData::new(&planar);
    let _ = forward_kinematics_batch(&puma, &mut data, &[0.0; 6]);
}

/// The suggestion's bounds: a name at exactly a third of its length from a candidate (in length
/// and in edits) gets it; two letters swapped are two edits, at the start of a name as elsewhere.
#[test]
fn suggestions_are_bounded_by_the_edit_distance() {
    use kinechain::error::closest_name;
    let links = ["elbow", "link", "wrist"];
    for (name, expected) in [
        ("elbo", Some("elbow")), // one letter short, and a third of four letters is one
        ("elbw", Some("elbow")), // one letter left out
        ("xelbow", Some("elbow")), // one letter added at the start
        ("ilnk", None),          // two edits
        ("wirst", None),         // two edits
        ("wristxx", Some("wrist")), // two edits, within a third of seven letters
    ] {
        assert_eq!(closest_name(name, links).as_deref(), expected, "{name}");
    }
}

/// An unknown name draws a suggestion only when one name of the chain is clearly the closest:
/// one or two letters off (a third of the name's length), letter case ignored, and no other
/// name as close.
#[test]
fn unknown_names_suggest_only_a_clear_typo() {
    let panda = robot("panda.urdf");
    for (name, expected) in [
        ("panda_hnd", Some("panda_hand")),
        ("PANDA_HAND_TCP", Some("panda_hand_tcp")),
        ("panda_link9", None), // panda_link0 … panda_link8 are all one letter away
        ("gripper", None),
    ] {
        let e = panda.link_id(name).unwrap_err();
        assert_eq!(e.suggestion(), expected, "{name}");
        assert!(matches!(e, NameError::UnknownLink { .. }));
        let hint = expected.map(|s| format!(" (did you mean '{s}'?)"));
        assert_eq!(
            e.to_string(),
            format!("no link named '{name}'{}", hint.unwrap_or_default())
        );
    }
    for (name, expected) in [
        ("panda_jiont4", Some("panda_joint4")),
        ("panda_joint9", None),
        ("elbow", None),
    ] {
        let e = panda.joint_id(name).unwrap_err();
        assert_eq!(e.suggestion(), expected, "{name}");
        assert!(matches!(e, NameError::UnknownJoint { .. }));
        // A joint vector keyed by name carries the same suggestion.
        let e = joint_vector_from_json(&panda, &json!({ name: 0.0 }), "q").unwrap_err();
        assert!(
            matches!(&e, InputError::UnknownJoint { suggestion, .. } if suggestion.as_deref() == expected),
            "{e:?}"
        );
    }
    // Lengths are compared after lowercasing, as the distance is: each 'İ' of this link's name
    // lowercases to two characters, so the misspelt name's ten are one letter from its ten.
    let dotted = Chain::from_urdf_str(r#"<robot name="r"><link name="İİİİab"/></robot>"#).unwrap();
    let misspelt: String = "İİİİac".chars().flat_map(char::to_lowercase).collect();
    assert_eq!(
        dotted.link_id(&misspelt).unwrap_err().suggestion(),
        Some("İİİİab")
    );
    // A megabyte-long name (from a batch line, say) gets no suggestion; a name of the longest
    // length that is still compared, MAX_SUGGESTED_NAME characters, does.
    let long = format!("panda_joint1{}", "x".repeat(1 << 20));
    assert_eq!(panda.joint_id(&long).unwrap_err().suggestion(), None);
    let near_limit = "a".repeat(kinechain::error::MAX_SUGGESTED_NAME - 1);
    let chain = Chain::from_urdf_str(&format!(
        r#"<robot name="r"><link name="{near_limit}b"/></robot>"#
    ))
    .unwrap();
    assert_eq!(
        chain
            .link_id(&format!("{near_limit}c"))
            .unwrap_err()
            .suggestion(),
        Some(format!("{near_limit}b").as_str())
    );
}
