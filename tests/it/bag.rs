//! ROS bags (`kinechain::io::bag`): `JointState` messages written here into MCAP files with the
//! `mcap` crate's writer, serialised by hand as ROS 2 (CDR) and ROS 1 do, read back.

use crate::common::Scratch;
use kinechain::io::bag::{BagError, JointStateOptions, Missing, TimeSource, read_joint_states};
use std::collections::BTreeMap;
use std::path::Path;

/// One `sensor_msgs/JointState` message.
#[derive(Clone)]
pub(crate) struct State<'a> {
    pub(crate) stamp: (i32, u32),
    pub(crate) names: &'a [&'a str],
    pub(crate) position: &'a [f64],
    pub(crate) velocity: &'a [f64],
    pub(crate) effort: &'a [f64],
}

/// How a message is serialised.
#[derive(Clone, Copy)]
pub(crate) enum Wire {
    /// ROS 2: CDR (XCDR1), little- or big-endian.
    Cdr { little: bool },
    /// ROS 2 with XCDR2's 4-byte largest alignment.
    Cdr2,
    /// ROS 1.
    Ros1,
}

/// A message's bytes, written the way the wire format lays them out.
struct Writer {
    bytes: Vec<u8>,
    origin: usize,
    little: bool,
    max_align: usize,
    nul: bool,
}

impl Writer {
    fn align(&mut self, n: usize) {
        let a = n.min(self.max_align);
        while !(self.bytes.len() - self.origin).is_multiple_of(a) {
            self.bytes.push(0);
        }
    }
    fn u32(&mut self, x: u32) {
        self.align(4);
        let b = if self.little {
            x.to_le_bytes()
        } else {
            x.to_be_bytes()
        };
        self.bytes.extend_from_slice(&b);
    }
    fn string(&mut self, s: &str) {
        self.u32(u32::try_from(s.len() + usize::from(self.nul)).unwrap());
        self.bytes.extend_from_slice(s.as_bytes());
        if self.nul {
            self.bytes.push(0);
        }
    }
    fn f64s(&mut self, xs: &[f64]) {
        self.u32(u32::try_from(xs.len()).unwrap());
        // (As Fast-CDR writes it: no padding before an empty sequence.)
        if !xs.is_empty() {
            self.align(8);
        }
        for x in xs {
            let b = if self.little {
                x.to_le_bytes()
            } else {
                x.to_be_bytes()
            };
            self.bytes.extend_from_slice(&b);
        }
    }
}

pub(crate) fn serialise(m: &State, wire: Wire) -> Vec<u8> {
    let mut w = match wire {
        Wire::Cdr { little } => Writer {
            bytes: vec![0, u8::from(little), 0, 0],
            origin: 4,
            little,
            max_align: 8,
            nul: true,
        },
        Wire::Cdr2 => Writer {
            bytes: vec![0, 7, 0, 0],
            origin: 4,
            little: true,
            max_align: 4,
            nul: true,
        },
        Wire::Ros1 => Writer {
            bytes: Vec::new(),
            origin: 0,
            little: true,
            max_align: 1,
            nul: false,
        },
    };
    if let Wire::Ros1 = wire {
        w.u32(7);
    }
    w.u32(m.stamp.0.cast_unsigned());
    w.u32(m.stamp.1);
    w.string("base");
    w.u32(u32::try_from(m.names.len()).unwrap());
    for n in m.names {
        w.string(n);
    }
    w.f64s(m.position);
    w.f64s(m.velocity);
    w.f64s(m.effort);
    w.bytes
}

/// A channel of a bag: its topic, message type and encoding.
pub(crate) struct Channel<'a> {
    pub(crate) topic: &'a str,
    pub(crate) schema: &'a str,
    pub(crate) encoding: &'a str,
}

pub(crate) const JOINT_STATES: Channel = Channel {
    topic: "/joint_states",
    schema: "sensor_msgs/msg/JointState",
    encoding: "cdr",
};

/// Writes `messages` (each a channel index, log time and bytes) into an MCAP file at `path`.
pub(crate) fn write_bag(
    path: &str,
    channels: &[Channel],
    messages: &[(usize, u64, Vec<u8>)],
    compression: Option<mcap::Compression>,
) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let options = mcap::WriteOptions::new()
        .compression(compression)
        .chunk_size(Some(4096));
    let mut w = options.create(file).unwrap();
    let ids: Vec<u16> = channels
        .iter()
        .map(|c| {
            let schema_encoding = if c.encoding == "ros1" {
                "ros1msg"
            } else {
                "ros2msg"
            };
            let schema = w.add_schema(c.schema, schema_encoding, b"").unwrap();
            w.add_channel(schema, c.topic, c.encoding, &BTreeMap::new())
                .unwrap()
        })
        .collect();
    for (sequence, (channel, log_time, data)) in messages.iter().enumerate() {
        let header = mcap::records::MessageHeader {
            channel_id: ids[*channel],
            sequence: u32::try_from(sequence).unwrap(),
            log_time: *log_time,
            publish_time: *log_time,
        };
        w.write_to_known_channel(&header, data).unwrap();
    }
    w.finish().unwrap();
}

const ARM: [&str; 3] = ["a", "b", "c"];

/// Message `i` of the arm: every joint, in a shuffled order, at values that name the message.
fn full(i: usize) -> (Vec<&'static str>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let order: [usize; 3] = [[0, 1, 2], [2, 0, 1], [1, 2, 0]][i % 3];
    let names = order.iter().map(|&j| ARM[j]).collect();
    let x = |j: usize, k: f64| (i * 10 + j) as f64 + k;
    let position = order.iter().map(|&j| x(j, 0.25)).collect();
    let velocity = order.iter().map(|&j| x(j, 0.5)).collect();
    let effort = order.iter().map(|&j| x(j, 0.75)).collect();
    (names, position, velocity, effort)
}

fn bag_of_full_states(scratch: &Scratch, wire: Wire, n: usize) -> String {
    let channel = match wire {
        Wire::Ros1 => Channel {
            topic: "/joint_states",
            schema: "sensor_msgs/JointState",
            encoding: "ros1",
        },
        _ => JOINT_STATES,
    };
    let path = scratch.path("full.mcap");
    write_bag(&path, &[channel], &full_messages(n, wire), None);
    path
}

/// `n` messages of [`full`] states, stamped `i` s + 5 ns, on channel 0.
fn full_messages(n: usize, wire: Wire) -> Vec<(usize, u64, Vec<u8>)> {
    (0..n)
        .map(|i| {
            let (names, p, v, e) = full(i);
            let state = State {
                stamp: (i32::try_from(i).unwrap(), 5),
                names: &names,
                position: &p,
                velocity: &v,
                effort: &e,
            };
            (0, 1_000 + i as u64, serialise(&state, wire))
        })
        .collect()
}

#[test]
fn every_wire_format_reads_back_in_column_order() {
    let scratch = Scratch::new("bag-wires");
    for wire in [
        Wire::Cdr { little: true },
        Wire::Cdr { little: false },
        Wire::Cdr2,
        Wire::Ros1,
    ] {
        let path = bag_of_full_states(&scratch, wire, 7);
        let options = JointStateOptions {
            velocities: true,
            efforts: true,
            ..JointStateOptions::default()
        };
        let log = read_joint_states(Path::new(&path), &options).unwrap();
        assert_eq!(log.names, ["a", "b", "c"]);
        assert_eq!(log.len(), 7);
        for i in 0..7 {
            assert_eq!(log.time[i], i as i64 * 1_000_000_000 + 5);
            for (j, _) in ARM.iter().enumerate() {
                let x = (i * 10 + j) as f64;
                assert_eq!(log.position[i * 3 + j], x + 0.25);
                assert_eq!(log.velocity[i * 3 + j], x + 0.5);
                assert_eq!(log.effort[i * 3 + j], x + 0.75);
            }
        }
        assert!(!log.truncated);
    }
}

#[test]
fn compressed_chunks_read_as_plain_ones() {
    let scratch = Scratch::new("bag-compression");
    let plain = bag_of_full_states(&scratch, Wire::Cdr { little: true }, 500);
    let expected = read_joint_states(Path::new(&plain), &JointStateOptions::default()).unwrap();
    for compression in [mcap::Compression::Zstd, mcap::Compression::Lz4] {
        let messages = full_messages(500, Wire::Cdr { little: true });
        let path = scratch.path("compressed.mcap");
        write_bag(&path, &[JOINT_STATES], &messages, Some(compression));
        let log = read_joint_states(Path::new(&path), &JointStateOptions::default()).unwrap();
        assert_eq!(log.time, expected.time);
        assert_eq!(log.position, expected.position);
    }
}

/// Two publishers on one topic (two channels), each sending a subset; a third channel of
/// another topic; the last values carried forward, or NaN.
#[test]
fn subsets_from_two_publishers_hold_or_leave_nan() {
    let scratch = Scratch::new("bag-subsets");
    let arm = State {
        stamp: (1, 0),
        names: &["b", "a"],
        position: &[2.0, 1.0],
        velocity: &[],
        effort: &[],
    };
    let gripper = State {
        stamp: (2, 0),
        names: &["g"],
        position: &[0.5],
        velocity: &[0.1],
        effort: &[],
    };
    let arm_again = State {
        stamp: (3, 0),
        names: &["a", "b"],
        position: &[1.5, 2.5],
        velocity: &[],
        effort: &[],
    };
    let other = Channel {
        topic: "/camera",
        schema: "sensor_msgs/msg/Image",
        encoding: "cdr",
    };
    let second = Channel {
        topic: "/joint_states",
        schema: "sensor_msgs/msg/JointState",
        encoding: "cdr",
    };
    let cdr = Wire::Cdr { little: true };
    let messages = [
        (0, 10, serialise(&arm, cdr)),
        (2, 11, vec![1, 2, 3]),
        (1, 12, serialise(&gripper, cdr)),
        (0, 13, serialise(&arm_again, cdr)),
    ];
    let path = scratch.path("subsets.mcap");
    // (The writer makes one channel of two identical ones: the second differs by metadata.)
    let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    let mut w = mcap::Writer::new(file).unwrap();
    let schema = w
        .add_schema("sensor_msgs/msg/JointState", "ros2msg", b"")
        .unwrap();
    let image = w
        .add_schema("sensor_msgs/msg/Image", "ros2msg", b"")
        .unwrap();
    let mut meta = BTreeMap::new();
    let c0 = w
        .add_channel(schema, "/joint_states", "cdr", &meta)
        .unwrap();
    meta.insert("publisher".to_string(), "gripper".to_string());
    let c1 = w
        .add_channel(schema, second.topic, second.encoding, &meta)
        .unwrap();
    let c2 = w
        .add_channel(image, other.topic, "cdr", &BTreeMap::new())
        .unwrap();
    for (k, (channel, log_time, data)) in messages.iter().enumerate() {
        let header = mcap::records::MessageHeader {
            channel_id: [c0, c1, c2][*channel],
            sequence: u32::try_from(k).unwrap(),
            log_time: *log_time,
            publish_time: *log_time,
        };
        w.write_to_known_channel(&header, data).unwrap();
    }
    w.finish().unwrap();

    let mut options = JointStateOptions {
        velocities: true,
        ..JointStateOptions::default()
    };
    let held = read_joint_states(Path::new(&path), &options).unwrap();
    assert_eq!(held.names, ["b", "a", "g"]);
    assert_eq!(held.time, [1_000_000_000, 2_000_000_000, 3_000_000_000]);
    let nan = f64::NAN;
    let same = |a: &[f64], b: &[f64]| {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
    };
    assert!(same(
        &held.position,
        &[2.0, 1.0, nan, 2.0, 1.0, 0.5, 2.5, 1.5, 0.5]
    ));
    assert!(same(
        &held.velocity,
        &[nan, nan, nan, nan, nan, 0.1, nan, nan, 0.1]
    ));
    options.missing = Missing::Null;
    options.time = TimeSource::Log;
    let nulls = read_joint_states(Path::new(&path), &options).unwrap();
    assert_eq!(nulls.time, [10, 12, 13]);
    assert!(same(
        &nulls.position,
        &[2.0, 1.0, nan, nan, nan, 0.5, 2.5, 1.5, nan]
    ));
}

#[test]
fn a_cut_off_bag_is_an_error_or_its_messages_before_the_cut() {
    let scratch = Scratch::new("bag-truncated");
    let path = bag_of_full_states(&scratch, Wire::Cdr { little: true }, 400);
    let bytes = std::fs::read(&path).unwrap();
    let cut = scratch.write("cut.mcap", &bytes[..bytes.len() * 2 / 3]);
    let err = read_joint_states(Path::new(&cut), &JointStateOptions::default()).unwrap_err();
    let BagError::Truncated { messages, .. } = &err else {
        panic!("{err}")
    };
    assert!(*messages > 0 && *messages < 400, "{err}");
    let text = err.to_string();
    assert!(
        text.contains("cut.mcap") && text.contains("/joint_states"),
        "{text}"
    );
    let options = JointStateOptions {
        keep_truncated: true,
        ..JointStateOptions::default()
    };
    let log = read_joint_states(Path::new(&cut), &options).unwrap();
    assert!(log.truncated);
    assert_eq!(log.len(), *messages);
    let whole = read_joint_states(Path::new(&path), &JointStateOptions::default()).unwrap();
    assert_eq!(log.position[..], whole.position[..log.position.len()]);
}

#[test]
fn topics_types_and_files_that_are_not_joint_states_are_errors() {
    let scratch = Scratch::new("bag-errors");
    let path = bag_of_full_states(&scratch, Wire::Cdr { little: true }, 3);
    let err = read_joint_states(
        Path::new(&path),
        &JointStateOptions::new("/arm/joint_states"),
    )
    .unwrap_err();
    assert!(matches!(err, BagError::NoTopic { .. }), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("no topic /arm/joint_states")
            && text.contains("/joint_states (sensor_msgs/msg/JointState)"),
        "{text}"
    );

    let odom = Channel {
        topic: "/odom",
        schema: "nav_msgs/msg/Odometry",
        encoding: "cdr",
    };
    let wrong = scratch.path("odom.mcap");
    write_bag(&wrong, &[odom], &[(0, 1, vec![0, 1, 0, 0])], None);
    let err = read_joint_states(Path::new(&wrong), &JointStateOptions::new("/odom")).unwrap_err();
    assert!(
        err.to_string()
            .contains("topic /odom carries nav_msgs/msg/Odometry messages (cdr)"),
        "{err}"
    );

    let not_mcap = scratch.write("notes.mcap", "these are not the bytes of a bag");
    let err = read_joint_states(Path::new(&not_mcap), &JointStateOptions::default()).unwrap_err();
    assert!(matches!(err, BagError::Mcap { .. }), "{err}");
    let err = read_joint_states(
        Path::new(&scratch.path("absent.mcap")),
        &JointStateOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(err, BagError::Io { .. }), "{err}");
}

#[test]
fn malformed_messages_name_the_message_and_the_problem() {
    let scratch = Scratch::new("bag-messages");
    let cdr = Wire::Cdr { little: true };
    let good = State {
        stamp: (0, 0),
        names: &["a", "b"],
        position: &[1.0, 2.0],
        velocity: &[],
        effort: &[],
    };
    let short = State {
        position: &[1.0],
        ..good.clone()
    };
    let twice = State {
        names: &["a", "a"],
        ..good.clone()
    };
    let cut = serialise(&good, cdr)[..30].to_vec();
    let cases: [(Vec<u8>, &str); 4] = [
        (serialise(&short, cdr), "2 names but 1 position values"),
        (serialise(&twice, cdr), "joint \"a\" is named twice"),
        (cut, "is longer than the 30-byte message"),
        (vec![0, 3, 0, 0, 1, 2], "is not plain CDR"),
    ];
    for (bytes, expected) in cases {
        let path = scratch.path("bad.mcap");
        let messages = vec![(0, 5, serialise(&good, cdr)), (0, 77, bytes)];
        write_bag(&path, &[JOINT_STATES], &messages, None);
        let err = read_joint_states(Path::new(&path), &JointStateOptions::default()).unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("message 1 of topic /joint_states (log time 77 ns)")
                && text.contains(expected),
            "{text}"
        );
    }
}

/// `kinechain fk --bag`: one CSV row (or JSON line) per message, headed by its time, with the
/// poses `fk --batch` gives for the same joint values.
#[cfg(feature = "cli")]
#[test]
fn the_command_line_gives_the_poses_of_each_message() {
    use std::process::Command;
    let scratch = Scratch::new("bag-cli");
    let arm = [
        "panda_joint3",
        "panda_joint1",
        "panda_joint2",
        "panda_joint4",
        "panda_joint5",
        "panda_joint7",
        "panda_joint6",
    ];
    let cdr = Wire::Cdr { little: true };
    let mut messages = Vec::new();
    let mut expected_q = Vec::new();
    // The arm before the gripper has a value: skipped.
    let mut q = [0.0; 8];
    for i in 0..20i32 {
        // (Mid-range values of each joint, a few hundredths apart.)
        let middle = [0.0, 0.0, 0.0, -1.5, 0.0, 1.5, 0.0];
        let values: Vec<f64> = (0..7)
            .map(|j| middle[j] + 0.01 * f64::from(i * 7 + j as i32) - 0.5)
            .collect();
        let position: Vec<f64> = arm
            .iter()
            .map(|n| {
                values[n
                    .trim_start_matches("panda_joint")
                    .parse::<usize>()
                    .unwrap()
                    - 1]
            })
            .collect();
        let state = State {
            stamp: (100 + i, 7),
            names: &arm,
            position: &position,
            velocity: &[],
            effort: &[],
        };
        messages.push((0, 1, serialise(&state, cdr)));
        q[..7].copy_from_slice(&values);
        if i == 0 {
            continue;
        }
        if i % 5 == 1 {
            q[7] = 0.001 * f64::from(i);
            let g = State {
                stamp: (100 + i, 8),
                names: &["panda_finger_joint1"],
                position: &[q[7]],
                velocity: &[],
                effort: &[],
            };
            messages.push((0, 2, serialise(&g, cdr)));
            expected_q.push((i64::from(100 + i) * 1_000_000_000 + 7, q));
            expected_q.push((i64::from(100 + i) * 1_000_000_000 + 8, q));
        } else {
            expected_q.push((i64::from(100 + i) * 1_000_000_000 + 7, q));
        }
    }
    // (Message 1 carries the arm before the gripper's first value: skipped too.)
    expected_q.remove(0);
    let bag = scratch.path("panda.mcap");
    write_bag(&bag, &[JOINT_STATES], &messages, None);
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_kinechain"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        (
            String::from_utf8(out.stdout).unwrap(),
            String::from_utf8(out.stderr).unwrap(),
        )
    };
    let (csv, warnings) = run(&[
        "fk",
        "robots/panda.urdf",
        "--bag",
        &bag,
        "--link",
        "panda_hand",
        "--format",
        "csv",
        "--orientation",
        "quat",
    ]);
    assert!(
        warnings.contains("2 message(s) of /joint_states before every joint"),
        "{warnings}"
    );
    let batch: String = expected_q
        .iter()
        .map(|(_, q)| {
            let row: Vec<String> = q.iter().map(|x| format!("{x:?}")).collect();
            row.join(",") + "\n"
        })
        .collect();
    let batch_file = scratch.write("q.csv", batch);
    let (expected, _) = run(&[
        "fk",
        "robots/panda.urdf",
        "--batch",
        &batch_file,
        "--link",
        "panda_hand",
        "--format",
        "csv",
        "--orientation",
        "quat",
    ]);
    let rows: Vec<&str> = csv.lines().collect();
    let expected_rows: Vec<&str> = expected.lines().collect();
    assert_eq!(rows[0], expected_rows[0].replacen("line", "time", 1));
    assert_eq!(rows.len(), expected_q.len() + 1);
    for (k, (time, _)) in expected_q.iter().enumerate() {
        let (t, poses) = rows[k + 1].split_once(',').unwrap();
        assert_eq!(t, time.to_string());
        let (_, expected_poses) = expected_rows[k + 1].split_once(',').unwrap();
        assert_eq!(poses, expected_poses);
    }
    let (jsonl, _) = run(&[
        "fk",
        "robots/panda.urdf",
        "--bag",
        &bag,
        "--format",
        "jsonl",
    ]);
    let first: serde_json::Value = serde_json::from_str(jsonl.lines().next().unwrap()).unwrap();
    assert_eq!(first["time"], expected_q[0].0);
    assert!(first["links"]["panda_hand"].is_object());

    // A message out of limits: an error naming it, or under --keep-going its row.
    let mut wild = messages.clone();
    let beyond = State {
        stamp: (500, 0),
        names: &["panda_joint4"],
        position: &[1.0],
        velocity: &[],
        effort: &[],
    };
    wild.push((0, 3, serialise(&beyond, cdr)));
    let wild_bag = scratch.path("wild.mcap");
    write_bag(&wild_bag, &[JOINT_STATES], &wild, None);
    let args = [
        "fk",
        "robots/panda.urdf",
        "--bag",
        &wild_bag,
        "--link",
        "panda_hand",
        "--format",
        "csv",
    ];
    let out = Command::new(env!("CARGO_BIN_EXE_kinechain"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stderr);
    let index = wild.len() - 1;
    assert!(
        !out.status.success()
            && text.contains(&format!("message {index} (time 500000000000 ns)"))
            && text.contains("panda_joint4"),
        "{text}"
    );
    let out = Command::new(env!("CARGO_BIN_EXE_kinechain"))
        .args(args.iter().copied().chain(["--keep-going"]))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && text.contains("1 message(s) failed"),
        "{text}"
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    let last = stdout.lines().last().unwrap();
    assert!(
        last.starts_with("500000000000,,,,") && last.contains("panda_joint4"),
        "{last}"
    );
    assert_eq!(stdout.lines().count(), expected_q.len() + 2);

    // Joints of the chain that no message names, and a missing topic.
    let out = Command::new(env!("CARGO_BIN_EXE_kinechain"))
        .args(["fk", "robots/ur5.yaml", "--bag", &bag])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && text.contains("topic /joint_states has no values for joints"),
        "{text}"
    );
    let out = Command::new(env!("CARGO_BIN_EXE_kinechain"))
        .args(["fk", "robots/panda.urdf", "--bag", &bag, "--topic", "/arm"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && text.contains("no topic /arm"),
        "{text}"
    );
}
