//! The errors of recording, verifying and comparing.

use super::options::{MAX_GOLDEN_BYTES, MAX_GOLDEN_LINE_BYTES};
use crate::eval::error::StateError;
use crate::model::error::NameError;

/// Why a record, a verification or a comparison could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RegressionError {
    /// A golden file is not what [`write_golden`](crate::regression::write_golden) writes.
    #[error("{file}:{line}: {problem}")]
    Golden {
        /// The file as named by the caller.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong there.
        problem: String,
    },
    /// The robot lacks joints the record has, or has joints the record lacks.
    #[error("{}", names_problem("joints", missing, extra))]
    Joints {
        /// Recorded joint entries the robot does not have.
        missing: Vec<String>,
        /// The robot's joint entries the record does not have.
        extra: Vec<String>,
    },
    /// The robot lacks links the record has (or that were asked for).
    #[error("{}", names_problem("links", missing, &[]))]
    Links {
        /// The link names missing.
        missing: Vec<String>,
    },
    /// A link name asked for is not in the robot.
    #[error(transparent)]
    Name(#[from] NameError),
    /// A configuration could not be evaluated.
    #[error("sample {sample}")]
    State {
        /// The sample.
        sample: usize,
        /// Why.
        #[source]
        source: StateError,
    },
    /// A recorded or evaluated quantity is not finite (limits so wide that poses overflow).
    #[error("sample {sample}: the {what} of link '{link}' is not finite")]
    NotFinite {
        /// The sample.
        sample: usize,
        /// The link.
        link: String,
        /// `pose`, `omega`, `v`, `alpha` or `a`.
        what: &'static str,
    },
    /// A chain without joints to move, or a record without samples.
    #[error("{0}")]
    Empty(&'static str),
    /// A golden file cannot be read, or is larger than the reader takes.
    #[error("cannot read {file}")]
    Read {
        /// The file as named by the caller.
        file: String,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The golden file would be larger than [`read_golden_file`](crate::regression::read_golden_file) reads back: nothing written.
    #[error(
        "the golden file would be {size} bytes with a line of {longest_line}, more than the {} bytes (or {} for a line) that kinechain reads back: record fewer samples or links",
        MAX_GOLDEN_BYTES,
        MAX_GOLDEN_LINE_BYTES
    )]
    TooLarge {
        /// Its size in bytes.
        size: usize,
        /// Its longest line in bytes.
        longest_line: usize,
    },
    /// The golden file could not be written.
    #[error(transparent)]
    Output(#[from] crate::io::output::OutputError),
    /// `compare`: joints that only one of the robots has, and no mapping for them.
    #[error("{}", unmatched_problem(only_in_first, only_in_second))]
    UnmatchedJoints {
        /// Joint entries of the first robot that the second lacks.
        only_in_first: Vec<String>,
        /// Joint entries of the second robot that the first lacks.
        only_in_second: Vec<String>,
    },
    /// `compare`: a rename that names a joint one of the robots does not have, or names one twice.
    #[error("rename {old}={new}: {problem}")]
    Rename {
        /// The first robot's joint name.
        old: String,
        /// The second robot's joint name.
        new: String,
        /// What is wrong.
        problem: String,
    },
}

fn unmatched_problem(first: &[String], second: &[String]) -> String {
    let list = |v: &[String]| {
        if v.is_empty() {
            return "none".to_string();
        }
        v.iter()
            .map(|n| format!("'{}'", crate::model::error::escape_controls(n)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "the robots' joints differ, and a joint only one robot has cannot be compared: only in the first: {}; only in the second: {} (map a renamed joint with --rename OLD=NEW, OLD of the first robot, NEW of the second)",
        list(first),
        list(second)
    )
}

fn names_problem(what: &str, missing: &[String], extra: &[String]) -> String {
    let list = |v: &[String]| {
        v.iter()
            .map(|n| format!("'{}'", crate::model::error::escape_controls(n)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    match (missing.is_empty(), extra.is_empty()) {
        (false, true) => format!(
            "{what} of the record missing from the robot: {}",
            list(missing)
        ),
        (true, false) => format!(
            "{what} of the robot missing from the record: {}",
            list(extra)
        ),
        _ => format!(
            "{what} of the record missing from the robot: {}; {what} of the robot missing from the record: {}",
            list(missing),
            list(extra)
        ),
    }
}
