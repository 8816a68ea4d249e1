//! Velocities and accelerations along a trajectory: the UR5 follows a smooth joint-space path
//! (a quintic blend from one configuration to another in 2 s); at each instant the tool's speed
//! and acceleration come from one `forward_accelerations` call, and central differences of
//! tool positions confirm them (the example fails if either disagrees beyond the differences'
//! own error).
//!
//! Run with `cargo run --release --example trajectory`.

mod support;

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

fn main() -> std::process::ExitCode {
    support::main(run)
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let chain = Chain::from_file(support::robot("ur5.yaml"))?;
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
    println!("   t (s)   |v| (m/s)   |a| (m/s²)   |ω| (rad/s)   finite differences: v      a");
    for step in 0..=10 {
        let t = duration * step as f64 / 10.0;
        let (q, qd, qdd) = state(t);
        let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd)?;
        let (v, a) = (acc.velocity(tool), acc.acceleration(tool));
        let mut at = |t: f64| -> Result<_, kinechain::StateError> {
            let q = state(t).0;
            Ok(forward_kinematics(&chain, &mut data, &q)?
                .world_from_link(tool)
                .translation())
        };
        // Central differences of the tool position: the first with h = 1e-5 s, the second with
        // h = 1e-4 s, since its rounding error grows as 1/h². The rounding of the positions
        // (about 1e-16 m) bounds their agreement at about 1e-10 m/s and 1e-7 m/s²; a wrong term
        // in the accelerations would be of the order of 0.1 m/s².
        let h = 1e-5;
        let v_fd = (at(t + h)? - at(t - h)?) / (2.0 * h);
        let h = 1e-4;
        let a_fd = (at(t + h)? - 2.0 * at(t)? + at(t - h)?) / (h * h);
        let (v_gap, a_gap) = ((v_fd - v.v).norm(), (a_fd - a.a).norm());
        println!(
            "{t:8.2} {:11.4} {:12.4} {:13.4}   {v_gap:21.1e} {a_gap:8.1e}",
            v.v.norm(),
            a.a.norm(),
            v.omega.norm(),
        );
        if v_gap > 1e-8 || a_gap > 1e-5 {
            return Err(format!(
                "at t = {t} s the differences disagree: v by {v_gap:e}, a by {a_gap:e}"
            )
            .into());
        }
    }
    Ok(())
}
