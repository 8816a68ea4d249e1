//! xacro: the feature file expanded as ROS 2's xacro defines each feature (worked out by hand;
//! agreement with the `xacrodoc` expander is tested from Python), vendor descriptions against
//! the reference expansions, and one test per class of error, bounds included.

use crate::common::Scratch;
use kinechain::io::LoadOptions;
use kinechain::io::error::LoadErrorKind;
use kinechain::io::xacro::{XacroError, XacroOptions, expand_file};
use kinechain::{Chain, Data, LimitPolicy, forward_kinematics};
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/xacro")
}

fn features() -> PathBuf {
    data().join("features/features.urdf.xacro")
}

/// The chains `a` and `b` have the same joints (names, kinds, limits, mimics) in the same
/// order and the same links, and every link's pose is equal bit for bit at zero and at seeded
/// configurations within the limits.
fn assert_same(a: &Chain, b: &Chain, what: &str) {
    let joints = |c: &Chain| -> Vec<String> {
        c.joints()
            .iter()
            .map(|j| {
                format!(
                    "{} {:?} {:?} {:?}",
                    j.name(),
                    j.kind(),
                    j.limits(),
                    j.mimic()
                )
            })
            .collect()
    };
    assert_eq!(joints(a), joints(b), "{what}: joints");
    let links =
        |c: &Chain| -> Vec<String> { c.links().iter().map(|l| l.name().to_string()).collect() };
    assert_eq!(links(a), links(b), "{what}: links");
    let mut qs = vec![vec![0.0; a.nq()]];
    let random = a.random_configurations(8, 7, (-1.0, 1.0));
    qs.extend(random.chunks(a.nq().max(1)).map(<[f64]>::to_vec));
    for q in qs.iter().filter(|q| q.len() == a.nq()) {
        let mut da = Data::new(a).with_limit_policy(LimitPolicy::Ignore);
        let mut db = Data::new(b).with_limit_policy(LimitPolicy::Ignore);
        let pa = forward_kinematics(a, &mut da, q).unwrap();
        let pb = forward_kinematics(b, &mut db, q).unwrap();
        for (i, link) in a.links().iter().enumerate() {
            let ta = pa.world_from_link(a.link_id(link.name()).unwrap());
            let tb = pb.world_from_link(b.link_id(link.name()).unwrap());
            assert_eq!(
                (ta.translation(), ta.rotation()),
                (tb.translation(), tb.rotation()),
                "{what}: link {i} '{}' at q = {q:?}",
                link.name()
            );
        }
    }
}

#[test]
fn the_feature_file_expands_as_xacro_defines_it() {
    let options = XacroOptions::default().with_arg("prefix", "left_");
    let out = expand_file(&features(), &options).unwrap();
    let urdf = &out.urdf;
    let chain = Chain::from_urdf_str(urdf).unwrap();
    let names: Vec<&str> = chain.joints().iter().map(|j| j.name()).collect();
    // Macros with blocks, a recursive macro, xacro:element, an included macro with a mimic.
    assert_eq!(
        names,
        [
            "left_j1",
            "left_j2",
            "left_seg3",
            "left_seg2",
            "left_seg1",
            "left_tip_joint",
            "left_tip_left_finger_joint",
            "left_tip_right_finger_joint",
            "left_marker_joint"
        ]
    );
    // The property block, a YAML value, lazy properties used before definition, eager ones,
    // dicts by key and by dot, `!degrees` and `!millimeters`, `:=^` and `:=^|` defaults.
    assert!(
        urdf.contains(r#"<origin xyz="0 0 0.15" rpy="0 0 0"/>"#),
        "{urdf}"
    );
    let tilt = 5.0 * (std::f64::consts::PI / 180.0);
    assert!(
        urdf.contains(&format!(
            r#"<origin xyz="0.1 -0.2 0.8" rpy="{tilt} 0 0.7853981633974483"/>"#
        )),
        "{urdf}"
    );
    assert!(urdf.contains(r#"<limit lower="-0.4" upper="0.7" effort="10" velocity="1"/>"#));
    assert!(urdf.contains(r#"<limit lower="-0.0" upper="0.12" effort="10" velocity="1"/>"#));
    // `scope="parent"` from a macro; `'0.5'` is text 0.5 that reads back as a number.
    assert!(
        urdf.contains(r#"<origin xyz="0 0 0.35" rpy="0 0 0"/>"#),
        "{urdf}"
    );
    // xacro:attribute, the $(eval) condition, builtins, the escapes.
    assert!(urdf.contains(r#"<link name="left_tip"/>"#), "{urdf}");
    assert!(urdf.contains(r#"<origin xyz="0.7 0.1 2.25" rpy="0 0 0.7853981633974483"/>"#));
    assert!(urdf.contains("<note>plain text</note>"), "{urdf}");
    // The multi-block `**extra` puts its content, the `*origin` block itself.
    assert!(urdf.contains(r#"<dynamics damping="0.1"/>"#));
    assert!(!urdf.contains("xacro:"));
    // Arguments change the result: no gripper, another reach (a float with a point).
    let options = XacroOptions::default()
        .with_arg("gripper", "false")
        .with_arg("reach", "0.2");
    let out = expand_file(&features(), &options).unwrap();
    assert!(!out.urdf.contains("finger"));
    assert!(!out.urdf.contains("marker"));
    assert!(
        out.urdf.contains(r#"<limit lower="-0.2" upper="0.5""#),
        "{}",
        out.urdf
    );
    // Every file read is listed: the main file, the includes and the YAML file.
    assert_eq!(out.files.len(), 4, "{:?}", out.files);
}

#[test]
fn a_xacro_file_loads_like_its_expansion() {
    let options = LoadOptions::default().with_xacro_arg("prefix", "r_");
    let chain = Chain::from_file_with(features(), &options).unwrap();
    let expanded = expand_file(&features(), &options.xacro).unwrap();
    let reference = Chain::from_urdf_str(&expanded.urdf).unwrap();
    assert_same(&chain, &reference, "features");
    assert!(chain.link_id("r_tip").is_ok());
    // The same text given as a string, with the directory its includes are in.
    let text = std::fs::read_to_string(features()).unwrap();
    let options = options.with_base_dir(data().join("features"));
    let from_text =
        Chain::from_str_with(&text, kinechain::io::Format::Xacro, "robot", &options).unwrap();
    assert_same(&chain, &from_text, "features from a string");
}

/// A case of `CASES.tsv`: the xacro file under `packages`, the arguments, and the reference
/// expansion if there is one.
struct Case {
    id: String,
    file: PathBuf,
    options: XacroOptions,
    expected: Option<PathBuf>,
}

fn cases(root: &Path) -> Vec<Case> {
    let text = std::fs::read_to_string(root.join("CASES.tsv")).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|line| {
            let fields: Vec<&str> = line.split('\t').collect();
            let folder = root.join(
                fields
                    .get(4)
                    .copied()
                    .filter(|f| !f.is_empty())
                    .unwrap_or("packages"),
            );
            let mut options = XacroOptions::default().with_package_path(&folder);
            if fields[2] != "-" {
                for arg in fields[2].split_whitespace() {
                    let (k, v) = arg.split_once(":=").unwrap();
                    options = options.with_arg(k, v);
                }
            }
            let expected = root.join("expected").join(format!("{}.urdf", fields[0]));
            Case {
                id: fields[0].to_string(),
                file: folder.join(fields[1]),
                options,
                expected: expected.is_file().then_some(expected),
            }
        })
        .collect()
}

/// Each case expands and loads with the same joints, limits and poses as the reference
/// expansion; a case without one fails with an error naming its file and line.
fn check_cases(root: &Path) -> usize {
    let mut checked = 0;
    for case in cases(root) {
        let options = LoadOptions::default().with_xacro(case.options.clone());
        match &case.expected {
            Some(expected) => {
                let chain = Chain::from_file_with(&case.file, &options).unwrap_or_else(|e| {
                    panic!("{}: {}", case.id, kinechain::error::error_chain(&e))
                });
                let reference = Chain::from_file(expected).unwrap();
                assert_same(&reference, &chain, &case.id);
                assert_eq!(chain.name(), reference.name(), "{}", case.id);
                checked += 1;
            }
            None => {
                let e = Chain::from_file_with(&case.file, &options).unwrap_err();
                let LoadErrorKind::Xacro(x) = e.kind() else {
                    panic!("{}: {}", case.id, kinechain::error::error_chain(&e));
                };
                assert!(x.line.is_some(), "{}: {x}", case.id);
            }
        }
    }
    checked
}

#[test]
fn bundled_vendor_descriptions_match_the_reference_expansions() {
    assert_eq!(check_cases(&data()), 6);
}

/// The whole corpus (136 cases): `KINECHAIN_XACRO_CORPUS=path/to/corpus/xacro cargo test
/// --release xacro_corpus -- --ignored`.
#[test]
#[ignore = "needs the corpus: KINECHAIN_XACRO_CORPUS=DIR"]
fn xacro_corpus() {
    let root =
        PathBuf::from(std::env::var("KINECHAIN_XACRO_CORPUS").expect("KINECHAIN_XACRO_CORPUS"));
    let checked = check_cases(&root);
    eprintln!("{checked} cases agree with their reference expansions");
}

fn expand_error(text: &str) -> XacroError {
    let dir = Scratch::new("xacro-errors");
    let path = dir.write("robot.urdf.xacro", text);
    expand_file(Path::new(&path), &XacroOptions::default()).unwrap_err()
}

fn robot(body: &str) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<robot name=\"r\" xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n{body}\n</robot>\n"
    )
}

/// What xacro keeps as text: `$${` and `$$(` escapes (one `$` dropped), a `$` before other
/// text; `$(dirname)` and `$(env)`.
#[test]
fn escapes_and_substitutions() {
    let dir = Scratch::new("xacro-escapes");
    let path = dir.write(
        "r.urdf.xacro",
        robot("  <note a=\"$${not evaluated} $$(neither) 5$ and $x\" d=\"$(dirname)\" e=\"$(env PATH)\"/>"),
    );
    let out = expand_file(Path::new(&path), &XacroOptions::default()).unwrap();
    assert!(
        out.urdf
            .contains("a=\"${not evaluated} $(neither) 5$ and $x\""),
        "{}",
        out.urdf
    );
    let dir_shown = Path::new(&path).parent().unwrap().canonicalize().unwrap();
    assert!(
        out.urdf.contains(&format!("d=\"{}\"", dir_shown.display())),
        "{}",
        out.urdf
    );
    let path_var = std::env::var("PATH").unwrap();
    assert!(
        out.urdf.contains(&format!("e=\"{path_var}\"")),
        "{}",
        out.urdf
    );
}

#[test]
fn errors_name_the_file_line_and_macro_calls() {
    let e = expand_error(&robot(
        "  <xacro:macro name=\"arm\" params=\"n\">\n    <link name=\"${n}_${foo}\"/>\n  </xacro:macro>\n  <xacro:arm n=\"a\"/>",
    ));
    assert_eq!((e.line, e.column), (Some(4), Some(5)));
    let shown = e.to_string();
    assert!(
        shown.ends_with("robot.urdf.xacro:4:5: in macro `arm` called at robot.urdf.xacro:6:3: property `foo` is not defined (in the expression 'foo')"),
        "{shown}"
    );
    for (body, says) in [
        (
            "  <link name=\"$(arg side)\"/>",
            "argument `side` is not defined",
        ),
        ("  <xacro:arm/>", "unknown macro name: xacro:arm"),
        (
            "  <xacro:property name=\"a\" value=\"${b}\"/>\n  <xacro:property name=\"b\" value=\"${a}\"/>\n  <link name=\"${a}\"/>",
            "circular property definition: a -> b -> a",
        ),
        (
            "  <link name=\"$(find no_such_pkg)\"/>",
            "package 'no_such_pkg' is not found; looked in:",
        ),
        (
            "  <link name=\"${1 +}\"/>",
            "unexpected end of the expression",
        ),
        (
            "  <link name=\"${__import__('os')}\"/>",
            "use of invalid name '__import__'",
        ),
        (
            "  <link name=\"${().__class__}\"/>",
            "use of invalid name '__class__'",
        ),
        (
            "  <link name=\"${open('/etc/passwd')}\"/>",
            "property `open` is not defined",
        ),
        (
            "  <xacro:if value=\"maybe\"><link name=\"a\"/></xacro:if>",
            "which is not a boolean",
        ),
        (
            "  <xacro:insert_block name=\"nothing\"/>",
            "undefined block `nothing`",
        ),
        (
            "  <xacro:macro name=\"m\" params=\"*b\"><xacro:insert_block name=\"b\"/></xacro:macro>\n  <xacro:m/>",
            "not enough blocks",
        ),
        (
            "  <xacro:macro name=\"m\" params=\"a\"/>\n  <xacro:m/>",
            "parameters not given: a",
        ),
        (
            "  <xacro:macro name=\"m\" params=\"a\"/>\n  <xacro:m a=\"1\" b=\"2\"/>",
            "macro `m` has no parameter `b`",
        ),
        (
            "  <link name=\"${xacro.fatal('stop here')}\"/>",
            "xacro.fatal: stop here",
        ),
        ("  <link name=\"${1/0}\"/>", "division by zero"),
        (
            "  <xacro:property name=\"1a\" value=\"1\"/>",
            "property names must be Python identifiers",
        ),
        (
            "  <xacro:include filename=\"missing.xacro\"/>",
            "cannot read",
        ),
        (
            "  <link name=\"${xacro.load_yaml('/etc/passwd')}\"/>",
            "is outside the directories",
        ),
    ] {
        let e = expand_error(&robot(body));
        assert!(e.to_string().contains(says), "{body}: {e}");
        assert!(e.line.is_some(), "{body}: {e}");
    }
}

#[test]
fn errors_in_included_files_name_them() {
    let dir = Scratch::new("xacro-include-errors");
    dir.write(
        "bad.xacro",
        "<robot xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n  <link name=\"a\">\n</robot>\n",
    );
    dir.write(
        "undefined.xacro",
        "<robot xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n\n  <link name=\"${nope}\"/>\n</robot>\n",
    );
    let main = dir.write(
        "main.urdf.xacro",
        robot("  <xacro:include filename=\"bad.xacro\"/>"),
    );
    let e = expand_file(Path::new(&main), &XacroOptions::default()).unwrap_err();
    assert!(e.file.ends_with("bad.xacro"), "{e}");
    assert!(e.to_string().contains("not well-formed XML"), "{e}");
    assert!(e.to_string().contains("in file"), "{e}");
    let main = dir.write(
        "main2.urdf.xacro",
        robot("\n  <xacro:include filename=\"undefined.xacro\"/>"),
    );
    let e = expand_file(Path::new(&main), &XacroOptions::default()).unwrap_err();
    assert!(e.file.ends_with("undefined.xacro"), "{e}");
    assert_eq!(e.line, Some(3), "{e}");
    assert!(
        e.to_string().contains("included at main2.urdf.xacro:4:3"),
        "{e}"
    );
}

#[test]
fn runaway_expansions_stop_at_their_bounds() {
    // A macro that calls itself without end.
    let e = expand_error(&robot(
        "  <xacro:macro name=\"loop\" params=\"\"><xacro:loop/></xacro:macro>\n  <xacro:loop/>",
    ));
    assert!(
        e.to_string().contains("macro calls nest deeper than 100"),
        "{e}"
    );
    // A macro that doubles its output 40 times: an error, not 2^40 links.
    let mut body =
        String::from("  <xacro:macro name=\"m0\" params=\"\"><link name=\"x\"/></xacro:macro>\n");
    for i in 1..=40 {
        body.push_str(&format!(
            "  <xacro:macro name=\"m{i}\" params=\"\"><xacro:m{j}/><xacro:m{j}/></xacro:macro>\n",
            j = i - 1
        ));
    }
    body.push_str("  <xacro:m40/>");
    let started = std::time::Instant::now();
    let e = expand_error(&robot(&body));
    assert!(e.to_string().contains("more than"), "{e}");
    assert!(started.elapsed().as_secs() < 60);
    // A string that doubles itself.
    let mut body = String::from("  <xacro:property name=\"s0\" value=\"xxxxxxxxxxxxxxxx\"/>\n");
    for i in 1..=40 {
        body.push_str(&format!(
            "  <xacro:property name=\"s{i}\" value=\"${{s{j} + s{j}}}\"/>\n",
            j = i - 1
        ));
    }
    body.push_str("  <link name=\"${s40}\"/>");
    let e = expand_error(&robot(&body));
    assert!(e.to_string().contains("longer than"), "{e}");
    // A file that includes itself.
    let dir = Scratch::new("xacro-cycle");
    let path = dir.write(
        "self.urdf.xacro",
        robot("  <xacro:include filename=\"self.urdf.xacro\"/>"),
    );
    let e = expand_file(Path::new(&path), &XacroOptions::default()).unwrap_err();
    assert!(e.to_string().contains("includes nest deeper than"), "{e}");
}

#[test]
fn packages_resolve_from_paths_and_by_walking_up() {
    // By walking up from the file: the package is beside the file's directory's contents.
    let out = expand_file(&features(), &XacroOptions::default()).unwrap();
    assert!(out.files.iter().any(|f| f.ends_with("arm.yaml")));
    // From a --package-path, for a file elsewhere.
    let dir = Scratch::new("xacro-packages");
    let main = dir.write(
        "main.urdf.xacro",
        robot("  <xacro:include filename=\"$(find my_arm_description)/urdf/links.xacro\"/>\n  <xacro:plain_link name=\"a\"/>"),
    );
    let e = expand_file(Path::new(&main), &XacroOptions::default()).unwrap_err();
    assert!(
        e.to_string()
            .contains("package 'my_arm_description' is not found"),
        "{e}"
    );
    let options = XacroOptions::default().with_package_path(data().join("features"));
    let out = expand_file(Path::new(&main), &options).unwrap();
    assert!(out.urdf.contains("<link name=\"a\">"), "{}", out.urdf);
}

#[test]
fn leftover_xacro_in_a_urdf_file() {
    // Undefined macros inside non-kinematic content are skipped with a warning.
    let text = robot(
        "  <link name=\"a\"><visual><geometry><box size=\"1 1 1\"/></geometry><xacro:grey/></visual></link>\n  <link name=\"b\"/>\n  <joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>",
    );
    let chain = Chain::from_urdf_str(&text).unwrap();
    assert_eq!(chain.links().len(), 2);
    assert!(
        chain
            .warnings()
            .iter()
            .any(|w| w.contains("<visual> skipped") && w.contains("xacro:grey")),
        "{:?}",
        chain.warnings()
    );
}

#[test]
fn the_cobot_pump_case_fails_as_xacro_does() {
    // franka_description at 566ba44 defines a property from itself (xacro fails the same way).
    let case = cases(&data())
        .into_iter()
        .find(|c| c.id == "franka_fr3_pump")
        .unwrap();
    let e = expand_file(&case.file, &case.options).unwrap_err();
    assert!(
        e.to_string().contains("circular property definition"),
        "{e}"
    );
    assert!(e.to_string().contains("in macro `franka_robot`"), "{e}");
}

/// xacro's comment rules: the comments right before a xacro element go (walking back over
/// single line breaks only, and never into what the previous xacro element expanded to); a
/// comment after a blank line stays; comments in a kept branch stay; `xacro:eval-comments`
/// evaluates the comments after it until an element, text, `:off` or the list's end. And the
/// namespace declarations of a file included inside a macro reach the document's root. (The
/// expected document is xacro 2.1.1's.)
#[test]
fn comments_stay_or_go_as_xacro_decides_and_namespaces_are_lifted() {
    let dir = Scratch::new("xacro-comments");
    dir.write(
        "ns.xacro",
        r#"<inc xmlns:xacro="http://www.ros.org/wiki/xacro" xmlns:b="http://www.ros.org/b"><b:x/></inc>"#,
    );
    let path = dir.write(
        "r.urdf.xacro",
        robot(
            r#"  <!-- kept: a blank line follows -->

  <!-- dropped -->
  <!-- dropped too -->
  <xacro:property name="n" value="three"/>
  <!-- dropped -->
  <xacro:if value="1"><!-- kept: in the branch --></xacro:if>
  <!-- dropped -->
  <xacro:macro name="m"><xacro:include filename="ns.xacro"/><!-- kept: from the macro --></xacro:macro>
  <xacro:m/>
  <!-- xacro:eval-comments -->
  <!-- evaluated: ${n} -->
  <!-- evaluated too: ${n} -->
  <link name="l"/>
  <!-- not evaluated: ${n} -->"#,
        ),
    );
    let out = expand_file(Path::new(&path), &XacroOptions::default())
        .unwrap()
        .urdf;
    let comments: Vec<&str> = out
        .lines()
        .skip(2)
        .filter_map(|l| l.trim().strip_prefix("<!--")?.strip_suffix("-->"))
        .map(str::trim)
        .collect();
    assert_eq!(
        comments,
        [
            "kept: a blank line follows",
            "kept: in the branch",
            "kept: from the macro",
            "evaluated: three",
            "evaluated too: three",
            "not evaluated: ${n}"
        ],
        "{out}"
    );
    assert!(out.contains(r#"xmlns:b="http://www.ros.org/b""#), "{out}");
    assert!(out.contains("<b:x/>"), "{out}");
}
