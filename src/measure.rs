//! Seeded joint configurations and wall-clock timing: what `kinechain bench` and the project's
//! benchmarks use, so that every figure they print is measured the same way (and so that a user
//! timing their own code can do likewise).

use crate::eval::Chain;
use std::time::{Duration, Instant};

pub(crate) use crate::eval::sampling::{SplitMix, between};

/// `n` configurations drawn uniformly within the joint limits, the same for the same `seed`
/// ([`Chain::random_configurations`], a floating base within a metre of the origin). An entry
/// without limits is drawn from `[−π, π]`, one with only a finite lower (upper) limit from the
/// 2π above (below) it.
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
    if chain.nq() == 0 {
        return vec![Vec::new(); n];
    }
    chain
        .random_configurations(n, seed, (-1.0, 1.0))
        .chunks(chain.nq())
        .map(<[f64]>::to_vec)
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
    ///
    /// # Panics
    /// If `m` is not the index of a method.
    #[must_use]
    pub fn median(&self, m: usize) -> f64 {
        median(self.ns.iter().map(|row| row[m]).collect())
    }

    /// Median over the rounds of `time(over) / time(m)`: how many times faster `m` ran than
    /// `over` in the same rounds.
    ///
    /// # Panics
    /// If `over` or `m` is not the index of a method.
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
    use std::f64::consts::{PI, TAU};

    #[test]
    fn the_generator_is_splitmix64() {
        // The first outputs of SplitMix64 from state 0 (Vigna's reference implementation),
        // as the 53 high bits over 2^53.
        let mut g = SplitMix(0);
        for want in [
            0xE220_A839_7B1D_CDAF_u64,
            0x6E78_9E6A_A1B9_65F4,
            0x06C4_5D18_8009_454F,
        ] {
            assert_eq!(g.unit(), (want >> 11) as f64 / (1u64 << 53) as f64);
        }
    }

    #[test]
    fn configurations_fill_the_limits_and_a_turn_where_they_are_open() {
        use crate::model::builder::{ChainBuilder, JointSpec};
        use crate::model::joint::JointKind;
        // Finite limits, none (a continuous joint), limits that are not both finite, and a
        // cylindrical joint's two entries.
        let mut b = ChainBuilder::new("five");
        b.link("l0")
            .link("l1")
            .link("l2")
            .link("l3")
            .link("l4")
            .link("l5");
        let joint = |name: &str, kind, parent: &str, child: &str| {
            JointSpec::new(name, kind, parent, child).with_axis([0.0, 0.0, 1.0])
        };
        b.joint(joint("limited", JointKind::Revolute, "l0", "l1").with_limits(-0.5, 2.0));
        b.joint(joint("free", JointKind::Continuous, "l1", "l2"));
        b.joint(joint("open", JointKind::Revolute, "l2", "l3").with_limits(0.0, f64::INFINITY));
        b.joint(joint("wide", JointKind::Revolute, "l3", "l4").with_limits(-f64::INFINITY, 1.0));
        let mut sleeve = joint("sleeve", JointKind::Cylindrical, "l4", "l5");
        sleeve.limits = [
            None,
            Some(crate::model::joint::Limits {
                lower: 0.1,
                upper: 0.3,
            }),
        ];
        b.joint(sleeve);
        let chain = b.build().unwrap();
        let qs = configurations(&chain, 4000, 7);
        let want = [
            (-0.5, 2.0),
            (-PI, PI),
            (0.0, TAU),
            (1.0 - TAU, 1.0),
            (-PI, PI),
            (0.1, 0.3),
        ];
        assert_eq!(chain.dof(), want.len());
        for (k, (lo, hi)) in want.into_iter().enumerate() {
            let x: Vec<f64> = qs.iter().map(|q| q[k]).collect();
            assert!(x.iter().all(|&x| (lo..=hi).contains(&x)), "entry {k}");
            // Uniform: the extremes come close to the limits, and the mean to the middle
            // (its standard deviation is (hi - lo) / √(12 · 4000) ≈ 0.005 (hi - lo)).
            let (min, max) = x.iter().fold((hi, lo), |(a, b), &x| (a.min(x), b.max(x)));
            assert!(
                min - lo < 0.01 * (hi - lo) && hi - max < 0.01 * (hi - lo),
                "entry {k}"
            );
            let mean = x.iter().sum::<f64>() / x.len() as f64;
            assert!(
                (mean - (lo + hi) / 2.0).abs() < 0.025 * (hi - lo),
                "entry {k}: {mean}"
            );
        }
    }

    /// Limits wider apart than `f64` can subtract (a slide between ±10³⁰⁸ m) still give
    /// configurations within them, spread over both signs. (Before, `hi − lo` overflowed and every
    /// entry was infinite, which `kinechain bench` then refused.)
    #[test]
    fn configurations_within_limits_too_far_apart_to_subtract() {
        use crate::model::builder::{ChainBuilder, JointSpec};
        use crate::model::joint::JointKind;
        let mut b = ChainBuilder::new("far");
        b.link("l0").link("l1");
        b.joint(
            JointSpec::new("slide", JointKind::Prismatic, "l0", "l1")
                .with_axis([0.0, 0.0, 1.0])
                .with_limits(-1e308, 1e308),
        );
        let chain = b.build().unwrap();
        let x: Vec<f64> = configurations(&chain, 1000, 3)
            .iter()
            .map(|q| q[0])
            .collect();
        assert!(x.iter().all(|x| (-1e308..=1e308).contains(x)));
        assert!(x.iter().any(|&x| x < -1e307) && x.iter().any(|&x| x > 1e307));
        assert_eq!(between(-1e308, 1e308, 0.0), -1e308);
        assert_eq!(between(-1e308, 1e308, 0.5), 0.0);
        assert_eq!(between(-0.5, 2.0, 0.5), 0.75);
    }

    /// Round `r` starts with method `r mod m`, and every method runs once per round (with a
    /// minimum run of zero, one call is enough).
    #[test]
    fn the_methods_take_turns_starting_a_round() {
        let order = std::cell::RefCell::new(Vec::new());
        let (mut a, mut b, mut c) = (
            || order.borrow_mut().push(0),
            || order.borrow_mut().push(1),
            || order.borrow_mut().push(2),
        );
        let t = Interleaved::run(Duration::ZERO, 4, &mut [&mut a, &mut b, &mut c]);
        assert_eq!(t.ns.len(), 4);
        // One call of each to choose the number of calls, then the rounds.
        let order = order.into_inner();
        assert_eq!(order, [0, 1, 2, 0, 1, 2, 1, 2, 0, 2, 0, 1, 0, 1, 2]);
    }

    #[test]
    fn worse_keeps_a_nan_from_either_side() {
        assert!(worse(f64::NAN, 1.0).is_nan() && worse(1.0, f64::NAN).is_nan());
        assert_eq!((worse(1.0, 2.0), worse(2.0, 1.0)), (2.0, 2.0));
    }

    #[test]
    fn the_median_is_the_middle_value() {
        assert_eq!(median(vec![5.0, 1.0, 4.0, 2.0, 3.0]), 3.0);
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 3.0);
    }

    /// A method that takes at least 20 µs per call is timed at that or a little more, and runs
    /// often enough to fill the minimum run. The upper bound is 50 times the spin, far above
    /// what a loaded machine adds and far below a time not divided by the number of calls.
    #[test]
    fn a_call_is_timed_per_call_over_runs_of_the_minimum_length() {
        const SPIN: Duration = Duration::from_micros(20);
        fn spin() {
            let t = Instant::now();
            while t.elapsed() < SPIN {}
        }
        let mut calls = 0u64;
        let mut counted = || {
            calls += 1;
            spin();
        };
        let t = Interleaved::run(Duration::from_millis(2), 3, &mut [&mut counted]);
        let spin_ns = SPIN.as_nanos() as f64;
        assert!(
            (spin_ns..50.0 * spin_ns).contains(&t.median(0)),
            "{}",
            t.median(0)
        );
        // At least the 2 ms run of each of the three rounds.
        assert!(calls >= 3 * 100, "{calls}");
        let per_call = time_per_call(Duration::from_millis(2), 3, spin);
        assert!((spin_ns..50.0 * spin_ns).contains(&per_call), "{per_call}");
    }

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
