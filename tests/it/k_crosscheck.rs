//! Cross-check against the `k` crate: for every URDF of `robots/` and of the reference data that
//! `k` loads, all link poses at 100 seeded random configurations agree to 1e-12.
//!
//! `k` pins its own nalgebra and urdf-rs, so results are compared through plain arrays. `k`
//! counts mimic joints in its joint vector (and overwrites them from their primary).

use crate::common::*;
use kinechain::{Chain, Data, forward_kinematics};

#[test]
fn link_poses_agree_with_k() {
    let mut robots_checked = 0;
    for path in k_urdf_files() {
        let chain = Chain::from_file(&path).unwrap();
        let robot = k::Chain::<f64>::from_urdf_file(&path)
            .unwrap_or_else(|e| panic!("k cannot load {}: {e}", path.display()));
        let mut data = Data::new(&chain);
        let mut rng = rng(7);
        let mut links_checked = 0;
        let names: Vec<String> = robot.iter_joints().map(|j| j.name.clone()).collect();
        for _ in 0..100 {
            let q = random_q(&chain, &mut rng);
            robot
                .set_joint_positions(
                    &chain
                        .positions_by_name(names.iter().map(String::as_str), &q)
                        .unwrap(),
                )
                .unwrap();
            robot.update_transforms();
            let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
            for node in robot.iter() {
                let Some(link) = node.link().as_ref().map(|l| l.name.clone()) else {
                    continue;
                };
                let theirs = node.world_transform().unwrap().to_homogeneous();
                let mut rows = [[0.0; 4]; 4];
                for (i, row) in rows.iter_mut().enumerate() {
                    for (j, x) in row.iter_mut().enumerate() {
                        *x = theirs[(i, j)];
                    }
                }
                let ours = poses.world_from_link(chain.link_id(&link).unwrap());
                let e = pose_error(&ours, &rows);
                assert!(e < 1e-12, "{}: link {link}: {e:e}", path.display());
                links_checked += 1;
            }
        }
        assert_eq!(
            links_checked,
            100 * chain.links().len(),
            "{}",
            path.display()
        );
        robots_checked += 1;
    }
    assert!(robots_checked >= 15);
}
