//! The chain as the kernels evaluate it: a validated [`Model`] and its kernel-ready form.
//! [`ChainBuilder::build`](crate::ChainBuilder::build) makes one (`crate::eval::compile`).

use crate::eval::error::StateError;
use crate::eval::layout::body::{Body, Carrier, ThetaGather};
use crate::eval::layout::limits::{DenseLimits, LimitCheck};
use crate::model::chain::{JointId, JointScrew, LinkId, Model};
use crate::model::joint::JointKind;
use nalgebra::{Unit, Vector3};

/// An immutable, validated kinematic chain (or tree), laid out for evaluation.
///
/// Build one from a file with [`Chain::from_file`], from text with
/// [`Chain::from_dh_yaml_str`] / [`Chain::from_urdf_str`], or programmatically with
/// [`ChainBuilder`](crate::ChainBuilder). Evaluate it with the free functions of the crate root
/// ([`forward_kinematics`](crate::forward_kinematics) and its siblings) into a
/// [`Data`](crate::Data) buffer. Its joints, links and names are those of its
/// [`Model`], to which it dereferences.
#[derive(Clone, Debug)]
pub struct Chain {
    pub(crate) model: Model,
    pub(crate) bodies: Vec<Body>,
    /// θ of the bodies, [`LANES`](crate::eval::simd::lanes::LANES) at a time.
    pub(crate) theta_gather: Vec<ThetaGather>,
    /// Each body's entry in the sines and cosines `theta_gather` yields (0 for a constant θ).
    pub(crate) trig_slot: Vec<usize>,
    /// `turning_before[k]`: the number of bodies before body `k` whose θ varies (`k` up to the
    /// number of bodies).
    pub(crate) turning_before: Vec<usize>,
    /// For each entry `i` of `q`, the first body whose θ or d reads entry `i` or a later one
    /// (`usize::MAX` if none): when entry `i` is the first to change, no body before this one
    /// moves.
    pub(crate) first_body_from: Vec<usize>,
    pub(crate) limit_checks: Vec<LimitCheck>,
    /// `limit_checks` by entry of `q`, when no entry has two different ones.
    pub(crate) dense_limits: Option<DenseLimits>,
    /// The number of leading bodies that form a serial chain (body `k` hangs from `k − 1`):
    /// the part of any body's path that needs no index list.
    pub(crate) serial_run: usize,
    /// The first body from which the bodies to the end are few enough for the scalar update of
    /// the last bodies (`single::kinematics::poses_tail`): at most four, of which at most two turn. A
    /// body index `k` qualifies exactly when `k ≥ tail_start` (both counts shrink as `k` grows).
    pub(crate) tail_start: usize,
    /// Each link's body (`None` for a link fixed to the world) and its constant placement in
    /// that body's frame, by link index.
    pub(crate) carriers: Vec<Carrier>,
    pub(crate) reach: f64,
    /// For each entry of `q`, the number of rate terms (θ or d of a body) that read it: the
    /// number of terms its Jacobian column can take (more than one for a mimicked joint).
    pub(crate) column_terms: Vec<usize>,
}

impl std::ops::Deref for Chain {
    type Target = Model;

    fn deref(&self) -> &Model {
        &self.model
    }
}

/// The span of `q` that the bodies from the world to one body read — from the first entry any of
/// them reads to the last (a robot's own entries, in a scene of many) — and the quaternions in
/// it: what a one-link evaluation reads and checks, so that a link of one robot in a scene of
/// many costs what it costs alone. Computed by [`Chain::path_reads`] into buffers sized once.
#[derive(Clone, Debug, Default)]
pub(crate) struct PathReads {
    /// The body they are for (`Some(None)`: a link fixed to the world; `None`: nothing yet).
    body: Option<Option<usize>>,
    /// The span's entries, in order.
    pub(crate) entries: Vec<usize>,
    pub(crate) quaternions: Vec<(JointId, usize)>,
    /// The span's limit columns four entries at a time, as [`DenseLimits::blocks`] gives them for
    /// all of `q` (when the chain has dense limits), for a check in vectors.
    pub(crate) columns: Vec<[[f64; 4]; 4]>,
    /// The span is all of `q` (a single robot's links mostly): the full checks apply.
    pub(crate) all: bool,
}

impl PathReads {
    /// Empty buffers with room for `chain`'s entries (filling them never allocates).
    pub(crate) fn new(chain: &Chain) -> PathReads {
        PathReads {
            body: None,
            entries: Vec::with_capacity(chain.nq()),
            quaternions: Vec::with_capacity(chain.quaternions().len()),
            columns: Vec::with_capacity(chain.nq().div_ceil(4)),
            all: false,
        }
    }
}

impl Chain {
    /// `reads` ← what the path from the world to `body` reads (unchanged if it holds that
    /// already).
    #[inline]
    pub(crate) fn path_reads(&self, body: Option<usize>, reads: &mut PathReads) {
        if reads.body != Some(body) {
            self.find_path_reads(body, reads);
        }
    }

    #[cold]
    #[inline(never)]
    fn find_path_reads(&self, body: Option<usize>, reads: &mut PathReads) {
        reads.entries.clear();
        reads.quaternions.clear();
        let (mut first, mut last) = (usize::MAX, 0);
        let mut k = body;
        while let Some(b) = k {
            for i in self.bodies[b].variables() {
                (first, last) = (first.min(i), last.max(i));
            }
            k = self.bodies[b].parent;
        }
        if first <= last {
            reads.entries.extend(first..=last);
        }
        reads.all = reads.entries.len() == self.nq();
        reads.quaternions.extend(
            self.quaternions()
                .iter()
                .filter(|(_, i)| (first..=last).contains(i)),
        );
        reads.columns.clear();
        for group in reads.entries.chunks(4) {
            let mut block = DenseLimits::FREE;
            if let Some(limits) = &self.dense_limits {
                for (k, &i) in group.iter().enumerate() {
                    let (scale, offset, lower, upper) = limits.entry(i);
                    (block[0][k], block[1][k], block[2][k], block[3][k]) =
                        (scale, offset, lower, upper);
                }
            }
            reads.columns.push(block);
        }
        reads.body = Some(body);
    }

    /// The validated model: joints, links, names, the layout of `q` (also reached through the
    /// chain itself, which dereferences to it).
    #[must_use]
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The body link `link` is fixed to (`None`: the world) and its placement in that body.
    #[inline]
    pub(crate) fn carrier(&self, link: LinkId) -> &Carrier {
        &self.carriers[link.0]
    }

    /// `path` ← the bodies from the base to `body` (base first; empty for `None`, a link fixed to
    /// the world). Reuses `path`'s allocation.
    pub(crate) fn body_path(&self, body: Option<usize>, path: &mut Vec<usize>) {
        path.clear();
        let mut k = body;
        while let Some(b) = k {
            path.push(b);
            k = self.bodies[b].parent;
        }
        path.reverse();
    }

    /// True when every moving joint hangs from the previous one (no branches).
    #[must_use]
    pub fn is_serial(&self) -> bool {
        self.serial_run == self.bodies.len()
    }

    /// An upper bound on the distance of any link origin from the world origin (m): the sum of
    /// the constant offsets along the longest path plus prismatic travel. Errors are reported
    /// relative to it.
    #[must_use]
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// The smallest value of each entry of `q` that the limit checks admit (`-∞` where none
    /// bounds it from below): the intersection of the joint's own limits and, mapped back
    /// through `θ = scale · q + offset`, those of every mimic joint that follows it. `nq`
    /// entries, in `q` order (a floating joint's unlimited).
    #[must_use]
    pub fn lower(&self) -> Vec<f64> {
        self.admitted_ranges().into_iter().map(|r| r.0).collect()
    }

    /// The largest value of each entry of `q` that the limit checks admit (`+∞` where none
    /// bounds it from above); see [`Chain::lower`].
    #[must_use]
    pub fn upper(&self) -> Vec<f64> {
        self.admitted_ranges().into_iter().map(|r| r.1).collect()
    }

    /// A configuration inside the limits: each entry is 0 where 0 is admitted, otherwise the
    /// middle of its admitted range (the finite bound where the other is infinite). An entry
    /// whose range is empty (a mimic joint's limits that its primary's cannot reach) is the
    /// middle of the empty range, which [`crate::check_q`] then refuses, naming the joint. A
    /// floating joint is at the origin, unturned (the quaternion 1, 0, 0, 0), and a ball joint unturned.
    #[must_use]
    pub fn neutral(&self) -> Vec<f64> {
        let mut q: Vec<f64> = self
            .admitted_ranges()
            .into_iter()
            .map(|(lo, hi)| {
                if lo <= 0.0 && 0.0 <= hi {
                    0.0
                } else if lo.is_finite() && hi.is_finite() {
                    lo + 0.5 * (hi - lo)
                } else if lo.is_finite() {
                    lo
                } else {
                    hi
                }
            })
            .collect();
        for &(_, first) in self.quaternions() {
            q[first] = 1.0;
        }
        q
    }

    /// `[lower, upper]` of each entry of `q`, bounds that pass the checks' own arithmetic.
    pub(crate) fn admitted_ranges(&self) -> Vec<(f64, f64)> {
        let mut ranges = vec![(f64::NEG_INFINITY, f64::INFINITY); self.nq()];
        for c in &self.limit_checks {
            let range = &mut ranges[c.index];
            if c.scale == 0.0 {
                if !c.limits.contains(c.offset) {
                    *range = (f64::INFINITY, f64::NEG_INFINITY);
                }
                continue;
            }
            let (a, b) = (
                (c.limits.lower - c.offset) / c.scale,
                (c.limits.upper - c.offset) / c.scale,
            );
            let (mut lo, mut hi) = if c.scale > 0.0 { (a, b) } else { (b, a) };
            // The division rounds: step inwards until the check itself admits the bound.
            for _ in 0..4 {
                if lo.is_finite() && !c.limits.contains(c.value(lo)) {
                    lo = lo.next_up();
                }
                if hi.is_finite() && !c.limits.contains(c.value(hi)) {
                    hi = hi.next_down();
                }
            }
            range.0 = range.0.max(lo);
            range.1 = range.1.min(hi);
        }
        ranges
    }

    /// Number of moving joints after folding fixed joints away.
    #[must_use]
    pub fn moving_joint_count(&self) -> usize {
        self.bodies.len()
    }

    /// θ, d and their rates for one joint at `(q, q_dot, q_ddot)`, from which its relative 4×4
    /// transform and derivatives follow (eqs. 2.119, 2.122, 2.127). A fixed joint has constant θ
    /// and d; a mimic joint follows its primary.
    ///
    /// # Errors
    /// [`StateError::WrongLength`] if `q` does not have [`Model::nq`] entries or a rate
    /// [`Model::nv`]; [`StateError::NoScrew`] for a floating or ball joint.
    ///
    /// # Panics
    /// If `joint` comes from another chain with more joints.
    pub fn joint_screw(
        &self,
        joint: JointId,
        q: &[f64],
        q_dot: &[f64],
        q_ddot: &[f64],
    ) -> Result<JointScrew, StateError> {
        for (what, v, n) in [
            ("q", q, self.nq()),
            ("q_dot", q_dot, self.nv()),
            ("q_ddot", q_ddot, self.nv()),
        ] {
            if v.len() != n {
                return Err(StateError::WrongLength {
                    what,
                    expected: n,
                    got: v.len(),
                });
            }
        }
        let j = &self.joints[joint.0];
        // The entries of `q` and of `q̇` the joint's coordinates come from (its own, or its
        // primary's for a mimic joint), with the mimic relation.
        let of = |k: &crate::model::chain::Joint| k.q_index.zip(k.v_index);
        let source = match j.mimic {
            None => of(j).map(|(i, v)| (i, v, 1.0, 0.0)),
            Some(m) => of(&self.joints[m.primary.0]).map(|(i, v)| (i, v, m.multiplier, m.offset)),
        };
        let coordinate = |k: usize| match source {
            Some((i, v, m, o)) => (m * q[i + k] + o, m * q_dot[v + k], m * q_ddot[v + k]),
            None => (0.0, 0.0, 0.0),
        };
        let (rot, slide) = match j.kind {
            JointKind::Revolute | JointKind::Continuous => (coordinate(0), (0.0, 0.0, 0.0)),
            JointKind::Prismatic => ((0.0, 0.0, 0.0), coordinate(0)),
            JointKind::Cylindrical => (coordinate(0), coordinate(1)),
            JointKind::Fixed => ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
            JointKind::Floating | JointKind::Ball => {
                return Err(StateError::NoScrew {
                    joint: j.name.clone(),
                });
            }
        };
        Ok(JointScrew {
            axis: Unit::new_unchecked(Vector3::from(j.axis)),
            theta: rot.0 + j.theta0,
            d: slide.0 + j.d0,
            theta_dot: rot.1,
            d_dot: slide.1,
            theta_ddot: rot.2,
            d_ddot: slide.2,
        })
    }
}
