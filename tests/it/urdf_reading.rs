//! The URDF reader: the same model as `urdf-rs` reads on every bundled and reference URDF, and
//! valid robots with content that URDF tools disagree on (`tests/data/urdf_lenient/`) load with
//! warnings that name their place, and put every link where the plain file does.

use crate::common::*;
use kinechain::{Chain, Data, JointKind, LimitPolicy, Transform, forward_kinematics};
use std::path::{Path, PathBuf};

/// The bundled robot URDFs and every URDF of the reference data.
fn urdf_files() -> Vec<PathBuf> {
    let files = k_urdf_files();
    assert!(files.len() >= 15, "{files:?}");
    files
}

/// `urdf-rs` and kinechain read the same links, joints, origins, axes, limits and mimics from
/// every bundled and reference URDF (these files are all well-formed and complete, so the two
/// readers' differences on other files do not show).
#[test]
fn the_model_is_the_one_urdf_rs_reads() {
    for path in urdf_files() {
        let theirs =
            urdf_rs::read_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let chain = Chain::from_file(&path).unwrap();
        let ours = chain.description();
        let file = path.display();
        assert_eq!(ours.name(), theirs.name, "{file}");
        let links: Vec<&str> = theirs.links.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(ours.links(), links.as_slice(), "{file}");
        assert_eq!(ours.joints().len(), theirs.joints.len(), "{file}");
        for (o, t) in ours.joints().iter().zip(&theirs.joints) {
            let what = format!("{file}: joint {}", t.name);
            assert_eq!(o.name, t.name, "{what}");
            assert_eq!(
                (o.parent.as_str(), o.child.as_str()),
                (t.parent.link.as_str(), t.child.link.as_str()),
                "{what}"
            );
            let kind = match t.joint_type {
                urdf_rs::JointType::Revolute => JointKind::Revolute,
                urdf_rs::JointType::Continuous => JointKind::Continuous,
                urdf_rs::JointType::Prismatic => JointKind::Prismatic,
                urdf_rs::JointType::Fixed => JointKind::Fixed,
                ref other => panic!("{what}: {other:?}"),
            };
            assert_eq!(o.kind, kind, "{what}");
            assert_eq!(
                o.origin,
                Transform::from_xyz_rpy(t.origin.xyz.0, t.origin.rpy.0),
                "{what}"
            );
            if kind != JointKind::Fixed {
                assert_eq!(o.axis, t.axis.xyz.0, "{what}");
            }
            match kind {
                JointKind::Revolute | JointKind::Prismatic => {
                    let l = o.limits[0].unwrap_or_else(|| panic!("{what}: no limits"));
                    assert_eq!((l.lower, l.upper), (t.limit.lower, t.limit.upper), "{what}");
                }
                _ => assert_eq!(o.limits, [None, None], "{what}"),
            }
            let mimic = t.mimic.as_ref().map(|m| {
                (
                    m.joint.clone(),
                    m.multiplier.unwrap_or(1.0),
                    m.offset.unwrap_or(0.0),
                )
            });
            let ours_mimic = o
                .mimic
                .as_ref()
                .map(|m| (m.joint.clone(), m.multiplier, m.offset));
            assert_eq!(ours_mimic, mimic, "{what}");
        }
        assert!(
            chain.warnings().is_empty(),
            "{file}: {:?}",
            chain.warnings()
        );
    }
}

fn lenient_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/urdf_lenient")
}

/// The `<!-- warns: TEXT -->` comments of a file, in order.
fn expected_warnings(text: &str) -> Vec<&str> {
    text.lines()
        .filter_map(|l| l.trim().strip_prefix("<!-- warns: "))
        .map(|l| l.trim_end_matches("-->").trim())
        .collect()
}

/// Every file of `tests/data/urdf_lenient/` loads; its warnings are the ones its comments list
/// (each with a line and column), in the order of the file; and at seeded configurations every
/// link is where `clean.urdf` puts it, to the bit.
#[test]
fn valid_robots_with_oddities_load_with_warnings_and_the_same_poses() {
    let clean = Chain::from_file(lenient_dir().join("clean.urdf")).unwrap();
    assert!(clean.warnings().is_empty(), "{:?}", clean.warnings());
    let mut clean_data = Data::new(&clean);
    let mut files: Vec<PathBuf> = std::fs::read_dir(lenient_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap() != "clean.urdf")
        .collect();
    files.sort();
    assert!(files.len() >= 4, "{files:?}");
    for path in files {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(&path).unwrap();
        let chain = Chain::from_file(&path)
            .unwrap_or_else(|e| panic!("{file}: {}", kinechain::error::error_chain(&e)));
        let expected = expected_warnings(&text);
        let warnings = chain.warnings();
        assert_eq!(warnings.len(), expected.len(), "{file}: {warnings:#?}");
        for (w, e) in warnings.iter().zip(&expected) {
            assert!(w.starts_with("line "), "{file}: {w}");
            assert!(w.contains(" column "), "{file}: {w}");
            assert!(w.contains(e), "{file}: {w}\nexpected: {e}");
        }
        assert_eq!(chain.dof(), clean.dof(), "{file}");
        assert_eq!(chain.links().len(), clean.links().len(), "{file}");
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut rng = rng(3);
        for _ in 0..20 {
            let q = random_q(&clean, &mut rng);
            let ours = forward_kinematics(&chain, &mut data, &q).unwrap();
            let reference = forward_kinematics(&clean, &mut clean_data, &q).unwrap();
            for (i, link) in clean.links().iter().enumerate() {
                let a = ours.world_from_link(chain.link_id(chain.links()[i].name()).unwrap());
                let b = reference.world_from_link(clean.link_id(link.name()).unwrap());
                assert_eq!(a, b, "{file}: link {}", link.name());
            }
        }
    }
}

#[test]
fn a_planar_joint_is_two_translations_in_the_plane_then_a_rotation_about_its_axis() {
    use kinechain::nalgebra::{Rotation3, Vector3};
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/planar/mobile_arm.urdf");
    let chain = kinechain::Chain::from_file(&path).unwrap();
    assert_eq!(
        kinechain::regression::variable_names(&chain),
        ["drive.x", "drive.y", "drive.theta", "shoulder", "elbow"]
    );
    assert_eq!((chain.nq(), chain.nv()), (5, 5));
    let (x, y, theta) = (0.7, -1.3, 2.1);
    let mut data = kinechain::Data::new(&chain);
    let poses = kinechain::forward_kinematics(&chain, &mut data, &[x, y, theta, 0.0, 0.0]).unwrap();
    let base = poses.world_from_link(chain.link_id("base").unwrap());
    // origin (0.1, -0.2, 0.15) turned 0.3 about z, then (x, y) in that frame, then θ about z.
    let turn = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.3);
    let want_p = Vector3::new(0.1, -0.2, 0.15) + turn * Vector3::new(x, y, 0.0);
    let want_r = turn * Rotation3::from_axis_angle(&Vector3::z_axis(), theta);
    assert!((base.translation() - want_p).abs().max() < 1e-15);
    assert!((base.rotation() - want_r.matrix()).abs().max() < 1e-15);
}
