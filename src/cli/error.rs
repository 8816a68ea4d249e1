//! The errors of the command line, each with its exit status.

use crate::cli::limits::MAX_BENCH_FRAMES;
use crate::io::input::InputError;
use crate::model::error::escape_controls;
use std::path::PathBuf;

/// A failure of a CLI command (printed as `error: …` with its source chain).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CliError {
    /// The robot file could not be loaded.
    #[error(transparent)]
    Load(#[from] crate::io::error::LoadError),
    /// Options that are not taken together.
    #[error("{0}")]
    Unsupported(&'static str),
    /// An inverse-kinematics target, option or solve that failed.
    #[error("{0}")]
    Ik(String),
    /// A page that could not be made (`view`).
    #[error("{0}")]
    View(String),
    /// A joint-space vector could not be read.
    #[error(transparent)]
    Input(#[from] InputError),
    /// A configuration cannot be evaluated.
    #[error(transparent)]
    State(#[from] crate::eval::error::StateError),
    /// A link name is unknown.
    #[error(transparent)]
    Name(#[from] crate::model::error::NameError),
    /// The robot cannot be written as URDF.
    #[error(transparent)]
    Convert(#[from] crate::io::convert::ConvertError),
    /// A result overflowed (finite joint values so large that a position, velocity or
    /// acceleration exceeds the `f64` range), which JSON could not print nor `render` draw.
    #[error(
        "{what} of {place} overflows f64 (not finite): the joint values or rates are too large"
    )]
    NotFinite {
        /// The quantity (`pose`, `omega`, `v`, `alpha`, `a`, `velocity`, `acceleration`, `jacobian`,
        /// `jacobian rate`; `axis` of a joint in `render`).
        what: &'static str,
        /// `link 'NAME'`, `point NAME (x, y, z)` or `joint 'NAME'`.
        place: String,
    },
    /// `bench` on a chain without moving joints.
    #[error("the chain has no moving joints: its poses are constant and there is nothing to time")]
    NothingToTime,
    /// `bench --configurations` times the links would keep more frames than the run may hold.
    #[error(
        "--configurations {configurations} with {links} links would keep {} link frames of 96 bytes, more than the {MAX_BENCH_FRAMES} that `bench` holds; at most {most} configurations for this robot",
        configurations.saturating_mul(*links)
    )]
    BenchTooLarge {
        /// Configurations asked for.
        configurations: usize,
        /// Links of the robot.
        links: usize,
        /// The most configurations allowed for this robot.
        most: usize,
    },
    /// `--format csv` asked of what it cannot print.
    #[error("--format csv {0}")]
    Csv(&'static str),
    /// `--qdd` without `--qd`.
    #[error("--qdd needs --qd (accelerations depend on velocities)")]
    QddWithoutQd,
    /// A `--point` argument is not `LINK:x,y,z`.
    #[error("--point '{0}': expected LINK:x,y,z (three numbers, link coordinates in metres)")]
    Point(String),
    /// A batch line failed.
    #[error("{}: line {line}", path.display())]
    BatchLine {
        /// The batch file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What went wrong.
        #[source]
        source: Box<CliError>,
    },
    /// A ROS bag could not be read as joint states.
    #[error(transparent)]
    Bag(#[from] crate::io::bag::BagError),
    /// A TF file that could not be written.
    #[error(transparent)]
    Tf(#[from] crate::io::tf::TfError),
    /// The bag's topic does not name every joint of the chain.
    #[error(
        "{}: topic {topic} has no values for joints {} (its joints: {})",
        path.display(),
        quoted(missing),
        quoted(present)
    )]
    BagJoints {
        /// The bag.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The chain's joints (entries of `q`) that no message names.
        missing: Vec<String>,
        /// The joints the topic names.
        present: Vec<String>,
    },
    /// A bag's message failed.
    #[error("{}: message {index} (time {time} ns)", path.display())]
    BagMessage {
        /// The bag.
        path: PathBuf,
        /// Its index among the topic's messages, from 0.
        index: usize,
        /// Its time, ns.
        time: i64,
        /// What went wrong.
        #[source]
        source: Box<CliError>,
    },
    /// Some bag messages failed under `--keep-going`.
    #[error("{}: {count} message(s) failed (their errors are in the output, each in its message's place)", path.display())]
    BagFailures {
        /// The bag.
        path: PathBuf,
        /// Messages that failed.
        count: usize,
    },
    /// A batch line is longer than any configuration of the chain could need.
    #[error("the line is longer than {limit} bytes, the most read for one configuration")]
    LineTooLong {
        /// The cap, in bytes.
        limit: usize,
    },
    /// More than the bytes a batch line may skip came without a line end: the rest of the input
    /// cannot be split into lines.
    #[error(
        "no line end in the {limit} bytes that follow the line's start; the input cannot be read as lines (the results before it are written)"
    )]
    Unended {
        /// Bytes read without a line end.
        limit: usize,
    },
    /// A batch line is not UTF-8 text.
    #[error("byte {byte} of the line is not UTF-8 text")]
    NotUtf8 {
        /// 1-based position of the first byte that is not.
        byte: usize,
    },
    /// Some batch lines failed under `--keep-going`.
    #[error("{}: {count} line(s) failed (their errors are in the output, each in its line's place)", path.display())]
    BatchFailures {
        /// The batch file.
        path: PathBuf,
        /// Lines that failed.
        count: usize,
    },
    /// An output file could not be written (or would overwrite an input).
    #[error(transparent)]
    Output(#[from] crate::io::output::OutputError),
    /// A regression record, verification or comparison could not be made.
    #[error(transparent)]
    Regression(#[from] crate::regression::RegressionError),
    /// `verify` or `compare`: a link moved beyond the tolerances (the report says which).
    #[error("link '{}' moved beyond the tolerances", escape_controls(link))]
    Moved {
        /// The first such link along the chain.
        link: String,
    },
    /// Reading input or writing output failed.
    #[error("{context}")]
    Io {
        /// What was being read or written.
        context: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}

/// Names, each quoted, separated by commas (`none` for none).
fn quoted(names: &[String]) -> String {
    if names.is_empty() {
        return "none".into();
    }
    let quoted: Vec<String> = names
        .iter()
        .map(|n| format!("'{}'", escape_controls(n)))
        .collect();
    quoted.join(", ")
}
