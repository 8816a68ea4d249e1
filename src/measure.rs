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

/// The larger of two errors, NaN if either is: `f64::max` drops a NaN, and a result that is NaN
/// would then read as exact.
///
/// # Examples
/// ```
/// use kinechain::measure::worse;
/// assert_eq!([1e-16, 3e-16, 2e-16].into_iter().fold(0.0, worse), 3e-16);
/// assert!([1e-16, f64::NAN, 2e-16].into_iter().fold(0.0, worse).is_nan());
/// assert_eq!([1e-16, f64::NAN].into_iter().fold(0.0, f64::max), 1e-16);
/// ```
#[must_use]
pub fn worse(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Times of several methods measured in alternation: round `r` runs every method once, each for
/// its own fixed number of calls (chosen so that a run lasts at least `min_run`), starting with a
/// different method each round. On a shared or virtual machine whose speed drifts, methods then
/// see the same conditions, and the ratio of two methods is taken within each round
/// ([`Interleaved::ratio`]) rather than between medians measured seconds apart.
#[derive(Clone, Debug)]
pub struct Interleaved {
    /// `ns[r][m]`: ns per call of method `m` in round `r`.
    ns: Vec<Vec<f64>>,
}

impl Interleaved {
    /// Runs `methods` (each a function timed per call) for `rounds` rounds.
    ///
    /// # Examples
    /// ```
    /// use std::time::Duration;
    /// let (mut a, mut b) = (0u64, 0u64);
    /// let t = kinechain::measure::Interleaved::run(
    ///     Duration::from_micros(200),
    ///     5,
    ///     &mut [
    ///         &mut || a = std::hint::black_box(a + 1),
    ///         &mut || for _ in 0..50 { b = std::hint::black_box(b + 1) },
    ///     ],
    /// );
    /// assert!(t.median(0) > 0.0 && t.ratio(1, 0) > 1.0);
    /// ```
    pub fn run(min_run: Duration, rounds: usize, methods: &mut [&mut dyn FnMut()]) -> Interleaved {
        let calls: Vec<u64> = methods.iter_mut().map(|f| calls_for(min_run, f)).collect();
        let m = methods.len();
        let ns = (0..rounds.max(1))
            .map(|r| {
                let mut row = vec![0.0; m];
                for i in 0..m {
                    let k = (r + i) % m;
                    let t = Instant::now();
                    for _ in 0..calls[k] {
                        (methods[k])();
                    }
                    row[k] = t.elapsed().as_nanos() as f64 / calls[k] as f64;
                }
                row
            })
            .collect();
        Interleaved { ns }
    }

    /// The times per item when a call of method `m` handles `items[m]` items (configurations,
    /// say): [`Interleaved::median`] then gives ns per item, and [`Interleaved::ratio`] compares
    /// methods per item.
    ///
    /// # Panics
    /// If `items` is shorter than the number of methods.
    #[must_use]
    pub fn per_item(mut self, items: &[usize]) -> Interleaved {
        for row in &mut self.ns {
            assert!(items.len() >= row.len(), "items for {} methods", row.len());
            for (t, &n) in row.iter_mut().zip(items) {
                *t /= n.max(1) as f64;
            }
        }
        self
    }

    /// Median over the rounds of method `m`'s ns per call.
    #[must_use]
    pub fn median(&self, m: usize) -> f64 {
        median(self.ns.iter().map(|row| row[m]).collect())
    }

    /// Median over the rounds of `time(over) / time(m)`: how many times faster `m` ran than
    /// `over` in the same rounds.
    #[must_use]
    pub fn ratio(&self, over: usize, m: usize) -> f64 {
        median(self.ns.iter().map(|row| row[over] / row[m]).collect())
    }
}

/// The middle value (the upper one of an even count).
fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs[xs.len() / 2]
}

/// Calls of `f` per run: doubled until a run lasts at least `min_run`.
fn calls_for(min_run: Duration, f: &mut dyn FnMut()) -> u64 {
    let mut calls = 1u64;
    loop {
        let t = Instant::now();
        for _ in 0..calls {
            f();
        }
        if t.elapsed() >= min_run {
            return calls;
        }
        calls *= 2;
    }
}

/// Time of one call of `f` in ns: the number of calls per run is doubled until a run lasts at
/// least `min_run`, then the median of `runs` such runs is returned (the median resists the
/// outliers of a shared machine).
pub fn time_per_call(min_run: Duration, runs: usize, mut f: impl FnMut()) -> f64 {
    Interleaved::run(min_run, runs, &mut [&mut f]).median(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn per_item_times_and_ratios() {
        // Two methods, three rounds; method 1 handles 4 items per call.
        let t = Interleaved {
            ns: vec![vec![10.0, 80.0], vec![12.0, 40.0], vec![30.0, 60.0]],
        };
        assert_eq!(t.median(1), 60.0);
        assert_eq!(t.ratio(0, 1), 0.3);
        let t = t.per_item(&[1, 4]);
        assert_eq!(t.median(0), 12.0);
        assert_eq!(t.median(1), 15.0);
        // Per round 10/20, 12/10, 30/15: the median ratio is the middle one.
        assert_eq!(t.ratio(0, 1), 1.2);
    }
}
