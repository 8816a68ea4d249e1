//! `kinechain view` (`kinechain::io::view`): the page carries the tree and the rows it was given,
//! and refuses what it cannot draw. (The Python tests open pages in headless Chromium and check
//! the poses the page computes against kinechain's.)

use crate::common::{Scratch, repo_chain};
use kinechain::io::view::{ViewError, page};

/// The JSON model a page carries.
fn model(html: &str) -> serde_json::Value {
    let start =
        html.find("type=\"application/json\">").unwrap() + "type=\"application/json\">".len();
    let end = start + html[start..].find("</script>").unwrap();
    serde_json::from_str(&html[start..end].replace("<\\/", "</")).unwrap()
}

#[test]
fn a_page_carries_the_tree_and_every_row() {
    let chain = repo_chain("robots/panda.urdf");
    let q = chain.random_configurations(3, 5, (-1.0, 1.0));
    let html = page(&chain, &q, Some(&[10, 20, 30])).unwrap();
    assert!(
        html.starts_with("<!doctype html>")
            && !html.contains("http://")
            && !html.contains("https://")
    );
    let m = model(&html);
    assert_eq!(m["links"].as_array().unwrap().len(), chain.links().len());
    assert_eq!(m["joints"].as_array().unwrap().len(), chain.joints().len());
    let rows: Vec<f64> = m["frames"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|r| r.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
        .collect();
    // Written with serde_json's shortest round trip: the same bits back.
    assert_eq!(rows, q);
    assert_eq!(m["times"], serde_json::json!([10, 20, 30]));
    let finger2 = m["joints"]
        .as_array()
        .unwrap()
        .iter()
        .find(|j| j["name"] == "panda_finger_joint2")
        .unwrap();
    assert_eq!(finger2["mimic"]["q"], 7);
}

#[test]
fn what_the_page_cannot_draw_is_an_error_naming_it() {
    let chain = repo_chain("robots/ur5.yaml");
    assert!(matches!(
        page(&chain, &[0.0; 5], None),
        Err(ViewError::Row { .. })
    ));
    let mut q = vec![0.0; 6];
    q[2] = f64::INFINITY;
    let e = page(&chain, &q, None).unwrap_err();
    assert!(e.to_string().contains("q[2]"), "{e}");
    assert!(matches!(
        page(&chain, &[0.0; 12], Some(&[1])),
        Err(ViewError::Times { times: 1, rows: 2 })
    ));
    let g1 = repo_chain("robots/g1.urdf+floating");
    let e = page(&g1, &g1.neutral(), None).unwrap_err();
    assert!(
        matches!(
            &e,
            ViewError::Joint {
                kind: "floating",
                ..
            }
        ),
        "{e}"
    );
}

/// `kinechain view ROBOT --q Q -o page.html`: the page; never over the robot file.
#[cfg(feature = "cli")]
#[test]
fn the_command_line_writes_a_page() {
    use std::process::Command;
    let scratch = Scratch::new("view-cli");
    let out = scratch.path("puma.html");
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_kinechain"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    };
    let done = run(&[
        "view",
        "robots/puma560.yaml",
        "--q",
        "[0, -0.5, 0.3, 0, 0.4, 0]",
        "-o",
        &out,
    ]);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let m = model(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(m["frames"][0][1], -0.5);
    let robot = scratch.path("puma560.yaml");
    std::fs::copy("robots/puma560.yaml", &robot).unwrap();
    let before = std::fs::read(&robot).unwrap();
    let refused = run(&["view", &robot, "-o", &robot]);
    assert!(!refused.status.success());
    assert_eq!(std::fs::read(&robot).unwrap(), before);
}
