//! High-precision link poses of a loaded chain, for measuring the floating-point error of the
//! `f64` kernels (`kinechain bench`, the stress tests).
//!
//! The model's constants (placements, axes, offsets, as loaded) and `q` are taken as exact binary
//! numbers and the chain is evaluated with 256-bit mantissas (`dashu-float`, whose `sin` and `cos`
//! are correctly rounded at that precision), then rounded to `f64`. The difference from the `f64`
//! kernels is their evaluation error; rounding made while loading a file (e.g. `rpy` to a matrix)
//! is not part of it (the 50-digit files of the reference data measure that too).

use crate::eval::Chain;
use crate::eval::layout::body::{Body, Placement};
use crate::measure::worse;
use crate::model::chain::LinkId;
use crate::model::joint::Term;
use crate::model::transform::Transform;
use dashu_float::FBig;
use dashu_float::round::mode::HalfEven;

type F = FBig<HalfEven, 2>;

/// Mantissa bits of the reference arithmetic.
pub const PRECISION_BITS: usize = 256;

fn exact(x: f64) -> F {
    // Finite f64 values convert exactly; the model and q are checked finite before they get here.
    F::try_from(x)
        .unwrap_or(F::ZERO)
        .with_precision(PRECISION_BITS)
        .value()
}

fn to_f64(x: &F) -> f64 {
    x.to_f64().value()
}

#[derive(Clone)]
struct BigFrame {
    r: [[F; 3]; 3],
    p: [F; 3],
}

impl BigFrame {
    fn from_transform(t: &Transform) -> Self {
        BigFrame {
            r: t.r.map(|c| c.map(exact)),
            p: t.p.map(exact),
        }
    }

    /// `R u + p`.
    fn apply_add(&self, u: &[F; 3], p: &[F; 3]) -> [F; 3] {
        std::array::from_fn(|k| {
            &self.r[0][k] * &u[0] + &self.r[1][k] * &u[1] + &self.r[2][k] * &u[2] + &p[k]
        })
    }

    fn compose(&self, other: &BigFrame) -> BigFrame {
        let zero = [F::ZERO, F::ZERO, F::ZERO];
        BigFrame {
            r: std::array::from_fn(|j| self.apply_add(&other.r[j], &zero)),
            p: self.apply_add(&other.p, &self.p),
        }
    }

    fn to_transform(&self) -> Transform {
        Transform {
            r: self.r.clone().map(|c| c.map(|x| to_f64(&x))),
            p: self.p.clone().map(|x| to_f64(&x)),
        }
    }
}

fn term(t: &Term, q: &[f64]) -> F {
    match *t {
        Term::Const(v) => exact(v),
        Term::Var {
            index,
            scale,
            offset,
        } => exact(scale) * exact(q[index]) + exact(offset),
    }
}

/// `A(e)` (eq. 2.13) of the normalised Euler parameters `e` (four entries), by columns, as
/// `eval::kernel::ball::columns` writes it.
fn euler_columns(e: &[f64]) -> [[F; 3]; 3] {
    let e: [F; 4] = std::array::from_fn(|k| exact(e[k]));
    let n2 = &e[0] * &e[0] + &e[1] * &e[1] + &e[2] * &e[2] + &e[3] * &e[3];
    let s = exact(2.0) / n2;
    let one = exact(1.0);
    let sq = |i: usize, j: usize| &e[i] * &e[j];
    [
        [
            &one - &s * (sq(2, 2) + sq(3, 3)),
            &s * (sq(1, 2) + sq(0, 3)),
            &s * (sq(1, 3) - sq(0, 2)),
        ],
        [
            &s * (sq(1, 2) - sq(0, 3)),
            &one - &s * (sq(1, 1) + sq(3, 3)),
            &s * (sq(2, 3) + sq(0, 1)),
        ],
        [
            &s * (sq(1, 3) + sq(0, 2)),
            &s * (sq(2, 3) - sq(0, 1)),
            &one - &s * (sq(1, 1) + sq(2, 2)),
        ],
    ]
}

/// The frame of a floating joint's body, `pre · [A(e) p] · post`, or of a ball joint's,
/// `pre · [A(e) 0] · post` (`eval::kernel::floating`, `eval::kernel::ball`; a floating joint other
/// than the floating base is a free ball body).
fn quaternion_local(body: &Body, q: &[f64]) -> BigFrame {
    let pre = BigFrame::from_transform(&body.pre_frame);
    let own = match body.ball {
        Some(ball) => BigFrame {
            r: euler_columns(&q[ball.quaternion()..ball.quaternion() + 4]),
            p: match ball.free {
                true => [exact(q[ball.q]), exact(q[ball.q + 1]), exact(q[ball.q + 2])],
                false => [F::ZERO, F::ZERO, F::ZERO],
            },
        },
        None => BigFrame {
            r: euler_columns(&q[3..7]),
            p: [exact(q[0]), exact(q[1]), exact(q[2])],
        },
    };
    let post = BigFrame::from_transform(&body.post.to_transform());
    pre.compose(&own).compose(&post)
}

/// `pre · M(θ, d) · post` of one body, exactly (Rodrigues' formula, eq. 2.112, with the model's
/// unit axis taken as exact).
fn local(body: &Body, q: &[f64]) -> BigFrame {
    if body.floating || body.ball.is_some() {
        return quaternion_local(body, q);
    }
    let pre = BigFrame::from_transform(&body.pre_frame);
    let v = body.motion.axis.vector().map(exact);
    let theta = term(&body.motion.theta, q);
    let d = term(&body.motion.d, q);
    let (s, c) = theta.sin_cos();
    let w = exact(1.0) - &c;
    // A = c I + s [v]x + (1 − c) v vᵀ, by columns.
    let a: [[F; 3]; 3] = std::array::from_fn(|j| {
        std::array::from_fn(|i| {
            let identity = if i == j { c.clone() } else { F::ZERO };
            // [v]x column j, row i: ε_{i k j} v_k.
            let skew = match (i, j) {
                (1, 0) => v[2].clone(),
                (2, 0) => -v[1].clone(),
                (0, 1) => -v[2].clone(),
                (2, 1) => v[0].clone(),
                (0, 2) => v[1].clone(),
                (1, 2) => -v[0].clone(),
                _ => F::ZERO,
            };
            identity + &s * skew + &w * &v[i] * &v[j]
        })
    });
    let zero = [F::ZERO, F::ZERO, F::ZERO];
    let motion = BigFrame {
        r: a,
        p: v.clone().map(|x| x * &d),
    };
    let _ = zero;
    let post = BigFrame::from_transform(&body.post.to_transform());
    pre.compose(&motion).compose(&post)
}

/// Link poses at `q` (in [`Chain::links`](crate::Model::links) order), evaluated with [`PRECISION_BITS`]-bit
/// mantissas and rounded to `f64`.
///
/// # Panics
/// If `q` does not have [`Chain::nq`](crate::Model::nq) entries (this is a measuring tool; check `q` first).
#[must_use]
pub fn link_poses(chain: &Chain, q: &[f64]) -> Vec<Transform> {
    assert_eq!(q.len(), chain.nq(), "q has the wrong length");
    let mut frames: Vec<BigFrame> = Vec::with_capacity(chain.bodies.len());
    for body in &chain.bodies {
        let m = local(body, q);
        let f = match body.parent {
            Some(p) => frames[p].compose(&m),
            None => m,
        };
        frames.push(f);
    }
    (0..chain.links().len())
        .map(|i| {
            let link = chain.carrier(LinkId(i));
            let offset = BigFrame::from_transform(&link.offset.to_transform());
            match link.body {
                None => offset.to_transform(),
                Some(b) => match link.offset {
                    Placement::Identity => frames[b].to_transform(),
                    _ => frames[b].compose(&offset).to_transform(),
                },
            }
        })
        .collect()
}

/// Largest position error (m) and rotation-entry error of `poses` against [`link_poses`] (NaN if
/// an entry of `poses` is NaN).
#[must_use]
pub fn max_errors(poses: &[Transform], reference: &[Transform]) -> (f64, f64) {
    let (mut position, mut rotation) = (0.0_f64, 0.0_f64);
    for (a, b) in poses.iter().zip(reference) {
        for j in 0..3 {
            position = worse(position, (a.p[j] - b.p[j]).abs());
            for i in 0..3 {
                rotation = worse(rotation, (a.r[j][i] - b.r[j][i]).abs());
            }
        }
    }
    (position, rotation)
}

/// For each of ω, v, α and a, in that order: the largest difference between `got` (one entry per
/// link, the four vectors in that order) and [`link_motion`]'s `exact`, over links and
/// components, and that difference in ulps of the quantity's largest component in `exact` over
/// all links (NaN if a component of `got` is NaN).
#[must_use]
pub fn max_rate_errors(got: &[[[f64; 3]; 4]], exact: &[LinkMotion]) -> [(f64, f64); 4] {
    let want: Vec<[[f64; 3]; 4]> = exact.iter().map(|m| [m.omega, m.v, m.alpha, m.a]).collect();
    std::array::from_fn(|k| {
        let largest = want
            .iter()
            .flat_map(|m| m[k])
            .fold(0.0_f64, |m, x| m.max(x.abs()));
        let error = got
            .iter()
            .zip(&want)
            .flat_map(|(g, w)| (0..3).map(move |c| (g[k][c] - w[k][c]).abs()))
            .fold(0.0_f64, worse);
        (
            error,
            error / (largest.max(f64::MIN_POSITIVE) * f64::EPSILON),
        )
    })
}

/// Pose, angular velocity, origin velocity, angular acceleration and classical origin
/// acceleration of one link, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkMotion {
    /// `world_from_link`.
    pub pose: Transform,
    /// ω.
    pub omega: [f64; 3],
    /// Velocity of the link-frame origin.
    pub v: [f64; 3],
    /// α = dω/dt.
    pub alpha: [f64; 3],
    /// Classical acceleration of the link-frame origin.
    pub a: [f64; 3],
}

fn cross(a: &[F; 3], b: &[F; 3]) -> [F; 3] {
    [
        &a[1] * &b[2] - &a[2] * &b[1],
        &a[2] * &b[0] - &a[0] * &b[2],
        &a[0] * &b[1] - &a[1] * &b[0],
    ]
}

fn add(a: &[F; 3], b: &[F; 3]) -> [F; 3] {
    std::array::from_fn(|k| &a[k] + &b[k])
}

fn sub(a: &[F; 3], b: &[F; 3]) -> [F; 3] {
    std::array::from_fn(|k| &a[k] - &b[k])
}

fn scale(s: &F, a: &[F; 3]) -> [F; 3] {
    std::array::from_fn(|k| s * &a[k])
}

/// The rate of a θ or d term from `q̇` or `q̈`.
fn rate(t: &crate::eval::layout::body::RateTerm, rates: &[f64]) -> F {
    match t.scale {
        0.0 => F::ZERO,
        scale => exact(scale) * exact(rates[t.index]),
    }
}

fn round3(v: &[F; 3]) -> [f64; 3] {
    std::array::from_fn(|k| to_f64(&v[k]))
}

#[derive(Clone)]
struct BigMotion {
    frame: BigFrame,
    omega: [F; 3],
    v: [F; 3],
    alpha: [F; 3],
    a: [F; 3],
}

/// Link poses, velocities and accelerations at `(q, q_dot, q_ddot)` (in [`Chain::links`](crate::Model::links)
/// order), by the recursion of `eval::single::kinematics` in [`PRECISION_BITS`]-bit arithmetic.
///
/// # Panics
/// If `q` does not have [`Chain::nq`](crate::Model::nq) entries or a rate
/// [`Chain::nv`](crate::Model::nv).
#[must_use]
pub fn link_motion(chain: &Chain, q: &[f64], q_dot: &[f64], q_ddot: &[f64]) -> Vec<LinkMotion> {
    assert!(
        q.len() == chain.nq() && q_dot.len() == chain.nv() && q_ddot.len() == chain.nv(),
        "joint vectors have the wrong length"
    );
    let zero = || [F::ZERO, F::ZERO, F::ZERO];
    let mut bodies: Vec<BigMotion> = Vec::with_capacity(chain.bodies.len());
    for body in &chain.bodies {
        let local = local(body, q);
        if body.floating {
            // Its rates are entries of q̇ and q̈ (world axes).
            let three = |x: &[f64], i: usize| [exact(x[i]), exact(x[i + 1]), exact(x[i + 2])];
            bodies.push(BigMotion {
                frame: local,
                omega: three(q_dot, 3),
                v: three(q_dot, 0),
                alpha: three(q_ddot, 3),
                a: three(q_ddot, 0),
            });
            continue;
        }
        let pre = BigFrame::from_transform(&body.pre_frame);
        let axis = body.motion.axis.vector().map(exact);
        let axis_in_parent = pre.apply_add(&axis, &zero());
        let (frame, p_joint, z, parent) = match body.parent {
            Some(p) => {
                let parent = &bodies[p];
                (
                    parent.frame.compose(&local),
                    parent.frame.apply_add(&pre.p, &parent.frame.p),
                    parent.frame.apply_add(&axis_in_parent, &zero()),
                    Some(parent),
                )
            }
            None => (local, pre.p.clone(), axis_in_parent, None),
        };
        let (p_parent, w_p, v_p, al_p, a_p) = match parent {
            Some(m) => (
                m.frame.p.clone(),
                m.omega.clone(),
                m.v.clone(),
                m.alpha.clone(),
                m.a.clone(),
            ),
            None => (zero(), zero(), zero(), zero(), zero()),
        };
        let (th_d, d_d) = (rate(&body.theta_rate, q_dot), rate(&body.d_rate, q_dot));
        let (th_dd, d_dd) = (rate(&body.theta_rate, q_ddot), rate(&body.d_rate, q_ddot));
        let u = sub(&frame.p, &p_joint);
        let r = sub(&frame.p, &p_parent);
        if let Some(ball) = body.ball {
            // The recursion of `eval::kernel::ball`: a free body's relative velocity and
            // acceleration are entries of q̇ and q̈, a ball's follow from its turn about p_j.
            let three = |x: &[f64], i: usize| [exact(x[i]), exact(x[i + 1]), exact(x[i + 2])];
            let (w, eps) = (three(q_dot, ball.angular()), three(q_ddot, ball.angular()));
            let (v_rel, a_rel) = match ball.free {
                true => (three(q_dot, ball.v), three(q_ddot, ball.v)),
                false => {
                    let v_rel = cross(&w, &u);
                    let a_rel = add(&cross(&eps, &u), &cross(&w, &v_rel));
                    (v_rel, a_rel)
                }
            };
            let w_r = cross(&w_p, &r);
            let a = add(
                &add(&a_p, &add(&cross(&al_p, &r), &cross(&w_p, &w_r))),
                &add(&scale(&exact(2.0), &cross(&w_p, &v_rel)), &a_rel),
            );
            bodies.push(BigMotion {
                frame,
                omega: add(&w_p, &w),
                v: add(&add(&v_p, &w_r), &v_rel),
                alpha: add(&add(&al_p, &eps), &cross(&w_p, &w)),
                a,
            });
            continue;
        }
        let z_u = cross(&z, &u);
        let v_rel = add(&scale(&d_d, &z), &scale(&th_d, &z_u));
        let w_r = cross(&w_p, &r);
        let omega = add(&w_p, &scale(&th_d, &z));
        let v = add(&add(&v_p, &w_r), &v_rel);
        let a_rel = add(
            &add(&scale(&d_dd, &z), &scale(&th_dd, &z_u)),
            &scale(&(&th_d * &th_d), &cross(&z, &z_u)),
        );
        let alpha = add(
            &add(&al_p, &scale(&th_dd, &z)),
            &cross(&w_p, &scale(&th_d, &z)),
        );
        let a = add(
            &add(&a_p, &add(&cross(&al_p, &r), &cross(&w_p, &w_r))),
            &add(&scale(&exact(2.0), &cross(&w_p, &v_rel)), &a_rel),
        );
        bodies.push(BigMotion {
            frame,
            omega,
            v,
            alpha,
            a,
        });
    }
    (0..chain.links().len())
        .map(|i| {
            let link = chain.carrier(LinkId(i));
            let offset = BigFrame::from_transform(&link.offset.to_transform());
            match link.body {
                None => LinkMotion {
                    pose: offset.to_transform(),
                    omega: [0.0; 3],
                    v: [0.0; 3],
                    alpha: [0.0; 3],
                    a: [0.0; 3],
                },
                Some(b) => {
                    let m = &bodies[b];
                    let frame = m.frame.compose(&offset);
                    let r = sub(&frame.p, &m.frame.p);
                    let w_r = cross(&m.omega, &r);
                    LinkMotion {
                        pose: frame.to_transform(),
                        omega: round3(&m.omega),
                        v: round3(&add(&m.v, &w_r)),
                        alpha: round3(&m.alpha),
                        a: round3(&add(
                            &m.a,
                            &add(&cross(&m.alpha, &r), &cross(&m.omega, &w_r)),
                        )),
                    }
                }
            }
        })
        .collect()
}
