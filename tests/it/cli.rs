//! The `kinechain` command line, through the built binary.

use crate::common::Scratch;
use serde_json::Value;
use std::process::{Command, Output};

/// The built binary with `args`, run from the repository (where `robots/` is).
fn command<'a>(args: impl IntoIterator<Item = &'a str>) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_kinechain"));
    command.args(args).current_dir(env!("CARGO_MANIFEST_DIR"));
    command
}

fn kinechain(args: &[&str]) -> Output {
    command(args.iter().copied()).output().unwrap()
}

/// Two slides along z without limits (link2 at z = q1 + q2), for results that overflow.
const TWO_SLIDES: &str = "name: slides\nconvention: standard\njoints:\n\
    - {name: j1, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0}\n\
    - {name: j2, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0}\n";

fn ok_json(args: &[&str]) -> Vec<Value> {
    let out = kinechain(args);
    assert!(
        out.status.success(),
        "{args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    json_lines(out.stdout)
}

/// Each line of a command's output, parsed as JSON.
fn json_lines(stdout: Vec<u8>) -> Vec<Value> {
    String::from_utf8(stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// Runs a command that must fail; returns its one-line stderr.
fn error(args: &[&str]) -> String {
    let out = kinechain(args);
    assert!(!out.status.success(), "{args:?} succeeded");
    let stderr = String::from_utf8(out.stderr).unwrap();
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "{args:?}: stderr is not one line: {stderr}");
    assert!(lines[0].starts_with("error: "), "{args:?}: {stderr}");
    lines[0].to_string()
}

/// Standard output of a command that must succeed.
fn ok_text(args: &[&str]) -> String {
    let out = kinechain(args);
    assert!(
        out.status.success(),
        "{args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// A command that succeeded without writing anything to stderr (not even a warning).
fn assert_quiet_success(out: &Output) {
    assert!(out.status.success(), "{out:?}");
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn position(result: &Value, link: &str) -> [f64; 3] {
    let pose = &result["links"][link]["pose"];
    [0, 1, 2].map(|i| pose[i][3].as_f64().unwrap())
}

/// The entries of a JSON array of numbers.
fn numbers(array: &Value) -> Vec<f64> {
    let entries = array.as_array().expect("a JSON array");
    entries
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

#[test]
fn info_lists_joints_in_q_order_and_links() {
    let v = &ok_json(&["info", "robots/panda.urdf"])[0];
    assert_eq!(v["name"], "panda");
    assert_eq!(v["dof"], 8);
    let joints = v["joints"].as_array().unwrap();
    assert_eq!(joints.len(), 8);
    assert_eq!(joints[0]["name"], "panda_joint1");
    assert_eq!(joints[0]["type"], "revolute");
    assert_eq!(joints[0]["dof"], 1);
    assert_eq!(joints[3]["limits"], serde_json::json!([-3.0718, -0.0698]));
    assert_eq!(joints[7]["name"], "panda_finger_joint1");
    let passive = v["passive_joints"].as_array().unwrap();
    assert!(passive.iter().any(
        |j| j["name"] == "panda_finger_joint2" && j["mimic"]["joint"] == "panda_finger_joint1"
    ));
    let links = v["links"].as_array().unwrap();
    assert_eq!(links.len(), 13);
    assert_eq!(links[0], "panda_link0");

    let cyl = &ok_json(&["info", "robots/cylindrical.yaml"])[0];
    assert_eq!(cyl["dof"], 2);
    assert_eq!(cyl["joints"][0]["type"], "cylindrical");
    assert_eq!(cyl["joints"][0]["dof"], 2);
    assert_eq!(
        cyl["joints"][0]["limits"]["d"],
        serde_json::json!([-5.0, 5.0])
    );

    let out = kinechain(&["info", "robots/puma560.yaml", "--format", "table"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("puma560: 6 degrees of freedom"), "{text}");
    // Limits as intervals, `none` where a joint has none (not JSON's `null`).
    let text = ok_text(&["info", "robots/cylindrical.yaml", "--format", "table"]);
    let row = text.lines().find(|l| l.contains(" cylindrical ")).unwrap();
    assert!(
        row.ends_with("theta [-3.141592653589793, 3.141592653589793], d [-5, 5]"),
        "{text}"
    );
    let text = ok_text(&["info", "robots/stanford.yaml", "--format", "table"]);
    assert!(text.contains(" [0.3048, 1.27]\n"), "{text}");
    let continuous = "tests/data/reference/urdf/double_pendulum_continuous.urdf";
    let text = ok_text(&["info", continuous, "--format", "table"]);
    assert!(
        text.lines()
            .filter(|l| l.ends_with(" continuous   none"))
            .count()
            == 2
            && !text.contains("null"),
        "{text}"
    );
}

#[test]
fn fk_with_array_and_object_q_agree() {
    let q = "[0.1, -0.4, 0.3, 0.2, 0.5, -0.6]";
    let object = r#"{"j1": 0.1, "j2": -0.4, "j3": 0.3, "j4": 0.2, "j5": 0.5, "j6": -0.6}"#;
    let a = &ok_json(&["fk", "robots/puma560.yaml", "--q", q])[0];
    let b = &ok_json(&["fk", "robots/puma560.yaml", "--q", object])[0];
    let c = &ok_json(&[
        "fk",
        "robots/puma560.yaml",
        "--q",
        "0.1,-0.4,0.3,0.2,0.5,-0.6",
    ])[0];
    assert_eq!(a, b);
    assert_eq!(a, c);
    let links = a["links"].as_object().unwrap();
    assert_eq!(links.len(), 8, "link0..link6 and tool");
    assert!(links.keys().eq([
        "link0", "link1", "link2", "link3", "link4", "link5", "link6", "tool"
    ]));
    let pose = links["tool"]["pose"].as_array().unwrap();
    assert_eq!(pose[3], serde_json::json!([0.0, 0.0, 0.0, 1.0]));
    // No rates unless asked for.
    assert!(links["tool"].get("omega").is_none());
}

#[test]
fn fk_output_round_trips_and_matches_the_library() {
    use kinechain::{Chain, Data, forward_kinematics};
    let chain = Chain::from_file("robots/panda_mdh.yaml").unwrap();
    let q = [0.3, -0.2, 0.1, -1.9, 0.4, 1.6, -0.7];
    let arg = serde_json::to_string(&q).unwrap();
    let v = &ok_json(&["fk", "robots/panda_mdh.yaml", "--q", &arg])[0];
    let mut data = Data::new(&chain);
    let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
    for link in chain.links() {
        let want = poses
            .world_from_link(chain.link_id(link.name()).unwrap())
            .to_rows();
        let got = &v["links"][link.name()]["pose"];
        for i in 0..4 {
            for j in 0..4 {
                // Bit for bit: the JSON numbers round-trip.
                assert_eq!(got[i][j].as_f64().unwrap().to_bits(), want[i][j].to_bits());
            }
        }
    }
}

#[test]
fn fk_link_prints_only_the_named_links() {
    let q = "[0.1, -0.4, 0.3, 0.2, 0.5, -0.6]";
    let all = &ok_json(&["fk", "robots/puma560.yaml", "--q", q])[0];
    let some = &ok_json(&[
        "fk",
        "robots/puma560.yaml",
        "--q",
        q,
        "--link",
        "tool",
        "--link",
        "link2",
    ])[0];
    let links = some["links"].as_object().unwrap();
    assert!(links.keys().eq(["tool", "link2"]));
    assert_eq!(links["tool"], all["links"]["tool"]);
    assert_eq!(links["link2"], all["links"]["link2"]);
}

#[test]
fn fk_batch_writes_one_line_per_configuration() {
    let dir = Scratch::new("cli-files");
    let batch = dir.write(
        "batch.jsonl",
        r#"{"q": [0, 0, 0]}

{"q": {"j1": 1.5707963267948966, "j2": 0, "j3": 0}}
{"q": [0, 0, 0], "qd": [1, 0, 0]}
"#,
    );
    let lines = ok_json(&["fk", "robots/planar3.yaml", "--batch", &batch]);
    assert_eq!(lines.len(), 3, "the blank line is skipped");
    assert_eq!(position(&lines[0], "link3"), [9.0, 0.0, 0.0]);
    let p = position(&lines[1], "link3");
    assert!(p[0].abs() < 1e-15 && (p[1] - 9.0).abs() < 1e-15);
    // ω = (0,0,1) at every link; the tip moves at 9 m/s along y.
    assert_eq!(
        lines[2]["links"]["link3"]["omega"],
        serde_json::json!([0.0, 0.0, 1.0])
    );
    assert_eq!(
        lines[2]["links"]["link3"]["v"],
        serde_json::json!([0.0, 9.0, 0.0])
    );

    // A bad line: earlier results are written, the error names the line.
    dir.write(
        "batch.jsonl",
        "{\"q\": [0, 0, 0]}\n{\"q\": [0, 0]}\n{\"q\": [0, 0, 0]}\n",
    );
    let out = kinechain(&["fk", "robots/planar3.yaml", "--batch", &batch]);
    assert!(!out.status.success());
    assert_eq!(String::from_utf8(out.stdout).unwrap().lines().count(), 1);
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.starts_with("error: "), "{stderr}");
    assert!(stderr.contains("line 2"), "{stderr}");
    assert!(stderr.contains("2 values given"), "{stderr}");

    // Lines of joint values alone (a CSV file, an array): the same output as the objects.
    let objects = dir.write(
        "objects.jsonl",
        "{\"q\": [0.25, -0.5, 1]}\n{\"q\": [0.125, 0, -1]}\n{\"q\": [1, 2, 0.5]}\n",
    );
    // (With the byte order mark that spreadsheet programs write first.)
    let rows = dir.write(
        "rows.csv",
        "\u{feff}0.25,-0.5,1\r\n0.125 0 -1\n[1, 2, 0.5]\n",
    );
    let from_objects = kinechain(&["fk", "robots/planar3.yaml", "--batch", &objects]);
    let from_rows = kinechain(&["fk", "robots/planar3.yaml", "--batch", &rows]);
    assert!(from_rows.status.success());
    assert_eq!(from_rows.stdout, from_objects.stdout);
    assert_eq!(
        String::from_utf8(from_rows.stdout.clone())
            .unwrap()
            .lines()
            .count(),
        3
    );
    let objects_results = json_lines(from_objects.stdout);
    // A header row of joint names gives the order of the columns of the rows below it (not of
    // arrays or objects, which are in q order).
    dir.write(
        "rows.csv",
        "\n j3, j1 ,j2\n1,0.25,-0.5\n-1 0.125 0\n[1, 2, 0.5]\n",
    );
    let from_rows = kinechain(&["fk", "robots/planar3.yaml", "--batch", &rows]);
    assert!(from_rows.status.success());
    // The same results, each naming its own line (the header and a blank line come first).
    let rows_results = json_lines(from_rows.stdout);
    for (k, (a, b)) in rows_results.iter().zip(&objects_results).enumerate() {
        assert_eq!(a["links"], b["links"]);
        assert_eq!(a["line"], k + 3);
    }
    assert_eq!(rows_results.len(), 3);
    // A header that names what is not a joint stops the run, even with --keep-going: the rows
    // cannot be read in the file's order.
    dir.write("rows.csv", "q1,q2,q3\n0.25,-0.5,1\n");
    for keep_going in [&[][..], &["--keep-going"]] {
        let args = ["fk", "robots/planar3.yaml", "--batch", &rows];
        let out = kinechain(&[&args[..], keep_going].concat());
        assert!(!out.status.success());
        assert!(out.stdout.is_empty());
        let stderr = String::from_utf8(out.stderr).unwrap();
        assert!(
            stderr.contains("rows.csv: line 1: header: no joint named 'q1'"),
            "{stderr}"
        );
    }
}

#[test]
fn failures_are_one_line_errors() {
    let m = error(&["fk", "robots/puma560.yaml", "--q", "[0, 0]"]);
    assert!(
        m.contains("2 values given") && m.contains("6 degrees of freedom"),
        "{m}"
    );

    let m = error(&["fk", "robots/puma560.yaml", "--q", "[90, 0, 0, 0, 0, 0]"]);
    assert!(m.contains("joint 'j1'") && m.contains("limits"), "{m}");
    assert!(m.contains("degrees"), "a hint about degrees: {m}");
    // --ignore-limits evaluates it anyway.
    ok_json(&[
        "fk",
        "robots/puma560.yaml",
        "--q",
        "[90, 0, 0, 0, 0, 0]",
        "--ignore-limits",
    ]);

    let m = error(&["fk", "robots/puma560.yaml", "--q", "[nan, 0, 0, 0, 0, 0]"]);
    assert!(m.contains("not valid JSON"), "{m}");
    let m = error(&["fk", "robots/puma560.yaml", "--q", "NaN,0,0,0,0,0"]);
    assert!(
        m.contains("not a finite number") && m.contains("'j1'"),
        "{m}"
    );

    let m = error(&["fk", "robots/puma560.yaml", "--q", r#"{"j1": 0}"#]);
    assert!(m.contains("no value for joint 'j2'"), "{m}");
    let m = error(&["fk", "robots/puma560.yaml", "--q", r#"{"elbow": 0}"#]);
    assert!(m.contains("no joint named 'elbow'"), "{m}");

    let m = error(&[
        "fk",
        "robots/puma560.yaml",
        "--q",
        "[0,0,0,0,0,0]",
        "--link",
        "hand",
    ]);
    assert!(m.contains("no link named 'hand'"), "{m}");

    let m = error(&[
        "fk",
        "robots/puma560.yaml",
        "--q",
        "[0,0,0,0,0,0]",
        "--qdd",
        "[0,0,0,0,0,0]",
    ]);
    assert!(m.contains("--qdd needs --qd"), "{m}");

    let m = error(&["fk", "robots/nothing.yaml", "--q", "[]"]);
    assert!(
        m.contains("robots/nothing.yaml") && m.contains("cannot read"),
        "{m}"
    );

    let m = error(&["info", "tests/data/bad/yaml/unknown_key.yaml"]);
    assert!(m.contains("alhpa") && m.contains("joint 'j2'"), "{m}");

    // Usage errors: one line too, exit code 2.
    let out = kinechain(&["fk", "robots/puma560.yaml"]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(String::from_utf8(out.stderr).unwrap().lines().count(), 1);
}

#[test]
fn fk_rates_appear_only_when_asked_for() {
    let q = r#"{"joint": [0.5235987755982988, 3]}"#;
    let v = &ok_json(&[
        "fk",
        "robots/cylindrical.yaml",
        "--q",
        q,
        "--qd",
        r#"{"joint": [5, 2]}"#,
    ])[0];
    let p = &v["links"]["P"];
    assert!(p.get("omega").is_some() && p.get("v").is_some());
    assert!(p.get("alpha").is_none() && p.get("a").is_none());
    // Ex. 2.8: velocity of P.
    let vel = numbers(&p["v"]);
    assert_eq!(vel.len(), 3, "{vel:?}");
    for (got, want) in vel.iter().zip([-0.51197, -0.51197, 4.48803]) {
        assert!((got - want).abs() < 5e-6, "{vel:?}");
    }

    let a = &ok_json(&[
        "fk",
        "robots/cylindrical.yaml",
        "--q",
        q,
        "--qd",
        "[5, 2]",
        "--qdd",
        "[0, 0]",
        "--point",
        "arm:0,1,0",
    ])[0];
    let p = &a["links"]["P"];
    assert!(p.get("alpha").is_some() && p.get("a").is_some());
    // The point (0,1,0) of the arm is the tool frame P: same position, velocity, acceleration.
    let point = &a["points"][0];
    assert_eq!(point["link"], "arm");
    for (field, link_field) in [("velocity", "v"), ("acceleration", "a")] {
        let got = numbers(&point[field]);
        let want = numbers(&p[link_field]);
        for k in 0..3 {
            assert!(
                (got[k] - want[k]).abs() < 1e-14,
                "{field}: {got:?} vs {want:?}"
            );
        }
    }
    let m = error(&[
        "fk",
        "robots/cylindrical.yaml",
        "--q",
        q,
        "--point",
        "arm:0,1",
    ]);
    assert!(m.contains("LINK:x,y,z"), "{m}");
    let m = error(&[
        "fk",
        "robots/cylindrical.yaml",
        "--q",
        q,
        "--point",
        "hand:0,1,0",
    ]);
    assert!(m.contains("no link named 'hand'"), "{m}");
}

/// A robot far beyond any real one (a slide between ±10³⁰⁸ m) is measured too: its random
/// configurations are finite, the reach prints in exponent form, and the f32 batch, whose range
/// the reach exceeds, gets no error figure rather than `NaN`.
#[test]
fn bench_measures_a_robot_beyond_the_f32_range() {
    let dir = Scratch::new("cli-bench-far");
    let path = dir.write(
        "far.yaml",
        "name: far\nconvention: standard\njoints:\n  \
         - {name: s1, link: l1, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0, limits: [-1e308, 1e308]}\n  \
         - {name: r1, link: l2, type: revolute, a: 1, alpha: 0, d: 0, theta: 0}\n",
    );
    let text = ok_text(&["bench", &path, "--configurations", "4"]);
    assert!(text.contains("ulp of the 1.000e308 m reach)"), "{text}");
    assert!(
        text.contains("no error for the batch f32: the reach is beyond the range of f32"),
        "{text}"
    );
    assert!(!text.contains("NaN") && !text.contains("inf"), "{text}");
}

#[test]
fn bench_prints_times_ratios_and_errors() {
    let text = ok_text(&["bench", "robots/panda.urdf", "--configurations", "4"]);
    for needle in [
        "kinechain, all links",
        "incremental (panda_finger_joint1 moves)",
        "batch",
        "k 0.32",
        "ulp of the",
        "vs k",
    ] {
        assert!(text.contains(needle), "missing '{needle}' in:\n{text}");
    }
    // The header names the instruction set of the kernels.
    let isa = match kinechain::isa() {
        kinechain::Isa::Avx512 => "avx512",
        kinechain::Isa::Avx2 => "avx2+fma",
        kinechain::Isa::Baseline => "baseline",
    };
    assert!(text.contains(&format!("kernels: {isa}")), "{text}");
    // Where single evaluations split their `sin`/`cos` into 256-bit halves (AVX-512 on Intel), a
    // row times the 512-bit form they avoid, and the header says so; elsewhere neither appears.
    let narrow = kinechain::isa() == kinechain::Isa::Avx512 && kinechain::narrow_trig();
    assert_eq!(
        text.contains("kinechain, all links, sin/cos in one 512-bit register"),
        narrow,
        "{text}"
    );
    assert_eq!(text.contains("sin/cos on 256 bits"), narrow, "{text}");
    // The incremental update against a full evaluation from the same rounds: a positive factor.
    assert!(factor_after(&text, "incremental (panda_finger_joint1 moves): ") > 0.0);
    // The error line reports a small error (under 8 ulp of the reach, and of 1 in rotation),
    // and not none: rounding leaves some error over 4 configurations of 13 links.
    let position = ulps_before(&text, " ulp of the");
    assert!(position > 0.0 && position < 8.0, "{text}");
    let rotation = number_after(&text, "reach), rotation ");
    assert!(rotation > 0.0 && rotation < 8.0 * f64::EPSILON, "{text}");
    // The single-precision batch has its row and its error line, within the 16 f32 ulps of the
    // reach that the reference tests allow.
    assert!(text.contains("kinechain, batch f32, 1 thread"), "{text}");
    let position = ulps_before(&text, " f32 ulp of the reach");
    assert!(position > 0.0 && position < 16.0, "{text}");
    let rotation = ulps_before(&text, " f32 ulp)");
    assert!(rotation > 0.0 && rotation < 16.0, "{text}");
    // The two-thread rows name their batch, large enough for the pool: over twice the threshold
    // on the path of the end link (a finger: seven arm joints and its own).
    let size: usize = text
        .split("batch of ")
        .nth(1)
        .and_then(|s| s.split(',').next())
        .and_then(|s| s.parse().ok())
        .unwrap();
    assert!(
        size * 8 >= 2 * kinechain::eval::batch::PARALLEL_WORK,
        "{text}"
    );
    assert_eq!(size % 4, 0, "whole copies of the 4 configurations: {text}");
    // Each two-thread row stands beside its one-thread row with a time of its own. (How the two
    // compare is a measurement, left to the benchmarks: on this shared 2-core host a thread of
    // the pool can wait milliseconds for a core, which made a bound here fail one run in three.)
    let threads = text
        .lines()
        .find_map(|l| l.strip_prefix(&format!("kinechain, batch of {size}, ")))
        .and_then(|l| l.split(' ').next())
        .unwrap();
    for (one, two) in [
        (
            "kinechain, batch, 1 thread",
            format!("kinechain, batch of {size}, {threads} threads"),
        ),
        (
            "kinechain, batch, end link only, 1 thread",
            format!("kinechain, batch of {size}, end link only, {threads} threads"),
        ),
    ] {
        let (one, two) = (ns_of(&text, one), ns_of(&text, &two));
        assert!(
            one.is_finite() && one > 0.0 && two.is_finite() && two > 0.0,
            "{two} ns against {one} ns on one thread:\n{text}"
        );
    }
    // Another link than the farthest one, and a name the robot does not have.
    let text = ok_text(&[
        "bench",
        "robots/panda.urdf",
        "--configurations",
        "2",
        "--link",
        "panda_hand_tcp",
    ]);
    assert!(text.contains("end link panda_hand_tcp only"), "{text}");
    // The incremental row moves the last joint on the link's path: the arm's seventh joint for
    // the tool, the gripper's for the default end link (a finger, checked above).
    assert!(text.contains("incremental (panda_joint7 moves)"), "{text}");
    let m = error(&["bench", "robots/panda.urdf", "--link", "hand"]);
    assert!(m.contains("no link named 'hand'"), "{m}");
    // One configuration would leave the incremental row timing updates that change nothing.
    let m = error(&["bench", "robots/ur5.yaml", "--configurations", "1"]);
    assert!(m.contains("at least 2"), "{m}");
    // Too many is refused before anything is allocated (it used to abort out of memory).
    let m = error(&[
        "bench",
        "robots/ur5.yaml",
        "--configurations",
        "100000000000",
    ]);
    assert!(m.contains("at most 65536"), "{m}");
    // A DH table: `k` runs on the URDF `convert` writes (a cylindrical joint is two URDF joints).
    for robot in ["robots/ur5.yaml", "robots/cylindrical.yaml"] {
        let text = ok_text(&["bench", robot, "--configurations", "2"]);
        let k_row = text
            .lines()
            .find(|l| l.starts_with("k 0.32, update_transforms, written as URDF"))
            .unwrap_or_else(|| panic!("no k row for {robot}:\n{text}"));
        assert!(k_row.ends_with("1.0x"), "{k_row}");
        let all_links = text
            .lines()
            .find(|l| l.starts_with("kinechain, all links"))
            .unwrap();
        assert!(all_links.ends_with('x'), "no ratio against k: {all_links}");
    }
    let text = ok_text(&[
        "bench",
        "robots/cylindrical.yaml",
        "--level",
        "acc",
        "--configurations",
        "2",
    ]);
    // The rates' cost against poses alone, from the same rounds: a positive factor.
    assert!(factor_after(&text, "poses + velocities + accelerations: ") > 0.0);
    // The rates' errors against the 256-bit evaluation, each within 8 ulps of the largest value
    // of its quantity: ω, v, α and a here, ω and v at `--level vel`.
    for (level, count) in [("acc", 4), ("vel", 2)] {
        let text = ok_text(&[
            "bench",
            "robots/puma560.yaml",
            "--level",
            level,
            "--configurations",
            "2",
        ]);
        let line = text
            .lines()
            .find(|l| l.starts_with("rate errors against the 256-bit evaluation: "))
            .unwrap_or_else(|| panic!("no rate errors at --level {level}:\n{text}"));
        let parts: Vec<&str> = line.split(" ulp of the largest").collect();
        assert_eq!(parts.len(), count + 1, "{line}");
        for part in &parts[..count] {
            let ulps: f64 = part.rsplit('(').next().unwrap().trim().parse().unwrap();
            assert!((0.0..8.0).contains(&ulps), "{line}");
        }
    }
}

/// The number in parentheses just before the first `marker` in `text` (`… (1.05 ulp of the …`).
fn ulps_before(text: &str, marker: &str) -> f64 {
    text.split(marker)
        .next()
        .and_then(|s| s.rsplit('(').next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("no number before '{marker}' in:\n{text}"))
}

/// The time of the row `label` of a `kinechain bench` table, ns per configuration.
fn ns_of(text: &str, label: &str) -> f64 {
    text.lines()
        .find_map(|l| l.strip_prefix(label))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no row '{label}' in:\n{text}"))
}

/// The number that follows `label` in `text`, up to the next space or line end.
fn number_after(text: &str, label: &str) -> f64 {
    text.split(label)
        .nth(1)
        .and_then(|s| s.split([' ', '\n']).next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no number after '{label}' in:\n{text}"))
}

/// The factor `kinechain bench` prints as `{label}{factor}x the time of …`.
fn factor_after(text: &str, label: &str) -> f64 {
    text.split(label)
        .nth(1)
        .and_then(|s| s.split('x').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no factor after '{label}' in:\n{text}"))
}

#[test]
fn batch_keeps_order_across_chunks_and_keep_going_reports_each_bad_line() {
    // 1000 lines: poses in several kernel batches (of up to 256 lines), with rate lines (each
    // ends a run of poses and starts one of velocities) and bad lines inside: one whose
    // evaluation fails (a rate line beyond a limit), one of the wrong length, one that is not
    // JSON. The failures are counted across the batches held and flushed after them.
    let lines: String = (0..1000)
        .map(|i| {
            let line = match i {
                100 | 500 => r#"{"q": [0.1, 0.0, 0.0], "qd": [1, 0, 0]}"#.to_string(),
                200 => r#"{"q": [10.0, 0.0, 0.0], "qd": [1, 0, 0]}"#.to_string(),
                300 => r#"{"q": [0.1, 0.0]}"#.to_string(),
                450 => "not json".to_string(),
                _ => format!(r#"{{"q": [{}, 0.0, 0.0]}}"#, 0.001 * f64::from(i)),
            };
            line + "\n"
        })
        .collect();
    let dir = Scratch::new("cli-batch");
    let batch = dir.write("many.jsonl", lines);
    let arg = batch.as_str();

    // Without --keep-going: the 200 lines before the first bad one are written.
    let out = kinechain(&["fk", "robots/planar3.yaml", "--batch", arg]);
    assert!(!out.status.success());
    assert_eq!(String::from_utf8(out.stdout).unwrap().lines().count(), 200);
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.contains("line 201") && stderr.contains("j1"),
        "{stderr}"
    );

    // With --keep-going: one output line per input line, error objects in place, exit non-zero.
    let out = kinechain(&["fk", "robots/planar3.yaml", "--batch", arg, "--keep-going"]);
    assert!(!out.status.success());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.starts_with("error: ") && stderr.contains("3 line(s) failed"),
        "{stderr}"
    );
    let lines: Vec<Value> = json_lines(out.stdout);
    assert_eq!(lines.len(), 1000);
    for (i, v) in lines.iter().enumerate() {
        match i {
            200 | 300 | 450 => {
                assert_eq!(v["line"], i + 1);
                assert!(v["error"].as_str().unwrap().len() > 5);
            }
            100 | 500 => assert!(v["links"]["link3"].get("omega").is_some()),
            _ => {
                // The tip of the planar arm at q1 = 0.001 i: (9 cos, 9 sin).
                let x = position(v, "link3")[0];
                assert!(
                    (x - 9.0 * (0.001 * i as f64).cos()).abs() < 1e-14,
                    "line {i}"
                );
            }
        }
    }

    // In a table, each failed line is a line of text in its place: after the tables of the
    // lines before it, before those of the lines after it.
    let args = ["fk", "robots/planar3.yaml", "--batch", arg, "--keep-going"];
    let out = kinechain(&[&args[..], &["--format", "table"]].concat());
    assert!(!out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let mut tables = 0;
    let mut failed = Vec::new();
    let mut headed = Vec::new();
    for line in text.lines() {
        if line.starts_with("link ") {
            tables += 1;
        } else if let Some(rest) = line.strip_prefix("line ") {
            if let Some(number) = rest.strip_suffix(':') {
                // Each table is headed by its line's number.
                headed.push(number.parse::<usize>().unwrap());
                continue;
            }
            let (number, error) = rest.split_once(": error: ").unwrap();
            assert!(error.len() > 5, "{line}");
            failed.push((number.parse::<usize>().unwrap(), tables));
        }
    }
    assert_eq!(tables, 997);
    let expected: Vec<usize> = (1..=1000)
        .filter(|l| ![201, 301, 451].contains(l))
        .collect();
    assert_eq!(headed, expected);
    assert_eq!(failed, [(201, 200), (301, 299), (451, 448)]);
}

/// Batch lines are read with a cap on their length (1 MiB plus 1 KiB per degree of freedom): a
/// longer line is an error naming it, skipped to its end, and the lines after it are read as
/// usual. Also `\r\n` endings, a line that is not UTF-8, and a last line without an end.
#[test]
fn batch_lines_have_a_length_cap() {
    let dir = Scratch::new("cli-batch-cap");
    let mut bytes = b"{\"q\": [0.1, 0, 0]}\r\n{\"q\": [0.2, 0, 0]".to_vec();
    // Valid JSON, but 2 MiB long.
    bytes.extend(std::iter::repeat_n(b' ', 2 << 20));
    bytes.extend_from_slice(
        b"}\n{\"q\": [0.3, 0, 0]}\n{\"q\": [0.4, \xff, 0]}\n{\"q\": [0.5, 0, 0]}",
    );
    let batch = dir.write("odd.jsonl", bytes);
    let arg = batch.as_str();

    let out = kinechain(&["fk", "robots/planar3.yaml", "--batch", arg]);
    assert!(!out.status.success());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.contains("odd.jsonl: line 2: the line is longer than 1051648 bytes"),
        "{stderr}"
    );
    assert_eq!(String::from_utf8(out.stdout).unwrap().lines().count(), 1);

    let out = kinechain(&["fk", "robots/planar3.yaml", "--batch", arg, "--keep-going"]);
    assert!(!out.status.success());
    let lines = json_lines(out.stdout);
    assert_eq!(lines.len(), 5);
    for (i, v) in lines.iter().enumerate() {
        match i {
            1 => assert!(v["error"].as_str().unwrap().contains("longer than"), "{v}"),
            3 => assert_eq!(v["error"], "byte 13 of the line is not UTF-8 text"),
            _ => {
                let q1 = 0.1 * (i + 1) as f64;
                let x = position(v, "link3")[0];
                assert!((x - 9.0 * q1.cos()).abs() < 1e-14, "line {}: {v}", i + 1);
            }
        }
    }
}

/// A command run with `input` written to its standard input (from another thread, so that a
/// large output cannot block the writing).
fn kinechain_with_input(args: &[&str], input: Vec<u8>) -> Output {
    use std::process::Stdio;
    let mut child = command(args.iter().copied())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || std::io::Write::write_all(&mut stdin, &input));
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap().unwrap();
    out
}

/// `--batch -` reads standard input: the same lines of output as from a file (lines of poses in
/// batches, lines with rates, a bad line under `--keep-going`), errors that name standard input,
/// and each result written before the next line is waited for, so that a program can send a
/// line and wait for its answer.
#[test]
fn batch_reads_standard_input() {
    let lines: String = (0..700)
        .map(|i| match i {
            300 => "{\"q\": [0.1, 0, 0], \"qd\": [1, 0, 0]}\n".to_string(),
            500 => "{\"q\": [0.1, 0]}\n".to_string(),
            _ => format!("{{\"q\": [{}, 0.2, 0]}}\n", 0.001 * f64::from(i)),
        })
        .collect();
    let dir = Scratch::new("cli-stdin");
    let file = dir.write("lines.jsonl", &lines);
    let args = ["fk", "robots/planar3.yaml", "--keep-going", "--batch"];
    let from_file = kinechain(&[&args[..], &[file.as_str()]].concat());
    let from_stdin = kinechain_with_input(&[&args[..], &["-"]].concat(), lines.into_bytes());
    assert!(!from_stdin.status.success());
    assert_eq!(json_lines(from_stdin.stdout.clone()).len(), 700);
    assert_eq!(from_stdin.stdout, from_file.stdout);
    let stderr = String::from_utf8(from_stdin.stderr).unwrap();
    assert_eq!(
        stderr,
        "error: standard input: 1 line(s) failed (their errors are in the output, each in its line's place)\n"
    );
    let out = kinechain_with_input(
        &["fk", "robots/planar3.yaml", "--batch", "-"],
        b"{\"q\": [0, 0, 0]}\n{\"q\": [0, 0]}\n".to_vec(),
    );
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.starts_with("error: standard input: line 2: q: 2 values given"),
        "{stderr}"
    );
    assert_eq!(json_lines(out.stdout).len(), 1);

    // One line at a time, each answered before the next is sent: lines of poses (which the
    // batch kernel holds), one whose pose overflows (found when the lines held are written) and
    // a line with rates (evaluated alone).
    let robot = dir.write("slides.yaml", TWO_SLIDES);
    use std::io::{BufRead, BufReader, Write};
    let mut child = command(["fk", &robot, "--batch", "-", "--keep-going"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let (answers, answered) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        let mut line = String::new();
        while stdout.read_line(&mut line).unwrap() > 0 {
            answers.send(std::mem::take(&mut line)).unwrap();
        }
    });
    for (line, q, rates) in [
        (1, "[1, 2]", None),
        (2, "[1e308, 1e308]", None),
        (3, "[3, 4]", Some("[1, 1]")),
        (4, "[0.5, 0.25]", None),
    ] {
        let qd = rates.map_or(String::new(), |qd| format!(", \"qd\": {qd}"));
        writeln!(stdin, "{{\"q\": {q}{qd}}}").unwrap();
        stdin.flush().unwrap();
        // (A result held until more input came would never come: the timeout fails the test.)
        let answer = answered
            .recv_timeout(std::time::Duration::from_secs(30))
            .unwrap_or_else(|_| panic!("no answer to line {line}"));
        let v: Value = serde_json::from_str(&answer).unwrap();
        match line {
            2 => assert_eq!(v["line"], 2, "{v}"),
            _ => {
                let q: Vec<f64> = serde_json::from_str(q).unwrap();
                assert_eq!(position(&v, "link2")[2], q[0] + q[1], "{v}");
                assert_eq!(v["links"]["link2"].get("v").is_some(), rates.is_some());
            }
        }
    }
    drop(stdin);
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success());
    assert_eq!(
        String::from_utf8(out.stderr).unwrap(),
        "error: standard input: 1 line(s) failed (their errors are in the output, each in its line's place)\n"
    );
    reader.join().unwrap();
}

/// A chain without moving joints: `--batch` writes one result per line (the lines go one by one,
/// not through the batch kernel, which cannot count empty configurations), and `bench` says
/// there is nothing to time.
#[test]
fn a_chain_without_moving_joints_in_batch_and_bench() {
    let dir = Scratch::new("cli-fixed");
    let robot = dir.write("fixed.urdf", crate::common::FIXED_ONLY_URDF);
    let batch = dir.write("three.jsonl", "{\"q\": []}\n\n{\"q\": []}\n{\"q\": []}\n");
    let lines = ok_json(&["fk", &robot, "--batch", &batch]);
    assert_eq!(lines.len(), 3);
    for v in &lines {
        assert_eq!(position(v, "tool"), [0.0, 0.0, 1.0]);
    }
    let m = error(&["bench", &robot]);
    assert!(m.contains("no moving joints"), "{m}");
}

/// In a table, each point is a line with its position, and its velocity and acceleration when
/// the rates are given: the values of the JSON output.
#[test]
fn points_print_in_a_table() {
    let base = ["fk", "robots/planar3.yaml", "--q", "[0.3, 0.2, 0.1]"];
    let points = ["--point", "link3:0.5,0.2,1", "--point", "link1:0,1,0"];
    for rates in [
        &[][..],
        &["--qd", "[1, 0, 0]"],
        &["--qd", "[1, 0, 0]", "--qdd", "[0, 1, 0]"],
    ] {
        let args = [&base[..], rates, &points].concat();
        let json = &ok_json(&args)[0]["points"];
        let table = ok_text(&[&args[..], &["--format", "table"]].concat());
        let lines: Vec<&str> = table.lines().filter(|l| l.starts_with("point ")).collect();
        assert_eq!(lines.len(), 2, "{table}");
        for (line, want) in lines.iter().zip(json.as_array().unwrap()) {
            let link = want["link"].as_str().unwrap();
            assert!(line.starts_with(&format!("point {link} (")), "{line}");
            let fields = ["position", "velocity", "acceleration"];
            let shown: Vec<&str> = fields
                .into_iter()
                .filter(|f| want.get(*f).is_some())
                .collect();
            assert_eq!(shown.len(), 1 + rates.len() / 2, "{line}");
            for field in fields {
                let Some(at) = line.find(&format!("{field} (")) else {
                    assert!(!shown.contains(&field), "{field} missing: {line}");
                    continue;
                };
                let text = &line[at + field.len() + 2..];
                let values: Vec<f64> = text[..text.find(')').unwrap()]
                    .split(", ")
                    .map(|x| x.parse().unwrap())
                    .collect();
                let want = crate::common::vec3(&want[field]);
                assert_eq!(values.len(), 3, "{line}");
                for (v, w) in values.iter().zip(&want) {
                    assert!((v - w).abs() <= 5e-7, "{field}: {line} against {want:?}");
                }
            }
        }
    }
}

/// A reader that stops early (`kinechain fk … | head -1`) ends the run quietly: exit 0 and
/// nothing on stderr, rather than an error about the broken pipe.
#[test]
fn a_closed_output_pipe_ends_the_run_quietly() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    // About 2 MB of output, far beyond a pipe's buffer.
    let lines: String = (0..5000)
        .map(|i| format!("{{\"q\": [{}, 0, 0]}}\n", 0.001 * f64::from(i)))
        .collect();
    let dir = Scratch::new("cli-pipe");
    let batch = dir.write("many.jsonl", lines);
    let mut child = command(["fk", "robots/planar3.yaml", "--batch", &batch])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    assert!(first.starts_with("{\"line\":1,\"links\""), "{first}");
    // The reader is dropped here, closing the pipe.
    assert_quiet_success(&child.wait_with_output().unwrap());
}

/// Any other failure to write the output (here a full device) is an error, not a quiet exit.
#[cfg(target_os = "linux")]
#[test]
fn an_output_that_cannot_be_written_is_an_error() {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let out = command(["fk", "robots/planar3.yaml", "--q", "[0.1, 0.2, 0.3]"])
        .stdout(full)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("cannot write output"), "{stderr}");
}

/// Results too large for `f64` (finite joint values whose sum overflows) are errors naming the
/// link or point and the quantity, not `null` in the JSON nor `NaN` in a drawing; in a batch,
/// the line's error.
/// Large finite values print in a table in exponent form.
#[test]
fn results_that_overflow_are_errors() {
    let dir = Scratch::new("cli-overflow");
    let robot = dir.write("slides.yaml", TWO_SLIDES);
    let robot = robot.as_str();
    let m = error(&["fk", robot, "--q", "[1e308, 1e308]"]);
    assert!(m.contains("pose of link 'link2' overflows"), "{m}");
    // `render` refuses it the same way, and draws a pose that is only far out.
    assert_eq!(error(&["render", robot, "--q", "[1e308, 1e308]"]), m);
    let far = ok_text(&["render", robot, "--q", "[1e300, 1e300]"]);
    assert!(far.starts_with("<svg") && !far.contains("NaN"), "{far}");
    let m = error(&["fk", robot, "--q", "[1, 1]", "--qd", "[1e308, 1e308]"]);
    assert!(m.contains("v of link 'link2' overflows"), "{m}");
    // A turning rate whose lever arm takes the velocity, and so J̇, past the range.
    let args = [
        "fk",
        "robots/planar3.yaml",
        "--q",
        "[0, 0, 0]",
        "--jacobian",
        "link3",
    ];
    let m = error(&[&args[..], &["--qd", "[1e308, 0, 0]"]].concat());
    assert!(m.contains("jacobian rate of link 'link3' overflows"), "{m}");
    ok_json(&[&args[..], &["--qd", "[1e307, 0, 0]"]].concat());
    let m = error(&[
        "fk",
        robot,
        "--q",
        "[1e308, 0]",
        "--point",
        "link2:0,0,1e308",
    ]);
    assert!(
        m.contains("position of point link2 (0.0, 0.0, 1e308) overflows"),
        "{m}"
    );
    // One term at the edge of the range is fine, and a table shows it in exponent form.
    let v = &ok_json(&["fk", robot, "--q", "[1e308, 0]"])[0];
    assert_eq!(position(v, "link2")[2], 1e308);
    let table = ok_text(&["fk", robot, "--q", "[1e308, 0]", "--format", "table"]);
    assert!(table.contains(" 1.000000e308 "), "{table}");
    assert!(table.lines().all(|l| l.len() < 200), "{table}");

    let batch = dir.write(
        "lines.jsonl",
        "{\"q\": [1, 2]}\n{\"q\": [1e308, 1e308]}\n{\"q\": [3, 4]}\n",
    );
    let batch = batch.as_str();
    let out = kinechain(&["fk", robot, "--batch", batch, "--keep-going"]);
    assert!(!out.status.success());
    let lines: Vec<Value> = json_lines(out.stdout);
    assert_eq!(lines.len(), 3);
    assert_eq!(position(&lines[0], "link2")[2], 3.0);
    assert_eq!(lines[1]["line"], 2);
    assert!(lines[1]["error"].as_str().unwrap().contains("overflows"));
    assert_eq!(position(&lines[2], "link2")[2], 7.0);
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("1 line(s) failed"), "{stderr}");
    let out = kinechain(&["fk", robot, "--batch", batch]);
    assert!(!out.status.success());
    assert_eq!(String::from_utf8(out.stdout).unwrap().lines().count(), 1);
    assert!(
        String::from_utf8(out.stderr)
            .unwrap()
            .contains("line 2: pose of link 'link2'")
    );

    // Lines that overflow in each batch of poses held, whatever ends the batch: a line that is
    // not JSON, a rate line (evaluated alone), the batch's size (256 lines), the end of the file.
    let overflow = "{\"q\": [1e308, 1e308]}";
    let mut text = format!("{{\"q\": [1, 2]}}\n{overflow}\nnot json\n{overflow}\n");
    text.push_str("{\"q\": [3, 4], \"qd\": [0, 0]}\n");
    text.push_str(&format!("{overflow}\n"));
    text.push_str(&"{\"q\": [1, 2]}\n".repeat(255));
    text.push_str(&format!("{overflow}\n"));
    let many = dir.write("many.jsonl", text);
    let out = kinechain(&["fk", robot, "--batch", &many, "--keep-going"]);
    assert!(!out.status.success());
    let results = json_lines(out.stdout);
    let failed: Vec<u64> = results
        .iter()
        .filter(|v| v.get("error").is_some())
        .filter_map(|v| v["line"].as_u64())
        .collect();
    assert_eq!(failed, [2, 3, 4, 6, 262]);
    // Every line has its result or its error, in order, each naming its line.
    let lines: Vec<u64> = results
        .iter()
        .map(|v| v["line"].as_u64().unwrap())
        .collect();
    assert_eq!(lines, (1..=262).collect::<Vec<u64>>());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("5 line(s) failed"), "{stderr}");
}

/// `--format table` prints the coordinates `--orientation` names, the same values as the JSON
/// output (to the six decimals shown), and `undefined` where JSON has `null`.
#[test]
fn tables_print_the_orientation_asked_for() {
    // Rounding residues (−6e-17, say) and −0 show as zero, without a sign: at this
    // configuration several position and rotation entries are such residues.
    let q = "[0, -0.5, 0.3, 0, 0.4, 0]";
    let args = ["fk", "robots/puma560.yaml", "--q", q, "--format", "table"];
    let table = ok_text(&args);
    let json = &ok_json(&args[..4])[0];
    let residue = |x: &Value| x.as_f64().is_some_and(|x| x < 0.0 && x > -5e-7);
    let residues = json["links"]
        .as_object()
        .unwrap()
        .values()
        .flat_map(|l| {
            l["pose"]
                .as_array()
                .unwrap()
                .iter()
                .flat_map(|r| r.as_array().unwrap())
        })
        .filter(|x| residue(x))
        .count();
    assert!(residues >= 3, "{residues}");
    assert!(!table.contains("-0.000000"), "{table}");
    let q = "[0.3, -0.5, -1.2, 0.1, -0.7, 2.9]";
    // A matrix's rows, and the axis before its angle, are groups separated by `;`.
    for (kind, sizes) in [("matrix", &[3, 3, 3][..]), ("axis-angle", &[3, 1])] {
        let args = ["fk", "robots/puma560.yaml", "--q", q, "--orientation", kind];
        let table = ok_text(&[&args[..], &["--format", "table"]].concat());
        for line in table.lines().skip(1) {
            let shown = line.split("   ").last().unwrap().trim();
            if shown != "undefined" {
                let groups: Vec<usize> = (shown.trim_matches(['[', ']']).split(';'))
                    .map(|g| g.split_whitespace().count())
                    .collect();
                assert_eq!(groups, sizes, "{kind}: {line}");
            }
        }
    }
    for (kind, header, key) in [
        ("quat", "quaternion (w x y z)", "quaternion"),
        ("rpy", "rpy (roll pitch yaw)", "rpy"),
        ("zxz", "euler_zxz (phi theta psi)", "euler_zxz"),
        ("axis-angle", "axis_angle (x y z; angle)", "axis_angle"),
        ("rodrigues", "rodrigues (γ1 γ2 γ3)", "rodrigues"),
    ] {
        let args = ["fk", "robots/puma560.yaml", "--q", q, "--orientation", kind];
        let json = &ok_json(&args)[0];
        let table = ok_text(&[&args[..], &["--format", "table"]].concat());
        let mut lines = table.lines();
        assert!(lines.next().unwrap().ends_with(header), "{table}");
        for line in lines {
            let link = line.split_whitespace().next().unwrap();
            let want = &json["links"][link][key];
            let shown = line.split("   ").last().unwrap().trim();
            if want.is_null() {
                assert_eq!(shown, "undefined", "{kind} {link}");
                continue;
            }
            let field = |k: &str| want[k].as_f64().expect("a number");
            let values: Vec<f64> = match want {
                Value::Array(_) => numbers(want),
                _ => match kind {
                    "quat" => ["w", "x", "y", "z"].map(field).to_vec(),
                    "rpy" => ["roll", "pitch", "yaw"].map(field).to_vec(),
                    "zxz" => ["phi", "theta", "psi"].map(field).to_vec(),
                    _ => {
                        let mut v = numbers(&want["axis"]);
                        v.push(field("angle"));
                        v
                    }
                },
            };
            let printed: Vec<f64> = shown
                .trim_matches(['[', ']'])
                .split([' ', ';'])
                .filter(|s| !s.is_empty())
                .map(|s| s.parse().unwrap())
                .collect();
            assert_eq!(printed.len(), values.len(), "{kind} {link}: {shown}");
            for (p, v) in printed.iter().zip(&values) {
                assert!(
                    (p - v).abs() <= 5e-7,
                    "{kind} {link}: {shown} against {want}"
                );
            }
        }
    }
    // The base link's axis is undefined (the identity).
    let table = ok_text(&[
        "fk",
        "robots/puma560.yaml",
        "--q",
        q,
        "--orientation",
        "axis-angle",
        "--format",
        "table",
    ]);
    assert!(
        table.lines().nth(1).unwrap().ends_with("undefined"),
        "{table}"
    );
}

/// Every `--orientation` kind on every reference robot and sample: each non-null output
/// recomposes to the link's rotation matrix (the `matrix` output) within 1e-12, near gimbal
/// lock included (the reference samples include the zero configuration and joint limits).
#[test]
fn orientation_kinds_recompose_on_the_reference_robots() {
    use kinechain::nalgebra::{Matrix3, Unit, Vector3};
    use kinechain::orientation::{AxisAngle, EulerParameters, EulerZxz, RodriguezParameters, Rpy};
    let dir = Scratch::new("cli-orient");
    let f = |v: &Value, k: &str| v[k].as_f64().unwrap();
    let v3 = |v: &Value| {
        Vector3::new(
            v[0].as_f64().unwrap(),
            v[1].as_f64().unwrap(),
            v[2].as_f64().unwrap(),
        )
    };
    let mut checked = 0;
    for path in crate::common::reference_files() {
        let reference = crate::common::read_json(&path);
        let robot = if reference["model"]["kind"] == "urdf" {
            let urdf = path.with_file_name(reference["model"]["file"].as_str().unwrap());
            urdf.to_str().unwrap().to_string()
        } else {
            let name = format!("{}.yaml", reference["robot"].as_str().unwrap());
            dir.write(&name, crate::common::model_yaml(&reference))
        };
        let lines: Vec<String> = reference["samples"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| serde_json::json!({"q": s["q"]}).to_string())
            .collect();
        let batch = dir.write("samples.jsonl", lines.join("\n"));
        let run = |kind: &str| {
            ok_json(&[
                "fk",
                &robot,
                "--batch",
                &batch,
                "--ignore-limits",
                "--orientation",
                kind,
            ])
        };
        let matrices = run("matrix");
        for kind in ["quat", "rpy", "zxz", "axis-angle", "rodrigues"] {
            for (out, want) in run(kind).iter().zip(&matrices) {
                for (name, link) in out["links"].as_object().unwrap() {
                    let pose = &want["links"][name]["pose"];
                    let a = Matrix3::from_fn(|i, j| pose[i][j].as_f64().unwrap());
                    assert_eq!(
                        v3(&link["position"]),
                        Vector3::new(
                            pose[0][3].as_f64().unwrap(),
                            pose[1][3].as_f64().unwrap(),
                            pose[2][3].as_f64().unwrap()
                        )
                    );
                    let r = match kind {
                        "quat" => Some(
                            EulerParameters {
                                e0: f(&link["quaternion"], "w"),
                                e1: f(&link["quaternion"], "x"),
                                e2: f(&link["quaternion"], "y"),
                                e3: f(&link["quaternion"], "z"),
                            }
                            .to_matrix(),
                        ),
                        "rpy" => (!link["rpy"].is_null()).then(|| {
                            Rpy {
                                roll: f(&link["rpy"], "roll"),
                                pitch: f(&link["rpy"], "pitch"),
                                yaw: f(&link["rpy"], "yaw"),
                            }
                            .to_matrix()
                        }),
                        "zxz" => (!link["euler_zxz"].is_null()).then(|| {
                            EulerZxz {
                                phi: f(&link["euler_zxz"], "phi"),
                                theta: f(&link["euler_zxz"], "theta"),
                                psi: f(&link["euler_zxz"], "psi"),
                            }
                            .to_matrix()
                        }),
                        "axis-angle" => (!link["axis_angle"].is_null()).then(|| {
                            AxisAngle {
                                axis: Unit::new_normalize(v3(&link["axis_angle"]["axis"])),
                                angle: f(&link["axis_angle"], "angle"),
                            }
                            .to_matrix()
                        }),
                        _ => (!link["rodrigues"].is_null())
                            .then(|| RodriguezParameters(v3(&link["rodrigues"])).to_matrix()),
                    };
                    if let Some(r) = r {
                        assert!(
                            (r - a).abs().max() < 1e-12,
                            "{} {kind} {name}",
                            path.display()
                        );
                        checked += 1;
                    } else {
                        // Null only where the representation really is undefined.
                        assert!(
                            match kind {
                                "zxz" => a[(0, 2)] == 0.0 && a[(1, 2)] == 0.0,
                                "rpy" => a[(0, 0)] == 0.0 && a[(1, 0)] == 0.0,
                                "axis-angle" => a == Matrix3::identity(),
                                _ => false,
                            },
                            "{} {kind} {name}: null for {a}",
                            path.display()
                        );
                    }
                }
            }
        }
    }
    assert!(checked > 5000, "{checked}");
}

#[test]
fn converting_a_urdf_says_what_is_not_written() {
    let dir = Scratch::new("cli-convert-urdf");
    let written = dir.path("panda.urdf");
    let out = kinechain(&["convert", "robots/panda.urdf", "-o", &written]);
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    for part in [
        "warning: robots/panda.urdf: the URDF written has the kinematics only",
        "11 visual elements, 17 collision elements, 11 links' masses and inertias",
        "9 joints' effort and velocity limits",
    ] {
        assert!(stderr.contains(part), "{stderr}");
    }
    // The written file has nothing more to drop, and a DH table never had any of it.
    for robot in [written.as_str(), "robots/puma560.yaml"] {
        assert_quiet_success(&kinechain(&["convert", robot]));
    }
}

/// Each joint that holds any of an effort limit, a velocity limit, `<dynamics>`,
/// `<calibration>` or `<safety_controller>` is counted once, whichever of them it holds.
#[test]
fn converting_a_urdf_counts_each_dropped_joint_part() {
    let dir = Scratch::new("cli-convert-parts");
    // (name, limit's effort and velocity, the elements after the limit)
    let joints = [
        ("effort_only", "10", "0", "<dynamics damping=\"0.1\"/>"),
        ("velocity_only", "0", "2", "<calibration rising=\"0.2\"/>"),
        (
            "safety_only",
            "0",
            "0",
            "<safety_controller k_velocity=\"1\"/>",
        ),
        ("bare", "0", "0", ""),
    ];
    let mut urdf = String::from("<robot name=\"parts\">\n  <link name=\"l0\"/>\n");
    for (i, (name, effort, velocity, extra)) in joints.iter().enumerate() {
        urdf += &format!(
            "  <link name=\"l{}\"/>\n  <joint name=\"{name}\" type=\"revolute\">\n    \
             <parent link=\"l{i}\"/><child link=\"l{}\"/><axis xyz=\"0 0 1\"/>\n    \
             <limit lower=\"-1\" upper=\"1\" effort=\"{effort}\" velocity=\"{velocity}\"/>{extra}\n  \
             </joint>\n",
            i + 1,
            i + 1
        );
    }
    urdf += "</robot>\n";
    let source = dir.write("parts.urdf", urdf);
    let out = kinechain(&["convert", &source, "-o", &dir.path("written.urdf")]);
    assert!(out.status.success(), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.trim_end().ends_with(
            "not written: 2 joints' effort and velocity limits, \
             3 joints' dynamics, calibration or safety controller elements"
        ),
        "{stderr}"
    );
}

/// A loader's warning (here |alpha| = 90 with `angle_unit: rad`, likely degrees) reaches stderr
/// with the file's name, and the command still succeeds.
#[test]
fn a_load_warning_is_printed_with_the_file() {
    let dir = Scratch::new("cli-warn");
    let path = dir.write(
        "degrees.yaml",
        "convention: standard\njoints:\n  - {name: j1, type: revolute, a: 0.1, alpha: 90, d: 0, theta: 0}\n",
    );
    let out = kinechain(&["info", &path]);
    assert!(out.status.success(), "{out:?}");
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.starts_with(&format!("warning: {path}: ")) && stderr.contains("degrees"),
        "{stderr}"
    );
}

#[test]
fn convert_and_render_write_files() {
    let dir = Scratch::new("cli-convert");
    let urdf = dir.path("puma.urdf");
    let out = kinechain(&["convert", "robots/puma560.yaml", "-o", &urdf]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The converted file gives the same tool pose.
    let q = "[0.3, -0.6, 0.4, 0.2, -0.7, 0.5]";
    let a = &ok_json(&["fk", "robots/puma560.yaml", "--q", q, "--link", "tool"])[0];
    let b = &ok_json(&["fk", &urdf, "--q", q, "--link", "tool"])[0];
    for i in 0..3 {
        for j in 0..4 {
            let (x, y) = (
                a["links"]["tool"]["pose"][i][j].as_f64().unwrap(),
                b["links"]["tool"]["pose"][i][j].as_f64().unwrap(),
            );
            assert!((x - y).abs() < 1e-12);
        }
    }
    let svg = dir.path("arm.svg");
    let out = kinechain(&["render", "robots/puma560.yaml", "--q", q, "-o", &svg]);
    assert!(out.status.success());
    assert!(std::fs::read_to_string(&svg).unwrap().starts_with("<svg"));
    let m = error(&[
        "render",
        "robots/puma560.yaml",
        "--q",
        "[10, 0, 0, 0, 0, 0]",
    ]);
    assert!(m.contains("limits"), "{m}");
}

/// `--jacobian LINK` prints the link's 6 × dof Jacobian; times `--qd` it is the printed
/// velocity of the link (a mimic finger included), in JSON, tables and batch lines alike.
/// The matrix printed as `rows` (a JSON array of six rows) times `x`.
fn times(rows: &Value, x: &[f64]) -> Vec<f64> {
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 6);
    rows.iter()
        .map(|row| {
            let row = row.as_array().unwrap();
            assert_eq!(row.len(), x.len());
            row.iter()
                .zip(x)
                .map(|(j, x)| j.as_f64().unwrap() * x)
                .sum()
        })
        .collect()
}

/// `J q̇` from the printed Jacobian is the printed velocity, and `J q̈ + J̇ q̇` with the printed
/// `J̇` the printed acceleration.
#[test]
fn fk_jacobians_give_the_printed_velocity_and_acceleration() {
    let robot = "robots/panda.urdf";
    let (q, qd, qdd) = (
        [0.1, -0.4, 0.3, -1.9, 0.2, 1.4, 0.6, 0.02],
        [0.3, -0.2, 0.5, 0.1, -0.6, 0.4, 0.2, 0.05],
        [-0.4, 0.6, 0.1, -0.3, 0.5, -0.2, 0.3, -0.1],
    );
    let text = |v: &[f64]| serde_json::to_string(v).unwrap();
    for link in ["panda_hand_tcp", "panda_rightfinger"] {
        let v = &ok_json(&[
            "fk",
            robot,
            "--q",
            &text(&q),
            "--qd",
            &text(&qd),
            "--qdd",
            &text(&qdd),
            "--jacobian",
            link,
        ])[0];
        let twist = times(&v["jacobians"][link], &qd);
        let (j_qdd, j_dot_qd) = (
            times(&v["jacobians"][link], &qdd),
            times(&v["jacobian_dots"][link], &qd),
        );
        // The same Jacobian when only that link's pose is asked for.
        let alone = &ok_json(&[
            "fk",
            robot,
            "--q",
            &text(&q),
            "--link",
            link,
            "--jacobian",
            link,
        ])[0];
        assert_eq!(alone["jacobians"][link], v["jacobians"][link], "{link}");
        assert!(alone.get("jacobian_dots").is_none(), "{alone}");
        // The library's bounds (2e-15 of the 1.4 m reach per unit rate (squared, for J̇ q̇)
        // and joint; 8 joints, rates up to 0.6) and the rounding of the printed products.
        let printed = &v["links"][link];
        for k in 0..3 {
            for (i, name, got, bound) in [
                (k, "v", twist[k], 1e-14),
                (3 + k, "omega", twist[3 + k], 1e-14),
                (k, "a", j_qdd[k] + j_dot_qd[k], 2e-14),
                (3 + k, "alpha", j_qdd[3 + k] + j_dot_qd[3 + k], 2e-14),
            ] {
                let want = printed[name][k].as_f64().unwrap();
                assert!(
                    (got - want).abs() < bound,
                    "{link} {name}[{i}]: {got} against {want}"
                );
            }
        }
    }
    let table = ok_text(&[
        "fk",
        robot,
        "--q",
        &text(&q),
        "--qd",
        &text(&qd),
        "--jacobian",
        "panda_hand",
        "--format",
        "table",
    ]);
    assert!(table.contains("jacobian of panda_hand"), "{table}");
    assert!(table.contains("jacobian rate of panda_hand"), "{table}");
    assert_eq!(
        table.lines().filter(|l| l.starts_with("omega_")).count(),
        6,
        "{table}"
    );

    let dir = Scratch::new("cli-jacobian");
    let batch = dir.write(
        "lines.jsonl",
        format!(
            "{{\"q\": {}}}\n{{\"q\": {}}}\n",
            text(&q),
            text(&[0.5, -0.4, 0.3, -1.9, 0.2, 1.4, 0.6, 0.02])
        ),
    );
    let lines = ok_json(&["fk", robot, "--batch", &batch, "--jacobian", "panda_hand"]);
    assert_eq!(lines.len(), 2);
    assert!(
        lines
            .iter()
            .all(|l| l["jacobians"]["panda_hand"].as_array().unwrap().len() == 6)
    );
    assert_ne!(lines[0]["jacobians"], lines[1]["jacobians"]);
    assert!(
        error(&["fk", robot, "--q", &text(&q), "--jacobian", "panda_hnd"])
            .contains("no link named 'panda_hnd' (did you mean 'panda_hand'?)")
    );
}

/// The JSON output's text, member by member and in order, where the numbers are exact (the planar
/// arm stretched out along x): links, then points, then Jacobians; each link's pose or position
/// and orientation, then its rates; `null` where the orientation is undefined. Both the single
/// evaluation and a batch line (written by the batch kernel's path).
#[test]
fn json_output_text() {
    let text = |args: &[&str]| {
        let out = kinechain(&[&["fk", "robots/planar3.yaml"], args].concat());
        assert!(out.status.success(), "{args:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let z3 = "[0.0,0.0,0.0]";
    let identity = "[[1.0,0.0,0.0,0.0],[0.0,1.0,0.0,0.0],[0.0,0.0,1.0,0.0],[0.0,0.0,0.0,1.0]]";
    let rates = ["--qd", "[1,0,0]", "--qdd", "[0,0,0]"];
    let only = ["--link", "link0", "--link", "link3"];
    let extra = ["--point", "link3:1,0,0", "--jacobian", "link3"];
    let q0 = ["--q", "[0,0,0]"];
    assert_eq!(
        text(&[&q0[..], &rates, &only, &extra].concat()),
        format!(
            concat!(
                r#"{{"links":{{"link0":{{"pose":{i},"omega":{z},"v":{z},"alpha":{z},"a":{z}}},"#,
                r#""link3":{{"pose":[[1.0,0.0,0.0,9.0],[0.0,1.0,0.0,0.0],[0.0,0.0,1.0,0.0],"#,
                r#"[0.0,0.0,0.0,1.0]],"omega":[0.0,0.0,1.0],"v":[0.0,9.0,0.0],"alpha":{z},"#,
                r#""a":[-9.0,0.0,0.0]}}}},"points":[{{"link":"link3","u":[1.0,0.0,0.0],"#,
                r#""position":[10.0,0.0,0.0],"velocity":[0.0,10.0,0.0],"#,
                r#""acceleration":[-10.0,0.0,0.0],"acceleration_parts":{{"origin":[-9.0,0.0,0.0],"#,
                r#""tangential":{z},"normal":[-1.0,0.0,0.0]}}}}],"jacobians":{{"link3":[{z},"#,
                r#"[9.0,5.0,2.0],{z},{z},{z},[1.0,1.0,1.0]]}},"jacobian_dots":{{"link3":"#,
                r#"[[-9.0,-5.0,-2.0],{z},{z},{z},{z},{z}]}}}}"#,
                "\n"
            ),
            i = identity,
            z = z3
        )
    );
    assert_eq!(
        text(&[&q0[..], &only, &["--orientation", "axis-angle"]].concat()),
        concat!(
            r#"{"links":{"link0":{"position":[0.0,0.0,0.0],"axis_angle":null},"#,
            r#""link3":{"position":[9.0,0.0,0.0],"axis_angle":null}}}"#,
            "\n"
        )
    );
    assert_eq!(
        text(&["--q", "[0,0,0]", "--link", "link3", "--orientation", "quat"]),
        concat!(
            r#"{"links":{"link3":{"position":[9.0,0.0,0.0],"#,
            r#""quaternion":{"w":1.0,"x":0.0,"y":0.0,"z":0.0}}}}"#,
            "\n"
        )
    );
    let turned = ["--q", "[0.5,0,0]", "--link", "link1", "--orientation"];
    let axis_angle = text(&[&turned[..], &["axis-angle"]].concat());
    assert!(
        axis_angle.contains(r#","axis_angle":{"axis":[0.0,0.0,1.0],"angle":0.49999999999999"#),
        "{axis_angle}"
    );
    let rodrigues = text(&[&turned[..], &["rodrigues"]].concat());
    assert!(
        rodrigues.contains(r#","rodrigues":[0.0,0.0,0.255"#),
        "{rodrigues}"
    );

    let dir = Scratch::new("cli-json-text");
    let batch = dir.write("one.jsonl", "{\"q\": [0, 0, 0]}\n");
    let zero = r#"{"roll":0.0,"pitch":-0.0,"yaw":0.0}"#;
    let links: Vec<String> = [
        ("link0", 0.0),
        ("link1", 4.0),
        ("link2", 7.0),
        ("link3", 9.0),
    ]
    .iter()
    .map(|(name, x)| format!(r#""{name}":{{"position":[{x:?},0.0,0.0],"rpy":{zero}}}"#))
    .collect();
    assert_eq!(
        text(&["--batch", &batch, "--orientation", "rpy"]),
        format!("{{\"line\":1,\"links\":{{{}}}}}\n", links.join(","))
    );
}

/// A link named twice in `--link` or `--jacobian` is printed once, where it was first named (a
/// JSON object cannot hold a name twice, and a table prints what the JSON does).
#[test]
fn repeated_link_names_print_once() {
    let fk = |names: &[&str], format: &str| {
        let q = "[0.1, -0.5, 0.3, 0.2, 0.4, -0.6]";
        let args = [
            &["fk", "robots/ur5.yaml", "--q", q, "--format", format],
            names,
        ]
        .concat();
        ok_text(&args)
    };
    for format in ["json", "table"] {
        let once = fk(
            &[
                "--link",
                "tool0",
                "--link",
                "forearm",
                "--jacobian",
                "tool0",
            ],
            format,
        );
        let twice = fk(
            &[
                "--link",
                "tool0",
                "--link",
                "forearm",
                "--link",
                "tool0",
                "--jacobian",
                "tool0",
                "--jacobian",
                "tool0",
            ],
            format,
        );
        assert_eq!(twice, once, "{format}");
        assert_eq!(once.matches("tool0").count(), 2, "{once}");
        let (tool, forearm) = (once.find("tool0"), once.find("forearm"));
        assert!(tool.is_some() && tool < forearm, "{once}");
    }
}

/// A table's name column is as wide as the longest link name in characters, not in bytes, and
/// the columns line up under names that are not ASCII.
#[test]
fn table_columns_line_up_under_names_that_are_not_ascii() {
    let dir = Scratch::new("cli-names");
    let robot = dir.write(
        "names.yaml",
        "name: names\nconvention: standard\nbase: {name: Basis}\njoints:\n  \
         - {name: j1, link: Glied_ä, type: revolute, a: 1, alpha: 0, d: 0, theta: 0}\n  \
         - {name: j2, link: Greifer, type: revolute, a: 1, alpha: 0, d: 0, theta: 0}\n",
    );
    let table = ok_text(&["fk", &robot, "--q", "[0.1, 0.2]", "--format", "table"]);
    let rows: Vec<&str> = table.lines().collect();
    assert_eq!(rows.len(), 4, "{table}");
    // Every row's first number ends in the same column: the name column, then 13 characters.
    let ends: Vec<usize> = rows[1..]
        .iter()
        .map(|row| row.chars().take_while(|&c| c != '[').count())
        .collect();
    assert!(ends.iter().all(|&e| e == ends[0]), "{table}");
    // The longest name has seven characters (eight bytes): the header's `x` ends the first
    // 12-wide number column after those seven and a space.
    assert_eq!(rows[0].find('x'), Some(7 + 1 + 11), "{table}");
}

/// `convert -o` and `render -o` never write over the robot file they read, named by the same
/// path, another path, a symbolic link or a hard link; the file is left as it was.
#[test]
fn outputs_never_overwrite_the_robot_file() {
    let dir = Scratch::new("cli-same-file");
    let original =
        std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/robots/panda.urdf")).unwrap();
    let robot = dir.write("panda.urdf", &original);
    let symlink = dir.path("symlink.urdf");
    std::os::unix::fs::symlink(&robot, &symlink).unwrap();
    let hard = dir.path("hard.urdf");
    std::fs::hard_link(&robot, &hard).unwrap();
    let dotted = format!("{}/./panda.urdf", dir.path(""));
    for output in [robot.as_str(), &symlink, &hard, &dotted] {
        for args in [
            vec!["convert", robot.as_str(), "-o", output],
            vec![
                "render",
                robot.as_str(),
                "--q",
                "0 0 0 -1 0 1 0 0",
                "-o",
                output,
            ],
            vec!["convert", output, "-o", robot.as_str()],
        ] {
            let e = error(&args);
            assert!(
                e.contains("(the same file): refusing to overwrite it"),
                "{args:?}: {e}"
            );
        }
    }
    assert_eq!(std::fs::read(&robot).unwrap(), original);
    assert_eq!(std::fs::read(&hard).unwrap(), original);
    // Another file is written whole, and written again over an earlier output.
    let out = dir.path("out.urdf");
    for _ in 0..2 {
        let status = kinechain(&["convert", &robot, "-o", &out]);
        assert!(status.status.success());
        let written = std::fs::read_to_string(&out).unwrap();
        assert!(written.trim_end().ends_with("</robot>"), "{written}");
    }
}

/// An output that cannot be put in place (here a directory stands at its path) is an error that
/// leaves nothing behind: no temporary file, and the directory as it was.
#[test]
fn a_failed_write_leaves_no_partial_output() {
    let dir = Scratch::new("cli-failed-write");
    std::fs::create_dir(dir.path("taken")).unwrap();
    let e = error(&["convert", "robots/puma560.yaml", "-o", &dir.path("taken")]);
    assert!(e.starts_with("error: cannot write "), "{e}");
    let left: Vec<String> = std::fs::read_dir(dir.path(""))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(left, ["taken"]);
    assert_eq!(std::fs::read_dir(dir.path("taken")).unwrap().count(), 0);
    let e = error(&[
        "convert",
        "robots/puma560.yaml",
        "-o",
        &dir.path("missing/out.urdf"),
    ]);
    assert!(e.starts_with("error: cannot write "), "{e}");
}

/// A command whose results go to a closed standard output fails and says so; one that writes a
/// file does not need it, and a reader that goes away early (`| head`) is not an error.
#[test]
fn a_closed_standard_output_is_an_error() {
    let run = |args: &str| {
        Command::new("sh")
            .arg("-c")
            .arg(format!("exec \"$0\" {args} >&-"))
            .arg(env!("CARGO_BIN_EXE_kinechain"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    };
    for args in [
        "info robots/panda.urdf",
        "fk robots/puma560.yaml --q 0,0,0,0,0,0",
        "convert robots/puma560.yaml",
    ] {
        let out = run(args);
        assert!(!out.status.success(), "{args}");
        assert_eq!(
            String::from_utf8_lossy(&out.stderr).trim_end(),
            "error: standard output is closed: the results would be lost",
            "{args}"
        );
    }
    let dir = Scratch::new("cli-closed-stdout");
    let out = run(&format!(
        "convert robots/puma560.yaml -o {}",
        dir.path("p.urdf")
    ));
    assert!(out.status.success(), "{out:?}");
    let piped = Command::new("sh")
        .arg("-c")
        .arg("\"$0\" fk robots/snake50.yaml --batch - --format table < /dev/zero | head -c 1 > /dev/null; exit 0")
        .arg(env!("CARGO_BIN_EXE_kinechain"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(piped.status.success());
}

/// Names and file text in errors and warnings have their control characters escaped, so that a
/// crafted name cannot move the cursor, clear the screen or reorder what the terminal shows.
#[test]
fn control_characters_in_messages_are_escaped() {
    let dir = Scratch::new("cli-escapes");
    let yaml = dir.write(
        "evil.yaml",
        "convention: standard\njoints:\n  - {name: \"j\\e[2J\\r\", type: revolute, a: 0, alpha: 0, d: 0, theta: 0, limits: [-1, 1]}\n",
    );
    let e = error(&["fk", &yaml, "--q", "5"]);
    assert!(e.contains("joint 'j\\u{1b}[2J\\r'"), "{e}");
    assert!(!e.contains('\u{1b}') && !e.contains('\r'), "{e}");
    // XML allows C1 controls and bidirectional overrides in names.
    let urdf = dir.write(
        "evil.urdf",
        "<robot name=\"r\"><link name=\"a\"/><link name=\"b\u{9b}2J\"/>\
         <joint name=\"j\u{202e}\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\u{9b}2J\"/><lmit/></joint></robot>",
    );
    let out = kinechain(&["info", &urdf]);
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("joint 'j\\u{202e}'"), "{stderr}");
    assert!(
        !stderr.contains('\u{202e}') && !stderr.contains('\u{9b}'),
        "{stderr}"
    );
    let out = kinechain(&["fk", &urdf, "--q", "[]", "--link", "b\u{9b}2"]);
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.contains("error: no link named 'b\\u{9b}2' (did you mean 'b\\u{9b}2J'?)"),
        "{stderr}"
    );
    assert!(!stderr.contains('\u{9b}'), "{stderr}");
}

/// A batch input without line ends (`/dev/zero`) ends the run with an error once its first line
/// passes the cap, rather than reading on forever; with `--keep-going`, after skipping 1 GiB of it.
#[test]
fn an_input_without_line_ends_is_an_error_not_a_hang() {
    let e = error(&["fk", "robots/puma560.yaml", "--batch", "/dev/zero"]);
    assert!(
        e.starts_with("error: /dev/zero: line 1: the line is longer than"),
        "{e}"
    );
    let out = kinechain(&[
        "fk",
        "robots/puma560.yaml",
        "--batch",
        "/dev/zero",
        "--keep-going",
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.starts_with("error: /dev/zero: line 1: no line end in the "),
        "{stderr}"
    );
}

/// `bench` keeps every link's frame for each configuration: a robot with many links gets an
/// error saying how many configurations it may have, not an exhausted memory.
#[test]
fn bench_is_capped_by_configurations_times_links() {
    let dir = Scratch::new("cli-bench-cap");
    let mut urdf = String::from("<robot name=\"many\"><link name=\"l0\"/>");
    for i in 1..=2000 {
        urdf += &format!(
            "<link name=\"l{i}\"/><joint name=\"j{i}\" type=\"continuous\"><parent link=\"l{}\"/><child link=\"l{i}\"/></joint>",
            i - 1
        );
    }
    urdf += "</robot>";
    let robot = dir.write("many.urdf", urdf);
    let e = error(&["bench", &robot, "--configurations", "65536"]);
    assert!(
        e.ends_with("at most 4192 configurations for this robot"),
        "{e}"
    );
}

/// Batch lines with rates go through the batch kernels in runs of one level (poses, velocities,
/// accelerations, in any order); each line's output is, byte for byte, what `fk --q --qd --qdd`
/// prints for it alone. A non-finite rate names its line; `qdd` without `qd` is the single path's
/// error.
#[test]
fn batch_lines_with_rates_equal_single_runs() {
    let q = |i: usize| format!("[{}, -0.5, 0.6, 0.2, 0.4, 0.0]", 0.01 * i as f64);
    let qd = "[0.3, 0.1, -0.2, 0.5, 0.0, 1.0]";
    let qdd = "[0.2, -0.4, 0.1, 0.0, 0.3, -0.1]";
    let mut lines = Vec::new();
    for i in 0..40 {
        lines.push(match i % 5 {
            0 | 1 => format!(r#"{{"q": {}, "qd": {qd}}}"#, q(i)),
            2 => format!(r#"{{"q": {}, "qd": {qd}, "qdd": {qdd}}}"#, q(i)),
            3 => q(i),
            _ => format!(r#"{{"q": {}, "qd": {qd}, "qdd": {qdd}}}"#, q(i)),
        });
    }
    let dir = Scratch::new("cli-batch-rates");
    let batch = dir.write("rates.jsonl", lines.join("\n") + "\n");
    // Every link, and with Jacobians (and their rates where the line has qd), which run through
    // the batch kernels of Jacobians.
    for extra in [vec![], vec!["--jacobian", "tool", "--jacobian", "link3"]] {
        let mut batch_args = vec!["fk", "robots/stanford.yaml", "--batch", &batch];
        batch_args.extend(&extra);
        let out = kinechain(&batch_args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let got = String::from_utf8(out.stdout).unwrap();
        let got: Vec<&str> = got.lines().collect();
        assert_eq!(got.len(), 40);
        for (i, line) in got.iter().enumerate() {
            let mut args = vec!["fk", "robots/stanford.yaml"];
            let qi = q(i);
            args.extend(["--q", &qi]);
            if i % 5 != 3 {
                args.extend(["--qd", qd]);
            }
            if i % 5 == 2 || i % 5 == 4 {
                args.extend(["--qdd", qdd]);
            }
            args.extend(&extra);
            let single = kinechain(&args);
            let single = String::from_utf8(single.stdout).unwrap();
            let mut want: Value = serde_json::from_str(single.trim()).unwrap();
            want.as_object_mut()
                .unwrap()
                .insert("line".into(), Value::from(i + 1));
            let got: Value = serde_json::from_str(line).unwrap();
            assert_eq!(got.get("jacobians").is_some(), !extra.is_empty());
            assert_eq!(
                got.get("jacobian_dots").is_some(),
                !extra.is_empty() && i % 5 != 3
            );
            assert_eq!(got, want, "line {} {extra:?}", i + 1);
        }
    }
    let bad = dir.write(
        "bad.jsonl",
        format!(
            "{}\n{{\"q\": {}, \"qd\": [0, 0, NaN, 0, 0, 0]}}\n",
            lines[0],
            q(1)
        ),
    );
    let out = kinechain(&["fk", "robots/stanford.yaml", "--batch", &bad]);
    assert!(!out.status.success());
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains("line 2"), "{stderr}");
    let bad = dir.write(
        "qdd.jsonl",
        format!("{{\"q\": {}, \"qdd\": {qdd}}}\n", q(1)),
    );
    let out = kinechain(&["fk", "robots/stanford.yaml", "--batch", &bad]);
    assert!(!out.status.success());
}

#[test]
fn a_floating_base_on_the_command_line() {
    use kinechain::{Chain, Data, forward_velocities, io::LoadOptions};
    let fb = LoadOptions::default().with_floating_base(true);
    let chain = Chain::from_file_with("robots/ur5.yaml", &fb).unwrap();
    // info: the sizes and the names of every entry.
    let info = &ok_json(&["info", "robots/ur5.yaml", "--floating-base"])[0];
    assert_eq!(
        (
            info["nq"].as_u64(),
            info["nv"].as_u64(),
            info["dof"].as_u64()
        ),
        (Some(13), Some(12), Some(12))
    );
    let q_names: Vec<&str> = info["q_names"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(
        q_names[..8],
        [
            "root_joint.x",
            "root_joint.y",
            "root_joint.z",
            "root_joint.qw",
            "root_joint.qx",
            "root_joint.qy",
            "root_joint.qz",
            "shoulder_pan"
        ]
    );
    let v_names: Vec<&str> = info["v_names"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(
        v_names[..7],
        [
            "root_joint.vx",
            "root_joint.vy",
            "root_joint.vz",
            "root_joint.wx",
            "root_joint.wy",
            "root_joint.wz",
            "shoulder_pan"
        ]
    );
    // fk: the array, object and list forms agree, with rates; the same bits as the library.
    let q = [
        0.5, -0.2, 0.1, 0.5, 0.5, -0.5, 0.5, 0.1, -0.4, 0.3, 0.2, 0.5, -0.6,
    ];
    let qd = [
        0.3, 0.0, -0.1, 0.2, -0.7, 0.4, 1.0, 0.5, -0.5, 0.2, 0.1, 0.0,
    ];
    let array = serde_json::to_string(&q).unwrap();
    let object = serde_json::json!({"root_joint": &q[..7], "shoulder_pan": q[7], "shoulder_lift": q[8], "elbow": q[9], "wrist_1": q[10], "wrist_2": q[11], "wrist_3": q[12]}).to_string();
    let rates = serde_json::to_string(&qd).unwrap();
    let a = &ok_json(&[
        "fk",
        "robots/ur5.yaml",
        "--floating-base",
        "--q",
        &array,
        "--qd",
        &rates,
    ])[0];
    let b = &ok_json(&[
        "--floating-base",
        "fk",
        "robots/ur5.yaml",
        "--q",
        &object,
        "--qd",
        &rates,
    ])[0];
    assert_eq!(a, b);
    let mut data = Data::new(&chain);
    let vel = forward_velocities(&chain, &mut data, &q, &qd).unwrap();
    let tool = chain.link_id("tool0").unwrap();
    let want = vel.velocity(tool);
    let got = numbers(&a["links"]["tool0"]["v"]);
    assert_eq!(got, want.v.as_slice());
    // A CSV batch with a header naming the base's entries one by one, in another order.
    let dir = Scratch::new("floating-cli");
    let header = "shoulder_pan,shoulder_lift,elbow,wrist_1,wrist_2,wrist_3,root_joint.qw,root_joint.qx,root_joint.qy,root_joint.qz,root_joint.x,root_joint.y,root_joint.z";
    let row: Vec<String> = [&q[7..], &q[3..7], &q[..3]]
        .concat()
        .iter()
        .map(f64::to_string)
        .collect();
    let file = dir.write("rows.csv", format!("{header}\n{}\n", row.join(",")));
    let lines = ok_json(&["fk", "robots/ur5.yaml", "--floating-base", "--batch", &file]);
    let plain = &ok_json(&["fk", "robots/ur5.yaml", "--floating-base", "--q", &array])[0];
    assert_eq!(lines[0]["links"], plain["links"]);
    // Errors: the length names the floating joint's share; a bad quaternion names the joint.
    let e = error(&[
        "fk",
        "robots/ur5.yaml",
        "--floating-base",
        "--q",
        "[0,0,0,1,0,0,0,0,0,0,0,0]",
    ]);
    assert!(e.contains("13"), "{e}");
    let e = error(&[
        "fk",
        "robots/ur5.yaml",
        "--floating-base",
        "--q",
        "[0,0,0,0,0,0,0,0,0,0,0,0,0]",
    ]);
    assert!(
        e.contains("quaternion of floating joint 'root_joint'"),
        "{e}"
    );
    // record / verify with a floating base, and convert: the URDF written has the floating
    // joint, and loads back to the same poses.
    let golden = dir.path("golden.jsonl");
    ok_text(&[
        "record",
        "robots/ur5.yaml",
        "--floating-base",
        "--level",
        "acc",
        "-o",
        &golden,
    ]);
    let report = ok_text(&["verify", "robots/ur5.yaml", "--floating-base", &golden]);
    assert!(
        report.contains("pass") || report.contains("PASS") || report.contains("ok"),
        "{report}"
    );
    let urdf = dir.path("ur5_floating.urdf");
    ok_text(&["convert", "robots/ur5.yaml", "--floating-base", "-o", &urdf]);
    let text = std::fs::read_to_string(&urdf).unwrap();
    assert!(text.contains("type=\"floating\""), "{text}");
    let back = &ok_json(&["fk", &urdf, "--q", &array])[0];
    for link in chain.links() {
        let (x, y) = (position(back, link.name()), position(plain, link.name()));
        for k in 0..3 {
            assert!((x[k] - y[k]).abs() < 1e-12, "{}: {x:?} {y:?}", link.name());
        }
    }
    // And the converted robot verifies against the golden file of the original.
    ok_text(&["verify", &urdf, &golden]);
}

#[test]
fn mjcf_files_load_with_their_keyframes_and_couplings_on_request() {
    let file = "tests/data/mjcf/features.xml";
    let info = &ok_json(&["info", file])[0];
    assert_eq!(info["nq"], 5);
    assert_eq!(info["keyframes"]["home"][4], 0.05);
    let coupled = &ok_json(&["info", file, "--couplings"])[0];
    assert_eq!(coupled["nq"], 4);
    assert_eq!(coupled["keyframes"]["home"].as_array().unwrap().len(), 4);
    // fk at a keyframe's q, a site by name.
    let lines = ok_json(&[
        "fk",
        file,
        "--q",
        "[0.1, 0.2, 0.3, 0.4, 0.05]",
        "--link",
        "tip",
    ]);
    assert!(lines[0]["links"]["tip"]["pose"].is_array());
    let out = kinechain(&["info", "tests/data/mjcf/menagerie/aloha/aloha.xml"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("equality constraints (2 joint)"));
}

#[test]
fn a_scene_of_two_arms_and_ten_free_boxes_lists_and_evaluates() {
    let file = "tests/data/mjcf/scene/pick.xml";
    let info = &ok_json(&["info", file])[0];
    assert_eq!(
        (info["nq"].as_u64(), info["nv"].as_u64()),
        (Some(85), Some(75))
    );
    let joints = info["joints"].as_array().unwrap();
    let free: Vec<&str> = joints
        .iter()
        .filter(|j| j["type"] == "floating")
        .map(|j| j["name"].as_str().unwrap())
        .collect();
    assert_eq!(free.len(), 10);
    assert_eq!(free[0], "box_00");
    assert_eq!(
        info["keyframes"]
            .as_object()
            .unwrap()
            .keys()
            .collect::<Vec<_>>(),
        ["left/home", "right/home"]
    );
    let table = ok_text(&["info", file, "--format", "table"]);
    assert!(table.contains("the floating joint 'box_09'"), "{table}");
    // fk of a box's site and the Panda's hand at the first keyframe: the box where the file
    // puts it (alignfree: its top site keeps its place), the hand as the library says.
    let q: Vec<f64> = numbers(&info["keyframes"]["left/home"]);
    let q_text = serde_json::to_string(&q).unwrap();
    let lines = ok_json(&[
        "fk",
        file,
        "--q",
        &q_text,
        "--link",
        "top_00",
        "--link",
        "left/hand",
    ]);
    let top = position(&lines[0], "top_00");
    assert!(
        (top[0] + 0.36).abs() < 1e-12 && (top[1] - 0.45).abs() < 1e-12,
        "{top:?}"
    );
    let chain = kinechain::Chain::from_file(file).unwrap();
    let mut data = kinechain::Data::new(&chain);
    let poses = kinechain::forward_kinematics(&chain, &mut data, &q).unwrap();
    let hand = poses
        .world_from_link(chain.link_id("left/hand").unwrap())
        .translation();
    assert_eq!(position(&lines[0], "left/hand"), [hand.x, hand.y, hand.z]);
}

#[test]
fn xacro_files_expand_and_load_with_args_and_package_paths() {
    let ur = "tests/data/xacro/packages/ur_description/urdf/ur.urdf.xacro";
    let args = ["--arg", "name:=ur", "--arg", "ur_type:=ur5e"];
    // `expand` writes what the URDF reader then loads: the same robot as the xacro file.
    let text = ok_text(&["expand", ur, args[0], args[1], args[2], args[3]]);
    assert!(text.contains("<robot name=\"ur\">"), "{text}");
    let dir = Scratch::new("cli-xacro");
    let urdf = dir.path("ur5e.urdf");
    ok_text(&[
        "expand", ur, args[0], args[1], args[2], args[3], "-o", &urdf,
    ]);
    assert_eq!(std::fs::read_to_string(&urdf).unwrap(), text);
    let info = &ok_json(&["info", ur, args[0], args[1], args[2], args[3]])[0];
    assert_eq!(info["nq"], 6);
    ok_text(&[
        "compare",
        &urdf,
        ur,
        args[0],
        args[1],
        args[2],
        args[3],
        "--samples",
        "5",
    ]);
    // --package-path, and fk on a xacro file.
    let lines = ok_json(&[
        "fk",
        ur,
        args[0],
        args[1],
        args[2],
        args[3],
        "--package-path",
        "tests/data/xacro/packages",
        "--q",
        "[0, -1, 1, 0, 0.5, 0]",
        "--link",
        "tool0",
    ]);
    assert!(lines[0]["links"]["tool0"]["pose"].is_array());
    // The robot's name comes from an argument that is read before its default is declared
    // (xacro fails the same way): the error names it, the file and the line.
    let out = kinechain(&["info", ur]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("ur.urdf.xacro:2:1: argument `name` is not defined"),
        "{err}"
    );
    // Without ur_type, its default names a type that has no configuration: the error names the
    // file it could not read and the macro call.
    let out = kinechain(&["info", ur, "--arg", "name:=ur"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot read") && err.contains("ur5x"), "{err}");
    assert!(err.contains("in macro `ur_robot`"), "{err}");
    // A bad --arg is refused.
    let out = kinechain(&["info", ur, "--arg", "ur_type=ur5e"]);
    assert_eq!(out.status.code(), Some(2));
    // `expand` does not write over its input.
    let out = kinechain(&["expand", ur, args[0], args[1], args[2], args[3], "-o", ur]);
    assert!(!out.status.success());
}

#[test]
fn ik_reaches_a_pose_that_fk_then_confirms_in_every_target_form() {
    // Where fk puts the UR5's tool at some q, as a matrix, xyz + rpy and xyz + quaternion.
    let q = "[0.3, -1.1, 1.2, -0.4, 1.0, 0.2]";
    let fk = &ok_json(&["fk", "robots/ur5.yaml", "--q", q, "--link", "tool0"])[0];
    let m: Vec<f64> = fk["links"]["tool0"]["pose"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(numbers)
        .collect();
    let matrix = serde_json::to_string(&m).unwrap();
    let r = kinechain::nalgebra::Matrix3::from_row_slice(&[
        m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10],
    ]);
    let e = kinechain::orientation::EulerParameters::from_matrix(&r);
    let v = e.as_vector();
    let quaternion = format!(
        "{},{},{},{},{},{},{}",
        m[3], m[7], m[11], v[0], v[1], v[2], v[3]
    );
    let (roll, pitch, yaw) =
        kinechain::nalgebra::Rotation3::from_matrix_unchecked(r).euler_angles();
    let rpy = format!("{} {} {} {roll} {pitch} {yaw}", m[3], m[7], m[11]);
    for target in [&matrix, &quaternion, &rpy] {
        let out = &ok_json(&[
            "ik",
            "robots/ur5.yaml",
            "--link",
            "tool0",
            "--target",
            target,
        ])[0];
        assert_eq!(out["success"], true, "{target}");
        assert!(out["position_error"].as_f64().unwrap() <= 1e-6);
        let q = serde_json::to_string(&out["q"]).unwrap();
        let back = &ok_json(&["fk", "robots/ur5.yaml", "--q", &q, "--link", "tool0"])[0];
        let got: Vec<f64> = back["links"]["tool0"]["pose"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(numbers)
            .collect();
        for (a, b) in got.iter().zip(&m) {
            assert!((a - b).abs() < 2e-6, "{target}: {a} vs {b}");
        }
    }
}

/// `error` of `kinechain ik robots/ur5.yaml --link tool0` with `rest`.
fn ur5_tool_ik_error(rest: &[&str]) -> String {
    let mut args = vec!["ik", "robots/ur5.yaml", "--link", "tool0"];
    args.extend_from_slice(rest);
    error(&args)
}

#[test]
fn ik_batches_lines_exits_1_for_an_unreached_target_and_names_bad_input() {
    let scratch = Scratch::new("ik-cli");
    let file = scratch.write("targets.csv", "x,y,z\n0.4,0.2,0.3\n5,5,5\n");
    let out = kinechain(&["ik", "robots/ur5.yaml", "--link", "tool0", "--batch", &file]);
    assert_eq!(out.status.code(), Some(1));
    let lines = json_lines(out.stdout);
    assert_eq!(lines.len(), 2);
    assert_eq!(
        (lines[0]["line"].as_u64(), lines[0]["success"].as_bool()),
        (Some(2), Some(true))
    );
    assert_eq!(lines[1]["success"], false);
    assert!(lines[1]["position_error"].as_f64().unwrap() > 6.0);
    assert!(String::from_utf8_lossy(&out.stderr).contains("1 of 2 targets not reached"));
    let csv = ok_text(&[
        "ik",
        "robots/ur5.yaml",
        "--link",
        "tool0",
        "--target",
        "0.4,0.2,0.3",
        "--format",
        "csv",
    ]);
    assert!(
        csv.starts_with("success,position_error,rotation_error,iterations,restarts,shoulder_pan,"),
        "{csv}"
    );
    assert!(
        error(&[
            "ik",
            "robots/ur5.yaml",
            "--link",
            "tool9",
            "--target",
            "0,0,0"
        ])
        .contains("tool9")
    );
    assert!(ur5_tool_ik_error(&["--target", "1,2"]).contains("2 numbers"));
    assert!(ur5_tool_ik_error(&["--target", "0,0,0,2,0,0,0"]).contains("norm"));
    assert!(
        ur5_tool_ik_error(&["--target", "0.4,0.2,0.3", "--q0", "9,0,0,0,0,0"])
            .contains("shoulder_pan")
    );
    assert!(ur5_tool_ik_error(&["--target", "0.4,0.2,0.3", "--lock", "nope"]).contains("nope"));
    let bad = scratch.write("bad.txt", "0.4,0.2,zero\n");
    assert!(ur5_tool_ik_error(&["--batch", &bad]).contains("line 1"));
}

#[test]
fn fk_base_prints_poses_and_rates_in_the_base_links_frame() {
    let q = "[0.3, -0.4, 0.1, -2.0, 0.2, 1.8, 0.6, 0.03]";
    let qd = "[0.1, 0.2, -0.3, 0.1, 0.0, 0.2, -0.1, 0.0]";
    let world = &ok_json(&[
        "fk",
        "robots/panda.urdf",
        "--q",
        q,
        "--qd",
        qd,
        "--link",
        "panda_hand",
        "--link",
        "panda_link3",
    ])[0];
    let rel = &ok_json(&[
        "fk",
        "robots/panda.urdf",
        "--q",
        q,
        "--qd",
        qd,
        "--link",
        "panda_hand",
        "--base",
        "panda_link3",
    ])[0];
    let m = |v: &Value| {
        let rows: Vec<f64> = v.as_array().unwrap().iter().flat_map(numbers).collect();
        kinechain::nalgebra::Matrix4::from_row_slice(&rows)
    };
    let (hand, base) = (
        m(&world["links"]["panda_hand"]["pose"]),
        m(&world["links"]["panda_link3"]["pose"]),
    );
    let want = base.try_inverse().unwrap() * hand;
    let got = m(&rel["links"]["panda_hand"]["pose"]);
    assert!((got - want).abs().max() < 1e-12, "{got} vs {want}");
    assert!(rel["links"]["panda_hand"]["omega"].is_array());
    let e = error(&[
        "fk",
        "robots/panda.urdf",
        "--q",
        q,
        "--base",
        "panda_link3",
        "--point",
        "panda_hand:0,0,0.1",
    ]);
    assert!(e.contains("--point with --base"), "{e}");
    assert!(error(&["fk", "robots/panda.urdf", "--q", q, "--base", "nope"]).contains("nope"));
}
