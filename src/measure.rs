//! Seeded joint configurations and wall-clock timing: what `kinechain bench` and the project's
//! benchmarks use, so that every figure they print is measured the same way (and so that a user
//! timing their own code can do likewise).

use crate::Chain;
use std::time::{Duration, Instant};

/// SplitMix64: a small, fast, seedable generator (reproducible across platforms).
struct SplitMix(u64);

impl SplitMix {
    /// Uniform in `[0, 1)`.
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n` configurations drawn uniformly within the joint limits (±π for an entry without finite
/// limits), the same for the same `seed`.
///
/// # Examples
/// ```
/// let chain = kinechain::Chain::from_file("robots/ur5.yaml")?;
/// let qs = kinechain::measure::configurations(&chain, 10, 1);
/// assert_eq!(qs.len(), 10);
/// assert!(qs.iter().all(|q| kinechain::check_q(&chain, q, kinechain::LimitPolicy::Enforce).is_ok()));
/// assert_eq!(qs, kinechain::measure::configurations(&chain, 10, 1));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[must_use]
pub fn configurations(chain: &Chain, n: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = SplitMix(seed);
    (0..n)
        .map(|_| {
            let mut q = vec![0.0; chain.dof()];
            for j in chain.joints() {
                let Some(first) = j.q_index() else { continue };
                for (k, l) in j.limits().iter().enumerate() {
                    let (lo, hi) = match l {
                        Some(l) if l.lower.is_finite() && l.upper.is_finite() => (l.lower, l.upper),
                        _ => (-std::f64::consts::PI, std::f64::consts::PI),
                    };
                    q[first + k] = lo + (hi - lo) * rng.unit();
                }
            }
            q
        })
        .collect()
}

/// Time of one call of `f` in ns: the number of calls per run is doubled until a run lasts at
/// least `min_run`, then the median of `runs` such runs is returned (the median resists the
/// outliers of a shared machine).
pub fn time_per_call(min_run: Duration, runs: usize, mut f: impl FnMut()) -> f64 {
    let mut calls = 1u64;
    loop {
        let t = Instant::now();
        for _ in 0..calls {
            f();
        }
        if t.elapsed() >= min_run {
            break;
        }
        calls *= 2;
    }
    let mut times: Vec<f64> = (0..runs.max(1))
        .map(|_| {
            let t = Instant::now();
            for _ in 0..calls {
                f();
            }
            t.elapsed().as_nanos() as f64 / calls as f64
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}
