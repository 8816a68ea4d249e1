//! Batches written into a caller's arrays (`kinechain::eval::batch::arrays`): the values of
//! single evaluations bit for bit in the C-ordered layout, on the calling thread and on a pool,
//! in blocks of every size; wrong lengths, bad configurations, overflowing results and an
//! interrupt are errors that name what they are about.

use crate::common::*;
use kinechain::eval::batch::arrays::{
    ArrayError, Interrupt, LinkArrays, LinkSelection, Motion, Overflow, Uninterrupted, Workers,
    write_jacobian_batch, write_link_batch,
};
use kinechain::{
    Chain, Data, JacobianFrame, LimitPolicy, forward_accelerations, forward_kinematics,
};

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

/// Outputs of `n` configurations of `l` links at `level` (0 poses, 1 velocities, 2
/// accelerations), filled with a value the evaluation never writes.
fn outputs(n: usize, l: usize, level: usize) -> (Vec<f64>, [Vec<f64>; 4]) {
    let rate = |k: usize| vec![f64::NAN; if k < 2 * level { n * l * 3 } else { 0 }];
    (
        vec![f64::NAN; n * l * 16],
        [rate(0), rate(1), rate(2), rate(3)],
    )
}

fn arrays<'a>(poses: &'a mut [f64], rates: &'a mut [Vec<f64>; 4]) -> LinkArrays<'a> {
    let [a, b, c, d] = rates;
    LinkArrays {
        poses,
        rates: [a, b, c, d],
    }
}

#[test]
fn written_arrays_are_single_evaluations_bit_for_bit() {
    let pool = pool(2);
    // 4 100 configurations: several blocks of every kind (512 with rates, 2 048 for one link),
    // the last one partial.
    let n = 4_100;
    for file in [
        "robots/panda.urdf",
        "robots/ur5.yaml",
        "robots/stanford.yaml",
    ] {
        let chain = repo_chain(file);
        let dof = chain.dof();
        let mut rng = rng(3);
        let qs: Vec<f64> = (0..n).flat_map(|_| random_q(&chain, &mut rng)).collect();
        let qds = random_vec(n * dof, 2.0, &mut rng);
        let qdds = random_vec(n * dof, 5.0, &mut rng);
        let every = link_ids(&chain);
        let last = *every.last().unwrap();
        let mut single = Data::new(&chain);
        for ids in [every.clone(), vec![last], vec![last, every[1], last]] {
            let links = LinkSelection::new(&chain, ids.clone());
            let l = ids.len();
            for level in 0..3 {
                let motion = Motion {
                    q: &qs,
                    qd: (level >= 1).then_some(&qds[..]),
                    qdd: (level == 2).then_some(&qdds[..]),
                };
                for workers in [Workers::Here, Workers::Pool(&pool)] {
                    let (mut poses, mut rates) = outputs(n, l, level);
                    write_link_batch(
                        &chain,
                        LimitPolicy::Enforce,
                        motion,
                        n,
                        &links,
                        arrays(&mut poses, &mut rates),
                        workers,
                        &mut Uninterrupted,
                    )
                    .unwrap();
                    for i in (0..n).step_by(37).chain([n - 1]) {
                        let row = i * dof..(i + 1) * dof;
                        let a = forward_accelerations(
                            &chain,
                            &mut single,
                            &qs[row.clone()],
                            &qds[row.clone()],
                            &qdds[row],
                        )
                        .unwrap();
                        for (k, &id) in ids.iter().enumerate() {
                            let m = &poses[(i * l + k) * 16..(i * l + k + 1) * 16];
                            assert_eq!(
                                m,
                                a.world_from_link(id).to_rows().as_flattened(),
                                "{file} {i} {k} {level}"
                            );
                            let want = [
                                a.velocity(id).omega,
                                a.velocity(id).v,
                                a.acceleration(id).alpha,
                                a.acceleration(id).a,
                            ];
                            for (r, w) in rates.iter().zip(want).take(2 * level) {
                                assert_eq!(
                                    &r[(i * l + k) * 3..(i * l + k + 1) * 3],
                                    w.as_slice(),
                                    "{file} {i} {k} {level}"
                                );
                            }
                        }
                    }
                    assert!(
                        poses.iter().all(|x| !x.is_nan()),
                        "{file}: every entry written"
                    );
                }
            }
        }
    }
}

#[test]
fn written_jacobians_are_single_evaluations_bit_for_bit() {
    let pool = pool(2);
    let chain = repo_chain("robots/panda.urdf");
    let (n, dof) = (1_100, chain.dof());
    let mut rng = rng(5);
    let qs: Vec<f64> = (0..n).flat_map(|_| random_q(&chain, &mut rng)).collect();
    let hand = chain.link_id("panda_hand").unwrap();
    let mut single = Data::new(&chain);
    for frame in [JacobianFrame::World, JacobianFrame::Link] {
        for workers in [Workers::Here, Workers::Pool(&pool)] {
            let mut out = vec![f64::NAN; n * 6 * dof];
            write_jacobian_batch(
                &chain,
                LimitPolicy::Enforce,
                &qs,
                n,
                hand,
                frame,
                &mut out,
                workers,
                &mut Uninterrupted,
            )
            .unwrap();
            for i in [0, 511, 512, 1_099] {
                let j = forward_kinematics(&chain, &mut single, &qs[i * dof..(i + 1) * dof])
                    .unwrap()
                    .jacobian_in(hand, frame);
                for r in 0..6 {
                    for c in 0..dof {
                        assert_eq!(out[i * 6 * dof + r * dof + c], j[(r, c)], "{i} {r} {c}");
                    }
                }
            }
        }
    }
}

#[test]
fn the_lowest_bad_configuration_is_the_error_on_any_workers() {
    let pool = pool(2);
    let chain = repo_chain("robots/ur5.yaml");
    let n = 5_000;
    let mut qs = vec![0.1; n * 6];
    // Out of limits in a late block and an early one; not finite in between.
    qs[4_900 * 6 + 2] = 100.0;
    qs[1_234 * 6 + 1] = 100.0;
    qs[3_000 * 6] = f64::NAN;
    let links = LinkSelection::all(&chain);
    for workers in [Workers::Here, Workers::Pool(&pool)] {
        let (mut poses, mut rates) = outputs(n, links.ids().len(), 0);
        let motion = Motion {
            q: &qs,
            qd: None,
            qdd: None,
        };
        let e = write_link_batch(
            &chain,
            LimitPolicy::Enforce,
            motion,
            n,
            &links,
            arrays(&mut poses, &mut rates),
            workers,
            &mut Uninterrupted,
        )
        .unwrap_err();
        assert!(matches!(e, ArrayError::State { index: 1_234, .. }), "{e:?}");
        let text = kinechain::error::error_chain(&e);
        assert!(text.starts_with("configuration 1234: joint"), "{text}");
    }
}

#[test]
fn results_that_overflow_name_the_configuration_the_quantity_and_the_link() {
    let chain = Chain::from_dh_yaml_str(
        "name: slides\nconvention: standard\njoints:\n\
         - {name: j1, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0}\n\
         - {name: j2, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0}\n",
    )
    .unwrap();
    let pool = pool(2);
    let n = 3_000;
    let mut qs = vec![0.0; 2 * n];
    qs[2 * 2_500..2 * 2_501].copy_from_slice(&[1e308, 1e308]);
    let qds = qs.iter().map(|_| 0.0).collect::<Vec<_>>();
    let mut qds_big = qds.clone();
    qds_big[2 * 7..2 * 8].copy_from_slice(&[1e308, 1e308]);
    let link2 = chain.link_id("link2").unwrap();
    let zeros = vec![0.0; 2 * n];
    for workers in [Workers::Here, Workers::Pool(&pool)] {
        for ids in [vec![link2], link_ids(&chain)] {
            let links = LinkSelection::new(&chain, ids);
            let l = links.ids().len();
            let cases: [(Motion<'_>, usize, &str, usize); 2] = [
                (
                    Motion {
                        q: &qs,
                        qd: None,
                        qdd: None,
                    },
                    0,
                    "pose",
                    2_500,
                ),
                (
                    Motion {
                        q: &zeros,
                        qd: Some(&qds_big),
                        qdd: None,
                    },
                    1,
                    "v",
                    7,
                ),
            ];
            for (motion, level, what, index) in cases {
                let (mut poses, mut rates) = outputs(n, l, level);
                let e = write_link_batch(
                    &chain,
                    LimitPolicy::Enforce,
                    motion,
                    n,
                    &links,
                    arrays(&mut poses, &mut rates),
                    workers,
                    &mut Uninterrupted,
                )
                .unwrap_err();
                assert_eq!(
                    e,
                    ArrayError::NotFinite {
                        index,
                        source: Overflow::new(what, "link2")
                    },
                    "{l} links"
                );
            }
        }
    }
}

#[test]
fn wrong_lengths_are_errors_before_anything_is_written() {
    let chain = repo_chain("robots/ur5.yaml");
    let links = LinkSelection::all(&chain);
    let l = links.ids().len();
    let qs = vec![0.1; 10 * 6];
    let check = |motion: Motion<'_>, n: usize, level: usize, short: Option<usize>| {
        let (mut poses, mut rates) = outputs(10, l, level);
        match short {
            Some(0) => {
                poses.pop();
            }
            Some(k) => {
                rates[k - 1].pop();
            }
            None => {}
        }
        let e = write_link_batch(
            &chain,
            LimitPolicy::Enforce,
            motion,
            n,
            &links,
            arrays(&mut poses, &mut rates),
            Workers::Here,
            &mut Uninterrupted,
        )
        .unwrap_err();
        assert!(poses.iter().all(|x| x.is_nan()), "nothing written");
        e
    };
    let q = |q| Motion {
        q,
        qd: None,
        qdd: None,
    };
    let e = check(q(&qs[1..]), 10, 0, None);
    assert_eq!(e.to_string(), "q has 59 entries, the batch needs 60");
    let e = check(q(&qs), 10, 0, Some(0));
    assert_eq!(
        e.to_string(),
        format!(
            "poses has {} entries, the batch needs {}",
            10 * l * 16 - 1,
            10 * l * 16
        )
    );
    let with_rates = Motion {
        q: &qs,
        qd: Some(&qs),
        qdd: None,
    };
    let e = check(with_rates, 10, 1, Some(2));
    assert!(e.to_string().starts_with("v has "), "{e}");
    let e = check(
        Motion {
            q: &qs,
            qd: Some(&qs[2..]),
            qdd: None,
        },
        10,
        1,
        None,
    );
    assert!(e.to_string().starts_with("qd has 58 entries"), "{e}");
    // Velocity outputs for a batch of poses alone.
    let e = check(q(&qs), 10, 1, None);
    assert!(e.to_string().starts_with("omega has "), "{e}");
    let fixed = Chain::from_urdf_str(
        r#"<robot name="r"><link name="a"/><link name="b"/>
           <joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint></robot>"#,
    )
    .unwrap();
    let e = write_jacobian_batch(
        &fixed,
        LimitPolicy::Enforce,
        &[],
        3,
        fixed.link_id("b").unwrap(),
        JacobianFrame::World,
        &mut [],
        Workers::Here,
        &mut Uninterrupted,
    )
    .unwrap_err();
    assert!(matches!(e, ArrayError::NoDegreesOfFreedom(_)), "{e:?}");
}

/// Stops at once.
struct Now(usize);

impl Interrupt for Now {
    fn interrupted(&mut self) -> bool {
        self.0 += 1;
        true
    }
    fn interval(&self) -> std::time::Duration {
        std::time::Duration::ZERO
    }
}

#[test]
fn an_interrupt_stops_the_batch() {
    let pool = pool(2);
    let chain = repo_chain("robots/snake50.yaml");
    let n = 40_000;
    let qs = vec![0.01; n * chain.dof()];
    let links = LinkSelection::all(&chain);
    for workers in [Workers::Here, Workers::Pool(&pool)] {
        let (mut poses, mut rates) = outputs(n, links.ids().len(), 0);
        let mut now = Now(0);
        let e = write_link_batch(
            &chain,
            LimitPolicy::Enforce,
            Motion {
                q: &qs,
                qd: None,
                qdd: None,
            },
            n,
            &links,
            arrays(&mut poses, &mut rates),
            workers,
            &mut now,
        )
        .unwrap_err();
        assert_eq!(e, ArrayError::Interrupted);
        assert_eq!(now.0, 1, "asked once");
        // The run stopped early: the last block was never written.
        assert!(poses[poses.len() - 16..].iter().all(|x| x.is_nan()));
    }
}

#[test]
fn a_finiteness_check_reads_the_links_without_a_selected_link_below() {
    let chain = repo_chain("robots/panda.urdf");
    let all = LinkSelection::all(&chain);
    // A non-finite entry in a link that is not watched (the base) is still found, from the
    // links below it, which it makes non-finite too; here the poses are made up so that only
    // the base is not finite: the check then passes, which is why only the leaves are read.
    let l = all.ids().len();
    let mut poses = vec![0.0; 16 * l];
    poses[3] = f64::INFINITY;
    assert!(all.check_finite(&chain, 0, &poses, &[]).is_ok());
    let parents: std::collections::HashSet<_> = chain.joints().iter().map(|j| j.parent()).collect();
    let leaf = (0..l).find(|&k| !parents.contains(&all.ids()[k])).unwrap();
    poses[16 * leaf + 7] = f64::NAN;
    let e = all.check_finite(&chain, 5, &poses, &[]).unwrap_err();
    // The first non-finite pose is named.
    assert_eq!(
        e,
        ArrayError::NotFinite {
            index: 5,
            source: Overflow::new("pose", chain.links()[0].name())
        }
    );
}
