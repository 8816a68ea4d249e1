//! The single-configuration workspace [`Data`]: one chain's frames, rates and sines, sized once.

use crate::eval::checks::{LimitPolicy, assert_buffers_match};
use crate::eval::layout::chain::Chain;
use crate::eval::layout::stored::Rates;
use crate::eval::simd::lanes::{LANES, Lanes};
use crate::model::transform::Transform;

/// The workspace for evaluating one [`Chain`]: per moving joint, the pose of its frame and, when
/// asked for, its velocity and acceleration. Created once with [`Data::new`]; evaluations then
/// allocate nothing.
///
/// A `Data` belongs to the chain it was created from; passing it with another chain is a
/// programming error and panics.
#[derive(Clone, Debug)]
pub struct Data {
    /// Padded columns (see [`crate::eval::padded`]).
    pub(crate) world_from_body: Vec<crate::eval::layout::stored::Stored>,
    /// ω, origin velocity, α and classical origin acceleration of each body (world frame).
    pub(crate) rates: Vec<Rates>,
    /// `sin θ` and `cos θ` of each body's joint, computed before the pass along the chain, in
    /// whole vectors of lanes (read as one run of `f64` through [`Lanes::flat`]): aligned to their
    /// size, so that the vectorised stores never straddle a cache line or a page, wherever the
    /// allocator puts them.
    pub(crate) sin: Vec<Lanes>,
    pub(crate) cos: Vec<Lanes>,
    /// Scratch: bodies on the path to a queried link, or dirty flags of an incremental update.
    pub(crate) path: Vec<usize>,
    /// What the path to the link of the last one-link evaluation reads of `q`.
    pub(crate) reads: crate::eval::layout::chain::PathReads,
    pub(crate) dirty: Vec<bool>,
    /// Joint positions of the last full evaluation, for incremental updates.
    pub(crate) last_q: Vec<f64>,
    /// True when `world_from_body` holds every body at `last_q`.
    pub(crate) poses_valid: bool,
    pub(crate) limit_policy: LimitPolicy,
    dof: usize,
}

impl Data {
    /// Buffers for `chain`.
    #[must_use]
    pub fn new(chain: &Chain) -> Self {
        let n = chain.bodies.len();
        // Whole chunks of lanes, at least one (constant-θ bodies read slot 0).
        let trig = chain.theta_gather.len().max(1);
        Data {
            world_from_body: vec![crate::eval::layout::stored::stored(&Transform::IDENTITY); n],
            rates: vec![Rates::ZERO; n],
            sin: vec![Lanes([0.0; LANES]); trig],
            cos: vec![Lanes([1.0; LANES]); trig],
            path: Vec::with_capacity(n),
            reads: crate::eval::layout::chain::PathReads::new(chain),
            dirty: vec![true; n],
            last_q: vec![0.0; chain.nq()],
            poses_valid: false,
            limit_policy: LimitPolicy::Enforce,
            dof: chain.nq(),
        }
    }

    /// These buffers, with evaluations checking joint limits under `policy` (as
    /// [`Data::set_limit_policy`] sets it), in one expression:
    /// `Data::new(&chain).with_limit_policy(LimitPolicy::Ignore)`.
    #[must_use]
    pub fn with_limit_policy(mut self, policy: LimitPolicy) -> Self {
        self.set_limit_policy(policy);
        self
    }

    /// Chooses whether evaluations check joint limits (default [`LimitPolicy::Enforce`]).
    pub fn set_limit_policy(&mut self, policy: LimitPolicy) {
        if policy != self.limit_policy {
            // The last evaluation's joint values were checked under the other policy.
            self.poses_valid = false;
        }
        self.limit_policy = policy;
    }

    /// The limit policy in force.
    #[must_use]
    pub fn limit_policy(&self) -> LimitPolicy {
        self.limit_policy
    }

    pub(crate) fn assert_matches(&self, chain: &Chain) {
        assert_buffers_match("Data", self.world_from_body.len(), self.dof, chain);
    }
}
