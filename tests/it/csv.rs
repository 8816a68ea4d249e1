//! `fk --format csv`: a header row and one row per configuration, the numbers of the JSON output,
//! the column names of the Python package's tables.

use std::io::Write;
use std::process::{Command, Stdio};

fn kinechain(args: &[&str], input: &str) -> (i32, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_kinechain"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

/// The numbers of one link in a JSON result: position then quaternion w, x, y, z.
fn json_values(line: &str, link: &str) -> Vec<f64> {
    let v: serde_json::Value = serde_json::from_str(line).unwrap();
    let l = &v["links"][link];
    let mut out: Vec<f64> = l["position"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    for c in ["w", "x", "y", "z"] {
        out.push(l["quaternion"][c].as_f64().unwrap());
    }
    out
}

#[test]
fn rows_hold_the_numbers_of_the_json_output() {
    let lines = "[0.1, -1.2, 1.4, -0.2, 1.5, 0.3]\n\n[0, 0, 0, 0, 0, 0]\n[-2, -1, 0.5, 1, 2, 3]\n";
    let common = [
        "fk",
        "robots/ur5.yaml",
        "--batch",
        "-",
        "--link",
        "tool0",
        "--link",
        "forearm",
        "--orientation",
        "quat",
    ];
    let (code, csv, err) = kinechain(&[&common[..], &["--format", "csv"]].concat(), lines);
    assert_eq!(code, 0, "{err}");
    let (_, json, _) = kinechain(&common, lines);
    let rows: Vec<&str> = csv.lines().collect();
    let mut header = vec!["line".to_string()];
    for link in ["tool0", "forearm"] {
        for c in ["x", "y", "z", "qw", "qx", "qy", "qz"] {
            header.push(format!("{link}.{c}"));
        }
    }
    header.push("error".into());
    assert_eq!(rows[0], header.join(","));
    assert_eq!(rows.len(), 4);
    for (row, json) in rows[1..].iter().zip(json.lines()) {
        let fields: Vec<&str> = row.split(',').collect();
        let line: serde_json::Value = serde_json::from_str(json).unwrap();
        assert_eq!(fields[0], line["line"].to_string());
        let numbers: Vec<f64> = fields[1..15].iter().map(|f| f.parse().unwrap()).collect();
        let mut want = json_values(json, "tool0");
        want.extend(json_values(json, "forearm"));
        // The same bits: each number reads back to the f64 the JSON printed.
        assert_eq!(numbers, want, "{row}");
        assert_eq!(fields[15], "");
    }
    // One configuration: no line or error column.
    let (code, out, _) = kinechain(
        &[
            "fk",
            "robots/planar3.yaml",
            "--q",
            "0.3 -0.2 0.5",
            "--link",
            "link3",
            "--orientation",
            "rpy",
            "--format",
            "csv",
        ],
        "",
    );
    assert_eq!(code, 0);
    assert_eq!(
        out.lines().next(),
        Some("link3.x,link3.y,link3.z,link3.roll,link3.pitch,link3.yaw")
    );
    assert_eq!(out.lines().count(), 2);
}

#[test]
fn failed_lines_keep_their_row_and_undefined_orientations_are_empty() {
    let (code, out, _) = kinechain(
        &[
            "fk",
            "robots/planar3.yaml",
            "--batch",
            "-",
            "--format",
            "csv",
            "--keep-going",
            "--link",
            "link3",
            "--orientation",
            "zxz",
        ],
        "[0, 0, 0]\n[9, 9, 9]\n",
    );
    assert_eq!(code, 1);
    let rows: Vec<&str> = out.lines().collect();
    // At q = 0 the z-x-z angles are undefined (θ = 0): empty fields, not numbers.
    assert_eq!(rows[1], "1,9.0,0.0,0.0,,,,");
    assert!(
        rows[2].starts_with("2,,,,,,,\"joint 'j1' = 9 is outside its limits"),
        "{}",
        rows[2]
    );
    assert_eq!(
        rows[2].matches(',').count(),
        rows[1].matches(',').count() + rows[2].split('"').nth(1).unwrap().matches(',').count()
    );
}

#[test]
fn what_csv_cannot_print_is_an_error() {
    for args in [
        &[
            "fk",
            "robots/planar3.yaml",
            "--q",
            "0 0 0",
            "--qd",
            "0 0 0",
            "--format",
            "csv",
        ][..],
        &[
            "fk",
            "robots/planar3.yaml",
            "--q",
            "0 0 0",
            "--point",
            "link3:0,0,0",
            "--format",
            "csv",
        ],
        &[
            "fk",
            "robots/planar3.yaml",
            "--q",
            "0 0 0",
            "--jacobian",
            "link3",
            "--format",
            "csv",
        ],
        &["info", "robots/planar3.yaml", "--format", "csv"],
    ] {
        let (code, out, err) = kinechain(args, "");
        assert_ne!(code, 0, "{args:?}");
        assert!(err.starts_with("error: --format csv "), "{err}");
        assert!(out.is_empty() || args[0] == "fk", "{out}");
    }
    // A batch line with rates.
    let (code, _, err) = kinechain(
        &[
            "fk",
            "robots/planar3.yaml",
            "--batch",
            "-",
            "--format",
            "csv",
        ],
        "{\"q\": [0, 0, 0], \"qd\": [0, 0, 0]}\n",
    );
    assert_ne!(code, 0);
    assert!(
        err.contains("velocities and accelerations need json or table"),
        "{err}"
    );
}
