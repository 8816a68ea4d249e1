//! `kinechain fk --bag`: one result per `JointState` message of a ROS bag (MCAP), headed by the
//! message's time.

use crate::cli::args::FkArgs;
use crate::cli::batch::failed_line;
use crate::cli::common::write_line;
use crate::cli::error::CliError;
use crate::cli::format::{Configuration, RowLabel};
use crate::cli::query::Request;
use crate::eval::{Chain, Data};
use crate::io::bag::{JointStateOptions, read_joint_states};
use crate::regression::variable_names;
use std::io::Write;
use std::path::Path;

/// Each message's configuration (the chain's entries of `q`, found by joint name among the
/// topic's; a joint a message does not carry keeps its last value) through [`Request::emit`].
/// Messages before every joint of the chain has had a value are skipped, and counted on standard
/// error.
pub(super) fn fk_bag(
    chain: &Chain,
    args: &FkArgs,
    data: &mut Data,
    request: &mut Request,
    path: &Path,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let log = read_joint_states(path, &JointStateOptions::new(&args.topic))?;
    let columns = match log.columns_of(&variable_names(chain)) {
        Ok(columns) => columns,
        Err(missing) => {
            return Err(CliError::BagJoints {
                path: path.to_path_buf(),
                topic: args.topic.clone(),
                missing,
                present: log.names,
            });
        }
    };
    let (mut skipped, mut failed) = (0usize, 0usize);
    for (i, &time) in log.time.iter().enumerate() {
        let row = log.position_row(i);
        let q: Vec<f64> = columns.iter().map(|&c| row[c]).collect();
        if q.iter().any(|x| x.is_nan()) {
            skipped += 1;
            continue;
        }
        let c = Configuration {
            q,
            qd: None,
            qdd: None,
        };
        match request.emit(chain, args, data, &c, Some(RowLabel::Time(time)), out) {
            Ok(()) => {}
            Err(e @ CliError::Io { .. }) => return Err(e),
            Err(e) if args.keep_going => {
                failed += 1;
                write_line(out, &failed_line(chain, args, RowLabel::Time(time), &e))?;
            }
            Err(e) => {
                return Err(CliError::BagMessage {
                    path: path.to_path_buf(),
                    index: i,
                    time,
                    source: Box::new(e),
                });
            }
        }
    }
    if skipped > 0 {
        let _ = writeln!(
            std::io::stderr(),
            "warning: {skipped} message(s) of {} before every joint of the chain had a value: skipped",
            args.topic
        );
    }
    out.flush().map_err(|source| CliError::Io {
        context: "cannot write the output".into(),
        source,
    })?;
    if failed > 0 {
        return Err(CliError::BagFailures {
            path: path.to_path_buf(),
            count: failed,
        });
    }
    Ok(())
}

/// `fk --bag IN --tf OUT`: the log's TF, written to `OUT` ([`crate::io::tf`]); a line on standard
/// error says what was written.
pub(super) fn tf_bag(chain: &Chain, args: &FkArgs, path: &Path, tf: &Path) -> Result<(), CliError> {
    use crate::io::tf::{TfOptions, rows_of_log, write_tf};
    let log = read_joint_states(path, &JointStateOptions::new(&args.topic))?;
    let (time, q) = rows_of_log(chain, &log)?;
    let skipped = log.len() - time.len();
    let description = if args.robot.extension().is_some_and(|e| e == "urdf") {
        std::fs::read_to_string(&args.robot).ok()
    } else {
        None
    };
    let options = TfOptions {
        frame_prefix: args.frame_prefix.clone(),
        world_frame: args.world_frame.clone(),
        description,
    };
    let summary = write_tf(chain, &time, &q, tf, &[path, &args.robot], &options)?;
    let _ = writeln!(
        std::io::stderr(),
        "{}: {} /tf message(s) of {} transform(s), /tf_static of {}, /robot_description{}",
        tf.display(),
        summary.messages,
        summary.moving,
        summary.fixed,
        if skipped > 0 {
            format!(" ({skipped} message(s) before every joint had a value: skipped)")
        } else {
            String::new()
        }
    );
    Ok(())
}
