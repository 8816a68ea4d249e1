//! Forward kinematics along the chain: every link's pose (eqs. 2.109, 2.119, 2.129), and on
//! request its velocity and acceleration (eqs. 2.120–2.127), in one pass from the base outwards.
//!
//! Longer than 800 lines: the entry points (all links, one link, incremental, rates) and their
//! dispatched kernels share the private steps of the pass (the trigonometry in chunks, the
//! composition of a prefix, the floating base's frame), which split files would have to expose.
//!
//! Three levels, each selected by the function called, so that a pose query does no velocity
//! work and a velocity query no acceleration work:
//!
//! | function | computes |
//! |---|---|
//! | [`forward_kinematics`] | poses |
//! | [`forward_velocities`] | poses, angular velocity ω and origin velocity v |
//! | [`forward_accelerations`] | the above, angular acceleration α and classical origin acceleration a |
//!
//! plus [`forward_kinematics_to`] (only the links on the path to one link) and
//! [`forward_kinematics_incremental`] (only the joints whose `q` changed, and their descendants).
//! The poses also give each link's geometric Jacobian ([`Poses::jacobian`]).
//!
//! # Frames and kinds
//! Every quantity is expressed in the world (base) frame unless its name says `local`. `v` is the
//! velocity of the link-frame origin, `d/dt` of the pose's translation; `a` is the **classical**
//! acceleration of that origin, `d²/dt²` of the translation — not the linear part of a spatial
//! acceleration, which differs from it by `ω × v`.
//!
//! # The recursion
//! For a joint with unit axis `z` (world frame) through the joint-frame origin `p_j`, parent body
//! origin `p_P` and child origin `p`, with `u = p − p_j` and `r = p − p_P`, the child moves
//! relative to its parent with (eqs. 2.120, 2.123–2.125)
//! `v_rel = ḋ z + θ̇ z × u` and `a_rel = d̈ z + θ̈ z × u + θ̇² z × (z × u)`;
//! composing with the parent's motion as a moving frame (eqs. 2.66, 2.75):
//! ```text
//! ω = ω_P + θ̇ z
//! α = α_P + θ̈ z + ω_P × θ̇ z
//! v = v_P + ω_P × r + v_rel
//! a = a_P + α_P × r + ω_P × (ω_P × r) + 2 ω_P × v_rel + a_rel
//! ```
//! (tangential, normal, Coriolis and local terms of eq. 2.75).

use crate::eval::checks::{LimitPolicy, admitted, check_q, check_q_entries, check_values};
use crate::eval::error::StateError;
use crate::eval::kernel::pose_columns::Frame4;
use crate::eval::kernel::rates_columns::Rates4;
use crate::eval::layout::chain::Chain;
use crate::eval::layout::limits::DenseLimits;
use crate::eval::simd::isa::fma_dispatch;
use crate::eval::simd::lanes::Lanes;
use crate::eval::simd::traits::Arith;
use crate::eval::single::data::Data;
use crate::eval::single::results::{Accelerations, Poses, Velocities};
use crate::model::chain::LinkId;
use crate::model::joint::Term;
use crate::model::transform::Transform;
use std::ops::Range;

/// Computes the pose of every link at `q`.
///
/// The inputs are checked, the results are not: finite values large enough to overflow (two
/// sliding joints at 10³⁰⁸ m along one axis, with limits absent or ignored) give infinite
/// entries, as IEEE arithmetic does. This holds for every evaluation function.
///
/// # Errors
/// [`StateError`] if `q` has the wrong length, a non-finite entry, or (under the data's
/// [`LimitPolicy::Enforce`]) a value outside a joint's limits.
///
/// # Panics
/// If `data` was created for another chain.
///
/// # Examples
/// ```
/// use kinechain::{Chain, Data, forward_kinematics};
/// let chain = Chain::from_file("robots/planar3.yaml")?;
/// let mut data = Data::new(&chain);
/// let poses = forward_kinematics(&chain, &mut data, &[0.0, 0.0, 0.0])?;
/// let tip = poses.world_from_link(chain.link_id("link3")?);
/// approx::assert_relative_eq!(tip.translation().x, 9.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[inline]
pub fn forward_kinematics<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
) -> Result<Poses<'a>, StateError> {
    data.assert_matches(chain);
    let done = match kernel_check(chain, q, data.limit_policy) {
        Some(limits) => poses_all_admitted(chain, data, q, limits),
        None => false,
    };
    if !done {
        check_q(chain, q, data.limit_policy)?;
        poses_all(chain, data, q);
    }
    data.last_q.copy_from_slice(q);
    data.poses_valid = true;
    Ok(Poses { chain, data })
}

/// Like [`forward_kinematics`], but recomputes only the joints whose inputs differ from the
/// previous full evaluation with this `data`, and the joints below them. The result is bit for
/// bit the same as a full evaluation (each pose is always composed from its parent's, never
/// updated in place, so there is no drift).
///
/// # Errors
/// As [`forward_kinematics`].
///
/// # Panics
/// If `data` was created for another chain.
#[inline]
pub fn forward_kinematics_incremental<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
) -> Result<Poses<'a>, StateError> {
    data.assert_matches(chain);
    if data.poses_valid {
        let (first, start) = first_changed(chain, data, q)?;
        if first != usize::MAX {
            if is_tail(chain, first) {
                poses_tail(chain, data, q, first);
            } else {
                poses_incremental(chain, data, q, first);
            }
            // Only the entries that differ are written: a loop the compiler does not turn into
            // a call to `memcpy`, which for the one or two entries of a typical update costs
            // more than the copy.
            for (last, x) in data.last_q[start..].iter_mut().zip(&q[start..]) {
                if last.to_bits() != x.to_bits() {
                    *last = *x;
                }
            }
        }
    } else {
        check_q(chain, q, data.limit_policy)?;
        poses_all(chain, data, q);
        data.last_q.copy_from_slice(q);
        data.poses_valid = true;
    }
    Ok(Poses { chain, data })
}

/// The first body that reads an entry of `q` differing (bit for bit) from the last evaluation's
/// or a later entry (`usize::MAX` when none differs), and the index of the first entry that
/// differs. Only the entries from there on are checked: the others were checked then, under the
/// same limit policy (changing the policy invalidates the poses).
///
/// # Errors
/// As [`check_q`].
fn first_changed(chain: &Chain, data: &Data, q: &[f64]) -> Result<(usize, usize), StateError> {
    if q.len() != chain.nq() {
        check_values(chain, q, "q")?;
    }
    let start = first_difference(q, &data.last_q);
    let Some(&first) = chain.first_body_from.get(start) else {
        return Ok((usize::MAX, start));
    };
    let rest = &q[start..];
    let ok = match (data.limit_policy, &chain.dense_limits) {
        (LimitPolicy::Ignore, _) => rest.iter().all(|x| x.is_finite()),
        (LimitPolicy::Enforce, Some(limits)) => {
            (start..).zip(rest).all(|(i, &x)| limits.admits(i, x))
        }
        (LimitPolicy::Enforce, None) => false,
    } && crate::eval::checks::check_quaternion(chain, q).is_ok();
    if !ok {
        // Decides, and names the entry at fault.
        check_q(chain, q, data.limit_policy)?;
    }
    Ok((first, start))
}

/// The index of the first entry of `a` whose bits differ from `b`'s (`a.len()` when none does),
/// compared four entries at a time: moving the last joints of an arm skips the unchanged
/// head in a vector compare or two instead of one branch per entry.
fn first_difference(a: &[f64], b: &[f64]) -> usize {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut start = 0;
    for (x, y) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        let bits = |i: usize| x[i].to_bits() ^ y[i].to_bits();
        if (bits(0) | bits(1)) | (bits(2) | bits(3)) != 0 {
            break;
        }
        start += 4;
    }
    a[start..]
        .iter()
        .zip(&b[start..])
        .position(|(x, y)| x.to_bits() != y.to_bits())
        .map_or(n, |i| start + i)
}

/// Computes the pose of one link, evaluating only the joints between the base and that link.
///
/// # Errors
/// As [`forward_kinematics`].
///
/// # Panics
/// If `data` was created for another chain, or `link` comes from another chain with more links.
#[inline]
pub fn forward_kinematics_to(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    link: LinkId,
) -> Result<Transform, StateError> {
    data.assert_matches(chain);
    let l = chain.carrier(link);
    // Only the entries of `q` the path reads are checked (a robot's link in a scene of many
    // costs what it costs alone); all of them, as `forward_kinematics` does, for the links of
    // most robots.
    chain.path_reads(l.body, &mut data.reads);
    let Some(body) = l.body else {
        check_q_entries(chain, q, &data.reads, data.limit_policy)?;
        return Ok(l.offset.to_transform());
    };
    if !data.reads.all {
        return part_of_q_to(chain, data, q, body, &l.offset);
    }
    let done = match kernel_check(chain, q, data.limit_policy) {
        Some(limits) => poses_path_admitted(chain, data, q, body, limits),
        None => false,
    };
    if !done {
        check_q(chain, q, data.limit_policy)?;
        poses_path(chain, data, q, body);
    }
    data.poses_valid = false;
    Ok(crate::eval::kernel::pose_columns::link_pose(
        &data.world_from_body[body],
        &l.offset,
    ))
}

/// [`forward_kinematics_to`] of a link whose path reads part of `q` only (a robot's link in a
/// scene): those entries checked, then the path evaluated. Out of line, so that the usual case
/// keeps its code.
#[inline(never)]
fn part_of_q_to(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    body: usize,
    offset: &crate::eval::layout::body::Placement,
) -> Result<Transform, StateError> {
    // The entries checked in vectors in the kernel's dispatched call when the limits have
    // columns (the usual case); else, or on failure, as `check_q` checks (naming the entry).
    let limits = match (data.limit_policy, &chain.dense_limits) {
        (LimitPolicy::Enforce, Some(_)) => Some(true),
        (LimitPolicy::Enforce, None) => None,
        (LimitPolicy::Ignore, _) => Some(false),
    };
    let done = limits.is_some_and(|with| {
        q.len() == chain.nq() && poses_part_admitted(chain, data, q, body, with)
    });
    if !done {
        check_q_entries(chain, q, &data.reads, data.limit_policy)?;
        poses_path(chain, data, q, body);
    }
    data.poses_valid = false;
    Ok(crate::eval::kernel::pose_columns::link_pose(
        &data.world_from_body[body],
        offset,
    ))
}

/// Computes poses, angular velocities and origin velocities of every link.
///
/// # Errors
/// As [`forward_kinematics`], and for `q_dot` of the wrong length or with a non-finite entry.
///
/// # Panics
/// If `data` was created for another chain.
#[inline]
pub fn forward_velocities<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
    q_dot: &[f64],
) -> Result<Velocities<'a>, StateError> {
    data.assert_matches(chain);
    let done = match kernel_check(chain, q, data.limit_policy) {
        Some(limits) if q_dot.len() == chain.nv() => {
            rates_admitted(chain, data, q, q_dot, None, limits)
        }
        _ => false,
    };
    if !done {
        check_q(chain, q, data.limit_policy)?;
        check_values(chain, q_dot, "q_dot")?;
        velocities_all(chain, data, q, q_dot);
    }
    data.last_q.copy_from_slice(q);
    data.poses_valid = true;
    Ok(Velocities {
        poses: Poses { chain, data },
    })
}

/// Computes poses, velocities, angular accelerations and classical origin accelerations of
/// every link.
///
/// # Errors
/// As [`forward_velocities`], and for `q_ddot` of the wrong length or with a non-finite entry.
///
/// # Panics
/// If `data` was created for another chain.
#[inline]
pub fn forward_accelerations<'a>(
    chain: &'a Chain,
    data: &'a mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
) -> Result<Accelerations<'a>, StateError> {
    data.assert_matches(chain);
    let nv = chain.nv();
    let done = match kernel_check(chain, q, data.limit_policy) {
        Some(limits) if q_dot.len() == nv && q_ddot.len() == nv => {
            rates_admitted(chain, data, q, q_dot, Some(q_ddot), limits)
        }
        _ => false,
    };
    if !done {
        check_q(chain, q, data.limit_policy)?;
        check_values(chain, q_dot, "q_dot")?;
        check_values(chain, q_ddot, "q_ddot")?;
        accelerations_all(chain, data, q, q_dot, q_ddot);
    }
    data.last_q.copy_from_slice(q);
    data.poses_valid = true;
    Ok(Accelerations {
        poses: Poses { chain, data },
    })
}

// ---------------------------------------------------------------------------------------------
// Loops over the bodies, single configuration (the per-body work is in `crate::eval::kernel`).

#[inline(always)]
fn poses_all_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64]) {
    let _ = poses_prefix::<A>(chain, data, q, chain.bodies.len());
}

/// What the dispatched kernels can check of `q` themselves, deciding as [`check_q`] does under
/// `policy`: finiteness only (`Some(None)`), or the limits one per entry (`Some(Some(_))`).
/// `None` when they cannot (the wrong length, or limits that are not one per entry).
#[inline(always)]
fn kernel_check<'a>(
    chain: &'a Chain,
    q: &[f64],
    policy: LimitPolicy,
) -> Option<Option<&'a DenseLimits>> {
    match (policy, &chain.dense_limits) {
        _ if q.len() != chain.nq() => None,
        // A floating joint's quaternion is checked here, before the kernels.
        _ if crate::eval::checks::check_quaternion(chain, q).is_err() => None,
        (LimitPolicy::Ignore, _) => Some(None),
        (LimitPolicy::Enforce, Some(limits)) => Some(Some(limits)),
        (LimitPolicy::Enforce, None) => None,
    }
}

/// [`poses_all_generic`] if `q` passes the check [`kernel_check`] chose, checked in the same
/// dispatched call (a separate baseline call costs about a tenth of a 7-joint evaluation).
/// False, with nothing computed, otherwise.
#[inline(always)]
fn poses_all_admitted_generic<A: Arith>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    limits: Option<&DenseLimits>,
) -> bool {
    let admitted = admitted::<A>(q, limits);
    if admitted {
        poses_all_generic::<A>(chain, data, q);
    }
    admitted
}

/// [`poses_path_generic`] if the span of `q` in `data.reads` passes its checks (its limits when
/// `limits`), in the same dispatched call.
#[inline(always)]
fn poses_part_admitted_generic<A: Arith>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    body: usize,
    limits: bool,
) -> bool {
    let admitted = crate::eval::checks::admitted_entries::<A>(q, &data.reads, limits);
    if admitted {
        poses_path_generic::<A>(chain, data, q, body);
    }
    admitted
}

/// [`poses_path_generic`] if `q` passes `limits`, as in [`poses_all_admitted_generic`].
#[inline(always)]
fn poses_path_admitted_generic<A: Arith>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    body: usize,
    limits: Option<&DenseLimits>,
) -> bool {
    let admitted = admitted::<A>(q, limits);
    if admitted {
        poses_path_generic::<A>(chain, data, q, body);
    }
    admitted
}

/// Poses of bodies `0..n` (parents come first, so they are all there); returns the last one
/// (the identity for `n = 0`).
#[inline(always)]
fn poses_prefix<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], n: usize) -> Frame4<A::Col> {
    let floating = store_base::<A>(chain, data, q, n);
    let chunks = chain.turning_before[n].div_ceil(crate::eval::simd::lanes::LANES);
    sin_cos_chunks::<A>(chain, data, q, 0..chunks);
    match floating {
        true => compose_prefix::<A, true>(chain, data, q, n),
        false => compose_prefix::<A, false>(chain, data, q, n),
    }
}

/// A floating joint's body's frame (body 0), when it is among bodies `0..n`, into its slot of
/// `data` before the sines and cosines are computed: every body waits for it, and its division
/// and products then run beside them. (Computed in the loop over the bodies, at its place, the
/// Unitree G1's base added about 40 ns to an evaluation; carried into the loop in registers, it
/// made the loop of chains without one slower.) The loop, compiled apart for chains with one
/// (see [`compose_prefix`]), reads it back from the first-level cache. True if it stored one.
#[inline(always)]
fn store_base<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], n: usize) -> bool {
    match chain.bodies[..n].first().filter(|b| b.floating) {
        Some(body) => {
            crate::eval::kernel::pose_columns::root_step::<A>(body, q, (0.0, 1.0))
                .store(&mut data.world_from_body[0]);
            true
        }
        None => false,
    }
}

/// `sin`/`cos` of the angles gathered in chunks `chunks` of [`Chain::theta_gather`], into the
/// same chunks of `data.sin` and `data.cos`.
#[inline(always)]
fn sin_cos_chunks<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], chunks: Range<usize>) {
    let from = chunks.start;
    crate::eval::kernel::joint::all_sin_cos::<A>(
        &chain.theta_gather[chunks],
        q,
        Lanes::flat_mut(&mut data.sin[from..]),
        Lanes::flat_mut(&mut data.cos[from..]),
    );
}

/// The values of `a` and `b` (`data.sin` and `data.cos`, of one length), cut to the shorter
/// one's length so that one comparison checks an index into both.
#[inline(always)]
fn same_length<'a>(a: &'a [Lanes], b: &'a [Lanes]) -> (&'a [f64], &'a [f64]) {
    let (a, b) = (Lanes::flat(a), Lanes::flat(b));
    let m = a.len().min(b.len());
    (&a[..m], &b[..m])
}

/// [`poses_prefix`] once the trigonometry of bodies `0..n` is in `data`.
#[inline(always)]
fn compose_prefix<A: Arith, const FLOATING: bool>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    n: usize,
) -> Frame4<A::Col> {
    // Sliced to `n` first, so that indexing by `k < n` needs no bounds checks.
    let frames = &mut data.world_from_body[..n];
    let (bodies, slots) = (&chain.bodies[..n], &chain.trig_slot[..n]);
    let (sin, cos) = same_length(&data.sin, &data.cos);
    // With `FLOATING`, body 0 is a floating base whose frame `store_base` has put in its slot:
    // the loop starts after it. (Compiled apart, so that chains without one run the loop they
    // ran before floating bases existed.)
    let (start, mut f) = match FLOATING {
        true => (1, Frame4::load(&frames[0])),
        false => (0, Frame4::<A::Col>::identity()),
    };
    for (i, (body, &slot)) in bodies[start..].iter().zip(&slots[start..]).enumerate() {
        let k = start + i;
        // The previous body's frame stays in registers; only branches read a parent from memory.
        // (One call per case, so that the frame is never reached through an optional pointer.)
        let sin_cos = (sin[slot], cos[slot]);
        f = match body.parent {
            _ if body.follows_previous => {
                crate::eval::kernel::pose_columns::pose_step::<A>(Some(&f), body, q, sin_cos)
            }
            Some(p) => crate::eval::kernel::pose_columns::pose_step::<A>(
                Some(&Frame4::load(&frames[p])),
                body,
                q,
                sin_cos,
            ),
            None => crate::eval::kernel::pose_columns::root_step::<A>(body, q, sin_cos),
        };
        f.store(&mut frames[k]);
    }
    f
}

/// The frames of the bodies on the path from the base to `body`, and of no other, into
/// `data.world_from_body`. The caller reads the link's pose from the last one with
/// [`crate::eval::kernel::pose_columns::link_pose`], as every other way of reading a pose does: ending the kernel with that
/// composition and store instead, in its AVX-512 build, made a one-link call 5–10 ns slower than a
/// full evaluation and a read of the same link on Zen 4 (a Panda finger).
#[inline(always)]
fn poses_path_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], body: usize) {
    // A body's ancestors all have smaller indices: the trigonometry of bodies 0..=body covers the
    // path (vectorised, so computing a few bodies off the path costs nothing).
    let chunks = chain.turning_before[body + 1].div_ceil(crate::eval::simd::lanes::LANES);
    sin_cos_chunks::<A>(chain, data, q, 0..chunks);
    // The path is a run of the leading serial bodies (no index list), then the rest of the path
    // (for a branch), listed from the body back towards the base.
    data.path.clear();
    let mut run = Some(body);
    while let Some(b) = run.filter(|&b| b >= chain.serial_run) {
        data.path.push(b);
        run = chain.bodies[b].parent;
    }
    let mut f = match run {
        Some(b) => match store_base::<A>(chain, data, q, b + 1) {
            true => compose_prefix::<A, true>(chain, data, q, b + 1),
            false => compose_prefix::<A, false>(chain, data, q, b + 1),
        },
        None => Frame4::identity(),
    };
    let frames = &mut data.world_from_body;
    let (sin, cos) = same_length(&data.sin, &data.cos);
    for &k in data.path.iter().rev() {
        // Each next body's parent is the previous one, whose frame stays in registers.
        let body = &chain.bodies[k];
        let slot = chain.trig_slot[k];
        let sin_cos = (sin[slot], cos[slot]);
        f = match body.parent {
            Some(_) => {
                crate::eval::kernel::pose_columns::pose_step::<A>(Some(&f), body, q, sin_cos)
            }
            None => crate::eval::kernel::pose_columns::root_step::<A>(body, q, sin_cos),
        };
        f.store(&mut frames[k]);
    }
}

#[inline(always)]
fn poses_incremental_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], first: usize) {
    // Bodies come parents first, so none before `first` (the first body reading a changed
    // entry) moves.
    if chain.is_serial() {
        poses_from::<A>(chain, data, q, first);
        return;
    }
    let changed = |t: &Term| match *t {
        Term::Var { index, .. } => q[index].to_bits() != data.last_q[index].to_bits(),
        Term::Const(_) => false,
    };
    let frames = &mut data.world_from_body;
    let mut f = Frame4::<A::Col>::identity();
    let mut previous_done = false;
    for (k, body) in (first..).zip(&chain.bodies[first..]) {
        let dirty = body.parent.is_some_and(|p| p >= first && data.dirty[p])
            || changed(&body.motion.theta)
            || changed(&body.motion.d)
            || (body.floating && (0..7).any(|i| q[i].to_bits() != data.last_q[i].to_bits()))
            || body.ball.is_some_and(|b| {
                b.q_range()
                    .any(|i| q[i].to_bits() != data.last_q[i].to_bits())
            });
        data.dirty[k] = dirty;
        if dirty {
            // The frame just computed stays in registers when it is the parent's.
            let sin_cos = crate::eval::kernel::joint::body_sin_cos::<f64, A>(body, q);
            f = match body.parent {
                _ if body.follows_previous && previous_done => {
                    crate::eval::kernel::pose_columns::pose_step::<A>(Some(&f), body, q, sin_cos)
                }
                Some(p) => crate::eval::kernel::pose_columns::pose_step::<A>(
                    Some(&Frame4::load(&frames[p])),
                    body,
                    q,
                    sin_cos,
                ),
                None => crate::eval::kernel::pose_columns::root_step::<A>(body, q, sin_cos),
            };
            f.store(&mut frames[k]);
        }
        previous_done = dirty;
    }
}

/// Poses of bodies `first..` of a serial chain (each body hangs from the one before), the
/// bodies before `first` being up to date; the trigonometry vectorised like a full evaluation's.
#[inline(always)]
fn poses_from<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], first: usize) {
    let chunk = chain.turning_before[first] / crate::eval::simd::lanes::LANES;
    sin_cos_chunks::<A>(chain, data, q, chunk..chain.theta_gather.len());
    let frames = &mut data.world_from_body;
    let mut f = match first.checked_sub(1) {
        Some(p) => Frame4::load(&frames[p]),
        None => Frame4::identity(),
    };
    let (sin, cos) = same_length(&data.sin, &data.cos);
    let bodies = chain.bodies[first..].iter().zip(&chain.trig_slot[first..]);
    for (k, (body, &slot)) in (first..).zip(bodies) {
        let sin_cos = (sin[slot], cos[slot]);
        f = match body.parent {
            Some(_) => {
                crate::eval::kernel::pose_columns::pose_step::<A>(Some(&f), body, q, sin_cos)
            }
            None => crate::eval::kernel::pose_columns::root_step::<A>(body, q, sin_cos),
        };
        f.store(&mut frames[k]);
    }
}

/// Whether the bodies from `first` on are few enough for [`poses_tail`] ([`Chain`]'s
/// `tail_start`: at most four, of which at most two turn; a sliding or fixed-θ body needs no
/// `sin`/`cos`). In a tree they may include bodies that did not move; recomputing one gives the
/// same frame, bit for bit.
#[inline(always)]
fn is_tail(chain: &Chain, first: usize) -> bool {
    first >= chain.tail_start
}

/// Poses of the bodies from `first` on ([`is_tail`]), the bodies before `first` being up to
/// date, with their trigonometry in scalar code: a function of its own, so that moving the last
/// joints (the common incremental update) runs none of the set-up of the vectorised or tree
/// paths.
#[inline(always)]
fn poses_tail_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], first: usize) {
    let frames = &mut data.world_from_body;
    let mut f = Frame4::<A::Col>::identity();
    // (Not `enumerate().skip(first)`, here or in `poses_from` and `poses_incremental_generic`:
    // it divides by the size of a body to count them.)
    for (k, body) in (first..).zip(&chain.bodies[first..]) {
        let sin_cos = crate::eval::kernel::joint::body_sin_cos::<f64, A>(body, q);
        // The parent's frame stays in registers when it was just computed.
        f = match body.parent {
            _ if body.follows_previous && k > first => {
                crate::eval::kernel::pose_columns::pose_step::<A>(Some(&f), body, q, sin_cos)
            }
            Some(p) => crate::eval::kernel::pose_columns::pose_step::<A>(
                Some(&Frame4::load(&frames[p])),
                body,
                q,
                sin_cos,
            ),
            None => crate::eval::kernel::pose_columns::root_step::<A>(body, q, sin_cos),
        };
        f.store(&mut frames[k]);
    }
}

#[inline(always)]
fn rates_all_generic<A: Arith, const ACC: bool>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
) {
    // A floating base's state first (see `store_base`); the loop, compiled apart for it, starts
    // after it.
    match chain.bodies.first().filter(|b| b.floating) {
        Some(b) => {
            let (f, r) = crate::eval::kernel::rates_columns::root_rates_step::<A, ACC>(
                b,
                q,
                q_dot,
                q_ddot,
                (0.0, 1.0),
            );
            f.store(&mut data.world_from_body[0]);
            r.store::<ACC>(&mut data.rates[0]);
            rates_loop::<A, ACC, true>(chain, data, q, q_dot, q_ddot);
        }
        None => rates_loop::<A, ACC, false>(chain, data, q, q_dot, q_ddot),
    }
}

/// The body loop of [`rates_all_generic`]; with `FLOATING`, body 0's state is already in `data`.
#[inline(always)]
fn rates_loop<A: Arith, const ACC: bool, const FLOATING: bool>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
) {
    sin_cos_chunks::<A>(chain, data, q, 0..chain.theta_gather.len());
    // Sliced to the number of bodies first, so that indexing by body needs no bounds checks.
    let n = chain.bodies.len();
    let (frames, rates) = (&mut data.world_from_body[..n], &mut data.rates[..n]);
    let slots = &chain.trig_slot[..n];
    let (sin, cos) = same_length(&data.sin, &data.cos);
    let (start, mut previous) = match FLOATING {
        true => (1, (Frame4::load(&frames[0]), Rates4::from_rates(&rates[0]))),
        false => (0, (Frame4::<A::Col>::identity(), Rates4::zero())),
    };
    let bodies = &chain.bodies[start..n];
    for (i, (body, &slot)) in bodies.iter().zip(&slots[start..]).enumerate() {
        let k = start + i;
        // The previous body's state stays in registers; only branches read a parent from memory.
        // (One call per case, as in `poses_prefix`.)
        let sin_cos = (sin[slot], cos[slot]);
        previous =
            match body.parent {
                _ if body.follows_previous => crate::eval::kernel::rates_columns::rates_step::<
                    A,
                    ACC,
                >(
                    Some(&previous), body, q, q_dot, q_ddot, sin_cos
                ),
                Some(p) => {
                    let loaded = (Frame4::load(&frames[p]), Rates4::from_rates(&rates[p]));
                    crate::eval::kernel::rates_columns::rates_step::<A, ACC>(
                        Some(&loaded),
                        body,
                        q,
                        q_dot,
                        q_ddot,
                        sin_cos,
                    )
                }
                None => crate::eval::kernel::rates_columns::root_rates_step::<A, ACC>(
                    body, q, q_dot, q_ddot, sin_cos,
                ),
            };
        previous.0.store(&mut frames[k]);
        previous.1.store::<ACC>(&mut rates[k]);
    }
}

/// [`rates_all_generic`] if `q` passes the check [`kernel_check`] chose and the rates (of the
/// chain's length) are finite, checked in the same dispatched call as in
/// [`poses_all_admitted_generic`]. False, with nothing computed, otherwise.
#[inline(always)]
fn rates_admitted_generic<A: Arith, const ACC: bool>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
    limits: Option<&DenseLimits>,
) -> bool {
    let admitted = admitted::<A>(q, limits)
        & admitted::<A>(q_dot, None)
        & (!ACC || admitted::<A>(q_ddot, None));
    if admitted {
        rates_all_generic::<A, ACC>(chain, data, q, q_dot, q_ddot);
    }
    admitted
}

/// [`rates_admitted_generic`] with accelerations when `q_ddot` is given.
#[inline(always)]
fn rates_admitted_either_generic<A: Arith>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: Option<&[f64]>,
    limits: Option<&DenseLimits>,
) -> bool {
    match q_ddot {
        Some(q_ddot) => rates_admitted_generic::<A, true>(chain, data, q, q_dot, q_ddot, limits),
        None => rates_admitted_generic::<A, false>(chain, data, q, q_dot, &[], limits),
    }
}

#[inline(always)]
fn velocities_generic<A: Arith>(chain: &Chain, data: &mut Data, q: &[f64], q_dot: &[f64]) {
    rates_all_generic::<A, false>(chain, data, q, q_dot, &[]);
}

#[inline(always)]
fn accelerations_generic<A: Arith>(
    chain: &Chain,
    data: &mut Data,
    q: &[f64],
    q_dot: &[f64],
    q_ddot: &[f64],
) {
    rates_all_generic::<A, true>(chain, data, q, q_dot, q_ddot);
}

fma_dispatch!(fn poses_all(chain: &Chain, data: &mut Data, q: &[f64]) => poses_all_generic);

fma_dispatch!(fn poses_path(chain: &Chain, data: &mut Data, q: &[f64], body: usize) => poses_path_generic);

fma_dispatch!(fn poses_all_admitted(chain: &Chain, data: &mut Data, q: &[f64], limits: Option<&DenseLimits>) -> bool => poses_all_admitted_generic);

fma_dispatch!(fn poses_path_admitted(chain: &Chain, data: &mut Data, q: &[f64], body: usize, limits: Option<&DenseLimits>) -> bool => poses_path_admitted_generic);

fma_dispatch!(fn poses_part_admitted(chain: &Chain, data: &mut Data, q: &[f64], body: usize, limits: bool) -> bool => poses_part_admitted_generic);

fma_dispatch!(fn poses_incremental(chain: &Chain, data: &mut Data, q: &[f64], first: usize) => poses_incremental_generic);

fma_dispatch!(fn poses_tail(chain: &Chain, data: &mut Data, q: &[f64], first: usize) => poses_tail_generic);

fma_dispatch!(fn rates_admitted(chain: &Chain, data: &mut Data, q: &[f64], q_dot: &[f64], q_ddot: Option<&[f64]>, limits: Option<&DenseLimits>) -> bool => rates_admitted_either_generic);

fma_dispatch!(fn velocities_all(chain: &Chain, data: &mut Data, q: &[f64], q_dot: &[f64]) => velocities_generic);

fma_dispatch!(fn accelerations_all(chain: &Chain, data: &mut Data, q: &[f64], q_dot: &[f64], q_ddot: &[f64]) => accelerations_generic);

#[cfg(test)]
mod tests;
