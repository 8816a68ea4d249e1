//! The unknowns of a problem: the entries of `q̇` on the goals' paths that are not locked, with
//! their limits, and what a step does to each.

use crate::eval::layout::chain::Chain;
use crate::model::chain::JointId;
use crate::model::joint::JointKind;
use std::f64::consts::{PI, TAU};

use super::goal::{Distance, Prepared};

/// An entry of `q̇` the solve moves.
#[derive(Clone, Copy, Debug)]
pub(super) enum Var {
    /// A joint coordinate `q[q]` within `[lo, hi]`; `wrap`: rotational and unbounded; `around`:
    /// rotational with limits a whole turn or more apart.
    Scalar {
        q: usize,
        lo: f64,
        hi: f64,
        wrap: bool,
        around: bool,
    },
    /// Component `k` of the translation of the floating joint of body `body`, at `q[q..q + 3]`.
    Shift { body: usize, q: usize, k: usize },
    /// Component `k` of the rotation of the quaternion joint of body `body`, quaternion at
    /// `q[q..q + 4]`.
    Turn { body: usize, q: usize, k: usize },
}
/// Unbounded rotational entries into `(−π, π]`.
pub(super) fn wrap(q: &mut [f64], vars: &[Var]) {
    for v in vars {
        if let Var::Scalar {
            q: i, wrap: true, ..
        } = *v
        {
            let x = q[i];
            if x > PI || x <= -PI {
                let y = x - (2.0 * PI) * ((x + PI) / (2.0 * PI)).floor();
                // y in [−π, π): move −π to π.
                q[i] = if y <= -PI { y + 2.0 * PI } else { y };
            }
        }
    }
}
pub(super) fn distance(metric: Distance, q: &[f64], seed: &[f64], vars: &[Var]) -> f64 {
    // The entries of `q` the variables move (a quaternion's w with its first turn), unallocated.
    let entries = vars.iter().flat_map(|v| {
        let (first, second) = match *v {
            Var::Scalar { q: i, .. } => (i, None),
            Var::Shift { q: i, k, .. } => (i + k, None),
            Var::Turn { q: i, k, .. } => (i + k + 1, (k == 0).then_some(i)),
        };
        std::iter::once(first).chain(second)
    });
    let d = entries.map(|i| (q[i] - seed[i]).abs());
    match metric {
        Distance::L2 => d.map(|x| x * x).sum::<f64>().sqrt(),
        Distance::LInf => d.fold(0.0, f64::max),
    }
}

/// The variables the goals depend on (the joints on their links' and base links' paths), not
/// locked, with their column in the full Jacobian, in `q̇` order.
pub(super) fn variables(
    chain: &Chain,
    goals: &[Prepared],
    locked: &[JointId],
) -> Vec<(Var, usize)> {
    let dof = chain.dof();
    let mut used = vec![false; dof];
    for g in goals {
        for link in std::iter::once(g.goal.link).chain(g.goal.base) {
            let mut body = chain.carrier(link).body;
            while let Some(b) = body {
                let bd = &chain.bodies[b];
                if bd.floating {
                    used[..6].fill(true);
                } else if let Some(ball) = bd.ball {
                    let n = if ball.free { 6 } else { 3 };
                    used[ball.v..ball.v + n].fill(true);
                } else {
                    for rate in [bd.theta_rate, bd.d_rate] {
                        if rate.scale != 0.0 {
                            used[rate.index] = true;
                        }
                    }
                }
                body = bd.parent;
            }
        }
    }
    let ranges = chain.admitted_ranges();
    let mut vars = Vec::new();
    for (id, joint) in chain.joints().iter().enumerate() {
        let (Some(q), Some(v)) = (joint.q_index(), joint.v_index()) else {
            continue;
        };
        if locked.iter().any(|l| l.0 == id) {
            continue;
        }
        let body_of = || {
            chain
                .bodies
                .iter()
                .position(|b| (b.floating && q == 0) || b.ball.is_some_and(|ball| ball.q == q))
                .unwrap_or(0)
        };
        match joint.kind() {
            JointKind::Floating => {
                let body = body_of();
                for k in 0..3 {
                    vars.push((Var::Shift { body, q, k }, v + k));
                }
                for k in 0..3 {
                    vars.push((Var::Turn { body, q: q + 3, k }, v + 3 + k));
                }
            }
            JointKind::Ball => {
                let body = body_of();
                for k in 0..3 {
                    vars.push((Var::Turn { body, q, k }, v + k));
                }
            }
            kind => {
                for k in 0..kind.dof() {
                    let (lo, hi) = ranges[q + k];
                    let rotational = matches!(kind, JointKind::Revolute | JointKind::Continuous)
                        || (kind == JointKind::Cylindrical && k == 0);
                    let wrap = rotational && !lo.is_finite() && !hi.is_finite();
                    let around = rotational && (hi - lo).is_finite() && hi - lo >= TAU;
                    vars.push((
                        Var::Scalar {
                            q: q + k,
                            lo,
                            hi,
                            wrap,
                            around,
                        },
                        v + k,
                    ));
                }
            }
        }
    }
    vars.retain(|(_, v)| used[*v]);
    vars
}
