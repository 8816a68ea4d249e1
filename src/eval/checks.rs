//! Checks of joint-space vectors before any kernel runs: length, finiteness and (under
//! [`LimitPolicy::Enforce`]) joint limits, one configuration at a time or a whole batch.

use crate::eval::error::StateError;
use crate::eval::layout::chain::Chain;
use crate::eval::layout::limits::DenseLimits;
use crate::eval::simd::isa::fma_dispatch;
use crate::eval::simd::portable::Separate;
use crate::eval::simd::traits::Arith;

/// Whether evaluation refuses joint values outside the joints' limits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LimitPolicy {
    /// Values outside the limits are an error naming the joint, the value and the limits
    /// (default: a common sign of degrees passed as radians).
    #[default]
    Enforce,
    /// Evaluate any finite value.
    Ignore,
}

/// Panics, naming both sides, unless buffers of type `what` made for a chain of `bodies` moving
/// joints and `dof` entries were made for one of `chain`'s shape.
#[inline]
pub(crate) fn assert_buffers_match(what: &str, bodies: usize, dof: usize, chain: &Chain) {
    assert!(
        bodies == chain.bodies.len() && dof == chain.nq(),
        "kinechain: {what} was created for another chain ({bodies} moving joints, dof {dof}), not '{}' ({} moving joints, dof {})",
        chain.name(),
        chain.bodies.len(),
        chain.nq()
    );
}

/// The error for a vector `what` of `got` entries where the chain takes `expected`.
pub(crate) fn wrong_length(
    chain: &Chain,
    what: &'static str,
    expected: usize,
    got: usize,
) -> StateError {
    if chain.quaternions().is_empty() {
        return StateError::WrongLength {
            what,
            expected,
            got,
        };
    }
    let parts = chain
        .quaternions()
        .iter()
        .map(|&(j, _)| {
            let joint = chain.joint(j);
            let n = if what == "q" {
                joint.kind().nq()
            } else {
                joint.kind().dof()
            };
            (joint.name().to_string(), n, joint.kind().as_str())
        })
        .collect();
    StateError::WrongLengthParts {
        what,
        expected,
        got,
        parts,
    }
}

/// Checks length and finiteness of a joint-space vector: `q` (of [`Model::nq`](crate::Model::nq)
/// entries, a floating joint's quaternion near unit length), or a rate `q_dot` or `q_ddot`
/// ([`Model::nv`](crate::Model::nv)).
pub(crate) fn check_values(
    chain: &Chain,
    values: &[f64],
    what: &'static str,
) -> Result<(), StateError> {
    let is_q = what == "q";
    let expected = if is_q { chain.nq() } else { chain.nv() };
    if values.len() != expected {
        return Err(wrong_length(chain, what, expected, values.len()));
    }
    // Branch-free, two operations per entry: `x · 0` is ±0 for a finite `x` and NaN for ±∞ or
    // NaN, so the sum is 0 exactly when every entry is finite. The entry at fault is looked for
    // only on failure.
    if values.iter().fold(0.0, |sum, x| sum + x * 0.0) != 0.0
        && let Some(index) = values.iter().position(|x| !x.is_finite())
    {
        let (joint, component) = if is_q {
            chain.variable(index)
        } else {
            chain.velocity_variable(index)
        };
        return Err(StateError::NonFinite {
            what,
            index,
            joint: chain.joints()[joint].name().to_string(),
            component,
            value: values[index],
        });
    }
    if is_q {
        check_quaternion(chain, values)?;
    }
    Ok(())
}

/// Each floating or ball joint's quaternion (finite) near unit length. (Inlined up to the test
/// for none, the common case: the loop of the others is out of line.)
#[inline]
pub(crate) fn check_quaternion(chain: &Chain, q: &[f64]) -> Result<(), StateError> {
    match chain.quaternions() {
        [] => Ok(()),
        quaternions => check_quaternions(chain, quaternions, q),
    }
}

#[inline(never)]
fn check_quaternions(
    chain: &Chain,
    quaternions: &[(crate::model::chain::JointId, usize)],
    q: &[f64],
) -> Result<(), StateError> {
    for &(j, first) in quaternions {
        let e = &q[first..first + 4];
        if !crate::eval::kernel::floating::admits(e) {
            return Err(StateError::BadQuaternion {
                joint: chain.joint(j).name().to_string(),
                kind: chain.joint(j).kind().as_str(),
                first,
                norm: e.iter().map(|x| x * x).sum::<f64>().sqrt(),
                tolerance: crate::eval::kernel::floating::QUATERNION_TOLERANCE,
            });
        }
    }
    Ok(())
}

/// See [`all_valid`]; `A` only selects the target features it is compiled with.
#[inline(always)]
fn all_valid_generic<A: Arith>(chain: &Chain, qs: &[f64], policy: LimitPolicy) -> bool {
    // Plain loops: an iterator adapter's closure is not always inlined into the target-feature
    // function, and would then run as baseline code.
    let mut finite = true;
    for x in qs {
        finite &= x.is_finite();
    }
    finite
        && (policy == LimitPolicy::Ignore
            || qs
                .chunks_exact(chain.nq())
                .all(|q| chain.limit_checks.iter().all(|c| c.admits(q))))
        && (chain.quaternions().is_empty()
            || qs.chunks_exact(chain.nq()).all(|q| {
                chain
                    .quaternions()
                    .iter()
                    .all(|&(_, i)| crate::eval::kernel::floating::admits(&q[i..i + 4]))
            }))
}

/// Checks `q` (length, finiteness, and limits under [`LimitPolicy::Enforce`]).
///
/// # Errors
/// [`StateError`] naming the first entry at fault.
pub fn check_q(chain: &Chain, q: &[f64], policy: LimitPolicy) -> Result<(), StateError> {
    // One branch-free pass when the checks fit one per entry; the entry at fault is looked for
    // only on failure.
    if let (Some(limits), LimitPolicy::Enforce, true) =
        (&chain.dense_limits, policy, q.len() == chain.nq())
        && admitted::<Separate>(q, Some(limits))
        && check_quaternion(chain, q).is_ok()
    {
        return Ok(());
    }
    check_values(chain, q, "q")?;
    if policy == LimitPolicy::Enforce {
        for c in &chain.limit_checks {
            let value = c.value(q[c.index]);
            if !c.limits.contains(value) {
                return Err(StateError::OutOfLimits {
                    joint: chain.joints()[c.joint].name().to_string(),
                    component: c.component,
                    angular: c.angular,
                    value,
                    lower: c.limits.lower,
                    upper: c.limits.upper,
                });
            }
        }
    }
    Ok(())
}

/// [`check_q`] on the entries of `q` that `reads` lists (a one-link evaluation's): its length,
/// then those entries finite, the quaternions among them near unit length, and under
/// [`LimitPolicy::Enforce`] the limit checks on them. All of [`check_q`] when they are all of
/// `q`.
pub(crate) fn check_q_entries(
    chain: &Chain,
    q: &[f64],
    reads: &crate::eval::layout::chain::PathReads,
    policy: LimitPolicy,
) -> Result<(), StateError> {
    if reads.all {
        return check_q(chain, q, policy);
    }
    if q.len() != chain.nq() {
        return Err(wrong_length(chain, "q", chain.nq(), q.len()));
    }
    if let Some(&index) = reads.entries.iter().find(|&&i| !q[i].is_finite()) {
        let (joint, component) = chain.variable(index);
        return Err(StateError::NonFinite {
            what: "q",
            index,
            joint: chain.joints()[joint].name().to_string(),
            component,
            value: q[index],
        });
    }
    check_quaternions(chain, &reads.quaternions, q)?;
    if policy == LimitPolicy::Enforce {
        for c in &chain.limit_checks {
            let value = c.value(q[c.index]);
            if reads.entries.binary_search(&c.index).is_ok() && !c.limits.contains(value) {
                return Err(StateError::OutOfLimits {
                    joint: chain.joints()[c.joint].name().to_string(),
                    component: c.component,
                    angular: c.angular,
                    value,
                    lower: c.limits.lower,
                    upper: c.limits.upper,
                });
            }
        }
    }
    Ok(())
}

/// Whether `q` (of the chain's length) passes the check `single::kinematics::kernel_check`
/// chose: finiteness, or [`within`](crate::eval::simd::traits::within) the limits of each entry.
/// Four entries per vector compare on the AVX paths (a loop over single entries stays scalar,
/// about 40 instructions more on a seven-joint arm), each against one contiguous block of limit
/// columns.
#[inline(always)]
pub(crate) fn admitted<A: Arith>(q: &[f64], limits: Option<&DenseLimits>) -> bool {
    match limits {
        // Another length is not decided here (`check_q` decides).
        Some(limits) if limits.blocks().len() != q.len().div_ceil(4) => false,
        Some(limits) => admitted_rows::<A>(q, limits.blocks().iter()),
        None => admitted_rows::<A>(q, std::iter::repeat(&DenseLimits::FREE)),
    }
}

/// Whether the span of `q` that `reads` gives passes [`admitted`]'s check (against its columns
/// `reads.columns` when `limits`, else for finiteness), in vectors, and the quaternions in it are
/// near unit length.
#[inline(always)]
pub(crate) fn admitted_entries<A: Arith>(
    q: &[f64],
    reads: &crate::eval::layout::chain::PathReads,
    limits: bool,
) -> bool {
    let span = match (reads.entries.first(), reads.entries.last()) {
        (Some(&first), Some(&last)) => &q[first..=last],
        _ => &[],
    };
    let admitted = match limits {
        true => admitted_rows::<A>(span, reads.columns.iter()),
        false => admitted_rows::<A>(span, std::iter::repeat(&DenseLimits::FREE)),
    };
    admitted
        && reads
            .quaternions
            .iter()
            .all(|&(_, i)| crate::eval::kernel::floating::admits(&q[i..i + 4]))
}

/// [`admitted`] with the limit columns of each block of four entries of `q` from `columns`,
/// which has one block for each (the last one for the completed rest).
#[inline(always)]
fn admitted_rows<'c, A: Arith>(
    q: &[f64],
    mut columns: impl Iterator<Item = &'c [[f64; 4]; 4]>,
) -> bool {
    let (blocks, rest) = q.as_chunks::<4>();
    let mut ok = true;
    for (x, c) in blocks.iter().zip(&mut columns) {
        ok &= admitted_block::<A>(x, c);
    }
    if !rest.is_empty() {
        ok &= match columns.next() {
            Some(c) => admitted_block::<A>(&completed(rest), c),
            None => false,
        };
    }
    ok
}

/// The last (one to three) entries of `q` completed with zeros, which the padding of the limit
/// columns admits (entry by entry: a copy of variable length would be a library call).
#[inline(always)]
fn completed(rest: &[f64]) -> [f64; 4] {
    let entry = |i: usize| rest.get(i).copied().unwrap_or(0.0);
    [entry(0), entry(1), entry(2), 0.0]
}

/// [`admitted`] for four entries `x` of `q` against their columns `[scale, offset, lower,
/// upper]`.
#[inline(always)]
fn admitted_block<A: Arith>(x: &[f64; 4], [s, o, l, u]: &[[f64; 4]; 4]) -> bool {
    use crate::eval::simd::traits::Col;
    type C<A> = <A as Arith>::Col;
    let columns = [
        C::<A>::load(s),
        C::<A>::load(o),
        C::<A>::load(l),
        C::<A>::load(u),
    ];
    C::<A>::admitted(C::<A>::load(x), columns)
}

fma_dispatch!(
    /// True when every entry of `qs` (whole configurations of `chain`) is finite and, under
    /// [`LimitPolicy::Enforce`], within its joint's limits: what [`check_q`] accepts, decided for
    /// a batch whose limits the kernels cannot check on their lanes (no
    /// [`Chain::dense_limits`](crate::Chain)), in a finiteness pass that vectorises.
    pub(crate) fn all_valid(chain: &Chain, qs: &[f64], policy: LimitPolicy) -> bool => all_valid_generic
);
