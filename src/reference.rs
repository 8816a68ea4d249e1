//! High-precision link poses of a loaded chain, for measuring the floating-point error of the
//! `f64` kernels (`kinechain bench`, the stress tests).
//!
//! The model's constants (placements, axes, offsets, as loaded) and `q` are taken as exact binary
//! numbers and the chain is evaluated with 256-bit mantissas (`dashu-float`, whose `sin` and `cos`
//! are correctly rounded at that precision), then rounded to `f64`. The difference from the `f64`
//! kernels is their evaluation error; rounding made while loading a file (e.g. `rpy` to a matrix)
//! is not part of it (the 50-digit files of the reference data measure that too).

use crate::chain::{Body, Chain, LinkId, Placement};
use crate::joint::Term;
use crate::transform::Transform;
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

/// `pre · M(θ, d) · post` of one body, exactly (Rodrigues' formula, eq. 2.112, with the model's
/// unit axis taken as exact).
fn local(body: &Body, q: &[f64]) -> BigFrame {
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

/// Link poses at `q` (in [`Chain::links`] order), evaluated with [`PRECISION_BITS`]-bit
/// mantissas and rounded to `f64`.
///
/// # Panics
/// If `q` does not have [`Chain::dof`] entries (this is a measuring tool; check `q` first).
#[must_use]
pub fn link_poses(chain: &Chain, q: &[f64]) -> Vec<Transform> {
    assert_eq!(q.len(), chain.dof(), "q has the wrong length");
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
            let link = chain.link(LinkId(i));
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

/// Largest position error (m) and rotation-entry error of `poses` against [`link_poses`].
#[must_use]
pub fn max_errors(poses: &[Transform], reference: &[Transform]) -> (f64, f64) {
    let (mut position, mut rotation) = (0.0_f64, 0.0_f64);
    for (a, b) in poses.iter().zip(reference) {
        for j in 0..3 {
            position = position.max((a.p[j] - b.p[j]).abs());
            for i in 0..3 {
                rotation = rotation.max((a.r[j][i] - b.r[j][i]).abs());
            }
        }
    }
    (position, rotation)
}
