//! The fused-multiply–add kernels (AVX2 and, where the CPU has it, AVX-512 with the `sin`/`cos`
//! of single evaluations in one 512-bit register and in two 256-bit halves), each forced in turn
//! in this process: all meet the 50-digit reference bounds, their batches equal their single
//! evaluations bit for bit, and they give the same bits as each other (the same operations in
//! the same order, four lanes or eight). The default tests run only the widest path the machine
//! has and one of the two ways of computing `sin`/`cos` on it, so without this file an AVX-512
//! machine would never run the AVX2 kernels.
//!
//! The instruction set is a process-wide choice, so this binary holds a single test.

mod common;

use common::*;
use kinechain::{
    Data, Isa, LimitPolicy, force_isa, force_narrow_trig, forward_accelerations,
    forward_kinematics_to, isa, narrow_trig,
};

/// Every link's pose, velocity and acceleration (as bits) over random states of `file`, and the
/// end link's pose from [`forward_kinematics_to`].
fn fingerprint(file: &str, seed: u64) -> Vec<u64> {
    let chain = repo_chain(file);
    let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
    let mut rng = rng(seed);
    let mut bits = Vec::new();
    for _ in 0..16 {
        let q = random_q(&chain, &mut rng);
        let qd = random_vec(chain.nv(), 2.0, &mut rng);
        let qdd = random_vec(chain.nv(), 5.0, &mut rng);
        let acc = forward_accelerations(&chain, &mut data, &q, &qd, &qdd).unwrap();
        for link in chain.links() {
            let id = chain.link_id(link.name()).unwrap();
            let (pose, v, a) = (
                acc.world_from_link(id),
                acc.velocity(id),
                acc.acceleration(id),
            );
            let rows = pose.to_rows();
            bits.extend(rows.iter().flatten().map(|x| x.to_bits()));
            for w in [v.omega, v.v, a.alpha, a.a] {
                bits.extend(w.iter().map(|x| x.to_bits()));
            }
        }
        let end = forward_kinematics_to(&chain, &mut data, &q, chain.end_link()).unwrap();
        bits.extend(end.to_rows().iter().flatten().map(|x| x.to_bits()));
    }
    bits
}

const FILES: [&str; 7] = [
    "robots/panda.urdf",
    "robots/panda.urdf+floating",
    "robots/ur5.yaml",
    "robots/stanford.yaml",
    "robots/snake50.yaml",
    "robots/cylindrical.yaml",
    "tests/data/reference/urdf/tiago_no_hand.urdf",
];

/// Whether the CPU has what the kernels of `isa` need, asked of the standard library here rather
/// than of the detection the library does (so that a detection that settles for less is seen).
fn cpu_has(isa: Isa) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        match isa {
            Isa::Baseline => true,
            Isa::Avx2 => has!("avx2") && has!("fma"),
            Isa::Avx512 => has!("avx512f") && has!("avx512dq") && has!("avx512vl") && has!("fma"),
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        isa == Isa::Baseline
    }
}

#[test]
fn avx2_and_avx512_kernels_meet_the_bounds_and_agree_bit_for_bit() {
    // Unforced, the kernels use the widest instruction set the CPU has.
    let widest = [Isa::Avx512, Isa::Avx2, Isa::Baseline]
        .into_iter()
        .find(|&i| cpu_has(i))
        .unwrap();
    assert_eq!(isa(), widest);
    let mut fingerprints = Vec::new();
    for (wanted, narrow) in [
        (Isa::Avx2, false),
        (Isa::Avx512, false),
        (Isa::Avx512, true),
    ] {
        force_isa(Some(wanted));
        force_narrow_trig(Some(narrow));
        assert_eq!(narrow_trig(), narrow);
        if !cpu_has(wanted) {
            assert!(isa() < wanted);
            eprintln!("this CPU has no {}: not tested", wanted.name());
            continue;
        }
        assert_eq!(isa(), wanted, "the CPU has {}", wanted.name());
        let wanted = match narrow {
            true => format!("{} with 256-bit sin/cos", wanted.name()),
            false => wanted.name().to_string(),
        };
        for path in reference_files() {
            let (position, rotation) = pose_ulps(&path);
            assert!(
                position <= 8.0 && rotation <= 8.0,
                "{wanted}: {}: position {position:.2} ulp of reach, rotation {rotation:.2} ulp",
                path.display()
            );
        }
        assert_batches_equal_single_evaluations(&FILES, 23);
        assert_lane_checks_decide_as_check_q_does();
        #[cfg(feature = "reference")]
        {
            let (position, rotation) = large_angle_pose_ulps("robots/puma560.yaml");
            assert!(
                position <= 8.0 && rotation <= 8.0,
                "{wanted}, large angles: position {position:.2} ulp of reach, rotation {rotation:.2} ulp"
            );
        }
        let prints: Vec<Vec<u64>> = FILES.iter().map(|f| fingerprint(f, 7)).collect();
        fingerprints.push((wanted, prints));
    }
    force_isa(None);
    force_narrow_trig(None);
    if let [(a, first), rest @ ..] = &fingerprints[..] {
        for (b, second) in rest {
            for ((file, x), y) in FILES.iter().zip(first).zip(second) {
                assert_eq!(x.len(), y.len());
                let differ = x.iter().zip(y).filter(|(p, q)| p != q).count();
                assert_eq!(
                    differ,
                    0,
                    "{file}: {differ} of {} values differ between {a} and {b}",
                    x.len(),
                );
            }
        }
    }
}
