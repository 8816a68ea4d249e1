//! Validation: the one place a description ([`ChainBuilder`]) is checked, in stages whose
//! errors come in a fixed order (names, each joint's numbers, the tree, floating joints, mimic
//! joints), and what it hands the evaluation layer besides the [`Model`]: the tree in the
//! builder's indices, unit axes, the layout of `q` and `q̇`, resolved mimic joints.

use crate::model::builder::ChainBuilder;
use crate::model::chain::{Joint, JointId, Link, LinkId, Mimic, Model, Variable};
use crate::model::error::{ModelError, closest_name};
use crate::model::joint::JointKind;
use crate::model::transform::{NotRigid, Transform};
use crate::orientation::normalize_axis;
use std::collections::HashMap;

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
    check_floating(spec, &tree)?;
    let (q_index, v_index, variables, velocities) = q_layout(spec, &tree.joint_order, &new_joint);
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
                v_index: v_index[j],
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
        floating: floating_base(spec, &tree).map(|f| JointId(new_joint[f])),
        quaternions: joints
            .iter()
            .enumerate()
            .filter_map(|(i, j)| Some((JointId(i), j.q_index? + j.kind.quaternion()?)))
            .collect(),
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
        velocities,
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
/// Each joint's first entry of `q` and of `q̇`, and the entries of each.
type Layout = (
    Vec<Option<usize>>,
    Vec<Option<usize>>,
    Vec<Variable>,
    Vec<Variable>,
);

/// The layout of `q` and `q̇`: independent joints in depth-first order. Each joint's first
/// entry of each (`None` for fixed and mimic joints), and each entry's joint (new index) and
/// component name (for joints of several entries).
fn q_layout(spec: &ChainBuilder, joint_order: &[usize], new_joint: &[usize]) -> Layout {
    let mut q_index: Vec<Option<usize>> = vec![None; spec.joints.len()];
    let mut v_index: Vec<Option<usize>> = vec![None; spec.joints.len()];
    let (mut variables, mut velocities) = (Vec::new(), Vec::new());
    for &j in joint_order {
        let js = &spec.joints[j];
        if js.mimic.is_some() || js.kind == JointKind::Fixed {
            continue;
        }
        q_index[j] = Some(variables.len());
        v_index[j] = Some(velocities.len());
        let (q_parts, v_parts) = js.kind.components();
        if q_parts.is_empty() {
            variables.push((new_joint[j], None));
            velocities.push((new_joint[j], None));
        } else {
            variables.extend(q_parts.iter().map(|&c| (new_joint[j], Some(c))));
            velocities.extend(v_parts.iter().map(|&c| (new_joint[j], Some(c))));
        }
    }
    (q_index, v_index, variables, velocities)
}
/// Floating joints may stand anywhere in the tree and be any number (a scene of free bodies),
/// but not in a row: a floating joint that is the only moving joint below another (through
/// fixed joints only) adds nothing but six redundant degrees of freedom (what a floating base
/// added to a robot that already floats would be).
fn check_floating(spec: &ChainBuilder, tree: &Tree) -> Result<(), ModelError> {
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); spec.links.len()];
    for (j, &(parent, _)) in tree.ends.iter().enumerate() {
        children[parent].push(j);
    }
    for (f, joint) in spec.joints.iter().enumerate() {
        if joint.kind != JointKind::Floating {
            continue;
        }
        // The moving joints that hang from what the floating joint moves, through fixed ones.
        let mut moving = Vec::new();
        let mut stack = vec![tree.ends[f].1];
        while let Some(link) = stack.pop() {
            for &j in &children[link] {
                match spec.joints[j].kind {
                    JointKind::Fixed => stack.push(tree.ends[j].1),
                    _ => moving.push(j),
                }
            }
        }
        if let [only] = moving[..]
            && spec.joints[only].kind == JointKind::Floating
        {
            return Err(ModelError::FloatingJoint {
                joint: spec.joints[only].name.clone(),
                problem: format!(
                    "it is the only joint that moves below floating joint '{}' (through fixed \
                     joints only): two floating joints in a row are one",
                    joint.name
                ),
            });
        }
    }
    Ok(())
}
/// The floating base, in the builder's indices: a floating joint that hangs from a link fixed
/// to the world (the root, or a link joined to it by fixed joints) and is the first moving
/// joint (the first body), so that its entries lead `q` and `q̇`. Evaluated on a path of its own; any
/// other floating joint is evaluated where it stands, as a ball joint is.
pub(crate) fn floating_base(spec: &ChainBuilder, tree: &Tree) -> Option<usize> {
    let first = tree
        .joint_order
        .iter()
        .copied()
        .find(|&j| spec.joints[j].kind != JointKind::Fixed)?;
    if spec.joints[first].kind != JointKind::Floating {
        return None;
    }
    let mut link = tree.ends[first].0;
    while let Some(j) = tree.parent_joint[link] {
        if spec.joints[j].kind != JointKind::Fixed {
            return None;
        }
        link = tree.ends[j].0;
    }
    Some(first)
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
