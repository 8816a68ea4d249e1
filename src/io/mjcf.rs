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
mod tree;

use crate::io::error::LoadErrorKind;
use crate::model::builder::{ChainBuilder, JointSpec};
use crate::model::joint::JointKind;
use attrs::{Compiler, Defaults, Kind, placement, real_list, reals, transform};
use nalgebra::{UnitQuaternion, Vector3};
use std::collections::HashSet;
use std::path::Path;
use tree::{Element, Problem};

/// A position and an orientation: where a frame is in its parent's.
#[derive(Clone, Copy, Debug)]
struct Pose {
    p: Vector3<f64>,
    q: UnitQuaternion<f64>,
}

impl Pose {
    const IDENTITY: Pose = Pose {
        p: Vector3::new(0.0, 0.0, 0.0),
        q: UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(1.0, 0.0, 0.0, 0.0)),
    };

    /// `self` then `then` (in `self`'s frame).
    fn then(&self, then: &Pose) -> Pose {
        Pose {
            p: self.p + self.q * then.p,
            q: self.q * then.q,
        }
    }

    fn transform(&self) -> crate::model::transform::Transform {
        transform(&self.p, &self.q)
    }
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
    let tree = tree::read(text, main, base, max_bytes)?;
    read_model(&tree.root, default_name, couplings).map_err(|p| p.into_kind(&tree.files))
}

fn read_model(
    root: &Element,
    default_name: &str,
    couplings: bool,
) -> Result<ChainBuilder, Problem> {
    let mut compiler = Compiler::default();
    for c in root.children_named("compiler") {
        compiler.read(c)?;
    }
    let defaults = Defaults::read(root)?;
    let name = root.attribute("model").map_or(default_name, |(v, _)| v);
    let mut reader = Reader {
        compiler,
        defaults,
        b: ChainBuilder::new(name),
        bodies: HashSet::new(),
        joint_names: HashSet::new(),
        link_names: HashSet::new(),
        counts: Counts::default(),
        qpos0: Vec::new(),
        refs: Vec::new(),
        quaternions: Vec::new(),
    };
    let worlds: Vec<&Element> = root.children_named("worldbody").collect();
    for w in &worlds {
        reader.body_names(w);
    }
    reader.add_link("world");
    for w in &worlds {
        reader.contents(w, "world", &Pose::IDENTITY, "main", true)?;
    }
    reader.keyframes(root)?;
    if couplings {
        reader.couplings(root)?;
    }
    reader.equalities(root, couplings);
    Ok(reader.b)
}

/// Elements that would add bodies or joints kinechain does not read.
const UNSUPPORTED: [&str; 5] = ["replicate", "attach", "composite", "flexcomp", "skin"];

#[derive(Default)]
struct Counts {
    bodies: usize,
    joints: usize,
    sites: usize,
}

struct Reader {
    compiler: Compiler,
    defaults: Defaults,
    b: ChainBuilder,
    /// Every body's name (sites that share one get a qualified name).
    bodies: HashSet<String>,
    joint_names: HashSet<String>,
    link_names: HashSet<String>,
    counts: Counts,
    /// MuJoCo's `qpos0`: what a keyframe without `qpos` holds.
    qpos0: Vec<f64>,
    /// Each hinge or slide joint's name and reference position (`qpos0`).
    refs: Vec<(String, f64)>,
    /// Where each free or ball joint's quaternion starts in `qpos`.
    quaternions: Vec<usize>,
}

impl Reader {
    fn body_names(&mut self, el: &Element) {
        for c in &el.children {
            if c.name == "body"
                && let Some((n, _)) = c.attribute("name")
            {
                self.bodies.insert(n.to_string());
            }
            if c.name == "body" || c.name == "frame" {
                self.body_names(c);
            }
        }
    }

    fn add_link(&mut self, name: &str) {
        self.link_names.insert(name.to_string());
        self.b.link(name);
    }

    /// `base`, or `base_1`, `base_2`, … : the first no joint has (generated names only).
    fn joint_name(&mut self, base: String) -> String {
        let name = std::iter::once(base.clone())
            .chain((1..).map(|i| format!("{base}_{i}")))
            .find(|n| !self.joint_names.contains(n))
            .unwrap_or(base);
        self.joint_names.insert(name.clone());
        name
    }

    /// The children of a body, a frame or the world body, placed by `frame` in link `link`.
    fn contents(
        &mut self,
        el: &Element,
        link: &str,
        frame: &Pose,
        class: &str,
        top: bool,
    ) -> Result<(), Problem> {
        for c in &el.children {
            match c.name.as_str() {
                "body" => self.body(c, link, frame, class, top)?,
                "frame" => {
                    let inner = self.childclass(c, class)?;
                    let (p, q) = placement(c, |n| c.attribute(n), &self.compiler)?;
                    let placed = frame.then(&Pose { p, q });
                    self.contents(c, link, &placed, &inner, top)?;
                }
                "site" => self.site(c, link, frame, class)?,
                "joint" | "freejoint" if el.name == "frame" => {
                    return Err(Problem::at(
                        c.at,
                        format!("<{}> inside a <frame>: a joint belongs to a body", c.name),
                    ));
                }
                name if UNSUPPORTED.contains(&name) => {
                    return Err(Problem::at(
                        c.at,
                        format!(
                            "<{name}> is not supported: kinechain reads bodies and joints written out"
                        ),
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }

    fn childclass(&self, el: &Element, class: &str) -> Result<String, Problem> {
        match el.attribute("childclass") {
            Some((v, at)) => {
                self.defaults.check(v, at)?;
                Ok(v.to_string())
            }
            None => Ok(class.to_string()),
        }
    }

    fn body(
        &mut self,
        el: &Element,
        parent: &str,
        frame: &Pose,
        class: &str,
        top: bool,
    ) -> Result<(), Problem> {
        self.counts.bodies += 1;
        let name = match el.attribute("name") {
            Some((n, _)) => n.to_string(),
            None => format!("body{}", self.counts.bodies),
        };
        let class = self.childclass(el, class)?;
        let (p, q) = placement(el, |n| el.attribute(n), &self.compiler)?;
        let pose = frame.then(&Pose { p, q });
        if let Some((v, at)) = el.attribute("mocap")
            && attrs::boolean(v, at, "mocap")?
        {
            self.b.warn(format!(
                "body '{name}' is a mocap body: it is fixed where the file places it (MuJoCo's \
                 mocap_pos and mocap_quat at their defaults)"
            ));
        }
        let joints: Vec<&Element> = el
            .children
            .iter()
            .filter(|c| c.name == "joint" || c.name == "freejoint")
            .collect();
        if joints.is_empty() {
            let joint = self.joint_name(format!("{name}/weld"));
            self.add_link(&name);
            self.b.joint(
                JointSpec::new(joint, JointKind::Fixed, parent, name.as_str())
                    .with_origin(pose.transform()),
            );
        } else {
            let mut from = parent.to_string();
            for (i, j) in joints.iter().enumerate() {
                let last = i + 1 == joints.len();
                let jname = self.joint_label(j);
                let to = if last {
                    name.clone()
                } else {
                    format!("{name}/{jname}")
                };
                let placed = if i == 0 { pose } else { Pose::IDENTITY };
                let spec = self.joint(j, &jname, &from, &to, &placed, &class, top, joints.len())?;
                self.add_link(&to);
                self.b.joint(spec);
                from = to;
            }
        }
        self.contents(el, &name, &Pose::IDENTITY, &class, false)
    }

    fn joint_label(&mut self, j: &Element) -> String {
        self.counts.joints += 1;
        match j.attribute("name") {
            Some((n, _)) => {
                self.joint_names.insert(n.to_string());
                n.to_string()
            }
            None => {
                let n = self.counts.joints;
                self.joint_name(format!("joint{n}"))
            }
        }
    }

    /// The joint `el` of a body placed at `pose` in link `parent`, moving link `child`.
    #[allow(clippy::too_many_arguments)]
    fn joint(
        &mut self,
        el: &Element,
        name: &str,
        parent: &str,
        child: &str,
        pose: &Pose,
        class: &str,
        top: bool,
        count: usize,
    ) -> Result<JointSpec, Problem> {
        let free = el.name == "freejoint";
        let class = if free {
            "main"
        } else {
            self.defaults.class_of(el, class)?
        };
        let get = |n: &str| {
            if free {
                el.attribute(n)
            } else {
                self.defaults.value(el, Kind::Joint, class, n)
            }
        };
        let kind = if free {
            "free"
        } else {
            get("type").map_or("hinge", |(v, _)| v)
        };
        let type_at = get("type").map_or(el.at, |(_, at)| at);
        match kind {
            "free" => {
                if !top || count > 1 {
                    return Err(Problem::at(
                        el.at,
                        format!(
                            "free joint '{name}' {}; MuJoCo allows a free joint only as the one joint of a body at the top of the tree",
                            if top {
                                "shares its body with other joints"
                            } else {
                                "is not in a top-level body"
                            }
                        ),
                    ));
                }
                self.quaternions.push(self.qpos0.len() + 3);
                self.qpos0
                    .extend_from_slice(&[pose.p.x, pose.p.y, pose.p.z]);
                let c = pose.q.quaternion();
                self.qpos0.extend_from_slice(&[c.w, c.i, c.j, c.k]);
                Ok(JointSpec::new(name, JointKind::Floating, parent, child))
            }
            "hinge" | "slide" => {
                let hinge = kind == "hinge";
                let angle = |v: f64| if hinge { self.compiler.angle(v) } else { v };
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
                let axis = [unit_axis.x, unit_axis.y, unit_axis.z];
                let pos = match get("pos") {
                    Some((v, at)) => Vector3::from(reals::<3>(v, at, "pos")?),
                    None => Vector3::zeros(),
                };
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
                        if !self.compiler.autolimits && range.is_some() {
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
                    parent,
                    child,
                )
                .with_axis(axis);
                if hinge {
                    let at = Pose {
                        p: pos,
                        q: UnitQuaternion::identity(),
                    };
                    spec = spec
                        .with_origin(pose.then(&at).transform())
                        .with_offsets(-reference, 0.0);
                    if pos != Vector3::zeros() {
                        spec = spec
                            .with_post(crate::model::transform::Transform::from_translation(-pos));
                    }
                } else {
                    spec = spec
                        .with_origin(pose.transform())
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
                let at = Pose {
                    p: pos,
                    q: UnitQuaternion::identity(),
                };
                let mut spec = JointSpec::new(name, JointKind::Ball, parent, child)
                    .with_origin(pose.then(&at).transform());
                if pos != Vector3::zeros() {
                    spec =
                        spec.with_post(crate::model::transform::Transform::from_translation(-pos));
                }
                let limited = match get("limited") {
                    Some(("auto", _)) | None => self.compiler.autolimits && get("range").is_some(),
                    Some((v, at)) => attrs::boolean(v, at, "limited")?,
                };
                if limited {
                    self.b.warn(format!(
                        "ball joint '{name}' has a range (a cone about its reference orientation): kinechain does not check it"
                    ));
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

    fn site(&mut self, el: &Element, link: &str, frame: &Pose, class: &str) -> Result<(), Problem> {
        self.counts.sites += 1;
        let class = self.defaults.class_of(el, class)?.to_string();
        let get = |n: &str| self.defaults.value(el, Kind::Site, &class, n);
        let pose = match get("fromto") {
            Some((_, at)) if get("pos").is_some() => {
                return Err(Problem::at(
                    at,
                    "a site with fromto cannot also have pos (MuJoCo refuses both)",
                ));
            }
            Some((v, at)) => {
                let [a, b, c, d, e, f] = reals::<6>(v, at, "fromto")?;
                let (from, to) = (Vector3::new(a, b, c), Vector3::new(d, e, f));
                // MuJoCo turns the site's z axis to point from `to` to `from`.
                let axis = attrs::unit(from - to).ok_or_else(|| {
                    Problem::at(
                        at,
                        "fromto: the two points coincide (or their distance overflows)",
                    )
                })?;
                Pose {
                    p: (from + to) * 0.5,
                    q: attrs::z_to(&axis),
                }
            }
            None => {
                let (p, q) = placement(el, get, &self.compiler)?;
                Pose { p, q }
            }
        };
        let given = el.attribute("name").map(|(n, _)| n.to_string());
        let base = match &given {
            Some(n) if self.bodies.contains(n) || self.link_names.contains(n) => {
                format!("site:{n}")
            }
            Some(n) => n.clone(),
            None => format!("site{}", self.counts.sites),
        };
        if self.link_names.contains(&base) {
            return Err(Problem::at(
                el.at,
                format!("site '{base}' has the name of another site or body"),
            ));
        }
        let joint = self.joint_name(format!("{base}/site"));
        self.add_link(&base);
        self.b.joint(
            JointSpec::new(joint, JointKind::Fixed, link, base.as_str())
                .with_origin(frame.then(&pose).transform()),
        );
        Ok(())
    }

    /// The `<key>` configurations (their `qpos`, with the quaternions of free and ball joints
    /// normalised as MuJoCo's compiler normalises them, or `qpos0` where a key gives none), unnamed
    /// ones called `keyN` (N counting keys from 0), and as many more holding `qpos0` as
    /// `<size nkey>` asks for.
    fn keyframes(&mut self, root: &Element) -> Result<(), Problem> {
        let nq = self.qpos0.len();
        let mut i = 0;
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
                    let q = real_list(v, at, "qpos")?;
                    if q.len() != nq {
                        return Err(Problem::at(
                            at,
                            format!(
                                "keyframe '{name}' has {} qpos values; the model has nq = {nq}",
                                q.len()
                            ),
                        ));
                    }
                    q
                }
                None => self.qpos0.clone(),
            };
            let mut q = q;
            for &first in &self.quaternions {
                normalize_quaternion(&mut q[first..first + 4]);
            }
            self.b.keyframe(name, q);
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
                    self.b.keyframe(format!("key{i}"), self.qpos0.clone());
                    i += 1;
                }
            }
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
