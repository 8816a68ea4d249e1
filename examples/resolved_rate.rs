//! Resolved-rate motion with the geometric Jacobian: the Panda (modified DH) brings its tool to a
//! target pose by damped least squares, `Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e`, one step per evaluation,
//! with the joint limits of the file respected. The target is the tool pose of another
//! configuration, so it can be reached.
//!
//! Run with `cargo run --release --example resolved_rate`.

mod support;

use kinechain::nalgebra::{Matrix6, Vector3, Vector6};
use kinechain::{Chain, Data, Limits, Transform, forward_kinematics};

/// The twist that closes the gap from `pose` to `target` in unit time, to first order: the
/// position difference, and for the orientation `½ Σ rᵢ × r*ᵢ` over the rotation columns (zero
/// when the rotations agree, and the rotation vector of the gap when it is small).
fn pose_error(pose: &Transform, target: &Transform) -> Vector6<f64> {
    let (r, r_target) = (pose.rotation(), target.rotation());
    let turn: Vector3<f64> = (0..3)
        .map(|i| r.column(i).cross(&r_target.column(i)))
        .sum::<Vector3<f64>>()
        * 0.5;
    let shift = target.translation() - pose.translation();
    Vector6::new(shift.x, shift.y, shift.z, turn.x, turn.y, turn.z)
}

/// The limits of each entry of `q` (a cylindrical joint has two entries and two limits).
fn limits_of_q(chain: &Chain) -> Vec<Option<Limits>> {
    let mut limits = vec![None; chain.dof()];
    for joint in chain.joints() {
        if let Some(first) = joint.q_index() {
            for (k, l) in joint.limits().iter().enumerate() {
                limits[first + k] = *l;
            }
        }
    }
    limits
}

fn main() -> std::process::ExitCode {
    support::main(run)
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let chain = Chain::from_file(support::robot("panda_mdh.yaml"))?;
    let tcp = chain.link_id("tcp")?;
    let limits = limits_of_q(&chain);
    let mut data = Data::new(&chain);

    let goal = [0.5, 0.4, -0.3, -1.2, 0.2, 1.8, -0.4];
    let target = forward_kinematics(&chain, &mut data, &goal)?.world_from_link(tcp);
    let mut q = vec![0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];

    // Damping keeps steps bounded near singular configurations; it slows the last steps a little.
    let damping: f64 = 1e-2;
    let mut jacobian = kinechain::nalgebra::Matrix6xX::zeros(chain.dof());
    for step in 0..200 {
        let poses = forward_kinematics(&chain, &mut data, &q)?;
        let error = pose_error(&poses.world_from_link(tcp), &target);
        println!(
            "step {step:3}: position error {:.3e} m, orientation error {:.3e} rad",
            error.fixed_rows::<3>(0).norm(),
            error.fixed_rows::<3>(3).norm()
        );
        if error.norm() < 1e-12 {
            return Ok(());
        }
        poses.jacobian_into(tcp, &mut jacobian);
        let jjt = &jacobian * jacobian.transpose() + Matrix6::identity() * damping.powi(2);
        let weights = jjt
            .cholesky()
            .ok_or("J Jᵀ + λ² I is not positive definite")?
            .solve(&error);
        let dq = jacobian.transpose() * weights;
        for ((x, dx), limit) in q.iter_mut().zip(dq.iter()).zip(&limits) {
            *x += dx;
            if let Some(l) = limit {
                *x = x.clamp(l.lower, l.upper);
            }
        }
    }
    Err("no convergence in 200 steps".into())
}
