//! TF out: what `robot_state_publisher` would have published for a joint log, as a ROS 2 bag
//! (MCAP, CDR), for the viewers that read TF (Foxglove, Lichtblick, RViz through `ros2 bag play`,
//! Rerun).
//!
//! ```no_run
//! use kinechain::io::bag::{JointStateOptions, read_joint_states};
//! use kinechain::io::tf::{TfOptions, write_tf};
//! let chain = kinechain::Chain::from_file("robots/panda.urdf")?;
//! let log = read_joint_states("run.mcap".as_ref(), &JointStateOptions::default())?;
//! let (time, q) = kinechain::io::tf::rows_of_log(&chain, &log)?;
//! write_tf(&chain, &time, &q, "tf.mcap".as_ref(), &["run.mcap".as_ref()], &TfOptions::default())?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The file has three topics:
//! - `/tf` (`tf2_msgs/msg/TFMessage`): one message per row of the log, stamped with its time,
//!   holding one `geometry_msgs/TransformStamped` per moving joint (revolute, prismatic,
//!   continuous, mimic, ball, planar, floating): the child link's frame in the parent link's;
//! - `/tf_static` (the same type): one message, at the first row's time (0 for an empty log),
//!   with every fixed joint's transform, recorded with the transient-local durability its publishers offer (so
//!   that a player latches it);
//! - `/robot_description` (`std_msgs/msg/String`): the URDF (the file's own text for a URDF,
//!   [`to_urdf`](crate::io::convert::to_urdf)'s for the other formats), transient local too, so
//!   that a viewer's URDF layer finds the meshes by link name.
//!
//! Frame ids are link names, after [`TfOptions::frame_prefix`]; the floating base's parent is
//! [`TfOptions::world_frame`]. Each transform is `T_parentᵀ T_child` of the two links' world
//! poses (eq. 2.119 composed along the path), its rotation as a unit quaternion (eq. 2.10,
//! Shepperd's method), so that composing the transforms from the root gives the world poses back
//! to rounding.

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use nalgebra::Matrix3;

use crate::eval::{Chain, Data, Poses, forward_kinematics};
use crate::io::bag::JointStates;
use crate::io::output::{OutputError, write_file};
use crate::model::chain::LinkId;
use crate::model::joint::JointKind;
use crate::orientation::EulerParameters;

/// The `ros2msg` definition of `tf2_msgs/msg/TFMessage` with its dependencies, in the layout
/// rosbag2 writes (each dependency after a line of `=` and `MSG: name`).
pub const TF_MESSAGE_SCHEMA: &str = "geometry_msgs/TransformStamped[] transforms
================================================================================
MSG: geometry_msgs/TransformStamped
std_msgs/Header header
string child_frame_id
Transform transform
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Transform
Vector3 translation
Quaternion rotation
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x 0
float64 y 0
float64 z 0
float64 w 1
";

/// The `ros2msg` definition of `std_msgs/msg/String`.
pub const STRING_SCHEMA: &str = "string data\n";

/// The QoS rosbag2 records for a topic, as the YAML of its `offered_qos_profiles` channel
/// metadata: reliable, keep-last `depth`, transient local or volatile, no deadline, lifespan or
/// lease (the largest durations).
fn qos(depth: u32, transient_local: bool) -> String {
    let infinite = "\n    sec: 9223372036\n    nsec: 854775807";
    format!(
        "- history: 1\n  depth: {depth}\n  reliability: 1\n  durability: {}\n  deadline:{infinite}\n  lifespan:{infinite}\n  liveliness: 1\n  liveliness_lease_duration:{infinite}\n  avoid_ros_namespace_conventions: false",
        if transient_local { 1 } else { 2 }
    )
}

/// How [`write_tf`] names frames and what it records beside the transforms.
#[derive(Clone, Debug)]
pub struct TfOptions {
    /// Put before every frame id (`"left/"`: several robots in one file).
    pub frame_prefix: String,
    /// The frame a floating base moves in (not prefixed).
    pub world_frame: String,
    /// The URDF text for `/robot_description`; `None` writes [`to_urdf`](crate::io::convert::to_urdf)'s.
    pub description: Option<String>,
}

impl Default for TfOptions {
    fn default() -> Self {
        TfOptions {
            frame_prefix: String::new(),
            world_frame: "world".into(),
            description: None,
        }
    }
}

/// What [`write_tf`] wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TfSummary {
    /// `/tf` messages (one per row).
    pub messages: usize,
    /// Transforms in each `/tf` message (the moving joints).
    pub moving: usize,
    /// Transforms in the `/tf_static` message (the fixed joints).
    pub fixed: usize,
}

/// Why a TF file was not written. Each names what it is about.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TfError {
    /// `time` and `q` disagree in length.
    #[error("{rows} time stamps for {entries} entries of q (nq = {nq})")]
    Length {
        /// Time stamps given.
        rows: usize,
        /// Entries of `q` given.
        entries: usize,
        /// Entries a configuration has.
        nq: usize,
    },
    /// A time before 1970 (ROS stamps and MCAP log times are unsigned).
    #[error("row {row}: time {time} ns is negative")]
    Time {
        /// The row.
        row: usize,
        /// Its time, ns.
        time: i64,
    },
    /// A row the chain cannot evaluate (NaN, out of limits, a quaternion of norm 0).
    #[error("row {row} (time {time} ns): {source}")]
    Row {
        /// The row.
        row: usize,
        /// Its time, ns.
        time: i64,
        /// Why.
        source: crate::eval::StateError,
    },
    /// A log that lacks a joint of the chain.
    #[error("the log has no joint {joint:?} (it has {present:?})")]
    Joint {
        /// The chain's joint.
        joint: String,
        /// The log's joint names.
        present: Vec<String>,
    },
    /// The URDF for `/robot_description` could not be written.
    #[error("cannot describe the robot as URDF for /robot_description: {0}")]
    Description(#[from] crate::io::convert::ConvertError),
    /// The MCAP writer failed.
    #[error("cannot encode {}: {source}", path.display())]
    Mcap {
        /// The output file.
        path: PathBuf,
        /// Why.
        source: mcap::McapError,
    },
    /// The file could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// The rows of a joint log the chain can evaluate: times, and row-major `q` (the chain's
/// entries found by joint name); rows before every joint has had a value are left out.
///
/// # Errors
/// [`TfError::Joint`] for a joint of the chain the log never names.
pub fn rows_of_log(chain: &Chain, log: &JointStates) -> Result<(Vec<i64>, Vec<f64>), TfError> {
    let columns = log
        .columns_of(&chain.variable_names())
        .map_err(|missing| TfError::Joint {
            joint: missing.into_iter().next().unwrap_or_default(),
            present: log.names.clone(),
        })?;
    let (mut time, mut q) = (Vec::new(), Vec::new());
    for (i, &t) in log.time.iter().enumerate() {
        let row = log.position_row(i);
        if columns.iter().any(|&c| row[c].is_nan()) {
            continue;
        }
        time.push(t);
        q.extend(columns.iter().map(|&c| row[c]));
    }
    Ok((time, q))
}

/// Appends CDR (little endian) to a message, aligning each primitive to its size from the
/// start of the payload (after the 4-byte encapsulation header).
struct Cdr(Vec<u8>);

impl Cdr {
    fn new() -> Cdr {
        Cdr(vec![0, 1, 0, 0])
    }
    fn align(&mut self, n: usize) {
        while !(self.0.len() - 4).is_multiple_of(n) {
            self.0.push(0);
        }
    }
    fn u32(&mut self, x: u32) {
        self.align(4);
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn f64(&mut self, x: f64) {
        self.align(8);
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    fn string(&mut self, s: &str) {
        // Length with the terminating NUL; names are short, so the cast holds.
        self.u32(u32::try_from(s.len() + 1).unwrap_or(u32::MAX));
        self.0.extend_from_slice(s.as_bytes());
        self.0.push(0);
    }
}

/// One joint's transform: frame ids, and the links whose poses give it.
struct Edge {
    parent: String,
    child: String,
    parent_link: LinkId,
    child_link: LinkId,
}

/// A `TFMessage`'s CDR for a fixed list of transforms: the frame ids written once, and where
/// each transform's stamp and numbers go, so that a row only writes those (every message of a
/// topic has the same layout: the same strings at the same offsets).
struct Template {
    bytes: Vec<u8>,
    /// Per transform: offset of its stamp, and of its seven numbers (x y z, qx qy qz qw).
    at: Vec<(usize, usize)>,
}

impl Template {
    fn new(edges: &[Edge]) -> Template {
        let mut m = Cdr::new();
        m.u32(u32::try_from(edges.len()).unwrap_or(u32::MAX));
        let mut at = Vec::with_capacity(edges.len());
        for e in edges {
            m.align(4);
            let stamp = m.0.len();
            m.u32(0);
            m.u32(0);
            m.string(&e.parent);
            m.string(&e.child);
            m.align(8);
            let numbers = m.0.len();
            for _ in 0..7 {
                m.f64(0.0);
            }
            at.push((stamp, numbers));
        }
        Template { bytes: m.0, at }
    }

    /// The message of `edges` at `poses`, stamped `t` (ns ≥ 0).
    fn fill(&mut self, poses: &Poses, edges: &[Edge], t: i64) -> &[u8] {
        // ROS stamps hold seconds in an int32 (until 2038).
        let sec = i32::try_from(t.div_euclid(1_000_000_000)).unwrap_or(i32::MAX);
        let nanosec = u32::try_from(t.rem_euclid(1_000_000_000)).unwrap_or(0);
        for (e, &(stamp, numbers)) in edges.iter().zip(&self.at) {
            self.bytes[stamp..stamp + 4].copy_from_slice(&sec.to_le_bytes());
            self.bytes[stamp + 4..stamp + 8].copy_from_slice(&nanosec.to_le_bytes());
            let x = poses.base_from_link(e.parent_link, e.child_link);
            let r = Matrix3::from_fn(|i, j| x.r[j][i]);
            // Unit to rounding (Shepperd's method leaves a few ulps; ROS checks the norm).
            let q = EulerParameters::from_matrix(&r).normalized();
            let values = [x.p[0], x.p[1], x.p[2], q.e1, q.e2, q.e3, q.e0];
            for (k, v) in values.iter().enumerate() {
                let o = numbers + 8 * k;
                self.bytes[o..o + 8].copy_from_slice(&v.to_le_bytes());
            }
        }
        &self.bytes
    }
}

/// Writes the TF of `rows` (times in ns, row-major `q`) of `chain` to `path` (never over one of
/// `inputs`; FIFOs and devices written in place).
///
/// # Errors
/// [`TfError`] for lengths that disagree, a negative time, a row the chain refuses (naming it),
/// or the file.
pub fn write_tf(
    chain: &Chain,
    time: &[i64],
    q: &[f64],
    path: &Path,
    inputs: &[&Path],
    options: &TfOptions,
) -> Result<TfSummary, TfError> {
    let nq = chain.nq();
    if q.len() != time.len() * nq {
        return Err(TfError::Length {
            rows: time.len(),
            entries: q.len(),
            nq,
        });
    }
    if let Some((row, &t)) = time.iter().enumerate().find(|(_, t)| **t < 0) {
        return Err(TfError::Time { row, time: t });
    }
    let description = match &options.description {
        Some(text) => text.clone(),
        None => crate::io::convert::to_urdf(chain)?,
    };
    let name = |l: LinkId| format!("{}{}", options.frame_prefix, chain.link(l).name());
    let (mut moving, mut fixed) = (Vec::new(), Vec::new());
    for j in chain.joints() {
        let parent = if j.kind() == JointKind::Floating {
            options.world_frame.clone()
        } else {
            name(j.parent())
        };
        let edge = Edge {
            parent,
            child: name(j.child()),
            parent_link: j.parent(),
            child_link: j.child(),
        };
        if j.kind() == JointKind::Fixed {
            fixed.push(edge);
        } else {
            moving.push(edge);
        }
    }
    let fail = |source| TfError::Mcap {
        path: path.to_path_buf(),
        source,
    };
    // LZ4 chunks: several times faster to write than zstd, and read by every MCAP reader.
    let mut w = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Lz4))
        .profile("ros2")
        .library(concat!("kinechain ", env!("CARGO_PKG_VERSION")))
        .create(Cursor::new(Vec::new()))
        .map_err(fail)?;
    let tf_schema = w
        .add_schema(
            "tf2_msgs/msg/TFMessage",
            "ros2msg",
            TF_MESSAGE_SCHEMA.as_bytes(),
        )
        .map_err(fail)?;
    let string_schema = w
        .add_schema("std_msgs/msg/String", "ros2msg", STRING_SCHEMA.as_bytes())
        .map_err(fail)?;
    let meta = |depth, latched| {
        BTreeMap::from([("offered_qos_profiles".to_string(), qos(depth, latched))])
    };
    let tf = w
        .add_channel(tf_schema, "/tf", "cdr", &meta(100, false))
        .map_err(fail)?;
    let tf_static = w
        .add_channel(tf_schema, "/tf_static", "cdr", &meta(1, true))
        .map_err(fail)?;
    let robot_description = w
        .add_channel(string_schema, "/robot_description", "cdr", &meta(1, true))
        .map_err(fail)?;
    let first = time.first().copied().unwrap_or(0);
    let header = |channel_id, sequence, t: i64| mcap::records::MessageHeader {
        channel_id,
        sequence,
        log_time: t.unsigned_abs(),
        publish_time: t.unsigned_abs(),
    };
    let mut text = Cdr::new();
    text.string(&description);
    w.write_to_known_channel(&header(robot_description, 0, first), &text.0)
        .map_err(fail)?;
    // The fixed joints' transforms do not depend on q: evaluated once, at the neutral
    // configuration (limits not applied: it is no row of the log), stamped with the first row's
    // time (0 for an empty log, whose file has them still).
    let mut data = Data::new(chain).with_limit_policy(crate::eval::LimitPolicy::Ignore);
    let neutral = chain.neutral();
    let poses = forward_kinematics(chain, &mut data, &neutral).map_err(|source| TfError::Row {
        row: 0,
        time: first,
        source,
    })?;
    let mut statics = Template::new(&fixed);
    w.write_to_known_channel(
        &header(tf_static, 0, first),
        statics.fill(&poses, &fixed, first),
    )
    .map_err(fail)?;
    let mut template = Template::new(&moving);
    let mut data = Data::new(chain);
    for (row, &t) in time.iter().enumerate() {
        let q = &q[row * nq..(row + 1) * nq];
        let poses = forward_kinematics(chain, &mut data, q).map_err(|source| TfError::Row {
            row,
            time: t,
            source,
        })?;
        let sequence = u32::try_from(row).unwrap_or(u32::MAX);
        w.write_to_known_channel(&header(tf, sequence, t), template.fill(&poses, &moving, t))
            .map_err(fail)?;
    }
    w.finish().map_err(fail)?;
    write_file(path, &w.into_inner().into_inner(), inputs)?;
    Ok(TfSummary {
        messages: time.len(),
        moving: moving.len(),
        fixed: fixed.len(),
    })
}
