//! The XML parser's errors in the terms of the file's author, with their line and column.

use crate::io::error::LoadErrorKind;

/// The parser's error in the file author's terms, with its line and column.
pub(crate) fn xml_error(source: &str, e: &roxmltree::Error, nodes: usize) -> LoadErrorKind {
    use roxmltree::Error as E;
    let end = line_column(source, source.len());
    let at = |pos: roxmltree::TextPos| (Some(pos.row), Some(pos.col));
    let (place, message) = match e {
        E::NoRootNode
            if source
                .trim_start_matches('\u{feff}')
                .trim_start()
                .starts_with('<') =>
        {
            (
                (Some(end.0), Some(end.1)),
                "not a complete XML document (the file ends inside its first element)".to_string(),
            )
        }
        E::NoRootNode => (
            (Some(end.0), Some(end.1)),
            "not an XML document (no root element)".to_string(),
        ),
        E::UnclosedRootNode | E::UnexpectedEndOfStream => (
            (Some(end.0), Some(end.1)),
            "not a complete XML document (the file ends inside an element)".to_string(),
        ),
        E::DtdDetected => {
            let offset = source.find("<!DOCTYPE").unwrap_or(0);
            let (line, column) = line_column(source, offset);
            (
                (Some(line), Some(column)),
                "a <!DOCTYPE> declaration is not accepted in a robot file".to_string(),
            )
        }
        E::NodesLimitReached => return too_many_nodes(nodes),
        E::UnknownNamespace(prefix, pos) if prefix == "xacro" => (
            at(*pos),
            "the namespace prefix 'xacro:' is not declared (add xmlns:xacro=\"http://www.ros.org/wiki/xacro\" to the root element)".to_string(),
        ),
        E::UnknownNamespace(prefix, pos) => (
            at(*pos),
            format!("not well-formed XML: the namespace prefix '{prefix}:' is not declared"),
        ),
        E::UnexpectedCloseTag(expected, actual, pos) => (
            at(*pos),
            format!("not well-formed XML: </{actual}> where </{expected}> closes the open element"),
        ),
        E::UnknownEntityReference(name, pos) => (
            at(*pos),
            format!("not well-formed XML: unknown entity &{name};"),
        ),
        E::MalformedEntityReference(pos) => (
            at(*pos),
            "not well-formed XML: a '&' that starts no entity or character reference (write &amp;)"
                .into(),
        ),
        E::DuplicatedAttribute(name, pos) => (
            at(*pos),
            format!("not well-formed XML: attribute {name} is given twice"),
        ),
        E::UnexpectedDeclaration(pos) => (
            at(*pos),
            "not well-formed XML: an XML declaration (<?xml ...?>) is allowed only at the start \
             of the file"
                .into(),
        ),
        E::NonXmlChar(c, pos) => (
            at(*pos),
            format!(
                "not well-formed XML: character U+{:04X} is not allowed in XML",
                u32::from(*c)
            ),
        ),
        E::InvalidComment(pos) => (at(*pos), "not well-formed XML: a comment holds '--'".into()),
        E::UnknownToken(pos) => (at(*pos), outside_root(source, *pos)),
        E::InvalidChar(expected, actual, pos) => (
            at(*pos),
            format!(
                "not well-formed XML: '{}' where '{}' belongs",
                char::from(*actual),
                char::from(*expected)
            ),
        ),
        E::InvalidChar2(expected, actual, pos) => (
            at(*pos),
            format!(
                "not well-formed XML: '{}' where {expected} belongs",
                char::from(*actual)
            ),
        ),
        E::InvalidString(expected, pos) => (
            at(*pos),
            format!("not well-formed XML: '{expected}' expected here"),
        ),
        E::InvalidName(pos) => (
            at(*pos),
            "not well-formed XML: a name that XML does not allow".into(),
        ),
        E::InvalidAttributeValue(pos) => (
            at(*pos),
            "not well-formed XML: '<' inside an attribute value (write &lt;)".into(),
        ),
        E::EntityReferenceLoop(pos) => (
            at(*pos),
            "not well-formed XML: entity references nest too deep (a loop?)".into(),
        ),
        E::InvalidCharacterData(pos) => (
            at(*pos),
            "not well-formed XML: ']]>' in text (write ]]&gt;)".into(),
        ),
        other => {
            let pos = other.pos();
            (
                at(pos),
                "not well-formed XML: a namespace declaration or reference XML does not allow"
                    .into(),
            )
        }
    };
    LoadErrorKind::Urdf {
        line: place.0,
        column: place.1,
        message,
    }
}

/// The error for a file with more than `limit` XML nodes.
pub(crate) fn too_many_nodes(limit: usize) -> LoadErrorKind {
    LoadErrorKind::Urdf {
        line: None,
        column: None,
        message: format!(
            "the file holds more than {limit} XML nodes, more than a robot file of its size \
             does (one node per {BYTES_PER_NODE} bytes is the most accepted, which bounds the \
             memory a load takes)"
        ),
    }
}

/// What the tokenizer found where an XML document allows only markup around its root element.
pub(super) fn outside_root(source: &str, pos: roxmltree::TextPos) -> String {
    let offset = offset_of(source, pos);
    let rest = &source[offset..];
    let name = |after: &str| -> String {
        after
            .chars()
            .take_while(|c| !c.is_whitespace() && *c != '>' && *c != '/')
            .collect()
    };
    if let Some(after) = rest.strip_prefix("</") {
        format!(
            "not well-formed XML: </{}> closes no open element",
            name(after)
        )
    } else if let Some(after) = rest
        .strip_prefix('<')
        .filter(|a| !a.starts_with('!') && !a.starts_with('?'))
    {
        format!(
            "not well-formed XML: <{}> follows the root element; a URDF file has one root \
             element",
            name(after)
        )
    } else if rest.starts_with('<') {
        "not well-formed XML: markup that XML does not define".into()
    } else {
        "not well-formed XML: text outside the root element".into()
    }
}

/// The byte offset of a 1-based (line, column in characters) position.
pub(super) fn offset_of(source: &str, pos: roxmltree::TextPos) -> usize {
    let line_start = if pos.row <= 1 {
        0
    } else {
        source
            .match_indices('\n')
            .nth(pos.row as usize - 2)
            .map_or(source.len(), |(i, _)| i + 1)
    };
    source[line_start..]
        .char_indices()
        .nth(pos.col.saturating_sub(1) as usize)
        .map_or(source.len(), |(i, _)| line_start + i)
}

/// File bytes per XML node the parser may build. Each node of the tree costs about 70 bytes
/// (and the parser reserves room for one per `<` before it starts, so a file may have at most two
/// `<` per node allowed), which bounds a load's memory to about 15 times the file's size whatever
/// the file holds; real URDFs spend 30 to 45 bytes on a `<`.
pub(crate) const BYTES_PER_NODE: usize = 12;

/// The 1-based line and column (in characters) of byte `offset`.
pub(super) fn line_column(source: &str, offset: usize) -> (u32, u32) {
    let before = &source[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (
        u32::try_from(line).unwrap_or(u32::MAX),
        u32::try_from(column).unwrap_or(u32::MAX),
    )
}
