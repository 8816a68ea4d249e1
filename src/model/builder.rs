//! What a loader or a program hands over to make a chain: links and joints as given, before
//! any check. [`ChainBuilder::build`] validates them (the single place a model is validated)
//! and compiles them for evaluation.

use crate::model::joint::{JointKind, Limits};
use crate::model::transform::Transform;

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
/// Collects links and joints and builds a validated [`Chain`](crate::eval::Chain).
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
    pub(crate) name: String,
    pub(crate) links: Vec<String>,
    pub(crate) joints: Vec<JointSpec>,
    pub(crate) world_from_root: Option<Transform>,
    pub(crate) warnings: Vec<String>,
    pub(crate) keyframes: Vec<(String, Vec<f64>)>,
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

    /// Adds a floating joint between the world and the robot's root link, so that the whole
    /// robot moves with the seven entries it takes first in `q` (a position, then a quaternion
    /// w, x, y, z) and six in `q̇`: what a humanoid's or a quadruped's base needs (Pinocchio's
    /// `buildModelFromUrdf(path, JointModelFreeFlyer())`). The joint is called `root_joint` and
    /// hangs from a new root link `world` (`_1`, `_2`, … appended to a name already taken), at
    /// the old root's place in the world ([`ChainBuilder::world_from_root`]); the old root
    /// link's pose is then that placement moved by the joint.
    ///
    /// A description whose root link it cannot tell (none, or several) is left as it is, for
    /// [`ChainBuilder::build`] to report.
    ///
    /// ```
    /// use kinechain::{ChainBuilder, JointKind, JointSpec};
    /// let mut b = ChainBuilder::new("cart");
    /// b.link("body").link("wheel");
    /// b.joint(JointSpec::new("axle", JointKind::Continuous, "body", "wheel"));
    /// let chain = b.floating_base().build()?;
    /// assert_eq!((chain.nq(), chain.nv(), chain.dof()), (8, 7, 7));
    /// assert_eq!(chain.joints()[0].name(), "root_joint");
    /// assert_eq!(chain.links()[0].name(), "world");
    /// # Ok::<(), kinechain::ModelError>(())
    /// ```
    pub fn floating_base(&mut self) -> &mut Self {
        let children: std::collections::HashSet<&str> =
            self.joints.iter().map(|j| j.child.as_str()).collect();
        let mut roots = self.links.iter().filter(|l| !children.contains(l.as_str()));
        let (Some(root), None) = (roots.next(), roots.next()) else {
            return self;
        };
        let root = root.clone();
        let world = self.unique_name("world");
        let joint = self.unique_name("root_joint");
        self.links.insert(0, world.clone());
        self.joints
            .insert(0, JointSpec::new(joint, JointKind::Floating, world, root));
        self
    }

    /// `base`, or `base_1`, `base_2`, … : the first that no link or joint has.
    fn unique_name(&self, base: &str) -> String {
        std::iter::once(base.to_string())
            .chain((1..).map(|i| format!("{base}_{i}")))
            .find(|n| self.name_owner(n).is_none())
            .unwrap_or_else(|| base.to_string())
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

    /// Records a named configuration of the robot (an MJCF `<key>`): `q` in the chain's
    /// layout, `nq` entries (checked by [`ChainBuilder::build`]).
    pub fn keyframe(&mut self, name: impl Into<String>, q: Vec<f64>) -> &mut Self {
        self.keyframes.push((name.into(), q));
        self
    }

    /// The named configurations given with [`ChainBuilder::keyframe`].
    #[must_use]
    pub fn keyframes(&self) -> &[(String, Vec<f64>)] {
        &self.keyframes
    }

    /// Records a warning that the built chain will carry (see [`Model::warnings`](crate::model::chain::Model::warnings)), with its
    /// control characters escaped ([`escape_controls`](crate::model::error::escape_controls)).
    pub fn warn(&mut self, message: impl Into<String>) -> &mut Self {
        let message = message.into();
        self.warnings
            .push(crate::model::error::escape_controls(&message).into_owned());
        self
    }
}
