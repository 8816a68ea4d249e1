//! `kinechain record`, `verify` and `compare`: regression tests on link kinematics.

#[allow(clippy::wildcard_imports)]
use super::*;
use crate::regression::{self, Options, Report, Tolerances};

/// The tolerances of `verify` and `compare`.
#[derive(Debug, clap::Args)]
pub(super) struct TolArgs {
    /// Largest distance a link origin may move (m).
    #[arg(long, default_value_t = 1e-9, value_parser = tolerance)]
    tol_position: f64,
    /// Largest angle a link may turn (rad).
    #[arg(long, default_value_t = 1e-9, value_parser = tolerance)]
    tol_rotation: f64,
    /// Largest change of ω, v, α or a (levels vel and acc).
    #[arg(long, default_value_t = 1e-9, value_parser = tolerance)]
    tol_rates: f64,
}

impl TolArgs {
    fn tolerances(&self) -> Tolerances {
        Tolerances {
            position: self.tol_position,
            rotation: self.tol_rotation,
            rates: self.tol_rates,
        }
    }
}

/// How `record` and `compare` draw configurations.
#[derive(Debug, clap::Args)]
pub(super) struct SampleArgs {
    /// Random configurations within the limits, besides zero and the two limit corners where
    /// the limits admit them.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(0..=1_000_000))]
    samples: u32,
    /// Seed of the configurations (the same seed draws the same ones).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// What to record: poses, poses and velocities, or poses, velocities and accelerations.
    #[arg(long, value_enum, default_value_t = Level::Pose)]
    level: Level,
    /// Only these links (repeatable; default: every link).
    #[arg(long = "link", value_name = "NAME")]
    links: Vec<String>,
}

impl SampleArgs {
    fn options(&self) -> Options {
        Options {
            samples: self.samples as usize,
            seed: self.seed,
            level: match self.level {
                Level::Pose => regression::Level::Pose,
                Level::Vel => regression::Level::Vel,
                Level::Acc => regression::Level::Acc,
            },
            links: self.links.clone(),
        }
    }
}

/// `OLD=NEW`: a joint of the first robot and its name in the second.
pub(super) fn rename(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((old, new)) if !old.is_empty() && !new.is_empty() => {
            Ok((old.to_string(), new.to_string()))
        }
        _ => Err(format!(
            "'{s}' is not OLD=NEW (a joint of the first robot, then its name in the second)"
        )),
    }
}

fn tolerance(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!("'{s}' is not a finite number ≥ 0")),
    }
}

pub(super) fn record(
    robot: &PathBuf,
    output: Option<&PathBuf>,
    sampling: &SampleArgs,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    refuse_overwrite(output, robot)?;
    let chain = load(robot)?;
    let golden = regression::record(&chain, &sampling.options())?;
    let bytes = regression::golden_bytes(&golden)?;
    match output {
        None => out.write_all(&bytes).map_err(output_error),
        Some(path) => Ok(crate::io::output::write_file(path, &bytes, &[robot])?),
    }
}

pub(super) fn verify(
    robot: &PathBuf,
    golden: &Path,
    tol: &TolArgs,
    format: OutputFormat,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let golden = regression::read_golden_file(golden)?;
    let chain = load(robot)?;
    let report = regression::verify(&chain, &golden, &tol.tolerances())?;
    print_report(&report, format, out)
}

pub(super) fn compare(
    robots: [&PathBuf; 2],
    renames: &[(String, String)],
    sampling: &SampleArgs,
    tol: &TolArgs,
    format: OutputFormat,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let (a, b) = (load(robots[0])?, load(robots[1])?);
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
