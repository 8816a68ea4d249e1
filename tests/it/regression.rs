//! Regression tests on link kinematics: record, verify and compare, in the library and on the
//! command line.

use crate::common::{Scratch, robot_files};
use kinechain::Chain;
use kinechain::regression::{
    Level, Options, RegressionError, Tolerances, compare, read_golden, record, variable_names,
    verify, write_golden,
};
use std::process::Command;

fn kinechain(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_kinechain"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

fn golden_text(chain: &Chain, options: &Options) -> String {
    let golden = record(chain, options).unwrap();
    let mut text = Vec::new();
    write_golden(&golden, &mut text).unwrap();
    String::from_utf8(text).unwrap()
}

fn panda_text() -> String {
    std::fs::read_to_string(crate::common::robots_dir().join("panda.urdf")).unwrap()
}

#[test]
fn every_bundled_robot_verifies_against_its_own_record_at_every_level() {
    for file in robot_files() {
        let chain = Chain::from_file(&file).unwrap();
        for level in [Level::Pose, Level::Vel, Level::Acc] {
            let options = Options {
                samples: 20,
                level,
                ..Options::default()
            };
            let text = golden_text(&chain, &options);
            let golden = read_golden(&text, "golden").unwrap();
            assert!(golden.samples.len() >= 20, "{}", file.display());
            // Every number reads back to the same bits: writing again gives the same bytes.
            let mut again = Vec::new();
            write_golden(&golden, &mut again).unwrap();
            assert_eq!(
                String::from_utf8(again).unwrap(),
                text,
                "{}",
                file.display()
            );
            let report = verify(&chain, &golden, &Tolerances::default()).unwrap();
            assert!(report.passed(), "{}: {report}", file.display());
            assert!(
                report
                    .links
                    .iter()
                    .all(|l| l.position.max == 0.0 && l.rotation.max == 0.0)
            );
            assert_eq!(report.outside_limits, 0);
        }
    }
}

#[test]
fn records_are_deterministic_and_inside_the_limits() {
    let chain = crate::common::repo_chain("robots/panda.urdf");
    let options = Options {
        samples: 50,
        level: Level::Acc,
        ..Options::default()
    };
    assert_eq!(golden_text(&chain, &options), golden_text(&chain, &options));
    let other = Options {
        seed: 2,
        ..options.clone()
    };
    assert_ne!(golden_text(&chain, &options), golden_text(&chain, &other));
    let golden = record(&chain, &options).unwrap();
    // The Panda's joint 4 excludes 0, so the zero configuration is left out; both corners are in.
    assert_eq!(golden.samples.len(), 52);
    assert_eq!(golden.samples[0].q, chain.lower());
    assert_eq!(golden.samples[1].q, chain.upper());
    for s in &golden.samples {
        kinechain::check_q(&chain, &s.q, kinechain::LimitPolicy::Enforce).unwrap();
        assert!(s.qd.as_ref().unwrap().iter().all(|x| x.abs() <= 1.0));
    }
    // The header names the robot, its joints in q order, the version, the seed and the level.
    let h = &golden.header;
    assert_eq!(
        (h.robot.as_str(), h.dof, h.seed, h.level),
        ("panda", 8, 1, Level::Acc)
    );
    assert_eq!(h.joints, variable_names(&chain));
    assert_eq!(h.kinechain, env!("CARGO_PKG_VERSION"));
}

#[test]
fn a_dh_table_and_the_urdf_it_converts_to_compare_equal() {
    for file in [
        "robots/puma560.yaml",
        "robots/stanford.yaml",
        "robots/ur5.yaml",
        "robots/panda_mdh.yaml",
    ] {
        let dh = crate::common::repo_chain(file);
        let urdf = Chain::from_urdf_str(&kinechain::io::convert::to_urdf(&dh).unwrap()).unwrap();
        let options = Options {
            samples: 30,
            level: Level::Acc,
            ..Options::default()
        };
        let report = compare(&dh, &urdf, &options, &Tolerances::default()).unwrap();
        assert!(report.passed(), "{file}: {report}");
        assert_eq!(
            report.links.len(),
            dh.links().len(),
            "{file}: every DH link is compared"
        );
        assert!(report.only_in_first.links.is_empty() && report.only_in_first.joints.is_empty());
        // The converted file's extra frames are listed, not compared.
        assert!(
            report.links.iter().all(|l| l.position.max < 1e-14),
            "{file}: {report}"
        );
    }
}

#[test]
fn a_joint_origin_moved_by_a_micrometre_fails_naming_its_child_link() {
    let scratch = Scratch::new("regression-moved");
    let original = scratch.write("panda.urdf", panda_text());
    let moved_text = panda_text().replace(
        r#"<origin rpy="1.5707963267948966 0 0" xyz="0.0825 0 0"/>"#,
        r#"<origin rpy="1.5707963267948966 0 0" xyz="0.082501 0 0"/>"#,
    );
    assert_ne!(moved_text, panda_text());
    let moved = scratch.write("moved.urdf", &moved_text);
    // The library: the child link and everything below it moved, nothing above.
    let (a, b) = (
        Chain::from_file(&original).unwrap(),
        Chain::from_file(&moved).unwrap(),
    );
    let golden = record(&a, &Options::default()).unwrap();
    let report = verify(&b, &golden, &Tolerances::default()).unwrap();
    let first = report.first_moved.as_ref().unwrap();
    assert_eq!(
        (first.link.as_str(), first.joint.as_deref()),
        ("panda_link4", Some("panda_joint4"))
    );
    for l in &report.links {
        let above =
            ["panda_link0", "panda_link1", "panda_link2", "panda_link3"].contains(&l.link.as_str());
        assert_eq!(l.within, above, "{}: {report}", l.link);
    }
    // The origin moved by 1 µm: the child link's origin by exactly that, to rounding.
    assert!(
        (first.position.max - 1e-6).abs() < 1e-12,
        "{}",
        first.position.max
    );
    assert_eq!(first.rotation.max, 0.0);
    // The command line: exit status 1, the table names the link and the joint above it.
    let g = scratch.path("golden.jsonl");
    assert_eq!(kinechain(&["record", &original, "-o", &g]).0, 0);
    let (code, out, _) = kinechain(&["verify", &moved, &g]);
    assert_eq!(code, 1, "{out}");
    let verdict = out.lines().last().unwrap();
    assert!(
        verdict.starts_with("fail:")
            && verdict.contains("'panda_link4' below joint 'panda_joint4'"),
        "{verdict}"
    );
    assert!(
        !out.lines()
            .any(|l| l.starts_with("panda_link3") && l.ends_with("moved")),
        "{out}"
    );
    let (code, out, _) = kinechain(&["compare", &original, &moved, "--format", "json"]);
    assert_eq!(code, 1, "{out}");
    let json: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(json["verdict"], "fail");
    assert_eq!(json["first_moved"]["link"], "panda_link4");
    assert_eq!(json["first_moved"]["joint"], "panda_joint4");
    // Within a looser tolerance it passes.
    let (code, out, _) = kinechain(&["verify", &moved, &g, "--tol-position", "2e-6"]);
    assert_eq!(code, 0, "{out}");
    assert_eq!(kinechain(&["verify", &original, &g]).0, 0);
}

#[test]
fn a_turned_origin_is_measured_as_the_angle_it_turned() {
    let turned = panda_text().replace(
        r#"<origin rpy="1.5707963267948966 0 0" xyz="0.0825 0 0"/>"#,
        r#"<origin rpy="1.5707963267948966 0 1e-7" xyz="0.0825 0 0"/>"#,
    );
    let (a, b) = (
        Chain::from_urdf_str(&panda_text()).unwrap(),
        Chain::from_urdf_str(&turned).unwrap(),
    );
    let report = compare(&a, &b, &Options::default(), &Tolerances::default()).unwrap();
    let link4 = report
        .links
        .iter()
        .find(|l| l.link == "panda_link4")
        .unwrap();
    assert!(
        (link4.rotation.max - 1e-7).abs() < 1e-13,
        "{}",
        link4.rotation.max
    );
    assert_eq!(report.first_moved.unwrap().link, "panda_link4");
}

/// Two arms on one base; `swapped` lists the second first, which changes the q order.
fn two_arms(swapped: bool) -> String {
    let arm = |n: &str, x: f64| {
        format!(
            r#"<link name="{n}1"/><link name="{n}2"/>
            <joint name="{n}_a" type="revolute"><parent link="base"/><child link="{n}1"/>
              <origin xyz="{x} 0 0.1"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
            <joint name="{n}_b" type="prismatic"><parent link="{n}1"/><child link="{n}2"/>
              <origin xyz="0.3 0 0"/><axis xyz="1 0 0"/><limit lower="0" upper="0.2" effort="1" velocity="1"/></joint>"#
        )
    };
    let (first, second) = if swapped {
        (arm("right", -0.2), arm("left", 0.2))
    } else {
        (arm("left", 0.2), arm("right", -0.2))
    };
    format!(r#"<robot name="two_arms"><link name="base"/>{first}{second}</robot>"#)
}

#[test]
fn reordered_joints_still_verify_and_a_renamed_joint_is_an_error_listing_it() {
    let (a, b) = (
        Chain::from_urdf_str(&two_arms(false)).unwrap(),
        Chain::from_urdf_str(&two_arms(true)).unwrap(),
    );
    assert_ne!(
        variable_names(&a),
        variable_names(&b),
        "the q order must differ for this test"
    );
    let golden = record(
        &a,
        &Options {
            level: Level::Acc,
            ..Options::default()
        },
    )
    .unwrap();
    let report = verify(&b, &golden, &Tolerances::default()).unwrap();
    assert!(report.passed(), "{report}");
    assert!(
        report.links.iter().all(|l| l.position.max == 0.0),
        "{report}"
    );
    // A renamed joint: the record's name is missing, the robot's new one unknown.
    let renamed = Chain::from_urdf_str(&two_arms(true).replace("left_b", "left_slide")).unwrap();
    let e = verify(&renamed, &golden, &Tolerances::default()).unwrap_err();
    let RegressionError::Joints { missing, extra } = &e else {
        panic!("{e}")
    };
    assert_eq!(
        (missing.as_slice(), extra.as_slice()),
        (&["left_b".to_string()][..], &["left_slide".to_string()][..])
    );
    assert!(
        e.to_string().contains("'left_b'") && e.to_string().contains("'left_slide'"),
        "{e}"
    );
    // On the command line: exit status 2, the names in the message.
    let scratch = Scratch::new("regression-renamed");
    let g = scratch.write("golden.jsonl", golden_text(&a, &Options::default()));
    let r = scratch.write(
        "renamed.urdf",
        two_arms(true).replace("left_b", "left_slide"),
    );
    let (code, out, err) = kinechain(&["verify", &r, &g]);
    assert_eq!(code, 2, "{out}");
    assert!(
        err.starts_with("error:") && err.contains("'left_b'"),
        "{err}"
    );
    // A link that is gone is an error too.
    let gone =
        Chain::from_urdf_str(&two_arms(false).replace("\"right2\"", "\"right_tip\"")).unwrap();
    let e = verify(&gone, &golden, &Tolerances::default()).unwrap_err();
    assert!(
        matches!(&e, RegressionError::Links { missing } if missing == &["right2".to_string()]),
        "{e}"
    );
}

#[test]
fn damaged_golden_files_are_errors_naming_the_line() {
    let chain = crate::common::repo_chain("robots/ur5.yaml");
    let text = golden_text(
        &chain,
        &Options {
            samples: 5,
            level: Level::Vel,
            ..Options::default()
        },
    );
    let lines: Vec<&str> = text.lines().collect();
    let joined = |ls: &[&str]| ls.iter().map(|l| format!("{l}\n")).collect::<String>();
    let third = lines[3];
    let cases: Vec<(String, usize, &str)> = vec![
        // Cut in the middle of a line (the file ends there).
        (
            text[..text.len() - 40].to_string(),
            lines.len(),
            "the last line has no line end",
        ),
        // Cut after a whole line: samples are missing.
        (joined(&lines[..4]), 5, "ends after 3 of the"),
        // A line damaged in the middle.
        (
            joined(&[&lines[..3], &[&third[..third.len() / 2]], &lines[4..]].concat()),
            4,
            "not a sample",
        ),
        // Two lines swapped.
        (
            joined(&[&lines[..2], &[lines[3], lines[2]], &lines[4..]].concat()),
            3,
            "sample 2 where sample 1 belongs",
        ),
        // A sample without its velocities.
        (
            text.replacen(",\"qd\":[", ",\"qx\":[", 1),
            2,
            "not a sample",
        ),
        // A header that is not one.
        (
            text.replacen("kinechain_golden", "golden", 1),
            1,
            "not a kinechain golden header",
        ),
        // An empty line inside.
        (text.replacen('\n', "\n\n", 1), 2, "an empty line"),
        // An empty file.
        (String::new(), 1, "not a kinechain golden header"),
    ];
    for (damaged, line, says) in cases {
        let e = read_golden(&damaged, "g.jsonl").unwrap_err();
        let RegressionError::Golden {
            line: at, problem, ..
        } = &e
        else {
            panic!("{e}")
        };
        assert_eq!(*at, line, "{e}");
        assert!(problem.contains(says), "{e}");
        assert!(
            e.to_string().starts_with(&format!("g.jsonl:{line}: ")),
            "{e}"
        );
    }
    // A changed number is read, and then fails the verification rather than passing.
    let digit = lines[2].find("\"pose\":[").unwrap() + 30;
    let mut changed = lines[2].to_string();
    let old = changed.as_bytes()[digit];
    let new = if old == b'1' { "2" } else { "1" };
    assert!(old.is_ascii_digit(), "{changed}");
    changed.replace_range(digit..=digit, new);
    let golden = read_golden(
        &joined(&[&lines[..2], &[changed.as_str()], &lines[3..]].concat()),
        "g",
    )
    .unwrap();
    assert!(
        !verify(&chain, &golden, &Tolerances::default())
            .unwrap()
            .passed()
    );
    // On the command line, exit status 2.
    let scratch = Scratch::new("regression-damaged");
    let g = scratch.write("g.jsonl", &text[..text.len() - 40]);
    let (code, _, err) = kinechain(&["verify", "robots/ur5.yaml", &g]);
    assert_eq!(code, 2);
    assert!(
        err.contains("g.jsonl:9: the last line has no line end"),
        "{err}"
    );
}

#[test]
fn the_command_line_records_the_same_bytes_as_the_library() {
    let scratch = Scratch::new("regression-cli");
    let g = scratch.path("g.jsonl");
    let (code, _, err) = kinechain(&[
        "record",
        "robots/iiwa7.yaml",
        "-o",
        &g,
        "--samples",
        "7",
        "--seed",
        "9",
        "--level",
        "acc",
        "--link",
        "link7",
    ]);
    assert_eq!(code, 0, "{err}");
    let chain = crate::common::repo_chain("robots/iiwa7.yaml");
    let options = Options {
        samples: 7,
        seed: 9,
        level: Level::Acc,
        links: vec!["link7".into()],
    };
    assert_eq!(
        std::fs::read_to_string(&g).unwrap(),
        golden_text(&chain, &options)
    );
    // To standard output without -o; the robot file is never overwritten.
    let (code, out, _) = kinechain(&[
        "record",
        "robots/iiwa7.yaml",
        "--samples",
        "7",
        "--seed",
        "9",
        "--level",
        "acc",
        "--link",
        "link7",
    ]);
    assert_eq!((code, out), (0, golden_text(&chain, &options)));
    let (code, _, err) = kinechain(&["record", "robots/iiwa7.yaml", "-o", "robots/iiwa7.yaml"]);
    assert_ne!(code, 0);
    assert!(err.contains("refusing to overwrite"), "{err}");
    // The table shows rates at level acc; unknown links are errors.
    let (code, out, _) = kinechain(&["verify", "robots/iiwa7.yaml", &g]);
    assert_eq!(code, 0, "{out}");
    assert!(out.lines().nth(1).unwrap().contains("rates"), "{out}");
    let (code, _, err) = kinechain(&["record", "robots/iiwa7.yaml", "--link", "link77"]);
    assert_ne!(code, 0);
    assert!(err.contains("link77"), "{err}");
    let (code, _, err) = kinechain(&["verify", "robots/iiwa7.yaml", &g, "--tol-position", "-1"]);
    assert_eq!(code, 2, "{err}");
}
