//! Typed errors: what loading a file can fail with ([`LoadError`]), what building a chain can
//! fail with ([`ModelError`]), and what an evaluation can fail with ([`StateError`]).

use crate::model::transform::NotRigid;
use std::path::{Path, PathBuf};

/// An error and its sources on one line, `error: source: source…`, with any line breaks of
/// their messages turned into spaces.
///
/// Each error of this crate displays only its own layer (a [`LoadError`] says which file, its
/// source what went wrong in it), as Rust errors do; this is the whole story for a log line or
/// a message to a user.
///
/// ```
/// let e = kinechain::Chain::from_file("no/such/robot.urdf").unwrap_err();
/// assert_eq!(e.to_string(), "cannot load no/such/robot.urdf");
/// let line = kinechain::error::error_chain(&e);
/// assert!(line.starts_with("cannot load no/such/robot.urdf: "), "{line}");
/// ```
#[must_use]
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    escape_controls(&text.replace('\n', " ")).into_owned()
}

/// `text` with every character that could change a terminal's state or the order in which
/// text shows written as an escape (`\u{1b}` for ESC, `\r`, `\0`, `\u{202e}` for a
/// right-to-left override): control characters (C0, DEL, C1) and Unicode's bidirectional
/// formatting characters. Names and file text in errors and warnings go through it, so that a
/// crafted joint name cannot rewrite the terminal it is printed to.
///
/// ```
/// use kinechain::error::escape_controls;
/// assert_eq!(escape_controls("joint\u{1b}[2J"), "joint\\u{1b}[2J");
/// assert_eq!(escape_controls("plain name"), "plain name");
/// ```
#[must_use]
pub fn escape_controls(text: &str) -> std::borrow::Cow<'_, str> {
    let unsafe_char = |c: char| {
        c.is_control()
            || matches!(c, '\u{200e}' | '\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
    };
    if !text.contains(unsafe_char) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if unsafe_char(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    std::borrow::Cow::Owned(out)
}

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
            | LoadErrorKind::Xacro { line, column, .. }
            | LoadErrorKind::Field { line, column, .. }
            | LoadErrorKind::Model { line, column, .. } => line.map(|l| (l, *column)),
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
    #[error("unknown robot file type (expected .yaml, .yml or .urdf)")]
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
    /// The file holds xacro macros (or its name says it is a xacro file): it must be expanded
    /// into URDF first.
    #[error(
        "{}{found}: this is a xacro file, not URDF; expand it first (`xacro in.urdf.xacro > out.urdf`) and load the result",
        location_prefix(*line, *column)
    )]
    Xacro {
        /// 1-based line of the first xacro element or attribute, when it is in the file.
        line: Option<u32>,
        /// 1-based column of the first xacro element or attribute, when it is in the file.
        column: Option<u32>,
        /// What shows it: the element, the attribute or the file name.
        found: String,
    },
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

/// Most names an error message lists; the rest are counted.
const MAX_LISTED: usize = 10;

/// `names` joined by commas, the first [`MAX_LISTED`] of them and a count of the rest.
fn listed(names: &[String]) -> String {
    let mut text = names
        .iter()
        .take(MAX_LISTED)
        .map(String::as_str)
        .collect::<Vec<_>>()
        .join(", ");
    if names.len() > MAX_LISTED {
        text.push_str(&format!(" and {} more", names.len() - MAX_LISTED));
    }
    text
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
        "joint type '{kind}' is not supported (supported: revolute, continuous, prismatic, fixed)"
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

/// The joints and links handed to [`ChainBuilder`](crate::ChainBuilder) do not form a valid
/// chain or tree.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    /// Two joints share a name.
    #[error("duplicate joint name '{name}'")]
    DuplicateJoint {
        /// The repeated name.
        name: String,
    },
    /// Two links share a name.
    #[error("duplicate link name '{name}'")]
    DuplicateLink {
        /// The repeated name.
        name: String,
    },
    /// A name is empty.
    #[error("empty {what} name")]
    EmptyName {
        /// `joint` or `link`.
        what: &'static str,
    },
    /// A joint refers to a link that does not exist.
    #[error("joint '{joint}': {role} link '{link}' does not exist{}", did_you_mean(.suggestion))]
    UnknownLink {
        /// The joint.
        joint: String,
        /// `parent` or `child`.
        role: &'static str,
        /// The missing link.
        link: String,
        /// The declared link whose name is closest, if it is close enough to be a likely typo
        /// (see [`closest_name`]).
        suggestion: Option<String>,
    },
    /// A link is the child of two joints.
    #[error("link '{link}' is the child of two joints, '{first}' and '{second}'")]
    TwoParents {
        /// The link.
        link: String,
        /// First joint naming it as child.
        first: String,
        /// Second joint naming it as child.
        second: String,
    },
    /// More than one link has no parent joint.
    #[error("more than one root link: {}", listed(roots))]
    MultipleRoots {
        /// The links without a parent joint.
        roots: Vec<String>,
    },
    /// The joints form a cycle (no link without a parent, or links unreachable from the root).
    #[error("joints form a cycle through joint '{joint}'")]
    Cycle {
        /// A joint on the cycle.
        joint: String,
    },
    /// The model has no links.
    #[error("model has no links")]
    NoLinks,
    /// A mimic joint refers to a joint that does not exist.
    #[error("joint '{joint}' mimics joint '{target}', which does not exist{}", did_you_mean(.suggestion))]
    UnknownMimicTarget {
        /// The mimic joint.
        joint: String,
        /// The missing joint.
        target: String,
        /// The declared joint whose name is closest, if it is close enough to be a likely typo
        /// (see [`closest_name`]).
        suggestion: Option<String>,
    },
    /// A mimic joint refers to a joint that cannot drive it (fixed or cylindrical).
    #[error(
        "joint '{joint}' mimics joint '{target}', which is {kind} (must be revolute, continuous or prismatic)"
    )]
    BadMimicTarget {
        /// The mimic joint.
        joint: String,
        /// The joint it mimics.
        target: String,
        /// The target's kind.
        kind: &'static str,
    },
    /// A mimic joint is not revolute, continuous or prismatic.
    #[error("joint '{joint}' is {kind} and cannot mimic another joint")]
    BadMimicKind {
        /// The mimic joint.
        joint: String,
        /// Its kind.
        kind: &'static str,
    },
    /// Mimic joints refer to each other in a cycle.
    #[error("mimic joints form a cycle through joint '{joint}'")]
    MimicCycle {
        /// A joint on the cycle.
        joint: String,
    },
    /// A joint has a NaN or infinite number.
    #[error("joint '{joint}': {field} is not finite")]
    NonFinite {
        /// The joint.
        joint: String,
        /// The field.
        field: &'static str,
    },
    /// A joint axis has zero length.
    #[error("joint '{joint}': axis has zero length")]
    ZeroAxis {
        /// The joint.
        joint: String,
    },
    /// A joint has `lower > upper` or NaN limits.
    #[error("joint '{joint}': lower limit {lower} is greater than upper limit {upper}")]
    ReversedLimits {
        /// The joint.
        joint: String,
        /// Lower limit.
        lower: f64,
        /// Upper limit.
        upper: f64,
    },
    /// A constant placement is not a rigid transform.
    #[error("joint '{joint}': {field} is not a rigid transform: {problem}")]
    NotRigid {
        /// The joint (or the base/root name).
        joint: String,
        /// The field.
        field: &'static str,
        /// What is wrong.
        problem: NotRigid,
    },
}

/// A joint-space vector (`q`, `q_dot`, `q_ddot`) cannot be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StateError {
    /// The vector has the wrong number of entries.
    #[error("{what} has {got} entries, the chain has {expected} degrees of freedom")]
    WrongLength {
        /// `q`, `q_dot` or `q_ddot`.
        what: &'static str,
        /// Entries expected (the chain's dof).
        expected: usize,
        /// Entries given.
        got: usize,
    },
    /// An entry is NaN or infinite.
    #[error(
        "{what}[{index}] (joint '{joint}'{}) is {value}, not a finite number",
        component_suffix(component)
    )]
    NonFinite {
        /// `q`, `q_dot` or `q_ddot`.
        what: &'static str,
        /// Index in the vector.
        index: usize,
        /// The joint this entry drives.
        joint: String,
        /// For a cylindrical joint, `theta` or `d`.
        component: Option<&'static str>,
        /// The value given.
        value: f64,
    },
    /// A batch for a chain without moving joints: its configurations have no entries, so a flat
    /// batch cannot say how many it holds. Evaluate such a chain once, with
    /// [`forward_kinematics`](crate::forward_kinematics).
    #[error(
        "the chain has no moving joints, so a batch cannot tell how many configurations it holds \
         (evaluate it once with forward_kinematics)"
    )]
    NoDegreesOfFreedom,
    /// A joint value is outside the joint's limits.
    #[error("joint '{joint}'{} = {value} is outside its limits [{lower}, {upper}]{}", component_suffix(component), hint(*value, *lower, *upper, *angular))]
    OutOfLimits {
        /// The joint.
        joint: String,
        /// For a cylindrical joint, `theta` or `d`.
        component: Option<&'static str>,
        /// Whether the coordinate is an angle (rad) rather than a length (m). Only an angle's
        /// message suggests that the value may have been given in degrees.
        angular: bool,
        /// The value (for a mimic joint, the value implied by its primary joint).
        value: f64,
        /// Lower limit.
        lower: f64,
        /// Upper limit.
        upper: f64,
    },
}

fn component_suffix(c: &Option<&'static str>) -> String {
    c.map(|c| format!(" {c}")).unwrap_or_default()
}

/// The degrees hint: for an angle beyond a full turn whose value read as degrees is within the
/// limits.
fn hint(value: f64, lower: f64, upper: f64, angular: bool) -> &'static str {
    let deg = value.to_radians();
    if angular && value.abs() > 2.0 * std::f64::consts::PI && deg >= lower && deg <= upper {
        " (the value looks like degrees; angles are in radians)"
    } else {
        ""
    }
}

/// A name given to a query is not in the chain.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum NameError {
    /// No link has this name.
    #[error("no link named '{name}'{}", did_you_mean(.suggestion))]
    UnknownLink {
        /// The name asked for.
        name: String,
        /// The chain's link whose name is closest, when it is close enough to be a likely typo
        /// (see [`closest_name`]).
        suggestion: Option<String>,
    },
    /// No joint has this name.
    #[error("no joint named '{name}'{}", did_you_mean(.suggestion))]
    UnknownJoint {
        /// The name asked for.
        name: String,
        /// The chain's joint whose name is closest, when it is close enough to be a likely typo
        /// (see [`closest_name`]).
        suggestion: Option<String>,
    },
}

impl NameError {
    /// The name the caller most likely meant, if one is clearly closest (see [`closest_name`]).
    #[must_use]
    pub fn suggestion(&self) -> Option<&str> {
        match self {
            NameError::UnknownLink { suggestion, .. }
            | NameError::UnknownJoint { suggestion, .. } => suggestion.as_deref(),
        }
    }
}

/// The longest name, in characters, for which [`closest_name`] looks for a likely spelling.
pub const MAX_SUGGESTED_NAME: usize = 256;

/// ` (did you mean 'x'?)` for a suggested name, nothing without one.
pub(crate) fn did_you_mean(suggestion: &Option<String>) -> String {
    suggestion
        .as_ref()
        .map(|s| format!(" (did you mean '{s}'?)"))
        .unwrap_or_default()
}

/// Of `candidates`, the one closest to `name` in edit distance (insertions, deletions and
/// substitutions of characters, letter case ignored), if that distance is at most a third of
/// `name`'s length (and at least 1) and no other candidate is as close: what a misspelt name
/// most likely meant. With several equally close candidates there is no telling, and `None`.
/// Names longer than [`MAX_SUGGESTED_NAME`] characters get no suggestion (the distance costs the
/// product of the two lengths, and a name read from untrusted input may be long).
///
/// ```
/// use kinechain::error::closest_name;
/// let links = ["base_link", "shoulder_link", "tool0", "tool1"];
/// assert_eq!(closest_name("shoulder_lnk", links).as_deref(), Some("shoulder_link"));
/// assert_eq!(closest_name("Tool0", links).as_deref(), Some("tool0"));
/// assert_eq!(closest_name("tool2", links), None); // tool0 and tool1 are as close
/// assert_eq!(closest_name("elbow", links), None);
/// ```
#[must_use]
pub fn closest_name<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<String> {
    if name.chars().count() > MAX_SUGGESTED_NAME {
        return None;
    }
    let name: Vec<char> = name.chars().flat_map(char::to_lowercase).collect();
    let most = (name.len() / 3).max(1);
    // The closest candidate so far, and whether another one is as close.
    let mut best: Option<(usize, &str, bool)> = None;
    // One row of the edit-distance table, reused for every candidate.
    let mut row: Vec<usize> = Vec::new();
    for candidate in candidates {
        // The distance is at least the difference in length, counted as the distance counts
        // (after lowercasing, which can lengthen a name: 'İ' becomes two characters).
        if candidate
            .chars()
            .flat_map(char::to_lowercase)
            .count()
            .abs_diff(name.len())
            > most
        {
            continue;
        }
        let d = edit_distance(&name, candidate, &mut row);
        match best {
            _ if d > most => {}
            Some((b, _, ref mut tied)) if d == b => *tied = true,
            Some((b, _, _)) if d > b => {}
            _ => best = Some((d, candidate, false)),
        }
    }
    match best {
        Some((_, c, false)) => Some(c.to_string()),
        _ => None,
    }
}

/// Levenshtein distance between `a` (already lowercase) and `b` (lowercased here), with `row`
/// as scratch space.
fn edit_distance(a: &[char], b: &str, row: &mut Vec<usize>) -> usize {
    row.clear();
    row.extend(0..=a.len());
    for (j, cb) in b.chars().flat_map(char::to_lowercase).enumerate() {
        // `diagonal` is the previous row's entry left of the one being replaced.
        let mut diagonal = row[0];
        row[0] = j + 1;
        for (i, &ca) in a.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != cb);
            diagonal = row[i + 1];
            row[i + 1] = substitute.min(row[i] + 1).min(diagonal + 1);
        }
    }
    row[a.len()]
}
