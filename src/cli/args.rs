//! The command line as clap parses it: the commands, their arguments, and the parsers of
//! argument values.

use crate::cli::error::CliError;
use crate::cli::limits::MAX_BENCH_CONFIGURATIONS;
use crate::eval::Chain;
use crate::model::chain::LinkId;
use crate::regression::{self, Options, Tolerances};
use clap::{Parser, Subcommand, ValueEnum};
use nalgebra::Vector3;
use std::path::PathBuf;

/// Forward kinematics of robot chains from DH YAML or URDF files.
#[derive(Debug, Parser)]
#[command(name = "kinechain", version, about)]
pub(super) struct Cli {
    #[command(subcommand)]
    pub(super) command: Command,
    /// Add a floating joint `root_joint` between the world and the robot's root link (a
    /// humanoid's or a quadruped's base): q then starts with its position x, y, z and
    /// quaternion w, x, y, z, and q̇ with its velocity and angular velocity (world axes).
    #[arg(long, global = true)]
    pub(super) floating_base: bool,
    /// MJCF: make each linear `<equality><joint>` coupling a joint that follows its leader (a
    /// mimic joint, with no entry of q), so that q holds the leaders only.
    #[arg(long, global = true)]
    pub(super) couplings: bool,
    /// xacro: an argument of the description (`--arg ur_type:=ur5e`), overriding its
    /// `<xacro:arg>` default; repeatable.
    #[arg(long = "arg", global = true, value_name = "NAME:=VALUE", value_parser = xacro_arg)]
    pub(super) xacro_args: Vec<(String, String)>,
    /// xacro: a directory holding ROS packages, searched first by `$(find PKG)` (a few levels
    /// deep, for a package.xml naming PKG or a directory named PKG); repeatable.
    #[arg(long = "package-path", global = true, value_name = "DIR")]
    pub(super) package_paths: Vec<PathBuf>,
}

impl Cli {
    /// How the robot files of the command are loaded.
    pub(super) fn load_options(&self) -> crate::io::LoadOptions {
        let mut options = crate::io::LoadOptions::default()
            .with_floating_base(self.floating_base)
            .with_couplings(self.couplings);
        options.xacro.args.clone_from(&self.xacro_args);
        options.xacro.package_paths.clone_from(&self.package_paths);
        options
    }
}

/// `NAME:=VALUE`, as xacro takes its arguments.
fn xacro_arg(text: &str) -> Result<(String, String), String> {
    match text.split_once(":=") {
        Some((name, value)) if !name.is_empty() => Ok((name.to_string(), value.to_string())),
        _ => Err(format!("'{text}' is not NAME:=VALUE")),
    }
}

#[derive(Debug, Subcommand)]
pub(super) enum Command {
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
    /// The joint values that put a link at a target (inverse kinematics): one --target, or a
    /// --batch file of them. Exits 1 if a target is not reached (its closest result printed).
    Ik(IkArgs),
    /// Write the robot as URDF (DH tables and the axis form; the links keep their names and
    /// poses).
    Convert {
        /// Robot file (.yaml/.yml DH table or .urdf).
        robot: PathBuf,
        /// Output file (default: standard output).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Expand a xacro file into URDF, as ROS's `xacro` does, without ROS (with --arg and
    /// --package-path).
    Expand {
        /// The xacro file (.xacro, .urdf.xacro).
        file: PathBuf,
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
    /// Write one self-contained HTML page that draws the robot (stick figure, link frames, joint
    /// axes), with a slider per joint and, for a bag, a timeline; it evaluates the chain itself.
    View {
        /// Robot file.
        robot: PathBuf,
        /// Joint positions to show (same forms as for fk; default: the neutral configuration).
        #[arg(long, allow_hyphen_values = true, conflicts_with = "bag")]
        q: Option<String>,
        /// A ROS bag (MCAP): its JointState messages as a trajectory with a timeline.
        #[arg(long, value_name = "FILE")]
        bag: Option<PathBuf>,
        /// The topic of --bag.
        #[arg(long, requires = "bag", default_value = crate::io::bag::DEFAULT_TOPIC)]
        topic: String,
        /// Output file (default: standard output).
        #[arg(short, long)]
        output: Option<PathBuf>,
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
pub(super) enum Level {
    Pose,
    Vel,
    Acc,
}

#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("many").args(["batch", "bag"])))]
pub(super) struct FkArgs {
    /// Robot file (.yaml/.yml DH table or .urdf).
    pub(super) robot: PathBuf,
    /// Joint positions: JSON array in q order, JSON object keyed by joint name, or a list
    /// separated by commas or spaces.
    #[arg(
        long,
        allow_hyphen_values = true,
        required_unless_present_any = ["batch", "bag"],
        conflicts_with_all = ["batch", "bag"]
    )]
    pub(super) q: Option<String>,
    /// Joint velocities (same forms as --q); adds "omega" and "v" to the output.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "batch")]
    pub(super) qd: Option<String>,
    /// Joint accelerations (same forms as --q); adds "alpha" and "a". Needs --qd.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "batch")]
    pub(super) qdd: Option<String>,
    /// A JSON-lines file with one configuration per line: {"q": .., "qd": .., "qdd": ..}, or q
    /// alone as a JSON array or numbers separated by commas or spaces (a CSV row, in the order
    /// of a first row of joint names if there is one); `-` reads standard input, writing each
    /// result before waiting for more input.
    #[arg(long, conflicts_with = "bag")]
    pub(super) batch: Option<PathBuf>,
    /// A ROS bag (MCAP): one result per sensor_msgs/JointState message of --topic, headed by its
    /// `header.stamp` in ns (`time`). Joints are found by name; a message that does not carry a
    /// joint keeps its last value; messages before every joint has had one are skipped (and
    /// counted on standard error).
    #[arg(long, value_name = "FILE")]
    pub(super) bag: Option<PathBuf>,
    /// The topic of --bag.
    #[arg(long, requires = "bag", default_value = crate::io::bag::DEFAULT_TOPIC)]
    pub(super) topic: String,
    /// With --bag: instead of printing results, write what robot_state_publisher would have
    /// published for the log to this MCAP file (a ROS 2 bag): /tf (one tf2_msgs/TFMessage per
    /// JointState message, one transform per moving joint), /tf_static (the fixed joints, once,
    /// transient local) and /robot_description (the URDF). Never over an input.
    #[arg(long, value_name = "OUT.mcap", requires = "bag", conflicts_with_all = ["links", "base", "points", "jacobians", "keep_going"])]
    pub(super) tf: Option<PathBuf>,
    /// With --tf: put this before every frame id (several robots in one file).
    #[arg(long, requires = "tf", default_value = "")]
    pub(super) frame_prefix: String,
    /// With --tf: the frame a floating base moves in.
    #[arg(long, requires = "tf", default_value = "world")]
    pub(super) world_frame: String,
    /// Only these links (repeatable); only the joints they depend on are evaluated.
    #[arg(long = "link", value_name = "NAME")]
    pub(super) links: Vec<String>,
    /// Results relative to this link, in its frame: poses `base_from_link`, and the velocities,
    /// accelerations and Jacobians of the motion relative to it.
    #[arg(long, value_name = "LINK")]
    pub(super) base: Option<String>,
    /// A point fixed on a link, in link coordinates (m): prints its position, and its velocity and
    /// acceleration when --qd/--qdd are given (repeatable).
    #[arg(long = "point", value_name = "LINK:X,Y,Z", allow_hyphen_values = true)]
    pub(super) points: Vec<String>,
    /// The geometric Jacobian of a link: the 6 × dof matrix J with [v; ω] = J q̇, world frame,
    /// linear rows first, columns in q order (repeatable). With --qd, also its time derivative
    /// J̇, so that [a; α] = J q̈ + J̇ q̇.
    #[arg(long = "jacobian", value_name = "LINK")]
    pub(super) jacobians: Vec<String>,
    /// Evaluate joint values outside the joints' limits instead of refusing them.
    #[arg(long)]
    pub(super) ignore_limits: bool,
    /// With --batch or --bag: on a bad line or message, write {"line": N, "error": ".."}
    /// ({"time": T, ..} for a message; in a table, `line N: error: ..`) in its place and go on;
    /// exit non-zero at the end if any failed.
    #[arg(long, requires = "many")]
    pub(super) keep_going: bool,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Json)]
    pub(super) format: OutputFormat,
    /// How to print each link's orientation: the pose matrix, or the position and one set of
    /// orientation coordinates (null, or `undefined` in a table, where undefined).
    #[arg(long, value_enum, default_value_t = Orientation::Matrix)]
    pub(super) orientation: Orientation,
}

#[derive(Debug, clap::Args)]
pub(super) struct IkArgs {
    /// Robot file (.yaml/.yml DH table, .urdf, .xacro or MJCF .xml).
    pub(super) robot: PathBuf,
    /// The link to place.
    #[arg(long)]
    pub(super) link: String,
    /// The target: `x,y,z` (a position, the orientation free), `x,y,z,roll,pitch,yaw` (m, rad,
    /// as URDF's rpy), `x,y,z,qw,qx,qy,qz`, or the 16 entries of a 4 × 4 matrix row by row;
    /// numbers separated by commas or spaces, or a JSON array.
    #[arg(
        long,
        allow_hyphen_values = true,
        required_unless_present = "batch",
        conflicts_with = "batch"
    )]
    pub(super) target: Option<String>,
    /// A file with one target per line (the forms of --target; a first line of column names is
    /// skipped); `-` reads standard input, writing each result before reading the next.
    #[arg(long)]
    pub(super) batch: Option<PathBuf>,
    /// The seed (the forms of fk's --q; default: the middle of each joint's limits).
    #[arg(long, allow_hyphen_values = true)]
    pub(super) q0: Option<String>,
    /// The link whose frame the target is given in (default: the world).
    #[arg(long)]
    pub(super) base: Option<String>,
    /// A joint that does not move (it keeps the seed's value); repeatable.
    #[arg(long = "lock", value_name = "JOINT")]
    pub(super) locked: Vec<String>,
    /// Position tolerance (m).
    #[arg(long, default_value_t = 1e-6)]
    pub(super) position_tolerance: f64,
    /// Rotation tolerance (rad).
    #[arg(long, default_value_t = 1e-6)]
    pub(super) rotation_tolerance: f64,
    /// Attempts in all (the first from the seed, the others from random configurations).
    #[arg(long, default_value_t = 100)]
    pub(super) max_attempts: usize,
    /// Seed of the restarts' random configurations.
    #[arg(long, default_value_t = 0)]
    pub(super) seed: u64,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutputFormat::Json)]
    pub(super) format: OutputFormat,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum OutputFormat {
    /// JSON; with --batch or --bag, one JSON object per line (also called `jsonl`).
    #[value(alias = "jsonl")]
    Json,
    Table,
    /// Comma-separated values (`fk` only): a header row, then one row per configuration.
    Csv,
}

/// `--configurations`: a whole number from 2 to [`MAX_BENCH_CONFIGURATIONS`].
pub(super) fn configuration_count(s: &str) -> Result<usize, String> {
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

/// A point fixed on a link.
pub(super) struct Point {
    pub(super) link: LinkId,
    pub(super) u: Vector3<f64>,
}

impl Point {
    /// `point LINK (x, y, z)`, the coordinates as given: for errors, and written straight into
    /// each table line.
    pub(super) fn label<'a>(&'a self, chain: &'a Chain) -> PointLabel<'a> {
        PointLabel {
            link: chain.link(self.link).name(),
            u: &self.u,
        }
    }
}

/// [`Point::label`].
pub(super) struct PointLabel<'a> {
    pub(super) link: &'a str,
    pub(super) u: &'a Vector3<f64>,
}

impl std::fmt::Display for PointLabel<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let u = self.u;
        write!(f, "point {} ({:?}, {:?}, {:?})", self.link, u.x, u.y, u.z)
    }
}

pub(super) fn parse_point(chain: &Chain, text: &str) -> Result<Point, CliError> {
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

/// How `fk` prints each link's orientation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum Orientation {
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

/// The tolerances of `verify` and `compare`.
#[derive(Debug, clap::Args)]
pub(super) struct TolArgs {
    /// Largest distance a link origin may move (m).
    #[arg(long, default_value_t = 1e-9, value_parser = tolerance)]
    tol_position: f64,
    /// Largest angle a link may turn (rad).
    #[arg(long, default_value_t = 1e-9, value_parser = tolerance)]
    tol_rotation: f64,
    /// Largest change of ω, v, α or a (levels vel and acc).
    #[arg(long, default_value_t = 1e-9, value_parser = tolerance)]
    tol_rates: f64,
}

impl TolArgs {
    pub(super) fn tolerances(&self) -> Tolerances {
        Tolerances {
            position: self.tol_position,
            rotation: self.tol_rotation,
            rates: self.tol_rates,
        }
    }
}

/// How `record` and `compare` draw configurations.
#[derive(Debug, clap::Args)]
pub(super) struct SampleArgs {
    /// Random configurations within the limits, besides zero and the two limit corners where
    /// the limits admit them.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(0..=1_000_000))]
    samples: u32,
    /// Seed of the configurations (the same seed draws the same ones).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// What to record: poses, poses and velocities, or poses, velocities and accelerations.
    #[arg(long, value_enum, default_value_t = Level::Pose)]
    level: Level,
    /// Only these links (repeatable; default: every link).
    #[arg(long = "link", value_name = "NAME")]
    links: Vec<String>,
}

impl SampleArgs {
    pub(super) fn options(&self) -> Options {
        Options {
            samples: self.samples as usize,
            seed: self.seed,
            level: match self.level {
                Level::Pose => regression::Level::Pose,
                Level::Vel => regression::Level::Vel,
                Level::Acc => regression::Level::Acc,
            },
            links: self.links.clone(),
        }
    }
}

/// `OLD=NEW`: a joint of the first robot and its name in the second.
pub(super) fn rename(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((old, new)) if !old.is_empty() && !new.is_empty() => {
            Ok((old.to_string(), new.to_string()))
        }
        _ => Err(format!(
            "'{s}' is not OLD=NEW (a joint of the first robot, then its name in the second)"
        )),
    }
}

fn tolerance(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!("'{s}' is not a finite number ≥ 0")),
    }
}
