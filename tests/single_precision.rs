//! The single-precision batch: its errors against the 50-digit references on every instruction
//! set, its checks (the same decisions and indices as the `f64` batch), and its one-link path.

mod common;

use common::*;
use kinechain::eval::batch::{self, single_precision as sp};
use kinechain::{Chain, Isa, LimitPolicy, StateError, force_isa, isa};
use std::sync::Mutex;

/// Held by the tests of this file: one of them switches the instruction set (a global setting).
static ISA: Mutex<()> = Mutex::new(());

/// One unit in the last place of an `f32` near 1.
const ULP32: f64 = f32::EPSILON as f64;

/// Largest position error (in `f32` ulps of the reach) and rotation error (in `f32` ulps of 1)
/// of the single-precision batch, all links and each link alone, over a reference file.
fn errors(path: &std::path::Path) -> (f64, f64) {
    let reference = read_json(path);
    let exact = read_json(&hp_path(path));
    let chain = reference_chain(path, &reference);
    let reach = scale_of(&exact, "pose");
    let samples = exact["samples"].as_array().unwrap();
    let qs: Vec<f64> = samples
        .iter()
        .flat_map(|s| joint_vector(&chain, &s["q"]))
        .collect();
    let mut data = sp::BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let mut one = sp::BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let (mut position, mut rotation) = (0.0_f64, 0.0_f64);
    let all = sp::forward_kinematics_batch(&chain, &mut data, &qs).unwrap();
    for name in samples[0]["links"].as_object().unwrap().keys() {
        let link = chain.link_id(name).unwrap();
        let alone = sp::forward_kinematics_batch_to(&chain, &mut one, &qs, link).unwrap();
        for (i, sample) in samples.iter().enumerate() {
            let got = all.world_from_link(i, link);
            // The one-link path does the same operations on the path's bodies.
            assert_eq!(alone.world_from_link(i), got, "{name}, sample {i}");
            let want = matrix4(&sample["links"][name]["pose"]);
            (position, rotation) = worse_pose((position, rotation), &got.to_rows(), &want);
        }
    }
    (position / (reach * ULP32), rotation / ULP32)
}

/// Within 16 `f32` ulps of the reach (positions) and of 1 (rotations) on every reference robot
/// and every instruction set: the remainders of θ and the frames are rounded to `f32`, so errors
/// of a few `f32` ulps are expected (measured: at most 2.4 and 3.8, on the baseline path), as 8 `f64` ulps bound the
/// `f64` paths.
#[test]
fn reference_errors_are_a_few_f32_ulps() {
    let _isa = ISA.lock().unwrap_or_else(|e| e.into_inner());
    let mut levels = vec![Isa::Baseline];
    if isa() >= Isa::Avx2 {
        levels.push(Isa::Avx2);
    }
    if isa() == Isa::Avx512 {
        levels.push(Isa::Avx512);
    }
    for level in levels {
        force_isa(Some(level));
        for path in reference_files() {
            let (position, rotation) = errors(&path);
            assert!(
                position <= 16.0 && rotation <= 16.0,
                "{}, {level:?}: position {position:.2}, rotation {rotation:.2} f32 ulps",
                path.display()
            );
        }
    }
    force_isa(None);
}

/// The same configurations are rejected, with the same index and error, as by the `f64` batch,
/// whatever lane and chunk of sixteen the bad one falls in; the limits are checked before the
/// values are rounded to `f32` (one `f64` ulp past a limit is rejected).
#[test]
fn checks_decide_as_the_f64_batch_does() {
    let _isa = ISA.lock().unwrap_or_else(|e| e.into_inner());
    let chain = Chain::from_file(robots_dir().join("puma560.yaml")).unwrap();
    let tool = chain.link_id("tool").unwrap();
    let upper = chain
        .joint(chain.joint_id("j2").unwrap())
        .limits()
        .first()
        .copied()
        .flatten()
        .unwrap()
        .upper;
    let mut data = sp::BatchData::new(&chain);
    let mut data64 = batch::BatchData::new(&chain);
    for n in [1, 15, 16, 17, 40] {
        for bad in 0..n {
            for value in [f64::NAN, f64::INFINITY, upper.next_up(), upper] {
                let mut qs = vec![0.1; 6 * n];
                qs[6 * bad + 1] = value;
                // Compared as text: a NaN in the error is not equal to itself.
                let text = |r: Result<usize, batch::BatchError>| format!("{r:?}");
                let want = text(
                    batch::forward_kinematics_batch(&chain, &mut data64, &qs).map(|p| p.len()),
                );
                let all =
                    text(sp::forward_kinematics_batch(&chain, &mut data, &qs).map(|p| p.len()));
                assert_eq!(all, want, "{n} configurations, bad {bad}, {value}");
                let one = text(
                    sp::forward_kinematics_batch_to(&chain, &mut data, &qs, tool).map(|p| p.len()),
                );
                assert_eq!(one, want, "{n} configurations, bad {bad}, {value}");
            }
        }
    }
    let e = sp::forward_kinematics_batch(&chain, &mut data, &[0.0; 13]).unwrap_err();
    assert!(matches!(e.source, StateError::WrongLength { .. }));
    assert!(
        sp::forward_kinematics_batch(&chain, &mut data, &[])
            .unwrap()
            .is_empty()
    );
    // Ignoring the limits still rejects non-finite values.
    data.set_limit_policy(LimitPolicy::Ignore);
    let mut qs = vec![10.0; 6 * 20];
    assert_eq!(
        sp::forward_kinematics_batch(&chain, &mut data, &qs).map(|p| p.len()),
        Ok(20)
    );
    qs[6 * 18 + 3] = f64::NAN;
    let e = sp::forward_kinematics_batch(&chain, &mut data, &qs).unwrap_err();
    assert_eq!(e.index, 18);
    assert!(matches!(e.source, StateError::NonFinite { index: 3, .. }));
}

/// Large joint angles are reduced in `f64`: a pose at θ and at θ + 2πk (k up to 10⁴) agree as
/// closely as at small angles, where computing θ in `f32` would lose about 2⁻²⁴ |θ|; and angles
/// up to 10¹⁵ rad agree with the `f64` batch (itself checked there against the 256-bit
/// evaluation).
#[test]
fn large_angles_are_as_accurate_as_small_ones() {
    let _isa = ISA.lock().unwrap_or_else(|e| e.into_inner());
    let chain = Chain::from_file(robots_dir().join("ur5.yaml")).unwrap();
    let tool = chain.link_id("tool0").unwrap();
    let mut data = sp::BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let mut data64 = batch::BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let mut rng = rng(5);
    // The largest difference of the tool poses from the `f64` batch's.
    let mut worst_error = |qs: &[f64]| {
        let exact = batch::forward_kinematics_batch(&chain, &mut data64, qs).unwrap();
        let single = sp::forward_kinematics_batch(&chain, &mut data, qs).unwrap();
        (0..single.len())
            .map(|i| {
                let want = exact.world_from_link(i, tool).to_rows();
                pose_error(&single.world_from_link(i, tool), &want)
            })
            .fold(0.0, worse)
    };
    let base: Vec<f64> = (0..64).flat_map(|_| random_q(&chain, &mut rng)).collect();
    for turns in [0.0, 1.0, 100.0, 10_000.0] {
        let qs: Vec<f64> = base
            .iter()
            .map(|q| q + turns * std::f64::consts::TAU)
            .collect();
        // The reach of the UR5 is about 1 m; 16 f32 ulps.
        let error = worst_error(&qs);
        assert!(error <= 16.0 * ULP32, "{turns} turns: {error:e}");
    }
    // Beyond the reduction's range (about 8.2·10⁵ rad) the standard library's `f64` functions
    // take over, in every lane of a pass that has such an angle, and only in those lanes.
    for scale in [1e6, 1e9, 1e15] {
        let mut qs: Vec<f64> = (0..64).flat_map(|_| random_q(&chain, &mut rng)).collect();
        for q in qs.iter_mut().step_by(5) {
            *q *= scale;
        }
        let error = worst_error(&qs);
        assert!(error <= 16.0 * ULP32, "angles of {scale:e}: {error:e}");
    }
}

/// Every bundled robot (sliding, cylindrical and mimic joints, branches, a 50-joint snake) at
/// random configurations within its limits: the single-precision batch stays within 16 `f32`
/// ulps of the reach (at least 1 m) of the `f64` batch, for every link (measured: at most 1.2).
#[test]
fn bundled_robots_agree_with_the_f64_batch() {
    let _isa = ISA.lock().unwrap_or_else(|e| e.into_inner());
    let mut rng = rng(11);
    let floating = kinechain::io::LoadOptions::default().with_floating_base(true);
    let files = robot_files();
    let chains = files
        .iter()
        .map(|p| (p, Chain::from_file(p).unwrap()))
        .chain(
            files
                .iter()
                .map(|p| (p, Chain::from_file_with(p, &floating).unwrap())),
        );
    for (path, chain) in chains {
        let qs: Vec<f64> = (0..37).flat_map(|_| random_q(&chain, &mut rng)).collect();
        let mut data = sp::BatchData::new(&chain);
        let mut data64 = batch::BatchData::new(&chain);
        let single = sp::forward_kinematics_batch(&chain, &mut data, &qs).unwrap();
        let double = batch::forward_kinematics_batch(&chain, &mut data64, &qs).unwrap();
        let reach = chain.reach().max(1.0);
        let links: Vec<_> = chain
            .links()
            .iter()
            .map(|l| chain.link_id(l.name()).unwrap())
            .collect();
        let mut worst = 0.0_f64;
        for i in 0..single.len() {
            for &link in &links {
                let error = pose_error(
                    &single.world_from_link(i, link),
                    &double.world_from_link(i, link).to_rows(),
                );
                worst = worse(worst, error / reach);
            }
        }
        assert!(worst <= 16.0 * ULP32, "{}: {worst:e}", path.display());
    }
}

/// Large batches on rayon's pool: the same poses, bit for bit, as on one thread, and the same
/// first bad configuration named, whatever task it falls in.
#[test]
fn parallel_batches_equal_the_single_threaded_batch() {
    let _isa = ISA.lock().unwrap_or_else(|e| e.into_inner());
    let chain = Chain::from_file(robots_dir().join("puma560.yaml")).unwrap();
    let tool = chain.link_id("tool").unwrap();
    let mut rng = rng(17);
    let n = 5003;
    let qs: Vec<f64> = (0..n).flat_map(|_| random_q(&chain, &mut rng)).collect();
    let mut one = sp::BatchData::new(&chain);
    let mut many = sp::BatchData::new(&chain);
    let serial = sp::forward_kinematics_batch(&chain, &mut one, &qs).unwrap();
    let parallel = sp::forward_kinematics_batch_par(&chain, &mut many, &qs).unwrap();
    assert_eq!(parallel.len(), n);
    let links: Vec<_> = chain
        .links()
        .iter()
        .map(|l| chain.link_id(l.name()).unwrap())
        .collect();
    for i in (0..n).step_by(7).chain([n - 1]) {
        for &link in &links {
            assert_eq!(
                parallel.world_from_link(i, link),
                serial.world_from_link(i, link)
            );
        }
    }
    let mut tool_one = sp::BatchData::new(&chain);
    let serial_tool = sp::forward_kinematics_batch_to(&chain, &mut tool_one, &qs, tool).unwrap();
    let parallel_tool = sp::forward_kinematics_batch_to_par(&chain, &mut many, &qs, tool).unwrap();
    for i in 0..n {
        assert_eq!(
            parallel_tool.world_from_link(i),
            serial_tool.world_from_link(i)
        );
    }
    let mut bad = qs.clone();
    bad[6 * 4500 + 1] = f64::NAN;
    bad[6 * 3001 + 4] = -10.0;
    for e in [
        sp::forward_kinematics_batch_par(&chain, &mut many, &bad).unwrap_err(),
        sp::forward_kinematics_batch_to_par(&chain, &mut many, &bad, tool).unwrap_err(),
    ] {
        assert_eq!(e.index, 3001);
        assert!(matches!(e.source, StateError::OutOfLimits { .. }));
    }
}
