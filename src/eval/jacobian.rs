//! Geometric Jacobians and their time derivatives, in the three frames [`JacobianFrame`] names,
//! from any evaluated state: a single evaluation's [`Poses`](crate::Poses) or one configuration
//! of a batch. Both read the same stored frames and rates and run this code, so a batched
//! Jacobian equals the single one bit for bit.

use crate::eval::kernel::pose_columns::{Frame4, place};
use crate::eval::layout::body::Body;
use crate::eval::layout::chain::Chain;
use crate::eval::layout::stored::Stored;
use crate::eval::simd::traits::{Arith, Col};
use crate::model::chain::LinkId;
use crate::model::transform::{Transform, add3, cross3, sub3};

/// Where a Jacobian's velocity is taken and in which axes its rows are written. Every kind has
/// rows `[v; ω]` (linear first, as Pinocchio and KDL order them) and one column per entry of `q`,
/// so that `[v; ω] = J q̇` and `[a; α] = J q̈ + J̇ q̇` (eqs. 2.120–2.127).
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum JacobianFrame {
    /// `v` of the link-frame origin and `ω`, both in world axes (Pinocchio's
    /// `LOCAL_WORLD_ALIGNED`, KDL's `JntToJac` with the reference point at the link origin).
    World,
    /// `v` of the link-frame origin and `ω`, both in the link's own axes: the world rows turned
    /// by `Aᵀ` (eq. 2.41; Pinocchio's `LOCAL`), as [`Velocities::velocity_local`](crate::Velocities::velocity_local) gives them.
    Link,
    /// `v` of the point with link coordinates `ū` (the velocity of eq. 2.55 for a fixed point)
    /// and `ω`, both in world axes.
    Point([f64; 3]),
}

impl JacobianFrame {
    /// The point `ū` (link coordinates) of [`JacobianFrame::Point`], the link origin otherwise.
    #[must_use]
    pub fn point(&self) -> [f64; 3] {
        match *self {
            JacobianFrame::Point(u) => u,
            _ => [0.0; 3],
        }
    }
}

/// What a Jacobian is computed from: the world frames of the bodies and of the links and, for
/// `J̇`, the bodies' and links' velocities.
pub(crate) trait State {
    fn chain(&self) -> &Chain;
    /// World frame of body `b`.
    fn body_frame(&self, b: usize) -> Transform;
    /// `[ω, v]` of body `b` (v of its origin), world axes.
    fn body_rates(&self, b: usize) -> [[f64; 3]; 2];
    /// World pose of `link`.
    fn link_pose(&self, link: LinkId) -> Transform;
    /// `[ω, v]` of `link` (v of its origin), world axes.
    fn link_rates(&self, link: LinkId) -> [[f64; 3]; 2];
}

/// The parts of a body's joint axis in the world frame: the origin of the frame before the
/// joint (the parent body's, or the world's), the joint-frame origin's offset from it in world
/// axes, and the unit direction.
#[inline(always)]
pub(crate) fn axis_parts(s: &impl State, body: &Body) -> ([f64; 3], [f64; 3], [f64; 3]) {
    match body.parent {
        Some(p) => {
            let parent = s.body_frame(p);
            let r = Transform {
                r: parent.r,
                p: [0.0; 3],
            };
            (
                parent.p,
                r.apply(body.pre_frame.p),
                r.apply(body.axis_in_parent),
            )
        }
        None => ([0.0; 3], body.pre_frame.p, body.axis_in_parent),
    }
}

/// `j` (6 × dof, column-major: column `i` is entries `6i..6i + 6`) ← the sum, over the bodies
/// from `link` back to the base, of each body's turning and sliding columns (from `columns`)
/// times its rate terms: a column can take several terms (a mimic joint's, a cylindrical
/// joint's two), and entries of joints off the path stay zero.
///
/// A floating joint's body gives its six columns (entries 0–5 of `q̇`) from `floating`: for each
/// world axis `e_k`, the columns of a slide along it and of a turn about it through the body's
/// origin. A ball joint's body gives its three from `columns` with the axis `Some(e_k)`: the
/// turning columns of revolute axes fixed in the parent's frame, through the joint origin, that
/// are the world axes in this configuration ([`crate::eval::kernel::ball`]).
#[inline(always)]
fn path_columns(
    s: &impl State,
    link: LinkId,
    j: &mut [f64],
    mut columns: impl FnMut(&Body, Option<[f64; 3]>) -> ([f64; 6], [f64; 6]),
    mut floating: impl FnMut(usize, [f64; 3]) -> ([f64; 6], [f64; 6]),
) {
    let chain = s.chain();
    j.fill(0.0);
    let mut body = chain.carrier(link).body;
    while let Some(b) = body {
        let bd = &chain.bodies[b];
        if let Some(ball) = bd.ball.filter(|b| !b.free) {
            for k in 0..3 {
                let mut e = [0.0; 3];
                e[k] = 1.0;
                let (turning, _) = columns(bd, Some(e));
                j[6 * (ball.v + k)..6 * (ball.v + k) + 6].copy_from_slice(&turning);
            }
            body = bd.parent;
            continue;
        }
        // The floating base's six columns are the first; another floating joint's its own.
        let free = match (bd.floating, bd.ball) {
            (true, _) => Some(0),
            (false, Some(ball)) => Some(ball.v),
            (false, None) => None,
        };
        if let Some(v) = free {
            for k in 0..3 {
                let mut e = [0.0; 3];
                e[k] = 1.0;
                let (turning, sliding) = floating(b, e);
                j[6 * (v + k)..6 * (v + k) + 6].copy_from_slice(&sliding);
                j[6 * (v + 3 + k)..6 * (v + 3 + k) + 6].copy_from_slice(&turning);
            }
            body = bd.parent;
            continue;
        }
        let (turning, sliding) = columns(bd, None);
        for (rate, terms) in [(bd.theta_rate, turning), (bd.d_rate, sliding)] {
            if rate.scale != 0.0 {
                let column = &mut j[6 * rate.index..6 * rate.index + 6];
                for (c, x) in column.iter_mut().zip(terms) {
                    *c += x * rate.scale;
                }
            }
        }
        body = bd.parent;
    }
}

fn join(a: [f64; 3], b: [f64; 3]) -> [f64; 6] {
    [a[0], a[1], a[2], b[0], b[1], b[2]]
}

/// The reference point of `frame` on `link` in the world frame, and the link's pose.
fn point_of(s: &impl State, link: LinkId, frame: JacobianFrame) -> ([f64; 3], Transform) {
    let pose = s.link_pose(link);
    let p = match frame {
        JacobianFrame::Point(u) => add3(pose.p, pose.apply(u)),
        _ => pose.p,
    };
    (p, pose)
}

/// Turns each 3-row half of every column of `j` by `Aᵀ` (`pose`'s rotation transposed), for
/// [`JacobianFrame::Link`].
fn to_link_axes(pose: &Transform, j: &mut [f64]) {
    for column in j.chunks_exact_mut(3) {
        let x = [column[0], column[1], column[2]];
        for (k, c) in column.iter_mut().enumerate() {
            let r = pose.r[k];
            *c = r[0] * x[0] + r[1] * x[1] + r[2] * x[2];
        }
    }
}

/// The Jacobian of `link` in `frame` into `j` (6 × dof, column-major): the scalar statement of
/// what [`stored_jacobian`] computes on vectors and the batch's lane kernel on lanes.
#[cfg(test)]
pub(crate) fn jacobian(s: &impl State, link: LinkId, frame: JacobianFrame, j: &mut [f64]) {
    let (p, pose) = point_of(s, link, frame);
    path_columns(
        s,
        link,
        j,
        |bd, world_axis| {
            let (parent_origin, offset, z) = axis_parts(s, bd);
            let z = world_axis.unwrap_or(z);
            let origin = add3(parent_origin, offset);
            let turning = cross3(z, sub3(p, origin));
            (join(turning, z), join(z, [0.0; 3]))
        },
        |b, e| {
            let origin = s.body_frame(b).p;
            let turning = cross3(e, sub3(p, origin));
            (join(turning, e), join(e, [0.0; 3]))
        },
    );
    if frame == JacobianFrame::Link {
        to_link_axes(&pose, j);
    }
}

/// `J̇` of [`jacobian`] (needs the rates in `s`) into `j`.
///
/// Each joint axis is fixed in the frame before its joint, which turns with that frame's
/// angular velocity `ω_j`: a turning column `[z × (p − p_j); z]` changes at
/// `[ż × (p − p_j) + z × (ṗ − ṗ_j); ż]` with `ż = ω_j × z` (eq. 2.120 for `ṗ_j`, the velocity of
/// the axis point), a sliding column `[z; 0]` at `[ż; 0]`. For a point `p = o + A ū`,
/// `ṗ = v + ω × (A ū)`. In link axes, `d/dt (Aᵀ c) = Aᵀ (ċ − ω × c)` for each half `c` of a
/// column of the world Jacobian.
pub(crate) fn jacobian_dot(s: &impl State, link: LinkId, frame: JacobianFrame, j: &mut [f64]) {
    let (p, pose) = point_of(s, link, frame);
    let [omega, v] = s.link_rates(link);
    let p_dot = match frame {
        JacobianFrame::Point(u) => add3(v, cross3(omega, pose.apply(u))),
        _ => v,
    };
    // Aᵀ (ċ − ω × c) for each half c of a world column (the link's ω).
    let less_spin = |dot: [f64; 6], c: [f64; 6]| {
        let (a, b) = (
            cross3(omega, [c[0], c[1], c[2]]),
            cross3(omega, [c[3], c[4], c[5]]),
        );
        join(
            sub3([dot[0], dot[1], dot[2]], a),
            sub3([dot[3], dot[4], dot[5]], b),
        )
    };
    path_columns(
        s,
        link,
        j,
        |bd, world_axis| {
            let (parent_origin, offset, z) = axis_parts(s, bd);
            let z = world_axis.unwrap_or(z);
            let origin = add3(parent_origin, offset);
            // The frame before the joint turns at ω and its origin moves at v; the axis point
            // at v + ω × offset (the offset in world axes, not a difference of origins).
            let (omega_j, origin_dot) = match bd.parent {
                Some(parent) => {
                    let [omega, v] = s.body_rates(parent);
                    (omega, add3(v, cross3(omega, offset)))
                }
                None => ([0.0; 3], [0.0; 3]),
            };
            let z_dot = cross3(omega_j, z);
            let turning = add3(
                cross3(z_dot, sub3(p, origin)),
                cross3(z, sub3(p_dot, origin_dot)),
            );
            let (turning_dot, sliding_dot) = (join(turning, z_dot), join(z_dot, [0.0; 3]));
            if frame != JacobianFrame::Link {
                return (turning_dot, sliding_dot);
            }
            let turning = cross3(z, sub3(p, origin));
            (
                less_spin(turning_dot, join(turning, z)),
                less_spin(sliding_dot, join(z, [0.0; 3])),
            )
        },
        |b, e| {
            // The turning column's point is the body's origin, moving at the body's v. The axes
            // are fixed in the parent's frame: under the floating base (or any floating joint
            // hanging from the world) they do not turn.
            let origin = s.body_frame(b).p;
            let origin_dot = s.body_rates(b)[1];
            let (turning_dot, sliding_dot) = match s.chain().bodies[b].parent {
                None => (join(cross3(e, sub3(p_dot, origin_dot)), [0.0; 3]), [0.0; 6]),
                Some(parent) => {
                    let e_dot = cross3(s.body_rates(parent)[0], e);
                    let turning = add3(
                        cross3(e_dot, sub3(p, origin)),
                        cross3(e, sub3(p_dot, origin_dot)),
                    );
                    (join(turning, e_dot), join(e_dot, [0.0; 3]))
                }
            };
            if frame != JacobianFrame::Link {
                return (turning_dot, sliding_dot);
            }
            let turning = cross3(e, sub3(p, origin));
            (
                less_spin(turning_dot, join(turning, e)),
                less_spin(sliding_dot, join(e, [0.0; 3])),
            )
        },
    );
    if frame == JacobianFrame::Link {
        to_link_axes(&pose, j);
    }
}

/// `R u` for constant `u`, on padded columns, in [`Transform::apply`]'s order (no fused
/// multiply–adds): `(c₀ u₀ + c₁ u₁) + c₂ u₂`.
#[inline(always)]
fn turn<C: Col>(c: &[C; 4], u: [f64; 3]) -> C {
    C::add(
        C::add(C::mul(c[0], C::splat(u[0])), C::mul(c[1], C::splat(u[1]))),
        C::mul(c[2], C::splat(u[2])),
    )
}

/// `a × b` on padded columns, entry for entry [`cross3`].
#[inline(always)]
fn cross4<C: Col>(a: C, b: C) -> C {
    C::sub(C::mul(a.yzx(), b.zxy()), C::mul(a.zxy(), b.yzx()))
}

/// [`jacobian`] read straight from stored body frames (`frames`, as [`crate::Data`] holds
/// them), on padded columns: each path body's axis, point and column in vector registers, in
/// the same operations and order as the scalar code, so the same bits. Only the frames of
/// the bodies on `link`'s path (and their parents) are read.
#[inline(always)]
fn stored_jacobian_generic<A: Arith>(
    chain: &Chain,
    frames: &[Stored],
    link: LinkId,
    frame: JacobianFrame,
    j: &mut [f64],
) {
    type C<A> = <A as Arith>::Col;
    let carrier = chain.carrier(link);
    let Some(body) = carrier.body else {
        // A link fixed to the world: no joint moves it (and no frame to turn the zeros by).
        j.fill(0.0);
        return;
    };
    let pad = |v: [f64; 3]| [v[0], v[1], v[2], 0.0];
    let zero = C::<A>::splat(0.0);
    let mut pose = Frame4::<C<A>>::load(&frames[body]);
    place::<A>(&mut pose.0, &carrier.offset);
    let p = match frame {
        JacobianFrame::Point(u) => C::<A>::add(pose.0[3], turn(&pose.0, u)),
        _ => pose.0[3],
    };
    // Aᵀ x = x₀ (row 0 of A) + x₁ (row 1) + x₂ (row 2), in `to_link_axes`' order.
    let mut r = [[0.0; 4]; 4];
    for (c, column) in pose.0.iter().zip(r.iter_mut()) {
        c.store(column);
    }
    let rows: [C<A>; 3] =
        std::array::from_fn(|i| C::<A>::from_entries([r[0][i], r[1][i], r[2][i], 0.0]));
    let to_link = |x: [f64; 3]| {
        C::<A>::add(
            C::<A>::add(
                C::<A>::mul(rows[0], C::<A>::splat(x[0])),
                C::<A>::mul(rows[1], C::<A>::splat(x[1])),
            ),
            C::<A>::mul(rows[2], C::<A>::splat(x[2])),
        )
    };
    let entries = |x: C<A>| {
        let mut e = [0.0; 4];
        x.store(&mut e);
        [e[0], e[1], e[2]]
    };
    let link_axes = frame == JacobianFrame::Link;
    // A column of one term is written once, already turned into link axes; the others (a
    // mimicked joint's) are summed from zero and turned at the end, as the scalar code does
    // every column. Columns no body on the path writes are zeros, turned like the others.
    let unwritten = if link_axes {
        entries(to_link([0.0; 3]))
    } else {
        [0.0; 3]
    };
    for (column, &terms) in j.chunks_exact_mut(6).zip(&chain.column_terms) {
        if terms > 1 {
            column.fill(0.0);
        } else {
            column[..3].copy_from_slice(&unwritten);
            column[3..].copy_from_slice(&unwritten);
        }
    }
    // A column of a floating or ball joint, written once: its two halves, in link axes when asked.
    let write_once = |j: &mut [f64], index: usize, halves: [C<A>; 2]| {
        let column = &mut j[6 * index..6 * index + 6];
        for (half, x) in column.chunks_exact_mut(3).zip(halves) {
            let mut x = entries(x);
            if link_axes {
                x = entries(to_link(x));
            }
            half.copy_from_slice(&x);
        }
    };
    let mut at = Some(body);
    while let Some(b) = at {
        let bd = &chain.bodies[b];
        // The floating base's six columns are the first; another floating joint's its own.
        let free = match (bd.floating, bd.ball) {
            (true, _) => Some(0),
            (false, Some(ball)) if ball.free => Some(ball.v),
            _ => None,
        };
        if let Some(v) = free {
            // Six columns: a slide along and a turn about each world axis, the turns through
            // the body's origin (see `path_columns`).
            let origin = Frame4::<C<A>>::load(&frames[b]).0[3];
            for k in 0..3 {
                let mut e = [0.0; 4];
                e[k] = 1.0;
                let z = C::<A>::from_entries(e);
                let turning = cross4(z, C::<A>::sub(p, origin));
                write_once(j, v + k, [z, zero]);
                write_once(j, v + 3 + k, [turning, z]);
            }
            at = bd.parent;
            continue;
        }
        let (origin, z) = match bd.parent {
            Some(parent) => {
                let c = Frame4::<C<A>>::load(&frames[parent]).0;
                (
                    C::<A>::add(c[3], turn(&c, bd.pre_frame.p)),
                    turn(&c, bd.axis_in_parent),
                )
            }
            // `axis_parts`' world origin plus the offset (`0 + x`, as the scalar code adds).
            None => (
                C::<A>::add(zero, C::<A>::from_entries(pad(bd.pre_frame.p))),
                C::<A>::from_entries(pad(bd.axis_in_parent)),
            ),
        };
        if let Some(ball) = bd.ball {
            // Three columns, written once: turns about the world axes through the joint origin.
            for k in 0..3 {
                let mut e = [0.0; 4];
                e[k] = 1.0;
                let z = C::<A>::from_entries(e);
                let turning = cross4(z, C::<A>::sub(p, origin));
                write_once(j, ball.v + k, [turning, z]);
            }
            at = bd.parent;
            continue;
        }
        let turning = cross4(z, C::<A>::sub(p, origin));
        for (rate, halves) in [(bd.theta_rate, [turning, z]), (bd.d_rate, [z, zero])] {
            if rate.scale != 0.0 {
                let scale = C::<A>::splat(rate.scale);
                let single = chain.column_terms[rate.index] == 1;
                let column = &mut j[6 * rate.index..6 * rate.index + 6];
                for (half, x) in column.chunks_exact_mut(3).zip(halves) {
                    let x = C::<A>::mul(x, scale);
                    if single {
                        // `0 + x`, as the sum from zero gives it.
                        let mut x = entries(C::<A>::add(x, zero));
                        if link_axes {
                            x = entries(to_link(x));
                        }
                        half.copy_from_slice(&x);
                    } else {
                        for (c, x) in half.iter_mut().zip(entries(x)) {
                            *c += x;
                        }
                    }
                }
            }
        }
        at = bd.parent;
    }
    if link_axes {
        for (column, &terms) in j.chunks_exact_mut(6).zip(&chain.column_terms) {
            if terms > 1 {
                for half in column.chunks_exact_mut(3) {
                    let x = entries(to_link([half[0], half[1], half[2]]));
                    half.copy_from_slice(&x);
                }
            }
        }
    }
}

crate::eval::simd::isa::fma_dispatch!(avx2 pub(crate) fn stored_jacobian(chain: &Chain, frames: &[Stored], link: LinkId, frame: JacobianFrame, j: &mut [f64]) => stored_jacobian_generic);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::configurations;
    use crate::{Data, LimitPolicy, forward_kinematics};

    /// The vector kernel reading stored frames gives the scalar code's bits: every link of every
    /// bundled robot (the Panda's mimicked finger joint sums two terms into one column), in each
    /// frame.
    #[test]
    fn stored_frames_give_the_scalar_code_bits() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("robots");
        let mut files: Vec<_> = std::fs::read_dir(&root)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "urdf" || e == "yaml"))
            .collect();
        files.sort();
        assert!(files.len() >= 4, "{files:?}");
        for file in files {
            let chain = Chain::from_file(&file).unwrap();
            let mut data = Data::new(&chain).with_limit_policy(LimitPolicy::Ignore);
            let dof = chain.dof();
            let (mut vector, mut scalar) = (vec![0.0; 6 * dof], vec![0.0; 6 * dof]);
            for q in configurations(&chain, 5, 7) {
                let poses = forward_kinematics(&chain, &mut data, &q).unwrap();
                for l in 0..chain.links().len() {
                    let link = LinkId(l);
                    for frame in [
                        JacobianFrame::World,
                        JacobianFrame::Link,
                        JacobianFrame::Point([0.1, -0.2, 0.05]),
                    ] {
                        // Filled with something else first: every entry must be written.
                        vector.fill(f64::NAN);
                        stored_jacobian(
                            &chain,
                            &poses.data.world_from_body,
                            link,
                            frame,
                            &mut vector,
                        );
                        jacobian(&poses, link, frame, &mut scalar);
                        let bits = |j: &[f64]| j.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                        assert_eq!(bits(&vector), bits(&scalar), "{file:?} link {l} {frame:?}");
                    }
                }
            }
        }
    }
}
