//! The immutable chain model: joints, links, the tree that connects them, constant placements,
//! limits and names. Every loader builds one through [`ChainBuilder`], the single place where a
//! model is validated.
//!
//! Internally each moving joint becomes a *body*: `world_from_body = world_from_parent_body ·
//! pre · M(θ, d) · post`, where `pre` and `post` are constant placements (fixed joints folded in)
//! and `M` is the joint's motion (eq. 2.119). Links are frames fixed to a body (or to the world)
//! at a constant offset, so a fixed joint costs nothing unless its link is asked for.

use crate::error::{ModelError, NameError, StateError, closest_name};
use crate::model::joint::{Axis, JointKind, Limits, Motion, Term};
use crate::model::transform::{NotRigid, Transform};
use crate::orientation::normalize_axis;
use nalgebra::{Matrix4, Unit, Vector3};
use std::collections::HashMap;

/// Index of a link in a [`Chain`] (valid only for the chain that produced it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct LinkId(pub(crate) usize);

impl LinkId {
    /// Position in [`Chain::links`].
    #[must_use]
    pub fn index(self) -> usize {
        self.0
    }
}

/// Index of a joint in a [`Chain`] (valid only for the chain that produced it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct JointId(pub(crate) usize);

impl JointId {
    /// Position in [`Chain::joints`].
    #[must_use]
    pub fn index(self) -> usize {
        self.0
    }
}

/// How a mimic joint follows its primary joint: `q = multiplier · q_primary + offset`.
#[derive(Clone, Debug, PartialEq)]
pub struct MimicSpec {
    /// Name of the joint to follow.
    pub joint: String,
    /// Multiplier.
    pub multiplier: f64,
    /// Offset (rad or m).
    pub offset: f64,
}

/// A joint as handed to [`ChainBuilder`]: format-independent, checked by
/// [`ChainBuilder::build`].
///
/// The child link's frame is `parent · origin · M(θ, d) · post`, where `M` rotates by θ about
/// `axis` and translates by `d` along it (eq. 2.119). Revolute and continuous joints have
/// `θ = q + theta` and constant `d`; prismatic joints `d = q + d` and constant `θ`; cylindrical
/// joints both; fixed joints neither.
#[derive(Clone, Debug, PartialEq)]
pub struct JointSpec {
    /// Joint name, unique among joints.
    pub name: String,
    /// Kind.
    pub kind: JointKind,
    /// Name of the parent link.
    pub parent: String,
    /// Name of the child link.
    pub child: String,
    /// Constant placement of the joint frame in the parent link frame.
    pub origin: Transform,
    /// Joint axis in the joint frame (normalised by the builder; ignored for fixed joints).
    pub axis: [f64; 3],
    /// θ at `q = 0` (rad).
    pub theta: f64,
    /// d at `q = 0` (m).
    pub d: f64,
    /// Constant placement after the motion (standard DH: `Tx(a) Rx(α)`).
    pub post: Transform,
    /// Limits of `q` (for a cylindrical joint: θ then d).
    pub limits: [Option<Limits>; 2],
    /// Present for a mimic joint.
    pub mimic: Option<MimicSpec>,
}

impl JointSpec {
    /// A joint with identity placements, axis z, zero offsets, no limits.
    #[must_use]
    pub fn new(
        name: impl Into<String>,
        kind: JointKind,
        parent: impl Into<String>,
        child: impl Into<String>,
    ) -> Self {
        JointSpec {
            name: name.into(),
            kind,
            parent: parent.into(),
            child: child.into(),
            origin: Transform::IDENTITY,
            axis: [0.0, 0.0, 1.0],
            theta: 0.0,
            d: 0.0,
            post: Transform::IDENTITY,
            limits: [None, None],
            mimic: None,
        }
    }

    /// Sets the constant placement of the joint frame in the parent link.
    #[must_use]
    pub fn with_origin(mut self, origin: Transform) -> Self {
        self.origin = origin;
        self
    }

    /// Sets the axis (any non-zero length).
    #[must_use]
    pub fn with_axis(mut self, axis: [f64; 3]) -> Self {
        self.axis = axis;
        self
    }

    /// Sets θ and d at `q = 0`.
    #[must_use]
    pub fn with_offsets(mut self, theta: f64, d: f64) -> Self {
        self.theta = theta;
        self.d = d;
        self
    }

    /// Sets the constant placement after the motion.
    #[must_use]
    pub fn with_post(mut self, post: Transform) -> Self {
        self.post = post;
        self
    }

    /// Sets the limits of the first (or only) coordinate.
    #[must_use]
    pub fn with_limits(mut self, lower: f64, upper: f64) -> Self {
        self.limits[0] = Some(Limits { lower, upper });
        self
    }

    /// Makes this a mimic joint.
    #[must_use]
    pub fn with_mimic(mut self, joint: impl Into<String>, multiplier: f64, offset: f64) -> Self {
        self.mimic = Some(MimicSpec {
            joint: joint.into(),
            multiplier,
            offset,
        });
        self
    }
}

/// Collects links and joints and builds a validated [`Chain`].
///
/// # Examples
/// ```
/// use kinechain::{ChainBuilder, JointKind, JointSpec, Transform};
/// use kinechain::nalgebra::Vector3;
/// let mut b = ChainBuilder::new("pendulum");
/// b.link("base").link("arm");
/// b.joint(JointSpec::new("hinge", JointKind::Continuous, "base", "arm").with_axis([0.0, 1.0, 0.0]));
/// let chain = b.build()?;
/// assert_eq!(chain.dof(), 1);
/// # Ok::<(), kinechain::ModelError>(())
/// ```
#[derive(Clone, Debug, Default)]
pub struct ChainBuilder {
    name: String,
    links: Vec<String>,
    joints: Vec<JointSpec>,
    world_from_root: Option<Transform>,
    warnings: Vec<String>,
}

impl ChainBuilder {
    /// What already has `name`, if anything: `"joint"` or `"link"`.
    pub(crate) fn name_owner(&self, name: &str) -> Option<&'static str> {
        if self.joints.iter().any(|j| j.name == name) {
            Some("joint")
        } else if self.links.iter().any(|l| l == name) {
            Some("link")
        } else {
            None
        }
    }

    /// An empty builder for a robot called `name`.
    #[must_use]
    pub fn new(name: impl Into<String>) -> Self {
        ChainBuilder {
            name: name.into(),
            ..Self::default()
        }
    }

    /// Declares a link.
    pub fn link(&mut self, name: impl Into<String>) -> &mut Self {
        self.links.push(name.into());
        self
    }

    /// Adds a joint.
    pub fn joint(&mut self, joint: JointSpec) -> &mut Self {
        self.joints.push(joint);
        self
    }

    /// Places the root link in the world (default: identity).
    pub fn world_from_root(&mut self, placement: Transform) -> &mut Self {
        self.world_from_root = Some(placement);
        self
    }

    /// Robot name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Declared links, in declaration order.
    #[must_use]
    pub fn links(&self) -> &[String] {
        &self.links
    }

    /// Joints, in declaration order.
    #[must_use]
    pub fn joints(&self) -> &[JointSpec] {
        &self.joints
    }

    /// The root link's placement in the world, if one was set.
    #[must_use]
    pub fn root_placement(&self) -> Option<Transform> {
        self.world_from_root
    }

    /// Records a warning that the built chain will carry (see [`Chain::warnings`]), with its
    /// control characters escaped ([`escape_controls`](crate::error::escape_controls)).
    pub fn warn(&mut self, message: impl Into<String>) -> &mut Self {
        let message = message.into();
        self.warnings
            .push(crate::error::escape_controls(&message).into_owned());
        self
    }

    /// Validates the model and compiles it.
    ///
    /// # Errors
    /// [`ModelError`] naming the joint or link at fault: duplicate or empty names, a joint
    /// referring to a missing link, a link with two parents, several roots, a cycle, a mimic
    /// joint referring to a missing joint or forming a cycle, a zero axis, a non-finite number,
    /// reversed limits, a placement that is not rigid.
    pub fn build(&self) -> Result<Chain, ModelError> {
        let mut chain = build(self)?;
        chain.source = self.clone();
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
                chain.source = self;
                Ok(chain)
            }
            Err(e) => Err(Box::new((e, self))),
        }
    }
}

/// A joint of a built [`Chain`].
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    name: String,
    kind: JointKind,
    parent: LinkId,
    child: LinkId,
    axis: [f64; 3],
    q_index: Option<usize>,
    mimic: Option<Mimic>,
    limits: [Option<Limits>; 2],
    theta0: f64,
    d0: f64,
}

/// θ and d of one joint's motion (eq. 2.119) and their first and second time derivatives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointScrew {
    /// Unit axis in the joint frame.
    pub axis: Unit<Vector3<f64>>,
    /// Rotation about the axis (rad).
    pub theta: f64,
    /// Translation along the axis (m).
    pub d: f64,
    /// dθ/dt.
    pub theta_dot: f64,
    /// dd/dt.
    pub d_dot: f64,
    /// d²θ/dt².
    pub theta_ddot: f64,
    /// d²d/dt².
    pub d_ddot: f64,
}

impl JointScrew {
    /// `T` of eq. (2.119).
    #[must_use]
    pub fn transform(&self) -> Matrix4<f64> {
        crate::model::joint::joint_transform(&self.axis, self.theta, self.d)
    }

    /// `Ṫ` of eq. (2.122).
    #[must_use]
    pub fn transform_dot(&self) -> Matrix4<f64> {
        crate::model::joint::joint_transform_dot(&self.axis, self.theta, self.theta_dot, self.d_dot)
    }

    /// `T̈` of eq. (2.127).
    #[must_use]
    pub fn transform_ddot(&self) -> Matrix4<f64> {
        crate::model::joint::joint_transform_ddot(
            &self.axis,
            self.theta,
            self.theta_dot,
            self.theta_ddot,
            self.d_ddot,
        )
    }
}

/// How a built mimic joint follows its primary: `q = multiplier · q_primary + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mimic {
    /// The independent joint that drives this one (mimics of mimics are resolved).
    pub primary: JointId,
    /// Multiplier.
    pub multiplier: f64,
    /// Offset.
    pub offset: f64,
}

impl Joint {
    /// Name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Kind.
    #[must_use]
    pub fn kind(&self) -> JointKind {
        self.kind
    }

    /// The link this joint hangs from.
    #[must_use]
    pub fn parent(&self) -> LinkId {
        self.parent
    }

    /// The link this joint moves.
    #[must_use]
    pub fn child(&self) -> LinkId {
        self.child
    }

    /// Unit axis in the joint frame.
    #[must_use]
    pub fn axis(&self) -> [f64; 3] {
        self.axis
    }

    /// Index of this joint's first entry in `q`, or `None` for fixed and mimic joints.
    #[must_use]
    pub fn q_index(&self) -> Option<usize> {
        self.q_index
    }

    /// Entries of `q` this joint takes (0 for fixed and mimic joints).
    #[must_use]
    pub fn dof(&self) -> usize {
        if self.q_index.is_some() {
            self.kind.dof()
        } else {
            0
        }
    }

    /// Present for a mimic joint.
    #[must_use]
    pub fn mimic(&self) -> Option<&Mimic> {
        self.mimic.as_ref()
    }

    /// Limits of each coordinate (θ then d for a cylindrical joint); `None` where unlimited.
    #[must_use]
    pub fn limits(&self) -> &[Option<Limits>] {
        &self.limits[..self.kind.dof()]
    }

    /// θ and d at `q = 0` (the DH `theta` and `d`, zero for URDF joints).
    #[must_use]
    pub fn offsets(&self) -> (f64, f64) {
        (self.theta0, self.d0)
    }
}

/// A link frame of a built [`Chain`].
#[derive(Clone, Debug, PartialEq)]
pub struct Link {
    name: String,
    parent_joint: Option<JointId>,
    pub(crate) body: Option<usize>,
    pub(crate) offset: Placement,
}

impl Link {
    /// Name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The joint whose child this link is; `None` for the root.
    #[must_use]
    pub fn parent_joint(&self) -> Option<JointId> {
        self.parent_joint
    }
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
    fn new(checks: &[LimitCheck], dof: usize) -> Option<DenseLimits> {
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

/// An immutable, validated kinematic chain (or tree).
///
/// Build one from a file with [`Chain::from_file`], from text with
/// [`Chain::from_dh_yaml_str`] / [`Chain::from_urdf_str`], or programmatically with
/// [`ChainBuilder`]. Evaluate it with the free functions of [`crate::eval::kinematics`] into a
/// [`Data`](crate::Data) buffer.
#[derive(Clone, Debug)]
pub struct Chain {
    name: String,
    joints: Vec<Joint>,
    links: Vec<Link>,
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
    /// For each entry of `q`: (joint, component name for cylindrical joints).
    variables: Vec<Variable>,
    pub(crate) limit_checks: Vec<LimitCheck>,
    /// `limit_checks` by entry of `q`, when no entry has two different ones.
    pub(crate) dense_limits: Option<DenseLimits>,
    link_index: HashMap<String, usize>,
    joint_index: HashMap<String, usize>,
    /// The number of leading bodies that form a serial chain (body `k` hangs from `k − 1`):
    /// the part of any body's path that needs no index list.
    pub(crate) serial_run: usize,
    /// The first body from which the bodies to the end are few enough for the scalar update of
    /// the last bodies (`kinematics::poses_tail`): at most four, of which at most two turn. A
    /// body index `k` qualifies exactly when `k ≥ tail_start` (both counts shrink as `k` grows).
    pub(crate) tail_start: usize,
    /// [`Chain::end_link`].
    end_link: LinkId,
    reach: f64,
    /// The description the chain was built from (for writing it out again), with the loader's
    /// warnings.
    source: ChainBuilder,
}

impl Chain {
    /// Robot name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Number of entries of `q`.
    #[must_use]
    pub fn dof(&self) -> usize {
        self.variables.len()
    }

    /// All joints (fixed and mimic included), from the base outwards (depth first, children in
    /// file order). Independent joints appear in the order of their entries in `q`.
    #[must_use]
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// All links, root first, in the same depth-first order as the joints.
    #[must_use]
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// The joint with this id.
    ///
    /// # Panics
    /// If `id` comes from another chain with more joints.
    #[must_use]
    pub fn joint(&self, id: JointId) -> &Joint {
        &self.joints[id.0]
    }

    /// The link with this id.
    ///
    /// # Panics
    /// If `id` comes from another chain with more links.
    #[must_use]
    #[inline]
    pub fn link(&self, id: LinkId) -> &Link {
        &self.links[id.0]
    }

    /// The link called `name`.
    ///
    /// # Errors
    /// [`NameError::UnknownLink`] if there is none.
    pub fn link_id(&self, name: &str) -> Result<LinkId, NameError> {
        self.link_index
            .get(name)
            .map(|&i| LinkId(i))
            .ok_or_else(|| NameError::UnknownLink {
                name: name.to_string(),
                suggestion: closest_name(name, self.links.iter().map(Link::name)),
            })
    }

    /// The joint called `name`.
    ///
    /// # Errors
    /// [`NameError::UnknownJoint`] if there is none.
    pub fn joint_id(&self, name: &str) -> Result<JointId, NameError> {
        self.joint_index
            .get(name)
            .map(|&i| JointId(i))
            .ok_or_else(|| NameError::UnknownJoint {
                name: name.to_string(),
                suggestion: closest_name(name, self.joints.iter().map(Joint::name)),
            })
    }

    /// The link farthest from the base, counted in joints (fixed ones included); of equally far
    /// ones, the last in file order. For a serial chain, the tip, whatever frames the file
    /// declares after it (a URDF's `base` frame fixed to `base_link`, say). Found when the chain
    /// is built.
    #[must_use]
    pub fn end_link(&self) -> LinkId {
        self.end_link
    }

    /// For each entry of `q`, the joint it drives and, for a cylindrical joint, `theta` or `d`.
    pub fn variables(&self) -> impl ExactSizeIterator<Item = (JointId, Option<&'static str>)> + '_ {
        self.variables.iter().map(|&(j, c)| (JointId(j), c))
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

    /// Warnings found while loading (e.g. an angle that looks like degrees).
    #[must_use]
    pub fn warnings(&self) -> &[String] {
        &self.source.warnings
    }

    /// The description this chain was built from: links and joints as given (before fixed joints
    /// were folded), and the root's placement.
    #[must_use]
    pub fn description(&self) -> &ChainBuilder {
        &self.source
    }

    /// Number of moving joints after folding fixed joints away.
    #[must_use]
    pub fn moving_joint_count(&self) -> usize {
        self.bodies.len()
    }

    pub(crate) fn variable(&self, index: usize) -> Variable {
        self.variables[index]
    }

    /// `(index, multiplier, offset)` of a joint's own coordinate(s) in `q`: its own entries, or
    /// its primary's for a mimic joint; `None` for a fixed joint.
    fn coordinate_source(&self, joint: JointId) -> Option<(usize, f64, f64)> {
        let j = &self.joints[joint.0];
        match (j.q_index, j.mimic) {
            (Some(i), _) => Some((i, 1.0, 0.0)),
            (None, Some(m)) => self.joints[m.primary.0]
                .q_index
                .map(|i| (i, m.multiplier, m.offset)),
            (None, None) => None,
        }
    }

    /// The position of a joint at `q`, as URDF tools count it: its entry of `q` (θ for a
    /// cylindrical joint) or, for a mimic joint, `multiplier · q_primary + offset`. `None` for a
    /// fixed joint, or when `q` is too short.
    ///
    /// # Panics
    /// If `joint` comes from another chain with more joints.
    ///
    /// # Examples
    /// ```
    /// use kinechain::{ChainBuilder, JointKind, JointSpec};
    /// let mut b = ChainBuilder::new("gripper");
    /// b.link("palm").link("left").link("right").link("tip");
    /// b.joint(JointSpec::new("left", JointKind::Prismatic, "palm", "left"));
    /// b.joint(JointSpec::new("right", JointKind::Prismatic, "palm", "right").with_mimic("left", -2.0, 0.01));
    /// b.joint(JointSpec::new("tip", JointKind::Fixed, "left", "tip"));
    /// let chain = b.build()?;
    /// let q = [0.02];
    /// assert_eq!(chain.joint_position(chain.joint_id("left")?, &q), Some(0.02));
    /// assert_eq!(chain.joint_position(chain.joint_id("right")?, &q), Some(-2.0 * 0.02 + 0.01));
    /// assert_eq!(chain.joint_position(chain.joint_id("tip")?, &q), None);
    /// assert_eq!(chain.joint_position(chain.joint_id("left")?, &[]), None);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn joint_position(&self, joint: JointId, q: &[f64]) -> Option<f64> {
        let (i, multiplier, offset) = self.coordinate_source(joint)?;
        q.get(i).map(|x| multiplier * x + offset)
    }

    /// The positions of the named joints at `q`, in the order given (see
    /// [`Chain::joint_position`]; a fixed joint reads 0): the joint vector of another tool that
    /// orders joints its own way, such as a URDF library listing its movable joints.
    ///
    /// # Errors
    /// [`NameError::UnknownJoint`] for a name this chain does not have.
    ///
    /// # Examples
    /// ```
    /// let chain = kinechain::Chain::from_file("robots/panda.urdf")?;
    /// let q = [0.1, 0.2, 0.3, -1.0, 0.5, 1.5, 0.7, 0.03];
    /// let theirs = chain.positions_by_name(["panda_finger_joint2", "panda_joint8", "panda_joint2"], &q)?;
    /// assert_eq!(theirs, [0.03, 0.0, 0.2]); // a mimic joint, a fixed joint, an arm joint
    /// assert!(chain.positions_by_name(["elbow"], &q).is_err());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn positions_by_name<'n>(
        &self,
        names: impl IntoIterator<Item = &'n str>,
        q: &[f64],
    ) -> Result<Vec<f64>, NameError> {
        names
            .into_iter()
            .map(|name| Ok(self.joint_position(self.joint_id(name)?, q).unwrap_or(0.0)))
            .collect()
    }

    /// θ, d and their rates for one joint at `(q, q_dot, q_ddot)`, from which its relative 4×4
    /// transform and derivatives follow (eqs. 2.119, 2.122, 2.127). A fixed joint has constant θ
    /// and d; a mimic joint follows its primary.
    ///
    /// # Errors
    /// [`StateError::WrongLength`] if a vector does not have [`Chain::dof`] entries.
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

fn check_finite(joint: &str, field: &'static str, values: &[f64]) -> Result<(), ModelError> {
    if values.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(ModelError::NonFinite {
            joint: joint.to_string(),
            field,
        })
    }
}

fn check_rigid(joint: &str, field: &'static str, t: &Transform) -> Result<(), ModelError> {
    let rows = t.to_rows();
    Transform::try_from_rows(&rows)
        .map(|_| ())
        .map_err(|problem| match problem {
            NotRigid::NonFinite => ModelError::NonFinite {
                joint: joint.to_string(),
                field,
            },
            problem => ModelError::NotRigid {
                joint: joint.to_string(),
                field,
                problem,
            },
        })
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

/// Validates `spec` and lays it out for evaluation, in stages whose errors come in this order:
/// names, each joint's numbers, the tree, mimic joints. The chain's description is left empty
/// for the caller to fill (with `spec` itself or a copy).
fn build(spec: &ChainBuilder) -> Result<Chain, ModelError> {
    let (link_of, joint_of) = name_indices(spec)?;
    let axes = checked_axes(spec)?;
    let tree = Tree::new(spec, &link_of)?;
    let new_joint = positions(&tree.joint_order);
    let new_link = positions(&tree.link_order);
    let (q_index, variables) = q_layout(spec, &tree.joint_order, &new_joint);
    let mimic = resolve_mimics(spec, &joint_of)?;
    let Assembled {
        bodies,
        link_carrier,
        reach,
        limit_checks,
    } = assemble(spec, &tree, &axes, &q_index, &mimic, &new_joint);
    let EvalTables {
        theta_gather,
        trig_slot,
        turning_before,
        first_body_from,
        serial_run,
        tail_start,
    } = EvalTables::new(&bodies, variables.len());

    let joints: Vec<Joint> = tree
        .joint_order
        .iter()
        .map(|&j| {
            let js = &spec.joints[j];
            Joint {
                name: js.name.clone(),
                kind: js.kind,
                parent: LinkId(new_link[tree.ends[j].0]),
                child: LinkId(new_link[tree.ends[j].1]),
                axis: axes[j],
                q_index: q_index[j],
                mimic: mimic[j].map(|(p, multiplier, offset)| Mimic {
                    primary: JointId(new_joint[p]),
                    multiplier,
                    offset,
                }),
                limits: if js.kind == JointKind::Continuous {
                    [None, None]
                } else {
                    js.limits
                },
                theta0: js.theta,
                d0: js.d,
            }
        })
        .collect();
    let links: Vec<Link> = tree
        .link_order
        .iter()
        .map(|&l| Link {
            name: spec.links[l].clone(),
            parent_joint: tree.parent_joint[l].map(|j| JointId(new_joint[j])),
            body: link_carrier[l].0,
            offset: link_carrier[l].1,
        })
        .collect();

    Ok(Chain {
        end_link: farthest_link(&links, &joints),
        name: spec.name.clone(),
        link_index: links
            .iter()
            .enumerate()
            .map(|(i, l)| (l.name.clone(), i))
            .collect(),
        joint_index: joints
            .iter()
            .enumerate()
            .map(|(i, j)| (j.name.clone(), i))
            .collect(),
        joints,
        links,
        bodies,
        theta_gather,
        trig_slot,
        turning_before,
        first_body_from,
        dense_limits: DenseLimits::new(&limit_checks, variables.len()),
        variables,
        limit_checks,
        serial_run,
        tail_start,
        reach,
        source: ChainBuilder::default(),
    })
}

/// An entry of `q`: its joint (index in the chain) and, for a cylindrical joint, the component
/// (`"theta"` or `"d"`).
type Variable = (usize, Option<&'static str>);

/// Indices in the builder's lists, by name.
type NameIndex<'a> = HashMap<&'a str, usize>;

/// A mimic joint resolved to an independent one: (primary joint in the builder's indices,
/// multiplier, offset).
type Resolved = (usize, f64, f64);

/// The index of every link and joint by name, after checking that names are unique and not
/// empty and that there is a link.
fn name_indices(spec: &ChainBuilder) -> Result<(NameIndex<'_>, NameIndex<'_>), ModelError> {
    let mut link_of = NameIndex::new();
    for (i, name) in spec.links.iter().enumerate() {
        if name.is_empty() {
            return Err(ModelError::EmptyName { what: "link" });
        }
        if link_of.insert(name.as_str(), i).is_some() {
            return Err(ModelError::DuplicateLink { name: name.clone() });
        }
    }
    if spec.links.is_empty() {
        return Err(ModelError::NoLinks);
    }
    let mut joint_of = NameIndex::new();
    for (i, j) in spec.joints.iter().enumerate() {
        if j.name.is_empty() {
            return Err(ModelError::EmptyName { what: "joint" });
        }
        if joint_of.insert(j.name.as_str(), i).is_some() {
            return Err(ModelError::DuplicateJoint {
                name: j.name.clone(),
            });
        }
    }
    Ok((link_of, joint_of))
}

/// Each joint's unit axis (z for a fixed joint), after checking its numbers: rigid placements,
/// finite values, a non-zero axis, ordered limits, a mimic only on a one-coordinate joint; and
/// the base placement.
fn checked_axes(spec: &ChainBuilder) -> Result<Vec<[f64; 3]>, ModelError> {
    let mut axes = Vec::with_capacity(spec.joints.len());
    for j in &spec.joints {
        check_rigid(&j.name, "origin", &j.origin)?;
        check_rigid(&j.name, "post", &j.post)?;
        check_finite(&j.name, "theta", &[j.theta])?;
        check_finite(&j.name, "d", &[j.d])?;
        let axis = if j.kind == JointKind::Fixed {
            [0.0, 0.0, 1.0]
        } else {
            check_finite(&j.name, "axis", &j.axis)?;
            normalize_axis(j.axis).ok_or_else(|| ModelError::ZeroAxis {
                joint: j.name.clone(),
            })?
        };
        axes.push(axis);
        for l in j.limits.iter().flatten() {
            if l.lower.is_nan() || l.upper.is_nan() {
                return Err(ModelError::NonFinite {
                    joint: j.name.clone(),
                    field: "limits",
                });
            }
            if l.lower > l.upper {
                return Err(ModelError::ReversedLimits {
                    joint: j.name.clone(),
                    lower: l.lower,
                    upper: l.upper,
                });
            }
        }
        if let Some(m) = &j.mimic {
            check_finite(&j.name, "mimic", &[m.multiplier, m.offset])?;
            if j.kind.dof() != 1 {
                return Err(ModelError::BadMimicKind {
                    joint: j.name.clone(),
                    kind: j.kind.as_str(),
                });
            }
        }
    }
    if let Some(root) = &spec.world_from_root {
        check_rigid("base", "placement", root)?;
    }
    Ok(axes)
}

/// The joints' tree, in the builder's indices.
struct Tree {
    /// Each link's parent joint (`None` for the root).
    parent_joint: Vec<Option<usize>>,
    /// Each joint's (parent, child) links.
    ends: Vec<(usize, usize)>,
    root: usize,
    /// Joints and links depth-first from the root, children in file order.
    joint_order: Vec<usize>,
    link_order: Vec<usize>,
}

impl Tree {
    /// The tree of `spec`'s joints, or the error for an unknown link, a link with two parents,
    /// several roots or a cycle.
    fn new(spec: &ChainBuilder, link_of: &NameIndex<'_>) -> Result<Tree, ModelError> {
        let mut parent_joint: Vec<Option<usize>> = vec![None; spec.links.len()];
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); spec.links.len()];
        let mut ends = Vec::with_capacity(spec.joints.len());
        for (i, j) in spec.joints.iter().enumerate() {
            let find = |name: &str, role| {
                link_of
                    .get(name)
                    .copied()
                    .ok_or_else(|| ModelError::UnknownLink {
                        joint: j.name.clone(),
                        role,
                        link: name.to_string(),
                        suggestion: closest_name(name, spec.links.iter().map(String::as_str)),
                    })
            };
            let parent = find(&j.parent, "parent")?;
            let child = find(&j.child, "child")?;
            if let Some(first) = parent_joint[child] {
                return Err(ModelError::TwoParents {
                    link: j.child.clone(),
                    first: spec.joints[first].name.clone(),
                    second: j.name.clone(),
                });
            }
            parent_joint[child] = Some(i);
            children[parent].push(i);
            ends.push((parent, child));
        }
        let roots: Vec<usize> = (0..spec.links.len())
            .filter(|&l| parent_joint[l].is_none())
            .collect();
        let root = match roots.as_slice() {
            [] => {
                return Err(ModelError::Cycle {
                    joint: spec
                        .joints
                        .first()
                        .map(|j| j.name.clone())
                        .unwrap_or_default(),
                });
            }
            [r] => *r,
            _ => {
                return Err(ModelError::MultipleRoots {
                    roots: roots.iter().map(|&l| spec.links[l].clone()).collect(),
                });
            }
        };

        // Depth-first order of joints from the root (iterative: chains may be very long).
        let mut joint_order = Vec::with_capacity(spec.joints.len());
        let mut link_order = Vec::with_capacity(spec.links.len());
        let mut stack = vec![root];
        while let Some(l) = stack.pop() {
            link_order.push(l);
            if let Some(j) = parent_joint[l] {
                joint_order.push(j);
            }
            // Push children reversed so the first declared child is visited first.
            stack.extend(children[l].iter().rev().map(|&j| ends[j].1));
        }
        if link_order.len() != spec.links.len() {
            // Every unreached link has a parent joint, so it lies on (or below) a cycle.
            let unreached = (0..spec.links.len())
                .find(|l| !link_order.contains(l))
                .and_then(|l| parent_joint[l])
                .map(|j| spec.joints[j].name.clone())
                .unwrap_or_default();
            return Err(ModelError::Cycle { joint: unreached });
        }
        Ok(Tree {
            parent_joint,
            ends,
            root,
            joint_order,
            link_order,
        })
    }
}

/// `position[i]`: where `i` stands in `order` (a permutation of `0..order.len()`).
fn positions(order: &[usize]) -> Vec<usize> {
    let mut position = vec![0; order.len()];
    for (n, &i) in order.iter().enumerate() {
        position[i] = n;
    }
    position
}

/// The layout of `q`: independent joints in depth-first order. Each joint's first entry
/// (`None` for fixed and mimic joints), and each entry's joint (new index) and component name
/// (for cylindrical joints).
fn q_layout(
    spec: &ChainBuilder,
    joint_order: &[usize],
    new_joint: &[usize],
) -> (Vec<Option<usize>>, Vec<Variable>) {
    let mut q_index: Vec<Option<usize>> = vec![None; spec.joints.len()];
    let mut variables = Vec::new();
    for &j in joint_order {
        let js = &spec.joints[j];
        if js.mimic.is_some() || js.kind == JointKind::Fixed {
            continue;
        }
        q_index[j] = Some(variables.len());
        if js.kind == JointKind::Cylindrical {
            variables.push((new_joint[j], Some("theta")));
            variables.push((new_joint[j], Some("d")));
        } else {
            variables.push((new_joint[j], None));
        }
    }
    (q_index, variables)
}

/// Each mimic joint's (primary joint, multiplier, offset), following mimics of mimics to an
/// independent joint. Each joint's target is looked up once and each joint resolved once, so a
/// chain of mimics of mimics resolves in time linear in its length.
fn resolve_mimics(
    spec: &ChainBuilder,
    joint_of: &NameIndex<'_>,
) -> Result<Vec<Option<Resolved>>, ModelError> {
    let n = spec.joints.len();
    let mut mimic: Vec<Option<Resolved>> = vec![None; n];
    // The walk (1-based number of the joint it started from) that last reached each joint, to
    // tell a cycle from a joint resolved by an earlier walk.
    let mut reached = vec![0usize; n];
    let mut path = Vec::new();
    for (start, js) in spec.joints.iter().enumerate() {
        if js.mimic.is_none() || mimic[start].is_some() {
            continue;
        }
        // Follow the targets until an independent joint or one already resolved.
        path.clear();
        let mut at = start;
        let end = loop {
            let Some(m) = &spec.joints[at].mimic else {
                break (at, 1.0, 0.0);
            };
            if let Some(done) = mimic[at] {
                break done;
            }
            if reached[at] == start + 1 {
                return Err(ModelError::MimicCycle {
                    joint: js.name.clone(),
                });
            }
            reached[at] = start + 1;
            path.push(at);
            let t =
                *joint_of
                    .get(m.joint.as_str())
                    .ok_or_else(|| ModelError::UnknownMimicTarget {
                        joint: spec.joints[at].name.clone(),
                        target: m.joint.clone(),
                        suggestion: closest_name(
                            &m.joint,
                            spec.joints.iter().map(|j| j.name.as_str()),
                        ),
                    })?;
            let tj = &spec.joints[t];
            if tj.kind.dof() != 1 {
                return Err(ModelError::BadMimicTarget {
                    joint: spec.joints[at].name.clone(),
                    target: tj.name.clone(),
                    kind: tj.kind.as_str(),
                });
            }
            at = t;
        };
        // Back along the path: q_j = m_j q_target + o_j, with q_target = M q_primary + O.
        let (primary, mut multiplier, mut offset) = end;
        for &j in path.iter().rev() {
            if let Some(m) = &spec.joints[j].mimic {
                offset = m.multiplier * offset + m.offset;
                multiplier *= m.multiplier;
                mimic[j] = Some((primary, multiplier, offset));
            }
        }
    }
    Ok(mimic)
}

/// The moving bodies of a chain, with what hangs from them.
struct Assembled {
    bodies: Vec<Body>,
    /// Each link's (body it is fixed to, `None` for the base; placement in that body's frame),
    /// in the builder's link indices.
    link_carrier: Vec<(Option<usize>, Placement)>,
    /// An upper bound on the distance of any link origin from the world origin ([`Chain::reach`]).
    reach: f64,
    limit_checks: Vec<LimitCheck>,
}

/// One body per moving joint in depth-first order, fixed joints folded into the placement of
/// what follows them; each joint's limits as checks on entries of `q`.
fn assemble(
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
struct EvalTables {
    theta_gather: Vec<ThetaGather>,
    trig_slot: Vec<usize>,
    turning_before: Vec<usize>,
    first_body_from: Vec<usize>,
    serial_run: usize,
    tail_start: usize,
}

impl EvalTables {
    /// The tables for `bodies`, whose motions read `dof` entries of `q`.
    fn new(bodies: &[Body], dof: usize) -> EvalTables {
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

/// The link farthest from the base, counted in joints, the last in file order of equally far
/// ones ([`Chain::end_link`]); `links` and `joints` parents first.
fn farthest_link(links: &[Link], joints: &[Joint]) -> LinkId {
    let mut depth = vec![0_usize; links.len()];
    let mut end = 0;
    for (l, link) in links.iter().enumerate() {
        if let Some(j) = link.parent_joint {
            depth[l] = depth[joints[j.0].parent.0] + 1;
        }
        if depth[l] >= depth[end] {
            end = l;
        }
    }
    LinkId(end)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        use ZTail as Z;
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
