//! Batched velocities and accelerations give, configuration by configuration and bit for bit,
//! what single evaluations give; they agree with the reference data's rates and with finite
//! differences of batched poses; bad rates are errors naming the configuration and joint.

use crate::common::*;
use kinechain::eval::batch::{
    BatchData, forward_accelerations_batch, forward_accelerations_batch_par,
    forward_kinematics_batch, forward_velocities_batch, forward_velocities_batch_par,
};
use kinechain::{Chain, Data, LimitPolicy, StateError, forward_accelerations, forward_velocities};

/// 37 configurations (four chunks of eight and a partial one) with rates.
fn samples(chain: &Chain, seed: u64) -> [Vec<f64>; 3] {
    let mut rng = rng(seed);
    let n = 37;
    let qs = (0..n).flat_map(|_| random_q(chain, &mut rng)).collect();
    let qds = random_vec(n * chain.dof(), 2.0, &mut rng);
    let qdds = random_vec(n * chain.dof(), 5.0, &mut rng);
    [qs, qds, qdds]
}

#[test]
fn batched_rates_equal_single_evaluations_bit_for_bit() {
    for (file, chain) in all_models() {
        if chain.dof() == 0 {
            continue;
        }
        let [qs, qds, qdds] = samples(&chain, 7);
        let dof = chain.dof();
        let links = link_ids(&chain);
        let mut single = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut batch = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        for parallel in [false, true] {
            let vel = if parallel {
                forward_velocities_batch_par(&chain, &mut batch, &qs, &qds)
            } else {
                forward_velocities_batch(&chain, &mut batch, &qs, &qds)
            }
            .unwrap();
            assert_eq!(vel.len(), 37);
            for i in 0..37 {
                let rows = i * dof..(i + 1) * dof;
                let want =
                    forward_velocities(&chain, &mut single, &qs[rows.clone()], &qds[rows]).unwrap();
                for &l in &links {
                    assert_eq!(
                        vel.world_from_link(i, l),
                        want.world_from_link(l),
                        "{file} {i}"
                    );
                    assert_eq!(vel.velocity(i, l), want.velocity(l), "{file} {i} {l:?}");
                }
            }
            let acc = if parallel {
                forward_accelerations_batch_par(&chain, &mut batch, &qs, &qds, &qdds)
            } else {
                forward_accelerations_batch(&chain, &mut batch, &qs, &qds, &qdds)
            }
            .unwrap();
            for i in 0..37 {
                let rows = i * dof..(i + 1) * dof;
                let want = forward_accelerations(
                    &chain,
                    &mut single,
                    &qs[rows.clone()],
                    &qds[rows.clone()],
                    &qdds[rows],
                )
                .unwrap();
                for &l in &links {
                    assert_eq!(
                        acc.world_from_link(i, l),
                        want.world_from_link(l),
                        "{file} {i}"
                    );
                    assert_eq!(acc.velocity(i, l), want.velocity(l), "{file} {i} {l:?}");
                    assert_eq!(
                        acc.acceleration(i, l),
                        want.acceleration(l),
                        "{file} {i} {l:?}"
                    );
                }
            }
        }
    }
}

/// The reference data's rates (independent software), every sample of every model in one batch.
#[test]
fn batched_rates_match_the_reference_data() {
    for path in reference_files() {
        let file = read_json(&path);
        let chain = reference_chain(&path, &file);
        let samples = file["samples"].as_array().unwrap();
        let rows = |key: &str| -> Vec<f64> {
            samples
                .iter()
                .flat_map(|s| joint_vector(&chain, &s[key]))
                .collect()
        };
        let (qs, qds, qdds) = (rows("q"), rows("qd"), rows("qdd"));
        let mut batch = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let acc = forward_accelerations_batch(&chain, &mut batch, &qs, &qds, &qdds).unwrap();
        let mut checked = 0;
        for (i, sample) in samples.iter().enumerate() {
            for (name, link) in sample["links"].as_object().unwrap() {
                let id = chain.link_id(name).unwrap();
                let (v, a) = (acc.velocity(i, id), acc.acceleration(i, id));
                for (k, got) in [v.omega, v.v, a.alpha, a.a].iter().enumerate() {
                    let want = vec3(&link[RATE_FIELDS[k]]);
                    let scale = want.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
                    let err = vec_error(got, want);
                    assert!(
                        err <= 1e-10 * scale,
                        "{} sample {i} {name} {}: {err:e}",
                        path.display(),
                        RATE_FIELDS[k]
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 0, "{}", path.display());
    }
}

/// Central differences of batched poses along each configuration's `q̇` give its batched `v` and
/// `ω` (the batch of poses at `q ± h q̇` evaluated as one batch).
#[test]
fn batched_velocities_match_finite_differences_of_batched_poses() {
    for file in [
        "robots/panda.urdf",
        "robots/stanford.yaml",
        "robots/cylindrical.yaml",
    ] {
        let chain = repo_chain(file);
        let [qs, qds, _] = samples(&chain, 11);
        let h = 1e-6;
        let step = |sign: f64| -> Vec<f64> {
            qs.iter()
                .zip(&qds)
                .map(|(q, qd)| q + sign * h * qd)
                .collect()
        };
        let (ahead, behind) = (step(1.0), step(-1.0));
        let mut data = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let mut rates = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let vel = forward_velocities_batch(&chain, &mut rates, &qs, &qds).unwrap();
        let links = link_ids(&chain);
        let plus: Vec<_> = {
            let p = forward_kinematics_batch(&chain, &mut data, &ahead).unwrap();
            (0..37)
                .flat_map(|i| links.iter().map(move |&l| p.world_from_link(i, l)))
                .collect()
        };
        let minus = forward_kinematics_batch(&chain, &mut data, &behind).unwrap();
        for i in 0..37 {
            for (j, &l) in links.iter().enumerate() {
                let (a, b) = (plus[i * links.len() + j], minus.world_from_link(i, l));
                let v = (a.translation() - b.translation()) / (2.0 * h);
                let dr = (a.rotation() - b.rotation()) / (2.0 * h);
                // ω from Ṙ Rᵀ = [ω]× (R at the midpoint, to second order).
                let w = dr * ((a.rotation() + b.rotation()) / 2.0).transpose();
                let omega = kinechain::nalgebra::Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
                let got = vel.velocity(i, l);
                assert!(
                    (got.v - v).norm() < 1e-7,
                    "{file} {i} {l:?}: {} {}",
                    got.v,
                    v
                );
                assert!(
                    (got.omega - omega).norm() < 1e-7,
                    "{file} {i} {l:?}: {} {}",
                    got.omega,
                    omega
                );
            }
        }
    }
}

#[test]
fn bad_rates_are_errors_naming_configuration_and_joint() {
    let chain = repo_chain("robots/puma560.yaml");
    let mut data = BatchData::new(&chain);
    let qs = vec![0.0; 6 * 10];
    let mut qds = vec![0.0; 6 * 10];
    let qdds = vec![0.0; 6 * 10];
    qds[6 * 7 + 2] = f64::NAN;
    let e = forward_velocities_batch(&chain, &mut data, &qs, &qds).unwrap_err();
    assert_eq!(e.index, 7);
    assert!(
        matches!(&e.source, StateError::NonFinite { what: "q_dot", index: 2, joint, .. } if joint == "j3"),
        "{e:?}"
    );
    qds[6 * 7 + 2] = 0.0;
    let e = forward_accelerations_batch(&chain, &mut data, &qs, &qds, &qdds[..54]).unwrap_err();
    assert_eq!(e.index, 9);
    assert!(matches!(
        e.source,
        StateError::WrongRows {
            what: "q_ddot",
            rows: 10,
            dof: 6,
            got: 54
        }
    ));
    assert_eq!(
        e.source.to_string(),
        "q_ddot has 54 entries, the batch's q has 10 configurations, each of 6 entries in q_ddot"
    );
    let longer = vec![0.0; 61];
    let e = forward_velocities_batch_par(&chain, &mut data, &qs, &longer).unwrap_err();
    assert_eq!(e.index, 10);
    assert!(matches!(e.source, StateError::WrongRows { got: 61, .. }));
    let mut qs = qs;
    qs[6 * 4] = 10.0;
    let e = forward_accelerations_batch_par(&chain, &mut data, &qs, &qds, &qdds).unwrap_err();
    assert_eq!(e.index, 4);
    assert!(matches!(e.source, StateError::OutOfLimits { .. }));
    // An empty batch is empty.
    assert!(
        forward_velocities_batch(&chain, &mut data, &[], &[])
            .unwrap()
            .is_empty()
    );
}

/// Rates written out eight configurations at a time hold the bits of each configuration's
/// `velocity` and `acceleration`, for every link of every bundled robot and reference model
/// (links fixed to the world and links with offsets from their body included), with a partial
/// last chunk; poses written from the same evaluation are those of `world_from_link`; buffers
/// of another length are refused.
#[test]
fn written_rates_are_the_link_rates_bit_for_bit() {
    let bits = |m: &[f64]| m.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (name, chain) in all_models() {
        let [qs, qds, qdds] = samples(&chain, 31);
        let n = qs.len() / chain.dof();
        let ids = link_ids(&chain);
        let l = ids.len();
        let mut data = BatchData::new(&chain).with_limit_policy(LimitPolicy::Ignore);
        let acc = forward_accelerations_batch(&chain, &mut data, &qs, &qds, &qdds).unwrap();
        let (mut w, mut v, mut al, mut a) = (
            vec![f64::NAN; n * l * 3],
            vec![f64::NAN; n * l * 3],
            vec![f64::NAN; n * l * 3],
            vec![f64::NAN; n * l * 3],
        );
        acc.velocities()
            .write_velocities(&ids, &mut w, &mut v)
            .unwrap();
        acc.write_accelerations(&ids, &mut al, &mut a).unwrap();
        let mut poses = vec![f64::NAN; n * l * 16];
        acc.velocities()
            .poses()
            .write_matrices(&ids, &mut poses)
            .unwrap();
        for i in 0..n {
            for (k, &id) in ids.iter().enumerate() {
                let at = 3 * (i * l + k);
                let (lv, la) = (acc.velocity(i, id), acc.acceleration(i, id));
                let what = format!("{name} link {k} configuration {i}");
                assert_eq!(bits(&w[at..at + 3]), bits(lv.omega.as_slice()), "{what}");
                assert_eq!(bits(&v[at..at + 3]), bits(lv.v.as_slice()), "{what}");
                assert_eq!(bits(&al[at..at + 3]), bits(la.alpha.as_slice()), "{what}");
                assert_eq!(bits(&a[at..at + 3]), bits(la.a.as_slice()), "{what}");
                let rows = acc.world_from_link(i, id).to_rows().concat();
                assert_eq!(
                    bits(&poses[16 * (i * l + k)..][..16]),
                    bits(&rows),
                    "{what}"
                );
            }
        }
        assert!(matches!(
            acc.write_accelerations(&ids, &mut al, &mut a[1..]),
            Err(StateError::OutputLength { .. })
        ));
        assert!(
            acc.velocities()
                .write_velocities(&ids, &mut w[1..], &mut v)
                .is_err()
        );
    }
}
