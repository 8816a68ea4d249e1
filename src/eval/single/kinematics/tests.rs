use super::*;

/// Buffers that evaluate values outside the joints' limits too (some test values are).
fn unchecked(chain: &Chain) -> Data {
    let mut data = Data::new(chain);
    data.set_limit_policy(LimitPolicy::Ignore);
    data
}

/// `forward_kinematics_to` evaluates the bodies from the base to the link's and no other:
/// after a full evaluation at `q0`, one link at `q1` rewrites exactly the frames of its path,
/// and those equal a full evaluation at `q1`; every other body keeps its frame of `q0`.
#[test]
fn one_link_evaluates_only_its_path() {
    let chain = Chain::from_file(concat!(env!("CARGO_MANIFEST_DIR"), "/robots/panda.urdf"))
        .expect("bundled robot");
    let q0: Vec<f64> = (0..chain.dof()).map(|i| 0.01 * i as f64).collect();
    let q1: Vec<f64> = q0.iter().map(|x| x + 0.3).collect();
    let frames_at = |q: &[f64]| {
        let mut data = unchecked(&chain);
        forward_kinematics(&chain, &mut data, q).expect("finite");
        data.world_from_body.clone()
    };
    let (before, after) = (frames_at(&q0), frames_at(&q1));
    assert!(
        before.iter().zip(&after).all(|(a, b)| a != b),
        "every body moves"
    );
    for (link, path_len) in [
        ("panda_link4", 4),
        ("panda_rightfinger", 8),
        ("panda_hand_tcp", 7),
    ] {
        let id = chain.link_id(link).expect("a Panda link");
        let mut path = Vec::new();
        chain.body_path(chain.carrier(id).body, &mut path);
        assert_eq!(path.len(), path_len, "{link}");
        let mut data = unchecked(&chain);
        forward_kinematics(&chain, &mut data, &q0).expect("finite");
        forward_kinematics_to(&chain, &mut data, &q1, id).expect("finite");
        for (k, frame) in data.world_from_body.iter().enumerate() {
            let want = if path.contains(&k) {
                &after[k]
            } else {
                &before[k]
            };
            assert_eq!(frame, want, "{link}: body {k}");
        }
    }
}

/// An incremental update that moves only the last joints writes the frames from the first
/// body reading a changed entry on, and reads only that body's parent before it: frames
/// further up, overwritten here with NaN after the first evaluation, stay as they are, and the
/// recomputed ones equal a fresh evaluation bit for bit.
#[test]
fn an_incremental_update_leaves_the_unchanged_head_alone() {
    for (file, moved) in [
        ("robots/ur5.yaml", 1),
        ("robots/panda.urdf", 2),
        ("robots/panda_mdh.yaml", 3),
    ] {
        let chain = Chain::from_file(format!("{}/{file}", env!("CARGO_MANIFEST_DIR")))
            .expect("bundled robot");
        let n = chain.dof();
        let q0: Vec<f64> = (0..n).map(|i| 0.01 * i as f64).collect();
        let mut q1 = q0.clone();
        for x in &mut q1[n - moved..] {
            *x += 0.02;
        }
        let first = chain.first_body_from[n - moved];
        let mut data = unchecked(&chain);
        forward_kinematics(&chain, &mut data, &q0).expect("finite");
        let parent = chain.bodies[first].parent.expect("a moving parent");
        let unset = crate::eval::layout::stored::Stored([[f64::NAN; 4]; 4]);
        for (k, frame) in data.world_from_body.iter_mut().enumerate().take(first) {
            if k != parent {
                *frame = unset;
            }
        }
        forward_kinematics_incremental(&chain, &mut data, &q1).expect("finite");
        let mut fresh = unchecked(&chain);
        forward_kinematics(&chain, &mut fresh, &q1).expect("finite");
        for (k, (frame, want)) in data
            .world_from_body
            .iter()
            .zip(&fresh.world_from_body)
            .enumerate()
        {
            if k < first && k != parent {
                assert!(
                    frame.iter().flatten().all(|x| x.is_nan()),
                    "{file}: body {k} was rewritten"
                );
            } else {
                assert_eq!(frame, want, "{file}: body {k}");
            }
        }
    }
}
