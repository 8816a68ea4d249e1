//! Converting a DH table to URDF: the Stanford arm (standard DH, with a prismatic joint) written
//! as URDF, loaded back, and compared link by link.
//!
//! Run with `cargo run --release --example dh_to_urdf [ROBOT.yaml]`; the URDF goes to stdout.

mod support;

use kinechain::{Chain, Data, LimitPolicy, forward_kinematics};

fn main() -> std::process::ExitCode {
    support::main(run)
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args_os()
        .nth(1)
        .map_or_else(|| support::robot("stanford.yaml"), std::path::PathBuf::from);
    let dh = Chain::from_file(&path)?;
    let text = kinechain::io::convert::to_urdf(&dh)?;
    let urdf = Chain::from_urdf_str(&text)?;

    // The same configuration through both models: every link of the DH model, same pose.
    let q: Vec<f64> = (0..dh.dof()).map(|i| 0.4 + 0.1 * i as f64).collect();
    let (mut a, mut b) = (
        Data::new(&dh).with_limit_policy(LimitPolicy::Ignore),
        Data::new(&urdf).with_limit_policy(LimitPolicy::Ignore),
    );
    let (pa, pb) = (
        forward_kinematics(&dh, &mut a, &q)?,
        forward_kinematics(&urdf, &mut b, &q)?,
    );
    let mut worst: f64 = 0.0;
    for link in dh.links() {
        let x = pa
            .world_from_link(dh.link_id(link.name())?)
            .to_homogeneous();
        let y = pb
            .world_from_link(urdf.link_id(link.name())?)
            .to_homogeneous();
        worst = worst.max((x - y).abs().max());
    }
    eprintln!(
        "{}: {} links, {} joints in the URDF; largest pose difference {worst:.1e}",
        path.display(),
        urdf.links().len(),
        urdf.joints().len()
    );
    // The URDF writes each DH row as an origin's xyz and rpy: the poses agree up to rounding.
    if worst > 1e-12 {
        return Err(format!("the URDF's poses differ from the DH table's by {worst:e}").into());
    }
    print!("{text}");
    Ok(())
}
