//! One `fk` request: the evaluation of one configuration and the tables of its results.

use crate::cli::args::{FkArgs, OutputFormat, Point, parse_point};
use crate::cli::error::CliError;
use crate::cli::format::{
    Configuration, JacobianResult, LinkResult, PointResult, ResultsJson, RowLabel, check_finite,
    csv_row, push_cells, results_table, write_buffered_line, write_json_line,
};
use crate::eval::Chain;
use crate::eval::Data;
use crate::eval::{
    Poses, Velocities, forward_accelerations, forward_kinematics, forward_kinematics_to,
    forward_velocities,
};
use crate::model::chain::LinkId;
use nalgebra::Vector3;
use std::io::Write;
use std::path::Path;

/// What `fk` computes for one configuration, in buffers reused from one to the next.
pub(super) struct Outputs {
    /// Per link printed: pose and the rates asked for.
    pub(super) links: Vec<LinkResult>,
    /// Per `--point`.
    pub(super) points: Vec<PointResult>,
    /// Per `--jacobian` link.
    pub(super) jacobians: Vec<JacobianResult>,
}

/// Writes each Jacobian of `jacobians` from `poses`, and its time derivative from `velocities`
/// when given; an entry too large for `f64` is an error.
pub(super) fn jacobians_from(
    chain: &Chain,
    poses: &Poses,
    velocities: Option<&Velocities>,
    jacobians: &mut [JacobianResult],
    base: Option<LinkId>,
) -> Result<(), CliError> {
    if base.is_some() && velocities.is_some() && !jacobians.is_empty() {
        return Err(CliError::Unsupported(
            "--jacobian with --base and --qd: the rate of a relative Jacobian is not computed",
        ));
    }
    for r in jacobians.iter_mut() {
        match base {
            Some(b) => r.j = poses.jacobian_relative(r.link, b, crate::eval::JacobianFrame::World),
            None => poses.jacobian_into(r.link, &mut r.j),
        }
        r.with_rate = velocities.is_some();
        if let Some(v) = velocities {
            v.jacobian_dot_into(r.link, &mut r.j_dot);
        }
    }
    jacobians_finite(chain, jacobians)
}

/// An error naming the first link whose Jacobian (or, where current, its rate) has an entry
/// too large for `f64`.
pub(super) fn jacobians_finite(
    chain: &Chain,
    jacobians: &[JacobianResult],
) -> Result<(), CliError> {
    for r in jacobians {
        let place = || format!("link '{}'", chain.link(r.link).name());
        if !r.j.iter().all(|x| x.is_finite()) {
            return Err(CliError::NotFinite {
                what: "jacobian",
                place: place(),
            });
        }
        if r.with_rate && !r.j_dot.iter().all(|x| x.is_finite()) {
            return Err(CliError::NotFinite {
                what: "jacobian rate",
                place: place(),
            });
        }
    }
    Ok(())
}

pub(super) fn evaluate(
    chain: &Chain,
    data: &mut Data,
    c: &Configuration,
    links: &[LinkId],
    points: &[Point],
    base: Option<LinkId>,
    out: &mut Outputs,
) -> Result<(), CliError> {
    if base.is_some() && !points.is_empty() {
        return Err(CliError::Unsupported(
            "--point with --base: points are printed in world coordinates",
        ));
    }
    let Outputs {
        links: results,
        points: point_results,
        jacobians,
    } = out;
    results.clear();
    point_results.clear();
    let all: Vec<LinkId>;
    let wanted = if links.is_empty() {
        all = (0..chain.links().len()).map(LinkId).collect();
        &all[..]
    } else {
        links
    };
    match (&c.qd, &c.qdd) {
        (None, Some(_)) => return Err(CliError::QddWithoutQd),
        // Only the paths to the links asked for, unless a point or a Jacobian needs the poses
        // view of a whole evaluation.
        (None, None)
            if !links.is_empty() && points.is_empty() && jacobians.is_empty() && base.is_none() =>
        {
            for &l in wanted {
                let pose = forward_kinematics_to(chain, data, &c.q, l)?;
                results.push((l, pose, None, None));
            }
        }
        (None, None) => {
            let poses = forward_kinematics(chain, data, &c.q)?;
            jacobians_from(chain, &poses, None, jacobians, base)?;
            results.extend(wanted.iter().map(|&l| {
                let pose = match base {
                    Some(b) => poses.base_from_link(b, l),
                    None => poses.world_from_link(l),
                };
                (l, pose, None, None)
            }));
            point_results.extend(points.iter().map(|p| {
                PointResult {
                    position: poses
                        .world_from_link(p.link)
                        .transform_point(&p.u.into())
                        .coords,
                    velocity: None,
                    acceleration: None,
                }
            }));
        }
        (Some(qd), None) => {
            let v = forward_velocities(chain, data, &c.q, qd)?;
            jacobians_from(chain, &v.poses(), Some(&v), jacobians, base)?;
            results.extend(wanted.iter().map(|&l| match base {
                Some(b) => (
                    l,
                    v.poses().base_from_link(b, l),
                    Some(v.velocity_relative(l, b)),
                    None,
                ),
                None => (l, v.world_from_link(l), Some(v.velocity(l)), None),
            }));
            point_results.extend(points.iter().map(|p| {
                let m = v.point(p.link, &p.u);
                PointResult {
                    position: m.position,
                    velocity: Some(m.velocity),
                    acceleration: None,
                }
            }));
        }
        (Some(qd), Some(qdd)) => {
            let a = forward_accelerations(chain, data, &c.q, qd, qdd)?;
            jacobians_from(chain, &a.poses(), Some(&a.velocities()), jacobians, base)?;
            results.extend(wanted.iter().map(|&l| match base {
                Some(b) => (
                    l,
                    a.poses().base_from_link(b, l),
                    Some(a.velocity_relative(l, b)),
                    Some(a.acceleration_relative(l, b)),
                ),
                None => (
                    l,
                    a.world_from_link(l),
                    Some(a.velocity(l)),
                    Some(a.acceleration(l)),
                ),
            }));
            point_results.extend(points.iter().map(|p| {
                let m = a.point(p.link, &p.u);
                PointResult {
                    position: m.position,
                    velocity: Some(m.velocity),
                    acceleration: Some((m.acceleration, m.parts)),
                }
            }));
        }
    }
    Ok(())
}

/// `fk --format table`: appends a line per point (each starting with a newline): its position,
/// then its rates.
pub(super) fn points_table(
    chain: &Chain,
    points: &[Point],
    results: &[PointResult],
    buf: &mut Vec<u8>,
) {
    let v3 = |buf: &mut Vec<u8>, label: &str, v: &Vector3<f64>| {
        let _ = write!(buf, "{label}(");
        push_cells(buf, [v.x, v.y, v.z], b", ", 0);
        buf.push(b')');
    };
    for (p, r) in points.iter().zip(results) {
        let _ = write!(buf, "\n{}: ", p.label(chain));
        v3(buf, "position ", &r.position);
        if let Some(v) = &r.velocity {
            v3(buf, ", velocity ", v);
        }
        if let Some((a, _)) = &r.acceleration {
            v3(buf, ", acceleration ", a);
        }
    }
}

/// `fk --format table`: appends each Jacobian (and `J̇`, with rates) under a heading naming its
/// link, one row per twist component (each line starting with a newline).
pub(super) fn jacobians_table(chain: &Chain, jacobians: &[JacobianResult], buf: &mut Vec<u8>) {
    let block = |buf: &mut Vec<u8>, m: &nalgebra::Matrix6xX<f64>| {
        for (name, row) in ["v_x", "v_y", "v_z", "omega_x", "omega_y", "omega_z"]
            .iter()
            .zip(m.row_iter())
        {
            let _ = write!(buf, "\n{name:<8}");
            push_cells(buf, row.iter().copied(), b" ", 12);
        }
    };
    for r in jacobians {
        let link = chain.link(r.link).name();
        let _ = write!(
            buf,
            "\njacobian of {link} ([v; omega] = J qd, columns in q order)"
        );
        block(buf, &r.j);
        if r.with_rate {
            let _ = write!(
                buf,
                "\njacobian rate of {link} ([a; alpha] = J qdd + Jdot qd)"
            );
            block(buf, &r.j_dot);
        }
    }
}

/// What `fk` prints for each configuration (`--link`, `--point`, `--jacobian`), with the
/// buffers of the results.
pub(super) struct Request {
    /// `--base`: the link whose frame the results are in.
    pub(super) base: Option<LinkId>,
    pub(super) links: Vec<LinkId>,
    pub(super) points: Vec<Point>,
    pub(super) outputs: Outputs,
    /// One line of output (JSON or a table), reused.
    pub(super) text: Vec<u8>,
}

impl Request {
    pub(super) fn new(chain: &Chain, args: &FkArgs) -> Result<Request, CliError> {
        // A link named twice in `--link` or `--jacobian` is printed once (a JSON object cannot
        // hold its name twice), where it was first named.
        let unique = |names: &[String]| -> Result<Vec<LinkId>, CliError> {
            let mut ids = Vec::with_capacity(names.len());
            for name in names {
                let id = chain.link_id(name)?;
                if !ids.contains(&id) {
                    ids.push(id);
                }
            }
            Ok(ids)
        };
        if args.format == OutputFormat::Csv
            && (!args.points.is_empty() || !args.jacobians.is_empty() || args.qd.is_some())
        {
            return Err(CliError::Csv(
                "prints link poses; --point, --jacobian, --qd and --qdd need json or table",
            ));
        }
        let links = unique(&args.links)?;
        let points = args
            .points
            .iter()
            .map(|p| parse_point(chain, p))
            .collect::<Result<Vec<_>, _>>()?;
        let outputs = Outputs {
            links: Vec::with_capacity(chain.links().len()),
            points: Vec::with_capacity(points.len()),
            jacobians: unique(&args.jacobians)?
                .into_iter()
                .map(|link| JacobianResult {
                    link,
                    j: nalgebra::Matrix6xX::zeros(chain.dof()),
                    j_dot: nalgebra::Matrix6xX::zeros(chain.dof()),
                    with_rate: false,
                })
                .collect(),
        };
        let base = args.base.as_deref().map(|b| chain.link_id(b)).transpose()?;
        Ok(Request {
            base,
            links,
            points,
            outputs,
            text: Vec::new(),
        })
    }

    /// Whether the request is every link (and any `--jacobian` links) and no point, which the
    /// batch kernels can evaluate (a chain without moving joints has empty configurations, which
    /// a flat batch cannot count).
    pub(super) fn every_link(&self, chain: &Chain) -> bool {
        self.links.is_empty() && self.points.is_empty() && self.base.is_none() && chain.dof() > 0
    }

    /// Evaluates `c` and writes its results in the format `args` asks for, headed by the batch
    /// line `line` they are for, if any.
    pub(super) fn emit(
        &mut self,
        chain: &Chain,
        args: &FkArgs,
        data: &mut Data,
        c: &Configuration,
        line: Option<RowLabel>,
        out: &mut dyn Write,
    ) -> Result<(), CliError> {
        if args.format == OutputFormat::Csv && c.qd.is_some() {
            return Err(CliError::Csv(
                "prints link poses; velocities and accelerations need json or table",
            ));
        }
        evaluate(
            chain,
            data,
            c,
            &self.links,
            &self.points,
            self.base,
            &mut self.outputs,
        )?;
        let Outputs {
            links: results,
            points: point_results,
            jacobians,
        } = &self.outputs;
        let points = &self.points;
        check_finite(chain, results, points, point_results)?;
        match args.format {
            OutputFormat::Json => {
                let value = ResultsJson {
                    line,
                    chain,
                    results,
                    orientation: args.orientation,
                    points,
                    point_results,
                    jacobians,
                };
                write_json_line(out, &mut self.text, &value)
            }
            OutputFormat::Table => write_buffered_line(out, &mut self.text, |buf| {
                line_heading(line, buf);
                results_table(chain, results, args.orientation, buf);
                points_table(chain, points, point_results, buf);
                jacobians_table(chain, jacobians, buf);
                Ok(())
            }),
            OutputFormat::Csv => write_buffered_line(out, &mut self.text, |buf| {
                csv_row(line, results, args.orientation, buf);
                Ok(())
            }),
        }
    }
}

/// The heading of a batch line's table, `line N:` on a line of its own.
pub(super) fn line_heading(line: Option<RowLabel>, buf: &mut Vec<u8>) {
    match line {
        Some(RowLabel::Line(line)) => buf.extend_from_slice(format!("line {line}:\n").as_bytes()),
        Some(RowLabel::Time(time)) => buf.extend_from_slice(format!("time {time}:\n").as_bytes()),
        None => {}
    }
}

/// The error of line `line` of the batch file `path`.
pub(super) fn at_line(path: &Path, line: usize, source: CliError) -> CliError {
    CliError::BatchLine {
        path: path.to_path_buf(),
        line,
        source: Box::new(source),
    }
}
