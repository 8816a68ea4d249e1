//! Batches give, configuration by configuration, exactly what single evaluations give.

use crate::common::*;
use kinechain::eval::batch::{
    BatchData, BatchError, BatchPoses, fold_block_len, forward_kinematics_batch,
    forward_kinematics_batch_fold, forward_kinematics_batch_fold_par, forward_kinematics_batch_par,
    forward_kinematics_batch_to, forward_kinematics_batch_to_par, single_precision as sp,
};
use kinechain::{Chain, LimitPolicy, LinkId, StateError, Transform};

#[test]
fn batches_equal_single_evaluations_bit_for_bit() {
    assert_batches_equal_single_evaluations(
        &[
            "robots/panda.urdf",
            "robots/ur5.yaml+floating",
            "robots/snake50.yaml",
            "robots/cylindrical.yaml",
            "robots/stanford.yaml",
            "tests/data/reference/urdf/tiago_no_hand.urdf",
        ],
        21,
    );
}

#[test]
fn batch_errors_name_the_configuration() {
    let chain = Chain::from_file(robots_dir().join("puma560.yaml")).unwrap();
    let mut batch = BatchData::new(&chain);
    let mut qs = vec![0.0; 6 * 10];
    qs[6 * 7 + 2] = f64::NAN;
    let e = forward_kinematics_batch(&chain, &mut batch, &qs).unwrap_err();
    assert_eq!(e.index, 7);
    assert!(matches!(e.source, StateError::NonFinite { index: 2, .. }));
    qs[6 * 7 + 2] = 0.0;
    qs[6 * 3] = 10.0;
    let e = forward_kinematics_batch(&chain, &mut batch, &qs).unwrap_err();
    assert_eq!(e.index, 3);
    assert!(matches!(e.source, StateError::OutOfLimits { .. }));
    // Whatever position a bad configuration has (whole blocks of eight are checked together,
    // the rest one by one), it is found and named.
    for bad in 0..19 {
        let mut qs = vec![0.0; 6 * 19];
        qs[6 * bad + 5] = f64::NEG_INFINITY;
        let e = forward_kinematics_batch(&chain, &mut batch, &qs).unwrap_err();
        assert_eq!(e.index, bad);
        assert!(matches!(e.source, StateError::NonFinite { index: 5, .. }));
        qs[6 * bad + 5] = -10.0;
        let e = forward_kinematics_batch(&chain, &mut batch, &qs).unwrap_err();
        assert_eq!(e.index, bad);
        assert!(matches!(e.source, StateError::OutOfLimits { .. }));
    }
    let e = forward_kinematics_batch(&chain, &mut batch, &qs[..13]).unwrap_err();
    assert!(matches!(e.source, StateError::WrongLength { .. }));
    assert!(
        forward_kinematics_batch(&chain, &mut batch, &[])
            .unwrap()
            .is_empty()
    );
    // Many configurations (checked in parts, in parallel): the first bad one is named, by both
    // entry points, whatever part it falls in.
    let mut qs = vec![0.0; 6 * 5000];
    qs[6 * 4500 + 1] = f64::INFINITY;
    qs[6 * 3001 + 4] = -10.0;
    for e in [
        forward_kinematics_batch(&chain, &mut batch, &qs).unwrap_err(),
        forward_kinematics_batch_par(&chain, &mut batch, &qs).unwrap_err(),
    ] {
        assert_eq!(e.index, 3001);
        assert!(matches!(e.source, StateError::OutOfLimits { .. }));
    }
    batch.set_limit_policy(LimitPolicy::Ignore);
    let e = forward_kinematics_batch_par(&chain, &mut batch, &qs).unwrap_err();
    assert_eq!(e.index, 4500);
    assert!(matches!(e.source, StateError::NonFinite { index: 1, .. }));
}

#[test]
fn large_parallel_batches_equal_the_single_threaded_batch() {
    // Past the size where the pool is used (smaller batches run on the calling thread).
    let chain = Chain::from_file(robots_dir().join("panda.urdf")).unwrap();
    let mut rng = rng(5);
    let qs: Vec<f64> = (0..3001).flat_map(|_| random_q(&chain, &mut rng)).collect();
    let unchecked = || BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let (mut one, mut all) = (unchecked(), unchecked());
    let a = forward_kinematics_batch(&chain, &mut one, &qs).unwrap();
    let b = forward_kinematics_batch_par(&chain, &mut all, &qs).unwrap();
    assert_eq!(a.len(), b.len());
    let links = link_ids(&chain);
    for i in (0..a.len()).step_by(7).chain([a.len() - 1]) {
        for &l in &links {
            assert_eq!(
                a.world_from_link(i, l),
                b.world_from_link(i, l),
                "configuration {i}"
            );
        }
    }
}

/// Parallel batches share their work with the pool they are called from, also from inside one
/// of its tasks and with more threads than cores; the results are the calling thread's, bit for
/// bit.
#[test]
fn parallel_batches_in_a_pool_and_in_its_tasks_equal_the_single_threaded_batch() {
    use rayon::prelude::*;
    let chain = Chain::from_file(robots_dir().join("ur5.yaml")).unwrap();
    let mut rng = rng(12);
    let qs: Vec<f64> = (0..1_501)
        .flat_map(|_| random_q(&chain, &mut rng))
        .collect();
    let tool = chain.link_id("tool0").unwrap();
    let unchecked = || BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let tool_poses = |poses: BatchPoses<'_>| -> Vec<Transform> {
        (0..poses.len())
            .map(|i| poses.world_from_link(i, tool))
            .collect()
    };
    let want = tool_poses(forward_kinematics_batch(&chain, &mut unchecked(), &qs).unwrap());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(5)
        .build()
        .unwrap();
    let runs: Vec<(Vec<Transform>, Vec<Transform>)> = pool.install(|| {
        (0..4)
            .into_par_iter()
            .map(|_| {
                let mut data = unchecked();
                let all = tool_poses(forward_kinematics_batch_par(&chain, &mut data, &qs).unwrap());
                let one = forward_kinematics_batch_to_par(&chain, &mut data, &qs, tool).unwrap();
                let one = (0..one.len()).map(|i| one.world_from_link(i)).collect();
                (all, one)
            })
            .collect()
    });
    for (all, one) in runs {
        assert!(all == want && one == want);
    }
}

#[test]
fn one_link_batches_equal_the_full_batch() {
    let mut rng = rng(6);
    for file in [
        "panda.urdf",
        "ur5.yaml",
        "stanford.yaml",
        "cylindrical.yaml",
    ] {
        let chain = Chain::from_file(robots_dir().join(file)).unwrap();
        // Enough configurations for the parallel path on every link (a path of one body needs
        // `batch::PARALLEL_WORK`), in dozens of runs per thread, and a partial last chunk.
        let qs: Vec<f64> = (0..20_003)
            .flat_map(|_| random_q(&chain, &mut rng))
            .collect();
        let mut full = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let all = forward_kinematics_batch(&chain, &mut full, &qs).unwrap();
        let mut one = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        for link in chain.links() {
            let id = chain.link_id(link.name()).unwrap();
            for parallel in [false, true] {
                let poses = (if parallel {
                    forward_kinematics_batch_to_par(&chain, &mut one, &qs, id)
                } else {
                    forward_kinematics_batch_to(&chain, &mut one, &qs, id)
                })
                .unwrap();
                assert_eq!(poses.len(), all.len());
                for i in (0..all.len()).step_by(11).chain([all.len() - 1]) {
                    assert_eq!(
                        poses.world_from_link(i),
                        all.world_from_link(i, id),
                        "{file} {} configuration {i}",
                        link.name()
                    );
                }
            }
        }
    }
}

/// A long chain is split over the threads from a few dozen configurations (the threshold is on
/// joints evaluated, not configurations), one-link batches in groups of fewer chunks than a
/// block; the results are those of the calling thread, bit for bit.
#[test]
fn small_batches_of_a_long_chain_run_in_parallel_with_the_same_results() {
    let chain = random_standard_dh_chain(300, 8);
    let mut rng = rng(8);
    // 69 configurations: 20 700 joints, nine chunks (the last partial), in groups of two on two
    // threads (of one on more).
    let qs: Vec<f64> = (0..69).flat_map(|_| random_q(&chain, &mut rng)).collect();
    let mut data = [(); 3].map(|()| BatchData::new(&chain));
    let [one, all, path] = &mut data;
    let a = forward_kinematics_batch(&chain, one, &qs).unwrap();
    let b = forward_kinematics_batch_par(&chain, all, &qs).unwrap();
    for link in ["link1", "link150", "link300"] {
        let id = chain.link_id(link).unwrap();
        for i in 0..a.len() {
            assert_eq!(
                a.world_from_link(i, id),
                b.world_from_link(i, id),
                "{link} {i}"
            );
        }
    }
    let tip = chain.link_id("link300").unwrap();
    let poses = forward_kinematics_batch_to_par(&chain, path, &qs, tip).unwrap();
    assert_eq!(poses.len(), 69);
    for i in 0..69 {
        assert_eq!(
            poses.world_from_link(i),
            a.world_from_link(i, tip),
            "tip {i}"
        );
    }
}

#[test]
fn one_link_batches_name_the_first_bad_configuration() {
    let chain = Chain::from_file(robots_dir().join("puma560.yaml")).unwrap();
    let tool = chain.link_id("tool").unwrap();
    let mut batch = BatchData::new(&chain);
    let mut qs = vec![0.0; 6 * 5000];
    qs[6 * 4500 + 1] = f64::NAN;
    qs[6 * 3001 + 4] = -10.0;
    for parallel in [false, true] {
        let e = (if parallel {
            forward_kinematics_batch_to_par(&chain, &mut batch, &qs, tool)
        } else {
            forward_kinematics_batch_to(&chain, &mut batch, &qs, tool)
        })
        .unwrap_err();
        assert_eq!(e.index, 3001);
        assert!(matches!(e.source, StateError::OutOfLimits { .. }));
    }
}

/// The kernels check each chunk's lanes as they transpose them: see
/// [`assert_lane_checks_decide_as_check_q_does`] (the AVX2 and baseline lanes are checked by
/// `fused_isas.rs` and `baseline_isa.rs`).
#[test]
fn lane_checks_decide_as_check_q_does() {
    assert_lane_checks_decide_as_check_q_does();
}

/// With limits that are not one interval per entry (a mimic finger bounding its primary's entry
/// with the opposite scale) the kernels cannot check the lanes; the batch checks the
/// configurations apart and decides as `check_q` does, by every entry point, in `f64` and `f32`.
#[test]
fn batches_decide_as_check_q_does_when_lanes_cannot() {
    let chain = Chain::from_urdf_str(MIMIC_GRIPPER).unwrap();
    let tool = chain.link_id("right").unwrap();
    let mut batch = BatchData::new(&chain);
    let mut batch32 = sp::BatchData::new(&chain);
    assert_eq!(batch.limit_policy(), LimitPolicy::Enforce);
    assert_eq!(batch32.limit_policy(), LimitPolicy::Enforce);
    // (entry, value): the right finger out of [−0.04, 0] (0.01 − 0.005 > 0), the left out of
    // [0, 0.04], inside both, and non-finite values at the joint that has no limits (which
    // accepts any finite value).
    let probes = [
        (2, 0.005),
        (2, 0.045),
        (2, 0.03),
        (0, f64::NAN),
        (0, f64::INFINITY),
        (0, 100.0),
    ];
    let (mut accepted, mut rejected) = (0, 0);
    for policy in [LimitPolicy::Enforce, LimitPolicy::Ignore] {
        batch.set_limit_policy(policy);
        batch32.set_limit_policy(policy);
        assert_eq!(
            (batch.limit_policy(), batch32.limit_policy()),
            (policy, policy)
        );
        // 19 configurations (blocks of eight and a rest) and 5000 (checked in parts in parallel).
        for (n, bads) in [(19, &[0, 7, 8, 18][..]), (5000, &[0, 2999, 4999][..])] {
            for &bad in bads {
                for (entry, x) in probes {
                    let mut qs = [0.7, -0.4, 0.02].repeat(n);
                    qs[3 * bad + entry] = x;
                    let want = qs
                        .chunks(3)
                        .position(|q| kinechain::check_q(&chain, q, policy).is_err());
                    let got = [
                        forward_kinematics_batch(&chain, &mut batch, &qs).err(),
                        forward_kinematics_batch_par(&chain, &mut batch, &qs).err(),
                        forward_kinematics_batch_to(&chain, &mut batch, &qs, tool).err(),
                        forward_kinematics_batch_to_par(&chain, &mut batch, &qs, tool).err(),
                        sp::forward_kinematics_batch(&chain, &mut batch32, &qs).err(),
                        sp::forward_kinematics_batch_par(&chain, &mut batch32, &qs).err(),
                        sp::forward_kinematics_batch_to(&chain, &mut batch32, &qs, tool).err(),
                        sp::forward_kinematics_batch_to_par(&chain, &mut batch32, &qs, tool).err(),
                    ];
                    for (i, e) in got.into_iter().enumerate() {
                        let e = e.map(|e| e.index);
                        assert_eq!(
                            e, want,
                            "{policy:?}: entry point {i}, {x} at {entry} of {bad}"
                        );
                    }
                    match want {
                        None => accepted += 1,
                        Some(_) => rejected += 1,
                    }
                }
            }
        }
    }
    // Enforced, four probes fail at each position; ignored, the two non-finite ones.
    assert_eq!((accepted, rejected), (7 * 2 + 7 * 4, 7 * 4 + 7 * 2));
}

/// The parallel paths, when the kernels cannot check the lanes, check each part before
/// evaluating it, and then evaluate every part: into buffers that no other call has filled, they
/// give what the single-threaded paths give, configuration by configuration.
#[test]
fn parallel_batches_checked_apart_from_the_kernels_evaluate_every_part() {
    let chain = Chain::from_urdf_str(MIMIC_GRIPPER).unwrap();
    let (n, links, tool) = (5000, link_ids(&chain), chain.link_id("right").unwrap());
    let qs: Vec<f64> = (0..n)
        .flat_map(|i| {
            let t = f64::from(i) / f64::from(n);
            [6.0 * t - 3.0, 1.5 - 3.0 * t, 0.01 + 0.03 * t]
        })
        .collect();
    let mut serial = BatchData::new(&chain);
    let want = forward_kinematics_batch(&chain, &mut serial, &qs).unwrap();
    let mut fresh = BatchData::new(&chain);
    let got = forward_kinematics_batch_par(&chain, &mut fresh, &qs).unwrap();
    for i in 0..n as usize {
        for &l in &links {
            assert_eq!(
                got.world_from_link(i, l),
                want.world_from_link(i, l),
                "{i} {l:?}"
            );
        }
    }
    let mut serial = BatchData::new(&chain);
    let want = forward_kinematics_batch_to(&chain, &mut serial, &qs, tool).unwrap();
    let mut fresh = BatchData::new(&chain);
    let got = forward_kinematics_batch_to_par(&chain, &mut fresh, &qs, tool).unwrap();
    for i in 0..n as usize {
        assert_eq!(got.world_from_link(i), want.world_from_link(i), "{i}");
    }
    let mut serial = sp::BatchData::new(&chain);
    let want = sp::forward_kinematics_batch(&chain, &mut serial, &qs).unwrap();
    let mut fresh = sp::BatchData::new(&chain);
    let got = sp::forward_kinematics_batch_par(&chain, &mut fresh, &qs).unwrap();
    for i in 0..n as usize {
        for &l in &links {
            assert_eq!(
                got.world_from_link(i, l),
                want.world_from_link(i, l),
                "f32 {i} {l:?}"
            );
        }
    }
}

/// A chain without moving joints has empty configurations, which a flat batch cannot count:
/// every batch entry point refuses it with an error that says so, while a single evaluation
/// works.
#[test]
fn batches_of_a_chain_without_moving_joints_are_refused() {
    let chain = Chain::from_urdf_str(FIXED_ONLY_URDF).unwrap();
    assert_eq!(chain.dof(), 0);
    let tool = chain.link_id("tool").unwrap();
    let mut batch = BatchData::new(&chain);
    let mut batch32 = kinechain::eval::batch::single_precision::BatchData::new(&chain);
    for qs in [&[][..], &[0.0][..]] {
        let errors = [
            forward_kinematics_batch(&chain, &mut batch, qs).map(|_| ()),
            forward_kinematics_batch_par(&chain, &mut batch, qs).map(|_| ()),
            forward_kinematics_batch_to(&chain, &mut batch, qs, tool).map(|_| ()),
            kinechain::eval::batch::single_precision::forward_kinematics_batch(
                &chain,
                &mut batch32,
                qs,
            )
            .map(|_| ()),
        ];
        for e in errors {
            let e = e.unwrap_err();
            assert_eq!(e.source, StateError::NoDegreesOfFreedom, "{qs:?}");
            assert!(e.source.to_string().contains("no moving joints"), "{e}");
        }
    }
    let mut data = kinechain::Data::new(&chain);
    let poses = kinechain::forward_kinematics(&chain, &mut data, &[]).unwrap();
    assert_eq!(poses.world_from_link(tool).translation().z, 1.0);
}

/// Every link's poses of the blocks a batch is folded in, in order.
type Blocks = Vec<(usize, Vec<Transform>)>;

/// `pose(i, l)` for configurations `i` of `0..n` and, in each, every link `l` of `links`.
fn every_pose(
    n: usize,
    links: &[LinkId],
    pose: impl Fn(usize, LinkId) -> Transform,
) -> Vec<Transform> {
    (0..n)
        .flat_map(|i| links.iter().map(move |&l| (i, l)))
        .map(|(i, l)| pose(i, l))
        .collect()
}

/// `$fold` (the `f64` or `f32` batch's `forward_kinematics_batch_fold`) collecting every pose,
/// block by block.
macro_rules! folded {
    ($fold:path, $fold_par:path) => {
        |chain: &Chain, qs: &[f64], parallel: bool| -> Result<Blocks, BatchError> {
            let links = link_ids(chain);
            macro_rules! run {
                ($f:path) => {
                    $f(
                        chain,
                        qs,
                        LimitPolicy::Ignore,
                        Vec::new,
                        |mut blocks: Blocks, first, poses| {
                            blocks.push((
                                first,
                                every_pose(poses.len(), &links, |i, l| poses.world_from_link(i, l)),
                            ));
                            blocks
                        },
                        |mut a, b| {
                            a.extend(b);
                            a
                        },
                    )
                };
            }
            if parallel {
                run!($fold_par)
            } else {
                run!($fold)
            }
        }
    };
}

/// The `f64` or the `f32` batch, as the fold tests use it.
struct Precision {
    name: &'static str,
    /// Configurations per pass through the kernels.
    width: usize,
    block_len: fn(&Chain) -> usize,
    /// Every link's pose in every configuration of the whole batch, configuration by
    /// configuration.
    whole: fn(&Chain, &[f64]) -> Vec<Transform>,
    folded: fn(&Chain, &[f64], bool) -> Result<Blocks, BatchError>,
}

const PRECISIONS: [Precision; 2] = [
    Precision {
        name: "f64",
        width: 8,
        block_len: fold_block_len,
        whole: |chain, qs| {
            let mut data = BatchData::new(chain).with_limit_policy(LimitPolicy::Ignore);
            let poses = forward_kinematics_batch(chain, &mut data, qs).unwrap();
            every_pose(poses.len(), &link_ids(chain), |i, l| {
                poses.world_from_link(i, l)
            })
        },
        folded: folded!(
            forward_kinematics_batch_fold,
            forward_kinematics_batch_fold_par
        ),
    },
    Precision {
        name: "f32",
        width: 16,
        block_len: sp::fold_block_len,
        whole: |chain, qs| {
            let mut data = sp::BatchData::new(chain).with_limit_policy(LimitPolicy::Ignore);
            let poses = sp::forward_kinematics_batch(chain, &mut data, qs).unwrap();
            every_pose(poses.len(), &link_ids(chain), |i, l| {
                poses.world_from_link(i, l)
            })
        },
        folded: folded!(
            sp::forward_kinematics_batch_fold,
            sp::forward_kinematics_batch_fold_par
        ),
    },
];

/// Folding a batch block by block, in `f64` or `f32`, on one thread or on a pool of two, hands
/// every configuration's poses over once, in blocks of `fold_block_len` in order, with the bits
/// of the whole batch. The 50-joint chain makes 73 blocks (of 48 configurations in `f64`, 96 in
/// `f32`), more than the 64 runs two threads aim for, so that runs of two blocks are folded.
#[test]
fn folded_blocks_equal_the_batch_bit_for_bit() {
    let mut rng = rng(9);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for p in &PRECISIONS {
        for (file, n) in [
            ("panda.urdf", 2_500),
            ("ur5.yaml", 3_500),
            ("snake50.yaml", 3_500),
        ] {
            let what = format!("{file} in {}", p.name);
            // As many blocks in either precision.
            let n = n * p.width / 8;
            let chain = Chain::from_file(robots_dir().join(file)).unwrap();
            let qs: Vec<f64> = (0..n).flat_map(|_| random_q(&chain, &mut rng)).collect();
            let whole = (p.whole)(&chain, &qs);
            let block = (p.block_len)(&chain);
            assert_eq!(block % p.width, 0, "{what}");
            assert!(
                n > 3 * block,
                "{what}: {n} configurations in blocks of {block}"
            );
            if file == "snake50.yaml" {
                assert!(n.div_ceil(block) > 64, "{what}: {n} in blocks of {block}");
            }
            let links = chain.links().len();
            for parallel in [false, true] {
                let blocks = pool.install(|| (p.folded)(&chain, &qs, parallel)).unwrap();
                assert_eq!(blocks.len(), n.div_ceil(block), "{what}");
                for (b, (first, poses)) in blocks.iter().enumerate() {
                    assert_eq!(*first, b * block, "{what}");
                    assert_eq!(poses.len(), block.min(n - first) * links, "{what}");
                    let want = &whole[first * links..][..poses.len()];
                    for (k, (pose, want)) in poses.iter().zip(want).enumerate() {
                        assert_eq!(
                            pose,
                            want,
                            "{what}, configuration {}, parallel {parallel}",
                            first + k / links
                        );
                    }
                }
            }
        }
    }
}

/// A folded batch, in `f64` or `f32`, names its first bad configuration, whichever block and
/// thread meets it, and refuses a batch of incomplete rows before folding anything.
#[test]
fn folded_batches_name_the_first_bad_configuration() {
    let chain = Chain::from_file(robots_dir().join("panda.urdf")).unwrap();
    let dof = chain.dof();
    let mut rng = rng(10);
    for p in &PRECISIONS {
        let block = (p.block_len)(&chain);
        let n = 9 * block;
        let qs: Vec<f64> = (0..n).flat_map(|_| random_q(&chain, &mut rng)).collect();
        for bad in [
            [0, 7 * block + 3],
            [3 * block + 1, 7 * block],
            [n - 1, n - 1],
        ] {
            let mut qs = qs.clone();
            for (k, &i) in bad.iter().enumerate() {
                qs[i * dof + k] = f64::NAN;
            }
            for parallel in [false, true] {
                let e = (p.folded)(&chain, &qs, parallel).unwrap_err();
                assert_eq!(e.index, bad[0], "{}, parallel {parallel}", p.name);
                assert!(matches!(e.source, StateError::NonFinite { .. }), "{e:?}");
            }
        }
        for parallel in [false, true] {
            let e = (p.folded)(&chain, &qs[..qs.len() - 1], parallel).unwrap_err();
            assert_eq!(e.index, n - 1, "{}", p.name);
            assert!(matches!(e.source, StateError::WrongLength { .. }), "{e:?}");
        }
    }
}

/// Every evaluation runs in a thread of 512 KiB of stack, in an unoptimised build too (`cargo test
/// --config profile.test.opt-level=0`), where no two values share a stack slot and the kernels'
/// frames are largest: a dependent crate's tests, built that way, run in threads of 2 MiB.
#[test]
fn evaluations_fit_a_small_thread_stack() {
    let run = || {
        for file in [
            "robots/panda.urdf",
            "tests/data/reference/urdf/tiago_no_hand.urdf",
        ] {
            let chain = repo_chain(file);
            let n = chain.dof();
            let end = chain.end_link();
            let qs: Vec<f64> = (0..40 * n).map(|i| 0.01 * i as f64).collect();
            let mut batch = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            let mut batch32 = sp::BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            forward_kinematics_batch(&chain, &mut batch, &qs).unwrap();
            forward_kinematics_batch_par(&chain, &mut batch, &qs).unwrap();
            forward_kinematics_batch_to(&chain, &mut batch, &qs, end).unwrap();
            sp::forward_kinematics_batch(&chain, &mut batch32, &qs).unwrap();
            sp::forward_kinematics_batch_to(&chain, &mut batch32, &qs, end).unwrap();
            let count = |n: usize, _: usize, poses: BatchPoses<'_>| n + poses.len();
            let folded = forward_kinematics_batch_fold(
                &chain,
                &qs,
                LimitPolicy::Ignore,
                || 0,
                count,
                |a, b| a + b,
            );
            assert_eq!(folded.unwrap(), 40);
            let mut data = kinechain::Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            let (q, qd, qdd) = (&qs[..n], &qs[n..2 * n], &qs[2 * n..3 * n]);
            kinechain::forward_accelerations(&chain, &mut data, q, qd, qdd).unwrap();
            kinechain::forward_kinematics_incremental(&chain, &mut data, qd).unwrap();
            kinechain::forward_kinematics_to(&chain, &mut data, q, end).unwrap();
        }
    };
    let thread = std::thread::Builder::new()
        .stack_size(512 * 1024)
        .spawn(run);
    thread.unwrap().join().unwrap();
}

/// Matrices written out eight configurations at a time hold the bits of each configuration's
/// `world_from_link`, for every link of every bundled robot and reference model (links fixed to
/// the world included), from full batches and one-link batches, with a partial last chunk; a
/// buffer of another length is refused.
#[test]
fn written_matrices_are_the_poses_bit_for_bit() {
    let mut rng = rng(17);
    for (name, chain) in all_models() {
        let qs: Vec<f64> = (0..21).flat_map(|_| random_q(&chain, &mut rng)).collect();
        let n = qs.len() / chain.dof();
        let ids = link_ids(&chain);
        let mut full = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let all = forward_kinematics_batch(&chain, &mut full, &qs).unwrap();
        let mut out = vec![f64::NAN; n * ids.len() * 16];
        all.write_matrices(&ids, &mut out).unwrap();
        let bits = |m: &[f64]| m.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for i in 0..n {
            for (k, &id) in ids.iter().enumerate() {
                let at = (i * ids.len() + k) * 16;
                let rows = all.world_from_link(i, id).to_rows().concat();
                assert_eq!(
                    bits(&out[at..at + 16]),
                    bits(&rows),
                    "{name} {k} configuration {i}"
                );
            }
        }
        assert!(matches!(
            all.write_matrices(&ids, &mut out[1..]),
            Err(StateError::OutputLength { got, expected }) if got + 1 == expected
        ));
        let mut one = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut out = vec![f64::NAN; n * 16];
        for &id in &ids {
            let poses = forward_kinematics_batch_to(&chain, &mut one, &qs, id).unwrap();
            poses.write_matrices(&mut out).unwrap();
            for i in 0..n {
                let rows = all.world_from_link(i, id).to_rows().concat();
                assert_eq!(
                    bits(&out[16 * i..16 * i + 16]),
                    bits(&rows),
                    "{name} configuration {i}"
                );
            }
            assert!(poses.write_matrices(&mut out[..16]).is_err());
        }
    }
}
