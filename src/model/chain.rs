//! The immutable model a description becomes once validated: joints and links in depth-first
//! order, the layout of `q`, mimic joints resolved to independent ones, limits and names.
//! `validate` is the one place where a description is checked; it hands the evaluation layer
//! what it needs to lay the model out for the kernels.

use crate::model::builder::ChainBuilder;
use crate::model::error::{ModelError, NameError, closest_name};
use crate::model::joint::{JointKind, Limits};
use crate::model::transform::{NotRigid, Transform};
use crate::orientation::normalize_axis;
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
    /// For each entry of `q`: (joint, component name for cylindrical joints).
    pub(crate) variables: Vec<Variable>,
    pub(crate) link_index: HashMap<String, usize>,
    pub(crate) joint_index: HashMap<String, usize>,
    /// [`Model::end_link`].
    pub(crate) end_link: LinkId,
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

    pub(crate) fn variable(&self, index: usize) -> Variable {
        self.variables[index]
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

/// What validating a description gives the evaluation layer to lay out, besides the model: in
/// the builder's indices, the tree, each joint's unit axis, its first entry of `q`, how a mimic
/// joint follows an independent one, and each joint's index in the model.
pub(crate) struct Validated {
    pub(crate) model: Model,
    pub(crate) tree: Tree,
    pub(crate) axes: Vec<[f64; 3]>,
    pub(crate) q_index: Vec<Option<usize>>,
    pub(crate) mimic: Vec<Option<Resolved>>,
    pub(crate) new_joint: Vec<usize>,
}

/// Validates `spec`, in stages whose errors come in this order: names, each joint's numbers,
/// the tree, mimic joints. The model's description is left empty for the caller to fill (with
/// `spec` itself or a copy).
pub(crate) fn validate(spec: &ChainBuilder) -> Result<Validated, ModelError> {
    let (link_of, joint_of) = name_indices(spec)?;
    let axes = checked_axes(spec)?;
    let tree = Tree::new(spec, &link_of)?;
    let new_joint = positions(&tree.joint_order);
    let new_link = positions(&tree.link_order);
    let (q_index, variables) = q_layout(spec, &tree.joint_order, &new_joint);
    let mimic = resolve_mimics(spec, &joint_of)?;
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
        })
        .collect();

    let model = Model {
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
        variables,
        source: ChainBuilder::default(),
    };
    Ok(Validated {
        model,
        tree,
        axes,
        q_index,
        mimic,
        new_joint,
    })
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
/// An entry of `q`: its joint (index in the chain) and, for a cylindrical joint, the component
/// (`"theta"` or `"d"`).
pub(crate) type Variable = (usize, Option<&'static str>);
/// Indices in the builder's lists, by name.
pub(crate) type NameIndex<'a> = HashMap<&'a str, usize>;
/// A mimic joint resolved to an independent one: (primary joint in the builder's indices,
/// multiplier, offset).
pub(crate) type Resolved = (usize, f64, f64);
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
pub(crate) struct Tree {
    /// Each link's parent joint (`None` for the root).
    pub(crate) parent_joint: Vec<Option<usize>>,
    /// Each joint's (parent, child) links.
    pub(crate) ends: Vec<(usize, usize)>,
    pub(crate) root: usize,
    /// Joints and links depth-first from the root, children in file order.
    pub(crate) joint_order: Vec<usize>,
    pub(crate) link_order: Vec<usize>,
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
/// The link farthest from the base, counted in joints, the last in file order of equally far
/// ones ([`Model::end_link`]); `links` and `joints` parents first.
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
