//! The layering of `src/`: each top-level module uses only the modules below it, so that their
//! imports never run in a circle, and no file is longer than the house allows without saying why.
//!
//! The layers, bottom to top: `orientation` (orientation coordinates, sec. 2.1–2.8), `model` (the
//! immutable chain), `eval` (kernels and evaluation), `io` (files in and out), then the tooling
//! beside them (`measure`, `reference`), the crate's umbrella `error`, and `cli` on top. A file
//! may use its own layer and the layers below it. References in comments and in a file's test
//! module (`#[cfg(test)] mod tests`, at its end) are not imports and are not counted.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Each top-level module and the modules it may use.
const ALLOWED: [(&str, &[&str]); 9] = [
    ("orientation", &[]),
    ("model", &["orientation"]),
    ("eval", &["orientation", "model"]),
    ("io", &["orientation", "model", "eval"]),
    ("measure", &["orientation", "model", "eval"]),
    ("reference", &["orientation", "model", "eval", "measure"]),
    (
        "regression",
        &["orientation", "model", "eval", "io", "measure"],
    ),
    (
        "error",
        &[
            "orientation",
            "model",
            "eval",
            "io",
            "measure",
            "regression",
        ],
    ),
    (
        "cli",
        &[
            "orientation",
            "model",
            "eval",
            "io",
            "measure",
            "reference",
            "regression",
            "error",
        ],
    ),
];

/// The longest a source file may be without a line near its top saying why it is longer.
const MAX_LINES: usize = 800;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The top-level module a file of `src/` belongs to (`None` for `lib.rs` and `main.rs`).
fn layer(src: &Path, file: &Path) -> Option<String> {
    let relative = file.strip_prefix(src).unwrap();
    let first = relative
        .components()
        .next()?
        .as_os_str()
        .to_str()?
        .to_string();
    match first.strip_suffix(".rs") {
        Some("lib" | "main") => None,
        Some(stem) => Some(stem.to_string()),
        None => Some(first),
    }
}

/// The code of a file without comments and without its test module.
fn code(text: &str) -> String {
    let mut out = String::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("#[cfg(test)]")
            && lines
                .peek()
                .is_some_and(|next| next.trim_start().starts_with("mod tests"))
        {
            break;
        }
        let without_comment = match line.find("//") {
            Some(i) => &line[..i],
            None => line,
        };
        out.push_str(without_comment);
        out.push('\n');
    }
    out
}

/// The names that follow `crate::` in `code`.
fn crate_paths(code: &str) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + "crate::".len()..];
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        found.insert(name);
    }
    found
}

#[test]
fn layers_use_only_the_layers_below_them() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut problems = Vec::new();
    let mut seen = BTreeSet::new();
    for file in &files {
        let Some(from) = layer(&src, file) else {
            continue;
        };
        let Some((_, allowed)) = ALLOWED.iter().find(|(l, _)| *l == from) else {
            problems.push(format!("{}: not in a known layer ({from})", file.display()));
            continue;
        };
        seen.insert(from.clone());
        let text = std::fs::read_to_string(file).unwrap();
        for used in crate_paths(&code(&text)) {
            if used == from || allowed.contains(&used.as_str()) {
                continue;
            }
            let why = if ALLOWED.iter().any(|(l, _)| *l == used) {
                "a layer it may not use".to_string()
            } else {
                "an item of the crate root (name its module instead)".to_string()
            };
            problems.push(format!(
                "{}: {from} uses crate::{used}, {why}",
                file.strip_prefix(&src).unwrap().display()
            ));
        }
        // `super::` from a layer's `mod.rs` would reach the crate root.
        if file.file_name().is_some_and(|n| n == "mod.rs")
            && file.parent() == Some(&src.join(&from))
            && code(&text).contains("super::")
        {
            problems.push(format!("{}: uses super:: (the crate root)", file.display()));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert_eq!(seen.len(), ALLOWED.len(), "layers found: {seen:?}");
}

#[test]
fn long_files_say_why() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut problems = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        let lines = text.lines().count();
        let head: Vec<&str> = text.lines().take(30).collect();
        if lines > MAX_LINES && !head.iter().any(|l| l.contains("Longer than")) {
            problems.push(format!("{}: {lines} lines", file.display()));
        }
    }
    assert!(
        problems.is_empty(),
        "files over {MAX_LINES} lines without a `Longer than ...` line near the top saying why:\n{}",
        problems.join("\n")
    );
}
