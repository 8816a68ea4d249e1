//! The bundled robots of `robots/`: each loads, has the dof its source gives, and at q = 0 puts
//! its frames where the file's `# check:` comments say (positions derived by hand from the
//! tables, so they are independent of the code).

use crate::common::*;
use kinechain::{Chain, Data, LimitPolicy, forward_kinematics};

#[test]
fn every_robot_loads_with_its_published_dof() {
    let expected = [
        ("cylindrical.yaml", 2),
        ("g1.urdf", 29),
        ("go2.urdf", 12),
        ("iiwa7.yaml", 7),
        ("irb140.yaml", 6),
        ("panda.urdf", 8),
        ("panda_mdh.yaml", 7),
        ("planar3.yaml", 3),
        ("puma560.yaml", 6),
        ("puma560_modified.yaml", 6),
        ("scara.yaml", 4),
        ("snake50.yaml", 50),
        ("so101.urdf", 6),
        ("stanford.yaml", 6),
        ("ur5.yaml", 6),
    ];
    let files = robot_files();
    assert_eq!(files.len(), expected.len(), "robots/ changed: {files:?}");
    for (name, dof) in expected {
        let chain = Chain::from_file(robots_dir().join(name)).unwrap();
        assert_eq!(chain.dof(), dof, "{name}");
        assert!(
            chain.warnings().is_empty(),
            "{name}: {:?}",
            chain.warnings()
        );
    }
}

/// `# check: at q = 0, LINK is at [x, y, z]` lines of a robot file.
fn checks(text: &str) -> Vec<(String, [f64; 3])> {
    text.lines()
        .filter_map(|l| l.strip_prefix("# check: at q = 0, "))
        .map(|l| {
            let (link, rest) = l.split_once(" is at ").unwrap();
            let numbers: Vec<f64> = rest
                .trim()
                .trim_start_matches('[')
                .trim_end_matches(']')
                .split(',')
                .map(|x| x.trim().parse().unwrap())
                .collect();
            (link.to_string(), [numbers[0], numbers[1], numbers[2]])
        })
        .collect()
}

#[test]
fn every_robot_is_where_its_file_says_at_the_zero_configuration() {
    let mut checked = 0;
    for path in robot_files() {
        let text = std::fs::read_to_string(&path).unwrap();
        let expected = checks(&text);
        if path.extension().unwrap() == "urdf" {
            continue; // third-party file, checked against the reference data instead
        }
        assert!(
            !expected.is_empty(),
            "{}: no '# check:' line",
            path.display()
        );
        let chain = Chain::from_file(&path).unwrap();
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let poses = forward_kinematics(&chain, &mut data, &vec![0.0; chain.dof()]).unwrap();
        for (link, want) in expected {
            let got = poses
                .world_from_link(chain.link_id(&link).unwrap())
                .translation();
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-12,
                    "{} {link}: {got:?} vs {want:?}",
                    path.display()
                );
            }
            checked += 1;
        }
    }
    assert!(checked >= 11);
}

/// The standard and modified DH files of the Puma 560 describe the same arm: identical tool
/// poses everywhere (to rounding).
#[test]
fn puma_standard_and_modified_dh_agree() {
    let standard = Chain::from_file(robots_dir().join("puma560.yaml")).unwrap();
    let modified = Chain::from_file(robots_dir().join("puma560_modified.yaml")).unwrap();
    let (mut ds, mut dm) = (Data::new(&standard), Data::new(&modified));
    let tool = standard.link_id("tool").unwrap();
    assert_eq!(modified.link_id("tool").unwrap(), tool);
    let mut rng = rng(560);
    for _ in 0..200 {
        let q = random_q(&standard, &mut rng);
        let a = forward_kinematics(&standard, &mut ds, &q)
            .unwrap()
            .world_from_link(tool);
        let b = forward_kinematics(&modified, &mut dm, &q)
            .unwrap()
            .world_from_link(tool);
        assert!(pose_error(&a, &b.to_rows()) < 1e-15, "q = {q:?}");
    }
}
