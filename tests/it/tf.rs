//! TF out (`kinechain::io::tf`, `kinechain fk --bag --tf`): the file read back with the `mcap`
//! crate's reader and the CDR decoded here by hand; the transforms composed from the root give
//! the chain's world poses. (The Python tests read the same files with two ROS readers.)

use crate::bag::{JOINT_STATES, State, Wire, serialise, write_bag};
use crate::common::{Scratch, repo_chain};
use kinechain::io::tf::{TfError, TfOptions, write_tf};
use kinechain::{Chain, Data, Transform, forward_kinematics};
use std::collections::HashMap;

/// Reads CDR (little endian) from after the 4-byte encapsulation header.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn align(&mut self, n: usize) {
        while !(self.at - 4).is_multiple_of(n) {
            self.at += 1;
        }
    }
    fn u32(&mut self) -> u32 {
        self.align(4);
        self.at += 4;
        u32::from_le_bytes(self.bytes[self.at - 4..self.at].try_into().unwrap())
    }
    fn f64(&mut self) -> f64 {
        self.align(8);
        self.at += 8;
        f64::from_le_bytes(self.bytes[self.at - 8..self.at].try_into().unwrap())
    }
    fn string(&mut self) -> String {
        let n = self.u32() as usize;
        self.at += n;
        assert_eq!(self.bytes[self.at - 1], 0, "strings end in NUL");
        String::from_utf8(self.bytes[self.at - n..self.at - 1].to_vec()).unwrap()
    }
}

/// One decoded `TransformStamped`: stamp (ns), parent, child, transform.
type Stamped = (i64, String, String, Transform);

fn decode(bytes: &[u8]) -> Vec<Stamped> {
    assert_eq!(&bytes[..4], &[0, 1, 0, 0], "CDR, little endian");
    let mut r = Reader { bytes, at: 4 };
    let n = r.u32();
    let out = (0..n)
        .map(|_| {
            let sec = i64::from(r.u32().cast_signed());
            let ns = i64::from(r.u32());
            let parent = r.string();
            let child = r.string();
            let p = [r.f64(), r.f64(), r.f64()];
            let [x, y, z, w] = [r.f64(), r.f64(), r.f64(), r.f64()];
            let norm = x * x + y * y + z * z + w * w;
            assert!((norm - 1.0).abs() < 1e-15, "|q|² = {norm}");
            // Rows of the rotation of the unit quaternion, and the translation.
            let rows = [
                [
                    1.0 - 2.0 * (y * y + z * z),
                    2.0 * (x * y - z * w),
                    2.0 * (x * z + y * w),
                    p[0],
                ],
                [
                    2.0 * (x * y + z * w),
                    1.0 - 2.0 * (x * x + z * z),
                    2.0 * (y * z - x * w),
                    p[1],
                ],
                [
                    2.0 * (x * z - y * w),
                    2.0 * (y * z + x * w),
                    1.0 - 2.0 * (x * x + y * y),
                    p[2],
                ],
            ];
            (
                sec * 1_000_000_000 + ns,
                parent,
                child,
                Transform::from_rows(&rows),
            )
        })
        .collect();
    assert_eq!(r.at, bytes.len(), "nothing after the message");
    out
}

/// A topic's messages (log time, bytes), its schema ("name encoding") and its channel metadata.
type Topic = (
    Vec<(u64, Vec<u8>)>,
    String,
    std::collections::BTreeMap<String, String>,
);

/// The file's messages by topic, with the channels' metadata.
fn topics(path: &str) -> HashMap<String, Topic> {
    let bytes = std::fs::read(path).unwrap();
    let mut out: HashMap<String, Topic> = HashMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().unwrap();
        let entry = out.entry(m.channel.topic.clone()).or_insert_with(|| {
            (
                Vec::new(),
                format!("{} {}", schema.name, schema.encoding),
                m.channel.metadata.clone(),
            )
        });
        entry.0.push((m.log_time, m.data.to_vec()));
    }
    out
}

/// The largest gap between the world poses composed from `statics` and one `/tf` message and
/// the chain's, at `q`.
fn gap(chain: &Chain, statics: &[Stamped], message: &[Stamped], q: &[f64], prefix: &str) -> f64 {
    let edges: HashMap<String, (String, Transform)> = statics
        .iter()
        .chain(message)
        .map(|(_, parent, child, t)| (child.clone(), (parent.clone(), *t)))
        .collect();
    let world = |frame: &str| {
        let (mut t, mut frame) = (Transform::IDENTITY, frame.to_string());
        while let Some((parent, x)) = edges.get(&frame) {
            t = *x * t;
            frame.clone_from(parent);
        }
        t
    };
    let mut data = Data::new(chain);
    let poses = forward_kinematics(chain, &mut data, q).unwrap();
    let mut worst = 0.0f64;
    for link in chain.links() {
        let a = poses.world_from_link(chain.link_id(link.name()).unwrap());
        let b = world(&format!("{prefix}{}", link.name()));
        worst = worst.max((a.to_homogeneous() - b.to_homogeneous()).amax());
    }
    worst
}

#[test]
fn rows_become_tf_messages_that_compose_to_the_world_poses() {
    let scratch = Scratch::new("tf-rows");
    let chain = repo_chain("robots/g1.urdf+floating");
    let n = 25;
    let q = chain.random_configurations(n, 3, (-1.0, 1.0));
    let time: Vec<i64> = (0..n as i64)
        .map(|i| 1_700_000_000_123_456_789 + i * 10_000_000)
        .collect();
    let out = scratch.path("g1.mcap");
    let options = TfOptions {
        frame_prefix: "g1/".into(),
        world_frame: "odom".into(),
        description: None,
    };
    let summary = write_tf(&chain, &time, &q, out.as_ref(), &[], &options).unwrap();
    let fixed = chain
        .joints()
        .iter()
        .filter(|j| j.kind() == kinechain::JointKind::Fixed)
        .count();
    assert_eq!(
        (summary.messages, summary.moving, summary.fixed),
        (n, chain.joints().len() - fixed, fixed)
    );
    let t = topics(&out);
    assert_eq!(t["/tf"].1, "tf2_msgs/msg/TFMessage ros2msg");
    assert_eq!(t["/robot_description"].1, "std_msgs/msg/String ros2msg");
    assert!(t["/tf_static"].2["offered_qos_profiles"].contains("durability: 1"));
    assert!(t["/tf"].2["offered_qos_profiles"].contains("durability: 2"));
    let statics = decode(&t["/tf_static"].0[0].1);
    assert_eq!(statics.len(), fixed);
    let messages = &t["/tf"].0;
    assert_eq!(messages.len(), n);
    let mut worst = 0.0f64;
    for (i, (log_time, bytes)) in messages.iter().enumerate() {
        assert_eq!(*log_time, time[i].cast_unsigned());
        let m = decode(bytes);
        assert!(m.iter().all(|s| s.0 == time[i] && s.2.starts_with("g1/")));
        assert_eq!(
            m.iter().filter(|s| s.1 == "odom").count(),
            1,
            "the floating base in odom"
        );
        worst = worst.max(gap(
            &chain,
            &statics,
            &m,
            &q[i * chain.nq()..(i + 1) * chain.nq()],
            "g1/",
        ));
    }
    // Positions within a metre of the origin and 1.3 m of reach: a few ulps of a metre.
    assert!(worst <= 2e-15, "{worst}");
    // The URDF beside the transforms loads as the same tree.
    let text = {
        let bytes = &t["/robot_description"].0[0].1;
        let n = u32::from_le_bytes(bytes[4..8].try_into().unwrap()) as usize;
        String::from_utf8(bytes[8..8 + n - 1].to_vec()).unwrap()
    };
    let again = Chain::from_urdf_str(&text).unwrap();
    for link in again.links() {
        assert!(chain.link_id(link.name()).is_ok(), "{}", link.name());
    }
    assert!(again.links().len() + 1 >= chain.links().len());
}

#[test]
fn what_cannot_be_written_is_an_error_naming_it() {
    let scratch = Scratch::new("tf-errors");
    let chain = repo_chain("robots/ur5.yaml");
    let out = scratch.path("ur5.mcap");
    let opts = TfOptions::default();
    let q = vec![0.0; 6];
    assert!(matches!(
        write_tf(&chain, &[1, 2], &q, out.as_ref(), &[], &opts),
        Err(TfError::Length {
            rows: 2,
            entries: 6,
            nq: 6
        })
    ));
    assert!(matches!(
        write_tf(&chain, &[-1], &q, out.as_ref(), &[], &opts),
        Err(TfError::Time { row: 0, time: -1 })
    ));
    let mut bad = q.clone();
    bad[2] = f64::NAN;
    let e = write_tf(&chain, &[1], &bad, out.as_ref(), &[], &opts).unwrap_err();
    assert!(
        matches!(
            e,
            TfError::Row {
                row: 0,
                time: 1,
                ..
            }
        ),
        "{e}"
    );
    // Never over an input.
    std::fs::write(&out, b"input").unwrap();
    let e = write_tf(&chain, &[1], &q, out.as_ref(), &[out.as_ref()], &opts).unwrap_err();
    assert!(matches!(e, TfError::Output(_)), "{e}");
    assert_eq!(std::fs::read(&out).unwrap(), b"input");
}

/// `kinechain fk ROBOT --bag IN --tf OUT`: one `/tf` message per message whose joints are all
/// known, stamped with its header, and the output never one of the inputs.
#[cfg(feature = "cli")]
#[test]
fn the_command_line_writes_the_tf_of_a_bag() {
    use std::process::Command;
    let scratch = Scratch::new("tf-cli");
    let names = [
        "shoulder_pan",
        "shoulder_lift",
        "elbow",
        "wrist_1",
        "wrist_2",
        "wrist_3",
    ];
    let cdr = Wire::Cdr { little: true };
    let messages: Vec<(usize, u64, Vec<u8>)> = (0..10u32)
        .map(|i| {
            let position: Vec<f64> = (0..6)
                .map(|j| 0.1 * f64::from(i) - 0.05 * f64::from(j))
                .collect();
            // The first message carries half the joints: skipped.
            let k = if i == 0 { 3 } else { 6 };
            let state = State {
                stamp: (50 + i.cast_signed(), 1000 * i),
                names: &names[..k],
                position: &position[..k],
                velocity: &[],
                effort: &[],
            };
            (0, u64::from(i), serialise(&state, cdr))
        })
        .collect();
    let bag = scratch.path("ur5.mcap");
    write_bag(&bag, &[JOINT_STATES], &messages, None);
    let out = scratch.path("tf.mcap");
    let run = |tf: &str| {
        Command::new(env!("CARGO_BIN_EXE_kinechain"))
            .args(["fk", "robots/ur5.yaml", "--bag", &bag, "--tf", tf])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    };
    let done = run(&out);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    assert!(done.stdout.is_empty());
    let said = String::from_utf8_lossy(&done.stderr);
    assert!(
        said.contains("9 /tf message(s) of 6 transform(s)") && said.contains("1 message(s) before"),
        "{said}"
    );
    let t = topics(&out);
    let stamps: Vec<i64> = t["/tf"].0.iter().map(|(_, b)| decode(b)[0].0).collect();
    let expected: Vec<i64> = (1..10)
        .map(|i| (50 + i) * 1_000_000_000 + 1000 * i)
        .collect();
    assert_eq!(stamps, expected);
    // Over the bag: refused, the bag unchanged.
    let before = std::fs::read(&bag).unwrap();
    let refused = run(&bag);
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("ur5.mcap"));
    assert_eq!(std::fs::read(&bag).unwrap(), before);
}
