//! Chains built in code: what the builder is given is what the built chain reports and where
//! its evaluation puts the links.

use kinechain::nalgebra::{Point3, Vector3};
use kinechain::{
    Chain, ChainBuilder, Data, JointKind, JointSpec, ModelError, Transform, forward_kinematics,
};

fn placed_arm() -> (ChainBuilder, Chain) {
    let base = Transform::from_xyz_rpy([0.5, -0.25, 1.0], [0.0, 0.0, 0.3]);
    let mut b = ChainBuilder::new("placed");
    b.link("base").link("upper").link("lower");
    b.world_from_root(base);
    b.joint(
        JointSpec::new("shoulder", JointKind::Revolute, "base", "upper")
            // Not a unit vector: the chain keeps it normalised.
            .with_axis([0.0, 1.2, 1.6])
            .with_origin(Transform::from_xyz_rpy([0.0, 0.0, 0.2], [0.0; 3])),
    );
    b.joint(
        JointSpec::new("elbow", JointKind::Prismatic, "upper", "lower")
            .with_origin(Transform::from_xyz_rpy([0.3, 0.0, 0.0], [0.0; 3]))
            .with_offsets(-0.5, 0.125)
            .with_limits(-0.1, 0.2),
    );
    let chain = b.build().unwrap();
    (b, chain)
}

#[test]
fn the_chain_reports_what_it_was_built_from() {
    let (b, chain) = placed_arm();
    assert_eq!(b.name(), "placed");
    assert_eq!(chain.name(), "placed");
    assert_eq!(chain.description().name(), "placed");
    let base = Transform::from_xyz_rpy([0.5, -0.25, 1.0], [0.0, 0.0, 0.3]);
    assert_eq!(b.root_placement(), Some(base));
    assert_eq!(chain.description().root_placement(), Some(base));
    assert_eq!(ChainBuilder::new("bare").root_placement(), None);
    for (i, name) in ["shoulder", "elbow"].into_iter().enumerate() {
        let id = chain.joint_id(name).unwrap();
        assert_eq!(id.index(), i);
        assert_eq!(chain.joint(id).name(), name);
    }
    let shoulder = chain.joint(chain.joint_id("shoulder").unwrap());
    let axis = shoulder.axis();
    assert!(axis[0] == 0.0 && (axis[1] - 0.6).abs() < 2e-16 && (axis[2] - 0.8).abs() < 2e-16);
    let elbow = chain.joint(chain.joint_id("elbow").unwrap());
    assert_eq!(elbow.axis(), [0.0, 0.0, 1.0]);
    assert_eq!(elbow.offsets(), (-0.5, 0.125));
    assert_eq!(shoulder.offsets(), (0.0, 0.0));
    // Each link names the joint it hangs from.
    for (link, joint) in [
        ("base", None),
        ("upper", Some("shoulder")),
        ("lower", Some("elbow")),
    ] {
        let parent = chain.link(chain.link_id(link).unwrap()).parent_joint();
        assert_eq!(parent, joint.map(|j| chain.joint_id(j).unwrap()), "{link}");
    }
}

#[test]
fn the_root_placement_moves_every_link() {
    let (_, chain) = placed_arm();
    let base = chain.description().root_placement().unwrap();
    let mut data = Data::new(&chain);
    let q = [0.4, 0.05];
    let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
    let root = chain.link_id("base").unwrap();
    assert_eq!(poses.world_from_link(root), base);
    // The same chain built without the placement, then placed by hand.
    let (mut unplaced, _) = placed_arm();
    unplaced.world_from_root(Transform::IDENTITY);
    let local = unplaced.build().unwrap();
    let mut local_data = Data::new(&local);
    let local_poses = forward_kinematics(&local, &mut local_data, &q).unwrap();
    for link in ["upper", "lower"] {
        let placed = poses.world_from_link(chain.link_id(link).unwrap());
        let by_hand = base * local_poses.world_from_link(local.link_id(link).unwrap());
        let diff = (placed.to_homogeneous() - by_hand.to_homogeneous())
            .abs()
            .max();
        assert!(diff < 4.0 * f64::EPSILON, "{link}: {diff:e}");
    }
}

#[test]
fn the_reach_bounds_every_link_within_the_limits() {
    let (_, chain) = placed_arm();
    // The base's distance, the two origins' lengths and the elbow's farthest slide, 0.125 + 0.2.
    let want = (0.5f64.powi(2) + 0.25f64.powi(2) + 1.0).sqrt() + 0.2 + 0.3 + 0.325;
    assert!(
        (chain.reach() - want).abs() < 4.0 * f64::EPSILON,
        "{}",
        chain.reach()
    );
    let mut data = Data::new(&chain);
    let mut farthest = 0.0_f64;
    for i in 0..=20 {
        for j in 0..=20 {
            let q = [-3.0 + 0.3 * f64::from(i), -0.1 + 0.015 * f64::from(j)];
            let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
            for link in chain.links() {
                let p = poses
                    .world_from_link(chain.link_id(link.name()).unwrap())
                    .translation();
                farthest = farthest.max(p.norm());
            }
        }
    }
    assert!(farthest <= chain.reach(), "{farthest} > {}", chain.reach());
    // Not a loose bound either: the farthest origin found comes within 0.25 m of it (0.205).
    assert!(farthest > chain.reach() - 0.25, "{farthest}");
}

/// The travel counted is the farther end of the slide from the joint's offset (here the lower
/// end: d = 0.3 − 0.9), and a placement after the joint's motion adds its length: 0.6 + 0.25.
#[test]
fn the_reach_counts_the_farther_end_of_a_slide_and_the_placement_after_it() {
    let mut b = ChainBuilder::new("slide");
    b.link("a").link("b").joint(
        JointSpec::new("slide", JointKind::Prismatic, "a", "b")
            .with_offsets(0.0, 0.3)
            .with_limits(-0.9, 0.1)
            .with_post(Transform::from_xyz_rpy([0.0, 0.25, 0.0], [0.0; 3])),
    );
    let chain = b.build().unwrap();
    assert!(
        (chain.reach() - 0.85).abs() < 4.0 * f64::EPSILON,
        "{}",
        chain.reach()
    );
    // At the lower end the link is 0.65 m out (the slide's −0.6 along z and the 0.25 along y,
    // at right angles): within the reach, and farther than the slide alone.
    let mut data = Data::new(&chain);
    let poses = forward_kinematics(&chain, &mut data, &[-0.9]).unwrap();
    let p = poses
        .world_from_link(chain.link_id("b").unwrap())
        .translation();
    assert!(p.norm() <= chain.reach() && p.norm() > 0.6, "{p}");
}

#[test]
fn an_open_ended_slide_leaves_the_reach_finite() {
    // Travel counts only where both limits are finite; otherwise the offset stands for it.
    for (lower, upper) in [(-0.1, f64::INFINITY), (f64::NEG_INFINITY, 0.2)] {
        let mut b = ChainBuilder::new("open");
        b.link("a").link("b").joint(
            JointSpec::new("slide", JointKind::Prismatic, "a", "b")
                .with_offsets(0.0, 0.5)
                .with_limits(lower, upper),
        );
        let chain = b.build().unwrap();
        assert_eq!(chain.reach(), 0.5, "{lower} {upper}");
    }
}

#[test]
fn numbers_from_code_are_checked_as_numbers_from_files_are() {
    let build = |joint: JointSpec| {
        let mut b = ChainBuilder::new("bad");
        b.link("a").link("b").joint(joint);
        b.build()
    };
    let joint = || JointSpec::new("j", JointKind::Cylindrical, "a", "b");
    let non_finite = [
        (joint().with_offsets(f64::NAN, 0.0), "theta"),
        (joint().with_offsets(0.0, f64::INFINITY), "d"),
        (joint().with_axis([0.0, f64::NAN, 1.0]), "axis"),
        (joint().with_limits(f64::NAN, 1.0), "limits"),
        (joint().with_limits(-1.0, f64::NAN), "limits"),
    ];
    for (spec, field) in non_finite {
        match build(spec) {
            Err(ModelError::NonFinite { joint, field: f }) => {
                assert_eq!((joint.as_str(), f), ("j", field));
            }
            other => panic!("{field}: {other:?}"),
        }
    }
    assert!(matches!(
        build(joint().with_axis([0.0; 3])),
        Err(ModelError::ZeroAxis { joint }) if joint == "j"
    ));
    assert!(matches!(
        build(joint().with_limits(1.0, -1.0)),
        Err(ModelError::ReversedLimits { joint, .. }) if joint == "j"
    ));
    assert!(build(joint().with_limits(-1.0, 1.0)).is_ok());
}

#[test]
fn a_mimic_of_a_mimic_follows_the_primary_through_both() {
    let mut b = ChainBuilder::new("gripper");
    b.link("palm").link("a").link("b").link("c");
    b.joint(JointSpec::new("drive", JointKind::Revolute, "palm", "a"));
    b.joint(JointSpec::new("middle", JointKind::Revolute, "a", "b").with_mimic("drive", 2.0, 0.1));
    b.joint(JointSpec::new("tip", JointKind::Revolute, "b", "c").with_mimic("middle", -1.0, 0.25));
    let chain = b.build().unwrap();
    assert_eq!(chain.dof(), 1);
    let q = [0.3];
    let tip = chain
        .joint_position(chain.joint_id("tip").unwrap(), &q)
        .unwrap();
    // q_tip = −(2 q + 0.1) + 0.25 = −2 q + 0.15.
    assert!(
        (tip - (-2.0 * 0.3 + 0.15)).abs() < 4.0 * f64::EPSILON,
        "{tip}"
    );
    // The tip turns by the sum of the three angles about the shared z axis.
    let mut data = Data::new(&chain);
    let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
    let r = poses
        .world_from_link(chain.link_id("c").unwrap())
        .rotation();
    let total = 0.3 + (2.0 * 0.3 + 0.1) + tip;
    assert!((r[(1, 0)] - total.sin()).abs() < 1e-15 && (r[(0, 0)] - total.cos()).abs() < 1e-15);
}

#[test]
fn joint_axes_pass_through_the_joint_frames() {
    let (mut b, _) = placed_arm();
    b.link("tool").joint(
        JointSpec::new("flange", JointKind::Fixed, "lower", "tool")
            .with_origin(Transform::from_xyz_rpy([0.0, 0.0, 0.1], [0.2, 0.0, 0.0])),
    );
    let chain = b.build().unwrap();
    let mut data = Data::new(&chain);
    let poses = forward_kinematics(&chain, &mut data, &[0.4, 0.05]).unwrap();
    let pose = |link: &str| poses.world_from_link(chain.link_id(link).unwrap());
    let axis = |joint: &str| poses.joint_axis(chain.joint_id(joint).unwrap());
    let close = |a: Vector3<f64>, b: Vector3<f64>| (a - b).amax() < 4.0 * f64::EPSILON;
    let upper = pose("upper");
    // The turning shoulder's axis passes through the origin of the link it turns, in the
    // direction it was given (normalised) turned into the world.
    let (point, direction) = axis("shoulder").unwrap();
    assert!(close(point.coords, upper.translation()), "{point}");
    let given = Vector3::new(0.0, 0.6, 0.8);
    assert!(close(direction, upper.rotation() * given), "{direction}");
    // The elbow's axis starts at its joint frame, 0.3 m along the upper link's x, and the lower
    // link's origin slides along it by d = 0.125 + q.
    let (point, direction) = axis("elbow").unwrap();
    let joint_frame = upper.transform_point(&Point3::new(0.3, 0.0, 0.0));
    assert!(close(point.coords, joint_frame.coords), "{point}");
    assert!(
        close(direction, upper.rotation() * Vector3::z()),
        "{direction}"
    );
    let lower = pose("lower").translation();
    assert!(
        close(lower, point.coords + (0.125 + 0.05) * direction),
        "{lower}"
    );
    // A fixed joint has no axis.
    assert_eq!(axis("flange"), None);
}
