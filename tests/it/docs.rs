//! The README and `docs/` say what the program does: every command shown with its output is
//! run here and must print that output, the quick start is two commands, links lead to files
//! that exist, and the README stays short. (Their Rust examples are doc tests, see `src/lib.rs`.)
//!
//! A shown command is a line `$ CMD` (continued by a trailing `\`) in a ```` ```console ````
//! block, its output the lines up to the next `$` line. A command ending in `# timings vary`
//! prints measurements: its output is compared with numbers, ISA names and spacing set aside,
//! each shown line beginning a printed one, in order (a host may print more).

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and every page of docs/.
fn pages() -> Vec<PathBuf> {
    let mut pages = vec![root().join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
}

/// The fenced blocks of a page: (info string, first line number, lines).
fn blocks(text: &str) -> Vec<(String, usize, Vec<String>)> {
    let mut out = Vec::new();
    let mut open: Option<(String, usize, Vec<String>)> = None;
    for (n, line) in text.lines().enumerate() {
        if let Some(info) = line.strip_prefix("```") {
            match open.take() {
                Some(block) => out.push(block),
                None => open = Some((info.trim().to_string(), n + 2, Vec::new())),
            }
        } else if let Some((_, _, lines)) = &mut open {
            lines.push(line.to_string());
        }
    }
    assert!(open.is_none(), "a code block is not closed");
    out
}

/// The commands of a console block and the output shown for each.
fn commands(lines: &[String]) -> Vec<(String, Vec<String>)> {
    let mut out: Vec<(String, Vec<String>)> = Vec::new();
    let mut continued = false;
    for line in lines {
        if continued {
            let (cmd, _) = out.last_mut().unwrap();
            cmd.push_str(line.trim_start());
            continued = cmd.ends_with('\\');
            if continued {
                cmd.pop();
            }
        } else if let Some(cmd) = line.strip_prefix("$ ") {
            let mut cmd = cmd.to_string();
            continued = cmd.ends_with('\\');
            if continued {
                cmd.pop();
            }
            out.push((cmd, Vec::new()));
        } else {
            let (_, shown) = out.last_mut().expect("output before any command");
            shown.push(line.clone());
        }
    }
    out
}

/// What `cmd` prints (standard output, then standard error), run by `sh` in the repository with
/// the `kinechain` built for these tests first on the path.
fn run(cmd: &str) -> (bool, String) {
    let bin = Path::new(env!("CARGO_BIN_EXE_kinechain")).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = Command::new("sh")
        .args(["-c", cmd])
        .current_dir(root())
        .env("PATH", path)
        .output()
        .unwrap();
    let mut text = String::from_utf8(out.stdout).unwrap();
    text.push_str(&String::from_utf8(out.stderr).unwrap());
    (out.status.success(), text)
}

/// A line of measurements with what varies set aside: every word with a digit in it, the
/// kernels' instruction set, the spacing.
fn shape(line: &str) -> String {
    line.split_whitespace()
        .map(|w| {
            if w.chars().any(|c| c.is_ascii_digit()) {
                "N"
            } else if ["avx512", "avx2", "baseline"].contains(&w) {
                "ISA"
            } else {
                w
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn shown_commands_print_what_is_shown() {
    let mut checked = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let name = page.strip_prefix(root()).unwrap().display().to_string();
        for (info, first, lines) in blocks(&text) {
            if info != "console" {
                // Output shown elsewhere would not be checked.
                for (i, line) in lines.iter().enumerate() {
                    assert!(
                        !line.starts_with("$ "),
                        "{name}:{}: a command with output outside a console block",
                        first + i
                    );
                }
                continue;
            }
            for (cmd, shown) in commands(&lines) {
                let (vary, cmd) = match cmd.strip_suffix("# timings vary") {
                    Some(c) => (true, c.trim_end().to_string()),
                    None => (false, cmd),
                };
                let (ok, printed) = run(&cmd);
                assert!(ok, "{name}:{first}: `{cmd}` failed:\n{printed}");
                let printed: Vec<&str> = printed.lines().collect();
                if vary {
                    let got: Vec<String> = printed.iter().map(|l| shape(l)).collect();
                    let want: Vec<String> = shown.iter().map(|l| shape(l)).collect();
                    // Hosts add rows (an Intel CPU's 512-bit `sin`/`cos` row) and details: each
                    // shown line begins a printed line, in order.
                    let mut rest = got.iter();
                    for line in &want {
                        assert!(
                            rest.any(|g| g.starts_with(line.as_str())),
                            "{name}:{first}: `{cmd}` printed no line like {line:?} in order:\n{got:#?}"
                        );
                    }
                } else {
                    assert_eq!(printed, shown, "{name}:{first}: `{cmd}`");
                }
                checked += 1;
            }
        }
    }
    assert!(checked >= 5, "only {checked} commands found");
}

#[test]
fn the_quick_start_is_two_commands_that_work() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let start = readme.find("## Quick start").expect("a quick start");
    let (info, _, lines) = blocks(&readme[start..]).remove(0);
    assert_eq!(info, "sh");
    assert_eq!(lines.len(), 2, "{lines:?}");
    // The second is the test command CI runs.
    let ci = std::fs::read_to_string(root().join(".ci/run")).unwrap();
    assert!(
        ci.lines().any(|l| l.trim() == lines[1]),
        "{} is not in .ci/run",
        lines[1]
    );
    // The first runs the command line on a bundled robot (here on the built binary).
    let args = lines[0]
        .strip_prefix("cargo run --release -- ")
        .expect("cargo run --release -- ...");
    let (ok, printed) = run(&format!("kinechain {args}"));
    assert!(ok, "{printed}");
    assert!(printed.starts_with("link "), "{printed}");
    assert!(printed.lines().count() > 5, "{printed}");
}

#[test]
fn links_lead_to_files_that_exist() {
    let mut problems = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let dir = page.parent().unwrap();
        for (i, _) in text.match_indices("](") {
            let target = &text[i + 2..];
            let end = target.find(')').unwrap_or(target.len());
            let target = &target[..end];
            let file = target.split('#').next().unwrap();
            if file.is_empty() || file.contains("://") || file.contains(' ') {
                continue;
            }
            if !dir.join(file).exists() {
                problems.push(format!("{}: {target}", page.display()));
            }
        }
    }
    assert!(
        problems.is_empty(),
        "links to missing files:\n{}",
        problems.join("\n")
    );
}

#[test]
fn the_readme_is_short() {
    let size = std::fs::metadata(root().join("README.md")).unwrap().len();
    assert!(size <= 10 * 1024, "README.md is {size} bytes");
}
