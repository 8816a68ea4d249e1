//! Velocities and accelerations along a trajectory: the UR5 follows a smooth joint-space path
//! (a quintic blend from one configuration to another in 2 s); at each instant the tool's speed
//! and acceleration come from one `forward_accelerations` call, and a central difference of
//! tool positions confirms them.
//!
//! Run with `cargo run --release --example trajectory`.

use kinechain::{Chain, Data, forward_accelerations, forward_kinematics};

/// Quintic blend s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ on [0, 1], with zero velocity and acceleration at
/// both ends; returns (s, ds/dτ, d²s/dτ²).
fn blend(tau: f64) -> (f64, f64, f64) {
    let (t2, t3) = (tau * tau, tau * tau * tau);
    (
        10.0 * t3 - 15.0 * t3 * tau + 6.0 * t3 * t2,
        30.0 * t2 - 60.0 * t3 + 30.0 * t2 * t2,
        60.0 * tau - 180.0 * t2 + 120.0 * t3,
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let chain = Chain::from_file("robots/ur5.yaml")?;
    let tool = chain.link_id("tool0")?;
    let mut data = Data::new(&chain);
    let start = [0.0, -1.6, 1.4, -1.4, -1.57, 0.0];
    let goal = [1.2, -0.8, 0.9, -1.7, -1.2, 0.8];
    let duration = 2.0;
    let state = |t: f64| {
        let (s, sd, sdd) = blend(t / duration);
        let q: Vec<f64> = (0..6)
            .map(|i| start[i] + s * (goal[i] - start[i]))
            .collect();
        let qd: Vec<f64> = (0..6)
            .map(|i| sd / duration * (goal[i] - start[i]))
            .collect();
        let qdd: Vec<f64> = (0..6)
            .map(|i| sdd / (duration * duration) * (goal[i] - start[i]))
            .collect();
        (q, qd, qdd)
    };
    println!("   t (s)   |v| (m/s)   |a| (m/s²)   |ω| (rad/s)   v vs finite difference");
    for step in 0..=10 {
        let t = duration * step as f64 / 10.0;
        let (q, qd, qdd) = state(t);
        let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd)?;
        let (v, a) = (acc.velocity(tool), acc.acceleration(tool));
        // Central difference of the tool position, h = 1e-5 s.
        let h = 1e-5;
        let mut at = |t: f64| -> Result<_, kinechain::StateError> {
            let q = state(t).0;
            Ok(forward_kinematics(&chain, &mut data, &q)?
                .world_from_link(tool)
                .translation())
        };
        let fd = (at(t + h)? - at(t - h)?) / (2.0 * h);
        println!(
            "{t:8.2} {:11.4} {:12.4} {:13.4}   {:.1e}",
            v.v.norm(),
            a.a.norm(),
            v.omega.norm(),
            (fd - v.v).norm()
        );
    }
    Ok(())
}
