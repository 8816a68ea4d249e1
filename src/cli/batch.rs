//! `kinechain fk --batch`: one result per input line; lines of poses, of poses and velocities, and
//! of poses, velocities and accelerations through the batch kernels.

use crate::cli::args::{FkArgs, OutputFormat};
use crate::cli::common::{output_error, write_line};
use crate::cli::error::CliError;
use crate::cli::format::{
    Configuration, JacobianResult, LinkResult, ResultsJson, RowLabel, check_finite, csv_field,
    csv_links, csv_row, orientation_columns, results_table, write_buffered_line, write_json_line,
};
use crate::cli::query::{Request, at_line, jacobians_finite, jacobians_table, line_heading};
use crate::error::error_chain;
use crate::eval::Chain;
use crate::eval::Data;
use crate::eval::JacobianFrame;
use crate::eval::batch::{
    BatchData, forward_accelerations_batch, forward_kinematics_batch, forward_velocities_batch,
    jacobian_batch, jacobian_dot_batch,
};
use crate::eval::check_q;
use crate::eval::checks::check_values;
use crate::model::chain::LinkId;
use serde_json::json;
use std::io::{BufRead, Write};
use std::path::Path;

/// Consecutive lines of a batch file that ask for every link at the same level (poses, with
/// velocities, with accelerations), evaluated together by the batch kernels.
pub(super) struct PendingPoses {
    /// Their configurations, row-major, and their rates when the level has them.
    pub(super) qs: Vec<f64>,
    pub(super) qds: Vec<f64>,
    pub(super) qdds: Vec<f64>,
    /// 0: poses, 1: with velocities, 2: with accelerations.
    pub(super) level: u8,
    /// The 1-based line number of each.
    pub(super) lines: Vec<usize>,
    pub(super) batch: BatchData,
    /// The `--jacobian` links' matrices for the line being written, and the batch buffers
    /// their batches run in (apart from `batch`, whose frames the lines' poses are read from):
    /// `J` and, with rates, `J̇` of every held line, `N × 6 × dof` row-major.
    pub(super) jacobians: Vec<JacobianResult>,
    pub(super) jacobian_batch: BatchData,
    pub(super) j: Vec<f64>,
    pub(super) j_dot: Vec<f64>,
    /// One line of output (JSON or a table), reused.
    pub(super) text: Vec<u8>,
}

impl PendingPoses {
    /// Lines held before they are evaluated.
    const MAX: usize = 256;

    /// Writes the pending configurations' results and forgets them; returns how many failed
    /// (written as error lines under `--keep-going`; without it, the first failure is the
    /// error).
    fn flush(
        &mut self,
        chain: &Chain,
        args: &FkArgs,
        path: &Path,
        out: &mut dyn Write,
    ) -> Result<usize, CliError> {
        if self.qs.is_empty() {
            return Ok(0);
        }
        let lines = &self.lines;
        let at = |e: crate::eval::batch::BatchError| {
            // (Each line was checked as it was read, so this is not expected.)
            let line = lines.get(e.index).or(lines.last()).copied().unwrap_or(0);
            at_line(path, line, CliError::State(e.source))
        };
        let (qs, qds, qdds) = (&self.qs, &self.qds, &self.qdds);
        // Each `--jacobian` link's matrices for every line, from the batch kernels of Jacobians
        // (the same bits as the single evaluation's).
        let dof = chain.dof();
        let size = 6 * dof * lines.len();
        let with_rate = self.level > 0;
        self.j.resize(size * self.jacobians.len(), 0.0);
        self.j_dot
            .resize(if with_rate { self.j.len() } else { 0 }, 0.0);
        for (k, r) in self.jacobians.iter().enumerate() {
            let j = &mut self.j[k * size..(k + 1) * size];
            jacobian_batch(
                chain,
                &mut self.jacobian_batch,
                qs,
                r.link,
                JacobianFrame::World,
                j,
            )
            .map_err(at)?;
            if with_rate {
                let j_dot = &mut self.j_dot[k * size..(k + 1) * size];
                let frame = JacobianFrame::World;
                jacobian_dot_batch(
                    chain,
                    &mut self.jacobian_batch,
                    qs,
                    qds,
                    r.link,
                    frame,
                    j_dot,
                )
                .map_err(at)?;
            }
        }
        let view = match self.level {
            0 => View::Poses(forward_kinematics_batch(chain, &mut self.batch, qs).map_err(at)?),
            1 => View::Velocities(
                forward_velocities_batch(chain, &mut self.batch, qs, qds).map_err(at)?,
            ),
            _ => View::Accelerations(
                forward_accelerations_batch(chain, &mut self.batch, qs, qds, qdds).map_err(at)?,
            ),
        };
        let mut failed = 0;
        // One buffer for every line's link results.
        let mut results: Vec<LinkResult> = Vec::with_capacity(chain.links().len());
        for (i, &line) in lines.iter().enumerate() {
            results.clear();
            results.extend((0..chain.links().len()).map(|l| view.result(i, LinkId(l))));
            let at_line_i = 6 * dof * i;
            for (k, r) in self.jacobians.iter_mut().enumerate() {
                let rows = |all: &[f64]| {
                    let from = k * size + at_line_i;
                    nalgebra::Matrix6xX::from_row_slice(&all[from..from + 6 * dof])
                };
                r.j.copy_from(&rows(&self.j));
                r.with_rate = with_rate;
                if with_rate {
                    r.j_dot.copy_from(&rows(&self.j_dot));
                }
            }
            let checked = check_finite(chain, &results, &[], &[])
                .and_then(|()| jacobians_finite(chain, &self.jacobians));
            let jacobians = &self.jacobians;
            match checked {
                Ok(()) => match args.format {
                    OutputFormat::Json => {
                        let value = ResultsJson {
                            line: Some(RowLabel::Line(line)),
                            chain,
                            results: &results,
                            orientation: args.orientation,
                            points: &[],
                            point_results: &[],
                            jacobians,
                        };
                        write_json_line(out, &mut self.text, &value)?;
                    }
                    OutputFormat::Table => write_buffered_line(out, &mut self.text, |buf| {
                        line_heading(Some(RowLabel::Line(line)), buf);
                        results_table(chain, &results, args.orientation, buf);
                        jacobians_table(chain, jacobians, buf);
                        Ok(())
                    })?,
                    OutputFormat::Csv => write_buffered_line(out, &mut self.text, |buf| {
                        csv_row(Some(RowLabel::Line(line)), &results, args.orientation, buf);
                        Ok(())
                    })?,
                },
                Err(e) if args.keep_going => {
                    failed += 1;
                    write_line(out, &failed_line(chain, args, RowLabel::Line(line), &e))?;
                }
                Err(e) => return Err(at_line(path, line, e)),
            }
        }
        self.qs.clear();
        self.qds.clear();
        self.qdds.clear();
        self.lines.clear();
        Ok(failed)
    }

    /// Holds configuration `c` of line `line`, checked, for the batch of its level (the lines
    /// held before it are written first when they are of another level). False, holding
    /// nothing, for what the batch kernels do not serve: acceleration without velocity (an
    /// error the single path reports), and rates asked for in CSV.
    fn hold(
        &mut self,
        chain: &Chain,
        args: &FkArgs,
        path: &Path,
        c: &Configuration,
        line: usize,
        out: &mut dyn Write,
    ) -> Result<(bool, usize), CliError> {
        let level = match (&c.qd, &c.qdd) {
            (None, None) => 0,
            _ if args.format == OutputFormat::Csv => return Ok((false, 0)),
            (Some(_), None) => 1,
            (Some(_), Some(_)) => 2,
            (None, Some(_)) => return Ok((false, 0)),
        };
        let policy = self.batch.limit_policy();
        check_q(chain, &c.q, policy)?;
        if let Some(qd) = &c.qd {
            check_values(chain, qd, "q_dot")?;
        }
        if let Some(qdd) = &c.qdd {
            check_values(chain, qdd, "q_ddot")?;
        }
        let failed = if level == self.level {
            0
        } else {
            let failed = self.flush(chain, args, path, out)?;
            self.level = level;
            failed
        };
        self.qs.extend_from_slice(&c.q);
        self.qds
            .extend_from_slice(c.qd.as_deref().unwrap_or_default());
        self.qdds
            .extend_from_slice(c.qdd.as_deref().unwrap_or_default());
        self.lines.push(line);
        Ok((true, failed))
    }
}

/// The results of a batch at one of [`PendingPoses`]' levels.
enum View<'a> {
    Poses(crate::eval::batch::BatchPoses<'a>),
    Velocities(crate::eval::batch::BatchVelocities<'a>),
    Accelerations(crate::eval::batch::BatchAccelerations<'a>),
}

impl View<'_> {
    /// Link `l`'s result in configuration `i`.
    fn result(&self, i: usize, l: LinkId) -> LinkResult {
        match self {
            View::Poses(p) => (l, p.world_from_link(i, l), None, None),
            View::Velocities(v) => (l, v.world_from_link(i, l), Some(v.velocity(i, l)), None),
            View::Accelerations(a) => (
                l,
                a.world_from_link(i, l),
                Some(a.velocity(i, l)),
                Some(a.acceleration(i, l)),
            ),
        }
    }
}

/// How errors name standard input, the batch file `-`.
pub(super) const STANDARD_INPUT: &str = "standard input";

/// `fk --batch`: the lines of the file at `path`, or of standard input for `-`, through
/// [`fk_batch`].
pub(super) fn fk_batch_file(
    chain: &Chain,
    args: &FkArgs,
    data: &mut Data,
    request: &mut Request,
    path: &Path,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    // Blocks of 64 KiB hold an arm's 256 lines of poses (about 100 bytes each) a few times
    // over: the results go out when the lines held fill a batch, not at every block's end.
    const BLOCK: usize = 1 << 16;
    if path == Path::new("-") {
        let mut reader = std::io::BufReader::with_capacity(BLOCK, std::io::stdin());
        let name = Path::new(STANDARD_INPUT);
        return fk_batch(chain, args, data, request, name, &mut reader, out);
    }
    let file = std::fs::File::open(path).map_err(|source| CliError::Io {
        context: format!("cannot open batch file {}", path.display()),
        source,
    })?;
    let mut reader = std::io::BufReader::with_capacity(BLOCK, file);
    fk_batch(chain, args, data, request, path, &mut reader, out)
}

/// What [`fk_batch`] makes of a line that reads without error.
pub(super) enum Row {
    /// Nothing to write now: a blank line, a header row, or a configuration held for the batch
    /// kernel.
    Held,
    /// A configuration evaluated on its own (rates, or a request the batch kernel does not serve).
    Single(Configuration),
    /// A header row of names that cannot be read: the end of the run.
    BadHeader(CliError),
}

/// One result per line of `reader` (`path` names it in errors), in line order. Lines asking for
/// every link (the common case) go through the batch kernels, [`PendingPoses::MAX`] consecutive
/// lines of one level (poses, with `qd`, with `qd` and `qdd`) at a time, with their `--jacobian`
/// matrices (and, with `qd`, their rates) from the batch kernels of Jacobians; a request with
/// `--link` or `--point` goes line by line. Everything before
/// a bad line is written before its error. Whenever the input read is used up, the results held
/// are written and the output flushed: reading more may wait for a program that writes a line
/// at a time and waits for its result.
pub(super) fn fk_batch<R: std::io::Read>(
    chain: &Chain,
    args: &FkArgs,
    data: &mut Data,
    request: &mut Request,
    path: &Path,
    reader: &mut std::io::BufReader<R>,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let batchable = request.every_link(chain);
    let mut pending = PendingPoses {
        jacobians: request
            .outputs
            .jacobians
            .iter()
            .map(|r| JacobianResult {
                link: r.link,
                j: r.j.clone(),
                j_dot: r.j_dot.clone(),
                with_rate: false,
            })
            .collect(),
        jacobian_batch: BatchData::new(chain).with_limit_policy(data.limit_policy()),
        j: Vec::new(),
        j_dot: Vec::new(),
        qs: Vec::new(),
        qds: Vec::new(),
        qdds: Vec::new(),
        level: 0,
        lines: Vec::new(),
        batch: BatchData::new(chain).with_limit_policy(data.limit_policy()),
        text: Vec::new(),
    };
    let mut failed_lines = 0usize;
    let limit = batch_line_limit(chain.dof());
    let mut bytes = Vec::new();
    // The first line that is not blank may be a header row of joint names (`csv_header`).
    let mut first = true;
    let mut header = None;
    for i in 0.. {
        if reader.buffer().is_empty() {
            failed_lines += pending.flush(chain, args, path, out)?;
            out.flush().map_err(output_error)?;
        }
        // Without --keep-going a line past the cap ends the run, so nothing of it is skipped;
        // with it, a line is skipped (it costs no memory) for up to `MAX_SKIPPED_LINE` bytes
        // before reading gives up on an input without line ends.
        let skip = if args.keep_going { MAX_SKIPPED_LINE } else { 0 };
        let result = match read_capped_line(reader, &mut bytes, limit, skip) {
            Ok(CappedLine::End) => break,
            Ok(CappedLine::Unended) if args.keep_going => {
                pending.flush(chain, args, path, out)?;
                return Err(at_line(
                    path,
                    i + 1,
                    CliError::Unended {
                        limit: limit.saturating_add(skip),
                    },
                ));
            }
            Ok(CappedLine::Unended) => Err(CliError::LineTooLong { limit }),
            Ok(CappedLine::Line) => std::str::from_utf8(&bytes).map_err(|e| CliError::NotUtf8 {
                byte: e.valid_up_to() + 1,
            }),
            Ok(CappedLine::TooLong) => Err(CliError::LineTooLong { limit }),
            Err(source) => Err(CliError::Io {
                context: "cannot read line".into(),
                source,
            }),
        };
        let mut failed_before = 0;
        let result = result.and_then(|line| {
            // A byte order mark, which spreadsheet programs put at the start of the CSV files
            // they write, is not part of the first line.
            let line = match i {
                0 => line.strip_prefix('\u{feff}').unwrap_or(line),
                _ => line,
            };
            if line.trim().is_empty() {
                return Ok(Row::Held);
            }
            if std::mem::take(&mut first)
                && let Some(order) = crate::io::input::csv_header(chain, line)
            {
                return Ok(match order {
                    Ok(order) => {
                        header = Some(order);
                        Row::Held
                    }
                    Err(e) => Row::BadHeader(e.into()),
                });
            }
            let c = batch_configuration(chain, line, header.as_ref())?;
            if batchable {
                let (held, failed) = pending.hold(chain, args, path, &c, i + 1, out)?;
                failed_before += failed;
                if held {
                    return Ok(Row::Held);
                }
            }
            Ok(Row::Single(c))
        });
        failed_lines += failed_before;
        match result {
            Ok(Row::Held) => {
                if pending.lines.len() >= PendingPoses::MAX {
                    failed_lines += pending.flush(chain, args, path, out)?;
                }
            }
            // A header that cannot be read stops the run even under `--keep-going`: the rows
            // below it would be read in another order than the file's. (Nothing is pending: a
            // header is the first line that is not blank.)
            Ok(Row::BadHeader(e)) => return Err(at_line(path, i + 1, e)),
            Ok(Row::Single(c)) => {
                failed_lines += pending.flush(chain, args, path, out)?;
                match request.emit(chain, args, data, &c, Some(RowLabel::Line(i + 1)), out) {
                    Ok(()) => {}
                    Err(e @ CliError::Io { .. }) => return Err(e),
                    Err(e) if args.keep_going => {
                        failed_lines += 1;
                        write_line(out, &failed_line(chain, args, RowLabel::Line(i + 1), &e))?;
                    }
                    Err(e) => return Err(at_line(path, i + 1, e)),
                }
            }
            Err(e) => {
                failed_lines += pending.flush(chain, args, path, out)?;
                if !args.keep_going {
                    return Err(at_line(path, i + 1, e));
                }
                failed_lines += 1;
                write_line(out, &failed_line(chain, args, RowLabel::Line(i + 1), &e))?;
            }
        }
    }
    failed_lines += pending.flush(chain, args, path, out)?;
    if failed_lines > 0 {
        return Err(CliError::BatchFailures {
            path: path.to_path_buf(),
            count: failed_lines,
        });
    }
    Ok(())
}

/// The most bytes of one over-long batch line that `--keep-going` skips to find its end (the line
/// is an error in its place, and the lines after it are read); past this the input is taken to
/// have no line ends (`/dev/zero`) and the run stops.
pub(super) const MAX_SKIPPED_LINE: usize = 1 << 30;

/// The longest batch line read, in bytes: 1 MiB, plus 1 KiB per degree of freedom (a line names
/// at most three numbers per joint, or three members named after it).
pub(super) fn batch_line_limit(dof: usize) -> usize {
    (1 << 20) + dof.saturating_mul(1 << 10)
}

/// What [`read_capped_line`] read.
#[derive(Debug)]
pub(super) enum CappedLine {
    /// A line (without its end) is in the buffer.
    Line,
    /// The line was longer than the cap; the rest of it was skipped.
    TooLong,
    /// The line was longer than the cap, and more than the bytes allowed to skip followed
    /// without a line end (`/dev/zero`, a stream that never sends one): reading stopped.
    Unended,
    /// The input is exhausted.
    End,
}

/// Reads one line of at most `limit` bytes into `buf` (cleared first; `\n` and a `\r` before it
/// dropped). A longer line is skipped to its end without being kept, so one huge line costs no
/// more memory than the cap, unless more than `skip` bytes past the cap come without a line end.
pub(super) fn read_capped_line(
    reader: &mut impl BufRead,
    buf: &mut Vec<u8>,
    limit: usize,
    skip: usize,
) -> std::io::Result<CappedLine> {
    buf.clear();
    let mut too_long = false;
    let mut skipped = 0usize;
    let mut any = false;
    loop {
        let available = match reader.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if available.is_empty() {
            break;
        }
        any = true;
        let (chunk, done) = match available.iter().position(|&b| b == b'\n') {
            Some(end) => (&available[..end], Some(end + 1)),
            None => (available, None),
        };
        if !too_long {
            if buf.len() + chunk.len() > limit {
                too_long = true;
                buf.clear();
            } else {
                buf.extend_from_slice(chunk);
            }
        }
        if too_long {
            skipped = skipped.saturating_add(chunk.len());
            if done.is_none() && skipped > skip {
                return Ok(CappedLine::Unended);
            }
        }
        let used = done.unwrap_or(chunk.len());
        reader.consume(used);
        if done.is_some() {
            break;
        }
    }
    if too_long {
        return Ok(CappedLine::TooLong);
    }
    if !any {
        return Ok(CappedLine::End);
    }
    if buf.last() == Some(&b'\r') {
        buf.pop();
    }
    Ok(CappedLine::Line)
}

/// The output line standing in for a failed batch line under `--keep-going`: an object
/// `{"line": N, "error": ".."}` in JSON output, `line N: error: ..` in a table, and in CSV the
/// row of line N with its values empty and the message in the `error` column.
pub(super) fn failed_line(chain: &Chain, args: &FkArgs, label: RowLabel, e: &CliError) -> String {
    let key = match label {
        RowLabel::Line(_) => "line",
        RowLabel::Time(_) => "time",
    };
    match (args.format, label) {
        (OutputFormat::Json, RowLabel::Line(n)) => {
            json!({ "line": n, "error": error_chain(e) }).to_string()
        }
        (OutputFormat::Json, RowLabel::Time(t)) => {
            json!({ "time": t, "error": error_chain(e) }).to_string()
        }
        (OutputFormat::Table, _) => format!("{key} {label}: error: {}", error_chain(e)),
        (OutputFormat::Csv, _) => {
            let fields =
                csv_links(chain, args).len() * (3 + orientation_columns(args.orientation).len());
            format!(
                "{label}{},{}",
                ",".repeat(fields),
                csv_field(&error_chain(e))
            )
        }
    }
}

/// One batch line through [`crate::io::input::parse_batch_row`] (rows of numbers in the order of
/// `header`).
pub(super) fn batch_configuration(
    chain: &Chain,
    line: &str,
    header: Option<&crate::io::input::CsvHeader>,
) -> Result<Configuration, CliError> {
    let l = crate::io::input::parse_batch_row(chain, line, header)?;
    Ok(Configuration {
        q: l.q,
        qd: l.q_dot,
        qdd: l.q_ddot,
    })
}
