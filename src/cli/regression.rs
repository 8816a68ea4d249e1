//! `kinechain record`, `verify` and `compare`: regression tests on link kinematics.

use crate::cli::args::{OutputFormat, SampleArgs, TolArgs};
use crate::cli::common::{load, output_error, refuse_overwrite};
use crate::cli::error::CliError;
use crate::io::LoadOptions;
use crate::regression::{self, Report};
use std::io::Write;
use std::path::{Path, PathBuf};

pub(super) fn record(
    robot: &PathBuf,
    options: &LoadOptions,
    output: Option<&PathBuf>,
    sampling: &SampleArgs,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    refuse_overwrite(output, robot)?;
    let chain = load(robot, options)?;
    let golden = regression::record(&chain, &sampling.options())?;
    let bytes = regression::golden_bytes(&golden)?;
    match output {
        None => out.write_all(&bytes).map_err(output_error),
        Some(path) => Ok(crate::io::output::write_file(path, &bytes, &[robot])?),
    }
}

pub(super) fn verify(
    robot: &PathBuf,
    options: &LoadOptions,
    golden: &Path,
    tol: &TolArgs,
    format: OutputFormat,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let golden = regression::read_golden_file(golden)?;
    let chain = load(robot, options)?;
    let report = regression::verify(&chain, &golden, &tol.tolerances())?;
    print_report(&report, format, out)
}

pub(super) fn compare(
    robots: [&PathBuf; 2],
    options: &LoadOptions,
    renames: &[(String, String)],
    sampling: &SampleArgs,
    tol: &TolArgs,
    format: OutputFormat,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let (a, b) = (load(robots[0], options)?, load(robots[1], options)?);
    let report =
        regression::compare_renamed(&a, &b, &sampling.options(), &tol.tolerances(), renames)?;
    print_report(&report, format, out)
}

/// Prints the report; a failed verdict is [`CliError::Moved`] (exit status 1).
fn print_report(
    report: &Report,
    format: OutputFormat,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    match format {
        OutputFormat::Json => {
            serde_json::to_writer(&mut *out, report).map_err(|e| output_error(e.into()))?;
            writeln!(out).map_err(output_error)?;
        }
        OutputFormat::Table => writeln!(out, "{report}").map_err(output_error)?,
        OutputFormat::Csv => {
            return Err(CliError::Csv(
                "is for fk results; verify and compare print json or table",
            ));
        }
    }
    match &report.first_moved {
        None => Ok(()),
        Some(l) => Err(CliError::Moved {
            link: l.link.clone(),
        }),
    }
}
