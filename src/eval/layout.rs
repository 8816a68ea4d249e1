//! The kernel-ready form of a chain. Each moving joint becomes a *body*: `world_from_body =
//! world_from_parent_body · pre · M(θ, d) · post`, where `pre` and `post` are constant placements
//! (fixed joints folded in) and `M` is the joint's motion (eq. 2.119). Links are frames fixed to
//! a body (or to the world) at a constant offset, so a fixed joint costs nothing unless its link
//! is asked for. Placements keep the shapes the kernels treat specially; the tables say which
//! bodies turn, where each entry of `q` is first read, and how limits are checked.

use crate::model::builder::{ChainBuilder, JointSpec};
use crate::model::chain::{Resolved, Tree};
use crate::model::joint::{Axis, JointKind, Limits, Motion, Term};
use crate::model::transform::Transform;

/// Where a link is: the body it is fixed to (`None` for a link fixed to the world) and its
/// constant placement in that body's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Carrier {
    pub(crate) body: Option<usize>,
    pub(crate) offset: Placement,
}

/// The columns `(i, j)` a rotation about axis `k` (0, 1, 2 for x, y, z) turns, in cyclic order:
/// `col_i' = c col_i + s col_j`, `col_j' = c col_j − s col_i`.
pub(crate) const fn rotation_plane(k: usize) -> (usize, usize) {
    ((k + 1) % 3, (k + 2) % 3)
}
/// A constant rigid placement, with the forms the kernels treat specially.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Placement {
    Identity,
    /// Pure translation.
    Translation([f64; 3]),
    /// `Tx(a) Rx(α) = Rx(α) Tx(a)` with `(c, s) = (cos α, sin α)`: the constant part of a DH row.
    ScrewX {
        a: f64,
        c: f64,
        s: f64,
    },
    /// `T(t) R_k(α)` with `(c, s) = (cos α, sin α)`: a translation, then a rotation about the new
    /// axis `k` (0, 1, 2 for x, y, z): the URDF origin of many arms, whose `rpy` turns about one
    /// axis.
    OffsetRot {
        t: [f64; 3],
        axis: usize,
        c: f64,
        s: f64,
    },
    General(Transform),
}
impl Placement {
    /// Recognises the special forms exactly (no tolerance: a form is used only when it
    /// reproduces the transform bit for bit).
    pub(crate) fn from_transform(t: &Transform) -> Placement {
        let r = &t.r;
        let identity_rotation = *r == Transform::IDENTITY.r;
        if identity_rotation && t.p == [0.0; 3] {
            Placement::Identity
        } else if identity_rotation {
            Placement::Translation(t.p)
        } else {
            // A rotation about one axis, recognised by rebuilding it.
            (0..3)
                .map(|axis| {
                    let (i, j) = rotation_plane(axis);
                    let (c, s, t) = (r[i][i], r[i][j], t.p);
                    match (axis, t) {
                        (0, [a, 0.0, 0.0]) => Placement::ScrewX { a, c, s },
                        _ => Placement::OffsetRot { t, axis, c, s },
                    }
                })
                .find(|p| p.to_transform() == *t)
                .unwrap_or(Placement::General(*t))
        }
    }

    #[inline]
    pub(crate) fn to_transform(self) -> Transform {
        match self {
            Placement::Identity => Transform::IDENTITY,
            Placement::Translation(p) => Transform {
                p,
                ..Transform::IDENTITY
            },
            Placement::ScrewX { a, c, s } => Transform {
                r: [[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]],
                p: [a, 0.0, 0.0],
            },
            Placement::OffsetRot { t, axis, c, s } => {
                let (i, j) = rotation_plane(axis);
                let mut r = Transform::IDENTITY.r;
                (r[i][i], r[i][j], r[j][i], r[j][j]) = (c, s, -s, c);
                Transform { r, p: t }
            }
            Placement::General(t) => t,
        }
    }
}
/// A moving joint compiled for evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Body {
    /// Parent body, or `None` when the joint hangs from a link fixed to the world.
    pub(crate) parent: Option<usize>,
    /// The parent is the body just before this one in the chain's order (set when the chain is
    /// built): the kernels then take its frame from registers, testing one flag.
    pub(crate) follows_previous: bool,
    /// A later body hangs from this one without following it ([`Body::follows_previous`]), so
    /// kernels that do not read their frames back from memory keep this one aside.
    pub(crate) branches: bool,
    /// Parent body frame (or world) to joint frame, fixed joints folded in.
    pub(crate) pre: Placement,
    pub(crate) motion: Motion,
    pub(crate) post: Placement,
    pub(crate) joint: usize,
    /// `pre` as a full transform.
    pub(crate) pre_frame: Transform,
    /// The joint axis in the parent body frame, `R_pre v`.
    pub(crate) axis_in_parent: [f64; 3],
    /// `pre_frame` and `axis_in_parent` with padded columns, for [`crate::eval::padded`].
    pub(crate) pre4: crate::eval::padded::Stored,
    pub(crate) axis4: crate::eval::padded::C4,
    /// `pre` as shape codes when it is at most a translation and a rotation about x (DH rows,
    /// most URDF arms): the kernels take one jump instead of matching on its kind.
    pub(crate) pre_steps: Option<CheapPlacement>,
    /// `M(θ, d) · post` as shape codes when the joint is about z and `post` is cheap.
    pub(crate) z_tail: Option<ZTail>,
    /// The cases of the rate recursion that apply: [`Body::NO_POST`], [`Body::SLIDES`],
    /// [`Body::ABOUT_Z`], [`Body::ON_PARENT_Z`].
    pub(crate) rate_shape: u8,
    /// The rates of θ and d as read by the rate recursion.
    pub(crate) theta_rate: RateTerm,
    pub(crate) d_rate: RateTerm,
}
/// How the rate of a joint term follows from `q̇` (or `q̈`): `scale · q̇[index]`, with scale zero
/// (and index 0) for a constant term, so that the kernels multiply instead of testing the term's
/// kind. (Every body of a chain has a joint that moves, so `q̇` is never empty where this is
/// read.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RateTerm {
    pub(crate) index: usize,
    pub(crate) scale: f64,
}
impl RateTerm {
    fn of(t: &Term) -> RateTerm {
        match *t {
            Term::Const(_) => RateTerm {
                index: 0,
                scale: 0.0,
            },
            Term::Var { index, scale, .. } => RateTerm { index, scale },
        }
    }
}
/// The steps after `pre` of a body about its z axis, `f ← f · M(θ, d) · post`, with the kinds of
/// the motion's terms and of `post` resolved at load time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ZTail {
    /// The kind of d (bits 0–1) and of θ (bits 2–3): [`ZTail::ZERO`], [`ZTail::CONSTANT`] or
    /// [`ZTail::VARIABLE`].
    pub(crate) motion: u8,
    pub(crate) post: CheapPlacement,
}
/// A placement that is a translation followed by a rotation about x (either may be absent),
/// applied in place as separate steps. `shape` says which steps there are, so that a kernel
/// chooses its code for the placement in one jump rather than testing for each step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CheapPlacement {
    /// [`CheapPlacement::ALONG_X`] or [`CheapPlacement::TRANSLATE`], plus the rotation's kind
    /// shifted left by two: [`CheapPlacement::NO_TURN`], `ANY_TURN`, `QUARTER` or
    /// `NEGATIVE_QUARTER`.
    pub(crate) shape: u8,
    /// The translation along x (one multiply–add per entry) ...
    pub(crate) x: f64,
    /// ... or along any vector (three).
    pub(crate) t: [f64; 3],
    /// Then the rotation about x by α, `(c, s) = (cos α, sin α)`. Most DH tables and URDF arms
    /// turn by quarter turns, where `sin α` is exactly ±1 (even for the double nearest π/2,
    /// whose cosine is 6.1·10⁻¹⁷, not 0): then each product `s · column` is the column or its
    /// negative, bit for bit, and the kernels skip it, which shortens the dependency chain
    /// from joint to joint.
    pub(crate) c: f64,
    pub(crate) s: f64,
}
impl CheapPlacement {
    pub(crate) const ALONG_X: u8 = 1;
    pub(crate) const TRANSLATE: u8 = 2;
    pub(crate) const NO_TURN: u8 = 0;
    pub(crate) const ANY_TURN: u8 = 1;
    /// `s = 1`.
    pub(crate) const QUARTER: u8 = 2;
    /// `s = −1`.
    pub(crate) const NEGATIVE_QUARTER: u8 = 3;

    /// The rotation's kind in a `shape`.
    pub(crate) const fn turn(shape: u8) -> u8 {
        shape >> 2
    }

    pub(crate) fn new(p: &Placement) -> Option<CheapPlacement> {
        let along_x = |t: [f64; 3]| t[1] == 0.0 && t[2] == 0.0;
        let mut out = CheapPlacement {
            shape: 0,
            x: 0.0,
            t: [0.0; 3],
            c: 1.0,
            s: 0.0,
        };
        match *p {
            Placement::Identity => {}
            Placement::Translation(t) if along_x(t) => out.along_x(t[0]),
            Placement::Translation(t) => out.translate(t),
            Placement::ScrewX { a, c, s } => {
                out.along_x(a);
                out.turn_x(c, s);
            }
            Placement::OffsetRot { t, axis: 0, c, s } => {
                out.translate(t);
                out.turn_x(c, s);
            }
            Placement::OffsetRot { .. } | Placement::General(_) => return None,
        }
        Some(out)
    }

    fn along_x(&mut self, a: f64) {
        (self.x, self.shape) = (a, self.shape | Self::ALONG_X);
    }

    fn translate(&mut self, t: [f64; 3]) {
        (self.t, self.shape) = (t, self.shape | Self::TRANSLATE);
    }

    /// Adds the rotation about x with `(cos α, sin α) = (c, s)`.
    pub(crate) fn turn_x(&mut self, c: f64, s: f64) {
        let kind = if s == 1.0 {
            Self::QUARTER
        } else if s == -1.0 {
            Self::NEGATIVE_QUARTER
        } else {
            Self::ANY_TURN
        };
        (self.c, self.s, self.shape) = (c, s, (self.shape & 3) | kind << 2);
    }
}
impl ZTail {
    /// A term that is zero (its step is skipped), another constant, or read from `q`.
    pub(crate) const ZERO: u8 = 0;
    pub(crate) const CONSTANT: u8 = 1;
    pub(crate) const VARIABLE: u8 = 2;

    /// The kind of d in a `motion` code.
    pub(crate) const fn d_kind(motion: u8) -> u8 {
        motion & 3
    }

    /// The kind of θ in a `motion` code.
    pub(crate) const fn theta_kind(motion: u8) -> u8 {
        motion >> 2
    }

    fn new(motion: &Motion, post: &Placement) -> Option<ZTail> {
        if motion.axis != crate::model::joint::Axis::Z {
            return None;
        }
        let kind = |t: &Term| match *t {
            Term::Const(0.0) => Self::ZERO,
            Term::Const(_) => Self::CONSTANT,
            Term::Var { .. } => Self::VARIABLE,
        };
        Some(ZTail {
            motion: kind(&motion.d) | kind(&motion.theta) << 2,
            post: CheapPlacement::new(post)?,
        })
    }
}
impl Body {
    /// `post` is the identity: the child origin lies on the joint axis.
    pub(crate) const NO_POST: u8 = 1;
    /// d varies.
    pub(crate) const SLIDES: u8 = 2;
    /// The joint turns or slides about its frame's z axis.
    pub(crate) const ABOUT_Z: u8 = 4;
    /// `pre` is the identity, the joint moves about z and `post` is not the identity: the joint
    /// sits at the parent's origin on the parent's z axis (standard DH rows).
    pub(crate) const ON_PARENT_Z: u8 = 8;
    /// θ varies (the joint turns).
    pub(crate) const TURNS: u8 = 16;

    pub(crate) fn new(
        parent: Option<usize>,
        pre: Placement,
        motion: Motion,
        post: Placement,
        joint: usize,
    ) -> Body {
        let pre_frame = pre.to_transform();
        let axis_in_parent = pre_frame.apply(motion.axis.vector());
        let no_post = post == Placement::Identity;
        let about_z = motion.axis == crate::model::joint::Axis::Z;
        Body {
            parent,
            follows_previous: false,
            branches: false,
            pre,
            motion,
            post,
            joint,
            pre4: crate::eval::padded::stored(&pre_frame),
            axis4: [axis_in_parent[0], axis_in_parent[1], axis_in_parent[2], 0.0],
            pre_steps: CheapPlacement::new(&pre),
            z_tail: ZTail::new(&motion, &post),
            rate_shape: (u8::from(no_post) * Body::NO_POST)
                | (u8::from(matches!(motion.d, Term::Var { .. })) * Body::SLIDES)
                | (u8::from(about_z) * Body::ABOUT_Z)
                | (u8::from(about_z && !no_post && pre == Placement::Identity) * Body::ON_PARENT_Z)
                | (u8::from(matches!(motion.theta, Term::Var { .. })) * Body::TURNS),
            theta_rate: RateTerm::of(&motion.theta),
            d_rate: RateTerm::of(&motion.d),
            pre_frame,
            axis_in_parent,
        }
    }
}
/// How to compute θ of [`LANES`](crate::eval::kernel::LANES) consecutive bodies from `q`:
/// `θ_i = scale_i · q[index_i] + offset_i` (scale 0 where θ is constant or past the last body).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ThetaGather {
    pub(crate) index: [usize; crate::eval::kernel::LANES],
    pub(crate) scale: [f64; crate::eval::kernel::LANES],
    pub(crate) offset: [f64; crate::eval::kernel::LANES],
}
/// One entry of `q` and what it drives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LimitCheck {
    pub(crate) joint: usize,
    pub(crate) index: usize,
    pub(crate) component: Option<&'static str>,
    /// Whether the coordinate is an angle (rad) rather than a length (m).
    pub(crate) angular: bool,
    pub(crate) scale: f64,
    pub(crate) offset: f64,
    pub(crate) limits: Limits,
}
impl LimitCheck {
    /// The joint coordinate this check limits when `q[self.index]` is `x`.
    pub(crate) fn value(&self, x: f64) -> f64 {
        self.scale * x + self.offset
    }

    /// Whether `q` (a whole configuration) passes this check (finiteness is checked apart).
    pub(crate) fn admits(&self, q: &[f64]) -> bool {
        self.limits.contains(self.value(q[self.index]))
    }
}
/// The limit checks by entry of `q`, as columns: entry `i` passes when it is finite and
/// `lower[i] ≤ scale[i] · x + offset[i] ≤ upper[i]` (the arithmetic of [`LimitCheck`]), with
/// `(1, 0, −∞, ∞)` for an entry without limits (also the padding to whole blocks of four). A
/// whole configuration is then checked in one branch-free pass, four entries per vector compare
/// (`kinematics::admitted`).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct DenseLimits {
    /// Block `b` holds the columns `[scale, offset, lower, upper]` of entries `4b..4b + 4`, so
    /// that a vector check reads one contiguous block.
    blocks: Vec<[[f64; 4]; 4]>,
}
impl DenseLimits {
    /// The columns of four entries without limits: any finite value passes.
    pub(crate) const FREE: [[f64; 4]; 4] = [
        [1.0; 4],
        [0.0; 4],
        [f64::NEG_INFINITY; 4],
        [f64::INFINITY; 4],
    ];

    /// The columns for `checks` over `dof` entries. Two checks of one entry with the same scale
    /// and offset (a mimic joint copying its leader) become their intersection; with different
    /// ones the result is `None`.
    pub(crate) fn new(checks: &[LimitCheck], dof: usize) -> Option<DenseLimits> {
        // Padded to whole blocks of four with entries that admit any finite value.
        let mut blocks = vec![Self::FREE; dof.div_ceil(4)];
        let mut seen = vec![false; dof];
        for c in checks {
            let i = c.index;
            let seen_before = *seen.get(i)?;
            let [scale, offset, lower, upper] = &mut blocks[i / 4];
            let k = i % 4;
            if seen_before && (scale[k] != c.scale || offset[k] != c.offset) {
                return None;
            }
            seen[i] = true;
            scale[k] = c.scale;
            offset[k] = c.offset;
            lower[k] = lower[k].max(c.limits.lower);
            upper[k] = upper[k].min(c.limits.upper);
        }
        Some(DenseLimits { blocks })
    }

    /// Whether entry `i` may take the value `x`.
    #[inline(always)]
    pub(crate) fn admits(&self, i: usize, x: f64) -> bool {
        within(x, self.entry(i))
    }

    /// `(scale, offset, lower, upper)` of entry `i`.
    #[inline(always)]
    pub(crate) fn entry(&self, i: usize) -> (f64, f64, f64, f64) {
        let [scale, offset, lower, upper] = &self.blocks[i / 4];
        let k = i % 4;
        (scale[k], offset[k], lower[k], upper[k])
    }

    /// The columns `[scale, offset, lower, upper]` of entries `4b..4b + 4` for each block `b`,
    /// as the rows of a vector check: one block per four entries of `q`, the last one padded.
    #[inline(always)]
    pub(crate) fn blocks(&self) -> &[[[f64; 4]; 4]] {
        &self.blocks
    }
}
/// Whether `x` is finite with `lower ≤ scale · x + offset ≤ upper`, the product and the sum
/// rounded separately: the decision of every limit check on a value.
#[inline(always)]
pub(crate) fn within(x: f64, (scale, offset, lower, upper): (f64, f64, f64, f64)) -> bool {
    let value = scale * x + offset;
    x.is_finite() & (value >= lower) & (value <= upper)
}
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
    /// An upper bound on the distance of any link origin from the world origin ([`Chain::reach`](crate::eval::chain::Chain::reach)).
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
    let root = tree.root;
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
            js.limits[js.kind.dof().saturating_sub(1)],
        ) {
            (true, Some(l)) if l.lower.is_finite() && l.upper.is_finite() => {
                (js.d + l.lower).abs().max((js.d + l.upper).abs())
            }
            _ => js.d.abs(),
        };
        reach_of[child] = reach_of[parent] + norm(js.origin.p) + travel + norm(js.post.p);

        let first = q_index[j].unwrap_or(0);
        let (theta, d) = joint_terms(js, first, mimic[j], q_index);

        if js.kind == JointKind::Fixed {
            let motion = crate::eval::kinematics::constant_motion(&Motion::new(
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
        JointKind::Fixed => (Term::Const(js.theta), Term::Const(js.d)),
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
    /// The tables for `bodies`, whose motions read `dof` entries of `q`.
    pub(crate) fn new(bodies: &[Body], dof: usize) -> EvalTables {
        let serial_run = bodies
            .iter()
            .enumerate()
            .take_while(|(k, b)| b.parent == k.checked_sub(1))
            .count();
        let mut first_body_from = vec![usize::MAX; dof];
        for (k, b) in bodies.iter().enumerate() {
            for index in b.motion.variables() {
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
            .chunks(crate::eval::kernel::LANES)
            .map(|chunk| {
                let mut g = ThetaGather {
                    index: [0; crate::eval::kernel::LANES],
                    scale: [0.0; crate::eval::kernel::LANES],
                    offset: [0.0; crate::eval::kernel::LANES],
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
