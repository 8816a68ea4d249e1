//! One bad file per failure mode (`tests/data/bad/`): each load fails with the expected error
//! kind, naming the file, the joint or link, and the field.

use crate::common::Scratch;
use kinechain::{
    Chain, Data, FieldProblem, LoadError, LoadErrorKind, ModelError, NotRigid, forward_kinematics,
};
use std::path::Path;

fn load(relative: &str) -> LoadError {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/bad")
        .join(relative);
    match Chain::from_file(&path) {
        Ok(chain) => panic!(
            "{relative}: loaded ({} dof) instead of failing",
            chain.dof()
        ),
        Err(e) => {
            assert_eq!(e.path(), path);
            let message = kinechain::error::error_chain(&e);
            assert!(
                message.contains(relative),
                "{relative}: message '{message}' does not name the file"
            );
            assert!(
                !message.contains('\n'),
                "{relative}: multi-line message '{message}'"
            );
            e
        }
    }
}

fn message(e: &LoadError) -> String {
    kinechain::error::error_chain(e)
}

fn field(e: &LoadError) -> (Option<&str>, &str, &FieldProblem) {
    match e.kind() {
        LoadErrorKind::Field {
            joint,
            field,
            problem,
            ..
        } => (joint.as_deref(), field.as_str(), problem),
        other => panic!("expected a field error, got {other:?}"),
    }
}

fn yaml(e: &LoadError) -> (Option<&str>, Option<u32>, &str) {
    match e.kind() {
        LoadErrorKind::Yaml {
            joint,
            line,
            message,
            ..
        } => (joint.as_deref(), *line, message.as_str()),
        other => panic!("expected a YAML error, got {other:?}"),
    }
}

/// The field a parser error names, if any.
fn yaml_field(e: &LoadError) -> Option<&str> {
    match e.kind() {
        LoadErrorKind::Yaml { field, .. } => field.as_deref(),
        other => panic!("expected a YAML error, got {other:?}"),
    }
}

/// The message of the URDF parser's error for `text`.
fn urdf_message(text: &str) -> String {
    match Chain::from_urdf_str(text).unwrap_err().kind() {
        kind @ LoadErrorKind::Urdf { .. } => kind.to_string(),
        other => panic!("expected a URDF error, got {other:?}"),
    }
}

fn model(e: &LoadError) -> &ModelError {
    match e.kind() {
        LoadErrorKind::Model { error, .. } => error,
        other => panic!("expected a model error, got {other:?}"),
    }
}

#[test]
fn yaml_unknown_keys_name_the_key_and_the_joint() {
    let e = load("yaml/unknown_key.yaml");
    let (joint, line, msg) = yaml(&e);
    assert_eq!(joint, Some("j2"));
    assert_eq!(line, Some(7));
    assert!(msg.contains("unknown field `alhpa`"), "{msg}");
    // The whole message places it: line and column (of the key), then the joint.
    let whole = message(&e);
    assert!(whole.contains("line 7 column 5: joint 'j2': "), "{whole}");

    let e = load("yaml/unknown_top_key.yaml");
    let (joint, _, msg) = yaml(&e);
    assert_eq!(joint, None);
    assert!(msg.contains("`convension`"), "{msg}");
}

/// A parser error names the joint and the field whose value holds it, in block and flow style
/// and in nested frames, but not a key the message names itself, nor the first key of a mapping
/// when the error is the mapping's (a missing key).
#[test]
fn yaml_parser_errors_name_the_field() {
    let cases = [
        (
            "convention: standard\njoints:\n  - name: j1\n    type: revolute\n    a: 1\n    alpha: 0\n    d: 1.5 m\n    theta: 0\n",
            Some("j1"),
            Some("d"),
        ),
        (
            "convention: standard\njoints:\n  - {name: j1, type: revolute, a: 1, alpha: [0], d: 0, theta: 0}\n",
            Some("j1"),
            Some("alpha"),
        ),
        (
            "convention: standard\njoints:\n  - {type: revolute, a: 1, alpha: 0, d: 0, theta: \"x\"}\n",
            Some("#1"),
            Some("theta"),
        ),
        (
            "convention: axis\njoints:\n  - {name: j1, type: revolute, axis: [0, 0, 1], origin: {xyz: [0, 0, 1 m]}}\n",
            Some("j1"),
            Some("origin.xyz"),
        ),
        (
            "convention: standard\nbase: {rpy: [0, 0, one]}\njoints: []\n",
            None,
            Some("base.rpy"),
        ),
        (
            "convention: standard\nangle_unit: grad\njoints: []\n",
            None,
            Some("angle_unit"),
        ),
        (
            "convention: standard\njoints:\n  - name: j1\n    type: revolute\n    a: 1\n    d: 0\n    theta: 0\n    alhpa: 0\n",
            Some("j1"),
            None,
        ),
        ("joints: []\n", None, None),
        (
            "convention: standard\njoints:\n  - name: j1\n    type: revolute\n    a: 1\n    a: 2\n",
            Some("j1"),
            None,
        ),
        // Beside a merge key, whose entries come after the keys written out.
        (
            "convention: standard\njoints:\n  - &rev {name: j1, type: revolute, a: 1, alpha: 0, d: 0, theta: 0, limits: [-3, 3]}\n  - {<<: *rev, name: j2, d: oops}\n",
            Some("j2"),
            Some("d"),
        ),
    ];
    for (text, joint, field) in cases {
        let e = Chain::from_dh_yaml_str(text).unwrap_err();
        assert_eq!(
            (yaml(&e).0, yaml_field(&e)),
            (joint, field),
            "{text}: {e:?}"
        );
    }
}

/// A file that writes its joints through anchors, aliases and merge keys loads as the same file
/// written out (with 59 aliases to each of two anchors, beyond the ratio the parser refuses by
/// default), and an error in its last joint is still placed (the parses stop replaying aliases
/// at four events per byte of the file; this one replays about 0.6).
#[test]
fn anchors_aliases_and_merge_keys() {
    let joints = 60;
    let template = "  - &rev {name: j1, type: revolute, a: 0.25, alpha: 1.5, d: 0.125, theta: 0, limits: &turn [-3, 3]}\n";
    let written = |i: usize| {
        format!(
            "  - {{name: j{i}, type: revolute, a: 0.25, alpha: 1.5, d: 0.125, theta: 0, limits: [-3, 3]}}\n"
        )
    };
    let aliased =
        |i: usize, last: &str| format!("  - {{<<: *rev, name: j{i}, limits: *turn{last}}}\n");
    let header = "convention: standard\njoints:\n";
    let mut short = header.to_string() + template;
    let mut long = header.to_string() + &written(1);
    for i in 2..=joints {
        short += &aliased(i, "");
        long += &written(i);
    }
    let (short, long) = (
        Chain::from_dh_yaml_str(&short).unwrap(),
        Chain::from_dh_yaml_str(&long).unwrap(),
    );
    assert_eq!(short.dof(), joints);
    let q: Vec<f64> = (0..joints).map(|i| (i as f64 * 0.37).sin()).collect();
    let (mut a, mut b) = (Data::new(&short), Data::new(&long));
    let (pa, pb) = (
        forward_kinematics(&short, &mut a, &q).unwrap(),
        forward_kinematics(&long, &mut b, &q).unwrap(),
    );
    let tip = |c: &Chain| c.link_id(&format!("link{joints}")).unwrap();
    assert_eq!(
        pa.world_from_link(tip(&short)).to_rows(),
        pb.world_from_link(tip(&long)).to_rows()
    );
    for (j, k) in short.joints().iter().zip(long.joints()) {
        assert_eq!(j.limits(), k.limits(), "{}", j.name());
    }

    let mut bad = header.to_string() + template;
    for i in 2..=joints {
        bad += &aliased(i, if i == joints { ", a: x" } else { "" });
    }
    let e = Chain::from_dh_yaml_str(&bad).unwrap_err();
    let last = format!("j{joints}");
    assert_eq!(
        (yaml(&e).0, yaml_field(&e)),
        (Some(last.as_str()), Some("a")),
        "{e:?}"
    );
}

/// A file beyond one of the YAML parser's limits (here 250 000 nodes: 20 000 joints of 13 nodes
/// each) is refused with the parser's count and what the limit is for.
#[test]
fn a_parser_limit_says_what_it_is_for() {
    let joints: String = (0..20_000)
        .map(|i| format!("  - {{name: j{i}, type: revolute, a: 0, alpha: 0, d: 0, theta: 0}}\n"))
        .collect();
    let text = format!("convention: standard\njoints:\n{joints}");
    let e = Chain::from_dh_yaml_str(&text).unwrap_err();
    let message = yaml(&e).2;
    assert!(
        message.starts_with("budget breached: Nodes")
            && message.ends_with("(a limit of the YAML parser against hostile files)"),
        "{message}"
    );
}

#[test]
fn yaml_missing_and_mistyped_fields() {
    let e = load("yaml/missing_field.yaml");
    let (joint, name, problem) = field(&e);
    assert_eq!((joint, name), (Some("j1"), "d"));
    assert!(matches!(problem, FieldProblem::Missing { .. }));
    assert!(
        message(&e).ends_with("joint 'j1': d: missing (required for convention standard)"),
        "{e}"
    );

    let e = load("yaml/missing_convention.yaml");
    assert!(yaml(&e).2.contains("missing field `convention`"));

    let e = load("yaml/wrong_type.yaml");
    assert_eq!(yaml(&e).0, Some("j1"));
    assert_eq!(yaml_field(&e), Some("a"));
    assert!(e.kind().to_string().contains("joint 'j1': a: "), "{e:?}");

    let e = load("yaml/axis_without_origin.yaml");
    let (joint, name, problem) = field(&e);
    assert_eq!((joint, name), (Some("j1"), "origin"));
    assert!(matches!(problem, FieldProblem::Missing { .. }));
    assert!(
        message(&e).ends_with("joint 'j1': origin: missing (required for convention axis)"),
        "{e}"
    );

    // A limits list of another length than two says what limits take.
    let cylindrical = "convention: axis\njoints:\n  - {name: c, link: l, type: cylindrical, \
                       origin: {xyz: [0, 0, 0]}, axis: [0, 0, 1], limits: LIMITS}\n";
    for (limits, length) in [("[1]", 1), ("[1, 2, 3]", 3)] {
        let e = Chain::from_dh_yaml_str(&cylindrical.replace("LIMITS", limits)).unwrap_err();
        assert!(
            message(&e).ends_with(&format!(
                "joint 'c': limits: invalid length {length}, expected [lower, upper] or \
                 {{theta: [lower, upper], d: [lower, upper]}}"
            )),
            "{e}"
        );
    }
}

#[test]
fn yaml_non_finite_numbers() {
    for (file, name) in [("yaml/nan.yaml", "d"), ("yaml/inf.yaml", "a")] {
        let e = load(file);
        let (joint, f, problem) = field(&e);
        assert_eq!((joint, f), (Some("j1"), name), "{file}");
        assert!(matches!(problem, FieldProblem::NonFinite { .. }), "{file}");
    }
}

#[test]
fn yaml_bad_axes() {
    let e = load("yaml/zero_axis.yaml");
    let (joint, f, problem) = field(&e);
    assert_eq!(
        (joint, f, problem),
        (Some("j1"), "axis", &FieldProblem::ZeroAxis)
    );

    let e = load("yaml/malformed_axis.yaml");
    let (joint, _, msg) = yaml(&e);
    assert_eq!(joint, Some("j1"));
    assert!(msg.contains("invalid length"), "{msg}");
    assert_eq!(yaml_field(&e), Some("axis"));
}

#[test]
fn yaml_duplicate_names() {
    assert_eq!(
        model(&load("yaml/duplicate_joint.yaml")),
        &ModelError::DuplicateJoint { name: "j1".into() }
    );
    assert_eq!(
        model(&load("yaml/duplicate_link.yaml")),
        &ModelError::DuplicateLink { name: "arm".into() }
    );
    assert_eq!(
        model(&load("yaml/empty_name.yaml")),
        &ModelError::EmptyName { what: "joint" }
    );
    // The tool is a link and a fixed joint under one name: a name already taken is the tool's
    // error, not a duplicate the file does not contain.
    for (file, owner, name) in [
        ("yaml/tool_named_like_a_joint.yaml", "joint", "j2"),
        ("yaml/tool_named_like_a_link.yaml", "link", "arm"),
    ] {
        let e = load(file);
        assert_eq!(
            field(&e),
            (
                None,
                "tool.name",
                &FieldProblem::NameTaken {
                    name: name.into(),
                    owner
                }
            )
        );
        assert!(
            message(&e).ends_with(&format!(
                "tool.name: '{name}' is already the name of a {owner}"
            )),
            "{}",
            message(&e)
        );
    }
    let e = load("yaml/duplicate_key.yaml");
    // Placed in its joint, without the parser's advice on its own options.
    assert_eq!(yaml(&e), (Some("j1"), Some(6), "duplicate mapping key: a"));
}

#[test]
fn yaml_reversed_limits() {
    let e = load("yaml/reversed_limits.yaml");
    let (joint, f, problem) = field(&e);
    assert_eq!((joint, f), (Some("j1"), "limits"));
    assert_eq!(
        problem,
        &FieldProblem::ReversedLimits {
            lower: 1.0,
            upper: -1.0
        }
    );
}

#[test]
fn yaml_matrices_must_be_rigid() {
    let e = load("yaml/non_rigid_matrix.yaml");
    let (joint, f, problem) = field(&e);
    assert_eq!((joint, f), (None, "base.matrix"));
    assert!(matches!(
        problem,
        FieldProblem::NotRigid(NotRigid::NotOrthonormal { .. })
    ));

    let e = load("yaml/reflection_matrix.yaml");
    let (_, f, problem) = field(&e);
    assert_eq!(f, "tool.matrix");
    assert!(matches!(
        problem,
        FieldProblem::NotRigid(NotRigid::Reflection { .. })
    ));

    let e = load("yaml/matrix_and_xyz.yaml");
    assert!(matches!(field(&e).2, FieldProblem::NotAllowed { .. }));
}

#[test]
fn yaml_keys_that_do_not_belong() {
    let e = load("yaml/dh_with_origin.yaml");
    let (joint, f, problem) = field(&e);
    assert_eq!((joint, f), (Some("j1"), "origin"));
    assert!(matches!(problem, FieldProblem::NotAllowed { .. }));
    assert!(
        message(&e).ends_with("joint 'j1': origin: not allowed for convention standard"),
        "{e}"
    );

    let e = load("yaml/cylindrical_pair_limits.yaml");
    assert!(matches!(field(&e).2, FieldProblem::Shape { .. }));

    let e = load("yaml/limits_on_fixed.yaml");
    assert!(matches!(field(&e).2, FieldProblem::NotAllowed { .. }));

    let e = load("yaml/degrees_tag_on_length.yaml");
    let (joint, f, problem) = field(&e);
    assert_eq!((joint, f), (Some("j1"), "d"));
    assert!(matches!(problem, FieldProblem::Shape { .. }));
}

/// A `deg(..)`/`rad(..)` conversion in a length (or a prismatic joint's limits, or a tool's
/// position) is refused like a unit tag, rather than read as the angle's radians in metres; an
/// expression without a unit (`pi/2`) is a plain number.
#[test]
fn yaml_angle_conversions_in_lengths() {
    let text = |a: &str, limits: &str, tool: &str| {
        format!(
            "convention: standard\ntool: {{xyz: [0, 0, {tool}]}}\njoints:\n  - {{name: j1, type: prismatic, a: {a}, alpha: 0, d: 0, theta: 0, limits: [0, {limits}]}}\n"
        )
    };
    for (a, limits, tool, at) in [
        ("deg(90)", "1", "0", "a"),
        ("1", "rad(1)", "0", "limits"),
        ("1", "1", "deg(1)", "tool.xyz"),
    ] {
        let e = Chain::from_dh_yaml_str(&text(a, limits, tool)).unwrap_err();
        let (_, f, problem) = field(&e);
        assert_eq!(f, at, "{problem}");
        assert!(matches!(problem, FieldProblem::Shape { .. }), "{problem}");
        assert!(problem.to_string().contains("deg(..)/rad(..)"), "{problem}");
    }
    let chain = Chain::from_dh_yaml_str(&text("pi/2", "pi", "0")).unwrap();
    let mut data = kinechain::Data::new(&chain);
    let poses = kinechain::forward_kinematics(&chain, &mut data, &[0.0]).unwrap();
    let link1 = poses.world_from_link(chain.link_id("link1").unwrap());
    assert_eq!(link1.translation().x, std::f64::consts::FRAC_PI_2);
}

#[test]
fn yaml_unknown_values_and_tags() {
    for file in [
        "yaml/unknown_convention.yaml",
        "yaml/unknown_joint_type.yaml",
        "yaml/unknown_angle_unit.yaml",
    ] {
        let e = load(file);
        assert!(
            yaml(&e).2.contains("unknown variant"),
            "{file}: {}",
            message(&e)
        );
    }
    let e = load("yaml/unknown_tag.yaml");
    let (joint, _, msg) = yaml(&e);
    assert_eq!(joint, Some("j1"));
    assert!(msg.contains("!foo"), "{msg}");
    assert_eq!(yaml_field(&e), Some("alpha"));

    let e = load("yaml/ambiguous_angle.yaml");
    assert!(matches!(field(&e).2, FieldProblem::AmbiguousAngle { .. }));
}

#[test]
fn yaml_empty_syntax_and_garbage() {
    assert!(matches!(
        load("yaml/empty.yaml").kind(),
        LoadErrorKind::Empty
    ));
    assert!(matches!(
        load("yaml/comment_only.yaml").kind(),
        LoadErrorKind::Empty
    ));
    // Document markers alone hold no document either.
    for text in ["---\n", "...\n", "# robot\n---\n...\n"] {
        let e = Chain::from_dh_yaml_str(text).unwrap_err();
        assert!(
            matches!(e.kind(), LoadErrorKind::Empty),
            "{text:?}: {}",
            message(&e)
        );
    }
    let e = load("yaml/syntax_error.yaml");
    assert!(yaml(&e).1.is_some(), "{}", message(&e));
    // A second document is refused, without the parser's advice on its own functions.
    let e = Chain::from_dh_yaml_str("convention: standard\njoints: []\n---\nconvention: axis\n")
        .unwrap_err();
    let (_, line, msg) = yaml(&e);
    assert_eq!(line, Some(4));
    assert_eq!(msg, "multiple YAML documents detected");
    assert!(matches!(
        load("yaml/binary.yaml").kind(),
        LoadErrorKind::NotText { .. }
    ));
}

#[test]
fn urdf_unsupported_joint_types_are_refused_not_made_fixed() {
    {
        let (file, kind) = ("urdf/screw.urdf", "screw");
        let e = load(file);
        let (joint, f, problem) = field(&e);
        assert_eq!(f, "type", "{file}");
        assert!(joint.is_some(), "{file}");
        assert_eq!(
            problem,
            &FieldProblem::UnsupportedJointType { kind: kind.into() }
        );
    }
}

#[test]
fn urdf_topology_errors_name_the_joint_or_link() {
    assert!(
        matches!(model(&load("urdf/cycle.urdf")), ModelError::TwoParents { link, .. } if link == "a")
    );
    assert!(matches!(
        model(&load("urdf/loop_without_root.urdf")),
        ModelError::Cycle { .. }
    ));
    assert_eq!(
        model(&load("urdf/multiple_roots.urdf")),
        &ModelError::MultipleRoots {
            roots: vec!["base".into(), "other_base".into()]
        }
    );
    assert_eq!(
        model(&load("urdf/dangling.urdf")),
        &ModelError::UnknownLink {
            joint: "j1".into(),
            role: "child",
            link: "ghost".into(),
            suggestion: None
        }
    );
    assert!(matches!(
        model(&load("urdf/two_parents.urdf")),
        ModelError::TwoParents { link, first, second } if link == "b" && first == "j2" && second == "j3"
    ));
    assert_eq!(model(&load("urdf/no_links.urdf")), &ModelError::NoLinks);
    // A misspelt link name is most likely the declared link one letter away.
    let misspelt = r#"<robot name="r"><link name="base"/><link name="forearm"/>
        <joint name="j1" type="revolute"><parent link="base"/><child link="foreram"/>
        <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#;
    let e = Chain::from_urdf_str(misspelt).unwrap_err();
    let e = model(&e);
    assert!(
        matches!(&e, ModelError::UnknownLink { link, suggestion: Some(s), .. } if link == "foreram" && s == "forearm"),
        "{e:?}"
    );
    assert!(e.to_string().ends_with("(did you mean 'forearm'?)"), "{e}");
    let mimic = r#"<robot name="r"><link name="base"/><link name="a"/><link name="b"/>
        <joint name="elbow" type="revolute"><parent link="base"/><child link="a"/>
        <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
        <joint name="follower" type="revolute"><parent link="a"/><child link="b"/><mimic joint="Elbow"/>
        <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#;
    let e = Chain::from_urdf_str(mimic).unwrap_err();
    assert!(
        matches!(model(&e), ModelError::UnknownMimicTarget { target, suggestion: Some(s), .. } if target == "Elbow" && s == "elbow"),
        "{e:?}"
    );
}

/// A URDF's model errors place the element at fault: the joint they name, the second of two
/// links or joints with one name, the joint that gives a link its second parent, the second root.
#[test]
fn urdf_model_errors_give_the_element_s_place() {
    for (file, place) in [
        ("urdf/dangling.urdf", (4, 3)),
        ("urdf/two_parents.urdf", (6, 3)),
        ("urdf/duplicate_link.urdf", (3, 38)),
        ("urdf/duplicate_joint.urdf", (5, 3)),
        ("urdf/multiple_roots.urdf", (3, 40)),
        ("urdf/mimic_missing.urdf", (4, 3)),
    ] {
        let e = load(file);
        assert_eq!(e.position(), Some((place.0, Some(place.1))), "{file}");
        assert!(
            message(&e).contains(&format!("line {} column {}: ", place.0, place.1)),
            "{file}: {}",
            message(&e)
        );
    }
}

#[test]
fn urdf_mimic_errors() {
    assert!(matches!(
        model(&load("urdf/mimic_cycle.urdf")),
        ModelError::MimicCycle { .. }
    ));
    assert_eq!(
        model(&load("urdf/mimic_missing.urdf")),
        &ModelError::UnknownMimicTarget {
            joint: "ja".into(),
            target: "nowhere".into(),
            suggestion: None
        }
    );
}

#[test]
fn urdf_bad_numbers_and_axes() {
    let e = load("urdf/zero_axis.urdf");
    assert_eq!(field(&e), (Some("ja"), "axis.xyz", &FieldProblem::ZeroAxis));
    let e = load("urdf/nan_origin.urdf");
    let (joint, f, problem) = field(&e);
    assert_eq!((joint, f), (Some("ja"), "origin.xyz"));
    assert!(matches!(problem, FieldProblem::NonFinite { .. }));
    let e = load("urdf/inf_axis.urdf");
    assert!(matches!(
        field(&e),
        (Some("ja"), "axis.xyz", FieldProblem::NonFinite { .. })
    ));
    let e = load("urdf/malformed_xyz.urdf");
    assert!(
        matches!(e.kind(), LoadErrorKind::Urdf { message, .. } if message.contains("1 x 2 3")),
        "{}",
        message(&e)
    );
    // The parser would read two or four numbers, or skip a word among them; each is refused,
    // in <origin> and in <axis> alike.
    for (element, value) in [
        ("origin", "1 0"),
        ("origin", "1 0 0 0"),
        ("axis", "0 0"),
        ("axis", "0 x 1"),
    ] {
        let text = format!(
            "<robot name=\"r\">\n<link name=\"a\"/><link name=\"b\"/>\n\
             <joint name=\"j\" type=\"continuous\"><parent link=\"a\"/><child link=\"b\"/>\n\
             <{element} xyz=\"{value}\"/></joint>\n</robot>"
        );
        // The column is the attribute's, after `<element `.
        let column = element.len() + 3;
        assert_eq!(
            urdf_message(&text),
            format!(
                "invalid URDF: line 4 column {column}: joint 'j': <{element}> attribute xyz=\"{value}\" is not three numbers"
            )
        );
    }
}

#[test]
fn urdf_limits() {
    let e = load("urdf/missing_limit.urdf");
    assert_eq!(
        field(&e),
        (
            Some("ja"),
            "limit",
            &FieldProblem::MissingLimit { kind: "revolute" }
        )
    );
    // An infinite bound is refused, as in a DH table (it printed as null, and `convert` wrote
    // the joint without bounds, which URDF reads back as [0, 0]).
    for (lower, upper) in [("-inf", "1"), ("-1", "1e400"), ("nan", "1")] {
        let text = format!(
            r#"<robot name="r"><link name="a"/><link name="b"/><joint name="j1" type="revolute"><parent link="a"/><child link="b"/><limit lower="{lower}" upper="{upper}" effort="1" velocity="1"/></joint></robot>"#
        );
        let e = Chain::from_urdf_str(&text).unwrap_err();
        assert!(
            matches!(
                field(&e),
                (Some("j1"), "limit", FieldProblem::NonFinite { .. })
            ),
            "{lower} {upper}: {e:?}"
        );
    }
}

/// A `<limit>` that gives neither `lower` nor `upper`, or a lower bound above the upper one (a
/// way some tools write "no limit"), loads as a joint without position limits, with a warning;
/// bounds that are equal load as written, with a warning that the joint cannot move.
#[test]
fn urdf_limits_that_are_not_a_range_draw_a_warning() {
    let urdf = |limit: &str| {
        format!(
            r#"<robot name="r"><link name="a"/><link name="b"/><joint name="j1" type="prismatic"><parent link="a"/><child link="b"/>{limit}</joint></robot>"#
        )
    };
    let q = [0.1];
    for (limit, warning) in [
        (
            r#"<limit effort="1" velocity="1"/>"#,
            "gives neither lower nor upper",
        ),
        (
            r#"<limit lower="1" upper="-1" effort="1" velocity="1"/>"#,
            "lower 1 is greater than upper -1",
        ),
    ] {
        let chain = Chain::from_urdf_str(&urdf(limit)).unwrap();
        assert_eq!(chain.warnings().len(), 1, "{limit}");
        let w = &chain.warnings()[0];
        assert!(
            w.starts_with("line 1 column 118: joint 'j1': <limit> ")
                && w.contains(warning)
                && w.ends_with("loaded without position limits"),
            "{w}"
        );
        assert_eq!(chain.joints()[0].limits(), &[None]);
        let mut data = kinechain::Data::new(&chain);
        assert!(kinechain::forward_kinematics(&chain, &mut data, &q).is_ok());
    }
    let chain = Chain::from_urdf_str(&urdf(
        r#"<limit lower="0" upper="0" effort="1" velocity="1"/>"#,
    ))
    .unwrap();
    assert_eq!(chain.warnings().len(), 1);
    assert!(
        chain.warnings()[0].contains("joint 'j1'") && chain.warnings()[0].contains("no motion"),
        "{:?}",
        chain.warnings()
    );
    let mut data = kinechain::Data::new(&chain);
    assert!(kinechain::forward_kinematics(&chain, &mut data, &q).is_err());
    let chain = Chain::from_urdf_str(&urdf(
        r#"<limit lower="0" upper="0.1" effort="1" velocity="1"/>"#,
    ))
    .unwrap();
    assert!(chain.warnings().is_empty(), "{:?}", chain.warnings());
}

#[test]
fn urdf_duplicates_syntax_and_empty() {
    assert_eq!(
        model(&load("urdf/duplicate_joint.urdf")),
        &ModelError::DuplicateJoint { name: "j".into() }
    );
    assert_eq!(
        model(&load("urdf/duplicate_link.urdf")),
        &ModelError::DuplicateLink { name: "a".into() }
    );
    assert!(matches!(
        load("urdf/syntax_error.urdf").kind(),
        LoadErrorKind::Urdf { .. }
    ));
    assert!(matches!(
        load("urdf/empty.urdf").kind(),
        LoadErrorKind::Empty
    ));
    // The parser's messages in the file's terms: a file cut short says so.
    let cut = urdf_message(r#"<robot name="r"><link name="a"/><link name="b"/><joint name="j""#);
    assert!(cut.contains("not a complete XML document"), "{cut}");
}

/// Every error of a URDF file places the element or attribute at fault by line and column, and
/// says what is wrong in the file's terms (never in the parser's).
#[test]
fn urdf_errors_name_the_element_and_its_place() {
    let urdf = |joint: &str| {
        let text = format!(
            "<robot name=\"r\">\n<link name=\"a\"/>\n<link name=\"b\"/>\n<link name=\"c\"/>\n\
             <joint name=\"j1\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\n\
             {joint}\n</robot>"
        );
        let e = Chain::from_urdf_str(&text).unwrap_err();
        kinechain::error::error_chain(&e)
    };
    let cases = [
        (
            r#"<joint name="j2"><parent link="b"/><child link="c"/></joint>"#,
            "invalid URDF: line 6 column 1: joint 'j2' has no type attribute (URDF requires one)",
        ),
        (
            r#"<joint type="fixed"><parent link="b"/><child link="c"/></joint>"#,
            "invalid URDF: line 6 column 1: <joint> has no name attribute (URDF requires one)",
        ),
        (
            r#"<joint name="j2" type="fixed"><parent link="b"/></joint>"#,
            "invalid URDF: line 6 column 1: joint 'j2' has no <child> element",
        ),
        (
            r#"<joint name="j2" type="fixed"><parent link="b"/><child/></joint>"#,
            "invalid URDF: line 6 column 49: joint 'j2': <child> has no link attribute (URDF requires one)",
        ),
        (
            r#"<joint name="j2" type="revolute"><parent link="b"/><child link="c"/>
               <limit lower="-1" upper="one" effort="1" velocity="1"/></joint>"#,
            "invalid URDF: line 7 column 34: joint 'j2': <limit> attribute upper=\"one\" is not a number",
        ),
        (
            r#"<joint name="j2" type="revolute"><parent link="b"/><child link="c"/>
               <limit lower="${-pi}" upper="1" effort="1" velocity="1"/></joint>"#,
            "invalid URDF: line 7 column 23: joint 'j2': <limit> attribute lower=\"${-pi}\" is not a number (a xacro expression: expand the file first",
        ),
        (
            r#"<joint name="j2" type="hinge"><parent link="b"/><child link="c"/></joint>"#,
            "line 6 column 24: joint 'j2': type: joint type 'hinge' is not supported",
        ),
        (
            r#"<joint name="j2" type="continuous"><parent link="b"/><child link="c"/><axis xyz="0 0 0"/></joint>"#,
            "line 6 column 71: joint 'j2': axis.xyz: zero length",
        ),
        (
            r#"<joint name="j2" type="fixed"><parent link="b"/><child link="c"/><origin xyz="0 0 1"/><origin rpy="0 0 1"/></joint>"#,
            "invalid URDF: line 6 column 87: joint 'j2' has a second <origin> (the first is at line 6 column 66); a joint has one",
        ),
        (
            r#"<joint name="j2" type="continuous"><parent link="b"/><child link="c"/><mimic/></joint>"#,
            "invalid URDF: line 6 column 71: joint 'j2': <mimic> has no joint attribute (URDF requires one)",
        ),
        (
            r#"<link/>"#,
            "invalid URDF: line 6 column 1: <link> has no name attribute (URDF requires one)",
        ),
        // Not well-formed XML is an error that says so, in the file's terms.
        (
            r#"<joint name="j2" type="fixed"><parent link="b"/><child link="c"/></jiont>"#,
            "invalid URDF: line 6 column 66: not well-formed XML: </jiont> where </joint> closes the open element",
        ),
        (
            r#"<joint name="j2" name="j3" type="fixed"><parent link="b"/><child link="c"/></joint>"#,
            "invalid URDF: line 6 column 18: not well-formed XML: attribute name is given twice",
        ),
        (
            r#"<joint name="j2" type="fixed"><parent link="b&c"/><child link="c"/></joint>"#,
            "invalid URDF: line 6 column 46: not well-formed XML: a '&' that starts no entity",
        ),
    ];
    for (joint, expected) in cases {
        let message = urdf(joint);
        let expected = format!("{}: {expected}", "cannot load <string>");
        assert!(
            message.starts_with(&expected),
            "{message}\nexpected {expected}"
        );
        for internal in [
            "XmlEvent",
            "namespace map",
            "Expected token",
            "TextPos",
            "custom:",
        ] {
            assert!(!message.contains(internal), "{message}");
        }
    }
}

/// A document whose root is not `<robot>`, a `<robot>` without a name, or anything but markup
/// around the root is refused.
#[test]
fn urdf_root_must_be_a_named_robot() {
    let cases = [
        (
            "<?xml version=\"1.0\"?>\n<!-- a comment -->\n<robt name=\"r\"><link name=\"a\"/></robt>",
            "line 3 column 1: the root element is <robt>; a URDF file's is <robot>",
        ),
        (
            "<sdf version=\"1.6\"><model name=\"m\"><link name=\"a\"/></model></sdf>",
            "line 1 column 1: the root element is <sdf>; a URDF file's is <robot>",
        ),
        (
            "<?xml version=\"1.0\"?>\n<robot>\n<link name=\"a\"/>\n</robot>",
            "line 2 column 1: <robot> has no name attribute (URDF requires one)",
        ),
        (
            "<robot name=\"r\">\n<link name=\"a\"/>\n</robot>\n<robot name=\"s\"/>\n",
            "line 4 column 1: not well-formed XML: <robot> follows the root element; a URDF file has one root element",
        ),
        (
            "<robot name=\"r\">\n<link name=\"a\"/>\n</robot>\n</robot>\n",
            "line 4 column 1: not well-formed XML: </robot> closes no open element",
        ),
        // Text outside the root (a truncated copy, a paste gone wrong).
        (
            "hello\n<robot name=\"r\"><link name=\"a\"/></robot>",
            "line 1 column 1: not well-formed XML: text outside the root element",
        ),
        (
            "<robot name=\"r\"><link name=\"a\"/></robot>\n<!-- c -->\nlink b",
            "line 3 column 1: not well-formed XML: text outside the root element",
        ),
        (
            "<robot name=\"r\"/>\n\nx",
            "line 3 column 1: not well-formed XML: text outside the root element",
        ),
        (
            "<?xml version=\"1.0\"?>\n<robot name=\"r\"/>\nx",
            "line 3 column 1: not well-formed XML: text outside the root element",
        ),
        (
            "<robot name=\"r\"><link name=\"a\"/>\n<link name=\"b\">",
            "line 2 column 16: not a complete XML document (the file ends inside an element)",
        ),
        (
            "<!DOCTYPE robot>\n<robot name=\"r\"><link name=\"a\"/></robot>",
            "line 1 column 1: a <!DOCTYPE> declaration is not accepted in a robot file",
        ),
    ];
    for (text, expected) in cases {
        assert_eq!(urdf_message(text), format!("invalid URDF: {expected}"));
    }
    // A byte order mark, the XML declaration, comments and blank lines around the root are not
    // text.
    for text in [
        "<robot name=\"r\"><link name=\"a\"/></robot>",
        "\u{feff}<?xml version=\"1.0\"?>\n<!-- c -->\n<robot name=\"r\">\n<link name=\"a\"/>\n</robot>\n<!-- end -->\n\n",
    ] {
        let chain = Chain::from_urdf_str(text).unwrap();
        assert_eq!(chain.name(), "r");
    }
}

/// An element or attribute that URDF does not define in a joint's kinematic parts, or an element
/// under `<robot>` it does not define, is skipped; it draws a warning naming the line and column
/// (and the joint and part), so that a typo (`<orgin>`, `rp=`, `lowr=`, `<jiont>`) does not
/// silently leave an identity origin, a zero bound or a missing joint.
#[test]
fn urdf_typos_in_a_joint_draw_warnings() {
    let urdf = |inside: &str| {
        format!(
            "<robot name=\"r\">\n<link name=\"a\"/><link name=\"b\"/>\n\
             <joint name=\"j\" type=\"revolute\">\n<parent link=\"a\"/><child link=\"b\"/>\n{inside}\n\
             </joint>\n</robot>"
        )
    };
    let limit = r#"<limit lower="-1" upper="1" effort="1" velocity="1"/>"#;
    let cases = [
        (
            format!(r#"<orgin xyz="1 0 0"/>{limit}"#),
            "line 5 column 1: joint 'j': <orgin> is not a URDF joint element and is ignored",
        ),
        (
            format!(r#"<origin xyz="1 0 0" rp="0 0 1"/>{limit}"#),
            "line 5 column 21: joint 'j': <origin> attribute rp is not a URDF attribute and is ignored (it takes xyz, rpy)",
        ),
        (
            r#"<limit lowr="-1" upper="1" effort="1" velocity="1"/>"#.to_string(),
            "line 5 column 8: joint 'j': <limit> attribute lowr is not a URDF attribute and is ignored (it takes lower, upper, effort, velocity)",
        ),
    ];
    for (inside, expected) in cases {
        let chain = Chain::from_urdf_str(&urdf(&inside)).unwrap();
        assert_eq!(chain.warnings(), [expected.to_string()], "{inside}");
    }
    // A misspelt joint under <robot> would be missing from the model.
    let misspelt = "<robot name=\"r\">\n<link name=\"a\"/>\n\
        <jiont name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></jiont>\n</robot>";
    let chain = Chain::from_urdf_str(misspelt).unwrap();
    assert_eq!(
        chain.warnings(),
        [
            "line 3 column 1: <jiont> is not a URDF element under <robot> and is ignored"
                .to_string()
        ]
    );
    // An attribute of <joint> itself other than name and type.
    let attribute = "<robot name=\"r\">\n<link name=\"a\"/><link name=\"b\"/>\n\
        <joint name=\"j\" type=\"fixed\" label=\"x\"><parent link=\"a\"/><child link=\"b\"/></joint>\n</robot>";
    let chain = Chain::from_urdf_str(attribute).unwrap();
    assert_eq!(
        chain.warnings(),
        [
            "line 3 column 30: joint 'j': attribute label is not a URDF joint attribute and is ignored"
                .to_string()
        ]
    );
    // Text where URDF has elements only: a stray character left by an edit.
    let stray = "<robot name=\"r\">\n<link name=\"a\"/>x\n<link name=\"b\">\n  y</link>\n\
        <joint name=\"j\" type=\"fixed\"><parent link=\"a\"/>><child link=\"b\"/></joint>\n</robot>";
    let chain = Chain::from_urdf_str(stray).unwrap();
    assert_eq!(
        chain.warnings(),
        [
            "line 2 column 17: text inside <robot> is not URDF and is ignored",
            "line 4 column 3: link 'b': text inside <link> is not URDF and is ignored",
            "line 5 column 48: joint 'j': text inside <joint> is not URDF and is ignored",
        ]
        .map(String::from)
    );
    // Single quotes are read as double quotes are (the joint is named, the typo found).
    let single = "<robot name='r'>\n<link name='a'/><link name='b'/>\n\
        <joint name='j' type='fixed'><parent link='a'/><child link='b'/><origin xyz='1 0 0' rp='0 0 1'/></joint>\n</robot>";
    let chain = Chain::from_urdf_str(single).unwrap();
    assert_eq!(
        chain.warnings(),
        ["line 3 column 85: joint 'j': <origin> attribute rp is not a URDF attribute and is ignored (it takes xyz, rpy)"
            .to_string()]
    );
    // Text right after a comment is found, and what extension elements hold is theirs to define.
    let commented = "<robot name=\"r\">\n<link name=\"a\"/><!-- c -->x<link name=\"b\"/>\n\
        <joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\n\
        <gazebo>text</gazebo>\n</robot>";
    let chain = Chain::from_urdf_str(commented).unwrap();
    assert_eq!(
        chain.warnings(),
        ["line 2 column 27: text inside <robot> is not URDF and is ignored".to_string()]
    );
    // Past twenty, the rest are counted rather than listed.
    let many = format!("{limit}{}", "<note/>\n".repeat(25));
    let chain = Chain::from_urdf_str(&urdf(&many)).unwrap();
    let warnings = chain.warnings();
    assert_eq!(warnings.len(), 21, "{warnings:?}");
    assert_eq!(
        warnings[19],
        "line 24 column 1: joint 'j': <note> is not a URDF joint element and is ignored"
    );
    assert!(
        warnings[20].starts_with("5 more warnings"),
        "{}",
        warnings[20]
    );
    // Vendor attributes on dynamics data, namespaced attributes and elements, and the defined
    // parts draw none.
    let clean = format!(
        r#"<origin xyz="1 0 0" rpy="0 0 1"/><axis xyz="0 0 1"/>{limit}
           <dynamics damping="0.1" D="1" K="7000" mu_coulomb="0"/>
           <safety_controller k_position="100" k_velocity="40" soft_lower_limit="-1" soft_upper_limit="1"/>
           <calibration rising="0"/>"#
    );
    let chain = Chain::from_urdf_str(&urdf(&clean)).unwrap();
    assert!(chain.warnings().is_empty(), "{:?}", chain.warnings());
    let named = r#"<robot name="r" xmlns:v="http://example.com/vendor"><link name="a"/><link name="b"/>
        <joint name="j" type="fixed" v:note="x"><parent link="a"/><child link="b"/><v:calibration/></joint>
        <material name="grey"/><transmission name="t"><type>simple</type></transmission>
        <gazebo reference="a"><mu1>0.2</mu1></gazebo><v:extra name="p"/> <!-- a comment -->
        </robot>"#;
    let chain = Chain::from_urdf_str(named).unwrap();
    assert!(chain.warnings().is_empty(), "{:?}", chain.warnings());
}

/// Files that a scan of the raw text misread: a `>` inside a quoted value hid a malformed
/// vector, a `<limit>` nested in `<dynamics>` passed as the joint's, an unexpanded xacro file
/// expanded, and a UTF-16 file gave a byte offset.
#[test]
fn urdf_hostile_files() {
    let e = load("urdf/gt_in_attribute.urdf");
    assert_eq!(
        message(&e).split_once(": ").unwrap().1,
        "invalid URDF: line 4 column 89: joint 'ja': <origin> attribute xyz=\"1 x 2 3\" is not three numbers"
    );
    assert_eq!(e.position(), Some((4, Some(89))));
    let e = load("urdf/limit_in_dynamics.urdf");
    assert_eq!(
        field(&e),
        (
            Some("ja"),
            "limit",
            &FieldProblem::MissingLimit { kind: "revolute" }
        )
    );
    assert_eq!(e.position(), Some((4, Some(3))));
    // Leftover xacro in a file saved as URDF is expanded (its macros are in the file).
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bad/urdf/unexpanded_xacro.urdf");
    let chain = Chain::from_file(&path).unwrap();
    assert!(chain.link_id("upper").is_ok());
    // An undeclared xacro prefix is named with the fix.
    let text = "<robot name=\"r\">\n  <xacro:include filename=\"arm.xacro\"/>\n</robot>";
    let e = Chain::from_urdf_str(text).unwrap_err();
    assert!(
        matches!(e.kind(), LoadErrorKind::Xacro(x) if x.line == Some(2)),
        "{}",
        message(&e)
    );
    assert!(message(&e).contains("xmlns:xacro"), "{}", message(&e));
    // A macro that is not defined, at the robot level (it could add links), is an error.
    let text = "<robot name=\"r\" xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n  <link name=\"a\"/>\n  <xacro:arm/>\n</robot>";
    let e = Chain::from_urdf_str(text).unwrap_err();
    assert!(
        message(&e).contains("unknown macro name: xacro:arm"),
        "{}",
        message(&e)
    );
    assert_eq!(e.position(), Some((3, Some(3))));
    let e = load("urdf/utf16.urdf");
    assert!(matches!(e.kind(), LoadErrorKind::Utf16), "{}", message(&e));
    assert!(message(&e).contains("UTF-16"), "{}", message(&e));
}

/// A chain of 40 000 joints, each mimicking the one before, resolves each joint once (following
/// every chain to its primary from every joint took 40 000²/2 steps), and composes the
/// multipliers and offsets: joint k follows joint 0 with multiplier 1 and offset k·0.001.
#[test]
fn long_mimic_chains_load_quickly() {
    let n = 40_000;
    let mut text = String::from("<robot name=\"r\">\n<link name=\"l0\"/>\n");
    for k in 1..=n {
        text += &format!("<link name=\"l{k}\"/>");
        text += &format!(
            "<joint name=\"j{k}\" type=\"continuous\"><parent link=\"l{}\"/><child link=\"l{k}\"/>",
            k - 1
        );
        if k > 1 {
            text += &format!("<mimic joint=\"j{}\" offset=\"0.001\"/>", k - 1);
        }
        text += "</joint>\n";
    }
    text += "</robot>\n";
    let start = std::time::Instant::now();
    let chain = Chain::from_urdf_str(&text).unwrap();
    let took = start.elapsed();
    assert!(took.as_secs_f64() < 2.0, "{took:?}");
    assert_eq!(chain.dof(), 1);
    let last = chain.joint(chain.joint_id(&format!("j{n}")).unwrap());
    let m = last.mimic().unwrap();
    assert_eq!(m.multiplier, 1.0);
    assert!(
        (m.offset - 0.001 * (n - 1) as f64).abs() < 1e-9,
        "{}",
        m.offset
    );
    // A cycle far down a long chain is still found, naming the first joint that leads into it.
    let cyclic = text.replace(
        "<joint name=\"j1\" type=\"continuous\"><parent link=\"l0\"/><child link=\"l1\"/>",
        &format!("<joint name=\"j1\" type=\"continuous\"><parent link=\"l0\"/><child link=\"l1\"/><mimic joint=\"j{n}\"/>"),
    );
    assert!(matches!(
        model(&Chain::from_urdf_str(&cyclic).unwrap_err()),
        ModelError::MimicCycle { joint } if joint == "j1"
    ));
}

/// Two merge keys in one mapping are refused like any other repeated key: the parser merged
/// both, each silently winning or losing on the keys they share. A list of merges is the way to
/// merge several.
#[test]
fn yaml_two_merge_keys_in_one_mapping() {
    let e = load("yaml/two_merge_keys.yaml");
    let (joint, line, msg) = yaml(&e);
    assert_eq!((joint, line), (Some("j1"), Some(7)));
    assert!(
        msg.starts_with("a second merge key `<<` in one mapping"),
        "{msg}"
    );
    assert_eq!(yaml_field(&e), None);
    let listed = "convention: standard\njoints:\n  - &t {name: j0, type: revolute, a: 0, alpha: 0, d: 0, theta: 0}\n  - &u {name: j9, type: revolute, a: 1, alpha: 0, d: 0, theta: 0}\n  - name: j1\n    <<: [*t, *u]\n";
    assert_eq!(Chain::from_dh_yaml_str(listed).unwrap().dof(), 3);
}

/// A robot path that is not a regular file is read up to the size limit: a pipe that ends
/// sooner loads, and a device that never ends (`/dev/zero`) is refused with a message that says
/// what happened rather than a size it does not have.
#[test]
fn robot_paths_that_are_not_regular_files() {
    let dir = Scratch::new("special");
    let zero = dir.path("zero.urdf");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let e = Chain::from_file(&zero).unwrap_err();
    assert!(
        matches!(e.kind(), LoadErrorKind::TooLarge { size: None, .. }),
        "{}",
        message(&e)
    );
    assert!(
        message(&e).ends_with("the input is not a regular file; reading stopped there"),
        "{}",
        message(&e)
    );
    let fifo = dir.path("fifo.urdf");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    let writer = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::write(fifo, crate::common::FIXED_ONLY_URDF).unwrap())
    };
    let chain = Chain::from_file(&fifo).unwrap();
    writer.join().unwrap();
    assert_eq!(chain.links().len(), 2);
}

#[test]
fn files_that_cannot_be_read() {
    let missing = Chain::from_file("tests/data/bad/does_not_exist.yaml").unwrap_err();
    assert!(matches!(missing.kind(), LoadErrorKind::Io(_)));
    let unknown = Chain::from_file("tests/data/bad/robot.sdf").unwrap_err();
    assert!(matches!(unknown.kind(), LoadErrorKind::UnknownFormat));
}

#[test]
fn every_bad_file_is_exercised() {
    // Keeps the corpus and this test in step: a new bad file needs an assertion above.
    let source = include_str!("loading_errors.rs");
    for dir in ["yaml", "urdf"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/bad")
            .join(dir);
        for entry in std::fs::read_dir(path).unwrap() {
            let name = entry.unwrap().file_name().into_string().unwrap();
            let needle = format!("{dir}/{name}\"");
            assert!(
                source.contains(&needle),
                "tests/data/bad/{dir}/{name} has no test"
            );
        }
    }
}

/// Resource attacks end quickly with an error: an alias bomb, a merge bomb, 20 000-deep nesting
/// (YAML and XML), an XML entity bomb, binary data, and a file over the size limit.
#[test]
fn resource_attacks_fail_fast() {
    let timed = |file: &str| {
        let start = std::time::Instant::now();
        let e = load(file);
        assert!(
            start.elapsed().as_secs_f64() < 2.0,
            "{file} took {:?}",
            start.elapsed()
        );
        e
    };
    let e = timed("yaml/alias_bomb.yaml");
    assert!(
        matches!(e.kind(), LoadErrorKind::Yaml { .. }),
        "{}",
        message(&e)
    );
    let e = timed("yaml/merge_bomb.yaml");
    let replays = yaml(&e).2;
    assert!(
        replays.contains("alias replay limit")
            && replays.ends_with("(aliases may replay 4 events per byte of the file)"),
        "{}",
        message(&e)
    );
    let e = timed("yaml/deep_nesting.yaml");
    assert!(yaml(&e).2.contains("recursion limit"), "{}", message(&e));
    let e = timed("urdf/deep_nesting.urdf");
    assert!(
        matches!(e.kind(), LoadErrorKind::Urdf { message, .. } if message.contains("nest deeper")),
        "{}",
        message(&e)
    );
    let e = timed("urdf/entity_bomb.urdf");
    assert!(
        matches!(e.kind(), LoadErrorKind::Urdf { .. }),
        "{}",
        message(&e)
    );
    let e = timed("urdf/binary.urdf");
    assert!(
        matches!(e.kind(), LoadErrorKind::NotText { offset: 128 }),
        "{}",
        message(&e)
    );

    let dir = Scratch::new("big");
    let line = "# padding padding padding padding padding padding padding padding padding\n";
    let big = dir.write(
        "big.yaml",
        line.repeat((kinechain::io::MAX_FILE_BYTES as usize) / line.len() + 2),
    );
    let e = Chain::from_file(&big).unwrap_err();
    assert!(
        matches!(e.kind(), LoadErrorKind::TooLarge { limit, .. } if *limit == kinechain::io::MAX_FILE_BYTES)
    );
    // A file of exactly the limit, the documented 16 MiB, is read: a one-joint table, then
    // comments up to the size.
    assert_eq!(kinechain::io::MAX_FILE_BYTES, 16 << 20);
    let table = "convention: standard\njoints:\n  - {name: j1, type: revolute, a: 0.1, alpha: 0, d: 0, theta: 0}\n";
    let mut text = table.to_string();
    let limit = kinechain::io::MAX_FILE_BYTES as usize;
    while text.len() < limit {
        // A line of `room` bytes: `#`, spaces, `\n` (an empty line for the last byte).
        let room = (limit - text.len()).min(line.len());
        if room >= 2 {
            text.push('#');
            text.push_str(&" ".repeat(room - 2));
        }
        text.push('\n');
    }
    std::fs::write(&big, &text).unwrap();
    assert_eq!(
        std::fs::metadata(&big).unwrap().len(),
        kinechain::io::MAX_FILE_BYTES
    );
    let chain = Chain::from_file(&big).map_err(|e| message(&e)).unwrap();
    assert_eq!(chain.dof(), 1);
}

/// Angle units: a plain number is in `angle_unit`; `!degrees`/`!radians` tags and `deg(..)`
/// expressions carry their own unit; with `angle_unit: rad`, |alpha| > 2π draws a warning
/// (which the CLI prints, `tests/cli.rs`).
#[test]
fn angle_units_tags_and_the_degrees_warning() {
    let alpha = |unit: &str, value: &str| {
        let text = format!(
            "convention: modified\nangle_unit: {unit}\njoints:\n  - {{name: j1, type: revolute, a: 0, alpha: {value}, d: 0, theta: 0}}\n"
        );
        let chain = Chain::from_dh_yaml_str(&text).unwrap();
        // The joint's origin is Rx(alpha): its rotation's (2,1) entry is sin(alpha).
        let t = chain.description().joints()[0].origin;
        (
            t.rotation()[(2, 1)].atan2(t.rotation()[(1, 1)]),
            chain.warnings().len(),
        )
    };
    let right = std::f64::consts::FRAC_PI_2;
    for (unit, value) in [
        ("deg", "90"),
        ("deg", "!radians 1.5707963267948966"),
        ("deg", "deg(90)"),
        ("rad", "!degrees 90"),
        ("rad", "1.5707963267948966"),
        ("rad", "pi/2"),
        ("rad", "deg(90)"),
    ] {
        let (a, warnings) = alpha(unit, value);
        assert!((a - right).abs() < 1e-15, "{unit} {value}: {a}");
        assert_eq!(warnings, 0, "{unit} {value}");
    }
    let (_, warnings) = alpha("rad", "90");
    assert_eq!(warnings, 1);
    // The warning starts past 2π in magnitude: a whole turn (the double nearest 2π) is quiet,
    // the next double is not, on either side of zero.
    for (value, expected) in [
        ("6.283185307179586", 0),
        ("-6.283185307179586", 0),
        ("6.283185307179587", 1),
        ("-6.283185307179587", 1),
    ] {
        assert_eq!(alpha("rad", value).1, expected, "{value}");
    }
}
