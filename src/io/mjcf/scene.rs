//! The bodies of an MJCF model as MuJoCo compiles them: `<frame>` placements folded into what
//! they hold, `<replicate>` and `<attach>` expanded with MuJoCo's names and placements, each
//! body's joints, sites and geoms in document order. Bodies are listed depth first from the
//! world, so that a body's index is its MuJoCo id, and so are joints and sites body by body
//! ([`Scene::ids`]).

use super::attrs::{Compiler, Defaults, Pose, placement, reals};
use super::tree::{At, Element, Problem};
use nalgebra::{UnitQuaternion, Vector3};

/// Deepest nesting of `<attach>` elements (an attached model attaching another, or a
/// self-attachment inside what it attaches).
const MAX_ATTACH_DEPTH: usize = 16;

/// Most bodies, joints and sites a model may expand to through `<replicate>` and `<attach>`.
pub(crate) const MAX_ELEMENTS: usize = 1 << 20;

/// A model: the main one (index 0), or one that an `<asset><model>` reads for `<attach>`.
pub(crate) struct Source {
    pub(crate) root: Element,
    pub(crate) compiler: Compiler,
    pub(crate) defaults: Defaults,
    /// The models its `<asset><model>` elements declare: (name, index into the sources).
    pub(crate) models: Vec<(String, usize)>,
}

impl Source {
    /// The source's settings read from its `<mujoco>` element.
    pub(crate) fn new(root: Element) -> Result<Source, Problem> {
        let mut compiler = Compiler::default();
        for c in root.children_named("compiler") {
            compiler.read(c)?;
        }
        let defaults = Defaults::read(&root)?;
        Ok(Source {
            root,
            compiler,
            defaults,
            models: Vec::new(),
        })
    }
}

/// How an element's name is made: `prefix + name + suffix` (`<attach>`'s prefixes, outer
/// first, and `<replicate>`'s suffixes, inner first). `key_prefix` is what an attached
/// model's keyframes are named with: the prefixes of attachments from other models only (MuJoCo
/// copies a self-attached subtree and a replica as they are, keyframe entries and all).
#[derive(Clone, Debug, Default)]
struct Naming {
    prefix: String,
    suffix: String,
    key_prefix: String,
}

impl Naming {
    fn name(&self, el: &Element) -> Option<String> {
        match el.attribute("name") {
            Some(("", _)) | None => None,
            Some((n, _)) => Some(format!("{}{n}{}", self.prefix, self.suffix)),
        }
    }
}

/// A keyframe's entries for one joint, as MuJoCo keeps them for the keyframes of an attached
/// model: (keyframe name, the joint's entries of its `qpos`).
pub(crate) type KeyEntries = Vec<(String, Vec<f64>)>;

/// An element that belongs to a body: a joint, a site, a geom or its inertial.
#[derive(Clone, Debug)]
pub(crate) struct Item<'a> {
    pub(crate) el: &'a Element,
    /// The model it comes from (its compiler settings and default classes).
    pub(crate) source: usize,
    /// Its name, with the prefixes and suffixes of the attachments and replicas around it;
    /// `None` when unnamed.
    pub(crate) name: Option<String>,
    /// The placement of the frames around it in the body's frame.
    pub(crate) frame: Pose,
    /// The default class in effect around it (a `childclass`, or `main`).
    pub(crate) class: String,
    /// A joint's entries in the keyframes of the models it was attached from.
    pub(crate) keys: KeyEntries,
}

/// A body: its element (`<worldbody>` for the world, body 0), parent, placement in the
/// parent's frame, and what it holds.
#[derive(Debug)]
pub(crate) struct Body<'a> {
    pub(crate) item: Item<'a>,
    pub(crate) parent: usize,
    pub(crate) pose: Pose,
    pub(crate) joints: Vec<Item<'a>>,
    pub(crate) sites: Vec<Item<'a>>,
    pub(crate) geoms: Vec<Item<'a>>,
    pub(crate) inertial: Option<Item<'a>>,
    pub(crate) children: usize,
}

/// The expanded model: its bodies in MuJoCo's order, and the keyframes its attachments bring
/// (names, in the order MuJoCo appends them after the model's own).
pub(crate) struct Scene<'a> {
    pub(crate) bodies: Vec<Body<'a>>,
    pub(crate) attached_keys: Vec<String>,
}

struct Collector<'a> {
    sources: &'a [Source],
    bodies: Vec<Body<'a>>,
    elements: usize,
    attached_keys: Vec<String>,
    /// Every joint met, in order: (body, index among its joints).
    joint_log: Vec<(usize, usize)>,
}

/// The scene of `sources[0]`, whose attachments come from the other sources.
pub(crate) fn collect(sources: &[Source]) -> Result<Scene<'_>, Problem> {
    let main = &sources[0].root;
    let world = main
        .children_named("worldbody")
        .next()
        .unwrap_or(&sources[0].root);
    let mut c = Collector {
        sources,
        bodies: vec![Body {
            item: Item {
                el: world,
                source: 0,
                name: Some("world".to_string()),
                frame: Pose::IDENTITY,
                class: "main".to_string(),
                keys: Vec::new(),
            },
            parent: 0,
            pose: Pose::IDENTITY,
            joints: Vec::new(),
            sites: Vec::new(),
            geoms: Vec::new(),
            inertial: None,
            children: 0,
        }],
        elements: 0,
        attached_keys: Vec::new(),
        joint_log: Vec::new(),
    };
    for w in main.children_named("worldbody") {
        if let Some((name, _, at)) = w.attributes.first() {
            return Err(Problem::at(
                *at,
                format!("<worldbody> has attribute '{name}'; the world body takes none"),
            ));
        }
        c.contents(w, 0, 0, &Pose::IDENTITY, "main", &Naming::default(), 0)?;
    }
    Ok(Scene {
        bodies: c.bodies,
        attached_keys: c.attached_keys,
    })
}

impl<'a> Collector<'a> {
    fn count(&mut self, at: At) -> Result<(), Problem> {
        self.elements += 1;
        if self.elements > MAX_ELEMENTS {
            return Err(Problem::at(
                at,
                format!("the model expands to more than {MAX_ELEMENTS} bodies, joints and sites"),
            ));
        }
        Ok(())
    }

    fn item(
        &self,
        el: &'a Element,
        source: usize,
        frame: &Pose,
        class: &str,
        n: &Naming,
    ) -> Item<'a> {
        Item {
            el,
            source,
            name: n.name(el),
            frame: *frame,
            class: class.to_string(),
            keys: Vec::new(),
        }
    }

    /// The class `el` gives its children: its `childclass`, or the one around it.
    fn childclass(&self, el: &Element, source: usize, class: &str) -> Result<String, Problem> {
        match el.attribute("childclass") {
            Some((v, at)) => {
                self.sources[source].defaults.check(v, at)?;
                Ok(v.to_string())
            }
            None => Ok(class.to_string()),
        }
    }

    /// The children of a body, a frame, a replica or the world body (`el`, of model `source`),
    /// placed by `frame` in body `body`.
    #[allow(clippy::too_many_arguments)]
    fn contents(
        &mut self,
        el: &'a Element,
        source: usize,
        body: usize,
        frame: &Pose,
        class: &str,
        n: &Naming,
        depth: usize,
    ) -> Result<(), Problem> {
        let compiler = &self.sources[source].compiler;
        for c in &el.children {
            match c.name.as_str() {
                "body" => self.body(c, source, body, frame, class, n, depth)?,
                "frame" => {
                    let inner = self.childclass(c, source, class)?;
                    let (p, q) = placement(c, |a| c.attribute(a), compiler)?;
                    let placed = frame.then(&Pose { p, q });
                    self.contents(c, source, body, &placed, &inner, n, depth)?;
                }
                "joint" | "freejoint" => {
                    if body == 0 {
                        return Err(Problem::at(
                            c.at,
                            format!(
                                "<{}> in the world body: MuJoCo's world body has no joints",
                                c.name
                            ),
                        ));
                    }
                    self.count(c.at)?;
                    let item = self.item(c, source, frame, class, n);
                    self.joint_log.push((body, self.bodies[body].joints.len()));
                    self.bodies[body].joints.push(item);
                }
                "site" => {
                    self.count(c.at)?;
                    let item = self.item(c, source, frame, class, n);
                    self.bodies[body].sites.push(item);
                }
                "geom" => {
                    self.count(c.at)?;
                    let item = self.item(c, source, frame, class, n);
                    self.bodies[body].geoms.push(item);
                }
                "inertial" if body > 0 => {
                    let item = self.item(c, source, frame, class, n);
                    self.bodies[body].inertial = Some(item);
                }
                "replicate" => self.replicate(c, source, body, frame, class, n, depth)?,
                "attach" => self.attach(c, source, body, frame, n, depth)?,
                "composite" | "flexcomp" | "flex" | "skin" => {
                    return Err(Problem::at(
                        c.at,
                        format!(
                            "<{}> makes a deformable object, which kinechain does not read (it reads rigid bodies and their joints)",
                            c.name
                        ),
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn body(
        &mut self,
        el: &'a Element,
        source: usize,
        parent: usize,
        frame: &Pose,
        class: &str,
        n: &Naming,
        depth: usize,
    ) -> Result<(), Problem> {
        self.count(el.at)?;
        let inner = self.childclass(el, source, class)?;
        let (p, q) = placement(el, |a| el.attribute(a), &self.sources[source].compiler)?;
        let index = self.bodies.len();
        let item = self.item(el, source, &Pose::IDENTITY, &inner, n);
        self.bodies.push(Body {
            item,
            parent,
            pose: frame.then(&Pose { p, q }),
            joints: Vec::new(),
            sites: Vec::new(),
            geoms: Vec::new(),
            inertial: None,
            children: 0,
        });
        self.bodies[parent].children += 1;
        self.contents(el, source, index, &Pose::IDENTITY, &inner, n, depth)
    }

    /// `<replicate count offset euler sep>`: `count` copies of its children, copy `i` turned by
    /// the Euler angles `i · euler` and placed at the sum of the offsets turned by the copies
    /// before it, its names suffixed with `sep` and `i` written with as many digits as `count`
    /// has.
    #[allow(clippy::too_many_arguments)]
    fn replicate(
        &mut self,
        el: &'a Element,
        source: usize,
        body: usize,
        frame: &Pose,
        class: &str,
        n: &Naming,
        depth: usize,
    ) -> Result<(), Problem> {
        let compiler = &self.sources[source].compiler;
        let Some((count_text, count_at)) = el.attribute("count") else {
            return Err(Problem::at(el.at, "<replicate> has no count"));
        };
        let count = match count_text.trim().parse::<usize>() {
            Ok(c) if c > 0 => c,
            _ => {
                return Err(Problem::at(
                    count_at,
                    format!("replicate count is '{count_text}'; it takes a positive whole number"),
                ));
            }
        };
        if count > MAX_ELEMENTS {
            return Err(Problem::at(
                count_at,
                format!("replicate count is {count}; kinechain makes at most {MAX_ELEMENTS}"),
            ));
        }
        let offset = match el.attribute("offset") {
            Some((v, at)) => Vector3::from(reals::<3>(v, at, "offset")?),
            None => Vector3::zeros(),
        };
        let euler = match el.attribute("euler") {
            Some((v, at)) => reals::<3>(v, at, "euler")?,
            None => [0.0; 3],
        };
        let sep = el.attribute("sep").map_or("", |(v, _)| v);
        let inner = self.childclass(el, source, class)?;
        let digits = count.to_string().len();
        let mut pos = Vector3::zeros();
        for i in 0..count {
            let k = i as f64;
            let turn = compiler.euler([k * euler[0], k * euler[1], k * euler[2]]);
            let placed = frame.then(&Pose { p: pos, q: turn });
            pos += turn * offset;
            let naming = Naming {
                prefix: n.prefix.clone(),
                suffix: format!("{sep}{i:0digits$}{}", n.suffix),
                key_prefix: n.key_prefix.clone(),
            };
            let first_joint = self.joint_log.len();
            self.contents(el, source, body, &placed, &inner, &naming, depth)?;
            // MuJoCo attaches the copies of what it read once: the keyframe entries of an
            // attached model go with the first copy only.
            if i > 0 {
                for &(b, j) in &self.joint_log[first_joint..] {
                    self.bodies[b].joints[j].keys.clear();
                }
            }
        }
        Ok(())
    }

    /// `<attach model body|frame prefix>`: a body (with its subtree), a frame (with what it
    /// holds) or the whole world body of another model, or of this one (without `model`), its
    /// names prefixed, placed by the frame around the attach element, with its own model's
    /// compiler settings and default classes.
    fn attach(
        &mut self,
        el: &'a Element,
        source: usize,
        body: usize,
        frame: &Pose,
        n: &Naming,
        depth: usize,
    ) -> Result<(), Problem> {
        if depth >= MAX_ATTACH_DEPTH {
            return Err(Problem::at(
                el.at,
                format!(
                    "attachments nest deeper than {MAX_ATTACH_DEPTH} (does a model attach itself?)"
                ),
            ));
        }
        let Some((prefix, _)) = el.attribute("prefix") else {
            return Err(Problem::at(
                el.at,
                "<attach> has no prefix; MuJoCo requires one",
            ));
        };
        let target = match (el.attribute("body"), el.attribute("frame")) {
            (Some(_), Some((_, at))) => {
                return Err(Problem::at(
                    at,
                    "<attach> names both a body and a frame; it takes one",
                ));
            }
            (Some((b, _)), None) => Some(("body", b)),
            (None, Some((f, _))) => Some(("frame", f)),
            (None, None) => None,
        };
        let from = match el.attribute("model") {
            Some((m, at)) => self.sources[source]
                .models
                .iter()
                .find(|(name, _)| name == m)
                .map(|&(_, s)| s)
                .ok_or_else(|| Problem::at(at, format!("no model asset '{m}' to attach")))?,
            None if target.is_none() => {
                return Err(Problem::at(
                    el.at,
                    "<attach> without a model attaches a body or a frame of this model: it needs body or frame",
                ));
            }
            None => source,
        };
        let naming = Naming {
            prefix: format!("{}{prefix}", n.prefix),
            suffix: n.suffix.clone(),
            key_prefix: match from == source {
                true => n.key_prefix.clone(),
                false => format!("{}{prefix}", n.key_prefix),
            },
        };
        let root = &self.sources[from].root;
        let (subtree, class_there) = match target {
            Some((kind, name)) => find(root, kind, name, "main", &self.sources[from].defaults)
                .ok_or_else(|| {
                    Problem::at(
                        el.at,
                        format!(
                            "no {kind} '{name}' in {} to attach",
                            el.attribute("model")
                                .map_or("this model".to_string(), |(m, _)| format!("model '{m}'"))
                        ),
                    )
                })?,
            None => (root, "main".to_string()),
        };
        let first_joint = self.joint_log.len();
        match target {
            Some(("body", _)) => {
                self.body(subtree, from, body, frame, &class_there, &naming, depth + 1)?;
            }
            Some(_) => {
                let inner = self.childclass(subtree, from, &class_there)?;
                let (p, q) = placement(
                    subtree,
                    |a| subtree.attribute(a),
                    &self.sources[from].compiler,
                )?;
                let placed = frame.then(&Pose { p, q });
                self.contents(subtree, from, body, &placed, &inner, &naming, depth + 1)?;
            }
            None => {
                for w in root.children_named("worldbody") {
                    self.contents(w, from, body, frame, "main", &naming, depth + 1)?;
                }
            }
        }
        if from != source {
            self.attach_keyframes(from, &naming.key_prefix, first_joint, el.at)?;
        }
        Ok(())
    }

    /// The keyframes of attached model `from`: each keyframe `K` becomes `prefix K` of this
    /// model, holding `K`'s values for the joints the attachment brought (those logged from
    /// `first_joint` on) and `qpos0` for the others. (A replica attaches again what MuJoCo
    /// attached once: the keyframe stays one, its values in every copy.)
    fn attach_keyframes(
        &mut self,
        from: usize,
        prefix: &str,
        first_joint: usize,
        at: At,
    ) -> Result<(), Problem> {
        let keys: Vec<&Element> = self.sources[from]
            .root
            .children_named("keyframe")
            .flat_map(|k| k.children_named("key"))
            .collect();
        if keys.is_empty() {
            return Ok(());
        }
        // The attached joints are a run of the attached model's own joints, in its qpos order.
        let layout = model_joints(self.sources, from)?;
        let brought: Vec<(usize, usize)> = self.joint_log[first_joint..].to_vec();
        let start = brought.first().and_then(|&(b, j)| {
            let el = self.bodies[b].joints[j].el as *const Element;
            layout.iter().position(|&(e, _)| e == el)
        });
        let nq: usize = layout.iter().map(|(_, n)| n).sum();
        for (i, key) in keys.iter().enumerate() {
            let name = key
                .attribute("name")
                .map_or_else(|| format!("key{i}"), |(n, _)| n.to_string());
            let name = format!("{prefix}{name}");
            if let (Some((text, qat)), Some(start)) = (key.attribute("qpos"), start) {
                let qpos = super::attrs::real_list(text, qat, "qpos")?;
                if qpos.len() != nq {
                    return Err(Problem::at(
                        at,
                        format!(
                            "the attached model's keyframe '{name}' has {} qpos values; that model has nq = {nq}",
                            qpos.len()
                        ),
                    ));
                }
                let mut adr: usize = layout[..start].iter().map(|(_, n)| n).sum();
                for (k, &(b, j)) in brought.iter().enumerate() {
                    let Some(&(el, size)) = layout.get(start + k) else {
                        break;
                    };
                    let item = &mut self.bodies[b].joints[j];
                    if !std::ptr::eq(item.el, el) {
                        break;
                    }
                    item.keys.retain(|(n, _)| *n != name);
                    item.keys
                        .push((name.clone(), qpos[adr..adr + size].to_vec()));
                    adr += size;
                }
            }
            if !self.attached_keys.contains(&name) {
                self.attached_keys.push(name);
            }
        }
        Ok(())
    }
}

/// The joints of model `source` in its own `qpos` order (its attachments' included), each with
/// its number of entries (free 7, ball 4, hinge and slide 1).
fn model_joints(
    sources: &[Source],
    source: usize,
) -> Result<Vec<(*const Element, usize)>, Problem> {
    let root = &sources[source].root;
    let mut c = Collector {
        sources,
        bodies: vec![Body {
            item: Item {
                el: root,
                source,
                name: None,
                frame: Pose::IDENTITY,
                class: "main".into(),
                keys: Vec::new(),
            },
            parent: 0,
            pose: Pose::IDENTITY,
            joints: Vec::new(),
            sites: Vec::new(),
            geoms: Vec::new(),
            inertial: None,
            children: 0,
        }],
        elements: 0,
        attached_keys: Vec::new(),
        joint_log: Vec::new(),
    };
    for w in root.children_named("worldbody") {
        c.contents(w, source, 0, &Pose::IDENTITY, "main", &Naming::default(), 1)?;
    }
    Ok(c.bodies
        .iter()
        .flat_map(|b| b.joints.iter())
        .map(|j| (j.el as *const Element, joint_size(j, &sources[j.source])))
        .collect())
}

/// The entries of `qpos` joint `j` takes.
fn joint_size(j: &Item<'_>, source: &Source) -> usize {
    if j.el.name == "freejoint" {
        return 7;
    }
    let class = j.el.attribute("class").map_or(j.class.as_str(), |(c, _)| c);
    match source
        .defaults
        .value(j.el, super::attrs::Kind::Joint, class, "type")
        .map(|(t, _)| t)
    {
        Some("free") => 7,
        Some("ball") => 4,
        _ => 1,
    }
}

/// The element `kind` (`body` or `frame`) named `name` under `el` (not inside another
/// model's), with the default class in effect at it.
fn find<'e>(
    el: &'e Element,
    kind: &str,
    name: &str,
    class: &str,
    defaults: &Defaults,
) -> Option<(&'e Element, String)> {
    for c in &el.children {
        let inner = match c.attribute("childclass") {
            Some((v, at)) if defaults.check(v, at).is_ok() => v.to_string(),
            _ => class.to_string(),
        };
        if c.name == kind && c.attribute("name").is_some_and(|(n, _)| n == name) {
            return Some((c, class.to_string()));
        }
        if matches!(
            c.name.as_str(),
            "worldbody" | "body" | "frame" | "replicate"
        ) && let Some(found) = find(c, kind, name, &inner, defaults)
        {
            return Some(found);
        }
    }
    None
}

impl Compiler {
    /// The rotation of Euler angles in the compiler's units and sequence.
    pub(crate) fn euler(&self, angles: [f64; 3]) -> UnitQuaternion<f64> {
        let mut q = UnitQuaternion::identity();
        for (&axis, angle) in self.eulerseq.iter().zip(angles) {
            let unit = match axis.to_ascii_lowercase() {
                b'x' => Vector3::x_axis(),
                b'y' => Vector3::y_axis(),
                _ => Vector3::z_axis(),
            };
            let turn = UnitQuaternion::from_axis_angle(&unit, self.angle(angle));
            // Lower case: about the moving axes (post-multiplied); upper case: about the
            // fixed ones (pre-multiplied).
            q = if axis.is_ascii_lowercase() {
                q * turn
            } else {
                turn * q
            };
        }
        q
    }
}
