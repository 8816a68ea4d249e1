//! Compiling a [`ChainBuilder`] into a [`Chain`]: validation, one body per moving joint with the
//! fixed joints folded into its placements, the limit checks, and the lookup tables of the
//! evaluation paths.

use crate::eval::layout::body::{Ball, Body, Carrier, Placement, ThetaGather};
use crate::eval::layout::chain::Chain;
use crate::eval::layout::limits::{DenseLimits, LimitCheck};
use crate::eval::simd::portable::Separate;
use crate::model::builder::{ChainBuilder, JointSpec};
use crate::model::error::ModelError;
use crate::model::joint::{Axis, JointKind, Motion, Term};
use crate::model::transform::Transform;
use crate::model::validate::{Resolved, Tree, validate};

fn compose(a: Placement, b: Placement) -> Placement {
    match (a, b) {
        (Placement::Identity, b) => b,
        (a, Placement::Identity) => a,
        (a, b) => Placement::from_transform(&(a.to_transform() * b.to_transform())),
    }
}

fn norm(p: [f64; 3]) -> f64 {
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

/// The moving bodies of a chain, with what hangs from them.
pub(crate) struct Assembled {
    pub(crate) bodies: Vec<Body>,
    /// Each link's (body it is fixed to, `None` for the base; placement in that body's frame),
    /// in the builder's link indices.
    pub(crate) link_carrier: Vec<(Option<usize>, Placement)>,
    /// An upper bound on the distance of any link origin from the world origin ([`Chain::reach`](crate::eval::layout::chain::Chain::reach)).
    pub(crate) reach: f64,
    pub(crate) limit_checks: Vec<LimitCheck>,
}

/// One body per moving joint in depth-first order, fixed joints folded into the placement of
/// what follows them; each joint's limits as checks on entries of `q`.
pub(crate) fn assemble(
    spec: &ChainBuilder,
    tree: &Tree,
    axes: &[[f64; 3]],
    q_index: &[Option<usize>],
    mimic: &[Option<Resolved>],
    new_joint: &[usize],
) -> Assembled {
    // The entry of `q̇` of entry `i` of `q` (a one-coordinate entry): each quaternion joint
    // before it takes one entry of `q` more than of `q̇`.
    let quaternion_entries: Vec<usize> = tree
        .joint_order
        .iter()
        .filter_map(|&j| {
            let kind = spec.joints[j].kind;
            Some(q_index[j]? + kind.quaternion()?)
        })
        .collect();
    let v_of_q = |i: usize| i - quaternion_entries.iter().filter(|&&e| e < i).count();
    let root = tree.root;
    let base = crate::model::validate::floating_base(spec, tree);
    let mut link_carrier: Vec<(Option<usize>, Placement)> =
        vec![(None, Placement::Identity); spec.links.len()];
    link_carrier[root] = (
        None,
        Placement::from_transform(&spec.world_from_root.unwrap_or(Transform::IDENTITY)),
    );
    let mut reach_of = vec![0.0; spec.links.len()];
    reach_of[root] = norm(spec.world_from_root.unwrap_or(Transform::IDENTITY).p);
    let mut bodies = Vec::new();
    let mut limit_checks = Vec::new();
    for &j in &tree.joint_order {
        let js = &spec.joints[j];
        let (parent, child) = tree.ends[j];
        let (carrier, offset) = link_carrier[parent];
        let origin = Placement::from_transform(&js.origin);
        let post = Placement::from_transform(&js.post);
        let axis = axes[j];

        let travel = match (
            js.kind.translates(),
            js.limits[js.kind.dof().clamp(1, 2) - 1],
        ) {
            (true, Some(l)) if l.lower.is_finite() && l.upper.is_finite() => {
                (js.d + l.lower).abs().max((js.d + l.upper).abs())
            }
            _ => js.d.abs(),
        };
        reach_of[child] = reach_of[parent] + norm(js.origin.p) + travel + norm(js.post.p);

        let first = q_index[j].unwrap_or(0);
        let (theta, d) = joint_terms(js, first, mimic[j], q_index);

        if js.kind == JointKind::Floating && Some(j) == base {
            // The floating base, the first body ([`Body::floating`]): its frame and rates come
            // from the first seven entries of `q` and six of `q̇`, not from a motion about an
            // axis.
            let body = bodies.len();
            bodies.push(Body {
                floating: true,
                ..Body::new(
                    carrier,
                    compose(offset, origin),
                    Motion::new(Axis::Z, Term::Const(0.0), Term::Const(0.0)),
                    post,
                    new_joint[j],
                )
            });
            link_carrier[child] = (Some(body), Placement::Identity);
            continue;
        }

        if matches!(js.kind, JointKind::Ball | JointKind::Floating) {
            // Its frame and rates come from its own entries of `q` and `q̇` ([`Body::ball`]; a
            // floating joint other than the floating base is a ball with a translation); a
            // motion about x keeps it off the kernels' z-axis paths, and its θ, NaN, sends the
            // kernels to the ball's step from the arm of a constant θ.
            let body = bodies.len();
            bodies.push(Body {
                follows_previous: carrier.is_some() && carrier == body.checked_sub(1),
                rate_shape: Body::BALL,
                ball: Some(Ball {
                    q: first,
                    v: v_of_q(first),
                    free: js.kind == JointKind::Floating,
                }),
                ..Body::new(
                    carrier,
                    compose(offset, origin),
                    Motion::new(Axis::X, Term::Const(f64::NAN), Term::Const(0.0)),
                    post,
                    new_joint[j],
                )
            });
            link_carrier[child] = (Some(body), Placement::Identity);
            continue;
        }

        if js.kind == JointKind::Fixed {
            let motion = crate::eval::compile::constant_motion(&Motion::new(
                Axis::from_unit(axis),
                theta,
                d,
            ));
            let placement = compose(compose(compose(offset, origin), motion), post);
            link_carrier[child] = (carrier, placement);
            continue;
        }

        let body = bodies.len();
        bodies.push(Body {
            follows_previous: carrier.is_some() && carrier == body.checked_sub(1),
            ..Body::new(
                carrier,
                compose(offset, origin),
                Motion::new(Axis::from_unit(axis), theta, d),
                post,
                new_joint[j],
            )
        });
        link_carrier[child] = (Some(body), Placement::Identity);

        limit_checks.extend(joint_limit_checks(
            js,
            new_joint[j],
            first,
            mimic[j],
            q_index,
        ));
    }
    for k in 0..bodies.len() {
        if let (false, Some(p)) = (bodies[k].follows_previous, bodies[k].parent) {
            bodies[p].branches = true;
        }
    }
    // After a floating or ball joint (seven entries of `q` for six of `q̇`, four for three), a
    // joint's entry of `q̇` is before its entry of `q`.
    for b in &mut bodies {
        for (rate, term) in [
            (&mut b.theta_rate, b.motion.theta),
            (&mut b.d_rate, b.motion.d),
        ] {
            if let Term::Var { index, .. } = term {
                rate.index = v_of_q(index);
            }
        }
    }
    Assembled {
        bodies,
        link_carrier,
        reach: reach_of.iter().copied().fold(0.0, f64::max),
        limit_checks,
    }
}

/// θ and d of `js` as terms of `q`: its own entries from `first`, or its primary's through the
/// mimic relation `(primary, multiplier, offset)`; constants for what the joint does not move.
fn joint_terms(
    js: &JointSpec,
    first: usize,
    mimic: Option<Resolved>,
    q_index: &[Option<usize>],
) -> (Term, Term) {
    // Entry `index` of the joint's own coordinates, plus the joint's value at q = 0.
    let var = |index: usize, base: f64| -> Term {
        let (index, scale, offset) = match mimic {
            Some((primary, scale, offset)) => (q_index[primary].unwrap_or(index), scale, offset),
            None => (index, 1.0, 0.0),
        };
        Term::Var {
            index,
            scale,
            offset: offset + base,
        }
    };
    match js.kind {
        JointKind::Fixed | JointKind::Floating | JointKind::Ball => {
            (Term::Const(js.theta), Term::Const(js.d))
        }
        JointKind::Revolute | JointKind::Continuous => (var(first, js.theta), Term::Const(js.d)),
        JointKind::Prismatic => (Term::Const(js.theta), var(first, js.d)),
        JointKind::Cylindrical => (var(first, js.theta), var(first + 1, js.d)),
    }
}

/// The checks of `js`'s limits (`joint` its index in the chain), on the joint's own
/// coordinate: `q` for an independent joint (entries from `first`), the implied value for a
/// mimic joint. None for a continuous joint.
fn joint_limit_checks(
    js: &JointSpec,
    joint: usize,
    first: usize,
    mimic: Option<Resolved>,
    q_index: &[Option<usize>],
) -> Vec<LimitCheck> {
    if js.kind == JointKind::Continuous {
        return Vec::new();
    }
    // Each coordinate's name (a cylindrical joint's two) and whether it is an angle.
    let components: &[(Option<&'static str>, bool)] = if js.kind == JointKind::Cylindrical {
        &[(Some("theta"), true), (Some("d"), false)]
    } else {
        &[(None, js.kind.rotates())]
    };
    components
        .iter()
        .enumerate()
        .filter_map(|(c, &(component, angular))| {
            let limits = js.limits[c]?;
            let (index, scale, offset) = match mimic {
                Some((primary, m, o)) => (q_index[primary].unwrap_or(0), m, o),
                None => (first + c, 1.0, 0.0),
            };
            Some(LimitCheck {
                joint,
                index,
                component,
                angular,
                scale,
                offset,
                limits,
            })
        })
        .collect()
}

/// What the evaluation paths look up about the bodies (the [`Chain`] fields of the same names).
pub(crate) struct EvalTables {
    pub(crate) theta_gather: Vec<ThetaGather>,
    pub(crate) trig_slot: Vec<usize>,
    pub(crate) turning_before: Vec<usize>,
    pub(crate) first_body_from: Vec<usize>,
    pub(crate) serial_run: usize,
    pub(crate) tail_start: usize,
}

impl EvalTables {
    /// The tables for `bodies`, whose motions read `nq` entries of `q`.
    pub(crate) fn new(bodies: &[Body], nq: usize) -> EvalTables {
        let serial_run = bodies
            .iter()
            .enumerate()
            .take_while(|(k, b)| b.parent == k.checked_sub(1))
            .count();
        let mut first_body_from = vec![usize::MAX; nq];
        for (k, b) in bodies.iter().enumerate() {
            for index in b.variables() {
                first_body_from[index] = first_body_from[index].min(k);
            }
        }
        for i in (1..first_body_from.len()).rev() {
            first_body_from[i - 1] = first_body_from[i - 1].min(first_body_from[i]);
        }
        // θ is gathered only for the bodies whose θ varies, in body order: a body's slot in
        // `sin`/`cos`.
        let turning: Vec<&Body> = bodies
            .iter()
            .filter(|b| matches!(b.motion.theta, Term::Var { .. }))
            .collect();
        let mut trig_slot = Vec::with_capacity(bodies.len());
        let mut turning_before = Vec::with_capacity(bodies.len() + 1);
        let mut count = 0;
        for b in bodies {
            turning_before.push(count);
            if matches!(b.motion.theta, Term::Var { .. }) {
                trig_slot.push(count);
                count += 1;
            } else {
                // Read but not used: a constant θ has its sine and cosine in the body.
                trig_slot.push(0);
            }
        }
        turning_before.push(count);
        let n = bodies.len();
        let tail_start = (0..=n)
            .find(|&k| n - k <= 4 && count - turning_before[k] <= 2)
            .unwrap_or(n);
        let theta_gather = turning
            .chunks(crate::eval::simd::lanes::LANES)
            .map(|chunk| {
                let mut g = ThetaGather {
                    index: [0; crate::eval::simd::lanes::LANES],
                    scale: [0.0; crate::eval::simd::lanes::LANES],
                    offset: [0.0; crate::eval::simd::lanes::LANES],
                };
                for (i, b) in chunk.iter().enumerate() {
                    if let Term::Var {
                        index,
                        scale,
                        offset,
                    } = b.motion.theta
                    {
                        (g.index[i], g.scale[i], g.offset[i]) = (index, scale, offset);
                    }
                }
                g
            })
            .collect();
        EvalTables {
            theta_gather,
            trig_slot,
            turning_before,
            first_body_from,
            serial_run,
            tail_start,
        }
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
    let (nq, nv) = (v.model.nq(), v.model.nv());
    if let Some((name, q)) = spec.keyframes.iter().find(|(_, q)| q.len() != nq) {
        return Err(ModelError::KeyframeLength {
            name: name.clone(),
            len: q.len(),
            nq,
        });
    }
    let EvalTables {
        theta_gather,
        trig_slot,
        turning_before,
        first_body_from,
        serial_run,
        tail_start,
    } = EvalTables::new(&bodies, nq);
    let carriers = v
        .tree
        .link_order
        .iter()
        .map(|&l| Carrier {
            body: link_carrier[l].0,
            offset: link_carrier[l].1,
        })
        .collect();
    let mut column_terms = vec![0_usize; nv];
    for t in bodies.iter().flat_map(|b| [b.theta_rate, b.d_rate]) {
        if t.scale != 0.0 {
            column_terms[t.index] += 1;
        }
    }
    // The floating base's body writes the first six columns, another floating joint's its six,
    // a ball joint's its three, once each.
    for b in &bodies {
        match (b.floating, b.ball) {
            (true, _) => column_terms[..6].fill(1),
            (false, Some(ball)) => column_terms[ball.v..ball.angular() + 3].fill(1),
            (false, None) => {}
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
        dense_limits: DenseLimits::new(&limit_checks, nq),
        limit_checks,
        serial_run,
        tail_start,
        carriers,
        reach,
    })
}

/// The constant transform `M(θ, d)` of a motion whose terms are constants (a fixed joint),
/// computed once at load time.
pub(crate) fn constant_motion(m: &Motion) -> Placement {
    let body = Body::new(None, Placement::Identity, *m, Placement::Identity, 0);
    let f =
        crate::eval::kernel::pose_lanes::pose_step::<f64, Separate>(None, &body, &[], (0.0, 1.0));
    Placement::from_transform(&f.into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::layout::body::Placement;
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
        use crate::eval::layout::body::ZTail as Z;
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
                crate::eval::checks::admitted::<crate::eval::simd::portable::Separate>(
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
                        crate::eval::checks::admitted::<crate::eval::simd::portable::Separate>(
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
