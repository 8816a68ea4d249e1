//! What every command shares: loading the robot, writing lines and output files, and warnings.

use crate::cli::error::CliError;
use crate::eval::Chain;
use crate::io::LoadOptions;
use crate::model::error::escape_controls;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A path as printed in a message, its control characters escaped.
fn shown(path: &Path) -> String {
    escape_controls(&path.display().to_string()).into_owned()
}

pub(super) fn load(path: &PathBuf, options: &LoadOptions) -> Result<Chain, CliError> {
    let chain = Chain::from_file_with(path, options)?;
    for w in chain.warnings() {
        eprintln!("warning: {}: {w}", shown(path));
    }
    Ok(chain)
}

/// Warns of what a URDF file holds beyond its kinematics, which `convert` does not write.
pub(super) fn warn_dropped(path: &Path) {
    let dropped = std::fs::read_to_string(path)
        .ok()
        .and_then(|text| crate::io::convert::dropped_from_urdf(&text));
    if let Some(dropped) = dropped {
        eprintln!(
            "warning: {}: the URDF written has the kinematics only; not written: {dropped}",
            shown(path)
        );
    }
}

/// Writes `text` to `path` by the rules of [`crate::io::output`] (never over `input`; FIFOs and
/// devices in place, regular files through a temporary file renamed into place, links
/// followed), or to `out` when there is no path.
pub(super) fn write_output(
    path: Option<&PathBuf>,
    input: &Path,
    text: &str,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    match path {
        None => out.write_all(text.as_bytes()).map_err(output_error),
        Some(path) => Ok(crate::io::output::write_file(
            path,
            text.as_bytes(),
            &[input],
        )?),
    }
}

/// An error when `output` names the file `input` (checked before the robot is read, so that the
/// refusal comes first; [`write_output`] checks again).
pub(super) fn refuse_overwrite(output: Option<&PathBuf>, input: &Path) -> Result<(), CliError> {
    match output {
        Some(path) => Ok(crate::io::output::refuse_inputs(path, &[input])?),
        None => Ok(()),
    }
}

pub(super) fn write_line(out: &mut dyn Write, text: &str) -> Result<(), CliError> {
    writeln!(out, "{text}").map_err(output_error)
}

/// A failure to write the output (standard output, or the writer `run` is given).
pub(super) fn output_error(source: std::io::Error) -> CliError {
    CliError::Io {
        context: "cannot write output".into(),
        source,
    }
}
