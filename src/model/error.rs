//! What building a chain can fail with ([`ModelError`]) and what a name given to a chain can
//! fail with ([`NameError`]), with the helpers every layer's messages share: the likely spelling
//! of a misspelt name and the escaping of control characters.

use crate::model::transform::NotRigid;

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

/// Most names an error message lists; the rest are counted.
pub(crate) const MAX_LISTED: usize = 10;

/// `names` joined by commas, the first [`MAX_LISTED`] of them and a count of the rest.
pub(crate) fn listed(names: &[String]) -> String {
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
    /// A floating joint where kinechain cannot evaluate one.
    #[error("floating joint '{joint}': {problem}")]
    FloatingJoint {
        /// The floating joint.
        joint: String,
        /// What is wrong with where it is.
        problem: String,
    },
    /// A named configuration has not `nq` entries.
    #[error("keyframe '{name}' has {len} entries; the chain takes {nq}")]
    KeyframeLength {
        /// The configuration's name.
        name: String,
        /// Its entries.
        len: usize,
        /// What the chain takes.
        nq: usize,
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
