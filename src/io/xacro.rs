//! xacro without ROS: vendor robot descriptions (`.urdf.xacro`) expanded in Rust, as ROS 2's
//! `xacro` expands them, into URDF that the URDF reader loads.
//!
//! The `${…}` language is a closed subset of Python's expressions ([`expr`](self)): no imports,
//! no attribute access beyond a fixed set of functions and methods, no file access except
//! includes and `xacro.load_yaml` of files inside the allowed directories (the main file's
//! directory and package, `--package-path` directories and packages found by `$(find)`), and
//! bounded recursion, output and work.

mod dom;
mod expand;
mod expr;
mod packages;
mod value;
mod yaml;

use std::path::{Path, PathBuf};

/// What a xacro file is expanded with: its arguments and where its packages are.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct XacroOptions {
    /// `NAME:=VALUE` arguments, as `xacro` takes them on its command line (they override
    /// `<xacro:arg>` defaults).
    pub args: Vec<(String, String)>,
    /// Directories that hold ROS packages (searched a few levels deep for a `package.xml` that
    /// names the package, or a directory of its name), tried first by `$(find PKG)`.
    pub package_paths: Vec<PathBuf>,
}

impl XacroOptions {
    /// With argument `name` set to `value`.
    #[must_use]
    pub fn with_arg(mut self, name: impl Into<String>, value: impl Into<String>) -> Self {
        self.args.push((name.into(), value.into()));
        self
    }

    /// With `dir` searched for packages.
    #[must_use]
    pub fn with_package_path(mut self, dir: impl Into<PathBuf>) -> Self {
        self.package_paths.push(dir.into());
        self
    }
}

/// An expanded document.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct Expansion {
    /// The URDF text.
    pub urdf: String,
    /// What the expansion noted without failing (`xacro.warning` calls, skipped non-kinematic
    /// content of a `.urdf` file, redefined globals).
    pub warnings: Vec<String>,
    /// Every file read: the main file, then its includes and YAML files in the order read.
    pub files: Vec<PathBuf>,
}

pub use crate::io::error::XacroError;

/// Whether `path` names a xacro file (`.xacro`, `.urdf.xacro`).
#[must_use]
pub fn is_xacro_path(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xacro"))
}

/// Expands the xacro file `path`.
///
/// # Errors
/// [`XacroError`] with the file, line and column of the problem and the macro calls and
/// includes that led to it.
///
/// # Examples
/// ```
/// use kinechain::io::xacro::{expand_file, XacroOptions};
/// let out = expand_file("tests/data/xacro/features/features.urdf.xacro".as_ref(),
///                       &XacroOptions::default().with_arg("prefix", "left_"))?;
/// assert!(out.urdf.contains("left_base"));
/// # Ok::<(), kinechain::io::xacro::XacroError>(())
/// ```
pub fn expand_file(path: &Path, options: &XacroOptions) -> Result<Expansion, XacroError> {
    let text = read_main(path)?;
    expand_text(&text, path, options, false)
}

/// Expands xacro text `text` as if it were the file `path` (includes and `$(find)` resolve from
/// its directory; the file itself is not read).
///
/// # Errors
/// As [`expand_file`].
pub fn expand_str(
    text: &str,
    path: &Path,
    options: &XacroOptions,
) -> Result<Expansion, XacroError> {
    expand_text(text, path, options, false)
}

fn read_main(path: &Path) -> Result<String, XacroError> {
    let fail = |message: String| XacroError {
        file: path.to_path_buf(),
        line: None,
        column: None,
        stack: Vec::new(),
        message,
    };
    let limit = crate::io::error::MAX_FILE_BYTES;
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| {
            std::io::Read::read_to_end(&mut std::io::Read::take(f, limit + 1), &mut bytes)
        })
        .map_err(|e| fail(format!("cannot read the file: {e}")))?;
    if bytes.len() as u64 > limit {
        return Err(fail(format!("the file is larger than {limit} bytes")));
    }
    String::from_utf8(bytes).map_err(|_| fail("the file is not UTF-8 text".into()))
}

/// Stack size of the thread an expansion runs on: deep macro nesting recurses.
const STACK_BYTES: usize = 64 << 20;

/// Expands `text` of file `path`; `lenient` for a `.urdf` file's leftover xacro elements, where
/// failures inside non-kinematic elements are skipped with a warning.
pub(crate) fn expand_text(
    text: &str,
    path: &Path,
    options: &XacroOptions,
    lenient: bool,
) -> Result<Expansion, XacroError> {
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .name("xacro".into())
            .stack_size(STACK_BYTES)
            .spawn_scoped(s, || run(text, path, options, lenient))
            .map_or_else(
                // Without a thread of its own (none can be made), expand here.
                |_| run(text, path, options, lenient),
                |handle| {
                    handle.join().unwrap_or_else(|_| {
                        Err(XacroError {
                            file: path.to_path_buf(),
                            line: None,
                            column: None,
                            stack: Vec::new(),
                            message: "the expansion failed unexpectedly".into(),
                        })
                    })
                },
            )
    })
}

fn run(
    text: &str,
    path: &Path,
    options: &XacroOptions,
    lenient: bool,
) -> Result<Expansion, XacroError> {
    let root = dom::parse(text, 0).map_err(|(at, message)| XacroError {
        file: path.to_path_buf(),
        line: Some(at.line),
        column: Some(at.column),
        stack: Vec::new(),
        message: format!("not well-formed XML: {message}"),
    })?;
    let mut x = expand::Expander::new(
        path.to_path_buf(),
        &options.args,
        &options.package_paths,
        lenient,
        crate::io::error::MAX_FILE_BYTES,
    );
    let done = x.run(root)?;
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let banner = if lenient {
        String::new()
    } else {
        format!("expanded by kinechain from {name}")
    };
    Ok(Expansion {
        urdf: dom::write(&done, &banner),
        warnings: x.warnings,
        files: x.files,
    })
}

/// Whether URDF text holds xacro elements or attributes (`<xacro:…>`, `xacro:…=`): leftovers in
/// a file saved as `.urdf`, expanded before reading.
pub(crate) fn has_xacro(text: &str) -> bool {
    text.contains("<xacro:") || text.contains(" xacro:")
}
