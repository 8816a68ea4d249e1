//! `kinechain bench`: the evaluation modes timed against each other and the `k` crate, with
//! their errors against the 256-bit evaluation.

use crate::cli::args::Level;
use crate::cli::common::{load, write_line};
use crate::cli::error::CliError;
use crate::cli::limits::MAX_BENCH_FRAMES;
use crate::eval::Chain;
use crate::eval::{Data, LimitPolicy};
use crate::eval::{
    forward_accelerations, forward_kinematics, forward_kinematics_to, forward_velocities,
};
use crate::measure::worse;
use crate::model::chain::LinkId;
use crate::model::transform::Transform;
use std::hint::black_box;
use std::io::Write;
use std::path::PathBuf;

/// Joint evaluations of the batch that `bench`'s two-thread rows time (≈70 µs of one thread's
/// work, some 5 000 configurations of a seven-joint arm): well above
/// [`crate::eval::batch::PARALLEL_WORK`], yet small enough for its frames to stay in the last-level
/// cache.
pub(super) const THREADED_ROWS_WORK: usize = 40_000;

/// One timed method of `kinechain bench`: its label, one call, and how many configurations a
/// call evaluates.
pub(super) type Method<'a> = (String, Box<dyn FnMut() + 'a>, usize);

/// The instruction set of the kernels, and for AVX-512 how single evaluations of at most eight
/// angles compute their `sin`/`cos` ([`crate::eval::narrow_trig`]).
pub(super) fn kernels_name() -> String {
    match crate::eval::isa() {
        crate::eval::Isa::Avx512 if crate::eval::narrow_trig() => {
            "avx512 (single evaluations of up to 8 angles: sin/cos on 256 bits)".to_string()
        }
        isa => isa.name().to_string(),
    }
}

pub(super) fn bench(
    path: &PathBuf,
    options: &crate::io::LoadOptions,
    level: Level,
    n: usize,
    link: Option<&str>,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let chain = &load(path, options)?;
    if chain.dof() == 0 {
        return Err(CliError::NothingToTime);
    }
    let links = chain.links().len();
    if n.saturating_mul(links) > MAX_BENCH_FRAMES {
        return Err(CliError::BenchTooLarge {
            configurations: n,
            links,
            most: (MAX_BENCH_FRAMES / links).max(1),
        });
    }
    let qs = &crate::measure::configurations(chain, n, 0x6b69_6e65);
    // Rates from the joint values (one per entry of q̇: a floating joint's quaternion's last
    // entry gives none).
    let nv = chain.nv();
    let qd: &Vec<Vec<f64>> = &qs
        .iter()
        .map(|q| q.iter().take(nv).map(|x| 0.5 * x.sin()).collect())
        .collect();
    let end = match link {
        Some(name) => chain.link_id(name)?,
        None => chain.end_link(),
    };
    let flat: &Vec<f64> = &qs.concat();
    let flat_qd: &Vec<f64> = &qd.concat();
    // The multi-threaded rows evaluate the configurations `copies` times over in one batch of
    // THREADED_ROWS_WORK joint evaluations on the end link's path.
    let mut end_path = Vec::new();
    chain.body_path(chain.carrier(end).body, &mut end_path);
    let copies = THREADED_ROWS_WORK
        .div_ceil(qs.len().max(1) * end_path.len().max(1))
        .max(1);
    let big: &Vec<f64> = &(0..copies).flat_map(|_| flat.iter().copied()).collect();
    let work = Workload {
        chain,
        qs,
        qd,
        flat,
        flat_qd,
        big,
        copies,
        end,
    };
    let pose_errors = work.pose_errors()?;

    let mut methods = match level {
        Level::Pose => work.pose_methods(path),
        Level::Vel | Level::Acc => work.rate_methods(level == Level::Acc),
    };
    let items: Vec<usize> = methods.iter().map(|m| m.2).collect();
    let mut calls: Vec<&mut dyn FnMut()> = methods.iter_mut().map(|m| &mut *m.1 as _).collect();
    let timings =
        crate::measure::Interleaved::run(std::time::Duration::from_millis(20), 7, &mut calls)
            .per_item(&items);
    let labels: Vec<&str> = methods.iter().map(|m| m.0.as_str()).collect();
    let mut text = timing_table(chain, qs.len(), &labels, &timings);
    text.push_str(&error_lines(&work, level, pose_errors)?);
    write_line(out, &text)
}

/// What `kinechain bench` evaluates: `qs` (with rates `qd`), row-major in `flat`, and `flat`
/// repeated `copies` times in `big` for the multi-threaded rows; `end` the link read after each
/// single evaluation and kept by the one-link batches.
#[derive(Clone, Copy)]
pub(super) struct Workload<'a> {
    pub(super) chain: &'a Chain,
    pub(super) qs: &'a [Vec<f64>],
    pub(super) qd: &'a [Vec<f64>],
    pub(super) flat: &'a [f64],
    pub(super) flat_qd: &'a [f64],
    pub(super) big: &'a [f64],
    pub(super) copies: usize,
    pub(super) end: LinkId,
}

impl<'a> Workload<'a> {
    /// Buffers of one method (each has its own, so that the methods can be timed in
    /// alternation), not checking limits, as `k` is timed.
    fn data(&self) -> Data {
        Data::new(self.chain).with_limit_policy(LimitPolicy::Ignore)
    }

    fn batch_data(&self) -> crate::eval::batch::BatchData {
        crate::eval::batch::BatchData::new(self.chain).with_limit_policy(LimitPolicy::Ignore)
    }

    fn single_data(&self) -> crate::eval::batch::single_precision::BatchData {
        crate::eval::batch::single_precision::BatchData::new(self.chain)
            .with_limit_policy(LimitPolicy::Ignore)
    }

    /// The largest (position, rotation) errors of the single evaluation and of the
    /// single-precision batch, against the 256-bit evaluation of the same model.
    fn pose_errors(&self) -> Result<[(f64, f64); 2], CliError> {
        let chain = self.chain;
        let all: Vec<LinkId> = (0..chain.links().len()).map(LinkId).collect();
        let mut errors = [(0.0_f64, 0.0_f64); 2];
        let mut d = self.data();
        let mut b32 = self.single_data();
        let rough = crate::eval::batch::single_precision::forward_kinematics_batch(
            chain, &mut b32, self.flat,
        )
        .map_err(|e| e.source)?;
        for (i, q) in self.qs.iter().enumerate() {
            let exact = crate::reference::link_poses(chain, q);
            let poses = forward_kinematics(chain, &mut d, q)?;
            let ours: Vec<Transform> = all.iter().map(|&l| poses.world_from_link(l)).collect();
            let single: Vec<Transform> = all.iter().map(|&l| rough.world_from_link(i, l)).collect();
            for (e, got) in errors.iter_mut().zip([ours, single]) {
                let (p, r) = crate::reference::max_errors(&got, &exact);
                *e = (worse(e.0, p), worse(e.1, r));
            }
        }
        Ok(errors)
    }

    /// Every link's pose of each configuration, on the kernels of `isa` (`None`: the machine's),
    /// with `wide` the `sin`/`cos` forced into one 512-bit register where `narrow_trig` would
    /// split them; the end link read after each.
    fn all_links(&self, isa: Option<crate::eval::Isa>, wide: bool) -> Box<dyn FnMut() + 'a> {
        let Workload { chain, qs, end, .. } = *self;
        let mut d = self.data();
        Box::new(move || {
            crate::eval::force_isa(isa);
            if wide {
                crate::eval::force_narrow_trig(Some(false));
            }
            for q in qs {
                black_box(
                    forward_kinematics(chain, &mut d, black_box(q))
                        .ok()
                        .map(|p| p.world_from_link(end)),
                );
            }
            crate::eval::force_isa(None);
            if wide {
                crate::eval::force_narrow_trig(None);
            }
        })
    }

    /// The rows of `--level pose`: every evaluation mode, the baseline path, and `k` when it
    /// loads the robot at `path`.
    fn pose_methods(&self, path: &std::path::Path) -> Vec<Method<'a>> {
        let Workload { chain, qs, end, .. } = *self;
        let n = qs.len();
        let mut methods: Vec<Method<'a>> = vec![(ALL_LINKS.into(), self.all_links(None, false), n)];
        let mut d = self.data();
        methods.push((
            format!("kinechain, end link {} only", chain.link(end).name()),
            Box::new(move || {
                for q in qs {
                    black_box(forward_kinematics_to(chain, &mut d, black_box(q), end).ok());
                }
            }),
            n,
        ));
        methods.extend(self.incremental_method());
        methods.extend(self.batch_methods());
        // Where the choice of `narrow_trig` applies (all the angles in one chunk, the test
        // `kernel::joint::all_sin_cos` makes), what it saves.
        if crate::eval::isa() == crate::eval::Isa::Avx512
            && crate::eval::narrow_trig()
            && chain.theta_gather.len() == 1
        {
            methods.push((
                "kinechain, all links, sin/cos in one 512-bit register".into(),
                self.all_links(None, true),
                n,
            ));
        }
        methods.push((
            "kinechain, baseline x86-64 path".into(),
            self.all_links(Some(crate::eval::Isa::Baseline), false),
            n,
        ));
        if let Some((label, k)) = k_method(path, chain, qs) {
            methods.push((label, k, n));
        }
        methods
    }

    /// The batch rows of `--level pose`: all links on one thread in `f64` and `f32`, all links
    /// of the repeated batch on the pool, and the end link alone on one thread and on the pool.
    fn batch_methods(&self) -> Vec<Method<'a>> {
        use crate::eval::batch::{
            forward_kinematics_batch, forward_kinematics_batch_par, forward_kinematics_batch_to,
            forward_kinematics_batch_to_par, single_precision,
        };
        let Workload {
            chain,
            qs,
            flat,
            big,
            copies,
            end,
            ..
        } = *self;
        let n = qs.len();
        let threads = rayon::current_num_threads();
        let mut methods: Vec<Method<'a>> = Vec::new();
        let mut b = self.batch_data();
        methods.push((
            "kinechain, batch, 1 thread".into(),
            Box::new(move || {
                black_box(
                    forward_kinematics_batch(chain, &mut b, black_box(flat))
                        .ok()
                        .map(|b| b.len()),
                );
            }),
            n,
        ));
        let mut b = self.single_data();
        methods.push((
            "kinechain, batch f32, 1 thread".into(),
            Box::new(move || {
                black_box(
                    single_precision::forward_kinematics_batch(chain, &mut b, black_box(flat))
                        .ok()
                        .map(|b| b.len()),
                );
            }),
            n,
        ));
        let mut b = self.batch_data();
        methods.push((
            format!("kinechain, batch of {}, {threads} threads", copies * n),
            Box::new(move || {
                black_box(
                    forward_kinematics_batch_par(chain, &mut b, black_box(big))
                        .ok()
                        .map(|b| b.len()),
                );
            }),
            copies * n,
        ));
        for parallel in [false, true] {
            let (qs, label, count) = if parallel {
                (
                    big,
                    format!(
                        "kinechain, batch of {}, end link only, {threads} threads",
                        copies * n
                    ),
                    copies * n,
                )
            } else {
                (flat, "kinechain, batch, end link only, 1 thread".into(), n)
            };
            let mut b = self.batch_data();
            methods.push((
                label,
                Box::new(move || {
                    black_box(
                        (if parallel {
                            forward_kinematics_batch_to_par(chain, &mut b, black_box(qs), end)
                        } else {
                            forward_kinematics_batch_to(chain, &mut b, black_box(qs), end)
                        })
                        .ok()
                        .map(|b| b.len()),
                    );
                }),
                count,
            ));
        }
        methods
    }

    /// The incremental update moving only the last entry of `q` on the end link's path, from
    /// the first configuration's other entries; `None` if no joint moves the end link.
    fn incremental_method(&self) -> Option<Method<'a>> {
        use crate::eval::forward_kinematics_incremental;
        let Workload { chain, qs, end, .. } = *self;
        let last = last_variable_to(chain, end)?;
        let (joint, component) = chain.variables().nth(last)?;
        let moved = match component {
            Some(c) => format!("{} {c}", chain.joint(joint).name()),
            None => chain.joint(joint).name().to_string(),
        };
        let moving: Vec<Vec<f64>> = qs
            .iter()
            .map(|q| {
                let mut m = qs[0].clone();
                m[last] = q[last];
                m
            })
            .collect();
        let mut d = self.data();
        Some((
            format!("{INCREMENTAL} ({moved} moves)"),
            Box::new(move || {
                for q in &moving {
                    black_box(
                        forward_kinematics_incremental(chain, &mut d, black_box(q))
                            .ok()
                            .map(|p| p.world_from_link(end)),
                    );
                }
            }),
            qs.len(),
        ))
    }

    /// The rows of `--level vel` (`acc` false) or `--level acc`: the evaluation with rates, and
    /// poses alone, each single and as a batch on one thread.
    fn rate_methods(&self, acc: bool) -> Vec<Method<'a>> {
        use crate::eval::batch::{
            forward_accelerations_batch, forward_kinematics_batch, forward_velocities_batch,
        };
        let Workload {
            chain,
            qs,
            qd,
            flat,
            flat_qd,
            end,
            ..
        } = *self;
        let with_rates = if acc {
            format!("{WITH_RATES} + accelerations")
        } else {
            WITH_RATES.to_string()
        };
        let mut d = self.data();
        let mut b = self.batch_data();
        let mut poses = self.batch_data();
        let mut methods: Vec<Method<'a>> = vec![
            (
                with_rates.clone(),
                Box::new(move || {
                    for (q, v) in qs.iter().zip(qd) {
                        if acc {
                            black_box(
                                forward_accelerations(chain, &mut d, black_box(q), v, v)
                                    .ok()
                                    .map(|a| a.acceleration(end)),
                            );
                        } else {
                            black_box(
                                forward_velocities(chain, &mut d, black_box(q), v)
                                    .ok()
                                    .map(|a| a.velocity(end)),
                            );
                        }
                    }
                }),
                qs.len(),
            ),
            (POSES_ONLY.into(), self.all_links(None, false), qs.len()),
            (
                with_rates.replacen("kinechain, ", BATCH_PREFIX, 1) + ", 1 thread",
                Box::new(move || {
                    let (q, v) = (black_box(flat), black_box(flat_qd));
                    black_box(if acc {
                        forward_accelerations_batch(chain, &mut b, q, v, v)
                            .ok()
                            .map(|b| b.len())
                    } else {
                        forward_velocities_batch(chain, &mut b, q, v)
                            .ok()
                            .map(|b| b.len())
                    });
                }),
                qs.len(),
            ),
            (
                format!("{BATCH_POSES_ONLY}, 1 thread"),
                Box::new(move || {
                    black_box(
                        forward_kinematics_batch(chain, &mut poses, black_box(flat))
                            .ok()
                            .map(|b| b.len()),
                    );
                }),
                qs.len(),
            ),
        ];
        if !acc {
            methods.extend(self.jacobian_methods());
        }
        methods
    }

    /// The Jacobian rows of `--level vel`: the end link's world Jacobian after a single
    /// evaluation and as a batch, and the batch of that link's pose alone.
    fn jacobian_methods(&self) -> Vec<Method<'a>> {
        use crate::eval::batch::{forward_kinematics_batch_to, jacobian_batch};
        let Workload {
            chain,
            qs,
            flat,
            end,
            ..
        } = *self;
        let name = chain.link(end).name();
        let mut d = self.data();
        let mut j = nalgebra::Matrix6xX::zeros(chain.dof());
        let mut b = self.batch_data();
        let mut out = vec![0.0; flat.len() * 6];
        let mut poses = self.batch_data();
        vec![
            (
                format!("{JACOBIAN} {name}"),
                Box::new(move || {
                    for q in qs {
                        if let Ok(p) = forward_kinematics(chain, &mut d, black_box(q)) {
                            p.jacobian_into(end, &mut j);
                        }
                        black_box(&j);
                    }
                }),
                qs.len(),
            ),
            (
                format!("{BATCH_JACOBIAN} {name}, 1 thread"),
                Box::new(move || {
                    let frame = crate::eval::JacobianFrame::World;
                    black_box(
                        jacobian_batch(chain, &mut b, black_box(flat), end, frame, &mut out).ok(),
                    );
                    black_box(&out);
                }),
                qs.len(),
            ),
            (
                format!("{BATCH_LINK_POSE} {name}, 1 thread"),
                Box::new(move || {
                    black_box(
                        forward_kinematics_batch_to(chain, &mut poses, black_box(flat), end)
                            .ok()
                            .map(|b| b.len()),
                    );
                }),
                qs.len(),
            ),
        ]
    }
}

/// The header, the table of `kinechain bench` (a row per method of `labels`, with its ratio
/// to the `k` row's time if there is one) and the lines comparing rows measured together.
pub(super) fn timing_table(
    chain: &Chain,
    n: usize,
    labels: &[&str],
    timings: &crate::measure::Interleaved,
) -> String {
    let k = labels.iter().position(|m| m.starts_with("k "));
    let mut text = format!(
        "{}: {} dof, {} links, {} moving joints; {n} random configurations; kernels: {}\n",
        chain.name(),
        chain.dof(),
        chain.links().len(),
        chain.moving_joint_count(),
        kernels_name()
    );
    // The method column as wide as its longest name (the end link's name is part of one).
    let width = labels
        .iter()
        .map(|m| m.chars().count())
        .max()
        .unwrap_or(0)
        .max(48);
    text.push_str(&format!(
        "{:<width$} {:>12} {:>10}\n",
        "method", "ns/config", "vs k"
    ));
    for (i, method) in labels.iter().enumerate() {
        let ns = timings.median(i);
        let ratio = k.map_or("-".to_string(), |k| format!("{:.1}x", timings.ratio(k, i)));
        text.push_str(&format!("{method:<width$} {ns:>12.1} {ratio:>10}\n"));
    }
    text.push_str(
        "times: medians of 7 rounds, the methods run in alternation, joint limits not checked; \"vs k\": median of the ratios within a round\n",
    );
    // The incremental update against a full evaluation, and rates against poses alone, measured
    // in the same rounds.
    let row = |label: &str| labels.iter().position(|m| m.starts_with(label));
    for (part, whole, of) in [
        (INCREMENTAL, ALL_LINKS, "all links"),
        (WITH_RATES, POSES_ONLY, "poses only"),
        (
            BATCH_WITH_RATES,
            BATCH_POSES_ONLY,
            "the batch of poses only",
        ),
        (
            BATCH_JACOBIAN,
            BATCH_LINK_POSE,
            "the batch of that link's pose only",
        ),
    ] {
        if let (Some(p), Some(w)) = (row(part), row(whole)) {
            text.push_str(&format!(
                "{}: {:.2}x the time of {of} (median of the ratios within a round)\n",
                labels[p].trim_start_matches("kinechain, "),
                timings.ratio(p, w)
            ));
        }
    }
    text
}

/// The error lines of `kinechain bench`: the poses' against the 256-bit evaluation
/// (`pose_errors` from [`Workload::pose_errors`]), then the single-precision batch's
/// (`--level pose`) or the rates' (`--level vel|acc`).
pub(super) fn error_lines(
    work: &Workload<'_>,
    level: Level,
    pose_errors: [(f64, f64); 2],
) -> Result<String, CliError> {
    let [(position, rotation), (position32, rotation32)] = pose_errors;
    let reach = work.chain.reach().max(f64::MIN_POSITIVE);
    // (A robot far larger than any real one, as a stress test, prints in exponent form.)
    let reach_text = if reach < 1e6 {
        format!("{reach:.3}")
    } else {
        format!("{reach:.3e}")
    };
    let mut text = format!(
        "pose error against a 256-bit evaluation of the same model: position {position:.2e} m ({:.2} ulp of the {reach_text} m reach), rotation {rotation:.2e}",
        position / (reach * f64::EPSILON)
    );
    if level == Level::Pose && reach > f64::from(f32::MAX) {
        text.push_str("\nno error for the batch f32: the reach is beyond the range of f32");
    } else if level == Level::Pose {
        text.push_str(&format!(
            "\nthe same for the batch f32: position {position32:.2e} m ({:.2} f32 ulp of the reach), rotation {rotation32:.2e} ({:.2} f32 ulp)",
            position32 / (reach * f64::from(f32::EPSILON)),
            rotation32 / f64::from(f32::EPSILON)
        ));
    } else {
        let names = ["ω", "v", "α", "a"];
        let units = ["rad/s", "m/s", "rad/s²", "m/s²"];
        let parts: Vec<String> = rate_errors(work.chain, work.qs, work.qd, level == Level::Acc)?
            .iter()
            .zip(names.iter().zip(units))
            .map(|((abs, ulps), (name, unit))| {
                format!("{name} {abs:.2e} {unit} ({ulps:.2} ulp of the largest)")
            })
            .collect();
        text.push_str(&format!(
            "\nrate errors against the 256-bit evaluation: {}",
            parts.join(", ")
        ));
    }
    Ok(text)
}

/// Errors of ω and v, and with `acc` of α and a, against the 256-bit evaluation of the same
/// model, by the evaluation `bench` times and at the states it times (`q̈ = q̇`, or none without
/// `acc`): the largest absolute error over links and configurations, and the largest in ulps of
/// the configuration's largest component of that quantity (over all links).
pub(super) fn rate_errors(
    chain: &Chain,
    qs: &[Vec<f64>],
    qd: &[Vec<f64>],
    acc: bool,
) -> Result<Vec<(f64, f64)>, CliError> {
    let mut data = Data::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let mut worst = vec![(0.0_f64, 0.0_f64); if acc { 4 } else { 2 }];
    let zero = vec![0.0; chain.nv()];
    for (q, v) in qs.iter().zip(qd) {
        let qdd = if acc { v } else { &zero };
        let exact = crate::reference::link_motion(chain, q, v, qdd);
        // The evaluation `bench` times at this level.
        let ours: Vec<[[f64; 3]; 4]> = if acc {
            let got = forward_accelerations(chain, &mut data, q, v, qdd)?;
            (0..exact.len())
                .map(|l| {
                    let (v, a) = (got.velocity(LinkId(l)), got.acceleration(LinkId(l)));
                    [v.omega.into(), v.v.into(), a.alpha.into(), a.a.into()]
                })
                .collect()
        } else {
            let got = forward_velocities(chain, &mut data, q, v)?;
            (0..exact.len())
                .map(|l| {
                    let v = got.velocity(LinkId(l));
                    [v.omega.into(), v.v.into(), [0.0; 3], [0.0; 3]]
                })
                .collect()
        };
        let errors = crate::reference::max_rate_errors(&ours, &exact);
        for (w, e) in worst.iter_mut().zip(errors) {
            *w = (worse(w.0, e.0), worse(w.1, e.1));
        }
    }
    Ok(worst)
}

/// Labels of `kinechain bench` rows (the first two as prefixes) that the line after the table
/// compares: the incremental update with a full evaluation of poses (`--level pose`), and the
/// evaluation with rates with poses alone (`--level vel|acc`).
pub(super) const INCREMENTAL: &str = "kinechain, incremental";

pub(super) const WITH_RATES: &str = "kinechain, poses + velocities";

pub(super) const ALL_LINKS: &str = "kinechain, all links";

pub(super) const POSES_ONLY: &str = "kinechain, poses only";

pub(super) const BATCH_PREFIX: &str = "kinechain, batch, ";

pub(super) const BATCH_WITH_RATES: &str = "kinechain, batch, poses + velocities";

pub(super) const BATCH_POSES_ONLY: &str = "kinechain, batch, poses only";

pub(super) const JACOBIAN: &str = "kinechain, Jacobian of";

pub(super) const BATCH_JACOBIAN: &str = "kinechain, batch, Jacobian of";

pub(super) const BATCH_LINK_POSE: &str = "kinechain, batch, pose only of";

/// The last entry of `q` that moves `link`: the largest read by the nearest body on its path that
/// reads one (on an arm with a gripper and the tool as `link`, the arm's last joint, not the
/// gripper's). `None` if no joint moves `link`.
pub(super) fn last_variable_to(chain: &Chain, link: LinkId) -> Option<usize> {
    let mut body = chain.carrier(link).body;
    while let Some(b) = body {
        if let Some(last) = chain.bodies[b].motion.variables().max() {
            return Some(last);
        }
        body = chain.bodies[b].parent;
    }
    None
}

/// One call of the `k` crate evaluating every configuration of `qs`, with the label of its row:
/// on the robot file itself for a URDF, otherwise (a DH table, the axis form) on the URDF that
/// `kinechain convert` writes for it, whose joint vector is the original's (`tests/convert.rs`
/// checks that `k`'s link poses on it agree with the original's). `None` when `k` cannot load
/// the model (mimic joints are in its joint vector).
pub(super) fn k_method<'a>(
    path: &std::path::Path,
    chain: &Chain,
    qs: &[Vec<f64>],
) -> Option<(String, Box<dyn FnMut() + 'a>)> {
    // `k` reads a floating joint as a fixed one: it has no column to compare.
    if chain
        .joints()
        .iter()
        .any(|j| j.kind() == crate::model::joint::JointKind::Floating)
    {
        return None;
    }
    let (robot, written, label) =
        if crate::io::Format::from_path(path) == Some(crate::io::Format::Urdf) {
            let robot = k::Chain::<f64>::from_urdf_file(path).ok()?;
            (robot, None, "k 0.32, update_transforms")
        } else {
            let text = crate::io::convert::to_urdf(chain).ok()?;
            let written = Chain::from_urdf_str(&text).ok()?;
            // Through a file: `k` parses URDF with another version of `urdf-rs`.
            let file =
                std::env::temp_dir().join(format!("kinechain-bench-{}.urdf", std::process::id()));
            std::fs::write(&file, &text).ok()?;
            let robot = k::Chain::<f64>::from_urdf_file(&file);
            let _ = std::fs::remove_file(&file);
            let robot = robot.ok()?;
            (
                robot,
                Some(written),
                "k 0.32, update_transforms, written as URDF",
            )
        };
    // Joint names are looked up in the model k loaded (a cylindrical joint is two URDF joints).
    let named = written.as_ref().unwrap_or(chain);
    if named.dof() != chain.dof() {
        return None;
    }
    let names: Vec<String> = robot.iter_joints().map(|j| j.name.clone()).collect();
    let kq: Vec<Vec<f64>> = qs
        .iter()
        .map(|q| named.positions_by_name(names.iter().map(String::as_str), q))
        .collect::<Result<_, _>>()
        .ok()?;
    let call: Box<dyn FnMut() + 'a> = Box::new(move || {
        for q in &kq {
            robot.set_joint_positions_unchecked(black_box(q));
            black_box(robot.update_transforms());
        }
    });
    Some((label.to_string(), call))
}
