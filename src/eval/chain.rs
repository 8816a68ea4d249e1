//! The chain as the kernels evaluate it: a validated [`Model`] and its kernel-ready form
//! (`eval::layout`). [`ChainBuilder::build`] makes one.

use crate::eval::error::StateError;
use crate::eval::layout::{
    Assembled, Body, Carrier, DenseLimits, EvalTables, LimitCheck, ThetaGather, assemble,
};
use crate::model::builder::ChainBuilder;
use crate::model::chain::{JointId, JointScrew, LinkId, Model, validate};
use crate::model::error::ModelError;
use crate::model::joint::JointKind;
use nalgebra::{Unit, Vector3};

/// An immutable, validated kinematic chain (or tree), laid out for evaluation.
///
/// Build one from a file with [`Chain::from_file`], from text with
/// [`Chain::from_dh_yaml_str`] / [`Chain::from_urdf_str`], or programmatically with
/// [`ChainBuilder`]. Evaluate it with the free functions of [`crate::eval::kinematics`] into a
/// [`Data`](crate::eval::data::Data) buffer. Its joints, links and names are those of its
/// [`Model`], to which it dereferences.
#[derive(Clone, Debug)]
pub struct Chain {
    model: Model,
    pub(crate) bodies: Vec<Body>,
    /// θ of the bodies, [`LANES`](crate::eval::kernel::LANES) at a time.
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
    /// the last bodies (`kinematics::poses_tail`): at most four, of which at most two turn. A
    /// body index `k` qualifies exactly when `k ≥ tail_start` (both counts shrink as `k` grows).
    pub(crate) tail_start: usize,
    /// Each link's body (`None` for a link fixed to the world) and its constant placement in
    /// that body's frame, by link index.
    carriers: Vec<Carrier>,
    reach: f64,
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

impl Chain {
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
    /// through `θ = scale · q + offset`, those of every mimic joint that follows it. `dof`
    /// entries, in `q` order.
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
    /// middle of the empty range, which [`crate::check_q`] then refuses, naming the joint.
    #[must_use]
    pub fn neutral(&self) -> Vec<f64> {
        self.admitted_ranges()
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
            .collect()
    }

    /// `[lower, upper]` of each entry of `q`, bounds that pass the checks' own arithmetic.
    fn admitted_ranges(&self) -> Vec<(f64, f64)> {
        let mut ranges = vec![(f64::NEG_INFINITY, f64::INFINITY); self.dof()];
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
    /// [`StateError::WrongLength`] if a vector does not have [`Chain::dof`](crate::Model::dof) entries.
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
        for (what, v) in [("q", q), ("q_dot", q_dot), ("q_ddot", q_ddot)] {
            if v.len() != self.dof() {
                return Err(StateError::WrongLength {
                    what,
                    expected: self.dof(),
                    got: v.len(),
                });
            }
        }
        let j = &self.joints[joint.0];
        let source = self.coordinate_source(joint);
        let coordinate = |k: usize| match source {
            Some((i, m, o)) => (m * q[i + k] + o, m * q_dot[i + k], m * q_ddot[i + k]),
            None => (0.0, 0.0, 0.0),
        };
        let (rot, slide) = match j.kind {
            JointKind::Revolute | JointKind::Continuous => (coordinate(0), (0.0, 0.0, 0.0)),
            JointKind::Prismatic => ((0.0, 0.0, 0.0), coordinate(0)),
            JointKind::Cylindrical => (coordinate(0), coordinate(1)),
            JointKind::Fixed => ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
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

impl ChainBuilder {
    /// Validates the model and compiles it.
    ///
    /// # Errors
    /// [`ModelError`] naming the joint or link at fault: duplicate or empty names, a joint
    /// referring to a missing link, a link with two parents, several roots, a cycle, a mimic
    /// joint referring to a missing joint or forming a cycle, a zero axis, a non-finite number,
    /// reversed limits, a placement that is not rigid.
    pub fn build(&self) -> Result<Chain, ModelError> {
        let mut chain = build(self)?;
        chain.model.source = self.clone();
        Ok(chain)
    }

    /// [`ChainBuilder::build`] keeping this description in the chain rather than a copy of it
    /// (the loaders': a load then holds one description at a time), without the room its lists
    /// grew while it was read. On an error, the description comes back with it.
    pub(crate) fn into_chain(mut self) -> Result<Chain, Box<(ModelError, ChainBuilder)>> {
        self.links.shrink_to_fit();
        self.joints.shrink_to_fit();
        match build(&self) {
            Ok(mut chain) => {
                chain.model.source = self;
                Ok(chain)
            }
            Err(e) => Err(Box::new((e, self))),
        }
    }
}

/// Validates `spec` and lays it out for evaluation. The model's description is left empty for
/// the caller to fill (with `spec` itself or a copy).
fn build(spec: &ChainBuilder) -> Result<Chain, ModelError> {
    let v = validate(spec)?;
    let Assembled {
        bodies,
        link_carrier,
        reach,
        limit_checks,
    } = assemble(spec, &v.tree, &v.axes, &v.q_index, &v.mimic, &v.new_joint);
    let dof = v.model.dof();
    let EvalTables {
        theta_gather,
        trig_slot,
        turning_before,
        first_body_from,
        serial_run,
        tail_start,
    } = EvalTables::new(&bodies, dof);
    let carriers = v
        .tree
        .link_order
        .iter()
        .map(|&l| Carrier {
            body: link_carrier[l].0,
            offset: link_carrier[l].1,
        })
        .collect();
    let mut column_terms = vec![0_usize; dof];
    for t in bodies.iter().flat_map(|b| [b.theta_rate, b.d_rate]) {
        if t.scale != 0.0 {
            column_terms[t.index] += 1;
        }
    }
    Ok(Chain {
        column_terms,
        model: v.model,
        bodies,
        theta_gather,
        trig_slot,
        turning_before,
        first_body_from,
        dense_limits: DenseLimits::new(&limit_checks, dof),
        limit_checks,
        serial_run,
        tail_start,
        carriers,
        reach,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::layout::Placement;
    use crate::model::builder::JointSpec;
    use crate::model::joint::Term;
    use crate::model::transform::Transform;

    #[test]
    // 1.57079632679: the rounded π/2 that URDF files write (not a quarter turn to the last bit).
    #[allow(clippy::approx_constant)]
    fn placement_forms_are_recognised_exactly_and_round_trip() {
        let (c, s) = (0.3_f64.cos(), 0.3_f64.sin());
        let cases = [
            (Transform::IDENTITY, "Identity"),
            (
                Transform::from_xyz_rpy([0.1, 0.2, 0.3], [0.0; 3]),
                "Translation",
            ),
            (
                Transform::from_xyz_rpy([0.4, 0.0, 0.0], [0.3, 0.0, 0.0]),
                "ScrewX",
            ),
            (
                Transform::from_xyz_rpy([0.0, -0.316, 0.0], [0.3, 0.0, 0.0]),
                "OffsetRot { t: [0.0, -0.316, 0.0], axis: 0",
            ),
            (
                Transform::from_xyz_rpy([0.0, 0.13585, 0.0], [0.0, 1.57079632679, 0.0]),
                "OffsetRot { t: [0.0, 0.13585, 0.0], axis: 1",
            ),
            (
                Transform::from_xyz_rpy([0.0, 0.0, 0.1], [0.0, 0.0, -0.3]),
                "OffsetRot { t: [0.0, 0.0, 0.1], axis: 2",
            ),
            (
                Transform::from_xyz_rpy([0.0, 0.0, 0.1], [0.0, 0.2, 0.3]),
                "General",
            ),
            (
                Transform::from_xyz_rpy([0.0; 3], [-1.57079632679, 0.0, -1.57079632679]),
                "General",
            ),
        ];
        for (t, kind) in cases {
            let p = Placement::from_transform(&t);
            assert!(format!("{p:?}").starts_with(kind), "{p:?} for {kind}");
            assert_eq!(p.to_transform(), t, "{kind}");
        }
        for axis in 0..3 {
            let p = Placement::OffsetRot {
                t: [1.0, 2.0, 3.0],
                axis,
                c,
                s,
            };
            assert_eq!(Placement::from_transform(&p.to_transform()), p);
        }
    }

    #[test]
    fn serial_chains_are_told_from_trees() {
        // Serial: every body hangs from the one before it (fixed tools and flanges folded).
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("robots");
        let reference = root.join("../tests/data/reference/urdf");
        for (chain, serial) in [
            (Chain::from_file(root.join("ur5.yaml")).unwrap(), true),
            (Chain::from_file(root.join("panda_mdh.yaml")).unwrap(), true),
            (Chain::from_file(reference.join("ur5.urdf")).unwrap(), true),
            // The second finger hangs from the hand, as the first does.
            (Chain::from_file(root.join("panda.urdf")).unwrap(), false),
            (
                Chain::from_file(reference.join("tiago_no_hand.urdf")).unwrap(),
                false,
            ),
        ] {
            assert_eq!(chain.is_serial(), serial, "{}", chain.name());
            let each = (0..chain.bodies.len()).all(|k| chain.bodies[k].parent == k.checked_sub(1));
            assert_eq!(chain.is_serial(), each, "{}", chain.name());
        }
    }

    #[test]
    fn bodies_take_the_shape_codes() {
        // Standard DH rows, and the Panda's URDF origins (rpy = (±π/2, 0, 0)): every arm joint is
        // evaluated in place without dispatch; the fingers, after the hand's fixed frame turned
        // about z, in place with dispatch on kinds.
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("robots");
        let coded = |b: &Body| b.pre_steps.is_some() && b.z_tail.is_some();
        let ur5 = Chain::from_file(root.join("ur5.yaml")).unwrap();
        assert!(ur5.bodies.iter().all(coded));
        let panda = Chain::from_file(root.join("panda.urdf")).unwrap();
        let shapes: Vec<bool> = panda.bodies.iter().map(coded).collect();
        assert_eq!(
            shapes,
            [true, true, true, true, true, true, true, false, false]
        );
        let general = |b: &Body| matches!(b.pre, Placement::General(_));
        assert!(!panda.bodies.iter().any(general));
        // The UR5's URDF origins turn about y (rpy = (0, 1.57079632679, 0)): a plane rotation
        // too. TIAGo's turn about two axes at once: general.
        let reference = root.join("../tests/data/reference/urdf");
        let ur5 = Chain::from_file(reference.join("ur5.urdf")).unwrap();
        assert!(!ur5.bodies.iter().any(general));
        let tiago = Chain::from_file(reference.join("tiago_no_hand.urdf")).unwrap();
        assert!(tiago.bodies.iter().any(general));
        // After a general origin (matched on its kind), a joint about z takes its steps from
        // shape codes: every joint of the SO-101, whose origins all turn about two or three axes.
        let so101 = Chain::from_file(reference.join("so101.urdf")).unwrap();
        assert!(
            so101
                .bodies
                .iter()
                .all(|b| general(b) && b.pre_steps.is_none() && b.z_tail.is_some())
        );
        // Seven sines for seven turning joints: one vector of lanes.
        assert_eq!(panda.theta_gather.len(), 1);
        // The flag the kernels test instead of the parent's index: set on every body whose
        // parent comes just before it, and on no other (the Panda's second finger hangs from the
        // hand like the first; TIAGo's tree branches too).
        for chain in [&panda, &ur5, &tiago] {
            for (k, body) in chain.bodies.iter().enumerate() {
                let previous = k.checked_sub(1).is_some_and(|p| body.parent == Some(p));
                assert_eq!(body.follows_previous, previous, "{} body {k}", chain.name());
            }
        }
        assert!(!panda.bodies[8].follows_previous && panda.bodies[7].follows_previous);
        // The frames read again by the finger that does not follow: the hand's only.
        for chain in [&panda, &ur5, &tiago] {
            for (k, body) in chain.bodies.iter().enumerate() {
                let read_again = chain.bodies[k + 1..]
                    .iter()
                    .any(|b| !b.follows_previous && b.parent == Some(k));
                assert_eq!(body.branches, read_again, "{} body {k}", chain.name());
            }
        }
        assert!(panda.bodies[6].branches && !panda.bodies[7].branches);
        assert!(
            tiago
                .bodies
                .iter()
                .any(|b| b.parent.is_some() && !b.follows_previous)
        );
        // The tables of the incremental update, against their definitions.
        for chain in [&panda, &ur5, &tiago] {
            let n = chain.bodies.len();
            for k in 0..=n {
                let few = n - k <= 4 && chain.turning_before[n] - chain.turning_before[k] <= 2;
                assert_eq!(k >= chain.tail_start, few, "{} body {k}", chain.name());
            }
            for (i, &first) in chain.first_body_from.iter().enumerate() {
                let reads = |b: &Body, j: usize| {
                    [b.motion.theta, b.motion.d]
                        .iter()
                        .any(|t| matches!(t, Term::Var { index, .. } if *index == j))
                };
                let want = (0..n)
                    .find(|&k| (i..chain.dof()).any(|j| reads(&chain.bodies[k], j)))
                    .unwrap_or(usize::MAX);
                assert_eq!(first, want, "{} entry {i}", chain.name());
            }
        }
        // On the Panda, moving the sixth or seventh arm joint updates a tail (their bodies and
        // the two fingers: four bodies, two turning); the fifth does not.
        assert_eq!(panda.tail_start, 5);
        assert_eq!(panda.first_body_from[6], 6);
    }

    #[test]
    fn z_tail_codes_give_the_kinds_of_theta_and_d() {
        use crate::eval::layout::ZTail as Z;
        // (kind, θ offset, d offset) and the (θ, d) kinds the code must give.
        let cases = [
            (JointKind::Revolute, 0.0, 0.0, (Z::VARIABLE, Z::ZERO)),
            (JointKind::Revolute, 0.0, 0.3, (Z::VARIABLE, Z::CONSTANT)),
            (JointKind::Prismatic, 0.2, 0.0, (Z::CONSTANT, Z::VARIABLE)),
            (JointKind::Prismatic, 0.0, 0.1, (Z::ZERO, Z::VARIABLE)),
            (JointKind::Cylindrical, 0.4, 0.0, (Z::VARIABLE, Z::VARIABLE)),
        ];
        let mut b = ChainBuilder::new("codes");
        b.link("l0");
        for (i, (kind, theta, d, _)) in cases.iter().enumerate() {
            b.link(format!("l{}", i + 1));
            b.joint(
                JointSpec::new(
                    format!("j{i}"),
                    *kind,
                    format!("l{i}"),
                    format!("l{}", i + 1),
                )
                .with_offsets(*theta, *d),
            );
        }
        let chain = b.build().unwrap();
        for (body, (kind, .., want)) in chain.bodies.iter().zip(cases) {
            let motion = body.z_tail.map(|z| z.motion);
            let got = motion.map(|m| (Z::theta_kind(m), Z::d_kind(m)));
            assert_eq!(got, Some(want), "{kind:?}");
        }
    }

    #[test]
    fn dense_limits_decide_as_the_checks_do() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("robots");
        let mimic_opposite = r#"<robot name="g"><link name="palm"/><link name="l"/><link name="r"/>
  <joint name="lf" type="prismatic"><parent link="palm"/><child link="l"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="1" velocity="1"/></joint>
  <joint name="rf" type="prismatic"><parent link="palm"/><child link="r"/><axis xyz="0 1 0"/>
    <limit lower="-0.04" upper="0" effort="1" velocity="1"/>
    <mimic joint="lf" multiplier="-1" offset="0.01"/></joint></robot>"#;
        let mimic_same = mimic_opposite
            .replace(r#"multiplier="-1" offset="0.01""#, "")
            .replace(r#"lower="-0.04" upper="0""#, r#"lower="0.01" upper="0.05""#);
        let chains = [
            (Chain::from_file(root.join("panda.urdf")).unwrap(), true),
            (
                Chain::from_file(root.join("cylindrical.yaml")).unwrap(),
                true,
            ),
            (Chain::from_file(root.join("ur5.yaml")).unwrap(), true),
            // Two checks of one entry with different scales: no columns, the checks are used.
            (Chain::from_urdf_str(mimic_opposite).unwrap(), false),
            // The same scale: one column, the intersection [0.01, 0.04].
            (Chain::from_urdf_str(&mimic_same).unwrap(), true),
        ];
        let slow = |chain: &Chain, q: &[f64]| {
            q.iter().all(|x| x.is_finite()) && chain.limit_checks.iter().all(|c| c.admits(q))
        };
        let values = [
            -7.0,
            -3.0718,
            -0.0698,
            -0.04,
            -0.0,
            0.0,
            0.005,
            0.01,
            0.03,
            0.04,
            0.0401,
            1.0,
            2.8973,
            3.7525,
            7.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for (chain, dense) in &chains {
            assert_eq!(chain.dense_limits.is_some(), *dense, "{}", chain.name());
            let Some(limits) = &chain.dense_limits else {
                continue;
            };
            let base = crate::measure::configurations(chain, 1, 3).remove(0);
            assert_eq!(
                crate::eval::kinematics::admitted::<crate::eval::arith::Separate>(
                    &base,
                    Some(limits)
                ),
                slow(chain, &base)
            );
            for i in 0..chain.dof() {
                for &x in &values {
                    let mut q = base.clone();
                    q[i] = x;
                    let want = slow(chain, &q);
                    assert_eq!(
                        crate::eval::kinematics::admitted::<crate::eval::arith::Separate>(
                            &q,
                            Some(limits)
                        ),
                        want,
                        "{} q[{i}] = {x}",
                        chain.name()
                    );
                    assert_eq!(limits.admits(i, x), want, "{} q[{i}] = {x}", chain.name());
                }
            }
        }
        let same = &chains[4].0;
        let limits = same.dense_limits.as_ref().unwrap();
        assert!(!limits.admits(0, 0.005) && limits.admits(0, 0.03) && !limits.admits(0, 0.045));
    }

    #[test]
    fn the_end_link_is_the_tip_whatever_the_file_declares_after_it() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        for (file, tip) in [
            // Declares `base` (fixed to `base_link`) after the arm: the last link in order.
            ("tests/data/reference/urdf/ur5.urdf", "tool0"),
            ("robots/panda.urdf", "panda_rightfinger"),
            ("robots/ur5.yaml", "tool0"),
            ("robots/planar3.yaml", "link3"),
        ] {
            let chain = Chain::from_file(root.join(file)).unwrap();
            assert_eq!(chain.link(chain.end_link()).name(), tip, "{file}");
        }
    }
}
