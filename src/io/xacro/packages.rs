//! `$(find PKG)` without ROS: the directory of a ROS package, looked up in the directories the
//! user names, then `ROS_PACKAGE_PATH` and `AMENT_PREFIX_PATH`, then by walking up from the file
//! being expanded.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// How deep below a `--package-path` directory packages are searched for.
const SEARCH_DEPTH: usize = 4;
/// Most directory entries read while searching one root (a bound on a search of `/`).
const MAX_ENTRIES: usize = 20_000;

/// Finds packages, remembering what it found.
#[derive(Debug, Default)]
pub(crate) struct Packages {
    /// The user's directories, then those of `ROS_PACKAGE_PATH`.
    roots: Vec<PathBuf>,
    /// `AMENT_PREFIX_PATH` prefixes (a package is `PREFIX/share/PKG`).
    prefixes: Vec<PathBuf>,
    /// The directory of the file being expanded, where the walk up starts.
    start: Option<PathBuf>,
    /// Each root's packages by name, indexed on first use.
    indexed: Vec<Option<HashMap<String, PathBuf>>>,
    found: HashMap<String, PathBuf>,
}

impl Packages {
    pub(crate) fn new(user: &[PathBuf], start: Option<&Path>) -> Packages {
        let mut roots: Vec<PathBuf> = user.to_vec();
        let env_paths = |name: &str| -> Vec<PathBuf> {
            std::env::var_os(name)
                .map(|v| {
                    std::env::split_paths(&v)
                        .filter(|p| !p.as_os_str().is_empty())
                        .collect()
                })
                .unwrap_or_default()
        };
        roots.extend(env_paths("ROS_PACKAGE_PATH"));
        let n = roots.len();
        Packages {
            roots,
            prefixes: env_paths("AMENT_PREFIX_PATH"),
            start: start.map(Path::to_path_buf),
            indexed: vec![None; n],
            found: HashMap::new(),
        }
    }

    /// The directory of package `name`.
    ///
    /// # Errors
    /// A message naming the package and every place looked in.
    pub(crate) fn find(&mut self, name: &str) -> Result<PathBuf, String> {
        if let Some(dir) = self.found.get(name) {
            return Ok(dir.clone());
        }
        let dir = self.search(name).ok_or_else(|| self.not_found(name))?;
        // Absolute, as ROS gives it: the text is joined to paths in other files.
        let dir = dir
            .canonicalize()
            .or_else(|_| std::path::absolute(&dir))
            .unwrap_or(dir);
        self.found.insert(name.to_string(), dir.clone());
        Ok(dir)
    }

    fn search(&mut self, name: &str) -> Option<PathBuf> {
        // The usual layouts first, without reading directories: the root is the package, or
        // holds it under its name.
        for root in &self.roots {
            if package_name(root).as_deref() == Some(name) {
                return Some(root.clone());
            }
            let dir = root.join(name);
            if package_name(&dir).as_deref() == Some(name) {
                return Some(dir);
            }
        }
        for i in 0..self.roots.len() {
            if self.indexed[i].is_none() {
                self.indexed[i] = Some(index(&self.roots[i]));
            }
            if let Some(dir) = self.indexed[i].as_ref().and_then(|m| m.get(name)) {
                return Some(dir.clone());
            }
        }
        for prefix in &self.prefixes {
            let dir = prefix.join("share").join(name);
            if dir.join("package.xml").is_file() {
                return Some(dir);
            }
        }
        // Walking up: a directory that is the package, or holds it one level down (the
        // packages of a cloned repository).
        let mut at = self.start.as_deref().and_then(|s| s.canonicalize().ok());
        while let Some(dir) = at {
            if package_name(&dir).as_deref() == Some(name) {
                return Some(dir);
            }
            let sibling = dir.join(name);
            if package_name(&sibling).as_deref() == Some(name) {
                return Some(sibling);
            }
            at = dir.parent().map(Path::to_path_buf);
        }
        None
    }

    fn not_found(&self, name: &str) -> String {
        let mut places: Vec<String> = self
            .roots
            .iter()
            .map(|r| format!("{} (and below, {SEARCH_DEPTH} levels)", r.display()))
            .collect();
        places.extend(
            self.prefixes
                .iter()
                .map(|p| format!("{}", p.join("share").join(name).display())),
        );
        if let Some(s) = &self.start {
            places.push(format!("the directories above {}", s.display()));
        }
        format!(
            "package '{name}' is not found; looked in: {} (name package directories with --package-path, or set ROS_PACKAGE_PATH)",
            if places.is_empty() {
                "nowhere".to_string()
            } else {
                places.join(", ")
            }
        )
    }
}

/// The name a directory's `package.xml` gives, if it has one.
fn package_name(dir: &Path) -> Option<String> {
    let file = dir.join("package.xml");
    let meta = std::fs::metadata(&file).ok()?;
    if !meta.is_file() || meta.len() > 1 << 20 {
        return None;
    }
    let text = std::fs::read_to_string(&file).ok()?;
    let doc = roxmltree::Document::parse(&text).ok()?;
    doc.root_element()
        .children()
        .find(|c| c.has_tag_name("name"))
        .and_then(|n| n.text())
        .map(|t| t.trim().to_string())
}

/// The packages under `root` to [`SEARCH_DEPTH`] levels: each directory with a `package.xml`
/// under the name it gives, and each directory under its own name (the first found of each
/// name, breadth first, `package.xml` names first).
fn index(root: &Path) -> HashMap<String, PathBuf> {
    let mut by_manifest = HashMap::new();
    let mut by_dir = HashMap::new();
    let mut level = vec![root.to_path_buf()];
    let mut entries = 0;
    for _ in 0..=SEARCH_DEPTH {
        let mut next = Vec::new();
        for dir in &level {
            if let Some(name) = package_name(dir) {
                by_manifest.entry(name).or_insert_with(|| dir.clone());
            }
            if let Some(n) = dir.file_name().and_then(|n| n.to_str()) {
                by_dir.entry(n.to_string()).or_insert_with(|| dir.clone());
            }
            let Ok(read) = std::fs::read_dir(dir) else {
                continue;
            };
            let mut subdirs: Vec<PathBuf> = read
                .filter_map(Result::ok)
                .take(MAX_ENTRIES.saturating_sub(entries))
                .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
                .filter(|e| !e.file_name().to_string_lossy().starts_with('.'))
                .map(|e| e.path())
                .collect();
            entries += subdirs.len();
            subdirs.sort();
            next.extend(subdirs);
        }
        level = next;
    }
    for (k, v) in by_dir {
        by_manifest.entry(k).or_insert(v);
    }
    by_manifest
}
