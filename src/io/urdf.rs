//! URDF read through `roxmltree`, a conforming XML parser that keeps the position of every node.
//!
//! The kinematic elements (`<robot>`, `<link>`, `<joint>` and a joint's `<origin>`, `<parent>`,
//! `<child>`, `<axis>`, `<limit>`, `<mimic>`) are taken from the parsed tree with strict checks;
//! every error names the line and column of the element or attribute at fault. Everything else
//! (visuals, collisions, inertials, materials, transmissions, Gazebo and vendor elements) cannot
//! change a pose: it is skipped, and what is malformed in it draws a warning, never a refusal.
//! XML that is not well-formed is an error, stated as such.

use crate::io::error::{FieldProblem, LoadErrorKind};
use crate::model::builder::{ChainBuilder, JointSpec};
use crate::model::joint::{JointKind, Limits};
use crate::model::transform::Transform;
use roxmltree::{Document, Node, ParsingOptions};
use xml_errors::{BYTES_PER_NODE, line_column, too_many_nodes, xml_error};

mod links;
mod planar;
pub(crate) mod xml_errors;

/// Deepest element nesting accepted (real URDFs nest about 6 deep).
pub(crate) const MAX_XML_DEPTH: usize = 100;

/// Nodes any file may hold, however short.
const MIN_NODES: usize = 4096;

/// Most warnings listed one by one; the rest are counted.
const MAX_WARNINGS: usize = 20;

/// The namespace URI of xacro, the ROS macro language.
const XACRO_URI: &str = "http://www.ros.org/wiki/xacro";

/// Where the `<link>` and `<joint>` elements of a URDF start (byte offsets, in the order of the
/// chain description's links and joints), to place the errors of building the chain.
pub(crate) struct Places {
    links: Vec<usize>,
    joints: Vec<usize>,
}

impl Places {
    /// `kind` with the line and column of the element its model error names, if it is one.
    pub(crate) fn locate(
        &self,
        source: &str,
        builder: &ChainBuilder,
        kind: LoadErrorKind,
    ) -> LoadErrorKind {
        let LoadErrorKind::Model {
            line: None, error, ..
        } = kind
        else {
            return kind;
        };
        let nth_named = |names: &mut dyn Iterator<Item = &str>, name: &str, n: usize| {
            names
                .enumerate()
                .filter(|(_, x)| *x == name)
                .nth(n)
                .map(|(i, _)| i)
        };
        let joint = |name: &str, n: usize| {
            nth_named(
                &mut builder.joints().iter().map(|j| j.name.as_str()),
                name,
                n,
            )
            .and_then(|i| self.joints.get(i))
        };
        let link = |name: &str, n: usize| {
            nth_named(&mut builder.links().iter().map(String::as_str), name, n)
                .and_then(|i| self.links.get(i))
        };
        use crate::model::error::ModelError as M;
        let offset = match &error {
            M::DuplicateJoint { name } => joint(name, 1),
            M::DuplicateLink { name } => link(name, 1),
            M::EmptyName { what: "joint" } => joint("", 0),
            M::EmptyName { .. } => link("", 0),
            M::TwoParents { second, .. } => joint(second, 0),
            M::MultipleRoots { roots } => roots.get(1).and_then(|r| link(r, 0)),
            M::UnknownLink { joint: j, .. }
            | M::UnknownMimicTarget { joint: j, .. }
            | M::BadMimicTarget { joint: j, .. }
            | M::BadMimicKind { joint: j, .. }
            | M::MimicCycle { joint: j }
            | M::Cycle { joint: j }
            | M::NonFinite { joint: j, .. }
            | M::ZeroAxis { joint: j }
            | M::ReversedLimits { joint: j, .. }
            | M::NotRigid { joint: j, .. } => joint(j, 0),
            _ => None,
        };
        let (line, column) = match offset {
            Some(&at) => {
                let (l, c) = line_column(source, at);
                (Some(l), Some(c))
            }
            None => (None, None),
        };
        LoadErrorKind::Model {
            line,
            column,
            error,
        }
    }
}

/// Parses URDF text into a chain description, with where its links and joints are.
pub(crate) fn parse(source: &str) -> Result<(ChainBuilder, Places), LoadErrorKind> {
    let limit = (source.len() / BYTES_PER_NODE).max(MIN_NODES);
    if source.bytes().filter(|&b| b == b'<').count() > 2 * limit {
        return Err(too_many_nodes(limit));
    }
    let options = ParsingOptions {
        allow_dtd: false,
        nodes_limit: u32::try_from(limit).unwrap_or(u32::MAX),
        ..ParsingOptions::default()
    };
    // An XML declaration after white space (a blank first line) is not XML, but a common slip
    // that changes nothing of the document; it is read as a processing instruction of the same
    // length, so that every position stays where it is in the file.
    let late = late_declaration(source);
    let patched;
    let text = match late {
        Some(at) => {
            patched = format!("{}<?xm-{}", &source[..at], &source[at + 5..]);
            patched.as_str()
        }
        None => source,
    };
    let doc =
        Document::parse_with_options(text, options).map_err(|e| xml_error(text, &e, limit))?;
    check_depth(&doc)?;
    check_xacro(&doc)?;
    let robot = doc.root_element();
    let mut reader = Reader {
        doc: &doc,
        notes: Notes::default(),
    };
    if qualified_name(&doc, robot) != "robot" {
        return Err(reader.error(
            robot.range().start,
            format!(
                "the root element is <{}>; a URDF file's is <robot>",
                qualified_name(&doc, robot)
            ),
        ));
    }
    let Some(name) = robot.attribute("name") else {
        return Err(reader.error(
            robot.range().start,
            "<robot> has no name attribute (URDF requires one)".into(),
        ));
    };
    if let Some(at) = late {
        reader.notes.add(at, || {
            "the XML declaration <?xml ...?> is not at the start of the file, as XML requires; read anyway".into()
        });
    }
    let mut b = ChainBuilder::new(name);
    let mut places = Places {
        links: Vec::new(),
        joints: Vec::new(),
    };
    for node in reader.elements(robot, "text inside <robot> is not URDF and is ignored") {
        match qualified_name(&doc, node) {
            "link" => {
                let name = reader.required(node, "name", "<link>")?;
                reader.link_contents(node, name);
                b.link(name);
                places.links.push(node.range().start);
            }
            "joint" => {
                let (spec, planar) = reader.joint(node)?;
                if planar {
                    let (links, joints) = planar::decompose(spec);
                    for link in links {
                        b.link(link);
                        places.links.push(node.range().start);
                    }
                    for joint in joints {
                        b.joint(joint);
                        places.joints.push(node.range().start);
                    }
                } else {
                    b.joint(spec);
                    places.joints.push(node.range().start);
                }
            }
            "material" | "transmission" | "gazebo" | "ros2_control" | "sensor" => {}
            other if other.contains(':') => {}
            other => reader.notes.add(node.range().start, || {
                format!("<{other}> is not a URDF element under <robot> and is ignored")
            }),
        }
    }
    for warning in reader.notes.numbered(&doc) {
        b.warn(warning);
    }
    Ok((b, places))
}

/// Where an XML declaration starts that white space precedes, if the file starts so.
fn late_declaration(source: &str) -> Option<usize> {
    let body = source.trim_start_matches('\u{feff}');
    let at = source.len() - body.trim_start().len();
    (at > source.len() - body.len() && source[at..].starts_with("<?xml")).then_some(at)
}

/// The 1-based line and column of byte `offset` of the document.
fn place(doc: &Document<'_>, offset: usize) -> (u32, u32) {
    let pos = doc.text_pos_at(offset);
    (pos.row, pos.col)
}

/// Refuses element nesting deeper than [`MAX_XML_DEPTH`].
fn check_depth(doc: &Document<'_>) -> Result<(), LoadErrorKind> {
    // Nodes come in document order, so a node's parent has its depth when the node is reached.
    let mut depth = vec![0u32; doc.descendants().count() + 1];
    for node in doc.descendants() {
        let d = node
            .parent()
            .map_or(0, |p| depth[p.id().get_usize()].saturating_add(1));
        depth[node.id().get_usize()] = d;
        if node.is_element() && d as usize > MAX_XML_DEPTH {
            let (line, column) = place(doc, node.range().start);
            return Err(LoadErrorKind::Urdf {
                line: Some(line),
                column: Some(column),
                message: format!("elements nest deeper than {MAX_XML_DEPTH} levels"),
            });
        }
    }
    Ok(())
}

/// Refuses a file that still holds xacro macros: what they would expand to is not in it.
fn check_xacro(doc: &Document<'_>) -> Result<(), LoadErrorKind> {
    for node in doc.descendants().filter(Node::is_element) {
        let found = if node.tag_name().namespace() == Some(XACRO_URI)
            || qualified_name(doc, node).starts_with("xacro:")
        {
            Some((
                node.range().start,
                format!("<{}>", qualified_name(doc, node)),
            ))
        } else {
            node.attributes()
                .find(|a| {
                    a.namespace() == Some(XACRO_URI)
                        || doc.input_text()[a.range_qname()].starts_with("xacro:")
                })
                .map(|a| {
                    (
                        a.range().start,
                        format!("attribute {}", &doc.input_text()[a.range_qname()]),
                    )
                })
        };
        if let Some((offset, what)) = found {
            let (line, column) = place(doc, offset);
            return Err(LoadErrorKind::Urdf {
                line: Some(line),
                column: Some(column),
                message: format!("{what}: a xacro element or attribute that was not expanded"),
            });
        }
    }
    Ok(())
}

/// An element's name as written, with its namespace prefix if it has one (`xacro:macro`).
fn qualified_name<'i>(doc: &Document<'i>, node: Node<'_, 'i>) -> &'i str {
    let text: &'i str = doc.input_text();
    let start = node.range().start + 1;
    let rest = &text[start..];
    let len = rest
        .find(|c: char| c.is_whitespace() || c == '/' || c == '>')
        .unwrap_or(rest.len());
    &rest[..len]
}

/// The elements URDF defines inside `<joint>`, each with its attributes when they take part in
/// the kinematics (`None`: dynamics, calibration and safety data, which vendors extend with
/// attributes of their own, are not checked).
const JOINT_PARTS: [(&str, Option<&[&str]>); 9] = [
    ("origin", Some(&["xyz", "rpy"])),
    ("parent", Some(&["link"])),
    ("child", Some(&["link"])),
    ("axis", Some(&["xyz"])),
    ("limit", Some(&["lower", "upper", "effort", "velocity"])),
    ("mimic", Some(&["joint", "multiplier", "offset"])),
    ("dynamics", None),
    ("calibration", None),
    ("safety_controller", None),
];

/// Reads the elements of one document, collecting warnings.
struct Reader<'d, 'i> {
    doc: &'d Document<'i>,
    notes: Notes,
}

/// The kinematic children of a `<joint>`, each the first of its name.
#[derive(Default)]
struct JointParts<'d, 'i> {
    origin: Option<Node<'d, 'i>>,
    parent: Option<Node<'d, 'i>>,
    child: Option<Node<'d, 'i>>,
    axis: Option<Node<'d, 'i>>,
    limit: Option<Node<'d, 'i>>,
    mimic: Option<Node<'d, 'i>>,
}

impl<'d, 'i> Reader<'d, 'i> {
    /// A [`LoadErrorKind::Urdf`] at byte `offset`.
    fn error(&self, offset: usize, message: String) -> LoadErrorKind {
        let (line, column) = place(self.doc, offset);
        LoadErrorKind::Urdf {
            line: Some(line),
            column: Some(column),
            message,
        }
    }

    /// A [`LoadErrorKind::Field`] of joint `joint` at byte `offset`.
    fn field(
        &self,
        offset: usize,
        joint: &str,
        field: &str,
        problem: FieldProblem,
    ) -> LoadErrorKind {
        let (line, column) = place(self.doc, offset);
        LoadErrorKind::Field {
            line: Some(line),
            column: Some(column),
            joint: Some(joint.to_string()),
            field: field.to_string(),
            problem,
        }
    }

    /// The attribute `attr` of `node`, which URDF requires: an error naming the element
    /// (`what`: `<link>`, `joint 'j'`, `joint 'j': <parent>`) without it.
    fn required(
        &self,
        node: Node<'d, 'i>,
        attr: &str,
        what: &str,
    ) -> Result<&'d str, LoadErrorKind> {
        node.attribute(attr).ok_or_else(|| {
            self.error(
                node.range().start,
                format!("{what} has no {attr} attribute (URDF requires one)"),
            )
        })
    }

    /// The element children of `node`, with the warning `text` for any of its text that is more
    /// than white space (URDF's `<robot>`, `<link>` and `<joint>` hold elements only).
    fn elements(&mut self, node: Node<'d, 'i>, text: &str) -> Vec<Node<'d, 'i>> {
        for child in node.children().filter(Node::is_text) {
            self.stray_text(child, text);
        }
        node.children().filter(Node::is_element).collect()
    }

    /// A warning for a text node that holds more than white space.
    fn stray_text(&mut self, node: Node<'_, '_>, message: &str) {
        let text = node.text().unwrap_or("");
        if let Some(at) = text.find(|c: char| !c.is_whitespace()) {
            // A text node's range covers its source text; entities may make the decoded text
            // shorter, so the offset is only used when it is inside the range.
            let range = node.range();
            let offset = if range.start + at < range.end {
                range.start + at
            } else {
                range.start
            };
            self.notes.add(offset, || message.to_string());
        }
    }

    /// The joint element `node` as a [`JointSpec`], and whether it is a planar joint (then the
    /// spec is its rotation's, for [`planar::decompose`] to split).
    fn joint(&mut self, node: Node<'d, 'i>) -> Result<(JointSpec, bool), LoadErrorKind> {
        let start = node.range().start;
        let name = self.required(node, "name", "<joint>")?;
        let label = format!("joint '{name}'");
        let type_name = self.required(node, "type", &label)?;
        // (`dont_collapse` is SDFormat's, on fixed joints it must not merge away: no kinematic
        // meaning, and common in vendor files.)
        for attr in node.attributes() {
            let qname = &self.doc.input_text()[attr.range_qname()];
            if !qname.contains(':') && !["name", "type", "dont_collapse"].contains(&qname) {
                self.notes.add(attr.range().start, || {
                    format!(
                        "{label}: attribute {qname} is not a URDF joint attribute and is ignored"
                    )
                });
            }
        }
        let type_offset = node
            .attribute_node("type")
            .map_or(start, |a| a.range_value().start);
        let kind = match type_name {
            "revolute" => JointKind::Revolute,
            "continuous" => JointKind::Continuous,
            "prismatic" => JointKind::Prismatic,
            "fixed" => JointKind::Fixed,
            "floating" => JointKind::Floating,
            // Split by `planar::decompose`; read here as its rotation about the axis.
            "planar" => JointKind::Continuous,
            other => {
                return Err(self.field(
                    type_offset,
                    name,
                    "type",
                    FieldProblem::UnsupportedJointType {
                        kind: other.to_string(),
                    },
                ));
            }
        };
        let parts = self.joint_parts(node, name, &label)?;
        let link = |part: Option<Node<'d, 'i>>, role: &str| -> Result<&'d str, LoadErrorKind> {
            let Some(part) = part else {
                return Err(self.error(start, format!("{label} has no <{role}> element")));
            };
            self.required(part, "link", &format!("{label}: <{role}>"))
        };
        let parent = link(parts.parent, "parent")?;
        let child = link(parts.child, "child")?;
        let mut spec = JointSpec::new(name, kind, parent, child);
        if let Some(origin) = parts.origin {
            let xyz = self.vector(origin, name, "origin", "xyz", [0.0; 3])?;
            let rpy = self.vector(origin, name, "origin", "rpy", [0.0; 3])?;
            spec = spec.with_origin(Transform::from_xyz_rpy(xyz, rpy));
        }
        if !matches!(kind, JointKind::Fixed | JointKind::Floating) {
            let axis = match parts.axis {
                Some(axis) => self.vector(axis, name, "axis", "xyz", [1.0, 0.0, 0.0])?,
                None => [1.0, 0.0, 0.0],
            };
            if axis == [0.0; 3] {
                let offset = parts.axis.map_or(start, |a| a.range().start);
                return Err(self.field(offset, name, "axis.xyz", FieldProblem::ZeroAxis));
            }
            spec = spec.with_axis(axis);
        }
        match kind {
            JointKind::Revolute | JointKind::Prismatic => {
                let Some(limit) = parts.limit else {
                    return Err(self.field(
                        start,
                        name,
                        "limit",
                        FieldProblem::MissingLimit {
                            kind: kind.as_str(),
                        },
                    ));
                };
                spec.limits[0] = self.limits(limit, name, &label)?;
            }
            _ => {
                if let Some(limit) = parts.limit {
                    self.unused_numbers(limit, &label, &["lower", "upper", "effort", "velocity"]);
                }
            }
        }
        let planar = type_name == "planar";
        if let Some(mimic) = parts.mimic {
            if planar {
                return Err(self.error(
                    mimic.range().start,
                    format!(
                        "{label}: a planar joint has three coordinates and cannot follow another"
                    ),
                ));
            }
            if kind == JointKind::Fixed {
                self.notes.add(mimic.range().start, || {
                    format!("{label}: a fixed joint cannot follow another; its <mimic> is ignored")
                });
            } else {
                let target = self.required(mimic, "joint", &format!("{label}: <mimic>"))?;
                let multiplier = self.number(mimic, name, "mimic", "multiplier", 1.0)?;
                let offset = self.number(mimic, name, "mimic", "offset", 0.0)?;
                spec = spec.with_mimic(target, multiplier, offset);
            }
        }
        Ok((spec, planar))
    }

    /// The kinematic children of joint `node`, with warnings for what URDF does not define in a
    /// joint and an error for a kinematic element given twice.
    fn joint_parts(
        &mut self,
        node: Node<'d, 'i>,
        name: &str,
        label: &str,
    ) -> Result<JointParts<'d, 'i>, LoadErrorKind> {
        let mut parts = JointParts::default();
        let text = format!("{label}: text inside <joint> is not URDF and is ignored");
        for part in self.elements(node, &text) {
            let element = qualified_name(self.doc, part);
            if element.contains(':') {
                continue;
            }
            let Some((_, allowed)) = JOINT_PARTS.iter().find(|(p, _)| *p == element) else {
                self.notes.add(part.range().start, || {
                    format!("{label}: <{element}> is not a URDF joint element and is ignored")
                });
                continue;
            };
            if let Some(allowed) = allowed {
                for attr in part.attributes() {
                    let qname = &self.doc.input_text()[attr.range_qname()];
                    if !qname.contains(':') && !allowed.contains(&qname) {
                        self.notes.add(attr.range().start, || {
                            format!(
                                "{label}: <{element}> attribute {qname} is not a URDF attribute and is ignored (it takes {})",
                                allowed.join(", ")
                            )
                        });
                    }
                }
            }
            let slot = match element {
                "origin" => &mut parts.origin,
                "parent" => &mut parts.parent,
                "child" => &mut parts.child,
                "axis" => &mut parts.axis,
                "limit" => &mut parts.limit,
                "mimic" => &mut parts.mimic,
                _ => continue,
            };
            if let Some(first) = slot {
                let (line, column): (u32, u32) = place(self.doc, first.range().start);
                if same_attributes(*first, part) && !part.has_children() {
                    self.notes.add(part.range().start, || {
                        format!(
                            "{label}: a second <{element}> repeats the one at line {line} column {column}; ignored"
                        )
                    });
                    continue;
                }
                return Err(self.error(
                    part.range().start,
                    format!(
                        "joint '{name}' has a second <{element}> (the first is at line {line} column {column}); a joint has one"
                    ),
                ));
            }
            *slot = Some(part);
        }
        Ok(parts)
    }

    /// The position limits a revolute or prismatic joint's `<limit>` gives: `None` (with a
    /// warning) when it gives neither bound or a lower bound above the upper one, which some
    /// tools write for "no limit".
    fn limits(
        &mut self,
        limit: Node<'d, 'i>,
        name: &str,
        label: &str,
    ) -> Result<Option<Limits>, LoadErrorKind> {
        let at = limit.range().start;
        for attr in ["effort", "velocity"] {
            match limit.attribute(attr) {
                None => self.notes.add(at, || {
                    format!(
                        "{label}: <limit> has no {attr} attribute, which URDF requires (kinematics does not use it)"
                    )
                }),
                Some(_) => self.unused_numbers(limit, label, &[attr]),
            }
        }
        if !limit.has_attribute("lower") && !limit.has_attribute("upper") {
            self.notes.add(at, || {
                format!(
                    "{label}: <limit> gives neither lower nor upper; the joint is loaded without position limits"
                )
            });
            return Ok(None);
        }
        let lower = self.number(limit, name, "limit", "lower", 0.0)?;
        let upper = self.number(limit, name, "limit", "upper", 0.0)?;
        if lower > upper {
            self.notes.add(at, || {
                format!(
                    "{label}: <limit> lower {lower} is greater than upper {upper} (a way of writing \"no limit\"); the joint is loaded without position limits"
                )
            });
            return Ok(None);
        }
        if lower == upper {
            self.notes.add(at, || {
                format!(
                    "{label}: limit [{lower}, {upper}] allows no motion (URDF reads a missing lower or upper as 0); values other than {lower} are refused unless limits are ignored"
                )
            });
        }
        Ok(Some(Limits { lower, upper }))
    }

    /// Warnings for attributes among `attrs` of `node` that are not one finite number, in an
    /// element whose numbers kinematics does not use.
    fn unused_numbers(&mut self, node: Node<'d, 'i>, label: &str, attrs: &[&str]) {
        for attr in attrs {
            let Some(a) = node.attribute_node(*attr) else {
                continue;
            };
            if a.value().trim().parse::<f64>().is_err() {
                let element = qualified_name(self.doc, node);
                let value = a.value();
                self.notes.add(a.range().start, || {
                    format!(
                        "{label}: <{element}> attribute {attr}=\"{value}\" is not a number; ignored (kinematics does not use it)"
                    )
                });
            }
        }
    }

    /// The number in attribute `attr` of `node` (`default` without it); an error naming the
    /// attribute when it is not a finite number.
    fn number(
        &self,
        node: Node<'d, 'i>,
        joint: &str,
        element: &str,
        attr: &str,
        default: f64,
    ) -> Result<f64, LoadErrorKind> {
        let Some(a) = node.attribute_node(attr) else {
            return Ok(default);
        };
        let value = a.value();
        let Ok(x) = value.trim().parse::<f64>() else {
            return Err(self.error(
                a.range().start,
                format!(
                    "joint '{joint}': <{element}> attribute {attr}=\"{value}\" is not a number{}",
                    xacro_hint(value)
                ),
            ));
        };
        if !x.is_finite() {
            return Err(self.field(
                a.range().start,
                joint,
                element,
                FieldProblem::NonFinite { value: x },
            ));
        }
        Ok(x)
    }

    /// The three numbers in attribute `attr` of `node` (`default` without it); an error naming
    /// the attribute when it is not three finite numbers.
    fn vector(
        &self,
        node: Node<'d, 'i>,
        joint: &str,
        element: &str,
        attr: &str,
        default: [f64; 3],
    ) -> Result<[f64; 3], LoadErrorKind> {
        let Some(a) = node.attribute_node(attr) else {
            return Ok(default);
        };
        let value = a.value();
        let Some(v) = three_numbers(value) else {
            return Err(self.error(
                a.range().start,
                format!(
                    "joint '{joint}': <{element}> attribute {attr}=\"{value}\" is not three numbers{}",
                    xacro_hint(value)
                ),
            ));
        };
        if let Some(&bad) = v.iter().find(|x| !x.is_finite()) {
            return Err(self.field(
                a.range().start,
                joint,
                &format!("{element}.{attr}"),
                FieldProblem::NonFinite { value: bad },
            ));
        }
        Ok(v)
    }
}

/// Whether two elements have the same attributes with the same values, in any order.
fn same_attributes(a: Node<'_, '_>, b: Node<'_, '_>) -> bool {
    let sorted = |n: Node<'_, '_>| {
        let mut all: Vec<(String, String)> = n
            .attributes()
            .map(|a| (a.name().to_string(), a.value().to_string()))
            .collect();
        all.sort_unstable();
        all
    };
    sorted(a) == sorted(b)
}

/// The three numbers of a URDF vector attribute (`"0 0.1 -2"`), `None` unless there are exactly
/// three tokens and each is a number.
fn three_numbers(value: &str) -> Option<[f64; 3]> {
    let mut tokens = value.split_whitespace();
    let mut v = [0.0; 3];
    for x in &mut v {
        *x = tokens.next()?.parse().ok()?;
    }
    tokens.next().is_none().then_some(v)
}

/// A hint for a value holding a xacro expression (`${...}`, `$(...)`).
fn xacro_hint(value: &str) -> &'static str {
    if value.contains("${") || value.contains("$(") {
        " (a xacro expression: expand the file first, `xacro in.urdf.xacro > out.urdf`)"
    } else {
        ""
    }
}

/// The warnings a read collects: the first [`MAX_WARNINGS`] as (byte offset, message without its
/// place), the rest counted.
#[derive(Default)]
struct Notes {
    found: Vec<(usize, String)>,
    more: usize,
}

impl Notes {
    /// A warning at byte `offset`; its message is made only if it is listed.
    fn add(&mut self, offset: usize, message: impl FnOnce() -> String) {
        if self.found.len() < MAX_WARNINGS {
            self.found.push((offset, message()));
        } else {
            self.more += 1;
        }
    }

    /// The warnings with their lines and columns, in the order of the file, and a count of the
    /// rest.
    fn numbered(mut self, doc: &Document<'_>) -> Vec<String> {
        self.found.sort_by_key(|(offset, _)| *offset);
        let mut warnings: Vec<String> = self
            .found
            .into_iter()
            .map(|(offset, message)| {
                let pos = doc.text_pos_at(offset);
                format!("line {} column {}: {message}", pos.row, pos.col)
            })
            .collect();
        if self.more > 0 {
            warnings.push(format!(
                "{} more warnings of the same kinds (elements or attributes that are not URDF, or are malformed, and are ignored)",
                self.more
            ));
        }
        warnings
    }
}
