//! Writing an output file without destroying anything: the one routine behind every `-o` of the
//! command line and every file the Python package writes.
//!
//! What the path names decides how it is written:
//! - nothing yet, or a regular file: the contents go to a temporary file in the same directory,
//!   which is renamed onto the path once complete, so that a failure leaves no half-written
//!   output and a file is replaced only by a complete one. A replaced file keeps its permissions.
//! - a FIFO, a character device or a socket (`/dev/stdout`, `/dev/null`, a process
//!   substitution): written directly, in place; nothing is renamed, so the node survives.
//! - a symbolic link: followed. The file it finally points to is written by the rules above (a
//!   regular target replaced through a temporary file in the *target's* directory), and the
//!   link itself stays; a dangling link creates its target.
//! - a directory or a block device: an error.
//!
//! An output that is the same file as one of the inputs (by path, symbolic link or hard link) is
//! refused in every case.

use std::io::Write;
use std::path::{Path, PathBuf};

/// Symbolic links followed before an output path is refused as a loop (Linux's own limit).
const MAX_LINK_HOPS: usize = 40;

/// An output file could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}", path.display())]
pub struct OutputError {
    path: PathBuf,
    #[source]
    problem: OutputProblem,
}

impl OutputError {
    fn new(path: &Path, problem: OutputProblem) -> Self {
        OutputError {
            path: path.to_path_buf(),
            problem,
        }
    }

    /// The output path as given.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// What went wrong.
    #[must_use]
    pub fn problem(&self) -> &OutputProblem {
        &self.problem
    }
}

/// Why an output file could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputProblem {
    /// The output is a file being read.
    #[error("it is {} (the same file): refusing to overwrite it", input.display())]
    IsInput {
        /// The input it is the same file as.
        input: PathBuf,
    },
    /// A directory stands at the path.
    #[error("it is a directory")]
    Directory,
    /// A block device stands at the path (a disk: never written).
    #[error("it is a block device")]
    BlockDevice,
    /// More symbolic links than the system follows, or a loop of them.
    #[error("more than {MAX_LINK_HOPS} symbolic links to follow (a loop?)")]
    LinkLoop,
    /// The system refused a step.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// What the path finally names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Nothing: a new file is made.
    Missing,
    /// A regular file: replaced.
    Regular,
    /// A FIFO, character device or socket: written in place.
    Stream,
}

/// Writes `contents` to `path` by the rules of this module, refusing a path that is the same
/// file as any of `inputs`.
///
/// # Errors
/// [`OutputError`] naming `path`: the input it would overwrite, a directory or block device at
/// the path, a loop of links, or the system's error (a missing directory, `ENOSPC` from
/// `/dev/full`, a closed pipe).
pub fn write_file(path: &Path, contents: &[u8], inputs: &[&Path]) -> Result<(), OutputError> {
    let fail = |problem| OutputError::new(path, problem);
    refuse_inputs(path, inputs)?;
    let (target, kind) = resolve(path).map_err(fail)?;
    match kind {
        Kind::Stream => {
            let mut file = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(|e| fail(e.into()))?;
            file.write_all(contents)
                .and_then(|()| file.flush())
                .map_err(|e| fail(e.into()))
        }
        Kind::Missing | Kind::Regular => {
            // Checked again just before the rename: a link to an input may have been made since.
            replace(&target, kind == Kind::Regular, contents, || {
                refuse_inputs(path, inputs)
            })
        }
    }
}

/// An error when `output` is the same existing file as one of `inputs`.
///
/// # Errors
/// [`OutputProblem::IsInput`] naming the input.
pub fn refuse_inputs(output: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
    match inputs.iter().find(|input| same_file(output, input)) {
        Some(input) => Err(OutputError::new(
            output,
            OutputProblem::IsInput {
                input: input.to_path_buf(),
            },
        )),
        None => Ok(()),
    }
}

/// Whether `a` and `b` name the same existing file (through symbolic or hard links too).
#[must_use]
pub fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(x), Ok(y)) if x == y
        )
    }
}

/// The path that is finally written (the end of a chain of symbolic links) and what stands there.
fn resolve(path: &Path) -> Result<(PathBuf, Kind), OutputProblem> {
    // The kind is read through every link at once (this also follows the kernel's own links,
    // such as `/proc/self/fd/1` behind `/dev/stdout`, whose text names no path).
    let kind = match std::fs::metadata(path) {
        Ok(m) => kind_of(&m)?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Kind::Missing,
        Err(e) => return Err(e.into()),
    };
    if kind == Kind::Stream {
        return Ok((path.to_path_buf(), kind));
    }
    let mut target = path.to_path_buf();
    for _ in 0..=MAX_LINK_HOPS {
        match std::fs::symlink_metadata(&target) {
            Ok(m) if m.file_type().is_symlink() => {
                let next = std::fs::read_link(&target)?;
                target = match target.parent() {
                    Some(dir) if next.is_relative() => dir.join(next),
                    _ => next,
                };
            }
            Ok(_) => return Ok((target, kind)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Ok((target, Kind::Missing));
            }
            Err(e) => return Err(e.into()),
        }
    }
    Err(OutputProblem::LinkLoop)
}

fn kind_of(m: &std::fs::Metadata) -> Result<Kind, OutputProblem> {
    let t = m.file_type();
    if t.is_dir() {
        return Err(OutputProblem::Directory);
    }
    if t.is_file() {
        return Ok(Kind::Regular);
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_block_device() {
            return Err(OutputProblem::BlockDevice);
        }
    }
    // FIFOs, character devices, sockets (and whatever else a system has that is neither a
    // file nor a directory) are opened and written as they are.
    Ok(Kind::Stream)
}

/// Writes `contents` to a temporary file beside `target` and renames it onto `target`; the
/// replaced file's permissions are kept. `check` runs just before the rename.
fn replace(
    target: &Path,
    exists: bool,
    contents: &[u8],
    check: impl FnOnce() -> Result<(), OutputError>,
) -> Result<(), OutputError> {
    let fail = |problem| OutputError::new(target, problem);
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = target.file_name().ok_or_else(|| {
        fail(OutputProblem::Io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "the path names no file",
        )))
    })?;
    let permissions = if exists {
        Some(
            std::fs::metadata(target)
                .map_err(|e| fail(e.into()))?
                .permissions(),
        )
    } else {
        None
    };
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!(".kinechain-{}.tmp", std::process::id()));
    let temp = dir.join(temp_name);
    let written = (|| {
        let mut options = std::fs::OpenOptions::new();
        options.write(true).create_new(true);
        #[cfg(unix)]
        if exists {
            // Readable by nobody else until it has the replaced file's permissions.
            use std::os::unix::fs::OpenOptionsExt;
            options.mode(0o600);
        }
        let mut file = options.open(&temp)?;
        file.write_all(contents)?;
        if let Some(p) = permissions {
            file.set_permissions(p)?;
        }
        file.sync_all()
    })();
    let renamed = written.map_err(|e| fail(e.into())).and_then(|()| {
        check()?;
        std::fs::rename(&temp, target).map_err(|e| fail(e.into()))
    });
    if renamed.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    renamed
}
