//! What every target checks once an input has been accepted: the chain evaluates at a
//! configuration without panicking, every pose is finite or infinite but never NaN, and every
//! way of reading a pose (full, one link, incremental, batch, with rates) gives the same bits;
//! and, for the batch-line target, a row read under a CSV header is the row read without one,
//! its entries moved to the header's columns.
// Each target uses part of this module.
#![allow(dead_code)]

use kinechain::eval::batch::{BatchData, forward_kinematics_batch};
use kinechain::io::input::{csv_header, parse_batch_line, parse_batch_row};
use kinechain::{
    Chain, Data, LimitPolicy, LinkId, Transform, forward_accelerations, forward_kinematics,
    forward_kinematics_incremental, forward_kinematics_to,
};

/// Entries below this bound cannot overflow in the Jacobians' cross products and differences,
/// so a NaN there would be a fault rather than `∞ − ∞` of an absurd model.
const MODERATE: f64 = 1e100;

pub fn evaluate(chain: &Chain, q: &[f64]) {
    let ids: Vec<LinkId> = chain
        .links()
        .iter()
        .map(|link| chain.link_id(link.name()).expect("listed link"))
        .collect();
    let mut data = Data::new(chain);
    data.set_limit_policy(LimitPolicy::Ignore);
    let rates = vec![0.5; chain.dof()];
    let Ok(poses) = forward_kinematics(chain, &mut data, q) else {
        let _ = forward_accelerations(chain, &mut data, q, &rates, &rates);
        return;
    };
    let full: Vec<Transform> = ids.iter().map(|&id| poses.world_from_link(id)).collect();
    for (pose, link) in full.iter().zip(chain.links()) {
        // Overflow to infinity is possible for absurd finite inputs (1e300 m links); NaN is not.
        assert!(
            !entries(pose).any(f64::is_nan),
            "NaN pose for {}",
            link.name()
        );
    }
    let moderate = full.iter().all(|p| entries(p).all(|x| x.abs() < MODERATE));
    for &id in &ids {
        let j = poses.jacobian(id);
        assert!(!moderate || !j.iter().any(|x| x.is_nan()), "NaN Jacobian");
    }
    let _ = kinechain::io::render::svg(chain, &poses);

    // One link at a time.
    let mut other = Data::new(chain);
    other.set_limit_policy(LimitPolicy::Ignore);
    for (&id, pose) in ids.iter().zip(&full) {
        let one = forward_kinematics_to(chain, &mut other, q, id).expect("accepted in full");
        assert!(same(&one, pose), "one-link pose of link {}", id.index());
    }

    // An update from another configuration that differs in the last entry.
    if let Some((&last, head)) = q.split_last() {
        let mut moved = head.to_vec();
        moved.push(last + 0.25);
        if forward_kinematics(chain, &mut other, &moved).is_ok() {
            let updated = forward_kinematics_incremental(chain, &mut other, q).expect("accepted");
            for (&id, pose) in ids.iter().zip(&full) {
                let got = updated.world_from_link(id);
                assert!(same(&got, pose), "incremental pose of link {}", id.index());
            }
        }

        // The same two configurations as one batch.
        let mut batch = BatchData::new(chain);
        batch.set_limit_policy(LimitPolicy::Ignore);
        let qs: Vec<f64> = moved.iter().chain(q).copied().collect();
        if let Ok(both) = forward_kinematics_batch(chain, &mut batch, &qs) {
            for (&id, pose) in ids.iter().zip(&full) {
                let got = both.world_from_link(1, id);
                assert!(same(&got, pose), "batch pose of link {}", id.index());
            }
        }
    }

    // With velocities and accelerations: the same poses.
    if let Ok(acc) = forward_accelerations(chain, &mut data, q, &rates, &rates) {
        for (&id, pose) in ids.iter().zip(&full) {
            assert!(same(&acc.world_from_link(id), pose), "pose with rates");
            if moderate {
                let j = acc.velocities().jacobian_dot(id);
                let v = acc.velocity(id);
                let bounded = v.omega.iter().chain(v.v.iter()).all(|x| x.abs() < MODERATE);
                assert!(
                    !bounded || !j.iter().any(|x| x.is_nan()),
                    "NaN Jacobian rate"
                );
            }
        }
    }
}

/// What the loader targets check beyond [`evaluate`]: a chain that converts to URDF loads back
/// with the same joint vector.
pub fn convert(chain: &Chain) {
    if let Ok(text) = kinechain::io::convert::to_urdf(chain) {
        let back = Chain::from_urdf_str(&text).expect("a converted chain loads back");
        assert_eq!(back.dof(), chain.dof(), "converted joint vector");
    }
}

/// Bit for bit, NaN included.
fn same(a: &Transform, b: &Transform) -> bool {
    entries(a)
        .zip(entries(b))
        .all(|(x, y)| x.to_bits() == y.to_bits())
}

fn entries(t: &Transform) -> impl Iterator<Item = f64> {
    t.to_rows().into_iter().flatten()
}

pub fn zero(chain: &Chain) -> Vec<f64> {
    vec![0.0; chain.dof()]
}

/// A configuration that turns every joint, for the loader targets (the zero configuration
/// leaves many terms at exactly 0 or 1).
pub fn turned(chain: &Chain) -> Vec<f64> {
    (0..chain.dof()).map(|i| 0.3 + 0.1 * i as f64).collect()
}

/// The chains the input-parser targets read joint vectors for: one with a cylindrical joint
/// (two entries), one with a mimic joint (no entry of its own).
pub fn input_chains() -> [Chain; 2] {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    [
        Chain::from_file(dir.join("robots/cylindrical.yaml")).expect("bundled robot"),
        Chain::from_file(dir.join("robots/panda.urdf")).expect("bundled robot"),
    ]
}

/// What the batch-line target checks of a CSV header: `text` read as a header, when it is one,
/// names every entry of `q` once; and when its first line is a header, the line after it read
/// under that header gives what the same line read without one gives (the same error, or the
/// same values with a row of numbers' entries moved to the header's columns).
pub fn header_and_row(chain: &Chain, text: &str) {
    if let Some(Ok(header)) = csv_header(chain, text) {
        let mut columns = header.columns().to_vec();
        columns.sort_unstable();
        assert!(columns.into_iter().eq(0..chain.dof()), "{text:?}");
    }
    let Some((first, rest)) = text.split_once('\n') else {
        return;
    };
    let Some(Ok(header)) = csv_header(chain, first) else {
        return;
    };
    let row = rest.split_once('\n').map_or(rest, |(row, _)| row);
    let json = row.trim_start().starts_with(['[', '{']);
    match (
        parse_batch_line(chain, row),
        parse_batch_row(chain, row, Some(&header)),
    ) {
        (Ok(plain), Ok(ordered)) => {
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let mut moved = plain.q.clone();
            if !json {
                for (&x, &column) in plain.q.iter().zip(header.columns()) {
                    moved[column] = x;
                }
            }
            assert_eq!(bits(&moved), bits(&ordered.q), "{text:?}");
            assert_eq!(plain.q_dot, ordered.q_dot, "{text:?}");
            assert_eq!(plain.q_ddot, ordered.q_ddot, "{text:?}");
        }
        (Err(plain), Err(ordered)) => assert_eq!(plain, ordered, "{text:?}"),
        (plain, ordered) => panic!("{text:?}: without a header {plain:?}, under it {ordered:?}"),
    }
}
