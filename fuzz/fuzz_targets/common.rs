//! What every target checks once an input has been accepted: the chain evaluates at a
//! configuration without panicking, and every pose is finite.
// Each target uses part of this module.
#![allow(dead_code)]

use kinechain::{Chain, Data, LimitPolicy, forward_accelerations, forward_kinematics};

pub fn evaluate(chain: &Chain, q: &[f64]) {
    let mut data = Data::new(chain);
    data.set_limit_policy(LimitPolicy::Ignore);
    if let Ok(poses) = forward_kinematics(chain, &mut data, q) {
        for link in chain.links() {
            let id = chain.link_id(link.name()).expect("listed link");
            let p = poses.world_from_link(id);
            // Overflow to infinity is possible for absurd finite inputs (1e300 m links); NaN is not.
            assert!(
                !p.to_rows().iter().flatten().any(|x| x.is_nan()),
                "NaN pose for {}",
                link.name()
            );
        }
    }
    let rates = vec![0.5; chain.dof()];
    let _ = forward_accelerations(chain, &mut data, q, &rates, &rates);
}

pub fn zero(chain: &Chain) -> Vec<f64> {
    vec![0.0; chain.dof()]
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
