//! An MJCF document as a tree of elements, each knowing its file, line and column, with every
//! `<include>` replaced by the elements of the file it names (as MuJoCo splices them: the
//! children of the included file's `<mujoco>` take the place of the `<include>` element).

use crate::io::error::LoadErrorKind;
use crate::io::urdf::xml_errors::{BYTES_PER_NODE, too_many_nodes, xml_error};
use roxmltree::{Document, Node, ParsingOptions};
use std::io::Read as _;
use std::path::{Path, PathBuf};

/// Deepest `<include>` nesting accepted.
pub(crate) const MAX_INCLUDE_DEPTH: usize = 16;

/// Most files one model may be made of (the main file and its includes).
pub(crate) const MAX_FILES: usize = 256;

/// Deepest element nesting accepted in one file.
const MAX_DEPTH: usize = crate::io::urdf::MAX_XML_DEPTH;

/// Nodes any file may hold, however short.
const MIN_NODES: usize = 4096;

/// Where an element or attribute is: the file (an index into [`Tree::files`]), line and column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct At {
    pub(crate) file: usize,
    pub(crate) line: u32,
    pub(crate) column: u32,
}

/// One element: its name, attributes (each with where it is) and child elements.
#[derive(Clone, Debug)]
pub(crate) struct Element {
    pub(crate) name: String,
    pub(crate) attributes: Vec<(String, String, At)>,
    pub(crate) children: Vec<Element>,
    pub(crate) at: At,
}

impl Element {
    /// The value of attribute `name` and where it is, if the element has it.
    pub(crate) fn attribute(&self, name: &str) -> Option<(&str, At)> {
        self.attributes
            .iter()
            .find(|(n, _, _)| n == name)
            .map(|(_, v, at)| (v.as_str(), *at))
    }

    /// The child elements called `name`.
    pub(crate) fn children_named<'a>(
        &'a self,
        name: &'a str,
    ) -> impl Iterator<Item = &'a Element> + 'a {
        self.children.iter().filter(move |c| c.name == name)
    }
}

/// A model's files and its `<mujoco>` element with the includes spliced in, and the reader that
/// reads the models it attaches ([`Tree::read_model`]) into the same list of files.
#[derive(Debug)]
pub(crate) struct Tree {
    pub(crate) root: Element,
    reader: Reader,
}

impl Tree {
    /// The files read, the main file first (`<string>` for text given without a path).
    pub(crate) fn files(&self) -> &[PathBuf] {
        &self.reader.files
    }

    /// The `<mujoco>` element of the model file `name` that an `<asset><model file>` at `at`
    /// names (looked up as an include is), with its includes read.
    pub(crate) fn read_model(&mut self, name: &str, at: At) -> Result<Element, Problem> {
        let r = &mut self.reader;
        let path = r.locate(name, at)?;
        let text = read_limited(&path, r.max_bytes)
            .map_err(|why| Problem::at(at, format!("cannot read model file '{name}': {why}")))?;
        r.files.push(path);
        let index = r.files.len() - 1;
        r.stack.push(index);
        let root = r.document(&text, index, true);
        r.stack.pop();
        root
    }
}

/// An error at `at` (or in no particular place), in the terms of [`LoadErrorKind::Mjcf`].
#[derive(Debug)]
pub(crate) struct Problem {
    pub(crate) at: Option<At>,
    pub(crate) message: String,
}

impl Problem {
    pub(crate) fn at(at: At, message: impl Into<String>) -> Self {
        Problem {
            at: Some(at),
            message: message.into(),
        }
    }

    /// The load error, naming the file when it is not the main one.
    pub(crate) fn into_kind(self, files: &[PathBuf]) -> LoadErrorKind {
        let (file, line, column) = match self.at {
            Some(at) => (
                (at.file > 0).then(|| files[at.file].clone()),
                Some(at.line),
                Some(at.column),
            ),
            None => (None, None, None),
        };
        LoadErrorKind::Mjcf {
            file,
            line,
            column,
            message: self.message,
        }
    }
}

/// Reads the model whose main file's text is `text`: `main` is its path (for messages and
/// includes; `None` for text given as a string) and `base` the directory includes are looked
/// up in first (the main file's directory by default).
pub(crate) fn read(
    text: &str,
    main: Option<&Path>,
    base: Option<&Path>,
    max_bytes: u64,
) -> Result<Tree, LoadErrorKind> {
    let mut reader = Reader {
        max_bytes,
        files: vec![main.map_or_else(|| PathBuf::from("<string>"), Path::to_path_buf)],
        base: base
            .map(Path::to_path_buf)
            .or_else(|| main.and_then(Path::parent).map(Path::to_path_buf)),
        stack: vec![0],
    };
    let root = reader
        .document(text, 0, true)
        .map_err(|p| p.into_kind(&reader.files))?;
    Ok(Tree { root, reader })
}

#[derive(Debug)]
struct Reader {
    /// The most bytes an included file may have.
    max_bytes: u64,
    files: Vec<PathBuf>,
    base: Option<PathBuf>,
    /// The files being read, the main one first, the innermost include last.
    stack: Vec<usize>,
}

impl Reader {
    /// The root element of file `file`, whose text is `text`, with its includes read: a
    /// `<mujoco>` element for a model (`model`), any element for an included file (MuJoCo
    /// splices the children of whatever root it has: `<mujocoinclude>` in older models).
    fn document(&mut self, text: &str, file: usize, model: bool) -> Result<Element, Problem> {
        let limit = (text.len() / BYTES_PER_NODE).max(MIN_NODES);
        let xml_problem = |kind: LoadErrorKind| match kind {
            LoadErrorKind::Urdf {
                line,
                column,
                message,
            } => Problem {
                at: line.map(|line| At {
                    file,
                    line,
                    column: column.unwrap_or(1),
                }),
                message,
            },
            other => Problem {
                at: None,
                message: other.to_string(),
            },
        };
        if text.bytes().filter(|&b| b == b'<').count() > 2 * limit {
            return Err(xml_problem(too_many_nodes(limit)));
        }
        let options = ParsingOptions {
            allow_dtd: false,
            nodes_limit: u32::try_from(limit).unwrap_or(u32::MAX),
            ..ParsingOptions::default()
        };
        let doc = Document::parse_with_options(text, options)
            .map_err(|e| xml_problem(xml_error(text, &e, limit)))?;
        let root = doc.root_element();
        let at = position(&doc, root.range().start, file);
        if model && root.tag_name().name() != "mujoco" {
            return Err(Problem::at(
                at,
                format!(
                    "the root element is <{}>; an MJCF file's is <mujoco>",
                    root.tag_name().name()
                ),
            ));
        }
        self.element(&doc, root, file, 0)
    }

    fn element(
        &mut self,
        doc: &Document<'_>,
        node: Node<'_, '_>,
        file: usize,
        depth: usize,
    ) -> Result<Element, Problem> {
        let at = position(doc, node.range().start, file);
        if depth > MAX_DEPTH {
            return Err(Problem::at(
                at,
                format!("elements nest deeper than {MAX_DEPTH} levels"),
            ));
        }
        let attributes = node
            .attributes()
            .map(|a| {
                (
                    a.name().to_string(),
                    a.value().to_string(),
                    position(doc, a.range().start, file),
                )
            })
            .collect();
        let mut children = Vec::new();
        for child in node.children().filter(Node::is_element) {
            if child.tag_name().name().eq_ignore_ascii_case("include") {
                children.extend(self.include(doc, child, file)?);
            } else {
                children.push(self.element(doc, child, file, depth + 1)?);
            }
        }
        Ok(Element {
            name: node.tag_name().name().to_string(),
            attributes,
            children,
            at,
        })
    }

    /// The elements an `<include file="...">` stands for: the children of the named file's
    /// `<mujoco>`.
    fn include(
        &mut self,
        doc: &Document<'_>,
        node: Node<'_, '_>,
        file: usize,
    ) -> Result<Vec<Element>, Problem> {
        let at = position(doc, node.range().start, file);
        let Some(name) = node.attribute("file") else {
            return Err(Problem::at(at, "<include> has no file attribute"));
        };
        if node.children().any(|c| c.is_element()) {
            return Err(Problem::at(
                at,
                "<include> has child elements; it takes none",
            ));
        }
        let path = self.locate(name, at)?;
        if let Some(seen) = self.files.iter().position(|f| same_file(f, &path)) {
            let message = if self.stack.contains(&seen) {
                format!(
                    "'{name}' includes itself (through {})",
                    self.stack
                        .iter()
                        .map(|&f| self.files[f].display().to_string())
                        .collect::<Vec<_>>()
                        .join(" → ")
                )
            } else {
                format!("'{name}' is included a second time (MuJoCo includes a file once)")
            };
            return Err(Problem::at(at, message));
        }
        let text = read_limited(&path, self.max_bytes)
            .map_err(|why| Problem::at(at, format!("cannot read included file '{name}': {why}")))?;
        self.files.push(path);
        let index = self.files.len() - 1;
        self.stack.push(index);
        let root = self.document(&text, index, false)?;
        self.stack.pop();
        if root.children.is_empty() {
            return Err(Problem::at(
                at,
                format!("included file '{name}' has no elements under its root"),
            ));
        }
        Ok(root.children)
    }

    /// The path of file `name` that an element at `at` names (an include, a model asset), after
    /// checking the bounds on nesting and on the number of files.
    fn locate(&self, name: &str, at: At) -> Result<PathBuf, Problem> {
        if self.stack.len() > MAX_INCLUDE_DEPTH {
            return Err(Problem::at(
                at,
                format!("includes nest deeper than {MAX_INCLUDE_DEPTH} files"),
            ));
        }
        if self.files.len() >= MAX_FILES {
            return Err(Problem::at(
                at,
                format!("the model is made of more than {MAX_FILES} files"),
            ));
        }
        self.resolve(Path::new(name), at.file).ok_or_else(|| {
            Problem::at(
                at,
                format!(
                    "file '{name}' is not found (looked in {})",
                    self.searched(at.file)
                ),
            )
        })
    }

    /// Where `name` is: as it is if absolute; else in the base directory, then beside the file
    /// that includes it.
    fn resolve(&self, name: &Path, from: usize) -> Option<PathBuf> {
        if name.is_absolute() {
            return name.is_file().then(|| name.to_path_buf());
        }
        self.directories(from)
            .into_iter()
            .map(|d| d.join(name))
            .find(|p| p.is_file())
    }

    fn directories(&self, from: usize) -> Vec<PathBuf> {
        let mut dirs: Vec<PathBuf> = self.base.iter().cloned().collect();
        if from > 0
            && let Some(d) = self.files[from].parent()
            && !dirs.iter().any(|x| x == d)
        {
            dirs.push(d.to_path_buf());
        }
        if dirs.is_empty() {
            dirs.push(PathBuf::from("."));
        }
        dirs
    }

    fn searched(&self, from: usize) -> String {
        self.directories(from)
            .iter()
            .map(|d| format!("'{}'", d.display()))
            .collect::<Vec<_>>()
            .join(", then ")
    }
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// The text of `path`, at most `max_bytes` of UTF-8.
fn read_limited(path: &Path, max_bytes: u64) -> Result<String, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut bytes = Vec::new();
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > max_bytes {
        return Err(format!("larger than {max_bytes} bytes"));
    }
    String::from_utf8(bytes)
        .map_err(|e| format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()))
}

fn position(doc: &Document<'_>, offset: usize, file: usize) -> At {
    let pos = doc.text_pos_at(offset);
    At {
        file,
        line: pos.row,
        column: pos.col,
    }
}
