//! One moving body of a compiled chain: its parent, constant placements before and after its
//! joint motion `M(θ, d)` (eq. 2.119), the shape codes that select a kernel's specialised steps,
//! and where each link hangs from it.

use crate::model::joint::{Motion, Term};
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
    pub(crate) pre4: crate::eval::layout::stored::Stored,
    pub(crate) axis4: crate::eval::layout::stored::C4,
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
    /// The body of the floating base (always the first body, hanging from the world): its frame
    /// is `pre · [R(e) | p] · post` with `p` and the Euler parameters `e` the first seven
    /// entries of `q` ([`crate::eval::kernel::floating`]), and its rates are the first six
    /// entries of `q̇` and `q̈`; `motion` is unused. Other floating joints are [`Body::ball`]
    /// bodies with [`Ball::free`].
    pub(crate) floating: bool,
    /// The body of a ball joint: its frame is `parent · pre · [A(e) 0] · post` with the Euler
    /// parameters `e` the four entries of `q` from [`Ball::q`], and its angular velocity and
    /// acceleration relative to the parent the three entries of `q̇` and `q̈` from [`Ball::v`]
    /// ([`crate::eval::kernel::ball`]); `motion` is unused but for its θ, a constant NaN, which
    /// leads the kernels to the ball's own step from the arm of a constant θ (taken otherwise
    /// only by sliding joints with a θ offset, so that other chains pay nothing for it).
    pub(crate) ball: Option<Ball>,
}

/// Where a ball joint's entries are: its quaternion at `q[q..q + 4]`, its rates at
/// `q̇[v..v + 3]` and `q̈[v..v + 3]`. With `free`, the body of a floating joint other than the
/// floating base: a translation at `q[q..q + 3]` before the quaternion at `q[q + 3..q + 7]`, and
/// six rates each, linear then angular ([`crate::eval::kernel::ball`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Ball {
    pub(crate) q: usize,
    pub(crate) v: usize,
    pub(crate) free: bool,
}

impl Ball {
    /// The first entry of the quaternion in `q`.
    #[inline(always)]
    pub(crate) fn quaternion(self) -> usize {
        if self.free { self.q + 3 } else { self.q }
    }

    /// The first entry of the angular rates in `q̇` and `q̈`.
    #[inline(always)]
    pub(crate) fn angular(self) -> usize {
        if self.free { self.v + 3 } else { self.v }
    }

    /// The entries of `q` it reads.
    pub(crate) fn q_range(self) -> std::ops::Range<usize> {
        self.q..self.quaternion() + 4
    }
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
    /// A ball joint ([`Body::ball`]): the only bit of its shape.
    pub(crate) const BALL: u8 = 32;

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
            pre4: crate::eval::layout::stored::stored(&pre_frame),
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
            floating: false,
            ball: None,
        }
    }

    /// The entries of `q` this body's frame reads.
    pub(crate) fn variables(&self) -> impl Iterator<Item = usize> {
        let own = match (self.floating, self.ball) {
            (true, _) => 0..7,
            (false, Some(b)) => b.q_range(),
            (false, None) => 0..0,
        };
        own.chain(self.motion.variables())
    }
}

/// How to compute θ of [`LANES`](crate::eval::simd::lanes::LANES) consecutive bodies from `q`:
/// `θ_i = scale_i · q[index_i] + offset_i` (scale 0 where θ is constant or past the last body).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ThetaGather {
    pub(crate) index: [usize; crate::eval::simd::lanes::LANES],
    pub(crate) scale: [f64; crate::eval::simd::lanes::LANES],
    pub(crate) offset: [f64; crate::eval::simd::lanes::LANES],
}
