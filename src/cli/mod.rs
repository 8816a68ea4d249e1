//! The `kinechain` command line: argument parsing, library calls, output. `main.rs` only calls
//! [`main`].

use crate::error::error_chain;

use crate::eval::batch::{
    BatchData, forward_accelerations_batch, forward_kinematics_batch, forward_velocities_batch,
    jacobian_batch, jacobian_dot_batch,
};
use crate::eval::chain::Chain;
use crate::eval::data::{Data, LimitPolicy};
use crate::eval::jacobian::JacobianFrame;
use crate::eval::kinematics::{
    AccelerationParts, LinkAcceleration, LinkVelocity, Poses, Velocities, check_q,
    forward_accelerations, forward_kinematics, forward_kinematics_to, forward_velocities,
};
use crate::io::input::{InputError, joint_vector_from_str};
use crate::measure::worse;
use crate::model::chain::LinkId;
use crate::model::error::escape_controls;
use crate::model::transform::Transform;
use clap::{Parser, Subcommand, ValueEnum};
use nalgebra::Vector3;
use serde::{Serialize, Serializer, ser::SerializeMap};
use serde_json::{Map, Value, json};
use std::hint::black_box;
use std::io::{BufRead, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod batch;
mod bench;
mod fk;
mod format;
mod info;
mod regression;

#[allow(clippy::wildcard_imports)]
use self::{batch::*, bench::*, fk::*, format::*, info::*, regression::*};

/// Forward kinematics of robot chains from DH YAML or URDF files.
#[derive(Debug, Parser)]
#[command(name = "kinechain", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// List the joints (in q order) and links of a robot.
    Info {
        /// Robot file (.yaml/.yml DH table or .urdf).
        robot: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t = OutputFormat::Json)]
        format: OutputFormat,
    },
    /// Poses (and velocities, accelerations) of the links at a configuration.
    Fk(FkArgs),
    /// Write the robot as URDF (DH tables and the axis form; the links keep their names and
    /// poses).
    Convert {
        /// Robot file (.yaml/.yml DH table or .urdf).
        robot: PathBuf,
        /// Output file (default: standard output).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Draw the robot at a configuration as SVG: front, side, top and isometric views.
    Render {
        /// Robot file (.yaml/.yml DH table or .urdf).
        robot: PathBuf,
        /// Joint positions (same forms as for fk).
        #[arg(long, allow_hyphen_values = true)]
        q: String,
        /// Output file (default: standard output).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Draw joint values outside the joints' limits instead of refusing them.
        #[arg(long)]
        ignore_limits: bool,
    },
    /// Time per configuration of each evaluation mode, and its error against a high-precision
    /// evaluation of the same model; the `k` crate in the same rounds, on the robot file or (DH
    /// tables, the axis form) on the URDF `convert` writes.
    Bench {
        /// Robot file (.yaml/.yml DH table or .urdf).
        robot: PathBuf,
        /// What to compute: poses, poses and velocities, or poses, velocities and accelerations.
        #[arg(long, value_enum, default_value_t = Level::Pose)]
        level: Level,
        /// Random configurations (within the joint limits) to time and check; at least two, so
        /// that the incremental row's updates move a joint, and at most 65536 (each is checked
        /// against a 256-bit evaluation, and the batch rows keep every link's frame).
        #[arg(long, default_value_t = 64, value_parser = configuration_count)]
        configurations: usize,
        /// The link that every method reads and the one-link methods evaluate up to (default:
        /// the link farthest from the base).
        #[arg(long, value_name = "NAME")]
        link: Option<String>,
    },
    /// Record every link's pose (and rates) at seeded configurations into a golden file (JSON
    /// lines), for `verify` to check a robot against later.
    Record {
        /// Robot file (.yaml/.yml DH table or .urdf).
        robot: PathBuf,
        /// Output file (default: standard output).
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        sampling: SampleArgs,
    },
    /// Check a robot against a golden file: per link, the largest position, rotation and rate
    /// differences and where they occur. Joints are matched by name. Exit status 0 when every
    /// link is within the tolerances, 1 when a link moved beyond them, 2 on any error.
    Verify {
        /// Robot file (.yaml/.yml DH table or .urdf).
        robot: PathBuf,
        /// Golden file written by `record`.
        golden: PathBuf,
        #[command(flatten)]
        tolerances: TolArgs,
        /// Output format.
        #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
        format: OutputFormat,
    },
    /// Compare two robot files at seeded configurations of the first, joints matched by name
    /// (both must have the same joints, after --rename), over the links they share; lists the
    /// links only one has. Exit status as for `verify`.
    Compare {
        /// The first robot file.
        robot_a: PathBuf,
        /// The second robot file.
        robot_b: PathBuf,
        /// A joint named OLD in the first robot and NEW in the second (repeatable). Both robots
        /// must otherwise have the same joints.
        #[arg(long = "rename", value_name = "OLD=NEW", value_parser = rename)]
        renames: Vec<(String, String)>,
        #[command(flatten)]
        sampling: SampleArgs,
        #[command(flatten)]
        tolerances: TolArgs,
        /// Output format.
        #[arg(long, value_enum, default_value_t = OutputFormat::Table)]
        format: OutputFormat,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Level {
    Pose,
    Vel,
    Acc,
}

#[derive(Debug, clap::Args)]
struct FkArgs {
    /// Robot file (.yaml/.yml DH table or .urdf).
    robot: PathBuf,
    /// Joint positions: JSON array in q order, JSON object keyed by joint name, or a list
    /// separated by commas or spaces.
    #[arg(
        long,
        allow_hyphen_values = true,
        required_unless_present = "batch",
        conflicts_with = "batch"
    )]
    q: Option<String>,
    /// Joint velocities (same forms as --q); adds "omega" and "v" to the output.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "batch")]
    qd: Option<String>,
    /// Joint accelerations (same forms as --q); adds "alpha" and "a". Needs --qd.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "batch")]
    qdd: Option<String>,
    /// A JSON-lines file with one configuration per line: {"q": .., "qd": .., "qdd": ..}, or q
    /// alone as a JSON array or numbers separated by commas or spaces (a CSV row, in the order
    /// of a first row of joint names if there is one); `-` reads standard input, writing each
    /// result before waiting for more input.
    #[arg(long)]
    batch: Option<PathBuf>,
    /// Only these links (repeatable); only the joints they depend on are evaluated.
    #[arg(long = "link", value_name = "NAME")]
    links: Vec<String>,
    /// A point fixed on a link, in link coordinates (m): prints its position, and its velocity and
    /// acceleration when --qd/--qdd are given (repeatable).
    #[arg(long = "point", value_name = "LINK:X,Y,Z", allow_hyphen_values = true)]
    points: Vec<String>,
    /// The geometric Jacobian of a link: the 6 × dof matrix J with [v; ω] = J q̇, world frame,
    /// linear rows first, columns in q order (repeatable). With --qd, also its time derivative
    /// J̇, so that [a; α] = J q̈ + J̇ q̇.
    #[arg(long = "jacobian", value_name = "LINK")]
    jacobians: Vec<String>,
    /// Evaluate joint values outside the joints' limits instead of refusing them.
    #[arg(long)]
    ignore_limits: bool,
    /// With --batch: on a bad line, write {"line": N, "error": ".."} (in a table, `line N:
    /// error: ..`) in its place and go on; exit non-zero at the end if any line failed.
    #[arg(long, requires = "batch")]
    keep_going: bool,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Json)]
    format: OutputFormat,
    /// How to print each link's orientation: the pose matrix, or the position and one set of
    /// orientation coordinates (null, or `undefined` in a table, where undefined).
    #[arg(long, value_enum, default_value_t = Orientation::Matrix)]
    orientation: Orientation,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum OutputFormat {
    Json,
    Table,
    /// Comma-separated values (`fk` only): a header row, then one row per configuration.
    Csv,
}

/// A failure of a CLI command (printed as `error: …` with its source chain).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CliError {
    /// The robot file could not be loaded.
    #[error(transparent)]
    Load(#[from] crate::io::error::LoadError),
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

/// Runs the command line and returns the process exit code; errors are printed to stderr as one
/// line, `error: ` followed by the error and its sources.
#[must_use]
pub fn main() -> ExitCode {
    main_with(false)
}

/// [`main`], told whether the process started with its standard output closed (the standard
/// library reopens a closed one on `/dev/null` before `main` runs, so only code that runs
/// earlier can tell; the `kinechain` binary does). A command whose results go to standard output
/// then fails rather than lose them.
#[must_use]
pub fn main_with(stdout_closed: bool) -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            // clap's message spans several lines; keep what precedes the usage text, on one.
            let text = e.to_string();
            let message: Vec<&str> = text
                .lines()
                .map(str::trim)
                .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("{} (see --help)", escape_controls(&message.join(" ")));
            return ExitCode::from(2);
        }
    };
    let writes_stdout = !matches!(
        &cli.command,
        Command::Convert {
            output: Some(_),
            ..
        } | Command::Render {
            output: Some(_),
            ..
        } | Command::Record {
            output: Some(_),
            ..
        }
    );
    if writes_stdout && stdout_closed {
        eprintln!("error: standard output is closed: the results would be lost");
        return ExitCode::FAILURE;
    }
    // `verify` and `compare` tell a moved link (1) from an error (2).
    let verdicts = matches!(
        &cli.command,
        Command::Verify { .. } | Command::Compare { .. }
    );
    let stdout = std::io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let result = run(cli.command, &mut out).and_then(|()| out.flush().map_err(output_error));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError::Moved { .. }) => match out.flush() {
            Ok(()) => ExitCode::FAILURE,
            Err(_) => ExitCode::from(2),
        },
        // The reader went away (`kinechain fk … | head`): stop quietly, as a shell tool does.
        Err(CliError::Io { source, .. }) if source.kind() == std::io::ErrorKind::BrokenPipe => {
            ExitCode::SUCCESS
        }
        Err(e) => {
            let _ = out.flush();
            eprintln!("error: {}", error_chain(&e));
            if verdicts {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// A path as printed in a message, its control characters escaped.
fn shown(path: &Path) -> String {
    escape_controls(&path.display().to_string()).into_owned()
}

fn load(path: &PathBuf) -> Result<Chain, CliError> {
    let chain = Chain::from_file(path)?;
    for w in chain.warnings() {
        eprintln!("warning: {}: {w}", shown(path));
    }
    Ok(chain)
}

/// Warns of what a URDF file holds beyond its kinematics, which `convert` does not write.
fn warn_dropped(path: &Path) {
    let dropped = std::fs::read_to_string(path)
        .ok()
        .and_then(|text| crate::io::convert::dropped_from_urdf(&text));
    if let Some(dropped) = dropped {
        eprintln!(
            "warning: {}: the URDF written has the kinematics only; not written: {dropped}",
            shown(path)
        );
    }
}

/// Writes `text` to `path` by the rules of [`crate::io::output`] (never over `input`; FIFOs and
/// devices in place, regular files through a temporary file renamed into place, links
/// followed), or to `out` when there is no path.
fn write_output(
    path: Option<&PathBuf>,
    input: &Path,
    text: &str,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    match path {
        None => out.write_all(text.as_bytes()).map_err(output_error),
        Some(path) => Ok(crate::io::output::write_file(
            path,
            text.as_bytes(),
            &[input],
        )?),
    }
}

/// An error when `output` names the file `input` (checked before the robot is read, so that the
/// refusal comes first; [`write_output`] checks again).
fn refuse_overwrite(output: Option<&PathBuf>, input: &Path) -> Result<(), CliError> {
    match output {
        Some(path) => Ok(crate::io::output::refuse_inputs(path, &[input])?),
        None => Ok(()),
    }
}

fn write_line(out: &mut dyn Write, text: &str) -> Result<(), CliError> {
    writeln!(out, "{text}").map_err(output_error)
}

/// A failure to write the output (standard output, or the writer `run` is given).
fn output_error(source: std::io::Error) -> CliError {
    CliError::Io {
        context: "cannot write output".into(),
        source,
    }
}

fn run(command: Command, out: &mut dyn Write) -> Result<(), CliError> {
    match command {
        Command::Info { robot, format } => info(&load(&robot)?, format, out),
        Command::Fk(args) => fk(&args, out),
        Command::Bench {
            robot,
            level,
            configurations,
            link,
        } => bench(&robot, level, configurations, link.as_deref(), out),
        Command::Convert { robot, output } => {
            refuse_overwrite(output.as_ref(), &robot)?;
            let chain = load(&robot)?;
            let text = crate::io::convert::to_urdf(&chain)?;
            if crate::io::Format::from_path(&robot) == Some(crate::io::Format::Urdf) {
                warn_dropped(&robot);
            }
            write_output(output.as_ref(), &robot, &text, out)
        }
        Command::Render {
            robot,
            q,
            output,
            ignore_limits,
        } => {
            refuse_overwrite(output.as_ref(), &robot)?;
            let chain = load(&robot)?;
            let q = joint_vector_from_str(&chain, &q, "q")?;
            let mut data = Data::new(&chain);
            if ignore_limits {
                data.set_limit_policy(LimitPolicy::Ignore);
            }
            let poses = forward_kinematics(&chain, &mut data, &q)?;
            let drawing =
                crate::io::render::svg(&chain, &poses).map_err(|e| CliError::NotFinite {
                    what: e.what,
                    place: e.place,
                })?;
            write_output(output.as_ref(), &robot, &drawing, out)
        }
        Command::Record {
            robot,
            output,
            sampling,
        } => record(&robot, output.as_ref(), &sampling, out),
        Command::Verify {
            robot,
            golden,
            tolerances,
            format,
        } => verify(&robot, &golden, &tolerances, format, out),
        Command::Compare {
            robot_a,
            robot_b,
            renames,
            sampling,
            tolerances,
            format,
        } => compare(
            [&robot_a, &robot_b],
            &renames,
            &sampling,
            &tolerances,
            format,
            out,
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A table's numbers: six decimals right-aligned, exponent form from 10⁹ on, and no sign on
    /// a value that shows as zero, whether it is padded, fills its width or has none.
    #[test]
    fn table_numbers() {
        let cell = |x: f64, width: usize| {
            let mut buf = b"|".to_vec();
            push_fixed(&mut buf, x, width);
            String::from_utf8(buf).unwrap()
        };
        assert_eq!(cell(-2.5, 12), "|   -2.500000");
        assert_eq!(cell(0.25, 0), "|0.250000");
        assert_eq!(cell(-0.0, 12), "|    0.000000");
        assert_eq!(cell(-6e-17, 0), "|0.000000");
        assert_eq!(cell(-4e-7, 9), "| 0.000000");
        assert_eq!(cell(-4e-7, 8), "|0.000000");
        assert_eq!(cell(-6e-7, 9), "|-0.000001");
        assert_eq!(cell(-2e9, 12), "| -2.000000e9");
        assert_eq!(cell(123_456_789.0, 0), "|123456789.000000");
        let mut buf = Vec::new();
        push_cells(&mut buf, [1.0, -0.0, 2.0], b"; ", 0);
        assert_eq!(buf, b"1.000000; 0.000000; 2.000000");
    }

    /// Reads every line of `input` through a reader that returns at most `chunk` bytes at a
    /// time, with lines capped at `limit` bytes: `Some(text)` per line kept, `None` per line
    /// too long.
    fn lines(input: &[u8], chunk: usize, limit: usize) -> Vec<Option<String>> {
        let mut reader = std::io::BufReader::with_capacity(chunk, input);
        let (mut buf, mut out) = (Vec::new(), Vec::new());
        loop {
            match read_capped_line(&mut reader, &mut buf, limit, usize::MAX).unwrap() {
                CappedLine::Line => out.push(Some(String::from_utf8(buf.clone()).unwrap())),
                CappedLine::TooLong => out.push(None),
                CappedLine::End | CappedLine::Unended => return out,
            }
        }
    }

    /// A line of exactly the cap is kept and one byte more is not, whether the line arrives in
    /// one piece or many; a long line is skipped to its end, and the lines around it are read.
    #[test]
    fn lines_are_capped_at_exactly_the_limit() {
        for chunk in [4, 7, 64, 1 << 16] {
            let (at, over) = ("a".repeat(40), "b".repeat(41));
            let input = format!("x\n{at}\n{over}\r\ny\r\n{}\nlast", "c".repeat(500));
            let got = lines(input.as_bytes(), chunk, 40);
            let want = [
                Some("x".into()),
                Some(at.clone()),
                None,
                Some("y".into()),
                None,
                Some("last".into()),
            ];
            assert_eq!(got, want, "chunks of {chunk}");
        }
        // A line far longer than the reader's buffer and within the cap is whole.
        let long = "d".repeat(100_000);
        assert_eq!(
            lines(format!("{long}\n").as_bytes(), 8192, 1 << 20),
            [Some(long)]
        );
        assert_eq!(lines(b"", 16, 40), []);
    }

    #[test]
    fn bench_takes_two_to_the_most_configurations() {
        let most = MAX_BENCH_CONFIGURATIONS;
        for (n, ok) in [(1, false), (2, true), (most, true), (most + 1, false)] {
            let got = configuration_count(&n.to_string());
            assert_eq!(got.clone().ok(), ok.then_some(n), "{n}: {got:?}");
        }
        assert!(configuration_count("many").is_err());
    }
}
