//! `kinechain ik`: the joint values that put a link at a target, for one target or a file of
//! them (`kinechain::ik`).

use crate::cli::args::{IkArgs, OutputFormat};
use crate::cli::common::{load, output_error, write_line};
use crate::cli::error::CliError;
use crate::eval::Chain;
use crate::ik::{Goal, Options, Solution, Solver};
use crate::io::input::joint_vector_from_str;
use crate::model::transform::Transform;
use crate::regression::variable_names;
use std::io::{BufRead, Write};

/// A target read from text: a pose, or a position only.
struct Target {
    pose: Transform,
    position_only: bool,
}

/// A target from its numbers: 3 (a position, the orientation free), 6 (x y z and roll pitch yaw,
/// rad, as URDF's `rpy`), 7 (x y z and a quaternion w x y z) or 16 (a 4 × 4 matrix, row by row);
/// as a JSON array (flat, or of four rows) or separated by commas or spaces.
fn parse_target(text: &str) -> Result<Target, String> {
    let text = text.trim();
    let numbers: Vec<f64> = if text.starts_with('[') {
        let v: serde_json::Value =
            serde_json::from_str(text).map_err(|e| format!("not a JSON array: {e}"))?;
        let flat: Vec<&serde_json::Value> = match v.as_array() {
            Some(rows) if rows.iter().all(serde_json::Value::is_array) => rows
                .iter()
                .flat_map(|r| r.as_array().into_iter().flatten())
                .collect(),
            Some(items) => items.iter().collect(),
            None => return Err("not a JSON array".into()),
        };
        flat.iter()
            .map(|x| x.as_f64().ok_or_else(|| format!("{x} is not a number")))
            .collect::<Result<_, _>>()?
    } else {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| {
                s.parse::<f64>()
                    .map_err(|_| format!("'{s}' is not a number"))
            })
            .collect::<Result<_, _>>()?
    };
    if let Some(x) = numbers.iter().find(|x| !x.is_finite()) {
        return Err(format!("{x} is not finite"));
    }
    let n = &numbers;
    let pose = match n.len() {
        3 => Transform::from_xyz_rpy([n[0], n[1], n[2]], [0.0; 3]),
        6 => Transform::from_xyz_rpy([n[0], n[1], n[2]], [n[3], n[4], n[5]]),
        7 => {
            let norm = (n[3] * n[3] + n[4] * n[4] + n[5] * n[5] + n[6] * n[6]).sqrt();
            if (norm - 1.0).abs() > 1e-6 {
                return Err(format!("the quaternion (w x y z) has norm {norm}, not 1"));
            }
            let e = crate::orientation::EulerParameters::from_vector(&nalgebra::Vector4::new(
                n[3], n[4], n[5], n[6],
            ));
            Transform::from_parts(&e.to_matrix(), &nalgebra::Vector3::new(n[0], n[1], n[2]))
        }
        16 => {
            let rows = [
                [n[0], n[1], n[2], n[3]],
                [n[4], n[5], n[6], n[7]],
                [n[8], n[9], n[10], n[11]],
                [n[12], n[13], n[14], n[15]],
            ];
            Transform::try_from_rows(&rows).map_err(|e| e.to_string())?
        }
        k => {
            return Err(format!(
                "{k} numbers: a target is 3 (x y z), 6 (x y z roll pitch yaw), 7 (x y z qw qx qy qz) or 16 (a 4 × 4 matrix)"
            ));
        }
    };
    Ok(Target {
        pose,
        position_only: n.len() == 3,
    })
}

pub(super) fn ik(
    args: &IkArgs,
    options: &crate::io::LoadOptions,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let chain = load(&args.robot, options)?;
    let link = chain.link_id(&args.link)?;
    let base = args.base.as_deref().map(|b| chain.link_id(b)).transpose()?;
    let locked = args
        .locked
        .iter()
        .map(|j| chain.joint_id(j))
        .collect::<Result<Vec<_>, _>>()?;
    let q0 = args
        .q0
        .as_deref()
        .map(|t| joint_vector_from_str(&chain, t, "q0"))
        .transpose()?;
    let options = Options {
        position_tolerance: args.position_tolerance,
        rotation_tolerance: args.rotation_tolerance,
        max_attempts: args.max_attempts,
        seed: args.seed,
        locked,
        ..Options::default()
    };
    let make = |position_only: bool| {
        let mut goal = if position_only {
            Goal::position(link)
        } else {
            Goal::pose(link)
        };
        if let Some(b) = base {
            goal = goal.relative_to(b);
        }
        Solver::new(&chain, vec![goal], options.clone()).map_err(ik_error)
    };
    let (mut pose_solver, mut position_solver) = (make(false)?, make(true)?);
    let names = variable_names(&chain);
    if args.format == OutputFormat::Csv {
        let mut header = vec![
            "success".to_string(),
            "position_error".into(),
            "rotation_error".into(),
            "iterations".into(),
            "restarts".into(),
        ];
        header.extend(names.iter().cloned());
        write_line(out, &header.join(","))?;
    }
    let mut unsolved = 0usize;
    let mut total = 0usize;
    let mut solve =
        |target: Target, line: Option<usize>, out: &mut dyn Write| -> Result<(), CliError> {
            let solver = if target.position_only {
                &mut position_solver
            } else {
                &mut pose_solver
            };
            let s = solver
                .solve(&[target.pose], q0.as_deref())
                .map_err(ik_error)?;
            total += 1;
            unsolved += usize::from(!s.success);
            emit(&chain, &names, &s, args.format, line, out)
        };
    match (&args.target, &args.batch) {
        (Some(t), None) => {
            let target = parse_target(t).map_err(|e| CliError::Ik(format!("--target: {e}")))?;
            solve(target, None, out)?;
        }
        (None, Some(path)) => {
            let reader: Box<dyn BufRead> = if path.as_os_str() == "-" {
                Box::new(std::io::BufReader::new(std::io::stdin()))
            } else {
                let file = std::fs::File::open(path).map_err(|source| CliError::Io {
                    context: format!("cannot read {}", path.display()),
                    source,
                })?;
                Box::new(std::io::BufReader::new(file))
            };
            for (i, line) in reader.lines().enumerate() {
                let line = line.map_err(|source| CliError::Io {
                    context: format!("cannot read {}", path.display()),
                    source,
                })?;
                let text = line.trim();
                // Blank lines, and a first line of column names, carry no target.
                if text.is_empty()
                    || (i == 0 && text.chars().next().is_some_and(char::is_alphabetic))
                {
                    continue;
                }
                let target = parse_target(text)
                    .map_err(|e| CliError::Ik(format!("{} line {}: {e}", path.display(), i + 1)))?;
                solve(target, Some(i + 1), out)?;
                out.flush().map_err(output_error)?;
            }
        }
        _ => return Err(CliError::Ik("give --target or --batch".into())),
    }
    if unsolved > 0 {
        return Err(CliError::Ik(format!(
            "{unsolved} of {total} targets not reached within the tolerances (the results printed are the closest found)"
        )));
    }
    Ok(())
}

fn ik_error(e: crate::ik::IkError) -> CliError {
    CliError::Ik(crate::error::error_chain(&e))
}

/// One solution in `format`: a JSON object, a CSV row, or a table of names and values.
fn emit(
    chain: &Chain,
    names: &[String],
    s: &Solution,
    format: OutputFormat,
    line: Option<usize>,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let (pe, re) = (s.position_error[0], s.rotation_error[0]);
    match format {
        OutputFormat::Json => {
            let mut object = serde_json::Map::new();
            if let Some(l) = line {
                object.insert("line".into(), l.into());
            }
            object.insert("success".into(), s.success.into());
            object.insert("q".into(), s.q.clone().into());
            object.insert("position_error".into(), pe.into());
            object.insert("rotation_error".into(), re.into());
            object.insert("iterations".into(), s.iterations.into());
            object.insert("restarts".into(), s.restarts.into());
            write_line(out, &serde_json::Value::Object(object).to_string())
        }
        OutputFormat::Csv => {
            let mut row = vec![
                s.success.to_string(),
                format!("{pe:e}"),
                format!("{re:e}"),
                s.iterations.to_string(),
                s.restarts.to_string(),
            ];
            row.extend(s.q.iter().map(|x| format!("{x}")));
            write_line(out, &row.join(","))
        }
        OutputFormat::Table => {
            if let Some(l) = line {
                write_line(out, &format!("line {l}"))?;
            }
            write_line(
                out,
                &format!(
                    "{} (position error {pe:.3e} m, rotation error {re:.3e} rad, {} iterations, {} restarts)",
                    if s.success { "solved" } else { "NOT solved" },
                    s.iterations,
                    s.restarts
                ),
            )?;
            let width = names.iter().map(String::len).max().unwrap_or(0);
            for (name, x) in names.iter().zip(&s.q) {
                write_line(out, &format!("  {name:width$}  {x:>12.6}"))?;
            }
            let _ = chain;
            Ok(())
        }
    }
}
