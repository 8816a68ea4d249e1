//! Workspace sampling: one million random configurations of the Panda arm (within its joint
//! limits), evaluated in blocks on every core, and the bounding box of the tool positions
//! reached.
//!
//! Run with `cargo run --release --example workspace`.

mod support;

use kinechain::eval::batch::forward_kinematics_batch_fold_par;
use kinechain::{Chain, LimitPolicy};

/// The box spanned by the tool positions seen, and the largest distance from the base.
#[derive(Clone, Copy)]
struct Reach {
    lo: [f64; 3],
    hi: [f64; 3],
    farthest: f64,
}

impl Reach {
    const EMPTY: Reach = Reach {
        lo: [f64::MAX; 3],
        hi: [f64::MIN; 3],
        farthest: 0.0,
    };

    fn merge(self, other: Reach) -> Reach {
        Reach {
            lo: std::array::from_fn(|k| self.lo[k].min(other.lo[k])),
            hi: std::array::from_fn(|k| self.hi[k].max(other.hi[k])),
            farthest: self.farthest.max(other.farthest),
        }
    }
}

fn main() -> std::process::ExitCode {
    support::main(run)
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let chain = Chain::from_file(support::robot("panda_mdh.yaml"))?;
    let tcp = chain.link_id("tcp")?;
    let n = 1_000_000;
    // Uniform within the joint limits, seeded (row-major: one configuration after another).
    let qs: Vec<f64> = kinechain::measure::configurations(&chain, n, 7).concat();
    let start = std::time::Instant::now();
    // Each block's poses are read while they are still in cache, on the thread that computed
    // them; keeping all million would take ~0.7 GB.
    let reach = forward_kinematics_batch_fold_par(
        &chain,
        &qs,
        LimitPolicy::Enforce,
        || Reach::EMPTY,
        |reach, _first, poses| {
            (0..poses.len()).fold(reach, |r, i| {
                let p = poses.world_from_link(i, tcp).translation();
                Reach {
                    lo: [p.x, p.y, p.z],
                    hi: [p.x, p.y, p.z],
                    farthest: p.norm(),
                }
                .merge(r)
            })
        },
        Reach::merge,
    )?;
    let elapsed = start.elapsed();
    println!(
        "{n} configurations in {:.1} ms ({:.1} ns each, {} threads)",
        elapsed.as_secs_f64() * 1e3,
        elapsed.as_nanos() as f64 / n as f64,
        rayon::current_num_threads()
    );
    let Reach { lo, hi, farthest } = reach;
    println!(
        "tcp reaches x ∈ [{:.3}, {:.3}] m, y ∈ [{:.3}, {:.3}] m, z ∈ [{:.3}, {:.3}] m",
        lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]
    );
    println!("farthest from the base: {farthest:.3} m");
    Ok(())
}
