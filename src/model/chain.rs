//! The immutable model a description becomes once validated: joints and links in depth-first
//! order, the layout of `q`, mimic joints resolved to independent ones, limits and names.
//! `crate::model::validate` checks a description and makes one.

use crate::model::builder::ChainBuilder;
use crate::model::error::{NameError, closest_name};
use crate::model::joint::{JointKind, Limits};
use nalgebra::{Matrix4, Unit, Vector3};
use std::collections::HashMap;

/// Index of a link in a [`Chain`](crate::Chain) (valid only for the chain that produced it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct LinkId(pub(crate) usize);

impl LinkId {
    /// Position in [`Model::links`].
    #[must_use]
    pub fn index(self) -> usize {
        self.0
    }
}
/// Index of a joint in a [`Chain`](crate::Chain) (valid only for the chain that produced it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct JointId(pub(crate) usize);

impl JointId {
    /// Position in [`Model::joints`].
    #[must_use]
    pub fn index(self) -> usize {
        self.0
    }
}
/// A joint of a built [`Chain`](crate::Chain).
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub(crate) name: String,
    pub(crate) kind: JointKind,
    pub(crate) parent: LinkId,
    pub(crate) child: LinkId,
    pub(crate) axis: [f64; 3],
    pub(crate) q_index: Option<usize>,
    pub(crate) v_index: Option<usize>,
    pub(crate) mimic: Option<Mimic>,
    pub(crate) limits: [Option<Limits>; 2],
    pub(crate) theta0: f64,
    pub(crate) d0: f64,
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

    /// Index of this joint's first entry in `q̇` (and `q̈`), or `None` for fixed and mimic
    /// joints: [`Joint::q_index`] but for joints after a floating or ball one.
    #[must_use]
    pub fn v_index(&self) -> Option<usize> {
        self.v_index
    }

    /// Degrees of freedom of this joint: its entries of `q̇` (0 for fixed and mimic joints).
    #[must_use]
    pub fn dof(&self) -> usize {
        if self.q_index.is_some() {
            self.kind.dof()
        } else {
            0
        }
    }

    /// Entries of `q` this joint takes (0 for fixed and mimic joints, 7 for a floating one, 4 for
    /// a ball joint).
    #[must_use]
    pub fn nq(&self) -> usize {
        if self.q_index.is_some() {
            self.kind.nq()
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
    /// A floating or ball joint has none.
    #[must_use]
    pub fn limits(&self) -> &[Option<Limits>] {
        match self.kind {
            JointKind::Floating | JointKind::Ball => &[],
            kind => &self.limits[..kind.dof()],
        }
    }

    /// θ and d at `q = 0` (the DH `theta` and `d`, zero for URDF joints).
    #[must_use]
    pub fn offsets(&self) -> (f64, f64) {
        (self.theta0, self.d0)
    }
}
/// A link frame of a built [`Chain`](crate::Chain).
#[derive(Clone, Debug, PartialEq)]
pub struct Link {
    pub(crate) name: String,
    pub(crate) parent_joint: Option<JointId>,
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

/// A validated kinematic chain (or tree): its joints, links, names, the layout of `q` and the
/// description it was built from. Every [`Chain`](crate::eval::Chain) has one (and
/// dereferences to it), so these methods are the chain's.
#[derive(Clone, Debug)]
pub struct Model {
    pub(crate) name: String,
    pub(crate) joints: Vec<Joint>,
    pub(crate) links: Vec<Link>,
    /// For each entry of `q`: (joint, component name for joints of several entries).
    pub(crate) variables: Vec<Variable>,
    /// For each entry of `q̇`, likewise.
    pub(crate) velocities: Vec<Variable>,
    pub(crate) link_index: HashMap<String, usize>,
    pub(crate) joint_index: HashMap<String, usize>,
    /// [`Model::end_link`].
    pub(crate) end_link: LinkId,
    /// [`Model::floating_joint`].
    pub(crate) floating: Option<JointId>,
    /// [`Model::quaternions`].
    pub(crate) quaternions: Vec<(JointId, usize)>,
    /// The description the chain was built from (for writing it out again), with the loader's
    /// warnings.
    pub(crate) source: ChainBuilder,
}

impl Model {
    /// Robot name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Degrees of freedom: the number of entries of `q̇` and `q̈`, and of the columns of a
    /// Jacobian. The number of entries of `q` too, unless the chain has a floating or ball
    /// joint ([`Model::nq`]).
    #[must_use]
    pub fn dof(&self) -> usize {
        self.velocities.len()
    }

    /// Number of entries of `q`: [`Model::dof`], plus one for a floating joint and for each ball
    /// joint (whose orientation is a quaternion of four entries for three degrees of freedom).
    #[must_use]
    pub fn nq(&self) -> usize {
        self.variables.len()
    }

    /// Number of entries of `q̇` and `q̈`: [`Model::dof`].
    #[must_use]
    pub fn nv(&self) -> usize {
        self.velocities.len()
    }

    /// The floating base, if the chain has one: a floating joint that is the first moving joint
    /// and hangs from a link fixed to the world, so that its entries come first in `q` (seven)
    /// and in `q̇` (six). Other floating joints (the free bodies of a scene, a floating joint
    /// below a moving one) are listed by [`Model::quaternions`].
    #[must_use]
    #[inline]
    pub fn floating_joint(&self) -> Option<JointId> {
        self.floating
    }

    /// The joints whose orientation is a quaternion (a floating joint, ball joints), in `q`
    /// order, each with the index in `q` of its quaternion's first entry (w): 3 for the
    /// floating joint, the joint's own first entry for a ball joint.
    #[must_use]
    #[inline]
    pub fn quaternions(&self) -> &[(JointId, usize)] {
        &self.quaternions
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

    /// For each entry of `q`, the joint it drives and, for a joint of several entries, the
    /// component (`theta` or `d` of a cylindrical joint; `x`, `y`, `z`, `qw`, `qx`, `qy`, `qz`
    /// of a floating one).
    pub fn variables(&self) -> impl ExactSizeIterator<Item = (JointId, Option<&'static str>)> + '_ {
        self.variables.iter().map(|&(j, c)| (JointId(j), c))
    }

    /// The name of each entry of `q`: its joint's, with `.component` for a joint of several
    /// entries (`root.qw`, `slide.d`), as [`Model::variables`] lists them.
    #[must_use]
    pub fn variable_names(&self) -> Vec<String> {
        self.variables()
            .map(|(j, component)| {
                let name = self.joint(j).name();
                component.map_or_else(|| name.to_string(), |c| format!("{name}.{c}"))
            })
            .collect()
    }

    /// For each entry of `q̇` (and `q̈`), the joint and component as [`Model::variables`] gives
    /// them (`vx`, `vy`, `vz`, `wx`, `wy`, `wz` of a floating joint).
    pub fn velocity_variables(
        &self,
    ) -> impl ExactSizeIterator<Item = (JointId, Option<&'static str>)> + '_ {
        self.velocities.iter().map(|&(j, c)| (JointId(j), c))
    }

    /// Warnings found while loading (e.g. an angle that looks like degrees).
    #[must_use]
    pub fn warnings(&self) -> &[String] {
        &self.source.warnings
    }

    /// The robot file's named configurations (MJCF `<key>` elements), in file order: each a
    /// name and a `q` of [`Model::nq`] entries.
    #[must_use]
    pub fn keyframes(&self) -> &[(String, Vec<f64>)] {
        &self.source.keyframes
    }

    /// The description this chain was built from: links and joints as given (before fixed joints
    /// were folded), and the root's placement.
    #[must_use]
    pub fn description(&self) -> &ChainBuilder {
        &self.source
    }

    pub(crate) fn variable(&self, index: usize) -> Variable {
        self.variables[index]
    }

    pub(crate) fn velocity_variable(&self, index: usize) -> Variable {
        self.velocities[index]
    }

    /// `(index, multiplier, offset)` of a joint's own coordinate(s) in `q`: its own entries, or
    /// its primary's for a mimic joint; `None` for a fixed joint.
    pub(crate) fn coordinate_source(&self, joint: JointId) -> Option<(usize, f64, f64)> {
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
    /// [`Model::joint_position`]; a fixed joint reads 0): the joint vector of another tool that
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
}

/// An entry of `q`: its joint (index in the chain) and, for a joint of several entries, the
/// component (`"theta"` or `"d"` of a cylindrical joint, `"qw"` of a floating one).
pub(crate) type Variable = (usize, Option<&'static str>);
