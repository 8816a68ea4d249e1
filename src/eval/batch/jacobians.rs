//! Batched Jacobians and their time derivatives: the batch kernels evaluate every body's frame
//! (and for `J̇` its velocity), then each configuration's columns are built from them by the
//! code single evaluations use ([`crate::eval::jacobian`]), so that every batched matrix equals
//! [`Poses::jacobian_in`](crate::Poses::jacobian_in) /
//! [`Velocities::jacobian_dot_in`](crate::Velocities::jacobian_dot_in) bit for bit.

use crate::eval::batch::blocks::transpose_chunk;
use crate::eval::batch::data::{BatchData, BatchError, LaneCheck, batch_rows, configurations};
use crate::eval::batch::poses::BatchPoses;
use crate::eval::batch::threads::worth_parallel;
use crate::eval::error::StateError;
use crate::eval::jacobian::{JacobianFrame, State};
use crate::eval::kernel::frame::{Frame, rotate};
use crate::eval::layout::body::Placement;
use crate::eval::layout::chain::Chain;
use crate::eval::simd::isa::fma_dispatch;
use crate::eval::simd::lanes::{LANES, Lanes};
use crate::eval::simd::traits::{Arith, LaneNum, Num};
use crate::model::chain::LinkId;
use crate::model::transform::Transform;

/// Configuration `index` of an evaluated batch, as the state a Jacobian is computed from.
struct Lane<'a> {
    chain: &'a Chain,
    data: &'a BatchData,
    index: usize,
}

impl Lane<'_> {
    #[inline(always)]
    fn slot(&self, b: usize) -> (usize, usize) {
        (
            (self.index / LANES) * self.data.bodies + b,
            self.index % LANES,
        )
    }
}

impl State for Lane<'_> {
    fn chain(&self) -> &Chain {
        self.chain
    }
    #[inline(always)]
    fn body_frame(&self, b: usize) -> Transform {
        let (k, lane) = self.slot(b);
        let f = &self.data.frames[k];
        Transform {
            r: f.r.map(|c| c.map(|x| x.0[lane])),
            p: f.p.map(|x| x.0[lane]),
        }
    }
    #[inline(always)]
    fn body_rates(&self, b: usize) -> [[f64; 3]; 2] {
        let (k, lane) = self.slot(b);
        self.data.velocities[k].0.map(|v| v.map(|x| x.0[lane]))
    }
    #[inline(always)]
    fn link_pose(&self, link: LinkId) -> Transform {
        BatchPoses {
            chain: self.chain,
            data: self.data,
        }
        .world_from_link(self.index, link)
    }
    #[inline(always)]
    fn link_rates(&self, link: LinkId) -> [[f64; 3]; 2] {
        let v = crate::eval::batch::rates::velocity(self.chain, self.data, self.index, link);
        [v.omega.into(), v.v.into()]
    }
}

/// The world Jacobian (or the one [`JacobianFrame`] names) of the link whose body path is
/// `path` and whose offset from its body is `offset`, for one chunk (`q` transposed into lanes),
/// into `columns` (6 × dof, row-major, lanes) and then `out` (each configuration's matrix after
/// the other's), with `axes` room for each path body's joint
/// origin and direction: the operations of [`crate::eval::jacobian::jacobian`] on lanes, so that each lane
/// holds the single evaluation's matrix bit for bit.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn chunk_jacobian_generic<A: Arith>(
    chain: &Chain,
    check: Option<LaneCheck<'_>>,
    path: &[usize],
    (offset, frame): (&Placement, JacobianFrame),
    (q, qs, c): (&mut [Lanes], &[f64], usize),
    axes: &mut [[[Lanes; 3]; 2]],
    (columns, out): (&mut [Lanes], &mut [f64]),
) -> bool {
    type N<A> = <A as Arith>::Lanes;
    let ok = transpose_chunk::<N<A>>(check, q, qs, c);
    let q = &*q;
    let (nq, dof) = (chain.nq(), chain.nv());
    columns.fill(Lanes::splat(0.0));
    let zero = N::<A>::splat(0.0);
    for (part, qp) in N::<A>::cast(q).chunks_exact(nq).enumerate() {
        let mut f = Frame::<N<A>>::splat(&Transform::IDENTITY);
        for (i, &k) in path.iter().enumerate() {
            let body = &chain.bodies[k];
            let sin_cos = crate::eval::kernel::joint::body_sin_cos::<N<A>, A>(body, qp);
            // The joint axis from the frame before the joint (`crate::eval::jacobian::axis_parts`).
            let (origin, z) = if i == 0 {
                (
                    body.pre_frame.p.map(|x| zero + N::<A>::splat(x)),
                    body.axis_in_parent.map(N::<A>::splat),
                )
            } else {
                let offset = rotate(&f.r, body.pre_frame.p);
                (
                    std::array::from_fn(|e| f.p[e] + offset[e]),
                    rotate(&f.r, body.axis_in_parent),
                )
            };
            for (slot, v) in axes[i].iter_mut().zip([origin, z]) {
                for (x, y) in slot.iter_mut().zip(v) {
                    y.put(x, part);
                }
            }
            f = if i == 0 {
                crate::eval::kernel::pose_lanes::root_step::<N<A>, A>(body, qp, sin_cos)
            } else {
                crate::eval::kernel::pose_lanes::pose_step::<N<A>, A>(Some(&f), body, qp, sin_cos)
            };
            if body.floating || body.ball.is_some_and(|b| b.free) {
                // Its turns are about the world axes through its own origin.
                for (x, y) in axes[i][0].iter_mut().zip(f.p) {
                    y.put(x, part);
                }
            }
        }
        crate::eval::kernel::frame::place::<N<A>, A>(&mut f, offset);
        let p: [N<A>; 3] = match frame {
            JacobianFrame::Point(u) => {
                let u = rotate(&f.r, u);
                std::array::from_fn(|e| f.p[e] + u[e])
            }
            _ => f.p,
        };
        for (i, &k) in path.iter().enumerate().rev() {
            let body = &chain.bodies[k];
            // The floating base's six columns are the first; another floating joint's its own.
            let free = match (body.floating, body.ball) {
                (true, _) => Some(0),
                (false, Some(ball)) if ball.free => Some(ball.v),
                _ => None,
            };
            if let Some(v) = free {
                // Six columns, written once (see `crate::eval::jacobian::path_columns`): a slide
                // along and a turn about each world axis.
                let origin = axes[i][0].map(|x| N::<A>::get(&x, part));
                let d: [N<A>; 3] = std::array::from_fn(|e| p[e] - origin[e]);
                let (one, zero) = (N::<A>::splat(1.0), N::<A>::splat(0.0));
                for k in 0..3 {
                    let z: [N<A>; 3] = std::array::from_fn(|e| if e == k { one } else { zero });
                    let turning = [
                        z[1] * d[2] - z[2] * d[1],
                        z[2] * d[0] - z[0] * d[2],
                        z[0] * d[1] - z[1] * d[0],
                    ];
                    let slide = [z[0], z[1], z[2], zero, zero, zero];
                    let turn = [turning[0], turning[1], turning[2], z[0], z[1], z[2]];
                    for (column, terms) in [(v + k, slide), (v + 3 + k, turn)] {
                        for (r, x) in terms.into_iter().enumerate() {
                            x.put(&mut columns[r * dof + column], part);
                        }
                    }
                }
                continue;
            }
            let [origin, z] = axes[i].map(|v| v.map(|x| N::<A>::get(&x, part)));
            let d: [N<A>; 3] = std::array::from_fn(|e| p[e] - origin[e]);
            if let Some(ball) = body.ball {
                // Three columns, written once: turns about the world axes through the joint
                // origin (see `crate::eval::jacobian::path_columns`).
                let (one, zero) = (N::<A>::splat(1.0), N::<A>::splat(0.0));
                for k in 0..3 {
                    let z: [N<A>; 3] = std::array::from_fn(|e| if e == k { one } else { zero });
                    let turn = [
                        z[1] * d[2] - z[2] * d[1],
                        z[2] * d[0] - z[0] * d[2],
                        z[0] * d[1] - z[1] * d[0],
                        z[0],
                        z[1],
                        z[2],
                    ];
                    for (r, x) in turn.into_iter().enumerate() {
                        x.put(&mut columns[r * dof + ball.v + k], part);
                    }
                }
                continue;
            }
            let turning = [
                z[1] * d[2] - z[2] * d[1],
                z[2] * d[0] - z[0] * d[2],
                z[0] * d[1] - z[1] * d[0],
            ];
            let turning = [turning[0], turning[1], turning[2], z[0], z[1], z[2]];
            let sliding = [z[0], z[1], z[2], zero, zero, zero];
            for (rate, terms) in [(body.theta_rate, turning), (body.d_rate, sliding)] {
                if rate.scale != 0.0 {
                    let scale = N::<A>::splat(rate.scale);
                    for (r, x) in terms.into_iter().enumerate() {
                        let c = &mut columns[r * dof + rate.index];
                        (N::<A>::get(c, part) + x * scale).put(c, part);
                    }
                }
            }
        }
        if frame == JacobianFrame::Link {
            for (half, c) in (0..2).flat_map(|h| (0..dof).map(move |c| (h, c))) {
                let at = |k: usize| (3 * half + k) * dof + c;
                let x: [N<A>; 3] = std::array::from_fn(|k| N::<A>::get(&columns[at(k)], part));
                for k in 0..3 {
                    let r = f.r[k];
                    (r[0] * x[0] + r[1] * x[1] + r[2] * x[2]).put(&mut columns[at(k)], part);
                }
            }
        }
    }
    write_lanes(columns, out);
    ok
}

fma_dispatch!(#[allow(clippy::too_many_arguments)] fn chunk_jacobian(chain: &Chain, check: Option<LaneCheck<'_>>, path: &[usize], kind: (&Placement, JacobianFrame), chunk: (&mut [Lanes], &[f64], usize), axes: &mut [[[Lanes; 3]; 2]], written: (&mut [Lanes], &mut [f64])) -> bool => chunk_jacobian_generic);

/// Writes lane `l` of every entry of `columns` as the `columns.len()` values of configuration
/// `l` in `out` (one chunk's configurations, each after the other; fewer than [`LANES`] in the
/// last chunk), configuration by configuration, in the order of `out`. (An 8 × 8 transposition of
/// eight entries at a time took longer: Panda 36.7 → 46.3 ns per configuration.)
#[inline(always)]
fn write_lanes(columns: &[Lanes], out: &mut [f64]) {
    for (l, rows) in out.chunks_exact_mut(columns.len()).enumerate() {
        for (y, x) in rows.iter_mut().zip(columns) {
            *y = x.0[l];
        }
    }
}

/// [`piece`] for `J`: the lane kernel chunk by chunk, each chunk's matrices written out
/// configuration by configuration.
fn piece_jacobian(
    chain: &Chain,
    data: &mut BatchData,
    qs: &[f64],
    link: LinkId,
    frame: JacobianFrame,
    out: &mut [f64],
) -> Result<(), BatchError> {
    let check = LaneCheck::of(chain, data.limit_policy);
    let chunks = data.prepare(chain, qs, check.is_none())?;
    let carrier = chain.carrier(link);
    chain.body_path(carrier.body, &mut data.path);
    let dof = chain.nv();
    data.axes
        .resize(data.path.len(), [[Lanes::splat(0.0); 3]; 2]);
    data.jacobian_lanes.resize(6 * dof, Lanes::splat(0.0));
    let q = &mut data.q_lanes[..chain.nq()];
    let mut all_ok = true;
    for (c, out) in out.chunks_mut(LANES * 6 * dof).enumerate().take(chunks) {
        all_ok &= chunk_jacobian(
            chain,
            check,
            &data.path,
            (&carrier.offset, frame),
            (&mut *q, qs, c),
            &mut data.axes,
            (&mut data.jacobian_lanes, out),
        );
    }
    if !all_ok {
        data.first_error(chain, qs)?;
    }
    Ok(())
}

/// Configurations per task of the parallel batches (a multiple of [`LANES`]).
const PIECE: usize = 512;

/// `J` (`qds` `None`) or `J̇` of `link` in `frame` for the configurations of `qs` into `out`
/// (row-major, 6 × dof per configuration), evaluated into `data`.
#[allow(clippy::too_many_arguments)]
fn piece(
    chain: &Chain,
    data: &mut BatchData,
    qs: &[f64],
    qds: Option<&[f64]>,
    link: LinkId,
    frame: JacobianFrame,
    out: &mut [f64],
) -> Result<(), BatchError> {
    match qds {
        None => return piece_jacobian(chain, data, qs, link, frame, out),
        Some(qds) => crate::eval::batch::rates::evaluate(chain, data, qs, qds, None, false)?,
    }
    let dof = chain.dof();
    let mut columns = std::mem::take(&mut data.jacobian);
    columns.resize(6 * dof, 0.0);
    for (index, rows) in out.chunks_exact_mut(6 * dof).enumerate() {
        let state = Lane { chain, data, index };
        crate::eval::jacobian::jacobian_dot(&state, link, frame, &mut columns);
        for (c, column) in columns.chunks_exact(6).enumerate() {
            for (r, &x) in column.iter().enumerate() {
                rows[r * dof + c] = x;
            }
        }
    }
    data.jacobian = columns;
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn run(
    chain: &Chain,
    data: &mut BatchData,
    qs: &[f64],
    qds: Option<&[f64]>,
    link: LinkId,
    frame: JacobianFrame,
    out: &mut [f64],
    parallel: bool,
) -> Result<(), BatchError> {
    let _ = chain.link(link);
    let dof = chain.dof();
    let n = configurations(chain, qs)?;
    if out.len() != n * 6 * dof {
        return Err(BatchError {
            index: 0,
            source: StateError::OutputLength {
                expected: n * 6 * dof,
                got: out.len(),
            },
        });
    }
    if !(parallel && n > PIECE && worth_parallel(qs, chain.nq(), chain.bodies.len())) {
        return piece(chain, data, qs, qds, link, frame, out);
    }
    // Checked here, so that an error names the first bad configuration of the whole batch.
    let policy = data.limit_policy;
    batch_rows(
        "BatchData",
        (data.bodies, data.dof),
        policy,
        chain,
        qs,
        true,
    )?;
    if let Some(qds) = qds {
        crate::eval::batch::rates::check_rates(chain, qds, "q_dot", n)?;
    }
    use rayon::prelude::*;
    let nq = chain.nq();
    out.par_chunks_mut(PIECE * 6 * dof)
        .enumerate()
        .try_for_each_init(
            || BatchData::new(chain).with_limit_policy(policy),
            |data, (k, out)| {
                let rows = |width: usize, len: usize| {
                    k * PIECE * width..((k + 1) * PIECE * width).min(len)
                };
                let qds = qds.map(|qds| &qds[rows(dof, qds.len())]);
                let qs = &qs[rows(nq, qs.len())];
                piece(chain, data, qs, qds, link, frame, out).map_err(|e| BatchError {
                    index: k * PIECE + e.index,
                    ..e
                })
            },
        )
}

/// The Jacobian of `link` in `frame` ([`JacobianFrame`]) for each configuration of `qs`
/// (row-major, `dof` entries per configuration), written into `out` as `N × 6 × dof` row-major
/// (configuration, then the rows `v` and `ω`, then one column per entry of `q`: the layout of a
/// C-ordered numpy array of shape `(N, 6, dof)`; configuration `i`'s matrix for nalgebra is
/// `Matrix6xX::from_row_slice(&out[6 * dof * i..6 * dof * (i + 1)])`). On the calling thread;
/// reusing `data` and `out`, it allocates nothing. Each matrix equals
/// [`Poses::jacobian_in`](crate::Poses::jacobian_in) of the configuration, bit for bit.
///
/// # Errors
/// As [`forward_kinematics_batch`](crate::eval::batch::forward_kinematics_batch), and [`StateError::OutputLength`] for an `out` of another
/// length than `N × 6 × dof`.
///
/// # Panics
/// If `data` was created for another chain, or `link` comes from another chain with more links.
///
/// # Examples
/// ```
/// use kinechain::{Chain, JacobianFrame, eval::batch::{BatchData, jacobian_batch}};
/// let chain = Chain::from_file("robots/planar3.yaml")?; // links of 4, 3 and 2 m
/// let mut data = BatchData::new(&chain);
/// let qs = [0.0, 0.0, 0.0, 1.5707963267948966, 0.0, 0.0];
/// let mut out = vec![0.0; 2 * 6 * 3];
/// jacobian_batch(&chain, &mut data, &qs, chain.link_id("link3")?, JacobianFrame::World, &mut out)?;
/// // Row v_y of the first configuration: every joint moves the tip along y.
/// assert_eq!(&out[3..6], &[9.0, 5.0, 2.0]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn jacobian_batch(
    chain: &Chain,
    data: &mut BatchData,
    qs: &[f64],
    link: LinkId,
    frame: JacobianFrame,
    out: &mut [f64],
) -> Result<(), BatchError> {
    run(chain, data, qs, None, link, frame, out, false)
}

/// As [`jacobian_batch`], in pieces of 512 configurations shared between the calling thread
/// and rayon's pool (each thread with buffers of its own; small batches stay on the calling
/// thread). The matrices are the same, bit for bit.
///
/// # Errors
/// As [`jacobian_batch`].
///
/// # Panics
/// As [`jacobian_batch`].
pub fn jacobian_batch_par(
    chain: &Chain,
    data: &mut BatchData,
    qs: &[f64],
    link: LinkId,
    frame: JacobianFrame,
    out: &mut [f64],
) -> Result<(), BatchError> {
    run(chain, data, qs, None, link, frame, out, true)
}

/// The time derivative `J̇` of [`jacobian_batch`]'s matrices at joint rates `qds` (row-major
/// like `qs`), in the same layout, so that `[a; α] = J q̈ + J̇ q̇` for each configuration. Each
/// matrix equals [`Velocities::jacobian_dot_in`](crate::Velocities::jacobian_dot_in) of the
/// configuration, bit for bit.
///
/// # Errors
/// As [`jacobian_batch`], and as [`forward_velocities_batch`](crate::eval::batch::forward_velocities_batch) for `qds`.
///
/// # Panics
/// As [`jacobian_batch`].
pub fn jacobian_dot_batch(
    chain: &Chain,
    data: &mut BatchData,
    qs: &[f64],
    qds: &[f64],
    link: LinkId,
    frame: JacobianFrame,
    out: &mut [f64],
) -> Result<(), BatchError> {
    run(chain, data, qs, Some(qds), link, frame, out, false)
}

/// As [`jacobian_dot_batch`], shared with rayon's pool as [`jacobian_batch_par`] shares a
/// batch. The matrices are the same, bit for bit.
///
/// # Errors
/// As [`jacobian_dot_batch`].
///
/// # Panics
/// As [`jacobian_batch`].
pub fn jacobian_dot_batch_par(
    chain: &Chain,
    data: &mut BatchData,
    qs: &[f64],
    qds: &[f64],
    link: LinkId,
    frame: JacobianFrame,
    out: &mut [f64],
) -> Result<(), BatchError> {
    run(chain, data, qs, Some(qds), link, frame, out, true)
}
