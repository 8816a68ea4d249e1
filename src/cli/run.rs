//! The entry point: parses the command line, runs the command and maps its result to an exit
//! status.

use crate::cli::args::{Cli, Command};
use crate::cli::bench::bench;
use crate::cli::common::{load, output_error, refuse_overwrite, warn_dropped, write_output};
use crate::cli::error::CliError;
use crate::cli::fk::fk;
use crate::cli::info::info;
use crate::cli::regression::{compare, record, verify};
use crate::error::error_chain;
use crate::eval::forward_kinematics;
use crate::eval::{Data, LimitPolicy};
use crate::io::LoadOptions;
use crate::io::input::joint_vector_from_str;
use crate::model::error::escape_controls;
use clap::Parser;
use std::io::{BufWriter, Write};
use std::process::ExitCode;

/// Runs the command line and returns the process exit code; errors are printed to stderr as one
/// line, `error: ` followed by the error and its sources.
#[must_use]
pub fn main() -> ExitCode {
    main_with(false)
}

/// [`main`], told whether the process started with its standard output closed (the standard
/// library reopens a closed one on `/dev/null` before `main` runs, so only code that runs
/// earlier can tell; the `kinechain` binary does). A command whose results go to standard output
/// then fails rather than lose them.
#[must_use]
pub fn main_with(stdout_closed: bool) -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            // clap's message spans several lines; keep what precedes the usage text, on one.
            let text = e.to_string();
            let message: Vec<&str> = text
                .lines()
                .map(str::trim)
                .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
                .filter(|l| !l.is_empty())
                .collect();
            eprintln!("{} (see --help)", escape_controls(&message.join(" ")));
            return ExitCode::from(2);
        }
    };
    let writes_stdout = !matches!(
        &cli.command,
        Command::Convert {
            output: Some(_),
            ..
        } | Command::Render {
            output: Some(_),
            ..
        } | Command::View {
            output: Some(_),
            ..
        } | Command::Record {
            output: Some(_),
            ..
        } | Command::Expand {
            output: Some(_),
            ..
        }
    );
    if writes_stdout && stdout_closed {
        eprintln!("error: standard output is closed: the results would be lost");
        return ExitCode::FAILURE;
    }
    // `verify` and `compare` tell a moved link (1) from an error (2).
    let verdicts = matches!(
        &cli.command,
        Command::Verify { .. } | Command::Compare { .. }
    );
    let stdout = std::io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    let options = cli.load_options();
    let result =
        run(cli.command, &options, &mut out).and_then(|()| out.flush().map_err(output_error));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError::Moved { .. }) => match out.flush() {
            Ok(()) => ExitCode::FAILURE,
            Err(_) => ExitCode::from(2),
        },
        // The reader went away (`kinechain fk … | head`): stop quietly, as a shell tool does.
        Err(CliError::Io { source, .. }) if source.kind() == std::io::ErrorKind::BrokenPipe => {
            ExitCode::SUCCESS
        }
        Err(e) => {
            let _ = out.flush();
            eprintln!("error: {}", error_chain(&e));
            if verdicts {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

pub(super) fn run(
    command: Command,
    options: &LoadOptions,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    match command {
        Command::Info { robot, format } => info(&load(&robot, options)?, format, out),
        Command::Fk(args) => fk(&args, options, out),
        Command::Ik(args) => crate::cli::ik::ik(&args, options, out),
        Command::Bench {
            robot,
            level,
            configurations,
            link,
        } => bench(&robot, options, level, configurations, link.as_deref(), out),
        Command::Convert { robot, output } => {
            refuse_overwrite(output.as_ref(), &robot)?;
            let chain = load(&robot, options)?;
            let text = crate::io::convert::to_urdf(&chain)?;
            if crate::io::Format::from_path(&robot) == Some(crate::io::Format::Urdf) {
                warn_dropped(&robot);
            }
            write_output(output.as_ref(), &robot, &text, out)
        }
        Command::Expand { file, output } => {
            refuse_overwrite(output.as_ref(), &file)?;
            let expansion = crate::io::xacro::expand_file(&file, &options.xacro).map_err(|e| {
                CliError::Load(crate::io::error::LoadError::new(
                    &file,
                    crate::io::error::LoadErrorKind::Xacro(e),
                ))
            })?;
            for w in &expansion.warnings {
                eprintln!("warning: {w}");
            }
            write_output(output.as_ref(), &file, &expansion.urdf, out)
        }
        Command::Render {
            robot,
            q,
            output,
            ignore_limits,
        } => {
            refuse_overwrite(output.as_ref(), &robot)?;
            let chain = load(&robot, options)?;
            let q = joint_vector_from_str(&chain, &q, "q")?;
            let mut data = Data::new(&chain);
            if ignore_limits {
                data.set_limit_policy(LimitPolicy::Ignore);
            }
            let poses = forward_kinematics(&chain, &mut data, &q)?;
            let drawing =
                crate::io::render::svg(&chain, &poses).map_err(|e| CliError::NotFinite {
                    what: e.what,
                    place: e.place,
                })?;
            write_output(output.as_ref(), &robot, &drawing, out)
        }
        Command::View {
            robot,
            q,
            bag,
            topic,
            output,
        } => {
            refuse_overwrite(output.as_ref(), &robot)?;
            if let (Some(out), Some(bag)) = (output.as_ref(), bag.as_ref()) {
                refuse_overwrite(Some(out), bag)?;
            }
            let chain = load(&robot, options)?;
            let (rows, times) = match (&q, &bag) {
                (_, Some(bag)) => {
                    let log = crate::io::bag::read_joint_states(
                        bag,
                        &crate::io::bag::JointStateOptions::new(&topic),
                    )?;
                    let (time, rows) = crate::io::tf::rows_of_log(&chain, &log)?;
                    if time.is_empty() {
                        return Err(CliError::View(format!(
                            "{}: no message of {topic} gives every joint of the chain a value",
                            bag.display()
                        )));
                    }
                    (rows, Some(time))
                }
                (Some(q), None) => (joint_vector_from_str(&chain, q, "q")?, None),
                (None, None) => (chain.neutral(), None),
            };
            let page = crate::io::view::page(&chain, &rows, times.as_deref())
                .map_err(|e| CliError::View(e.to_string()))?;
            write_output(output.as_ref(), &robot, &page, out)
        }
        Command::Record {
            robot,
            output,
            sampling,
        } => record(&robot, options, output.as_ref(), &sampling, out),
        Command::Verify {
            robot,
            golden,
            tolerances,
            format,
        } => verify(&robot, options, &golden, &tolerances, format, out),
        Command::Compare {
            robot_a,
            robot_b,
            renames,
            sampling,
            tolerances,
            format,
        } => compare(
            [&robot_a, &robot_b],
            options,
            &renames,
            &sampling,
            &tolerances,
            format,
            out,
        ),
    }
}

#[cfg(test)]
mod tests {
    use crate::cli::args::configuration_count;
    use crate::cli::batch::{CappedLine, read_capped_line};
    use crate::cli::format::{push_cells, push_fixed};
    use crate::cli::limits::MAX_BENCH_CONFIGURATIONS;

    /// A table's numbers: six decimals right-aligned, exponent form from 10⁹ on, and no sign on
    /// a value that shows as zero, whether it is padded, fills its width or has none.
    #[test]
    fn table_numbers() {
        let cell = |x: f64, width: usize| {
            let mut buf = b"|".to_vec();
            push_fixed(&mut buf, x, width);
            String::from_utf8(buf).unwrap()
        };
        assert_eq!(cell(-2.5, 12), "|   -2.500000");
        assert_eq!(cell(0.25, 0), "|0.250000");
        assert_eq!(cell(-0.0, 12), "|    0.000000");
        assert_eq!(cell(-6e-17, 0), "|0.000000");
        assert_eq!(cell(-4e-7, 9), "| 0.000000");
        assert_eq!(cell(-4e-7, 8), "|0.000000");
        assert_eq!(cell(-6e-7, 9), "|-0.000001");
        assert_eq!(cell(-2e9, 12), "| -2.000000e9");
        assert_eq!(cell(123_456_789.0, 0), "|123456789.000000");
        let mut buf = Vec::new();
        push_cells(&mut buf, [1.0, -0.0, 2.0], b"; ", 0);
        assert_eq!(buf, b"1.000000; 0.000000; 2.000000");
    }

    /// Reads every line of `input` through a reader that returns at most `chunk` bytes at a
    /// time, with lines capped at `limit` bytes: `Some(text)` per line kept, `None` per line
    /// too long.
    fn lines(input: &[u8], chunk: usize, limit: usize) -> Vec<Option<String>> {
        let mut reader = std::io::BufReader::with_capacity(chunk, input);
        let (mut buf, mut out) = (Vec::new(), Vec::new());
        loop {
            match read_capped_line(&mut reader, &mut buf, limit, usize::MAX).unwrap() {
                CappedLine::Line => out.push(Some(String::from_utf8(buf.clone()).unwrap())),
                CappedLine::TooLong => out.push(None),
                CappedLine::End | CappedLine::Unended => return out,
            }
        }
    }

    /// A line of exactly the cap is kept and one byte more is not, whether the line arrives in
    /// one piece or many; a long line is skipped to its end, and the lines around it are read.
    #[test]
    fn lines_are_capped_at_exactly_the_limit() {
        for chunk in [4, 7, 64, 1 << 16] {
            let (at, over) = ("a".repeat(40), "b".repeat(41));
            let input = format!("x\n{at}\n{over}\r\ny\r\n{}\nlast", "c".repeat(500));
            let got = lines(input.as_bytes(), chunk, 40);
            let want = [
                Some("x".into()),
                Some(at.clone()),
                None,
                Some("y".into()),
                None,
                Some("last".into()),
            ];
            assert_eq!(got, want, "chunks of {chunk}");
        }
        // A line far longer than the reader's buffer and within the cap is whole.
        let long = "d".repeat(100_000);
        assert_eq!(
            lines(format!("{long}\n").as_bytes(), 8192, 1 << 20),
            [Some(long)]
        );
        assert_eq!(lines(b"", 16, 40), []);
    }

    #[test]
    fn bench_takes_two_to_the_most_configurations() {
        let most = MAX_BENCH_CONFIGURATIONS;
        for (n, ok) in [(1, false), (2, true), (most, true), (most + 1, false)] {
            let got = configuration_count(&n.to_string());
            assert_eq!(got.clone().ok(), ok.then_some(n), "{n}: {got:?}");
        }
        assert!(configuration_count("many").is_err());
    }
}
