//! URDF through `urdf-rs` (its `package://` expansion, which runs ROS tools, is never used: mesh
//! paths do not matter for kinematics). The `urdf_rs` types never leave this file.

use crate::chain::{ChainBuilder, JointSpec};
use crate::error::{FieldProblem, LoadErrorKind};
use crate::joint::{JointKind, Limits};
use crate::transform::Transform;

/// Deepest element nesting accepted (real URDFs nest about 6 deep); a limit keeps a hostile file
/// from exhausting the parser's stack.
pub(crate) const MAX_XML_DEPTH: usize = 100;

/// Parses URDF text into a chain description.
pub(crate) fn parse(source: &str) -> Result<ChainBuilder, LoadErrorKind> {
    check_depth(source)?;
    check_root(source)?;
    check_vector_attributes(source)?;
    let robot = urdf_rs::read_from_string(source).map_err(|e| {
        let message = parser_message(&e.to_string());
        LoadErrorKind::Urdf {
            message: locate(source, &message).unwrap_or(message),
        }
    })?;
    let mut b = ChainBuilder::new(robot.name.clone());
    let scan = scan_parts(source);
    for warning in scan.warnings {
        b.warn(warning);
    }
    for link in &robot.links {
        b.link(link.name.clone());
    }
    // Counted in the same order as urdf-rs reads them; should the counts differ, a `<limit>` is
    // taken as missing when all its values are zero, as urdf-rs fills a missing one.
    let aligned = scan.joint_has_limit.len() == robot.joints.len();
    for (k, j) in robot.joints.iter().enumerate() {
        let l = &j.limit;
        let has_limit = if aligned {
            scan.joint_has_limit[k]
        } else {
            [l.lower, l.upper, l.velocity, l.effort] != [0.0; 4]
        };
        let spec = joint_spec(j, has_limit, &mut b)?;
        b.joint(spec);
    }
    Ok(b)
}

/// The joint `j` as a [`JointSpec`] (`has_limit`: whether the file gives it a `<limit>`), after
/// checking its numbers; a warning in `b` for limits that allow no motion.
fn joint_spec(
    j: &urdf_rs::Joint,
    has_limit: bool,
    b: &mut ChainBuilder,
) -> Result<JointSpec, LoadErrorKind> {
    let field = |field: &str, problem| LoadErrorKind::Field {
        joint: Some(j.name.clone()),
        field: field.to_string(),
        problem,
    };
    let finite = |name: &str, values: &[f64]| match values.iter().find(|x| !x.is_finite()) {
        Some(&value) => Err(field(name, FieldProblem::NonFinite { value })),
        None => Ok(()),
    };
    let kind = match j.joint_type {
        urdf_rs::JointType::Revolute => JointKind::Revolute,
        urdf_rs::JointType::Continuous => JointKind::Continuous,
        urdf_rs::JointType::Prismatic => JointKind::Prismatic,
        urdf_rs::JointType::Fixed => JointKind::Fixed,
        ref other => {
            return Err(field(
                "type",
                FieldProblem::UnsupportedJointType {
                    kind: format!("{other:?}").to_lowercase(),
                },
            ));
        }
    };
    finite("origin.xyz", &j.origin.xyz.0)?;
    finite("origin.rpy", &j.origin.rpy.0)?;
    let mut spec = JointSpec::new(
        j.name.clone(),
        kind,
        j.parent.link.clone(),
        j.child.link.clone(),
    )
    .with_origin(Transform::from_xyz_rpy(j.origin.xyz.0, j.origin.rpy.0));
    if kind != JointKind::Fixed {
        finite("axis.xyz", &j.axis.xyz.0)?;
        if j.axis.xyz.0 == [0.0; 3] {
            return Err(field("axis.xyz", FieldProblem::ZeroAxis));
        }
        spec = spec.with_axis(j.axis.xyz.0);
    }
    if matches!(kind, JointKind::Revolute | JointKind::Prismatic) {
        let l = &j.limit;
        if !has_limit {
            return Err(field(
                "limit",
                FieldProblem::MissingLimit {
                    kind: kind.as_str(),
                },
            ));
        }
        // (An infinite bound is refused as in DH tables: a joint without bounds is
        // `continuous`, and JSON output could not print it.)
        finite("limit", &[l.lower, l.upper])?;
        if l.lower > l.upper {
            return Err(field(
                "limit",
                FieldProblem::ReversedLimits {
                    lower: l.lower,
                    upper: l.upper,
                },
            ));
        }
        if l.lower == l.upper {
            b.warn(format!(
                "joint '{}': limit [{}, {}] allows no motion (URDF reads a missing lower or upper as 0); values other than {} are refused unless limits are ignored",
                j.name, l.lower, l.upper, l.lower
            ));
        }
        spec.limits[0] = Some(Limits {
            lower: l.lower,
            upper: l.upper,
        });
    }
    if let Some(m) = &j.mimic {
        let (multiplier, offset) = (m.multiplier.unwrap_or(1.0), m.offset.unwrap_or(0.0));
        finite("mimic", &[multiplier, offset])?;
        spec = spec.with_mimic(m.joint.clone(), multiplier, offset);
    }
    Ok(spec)
}

/// The XML parser's message in the file author's terms: without the deserializer's `custom: `
/// prefix, and saying what "No elements found" means.
fn parser_message(message: &str) -> String {
    match message.strip_prefix("custom: ").unwrap_or(message) {
        "No elements found" => {
            "not a complete XML document (no root element, or the file ends inside one)".into()
        }
        m => m.to_string(),
    }
}

/// Attributes `urdf-rs` reads as one number.
const NUMBER_ATTRIBUTES: [&str; 23] = [
    "lower",
    "upper",
    "effort",
    "velocity",
    "multiplier",
    "offset",
    "damping",
    "friction",
    "soft_lower_limit",
    "soft_upper_limit",
    "k_position",
    "k_velocity",
    "rising",
    "falling",
    "value",
    "radius",
    "length",
    "ixx",
    "ixy",
    "ixz",
    "iyy",
    "iyz",
    "izz",
];

/// Where the parser's complaint `message` comes from, for messages that do not say (`missing
/// field`, `invalid float literal`, `unknown variant`): each element under `<robot>` is parsed on
/// its own, and the first that fails with the same message is named with its line. For a number
/// that is not one, the attribute is named too. `None` when no single element reproduces it.
/// Runs only on a file the parser refused.
fn locate(source: &str, message: &str) -> Option<String> {
    for (start, end, tag) in top_level_elements(source) {
        let alone = format!("<robot name=\"r\">{}</robot>", &source[start..end]);
        match urdf_rs::read_from_string(&alone) {
            Err(e) if parser_message(&e.to_string()) == message => {}
            _ => continue,
        }
        let element = match attribute(tag, "name") {
            Some(name) => format!("{} '{name}'", element_name(tag)),
            None => format!("<{}>", element_name(tag)),
        };
        if message == "invalid float literal" {
            let inner = tags(&source[start..end]).find_map(|(offset, inner)| {
                attributes(inner)
                    .find(|(name, value)| {
                        NUMBER_ATTRIBUTES.contains(name) && value.trim().parse::<f64>().is_err()
                    })
                    .map(|(name, value)| (start + offset, element_name(inner), name, value))
            });
            if let Some((offset, inner, name, value)) = inner {
                return Some(format!(
                    "line {}: {element}: <{inner}> attribute {name}=\"{value}\" is not a number",
                    line_at(source, offset)
                ));
            }
        }
        let message = match message.strip_prefix("missing field ") {
            Some(field) => format!("missing {field}"),
            None => message.to_string(),
        };
        return Some(format!(
            "line {}: {element}: {message}",
            line_at(source, start)
        ));
    }
    None
}

/// The elements directly under the root, as (start offset, end offset, opening tag); an element
/// the file does not close is left out.
fn top_level_elements(source: &str) -> Vec<(usize, usize, &str)> {
    let mut open = None;
    let mut elements = Vec::new();
    for (offset, tag, depth) in nested_tags(source) {
        if depth != 1 {
            continue;
        }
        if closes(tag) {
            if let Some((start, opening)) = open.take() {
                elements.push((start, offset + tag.len(), opening));
            }
        } else if tag.ends_with("/>") {
            elements.push((offset, offset + tag.len(), tag));
        } else {
            open = Some((offset, tag));
        }
    }
    elements
}

/// The 1-based line of byte `offset` in `source`.
fn line_at(source: &str, offset: usize) -> usize {
    source[..offset].matches('\n').count() + 1
}

/// The element name of a tag's text (`<limit lower="0"/>` → `limit`).
fn element_name(tag: &str) -> &str {
    tag.trim_start_matches('<')
        .split(|c: char| c.is_whitespace() || c == '/' || c == '>')
        .next()
        .unwrap_or("")
}

/// The attributes of a tag's text as (name, value), in order; stops at the first thing that is
/// not `name="value"` or `name='value'`.
fn attributes(tag: &str) -> impl Iterator<Item = (&str, &str)> {
    let mut rest = tag
        .trim_start_matches('<')
        .trim_end_matches('>')
        .trim_end_matches('/');
    rest = rest.trim_start_matches(|c: char| !c.is_whitespace());
    std::iter::from_fn(move || {
        let (name, after) = rest.trim_start().split_once('=')?;
        let after = after.trim_start();
        let quote = after.chars().next().filter(|c| *c == '"' || *c == '\'')?;
        let (value, tail) = after[1..].split_once(quote)?;
        rest = tail;
        Some((name.trim(), value))
    })
}

/// The tags of an XML text, skipping comments, CDATA sections, declarations and processing
/// instructions: yields (byte offset, tag text from `<` to `>`).
fn tags(source: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut i = 0;
    std::iter::from_fn(move || {
        loop {
            let off = source[i..].find('<')?;
            i += off;
            let (len, is_tag) = markup(&source[i..]);
            let start = i;
            i += len;
            if is_tag {
                return Some((start, &source[start..i]));
            }
        }
    })
}

/// The length of the markup that `rest` starts with (at a `<`), and whether it is a tag rather
/// than a comment, CDATA section, declaration or processing instruction.
fn markup(rest: &str) -> (usize, bool) {
    let skip_to = |end: &str| rest.find(end).map_or(rest.len(), |e| e + end.len());
    if rest.starts_with("<!--") {
        (skip_to("-->"), false)
    } else if rest.starts_with("<![CDATA[") {
        (skip_to("]]>"), false)
    } else if rest.starts_with("<?") || rest.starts_with("<!") {
        (skip_to(">"), false)
    } else {
        (skip_to(">"), true)
    }
}

/// The offset of the first text in `source[range]` that is neither blank nor markup.
fn stray_text(source: &str, range: std::ops::Range<usize>) -> Option<usize> {
    let mut i = range.start;
    while i < range.end {
        let rest = &source[i..range.end];
        let text = rest.find('<').unwrap_or(rest.len());
        if let Some(at) = rest[..text].find(|c: char| !c.is_whitespace() && c != '\u{feff}') {
            return Some(i + at);
        }
        i += text;
        if i < range.end {
            i += markup(&source[i..range.end]).0;
        }
    }
    None
}

/// Whether a tag's text closes an element (`</joint>`).
fn closes(tag: &str) -> bool {
    tag.starts_with("</")
}

/// Whether a tag's text opens an element that a closing tag ends (not `<axis/>`).
fn opens(tag: &str) -> bool {
    !closes(tag) && !tag.ends_with("/>")
}

/// [`tags`] with the number of elements open around each: the root's opening tag is at depth 0,
/// its children's tags at 1, and a closing tag at the depth of its opening tag.
fn nested_tags(source: &str) -> impl Iterator<Item = (usize, &str, usize)> {
    let mut depth = 0usize;
    tags(source).map(move |(offset, tag)| {
        if closes(tag) {
            depth = depth.saturating_sub(1);
            return (offset, tag, depth);
        }
        let at = depth;
        depth += usize::from(opens(tag));
        (offset, tag, at)
    })
}

/// Refuses element nesting deeper than [`MAX_XML_DEPTH`] before the recursive XML parser sees
/// the file.
fn check_depth(source: &str) -> Result<(), LoadErrorKind> {
    for (_, tag, depth) in nested_tags(source) {
        if depth >= MAX_XML_DEPTH && opens(tag) {
            return Err(LoadErrorKind::Urdf {
                message: format!("elements nest deeper than {MAX_XML_DEPTH} levels"),
            });
        }
    }
    Ok(())
}

/// Refuses a document whose root element is not `<robot>`, whose `<robot>` has no name, or that
/// has a second element or any text (other than comments and the like) before or after the root
/// (the parser would read any root, default the name to empty, and skip the rest). A file with
/// no element at all is left to the parser, which says so.
fn check_root(source: &str) -> Result<(), LoadErrorKind> {
    let mut outside = nested_tags(source).filter(|(_, _, depth)| *depth == 0);
    let Some((offset, tag, _)) = outside.next() else {
        return Ok(());
    };
    let line = line_at(source, offset);
    let root_end = if tag.ends_with("/>") {
        Some(offset + tag.len())
    } else {
        outside.next().map(|(o, t, _)| o + t.len())
    };
    let stray = |range| {
        stray_text(source, range).map(|at| {
            format!(
                "line {}: text outside the root element <robot>",
                line_at(source, at)
            )
        })
    };
    let message = match element_name(tag) {
        "robot" if attribute(tag, "name").is_some() => match outside.next() {
            Some((offset, tag, _)) if closes(tag) => format!(
                "line {}: </{}> closes no open element",
                line_at(source, offset),
                element_name(tag.trim_start_matches("</"))
            ),
            Some((offset, tag, _)) => format!(
                "line {}: <{}> follows the <robot> element; a URDF file has one root element",
                line_at(source, offset),
                element_name(tag)
            ),
            None => match stray(0..offset)
                .or_else(|| root_end.and_then(|end| stray(end..source.len())))
            {
                Some(message) => message,
                None => return Ok(()),
            },
        },
        "robot" => format!("line {line}: <robot> has no name attribute (URDF requires one)"),
        other => format!("line {line}: the root element is <{other}>; a URDF file's is <robot>"),
    };
    Err(LoadErrorKind::Urdf { message })
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

/// The elements URDF and its common extensions put under `<robot>`.
const TOP_LEVEL: [&str; 7] = [
    "link",
    "joint",
    "material",
    "transmission",
    "gazebo",
    "ros2_control",
    "sensor",
];

/// Most warnings [`scan_parts`] lists one by one; the rest are counted.
const MAX_PART_WARNINGS: usize = 20;

/// Warnings for what the parser skips without a word: an element under `<robot>` that URDF does
/// not define (`<jiont>`: the joint would be missing), and inside a `<joint>` an element or
/// attribute URDF does not define there, such as `<orgin>` or `<origin rp="..">`, which would
/// leave the joint's origin at the identity; and text directly inside `<robot>`, a `<link>` or a
/// `<joint>`, whose contents URDF defines as elements only (a stray character left by an edit).
/// Elements and attributes with a namespace prefix (`xacro:`) are not checked. One pass over the
/// text, lines counted as it goes.
///
/// The same pass notes, for each `<joint>` under `<robot>` in the order of the file, whether it
/// holds a `<limit>` element: urdf-rs fills a missing one with zeros, which cannot be told from
/// `<limit lower="0" upper="0" effort="0" velocity="0"/>` (a joint locked at 0, as `kinechain
/// convert` writes it) by the values alone.
fn scan_parts(source: &str) -> Scanned {
    let mut joint_has_limit = Vec::new();
    let mut notes = Notes::default();
    // The <link> or <joint> open under <robot>, as (label, element name): its parts are checked
    // when it is a joint, and text directly inside it in both cases.
    let mut holder: Option<(String, &str)> = None;
    // Where the text after the previous tag starts, and how many elements are open there.
    let (mut text_from, mut open) = (0, 0);
    for (offset, tag, depth) in nested_tags(source) {
        let checked = open == 1 || (open == 2 && holder.is_some());
        if checked && let Some(at) = stray_text(source, text_from..offset) {
            notes.add(at, || match (open, &holder) {
                (2, Some((label, element))) => {
                    format!("{label}: text inside <{element}> is not URDF and is ignored")
                }
                _ => "text inside <robot> is not URDF and is ignored".to_string(),
            });
        }
        text_from = offset + tag.len();
        open = depth + usize::from(opens(tag));
        if closes(tag) {
            continue;
        }
        let name = element_name(tag);
        match depth {
            1 if name == "joint" => {
                let label =
                    attribute(tag, "name").map_or("<joint>".into(), |n| format!("joint '{n}'"));
                for attr in unknown_attributes(tag, &["name", "type"]) {
                    notes.add(offset, || {
                        format!(
                            "{label}: attribute {attr} is not a URDF joint attribute and is ignored"
                        )
                    });
                }
                holder = Some((label, "joint"));
                joint_has_limit.push(false);
            }
            1 => {
                holder = (name == "link").then(|| {
                    let label =
                        attribute(tag, "name").map_or("<link>".into(), |n| format!("link '{n}'"));
                    (label, "link")
                });
                if !name.contains(':') && !TOP_LEVEL.contains(&name) {
                    notes.add(offset, || {
                        format!("<{name}> is not a URDF element under <robot> and is ignored")
                    });
                }
            }
            2 => {
                if let Some((label, "joint")) = &holder {
                    if name == "limit"
                        && let Some(has) = joint_has_limit.last_mut()
                    {
                        *has = true;
                    }
                    joint_part(&mut notes, offset, tag, label);
                }
            }
            _ => {}
        }
    }
    Scanned {
        warnings: notes.numbered(source),
        joint_has_limit,
    }
}

/// Notes on an element `tag` (at byte `offset`) inside the joint `label`: an element URDF does
/// not define there, or an attribute it does not define on that element.
fn joint_part(notes: &mut Notes, offset: usize, tag: &str, label: &str) {
    let name = element_name(tag);
    match JOINT_PARTS.iter().find(|(part, _)| *part == name) {
        Some((_, None)) => {}
        Some((_, Some(allowed))) => {
            for attr in unknown_attributes(tag, allowed) {
                notes.add(offset, || {
                    format!(
                        "{label}: <{name}> attribute {attr} is not a URDF attribute and is ignored (it takes {})",
                        allowed.join(", ")
                    )
                });
            }
        }
        None => notes.add(offset, || {
            format!("{label}: <{name}> is not a URDF joint element and is ignored")
        }),
    }
}

/// The attributes of `tag` without a namespace prefix that are not in `allowed`.
fn unknown_attributes<'t>(tag: &'t str, allowed: &[&str]) -> Vec<&'t str> {
    attributes(tag)
        .map(|(attr, _)| attr)
        .filter(|attr| !attr.contains(':') && !allowed.contains(attr))
        .collect()
}

/// The warnings [`scan_parts`] collects: the first [`MAX_PART_WARNINGS`] as (byte offset,
/// message without its line), the rest counted.
#[derive(Default)]
struct Notes {
    found: Vec<(usize, String)>,
    more: usize,
}

impl Notes {
    /// A warning at byte `offset`; its message is made only if it is listed.
    fn add(&mut self, offset: usize, message: impl FnOnce() -> String) {
        if self.found.len() < MAX_PART_WARNINGS {
            self.found.push((offset, message()));
        } else {
            self.more += 1;
        }
    }

    /// The warnings with their line numbers in `source` (offsets in increasing order, so the
    /// lines are counted in one pass), and a count of the rest.
    fn numbered(self, source: &str) -> Vec<String> {
        let (mut line, mut counted) = (1, 0);
        let mut warnings: Vec<String> = self
            .found
            .into_iter()
            .map(|(offset, message)| {
                line += source[counted..offset].matches('\n').count();
                counted = offset;
                format!("line {line}: {message}")
            })
            .collect();
        if self.more > 0 {
            warnings.push(format!(
                "{} more elements or attributes are not URDF and are ignored",
                self.more
            ));
        }
        warnings
    }
}

/// What [`scan_parts`] finds in a URDF text.
struct Scanned {
    /// Parts the parser skips without a word, each a warning with its line.
    warnings: Vec<String>,
    /// For each `<joint>` under `<robot>`, in the order of the file: whether it holds a `<limit>`.
    joint_has_limit: Vec<bool>,
}

/// `urdf-rs` reads `xyz`/`rpy` attributes by dropping tokens that are not numbers
/// (`"1 x 2 3"` reads as `[1, 2, 3]`); refuse such attributes of `<origin>` and `<axis>` instead
/// of guessing.
fn check_vector_attributes(source: &str) -> Result<(), LoadErrorKind> {
    for (offset, tag) in tags(source) {
        let name = element_name(tag);
        if name != "origin" && name != "axis" {
            continue;
        }
        for attr in ["xyz", "rpy"] {
            let Some(value) = attribute(tag, attr) else {
                continue;
            };
            let tokens: Vec<&str> = value.split_whitespace().collect();
            if tokens.len() != 3 || tokens.iter().any(|t| t.parse::<f64>().is_err()) {
                let line = line_at(source, offset);
                return Err(LoadErrorKind::Urdf {
                    message: format!(
                        "line {line}: <{name}> attribute {attr}=\"{value}\" is not three numbers"
                    ),
                });
            }
        }
    }
    Ok(())
}

/// The value of attribute `name` in a tag's text.
fn attribute<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    attributes(tag)
        .find(|(n, _)| *n == name)
        .map(|(_, value)| value)
}
