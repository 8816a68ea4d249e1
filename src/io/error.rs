//! What loading a robot file can fail with ([`LoadError`]): the file, and what went wrong in it
//! ([`LoadErrorKind`], [`FieldProblem`]).

use crate::model::error::ModelError;
use crate::model::transform::NotRigid;
use std::path::{Path, PathBuf};

/// Largest robot file accepted, in bytes (each file a xacro or MJCF file includes too). URDFs of
/// real robots are well under 1 MiB.
pub const MAX_FILE_BYTES: u64 = 16 * 1024 * 1024;

/// A robot file could not be turned into a [`Chain`](crate::Chain).
///
/// Its message names the file; its source ([`LoadError::kind`]) says what went wrong.
#[derive(Debug, thiserror::Error)]
#[error("cannot load {}", path.display())]
pub struct LoadError {
    path: PathBuf,
    #[source]
    kind: Box<LoadErrorKind>,
}

impl LoadError {
    pub(crate) fn new(path: &Path, kind: LoadErrorKind) -> Self {
        LoadError {
            path: path.to_path_buf(),
            kind: Box::new(kind),
        }
    }

    /// The error of a xacro file that could not be expanded.
    #[must_use]
    pub fn new_xacro(path: &Path, error: XacroError) -> Self {
        LoadError::new(path, LoadErrorKind::Xacro(error))
    }

    /// The file that failed to load.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// What went wrong.
    #[must_use]
    pub fn kind(&self) -> &LoadErrorKind {
        &self.kind
    }

    /// The 1-based line and column of the problem in the file, when the error has one.
    #[must_use]
    pub fn position(&self) -> Option<(u32, Option<u32>)> {
        self.kind.position()
    }
}

impl LoadErrorKind {
    /// The 1-based line and (when known) column of the problem in the file, if the error has a
    /// place in it.
    #[must_use]
    pub fn position(&self) -> Option<(u32, Option<u32>)> {
        match self {
            LoadErrorKind::Yaml { line, column, .. }
            | LoadErrorKind::Urdf { line, column, .. }
            | LoadErrorKind::Mjcf { line, column, .. }
            | LoadErrorKind::Field { line, column, .. }
            | LoadErrorKind::Model { line, column, .. } => line.map(|l| (l, *column)),
            LoadErrorKind::Xacro(e) => e.line.map(|l| (l, e.column)),
            _ => None,
        }
    }
}

/// What went wrong while loading a robot file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LoadErrorKind {
    /// The file could not be read.
    #[error("cannot read file")]
    Io(#[from] std::io::Error),
    /// The file is larger than the loader accepts.
    #[error("{}", too_large(*size, *limit))]
    TooLarge {
        /// Size of the file in bytes; `None` for a pipe or device, which was read up to the limit
        /// and no further.
        size: Option<u64>,
        /// The limit in bytes.
        limit: u64,
    },
    /// The file name has no extension kinechain knows.
    #[error("unknown robot file type (expected .yaml, .yml, .urdf, .xacro or .xml)")]
    UnknownFormat,
    /// The file holds nothing but whitespace or comments.
    #[error("file is empty")]
    Empty,
    /// The file is not valid UTF-8 text.
    #[error("file is not UTF-8 text (byte {offset})")]
    NotText {
        /// Byte offset of the first invalid byte.
        offset: usize,
    },
    /// The YAML parser or the schema rejected the file (syntax error, unknown or missing key,
    /// wrong type, resource limit).
    #[error(
        "{}{}{}{message}",
        location_prefix(*line, *column),
        joint_prefix(joint.as_deref()),
        field.as_deref().map(|f| format!("{f}: ")).unwrap_or_default()
    )]
    Yaml {
        /// 1-based line of the problem, when known.
        line: Option<u32>,
        /// 1-based column of the problem, when known.
        column: Option<u32>,
        /// The joint whose entry holds the problem, when known.
        joint: Option<String>,
        /// The field whose value holds the problem (`a`, `origin.xyz`, `base.rpy`), when known
        /// and not already named by the message.
        field: Option<String>,
        /// The parser's description.
        message: String,
    },
    /// The file (or a file it includes) is not well-formed XML, or its MJCF elements are not
    /// what MJCF defines, or use what kinechain does not read.
    #[error(
        "invalid MJCF: {}{}{message}",
        file.as_ref().map(|f| format!("in file {}: ", f.display())).unwrap_or_default(),
        location_prefix(*line, *column)
    )]
    Mjcf {
        /// The file the problem is in (an included file, or a model an `<attach>` reads);
        /// `None` for the main file.
        file: Option<PathBuf>,
        /// 1-based line of the element or attribute at fault, when known.
        line: Option<u32>,
        /// 1-based column of the element or attribute at fault, when known.
        column: Option<u32>,
        /// What is wrong, in the terms of the file.
        message: String,
    },
    /// The file is not well-formed XML, or its URDF elements are not what URDF defines.
    #[error("invalid URDF: {}{message}", location_prefix(*line, *column))]
    Urdf {
        /// 1-based line of the element or attribute at fault, when known.
        line: Option<u32>,
        /// 1-based column (in characters) of the element or attribute at fault, when known.
        column: Option<u32>,
        /// What is wrong, in the terms of the file.
        message: String,
    },
    /// The xacro file (or a `.urdf` file's leftover xacro elements) could not be expanded.
    #[error("xacro: {0}")]
    Xacro(XacroError),
    /// The URDF a xacro file expands to could not be read (lines and columns are those of the
    /// expanded text, which `kinechain expand` writes).
    #[error("in the URDF the xacro expands to: {0}")]
    Expanded(Box<LoadErrorKind>),
    /// The file is UTF-16 text (it starts with a UTF-16 byte order mark); robot files are read
    /// as UTF-8.
    #[error(
        "file is UTF-16 text; kinechain reads UTF-8 (convert it, e.g. `iconv -f UTF-16 -t UTF-8`)"
    )]
    Utf16,
    /// A field has a value kinechain cannot accept.
    #[error(
        "{}{}{field}: {problem}",
        location_prefix(*line, *column),
        joint_prefix(joint.as_deref())
    )]
    Field {
        /// 1-based line of the value, when known.
        line: Option<u32>,
        /// 1-based column of the value, when known.
        column: Option<u32>,
        /// The joint whose entry holds the field, if the field belongs to a joint.
        joint: Option<String>,
        /// The field, e.g. `alpha` or `origin.matrix`.
        field: String,
        /// What is wrong with it.
        problem: FieldProblem,
    },
    /// The joints and links do not form a valid chain or tree.
    #[error("{}{error}", location_prefix(*line, *column))]
    Model {
        /// 1-based line of the joint or link element at fault, when the format gives one (URDF).
        line: Option<u32>,
        /// 1-based column of that element, when known.
        column: Option<u32>,
        /// What is wrong.
        error: ModelError,
    },
}

impl From<ModelError> for LoadErrorKind {
    fn from(error: ModelError) -> Self {
        LoadErrorKind::Model {
            line: None,
            column: None,
            error,
        }
    }
}

fn too_large(size: Option<u64>, limit: u64) -> String {
    match size {
        Some(size) => {
            format!("file is {size} bytes, more than the {limit}-byte limit for robot files")
        }
        None => format!(
            "more than {limit} bytes read (the limit for robot files) and the input is not a regular file; reading stopped there"
        ),
    }
}

fn location_prefix(line: Option<u32>, column: Option<u32>) -> String {
    match (line, column) {
        (Some(l), Some(c)) => format!("line {l} column {c}: "),
        (Some(l), None) => format!("line {l}: "),
        _ => String::new(),
    }
}

fn joint_prefix(joint: Option<&str>) -> String {
    joint.map(|j| format!("joint '{j}': ")).unwrap_or_default()
}

/// What is wrong with one field of a robot file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FieldProblem {
    /// A number is NaN or infinite.
    #[error("value {value} is not finite")]
    NonFinite {
        /// The value read.
        value: f64,
    },
    /// A joint axis has zero length.
    #[error("zero length")]
    ZeroAxis,
    /// A matrix is not a rigid transform.
    #[error("not a rigid transform: {0}")]
    NotRigid(NotRigid),
    /// A limit pair has `lower > upper`.
    #[error("lower limit {lower} is greater than upper limit {upper}")]
    ReversedLimits {
        /// Lower limit read.
        lower: f64,
        /// Upper limit read.
        upper: f64,
    },
    /// The field is required here and missing.
    #[error("missing (required {context})")]
    Missing {
        /// Why it is required, e.g. `for convention standard`.
        context: &'static str,
    },
    /// The field exists but does not belong here (e.g. `origin` in a DH joint).
    #[error("not allowed {context}")]
    NotAllowed {
        /// Where it is not allowed, e.g. `for convention standard`.
        context: &'static str,
    },
    /// The value has the wrong shape (e.g. two limits where a cylindrical joint needs a map).
    #[error("{expected}")]
    Shape {
        /// What was expected.
        expected: &'static str,
    },
    /// An angle written as an expression without a unit where `angle_unit: deg` applies.
    #[error(
        "expression '{text}' has no unit; with angle_unit: deg write a number, deg(..), rad(..) or a !degrees/!radians tag"
    )]
    AmbiguousAngle {
        /// The text of the value.
        text: String,
    },
    /// A URDF joint type kinechain does not model.
    #[error(
        "joint type '{kind}' is not supported (supported: revolute, continuous, prismatic, fixed, floating)"
    )]
    UnsupportedJointType {
        /// The type found in the file.
        kind: String,
    },
    /// A revolute or prismatic URDF joint without a `<limit>` element.
    #[error(
        "{kind} joint has no <limit> element (URDF requires one for revolute and prismatic joints)"
    )]
    MissingLimit {
        /// The joint type.
        kind: &'static str,
    },
    /// A name given to one thing is already another's (a DH tool named like a joint or link).
    #[error("'{name}' is already the name of a {owner}")]
    NameTaken {
        /// The name.
        name: String,
        /// What already has it: `joint` or `link`.
        owner: &'static str,
    },
}

/// A xacro document could not be expanded.
///
/// Shown as `FILE:LINE:COLUMN: in macro `m` called at F:L:C: MESSAGE`.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct XacroError {
    /// The file the problem is in.
    pub file: PathBuf,
    /// 1-based line of the element at fault, when known.
    pub line: Option<u32>,
    /// 1-based column of the element at fault, when known.
    pub column: Option<u32>,
    /// The macro calls and includes that led there, innermost first ("in macro `ur_robot`
    /// called at ur.urdf.xacro:42:5").
    pub stack: Vec<String>,
    /// What is wrong.
    pub message: String,
}

impl std::fmt::Display for XacroError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&location(&self.file, self.line, self.column))?;
        for s in &self.stack {
            write!(f, "{s}: ")?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for XacroError {}

fn location(file: &Path, line: Option<u32>, column: Option<u32>) -> String {
    match (line, column) {
        (Some(l), Some(c)) => format!("{}:{l}:{c}: ", file.display()),
        (Some(l), None) => format!("{}:{l}: ", file.display()),
        _ => format!("{}: ", file.display()),
    }
}
