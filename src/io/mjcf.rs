//! MJCF (MuJoCo's XML) read for its kinematics, with MuJoCo's semantics: `q` is MuJoCo's
//! `qpos`, entry for entry, and every body and site lands where `mj_kinematics` puts it.
//!
//! A body becomes a link of the same name; its joints become joints in the order the file gives
//! them, with links between them named `BODY/JOINT` when a body has several; a body without
//! joints is welded to its parent (a joint `BODY/weld`); a site is a link fixed to its body (its
//! name, or `site:NAME` when a body has the name), joined by `SITE/site`. A hinge turns about
//! its `pos`, and a hinge or slide joint moves by `qpos − ref`. A free joint places its body in
//! the world by `qpos` alone (a floating joint from `world`). Geoms, meshes, assets, actuators,
//! sensors, tendons, contacts and the rest do not move a body: they are skipped.

mod attrs;
mod inertia;
mod names;
mod scene;
mod tree;

use crate::io::error::LoadErrorKind;
use crate::model::builder::{ChainBuilder, JointSpec};
use crate::model::joint::JointKind;
use attrs::{Kind, Pose, fromto, placement, real_list, reals};
use inertia::align;
use nalgebra::{UnitQuaternion, Vector3};
use names::Names;
use scene::{Scene, Source};
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use tree::{Element, Problem};

/// Where a joint of a body goes: its name, the links it joins, the body's placement in the
/// parent link (the identity for the second and later joints of a body), the frames around the
/// joint in the body, whether the body hangs from the world, and how many joints it has.
struct JointAt<'a> {
    name: &'a str,
    parent: &'a str,
    child: &'a str,
    body: &'a Pose,
    frame: &'a Pose,
    top: bool,
    count: usize,
}

/// Reads MJCF text: `main` is its file (for includes and messages), `base` the directory
/// includes are looked up in first (the main file's by default); an included file may have at
/// most `max_bytes`. With `couplings`, linear joint couplings become mimic joints.
pub(crate) fn parse(
    text: &str,
    (main, base): (Option<&Path>, Option<&Path>),
    default_name: &str,
    (max_bytes, couplings): (u64, bool),
) -> Result<ChainBuilder, LoadErrorKind> {
    let mut tree = tree::read(text, main, base, max_bytes)?;
    let sources = match read_sources(&mut tree) {
        Ok(s) => s,
        Err(p) => return Err(p.into_kind(tree.files())),
    };
    read_model(&sources, tree.files(), default_name, couplings)
        .map_err(|p| p.into_kind(tree.files()))
}

/// The main model and every model its `<asset><model>` elements (and theirs) read for
/// `<attach>`, the main one first.
fn read_sources(tree: &mut tree::Tree) -> Result<Vec<Source>, Problem> {
    let placeholder = Element {
        name: String::new(),
        attributes: Vec::new(),
        children: Vec::new(),
        at: tree.root.at,
    };
    let root = std::mem::replace(&mut tree.root, placeholder);
    let mut sources = vec![Source::new(root)?];
    let mut next = 0;
    while next < sources.len() {
        let declared: Vec<(Option<String>, String, tree::At)> = sources[next]
            .root
            .children_named("asset")
            .flat_map(|a| a.children_named("model"))
            .map(|m| {
                let file = m.attribute("file").map(|(f, _)| f.to_string());
                (m.attribute("name").map(|(n, _)| n.to_string()), file, m.at)
            })
            .map(|(name, file, at)| {
                file.map(|f| (name, f, at))
                    .ok_or_else(|| Problem::at(at, "<model> has no file attribute"))
            })
            .collect::<Result<_, _>>()?;
        for (name, file, at) in declared {
            let root = tree.read_model(&file, at)?;
            // Named by the asset, else by the model's own name (MuJoCo's default if none).
            let name = name
                .or_else(|| root.attribute("model").map(|(m, _)| m.to_string()))
                .unwrap_or_else(|| "MuJoCo Model".to_string());
            sources.push(Source::new(root)?);
            let index = sources.len() - 1;
            sources[next].models.push((name, index));
        }
        next += 1;
    }
    Ok(sources)
}

fn read_model(
    sources: &[Source],
    files: &[PathBuf],
    default_name: &str,
    couplings: bool,
) -> Result<ChainBuilder, Problem> {
    let root = &sources[0].root;
    let name = root.attribute("model").map_or(default_name, |(v, _)| v);
    let scene = scene::collect(sources)?;
    let names = Names::of(&scene)?;
    let mut reader = Reader {
        sources,
        files,
        b: ChainBuilder::new(name),
        link_names: HashSet::new(),
        joint_names: HashSet::new(),
        qpos0: Vec::new(),
        refs: Vec::new(),
        quaternions: Vec::new(),
        joint_keys: Vec::new(),
    };
    reader.link_names.extend(names.links());
    reader.joint_names.extend(names.joints.iter().cloned());
    reader.b.link("world");
    reader.fusestatic(&scene);
    for b in 0..scene.bodies.len() {
        reader.body(&scene, &names, b)?;
    }
    reader.keyframes(root, &scene.attached_keys)?;
    if couplings {
        reader.couplings(root)?;
    }
    reader.equalities(root, couplings);
    Ok(reader.b)
}

struct Reader<'a> {
    sources: &'a [Source],
    files: &'a [PathBuf],
    b: ChainBuilder,
    /// Every link name (the file's, and those made up), to keep made-up ones apart.
    link_names: HashSet<String>,
    joint_names: HashSet<String>,
    /// MuJoCo's `qpos0`: what a keyframe without `qpos` holds.
    qpos0: Vec<f64>,
    /// Each hinge or slide joint's name and reference position (`qpos0`).
    refs: Vec<(String, f64)>,
    /// Where each free or ball joint's quaternion starts in `qpos`.
    quaternions: Vec<usize>,
    /// Each joint's entries in the keyframes of attached models, and its first entry in `qpos`.
    joint_keys: Vec<(usize, usize, scene::KeyEntries)>,
}

impl Reader<'_> {
    /// Where `at` is, for a warning, as errors say it: `line L column C`, after `in file F:`
    /// for a file other than the main one.
    fn place(&self, at: tree::At) -> String {
        let file = match self.files.get(at.file) {
            Some(f) if at.file > 0 => format!("in file {}: ", f.display()),
            _ => String::new(),
        };
        format!("{file}line {} column {}", at.line, at.column)
    }

    /// `fusestatic`: MuJoCo fuses bodies without joints into their parents, and renumbers the
    /// bodies and sites after them. Their frames do not move, so kinechain keeps such bodies as
    /// links; names made from ids then may not be MuJoCo's ids, which a warning says.
    fn fusestatic(&mut self, scene: &Scene<'_>) {
        let Some(at) = self.sources[0].compiler.fusestatic else {
            return;
        };
        let bodies = &scene.bodies[1..];
        let is_static = |b: &scene::Body<'_>| {
            b.joints.is_empty()
                && b.item
                    .el
                    .attribute("mocap")
                    .is_none_or(|(v, _)| v != "true")
        };
        let unnamed_bodies = bodies.iter().filter(|b| b.item.name.is_none()).count();
        let unnamed_sites = (scene.bodies.iter())
            .flat_map(|b| &b.sites)
            .filter(|s| s.name.is_none())
            .count();
        if bodies.iter().any(is_static) && unnamed_bodies + unnamed_sites > 0 {
            self.warn(
                at,
                format!(
                    "fusestatic: MuJoCo fuses bodies without joints into their parents, which \
                     renumbers bodies and sites; kinechain keeps those bodies as links (their \
                     frames are the same) and names the {unnamed_bodies} unnamed bodies and \
                     {unnamed_sites} unnamed sites by their ids without fusion (body#ID, \
                     site#ID), which may not be MuJoCo's: name them to refer to them"
                ),
            );
        }
    }

    fn warn(&mut self, at: tree::At, message: String) {
        let place = self.place(at);
        self.b.warn(format!("{place}: {message}"));
    }

    /// `base`, or `base_1`, `base_2`, … : the first no joint has (names made up here only).
    fn joint_name(&mut self, base: String) -> String {
        let name = std::iter::once(base.clone())
            .chain((1..).map(|i| format!("{base}_{i}")))
            .find(|n| !self.joint_names.contains(n))
            .unwrap_or(base);
        self.joint_names.insert(name.clone());
        name
    }

    /// Likewise for links.
    fn link_name(&mut self, base: String) -> String {
        let name = std::iter::once(base.clone())
            .chain((1..).map(|i| format!("{base}_{i}")))
            .find(|n| !self.link_names.contains(n))
            .unwrap_or(base);
        self.link_names.insert(name.clone());
        name
    }

    /// Body `b` of the scene: its link, its joints (a chain of links when it has several, a
    /// fixed joint when none) and its sites.
    fn body(&mut self, scene: &Scene<'_>, names: &Names, b: usize) -> Result<(), Problem> {
        let body = &scene.bodies[b];
        let name = names.bodies[b].clone();
        let parent = match b {
            0 => String::new(),
            _ => names.bodies[body.parent].clone(),
        };
        let source = &self.sources[body.item.source];
        let first_joint: usize = scene.bodies[..b].iter().map(|x| x.joints.len()).sum();
        let first_site: usize = scene.bodies[..b].iter().map(|x| x.sites.len()).sum();
        let mut pose = body.pose;
        // alignfree: a free body without children moves onto its inertial frame, and what it
        // holds moves the other way (MuJoCo's free-joint alignment).
        let aligned = match if b == 0 { None } else { align(body, source)? } {
            Some(frame) => {
                pose = pose.then(&frame);
                Some(frame.inverse())
            }
            None => None,
        };
        let held = |item: &scene::Item<'_>| match &aligned {
            Some(inverse) => inverse.then(&item.frame),
            None => item.frame,
        };
        if let Some((v, at)) = body.item.el.attribute("mocap")
            && attrs::boolean(v, at, "mocap")?
        {
            self.warn(
                body.item.el.at,
                format!(
                    "body '{name}' is a mocap body: it is fixed where the file places it (MuJoCo's \
                     mocap_pos and mocap_quat at their defaults)"
                ),
            );
        }
        if b == 0 {
            // The world: its link is there; only its sites follow.
        } else if body.joints.is_empty() {
            let joint = self.joint_name(format!("{name}/weld"));
            self.b.link(&name);
            self.b.joint(
                JointSpec::new(joint, JointKind::Fixed, parent.as_str(), name.as_str())
                    .with_origin(pose.transform()),
            );
        } else {
            let mut from = parent;
            let count = body.joints.len();
            for (i, j) in body.joints.iter().enumerate() {
                let jname = names.joints[first_joint + i].clone();
                let to = if i + 1 == count {
                    name.clone()
                } else {
                    self.link_name(format!("{name}/{jname}"))
                };
                let placed = if i == 0 { pose } else { Pose::IDENTITY };
                let at_joint = JointAt {
                    name: &jname,
                    parent: &from,
                    child: &to,
                    body: &placed,
                    frame: &held(j),
                    top: body.parent == 0,
                    count,
                };
                let spec = self.joint(j, &at_joint)?;
                if !j.keys.is_empty() {
                    let first = self.qpos0.len() - spec.kind.nq();
                    self.joint_keys
                        .push((first, spec.kind.nq(), j.keys.clone()));
                }
                self.b.link(&to);
                self.b.joint(spec);
                from = to;
            }
        }
        for (k, site) in body.sites.iter().enumerate() {
            let link = names.sites[first_site + k].clone();
            let placed = self.site(site, &held(site), &link)?;
            let joint = self.joint_name(format!("{link}/site"));
            self.b.link(&link);
            self.b.joint(
                JointSpec::new(joint, JointKind::Fixed, name.as_str(), link.as_str())
                    .with_origin(placed.transform()),
            );
        }
        Ok(())
    }

    /// The joint `j` of a body ([`JointAt`]).
    fn joint(&mut self, j: &scene::Item<'_>, at: &JointAt<'_>) -> Result<JointSpec, Problem> {
        let el = j.el;
        let source = &self.sources[j.source];
        let (compiler, defaults) = (&source.compiler, &source.defaults);
        let name = at.name;
        let free = el.name == "freejoint";
        let class = if free {
            "main"
        } else {
            defaults.class_of(el, &j.class)?
        };
        let get = |n: &str| {
            if free {
                el.attribute(n)
            } else {
                defaults.value(el, Kind::Joint, class, n)
            }
        };
        let kind = if free {
            "free"
        } else {
            get("type").map_or("hinge", |(v, _)| v)
        };
        let type_at = get("type").map_or(el.at, |(_, at)| at);
        // The joint's anchor and axis in the body's frame: the frames around it place them.
        let anchor = |pos: Vector3<f64>| at.frame.p + at.frame.q * pos;
        match kind {
            "free" => {
                if !at.top || at.count > 1 {
                    return Err(Problem::at(
                        el.at,
                        format!(
                            "free joint '{name}' {}; MuJoCo allows a free joint only as the one joint of a body at the top of the tree",
                            if at.top {
                                "shares its body with other joints"
                            } else {
                                "is not in a top-level body"
                            }
                        ),
                    ));
                }
                self.quaternions.push(self.qpos0.len() + 3);
                let pose = at.body;
                self.qpos0
                    .extend_from_slice(&[pose.p.x, pose.p.y, pose.p.z]);
                let c = pose.q.quaternion();
                self.qpos0.extend_from_slice(&[c.w, c.i, c.j, c.k]);
                Ok(JointSpec::new(
                    name,
                    JointKind::Floating,
                    at.parent,
                    at.child,
                ))
            }
            "hinge" | "slide" => {
                let hinge = kind == "hinge";
                let angle = |v: f64| if hinge { compiler.angle(v) } else { v };
                let axis = match get("axis") {
                    Some((v, at)) => reals::<3>(v, at, "axis")?,
                    None => [0.0, 0.0, 1.0],
                };
                let Some(unit_axis) = attrs::unit(Vector3::from(axis)) else {
                    return Err(Problem::at(
                        get("axis").map_or(el.at, |(_, at)| at),
                        format!("joint '{name}': the axis is zero or too small"),
                    ));
                };
                let unit_axis = at.frame.q * unit_axis;
                let axis = [unit_axis.x, unit_axis.y, unit_axis.z];
                let pos = match get("pos") {
                    Some((v, at)) => Vector3::from(reals::<3>(v, at, "pos")?),
                    None => Vector3::zeros(),
                };
                let pos = anchor(pos);
                let reference = match get("ref") {
                    Some((v, at)) => angle(reals::<1>(v, at, "ref")?[0]),
                    None => 0.0,
                };
                let range = match get("range") {
                    Some((v, at)) => Some((reals::<2>(v, at, "range")?, at)),
                    None => None,
                };
                let limited = match get("limited") {
                    Some(("auto", _)) | None => {
                        if !compiler.autolimits && range.is_some() {
                            return Err(Problem::at(
                                el.at,
                                format!(
                                    "joint '{name}' has a range and limited=\"auto\", but the compiler's autolimits is false: say limited=\"true\" or \"false\""
                                ),
                            ));
                        }
                        range.is_some()
                    }
                    Some((v, at)) => attrs::boolean(v, at, "limited")?,
                };
                let mut spec = JointSpec::new(
                    name,
                    if hinge {
                        if limited {
                            JointKind::Revolute
                        } else {
                            JointKind::Continuous
                        }
                    } else {
                        JointKind::Prismatic
                    },
                    at.parent,
                    at.child,
                )
                .with_axis(axis);
                if hinge {
                    let about = Pose {
                        p: pos,
                        q: UnitQuaternion::identity(),
                    };
                    spec = spec
                        .with_origin(at.body.then(&about).transform())
                        .with_offsets(-reference, 0.0);
                    if pos != Vector3::zeros() {
                        spec = spec
                            .with_post(crate::model::transform::Transform::from_translation(-pos));
                    }
                } else {
                    spec = spec
                        .with_origin(at.body.transform())
                        .with_offsets(0.0, -reference);
                }
                if limited {
                    let Some(([lo, hi], at)) = range else {
                        return Err(Problem::at(
                            el.at,
                            format!("joint '{name}' is limited but has no range"),
                        ));
                    };
                    let (lo, hi) = (angle(lo), angle(hi));
                    if lo > hi {
                        return Err(Problem::at(
                            at,
                            format!(
                                "joint '{name}': range lower bound {lo} is above the upper bound {hi}"
                            ),
                        ));
                    }
                    spec = spec.with_limits(lo, hi);
                }
                self.qpos0.push(reference);
                self.refs.push((name.to_string(), reference));
                Ok(spec)
            }
            "ball" => {
                // Turns about `pos` in the body's frame (its axis is unused); qpos0 is the
                // identity quaternion, whatever `ref` says (MuJoCo uses `ref` for hinges and
                // slides only).
                let pos = match get("pos") {
                    Some((v, at)) => Vector3::from(reals::<3>(v, at, "pos")?),
                    None => Vector3::zeros(),
                };
                let pos = anchor(pos);
                let about = Pose {
                    p: pos,
                    q: UnitQuaternion::identity(),
                };
                let mut spec = JointSpec::new(name, JointKind::Ball, at.parent, at.child)
                    .with_origin(at.body.then(&about).transform());
                if pos != Vector3::zeros() {
                    spec =
                        spec.with_post(crate::model::transform::Transform::from_translation(-pos));
                }
                let limited = match get("limited") {
                    Some(("auto", _)) | None => compiler.autolimits && get("range").is_some(),
                    Some((v, at)) => attrs::boolean(v, at, "limited")?,
                };
                if limited {
                    self.warn(
                        el.at,
                        format!(
                            "ball joint '{name}' has a range (a cone about its reference orientation): kinechain does not check it"
                        ),
                    );
                }
                self.quaternions.push(self.qpos0.len());
                self.qpos0.extend_from_slice(&[1.0, 0.0, 0.0, 0.0]);
                Ok(spec)
            }
            other => Err(Problem::at(
                type_at,
                format!(
                    "joint '{name}' has type '{other}'; MJCF's joint types are free, ball, slide and hinge"
                ),
            )),
        }
    }

    /// The placement of site `s` in its body's frame (`frame` the frames around it there).
    fn site(&self, s: &scene::Item<'_>, frame: &Pose, name: &str) -> Result<Pose, Problem> {
        let el = s.el;
        let source = &self.sources[s.source];
        let class = source.defaults.class_of(el, &s.class)?.to_string();
        let get = |n: &str| source.defaults.value(el, Kind::Site, &class, n);
        let pose = match get("fromto") {
            Some((_, at)) if get("pos").is_some() => {
                return Err(Problem::at(
                    at,
                    format!("site '{name}' has fromto and pos; MuJoCo refuses both"),
                ));
            }
            Some((v, at)) => fromto(v, at)?,
            None => {
                let (p, q) = placement(el, get, &source.compiler)?;
                Pose { p, q }
            }
        };
        Ok(frame.then(&pose))
    }

    /// The `<key>` configurations of the main model (their `qpos`, padded with `qpos0` when
    /// shorter than `nq`, as MuJoCo pads them; `qpos0` where a key gives none), unnamed ones
    /// called `keyN` (N counting keys from 0), as many more holding `qpos0` as `<size nkey>`
    /// asks for, then those of attached models (`attached`: each joint's own entries, or its
    /// `qpos0`). The quaternions of free and ball joints are normalised as MuJoCo's compiler
    /// normalises them.
    fn keyframes(&mut self, root: &Element, attached: &[String]) -> Result<(), Problem> {
        let nq = self.qpos0.len();
        let mut i = 0;
        let mut keys = Vec::new();
        for k in root
            .children_named("keyframe")
            .flat_map(|k| k.children_named("key"))
        {
            let name = k
                .attribute("name")
                .map_or_else(|| format!("key{i}"), |(n, _)| n.to_string());
            i += 1;
            let q = match k.attribute("qpos") {
                Some((v, at)) => {
                    let mut q = real_list(v, at, "qpos")?;
                    if q.len() > nq {
                        return Err(Problem::at(
                            at,
                            format!(
                                "keyframe '{name}' has {} qpos values; the model has nq = {nq}",
                                q.len()
                            ),
                        ));
                    }
                    q.extend_from_slice(&self.qpos0[q.len()..]);
                    q
                }
                None => self.qpos0.clone(),
            };
            keys.push((name, q));
        }
        // `<size nkey="N">` makes room for N keys: those the file does not give hold qpos0.
        for size in root.children_named("size") {
            if let Some((v, at)) = size.attribute("nkey") {
                let n = v.trim().parse::<usize>().map_err(|_| {
                    Problem::at(at, format!("nkey is '{v}'; it takes a whole number"))
                })?;
                if n > 10_000 {
                    return Err(Problem::at(
                        at,
                        format!("nkey is {n}; kinechain keeps at most 10000 keyframes"),
                    ));
                }
                while i < n {
                    keys.push((format!("key{i}"), self.qpos0.clone()));
                    i += 1;
                }
            }
        }
        for name in attached {
            let mut q = self.qpos0.clone();
            for (first, size, entries) in &self.joint_keys {
                if let Some((_, values)) = entries.iter().find(|(n, _)| n == name) {
                    q[*first..first + size].copy_from_slice(&values[..*size]);
                }
            }
            keys.push((name.clone(), q));
        }
        for (name, mut q) in keys {
            for &first in &self.quaternions {
                normalize_quaternion(&mut q[first..first + 4]);
            }
            self.b.keyframe(name, q);
        }
        Ok(())
    }

    /// Each active `<equality><joint>` as a mimic joint: `y − y0 = a0 + a1 (x − x0)` (`y0`, `x0`
    /// the joints' reference positions) is `y = a1 x + (a0 + y0 − a1 x0)`. A coupling with a
    /// non-zero `polycoef` beyond the second, or without `joint2`, is an error naming it.
    fn couplings(&mut self, root: &Element) -> Result<(), Problem> {
        for e in root
            .children_named("equality")
            .flat_map(|e| e.children_named("joint"))
        {
            if let Some((v, at)) = e.attribute("active")
                && !attrs::boolean(v, at, "active")?
            {
                continue;
            }
            let label = e
                .attribute("name")
                .map_or_else(String::new, |(n, _)| format!(" '{n}'"));
            let joint = |key: &str| -> Result<(String, f64), Problem> {
                let Some((name, at)) = e.attribute(key) else {
                    return Err(Problem::at(
                        e.at,
                        format!("joint coupling{label} has no {key}: kinechain couples two joints"),
                    ));
                };
                self.refs
                    .iter()
                    .find(|(n, _)| n == name)
                    .cloned()
                    .ok_or_else(|| {
                        Problem::at(
                            at,
                            format!(
                                "joint coupling{label}: '{name}' is not a hinge or slide joint"
                            ),
                        )
                    })
            };
            let (y, y0) = joint("joint1")?;
            let (x, x0) = joint("joint2")?;
            let c = match e.attribute("polycoef") {
                Some((v, at)) => reals::<5>(v, at, "polycoef")?,
                None => [0.0, 1.0, 0.0, 0.0, 0.0],
            };
            if c[2..].iter().any(|&k| k != 0.0) {
                let at = e.attribute("polycoef").map_or(e.at, |(_, at)| at);
                return Err(Problem::at(
                    at,
                    format!(
                        "joint coupling{label} of '{y}' to '{x}' is not linear (polycoef {c:?}); \
                         only linear couplings become mimic joints"
                    ),
                ));
            }
            let offset = c[0] + y0 - c[1] * x0;
            let Some(spec) = self.b.joints.iter_mut().find(|j| j.name == y) else {
                return Err(Problem::at(
                    e.at,
                    format!("joint coupling{label}: no joint '{y}'"),
                ));
            };
            *spec = spec.clone().with_mimic(x, c[1], offset);
        }
        // The followers take no entry of q: their entries leave the keyframes.
        let mut followers = Vec::new();
        let mut index = 0;
        for j in self.b.joints.iter().filter(|j| j.kind != JointKind::Fixed) {
            if j.mimic.is_some() {
                followers.push(index);
            }
            index += j.kind.nq();
        }
        for (_, q) in &mut self.b.keyframes {
            let mut k = 0;
            q.retain(|_| {
                k += 1;
                !followers.contains(&(k - 1))
            });
        }
        Ok(())
    }

    /// One warning for the equality constraints not applied (`mj_kinematics` applies none).
    fn equalities(&mut self, root: &Element, couplings: bool) {
        let mut kinds: Vec<(String, usize)> = Vec::new();
        for e in root
            .children_named("equality")
            .flat_map(|e| e.children.iter())
            .filter(|e| !(couplings && e.name == "joint"))
        {
            match kinds.iter_mut().find(|(k, _)| *k == e.name) {
                Some((_, n)) => *n += 1,
                None => kinds.push((e.name.clone(), 1)),
            }
        }
        if !kinds.is_empty() {
            let list: Vec<String> = kinds.iter().map(|(k, n)| format!("{n} {k}")).collect();
            self.b.warn(format!(
                "equality constraints ({}) are not applied: q is read as MuJoCo's mj_kinematics reads qpos",
                list.join(", ")
            ));
        }
    }
}

/// `e` (a quaternion of `qpos`) normalised as MuJoCo's `mju_normalize4` does it: the identity
/// when its norm is below `mjMINVAL` (10⁻¹⁵), unchanged when within that of 1, else divided by
/// its norm.
fn normalize_quaternion(e: &mut [f64]) {
    const MIN: f64 = 1e-15;
    let norm = (((e[0] * e[0] + e[1] * e[1]) + e[2] * e[2]) + e[3] * e[3]).sqrt();
    if norm < MIN {
        e.copy_from_slice(&[1.0, 0.0, 0.0, 0.0]);
    } else if (norm - 1.0).abs() > MIN {
        for x in e {
            *x /= norm;
        }
    }
}
