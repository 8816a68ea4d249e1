//! Random configurations: every entry uniform within its joint's limits, a floating joint's
//! position uniform in a box and its orientation a uniformly random rotation. Seeded, and the
//! same on every platform.

use crate::eval::layout::chain::Chain;
use crate::model::joint::JointKind;
use std::f64::consts::{PI, TAU};

/// SplitMix64: a small, fast, seedable generator (reproducible across platforms).
pub(crate) struct SplitMix(pub(crate) u64);

impl SplitMix {
    /// Uniform in `[0, 1)`.
    pub(crate) fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A uniformly random unit quaternion (w, x, y, z), from three uniform numbers (Shoemake's
    /// method: uniform over the rotations).
    pub(crate) fn unit_quaternion(&mut self) -> [f64; 4] {
        let (u1, u2, u3) = (self.unit(), self.unit(), self.unit());
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        let (s2, c2) = (TAU * u2).sin_cos();
        let (s3, c3) = (TAU * u3).sin_cos();
        [a * s2, a * c2, b * s3, b * c3]
    }
}

/// The point a fraction `u` of the way from `lo` to `hi`. When `hi − lo` overflows (limits such
/// as ±10³⁰⁸), as a weighted mean, which stays within the two; otherwise `lo + (hi − lo) u`.
pub(crate) fn between(lo: f64, hi: f64, u: f64) -> f64 {
    let span = hi - lo;
    if span.is_finite() {
        lo + span * u
    } else {
        (lo * (1.0 - u) + hi * u).clamp(lo, hi)
    }
}

/// The range a coordinate is drawn from: its limits, the 2π beside a single finite bound, or
/// `[−π, π]` without one.
pub(crate) fn range(lower: f64, upper: f64) -> (f64, f64) {
    match (lower.is_finite(), upper.is_finite()) {
        (true, true) => (lower, upper),
        (true, false) => (lower, lower + TAU),
        (false, true) => (upper - TAU, upper),
        (false, false) => (-PI, PI),
    }
}

impl Chain {
    /// `n` random configurations, row-major (`n · nq` entries), the same for the same `seed`:
    /// each joint coordinate uniform within its limits ([`range`]: `[−π, π]` without limits, the
    /// 2π beside a single bound), a floating joint's position uniform in `[base.0, base.1]` along
    /// each axis and its orientation, like a ball joint's, a uniformly random rotation (a unit
    /// quaternion).
    ///
    /// # Examples
    /// ```
    /// use kinechain::{Chain, LimitPolicy, check_q, io::LoadOptions};
    /// let chain = Chain::from_file_with("robots/ur5.yaml", &LoadOptions::default().with_floating_base(true))?;
    /// let qs = chain.random_configurations(100, 7, (-2.0, 2.0));
    /// assert_eq!(qs.len(), 100 * chain.nq());
    /// assert!(qs.chunks(chain.nq()).all(|q| check_q(&chain, q, LimitPolicy::Enforce).is_ok()));
    /// assert_eq!(qs, chain.random_configurations(100, 7, (-2.0, 2.0)));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn random_configurations(&self, n: usize, seed: u64, base: (f64, f64)) -> Vec<f64> {
        let mut rng = SplitMix(seed);
        let nq = self.nq();
        let mut qs = vec![0.0; n * nq];
        for q in qs.chunks_exact_mut(nq.max(1)) {
            for j in self.joints() {
                let Some(first) = j.q_index() else { continue };
                if j.kind() == JointKind::Floating {
                    for x in &mut q[first..first + 3] {
                        *x = between(base.0, base.1, rng.unit());
                    }
                    q[first + 3..first + 7].copy_from_slice(&rng.unit_quaternion());
                    continue;
                }
                if j.kind() == JointKind::Ball {
                    q[first..first + 4].copy_from_slice(&rng.unit_quaternion());
                    continue;
                }
                for (k, l) in j.limits().iter().enumerate() {
                    let (lower, upper) = l.map_or((f64::NAN, f64::NAN), |l| (l.lower, l.upper));
                    let (lo, hi) = range(lower, upper);
                    q[first + k] = between(lo, hi, rng.unit());
                }
            }
        }
        qs
    }
}
