//! Workspace sampling: one million random configurations of the Panda arm (within its joint
//! limits), evaluated in batches on every core, and the bounding box of the tool positions
//! reached.
//!
//! Run with `cargo run --release --example workspace`.

use kinechain::Chain;
use kinechain::batch::{BatchData, forward_kinematics_batch_par};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let chain = Chain::from_file("robots/panda_mdh.yaml")?;
    let tcp = chain.link_id("tcp")?;
    let n = 1_000_000;
    // Uniform within the joint limits, seeded (row-major: one configuration after another).
    let qs: Vec<f64> = kinechain::measure::configurations(&chain, n, 7).concat();
    // Chunks of a few thousand configurations: the poses of each chunk are read while they are
    // still in cache, and the buffers are reused (all million at once would take ~0.7 GB).
    let chunk = 8192 * chain.dof();
    let mut batch = BatchData::new(&chain);
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    let mut farthest: f64 = 0.0;
    let start = std::time::Instant::now();
    for qs in qs.chunks(chunk) {
        let poses = forward_kinematics_batch_par(&chain, &mut batch, qs)?;
        for i in 0..poses.len() {
            let p = poses.world_from_link(i, tcp).translation();
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            farthest = farthest.max(p.norm());
        }
    }
    let elapsed = start.elapsed();
    println!(
        "{n} configurations in {:.1} ms ({:.1} ns each, {} threads)",
        elapsed.as_secs_f64() * 1e3,
        elapsed.as_nanos() as f64 / n as f64,
        rayon::current_num_threads()
    );
    println!(
        "tcp reaches x ∈ [{:.3}, {:.3}] m, y ∈ [{:.3}, {:.3}] m, z ∈ [{:.3}, {:.3}] m",
        lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]
    );
    println!("farthest from the base: {farthest:.3} m");
    Ok(())
}
