//! End-effector pose of a bundled robot: the Panda arm (modified DH) at a few configurations.
//!
//! Run with `cargo run --release --example end_effector`.

mod support;

use kinechain::{Chain, Data, forward_kinematics, forward_kinematics_to};

fn main() -> std::process::ExitCode {
    support::main(run)
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let chain = Chain::from_file(support::robot("panda_mdh.yaml"))?;
    let tcp = chain.link_id("tcp")?;
    let mut data = Data::new(&chain);

    let configurations = [
        ("ready", [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]),
        ("reach", [0.5, 0.4, -0.3, -1.2, 0.2, 1.8, -0.4]),
        ("folded", [0.0, -1.7, 0.0, -3.0, 0.0, 0.5, 0.0]),
    ];
    for (name, q) in &configurations {
        // All links at once ...
        let poses = forward_kinematics(&chain, &mut data, q)?;
        let pose = poses.world_from_link(tcp);
        // ... or only the joints between the base and the tool.
        let same = forward_kinematics_to(&chain, &mut data, q, tcp)?;
        assert_eq!(pose, same);

        let p = pose.translation();
        let z = pose.rotation().column(2).into_owned();
        println!(
            "{name:>7}: tcp at ({:+.4}, {:+.4}, {:+.4}) m, approach axis ({:+.3}, {:+.3}, {:+.3})",
            p.x, p.y, p.z, z.x, z.y, z.z
        );
    }
    Ok(())
}
