//! Regression tests on link kinematics: [`record`] a robot's link poses (and rates) at seeded
//! configurations into a [`Golden`] record, [`verify`] a robot against one, [`compare`] two robots
//! over the joints and links they share by name. Each gives a [`Report`]: per link, the largest
//! position, rotation and rate differences and the sample where each occurs, and the verdict
//! against [`Tolerances`].
//!
//! Joints are matched by name (a cylindrical joint's entries as `NAME.theta` and `NAME.d`), so a
//! robot whose `q` order changed still verifies. Evaluations run with the limits ignored: a
//! recorded configuration outside the verified robot's limits is still compared (the report
//! counts them), since a change of limits is not a change of kinematics.
//!
//! The golden file is JSON lines: a header (robot, dof, joint and link names, kinechain version,
//! seed, sample count, level), then one line per sample. Numbers are written so that they read
//! back to the same `f64`, and the same inputs give the same bytes.
//!
//! This layer may use [`crate::model`], [`crate::eval`], [`crate::io`] and [`crate::measure`].

mod error;
mod golden;
mod options;
mod report;

pub use error::RegressionError;
pub use options::{Level, MAX_GOLDEN_BYTES, MAX_GOLDEN_LINE_BYTES, Options, Tolerances};

pub use golden::{
    Golden, Header, LinkState, Sample, golden_bytes, read_golden, read_golden_file, write_golden,
    write_golden_file,
};
pub use report::{LinkReport, Names, Report, Worst};

use crate::eval::Chain;
use crate::eval::{Data, LimitPolicy};
use crate::eval::{check_q, forward_accelerations, forward_kinematics, forward_velocities};
use crate::measure::{SplitMix, between};
use crate::model::chain::LinkId;
use crate::model::transform::Transform;
use std::f64::consts::PI;

/// The name of each entry of `q`: the joint's, or `NAME.COMPONENT` for a joint of several
/// (`NAME.theta` / `NAME.d` of a cylindrical joint, `NAME.x` … `NAME.qz` of a floating one).
#[must_use]
pub fn variable_names(chain: &Chain) -> Vec<String> {
    names(chain, chain.variables())
}

/// The name of each entry of `q̇` (and `q̈`): as [`variable_names`], but `NAME.vx` … `NAME.wz` for
/// a floating joint's six.
#[must_use]
pub fn velocity_names(chain: &Chain) -> Vec<String> {
    names(chain, chain.velocity_variables())
}

/// The unit of each entry of `q`, as [`variable_names`] lists them: `rad` (a revolute or
/// continuous joint, a cylindrical joint's θ), `m` (a prismatic joint, a cylindrical joint's d, a
/// floating joint's position) or `1` (a floating or ball joint's quaternion).
#[must_use]
pub fn variable_units(chain: &Chain) -> Vec<&'static str> {
    use crate::model::joint::JointKind;
    chain
        .variables()
        .map(|(j, component)| match (chain.joint(j).kind(), component) {
            (JointKind::Revolute | JointKind::Continuous, _)
            | (JointKind::Cylindrical, Some("theta")) => "rad",
            (JointKind::Floating | JointKind::Ball, Some("qw" | "qx" | "qy" | "qz")) => "1",
            _ => "m",
        })
        .collect()
}

fn names<'c>(
    chain: &Chain,
    entries: impl Iterator<Item = (crate::model::chain::JointId, Option<&'c str>)>,
) -> Vec<String> {
    entries
        .map(|(j, component)| {
            let name = chain.joint(j).name();
            component.map_or_else(|| name.to_string(), |c| format!("{name}.{c}"))
        })
        .collect()
}

/// The configurations a record is made at: zero, the lower and the upper corner of the limits
/// (each where the limits admit it; an entry without a finite bound takes its neutral value),
/// then `samples` drawn uniformly within [`Chain::lower`] and [`Chain::upper`] (`[−π, π]` where
/// unbounded, or the 2π beside a single bound). With `level` above poses each gets `q̇` and `q̈`
/// (as the level needs) drawn uniformly from `[−1, 1]`.
fn configurations(chain: &Chain, options: &Options) -> Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let (lower, upper, neutral) = (chain.lower(), chain.upper(), chain.neutral());
    let (dof, nv) = (chain.nq(), chain.nv());
    let admitted = |q: &Vec<f64>| check_q(chain, q, LimitPolicy::Enforce).is_ok();
    let corner = |bound: &[f64]| -> Vec<f64> {
        (0..dof)
            .map(|i| {
                if bound[i].is_finite() {
                    bound[i]
                } else {
                    neutral[i]
                }
            })
            .collect()
    };
    let mut qs: Vec<Vec<f64>> = Vec::new();
    for q in [vec![0.0; dof], corner(&lower), corner(&upper)] {
        if admitted(&q) && !qs.contains(&q) {
            qs.push(q);
        }
    }
    let mut rng = SplitMix(options.seed);
    for _ in 0..options.samples {
        let mut q: Vec<f64> = (0..dof)
            .map(|i| {
                let (lo, hi) = match (lower[i].is_finite(), upper[i].is_finite()) {
                    (true, true) => (lower[i], upper[i]),
                    (true, false) => (lower[i], lower[i] + 2.0 * PI),
                    (false, true) => (upper[i] - 2.0 * PI, upper[i]),
                    (false, false) => (-PI, PI),
                };
                between(lo, hi, rng.unit())
            })
            .collect();
        // Floating and ball joints' quaternions, drawn as uniformly random rotations.
        for &(_, first) in chain.quaternions() {
            q[first..first + 4].copy_from_slice(&rng.unit_quaternion());
        }
        qs.push(q);
    }
    let mut rates = |n| (0..n).map(|_| 2.0 * rng.unit() - 1.0).collect::<Vec<f64>>();
    qs.into_iter()
        .map(|q| {
            let qd = if options.level == Level::Pose {
                vec![0.0; nv]
            } else {
                rates(nv)
            };
            let qdd = if options.level == Level::Acc {
                rates(nv)
            } else {
                vec![0.0; nv]
            };
            (q, qd, qdd)
        })
        .collect()
}

/// Evaluates every link in `links` at one configuration, as a record holds it.
fn states(
    chain: &Chain,
    data: &mut Data,
    links: &[LinkId],
    level: Level,
    (q, qd, qdd): (&[f64], &[f64], &[f64]),
    sample: usize,
) -> Result<Vec<LinkState>, RegressionError> {
    let state = |source| RegressionError::State { sample, source };
    let mut out = Vec::with_capacity(links.len());
    let finite = |link: LinkId, what, v: &[f64]| {
        if v.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(RegressionError::NotFinite {
                sample,
                link: chain.link(link).name().to_string(),
                what,
            })
        }
    };
    let pose_of = |t: &Transform| -> [f64; 12] {
        let rows = t.to_rows();
        std::array::from_fn(|k| rows[k / 4][k % 4])
    };
    match level {
        Level::Pose => {
            let poses = forward_kinematics(chain, data, q).map_err(state)?;
            for &link in links {
                let pose = pose_of(&poses.world_from_link(link));
                finite(link, "pose", &pose)?;
                out.push(LinkState::pose(pose));
            }
        }
        Level::Vel => {
            let vel = forward_velocities(chain, data, q, qd).map_err(state)?;
            for &link in links {
                let pose = pose_of(&vel.world_from_link(link));
                finite(link, "pose", &pose)?;
                let v = vel.velocity(link);
                let s = LinkState {
                    omega: Some(v.omega.into()),
                    v: Some(v.v.into()),
                    ..LinkState::pose(pose)
                };
                for (what, x) in [("omega", &s.omega), ("v", &s.v)] {
                    finite(link, what, x.as_ref().map_or(&[][..], |x| x))?;
                }
                out.push(s);
            }
        }
        Level::Acc => {
            let acc = forward_accelerations(chain, data, q, qd, qdd).map_err(state)?;
            for &link in links {
                let pose = pose_of(&acc.world_from_link(link));
                finite(link, "pose", &pose)?;
                let (v, a) = (acc.velocity(link), acc.acceleration(link));
                let s = LinkState {
                    pose,
                    omega: Some(v.omega.into()),
                    v: Some(v.v.into()),
                    alpha: Some(a.alpha.into()),
                    a: Some(a.a.into()),
                };
                for (what, x) in [
                    ("omega", &s.omega),
                    ("v", &s.v),
                    ("alpha", &s.alpha),
                    ("a", &s.a),
                ] {
                    finite(link, what, x.as_ref().map_or(&[][..], |x| x))?;
                }
                out.push(s);
            }
        }
    }
    Ok(out)
}

/// The links named, or every link; each named link must exist.
fn chosen_links(chain: &Chain, names: &[String]) -> Result<Vec<LinkId>, RegressionError> {
    if names.is_empty() {
        return Ok((0..chain.links().len())
            .map(|i| chain.link_id(chain.links()[i].name()))
            .collect::<Result<_, _>>()?);
    }
    let mut ids: Vec<LinkId> = Vec::new();
    for name in names {
        let id = chain.link_id(name)?;
        if !ids.contains(&id) {
            ids.push(id);
        }
    }
    Ok(ids)
}

/// Records `chain` at the configurations `options` describes.
///
/// # Errors
/// An unknown link name; a chain without joints to move; a pose or rate that is not finite.
pub fn record(chain: &Chain, options: &Options) -> Result<Golden, RegressionError> {
    if chain.dof() == 0 {
        return Err(RegressionError::Empty(
            "the chain has no joints to move: there is nothing to record",
        ));
    }
    let links = chosen_links(chain, &options.links)?;
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let mut samples = Vec::new();
    for (i, (q, qd, qdd)) in configurations(chain, options).into_iter().enumerate() {
        let links = states(chain, &mut data, &links, options.level, (&q, &qd, &qdd), i)?;
        samples.push(Sample {
            sample: i,
            qd: (options.level != Level::Pose).then_some(qd),
            qdd: (options.level == Level::Acc).then_some(qdd),
            q,
            links,
        });
    }
    Ok(Golden {
        header: Header {
            kinechain_golden: golden::FORMAT,
            robot: chain.name().to_string(),
            dof: chain.nq(),
            joints: variable_names(chain),
            rates: match chain.nq() == chain.nv() {
                true => Vec::new(),
                false => velocity_names(chain),
            },
            links: links
                .iter()
                .map(|&l| chain.link(l).name().to_string())
                .collect(),
            kinechain: env!("CARGO_PKG_VERSION").to_string(),
            seed: options.seed,
            samples: samples.len(),
            level: options.level,
        },
        samples,
    })
}

/// Evaluates `chain` at the record's configurations and compares every recorded link.
///
/// # Errors
/// [`RegressionError::Joints`] when the joint names differ (listing both sides),
/// [`RegressionError::Links`] when recorded links are missing; an evaluation that fails.
pub fn verify(
    chain: &Chain,
    golden: &Golden,
    tolerances: &Tolerances,
) -> Result<Report, RegressionError> {
    let names = variable_names(chain);
    let missing: Vec<String> = golden
        .header
        .joints
        .iter()
        .filter(|j| !names.contains(j))
        .cloned()
        .collect();
    let extra: Vec<String> = names
        .iter()
        .filter(|j| !golden.header.joints.contains(j))
        .cloned()
        .collect();
    if !missing.is_empty() || !extra.is_empty() {
        return Err(RegressionError::Joints { missing, extra });
    }
    let order = |mine: &[String], theirs: &[String]| -> Vec<usize> {
        mine.iter()
            .map(|n| theirs.iter().position(|j| j == n).unwrap_or(0))
            .collect()
    };
    let q_order = order(&names, &golden.header.joints);
    let v_order = order(&velocity_names(chain), golden.header.rate_names());
    check_links(chain, &golden.header.links)?;
    let mut report = Report::new(chain, &golden.header.links, golden.header.level, tolerances);
    evaluate_against(chain, golden, &mut report, |recorded, rates| {
        let order = if rates { &v_order } else { &q_order };
        order.iter().map(|&k| recorded[k]).collect()
    })?;
    Ok(report)
}

/// Every name in `links` is a link of `chain`.
fn check_links(chain: &Chain, links: &[String]) -> Result<(), RegressionError> {
    let missing: Vec<String> = links
        .iter()
        .filter(|l| chain.link_id(l).is_err())
        .cloned()
        .collect();
    if missing.is_empty() {
        Ok(())
    } else {
        Err(RegressionError::Links { missing })
    }
}

/// Evaluates `chain` at each sample (its `q`, `q̇`, `q̈` mapped by `to_chain`, told whether it
/// maps rates) and adds the differences to `report`.
fn evaluate_against(
    chain: &Chain,
    golden: &Golden,
    report: &mut Report,
    to_chain: impl Fn(&[f64], bool) -> Vec<f64>,
) -> Result<(), RegressionError> {
    let links = chosen_links(chain, &golden.header.links)?;
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let zero = vec![0.0; golden.header.rate_names().len()];
    for s in &golden.samples {
        let q = to_chain(&s.q, false);
        let qd = to_chain(s.qd.as_deref().unwrap_or(&zero), true);
        let qdd = to_chain(s.qdd.as_deref().unwrap_or(&zero), true);
        if check_q(chain, &q, LimitPolicy::Enforce).is_err() {
            report.outside_limits += 1;
        }
        let now = states(
            chain,
            &mut data,
            &links,
            golden.header.level,
            (&q, &qd, &qdd),
            s.sample,
        )?;
        report.add(s.sample, &s.links, &now);
    }
    report.samples = golden.samples.len();
    Ok(())
}

/// Compares `b` with `a` at configurations drawn for `a` (`options`), joints matched by name;
/// the links compared are those named in `options` (each must be in both) or every link they
/// share. The report lists the links only one of them has. Both robots must have the same joint
/// entries: a joint only one has would take a value in one robot and none in the other, and the
/// links below it would seem to move. [`compare_renamed`] maps renamed joints.
///
/// # Errors
/// [`RegressionError::UnmatchedJoints`] listing the joint entries only one robot has; a link
/// asked for that one of them lacks; a chain without joints to move; an evaluation that fails.
pub fn compare(
    a: &Chain,
    b: &Chain,
    options: &Options,
    tolerances: &Tolerances,
) -> Result<Report, RegressionError> {
    compare_renamed(a, b, options, tolerances, &[])
}

/// [`compare`], with the joint `old` of `a` matched to the joint `new` of `b` for each
/// `(old, new)` of `renames` (a cylindrical joint's two entries with it).
///
/// # Errors
/// As [`compare`]; [`RegressionError::Rename`] when a rename names a joint that is not in its
/// robot, or names a joint twice.
pub fn compare_renamed(
    a: &Chain,
    b: &Chain,
    options: &Options,
    tolerances: &Tolerances,
    renames: &[(String, String)],
) -> Result<Report, RegressionError> {
    let rename_problem = |(old, new): &(String, String), problem: String| RegressionError::Rename {
        old: old.clone(),
        new: new.clone(),
        problem,
    };
    for (i, pair) in renames.iter().enumerate() {
        let (old, new) = pair;
        if a.joint_id(old).is_err() {
            return Err(rename_problem(
                pair,
                format!("the first robot has no joint '{old}'"),
            ));
        }
        if b.joint_id(new).is_err() {
            return Err(rename_problem(
                pair,
                format!("the second robot has no joint '{new}'"),
            ));
        }
        if renames[..i].iter().any(|(o, n)| o == old || n == new) {
            return Err(rename_problem(pair, "a joint is renamed twice".into()));
        }
    }
    let link_names = |c: &Chain| {
        c.links()
            .iter()
            .map(|l| l.name().to_string())
            .collect::<Vec<_>>()
    };
    let (links_a, links_b) = (link_names(a), link_names(b));
    let shared: Vec<String> = if options.links.is_empty() {
        links_a
            .iter()
            .filter(|l| links_b.contains(l))
            .cloned()
            .collect()
    } else {
        check_links(a, &options.links)?;
        check_links(b, &options.links)?;
        options.links.clone()
    };
    // `a`'s entries under `b`'s names.
    let renamed =
        |entries: &mut dyn Iterator<Item = (crate::model::chain::JointId, Option<&str>)>| {
            entries
                .map(|(j, component)| {
                    let name = a.joint(j).name();
                    let name = renames
                        .iter()
                        .find(|(old, _)| old == name)
                        .map_or(name, |(_, new)| new.as_str());
                    component.map_or_else(|| name.to_string(), |c| format!("{name}.{c}"))
                })
                .collect::<Vec<String>>()
        };
    let joints_a = renamed(&mut a.variables());
    let rates_a = renamed(&mut a.velocity_variables());
    let joints_b = variable_names(b);
    let only_in_first: Vec<String> = joints_a
        .iter()
        .zip(variable_names(a))
        .filter(|(j, _)| !joints_b.contains(j))
        .map(|(_, original)| original)
        .collect();
    let only_in_second: Vec<String> = joints_b
        .iter()
        .filter(|j| !joints_a.contains(j))
        .cloned()
        .collect();
    if !only_in_first.is_empty() || !only_in_second.is_empty() {
        return Err(RegressionError::UnmatchedJoints {
            only_in_first,
            only_in_second,
        });
    }
    let golden = record(
        a,
        &Options {
            links: shared.clone(),
            ..options.clone()
        },
    )?;
    // Every entry of `b` is one of `a`'s (checked above).
    let from = |b_names: &[String], a_names: &[String]| -> Vec<usize> {
        b_names
            .iter()
            .map(|n| a_names.iter().position(|j| j == n).unwrap_or(0))
            .collect()
    };
    let from_a = from(&joints_b, &joints_a);
    let rates_from_a = from(&velocity_names(b), &rates_a);
    let mut report = Report::new(b, &shared, options.level, tolerances);
    report.only_in_first = Names {
        joints: Vec::new(),
        links: links_a
            .iter()
            .filter(|l| !links_b.contains(l))
            .cloned()
            .collect(),
    };
    report.only_in_second = Names {
        joints: Vec::new(),
        links: links_b
            .iter()
            .filter(|l| !links_a.contains(l))
            .cloned()
            .collect(),
    };
    evaluate_against(b, &golden, &mut report, |values, rates| {
        let from = if rates { &rates_from_a } else { &from_a };
        from.iter().map(|&k| values[k]).collect()
    })?;
    Ok(report)
}
