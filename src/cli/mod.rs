//! The `kinechain` command line: argument parsing, library calls, output. `main.rs` only calls
//! [`main`].

use crate::error::error_chain;

use crate::model::error::escape_controls;
use crate::eval::batch::{BatchData, forward_kinematics_batch};
use crate::eval::data::{Data, LimitPolicy};
use crate::eval::kinematics::{
    AccelerationParts, LinkAcceleration, LinkVelocity, Poses, Velocities, check_q,
    forward_accelerations, forward_kinematics, forward_kinematics_to, forward_velocities,
};
use crate::io::input::{InputError, joint_vector_from_str};
use crate::measure::worse;
use crate::eval::chain::Chain;
use crate::model::chain::LinkId;
use crate::model::transform::Transform;
use clap::{Parser, Subcommand, ValueEnum};
use nalgebra::Vector3;
use serde::{Serialize, Serializer, ser::SerializeMap};
use serde_json::{Map, Value, json};
use std::hint::black_box;
use std::io::{BufRead, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

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
    /// `convert -o` or `render -o` names the robot file being read.
    #[error(
        "the output {} is the robot file {} (the same file): refusing to overwrite it",
        output.display(),
        input.display()
    )]
    OutputIsInput {
        /// The output path given.
        output: PathBuf,
        /// The robot file.
        input: PathBuf,
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
        }
    );
    if writes_stdout && stdout_closed {
        eprintln!("error: standard output is closed: the results would be lost");
        return ExitCode::FAILURE;
    }
    let stdout = std::io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let result = run(cli.command, &mut out).and_then(|()| out.flush().map_err(output_error));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader went away (`kinechain fk … | head`): stop quietly, as a shell tool does.
        Err(CliError::Io { source, .. }) if source.kind() == std::io::ErrorKind::BrokenPipe => {
            ExitCode::SUCCESS
        }
        Err(e) => {
            let _ = out.flush();
            eprintln!("error: {}", error_chain(&e));
            ExitCode::FAILURE
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

/// Writes `text` to `path`, or to `out` when there is no path. A path that names the file
/// `input` (the same file by path, symbolic link or hard link) is refused, and the file is
/// written whole to a temporary file beside it and renamed into place, so that a failure leaves
/// no half-written output and an existing file is replaced only by a complete one.
fn write_output(
    path: Option<&PathBuf>,
    input: &Path,
    text: &str,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let Some(path) = path else {
        return out.write_all(text.as_bytes()).map_err(output_error);
    };
    // (Checked before the robot is read too, so that the refusal comes first; again here, in
    // case a link was made meanwhile.)
    refuse_overwrite(Some(path), input)?;
    let fail = |source| CliError::Io {
        context: format!("cannot write {}", path.display()),
        source,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| {
        fail(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "the path names no file",
        ))
    })?;
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!(".kinechain-{}.tmp", std::process::id()));
    let temp = dir.join(temp_name);
    let written = (|| {
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temp)?;
        file.write_all(text.as_bytes())?;
        file.sync_all()?;
        std::fs::rename(&temp, path)
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&temp);
        return Err(fail(e));
    }
    Ok(())
}

/// An error when `output` names the file `input`.
fn refuse_overwrite(output: Option<&PathBuf>, input: &Path) -> Result<(), CliError> {
    match output {
        Some(path) if same_file(path, input) => Err(CliError::OutputIsInput {
            output: path.clone(),
            input: input.to_path_buf(),
        }),
        _ => Ok(()),
    }
}

/// Whether `a` and `b` name the same existing file (through symbolic or hard links too).
fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(x), Ok(y)) if x == y
        )
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
    }
}

fn limits_json(joint: &crate::model::chain::Joint) -> Value {
    let one = |l: &Option<crate::model::joint::Limits>| match l {
        Some(l) => json!([l.lower, l.upper]),
        None => Value::Null,
    };
    match joint.limits() {
        [l] => one(l),
        [theta, d] => json!({"theta": one(theta), "d": one(d)}),
        _ => Value::Null,
    }
}

/// The limits column of `info --format table`: `[lower, upper]` or `none`, a cylindrical
/// joint's as `theta [..], d [..]`.
fn limits_text(joint: &crate::model::chain::Joint) -> String {
    let one = |l: &Option<crate::model::joint::Limits>| match l {
        Some(l) => format!("[{}, {}]", l.lower, l.upper),
        None => "none".to_string(),
    };
    match joint.limits() {
        [l] => one(l),
        [theta, d] => format!("theta {}, d {}", one(theta), one(d)),
        _ => String::new(),
    }
}

fn info(chain: &Chain, format: OutputFormat, out: &mut dyn Write) -> Result<(), CliError> {
    let independent = chain.joints().iter().filter(|j| j.dof() > 0);
    let passive = chain.joints().iter().filter(|j| j.dof() == 0);
    match format {
        OutputFormat::Json => {
            let joints: Vec<Value> = independent
                .map(|j| {
                    json!({
                        "name": j.name(),
                        "type": j.kind().as_str(),
                        "dof": j.dof(),
                        "limits": limits_json(j),
                    })
                })
                .collect();
            let passive: Vec<Value> = passive
                .map(|j| {
                    let mut m = Map::new();
                    m.insert("name".into(), json!(j.name()));
                    m.insert("type".into(), json!(j.kind().as_str()));
                    if let Some(mimic) = j.mimic() {
                        m.insert(
                            "mimic".into(),
                            json!({
                                "joint": chain.joint(mimic.primary).name(),
                                "multiplier": mimic.multiplier,
                                "offset": mimic.offset,
                            }),
                        );
                    }
                    Value::Object(m)
                })
                .collect();
            let links: Vec<&str> = chain.links().iter().map(|l| l.name()).collect();
            let value = json!({
                "name": chain.name(),
                "dof": chain.dof(),
                "joints": joints,
                "passive_joints": passive,
                "links": links,
            });
            write_line(out, &value.to_string())
        }
        OutputFormat::Table => {
            let mut text = format!(
                "{}: {} degree{} of freedom\n",
                chain.name(),
                chain.dof(),
                if chain.dof() == 1 { "" } else { "s" }
            );
            text.push_str(&format!(
                "{:>4}  {:<28} {:<12} {}\n",
                "q", "joint", "type", "limits"
            ));
            for j in independent {
                let limits = limits_text(j);
                text.push_str(&format!(
                    "{:>4}  {:<28} {:<12} {}\n",
                    j.q_index().unwrap_or(0),
                    j.name(),
                    j.kind().as_str(),
                    limits
                ));
            }
            for j in passive {
                let note = match j.mimic() {
                    Some(m) => format!(
                        "mimics {} (x{} {:+})",
                        chain.joint(m.primary).name(),
                        m.multiplier,
                        m.offset
                    ),
                    None => String::new(),
                };
                text.push_str(&format!(
                    "{:>4}  {:<28} {:<12} {}\n",
                    "-",
                    j.name(),
                    j.kind().as_str(),
                    note
                ));
            }
            text.push_str("links:");
            for l in chain.links() {
                text.push(' ');
                text.push_str(l.name());
            }
            write_line(out, &text)
        }
    }
}

/// One configuration to evaluate.
struct Configuration {
    q: Vec<f64>,
    qd: Option<Vec<f64>>,
    qdd: Option<Vec<f64>>,
}

/// Per link: pose, and velocity/acceleration when asked for.
type LinkResult = (
    LinkId,
    Transform,
    Option<LinkVelocity>,
    Option<LinkAcceleration>,
);

/// A point fixed on a link.
struct Point {
    link: LinkId,
    u: Vector3<f64>,
}

/// Per point: position, velocity, acceleration and its parts, as far as asked for.
struct PointResult {
    position: Vector3<f64>,
    velocity: Option<Vector3<f64>>,
    acceleration: Option<(Vector3<f64>, AccelerationParts)>,
}

impl Point {
    /// `point LINK (x, y, z)`, the coordinates as given: for errors, and written straight into
    /// each table line.
    fn label<'a>(&'a self, chain: &'a Chain) -> PointLabel<'a> {
        PointLabel {
            link: chain.link(self.link).name(),
            u: &self.u,
        }
    }
}

/// [`Point::label`].
struct PointLabel<'a> {
    link: &'a str,
    u: &'a Vector3<f64>,
}

impl std::fmt::Display for PointLabel<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let u = self.u;
        write!(f, "point {} ({:?}, {:?}, {:?})", self.link, u.x, u.y, u.z)
    }
}

fn parse_point(chain: &Chain, text: &str) -> Result<Point, CliError> {
    let bad = || CliError::Point(text.to_string());
    let (link, coords) = text.rsplit_once(':').ok_or_else(bad)?;
    let values: Vec<f64> = coords
        .split(',')
        .map(|c| c.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    if values.len() != 3 || values.iter().any(|v| !v.is_finite()) {
        return Err(bad());
    }
    Ok(Point {
        link: chain.link_id(link)?,
        u: Vector3::new(values[0], values[1], values[2]),
    })
}

/// What `fk` computes for one configuration, in buffers reused from one to the next.
struct Outputs {
    /// Per link printed: pose and the rates asked for.
    links: Vec<LinkResult>,
    /// Per `--point`.
    points: Vec<PointResult>,
    /// Per `--jacobian` link.
    jacobians: Vec<JacobianResult>,
}

/// One `--jacobian` link's matrices, in buffers reused from one configuration to the next.
struct JacobianResult {
    link: LinkId,
    j: nalgebra::Matrix6xX<f64>,
    /// `J̇`, current when `with_rate` (the configuration has `qd`).
    j_dot: nalgebra::Matrix6xX<f64>,
    with_rate: bool,
}

/// Writes each Jacobian of `jacobians` from `poses`, and its time derivative from `velocities`
/// when given; an entry too large for `f64` is an error.
fn jacobians_from(
    chain: &Chain,
    poses: &Poses,
    velocities: Option<&Velocities>,
    jacobians: &mut [JacobianResult],
) -> Result<(), CliError> {
    for r in jacobians {
        let place = || format!("link '{}'", chain.link(r.link).name());
        poses.jacobian_into(r.link, &mut r.j);
        if !r.j.iter().all(|x| x.is_finite()) {
            return Err(CliError::NotFinite {
                what: "jacobian",
                place: place(),
            });
        }
        r.with_rate = velocities.is_some();
        if let Some(v) = velocities {
            v.jacobian_dot_into(r.link, &mut r.j_dot);
            if !r.j_dot.iter().all(|x| x.is_finite()) {
                return Err(CliError::NotFinite {
                    what: "jacobian rate",
                    place: place(),
                });
            }
        }
    }
    Ok(())
}

fn evaluate(
    chain: &Chain,
    data: &mut Data,
    c: &Configuration,
    links: &[LinkId],
    points: &[Point],
    out: &mut Outputs,
) -> Result<(), CliError> {
    let Outputs {
        links: results,
        points: point_results,
        jacobians,
    } = out;
    results.clear();
    point_results.clear();
    let all: Vec<LinkId>;
    let wanted = if links.is_empty() {
        all = (0..chain.links().len()).map(LinkId).collect();
        &all[..]
    } else {
        links
    };
    match (&c.qd, &c.qdd) {
        (None, Some(_)) => return Err(CliError::QddWithoutQd),
        // Only the paths to the links asked for, unless a point or a Jacobian needs the poses
        // view of a whole evaluation.
        (None, None) if !links.is_empty() && points.is_empty() && jacobians.is_empty() => {
            for &l in wanted {
                let pose = forward_kinematics_to(chain, data, &c.q, l)?;
                results.push((l, pose, None, None));
            }
        }
        (None, None) => {
            let poses = forward_kinematics(chain, data, &c.q)?;
            jacobians_from(chain, &poses, None, jacobians)?;
            results.extend(
                wanted
                    .iter()
                    .map(|&l| (l, poses.world_from_link(l), None, None)),
            );
            point_results.extend(points.iter().map(|p| {
                PointResult {
                    position: poses
                        .world_from_link(p.link)
                        .transform_point(&p.u.into())
                        .coords,
                    velocity: None,
                    acceleration: None,
                }
            }));
        }
        (Some(qd), None) => {
            let v = forward_velocities(chain, data, &c.q, qd)?;
            jacobians_from(chain, &v.poses(), Some(&v), jacobians)?;
            results.extend(
                wanted
                    .iter()
                    .map(|&l| (l, v.world_from_link(l), Some(v.velocity(l)), None)),
            );
            point_results.extend(points.iter().map(|p| {
                let m = v.point(p.link, &p.u);
                PointResult {
                    position: m.position,
                    velocity: Some(m.velocity),
                    acceleration: None,
                }
            }));
        }
        (Some(qd), Some(qdd)) => {
            let a = forward_accelerations(chain, data, &c.q, qd, qdd)?;
            jacobians_from(chain, &a.poses(), Some(&a.velocities()), jacobians)?;
            results.extend(wanted.iter().map(|&l| {
                (
                    l,
                    a.world_from_link(l),
                    Some(a.velocity(l)),
                    Some(a.acceleration(l)),
                )
            }));
            point_results.extend(points.iter().map(|p| {
                let m = a.point(p.link, &p.u);
                PointResult {
                    position: m.position,
                    velocity: Some(m.velocity),
                    acceleration: Some((m.acceleration, m.parts)),
                }
            }));
        }
    }
    Ok(())
}

/// `fk --format table`: appends a line per point (each starting with a newline): its position,
/// then its rates.
fn points_table(chain: &Chain, points: &[Point], results: &[PointResult], buf: &mut Vec<u8>) {
    let v3 = |buf: &mut Vec<u8>, label: &str, v: &Vector3<f64>| {
        let _ = write!(buf, "{label}(");
        push_cells(buf, [v.x, v.y, v.z], b", ", 0);
        buf.push(b')');
    };
    for (p, r) in points.iter().zip(results) {
        let _ = write!(buf, "\n{}: ", p.label(chain));
        v3(buf, "position ", &r.position);
        if let Some(v) = &r.velocity {
            v3(buf, ", velocity ", v);
        }
        if let Some((a, _)) = &r.acceleration {
            v3(buf, ", acceleration ", a);
        }
    }
}

/// `fk --format table`: appends each Jacobian (and `J̇`, with rates) under a heading naming its
/// link, one row per twist component (each line starting with a newline).
fn jacobians_table(chain: &Chain, jacobians: &[JacobianResult], buf: &mut Vec<u8>) {
    let block = |buf: &mut Vec<u8>, m: &nalgebra::Matrix6xX<f64>| {
        for (name, row) in ["v_x", "v_y", "v_z", "omega_x", "omega_y", "omega_z"]
            .iter()
            .zip(m.row_iter())
        {
            let _ = write!(buf, "\n{name:<8}");
            push_cells(buf, row.iter().copied(), b" ", 12);
        }
    };
    for r in jacobians {
        let link = chain.link(r.link).name();
        let _ = write!(
            buf,
            "\njacobian of {link} ([v; omega] = J qd, columns in q order)"
        );
        block(buf, &r.j);
        if r.with_rate {
            let _ = write!(
                buf,
                "\njacobian rate of {link} ([a; alpha] = J qdd + Jdot qd)"
            );
            block(buf, &r.j_dot);
        }
    }
}

/// How `fk` prints each link's orientation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Orientation {
    /// The 4×4 pose matrix (`"pose"`).
    Matrix,
    /// Euler parameters, `"quaternion": {"w", "x", "y", "z"}`.
    Quat,
    /// `"rpy": {"roll", "pitch", "yaw"}`, `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    Rpy,
    /// `"euler_zxz": {"phi", "theta", "psi"}`, `R = Rz(φ) Rx(θ) Rz(ψ)` (eq. 2.96).
    Zxz,
    /// `"axis_angle": {"axis": [x, y, z], "angle"}`.
    AxisAngle,
    /// Rodriguez parameters `"rodrigues": [γ1, γ2, γ3]` (eq. 2.77).
    Rodrigues,
}

/// The coordinates of `a` that `--orientation` names, in the order the README gives (the matrix
/// row by row, quaternion `w x y z`, `roll pitch yaw`, `phi theta psi`, the axis then the angle,
/// `γ1 γ2 γ3`); `None` where the representation is undefined (a singularity).
fn orientation_values(a: &nalgebra::Matrix3<f64>, kind: Orientation) -> Option<Coordinates> {
    use crate::orientation::{AxisAngle, EulerParameters, EulerZxz, RodriguezParameters, Rpy};
    match kind {
        Orientation::Matrix => Some(Coordinates::new([
            a.m11, a.m12, a.m13, a.m21, a.m22, a.m23, a.m31, a.m32, a.m33,
        ])),
        Orientation::Quat => {
            let e = EulerParameters::from_matrix(a);
            Some(Coordinates::new([e.e0, e.e1, e.e2, e.e3]))
        }
        Orientation::Rpy => Rpy::from_matrix(a)
            .ok()
            .map(|r| Coordinates::new([r.roll, r.pitch, r.yaw])),
        Orientation::Zxz => EulerZxz::from_matrix(a)
            .ok()
            .map(|e| Coordinates::new([e.phi, e.theta, e.psi])),
        Orientation::AxisAngle => AxisAngle::from_matrix(a)
            .ok()
            .map(|x| Coordinates::new([x.axis.x, x.axis.y, x.axis.z, x.angle])),
        Orientation::Rodrigues => RodriguezParameters::from_matrix(a)
            .ok()
            .map(|g| Coordinates::new([g.0.x, g.0.y, g.0.z])),
    }
}

/// The orientation coordinates of one link (at most a matrix's nine), held without an
/// allocation: the output of a batch makes one per link and line.
struct Coordinates {
    values: [f64; 9],
    len: usize,
}

impl Coordinates {
    fn new<const N: usize>(values: [f64; N]) -> Self {
        const { assert!(N <= 9) };
        let mut all = [0.0; 9];
        for (slot, x) in all.iter_mut().zip(values) {
            *slot = x;
        }
        Coordinates {
            values: all,
            len: N,
        }
    }

    fn as_slice(&self) -> &[f64] {
        &self.values[..self.len]
    }
}

/// `{"links": {"NAME": {..}, ..}, ..}` for one configuration's `results`, then `"points"`,
/// `"jacobians"` and `"jacobian_dots"` where there are any: serialised straight into the
/// output, since a `Value` tree allocates a node per number (which took most of a batch run's
/// time).
struct ResultsJson<'a> {
    /// The batch line the results are for (none for `--q`).
    line: Option<usize>,
    chain: &'a Chain,
    results: &'a [LinkResult],
    orientation: Orientation,
    points: &'a [Point],
    point_results: &'a [PointResult],
    jacobians: &'a [JacobianResult],
}

impl Serialize for ResultsJson<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        /// The links, keyed by name.
        struct Links<'b>(&'b ResultsJson<'b>);
        impl Serialize for Links<'_> {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                let r = self.0;
                let mut m = s.serialize_map(Some(r.results.len()))?;
                for result in r.results {
                    let link = LinkJson {
                        result,
                        orientation: r.orientation,
                    };
                    m.serialize_entry(r.chain.link(result.0).name(), &link)?;
                }
                m.end()
            }
        }
        let mut m = s.serialize_map(None)?;
        if let Some(line) = self.line {
            m.serialize_entry("line", &line)?;
        }
        m.serialize_entry("links", &Links(self))?;
        if !self.points.is_empty() {
            let points = self.points.iter().zip(self.point_results);
            let list = points.map(|(p, r)| PointJson {
                link: self.chain.link(p.link).name(),
                u: xyz(&p.u),
                position: xyz(&r.position),
                velocity: r.velocity.as_ref().map(xyz),
                acceleration: r.acceleration.as_ref().map(|(a, _)| xyz(a)),
                acceleration_parts: r.acceleration.as_ref().map(|(_, parts)| PartsJson {
                    origin: xyz(&parts.origin),
                    tangential: xyz(&parts.tangential),
                    normal: xyz(&parts.normal),
                }),
            });
            m.serialize_entry("points", &Listed(list))?;
        }
        if !self.jacobians.is_empty() {
            let jacobians = |rate| JacobiansJson {
                chain: self.chain,
                jacobians: self.jacobians,
                rate,
            };
            m.serialize_entry("jacobians", &jacobians(false))?;
            if self.jacobians.iter().any(|r| r.with_rate) {
                m.serialize_entry("jacobian_dots", &jacobians(true))?;
            }
        }
        m.end()
    }
}

/// One `--point`: `{"link", "u", "position"}`, then with rates `"velocity"`, and with
/// accelerations `"acceleration"` and `"acceleration_parts"`.
#[derive(Serialize)]
struct PointJson<'a> {
    link: &'a str,
    u: [f64; 3],
    position: [f64; 3],
    #[serde(skip_serializing_if = "Option::is_none")]
    velocity: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    acceleration: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    acceleration_parts: Option<PartsJson>,
}

/// The parts of a point's acceleration (eq. 2.75) that do not vanish for a point fixed on its
/// link.
#[derive(Serialize)]
struct PartsJson {
    origin: [f64; 3],
    tangential: [f64; 3],
    normal: [f64; 3],
}

/// `{"LINK": [[row], … six rows], …}` per `--jacobian` link, rows `v_x, v_y, v_z, ω_x, ω_y,
/// ω_z`, columns in `q` order: `J`, or `J̇` when `rate`.
struct JacobiansJson<'a> {
    chain: &'a Chain,
    jacobians: &'a [JacobianResult],
    rate: bool,
}

impl Serialize for JacobiansJson<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(self.jacobians.len()))?;
        for r in self.jacobians {
            let matrix = if self.rate { &r.j_dot } else { &r.j };
            // Column-major storage: row `i` is every sixth entry from the `i`-th.
            let entries = matrix.as_slice();
            let rows = (0..6).map(|i| Listed(entries.iter().skip(i).step_by(6)));
            m.serialize_entry(self.chain.link(r.link).name(), &Listed(rows))?;
        }
        m.end()
    }
}

/// The items of an iterator, serialised as a JSON array without collecting them.
struct Listed<I>(I);

impl<I> Serialize for Listed<I>
where
    I: Iterator + Clone,
    I::Item: Serialize,
{
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0.clone())
    }
}

/// One link's members: `"pose"`, or `"position"` and the orientation coordinates (`null` where
/// the representation is undefined, at a singularity); then the rates there are.
struct LinkJson<'a> {
    result: &'a LinkResult,
    orientation: Orientation,
}

impl Serialize for LinkJson<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let (_, pose, vel, acc) = self.result;
        let mut m = s.serialize_map(None)?;
        let kind = self.orientation;
        if kind == Orientation::Matrix {
            m.serialize_entry("pose", &pose.to_rows())?;
        } else {
            m.serialize_entry("position", &xyz(&pose.translation()))?;
            let key = orientation_labels(kind).0;
            let values = orientation_values(&pose.rotation(), kind);
            match (kind, values.as_ref().map(Coordinates::as_slice)) {
                (_, None) => m.serialize_entry(key, &())?,
                (Orientation::Quat, Some(&[w, x, y, z])) => {
                    m.serialize_entry(key, &Named([("w", w), ("x", x), ("y", y), ("z", z)]))?;
                }
                (Orientation::Rpy, Some(&[roll, pitch, yaw])) => {
                    let angles = [("roll", roll), ("pitch", pitch), ("yaw", yaw)];
                    m.serialize_entry(key, &Named(angles))?;
                }
                (Orientation::Zxz, Some(&[phi, theta, psi])) => {
                    let angles = [("phi", phi), ("theta", theta), ("psi", psi)];
                    m.serialize_entry(key, &Named(angles))?;
                }
                (Orientation::AxisAngle, Some(&[x, y, z, angle])) => {
                    m.serialize_entry(
                        key,
                        &AxisAngleJson {
                            axis: [x, y, z],
                            angle,
                        },
                    )?;
                }
                // Rodriguez parameters, an array.
                (_, Some(v)) => m.serialize_entry(key, v)?,
            }
        }
        if let Some(v) = vel {
            m.serialize_entry("omega", &xyz(&v.omega))?;
            m.serialize_entry("v", &xyz(&v.v))?;
        }
        if let Some(a) = acc {
            m.serialize_entry("alpha", &xyz(&a.alpha))?;
            m.serialize_entry("a", &xyz(&a.a))?;
        }
        m.end()
    }
}

/// `{"axis": [x, y, z], "angle": θ}`.
#[derive(Serialize)]
struct AxisAngleJson {
    axis: [f64; 3],
    angle: f64,
}

/// An object of numbers with the given member names, in their order.
struct Named<const N: usize>([(&'static str, f64); N]);

impl<const N: usize> Serialize for Named<N> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(N))?;
        for (key, value) in &self.0 {
            m.serialize_entry(key, value)?;
        }
        m.end()
    }
}

/// The entries of `v`, for serialising as `[x, y, z]`.
fn xyz(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// The name of an `--orientation`'s coordinates (the JSON member; for the matrix, the table's
/// column) and what they are, in order (the table's column header).
fn orientation_labels(kind: Orientation) -> (&'static str, &'static str) {
    match kind {
        Orientation::Matrix => ("rotation", "rows"),
        Orientation::Quat => ("quaternion", "w x y z"),
        Orientation::Rpy => ("rpy", "roll pitch yaw"),
        Orientation::Zxz => ("euler_zxz", "phi theta psi"),
        Orientation::AxisAngle => ("axis_angle", "x y z; angle"),
        Orientation::Rodrigues => ("rodrigues", "γ1 γ2 γ3"),
    }
}

/// Writes `value` as one line of JSON, serialised into `buf` (reused from line to line) and
/// written with one call.
fn write_json_line(
    out: &mut dyn Write,
    buf: &mut Vec<u8>,
    value: &impl Serialize,
) -> Result<(), CliError> {
    // (Serialising into memory fails only for a map key that is not a string, which the
    // values written here do not have.)
    write_buffered_line(out, buf, |buf| {
        serde_json::to_writer(buf, value).map_err(|e| output_error(e.into()))
    })
}

/// Writes the text `fill` appends to `buf` (emptied first, and reused from line to line) and a
/// newline, with one call.
fn write_buffered_line(
    out: &mut dyn Write,
    buf: &mut Vec<u8>,
    fill: impl FnOnce(&mut Vec<u8>) -> Result<(), CliError>,
) -> Result<(), CliError> {
    buf.clear();
    fill(buf)?;
    buf.push(b'\n');
    out.write_all(buf).map_err(output_error)
}

/// The error for the first result that is not finite (a value too large for `f64`, which JSON
/// cannot print): every pose, rate and point result of one configuration.
fn check_finite(
    chain: &Chain,
    results: &[LinkResult],
    points: &[Point],
    point_results: &[PointResult],
) -> Result<(), CliError> {
    let finite = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
    for (l, pose, vel, acc) in results {
        let parts = [
            (
                "pose",
                pose.to_rows().iter().flatten().all(|x| x.is_finite()),
            ),
            ("omega", vel.is_none_or(|v| finite(&v.omega))),
            ("v", vel.is_none_or(|v| finite(&v.v))),
            ("alpha", acc.is_none_or(|a| finite(&a.alpha))),
            ("a", acc.is_none_or(|a| finite(&a.a))),
        ];
        if let Some(&(what, _)) = parts.iter().find(|(_, ok)| !ok) {
            return Err(CliError::NotFinite {
                what,
                place: format!("link '{}'", chain.link(*l).name()),
            });
        }
    }
    for (p, r) in points.iter().zip(point_results) {
        let acceleration = r.acceleration.as_ref();
        let parts = [
            ("position", finite(&r.position)),
            ("velocity", r.velocity.as_ref().is_none_or(finite)),
            (
                "acceleration",
                acceleration.is_none_or(|(a, parts)| {
                    finite(a)
                        && [
                            parts.origin,
                            parts.tangential,
                            parts.normal,
                            parts.coriolis,
                            parts.local,
                        ]
                        .iter()
                        .all(finite)
                }),
            ),
        ];
        if let Some(&(what, _)) = parts.iter().find(|(_, ok)| !ok) {
            return Err(CliError::NotFinite {
                what,
                place: p.label(chain).to_string(),
            });
        }
    }
    Ok(())
}

/// Appends `x` as a number for a table, right-aligned in `width` columns (0: as wide as it is):
/// six decimals, or six significant digits after the first in exponent form from 10⁹ on (where
/// six decimals would print hundreds of digits for a large value). A value that shows as zero
/// has no sign: the `-` of `-0.000000` would come from a rounding residue such as −6·10⁻¹⁷ or
/// from −0, not from the robot.
fn push_fixed(buf: &mut Vec<u8>, x: f64, width: usize) {
    let start = buf.len();
    if x.abs() >= 1e9 {
        let _ = write!(buf, "{x:>width$.6e}");
        return;
    }
    let _ = write!(buf, "{x:>width$.6}");
    let cell = &buf[start..];
    let Some(sign) = cell.iter().position(|&b| b != b' ') else {
        return;
    };
    let zero = |rest: &[u8]| rest.iter().all(|&b| b == b'0' || b == b'.');
    if cell[sign] == b'-' && zero(&cell[sign + 1..]) {
        if sign > 0 {
            // The sign's column becomes padding.
            buf[start + sign] = b' ';
        } else {
            buf.remove(start);
            if buf.len() - start < width {
                buf.insert(start, b' ');
            }
        }
    }
}

/// Appends the numbers of `cells` ([`push_fixed`], each `width` wide) with `separator` between
/// them.
fn push_cells(
    buf: &mut Vec<u8>,
    cells: impl IntoIterator<Item = f64>,
    separator: &[u8],
    width: usize,
) {
    for (i, x) in cells.into_iter().enumerate() {
        if i > 0 {
            buf.extend_from_slice(separator);
        }
        push_fixed(buf, x, width);
    }
}

/// `fk --format table`: appends one row per link, its position and its orientation in the
/// coordinates `--orientation` names (`undefined` at a singularity of the representation), then
/// its rates; no newline after the last row.
fn results_table(
    chain: &Chain,
    results: &[LinkResult],
    orientation: Orientation,
    buf: &mut Vec<u8>,
) {
    let width = results
        .iter()
        .map(|(l, ..)| chain.link(*l).name().chars().count())
        .max()
        .unwrap_or(4)
        .max(4);
    let (name, coordinates) = orientation_labels(orientation);
    let _ = write!(
        buf,
        "{:<width$} {:>12} {:>12} {:>12}   {name} ({coordinates})",
        "link", "x", "y", "z"
    );
    // A matrix's rows, and the axis before its angle, are separated by `;`.
    let group = match orientation {
        Orientation::Matrix | Orientation::AxisAngle => 3,
        _ => 4,
    };
    let row = |buf: &mut Vec<u8>, label: &str, v: &Vector3<f64>| {
        let _ = write!(buf, "\n{label:>width$} ");
        push_cells(buf, [v.x, v.y, v.z], b" ", 12);
    };
    for (l, pose, vel, acc) in results {
        let p = pose.translation();
        let _ = write!(buf, "\n{:<width$} ", chain.link(*l).name());
        push_cells(buf, [p.x, p.y, p.z], b" ", 12);
        buf.extend_from_slice(b"   ");
        match orientation_values(&pose.rotation(), orientation) {
            None => buf.extend_from_slice(b"undefined"),
            Some(values) => {
                buf.push(b'[');
                for (i, chunk) in values.as_slice().chunks(group).enumerate() {
                    if i > 0 {
                        buf.extend_from_slice(b"; ");
                    }
                    push_cells(buf, chunk.iter().copied(), b" ", 0);
                }
                buf.push(b']');
            }
        }
        if let Some(v) = vel {
            row(buf, "omega", &v.omega);
            row(buf, "v", &v.v);
        }
        if let Some(a) = acc {
            row(buf, "alpha", &a.alpha);
            row(buf, "a", &a.a);
        }
    }
}

fn fk(args: &FkArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let chain = load(&args.robot)?;
    let mut data = Data::new(&chain);
    if args.ignore_limits {
        data.set_limit_policy(LimitPolicy::Ignore);
    }
    let mut request = Request::new(&chain, args)?;
    if let Some(path) = &args.batch {
        return fk_batch_file(&chain, args, &mut data, &mut request, path, out);
    }
    let q = args.q.as_deref().unwrap_or_default();
    let c = Configuration {
        q: joint_vector_from_str(&chain, q, "q")?,
        qd: args
            .qd
            .as_deref()
            .map(|t| joint_vector_from_str(&chain, t, "qd"))
            .transpose()?,
        qdd: args
            .qdd
            .as_deref()
            .map(|t| joint_vector_from_str(&chain, t, "qdd"))
            .transpose()?,
    };
    request.emit(&chain, args, &mut data, &c, None, out)
}

/// What `fk` prints for each configuration (`--link`, `--point`, `--jacobian`), with the
/// buffers of the results.
struct Request {
    links: Vec<LinkId>,
    points: Vec<Point>,
    outputs: Outputs,
    /// One line of output (JSON or a table), reused.
    text: Vec<u8>,
}

impl Request {
    fn new(chain: &Chain, args: &FkArgs) -> Result<Request, CliError> {
        // A link named twice in `--link` or `--jacobian` is printed once (a JSON object cannot
        // hold its name twice), where it was first named.
        let unique = |names: &[String]| -> Result<Vec<LinkId>, CliError> {
            let mut ids = Vec::with_capacity(names.len());
            for name in names {
                let id = chain.link_id(name)?;
                if !ids.contains(&id) {
                    ids.push(id);
                }
            }
            Ok(ids)
        };
        let links = unique(&args.links)?;
        let points = args
            .points
            .iter()
            .map(|p| parse_point(chain, p))
            .collect::<Result<Vec<_>, _>>()?;
        let outputs = Outputs {
            links: Vec::with_capacity(chain.links().len()),
            points: Vec::with_capacity(points.len()),
            jacobians: unique(&args.jacobians)?
                .into_iter()
                .map(|link| JacobianResult {
                    link,
                    j: nalgebra::Matrix6xX::zeros(chain.dof()),
                    j_dot: nalgebra::Matrix6xX::zeros(chain.dof()),
                    with_rate: false,
                })
                .collect(),
        };
        Ok(Request {
            links,
            points,
            outputs,
            text: Vec::new(),
        })
    }

    /// Whether the request is every link's pose and nothing else, which the batch kernel can
    /// evaluate (a chain without moving joints has empty configurations, which a flat batch
    /// cannot count).
    fn poses_only(&self, chain: &Chain) -> bool {
        self.links.is_empty()
            && self.points.is_empty()
            && self.outputs.jacobians.is_empty()
            && chain.dof() > 0
    }

    /// Evaluates `c` and writes its results in the format `args` asks for, headed by the batch
    /// line `line` they are for, if any.
    fn emit(
        &mut self,
        chain: &Chain,
        args: &FkArgs,
        data: &mut Data,
        c: &Configuration,
        line: Option<usize>,
        out: &mut dyn Write,
    ) -> Result<(), CliError> {
        evaluate(chain, data, c, &self.links, &self.points, &mut self.outputs)?;
        let Outputs {
            links: results,
            points: point_results,
            jacobians,
        } = &self.outputs;
        let points = &self.points;
        check_finite(chain, results, points, point_results)?;
        match args.format {
            OutputFormat::Json => {
                let value = ResultsJson {
                    line,
                    chain,
                    results,
                    orientation: args.orientation,
                    points,
                    point_results,
                    jacobians,
                };
                write_json_line(out, &mut self.text, &value)
            }
            OutputFormat::Table => write_buffered_line(out, &mut self.text, |buf| {
                line_heading(line, buf);
                results_table(chain, results, args.orientation, buf);
                points_table(chain, points, point_results, buf);
                jacobians_table(chain, jacobians, buf);
                Ok(())
            }),
        }
    }
}

/// The heading of a batch line's table, `line N:` on a line of its own.
fn line_heading(line: Option<usize>, buf: &mut Vec<u8>) {
    if let Some(line) = line {
        buf.extend_from_slice(format!("line {line}:\n").as_bytes());
    }
}

/// The error of line `line` of the batch file `path`.
fn at_line(path: &Path, line: usize, source: CliError) -> CliError {
    CliError::BatchLine {
        path: path.to_path_buf(),
        line,
        source: Box::new(source),
    }
}

/// Pose-only lines of a batch file, evaluated together by the batch kernel.
struct PendingPoses {
    /// Their configurations, row-major.
    qs: Vec<f64>,
    /// The 1-based line number of each.
    lines: Vec<usize>,
    batch: BatchData,
    /// One line of output (JSON or a table), reused.
    text: Vec<u8>,
}

impl PendingPoses {
    /// Lines held before they are evaluated.
    const MAX: usize = 256;

    /// Writes the pending configurations' results and forgets them; returns how many failed
    /// (written as error lines under `--keep-going`; without it, the first failure is the
    /// error).
    fn flush(
        &mut self,
        chain: &Chain,
        args: &FkArgs,
        path: &Path,
        out: &mut dyn Write,
    ) -> Result<usize, CliError> {
        if self.qs.is_empty() {
            return Ok(0);
        }
        let lines = &self.lines;
        let poses = forward_kinematics_batch(chain, &mut self.batch, &self.qs).map_err(|e| {
            // (Each line was checked as it was read, so this is not expected.)
            let line = lines.get(e.index).or(lines.last()).copied().unwrap_or(0);
            at_line(path, line, CliError::State(e.source))
        })?;
        let mut failed = 0;
        // One buffer for every line's link results.
        let mut results: Vec<LinkResult> = Vec::with_capacity(chain.links().len());
        for (i, &line) in lines.iter().enumerate() {
            results.clear();
            results.extend(
                (0..chain.links().len())
                    .map(|l| (LinkId(l), poses.world_from_link(i, LinkId(l)), None, None)),
            );
            match check_finite(chain, &results, &[], &[]) {
                Ok(()) => match args.format {
                    OutputFormat::Json => {
                        let value = ResultsJson {
                            line: Some(line),
                            chain,
                            results: &results,
                            orientation: args.orientation,
                            points: &[],
                            point_results: &[],
                            jacobians: &[],
                        };
                        write_json_line(out, &mut self.text, &value)?;
                    }
                    OutputFormat::Table => write_buffered_line(out, &mut self.text, |buf| {
                        line_heading(Some(line), buf);
                        results_table(chain, &results, args.orientation, buf);
                        Ok(())
                    })?,
                },
                Err(e) if args.keep_going => {
                    failed += 1;
                    write_line(out, &failed_line(args.format, line, &e))?;
                }
                Err(e) => return Err(at_line(path, line, e)),
            }
        }
        self.qs.clear();
        self.lines.clear();
        Ok(failed)
    }
}

/// How errors name standard input, the batch file `-`.
const STANDARD_INPUT: &str = "standard input";

/// `fk --batch`: the lines of the file at `path`, or of standard input for `-`, through
/// [`fk_batch`].
fn fk_batch_file(
    chain: &Chain,
    args: &FkArgs,
    data: &mut Data,
    request: &mut Request,
    path: &Path,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    // Blocks of 64 KiB hold an arm's 256 lines of poses (about 100 bytes each) a few times
    // over: the results go out when the lines held fill a batch, not at every block's end.
    const BLOCK: usize = 1 << 16;
    if path == Path::new("-") {
        let mut reader = std::io::BufReader::with_capacity(BLOCK, std::io::stdin());
        let name = Path::new(STANDARD_INPUT);
        return fk_batch(chain, args, data, request, name, &mut reader, out);
    }
    let file = std::fs::File::open(path).map_err(|source| CliError::Io {
        context: format!("cannot open batch file {}", path.display()),
        source,
    })?;
    let mut reader = std::io::BufReader::with_capacity(BLOCK, file);
    fk_batch(chain, args, data, request, path, &mut reader, out)
}

/// What [`fk_batch`] makes of a line that reads without error.
enum Row {
    /// Nothing to write now: a blank line, a header row, or a configuration held for the batch
    /// kernel.
    Held,
    /// A configuration evaluated on its own (rates, or a request the batch kernel does not serve).
    Single(Configuration),
    /// A header row of names that cannot be read: the end of the run.
    BadHeader(CliError),
}

/// One result per line of `reader` (`path` names it in errors), in line order. Pose-only lines
/// (the common case) go through the batch kernel, [`PendingPoses::MAX`] at a time; lines with
/// rates, or a request with `--link`, `--point` or `--jacobian`, go one by one. Everything before
/// a bad line is written before its error. Whenever the input read is used up, the results held
/// are written and the output flushed: reading more may wait for a program that writes a line
/// at a time and waits for its result.
fn fk_batch<R: std::io::Read>(
    chain: &Chain,
    args: &FkArgs,
    data: &mut Data,
    request: &mut Request,
    path: &Path,
    reader: &mut std::io::BufReader<R>,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let batchable = request.poses_only(chain);
    let mut pending = PendingPoses {
        qs: Vec::new(),
        lines: Vec::new(),
        batch: BatchData::new(chain).with_limit_policy(data.limit_policy()),
        text: Vec::new(),
    };
    let mut failed_lines = 0usize;
    let limit = batch_line_limit(chain.dof());
    let mut bytes = Vec::new();
    // The first line that is not blank may be a header row of joint names (`csv_header`).
    let mut first = true;
    let mut header = None;
    for i in 0.. {
        if reader.buffer().is_empty() {
            failed_lines += pending.flush(chain, args, path, out)?;
            out.flush().map_err(output_error)?;
        }
        // Without --keep-going a line past the cap ends the run, so nothing of it is skipped;
        // with it, a line is skipped up to 64 times the cap before reading gives up.
        let skip = if args.keep_going {
            limit.saturating_mul(64)
        } else {
            0
        };
        let result = match read_capped_line(reader, &mut bytes, limit, skip) {
            Ok(CappedLine::End) => break,
            Ok(CappedLine::Unended) if args.keep_going => {
                pending.flush(chain, args, path, out)?;
                return Err(at_line(
                    path,
                    i + 1,
                    CliError::Unended {
                        limit: limit.saturating_add(skip),
                    },
                ));
            }
            Ok(CappedLine::Unended) => Err(CliError::LineTooLong { limit }),
            Ok(CappedLine::Line) => std::str::from_utf8(&bytes).map_err(|e| CliError::NotUtf8 {
                byte: e.valid_up_to() + 1,
            }),
            Ok(CappedLine::TooLong) => Err(CliError::LineTooLong { limit }),
            Err(source) => Err(CliError::Io {
                context: "cannot read line".into(),
                source,
            }),
        };
        let result = result.and_then(|line| {
            // A byte order mark, which spreadsheet programs put at the start of the CSV files
            // they write, is not part of the first line.
            let line = match i {
                0 => line.strip_prefix('\u{feff}').unwrap_or(line),
                _ => line,
            };
            if line.trim().is_empty() {
                return Ok(Row::Held);
            }
            if std::mem::take(&mut first)
                && let Some(order) = crate::io::input::csv_header(chain, line)
            {
                return Ok(match order {
                    Ok(order) => {
                        header = Some(order);
                        Row::Held
                    }
                    Err(e) => Row::BadHeader(e.into()),
                });
            }
            let c = batch_configuration(chain, line, header.as_ref())?;
            if batchable && c.qd.is_none() && c.qdd.is_none() {
                check_q(chain, &c.q, data.limit_policy())?;
                pending.qs.extend_from_slice(&c.q);
                pending.lines.push(i + 1);
                return Ok(Row::Held);
            }
            Ok(Row::Single(c))
        });
        match result {
            Ok(Row::Held) => {
                if pending.lines.len() >= PendingPoses::MAX {
                    failed_lines += pending.flush(chain, args, path, out)?;
                }
            }
            // A header that cannot be read stops the run even under `--keep-going`: the rows
            // below it would be read in another order than the file's. (Nothing is pending: a
            // header is the first line that is not blank.)
            Ok(Row::BadHeader(e)) => return Err(at_line(path, i + 1, e)),
            Ok(Row::Single(c)) => {
                failed_lines += pending.flush(chain, args, path, out)?;
                match request.emit(chain, args, data, &c, Some(i + 1), out) {
                    Ok(()) => {}
                    Err(e @ CliError::Io { .. }) => return Err(e),
                    Err(e) if args.keep_going => {
                        failed_lines += 1;
                        write_line(out, &failed_line(args.format, i + 1, &e))?;
                    }
                    Err(e) => return Err(at_line(path, i + 1, e)),
                }
            }
            Err(e) => {
                failed_lines += pending.flush(chain, args, path, out)?;
                if !args.keep_going {
                    return Err(at_line(path, i + 1, e));
                }
                failed_lines += 1;
                write_line(out, &failed_line(args.format, i + 1, &e))?;
            }
        }
    }
    failed_lines += pending.flush(chain, args, path, out)?;
    if failed_lines > 0 {
        return Err(CliError::BatchFailures {
            path: path.to_path_buf(),
            count: failed_lines,
        });
    }
    Ok(())
}

/// The longest batch line read, in bytes: 1 MiB, plus 1 KiB per degree of freedom (a line names
/// at most three numbers per joint, or three members named after it).
fn batch_line_limit(dof: usize) -> usize {
    (1 << 20) + dof.saturating_mul(1 << 10)
}

/// What [`read_capped_line`] read.
#[derive(Debug)]
enum CappedLine {
    /// A line (without its end) is in the buffer.
    Line,
    /// The line was longer than the cap; the rest of it was skipped.
    TooLong,
    /// The line was longer than the cap, and more than the bytes allowed to skip followed
    /// without a line end (`/dev/zero`, a stream that never sends one): reading stopped.
    Unended,
    /// The input is exhausted.
    End,
}

/// Reads one line of at most `limit` bytes into `buf` (cleared first; `\n` and a `\r` before it
/// dropped). A longer line is skipped to its end without being kept, so one huge line costs no
/// more memory than the cap, unless more than `skip` bytes past the cap come without a line end.
fn read_capped_line(
    reader: &mut impl BufRead,
    buf: &mut Vec<u8>,
    limit: usize,
    skip: usize,
) -> std::io::Result<CappedLine> {
    buf.clear();
    let mut too_long = false;
    let mut skipped = 0usize;
    let mut any = false;
    loop {
        let available = match reader.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if available.is_empty() {
            break;
        }
        any = true;
        let (chunk, done) = match available.iter().position(|&b| b == b'\n') {
            Some(end) => (&available[..end], Some(end + 1)),
            None => (available, None),
        };
        if !too_long {
            if buf.len() + chunk.len() > limit {
                too_long = true;
                buf.clear();
            } else {
                buf.extend_from_slice(chunk);
            }
        }
        if too_long {
            skipped = skipped.saturating_add(chunk.len());
            if done.is_none() && skipped > skip {
                return Ok(CappedLine::Unended);
            }
        }
        let used = done.unwrap_or(chunk.len());
        reader.consume(used);
        if done.is_some() {
            break;
        }
    }
    if too_long {
        return Ok(CappedLine::TooLong);
    }
    if !any {
        return Ok(CappedLine::End);
    }
    if buf.last() == Some(&b'\r') {
        buf.pop();
    }
    Ok(CappedLine::Line)
}

/// The output line standing in for a failed batch line under `--keep-going`: an object
/// `{"line": N, "error": ".."}` in JSON output, `line N: error: ..` in a table.
fn failed_line(format: OutputFormat, line: usize, e: &CliError) -> String {
    match format {
        OutputFormat::Json => json!({ "line": line, "error": error_chain(e) }).to_string(),
        OutputFormat::Table => format!("line {line}: error: {}", error_chain(e)),
    }
}

/// One batch line through [`crate::io::input::parse_batch_row`] (rows of numbers in the order of
/// `header`).
fn batch_configuration(
    chain: &Chain,
    line: &str,
    header: Option<&crate::io::input::CsvHeader>,
) -> Result<Configuration, CliError> {
    let l = crate::io::input::parse_batch_row(chain, line, header)?;
    Ok(Configuration {
        q: l.q,
        qd: l.q_dot,
        qdd: l.q_ddot,
    })
}

/// The most configurations `bench` takes.
const MAX_BENCH_CONFIGURATIONS: usize = 1 << 16;

/// Joint evaluations of the batch that `bench`'s two-thread rows time (≈70 µs of one thread's
/// work, some 5 000 configurations of a seven-joint arm): well above
/// [`crate::eval::batch::PARALLEL_WORK`], yet small enough for its frames to stay in the last-level
/// cache.
const THREADED_ROWS_WORK: usize = 40_000;

/// `--configurations`: a whole number from 2 to [`MAX_BENCH_CONFIGURATIONS`].
/// The most link frames (configurations times links) `bench` keeps: 2²³, 768 MiB of frames, so
/// that a robot with many links cannot make the batch rows exhaust memory.
const MAX_BENCH_FRAMES: usize = 1 << 23;

fn configuration_count(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if n < 2 => {
            Err("at least 2 are needed (the incremental row moves between them)".into())
        }
        Ok(n) if n > MAX_BENCH_CONFIGURATIONS => Err(format!(
            "at most {MAX_BENCH_CONFIGURATIONS} (each is checked against a 256-bit evaluation, and the batch rows keep every link's frame)"
        )),
        Ok(n) => Ok(n),
        Err(e) => Err(e.to_string()),
    }
}

/// One timed method of `kinechain bench`: its label, one call, and how many configurations a
/// call evaluates.
type Method<'a> = (String, Box<dyn FnMut() + 'a>, usize);

/// The instruction set of the kernels, and for AVX-512 how single evaluations of at most eight
/// angles compute their `sin`/`cos` ([`crate::eval::arith::narrow_trig`]).
fn kernels_name() -> String {
    match crate::eval::arith::isa() {
        crate::eval::arith::Isa::Avx512 if crate::eval::arith::narrow_trig() => {
            "avx512 (single evaluations of up to 8 angles: sin/cos on 256 bits)".to_string()
        }
        isa => isa.name().to_string(),
    }
}

fn bench(
    path: &PathBuf,
    level: Level,
    n: usize,
    link: Option<&str>,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let chain = &load(path)?;
    if chain.dof() == 0 {
        return Err(CliError::NothingToTime);
    }
    let links = chain.links().len();
    if n.saturating_mul(links) > MAX_BENCH_FRAMES {
        return Err(CliError::BenchTooLarge {
            configurations: n,
            links,
            most: (MAX_BENCH_FRAMES / links).max(1),
        });
    }
    let qs = &crate::measure::configurations(chain, n, 0x6b69_6e65);
    let qd: &Vec<Vec<f64>> = &qs
        .iter()
        .map(|q| q.iter().map(|x| 0.5 * x.sin()).collect())
        .collect();
    let end = match link {
        Some(name) => chain.link_id(name)?,
        None => chain.end_link(),
    };
    let flat: &Vec<f64> = &qs.concat();
    // The multi-threaded rows evaluate the configurations `copies` times over in one batch of
    // THREADED_ROWS_WORK joint evaluations on the end link's path.
    let mut end_path = Vec::new();
    chain.body_path(chain.carrier(end).body, &mut end_path);
    let copies = THREADED_ROWS_WORK
        .div_ceil(qs.len().max(1) * end_path.len().max(1))
        .max(1);
    let big: &Vec<f64> = &(0..copies).flat_map(|_| flat.iter().copied()).collect();
    let work = Workload {
        chain,
        qs,
        qd,
        flat,
        big,
        copies,
        end,
    };
    let pose_errors = work.pose_errors()?;

    let mut methods = match level {
        Level::Pose => work.pose_methods(path),
        Level::Vel | Level::Acc => work.rate_methods(level == Level::Acc),
    };
    let items: Vec<usize> = methods.iter().map(|m| m.2).collect();
    let mut calls: Vec<&mut dyn FnMut()> = methods.iter_mut().map(|m| &mut *m.1 as _).collect();
    let timings =
        crate::measure::Interleaved::run(std::time::Duration::from_millis(20), 7, &mut calls)
            .per_item(&items);
    let labels: Vec<&str> = methods.iter().map(|m| m.0.as_str()).collect();
    let mut text = timing_table(chain, qs.len(), &labels, &timings);
    text.push_str(&error_lines(&work, level, pose_errors)?);
    write_line(out, &text)
}

/// What `kinechain bench` evaluates: `qs` (with rates `qd`), row-major in `flat`, and `flat`
/// repeated `copies` times in `big` for the multi-threaded rows; `end` the link read after each
/// single evaluation and kept by the one-link batches.
#[derive(Clone, Copy)]
struct Workload<'a> {
    chain: &'a Chain,
    qs: &'a [Vec<f64>],
    qd: &'a [Vec<f64>],
    flat: &'a [f64],
    big: &'a [f64],
    copies: usize,
    end: LinkId,
}

impl<'a> Workload<'a> {
    /// Buffers of one method (each has its own, so that the methods can be timed in
    /// alternation), not checking limits, as `k` is timed.
    fn data(&self) -> Data {
        Data::new(self.chain).with_limit_policy(LimitPolicy::Ignore)
    }

    fn batch_data(&self) -> crate::eval::batch::BatchData {
        crate::eval::batch::BatchData::new(self.chain).with_limit_policy(LimitPolicy::Ignore)
    }

    fn single_data(&self) -> crate::eval::batch::single_precision::BatchData {
        crate::eval::batch::single_precision::BatchData::new(self.chain)
            .with_limit_policy(LimitPolicy::Ignore)
    }

    /// The largest (position, rotation) errors of the single evaluation and of the
    /// single-precision batch, against the 256-bit evaluation of the same model.
    fn pose_errors(&self) -> Result<[(f64, f64); 2], CliError> {
        let chain = self.chain;
        let all: Vec<LinkId> = (0..chain.links().len()).map(LinkId).collect();
        let mut errors = [(0.0_f64, 0.0_f64); 2];
        let mut d = self.data();
        let mut b32 = self.single_data();
        let rough = crate::eval::batch::single_precision::forward_kinematics_batch(
            chain, &mut b32, self.flat,
        )
        .map_err(|e| e.source)?;
        for (i, q) in self.qs.iter().enumerate() {
            let exact = crate::reference::link_poses(chain, q);
            let poses = forward_kinematics(chain, &mut d, q)?;
            let ours: Vec<Transform> = all.iter().map(|&l| poses.world_from_link(l)).collect();
            let single: Vec<Transform> = all.iter().map(|&l| rough.world_from_link(i, l)).collect();
            for (e, got) in errors.iter_mut().zip([ours, single]) {
                let (p, r) = crate::reference::max_errors(&got, &exact);
                *e = (worse(e.0, p), worse(e.1, r));
            }
        }
        Ok(errors)
    }

    /// Every link's pose of each configuration, on the kernels of `isa` (`None`: the machine's),
    /// with `wide` the `sin`/`cos` forced into one 512-bit register where `narrow_trig` would
    /// split them; the end link read after each.
    fn all_links(&self, isa: Option<crate::eval::arith::Isa>, wide: bool) -> Box<dyn FnMut() + 'a> {
        let Workload { chain, qs, end, .. } = *self;
        let mut d = self.data();
        Box::new(move || {
            crate::eval::arith::force_isa(isa);
            if wide {
                crate::eval::arith::force_narrow_trig(Some(false));
            }
            for q in qs {
                black_box(
                    forward_kinematics(chain, &mut d, black_box(q))
                        .ok()
                        .map(|p| p.world_from_link(end)),
                );
            }
            crate::eval::arith::force_isa(None);
            if wide {
                crate::eval::arith::force_narrow_trig(None);
            }
        })
    }

    /// The rows of `--level pose`: every evaluation mode, the baseline path, and `k` when it
    /// loads the robot at `path`.
    fn pose_methods(&self, path: &std::path::Path) -> Vec<Method<'a>> {
        let Workload { chain, qs, end, .. } = *self;
        let n = qs.len();
        let mut methods: Vec<Method<'a>> = vec![(ALL_LINKS.into(), self.all_links(None, false), n)];
        let mut d = self.data();
        methods.push((
            format!("kinechain, end link {} only", chain.link(end).name()),
            Box::new(move || {
                for q in qs {
                    black_box(forward_kinematics_to(chain, &mut d, black_box(q), end).ok());
                }
            }),
            n,
        ));
        methods.extend(self.incremental_method());
        methods.extend(self.batch_methods());
        // Where the choice of `narrow_trig` applies (all the angles in one chunk, the test
        // `kernel::all_sin_cos` makes), what it saves.
        if crate::eval::arith::isa() == crate::eval::arith::Isa::Avx512
            && crate::eval::arith::narrow_trig()
            && chain.theta_gather.len() == 1
        {
            methods.push((
                "kinechain, all links, sin/cos in one 512-bit register".into(),
                self.all_links(None, true),
                n,
            ));
        }
        methods.push((
            "kinechain, baseline x86-64 path".into(),
            self.all_links(Some(crate::eval::arith::Isa::Baseline), false),
            n,
        ));
        if let Some((label, k)) = k_method(path, chain, qs) {
            methods.push((label, k, n));
        }
        methods
    }

    /// The batch rows of `--level pose`: all links on one thread in `f64` and `f32`, all links
    /// of the repeated batch on the pool, and the end link alone on one thread and on the pool.
    fn batch_methods(&self) -> Vec<Method<'a>> {
        use crate::eval::batch::{
            forward_kinematics_batch, forward_kinematics_batch_par, forward_kinematics_batch_to,
            single_precision,
        };
        let Workload {
            chain,
            qs,
            flat,
            big,
            copies,
            end,
            ..
        } = *self;
        let n = qs.len();
        let threads = rayon::current_num_threads();
        let mut methods: Vec<Method<'a>> = Vec::new();
        let mut b = self.batch_data();
        methods.push((
            "kinechain, batch, 1 thread".into(),
            Box::new(move || {
                black_box(
                    forward_kinematics_batch(chain, &mut b, black_box(flat))
                        .ok()
                        .map(|b| b.len()),
                );
            }),
            n,
        ));
        let mut b = self.single_data();
        methods.push((
            "kinechain, batch f32, 1 thread".into(),
            Box::new(move || {
                black_box(
                    single_precision::forward_kinematics_batch(chain, &mut b, black_box(flat))
                        .ok()
                        .map(|b| b.len()),
                );
            }),
            n,
        ));
        let mut b = self.batch_data();
        methods.push((
            format!("kinechain, batch of {}, {threads} threads", copies * n),
            Box::new(move || {
                black_box(
                    forward_kinematics_batch_par(chain, &mut b, black_box(big))
                        .ok()
                        .map(|b| b.len()),
                );
            }),
            copies * n,
        ));
        for parallel in [false, true] {
            let (qs, label, count) = if parallel {
                (
                    big,
                    format!(
                        "kinechain, batch of {}, end link only, {threads} threads",
                        copies * n
                    ),
                    copies * n,
                )
            } else {
                (flat, "kinechain, batch, end link only, 1 thread".into(), n)
            };
            let mut b = self.batch_data();
            methods.push((
                label,
                Box::new(move || {
                    black_box(
                        forward_kinematics_batch_to(chain, &mut b, black_box(qs), end, parallel)
                            .ok()
                            .map(|b| b.len()),
                    );
                }),
                count,
            ));
        }
        methods
    }

    /// The incremental update moving only the last entry of `q` on the end link's path, from
    /// the first configuration's other entries; `None` if no joint moves the end link.
    fn incremental_method(&self) -> Option<Method<'a>> {
        use crate::eval::kinematics::forward_kinematics_incremental;
        let Workload { chain, qs, end, .. } = *self;
        let last = last_variable_to(chain, end)?;
        let (joint, component) = chain.variables().nth(last)?;
        let moved = match component {
            Some(c) => format!("{} {c}", chain.joint(joint).name()),
            None => chain.joint(joint).name().to_string(),
        };
        let moving: Vec<Vec<f64>> = qs
            .iter()
            .map(|q| {
                let mut m = qs[0].clone();
                m[last] = q[last];
                m
            })
            .collect();
        let mut d = self.data();
        Some((
            format!("{INCREMENTAL} ({moved} moves)"),
            Box::new(move || {
                for q in &moving {
                    black_box(
                        forward_kinematics_incremental(chain, &mut d, black_box(q))
                            .ok()
                            .map(|p| p.world_from_link(end)),
                    );
                }
            }),
            qs.len(),
        ))
    }

    /// The rows of `--level vel` (`acc` false) or `--level acc`: the evaluation with rates, and
    /// poses alone.
    fn rate_methods(&self, acc: bool) -> Vec<Method<'a>> {
        let Workload {
            chain, qs, qd, end, ..
        } = *self;
        let mut d = self.data();
        vec![
            (
                if acc {
                    format!("{WITH_RATES} + accelerations")
                } else {
                    WITH_RATES.to_string()
                },
                Box::new(move || {
                    for (q, v) in qs.iter().zip(qd) {
                        if acc {
                            black_box(
                                forward_accelerations(chain, &mut d, black_box(q), v, v)
                                    .ok()
                                    .map(|a| a.acceleration(end)),
                            );
                        } else {
                            black_box(
                                forward_velocities(chain, &mut d, black_box(q), v)
                                    .ok()
                                    .map(|a| a.velocity(end)),
                            );
                        }
                    }
                }),
                qs.len(),
            ),
            (POSES_ONLY.into(), self.all_links(None, false), qs.len()),
        ]
    }
}

/// The header, the table of `kinechain bench` (a row per method of `labels`, with its ratio
/// to the `k` row's time if there is one) and the lines comparing rows measured together.
fn timing_table(
    chain: &Chain,
    n: usize,
    labels: &[&str],
    timings: &crate::measure::Interleaved,
) -> String {
    let k = labels.iter().position(|m| m.starts_with("k "));
    let mut text = format!(
        "{}: {} dof, {} links, {} moving joints; {n} random configurations; kernels: {}\n",
        chain.name(),
        chain.dof(),
        chain.links().len(),
        chain.moving_joint_count(),
        kernels_name()
    );
    // The method column as wide as its longest name (the end link's name is part of one).
    let width = labels
        .iter()
        .map(|m| m.chars().count())
        .max()
        .unwrap_or(0)
        .max(48);
    text.push_str(&format!(
        "{:<width$} {:>12} {:>10}\n",
        "method", "ns/config", "vs k"
    ));
    for (i, method) in labels.iter().enumerate() {
        let ns = timings.median(i);
        let ratio = k.map_or("-".to_string(), |k| format!("{:.1}x", timings.ratio(k, i)));
        text.push_str(&format!("{method:<width$} {ns:>12.1} {ratio:>10}\n"));
    }
    text.push_str(
        "times: medians of 7 rounds, the methods run in alternation, joint limits not checked; \"vs k\": median of the ratios within a round\n",
    );
    // The incremental update against a full evaluation, and rates against poses alone, measured
    // in the same rounds.
    let row = |label: &str| labels.iter().position(|m| m.starts_with(label));
    for (part, whole, of) in [
        (INCREMENTAL, ALL_LINKS, "all links"),
        (WITH_RATES, POSES_ONLY, "poses only"),
    ] {
        if let (Some(p), Some(w)) = (row(part), row(whole)) {
            text.push_str(&format!(
                "{}: {:.2}x the time of {of} (median of the ratios within a round)\n",
                labels[p].trim_start_matches("kinechain, "),
                timings.ratio(p, w)
            ));
        }
    }
    text
}

/// The error lines of `kinechain bench`: the poses' against the 256-bit evaluation
/// (`pose_errors` from [`Workload::pose_errors`]), then the single-precision batch's
/// (`--level pose`) or the rates' (`--level vel|acc`).
fn error_lines(
    work: &Workload<'_>,
    level: Level,
    pose_errors: [(f64, f64); 2],
) -> Result<String, CliError> {
    let [(position, rotation), (position32, rotation32)] = pose_errors;
    let reach = work.chain.reach().max(f64::MIN_POSITIVE);
    // (A robot far larger than any real one, as a stress test, prints in exponent form.)
    let reach_text = if reach < 1e6 {
        format!("{reach:.3}")
    } else {
        format!("{reach:.3e}")
    };
    let mut text = format!(
        "pose error against a 256-bit evaluation of the same model: position {position:.2e} m ({:.2} ulp of the {reach_text} m reach), rotation {rotation:.2e}",
        position / (reach * f64::EPSILON)
    );
    if level == Level::Pose && reach > f64::from(f32::MAX) {
        text.push_str("\nno error for the batch f32: the reach is beyond the range of f32");
    } else if level == Level::Pose {
        text.push_str(&format!(
            "\nthe same for the batch f32: position {position32:.2e} m ({:.2} f32 ulp of the reach), rotation {rotation32:.2e} ({:.2} f32 ulp)",
            position32 / (reach * f64::from(f32::EPSILON)),
            rotation32 / f64::from(f32::EPSILON)
        ));
    } else {
        let names = ["ω", "v", "α", "a"];
        let units = ["rad/s", "m/s", "rad/s²", "m/s²"];
        let parts: Vec<String> = rate_errors(work.chain, work.qs, work.qd, level == Level::Acc)?
            .iter()
            .zip(names.iter().zip(units))
            .map(|((abs, ulps), (name, unit))| {
                format!("{name} {abs:.2e} {unit} ({ulps:.2} ulp of the largest)")
            })
            .collect();
        text.push_str(&format!(
            "\nrate errors against the 256-bit evaluation: {}",
            parts.join(", ")
        ));
    }
    Ok(text)
}

/// Errors of ω and v, and with `acc` of α and a, against the 256-bit evaluation of the same
/// model, by the evaluation `bench` times and at the states it times (`q̈ = q̇`, or none without
/// `acc`): the largest absolute error over links and configurations, and the largest in ulps of
/// the configuration's largest component of that quantity (over all links).
fn rate_errors(
    chain: &Chain,
    qs: &[Vec<f64>],
    qd: &[Vec<f64>],
    acc: bool,
) -> Result<Vec<(f64, f64)>, CliError> {
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let mut worst = vec![(0.0_f64, 0.0_f64); if acc { 4 } else { 2 }];
    let zero = vec![0.0; chain.dof()];
    for (q, v) in qs.iter().zip(qd) {
        let qdd = if acc { v } else { &zero };
        let exact = crate::reference::link_motion(chain, q, v, qdd);
        // The evaluation `bench` times at this level.
        let ours: Vec<[[f64; 3]; 4]> = if acc {
            let got = forward_accelerations(chain, &mut data, q, v, qdd)?;
            (0..exact.len())
                .map(|l| {
                    let (v, a) = (got.velocity(LinkId(l)), got.acceleration(LinkId(l)));
                    [v.omega.into(), v.v.into(), a.alpha.into(), a.a.into()]
                })
                .collect()
        } else {
            let got = forward_velocities(chain, &mut data, q, v)?;
            (0..exact.len())
                .map(|l| {
                    let v = got.velocity(LinkId(l));
                    [v.omega.into(), v.v.into(), [0.0; 3], [0.0; 3]]
                })
                .collect()
        };
        let errors = crate::reference::max_rate_errors(&ours, &exact);
        for (w, e) in worst.iter_mut().zip(errors) {
            *w = (worse(w.0, e.0), worse(w.1, e.1));
        }
    }
    Ok(worst)
}

/// Labels of `kinechain bench` rows (the first two as prefixes) that the line after the table
/// compares: the incremental update with a full evaluation of poses (`--level pose`), and the
/// evaluation with rates with poses alone (`--level vel|acc`).
const INCREMENTAL: &str = "kinechain, incremental";
const WITH_RATES: &str = "kinechain, poses + velocities";
const ALL_LINKS: &str = "kinechain, all links";
const POSES_ONLY: &str = "kinechain, poses only";

/// The last entry of `q` that moves `link`: the largest read by the nearest body on its path that
/// reads one (on an arm with a gripper and the tool as `link`, the arm's last joint, not the
/// gripper's). `None` if no joint moves `link`.
fn last_variable_to(chain: &Chain, link: LinkId) -> Option<usize> {
    let mut body = chain.carrier(link).body;
    while let Some(b) = body {
        if let Some(last) = chain.bodies[b].motion.variables().max() {
            return Some(last);
        }
        body = chain.bodies[b].parent;
    }
    None
}

/// One call of the `k` crate evaluating every configuration of `qs`, with the label of its row:
/// on the robot file itself for a URDF, otherwise (a DH table, the axis form) on the URDF that
/// `kinechain convert` writes for it, whose joint vector is the original's (`tests/convert.rs`
/// checks that `k`'s link poses on it agree with the original's). `None` when `k` cannot load
/// the model (mimic joints are in its joint vector).
fn k_method<'a>(
    path: &std::path::Path,
    chain: &Chain,
    qs: &[Vec<f64>],
) -> Option<(String, Box<dyn FnMut() + 'a>)> {
    let (robot, written, label) =
        if crate::io::Format::from_path(path) == Some(crate::io::Format::Urdf) {
            let robot = k::Chain::<f64>::from_urdf_file(path).ok()?;
            (robot, None, "k 0.32, update_transforms")
        } else {
            let text = crate::io::convert::to_urdf(chain).ok()?;
            let written = Chain::from_urdf_str(&text).ok()?;
            // Through a file: `k` parses URDF with another version of `urdf-rs`.
            let file =
                std::env::temp_dir().join(format!("kinechain-bench-{}.urdf", std::process::id()));
            std::fs::write(&file, &text).ok()?;
            let robot = k::Chain::<f64>::from_urdf_file(&file);
            let _ = std::fs::remove_file(&file);
            let robot = robot.ok()?;
            (
                robot,
                Some(written),
                "k 0.32, update_transforms, written as URDF",
            )
        };
    // Joint names are looked up in the model k loaded (a cylindrical joint is two URDF joints).
    let named = written.as_ref().unwrap_or(chain);
    if named.dof() != chain.dof() {
        return None;
    }
    let names: Vec<String> = robot.iter_joints().map(|j| j.name.clone()).collect();
    let kq: Vec<Vec<f64>> = qs
        .iter()
        .map(|q| named.positions_by_name(names.iter().map(String::as_str), q))
        .collect::<Result<_, _>>()
        .ok()?;
    let call: Box<dyn FnMut() + 'a> = Box::new(move || {
        for q in &kq {
            robot.set_joint_positions_unchecked(black_box(q));
            black_box(robot.update_transforms());
        }
    });
    Some((label.to_string(), call))
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
