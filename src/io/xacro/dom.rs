//! The XML tree the expander rewrites: elements with their names as written (`xacro:macro`),
//! attributes in order, text and comments, each element knowing its file, line and column; read
//! with `roxmltree` (no DTDs, bounded nodes and depth) and written back as indented XML.

use crate::io::urdf::xml_errors::{BYTES_PER_NODE, xml_error};
use crate::io::xml::escape_shown;
use roxmltree::{Document, ParsingOptions};

/// Deepest element nesting accepted in one file.
const MAX_DEPTH: usize = crate::io::urdf::MAX_XML_DEPTH;
/// Nodes any file may hold, however short.
const MIN_NODES: usize = 4096;

/// Where an element is: a file (an index into the expander's list), line and column (1-based).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Place {
    pub(crate) file: usize,
    pub(crate) line: u32,
    pub(crate) column: u32,
}

#[derive(Clone, Debug)]
pub(crate) enum Node {
    Element(Element),
    Text(String),
    Comment(String),
}

#[derive(Clone, Debug)]
pub(crate) struct Element {
    /// The name as written, with its prefix (`xacro:property`, `gazebo`).
    pub(crate) name: String,
    /// Attributes in document order, namespace declarations (`xmlns:xacro`) among them.
    pub(crate) attrs: Vec<(String, String)>,
    pub(crate) children: Vec<Node>,
    pub(crate) at: Place,
}

impl Element {
    pub(crate) fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    /// Sets attribute `name`, replacing its value where it has one.
    pub(crate) fn set_attr(&mut self, name: String, value: String) {
        match self.attrs.iter_mut().find(|(n, _)| *n == name) {
            Some(slot) => slot.1 = value,
            None => self.attrs.push((name, value)),
        }
    }

    pub(crate) fn remove_attr(&mut self, name: &str) {
        self.attrs.retain(|(n, _)| n != name);
    }

    /// The number of nodes in the element's subtree, itself included.
    pub(crate) fn size(&self) -> usize {
        1 + self
            .children
            .iter()
            .map(|c| match c {
                Node::Element(e) => e.size(),
                _ => 1,
            })
            .sum::<usize>()
    }
}

/// The root element of the XML text `text` of file `file`.
///
/// # Errors
/// The line, column and message of what is not well-formed, or of a bound exceeded.
pub(crate) fn parse(text: &str, file: usize) -> Result<Element, (Place, String)> {
    let limit = (text.len() / BYTES_PER_NODE).max(MIN_NODES);
    let options = ParsingOptions {
        allow_dtd: false,
        nodes_limit: u32::try_from(limit).unwrap_or(u32::MAX),
        ..ParsingOptions::default()
    };
    let doc = Document::parse_with_options(text, options).map_err(|e| {
        let kind = xml_error(text, &e, limit);
        let (line, column) = kind.position().unwrap_or((1, None));
        let message = match kind {
            crate::io::error::LoadErrorKind::Urdf { message, .. } => message,
            other => other.to_string(),
        };
        (
            Place {
                file,
                line,
                column: column.unwrap_or(1),
            },
            message,
        )
    })?;
    let lines = Lines {
        starts: std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect(),
        file,
    };
    convert(&doc, doc.root_element(), &lines, 0)
}

/// Where each line of a file starts, to place byte offsets (roxmltree's own lookup scans the
/// text from its start each time).
struct Lines {
    starts: Vec<usize>,
    file: usize,
}

impl Lines {
    fn place(&self, text: &str, offset: usize) -> Place {
        let line = self.starts.partition_point(|&s| s <= offset).max(1);
        let start = self.starts[line - 1];
        let column = text.get(start..offset).map_or(1, |t| t.chars().count() + 1);
        Place {
            file: self.file,
            line: u32::try_from(line).unwrap_or(u32::MAX),
            column: u32::try_from(column).unwrap_or(u32::MAX),
        }
    }
}

fn convert(
    doc: &Document<'_>,
    node: roxmltree::Node<'_, '_>,
    lines: &Lines,
    depth: usize,
) -> Result<Element, (Place, String)> {
    let at = lines.place(doc.input_text(), node.range().start);
    if depth > MAX_DEPTH {
        return Err((at, format!("elements nest deeper than {MAX_DEPTH} levels")));
    }
    let text = doc.input_text();
    let start = node.range().start + 1;
    let rest = &text[start..];
    let len = rest
        .find(|c: char| c.is_whitespace() || c == '/' || c == '>')
        .unwrap_or(rest.len());
    let name = rest[..len].to_string();
    let mut attrs = Vec::new();
    // Namespace declarations made on this element (those in scope that its parent lacks).
    let parent = node.parent_element();
    let inherited = parent.map_or(0, |p| p.namespaces().len());
    let declares = parent.is_none() || node.namespaces().len() != inherited;
    for ns in node.namespaces().filter(|_| declares) {
        if ns.name() == Some("xml")
            || parent.is_some_and(|p| {
                p.namespaces()
                    .any(|n| n.name() == ns.name() && n.uri() == ns.uri())
            })
        {
            continue;
        }
        let key = ns
            .name()
            .map_or_else(|| "xmlns".to_string(), |p| format!("xmlns:{p}"));
        attrs.push((key, ns.uri().to_string()));
    }
    for a in node.attributes() {
        attrs.push((text[a.range_qname()].to_string(), a.value().to_string()));
    }
    let mut children = Vec::new();
    for child in node.children() {
        if child.is_element() {
            children.push(Node::Element(convert(doc, child, lines, depth + 1)?));
        } else if child.is_text() {
            // White space between elements means nothing to URDF (and is not written), but
            // xacro's rules for dropping comments count its line breaks.
            children.push(Node::Text(child.text().unwrap_or_default().to_string()));
        } else if child.is_comment() {
            children.push(Node::Comment(child.text().unwrap_or_default().to_string()));
        }
    }
    Ok(Element {
        name,
        attrs,
        children,
        at,
    })
}

/// The document `root` as indented XML text, as `xacro` writes it (two spaces per level, text
/// that is an element's only child kept on its line, white-space-only text dropped).
pub(crate) fn write(root: &Element, banner: &str) -> String {
    let mut out = String::from("<?xml version=\"1.0\" ?>\n");
    if !banner.is_empty() {
        out.push_str("<!-- ");
        out.push_str(&banner.replace("--", "- -"));
        out.push_str(" -->\n");
    }
    write_element(root, 0, &mut out);
    out
}

fn write_element(e: &Element, depth: usize, out: &mut String) {
    let indent = "  ".repeat(depth);
    out.push_str(&indent);
    out.push('<');
    out.push_str(&e.name);
    for (k, v) in &e.attrs {
        out.push(' ');
        out.push_str(k);
        out.push_str("=\"");
        out.push_str(&escape_shown(v));
        out.push('"');
    }
    // White-space text is not written (it is kept for the expansion's comment rules only).
    let shown: Vec<&Node> = e
        .children
        .iter()
        .filter(|c| !matches!(c, Node::Text(t) if t.trim().is_empty()))
        .collect();
    if shown.is_empty() {
        out.push_str("/>\n");
        return;
    }
    if let [Node::Text(t)] = shown.as_slice() {
        out.push('>');
        out.push_str(&escape_text(t));
        out.push_str("</");
        out.push_str(&e.name);
        out.push_str(">\n");
        return;
    }
    out.push_str(">\n");
    for child in shown {
        match child {
            Node::Element(c) => write_element(c, depth + 1, out),
            Node::Text(t) => {
                out.push_str(&indent);
                out.push_str("  ");
                out.push_str(&escape_text(t));
                out.push('\n');
            }
            Node::Comment(c) => {
                out.push_str(&indent);
                out.push_str("  <!--");
                out.push_str(&c.replace("--", "- -"));
                out.push_str("-->\n");
            }
        }
    }
    out.push_str(&indent);
    out.push_str("</");
    out.push_str(&e.name);
    out.push_str(">\n");
}

/// Element text with `&`, `<` and `>` escaped.
fn escape_text(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
