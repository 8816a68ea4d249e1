//! Batched velocities and accelerations: every body's frame and motion for eight configurations
//! per pass, the rate recursion of the single-configuration kernels on lanes
//! ([`super::lane_rates`]), so that every result equals [`forward_velocities`] /
//! [`forward_accelerations`] of the same configuration bit for bit.
//!
//! [`forward_velocities`]: crate::forward_velocities
//! [`forward_accelerations`]: crate::forward_accelerations

use crate::eval::batch::blocks::chunk_frames;
use crate::eval::batch::data::{BatchData, BatchError, Pair};
use crate::eval::batch::poses::BatchPoses;
use crate::eval::batch::threads::{TASK_WORK, worth_parallel};
use crate::eval::checks::check_values;
use crate::eval::error::StateError;
use crate::eval::kernel::frame::{Frame, V3};
use crate::eval::kernel::rates_lanes::{Motion, body_motion};
use crate::eval::layout::body::Placement;
use crate::eval::layout::chain::Chain;
use crate::eval::link_rates::{
    LinkAcceleration, LinkVelocity, link_acceleration, link_velocity, offset_in_world,
};
use crate::eval::simd::isa::fma_dispatch;
use crate::eval::simd::lanes::{LANES, Lanes};
use crate::eval::simd::traits::{Arith, LaneNum, Num};
use crate::model::chain::LinkId;
use crate::model::transform::Transform;

/// The frames and motions of one chunk's bodies (`q`, `q̇`, `q̈` transposed into lanes as
/// [`LaneNum::transpose`] writes them); α and a only when `ACC`.
///
/// The frames first, by the batch of poses' own kernel, then the motions body by body, reading
/// the frames back from the first-level cache (a chunk's frames are 768 bytes per body). Fused
/// into one pass, a frame, its parent's and the motions held at once overflowed the registers
/// and spilled at every body: UR5 41.4 ns per configuration with velocities, 52.2 with
/// accelerations, against 18.6 for poses alone (AVX-512, Intel family 6 model 167).
#[inline(always)]
fn chunk_motion<A: Arith, const ACC: bool>(
    chain: &Chain,
    frames: &mut [Frame<Lanes>],
    velocities: &mut [Pair],
    accelerations: &mut [Pair],
    [q, qd, qdd]: [&[Lanes]; 3],
) {
    type N<A> = <A as Arith>::Lanes;
    chunk_frames::<A, false>(chain, frames, q, &mut []);
    let nv = chain.nv();
    let (qd, qdd) = (N::<A>::cast(qd), N::<A>::cast(qdd));
    for part in 0..N::<A>::PARTS {
        let span = part * nv..(part + 1) * nv;
        let (qdp, qddp) = (&qd[span.clone()], &qdd[span]);
        let mut prev = Motion::zero();
        for (k, body) in chain.bodies.iter().enumerate() {
            let f = Frame::<N<A>>::get(&frames[k], part);
            let m = match body.parent {
                Some(p) => {
                    let parent_motion = if body.follows_previous {
                        prev
                    } else {
                        let [omega, v] = velocities[p].get(part);
                        let [alpha, a] = if ACC {
                            accelerations[p].get(part)
                        } else {
                            [[N::<A>::splat(0.0); 3]; 2]
                        };
                        Motion { omega, v, alpha, a }
                    };
                    let parent = Frame::get(&frames[p], part);
                    body_motion::<N<A>, A, ACC>(
                        Some((&parent, &parent_motion)),
                        body,
                        &f,
                        qdp,
                        qddp,
                    )
                }
                // A floating joint's body: its rates are the first entries of q̇ and q̈.
                None if body.floating => {
                    let three = |x: &[N<A>], i: usize| [x[i], x[i + 1], x[i + 2]];
                    let zero = [N::<A>::splat(0.0); 3];
                    Motion {
                        omega: three(qdp, 3),
                        v: three(qdp, 0),
                        alpha: if ACC { three(qddp, 3) } else { zero },
                        a: if ACC { three(qddp, 0) } else { zero },
                    }
                }
                None => body_motion::<N<A>, A, ACC>(None, body, &f, qdp, qddp),
            };
            velocities[k].put([m.omega, m.v], part);
            if ACC {
                accelerations[k].put([m.alpha, m.a], part);
            }
            prev = m;
        }
    }
}

/// Chunk `c` of the batch (`rows[i]` the row-major inputs `q`, `q̇` and, for accelerations, `q̈`)
/// into one chunk's `frames`, `velocities` and (when `accelerations` is not empty)
/// `accelerations`, `lanes` holding the transposed inputs.
#[inline(always)]
fn chunk_generic<A: Arith>(
    chain: &Chain,
    rows: [&[f64]; 3],
    c: usize,
    lanes: &mut [Lanes],
    frames: &mut [Frame<Lanes>],
    velocities: &mut [Pair],
    accelerations: &mut [Pair],
) {
    let (nq, nv) = (chain.nq(), chain.nv());
    let n = rows[0].len() / nq;
    let which: [usize; LANES] = std::array::from_fn(|l| (c * LANES + l).min(n - 1));
    let acc = !accelerations.is_empty();
    let (q, rest) = lanes.split_at_mut(nq);
    let (qd, qdd) = rest.split_at_mut(nv);
    for (x, out) in rows.iter().zip([q, qd, &mut qdd[..nv]]) {
        if !x.is_empty() {
            A::Lanes::transpose(out, x, which);
        }
    }
    let (q, rest) = lanes.split_at(nq);
    let (qd, qdd) = rest.split_at(nv);
    if acc {
        chunk_motion::<A, true>(chain, frames, velocities, accelerations, [q, qd, qdd]);
    } else {
        chunk_motion::<A, false>(chain, frames, velocities, accelerations, [q, qd, qd]);
    }
}

fma_dispatch!(fn chunk(chain: &Chain, rows: [&[f64]; 3], c: usize, lanes: &mut [Lanes], frames: &mut [Frame<Lanes>], velocities: &mut [Pair], accelerations: &mut [Pair]) => chunk_generic);

/// Checks a batch's `q̇` or `q̈` (`values`, named `what`) against the `n` configurations of its
/// `q`: one row per configuration, every entry finite.
pub(crate) fn check_rates(
    chain: &Chain,
    values: &[f64],
    what: &'static str,
    n: usize,
) -> Result<(), BatchError> {
    let nv = chain.nv();
    if values.len() != n * nv {
        return Err(BatchError {
            index: (values.len() / nv).min(n),
            source: StateError::WrongRows {
                what,
                rows: n,
                dof: nv,
                got: values.len(),
            },
        });
    }
    if !values.iter().all(|x| x.is_finite()) {
        for (index, row) in values.chunks_exact(nv).enumerate() {
            check_values(chain, row, what).map_err(|source| BatchError { index, source })?;
        }
    }
    Ok(())
}

/// Evaluates the batch into `data` (α and a when `qdds` is given), on rayon's pool when
/// `parallel` and the batch is worth it.
pub(crate) fn evaluate(
    chain: &Chain,
    data: &mut BatchData,
    qs: &[f64],
    qds: &[f64],
    qdds: Option<&[f64]>,
    parallel: bool,
) -> Result<(), BatchError> {
    let chunks = data.prepare(chain, qs, true)?;
    let n = data.len;
    check_rates(chain, qds, "q_dot", n)?;
    if let Some(qdds) = qdds {
        check_rates(chain, qdds, "q_ddot", n)?;
    }
    let bodies = chain.bodies.len();
    let size = data.size_frames(chunks);
    data.velocities.resize(size, Pair::ZERO);
    let acc_size = if qdds.is_some() { size } else { 0 };
    data.accelerations
        .resize(acc_size.max(data.accelerations.len()), Pair::ZERO);
    if n == 0 || bodies == 0 {
        return Ok(());
    }
    let rows = [qs, qds, qdds.unwrap_or_default()];
    let frames = &mut data.frames[..size];
    let velocities = &mut data.velocities[..size];
    let accelerations = &mut data.accelerations[..acc_size];
    let nq = chain.nq();
    if parallel && worth_parallel(qs, nq, bodies) {
        use rayon::prelude::*;
        let min_len = TASK_WORK.div_ceil(LANES * bodies);
        let scratch = || vec![Lanes::splat(0.0); nq + 2 * chain.nv()];
        let pieces = frames
            .par_chunks_mut(bodies)
            .zip(velocities.par_chunks_mut(bodies))
            .enumerate()
            .with_min_len(min_len);
        if acc_size > 0 {
            pieces
                .zip(accelerations.par_chunks_mut(bodies))
                .for_each_init(scratch, |lanes, ((c, (f, v)), a)| {
                    chunk(chain, rows, c, lanes, f, v, a);
                });
        } else {
            pieces.for_each_init(scratch, |lanes, (c, (f, v))| {
                chunk(chain, rows, c, lanes, f, v, &mut []);
            });
        }
    } else {
        let lanes = &mut data.rate_lanes;
        for (c, (f, v)) in frames
            .chunks_exact_mut(bodies)
            .zip(velocities.chunks_exact_mut(bodies))
            .enumerate()
        {
            let a = if acc_size > 0 {
                &mut accelerations[c * bodies..(c + 1) * bodies]
            } else {
                &mut []
            };
            chunk(chain, rows, c, lanes, f, v, a);
        }
    }
    Ok(())
}

/// Poses and velocities of every link for each configuration of a batch.
#[derive(Clone, Copy, Debug)]
pub struct BatchVelocities<'a> {
    chain: &'a Chain,
    data: &'a BatchData,
}

/// Poses, velocities and accelerations of every link for each configuration of a batch.
#[derive(Clone, Copy, Debug)]
pub struct BatchAccelerations<'a> {
    chain: &'a Chain,
    data: &'a BatchData,
}

batch_len!(BatchVelocities, BatchAccelerations);

/// The body carrying `link`, its frame and the link's offset from it in world axes, in
/// configuration `index` of `data` (`None` for a link fixed to the world).
#[inline]
fn carrier(
    chain: &Chain,
    data: &BatchData,
    index: usize,
    link: LinkId,
) -> Option<(usize, [f64; 3])> {
    assert!(index < data.len, "configuration {index} of {}", data.len);
    let l = chain.carrier(link);
    let b = l.body?;
    let f = &data.frames[(index / LANES) * data.bodies + b];
    let lane = index % LANES;
    let body = Transform {
        r: f.r.map(|c| c.map(|x| x.0[lane])),
        p: f.p.map(|x| x.0[lane]),
    };
    Some((b, offset_in_world(&body, &l.offset)))
}

/// `[ω, v]` of `link` in configuration `index`.
#[inline]
pub(crate) fn velocity(
    chain: &Chain,
    data: &BatchData,
    index: usize,
    link: LinkId,
) -> LinkVelocity {
    match carrier(chain, data, index, link) {
        None => link_velocity([0.0; 3], [0.0; 3], [0.0; 3]),
        Some((b, r)) => {
            let [omega, v] = data.velocities[(index / LANES) * data.bodies + b].lane(index % LANES);
            link_velocity(omega, v, r)
        }
    }
}

impl BatchVelocities<'_> {
    /// The poses of the same evaluation (for [`BatchPoses::write_matrices`]).
    #[must_use]
    pub fn poses(&self) -> BatchPoses<'_> {
        BatchPoses {
            chain: self.chain,
            data: self.data,
        }
    }

    /// Pose of `link` in configuration `index`, world frame.
    ///
    /// # Panics
    /// If `index >= self.len()` or `link` comes from another chain.
    #[must_use]
    #[inline]
    pub fn world_from_link(&self, index: usize, link: LinkId) -> Transform {
        BatchPoses {
            chain: self.chain,
            data: self.data,
        }
        .world_from_link(index, link)
    }

    /// Angular velocity of `link` and linear velocity of its origin in configuration `index`,
    /// world frame (as [`Velocities::velocity`](crate::Velocities::velocity)).
    ///
    /// # Panics
    /// If `index >= self.len()` or `link` comes from another chain.
    #[must_use]
    #[inline]
    pub fn velocity(&self, index: usize, link: LinkId) -> LinkVelocity {
        velocity(self.chain, self.data, index, link)
    }
}

/// `a × b` on lanes, entry for entry [`cross3`](crate::model::transform::cross3).
#[inline(always)]
fn cross<N: Num>(a: V3<N>, b: V3<N>) -> V3<N> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline(always)]
fn plus<N: Num>(a: V3<N>, b: V3<N>) -> V3<N> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `[ω, v]` (`ACC` false) or `[α, a]` of each of `links` in every configuration of `data`, into
/// `outs` (each `N × links.len() × 3`): the body's motion carried to the link's origin on the
/// lanes of a chunk, in the operations of [`link_velocity`] / [`link_acceleration`] (and
/// [`offset_in_world`] for the origin), so the same bits.
#[inline(always)]
fn write_rates_generic<A: Arith, const ACC: bool>(
    chain: &Chain,
    data: &BatchData,
    links: &[LinkId],
    [first, second]: [&mut [f64]; 2],
) {
    type N<A> = <A as Arith>::Lanes;
    let (n, l) = (data.len, links.len());
    let zero = N::<A>::splat(0.0);
    for c in 0..n.div_ceil(LANES) {
        let count = (n - c * LANES).min(LANES);
        for (k, &link) in links.iter().enumerate() {
            let carrier = chain.carrier(link);
            let mut out = Pair::ZERO;
            if let Some(b) = carrier.body {
                let at = c * data.bodies + b;
                let u = match carrier.offset {
                    Placement::Identity => None,
                    offset => Some(offset.to_transform().p),
                };
                for part in 0..N::<A>::PARTS {
                    let f = Frame::<N<A>>::get(&data.frames[at], part);
                    let r = u.map_or([zero; 3], |u| crate::eval::kernel::frame::rotate(&f.r, u));
                    let [w, v] = data.velocities[at].get::<N<A>>(part);
                    let pair = if ACC {
                        let [al, a] = data.accelerations[at].get::<N<A>>(part);
                        [al, plus(a, plus(cross(al, r), cross(w, cross(w, r))))]
                    } else {
                        [w, plus(v, cross(w, r))]
                    };
                    out.put(pair, part);
                }
            }
            for lane in 0..count {
                let i = (c * LANES + lane) * l + k;
                for (o, x) in [&mut *first, &mut *second].into_iter().zip(&out.0) {
                    o[3 * i..3 * i + 3].copy_from_slice(&[
                        x[0].0[lane],
                        x[1].0[lane],
                        x[2].0[lane],
                    ]);
                }
            }
        }
    }
}

#[inline(always)]
fn write_velocities_generic<A: Arith>(
    chain: &Chain,
    data: &BatchData,
    links: &[LinkId],
    outs: [&mut [f64]; 2],
) {
    write_rates_generic::<A, false>(chain, data, links, outs);
}

#[inline(always)]
fn write_accelerations_generic<A: Arith>(
    chain: &Chain,
    data: &BatchData,
    links: &[LinkId],
    outs: [&mut [f64]; 2],
) {
    write_rates_generic::<A, true>(chain, data, links, outs);
}

fma_dispatch!(fn write_velocities(chain: &Chain, data: &BatchData, links: &[LinkId], outs: [&mut [f64]; 2]) => write_velocities_generic);

fma_dispatch!(fn write_accelerations(chain: &Chain, data: &BatchData, links: &[LinkId], outs: [&mut [f64]; 2]) => write_accelerations_generic);

/// [`StateError::OutputLength`] unless each of `outs` holds `N × links × 3` entries.
fn check_rate_outputs(
    data: &BatchData,
    links: &[LinkId],
    outs: [&[f64]; 2],
) -> Result<(), StateError> {
    let expected = 3 * links.len() * data.len;
    match outs.iter().find(|o| o.len() != expected) {
        Some(o) => Err(StateError::OutputLength {
            expected,
            got: o.len(),
        }),
        None => Ok(()),
    }
}

impl BatchVelocities<'_> {
    /// Writes ω and the origin's v of each of `links` in every configuration (world frame):
    /// configuration `i`'s vectors start at `3 · links.len() · i` of `omega` and `v`, link
    /// `k`'s three entries after `3 k` more (C-ordered `(N, links.len(), 3)` arrays). The
    /// entries are those of [`velocity(i, link)`](BatchVelocities::velocity) bit for bit,
    /// carried to the links eight configurations at a time.
    ///
    /// # Errors
    /// [`StateError::OutputLength`] when `omega` or `v` does not have `3 · links.len() ·
    /// self.len()` entries (nothing is written then).
    ///
    /// # Panics
    /// If a link comes from another chain with more links.
    pub fn write_velocities(
        &self,
        links: &[LinkId],
        omega: &mut [f64],
        v: &mut [f64],
    ) -> Result<(), StateError> {
        check_rate_outputs(self.data, links, [omega, v])?;
        write_velocities(self.chain, self.data, links, [omega, v]);
        Ok(())
    }
}

impl BatchAccelerations<'_> {
    /// Writes α and the origin's classical acceleration a of each of `links` in every
    /// configuration, in the layout of [`BatchVelocities::write_velocities`]; the entries are
    /// those of [`acceleration(i, link)`](BatchAccelerations::acceleration) bit for bit.
    ///
    /// # Errors
    /// [`StateError::OutputLength`] when `alpha` or `a` does not have `3 · links.len() ·
    /// self.len()` entries.
    ///
    /// # Panics
    /// If a link comes from another chain with more links.
    pub fn write_accelerations(
        &self,
        links: &[LinkId],
        alpha: &mut [f64],
        a: &mut [f64],
    ) -> Result<(), StateError> {
        check_rate_outputs(self.data, links, [alpha, a])?;
        write_accelerations(self.chain, self.data, links, [alpha, a]);
        Ok(())
    }
}

impl BatchAccelerations<'_> {
    /// The poses and velocities of the same evaluation.
    #[must_use]
    pub fn velocities(&self) -> BatchVelocities<'_> {
        BatchVelocities {
            chain: self.chain,
            data: self.data,
        }
    }

    /// Pose of `link` in configuration `index`, world frame.
    ///
    /// # Panics
    /// If `index >= self.len()` or `link` comes from another chain.
    #[must_use]
    #[inline]
    pub fn world_from_link(&self, index: usize, link: LinkId) -> Transform {
        self.velocities().world_from_link(index, link)
    }

    /// As [`BatchVelocities::velocity`].
    ///
    /// # Panics
    /// If `index >= self.len()` or `link` comes from another chain.
    #[must_use]
    #[inline]
    pub fn velocity(&self, index: usize, link: LinkId) -> LinkVelocity {
        velocity(self.chain, self.data, index, link)
    }

    /// Angular acceleration of `link` and classical acceleration of its origin in configuration
    /// `index`, world frame (as [`Accelerations::acceleration`](crate::Accelerations::acceleration)).
    ///
    /// # Panics
    /// If `index >= self.len()` or `link` comes from another chain.
    #[must_use]
    #[inline]
    pub fn acceleration(&self, index: usize, link: LinkId) -> LinkAcceleration {
        match carrier(self.chain, self.data, index, link) {
            None => link_acceleration([[0.0; 3]; 3], [0.0; 3]),
            Some((b, r)) => {
                let k = (index / LANES) * self.data.bodies + b;
                let [omega, _] = self.data.velocities[k].lane(index % LANES);
                let [alpha, a] = self.data.accelerations[k].lane(index % LANES);
                link_acceleration([omega, alpha, a], r)
            }
        }
    }
}

/// Poses and velocities (ω, and v of the origin) of every link for each configuration of `qs`,
/// with joint rates `qds` (both row-major, `dof` entries per configuration), on the calling
/// thread: the same, bit for bit, as [`forward_velocities`](crate::forward_velocities) of each
/// configuration.
///
/// Kept per body and configuration: 96 bytes of frame and 48 of velocities.
///
/// # Errors
/// As [`forward_kinematics_batch`](crate::eval::batch::forward_kinematics_batch), and [`StateError::WrongRows`] when `qds` does not hold one
/// row per configuration, [`StateError::NonFinite`] naming the configuration and joint of a
/// non-finite rate.
///
/// # Panics
/// If `data` was created for another chain.
///
/// # Examples
/// ```
/// use kinechain::{Chain, eval::batch::{BatchData, forward_velocities_batch}};
/// let chain = Chain::from_file("robots/planar3.yaml")?; // links of 4, 3 and 2 m
/// let mut data = BatchData::new(&chain);
/// let qs = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
/// let qds = [1.0, 0.0, 0.0, 0.0, 0.0, 2.0]; // first joint turning, then the last one
/// let rates = forward_velocities_batch(&chain, &mut data, &qs, &qds)?;
/// let tip = chain.link_id("link3")?;
/// approx::assert_relative_eq!(rates.velocity(0, tip).v.y, 9.0);
/// approx::assert_relative_eq!(rates.velocity(1, tip).v.y, 4.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn forward_velocities_batch<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    qds: &[f64],
) -> Result<BatchVelocities<'a>, BatchError> {
    evaluate(chain, data, qs, qds, None, false)?;
    Ok(BatchVelocities { chain, data })
}

/// As [`forward_velocities_batch`], the batch shared between the calling thread and rayon's
/// pool (batches of fewer than [`PARALLEL_WORK`](crate::eval::batch::PARALLEL_WORK) joint evaluations stay on the calling thread).
/// The results are the same, bit for bit.
///
/// # Errors
/// As [`forward_velocities_batch`].
///
/// # Panics
/// As [`forward_velocities_batch`].
pub fn forward_velocities_batch_par<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    qds: &[f64],
) -> Result<BatchVelocities<'a>, BatchError> {
    evaluate(chain, data, qs, qds, None, true)?;
    Ok(BatchVelocities { chain, data })
}

/// Poses, velocities and accelerations (α, and the classical acceleration of the origin) of
/// every link for each configuration of `qs`, with joint rates `qds` and `qdds` (row-major), on
/// the calling thread: the same, bit for bit, as
/// [`forward_accelerations`](crate::forward_accelerations) of each configuration.
///
/// Kept per body and configuration: 96 bytes of frame and 96 of rates.
///
/// # Errors
/// As [`forward_velocities_batch`], for `qdds` too.
///
/// # Panics
/// If `data` was created for another chain.
pub fn forward_accelerations_batch<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    qds: &[f64],
    qdds: &[f64],
) -> Result<BatchAccelerations<'a>, BatchError> {
    evaluate(chain, data, qs, qds, Some(qdds), false)?;
    Ok(BatchAccelerations { chain, data })
}

/// As [`forward_accelerations_batch`], shared with rayon's pool as
/// [`forward_velocities_batch_par`] shares a batch. The results are the same, bit for bit.
///
/// # Errors
/// As [`forward_accelerations_batch`].
///
/// # Panics
/// As [`forward_accelerations_batch`].
pub fn forward_accelerations_batch_par<'a>(
    chain: &'a Chain,
    data: &'a mut BatchData,
    qs: &[f64],
    qds: &[f64],
    qdds: &[f64],
) -> Result<BatchAccelerations<'a>, BatchError> {
    evaluate(chain, data, qs, qds, Some(qdds), true)?;
    Ok(BatchAccelerations { chain, data })
}
