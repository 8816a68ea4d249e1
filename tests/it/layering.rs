//! The layering of `src/`: each top-level module uses only the modules below it; no two files
//! import one another, directly or around a circle; inside `eval`, each file uses only the rooms
//! listed before it in [`EVAL_ORDER`]; every dispatched kernel's generic function is written out
//! under its own name; and no file is longer than the house allows without saying why.
//!
//! A file's imports are every `crate::`, `super::` and `self::` path in its code, and every path
//! through a child module it declares (`mod fk;` then `fk::run`), each resolved to the deepest
//! module it names: `crate::eval::simd::traits::Arith` is a use of `eval::simd::traits`, and
//! `use super::*` in `cli/fk.rs` a use of `cli` (its `mod.rs`).
//!
//! The layers, bottom to top: `orientation` (orientation coordinates, sec. 2.1–2.8), `model` (the
//! immutable chain), `eval` (kernels and evaluation), `io` (files in and out), then the tooling
//! beside them (`measure`, `reference`), the crate's umbrella `error`, and `cli` on top. A file
//! may use its own layer and the layers below it. References in comments and in a file's test
//! module (`#[cfg(test)] mod tests`, at its end) are not imports and are not counted.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Each top-level module and the modules it may use.
const ALLOWED: [(&str, &[&str]); 10] = [
    ("orientation", &[]),
    ("model", &["orientation"]),
    ("eval", &["orientation", "model"]),
    ("io", &["orientation", "model", "eval"]),
    ("ik", &["orientation", "model", "eval"]),
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
            "ik",
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
            "ik",
        ],
    ),
];

/// The modules of `eval`, bottom to top: each may use only modules listed before it (its own
/// room's `mod.rs` only declares and re-exports its files, so it comes after them).
const EVAL_ORDER: &[&str] = &[
    "eval::error",
    "eval::simd::lanes",
    "eval::simd::traits",
    "eval::simd::trig",
    "eval::simd::portable",
    "eval::simd::fused",
    "eval::simd::isa",
    "eval::simd",
    "eval::layout::stored",
    "eval::layout::body",
    "eval::layout::limits",
    "eval::layout::chain",
    "eval::layout",
    "eval::kernel::frame",
    "eval::kernel::joint",
    "eval::kernel::ball",
    "eval::kernel::floating",
    "eval::kernel::pose_lanes",
    "eval::kernel::pose_columns",
    "eval::kernel::rates_columns",
    "eval::kernel::rates_lanes",
    "eval::kernel",
    "eval::compile",
    "eval::checks",
    "eval::layouts",
    "eval::sampling",
    "eval::link_rates",
    "eval::jacobian",
    "eval::single::data",
    "eval::single::results",
    "eval::single::kinematics",
    "eval::single",
    "eval::batch::claims",
    "eval::batch::data",
    "eval::batch::threads",
    "eval::batch::blocks",
    "eval::batch::poses",
    "eval::batch::matrices",
    "eval::batch::fold",
    "eval::batch::macros",
    "eval::batch::rates",
    "eval::batch::jacobians",
    "eval::batch::lanes32",
    "eval::batch::single_precision",
    "eval::batch::arrays",
    "eval::batch",
    "eval",
];

/// Rooms of `eval` that use nothing of the crate outside themselves.
const SELF_CONTAINED: &[&str] = &["eval::error", "eval::simd"];

/// Sibling rooms that share the rooms below them and never use each other.
const SIBLINGS: &[(&str, &str)] = &[("eval::single", "eval::batch")];

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

/// The module path of a file of `src/` (`["eval", "simd", "lanes"]`; empty for `lib.rs`),
/// `None` for `main.rs` (another crate) and for test modules kept in files of their own.
fn module_of(src: &Path, file: &Path) -> Option<Vec<String>> {
    let relative = file.strip_prefix(src).unwrap().with_extension("");
    let mut segments: Vec<String> = relative
        .components()
        .map(|c| c.as_os_str().to_str().unwrap().to_string())
        .collect();
    match segments.last().map(String::as_str) {
        Some("main") if segments.len() == 1 => return None,
        Some("tests") => return None,
        Some("mod") => {
            segments.pop();
        }
        Some("lib") if segments.len() == 1 => segments.clear(),
        _ => {}
    }
    Some(segments)
}

/// `code` without string and character literals (their text is not a path).
fn without_literals(code: &str) -> String {
    let chars: Vec<char> = code.chars().collect();
    let mut out = String::with_capacity(code.len());
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == '"' {
            // A raw string's `#`s are not needed here: no source file writes `"` inside one.
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                i += if chars[i] == '\\' { 2 } else { 1 };
            }
            out.push_str("\"\"");
            i += 1;
        } else if c == '\'' && i + 2 < chars.len() && (chars[i + 2] == '\'' || chars[i + 1] == '\\')
        {
            let end = (i + 2..chars.len())
                .find(|&j| chars[j] == '\'' && j > i + 1)
                .unwrap();
            out.push_str("' '");
            i = end + 1;
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// The paths of a use tree starting at `at` (`a::b::{c, d::e}` gives `a::b::c` and
/// `a::b::d::e`), as segments; `self` inside braces is the prefix itself, `*` the prefix.
fn use_tree(code: &[char], at: &mut usize) -> Vec<Vec<String>> {
    let skip_space = |at: &mut usize| {
        while *at < code.len() && code[*at].is_whitespace() {
            *at += 1;
        }
    };
    let mut prefix = Vec::new();
    loop {
        skip_space(at);
        if *at < code.len() && code[*at] == '{' {
            *at += 1;
            let mut paths = Vec::new();
            loop {
                skip_space(at);
                if *at >= code.len() || code[*at] == '}' {
                    *at += 1;
                    break;
                }
                for tail in use_tree(code, at) {
                    paths.push(prefix.iter().cloned().chain(tail).collect());
                }
                skip_space(at);
                if *at < code.len() && code[*at] == ',' {
                    *at += 1;
                }
            }
            return paths;
        }
        if *at < code.len() && code[*at] == '*' {
            *at += 1;
            return vec![prefix];
        }
        let start = *at;
        while *at < code.len() && is_ident(code[*at]) {
            *at += 1;
        }
        let segment: String = code[start..*at].iter().collect();
        if segment.is_empty() {
            return vec![prefix];
        }
        if segment != "self" || prefix.is_empty() {
            prefix.push(segment);
        }
        if code[*at..].starts_with(&[':', ':']) {
            *at += 2;
        } else {
            return vec![prefix];
        }
    }
}

/// The modules a file of module `this` uses, out of `modules`.
fn uses(this: &[String], text: &str, modules: &BTreeSet<Vec<String>>) -> BTreeSet<Vec<String>> {
    let code: Vec<char> = without_literals(&code(text)).chars().collect();
    let children: Vec<String> = text
        .lines()
        .filter_map(|l| {
            let l = l.trim_start();
            let l = l
                .strip_prefix("pub(crate) ")
                .or_else(|| l.strip_prefix("pub "))
                .unwrap_or(l);
            let name = l.strip_prefix("mod ")?.strip_suffix(';')?;
            Some(name.to_string())
        })
        .collect();
    let mut found = BTreeSet::new();
    for i in 0..code.len() {
        if i > 0 && (is_ident(code[i - 1]) || code[i - 1] == ':') {
            continue;
        }
        let word: String = code[i..].iter().take_while(|c| is_ident(**c)).collect();
        let (base, from) = match word.as_str() {
            "crate" => (Vec::new(), i + word.len()),
            "self" => (this.to_vec(), i + word.len()),
            "super" => {
                let mut base = this.to_vec();
                let mut at = i;
                while code[at..].starts_with(&['s', 'u', 'p', 'e', 'r', ':', ':']) {
                    base.pop();
                    at += "super::".len();
                }
                (base, at - 2)
            }
            w if children.iter().any(|c| c == w) => (this.to_vec(), i),
            _ => continue,
        };
        // A path goes on after its first word (`crate::x`, `fk::run`); a bare child name is a
        // value or a declaration, not a path.
        if !code[i + word.len()..].starts_with(&[':', ':']) {
            continue;
        }
        let mut at = from;
        if code[at..].starts_with(&[':', ':']) {
            at += 2;
        }
        for tail in use_tree(&code, &mut at) {
            let full: Vec<String> = base.iter().cloned().chain(tail).collect();
            let resolved = (0..=full.len())
                .rev()
                .map(|n| full[..n].to_vec())
                .find(|m| modules.contains(m));
            if let Some(m) = resolved
                && m != this
            {
                found.insert(m);
            }
        }
    }
    found
}

/// Every file's module and the modules it uses.
fn import_graph() -> Vec<(Vec<String>, PathBuf, BTreeSet<Vec<String>>)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let files: Vec<(Vec<String>, PathBuf)> = files
        .into_iter()
        .filter_map(|f| {
            Some((
                module_of(&src, &f)?,
                f.strip_prefix(&src).unwrap().to_path_buf(),
            ))
        })
        .collect();
    let modules: BTreeSet<Vec<String>> = files.iter().map(|(m, _)| m.clone()).collect();
    files
        .into_iter()
        .map(|(m, f)| {
            let text = std::fs::read_to_string(src.join(&f)).unwrap();
            let used = uses(&m, &text, &modules);
            (m, f, used)
        })
        .collect()
}

fn name(m: &[String]) -> String {
    if m.is_empty() {
        "crate".into()
    } else {
        m.join("::")
    }
}

/// Whether `m` is `room` or inside it.
fn within(m: &str, room: &str) -> bool {
    m == room || m.starts_with(&format!("{room}::"))
}

#[test]
fn the_import_graph_sees_what_it_should() {
    let graph = import_graph();
    let uses_of = |m: &str| {
        graph
            .iter()
            .find(|(n, _, _)| name(n) == m)
            .map(|(_, _, u)| u.iter().map(|u| name(u)).collect::<BTreeSet<_>>())
            .unwrap()
    };
    // A group import, a `self` inside braces and a path through a declared child.
    assert!(uses_of("eval::batch::rates").contains("eval::simd::traits"));
    assert!(uses_of("eval").contains("eval::single::kinematics"));
    assert!(uses_of("cli").contains("cli::run"));
    assert!(
        !uses_of("eval::simd::lanes")
            .iter()
            .any(|u| u != "eval::simd::lanes")
    );
}

#[test]
fn no_files_import_each_other_around_a_circle() {
    let graph = import_graph();
    let index = |m: &Vec<String>| graph.iter().position(|(n, _, _)| n == m);
    let reaches = |from: usize, to: usize| {
        let mut seen = vec![false; graph.len()];
        let mut stack = vec![from];
        while let Some(k) = stack.pop() {
            if k == to {
                return true;
            }
            if std::mem::replace(&mut seen[k], true) {
                continue;
            }
            stack.extend(graph[k].2.iter().filter_map(index));
        }
        false
    };
    let mut circles = Vec::new();
    for (k, (m, file, used)) in graph.iter().enumerate() {
        for u in used {
            if let Some(j) = index(u)
                && reaches(j, k)
            {
                circles.push(format!(
                    "{}: uses {}, which leads back to {}",
                    file.display(),
                    name(u),
                    name(m)
                ));
            }
        }
    }
    assert!(circles.is_empty(), "{}", circles.join("\n"));
}

#[test]
fn eval_rooms_use_only_the_rooms_before_them() {
    let graph = import_graph();
    let mut problems = Vec::new();
    for (m, file, used) in &graph {
        let m = name(m);
        if !within(&m, "eval") {
            continue;
        }
        let Some(rank) = EVAL_ORDER.iter().position(|e| *e == m) else {
            problems.push(format!("{}: {m} is not in EVAL_ORDER", file.display()));
            continue;
        };
        for u in used.iter().map(|u| name(u)) {
            let why = if let Some(room) = SELF_CONTAINED.iter().find(|r| within(&m, r))
                && !within(&u, room)
            {
                format!("{room} uses nothing outside itself")
            } else if let Some((a, b)) = SIBLINGS
                .iter()
                .find(|(a, b)| (within(&m, a) && within(&u, b)) || (within(&m, b) && within(&u, a)))
            {
                format!("{a} and {b} never use each other")
            } else if !within(&u, "eval") {
                continue;
            } else if EVAL_ORDER
                .iter()
                .position(|e| *e == u)
                .is_none_or(|r| r >= rank)
            {
                "it is not listed before it in EVAL_ORDER".to_string()
            } else {
                continue;
            };
            problems.push(format!("{}: {m} uses {u}, but {why}", file.display()));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Each `fma_dispatch!` invocation in `text`: the function it defines and the generic function
/// it calls.
fn dispatched(text: &str) -> Vec<(String, String)> {
    let mut found = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find("fma_dispatch!(") {
        rest = &rest[i + "fma_dispatch!(".len()..];
        let mut depth = 1;
        let end = rest
            .char_indices()
            .find(|&(_, c)| {
                depth += match c {
                    '(' => 1,
                    ')' => -1,
                    _ => 0,
                };
                depth == 0
            })
            .unwrap()
            .0;
        let call = &rest[..end];
        let word_after = |key: &str| -> Option<String> {
            let at = call.find(key)? + key.len();
            Some(
                call[at..]
                    .trim_start()
                    .chars()
                    .take_while(|c| is_ident(*c))
                    .collect(),
            )
        };
        // The macro's own arms (`$generic`) are not invocations.
        if let (Some(function), Some(generic)) = (word_after("fn "), word_after("=>"))
            && !generic.is_empty()
        {
            found.push((function, generic));
        }
        rest = &rest[end..];
    }
    found
}

#[test]
fn every_dispatched_kernel_is_written_out_under_its_own_name() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let texts: Vec<String> = files
        .iter()
        .map(|f| std::fs::read_to_string(f).unwrap())
        .collect();
    let all = texts.join("\n");
    let mut count = 0;
    let mut problems = Vec::new();
    for (function, generic) in texts.iter().flat_map(|t| dispatched(t)) {
        count += 1;
        if !all.contains(&format!("fn {generic}<")) {
            problems.push(format!(
                "{function} dispatches to {generic}, which no `fn {generic}<` defines"
            ));
        }
    }
    // `poses_all_admitted` is the first call of `forward_kinematics`.
    assert!(
        all.contains("fn poses_all_admitted("),
        "the dispatcher is not found by its name"
    );
    assert!(count >= 20, "{count} dispatched functions found");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
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
        // A test module kept in a file of its own.
        if file.file_name().is_some_and(|n| n == "tests.rs") {
            continue;
        }
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
