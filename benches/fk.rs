//! Run time of forward kinematics: kinechain's evaluation modes against the `k` crate and a naive
//! product of eq. (2.129) matrices, on the same robots and seeded configurations in one run.
//!
//! `cargo bench --bench fk` (ids like `fk/pose/panda`); the run-time-against-error table is
//! `cargo bench --bench table`.

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use kinechain::measure::configurations;
use kinechain::{
    Chain, Data, LimitPolicy, forward_accelerations, forward_kinematics,
    forward_kinematics_incremental, forward_kinematics_to, forward_velocities,
};
use rayon::prelude::*;
use std::hint::black_box;
use std::path::Path;

fn robots() -> Vec<(&'static str, &'static str)> {
    vec![
        ("ur5", "tests/data/reference/urdf/ur5.urdf"),
        ("panda", "robots/panda.urdf"),
    ]
}

/// The link at the tip of the arm (not a finger or a fixed frame on the base).
fn tool_link(robot: &str) -> &'static str {
    match robot {
        "ur5" => "ee_link",
        _ => "panda_hand_tcp",
    }
}

/// The arm's last joint.
fn last_joint(robot: &str) -> &'static str {
    match robot {
        "ur5" => "wrist_3_joint",
        _ => "panda_joint7",
    }
}

fn kinechain_modes(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (name, file) in robots() {
        let chain = Chain::from_file(root.join(file)).unwrap();
        let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let qs = configurations(&chain, 64, 1);
        let qd = vec![0.3; chain.dof()];
        let tip = chain.link_id(tool_link(name)).unwrap();
        let mut i = 0;
        let mut next = || {
            i = (i + 1) % qs.len();
            &qs[i]
        };
        c.bench_function(&format!("fk/pose/{name}"), |b| {
            b.iter(|| {
                let p = forward_kinematics(&chain, &mut data, black_box(next())).unwrap();
                black_box(p.world_from_link(tip));
            })
        });
        // The default setting: the joint limits checked in the same call (the seeded
        // configurations are within them).
        let mut checked = Data::new(&chain);
        c.bench_function(&format!("fk/pose_checked/{name}"), |b| {
            b.iter(|| {
                let p = forward_kinematics(&chain, &mut checked, black_box(next())).unwrap();
                black_box(p.world_from_link(tip));
            })
        });
        c.bench_function(&format!("fk/vel/{name}"), |b| {
            b.iter(|| {
                let v = forward_velocities(&chain, &mut data, black_box(next()), &qd).unwrap();
                black_box(v.velocity(tip));
            })
        });
        c.bench_function(&format!("fk/acc/{name}"), |b| {
            b.iter(|| {
                let a =
                    forward_accelerations(&chain, &mut data, black_box(next()), &qd, &qd).unwrap();
                black_box(a.acceleration(tip));
            })
        });
        // A user's Jacobian query: the poses, then the tool's Jacobian into a reused matrix.
        let mut jacobian = kinechain::nalgebra::Matrix6xX::zeros(chain.dof());
        c.bench_function(&format!("fk/jacobian/{name}"), |b| {
            b.iter(|| {
                let p = forward_kinematics(&chain, &mut data, black_box(next())).unwrap();
                p.jacobian_into(tip, &mut jacobian);
                black_box(&jacobian);
            })
        });
        // What Pinocchio's `computeJointJacobian` computes: the last joint's child link in its own
        // axes (LOCAL), the poses included.
        let link7 = chain
            .joint(chain.joint_id(last_joint(name)).unwrap())
            .child();
        c.bench_function(&format!("fk/jacobian_local_last_joint/{name}"), |b| {
            b.iter(|| {
                let p = forward_kinematics(&chain, &mut data, black_box(next())).unwrap();
                p.jacobian_in_into(link7, kinechain::JacobianFrame::Link, &mut jacobian);
                black_box(&jacobian);
            })
        });
        // The same with velocities and the Jacobian's rate (the bias term of [a; α] = J q̈ + J̇ q̇).
        c.bench_function(&format!("fk/jacobian_dot/{name}"), |b| {
            b.iter(|| {
                let v = forward_velocities(&chain, &mut data, black_box(next()), &qd).unwrap();
                v.jacobian_dot_into(tip, &mut jacobian);
                black_box(&jacobian);
            })
        });
        c.bench_function(&format!("fk/end/{name}"), |b| {
            b.iter(|| {
                black_box(forward_kinematics_to(&chain, &mut data, black_box(next()), tip).unwrap())
            })
        });
        // Only the last arm joint moves between calls (precomputed configurations).
        let last = chain
            .joint(chain.joint_id(last_joint(name)).unwrap())
            .q_index()
            .unwrap();
        let moving: Vec<Vec<f64>> = (0..64)
            .map(|i| {
                let mut q = qs[0].clone();
                q[last] += 1e-3 * i as f64;
                q
            })
            .collect();
        forward_kinematics_incremental(&chain, &mut data, &moving[0]).unwrap();
        let mut i = 0;
        c.bench_function(&format!("fk/incremental_last/{name}"), |b| {
            b.iter(|| {
                i = (i + 1) % moving.len();
                let p = forward_kinematics_incremental(&chain, &mut data, black_box(&moving[i]))
                    .unwrap();
                black_box(p.world_from_link(tip));
            })
        });
    }
}

fn k_baseline(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (name, file) in robots() {
        let chain = Chain::from_file(root.join(file)).unwrap();
        let robot = k::Chain::<f64>::from_urdf_file(root.join(file)).unwrap();
        // k's joint vector (mimic joints included) for each configuration.
        let names: Vec<String> = robot.iter_joints().map(|j| j.name.clone()).collect();
        let configs = configurations(&chain, 64, 1);
        let by_name = |names: &[String]| -> Vec<Vec<f64>> {
            configs
                .iter()
                .map(|q| {
                    chain
                        .positions_by_name(names.iter().map(String::as_str), q)
                        .unwrap()
                })
                .collect()
        };
        let qs = by_name(&names);
        let mut i = 0;
        c.bench_function(&format!("k/pose/{name}"), |b| {
            b.iter(|| {
                i = (i + 1) % qs.len();
                robot.set_joint_positions_unchecked(black_box(&qs[i]));
                black_box(robot.update_transforms());
            })
        });
        // k's Jacobian is of a serial chain: the path from the root to the tool.
        let arm = k::SerialChain::from_end(robot.find_link(tool_link(name)).unwrap());
        let path: Vec<String> = arm.iter_joints().map(|j| j.name.clone()).collect();
        let path_qs = by_name(&path);
        c.bench_function(&format!("k/jacobian/{name}"), |b| {
            b.iter(|| {
                i = (i + 1) % path_qs.len();
                arm.set_joint_positions_unchecked(black_box(&path_qs[i]));
                black_box(k::jacobian(&arm));
            })
        });
    }
}

/// The textbook method: multiply eq. (2.129)-style 4×4 matrices with `nalgebra::Matrix4`.
fn naive_baseline(c: &mut Criterion) {
    use kinechain::model::joint::{DhConvention, dh_transform};
    use kinechain::nalgebra::Matrix4;
    // The Panda arm's modified DH table (robots/panda_mdh.yaml): (a, alpha, d).
    let rows: [(f64, f64, f64); 7] = [
        (0.0, 0.0, 0.333),
        (0.0, -std::f64::consts::FRAC_PI_2, 0.0),
        (0.0, std::f64::consts::FRAC_PI_2, 0.316),
        (0.0825, std::f64::consts::FRAC_PI_2, 0.0),
        (-0.0825, -std::f64::consts::FRAC_PI_2, 0.384),
        (0.0, std::f64::consts::FRAC_PI_2, 0.0),
        (0.088, std::f64::consts::FRAC_PI_2, 0.0),
    ];
    let chain =
        Chain::from_file(Path::new(env!("CARGO_MANIFEST_DIR")).join("robots/panda_mdh.yaml"))
            .unwrap();
    let qs = configurations(&chain, 64, 1);
    let mut out = vec![Matrix4::<f64>::identity(); 8];
    let mut i = 0;
    c.bench_function("naive/pose/panda_mdh", |b| {
        b.iter(|| {
            i = (i + 1) % qs.len();
            let q = black_box(&qs[i]);
            let mut t = Matrix4::<f64>::identity();
            for (k, &(a, alpha, d)) in rows.iter().enumerate() {
                let m = dh_transform(DhConvention::Modified, a, alpha, d, q[k]);
                t *= m;
                out[k + 1] = t;
            }
            black_box(&out);
        })
    });
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let tip = chain.end_link();
    c.bench_function("fk/pose/panda_mdh", |b| {
        b.iter(|| {
            i = (i + 1) % qs.len();
            let p = forward_kinematics(&chain, &mut data, black_box(&qs[i])).unwrap();
            black_box(p.world_from_link(tip));
        })
    });
    let _ = BatchSize::SmallInput;
}

/// Batches of 4 096 configurations (`fk/batch/...`, where waking the second thread is a visible
/// part of a 45–65 µs call) and of 65 536 (`fk/batch_large/...`, where the threads' scaling is
/// measured: the frames of all links then no longer fit the cache), and 512 configurations of a
/// 50-joint chain (`fk/batch_long/snake50`: the pool is used from `batch::PARALLEL_WORK` joint
/// evaluations, so a long chain is split over the threads at a few dozen configurations);
/// criterion reports time
/// per batch and configurations per second (`thrpt`).
fn batches(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (name, file) in robots() {
        let chain = Chain::from_file(root.join(file)).unwrap();
        for (group_name, n) in [("batch", 4096), ("batch_large", 65536)] {
            batch_group(c, &format!("fk/{group_name}/{name}"), &chain, n);
        }
    }
    let snake = Chain::from_file(root.join("robots/snake50.yaml")).unwrap();
    batch_group(c, "fk/batch_long/snake50", &snake, 512);
}

/// One thread and the pool, all links and the end link only, for `n` configurations of `chain`.
fn batch_group(c: &mut Criterion, group_id: &str, chain: &Chain, n: usize) {
    use criterion::Throughput;
    use kinechain::eval::batch::{
        BatchData, BatchError, BatchPoses, forward_kinematics_batch, forward_kinematics_batch_fold,
        forward_kinematics_batch_fold_par, forward_kinematics_batch_par,
        forward_kinematics_batch_to, forward_kinematics_batch_to_par, single_precision,
    };
    let qs: Vec<f64> = configurations(chain, n, 2).concat();
    let mut data = BatchData::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let mut group = c.benchmark_group(group_id);
    group.throughput(Throughput::Elements(n as u64));
    if n > 4096 {
        group.sample_size(20);
    }
    type AllLinks =
        for<'a> fn(&'a Chain, &'a mut BatchData, &[f64]) -> Result<BatchPoses<'a>, BatchError>;
    let all_links: [(&str, AllLinks); 2] = [
        ("1_thread", forward_kinematics_batch),
        ("all_threads", forward_kinematics_batch_par),
    ];
    for (id, evaluate) in all_links {
        group.bench_function(id, |b| {
            b.iter(|| black_box(evaluate(chain, &mut data, black_box(&qs)).unwrap().len()))
        });
    }
    // Every link's poses, folded block by block while in cache (the fold only counts them), in
    // f64 and in f32.
    macro_rules! fold_benches {
        ($prefix:literal, $fold:path, $fold_par:path, $poses:ty) => {
            for (id, parallel) in [("fold_1_thread", false), ("fold_all_threads", true)] {
                group.bench_function(format!("{}{id}", $prefix), |b| {
                    b.iter(|| {
                        let count = |n: usize, _, poses: $poses| n + poses.len();
                        let qs = black_box(&qs);
                        if parallel {
                            $fold_par(chain, qs, LimitPolicy::Ignore, || 0, count, |a, b| a + b)
                        } else {
                            $fold(chain, qs, LimitPolicy::Ignore, || 0, count, |a, b| a + b)
                        }
                        .unwrap()
                    })
                });
            }
        };
    }
    fold_benches!(
        "",
        forward_kinematics_batch_fold,
        forward_kinematics_batch_fold_par,
        BatchPoses<'_>
    );
    fold_benches!(
        "f32_",
        single_precision::forward_kinematics_batch_fold,
        single_precision::forward_kinematics_batch_fold_par,
        single_precision::BatchPoses<'_>
    );
    // Reading every link's pose of every configuration of an evaluated batch (no evaluation).
    let links: Vec<_> = (0..chain.links().len())
        .map(|l| chain.link_id(chain.links()[l].name()).unwrap())
        .collect();
    let mut read_data = BatchData::new(chain).with_limit_policy(LimitPolicy::Ignore);
    let poses = forward_kinematics_batch(chain, &mut read_data, &qs).unwrap();
    group.bench_function("read_all_links", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for i in 0..poses.len() {
                for &l in &links {
                    sum += poses.world_from_link(i, l).translation().x;
                }
            }
            black_box(sum)
        })
    });
    // Only the end link's pose, per configuration.
    let end = chain.end_link();
    for (id, parallel) in [("end_link_1_thread", false), ("end_link_all_threads", true)] {
        group.bench_function(id, |b| {
            b.iter(|| {
                black_box(
                    (if parallel {
                        forward_kinematics_batch_to_par(chain, &mut data, black_box(&qs), end)
                    } else {
                        forward_kinematics_batch_to(chain, &mut data, black_box(&qs), end)
                    })
                    .unwrap()
                    .len(),
                )
            })
        });
    }
    // The single-precision variant (looser: errors of a few f32 ulps), one thread.
    let mut data32 = single_precision::BatchData::new(chain).with_limit_policy(LimitPolicy::Ignore);
    group.bench_function("f32_1_thread", |b| {
        b.iter(|| {
            black_box(
                single_precision::forward_kinematics_batch(chain, &mut data32, black_box(&qs))
                    .unwrap()
                    .len(),
            )
        })
    });
    group.bench_function("f32_all_threads", |b| {
        b.iter(|| {
            black_box(
                single_precision::forward_kinematics_batch_par(chain, &mut data32, black_box(&qs))
                    .unwrap()
                    .len(),
            )
        })
    });
    group.bench_function("f32_end_link_1_thread", |b| {
        b.iter(|| {
            black_box(
                single_precision::forward_kinematics_batch_to(
                    chain,
                    &mut data32,
                    black_box(&qs),
                    end,
                )
                .unwrap()
                .len(),
            )
        })
    });
    group.finish();
}

/// `n` rounds of eight independent multiply–add chains: arithmetic with no memory traffic and no
/// shared state, the best case for threads.
fn arithmetic(n: u64) -> f64 {
    let mut x: [f64; 8] = std::array::from_fn(|i| 1.0 + i as f64 * 1e-9);
    for _ in 0..n {
        for v in &mut x {
            *v = black_box(*v) * 0.999_999_9 + 1e-9;
        }
    }
    x.iter().sum()
}

/// What two threads give independent work on this machine through rayon's fork–join: the same
/// arithmetic on one thread and split over rayon's pool, in the same run as `fk/batch_large`. A
/// virtual machine's second core may share a physical core (and its floating-point units) with
/// the first, which this shows. The batches, which share their work with the calling thread
/// instead of waiting for the pool to wake and join, can exceed it.
fn machine_baseline(c: &mut Criterion) {
    const ROUNDS: u64 = 200_000;
    let mut group = c.benchmark_group("machine/arithmetic");
    group.bench_function("1_thread", |b| b.iter(|| black_box(arithmetic(ROUNDS))));
    group.bench_function("all_threads", |b| {
        b.iter(|| {
            let parts = rayon::current_num_threads() as u64;
            let sum: f64 = (0..parts)
                .into_par_iter()
                .map(|_| arithmetic(ROUNDS / parts))
                .sum();
            black_box(sum)
        })
    });
    group.finish();
}

criterion_group!(
    benches,
    kinechain_modes,
    k_baseline,
    naive_baseline,
    batches,
    machine_baseline
);
criterion_main!(benches);
