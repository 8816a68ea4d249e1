//! What `-o` does with what stands at its path (FIFOs, devices, symbolic links, directories,
//! read-only directories, inputs), the limits that keep kinechain from writing what it would not
//! read back, `compare` with renamed joints, and batch lines past the length cap.

use crate::common::Scratch;
use kinechain::io::output::{OutputProblem, write_file};
use std::io::{Read, Write};
use std::os::unix::fs::{FileTypeExt, PermissionsExt};
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn kinechain(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kinechain"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The three commands that write through `-o`, each writing `output`.
fn writers(output: &str) -> [Vec<&str>; 3] {
    [
        vec!["convert", "robots/planar3.yaml", "-o", output],
        vec![
            "render",
            "robots/planar3.yaml",
            "--q",
            "0 0.5 1",
            "-o",
            output,
        ],
        vec![
            "record",
            "robots/planar3.yaml",
            "--samples",
            "3",
            "-o",
            output,
        ],
    ]
}

/// What each command prints to standard output when it has no `-o`.
fn expected(args: &[&str]) -> Vec<u8> {
    let without: Vec<&str> = args[..args.len() - 2].to_vec();
    let out = kinechain(&without);
    assert!(out.status.success(), "{without:?}: {}", stderr(&out));
    out.stdout
}

fn mkfifo(path: &str) {
    let status = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(status.success());
}

/// A FIFO is written in place (its reader gets every byte) and stays a FIFO.
#[test]
fn a_fifo_is_written_in_place() {
    let dir = Scratch::new("out-fifo");
    let fifo = dir.path("f");
    mkfifo(&fifo);
    for args in writers(&fifo) {
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || {
                let mut got = Vec::new();
                std::fs::File::open(&fifo)
                    .unwrap()
                    .read_to_end(&mut got)
                    .unwrap();
                got
            })
        };
        let out = kinechain(&args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
        assert_eq!(reader.join().unwrap(), expected(&args), "{args:?}");
        let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
        assert!(kind.is_fifo(), "{args:?}: the FIFO was replaced");
    }
    let left: Vec<_> = std::fs::read_dir(dir.path("")).unwrap().collect();
    assert_eq!(left.len(), 1, "a temporary file was left: {left:?}");
}

/// `/dev/null` and `/dev/stdout` (a symbolic link to the process's own descriptor) are written,
/// not replaced.
#[test]
fn dev_null_and_dev_stdout_are_written() {
    for args in writers("/dev/null") {
        let out = kinechain(&args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    }
    assert!(
        std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device()
    );
    for args in writers("/dev/stdout") {
        let out = kinechain(&args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
        assert_eq!(out.stdout, expected(&args), "{args:?}");
    }
    assert!(
        std::fs::symlink_metadata("/dev/stdout")
            .unwrap()
            .file_type()
            .is_symlink()
    );
}

/// A character device that refuses the bytes (`/dev/full`: ENOSPC) is an error naming the path,
/// and the node survives. The node is made in the test's own directory (as root; skipped
/// otherwise), the same device as `/dev/full`.
#[test]
fn a_full_device_is_an_error_and_survives() {
    let dir = Scratch::new("out-full");
    let full = dir.path("full");
    let made = Command::new("mknod")
        .args([&full, "c", "1", "7"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !made {
        eprintln!("skipped: cannot make a device node here (not root)");
        return;
    }
    for args in writers(&full) {
        let out = kinechain(&args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let e = stderr(&out);
        assert!(
            e.starts_with(&format!("error: cannot write {full}: ")) && e.contains("space"),
            "{args:?}: {e}"
        );
        let kind = std::fs::symlink_metadata(&full).unwrap().file_type();
        assert!(kind.is_char_device(), "{args:?}: the device was replaced");
    }
}

/// A symbolic link is followed: the file it points to is replaced whole (and keeps its
/// permissions), the link stays; a dangling link creates its target; a link to the input is
/// refused.
#[test]
fn symbolic_links_are_followed() {
    let dir = Scratch::new("out-links");
    std::fs::create_dir(dir.path("elsewhere")).unwrap();
    let target = dir.write("elsewhere/target.urdf", "old");
    std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o600)).unwrap();
    let link = dir.path("link.urdf");
    std::os::unix::fs::symlink("elsewhere/target.urdf", &link).unwrap();
    // A link to the link, to show the chain is followed to its end.
    let link2 = dir.path("link2.urdf");
    std::os::unix::fs::symlink(&link, &link2).unwrap();
    for args in writers(&link2) {
        let out = kinechain(&args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
        assert_eq!(std::fs::read(&target).unwrap(), expected(&args), "{args:?}");
        for l in [&link, &link2] {
            assert!(
                std::fs::symlink_metadata(l)
                    .unwrap()
                    .file_type()
                    .is_symlink()
            );
        }
        let mode = std::fs::metadata(&target).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600, "{args:?}: the replaced file's mode changed");
    }
    // No temporary file beside the link nor beside the target.
    assert_eq!(std::fs::read_dir(dir.path("elsewhere")).unwrap().count(), 1);
    assert_eq!(std::fs::read_dir(dir.path("")).unwrap().count(), 3);

    let dangling = dir.path("dangling.urdf");
    std::os::unix::fs::symlink("elsewhere/new.urdf", &dangling).unwrap();
    let out = kinechain(&["convert", "robots/planar3.yaml", "-o", &dangling]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        std::fs::symlink_metadata(&dangling)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    let made = std::fs::read_to_string(dir.path("elsewhere/new.urdf")).unwrap();
    assert!(made.starts_with("<robot name=\"planar3\">"), "{made}");

    // The input, reached through a link to it: refused, and unchanged.
    let input = dir.write("arm.yaml", std::fs::read("robots/planar3.yaml").unwrap());
    let to_input = dir.path("to_input.urdf");
    std::os::unix::fs::symlink(&input, &to_input).unwrap();
    for args in [
        vec!["convert", input.as_str(), "-o", &to_input],
        vec!["render", input.as_str(), "--q", "0 0 0", "-o", &to_input],
        vec!["record", input.as_str(), "-o", &to_input],
    ] {
        let out = kinechain(&args);
        assert!(!out.status.success(), "{args:?}");
        assert!(
            stderr(&out).contains("(the same file): refusing to overwrite it"),
            "{args:?}: {}",
            stderr(&out)
        );
    }
    assert_eq!(
        std::fs::read(&input).unwrap(),
        std::fs::read("robots/planar3.yaml").unwrap()
    );
}

/// A regular file replaced keeps its mode; a new file gets the usual one.
#[test]
fn a_replaced_file_keeps_its_mode() {
    let dir = Scratch::new("out-mode");
    let path = dir.write("out.urdf", "old");
    for mode in [0o600, 0o640, 0o755] {
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode)).unwrap();
        write_file(Path::new(&path), b"new", &[]).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        let now = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(now, mode);
    }
}

/// A directory at the path, a missing directory and a directory that cannot be written are
/// errors naming the path, and leave nothing behind.
#[test]
fn directories_are_errors() {
    let dir = Scratch::new("out-dirs");
    std::fs::create_dir(dir.path("taken")).unwrap();
    let taken = dir.path("taken");
    let e = write_file(Path::new(&taken), b"x", &[]).unwrap_err();
    assert!(matches!(e.problem(), OutputProblem::Directory), "{e:?}");
    for args in writers(&taken) {
        let out = kinechain(&args);
        assert_eq!(
            stderr(&out).trim_end(),
            format!("error: cannot write {taken}: it is a directory"),
            "{args:?}"
        );
    }
    std::fs::create_dir(dir.path("locked")).unwrap();
    std::fs::set_permissions(dir.path("locked"), std::fs::Permissions::from_mode(0o500)).unwrap();
    let locked = dir.path("locked/out.urdf");
    let out = kinechain(&["convert", "robots/planar3.yaml", "-o", &locked]);
    // Root writes anywhere: then the file is simply made.
    let root = std::fs::File::create(dir.path("locked/probe")).is_ok();
    if root {
        assert!(out.status.success(), "{}", stderr(&out));
        std::fs::remove_file(dir.path("locked/probe")).unwrap();
        std::fs::remove_file(&locked).unwrap();
    } else {
        assert!(
            stderr(&out).starts_with(&format!("error: cannot write {locked}")),
            "{}",
            stderr(&out)
        );
    }
    assert_eq!(std::fs::read_dir(dir.path("locked")).unwrap().count(), 0);
    std::fs::set_permissions(dir.path("locked"), std::fs::Permissions::from_mode(0o700)).unwrap();
    let missing = dir.path("missing/out.urdf");
    let out = kinechain(&["convert", "robots/planar3.yaml", "-o", &missing]);
    assert!(
        stderr(&out).starts_with(&format!("error: cannot write {missing}: ")),
        "{}",
        stderr(&out)
    );
}

/// A URDF that kinechain would refuse to read back (over 16 MiB, here from a 5 MiB joint name)
/// is not written, to a file or to standard output, and the limit is named.
#[test]
fn convert_refuses_what_it_would_not_read_back() {
    let dir = Scratch::new("out-large");
    let name = "j".repeat(5 << 20);
    let robot = dir.write(
        "big.yaml",
        format!(
            "name: big\nconvention: standard\njoints:\n- {{name: {name}, type: revolute, a: 1, alpha: 0, d: 0, theta: 0}}\n"
        ),
    );
    let out_path = dir.path("big.urdf");
    for args in [
        vec!["convert", robot.as_str(), "-o", &out_path],
        vec!["convert", robot.as_str()],
    ] {
        let out = kinechain(&args);
        assert!(!out.status.success());
        assert!(out.stdout.is_empty());
        let e = stderr(&out);
        assert!(
            e.contains("more than the 16777216 bytes that kinechain reads back"),
            "{e}"
        );
    }
    assert!(!Path::new(&out_path).exists());
}

/// `compare` of two robots whose joints differ (one renamed) refuses, naming both sides and how
/// to map them; with `--rename` the geometry is the same and the verdict is a pass.
#[test]
fn compare_refuses_a_joint_only_one_robot_has() {
    let dir = Scratch::new("out-compare");
    let text = std::fs::read_to_string("robots/panda.urdf").unwrap();
    let renamed = text.replace("\"panda_joint4\"", "\"elbow_joint\"");
    assert_ne!(renamed, text);
    let b = dir.write("renamed.urdf", renamed);
    let out = kinechain(&["compare", "robots/panda.urdf", &b]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let e = stderr(&out);
    assert!(
        e.contains("only in the first: 'panda_joint4'")
            && e.contains("only in the second: 'elbow_joint'")
            && e.contains("--rename OLD=NEW"),
        "{e}"
    );
    let out = kinechain(&[
        "compare",
        "robots/panda.urdf",
        &b,
        "--rename",
        "panda_joint4=elbow_joint",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    // A rename of a joint that is not there is an error.
    let out = kinechain(&[
        "compare",
        "robots/panda.urdf",
        &b,
        "--rename",
        "panda_joint44=elbow_joint",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("the first robot has no joint 'panda_joint44'"),
        "{}",
        stderr(&out)
    );
    // `verify` refuses a robot whose joints differ from the record's.
    let golden = dir.path("panda.jsonl");
    assert!(
        kinechain(&[
            "record",
            "robots/panda.urdf",
            "--samples",
            "2",
            "-o",
            &golden
        ])
        .status
        .success()
    );
    let out = kinechain(&["verify", &b, &golden]);
    assert_eq!(out.status.code(), Some(2));
    let e = stderr(&out);
    assert!(
        e.contains("missing from the robot: 'panda_joint4'") && e.contains("'elbow_joint'"),
        "{e}"
    );
}

/// A golden file that is an endless stream (`/dev/zero`) fails once a line passes the line cap,
/// not after gigabytes.
#[test]
fn verify_reads_a_bounded_golden_file() {
    let out = kinechain(&["verify", "robots/planar3.yaml", "/dev/zero"]);
    assert_eq!(out.status.code(), Some(2));
    let e = stderr(&out);
    assert!(
        e.contains("line 1 is longer than the 33554432 bytes a golden file's line may be"),
        "{e}"
    );
}

/// Under `--keep-going` a 100 MiB line between two good lines is an error in its place, and the
/// line after it is evaluated: three results in order, while the process holds far less than
/// the line.
#[test]
fn keep_going_skips_an_over_long_line() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_kinechain"))
        .args([
            "fk",
            "robots/planar3.yaml",
            "--batch",
            "-",
            "--keep-going",
            "--link",
            "link3",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(b"[0, 0, 0]\n").unwrap();
    let chunk = vec![b'1'; 1 << 20];
    for _ in 0..100 {
        stdin.write_all(&chunk).unwrap();
    }
    stdin.write_all(b"\n[0.1, 0.2, 0.3]\n").unwrap();
    // Everything but the last 64 KiB (a pipe's buffer) has been read by now.
    let status = std::fs::read_to_string(format!("/proc/{}/status", child.id())).unwrap();
    drop(stdin);
    let out = child.wait_with_output().unwrap();
    let peak_kib: u64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap();
    assert!(peak_kib < 48 << 10, "peak resident memory {peak_kib} KiB");
    assert_eq!(out.status.code(), Some(1));
    let lines: Vec<serde_json::Value> = String::from_utf8(out.stdout.clone())
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 3, "{lines:?}");
    assert_eq!(lines[0]["line"], 1);
    assert_eq!(lines[1]["line"], 2);
    assert!(
        lines[1]["error"]
            .as_str()
            .unwrap()
            .contains("the line is longer than"),
        "{}",
        lines[1]
    );
    assert_eq!(lines[2]["line"], 3);
    assert!(lines[2].get("error").is_none(), "{}", lines[2]);
    assert!(
        stderr(&out).contains("1 line(s) failed"),
        "{}",
        stderr(&out)
    );
}

/// A CSV batch whose header row is quoted as Python's `csv` module writes it (a name with a
/// comma, a name with a quote) reads each column as the joint it names.
#[test]
fn a_quoted_csv_header_is_read() {
    let dir = Scratch::new("out-csv");
    let robot = dir.write(
        "arm.yaml",
        "name: arm\nconvention: standard\njoints:\n\
         - {name: \"j,1\", type: revolute, a: 1, alpha: 0, d: 0, theta: 0}\n\
         - {name: \"j\\\"2\", type: revolute, a: 1, alpha: 0, d: 0, theta: 0}\n\
         - {name: j3, type: revolute, a: 1, alpha: 0, d: 0, theta: 0}\n",
    );
    let batch = dir.write("q.csv", "j3,\"j\"\"2\",\"j,1\"\n0.3,0.2,0.1\n");
    let out = kinechain(&["fk", &robot, "--batch", &batch]);
    assert!(out.status.success(), "{}", stderr(&out));
    let batched = String::from_utf8(out.stdout).unwrap();
    let out = kinechain(&["fk", &robot, "--q", "[0.1, 0.2, 0.3]"]);
    let single: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mut batched: serde_json::Value = serde_json::from_str(batched.trim()).unwrap();
    batched.as_object_mut().unwrap().remove("line");
    assert_eq!(batched, single);
    let bad = dir.write("bad.csv", "j3,\"j\"\"2,\"j,1\"\n0.3,0.2,0.1\n");
    let out = kinechain(&["fk", &robot, "--batch", &bad]);
    assert!(
        stderr(&out).contains("header: column 2: text follows the closing quote"),
        "{}",
        stderr(&out)
    );
}
